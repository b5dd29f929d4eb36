// bench/machine_limits.cpp: this machine's limits on ONE core, for the roofline of the online
// kernel of `morse simulate` (bench/nlrom_bench.py --r79). Standalone, single-threaded, no PETSc.
//
//     g++ -O3 -march=x86-64 -std=c++17 machine_limits.cpp -o machine_limits
//     ./machine_limits [--n N]          # N doubles per array, default 40,000,000 (3 arrays: 960 MB)
//     ./machine_limits --scalar         # force the scalar kernels (to check the fallback)
//
// Prints one JSON object on stdout:
//   stream_copy_gbs, stream_scale_gbs, stream_add_gbs, stream_triad_gbs: STREAM-like kernels
//     (c = a; b = s c; c = a + b; a = b + s c) over arrays of N doubles, best of 5 repetitions.
//     Convention of STREAM (McCalpin): bytes counted are those the kernel names, 16 per element
//     for copy and scale (one read, one write), 24 for add and triad (two reads, one write); the
//     write-allocate read of the destination that a cache without streaming stores also performs
//     is NOT counted. GB = 1e9 bytes.
//   read_gbs: sum over one array of N doubles (8 bytes per element, read only), best of 5: the
//     relevant figure for a kernel that streams a large read-only tensor once per call.
//   fma_peak_gflops: the core's peak: 12 independent accumulator chains of 8-lane AVX-512 FMAs
//     when the processor has AVX-512F, else of 4-lane AVX2 FMAs (2 flops per lane per FMA), best
//     of 5; a scalar multiply-add fallback (12 chains, 2 flops each) when the processor has no
//     FMA/AVX2 ("isa" says which one ran).
//   fma_avx2_gflops: the AVX2 figure alone (on an AVX-512 core, what a 4-lane kernel can reach).
//   n, isa, convention, reps, checksum (sum of the results, printed so that nothing can be
//     optimized away).
// The build is for baseline x86-64; only the FMA and read kernels are compiled for AVX2 + FMA or
// AVX-512F (function target attribute) and chosen at run time with __builtin_cpu_supports.
#include <immintrin.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// Tells the compiler that the memory behind p is read and written here: stores before it cannot be
// dropped, loads after it cannot be hoisted across it.
inline void escape(void* p) { __asm__ volatile("" : : "g"(p) : "memory"); }

double* alloc(std::size_t n) {
  const std::size_t bytes = ((n * sizeof(double) + 63) / 64) * 64;
  void* p = std::aligned_alloc(64, bytes);
  if (!p) {
    std::fprintf(stderr, "machine_limits: cannot allocate %zu bytes\n", bytes);
    std::exit(1);
  }
  return static_cast<double*>(p);
}

// ---- read-only bandwidth -------------------------------------------------------------------

__attribute__((target("avx2,fma"))) double read_sum_avx2(const double* a, std::size_t n) {
  __m256d s0 = _mm256_setzero_pd(), s1 = _mm256_setzero_pd(), s2 = _mm256_setzero_pd(), s3 = _mm256_setzero_pd();
  std::size_t i = 0;
  for (; i + 16 <= n; i += 16) {
    s0 = _mm256_add_pd(s0, _mm256_load_pd(a + i));
    s1 = _mm256_add_pd(s1, _mm256_load_pd(a + i + 4));
    s2 = _mm256_add_pd(s2, _mm256_load_pd(a + i + 8));
    s3 = _mm256_add_pd(s3, _mm256_load_pd(a + i + 12));
  }
  alignas(32) double t[4];
  _mm256_store_pd(t, _mm256_add_pd(_mm256_add_pd(s0, s1), _mm256_add_pd(s2, s3)));
  double s = t[0] + t[1] + t[2] + t[3];
  for (; i < n; ++i) s += a[i];
  return s;
}

double read_sum_scalar(const double* a, std::size_t n) {
  // Eight independent chains: the sum is limited by the loads, not by the latency of one add.
  double s[8] = {0, 0, 0, 0, 0, 0, 0, 0};
  std::size_t i = 0;
  for (; i + 8 <= n; i += 8)
    for (int k = 0; k < 8; ++k) s[k] += a[i + k];
  double t = ((s[0] + s[1]) + (s[2] + s[3])) + ((s[4] + s[5]) + (s[6] + s[7]));
  for (; i < n; ++i) t += a[i];
  return t;
}

// ---- FMA peak ------------------------------------------------------------------------------

