// The periodic bar-on-obstacle benchmark of dynamic Signorini contact: a 1-D problem with a
// closed-form, periodic solution, of the kind Doyen, Ern & Piperno (SIAM J. Sci. Comput. 33(1),
// 2011) use to compare contact time schemes (set-up as in GetFEM's demo_dynamic_contact_1D, after
// Dabaghi, Petrov, Pousin & Renard), run through sim::integrate (explicit central differences
// with the forward-increment Lagrange multipliers of Carpenter, Taylor & Katona 1991).
// docs/contact.md ("Verification: the periodic bar on an obstacle") derives the closed form.
//
// A bar 0 <= x <= L (3-D box, nu = 0, one element across: a 1-D bar in x) is clamped at x = L and
// touches a rigid wall at x = 0 without pre-stress. It is compressed uniformly,
// u(x, 0) = delta (1 - x/L), and released from rest. With tau = c t / L (mod 3) the exact
// solution is periodic of period 3 L/c: the end x = 0 flies to the wall (tau in [0, 1]), stays on
// it (tau in [1, 2]) with the constant contact force E A delta / L, and flies back (tau in [2, 3]);
// the energy E A delta^2 / 2L is conserved.
#include <petscsys.h>
#include <gtest/gtest.h>
#include <petscblaslapack.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/core/log.hpp"
#include "morse/eigen/eigen.hpp"
#include "morse/nlrom/nlrom.hpp"
#include "morse/sim/sim.hpp"
#include "util.hpp"

using namespace morse;
using mesh::ElementType;

