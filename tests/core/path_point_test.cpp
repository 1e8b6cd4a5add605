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

}  // namespace
}  // namespace isowrench
