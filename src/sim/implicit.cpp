// Implicit reduced integration (see morse/sim/sim.hpp, Scheme::Trapezoidal).
//
// The scheme of `morse fom` (src/dyn/fom.cpp) on the reduced model, residual scaled by 2, with
// q0, v0 known and v1 = 2 (q1 - q0)/h - v0:
//   R(q1) = (2/h) M (v1 - v0) + C (v0 + v1) + K (q0 + q1) + g(q0) + g(q1) - (f(t0) + f(t1)),
//   J(q1) = (4/h^2) M + (2/h) C + K + dg/dq(q1),
// solved by Newton with a dense LU of J at every iteration (r x r); g and dg/dq come from one pass of
// TangentKernel. The same convergence test
// as fom, ||R|| <= rtol max(||inertia||, ||internal||, ||load||), or a correction at round-off
// (max|dq| <= 1e-13 max|q|: stiff constraint modes put the floor of ||R|| above small rtol). With a basis that spans
// the whole space this is the full model's discrete solution.
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
}  // namespace

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
      J(r * r), G(r * r), Jlin(r * r);
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
  // when it is not positive definite.
  bool symmetric = !nonlinear || tangent->symmetric();
  {
    double big = 0.0, dev = 0.0;
    for (std::size_t i = 0; i < r; ++i)
      for (std::size_t j = 0; j < r; ++j)
        big = std::max(big, std::abs(Jlin[i * r + j])),
        dev = std::max(dev, std::abs(Jlin[i * r + j] - Jlin[j * r + i]));
    symmetric = symmetric && dev <= 1e-12 * big;
  }
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
  if (nonlinear) tangent->apply(q0.data(), g0.data(), G.data());
  load(0.0, f0);
  StepState ss;
  ss.model = &m;
  ss.q = q0.data();
  ss.v = v0.data();
  callback(ss);
  const long n_steps = detail::step_count(s.t_final, h);
  const auto t_start = std::chrono::steady_clock::now();
  for (long n = 1; n <= n_steps; ++n) {
    const double t0 = (n - 1) * h, t1 = n * h;
    load(t1, f1);
    q1 = q0;  // predictor u1 = u0, as fom
    stacked(q0.data(), mkc.data());
    stacked(v0.data(), Mv0.data());  // only its M part is used
    for (std::size_t i = 0; i < r; ++i) {
      aM[i] = -4.0 / (h * h) * mkc[i] - 4.0 / h * Mv0[i];
      aK[i] = mkc[r + i] + g0[i];
      aC[i] = -2.0 / h * mkc[2 * r + i];
    }
    for (int it = 0;; ++it) {
      // R = inertia + damping + internal - load, with [M; K; C] q1 in one pass and the parts
      // that depend on q0, v0 only (a_*) formed once per step:
      //   inertia = (2/h) M (v1 - v0) = (4/h^2) M q1 + a_M,  a_M = -(4/h^2) M q0 - (4/h) M v0
      //   damping = C (v0 + v1) = (2/h) C q1 + a_C,          a_C = -(2/h) C q0
      //   internal = K (q0 + q1) + g0 + g1 = K q1 + a_K + g1, a_K = K q0 + g0
      stacked(q1.data(), mkc.data());
      double inertia = 0.0;
      for (std::size_t i = 0; i < r; ++i) {
        const double x = 4.0 / (h * h) * mkc[i] + aM[i];
        R[i] = x + 2.0 / h * mkc[2 * r + i] + aC[i];
        internal[i] = mkc[r + i] + aK[i];
        inertia += x * x;
      }
      inertia = std::sqrt(inertia);
      if (nonlinear) {
        // At the predictor q1 = q0, g and the tangent are those of the last evaluation (the
        // converged q0, or its last correction at round-off when Newton stopped on the floor).
        if (it == 0)
          g1 = g0;
        else
          tangent->apply(q1.data(), g1.data(), G.data());  // G is used below only if the step goes on
        for (std::size_t i = 0; i < r; ++i) internal[i] += g1[i];
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
      // J = 4/h^2 M + 2/h C + K + dg/dq(q1); w = J^-1 R.
      for (std::size_t k = 0; k < r * r; ++k) J[k] = Jlin[k] + (nonlinear ? G[k] : 0.0);
      w = R;
      if (!symmetric || !cholesky_solve(r, J.data(), w.data(), col.data())) {
        for (std::size_t k = 0; k < r * r; ++k) J[k] = Jlin[k] + (nonlinear ? G[k] : 0.0);
        w = R;
        MORSE_CHECK(lu_solve(r, J.data(), piv.data(), w.data()), "simulate: singular iteration matrix at t = ", t1);
      }
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
