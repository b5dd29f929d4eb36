// The implicit reduced schemes (sim/implicit.cpp) against closed forms: the exact line search on
// the incremental potential (the first minimum of a quartic), a stiff Duffing step whose root is
// Cardano's (plain Newton needs dozens of iterations, the line search two), the error message of a
// Newton failure, exact energy conservation of the energy scheme at any step (the trapezoidal rule
// does not conserve it), second-order convergence of both schemes to a converged explicit run, and
// the time-discretization error estimate against the exact phase error of an oscillator; the
// tangent critical step of explicit runs against closed forms, and a divergence message naming it.
// Serial integrators: every rank runs the same case (the verdicts agree by construction).
#include <petscsys.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/core/log.hpp"
#include "morse/nlrom/nlrom.hpp"
#include "morse/sim/sim.hpp"

using namespace morse;

namespace {

// The root of k3 x^3 + a x = c (a, k3 > 0: one real root), by Cardano's formula in the form
// without cancellation: x = u - p / (3 u), u = cbrt(c' / 2 + sqrt(c'^2 / 4 + p^3 / 27)).
double cardano(double k3, double a, double c) {
  const double p = a / k3, cc = c / k3;
  const double u = std::cbrt(0.5 * cc + std::sqrt(0.25 * cc * cc + p * p * p / 27.0));
  return u - p / (3.0 * u);
}

// A one-coordinate model m q'' + k q + k3 q^3 = f.
nlrom::ReducedModel duffing(double m, double k, double k3) {
  nlrom::ReducedModel rm;
  rm.r = 1;
  rm.M = {m};
  rm.K = {k};
  rm.C = {0.0};
  rm.g.r = 1;
  rm.g.A = {0.0};
  rm.g.B = {k3};
  return rm;
}

// A three-coordinate model with the potential
//   V(q) = c3 (w.q)^3 / 3 + c4 (u.q)^4 / 4 + d4 (q.q)^2 / 4,
// so g = c3 (w.q)^2 w + c4 (u.q)^3 u + d4 (q.q) q, written into the monomial tables of CubicForce
// (pairs i <= j and triples i <= j <= k, lexicographic).
struct Potential3 {
  double c3 = 2.0e3, c4 = 5.0e5, d4 = 3.0e5;
  std::vector<double> w = {0.6, -0.3, 0.8}, u = {0.2, 0.9, -0.4};
  double value(const double* q) const {
    double wq = 0, uq = 0, qq = 0;
    for (int i = 0; i < 3; ++i) wq += w[i] * q[i], uq += u[i] * q[i], qq += q[i] * q[i];
    return c3 * wq * wq * wq / 3.0 + c4 * uq * uq * uq * uq / 4.0 + d4 * qq * qq / 4.0;
  }
  nlrom::CubicForce force() const {
    const std::size_t r = 3;
    nlrom::CubicForce g;
    g.r = r;
    g.A.assign(nlrom::n_quadratic(r) * r, 0.0);
    g.B.assign(nlrom::n_cubic(r) * r, 0.0);
    std::size_t a = 0, b = 0;
    for (std::size_t i = 0; i < r; ++i)
      for (std::size_t j = i; j < r; ++j, ++a) {
        for (std::size_t p = 0; p < r; ++p) g.A[a * r + p] = c3 * w[p] * w[i] * w[j] * (i == j ? 1.0 : 2.0);
        for (std::size_t k = j; k < r; ++k, ++b) {
          const double perms = (i == j && j == k) ? 1.0 : (i == j || j == k) ? 3.0 : 6.0;
          for (std::size_t p = 0; p < r; ++p) {
            double v = c4 * u[p] * u[i] * u[j] * u[k] * perms;
            // (q.q) q_p: the monomial q_s q_s q_p, sorted, with coefficient 1 (3 when s = p: q_p^3
            // appears once in (q.q) q_p, from s = p).
            const std::size_t sorted[3] = {i, j, k};
            for (std::size_t s = 0; s < r; ++s) {
              std::size_t t[3] = {s, s, p};
              std::sort(t, t + 3);
              if (t[0] == sorted[0] && t[1] == sorted[1] && t[2] == sorted[2]) v += d4;
            }
            g.B[b * r + p] = v;
          }
        }
      }
    return g;
  }
};

nlrom::ReducedModel three_dof() {
  nlrom::ReducedModel rm;
  rm.r = 3;
  rm.M = {2.0, 0.3, 0.0, 0.3, 1.0, 0.1, 0.0, 0.1, 1.5};
  rm.K = {4.0e4, -1.0e4, 0.0, -1.0e4, 3.0e4, -5.0e3, 0.0, -5.0e3, 9.0e4};
  rm.C.assign(9, 0.0);
  rm.g = Potential3{}.force();
  return rm;
}

double quadratic(const std::vector<double>& A, const double* x) {
  double s = 0.0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) s += 0.5 * x[i] * A[i * 3 + j] * x[j];
  return s;
}

}  // namespace

