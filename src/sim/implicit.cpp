// Implicit reduced integration (see morse/sim/sim.hpp, Scheme::Trapezoidal).
//
// The scheme of `morse fom` (src/dyn/fom.cpp) on the reduced model, residual scaled by 2, with
// q0, v0 known and v1 = 2 (q1 - q0)/h - v0:
//   R(q1) = (2/h) M (v1 - v0) + C (v0 + v1) + K (q0 + q1) + g(q0) + g(q1) - (f(t0) + f(t1)),
//   J(q1) = (4/h^2) M + (2/h) C + K + dg/dq(q1),
// solved by Newton with a dense LU of J at every iteration (r x r). The same convergence test
// as fom, ||R|| <= rtol max(||inertia||, ||internal||, ||load||), or a correction at round-off
// (max|dq| <= 1e-13 max|q|: stiff constraint modes put the floor of ||R|| above small rtol). With a basis that spans the
// whole space this is the full model's discrete solution.
#include <petscsys.h>
#include <petscblaslapack.h>

#include <algorithm>
#include <chrono>
#include <cmath>

#include "morse/core/error.hpp"
#include "morse/sim/sim.hpp"
#include "sim/contact.hpp"

namespace morse::sim {

namespace {
double norm2(const std::vector<double>& x) {
  double s = 0.0;
  for (double v : x) s += v * v;
  return std::sqrt(s);
}
}  // namespace

Stats integrate_trapezoidal(const nlrom::ReducedModel& m, const std::vector<ReducedLoad>& loads, const Settings& s,
                            const std::function<void(const StepState&)>& callback) {
  const std::size_t r = static_cast<std::size_t>(m.r);
  const double h = s.dt;
  MORSE_CHECK(h > 0 && std::isfinite(h), "simulate: the time step -sim_dt must be positive (got ", h, ")");
  MORSE_CHECK(s.t_final > 0 && std::isfinite(s.t_final), "simulate: -sim_tfinal must be positive (got ", s.t_final, ")");
  for (const auto& l : loads) MORSE_CHECK(l.p.size() == r, "simulate: a reduced load has ", l.p.size(), " entries, not ", r);
  const bool nonlinear = !s.linear;
  MORSE_CHECK(s.contact.nodes.empty(), "simulate: contact needs the explicit scheme (-sim_scheme central)");
  MORSE_CHECK(s.linear || m.g.r == r, "simulate: the reduced model has no nonlinear force of size ", r);
  Stats st;
  st.critical_dt = critical_step(m);
  st.kernel = nonlinear ? "implicit" : "linear";
  std::vector<double> q0, v0, q1(r), v1(r), g0(r, 0.0), g1(r, 0.0), f0(r, 0.0), f1(r, 0.0), R(r), w(r), internal(r),
      J(r * r), G(r * r);
  initial_state(s, r, &q0, &v0);
  auto load = [&](double t, std::vector<double>& f) {
    std::fill(f.begin(), f.end(), 0.0);
    for (const auto& l : loads) {
      const double c = l.factor(t);
      for (std::size_t i = 0; i < r; ++i) f[i] += c * l.p[i];
    }
  };
  auto matvec = [&](const std::vector<double>& A, const std::vector<double>& x, double a, std::vector<double>& y) {
    for (std::size_t i = 0; i < r; ++i) {
      double v = 0.0;
      for (std::size_t j = 0; j < r; ++j) v += A[i * r + j] * x[j];
      y[i] += a * v;
    }
  };
  if (nonlinear) m.g.evaluate(q0.data(), g0.data());
  load(0.0, f0);
  StepState ss;
  ss.model = &m;
  ss.q = q0.data();
  ss.v = v0.data();
  callback(ss);
  const long n_steps = detail::step_count(s.t_final, h);
  std::vector<PetscBLASInt> piv(r);
  const auto t_start = std::chrono::steady_clock::now();
  for (long n = 1; n <= n_steps; ++n) {
    const double t0 = (n - 1) * h, t1 = n * h;
    load(t1, f1);
    q1 = q0;  // predictor u1 = u0, as fom
    for (int it = 0;; ++it) {
      for (std::size_t i = 0; i < r; ++i) v1[i] = 2.0 * (q1[i] - q0[i]) / h - v0[i];
      // R = inertia + damping + internal - load
      std::fill(R.begin(), R.end(), 0.0);
      for (std::size_t i = 0; i < r; ++i) w[i] = v1[i] - v0[i];
      matvec(m.M, w, 2.0 / h, R);
      const double inertia = norm2(R);
      for (std::size_t i = 0; i < r; ++i) w[i] = v0[i] + v1[i];
      matvec(m.C, w, 1.0, R);
      std::fill(internal.begin(), internal.end(), 0.0);
      for (std::size_t i = 0; i < r; ++i) w[i] = q0[i] + q1[i];
      matvec(m.K, w, 1.0, internal);
      if (nonlinear) {
        m.g.evaluate(q1.data(), g1.data());
        for (std::size_t i = 0; i < r; ++i) internal[i] += g0[i] + g1[i];
      }
      double loadn = 0.0;
      for (std::size_t i = 0; i < r; ++i) {
        R[i] += internal[i] - (f0[i] + f1[i]);
        loadn += (f0[i] + f1[i]) * (f0[i] + f1[i]);
      }
      const double rnorm = norm2(R), scale = std::max({inertia, norm2(internal), std::sqrt(loadn)});
      if (!std::isfinite(rnorm))
        throw Error(cat("simulate: NaN or infinite residual at t = ", t1, " (step ", n, "); last converged time ", t0,
                        ". Reduce -sim_dt"));
      if (rnorm <= s.newton_rtol * scale || (scale == 0.0 && rnorm == 0.0)) break;
      if (it >= s.newton_max_it)
        throw Error(cat("simulate: Newton did not converge at t = ", t1, " (step ", n, ") in ", s.newton_max_it,
                        " iterations (||R|| = ", rnorm, ", tolerance ", s.newton_rtol * scale,
                        "); last converged time ", t0, ". Reduce -sim_dt"));
      // J = 4/h^2 M + 2/h C + K + dg/dq(q1), stored column-major for LAPACK; x = J^-1 R.
      if (nonlinear) m.g.jacobian(q1.data(), G.data());
      for (std::size_t i = 0; i < r; ++i)
        for (std::size_t j = 0; j < r; ++j)  // column-major J(i, j) at J[j r + i]
          J[j * r + i] = 4.0 / (h * h) * m.M[i * r + j] + 2.0 / h * m.C[i * r + j] + m.K[i * r + j] +
                         (nonlinear ? G[i * r + j] : 0.0);
      PetscBLASInt nn = static_cast<PetscBLASInt>(r), one = 1, info = 0;
      w = R;
      LAPACKgesv_(&nn, &one, J.data(), &nn, piv.data(), w.data(), &nn, &info);
      MORSE_CHECK(info == 0, "simulate: singular iteration matrix at t = ", t1, " (LAPACK gesv info ", info, ")");
      double dq = 0.0, qn = 0.0;
      for (std::size_t i = 0; i < r; ++i) {
        q1[i] -= w[i];
        dq = std::max(dq, std::abs(w[i]));
        qn = std::max(qn, std::abs(q1[i]));
      }
      ++st.newton_iterations;
      // Round-off floor: a correction at the last bits of q means R cannot fall further.
      if (it > 0 && dq <= 1e-13 * qn) break;
    }
    for (std::size_t i = 0; i < r; ++i) v1[i] = 2.0 * (q1[i] - q0[i]) / h - v0[i];
    std::swap(q0, q1);
    std::swap(v0, v1);
    std::swap(g0, g1);
    std::swap(f0, f1);
    ss.step = n;
    ss.t = t1;
    ss.q = q0.data();
    ss.v = v0.data();
    callback(ss);
    ++st.steps;
  }
  st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return st;
}

}  // namespace morse::sim
