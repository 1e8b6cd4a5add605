// <isowrench:wrap> objects and <isowrench:path_wrap> lists in URDF: read, written, read back
// equal; bad input names the file, the line, the muscle and the object.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "isowrench/error.hpp"
#include "isowrench/kinematics.hpp"
#include "isowrench/model.hpp"
#include "isowrench/wrap.hpp"

namespace isowrench {
namespace {

using ::testing::HasSubstr;

std::string WrapUrdf(const std::string& wraps, const std::string& muscle_wraps) {
  return R"(<?xml version="1.0"?>
<robot name="leg" xmlns:isowrench="urn:isowrench:urdf:1">
  <link name="ground"/> <link name="femur"/> <link name="tibia"/>
  <joint name="hip" type="revolute"><parent link="ground"/><child link="femur"/>
    <origin xyz="0 0 0" rpy="0 0 0"/><axis xyz="0 0 1"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
  <joint name="knee" type="revolute"><parent link="femur"/><child link="tibia"/>
    <origin xyz="0.04 0 0" rpy="0 0 0"/><axis xyz="0 0 1"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
  <isowrench:transducer link="tibia" xyz="0.04 0 0"/>
)" + wraps +
         R"(
  <isowrench:muscle name="VAS" max_force="2">
    <isowrench:point link="ground" xyz="0.01 0.01 0"/>
    <isowrench:point link="femur" xyz="0.02 0.005 0"/>
    <isowrench:point link="tibia" xyz="0.01 0.004 0"/>
)" + muscle_wraps +
         R"(
  </isowrench:muscle>
</robot>
)";
}

const char* kObjects = R"(
  <isowrench:wrap name="knee_cyl" link="femur" shape="cylinder" radius="0.004" length="0.02"
      translation="0.04 0 0" xyz_body_rotation="0 0.1 0.2" quadrant="+y" active="true"/>
  <isowrench:wrap name="hip_ball" link="ground" shape="sphere" radius="0.003"/>
  <isowrench:wrap name="ell" link="tibia" shape="ellipsoid" radii="0.003 0.004 0.005" active="false"/>
  <isowrench:wrap name="ring" link="tibia" shape="torus" inner_radius="0.001" outer_radius="0.004" quadrant="-z"/>)";

const char* kList = R"(
    <isowrench:path_wrap object="knee_cyl" range="2 3"/>
    <isowrench:path_wrap object="ell" method="axial"/>
    <isowrench:path_wrap object="hip_ball" range="-1 2" method="midpoint"/>)";

TEST(WrapUrdfTest, WrapObjectsAndListsRoundTrip) {
  const LimbDescription d = ReadUrdfString(WrapUrdf(kObjects, kList), "leg.urdf");
  ASSERT_EQ(d.wrap_objects.size(), 4u);
  const WrapObjectSpec& c = d.wrap_objects[0];
  EXPECT_EQ(c.name, "knee_cyl");
  EXPECT_EQ(c.link, "femur");
  EXPECT_EQ(c.shape, WrapShape::kCylinder);
  EXPECT_EQ(c.radius, 0.004);
  EXPECT_EQ(c.length, 0.02);
  EXPECT_EQ(c.translation, Eigen::Vector3d(0.04, 0, 0));
  EXPECT_EQ(c.xyz_body_rotation, Eigen::Vector3d(0, 0.1, 0.2));
  EXPECT_EQ(c.quadrant.ToString(), "+y");
  EXPECT_EQ(d.wrap_objects[1].link, "ground");
  EXPECT_EQ(d.wrap_objects[2].radii, Eigen::Vector3d(0.003, 0.004, 0.005));
  EXPECT_FALSE(d.wrap_objects[2].active);
  EXPECT_EQ(d.wrap_objects[3].outer_radius, 0.004);
  ASSERT_EQ(d.muscles[0].wraps.size(), 3u);
  EXPECT_EQ(d.muscles[0].wraps[0].range_first, 2);
  EXPECT_EQ(d.muscles[0].wraps[0].range_last, 3);
  EXPECT_EQ(d.muscles[0].wraps[1].method, WrapMethod::kAxial);
  EXPECT_EQ(d.muscles[0].wraps[1].range_first, -1);
  EXPECT_EQ(d.muscles[0].wraps[2].method, WrapMethod::kMidpoint);
  // Written and read back: the same description.
  const LimbDescription again = ReadUrdfString(WriteUrdfString(d), "again.urdf");
  ASSERT_EQ(again.wrap_objects.size(), d.wrap_objects.size());
  for (size_t i = 0; i < d.wrap_objects.size(); ++i) {
    const WrapObjectSpec &a = d.wrap_objects[i], &b = again.wrap_objects[i];
    EXPECT_EQ(a.name, b.name);
    EXPECT_EQ(a.link, b.link);
    EXPECT_EQ(a.shape, b.shape);
    EXPECT_EQ(a.radius, b.radius);
    EXPECT_EQ(a.length, b.length);
    EXPECT_EQ(a.radii, b.radii);
    EXPECT_EQ(a.inner_radius, b.inner_radius);
    EXPECT_EQ(a.outer_radius, b.outer_radius);
    EXPECT_EQ(a.translation, b.translation);
    EXPECT_EQ(a.xyz_body_rotation, b.xyz_body_rotation);
    EXPECT_EQ(a.active, b.active);
    EXPECT_EQ(a.quadrant, b.quadrant);
  }
  ASSERT_EQ(again.muscles[0].wraps.size(), 3u);
  for (size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(again.muscles[0].wraps[i].object, d.muscles[0].wraps[i].object);
    EXPECT_EQ(again.muscles[0].wraps[i].range_first, d.muscles[0].wraps[i].range_first);
    EXPECT_EQ(again.muscles[0].wraps[i].range_last, d.muscles[0].wraps[i].range_last);
    EXPECT_EQ(again.muscles[0].wraps[i].method, d.muscles[0].wraps[i].method);
  }
  EXPECT_NO_THROW(Model{d});
}