constexpr int kChains = 12;

// acc = acc * m + c converges to c / (1 - m) for |m| < 1: no overflow, no denormals.
__attribute__((target("avx2,fma"))) double fma_avx2(long iterations, double m, double c) {
  const __m256d vm = _mm256_set1_pd(m), vc = _mm256_set1_pd(c);
  __m256d x0 = _mm256_set1_pd(0.0), x1 = _mm256_set1_pd(0.1), x2 = _mm256_set1_pd(0.2), x3 = _mm256_set1_pd(0.3),
          x4 = _mm256_set1_pd(0.4), x5 = _mm256_set1_pd(0.5), x6 = _mm256_set1_pd(0.6), x7 = _mm256_set1_pd(0.7),
          x8 = _mm256_set1_pd(0.8), x9 = _mm256_set1_pd(0.9), x10 = _mm256_set1_pd(1.0), x11 = _mm256_set1_pd(1.1);
  for (long it = 0; it < iterations; ++it) {
    x0 = _mm256_fmadd_pd(x0, vm, vc);
    x1 = _mm256_fmadd_pd(x1, vm, vc);
    x2 = _mm256_fmadd_pd(x2, vm, vc);
    x3 = _mm256_fmadd_pd(x3, vm, vc);
    x4 = _mm256_fmadd_pd(x4, vm, vc);
    x5 = _mm256_fmadd_pd(x5, vm, vc);
    x6 = _mm256_fmadd_pd(x6, vm, vc);
    x7 = _mm256_fmadd_pd(x7, vm, vc);
    x8 = _mm256_fmadd_pd(x8, vm, vc);
    x9 = _mm256_fmadd_pd(x9, vm, vc);
    x10 = _mm256_fmadd_pd(x10, vm, vc);
    x11 = _mm256_fmadd_pd(x11, vm, vc);
  }
  const __m256d s = _mm256_add_pd(_mm256_add_pd(_mm256_add_pd(_mm256_add_pd(x0, x1), _mm256_add_pd(x2, x3)),
                                                _mm256_add_pd(_mm256_add_pd(x4, x5), _mm256_add_pd(x6, x7))),
                                  _mm256_add_pd(_mm256_add_pd(x8, x9), _mm256_add_pd(x10, x11)));
  alignas(32) double t[4];
  _mm256_store_pd(t, s);
  return t[0] + t[1] + t[2] + t[3];
}

__attribute__((target("avx512f"))) double fma_avx512(long iterations, double m, double c) {
  const __m512d vm = _mm512_set1_pd(m), vc = _mm512_set1_pd(c);
  __m512d x[kChains];
  for (int k = 0; k < kChains; ++k) x[k] = _mm512_set1_pd(0.1 * k);
  for (long it = 0; it < iterations; ++it) {
#pragma GCC unroll 12
    for (int k = 0; k < kChains; ++k) x[k] = _mm512_fmadd_pd(x[k], vm, vc);
  }
  __m512d s = x[0];
  for (int k = 1; k < kChains; ++k) s = _mm512_add_pd(s, x[k]);
  return _mm512_reduce_add_pd(s);
}

