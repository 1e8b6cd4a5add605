// Coupled joints and independent coordinates (issue 12 items 2 and 3): URDF <mimic>,
// <isowrench:coupling>, <isowrench:coordinate>, locked coordinates, posture naming, the
// description edits and the writer. Expected values are derived by hand in the test (composed
// linear maps, cubics a SimmSpline must reproduce, a natural spline solved on paper).

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "eigen_compare.hpp"
#include "isowrench/kinematics.hpp"
#include "isowrench/posture.hpp"
#include "test_models.hpp"

namespace isowrench_test {
namespace {

using isowrench::CoordinateSpec;
using isowrench::Error;
using isowrench::FunctionKind;
using isowrench::JointSpec;
using isowrench::JointType;
using isowrench::LimbDescription;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

constexpr const char* kSource = "leg.urdf";

/// A leg hip (rz) - knee_tx (prismatic x) - knee_ty (prismatic y) - knee (rz) - weld (fixed)
/// with the endpoint on "foot". `joint_extra` maps a joint name to XML placed inside it;
/// `extensions` goes before </robot>.
std::string Leg(const std::string& tx_extra, const std::string& ty_extra,
                const std::string& extensions) {
  return std::string(R"(<?xml version="1.0"?>
<robot name="leg" xmlns:isowrench="urn:isowrench:urdf:1">
  <link name="ground"/> <link name="thigh"/> <link name="slide_x"/> <link name="slide_y"/>
  <link name="shank"/> <link name="foot"/>
  <joint name="hip" type="continuous">
    <parent link="ground"/> <child link="thigh"/> <origin xyz="0 0 0"/> <axis xyz="0 0 1"/>
  </joint>
  <joint name="knee_tx" type="prismatic">
    <parent link="thigh"/> <child link="slide_x"/> <origin xyz="0.03 0 0"/> <axis xyz="1 0 0"/>
    <limit lower="-0.01" upper="0.01" effort="1" velocity="1"/>
)") + tx_extra +
         R"(
  </joint>
  <joint name="knee_ty" type="prismatic">
    <parent link="slide_x"/> <child link="slide_y"/> <origin xyz="0 0 0"/> <axis xyz="0 1 0"/>
    <limit lower="-0.01" upper="0.01" effort="1" velocity="1"/>
)" + ty_extra +
         R"(
  </joint>
  <joint name="knee" type="revolute">
    <parent link="slide_y"/> <child link="shank"/> <origin xyz="0 0 0"/> <axis xyz="0 0 1"/>
    <limit lower="-0.5" upper="2.5" effort="1" velocity="1"/>
  </joint>
  <joint name="weld" type="fixed">
    <parent link="shank"/> <child link="foot"/> <origin xyz="0.04 0 0"/>
  </joint>
  <isowrench:transducer link="foot" xyz="0 0 0"/>
  <isowrench:muscle name="M" max_force="1">
    <isowrench:point link="ground" xyz="0.01 0.012 0.003"/>
    <isowrench:point link="shank" xyz="0.012 -0.004 0.002"/>
  </isowrench:muscle>
)" + extensions +
         R"(
</robot>
)";
}

LimbDescription Read(const std::string& xml) { return isowrench::ReadUrdfString(xml, kSource); }

const JointSpec& Joint(const LimbDescription& d, const std::string& name) {
  for (const JointSpec& j : d.joints) {
    if (j.name == name) return j;
  }
  throw std::runtime_error("no joint " + name);
}

std::vector<std::string> CoordinateNames(const LimbDescription& d) {
  std::vector<std::string> names;
  for (const CoordinateSpec& c : d.coordinates) names.push_back(c.name);
  return names;
}

/// "leg.urdf:<line of the first occurrence of needle>".
std::string At(const std::string& xml, const std::string& needle) {
  const size_t pos = xml.find(needle);
  if (pos == std::string::npos) throw std::runtime_error("needle not found: " + needle);
  return std::string(kSource) + ":" +
         std::to_string(1 + std::count(xml.begin(), xml.begin() + pos, '\n'));
}

/// "leg.urdf:<line of the last occurrence of needle>".
std::string AtLast(const std::string& xml, const std::string& needle) {
  const size_t pos = xml.rfind(needle);
  if (pos == std::string::npos) throw std::runtime_error("needle not found: " + needle);
  return std::string(kSource) + ":" +
         std::to_string(1 + std::count(xml.begin(), xml.begin() + pos, '\n'));
}

// ---- ordinary URDFs: one identity coordinate per movable joint ------------------------------

TEST(Coordinates, OrdinaryUrdfGivesOneIdentityCoordinatePerMovableJointInChainOrder) {
  for (const std::string& file : ShippedUrdfs()) {
    const LimbDescription d = LoadDescription(file);
    std::vector<std::string> movable;
    for (const JointSpec& j : d.joints) {
      if (j.type == JointType::kFixed) continue;
      movable.push_back(j.name);
      EXPECT_EQ(j.coordinate, j.name) << file;
      EXPECT_TRUE(j.coupling.is_identity()) << file << " " << j.name;
      const CoordinateSpec& c = isowrench::FindCoordinate(d, j.name);
      EXPECT_EQ(c.joint, j.name);
      EXPECT_EQ(c.type, j.type);
      EXPECT_EQ(c.role, j.role);
      EXPECT_EQ(c.stiffness, j.stiffness);
      EXPECT_FALSE(c.locked);
    }
    EXPECT_EQ(CoordinateNames(d), movable) << file;
  }
}

TEST(Coordinates, JointStiffnessAndRoleAreTheCoordinates) {
  const LimbDescription d = LoadDescription("rat_hindlimb_6dof.urdf");
  const CoordinateSpec& c = isowrench::FindCoordinate(d, "knee_ry");
  EXPECT_EQ(c.role, isowrench::JointRole::kExtra);
  EXPECT_EQ(c.stiffness, Joint(d, "knee_ry").stiffness);
  EXPECT_GT(c.stiffness, 0.0);
}

