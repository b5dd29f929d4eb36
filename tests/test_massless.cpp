// Massless-boundary reduced models (issue 27; nlrom::massless_transform, make_massless: MacNeal's
// residual flexibility on the reduced model), against independent references on a hex20
// cantilever:
//  - with its boundary free, the model's modes are exactly the lowest modes of the reduced model
//    it comes from (the CB model's own eigenproblem, solved separately), and its mass is
//    diag(0, I);
//  - their frequencies converge to the full model's (the block eigen solver on K, M) as the number
//    of fixed-interface modes grows, exactly as the mass-carrying model's do;
//  - its critical steps are ordered: every static coordinate held <= the contact normals held <=
//    free, and the free one is 2 / omega of its highest dynamic mode;
//  - with its interior mass-scaled (-nlrom_massless_interior scaled), the z coordinates are
//    K-orthogonal to the rest, their frequencies are capped at the scaling frequency and the other
//    modes are unchanged; a nonlinear run converges to the static interior's at second order in
//    the load frequency over the scaling frequency.
#include <petscsys.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "morse/cb/craig_bampton.hpp"
#include "morse/core/log.hpp"
#include "morse/eigen/eigen.hpp"
#include "morse/fe/nonlinear.hpp"
#include "morse/nlrom/nlrom.hpp"
#include "morse/sim/sim.hpp"
#include "scratch.hpp"
#include "util.hpp"

using namespace morse;
using mesh::ElementType;

namespace {

test::Model beam(int nx) {
  return test::assembled_box(PETSC_COMM_WORLD, test::box_spec(ElementType::Hex20, 1.0, 0.1, 0.1, nx, 1, 1));
}

// The massless model of the CB basis of `m` with boundary x1 and n_fixed modes (no damping).
nlrom::ReducedModel massless_cb(const test::Model& m, PetscInt n_fixed, double fmax_hz = 0.0,
                                cb::CBResult* cb_out = nullptr) {
  auto c = test::cb_basis(m, "x1", n_fixed);
  const PetscInt r = c.n();
  PetscInt n_static = 0;
  auto V = nlrom::transform_basis(c.T.get(), nlrom::massless_transform(c.M, c.K, r, c.n_b, fmax_hz, &n_static));
  auto rm = nlrom::project_model(PETSC_COMM_WORLD, V.get(), m.ops.K.get(), m.ops.M.get(), 0.0, 0);
  rm.n_b = c.n_b;
  nlrom::make_massless(&rm, n_static, 0.0, 0);
  if (cb_out) *cb_out = std::move(c);
  return rm;
}

}  // namespace

