// The muscle curves against independent references: their documented corner points
// (ActiveForceLengthCurve.h, FiberForceLengthCurve.h, TendonForceLengthCurve.h, Thelen 2003),
// a de Casteljau evaluation of the Bezier control points, hand-built control points, and
// central differences for the slopes.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "isowrench/error.hpp"
#include "isowrench/muscle.hpp"
#include "muscle/smooth_curve.hpp"

namespace isowrench {
namespace {

using ::testing::HasSubstr;

// Values at exact curve knots are the knot's control point up to a few roundings of the
// power-basis sum: 8 eps of the largest value involved.
constexpr double kKnotTolerance = 8 * 2.220446049250313e-16 * 4;

MuscleForceModel Millard(double damping = 0.1, bool rigid = false) {
  MuscleForceSpec spec;
  spec.model = ForceModelType::kMillard2012;
  spec.optimal_fiber_length = 0.03;
  spec.tendon_slack_length = 0.01;
  spec.fiber_damping = damping;
  spec.ignore_tendon_compliance = rigid;
  return MuscleForceModel("M", 2.0, spec);
}

MuscleForceModel Thelen() {
  MuscleForceSpec spec;
  spec.model = ForceModelType::kThelen2003;
  spec.optimal_fiber_length = 0.03;
  spec.tendon_slack_length = 0.01;
  spec.thelen.FmaxTendonStrain = 0.033;
  spec.thelen.KshapeActive = 0.5;
  spec.thelen.KshapePassive = 4;
  return MuscleForceModel("T", 2.0, spec);
}

TEST(MuscleCurves, ActiveCurveIsOneWithZeroSlopeAtOptimalLength) {
  for (const MuscleForceModel& m : {Millard(), Millard(0.0), Thelen()}) {
    const CurvePoint p = m.ActiveForceLength(1.0);
    EXPECT_NEAR(p.value, 1.0, kKnotTolerance) << ForceModelName(m.type());
    EXPECT_NEAR(p.slope, 0.0, 1e-12) << ForceModelName(m.type());
  }
}

TEST(MuscleCurves, MillardActiveCurveFloorFollowsDampingAndTendon) {
  // Millard2012EquilibriumMuscle::extendFinalizeFromProperties: the damped model (and the
  // rigid tendon) use minimum_value 0, the classic Hill model with a compliant tendon at
  // least 0.1; the curve is at its floor from min_norm_active_fiber_length (0.4441) down and
  // from max_norm_active_fiber_length (1.8123) up.
  for (double x : {0.2, 0.4441, 1.8123, 2.5}) {
    EXPECT_NEAR(Millard(0.1).ActiveForceLength(x).value, 0.0, kKnotTolerance) << x;
    EXPECT_NEAR(Millard(0.0, true).ActiveForceLength(x).value, 0.0, kKnotTolerance) << x;
    EXPECT_NEAR(Millard(0.0).ActiveForceLength(x).value, 0.1, kKnotTolerance) << x;
  }
  EXPECT_GT(Millard(0.1).ActiveForceLength(0.5).value, 0.0);
}

TEST(MuscleCurves, PassiveCurveZeroBelowSlackStrainAndOneAtStrainAtOneNormForce) {
  MuscleForceSpec spec;
  spec.model = ForceModelType::kMillard2012;
  spec.optimal_fiber_length = 0.03;
  spec.fiber_force_length.strain_at_zero_force = 0.05;
  spec.fiber_force_length.strain_at_one_norm_force = 0.6;
  const MuscleForceModel m("M", 1.0, spec);
  for (double x : {0.5, 0.9, 1.0, 1.05}) {
    EXPECT_EQ(m.PassiveForceLength(x).value, 0.0) << x;
    EXPECT_EQ(m.PassiveForceLength(x).slope, 0.0) << x;
  }
  EXPECT_GT(m.PassiveForceLength(1.06).value, 0.0);
  const CurvePoint one = m.PassiveForceLength(1.6);
  EXPECT_NEAR(one.value, 1.0, kKnotTolerance);
  // Default stiffness_at_one_norm_force 2 / (e1 - e0), and a straight line beyond.
  EXPECT_NEAR(one.slope, 2.0 / 0.55, 1e-12);
  EXPECT_NEAR(m.PassiveForceLength(1.8).value, 1.0 + 0.2 * 2.0 / 0.55, 1e-12);
  // Thelen: 0 up to the optimal length, 1 at 1 + FmaxMuscleStrain.
  const MuscleForceModel t = Thelen();
  EXPECT_EQ(t.PassiveForceLength(1.0).value, 0.0);
  EXPECT_NEAR(t.PassiveForceLength(1.6).value, 1.0, 1e-14);
}

TEST(MuscleCurves, TendonCurveOneAtStrainAtOneNormForceAndToeEndAtItsForce) {
  MuscleForceSpec spec;
  spec.model = ForceModelType::kMillard2012;
  spec.optimal_fiber_length = 0.03;
  spec.tendon_slack_length = 0.01;
  spec.tendon_force_length.strain_at_one_norm_force = 0.04;
  const MuscleForceModel m("M", 1.0, spec);
  EXPECT_EQ(m.TendonForceLength(0.98).value, 0.0);
  EXPECT_EQ(m.TendonForceLength(1.0).value, 0.0);
  const CurvePoint one = m.TendonForceLength(1.04);
  EXPECT_NEAR(one.value, 1.0, 1e-14);
  EXPECT_NEAR(one.slope, 1.375 / 0.04, 1e-10);
  // The toe region ends at norm_force_at_toe_end (2/3) on the line of slope 1.375 / e0
  // through (1 + e0, 1).
  // (toe is computed with a few roundings, ~4e-16; times the slope ~34: 1e-13.)
  const double toe = 1.04 + (2.0 / 3.0 - 1.0) / (1.375 / 0.04);
  EXPECT_NEAR(m.TendonForceLength(toe).value, 2.0 / 3.0, 1e-13);
  // Thelen: 1 at 1 + FmaxTendonStrain, the toe region meets the line with equal value and
  // slope (that is how Thelen2003Muscle::calcfse derives eToe and klin).
  const MuscleForceModel t = Thelen();
  EXPECT_NEAR(t.TendonForceLength(1.033).value, 1.0, 1e-14);
  const double e3 = std::exp(3.0);
  const double etoe = 99 * 0.033 * e3 / (166 * e3 - 67);
  const CurvePoint left = t.TendonForceLength(1 + etoe * (1 - 1e-12));
  const CurvePoint right = t.TendonForceLength(1 + etoe * (1 + 1e-12));
  EXPECT_NEAR(left.value, 0.33, 1e-10);
  EXPECT_NEAR(right.value, 0.33, 1e-10);
  EXPECT_NEAR(left.slope, right.slope, 1e-8 * right.slope);
}

// y at x of a Bezier segment by de Casteljau, u found by bisection on x(u): shares no code
// with SmoothCurve::Evaluate (power basis, Hermite guess, Newton).
double DeCasteljauY(const muscle::ControlPoints& p, double x) {
  double lo = 0, hi = 1;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (muscle::BezierValue(p.x, mid) < x ? lo : hi) = mid;
  }
  return muscle::BezierValue(p.y, 0.5 * (lo + hi));
}

TEST(MuscleCurves, BezierCurvesEqualDeCasteljauOfTheirControlPoints) {
  const muscle::SmoothCurve curves[] = {
      muscle::ActiveForceLengthCurve(ActiveForceLengthCurveSpec{}, 0.0, "M"),
      muscle::ActiveForceLengthCurve(ActiveForceLengthCurveSpec{}, 0.1, "M"),
      muscle::FiberForceLengthCurve(FiberForceLengthCurveSpec{}, "M"),
      muscle::TendonForceLengthCurve(TendonForceLengthCurveSpec{}, "M")};
  double worst = 0;
  for (const muscle::SmoothCurve& c : curves) {
    for (int s = 0; s < c.segment_count(); ++s) {
      const muscle::ControlPoints& p = c.control_points(s);
      for (int k = 0; k <= 40; ++k) {
        const double x = p.x[0] + (p.x[5] - p.x[0]) * k / 40.0;
        worst = std::max(worst, std::abs(c.Evaluate(x).value - DeCasteljauY(p, x)));
      }
    }
  }
  EXPECT_LT(worst, 1e-13);
}

#if defined(ISOWRENCH_CURVE_AVX2) && defined(__linux__)
// SmoothCurve::Lanes' AVX2 form (gathers), as MuscleForceModel::Tension4's avx2 version runs it.
__attribute__((target("avx2"))) void GatherLanes(const muscle::SmoothCurve& c,
                                                 const muscle::LaneDoubles& x,
                                                 muscle::LaneDoubles& value,
                                                 muscle::LaneDoubles& slope,
                                                 muscle::LaneDoubles& value_only) {
  muscle::LaneDoubles unused;
  c.Lanes<true, true>(x, value, slope);
  c.Lanes<false, true>(x, value_only, unused);
}
bool HasAvx2() { return __builtin_cpu_supports("avx2"); }
#else
void GatherLanes(const muscle::SmoothCurve&, const muscle::LaneDoubles&, muscle::LaneDoubles&,
                 muscle::LaneDoubles&, muscle::LaneDoubles&) {}
bool HasAvx2() { return false; }
#endif

// SmoothCurve::Lanes (the batch force stage's four-lane curves) is Value and SolveEvaluate lane
// by lane to the last bit: groups of four arguments spread over the whole curve (lanes in
// different segments), packed into one segment, on the guess table's knots, at the segment
// ends, outside [x0, x1] and NaN, on every curve kind (the active curve's far end needs more
// than one Newton step: the scalar fallback). Both forms: the portable one and, where the CPU
// has AVX2, the gathers (two-segment curves with the lanes in one segment read the segment's
// splatted coefficients).
TEST(MuscleCurves, LanesAreValueAndSolveEvaluateBitForBit) {
  const muscle::SmoothCurve curves[] = {
      muscle::ActiveForceLengthCurve(ActiveForceLengthCurveSpec{}, 0.0, "M"),
      muscle::ActiveForceLengthCurve(ActiveForceLengthCurveSpec{}, 0.1, "M"),
      muscle::FiberForceLengthCurve(FiberForceLengthCurveSpec{}, "M"),
      muscle::TendonForceLengthCurve(TendonForceLengthCurveSpec{}, "M")};
  auto bits = [](double v) {
    std::uint64_t b;
    std::memcpy(&b, &v, sizeof b);
    return b;
  };
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int groups = 0;
  const bool avx2 = HasAvx2();
  for (const muscle::SmoothCurve& c : curves) {
    const double x0 = c.x0(), x1 = c.x1(), w = x1 - x0;
    std::vector<double> special = {x0,
                                   x1,
                                   std::numeric_limits<double>::quiet_NaN(),
                                   x0 - w,
                                   x1 + w,
                                   std::nextafter(x1, 0.0),
                                   std::nextafter(x0, 2.0)};
    for (int s = 0; s < c.segment_count(); ++s) {
      const muscle::ControlPoints& p = c.control_points(s);
      for (int j = 0; j <= 64; ++j) special.push_back(p.x[0] + (p.x[5] - p.x[0]) * j / 64.0);
    }
    for (int group = 0; group < 4000; ++group) {
      muscle::LaneDoubles x;
      const double centre = x0 - 0.2 * w + 1.4 * w * unit(rng);
      for (int l = 0; l < 4; ++l) {
        const double pick = unit(rng);
        x[l] = pick < 0.5    ? x0 - 0.2 * w + 1.4 * w * unit(rng)
               : pick < 0.85 ? centre + 1e-3 * w * unit(rng)
                             : special[static_cast<std::size_t>(unit(rng) * special.size())];
      }
      muscle::LaneDoubles value, slope, value_only, unused;
      c.Lanes<true>(x, value, slope);
      c.Lanes<false>(x, value_only, unused);
      muscle::LaneDoubles g_value = value, g_slope = slope, g_value_only = value_only;
      if (avx2) GatherLanes(c, x, g_value, g_slope, g_value_only);
      for (int l = 0; l < 4; ++l) {
        const CurvePoint p = c.SolveEvaluate(x[l]);
        ASSERT_EQ(bits(value[l]), bits(p.value)) << "x " << x[l] << " lane " << l;
        ASSERT_EQ(bits(slope[l]), bits(p.slope)) << "x " << x[l] << " lane " << l;
        ASSERT_EQ(bits(value_only[l]), bits(c.Value(x[l]))) << "x " << x[l] << " lane " << l;
        ASSERT_EQ(bits(g_value[l]), bits(p.value)) << "gathers: x " << x[l] << " lane " << l;
        ASSERT_EQ(bits(g_slope[l]), bits(p.slope)) << "gathers: x " << x[l] << " lane " << l;
        ASSERT_EQ(bits(g_value_only[l]), bits(c.Value(x[l])))
            << "gathers: x " << x[l] << " lane " << l;
      }
      ++groups;
    }
  }
  EXPECT_EQ(groups, 16000);
}

TEST(MuscleCurves, GuessTableMakesOneNewtonStepEnough) {
  // The guess table (128 intervals per segment) puts u close enough to the curve's u on
  // OpenSim's default curves that one Newton step (at most 1e-8) finishes every evaluation and
  // no lane of the batch falls back to the scalar loop. Largest first steps over 100,001 points
  // per curve with 128 intervals: the active curve with floor 0 (the damped model's) 6.6e-9,
  // with floor 0.1 1.7e-10, the passive curve 2e-13, the tendon curve 1.2e-10; with 64 intervals
  // 3.6e-7, 1.06e-8, 1.3e-11 and 7.2e-9.
  const muscle::SmoothCurve curves[] = {
      muscle::ActiveForceLengthCurve(ActiveForceLengthCurveSpec{}, 0.0, "M"),
      muscle::ActiveForceLengthCurve(ActiveForceLengthCurveSpec{}, 0.1, "M"),
      muscle::FiberForceLengthCurve(FiberForceLengthCurveSpec{}, "M"),
      muscle::TendonForceLengthCurve(TendonForceLengthCurveSpec{}, "M")};
  for (const muscle::SmoothCurve& c : curves) {
    double largest = 0.0;
    for (int i = 0; i <= 100000; ++i) {
      const double x = c.x0() + (c.x1() - c.x0()) * (i / 100000.0);
      largest = std::max(largest, c.FirstNewtonStep(x));
    }
    EXPECT_LE(largest, 1e-8) << "curve over [" << c.x0() << ", " << c.x1() << "]";
  }
}

TEST(MuscleCurves, SlopesEqualCentralDifferences) {
  const MuscleForceModel models[] = {Millard(), Millard(0.0), Thelen()};
  const double h = 1e-6;  // truncation ~ h^2 y''' ~ 1e-10, rounding ~ 1e-16 / h = 1e-10
  for (const MuscleForceModel& m : models) {
    for (double x = 0.3; x < 2.0; x += 0.0173) {
      if (m.type() == ForceModelType::kThelen2003 && std::abs(x - 1.0) < 2 * h) continue;
      const double fd =
          (m.ActiveForceLength(x + h).value - m.ActiveForceLength(x - h).value) / (2 * h);
      EXPECT_NEAR(m.ActiveForceLength(x).slope, fd, 1e-7) << x;
      const double pd =
          (m.PassiveForceLength(x + h).value - m.PassiveForceLength(x - h).value) / (2 * h);
      EXPECT_NEAR(m.PassiveForceLength(x).slope, pd, 1e-7) << x;
    }
    for (double x = 1.0005; x < 1.08; x += 0.00137) {
      const double td =
          (m.TendonForceLength(x + h).value - m.TendonForceLength(x - h).value) / (2 * h);
      EXPECT_NEAR(m.TendonForceLength(x).slope, td, 1e-6 * (1 + std::abs(td))) << x;
    }
  }
}

TEST(MuscleCurves, CornerControlPointsFollowTheTangentLines) {
  // Hand derivation: from (0, 0) with slope 0 to (1, 1) with slope 2 the tangent lines meet
  // at xC = (y1 - y0 - x1 dydx1 + x0 dydx0) / (dydx0 - dydx1) = (1 - 2) / (-2) = 0.5,
  // yC = (xC - x1) dydx1 + y1 = 0. With curviness 0.5 the inner points are halfway to C:
  // (0.25, 0) twice and (0.75, 0.5) twice.
  muscle::ControlPoints p;
  ASSERT_TRUE(muscle::CornerControlPoints(0, 0, 0, 1, 1, 2, 0.5, &p));
  const std::array<double, 6> x = {0, 0.25, 0.25, 0.75, 0.75, 1};
  const std::array<double, 6> y = {0, 0, 0, 0.5, 0.5, 1};
  for (int i = 0; i < 6; ++i) {
    EXPECT_DOUBLE_EQ(p.x[i], x[i]) << i;
    EXPECT_DOUBLE_EQ(p.y[i], y[i]) << i;
  }
  // An S-shaped request (the lines meet beyond the chord) is refused, as OpenSim does.
  EXPECT_FALSE(muscle::CornerControlPoints(0, 0, 10, 1, 1, 10.5, 0.5, &p));
}

TEST(MuscleCurves, CurveParametersOpenSimRejectsAreErrorsNamingMuscleAndValue) {
  auto build = [](auto edit) {
    MuscleForceSpec spec;
    spec.model = ForceModelType::kMillard2012;
    spec.optimal_fiber_length = 0.03;
    spec.tendon_slack_length = 0.01;
    edit(spec);
    MuscleForceModel("R_GP", 2.35, spec);
  };
  using ::testing::ThrowsMessage;
  EXPECT_THAT(
      [&] {
        build([](MuscleForceSpec& s) { s.active_force_length.transition_norm_fiber_length = 0.4; });
      },
      ThrowsMessage<Error>(AllOf(HasSubstr("R_GP"), HasSubstr("ActiveForceLengthCurve"),
                                 HasSubstr("transition_norm_fiber_length 0.4"))));
  EXPECT_THAT(
      [&] { build([](MuscleForceSpec& s) { s.active_force_length.shallow_ascending_slope = 5; }); },
      ThrowsMessage<Error>(HasSubstr("shallow_ascending_slope 5 must be >= 0 and <")));
  EXPECT_THAT(
      [&] {
        build([](MuscleForceSpec& s) { s.active_force_length.max_norm_active_fiber_length = 1.0; });
      },
      ThrowsMessage<Error>(HasSubstr("max_norm_active_fiber_length 1")));
  EXPECT_THAT([&] { build([](MuscleForceSpec& s) { s.fiber_force_length.curviness = 0.5; }); },
              ThrowsMessage<Error>(AllOf(HasSubstr("FiberForceLengthCurve"),
                                         HasSubstr("must all be set or all be empty"))));
  EXPECT_THAT(
      [&] {
        build([](MuscleForceSpec& s) { s.fiber_force_length.strain_at_one_norm_force = -0.1; });
      },
      ThrowsMessage<Error>(HasSubstr("strain_at_one_norm_force -0.1 must be greater")));
  EXPECT_THAT(
      [&] {
        build([](MuscleForceSpec& s) {
          s.fiber_force_length.stiffness_at_low_force = 0.2;
          s.fiber_force_length.stiffness_at_one_norm_force = 1.0;  // <= 1/0.7
          s.fiber_force_length.curviness = 0.5;
        });
      },
      ThrowsMessage<Error>(HasSubstr("stiffness_at_one_norm_force 1 must be greater")));
  EXPECT_THAT(
      [&] {
        build([](MuscleForceSpec& s) { s.tendon_force_length.strain_at_one_norm_force = 0; });
      },
      ThrowsMessage<Error>(AllOf(HasSubstr("TendonForceLengthCurve"),
                                 HasSubstr("strain_at_one_norm_force 0 must be > 0"))));
  EXPECT_THAT(
      [&] {
        build([](MuscleForceSpec& s) {
          s.tendon_force_length.stiffness_at_one_norm_force = 30;
          s.tendon_force_length.norm_force_at_toe_end = 1.0;
          s.tendon_force_length.curviness = 0.5;
        });
      },
      ThrowsMessage<Error>(HasSubstr("norm_force_at_toe_end 1 must be > 0 and < 1")));
  EXPECT_THAT(
      [&] {
        build([](MuscleForceSpec& s) {
          s.tendon_force_length.stiffness_at_one_norm_force = 30;
          s.tendon_force_length.norm_force_at_toe_end = 0.5;
          s.tendon_force_length.curviness = 1.5;
        });
      },
      ThrowsMessage<Error>(HasSubstr("curviness 1.5 must be in [0, 1]")));
}

}  // namespace
}  // namespace isowrench
