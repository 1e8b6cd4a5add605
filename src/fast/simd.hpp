#pragma once
// Private: the compiler switches of the fast path's hot code (fast.cpp and lanes.cpp), and the
// arithmetic both write once for a scalar and for a 4-lane vector.

#include <cstdint>

#include "isowrench/engine.hpp"

// The hot functions are compiled twice, for x86-64-v3 (AVX2 + FMA: a multiply-add is one
// instruction, 4 doubles per register) and for the baseline; the loader picks the one the CPU
// runs (GNU ifunc). Other compilers/targets get the baseline only.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__) && \
    !defined(ISOWRENCH_NO_CLONES)
#define ISOWRENCH_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define ISOWRENCH_CLONES
#endif

#if defined(__GNUC__)
#define ISOWRENCH_INLINE inline __attribute__((always_inline))
#define ISOWRENCH_LAMBDA_INLINE __attribute__((always_inline))
#define ISOWRENCH_NOINLINE __attribute__((noinline))
#else
#define ISOWRENCH_INLINE inline
#define ISOWRENCH_LAMBDA_INLINE
#define ISOWRENCH_NOINLINE
#endif

// Full unrolling of loops whose trip count is a compile-time constant (the statics kernels'
// N > 0, the 3- and 9-element loops over vectors and frames of the kinematics): straight-line
// code early enough for GCC to keep such small arrays in registers (measured: 2,714 -> 2,601
// instructions per one-posture evaluation, 852 -> 812 per batched one). GCC only: clang's
// "#pragma unroll" on the same template with N = 0 (a run-time trip count) fails with
// -Wpass-failed under -Werror, and clang's own unroller already unrolls the constant-count
// loops at -O2.
#if defined(__GNUC__) && !defined(__clang__)
#define ISOWRENCH_UNROLL _Pragma("GCC unroll 16")
#else
#define ISOWRENCH_UNROLL
#endif

#if !defined(__GNUC__)
#error "isowrench's fast path needs GCC or Clang vector extensions (vector_size)"
#endif

namespace isowrench {

// 4 doubles / 4 64-bit integers (GCC/Clang vector extensions): one AVX register in the
// x86-64-v3 clone, two SSE2 registers in the baseline. Helpers take them by reference and
// constants are made by macro: a 32-byte vector passed or returned by value would draw GCC's
// -Wpsabi note (its ABI depends on AVX being enabled).
typedef double V4 __attribute__((vector_size(32)));
typedef std::int64_t V4i __attribute__((vector_size(32)));

}  // namespace isowrench

#define ISOWRENCH_V4_SPLAT(x) (::isowrench::V4{(x), (x), (x), (x)})

namespace isowrench {

// sin and cos near zero: Cody-Waite reduction by pi/2 with a three-part constant (exact
// products k * kPio2_1 for |k| < 2^20), then fdlibm's __kernel_sin / __kernel_cos polynomials
// on [-pi/4, pi/4]. T is double or V4; the caller rounds k = round(x 2/pi) and applies the
// quadrant (a branch for a scalar, selects for lanes).
namespace sincos {
constexpr double kTwoOverPi = 6.36619772367581382433e-01;
constexpr double kPio2_1 = 1.57079632673412561417e+00;  // first 33 bits of pi/2
constexpr double kPio2_2 = 6.07710050630396597660e-11;  // next 33 bits
constexpr double kPio2_3 = 2.02226624871116645580e-21;  // next 33 bits
constexpr double kRound = 6755399441055744.0;           // 1.5 * 2^52: x + kRound - kRound rounds x
/// |x| below this (rad) keeps k < 2^17, well inside the exact range; larger angles go to
/// std::sin / std::cos.
constexpr double kMaxReduced = 1e5;

/// sin and cos of r = x - k pi/2 (|r| <= pi/4).
template <class T>
ISOWRENCH_INLINE void Kernel(const T& x, const T& k, T& sin_r, T& cos_r) {
  constexpr double S1 = -1.66666666666666324348e-01, S2 = 8.33333333332248946124e-03,
                   S3 = -1.98412698298579493134e-04, S4 = 2.75573137070700676789e-06,
                   S5 = -2.50507602534068634195e-08, S6 = 1.58969099521155010221e-10;
  constexpr double C1 = 4.16666666666666019037e-02, C2 = -1.38888888888741095749e-03,
                   C3 = 2.48015872894767294178e-05, C4 = -2.75573143513906633035e-07,
                   C5 = 2.08757232129817482790e-09, C6 = -1.13596475577881948265e-11;
  const T r = ((x - k * kPio2_1) - k * kPio2_2) - k * kPio2_3;
  const T z = r * r;
  sin_r = r + r * z * (S1 + z * (S2 + z * (S3 + z * (S4 + z * (S5 + z * S6)))));
  const T hz = 0.5 * z;
  const T w = 1.0 - hz;
  cos_r =
      w + (((1.0 - w) - hz) + z * z * (C1 + z * (C2 + z * (C3 + z * (C4 + z * (C5 + z * C6))))));
}
}  // namespace sincos

/// Solve U^T U x = b with the Cholesky factor U (upper triangle by rows: U_ki at
/// U[k * kMaxDofs + i], k <= i; only the strict upper triangle and the reciprocal diagonal
/// inv_diag are read): forward substitution into y, back substitution into x. T is double or
/// V4; N > 0 fixes m at compile time (loops unroll).
template <int N, class T>
ISOWRENCH_INLINE void SolveWithFactor(int m, const T* U, const T* inv_diag, const T* b, T* y,
                                      T* x) {
  constexpr int S = kMaxDofs;  // the row stride of U
  ISOWRENCH_UNROLL
  for (int i = 0; i < m; ++i) {
    T v = b[i];
    ISOWRENCH_UNROLL
    for (int k = 0; k < i; ++k) v -= U[k * S + i] * y[k];
    y[i] = v * inv_diag[i];
  }
  ISOWRENCH_UNROLL
  for (int i = m - 1; i >= 0; --i) {
    T v = y[i];
    ISOWRENCH_UNROLL
    for (int k = i + 1; k < m; ++k) v -= U[i * S + k] * x[k];
    x[i] = v * inv_diag[i];
  }
}

}  // namespace isowrench
