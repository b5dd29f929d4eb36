// Rigid elements (RBE2), interpolation elements (RBE3) and linear constraints (MPC) eliminated by
// u = T u_bar (fe/constraints.hpp), against exact references:
//   - two boxes tied face to face by MPCs have the spectrum of the one box they make;
//   - a free box made rigid by an RBE2 has no stiffness and the rigid-body mass matrix of a
//     homogeneous box about the spider's centre (closed form; consistent mass is exact for it);
//   - a force and moment on an RBE3's reference point load the structure exactly as the lever
//     rule's nodal forces F/n + (J^-1 M) x r_i do, and the reference moves as the least-squares
//     fit of its nodes (mean translation, J^-1 sum r_i x u_i);
//   - the St Venant-Kirchhoff forces through T (fe::Svk(Model)): on the tied boxes, the strain
//     energy, nonlinear force, tangent and projected cubic tensors of smooth displacement fields
//     are those of the one box, and a nonlinear static solve (loads T^T f, tangent T^T K_T T)
//     under a large tip load gives the one box's displacement field, and so does the time
//     integration of the full model (dyn::integrate, morse fom's) from rest;
//   - the errors a deck can make (a dependent DOF clamped or dependent twice, a cycle, collinear
//     RBE3 nodes, rotations of solid nodes) are thrown on every rank.
#include <petscsys.h>
#include <gtest/gtest.h>
#include <petscblaslapack.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>

#include "morse/core/error.hpp"
#include "morse/core/log.hpp"
#include "morse/dyn/dyn.hpp"
#include "morse/fe/constraints.hpp"
#include "morse/fe/nonlinear.hpp"
#include "morse/io/h5.hpp"
#include "morse/mesh/partition.hpp"
#include "util.hpp"

using namespace morse;
using mesh::ElementType;

