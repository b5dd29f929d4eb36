// Speed sweeps: batched central differences with contact, spread over ranks (see
// morse/sim/sim.hpp, sweep()).
//
// A rank holds up to `batch` speeds ("lanes"), stored lane-inner: Q[j * L + l] is coordinate j of
// lane l, L a multiple of 4. One pass of the folded cubic tensor W (n x r, row m = monomial m)
// serves every lane: Y(p, l) = sum_m W(m, p) z_m(l), the monomials z_m(l) of each lane computed on
// the fly, four rows of W at a time. Every lane's arithmetic (the order of its sums) is fixed by m
// and p alone, so a speed gives the same bits whichever speeds share its pass.
#include <petscsys.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <complex>
#include <cstring>
#include <deque>
#include <memory>

#include "core/detail/pack.hpp"
#include "morse/core/error.hpp"
#include "morse/core/log.hpp"
#include "morse/sim/sim.hpp"
#include "sim/contact.hpp"
#include "sim/massless.hpp"

// The batched kernels are built for AVX2 without FMA as well as for the baseline (GCC function
// multiversioning, dispatched on the CPU's features). No FMA: a lane's arithmetic is then the same
// (each product and sum rounded) in the vector body and in the scalar remainder, so a speed's
// result does not depend on how many lanes share its pass, bitwise. With FMA contraction the
// vectorized and scalar paths round differently.
#if MORSE_GCC_X86
#define MORSE_BATCH_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define MORSE_BATCH_CLONES
#endif

namespace morse::sim {

std::vector<double> SweepSettings::frequencies() const {
  std::vector<double> f;
  if (spectrum_fmax <= 0 || spectrum_bins <= 0) return f;
  for (int k = 0; k <= spectrum_bins; ++k) f.push_back(spectrum_fmax * k / spectrum_bins);
  return f;
}

namespace {

// x := (x - mean(x)) w, w the Hann window of n points (denominator n - 1); returns sum w.
double hann_demeaned(std::vector<double>& x) {
  const std::size_t n = x.size();
  double mean = 0.0;
  for (double v : x) mean += v;
  mean /= static_cast<double>(n);
  double wsum = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    const double w = 0.5 * (1.0 - std::cos(2.0 * M_PI * static_cast<double>(k) / static_cast<double>(n - 1)));
    x[k] = (x[k] - mean) * w;
    wsum += w;
  }
  return wsum;
}

// In-place radix-2 FFT, X_j = sum_k x_k exp(-2 pi i j k / m), m = z.size() a power of two. The
// twiddles are evaluated directly (std::polar), not by recurrence: the error stays at a few ulps
// times log2 m of the largest |X|.
void fft_pow2(std::vector<std::complex<double>>& z) {
  const std::size_t m = z.size();
  for (std::size_t i = 1, j = 0; i < m; ++i) {  // bit reversal
    std::size_t bit = m >> 1;
    for (; j & bit; bit >>= 1) j ^= bit;
    j ^= bit;
    if (i < j) std::swap(z[i], z[j]);
  }
  std::vector<std::complex<double>> tw(m / 2);
  for (std::size_t k = 0; k < m / 2; ++k)
    tw[k] = std::polar(1.0, -2.0 * M_PI * static_cast<double>(k) / static_cast<double>(m));
  for (std::size_t len = 2; len <= m; len <<= 1) {
    const std::size_t half = len / 2, stride = m / len;
    for (std::size_t i = 0; i < m; i += len)
      for (std::size_t k = 0; k < half; ++k) {
        const std::complex<double> u = z[i + k], v = z[i + k + half] * tw[k * stride];
        z[i + k] = u + v;
        z[i + k + half] = u - v;
      }
  }
}

// The Dirichlet gain of a mean of s samples h apart at f: |sin(s y) / (s sin y)|, y = pi f h.
double block_mean_gain(double f, double h, long s) {
  const double y = M_PI * f * h;
  if (s <= 1 || std::sin(y) == 0.0) return 1.0;
  return std::abs(std::sin(static_cast<double>(s) * y) / (static_cast<double>(s) * std::sin(y)));
}

}  // namespace

std::vector<double> amplitude_spectrum(std::vector<double> x, double dt, const std::vector<double>& f) {
  std::vector<double> a(f.size(), 0.0);
  const std::size_t n = x.size();
  if (n < 2) return a;
  const double wsum = hann_demeaned(x);
  for (std::size_t b = 0; b < f.size(); ++b) {
    const std::complex<double> rot = std::polar(1.0, -2.0 * M_PI * f[b] * dt);
    std::complex<double> z(1.0, 0.0), acc(0.0, 0.0);
    for (std::size_t k = 0; k < n; ++k) {
      acc += x[k] * z;
      z *= rot;
      if ((k & 1023) == 1023) z /= std::abs(z);  // keep the phasor on the unit circle
    }
    a[b] = (f[b] == 0.0 ? 1.0 : 2.0) * std::abs(acc) / wsum;
  }
  return a;
}

std::vector<double> decimated_spectrum(std::vector<double> block_means, double h, long s,
                                       const std::vector<double>& f) {
  const double T = static_cast<double>(s) * h;
  auto a = amplitude_spectrum(std::move(block_means), T, f);
  for (std::size_t b = 0; b < f.size(); ++b) {  // the gain of a mean of s samples (Dirichlet kernel)
    const double g = block_mean_gain(f[b], h, s);
    if (g != 1.0) a[b] /= g;
  }
  return a;
}

long spectrum_block(double fmax, double h) { return std::max(1L, static_cast<long>(1.0 / (2.5 * fmax * h))); }

