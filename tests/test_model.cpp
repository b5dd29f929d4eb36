// Distributed model: DOF numbering, assembly, mass, rigid-body modes, patch test and the
// cantilever frequencies against closed forms (Euler–Bernoulli bending, axial rod, Saint-Venant
// torsion).
#include <gtest/gtest.h>

#include <cmath>

#include "morse/cb/craig_bampton.hpp"
#include "morse/core/session.hpp"
#include "morse/fe/element.hpp"
#include "util.hpp"

using namespace morse;
using mesh::ElementType;

namespace {

constexpr ElementType kAllTypes[] = {ElementType::Tet4,    ElementType::Tet10, ElementType::Wedge6,
                                     ElementType::Wedge15, ElementType::Hex8,  ElementType::Hex20};

std::string name(ElementType t) { return mesh::element_name(t); }

}  // namespace

TEST(Model, DofNumberingIsContiguousAndComplete) {
  mesh::BoxSpec b;
  b.type = ElementType::Hex20;
  b.nx = 6;
  b.ny = 2;
  b.nz = 1;
  auto lm = test::box_mesh(PETSC_COMM_WORLD, b);
  auto dofs = fe::number_dofs(lm, {"x0"});
  EXPECT_EQ(dofs.n_global + dofs.n_clamped_global, 3 * lm.n_global_nodes);
  EXPECT_EQ(dofs.n_clamped_global, 3 * lm.node_set_sizes.at("x0"));
  // Every local node (owned or ghost) has its DOFs, clamped ones -1, others in range.
  int bad = 0;
  for (std::int64_t k = 0; k < lm.mesh.num_nodes(); ++k)
    for (int d = 0; d < 3; ++d) {
      PetscInt g = dofs.node_dof[3 * k + d];
      bool clamped = std::binary_search(lm.mesh.node_sets.at("x0").begin(), lm.mesh.node_sets.at("x0").end(), k);
      if (clamped != (g < 0) || g >= dofs.n_global) ++bad;
    }
  EXPECT_FALSE(any_rank(PETSC_COMM_WORLD, bad != 0));
}

TEST(Model, MissingSetIsACollectiveError) {
  mesh::BoxSpec b;
  b.nx = 2;
  auto lm = test::box_mesh(PETSC_COMM_WORLD, b);
  try {
    fe::number_dofs(lm, {"nosuchset"});
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("nosuchset"), std::string::npos) << e.what();
  }
}

