// The Nastran bulk data path against the other readers, at the level of the operators: the same
// geometry written as Gmsh, Abaqus (.inp) and Nastran (.bdf) gives the same K and M (to
// round-off) and the same frequencies, for every element type, so that the node orders of the
// quadratic elements are verified against two independent conventions; the deck's SPC1 clamp
// equals -clamp of the node set; CONM2 point masses add exactly their mass to the model (rigid
// translation identity) and lower the frequencies as a closed form predicts.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "morse/core/session.hpp"
#include "morse/eigen/eigen.hpp"
#include "morse/fe/element.hpp"
#include "morse/mesh/gmsh.hpp"
#include "morse/mesh/nastran.hpp"
#include "scratch.hpp"
#include "util.hpp"

using namespace morse;
using mesh::ElementType;

namespace {

namespace fs = std::filesystem;

// Abaqus node order of the quadratic elements, as vertex pairs of the mid-edge nodes (Abaqus
// Analysis User's Guide, "three-dimensional solid element library"), independent of the Nastran
// reader's tables.
std::vector<std::pair<int, int>> abaqus_mid_edges(ElementType t) {
  switch (t) {
    case ElementType::Tet10:
      return {{0, 1}, {1, 2}, {2, 0}, {0, 3}, {1, 3}, {2, 3}};
    case ElementType::Wedge15:
      return {{0, 1}, {1, 2}, {2, 0}, {3, 4}, {4, 5}, {5, 3}, {0, 3}, {1, 4}, {2, 5}};
    case ElementType::Hex20:
      return {{0, 1}, {1, 2}, {2, 3}, {3, 0}, {4, 5}, {5, 6}, {6, 7}, {7, 4}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};
    default:
      return {};
  }
}

const char* abaqus_type(ElementType t) {
  switch (t) {
    case ElementType::Tet4:
      return "C3D4";
    case ElementType::Tet10:
      return "C3D10";
    case ElementType::Wedge6:
      return "C3D6";
    case ElementType::Wedge15:
      return "C3D15";
    case ElementType::Hex8:
      return "C3D8";
    default:
      return "C3D20";
  }
}

// Writes m (one element type, one material) as an Abaqus deck with *BOUNDARY on node set `clamp`.
void write_inp(const mesh::Mesh& m, const std::string& path, const std::string& clamp) {
  std::ofstream f(path);
  f.precision(17);
  f << "*NODE\n";
  for (std::int64_t k = 0; k < m.num_nodes(); ++k)
    f << m.node_ids[k] << ", " << m.coords[3 * k] << ", " << m.coords[3 * k + 1] << ", " << m.coords[3 * k + 2] << "\n";
  const auto t = m.elem_types[0];
  const auto perm = mesh::foreign_to_morse(t, abaqus_mid_edges(t));  // Abaqus position -> morse index
  f << "*ELEMENT, TYPE=" << abaqus_type(t) << ", ELSET=SOLID\n";
  for (std::int64_t e = 0; e < m.num_elements(); ++e) {
    f << m.elem_ids[e];
    const auto* n = &m.elem_nodes[m.elem_offsets[e]];
    for (std::size_t i = 0; i < perm.size(); ++i) f << ",\n"[0] << " " << m.node_ids[n[perm[i]]];
    f << "\n";
  }
  f << "*NSET, NSET=FIXED\n";
  for (auto k : m.node_sets.at(clamp)) f << m.node_ids[k] << ",\n";
  const auto& mat = m.materials[0];
  f << "*MATERIAL, NAME=STEEL\n*ELASTIC\n" << mat.E << ", " << mat.nu << "\n*DENSITY\n" << mat.rho << "\n";
  f << "*SOLID SECTION, ELSET=SOLID, MATERIAL=STEEL\n*BOUNDARY\nFIXED, 1, 3\n";
}

struct Assembled {
  mesh::LocalMesh lm;
  fe::DofLayout dofs;
  fe::Operators ops;
};

Assembled assemble(const std::string& path, const std::vector<std::string>& clamp) {
  Assembled a;
  a.lm = mesh::read_and_distribute(PETSC_COMM_WORLD, path);
  a.dofs = fe::number_dofs(a.lm, clamp);
  a.ops = fe::assemble(a.lm, a.dofs, test::steel());
  return a;
}

double rel_diff(Mat A, Mat B) {
  UMat D;
  MORSE_CALL(MatDuplicate(A, MAT_COPY_VALUES, D.ptr()));
  MORSE_CALL(MatAXPY(D.get(), -1.0, B, DIFFERENT_NONZERO_PATTERN));
  PetscReal d = 0, a = 0;
  MORSE_CALL(MatNorm(D.get(), NORM_FROBENIUS, &d));
  MORSE_CALL(MatNorm(A, NORM_FROBENIUS, &a));
  return d / a;
}

std::vector<double> lowest(const Assembled& a, PetscInt n) {
  eigen::EigenSettings es;
  es.nev = n;
  es.prefix = "test_";
  auto w = cb::sign_reference(test::model_of(a.lm, a.dofs, a.ops));
  return eigen::solve_eigen(a.ops.K.get(), a.ops.M.get(), es, w.get()).omega2;
}

}  // namespace