std::vector<double> binned_spectrum(std::vector<double> block_means, double h, long s, const std::vector<double>& f) {
  const std::size_t nb = f.size(), n = block_means.size();
  std::vector<double> out(nb, 0.0);
  if (nb == 0 || n < 2) return out;
  const double dts = static_cast<double>(s) * h;  // the block means' spacing
  // Bin b spans [lo_b, hi_b] (hi_b = lo_{b+1}); its centre and both edges are evaluated directly,
  // each shared edge once: g = lo_0, f_0, hi_0, f_1, hi_1, ...
  std::vector<double> lo(nb), hi(nb), g;
  for (std::size_t b = 0; b < nb; ++b) {
    lo[b] = b > 0 ? hi[b - 1] : (nb > 1 ? std::max(0.0, f[0] - 0.5 * (f[1] - f[0])) : f[0]);
    hi[b] = b + 1 < nb ? 0.5 * (f[b] + f[b + 1]) : (nb > 1 ? f[b] + 0.5 * (f[b] - f[b - 1]) : f[b]);
    if (b == 0) g.push_back(lo[0]);
    g.push_back(f[b]);
    g.push_back(hi[b]);
  }
  const auto direct = decimated_spectrum(block_means, h, s, g);
  for (std::size_t b = 0; b < nb; ++b) out[b] = std::max({direct[2 * b], direct[2 * b + 1], direct[2 * b + 2]});
  // Between them, the transform on the grid j / (m dts), m >= 4 n a power of two: a spacing of
  // 1 / (4 T) or finer (T = n dts), by one zero-padded FFT (m log m instead of the (f_B / delta) n
  // products of evaluating every point directly). With the edges and centres, the points of a bin
  // are at most 1 / (4 T) apart, so a line anywhere in it is within 1 / (8 T) of one.
  std::size_t m = 1;
  while (m < 4 * n) m <<= 1;
  const double wsum = hann_demeaned(block_means);
  std::vector<std::complex<double>> z(m, {0.0, 0.0});
  for (std::size_t k = 0; k < n; ++k) z[k] = block_means[k];
  fft_pow2(z);
  // The transform of the block means is periodic in f with period 1 / dts (m df): a bin above the
  // block means' Nyquist frequency reads its grid points modulo m, as the direct sum would.
  const double df = 1.0 / (static_cast<double>(m) * dts);
  for (std::size_t b = 0; b < nb; ++b) {
    const auto j0 = static_cast<long long>(std::ceil(lo[b] / df)), j1 = static_cast<long long>(std::floor(hi[b] / df));
    for (long long j = j0; j <= j1; ++j) {
      const double fj = static_cast<double>(j) * df;
      const auto jm = static_cast<std::size_t>(j % static_cast<long long>(m));
      out[b] = std::max(out[b], (fj == 0.0 ? 1.0 : 2.0) * std::abs(z[jm]) / wsum / block_mean_gain(fj, h, s));
    }
  }
  return out;
}