namespace {

int rank_of() {
  int r = 0;
  MPI_Comm_rank(PETSC_COMM_WORLD, &r);
  return r;
}

// Distributes `serial` (significant on rank 0), clamps `clamp`, assembles (steel) and eliminates
// its constraints if it has any. Collective.
fe::Model build(mesh::Mesh serial, const std::vector<std::string>& clamp) {
  fe::Model md;
  md.mesh = mesh::distribute(PETSC_COMM_WORLD, &serial);
  md.dofs = fe::number_dofs(*md.mesh, clamp);
  auto ops = fe::assemble(*md.mesh, md.dofs, test::steel());
  md.K = std::move(ops.K);
  md.M = std::move(ops.M);
  md.mass = ops.mass;
  if (!md.mesh->mesh.constraints.empty()) fe::eliminate_constraints(&md, clamp);
  return md;
}

// Adds box b's nodes (ids + id_offset) and elements (ids + id_offset) to m; its node sets get the
// prefix. Returns the node index offset.
std::int64_t append_box(mesh::Mesh* m, const mesh::BoxSpec& b, std::int64_t id_offset, const std::string& prefix) {
  const auto box = mesh::generate_box(b);
  const auto base = m->num_nodes();
  for (std::int64_t k = 0; k < box.num_nodes(); ++k)
    m->add_node(box.node_ids[k] + id_offset, box.coords[3 * k], box.coords[3 * k + 1], box.coords[3 * k + 2]);
  for (std::int64_t e = 0; e < box.num_elements(); ++e) {
    std::vector<std::int64_t> nodes(box.elem_nodes.begin() + box.elem_offsets[e],
                                    box.elem_nodes.begin() + box.elem_offsets[e + 1]);
    for (auto& k : nodes) k += base;
    m->add_element(box.elem_ids[e] + id_offset, box.elem_types[e], nodes.data());
  }
  for (const auto& [name, v] : box.node_sets) {
    auto& s = m->node_sets[prefix + name];
    for (auto k : v) s.push_back(k + base);
  }
  m->source = "test boxes";
  return base;
}

std::string thrown(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

}  // namespace

namespace {
// [0, 0.5] and [0.5, 1] (5 + 5 cells) tied node to node on x = 0.5 by 27 MPCs u_B = u_A, clamped
// at x = 0; and the box [0, 1] (10 cells) they make, clamped at x = 0. Collective.
std::pair<fe::Model, fe::Model> tied_and_one_box() {
  const auto half = [](double x0) {
    auto b = test::box_spec(ElementType::Hex8, 0.5, 0.1, 0.08, 5, 2, 2);
    b.origin = {x0, 0, 0};
    return b;
  };
  mesh::Mesh two;
  std::size_t n_mpc = 0;
  if (rank_of() == 0) {
    append_box(&two, half(0.0), 0, "A_");
    append_box(&two, half(0.5), 10000, "B_");
    const auto& a = two.node_sets.at("A_x1");
    const auto& b = two.node_sets.at("B_x0");
    for (auto ka : a)
      for (auto kb : b) {
        double d = 0;
        for (int j = 0; j < 3; ++j) d += std::abs(two.coords[3 * ka + j] - two.coords[3 * kb + j]);
        if (d > 1e-12) continue;
        for (int c = 1; c <= 3; ++c) {
          mesh::LinearConstraint lc;
          lc.id = static_cast<std::int64_t>(++n_mpc);
          lc.where = cat("test MPC ", lc.id);
          lc.terms = {{two.node_ids[kb], c, 2.0}, {two.node_ids[ka], c, -2.0}};  // u_B = u_A
          two.constraints.linear.push_back(lc);
        }
      }
    EXPECT_EQ(n_mpc, 27u);
  }
  auto tied = build(std::move(two), {"A_x0"});
  mesh::Mesh one;
  if (rank_of() == 0) one = mesh::generate_box(test::box_spec(ElementType::Hex8, 1.0, 0.1, 0.08, 10, 2, 2));
  auto ref = build(std::move(one), {"x0"});
  return {std::move(tied), std::move(ref)};
}
}  // namespace

TEST(Constraints, TwoBoxesTiedByMpcsHaveTheSpectrumOfOneBox) {
  auto [tied, ref] = tied_and_one_box();
  ASSERT_TRUE(tied.constraints);
  EXPECT_EQ(tied.constraints->n_dependent, 27);
  EXPECT_EQ(tied.dofs.n_global, ref.dofs.n_global);
  EXPECT_NEAR(tied.mass, ref.mass, 1e-12 * ref.mass);
  const auto wt = test::lowest_eigenvalues(tied.K.get(), tied.M.get(), 8);
  const auto wr = test::lowest_eigenvalues(ref.K.get(), ref.M.get(), 8);
  for (int i = 0; i < 8; ++i) EXPECT_NEAR(wt[i], wr[i], 1e-9 * wr[i]) << "mode " << i + 1;
}

// The nonlinear forces through T: smooth displacement fields of the tied boxes and of the one box
// (the same physical fields, the tied model's dependent nodes following through the MPCs) have the
// same strain energy, directional nonlinear force v . g_nl(u), tangent v . K_T(u) v and projected
// cubic tensors (exact: the meshes are the same but for the doubled nodes at x = 0.5). The fields
// reach 24 cm on the 1 m box, so that the nonlinear energy is a sizeable part of the total.
TEST(Constraints, NonlinearForcesThroughTiedBoxesAreTheOneBoxs) {
  auto [tied, ref] = tied_and_one_box();
  ASSERT_TRUE(tied.constraints);
  const mesh::Material steel = test::steel();
  fe::Svk st(tied, steel), sr(ref, steel);
  EXPECT_EQ(st.stiffness(), tied.K.get()) << "the linear part is the model's K_bar";
  using Field = std::function<void(const double*, double*)>;
  const Field f1 = [](const double* x, double* u) { u[0] = 0.08 * x[0] * x[1], u[1] = 0.24 * x[0] * x[0], u[2] = 0; };
  const Field f2 = [](const double* x, double* u) {
    u[0] = 0.004 * x[0], u[1] = 0.002 * x[0] * x[2], u[2] = 0.02 * x[0] * x[0] * x[0];
  };
  // The field on md's DOFs (its owned rows; a dependent node's rows are not the model's).
  auto vec = [](const fe::Model& md, const Field& f) {
    UVec v;
    MORSE_CALL(MatCreateVecs(md.K.get(), v.ptr(), nullptr));
    const auto& m = md.mesh->mesh;
    for (std::int64_t k = 0; k < m.num_nodes(); ++k) {
      double u[3];
      f(&m.coords[3 * k], u);
      for (int d = 0; d < 3; ++d) {
        const PetscInt g = md.dofs.node_dof[3 * k + d];
        if (g >= md.dofs.first && g < md.dofs.first + md.dofs.n_owned)
          MORSE_CALL(VecSetValue(v.get(), g, u[d], INSERT_VALUES));
      }
    }
    MORSE_CALL(VecAssemblyBegin(v.get()));
    MORSE_CALL(VecAssemblyEnd(v.get()));
    return v;
  };
  struct Values {
    double linear, nonlinear, force, tangent;
    std::vector<double> A, B;
  };
  auto values = [&](const fe::Model& md, const fe::Svk& svk) {
    Values r;
    auto u = vec(md, f1), v = vec(md, f2);
    const auto e = svk.energy(u.get());
    r.linear = e.linear, r.nonlinear = e.nonlinear;
    UVec g;
    MORSE_CALL(VecDuplicate(u.get(), g.ptr()));
    svk.nonlinear_force(u.get(), g.get());
    MORSE_CALL(VecDot(v.get(), g.get(), &r.force));
    auto Kt = svk.create_tangent();
    svk.tangent(u.get(), Kt.get());
    MORSE_CALL(MatMult(Kt.get(), v.get(), g.get()));
    MORSE_CALL(VecDot(v.get(), g.get(), &r.tangent));
    PetscInt n = 0;
    MORSE_CALL(VecGetLocalSize(u.get(), &n));
    UMat Phi;
    MORSE_CALL(MatCreateDense(PETSC_COMM_WORLD, n, PETSC_DECIDE, PETSC_DETERMINE, 2, nullptr, Phi.ptr()));
    for (PetscInt j = 0; j < 2; ++j) {
      Vec c;
      MORSE_CALL(MatDenseGetColumnVecWrite(Phi.get(), j, &c));
      MORSE_CALL(VecCopy(j == 0 ? u.get() : v.get(), c));
      MORSE_CALL(MatDenseRestoreColumnVecWrite(Phi.get(), j, &c));
    }
    svk.project_tensors(Phi.get(), &r.A, &r.B);
    return r;
  };
  const auto t = values(tied, st), r = values(ref, sr);
  print0(PETSC_COMM_WORLD,
         "  tied boxes: W_lin %.6e (one box %.6e), W_nl %.6e (%.6e), v.g %.6e (%.6e), v.Kt v %.6e (%.6e) J\n", t.linear,
         r.linear, t.nonlinear, r.nonlinear, t.force, r.force, t.tangent, r.tangent);
  EXPECT_GT(std::abs(r.nonlinear), 0.05 * r.linear) << "the fields should be large enough to be nonlinear";
  EXPECT_NEAR(t.linear, r.linear, 1e-10 * r.linear);
  EXPECT_NEAR(t.nonlinear, r.nonlinear, 1e-10 * std::abs(r.nonlinear));
  EXPECT_NEAR(t.force, r.force, 1e-10 * std::abs(r.force));
  EXPECT_NEAR(t.tangent, r.tangent, 1e-10 * std::abs(r.tangent));
  ASSERT_EQ(t.A.size(), r.A.size());
  ASSERT_EQ(t.B.size(), r.B.size());
  double scale = 0, diff = 0;
  for (std::size_t i = 0; i < r.A.size(); ++i)
    scale = std::max(scale, std::abs(r.A[i])), diff = std::max(diff, std::abs(t.A[i] - r.A[i]));
  EXPECT_LT(diff, 1e-10 * scale) << "quadratic tensor";
  scale = diff = 0;
  for (std::size_t i = 0; i < r.B.size(); ++i)
    scale = std::max(scale, std::abs(r.B[i])), diff = std::max(diff, std::abs(t.B[i] - r.B[i]));
  EXPECT_LT(diff, 1e-10 * scale) << "cubic tensor";
}

// The tied boxes under a large tip load (dead, along y, 300 kN on each of the 9 tip nodes, far into
// the geometrically nonlinear range), solved with Newton on the model's DOFs
// (dyn::solve_static): the displacement of every node, expanded through the MPCs, is the one box's
// at the same place.
TEST(Constraints, NonlinearStaticAndDynamicsOfTiedBoxesAreTheOneBoxs) {
  auto [tied, ref] = tied_and_one_box();
  const mesh::Material steel = test::steel();
  // dynamic: the full model's time integration (dyn::integrate, energy scheme, 40 steps of 20 us
  // from rest under the suddenly applied load) instead of the static solve; the state at the end.
  auto solve = [&](const fe::Model& md, const std::string& tip, bool linear, bool dynamic = false) {
    fe::Svk svk(md, steel);
    dyn::NodalLoad l;
    l.set = tip, l.dir[1] = 1.0, l.amplitude = 3e5;
    dyn::Loads loads(md, {l});
    UVec u;
    if (dynamic) {
      dyn::FomSettings fs;
      fs.dt = 2e-5, fs.t_final = 8e-4, fs.linear = linear;
      dyn::integrate(svk, md.M.get(), loads, fs, nullptr, nullptr, [&](const dyn::StepInfo& i) {
        if (i.t >= fs.t_final * (1 - 1e-9)) u = fe::expand(md, i.u);
      });
    } else {
      dyn::StaticSettings ss;
      ss.steps = 8;
      ss.linear = linear;
      auto r = dyn::solve_static(svk, loads, ss);
      u = fe::expand(md, r.u.get());
    }
    // Every node's displacement by its position (rank 0 gathers).
    const auto& lm = *md.mesh;
    auto nodal = io::gather_nodal(lm, fe::node_layout(md), u.get());
    std::vector<std::pair<std::array<long, 3>, std::array<double, 3>>> byx;
    const auto gm = mesh::gather_to_rank0(lm);
    for (std::int64_t k = 0; k < gm.num_nodes(); ++k) {
      std::array<long, 3> key;
      for (int d = 0; d < 3; ++d) key[d] = std::lround(gm.coords[3 * k + d] * 1e6);
      byx.push_back({key, {nodal[3 * k], nodal[3 * k + 1], nodal[3 * k + 2]}});
    }
    std::sort(byx.begin(), byx.end());
    byx.erase(std::unique(byx.begin(), byx.end(), [](const auto& a, const auto& b) { return a.first == b.first; }),
              byx.end());  // the tied nodes at x = 0.5 once
    return byx;
  };
  // Decided on rank 0 and shared: the same nodes, the largest difference and the largest u_y of b.
  struct Diff {
    int same = 1;
    double err = 0, tip = 0;
  };
  auto compare = [](const auto& a, const auto& b) {
    Diff x;
    if (rank_of() == 0) {
      x.same = a.size() == b.size();
      for (std::size_t i = 0; x.same && i < b.size(); ++i) {
        x.same = a[i].first == b[i].first;
        for (int d = 0; d < 3; ++d) x.err = std::max(x.err, std::abs(a[i].second[d] - b[i].second[d]));
        x.tip = std::max(x.tip, std::abs(b[i].second[1]));
      }
    }
    MPI_Bcast(&x.same, 1, MPI_INT, 0, PETSC_COMM_WORLD);
    for (double* v : {&x.err, &x.tip}) MPI_Bcast(v, 1, MPI_DOUBLE, 0, PETSC_COMM_WORLD);
    return x;
  };
  const auto r = solve(ref, "x1", false);
  const auto st = compare(solve(tied, "B_x1", false), r), lin = compare(r, solve(ref, "x1", true));
  print0(PETSC_COMM_WORLD, "  tied boxes, static: tip u_y %.6e m (linear %.6e m), max |u_tied - u_one| %.2e m\n",
         st.tip, lin.tip, st.err);
  ASSERT_EQ(st.same, 1) << "the nodes' positions differ";
  EXPECT_GT(lin.tip, 1.1 * st.tip) << "the load should be large enough to be nonlinear";
  EXPECT_LT(st.err, 1e-8 * st.tip);
  // The same through time (morse fom's integrator, M_bar = T^T M T).
  const auto dy = compare(solve(tied, "B_x1", false, true), solve(ref, "x1", false, true));
  print0(PETSC_COMM_WORLD, "  tied boxes, dynamic: tip u_y %.6e m at 0.8 ms, max |u_tied - u_one| %.2e m\n", dy.tip,
         dy.err);
  ASSERT_EQ(dy.same, 1);
  EXPECT_GT(dy.tip, 0.01) << "the load should move the tip";
  EXPECT_LT(dy.err, 1e-8 * dy.tip);
}

TEST(Constraints, RigidSpiderOverAFreeBoxGivesTheRigidBodyMassMatrix) {
  // The spider also carries a second point 9002, dependent with all six components, holding a
  // rigid mass (CONM2 with offset and inertia): it adds that body's mass matrix moved to x_R.
  const double L = 0.6, B = 0.2, H = 0.1, rho = test::steel().rho;
  const double xr[3] = {0.25, 0.05, -0.03};  // the spider's centre, off the box's centre
  const double xp[3] = {0.7, -0.1, 0.2}, off[3] = {0.05, 0.02, -0.04}, m2 = 3.5;
  const double J2[9] = {0.4, 0.01, -0.02, 0.01, 0.3, 0.03, -0.02, 0.03, 0.2};
  mesh::Mesh m;
  if (rank_of() == 0) {
    m = mesh::generate_box(test::box_spec(ElementType::Hex8, L, B, H, 6, 2, 2));
    const auto n_box = m.num_nodes();
    m.add_node(9001, xr[0], xr[1], xr[2]);
    m.add_node(9002, xp[0], xp[1], xp[2]);
    mesh::RigidElement r;
    r.id = 1;
    r.where = "test RBE2 1";
    r.reference = 9001;
    r.components = 63;
    for (std::int64_t k = 0; k < n_box; ++k) r.dependent.push_back(m.node_ids[k]);
    r.dependent.push_back(9002);
    m.constraints.rigid.push_back(r);
    m.constraints.mass_ids.push_back(9002);
    const auto M6 = mesh::rigid_mass_matrix(m2, off, J2);
    m.constraints.mass_matrices.assign(M6.begin(), M6.end());
  }
  auto md = build(std::move(m), {});
  ASSERT_EQ(md.dofs.n_global, 6);
  const auto K = test::dense_matrix(md.K.get()), M = test::dense_matrix(md.M.get());
  PetscReal kfull = 0;
  // K of a rigid motion vanishes: against the stiffness scale E * L (N/m) times lever arms.
  const double kscale = test::steel().E * L;
  for (double v : K) kfull = std::max(kfull, std::abs(v));
  EXPECT_LT(kfull, 1e-9 * kscale);
  // Closed form about x_R, body by body: [[m I, -m [d]x], [m [d]x, J_c + m (|d|^2 I - d d^T)]],
  // d = its centre of gravity - x_R, J_c its inertia about its centre of gravity.
  double E[6][6] = {};
  auto add_body = [&](double m, const double d[3], const double Jc[9]) {
    const double S[3][3] = {{0, -d[2], d[1]}, {d[2], 0, -d[0]}, {-d[1], d[0], 0}};
    for (int i = 0; i < 3; ++i) {
      E[i][i] += m;
      for (int j = 0; j < 3; ++j) {
        E[i][3 + j] -= m * S[i][j];
        E[3 + i][j] += m * S[i][j];
        E[3 + i][3 + j] += Jc[3 * i + j] + m * ((i == j ? d[0] * d[0] + d[1] * d[1] + d[2] * d[2] : 0) - d[i] * d[j]);
      }
    }
  };
  const double mass = rho * L * B * H;
  const double d[3] = {L / 2 - xr[0], B / 2 - xr[1], H / 2 - xr[2]};
  const double Jbox[9] = {mass * (B * B + H * H) / 12, 0, 0, 0, mass * (L * L + H * H) / 12, 0, 0, 0,
                          mass * (L * L + B * B) / 12};
  add_body(mass, d, Jbox);
  // The second body: its centre of gravity at x_p + offset.
  const double d2[3] = {xp[0] + off[0] - xr[0], xp[1] + off[1] - xr[1], xp[2] + off[2] - xr[2]};
  add_body(m2, d2, J2);
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j) EXPECT_NEAR(M[6 * i + j], E[i][j], 1e-12 * mass) << i << "," << j;
  EXPECT_NEAR(md.mass, mass + m2, 1e-12 * mass);
}

