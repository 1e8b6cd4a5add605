#pragma once
/// @file
/// Real functions of one variable, y = f(x), with OpenSim's exact semantics.
///
/// They describe couplings between joints and coordinates (q_joint = f(q_coordinate)) and
/// moving muscle points (one component of a point's position = f(q)). Each kind evaluates
/// exactly as the OpenSim class of the same name (opensim-core, OpenSim/Common/*.cpp):
///  - Constant: f = value.
///  - Linear (OpenSim LinearFunction): f = slope x + intercept.
///  - SimmSpline: the Forsythe-Malcolm-Moler cubic spline (NOT a natural spline). With four
///    or more knots the third derivative at each end equals that of the cubic through the four
///    end knots, so knots taken from any cubic reproduce it exactly; with three knots both end
///    intervals have equal second derivatives at their knots (the parabola through the three
///    knots); with two knots the straight line.
///  - NaturalCubicSpline: the classic natural cubic spline (second derivative 0 at both end
///    knots). Note: OpenSim 4.x reads an .osim element named `NaturalCubicSpline` as a
///    SimmSpline (RegisterTypes_osimCommon.cpp renames it); the importer follows OpenSim.
///  - PiecewiseLinear: straight segments between the knots.
///  - Polynomial: c_n x^n + ... + c_1 x + c_0, coefficients highest order first (OpenSim).
///  - Multiplier: scale * inner(x).
/// The knot-based kinds (SimmSpline, NaturalCubicSpline, PiecewiseLinear) extrapolate
/// LINEARLY outside [x_0, x_n-1] with the slope at the nearest end knot (second derivative 0
/// there), and an argument within 2e-13 of an end knot returns that knot's y exactly (and
/// the end knot's derivatives), as OpenSim does.
///
/// Units are those of the caller: for a coupling x is the coordinate (rad or m) and y the
/// joint position (rad or m); derivatives are dy/dx and d2y/dx2 in the matching units.

#include <memory>
#include <vector>

namespace isowrench {

/// The kind of a Function; names as in FunctionKindName().
enum class FunctionKind {
  kConstant,
  kLinear,
  kSimmSpline,
  kNaturalCubicSpline,
  kPiecewiseLinear,
  kPolynomial,
  kMultiplier
};

/// "constant", "linear", "simm_spline", "natural_cubic_spline", "piecewise_linear",
/// "polynomial", "multiplier" (the URDF extension element names without the prefix).
const char* FunctionKindName(FunctionKind kind);

/// An immutable real function of one variable y = f(x) with OpenSim's exact semantics (see
/// the file comment). Cheap to copy (shared immutable state), safe to evaluate from many
/// threads at once.
class Function {
 public:
  /// Constant(0).
  Function();

  /// f(x) = value. @throws isowrench::Error if value is NaN or infinite.
  static Function Constant(double value);
  /// f(x) = slope x + intercept. @throws isowrench::Error for a non-finite number.
  static Function Linear(double slope, double intercept);
  /// OpenSim SimmSpline through (x[i], y[i]).
  /// @throws isowrench::Error if x and y differ in length, fewer than 2 knots, a value is not
  ///         finite, or x is not strictly increasing (the message names the index and values).
  static Function SimmSpline(std::vector<double> x, std::vector<double> y);
  /// Natural cubic spline through (x[i], y[i]) (second derivative 0 at the end knots).
  /// @throws isowrench::Error as SimmSpline().
  static Function NaturalCubicSpline(std::vector<double> x, std::vector<double> y);
  /// Piecewise linear through (x[i], y[i]).
  /// @throws isowrench::Error as SimmSpline().
  static Function PiecewiseLinear(std::vector<double> x, std::vector<double> y);
  /// c_n x^n + ... + c_0 from coefficients {c_n, ..., c_1, c_0} (highest order first).
  /// @throws isowrench::Error if there is no coefficient or one is not finite.
  static Function Polynomial(std::vector<double> coefficients);
  /// scale * inner(x). @throws isowrench::Error if scale is not finite.
  static Function Multiplier(Function inner, double scale);

  /// f(x).
  double Value(double x) const;
  /// df/dx.
  double Derivative(double x) const;
  /// d2f/dx2.
  double SecondDerivative(double x) const;
  /// f(x) and df/dx at once (one interval search for the knot-based kinds): the same numbers
  /// as Value(x) and Derivative(x).
  void ValueAndDerivative(double x, double* value, double* derivative) const;

  FunctionKind kind() const;
  /// True for Constant, Linear, and a Multiplier of one of these (possibly nested): the
  /// function is slope x + intercept everywhere and can be written as a URDF <mimic>.
  bool is_linear() const;
  /// True when is_linear() with slope 1 and intercept 0 (the identity coupling).
  bool is_identity() const;
  /// Slope and intercept of a function with is_linear() (slope 0 for a Constant; for a
  /// Multiplier, scale times the inner one). Undefined (asserts) otherwise.
  double slope() const;
  double intercept() const;

  /// Knots of SimmSpline, NaturalCubicSpline and PiecewiseLinear (empty otherwise).
  const std::vector<double>& x() const;
  const std::vector<double>& y() const;
  /// Polynomial coefficients, highest order first (empty for other kinds).
  const std::vector<double>& coefficients() const;
  /// The scaled function of a Multiplier (Constant(0) for other kinds).
  const Function& inner() const;
  /// The factor of a Multiplier (1 for other kinds).
  double scale() const;

  struct Impl;  ///< private; defined in src/model/function_impl.hpp

 private:
  friend struct FunctionAccess;  // src/model/function_impl.hpp
  explicit Function(std::shared_ptr<const Impl> impl);
  std::shared_ptr<const Impl> impl_;
};

}  // namespace isowrench