namespace {

constexpr std::size_t kGroup = 4;  // lanes per vector group

// Qp(:, g) = P1 Q(:, g) + P2 Qm(:, g) for the listed groups g.
MORSE_BATCH_CLONES
void batch_linear(std::size_t r, std::size_t L, const std::size_t* groups, std::size_t ng, const double* __restrict P1,
                  const double* __restrict P2, const double* __restrict Q, const double* __restrict Qm,
                  double* __restrict Qp) {
  for (std::size_t i = 0; i < r; ++i) {
    const double* __restrict p1 = P1 + i * r;
    const double* __restrict p2 = P2 + i * r;
    for (std::size_t gi = 0; gi < ng; ++gi) {
      const std::size_t g = groups[gi] * kGroup;
      double a[kGroup] = {0.0, 0.0, 0.0, 0.0};
      for (std::size_t j = 0; j < r; ++j) {
        const double* __restrict qj = Q + j * L + g;
        const double* __restrict mj = Qm + j * L + g;
        for (std::size_t l = 0; l < kGroup; ++l) a[l] += p1[j] * qj[l] + p2[j] * mj[l];
      }
      for (std::size_t l = 0; l < kGroup; ++l) Qp[i * L + g + l] = a[l];
    }
  }
}

// Y(:, g) = W^T z(Q(:, g)), z = [q_i q_j (i <= j); q_i q_j q_k (i <= j <= k)] as in CubicKernel: a
// matrix-matrix product (r x n) (n x L) with W in panels of 4 outputs (Wp[pb][m][4], padded with
// zeros to rp = 4 ceil(r / 4)), blocked by kChunk monomial rows so that the chunk of Z stays in L1
// across the panels. Register block: 4 outputs x 2 groups of 4 lanes. Each output of each lane
// is one sum over m in increasing order, whichever groups share the pass.
constexpr std::size_t kChunk = 256;

template <int NG>
inline __attribute__((always_inline)) void panel_chunk(std::size_t L, const std::size_t* g, const double* __restrict w,
                                                       const double* __restrict Z, std::size_t m0, std::size_t m1,
                                                       double* __restrict Y, std::size_t p0) {
  double acc[4][NG][kGroup];
  for (int k = 0; k < 4; ++k)
    for (int a = 0; a < NG; ++a)
      for (std::size_t l = 0; l < kGroup; ++l) acc[k][a][l] = Y[(p0 + k) * L + g[a] + l];
  for (std::size_t m = m0; m < m1; ++m) {
    const double* __restrict wm = w + 4 * m;
    for (int a = 0; a < NG; ++a) {
      const double* __restrict z = Z + m * L + g[a];
      for (int k = 0; k < 4; ++k)
        for (std::size_t l = 0; l < kGroup; ++l) acc[k][a][l] += wm[k] * z[l];
    }
  }
  for (int k = 0; k < 4; ++k)
    for (int a = 0; a < NG; ++a)
      for (std::size_t l = 0; l < kGroup; ++l) Y[(p0 + k) * L + g[a] + l] = acc[k][a][l];
}

MORSE_BATCH_CLONES
void batch_cubic(std::size_t r, std::size_t L, const std::size_t* groups, std::size_t ng, const double* __restrict Wp,
                 std::size_t n, const double* __restrict Q, double* __restrict Y, double* __restrict Z) {
  const std::size_t rp = (r + 3) / 4 * 4;
  // Monomials of every active lane, in the rows of W: quadratic (i <= j), then cubic (i <= j <= k).
  for (std::size_t gi = 0; gi < ng; ++gi) {
    const std::size_t g = groups[gi] * kGroup;
    double* __restrict z2 = Z + g;
    for (std::size_t i = 0; i < r; ++i)
      for (std::size_t j = i; j < r; ++j, z2 += L)
        for (std::size_t l = 0; l < kGroup; ++l) z2[l] = Q[i * L + g + l] * Q[j * L + g + l];
    const double* qq = Z + g;  // row (i, i) of the quadratic monomials
    double* __restrict z3 = z2;
    for (std::size_t i = 0; i < r; ++i) {
      for (std::size_t j = i; j < r; ++j) {
        const double* a = qq + (j - i) * L;
        for (std::size_t k = j; k < r; ++k, z3 += L)
          for (std::size_t l = 0; l < kGroup; ++l) z3[l] = a[l] * Q[k * L + g + l];
      }
      qq += (r - i) * L;
    }
    for (std::size_t p = 0; p < rp; ++p)
      for (std::size_t l = 0; l < kGroup; ++l) Y[p * L + g + l] = 0.0;
  }
  for (std::size_t gi = 0; gi < ng; gi += 2) {
    const std::size_t g[2] = {groups[gi] * kGroup, gi + 1 < ng ? groups[gi + 1] * kGroup : 0};
    for (std::size_t m0 = 0; m0 < n; m0 += kChunk) {
      const std::size_t m1 = std::min(n, m0 + kChunk);
      for (std::size_t pb = 0; pb < rp / 4; ++pb) {
        const double* w = Wp + pb * 4 * n;
        if (gi + 1 < ng)
          panel_chunk<2>(L, g, w, Z, m0, m1, Y, 4 * pb);
        else
          panel_chunk<1>(L, g, w, Z, m0, m1, Y, 4 * pb);
      }
    }
  }
}

struct Lane {
  bool busy = false;
  SpeedResult res;
  std::unique_ptr<ContactSettings> cs;
  std::unique_ptr<detail::ContactSolver> contact;      // mass-carrying model
  std::unique_ptr<detail::MasslessBoundary> boundary;  // massless model (with its contact, if any)
  bool has_contact() const { return contact || (boundary && boundary->has_contact()); }
  const double* normal() const { return contact ? contact->normal() : boundary->normal(); }
  int active() const { return contact ? contact->active() : boundary->active(); }
  std::unique_ptr<detail::EnergyLedger> ledger;
  std::vector<double> lam_prev, fric_prev;  // massless: the forces of state n (its equilibrium's)
  long n = 0, n_steps = 0, half = 0, sample_every = 1, in_block = 0;
  long check_every = 0;  // tangent checks (Settings::tangent_checks): 0 none
  double last_tangent_dt = 0.0, last_tangent_t = 0.0;
  double sum = 0.0, sum2 = 0.0, block = 0.0;
  long count = 0;
  std::vector<double> samples;
  std::chrono::steady_clock::time_point start;
};

// The lanes of one rank.
class Batch {
 public:
  Batch(const nlrom::ReducedModel& m, const SweepSettings& s) : s_(s), m_(m), r_(static_cast<std::size_t>(m.r)) {
    const std::size_t want = static_cast<std::size_t>(std::max(1, s.batch));
    L_ = (want + kGroup - 1) / kGroup * kGroup;
    if (m.massless) {
      detail::massless_step_operators(m, s.base.dt, &P1_, &P2_, &P3_);
      if (!s.base.linear) {  // shared by the lanes' boundary solves
        raw_ = detail::MasslessBoundary::raw_kernel(m);
        tangent_ = std::make_shared<TangentKernel>(m.g);
      }
    } else {
      detail::step_operators(m, s.base.dt, &P1_, &P2_, &P3_);
    }
    const std::size_t rp = (r_ + 3) / 4 * 4;
    // The kernel: Auto resolves to Potential whenever g~ has a potential (CubicKernel's Auto keeps
    // the folded form for small r, where it is faster lane by lane, not batched), else to Lane. A
    // linear run has none (Lane, no kernel).
    kind_ = s.base.linear ? SweepKernel::Lane : s.kernel;
    if (kind_ == SweepKernel::Auto || kind_ == SweepKernel::Potential) {
      auto k = std::make_unique<CubicKernel>(
          m.g, P3_, kind_ == SweepKernel::Potential ? KernelLayout::Potential : KernelLayout::Auto);
      if (!k->potential() && k->asymmetry() <= 1e-6)
        k = std::make_unique<CubicKernel>(m.g, P3_, KernelLayout::Potential);
      if (k->potential()) {
        potential_ = std::make_unique<CubicKernelBatch>(*k, s.single);
        potential_->set_isa(kernel_isa_or_best(s.isa));
        kind_ = SweepKernel::Potential;
        // A lone busy lane takes the single-speed kernel, which streams the coefficients once for
        // one lane instead of a whole group of four (x1.22 at r = 79, bench/README.md): it gives the lane the
        // bits of the fused builds (CubicKernelBatch), so only with them and double coefficients.
        if (!s.single && potential_->isa() != KernelIsa::Baseline && kernel_isa_supported(KernelIsa::Avx2))
          lone_kernel_ = std::move(k);
      } else {
        lane_kernel_ = std::move(k);
        kind_ = SweepKernel::Lane;
      }
    } else if (kind_ == SweepKernel::Lane && !s.base.linear) {
      lane_kernel_ = std::make_unique<CubicKernel>(m.g, P3_, KernelLayout::Auto);
    } else if (kind_ == SweepKernel::Folded) {
      CubicKernel k(m.g, P3_, KernelLayout::Folded);
      const auto& W = k.folded();
      n_ = W.size() / r_;
      W_.assign(rp * n_, 0.0);  // panels Wp[pb][m][4]
      for (std::size_t m = 0; m < n_; ++m)
        for (std::size_t p = 0; p < r_; ++p) W_[(p / 4) * 4 * n_ + 4 * m + p % 4] = W[m * r_ + p];
      Z_.assign(n_ * L_, 0.0);
    }
    MORSE_CHECK(!s.single || kind_ == SweepKernel::Potential,
                "sweep: float coefficients (-sweep_float) need the potential kernel (-sweep_kernel potential or "
                "auto with a force that is the gradient of a potential)");
    if (lane_kernel_ || lone_kernel_) y_.assign(r_, 0.0);
    Q_.assign(r_ * L_, 0.0), Qm_.assign(r_ * L_, 0.0), Qp_.assign(r_ * L_, 0.0), Y_.assign(rp * L_, 0.0);
    lanes_.resize(want);
    col_.resize(r_), colm_.resize(r_);
    freqs_ = s.frequencies();
  }
  // E_{n+1/2} of the energy balance from q_a = q_n, q_b = q_{n+1}: V from the batched kernel's
  // coefficients when it runs (one pass over them), else from the reference force.
  double energy(const double* qa, const double* qb) const {
    if (potential_ && !s_.base.linear) return discrete_energy(m_, qa, qb, s_.base.dt, *potential_);
    return discrete_energy(m_, qa, qb, s_.base.dt, !s_.base.linear);
  }
  std::size_t free_slots() const {
    std::size_t n = 0;
    for (const auto& l : lanes_) n += !l.busy;
    return n;
  }
  bool any_busy() const { return free_slots() < lanes_.size(); }
  std::size_t busy() const { return lanes_.size() - free_slots(); }

