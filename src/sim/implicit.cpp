// Implicit reduced integration (see morse/sim/sim.hpp, Scheme::Trapezoidal and Scheme::Energy).
//
// The schemes of `morse fom` (src/dyn/fom.cpp) on the reduced model, residual scaled by 2, with
// q0, v0 known and v1 = 2 (q1 - q0)/h - v0:
//   R(q1) = (2/h) M (v1 - v0) + C (v0 + v1) + K (q0 + q1) + 2 g_alg - (f(t0) + f(t1)),
//   2 g_alg = g(q0) + g(q1)                        (trapezoidal),
//           = (g(q0) + 4 g((q0 + q1)/2) + g(q1))/3  (energy: the mean of g over the step, exact),
// solved by Newton (Cholesky, or LU, of the r x r iteration matrix) with an exact line search on
// the incremental potential (theory §9.1); g and dg/dq come from one pass of TangentKernel per
// point. The same convergence test as fom, ||R|| <= rtol max(||inertia||, ||internal||, ||load||),
// or the round-off floor of R (below). With a basis that spans the whole space the trapezoidal
// scheme gives the full model's discrete solution.
#include <petscsys.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>

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

// In-place LU with partial pivoting of the row-major n x n matrix A, then x = A^-1 b in b.
// Returns false if a pivot is zero. For the r <= ~100 iteration matrices of the reduced Newton,
// this is cheaper than LAPACK's call overhead.
bool lu_solve(std::size_t n, double* A, std::size_t* piv, double* b) {
  for (std::size_t k = 0; k < n; ++k) {
    std::size_t p = k;
    double best = std::abs(A[k * n + k]);
    for (std::size_t i = k + 1; i < n; ++i)
      if (std::abs(A[i * n + k]) > best) best = std::abs(A[i * n + k]), p = i;
    if (best == 0.0 || !std::isfinite(best)) return false;
    piv[k] = p;
    if (p != k) {
      for (std::size_t j = 0; j < n; ++j) std::swap(A[k * n + j], A[p * n + j]);
      std::swap(b[k], b[p]);
    }
    const double inv = 1.0 / A[k * n + k];
    const double* __restrict rk = A + k * n;
    for (std::size_t i = k + 1; i < n; ++i) {
      double* __restrict ri = A + i * n;
      const double l = ri[k] * inv;
      ri[k] = l;
      for (std::size_t j = k + 1; j < n; ++j) ri[j] -= l * rk[j];
      b[i] -= l * b[k];
    }
  }
  for (std::size_t k = n; k-- > 0;) {
    double v = b[k];
    for (std::size_t j = k + 1; j < n; ++j) v -= A[k * n + j] * b[j];
    b[k] = v / A[k * n + k];
  }
  return true;
}

// In-place Cholesky A = L L^T of the symmetric row-major n x n matrix A (lower triangle used and
// overwritten), then x = A^-1 b in b. Returns false (A partly overwritten) if A is not positive
// definite. Right-looking: the trailing update runs along contiguous rows (no dependency chain);
// col holds column j of L contiguously (n entries).
bool cholesky_solve(std::size_t n, double* A, double* b, double* col) {
  for (std::size_t j = 0; j < n; ++j) {
    const double d = A[j * n + j];
    if (!(d > 0.0) || !std::isfinite(d)) return false;
    const double ljj = std::sqrt(d), inv = 1.0 / ljj;
    A[j * n + j] = ljj;
    for (std::size_t i = j + 1; i < n; ++i) col[i] = A[i * n + j] *= inv;
    for (std::size_t i = j + 1; i < n; ++i) {
      double* __restrict ri = A + i * n;
      const double l = col[i];
      for (std::size_t k = j + 1; k <= i; ++k) ri[k] -= l * col[k];
    }
  }
  for (std::size_t k = 0; k < n; ++k) {  // L y = b, by columns (no serial dot-product chain)
    b[k] /= A[k * n + k];
    const double v = b[k];
    for (std::size_t i = k + 1; i < n; ++i) b[i] -= A[i * n + k] * v;
  }
  for (std::size_t i = n; i-- > 0;) {  // L^T x = y: subtract column i of L from the rows above
    b[i] /= A[i * n + i];
    const double v = b[i];
    for (std::size_t k = 0; k < i; ++k) b[k] -= A[i * n + k] * v;
  }
  return true;
}