TEST(Constraints, InterpolationElementLoadsLikeTheLeverRuleAndMovesAsTheFit) {
  // Cantilever clamped at x = 0; an RBE3 on the 9 nodes of the tip face, equal weights, its
  // reference at the face's centroid. A load (F, M) on the reference point against the same box
  // without the RBE3 under the lever rule's nodal forces.
  const double L = 1.0, B = 0.1, H = 0.1;
  const double xr[3] = {L, B / 2, H / 2};
  const double load[6] = {100, 200, -50, 7, -3, 5};
  const auto spec = test::box_spec(ElementType::Hex8, L, B, H, 8, 2, 2);
  mesh::Mesh m;
  if (rank_of() == 0) {
    m = mesh::generate_box(spec);
    m.add_node(9001, xr[0], xr[1], xr[2]);
    mesh::InterpolationElement r;
    r.id = 7;
    r.where = "test RBE3 7";
    r.reference = 9001;
    r.ref_components = 63;
    for (auto k : m.node_sets.at("x1")) {
      r.nodes.push_back(m.node_ids[k]);
      r.weights.push_back(2.5);
      r.node_components.push_back(7);
    }
    m.constraints.interpolation.push_back(r);
    m.node_sets["ref"] = {m.num_nodes() - 1};
  }
  auto md = build(std::move(m), {"x0"});
  ASSERT_TRUE(md.constraints);
  EXPECT_EQ(md.constraints->n_point_dofs, 6);
  EXPECT_EQ(md.constraints->n_dependent, 6);
  // The reference point's rows, in component order (set "ref").
  const auto rows = fe::set_rows(md.dofs, "ref", "test");
  ASSERT_EQ(rows.size(), 6u);
  UVec f, ub;
  MORSE_CALL(MatCreateVecs(md.K.get(), ub.ptr(), f.ptr()));
  for (const auto& r : rows)
    if (r.row >= md.dofs.first && r.row < md.dofs.first + md.dofs.n_owned)
      MORSE_CALL(VecSetValue(f.get(), r.row, load[r.component - 1], INSERT_VALUES));
  MORSE_CALL(VecAssemblyBegin(f.get()));
  MORSE_CALL(VecAssemblyEnd(f.get()));
  test::direct_solve(md.K.get(), f.get(), ub.get());
  auto u = fe::expand(md, ub.get());
  double ref_motion[6] = {0, 0, 0, 0, 0, 0};
  {
    std::vector<double> all(6, 0.0);
    const PetscScalar* a;
    MORSE_CALL(VecGetArrayRead(ub.get(), &a));
    for (const auto& r : rows)
      if (r.row >= md.dofs.first && r.row < md.dofs.first + md.dofs.n_owned)
        all[r.component - 1] = a[r.row - md.dofs.first];
    MORSE_CALL(VecRestoreArrayRead(ub.get(), &a));
    MPI_Allreduce(MPI_IN_PLACE, all.data(), 6, MPI_DOUBLE, MPI_SUM, PETSC_COMM_WORLD);
    std::copy(all.begin(), all.end(), ref_motion);
  }

  // The reference: the plain box, nodal forces F/n + (J^-1 M) x r_i on the tip face.
  auto box = test::assembled_box(PETSC_COMM_WORLD, spec, {"x0"});
  const auto& lm = box.lm;
  const auto& tip = lm.mesh.node_sets.at("x1");
  std::int64_t n_tip = lm.node_set_sizes.at("x1");
  double J[3] = {0, 0, 0};  // diagonal of sum (|r|^2 I - r r^T) (the face is symmetric: no products)
  const double ry[3] = {-B / 2, 0, B / 2}, rz[3] = {-H / 2, 0, H / 2};
  for (double y : ry)
    for (double z : rz) J[0] += y * y + z * z, J[1] += z * z, J[2] += y * y;
  const double th[3] = {load[3] / J[0], load[4] / J[1], load[5] / J[2]};
  UVec fr, ur;
  MORSE_CALL(MatCreateVecs(box.ops.K.get(), ur.ptr(), fr.ptr()));
  int rank = rank_of();
  for (auto k : tip) {
    if (lm.node_owner[k] != rank) continue;
    const double r[3] = {lm.mesh.coords[3 * k] - xr[0], lm.mesh.coords[3 * k + 1] - xr[1],
                         lm.mesh.coords[3 * k + 2] - xr[2]};
    const double cr[3] = {th[1] * r[2] - th[2] * r[1], th[2] * r[0] - th[0] * r[2], th[0] * r[1] - th[1] * r[0]};
    for (int dd = 0; dd < 3; ++dd)
      MORSE_CALL(VecSetValue(fr.get(), box.dofs.node_dof[3 * k + dd], load[dd] / static_cast<double>(n_tip) + cr[dd],
                             ADD_VALUES));
  }
  MORSE_CALL(VecAssemblyBegin(fr.get()));
  MORSE_CALL(VecAssemblyEnd(fr.get()));
  test::direct_solve(box.ops.K.get(), fr.get(), ur.get());
  // Same node DOF numbering (the same box, distributed alike), so the vectors compare directly.
  PetscReal nref = 0, ndiff = 0;
  MORSE_CALL(VecNorm(ur.get(), NORM_INFINITY, &nref));
  MORSE_CALL(VecAXPY(ur.get(), -1.0, u.get()));
  MORSE_CALL(VecNorm(ur.get(), NORM_INFINITY, &ndiff));
  EXPECT_GT(nref, 0);
  EXPECT_LT(ndiff, 1e-9 * nref);

  // The reference point moves as the fit: mean translation, theta = J^-1 sum r_i x u_i.
  double mean[3] = {0, 0, 0}, mom[3] = {0, 0, 0};
  {
    const PetscScalar* a;
    MORSE_CALL(VecGetArrayRead(u.get(), &a));
    const auto& full = md.constraints->full;
    const auto& mlm = *md.mesh;
    for (auto k : mlm.mesh.node_sets.at("x1")) {
      if (mlm.node_owner[k] != rank) continue;
      double uk[3], r[3];
      for (int dd = 0; dd < 3; ++dd) {
        uk[dd] = a[full.node_dof[3 * k + dd] - full.first];
        r[dd] = mlm.mesh.coords[3 * k + dd] - xr[dd];
        mean[dd] += uk[dd] / static_cast<double>(n_tip);
      }
      mom[0] += r[1] * uk[2] - r[2] * uk[1];
      mom[1] += r[2] * uk[0] - r[0] * uk[2];
      mom[2] += r[0] * uk[1] - r[1] * uk[0];
    }
    MORSE_CALL(VecRestoreArrayRead(u.get(), &a));
    MPI_Allreduce(MPI_IN_PLACE, mean, 3, MPI_DOUBLE, MPI_SUM, PETSC_COMM_WORLD);
    MPI_Allreduce(MPI_IN_PLACE, mom, 3, MPI_DOUBLE, MPI_SUM, PETSC_COMM_WORLD);
  }
  double scale = 0;
  for (double v : mean) scale = std::max(scale, std::abs(v));
  for (int dd = 0; dd < 3; ++dd) {
    EXPECT_NEAR(ref_motion[dd], mean[dd], 1e-9 * scale) << "translation " << dd;
    EXPECT_NEAR(ref_motion[3 + dd], mom[dd] / J[dd], 1e-9 * scale / B) << "rotation " << dd;
  }
}