  void start(const SpeedTask& task) {
    std::size_t slot = 0;
    while (lanes_[slot].busy) ++slot;
    Lane& ln = lanes_[slot];
    ln = Lane();
    ln.busy = true;
    ln.start = std::chrono::steady_clock::now();
    ln.res.index = task.index;
    ln.res.omega = task.omega;
    ln.res.halvings = task.halvings;
    const double h = s_.base.dt;
    ln.res.dt = h;
    ln.res.t_final = s_.revolutions * 2.0 * M_PI / std::abs(task.omega);
    ln.n_steps = detail::step_count(ln.res.t_final, h);
    ln.half = (ln.n_steps + 1) / 2;
    if (!freqs_.empty()) ln.sample_every = spectrum_block(s_.spectrum_fmax, h);
    const bool continued = !task.q0.empty();
    MORSE_CHECK(!continued || (task.q0.size() == r_ && task.qm0.size() == r_), "sweep: speed ", task.index,
                " continues from a state of ", task.q0.size(), " and ", task.qm0.size(), " coordinates, not r = ", r_);
    ln.res.from = continued ? task.from : -1;
    ln.res.phase = task.phase;
    if (!s_.base.contact.nodes.empty()) {
      ln.cs = std::make_unique<ContactSettings>(s_.base.contact);
      ln.cs->obstacle = Obstacle::Casing;
      ln.cs->casing.omega = task.omega;
      ln.cs->casing.phase = task.phase;
      ln.cs->casing.grown = continued;
      if (!m_.massless) ln.contact = std::make_unique<detail::ContactSolver>(*ln.cs, P3_, r_, ln.res.t_final);
    }
    if (m_.massless)
      ln.boundary =
          std::make_unique<detail::MasslessBoundary>(m_, ln.cs.get(), ln.res.t_final, !s_.base.linear, raw_, tangent_);
    if (s_.base.energy_balance) ln.ledger = std::make_unique<detail::EnergyLedger>(m_, ln.cs.get(), h);
    if (ln.cs) ln.lam_prev.assign(ln.cs->nodes.size(), 0.0), ln.fric_prev.assign(3 * ln.cs->nodes.size(), 0.0);
    if (continued) {  // q_0, q_{-1}: the final state of speed task.from
      for (std::size_t j = 0; j < r_; ++j) Q_[j * L_ + slot] = task.q0[j], Qm_[j * L_ + slot] = task.qm0[j];
      ln.res.energy_start = energy(task.qm0.data(), task.q0.data());
    } else {  // at rest: q_0 = q_{-1} = 0
      for (std::size_t j = 0; j < r_; ++j) Q_[j * L_ + slot] = Qm_[j * L_ + slot] = 0.0;
    }
    if (!s_.base.linear && !m_.massless && s_.base.tangent_checks > 0) {  // at steps 0, every, 2 every, ...
      ln.check_every = detail::tangent_check_every(ln.n_steps, s_.base.tangent_checks);
      for (std::size_t j = 0; j < r_; ++j) col_[j] = Q_[j * L_ + slot];
      check_tangent(ln, 0.0);
    }
  }