TEST(Coordinates, UrdfLimitsBecomeTheCoordinateRange) {
  const LimbDescription d = Read(Leg("", "", ""));
  const CoordinateSpec& knee = isowrench::FindCoordinate(d, "knee");
  EXPECT_EQ(knee.lower, -0.5);
  EXPECT_EQ(knee.upper, 2.5);
  EXPECT_TRUE(std::isinf(isowrench::FindCoordinate(d, "hip").upper));  // continuous
}

// ---- <mimic> ---------------------------------------------------------------------------------

TEST(Mimic, PrismaticJointFollowsARevoluteOne) {
  const LimbDescription d =
      Read(Leg(R"(<mimic joint="knee" multiplier="0.01" offset="0.002"/>)", "", ""));
  EXPECT_EQ(CoordinateNames(d), (std::vector<std::string>{"hip", "knee", "knee_ty"}));
  const JointSpec& tx = Joint(d, "knee_tx");
  EXPECT_EQ(tx.coordinate, "knee");
  ASSERT_TRUE(tx.coupling.is_linear());
  EXPECT_EQ(tx.coupling.slope(), 0.01);
  EXPECT_EQ(tx.coupling.intercept(), 0.002);
  EXPECT_EQ(tx.coupling.Value(2.0), 0.01 * 2.0 + 0.002);
  // The coordinate is carried by the knee, whose limits it keeps.
  EXPECT_EQ(isowrench::FindCoordinate(d, "knee").joint, "knee");
}

TEST(Mimic, DefaultsAreMultiplierOneOffsetZero) {
  const LimbDescription d = Read(Leg(R"(<mimic joint="knee"/>)", "", ""));
  EXPECT_TRUE(Joint(d, "knee_tx").coupling.is_identity());
  EXPECT_EQ(Joint(d, "knee_tx").coordinate, "knee");
}

TEST(Mimic, MimicOfAMimicResolvesToTheIndependentCoordinate) {
  // knee_ty = 2 knee_tx + 0.001 and knee_tx = 0.01 knee + 0.002
  //   => knee_ty = 0.02 knee + (2 * 0.002 + 0.001) = 0.02 knee + 0.005.
  const LimbDescription d =
      Read(Leg(R"(<mimic joint="knee" multiplier="0.01" offset="0.002"/>)",
               R"(<mimic joint="knee_tx" multiplier="2" offset="0.001"/>)", ""));
  EXPECT_EQ(CoordinateNames(d), (std::vector<std::string>{"hip", "knee"}));
  const JointSpec& ty = Joint(d, "knee_ty");
  EXPECT_EQ(ty.coordinate, "knee");
  ASSERT_TRUE(ty.coupling.is_linear());
  EXPECT_DOUBLE_EQ(ty.coupling.slope(), 0.02);
  EXPECT_DOUBLE_EQ(ty.coupling.intercept(), 0.005);
}

TEST(Mimic, MimicOfASplineCoupledJointScalesAndShiftsTheSpline) {
  // knee_tx = c(knee) with c(x) = 1e-3 (x^3 - 2 x^2 + 0.5 x): a SimmSpline through knots of a
  // cubic reproduces it between the knots and continues with the end slope outside them.
  auto c = [](double x) { return 1e-3 * (x * x * x - 2 * x * x + 0.5 * x); };
  auto dc = [](double x) { return 1e-3 * (3 * x * x - 4 * x + 0.5); };
  const std::string spline = R"(<isowrench:coupling joint="knee_tx" coordinate="knee">
    <isowrench:simm_spline x="-1 0 1 2 3" y=")" +
                             std::to_string(c(-1)) + " " + std::to_string(c(0)) + " " +
                             std::to_string(c(1)) + " " + std::to_string(c(2)) + " " +
                             std::to_string(c(3)) + R"("/></isowrench:coupling>)";
  const LimbDescription d =
      Read(Leg("", R"(<mimic joint="knee_tx" multiplier="-0.5" offset="0.001"/>)", spline));
  const JointSpec& tx = Joint(d, "knee_tx");
  const JointSpec& ty = Joint(d, "knee_ty");
  EXPECT_EQ(tx.coordinate, "knee");
  EXPECT_EQ(ty.coordinate, "knee");
  EXPECT_EQ(tx.coupling.kind(), FunctionKind::kSimmSpline);
  // std::to_string rounds the knots to 1e-6 m... of values of order 1e-3: exact to 1e-9.
  for (double x : {-0.5, 0.25, 1.5, 2.75}) {
    EXPECT_NEAR(tx.coupling.Value(x), c(x), 1e-9) << x;
    EXPECT_NEAR(ty.coupling.Value(x), -0.5 * c(x) + 0.001, 1e-9) << x;
    EXPECT_NEAR(ty.coupling.Derivative(x), -0.5 * dc(x), 1e-8) << x;
  }
  // Linear extrapolation on both sides with the end slopes of the cubic.
  EXPECT_NEAR(tx.coupling.Value(-3.0), c(-1) + dc(-1) * (-2.0), 1e-8);
  EXPECT_NEAR(tx.coupling.Value(5.0), c(3) + dc(3) * 2.0, 1e-8);
  EXPECT_NEAR(ty.coupling.Value(5.0), -0.5 * (c(3) + dc(3) * 2.0) + 0.001, 1e-8);
  EXPECT_NEAR(ty.coupling.SecondDerivative(5.0), 0.0, 1e-15);
}

// ---- <isowrench:coupling> function kinds, values hand-computed --------------------------------

double CouplingValue(const std::string& function, double x) {
  const LimbDescription d = Read(Leg("", "",
                                     R"(<isowrench:coupling joint="knee_tx" coordinate="knee">)" +
                                         function + "</isowrench:coupling>"));
  EXPECT_EQ(Joint(d, "knee_tx").coordinate, "knee");
  return Joint(d, "knee_tx").coupling.Value(x);
}

