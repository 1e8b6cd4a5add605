// isowrench::Function: OpenSim's one-variable functions, evaluated as opensim-core does.
//
// The knot-based kinds share one representation: on interval k (x[k] <= x <= x[k+1])
//   f(x) = y[k] + dx (b[k] + dx (c[k] + dx d[k])),  dx = x - x[k],
// and outside the knots f extrapolates linearly with b[0] / b[n-1], exactly as
// OpenSim/Common/SimmSpline.cpp and PiecewiseLinearFunction.cpp (calcValue, calcDerivative).
// The SimmSpline coefficients are computed by the same Forsythe-Malcolm-Moler algorithm as
// SimmSpline::calcCoefficients, step for step, so the results agree to the last bit.

#include "isowrench/function.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <string>

#include "isowrench/error.hpp"
#include "model/function_impl.hpp"
#include "util/text.hpp"

namespace isowrench {

namespace {

// OpenSim/Common/SimmMacros.h: TINY_NUMBER bounds knot spacing from below in the coefficient
// computations (ROUNDOFF_ERROR, the distance within which an argument snaps to an end knot, is
// kKnotRoundoffError of function_impl.hpp).
constexpr double kTinyNumber = 0.0000001;

std::string Num(double v) { return util::FormatNumber(v, 17); }

void CheckFinite(double v, const char* what, const std::string& kind) {
  if (!std::isfinite(v)) {
    throw Error(kind + " " + what + " = " + Num(v) + " is not finite");
  }
}

void CheckKnots(const std::vector<double>& x, const std::vector<double>& y,
                const std::string& kind) {
  if (x.size() != y.size()) {
    throw Error(kind + " has " + std::to_string(x.size()) + " x values but " +
                std::to_string(y.size()) + " y values; they must be equal in number");
  }
  if (x.size() < 2) {
    throw Error(kind + " has " + std::to_string(x.size()) + " knot(s); it needs at least 2");
  }
  for (size_t i = 0; i < x.size(); ++i) {
    if (!std::isfinite(x[i])) {
      throw Error(kind + " knot x[" + std::to_string(i) + "] = " + Num(x[i]) + " is not finite");
    }
    if (!std::isfinite(y[i])) {
      throw Error(kind + " knot y[" + std::to_string(i) + "] = " + Num(y[i]) + " is not finite");
    }
    if (i > 0 && !(x[i] > x[i - 1])) {
      throw Error(kind + " knots must be strictly increasing: x[" + std::to_string(i) +
                  "] = " + Num(x[i]) + (x[i] == x[i - 1] ? " duplicates" : " is below") + " x[" +
                  std::to_string(i - 1) + "] = " + Num(x[i - 1]));
    }
  }
}

// SimmSpline::calcCoefficients (opensim-core OpenSim/Common/SimmSpline.cpp), same operations
// in the same order.
void SimmCoefficients(const std::vector<double>& x, const std::vector<double>& y,
                      std::vector<double>& b, std::vector<double>& c, std::vector<double>& d) {
  const int n = static_cast<int>(x.size());
  b.assign(n, 0.0);
  c.assign(n, 0.0);
  d.assign(n, 0.0);
  if (n == 2) {
    double t = std::max(kTinyNumber, x[1] - x[0]);
    b[0] = b[1] = (y[1] - y[0]) / t;
    return;
  }
  const int nm1 = n - 1;
  const int nm2 = n - 2;
  // Tridiagonal system: b = diagonal, d = off-diagonal, c = right-hand side.
  d[0] = std::max(kTinyNumber, x[1] - x[0]);
  c[1] = (y[1] - y[0]) / d[0];
  for (int i = 1; i < nm1; ++i) {
    d[i] = std::max(kTinyNumber, x[i + 1] - x[i]);
    b[i] = 2.0 * (d[i - 1] + d[i]);
    c[i + 1] = (y[i + 1] - y[i]) / d[i];
    c[i] = c[i + 1] - c[i];
  }
  // End conditions: third derivatives at x[0] and x[n-1] from divided differences.
  b[0] = -d[0];
  b[nm1] = -d[nm2];
  c[0] = 0.0;
  c[nm1] = 0.0;
  if (n > 3) {
    double d31 = std::max(kTinyNumber, x[3] - x[1]);
    double d20 = std::max(kTinyNumber, x[2] - x[0]);
    double d1 = std::max(kTinyNumber, x[nm1] - x[n - 3]);
    double d2 = std::max(kTinyNumber, x[nm2] - x[n - 4]);
    double d30 = std::max(kTinyNumber, x[3] - x[0]);
    double d3 = std::max(kTinyNumber, x[nm1] - x[n - 4]);
    c[0] = c[2] / d31 - c[1] / d20;
    c[nm1] = c[nm2] / d1 - c[n - 3] / d2;
    c[0] = c[0] * d[0] * d[0] / d30;
    c[nm1] = -c[nm1] * d[nm2] * d[nm2] / d3;
  }
  // Forward elimination.
  for (int i = 1; i < n; ++i) {
    double t = d[i - 1] / b[i - 1];
    b[i] -= t * d[i - 1];
    c[i] -= t * c[i - 1];
  }
  // Back substitution.
  c[nm1] /= b[nm1];
  for (int j = 0; j < nm1; ++j) {
    int i = nm2 - j;
    c[i] = (c[i] - d[i] * c[i + 1]) / b[i];
  }
  // Polynomial coefficients.
  b[nm1] = (y[nm1] - y[nm2]) / d[nm2] + d[nm2] * (c[nm2] + 2.0 * c[nm1]);
  for (int i = 0; i < nm1; ++i) {
    b[i] = (y[i + 1] - y[i]) / d[i] - d[i] * (c[i + 1] + 2.0 * c[i]);
    d[i] = (c[i + 1] - c[i]) / d[i];
    c[i] *= 3.0;
  }
  c[nm1] *= 3.0;
  d[nm1] = d[nm2];
}

// Natural cubic spline: second derivatives M with M[0] = M[n-1] = 0 from the usual tridiagonal
// system h[i-1] M[i-1] + 2 (h[i-1] + h[i]) M[i] + h[i] M[i+1] = 6 (s[i] - s[i-1]), s = slopes.
void NaturalCoefficients(const std::vector<double>& x, const std::vector<double>& y,
                         std::vector<double>& b, std::vector<double>& c, std::vector<double>& d) {
  const int n = static_cast<int>(x.size());
  std::vector<double> h(n - 1), slope(n - 1), m(n, 0.0);
  for (int i = 0; i + 1 < n; ++i) {
    h[i] = x[i + 1] - x[i];
    slope[i] = (y[i + 1] - y[i]) / h[i];
  }
  if (n > 2) {
    // Thomas algorithm on the unknowns M[1..n-2].
    const int k = n - 2;
    std::vector<double> diag(k), upper(k), rhs(k);
    for (int r = 0; r < k; ++r) {
      int i = r + 1;
      diag[r] = 2.0 * (h[i - 1] + h[i]);
      upper[r] = h[i];
      rhs[r] = 6.0 * (slope[i] - slope[i - 1]);
    }
    for (int r = 1; r < k; ++r) {
      double t = h[r] / diag[r - 1];  // sub-diagonal of row r is h[r]
      diag[r] -= t * upper[r - 1];
      rhs[r] -= t * rhs[r - 1];
    }
    m[k] = rhs[k - 1] / diag[k - 1];
    for (int r = k - 2; r >= 0; --r) m[r + 1] = (rhs[r] - upper[r] * m[r + 2]) / diag[r];
  }
  b.assign(n, 0.0);
  c.assign(n, 0.0);
  d.assign(n, 0.0);
  for (int i = 0; i + 1 < n; ++i) {
    b[i] = slope[i] - h[i] * (2.0 * m[i] + m[i + 1]) / 6.0;
    c[i] = m[i] / 2.0;
    d[i] = (m[i + 1] - m[i]) / (6.0 * h[i]);
  }
  b[n - 1] = slope[n - 2] + h[n - 2] * (m[n - 2] + 2.0 * m[n - 1]) / 6.0;
  c[n - 1] = m[n - 1] / 2.0;  // 0
}

// PiecewiseLinearFunction::calcCoefficients.
void PiecewiseCoefficients(const std::vector<double>& x, const std::vector<double>& y,
                           std::vector<double>& b, std::vector<double>& c, std::vector<double>& d) {
  const int n = static_cast<int>(x.size());
  b.assign(n, 0.0);
  c.assign(n, 0.0);
  d.assign(n, 0.0);
  for (int i = 0; i < n - 1; ++i) {
    double range = std::max(kTinyNumber, x[i + 1] - x[i]);
    b[i] = (y[i + 1] - y[i]) / range;
  }
  b[n - 1] = b[n - 2];
}

// Horner's rule on coefficients highest order first (SimTK::Function::Polynomial).
double EvaluatePolynomial(const std::vector<double>& coefficients, double a, int order) {
  const int n = static_cast<int>(coefficients.size());
  double value = 0.0;
  for (int i = 0; i < n - order; ++i) {
    const int power = n - 1 - i;
    double factor = 1.0;
    for (int o = 0; o < order; ++o) factor *= power - o;
    value = value * a + factor * coefficients[i];
  }
  return value;
}

double Evaluate(const Function::Impl& s, double a, int order) {
  switch (s.kind) {
    case FunctionKind::kConstant: return order == 0 ? s.intercept : 0.0;
    case FunctionKind::kLinear:
      return order == 0 ? s.slope * a + s.intercept : order == 1 ? s.slope : 0.0;
    case FunctionKind::kSimmSpline:
    case FunctionKind::kNaturalCubicSpline:
    case FunctionKind::kPiecewiseLinear: {
      double v[3];
      KnotValues(s, a, &v[0], &v[1], &v[2]);
      return v[order];
    }
    case FunctionKind::kPolynomial: return EvaluatePolynomial(s.coefficients, a, order);
    case FunctionKind::kMultiplier: {
      const Function& f = s.inner.front();
      double inner = order == 0 ? f.Value(a) : order == 1 ? f.Derivative(a) : f.SecondDerivative(a);
      return inner * s.scale;
    }
  }
  return 0.0;
}

// A knot-based function: checked knots, then the kind's coefficients, stored per knot.
using CoefficientFunction = void (*)(const std::vector<double>& x, const std::vector<double>& y,
                                     std::vector<double>& b, std::vector<double>& c,
                                     std::vector<double>& d);
std::shared_ptr<const Function::Impl> KnotImpl(FunctionKind kind, const char* name,
                                               std::vector<double> x, std::vector<double> y,
                                               CoefficientFunction coefficients) {
  CheckKnots(x, y, name);
  auto s = std::make_shared<Function::Impl>();
  s->kind = kind;
  s->x = std::move(x);
  s->y = std::move(y);
  std::vector<double> b, c, d;
  coefficients(s->x, s->y, b, c, d);
  for (size_t k = 0; k < s->x.size(); ++k)
    s->ybcd.insert(s->ybcd.end(), {s->y[k], b[k], c[k], d[k]});
  return s;
}

const std::shared_ptr<const Function::Impl>& ZeroImpl() {
  static const std::shared_ptr<const Function::Impl> zero = std::make_shared<Function::Impl>();
  return zero;
}

const std::vector<double>& EmptyVector() {
  static const std::vector<double> empty;
  return empty;
}

}  // namespace

const char* FunctionKindName(FunctionKind kind) {
  switch (kind) {
    case FunctionKind::kConstant: return "constant";
    case FunctionKind::kLinear: return "linear";
    case FunctionKind::kSimmSpline: return "simm_spline";
    case FunctionKind::kNaturalCubicSpline: return "natural_cubic_spline";
    case FunctionKind::kPiecewiseLinear: return "piecewise_linear";
    case FunctionKind::kPolynomial: return "polynomial";
    case FunctionKind::kMultiplier: return "multiplier";
  }
  return "unknown";
}

Function::Function() : impl_(ZeroImpl()) {}

Function::Function(std::shared_ptr<const Impl> impl) : impl_(std::move(impl)) {}

Function Function::Constant(double value) {
  CheckFinite(value, "value", "constant function");
  auto s = std::make_shared<Impl>();
  s->kind = FunctionKind::kConstant;
  s->intercept = value;
  return Function(std::move(s));
}

Function Function::Linear(double slope, double intercept) {
  CheckFinite(slope, "slope", "linear function");
  CheckFinite(intercept, "intercept", "linear function");
  auto s = std::make_shared<Impl>();
  s->kind = FunctionKind::kLinear;
  s->slope = slope;
  s->intercept = intercept;
  return Function(std::move(s));
}

Function Function::SimmSpline(std::vector<double> x, std::vector<double> y) {
  return Function(KnotImpl(FunctionKind::kSimmSpline, "SimmSpline", std::move(x), std::move(y),
                           SimmCoefficients));
}

Function Function::NaturalCubicSpline(std::vector<double> x, std::vector<double> y) {
  return Function(KnotImpl(FunctionKind::kNaturalCubicSpline, "natural cubic spline", std::move(x),
                           std::move(y), NaturalCoefficients));
}

Function Function::PiecewiseLinear(std::vector<double> x, std::vector<double> y) {
  return Function(KnotImpl(FunctionKind::kPiecewiseLinear, "piecewise linear function",
                           std::move(x), std::move(y), PiecewiseCoefficients));
}

Function Function::Polynomial(std::vector<double> coefficients) {
  if (coefficients.empty()) {
    throw Error("polynomial function has no coefficient; it needs at least 1");
  }
  for (size_t i = 0; i < coefficients.size(); ++i) {
    if (!std::isfinite(coefficients[i])) {
      throw Error("polynomial coefficient " + std::to_string(i) + " = " + Num(coefficients[i]) +
                  " is not finite");
    }
  }
  auto s = std::make_shared<Impl>();
  s->kind = FunctionKind::kPolynomial;
  s->coefficients = std::move(coefficients);
  return Function(std::move(s));
}

Function Function::Multiplier(Function inner, double scale) {
  CheckFinite(scale, "scale", "multiplier function");
  auto s = std::make_shared<Impl>();
  s->kind = FunctionKind::kMultiplier;
  s->scale = scale;
  s->inner.push_back(std::move(inner));
  return Function(std::move(s));
}

double Function::Value(double x) const { return Evaluate(*impl_, x, 0); }
double Function::Derivative(double x) const { return Evaluate(*impl_, x, 1); }
double Function::SecondDerivative(double x) const { return Evaluate(*impl_, x, 2); }

void Function::ValueAndDerivative(double x, double* value, double* derivative) const {
  const Impl& s = *impl_;
  switch (s.kind) {
    case FunctionKind::kSimmSpline:
    case FunctionKind::kNaturalCubicSpline:
    case FunctionKind::kPiecewiseLinear: KnotValueAndSlope(s, x, value, derivative); return;
    case FunctionKind::kLinear:
      *value = s.slope * x + s.intercept;
      *derivative = s.slope;
      return;
    default: *value = Evaluate(s, x, 0); *derivative = Evaluate(s, x, 1);
  }
}

FunctionKind Function::kind() const { return impl_->kind; }

bool Function::is_linear() const {
  switch (impl_->kind) {
    case FunctionKind::kConstant:
    case FunctionKind::kLinear: return true;
    case FunctionKind::kMultiplier: return impl_->inner.front().is_linear();
    default: return false;
  }
}

bool Function::is_identity() const { return is_linear() && slope() == 1.0 && intercept() == 0.0; }

double Function::slope() const {
  assert(is_linear());
  switch (impl_->kind) {
    case FunctionKind::kLinear: return impl_->slope;
    case FunctionKind::kMultiplier: return impl_->scale * impl_->inner.front().slope();
    default: return 0.0;
  }
}

double Function::intercept() const {
  assert(is_linear());
  if (impl_->kind == FunctionKind::kMultiplier) {
    return impl_->scale * impl_->inner.front().intercept();
  }
  return impl_->intercept;
}

const std::vector<double>& Function::x() const { return impl_->x; }
const std::vector<double>& Function::y() const { return impl_->y; }
const std::vector<double>& Function::coefficients() const {
  return impl_->kind == FunctionKind::kPolynomial ? impl_->coefficients : EmptyVector();
}

const Function& Function::inner() const {
  static const Function zero;
  return impl_->inner.empty() ? zero : impl_->inner.front();
}

double Function::scale() const {
  return impl_->kind == FunctionKind::kMultiplier ? impl_->scale : 1.0;
}

}  // namespace isowrench
