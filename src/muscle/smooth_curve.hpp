#pragma once
// Private: OpenSim's smooth segmented quintic Bezier curves (Common/SmoothSegmentedFunction,
// SmoothSegmentedFunctionFactory, SegmentedQuinticBezierToolkit) for the Millard2012 muscle
// curves, with the coefficients precomputed so that an evaluation allocates nothing.
//
// A curve is a chain of quintic Bezier segments (x(u), y(u)), u in [0, 1], each monotone in x,
// joined end to end over [x0, x1], and the straight lines y0 + slope0 (x - x0) left of x0 and
// y1 + slope1 (x - x1) right of x1. y(x) needs u(x): OpenSim fits a cubic spline of u(x) per
// segment and refines it by Newton's method to |x(u) - x| <= 100 eps (calcU); here a quintic
// Hermite guess from u, du/dx and d2u/dx2 at 65 exact samples per segment (error up to ~4e-7,
// mostly far less) is refined by one Newton step to machine precision (more steps only where
// that step exceeds 1e-8, which the table's accuracy makes rare: one end of the active curve),
// so the values are those of the exact curve.
//
// Three evaluations share that u(x), so they give the same value to the last bit: Evaluate
// (value and exact slope), Value (value only: the rigid tendon's force) and SolveEvaluate (value
// and a slope from dx/du before the Newton step, ~1e-9 relative: the equilibrium iteration's
// Newton slope, one polynomial fewer).

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <string>
#include <vector>

#include "isowrench/muscle.hpp"

namespace isowrench::muscle {

/// Control points of one quintic Bezier segment (Bernstein basis).
struct ControlPoints {
  std::array<double, 6> x{}, y{};
};

/// SegmentedQuinticBezierToolkit::calcQuinticBezierCornerControlPoints: the C-shaped corner
/// from (x0, y0) with slope dydx0 to (x1, y1) with slope dydx1, `curviness` in [0, 1] (already
/// scaled by SmoothSegmentedFunctionFactory::scaleCurviness). Returns false (OpenSim throws)
/// when the two tangent lines do not make a C-shaped corner.
bool CornerControlPoints(double x0, double y0, double dydx0, double x1, double y1, double dydx1,
                         double curviness, ControlPoints* out);

/// Bernstein-form value of a quintic at u (de Casteljau): an independent evaluation for tests.
double BezierValue(const std::array<double, 6>& points, double u);

class SmoothCurve {
 public:
  SmoothCurve() = default;
  /// Segments joined end to end; x0 = first segment's first x, x1 = last segment's last x.
  SmoothCurve(const ControlPoints* segments, int count, double y0, double y1, double slope0,
              double slope1);

  /// Value and slope at x (linear extrapolation outside [x0, x1]; NaN for NaN).
  CurvePoint Evaluate(double x) const {
    if (!(x >= x0_)) return {y0_ + slope0_ * (x - x0_), slope0_};
    if (x > x1_) return {y1_ + slope1_ * (x - x1_), slope1_};
    const Segment& g = Find(x);
    double dxdu = 0.0;
    const double u = U(g, x, &dxdu);
    // calcQuinticBezierCurveDerivDYDX: dy/dx = (dy/du) / (dx/du), dx/du at the solved u.
    dxdu = Slope(g.dx, u);
    return {Poly(g.y, u), dxdu > 0.0 ? Slope(g.dy, u) / dxdu : 0.0};
  }
  /// Evaluate(x).value, without the slope.
  double Value(double x) const {
    if (!(x >= x0_)) return y0_ + slope0_ * (x - x0_);
    if (x > x1_) return y1_ + slope1_ * (x - x1_);
    const Segment& g = Find(x);
    double dxdu = 0.0;
    return Poly(g.y, U(g, x, &dxdu));
  }
  /// Evaluate(x).value, and the slope with dx/du taken before the last Newton step of u(x)
  /// (relative error ~ |x''/x'| |du|, about 1e-10): for Newton iterations on the curve, where
  /// the slope only steers.
  CurvePoint SolveEvaluate(double x) const {
    if (!(x >= x0_)) return {y0_ + slope0_ * (x - x0_), slope0_};
    if (x > x1_) return {y1_ + slope1_ * (x - x1_), slope1_};
    const Segment& g = Find(x);
    double dxdu = 0.0;
    const double u = U(g, x, &dxdu);
    return {Poly(g.y, u), dxdu > 0.0 ? Slope(g.dy, u) / dxdu : 0.0};
  }

  int segment_count() const { return count_; }
  const ControlPoints& control_points(int i) const { return control_[i]; }
  double x0() const { return x0_; }
  double x1() const { return x1_; }

