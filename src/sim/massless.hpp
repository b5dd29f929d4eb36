// Private to src/sim: central differences on a massless-boundary model (nlrom::make_massless).
// Below, "u_b" stands for the n_static static coordinates (the boundary, then the internal modes
// made quasi-static) and "eta" for the dynamic ones.
//
// With q = [u_b; eta] and M = diag(0, M_ii), C = diag(0, C_ii), the internal coordinates follow
// central differences and the boundary is in static equilibrium at every instant:
//
//   eta_{n+1} = (2 M_ii + h C_ii)^-1 { 2h^2 [f_i(t_n) - K_ib u_b,n - K_ii eta_n - g_i(q_n)]
//                                      + 4 M_ii eta_n + (h C_ii - 2 M_ii) eta_{n-1} },
//   K_bb u_b,n+1 + K_bi eta_{n+1} + g_b(u_b,n+1, eta_{n+1}) = f_b(t_{n+1}) + f_c,
//
// f_c the contact forces of the boundary nodes (normal non-penetration, Coulomb friction along the
// sliding direction), found with the boundary. The first line has the form of the mass-carrying
// step, q_{n+1} = P1 q_n + P2 q_{n-1} + P3 (f - g(q_n)), with P3's boundary rows zero and P1, P2's
// extrapolating u_b linearly (the first guess of the equilibrium), so the single and the
// batched integrators share it; MasslessBoundary then solves the second line in place.
#pragma once

#include <memory>
#include <optional>
#include <vector>

#include "morse/sim/sim.hpp"
#include "sim/contact.hpp"

namespace morse::sim::detail {

/// Refuses a contact node whose DOFs are not among the model's n_b boundary coordinates.
void check_contact_on_boundary(const nlrom::ReducedModel& m, const ContactSettings& c);

/// P1, P2, P3 (r x r, row-major) of the internal step above; boundary rows: the linear
/// extrapolation 2 u_b,n - u_b,n-1 (the first guess of the equilibrium), P3 = 0.
void massless_step_operators(const nlrom::ReducedModel& m, double h, std::vector<double>* P1, std::vector<double>* P2,
                             std::vector<double>* P3);

/// The static equilibrium of the boundary, with contact: for fixed internal coordinates, u_b solves
/// R(u_b) = K_bb u_b + K_bi eta + g_b(u_b, eta) - f_b = f_c. Each iteration takes the step
/// u_free = u - D R(u) with a compliance D and then the contact correction u = u_free + D f_c
/// (ContactSolver, exact for the linearized gaps), so a fixed point is the equilibrium with contact.
/// Linear (or g = 0): D = K_bb^-1 and one iteration is exact. Nonlinear: D starts as K_bb^-1 and is
/// replaced by the tangent (K_bb + dg_b/du_b)^-1 at the current iterate whenever an iteration
/// contracts the change by less than 10 (and kept for the next steps: the tangent of a nearby state
/// makes the iteration converge in two or three steps), to 1e-10 relative change or the round-off
/// level of the update (64 eps ||D|| times the largest force term), or where the change stops
/// falling below 1e-6 of the displacement; at most 100 iterations.
class MasslessBoundary {
 public:
  /// contact: null or without nodes for none (kept by reference, as ContactSolver does). g (the
  /// raw force, P3 = I) and tangent: kernels of m.g to share between the lanes of a sweep (built
  /// here if null; they hold only scratch state, so lanes advanced one after the other may share).
  MasslessBoundary(const nlrom::ReducedModel& m, const ContactSettings* contact, double t_final, bool nonlinear,
                   std::shared_ptr<CubicKernel> g = nullptr, std::shared_ptr<TangentKernel> tangent = nullptr);
  /// The raw force kernel of m (P3 = I), for sharing.
  static std::shared_ptr<CubicKernel> raw_kernel(const nlrom::ReducedModel& m);
  /// Sets q[0..n_b) (in: the first guess) to the equilibrium at time t with q[n_b..r). fb: the
  /// external boundary forces at t (n_b values). qm: the state one step earlier (sliding direction
  /// of friction), h the step. Throws naming t if the nonlinear iteration does not converge.
  void solve(double* q, const double* qm, double h, double t, const double* fb);
  bool has_contact() const { return contact_.has_value(); }
  double gap_of(std::size_t k, const double* q, double t) const { return contact_->gap_of(k, q, t); }
  const double* normal() const { return contact_->normal(); }
  const double* friction() const { return contact_->friction(); }
  const double* gap() const { return contact_->gap(); }
  int active() const { return contact_->active(); }
  long iterations() const { return iterations_; }  ///< iterations so far (all solves)
  long tangent_updates() const { return tangent_updates_; }

 private:
  std::size_t r_, nb_;
  bool nonlinear_;
  std::vector<double> Kbb_;         // nb x nb
  std::vector<double> D_;           // nb x nb: the compliance, K_bb^-1 or the tangent's inverse
  double norm_D_ = 0.0;             // its infinity norm (the round-off level of an update)
  std::vector<double> Kbi_;         // nb x (r - nb)
  std::shared_ptr<CubicKernel> g_;  // the raw g~ (P3 = I)
  std::shared_ptr<TangentKernel> tangent_;
  std::vector<double> J_, P_;
  long tangent_updates_ = 0;
  void update_tangent(const double* q);
  std::optional<ContactSolver> contact_;
  std::vector<double> g_val_, rhs_, base_, last_;
  long iterations_ = 0;
};

/// The Central branch of integrate() for a massless model (m.massless), from what integrate()
/// checked and built: the operators of massless_step_operators, the folded loads lp = P3 p_l and
/// the folded cubic kernel (null: linear). Sets st's steps, time and boundary counters.
void integrate_massless(const nlrom::ReducedModel& m, const std::vector<ReducedLoad>& loads, const Settings& s,
                        const std::vector<double>& P1, const std::vector<double>& P2,
                        const std::vector<std::vector<double>>& lp, const CubicKernel* kernel,
                        const std::function<void(const StepState&)>& callback, Stats* st);

}  // namespace morse::sim::detail
