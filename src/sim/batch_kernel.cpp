// The batched potential kernel of a sweep's lanes (see morse/sim/sim.hpp, CubicKernelBatch, and
// docs/theory.md §10.4).
//
// g~ is the gradient of V(q) = sum c3 q_i q_j q_k (i <= j <= k) + sum c4 q_i q_j q_k q_l
// (i <= j <= k <= l). For fixed i (cubic) or fixed i <= j (quartic), the coefficients form a
// triangle: row k (k = j .. r - 1) holds the columns l = k .. r - 1, contiguous. Row k contributes
// acc_k = sum_l c(k, l) q_l (its slots other than l) and g_l += c(k, l) s_k (slot l), with
// s_k = q_i q_k (cubic, j = i) or q_i q_j q_k (quartic). The rows of a triangle are taken R at a
// time: each column l then loads q_l and g_l once for R rows, and each coefficient, broadcast once,
// feeds 2 multiply-adds per group of 4 lanes.
//
// A lane's arithmetic does not depend on R nor on the groups beside it: acc_k is one sum over l in
// increasing order from zero; g_l receives the rows' slot-l terms in increasing k; a row's slot-k
// term goes to g_k when the row is done, and its slot-i (and slot-j) terms are summed over the
// triangle's rows in order, in registers, and added to g_i (g_j) at its end (a row's own slots are
// never columns of the later rows of its triangle). So a group alone (R = 4), a pair of groups
// (R = 3) and one lane in scalars (CubicKernel, `morse simulate`) give the same bits, lane by lane.
#include <algorithm>
#include <cstdint>
#include <cstring>

#include "morse/core/error.hpp"
#include "morse/sim/sim.hpp"
#include "sim/contact.hpp"

