// Nonlinear statics and full-order dynamics (dyn/dyn.hpp) against references from outside
// morse: the Euler elastica (large-deflection cantilever), modal superposition of a harmonic
// response in closed form, modal damping decay exp(-xi w t), exact energy balance of the energy
// scheme, and the independence of the rank count.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "elastica.hpp"
#include "given_options.hpp"
#include "morse/core/session.hpp"
#include "morse/dyn/dyn.hpp"
#include "morse/io/h5.hpp"
#include "scratch.hpp"
#include "util.hpp"

using namespace morse;
using mesh::ElementType;

namespace {

struct Beam {
  mesh::LocalMesh lm;
  fe::DofLayout dofs;
  fe::Operators ops;
  mesh::Material mat;
};

Beam cantilever(MPI_Comm comm, ElementType t, double L, double h, int nx, int nyz, double nu) {
  Beam b;
  b.mat = test::steel();
  b.mat.nu = nu;
  b.lm = test::box_mesh(comm, test::box_spec(t, L, h, h, nx, nyz, nyz));
  b.dofs = fe::number_dofs(b.lm, {"x0"});
  b.ops = fe::assemble(b.lm, b.dofs, b.mat);
  return b;
}

// Mean of component d of u over the nodes of a set. Collective.
double set_mean(const Beam& b, Vec u, const std::string& set, int d) {
  int rank = 0;
  MPI_Comm_rank(b.lm.comm, &rank);
  const double* a;
  MORSE_CALL(VecGetArrayRead(u, &a));
  double s[2] = {0, 0}, g[2];
  for (auto k : b.lm.mesh.node_sets.at(set)) {
    if (b.lm.node_owner[k] != rank) continue;
    const PetscInt dof = b.dofs.node_dof[3 * k + d];
    s[0] += dof >= 0 ? a[dof - b.dofs.first] : 0.0;
    s[1] += 1;
  }
  MORSE_CALL(VecRestoreArrayRead(u, &a));
  MPI_Allreduce(s, g, 2, MPI_DOUBLE, MPI_SUM, b.lm.comm);
  return g[0] / g[1];
}

dyn::NodalLoad tip_load(double amplitude, double omega, int dir = 2) {
  dyn::NodalLoad l;
  l.set = "x1";
  l.dir[dir] = 1.0;
  l.amplitude = amplitude;
  l.omega = omega;
  return l;
}

}  // namespace

// Tip deflection of a slender cantilever (L/h = 25) under a dead tip load P against the
// elliptic-integral elastica, at P L^2/EI = 1 and 5 (tip rotation 26 and 70 degrees).
TEST(Static, CantileverMatchesEulerElastica) {
  const double L = 1.0, h = 0.04;
  auto b = cantilever(PETSC_COMM_WORLD, ElementType::Hex20, L, h, 24, 1, 0.0);
  fe::Svk svk(b.lm, b.dofs, b.mat, b.ops.K.get());
  const double EI = b.mat.E * h * h * h * h / 12.0;
  const double n_tip = static_cast<double>(b.lm.node_set_sizes.at("x1"));
  for (double alpha : {1.0, 5.0}) {
    const double P = alpha * EI / (L * L);
    dyn::Loads loads(b.lm, b.dofs, {tip_load(P / n_tip, 0.0)});
    dyn::StaticSettings s;
    s.steps = alpha > 2 ? 8 : 3;
    auto r = dyn::solve_static(svk, loads, s);
    const auto ref = test::cantilever_tip_load_elastica(alpha);
    const double w = set_mean(b, r.u.get(), "x1", 2) / L, shortening = -set_mean(b, r.u.get(), "x1", 0) / L;
    EXPECT_NEAR(w, ref.deflection, 0.01 * ref.deflection) << "alpha " << alpha;
    EXPECT_NEAR(shortening, ref.shortening, 0.02 * ref.shortening) << "alpha " << alpha;
    // The linear solution is w/L = alpha/3, far from the elastica at alpha = 5.
    s.linear = true;
    auto rl = dyn::solve_static(svk, loads, s);
    EXPECT_NEAR(set_mean(b, rl.u.get(), "x1", 2) / L, alpha / 3.0, 0.01 * alpha / 3.0);
  }
}

