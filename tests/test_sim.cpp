// Explicit reduced integration (sim/sim.hpp) against closed forms: the linear CB superelement's
// response to a harmonic load from rest (modal solution of the reduced model), second-order
// convergence in dt, the critical step refusal, and bounded energy of the undamped, unforced
// nonlinear reduced model over 10^6 steps.
#include <petscsys.h>
#include <gtest/gtest.h>
#include <petscblaslapack.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <utility>

#include "given_options.hpp"
#include "morse/cb/craig_bampton.hpp"
#include "morse/core/files.hpp"
#include "morse/core/log.hpp"
#include "morse/core/session.hpp"
#include "morse/dyn/dyn.hpp"
#include "morse/fe/nonlinear.hpp"
#include "morse/io/h5.hpp"
#include "morse/nlrom/nlrom.hpp"
#include "morse/sim/run.hpp"
#include "morse/sim/sim.hpp"
#include "scratch.hpp"
#include "util.hpp"

using namespace morse;
using mesh::ElementType;

namespace {

using test::Model;

Model box(ElementType t, int nx) {
  return test::assembled_box(PETSC_COMM_WORLD, test::box_spec(t, 1.0, 0.2, 0.2, nx, 1, 1));
}

// The basis that spans the whole space: the identity on the free DOFs (n x n, K's row layout).
UMat identity_basis(const Model& b) {
  const PetscInt n = b.dofs.n_global;
  PetscInt first = 0, last = 0;
  MORSE_CALL(MatGetOwnershipRange(b.ops.K.get(), &first, &last));
  UMat V;
  MORSE_CALL(MatCreateDense(PETSC_COMM_WORLD, last - first, PETSC_DECIDE, n, n, nullptr, V.ptr()));
  for (PetscInt i = first; i < last; ++i) MORSE_CALL(MatSetValue(V.get(), i, i, 1.0, INSERT_VALUES));
  MORSE_CALL(MatAssemblyBegin(V.get(), MAT_FINAL_ASSEMBLY));
  MORSE_CALL(MatAssemblyEnd(V.get(), MAT_FINAL_ASSEMBLY));
  return V;
}

// Reference positions of the CB boundary nodes (x y z, in the order of the boundary DOFs), on
// every rank.
std::vector<double> boundary_positions(const Model& m, const cb::CBResult& c) {
  int rank = 0;
  MPI_Comm_rank(PETSC_COMM_WORLD, &rank);
  const std::size_t nb = static_cast<std::size_t>(c.n_b) / 3;
  std::vector<double> X(3 * nb, 0.0);
  for (std::size_t k = 0; k < nb; ++k) {
    const auto loc = m.lm.local_of_global(c.boundary_global_nodes[k]);
    if (loc >= 0 && m.lm.node_owner[loc] == rank)
      for (int d = 0; d < 3; ++d) X[3 * k + d] = m.lm.mesh.coords[3 * loc + d];
  }
  MPI_Allreduce(MPI_IN_PLACE, X.data(), static_cast<int>(X.size()), MPI_DOUBLE, MPI_SUM, PETSC_COMM_WORLD);
  return X;
}

// The contact nodes of the CB boundary, from boundary_positions (node k's u_x is coordinate 3k).
std::vector<sim::ContactNode> boundary_contact_nodes(const std::vector<double>& X) {
  std::vector<sim::ContactNode> nodes(X.size() / 3);
  for (std::size_t k = 0; k < nodes.size(); ++k) {
    nodes[k].dof = 3 * k;
    for (int d = 0; d < 3; ++d) nodes[k].x[d] = X[3 * k + d];
  }
  return nodes;
}

// The reduced model of the CB basis c of the box with exact tensors and modal damping xi on every
// (dynamic) mode; massless: the basis made massless first (nlrom::massless_transform).
nlrom::ReducedModel box_model(const Model& m, const cb::CBResult& c, bool massless, double xi) {
  fe::Svk svk(m.lm, m.dofs, test::steel(), m.ops.K.get());
  const PetscInt r = c.n();
  UMat V;
  PetscInt n_static = 0;
  if (massless) {
    const auto rm0 = nlrom::project_model(PETSC_COMM_WORLD, c.T.get(), m.ops.K.get(), m.ops.M.get(), 0.0, 0);
    V = nlrom::transform_basis(c.T.get(), nlrom::massless_transform(rm0.M, rm0.K, r, c.n_b, 0.0, &n_static));
  }
  Mat basis = massless ? V.get() : c.T.get();
  auto rm = nlrom::project_model(PETSC_COMM_WORLD, basis, m.ops.K.get(), m.ops.M.get(), massless ? 0.0 : xi, r);
  rm.n_b = c.n_b;
  if (massless) nlrom::make_massless(&rm, n_static, xi, r - n_static);
  rm.g = nlrom::exact_forces(svk, basis);
  return rm;
}

// Exact and STEP (1 mm) tensors of a CB basis of the clamped box with r = 30 (12 boundary DOFs
// of face x1 and 18 fixed-interface modes), where every index pattern (repeated, distinct) occurs.
std::pair<nlrom::CubicForce, nlrom::CubicForce> box_forces_r30() {
  auto m = box(ElementType::Hex8, 6);
  fe::Svk svk(m.lm, m.dofs, test::steel(), m.ops.K.get());
  auto c = test::cb_basis(m, "x1", 18);
  MORSE_CHECK(c.n() == 30, "box_forces_r30: the basis has ", c.n(), " columns, not 30");
  nlrom::StepSettings ss;
  ss.displacement = 1e-3;
  return {nlrom::exact_forces(svk, c.T.get()), nlrom::step_forces(svk, c.T.get(), ss)};
}

}  // namespace

TEST(Sim, LinearSuperelementMatchesModalClosedForm) {
  auto m = box(ElementType::Hex8, 4);
  auto c = test::cb_basis(m, "x1", 3);
  auto rm = nlrom::project_model(PETSC_COMM_WORLD, c.T.get(), m.ops.K.get(), m.ops.M.get(), 0.0, 0);
  const std::size_t r = rm.r;
  dyn::NodalLoad l;
  l.set = "x1";
  l.dir[1] = 1.0;
  l.amplitude = 100.0;
  l.omega = 3000.0;
  dyn::Loads loads(m.lm, m.dofs, {l});
  sim::ReducedLoad rl;
  rl.p = nlrom::project_vector(c.T.get(), loads.pattern(0));
  rl.amplitude = l.amplitude;
  rl.omega = l.omega;
  // Closed form: modes of (K~, M~), each driven from rest by A sin(W t).
  std::vector<double> X = rm.K, B = rm.M, w(r), work(64 * r);
  PetscBLASInt n = static_cast<PetscBLASInt>(r), one = 1, lwork = static_cast<PetscBLASInt>(64 * r), info = 0;
  LAPACKsygv_(&one, "V", "U", &n, X.data(), &n, B.data(), &n, w.data(), work.data(), &lwork, &info);
  ASSERT_EQ(info, 0);
  const double W = l.omega, T = 2e-3;
  auto exact = [&](double t) {
    std::vector<double> q(r, 0.0);
    for (std::size_t k = 0; k < r; ++k) {
      const double wk = std::sqrt(w[k]);
      double pk = 0;
      for (std::size_t i = 0; i < r; ++i) pk += X[k * r + i] * rl.p[i];
      const double eta = pk * l.amplitude / (wk * wk - W * W) * (std::sin(W * t) - W / wk * std::sin(wk * t));
      for (std::size_t i = 0; i < r; ++i) q[i] += X[k * r + i] * eta;
    }
    return q;
  };
  const double hc = sim::critical_step(rm);
  EXPECT_NEAR(hc, 2.0 / std::sqrt(w[r - 1]), 1e-12 * hc);
  auto run = [&](double h) {
    sim::Settings s;
    s.dt = h;
    s.t_final = T;
    s.linear = true;
    double err = 0, scale = 0;
    sim::integrate(rm, {rl}, s, [&](const sim::StepState& st) {
      auto q = exact(st.t);
      for (std::size_t i = 0; i < r; ++i) {
        err = std::max(err, std::abs(st.q[i] - q[i]));
        scale = std::max(scale, std::abs(q[i]));
      }
    });
    return err / scale;
  };
  const double h0 = 0.4 * hc;
  const double e1 = run(h0), e2 = run(h0 / 2);
  EXPECT_LT(e2, 5e-3) << "relative error at dt = " << h0 / 2;
  EXPECT_NEAR(e1 / e2, 4.0, 0.4) << "central differences are second order";
  // A step above the critical one is refused, naming the limit.
  sim::Settings bad;
  bad.dt = 1.01 * hc;
  bad.t_final = T;
  bad.linear = true;
  try {
    sim::integrate(rm, {rl}, bad, [](const sim::StepState&) {});
    ADD_FAILURE() << "no error for dt above the critical step";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("critical step"), std::string::npos) << e.what();
  }
}

// Undamped, unforced nonlinear reduced model from a large initial displacement: the central
// difference energy oscillates but does not drift over 10^6 steps.
TEST(Sim, NonlinearEnergyBoundedOverMillionSteps) {
  auto m = box(ElementType::Hex8, 6);
  fe::Svk svk(m.lm, m.dofs, test::steel(), m.ops.K.get());
  // Basis: the 4 fixed-interface columns of a CB basis with boundary x1 (no constraint modes).
  auto c = test::cb_basis(m, "x1", 4);
  UMat V;
  {
    PetscInt ml;
    MORSE_CALL(MatGetLocalSize(c.T.get(), &ml, nullptr));
    MORSE_CALL(MatCreateDense(PETSC_COMM_WORLD, ml, PETSC_DECIDE, m.dofs.n_global, 4, nullptr, V.ptr()));
    for (PetscInt j = 0; j < 4; ++j) {
      Vec a, b;
      MORSE_CALL(MatDenseGetColumnVecRead(c.T.get(), c.n_b + j, &a));
      MORSE_CALL(MatDenseGetColumnVecWrite(V.get(), j, &b));
      MORSE_CALL(VecCopy(a, b));
      MORSE_CALL(MatDenseRestoreColumnVecWrite(V.get(), j, &b));
      MORSE_CALL(MatDenseRestoreColumnVecRead(c.T.get(), c.n_b + j, &a));
    }
  }
  auto rm = nlrom::project_model(PETSC_COMM_WORLD, V.get(), m.ops.K.get(), m.ops.M.get(), 0.0, 0);
  rm.g = nlrom::exact_forces(svk, V.get());
  sim::Settings s;
  s.dt = 0.2 * sim::critical_step(rm);
  s.t_final = 1e6 * s.dt;
  s.q0 = {0.05, 0.02, -0.01, 0.005};  // M-normalized modes: large amplitude (nonlinear regime)
  double e0 = 0, emin = 1e300, emax = 0, early = 0, late = 0, gmax = 0;
  long n_early = 0, n_late = 0;
  std::vector<double> g(4);
  rm.g.evaluate(s.q0.data(), g.data());
  for (double x : g) gmax = std::max(gmax, std::abs(x));
  double kq = 0;
  for (int i = 0; i < 4; ++i) kq = std::max(kq, std::abs(rm.K[i * 4 + i] * s.q0[i]));
  EXPECT_GT(gmax, 1e-3 * kq) << "not in the nonlinear regime";
  auto st = sim::integrate(rm, {}, s, [&](const sim::StepState& x) {
    if (x.step == 0) e0 = x.energy();
    emin = std::min(emin, x.energy());
    emax = std::max(emax, x.energy());
    if (x.step < 10000) early += x.energy(), ++n_early;
    if (x.step >= 990000) late += x.energy(), ++n_late;
  });
  EXPECT_EQ(st.steps, 1000000);
  EXPECT_GT(e0, 0.0);
  // eq. 46's energy omits the nonlinear strain energy, so it oscillates; its bounds and running
  // mean must not drift.
  EXPECT_LT(emax, 2.0 * e0);
  EXPECT_GT(emin, 0.0);
  EXPECT_NEAR(late / n_late, early / n_early, 0.02 * e0) << "energy drift";
}

// A basis that spans the whole space (the identity on the free DOFs) makes the reduced model the
// full model: simulate's central differences and fom's trapezoidal Newton scheme then solve the
// same ODE, and their difference falls as h^2 (both are second order).
TEST(Sim, FullBasisReproducesFullModel) {
  auto b = test::assembled_box(PETSC_COMM_WORLD, test::box_spec(ElementType::Hex8, 1.0, 0.05, 0.05, 4, 1, 1));
  fe::Svk svk(b.lm, b.dofs, test::steel(), b.ops.K.get());
  PetscInt first = 0, last = 0;
  MORSE_CALL(MatGetOwnershipRange(b.ops.K.get(), &first, &last));
  UMat V = identity_basis(b);
  auto rm = nlrom::project_model(PETSC_COMM_WORLD, V.get(), b.ops.K.get(), b.ops.M.get(), 0.0, 0);
  rm.g = nlrom::exact_forces(svk, V.get());
  const double E = test::steel().E, EI = E * std::pow(0.05, 4) / 12.0;
  dyn::NodalLoad l;
  l.set = "x1";
  l.dir[1] = 1.0;
  l.amplitude = 0.5 * EI / static_cast<double>(b.lm.node_set_sizes.at("x1"));
  l.omega = 300.0;
  dyn::Loads loads(b.lm, b.dofs, {l});
  sim::ReducedLoad rl;
  rl.p = nlrom::project_vector(V.get(), loads.pattern(0));
  rl.amplitude = l.amplitude;
  rl.omega = l.omega;
  const double hc = sim::critical_step(rm), T = 6e-3;
  // Histories of the owned DOFs at every step.
  auto run_fom = [&](double h) {
    dyn::FomSettings s;
    s.dt = h;
    s.t_final = T;
    s.newton_rtol = 1e-9;
    std::vector<double> out;
    dyn::integrate(svk, b.ops.M.get(), loads, s, nullptr, nullptr, [&](const dyn::StepInfo& i) {
      const double* a;
      MORSE_CALL(VecGetArrayRead(i.u, &a));
      out.insert(out.end(), a, a + (last - first));
      MORSE_CALL(VecRestoreArrayRead(i.u, &a));
    });
    return out;
  };
  auto run_sim = [&](double h, bool linear, sim::Scheme scheme = sim::Scheme::Central) {
    sim::Settings s;
    s.dt = h;
    s.t_final = T;
    s.linear = linear;
    s.scheme = scheme;
    s.newton_rtol = 1e-9;
    std::vector<double> out;
    sim::integrate(rm, {rl}, s, [&](const sim::StepState& x) { out.insert(out.end(), x.q + first, x.q + last); });
    return out;
  };
  // max_t ||a(t) - b(t)||_inf / max_t ||a(t)||_inf over all ranks.
  auto rel = [&](const std::vector<double>& a, const std::vector<double>& c) {
    double v[2] = {0.0, 0.0};
    for (std::size_t i = 0; i < std::min(a.size(), c.size()); ++i) {
      v[0] = std::max(v[0], std::abs(a[i] - c[i]));
      v[1] = std::max(v[1], std::abs(a[i]));
    }
    if (a.size() != c.size()) v[0] = 1e300;
    MPI_Allreduce(MPI_IN_PLACE, v, 2, MPI_DOUBLE, MPI_MAX, PETSC_COMM_WORLD);
    return v[0] / v[1];
  };
  const double h = 0.5 * hc;
  const auto f1 = run_fom(h), f2 = run_fom(h / 2);
  const auto s1 = run_sim(h, false), s2 = run_sim(h / 2, false), lin = run_sim(h / 2, true);
  const double d1 = rel(f1, s1), d2 = rel(f2, s2), nl = rel(s2, lin);
  print0(PETSC_COMM_WORLD, "  simulate vs fom: %.3e at dt, %.3e at dt/2 (ratio %.2f); nonlinear effect %.3e\n", d1, d2,
         d1 / d2, nl);
  EXPECT_LT(d2, 1e-5) << "simulate vs fom at dt = " << h / 2;
  EXPECT_GT(nl, 20.0 * d2) << "not a nonlinear test: the linear model is as close as the integrator error";
  EXPECT_NEAR(d1 / d2, 4.0, 0.4) << "the difference does not fall as dt^2 (" << d1 << ", " << d2 << ")";
  // The implicit scheme is fom's scheme: the same discrete solution (to the Newton tolerances),
  // also at 8 times the critical step of central differences.
  const auto f8 = run_fom(8 * hc);
  const double t1 = rel(f1, run_sim(h, false, sim::Scheme::Trapezoidal));
  const double t8 = rel(f8, run_sim(8 * hc, false, sim::Scheme::Trapezoidal));
  print0(PETSC_COMM_WORLD, "  trapezoidal simulate vs fom: %.3e at dt, %.3e at 8 x critical step\n", t1, t8);
  EXPECT_LT(t1, 1e-7);
  EXPECT_LT(t8, 1e-7);
}

// The two storages of the nonlinear force give the same P3 g~(q): the potential form of exact
// tensors (asymmetry at round-off) and of STEP tensors (its identification error), against the
// folded product, at r = 30 where every index pattern (repeated, distinct) occurs. A force that
// is no gradient (A perturbed) falls back to the folded form under Auto and is refused under
// Potential.
TEST(Sim, PotentialKernelMatchesFolded) {
  const std::size_t r = 30;
  const auto [exact, step] = box_forces_r30();
  std::vector<double> P3(r * r);
  for (std::size_t i = 0; i < r * r; ++i) P3[i] = std::sin(1.0 + 0.37 * static_cast<double>(i));  // any matrix
  std::vector<double> q(r), y1(r), y2(r);
  for (std::size_t i = 0; i < r; ++i) q[i] = 1e-3 * std::cos(0.9 * static_cast<double>(i) + 0.2);
  auto compare = [&](const nlrom::CubicForce& g, double tol) {
    sim::CubicKernel folded(g, P3, sim::KernelLayout::Folded), pot(g, P3, sim::KernelLayout::Potential);
    EXPECT_FALSE(folded.potential());
    EXPECT_TRUE(pot.potential());
    EXPECT_LT(pot.bytes(), folded.bytes() / 3.0);  // 4r / (r + 3) asymptotically
    folded.apply(q.data(), y1.data());
    pot.apply(q.data(), y2.data());
    double d = 0, s = 0;
    for (std::size_t i = 0; i < r; ++i) d = std::max(d, std::abs(y1[i] - y2[i])), s = std::max(s, std::abs(y1[i]));
    EXPECT_GT(s, 0.0);
    EXPECT_LT(d, tol * s) << "potential vs folded kernel, asymmetry " << pot.asymmetry();
    return pot.asymmetry();
  };
  EXPECT_LT(compare(exact, 1e-12), 1e-12);
  EXPECT_LT(compare(step, 1e-7), 1e-6);
  auto bad = exact;
  bad.A[5 * r + 7] += 1e-3 * bad.max_abs_A();
  sim::CubicKernel fallback(bad, P3, sim::KernelLayout::Auto);
  EXPECT_FALSE(fallback.potential());
  EXPECT_GT(fallback.asymmetry(), 1e-6);
  EXPECT_THROW(sim::CubicKernel(bad, P3, sim::KernelLayout::Potential), Error);
}