TEST(Implicit, FirstMinimumOfQuartic) {
  // phi' = (a - 0.3)(a - 2)(a - 5): - to + at 0.3 (then + to - at 2, - to + at 5).
  EXPECT_NEAR(sim::first_minimum_of_quartic(-3.0, 12.1, -7.3, 1.0), 0.3, 1e-14);
  // phi' = (a - 1)^2 (a - 3): touches 0 at 1 (an inflection of phi, not a minimum), crosses at 3.
  EXPECT_NEAR(sim::first_minimum_of_quartic(-3.0, 7.0, -5.0, 1.0), 3.0, 1e-13);
  // phi' = (a - 1)^3: a triple root.
  EXPECT_NEAR(sim::first_minimum_of_quartic(-1.0, 3.0, -3.0, 1.0), 1.0, 1e-5);
  // A parabola and a line: phi' = a^2 - 4, phi' = 2 a - 1.
  EXPECT_NEAR(sim::first_minimum_of_quartic(-4.0, 0.0, 1.0, 0.0), 2.0, 1e-14);
  EXPECT_NEAR(sim::first_minimum_of_quartic(-1.0, 2.0, 0.0, 0.0), 0.5, 1e-15);
  // A far root: phi' = a^3 - 1e15.
  EXPECT_NEAR(sim::first_minimum_of_quartic(-1e15, 0.0, 0.0, 1.0), 1e5, 1e-9);
  // No minimum along a > 0: phi' = -1 - a^3; not a descent direction: 0.
  EXPECT_EQ(sim::first_minimum_of_quartic(-1.0, 0.0, 0.0, -1.0), -1.0);
  EXPECT_EQ(sim::first_minimum_of_quartic(1.0, 1.0, 0.0, 1.0), 0.0);
}

// One step of m q'' + k q + k3 q^3 = F from rest with F = 5e11 applied from t = 0: the step
// equation is (4 m / h^2 + k) q1 + k3 q1^3 = 2 F (trapezoidal) or (4 m / h^2 + k) q1 + k3 q1^3 / 2 = 2 F
// (energy: the mean of k3 s^3 q1^3 over s in [0, 1] is k3 q1^3 / 4). Newton from the predictor
// q1 = 0 jumps to 1e12 (the linear iteration matrix is 1) and then shrinks by 2/3 per iteration
// (45 of them); the exact line search lands on the root at once.
TEST(Implicit, LineSearchSolvesAStiffDuffingStep) {
  const double h = 1.0, m = 0.125, k = 0.5, k3 = 1.0, F = 5e11;
  const auto rm = duffing(m, k, k3);
  sim::ReducedLoad load;
  load.p = {F};
  load.amplitude = 1.0;  // omega = 0: constant
  for (auto scheme : {sim::Scheme::Trapezoidal, sim::Scheme::Energy}) {
    const bool energy = scheme == sim::Scheme::Energy;
    const double exact = cardano(energy ? 0.5 * k3 : k3, 4.0 * m / (h * h) + k, 2.0 * F);
    sim::Settings s;
    s.scheme = scheme;
    s.dt = h;
    s.t_final = h;
    s.newton_rtol = 1e-13;
    s.newton_max_it = 30;
    double q1 = 0.0;
    auto st = sim::integrate(rm, {load}, s, [&](const sim::StepState& x) { q1 = x.q[0]; });
    print0(PETSC_COMM_WORLD, "  %s: q1 = %.15e (Cardano %.15e), %ld Newton iterations, %ld line searches\n",
           energy ? "energy" : "trapezoidal", q1, exact, st.newton_iterations, st.line_searches);
    EXPECT_NEAR(q1, exact, 1e-13 * exact) << (energy ? "energy" : "trapezoidal");
    EXPECT_LE(st.newton_iterations, 4) << "the line search should land on the root at once";
    EXPECT_GE(st.line_searches, 1);
    // Without the line search: the same root after 45 iterations, or a failure at 30 that names
    // the time, the residual history and what to try.
    s.newton_line_search = false;
    try {
      sim::integrate(rm, {load}, s, [](const sim::StepState&) {});
      ADD_FAILURE() << "plain Newton converged in 30 iterations: not the test's case";
    } catch (const Error& e) {
      const std::string w = e.what();
      for (const char* part : {"did not converge at t = 1", "||R|| per iteration", "more)", "last converged time 0",
                               "-sim_dt", "-sim_newton_max_it", "line search"})
        EXPECT_NE(w.find(part), std::string::npos) << part << " missing from: " << w;
    }
    s.newton_max_it = 100;
    auto plain = sim::integrate(rm, {load}, s, [&](const sim::StepState& x) { q1 = x.q[0]; });
    EXPECT_NEAR(q1, exact, 1e-12 * exact);
    EXPECT_GT(plain.newton_iterations, 40);
  }
}