// Linear twin under a harmonic tip load from rest against modal superposition in closed form:
// u(t) = sum_k phi_k phi_k^T F / (w_k^2 - W^2) (sin W t - W/w_k sin w_k t), with the modes of the
// model (20 of them plus the quasi-static correction of the rest).
TEST(Fom, LinearTwinMatchesModalSuperposition) {
  auto b = cantilever(PETSC_COMM_WORLD, ElementType::Hex20, 1.0, 0.1, 6, 1, 0.3);
  fe::Svk svk(b.lm, b.dofs, b.mat, b.ops.K.get());
  eigen::EigenSettings es;
  es.nev = 20;
  es.prefix = "test_modes_";
  auto eig = eigen::solve_eigen(b.ops.K.get(), b.ops.M.get(), es, nullptr);
  const double w1 = std::sqrt(eig.omega2[0]), W = 0.6 * w1, A = 100.0;
  dyn::Loads loads(b.lm, b.dofs, {tip_load(A, W)});
  UVec F, ustat, tmp;
  MORSE_CALL(MatCreateVecs(b.ops.K.get(), F.ptr(), ustat.ptr()));
  MORSE_CALL(VecDuplicate(F.get(), tmp.ptr()));
  loads.evaluate(M_PI / (2 * W), F.get());                  // amplitude pattern
  test::direct_solve(b.ops.K.get(), F.get(), ustat.get());  // K^-1 F (all modes, static)
  // Tip response of each mode and of the static remainder.
  const int m = 20;
  std::vector<double> coef(m), tip(m);
  double tip_static = set_mean(b, ustat.get(), "x1", 2), tip_rest = tip_static;
  for (int k = 0; k < m; ++k) {
    Vec phi;
    MORSE_CALL(MatDenseGetColumnVecRead(eig.V.get(), k, &phi));
    MORSE_CALL(VecDot(phi, F.get(), &coef[k]));
    tip[k] = set_mean(b, phi, "x1", 2);
    MORSE_CALL(MatDenseRestoreColumnVecRead(eig.V.get(), k, &phi));
    tip_rest -= coef[k] * tip[k] / eig.omega2[k];
  }
  auto exact = [&](double t) {
    double u = tip_rest * std::sin(W * t);
    for (int k = 0; k < m; ++k) {
      const double wk = std::sqrt(eig.omega2[k]);
      u += tip[k] * coef[k] / (eig.omega2[k] - W * W) * (std::sin(W * t) - W / wk * std::sin(wk * t));
    }
    return u;
  };
  dyn::FomSettings s;
  s.linear = true;
  s.dt = 2 * M_PI / w1 / 200;
  s.t_final = 3 * 2 * M_PI / W;
  double err = 0, peak = 0;
  dyn::integrate(svk, b.ops.M.get(), loads, s, nullptr, nullptr, [&](const dyn::StepInfo& i) {
    const double u = set_mean(b, i.u, "x1", 2), e = exact(i.t);
    err = std::max(err, std::abs(u - e));
    peak = std::max(peak, std::abs(e));
  });
  EXPECT_LT(err, 0.01 * peak) << "max error " << err << " peak " << peak;
}