// The batched potential kernel (CubicKernelBatch) against the reference O(r^4) loops of
// CubicForce, P3 g~(q), lane by lane, at r = 30 (every index pattern; triangles of every size, so
// every partial row block of 1..3 rows) and r = 7: 12 lanes of different q in 3 groups, scattered
// in a wider array. Each lane's bits do not depend on its group's partner, position or order (a
// pair of groups, 3 rows at a time; a group alone, 4 rows at a time), and equal those of the
// single-speed kernel (CubicKernel, scalar). Float coefficients differ from double by their
// rounding only.
TEST(Sim, BatchedPotentialKernelMatchesReferenceAndIsBitwisePerLane) {
  const auto [exact, step] = box_forces_r30();
  for (const nlrom::CubicForce* force : {&exact, &step}) {
    for (std::size_t r : {std::size_t{30}, std::size_t{7}}) {
      nlrom::CubicForce g = *force;
      if (r < g.r) {  // the leading r x r block of coordinates: the tensors of the first r modes
        nlrom::CubicForce h;
        h.r = r;
        h.A.assign(nlrom::n_quadratic(r) * r, 0.0), h.B.assign(nlrom::n_cubic(r) * r, 0.0);
        std::size_t m = 0, m2 = 0;
        for (std::size_t i = 0; i < g.r; ++i)
          for (std::size_t j = i; j < g.r; ++j, ++m)
            if (j < r) {
              for (std::size_t p = 0; p < r; ++p) h.A[m2 * r + p] = g.A[m * g.r + p];
              ++m2;
            }
        m = 0, m2 = 0;
        for (std::size_t i = 0; i < g.r; ++i)
          for (std::size_t j = i; j < g.r; ++j)
            for (std::size_t k = j; k < g.r; ++k, ++m)
              if (k < r) {
                for (std::size_t p = 0; p < r; ++p) h.B[m2 * r + p] = g.B[m * g.r + p];
                ++m2;
              }
        g = std::move(h);
      }
      std::vector<double> P3(r * r);
      for (std::size_t i = 0; i < r * r; ++i) P3[i] = std::sin(1.0 + 0.37 * static_cast<double>(i));
      const sim::CubicKernel pot(g, P3, sim::KernelLayout::Potential);
      const sim::CubicKernelBatch batch(pot), single(pot, true);
      EXPECT_EQ(single.bytes(), batch.bytes() / 2);
      const std::size_t L = 16, lanes = 12;  // groups 0, 1, 2 used; group 3 must stay untouched
      std::vector<double> Q(r * L, 0.0), Y(r * L, 7.0);
      for (std::size_t j = 0; j < r; ++j)
        for (std::size_t l = 0; l < lanes; ++l)
          Q[j * L + l] = 1e-3 * std::cos(0.9 * static_cast<double>(j) + 0.31 * static_cast<double>(l) + 0.2);
      const std::size_t all[3] = {0, 1, 2};
      batch.apply(L, all, 3, Q.data(), Y.data());
      double worst = 0.0;
      std::vector<double> q(r), gq(r);
      for (std::size_t l = 0; l < lanes; ++l) {
        for (std::size_t j = 0; j < r; ++j) q[j] = Q[j * L + l];
        g.evaluate(q.data(), gq.data());
        double d = 0.0, scale = 0.0;
        for (std::size_t p = 0; p < r; ++p) {
          double y = 0.0;
          for (std::size_t k = 0; k < r; ++k) y += P3[p * r + k] * gq[k];
          d = std::max(d, std::abs(Y[p * L + l] - y)), scale = std::max(scale, std::abs(y));
        }
        ASSERT_GT(scale, 0.0);
        worst = std::max(worst, d / scale);
      }
      // STEP tensors are a potential only to their identification error: the batched kernel
      // evaluates the nearest potential, as CubicKernel does.
      const double tol = force == &exact ? 1e-12 : 10.0 * pot.asymmetry() + 1e-12;
      EXPECT_LT(worst, tol) << "r " << r << (force == &exact ? " exact" : " STEP");
      for (std::size_t j = 0; j < r; ++j)
        for (std::size_t l = lanes; l < L; ++l) EXPECT_EQ(Y[j * L + l], 7.0) << "a group not listed was written";
      // The same lanes in other passes: each group alone (one group, 4 rows at a time), and the
      // groups in another order (group 2 paired with group 0, group 1 alone).
      std::vector<double> Y1(r * L, 0.0), Y2(r * L, 0.0);
      for (std::size_t gi = 0; gi < 3; ++gi) batch.apply(L, &all[gi], 1, Q.data(), Y1.data());
      const std::size_t reordered[3] = {2, 0, 1};
      batch.apply(L, reordered, 3, Q.data(), Y2.data());
      bool same = true;
      for (std::size_t j = 0; j < r; ++j)
        for (std::size_t l = 0; l < lanes; ++l)
          same = same && Y1[j * L + l] == Y[j * L + l] && Y2[j * L + l] == Y[j * L + l];
      EXPECT_TRUE(same) << "a lane's bits depend on the groups beside it (r " << r << ")";
      // The single-speed kernel (CubicKernel, `morse simulate`) applies the same bits to each lane.
      bool single_same = true;
      std::vector<double> y1(r);
      for (std::size_t l = 0; l < lanes; ++l) {
        for (std::size_t j = 0; j < r; ++j) q[j] = Q[j * L + l];
        pot.apply(q.data(), y1.data());
        for (std::size_t j = 0; j < r; ++j) single_same = single_same && y1[j] == Y[j * L + l];
      }
      EXPECT_TRUE(single_same) << "the single-speed kernel differs from the batched one (r " << r << ")";
      // Float coefficients: |c - fl(c)| <= 2^-24 |c|, so each output moves by at most 2^-24 times
      // the sum of its terms' magnitudes (bounded here by 100 times the output scale), and it moves.
      std::vector<double> Yf(r * L, 0.0);
      single.apply(L, all, 3, Q.data(), Yf.data());
      double df = 0.0, sf = 0.0;
      for (std::size_t j = 0; j < r; ++j)
        for (std::size_t l = 0; l < lanes; ++l)
          df = std::max(df, std::abs(Yf[j * L + l] - Y[j * L + l])), sf = std::max(sf, std::abs(Y[j * L + l]));
      EXPECT_LT(df, 100.0 * std::ldexp(1.0, -24) * sf) << "float coefficients, r " << r;
      EXPECT_GT(df, 0.0) << "float coefficients give double results";
      print0(PETSC_COMM_WORLD, "  batched potential kernel, r = %zu (%s): %.2e of the reference; float %.2e\n", r,
             force == &exact ? "exact" : "STEP", worst, df / sf);
    }
  }
  // A force that is no gradient has no potential kernel to batch.
  auto bad = exact;
  bad.A[5 * 30 + 7] += 1e-3 * bad.max_abs_A();
  std::vector<double> P3(900, 0.5);
  EXPECT_THROW(sim::CubicKernelBatch(sim::CubicKernel(bad, P3, sim::KernelLayout::Auto)), Error);
}

// The batched potential kernel's builds for each instruction set (AVX-512: 4 groups in two 8-lane
// registers, 6 rows at a time, then pairs of groups in one register 12 rows at a time; AVX2: pairs
// of groups 3 rows at a time; a last single group 4 rows at a time in both), in double and in float
// coefficients: for 20 lanes in 5 groups (every pass shape), for subsets and orders of the groups
// that put each lane in another pass shape, every lane's bits equal those of the single-speed
// kernel (CubicKernel, `morse simulate`) on every build that fuses multiply-adds, and the float
// builds agree bitwise. The baseline build (products and sums rounded apart) is checked against
// the reference loops and for its own lane-by-lane bits. A build the processor lacks is refused.
// V(q) of the batched kernel's coefficients is the potential of the reference force g~ = A(q, q) +
// B(q, q, q): Euler's theorem on its homogeneous parts (V = q.A(q, q)/3 + q.B(q, q, q)/4) and its
// derivative along a direction d (central differences against d.g~(q), error O(eps^2): halving eps
// divides it by 4). Float coefficients: within their rounding.
TEST(Sim, BatchedKernelPotentialIsTheEnergyOfItsForce) {
  const auto [exact, step] = box_forces_r30();
  const std::size_t r = 30;
  std::vector<double> P3(r * r, 0.0);
  for (std::size_t i = 0; i < r; ++i) P3[i * r + i] = 1.0;
  std::vector<double> q(r), d(r), qn(r), gp(r), gm(r), qa(r), qb(r);
  for (std::size_t j = 0; j < r; ++j) {
    q[j] = 1e-3 * std::sin(0.7 * static_cast<double>(j) + 0.1), qn[j] = -q[j];
    d[j] = std::cos(1.3 * static_cast<double>(j) + 0.4);
  }
  for (const nlrom::CubicForce* force : {&exact, &step}) {
    const sim::CubicKernel pot(*force, P3, sim::KernelLayout::Potential);
    force->evaluate(q.data(), gp.data());
    force->evaluate(qn.data(), gm.data());
    double euler = 0.0, dg = 0.0;
    for (std::size_t i = 0; i < r; ++i)
      euler += q[i] * ((gp[i] + gm[i]) / 6.0 + (gp[i] - gm[i]) / 8.0), dg += d[i] * gp[i];
    const sim::CubicKernelBatch b(pot), f(pot, true);
    const double V = b.potential(q.data()), Vf = f.potential(q.data());
    EXPECT_GT(std::abs(V), 0.0);
    EXPECT_LE(std::abs(V - euler), 1e-12 * std::abs(euler)) << V << " against " << euler;
    EXPECT_LE(std::abs(Vf - euler), 1e-6 * std::abs(euler)) << Vf << " against " << euler;
    double err[2];
    for (int k = 0; k < 2; ++k) {
      const double eps = 1e-7 / (1 << k);  // 1e-4 of q: truncation (1e-8) far above round-off
      for (std::size_t j = 0; j < r; ++j) qa[j] = q[j] + eps * d[j], qb[j] = q[j] - eps * d[j];
      err[k] = std::abs((b.potential(qa.data()) - b.potential(qb.data())) / (2 * eps) - dg);
    }
    EXPECT_LE(err[0], 1e-7 * std::abs(dg)) << err[0] << " against " << dg;
    EXPECT_NEAR(err[0] / err[1], 4.0, 0.2) << err[0] << ", " << err[1];
    print0(PETSC_COMM_WORLD, "  %s: V %.6e, Euler %.6e (float %.1e off), dV/ds error %.2e then %.2e (d.g %.3e)\n",
           force == &exact ? "exact" : "STEP", V, euler, std::abs(Vf - euler) / std::abs(euler), err[0], err[1], dg);
  }
}

TEST(Sim, BatchedPotentialKernelIsBitwiseTheSameOnEveryInstructionSet) {
  const auto [exact, step] = box_forces_r30();
  const std::size_t r = 30, L = 24, lanes = 20;  // groups 0..4 used; group 5 must stay untouched
  std::vector<double> P3(r * r);
  for (std::size_t i = 0; i < r * r; ++i) P3[i] = std::cos(0.3 + 0.41 * static_cast<double>(i));
  std::vector<double> Q(r * L, 0.0);
  for (std::size_t j = 0; j < r; ++j)
    for (std::size_t l = 0; l < lanes; ++l)
      Q[j * L + l] = 1e-3 * std::sin(0.7 * static_cast<double>(j) + 0.23 * static_cast<double>(l) + 0.1);
  const std::vector<std::vector<std::size_t>> passes = {
      {0, 1, 2, 3, 4}, {4, 2, 0, 3, 1}, {0, 1, 2, 3}, {1, 3}, {2, 4, 0}, {4}, {3, 1, 0, 2}};
  // Y of the listed groups, each pass in turn (a group in several passes: its latest).
  auto run = [&](const sim::CubicKernelBatch& b, const std::vector<std::size_t>& groups) {
    std::vector<double> Y(r * L, 7.0);
    b.apply(L, groups.data(), groups.size(), Q.data(), Y.data());
    return Y;
  };
  // Whether every pass of `passes` gives each of its lanes the bits of Yall.
  auto same_in_every_pass = [&](const sim::CubicKernelBatch& b, const std::vector<double>& Yall) {
    bool same = true;
    for (const auto& groups : passes) {
      const auto Y = run(b, groups);
      for (std::size_t g : groups)
        for (std::size_t j = 0; j < r; ++j)
          for (std::size_t l = 4 * g; l < 4 * g + 4; ++l) same = same && Y[j * L + l] == Yall[j * L + l];
    }
    return same;
  };
  const bool fused = sim::kernel_isa_supported(sim::KernelIsa::Avx2);
  if (!sim::kernel_isa_supported(sim::KernelIsa::Avx512))
    print0(PETSC_COMM_WORLD, "  NOTICE: this processor has no AVX-512: that build of the kernel is not run here\n");
  for (const nlrom::CubicForce* force : {&exact, &step}) {
    const sim::CubicKernel pot(*force, P3, sim::KernelLayout::Potential);
    std::vector<double> lane(r * lanes), q(r), y(r);  // the single-speed kernel, lane by lane
    for (std::size_t l = 0; l < lanes; ++l) {
      for (std::size_t j = 0; j < r; ++j) q[j] = Q[j * L + l];
      pot.apply(q.data(), y.data());
      for (std::size_t j = 0; j < r; ++j) lane[j * lanes + l] = y[j];
    }
    std::vector<double> float_ref;  // the first fused build's float result (all 5 groups)
    for (sim::KernelIsa isa : {sim::KernelIsa::Avx512, sim::KernelIsa::Avx2, sim::KernelIsa::Baseline}) {
      sim::CubicKernelBatch b(pot), f(pot, true);
      if (!sim::kernel_isa_supported(isa)) {
        EXPECT_THROW(b.set_isa(isa), Error) << sim::kernel_isa_name(isa);
        continue;
      }
      b.set_isa(isa), f.set_isa(isa);
      EXPECT_EQ(b.isa(), isa);
      const bool fuses = isa != sim::KernelIsa::Baseline;
      const auto Yall = run(b, passes[0]);
      double worst = 0.0, scale = 0.0;
      bool same_lane = true, untouched = true;
      for (std::size_t j = 0; j < r; ++j) {
        for (std::size_t l = 0; l < lanes; ++l) {
          const double y_ref = lane[j * lanes + l];
          same_lane = same_lane && Yall[j * L + l] == y_ref;
          worst = std::max(worst, std::abs(Yall[j * L + l] - y_ref)), scale = std::max(scale, std::abs(y_ref));
        }
        for (std::size_t l = lanes; l < L; ++l) untouched = untouched && Yall[j * L + l] == 7.0;
      }
      EXPECT_TRUE(untouched) << sim::kernel_isa_name(isa) << ": a group not listed was written";
      EXPECT_TRUE(same_in_every_pass(b, Yall))
          << sim::kernel_isa_name(isa) << ": a lane's bits depend on the groups beside it";
      if (fuses && fused)
        EXPECT_TRUE(same_lane) << sim::kernel_isa_name(isa) << ": not the single-speed kernel's bits";
      else  // products and sums rounded apart: the same sums, rounded otherwise
        EXPECT_LT(worst, 1e-12 * scale) << sim::kernel_isa_name(isa);
      // Float coefficients: the same conversion (exact) and the same fused operations on every build.
      const auto Yf = run(f, passes[0]);
      if (fuses) {
        if (float_ref.empty()) float_ref = Yf;
        EXPECT_TRUE(Yf == float_ref) << sim::kernel_isa_name(isa) << ": float coefficients differ between builds";
      }
      EXPECT_TRUE(same_in_every_pass(f, Yf))
          << sim::kernel_isa_name(isa) << ": float lanes depend on the groups beside them";
      print0(PETSC_COMM_WORLD, "  %s, %s tensors: %s the single-speed kernel (%.1e)\n", sim::kernel_isa_name(isa),
             force == &exact ? "exact" : "STEP", same_lane ? "bitwise" : "not bitwise", worst / scale);
    }
  }
  EXPECT_NE(sim::best_kernel_isa() == sim::KernelIsa::Avx512, !sim::kernel_isa_supported(sim::KernelIsa::Avx512));
}

// The implicit scheme's one-pass force and tangent (TangentKernel: Euler's theorem on the
// homogeneous parts, the symmetric fourth-derivative storage when g~ is a gradient) against the
// reference O(r^4) loops of CubicForce, and the tangent of those against central differences of
// g~ (exact for the quadratic part; the cubic part's error is eps^2/6 times its third
// derivative). At r = 30 (465 pairs, padded to 30 panels of 16) every index pattern occurs. Exact
// tensors and STEP take the symmetric path, a force that is no gradient the general one.
TEST(Sim, TangentKernelMatchesReference) {
  const std::size_t r = 30;
  const auto [exact, step] = box_forces_r30();
  auto bad = exact;
  bad.A[5 * r + 7] += 1e-3 * bad.max_abs_A();
  bad.B[40 * r + 3] += 1e-3 * bad.max_abs_B();
  std::vector<double> q(r), g1(r), g2(r), J1(r * r), J2(r * r);
  for (std::size_t i = 0; i < r; ++i) q[i] = 1e-3 * std::cos(0.9 * static_cast<double>(i) + 0.2);
  auto maxabs = [](const std::vector<double>& x) {
    double v = 0;
    for (double a : x) v = std::max(v, std::abs(a));
    return v;
  };
  auto dist = [](const std::vector<double>& x, const std::vector<double>& y) {
    double v = 0;
    for (std::size_t i = 0; i < x.size(); ++i) v = std::max(v, std::abs(x[i] - y[i]));
    return v;
  };
  auto check = [&](const nlrom::CubicForce& g, bool symmetric, double tol) {
    sim::TangentKernel t(g);
    EXPECT_EQ(t.symmetric(), symmetric) << "asymmetry " << t.asymmetry();
    t.apply(q.data(), g1.data(), J1.data());
    g.evaluate(q.data(), g2.data());
    g.jacobian(q.data(), J2.data());
    EXPECT_GT(maxabs(g2), 0.0);
    EXPECT_LT(dist(g1, g2), tol * maxabs(g2)) << "g, asymmetry " << t.asymmetry();
    EXPECT_LT(dist(J1, J2), tol * maxabs(J2)) << "dg/dq, asymmetry " << t.asymmetry();
    // The reference tangent against central differences of the reference force.
    const double eps = 1e-4 * maxabs(q);
    std::vector<double> qp = q, qm = q, gp(r), gm(r);
    double d = 0.0;
    for (std::size_t k = 0; k < r; ++k) {
      qp[k] += eps, qm[k] -= eps;
      g.evaluate(qp.data(), gp.data());
      g.evaluate(qm.data(), gm.data());
      qp[k] = qm[k] = q[k];
      for (std::size_t p = 0; p < r; ++p) d = std::max(d, std::abs((gp[p] - gm[p]) / (2 * eps) - J2[p * r + k]));
    }
    EXPECT_LT(d, 1e-6 * maxabs(J2)) << "CubicForce::jacobian against central differences";
    return t.asymmetry();
  };
  EXPECT_LT(check(exact, true, 1e-12), 1e-12);
  EXPECT_LT(check(step, true, 1e-7), 1e-6);  // symmetrized: within STEP's identification error
  EXPECT_GT(check(bad, false, 1e-12), 1e-6);
}