// Boundary free: the modes of the massless model are the lowest of the CB model (r - n_b of them by
// default, those up to a frequency with -nlrom_massless_fmax), its mass is diag(0, I), and the
// critical steps are ordered.
TEST(Massless, FreeBoundaryModesAreTheReducedModelsLowest) {
  const auto m = beam(10);
  for (int variant = 0; variant < 2; ++variant) {
    cb::CBResult c;
    auto probe = test::cb_basis(m, "x1", 12);
    const auto wcb = eigen::dense_eigenvalues(static_cast<int>(probe.n()), probe.K, probe.M);
    // Variant 1: the modes up to the midpoint of modes 6 and 7 dynamic, the rest residual.
    const double fmax = variant == 0 ? 0.0 : 0.5 * (std::sqrt(wcb[5]) + std::sqrt(wcb[6])) / (2.0 * M_PI);
    const auto rm = massless_cb(m, 12, fmax, &c);
    const std::size_t r = static_cast<std::size_t>(rm.r), ns = static_cast<std::size_t>(rm.n_static), nd = r - ns;
    // By default r - n_b = 12 dynamic modes; this face needs one more residual mode for its
    // flexibility, which massless_transform finds and reports: 11.
    if (variant == 0)
      ASSERT_TRUE(nd == 11u || nd == 12u) << nd;
    else
      ASSERT_EQ(nd, 6u);
    ASSERT_EQ(rm.n_b, 24);
    double dm = 0, damping = 0;
    for (std::size_t i = 0; i < r; ++i)
      for (std::size_t j = 0; j < r; ++j) {
        dm = std::max(dm, std::abs(rm.M[i * r + j] - (i >= ns && i == j ? 1.0 : 0.0)));
        damping = std::max(damping, std::abs(rm.C[i * r + j]));
      }
    const auto w = nlrom::free_eigenvalues(rm);
    double dw = 0;
    for (std::size_t k = 0; k < nd; ++k) dw = std::max(dw, std::abs(w[k] / wcb[k] - 1.0));
    double free_dt = 0;
    const double held_all = nlrom::massless_critical_step(rm, &free_dt);
    // The x components of the face nodes held (a plane contact of normal x on every node).
    std::vector<double> H(ns * (ns > 0 ? static_cast<std::size_t>(rm.n_b) / 3 : 0), 0.0);
    const std::size_t nh = static_cast<std::size_t>(rm.n_b) / 3;
    for (std::size_t k = 0; k < nh; ++k) H[(3 * k) * nh + k] = 1.0;
    const double held_x = nlrom::massless_critical_step(rm, H, nh);
    print0(PETSC_COMM_WORLD,
           "  %zu dynamic modes: max |w / w_CB - 1| %.1e, max |M - diag(0, I)| %.1e; critical steps: all static held "
           "%.4e s <= x held %.4e s <= free %.4e s = 2 / omega_%zu %.4e s\n",
           nd, dw, dm, held_all, held_x, free_dt, nd, 2.0 / std::sqrt(wcb[nd - 1]));
    EXPECT_LT(dw, 1e-9);
    EXPECT_EQ(dm, 0.0);
    EXPECT_EQ(damping, 0.0);
    EXPECT_LE(held_all, held_x * (1 + 1e-12));
    EXPECT_LE(held_x, free_dt * (1 + 1e-12));
    EXPECT_NEAR(free_dt, 2.0 / std::sqrt(wcb[nd - 1]), 1e-8 * free_dt);
  }
}

// Boundary free, against the full model (the block eigen solver, root clamped, tip free): the
// lowest 4 frequencies of the massless model equal the mass-carrying CB model's (to 1e-9) and
// converge with the number of fixed-interface modes (6 to 48) like them, by at least 10 times.
TEST(Massless, FreeBoundaryFrequenciesConvergeToTheFullModel) {
  const auto m = beam(10);
  eigen::EigenSettings es;
  es.nev = 4;
  es.what = "full-model modes";
  const auto full = eigen::solve_eigen(m.ops.K.get(), m.ops.M.get(), es, nullptr);
  double first = 0, last = 0, prev = 1e300;
  for (PetscInt nf : {6, 12, 24, 48}) {
    const auto rm = massless_cb(m, nf);
    const auto w = nlrom::free_eigenvalues(rm);
    cb::CBResult c = test::cb_basis(m, "x1", nf);
    const auto wc = eigen::dense_eigenvalues(static_cast<int>(c.n()), c.K, c.M);
    double err = 0, same = 0;
    for (int k = 0; k < 4; ++k) {
      err = std::max(err, std::abs(std::sqrt(w[k] / full.omega2[k]) - 1.0));
      same = std::max(same, std::abs(w[k] / wc[k] - 1.0));
    }
    print0(PETSC_COMM_WORLD,
           "  %2d fixed-interface modes: max relative frequency error of modes 1-4 %.3e (massless = mass-carrying "
           "to %.1e)\n",
           (int)nf, err, same);
    EXPECT_LT(same, 1e-9);
    EXPECT_LT(err, prev) << "the error does not fall with the modes";
    prev = err;
    if (nf == 6) first = err;
    last = err;
  }
  EXPECT_GT(first / last, 10.0);
}