TEST(Coupling, NaturalCubicSplineMatchesTheSplineSolvedByHand) {
  // Knots (0,0) (1,1) (2,0), natural ends: M0 = M2 = 0, 4 M1 = 6 (-1 - 1) => M1 = -3, so on
  // [0,1] S = -x^3/2 + 3x/2 (S(0.5) = 0.6875, S'(0) = 1.5), symmetric on [1,2]; outside the
  // knots the end slopes +-1.5 continue linearly: S(-1) = -1.5, S(3) = -1.5.
  const std::string f = R"(<isowrench:natural_cubic_spline x="0 1 2" y="0 1 0"/>)";
  EXPECT_NEAR(CouplingValue(f, 0.5), 0.6875, 1e-15);
  EXPECT_NEAR(CouplingValue(f, 1.5), 0.6875, 1e-15);
  EXPECT_NEAR(CouplingValue(f, -1.0), -1.5, 1e-15);
  EXPECT_NEAR(CouplingValue(f, 3.0), -1.5, 1e-15);
}

TEST(Coupling, SimmSplineReproducesACubicAndExtrapolatesLinearlyOnBothSides) {
  // y = x^3 at x = 0 1 2 3: FMM end conditions match the cubic's third derivative exactly.
  const std::string f = R"(<isowrench:simm_spline x="0 1 2 3" y="0 1 8 27"/>)";
  EXPECT_NEAR(CouplingValue(f, 0.5), 0.125, 1e-14);
  EXPECT_NEAR(CouplingValue(f, 2.5), 15.625, 1e-13);
  EXPECT_NEAR(CouplingValue(f, -1.0), 0.0, 1e-14);         // slope 3 x^2 = 0 at x = 0
  EXPECT_NEAR(CouplingValue(f, 4.0), 27.0 + 27.0, 1e-12);  // slope 27 at x = 3
}

TEST(Coupling, OtherFunctionKinds) {
  EXPECT_EQ(CouplingValue(R"(<isowrench:constant value="0.001"/>)", 7.0), 0.001);
  EXPECT_EQ(CouplingValue(R"(<isowrench:linear slope="2" intercept="0.5"/>)", 3.0), 6.5);
  EXPECT_DOUBLE_EQ(CouplingValue(R"(<isowrench:piecewise_linear x="0 1 3" y="0 2 3"/>)", 2.0), 2.5);
  EXPECT_DOUBLE_EQ(CouplingValue(R"(<isowrench:piecewise_linear x="0 1 3" y="0 2 3"/>)", -1.0),
                   -2.0);
  EXPECT_DOUBLE_EQ(CouplingValue(R"(<isowrench:piecewise_linear x="0 1 3" y="0 2 3"/>)", 5.0), 4.0);
  // 2 x^2 - 3 x + 1 at x = 2: 8 - 6 + 1 = 3.
  EXPECT_DOUBLE_EQ(CouplingValue(R"(<isowrench:polynomial coefficients="2 -3 1"/>)", 2.0), 3.0);
  EXPECT_DOUBLE_EQ(
      CouplingValue(
          R"(<isowrench:multiplier scale="-2"><isowrench:linear slope="1" intercept="1"/></isowrench:multiplier>)",
          2.0),
      -6.0);
}

// ---- free-standing coordinates, locked coordinates ---------------------------------------------

const char* kFreeCoordinate = R"(
  <isowrench:coordinate name="flexion" type="revolute" default="0.3" lower="-2" upper="0.2" locked="true"/>
  <isowrench:joint name="flexion" role="extra" stiffness="2.5"/>
  <isowrench:coupling joint="knee" coordinate="flexion"><isowrench:linear slope="1" intercept="0"/></isowrench:coupling>
  <isowrench:coupling joint="knee_tx" coordinate="flexion">
    <isowrench:simm_spline x="-2 -1 0 0.2" y="-0.001 -0.0004 0 0.0001"/>
  </isowrench:coupling>
  <isowrench:joint name="hip" locked="true" stiffness="1"/>
  <isowrench:posture joint="flexion" degrees="-30"/>)";

TEST(FreeCoordinate, DrivesJointsAndTakesTheColumnOfTheFirstOne) {
  const LimbDescription d = Read(Leg("", "", kFreeCoordinate));
  // flexion's first joint (knee_tx) comes before knee_ty along the chain.
  EXPECT_EQ(CoordinateNames(d), (std::vector<std::string>{"hip", "flexion", "knee_ty"}));
  const CoordinateSpec& f = isowrench::FindCoordinate(d, "flexion");
  EXPECT_EQ(f.joint, "");
  EXPECT_EQ(f.type, JointType::kRevolute);
  EXPECT_EQ(f.default_value, 0.3);
  EXPECT_EQ(f.lower, -2.0);
  EXPECT_EQ(f.upper, 0.2);
  EXPECT_TRUE(f.locked);
  EXPECT_EQ(f.role, isowrench::JointRole::kExtra);
  EXPECT_EQ(f.stiffness, 2.5);
  EXPECT_EQ(Joint(d, "knee").coordinate, "flexion");
  EXPECT_EQ(Joint(d, "knee_tx").coordinate, "flexion");
  const CoordinateSpec& hip = isowrench::FindCoordinate(d, "hip");
  EXPECT_TRUE(hip.locked);
  EXPECT_EQ(hip.stiffness, 1.0);
  ASSERT_EQ(d.nominal_posture.size(), 1u);
  EXPECT_EQ(d.nominal_posture[0].first, "flexion");
  EXPECT_NEAR(d.nominal_posture[0].second, -kPi / 6, 1e-15);
}

// ---- bad input: a named error with file and line ------------------------------------------------

void ExpectError(const std::string& xml, const std::vector<std::string>& parts) {
  try {
    Read(xml);
    ADD_FAILURE() << "no error; expected one containing " << parts.front();
  } catch (const Error& e) {
    for (const std::string& part : parts) EXPECT_THAT(e.what(), HasSubstr(part));
  }
}