// Contact with a rigid plane (Lagrange multipliers, eq. 42). A heavily damped linear CB model of
// the clamped box, pushed axially at its free face x1 against a plane at x = 1 + delta: every
// gap stays >= 0 to round-off, every multiplier is compressive, and the state settles on the
// static solution of the constrained problem [K E; E^T 0][q; lambda] = [f; delta] solved
// directly. With friction and a transverse load, friction does negative work and holds the face
// back.
TEST(Sim, ContactWithRigidPlane) {
  auto m = box(ElementType::Hex8, 4);
  auto c = test::cb_basis(m, "x1", 3);
  const std::size_t r = static_cast<std::size_t>(c.n()), nb = static_cast<std::size_t>(c.n_b) / 3;
  auto rm =
      nlrom::project_model(PETSC_COMM_WORLD, c.T.get(), m.ops.K.get(), m.ops.M.get(), 0.5, static_cast<PetscInt>(r));
  dyn::NodalLoad lx;
  lx.set = "x1";
  lx.dir[0] = 1.0;
  lx.amplitude = 1e7;
  dyn::Loads loads(m.lm, m.dofs, {lx});
  sim::ReducedLoad rl;
  rl.p = nlrom::project_vector(c.T.get(), loads.pattern(0));
  rl.amplitude = lx.amplitude;
  // Free static axial displacement of the first face node; the plane stops it at half of it.
  std::vector<double> K = rm.K, f(r);
  for (std::size_t i = 0; i < r; ++i) f[i] = rl.amplitude * rl.p[i];
  auto solve = [](std::vector<double> A, std::vector<double> b) {
    PetscBLASInt n = static_cast<PetscBLASInt>(b.size()), one = 1, info = 0;
    std::vector<PetscBLASInt> piv(b.size());
    LAPACKgesv_(&n, &one, A.data(), &n, piv.data(), b.data(), &n, &info);  // A symmetric: layout moot
    EXPECT_EQ(info, 0);
    return b;
  };
  const auto qfree = solve(K, f);
  const double delta = 0.5 * qfree[0];
  ASSERT_GT(delta, 0.0);
  sim::Settings s;
  s.linear = true;
  s.dt = 0.5 * sim::critical_step(rm);
  s.t_final = 0.03;
  s.contact.mu = 0.0;
  s.contact.plane.point[0] = 1.0 + delta;
  s.contact.plane.normal[2] = 0.0;
  s.contact.plane.normal[0] = -1.0;
  for (std::size_t k = 0; k < nb; ++k) {
    sim::ContactNode node;
    node.dof = 3 * k;
    node.x[0] = 1.0;  // every x1 node has x = 1
    s.contact.nodes.push_back(node);
  }
  double min_gap = 1e300, min_lam = 1e300;
  int max_active = 0;
  std::vector<double> qT(r), lamT(nb);
  sim::integrate(rm, {rl}, s, [&](const sim::StepState& x) {
    for (std::size_t k = 0; k < nb; ++k) {
      min_gap = std::min(min_gap, x.gap[k]);
      min_lam = std::min(min_lam, x.contact_normal[k]);
      lamT[k] = x.contact_normal[k];
    }
    max_active = std::max(max_active, x.active);
    std::copy(x.q, x.q + r, qT.begin());
  });
  EXPECT_EQ(max_active, static_cast<int>(nb));
  EXPECT_GE(min_gap, -1e-12 * delta) << "penetration";
  EXPECT_GE(min_lam, 0.0) << "tensile contact force";
  // The constrained static solution, solved directly.
  const std::size_t nz = r + nb;
  std::vector<double> B(nz * nz, 0.0), rhs(nz, 0.0);
  for (std::size_t i = 0; i < r; ++i) {
    for (std::size_t j = 0; j < r; ++j) B[i * nz + j] = K[i * r + j];
    rhs[i] = f[i];
  }
  for (std::size_t k = 0; k < nb; ++k) {
    B[(3 * k) * nz + r + k] = B[(r + k) * nz + 3 * k] = 1.0;
    rhs[r + k] = delta;
  }
  const auto z = solve(B, rhs);
  double dq = 0, sq = 0, dl = 0, sl = 0;
  for (std::size_t i = 0; i < r; ++i) dq = std::max(dq, std::abs(qT[i] - z[i])), sq = std::max(sq, std::abs(z[i]));
  for (std::size_t k = 0; k < nb; ++k)
    dl = std::max(dl, std::abs(lamT[k] - z[r + k])), sl = std::max(sl, std::abs(z[r + k]));
  print0(PETSC_COMM_WORLD,
         "  contact: r = %zu, %zu nodes, delta %.3e m, min gap %.2e, final state vs statics %.2e, forces %.2e\n", r, nb,
         delta, min_gap, dq / sq, dl / sl);
  EXPECT_LT(dq, 1e-6 * sq) << "final state vs constrained statics";
  EXPECT_LT(dl, 1e-5 * sl) << "contact forces vs constrained statics";
  // Friction: a transverse load at the face; friction opposes sliding (negative work) and holds
  // the face back compared with the frictionless run.
  dyn::NodalLoad ly = lx;
  ly.dir[0] = 0.0;
  ly.dir[1] = 1.0;
  ly.amplitude = 2e6;
  dyn::Loads loads_y(m.lm, m.dofs, {ly});
  sim::ReducedLoad rly;
  rly.p = nlrom::project_vector(c.T.get(), loads_y.pattern(0));
  rly.amplitude = ly.amplitude;
  auto slide = [&](double mu, double* work) {
    sim::Settings sf = s;
    sf.contact.mu = mu;
    sf.t_final = 0.01;
    double uy = 0.0, w = 0.0;
    sim::integrate(rm, {rl, rly}, sf, [&](const sim::StepState& x) {
      for (std::size_t k = 0; k < nb; ++k)
        for (int d = 0; d < 3; ++d) w += x.contact_friction[3 * k + d] * x.v[3 * k + d] * sf.dt;
      uy = x.q[1];
    });
    *work = w;
    return uy;
  };
  double w0 = 0, w1 = 0;
  const double uy0 = slide(0.0, &w0), uy1 = slide(0.3, &w1);
  print0(PETSC_COMM_WORLD, "  friction: work %.3e J, u_y %.3e (mu = 0.3) vs %.3e (mu = 0)\n", w1, uy1, uy0);
  EXPECT_EQ(w0, 0.0);
  EXPECT_LT(w1, 0.0) << "friction must dissipate";
  EXPECT_LT(std::abs(uy1), std::abs(uy0)) << "friction must hold the face back";
  // Bad input is refused with a message naming it.
  sim::Settings bad = s;
  bad.contact.plane.normal[0] = -2.0;
  EXPECT_THROW(sim::integrate(rm, {rl}, bad, [](const sim::StepState&) {}), Error);
  bad = s;
  bad.contact.mu = -0.1;
  EXPECT_THROW(sim::integrate(rm, {rl}, bad, [](const sim::StepState&) {}), Error);
  bad = s;
  bad.contact.nodes[0].dof = r;
  EXPECT_THROW(sim::integrate(rm, {rl}, bad, [](const sim::StepState&) {}), Error);
}

// The seed's casing (eq. 52-53) at rest (omega = 0) with wide bumps that grow in time: it pushes
// the free face of the damped box inward; no node penetrates, and every node in contact at the
// end sits exactly on the casing, u . e_r = c0 - (1 - exp(-alpha T)) f(theta) (eq. 53 with g = 0).
// (Friction along e_theta tilts the stiff face, so only some face nodes stay in contact.)
TEST(Sim, ContactWithGrowingCasing) {
  auto m = box(ElementType::Hex8, 4);
  auto c = test::cb_basis(m, "x1", 3);
  const std::size_t r = static_cast<std::size_t>(c.n()), nb = static_cast<std::size_t>(c.n_b) / 3;
  auto rm =
      nlrom::project_model(PETSC_COMM_WORLD, c.T.get(), m.ops.K.get(), m.ops.M.get(), 0.5, static_cast<PetscInt>(r));
  // Reference positions of the boundary nodes (in the order of the boundary DOFs), from every rank.
  int rank = 0;
  MPI_Comm_rank(PETSC_COMM_WORLD, &rank);
  const auto X = boundary_positions(m, c);
  sim::Settings s;
  s.linear = true;
  s.dt = 0.5 * sim::critical_step(rm);
  s.t_final = 0.03;
  s.contact.obstacle = sim::Obstacle::Casing;
  s.contact.casing.clearance = 1e-3;
  s.contact.casing.bump_height = 2e-3;
  s.contact.casing.width = 10.0;
  s.contact.nodes = boundary_contact_nodes(X);
  double min_gap = 1e300;
  int active = 0;
  std::vector<double> qT(r), gT(nb), lT(nb);
  sim::integrate(rm, {}, s, [&](const sim::StepState& x) {
    for (std::size_t k = 0; k < nb; ++k)
      min_gap = std::min(min_gap, x.gap[k]), gT[k] = x.gap[k], lT[k] = x.contact_normal[k];
    active = x.active;
    std::copy(x.q, x.q + r, qT.begin());
  });
  EXPECT_GE(min_gap, -1e-15) << "penetration";
  EXPECT_GE(active, 1) << "the grown bumps should hold the face";
  const double alpha = std::log(100.0) / (0.2 * s.t_final), grow = 1.0 - std::exp(-alpha * s.t_final);
  double worst = 0.0;
  for (std::size_t k = 0; k < nb; ++k) {
    const double rho = std::hypot(X[3 * k], X[3 * k + 1]), theta = std::atan2(X[3 * k + 1], X[3 * k]);
    double th = std::fmod(theta, M_PI);
    if (th < 0) th += M_PI;
    const double f = 2e-3 * std::exp(-std::pow((th - M_PI / 2) / 10.0, 2));
    const double ur = (qT[3 * k] * X[3 * k] + qT[3 * k + 1] * X[3 * k + 1]) / rho;
    if (lT[k] > 0.0)
      worst = std::max(worst, std::abs(ur - (1e-3 - grow * f)));
    else
      EXPECT_GE(gT[k], 0.0);
  }
  EXPECT_LT(worst, 1e-12) << "nodes in contact are not on the casing";
  print0(PETSC_COMM_WORLD, "  casing: %d of %zu nodes in contact, |u_r - (c0 - f)| <= %.2e m, min gap %.2e\n", active,
         nb, worst, min_gap);
}

// The amplitude spectrum of a sampled sinusoid (Hann window): a at its frequency, and a constant
// offset removed; decimation by block means (the sweep's) against plain decimation.
TEST(Sim, AmplitudeSpectrumOfSinusoid) {
  const double dt = 1e-4, f0 = 250.0, a = 3e-4;
  std::vector<double> x(20000);
  for (std::size_t k = 0; k < x.size(); ++k) x[k] = 0.7 + a * std::sin(2 * M_PI * f0 * k * dt + 0.3);
  std::vector<double> f = {0.0, 100.0, 250.0, 400.0};
  auto A = sim::amplitude_spectrum(x, dt, f);
  EXPECT_NEAR(A[2], a, 2e-4 * a);
  EXPECT_LT(A[0], 1e-6 * a);
  EXPECT_LT(A[1], 1e-4 * a);
  EXPECT_LT(A[3], 1e-4 * a);
  // Decimation by 40 (Nyquist 12.5 kHz) of 3 kHz plus a tone at 24 kHz, which plain decimation
  // folds onto 1 kHz at full amplitude: block means keep the 3 kHz amplitude (after the gain
  // correction) and attenuate the folded tone by |sin(pi f' s h) / (s sin(pi f' h))| = 0.042.
  const double h = 1e-6, b = 2e-4;
  const long s = 40;
  std::vector<double> y(400000), means, plain;
  for (std::size_t k = 0; k < y.size(); ++k)
    y[k] = a * std::sin(2 * M_PI * 3000.0 * k * h + 0.3) + b * std::sin(2 * M_PI * 24000.0 * k * h + 1.1);
  for (std::size_t j = 0; j + s <= y.size(); j += s) {
    double m = 0;
    for (long k = 0; k < s; ++k) m += y[j + k];
    means.push_back(m / s);
    plain.push_back(y[j]);
  }
  const std::vector<double> fd = {1000.0, 3000.0};
  const auto D = sim::decimated_spectrum(means, h, s, fd);
  const auto P = sim::amplitude_spectrum(plain, s * h, fd);
  EXPECT_NEAR(P[0], b, 1e-3 * b) << "plain decimation folds 24 kHz onto 1 kHz";
  EXPECT_NEAR(D[1], a, 1e-3 * a);
  const double gain = std::abs(std::sin(M_PI * 24000.0 * s * h) / (s * std::sin(M_PI * 24000.0 * h)));
  const double gain1 = std::abs(std::sin(M_PI * 1000.0 * s * h) / (s * std::sin(M_PI * 1000.0 * h)));
  EXPECT_NEAR(D[0], b * gain / gain1, 1e-3 * b);
  EXPECT_LT(D[0], 0.05 * b);
}

// The sweep's spectrum over bins much wider than the window's resolution 1 / T (the seed's 200
// revolutions on 20 Hz bins: T = 0.37 s at 1,700 rad/s, 1 / T = 2.7 Hz): a line anywhere between
// two bin frequencies keeps its amplitude to within the Hann window's loss at 1 / (8 T), 1 %, and
// is not smeared onto bins beyond its main lobe; the spectrum sampled at the bin frequencies alone
// loses a line 10 Hz from them (the window's transform there is a sidelobe).
TEST(Sim, BinnedSpectrumKeepsALineBetweenItsFrequencies) {
  const double h = 2e-4, T = 0.37, a = 1e-4;
  const long n = std::lround(T / h);
  std::vector<double> f;
  for (int b = 0; b <= 100; ++b) f.push_back(20.0 * b);  // 0 .. 2 kHz every 20 Hz
  double worst = 1.0;
  for (const double d : {0.0, 1.3, 2.5, 5.0, 7.5, 10.0, -4.1, -9.9}) {
    const double f0 = 1620.0 + d;
    std::vector<double> x(static_cast<std::size_t>(n));
    for (long k = 0; k < n; ++k) x[static_cast<std::size_t>(k)] = 0.3 * a + a * std::sin(2 * M_PI * f0 * k * h + 0.7);
    const auto B = sim::binned_spectrum(x, h, 1, f);
    const auto P = sim::decimated_spectrum(x, h, 1, f);
    const auto bin = static_cast<std::size_t>(std::lround(f0 / 20.0));
    EXPECT_GE(B[bin], 0.99 * a) << "a line at " << f0 << " Hz";
    EXPECT_LE(B[bin], 1.002 * a) << "a line at " << f0 << " Hz";
    worst = std::min(worst, B[bin] / a);
    for (std::size_t b = 0; b < f.size(); ++b)
      if (b + 2 <= bin || b >= bin + 2) {
        EXPECT_LT(B[b], 0.01 * a) << "bin " << f[b] << " Hz, line at " << f0;
      }
    EXPECT_GE(B[bin], P[bin] * (1 - 1e-12)) << "the bin's peak is at least its centre's value";
    if (std::abs(d) >= 9.9) {
      EXPECT_LT(P[bin], 0.03 * a) << "the centre's value alone loses the line";
    }
    if (d == 0.0) {
      EXPECT_NEAR(B[bin], P[bin], 1e-3 * a);
    }
  }
  print0(PETSC_COMM_WORLD, "  binned spectrum: worst line amplitude %.4f a over 8 offsets (Hann bound 0.990)\n", worst);

  // Against the definition, every bin: the largest of the transform over a direct grid 16 times
  // finer than 1 / T (within 0.2 % of the true largest), for block means (s = 4 steps of 5e-5 s:
  // 5 kHz, the bins below its Nyquist frequency as the sweep's 2.5 fmax keeps them) of two lines,
  // one on a bin edge, and a slow drift; T is not a whole number of periods of either.
  const long s = 4;
  const double hs = 5e-5;
  const long nm = std::lround(T / (s * hs)) + 7;
  std::vector<double> means(static_cast<std::size_t>(nm));
  for (long k = 0; k < nm; ++k) {
    double acc = 0.0;
    for (long q = 0; q < s; ++q) {
      const double t = (k * s + q) * hs;
      acc += a * std::sin(2 * M_PI * 433.3 * t) + 0.2 * a * std::cos(2 * M_PI * 1010.0 * t + 0.3) + 3 * a * t;
    }
    means[static_cast<std::size_t>(k)] = acc / s;
  }
  const auto B = sim::binned_spectrum(means, hs, s, f);
  const double Tm = static_cast<double>(nm) * s * hs;
  double lo_ratio = 2.0, lo_side = 2.0, hi_ratio = 0.0;
  for (std::size_t b = 0; b < f.size(); ++b) {
    const double lo = b > 0 ? 0.5 * (f[b - 1] + f[b]) : 0.0,
                 hi = b + 1 < f.size() ? 0.5 * (f[b] + f[b + 1]) : f[b] + 10.0;
    std::vector<double> fine;
    for (double x = lo; x <= hi + 1e-9; x += 1.0 / (16.0 * Tm)) fine.push_back(x);
    fine.push_back(hi);
    const auto D = sim::decimated_spectrum(means, hs, s, fine);
    const double ref = *std::max_element(D.begin(), D.end());
    if (ref < 1e-3 * a) continue;  // far from both lines and the drift's low end: round-off
    if (ref >= 0.05 * a) lo_ratio = std::min(lo_ratio, B[b] / ref);  // a line's main lobe
    lo_side = std::min(lo_side, B[b] / ref);
    hi_ratio = std::max(hi_ratio, B[b] / ref);
  }
  EXPECT_GE(lo_ratio, 0.99) << "a bin of a line's main lobe below the largest of the transform over it";
  // A sidelobe peak, |cos| wide 1 / T, loses up to 1 - cos(pi / 8) = 7.6 % at 1 / (8 T).
  EXPECT_GE(lo_side, 0.92) << "a bin of the sidelobes below the largest of the transform over it";
  EXPECT_LE(hi_ratio, 1.002) << "a bin above the largest of the transform over it";
  print0(PETSC_COMM_WORLD,
         "  binned spectrum against a direct grid 16x finer: main-lobe bins %.4f, sidelobe bins %.4f, "
         "all at most %.4f of the largest over the bin\n",
         lo_ratio, lo_side, hi_ratio);
}