// -nlrom_damping_modes all on a massless model: every dynamic mode of the model with its static
// coordinates condensed gets the ratio xi. With M_dd = I, C_dd = sum 2 xi w_k x_k x_k^T has the
// eigenvalues 2 xi w_k (w_k^2: free_eigenvalues), and C is zero on the static coordinates.
TEST(Massless, ModalDampingOnEveryDynamicMode) {
  const auto m = beam(10);
  auto rm = massless_cb(m, 12);
  const double xi = 5e-4;
  nlrom::make_massless(&rm, rm.n_static, xi, nlrom::kAllModes);
  const std::size_t r = static_cast<std::size_t>(rm.r), ns = static_cast<std::size_t>(rm.n_static), nd = r - ns;
  const auto w2 = nlrom::free_eigenvalues(rm);
  ASSERT_EQ(rm.damping_omega.size(), nd);
  std::vector<double> Cdd(nd * nd), I(nd * nd, 0.0);
  double static_part = 0;
  for (std::size_t i = 0; i < r; ++i)
    for (std::size_t j = 0; j < r; ++j) {
      if (i >= ns && j >= ns)
        Cdd[(i - ns) * nd + j - ns] = rm.C[i * r + j];
      else
        static_part = std::max(static_part, std::abs(rm.C[i * r + j]));
    }
  for (std::size_t i = 0; i < nd; ++i) I[i * nd + i] = 1.0;
  const auto c = eigen::dense_eigenvalues(static_cast<int>(nd), Cdd, I);
  for (std::size_t k = 0; k < nd; ++k) {
    const double w = std::sqrt(w2[k]);
    EXPECT_NEAR(c[k] / (2 * w), xi, 1e-10) << "dynamic mode " << k;
    EXPECT_NEAR(rm.damping_omega[k], w, 1e-10 * w) << "dynamic mode " << k;
  }
  EXPECT_EQ(static_part, 0.0);
}

// A boundary coordinate without stiffness (an isolated node: its static equilibrium is
// singular) is refused by make_massless with that reason.
TEST(Massless, BoundaryWithoutStiffnessIsRefused) {
  nlrom::ReducedModel rm;
  rm.r = 4, rm.n_b = 3;
  rm.K.assign(16, 0.0), rm.M.assign(16, 0.0), rm.C.assign(16, 0.0);
  for (int i = 0; i < 4; ++i) rm.M[i * 4 + i] = 1.0;
  rm.K[0] = 2.0, rm.K[5] = 2.0, rm.K[15] = 5.0;  // coordinate 2 (a boundary DOF) has no stiffness
  test::expect_error_parts([&] { nlrom::make_massless(&rm, 3, 0.0, 0); },
                           {"massless boundary", "not positive definite", "no stiffness of its own"},
                           "a boundary coordinate without stiffness");
}

// A dynamic-mode cut below the lowest mode leaves no dynamic coordinate: refused naming the option
// and the lowest mode's frequency.
TEST(Massless, CutBelowEveryModeIsRefused) {
  const auto m = beam(10);
  auto c = test::cb_basis(m, "x1", 6);
  PetscInt n_static = 0;
  test::expect_error_parts([&] { nlrom::massless_transform(c.M, c.K, c.n(), c.n_b, 1e-3, &n_static); },
                           {"-nlrom_massless_fmax 0.001 Hz is below the lowest mode of the model"},
                           "a cut below every mode");
}

