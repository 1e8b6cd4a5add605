// Moving and conditional muscle path points (issue 13): the URDF syntax (reader, writer, errors
// naming file and line), and the engine against a closed form written in this file: a planar
// two-joint leg whose muscle runs from the ground over a thigh point that is in the path only
// for some knee angles, to a shank point that slides along the shank as a function of the knee
// angle (clamped to the knee's range, as OpenSim's MovingPathPoint).

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "isowrench/isowrench.hpp"

namespace isowrench {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

constexpr const char* kSource = "moving.urdf";

// The leg: hip (rz) at the ground origin, thigh 0.03 m along x to the knee (rz, range
// [-2, 0.5] rad), shank 0.04 m along x to the foot (the endpoint).
constexpr double kThigh = 0.03;  // the shank (0.04 m) carries no path point the closed form needs
constexpr double kKneeLower = -2.0, kKneeUpper = 0.5;

// The muscle: origin on the ground at G, point T on the thigh (active for knee in
// [kActiveLower, kActiveUpper]), insertion S on the shank whose x follows the knee through the
// piecewise-linear function below and whose z follows the hip through a linear function (a
// second coordinate, on purpose: the URDF syntax allows one per axis).
const Eigen::Vector3d kG(-0.01, 0.008, 0.0);
const Eigen::Vector3d kT(0.02, 0.006, 0.001);
constexpr double kActiveLower = -1.2, kActiveUpper = -0.3;
constexpr double kSy = 0.004;
// x of S on the shank: piecewise linear through (-2, 0.010), (-0.5, 0.016), (0.5, 0.012).
double ShankX(double knee) {
  if (knee <= -0.5) return 0.010 + (knee + 2.0) * (0.006 / 1.5);
  return 0.016 - (knee + 0.5) * 0.004;
}
// z of S: 0.002 + 0.001 hip (hip is unlimited: no clamp).
double ShankZ(double hip) { return 0.002 + 0.001 * hip; }

std::string Leg(const std::string& shank_point, const std::string& thigh_point) {
  return std::string(R"(<?xml version="1.0"?>
<robot name="moving_leg" xmlns:isowrench="urn:isowrench:urdf:1">
  <link name="ground"/> <link name="thigh"/> <link name="shank"/> <link name="foot"/>
  <joint name="hip" type="continuous">
    <parent link="ground"/> <child link="thigh"/> <axis xyz="0 0 1"/>
  </joint>
  <joint name="knee" type="revolute">
    <parent link="thigh"/> <child link="shank"/> <origin xyz="0.03 0 0"/> <axis xyz="0 0 1"/>
    <limit lower="-2" upper="0.5" effort="1" velocity="1"/>
  </joint>
  <joint name="ankle" type="fixed">
    <parent link="shank"/> <child link="foot"/> <origin xyz="0.04 0 0"/>
  </joint>
  <isowrench:transducer link="foot" xyz="0 0 0" stiffness="1e4 1e4 1e4 10 10 10"/>
  <isowrench:muscle name="M" max_force="2">
    <isowrench:point link="ground" xyz="-0.01 0.008 0"/>
)") + thigh_point +
         "\n" + shank_point + R"(
  </isowrench:muscle>
</robot>
)";
}

const std::string kThighPoint =
    R"(    <isowrench:point link="thigh" xyz="0.02 0.006 0.001" active_coordinate="knee" active_range="-1.2 -0.3"/>)";
const std::string kShankPoint = R"(    <isowrench:point link="shank" xyz="0 0.004 0">
      <isowrench:moving axis="x" coordinate="knee">
        <isowrench:piecewise_linear x="-2 -0.5 0.5" y="0.010 0.016 0.012"/>
      </isowrench:moving>
      <isowrench:moving axis="z" coordinate="hip">
        <isowrench:linear slope="0.001" intercept="0.002"/>
      </isowrench:moving>
    </isowrench:point>)";

LimbDescription Read(const std::string& xml) { return ReadUrdfString(xml, kSource); }

// The line of the first occurrence of `text` in `xml` (1-based).
int LineOf(const std::string& xml, const std::string& text) {
  const size_t at = xml.find(text);
  EXPECT_NE(at, std::string::npos) << text;
  return 1 + static_cast<int>(std::count(xml.begin(), xml.begin() + at, '\n'));
}

void ExpectReadError(const std::string& xml, const std::string& line_text,
                     const std::string& what) {
  const std::string where = std::string(kSource) + ":" + std::to_string(LineOf(xml, line_text));
  EXPECT_THAT([&] { Read(xml); }, ThrowsMessage<Error>(AllOf(HasSubstr(where), HasSubstr(what))));
}