// A speed sweep of the clamped box rubbing its free face on the growing two-lobe casing. Each
// speed's result is checked against a single run of sim::integrate (the unbatched scheme and
// kernel) post-processed here, and the sweep on all ranks with 6 lanes per rank (dynamic load
// balancing) gives bitwise the same results as one rank running the speeds one at a time.
namespace {
// Massless: the same basis made massless (nlrom::massless_transform), the damping on its dynamic
// modes; each lane then solves its boundary's equilibrium (with the shared kernels) every step.
void check_sweep(bool massless) {
  auto m = box(ElementType::Hex8, 4);
  auto c = test::cb_basis(m, "x1", 3);
  const std::size_t r = static_cast<std::size_t>(c.n()), nb = static_cast<std::size_t>(c.n_b) / 3;
  const auto rm = box_model(m, c, massless, 0.01);
  int rank = 0;
  MPI_Comm_rank(PETSC_COMM_WORLD, &rank);
  const auto X = boundary_positions(m, c);
  sim::SweepSettings s;
  s.base.dt = 0.5 * sim::critical_step(rm);
  s.base.contact.obstacle = sim::Obstacle::Casing;
  s.base.contact.casing.clearance = 2e-4;
  s.base.contact.casing.bump_height = 6e-4;
  s.base.contact.casing.width = 0.3;
  s.base.contact.mu = 0.15;
  s.base.contact.nodes = boundary_contact_nodes(X);
  s.revolutions = 3.0;
  s.monitor.assign(r, 0.0);
  {
    const double rho = std::hypot(X[0], X[1]);
    s.monitor[0] = X[0] / rho, s.monitor[1] = X[1] / rho;  // e_r . u of the first face node
  }
  s.spectrum_fmax = 2000.0;
  s.spectrum_bins = 40;
  s.orders = 8;  // engine orders above 2 kHz are not measured (NaN)
  std::vector<sim::SpeedTask> tasks;
  for (int i = 0; i < 5; ++i) tasks.push_back({i, 900.0 + 250.0 * i});
  long mine = 0;  // speeds this rank ran in the last sweep
  auto run = [&](MPI_Comm comm, int batch, sim::SweepKernel kernel, bool single, int isa = -1) {
    std::vector<sim::SpeedResult> out(tasks.size());
    sim::SweepSettings sb = s;
    sb.batch = batch;
    sb.kernel = kernel;
    sb.single = single;
    sb.isa = isa;
    mine = sim::sweep(comm, rm, sb, tasks, [&](const sim::SpeedResult& R) {
             out[static_cast<std::size_t>(R.index)] = R;
           }).speeds;
    return out;
  };
  // Every kernel: the batched potential pass (in double and with float coefficients), the batched
  // folded pass, and the auto kernel lane by lane. On one rank, 5 speeds in 6 lanes are two groups
  // of 4 lanes, which the potential kernel takes as a pair (2 rows at a time); alone, one group (4
  // rows at a time): the bits must not change.
  std::vector<sim::SpeedResult> one, lane, folded, single;
  const std::pair<sim::SweepKernel, bool> kernels[] = {{sim::SweepKernel::Potential, false},
                                                       {sim::SweepKernel::Folded, false},
                                                       {sim::SweepKernel::Lane, false},
                                                       {sim::SweepKernel::Potential, true}};
  for (auto [kernel, sp] : kernels) {
    const auto all = run(PETSC_COMM_WORLD, 6, kernel, sp);  // two lane groups per pass; rank 0 holds the results
    // 6 lanes per rank but 5 speeds: no rank holds more than its share, ceil(5 / ranks).
    long total = 0, most = 0;
    int size = 1;
    MPI_Comm_size(PETSC_COMM_WORLD, &size);
    MPI_Allreduce(&mine, &total, 1, MPI_LONG, MPI_SUM, PETSC_COMM_WORLD);
    MPI_Allreduce(&mine, &most, 1, MPI_LONG, MPI_MAX, PETSC_COMM_WORLD);
    EXPECT_EQ(total, static_cast<long>(tasks.size()));
    EXPECT_LE(most, (static_cast<long>(tasks.size()) + size - 1) / size) << "a rank took more than its share";
    auto alone = run(PETSC_COMM_SELF, 1, kernel, sp);  // every rank alone, one lane
    // Bitwise agreement, decided on rank 0 and shared.
    int same = 1;
    if (rank == 0)
      for (std::size_t i = 0; i < tasks.size(); ++i) {
        const auto &a = all[i], &b = alone[i];
        same &= a.status == 0 && b.status == 0 && a.steps == b.steps && a.rms == b.rms && a.mean == b.mean &&
                a.max_displacement == b.max_displacement && a.time_of_max == b.time_of_max &&
                a.max_force == b.max_force && a.max_node_force == b.max_node_force && a.max_active == b.max_active &&
                a.spectrum == b.spectrum && a.orders.size() == b.orders.size() &&
                std::equal(a.orders.begin(), a.orders.end(), b.orders.begin(),
                           [](double x, double y) { return x == y || (std::isnan(x) && std::isnan(y)); }) &&
                a.energy_half == b.energy_half && a.energy_end == b.energy_end &&
                a.work_end.normal == b.work_end.normal && a.work_end.friction == b.work_end.friction &&
                a.work_end.damping == b.work_end.damping && a.work_half.friction == b.work_half.friction &&
                a.tangent_dt_min == b.tangent_dt_min && a.tangent_checks == b.tangent_checks &&
                a.tangent_negative_checks == b.tangent_negative_checks;
      }
    MPI_Bcast(&same, 1, MPI_INT, 0, PETSC_COMM_WORLD);
    EXPECT_EQ(same, 1) << "sweep results depend on the ranks or the batch (kernel " << sim::kernel_name(kernel)
                       << (sp ? ", float" : "") << ")";
    (sp                                      ? single
     : kernel == sim::SweepKernel::Potential ? one
     : kernel == sim::SweepKernel::Folded    ? folded
                                             : lane) = std::move(alone);
  }
  // The AVX2 build of the potential kernel where the processor also has the AVX-512 one (which
  // `one` ran): the same bits, speed by speed (all 5 speeds in one pass on this rank).
  if (sim::best_kernel_isa() == sim::KernelIsa::Avx512) {
    const auto avx2 =
        run(PETSC_COMM_SELF, 6, sim::SweepKernel::Potential, false, static_cast<int>(sim::KernelIsa::Avx2));
    bool same = true;
    for (std::size_t i = 0; i < tasks.size(); ++i)
      same = same && avx2[i].status == 0 && avx2[i].rms == one[i].rms && avx2[i].spectrum == one[i].spectrum &&
             avx2[i].max_force == one[i].max_force && avx2[i].energy_end == one[i].energy_end;
    EXPECT_TRUE(same) << "the AVX2 and AVX-512 builds of the potential kernel give other sweeps";
  } else {
    print0(PETSC_COMM_WORLD, "  NOTICE: no AVX-512 on this processor: the sweep's two builds are not compared here\n");
  }
  // The predicted cost counts the tangent checks the speeds then ran (none for a massless model)
  // at their measured time.
  {
    const auto cost = sim::predict_sweep_cost(PETSC_COMM_WORLD, rm, s, sim::SweepOptions{}, tasks, {}, 0.02);
    long ran = 0;
    double steps = 0.0;
    for (const auto& R : one) ran += R.tangent_checks, steps += static_cast<double>(R.steps);
    EXPECT_EQ(cost.checks, static_cast<double>(ran));
    EXPECT_EQ(cost.steps, steps);
    EXPECT_EQ(ran == 0, massless);
    if (!massless) {
      EXPECT_GT(cost.check_seconds, 0.0);
    }
    EXPECT_NEAR(cost.core_hours, (steps / cost.rate + cost.checks * cost.check_seconds) / 3600.0,
                1e-12 * cost.core_hours);
  }
  // Against sim::integrate, speed by speed (on every rank, from `one`).
  int touched = 0;
  for (std::size_t i = 0; i < tasks.size(); ++i) {
    sim::Settings si = s.base;
    si.kernel = sim::KernelLayout::Folded;
    si.contact.casing.omega = tasks[i].omega;
    si.t_final = s.revolutions * 2 * M_PI / tasks[i].omega;
    const long n_steps = static_cast<long>(std::ceil(si.t_final / si.dt - 1e-9)), half = (n_steps + 1) / 2;
    double sum2 = 0, umax = 0, fmax = 0, e_half = 0, e_end = 0;
    std::vector<double> window;  // the analysed half, every step
    sim::EnergyWork w_half, w_end;
    long cnt = 0, steps = 0;
    int act = 0;
    const auto ist = sim::integrate(rm, {}, si, [&](const sim::StepState& x) {
      // The sweep's balance rows: E_{n+1/2} and the works of steps 0..n for n = half - 1, n_steps - 1.
      if (x.step == half - 1) e_half = x.balance_energy(), w_half = *x.work;
      if (x.step == n_steps - 1) e_end = x.balance_energy(), w_end = *x.work;
      if (x.step == 0) return;
      steps = x.step;
      if (x.step > n_steps) return;
      double u = 0;
      for (std::size_t j = 0; j < r; ++j) u += s.monitor[j] * x.q[j];
      umax = std::max(umax, std::abs(u));
      if (x.step >= half) sum2 += u * u, ++cnt, window.push_back(u);
      double tot = 0;
      for (std::size_t k = 0; k < nb; ++k) tot += x.contact_normal[k];
      fmax = std::max(fmax, tot);
      act = std::max(act, x.active);
    });
    const auto& R = one[i];
    EXPECT_NEAR(lane[i].rms, R.rms, 1e-9 * R.rms) << "per-lane vs batched potential kernel";
    EXPECT_NEAR(folded[i].rms, R.rms, 1e-9 * R.rms) << "batched folded vs batched potential kernel";
    // Float coefficients: each rounded by at most 2^-24 relative; over 3 revolutions of contact the
    // response moves by about that times the force's share of the response (measured 1e-7).
    EXPECT_NEAR(single[i].rms, R.rms, 1e-5 * R.rms) << "float vs double coefficients";
    EXPECT_NEAR(single[i].max_force, R.max_force, 1e-4 * R.max_force + 1e-12) << "float vs double coefficients";
    print0(PETSC_COMM_WORLD, "  sweep: omega %.0f rad/s, float coefficients: rms %.2e relative\n", R.omega,
           std::abs(single[i].rms - R.rms) / R.rms);
    EXPECT_EQ(R.steps, n_steps);
    EXPECT_NEAR(R.rms, std::sqrt(sum2 / cnt), 1e-9 * R.rms) << "omega " << tasks[i].omega;
    EXPECT_NEAR(R.max_displacement, umax, 1e-9 * umax);
    EXPECT_NEAR(R.max_force, fmax, 1e-7 * fmax + 1e-12);
    EXPECT_EQ(R.max_active, act);
    // The engine-order lines at their exact frequencies, against the spectrum of every step of the
    // window (the sweep's is of block means of 1 / (2.5 fmax h) steps: the same line to within the
    // windows' difference, O(block / window)).
    {
      ASSERT_EQ(R.orders.size(), 8u);
      const double f1 = tasks[i].omega / (2 * M_PI);
      std::vector<double> fk;
      for (int k = 1; k * f1 <= s.spectrum_fmax; ++k) fk.push_back(k * f1);
      // The same span as the sweep's whole blocks (its last partial block is not analysed).
      const long block = std::max(1L, static_cast<long>(1.0 / (2.5 * s.spectrum_fmax * si.dt)));
      window.resize(window.size() / static_cast<std::size_t>(block) * static_cast<std::size_t>(block));
      const auto ref = sim::amplitude_spectrum(window, si.dt, fk);
      std::vector<double> means;  // the sweep's block means, formed here from the run's steps
      for (std::size_t j = 0; j < window.size(); j += static_cast<std::size_t>(block)) {
        double m = 0;
        for (long k = 0; k < block; ++k) m += window[j + static_cast<std::size_t>(k)];
        means.push_back(m / static_cast<double>(block));
      }
      const auto dec = sim::decimated_spectrum(means, si.dt, block, fk);
      const double big = *std::max_element(ref.begin(), ref.end());
      double worst = 0;
      for (std::size_t k = 0; k < 8; ++k) {
        if (k < fk.size()) {
          // The same samples: to round-off. Every step: to what the block means fold from above
          // their Nyquist frequency, 1.25 fmax (contact content; measured up to 5 % of the largest line).
          EXPECT_NEAR(R.orders[k], dec[k], 1e-9 * big) << "omega " << tasks[i].omega << ", order " << k + 1;
          EXPECT_NEAR(R.orders[k], ref[k], 0.1 * big) << "omega " << tasks[i].omega << ", order " << k + 1;
          worst = std::max(worst, std::abs(R.orders[k] - ref[k]) / big);
        } else
          EXPECT_TRUE(std::isnan(R.orders[k])) << "order " << k + 1 << " is above fmax";
      }
      print0(PETSC_COMM_WORLD,
             "  sweep: omega %.0f rad/s, engine-order lines against every step: %.3f of the largest\n", R.omega, worst);
    }
    // The tangent checks at the same states (none for the massless model).
    EXPECT_EQ(R.tangent_checks, static_cast<long>(ist.tangent.size()));
    EXPECT_EQ(R.tangent_negative_checks, ist.tangent_negative_checks);
    if (std::isinf(ist.tangent_dt_min))
      EXPECT_TRUE(std::isinf(R.tangent_dt_min) && massless);
    else
      EXPECT_NEAR(R.tangent_dt_min, ist.tangent_dt_min, 1e-9 * ist.tangent_dt_min);
    const double es = std::max({std::abs(e_end), std::abs(w_end.normal), std::abs(w_end.friction), w_end.damping});
    EXPECT_NEAR(R.energy_half, e_half, 1e-9 * es);
    EXPECT_NEAR(R.energy_end, e_end, 1e-9 * es);
    EXPECT_NEAR(R.work_half.friction, w_half.friction, 1e-9 * es);
    for (auto [a, b] : {std::pair{R.work_end.normal, w_end.normal},
                        {R.work_end.friction, w_end.friction},
                        {R.work_end.damping, w_end.damping},
                        {R.work_end.external, w_end.external}})
      EXPECT_NEAR(a, b, 1e-9 * es) << "omega " << tasks[i].omega;
    touched += R.max_active > 0;
    print0(PETSC_COMM_WORLD,
           "  sweep: omega %.0f rad/s, %ld steps, rms %.3e m, max |u_r| %.3e m, max force %.3e N, %d nodes\n", R.omega,
           R.steps, R.rms, R.max_displacement, R.max_force, R.max_active);
  }
  EXPECT_GE(touched, 3) << "the casing should be touched at most speeds";
  // Float coefficients exist only in the potential kernel: asked with another, the sweep is refused
  // on every rank, naming the option, before anything runs.
  sim::SweepSettings sf = s;
  sf.kernel = sim::SweepKernel::Folded;
  sf.single = true;
  test::expect_error_parts([&] { sim::sweep(PETSC_COMM_WORLD, rm, sf, tasks, [](const sim::SpeedResult&) {}); },
                           {"-sweep_float", "potential kernel"}, "float coefficients with the folded kernel");
}
}  // namespace

TEST(Sim, SweepMatchesSingleRunsOnAnyRanksAndBatch) { check_sweep(false); }
TEST(Sim, MasslessSweepMatchesSingleRunsOnAnyRanksAndBatch) { check_sweep(true); }

// The casing's kinematics against a closed form (issue 28 §1): one tip node on a stiff, heavily
// damped isotropic spring (r = 3, omega_n = 10^6 rad/s, far above the bump passage), so that it
// follows the casing quasi-statically. Derived independently of the code: the casing of revolution
// about z has the radius R + c0 - s(t) f(phi) at the fixed-frame angle phi, s(t) = 1 - exp(-alpha
// t); the blade turning at Omega puts the node at phi = theta0 + Omega t, so the node is in contact
// when s(t) f(theta0 + Omega t) > c0 and then sits on the casing, u_r = c0 - s f; friction opposes
// the node's sliding along the casing (along sign(Omega) e_theta) with mu lambda, and the spring
// answers lambda = k |u_r| with u_theta = -mu sign(Omega) |u_r|. Both senses of rotation.
TEST(Sim, RigidTipFollowsTheRotatingCasing) {
  const double k = 1e12, mass = 1e0, R = 0.25, theta0 = 0.3, mu = 0.2;
  const double wn = std::sqrt(k / mass);
  nlrom::ReducedModel m;
  m.r = 3;
  m.K.assign(9, 0.0), m.M.assign(9, 0.0), m.C.assign(9, 0.0);
  for (int i = 0; i < 3; ++i) m.K[4 * i] = k, m.M[4 * i] = mass, m.C[4 * i] = 2.0 * 0.8 * wn * mass;
  for (double omega : {100.0, -100.0}) {
    sim::Settings s;
    s.linear = true;
    s.dt = 0.5 * sim::critical_step(m);
    s.t_final = 2 * 2 * M_PI / std::abs(omega);
    s.contact.obstacle = sim::Obstacle::Casing;
    s.contact.casing = {2e-4, 6e-4, 2, 0.3, 0.0, omega};
    s.contact.mu = mu;
    s.contact.sliding = sim::Sliding::Rotation;  // the closed form is the seed's law
    sim::ContactNode node;
    node.x[0] = R * std::cos(theta0), node.x[1] = R * std::sin(theta0);
    s.contact.nodes.push_back(node);
    const double er[2] = {std::cos(theta0), std::sin(theta0)}, et[2] = {-std::sin(theta0), std::cos(theta0)};
    const double alpha = std::log(100.0) / (0.2 * s.t_final), hb = 6e-4, c0 = 2e-4, w = 0.3;
    auto casing_push = [&](double t) {  // s(t) f(phi) at the node's fixed-frame angle
      double phi = std::fmod(theta0 + omega * t, M_PI);
      if (phi < 0) phi += M_PI;
      const double z = (phi - M_PI / 2) / w;
      return (1 - std::exp(-alpha * t)) * hb * std::exp(-z * z);
    };
    double err_r = 0, err_t = 0, first = -1, first_closed = -1;
    long steps = 0;
    sim::integrate(m, {}, s, [&](const sim::StepState& x) {
      const double t = x.t, ur = er[0] * x.q[0] + er[1] * x.q[1], ut = et[0] * x.q[0] + et[1] * x.q[1];
      const double push = casing_push(t), closed = std::min(0.0, c0 - push);
      err_r = std::max(err_r, std::abs(ur - closed));
      err_t = std::max(err_t, std::abs(ut - (omega > 0 ? -1 : 1) * mu * std::abs(closed)));
      if (first < 0 && x.contact_normal[0] > 0) first = t;
      if (first_closed < 0 && push > c0) first_closed = t;
      ++steps;
    });
    print0(PETSC_COMM_WORLD,
           "  rigid tip, Omega %+.0f rad/s: %ld steps, first contact at %.6f s (closed form %.6f s), "
           "|u_r - closed| <= %.2e m, |u_theta - closed| <= %.2e m of h_b = %.1e m\n",
           omega, steps, first, first_closed, err_r, err_t, hb);
    EXPECT_LT(err_r, 1e-3 * (hb - c0)) << "omega " << omega;
    EXPECT_LT(err_t, 1e-3 * mu * (hb - c0)) << "omega " << omega;
    EXPECT_NEAR(first, first_closed, 2e-3 * s.t_final) << "omega " << omega;
    EXPECT_GT(first_closed, 0.0);
  }
}

// A point mass on springs k (r = 3: u_x radial, u_y along e_theta, u_z axial) pressed onto a round
// casing (no lobes) of clearance c0 at radius R by a constant radial load F = lambda + k c0, at the
// static friction offset, with an axial velocity vz0: the set-up of the two tests below.
struct TipOnCasing {
  nlrom::ReducedModel m;
  sim::ReducedLoad load;
  sim::Settings s;
};
static TipOnCasing tip_on_casing(double k, double mass, double R, double mu, double c0, double lambda, double vz0,
                                 double omega, sim::Sliding sliding) {
  TipOnCasing x;
  x.m.r = 3;
  x.m.K.assign(9, 0.0), x.m.M.assign(9, 0.0), x.m.C.assign(9, 0.0);
  for (int i = 0; i < 3; ++i) x.m.K[4 * i] = k, x.m.M[4 * i] = mass;
  x.load.p = {1.0, 0.0, 0.0}, x.load.amplitude = lambda + k * c0;  // omega 0: constant
  x.s.linear = true;
  x.s.dt = 1e-5;
  x.s.contact.obstacle = sim::Obstacle::Casing;
  x.s.contact.casing = {c0, 0.0, 2, 0.15, 0.0, omega};
  x.s.contact.mu = mu;
  x.s.contact.sliding = sliding;
  sim::ContactNode node;
  node.x[0] = R;  // e_r = x, e_theta = y
  x.s.contact.nodes.push_back(node);
  const double sgn = omega > 0 ? 1.0 : -1.0;
  x.s.q0 = {c0, -sgn * mu * lambda / k, 0.0};  // on the casing, at the static friction offset
  x.s.v0 = {0.0, 0.0, vz0};
  return x;
}

// The casing's two friction laws on a tip node pressed onto a round casing (no lobes) by a
// constant radial force F, with an axial vibration (a point mass m on springs k, no damping). The
// normal force is lambda = F - k c0. Friction along sign(Omega) e_theta (Sliding::Rotation, the
// seed's) has no axial part: the axial energy stays. Against the relative sliding velocity
// (Sliding::Relative), v = Omega R e_theta + u', the axial part of the force is
// -mu lambda u'_z / |v| = -c u'_z to first order in u'/(Omega R), c = mu lambda / (|Omega| R): the
// axial energy decays as exp(-c t / m) (closed form of the lightly damped oscillator, averaged
// over its period), and the friction force keeps the magnitude mu lambda. Both senses.
TEST(Sim, RelativeSlidingDampsTheTipsAxialVibration) {
  const double k = 1e6, mass = 1.0, R = 0.25, mu = 0.15, c0 = 2e-4, lambda = 1e4, vz0 = 1.0;
  for (double omega : {1000.0, -1000.0})
    for (auto sliding : {sim::Sliding::Rotation, sim::Sliding::Relative}) {
      auto [m, load, s] = tip_on_casing(k, mass, R, mu, c0, lambda, vz0, omega, sliding);
      s.t_final = 0.5;
      const double c = mu * lambda / (std::abs(omega) * R);
      double e0 = -1, e_end = 0, t_end = 0, lam_err = 0, fric_err = 0;
      sim::integrate(m, {load}, s, [&](const sim::StepState& x) {
        const double ez = 0.5 * mass * x.v[2] * x.v[2] + 0.5 * k * x.q[2] * x.q[2];
        if (e0 < 0) e0 = ez;
        e_end = ez, t_end = x.t;
        if (x.t > 0.01) {
          lam_err = std::max(lam_err, std::abs(x.contact_normal[0] - lambda) / lambda);
          const double* f = x.contact_friction;
          fric_err = std::max(
              fric_err, std::abs(std::sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]) - mu * lambda) / (mu * lambda));
        }
      });
      const double ratio = e_end / e0, expected = sliding == sim::Sliding::Relative ? std::exp(-c * t_end / mass) : 1.0;
      print0(PETSC_COMM_WORLD,
             "  tip on a round casing, Omega %+.0f, sliding %s: axial energy ratio %.6f at t = %.3f s (closed form "
             "%.6f), |lambda - F + k c0| <= %.1e, |f_t| - mu lambda <= %.1e (relative)\n",
             omega, sliding == sim::Sliding::Relative ? "relative" : "rotation", ratio, t_end, expected, lam_err,
             fric_err);
      EXPECT_NEAR(ratio / expected, 1.0, sliding == sim::Sliding::Relative ? 1e-2 : 1e-3) << omega;
      EXPECT_LT(lam_err, 1e-6) << omega;
      EXPECT_LT(fric_err, 1e-9) << omega;
    }
}