namespace {

// Length, side of the square section and end displacement of the initial compression [m].
constexpr double kL = 1.0, kA = 0.1, kDelta = 1e-4;

mesh::Material bar_material() {
  mesh::Material m = test::steel();
  m.nu = 0.0;  // no lateral coupling: the axial field u_x(x) is exactly 1-D
  return m;
}

// The exact displacement u(x, t) / delta (x in [0, L]), tau = c t / L.
double exact_u(double xi, double tau) {
  const double p = std::fmod(tau, 3.0);
  const int phase = std::min(2, static_cast<int>(std::floor(p)));
  const double s = p - phase;
  if (phase == 0) return 1.0 - std::max(xi, s);                           // release wave from x = 0
  if (phase == 1) return -std::min(xi, s) + std::max(0.0, xi + s - 1.0);  // stopping waves from both ends
  return std::min(s, 1.0 - xi);                                           // leaving, reloaded from x = L
}
// Exact velocity of the end x = 0, in units of delta c / L.
double exact_v0(double tau) {
  const double p = std::fmod(tau, 3.0);
  return p < 1.0 ? -1.0 : (p < 2.0 ? 0.0 : 1.0);
}

enum class Basis { Sections, Identity };

// The bar as a reduced model.
//  - Sections: one column per cross-section (u_x = 1 on its 4 nodes), plus u_y and u_z of the
//    contact face: r = nx + 2 and q[0..2] is the displacement of the whole contact face (one
//    contact node carrying the total force). It spans the axial field exactly (nu = 0), so the
//    reduced model is the 1-D bar with its consistent mass.
//  - Identity: every free DOF (r = 12 nx), the 4 nodes of the face in contact separately.
struct Bar {
  int nx = 0;
  Basis basis = Basis::Sections;
  nlrom::ReducedModel rm;
  std::size_t r = 0;
  std::vector<double> xpos;       // per column: x of the node (NaN for non-axial columns)
  std::vector<std::size_t> face;  // u_x indices of the contact nodes in q
  double crit = 0.0;
  // Massless boundary (make_bar's massless): q_old = T q (r x r, row-major), q_old the
  // coordinates the columns above describe; empty: q is q_old.
  std::vector<double> T;
};

// q_old = T q for a massless bar (the section coordinates of xpos), else q itself.
std::vector<double> section_coordinates(const Bar& bar, const double* q) {
  if (bar.T.empty()) return std::vector<double>(q, q + bar.r);
  std::vector<double> y(bar.r, 0.0);
  for (std::size_t i = 0; i < bar.r; ++i)
    for (std::size_t j = 0; j < bar.r; ++j) y[i] += bar.T[i * bar.r + j] * q[j];
  return y;
}

Bar make_bar(int nx, Basis basis, bool massless = false, double dynamic_fraction = 1.0) {
  Bar bar;
  bar.nx = nx;
  bar.basis = basis;
  int rank = 0;
  MPI_Comm_rank(PETSC_COMM_WORLD, &rank);
  auto b = test::assembled_box(PETSC_COMM_WORLD, test::box_spec(ElementType::Hex8, kL, kA, kA, nx, 1, 1), {"x1"},
                               bar_material());
  const PetscInt n = b.dofs.n_global;
  const double h = kL / nx;
  const PetscInt r = basis == Basis::Sections ? nx + 2 : n;
  PetscInt first = 0, last = 0;
  MORSE_CALL(MatGetOwnershipRange(b.ops.K.get(), &first, &last));
  UMat V;
  MORSE_CALL(MatCreateDense(PETSC_COMM_WORLD, last - first, PETSC_DECIDE, n, r, nullptr, V.ptr()));
  std::vector<double> xpos(static_cast<std::size_t>(r), 0.0), is_x(static_cast<std::size_t>(r), 0.0),
      face(static_cast<std::size_t>(r), 0.0);
  for (std::size_t k = 0; k < b.lm.node_owner.size(); ++k) {
    if (b.lm.node_owner[k] != rank) continue;
    const PetscInt dx = b.dofs.node_dof[3 * k];
    if (dx < 0) continue;  // clamped face x = L
    const double x = b.lm.mesh.coords[3 * k];
    const long sec = std::lround(x / h);
    if (basis == Basis::Sections) {
      if (sec == 0) {
        for (int d = 0; d < 3; ++d) MORSE_CALL(MatSetValue(V.get(), dx + d, d, 1.0, INSERT_VALUES));
      } else {
        MORSE_CALL(MatSetValue(V.get(), dx, sec + 2, 1.0, INSERT_VALUES));
      }
      if (sec == 0) face[0] = 1.0;
      xpos[static_cast<std::size_t>(sec == 0 ? 0 : sec + 2)] = x;
      is_x[static_cast<std::size_t>(sec == 0 ? 0 : sec + 2)] = 1.0;
    } else {
      for (int d = 0; d < 3; ++d) MORSE_CALL(MatSetValue(V.get(), dx + d, dx + d, 1.0, INSERT_VALUES));
      xpos[static_cast<std::size_t>(dx)] = x;
      is_x[static_cast<std::size_t>(dx)] = 1.0;
      if (sec == 0) face[static_cast<std::size_t>(dx)] = 1.0;
    }
  }
  MORSE_CALL(MatAssemblyBegin(V.get(), MAT_FINAL_ASSEMBLY));
  MORSE_CALL(MatAssemblyEnd(V.get(), MAT_FINAL_ASSEMBLY));
  // Every rank needs the column data; the owners set them, the others hold 0 (x >= 0: max).
  for (auto* v : {&xpos, &is_x, &face})
    MPI_Allreduce(MPI_IN_PLACE, v->data(), static_cast<int>(r), MPI_DOUBLE, MPI_MAX, PETSC_COMM_WORLD);
  bar.rm = nlrom::project_model(PETSC_COMM_WORLD, V.get(), b.ops.K.get(), b.ops.M.get(), 0.0, 0);
  bar.r = static_cast<std::size_t>(r);
  bar.xpos.assign(bar.r, std::nan(""));
  for (std::size_t i = 0; i < bar.r; ++i) {
    if (is_x[i] > 0) bar.xpos[i] = xpos[i];
    if (face[i] > 0) bar.face.push_back(i);
  }
  if (massless) {  // the face (q[0..2]) massless: nlrom's massless_transform on the reduced model
    // The face's lateral columns u_y, u_z carry no force here (mu = 0, wall normal x) but MacNeal's
    // residual flexibility needs every boundary coordinate moved by a residual mode: they become
    // two decoupled coordinates above every axial mode (omega^2 = 10 max), which then are the
    // residual modes with the highest axial one, and stay at rest.
    const auto w = eigen::dense_eigenvalues(static_cast<int>(r), bar.rm.K, bar.rm.M);
    for (std::size_t d = 1; d <= 2; ++d) {
      for (std::size_t j = 0; j < bar.r; ++j) {
        bar.rm.K[d * bar.r + j] = bar.rm.K[j * bar.r + d] = 0.0;
        bar.rm.M[d * bar.r + j] = bar.rm.M[j * bar.r + d] = 0.0;
      }
      bar.rm.M[d * bar.r + d] = 1.0, bar.rm.K[d * bar.r + d] = 10.0 * w.back();
    }
    bar.rm.n_b = 3;
    PetscInt n_static = 0;
    const double fmax = dynamic_fraction < 1.0 ? dynamic_fraction * std::sqrt(w.back()) / (2.0 * M_PI) : 0.0;
    bar.T = nlrom::massless_transform(bar.rm.M, bar.rm.K, static_cast<PetscInt>(r), 3, fmax, &n_static);
    auto congruence = [&](const std::vector<double>& A) {  // T^T A T
      std::vector<double> AT(bar.r * bar.r, 0.0), B(bar.r * bar.r, 0.0);
      for (std::size_t i = 0; i < bar.r; ++i)
        for (std::size_t k = 0; k < bar.r; ++k)
          for (std::size_t j = 0; j < bar.r; ++j) AT[i * bar.r + j] += A[i * bar.r + k] * bar.T[k * bar.r + j];
      for (std::size_t k = 0; k < bar.r; ++k)
        for (std::size_t i = 0; i < bar.r; ++i)
          for (std::size_t j = 0; j < bar.r; ++j) B[i * bar.r + j] += bar.T[k * bar.r + i] * AT[k * bar.r + j];
      return B;
    };
    bar.rm.K = congruence(bar.rm.K);
    bar.rm.M = congruence(bar.rm.M);
    nlrom::make_massless(&bar.rm, n_static, 0.0, 0);
  }
  bar.crit = sim::critical_step(bar.rm);
  return bar;
}

// One contact phase as integrate() reports it: states with an active node, grouped when closer
// than L/(2c); the phase holds [t_first - dt/2, t_last + dt/2].
struct Phase {
  double start = 0, end = 0, impulse = 0;
  double e_before = 0, e_after = 0;  // conserved discrete energy just before and after
  int releases = 0;                  // inactive states inside the phase (chatter)
  double f_min = 0, f_max = 0;       // range of the pointwise total force
};

struct Result {
  double dt = 0;
  long steps = 0;
  double err_u0 = 0;       // max |u_h(0, t) - u(0, t)| / delta
  double err_field = 0;    // the same over every node (Sections basis)
  double err_v0 = 0;       // time mean of |v_h(0, t) - v(0, t)| / (delta c / L)
  double min_gap = 0;      // most negative gap / delta
  double e0 = 0;           // conserved discrete energy at the start / exact energy
  double max_rise = 0;     // largest step increase of the discrete energy / exact energy
  double max_balance = 0;  // max |E step change - lambda (g_n - g_{n-2}) / 2| / exact energy
  double split = 0;        // max |lambda_k - lambda / n_c| / max lambda (several contact nodes)
  std::vector<Phase> phases;
  std::vector<double> u0;  // end displacement history / delta
};

struct Options {
  double dt = 0;  // 0: ratio * critical step
  double ratio = 0.9;
  double periods = 4.0;     // of 3 L/c
  double wall_shift = 0.0;  // wall at x = -wall_shift * delta (0: the benchmark)
  bool contact = true;
  bool energy = true;  // track the conserved discrete energy (2 r^2 per step)
};

Result run(const Bar& bar, const Options& o) {
  const auto mat = bar_material();
  const double c = std::sqrt(mat.E / mat.rho), tL = kL / c, area = kA * kA;
  const double E_exact = mat.E * area * kDelta * kDelta / (2.0 * kL), v_scale = kDelta / tL;
  const std::size_t r = bar.r;
  sim::Settings s;
  s.linear = true;
  s.dt = o.dt > 0 ? o.dt : o.ratio * bar.crit;
  s.t_final = o.periods * 3.0 * tL;
  s.contact.mu = 0.0;
  s.contact.plane.point[0] = -o.wall_shift * kDelta;
  s.contact.plane.normal[0] = 1.0,
  s.contact.plane.normal[2] = 0.0;  // the wall x = 0, free side x > 0
  if (o.contact)
    for (std::size_t i : bar.face) {
      sim::ContactNode node;
      node.dof = i;  // reference x = 0
      s.contact.nodes.push_back(node);
    }
  s.q0.assign(r, 0.0);
  for (std::size_t i = 0; i < r; ++i)
    if (!std::isnan(bar.xpos[i])) s.q0[i] = kDelta * (1.0 - bar.xpos[i] / kL);
  if (!bar.T.empty()) {  // q0 = T^-1 q0_old
    std::vector<double> A(bar.T);
    std::vector<PetscBLASInt> piv(r);
    PetscBLASInt n = static_cast<PetscBLASInt>(r), one = 1, info = 0;
    // Row-major T is T^T column-major: solve T^T y = q0 with 'T' to get T y = q0.
    const char tr = 'T';
    LAPACKgetrf_(&n, &n, A.data(), &n, piv.data(), &info);
    LAPACKgetrs_(&tr, &n, &one, A.data(), &n, piv.data(), s.q0.data(), &n, &info);
  }
  const std::size_t i0 = bar.face.front();
  const std::size_t nc = s.contact.nodes.size();
  const double h = s.dt;
  Result R;
  R.dt = h;
  std::vector<double> qprev(r);
  std::vector<double> g_hist;  // contact-end gap per state
  double e_prev = 0, l1v = 0, t_last = 0, split = 0, lam_max = 0, lam_prev = 0;
  std::vector<std::pair<double, double>> active_states;  // (t, total force)
  std::vector<double> energy_at;                         // conserved energy per state (n >= 1)
  sim::integrate(bar.rm, {}, s, [&](const sim::StepState& x) {
    const double tau = x.t / tL;
    const double u = x.q[i0] / kDelta;
    R.u0.push_back(u);
    R.err_u0 = std::max(R.err_u0, std::abs(u - exact_u(0.0, tau)));
    if (bar.basis == Basis::Sections) {
      const auto qs = section_coordinates(bar, x.q);
      for (std::size_t i = 0; i < r; ++i)
        if (!std::isnan(bar.xpos[i]))
          R.err_field = std::max(R.err_field, std::abs(qs[i] / kDelta - exact_u(bar.xpos[i] / kL, tau)));
    }
    if (x.step > 0) l1v += std::abs(x.v[i0] / v_scale - exact_v0(tau)) * h;
    t_last = x.t;
    double lam = 0, gap = x.q[i0] - s.contact.plane.point[0];
    for (std::size_t k = 0; k < nc; ++k) {
      lam += x.contact_normal[k];
      R.min_gap = std::min(R.min_gap, x.gap[k] / kDelta);
    }
    for (std::size_t k = 0; k < nc; ++k)
      split = std::max(split, std::abs(x.contact_normal[k] - lam / static_cast<double>(nc)));
    lam_max = std::max(lam_max, lam);
    if (x.active > 0) active_states.emplace_back(x.t, lam);
    // The discrete energy that central differences conserve exactly without contact:
    // E_{n-1/2} = (q_n - q_{n-1})^T M (q_n - q_{n-1}) / 2h^2 + q_{n-1}^T K q_n / 2. With the
    // contact force f_{n-1} = lambda_n n (the force reported with state n produced q_n):
    // E_{n-1/2} - E_{n-3/2} = lambda_n (g_n - g_{n-2}) / 2 = -lambda_n g_{n-2} / 2 <= 0.
    if (x.step > 0 && o.energy) {
      double e = 0;
      for (std::size_t i = 0; i < r; ++i) {
        double a = 0, b = 0;
        for (std::size_t j = 0; j < r; ++j) {
          a += bar.rm.M[i * r + j] * (x.q[j] - qprev[j]);
          b += bar.rm.K[i * r + j] * x.q[j];
        }
        e += 0.5 * (x.q[i] - qprev[i]) * a / (h * h) + 0.5 * qprev[i] * b;
      }
      e /= E_exact;
      energy_at.push_back(e);
      if (x.step == 1) R.e0 = e;
      if (x.step > 1) {
        R.max_rise = std::max(R.max_rise, e - e_prev);
        const double g2 = g_hist[g_hist.size() - 2];
        // Mass-carrying: the forward increment puts the force reported with state n on step n - 1.
        // Massless: M (q_{n+1} - 2 q_n + q_{n-1}) / h^2 + K q_n = lambda_n n (the face in static
        // equilibrium with the force of state n), so E_{n-1/2} - E_{n-3/2} = lambda_{n-1} (g_n - g_{n-2}) / 2,
        // positive in the one step where the face leaves the wall (lambda_{n-1} > 0, g_n > 0).
        const double work = (bar.T.empty() ? lam : lam_prev) * (gap - g2) / 2.0;
        R.max_balance = std::max(R.max_balance, std::abs((e - e_prev) - work / E_exact));
      }
      e_prev = e;
    }
    g_hist.push_back(gap);
    lam_prev = lam;
    std::copy(x.q, x.q + r, qprev.begin());
  });
  R.steps = static_cast<long>(R.u0.size()) - 1;
  R.err_v0 = l1v / t_last;
  R.split = lam_max > 0 ? split / lam_max : 0.0;
  // Group the active states into phases.
  for (std::size_t a = 0; a < active_states.size(); ++a) {
    const double t = active_states[a].first, f = active_states[a].second;
    if (R.phases.empty() || t - R.phases.back().end > 0.5 * tL) {
      Phase p;
      p.start = t - 0.5 * h;
      p.f_min = p.f_max = f;
      const long n = std::lround(t / h);  // state index; energy_at[n - 1] is E_{n-1/2}
      if (o.energy) p.e_before = n >= 2 ? energy_at[static_cast<std::size_t>(n - 2)] : energy_at.front();
      R.phases.push_back(p);
    } else {
      R.phases.back().releases += static_cast<int>(std::lround((t - R.phases.back().end + 0.5 * h) / h)) - 1;
    }
    auto& p = R.phases.back();
    p.end = t + 0.5 * h;
    p.impulse += f * h;
    p.f_min = std::min(p.f_min, f), p.f_max = std::max(p.f_max, f);
    if (o.energy) p.e_after = energy_at[static_cast<std::size_t>(std::lround(t / h) - 1)];
  }
  return R;
}

// Tolerances at the finest mesh (nx = 400, h = L/400, dt = 0.0013 L/c): 1.3 to 1.6 times the
// discretization error measured there (docs/contact.md, "Verification: the periodic bar on an
// obstacle"), which falls as h^0.74 (displacement), h^0.42 (velocity), h^0.67 (impulse) and
// h^0.79 (contact times) from 25 to 400 elements. The margin on the times is 3 steps.
constexpr int kFine = 400;
constexpr double kTolU = 0.03;        // max |u_h - u| / delta over 4 periods (measured 0.0216)
constexpr double kTolV = 0.09;        // time mean |v_h(0) - v(0)| / (delta c / L) (0.0698)
constexpr double kTolTimes = 0.01;    // contact start and end [L/c] (0.0063)
constexpr double kTolImpulse = 0.03;  // impulse of each contact phase / E A delta / c - 1 (0.0194)

// The criteria of the benchmark that depend on the physics (not on the energy bookkeeping), at
// the tolerances of the finest mesh; returns how many fail and describes each in *why.
int failed_criteria(const Result& R, double impulse_exact, double tL, std::string* why, double tol_times = kTolTimes) {
  int n = 0;
  auto fail = [&](const std::string& w) { ++n, *why += w + "; "; };
  if (R.err_u0 > kTolU) fail(cat("u(0) error ", R.err_u0));
  if (R.err_field > kTolU) fail(cat("field error ", R.err_field));
  if (R.err_v0 > kTolV) fail(cat("v(0) error ", R.err_v0));
  if (R.phases.size() != 4) fail(cat(R.phases.size(), " contact phases instead of 4"));
  for (std::size_t k = 0; k < R.phases.size(); ++k) {
    const auto& p = R.phases[k];
    const double t0 = 1.0 + 3.0 * static_cast<double>(k), t1 = t0 + 1.0;
    if (std::abs(p.start / tL - t0) > tol_times) fail(cat("contact ", k, " starts at ", p.start / tL, " L/c"));
    if (std::abs(p.end / tL - t1) > tol_times) fail(cat("contact ", k, " ends at ", p.end / tL, " L/c"));
    if (std::abs(p.impulse / impulse_exact - 1.0) > kTolImpulse)
      fail(cat("impulse ", k, " / exact ", p.impulse / impulse_exact));
  }
  return n;
}

double mean_impulse_error(const Result& R, double impulse_exact) {
  double e = 0;
  for (const auto& p : R.phases) e += std::abs(p.impulse / impulse_exact - 1.0);
  return R.phases.empty() ? 1.0 : e / static_cast<double>(R.phases.size());
}
double max_time_error(const Result& R, double tL) {
  double e = 0;
  for (std::size_t k = 0; k < R.phases.size(); ++k) {
    const double t0 = 1.0 + 3.0 * static_cast<double>(k);
    e = std::max({e, std::abs(R.phases[k].start / tL - t0), std::abs(R.phases[k].end / tL - t0 - 1.0)});
  }
  return e;
}
double rate(double e_coarse, double e_fine, double refine) { return std::log(e_coarse / e_fine) / std::log(refine); }

struct Scales {
  double c, tL, impulse, force;
};
Scales scales() {
  const auto mat = bar_material();
  const double c = std::sqrt(mat.E / mat.rho);
  return {c, kL / c, mat.E * kA * kA * kDelta / c, mat.E * kA * kA * kDelta / kL};
}

}  // namespace