// The energy scheme conserves E = v^T M v / 2 + q^T K q / 2 + V(q) exactly (to the Newton
// tolerance) without damping or load, at a step 5 times the shortest linear period and in the
// strongly nonlinear regime; the trapezoidal rule on the same run does not.
TEST(Implicit, EnergySchemeConservesEnergyAtAnyStep) {
  const auto rm = three_dof();
  const Potential3 pot;
  // The tables reproduce the potential's gradient (central differences of V).
  {
    const double q[3] = {0.011, -0.007, 0.004};
    std::vector<double> g(3);
    rm.g.evaluate(q, g.data());
    for (int i = 0; i < 3; ++i) {
      double a[3] = {q[0], q[1], q[2]}, b[3] = {q[0], q[1], q[2]};
      const double d = 1e-6;
      a[i] += d, b[i] -= d;
      EXPECT_NEAR(g[i], (pot.value(a) - pot.value(b)) / (2 * d), 1e-6 * std::abs(g[i]) + 1e-9);
    }
  }
  auto energy = [&](const double* q, const double* v) {
    return quadratic(rm.M, v) + quadratic(rm.K, q) + pot.value(q);
  };
  sim::Settings s;
  s.dt = 5.0 * sim::critical_step(rm) * M_PI;  // critical step 2/omega_max: 5 shortest periods
  s.t_final = 400 * s.dt;
  s.newton_rtol = 1e-13;
  s.q0 = {0.5, -0.3, 0.2};
  s.v0 = {10.0, 20.0, -15.0};
  double e0 = 0.0, worst = 0.0, g_over_k = 0.0;
  {
    std::vector<double> g(3);
    rm.g.evaluate(s.q0.data(), g.data());
    double kq = 0.0, gn = 0.0;
    for (int i = 0; i < 3; ++i) {
      double x = 0.0;
      for (int j = 0; j < 3; ++j) x += rm.K[i * 3 + j] * s.q0[j];
      kq += x * x, gn += g[i] * g[i];
    }
    g_over_k = std::sqrt(gn / kq);
  }
  EXPECT_GT(g_over_k, 0.5) << "not a nonlinear test";
  for (auto scheme : {sim::Scheme::Energy, sim::Scheme::Trapezoidal}) {
    s.scheme = scheme;
    worst = 0.0;
    auto st = sim::integrate(rm, {}, s, [&](const sim::StepState& x) {
      const double e = energy(x.q, x.v);
      if (x.step == 0) e0 = e;
      worst = std::max(worst, std::abs(e - e0) / e0);
    });
    EXPECT_EQ(st.steps, 400);
    print0(PETSC_COMM_WORLD,
           "  %s: largest relative energy change %.3e over 400 steps of 5 shortest periods (|g|/|Kq| = %.2f)\n",
           scheme == sim::Scheme::Energy ? "energy" : "trapezoidal", worst, g_over_k);
    if (scheme == sim::Scheme::Energy)
      EXPECT_LT(worst, 1e-10) << "the energy scheme changed the energy";
    else
      EXPECT_GT(worst, 1e-4) << "the trapezoidal rule conserved the energy: the test cannot tell the schemes apart";
  }
}