namespace morse::sim {

namespace {

// The helpers below pass 256-bit vectors by value but are always inlined: no call, no ABI.
#pragma GCC diagnostic ignored "-Wpsabi"
typedef double v4 __attribute__((vector_size(32), aligned(8)));
inline __attribute__((always_inline)) v4 vld(const double* p) { return *reinterpret_cast<const v4*>(p); }
// The coefficient at c in all 4 lanes. Written as a load of 4 and a shuffle, which GCC turns into
// one vbroadcastsd from memory in the AVX2 clone (a broadcast of a scalar used twice becomes
// vmovddup + vinsertf128, a shuffle on a multiply-add port); the coefficient arrays are padded so
// that the 4 loaded never pass their end.
typedef long long m4 __attribute__((vector_size(32)));
typedef float f4 __attribute__((vector_size(16), aligned(4)));
typedef int i4 __attribute__((vector_size(16)));
inline __attribute__((always_inline)) v4 bcast(const double* c) { return __builtin_shuffle(vld(c), m4{0, 0, 0, 0}); }
inline __attribute__((always_inline)) v4 bcast(const float* c) {
  return __builtin_convertvector(__builtin_shuffle(*reinterpret_cast<const f4*>(c), i4{0, 0, 0, 0}), v4);
}
// 8 lanes in one AVX-512 register (the x86-64-v4 build only): two adjacent groups of 4.
typedef double v8 __attribute__((vector_size(64), aligned(8)));
// A broadcast from memory (vbroadcastsd zmm, m64: a load port only), written out because GCC turns
// both the load-and-shuffle of bcast and a scalar's broadcast into a 64-byte load (mostly across
// two cache lines) and a register broadcast on port 5, one of the two 512-bit multiply-add ports.
// (Used in the x86-64-v4 build only.)
#if MORSE_GCC_X86
inline __attribute__((always_inline)) v8 bcast8(const double* c) {
  v8 v;
  __asm__("vbroadcastsd %1, %0" : "=v"(v) : "m"(*c));
  return v;
}
inline __attribute__((always_inline)) v8 bcast8(const float* c) {
  v8 v;
  __asm__("vbroadcastss %1, %t0\n\tvcvtps2pd %t0, %0" : "=v"(v) : "m"(*c));
  return v;
}
#else  // other compilers and processors: the generic vector code (never chosen, kernel_isa_supported)
template <class T>
inline v8 bcast8(const T* c) {
  const double x = static_cast<double>(*c);
  return v8{x, x, x, x, x, x, x, x};
}
#endif
// The width of a group: 4 lanes in one AVX2 register (a sweep's lanes; Wide8: two groups in one
// AVX-512 register), or 1 lane in a scalar (`morse simulate`, CubicKernel). The same operations in
// the same order, each rounded alike (a fused multiply-add in the x86-64-v3 and v4 builds, a product
// then a sum in the baseline), so that a lane gets the same bits at any width.
// The vector of N lanes (a member typedef keeps aligned(8), which a template argument would drop).
template <std::size_t N>
struct VecOf;
template <>
struct VecOf<4> {
  typedef v4 type;
};
template <>
struct VecOf<8> {
  typedef v8 type;
};
template <std::size_t N>
struct Lanes {
  typedef typename VecOf<N>::type V;
  static constexpr std::size_t W = N;
  static V ld(const double* p) { return *reinterpret_cast<const V*>(p); }
  static void st(double* p, V v) { *reinterpret_cast<V*>(p) = v; }
  template <class T>
  static V bc(const T* c) {
    if constexpr (N == 8)
      return bcast8(c);
    else
      return bcast(c);
  }
  static V zero() { return V{}; }
};
using Wide = Lanes<4>;
using Wide8 = Lanes<8>;
struct Narrow {
  typedef double V;
  static constexpr std::size_t W = 1;
  static V ld(const double* p) { return *p; }
  static void st(double* p, V v) { *p = v; }
  template <class T>
  static V bc(const T* c) {
    return static_cast<double>(*c);
  }
  static V zero() { return 0.0; }
};
// Wide's broadcast loads 4 coefficients from any coefficient: the arrays are padded (by a whole
// 64-byte line).
constexpr std::size_t kPad = 8;

// Rows kb .. kb + RH - 1 of a triangle of n columns (row kb + a: its column l at p[a][l]), for NG
// groups of 4 lanes at X and G (row stride ld). Returns acc[a][g] and adds the rows' slot-l terms
// to G.
template <class Op, int NG, int RH, class T>
inline __attribute__((always_inline)) void row_block(std::size_t kb, std::size_t n, const T* const* p,
                                                     const typename Op::V (*s_in)[NG], typename Op::V (*acc_out)[NG],
                                                     const double* __restrict X, double* __restrict G, std::size_t ld) {
  // Local copies indexed by constants only (the loops over a and g unroll), so that they live in
  // registers: acc in memory would put a store-to-load forwarding into every multiply-add chain.
  typename Op::V acc[RH][NG], s[RH][NG];
  const T* pa[RH];
#pragma GCC unroll 16
  for (int a = 0; a < RH; ++a) {
    pa[a] = p[a];
#pragma GCC unroll 4
    for (int g = 0; g < NG; ++g) acc[a][g] = Op::zero(), s[a][g] = s_in[a][g];
  }
  // The triangle of the block, column by column: column kb + b holds rows a = 0 .. b of it. Each
  // g_l is loaded and stored once (row by row, a column's updates would chain through memory);
  // a row's acc still sums its columns in increasing l, a column its rows in increasing a.
#pragma GCC unroll 16
  for (int b = 0; b < RH; ++b) {
    const std::size_t l = kb + static_cast<std::size_t>(b);
    typename Op::V x[NG], y[NG];
#pragma GCC unroll 4
    for (int g = 0; g < NG; ++g) x[g] = Op::ld(X + l * ld + Op::W * g), y[g] = Op::ld(G + l * ld + Op::W * g);
#pragma GCC unroll 16
    for (int a = 0; a <= b; ++a) {
      const typename Op::V c = Op::bc(pa[a] + l);
#pragma GCC unroll 4
      for (int g = 0; g < NG; ++g) {
        acc[a][g] += c * x[g];
        y[g] += c * s[a][g];
      }
    }
#pragma GCC unroll 4
    for (int g = 0; g < NG; ++g) Op::st(G + l * ld + Op::W * g, y[g]);
  }
  // The rectangle: every row of the block, columns kb + RH .. n - 1. With one 8-lane register
  // (NG = 1), two columns at a time, interleaved: each column's g_l is a chain of RH dependent
  // multiply-adds, and two chains side by side keep both ports busy (theory §10.4). A row's acc
  // still takes column l before l + 1, so the bits are those of one column at a time.
  std::size_t l0 = kb + RH;
  if constexpr (Op::W == 8 && NG == 1) {
    for (; l0 + 2 <= n; l0 += 2) {
      const typename Op::V x0 = Op::ld(X + l0 * ld), x1 = Op::ld(X + (l0 + 1) * ld);
      typename Op::V y0 = Op::ld(G + l0 * ld), y1 = Op::ld(G + (l0 + 1) * ld);
#pragma GCC unroll 16
      for (int a = 0; a < RH; ++a) {
        const typename Op::V c0 = Op::bc(pa[a] + l0), c1 = Op::bc(pa[a] + l0 + 1);
        acc[a][0] += c0 * x0;
        y0 += c0 * s[a][0];
        acc[a][0] += c1 * x1;
        y1 += c1 * s[a][0];
      }
      Op::st(G + l0 * ld, y0), Op::st(G + (l0 + 1) * ld, y1);
    }
  }
  for (std::size_t l = l0; l < n; ++l) {
    typename Op::V x[NG], y[NG];
#pragma GCC unroll 4
    for (int g = 0; g < NG; ++g) x[g] = Op::ld(X + l * ld + Op::W * g), y[g] = Op::ld(G + l * ld + Op::W * g);
#pragma GCC unroll 16
    for (int a = 0; a < RH; ++a) {
      const typename Op::V c = Op::bc(pa[a] + l);
#pragma GCC unroll 4
      for (int g = 0; g < NG; ++g) {
        acc[a][g] += c * x[g];
        y[g] += c * s[a][g];
      }
    }
#pragma GCC unroll 4
    for (int g = 0; g < NG; ++g) Op::st(G + l * ld + Op::W * g, y[g]);
  }
#pragma GCC unroll 16
  for (int a = 0; a < RH; ++a)
#pragma GCC unroll 4
    for (int g = 0; g < NG; ++g) acc_out[a][g] = acc[a][g];
}

// Rows kb .. kb + rh - 1 for a run-time rh <= RH: row_block with rh as a constant.
template <class Op, int NG, int RH, class T>
inline __attribute__((always_inline)) void row_block_upto(std::size_t rh, std::size_t kb, std::size_t n,
                                                          const T* const* p, const typename Op::V (*s)[NG],
                                                          typename Op::V (*acc)[NG], const double* __restrict X,
                                                          double* __restrict G, std::size_t ld) {
  if constexpr (RH >= 1) {
    if (rh == RH)
      row_block<Op, NG, RH>(kb, n, p, s, acc, X, G, ld);
    else
      row_block_upto<Op, NG, RH - 1>(rh, kb, n, p, s, acc, X, G, ld);
  }
}

// One triangle: rows k0 .. n - 1 of coefficients C (row k0 first), fixed indices i (and j when
// Quartic), for NG groups at X and G, R rows at a time. A row's slot-k term goes to G(k) when the
// row is done; its slot-i (and slot-j) terms are summed over the triangle's rows in order, in
// registers, and added to G(i) (and G(j)) at the end.
template <class Op, int NG, int R, bool Quartic, class T>
inline __attribute__((always_inline)) void triangle(std::size_t i, std::size_t j, std::size_t k0, std::size_t n,
                                                    const T* C, const double* __restrict X, double* __restrict G,
                                                    std::size_t ld) {
  typename Op::V base[NG], xi[NG], xj[NG], si[NG], sj[NG];
  for (int g = 0; g < NG; ++g) {
    xi[g] = Op::ld(X + i * ld + Op::W * g), xj[g] = Op::ld(X + j * ld + Op::W * g);
    base[g] = Quartic ? xi[g] * xj[g] : xi[g];
    si[g] = sj[g] = Op::zero();
  }
  const T* row = C;
  for (std::size_t kb = k0; kb < n; kb += R) {
    const std::size_t rh = std::min<std::size_t>(R, n - kb);
    const T* p[R];
    typename Op::V s[R][NG], acc[R][NG];
    for (std::size_t a = 0; a < rh; ++a) {
      p[a] = row - (kb + a);  // column l of row kb + a at p[a][l] (inside C: rows before it are longer)
      row += n - (kb + a);
      for (int g = 0; g < NG; ++g) s[a][g] = base[g] * Op::ld(X + (kb + a) * ld + Op::W * g);
    }
    // The hardware prefetcher does not run far enough ahead of the short rows of a triangle:
    // ask for the lines 1 KB past this block's coefficients (measured on the 2-core EPYC: 4 % more
    // lane-steps/s at r = 79 with 8 lanes; 4 KB ahead gains less). Not in the AVX-512 passes: on
    // the Xeon whose L3 holds the coefficients it cost 3 % (r = 79, 16 lanes).
    if constexpr (Op::W < 8)
      for (const char *a = reinterpret_cast<const char*>(p[0] + kb) + 1024,
                      *b = reinterpret_cast<const char*>(row) + 1024;
           a < b; a += 64)
        __builtin_prefetch(a);
    row_block_upto<Op, NG, R>(rh, kb, n, p, s, acc, X, G, ld);
    for (std::size_t a = 0; a < rh; ++a) {
      const std::size_t k = kb + a;
      for (int g = 0; g < NG; ++g) {
        const typename Op::V xk = Op::ld(X + k * ld + Op::W * g);
        if (Quartic) {
          si[g] += acc[a][g] * (xj[g] * xk);
          sj[g] += acc[a][g] * (xi[g] * xk);
        } else {
          si[g] += acc[a][g] * xk;
        }
        double* gk = G + k * ld + Op::W * g;
        Op::st(gk, Op::ld(gk) + acc[a][g] * base[g]);
      }
    }
  }
  for (int g = 0; g < NG; ++g) {
    double* gi = G + i * ld + Op::W * g;
    Op::st(gi, Op::ld(gi) + si[g]);
    if (Quartic) {
      double* gj = G + j * ld + Op::W * g;
      Op::st(gj, Op::ld(gj) + sj[g]);
    }
  }
}

// Every triangle for the ng groups of 4 lanes at X, G (row stride ld >= 4 ng), in passes whose
// shapes were measured fastest (bench/README.md, "Batched potential kernel"):
//  - Avx2 (x86-64-v3, 16 vector registers): pairs of groups 3 rows at a time, a last single group
//    4 rows at a time;
//  - Avx512 (x86-64-v4, 32 registers of 8 lanes): 4 groups (2 registers) 6 rows at a time, then a
//    pair of groups (one register) 12 rows at a time, then a last single group as in Avx2;
//  - Scalar (one lane, `morse simulate`): 4 rows at a time.
// A lane's bits do not depend on the pass it is in (file comment), so every shape gives the same.
struct PassAvx2 {
  template <bool Quartic, class T>
  static inline __attribute__((always_inline)) void run(std::size_t i, std::size_t j, std::size_t k0, std::size_t r,
                                                        std::size_t ng, std::size_t ld, const T* C, const double* X,
                                                        double* G) {
    std::size_t g = 0;
    for (; g + 2 <= ng; g += 2) triangle<Wide, 2, 3, Quartic>(i, j, k0, r, C, X + 4 * g, G + 4 * g, ld);
    if (g < ng) triangle<Wide, 1, 4, Quartic>(i, j, k0, r, C, X + 4 * g, G + 4 * g, ld);
  }
};
struct PassAvx512 {
  template <bool Quartic, class T>
  static inline __attribute__((always_inline)) void run(std::size_t i, std::size_t j, std::size_t k0, std::size_t r,
                                                        std::size_t ng, std::size_t ld, const T* C, const double* X,
                                                        double* G) {
    std::size_t g = 0;
    for (; g + 4 <= ng; g += 4) triangle<Wide8, 2, 6, Quartic>(i, j, k0, r, C, X + 4 * g, G + 4 * g, ld);
    for (; g + 2 <= ng; g += 2) triangle<Wide8, 1, 12, Quartic>(i, j, k0, r, C, X + 4 * g, G + 4 * g, ld);
    if (g < ng) triangle<Wide, 1, 4, Quartic>(i, j, k0, r, C, X + 4 * g, G + 4 * g, ld);
  }
};
struct PassScalar {
  template <bool Quartic, class T>
  static inline __attribute__((always_inline)) void run(std::size_t i, std::size_t j, std::size_t k0, std::size_t r,
                                                        std::size_t, std::size_t, const T* C, const double* X,
                                                        double* G) {
    triangle<Narrow, 1, 4, Quartic>(i, j, k0, r, C, X, G, 1);
  }
};

template <class Pass, class T>
inline __attribute__((always_inline)) void gradient(std::size_t r, std::size_t ng, std::size_t ld, const T* c3,
                                                    const T* c4, const double* X, double* G) {
  std::memset(G, 0, sizeof(double) * r * ld);
  for (std::size_t i = 0; i < r; ++i) {  // cubic: triangle of rows j = i .. r - 1
    Pass::template run<false>(i, i, i, r, ng, ld, c3, X, G);
    c3 += (r - i) * (r - i + 1) / 2;
  }
  for (std::size_t i = 0; i < r; ++i)
    for (std::size_t j = i; j < r; ++j) {  // quartic: triangle of rows k = j .. r - 1
      Pass::template run<true>(i, j, j, r, ng, ld, c4, X, G);
      c4 += (r - j) * (r - j + 1) / 2;
    }
}

// The batched gradient, one build per instruction set (chosen by CubicKernelBatch, not by GCC's
// dispatch, so that a test can run each on a machine that has them all). The x86-64-v3 and v4
// builds fuse every multiply-add, the baseline rounds products and sums apart.
#if MORSE_GCC_X86
#define MORSE_TARGET_V3 __attribute__((target("arch=x86-64-v3")))
#define MORSE_TARGET_V4 __attribute__((target("arch=x86-64-v4")))
#else
#define MORSE_TARGET_V3
#define MORSE_TARGET_V4
#endif
template <class T>
void gradient_baseline(std::size_t r, std::size_t ng, std::size_t ld, const T* c3, const T* c4, const double* X,
                       double* G) {
  gradient<PassAvx2>(r, ng, ld, c3, c4, X, G);
}
template <class T>
MORSE_TARGET_V3 void gradient_avx2(std::size_t r, std::size_t ng, std::size_t ld, const T* c3, const T* c4,
                                   const double* X, double* G) {
  gradient<PassAvx2>(r, ng, ld, c3, c4, X, G);
}
template <class T>
MORSE_TARGET_V4 void gradient_avx512(std::size_t r, std::size_t ng, std::size_t ld, const T* c3, const T* c4,
                                     const double* X, double* G) {
  gradient<PassAvx512>(r, ng, ld, c3, c4, X, G);
}
template <class T>
void gradient_isa(KernelIsa isa, std::size_t r, std::size_t ng, std::size_t ld, const T* c3, const T* c4,
                  const double* X, double* G) {
  switch (isa) {
    case KernelIsa::Avx512:
      return gradient_avx512(r, ng, ld, c3, c4, X, G);
    case KernelIsa::Avx2:
      return gradient_avx2(r, ng, ld, c3, c4, X, G);
    case KernelIsa::Baseline:
      return gradient_baseline(r, ng, ld, c3, c4, X, G);
  }
}

// Y(p, groups) = sum_k P3(p, k) G(k, :), k increasing (G: row stride ld, group g at W g).
template <class Op>
inline __attribute__((always_inline)) void project(std::size_t r, std::size_t L, const std::size_t* groups,
                                                   std::size_t ng, std::size_t ld, const double* __restrict P3,
                                                   const double* __restrict G, double* __restrict Y) {
  for (std::size_t p = 0; p < r; ++p)
    for (std::size_t g = 0; g < ng; ++g) {
      typename Op::V y = Op::zero();
      for (std::size_t k = 0; k < r; ++k) y += Op::bc(&P3[p * r + k]) * Op::ld(G + k * ld + Op::W * g);
      Op::st(Y + p * L + Op::W * groups[g], y);
    }
}
// The projection is r^2 per lane against the gradient's r^4 / 24: the AVX2 build serves Avx512 too
// (the same fused operations, so the same bits).
void project_baseline(std::size_t r, std::size_t L, const std::size_t* groups, std::size_t ng, std::size_t ld,
                      const double* __restrict P3, const double* __restrict G, double* __restrict Y) {
  project<Wide>(r, L, groups, ng, ld, P3, G, Y);
}
MORSE_TARGET_V3 void project_avx2(std::size_t r, std::size_t L, const std::size_t* groups, std::size_t ng,
                                  std::size_t ld, const double* __restrict P3, const double* __restrict G,
                                  double* __restrict Y) {
  project<Wide>(r, L, groups, ng, ld, P3, G, Y);
}

}  // namespace

namespace detail {
// Not vectorized by GCC: its SLP vectorizer would pack the rows' products into vector multiplies
// and adds, unfused, where the lanes of CubicKernelBatch fuse them (measured: 1-ulp differences).
MORSE_KERNEL_CLONES __attribute__((optimize("no-tree-vectorize"))) void potential_force_lane(
    std::size_t r, const double* q, const double* c3, const double* c4, const double* P3, double* g, double* y) {
  const std::size_t lane = 0;
  gradient<PassScalar>(r, 1, 1, c3, c4, q, g);
  project<Narrow>(r, 1, &lane, 1, 1, P3, g, y);
}
}  // namespace detail

bool kernel_isa_supported(KernelIsa isa) {
  switch (isa) {
    case KernelIsa::Baseline:
      return true;
#if MORSE_GCC_X86
    case KernelIsa::Avx2:
      return __builtin_cpu_supports("x86-64-v3");
    case KernelIsa::Avx512:
      return __builtin_cpu_supports("x86-64-v4");
#else
    case KernelIsa::Avx2:
    case KernelIsa::Avx512:
      return false;
#endif
  }
  return false;
}

KernelIsa best_kernel_isa() {
  for (KernelIsa isa : {KernelIsa::Avx512, KernelIsa::Avx2})
    if (kernel_isa_supported(isa)) return isa;
  return KernelIsa::Baseline;
}

KernelIsa kernel_isa_or_best(int isa) { return isa >= 0 ? static_cast<KernelIsa>(isa) : best_kernel_isa(); }

const char* kernel_isa_name(KernelIsa isa) {
  switch (isa) {
    case KernelIsa::Baseline:
      return "baseline x86-64";
    case KernelIsa::Avx2:
      return "AVX2 + FMA (x86-64-v3)";
    case KernelIsa::Avx512:
      return "AVX-512 (x86-64-v4)";
  }
  return "?";
}

CubicKernelBatch::CubicKernelBatch(const CubicKernel& k, bool single) : r_(k.r()), single_(single) {
  MORSE_CHECK(k.potential(),
              "sweep: the batched potential kernel needs a reduced force that is the gradient of a "
              "potential (relative asymmetry ",
              k.asymmetry(), "); use the per-lane kernel");
  P3_ = k.P3_;
  n3_ = k.c3_.size(), n4_ = k.c4_.size();
  if (single) {
    c3f_.assign(k.c3_.begin(), k.c3_.end());
    c4f_.assign(k.c4_.begin(), k.c4_.end());
    c3f_.resize(n3_ + kPad, 0.0f), c4f_.resize(n4_ + kPad, 0.0f);
  } else {
    c3_ = k.c3_, c4_ = k.c4_;
    c3_.resize(n3_ + kPad, 0.0), c4_.resize(n4_ + kPad, 0.0);
  }
  P3_.resize(r_ * r_ + kPad, 0.0);
  isa_ = best_kernel_isa();
}

void CubicKernelBatch::set_isa(KernelIsa isa) {
  MORSE_CHECK(kernel_isa_supported(isa), "the batched potential kernel: this processor has no ", kernel_isa_name(isa));
  isa_ = isa;
}

void CubicKernelBatch::apply(std::size_t L, const std::size_t* groups, std::size_t ng, const double* Q,
                             double* Y) const {
  if (ng == 0) return;
  // Rows of a whole number of 8-lane registers, and X and G on 64-byte boundaries: no row of a
  // group or a pair of groups straddles a cache line.
  const std::size_t ld = 8 * ((ng + 1) / 2);
  if (X_.size() < r_ * ld + 8) X_.resize(r_ * ld + 8), G_.resize(r_ * ld + 8);
  auto aligned = [](std::vector<double>& v) {
    const auto a = reinterpret_cast<std::uintptr_t>(v.data());
    return v.data() + ((64 - a % 64) % 64) / sizeof(double);
  };
  double *X = aligned(X_), *G = aligned(G_);
  for (std::size_t j = 0; j < r_; ++j)
    for (std::size_t g = 0; g < ng; ++g) std::memcpy(X + j * ld + 4 * g, Q + j * L + 4 * groups[g], 4 * sizeof(double));
  if (single_)
    gradient_isa(isa_, r_, ng, ld, c3f_.data(), c4f_.data(), X, G);
  else
    gradient_isa(isa_, r_, ng, ld, c3_.data(), c4_.data(), X, G);
  if (isa_ == KernelIsa::Baseline)
    project_baseline(r_, L, groups, ng, ld, P3_.data(), G, Y);
  else
    project_avx2(r_, L, groups, ng, ld, P3_.data(), G, Y);
}

namespace {
// V(q) = sum_{i<=j<=k} c3 q_i q_j q_k + sum_{i<=j<=k<=l} c4 q_i q_j q_k q_l, the coefficients in
// the lexicographic order of the sorted tuples (the last index innermost, contiguous).
template <class T>
double potential_of_coefficients(std::size_t r, const T* c3, const T* c4, const double* q) {
  double v3 = 0.0, v4 = 0.0;
  for (std::size_t i = 0; i < r; ++i)
    for (std::size_t j = i; j < r; ++j) {
      const double qij = q[i] * q[j];
      double s3 = 0.0;
      for (std::size_t k = j; k < r; ++k) s3 += static_cast<double>(*c3++) * q[k];
      v3 += qij * s3;
      for (std::size_t k = j; k < r; ++k) {
        double s4 = 0.0;
        for (std::size_t l = k; l < r; ++l) s4 += static_cast<double>(*c4++) * q[l];
        v4 += qij * q[k] * s4;
      }
    }
  return v3 + v4;
}
}  // namespace

double CubicKernelBatch::potential(const double* q) const {
  return single_ ? potential_of_coefficients(r_, c3f_.data(), c4f_.data(), q)
                 : potential_of_coefficients(r_, c3_.data(), c4_.data(), q);
}

double CubicKernelBatch::flops() const {
  return 4.0 * static_cast<double>(n3_ + n4_) + 2.0 * static_cast<double>(r_ * r_);
}

double CubicKernelBatch::bytes() const { return (single_ ? 4.0 : 8.0) * static_cast<double>(n3_ + n4_); }

}  // namespace morse::sim