// Gmsh, Abaqus and Nastran (free and large field) files of one distorted cantilever give the
// same operators and frequencies, for each element type.
TEST(NastranModel, SameOperatorsAsGmshAndAbaqus) {
  const test::SharedScratchDir shared("nastran_model_same");
  const std::string dir = shared.dir().string();
  for (auto t : {ElementType::Hex20, ElementType::Tet10, ElementType::Wedge15, ElementType::Hex8, ElementType::Tet4,
                 ElementType::Wedge6}) {
    SCOPED_TRACE(mesh::element_name(t));
    auto spec = test::box_spec(t, 1.0, 0.08, 0.05, 6, 2, 1);
    spec.distortion = 0.1;
    const std::string msh = dir + "/m.msh", inp = dir + "/m.inp", bdf = dir + "/m.bdf", bdfl = dir + "/ml.bdf";
    if (world_rank() == 0) {
      auto m = mesh::generate_box(spec);
      m.materials = {test::steel()};
      m.elem_material.assign(m.num_elements(), 0);
      mesh::write_gmsh(m, msh);
      write_inp(m, inp, "x0");
      m.fixed_dofs.assign(m.num_nodes(), 0);
      for (auto k : m.node_sets.at("x0")) m.fixed_dofs[k] = 7;
      mesh::NastranWriteOptions o;
      o.format = mesh::NastranWriteOptions::Format::Free;
      mesh::write_nastran(m, bdf, o);
      o.format = mesh::NastranWriteOptions::Format::Large;
      mesh::write_nastran(m, bdfl, o);
    }
    MPI_Barrier(PETSC_COMM_WORLD);
    auto g = assemble(msh, {"x0"});
    auto a = assemble(inp, {mesh::kDeckBoundarySet});
    auto n = assemble(bdf, {mesh::kDeckBoundarySet});
    auto nl = assemble(bdfl, {mesh::kDeckBoundarySet});
    ASSERT_EQ(n.dofs.n_global, g.dofs.n_global);
    ASSERT_EQ(a.dofs.n_global, g.dofs.n_global);
    // Same node order and the same deterministic partition: the matrices are comparable entry
    // by entry. Free field is exact; large field rounds some coordinates at ~1e-15.
    EXPECT_LT(rel_diff(g.ops.K.get(), n.ops.K.get()), 1e-14);
    EXPECT_LT(rel_diff(g.ops.M.get(), n.ops.M.get()), 1e-14);
    EXPECT_LT(rel_diff(g.ops.K.get(), a.ops.K.get()), 1e-14);
    EXPECT_LT(rel_diff(g.ops.M.get(), a.ops.M.get()), 1e-14);
    EXPECT_LT(rel_diff(g.ops.K.get(), nl.ops.K.get()), 1e-12);
    EXPECT_NEAR(n.ops.mass, g.ops.mass, 1e-14 * g.ops.mass);
    auto wg = lowest(g, 6), wn = lowest(n, 6), wa = lowest(a, 6);
    for (int k = 0; k < 6; ++k) {
      EXPECT_NEAR(wn[k], wg[k], 1e-10 * wg[k]) << "mode " << k;
      EXPECT_NEAR(wa[k], wg[k], 1e-10 * wg[k]) << "mode " << k;
    }
  }
}