double dot(std::size_t n, const double* a, const double* b) {
  double s = 0.0;
  for (std::size_t i = 0; i < n; ++i) s += a[i] * b[i];
  return s;
}

// x^T A y for the row-major n x n matrix A.
double quadratic_form(std::size_t n, const double* A, const double* x, const double* y) {
  double s = 0.0;
  for (std::size_t i = 0; i < n; ++i) s += x[i] * dot(n, A + i * n, y);
  return s;
}

}  // namespace

double first_minimum_of_quartic(double c0, double c1, double c2, double c3) {
  // phi'(a) = c0 + c1 a + c2 a^2 + c3 a^3 with c0 < 0: the first a > 0 where phi' changes sign
  // from - to +. The critical points of phi' (roots of c1 + 2 c2 a + 3 c3 a^2) split (0, inf) into
  // intervals on which phi' is monotone; the first interval whose right end has phi' >= 0 holds
  // the root, found by bisection to the last bits (a safe, branch-free method: no case analysis of
  // Cardano's formula, whose cancellations lose digits exactly where the roots nearly coincide).
  auto d = [&](double a) { return c0 + a * (c1 + a * (c2 + a * c3)); };
  if (!(c0 < 0.0)) return 0.0;
  std::vector<double> ends;
  if (c3 != 0.0) {
    const double A = 3.0 * c3, B = 2.0 * c2, C = c1, disc = B * B - 4.0 * A * C;
    if (disc >= 0.0) {
      const double sq = std::sqrt(disc), qq = -0.5 * (B + std::copysign(sq, B));
      const double r1 = qq / A, r2 = qq != 0.0 ? C / qq : r1;
      for (double x : {r1, r2})
        if (x > 0.0 && std::isfinite(x)) ends.push_back(x);
    }
  } else if (c2 != 0.0) {
    const double x = -c1 / (2.0 * c2);
    if (x > 0.0) ends.push_back(x);
  }
  std::sort(ends.begin(), ends.end());
  double lo = 0.0;
  for (std::size_t k = 0;; ++k) {
    double hi;
    if (k < ends.size()) {
      hi = ends[k];
      if (d(hi) <= 0.0) {  // phi' still negative (or touching 0: an inflection of phi, no minimum)
        lo = hi;
        continue;
      }
    } else {
      // Beyond the last critical point phi' is monotone: grow the bracket until phi' >= 0.
      if (!(c3 > 0.0 || (c3 == 0.0 && (c2 > 0.0 || (c2 == 0.0 && c1 > 0.0))))) return -1.0;  // phi' < 0 for ever
      hi = std::max(2.0 * lo, 1.0);
      for (int g = 0; d(hi) < 0.0 && g < 2100; ++g) hi *= 2.0;
      if (d(hi) < 0.0) return -1.0;
    }
    for (int it = 0; it < 200 && hi - lo > 1e-15 * hi; ++it) {
      const double mid = 0.5 * (lo + hi);
      (d(mid) < 0.0 ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
  }
}

TangentKernel::TangentKernel(const nlrom::CubicForce& g) : r_(g.r) {
  const std::size_t r = r_, n2 = nlrom::n_quadratic(r), R = r * r;
  MORSE_CHECK(g.A.size() == n2 * r && g.B.size() == nlrom::n_cubic(r) * r,
              "simulate: the reduced nonlinear force has the wrong size for r = ", r);
  auto pair = [r](std::size_t i, std::size_t j) {  // lexicographic index of (i <= j)
    if (i > j) std::swap(i, j);
    return i * r - i * (i - 1) / 2 + (j - i);
  };
  // All rows (p, m) first: H2(c, p r + m) = d^2 g_p / dq_m dq_c, H3(ab, p r + m) the coefficient
  // of q_a q_b in dg_p/dq_m.
  std::vector<double> F2(r * R, 0.0), F3(n2 * R, 0.0);
  std::size_t a = 0, b = 0;
  for (std::size_t i = 0; i < r; ++i)
    for (std::size_t j = i; j < r; ++j) {
      const double* A = &g.A[a++ * r];
      for (std::size_t p = 0; p < r; ++p) {  // d(q_i q_j) = q_j dq_i + q_i dq_j
        F2[j * R + p * r + i] += A[p];
        F2[i * R + p * r + j] += A[p];
      }
      for (std::size_t k = j; k < r; ++k) {
        const double* B = &g.B[b++ * r];
        const std::size_t jk = pair(j, k), ik = pair(i, k), ij = pair(i, j);
        for (std::size_t p = 0; p < r; ++p) {
          F3[jk * R + p * r + i] += B[p];
          F3[ik * R + p * r + j] += B[p];
          F3[ij * R + p * r + k] += B[p];
        }
      }
    }
  double big = 0.0, dev = 0.0;
  auto scan = [&](const std::vector<double>& F, std::size_t cols) {
    for (std::size_t c = 0; c < cols; ++c)
      for (std::size_t p = 0; p < r; ++p)
        for (std::size_t m = p; m < r; ++m) {
          const double x = F[c * R + p * r + m], y = F[c * R + m * r + p];
          big = std::max({big, std::abs(x), std::abs(y)});
          dev = std::max(dev, std::abs(x - y));
        }
  };
  scan(F2, r);
  scan(F3, n2);
  asymmetry_ = big > 0.0 ? dev / big : 0.0;
  symmetric_ = asymmetry_ <= 1e-6;
  rows_ = symmetric_ ? n2 : R;
  n_panels_ = (rows_ + detail::kPanel - 1) / detail::kPanel;
  const std::size_t P = detail::kPanel, padded = n_panels_ * P;
  // Row k of the kernel: (p, m) with p <= m (symmetric, averaged with (m, p)) or every (p, m).
  std::vector<std::size_t> row_p(rows_), row_m(rows_);
  for (std::size_t p = 0, k = 0; p < r; ++p)
    for (std::size_t m = symmetric_ ? p : 0; m < r; ++m, ++k) row_p[k] = p, row_m[k] = m;
  auto coef = [&](const std::vector<double>& F, std::size_t c, std::size_t k) {
    const std::size_t pm = row_p[k] * r + row_m[k], mp = row_m[k] * r + row_p[k];
    return symmetric_ ? 0.5 * (F[c * R + pm] + F[c * R + mp]) : F[c * R + pm];
  };
  // The quadratic part (columns q_c), or everything when not symmetric: panel-major.
  const std::size_t n_cols = symmetric_ ? r : r + n2;
  Hp_.assign(n_panels_ * n_cols * P, 0.0);
  for (std::size_t k = 0; k < rows_; ++k)
    for (std::size_t c = 0; c < n_cols; ++c)
      Hp_[((k / P) * n_cols + c) * P + k % P] = c < r ? coef(F2, c, k) : coef(F3, c - r, k);
  if (symmetric_) {
    // The cubic part: J3_pm = sum_{a <= b} w_ab T_pmab q_a q_b with T = the fourth derivative of
    // the potential (symmetric under (p, m) <-> (a, b)) and w_ab = 1 (a < b), 1/2 (a = b). The
    // product runs on T (upper block triangle, averaged with its transpose) and the monomials
    // scaled by w.
    auto T = [&](std::size_t k, std::size_t c) {  // rows and columns both (i <= j) pairs
      const double wc = row_p[c] == row_m[c] ? 0.5 : 1.0, wk = row_p[k] == row_m[k] ? 0.5 : 1.0;
      return 0.5 * (coef(F3, c, k) / wc + coef(F3, k, c) / wk);
    };
    S_.clear();
    for (std::size_t b = 0; b < n_panels_; ++b)
      for (std::size_t c = b * P; c < padded; ++c)
        for (std::size_t o = 0; o < P; ++o) {
          const std::size_t k = b * P + o;
          S_.push_back(k < rows_ && c < rows_ ? T(k, c) : 0.0);
        }
  }
  x_.assign(symmetric_ ? std::max(r, padded) : r + n2, 0.0);
  y2_.assign(padded, 0.0);
  y3_.assign(padded, 0.0);
}

void TangentKernel::apply(const double* q, double* g, double* J) const {
  const std::size_t r = r_, n2 = nlrom::n_quadratic(r);
  if (symmetric_) {
    detail::panel_product(n_panels_, r, r, q, Hp_.data(), y2_.data(), y3_.data());  // y3: scratch
    detail::quadratic_monomials(r, q, x_.data());
    for (std::size_t i = 0, k = 0; i < r; k += r - i, ++i) x_[k] *= 0.5;  // w_ii
    detail::sym_panel_product(n_panels_, S_.data(), x_.data(), y3_.data());
    std::size_t k = 0;
    for (std::size_t p = 0; p < r; ++p)
      for (std::size_t m = p; m < r; ++m, ++k) J[p * r + m] = J[m * r + p] = y2_[k] + y3_[k];
  } else {
    std::copy(q, q + r, x_.begin());
    detail::quadratic_monomials(r, q, x_.data() + r);
    detail::panel_product(n_panels_, r + n2, r, x_.data(), Hp_.data(), y2_.data(), y3_.data());
    for (std::size_t k = 0; k < r * r; ++k) J[k] = y2_[k] + y3_[k];
  }
  // Euler: g = J2 q / 2 + J3 q / 3.
  for (std::size_t p = 0; p < r; ++p) g[p] = 0.0;
  if (symmetric_) {
    std::size_t k = 0;
    for (std::size_t p = 0; p < r; ++p)
      for (std::size_t m = p; m < r; ++m, ++k) {
        const double c = 0.5 * y2_[k] + y3_[k] / 3.0;
        g[p] += c * q[m];
        if (m != p) g[m] += c * q[p];
      }
  } else {
    for (std::size_t p = 0; p < r; ++p) {
      double v = 0.0;
      for (std::size_t m = 0; m < r; ++m) v += (0.5 * y2_[p * r + m] + y3_[p * r + m] / 3.0) * q[m];
      g[p] = v;
    }
  }
}

double TangentKernel::flops() const {
  const double r = static_cast<double>(r_), n2 = static_cast<double>(nlrom::n_quadratic(r_));
  const double rows = static_cast<double>(n_panels_ * detail::kPanel);
  // 2 flops per stored coefficient and use (the off-diagonal blocks of S are used twice), plus
  // the monomials and Euler's sum.
  return 2.0 * static_cast<double>(Hp_.size()) +
         (symmetric_ ? 4.0 * static_cast<double>(S_.size()) - 2.0 * rows * detail::kPanel : 0.0) + n2 + 4.0 * r * r;
}

double TangentKernel::bytes() const { return 8.0 * static_cast<double>(Hp_.size() + S_.size()); }

Stats integrate_trapezoidal(const nlrom::ReducedModel& m, const std::vector<ReducedLoad>& loads, const Settings& s,
                            const std::function<void(const StepState&)>& callback) {
  const std::size_t r = static_cast<std::size_t>(m.r);
  const double h = s.dt;
  MORSE_CHECK(h > 0 && std::isfinite(h), "simulate: the time step -sim_dt must be positive (got ", h, ")");
  MORSE_CHECK(s.t_final > 0 && std::isfinite(s.t_final), "simulate: -sim_tfinal must be positive (got ", s.t_final,
              ")");
  for (const auto& l : loads)
    MORSE_CHECK(l.p.size() == r, "simulate: a reduced load has ", l.p.size(), " entries, not ", r);
  const bool nonlinear = !s.linear;
  MORSE_CHECK(s.contact.nodes.empty(), "simulate: contact needs the explicit scheme (-sim_scheme central)");
  MORSE_CHECK(s.linear || m.g.r == r, "simulate: the reduced model has no nonlinear force of size ", r,
              " (a linear model, -nlrom_forces none): run it with -sim_linear");
  Stats st;
  st.critical_dt = critical_step(m);
  st.kernel = nonlinear ? "implicit" : "linear";
  std::vector<double> q0, v0, q1(r), v1(r), g0(r, 0.0), g1(r, 0.0), f0(r, 0.0), f1(r, 0.0), R(r), w(r), internal(r),
      J(r * r), G(r * r), Jlin(r * r), qt(r), gt(r), Gt(r * r), g_end(r), g_trial(r);
  std::vector<std::size_t> piv(r);
  std::vector<double> col(r);
  initial_state(s, r, &q0, &v0);
  std::optional<TangentKernel> tangent;
  if (nonlinear) {
    tangent.emplace(m.g);
    st.kernel_flops = tangent->flops();
    st.kernel_bytes = tangent->bytes();
  }
  // The linear part of the iteration matrix, 4/h^2 M + 2/h C + K (row-major).
  for (std::size_t k = 0; k < r * r; ++k) Jlin[k] = 4.0 / (h * h) * m.M[k] + 2.0 / h * m.C[k] + m.K[k];
  // Cholesky when the iteration matrix is symmetric (M, C, K and the tangent), LU otherwise or
  // when it is not positive definite. When it is symmetric, R is the gradient of the incremental
  // potential Pi(q1) = q1^T Jlin q1 / 2 + c^T q1 + V(q1) (V the potential of g~, c fixed in the
  // step), and the line search below minimizes Pi along the Newton direction.
  bool symmetric = !nonlinear || tangent->symmetric();
  {
    double big = 0.0, dev = 0.0;
    for (std::size_t i = 0; i < r; ++i)
      for (std::size_t j = 0; j < r; ++j)
        big = std::max(big, std::abs(Jlin[i * r + j])),
        dev = std::max(dev, std::abs(Jlin[i * r + j] - Jlin[j * r + i]));
    symmetric = symmetric && dev <= 1e-12 * big;
  }
  const bool line_search = nonlinear && symmetric && s.newton_line_search;
  auto load = [&](double t, std::vector<double>& f) {
    std::fill(f.begin(), f.end(), 0.0);
    for (const auto& l : loads) {
      const double c = l.factor(t);
      for (std::size_t i = 0; i < r; ++i) f[i] += c * l.p[i];
    }
  };
  // [M; K; C] stacked and stored by columns (r columns of 3r): y = [M x; K x; C x] as r axpys
  // along contiguous columns (vectorized; a dot-product loop would be one serial FMA chain).
  std::vector<double> MKC(3 * r * r), mkc(3 * r), aM(r), aC(r), aK(r), Mv0(3 * r);
  for (std::size_t i = 0; i < r; ++i)
    for (std::size_t j = 0; j < r; ++j) {
      MKC[j * 3 * r + i] = m.M[i * r + j];
      MKC[j * 3 * r + r + i] = m.K[i * r + j];
      MKC[j * 3 * r + 2 * r + i] = m.C[i * r + j];
    }
  auto stacked = [&](const double* __restrict x, double* __restrict y) {
    for (std::size_t i = 0; i < 3 * r; ++i) y[i] = 0.0;
    for (std::size_t j = 0; j < r; ++j) {
      const double* __restrict a = &MKC[j * 3 * r];
      const double xj = x[j];
      for (std::size_t i = 0; i < 3 * r; ++i) y[i] += a[i] * xj;
    }
  };
  // The time-discretization error estimate (theory §9.2): the local error of both schemes is
  // h^3 q'''/12 + O(h^4). The computed states lie on a smooth curve, so the quadratic
  // extrapolation q_p = 3 q_0 - 3 q_-1 + q_-2 of the last three misses q_1 by h^3 q''' + O(h^4),
  // and e = (q_1 - q_p) / 12 estimates the local error from displacements alone (from the third
  // step on). An unresolved stiff mode (omega h >> 1,
  // which the rule rings at the Nyquist frequency) contributes about its ringing amplitude, not
  // (omega h)^2 times it as an acceleration-based estimate would. Measured in the M-norm.
  std::vector<double> qm1, qm2, e(r);
  const bool estimate = s.error_estimate;
  auto m_norm = [&](const std::vector<double>& x) {
    return std::sqrt(std::max(0.0, quadratic_form(r, m.M.data(), x.data(), x.data())));
  };
  double q_max = 0.0, e_sum = 0.0, e_sq = 0.0;
  long n_estimates = 0;
  // The nonlinear term of R and its Jacobian at q1 (gb, Gb), and g~(q1) itself (gq):
  //  - trapezoidal: (g~(q0) + g~(q1)) / 2, so gb = g~(q1) (a_K holds g~(q0));
  //  - energy (the average vector field, theory §9.3): the mean of g~ over the segment q0 -> q1,
  //    exact by Simpson's rule for a cubic, (g~(q0) + 4 g~(q_m) + g~(q1)) / 6 with
  //    q_m = (q0 + q1) / 2, so gb = (4 g~(q_m) + g~(q1)) / 3 and Gb = (2 G(q_m) + G(q1)) / 3.
  //    Then (q1 - q0)^T (twice the mean) = 2 (V(q1) - V(q0)): the discrete energy is conserved
  //    exactly when undamped and unforced, whatever the step.
  const bool avf = s.scheme == Scheme::Energy;
  const double g0_share = avf ? 1.0 / 3.0 : 1.0;
  std::vector<double> qmid(avf ? r : 0), gmid(avf ? r : 0), Gmid(avf ? r * r : 0);
  auto evaluate = [&](const double* q, double* gb, double* Gb, double* gq) {
    if (!avf) {
      tangent->apply(q, gb, Gb);
      std::copy(gb, gb + r, gq);
      return;
    }
    for (std::size_t i = 0; i < r; ++i) qmid[i] = 0.5 * (q0[i] + q[i]);
    tangent->apply(qmid.data(), gmid.data(), Gmid.data());
    tangent->apply(q, gq, Gb);
    for (std::size_t i = 0; i < r; ++i) gb[i] = (4.0 * gmid[i] + gq[i]) / 3.0;
    for (std::size_t k = 0; k < r * r; ++k) Gb[k] = (2.0 * Gmid[k] + Gb[k]) / 3.0;
  };
  if (nonlinear) tangent->apply(q0.data(), g0.data(), G.data());
  load(0.0, f0);
  if (estimate) q_max = m_norm(q0);
  StepState ss;
  ss.model = &m;
  ss.q = q0.data();
  ss.v = v0.data();
  callback(ss);
  const long n_steps = detail::step_count(s.t_final, h);
  std::vector<double> history;  // ||R|| of the iterations of the current step (for the error message)
  const auto t_start = std::chrono::steady_clock::now();
  for (long n = 1; n <= n_steps; ++n) {
    const double t0 = (n - 1) * h, t1 = n * h;
    load(t1, f1);
    // Predictor q1 = q0, as fom; with the trapezoidal rule g and the tangent there are those of
    // the converged q0.
    q1 = q0;
    if (avf && nonlinear)
      evaluate(q1.data(), g1.data(), G.data(), g_end.data());
    else
      g1 = g0, g_end = g0;
    stacked(q0.data(), mkc.data());
    stacked(v0.data(), Mv0.data());  // only its M part is used
    for (std::size_t i = 0; i < r; ++i) {
      aM[i] = -4.0 / (h * h) * mkc[i] - 4.0 / h * Mv0[i];
      aK[i] = mkc[r + i] + g0_share * g0[i];
      aC[i] = -2.0 / h * mkc[2 * r + i];
    }
    history.clear();
    double previous_rel = 1.0;
    bool at_floor = false;
    for (int it = 0;; ++it) {
      // R = inertia + damping + internal - load, with [M; K; C] q1 in one pass and the parts
      // that depend on q0, v0 only (a_*) formed once per step:
      //   inertia = (2/h) M (v1 - v0) = (4/h^2) M q1 + a_M,  a_M = -(4/h^2) M q0 - (4/h) M v0
      //   damping = C (v0 + v1) = (2/h) C q1 + a_C,          a_C = -(2/h) C q0
      //   internal = K (q0 + q1) + g0 + g1 = K q1 + a_K + g1, a_K = K q0 + g0
      // (energy: a_K = K q0 + g0 / 3, g1 = gb). g1 and G are those of q1 (the predictor, or the
      // last update).
      stacked(q1.data(), mkc.data());
      double inertia = 0.0;
      for (std::size_t i = 0; i < r; ++i) {
        const double x = 4.0 / (h * h) * mkc[i] + aM[i];
        R[i] = x + 2.0 / h * mkc[2 * r + i] + aC[i];
        internal[i] = mkc[r + i] + aK[i] + (nonlinear ? g1[i] : 0.0);
        inertia += x * x;
      }
      inertia = std::sqrt(inertia);
      double loadn = 0.0;
      for (std::size_t i = 0; i < r; ++i) {
        R[i] += internal[i] - (f0[i] + f1[i]);
        loadn += (f0[i] + f1[i]) * (f0[i] + f1[i]);
      }
      const double rnorm = norm2(R), scale = std::max({inertia, norm2(internal), std::sqrt(loadn)});
      history.push_back(rnorm);
      if (!std::isfinite(rnorm))
        throw Error(cat("simulate: NaN or infinite residual at t = ", t1, " (step ", n, "); last converged time ", t0,
                        ". Reduce -sim_dt"));
      if (rnorm <= s.newton_rtol * scale || (scale == 0.0 && rnorm == 0.0)) break;
      if (at_floor) {
        ++st.newton_floor_steps;
        st.newton_floor_ratio = std::max(st.newton_floor_ratio, rnorm / (s.newton_rtol * scale));
        break;
      }
      if (it >= s.newton_max_it) {
        std::string trace;
        for (std::size_t k = 0; k < history.size(); ++k) {
          if (history.size() > 12 && k == 6) {
            trace += cat(", ... (", history.size() - 12, " more)");
            k = history.size() - 6;
          }
          trace += cat(k ? ", " : "", history[k]);
        }
        throw Error(
            cat("simulate: Newton did not converge at t = ", t1, " (step ", n, ") in ", s.newton_max_it,
                " iterations (tolerance ", s.newton_rtol * scale, "; ||R|| per iteration: ", trace,
                "); last converged time ", t0,
                line_search ? "" : " (no line search: -sim_newton_line_search off or a force with no potential)",
                ". Try a smaller -sim_dt, a larger -sim_newton_max_it or -sim_newton_rtol, "
                "or -sim_scheme central"));
      }
      // J = 4/h^2 M + 2/h C + K + dg/dq(q1); w = J^-1 R, the Newton direction d = -w.
      for (std::size_t k = 0; k < r * r; ++k) J[k] = Jlin[k] + (nonlinear ? G[k] : 0.0);
      w = R;
      if (!symmetric || !cholesky_solve(r, J.data(), w.data(), col.data())) {
        for (std::size_t k = 0; k < r * r; ++k) J[k] = Jlin[k] + (nonlinear ? G[k] : 0.0);
        w = R;
        MORSE_CHECK(lu_solve(r, J.data(), piv.data(), w.data()), "simulate: singular iteration matrix at t = ", t1);
      }
      ++st.newton_iterations;
      if (!nonlinear) {
        double dq = 0.0, qn = 0.0;
        for (std::size_t i = 0; i < r; ++i) {
          q1[i] -= w[i];
          dq = std::max(dq, std::abs(w[i]));
          qn = std::max(qn, std::abs(q1[i]));
        }
        if (it > 0 && dq <= 1e-13 * qn) break;
        continue;
      }
      // Line search (theory §9.1). Along q1 + a d, Pi is a quartic in a; its slope is
      //   phi'(a) = d^T R(q1 + a d) = c0 + c1 a + c2 a^2 + c3 a^3,
      // c0 = d^T R(q1), c1 = d^T (Jlin + G(q1)) d, and c2, c3 from the nonlinear slope
      // psi(a) = d^T g~(q1 + a d), a cubic known from psi(0), psi'(0) and, at the full step a = 1,
      // psi(1) and psi'(1): the evaluation plain Newton needs anyway. The full step is taken when
      // it lowers Pi enough (Armijo); otherwise the first minimum of the quartic along d, from q1,
      // so the iteration stays in the basin it started from (the previous step's state).
      double sign = -1.0, c0 = 0.0, c1 = 0.0, psi0 = 0.0, psi1 = 0.0;
      if (line_search) {
        const double wJw = dot(r, w.data(), R.data());  // w^T J w, as J w = R
        if (wJw < 0.0) sign = 1.0;                      // J indefinite along w: -w climbs Pi
        if (sign > 0.0)
          for (std::size_t i = 0; i < r; ++i) w[i] = -w[i];  // w = -d from here on
        c0 = -dot(r, w.data(), R.data());
        c1 = wJw;  // d^T J d, even in d
        psi0 = -dot(r, w.data(), g1.data());
        psi1 = quadratic_form(r, G.data(), w.data(), w.data());
      }
      for (std::size_t i = 0; i < r; ++i) qt[i] = q1[i] - w[i];
      evaluate(qt.data(), gt.data(), Gt.data(), g_trial.data());
      double alpha = 1.0;
      if (line_search && c0 < 0.0) {
        const double psi_1 = -dot(r, w.data(), gt.data()), dpsi_1 = quadratic_form(r, Gt.data(), w.data(), w.data());
        const double e1 = psi_1 - psi0 - psi1, e2 = dpsi_1 - psi1;
        const double c3 = e2 - 2.0 * e1, c2 = e1 - c3;
        const double dpi1 = c0 + 0.5 * c1 + c2 / 3.0 + 0.25 * c3;  // Pi(q1 + d) - Pi(q1)
        if (sign > 0.0 || !(dpi1 <= 1e-4 * c0)) {
          const double a = first_minimum_of_quartic(c0, c1, c2, c3);
          if (a > 0.0 && std::isfinite(a) && std::abs(a - 1.0) > 1e-12) {
            alpha = a;
            ++st.line_searches;
          }
        }
      }
      double dq = 0.0, qn = 0.0;
      if (alpha == 1.0) {
        q1.swap(qt);
        g1.swap(gt);
        G.swap(Gt);
        g_end.swap(g_trial);
        for (std::size_t i = 0; i < r; ++i) dq = std::max(dq, std::abs(w[i]));
      } else {
        for (std::size_t i = 0; i < r; ++i) {
          q1[i] -= alpha * w[i];
          dq = std::max(dq, std::abs(alpha * w[i]));
        }
        evaluate(q1.data(), g1.data(), G.data(), g_end.data());
      }
      for (std::size_t i = 0; i < r; ++i) qn = std::max(qn, std::abs(q1[i]));
      // Round-off floor: a correction at the last bits of q means R cannot fall further. With
      // stiff constraint modes the cubic force's sums cancel (|g~| 10^3 times the net internal
      // force on the 60k blade), and ||R|| stalls above the tolerance with corrections of 10^-9 |q|
      // in random directions. A full Newton step of at most 10^-8 |q| after one of at most
      // 10^-4 |q| is the quadratic phase: the error left is about the square of the correction,
      // so the step is converged as far as the arithmetic allows: R is evaluated once more, and
      // if it still misses the tolerance the step ends there (counted, reported).
      const double rel = qn > 0.0 ? dq / qn : 0.0;
      if (it > 0 && rel <= 1e-13) break;
      // Evaluate R once more at the corrected q1: it either meets the tolerance or is the floor.
      if (it > 0 && alpha == 1.0 && rel <= 1e-8 && previous_rel <= 1e-4) at_floor = true;
      previous_rel = rel;
    }
    for (std::size_t i = 0; i < r; ++i) v1[i] = 2.0 * (q1[i] - q0[i]) / h - v0[i];
    if (estimate) {
      q_max = std::max(q_max, m_norm(q1));
      if (n >= 3) {
        for (std::size_t i = 0; i < r; ++i) e[i] = (q1[i] - (3.0 * q0[i] - 3.0 * qm1[i] + qm2[i])) / 12.0;
        const double en = m_norm(e);
        e_sum += en;
        e_sq += en * en;
        ++n_estimates;
        if (en > st.error_local_max) st.error_local_max = en, st.error_time = t1;
      }
      qm2.swap(qm1);
      qm1 = q0;
    }
    std::swap(q0, q1);
    std::swap(v0, v1);
    std::swap(g0, g_end);
    std::swap(f0, f1);
    ss.step = n;
    ss.t = t1;
    ss.q = q0.data();
    ss.v = v0.data();
    callback(ss);
    ++st.steps;
  }
  if (estimate && n_estimates > 0) {
    st.error_estimated = true;
    st.error_q_max = q_max;
    st.error_local_rms = std::sqrt(e_sq / static_cast<double>(n_estimates));
    st.error_sum = e_sum;
  }
  st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return st;
}

}  // namespace morse::sim