// A run that grows without bound stops at -sim_divergence_limit with the time reached: a point mass
// held on a round casing (as above) with a negative damping -c_n on its axial motion, which outgrows
// friction's dashpot c = mu lambda / (|Omega| R): the axial amplitude grows as exp(sigma t),
// sigma = (c_n - c) / 2m, from v0 / omega_n, so it passes the limit L at
// t_L = ln(L omega_n / v0) / sigma. Without a limit the same run ends at t_final.
TEST(Sim, DivergenceLimitStopsAGrowingContactRun) {
  const double k = 1e6, mass = 1.0, R = 0.25, mu = 0.15, c0 = 2e-4, lambda = 1e4, vz0 = 1.0, omega = 1000.0;
  const double cn = 100.0, c = mu * lambda / (omega * R), sigma = (cn - c) / (2 * mass);
  auto [m, load, s] = tip_on_casing(k, mass, R, mu, c0, lambda, vz0, omega, sim::Sliding::Relative);
  m.C[8] = -cn;
  s.t_final = 0.25;
  EXPECT_DOUBLE_EQ(sim::divergence_radius(s.contact), R);
  const double L = 0.05, t_L = std::log(L * std::sqrt(k / mass) / vz0) / sigma;
  double t_last = 0;
  std::string what;
  s.divergence_limit = L;
  try {
    sim::integrate(m, {load}, s, [&](const sim::StepState& x) { t_last = x.t; });
  } catch (const std::exception& e) {
    what = e.what();
  }
  print0(PETSC_COMM_WORLD, "  growing axial motion (sigma %.1f 1/s): stopped at t = %.4f s, closed form %.4f s: %s\n",
         sigma, t_last, t_L, what.c_str());
  EXPECT_NE(what.find("diverged at t = "), std::string::npos) << what;
  EXPECT_NE(what.find("-sim_divergence_limit"), std::string::npos) << what;
  EXPECT_NEAR(t_last / t_L, 1.0, 0.03);  // an envelope crossing: within a period (6 ms) of t_L
  s.divergence_limit = 0.0;              // no limit: the run ends at t_final, far beyond L
  double a_end = 0;
  sim::integrate(m, {load}, s, [&](const sim::StepState& x) { t_last = x.t, a_end = std::abs(x.q[2]); });
  EXPECT_NEAR(t_last, s.t_final, 2 * s.dt);
  EXPECT_GT(a_end, 0.0);
}

// Adaptive refinement of a sweep: the rules (RMS jump, a change of the dominant frequency, a
// failure on one side), then a refined sweep of the clamped box on the casing against the sweep of
// the whole fine grid: every refined speed is the fine grid's result (bitwise), the largest RMS is
// found at the same speed, no two neighbouring refined speeds farther apart than the fine step
// still differ, and fewer speeds were run.
TEST(SimRun, RefinementBisectsWhereNeighboursDiffer) {
  sim::SweepOptions so;
  so.omega_min = 100, so.omega_max = 900, so.omega_step = 200, so.refine_step = 25;
  EXPECT_EQ(so.stride(), 8);
  EXPECT_EQ(so.n_speeds(), 33);
  const auto coarse = so.todo({});
  ASSERT_EQ(coarse.size(), 5u);
  EXPECT_EQ(coarse[2].index, 16);
  EXPECT_EQ(coarse[2].omega, 500.0);
  const std::vector<double> freqs = {0, 10, 20, 30, 40, 50, 60, 70, 80, 90, 100};
  auto result = [&](long index, double rms, std::size_t peak) {
    sim::SpeedResult R;
    R.index = index, R.rms = rms, R.spectrum.assign(freqs.size(), 0.1);
    R.spectrum[0] = 5, R.spectrum[peak] = 1;  // f = 0 does not count
    return R;
  };
  std::vector<sim::SpeedResult> done = {result(0, 1.05, 5), result(8, 1.1, 5), result(16, 2, 5), result(24, 1, 5),
                                        result(32, 1, 9)};
  auto next = so.refine(done, freqs);
  ASSERT_EQ(next.size(), 3u);  // 8-16 and 16-24 (RMS, and the peak at 16), 24-32 (90 against 50 Hz)
  EXPECT_EQ(next[0].index, 12);
  EXPECT_EQ(next[1].index, 20);
  EXPECT_EQ(next[2].index, 28);
  EXPECT_EQ(next[2].omega, 800.0);
  // A peak between alike neighbours: both sides of it are bisected.
  next = so.refine({result(0, 1, 5), result(8, 1.05, 5), result(16, 1, 5)}, freqs);
  ASSERT_EQ(next.size(), 2u);
  EXPECT_EQ(next[0].index, 4);
  EXPECT_EQ(next[1].index, 12);
  // Two bins apart is not a new line; a failure on one side is a difference; neighbours one fine
  // step apart are not refined.
  EXPECT_FALSE(sim::speeds_differ(result(0, 1, 5), result(1, 1, 7), freqs, 0.2, 0.05));
  EXPECT_TRUE(sim::speeds_differ(result(0, 1, 5), result(1, 1, 8), freqs, 0.2, 0.05));
  auto failed = result(1, 1, 5);
  failed.status = 1;
  EXPECT_TRUE(sim::speeds_differ(result(0, 1, 5), failed, freqs, 0.2, 0.05));
  EXPECT_TRUE(so.refine({result(3, 1, 5), result(4, 9, 5)}, freqs).empty());
  EXPECT_TRUE(so.refine({result(0, 1, 5), result(8, 1.05, 5), result(16, 1.1, 5)}, freqs).size() == 1u)
      << "the rising edge's top (16) has one interval beside it";
  so.rotation = -1;
  EXPECT_EQ(so.refine(done, freqs)[0].omega, -400.0);
  so.refine_step = 0;
  EXPECT_TRUE(so.refine(done, freqs).empty()) << "no refinement asked";

  // On engine-order lines (-sweep_refine_orders): a flat RMS with a line that locks between two
  // speeds, noise of an absent line below the floor, a line's peak between alike neighbours.
  so.rotation = 1, so.refine_step = 25;
  so.refine_orders = {6};
  auto lined = [&](long index, double eo6, double eo8) {
    auto R = result(index, 1.0, 5);
    R.orders.assign(8, 1e-9);
    R.orders[5] = eo6, R.orders[7] = eo8;
    return R;
  };
  // eo6 locks between 8 and 16 (x10): refined there only; the RMS and dominant line are alike.
  next = so.refine(
      {lined(0, 1e-4, 1), lined(8, 1.2e-4, 1), lined(16, 1e-3, 1), lined(24, 1.05e-3, 1), lined(32, 1.1e-3, 1)}, freqs);
  ASSERT_EQ(next.size(), 2u) << "the jump 8-16, and the peak at 32 (the grid's end) beside 24-32";
  EXPECT_EQ(next[0].index, 12);
  EXPECT_EQ(next[1].index, 28);
  // An absent line's noise (below 0.1 of its largest) refines nothing, even with jumps of x10.
  next = so.refine({lined(0, 1e-3, 1), lined(8, 1e-5, 1), lined(16, 1e-6, 1), lined(24, 1e-5, 1), lined(32, 1e-6, 1)},
                   freqs);
  ASSERT_EQ(next.size(), 1u) << "only beside the line's peak at 0";
  EXPECT_EQ(next[0].index, 4);
  // A peak of eo6 between alike neighbours: both sides; eo8 is not listed and refines nothing.
  next = so.refine({lined(0, 1e-3, 1), lined(8, 1.3e-3, 5), lined(16, 1e-3, 1)}, freqs);
  ASSERT_EQ(next.size(), 2u);
  EXPECT_EQ(next[0].index, 4);
  EXPECT_EQ(next[1].index, 12);
  // A failure beside a finished speed refines; a line not measured there (NaN) is skipped.
  auto bad = lined(8, 1e-3, 1);
  bad.status = 1;
  EXPECT_EQ(so.refine({lined(0, 1e-3, 1), bad}, freqs).size(), 1u);
  auto unmeasured = lined(8, std::nan(""), 1);
  EXPECT_EQ(so.refine({lined(0, 1e-3, 1), unmeasured, lined(16, 1e-3, 1)}, freqs).size(), 2u)
      << "the speeds beside an unmeasured one are peaks of the line, as beside a failure";
  so.refine_orders = {6, 8};  // eo8 listed: its jump 1 -> 5 at 0-8 now refines too
  next = so.refine({lined(0, 1e-3, 1), lined(8, 1e-3, 5), lined(16, 1e-3, 5)}, freqs);
  ASSERT_EQ(next.size(), 1u);
  EXPECT_EQ(next[0].index, 4);
}

TEST(Sim, RefinedSweepFindsThePeakOfTheFineGrid) {
  auto m = box(ElementType::Hex8, 4);
  auto c = test::cb_basis(m, "x1", 3);
  const std::size_t r = static_cast<std::size_t>(c.n());
  auto rm =
      nlrom::project_model(PETSC_COMM_WORLD, c.T.get(), m.ops.K.get(), m.ops.M.get(), 0.01, static_cast<PetscInt>(r));
  rm.n_b = c.n_b;
  const auto X = boundary_positions(m, c);
  sim::SweepSettings s;
  s.base.dt = 0.5 * sim::critical_step(rm);
  s.base.linear = true;
  s.base.contact.obstacle = sim::Obstacle::Casing;
  s.base.contact.casing = {2e-4, 6e-4, 2, 0.3, 0.0, 0.0};
  s.base.contact.mu = 0.15;
  s.base.contact.nodes = boundary_contact_nodes(X);
  s.revolutions = 3.0;
  s.monitor.assign(r, 0.0);
  const double rho = std::hypot(X[0], X[1]);
  s.monitor[0] = X[0] / rho, s.monitor[1] = X[1] / rho;
  s.spectrum_fmax = 2000.0;
  s.spectrum_bins = 40;
  s.batch = 4;
  sim::SweepOptions so;
  so.omega_min = 800, so.omega_max = 2400, so.omega_step = 400, so.refine_step = 25;
  so.refine_rms = 0.1;
  const auto freqs = s.frequencies();
  // The predicted cost counts the coarse speeds' steps, and the rest of the fine grid as the bound.
  {
    const auto cost = sim::predict_sweep_cost(PETSC_COMM_WORLD, rm, s, so, so.todo({}), {}, 0.05);
    double coarse = 0, rest = 0;
    for (long i = 0; i < so.n_speeds(); ++i) {
      const double w = so.omega_min + static_cast<double>(i) * so.refine_step;
      const double n = std::ceil(s.revolutions * 2 * M_PI / w / s.base.dt - 1e-9);
      (i % so.stride() == 0 ? coarse : rest) += n;
    }
    EXPECT_EQ(cost.steps, coarse);
    EXPECT_EQ(cost.refine_steps, rest);
    EXPECT_GT(cost.rate, 0.0);
    EXPECT_NEAR(cost.core_hours, coarse / cost.rate / 3600.0, 1e-12 * cost.core_hours);
    EXPECT_EQ(cost.checks, 0.0) << "a linear model has no tangent checks";
  }
  std::vector<sim::SpeedResult> refined;
  std::size_t n_run = 0;
  sim::sweep_rounds(
      PETSC_COMM_WORLD, rm, s, so, so.todo({}), &refined, freqs, [](const sim::SpeedResult&) {}, &n_run);
  std::vector<sim::SpeedTask> all;
  for (long i = 0; i < so.n_speeds(); ++i) all.push_back({i, so.omega_min + static_cast<double>(i) * so.refine_step});
  std::vector<sim::SpeedResult> fine(all.size());
  sim::sweep(PETSC_COMM_WORLD, rm, s, all,
             [&](const sim::SpeedResult& R) { fine[static_cast<std::size_t>(R.index)] = R; });
  // Decided on rank 0 (which holds the results), shared.
  int ok_same = 1, ok_done = 1, same_peak = 0;
  long runs = static_cast<long>(n_run), w_ref = -1, w_fine = -1;
  if (world_rank() == 0) {
    std::sort(refined.begin(), refined.end(),
              [](const sim::SpeedResult& a, const sim::SpeedResult& b) { return a.index < b.index; });
    for (const auto& R : refined) {
      const auto& F = fine[static_cast<std::size_t>(R.index)];
      ok_same &= R.omega == F.omega && R.rms == F.rms && R.spectrum == F.spectrum;
    }
    for (std::size_t k = 0; k + 1 < refined.size(); ++k)
      if (refined[k + 1].index - refined[k].index >= 2)
        ok_done &= !sim::speeds_differ(refined[k], refined[k + 1], freqs, so.refine_rms, so.refine_frequency);
    auto peak = [](const std::vector<sim::SpeedResult>& v) {
      return std::max_element(v.begin(), v.end(), [](const auto& a, const auto& b) { return a.rms < b.rms; })->index;
    };
    w_ref = peak(refined), w_fine = peak(fine);
    same_peak = w_ref == w_fine;
    print0(PETSC_COMM_SELF, "  refined sweep: %zu of %zu speeds run, peak RMS at %.0f rad/s (fine grid: %.0f)\n",
           refined.size(), fine.size(), so.omega_min + w_ref * so.refine_step, so.omega_min + w_fine * so.refine_step);
  }
  for (int* v : {&ok_same, &ok_done, &same_peak}) MPI_Bcast(v, 1, MPI_INT, 0, PETSC_COMM_WORLD);
  MPI_Bcast(&runs, 1, MPI_LONG, 0, PETSC_COMM_WORLD);
  EXPECT_EQ(ok_same, 1) << "a refined speed differs from the same speed of the fine grid";
  EXPECT_EQ(ok_done, 1) << "neighbouring refined speeds still differ";
  EXPECT_EQ(same_peak, 1) << "the refinement missed the fine grid's peak";
  EXPECT_LT(runs, so.n_speeds()) << "the refinement ran the whole fine grid";
}

// A tip that the casing kicks, on a hardening spring: r = 3, M = I, K = w_n^2 I, g = k3 |q|^2 q (the
// gradient of k3 |q|^4 / 4), 1 % damping. The tangent stiffness w_n^2 + 3 k3 |q|^2 grows with the
// amplitude, so the critical step of central differences shrinks during the run: with the casing's
// kick at amplitude a the step must stay below 2 / sqrt(w_n^2 + 3 k3 a^2) (a linearization), which
// no step set before the run can guarantee.
namespace {
nlrom::ReducedModel hardening_tip(double wn, double k3) {
  nlrom::ReducedModel m;
  m.r = 3;
  m.K.assign(9, 0.0), m.M.assign(9, 0.0), m.C.assign(9, 0.0);
  for (int i = 0; i < 3; ++i) m.K[4 * i] = wn * wn, m.M[4 * i] = 1.0, m.C[4 * i] = 2.0 * 0.01 * wn;
  m.damping_omega = {wn, wn, wn};
  m.g.r = 3;
  m.g.A.assign(6 * 3, 0.0);
  m.g.B.assign(10 * 3, 0.0);
  std::size_t mono = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = i; j < 3; ++j)
      for (int k = j; k < 3; ++k, ++mono)
        for (int p = 0; p < 3; ++p) {  // q_i q_j q_k = q_a^2 q_p for some a: the other two are equal
          if (i == p)
            m.g.B[mono * 3 + p] = j == k ? k3 : 0.0;
          else if (j == p)
            m.g.B[mono * 3 + p] = i == k ? k3 : 0.0;
          else if (k == p)
            m.g.B[mono * 3 + p] = i == j ? k3 : 0.0;
        }
  return m;
}
}  // namespace

// A sweep retries a failed speed at half its step (-sweep_retries), and only that speed: the tip
// on a hardening spring with k3 = 1e15 at 0.9 of the critical step of the linear model diverges at
// most speeds once the casing has kicked it (the tangent stiffness at the kick's amplitude is above
// the step's), and runs at half the step at every speed. The retried results are bitwise those of
// the same speed run at half the step alone; the others are untouched. A resumed sweep runs the
// retries its file still owes, and nothing else. With k3 = 1e16 and two retries, the speeds that
// still fail at a quarter of the step stop there.
TEST(Sim, SweepRetriesAFailedSpeedAtHalfTheStep) {
  const double wn = 2 * M_PI * 1000.0, c0 = 2e-4, hb = 6e-4;
  sim::SweepSettings s;
  s.base.contact.obstacle = sim::Obstacle::Casing;
  s.base.contact.casing = {c0, hb, 2, 0.3, 0.0, 0.0};
  s.base.contact.mu = 0.15;
  sim::ContactNode node;
  node.x[0] = 0.25 * std::cos(0.3), node.x[1] = 0.25 * std::sin(0.3);
  s.base.contact.nodes.push_back(node);
  s.revolutions = 5.0;
  s.monitor = {std::cos(0.3), std::sin(0.3), 0.0};
  s.spectrum_fmax = 5000.0;
  s.spectrum_bins = 50;
  s.divergence_limit = 0.25;  // the tip radius
  s.batch = 4;
  sim::SweepOptions so;
  so.omega_min = 1000, so.omega_max = 5000, so.omega_step = 500;
  const auto tasks = so.todo({});
  ASSERT_EQ(tasks.size(), 9u);
  const auto freqs = s.frequencies();
  const bool root = world_rank() == 0;
  // Each speed alone at the step h / 2^k, on every rank (the references).
  auto alone = [&](const nlrom::ReducedModel& rm, double h) {
    sim::SweepSettings sh = s;
    sh.base.dt = h;
    std::vector<sim::SpeedResult> out(tasks.size());
    sim::sweep(PETSC_COMM_SELF, rm, sh, tasks,
               [&](const sim::SpeedResult& R) { out[static_cast<std::size_t>(R.index)] = R; });
    return out;
  };
  auto rounds = [&](const nlrom::ReducedModel& rm, int retries, std::vector<sim::SpeedTask> todo,
                    std::vector<sim::SpeedResult> done, std::size_t* n_run) {
    so.retries = retries;
    sim::sweep_rounds(
        PETSC_COMM_WORLD, rm, s, so, std::move(todo), &done, freqs, [](const sim::SpeedResult&) {}, n_run);
    std::sort(done.begin(), done.end(), [](const auto& a, const auto& b) { return a.index < b.index; });
    return done;  // on rank 0
  };
  auto same = [](const sim::SpeedResult& a, const sim::SpeedResult& b) {
    return a.status == b.status && a.dt == b.dt && a.steps == b.steps && a.rms == b.rms &&
           a.max_displacement == b.max_displacement && a.spectrum == b.spectrum && a.max_force == b.max_force;
  };
  {
    const auto rm = hardening_tip(wn, 1e15);
    s.base.dt = 0.9 * sim::critical_step(rm);
    const auto at_h = alone(rm, s.base.dt), at_h2 = alone(rm, 0.5 * s.base.dt);
    std::size_t n_run = 0;
    const auto none = rounds(rm, 0, tasks, {}, &n_run);
    const auto once = rounds(rm, 1, tasks, {}, &n_run);
    const long runs_once = static_cast<long>(n_run);
    // A resumed file: the sweep without retries, whose failures are owed one retry.
    const auto resumed = rounds(rm, 1, {}, none, &n_run);
    const long runs_resumed = static_cast<long>(n_run);
    int failures = 0, ok_none = 1, ok_once = 1, ok_resumed = 1, ok_file = 1, ok_note = 1, ok_checks = 1;
    double umax = 0;
    if (root) {
      // Tangent checks (Settings::tangent_checks, 200): a failure names the tangent critical step;
      // a finished speed was checked at steps 0, every, 2 every, ... (every = steps / 200).
      for (std::size_t i = 0; i < 9; ++i) {
        if (at_h[i].status != 0) {
          ok_note &= at_h[i].error.find("the tangent critical step was") != std::string::npos;
          continue;
        }
        const long every = std::max(1L, at_h[i].steps / 200);
        ok_checks &= at_h[i].tangent_checks == at_h[i].steps / every + 1 && at_h[i].tangent_dt_min > 0 &&
                     at_h[i].tangent_dt_min <= sim::critical_step(rm) * (1 + 1e-12);
      }
      ok_none = ok_once = ok_resumed = none.size() == 9 && once.size() == 9 && resumed.size() == 9;
      for (std::size_t i = 0; ok_none && i < 9; ++i) {
        failures += at_h[i].status != 0;
        ok_none &= same(none[i], at_h[i]) && none[i].halvings == 0;
        const bool retried = at_h[i].status != 0;
        ok_once &= same(once[i], retried ? at_h2[i] : at_h[i]) && once[i].halvings == (retried ? 1 : 0) &&
                   once[i].status == 0 && once[i].dt == (retried ? 0.5 : 1.0) * s.base.dt;
        ok_resumed &= same(resumed[i], once[i]) && resumed[i].halvings == once[i].halvings;
        if (retried) umax = std::max(umax, once[i].max_displacement);
        if (retried)
          print0(PETSC_COMM_SELF, "  retry: omega %.0f rad/s failed at dt %.3e s (%s); at dt / 2: max |u_r| %.3e m\n",
                 at_h[i].omega, s.base.dt, at_h[i].error.c_str(), once[i].max_displacement);
      }
      // The step and the halvings survive the sweep file.
      sim::SweepRecord rec, back;
      rec.settings = "k=v\n", rec.n_speeds = 9, rec.frequencies = freqs, rec.results = once;
      const test::ScratchDir dir("retry");
      const std::string path = dir.path("sweep.h5");
      sim::write_sweep(path, rec);
      std::string why;
      ok_file = sim::read_sweep(path, &back, &why) && back.results.size() == 9;
      for (std::size_t i = 0; ok_file && i < 9; ++i)
        ok_file &= back.results[i].dt == once[i].dt && back.results[i].halvings == once[i].halvings &&
                   back.results[i].tangent_dt_min == once[i].tangent_dt_min &&
                   back.results[i].tangent_dt_min_time == once[i].tangent_dt_min_time &&
                   back.results[i].tangent_checks == once[i].tangent_checks &&
                   back.results[i].tangent_negative_checks == once[i].tangent_negative_checks;
    }
    for (int* v : {&failures, &ok_none, &ok_once, &ok_resumed, &ok_file, &ok_note, &ok_checks})
      MPI_Bcast(v, 1, MPI_INT, 0, PETSC_COMM_WORLD);
    MPI_Bcast(&umax, 1, MPI_DOUBLE, 0, PETSC_COMM_WORLD);
    EXPECT_GE(failures, 5) << "the step should fail at most speeds (the case does not test retries)";
    EXPECT_LT(failures, 9) << "some speeds should run at the full step";
    EXPECT_EQ(ok_none, 1) << "without retries, a sweep is its speeds run alone";
    EXPECT_EQ(ok_once, 1) << "a retried speed is not the speed run alone at half the step, or another changed";
    EXPECT_EQ(runs_once, 9 + failures) << "speed runs with one retry";
    EXPECT_EQ(ok_resumed, 1) << "a resumed file's owed retries differ from the sweep's own";
    EXPECT_EQ(runs_resumed, failures) << "a resume runs the owed retries only";
    EXPECT_EQ(ok_file, 1) << "dt, halvings and the tangent checks do not survive the sweep file";
    EXPECT_EQ(ok_note, 1) << "a failed speed's message does not name the tangent critical step";
    EXPECT_EQ(ok_checks, 1) << "a finished speed's tangent checks are not at steps 0, every, 2 every, ...";
    // The casing pushes the tip in by at most h_b - c0; the retried runs stay on that scale.
    EXPECT_LT(umax, 1.1 * (hb - c0)) << "a retried run is not physical";
  }
  {  // At most so.retries halvings.
    const auto rm = hardening_tip(wn, 1e16);
    s.base.dt = 0.9 * sim::critical_step(rm);
    const auto at_h4 = alone(rm, 0.25 * s.base.dt);
    std::size_t n_run = 0;
    const auto twice = rounds(rm, 2, tasks, {}, &n_run);
    int ok = 1, still = 0;
    if (root) {
      ok = twice.size() == 9;
      for (std::size_t i = 0; ok && i < 9; ++i) {
        ok &= same(twice[i], at_h4[i]) && twice[i].halvings == 2;
        still += twice[i].status != 0;
      }
    }
    MPI_Bcast(&ok, 1, MPI_INT, 0, PETSC_COMM_WORLD);
    MPI_Bcast(&still, 1, MPI_INT, 0, PETSC_COMM_WORLD);
    EXPECT_EQ(ok, 1) << "two retries: every speed should end at a quarter of the step";
    EXPECT_GT(still, 0) << "some speeds should still fail at a quarter of the step (the cap is not tested)";
    EXPECT_EQ(static_cast<long>(n_run), 27) << "every speed failed at h and h/2";
  }
}