// Both implicit schemes converge at second order to a converged explicit run (central differences
// at 1/400 of the implicit steps) of the forced, damped, nonlinear three-coordinate model.
TEST(Implicit, SchemesConvergeAtSecondOrder) {
  auto rm = three_dof();
  for (int i = 0; i < 3; ++i) rm.C[i * 3 + i] = 2.0;
  sim::ReducedLoad load;
  load.p = {2.0e4, -1.0e4, 1.5e4};
  load.amplitude = 1.0;
  load.omega = 150.0;
  const double T = 0.2;
  auto final_q = [&](sim::Scheme scheme, double h) {
    sim::Settings s;
    s.scheme = scheme;
    s.dt = h;
    s.t_final = T;
    s.newton_rtol = 1e-13;
    std::vector<double> q(3);
    sim::integrate(rm, {load}, s, [&](const sim::StepState& x) { q.assign(x.q, x.q + 3); });
    return q;
  };
  const double h = 5e-4;
  const auto ref = final_q(sim::Scheme::Central, h / 400);
  auto err = [&](const std::vector<double>& q) {
    double d = 0, n = 0;
    for (int i = 0; i < 3; ++i) d += (q[i] - ref[i]) * (q[i] - ref[i]), n += ref[i] * ref[i];
    return std::sqrt(d / n);
  };
  for (auto scheme : {sim::Scheme::Trapezoidal, sim::Scheme::Energy}) {
    const double e1 = err(final_q(scheme, h)), e2 = err(final_q(scheme, h / 2)), e3 = err(final_q(scheme, h / 4));
    print0(PETSC_COMM_WORLD, "  %s: error %.3e, %.3e, %.3e at h, h/2, h/4 (ratios %.2f, %.2f)\n",
           scheme == sim::Scheme::Energy ? "energy" : "trapezoidal", e1, e2, e3, e1 / e2, e2 / e3);
    EXPECT_LT(e1, 0.2);
    EXPECT_NEAR(e1 / e2, 4.0, 0.6) << e1 << " " << e2;
    EXPECT_NEAR(e2 / e3, 4.0, 0.4) << e2 << " " << e3;
  }
}

// The local error estimate against the exact local error of the trapezoidal rule on
// q'' + w^2 q = 0, q = sin(w t): the rule's phase advances by 2 atan(w h / 2) per step instead of
// w h, a local error (w h)^3 / 12 + O((w h)^5) of the unit amplitude where q''' is largest. The
// estimate's largest value matches it, falls by 8 when h halves, and its sum over one period is
// 2 / pi of the error the phase drift leaves at the end.
TEST(Implicit, ErrorEstimateMatchesThePhaseErrorOfAnOscillator) {
  const double w = 100.0;
  nlrom::ReducedModel rm;
  rm.r = 1;
  rm.M = {1.0};
  rm.K = {w * w};
  rm.C = {0.0};
  double last_max = 0.0;
  for (double wh : {0.04, 0.02}) {
    sim::Settings s;
    s.scheme = sim::Scheme::Trapezoidal;
    s.linear = true;
    s.dt = wh / w;
    s.t_final = 2 * M_PI / w;
    s.v0 = {w};
    s.q0 = {0.0};
    double qT = 0.0, tT = 0.0;
    auto st = sim::integrate(rm, {}, s, [&](const sim::StepState& x) { qT = x.q[0], tT = x.t; });
    ASSERT_TRUE(st.error_estimated);
    const double local = wh * wh * wh / 12.0;
    EXPECT_NEAR(st.error_q_max, 1.0, 1e-3);
    EXPECT_NEAR(st.error_local_max / local, 1.0, 0.02) << "w h = " << wh;
    print0(PETSC_COMM_WORLD,
           "  w h = %.2f: largest local estimate / (w h)^3/12 = %.4f, sum / final error = %.4f (2/pi = %.4f)\n", wh,
           st.error_local_max / local, st.error_sum / std::abs(qT - std::sin(w * tT)), 2.0 / M_PI);
    // The error at the end of the period, against sin(w t): the phase drift N (w h)^3 / 12 times
    // |cos| = 1 there, while the local errors are (w h)^3 |cos(w t)| / 12 (none where the
    // velocity vanishes), whose sum over a period is 2 / pi of it.
    const double actual = std::abs(qT - std::sin(w * tT));
    EXPECT_NEAR(st.error_sum / actual, 2.0 / M_PI, 0.03) << "w h = " << wh;
    if (last_max > 0) {
      EXPECT_NEAR(last_max / st.error_local_max, 8.0, 0.2);
    }
    last_max = st.error_local_max;
  }
}

