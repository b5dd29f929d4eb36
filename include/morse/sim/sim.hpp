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

#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "morse/dyn/dyn.hpp"
#include "morse/mesh/partition.hpp"
#include "morse/nlrom/nlrom.hpp"

namespace morse::sim {

/// f~(t) = sum_l factor_l(t) p_l: the projected patterns of dyn::Loads with their time laws.
struct ReducedLoad {
  std::vector<double> p;  ///< r
  double amplitude = 0, omega = 0, phase = 0;
  double factor(double t) const { return dyn::harmonic_factor(amplitude, omega, phase, t); }
};

/// Storage of the reduced nonlinear force in the time loop.
///  - Folded: P3 [A; B] as one (n2 + n3) x r matrix times the monomials of q (any A, B).
///  - Potential: when g~ is the gradient of a quartic potential (exact tensors, and STEP to its
///    identification error), the fully symmetric coefficients of the cubic and quartic energy:
///    r(r+1)(r+2)/6 + r(r+1)(r+2)(r+3)/24 numbers instead of (n2 + n3) r, about 4r/(r+3) times fewer
///    bytes streamed per step, then y = P3 g.
///  - Auto: Potential if A and B are consistent with a potential to 1e-6 relative and the folded
///    matrix would exceed 12 MB (r >= 56: it no longer stays in cache and the time loop becomes
///    bandwidth bound; measured on the 2-core EPYC: r = 50 folded 5.8k steps/s vs potential 5.1k,
///    r = 60 1.7k vs 3.0k, r = 79 241 vs 1,190), else Folded.
enum class KernelLayout { Auto, Folded, Potential };

/// Contact of physical nodes of the basis with a rigid obstacle (seed 003 §3.4; Carpenter,
/// Taylor & Katona 1991): after the predictor q* of eq. 41, the gaps of the contact nodes are
/// computed, and forward-increment Lagrange multipliers cancel every penetration exactly
/// (eq. 42: q = q* + P f_c, P = (M~/h^2 + C~/2h)^-1), with Coulomb friction mu lambda opposing the
/// predicted sliding velocity. The active set is iterated until every normal multiplier is
/// compressive. Central differences only.
struct ContactNode {
  std::size_t dof = 0;            ///< index of u_x of the node in q (u_y, u_z follow)
  double x[3] = {0.0, 0.0, 0.0};  ///< reference position
};
/// A rigid plane: gap = (x + u - point) . normal, normal pointing into the free side.
struct Plane {
  double point[3] = {0.0, 0.0, 0.0};
  double normal[3] = {0.0, 0.0, 1.0};
};
/// The seed's rigid casing of revolution about z around a blade rotating at omega (eq. 52–53), in
/// the blade's frame: gap = c0 - (1 - exp(-alpha t)) f(theta_b(t)) - u_r with theta_b = theta_b0 +
/// omega t, u_r the displacement along the node's radial direction e_r = (x, y, 0)/|(x, y)|, and
/// f(theta) = h_b exp(-((theta mod (2 pi / lobes) - pi / lobes) / width)^2) (eq. 52 for 2 lobes).
/// Friction opposes the sliding of the tip along the casing (Sliding: along -sign(omega) e_theta,
/// the seed's assumption, or against the tip's velocity relative to the casing).
struct Casing {
  double clearance = 0.356e-3;    ///< c0 [m]
  double bump_height = 0.712e-3;  ///< h_b [m]
  int lobes = 2;
  double width = 0.15;  ///< of each bump [rad]
  double alpha = 0.0;   ///< growth rate [1/s]; 0: 99 % of h_b at 20 % of t_final
  double omega = 0.0;   ///< rotation speed [rad/s]
  /// The lobes' angle at t = 0 [rad]: a node at reference angle theta_0 sees the casing at
  /// theta_0 + phase + omega t (a run continued from another's final state keeps the lobes where
  /// that run left them; SpeedTask::phase).
  double phase = 0.0;
  /// The lobes at their full height h_b from t = 0 (no growth): a run continued from a state in
  /// contact with the grown casing.
  bool grown = false;
};
enum class Obstacle { Plane, Casing };
/// The sliding direction t_k of Coulomb friction on the casing (the force on node k is
/// lambda_k (n_k - mu t_k); theory §10.1):
///  - Rotation: t_k = sign(omega) e_theta, the tip's rigid sliding alone (seed 003 §3.4: "the
///    tangential speed to rotation is significantly larger than the vibration speed").
///  - Relative: t_k = v_t / |v_t| of the tip's velocity relative to the casing, v = omega e_z x
///    x_k + u'_k (u' the central-difference velocity of the predictor, as for the plane), v_t its
///    part in the casing's tangent plane. Exact Coulomb sliding for any vibration speed; friction
///    then also damps the tip's axial and circumferential vibration by about mu lambda / (omega rho).
/// The plane always uses the tangential predicted velocity. Relative is the default: the linear
/// maps of docs/contact.md turned the seed's law into tip speeds up to 9 Omega rho, far outside its
/// premise, and friction-fed responses of kJ; the exact law keeps them at the millimetre.
enum class Sliding { Rotation, Relative };
struct ContactSettings {
  std::vector<ContactNode> nodes;  ///< empty: no contact
  Obstacle obstacle = Obstacle::Plane;
  Plane plane;
  Casing casing;
  double mu = 0.15;  ///< Coulomb friction coefficient
  Sliding sliding = Sliding::Relative;
};

/// The unit normal n_k of each contact node, pointing to the free side (3 values per node, global
/// axes; constant in time): the plane's normal, or -e_r = -(x, y, 0)/|(x, y)| of the node's
/// reference position for the casing. The force of contact node k on the structure is
/// lambda_k n_k + its friction force (StepState::contact_friction). Throws on a plane normal that
/// is not a unit vector or a casing node on the axis.
std::vector<double> contact_normals(const ContactSettings& c);

/// The contact nodes of node set `set` of a stored model: each node's u_x index in q (it must be
/// a physical boundary node of the basis; throws naming the first that is not) and its reference
/// position from /mesh/coordinates.
std::vector<ContactNode> contact_nodes(const nlrom::StoredModel& sm, const std::string& set);

/// Time scheme of the reduced model.
///  - Central: explicit central differences (eq. 40–41), conditionally stable (critical_step()).
///  - Trapezoidal: the implicit scheme of `morse fom` (trapezoidal rule, Newton with the exact
///    reduced tangent K~ + dg~/dq): no stability limit, the same step as the full model, and with a
///    basis spanning the whole space the same discrete solution as `morse fom`.
///  - Energy: the same, with the nonlinear force averaged over the step exactly (the average
///    vector field, theory §9.3): the discrete energy is conserved exactly without damping and
///    load, at any step (the trapezoidal rule can gain energy from a stiff nonlinear force).
enum class Scheme { Central, Trapezoidal, Energy };

struct Settings {
  Scheme scheme = Scheme::Central;
  ContactSettings contact;
  double newton_rtol = 1e-8;  ///< Trapezoidal: ||R|| <= rtol * max(inertia, internal, load norms)
  int newton_max_it = 100;    ///< reduced Newton is cheap; stiff constraint modes need many at large dt
  /// Implicit schemes, nonlinear with a potential: when the full Newton step does not lower the
  /// incremental potential enough (Armijo), step to the first minimum of the potential along the
  /// Newton direction, exactly (it is a quartic; theory §9.1). -sim_newton_line_search.
  bool newton_line_search = true;
  /// Implicit schemes: estimate the local time-discretization error of every step from the last
  /// four states (theory §9.2; about 2 r^2 flops per step). -sim_error_estimate.
  bool error_estimate = true;
  double dt = 0.0;
  KernelLayout kernel = KernelLayout::Auto;
  double t_final = 0.0;
  bool linear = false;  ///< g~ = 0
  /// The energy balance (EnergyWork, central differences): about k r multiply-adds per step for C~
  /// of rank k, up to 2 times the time of a linear step at r = 54 with every mode damped.
  bool energy_balance = true;
  /// Nonlinear central runs of mass-carrying models: tangent_step() at the initial state and at
  /// this many evenly spaced states more (0: none), so that a run reports how close its step came to
  /// the critical step of the stiffened model, and a divergence names it. One check costs about
  /// 3 n_cubic(r) r multiply-adds and an r x r eigen solve (~5 ms at r = 79). -sim_tangent_checks.
  long tangent_checks = 200;
  /// Central differences: a contact node displaced by more than this (model units) stops the run
  /// with the time reached, as a NaN does (0: no limit). -sim_divergence_limit; its default is
  /// divergence_radius() of the contact.
  double divergence_limit = 0.0;
  std::vector<double> q0, v0;  ///< initial state (empty: zero)
};

/// The energy balance of central differences (theory §10.6): step n of the scheme, multiplied by
/// the increment (q_{n+1} - q_{n-1}) / 2, is exactly
///   E_{n+1/2} - E_{n-1/2} = [f(t_n) + f_c] . (q_{n+1} - q_{n-1}) / 2 - (q_{n+1} - q_{n-1})^T C (q_{n+1} - q_{n-1}) /
///   4h
/// for the discrete energy E_{n+1/2} = v^T M v / 2 + q_n^T K q_{n+1} / 2 (+ V(q_{n+1/2}), the
/// potential of g~ at the midpoint, in nonlinear runs), v = (q_{n+1} - q_n) / h. The works below
/// are these terms summed from the first step, with f_c split into the normal contact force and
/// friction. Linear: the balance closes to round-off; nonlinear: to O(h^2) (the midpoint rule on
/// V), for a g~ that is the gradient of a potential (exact tensors; STEP to its identification
/// error). With a massless boundary (M = diag(0, I)) the same identity holds, with the contact
/// forces of the equilibrium of state n in step n.
struct EnergyWork {
  double external = 0.0;  ///< work of the external loads [J]
  double normal = 0.0;    ///< work of the normal contact forces on the blade (negative: absorbed)
  double friction = 0.0;  ///< work of the friction forces on the blade (positive: energy fed in)
  double damping = 0.0;   ///< energy dissipated by the viscous damping (>= 0)
  double net() const { return external + normal + friction - damping; }
};
/// E = v^T M v / 2 + q_a^T K q_b / 2 (+ V((q_a + q_b) / 2) if nonlinear), v = (q_b - q_a) / h:
/// E_{n+1/2} of EnergyWork for q_a = q_n, q_b = q_{n+1}. V(q) = q.[g(q) + g(-q)] / 6 + q.[g(q) -
/// g(-q)] / 8 (Euler's theorem on the cubic and quartic parts of the potential).
double discrete_energy(const nlrom::ReducedModel& m, const double* q_a, const double* q_b, double h, bool nonlinear);
class CubicKernelBatch;
/// The same with V from the kernel's potential coefficients (CubicKernelBatch::potential), the
/// same up to round-off.
double discrete_energy(const nlrom::ReducedModel& m, const double* q_a, const double* q_b, double h,
                       const CubicKernelBatch& potential);

struct StepState {
  long step = 0;  ///< 0 = initial state
  double t = 0.0;
  const double* q = nullptr;  ///< r
  const double* v = nullptr;  ///< r (central difference velocity)
  const nlrom::ReducedModel* model = nullptr;
  /// Contact (Settings::contact): per contact node, the normal force lambda >= 0 [N], the
  /// tangential (friction) force vector (3 values per node) and the gap of state q (after the
  /// correction); null without contact.
  const double* contact_normal = nullptr;
  const double* contact_friction = nullptr;
  const double* gap = nullptr;
  int active = 0;  ///< nodes in contact
  /// Seed 003 eq. 46: v^T M v / 2 + q^T K q / 2, computed on demand (2 r^2 multiply-adds, a few
  /// per cent of a step at r = 20, so the time loop does not pay for it when nobody asks).
  double energy() const;
  /// The energy balance (central differences): the works of the steps 0 .. n (state 0: none) and
  /// the discrete energy they change, E_{n+1/2} (state 0: E_{-1/2}), computed on demand.
  const EnergyWork* work = nullptr;
  const double *energy_qa = nullptr, *energy_qb = nullptr;
  double dt = 0.0;
  bool nonlinear = false;
  double balance_energy() const;
};

struct Stats {
  std::string kernel = "linear";                  ///< folded | potential | implicit | linear (no nonlinear force)
  double kernel_flops = 0.0, kernel_bytes = 0.0;  ///< per step (CubicKernel::flops(), bytes())
  long steps = 0;
  long newton_iterations = 0;  ///< implicit schemes
  long line_searches = 0;      ///< implicit schemes: Newton steps shortened by the line search
  /// Implicit schemes: steps whose Newton stopped at the round-off floor of the residual (a correction
  /// below 1e-8 |q| in the quadratic phase) above the tolerance, and the largest ||R|| / tolerance.
  long newton_floor_steps = 0;
  double newton_floor_ratio = 0.0;
  /// Implicit schemes with Settings::error_estimate: the local error estimate
  /// e_n = (q_n - (3 q_{n-1} - 3 q_{n-2} + q_{n-3})) / 12 of each step in the M-norm: its largest
  /// value (and time), its rms over the steps, its sum (the order of the accumulated drift: 2/pi of
  /// an oscillator's phase drift), and the largest |q|_M of the run.
  bool error_estimated = false;
  double error_local_max = 0.0, error_time = 0.0, error_local_rms = 0.0, error_sum = 0.0, error_q_max = 0.0;
  /// Settings::tangent_checks: each check's time, tangent critical step and number of negative
  /// tangent eigenvalues; the smallest step and its time.
  struct TangentSample {
    double t = 0.0, dt = 0.0;
    int negative = 0;
  };
  std::vector<TangentSample> tangent;
  double tangent_dt_min = std::numeric_limits<double>::infinity(), tangent_dt_min_time = 0.0;
  long tangent_negative_checks = 0;  ///< checks with at least one negative tangent eigenvalue
  long boundary_iterations = 0;      ///< massless boundary: equilibrium iterations (one per step if linear)
  long tangent_updates = 0;          ///< massless boundary: tangent compliances computed
  double seconds = 0.0;
  double critical_dt = 0.0;
};

/// The initial state of s for a model of size r: s.q0 and s.v0, or zeros when empty. Throws if a
/// given vector has another size.
void initial_state(const Settings& s, std::size_t r, std::vector<double>* q, std::vector<double>* v);

/// Seed 003 eq. 46 of the reduced model: v^T M~ v / 2 + q^T K~ q / 2.
double energy(const nlrom::ReducedModel& m, const double* q, const double* v);

/// Critical step of central differences for the linearized reduced model: 2 / omega_max
/// (undamped bound), omega_max^2 the largest eigenvalue of (K~, M~); for a massless boundary
/// (m.massless), that of the internal part with the boundary held (nlrom::massless_critical_step).
double critical_step(const nlrom::ReducedModel& m);
/// Central differences on the model linearized at state q: dt = 2 / omega_max, omega_max^2 the
/// largest eigenvalue of (K~ + J_s(q), M~), J_s the symmetric part of dg~/dq (dg~/dq itself for
/// forces with a potential: exact tensors, STEP to its identification error). `negative` counts
/// the negative eigenvalues: directions of negative tangent stiffness, in which the state departs
/// exponentially whatever the step. q null or a model without nonlinear force: the linear model
/// (critical_step(m)). A state whose tangent overflows (not finite) gives dt = 0. Mass-carrying
/// models only (throws on a massless one).
struct TangentStep {
  double dt = std::numeric_limits<double>::infinity();  ///< infinity if no eigenvalue is positive
  double omega2_max = 0.0, omega2_min = 0.0;
  int negative = 0;
};
TangentStep tangent_step(const nlrom::ReducedModel& m, const double* q);

/// The critical step of a run with contact c (null or no nodes: none). Mass-carrying models:
/// critical_step(m). Massless: the dynamic modes with the normal directions of the contact nodes
/// held (a sliding contact holds no other; nlrom::massless_critical_step), or with every static
/// coordinate free without contact.
double critical_step(const nlrom::ReducedModel& m, const ContactSettings* c);
/// The largest distance of the contact nodes from the z axis (0 without contact nodes): a
/// displacement no blade survives, the default divergence limit of simulate and sweep.
double divergence_radius(const ContactSettings& c);

/// The nonlinear term of one step: G(q) = P3 g~(q) with P3 = 2h^2 (2M + hC)^-1 (KernelLayout).
class CubicKernel {
 public:
  /// Throws if layout = Potential and g~ is not the gradient of a potential (naming the
  /// relative inconsistency).
  CubicKernel(const nlrom::CubicForce& g, const std::vector<double>& P3, KernelLayout layout = KernelLayout::Auto);
  /// y = G(q) (y has r entries). No allocation.
  void apply(const double* q, double* y) const;
  std::size_t r() const { return r_; }
  bool potential() const { return potential_; }
  /// Relative distance of A, B to the nearest potential form (0 for exact tensors up to round-off).
  double asymmetry() const { return asymmetry_; }
  /// Floating-point operations and bytes of coefficients read by one apply().
  double flops() const;
  double bytes() const;
  /// Folded layout: the (n2 + n3) x r matrix P3 [A; B] transposed (row m: monomial m), row-major.
  const std::vector<double>& folded() const { return W_; }