// Modal damping (low-rank C, Woodbury solve): free decay from the first mode's shape follows
// exp(-xi w1 t).
TEST(Fom, ModalDampingDecayRate) {
  auto b = cantilever(PETSC_COMM_WORLD, ElementType::Hex20, 1.0, 0.1, 6, 1, 0.3);
  fe::Svk svk(b.lm, b.dofs, b.mat, b.ops.K.get());
  eigen::EigenSettings es;
  es.nev = 3;
  es.prefix = "test_modes_";
  auto eig = eigen::solve_eigen(b.ops.K.get(), b.ops.M.get(), es, nullptr);
  const double w1 = std::sqrt(eig.omega2[0]), xi = 0.02;
  UVec u0;
  MORSE_CALL(MatCreateVecs(b.ops.K.get(), u0.ptr(), nullptr));
  Vec phi;
  MORSE_CALL(MatDenseGetColumnVecRead(eig.V.get(), 0, &phi));
  MORSE_CALL(VecCopy(phi, u0.get()));
  MORSE_CALL(MatDenseRestoreColumnVecRead(eig.V.get(), 0, &phi));
  dyn::Loads loads(b.lm, b.dofs, {});
  dyn::FomSettings s;
  s.linear = true;
  s.modal_xi = xi;
  s.damping_modes = 3;
  const double T = 2 * M_PI / w1;
  s.dt = T / 400;
  s.t_final = 10 * T;
  double peak_first = 0, peak_last = 0, q0 = 0;
  dyn::integrate(svk, b.ops.M.get(), loads, s, u0.get(), nullptr, [&](const dyn::StepInfo& i) {
    const double q = set_mean(b, i.u, "x1", 2);
    if (i.step == 0) q0 = q;
    if (i.t < T) peak_first = std::max(peak_first, std::abs(q));
    if (i.t > 9 * T - 1e-12) peak_last = std::max(peak_last, std::abs(q));
  });
  ASSERT_GT(std::abs(q0), 0.0);
  // Envelope after 9 periods of the damped oscillator (w_d = w1 sqrt(1 - xi^2)).
  const double expected = std::exp(-xi * w1 * 9 * T / std::sqrt(1 - xi * xi));
  EXPECT_NEAR(peak_last / peak_first, expected, 0.01 * expected);
}

// Undamped, unforced large-amplitude vibration from a deflected state: the energy scheme keeps
// kinetic + strain energy constant to the Newton tolerance over 1,000 steps.
TEST(Fom, EnergySchemeConservesEnergy) {
  auto b = cantilever(PETSC_COMM_WORLD, ElementType::Hex8, 1.0, 0.05, 8, 1, 0.3);
  fe::Svk svk(b.lm, b.dofs, b.mat, b.ops.K.get());
  const double EI = b.mat.E * std::pow(0.05, 4) / 12.0;
  dyn::Loads push(b.lm, b.dofs, {tip_load(2.0 * EI / b.lm.node_set_sizes.at("x1"), 0.0)});
  dyn::StaticSettings ss;
  ss.steps = 4;
  auto u0 = dyn::solve_static(svk, push, ss);
  dyn::Loads none(b.lm, b.dofs, {});
  dyn::FomSettings s;
  s.dt = 2e-4;
  s.t_final = 1000 * s.dt;
  s.scheme = dyn::Scheme::Energy;
  s.newton_rtol = 1e-10;
  double e0 = 0, worst = 0, tip_min = 1e300, strain_nl = 0;
  auto st = dyn::integrate(svk, b.ops.M.get(), none, s, u0.u.get(), nullptr, [&](const dyn::StepInfo& i) {
    if (i.step == 0) e0 = i.energy.balance();
    worst = std::max(worst, std::abs(i.energy.balance() - e0));
    tip_min = std::min(tip_min, set_mean(b, i.u, "x1", 2));
    strain_nl = std::max(strain_nl, std::abs(i.energy.strain_nonlinear));
  });
  EXPECT_EQ(st.steps, 1000);
  EXPECT_LT(tip_min, 0.0) << "the beam should swing through";
  EXPECT_GT(strain_nl, 1e-3 * e0) << "not a nonlinear test";
  EXPECT_LT(worst, 1e-8 * e0) << "energy drift " << worst << " of " << e0;
}

// The same short nonlinear forced run on one rank and on all ranks agrees to round-off.
TEST(Fom, IndependentOfRankCount) {
  int rank = 0;
  MPI_Comm_rank(PETSC_COMM_WORLD, &rank);
  auto run = [](MPI_Comm comm) {
    auto b = cantilever(comm, ElementType::Wedge15, 1.0, 0.05, 6, 1, 0.3);
    fe::Svk svk(b.lm, b.dofs, b.mat, b.ops.K.get());
    const double EI = b.mat.E * std::pow(0.05, 4) / 12.0;
    dyn::Loads loads(b.lm, b.dofs, {tip_load(3.0 * EI / b.lm.node_set_sizes.at("x1"), 300.0, 1)});
    dyn::FomSettings s;
    s.dt = 1e-4;
    s.t_final = 40 * s.dt;
    s.rayleigh_alpha = 1.0;
    std::vector<double> h;
    dyn::integrate(svk, b.ops.M.get(), loads, s, nullptr, nullptr, [&](const dyn::StepInfo& i) {
      for (int d = 0; d < 3; ++d) h.push_back(set_mean(b, i.u, "x1", d));
      h.push_back(i.energy.kinetic + i.energy.strain_linear + i.energy.strain_nonlinear);
    });
    return h;
  };
  std::vector<double> serial;
  if (rank == 0) serial = run(PETSC_COMM_SELF);
  auto all = run(PETSC_COMM_WORLD);
  std::string msg;
  if (rank == 0) {
    // Tip displacements against the largest displacement, energies against the largest energy.
    msg = test::history_rank_difference(serial, all, 1e-10);
  }
  EXPECT_FALSE(any_rank(PETSC_COMM_WORLD, !msg.empty())) << msg;
}