double fma_scalar(long iterations, double m, double c) {
  double x[kChains];
  for (int k = 0; k < kChains; ++k) x[k] = 0.1 * k;
  for (long it = 0; it < iterations; ++it)
    for (int k = 0; k < kChains; ++k) x[k] = x[k] * m + c;  // no FMA in baseline x86-64: mul + add
  double s = 0.0;
  for (int k = 0; k < kChains; ++k) s += x[k];
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  std::size_t n = 40000000;
  const int reps = 5;
  bool force_scalar = false;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--n") == 0 && i + 1 < argc) {
      n = std::strtoull(argv[++i], nullptr, 10);
    } else if (std::strcmp(argv[i], "--scalar") == 0) {
      force_scalar = true;
    } else if (std::strcmp(argv[i], "--help") == 0 || std::strcmp(argv[i], "-h") == 0) {
      std::printf("usage: %s [--n N] [--scalar]   (N doubles per array, default 40000000)\n", argv[0]);
      return 0;
    } else {
      std::fprintf(stderr, "machine_limits: unknown argument %s (usage: --n N, --scalar)\n", argv[i]);
      return 1;
    }
  }
  if (n < 16) n = 16;
  const bool avx2 = !force_scalar && __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  const bool avx512 = avx2 && __builtin_cpu_supports("avx512f");

  double* a = alloc(n);
  double* b = alloc(n);
  double* c = alloc(n);
  for (std::size_t i = 0; i < n; ++i) a[i] = 1.0, b[i] = 2.0, c[i] = 0.0;  // first touch
  escape(a), escape(b), escape(c);
  // Runtime scalar so that the compiler cannot fold it.
  const double s = 3.0 + 1e-9 * (argc & 1);

  double best[5] = {1e30, 1e30, 1e30, 1e30, 1e30};  // copy, scale, add, triad, read
  double checksum = 0.0;
  for (int k = 0; k < reps; ++k) {
    auto t0 = Clock::now();
    for (std::size_t i = 0; i < n; ++i) c[i] = a[i];
    escape(c);
    best[0] = std::min(best[0], seconds_since(t0));

    t0 = Clock::now();
    for (std::size_t i = 0; i < n; ++i) b[i] = s * c[i];
    escape(b);
    best[1] = std::min(best[1], seconds_since(t0));

    t0 = Clock::now();
    for (std::size_t i = 0; i < n; ++i) c[i] = a[i] + b[i];
    escape(c);
    best[2] = std::min(best[2], seconds_since(t0));

    t0 = Clock::now();
    for (std::size_t i = 0; i < n; ++i) a[i] = b[i] + s * c[i];
    escape(a);
    best[3] = std::min(best[3], seconds_since(t0));

    t0 = Clock::now();
    const double sum = avx2 ? read_sum_avx2(b, n) : read_sum_scalar(b, n);
    best[4] = std::min(best[4], seconds_since(t0));
    checksum += sum * 1e-12;
    escape(a), escape(b), escape(c);
  }
  checksum += (a[n / 2] + b[n / 3] + c[n - 1]) * 1e-12;

  // FMA peak: ~0.1-0.5 s per repetition on current x86 cores.
  const long iterations = 50000000;
  const double m = 0.999999 - 1e-12 * (argc & 1), cc = 1e-6;
  double best_fma = 1e30, best_avx2 = 1e30;
  for (int k = 0; k < reps; ++k) {
    auto t0 = Clock::now();
    const double r = avx2 ? fma_avx2(iterations, m, cc) : fma_scalar(iterations, m, cc);
    best_avx2 = std::min(best_avx2, seconds_since(t0));
    checksum += r * 1e-12;
    if (avx512) {
      t0 = Clock::now();
      checksum += fma_avx512(iterations, m, cc) * 1e-12;
      best_fma = std::min(best_fma, seconds_since(t0));
    }
  }
  const double avx2_flops = static_cast<double>(iterations) * kChains * (avx2 ? 4 : 1) * 2.0;
  const double fma_avx2_gflops = avx2_flops / best_avx2 * 1e-9;
  const double fma_peak_gflops =
      avx512 ? static_cast<double>(iterations) * kChains * 8 * 2.0 / best_fma * 1e-9 : fma_avx2_gflops;

  const double dn = static_cast<double>(n);
  std::printf(
      "{\"stream_copy_gbs\": %.3f, \"stream_scale_gbs\": %.3f, \"stream_add_gbs\": %.3f, "
      "\"stream_triad_gbs\": %.3f, \"read_gbs\": %.3f, \"fma_peak_gflops\": %.3f, \"fma_avx2_gflops\": %.3f, "
      "\"n\": %zu, "
      "\"isa\": \"%s\", \"reps\": %d, \"fma_chains\": %d, "
      "\"convention\": \"STREAM: 16 bytes/element for copy and scale, 24 for add and triad (write-allocate "
      "traffic not counted); read: 8 bytes/element; GB = 1e9 bytes; best of reps; FMA: 2 flops per lane per "
      "FMA (scalar fallback: mul + add = 2 flops)\", \"checksum\": %.17g}\n",
      16.0 * dn / best[0] * 1e-9, 16.0 * dn / best[1] * 1e-9, 24.0 * dn / best[2] * 1e-9, 24.0 * dn / best[3] * 1e-9,
      8.0 * dn / best[4] * 1e-9, fma_peak_gflops, fma_avx2_gflops, n,
      avx512 ? "avx512f (8 x double)"
      : avx2 ? "avx2+fma (4 x double)"
             : "x86-64 scalar (no fma)",
      reps, kChains, checksum);
  std::free(a);
  std::free(b);
  std::free(c);
  return 0;
}