 private:
  std::size_t r_ = 0, n_ = 0;
  bool potential_ = false;
  double asymmetry_ = 0.0;
  std::vector<double> W_;             // Folded: (n2 + n3) x r, row-major
  mutable std::vector<double> z_;     // Folded: monomials; Potential: g
  std::vector<double> c3_, c4_, P3_;  // Potential: energy coefficients (sorted indices), P3
  friend class CubicKernelBatch;
};

/// The instruction sets the batched potential kernel is built for. Avx2 and Avx512 fuse every
/// multiply-add and give the same bits lane by lane; Baseline rounds products and sums apart.
enum class KernelIsa { Baseline, Avx2, Avx512 };
/// Whether this processor runs the kernel's build for isa (Baseline: always).
bool kernel_isa_supported(KernelIsa isa);
/// The widest supported: Avx512, else Avx2, else Baseline.
KernelIsa best_kernel_isa();
/// The build an option's value stands for (SweepSettings::isa, -sweep_isa): isa if >= 0 (a
/// KernelIsa), else best_kernel_isa().
KernelIsa kernel_isa_or_best(int isa);
const char* kernel_isa_name(KernelIsa isa);

/// The nonlinear term G = P3 g~ of several lanes (speeds of a sweep) in one pass over the potential
/// coefficients of a CubicKernel (KernelLayout::Potential): every coefficient loaded feeds the
/// multiply-adds of all the lanes, so the pass turns from bandwidth-bound (one lane) to compute-bound
/// (theory §10.4). Lanes come in groups of 4, stored lane-inner (Q[j L + l], L a multiple of 4); two
/// groups share each pass over a row block held in registers.
///  - A lane's arithmetic (the order of its sums, where it fuses multiply-adds) does not depend on
///    the lane's group, on how many groups share the pass or which: a speed gives the same bits
///    whichever speeds run beside it.
///  - CubicKernel's potential layout runs the same kernel on one lane (a scalar build): a speed of
///    a sweep and `morse simulate` apply the same bits (tested).
///  - Float coefficients (`single`): the coefficients rounded to float (half the bytes), the
///    products and sums in double. Their error is that of the rounding, about 6e-8 relative per
///    coefficient.
/// Built for AVX-512 (x86-64-v4: two 8-lane registers of 4 groups 6 rows at a time), AVX2 + FMA
/// (x86-64-v3) and the baseline; the widest the processor runs is used (set_isa to choose).
class CubicKernelBatch {
 public:
  /// Throws unless k holds the potential layout (k.potential()).
  explicit CubicKernelBatch(const CubicKernel& k, bool single = false);
  /// Y(:, groups) = G(Q(:, groups)) for the ng listed groups of 4 lanes (Y r x L, lane-inner; the
  /// other columns are left alone). No allocation after the first call with this many groups.
  void apply(std::size_t L, const std::size_t* groups, std::size_t ng, const double* Q, double* Y) const;
  std::size_t r() const { return r_; }
  bool single() const { return single_; }
  KernelIsa isa() const { return isa_; }
  /// Runs the build for isa from now on; throws if this processor lacks it.
  void set_isa(KernelIsa isa);
  /// Floating-point operations per lane and bytes of coefficients read by one apply() (whatever the
  /// number of lanes).
  double flops() const;
  double bytes() const;
  /// The potential V(q) whose gradient is g~(q) (the cubic and quartic energy coefficients of one
  /// lane, q of r entries; the rounded coefficients if single): one pass over them, about half the
  /// work of one lane's apply(). The sweep's energy balance takes it instead of two evaluations of
  /// the reference force.
  double potential(const double* q) const;