// Newton-Krylov (matrix-free exact tangent, reused factor as preconditioner) and modified Newton
// solve the same discrete equations: with Rayleigh and modal damping both active (every term of
// the Jacobian product), their trajectories agree to the Newton tolerance, and Krylov takes
// quadratically convergent (hence fewer) Newton iterations.
TEST(Fom, NewtonKrylovMatchesModifiedNewton) {
  auto b = cantilever(PETSC_COMM_WORLD, ElementType::Tet10, 1.0, 0.05, 6, 1, 0.3);
  fe::Svk svk(b.lm, b.dofs, b.mat, b.ops.K.get());
  const double EI = b.mat.E * std::pow(0.05, 4) / 12.0;
  dyn::Loads loads(b.lm, b.dofs, {tip_load(4.0 * EI / b.lm.node_set_sizes.at("x1"), 300.0, 1)});
  auto run = [&](dyn::Newton newton, dyn::FomStats* st) {
    dyn::FomSettings s;
    s.dt = 2e-4;
    s.t_final = 30 * s.dt;
    s.rayleigh_alpha = 2.0;
    s.rayleigh_beta = 1e-6;
    s.modal_xi = 0.02;
    s.damping_modes = 3;
    s.newton_rtol = 1e-10;
    s.newton = newton;
    std::vector<double> h;
    *st = dyn::integrate(svk, b.ops.M.get(), loads, s, nullptr, nullptr, [&](const dyn::StepInfo& i) {
      h.push_back(set_mean(b, i.u, "x1", 1));
      h.push_back(set_mean(b, i.u, "x1", 0));
    });
    return h;
  };
  dyn::FomStats sk, sm;
  auto hk = run(dyn::Newton::Krylov, &sk);
  auto hm = run(dyn::Newton::Modified, &sm);
  ASSERT_EQ(hk.size(), hm.size());
  double scale = 0, diff = 0, shortening = 0;
  for (std::size_t i = 0; i < hk.size(); ++i) {
    scale = std::max(scale, std::abs(hm[i]));
    diff = std::max(diff, std::abs(hk[i] - hm[i]));
    if (i % 2 == 1) shortening = std::max(shortening, std::abs(hm[i]));
  }
  EXPECT_GT(shortening, 1e-3 * scale) << "not a nonlinear test (no axial shortening)";
  EXPECT_LT(diff, 1e-8 * scale) << "Krylov vs modified Newton: " << diff << " of " << scale;
  EXPECT_GT(sk.krylov_iterations, 0);
  EXPECT_LT(sk.newton_iterations, sm.newton_iterations);
  EXPECT_EQ(sm.krylov_iterations, 0);
}