void ExpectUrdfError(const std::string& objects, const std::string& list, const std::string& text) {
  try {
    ReadUrdfString(WrapUrdf(objects, list), "leg.urdf");
    ADD_FAILURE() << "no error; expected " << text;
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr(text));
  }
}

TEST(WrapUrdfTest, BadWrapsNameTheFileLineMuscleAndObject) {
  ExpectUrdfError(
      R"(<isowrench:wrap name="c" link="femur" shape="cylinder" radius="-0.004" length="0.02"/>)",
      "", "leg.urdf:9: wrap object 'c' (cylinder): radius -0.004 m must be > 0");
  ExpectUrdfError(
      R"(<isowrench:wrap name="t" link="femur" shape="torus" inner_radius="0.005" outer_radius="0.004"/>)",
      "",
      "leg.urdf:9: wrap object 't' (torus): inner_radius 0.005 m must be below outer_radius 0.004 "
      "m");
  ExpectUrdfError(R"(<isowrench:wrap name="c" link="femur" shape="cylinder_obst" radius="0.004"/>)",
                  "", "WrapCylinderObst and WrapDoubleCylinderObst are not supported yet");
  ExpectUrdfError(
      R"(<isowrench:wrap name="c" link="femur" shape="cylinder" radius="0.004" length="0.02" radii="1 1 1"/>)",
      "", "a cylinder has no 'radii'");
  ExpectUrdfError(
      R"(<isowrench:wrap name="c" link="femur" shape="cylinder" radius="0.004" lenght="0.02"/>)",
      "", "has no attribute 'lenght' (did you mean 'length'?)");
  ExpectUrdfError(kObjects, R"(<isowrench:path_wrap object="knee_cly"/>)",
                  "muscle 'VAS', path_wrap 'knee_cly': no <isowrench:wrap> is called 'knee_cly' "
                  "(did you mean 'knee_cyl'?)");
  ExpectUrdfError(kObjects, R"(<isowrench:path_wrap object="knee_cyl" range="2 4"/>)",
                  "muscle 'VAS', path_wrap 'knee_cyl': range 2 4 is outside the muscle's 3 points");
  ExpectUrdfError(kObjects, R"(<isowrench:path_wrap object="knee_cyl" method="fan"/>)",
                  "method 'fan' is not one of hybrid, midpoint, axial");
  ExpectUrdfError(R"(<isowrench:wrap name="c" link="foot" shape="sphere" radius="0.004"/>)", "",
                  "unknown link 'foot'");
  ExpectUrdfError(
      R"(<isowrench:wrap name="c" link="femur" shape="sphere" radius="0.004" quadrant="+w"/>)", "",
      "quadrant '+w' is not one of all");
}