  // One step of every busy lane; finished (or failed) lanes are appended to *done and freed.
  void step(std::vector<SpeedResult>* done, SweepStats* st) {
    groups_.clear();
    for (std::size_t g = 0; g * kGroup < lanes_.size(); ++g) {
      bool busy = false;
      for (std::size_t l = g * kGroup; l < std::min(lanes_.size(), (g + 1) * kGroup); ++l)
        busy = busy || lanes_[l].busy;
      if (busy) groups_.push_back(g);
    }
    const auto t0 = std::chrono::steady_clock::now();
    batch_linear(r_, L_, groups_.data(), groups_.size(), P1_.data(), P2_.data(), Q_.data(), Qm_.data(), Qp_.data());
    if (lane_kernel_) {
      for (std::size_t slot = 0; slot < lanes_.size(); ++slot) {
        if (!lanes_[slot].busy) continue;
        for (std::size_t j = 0; j < r_; ++j) col_[j] = Q_[j * L_ + slot];
        lane_kernel_->apply(col_.data(), y_.data());
        for (std::size_t p = 0; p < r_; ++p) Qp_[p * L_ + slot] -= y_[p];
      }
    } else if (lone_kernel_ && busy() == 1) {
      std::size_t slot = 0;
      while (!lanes_[slot].busy) ++slot;
      for (std::size_t j = 0; j < r_; ++j) col_[j] = Q_[j * L_ + slot];
      lone_kernel_->apply(col_.data(), y_.data());
      for (std::size_t p = 0; p < r_; ++p) Qp_[p * L_ + slot] -= y_[p];
    } else if (!s_.base.linear) {  // a batched kernel: Y for the busy groups
      if (potential_)
        potential_->apply(L_, groups_.data(), groups_.size(), Q_.data(), Y_.data());
      else
        batch_cubic(r_, L_, groups_.data(), groups_.size(), W_.data(), n_, Q_.data(), Y_.data(), Z_.data());
      for (auto g : groups_)
        for (std::size_t p = 0; p < r_; ++p)
          for (std::size_t l = 0; l < kGroup; ++l) Qp_[p * L_ + g * kGroup + l] -= Y_[p * L_ + g * kGroup + l];
    }
    st->kernel_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const double h = s_.base.dt;
    for (std::size_t slot = 0; slot < lanes_.size(); ++slot) {
      Lane& ln = lanes_[slot];
      if (!ln.busy) continue;
      ++st->lane_steps;
      const long n1 = ln.n + 1;  // the state computed now
      const double t = static_cast<double>(n1) * h;
      for (std::size_t j = 0; j < r_; ++j) col_[j] = Qp_[j * L_ + slot], colm_[j] = Qm_[j * L_ + slot];
      bool fail = false;
      double u = 0.0;
      try {
        if (ln.contact) ln.contact->correct(col_.data(), colm_.data(), h, t);
        if (ln.boundary) ln.boundary->solve(col_.data(), colm_.data(), h, t, nullptr);
        for (std::size_t j = 0; j < r_ && !fail; ++j) fail = !std::isfinite(col_[j]);
        if (fail)
          ln.res.error =
              cat("NaN or infinite state at t = ", t, " (step ", n1, "); last finite time ", t - h, tangent_note(ln));
        u = monitored();
        if (!fail && s_.divergence_limit > 0 && std::abs(u) > s_.divergence_limit) {
          fail = true;
          ln.res.error =
              cat("diverged: the monitored displacement is ", u, " m at t = ", t, " (step ", n1, "), above the limit ",
                  s_.divergence_limit, " m (-sweep_divergence_limit)", tangent_note(ln));
        }
      } catch (const std::exception& e) {
        fail = true;
        ln.res.error = message_of(e);
      }
      if (!fail) {
        for (std::size_t j = 0; j < r_; ++j) Qp_[j * L_ + slot] = col_[j];
        if (s_.base.energy_balance) balance(ln, slot, n1);
        record(ln, n1, t, u);
        if (ln.check_every && n1 % ln.check_every == 0) check_tangent(ln, t);  // col_: the state n1
      }
      ln.n = n1;
      if (fail || n1 == ln.n_steps) {
        if (s_.keep_state && !fail) {  // q_N (corrected, in Qp_) and q_{N-1}
          ln.res.q_end.resize(r_), ln.res.qm_end.resize(r_);
          for (std::size_t j = 0; j < r_; ++j)
            ln.res.q_end[j] = Qp_[j * L_ + slot], ln.res.qm_end[j] = Q_[j * L_ + slot];
          if (ln.cs) {  // the lobes' angle at t_N, as gap_of sees it (theta_0 + phase + omega t)
            const double period = 2.0 * M_PI / ln.cs->casing.lobes;
            ln.res.phase_end = std::fmod(ln.res.phase + ln.res.omega * t, period);
            if (ln.res.phase_end < 0) ln.res.phase_end += period;
          }
        }
        finish(ln, fail);
        done->push_back(std::move(ln.res));
        ++st->speeds;
        ln.busy = false;
        for (std::size_t j = 0; j < r_; ++j) Qp_[j * L_ + slot] = Q_[j * L_ + slot] = 0.0;
      }
    }
    std::swap(Qm_, Q_);
    std::swap(Q_, Qp_);
  }