TEST(Constraints, DeckErrorsAreThrownOnEveryRank) {
  const auto spec = test::box_spec(ElementType::Hex8, 1.0, 0.1, 0.1, 4, 1, 1);
  // f adds constraints to a box (node ids 1..20: x = 0 face 1, 6, 11, 16) with a point 9001.
  auto run = [&](const std::function<void(mesh::Mesh*)>& f, const std::vector<std::string>& clamp) {
    mesh::Mesh m;
    if (rank_of() == 0) {
      m = mesh::generate_box(spec);
      m.add_node(9001, 1.0, 0.05, 0.05);
      f(&m);
    }
    return thrown([&] { build(std::move(m), clamp); });
  };
  auto rbe2 = [](std::int64_t id, std::int64_t ref, std::vector<std::int64_t> dep) {
    mesh::RigidElement r;
    r.id = id;
    r.where = cat("deck.bdf:", id, ": RBE2 ", id);
    r.reference = ref;
    r.components = 63;
    r.dependent = std::move(dep);
    return r;
  };
  auto mpc = [](std::int64_t id, std::int64_t a, int ca, std::int64_t b, int cb) {
    mesh::LinearConstraint l;
    l.id = id;
    l.where = cat("deck.bdf:", id, ": MPC ", id);
    l.terms = {{a, ca, 1.0}, {b, cb, -1.0}};
    return l;
  };
  // A dependent node of the clamped face.
  auto msg = run([&](mesh::Mesh* m) { m->constraints.rigid.push_back(rbe2(3, 9001, {5, 1})); }, {"x0"});
  EXPECT_NE(msg.find("deck.bdf:3: RBE2 3"), std::string::npos) << msg;
  EXPECT_NE(msg.find("node 1 component 1 (x) is dependent but also fixed"), std::string::npos) << msg;
  // Dependent in two elements.
  msg = run(
      [&](mesh::Mesh* m) {
        m->constraints.rigid.push_back(rbe2(3, 9001, {5, 10}));
        m->constraints.linear.push_back(mpc(4, 10, 2, 9, 2));
      },
      {"x0"});
  EXPECT_NE(msg.find("node 10 component 2 (y) is dependent here and in deck.bdf:3: RBE2 3"), std::string::npos) << msg;
  // A cycle.
  msg = run(
      [&](mesh::Mesh* m) {
        m->constraints.linear.push_back(mpc(4, 10, 1, 9, 1));
        m->constraints.linear.push_back(mpc(5, 9, 1, 10, 1));
      },
      {"x0"});
  EXPECT_NE(msg.find("circular dependency"), std::string::npos) << msg;
  // The independent node of an RBE2 is a solid node.
  msg = run([&](mesh::Mesh* m) { m->constraints.rigid.push_back(rbe2(3, 5, {10})); }, {"x0"});
  EXPECT_NE(msg.find("independent node 5 is a node of solid elements"), std::string::npos) << msg;
  // A rotation of a solid node in an MPC.
  msg = run([&](mesh::Mesh* m) { m->constraints.linear.push_back(mpc(4, 10, 5, 9, 1)); }, {"x0"});
  EXPECT_NE(msg.find("component 5 of node 10"), std::string::npos) << msg;
  EXPECT_NE(msg.find("no rotations"), std::string::npos) << msg;
  // RBE3 on three collinear nodes (an edge along x): rotation about x undetermined.
  msg = run(
      [&](mesh::Mesh* m) {
        mesh::InterpolationElement r;
        r.id = 8;
        r.where = "deck.bdf:8: RBE3 8";
        r.reference = 9001;
        r.ref_components = 63;
        r.nodes = {3, 4, 5};
        r.weights = {1, 1, 1};
        r.node_components = {7, 7, 7};
        m->constraints.interpolation.push_back(r);
      },
      {"x0"});
  EXPECT_NE(msg.find("deck.bdf:8: RBE3 8"), std::string::npos) << msg;
  EXPECT_NE(msg.find("do not determine the reference's motion"), std::string::npos) << msg;
  // A constraint naming an id that is no node.
  msg = run([&](mesh::Mesh* m) { m->constraints.linear.push_back(mpc(4, 10, 1, 777, 1)); }, {"x0"});
  EXPECT_NE(msg.find("names node 777, which is not a node of the mesh"), std::string::npos) << msg;
}