// Central differences with forward-increment multipliers on the periodic benchmark: 4 periods
// (12 L/c, 4 impacts) at 0.9 of the critical step on 25 to 400 elements, reduced basis of the
// cross-sections (r = nx + 2). Against the closed form: the end displacement and the whole
// field, the end velocity (time mean: it jumps, so its pointwise error is O(1) within the
// smearing of each jump), the contact intervals, the impulse of each contact phase (the pointwise
// force oscillates step to step, by about +-50 % at every h); the gap never negative beyond
// round-off; the energy that central differences conserve never rises, changes exactly by
// -lambda_n g_{n-2} / 2 (the work of the multiplier on the first contact steps), and the loss
// per impact is O(h). Every error falls with h.
TEST(SimDep, PeriodicBarOnObstacleMatchesClosedForm) {
  const Scales S = scales();
  const std::vector<int> meshes = {25, 50, 100, 200, kFine};
  std::vector<Result> res;
  for (int nx : meshes) {
    const Bar bar = make_bar(nx, Basis::Sections);
    res.push_back(run(bar, Options{}));
    const Result& R = res.back();
    const double hL = 1.0 / nx;
    print0(PETSC_COMM_WORLD,
           "  nx %3d (r %3zu, dt %.3e s = %.3f h/c, %ld steps): u(0) max err %.4f, field %.4f, "
           "v(0) mean err %.4f, "
           "impulse mean err %.4f, contact times max err %.4f L/c, min gap %.1e delta, E_1/2 / E "
           "%.6f, "
           "max step rise %.1e, balance %.1e\n",
           nx, bar.r, R.dt, R.dt * S.c * nx / kL, R.steps, R.err_u0, R.err_field, R.err_v0,
           mean_impulse_error(R, S.impulse), max_time_error(R, S.tL), R.min_gap, R.e0, R.max_rise, R.max_balance);
    for (std::size_t k = 0; k < R.phases.size(); ++k) {
      const Phase& p = R.phases[k];
      print0(PETSC_COMM_WORLD,
             "    contact %zu: [%.4f, %.4f] L/c (exact [%d, %d]), impulse / exact %.4f, force "
             "%.2f..%.2f x EA delta/L, "
             "%d chatter states, energy %.5f -> %.5f (loss %.2f h/L)\n",
             k, p.start / S.tL, p.end / S.tL, 1 + 3 * static_cast<int>(k), 2 + 3 * static_cast<int>(k),
             p.impulse / S.impulse, p.f_min / S.force, p.f_max / S.force, p.releases, p.e_before, p.e_after,
             (p.e_before - p.e_after) / hL);
    }
    // At every h: no penetration beyond round-off, no energy created, every loss accounted for
    // by the multipliers, and the loss of each impact O(h): at most h/L of the energy (observed
    // up to 0.5 h/L; about the kinetic energy of the end's effective mass rho A h / (2 sqrt 3)
    // stopped in each of the first two contact steps).
    EXPECT_GE(R.min_gap, -1e-12) << "penetration at nx = " << nx;
    EXPECT_LT(R.max_rise, 1e-10) << "energy created at nx = " << nx;
    EXPECT_LT(R.max_balance, 1e-10) << "energy change not the work of the multipliers at nx = " << nx;
    for (const auto& p : R.phases) {
      EXPECT_GE(p.e_before - p.e_after, -1e-10);
      EXPECT_LT(p.e_before - p.e_after, hL) << "energy loss per impact at nx = " << nx;
    }
  }
  // The closed form at the finest mesh.
  std::string why;
  EXPECT_EQ(failed_criteria(res.back(), S.impulse, S.tL, &why), 0) << why;
  // Convergence: each error falls at every refinement, at the observed rates over 16x in h.
  for (std::size_t i = 1; i < res.size(); ++i) {
    EXPECT_LT(res[i].err_u0, res[i - 1].err_u0) << "u(0) error does not fall at nx = " << meshes[i];
    EXPECT_LT(res[i].err_field, res[i - 1].err_field) << "field error does not fall at nx = " << meshes[i];
    EXPECT_LT(res[i].err_v0, res[i - 1].err_v0) << "v(0) error does not fall at nx = " << meshes[i];
    EXPECT_LT(mean_impulse_error(res[i], S.impulse), mean_impulse_error(res[i - 1], S.impulse))
        << "impulse error does not fall at nx = " << meshes[i];
  }
  const double refine = static_cast<double>(meshes.back()) / meshes.front();
  const Result &C = res.front(), &F = res.back();
  const double loss_c = C.phases.front().e_before - C.phases.back().e_after;
  const double loss_f = F.phases.front().e_before - F.phases.back().e_after;
  const double r_u = rate(C.err_u0, F.err_u0, refine), r_v = rate(C.err_v0, F.err_v0, refine);
  const double r_j = rate(mean_impulse_error(C, S.impulse), mean_impulse_error(F, S.impulse), refine);
  const double r_t = rate(max_time_error(C, S.tL), max_time_error(F, S.tL), refine);
  const double r_e = rate(loss_c, loss_f, refine);
  print0(PETSC_COMM_WORLD,
         "  rates in h from %d to %d elements: u(0) %.2f, v(0) %.2f, impulse %.2f, contact times "
         "%.2f, "
         "energy lost in 4 impacts %.2f (%.4f -> %.4f)\n",
         meshes.front(), meshes.back(), r_u, r_v, r_j, r_t, r_e, loss_c, loss_f);
  EXPECT_GT(r_u, 0.6);
  EXPECT_GT(r_v, 0.3);
  EXPECT_GT(r_j, 0.5);
  EXPECT_GT(r_t, 0.5);
  EXPECT_GT(r_e, 0.7);
}

