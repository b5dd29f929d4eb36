// Private to src/sim: the panel kernels of the implicit tangent (TangentKernel), the folded step
// operators shared by the single and the batched integrators, and the Lagrange-multiplier contact correction of
// central differences (see morse/sim/sim.hpp, ContactSettings).
#pragma once

#include <petscsys.h>
#include <petscblaslapack.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <vector>

#include "morse/sim/sim.hpp"

// The hot loops of the online stage: built for AVX2 + FMA as well as for the baseline, the
// processor picks at run time (GCC function multiversioning). The clone is named by ISA level
// (x86-64-v3: AVX2, FMA, BMI2), which GCC dispatches on the CPU's features: "arch=haswell" is
// dispatched on the CPU model and never chosen on AMD processors. In the x86-64-v3 clone GCC fuses
// a * b + c into one FMA (C++ contracts by default).
#if defined(__GNUC__) && defined(__x86_64__) && !defined(__clang__)
#define MORSE_GCC_X86 1  // GCC on x86-64: multiversioned and per-ISA builds of the kernels
#else
#define MORSE_GCC_X86 0
#endif
#if MORSE_GCC_X86
#define MORSE_KERNEL_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define MORSE_KERNEL_CLONES
#endif

namespace morse::sim::detail {

/// The steps between tangent checks (Settings::tangent_checks = checks > 0) of a run of n_steps:
/// the checks are at steps 0, every, 2 every, ... (simulate and sweep alike).
inline long tangent_check_every(long n_steps, long checks) { return std::max(1L, n_steps / checks); }

/// Rows per panel of panel_product.
constexpr std::size_t kPanel = 16;
/// Panel-major product: rows come in panels of kPanel (row b kPanel + k of column c at
/// H[(b n_cols + c) kPanel + k]); y1 = the product over columns [0, split), y2 over [split, n_cols),
/// n_panels kPanel entries each. Built for AVX2 + FMA and the baseline.
void panel_product(std::size_t n_panels, std::size_t n_cols, std::size_t split, const double* x, const double* H,
                   double* y1, double* y2);
/// y = S x for a symmetric S of n_panels kPanel rows stored as its upper block triangle: for each
/// panel b, the blocks (b, b'), b' = b .. n_panels - 1, each kPanel columns of kPanel contiguous
/// rows (diagonal blocks whole). x and y have n_panels kPanel entries. Built for AVX2 + FMA and the
/// baseline.
void sym_panel_product(std::size_t n_panels, const double* S, const double* x, double* y);
/// y = P3 g~(q), g~ = the gradient of the potential with the coefficients c3, c4 of CubicKernel
/// (g: r entries of scratch, then g~): CubicKernelBatch's arithmetic for one lane, so that a speed
/// of a sweep and `morse simulate` apply the same bits. Built for AVX2 + FMA and the baseline.
void potential_force_lane(std::size_t r, const double* q, const double* c3, const double* c4, const double* P3,
                          double* g, double* y);
/// z = the r (r + 1) / 2 monomials q_i q_j, i <= j, lexicographic.
void quadratic_monomials(std::size_t r, const double* q, double* z);

/// The works of EnergyWork, step by step: add(q_{n-1}, q_{n+1}, ...) adds step n's. The damping
/// term uses C = W diag(c) W^T (its nonzero eigenpairs: modal damping on k modes costs k r per
/// step, not r^2).
class EnergyLedger {
 public:
  /// contact: null or without nodes for none (its node DOFs and normals are copied).
  EnergyLedger(const nlrom::ReducedModel& m, const ContactSettings* contact, double h);
  /// Step n: the loads at t_n (factor(t) p_l), the contact forces acting in it (lam: normal
  /// multipliers, fric: 3 per node; null: none).
  void add(const double* q_prev, const double* q_next, const std::vector<ReducedLoad>& loads, double t,
           const double* lam, const double* fric);
  const EnergyWork& work() const { return w_; }