TEST(Constraints, SpidersOnANodeSet) {
  // Spiders on two opposite corners of the tip face (8x2x2 hex8 cantilever, node spacing 0.05 in
  // y and z): each joins its corner and the corner's two face neighbours within 0.06. RBE3
  // spiders add no stiffness: the spectrum is the plain box's; RBE2 spiders stiffen it. Overlapping
  // RBE3s (every node of the tip face) keep some references dependent: nothing changes either.
  const auto spec = test::box_spec(ElementType::Hex8, 1.0, 0.1, 0.1, 8, 2, 2);
  auto model = [&](mesh::SpiderType type, const std::string& set, double radius) {
    fe::Model md;
    md.mesh = test::box_mesh(PETSC_COMM_WORLD, spec);
    mesh::add_node_set(&*md.mesh, "corners", {9, 81}, "test");
    mesh::add_spiders(&*md.mesh, {set}, radius, type);
    md.dofs = fe::number_dofs(*md.mesh, {"x0"});
    auto ops = fe::assemble(*md.mesh, md.dofs, test::steel());
    md.K = std::move(ops.K);
    md.M = std::move(ops.M);
    fe::eliminate_constraints(&md, {"x0"});
    return md;
  };
  auto plain = test::assembled_box(PETSC_COMM_WORLD, spec, {"x0"});
  const auto w0 = test::lowest_eigenvalues(plain.ops.K.get(), plain.ops.M.get(), 6);
  auto rbe3 = model(mesh::SpiderType::Interpolation, "corners", 0.06);
  const auto& cs = rbe3.mesh->mesh.constraints;
  ASSERT_EQ(cs.interpolation.size(), 2u);
  EXPECT_EQ(cs.interpolation[0].nodes, (std::vector<std::int64_t>{9, 18, 36}));  // (8,0,0), (8,1,0), (8,0,1)
  EXPECT_EQ(cs.point_ids, (std::vector<std::int64_t>{82, 83}));
  EXPECT_EQ(rbe3.mesh->node_set_sizes.at("corners_spiders"), 2);
  // The points join the other sets of their centres: both corners are tip (x1) nodes, no root one.
  EXPECT_EQ(rbe3.mesh->node_set_sizes.at("x1_spiders"), 2);
  EXPECT_EQ(cs.point_sets.at("x1_spiders"), (std::vector<std::int64_t>{82, 83}));
  EXPECT_EQ(rbe3.mesh->node_set_sizes.count("x0_spiders"), 0u);
  EXPECT_EQ(fe::set_rows(rbe3.dofs, "x1_spiders", "test").size(), 12u);
  EXPECT_EQ(fe::set_rows(rbe3.dofs, "corners_spiders", "test").size(), 12u);
  const auto w3 = test::lowest_eigenvalues(rbe3.K.get(), rbe3.M.get(), 6);
  auto rbe2 = model(mesh::SpiderType::Rigid, "corners", 0.06);
  const auto w2 = test::lowest_eigenvalues(rbe2.K.get(), rbe2.M.get(), 6);
  auto all = model(mesh::SpiderType::Interpolation, "x1", 0.06);
  EXPECT_LT(all.constraints->n_point_dofs, 9 * 6);  // some references stay dependent
  const auto wa = test::lowest_eigenvalues(all.K.get(), all.M.get(), 6);
  for (int i = 0; i < 6; ++i) {
    EXPECT_NEAR(w3[i], w0[i], 1e-9 * w0[i]) << "mode " << i + 1;
    EXPECT_NEAR(wa[i], w0[i], 1e-9 * w0[i]) << "mode " << i + 1;
    EXPECT_GE(w2[i], w0[i] * (1 - 1e-12)) << "mode " << i + 1;
  }
  EXPECT_GT(w2[5], w0[5] * (1 + 1e-6));  // torsion feels the rigid corners
  // Bad input, on every rank.
  auto msg = thrown([&] { model(mesh::SpiderType::Interpolation, "nowhere", 0.06); });
  EXPECT_NE(msg.find("-mesh_spiders: node set 'nowhere' not found"), std::string::npos) << msg;
  msg = thrown([&] { model(mesh::SpiderType::Interpolation, "corners", -1); });
  EXPECT_NE(msg.find("-mesh_spider_radius -1 must be positive"), std::string::npos) << msg;
  msg = thrown([&] { model(mesh::SpiderType::Interpolation, "corners", 0.01); });  // one node each
  EXPECT_NE(msg.find("-mesh_spiders corners: the spider at node 9 (point 82, 1 nodes within 0.01)"), std::string::npos)
      << msg;
  EXPECT_NE(msg.find("do not determine the reference's motion"), std::string::npos) << msg;
}