// The same bar with the basis spanning the whole 3-D space (r = 12 nx, the 4 face nodes in
// contact separately) and the same step: the contact-end history equals the cross-section
// basis's to round-off and the 4 nodes share the force equally, so the 1-D reduced model is the
// full model and the multi-node active set reproduces the single-node one.
TEST(SimDep, PeriodicBarFullBasisMatchesSectionBasis) {
  const int nx = 25;
  const Bar sec = make_bar(nx, Basis::Sections), full = make_bar(nx, Basis::Identity);
  ASSERT_EQ(full.face.size(), 4u);
  ASSERT_EQ(sec.face.size(), 1u);
  Options o;
  o.dt = 0.9 * std::min(sec.crit, full.crit);
  const Result a = run(sec, o), b = run(full, o);
  ASSERT_EQ(a.u0.size(), b.u0.size());
  double d = 0;
  for (std::size_t n = 0; n < a.u0.size(); ++n) d = std::max(d, std::abs(a.u0[n] - b.u0[n]));
  print0(PETSC_COMM_WORLD,
         "  nx %d: critical step %.4e s (sections) vs %.4e s (whole space, r = %zu); u(0) "
         "histories differ by "
         "%.1e delta, force split between the 4 nodes %.1e, phases %zu vs %zu\n",
         nx, sec.crit, full.crit, full.r, d, b.split, a.phases.size(), b.phases.size());
  EXPECT_LT(d, 1e-9);
  EXPECT_LT(b.split, 1e-9);
  ASSERT_EQ(a.phases.size(), b.phases.size());
  for (std::size_t k = 0; k < a.phases.size(); ++k) {
    EXPECT_NEAR(a.phases[k].start, b.phases[k].start, 1e-3 * o.dt);
    EXPECT_NEAR(a.phases[k].end, b.phases[k].end, 1e-3 * o.dt);
    EXPECT_NEAR(a.phases[k].impulse, b.phases[k].impulse, 1e-9 * a.phases[k].impulse);
  }
}