 private:
  std::size_t r_;
  double h_;
  std::vector<double> cw_, cv_, y_;  // damping: eigenvalues cv_ (nonzero), vectors cw_ [r][k], y_ = W^T d
  std::vector<std::size_t> dofs_;
  std::vector<double> normals_, d_;
  EnergyWork w_;
};

/// What follows the explicit update of each step of central_loop: the contact correction of a
/// mass-carrying model, or the static equilibrium of a massless boundary (with its contact).
struct Corrector {
  std::size_t nodes = 0;                                                // contact nodes (0: none)
  std::function<void(double* qp, const double* qm, double t)> correct;  // of the state at t; null: none
  std::function<const double*()> normal, friction, gap;                 // what the last correction left
  std::function<int()> active;
  std::vector<double> gap0;     // the initial state's gaps (if not initial_forces)
  bool initial_forces = false;  // the initial state's forces and gaps are the corrector's current ones
  // The forces the corrector leaves act in the step that follows (massless: the equilibrium of
  // state n + 1 belongs to step n + 1), not in the step that made them (mass-carrying).
  bool forces_of_state = false;
  const ContactSettings* contact = nullptr;  // for the energy balance (nodes and normals)
};

/// The time loop of central differences, shared by the mass-carrying and the massless models: from
/// the state q_0 (velocity v, q_{-1} = qm), q_{n+1} = P1 q_n + P2 q_{n-1} + sum_l c_l(t_n) lp_l -
/// kernel(q_n), then corr.correct(q_{n+1}, q_{n-1}, t_{n+1}); NaN stops the run naming the time.
/// callback(state n) runs once v_n is known. Sets st->steps and st->seconds.
void central_loop(const nlrom::ReducedModel& m, const std::vector<ReducedLoad>& loads, const Settings& s,
                  const std::vector<double>& P1, const std::vector<double>& P2,
                  const std::vector<std::vector<double>>& lp, const CubicKernel* kernel, const Corrector& corr,
                  std::vector<double> q, std::vector<double> qm, std::vector<double> v,
                  const std::function<void(const StepState&)>& callback, Stats* st);

/// The inverse of a dense n x n matrix (row-major) by LU; throws `what` with LAPACK's info if it is
/// singular.
std::vector<double> inverse(std::vector<double> A, std::size_t n, const char* what);

/// Steps of length h that reach t_final (the last one may end just past it), as every integrator
/// of src/sim counts them.
inline long step_count(double t_final, double h) { return static_cast<long>(std::ceil(t_final / h - 1e-9)); }

/// The folded central-difference operators of step h: q_{n+1} = P1 q_n + P2 q_{n-1} + P3 (f - g)
/// with P3 = 2 h^2 (2M + hC)^-1 (r x r, row-major).
void step_operators(const nlrom::ReducedModel& m, double h, std::vector<double>* P1, std::vector<double>* P2,
                    std::vector<double>* P3);
/// q_{-1} = q0 - h v0 + h^2/2 a0, a0 = M^-1 (f0 - K q0 - C v0 - g(q0)) (g = 0 if !nonlinear).
void previous_state(const nlrom::ReducedModel& m, double h, bool nonlinear, const std::vector<double>& f0,
                    const std::vector<double>& q, const std::vector<double>& v, std::vector<double>* qm);

class ContactSolver {
 public:
  /// P = (M~/h^2 + C~/2h)^-1 (r x r, row-major), the operator of eq. 42.
  ContactSolver(const ContactSettings& c, const std::vector<double>& P, std::size_t r, double t_final);
  /// Replaces P (the same r x r layout), e.g. an updated tangent compliance.
  void set_compliance(const std::vector<double>& P);
  /// Corrects the predictor qp of time t in place (qm = q_{n-1}, for the sliding velocity, h the
  /// step) and records the forces and gaps of the new state.
  void correct(double* qp, const double* qm, double h, double t);
  /// Gap of node k at time t for the state q.
  double gap_of(std::size_t k, const double* q, double t) const;
  const double* normal() const { return lam_.data(); }
  const double* friction() const { return fric_.data(); }
  const double* gap() const { return gap_.data(); }
  int active() const { return active_; }

 private:
  const ContactSettings& c_;
  std::size_t r_, n_;
  std::vector<double> Pc_;              // r x 3n: the columns of P at the contact DOFs
  std::vector<double> normal_, slide_;  // per node: unit normal (free side), casing: fixed sliding direction
  std::vector<double> omega_rho_;       // casing: the node's rigid velocity omega e_z x x_k (Sliding::Relative)
  std::vector<double> theta0_;          // casing: reference angle of each node plus Casing::phase
  double alpha_ = 0.0;
  std::vector<double> lam_, fric_, gap_, dir_, W_, rhs_;
  std::vector<std::size_t> set_;  // the active set of the current correction
  std::vector<int> in_set_;       // membership flags of set_
  std::vector<PetscBLASInt> piv_;
  int active_ = 0;
};

}  // namespace morse::sim::detail