// The round-off floor stop: with a tolerance no residual can meet (rtol = 0), most steps end on
// the floor rule (a full step below 1e-8 |q| right after one below 1e-4 |q|) and are counted, and
// the states agree with a run that converges normally (rtol 1e-10, no step on the floor) to that
// run's own accuracy: the stop comes only once the quadratic phase has left nothing to correct.
TEST(Implicit, RoundOffFloorStopsOnlyInTheQuadraticPhase) {
  auto rm = three_dof();
  sim::ReducedLoad load;
  load.p = {2.0e4, -1.0e4, 1.5e4};
  load.amplitude = 1.0;
  load.omega = 150.0;
  for (auto scheme : {sim::Scheme::Trapezoidal, sim::Scheme::Energy}) {
    auto run = [&](double rtol, sim::Stats* st) {
      sim::Settings s;
      s.scheme = scheme;
      s.dt = 5e-4;
      s.t_final = 0.1;
      s.newton_rtol = rtol;
      std::vector<double> out;
      *st = sim::integrate(rm, {load}, s, [&](const sim::StepState& x) { out.insert(out.end(), x.q, x.q + 3); });
      return out;
    };
    sim::Stats tight, floor;
    const auto a = run(1e-10, &tight), b = run(0.0, &floor);
    ASSERT_EQ(a.size(), b.size());
    double d = 0, n = 0;
    for (std::size_t i = 0; i < a.size(); ++i) d = std::max(d, std::abs(a[i] - b[i])), n = std::max(n, std::abs(a[i]));
    print0(PETSC_COMM_WORLD,
           "  %s: rtol 0: %ld of %ld steps on the floor, %.2f iterations per step (rtol 1e-10: %.2f); "
           "largest difference %.2e of max |q|\n",
           scheme == sim::Scheme::Energy ? "energy" : "trapezoidal", floor.newton_floor_steps, floor.steps,
           double(floor.newton_iterations) / floor.steps, double(tight.newton_iterations) / tight.steps, d / n);
    // The others end on a correction at the last bits (1e-13 |q|) or an exact zero.
    EXPECT_GT(floor.newton_floor_steps, floor.steps / 2) << "the floor rule did not stop most steps";
    EXPECT_EQ(tight.newton_floor_steps, 0);
    EXPECT_LT(d, 1e-9 * n);  // the rtol 1e-10 run's own error
  }
}

// The tangent critical step (sim::tangent_step) against closed forms: a Duffing oscillator with a
// quadratic term, J = k + 2 a q + 3 k3 q^2, so dt = 2 sqrt(m / J) while J > 0 and no stable step
// (one negative eigenvalue) past it; the three-coordinate potential model against the eigenvalues
// of its analytic Hessian K + 2 c3 (w.q) w w^T + 3 c4 (u.q)^2 u u^T + d4 ((q.q) I + 2 q q^T).
TEST(Tangent, CriticalStepOfTheLinearizedModel) {
  const double m = 2.0, k = 50.0, k3 = 1.0e4, a = -300.0;
  auto rm = duffing(m, k, k3);
  rm.g.A = {a};
  for (double q : {0.0, 0.03, 0.3, -0.2}) {
    const double J = k + 2.0 * a * q + 3.0 * k3 * q * q;
    const auto ts = sim::tangent_step(rm, &q);
    EXPECT_NEAR(ts.omega2_max, J / m, 1e-14 * (k + 3.0 * k3 * q * q) / m) << "q = " << q;
    if (J > 0) {
      EXPECT_NEAR(ts.dt, 2.0 * std::sqrt(m / J), 1e-13 * 2.0 * std::sqrt(m / J)) << "q = " << q;
      EXPECT_EQ(ts.negative, 0);
    } else {
      EXPECT_TRUE(std::isinf(ts.dt)) << "q = " << q << ": J = " << J << " < 0 has no stable step";
      EXPECT_EQ(ts.negative, 1);
    }
  }
  auto soft = duffing(1.0, 1.0, 1.0);
  soft.g.A = {-10.0};
  const double q1 = 1.0;  // J = 1 - 20 + 3 = -16
  const auto neg = sim::tangent_step(soft, &q1);
  EXPECT_EQ(neg.negative, 1);
  EXPECT_TRUE(std::isinf(neg.dt));
  EXPECT_NEAR(neg.omega2_min, -16.0, 1e-13);
  // Null state: the linear model's critical step.
  EXPECT_NEAR(sim::tangent_step(rm, nullptr).dt, sim::critical_step(rm), 1e-15);

  const auto r3 = three_dof();
  const Potential3 pot;
  for (const std::vector<double>& q : std::vector<std::vector<double>>{{0.1, -0.2, 0.3}, {-0.5, 0.2, -0.4}}) {
    double wq = 0, uq = 0, qq = 0;
    for (int i = 0; i < 3; ++i) wq += pot.w[i] * q[i], uq += pot.u[i] * q[i], qq += q[i] * q[i];
    std::vector<double> H(r3.K);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        H[i * 3 + j] += 2.0 * pot.c3 * wq * pot.w[i] * pot.w[j] + 3.0 * pot.c4 * uq * uq * pot.u[i] * pot.u[j] +
                        pot.d4 * ((i == j ? qq : 0.0) + 2.0 * q[i] * q[j]);
    // The largest and smallest eigenvalues of (H, M) by the Rayleigh quotient's extremes: the roots of
    // det(H - w M) = 0, found by bisection on the cubic (independent of LAPACK).
    auto det = [&](double w) {
      double A[9];
      for (int i = 0; i < 9; ++i) A[i] = H[i] - w * r3.M[i];
      return A[0] * (A[4] * A[8] - A[5] * A[7]) - A[1] * (A[3] * A[8] - A[5] * A[6]) +
             A[2] * (A[3] * A[7] - A[4] * A[6]);
    };
    // det(H - w M) = -det(M) w^3 + ...: positive for w -> -inf, negative for w -> +inf. The largest
    // root: the last sign change scanning down from a bound above every eigenvalue.
    double hi = 0.0;
    for (double x : H) hi += std::abs(x);
    hi /= 0.5;  // M's smallest eigenvalue exceeds 0.5
    double lo = hi;
    while (det(lo) < 0.0) lo -= 1e-3 * hi;
    for (int it = 0; it < 200; ++it) {
      const double mid = 0.5 * (lo + hi);
      (det(mid) < 0.0 ? hi : lo) = mid;
    }
    const auto ts = sim::tangent_step(r3, q.data());
    EXPECT_NEAR(ts.omega2_max, 0.5 * (lo + hi), 1e-10 * ts.omega2_max);
    EXPECT_NEAR(ts.dt, 2.0 / std::sqrt(0.5 * (lo + hi)), 1e-10 * ts.dt);
  }
}