// The criteria reject wrong physics at the finest mesh: without contact, or with the wall moved
// by 5 % of delta either way (initial gap 1.05 delta or 0.95 delta), the same checks fail.
TEST(SimDep, PeriodicBarCriteriaRejectWrongPhysics) {
  const Scales S = scales();
  const Bar bar = make_bar(kFine, Basis::Sections);
  struct Case {
    const char* name;
    Options o;
  };
  std::vector<Case> cases(3);
  for (auto& c : cases) c.o.energy = false;
  cases[0].name = "no contact";
  cases[0].o.contact = false;
  cases[1].name = "wall 0.05 delta farther";
  cases[1].o.wall_shift = 0.05;
  cases[2].name = "wall 0.05 delta nearer";
  cases[2].o.wall_shift = -0.05;
  for (const auto& c : cases) {
    const Result R = run(bar, c.o);
    std::string why;
    const int n = failed_criteria(R, S.impulse, S.tL, &why);
    print0(PETSC_COMM_WORLD, "  %s: %d criteria fail (%s)\n", c.name, n, why.c_str());
    EXPECT_GT(R.err_u0, kTolU) << c.name;
    EXPECT_GE(n, 3) << c.name;
  }
}

// The same benchmark with a massless contact face (issue 27: nlrom::massless_transform and
// make_massless on the cross-section model, MacNeal's residual flexibility, the modes up to half
// the highest frequency dynamic, the face in static equilibrium with the wall at every step), at
// half the critical step (at 0.9 of it the switch between the free and the held face pumps energy
// near the stability limit, measured: +150 % over 4 impacts). Against the closed form at the
// finest mesh at the tolerances of the mass-carrying test but the contact times (0.015 L/c); every
// error falls with h; the energy changes exactly by the work of the contact force and no cycle of
// impact and release gains energy.
TEST(SimDep, PeriodicBarMasslessBoundaryMatchesClosedForm) {
  const Scales S = scales();
  const std::vector<int> meshes = {25, 50, 100, 200, kFine};
  std::vector<Result> res;
  for (int nx : meshes) {
    const Bar bar = make_bar(nx, Basis::Sections, true, 0.5);
    const Bar carrying = make_bar(nx, Basis::Sections);
    Options o;
    o.ratio = 0.5;
    res.push_back(run(bar, o));
    const Result& R = res.back();
    const double hL = 1.0 / nx;
    double loss = 0;
    for (const auto& p : R.phases) loss += p.e_before - p.e_after;
    print0(PETSC_COMM_WORLD,
           "  massless nx %3d: critical step %.4e s (mass-carrying %.4e s), %ld steps: u(0) max err %.4f, field "
           "%.4f, v(0) mean err %.4f, impulse mean err %.4f, contact times max err %.4f L/c, min gap %.1e delta, "
           "E_1/2 / E %.6f, max step rise %.1e, energy lost in %zu impacts %.2e (%.2f h/L)\n",
           nx, bar.crit, carrying.crit, R.steps, R.err_u0, R.err_field, R.err_v0, mean_impulse_error(R, S.impulse),
           max_time_error(R, S.tL), R.min_gap, R.e0, R.max_rise, R.phases.size(), loss, loss / hL);
    // No penetration; the energy changes only by the work of the contact force (exactly); that
    // work is positive only in the step of a release, and no impact gains energy overall: each
    // loses less than 0.5 h/L (measured up to 0.21 h/L per 4 impacts, against 0.42 h/L for the
    // first impact alone with the mass-carrying face).
    EXPECT_GE(R.min_gap, -1e-12) << "penetration at nx = " << nx;
    EXPECT_LT(R.max_balance, 1e-10) << "energy change not the work of the contact force at nx = " << nx;
    // Energy: each contact phase loses some (the impact), and the step that releases the face
    // gives back part of it (the positive work lambda_{n-1} g_n / 2 above). No impact gains energy
    // (measured: each loses 0.008 to 0.15 h/L); a cycle of impact and release may gain a little,
    // O(h) (at most 0.032 h/L measured, 3 of the 15 cycles), and the 4 impacts together lose.
    for (std::size_t k = 0; k < R.phases.size(); ++k) {
      const auto& p = R.phases[k];
      print0(PETSC_COMM_WORLD, "    contact [%.4f, %.4f] L/c: energy %.6f -> %.6f (loss %.3f h/L)\n", p.start / S.tL,
             p.end / S.tL, p.e_before, p.e_after, (p.e_before - p.e_after) / hL);
      EXPECT_GE(p.e_before - p.e_after, -1e-10) << "an impact gained energy at nx = " << nx;
      if (k > 0) {
        EXPECT_LE(p.e_before - R.phases[k - 1].e_before, 0.05 * hL) << "a cycle gained energy at nx = " << nx;
      }
    }
    EXPECT_GE(loss, 0.0);
    EXPECT_LT(loss, 0.5 * hL) << "energy lost in 4 impacts at nx = " << nx;
  }
  // The closed form at the finest mesh: the tolerances of the mass-carrying test, but for the
  // contact times, whose error is larger with a massless face (0.069 L/c at 25 elements, 0.0116 at
  // 400, against 0.056 and 0.0063; h^0.64): 0.015 L/c.
  std::string why;
  EXPECT_EQ(failed_criteria(res.back(), S.impulse, S.tL, &why, 0.015), 0) << why;
  for (std::size_t i = 1; i < res.size(); ++i) {
    EXPECT_LT(res[i].err_u0, res[i - 1].err_u0) << "u(0) error does not fall at nx = " << meshes[i];
    EXPECT_LT(res[i].err_field, res[i - 1].err_field) << "field error does not fall at nx = " << meshes[i];
    EXPECT_LT(res[i].err_v0, res[i - 1].err_v0) << "v(0) error does not fall at nx = " << meshes[i];
  }
  const double refine = static_cast<double>(meshes.back()) / meshes.front();
  const Result &C = res.front(), &F = res.back();
  const double r_u = rate(C.err_u0, F.err_u0, refine), r_v = rate(C.err_v0, F.err_v0, refine);
  const double r_j = rate(mean_impulse_error(C, S.impulse), mean_impulse_error(F, S.impulse), refine);
  const double r_t = rate(max_time_error(C, S.tL), max_time_error(F, S.tL), refine);
  print0(PETSC_COMM_WORLD,
         "  massless rates in h from %d to %d elements: u(0) %.2f, v(0) %.2f, impulse %.2f, "
         "contact times %.2f\n",
         meshes.front(), meshes.back(), r_u, r_v, r_j, r_t);
  EXPECT_GT(r_u, 0.6);
  EXPECT_GT(r_v, 0.3);
  EXPECT_GT(r_j, 0.5);
  EXPECT_GT(r_t, 0.5);
}