 private:
  std::size_t r_ = 0, n3_ = 0, n4_ = 0;
  bool single_ = false;
  KernelIsa isa_ = KernelIsa::Baseline;
  std::vector<double> c3_, c4_, P3_;  // padded (the kernel loads 4 from any coefficient)
  std::vector<float> c3f_, c4f_;
  mutable std::vector<double> X_, G_;  // the listed groups, compact: r x 8 ceil(ng / 2)
};

/// The nonlinear force and its tangent in one pass, for Newton in the implicit scheme. By Euler's
/// theorem on the homogeneous parts of g~ (eq. 28), g~ = J2(q) q / 2 + J3(q) q / 3, where
/// J2 = d(quadratic part)/dq is linear in q and J3 = d(cubic part)/dq is quadratic in q; so both
/// come from one product of the tangent coefficients with [q; q_a q_b (a <= b)].
///  - Symmetric (the tangent symmetric to 1e-6 relative: g~ the gradient of a potential, as exact
///    tensors and STEP up to its identification error): only the rows p <= m, averaged with
///    (m, p), so J and g are those of the symmetrized potential and Newton is exact on it. J2 is a
///    panel-major n2 x r matrix; J3 comes from T, the fourth derivative of the potential, an
///    n2 x n2 symmetric matrix of which only the upper block triangle is stored (theory §9).
///    Memory about 8 (n2 r + n2^2 / 2) bytes, n2 = r(r+1)/2: 0.25 MB at r = 20, 40 MB at r = 79.
///  - Otherwise (POD-filtered forces): all r^2 rows (p, m) over the r + n2 columns, panel-major:
///    8 r^2 (r + n2) bytes.
/// The constructor holds the full r^2 x (r + n2) coefficients while it builds either layout.
class TangentKernel {
 public:
  explicit TangentKernel(const nlrom::CubicForce& g);
  /// g = g~(q) (r entries) and J = dg~/dq (r x r, row-major: J[p r + m] = dg_p/dq_m). No allocation.
  void apply(const double* q, double* g, double* J) const;
  std::size_t r() const { return r_; }
  bool symmetric() const { return symmetric_; }
  /// max |dg_p/dq_m - dg_m/dq_p| over the coefficients, relative to the largest one.
  double asymmetry() const { return asymmetry_; }
  /// Floating-point operations and bytes of coefficients read by one apply().
  double flops() const;
  double bytes() const;