 private:
  // The works of step n = n1 - 1 (EnergyWork), and the energy E_{n+1/2} at the window's start
  // and at the end.
  void balance(Lane& ln, std::size_t slot, long n1) {
    const double h = s_.base.dt;
    const double *lam = nullptr, *fric = nullptr;
    if (ln.contact) {
      lam = ln.contact->normal(), fric = ln.contact->friction();
    } else if (ln.has_contact()) {
      lam = ln.lam_prev.data(), fric = ln.fric_prev.data();
    }
    ln.ledger->add(colm_.data(), col_.data(), no_loads_, static_cast<double>(n1 - 1) * h, lam, fric);
    if (ln.boundary && ln.has_contact()) {
      std::copy(ln.boundary->normal(), ln.boundary->normal() + ln.lam_prev.size(), ln.lam_prev.begin());
      std::copy(ln.boundary->friction(), ln.boundary->friction() + ln.fric_prev.size(), ln.fric_prev.begin());
    }
    if (n1 != ln.half && n1 != ln.n_steps) return;
    std::vector<double> qn(r_);
    for (std::size_t j = 0; j < r_; ++j) qn[j] = Q_[j * L_ + slot];
    const double e = energy(qn.data(), col_.data());
    if (n1 == ln.half) ln.res.energy_half = e, ln.res.work_half = ln.ledger->work();
    if (n1 == ln.n_steps) ln.res.energy_end = e, ln.res.work_end = ln.ledger->work();
  }
  // monitor . q of the state just computed (col_).
  double monitored() const {
    double u = 0.0;
    for (std::size_t j = 0; j < r_; ++j) u += s_.monitor[j] * col_[j];
    return u;
  }
  void record(Lane& ln, long n1, double t, double u) {
    SpeedResult& R = ln.res;
    R.steps = n1;
    if (std::abs(u) > R.max_displacement) R.max_displacement = std::abs(u), R.time_of_max = t;
    if (n1 >= ln.half) {
      ln.sum += u, ln.sum2 += u * u, ++ln.count;
      if (!freqs_.empty()) {  // block means of sample_every steps (decimated_spectrum)
        ln.block += u;
        if (++ln.in_block == ln.sample_every)
          ln.samples.push_back(ln.block / static_cast<double>(ln.sample_every)), ln.block = 0.0, ln.in_block = 0;
      }
    }
    if (ln.has_contact()) {
      double total = 0.0;
      const std::size_t nc = ln.cs->nodes.size();
      const double* lam = ln.normal();
      for (std::size_t k = 0; k < nc; ++k) total += lam[k], R.max_node_force = std::max(R.max_node_force, lam[k]);
      if (total > R.max_force) R.max_force = total, R.time_of_max_force = t;
      R.max_active = std::max(R.max_active, ln.active());
    }
  }
  // tangent_step() at the state in col_, time t.
  void check_tangent(Lane& ln, double t) {
    const auto ts = tangent_step(m_, col_.data());
    SpeedResult& R = ln.res;
    ++R.tangent_checks;
    if (ts.dt < R.tangent_dt_min) R.tangent_dt_min = ts.dt, R.tangent_dt_min_time = t;
    if (ts.negative > 0) ++R.tangent_negative_checks;
    ln.last_tangent_dt = ts.dt, ln.last_tangent_t = t;
  }
  std::string tangent_note(const Lane& ln) const {
    if (ln.res.tangent_checks == 0) return {};
    return cat("; the tangent critical step was ", ln.last_tangent_dt, " s at the last check (t = ", ln.last_tangent_t,
               " s), at least ", ln.res.tangent_dt_min, " s over ", ln.res.tangent_checks,
               " checks (t = ", ln.res.tangent_dt_min_time, " s), against the step ", s_.base.dt, " s");
  }
  void finish(Lane& ln, bool fail) {
    SpeedResult& R = ln.res;
    R.status = fail ? 1 : 0;
    if (ln.count > 0) {
      R.mean = ln.sum / static_cast<double>(ln.count);
      R.rms = std::sqrt(ln.sum2 / static_cast<double>(ln.count));
    }
    if (!freqs_.empty() && s_.orders > 0) {  // the engine-order lines at their exact frequencies
      const double f1 = std::abs(R.omega) / (2.0 * M_PI);
      std::vector<double> fk;
      for (int k = 1; k <= s_.orders && k * f1 <= s_.spectrum_fmax; ++k) fk.push_back(k * f1);
      R.orders.assign(static_cast<std::size_t>(s_.orders), std::nan(""));
      if (!fail) {
        const auto a = decimated_spectrum(ln.samples, s_.base.dt, ln.sample_every, fk);
        std::copy(a.begin(), a.end(), R.orders.begin());
      }
    }
    if (!freqs_.empty())
      R.spectrum = fail ? std::vector<double>(freqs_.size(), 0.0)
                        : binned_spectrum(std::move(ln.samples), s_.base.dt, ln.sample_every, freqs_);
    R.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - ln.start).count();
  }

  const SweepSettings& s_;
  const nlrom::ReducedModel& m_;
  std::shared_ptr<CubicKernel> raw_;  // massless: the lanes' boundary kernels
  std::shared_ptr<TangentKernel> tangent_;
  std::size_t r_, L_, n_ = 0;
  std::vector<double> P1_, P2_, P3_, W_, Q_, Qm_, Qp_, Y_, Z_, col_, colm_, freqs_;
  const std::vector<ReducedLoad> no_loads_;
  std::vector<std::size_t> groups_;
  std::vector<Lane> lanes_;
  std::unique_ptr<CubicKernel> lane_kernel_;     // SweepKernel::Lane
  std::unique_ptr<CubicKernelBatch> potential_;  // SweepKernel::Potential
  std::unique_ptr<CubicKernel> lone_kernel_;     // Potential: for a lone busy lane (same bits)
  SweepKernel kind_ = SweepKernel::Lane;
  std::vector<double> y_;

 public:
  /// The kernel in use (Auto resolved; Lane for a linear run).
  SweepKernel kernel() const { return kind_; }
};

void pack(morse::detail::Packer* pk, const SpeedResult& R) {
  pk->put(R.index), pk->put(R.omega), pk->put(R.status), pk->put_str(R.error), pk->put(R.steps);
  pk->put(R.dt), pk->put(R.halvings);
  pk->put(R.t_final), pk->put(R.rms), pk->put(R.mean), pk->put(R.max_displacement), pk->put(R.time_of_max);
  pk->put(R.max_force), pk->put(R.time_of_max_force), pk->put(R.max_node_force), pk->put(R.max_active);
  pk->put(R.tangent_dt_min), pk->put(R.tangent_dt_min_time), pk->put(R.tangent_checks);
  pk->put(R.tangent_negative_checks);
  pk->put(R.seconds), pk->put_vec(R.spectrum), pk->put_vec(R.orders);
  pk->put(R.energy_half), pk->put(R.energy_end);
  for (const auto* w : {&R.work_half, &R.work_end})
    pk->put(w->external), pk->put(w->normal), pk->put(w->friction), pk->put(w->damping);
  pk->put(R.from), pk->put(R.phase), pk->put(R.energy_start), pk->put_vec(R.q_end), pk->put_vec(R.qm_end);
  pk->put(R.phase_end);
}