// Continuation (-sweep_continuation): a speed continued from its neighbour's final state, on the
// grown casing with the lobes where that run left them, is the neighbour's run carried on. With
// neighbouring speeds 1e-9 rad/s apart (the same step count N), chain k of a continuation sweep
// ends where one uninterrupted run of 2N steps at its first speed ends (the hardening tip, k3 = 1e14,
// kicked by the casing, up and down, 2 chains of 2 speeds). Dropping the lobes' angle (phase 0)
// breaks the identity: the test can fail. A sweep resumed from the file written after the first
// round (final states read back) gives bitwise the same second round; a linear chain's continued
// speed closes its energy balance from its start energy.
TEST(Sim, ContinuedSpeedsAreOneUninterruptedRun) {
  const double wn = 2 * M_PI * 1000.0, c0 = 2e-4, hb = 6e-4, w0 = 2000.0, dw = 1e-11;
  const double revs = 10.0, T = revs * 2 * M_PI / w0;
  sim::SweepSettings s;
  s.base.contact.obstacle = sim::Obstacle::Casing;
  s.base.contact.casing = {c0, hb, 2, 0.3, 60.0 / T, 0.0};  // grown to 1 - e^-60 (1.0 in double) by T
  s.base.contact.mu = 0.15;
  sim::ContactNode node;
  node.x[0] = 0.25 * std::cos(0.3), node.x[1] = 0.25 * std::sin(0.3);
  s.base.contact.nodes.push_back(node);
  s.revolutions = revs;
  s.monitor = {std::cos(0.3), std::sin(0.3), 0.0};
  s.spectrum_fmax = 5000.0;
  s.spectrum_bins = 50;
  s.batch = 2;
  const auto rm = hardening_tip(wn, 1e14);
  {
    const double h0 = 0.5 * sim::critical_step(rm, &s.base.contact);
    s.base.dt = T / (std::floor(T / h0) + 0.5);  // every speed of the grid: the same step count N
  }
  const long N = static_cast<long>(std::floor(T / s.base.dt)) + 1;
  sim::SweepOptions so;
  so.omega_min = w0, so.omega_step = dw, so.omega_max = w0 + 3.5 * dw, so.chains = 2;
  ASSERT_EQ(so.n_speeds(), 4);
  const auto freqs = s.frequencies();
  const bool root = world_rank() == 0;
  // One run of 2N steps at speed i (the reference), on this rank.
  auto uninterrupted = [&](long i) {
    sim::SweepSettings sr = s;
    sr.keep_state = true;
    sr.revolutions = (2.0 * static_cast<double>(N) - 0.5) * s.base.dt * (w0 + static_cast<double>(i) * dw) / (2 * M_PI);
    sim::SpeedResult out;
    sim::sweep(PETSC_COMM_SELF, rm, sr, {sim::SpeedTask(i, w0 + static_cast<double>(i) * dw)},
               [&](const sim::SpeedResult& R) { out = R; });
    return out;
  };
  auto chains = [&](int direction, std::vector<sim::SpeedResult> done) {
    so.continuation = direction;
    std::size_t n_run = 0;
    sim::sweep_rounds(
        PETSC_COMM_WORLD, rm, s, so, {}, &done, freqs, [](const sim::SpeedResult&) {}, &n_run);
    std::sort(done.begin(), done.end(), [](const auto& a, const auto& b) { return a.index < b.index; });
    return done;  // on rank 0
  };
  auto rel = [](const std::vector<double>& a, const std::vector<double>& b) {
    double d = 0, m = 0;
    for (std::size_t j = 0; j < a.size(); ++j) d = std::max(d, std::abs(a[j] - b[j])), m = std::max(m, std::abs(b[j]));
    return a.size() == b.size() && m > 0 ? d / m : 1.0;
  };
  int ok_plan = 1, ok_file = 1, ok_resumed = 1;
  double worst = 0, dropped = 0, contact = 1e30, balance = 0;
  std::map<int, std::vector<sim::SpeedResult>> by_direction;
  for (int direction : {1, -1}) {
    const auto res = chains(direction, {});
    by_direction[direction] = res;
    if (root) {
      ok_plan &= res.size() == 4;
      // Up: 0 -> 1 and 2 -> 3; down: 1 -> 0 and 3 -> 2.
      for (long first : {0L, 2L}) {
        if (!ok_plan) break;
        const long a = direction > 0 ? first : first + 1, b = direction > 0 ? first + 1 : first;
        const auto &A = res[static_cast<std::size_t>(a)], &B = res[static_cast<std::size_t>(b)];
        ok_plan &= A.from == -1 && B.from == a && B.phase == A.phase_end && A.steps == N && B.steps == N &&
                   A.status == 0 && B.status == 0 && B.energy_start > 0;
        const auto ref = uninterrupted(a);
        ok_plan &= ref.steps == 2 * N;
        worst = std::max({worst, rel(B.q_end, ref.q_end), rel(B.qm_end, ref.qm_end)});
        contact = std::min(contact, static_cast<double>(B.max_active));
        print0(PETSC_COMM_SELF, "  continuation %s: speed %ld from %ld: |q_N - q_2N(uninterrupted)| / |q| = %.2e\n",
               direction > 0 ? "up" : "down", b, a, rel(B.q_end, ref.q_end));
        if (direction > 0 && first == 0) {  // the control: the lobes' angle dropped
          sim::SpeedTask t(b, B.omega);
          t.q0 = A.q_end, t.qm0 = A.qm_end, t.from = a, t.phase = 0.0;
          sim::SweepSettings sk = s;
          sk.keep_state = true;
          sim::SpeedResult X;
          sim::sweep(PETSC_COMM_SELF, rm, sk, {t}, [&](const sim::SpeedResult& R) { X = R; });
          dropped = rel(X.q_end, ref.q_end);
          print0(PETSC_COMM_SELF, "  control, the lobes' angle dropped: %.2e\n", dropped);
        }
      }
    }
    if (direction > 0) {
      // Resumed after the first round (speeds 0 and 2) from the file.
      std::vector<sim::SpeedResult> first_round;
      if (root) {
        sim::SweepRecord rec, back;
        rec.settings = "k=v\n", rec.n_speeds = 4, rec.frequencies = freqs;
        rec.results = {res[0], res[2]};
        const test::ScratchDir dir("continuation");
        const std::string path = dir.path("sweep.h5");
        sim::write_sweep(path, rec);
        std::string why;
        ok_file = sim::read_sweep(path, &back, &why) && back.results.size() == 2;
        for (std::size_t i = 0; ok_file && i < 2; ++i) {
          const auto &x = back.results[i], &y = rec.results[i];
          ok_file &= x.q_end == y.q_end && x.qm_end == y.qm_end && x.phase_end == y.phase_end && x.from == y.from &&
                     x.phase == y.phase && x.energy_start == y.energy_start;
        }
        if (!ok_file) print0(PETSC_COMM_SELF, "  file: %s\n", why.c_str());
        first_round = back.results;
      }
      const auto again = chains(1, first_round);
      if (root) {
        ok_resumed = again.size() == 4;
        for (std::size_t i = 0; ok_resumed && i < 4; ++i)
          ok_resumed &= again[i].q_end == res[i].q_end && again[i].rms == res[i].rms &&
                        again[i].spectrum == res[i].spectrum && again[i].from == res[i].from;
      }
    }
  }
  int ok_both = 1;
  {  // Both ways in one sweep: indices 0..3 are the up sweep's speeds, 4..7 the down sweep's, bitwise
    // (a lane's arithmetic does not depend on the lanes beside it).
    const auto both = chains(2, {});
    if (root) {
      ok_both = both.size() == 8 && so.n_speeds() == 8;
      for (std::size_t i = 0; ok_both && i < 8; ++i) {
        const auto& ref = by_direction[i < 4 ? 1 : -1][i % 4];
        const auto& x = both[i];
        ok_both &= x.index == static_cast<long>(i) && x.omega == ref.omega && x.q_end == ref.q_end &&
                   x.rms == ref.rms && x.spectrum == ref.spectrum &&
                   x.from == (ref.from < 0 ? -1 : ref.from + (i < 4 ? 0 : 4));
      }
    }
  }
  {  // A linear chain: the works of a continued speed count from its start.
    s.base.linear = true;
    const auto res = chains(1, {});
    s.base.linear = false;
    if (root && res.size() == 4) {
      const auto& B = res[1];
      const auto& w = B.work_end;
      const double sum = w.external + w.normal + w.friction - w.damping;
      const double scale = std::max({std::abs(B.energy_end), std::abs(B.energy_start), std::abs(w.normal),
                                     std::abs(w.friction), std::abs(w.damping)});
      balance = std::abs(B.energy_end - B.energy_start - sum) / scale;
      print0(PETSC_COMM_SELF, "  linear continued speed: E_start %.4e J, E_end %.4e J, balance residual %.2e\n",
             B.energy_start, B.energy_end, balance);
    } else if (root) {
      balance = 1.0;
    }
  }
  {  // The predicted wall time: the chains run side by side, on at most as many ranks as chains.
    so.continuation = 1;
    const auto cost = sim::predict_sweep_cost(PETSC_COMM_WORLD, rm, s, so, so.todo({}), {}, 0.02);
    int size = 1;
    MPI_Comm_size(PETSC_COMM_WORLD, &size);
    EXPECT_EQ(cost.steps, 4.0 * static_cast<double>(N));
    EXPECT_NEAR(cost.wall_seconds, cost.core_hours * 3600.0 / std::min(size, 2), 1e-12 * cost.wall_seconds);
    so.continuation = 2;  // both ways: every speed twice, 4 chains
    const auto cost2 = sim::predict_sweep_cost(PETSC_COMM_WORLD, rm, s, so, so.todo({}), {}, 0.02);
    EXPECT_EQ(cost2.steps, 8.0 * static_cast<double>(N));
    EXPECT_NEAR(cost2.wall_seconds, cost2.core_hours * 3600.0 / std::min(size, 4), 1e-12 * cost2.wall_seconds);
  }
  for (int* v : {&ok_plan, &ok_file, &ok_resumed, &ok_both}) MPI_Bcast(v, 1, MPI_INT, 0, PETSC_COMM_WORLD);
  for (double* v : {&worst, &dropped, &contact, &balance}) MPI_Bcast(v, 1, MPI_DOUBLE, 0, PETSC_COMM_WORLD);
  EXPECT_EQ(ok_plan, 1) << "the chains' order, starts or recorded origins are wrong";
  EXPECT_LT(worst, 1e-8) << "a continued speed is not the uninterrupted run";
  EXPECT_GT(dropped, 1e-3) << "without the lobes' angle the continued run should differ (the test cannot fail)";
  EXPECT_GE(contact, 1.0) << "the continued speeds never touched the casing (the case does not test the phase)";
  EXPECT_EQ(ok_file, 1) << "the final states do not survive the sweep file";
  EXPECT_EQ(ok_resumed, 1) << "a resumed continuation differs from the uninterrupted sweep";
  EXPECT_LT(balance, 1e-9) << "a continued linear speed's energy balance does not close";
  EXPECT_EQ(ok_both, 1) << "a continuation both ways differs from the up and down sweeps";
}

// The energy balance of central differences (sim::EnergyWork): the discrete energy E_{n+1/2}
// changes by the works of the load, the normal contact forces and friction, less the damping
// dissipation. The clamped box with a harmonic load on its free face, modal damping on every
// mode, rubbing the two-lobe casing with friction (mass-carrying and massless boundary): linear
// runs close the balance to round-off at every revolution; nonlinear runs without contact to
// O(h^2) (the midpoint rule on the potential), checked by halving the step.
namespace {
struct BalanceRun {
  double residual = 0, scale = 0;  // max |E - E_0 - net| over the rows; max |term|
  sim::EnergyWork w;
  long rows = 0;
};
BalanceRun balance_run(const nlrom::ReducedModel& rm, const std::vector<double>& X, bool contact, bool linear, double h,
                       double mu, double amplitude) {
  const std::size_t r = static_cast<std::size_t>(rm.r);
  sim::Settings s;
  s.dt = h;
  s.linear = linear;
  s.t_final = 3 * 2 * M_PI / 1500.0;  // three revolutions at 1,500 rad/s
  if (contact) {
    s.contact.obstacle = sim::Obstacle::Casing;
    s.contact.casing = {2e-4, 6e-4, 2, 0.3, 0.0, 1500.0};
    s.contact.mu = mu;
    s.contact.nodes = boundary_contact_nodes(X);
  }
  sim::ReducedLoad load;  // 2 kN per node along y at 2,500 rad/s on the face
  load.p.assign(r, 0.0);
  for (std::size_t k = 0; k < X.size() / 3; ++k) load.p[3 * k + 1] = 1.0;
  load.amplitude = amplitude, load.omega = 2500.0;
  BalanceRun R;
  double e0 = 0;
  const long every = std::max(1L, static_cast<long>(s.t_final / h / 20));
  sim::integrate(rm, {load}, s, [&](const sim::StepState& x) {
    if (x.step % every != 0) return;
    const double e = x.balance_energy();
    if (x.step == 0) e0 = e;
    const auto& w = *x.work;
    R.residual = std::max(R.residual, std::abs(e - e0 - w.net()));
    for (double t : {e - e0, w.external, w.normal, w.friction, w.damping}) R.scale = std::max(R.scale, std::abs(t));
    R.w = w;
    ++R.rows;
  });
  return R;
}
}  // namespace

TEST(Sim, EnergyBalanceClosesExactlyWhenLinearAndAtSecondOrderWhenNot) {
  auto m = box(ElementType::Hex8, 4);
  auto c = test::cb_basis(m, "x1", 3);
  const auto X = boundary_positions(m, c);
  for (bool massless : {false, true}) {
    const auto rm = box_model(m, c, massless, 0.02);
    const double h = 0.5 * sim::critical_step(rm);
    const char* name = massless ? "massless" : "mass-carrying";
    // Linear, with contact and friction: every term at work, the balance exact.
    const auto L = balance_run(rm, X, true, true, h, 0.15, 2e3);
    print0(PETSC_COMM_WORLD,
           "  %s, linear, contact: %ld rows, works: load %.4e, normal %.4e, friction %.4e, damping %.4e J; "
           "residual %.2e of %.2e J\n",
           name, L.rows, L.w.external, L.w.normal, L.w.friction, L.w.damping, L.residual, L.scale);
    EXPECT_LT(L.residual, 1e-10 * L.scale) << name;
    EXPECT_GT(std::abs(L.w.normal), 1e-3 * L.scale) << name << ": the casing should be touched";
    EXPECT_GT(std::abs(L.w.friction), 1e-4 * L.scale) << name << ": friction should work";
    EXPECT_GT(L.w.damping, 1e-3 * L.scale) << name;
    // Without friction, its work is zero and the balance still closes.
    const auto F = balance_run(rm, X, true, true, h, 0.0, 2e3);
    EXPECT_EQ(F.w.friction, 0.0) << name;
    EXPECT_LT(F.residual, 1e-10 * F.scale) << name;
    // Nonlinear, without contact, at amplitudes where g~ matters: the residual falls as h^2.
    const auto N1 = balance_run(rm, X, false, false, h, 0.0, 1e5);
    const auto N2 = balance_run(rm, X, false, false, h / 2, 0.0, 1e5);
    const double rate = std::log2(N1.residual / N2.residual);
    print0(PETSC_COMM_WORLD, "  %s, nonlinear: residual %.3e -> %.3e J of %.3e J (rate %.2f)\n", name, N1.residual,
           N2.residual, N1.scale, rate);
    EXPECT_GT(rate, 1.7) << name;
    EXPECT_LT(N1.residual, 1e-2 * N1.scale) << name;
    // Switched off (-sim_energy_balance false): no works offered.
    sim::Settings off;
    off.dt = h, off.t_final = 10 * h, off.linear = true, off.energy_balance = false;
    bool any = false;
    sim::integrate(rm, {}, off, [&](const sim::StepState& x) { any = any || x.work != nullptr; });
    EXPECT_FALSE(any) << name;
  }
}