 private:
  std::size_t r_ = 0, rows_ = 0, n_panels_ = 0;
  bool symmetric_ = false;
  double asymmetry_ = 0.0;
  // Panel-major (detail::panel_product): the rows_ x r quadratic part when symmetric_, else the
  // rows_ x (r + r(r+1)/2) columns [q_c; q_a q_b]. S_: the cubic part when symmetric_, as the
  // symmetric fourth-derivative matrix (detail::sym_panel_product).
  std::vector<double> Hp_, S_;
  mutable std::vector<double> x_, y2_, y3_;
};

/// The line search of the implicit scheme: for phi with phi'(a) = c0 + c1 a + c2 a^2 + c3 a^3 and
/// c0 < 0, the first a > 0 where phi' changes sign from - to + (phi's first minimum along a > 0),
/// to the last bits; -1 if phi' < 0 for every a > 0; 0 if c0 >= 0.
double first_minimum_of_quartic(double c0, double c1, double c2, double c3);

/// Integrates from the initial state to t_final with s.scheme. Central: refuses (throws, naming
/// the limit) a dt above critical_step(); stops with an error naming the time reached if the state
/// becomes NaN or infinite. Trapezoidal: stops with an error naming the time reached if Newton
/// does not converge in newton_max_it iterations. callback(state) runs after the initial state
/// and every step. Serial (one rank).
Stats integrate(const nlrom::ReducedModel& m, const std::vector<ReducedLoad>& loads, const Settings& s,
                const std::function<void(const StepState&)>& callback);

/// The Trapezoidal branch of integrate().
Stats integrate_trapezoidal(const nlrom::ReducedModel& m, const std::vector<ReducedLoad>& loads, const Settings& s,
                            const std::function<void(const StepState&)>& callback);

// ------------------------------------------------------------------------------------------
// Speed sweeps (interaction maps, seed 003 §5): constant-speed runs against the casing.

/// One speed of a sweep: its index in the sweep's speed grid and Omega [rad/s].
struct SpeedTask {
  SpeedTask() = default;
  SpeedTask(long i, double w, int h = 0) : index(i), omega(w), halvings(h) {}
  long index = 0;
  double omega = 0.0;
  /// Times the step was halved for this speed (a retry after a failure, sweep_rounds): recorded
  /// in its result. sweep() runs every task at s.base.dt, which the caller has set accordingly.
  int halvings = 0;
  /// A continued speed (-sweep_continuation): the initial state q_0 = q0, q_{-1} = qm0 (r each,
  /// both at the step s.base.dt: the final state of speed `from`), the casing fully grown with its
  /// lobes at angle `phase` at t = 0. Empty q0: from rest on the growing casing.
  std::vector<double> q0, qm0;
  double phase = 0.0;
  long from = -1;  ///< the index of the speed whose final state q0 is (-1: from rest)
};

/// The cubic force kernel of a sweep's lanes (SweepSettings::kernel).
enum class SweepKernel { Auto, Lane, Folded, Potential };
/// "auto", "lane", "folded", "potential".
const char* kernel_name(SweepKernel k);

/// Everything a constant-speed run of a sweep records (Fig. 23–24 of seed 003).
struct SpeedResult {
  long index = -1;
  double omega = 0.0;
  int status = 0;  ///< 0 done; 1 failed (error says why; the other fields hold what was reached)
  std::string error;
  double dt = 0.0;                                   ///< the time step of this run [s]
  int halvings = 0;                                  ///< SpeedTask::halvings: dt is the sweep's step / 2^halvings
  long steps = 0;                                    ///< states after the initial one
  double t_final = 0.0;                              ///< revolutions * 2 pi / |Omega|
  double rms = 0.0;                                  ///< RMS of the monitored displacement over t >= t_final / 2
  double mean = 0.0;                                 ///< its mean over the same window
  double max_displacement = 0.0, time_of_max = 0.0;  ///< max |monitored displacement| over the run
  double max_force = 0.0, time_of_max_force = 0.0;   ///< max over time of the total normal force [N]
  double max_node_force = 0.0;                       ///< max over time and nodes of one normal force
  int max_active = 0;                                ///< most nodes in contact at once
  /// Settings::tangent_checks (nonlinear, mass-carrying): the smallest tangent critical step
  /// (tangent_step()) over the checked states and its time, the number of checks and of checked
  /// states with negative tangent stiffness (infinity, 0, 0, 0 without checks).
  double tangent_dt_min = std::numeric_limits<double>::infinity(), tangent_dt_min_time = 0.0;
  long tangent_checks = 0, tangent_negative_checks = 0;
  double seconds = 0.0;  ///< wall time on its rank (shared with the other lanes of its batch)
  /// amplitude over each bin of SweepSettings::frequencies() (binned_spectrum), same window, mean removed
  std::vector<double> spectrum;
  /// SweepSettings::orders > 0: the amplitude of engine order k = 1..orders at its exact frequency
  /// k |Omega| / 2 pi (decimated_spectrum), same window; NaN above spectrum_fmax and for a failed speed.
  std::vector<double> orders;
  /// The energy balance (EnergyWork) from rest: the discrete energy and the works at the first
  /// state of the analysed window (t_final / 2) and at the end.
  double energy_half = 0.0, energy_end = 0.0;
  EnergyWork work_half, work_end;
  /// Continuation (SpeedTask::from, phase): the speed whose final state this run started from (-1:
  /// from rest), the lobes' angle at its start and its discrete energy E_{-1/2} there (0 from rest);
  /// the works above count from this start, so energy - energy_start = their sum.
  long from = -1;
  double phase = 0.0, energy_start = 0.0;
  /// The final state q_N, q_{N-1} (r each) and the lobes' angle at t_N, modulo 2 pi / lobes: kept
  /// when SweepSettings::keep_state (a continuation sweep's next speed starts from it); empty
  /// otherwise and for a failed speed.
  std::vector<double> q_end, qm_end;
  double phase_end = 0.0;
};

struct SweepSettings {
  /// dt, linear, kernel, contact (nodes, casing, mu); t_final and casing.omega are set per
  /// speed. The run starts at rest (no q0, v0, loads).
  Settings base;
  double revolutions = 200.0;
  std::vector<double> monitor;  ///< r: the recorded displacement is monitor . q (e.g. e_r . u at LE)
  double spectrum_fmax = 0.0;   ///< [Hz]; 0: no spectrum
  int spectrum_bins = 0;        ///< frequencies k fmax / bins, k = 0..bins
  int orders = 0;               ///< engine-order lines 1..orders measured at their frequencies (SpeedResult::orders)
  int batch = 8;                ///< speeds advanced together per rank (lanes)
  /// The cubic force of the lanes (-sweep_kernel), measured on the 2-core EPYC in bench/README.md
  /// ("Batched potential kernel"):
  ///  - Auto: Potential when g~ is the gradient of a potential (exact tensors, STEP), else Lane.
  ///  - Potential: CubicKernelBatch, one pass over the potential coefficients for all the lanes of
  ///    a rank (compute-bound from 8 lanes).
  ///  - Folded: one pass of the folded tensor for all lanes (a matrix-matrix product; any force).
  ///  - Lane: CubicKernel (KernelLayout::Auto) lane by lane.
  SweepKernel kernel = SweepKernel::Auto;
  /// Potential: float coefficients, double arithmetic (CubicKernelBatch; -sweep_float).
  bool single = false;
  /// Potential: the kernel's build (-1: the widest the processor runs, best_kernel_isa(); else a
  /// KernelIsa the processor must have).
  int isa = -1;
  /// A speed fails (status 1, "diverged") as soon as |monitor . q| exceeds this [m] (0: never): a
  /// run that has lost stability can end with a huge but finite state before it turns non-finite.
  double divergence_limit = 0.0;
  /// Every finished speed returns its final state (SpeedResult::q_end, qm_end, phase_end).
  bool keep_state = false;
  /// The frequency grid of the spectrum (empty without one).
  std::vector<double> frequencies() const;
};

/// Amplitude spectrum of a signal x sampled every dt, at the frequencies f [Hz]: the mean removed,
/// a Hann window w, A(f) = 2 |sum_k w_k x_k exp(-2 pi i f k dt)| / sum_k w_k (A(0) without the 2),
/// so that a sinusoid of amplitude a at a frequency of f gives a.
std::vector<double> amplitude_spectrum(std::vector<double> x, double dt, const std::vector<double>& f);

/// The amplitude spectrum of a signal sampled every h and decimated by s through block means
/// (x_j = the mean of samples js .. js + s - 1): amplitude_spectrum(x, s h, f) divided by the block
/// mean's gain |sin(pi f s h) / (s sin(pi f h))|, so a sinusoid below the decimated Nyquist frequency
/// keeps its amplitude, while content at f' beyond it, which plain decimation folds onto
/// |f' - k / (s h)| unchanged, is attenuated by the block mean (by about f / f' at low f).
std::vector<double> decimated_spectrum(std::vector<double> block_means, double h, long s, const std::vector<double>& f);

/// The sweep's decimation: steps of h per block mean, max(1, floor(1 / (2.5 fmax h))), so that the
/// block means come at least 2.5 fmax per second (the sweep's lanes and its memory check).
long spectrum_block(double fmax, double h);

/// The sweep's spectrum: for every frequency f_b of the grid f (ascending, f_0 >= 0), the largest
/// decimated_spectrum over its bin [(f_{b-1} + f_b) / 2, (f_b + f_{b+1}) / 2] (the first from
/// max(0, f_0 - (f_1 - f_0) / 2), the last to f_B + (f_B - f_{B-1}) / 2), sampled at its centre,
/// its edges (directly) and between them on the grid j / (m s h), m >= 4 block_means.size() a power
/// of two (one zero-padded FFT): every delta <= 1 / (4 T) or finer, T the window's length
/// (block_means.size() s h). So a line anywhere keeps its amplitude to within 1 % (the Hann
/// window's loss at delta / 2 <= 1 / (8 T): 0.99) however wide the bins are against the resolution
/// 1 / T. decimated_spectrum at f alone loses a line that falls between two frequencies farther
/// than 2 / T from it (a long window on a coarse grid). Costs (2 B + 3) block_means.size()
/// complex products and an FFT of m points (evaluating every point directly would cost
/// 10 fmax^2 T^2 products at the sweep's decimation, 2.5 fmax samples per second: 45 s per speed
/// at 200 revolutions of 258 rad/s).
std::vector<double> binned_spectrum(std::vector<double> block_means, double h, long s, const std::vector<double>& f);

/// Throughput counters of one rank's part of a sweep.
struct SweepStats {
  long lane_steps = 0;  ///< sum over speeds of their steps
  long speeds = 0;      ///< speeds finished on this rank
  double seconds = 0.0;
  double kernel_seconds = 0.0;  ///< in the batched linear + cubic product
  /// With no speed to advance: waiting for a speed to be handed out, or (rank 0) for the other
  /// ranks to finish theirs. The load-balance loss of the sweep.
  double idle_seconds = 0.0;
  SweepKernel kernel = SweepKernel::Lane;  ///< the cubic force kernel used (Auto resolved)
};

/// A rank's fair share of a sweep of `speeds` speeds on `ranks` ranks: ceil(speeds / ranks), at
/// least 1.
std::size_t sweep_share(std::size_t speeds, int ranks);
/// The speeds a rank of sweep() starts with: min(batch, sweep_share) (batch at least 1).
std::size_t sweep_lanes_per_rank(int batch, std::size_t speeds, int ranks);
/// The tangent checks of a sweep's speed of n_steps steps with Settings::tangent_checks = checks
/// (> 0): at step 0 and every max(1, n_steps / checks) steps after it.
long sweep_tangent_checks(long n_steps, long checks);

/// Runs every task of `todo` on the ranks of comm with dynamic load balancing: rank 0 hands out
/// speeds one at a time (longest first) to whichever rank has a free lane, and also computes.
/// Each rank advances up to s.batch speeds together, and never more than its fair share
/// (sweep_share), so that a short sweep is not given whole to one rank. The ranks' first
/// sweep_lanes_per_rank speeds are dealt round robin down the longest-first order and kept for a
/// rank that starts late. The cubic force of a rank's speeds is one pass of s.kernel over all of
/// them (Potential, Folded) or one per speed (Lane).
/// The arithmetic of a speed does not depend on which other speeds share its pass, so a speed's result is bitwise the
/// same on any number of ranks and with any batch. A speed that fails (NaN, contact that does not settle) is returned
/// with status 1 and does not stop the others. on_result runs on rank 0 for each finished speed, in the order they
/// finish (the checkpoint); rank 0 prints the progress as results arrive. Collective. Returns this rank's counters.
SweepStats sweep(MPI_Comm comm, const nlrom::ReducedModel& m, const SweepSettings& s,
                 const std::vector<SpeedTask>& todo, const std::function<void(const SpeedResult&)>& on_result);

/// Lane-steps per second of a rank of a sweep advancing `lanes` speeds at omega together (at most
/// s.batch), measured over about `seconds` of wall time (the time loop only: the same lane
/// machinery as sweep(), from rest, so the first steps are contact-free). Not collective: for the
/// predicted cost of a sweep (cmd sweep).
double measure_step_rate(const nlrom::ReducedModel& m, const SweepSettings& s, double omega, double seconds,
                         int lanes = 1);

/// A sweep file (docs/hdf5-schema.md, /sweep): the settings that define the sweep, the frequency
/// grid, the model's eigenfrequencies and the finished speeds sorted by index.
struct SweepRecord {
  std::string settings;  ///< "key=value" lines; a resumed sweep must match them exactly
  std::string units = "SI", rom;
  std::vector<double> frequencies, eigenfrequencies_hz;
  std::vector<SpeedResult> results;
  long n_speeds = 0;  ///< size of the whole speed grid
  int orders = 0;     ///< SweepSettings::orders: the columns of /sweep/order_amplitude (0: none written)
};
/// Writes the record atomically (temporary file renamed into place), results sorted by index.
/// Serial: call on one rank. Throws naming the file if it cannot be written.
void write_sweep(const std::string& path, SweepRecord rec);
/// Reads a sweep file written by write_sweep (rec->n_speeds from /sweep@n_speeds). Returns false
/// (and sets *error, naming the file and the dataset) if the file does not exist, is not a sweep
/// file, or is inconsistent: a dataset of the finished speeds whose shape is not [n] ([n][number
/// of frequencies] for /sweep/spectrum) for the n speeds of /sweep/index, /sweep@n_done other than
/// n, more finished speeds than the grid has, or an index outside the grid or given twice. Nothing
/// of an inconsistent file is used. Serial.
bool read_sweep(const std::string& path, SweepRecord* rec, std::string* error);

// ------------------------------------------------------------------------------------------
// The file of a reduced run (/sim of `morse simulate`, docs/hdf5-schema.md). Its contact group
// (/sim/contact) is read back as a load history by dyn::read_load_table (dyn is below sim: the
// reader of that table format stays there).

/// What a run records at its output steps (every -sim_output_every steps from the initial state).
struct SimRecord {
  std::vector<double> time, energy;      ///< energy: seed 003 eq. 46 (StepState::energy)
  std::vector<double> q;                 ///< [time][r] reduced coordinates
  std::vector<double> final_q, final_v;  ///< the state at final_time (the last step)
  double final_time = 0.0;
  /// Displacements u = Phi q of monitored node sets: u is [time][node][x,y,z].
  struct Set {
    std::string name;
    std::vector<std::int64_t> node_ids;
    std::vector<double> u;
  };
  std::vector<Set> sets;
  /// Full fields at the snapshot times of a fom file (snapshots_fom empty: none): u and v are
  /// [snapshot][DOF] on the fom's DOF map (node id, component 0..2).
  std::string snapshots_fom;
  std::vector<double> snapshot_time, snapshot_u, snapshot_v;
  std::vector<std::int64_t> snapshot_node_ids, snapshot_components;
  /// Contact at the output steps (written when Settings::contact has nodes), per contact node.
  struct Contact {
    std::vector<std::int64_t> node_ids;
    std::vector<double> normal;               ///< [time][node] lambda >= 0 [N]
    std::vector<double> tangential;           ///< [time][node][3] friction force [N]
    std::vector<double> normals;              ///< [node][3] contact_normals()
    std::vector<double> mean_force;           ///< [time][node][3] mean force since the previous output row
    std::vector<double> mean_force_time;      ///< centre of each row's output interval (0 for row 0)
    std::vector<double> gap;                  ///< [time][node]
    std::vector<std::int64_t> active;         ///< [time] nodes in contact
    std::vector<double> radial_displacement;  ///< [time][node] e_r . u
    double max_normal_force = 0.0, time_of_max_normal_force = 0.0;
  } contact;
  /// The energy balance (EnergyWork; central differences only): rows at t = 0, at the end of
  /// every revolution of the casing (every t_final / 100 without one) and at the end.
  struct Balance {
    std::vector<double> time, energy;                         ///< energy: E_{n+1/2} of the row's state n
    std::vector<double> external, normal, friction, damping;  ///< cumulative from t = 0
    double period = 0.0;                                      ///< the interval of the rows [s]
  } balance;
  std::string rom;            ///< the nlrom file of the model
  std::string case_name;      ///< -sim_cases: the case, "" for a single run
  dyn::LoadDescription load;  ///< the run's nodal loads (/sim/load)
};

/// Writes /sim: the histories of rec, its snapshots and contact, the load (/sim/load) and the
/// settings and statistics of the run as attributes. /meta is the command's. Rank 0 data (or a
/// serial H5Output, as `morse simulate` runs one case per rank); not collective.
void write_sim(io::H5Output& out, const SimRecord& rec, const Settings& s, const Stats& stats);

/// Reads a simulate file back: the histories, the final state, the monitored sets `sets` (each
/// must be in /sim/sets), the snapshots and the contact histories if the file has them, the model
/// (/sim@rom), the case and the stored load (empty for a file written before it was stored).
/// Throws naming the file and the missing or inconsistent dataset. Serial, any rank.
SimRecord read_sim(const std::string& file, const std::vector<std::string>& sets);

// ------------------------------------------------------------------------------------------
// Stress recovery (seed 003 Figs. 11 and 25): the stress of a displacement field u = Phi q.

/// Linear: the small-strain stress sigma = lambda tr(eps) I + 2 mu eps, eps = (H + H^T) / 2.
/// Nonlinear: the Cauchy stress of St Venant-Kirchhoff, sigma = F S F^T / det F with
/// S = lambda tr(E) I + 2 mu E, E = (H + H^T + H^T H) / 2, F = I + H (zero under any rigid motion).
enum class StressMeasure { Linear, Nonlinear };

/// Von Mises stress of s = (xx, yy, zz, yz, xz, xy).
double von_mises(const double s[6]);

/// Stress at one point of a solid from its displacement gradient H (row-major, H[3i + j] =
/// du_i/dX_j): s = (xx, yy, zz, yz, xz, xy).
void stress_from_gradient(StressMeasure m, double E, double nu, const double H[9], double s[6]);

/// A recovered stress field. Element and nodal arrays are on rank 0 only (empty elsewhere), in
/// global element / node order (that of mesh::gather_to_rank0 and io::write_mesh).
struct StressField {
  std::vector<double> element_mises;      ///< [element] volume mean over the stiffness quadrature points
  std::vector<double> element_mises_max;  ///< [element] max over the stiffness quadrature points
  std::vector<double> nodal_stress;       ///< [node][6] mean over the elements around the node of the
                                          ///< stress each evaluates at the node
  std::vector<double> nodal_mises;        ///< [node] von Mises of nodal_stress
  /// Every rank: the largest quadrature-point von Mises and its element's id (the mesh's label).
  double max_mises = 0.0;
  std::int64_t max_element_id = -1;
};

/// Stress of the displacement field u ([k][3] at the nodes with external ids node_ids, e.g. a
/// StoredModel's rows) over every element of the distributed mesh. Materials as in fe::assemble
/// (the element's, else `fallback`). Each rank evaluates its own elements; rank 0 sums the nodal
/// contributions in (node, global element) order, so the result is bitwise the same on any
/// number of ranks. Throws (collectively) naming a mesh node that u lacks, or a missing/invalid
/// material. Collective.
StressField recover_stress(const mesh::LocalMesh& lm, const mesh::Material& fallback,
                           const std::vector<std::int64_t>& node_ids, const std::vector<double>& u, StressMeasure m);

/// Whether the distributed mesh `lm` (read from mesh_file) is the one the reduced model (node
/// ids and reference coordinates, read from rom_file) was built on: the same number of nodes,
/// every mesh node among the model's, at the same position to 1e-6 of the model's size. Throws
/// (collectively) naming both files and the first node that differs. Collective.
void check_stress_mesh(const mesh::LocalMesh& lm, const std::vector<std::int64_t>& node_ids,
                       const std::vector<double>& coords, const std::string& mesh_file, const std::string& rom_file);

/// What `morse stress` writes besides the field (/stress, docs/hdf5-schema.md).
struct StressRecord {
  std::int64_t n_nodes = 0, n_elements = 0;  ///< of the global mesh
  std::vector<double> displacement;          ///< [node][3] u = Phi q in global node order (rank 0)
  double time = 0.0;                         ///< of the state
  std::int64_t step = 0;                     ///< its output row in the simulate file
  StressMeasure measure = StressMeasure::Nonlinear;
  double max_nodal_von_mises = 0.0;  ///< largest nodal von Mises and its node's id
  std::int64_t max_node_id = -1;
  std::string rom, sim;  ///< the nlrom and simulate files
  std::string monitor;   ///< the set whose radial displacement chose the state ("" if a time did)
  double monitor_radial_displacement = 0.0;
};
/// Writes /stress: the displacement, the nodal stress (in XDMF Tensor6 order xx, xy, xz, yy, yz,
/// zz) and von Mises, the element von Mises (mean and max) of f, and the attributes of r. /meta
/// and /mesh are the command's. Rank 0 data; not collective.
void write_stress(io::H5Output& out, const StressField& f, const StressRecord& r);

}  // namespace morse::sim