// CONM2: a free box with point masses m_k: u^T M u for a rigid translation u = e_x, e_y, e_z is
// the total mass rho V + sum m_k (an exact identity). Clamped by the deck's SPC1 at x0, the tip
// masses lower the first bending frequency as an Euler-Bernoulli cantilever with a tip mass
// predicts: beta L solves 1 + cos cosh + mu beta L (cos sinh - sin cosh) = 0, mu = m_tip / (rho A L);
// the ratio of the frequencies with and without the mass is compared (1 %: the model error of
// the coarse solid beam mostly cancels in the ratio).
TEST(NastranModel, PointMassesAddTheirMass) {
  const test::SharedScratchDir shared("nastran_model_conm2");
  const std::string dir = shared.dir().string();
  const double L = 1.0, b = 0.08, h = 0.05, rho = 7800;
  auto spec = test::box_spec(ElementType::Hex20, L, b, h, 12, 2, 1);
  const std::string plain = dir + "/p.bdf", heavy = dir + "/h.bdf";
  double added = 0;
  if (world_rank() == 0) {
    auto m = mesh::generate_box(spec);
    m.materials = {test::steel()};
    m.elem_material.assign(m.num_elements(), 0);
    m.fixed_dofs.assign(m.num_nodes(), 0);
    for (auto k : m.node_sets.at("x0")) m.fixed_dofs[k] = 7;
    mesh::write_nastran(m, plain);
    m.point_mass.assign(m.num_nodes(), 0.0);
    for (auto k : m.node_sets.at("x1")) m.point_mass[k] = 0.25, added += 0.25;
    mesh::write_nastran(m, heavy);
  }
  MPI_Bcast(&added, 1, MPI_DOUBLE, 0, PETSC_COMM_WORLD);
  MPI_Barrier(PETSC_COMM_WORLD);
  auto p = assemble(plain, {}), hv = assemble(heavy, {});
  const double rho_v = rho * L * b * h;
  EXPECT_NEAR(p.ops.mass, rho_v, 1e-12 * rho_v);
  EXPECT_NEAR(hv.ops.mass, rho_v + added, 1e-12 * rho_v);
  for (int d = 0; d < 3; ++d) {
    auto u = test::nodal_vector(hv.lm, hv.dofs, [d](double, double, double, int c) { return c == d ? 1.0 : 0.0; });
    UVec Mu;
    MORSE_CALL(VecDuplicate(u.get(), Mu.ptr()));
    MORSE_CALL(MatMult(hv.ops.M.get(), u.get(), Mu.get()));
    PetscScalar m = 0;
    MORSE_CALL(VecDot(u.get(), Mu.get(), &m));
    EXPECT_NEAR(m, rho_v + added, 1e-12 * rho_v) << "direction " << d;
  }
  auto pc = assemble(plain, {mesh::kDeckBoundarySet}), hc = assemble(heavy, {mesh::kDeckBoundarySet});
  const double w_plain = lowest(pc, 1)[0], w_heavy = lowest(hc, 1)[0];
  const double mu = added / rho_v;
  auto f = [mu](double x) {
    return 1 + std::cos(x) * std::cosh(x) + mu * x * (std::cos(x) * std::sinh(x) - std::sin(x) * std::cosh(x));
  };
  auto root = [&](double lo, double hi) {
    for (int it = 0; it < 200; ++it) {
      double mid = 0.5 * (lo + hi);
      ((f(lo) > 0) == (f(mid) > 0) ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
  };
  const double x_heavy = root(0.5, 1.8751040687), x_plain = 1.8751040687119611;
  const double ratio_eb = std::pow(x_heavy / x_plain, 4);  // omega^2 ratio
  EXPECT_NEAR(w_heavy / w_plain, ratio_eb, 0.01 * ratio_eb) << "mu " << mu;
  if (world_rank() == 0)
    std::printf("tip-mass ratio: FE %.6f, Euler-Bernoulli %.6f (mu %.4f)\n", w_heavy / w_plain, ratio_eb, mu);
  EXPECT_LT(w_heavy, w_plain);
}
