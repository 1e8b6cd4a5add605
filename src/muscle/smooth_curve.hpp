#pragma once
// Private: OpenSim's smooth segmented quintic Bezier curves (Common/SmoothSegmentedFunction,
// SmoothSegmentedFunctionFactory, SegmentedQuinticBezierToolkit) for the Millard2012 muscle
// curves, with the coefficients precomputed so that an evaluation allocates nothing.
//
// A curve is a chain of quintic Bezier segments (x(u), y(u)), u in [0, 1], each monotone in x,
// joined end to end over [x0, x1], and the straight lines y0 + slope0 (x - x0) left of x0 and
// y1 + slope1 (x - x1) right of x1. y(x) needs u(x): OpenSim fits a cubic spline of u(x) per
// segment and refines it by Newton's method to |x(u) - x| <= 100 eps (calcU); here a cubic
// Hermite guess from 33 exact samples per segment (error ~1e-9) is refined by Newton's method to
// machine precision (usually one step), so the values are those of the exact curve.

#include <array>
#include <string>

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

  /// Value and slope at x (linear extrapolation outside [x0, x1]); x must not be NaN.
  CurvePoint Evaluate(double x) const;

  int segment_count() const { return count_; }
  const ControlPoints& control_points(int i) const { return control_[i]; }
  double x0() const { return x0_; }
  double x1() const { return x1_; }

 private:
  static constexpr int kMaxSegments = 5;
  static constexpr int kGuessIntervals = 32;
  struct Segment {
    double x_begin = 0.0, x_end = 0.0, inv_step = 0.0;
    std::array<double, 6> x{}, y{};  // power-basis coefficients of x(u), y(u)
    std::array<double, kGuessIntervals + 1> u{}, dudx{};
  };
  std::array<Segment, kMaxSegments> segments_{};
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