namespace {

// The CB basis of the beam (boundary x1, 12 fixed-interface modes) made massless with the modes
// above fmax_hz residual, projected, with exact tensors if `tensors`; not yet make_massless'd.
// *V receives the basis, *n_static the static count of massless_transform.
nlrom::ReducedModel massless_projected(const test::Model& m, double fmax_hz, bool tensors, PetscInt* n_static) {
  auto c = test::cb_basis(m, "x1", 12);
  auto V = nlrom::transform_basis(c.T.get(), nlrom::massless_transform(c.M, c.K, c.n(), c.n_b, fmax_hz, n_static));
  auto rm = nlrom::project_model(PETSC_COMM_WORLD, V.get(), m.ops.K.get(), m.ops.M.get(), 0.0, 0);
  rm.n_b = c.n_b;
  if (tensors) {
    fe::Svk svk(m.lm, m.dofs, test::steel(), m.ops.K.get());
    rm.g = nlrom::exact_forces(svk, V.get());
  }
  return rm;
}

// The cut between the reduced model's modes 6 and 7 [Hz].
double cut_6_7(const test::Model& m) {
  auto probe = test::cb_basis(m, "x1", 12);
  const auto w = eigen::dense_eigenvalues(static_cast<int>(probe.n()), probe.K, probe.M);
  return 0.5 * (std::sqrt(w[5]) + std::sqrt(w[6])) / (2.0 * M_PI);
}

// The smooth tip load F (1 - cos W t) in y on the nb / 3 boundary nodes of face x1 (coordinates
// 3k + 1 of a CB or massless model): F gives 7 % of the beam's length in linear static deflection
// (Euler-Bernoulli), W = w1 / 5.
std::vector<sim::ReducedLoad> smooth_tip_load(std::size_t r, std::size_t nb, double w1) {
  const double EI = test::steel().E * 0.1 * 0.1 * 0.1 * 0.1 / 12.0, F = 3.0 * EI * 0.07;
  sim::ReducedLoad constant, wave;
  constant.p.assign(r, 0.0);
  for (std::size_t k = 0; k < nb / 3; ++k) constant.p[3 * k + 1] = F / static_cast<double>(nb / 3);
  wave.p = constant.p;
  constant.amplitude = wave.amplitude = 1.0;
  wave.omega = w1 / 5.0, wave.phase = -0.5 * M_PI;  // F (1 - cos W t)
  return {constant, wave};
}

// The first nb coordinates of every step of a run.
std::vector<double> boundary_history(const nlrom::ReducedModel& m, const std::vector<sim::ReducedLoad>& loads,
                                     const sim::Settings& s, std::size_t nb) {
  std::vector<double> u;
  sim::integrate(m, loads, s, [&](const sim::StepState& x) {
    for (std::size_t a = 0; a < nb; ++a) u.push_back(x.q[a]);
  });
  return u;
}

// max |u - ref| / max |ref| over histories of the same length.
double relative_error(const std::vector<double>& u, const std::vector<double>& ref) {
  MORSE_CHECK(u.size() == ref.size(), "relative_error: histories of ", u.size(), " and ", ref.size(), " values");
  double e = 0, peak = 0;
  for (std::size_t i = 0; i < u.size(); ++i)
    e = std::max(e, std::abs(u[i] - ref[i])), peak = std::max(peak, std::abs(ref[i]));
  return e / peak;
}

}  // namespace