// ---- URDF syntax -------------------------------------------------------------------------------

TEST(PathPointUrdf, ReadsMovingComponentsAndTheActiveRange) {
  const LimbDescription d = Read(Leg(kShankPoint, kThighPoint));
  ASSERT_EQ(d.muscles.size(), 1u);
  const std::vector<PathPoint>& path = d.muscles[0].path;
  ASSERT_EQ(path.size(), 3u);
  EXPECT_TRUE(path[0].moving.empty());
  EXPECT_TRUE(path[0].active_coordinate.empty());
  EXPECT_EQ(path[1].active_coordinate, "knee");
  EXPECT_EQ(path[1].active_lower, -1.2);
  EXPECT_EQ(path[1].active_upper, -0.3);
  ASSERT_EQ(path[2].moving.size(), 2u);
  EXPECT_EQ(path[2].moving[0].axis, 0);
  EXPECT_EQ(path[2].moving[0].coordinate, "knee");
  EXPECT_EQ(path[2].moving[0].function.kind(), FunctionKind::kPiecewiseLinear);
  EXPECT_NEAR(path[2].moving[0].function.Value(-1.25), 0.013, 1e-17);  // halfway between knots
  EXPECT_EQ(path[2].moving[1].axis, 2);
  EXPECT_EQ(path[2].moving[1].coordinate, "hip");
  EXPECT_DOUBLE_EQ(path[2].moving[1].function.Value(2.0), 0.004);
}

TEST(PathPointUrdf, WriterRoundTripsMovingAndConditionalPoints) {
  const LimbDescription d = Read(Leg(kShankPoint, kThighPoint));
  const std::string written = WriteUrdfString(d);
  EXPECT_THAT(written, AllOf(HasSubstr("active_coordinate=\"knee\" active_range=\"-1.2 -0.2999"),
                             HasSubstr("<isowrench:moving axis=\"x\" coordinate=\"knee\">"),
                             HasSubstr("<isowrench:moving axis=\"z\" coordinate=\"hip\">")));
  const LimbDescription back = ReadUrdfString(written, "written.urdf");
  ASSERT_EQ(back.muscles.size(), 1u);
  const std::vector<PathPoint>& a = d.muscles[0].path;
  const std::vector<PathPoint>& b = back.muscles[0].path;
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].link, b[i].link);
    EXPECT_EQ(a[i].position, b[i].position);
    EXPECT_EQ(a[i].active_coordinate, b[i].active_coordinate);
    EXPECT_EQ(a[i].active_lower, b[i].active_lower);
    EXPECT_EQ(a[i].active_upper, b[i].active_upper);
    ASSERT_EQ(a[i].moving.size(), b[i].moving.size());
    for (size_t k = 0; k < a[i].moving.size(); ++k) {
      EXPECT_EQ(a[i].moving[k].axis, b[i].moving[k].axis);
      EXPECT_EQ(a[i].moving[k].coordinate, b[i].moving[k].coordinate);
      for (double q : {-2.5, -1.7, -0.5, 0.1, 0.9}) {
        EXPECT_EQ(a[i].moving[k].function.Value(q), b[i].moving[k].function.Value(q));
      }
    }
  }
}