TEST(CouplingErrors, MimicCycleNamesBothJoints) {
  const std::string xml = Leg(R"(<mimic joint="knee_ty"/>)", R"(<mimic joint="knee_tx"/>)", "");
  ExpectError(xml, {At(xml, "<mimic joint=\"knee_ty\""), "knee_tx", "knee_ty", "cycle"});
}

TEST(CouplingErrors, MimicOfItself) {
  const std::string xml = Leg(R"(<mimic joint="knee_tx"/>)", "", "");
  ExpectError(xml, {At(xml, "<mimic"), "knee_tx", "itself"});
}

TEST(CouplingErrors, UnknownMimickedJointNamesBothJointsAndSuggests) {
  const std::string xml = Leg(R"(<mimic joint="kne"/>)", "", "");
  ExpectError(xml, {At(xml, "<mimic"), "knee_tx", "unknown joint 'kne'", "did you mean 'knee'"});
}

TEST(CouplingErrors, MimicOfAFixedJoint) {
  const std::string xml = Leg(R"(<mimic joint="weld"/>)", "", "");
  ExpectError(xml, {At(xml, "<mimic"), "knee_tx", "weld", "fixed"});
}

TEST(CouplingErrors, CouplingOfAFixedJoint) {
  const std::string xml = Leg("", "", R"(<isowrench:coupling joint="weld" coordinate="knee">
    <isowrench:constant value="0"/></isowrench:coupling>)");
  ExpectError(xml, {At(xml, "<isowrench:coupling"), "weld", "fixed"});
}

TEST(CouplingErrors, CouplingOfAnUnknownJoint) {
  const std::string xml = Leg("", "", R"(<isowrench:coupling joint="knee_tz" coordinate="knee">
    <isowrench:constant value="0"/></isowrench:coupling>)");
  ExpectError(xml, {At(xml, "<isowrench:coupling"), "unknown joint 'knee_tz'", "did you mean"});
}

TEST(CouplingErrors, JointBothMimicAndCoupled) {
  const std::string xml =
      Leg(R"(<mimic joint="knee"/>)", "", R"(<isowrench:coupling joint="knee_tx" coordinate="knee">
    <isowrench:constant value="0"/></isowrench:coupling>)");
  ExpectError(xml, {At(xml, "<isowrench:coupling"), "knee_tx", "coupled twice", "<mimic>",
                    "line " + At(xml, "<mimic").substr(std::string(kSource).size() + 1)});
}

TEST(CouplingErrors, CouplingNamesAnUnknownCoordinate) {
  const std::string xml = Leg("", "", R"(<isowrench:coupling joint="knee_tx" coordinate="knee_">
    <isowrench:constant value="0"/></isowrench:coupling>)");
  ExpectError(xml, {At(xml, "<isowrench:coupling"), "knee_tx", "'knee_'", "unknown",
                    "did you mean 'knee'"});
}

TEST(CouplingErrors, CouplingNamesADrivenJoint) {
  const std::string xml = Leg(R"(<mimic joint="knee"/>)", "",
                              R"(<isowrench:coupling joint="knee_ty" coordinate="knee_tx">
    <isowrench:constant value="0"/></isowrench:coupling>)");
  ExpectError(xml, {At(xml, "<isowrench:coupling"), "knee_ty", "driven by coordinate 'knee'"});
}

TEST(CouplingErrors, CouplingNeedsExactlyOneFunction) {
  const std::string xml = Leg("", "", R"(<isowrench:coupling joint="knee_tx" coordinate="knee"/>)");
  ExpectError(xml, {At(xml, "<isowrench:coupling"), "knee_tx", "needs one function element"});
}

TEST(CouplingErrors, SplineWithUnsortedDuplicateOrTooFewKnotsOrNaN) {
  const std::vector<std::string> bad = {
      R"(<isowrench:simm_spline x="0 2 1" y="0 1 2"/>)",           // unsorted
      R"(<isowrench:natural_cubic_spline x="0 1 1" y="0 1 2"/>)",  // duplicate
      R"(<isowrench:piecewise_linear x="0" y="0"/>)",              // too few
      R"(<isowrench:polynomial coefficients="1 nan 0"/>)",         // NaN coefficient
  };
  for (const std::string& f : bad) {
    const std::string xml = Leg("", "",
                                "<isowrench:coupling joint=\"knee_tx\" coordinate=\"knee\">\n    " +
                                    f + "</isowrench:coupling>");
    ExpectError(xml, {At(xml, f.substr(0, 20)), "knee_tx"});
  }
}

TEST(CouplingErrors, PostureNamingADrivenJointNamesItsDriver) {
  const std::string xml = Leg(R"(<mimic joint="knee" multiplier="0.01"/>)", "",
                              R"(<isowrench:posture joint="knee_tx" value="0.001"/>)");
  ExpectError(
      xml, {At(xml, "<isowrench:posture"), "joint 'knee_tx' is driven by coordinate 'knee' (mimic)",
            "set 'knee' instead"});
}

TEST(CouplingErrors, StiffnessOnADrivenJoint) {
  const std::string xml = Leg(R"(<mimic joint="knee" multiplier="0.01"/>)", "",
                              R"(<isowrench:joint name="knee_tx" stiffness="5"/>)");
  ExpectError(xml, {At(xml, "<isowrench:joint"), "knee_tx", "set 'knee' instead"});
}

TEST(CouplingErrors, FreeCoordinateWithAJointsNameOrDefinedTwice) {
  std::string xml = Leg("", "", R"(<isowrench:coordinate name="knee"/>)");
  ExpectError(xml, {At(xml, "<isowrench:coordinate"), "'knee'", "name of a joint"});
  xml = Leg("", "", R"(<isowrench:coordinate name="a"/>
  <isowrench:coordinate name="a"/>)");
  ExpectError(xml, {AtLast(xml, "<isowrench:coordinate name=\"a\"/>"), "'a'", "twice"});
  xml = Leg("", "", R"(<isowrench:coordinate name="a" lower="1" upper="0"/>)");
  ExpectError(xml, {At(xml, "<isowrench:coordinate"), "'a'", "lower"});
  xml = Leg("", "", R"(<isowrench:coordinate name="a" type="fixed"/>)");
  ExpectError(xml, {At(xml, "<isowrench:coordinate"), "'a'", "revolute or prismatic"});
}