// A free elastic bar (nu = 0, so the 1-D wave solution holds) moving at v0 onto a rigid wall,
// with a basis spanning the whole space: the closed form gives a contact lasting 2L/c, after
// which the bar leaves with -v0 and no strain energy. Central differences with forward-increment
// multipliers reach both within the discretization error, which falls with the mesh size, and
// the face never penetrates the wall.
TEST(Sim, BarImpactOnRigidWallMatchesWaveSolution) {
  mesh::Material mat = test::steel();
  mat.nu = 0.0;
  const double L = 1.0, v0 = 1.0, c = std::sqrt(mat.E / mat.rho), T = 2.0 * L / c;
  int rank = 0;
  MPI_Comm_rank(PETSC_COMM_WORLD, &rank);
  auto impact = [&](int nx, double* duration, double* rebound, double* energy_ratio, double* depth) {
    auto b = test::assembled_box(PETSC_COMM_WORLD, test::box_spec(ElementType::Hex8, L, 0.05, 0.05, nx, 1, 1), {}, mat);
    const PetscInt n = b.dofs.n_global;
    UMat V = identity_basis(b);
    auto rm = nlrom::project_model(PETSC_COMM_WORLD, V.get(), b.ops.K.get(), b.ops.M.get(), 0.0, 0);
    const std::size_t r = static_cast<std::size_t>(n);
    // The x = 0 face: global DOF of u_x and the position of each node, from every rank.
    std::vector<double> face(r, 0.0), xdir(r, 0.0);
    for (std::size_t k = 0; k < b.lm.node_owner.size(); ++k) {
      if (b.lm.node_owner[k] != rank) continue;
      const PetscInt dx = b.dofs.node_dof[3 * k];
      ASSERT_EQ(b.dofs.node_dof[3 * k + 1], dx + 1);
      ASSERT_EQ(b.dofs.node_dof[3 * k + 2], dx + 2);
      xdir[static_cast<std::size_t>(dx)] = 1.0;
      if (std::abs(b.lm.mesh.coords[3 * k]) < 1e-12) face[static_cast<std::size_t>(dx)] = 1.0;
    }
    MPI_Allreduce(MPI_IN_PLACE, face.data(), static_cast<int>(r), MPI_DOUBLE, MPI_SUM, PETSC_COMM_WORLD);
    MPI_Allreduce(MPI_IN_PLACE, xdir.data(), static_cast<int>(r), MPI_DOUBLE, MPI_SUM, PETSC_COMM_WORLD);
    sim::Settings s;
    s.linear = true;
    s.dt = 0.5 * sim::critical_step(rm);
    s.t_final = 2.5 * T;
    s.contact.mu = 0.0;
    s.contact.plane.normal[0] = 1.0, s.contact.plane.normal[2] = 0.0;  // the wall x = 0, free side x > 0
    for (std::size_t i = 0; i < r; ++i)
      if (face[i] > 0) {
        sim::ContactNode node;
        node.dof = i;
        s.contact.nodes.push_back(node);
      }
    ASSERT_EQ(s.contact.nodes.size(), 4u);
    s.v0.assign(r, 0.0);
    for (std::size_t i = 0; i < r; ++i) s.v0[i] = -v0 * xdir[i];
    // Mass-weighted mean x velocity: 1_x^T M v / 1_x^T M 1_x.
    std::vector<double> Mx(r, 0.0);
    double mass = 0.0;
    for (std::size_t i = 0; i < r; ++i)
      for (std::size_t j = 0; j < r; ++j) Mx[i] += rm.M[i * r + j] * xdir[j];
    for (std::size_t i = 0; i < r; ++i) mass += Mx[i] * xdir[i];
    double t_on = -1, t_off = -1, e0 = 0, v_after = 0, e_after = 0, min_gap = 0;
    sim::integrate(rm, {}, s, [&](const sim::StepState& x) {
      if (x.step == 0) e0 = x.energy();
      for (std::size_t k = 0; k < 4; ++k) min_gap = std::min(min_gap, x.gap[k]);
      if (x.active > 0) {
        if (t_on < 0) t_on = x.t;
        t_off = x.t;
      }
      double p = 0;
      for (std::size_t i = 0; i < r; ++i) p += Mx[i] * x.v[i];
      v_after = p / mass;
      e_after = x.energy();
    });
    // The contact is reported on the states it holds, from the first state after t = 0 to the
    // last state before release: add one step.
    *duration = t_off - t_on + s.dt;
    *rebound = v_after;
    *energy_ratio = e_after / e0;
    *depth = -min_gap;
  };
  double d[2], v[2], e[2], p[2];
  impact(20, &d[0], &v[0], &e[0], &p[0]);
  impact(40, &d[1], &v[1], &e[1], &p[1]);
  for (int i = 0; i < 2; ++i)
    print0(PETSC_COMM_WORLD,
           "  bar impact, %d elements: contact %.4e s (2L/c %.4e, error %.2f%%), rebound %.4f m/s, "
           "energy after / before %.4f, deepest penetration %.1e m\n",
           20 << i, d[i], T, 100 * (d[i] / T - 1), v[i], e[i], p[i]);
  for (int i = 0; i < 2; ++i) {
    EXPECT_NEAR(d[i], T, 0.03 * T) << "contact duration";
    EXPECT_NEAR(v[i], v0, 0.05 * v0) << "rebound velocity";
    EXPECT_LT(p[i], 1e-12 * v0 * T) << "penetration";
    // mu = 0: no energy is created; the loss is the inelastic impact of the discrete contact
    // nodes, which vanishes with h.
    EXPECT_LE(e[i], 1.0 + 1e-9);
    EXPECT_GT(e[i], 0.98);
  }
  EXPECT_LT(std::abs(d[1] - T), 0.8 * std::abs(d[0] - T)) << "the duration error does not fall with h";
  EXPECT_LT(std::abs(v[1] - v0), 0.8 * std::abs(v[0] - v0)) << "the rebound error does not fall with h";
  EXPECT_LT(1.0 - e[1], 0.8 * (1.0 - e[0])) << "the energy loss does not fall with h";
}

// Stress recovery (sim::recover_stress) against closed forms, on quadratic hex, tet and wedge
// boxes: (1) the linear pure-bending field u_x = k x z, u_y = -nu k y z,
// u_z = -k/2 (x^2 + nu (z^2 - y^2)) (z from mid-height) has sigma_xx = E k z and no other
// component, which quadratic elements recover exactly at every node; (2) the nonlinear (Cauchy)
// measure under a uniaxial stretch u = (a x, 0, 0): E11 = a + a^2/2, S11 = (lambda + 2 mu) E11,
// S22 = S33 = lambda E11, sigma11 = (1 + a) S11, sigma22 = sigma33 = S22 / (1 + a), uniform, so
// the element means equal it too; (3) a finite rigid rotation plus translation gives zero
// nonlinear stress to round-off, while the linear measure does not. The distributed result is
// bitwise the one computed on each rank alone.
TEST(Sim, StressRecoveryMatchesClosedForms) {
  int rank = 0;
  MPI_Comm_rank(PETSC_COMM_WORLD, &rank);
  const auto mat = test::steel();
  const double E = mat.E, nu = mat.nu, lambda = E * nu / ((1 + nu) * (1 - 2 * nu)), mu = E / (2 * (1 + nu));
  for (auto t : {ElementType::Hex20, ElementType::Tet10, ElementType::Wedge15}) {
    const auto spec = test::box_spec(t, 1.0, 0.2, 0.2, 4, 2, 2);
    auto lm = test::box_mesh(PETSC_COMM_WORLD, spec);
    auto self = test::box_mesh(PETSC_COMM_SELF, spec);
    // A nodal field of the local nodes of a mesh, from a function of the position.
    auto field = [](const mesh::LocalMesh& l, auto fn) {
      std::vector<double> u(l.mesh.coords.size());
      for (std::size_t k = 0; k < u.size() / 3; ++k) fn(&l.mesh.coords[3 * k], &u[3 * k]);
      return u;
    };
    auto solve = [&](const mesh::LocalMesh& l, auto fn, sim::StressMeasure m) {
      return sim::recover_stress(l, mat, l.mesh.node_ids, field(l, fn), m);
    };
    const double k = 1e-3, z0 = 0.1;
    auto bending = [&](const double* X, double* u) {
      const double x = X[0], y = X[1], z = X[2] - z0;
      u[0] = k * x * z, u[1] = -nu * k * y * z, u[2] = -0.5 * k * (x * x + nu * (z * z - y * y));
    };
    auto fb = solve(lm, bending, sim::StressMeasure::Linear);
    auto fb1 = solve(self, bending, sim::StressMeasure::Linear);
    const double a = 0.1, E11 = a + a * a / 2, s11 = (1 + a) * (lambda + 2 * mu) * E11, s22 = lambda * E11 / (1 + a);
    auto stretch = [&](const double* X, double* u) { u[0] = a * X[0], u[1] = u[2] = 0.0; };
    auto fs = solve(lm, stretch, sim::StressMeasure::Nonlinear);
    const double th = 0.5, c = std::cos(th), s = std::sin(th);
    auto rotation = [&](const double* X, double* u) {  // about e_z, then a translation
      u[0] = (c - 1) * X[0] - s * X[1] + 0.3, u[1] = s * X[0] + (c - 1) * X[1] - 0.1, u[2] = 0.2;
    };
    auto fr = solve(lm, rotation, sim::StressMeasure::Nonlinear);
    auto fr_lin = solve(lm, rotation, sim::StressMeasure::Linear);
    EXPECT_NEAR(fs.max_mises, s11 - s22, 1e-12 * s11);
    EXPECT_LT(fr.max_mises, 1e-6 * E) << "rigid rotation under the nonlinear measure";
    EXPECT_GT(fr_lin.max_mises, 0.1 * E * (1 - c)) << "the linear measure is not objective";
    if (rank != 0) continue;
    const auto gm = mesh::generate_box(spec);  // global node order = generation order here
    ASSERT_EQ(fb.nodal_mises.size(), static_cast<std::size_t>(gm.num_nodes()));
    double eb = 0.0, es = 0.0, er = 0.0, emean = 0.0;
    for (std::int64_t n = 0; n < gm.num_nodes(); ++n) {
      const double z = gm.coords[3 * n + 2] - z0;
      const double* sb = &fb.nodal_stress[6 * n];
      eb = std::max(eb, std::abs(sb[0] - E * k * z));
      for (int q = 1; q < 6; ++q) eb = std::max(eb, std::abs(sb[q]));
      eb = std::max(eb, std::abs(fb.nodal_mises[n] - E * k * std::abs(z)));
      const double* ss = &fs.nodal_stress[6 * n];
      es = std::max({es, std::abs(ss[0] - s11), std::abs(ss[1] - s22), std::abs(ss[2] - s22)});
      er = std::max(er, fr.nodal_mises[n]);
    }
    for (double v : fs.element_mises) emean = std::max(emean, std::abs(v - (s11 - s22)));
    print0(PETSC_COMM_SELF,
           "  stress %s: bending %.1e, stretch %.1e, element mean %.1e, rotation %.1e (of E k z %.2e, %.2e)\n",
           mesh::element_name(t), eb / (E * k * 0.1), es / s11, emean / s11, er / E, E * k * 0.1, s11);
    EXPECT_LT(eb, 1e-9 * E * k * 0.1) << mesh::element_name(t) << ": pure bending";
    EXPECT_LT(es, 1e-12 * s11) << mesh::element_name(t) << ": uniaxial stretch";
    EXPECT_LT(emean, 1e-12 * s11) << mesh::element_name(t) << ": element means";
    EXPECT_LT(er, 1e-9 * E * (1 - c)) << mesh::element_name(t) << ": rigid rotation";
    EXPECT_EQ(fb.nodal_stress, fb1.nodal_stress) << "1 rank against all ranks";
    EXPECT_EQ(fb.element_mises, fb1.element_mises);
    EXPECT_EQ(fb.element_mises_max, fb1.element_mises_max);
  }
}

// sim::write_sim writes what read_sim reads: the histories, final state, sets, snapshots, contact
// histories and the stored load to the last bit. Each rank writes and reads its own file (a
// simulate case is serial).
TEST(SimFile, RoundTrips) {
  int pid = world_rank() == 0 ? static_cast<int>(getpid()) : 0;
  MPI_Bcast(&pid, 1, MPI_INT, 0, PETSC_COMM_WORLD);
  const std::string file = cat("/tmp/morse_test_sim_file_", pid, "_r", world_rank(), ".h5");
  auto seq = [](std::size_t n, double a) {
    std::vector<double> v(n);
    for (std::size_t k = 0; k < n; ++k) v[k] = a * std::cos(0.3 * k) + k;
    return v;
  };
  const std::size_t nt = 4, r = 3, nn = 2, nd = 5;
  sim::SimRecord rec;
  rec.time = seq(nt, 0.1), rec.energy = seq(nt, 2.0), rec.q = seq(nt * r, 1e-3);
  rec.final_q = seq(r, 1.0), rec.final_v = seq(r, -1.0), rec.final_time = 0.3;
  rec.sets.push_back({"tip", {4, 9}, seq(nt * 2 * 3, 1e-4)});
  rec.snapshots_fom = "fom.h5";
  rec.snapshot_time = {0.0, 0.2}, rec.snapshot_u = seq(2 * nd, 1.0), rec.snapshot_v = seq(2 * nd, 3.0);
  rec.snapshot_node_ids = {1, 1, 2, 2, 3}, rec.snapshot_components = {0, 1, 0, 2, 1};
  auto& c = rec.contact;
  c.node_ids = {4, 9}, c.normal = seq(nt * nn, 5.0), c.tangential = seq(nt * nn * 3, 0.5);
  c.normals = seq(nn * 3, 1.0), c.mean_force = seq(nt * nn * 3, 7.0), c.mean_force_time = seq(nt, 0.05);
  c.gap = seq(nt * nn, 1e-5), c.active = {0, 1, 2, 1}, c.radial_displacement = seq(nt * nn, 1e-6);
  c.max_normal_force = 12.5, c.time_of_max_normal_force = 0.2;
  rec.balance.time = {0.0, 0.1, 0.2}, rec.balance.energy = seq(3, 2.0), rec.balance.external = seq(3, 0.1);
  rec.balance.normal = seq(3, -0.2), rec.balance.friction = seq(3, 0.3), rec.balance.damping = seq(3, 0.05);
  rec.balance.period = 0.1;
  rec.rom = "rom.h5", rec.case_name = "b";
  rec.load.loads.resize(1);
  rec.load.loads[0].set = "tip", rec.load.loads[0].dir[2] = 1, rec.load.loads[0].amplitude = 3,
  rec.load.loads[0].omega = 9;
  sim::Settings s;
  s.dt = 1e-3, s.t_final = 0.3;
  s.contact.nodes.resize(nn);
  s.contact.obstacle = sim::Obstacle::Casing;
  s.contact.casing.omega = 100;
  sim::Stats stats;
  stats.steps = 300;
  {
    io::H5Output out(PETSC_COMM_SELF, file);
    sim::write_sim(out, rec, s, stats);
    out.commit();
  }
  const auto back = sim::read_sim(file, {"tip"});
  EXPECT_EQ(back.time, rec.time);
  EXPECT_EQ(back.energy, rec.energy);
  EXPECT_EQ(back.q, rec.q);
  EXPECT_EQ(back.final_q, rec.final_q);
  EXPECT_EQ(back.final_v, rec.final_v);
  EXPECT_EQ(back.final_time, rec.final_time);
  ASSERT_EQ(back.sets.size(), 1u);
  EXPECT_EQ(back.sets[0].name, "tip");
  EXPECT_EQ(back.sets[0].node_ids, rec.sets[0].node_ids);
  EXPECT_EQ(back.sets[0].u, rec.sets[0].u);
  EXPECT_EQ(back.snapshots_fom, rec.snapshots_fom);
  EXPECT_EQ(back.snapshot_time, rec.snapshot_time);
  EXPECT_EQ(back.snapshot_u, rec.snapshot_u);
  EXPECT_EQ(back.snapshot_v, rec.snapshot_v);
  EXPECT_EQ(back.snapshot_node_ids, rec.snapshot_node_ids);
  EXPECT_EQ(back.snapshot_components, rec.snapshot_components);
  EXPECT_EQ(back.balance.time, rec.balance.time);
  EXPECT_EQ(back.balance.energy, rec.balance.energy);
  EXPECT_EQ(back.balance.external, rec.balance.external);
  EXPECT_EQ(back.balance.normal, rec.balance.normal);
  EXPECT_EQ(back.balance.friction, rec.balance.friction);
  EXPECT_EQ(back.balance.damping, rec.balance.damping);
  EXPECT_EQ(back.balance.period, rec.balance.period);
  const auto& b = back.contact;
  EXPECT_EQ(b.node_ids, c.node_ids);
  EXPECT_EQ(b.normal, c.normal);
  EXPECT_EQ(b.tangential, c.tangential);
  EXPECT_EQ(b.normals, c.normals);
  EXPECT_EQ(b.mean_force, c.mean_force);
  EXPECT_EQ(b.mean_force_time, c.mean_force_time);
  EXPECT_EQ(b.gap, c.gap);
  EXPECT_EQ(b.active, c.active);
  EXPECT_EQ(b.radial_displacement, c.radial_displacement);
  EXPECT_EQ(b.max_normal_force, c.max_normal_force);
  EXPECT_EQ(b.time_of_max_normal_force, c.time_of_max_normal_force);
  EXPECT_EQ(back.rom, "rom.h5");
  EXPECT_EQ(back.case_name, "b");
  ASSERT_EQ(back.load.loads.size(), 1u);
  EXPECT_EQ(back.load.loads[0].set, "tip");
  EXPECT_EQ(back.load.loads[0].omega, 9.0);
  // The contact group also reads as a load history (dyn::read_load_table, the -load_history of
  // morse fom): the mean forces at their times.
  dyn::LoadTable table;
  EXPECT_EQ(dyn::read_load_table(file, &table), "");
  EXPECT_EQ(table.time, c.mean_force_time);
  EXPECT_EQ(table.forces, c.mean_force);
  std::remove(file.c_str());
}

TEST(SimRun, CasePathsAndSpeedGrid) {
  EXPECT_EQ(sim::case_path("out/simulate.h5", "a"), "out/simulate_a.h5");
  EXPECT_EQ(sim::case_path("run.d/simulate", "b"), "run.d/simulate_b.h5");
  EXPECT_EQ(sim::case_path("x.y.h5", "c"), "x.y_c.h5");
  sim::SweepOptions so;
  so.omega_min = 100, so.omega_max = 130, so.omega_step = 10;
  EXPECT_EQ(so.n_speeds(), 4);
  const auto todo = so.todo({1, 3});
  ASSERT_EQ(todo.size(), 2u);
  EXPECT_EQ(todo[0].index, 0);
  EXPECT_EQ(todo[1].index, 2);
  EXPECT_EQ(todo[1].omega, 120.0);
  so.omega_max = so.omega_min;
  EXPECT_EQ(so.n_speeds(), 1);
}

TEST(SimRun, CasesRoundRobinReportEveryFailure) {
  int size = 1, rank = 0;
  MPI_Comm_size(PETSC_COMM_WORLD, &size);
  MPI_Comm_rank(PETSC_COMM_WORLD, &rank);
  std::vector<std::size_t> ran;
  sim::run_cases(PETSC_COMM_WORLD, {"a", "b", "c"}, [&](std::size_t i) { ran.push_back(i); });
  for (std::size_t i : ran) EXPECT_EQ(static_cast<int>(i % size), rank);
  try {
    sim::run_cases(PETSC_COMM_WORLD, {"a", "b", ""}, [&](std::size_t i) {
      if (i != 0) throw Error(cat("bad ", i));
    });
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("case b: bad 1"), std::string::npos) << m;
    EXPECT_NE(m.find("bad 2"), std::string::npos) << m;
    EXPECT_EQ(m.find("case a"), std::string::npos) << m;
  }
}