// The wrap mode is an attribute of <robot> (docs/urdf-extensions.md "Wrap mode"): written by
// WriteUrdfString, read back, and the model read from the file computes its wraps in that mode.
// The reference is the model built in code with the mode set. On sphere_far_side.urdf at a
// straight knee OpenSim wraps the far side of the constrained sphere with a negative arc, the
// exact path goes the long way round: the modes differ by centimetres, so a file that lost the
// mode fails the length check.
TEST(WrapUrdfTest, WrapModeRoundTripsAndSetsTheModelsMode) {
  LimbDescription d = ReadUrdfFile(std::string(ISOWRENCH_TEST_WRAP_DIR) + "/sphere_far_side.urdf");
  EXPECT_EQ(d.wrap_mode, WrapMode::kOpenSim);  // no attribute: opensim
  EXPECT_THAT(WriteUrdfString(d), HasSubstr("isowrench:wrap_mode=\"opensim\""));
  d.wrap_mode = WrapMode::kExact;
  const std::string text = WriteUrdfString(d);
  EXPECT_THAT(text, HasSubstr("isowrench:wrap_mode=\"exact\""));
  const LimbDescription again = ReadUrdfString(text, "again.urdf");
  EXPECT_EQ(again.wrap_mode, WrapMode::kExact);
  LimbDescription opensim = d;
  opensim.wrap_mode = WrapMode::kOpenSim;
  const Model exact_in_code(d), exact_from_file(again), opensim_model(opensim);
  Data a(exact_in_code), b(exact_from_file), c(opensim_model);
  const Eigen::VectorXd q = Eigen::VectorXd::Zero(2);  // rad: hip and knee straight
  const WrappedPath in_code = MuscleWrappedPath(exact_in_code, a, q, 0);
  const WrappedPath from_file = MuscleWrappedPath(exact_from_file, b, q, 0);
  const WrappedPath other = MuscleWrappedPath(opensim_model, c, q, 0);
  ASSERT_TRUE(in_code.wraps.at(0).wrapped);
  EXPECT_EQ(from_file.length, in_code.length);
  EXPECT_GT(in_code.length - other.length, 0.01) << "the modes should differ here";
  // A limb without wrap objects in the default mode is written as before (no attribute); in
  // exact mode it carries it.
  LimbDescription plain = d;
  plain.wrap_objects.clear();
  for (MuscleSpec& m : plain.muscles) m.wraps.clear();
  plain.wrap_mode = WrapMode::kOpenSim;
  EXPECT_THAT(WriteUrdfString(plain), ::testing::Not(HasSubstr("wrap_mode")));
  plain.wrap_mode = WrapMode::kExact;
  EXPECT_EQ(ReadUrdfString(WriteUrdfString(plain), "plain.urdf").wrap_mode, WrapMode::kExact);
}

TEST(WrapUrdfTest, BadWrapModeNamesTheFileLineAndValue) {
  const auto read = [](const std::string& attribute) {
    std::string text = WrapUrdf(kObjects, kList);
    const std::string robot = "xmlns:isowrench=\"urn:isowrench:urdf:1\"";
    text.replace(text.find(robot), robot.size(), robot + " " + attribute);
    return ReadUrdfString(text, "leg.urdf");
  };
  EXPECT_EQ(read("isowrench:wrap_mode=\"exact\"").wrap_mode, WrapMode::kExact);
  EXPECT_EQ(read("isowrench:wrap_mode=\"opensim\"").wrap_mode, WrapMode::kOpenSim);
  EXPECT_THAT([&] { read("isowrench:wrap_mode=\"shortest\""); },
              ::testing::ThrowsMessage<Error>(HasSubstr(
                  "leg.urdf:2: <robot> isowrench:wrap_mode = 'shortest' is not one of opensim, "
                  "exact")));
  EXPECT_THAT([&] { read("isowrench:wrapmode=\"exact\""); },
              ::testing::ThrowsMessage<Error>(HasSubstr(
                  "leg.urdf:2: <robot> has no attribute 'isowrench:wrapmode' (did you mean "
                  "'isowrench:wrap_mode'?)")));
}

}  // namespace
}  // namespace isowrench