// fe::restrict_columns, the model coordinates of nodal fields (how morse nlrom reads a fom file's
// snapshots on a constrained deck): for fields that satisfy the constraints (X = T Y, Y random on
// the model's DOFs, the six-DOF points' rotations included) it returns Y; for any field it returns
// the least-squares fit, whose residual is orthogonal to the range of T (T^T (T Y - X) = 0).
TEST(Constraints, NodalFieldsRestrictToTheirModelCoordinates) {
  const auto spec = test::box_spec(ElementType::Hex8, 1.0, 0.1, 0.1, 8, 2, 2);
  for (auto type : {mesh::SpiderType::Rigid, mesh::SpiderType::Interpolation}) {
    fe::Model md;
    md.mesh = test::box_mesh(PETSC_COMM_WORLD, spec);
    mesh::add_node_set(&*md.mesh, "corners", {9, 81}, "test");
    mesh::add_spiders(&*md.mesh, {"corners"}, 0.06, type);
    md.dofs = fe::number_dofs(*md.mesh, {"x0"});
    auto ops = fe::assemble(*md.mesh, md.dofs, test::steel());
    md.K = std::move(ops.K);
    md.M = std::move(ops.M);
    fe::eliminate_constraints(&md, {"x0"});
    ASSERT_TRUE(md.constraints);
    ASSERT_GT(md.constraints->n_point_dofs, 0);
    Mat T = md.constraints->T.get();
    const PetscInt ncol = 3;
    PetscInt m_loc = 0, n_loc = 0;
    MORSE_CALL(MatGetLocalSize(T, &m_loc, &n_loc));
    (void)m_loc;
    UMat Y, X;
    MORSE_CALL(MatCreateDense(PETSC_COMM_WORLD, n_loc, PETSC_DECIDE, PETSC_DETERMINE, ncol, nullptr, Y.ptr()));
    PetscInt lo = 0, hi = 0;
    MORSE_CALL(MatGetOwnershipRange(Y.get(), &lo, &hi));
    for (PetscInt j = 0; j < ncol; ++j)
      for (PetscInt i = lo; i < hi; ++i)  // a field of every DOF, independent of the rank count
        MORSE_CALL(MatSetValue(Y.get(), i, j, std::sin(0.7 * i + 1.3 * j + 0.1) * (j + 1), INSERT_VALUES));
    MORSE_CALL(MatAssemblyBegin(Y.get(), MAT_FINAL_ASSEMBLY));
    MORSE_CALL(MatAssemblyEnd(Y.get(), MAT_FINAL_ASSEMBLY));
    MORSE_CALL(MatMatMult(T, Y.get(), MAT_INITIAL_MATRIX, PETSC_DEFAULT, X.ptr()));
    auto R = fe::restrict_columns(md, X.get());
    double ny = 0, nd = 0;
    MORSE_CALL(MatNorm(Y.get(), NORM_FROBENIUS, &ny));
    MORSE_CALL(MatAXPY(R.get(), -1.0, Y.get(), SAME_NONZERO_PATTERN));
    MORSE_CALL(MatNorm(R.get(), NORM_FROBENIUS, &nd));
    EXPECT_LT(nd, 1e-12 * ny) << "fields that satisfy the constraints";
    // A field that does not: X + a nodal perturbation; the fit's residual is orthogonal to range(T).
    MORSE_CALL(MatGetOwnershipRange(X.get(), &lo, &hi));
    for (PetscInt j = 0; j < ncol; ++j)
      for (PetscInt i = lo; i < hi; ++i)
        MORSE_CALL(MatSetValue(X.get(), i, j, 0.3 * std::cos(1.1 * i - 0.4 * j), ADD_VALUES));
    MORSE_CALL(MatAssemblyBegin(X.get(), MAT_FINAL_ASSEMBLY));
    MORSE_CALL(MatAssemblyEnd(X.get(), MAT_FINAL_ASSEMBLY));
    auto F = fe::restrict_columns(md, X.get());
    UMat TF, G;
    MORSE_CALL(MatMatMult(T, F.get(), MAT_INITIAL_MATRIX, PETSC_DEFAULT, TF.ptr()));
    MORSE_CALL(MatAXPY(TF.get(), -1.0, X.get(), SAME_NONZERO_PATTERN));
    MORSE_CALL(MatTransposeMatMult(T, TF.get(), MAT_INITIAL_MATRIX, PETSC_DEFAULT, G.ptr()));
    double nx = 0, ng = 0;
    MORSE_CALL(MatNorm(X.get(), NORM_FROBENIUS, &nx));
    MORSE_CALL(MatNorm(G.get(), NORM_FROBENIUS, &ng));
    EXPECT_LT(ng, 1e-12 * nx) << "least squares: T^T (T Y - X) = 0";
  }
}