// In a run (central differences, Settings::tangent_checks): the checks fall at steps 0, every, ...,
// the first is the closed form at q0; a step above the tangent critical step but below the linear
// one diverges, and the message names the tangent step and the time of the last check.
TEST(Tangent, RunsCheckTheStepAndDivergenceNamesIt) {
  const double m = 1.0, k = 1.0, k3 = 1.0e4, q0 = 0.2;
  const auto rm = duffing(m, k, k3);
  const double dt0 = 2.0 / std::sqrt((k + 3.0 * k3 * q0 * q0) / m);  // 0.05764
  sim::Settings s;
  s.q0 = {q0};
  s.dt = 0.02;  // below dt0, far below the linear 2 s
  s.t_final = 20.0;
  s.tangent_checks = 200;
  auto st = sim::integrate(rm, {}, s, [](const sim::StepState&) {});
  ASSERT_EQ(st.steps, 1000);
  ASSERT_EQ(st.tangent.size(), 201u);
  EXPECT_EQ(st.tangent[1].t, 5 * s.dt);
  EXPECT_NEAR(st.tangent[0].dt, dt0, 1e-14 * dt0);
  // The amplitude stays q0 to O(h^2) (undamped, conservative): the smallest step is that at q0.
  EXPECT_NEAR(st.tangent_dt_min, dt0, 0.02 * dt0);
  EXPECT_EQ(st.tangent_negative_checks, 0);
  s.tangent_checks = 0;
  EXPECT_TRUE(sim::integrate(rm, {}, s, [](const sim::StepState&) {}).tangent.empty());
  // h = 0.1 > dt0 (but < 2 s, the linear critical step): the run diverges.
  s.tangent_checks = 200;
  s.dt = 0.1;
  s.t_final = 1000.0;
  try {
    sim::integrate(rm, {}, s, [](const sim::StepState&) {});
    ADD_FAILURE() << "a step 1.7 times the tangent critical step did not diverge";
  } catch (const Error& e) {
    const std::string w = e.what();
    print0(PETSC_COMM_WORLD, "  divergence: %s\n", w.c_str());
    for (const char* part : {"NaN or infinite state", "tangent critical step 2/omega_max", "at the last check (t = ",
                             "-sim_dt is 0.1 s", "reduce it below the tangent critical step"})
      EXPECT_NE(w.find(part), std::string::npos) << part << " missing from: " << w;
  }
}