TEST(SimRun, ContactOptionsReadAndCheckTheirValues) {
  MORSE_CALL(PetscOptionsSetValue(nullptr, "-contact_set", "tip"));
  MORSE_CALL(PetscOptionsSetValue(nullptr, "-contact_plane_normal", "0,3,4"));
  MORSE_CALL(PetscOptionsSetValue(nullptr, "-casing_clearance", "1e-3"));
  MORSE_CALL(PetscOptionsSetValue(nullptr, "-casing_lobes", "0"));
  sim::ContactOptions c;
  MORSE_CALL(c.set_from_options(PETSC_COMM_WORLD));
  EXPECT_EQ(c.set, "tip");
  EXPECT_TRUE(c.plane_given);
  EXPECT_DOUBLE_EQ(c.plane.normal[1], 0.6);
  EXPECT_DOUBLE_EQ(c.plane.normal[2], 0.8);
  EXPECT_DOUBLE_EQ(c.casing.bump_height, 2e-3);  // default 2 x clearance
  EXPECT_EQ(c.error, "-casing_lobes must be >= 1 (got 0)");
  for (const char* o : {"-contact_set", "-contact_plane_normal", "-casing_clearance", "-casing_lobes"})
    MORSE_CALL(PetscOptionsClearValue(nullptr, o));
}

// The sweep settings refuse non-finite speeds and grids beyond kMaxSweepSpeeds, naming the options
// and the file size they would need; a finite grid is read as given.
TEST(SimRun, SweepOptionsRefuseNonFiniteAndHugeGrids) {
  auto read = [](std::initializer_list<std::pair<const char*, const char*>> given) {
    test::GivenOptions g(given);
    sim::SweepOptions so;
    MORSE_CALL(so.set_from_options(PETSC_COMM_WORLD));
    return so;
  };
  // read(given) must throw an error naming the option and its text.
  auto refused = [&](std::initializer_list<std::pair<const char*, const char*>> given, const std::string& msg) {
    test::expect_error_parts([&] { read(given); }, {msg}, msg);
  };
  auto so = read({{"-sweep_omega_min", "800"}, {"-sweep_omega_max", "1e15"}, {"-sweep_omega_step", "1e-6"}});
  EXPECT_NE(so.error.find("-sweep_omega_min 800, -sweep_omega_max 1e+15 and -sweep_omega_step 1e-06 give 1e+21 "
                          "speeds; a sweep takes at most 1000000"),
            std::string::npos)
      << so.error;
  EXPECT_NE(so.error.find(" GB, 4312 bytes per speed"), std::string::npos) << so.error;  // 500 bins, 24 orders
  test::expect_error_parts([&] { so.check(); }, {"1e+21 speeds"}, "check() raises the error");
  // Non-finite values are refused when read, naming the option and the text (the option wrappers).
  refused({{"-sweep_omega_min", "800"}, {"-sweep_omega_max", "inf"}, {"-sweep_omega_step", "100"}},
          "-sweep_omega_max inf: expected a finite number");
  refused({{"-sweep_omega_min", "nan"}, {"-sweep_omega_max", "900"}, {"-sweep_omega_step", "100"}},
          "-sweep_omega_min nan: expected a finite number");
  refused({{"-sweep_omega_min", "800"}, {"-sweep_omega_max", "900"}, {"-sweep_omega_step", "100"}, {"-sim_dt", "inf"}},
          "-sim_dt inf: expected a finite number");
  refused({{"-sweep_omega_min", "800"},
           {"-sweep_omega_max", "900"},
           {"-sweep_omega_step", "100"},
           {"-casing_clearance", "inf"}},
          "-casing_clearance inf: expected a finite number");
  // The largest grid taken, and one more speed.
  so = read({{"-sweep_omega_min", "1"}, {"-sweep_omega_max", "1000000"}, {"-sweep_omega_step", "1"}});
  EXPECT_EQ(so.error, "");
  EXPECT_EQ(so.n_speeds(), sim::kMaxSweepSpeeds);
  so = read({{"-sweep_omega_min", "1"}, {"-sweep_omega_max", "1000001"}, {"-sweep_omega_step", "1"}});
  EXPECT_NE(so.error.find("-sweep_omega_max 1000001 and -sweep_omega_step 1 give 1000001 speeds"), std::string::npos)
      << so.error;
  // The sense of rotation: the grid's magnitudes, turned negative, and a key of the settings.
  so = read({{"-sweep_omega_min", "800"}, {"-sweep_omega_max", "1000"}, {"-sweep_omega_step", "100"}});
  EXPECT_EQ(so.rotation, 1);
  so = read({{"-sweep_omega_min", "800"},
             {"-sweep_omega_max", "1000"},
             {"-sweep_omega_step", "100"},
             {"-sweep_rotation", "negative"}});
  EXPECT_EQ(so.rotation, -1);
  const auto todo = so.todo({1});
  ASSERT_EQ(todo.size(), 2u);
  EXPECT_EQ(todo[0].omega, -800.0);
  EXPECT_EQ(todo[1].omega, -1000.0);
  nlrom::ReducedModel model;
  model.r = 2, model.K = {2, -1, -1, 2}, model.M = {1, 0, 0, 1}, model.C.assign(4, 0.0);
  const auto text = sim::settings_text(so, sim::SweepSettings(), model);
  EXPECT_NE(text.find("\nrotation=-1\n"), std::string::npos);
  // The model's numbers are a key: the same model, the same text; another stiffness, another.
  EXPECT_NE(text.find("\nmodel=" + nlrom::fingerprint(model) + "\n"), std::string::npos);
  EXPECT_EQ(nlrom::fingerprint(model).size(), 16u);
  auto other = model;
  other.K[0] = 2.0000000001;
  EXPECT_NE(nlrom::fingerprint(other), nlrom::fingerprint(model));
  EXPECT_NE(sim::settings_difference(text, sim::settings_text(so, sim::SweepSettings(), other)).find("model: "),
            std::string::npos);
  test::expect_error_parts(
      [&] {
        read({{"-sweep_rotation", "sideways"}});
      },
      {"-sweep_rotation", "sideways"}, "an unknown sense of rotation");
  // Retries and the divergence limit: their ranges, and keys of the settings.
  so = read({{"-sweep_omega_min", "800"}, {"-sweep_omega_max", "900"}, {"-sweep_omega_step", "100"}});
  EXPECT_EQ(so.retries, 1);
  // The batch: unless given, 16 lanes for the AVX-512 build of the potential kernel, else 8.
  EXPECT_FALSE(so.batch_given);
  EXPECT_EQ(so.isa, -1);
  EXPECT_EQ(sim::default_sweep_batch(-1), sim::best_kernel_isa() == sim::KernelIsa::Avx512 ? 16 : 8);
  EXPECT_EQ(sim::default_sweep_batch(static_cast<int>(sim::KernelIsa::Avx512)), 16);
  EXPECT_EQ(sim::default_sweep_batch(static_cast<int>(sim::KernelIsa::Avx2)), 8);
  EXPECT_EQ(sim::default_sweep_batch(static_cast<int>(sim::KernelIsa::Baseline)), 8);
  {
    const auto given = read({{"-sweep_omega_min", "800"},
                             {"-sweep_omega_max", "900"},
                             {"-sweep_omega_step", "100"},
                             {"-sweep_batch", "5"},
                             {"-sweep_isa", "baseline"}});
    EXPECT_TRUE(given.batch_given);
    EXPECT_EQ(given.batch, 5);
    EXPECT_EQ(given.isa, static_cast<int>(sim::KernelIsa::Baseline));
    EXPECT_TRUE(given.error.empty()) << given.error;
  }
  EXPECT_LT(so.divergence_limit, 0.0) << "default: the tip radius";
  // Refinement on engine-order lines: the orders measured, the thresholds' ranges, a refined sweep.
  {
    auto lines = read({{"-sweep_omega_min", "800"},
                       {"-sweep_omega_max", "1600"},
                       {"-sweep_omega_step", "100"},
                       {"-sweep_refine_step", "25"},
                       {"-sweep_refine_orders", "6,8"}});
    EXPECT_TRUE(lines.error.empty()) << lines.error;
    EXPECT_EQ(lines.refine_orders, (std::vector<int>{6, 8}));
    EXPECT_EQ(lines.orders, 24);
    EXPECT_EQ(lines.refine_order_jump, 0.5);
    EXPECT_EQ(lines.refine_order_floor, 0.1);
    struct Bad {
      std::vector<std::pair<const char*, const char*>> extra;
      const char* msg;
    };
    const Bad bads[] = {
        {{{"-sweep_refine_step", "25"}, {"-sweep_refine_orders", "30"}},
         "-sweep_refine_orders: engine order 30 is not among those measured, 1..-sweep_orders 24"},
        {{{"-sweep_refine_step", "25"}, {"-sweep_refine_orders", "6"}, {"-sweep_orders", "4"}},
         "engine order 6 is not among those measured, 1..-sweep_orders 4"},
        {{{"-sweep_refine_step", "25"}, {"-sweep_refine_orders", "0"}}, "engine order 0 is not among"},
        {{{"-sweep_refine_orders", "6"}}, "-sweep_refine_orders applies to a refined sweep: give -sweep_refine_step"},
        {{{"-sweep_refine_step", "25"}, {"-sweep_refine_orders", "6"}, {"-sweep_refine_order_jump", "1"}},
         "-sweep_refine_order_jump must be in (0, 1) (got 1"},
        {{{"-sweep_refine_step", "25"}, {"-sweep_refine_orders", "6"}, {"-sweep_refine_order_floor", "-0.1"}},
         "-sweep_refine_order_floor must be in [0, 1) (got -0.1"},
        {{{"-sweep_orders", "-1"}}, "-sweep_orders must be in 0..1000 (got -1)"},
    };
    for (const auto& b : bads) {
      std::vector<std::pair<const char*, const char*>> all = {
          {"-sweep_omega_min", "800"}, {"-sweep_omega_max", "1600"}, {"-sweep_omega_step", "100"}};
      all.insert(all.end(), b.extra.begin(), b.extra.end());
      test::GivenOptions g;
      for (const auto& [name, value] : all) PetscOptionsSetValue(nullptr, name, value), g.names.emplace_back(name);
      sim::SweepOptions o;
      MORSE_CALL(o.set_from_options(PETSC_COMM_WORLD));
      EXPECT_NE(o.error.find(b.msg), std::string::npos) << o.error;
    }
  }
  for (const char* bad : {"-1", "21"}) {
    so = read({{"-sweep_omega_min", "800"},
               {"-sweep_omega_max", "900"},
               {"-sweep_omega_step", "100"},
               {"-sweep_retries", bad}});
    EXPECT_NE(so.error.find(cat("-sweep_retries must be in 0..20 (got ", bad)), std::string::npos) << so.error;
  }
  so = read({{"-sweep_omega_min", "800"},
             {"-sweep_omega_max", "900"},
             {"-sweep_omega_step", "100"},
             {"-sim_tangent_checks", "-1"}});
  EXPECT_EQ(so.error, "-sim_tangent_checks must be >= 0 (got -1; 0: no tangent checks)");
  refused({{"-sweep_omega_min", "800"},
           {"-sweep_omega_max", "900"},
           {"-sweep_omega_step", "100"},
           {"-sweep_divergence_limit", "nan"}},
          "-sweep_divergence_limit nan: expected a finite number");
  so = read({{"-sweep_omega_min", "800"},
             {"-sweep_omega_max", "900"},
             {"-sweep_omega_step", "100"},
             {"-sweep_retries", "3"}});
  sim::SweepSettings limited;
  limited.divergence_limit = 0.25;
  const auto keyed = sim::settings_text(so, limited, model);
  EXPECT_NE(keyed.find("\nretries=3\n"), std::string::npos) << keyed;
  EXPECT_NE(keyed.find("\ndivergence_limit=0.25\n"), std::string::npos) << keyed;
  EXPECT_EQ(keyed.find("continuation="), std::string::npos) << "a key only for a continuation (old files resume)";
  // Continuation: its chains (in the order they run), keys of the settings, and what it refuses.
  so = read({{"-sweep_omega_min", "800"},
             {"-sweep_omega_max", "1000"},
             {"-sweep_omega_step", "40"},
             {"-sweep_continuation", "down"},
             {"-sweep_chains", "2"}});
  EXPECT_EQ(so.error, "");
  EXPECT_EQ(so.continuation, -1);
  EXPECT_EQ(so.chain_order(), (std::vector<std::vector<long>>{{2, 1, 0}, {5, 4, 3}}));
  const auto cont = sim::settings_text(so, limited, model);
  EXPECT_NE(cont.find("\ncontinuation=down\nchains=2\n"), std::string::npos) << cont;
  {
    auto both = so;
    both.continuation = 2;
    EXPECT_EQ(both.n_speeds(), 12);
    EXPECT_EQ(both.chain_order(), (std::vector<std::vector<long>>{{0, 1, 2}, {3, 4, 5}, {8, 7, 6}, {11, 10, 9}}));
    EXPECT_EQ(both.omega_of(7), 840.0);
    EXPECT_NE(sim::settings_text(both, limited, model).find("\ncontinuation=both\n"), std::string::npos);
    EXPECT_EQ(read({{"-sweep_omega_min", "800"},
                    {"-sweep_omega_max", "1000"},
                    {"-sweep_omega_step", "40"},
                    {"-sweep_continuation", "both"}})
                  .continuation,
              2);
  }
  {  // the next speed of each chain: after speed 2 (with a state) and none of the second chain
    sim::SpeedResult R;
    R.index = 2, R.omega = 880, R.q_end = {1, 2}, R.qm_end = {3, 4}, R.phase_end = 0.5;
    auto next = so.next_in_chains({R});
    ASSERT_EQ(next.size(), 2u);
    EXPECT_EQ(next[0].index, 1);
    EXPECT_EQ(next[0].omega, 840.0);
    EXPECT_EQ(next[0].from, 2);
    EXPECT_EQ(next[0].q0, R.q_end);
    EXPECT_EQ(next[0].qm0, R.qm_end);
    EXPECT_EQ(next[0].phase, 0.5);
    EXPECT_EQ(next[1].index, 5);
    EXPECT_TRUE(next[1].q0.empty()) << "a chain's first speed starts from rest";
    R.status = 1, R.q_end.clear(), R.qm_end.clear();  // a failed speed: its successor from rest
    next = so.next_in_chains({R});
    EXPECT_TRUE(next[0].q0.empty());
    EXPECT_EQ(next[0].from, -1);
  }
  so = read({{"-sweep_omega_min", "800"},
             {"-sweep_omega_max", "1000"},
             {"-sweep_omega_step", "40"},
             {"-sweep_continuation", "up"},
             {"-sweep_refine_step", "10"}});
  EXPECT_NE(so.error.find("-sweep_continuation and -sweep_refine_step exclude each other"), std::string::npos)
      << so.error;
  for (const char* bad : {"0", "7"}) {
    so = read({{"-sweep_omega_min", "800"},
               {"-sweep_omega_max", "1000"},
               {"-sweep_omega_step", "40"},
               {"-sweep_continuation", "up"},
               {"-sweep_chains", bad}});
    EXPECT_NE(
        so.error.find(cat("-sweep_chains ", bad == std::string("0") ? "must be at least 1 (got 0)" : "7 is more")),
        std::string::npos)
        << so.error;
  }
  test::expect_error_parts(
      [&] {
        read({{"-sweep_continuation", "sideways"}});
      },
      {"-sweep_continuation", "sideways"}, "an unknown continuation");
}

// simulate's options refuse non-finite initial states and steps, a case given twice and a case
// name that would write outside -out's directory, naming the option.
TEST(SimRun, SimOptionsRefuseNonFiniteValuesAndBadCases) {
  auto read = [](std::initializer_list<std::pair<const char*, const char*>> given) {
    test::GivenOptions g(given);
    sim::SimOptions so;
    MORSE_CALL(so.set_from_options(PETSC_COMM_WORLD));
    return so;
  };
  // read(given) must throw an error naming the option and its text.
  auto refused = [&](std::initializer_list<std::pair<const char*, const char*>> given, const std::string& msg) {
    test::expect_error_parts([&] { read(given); }, {msg}, msg);
  };
  // Non-finite values are refused when read, naming the option and the text (the option wrappers).
  refused({{"-sim_q0", "0,nan,1"}}, "-sim_q0 0,nan,1: item 'nan': expected a finite number");
  refused({{"-sim_v0", "inf"}}, "-sim_v0 inf: item 'inf': expected a finite number");
  refused({{"-sim_v0_uniform", "0,0,-inf"}}, "-sim_v0_uniform 0,0,-inf: item '-inf': expected a finite number");
  refused({{"-sim_dt", "nan"}}, "-sim_dt nan: expected a finite number");
  EXPECT_EQ(read({{"-sim_cases", "a,b,a"}, {"-out", "run.h5"}}).error,
            "-sim_cases: case a is given twice (each case writes its own file, run_a.h5)");
  EXPECT_EQ(read({{"-sim_cases", "a,../../etc/x"}, {"-out", "run.h5"}}).error,
            "-sim_cases: case name '../../etc/x' must not be empty nor contain '/' or '..' (case c writes run_c.h5)");
  EXPECT_NE(read({{"-sim_cases", "sub/x"}}).error.find("case name 'sub/x'"), std::string::npos);
  EXPECT_NE(read({{"-sim_cases", "x..y"}}).error.find("case name 'x..y'"), std::string::npos);
  const auto ok = read({{"-sim_cases", "a,b"}, {"-sim_q0", "1,2"}, {"-sim_dt", "1e-6"}});
  EXPECT_EQ(ok.error, "");
  EXPECT_EQ(ok.s.q0, (std::vector<double>{1, 2}));
  EXPECT_EQ(ok.s.tangent_checks, 200);
  EXPECT_EQ(read({{"-sim_tangent_checks", "0"}}).s.tangent_checks, 0);
  EXPECT_EQ(read({{"-sim_tangent_checks", "-3"}}).error,
            "-sim_tangent_checks must be >= 0 (got -3; 0: no tangent checks)");
  refused({{"-sim_omega", "inf"}}, "-sim_omega inf: expected a finite number");
  refused({{"-contact_plane_normal", "0,0,inf"}},
          "-contact_plane_normal 0,0,inf: item 'inf': expected a finite number");
}

// A sweep checkpoint is resumed only with the same settings; the refusal names every key that
// differs, and the reduced model given by another spelling of the same file (relative against
// absolute) is the same setting.
TEST(SimRun, SweepSettingsDifferenceNamesTheKeys) {
  const std::string rel = "sweep_settings_rom.h5";
  if (world_rank() == 0) std::fclose(std::fopen(rel.c_str(), "w"));
  MPI_Barrier(PETSC_COMM_WORLD);
  const std::string stored = "rom=" + rel + "\nr=15\ndt=1e-06\nmu=0.1\n";
  EXPECT_EQ(sim::settings_difference(stored, "rom=" + files::absolute_path(rel) + "\nr=15\ndt=1e-06\nmu=0.1\n"), "");
  EXPECT_EQ(sim::settings_difference(stored, "rom=./" + rel + "\nr=15\ndt=2e-06\nmu=0.1\nlobes=2\n"),
            "dt: 1e-06 in the file, 2e-06 now; lobes: (none) in the file, 2 now");
  EXPECT_EQ(sim::settings_difference(stored, "rom=other.h5\nr=15\ndt=1e-06\nmu=0.1\n"),
            "rom: " + rel + " in the file, other.h5 now");
  // A path stored by an older run, relative to the file that stores it, is found from elsewhere.
  EXPECT_EQ(files::resolve_stored_path(rel, "/no/such/dir/sim.h5"), rel);  // exists from here
  // found nowhere: as stored (a name no run leaves behind, beside a directory that does not exist;
  // "x.h5" beside /tmp/sim.h5 failed once a run had left /tmp/x.h5)
  EXPECT_EQ(files::resolve_stored_path("morse_test_absent_4e7a.h5", "/no/such/dir/sim.h5"),
            "morse_test_absent_4e7a.h5");
  EXPECT_EQ(files::absolute_path(""), "");
  MPI_Barrier(PETSC_COMM_WORLD);
  if (world_rank() == 0) std::remove(rel.c_str());
}
