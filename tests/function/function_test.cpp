// isowrench::Function against values derived independently in this file: polynomials the
// splines must reproduce exactly, end conditions written out as divided differences, hand
// solved natural splines, finite differences, and OpenSim's extrapolation rule.

#include "isowrench/function.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <string>

#include "isowrench/error.hpp"
#include "model/function_impl.hpp"

namespace isowrench {
namespace {

using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

// Values of order 1 computed through a few dozen flops: a few hundred ulps.
constexpr double kExact = 1e-12;
// Central differences with step h: truncation ~h^2 |f'''|, round-off ~eps/h.
constexpr double kStep = 1e-5;
constexpr double kFdTolerance = 1e-7;

struct Cubic {
  double a0, a1, a2, a3;
  double Value(double x) const { return a0 + x * (a1 + x * (a2 + x * a3)); }
  double Slope(double x) const { return a1 + x * (2 * a2 + 3 * a3 * x); }
  double Curvature(double x) const { return 2 * a2 + 6 * a3 * x; }
};

// Non-uniform knots over a knee-like range (rad).
const std::vector<double> kKnots = {-2.0944, -1.7, -1.2, -0.9, -0.35, 0.0, 0.17453};

std::vector<double> Sample(const Cubic& p, const std::vector<double>& x) {
  std::vector<double> y;
  for (double xi : x) y.push_back(p.Value(xi));
  return y;
}

double CentralDifference(const std::function<double(double)>& f, double x) {
  return (f(x + kStep) - f(x - kStep)) / (2 * kStep);
}

TEST(SimmSpline, ReproducesTheCubicThroughItsKnots) {
  // With >= 4 knots the FMM end conditions match the third derivative of the cubic through
  // the four end knots, which for knots sampled from a cubic is the cubic's own: the cubic
  // then satisfies every spline equation, and the spline is unique.
  const Cubic p{0.003, -0.0021, 0.0047, 0.0012};
  Function f = Function::SimmSpline(kKnots, Sample(p, kKnots));
  for (double x = -2.09; x <= 0.17; x += 0.0137) {
    EXPECT_NEAR(f.Value(x), p.Value(x), kExact) << x;
    EXPECT_NEAR(f.Derivative(x), p.Slope(x), kExact) << x;
    EXPECT_NEAR(f.SecondDerivative(x), p.Curvature(x), 1e-10) << x;
  }
}

TEST(SimmSpline, ExtrapolatesLinearlyWithTheEndSlope) {
  const Cubic p{0.003, -0.0021, 0.0047, 0.0012};
  Function f = Function::SimmSpline(kKnots, Sample(p, kKnots));
  const double x0 = kKnots.front(), xn = kKnots.back();
  for (double dx : {1e-9, 0.01, 0.3}) {
    EXPECT_NEAR(f.Value(x0 - dx), p.Value(x0) - dx * p.Slope(x0), kExact);
    EXPECT_NEAR(f.Derivative(x0 - dx), p.Slope(x0), kExact);
    EXPECT_EQ(f.SecondDerivative(x0 - dx), 0.0);
    EXPECT_NEAR(f.Value(xn + dx), p.Value(xn) + dx * p.Slope(xn), kExact);
    EXPECT_NEAR(f.Derivative(xn + dx), p.Slope(xn), kExact);
    EXPECT_EQ(f.SecondDerivative(xn + dx), 0.0);
  }
}

// The third divided difference f[x_i, ..., x_i+3] of the knots.
double ThirdDividedDifference(const std::vector<double>& x, const std::vector<double>& y,
                              size_t i) {
  auto d1 = [&](size_t k) { return (y[k + 1] - y[k]) / (x[k + 1] - x[k]); };
  auto d2 = [&](size_t k) { return (d1(k + 1) - d1(k)) / (x[k + 2] - x[k]); };
  return (d2(i + 1) - d2(i)) / (x[i + 3] - x[i]);
}

TEST(SimmSpline, EndThirdDerivativesAreThoseOfTheEndCubics) {
  // Data that is no cubic (a knee translation-like curve): the Forsythe-Malcolm-Moler end
  // condition says f''' on the first and last interval = 6 f[x0..x3] and 6 f[x_n-4..x_n-1].
  std::vector<double> y;
  for (double x : kKnots) y.push_back(0.004 * std::sin(1.3 * x) + 0.001 * x * x);
  Function f = Function::SimmSpline(kKnots, y);
  const size_t n = kKnots.size();
  // f'' is linear on an interval: its slope there is f'''.
  auto third = [&](double a, double b) {
    return (f.SecondDerivative(b) - f.SecondDerivative(a)) / (b - a);
  };
  const double first =
      third(kKnots[0] + 0.1 * (kKnots[1] - kKnots[0]), kKnots[0] + 0.9 * (kKnots[1] - kKnots[0]));
  const double last = third(kKnots[n - 2] + 0.1 * (kKnots[n - 1] - kKnots[n - 2]),
                            kKnots[n - 2] + 0.9 * (kKnots[n - 1] - kKnots[n - 2]));
  EXPECT_NEAR(first, 6 * ThirdDividedDifference(kKnots, y, 0), 1e-9);
  EXPECT_NEAR(last, 6 * ThirdDividedDifference(kKnots, y, n - 4), 1e-9);
  // Interpolation and C2 continuity at the interior knots.
  const double h = 1e-9;
  for (size_t i = 0; i < n; ++i) EXPECT_NEAR(f.Value(kKnots[i]), y[i], kExact);
  for (size_t i = 1; i + 1 < n; ++i) {
    EXPECT_NEAR(f.Derivative(kKnots[i] - h), f.Derivative(kKnots[i] + h), 1e-9);
    EXPECT_NEAR(f.SecondDerivative(kKnots[i] - h), f.SecondDerivative(kKnots[i] + h), 1e-7);
  }
}

TEST(SimmSpline, ThreeKnotsGiveTheParabolaTwoKnotsTheLine) {
  // Three knots: the end rows read sigma_0 = sigma_1 and sigma_1 = sigma_2 (equal second
  // derivatives), so the spline is the parabola through the knots: y = 2x - x^2 here.
  Function f = Function::SimmSpline({0, 1, 2}, {0, 1, 0});
  EXPECT_NEAR(f.Value(0.5), 0.75, kExact);
  EXPECT_NEAR(f.Value(1.7), 2 * 1.7 - 1.7 * 1.7, kExact);
  EXPECT_NEAR(f.Derivative(0.25), 2 - 2 * 0.25, kExact);
  EXPECT_NEAR(f.SecondDerivative(1.5), -2.0, kExact);
  // Beyond x = 2 the end slope 2 - 2*2 = -2 continues.
  EXPECT_NEAR(f.Value(2.5), 0 - 2 * 0.5, kExact);
  Function line = Function::SimmSpline({1, 3}, {2, 3});
  EXPECT_NEAR(line.Value(2.2), 2 + 0.5 * 1.2, kExact);
  EXPECT_NEAR(line.Value(-1), 2 - 0.5 * 2, kExact);
  EXPECT_EQ(line.SecondDerivative(2), 0.0);
}

TEST(SimmSpline, ArgumentsWithin2e13OfAnEndKnotReturnItsY) {
  // OpenSim's ROUNDOFF_ERROR: |x - x_end| <= 2e-13 returns y_end exactly.
  const std::vector<double> x = {0.0, 0.5, 1.1, 2.0};
  const std::vector<double> y = {0.25, -0.4, 0.9, 1.0};
  Function f = Function::SimmSpline(x, y);
  EXPECT_EQ(f.Value(1.5e-13), 0.25);
  EXPECT_EQ(f.Value(2.0 - 1.5e-13), 1.0);
  EXPECT_NE(f.Value(1e-9), 0.25);
}

TEST(NaturalCubicSpline, MatchesTheHandSolvedSpline) {
  // Knots (0,0) (1,1) (2,0), M0 = M2 = 0: 2(1+1) M1 = 6((-1) - 1) -> M1 = -3. On [0, 1]:
  // f = x (1 - h(2 M0 + M1)/6) + (M1 - M0)/6 x^3 = 1.5 x - 0.5 x^3.
  Function f = Function::NaturalCubicSpline({0, 1, 2}, {0, 1, 0});
  EXPECT_NEAR(f.Value(0.5), 1.5 * 0.5 - 0.5 * 0.125, kExact);
  EXPECT_NEAR(f.Derivative(0.5), 1.5 - 1.5 * 0.25, kExact);
  EXPECT_NEAR(f.SecondDerivative(0.5), -3 * 0.5, kExact);
  EXPECT_NEAR(f.SecondDerivative(0.0), 0.0, kExact);
  EXPECT_NEAR(f.SecondDerivative(2.0), 0.0, kExact);
  // Symmetric about x = 1; extrapolation with the end slopes +-1.5.
  EXPECT_NEAR(f.Value(1.5), f.Value(0.5), kExact);
  EXPECT_NEAR(f.Value(-0.2), -0.3, kExact);
  EXPECT_NEAR(f.Value(2.2), -0.3, kExact);
  // The SimmSpline of the same knots is the parabola, not this spline.
  EXPECT_GT(std::abs(Function::SimmSpline({0, 1, 2}, {0, 1, 0}).Value(0.5) - f.Value(0.5)), 0.05);
}

TEST(NaturalCubicSpline, ZeroEndCurvatureAndContinuityOnManyKnots) {
  std::vector<double> y;
  for (double x : kKnots) y.push_back(std::cos(x));
  Function f = Function::NaturalCubicSpline(kKnots, y);
  EXPECT_NEAR(f.SecondDerivative(kKnots.front()), 0.0, kExact);
  EXPECT_NEAR(f.SecondDerivative(kKnots.back()), 0.0, kExact);
  for (size_t i = 0; i < kKnots.size(); ++i) EXPECT_NEAR(f.Value(kKnots[i]), y[i], kExact);
  for (size_t i = 1; i + 1 < kKnots.size(); ++i) {
    EXPECT_NEAR(f.Derivative(kKnots[i] - 1e-9), f.Derivative(kKnots[i] + 1e-9), 1e-8);
    EXPECT_NEAR(f.SecondDerivative(kKnots[i] - 1e-9), f.SecondDerivative(kKnots[i] + 1e-9), 1e-7);
  }
  // A straight line is its own natural spline.
  Function line = Function::NaturalCubicSpline(kKnots, Sample({0.1, 0.7, 0, 0}, kKnots));
  EXPECT_NEAR(line.Value(-0.5), 0.1 - 0.35, kExact);
  EXPECT_NEAR(line.Derivative(-1.0), 0.7, kExact);
}

TEST(PiecewiseLinear, SegmentsSlopesAndExtrapolation) {
  Function f = Function::PiecewiseLinear({0, 1, 3}, {1, 3, 2});
  EXPECT_NEAR(f.Value(0.25), 1.5, kExact);
  EXPECT_NEAR(f.Value(2.0), 2.5, kExact);
  EXPECT_NEAR(f.Derivative(0.5), 2.0, kExact);
  EXPECT_NEAR(f.Derivative(2.5), -0.5, kExact);
  EXPECT_NEAR(f.Value(-1), -1.0, kExact);  // first slope 2 continued
  EXPECT_NEAR(f.Value(5), 1.0, kExact);    // last slope -0.5 continued
  EXPECT_EQ(f.SecondDerivative(0.5), 0.0);
  // OpenSim's binary search stops at k = 1 for x = x[1] = 1 (3 knots: k = (0+3)/2 = 1, and
  // x[1] <= 1 <= x[2]): the slope of the segment to the right.
  EXPECT_NEAR(f.Derivative(1.0), -0.5, kExact);
}

TEST(Polynomial, HighestOrderFirst) {
  // 2x^3 - 3x^2 + 0.5x + 4
  Function f = Function::Polynomial({2, -3, 0.5, 4});
  const double x = -0.7;
  EXPECT_NEAR(f.Value(x), 2 * x * x * x - 3 * x * x + 0.5 * x + 4, kExact);
  EXPECT_NEAR(f.Derivative(x), 6 * x * x - 6 * x + 0.5, kExact);
  EXPECT_NEAR(f.SecondDerivative(x), 12 * x - 6, kExact);
  EXPECT_EQ(Function::Polynomial({5}).Value(3), 5.0);
  EXPECT_EQ(Function::Polynomial({5}).Derivative(3), 0.0);
}

TEST(ConstantLinearMultiplier, ValuesAndLinearity) {
  Function c = Function::Constant(0.002);
  EXPECT_EQ(c.Value(7), 0.002);
  EXPECT_EQ(c.Derivative(7), 0.0);
  EXPECT_TRUE(c.is_linear());
  EXPECT_EQ(c.slope(), 0.0);
  EXPECT_EQ(c.intercept(), 0.002);
  Function l = Function::Linear(0.01, 0.002);
  EXPECT_NEAR(l.Value(0.5), 0.007, kExact);
  EXPECT_EQ(l.Derivative(-3), 0.01);
  EXPECT_FALSE(l.is_identity());
  EXPECT_TRUE(Function::Linear(1, 0).is_identity());
  Function m = Function::Multiplier(l, -2);
  EXPECT_TRUE(m.is_linear());
  EXPECT_NEAR(m.slope(), -0.02, kExact);
  EXPECT_NEAR(m.intercept(), -0.004, kExact);
  EXPECT_NEAR(m.Value(0.5), -0.014, kExact);
  Function ms = Function::Multiplier(Function::SimmSpline({0, 1, 2}, {0, 1, 0}), 3);
  EXPECT_FALSE(ms.is_linear());
  EXPECT_NEAR(ms.Value(0.5), 3 * 0.75, kExact);
  EXPECT_NEAR(ms.SecondDerivative(0.5), 3 * -2.0, kExact);
  EXPECT_EQ(ms.inner().kind(), FunctionKind::kSimmSpline);
  EXPECT_EQ(ms.scale(), 3.0);
  Function zero;
  EXPECT_EQ(zero.kind(), FunctionKind::kConstant);
  EXPECT_EQ(zero.Value(1.0), 0.0);
}

TEST(AllKinds, DerivativesMatchFiniteDifferences) {
  std::vector<double> y;
  for (double x : kKnots) y.push_back(0.003 * std::sin(2 * x) - 0.001 * x);
  const std::vector<Function> functions = {
      Function::SimmSpline(kKnots, y), Function::NaturalCubicSpline(kKnots, y),
      Function::Polynomial({0.3, -0.2, 0.1, 0.05}),
      Function::Multiplier(Function::SimmSpline(kKnots, y), 1.7), Function::Linear(0.3, 0.1)};
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> u(-2.5, 0.5);  // inside and outside the knots
  for (const Function& f : functions) {
    for (int i = 0; i < 50; ++i) {
      const double x = u(rng);
      bool near_knot = false;
      for (double k : kKnots) near_knot |= std::abs(x - k) < 2 * kStep;
      if (near_knot) continue;  // derivatives of a C2 spline's pieces jump in f''' there
      EXPECT_NEAR(f.Derivative(x), CentralDifference([&](double v) { return f.Value(v); }, x),
                  kFdTolerance)
          << FunctionKindName(f.kind()) << " at " << x;
      EXPECT_NEAR(f.SecondDerivative(x),
                  CentralDifference([&](double v) { return f.Derivative(v); }, x), 1e-5)
          << FunctionKindName(f.kind()) << " at " << x;
    }
  }
}

// ValueAndDerivative (one interval search, used by the engine for couplings) must give exactly
// Value and Derivative, on the knots, between them and on both sides of them.
TEST(AllKinds, ValueAndDerivativeIsValueAndDerivative) {
  std::vector<double> y;
  for (double x : kKnots) y.push_back(0.003 * std::sin(2 * x) - 0.001 * x);
  const std::vector<Function> functions = {
      Function::SimmSpline(kKnots, y),
      Function::NaturalCubicSpline(kKnots, y),
      Function::PiecewiseLinear(kKnots, y),
      Function::Polynomial({0.3, -0.2, 0.1, 0.05}),
      Function::Multiplier(Function::SimmSpline(kKnots, y), 1.7),
      Function::Linear(0.3, 0.1),
      Function::Constant(-0.25)};
  std::vector<double> xs = kKnots;
  for (double x = -3.0; x <= 1.0; x += 0.0625) xs.push_back(x);
  xs.push_back(kKnots.front() + 1e-14);  // within OpenSim's round-off of the end knots
  xs.push_back(kKnots.back() - 1e-14);
  for (const Function& f : functions) {
    for (double x : xs) {
      double value = std::nan(""), derivative = std::nan("");
      f.ValueAndDerivative(x, &value, &derivative);
      EXPECT_EQ(value, f.Value(x)) << FunctionKindName(f.kind()) << " at " << x;
      EXPECT_EQ(derivative, f.Derivative(x)) << FunctionKindName(f.kind()) << " at " << x;
    }
  }
}

// OpenSim's interval search (SimmSpline::calcValue), written out here: the reference for the
// engine's scan.
int OpenSimBisection(const std::vector<double>& x, double a) {
  const int n = static_cast<int>(x.size());
  int i = 0, j = n, k = 0;
  while (true) {
    k = (i + j) / 2;
    if (a < x[k]) {
      j = k;
    } else if (a > x[k + 1]) {
      i = k;
    } else {
      return k;
    }
  }
}

// Between the end knots the interval is OpenSim's: by the scan up to 32 knots (everywhere but on
// an interior knot, where the bisection itself decides), by the bisection beyond. And the
// engine's inline knot evaluation (KnotScan) gives exactly ValueAndDerivative wherever it
// answers; it answers between the knots more than 4e-13 inside the end knots, except on interior
// knots and above 32 knots, and never within 2e-13 of an end knot (where OpenSim snaps to it) or
// outside the knots. Knots near 0 and near 3000 (where an ulp, 4.5e-13, exceeds OpenSim's
// 2e-13).
TEST(KnotIntervals, TheScanFindsOpenSimsIntervalAndKnotScanIsValueAndDerivative) {
  enum Answer { kNo, kYes, kMay };
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> gap(0.05, 1.0), u(0.0, 1.0);
  for (const double start : {-0.7, 3000.0}) {
    for (const int n : {3, 4, 7, 12, 31, 32, 33, 40}) {
      std::vector<double> x = {start}, y;
      while (static_cast<int>(x.size()) < n) x.push_back(x.back() + gap(rng));
      for (double xi : x) y.push_back(0.01 * std::sin(3 * xi) + 0.002 * xi);
      std::vector<std::pair<double, Answer>> args;
      for (int i = 0; i < 400; ++i)
        args.push_back({x.front() + (x.back() - x.front()) * u(rng), kYes});
      for (size_t i = 0; i < x.size(); ++i) {
        const bool interior = i > 0 && i + 1 < x.size();
        if (interior) args.push_back({x[i], kNo});
        const double below = std::nextafter(x[i], -1e9), above = std::nextafter(x[i], 1e9);
        args.push_back({below, interior ? kYes : i == 0 ? kNo : kMay});
        args.push_back({above, interior ? kYes : i == 0 ? kMay : kNo});
      }
      for (double d : {1e-14, 1.9e-13}) {
        args.push_back({x.front() + d, kMay});  // (3000 + d rounds to 3000 or the next double)
        args.push_back({x.back() - d, kMay});
      }
      args.push_back({x.front() + 5e-13, start < 1.0 ? kYes : kMay});
      args.push_back({x.back() - 5e-13, start < 1.0 ? kYes : kMay});
      args.push_back({x.front() - 0.5, kNo});
      args.push_back({x.back() + 0.5, kNo});
      for (const Function& f : {Function::SimmSpline(x, y), Function::NaturalCubicSpline(x, y),
                                Function::PiecewiseLinear(x, y)}) {
        const KnotScan scan(FunctionAccess::Of(f));
        for (const auto& [a, answer] : args) {
          const std::string where = std::string(FunctionKindName(f.kind())) + ", " +
                                    std::to_string(n) + " knots from " + std::to_string(start) +
                                    ", at " + std::to_string(a);
          if (a > x.front() && a < x.back()) {
            EXPECT_EQ(FindInterval(x, a), OpenSimBisection(x, a)) << where;
          }
          double value = 0.0, slope = 0.0, v = 0.0, s = 0.0;
          const bool answered = scan.ValueAndSlope(a, &value, &slope);
          const bool within = std::abs(a - x.front()) <= 2e-13 || std::abs(a - x.back()) <= 2e-13;
          if (n > kScannedKnots || answer == kNo || within) {  // (within: OpenSim's end rule)
            EXPECT_FALSE(answered) << where;
          } else if (answer == kYes) {
            EXPECT_TRUE(answered) << where;
          }
          if (!answered) continue;
          f.ValueAndDerivative(a, &v, &s);
          EXPECT_EQ(value, v) << where;
          EXPECT_EQ(slope, s) << where;
        }
      }
    }
  }
  // Functions without knots (and two knots) are never evaluated by the scan.
  double value = 0.0, slope = 0.0;
  EXPECT_FALSE(
      KnotScan(FunctionAccess::Of(Function::Linear(2.0, 1.0))).ValueAndSlope(0.5, &value, &slope));
  EXPECT_FALSE(KnotScan(FunctionAccess::Of(Function::SimmSpline({0.0, 1.0}, {0.0, 2.0})))
                   .ValueAndSlope(0.5, &value, &slope));
}

TEST(BadKnots, ErrorsNameTheRule) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THAT(
      [] {
        Function::SimmSpline({0, 2, 1}, {0, 1, 2});
      },
      ThrowsMessage<Error>(HasSubstr("strictly increasing: x[2] = 1 is below x[1] = 2")));
  EXPECT_THAT(
      [] {
        Function::PiecewiseLinear({0, 1, 1}, {0, 1, 2});
      },
      ThrowsMessage<Error>(HasSubstr("x[2] = 1 duplicates x[1] = 1")));
  EXPECT_THAT([] { Function::NaturalCubicSpline({0}, {0}); },
              ThrowsMessage<Error>(HasSubstr("1 knot(s); it needs at least 2")));
  EXPECT_THAT(
      [nan] {
        Function::SimmSpline({0, nan, 2}, {0, 1, 2});
      },
      ThrowsMessage<Error>(HasSubstr("x[1] = nan is not finite")));
  EXPECT_THAT(
      [nan] {
        Function::SimmSpline({0, 1, 2}, {0, 1, nan});
      },
      ThrowsMessage<Error>(HasSubstr("y[2] = nan is not finite")));
  EXPECT_THAT(
      [] {
        Function::SimmSpline({0, 1, 2}, {0, 1});
      },
      ThrowsMessage<Error>(HasSubstr("3 x values but 2 y values")));
  EXPECT_THAT([] { Function::Polynomial({}); },
              ThrowsMessage<Error>(HasSubstr("needs at least 1")));
  EXPECT_THAT([nan] { Function::Constant(nan); }, ThrowsMessage<Error>(HasSubstr("not finite")));
  EXPECT_THAT([] { Function::Multiplier(Function(), std::numeric_limits<double>::infinity()); },
              ThrowsMessage<Error>(HasSubstr("scale = inf is not finite")));
}

}  // namespace
}  // namespace isowrench