// -nlrom_massless_interior scaled (make_massless with a scaling frequency f_c): the z coordinates
// (residual combinations that vanish on the boundary) are K-orthogonal to the boundary and the
// dynamic modes (theory §11.7: Z^T K Psi = 0 since Z vanishes on the boundary), so giving them the
// mass K_zz / w_c^2 puts each at w_c exactly and leaves every other mode of the free model as the
// static interior has it; only the boundary is static, and the free critical step is 2 / w_c.
TEST(Massless, ScaledInteriorIsDecoupledAndCappedAtItsFrequency) {
  const auto m = beam(10);
  const double fcut = cut_6_7(m);
  PetscInt n_static = 0;
  const auto rm0 = massless_projected(m, fcut, false, &n_static);
  const std::size_t r = static_cast<std::size_t>(rm0.r), nb = static_cast<std::size_t>(rm0.n_b),
                    ns = static_cast<std::size_t>(n_static), nz = ns - nb, nd = r - ns;
  ASSERT_EQ(nd, 6u);
  ASSERT_GT(nz, 0u);
  // Coupling of z with everything else, normalized by the diagonal: sqrt(K_ii K_jj).
  double coupling = 0, wz_min = 1e300, wz_max = 0;
  for (std::size_t i = nb; i < ns; ++i) {
    wz_min = std::min(wz_min, std::sqrt(rm0.K[i * r + i])), wz_max = std::max(wz_max, std::sqrt(rm0.K[i * r + i]));
    for (std::size_t j = 0; j < r; ++j)
      if (j != i)
        coupling = std::max(coupling, std::abs(rm0.K[i * r + j]) / std::sqrt(rm0.K[i * r + i] * rm0.K[j * r + j]));
  }
  const double fc = 0.5 * (fcut + wz_min / (2.0 * M_PI));  // above every dynamic mode, below every z
  auto st = rm0, sc = rm0;
  nlrom::make_massless(&st, n_static, 0.0, 0);
  nlrom::make_massless(&sc, n_static, 0.0, 0, fc);
  const auto wst = nlrom::free_eigenvalues(st), wsc = nlrom::free_eigenvalues(sc);
  ASSERT_EQ(wsc.size(), nd + nz);
  const double wc2 = std::pow(2.0 * M_PI * fc, 2);
  double d_low = 0, d_cap = 0, d_mass = 0;
  ASSERT_LT(wst[nd - 1], wc2);
  for (std::size_t k = 0; k < nd; ++k) d_low = std::max(d_low, std::abs(wsc[k] / wst[k] - 1.0));
  for (std::size_t k = nd; k < nd + nz; ++k) d_cap = std::max(d_cap, std::abs(wsc[k] / wc2 - 1.0));
  for (std::size_t i = nb; i < ns; ++i)
    d_mass = std::max(d_mass, std::abs(sc.M[i * r + i] * wc2 / sc.K[i * r + i] - 1.0));
  double free_dt = 0;
  nlrom::massless_critical_step(sc, &free_dt);
  print0(PETSC_COMM_WORLD,
         "  cut %.1f Hz: %zu dynamic, %zu z at %.0f-%.0f Hz, scaled to %.0f Hz; z coupling %.1e; low modes "
         "unchanged to %.1e, z at f_c to %.1e; free step %.4e s = 2 / w_c %.4e s\n",
         fcut, nd, nz, wz_min / (2 * M_PI), wz_max / (2 * M_PI), fc, coupling, d_low, d_cap, free_dt,
         2.0 / std::sqrt(wc2));
  EXPECT_EQ(sc.n_static, rm0.n_b);
  EXPECT_LT(coupling, 1e-8);
  EXPECT_LT(d_low, 1e-8);
  EXPECT_LT(d_cap, 1e-8);
  EXPECT_LT(d_mass, 1e-12);
  EXPECT_NEAR(free_dt, 2.0 / std::sqrt(wc2), 1e-8 * free_dt);
}

