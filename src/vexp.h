// A vectorisable exp for arrays: the Cephes rational approximation of exp on
// [-ln 2 / 2, ln 2 / 2] (relative error below 2.3e-16 there; 1.5 ulp in all
// against the C library) with the scaling by 2^n built in the exponent bits.
// The loops are written so that the compiler vectorises them (OpenMP simd:
// no branch inside a loop), and on x86-64 Linux with GCC each kernel is also
// compiled for AVX-512 and AVX2, chosen at run time. The clones do the same
// IEEE operations in the same order (contraction into fused multiply-adds is
// turned off), so the results do not depend on the machine, to the bit. exp(x) is 0 for x < -708 (where the double result
// would be subnormal); arguments must be below 709.
// Free of R types.
#ifndef WAVEVALID_VEXP_H
#define WAVEVALID_VEXP_H

#include <cstdint>
#include <cstring>

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define WAVEVALID_CLONES __attribute__((target_clones("avx512f", "avx2", "default"), optimize("fp-contract=off")))
#define WAVEVALID_NO_CONTRACT __attribute__((optimize("fp-contract=off")))
#else
#define WAVEVALID_CLONES
#define WAVEVALID_NO_CONTRACT
#endif

#if defined(_OPENMP)
#define WAVEVALID_SIMD _Pragma("omp simd")
#else
#define WAVEVALID_SIMD
#endif

namespace wavevalid {

// exp(x) for x in [-708, 709].
WAVEVALID_NO_CONTRACT inline double exp_kernel(double x) {
  const double shift = 6755399441055744.0;  // 1.5 * 2^52: adding it rounds to an integer
  const double fx = (x * 1.4426950408889634 + shift) - shift;
  const double r = (x - fx * 0.693145751953125) - fx * 1.42860682030941723212e-6;
  const double rr = r * r;
  const double px = r * ((1.26177193074810590878e-4 * rr + 3.02994407707441961300e-2) * rr +
                         9.99999999999999999910e-1);
  const double qx = ((3.00198505138664455042e-6 * rr + 2.52448340349684104192e-3) * rr +
                     2.27265548208155028766e-1) * rr + 2.00000000000000000009e0;
  const double e = 1.0 + 2.0 * px / (qx - px);
  // 2^fx from its exponent bits: fx + 1023 in the low bits of a double in [2^52, 2^53)
  const double biased = fx + (1023.0 + 4503599627370496.0);
  std::uint64_t bits;
  std::memcpy(&bits, &biased, sizeof bits);
  bits <<= 52;
  double scale;
  std::memcpy(&scale, &bits, sizeof scale);
  return e * scale;
}

// out[i] = exp(a * x[i] + b); out must not overlap x.
WAVEVALID_CLONES inline void vexp_affine(const double* x, double a, double b, double* out, int n) {
WAVEVALID_SIMD
  for (int i = 0; i < n; ++i) {
    const double v = a * x[i] + b;
    out[i] = v < -708.0 ? -708.0 : v;
  }
WAVEVALID_SIMD
  for (int i = 0; i < n; ++i) out[i] = exp_kernel(out[i]);
WAVEVALID_SIMD
  for (int i = 0; i < n; ++i) out[i] = a * x[i] + b < -708.0 ? 0.0 : out[i];
}

// out[i] = exp(-s[i]); out must not overlap s.
WAVEVALID_CLONES inline void vexp_neg(const double* s, double* out, int n) {
  vexp_affine(s, -1.0, 0.0, out, n);
}

}  // namespace wavevalid

#endif