SpeedResult unpack(morse::detail::Unpacker* up) {
  SpeedResult R;
  R.index = up->get<long>(), R.omega = up->get<double>(), R.status = up->get<int>(), R.error = up->get_str();
  R.steps = up->get<long>(), R.dt = up->get<double>(), R.halvings = up->get<int>();
  R.t_final = up->get<double>(), R.rms = up->get<double>(), R.mean = up->get<double>();
  R.max_displacement = up->get<double>(), R.time_of_max = up->get<double>(), R.max_force = up->get<double>();
  R.time_of_max_force = up->get<double>(), R.max_node_force = up->get<double>(), R.max_active = up->get<int>();
  R.tangent_dt_min = up->get<double>(), R.tangent_dt_min_time = up->get<double>();
  R.tangent_checks = up->get<long>(), R.tangent_negative_checks = up->get<long>();
  R.seconds = up->get<double>(), R.spectrum = up->get_vec<double>(), R.orders = up->get_vec<double>();
  R.energy_half = up->get<double>(), R.energy_end = up->get<double>();
  for (auto* w : {&R.work_half, &R.work_end}) {
    w->external = up->get<double>(), w->normal = up->get<double>();
    w->friction = up->get<double>(), w->damping = up->get<double>();
  }
  R.from = up->get<long>(), R.phase = up->get<double>(), R.energy_start = up->get<double>();
  R.q_end = up->get_vec<double>(), R.qm_end = up->get_vec<double>();
  R.phase_end = up->get<double>();
  return R;
}

constexpr int kTagMsg = 7301, kTagTask = 7302;
constexpr int kResult = 1, kRequest = 2, kBye = 4;

}  // namespace

double measure_step_rate(const nlrom::ReducedModel& m, const SweepSettings& s, double omega, double seconds,
                         int lanes) {
  SweepSettings one = s;
  one.batch = std::max(1, std::min(lanes, s.batch));
  one.revolutions = 1e9;  // the lanes never finish while they are timed
  Batch batch(m, one);
  for (int k = 0; k < one.batch; ++k) batch.start({k, omega});
  std::vector<SpeedResult> done;
  SweepStats st;
  long steps = 0, chunk = 50;
  const auto t0 = std::chrono::steady_clock::now();
  double dt = 0.0;
  while (true) {
    for (long k = 0; k < chunk; ++k) batch.step(&done, &st);
    steps += chunk;
    dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (dt >= seconds || !done.empty()) break;
    chunk = std::min(chunk * 2, 100000L);
  }
  return dt > 0 ? static_cast<double>(steps) * one.batch / dt : 0.0;
}

std::size_t sweep_share(std::size_t speeds, int ranks) {
  const std::size_t n = static_cast<std::size_t>(std::max(1, ranks));
  return std::max<std::size_t>(1, (speeds + n - 1) / n);
}

std::size_t sweep_lanes_per_rank(int batch, std::size_t speeds, int ranks) {
  return std::min(static_cast<std::size_t>(std::max(1, batch)), sweep_share(speeds, ranks));
}

long sweep_tangent_checks(long n_steps, long checks) {
  return 1 + n_steps / detail::tangent_check_every(n_steps, checks);
}

const char* kernel_name(SweepKernel k) {
  switch (k) {
    case SweepKernel::Lane:
      return "lane";
    case SweepKernel::Folded:
      return "folded";
    case SweepKernel::Potential:
      return "potential";
    default:
      return "auto";
  }
}