// ---- FindCoordinate
// ------------------------------------------------------------------------------

TEST(FindCoordinate, NamesTheDriverOfADrivenJointAndRefusesFixedAndUnknownNames) {
  const LimbDescription d = Read(Leg(R"(<mimic joint="knee" multiplier="0.01"/>)", "", ""));
  EXPECT_EQ(isowrench::FindCoordinate(d, "knee").name, "knee");
  EXPECT_THAT([&] { isowrench::FindCoordinate(d, "knee_tx"); },
              ThrowsMessage<Error>(HasSubstr(
                  "joint 'knee_tx' is driven by coordinate 'knee' (mimic); set 'knee' instead")));
  EXPECT_THAT([&] { isowrench::FindCoordinate(d, "weld"); },
              ThrowsMessage<Error>(HasSubstr("'weld'")));
  EXPECT_THAT([&] { isowrench::FindCoordinate(d, "hipp"); },
              ThrowsMessage<Error>(
                  AllOf(HasSubstr("unknown coordinate 'hipp'"), HasSubstr("did you mean 'hip'"))));
  const LimbDescription free = Read(Leg("", "", kFreeCoordinate));
  EXPECT_THAT(
      [&] { isowrench::FindCoordinate(free, "knee"); },
      ThrowsMessage<Error>(HasSubstr("driven by coordinate 'flexion' (isowrench:coupling)")));
}

// ---- writer round trip
// ---------------------------------------------------------------------------

void ExpectSameCoordinates(const LimbDescription& a, const LimbDescription& b) {
  ASSERT_EQ(CoordinateNames(a), CoordinateNames(b));
  for (size_t i = 0; i < a.coordinates.size(); ++i) {
    const CoordinateSpec& x = a.coordinates[i];
    const CoordinateSpec& y = b.coordinates[i];
    EXPECT_EQ(x.type, y.type) << x.name;
    EXPECT_EQ(x.role, y.role) << x.name;
    EXPECT_EQ(x.stiffness, y.stiffness) << x.name;
    EXPECT_EQ(x.default_value, y.default_value) << x.name;
    EXPECT_EQ(x.lower, y.lower) << x.name;
    EXPECT_EQ(x.upper, y.upper) << x.name;
    EXPECT_EQ(x.locked, y.locked) << x.name;
    EXPECT_EQ(x.joint, y.joint) << x.name;
  }
  ASSERT_EQ(a.joints.size(), b.joints.size());
  for (size_t i = 0; i < a.joints.size(); ++i) {
    const JointSpec& x = a.joints[i];
    const JointSpec& y = b.joints[i];
    EXPECT_EQ(x.coordinate, y.coordinate) << x.name;
    EXPECT_EQ(x.coupling.kind(), y.coupling.kind()) << x.name;
    for (double q : {-3.0, -0.7, 0.0, 0.1, 1.3, 4.0}) {
      EXPECT_EQ(x.coupling.Value(q), y.coupling.Value(q)) << x.name << " at " << q;
    }
  }
  ASSERT_EQ(a.nominal_posture.size(), b.nominal_posture.size());
}

