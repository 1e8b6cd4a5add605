#pragma once
// Private: the elementary functions of the uncertainty studies (exp of the log-normal and
// log-uniform draws, the direction angle's atan2), written with IEEE basic operations only
// (+ - * /, comparisons, exact power-of-two scaling by the exponent bits), so that every machine
// and every build gives the same bits: no libm (glibc picks FMA or plain variants at load time),
// no multiply-add (the library is compiled for baseline x86-64 and its clones are "avx", which
// has no FMA). Both follow Cephes (S. L. Moshier, Cephes Math Library, netlib: exp.c, atan.c),
// the same rational approximations in the same order of operations.
//
// UncExpLanes: exp of four doubles (GCC/Clang vector extensions), relative error below
// 3.5e-16 (tests/uncertainty/unc_math_test.cpp against std::exp). UncExp: the same for
// one double (lane 0 of the four: the same bits). UncAtan2: atan2 of one pair, absolute error below
// 1e-15 rad (against std::atan2).

#include <cmath>
#include <cstdint>
#include <cstring>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace isowrench {

typedef double UncMathV4 __attribute__((vector_size(32)));
typedef std::int64_t UncMathI4 __attribute__((vector_size(32)));
typedef double UncMathV4u __attribute__((vector_size(32), aligned(8), may_alias));

// out[0..3] = exp(in[0..3]). Pointers (any alignment), not vectors by value: a 32-byte vector
// passed or returned by value draws GCC's -Wpsabi note in the baseline build.
inline __attribute__((always_inline)) void UncExpLanes(const double* in, double* out) {
  UncMathV4 x = *reinterpret_cast<const UncMathV4u*>(in);
  // Beyond +-746 exp is 0 or infinite in doubles; the clamp keeps n in range (NaN stays NaN).
  x = x > 746.0 ? 746.0 : x;
  x = x < -746.0 ? -746.0 : x;
  // n = round(x / ln 2) by the 1.5 * 2^52 shift (exact: |x / ln 2| < 2^11); its bits hold n.
  const double shift = 6755399441055744.0;  // 0x1.8p52
  const UncMathV4 m = x * 1.4426950408889634073599 + shift;
  const UncMathV4 n = m - shift;
  // r = x - n ln 2 in two parts (C1 has few bits: n C1 is exact), |r| <= 0.35.
  x = x - n * 6.93145751953125E-1;
  x = x - n * 1.42860682030941723212E-6;
  const UncMathV4 xx = x * x;
  const UncMathV4 px = x * ((1.26177193074810590878E-4 * xx + 3.02994407707441961300E-2) * xx +
                            9.99999999999999999910E-1);
  const UncMathV4 qx = ((3.00198505138664455042E-6 * xx + 2.52448340349684104192E-3) * xx +
                        2.27265548208155028766E-1) *
                           xx +
                       2.00000000000000000009E0;
  const UncMathV4 e = 1.0 + 2.0 * (px / (qx - px));
  // 2^n in two exact steps (n1 + n2 = n, each within the normal exponents for |x| <= 746).
  UncMathI4 ni;
  std::memcpy(&ni, &m, sizeof ni);
  ni -= static_cast<std::int64_t>(0x4338000000000000ll);  // the bits of the shift
  const UncMathI4 n1 = ni >> 1;
  const UncMathI4 n2 = ni - n1;
  const UncMathI4 b1 = (n1 + 1023) << 52, b2 = (n2 + 1023) << 52;
  UncMathV4 s1, s2;
  std::memcpy(&s1, &b1, sizeof s1);
  std::memcpy(&s2, &b2, sizeof s2);
  *reinterpret_cast<UncMathV4u*>(out) = e * s1 * s2;
}

inline double UncExp(double x) {
  const double in[4] = {x, x, x, x};
  double out[4];
  UncExpLanes(in, out);
  return out[0];
}