TEST(Constraints, ASpiderCentreFixedByTheDeckClampsItsNodes) {
  // *BOUNDARY / SPC 123456 on the centre of an RBE2 over the tip face: the tip face is clamped,
  // so the model is the box clamped at both ends. Without the rotations fixed (123) the tip face
  // may still rotate about the centre: softer than that.
  const auto spec = test::box_spec(ElementType::Hex8, 1.0, 0.1, 0.1, 8, 2, 2);
  auto model = [&](std::uint8_t fixed) {
    mesh::Mesh m;
    if (rank_of() == 0) {
      m = mesh::generate_box(spec);
      m.fixed_dofs.assign(m.num_nodes() + 1, 0);
      for (auto k : m.node_sets.at("x0")) m.fixed_dofs[k] = 7;
      m.add_node(9001, 1.0, 0.05, 0.05);
      m.fixed_dofs.back() = fixed;
      mesh::RigidElement r;
      r.id = 1;
      r.where = "test RBE2 1";
      r.reference = 9001;
      r.components = 63;
      for (auto k : m.node_sets.at("x1")) r.dependent.push_back(m.node_ids[k]);
      m.constraints.rigid.push_back(r);
    }
    return build(std::move(m), {mesh::kDeckBoundarySet});
  };
  auto both = test::assembled_box(PETSC_COMM_WORLD, spec, {"x0", "x1"});
  const auto wb = test::lowest_eigenvalues(both.ops.K.get(), both.ops.M.get(), 4);
  auto all6 = model(63);
  EXPECT_EQ(all6.constraints->n_point_dofs, 0);
  const auto w6 = test::lowest_eigenvalues(all6.K.get(), all6.M.get(), 4);
  auto pin = model(7);
  EXPECT_EQ(pin.constraints->n_point_dofs, 3);
  const auto w3 = test::lowest_eigenvalues(pin.K.get(), pin.M.get(), 4);
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(w6[i], wb[i], 1e-9 * wb[i]) << "mode " << i + 1;
    EXPECT_LT(w3[i], wb[i] * (1 - 1e-3)) << "mode " << i + 1;
  }
}