TEST(CouplingRoundTrip, WriteThenReadKeepsCoordinatesAndCouplings) {
  for (
      const std::string& xml :
      {Leg("", "", kFreeCoordinate),
       Leg(R"(<mimic joint="knee" multiplier="0.01" offset="0.002"/>)",
           R"(<mimic joint="knee_tx" multiplier="2" offset="0.001"/>)", ""),
       Leg("", R"(<mimic joint="knee_tx" multiplier="-0.5" offset="0.001"/>)",
           R"(<isowrench:coupling joint="knee_tx" coordinate="knee"><isowrench:multiplier scale="3">
               <isowrench:polynomial coefficients="1e-3 2e-4 0"/></isowrench:multiplier></isowrench:coupling>)")}) {
    const LimbDescription d = Read(xml);
    const std::string written = isowrench::WriteUrdfString(d);
    ExpectSameCoordinates(d, isowrench::ReadUrdfString(written, "written.urdf"));
  }
  const LimbDescription knee = LoadDescription("rat_hindlimb_coupled_knee.urdf");
  ExpectSameCoordinates(
      knee, isowrench::ReadUrdfString(isowrench::WriteUrdfString(knee), "written.urdf"));
}

// ---- description edits keep coordinates consistent ----------------------------------------------

TEST(CouplingEdits, BaseStiffnessAddsBaseCoordinatesFirst) {
  const LimbDescription d = isowrench::WithBaseStiffness(Read(Leg("", "", kFreeCoordinate)), 1e5);
  EXPECT_EQ(CoordinateNames(d),
            (std::vector<std::string>{"base_x", "base_y", "base_z", "hip", "flexion", "knee_ty"}));
  EXPECT_EQ(isowrench::FindCoordinate(d, "base_y").stiffness, 1e5);
  EXPECT_EQ(isowrench::FindCoordinate(d, "base_y").type, JointType::kPrismatic);
  EXPECT_EQ(isowrench::FindCoordinate(d, "base_y").role, isowrench::JointRole::kBase);
  EXPECT_TRUE(isowrench::FindCoordinate(d, "flexion").locked);  // kept
  const LimbDescription again = isowrench::WithBaseStiffness(d, 2e5);
  EXPECT_EQ(isowrench::FindCoordinate(again, "base_z").stiffness, 2e5);
}

TEST(CouplingEdits, JointStiffnessGoesToTheCoordinate) {
  const LimbDescription d = Read(Leg(R"(<mimic joint="knee" multiplier="0.01"/>)", "", ""));
  EXPECT_EQ(
      isowrench::FindCoordinate(isowrench::WithJointStiffness(d, "knee", 3.0), "knee").stiffness,
      3.0);
  EXPECT_EQ(Joint(isowrench::WithJointStiffness(d, "knee", 3.0), "knee").stiffness, 3.0);
  EXPECT_THAT([&] { isowrench::WithJointStiffness(d, "knee_tx", 1.0); },
              ThrowsMessage<Error>(HasSubstr("set 'knee' instead")));
  const LimbDescription free = Read(Leg("", "", kFreeCoordinate));
  EXPECT_EQ(
      isowrench::FindCoordinate(isowrench::WithJointStiffness(free, "flexion", 4.0), "flexion")
          .stiffness,
      4.0);
}

TEST(CouplingEdits, ExtraJointGetsItsOwnCoordinateInChainOrder) {
  const LimbDescription d = isowrench::WithExtraJoint(Read(Leg("", "", kFreeCoordinate)), "knee",
                                                      "knee_ry", Eigen::Vector3d::UnitY(), 1.5);
  EXPECT_EQ(CoordinateNames(d), (std::vector<std::string>{"hip", "flexion", "knee_ty", "knee_ry"}));
  EXPECT_EQ(isowrench::FindCoordinate(d, "knee_ry").stiffness, 1.5);
  EXPECT_EQ(isowrench::FindCoordinate(d, "knee_ry").role, isowrench::JointRole::kExtra);
}

TEST(CouplingEdits, DescriptionBuiltInCodeGetsItsCoordinatesFromNormalize) {
  LimbDescription d = LoadDescription("rat_hindlimb_5dof.urdf");
  d.coordinates.clear();
  for (JointSpec& j : d.joints) j.coordinate.clear();
  const LimbDescription n = isowrench::NormalizeCoordinates(d);
  EXPECT_EQ(CoordinateNames(n), CoordinateNames(LoadDescription("rat_hindlimb_5dof.urdf")));
  // A joint made fixed after reading loses its coordinate.
  LimbDescription fixed = LoadDescription("rat_hindlimb_5dof.urdf");
  for (JointSpec& j : fixed.joints) {
    if (j.name == "hip_rx") j.type = JointType::kFixed;
  }
  EXPECT_EQ(CoordinateNames(isowrench::NormalizeCoordinates(fixed)),
            (std::vector<std::string>{"hip_rz", "hip_ry", "knee_rz", "knee_rx"}));
}

// ---- postures name coordinates
// -------------------------------------------------------------------

TEST(CouplingPostures, AssignmentToADrivenJointNamesItsDriver) {
  const isowrench::Model model(Read(Leg(R"(<mimic joint="knee" multiplier="0.01"/>)", "", "")));
  EXPECT_THAT(
      [&] { isowrench::ApplyPostureAssignments(model, model.nominal_posture(), "knee_tx=1"); },
      ThrowsMessage<Error>(
          HasSubstr("joint 'knee_tx' is driven by coordinate 'knee' (mimic); set 'knee' instead")));
}

TEST(PostureCsv, ColumnsNameCoordinatesInDegreesAndMillimetres) {
  const isowrench::Model rat = LoadModel("rat_hindlimb_5dof_base.urdf");
  const Eigen::VectorXd base = rat.nominal_posture();
  const auto q = isowrench::ParsePostureCsv(
      rat, "hip_rz, knee_rz,base_x\n# comment\n-100,90,2\n\n30,,-1\n", "p.csv", base);
  ASSERT_EQ(q.size(), 2u);
  EXPECT_NEAR(q[0][rat.JointIndex("hip_rz")], Deg(-100), 1e-15);
  EXPECT_NEAR(q[0][rat.JointIndex("knee_rz")], Deg(90), 1e-15);
  EXPECT_NEAR(q[0][rat.JointIndex("base_x")], 0.002, 1e-18);
  EXPECT_EQ(q[0][rat.JointIndex("hip_ry")], base[rat.JointIndex("hip_ry")]);
  EXPECT_EQ(q[1][rat.JointIndex("knee_rz")], base[rat.JointIndex("knee_rz")]);  // empty cell
  EXPECT_NEAR(q[1][rat.JointIndex("base_x")], -0.001, 1e-18);
}

TEST(PostureCsv, BadFilesAreNamedErrors) {
  const isowrench::Model rat = LoadModel("rat_hindlimb_5dof.urdf");
  const Eigen::VectorXd base = rat.nominal_posture();
  auto parse = [&](const std::string& text) {
    isowrench::ParsePostureCsv(rat, text, "p.csv", base);
  };
  EXPECT_THAT([&] { parse("hip_rz,kne_rz\n1,2\n"); },
              ThrowsMessage<Error>(AllOf(HasSubstr("p.csv:1"), HasSubstr("'kne_rz'"),
                                         HasSubstr("did you mean 'knee_rz'"))));
  EXPECT_THAT([&] { parse("hip_rz,hip_rz\n1,2\n"); }, ThrowsMessage<Error>(HasSubstr("twice")));
  EXPECT_THAT([&] { parse("hip_rz,knee_rz\n1,2\n1\n"); },
              ThrowsMessage<Error>(AllOf(HasSubstr("p.csv:3"), HasSubstr("1 fields"))));
  EXPECT_THAT([&] { parse("hip_rz,knee_rz\n1,abc\n"); },
              ThrowsMessage<Error>(
                  AllOf(HasSubstr("p.csv:2"), HasSubstr("'knee_rz'"), HasSubstr("'abc'"))));
  EXPECT_THAT([&] { parse("hip_rz\n"); }, ThrowsMessage<Error>(HasSubstr("no posture rows")));
  const isowrench::Model leg(Read(Leg(R"(<mimic joint="knee" multiplier="0.01"/>)", "", "")));
  EXPECT_THAT(
      [&] { isowrench::ParsePostureCsv(leg, "knee_tx\n1\n", "p.csv", leg.nominal_posture()); },
      ThrowsMessage<Error>(AllOf(HasSubstr("p.csv:1"), HasSubstr("set 'knee' instead"))));
}

// ---- coupled kinematics against an independent forward kinematics -----------------------------
// These need the engine to map couplings (Model columns = coordinates, J = J_joints C); until it
// does, they skip with that reason.

namespace kin {

using isowrench::Model;

bool EngineMapsCouplings(const Model& model) {
  return model.dof_count() == static_cast<int>(model.description().coordinates.size());
}

Eigen::Matrix3d Rz(double a) {
  return Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}
Eigen::Matrix3d Ry(double a) {
  return Eigen::AngleAxisd(a, Eigen::Vector3d::UnitY()).toRotationMatrix();
}
Eigen::Matrix3d Rx(double a) {
  return Eigen::AngleAxisd(a, Eigen::Vector3d::UnitX()).toRotationMatrix();
}

/// urdf/rat_hindlimb_coupled_knee.urdf written out by hand, coordinates q = [hip_rz hip_ry
/// hip_rx knee_rz knee_rx]: the femur turns by Rz Ry Rx about the hip; the knee centre sits at
/// (0.031 + tx(knee_rz), ty(knee_rz), 0) in the femur frame; the tibia turns by Rz(knee_rz)
/// Rx(knee_rx) about it. tx is the file's SimmSpline (built here from the same knots), ty the
/// mimic 0.0004 knee_rz + 0.0001.
struct CoupledKnee {
  isowrench::Function tx = isowrench::Function::SimmSpline(
      {0, 0.5, 1, 1.5, 2, 2.5}, {0, -0.0002, -0.0005, -0.0009, -0.0012, -0.0014});
  Eigen::Matrix3d Tibia(const Eigen::VectorXd& q) const {
    return Rz(q[0]) * Ry(q[1]) * Rx(q[2]) * Rz(q[3]) * Rx(q[4]);
  }
  Eigen::Vector3d OnTibia(const Eigen::VectorXd& q, const Eigen::Vector3d& p) const {
    const Eigen::Vector3d knee(0.031 + tx.Value(q[3]), 0.0004 * q[3] + 0.0001, 0.0);
    return Rz(q[0]) * Ry(q[1]) * Rx(q[2]) * (knee + Rz(q[3]) * Rx(q[4]) * p);
  }
  Eigen::Vector3d Endpoint(const Eigen::VectorXd& q) const {
    return OnTibia(q, Eigen::Vector3d(0.041, 0, 0));
  }
  double GpLength(const Eigen::VectorXd& q) const {
    return (OnTibia(q, Eigen::Vector3d(0.0156, -0.00452, -0.00378)) -
            Eigen::Vector3d(0.01267, -0.010403, -0.00478))
        .norm();
  }
};

/// Central differences, step h: error ~ h^2 |f'''| / 6 (< 1e-13 here) plus rounding eps |f| / h.
constexpr double kStep = 1e-6;
constexpr double kFdTolerance = 1e-9;

isowrench::Matrix6Xd JacobianByDifferences(const CoupledKnee& k, const Eigen::VectorXd& q) {
  isowrench::Matrix6Xd J(6, q.size());
  for (int i = 0; i < q.size(); ++i) {
    Eigen::VectorXd plus = q, minus = q;
    plus[i] += kStep;
    minus[i] -= kStep;
    J.block<3, 1>(0, i) = (k.Endpoint(plus) - k.Endpoint(minus)) / (2 * kStep);
    J.block<3, 1>(3, i) =
        Vee((k.Tibia(plus) - k.Tibia(minus)) / (2 * kStep) * k.Tibia(q).transpose());
  }
  return J;
}

Eigen::VectorXd MomentArmsByDifferences(const CoupledKnee& k, const Eigen::VectorXd& q) {
  Eigen::VectorXd r(q.size());
  for (int i = 0; i < q.size(); ++i) {
    Eigen::VectorXd plus = q, minus = q;
    plus[i] += kStep;
    minus[i] -= kStep;
    r[i] = -(k.GpLength(plus) - k.GpLength(minus)) / (2 * kStep);
  }
  return r;
}

/// Postures over the knee's whole range, spline extrapolation on both sides included.
std::vector<Eigen::VectorXd> Postures() {
  std::vector<Eigen::VectorXd> out;
  for (double knee : {-0.3, 0.2, 1.2, 1.8326, 2.5, 2.9}) {
    Eigen::VectorXd q(5);
    q << Deg(-110), 0.1, -0.2, knee, 0.15;
    out.push_back(q);
  }
  return out;
}

}  // namespace kin

TEST(CoupledKinematics, EngineMatchesDifferencesOfAnIndependentForwardKinematics) {
  const isowrench::Model model = LoadModel("rat_hindlimb_coupled_knee.urdf");
  ASSERT_TRUE(kin::EngineMapsCouplings(model)) << "the engine must map couplings to coordinates";
  const kin::CoupledKnee knee;
  isowrench::Data ws(model);
  for (const Eigen::VectorXd& q : kin::Postures()) {
    EXPECT_TRUE(
        MatricesNear(isowrench::EndpointPose(model, ws, q).translation(), knee.Endpoint(q), 1e-15));
    EXPECT_TRUE(MatricesNear(isowrench::EndpointJacobianWorld(model, ws, q),
                             kin::JacobianByDifferences(knee, q), kin::kFdTolerance));
    const isowrench::MuscleTorque t =
        isowrench::ComputeMuscleTorque(model, ws, q, model.MuscleIndex("GP"));
    EXPECT_NEAR(t.length, knee.GpLength(q), 1e-15);
    EXPECT_TRUE(MatricesNear(Eigen::VectorXd(-t.dL_dq.transpose()),
                             kin::MomentArmsByDifferences(knee, q), kin::kFdTolerance));
  }
}

TEST(CoupledKinematics, KinematicsCommandJsonMatchesDifferencesOfAnIndependentForwardKinematics) {
  const isowrench::Model model = LoadModel("rat_hindlimb_coupled_knee.urdf");
  ASSERT_TRUE(kin::EngineMapsCouplings(model)) << "the engine must map couplings to coordinates";
  const std::string csv = ::testing::TempDir() + "coupled_knee_postures.csv";
  {
    std::ofstream out(csv);
    out << "hip_rz,hip_ry,hip_rx,knee_rz,knee_rx\n";
    for (const Eigen::VectorXd& q : kin::Postures()) {
      out.precision(17);
      for (int i = 0; i < 5; ++i) out << (i ? "," : "") << q[i] * 180.0 / kPi;
      out << "\n";
    }
  }
  const std::string command = std::string(ISOWRENCH_CLI) + " kinematics " +
                              UrdfPath("rat_hindlimb_coupled_knee.urdf") + " --postures " + csv +
                              " --json";
  FILE* pipe = popen(command.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  std::string text;
  char buffer[4096];
  for (size_t n; (n = fread(buffer, 1, sizeof(buffer), pipe)) > 0;) text.append(buffer, n);
  ASSERT_EQ(pclose(pipe), 0) << text;
  std::remove(csv.c_str());
  const nlohmann::json json = nlohmann::json::parse(text);
  EXPECT_EQ(json["coordinates"],
            (std::vector<std::string>{"hip_rz", "hip_ry", "hip_rx", "knee_rz", "knee_rx"}));
  const kin::CoupledKnee knee;
  const std::vector<Eigen::VectorXd> postures = kin::Postures();
  ASSERT_EQ(json["postures"].size(), postures.size());
  for (size_t p = 0; p < postures.size(); ++p) {
    const nlohmann::json& out = json["postures"][p];
    // The CSV carries degrees with 17 digits: the posture is q to ~1e-16 rad.
    const Eigen::Vector3d endpoint(out["endpoint_m"][0], out["endpoint_m"][1],
                                   out["endpoint_m"][2]);
    EXPECT_TRUE(MatricesNear(endpoint, knee.Endpoint(postures[p]), 1e-15));
    isowrench::Matrix6Xd J(6, 5);
    for (int r = 0; r < 6; ++r) {
      for (int c = 0; c < 5; ++c) J(r, c) = out["jacobian"][r][c];
    }
    EXPECT_TRUE(MatricesNear(J, kin::JacobianByDifferences(knee, postures[p]), kin::kFdTolerance));
    EXPECT_NEAR(out["muscles"]["GP"]["length_m"].get<double>(), knee.GpLength(postures[p]), 1e-15);
    Eigen::VectorXd r(5);
    for (int c = 0; c < 5; ++c) r[c] = out["muscles"]["GP"]["moment_arm_m"][c];
    EXPECT_TRUE(
        MatricesNear(r, kin::MomentArmsByDifferences(knee, postures[p]), kin::kFdTolerance));
  }
}

TEST(CoupledKinematics, MimicLegEqualsTheSameLegWrittenAsOneJoint) {
  // Two knee joints on one axis at one point, the second a mimic (multiplier 1, offset 0.2) of
  // the first: the same as one knee joint at angle 2 q + 0.2, whose column is twice as large.
  auto leg = [](const std::string& knee2) {
    return std::string(R"(<robot name="leg" xmlns:isowrench="urn:isowrench:urdf:1">
  <link name="ground"/> <link name="thigh"/> <link name="mid"/> <link name="shank"/>
  <joint name="hip" type="continuous"><parent link="ground"/><child link="thigh"/><axis xyz="0 0 1"/></joint>
  <joint name="knee" type="continuous"><parent link="thigh"/><child link="mid"/>
    <origin xyz="0.03 0.004 0" rpy="0.1 0 0"/><axis xyz="0 0.6 0.8"/></joint>
  <joint name="knee2" type=)") +
           knee2 + R"(
  <isowrench:transducer link="shank" xyz="0.04 0.002 -0.001"/>
  <isowrench:muscle name="M" max_force="1">
    <isowrench:point link="ground" xyz="0.01 0.012 0.003"/> <isowrench:point link="shank" xyz="0.012 -0.004 0.002"/>
  </isowrench:muscle>
</robot>)";
  };
  const isowrench::Model mimic(
      Read(leg(R"("continuous"><parent link="mid"/><child link="shank"/><axis xyz="0 0.6 0.8"/>
    <mimic joint="knee" multiplier="1" offset="0.2"/></joint>)")));
  const isowrench::Model single(
      Read(leg(R"("fixed"><parent link="mid"/><child link="shank"/></joint>)")));
  ASSERT_TRUE(kin::EngineMapsCouplings(mimic)) << "the engine must map couplings to coordinates";
  ASSERT_EQ(mimic.dof_count(), 2);
  isowrench::Data ws_m(mimic), ws_s(single);
  for (double knee : {-1.0, 0.3, 2.0}) {
    Eigen::Vector2d q(0.4, knee);
    Eigen::Vector2d q_single(0.4, 2 * knee + 0.2);
    EXPECT_TRUE(MatricesNear(isowrench::EndpointPose(mimic, ws_m, q).matrix(),
                             isowrench::EndpointPose(single, ws_s, q_single).matrix(), 1e-15));
    isowrench::Matrix6Xd J_expected = isowrench::EndpointJacobianWorld(single, ws_s, q_single);
    J_expected.col(1) *= 2.0;
    EXPECT_TRUE(MatricesNear(isowrench::EndpointJacobianWorld(mimic, ws_m, q), J_expected, 1e-15));
    Eigen::RowVectorXd dL = isowrench::ComputeMuscleTorque(single, ws_s, q_single, 0).dL_dq;
    dL[1] *= 2.0;
    EXPECT_TRUE(MatricesNear(isowrench::ComputeMuscleTorque(mimic, ws_m, q, 0).dL_dq, dL, 1e-15));
  }
}

}  // namespace
}  // namespace isowrench_test