// A nonlinear run (exact tensors; a smooth tip load F (1 - cos W t), F of 7 % of the beam's length
// in linear static deflection, W a fifth of the first bending frequency; the CB model without
// modal derivatives stiffens, and the tip reaches about 5 % of the length): the mass-scaled interior responds
// quasi-statically up to O((W / w_c)^2), so its tip history converges to the static interior's at
// second order as the scaling frequency f_c doubles (both run with the same step).
TEST(Massless, ScaledInteriorConvergesToTheStaticOneAtSecondOrder) {
  const auto m = beam(10);
  PetscInt n_static = 0;
  const auto rm0 = massless_projected(m, cut_6_7(m), true, &n_static);
  const std::size_t r = static_cast<std::size_t>(rm0.r), nb = static_cast<std::size_t>(rm0.n_b);
  double wz_min = 1e300;
  for (std::size_t i = nb; i < static_cast<std::size_t>(n_static); ++i)
    wz_min = std::min(wz_min, std::sqrt(rm0.K[i * r + i]));
  auto st = rm0;
  nlrom::make_massless(&st, n_static, 0.0, 0);
  const double w1 = std::sqrt(nlrom::free_eigenvalues(st)[0]);
  const auto loads = smooth_tip_load(r, nb, w1);
  const double fcs[3] = {wz_min / 8.0, wz_min / 4.0, wz_min / 2.0};
  std::vector<nlrom::ReducedModel> models;
  double dt = sim::critical_step(st);
  for (double wc : fcs) {
    models.push_back(rm0);
    nlrom::make_massless(&models.back(), n_static, 0.0, 0, wc / (2.0 * M_PI));
    dt = std::min(dt, sim::critical_step(models.back()));
  }
  sim::Settings s;
  s.dt = 0.25 * dt;
  s.t_final = 2.0 * (2.0 * M_PI / loads[1].omega);
  s.energy_balance = false;
  const auto ref = boundary_history(st, loads, s, nb);
  double peak = 0;
  for (double u : ref) peak = std::max(peak, std::abs(u));
  double err[3];
  for (int k = 0; k < 3; ++k)
    err[k] = relative_error(boundary_history(models[static_cast<std::size_t>(k)], loads, s, nb), ref);
  const double rate1 = std::log2(err[0] / err[1]), rate2 = std::log2(err[1] / err[2]);
  print0(PETSC_COMM_WORLD,
         "  tip peak %.4f m (W / w_1 = 0.2, %ld steps); max tip error against the static interior at f_c = "
         "f_z,min/8, /4, /2: %.2e %.2e %.2e (rates %.2f %.2f)\n",
         peak, static_cast<long>(ref.size() / nb), err[0], err[1], err[2], rate1, rate2);
  EXPECT_GT(peak, 0.04);
  EXPECT_LT(err[2], 1e-3);
  EXPECT_GT(rate1, 1.7);
  EXPECT_GT(rate2, 1.7);
}

// Selective mass scaling of a mass-carrying model (nlrom::scale_modal_mass,
// -nlrom_mass_scaling_fmax; theory §8.7): the modes of (K~, M~) below the cap keep their shapes and
// frequencies, those above sit at the cap with their shapes, and the critical step is 2 / w_c.
TEST(MassScaling, LowModesKeptHighModesAtTheCap) {
  const auto m = beam(10);
  auto c = test::cb_basis(m, "x1", 12);
  auto rm = nlrom::project_model(PETSC_COMM_WORLD, c.T.get(), m.ops.K.get(), m.ops.M.get(), 0.0, 0);
  const std::size_t r = static_cast<std::size_t>(rm.r);
  std::vector<double> X0, X1;
  const auto w0 = eigen::dense_eigenvalues(static_cast<int>(r), rm.K, rm.M, &X0);
  const double fc = 0.5 * (std::sqrt(w0[5]) + std::sqrt(w0[6])) / (2.0 * M_PI), wc2 = std::pow(2.0 * M_PI * fc, 2);
  auto sc = rm;
  const std::size_t n = nlrom::scale_modal_mass(&sc, fc);
  const auto w1 = eigen::dense_eigenvalues(static_cast<int>(r), sc.K, sc.M, &X1);
  double d_low = 0, d_shape = 0, d_cap = 0;
  for (std::size_t k = 0; k < 6; ++k) {
    d_low = std::max(d_low, std::abs(w1[k] / w0[k] - 1.0));
    // The shape: a mode of the unscaled model at the same frequency, ||K x - w M x|| / ||K x|| (the
    // beam's bending pairs are double, so the vectors themselves are not unique).
    double res = 0, kx2 = 0;
    for (std::size_t i = 0; i < r; ++i) {
      double kx = 0, mx = 0;
      for (std::size_t j = 0; j < r; ++j) kx += rm.K[i * r + j] * X1[j * r + k], mx += rm.M[i * r + j] * X1[j * r + k];
      res += (kx - w0[k] * mx) * (kx - w0[k] * mx), kx2 += kx * kx;
    }
    d_shape = std::max(d_shape, std::sqrt(res / kx2));
  }
  for (std::size_t k = 6; k < r; ++k) d_cap = std::max(d_cap, std::abs(w1[k] / wc2 - 1.0));
  const double dt = 2.0 / std::sqrt(nlrom::free_eigenvalues(sc).back());
  print0(PETSC_COMM_WORLD,
         "  %zu of %zu modes scaled to %.1f Hz (highest was %.0f Hz): low modes kept to %.1e (shapes %.1e), the "
         "others at the cap to %.1e; critical step %.4e s (was %.4e s)\n",
         n, r, fc, std::sqrt(w0.back()) / (2 * M_PI), d_low, d_shape, d_cap, dt, 2.0 / std::sqrt(w0.back()));
  EXPECT_EQ(n, r - 6);
  EXPECT_LT(d_low, 1e-9);
  EXPECT_LT(d_shape, 1e-8);
  EXPECT_LT(d_cap, 1e-8);
  EXPECT_NEAR(dt, 2.0 / std::sqrt(wc2), 1e-8 * dt);
  nlrom::ReducedModel ml;
  ml.massless = true;
  test::expect_error_parts([&] { nlrom::scale_modal_mass(&ml, fc); }, {"mass-carrying model"}, "a massless model");
  test::expect_error_parts([&] { nlrom::scale_modal_mass(&sc, -1.0); }, {"must be finite and > 0"}, "a negative cap");
}