TEST(PathPointUrdfErrors, NameFileLineMuscleAndRule) {
  {  // unknown coordinate, with the closest name
    const std::string xml = Leg(kShankPoint, R"(    <isowrench:point link="thigh" xyz="0 0 0"
        active_coordinate="kne" active_range="-1 0"/>)");
    ExpectReadError(xml, "<isowrench:point link=\"thigh\"",
                    "muscle 'M', point on 'thigh', active_coordinate: unknown coordinate 'kne'");
    ExpectReadError(xml, "<isowrench:point link=\"thigh\"", "did you mean 'knee'");
  }
  {  // a moving component naming an unknown coordinate
    std::string shank = kShankPoint;
    shank.replace(shank.find("coordinate=\"hip\""), 16, "coordinate=\"hipp\"");
    const std::string xml = Leg(shank, kThighPoint);
    ExpectReadError(xml, "<isowrench:moving axis=\"z\"",
                    "moving axis z: unknown coordinate 'hipp' in model 'moving_leg'");
  }
  {  // bad axis
    std::string shank = kShankPoint;
    shank.replace(shank.find("axis=\"z\""), 8, "axis=\"w\"");
    const std::string xml = Leg(shank, kThighPoint);
    ExpectReadError(xml, "<isowrench:moving axis=\"w\"", "moving axis 'w' is not one of x, y, z");
  }
  {  // duplicate axis
    std::string shank = kShankPoint;
    shank.replace(shank.find("axis=\"z\""), 8, "axis=\"x\"");
    const std::string xml = Leg(shank, kThighPoint);
    ExpectReadError(xml, "<isowrench:moving axis=\"x\" coordinate=\"hip\"",
                    "axis 'x' has two <isowrench:moving> elements");
  }
  {  // range lower > upper
    const std::string xml = Leg(kShankPoint, R"(    <isowrench:point link="thigh" xyz="0 0 0"
        active_coordinate="knee" active_range="0.3 -1.2"/>)");
    ExpectReadError(xml, "<isowrench:point link=\"thigh\"", "active_range lower 0.3 > upper -1.2");
  }
  {  // NaN in the range
    const std::string xml = Leg(kShankPoint, R"(    <isowrench:point link="thigh" xyz="0 0 0"
        active_coordinate="knee" active_range="nan 0.3"/>)");
    ExpectReadError(xml, "<isowrench:point link=\"thigh\"", "'nan' is not finite");
  }
  {  // a range without its coordinate
    const std::string xml = Leg(kShankPoint, R"(    <isowrench:point link="thigh" xyz="0 0 0"
        active_range="-1 0"/>)");
    ExpectReadError(xml, "<isowrench:point link=\"thigh\"",
                    "give both active_coordinate= and active_range=");
  }
  {  // no function in a moving element
    std::string shank = kShankPoint;
    shank.replace(shank.find("<isowrench:linear"), 54, "");
    const std::string xml = Leg(shank, kThighPoint);
    ExpectReadError(xml, "<isowrench:moving axis=\"z\"", "needs one function element");
  }
  {  // something else inside a point
    const std::string xml = Leg(kShankPoint, R"(    <isowrench:point link="thigh" xyz="0 0 0">
      <isowrench:coupling joint="knee" coordinate="hip"/>
    </isowrench:point>)");
    ExpectReadError(xml, "<isowrench:coupling joint=\"knee\"", "expected <isowrench:moving>");
  }
  {  // only one point that is always in the path
    const std::string xml = Leg(R"(    <isowrench:point link="shank" xyz="0.01 0 0"
        active_coordinate="knee" active_range="-1 0"/>)",
                                kThighPoint);
    ExpectReadError(xml, "<isowrench:muscle name=\"M\"",
                    "needs at least two points without active_coordinate");
  }
}

// ---- the engine against the closed form -------------------------------------------------------