SweepStats sweep(MPI_Comm comm, const nlrom::ReducedModel& m, const SweepSettings& s,
                 const std::vector<SpeedTask>& todo, const std::function<void(const SpeedResult&)>& on_result) {
  const std::size_t r = static_cast<std::size_t>(m.r);
  MORSE_CHECK(s.monitor.size() == r, "sweep: the monitor has ", s.monitor.size(), " entries, not r = ", r);
  MORSE_CHECK(s.base.dt > 0 && std::isfinite(s.base.dt), "sweep: the time step must be positive (got ", s.base.dt, ")");
  MORSE_CHECK(s.revolutions > 0, "sweep: the number of revolutions must be positive (got ", s.revolutions, ")");
  MORSE_CHECK(s.base.linear || m.g.r == r, "sweep: the reduced model has no nonlinear force of size ", r,
              " (a linear model, -nlrom_forces none): run it with -sim_linear");
  ContactSettings casing = s.base.contact;  // every lane's obstacle is the casing
  casing.obstacle = Obstacle::Casing;
  const double hc = critical_step(m, &casing);
  MORSE_CHECK(s.base.dt <= hc, "sweep: -sim_dt ", s.base.dt, " s is above the critical step of central differences, ",
              hc, " s; use -sim_dt <= ", hc);
  for (const auto& t : todo)
    MORSE_CHECK(t.omega != 0.0 && std::isfinite(t.omega), "sweep: speed ", t.index, " is zero");
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  SweepStats st;
  const auto t0 = std::chrono::steady_clock::now();
  Batch batch(m, s);
  st.kernel = batch.kernel();
  // A rank holds at most its fair share of the speeds at once: with more lanes than that, the
  // first rank to ask would take nearly all of a short sweep (measured: 8 of 9 speeds on one of
  // 2 ranks, the other idle after its one speed). Each finished speed asks for one more.
  const std::size_t share = sweep_share(todo.size(), size);
  // Handed out longest first (a run's cost is its steps, revolutions 2 pi / |Omega| / dt): the
  // last speeds to start are the shortest, so the ranks finish together. The first lanes of the
  // ranks are filled round robin down that order (rank k the k-th, (k + size)-th, ... longest, up
  // to its lanes): filled in turn, rank 0 took the 8 longest of 16 speeds and rank 1 sat idle 47 %
  // of the sweep (measured). A rank that starts late finds its first speeds kept for it.
  std::vector<std::size_t> order(todo.size());
  for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return std::abs(todo[a].omega) < std::abs(todo[b].omega); });
  const std::size_t first_fill = sweep_lanes_per_rank(s.batch, todo.size(), size);
  std::vector<SpeedResult> done;
  // Progress counts lane steps, not finished speeds (with several lanes per rank, every speed may
  // finish near the end): rank 0 counts its own, the other ranks report theirs with every message
  // and at least every second.
  if (rank == 0) {
    double total = 0.0;
    for (const auto& t : todo) total += s.revolutions * 2.0 * M_PI / std::abs(t.omega) / s.base.dt;
    Progress prog(comm, cat("sweep (", todo.size(), " speeds on ", size, " rank(s))"), std::max(total, 1.0));
    std::size_t received = 0;
    int byes = 0;
    long remote_steps = 0;
    unsigned long ticks = 0;
    std::vector<std::deque<std::size_t>> kept(static_cast<std::size_t>(size));  // each rank's first fill
    std::size_t next = std::min(todo.size(), first_fill * static_cast<std::size_t>(size));
    for (std::size_t k = 0; k < next; ++k) kept[k % static_cast<std::size_t>(size)].push_back(order[k]);
    auto take = [&](int who) -> long {  // the next speed (index in todo) for rank `who`, or -1
      auto& q = kept[static_cast<std::size_t>(who)];
      if (!q.empty()) {
        const std::size_t i = q.front();
        q.pop_front();
        return static_cast<long>(i);
      }
      return next < todo.size() ? static_cast<long>(order[next++]) : -1;
    };
    auto report = [&]() { prog.update(static_cast<double>(st.lane_steps + remote_steps)); };
    auto accept = [&](const SpeedResult& R) {
      ++received;
      report();
      on_result(R);
    };
    auto handle = [&](const MPI_Status& status) {
      int len = 0;
      MPI_Get_count(&status, MPI_CHAR, &len);
      std::vector<char> buf(static_cast<std::size_t>(len));
      MPI_Recv(buf.data(), len, MPI_CHAR, status.MPI_SOURCE, kTagMsg, comm, MPI_STATUS_IGNORE);
      morse::detail::Unpacker up(buf);
      const int flags = up.get<int>();
      remote_steps += up.get<long>();
      report();
      if (flags & kResult) accept(unpack(&up));
      if (flags & kRequest) {
        long idx = take(status.MPI_SOURCE);
        MPI_Send(&idx, 1, MPI_LONG, status.MPI_SOURCE, kTagTask, comm);
      }
      if (flags & kBye) ++byes;
    };
    for (;;) {
      int flag = 1;
      while (size > 1 && flag) {
        MPI_Status status;
        MPI_Iprobe(MPI_ANY_SOURCE, kTagMsg, comm, &flag, &status);
        if (flag) handle(status);
      }
      while (batch.free_slots() > 0 && batch.busy() < share) {
        const long i = take(0);
        if (i < 0) break;
        batch.start(todo[static_cast<std::size_t>(i)]);
      }
      if (batch.any_busy()) {
        done.clear();
        batch.step(&done, &st);
        for (const auto& R : done) accept(R);
        if ((++ticks & 1023) == 0) report();
        continue;
      }
      if (received == todo.size() && byes == size - 1) break;
      MPI_Status status;
      const auto w0 = std::chrono::steady_clock::now();
      MPI_Probe(MPI_ANY_SOURCE, kTagMsg, comm, &status);
      st.idle_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count();
      handle(status);
    }
  } else {
    long reply = -1;
    MPI_Request req = MPI_REQUEST_NULL;
    int outstanding = 0;
    bool exhausted = false;
    long reported = 0;  // lane steps already reported to rank 0
    unsigned long ticks = 0;
    auto last_report = std::chrono::steady_clock::now();
    auto send = [&](int flags, const SpeedResult* R) {
      morse::detail::Packer pk;
      pk.put(flags);
      pk.put(static_cast<long>(st.lane_steps - reported));
      reported = st.lane_steps;
      last_report = std::chrono::steady_clock::now();
      if (R) pack(&pk, *R);
      auto& buf = pk.buffer();
      MPI_Send(buf.data(), static_cast<int>(buf.size()), MPI_CHAR, 0, kTagMsg, comm);
      if (flags & kRequest)
        if (outstanding++ == 0) MPI_Irecv(&reply, 1, MPI_LONG, 0, kTagTask, comm, &req);
    };
    auto got_reply = [&]() {
      --outstanding;
      if (reply < 0)
        exhausted = true;
      else
        batch.start(todo[static_cast<std::size_t>(reply)]);
      if (outstanding > 0) MPI_Irecv(&reply, 1, MPI_LONG, 0, kTagTask, comm, &req);
    };
    for (std::size_t k = std::min(batch.free_slots(), share); k > 0; --k) send(kRequest, nullptr);
    for (;;) {
      int flag = 1;
      while (outstanding > 0 && flag) {
        MPI_Test(&req, &flag, MPI_STATUS_IGNORE);
        if (flag) got_reply();
      }
      if (batch.any_busy()) {
        done.clear();
        batch.step(&done, &st);
        for (const auto& R : done) send(kResult | (exhausted ? 0 : kRequest), &R);
        if ((++ticks & 1023) == 0 &&
            std::chrono::duration<double>(std::chrono::steady_clock::now() - last_report).count() >= 1.0)
          send(0, nullptr);  // progress only
        continue;
      }
      if (outstanding > 0) {
        const auto w0 = std::chrono::steady_clock::now();
        MPI_Wait(&req, MPI_STATUS_IGNORE);
        st.idle_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count();
        got_reply();
        continue;
      }
      send(kBye, nullptr);
      break;
    }
  }
  st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  // A rank that left the loop early (its last speed done, nothing more to take) idles until the
  // slowest rank ends: the sweep's wall time is the longest rank's.
  double longest = st.seconds;
  MPI_Allreduce(MPI_IN_PLACE, &longest, 1, MPI_DOUBLE, MPI_MAX, comm);
  st.idle_seconds += longest - st.seconds;
  return st;
}

}  // namespace morse::sim
