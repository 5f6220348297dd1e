// exp over arrays, to the bit as Eigen 3.3's SSE2 array exp computes it, in
// wider vectors.
//
// On x86-64 without SSE4.1 or AVX (the compilers' default target), Eigen 3.3
// evaluates `array.exp()` with its packet exp of two doubles (pexp<Packet2d>:
// the Cephes rational approximation) at the positions its assignment loop
// aligns to 16 bytes, and with the C library's exp at the others (a first
// element whose address is not aligned, a last odd one). exp_cephes() does
// the packet exp's IEEE operations in the same order for one element, and
// vexp_eigen() sends each element down the same path as Eigen would: the
// results are those of Eigen's expression to the bit, while the loop over
// the packet positions is compiled for AVX-512 and AVX2 as well, chosen at
// run time (GCC on x86-64 Linux; contraction into fused multiply-adds is off
// in every clone). Where Eigen's expression is not that one (another Eigen,
// another target), vexp_eigen_available is false and callers keep Eigen's
// expression. Free of R types.
#ifndef WAVEVALID_VEXP_H
#define WAVEVALID_VEXP_H

#include <cmath>
#include <cstdint>
#include <cstring>
#include <Eigen/Core>

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__) && \
    EIGEN_WORLD_VERSION == 3 && EIGEN_MAJOR_VERSION == 3 && defined(EIGEN_VECTORIZE_SSE2) && \
    !defined(EIGEN_VECTORIZE_SSE4_1) && !defined(EIGEN_VECTORIZE_AVX) && !defined(EIGEN_VECTORIZE_FMA) && \
    !defined(EIGEN_DONT_VECTORIZE) && !defined(EIGEN_UNALIGNED_VECTORIZE_OFF)
#define WAVEVALID_VEXP_EIGEN 1
#include <immintrin.h>
#define WAVEVALID_VEXP_TARGET(isa) __attribute__((target(isa), optimize("fp-contract=off")))
#define WAVEVALID_CLONES \
  __attribute__((target_clones("avx512f", "avx2", "default"), optimize("O3", "fp-contract=off")))
#define WAVEVALID_NO_CONTRACT __attribute__((optimize("fp-contract=off")))
#else
#define WAVEVALID_VEXP_EIGEN 0
#define WAVEVALID_CLONES
#define WAVEVALID_NO_CONTRACT
#endif