Eigen::Matrix3d Rz(double a) {
  return Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

// The muscle's length written out: thigh frame Rz(hip) at the origin, shank frame Rz(hip + knee)
// at Rz(hip) (kThigh, 0, 0); the shank point's x uses the knee clamped to its range.
double ClosedFormLength(double hip, double knee, const Eigen::Vector3d& thigh_point,
                        bool* active = nullptr) {
  const double k = std::clamp(knee, kKneeLower, kKneeUpper);
  const Eigen::Vector3d s_local(ShankX(k), kSy, ShankZ(hip));
  const Eigen::Vector3d knee_origin = Rz(hip) * Eigen::Vector3d(kThigh, 0, 0);
  const Eigen::Vector3d S = knee_origin + Rz(hip + knee) * s_local;
  const Eigen::Vector3d T = Rz(hip) * thigh_point;
  const bool on = knee >= kActiveLower - 1e-5 && knee <= kActiveUpper + 1e-5;
  if (active) *active = on;
  return on ? (T - kG).norm() + (S - T).norm() : (S - kG).norm();
}

// Central differences of the closed form, h = 1e-6: truncation h^2 |L'''| / 6 < 1e-13,
// round-off eps L / h ~ 1e-11.
Eigen::RowVector2d ClosedFormGradient(double hip, double knee, const Eigen::Vector3d& t) {
  constexpr double h = 1e-6;
  return Eigen::RowVector2d(
      (ClosedFormLength(hip + h, knee, t) - ClosedFormLength(hip - h, knee, t)) / (2 * h),
      (ClosedFormLength(hip, knee + h, t) - ClosedFormLength(hip, knee - h, t)) / (2 * h));
}

Model LegModel(const Eigen::Vector3d& thigh_point = kT) {
  LimbDescription d = Read(Leg(kShankPoint, kThighPoint));
  d.muscles[0].path[1].position = thigh_point;
  return Model(d);
}

TEST(PathPointEngine, LengthMatchesTheClosedFormInsideAndBeyondTheRanges) {
  const Model model = LegModel();
  Data ws(model);
  int active = 0, inactive = 0;
  for (double hip : {-0.4, 0.3, 1.1}) {
    for (double knee : {-2.6, -2.0, -1.5, -1.2, -0.7, -0.3, 0.0, 0.5, 0.9}) {
      bool on = false;
      const double expected = ClosedFormLength(hip, knee, kT, &on);
      (on ? active : inactive)++;
      const MuscleTorque t = ComputeMuscleTorque(model, ws, Eigen::Vector2d(hip, knee), 0);
      EXPECT_NEAR(t.length, expected, 1e-15) << "hip " << hip << " knee " << knee;
    }
  }
  EXPECT_GT(active, 0);
  EXPECT_GT(inactive, 0);
}

TEST(PathPointEngine, MusclePathPointsAreTheActivePointsWhereTheyAre) {
  const Model model = LegModel();
  Data ws(model);
  for (double knee : {-2.6, -0.7, 0.9}) {  // clamped and inactive, active, clamped and inactive
    const double hip = 0.3;
    const double k = std::clamp(knee, kKneeLower, kKneeUpper);
    const Eigen::Vector3d S = Rz(hip) * Eigen::Vector3d(kThigh, 0, 0) +
                              Rz(hip + knee) * Eigen::Vector3d(ShankX(k), kSy, ShankZ(hip));
    std::vector<Eigen::Vector3d> expected = {kG};
    if (knee >= kActiveLower && knee <= kActiveUpper) expected.push_back(Rz(hip) * kT);
    expected.push_back(S);
    const std::vector<Eigen::Vector3d> points =
        MusclePathPoints(model, ws, Eigen::Vector2d(hip, knee), 0);
    ASSERT_EQ(points.size(), expected.size()) << "knee " << knee;
    for (size_t i = 0; i < points.size(); ++i) {
      EXPECT_LT((points[i] - expected[i]).norm(), 1e-16) << "knee " << knee << " point " << i;
    }
  }
  EXPECT_THROW(MusclePathPoints(model, ws, Eigen::Vector2d(0, 0), 1), Error);
}

TEST(PathPointEngine, MomentArmsAreFiniteDifferencesOfTheClosedForm) {
  const Model model = LegModel();
  Data ws(model);
  // Knee angles away from the kinks (knots at -2, -0.5, 0.5; clamp at -2 and 0.5; switches at
  // -1.2 - 1e-5 and -0.3 + 1e-5), including beyond the knee's range where the moving x is
  // clamped (its term of dL/dknee is 0 there).
  for (double hip : {-0.4, 0.3, 1.1}) {
    for (double knee : {-2.6, -1.5, -1.0, -0.7, -0.2, 0.2, 0.9}) {
      const MuscleTorque t = ComputeMuscleTorque(model, ws, Eigen::Vector2d(hip, knee), 0, 0.5);
      const Eigen::RowVector2d expected = ClosedFormGradient(hip, knee, kT);
      EXPECT_NEAR(t.dL_dq[0], expected[0], 1e-9) << "hip " << hip << " knee " << knee;
      EXPECT_NEAR(t.dL_dq[1], expected[1], 1e-9) << "hip " << hip << " knee " << knee;
      EXPECT_NEAR(t.tau[1], -0.5 * 2.0 * expected[1], 1e-9);  // -activation F dL/dq
    }
  }
}

// Across the switch at knee -0.3 + 1e-5 (hip 0.3), each side follows its own closed form: the
// length jumps by D = |T - G| + |S - T| - |S - G| >= 0 and the moment arm by dD/dq. With the
// thigh point on the straight line from G to S there, D and dD/dq are 0 (D has its minimum
// there): length and moment arm are continuous.
void CheckSwitch(const Eigen::Vector3d& thigh_point, bool on_the_line) {
  const double hip = 0.3, knee_switch = kActiveUpper + 1e-5;
  const Model model = LegModel(thigh_point);
  Data ws(model);
  constexpr double d = 1e-9;
  const MuscleTorque in = ComputeMuscleTorque(model, ws, Eigen::Vector2d(hip, knee_switch - d), 0);
  const MuscleTorque out = ComputeMuscleTorque(model, ws, Eigen::Vector2d(hip, knee_switch + d), 0);
  bool on_in = false, on_out = true;
  EXPECT_NEAR(in.length, ClosedFormLength(hip, knee_switch - d, thigh_point, &on_in), 1e-15);
  EXPECT_NEAR(out.length, ClosedFormLength(hip, knee_switch + d, thigh_point, &on_out), 1e-15);
  ASSERT_TRUE(on_in);
  ASSERT_FALSE(on_out);
  // One-sided differences of the closed form, h = 1e-7: error ~h |L''| < 1e-8.
  constexpr double h = 1e-7;
  const double left = (ClosedFormLength(hip, knee_switch - d, thigh_point) -
                       ClosedFormLength(hip, knee_switch - d - h, thigh_point)) /
                      h;
  const double right = (ClosedFormLength(hip, knee_switch + d + h, thigh_point) -
                        ClosedFormLength(hip, knee_switch + d, thigh_point)) /
                       h;
  EXPECT_NEAR(in.dL_dq[1], left, 1e-7);
  EXPECT_NEAR(out.dL_dq[1], right, 1e-7);
  if (on_the_line) {
    EXPECT_LT(std::abs(in.length - out.length), 1e-10);  // |dL/dq| < 0.05 m over 2 nm
    EXPECT_LT(std::abs(in.dL_dq[1] - out.dL_dq[1]), 1e-6);
  } else {
    EXPECT_GT(std::abs(in.length - out.length), 1e-5) << "the fixture must make it jump";
    EXPECT_GT(std::abs(in.dL_dq[1] - out.dL_dq[1]), 1e-4) << "the fixture must make it jump";
  }
}

TEST(PathPointEngine, ConditionalPointSwitchJumpsOffTheLineAndIsContinuousOnIt) {
  CheckSwitch(kT, false);
  // 40 % of the way from G to S at the switch posture, in the thigh frame.
  const double hip = 0.3, k = kActiveUpper + 1e-5;
  const Eigen::Vector3d S = Rz(hip) * Eigen::Vector3d(kThigh, 0, 0) +
                            Rz(hip + k) * Eigen::Vector3d(ShankX(k), kSy, ShankZ(hip));
  CheckSwitch(Rz(hip).transpose() * (kG + 0.4 * (S - kG)), true);
}

TEST(PathPointEngine, BatchEqualsSingleEvaluations) {
  const Model model = LegModel();
  const std::vector<double> hips = {-0.4, 0.3, 1.1};
  const std::vector<double> knees = {-2.6, -1.5, -1.0, -0.7, -0.2, 0.2, 0.9};
  Eigen::MatrixXd postures(2, static_cast<long>(hips.size() * knees.size()));
  long column = 0;
  for (double hip : hips) {
    for (double knee : knees) {
      postures(0, column) = hip;
      postures(1, column++) = knee;
    }
  }
  std::vector<StiffnessSet> sets = {model.model_stiffness()};
  StiffnessSet soft = sets[0];
  soft.s_p = JointVector::Constant(2, 0.5);
  sets.push_back(soft);
  std::vector<WrenchResult> batch;
  EvaluateBatch(model, postures, 0, sets, batch, 0.7);
  Data ws(model);
  for (long p = 0; p < postures.cols(); ++p) {
    for (size_t s = 0; s < sets.size(); ++s) {
      const WrenchResult single = Evaluate(model, ws, postures.col(p), 0, sets[s], 0.7);
      const WrenchResult& b = batch[p * sets.size() + s];
      EXPECT_EQ(b.status, single.status);
      EXPECT_EQ(b.status, StaticsStatus::kOk);
      for (int i = 0; i < 6; ++i) {
        EXPECT_NEAR(b.wrench[i], single.wrench[i], 1e-12 * (1 + single.wrench.norm()))
            << "posture " << p << " set " << s;
      }
    }
  }
}

TEST(PathPointEngine, ModelRefusesUnknownCoordinatesAndBadRanges) {
  const LimbDescription d = Read(Leg(kShankPoint, kThighPoint));
  LimbDescription bad = d;
  bad.muscles[0].path[2].moving[0].coordinate = "ankle";
  EXPECT_THAT([&] { Model m(bad); },
              ThrowsMessage<Error>(AllOf(HasSubstr("muscle 'M', point on 'shank', moving axis x"),
                                         HasSubstr("is fixed; it has no coordinate"))));
  bad = d;
  bad.muscles[0].path[1].active_upper = std::nan("");
  EXPECT_THAT([&] { Model m(bad); },
              ThrowsMessage<Error>(HasSubstr("active range [-1.2, nan] must be finite")));
}

}  // namespace
}  // namespace isowrench