 private:
  static constexpr int kMaxSegments = 5;
  static constexpr int kGuessIntervals = 64;
  struct Segment {
    double x_begin = 0.0, x_end = 0.0, inv_step = 0.0;
    std::array<double, 6> x{}, y{};    // power-basis coefficients of x(u), y(u)
    std::array<double, 5> dx{}, dy{};  // of dx/du, dy/du (k a_k)
    // The quintic Hermite guess of u on interval k as a quintic in r = t - k:
    // guess[6k + i] r^i; interval kGuessIntervals (t rounded to it at x = x_end) is u's
    // Taylor polynomial there.
    std::array<double, 6 * (kGuessIntervals + 1)> guess{};
  };

  static double Poly(const std::array<double, 6>& a, double u) {
    return ((((a[5] * u + a[4]) * u + a[3]) * u + a[2]) * u + a[1]) * u + a[0];
  }
  static double Slope(const std::array<double, 5>& b, double u) {
    return (((b[4] * u + b[3]) * u + b[2]) * u + b[1]) * u + b[0];
  }
  // calcIndex: the segment with x_begin <= x < x_end (the last one for x = x1): the number
  // of inner segment ends at or before x, without a loop (ends_ past the last are +inf).
  const Segment& Find(double x) const {
    int s = x >= ends_[0];
    if (count_ > 2) s += (x >= ends_[1]) + (x >= ends_[2]) + (x >= ends_[3]);
    return segments_[static_cast<std::size_t>(s)];
  }
  // calcU: u in [0, 1] with x(u) = x on segment g (x in [x_begin, x_end]); *dxdu: dx/du at
  // the u before the last Newton step.
  double U(const Segment& g, double x, double* dxdu) const {
    const double t = (x - g.x_begin) * g.inv_step;  // in [0, kGuessIntervals (1 + 2 eps)]
    const int k = static_cast<int>(t);
    const double r = t - k;
    const double* c = &g.guess[6 * static_cast<std::size_t>(k)];
    // (No clamp to [0, 1]: the guess is within ~4e-7 of u in [0, 1], and the polynomials are
    // as good just outside; at a knot it is the knot's exact u, 0 at a segment's start.)
    const double u = ((((c[5] * r + c[4]) * r + c[3]) * r + c[2]) * r + c[1]) * r + c[0];
    const double d = Slope(g.dx, u);
    const double du = (Poly(g.x, u) - x) / d;
    // Newton converges quadratically: after a step du the error in u is about
    // |x''/(2 x')| du^2, below 1e-15 once |du| <= 1e-8 (x''/x' is O(1) to O(10) on these
    // corners), so that step is the last. (d > 0 on a corner segment; not: Converge.)
    if (!(std::abs(du) <= 1e-8)) return Converge(g, x, u, dxdu);
    *dxdu = d;
    return std::min(u - du, 1.0);  // (x = x1: exactly the curve's end)
  }
  // Newton's method from u until a step is at most 1e-8 (a guess too far for one step).
  double Converge(const Segment& g, double x, double u, double* dxdu) const;

  std::vector<Segment> segments_;  // (sized once: an evaluation allocates nothing)
  // x_end of segments 0 .. count - 2, then +inf.
  std::array<double, kMaxSegments - 1> ends_{};
  std::array<ControlPoints, kMaxSegments> control_{};
  int count_ = 0;
  double x0_ = 0.0, x1_ = 0.0, y0_ = 0.0, y1_ = 0.0, slope0_ = 0.0, slope1_ = 0.0;
};

// Factories (SmoothSegmentedFunctionFactory). Each checks OpenSim's conditions and throws
// isowrench::Error "muscle 'NAME': <what> ..." naming the property and value.

/// createFiberActiveForceLengthCurve(x0, x1, 1, x3, ylow = minimum_value, dydx, curviness 1).
SmoothCurve ActiveForceLengthCurve(const ActiveForceLengthCurveSpec& spec, double minimum_value,
                                   const std::string& muscle);
/// createFiberForceLengthCurve(e0, e1, kLow, kIso, curviness) with OpenSim's defaults for the
/// optional properties.
SmoothCurve FiberForceLengthCurve(const FiberForceLengthCurveSpec& spec, const std::string& muscle);
/// createTendonForceLengthCurve(eIso, kIso, fToe, curviness) with OpenSim's defaults for the
/// optional properties.
SmoothCurve TendonForceLengthCurve(const TendonForceLengthCurveSpec& spec,
                                   const std::string& muscle);

}  // namespace isowrench::muscle
