// Explicit central differences on reduced models (see morse/sim/sim.hpp).
#include <petscsys.h>
#include <petscblaslapack.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>

#include "morse/core/error.hpp"
#include "morse/eigen/eigen.hpp"
#include "morse/sim/sim.hpp"
#include "sim/contact.hpp"
#include "sim/massless.hpp"

namespace morse::sim {

namespace {

std::vector<double> matmul(const std::vector<double>& A, const std::vector<double>& B, std::size_t r) {
  std::vector<double> C(r * r, 0.0);
  for (std::size_t i = 0; i < r; ++i)
    for (std::size_t k = 0; k < r; ++k) {
      const double a = A[i * r + k];
      for (std::size_t j = 0; j < r; ++j) C[i * r + j] += a * B[k * r + j];
    }
  return C;
}

}  // namespace

namespace detail {

std::vector<double> inverse(std::vector<double> A, std::size_t n, const char* what) {
  PetscBLASInt nn = static_cast<PetscBLASInt>(n), info = 0, lwork = static_cast<PetscBLASInt>(n * 64);
  std::vector<PetscBLASInt> piv(n);
  std::vector<double> work(static_cast<std::size_t>(lwork));
  LAPACKgetrf_(&nn, &nn, A.data(), &nn, piv.data(), &info);
  MORSE_CHECK(info == 0, what, " (LAPACK getrf info ", info, ")");
  LAPACKgetri_(&nn, A.data(), &nn, piv.data(), work.data(), &lwork, &info);
  MORSE_CHECK(info == 0, what, " (LAPACK getri info ", info, ")");
  return A;  // the inverse of the transpose of a row-major matrix, transposed: the inverse
}

void step_operators(const nlrom::ReducedModel& m, double h, std::vector<double>* P1, std::vector<double>* P2,
                    std::vector<double>* P3) {
  const std::size_t r = static_cast<std::size_t>(m.r);
  std::vector<double> D(r * r);
  for (std::size_t i = 0; i < r * r; ++i) D[i] = 2.0 * m.M[i] + h * m.C[i];
  D = inverse(D, r, "simulate: singular reduced matrix");
  std::vector<double> T1(r * r), T2(r * r);
  for (std::size_t i = 0; i < r * r; ++i) {
    T1[i] = 4.0 * m.M[i] - 2.0 * h * h * m.K[i];
    T2[i] = h * m.C[i] - 2.0 * m.M[i];
  }
  *P1 = matmul(D, T1, r), *P2 = matmul(D, T2, r);
  *P3 = D;
  for (double& x : *P3) x *= 2.0 * h * h;
}

void previous_state(const nlrom::ReducedModel& m, double h, bool nonlinear, const std::vector<double>& f0,
                    const std::vector<double>& q, const std::vector<double>& v, std::vector<double>* qm) {
  // a0 = M^-1 (f(0) - K q0 - C v0 - g(q0)); q_{-1} = q0 - h v0 + h^2/2 a0.
  const std::size_t r = static_cast<std::size_t>(m.r);
  std::vector<double> rhs(f0), g(r, 0.0);
  if (nonlinear) m.g.evaluate(q.data(), g.data());
  for (std::size_t i = 0; i < r; ++i) {
    double x = rhs[i] - g[i];
    for (std::size_t j = 0; j < r; ++j) x -= m.K[i * r + j] * q[j] + m.C[i * r + j] * v[j];
    rhs[i] = x;
  }
  auto Minv = inverse(m.M, r, "simulate: singular reduced matrix");
  qm->assign(r, 0.0);
  for (std::size_t i = 0; i < r; ++i) {
    double a = 0.0;
    for (std::size_t j = 0; j < r; ++j) a += Minv[i * r + j] * rhs[j];
    (*qm)[i] = q[i] - h * v[i] + 0.5 * h * h * a;
  }
}

}  // namespace detail

void initial_state(const Settings& s, std::size_t r, std::vector<double>* q, std::vector<double>* v) {
  MORSE_CHECK(s.q0.empty() || s.q0.size() == r, "simulate: initial q has ", s.q0.size(), " entries, not ", r);
  MORSE_CHECK(s.v0.empty() || s.v0.size() == r, "simulate: initial v has ", s.v0.size(), " entries, not ", r);
  *q = s.q0.empty() ? std::vector<double>(r, 0.0) : s.q0;
  *v = s.v0.empty() ? std::vector<double>(r, 0.0) : s.v0;
}

double energy(const nlrom::ReducedModel& m, const double* q, const double* v) {
  const std::size_t r = static_cast<std::size_t>(m.r);
  double e = 0.0;
  for (std::size_t i = 0; i < r; ++i)
    for (std::size_t j = 0; j < r; ++j) e += 0.5 * (v[i] * m.M[i * r + j] * v[j] + q[i] * m.K[i * r + j] * q[j]);
  return e;
}

double StepState::energy() const { return sim::energy(*model, q, v); }

double critical_step(const nlrom::ReducedModel& m, const ContactSettings* c) {
  if (!m.massless) return critical_step(m);
  const std::size_t ns = static_cast<std::size_t>(m.n_static), nc = c ? c->nodes.size() : 0;
  if (nc == 0) return 2.0 / std::sqrt(std::max(nlrom::free_eigenvalues(m).back(), 1e-300));
  detail::check_contact_on_boundary(m, *c);
  const auto normal = contact_normals(*c);
  std::vector<double> H(ns * nc, 0.0);
  for (std::size_t k = 0; k < nc; ++k)
    for (int d = 0; d < 3; ++d) H[(c->nodes[k].dof + d) * nc + k] = normal[3 * k + d];
  return nlrom::massless_critical_step(m, H, nc);
}

double critical_step(const nlrom::ReducedModel& m) {
  if (m.massless) return nlrom::massless_critical_step(m);
  const auto w = eigen::dense_eigenvalues(static_cast<int>(m.r), m.K, m.M, nullptr);
  return 2.0 / std::sqrt(std::max(w.back(), 1e-300));
}

TangentStep tangent_step(const nlrom::ReducedModel& m, const double* q) {
  MORSE_CHECK(!m.massless, "simulate: the tangent critical step is defined for mass-carrying models only");
  const std::size_t r = static_cast<std::size_t>(m.r);
  std::vector<double> J(m.K);
  if (q && m.g.r == r) {
    std::vector<double> D(r * r);
    m.g.jacobian(q, D.data());
    for (std::size_t p = 0; p < r; ++p)
      for (std::size_t c = 0; c < r; ++c) J[p * r + c] += 0.5 * (D[p * r + c] + D[c * r + p]);
  }
  TangentStep ts;
  for (double x : J)
    if (!std::isfinite(x)) {  // a state so large that the tangent overflows: no stable step
      ts.dt = 0.0;
      ts.omega2_max = std::numeric_limits<double>::infinity();
      return ts;
    }
  const auto w = eigen::dense_eigenvalues(static_cast<int>(r), J, m.M, nullptr);
  ts.omega2_min = w.front();
  ts.omega2_max = w.back();
  for (double x : w) ts.negative += x < 0.0 ? 1 : 0;
  if (ts.omega2_max > 0.0) ts.dt = 2.0 / std::sqrt(ts.omega2_max);
  return ts;
}

namespace {
// Lexicographic numbering of sorted index tuples: the triples i <= j <= k start at off2[i r + j]
// (k = j.. r-1 follow), the quadruples i <= j <= k <= l at off3[(i r + j) r + k] (l = k.. r-1).
struct SortedIndex {
  std::size_t r;
  std::vector<std::size_t> off2, off3;
  std::size_t n3 = 0, n4 = 0;
  explicit SortedIndex(std::size_t r_) : r(r_), off2(r_ * r_, 0), off3(r_ * r_ * r_, 0) {
    for (std::size_t i = 0; i < r; ++i)
      for (std::size_t j = i; j < r; ++j) {
        off2[i * r + j] = n3;
        n3 += r - j;
        for (std::size_t k = j; k < r; ++k) {
          off3[(i * r + j) * r + k] = n4;
          n4 += r - k;
        }
      }
  }
  // The number of the sorted tuple of t (sorted, 2 or 3 indices) and one more index p, found by
  // insertion: the kernel's set-up asks for it for every coefficient estimate, 6.7 million at r = 79.
  std::size_t at3_sorted(const std::size_t* t, std::size_t p) const {
    if (p <= t[0]) return off2[p * r + t[0]] + (t[1] - t[0]);
    if (p <= t[1]) return off2[t[0] * r + p] + (t[1] - p);
    return off2[t[0] * r + t[1]] + (p - t[1]);
  }
  std::size_t at4_sorted(const std::size_t* t, std::size_t p) const {
    if (p <= t[0]) return off3[(p * r + t[0]) * r + t[1]] + (t[2] - t[1]);
    if (p <= t[1]) return off3[(t[0] * r + p) * r + t[1]] + (t[2] - t[1]);
    if (p <= t[2]) return off3[(t[0] * r + t[1]) * r + p] + (t[2] - p);
    return off3[(t[0] * r + t[1]) * r + t[2]] + (p - t[2]);
  }
};

// Coefficients c (sorted tuples) of the potential whose gradient has the coefficients C: row m of
// C (a sorted tuple T of size n - 1) and output p give c[sort(T, p)] = C(m, p) / (times p occurs
// in (T, p)). Each c has up to n estimates; returns their mean and sets *dev to the largest
// distance of an estimate from it.
template <class RowTuples, class At>
std::vector<double> potential_of(const std::vector<double>& C, std::size_t r, std::size_t n_out, RowTuples rows, At at,
                                 double* dev) {
  // Two passes over the estimates (mean, then spread) instead of storing them: they number
  // n_cubic(r) r, 54 MB at r = 79.
  std::vector<double> sum(n_out, 0.0);
  std::vector<int> count(n_out, 0);
  auto each_estimate = [&](auto&& f) {
    rows([&](std::size_t m, const std::size_t* t, int nt) {
      for (std::size_t p = 0; p < r; ++p) {
        int mult = 1;
        for (int a = 0; a < nt; ++a) mult += t[a] == p;
        f(at(t, p), C[m * r + p] / mult);
      }
    });
  };
  each_estimate([&](std::size_t c, double e) { sum[c] += e, ++count[c]; });
  for (std::size_t c = 0; c < n_out; ++c) sum[c] /= std::max(count[c], 1);
  *dev = 0.0;
  each_estimate([&](std::size_t c, double e) { *dev = std::max(*dev, std::abs(e - sum[c])); });
  return sum;
}
}  // namespace

CubicKernel::CubicKernel(const nlrom::CubicForce& g, const std::vector<double>& P3, KernelLayout layout) : r_(g.r) {
  const std::size_t n2 = nlrom::n_quadratic(r_), n3 = nlrom::n_cubic(r_);
  n_ = n2 + n3;
  if (layout != KernelLayout::Folded) {
    const SortedIndex ix(r_);
    double dev3 = 0.0, dev4 = 0.0;
    c3_ = potential_of(
        g.A, r_, ix.n3,
        [&](auto f) {
          std::size_t m = 0, t[2];
          for (t[0] = 0; t[0] < r_; ++t[0])
            for (t[1] = t[0]; t[1] < r_; ++t[1]) f(m++, t, 2);
        },
        [&](const std::size_t* t, std::size_t p) { return ix.at3_sorted(t, p); }, &dev3);
    c4_ = potential_of(
        g.B, r_, ix.n4,
        [&](auto f) {
          std::size_t m = 0, t[3];
          for (t[0] = 0; t[0] < r_; ++t[0])
            for (t[1] = t[0]; t[1] < r_; ++t[1])
              for (t[2] = t[1]; t[2] < r_; ++t[2]) f(m++, t, 3);
        },
        [&](const std::size_t* t, std::size_t p) { return ix.at4_sorted(t, p); }, &dev4);
    asymmetry_ = std::max(dev3 / std::max(g.max_abs_A(), 1e-300), dev4 / std::max(g.max_abs_B(), 1e-300));
    if (g.max_abs_A() == 0.0 && g.max_abs_B() == 0.0) asymmetry_ = 0.0;
    MORSE_CHECK(layout != KernelLayout::Potential || asymmetry_ <= 1e-6,
                "simulate: the reduced nonlinear force is not the gradient of a potential (relative asymmetry ",
                asymmetry_, " > 1e-6; POD-filtered forces are not): use the folded kernel");
    const double folded_bytes = 8.0 * static_cast<double>(n_) * static_cast<double>(r_);
    potential_ = asymmetry_ <= 1e-6 && (layout == KernelLayout::Potential || folded_bytes > 12e6);
  }
  if (potential_) {
    P3_ = P3;
    z_.assign(r_, 0.0);
    return;
  }
  c3_.clear(), c4_.clear();
  W_.assign(n_ * r_, 0.0);
  z_.assign(n_, 0.0);
  // W(m, p) = sum_k P3(p, k) coef(m, k)
  auto fold = [&](const std::vector<double>& C, std::size_t rows, std::size_t off) {
    for (std::size_t m = 0; m < rows; ++m)
      for (std::size_t p = 0; p < r_; ++p) {
        double v = 0.0;
        for (std::size_t k = 0; k < r_; ++k) v += P3[p * r_ + k] * C[m * r_ + k];
        W_[(off + m) * r_ + p] = v;
      }
  };
  fold(g.A, n2, 0);
  fold(g.B, n3, n2);
}

namespace detail {
MORSE_KERNEL_CLONES
void panel_product(std::size_t n_panels, std::size_t n_cols, std::size_t split, const double* __restrict x,
                   const double* __restrict H, double* __restrict y1, double* __restrict y2) {
  // One panel of kPanel = 16 rows at a time, its accumulators held in four 4-lane registers over
  // all columns (GCC vector extension: AVX2 in the x86-64-v3 clone, SSE pairs in the baseline).
  static_assert(kPanel == 16, "panel_product holds 16 rows in four 4-lane accumulators");
  typedef double v4 __attribute__((vector_size(32), aligned(8)));
  for (std::size_t b = 0; b < n_panels; ++b) {
    const double* __restrict h = H + b * n_cols * kPanel;
    double* out = y1;
    std::size_t c = 0;
    for (std::size_t end : {split, n_cols}) {
      v4 a0 = {0, 0, 0, 0}, a1 = a0, a2 = a0, a3 = a0;
      for (; c < end; ++c, h += kPanel) {
        const v4 xc = {x[c], x[c], x[c], x[c]};
        a0 += xc * *reinterpret_cast<const v4*>(h);
        a1 += xc * *reinterpret_cast<const v4*>(h + 4);
        a2 += xc * *reinterpret_cast<const v4*>(h + 8);
        a3 += xc * *reinterpret_cast<const v4*>(h + 12);
      }
      double* o = out + b * kPanel;
      *reinterpret_cast<v4*>(o) = a0;
      *reinterpret_cast<v4*>(o + 4) = a1;
      *reinterpret_cast<v4*>(o + 8) = a2;
      *reinterpret_cast<v4*>(o + 12) = a3;
      out = y2;
    }
  }
}

MORSE_KERNEL_CLONES
void sym_panel_product(std::size_t n_panels, const double* __restrict S, const double* __restrict x,
                       double* __restrict y) {
  // Panel b holds the blocks (b, b'), b' >= b, of the upper block triangle; column j of a block is
  // 16 contiguous rows. A diagonal block is stored whole and applied as is. An off-diagonal block
  // is applied twice from one load: y(I_b) += S(I_b, c) x_c (accumulated in registers) and
  // y_c += S(I_b, c) . x(I_b) (its transpose). Half the bytes of the full product.
  static_assert(kPanel == 16, "sym_panel_product holds 16 rows in four 4-lane accumulators");
  typedef double v4 __attribute__((vector_size(32), aligned(8)));
  for (std::size_t i = 0; i < n_panels * kPanel; ++i) y[i] = 0.0;
  const double* __restrict s = S;
  for (std::size_t b = 0; b < n_panels; ++b) {
    const double* xb = x + b * kPanel;
    const v4 x0 = *reinterpret_cast<const v4*>(xb), x1 = *reinterpret_cast<const v4*>(xb + 4),
             x2 = *reinterpret_cast<const v4*>(xb + 8), x3 = *reinterpret_cast<const v4*>(xb + 12);
    v4 a0 = {0, 0, 0, 0}, a1 = a0, a2 = a0, a3 = a0;
    for (std::size_t j = 0; j < kPanel; ++j, s += kPanel) {
      const double xc = xb[j];
      const v4 xv = {xc, xc, xc, xc};
      a0 += xv * *reinterpret_cast<const v4*>(s);
      a1 += xv * *reinterpret_cast<const v4*>(s + 4);
      a2 += xv * *reinterpret_cast<const v4*>(s + 8);
      a3 += xv * *reinterpret_cast<const v4*>(s + 12);
    }
    // Off-diagonal blocks, four columns at a time: their four transposed dot products are
    // reduced together (a 4 x 4 transpose of partial sums) into one store.
    for (std::size_t c = (b + 1) * kPanel; c < n_panels * kPanel; c += 4) {
      v4 d[4];
      for (int j = 0; j < 4; ++j, s += kPanel) {
        const double xc = x[c + j];
        const v4 xv = {xc, xc, xc, xc};
        const v4 t0 = *reinterpret_cast<const v4*>(s), t1 = *reinterpret_cast<const v4*>(s + 4),
                 t2 = *reinterpret_cast<const v4*>(s + 8), t3 = *reinterpret_cast<const v4*>(s + 12);
        a0 += xv * t0;
        a1 += xv * t1;
        a2 += xv * t2;
        a3 += xv * t3;
        d[j] = t3 * x3 + (t2 * x2 + (t1 * x1 + t0 * x0));  // one product, three FMAs
      }
      typedef long long m4 __attribute__((vector_size(32)));
      const v4 e0 = __builtin_shuffle(d[0], d[1], m4{0, 4, 2, 6}) + __builtin_shuffle(d[0], d[1], m4{1, 5, 3, 7});
      const v4 e1 = __builtin_shuffle(d[2], d[3], m4{0, 4, 2, 6}) + __builtin_shuffle(d[2], d[3], m4{1, 5, 3, 7});
      *reinterpret_cast<v4*>(y + c) +=
          __builtin_shuffle(e0, e1, m4{0, 1, 4, 5}) + __builtin_shuffle(e0, e1, m4{2, 3, 6, 7});
    }
    double* yb = y + b * kPanel;
    *reinterpret_cast<v4*>(yb) += a0;
    *reinterpret_cast<v4*>(yb + 4) += a1;
    *reinterpret_cast<v4*>(yb + 8) += a2;
    *reinterpret_cast<v4*>(yb + 12) += a3;
  }
}

void quadratic_monomials(std::size_t r, const double* __restrict q, double* __restrict z) {
  for (std::size_t i = 0; i < r; ++i)
    for (std::size_t j = i; j < r; ++j) *z++ = q[i] * q[j];
}
}  // namespace detail

namespace {
MORSE_KERNEL_CLONES
void monomials_and_product(std::size_t r, std::size_t n, const double* __restrict q, double* __restrict z,
                           const double* __restrict W, double* __restrict y) {
  // Monomials: all q_i q_j (i <= j), then all q_i q_j q_k (i <= j <= k), both lexicographic.
  detail::quadratic_monomials(r, q, z);
  double* z3 = z + r * (r + 1) / 2;
  const double* qq = z;
  for (std::size_t i = 0; i < r; ++i) {
    for (std::size_t j = i; j < r; ++j) {
      const double a = qq[j - i];
      for (std::size_t k = j; k < r; ++k) *z3++ = a * q[k];
    }
    qq += r - i;
  }
  for (std::size_t p = 0; p < r; ++p) y[p] = 0.0;
  // Four rows per pass: one load and one store of y per four FMAs.
  std::size_t m = 0;
  for (; m + 4 <= n; m += 4) {
    const double c0 = z[m], c1 = z[m + 1], c2 = z[m + 2], c3 = z[m + 3];
    const double* __restrict w0 = W + m * r;
    const double* __restrict w1 = w0 + r;
    const double* __restrict w2 = w1 + r;
    const double* __restrict w3 = w2 + r;
    for (std::size_t p = 0; p < r; ++p) y[p] += c0 * w0[p] + c1 * w1[p] + c2 * w2[p] + c3 * w3[p];
  }
  for (; m < n; ++m) {
    const double c = z[m];
    const double* __restrict w = W + m * r;
    for (std::size_t p = 0; p < r; ++p) y[p] += c * w[p];
  }
}
}  // namespace

void CubicKernel::apply(const double* q, double* y) const {
  if (!potential_) {
    monomials_and_product(r_, n_, q, z_.data(), W_.data(), y);
    return;
  }
  detail::potential_force_lane(r_, q, c3_.data(), c4_.data(), P3_.data(), z_.data(), y);
}

double CubicKernel::flops() const {
  const double r = static_cast<double>(r_);
  if (potential_) return 4.0 * static_cast<double>(c3_.size() + c4_.size()) + 2.0 * r * r;
  return 2.0 * static_cast<double>(n_) * r + static_cast<double>(n_);
}

double CubicKernel::bytes() const {
  if (potential_) return 8.0 * static_cast<double>(c3_.size() + c4_.size() + P3_.size());
  return 8.0 * static_cast<double>(W_.size());
}

Stats integrate(const nlrom::ReducedModel& m, const std::vector<ReducedLoad>& loads, const Settings& s,
                const std::function<void(const StepState&)>& callback) {
  if (s.scheme != Scheme::Central) {
    MORSE_CHECK(!m.massless,
                "simulate: the implicit schemes (-sim_scheme trapezoidal, energy) do not take a massless-boundary "
                "model; use -sim_scheme central (its step is set by the internal modes)");
    return integrate_trapezoidal(m, loads, s, callback);
  }
  const std::size_t r = static_cast<std::size_t>(m.r);
  const double h = s.dt;
  MORSE_CHECK(h > 0 && std::isfinite(h), "simulate: the time step -sim_dt must be positive (got ", h, ")");
  MORSE_CHECK(s.t_final > 0 && std::isfinite(s.t_final), "simulate: -sim_tfinal must be positive (got ", s.t_final,
              ")");
  Stats st;
  st.critical_dt = critical_step(m, &s.contact);
  if (m.massless)
    MORSE_CHECK(
        h <= st.critical_dt, "simulate: -sim_dt ", h,
        " s is above the critical step of central differences on the massless model, ", st.critical_dt,
        " s (2 / omega_max of its dynamic modes with the contact normals held); use -sim_dt <= ", st.critical_dt);
  else
    MORSE_CHECK(h <= st.critical_dt, "simulate: -sim_dt ", h, " s is above the critical step of central differences, ",
                st.critical_dt, " s (2 / omega_max of the reduced model); use -sim_dt <= ", st.critical_dt);
  for (const auto& l : loads)
    MORSE_CHECK(l.p.size() == r, "simulate: a reduced load has ", l.p.size(), " entries, not ", r);
  std::vector<double> P1, P2, P3;
  if (m.massless)
    detail::massless_step_operators(m, h, &P1, &P2, &P3);
  else
    detail::step_operators(m, h, &P1, &P2, &P3);
  std::vector<std::vector<double>> lp;  // P3 p_l
  for (const auto& l : loads) {
    std::vector<double> y(r, 0.0);
    for (std::size_t i = 0; i < r; ++i)
      for (std::size_t j = 0; j < r; ++j) y[i] += P3[i * r + j] * l.p[j];
    lp.push_back(std::move(y));
  }
  const bool nonlinear = !s.linear;
  MORSE_CHECK(s.linear || m.g.r == r, "simulate: the reduced model has no nonlinear force of size ", r,
              " (a linear model, -nlrom_forces none): run it with -sim_linear");
  std::optional<CubicKernel> kernel;  // folded only when used
  if (nonlinear) {
    kernel.emplace(m.g, P3, s.kernel);
    st.kernel = kernel->potential() ? "potential" : "folded";
    st.kernel_flops = kernel->flops();
    st.kernel_bytes = kernel->bytes();
  }
  if (m.massless) {
    detail::integrate_massless(m, loads, s, P1, P2, lp, kernel ? &*kernel : nullptr, callback, &st);
    return st;
  }

  std::vector<double> qm(r), q, v;
  initial_state(s, r, &q, &v);
  {
    std::vector<double> f0(r, 0.0);
    for (const auto& l : loads)
      for (std::size_t i = 0; i < r; ++i) f0[i] += l.factor(0.0) * l.p[i];
    detail::previous_state(m, h, nonlinear, f0, q, v, &qm);
  }
  // Contact: P = (M/h^2 + C/2h)^-1 = P3.
  std::optional<detail::ContactSolver> contact;
  detail::Corrector corr;
  if (!s.contact.nodes.empty()) {
    contact.emplace(s.contact, P3, r, s.t_final);
    const std::size_t nc = s.contact.nodes.size();
    corr.nodes = nc;
    corr.correct = [&](double* qp, const double* qmm, double t) { contact->correct(qp, qmm, h, t); };
    corr.normal = [&] { return contact->normal(); };
    corr.friction = [&] { return contact->friction(); };
    corr.gap = [&] { return contact->gap(); };
    corr.active = [&] { return contact->active(); };
    corr.gap0.assign(nc, 0.0);
    for (std::size_t k = 0; k < nc; ++k) corr.gap0[k] = contact->gap_of(k, q.data(), 0.0);
    corr.contact = &s.contact;
  }
  detail::central_loop(m, loads, s, P1, P2, lp, kernel ? &*kernel : nullptr, corr, std::move(q), std::move(qm),
                       std::move(v), callback, &st);
  return st;
}

namespace detail {

void central_loop(const nlrom::ReducedModel& m, const std::vector<ReducedLoad>& loads, const Settings& s,
                  const std::vector<double>& P1, const std::vector<double>& P2,
                  const std::vector<std::vector<double>>& lp, const CubicKernel* kernel, const Corrector& corr,
                  std::vector<double> q, std::vector<double> qm, std::vector<double> v,
                  const std::function<void(const StepState&)>& callback, Stats* st) {
  const std::size_t r = static_cast<std::size_t>(m.r), nc = corr.nodes;
  const double h = s.dt;
  std::vector<double> qp(r), g(r);
  const long n_steps = step_count(s.t_final, h);
  // The forces of state n are reported with state n, one step after they are computed, so they
  // are kept one step; those of the initial state are the corrector's gap0 (and its forces, if any).
  std::vector<double> c_lam(nc, 0.0), c_fric(3 * nc, 0.0), c_gap(nc, 0.0);
  if (corr.gap0.size() == nc) c_gap = corr.gap0;
  int c_active = 0;
  if (nc && corr.initial_forces) {
    std::copy(corr.normal(), corr.normal() + nc, c_lam.begin());
    std::copy(corr.friction(), corr.friction() + 3 * nc, c_fric.begin());
    std::copy(corr.gap(), corr.gap() + nc, c_gap.begin());
    c_active = corr.active();
  }
  EnergyLedger ledger(m, corr.contact, h);
  StepState ss;
  ss.model = &m;
  ss.q = q.data();
  ss.v = v.data();
  ss.active = c_active;
  ss.work = s.energy_balance ? &ledger.work() : nullptr;
  ss.energy_qa = qm.data(), ss.energy_qb = q.data();  // E_{-1/2}
  ss.dt = h;
  ss.nonlinear = kernel != nullptr;
  if (nc) ss.contact_normal = c_lam.data(), ss.contact_friction = c_fric.data(), ss.gap = c_gap.data();
  callback(ss);
  // Tangent checks (Settings::tangent_checks) at steps 0, every, 2 every, ...
  const bool check_tangent = kernel && !m.massless && s.tangent_checks > 0;
  const long check_every = check_tangent ? tangent_check_every(n_steps, s.tangent_checks) : 0;
  // What a divergence message says about the step.
  auto divergence_note = [&]() -> std::string {
    if (!kernel || m.massless) return ": reduce -sim_dt";
    std::string note;
    if (!st->tangent.empty()) {
      const auto& last = st->tangent.back();
      note =
          cat(". The tangent critical step 2/omega_max(K~ + dg~/dq, M~) was ", last.dt,
              " s at the last check (t = ", last.t, " s, ", last.negative, " negative tangent eigenvalues), at least ",
              st->tangent_dt_min, " s over the ", st->tangent.size(), " checks (t = ", st->tangent_dt_min_time, " s)");
    } else if (!check_tangent) {
      note = " (no tangent checks: -sim_tangent_checks 0)";
    }
    return cat(note, ". -sim_dt is ", h,
               " s: reduce it below the tangent critical step (the nonlinear model stiffens with the amplitude)");
  };
  const auto t0 = std::chrono::steady_clock::now();
  // Step n: from (q_{n-1}, q_n) to q_{n+1}; v_n is known after it, so the callback for state n
  // runs one step late (the last state's velocity uses one extra step).
  for (long n = 0; n <= n_steps; ++n) {
    const double t = static_cast<double>(n) * h;
    if (check_tangent && n % check_every == 0) {
      const auto ts = tangent_step(m, q.data());
      st->tangent.push_back({t, ts.dt, ts.negative});
      if (ts.dt < st->tangent_dt_min) st->tangent_dt_min = ts.dt, st->tangent_dt_min_time = t;
      if (ts.negative > 0) ++st->tangent_negative_checks;
    }
    for (std::size_t i = 0; i < r; ++i) {
      double x = 0.0;
      const double* p1 = &P1[i * r];
      const double* p2 = &P2[i * r];
      for (std::size_t j = 0; j < r; ++j) x += p1[j] * q[j] + p2[j] * qm[j];
      qp[i] = x;
    }
    for (std::size_t l = 0; l < loads.size(); ++l) {
      const double c = loads[l].factor(t);
      for (std::size_t i = 0; i < r; ++i) qp[i] += c * lp[l][i];
    }
    if (kernel) {
      kernel->apply(q.data(), g.data());
      for (std::size_t i = 0; i < r; ++i) qp[i] -= g[i];
    }
    if (corr.correct) corr.correct(qp.data(), qm.data(), t + h);
    bool finite = true;
    for (std::size_t i = 0; i < r; ++i) finite = finite && std::isfinite(qp[i]);
    if (!finite)
      throw Error(cat("simulate: NaN or infinite state at t = ", t + h, " (step ", n + 1, "); last finite time ", t,
                      divergence_note()));
    if (s.divergence_limit > 0)  // a contact node's coordinates are its displacement (q[dof..dof+2])
      for (const auto& node : s.contact.nodes) {
        const double* u = &qp[node.dof];
        const double a = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
        if (a > s.divergence_limit)
          throw Error(cat("simulate: diverged at t = ", t + h, " (step ", n + 1, "): the contact node at (", node.x[0],
                          ", ", node.x[1], ", ", node.x[2], ") is displaced by ", a, ", above the limit ",
                          s.divergence_limit,
                          " (-sim_divergence_limit; default: the largest radius of the contact "
                          "nodes)",
                          kernel && !m.massless ? divergence_note() : std::string()));
      }
    if (s.energy_balance) {
      // The contact forces of step n: the equilibrium's of state n (massless), or the correction's.
      const double* lam = !nc ? nullptr : corr.forces_of_state ? c_lam.data() : corr.normal();
      const double* fric = !nc ? nullptr : corr.forces_of_state ? c_fric.data() : corr.friction();
      ledger.add(qm.data(), qp.data(), loads, t, lam, fric);
    }
    if (n > 0) {  // state n with its central velocity
      for (std::size_t i = 0; i < r; ++i) v[i] = (qp[i] - qm[i]) / (2.0 * h);
      ss.q = q.data();
      ss.v = v.data();
      ss.step = n;
      ss.t = t;
      ss.active = c_active;
      ss.energy_qa = q.data(), ss.energy_qb = qp.data();  // E_{n+1/2}
      callback(ss);
    }
    if (nc) {  // the forces that produced q_{n+1} belong to state n + 1
      std::copy(corr.normal(), corr.normal() + nc, c_lam.begin());
      std::copy(corr.friction(), corr.friction() + 3 * nc, c_fric.begin());
      std::copy(corr.gap(), corr.gap() + nc, c_gap.begin());
      c_active = corr.active();
    }
    std::swap(qm, q);
    std::swap(q, qp);
  }
  st->steps = n_steps;
  st->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace detail

}  // namespace morse::sim
