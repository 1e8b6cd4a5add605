#pragma once
// Private: the representation of a Function (src/model/function.cpp), for the engine's coupling
// step (src/fast/), which evaluates knot functions of four postures at once.

#include <cmath>
#include <vector>

#include "isowrench/function.hpp"

namespace isowrench {

struct Function::Impl {
  FunctionKind kind = FunctionKind::kConstant;
  double slope = 0.0;                // Linear
  double intercept = 0.0;            // Linear; the value of a Constant
  double scale = 1.0;                // Multiplier
  std::vector<Function> inner;       // Multiplier: exactly one
  std::vector<double> x, y;          // knots
  std::vector<double> b, c, d;       // per-knot polynomial coefficients (function.cpp)
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

/// The interval k (x[k] <= a <= x[k+1]) of a knot function, by OpenSim's bisection
/// (SimmSpline::calcValue): where a equals an interior knot, the bisection's order decides
/// between the two intervals that hold it.
inline int FindInterval(const std::vector<double>& x, double a) {
  const int n = static_cast<int>(x.size());
  if (n < 3) return 0;
  int i = 0, j = n, k = 0;
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
  return k;
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
    *value = s.y[end] + (a - x[end]) * s.b[end];
    *slope = s.b[end];
    if (second) *second = 0.0;
    return;
  }
  if (std::abs(a - x[0]) <= kKnotRoundoffError || std::abs(a - x[n - 1]) <= kKnotRoundoffError) {
    const int end = std::abs(a - x[0]) <= kKnotRoundoffError ? 0 : n - 1;
    *value = s.y[end];
    *slope = s.b[end];
    if (second) *second = 2.0 * s.c[end];
    return;
  }
  const int k = FindInterval(s.x, a);
  const double dx = a - x[k];
  *value = s.y[k] + dx * (s.b[k] + dx * (s.c[k] + dx * s.d[k]));
  *slope = s.b[k] + dx * (2.0 * s.c[k] + 3.0 * dx * s.d[k]);
  if (second) *second = 2.0 * s.c[k] + 6.0 * dx * s.d[k];
}

/// Value and first derivative of a knot function (KnotValues without the second).
inline void KnotValueAndSlope(const Function::Impl& s, double a, double* value, double* slope) {
  KnotValues(s, a, value, slope, nullptr);
}

}  // namespace isowrench
