#pragma once
// Private: the representation of a Function (src/model/function.cpp), for the engine's coupling
// step (src/fast/), which evaluates knot functions of four postures at once.

#include <cmath>
#include <limits>
#include <vector>

#include "isowrench/function.hpp"

namespace isowrench {

struct Function::Impl {
  FunctionKind kind = FunctionKind::kConstant;
  double slope = 0.0;           // Linear
  double intercept = 0.0;       // Linear; the value of a Constant
  double scale = 1.0;           // Multiplier
  std::vector<Function> inner;  // Multiplier: exactly one
  std::vector<double> x, y;     // knots
  /// Per knot k, y_k and the coefficients of f = y_k + dx (b_k + dx (c_k + dx d_k)) on
  /// [x_k, x_k+1] (function.cpp), interleaved: y_k, b_k, c_k, d_k at 4 k .. 4 k + 3.
  std::vector<double> ybcd;
  std::vector<double> coefficients;  // Polynomial, highest order first
};

/// Whether f is a knot function (KnotValueAndSlope applies).
inline bool IsKnotFunction(FunctionKind kind) {
  return kind == FunctionKind::kSimmSpline || kind == FunctionKind::kNaturalCubicSpline ||
         kind == FunctionKind::kPiecewiseLinear;
}

/// Read-only access to a Function's representation.
struct FunctionAccess {
  static const Function::Impl& Of(const Function& f) { return *f.impl_; }
};

/// OpenSim's ROUNDOFF_ERROR (SimmMacros.h): an argument this close to an end knot snaps to it.
inline constexpr double kKnotRoundoffError = 0.0000000000002;

/// Knot functions with at most this many knots find their interval by a scan from the first.
inline constexpr int kScannedKnots = 32;

/// The first knot >= a, for x[0] < a < x[n-1] (a scan that x[n-1] > a ends): x[k+1] of
/// interval k (x[k] < a < x[k+1]) wherever a is not an interior knot.
inline const double* ScanAbove(const double* x, double a) {
  const double* above = x + 1;
  while (*above < a) ++above;
  return above;
}

/// The interval k (x[k] <= a <= x[k+1]) of a knot function for x[0] < a < x[n-1], as OpenSim's
/// bisection (SimmSpline::calcValue) finds it: up to kScannedKnots knots by ScanAbove; else,
/// and where a equals an interior knot, the bisection itself, whose order decides between the
/// two intervals that hold it.
inline int FindInterval(const std::vector<double>& x, double a) {
  const auto n = static_cast<unsigned>(x.size());
  if (n < 3) return 0;
  if (n <= kScannedKnots) {
    const double* above = ScanAbove(x.data(), a);
    if (*above != a) return static_cast<int>(above - x.data()) - 1;
  }
  unsigned i = 0, j = n, k = 0;  // (unsigned: the halving is one shift)
  while (true) {
    k = (i + j) / 2;
    if (a < x[k]) {
      j = k;
    } else if (a > x[k + 1]) {
      i = k;
    } else {
      break;
    }
  }
  return static_cast<int>(k);
}

/// The cubic of an interval at dx = a - x_k: p = its y_k, b_k, c_k, d_k (Function::Impl::ybcd).
inline void KnotPolynomial(const double* p, double dx, double* value, double* slope,
                           double* second) {
  *value = p[0] + dx * (p[1] + dx * (p[2] + dx * p[3]));
  *slope = p[1] + dx * (2.0 * p[2] + 3.0 * dx * p[3]);
  if (second) *second = 2.0 * p[2] + 6.0 * dx * p[3];
}

/// Value, first and (when `second` is not null) second derivative of a knot function
/// (SimmSpline, natural cubic spline, piecewise linear) at a, as OpenSim computes them: linear
/// extrapolation outside the knots, an end knot's value within kKnotRoundoffError of it, else
/// the polynomial of interval k (FindInterval).
inline void KnotValues(const Function::Impl& s, double a, double* value, double* slope,
                       double* second) {
  const double* x = s.x.data();
  const int n = static_cast<int>(s.x.size());
  if (a < x[0] || a > x[n - 1]) {
    const int end = a < x[0] ? 0 : n - 1;
    const double* e = s.ybcd.data() + 4 * end;
    *value = e[0] + (a - x[end]) * e[1];
    *slope = e[1];
    if (second) *second = 0.0;
    return;
  }
  if (std::abs(a - x[0]) <= kKnotRoundoffError || std::abs(a - x[n - 1]) <= kKnotRoundoffError) {
    const int end = std::abs(a - x[0]) <= kKnotRoundoffError ? 0 : n - 1;
    const double* e = s.ybcd.data() + 4 * end;
    *value = e[0];
    *slope = e[1];
    if (second) *second = 2.0 * e[2];
    return;
  }
  const int k = FindInterval(s.x, a);
  KnotPolynomial(s.ybcd.data() + 4 * k, a - x[k], value, slope, second);
}

/// A knot function of 3 to kScannedKnots knots as the engine's coupling step reads it (x: the
/// knots, ybcd: Function::Impl::ybcd), so that the common case is evaluated inline:
/// KnotValueAndSlope's result for a in (lower, upper), two kKnotRoundoffError inside the end
/// knots, and not an interior knot. The range is empty for any other function.
struct KnotScan {
  const double* x = nullptr;
  const double* ybcd = nullptr;
  double lower = std::numeric_limits<double>::infinity();
  double upper = -std::numeric_limits<double>::infinity();
  KnotScan() = default;
  explicit KnotScan(const Function::Impl& f) {
    if (!IsKnotFunction(f.kind) || f.x.size() < 3 || f.x.size() > kScannedKnots) return;
    x = f.x.data();
    ybcd = f.ybcd.data();
    lower = f.x.front() + 2 * kKnotRoundoffError;
    upper = f.x.back() - 2 * kKnotRoundoffError;
  }
  /// Writes value and slope and returns true in the common case; else returns false (nothing
  /// written: evaluate the function).
  bool ValueAndSlope(double a, double* value, double* slope) const {
    // a > lower makes KnotValues' a - x[0] (as computed) exceed kKnotRoundoffError: the
    // computed difference does not decrease as a grows, and at a = lower (x[0] + 2
    // kKnotRoundoffError, rounded) it exceeds kKnotRoundoffError where half an ulp of x[0] is
    // below kKnotRoundoffError; elsewhere a > lower >= x[0] puts a an ulp of x[0] (>= 2
    // kKnotRoundoffError) or more above x[0]. Likewise at the last knot. (NaN fails both.)
    if (!(a > lower && a < upper)) return false;
    const double* above = ScanAbove(x, a);
    if (*above == a) return false;
    KnotPolynomial(ybcd + 4 * (above - x - 1), a - above[-1], value, slope, nullptr);
    return true;
  }
};

/// Value and first derivative of a knot function (KnotValues without the second).
inline void KnotValueAndSlope(const Function::Impl& s, double a, double* value, double* slope) {
  KnotValues(s, a, value, slope, nullptr);
}

}  // namespace isowrench
