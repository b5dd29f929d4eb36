// morse/sim/sim.hpp: the online stage of seed 003 — explicit central differences on a reduced
// model (eq. 40–41; contact, eq. 42, comes with the contact module):
//
//   q_{n+1} = (2M + hC)^-1 { 2h^2 [f(t_n) - g(q_n)] + (4M - 2h^2 K) q_n + (hC - 2M) q_{n-1} },
//   v_n = (q_{n+1} - q_{n-1}) / 2h,
//
// with the start q_{-1} = q_0 - h v_0 + h^2/2 a_0 (a_0 from the equation of motion at t = 0).
// Every dense operator is folded once into q_{n+1} = P1 q_n + P2 q_{n-1} + P3 f(t_n) - G(q_n),
// where G = P3 g~ is one product of the folded cubic tensor with the monomials of q_n
// (q_i q_j, i <= j, then q_i q_j q_k, i <= j <= k): one contiguous pass, no allocation.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "morse/nlrom/nlrom.hpp"

namespace morse::sim {

/// f~(t) = sum_l factor_l(t) p_l: the projected patterns of dyn::Loads with their time laws.
struct ReducedLoad {
  std::vector<double> p;  ///< r
  double amplitude = 0, omega = 0, phase = 0;
  double factor(double t) const { return omega == 0.0 ? amplitude : amplitude * std::sin(omega * t + phase); }
};

struct Settings {
  double dt = 0.0;
  double t_final = 0.0;
  bool linear = false;          ///< g~ = 0
  std::vector<double> q0, v0;   ///< initial state (empty: zero)
};

struct StepState {
  long step = 0;  ///< 0 = initial state
  double t = 0.0;
  const double* q = nullptr;  ///< r
  const double* v = nullptr;  ///< r (central difference velocity)
  double energy = 0.0;        ///< seed 003 eq. 46: v^T M v / 2 + q^T K q / 2
};

struct Stats {
  long steps = 0;
  double seconds = 0.0;
  double critical_dt = 0.0;
};

/// Critical step of central differences for the linearized reduced model: 2 / omega_max
/// (undamped bound), omega_max^2 the largest eigenvalue of (K~, M~).
double critical_step(const nlrom::ReducedModel& m);

/// Folded cubic kernel: G(q) = P3 g~(q) with P3 = 2h^2 (2M + hC)^-1.
class CubicKernel {
 public:
  CubicKernel(const nlrom::CubicForce& g, const std::vector<double>& P3);
  /// y = G(q) (y has r entries). No allocation.
  void apply(const double* q, double* y) const;
  std::size_t r() const { return r_; }
  /// Floating-point operations of one apply().
  double flops() const;

 private:
  std::size_t r_ = 0, n_ = 0;
  std::vector<double> W_;          // (n2 + n3) x r, row-major
  mutable std::vector<double> z_;  // monomials
};

/// Integrates from the initial state to t_final. Refuses (throws, naming the limit) a dt above
/// critical_step(); stops with an error naming the time reached if the state becomes NaN or
/// infinite. callback(state) runs after the initial state and every step. Serial (one rank).
Stats integrate(const nlrom::ReducedModel& m, const std::vector<ReducedLoad>& loads, const Settings& s,
                const std::function<void(const StepState&)>& callback);

}  // namespace morse::sim