// Lane helpers: the same source for a double (T = double, masks are bool) and four doubles
// (T = UncMathV4, masks are UncMathI4), so that every lane rounds as the scalar does. Results
// by reference: a 32-byte vector returned by value draws GCC's -Wpsabi note.
inline void UncAbs(double x, double& out) { out = std::fabs(x); }
inline void UncAbs(const UncMathV4& x, UncMathV4& out) {
  UncMathI4 b;
  std::memcpy(&b, &x, sizeof b);
  b &= 0x7fffffffffffffffll;
  std::memcpy(&out, &b, sizeof out);
}
inline void UncSignBit(double x, bool& out) { out = std::signbit(x); }
inline void UncSignBit(const UncMathV4& x, UncMathI4& out) {
  UncMathI4 b;
  std::memcpy(&b, &x, sizeof b);
  out = b < 0;
}
inline void UncSqrt(double x, double& out) { out = std::sqrt(x); }
inline void UncSqrt(const UncMathV4& x, UncMathV4& out) {
#if defined(__SSE2__)
  // sqrtpd (correctly rounded, as sqrtsd): two lanes per instruction, no errno branch.
  __m128d lo, hi;
  std::memcpy(&lo, &x, sizeof lo);
  std::memcpy(&hi, reinterpret_cast<const char*>(&x) + sizeof lo, sizeof hi);
  lo = _mm_sqrt_pd(lo);
  hi = _mm_sqrt_pd(hi);
  std::memcpy(&out, &lo, sizeof lo);
  std::memcpy(reinterpret_cast<char*>(&out) + sizeof lo, &hi, sizeof hi);
#else
  for (int l = 0; l < 4; ++l) out[l] = std::sqrt(x[l]);
#endif
}
template <class T>
struct UncMask {
  typedef bool type;
};
template <>
struct UncMask<UncMathV4> {
  typedef UncMathI4 type;
};

// atan2(y, x) for y >= 0 (or NaN) and any x (Cephes atan.c on t = y / |x|, every branch
// computed and the right one selected, so a lane and a scalar give the same bits).
template <class T>
inline void UncAtan2NonNegativeY(const T& y, const T& x, T& out) {
  constexpr double kMoreBits = 6.123233995736765886130E-17;  // pi/2 - double(pi/2)
  constexpr double kPiHi = 3.141592653589793116, kPiLo = 1.2246467991473532072e-16;
  T ax;
  UncAbs(x, ax);
  const T t0 = y / ax;                           // ax = 0: +inf (pi/2); y = 0: 0 (0 or pi below)
  const auto big = t0 > 2.41421356237309504880;  // tan(3 pi / 8)
  const auto mid = t0 > 0.66;
  const T t_big = -1.0 / t0, t_mid = (t0 - 1.0) / (t0 + 1.0);
  const T t = big ? t_big : mid ? t_mid : t0;
  const T y0 = big ? T{} + 1.57079632679489661923 : mid ? T{} + 0.78539816339744830962 : T{};
  const T extra = big ? T{} + kMoreBits : mid ? T{} + 0.5 * kMoreBits : T{};
  const T z = t * t;
  const T p = (((-8.750608600031904122785E-1 * z - 1.615753718733365076637E1) * z -
                7.500855792314704667340E1) *
                   z -
               1.228866684490136173410E2) *
                  z -
              6.485021904942025371773E1;
  const T q = ((((z + 2.485846490142306297962E1) * z + 1.650270098316988542046E2) * z +
                4.328810604912902668951E2) *
                   z +
               4.853903996359136964868E2) *
                  z +
              1.945506571482613964425E2;
  const T r = t * (z * p / q) + t;
  const T a = y0 + (r + extra);
  typename UncMask<T>::type x_negative;
  UncSignBit(x, x_negative);
  const T a_signed = x_negative ? (kPiHi - a) + kPiLo : a;
  const T zero_y = x_negative ? T{} + kPiHi : T{};
  out = y == 0.0 ? zero_y : a_signed;
}

// atan2(y, x) for finite or infinite y, x (the quadrant from the signs, as std::atan2; both
// infinite gives NaN, not +-pi/4).
inline double UncAtan2(double y, double x) {
  double a;
  UncAtan2NonNegativeY(std::fabs(y), x, a);
  return std::signbit(y) ? -a : a;
}

}  // namespace isowrench