// The load description of a run (/fom/load, /sim/load) reads back as written; a file without it
// (written before morse stored it) reads as "not stored"; t_max is the first maximum of the first
// harmonic load. Each rank writes and reads its own file (serial HDF5).
TEST(RunFile, LoadDescriptionRoundTrips) {
  int pid = world_rank() == 0 ? static_cast<int>(getpid()) : 0;
  MPI_Bcast(&pid, 1, MPI_INT, 0, PETSC_COMM_WORLD);
  const std::string file = cat("/tmp/morse_test_dyn_load_", pid, "_r", world_rank(), ".h5");
  dyn::LoadDescription d;
  d.loads.resize(3);
  d.loads[0].set = "x1", d.loads[0].dir[2] = 1, d.loads[0].amplitude = 5;  // constant
  d.loads[1].set = "tip", d.loads[1].dir[0] = 0.6, d.loads[1].dir[1] = 0.8, d.loads[1].amplitude = 1e6;
  d.loads[1].omega = 300, d.loads[1].phase = 0.25;
  d.loads[2].set = "x1", d.loads[2].dir[1] = -1, d.loads[2].amplitude = 2, d.loads[2].omega = 900;
  d.history = "forces.csv";
  d.history_scale = 0.5;
  d.history_outside = dyn::Outside::Hold;
  {
    io::H5Output out(PETSC_COMM_SELF, file);
    out.write("/fom/time", std::vector<double>{0.0, 1.0});
    dyn::write_load_description(out, "/fom/load", d);
    out.commit();
  }
  dyn::LoadDescription back;
  ASSERT_TRUE(dyn::read_load_description(file, "/fom/load", &back));
  ASSERT_EQ(back.loads.size(), d.loads.size());
  for (std::size_t k = 0; k < d.loads.size(); ++k) {
    EXPECT_EQ(back.loads[k].set, d.loads[k].set);
    for (int c = 0; c < 3; ++c) EXPECT_EQ(back.loads[k].dir[c], d.loads[k].dir[c]);
    EXPECT_EQ(back.loads[k].amplitude, d.loads[k].amplitude);
    EXPECT_EQ(back.loads[k].omega, d.loads[k].omega);
    EXPECT_EQ(back.loads[k].phase, d.loads[k].phase);
  }
  EXPECT_EQ(back.history, d.history);
  EXPECT_EQ(back.history_scale, d.history_scale);
  EXPECT_EQ(back.history_outside, dyn::Outside::Hold);
  // The first harmonic load's first maximum: 300 t + 0.25 = pi/2.
  EXPECT_NEAR(dyn::first_maximum(back.loads), (M_PI / 2 - 0.25) / 300, 1e-15);
  EXPECT_EQ(dyn::first_maximum({d.loads[0]}), -1);
  // No stored load: false, the description untouched; no load at all: stored, empty.
  EXPECT_FALSE(dyn::read_load_description(file, "/sim/load", &back));
  EXPECT_EQ(back.loads.size(), 3u);
  {
    io::H5Output out(PETSC_COMM_SELF, file);
    dyn::write_load_description(out, "/sim/load", dyn::LoadDescription{});
    out.commit();
  }
  ASSERT_TRUE(dyn::read_load_description(file, "/sim/load", &back));
  EXPECT_TRUE(back.loads.empty());
  EXPECT_TRUE(back.history.empty());
  std::remove(file.c_str());
}