namespace wavevalid {

constexpr bool vexp_eigen_available = WAVEVALID_VEXP_EIGEN == 1;

// One lane of Eigen 3.3's pexp<Packet2d> (SSE2): the same operations, in the
// same order, with the same constants.
WAVEVALID_NO_CONTRACT inline double exp_cephes(double x0) {
  double x = x0 < 709.437 ? x0 : 709.437;                     // pmin(x, exp_hi)
  x = x > -709.436139303 ? x : -709.436139303;                // pmax(., exp_lo)
  double fx = 1.4426950408889634073599 * x + 0.5;              // pmadd(LOG2EF, x, half)
  double tmp = static_cast<double>(static_cast<std::int32_t>(fx));  // cvttpd, cvtepi32
  fx = tmp - (tmp > fx ? 1.0 : 0.0);                           // floor
  const double t1 = fx * 0.693145751953125;
  const double z = fx * 1.42860682030941723212e-6;
  x = x - t1;
  x = x - z;
  const double x2 = x * x;
  double px = 1.26177193074810590878e-4 * x2 + 3.02994407707441961300e-2;
  px = px * x2 + 9.99999999999999999910e-1;
  px = px * x;
  double qx = 3.00198505138664455042e-6 * x2 + 2.52448340349684104192e-3;
  qx = qx * x2 + 2.27265548208155028766e-1;
  qx = qx * x2 + 2.00000000000000000009e0;
  x = px / (qx - px);
  x = 2.0 * x + 1.0;
  // 2^fx: (fx + 1023) << 20 in the high 32 bits, the low ones zero
  const std::uint32_t hi = static_cast<std::uint32_t>(static_cast<std::int32_t>(fx) + 1023) << 20;
  const std::uint64_t bits = static_cast<std::uint64_t>(hi) << 32;
  double scale;
  std::memcpy(&scale, &bits, sizeof scale);
  const double r = x * scale;
  return r > x0 ? r : x0;                                      // pmax(r, _x)
}

#if WAVEVALID_VEXP_EIGEN
// The same operations on 4 and on 8 lanes (AVX2, AVX-512).
WAVEVALID_VEXP_TARGET("avx2")
inline void exp_cephes_avx2(const double* x, double* out, std::ptrdiff_t n) {
  const __m256d hi = _mm256_set1_pd(709.437), lo = _mm256_set1_pd(-709.436139303);
  const __m256d log2e = _mm256_set1_pd(1.4426950408889634073599), half = _mm256_set1_pd(0.5);
  const __m256d one = _mm256_set1_pd(1.0), two = _mm256_set1_pd(2.0);
  const __m256d c1 = _mm256_set1_pd(0.693145751953125), c2 = _mm256_set1_pd(1.42860682030941723212e-6);
  const __m256d p0 = _mm256_set1_pd(1.26177193074810590878e-4), p1 = _mm256_set1_pd(3.02994407707441961300e-2);
  const __m256d p2 = _mm256_set1_pd(9.99999999999999999910e-1);
  const __m256d q0 = _mm256_set1_pd(3.00198505138664455042e-6), q1 = _mm256_set1_pd(2.52448340349684104192e-3);
  const __m256d q2 = _mm256_set1_pd(2.27265548208155028766e-1), q3 = _mm256_set1_pd(2.00000000000000000009e0);
  const __m128i bias = _mm_set1_epi32(1023);
  std::ptrdiff_t i = 0;
  for (; i + 4 <= n; i += 4) {
    const __m256d x0 = _mm256_loadu_pd(x + i);
    __m256d v = _mm256_max_pd(_mm256_min_pd(x0, hi), lo);
    __m256d fx = _mm256_add_pd(_mm256_mul_pd(log2e, v), half);
    __m256d tmp = _mm256_cvtepi32_pd(_mm256_cvttpd_epi32(fx));
    fx = _mm256_sub_pd(tmp, _mm256_and_pd(_mm256_cmp_pd(tmp, fx, _CMP_GT_OQ), one));
    tmp = _mm256_mul_pd(fx, c1);
    const __m256d z = _mm256_mul_pd(fx, c2);
    v = _mm256_sub_pd(v, tmp);
    v = _mm256_sub_pd(v, z);
    const __m256d x2 = _mm256_mul_pd(v, v);
    __m256d px = _mm256_add_pd(_mm256_mul_pd(p0, x2), p1);
    px = _mm256_add_pd(_mm256_mul_pd(px, x2), p2);
    px = _mm256_mul_pd(px, v);
    __m256d qx = _mm256_add_pd(_mm256_mul_pd(q0, x2), q1);
    qx = _mm256_add_pd(_mm256_mul_pd(qx, x2), q2);
    qx = _mm256_add_pd(_mm256_mul_pd(qx, x2), q3);
    v = _mm256_div_pd(px, _mm256_sub_pd(qx, px));
    v = _mm256_add_pd(_mm256_mul_pd(two, v), one);
    const __m128i e = _mm_slli_epi32(_mm_add_epi32(_mm256_cvttpd_epi32(fx), bias), 20);
    const __m256d scale = _mm256_castsi256_pd(_mm256_slli_epi64(_mm256_cvtepu32_epi64(e), 32));
    _mm256_storeu_pd(out + i, _mm256_max_pd(_mm256_mul_pd(v, scale), x0));
  }
  for (; i < n; ++i) out[i] = exp_cephes(x[i]);
}

WAVEVALID_VEXP_TARGET("avx512f")
inline void exp_cephes_avx512(const double* x, double* out, std::ptrdiff_t n) {
  const __m512d hi = _mm512_set1_pd(709.437), lo = _mm512_set1_pd(-709.436139303);
  const __m512d log2e = _mm512_set1_pd(1.4426950408889634073599), half = _mm512_set1_pd(0.5);
  const __m512d one = _mm512_set1_pd(1.0), two = _mm512_set1_pd(2.0);
  const __m512d c1 = _mm512_set1_pd(0.693145751953125), c2 = _mm512_set1_pd(1.42860682030941723212e-6);
  const __m512d p0 = _mm512_set1_pd(1.26177193074810590878e-4), p1 = _mm512_set1_pd(3.02994407707441961300e-2);
  const __m512d p2 = _mm512_set1_pd(9.99999999999999999910e-1);
  const __m512d q0 = _mm512_set1_pd(3.00198505138664455042e-6), q1 = _mm512_set1_pd(2.52448340349684104192e-3);
  const __m512d q2 = _mm512_set1_pd(2.27265548208155028766e-1), q3 = _mm512_set1_pd(2.00000000000000000009e0);
  const __m256i bias = _mm256_set1_epi32(1023);
  std::ptrdiff_t i = 0;
  for (; i + 8 <= n; i += 8) {
    const __m512d x0 = _mm512_loadu_pd(x + i);
    __m512d v = _mm512_max_pd(_mm512_min_pd(x0, hi), lo);
    __m512d fx = _mm512_add_pd(_mm512_mul_pd(log2e, v), half);
    __m512d tmp = _mm512_cvtepi32_pd(_mm512_cvttpd_epi32(fx));
    fx = _mm512_sub_pd(tmp, _mm512_maskz_mov_pd(_mm512_cmp_pd_mask(tmp, fx, _CMP_GT_OQ), one));
    tmp = _mm512_mul_pd(fx, c1);
    const __m512d z = _mm512_mul_pd(fx, c2);
    v = _mm512_sub_pd(v, tmp);
    v = _mm512_sub_pd(v, z);
    const __m512d x2 = _mm512_mul_pd(v, v);
    __m512d px = _mm512_add_pd(_mm512_mul_pd(p0, x2), p1);
    px = _mm512_add_pd(_mm512_mul_pd(px, x2), p2);
    px = _mm512_mul_pd(px, v);
    __m512d qx = _mm512_add_pd(_mm512_mul_pd(q0, x2), q1);
    qx = _mm512_add_pd(_mm512_mul_pd(qx, x2), q2);
    qx = _mm512_add_pd(_mm512_mul_pd(qx, x2), q3);
    v = _mm512_div_pd(px, _mm512_sub_pd(qx, px));
    v = _mm512_add_pd(_mm512_mul_pd(two, v), one);
    const __m256i e = _mm256_slli_epi32(_mm256_add_epi32(_mm512_cvttpd_epi32(fx), bias), 20);
    const __m512d scale = _mm512_castsi512_pd(_mm512_slli_epi64(_mm512_cvtepu32_epi64(e), 32));
    _mm512_storeu_pd(out + i, _mm512_max_pd(_mm512_mul_pd(v, scale), x0));
  }
  for (; i < n; ++i) out[i] = exp_cephes(x[i]);
}

inline void exp_cephes_plain(const double* x, double* out, std::ptrdiff_t n) {
  for (std::ptrdiff_t i = 0; i < n; ++i) out[i] = exp_cephes(x[i]);
}

typedef void (*ExpLoop)(const double*, double*, std::ptrdiff_t);

// The widest loop this processor runs, chosen once.
inline ExpLoop exp_cephes_loop() {
  static const ExpLoop loop = [] {
    __builtin_cpu_init();
    if (__builtin_cpu_supports("avx512f")) return static_cast<ExpLoop>(exp_cephes_avx512);
    if (__builtin_cpu_supports("avx2")) return static_cast<ExpLoop>(exp_cephes_avx2);
    return static_cast<ExpLoop>(exp_cephes_plain);
  }();
  return loop;
}
#endif

// out[i] = exp(x[i]) for i < n, each element by the path Eigen 3.3's
// assignment `dst = x.exp()` takes for it (see above), for a destination dst
// at `aligned_as` (by default out itself). x may be out.
inline void vexp_eigen(const double* x, double* out, std::ptrdiff_t n, const double* aligned_as = nullptr) {
  const std::uintptr_t addr = reinterpret_cast<std::uintptr_t>(aligned_as ? aligned_as : out);
  std::ptrdiff_t start = addr % sizeof(double) != 0 ? n : ((addr % 16) == 0 ? 0 : 1);
  if (start > n) start = n;
  const std::ptrdiff_t end = start + ((n - start) / 2) * 2;
  for (std::ptrdiff_t i = 0; i < start; ++i) out[i] = std::exp(x[i]);
#if WAVEVALID_VEXP_EIGEN
  exp_cephes_loop()(x + start, out + start, end - start);
#else
  for (std::ptrdiff_t i = start; i < end; ++i) out[i] = exp_cephes(x[i]);
#endif
  for (std::ptrdiff_t i = end; i < n; ++i) out[i] = std::exp(x[i]);
}

// out[i] = a * x[i] + b, rounded after the product and after the sum as
// Eigen's `a * x + b` rounds them.
WAVEVALID_CLONES inline void affine_eigen(const double* __restrict x, double a, double b, double* __restrict out,
                                          std::ptrdiff_t n) {
  for (std::ptrdiff_t i = 0; i < n; ++i) out[i] = a * x[i] + b;
}

// t[i] = a * x[i] and s[i] += t[i]: a product as Eigen's `a * x` rounds it,
// and add_to(), in one pass.
WAVEVALID_CLONES inline void scale_add_to(const double* __restrict x, double a, double* __restrict t,
                                          double* __restrict s, std::ptrdiff_t n) {
  for (std::ptrdiff_t i = 0; i < n; ++i) {
    const double v = a * x[i];
    t[i] = v;
    s[i] = s[i] + v;
  }
}

// out[t] = (u[t] * uk - r[t]) * c[t].
WAVEVALID_CLONES inline void scaled_difference(const double* __restrict u, double uk, const double* __restrict r,
                                               const double* __restrict c, double* __restrict out, std::ptrdiff_t n) {
  for (std::ptrdiff_t t = 0; t < n; ++t) out[t] = (u[t] * uk - r[t]) * c[t];
}

// With x[i] = a[i] * b[i], the sums of x[i] and of x[i] * c[i] over i < n
// (n >= 4), each summed as Eigen 3.3's SSE2 redux sums an array that starts
// aligned: two packets of two partial sums, one lane per i modulo 4, the
// packets added, a last full packet added to them, the two lanes added, an
// odd last element at the end.
WAVEVALID_CLONES inline void product_sums(const double* __restrict a, const double* __restrict b,
                                          const double* __restrict c, std::ptrdiff_t n, double* sum_x,
                                          double* sum_xc) {
  double s[4], t[4];
  for (int r = 0; r < 4; ++r) {
    s[r] = a[r] * b[r];
    t[r] = s[r] * c[r];
  }
  const std::ptrdiff_t e2 = (n / 4) * 4, e1 = (n / 2) * 2;
  for (std::ptrdiff_t i = 4; i < e2; i += 4) {
    for (int r = 0; r < 4; ++r) {
      const double x = a[i + r] * b[i + r];
      s[r] = s[r] + x;
      t[r] = t[r] + x * c[i + r];
    }
  }
  double s0 = s[0] + s[2], s1 = s[1] + s[3], t0 = t[0] + t[2], t1 = t[1] + t[3];
  if (e1 > e2) {
    const double x0 = a[e2] * b[e2], x1 = a[e2 + 1] * b[e2 + 1];
    s0 = s0 + x0;
    s1 = s1 + x1;
    t0 = t0 + x0 * c[e2];
    t1 = t1 + x1 * c[e2 + 1];
  }
  double rs = s0 + s1, rt = t0 + t1;
  for (std::ptrdiff_t i = e1; i < n; ++i) {
    const double x = a[i] * b[i];
    rs = rs + x;
    rt = rt + x * c[i];
  }
  *sum_x = rs;
  *sum_xc = rt;
}

// Dot products summed as Eigen 3.3's SSE2 `a.dot(b)` of two columns sums
// them (its linear vectorised redux, the packets from the first element on):
// every product rounded on its own, four partial sums, one lane per k modulo
// 4 (two packets of two), the packets added, a last full packet added to
// them, the two lanes added, an odd last element at the end; for n < 4 one
// packet and the rest in order. dot_eigen_ref() is that order one element
// at a time; dots_eigen() computes several at once, in AVX2 vectors of four
// lanes (the four partial sums) where the processor has them, so that the
// dependent additions of different products overlap. (In the sampler, at the
// large size, dots over two different weight columns at once were slower than
// one column at a time: the callers give it one coefficient's weights.)
WAVEVALID_NO_CONTRACT inline double dot_eigen_ref(const double* a, const double* b, std::ptrdiff_t n) {
  if (n < 2) return n == 1 ? a[0] * b[0] : 0.0;
  const std::ptrdiff_t e2 = (n / 4) * 4, e1 = (n / 2) * 2;
  double res;
  if (n >= 4) {
    double s[4];
    for (int r = 0; r < 4; ++r) s[r] = a[r] * b[r];
    for (std::ptrdiff_t k = 4; k < e2; k += 4)
      for (int r = 0; r < 4; ++r) s[r] = s[r] + a[k + r] * b[k + r];
    double s0 = s[0] + s[2], s1 = s[1] + s[3];
    if (e1 > e2) {
      s0 = s0 + a[e2] * b[e2];
      s1 = s1 + a[e2 + 1] * b[e2 + 1];
    }
    res = s0 + s1;
  } else {
    res = a[0] * b[0] + a[1] * b[1];
  }
  for (std::ptrdiff_t k = e1; k < n; ++k) res = res + a[k] * b[k];
  return res;
}

#if WAVEVALID_VEXP_EIGEN
// D products at once (n >= 4): lanes 0-3 of an AVX2 vector are Eigen's four
// partial sums, its halves its two packets.
template <int D>
WAVEVALID_VEXP_TARGET("avx2")
inline void dots_eigen_avx2(const double* const* a, const double* const* b, std::ptrdiff_t n, double* out) {
  const std::ptrdiff_t e2 = (n / 4) * 4, e1 = (n / 2) * 2;
  __m256d acc[D];
#pragma GCC unroll 4
  for (int d = 0; d < D; ++d) acc[d] = _mm256_mul_pd(_mm256_loadu_pd(a[d]), _mm256_loadu_pd(b[d]));
  for (std::ptrdiff_t k = 4; k < e2; k += 4) {
#pragma GCC unroll 4
    for (int d = 0; d < D; ++d)
      acc[d] = _mm256_add_pd(acc[d], _mm256_mul_pd(_mm256_loadu_pd(a[d] + k), _mm256_loadu_pd(b[d] + k)));
  }
#pragma GCC unroll 4
  for (int d = 0; d < D; ++d) {
    __m128d v = _mm_add_pd(_mm256_castpd256_pd128(acc[d]), _mm256_extractf128_pd(acc[d], 1));
    if (e1 > e2) v = _mm_add_pd(v, _mm_mul_pd(_mm_loadu_pd(a[d] + e2), _mm_loadu_pd(b[d] + e2)));
    double res = _mm_cvtsd_f64(v) + _mm_cvtsd_f64(_mm_unpackhi_pd(v, v));
    for (std::ptrdiff_t k = e1; k < n; ++k) res = res + a[d][k] * b[d][k];
    out[d] = res;
  }
}

inline bool has_avx2() {
  static const bool yes = [] {
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx2") != 0;
  }();
  return yes;
}
#endif

// out[d] = the dot product of a[d] and b[d], n values each, for d < D, each
// as dot_eigen_ref() sums it.
inline void dots_eigen(const double* const* a, const double* const* b, int D, std::ptrdiff_t n, double* out) {
  int d = 0;
#if WAVEVALID_VEXP_EIGEN
  if (n >= 4 && has_avx2()) {
    for (; d + 4 <= D; d += 4) dots_eigen_avx2<4>(a + d, b + d, n, out + d);
    if (d + 2 <= D) {
      dots_eigen_avx2<2>(a + d, b + d, n, out + d);
      d += 2;
    }
    if (d < D) dots_eigen_avx2<1>(a + d, b + d, n, out + d);
    return;
  }
#endif
  for (; d < D; ++d) out[d] = dot_eigen_ref(a[d], b[d], n);
}

// x[k] = (((x[k] - a0 p0[k]) - a1 p1[k]) - a2 p2[k]) - a3 p3[k] for k < len,
// each product and difference rounded on its own (no fused multiply-adds), as
// SSE2's packets of two compute them: every element the same operations in
// the same order, in the widest vectors.
WAVEVALID_CLONES inline void sub_products4(double* __restrict x, std::ptrdiff_t len, double a0, double a1, double a2,
                                           double a3, const double* __restrict p0, const double* __restrict p1,
                                           const double* __restrict p2, const double* __restrict p3) {
  for (std::ptrdiff_t k = 0; k < len; ++k) {
    double v = x[k];
    v = v - a0 * p0[k];
    v = v - a1 * p1[k];
    v = v - a2 * p2[k];
    v = v - a3 * p3[k];
    x[k] = v;
  }
}

// s[i] += x[i].
WAVEVALID_CLONES inline void add_to(double* __restrict s, const double* __restrict x, std::ptrdiff_t n) {
  for (std::ptrdiff_t i = 0; i < n; ++i) s[i] = s[i] + x[i];
}

// The inverse of a Cholesky factor and the lower triangle of R^-1, as the
// likelihood's gradient computes them with Eigen's SSE2 packets, to the bit,
// in wider vectors: every entry gets the same operations in the same order.
//
// LT (Kp x K, column-major, Kp >= K a multiple of 8; every entry written):
// LT[j + i Kp] = (L^-1)(i, j) for the lower triangular L (K x K,
// column-major), by the forward substitution of each column j of L^-1 from
// e_j (an entry's updates in the order k = j, j + 1, ...), all columns at once.
WAVEVALID_CLONES inline void tri_inverse_t(const double* __restrict L, double* __restrict LT, int K, int Kp) {
  for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(K) * Kp; ++i) LT[i] = 0.0;
  for (int k = 0; k < K; ++k) {
    const double* __restrict lk = L + static_cast<std::ptrdiff_t>(k) * K;
    double* __restrict ck = LT + static_cast<std::ptrdiff_t>(k) * Kp;
    ck[k] = 1.0;
    const int m = ((k + 8) / 8) * 8;  // lanes 0..k, rounded up to 8 (the others hold zeros and stay so)
    const double d = lk[k];
    for (int j = 0; j < m; ++j) ck[j] = ck[j] / d;
    for (int i = k + 1; i < K; ++i) {
      const double l = lk[i];
      double* __restrict ci = LT + static_cast<std::ptrdiff_t>(i) * Kp;
      for (int j = 0; j < m; ++j) ci[j] = ci[j] - ck[j] * l;
    }
  }
}