// A node set given by external ids (-mesh_node_sets): it holds exactly the local nodes with those
// ids, its global size counts each id once, clamping it removes 3 DOFs per node, and an unknown
// id or a taken name is a collective error naming the id or the set.
TEST(Model, NodeSetFromIds) {
  mesh::BoxSpec b;
  b.nx = 3;
  auto lm = test::box_mesh(PETSC_COMM_WORLD, b);
  auto all = fe::number_dofs(lm, {});
  // Ids of the x0 face, gathered from every rank.
  std::vector<std::int64_t> ids;
  for (auto k : lm.mesh.node_sets.at("x0")) ids.push_back(lm.mesh.node_ids[k]);
  int n = static_cast<int>(ids.size()), size = 1;
  MPI_Comm_size(PETSC_COMM_WORLD, &size);
  std::vector<int> counts(size), displs(size, 0);
  MPI_Allgather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, PETSC_COMM_WORLD);
  for (int i = 1; i < size; ++i) displs[i] = displs[i - 1] + counts[i - 1];
  std::vector<std::int64_t> every(displs.back() + counts.back());
  MPI_Allgatherv(ids.data(), n, MPI_INT64_T, every.data(), counts.data(), displs.data(), MPI_INT64_T, PETSC_COMM_WORLD);
  every.push_back(every.front());  // a duplicate counts once
  mesh::add_node_set(&lm, "face", every, "-mesh_node_set_face");
  EXPECT_EQ(lm.node_set_sizes.at("face"), lm.node_set_sizes.at("x0"));
  EXPECT_EQ(lm.mesh.node_sets.at("face"), lm.mesh.node_sets.at("x0"));
  auto dofs = fe::number_dofs(lm, {"face"});
  EXPECT_EQ(all.n_global - dofs.n_global, 3 * lm.node_set_sizes.at("x0"));
  auto expect_error = [&](const std::string& name, std::vector<std::int64_t> v, const std::string& needle) {
    try {
      mesh::add_node_set(&lm, name, v, "-mesh_node_set_" + name);
      ADD_FAILURE() << "no error for set " << name;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  expect_error("bad", {every.front(), 987654321}, "987654321");
  expect_error("face", {every.front()}, "already exists");
  EXPECT_EQ(lm.mesh.node_sets.count("bad"), 0u);
}

// The layout of a mesh model labels every owned row by its node id and component 1..3 (the
// inverse of node_dof), and holds every node set as a row set of its free rows: fe::set_rows
// gives the set's rows on every rank by (node id, component), as the boundary of a superelement.
TEST(Model, LayoutLabelsAndRowSets) {
  mesh::BoxSpec b;
  b.nx = 3;
  auto lm = test::box_mesh(PETSC_COMM_WORLD, b);
  auto dofs = fe::number_dofs(lm, {"x0"});
  int rank = 0;
  MPI_Comm_rank(PETSC_COMM_WORLD, &rank);
  ASSERT_EQ(dofs.node.size(), static_cast<std::size_t>(dofs.n_owned));
  ASSERT_EQ(dofs.component.size(), static_cast<std::size_t>(dofs.n_owned));
  for (std::int64_t k = 0; k < lm.mesh.num_nodes(); ++k) {
    if (lm.node_owner[k] != rank) continue;
    for (int d = 0; d < 3; ++d) {
      const PetscInt g = dofs.node_dof[3 * k + d];
      if (g < 0) continue;
      EXPECT_EQ(dofs.node[g - dofs.first], lm.mesh.node_ids[k]);
      EXPECT_EQ(dofs.component[g - dofs.first], d + 1);
    }
  }
  for (const auto& [name, nodes] : lm.mesh.node_sets) ASSERT_EQ(dofs.sets.count(name), 1u) << name;
  EXPECT_TRUE(dofs.sets.at("x0").empty());  // clamped: no free row
  auto rows = fe::set_rows(dofs, "x1", "boundary set");
  ASSERT_EQ(static_cast<std::int64_t>(rows.size()), 3 * lm.node_set_sizes.at("x1"));
  for (std::size_t i = 0; i < rows.size(); ++i) {
    EXPECT_EQ(rows[i].component, static_cast<int>(i % 3) + 1);
    if (i > 0) {
      EXPECT_TRUE(rows[i - 1].node < rows[i].node || (rows[i - 1].node == rows[i].node && i % 3 != 0));
    }
  }
  for (const auto& [set, needle] : {std::pair<std::string, std::string>{"nosuchset", "sets: "}, {"x0", "is empty"}})
    try {
      fe::set_rows(dofs, set, "boundary set");
      ADD_FAILURE() << "no error for set " << set;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
}

class ModelByType : public ::testing::TestWithParam<ElementType> {};

// Total translational mass: 1^T M_x 1 = rho V for a distorted box, to round-off.
TEST_P(ModelByType, MassEqualsRhoV) {
  mesh::BoxSpec b;
  b.type = GetParam();
  b.lx = 0.7;
  b.ly = 0.3;
  b.lz = 0.2;
  b.nx = 4;
  b.ny = 3;
  b.nz = 2;
  b.distortion = 0.2;
  auto lm = test::box_mesh(PETSC_COMM_WORLD, b);
  auto dofs = fe::number_dofs(lm, {});
  auto ops = fe::assemble(lm, dofs, test::steel());
  const double V = b.lx * b.ly * b.lz, rho = test::steel().rho;
  EXPECT_NEAR(ops.volume, V, 1e-13 * V);
  for (int d = 0; d < 3; ++d) {
    auto e = test::nodal_vector(lm, dofs, [d](double, double, double, int c) { return c == d ? 1.0 : 0.0; });
    UVec Me;
    MORSE_CALL(VecDuplicate(e.get(), Me.ptr()));
    MORSE_CALL(MatMult(ops.M.get(), e.get(), Me.get()));
    PetscScalar m;
    MORSE_CALL(VecDot(e.get(), Me.get(), &m));
    EXPECT_NEAR(m, rho * V, 1e-12 * rho * V) << name(GetParam()) << " direction " << d;
  }
}

// A free-free solid has exactly six rigid-body modes.
TEST_P(ModelByType, FreeFreeHasSixRigidBodyModes) {
  mesh::BoxSpec b;
  b.type = GetParam();
  b.lx = 1.0;
  b.ly = 0.4;
  b.lz = 0.25;
  b.nx = 4;
  b.ny = 2;
  b.nz = 2;
  b.distortion = 0.15;
  auto lm = test::box_mesh(PETSC_COMM_WORLD, b);
  auto dofs = fe::number_dofs(lm, {});
  auto ops = fe::assemble(lm, dofs, test::steel());
  eigen::EigenSettings es;
  es.nev = 8;
  es.shift = -1e3;  // K is singular: shift away from the rigid-body eigenvalue 0
  es.prefix = "test_ff_";
  auto eig = eigen::solve_eigen(ops.K.get(), ops.M.get(), es, nullptr);
  const double first_elastic = eig.omega2[6];
  EXPECT_GT(first_elastic, 1e3) << name(GetParam());
  for (int i = 0; i < 6; ++i)
    EXPECT_LT(std::abs(eig.omega2[i]), 1e-8 * first_elastic) << name(GetParam()) << " mode " << i;
}

// Constant-strain patch test on a distorted mesh: prescribe u = A x + c on the box faces; the
// solution inside must be the same linear field, to round-off.
TEST_P(ModelByType, PatchTestDistorted) {
  mesh::BoxSpec b;
  b.type = GetParam();
  b.lx = 1.0;
  b.ly = 0.8;
  b.lz = 0.6;
  b.nx = 3;
  b.ny = 3;
  b.nz = 3;
  b.distortion = 0.25;
  auto lm = test::box_mesh(PETSC_COMM_WORLD, b);
  auto dofs = fe::number_dofs(lm, {});
  auto ops = fe::assemble(lm, dofs, test::steel());
  const double A[3][3] = {{1e-3, 2e-4, -3e-4}, {5e-4, -7e-4, 1e-4}, {-2e-4, 3e-4, 4e-4}};
  const double c[3] = {1e-3, -2e-3, 5e-4};
  auto exact = test::nodal_vector(
      lm, dofs, [&](double x, double y, double z, int d) { return A[d][0] * x + A[d][1] * y + A[d][2] * z + c[d]; });
  // Boundary = nodes on any face.
  std::vector<PetscInt> bnd, inn;
  int rank = 0;
  MPI_Comm_rank(lm.comm, &rank);
  std::vector<char> on_face(lm.mesh.num_nodes(), 0);
  for (const char* f : {"x0", "x1", "y0", "y1", "z0", "z1"})
    for (auto k : lm.mesh.node_sets.at(f)) on_face[k] = 1;
  for (std::int64_t k = 0; k < lm.mesh.num_nodes(); ++k)
    if (lm.node_owner[k] == rank)
      for (int d = 0; d < 3; ++d) (on_face[k] ? bnd : inn).push_back(dofs.node_dof[3 * k + d]);
  std::sort(bnd.begin(), bnd.end());
  std::sort(inn.begin(), inn.end());
  UIS isb, isi;
  MORSE_CALL(ISCreateGeneral(lm.comm, (PetscInt)bnd.size(), bnd.data(), PETSC_COPY_VALUES, isb.ptr()));
  MORSE_CALL(ISCreateGeneral(lm.comm, (PetscInt)inn.size(), inn.data(), PETSC_COPY_VALUES, isi.ptr()));
  UMat Kii, Kib;
  MORSE_CALL(MatCreateSubMatrix(ops.K.get(), isi.get(), isi.get(), MAT_INITIAL_MATRIX, Kii.ptr()));
  MORSE_CALL(MatCreateSubMatrix(ops.K.get(), isi.get(), isb.get(), MAT_INITIAL_MATRIX, Kib.ptr()));
  Vec ub, ui_exact;
  MORSE_CALL(VecGetSubVector(exact.get(), isb.get(), &ub));
  MORSE_CALL(VecGetSubVector(exact.get(), isi.get(), &ui_exact));
  UVec rhs, ui;
  MORSE_CALL(MatCreateVecs(Kii.get(), ui.ptr(), rhs.ptr()));
  MORSE_CALL(MatMult(Kib.get(), ub, rhs.get()));
  MORSE_CALL(VecScale(rhs.get(), -1.0));
  test::direct_solve(Kii.get(), rhs.get(), ui.get());
  PetscReal ref, err;
  MORSE_CALL(VecNorm(ui_exact, NORM_INFINITY, &ref));
  MORSE_CALL(VecAXPY(ui.get(), -1.0, ui_exact));
  MORSE_CALL(VecNorm(ui.get(), NORM_INFINITY, &err));
  MORSE_CALL(VecRestoreSubVector(exact.get(), isb.get(), &ub));
  MORSE_CALL(VecRestoreSubVector(exact.get(), isi.get(), &ui_exact));
  EXPECT_LT(err, 1e-10 * ref) << name(GetParam());
}

INSTANTIATE_TEST_SUITE_P(AllTypes, ModelByType, ::testing::ValuesIn(kAllTypes),
                         [](const auto& info) { return std::string(mesh::element_name(info.param)); });

// --------------------------------------------------------------------------- cantilever
namespace {

// Saint-Venant torsion constant of an a x b rectangle (a >= b), series solution.
double torsion_constant(double a, double b) {
  double s = 0;
  for (int n = 1; n < 200; n += 2) s += std::tanh(n * M_PI * a / (2 * b)) / std::pow(n, 5);
  return a * b * b * b / 3.0 * (1.0 - 192.0 / std::pow(M_PI, 5) * (b / a) * s);
}

}  // namespace

class Cantilever : public ::testing::TestWithParam<ElementType> {};

// A slender clamped-free bar (L/h = 50). Each analytic mode shape is matched to the computed
// mode of highest MAC, whose frequency must be within 1% of the closed form.
TEST_P(Cantilever, FrequenciesMatchClosedForms) {
  const double L = 1.0, by = 0.03, hz = 0.02;  // bending in z is the weak direction
  mesh::BoxSpec b;
  b.type = GetParam();
  b.lx = L;
  b.ly = by;
  b.lz = hz;
  b.nx = 40;
  b.ny = 3;
  b.nz = 2;
  if (b.type == ElementType::Tet10) {  // stiffer in torsion: refine the cross-section
    b.ny = 4;
    b.nz = 3;
  }
  auto lm = test::box_mesh(PETSC_COMM_WORLD, b);
  auto dofs = fe::number_dofs(lm, {"x0"});
  const auto mat = test::steel();
  auto ops = fe::assemble(lm, dofs, mat);
  eigen::EigenSettings es;
  es.nev = 14;
  es.prefix = "test_cant_";
  auto eig = eigen::solve_eigen(ops.K.get(), ops.M.get(), es, nullptr);

  const double A = by * hz, Iy = by * hz * hz * hz / 12.0, E = mat.E, rho = mat.rho;
  const double G = E / (2 * (1 + mat.nu));
  const double beta[3] = {1.8751040687119611, 4.6940911329741745, 7.8547574382376126};
  struct Case {
    std::string what;
    double omega;
    std::function<double(double, double, double, int)> shape;
  };
  std::vector<Case> cases;
  for (int n = 0; n < 3; ++n) {
    double bl = beta[n];
    double sigma = (std::cosh(bl) + std::cos(bl)) / (std::sinh(bl) + std::sin(bl));
    cases.push_back({"bending " + std::to_string(n + 1), bl * bl / (L * L) * std::sqrt(E * Iy / (rho * A)),
                     [=](double x, double, double, int d) {
                       double s = bl * x / L;
                       return d == 2 ? std::cosh(s) - std::cos(s) - sigma * (std::sinh(s) - std::sin(s)) : 0.0;
                     }});
  }
  cases.push_back({"axial", M_PI / (2 * L) * std::sqrt(E / rho),
                   [=](double x, double, double, int d) { return d == 0 ? std::sin(M_PI * x / (2 * L)) : 0.0; }});
  const double J = torsion_constant(by, hz), Ip = (by * hz * hz * hz + hz * by * by * by) / 12.0;
  cases.push_back({"torsion", M_PI / (2 * L) * std::sqrt(G * J / (rho * Ip)), [=](double x, double y, double z, int d) {
                     double th = std::sin(M_PI * x / (2 * L));
                     return d == 1 ? -th * (z - hz / 2) : d == 2 ? th * (y - by / 2) : 0.0;
                   }});
  for (const auto& c : cases) {
    auto ref = test::nodal_vector(lm, dofs, c.shape);
    double best = 0;
    int best_i = -1;
    for (int i = 0; i < (int)eig.omega2.size(); ++i) {
      Vec v;
      MORSE_CALL(MatDenseGetColumnVecRead(eig.V.get(), i, &v));
      double m = test::mac(ops.M.get(), ref.get(), v);
      MORSE_CALL(MatDenseRestoreColumnVecRead(eig.V.get(), i, &v));
      if (m > best) best = m, best_i = i;
    }
    ASSERT_GE(best_i, 0);
    const double omega = std::sqrt(eig.omega2[best_i]);
    EXPECT_GT(best, 0.9) << name(GetParam()) << " " << c.what;
    EXPECT_NEAR(omega / c.omega, 1.0, 0.01) << name(GetParam()) << " " << c.what << ": " << omega << " vs " << c.omega
                                            << " rad/s (mode " << best_i + 1 << ", MAC " << best << ")";
  }
}

INSTANTIATE_TEST_SUITE_P(Quadratic, Cantilever,
                         ::testing::Values(ElementType::Tet10, ElementType::Wedge15, ElementType::Hex20),
                         [](const auto& info) { return std::string(mesh::element_name(info.param)); });

// Material per element set (-material_sets): the total mass follows the densities of the sets.
TEST(Model, MaterialPerElementSet) {
  mesh::BoxSpec b;
  b.type = ElementType::Hex8;
  b.lx = 1.0;
  b.ly = 0.2;
  b.lz = 0.1;
  b.nx = 4;
  mesh::Mesh serial;
  if (world_rank() == 0) {
    serial = mesh::generate_box(b);
    serial.elem_sets["left"] = {0, 1};  // two of the four cells
  }
  auto lm = mesh::distribute(PETSC_COMM_WORLD, &serial);
  mesh::Material alu{"left", 7e10, 0.33, 2700.0};
  mesh::assign_set_material(&lm.mesh, alu);
  EXPECT_THROW(mesh::assign_set_material(&lm.mesh, mesh::Material{"nope", 1, 0.3, 1}), Error);
  auto dofs = fe::number_dofs(lm, {});
  auto ops = fe::assemble(lm, dofs, test::steel());
  const double V = b.lx * b.ly * b.lz;
  EXPECT_NEAR(ops.mass, 0.5 * V * 2700.0 + 0.5 * V * 7800.0, 1e-10 * ops.mass);
}

TEST(MeshQuality, BoxCountsVolumeAndNoInvertedElement) {
  auto lm = morse::test::box_mesh(PETSC_COMM_WORLD,
                                  morse::test::box_spec(morse::mesh::ElementType::Tet4, 2.0, 0.5, 0.25, 4, 2, 1));
  const auto q = morse::fe::mesh_quality(PETSC_COMM_WORLD, lm);
  EXPECT_EQ(q.per_type[static_cast<int>(morse::mesh::ElementType::Tet4)], 6 * 4 * 2 * 1);
  EXPECT_NEAR(q.volume, 2.0 * 0.5 * 0.25, 1e-12);
  EXPECT_GT(q.min_jacobian, 0);
  EXPECT_GE(q.worst_element, 0);
  EXPECT_EQ(q.n_inverted, 0);
  EXPECT_EQ(q.n_fixed_nodes, 0);
}