// dyn::write_fom and the snapshot writer write what read_fom and read_fom_snapshots read: the
// histories and monitored sets to the last bit, the snapshots as the distributed vectors written,
// on 1 and 2 ranks.
TEST(RunFile, FomFileRoundTrips) {
  auto m = test::assembled_box(PETSC_COMM_WORLD, test::box_spec(ElementType::Hex8, 1.0, 0.2, 0.2, 3, 1, 1));
  int pid = world_rank() == 0 ? static_cast<int>(getpid()) : 0;
  MPI_Bcast(&pid, 1, MPI_INT, 0, PETSC_COMM_WORLD);
  const std::string file = cat("/tmp/morse_test_dyn_fom_", pid, ".h5");
  std::vector<UVec> us, vs;
  for (int k = 0; k < 3; ++k) {
    us.push_back(
        test::nodal_vector(m.lm, m.dofs, [=](double x, double y, double z, int d) { return (k + 1) * x + y * d - z; }));
    vs.push_back(
        test::nodal_vector(m.lm, m.dofs, [=](double x, double, double z, int d) { return std::sin(k + x + d * z); }));
  }
  dyn::FomHistory h;
  dyn::SetProbe probe(m.lm, m.dofs, "x1");
  h.sets.push_back({"x1", probe.node_ids(), {}});
  dyn::FomSettings s;
  s.dt = 0.5;
  s.scheme = dyn::Scheme::Energy;
  dyn::FomStats stats;
  stats.steps = 2;
  stats.damping_omega = {3.0};
  dyn::LoadDescription ld;
  ld.loads.resize(1);
  ld.loads[0].set = "x1", ld.loads[0].dir[1] = 1, ld.loads[0].amplitude = 10, ld.loads[0].omega = 7;
  std::vector<double> snap_times;
  {
    io::H5Output out(PETSC_COMM_WORLD, file);
    dyn::FomSnapshotWriter snaps(out, m.lm, m.dofs, 3);
    for (int k = 0; k < 3; ++k) {
      dyn::StepInfo i;
      i.step = k, i.t = 0.5 * k, i.u = us[k].get(), i.v = vs[k].get();
      i.energy.kinetic = 1 + k, i.energy.strain_linear = 2 * k, i.energy.strain_nonlinear = 0.1 * k;
      i.energy.external_work = 3 * k, i.energy.damping_loss = 0.01 * k;
      i.newton_iterations = k + 2, i.residual = 1e-9 * k;
      h.record(i);
      auto u = probe.sample(i.u);
      h.sets[0].u.insert(h.sets[0].u.end(), u.begin(), u.end());
      snaps.write(i);
    }
    snaps.close();
    snap_times = snaps.times();
    dyn::write_fom(out, h, snap_times, 1, s, stats, ld);
    out.commit();
  }
  EXPECT_EQ(snap_times, (std::vector<double>{0.0, 0.5, 1.0}));
  if (world_rank() == 0) {
    const auto back = dyn::read_fom(file, {"x1"});
    EXPECT_EQ(back.time, h.time);
    EXPECT_EQ(back.energy, h.energy);
    EXPECT_EQ(back.kinetic, h.kinetic);
    EXPECT_EQ(back.strain_linear, h.strain_linear);
    EXPECT_EQ(back.strain_nonlinear, h.strain_nonlinear);
    EXPECT_EQ(back.external_work, h.external_work);
    EXPECT_EQ(back.damping_loss, h.damping_loss);
    EXPECT_EQ(back.balance, h.balance);
    EXPECT_EQ(back.newton_iterations, h.newton_iterations);
    EXPECT_EQ(back.residual, h.residual);
    ASSERT_EQ(back.sets.size(), 1u);
    EXPECT_EQ(back.sets[0].node_ids, h.sets[0].node_ids);
    EXPECT_EQ(back.sets[0].u, h.sets[0].u);
    EXPECT_EQ(io::read_string_attribute(file, "/fom", "scheme"), "energy");
    EXPECT_EQ(io::read_string_attribute(file, "/fom", "newton"), "modified");
    dyn::LoadDescription lb;
    ASSERT_TRUE(dyn::read_load_description(file, "/fom/load", &lb));
    ASSERT_EQ(lb.loads.size(), 1u);
    EXPECT_EQ(lb.loads[0].omega, 7.0);
    test::expect_error_parts([&] { dyn::read_fom(file, {"tip"}); }, {file, "/fom/sets/tip"},
                             "read_fom of a missing set");
  }
  // One snapshot as nodal displacements (morse stress -fom): the nearest to the time asked, the
  // probe's samples at the nodes of x1, every node with a free DOF present.
  {
    const auto f = dyn::read_fom_snapshot(file, 0.6);
    EXPECT_EQ(f.index, 1);
    EXPECT_EQ(f.time, 0.5);
    EXPECT_EQ(f.n_rows, 3);
    const auto x1 = probe.sample(us[1].get());  // rank 0 only
    if (world_rank() == 0) {
      std::map<std::int64_t, std::size_t> at;
      for (std::size_t j = 0; j < f.node_ids.size(); ++j) at[f.node_ids[j]] = j;
      ASSERT_EQ(f.u.size(), 3 * f.node_ids.size());
      for (std::size_t n = 0; n < probe.node_ids().size(); ++n) {
        ASSERT_TRUE(at.count(probe.node_ids()[n]));
        for (int c = 0; c < 3; ++c) EXPECT_EQ(f.u[3 * at[probe.node_ids()[n]] + c], x1[3 * n + c]);
      }
      EXPECT_TRUE(std::is_sorted(f.node_ids.begin(), f.node_ids.end()));
    }
    const std::string none = file + ".none.h5";
    test::expect_error_parts([&] { dyn::read_fom_snapshot(none, 0.0); }, {none, "no full-field snapshots"},
                             "a fom file without snapshots");
  }
  auto X = dyn::read_fom_snapshots(m.lm, m.dofs, file);
  PetscInt n_snap = 0;
  MORSE_CALL(MatGetSize(X.get(), nullptr, &n_snap));
  ASSERT_EQ(n_snap, 3);
  for (int k = 0; k < 3; ++k) {
    Vec c;
    PetscBool same = PETSC_FALSE;
    MORSE_CALL(MatDenseGetColumnVecRead(X.get(), k, &c));
    MORSE_CALL(VecEqual(c, us[k].get(), &same));
    MORSE_CALL(MatDenseRestoreColumnVecRead(X.get(), k, &c));
    EXPECT_TRUE(same) << "snapshot " << k;
  }
  MPI_Barrier(PETSC_COMM_WORLD);
  if (world_rank() == 0) std::remove(file.c_str());
}

