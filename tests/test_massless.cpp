// Massless-boundary reduced models (issue 27; nlrom::massless_transform, make_massless: MacNeal's
// residual flexibility on the reduced model), against independent references on a hex20
// cantilever:
//  - with its boundary free, the model's modes are exactly the lowest modes of the reduced model
//    it comes from (the CB model's own eigenproblem, solved separately), and its mass is
//    diag(0, I);
//  - their frequencies converge to the full model's (the block eigen solver on K, M) as the number
//    of fixed-interface modes grows, exactly as the mass-carrying model's do;
//  - its critical steps are ordered: every static coordinate held <= the contact normals held <=
//    free, and the free one is 2 / omega of its highest dynamic mode.
#include <petscsys.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "morse/cb/craig_bampton.hpp"
#include "morse/core/log.hpp"
#include "morse/eigen/eigen.hpp"
#include "morse/nlrom/nlrom.hpp"
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