// A nonlinear run of the mass-carrying CB model (exact tensors, the smooth tip load of
// ScaledInteriorConvergesToTheStaticOneAtSecondOrder) with its modes above w_c scaled, against the
// unscaled model, all with the unscaled model's step, over one period of the load: the tip history
// converges at least at second order in 1 / w_c (the scaled modes respond to slow forcing
// quasi-statically up to O((W / w_c)^2); measured 3.5-4.3).
TEST(MassScaling, NonlinearRunConvergesAtSecondOrder) {
  const auto m = beam(10);
  auto c = test::cb_basis(m, "x1", 12);
  auto rm = nlrom::project_model(PETSC_COMM_WORLD, c.T.get(), m.ops.K.get(), m.ops.M.get(), 0.0, 0);
  rm.n_b = c.n_b;
  {
    fe::Svk svk(m.lm, m.dofs, test::steel(), m.ops.K.get());
    rm.g = nlrom::exact_forces(svk, c.T.get());
  }
  const std::size_t r = static_cast<std::size_t>(rm.r), nb = static_cast<std::size_t>(rm.n_b);
  const auto w = nlrom::free_eigenvalues(rm);
  const auto loads = smooth_tip_load(r, nb, std::sqrt(w[0]));
  sim::Settings s;
  s.dt = 0.25 * sim::critical_step(rm);
  s.t_final = 2.0 * M_PI / loads[1].omega;
  s.energy_balance = false;
  const auto ref = boundary_history(rm, loads, s, nb);
  double peak = 0;
  for (double u : ref) peak = std::max(peak, std::abs(u));
  const double wtop = std::sqrt(w.back());
  double err[3];
  for (int k = 0; k < 3; ++k) {
    auto sc = rm;
    nlrom::scale_modal_mass(&sc, wtop / (2.0 * M_PI) / std::pow(2.0, 5 - k));  // f_top / 32, / 16, / 8
    err[k] = relative_error(boundary_history(sc, loads, s, nb), ref);
  }
  const double rate1 = std::log2(err[0] / err[1]), rate2 = std::log2(err[1] / err[2]);
  print0(PETSC_COMM_WORLD,
         "  tip peak %.4f m, %ld steps; max tip error against the unscaled model at f_c = f_top/32, /16, /8 "
         "(f_top %.0f Hz, f_1 %.1f Hz): %.2e %.2e %.2e (rates %.2f %.2f)\n",
         peak, static_cast<long>(ref.size() / nb), wtop / (2 * M_PI), std::sqrt(w[0]) / (2 * M_PI), err[0], err[1],
         err[2], rate1, rate2);
  EXPECT_GT(peak, 0.04);
  EXPECT_GT(rate1, 1.7);
  EXPECT_GT(rate2, 1.7);
}