// dyn::write_static writes what -fom_initial reads back (io::read_nodal_field of /static/u): the
// displacement on every free DOF to the last bit; and the history of the increments.
TEST(RunFile, StaticFileRoundTrips) {
  auto m = test::assembled_box(PETSC_COMM_WORLD, test::box_spec(ElementType::Hex8, 1.0, 0.2, 0.2, 3, 1, 1));
  int pid = world_rank() == 0 ? static_cast<int>(getpid()) : 0;
  MPI_Bcast(&pid, 1, MPI_INT, 0, PETSC_COMM_WORLD);
  const std::string file = cat("/tmp/morse_test_dyn_static_", pid, ".h5");
  dyn::StaticResult res;
  res.u = test::nodal_vector(m.lm, m.dofs, [](double x, double y, double z, int d) { return x * x + 0.1 * y - z * d; });
  res.history = {{0.5, 3, 1e-10, true, ""}, {1.0, 4, 2e-10, true, ""}};
  res.load_norm = 7.0;
  dyn::StaticSettings s;
  std::vector<dyn::SetProbe> probes;
  probes.emplace_back(m.lm, m.dofs, "x1");
  {
    io::H5Output out(PETSC_COMM_WORLD, file);
    io::write_mesh(out, mesh::gather_to_rank0(m.lm));  // the command's part: the node ids
    dyn::write_static(out, m.lm, m.dofs, res, probes, s);
    out.commit();
  }
  UVec back;
  MORSE_CALL(VecDuplicate(res.u.get(), back.ptr()));
  MORSE_CALL(VecSet(back.get(), 0.0));
  io::read_nodal_field(m.lm, m.dofs, file, "/static/u", back.get());
  PetscBool same = PETSC_FALSE;
  MORSE_CALL(VecEqual(back.get(), res.u.get(), &same));
  EXPECT_TRUE(same);
  if (world_rank() == 0) {
    std::vector<double> lambda;
    std::vector<hsize_t> d;
    std::string err;
    EXPECT_TRUE(io::read_doubles(file, "/static/history/load_factor", &lambda, &d, &err)) << err;
    EXPECT_EQ(lambda, (std::vector<double>{0.5, 1.0}));
    double norm = 0;
    EXPECT_TRUE(io::read_attribute(file, "/static", "load_norm", &norm, &err) && norm == 7.0) << err;
  }
  MPI_Barrier(PETSC_COMM_WORLD);
  if (world_rank() == 0) std::remove(file.c_str());
}

