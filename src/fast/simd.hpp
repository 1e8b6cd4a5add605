#pragma once
// Private: the compiler switches of the fast path's hot code (fast.cpp and lanes.cpp), and the
// arithmetic both write once for a scalar and for a 4-lane vector.

#include <cstdint>
#include <type_traits>

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

// ISOWRENCH_NO_FORCE_INLINE (the sanitizer build, CMakeLists.txt): inlining left to the compiler.
#if defined(__GNUC__) && !defined(ISOWRENCH_NO_FORCE_INLINE)
#define ISOWRENCH_INLINE inline __attribute__((always_inline))
#define ISOWRENCH_LAMBDA_INLINE __attribute__((always_inline))
#else
#define ISOWRENCH_INLINE inline
#define ISOWRENCH_LAMBDA_INLINE
#endif
#if defined(__GNUC__)
#define ISOWRENCH_NOINLINE __attribute__((noinline))
#else
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

// The checks for inf and NaN (the solve's inputs, the batch's postures) add 0 * x, which is NaN
// exactly for inf or NaN x: finite-math optimisation would fold it to 0 and let them through.
#if defined(__FAST_MATH__) || (defined(__FINITE_MATH_ONLY__) && __FINITE_MATH_ONLY__)
#error \
    "isowrench's fast path needs IEEE inf/NaN semantics: build without -ffast-math / -ffinite-math-only"
#endif

// A compiler barrier: memory may have changed, so values are loaded again after it (used where
// GCC would otherwise keep loaded values live and spill them, or extract them from registers).
#define ISOWRENCH_COMPILER_BARRIER() asm volatile("" ::: "memory")

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

// The polynomial and reduction constants, by index: a table of doubles for one posture and one
// of whole vectors for the lanes. The vector table is defined in another translation unit
// (batch.cpp), so the compiler does not see its values: each multiply-add then reads its
// constant as a memory operand instead of first broadcasting a known scalar (one instruction
// fewer per constant per lane group).
enum Constant : int {
  kS1,
  kS2,
  kS3,
  kS4,
  kS5,
  kS6,
  kC1,
  kC2,
  kC3,
  kC4,
  kC5,
  kC6,
  kReduce1,
  kReduce2,
  kReduce3,
  kHalf,
  kOne,
  kConstantCount
};
inline constexpr double kScalarConstants[kConstantCount] = {-1.66666666666666324348e-01,
                                                            8.33333333332248946124e-03,
                                                            -1.98412698298579493134e-04,
                                                            2.75573137070700676789e-06,
                                                            -2.50507602534068634195e-08,
                                                            1.58969099521155010221e-10,
                                                            4.16666666666666019037e-02,
                                                            -1.38888888888741095749e-03,
                                                            2.48015872894767294178e-05,
                                                            -2.75573143513906633035e-07,
                                                            2.08757232129817482790e-09,
                                                            -1.13596475577881948265e-11,
                                                            kPio2_1,
                                                            kPio2_2,
                                                            kPio2_3,
                                                            0.5,
                                                            1.0};
extern const V4 kLaneConstants[kConstantCount];  // the same, splatted (batch.cpp)

inline constexpr V4 kKnownLaneConstants[kConstantCount] = {
#define ISOWRENCH_SPLAT_CONSTANT(i) ISOWRENCH_V4_SPLAT(kScalarConstants[i])
    ISOWRENCH_SPLAT_CONSTANT(kS1),      ISOWRENCH_SPLAT_CONSTANT(kS2),
    ISOWRENCH_SPLAT_CONSTANT(kS3),      ISOWRENCH_SPLAT_CONSTANT(kS4),
    ISOWRENCH_SPLAT_CONSTANT(kS5),      ISOWRENCH_SPLAT_CONSTANT(kS6),
    ISOWRENCH_SPLAT_CONSTANT(kC1),      ISOWRENCH_SPLAT_CONSTANT(kC2),
    ISOWRENCH_SPLAT_CONSTANT(kC3),      ISOWRENCH_SPLAT_CONSTANT(kC4),
    ISOWRENCH_SPLAT_CONSTANT(kC5),      ISOWRENCH_SPLAT_CONSTANT(kC6),
    ISOWRENCH_SPLAT_CONSTANT(kReduce1), ISOWRENCH_SPLAT_CONSTANT(kReduce2),
    ISOWRENCH_SPLAT_CONSTANT(kReduce3), ISOWRENCH_SPLAT_CONSTANT(kHalf),
    ISOWRENCH_SPLAT_CONSTANT(kOne)};
#undef ISOWRENCH_SPLAT_CONSTANT

/// Constant i as a T: the lanes (kOpaque) read the vector table of batch.cpp (`table`, which is
/// kLaneConstants or a copy of its address that GCC cannot follow); one posture, whose vector
/// sin/cos of four joints at once keeps the constants in registers across its two or three
/// calls, uses the known values.
template <class T, bool kOpaque>
ISOWRENCH_INLINE const T& Get(Constant i, [[maybe_unused]] const V4* table) {
  if constexpr (std::is_same_v<T, double>) {
    return kScalarConstants[i];
  } else if constexpr (kOpaque) {
    return table[i];
  } else {
    return kKnownLaneConstants[i];
  }
}

/// sin and cos of r = x - k pi/2 (|r| <= pi/4).
template <bool kOpaque = false, class T>
ISOWRENCH_INLINE void Kernel(const T& x, const T& k, T& sin_r, T& cos_r,
                             const V4* table = kLaneConstants) {
  const T r = ((x - k * Get<T, kOpaque>(kReduce1, table)) - k * Get<T, kOpaque>(kReduce2, table)) -
              k * Get<T, kOpaque>(kReduce3, table);
  const T z = r * r;
  sin_r =
      r +
      r * z *
          (Get<T, kOpaque>(kS1, table) +
           z * (Get<T, kOpaque>(kS2, table) +
                z * (Get<T, kOpaque>(kS3, table) +
                     z * (Get<T, kOpaque>(kS4, table) +
                          z * (Get<T, kOpaque>(kS5, table) + z * Get<T, kOpaque>(kS6, table))))));
  const T hz = Get<T, kOpaque>(kHalf, table) * z;
  const T w = Get<T, kOpaque>(kOne, table) - hz;
  cos_r =
      w +
      (((Get<T, kOpaque>(kOne, table) - w) - hz) +
       z * z *
           (Get<T, kOpaque>(kC1, table) +
            z * (Get<T, kOpaque>(kC2, table) +
                 z * (Get<T, kOpaque>(kC3, table) +
                      z * (Get<T, kOpaque>(kC4, table) +
                           z * (Get<T, kOpaque>(kC5, table) + z * Get<T, kOpaque>(kC6, table)))))));
}
}  // namespace sincos

/// Solve U^T U x = b with the Cholesky factor U (upper triangle by rows: U_ki at
/// U[k * S + i], k <= i; only the strict upper triangle and the reciprocal diagonal
/// inv_diag are read): forward substitution into y, back substitution into x. T is double or
/// V4; N > 0 fixes m at compile time (loops unroll).
template <int N, class T>
ISOWRENCH_INLINE void SolveWithFactor(int m, const T* U, int S, const T* inv_diag, const T* b, T* y,
                                      T* x) {
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