// Ri(j, k) for k <= j (Ri K x K column-major) = sum_{i >= j} L^-1(i, j) L^-1(i, k),
// summed as Eigen's dot of the two columns' segments from row j sums it with
// SSE2 packets: four partial sums interleaved by element, combined as
// (s0 + s2) + (s1 + s3), a last pair added to the first two, an odd last
// element at the end. All k at once; acc holds 4 Kp.
WAVEVALID_CLONES inline void gram_lower_t(const double* __restrict LT, double* __restrict Ri, double* __restrict acc,
                                   int K, int Kp) {
  double* __restrict A0 = acc;
  double* __restrict A1 = acc + Kp;
  double* __restrict B0 = acc + 2 * Kp;
  double* __restrict B1 = acc + 3 * Kp;
  for (int j = 0; j < K; ++j) {
    const int n = K - j, m = ((j + 8) / 8) * 8;
    const double* __restrict row = LT + static_cast<std::ptrdiff_t>(j) * Kp;  // row[k + t Kp] = L^-1(j + t, k)
    auto lj = [&](int t) { return row[j + static_cast<std::ptrdiff_t>(t) * Kp]; };  // L^-1(j + t, j)
    if (n == 1) {
      const double a = lj(0);
      for (int k = 0; k < m; ++k) A0[k] = a * row[k];
    } else if (n < 4) {
      const double a0 = lj(0), a1 = lj(1);
      const double* __restrict r1 = row + Kp;
      for (int k = 0; k < m; ++k) A0[k] = a0 * row[k] + a1 * r1[k];
      if (n == 3) {
        const double a2 = lj(2);
        const double* __restrict r2 = row + 2 * Kp;
        for (int k = 0; k < m; ++k) A0[k] = A0[k] + a2 * r2[k];
      }
    } else {
      {
        const double a0 = lj(0), a1 = lj(1), a2 = lj(2), a3 = lj(3);
        const double* __restrict r1 = row + Kp;
        const double* __restrict r2 = row + 2 * Kp;
        const double* __restrict r3 = row + 3 * Kp;
        for (int k = 0; k < m; ++k) {
          A0[k] = a0 * row[k];
          A1[k] = a1 * r1[k];
          B0[k] = a2 * r2[k];
          B1[k] = a3 * r3[k];
        }
      }
      const int e2 = (n / 4) * 4;
      for (int t = 4; t < e2; t += 4) {
        const double a0 = lj(t), a1 = lj(t + 1), a2 = lj(t + 2), a3 = lj(t + 3);
        const double* __restrict r0 = row + static_cast<std::ptrdiff_t>(t) * Kp;
        const double* __restrict r1 = r0 + Kp;
        const double* __restrict r2 = r0 + 2 * Kp;
        const double* __restrict r3 = r0 + 3 * Kp;
        for (int k = 0; k < m; ++k) {
          A0[k] = A0[k] + a0 * r0[k];
          A1[k] = A1[k] + a1 * r1[k];
          B0[k] = B0[k] + a2 * r2[k];
          B1[k] = B1[k] + a3 * r3[k];
        }
      }
      for (int k = 0; k < m; ++k) {
        A0[k] = A0[k] + B0[k];
        A1[k] = A1[k] + B1[k];
      }
      if (n - e2 >= 2) {
        const double a0 = lj(e2), a1 = lj(e2 + 1);
        const double* __restrict r0 = row + static_cast<std::ptrdiff_t>(e2) * Kp;
        const double* __restrict r1 = r0 + Kp;
        for (int k = 0; k < m; ++k) {
          A0[k] = A0[k] + a0 * r0[k];
          A1[k] = A1[k] + a1 * r1[k];
        }
      }
      for (int k = 0; k < m; ++k) A0[k] = A0[k] + A1[k];
      if (n % 2 == 1) {
        const double a = lj(n - 1);
        const double* __restrict r = row + static_cast<std::ptrdiff_t>(n - 1) * Kp;
        for (int k = 0; k < m; ++k) A0[k] = A0[k] + a * r[k];
      }
    }
    for (int k = 0; k <= j; ++k) Ri[j + static_cast<std::ptrdiff_t>(k) * K] = A0[k];
  }
}

}  // namespace wavevalid

#endif