// dyn::get_loads reads -load_* (under a case prefix too) and records the first bad value, naming
// the option; the load-history and fom settings read and validate their options.
TEST(Options, LoadsHistoryAndFomSettings) {
  using test::GivenOptions;
  {
    GivenOptions g{{"-c1_load_sets", "tip,root"},
                   {"-c1_load_tip_dir", "y"},
                   {"-c1_load_tip_amplitude", "3"},
                   {"-c1_load_tip_omega", "100"},
                   {"-c1_load_root_amplitude", "1"}};
    std::vector<dyn::NodalLoad> loads;
    std::string error;
    ASSERT_EQ(dyn::get_loads(PETSC_COMM_WORLD, &loads, &error, "c1_"), PETSC_SUCCESS);
    ASSERT_EQ(loads.size(), 2u);
    EXPECT_EQ(loads[0].set, "tip");
    EXPECT_EQ(loads[0].dir[1], 1.0);
    EXPECT_EQ(loads[0].amplitude, 3.0);
    EXPECT_EQ(loads[0].omega, 100.0);
    EXPECT_EQ(error, "load on set root: give its direction with -c1_load_root_dir x|y|z|vx,vy,vz");
    EXPECT_TRUE(options::registered("-c1_load_tip_phase"));
  }
  // Non-finite load values are refused when read, naming the option and the text (the option
  // wrappers' check); a negative frequency by get_loads.
  for (const auto& [opt, value] : {std::pair<const char*, const char*>{"-c2_load_tip_amplitude", "nan"},
                                   {"-c2_load_tip_omega", "inf"},
                                   {"-c2_load_tip_phase", "-inf"}}) {
    GivenOptions g{{"-c2_load_sets", "tip"}, {"-c2_load_tip_dir", "y"}, {"-c2_load_tip_amplitude", "1"}, {opt, value}};
    std::vector<dyn::NodalLoad> loads;
    std::string error;
    try {
      dyn::get_loads(PETSC_COMM_WORLD, &loads, &error, "c2_");
      ADD_FAILURE() << opt << " " << value << " accepted";
    } catch (const Error& e) {
      EXPECT_EQ(std::string(e.what()), cat(opt, " ", value, ": expected a finite number"));
    }
  }
  {
    GivenOptions g{{"-c2_load_sets", "tip"},
                   {"-c2_load_tip_dir", "y"},
                   {"-c2_load_tip_amplitude", "1"},
                   {"-c2_load_tip_omega", "-3"}};
    std::vector<dyn::NodalLoad> loads;
    std::string error;
    ASSERT_EQ(dyn::get_loads(PETSC_COMM_WORLD, &loads, &error, "c2_"), PETSC_SUCCESS);
    EXPECT_EQ(error, "-c2_load_tip_omega must be >= 0 (got -3)");
  }
  {
    GivenOptions g{{"-load_history_outside", "hold"}};
    dyn::LoadHistoryOptions h;
    ASSERT_EQ(h.set_from_options(PETSC_COMM_WORLD), PETSC_SUCCESS);
    EXPECT_EQ(h.outside, dyn::Outside::Hold);
    EXPECT_EQ(h.error, "-load_history_outside needs -load_history FILE");
  }
  {
    GivenOptions g{{"-fom_dt", "1e-3"},          {"-fom_tfinal", "0.01"},  {"-fom_scheme", "energy"},
                   {"-fom_monitor", "tip,root"}, {"-fom_rayleigh", "1,2"}, {"-fom_snapshot_every", "5"}};
    dyn::FomSettings s;
    ASSERT_EQ(s.set_from_options(PETSC_COMM_WORLD), PETSC_SUCCESS);
    EXPECT_EQ(s.error, "");
    EXPECT_EQ(s.dt, 1e-3);
    EXPECT_EQ(s.scheme, dyn::Scheme::Energy);
    EXPECT_EQ(s.monitor, (std::vector<std::string>{"tip", "root"}));
    EXPECT_EQ(s.rayleigh_beta, 2.0);
    EXPECT_EQ(s.snapshot_every, 5);
  }
  {
    GivenOptions g{{"-fom_dt", "1e-3"}, {"-fom_newton", "exact"}};
    dyn::FomSettings s;
    ASSERT_EQ(s.set_from_options(PETSC_COMM_WORLD), PETSC_SUCCESS);
    EXPECT_EQ(s.error, "-fom_newton exact: unknown (krylov or modified)");
  }
  {
    GivenOptions g{{"-fom_dt", "1e-3"}};
    dyn::FomSettings s;
    ASSERT_EQ(s.set_from_options(PETSC_COMM_WORLD), PETSC_SUCCESS);
    EXPECT_EQ(s.error, "-fom_tfinal must be positive (got 0)");
  }
}
