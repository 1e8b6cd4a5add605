// Quintic Bezier muscle curves: a port of opensim-core's SegmentedQuinticBezierToolkit
// (calcQuinticBezierCornerControlPoints, calcIndex, calcU), SmoothSegmentedFunction
// (calcSelectedDerivatives) and SmoothSegmentedFunctionFactory (createFiberActiveForceLength-
// Curve, createFiberForceLengthCurve, createTendonForceLengthCurve) and of the default rules of
// ActiveForceLengthCurve, FiberForceLengthCurve and TendonForceLengthCurve (OpenSim/Actuators).
// opensim-core is Apache-2.0; this follows its algorithms at commit 0435b081d.

#include "muscle/smooth_curve.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "isowrench/error.hpp"
#include "util/text.hpp"

namespace isowrench::muscle {
namespace {

constexpr double kCurveEps = std::numeric_limits<double>::epsilon();

// SmoothSegmentedFunctionFactory::scaleCurviness.
double ScaleCurviness(double curviness) { return 0.1 + 0.8 * curviness; }

std::string CurveNumber(double v) { return util::FormatNumber(v, 6); }

[[noreturn]] void CurveFail(const std::string& muscle, const std::string& curve,
                            const std::string& what) {
  throw Error("muscle '" + muscle + "': " + curve + ": " + what);
}

// Bernstein coefficients -> power basis: B(u) = sum_k a_k u^k.
std::array<double, 6> PowerBasis(const std::array<double, 6>& p) {
  return {p[0],
          5.0 * (p[1] - p[0]),
          10.0 * (p[2] - 2.0 * p[1] + p[0]),
          10.0 * (p[3] - 3.0 * p[2] + 3.0 * p[1] - p[0]),
          5.0 * (p[4] - 4.0 * p[3] + 6.0 * p[2] - 4.0 * p[1] + p[0]),
          p[5] - 5.0 * p[4] + 10.0 * p[3] - 10.0 * p[2] + 5.0 * p[1] - p[0]};
}

inline double Poly(const std::array<double, 6>& a, double u) {
  return ((((a[5] * u + a[4]) * u + a[3]) * u + a[2]) * u + a[1]) * u + a[0];
}

inline double PolySlope(const std::array<double, 6>& a, double u) {
  return (((5.0 * a[5] * u + 4.0 * a[4]) * u + 3.0 * a[3]) * u + 2.0 * a[2]) * u + a[1];
}

inline double PolyCurvature(const std::array<double, 6>& a, double u) {
  return ((20.0 * a[5] * u + 12.0 * a[4]) * u + 6.0 * a[3]) * u + 2.0 * a[2];
}

// u in [0, 1] with x(u) = x, by bisection polished by Newton (construction only).
double SolveU(const std::array<double, 6>& a, double x) {
  double lo = 0.0, hi = 1.0;
  for (int i = 0; i < 200 && hi - lo > 4 * kCurveEps; ++i) {
    const double mid = 0.5 * (lo + hi);
    (Poly(a, mid) < x ? lo : hi) = mid;
  }
  double u = 0.5 * (lo + hi);
  for (int i = 0; i < 3; ++i) {
    const double d = PolySlope(a, u);
    if (!(d > 0.0)) break;
    u = std::clamp(u - (Poly(a, u) - x) / d, lo, hi);
  }
  return u;
}

}  // namespace

bool CornerControlPoints(double x0, double y0, double dydx0, double x1, double y1, double dydx1,
                         double curviness, ControlPoints* out) {
  // 1. Where the two tangent lines intersect (their mean x when they are parallel).
  const double root_eps = std::sqrt(kCurveEps);
  double xC = 0.0;
  if (std::abs(dydx0 - dydx1) > root_eps) {
    xC = (y1 - y0 - x1 * dydx1 + x0 * dydx0) / (dydx0 - dydx1);
  } else {
    xC = (x1 + x0) / 2;
  }
  const double yC = (xC - x1) * dydx1 + y1;
  // 2. A C-shaped corner: the chord is longer than either side to the intersection.
  const double xCx0 = xC - x0, yCy0 = yC - y0, xCx1 = xC - x1, yCy1 = yC - y1;
  const double x0x1 = x1 - x0, y0y1 = y1 - y0;
  const double a = xCx0 * xCx0 + yCy0 * yCy0;
  const double b = xCx1 * xCx1 + yCy1 * yCy1;
  const double c = x0x1 * x0x1 + y0y1 * y0y1;
  if (!(c > a && c > b) || !(curviness >= 0 && curviness <= 1)) return false;
  // 3. The "original code" midpoints (two localized corners).
  const double x0_mid = x0 + curviness * xCx0, y0_mid = y0 + curviness * yCy0;
  const double x1_mid = x1 + curviness * xCx1, y1_mid = y1 + curviness * yCy1;
  out->x = {x0, x0_mid, x0_mid, x1_mid, x1_mid, x1};
  out->y = {y0, y0_mid, y0_mid, y1_mid, y1_mid, y1};
  return true;
}

double BezierValue(const std::array<double, 6>& points, double u) {
  std::array<double, 6> p = points;
  for (int level = 5; level > 0; --level) {
    for (int i = 0; i < level; ++i) p[i] = (1.0 - u) * p[i] + u * p[i + 1];
  }
  return p[0];
}

SmoothCurve::SmoothCurve(const ControlPoints* segments, int count, double y0, double y1,
                         double slope0, double slope1)
    : segments_(static_cast<std::size_t>(count)),
      count_(count),
      y0_(y0),
      y1_(y1),
      slope0_(slope0),
      slope1_(slope1) {
  for (int s = 0; s < count; ++s) {
    control_[s] = segments[s];
    Segment& g = segments_[static_cast<std::size_t>(s)];
    g.x = PowerBasis(segments[s].x);
    g.y = PowerBasis(segments[s].y);
    for (int k = 0; k < 5; ++k) {
      g.dx[k] = (k + 1) * g.x[k + 1];
      g.dy[k] = (k + 1) * g.y[k + 1];
    }
    g.x_begin = segments[s].x[0];
    g.x_end = segments[s].x[5];
    const double step = (g.x_end - g.x_begin) / kGuessIntervals;
    g.inv_step = 1.0 / step;
    // Exact u, du/dx and d2u/dx2 = -x''(u) / x'(u)^3 at the 129 knots, then each interval's
    // quintic Hermite guess in r (per unit r: du/dr = step du/dx, d2u/dr2 = step^2 d2u/dx2).
    std::array<double, kGuessIntervals + 1> u{}, m{}, c2{};
    for (int j = 0; j <= kGuessIntervals; ++j) {
      const double x = j == kGuessIntervals ? g.x_end : g.x_begin + j * step;
      u[j] = j == 0 ? 0.0 : j == kGuessIntervals ? 1.0 : SolveU(g.x, x);
      const double d = PolySlope(g.x, u[j]);
      if (d > 1e-12) {  // (else: the guess uses no derivatives there)
        const double dd = PolyCurvature(g.x, u[j]);
        m[j] = step / d;
        c2[j] = -dd / (d * d * d) * step * step;
      }
    }
    for (int j = 0; j < kGuessIntervals; ++j) {
      // p(r) = sum c_i r^i with p, p', p'' equal to u, m, c2 at r = 0 and r = 1.
      const double A = u[j + 1] - u[j] - m[j] - 0.5 * c2[j];
      const double B = m[j + 1] - m[j] - c2[j];
      const double C = c2[j + 1] - c2[j];
      double* c = &g.guess[6 * static_cast<std::size_t>(j)];
      c[0] = u[j];
      c[1] = m[j];
      c[2] = 0.5 * c2[j];
      c[3] = 10.0 * A - 4.0 * B + 0.5 * C;
      c[4] = -15.0 * A + 7.0 * B - C;
      c[5] = 6.0 * A - 3.0 * B + 0.5 * C;
    }
    double* end = &g.guess[6 * static_cast<std::size_t>(kGuessIntervals)];
    end[0] = u[kGuessIntervals];
    end[1] = m[kGuessIntervals];
    end[2] = 0.5 * c2[kGuessIntervals];
    g.packed[kLaneBegin] = g.x_begin;
    g.packed[kLaneInvStep] = g.inv_step;
    for (int k = 0; k < 6; ++k) {
      g.packed[static_cast<std::size_t>(kLaneX + k)] = g.x[k];
      g.packed[static_cast<std::size_t>(kLaneY + k)] = g.y[k];
    }
    for (int k = 0; k < 5; ++k) {
      g.packed[static_cast<std::size_t>(kLaneDx + k)] = g.dx[k];
      g.packed[static_cast<std::size_t>(kLaneDy + k)] = g.dy[k];
    }
    for (std::size_t k = 0; k < g.packed.size(); ++k) {
      const double v = g.packed[k];
      g.splat[k] = LaneDoubles{v, v, v, v};
    }
  }
  x0_ = segments[0].x[0];
  x1_ = segments[count - 1].x[5];
  for (int s = 0; s + 1 < kMaxSegments; ++s) {
    ends_[static_cast<std::size_t>(s)] =
        s + 1 < count ? segments[s].x[5] : std::numeric_limits<double>::infinity();
  }
  auto splat = [](double v) { return LaneDoubles{v, v, v, v}; };
  lane_.x0 = splat(x0_);
  lane_.x1 = splat(x1_);
  for (int s = 0; s + 1 < kMaxSegments; ++s)
    lane_.ends[s] = splat(ends_[static_cast<std::size_t>(s)]);
  lane_.y0 = splat(y0_);
  lane_.slope0 = splat(slope0_);
  lane_.y1 = splat(y1_);
  lane_.slope1 = splat(slope1_);
  lane_.step_limit = splat(1e-8);
  lane_.one = splat(1.0);
  const long long magnitude = 0x7fffffffffffffffLL;
  lane_.magnitude = LaneMasks{magnitude, magnitude, magnitude, magnitude};
}

CurvePoint SmoothCurve::ScalarLane(double x, bool slope) const {
  if (slope) return SolveEvaluate(x);
  return {Value(x), 0.0};
}

double SmoothCurve::Converge(const Segment& g, double x, double u, double* dxdu) const {
  double d = Slope(g.dx, u);
  *dxdu = d;
  for (int i = 0; i < 8; ++i) {
    if (!(d > 0.0)) break;
    const double du = (Poly(g.x, u) - x) / d;
    *dxdu = d;
    u = std::clamp(u - du, 0.0, 1.0);
    d = Slope(g.dx, u);
    if (std::abs(du) <= 1e-8) break;
  }
  return u;
}

SmoothCurve ActiveForceLengthCurve(const ActiveForceLengthCurveSpec& spec, double ylow,
                                   const std::string& muscle) {
  const char* curve = "ActiveForceLengthCurve";
  const double x0 = spec.min_norm_active_fiber_length;
  const double x1 = spec.transition_norm_fiber_length;
  const double x2 = 1.0;
  const double x3 = spec.max_norm_active_fiber_length;
  const double dydx = spec.shallow_ascending_slope;
  for (const auto& [name, v] : {std::pair<const char*, double>{"min_norm_active_fiber_length", x0},
                                {"transition_norm_fiber_length", x1},
                                {"max_norm_active_fiber_length", x3},
                                {"shallow_ascending_slope", dydx},
                                {"minimum_value", ylow}}) {
    if (!std::isfinite(v)) CurveFail(muscle, curve, std::string(name) + " is not finite");
  }
  // createFiberActiveForceLengthCurve's checks.
  const double root_eps = std::sqrt(kCurveEps);
  if (!(x0 >= 0 && x1 > x0 + root_eps && x2 > x1 + root_eps && x3 > x2 + root_eps)) {
    CurveFail(muscle, curve,
              "min_norm_active_fiber_length " + CurveNumber(x0) +
                  ", transition_norm_fiber_length " + CurveNumber(x1) +
                  ", 1 (optimal) and max_norm_active_fiber_length " + CurveNumber(x3) +
                  " must increase (OpenSim: 0 <= lce0 < lce1 < lce2 = 1 < lce3, each step > "
                  "1.5e-8)");
  }
  if (!(ylow >= 0)) {
    CurveFail(muscle, curve, "minimum_value " + CurveNumber(ylow) + " must be >= 0");
  }
  const double dydx_upper = (1 - ylow) / (x2 - x1);
  if (!(dydx >= 0 && dydx < dydx_upper)) {
    CurveFail(muscle, curve,
              "shallow_ascending_slope " + CurveNumber(dydx) + " must be >= 0 and < " +
                  CurveNumber(dydx_upper) +
                  " ((1 - minimum_value) / (1 - transition_norm_fiber_length))");
  }
  const double c = ScaleCurviness(1.0);
  const double xDelta = 0.05 * x2;
  const double xs = x2 - xDelta;
  const double y0 = 0, dydx0 = 0;
  const double y1 = 1 - dydx * (xs - x1);
  const double dydx01 = 1.25 * (y1 - y0) / (x1 - x0);
  const double x01 = x0 + 0.5 * (x1 - x0);
  const double y01 = y0 + 0.5 * (y1 - y0);
  const double x1s = x1 + 0.5 * (xs - x1);
  const double y1s = y1 + 0.5 * (1 - y1);
  const double dydx1s = dydx;
  const double y2 = 1, dydx2 = 0;
  const double y3 = 0, dydx3 = 0;
  const double x23 = (x2 + xDelta) + 0.5 * (x3 - (x2 + xDelta));
  const double y23 = y2 + 0.5 * (y3 - y2);
  const double dydx23 = (y3 - y2) / ((x3 - xDelta) - (x2 + xDelta));
  ControlPoints p[5];
  const bool ok = CornerControlPoints(x0, ylow, dydx0, x01, y01, dydx01, c, &p[0]) &&
                  CornerControlPoints(x01, y01, dydx01, x1s, y1s, dydx1s, c, &p[1]) &&
                  CornerControlPoints(x1s, y1s, dydx1s, x2, y2, dydx2, c, &p[2]) &&
                  CornerControlPoints(x2, y2, dydx2, x23, y23, dydx23, c, &p[3]) &&
                  CornerControlPoints(x23, y23, dydx23, x3, ylow, dydx3, c, &p[4]);
  if (!ok) {
    CurveFail(muscle, curve,
              "these parameters do not make C-shaped Bezier corners (OpenSim "
              "SegmentedQuinticBezierToolkit::calcQuinticBezierCornerControlPoints refuses them)");
  }
  return SmoothCurve(p, 5, ylow, ylow, 0.0, 0.0);
}

SmoothCurve FiberForceLengthCurve(const FiberForceLengthCurveSpec& spec,
                                  const std::string& muscle) {
  const char* curve = "FiberForceLengthCurve";
  const int given = spec.stiffness_at_low_force.has_value() +
                    spec.stiffness_at_one_norm_force.has_value() + spec.curviness.has_value();
  if (given != 0 && given != 3) {
    CurveFail(muscle, curve,
              "stiffness_at_low_force, stiffness_at_one_norm_force and curviness must all be set "
              "or all be empty (OpenSim FiberForceLengthCurve::ensureCurveUpToDate)");
  }
  const double eZero = spec.strain_at_zero_force, eIso = spec.strain_at_one_norm_force;
  // createFiberForceLengthCurve's first check (before the defaults divide by e1 - e0).
  if (!(eIso > eZero) || !std::isfinite(eIso) || !std::isfinite(eZero)) {
    CurveFail(muscle, curve,
              "strain_at_one_norm_force " + CurveNumber(eIso) +
                  " must be greater than strain_at_zero_force " + CurveNumber(eZero));
  }
  // FiberForceLengthCurve::ensureCurveUpToDate defaults.
  const double kIso = given ? *spec.stiffness_at_one_norm_force : 2.0 / (eIso - eZero);
  const double kLow = given ? *spec.stiffness_at_low_force : 0.2;
  const double curviness = given ? *spec.curviness : 0.75;
  for (const auto& [name, v] : {std::pair<const char*, double>{"strain_at_zero_force", eZero},
                                {"strain_at_one_norm_force", eIso},
                                {"stiffness_at_low_force", kLow},
                                {"stiffness_at_one_norm_force", kIso},
                                {"curviness", curviness}}) {
    if (!std::isfinite(v)) CurveFail(muscle, curve, std::string(name) + " is not finite");
  }
  // createFiberForceLengthCurve's other checks.
  if (!(kIso > 1.0 / (eIso - eZero))) {
    CurveFail(muscle, curve,
              "stiffness_at_one_norm_force " + CurveNumber(kIso) + " must be greater than " +
                  CurveNumber(1.0 / (eIso - eZero)) +
                  " (1 / (strain_at_one_norm_force - strain_at_zero_force))");
  }
  if (!(kLow > 0.0 && kLow < 1.0 / (eIso - eZero))) {
    CurveFail(muscle, curve,
              "stiffness_at_low_force " + CurveNumber(kLow) + " must be > 0 and < " +
                  CurveNumber(1.0 / (eIso - eZero)) +
                  " (1 / (strain_at_one_norm_force - strain_at_zero_force))");
  }
  if (!(curviness >= 0 && curviness <= 1)) {
    CurveFail(muscle, curve, "curviness " + CurveNumber(curviness) + " must be in [0, 1]");
  }
  const double c = ScaleCurviness(curviness);
  const double xZero = 1 + eZero, yZero = 0;
  const double xIso = 1 + eIso, yIso = 1;
  const double deltaX = std::min(0.1 * (1.0 / kIso), 0.1 * (xIso - xZero));
  const double xLow = xZero + deltaX;
  const double xfoot = xZero + 0.5 * (xLow - xZero);
  const double yfoot = 0;
  const double yLow = yfoot + kLow * (xLow - xfoot);
  ControlPoints p[2];
  if (!CornerControlPoints(xZero, yZero, 0, xLow, yLow, kLow, c, &p[0]) ||
      !CornerControlPoints(xLow, yLow, kLow, xIso, yIso, kIso, c, &p[1])) {
    CurveFail(muscle, curve,
              "these parameters do not make C-shaped Bezier corners (OpenSim "
              "SegmentedQuinticBezierToolkit::calcQuinticBezierCornerControlPoints refuses them)");
  }
  return SmoothCurve(p, 2, yZero, yIso, 0.0, kIso);
}

SmoothCurve TendonForceLengthCurve(const TendonForceLengthCurveSpec& spec,
                                   const std::string& muscle) {
  const char* curve = "TendonForceLengthCurve";
  const int given = spec.stiffness_at_one_norm_force.has_value() +
                    spec.norm_force_at_toe_end.has_value() + spec.curviness.has_value();
  if (given != 0 && given != 3) {
    CurveFail(muscle, curve,
              "stiffness_at_one_norm_force, norm_force_at_toe_end and curviness must all be set or "
              "all be empty (OpenSim TendonForceLengthCurve::ensureCurveUpToDate)");
  }
  const double eIso = spec.strain_at_one_norm_force;
  // createTendonForceLengthCurve's first check (before the defaults divide by it).
  if (!(eIso > 0) || !std::isfinite(eIso)) {
    CurveFail(muscle, curve, "strain_at_one_norm_force " + CurveNumber(eIso) + " must be > 0");
  }
  // TendonForceLengthCurve::ensureCurveUpToDate defaults.
  const double kIso = given ? *spec.stiffness_at_one_norm_force : 1.375 / eIso;
  const double fToe = given ? *spec.norm_force_at_toe_end : 2.0 / 3.0;
  const double curviness = given ? *spec.curviness : 0.5;
  for (const auto& [name, v] : {std::pair<const char*, double>{"strain_at_one_norm_force", eIso},
                                {"stiffness_at_one_norm_force", kIso},
                                {"norm_force_at_toe_end", fToe},
                                {"curviness", curviness}}) {
    if (!std::isfinite(v)) CurveFail(muscle, curve, std::string(name) + " is not finite");
  }
  // createTendonForceLengthCurve's other checks.
  if (!(fToe > 0 && fToe < 1)) {
    CurveFail(muscle, curve, "norm_force_at_toe_end " + CurveNumber(fToe) + " must be > 0 and < 1");
  }
  if (!(kIso > 1 / eIso)) {
    CurveFail(muscle, curve,
              "stiffness_at_one_norm_force " + CurveNumber(kIso) + " must be greater than " +
                  CurveNumber(1 / eIso) + " (1 / strain_at_one_norm_force)");
  }
  if (!(curviness >= 0 && curviness <= 1)) {
    CurveFail(muscle, curve, "curviness " + CurveNumber(curviness) + " must be in [0, 1]");
  }
  const double c = ScaleCurviness(curviness);
  const double x0 = 1.0, y0 = 0, dydx0 = 0;
  const double xIso = 1.0 + eIso, yIso = 1, dydxIso = kIso;
  const double yToe = fToe;
  const double xToe = (yToe - 1) / kIso + xIso;
  const double xFoot = 1.0 + (xToe - 1.0) / 10.0;
  const double yFoot = 0;
  const double yToeMid = yToe * 0.5;
  const double xToeMid = (yToeMid - yIso) / kIso + xIso;
  const double dydxToeMid = (yToeMid - yFoot) / (xToeMid - xFoot);
  const double xToeCtrl = xFoot + 0.5 * (xToeMid - xFoot);
  const double yToeCtrl = yFoot + dydxToeMid * (xToeCtrl - xFoot);
  ControlPoints p[2];
  if (!CornerControlPoints(x0, y0, dydx0, xToeCtrl, yToeCtrl, dydxToeMid, c, &p[0]) ||
      !CornerControlPoints(xToeCtrl, yToeCtrl, dydxToeMid, xToe, yToe, dydxIso, c, &p[1])) {
    CurveFail(muscle, curve,
              "these parameters do not make C-shaped Bezier corners (OpenSim "
              "SegmentedQuinticBezierToolkit::calcQuinticBezierCornerControlPoints refuses them)");
  }
  return SmoothCurve(p, 2, y0, yToe, dydx0, dydxIso);
}

}  // namespace isowrench::muscle
