// Issue 26, item 1: plausibility warnings from one place (include/isowrench/input_checks.hpp),
// asked by every reader and option: a posture outside the joint's limits or beyond a full turn
// (URDF <isowrench:posture value=>, --posture, posture and trial CSV), a rotation beyond a full
// turn (degrees written as radians), a coupled joint moving the endpoint further than the limb
// is long, offsets typed at import. Legal values warn, they never fail.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>
#include <string>

#include "isowrench/error.hpp"
#include "isowrench/input_checks.hpp"
#include "isowrench/kinematics.hpp"
#include "isowrench/model.hpp"
#include "isowrench/opensim.hpp"
#include "isowrench/posture.hpp"
#include "util/text.hpp"

namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::IsEmpty;
using ::testing::Not;
using ::testing::SizeIs;

// A cat hindlimb written from the docs: hip and knee with URDF limits (rad), a prismatic knee
// slide coupled to the knee by a <mimic> (m per rad), shank 0.15 m, thigh 0.12 m.
std::string Cat(const std::string& hip_posture, const std::string& slide_multiplier,
                const std::string& transducer_rpy = "0 0 0",
                const std::string& knee_rpy = "0 0 0") {
  return R"(<robot name="cat" xmlns:isowrench="urn:isowrench:urdf:1">
  <link name="ground"/> <link name="thigh"/> <link name="shank_0"/> <link name="shank"/>
  <joint name="hip_rz" type="revolute">
    <parent link="ground"/> <child link="thigh"/> <axis xyz="0 0 1"/>
    <limit lower="-2.5" upper="0.5" effort="1" velocity="1"/>
  </joint>
  <joint name="knee_rz" type="revolute">
    <parent link="thigh"/> <child link="shank_0"/>
    <origin xyz="0.12 0 0" rpy=")" +
         knee_rpy + R"("/> <axis xyz="0 0 1"/>
    <limit lower="0" upper="2.6" effort="1" velocity="1"/>
  </joint>
  <joint name="knee_slide" type="prismatic">
    <parent link="shank_0"/> <child link="shank"/> <axis xyz="1 0 0"/>
    <limit lower="-0.01" upper="0.01" effort="1" velocity="1"/>
    <mimic joint="knee_rz" multiplier=")" +
         slide_multiplier + R"(" offset="0"/>
  </joint>
  <isowrench:transducer link="shank" xyz="0.15 0 0" rpy=")" +
         transducer_rpy + R"(" axes="world"/>
  <isowrench:muscle name="GS" max_force="20">
    <isowrench:point link="ground" xyz="0.02 0.02 0"/>
    <isowrench:point link="shank" xyz="0.05 0.005 0"/>
  </isowrench:muscle>
  <isowrench:posture joint="hip_rz" )" +
         hip_posture + R"(/>
  <isowrench:posture joint="knee_rz" degrees="50"/>
</robot>
)";
}

const std::string kSlideMm = "0.001";  // 1 mm per rad: what was meant
const std::string kSlideM = "1";       // 1 m per rad: the slip

TEST(Plausibility, TheCatAsMeantLoadsWithoutAWarning) {
  isowrench::WarningCollector warnings;
  isowrench::Model model(isowrench::ReadUrdfString(Cat("degrees=\"-60\"", kSlideMm), "cat.urdf"));
  EXPECT_THAT(warnings.warnings(), IsEmpty()) << warnings.text();
  // Limits themselves are plausible: exactly at lower and upper, nothing.
  EXPECT_THAT(isowrench::PostureWarnings(model.description(), Eigen::Vector2d(-2.5, 2.6)),
              IsEmpty());
}

TEST(Plausibility, UrdfPostureInRadiansThatWereDegreesWarnsNamingTheLine) {
  // value= is radians: -60 where -60 degrees were meant is -3437.75 deg.
  isowrench::WarningCollector warnings;
  isowrench::ReadUrdfString(Cat("value=\"-60\"", kSlideMm), "cat.urdf");
  ASSERT_THAT(warnings.warnings(), SizeIs(1)) << warnings.text();
  EXPECT_THAT(warnings.text(),
              AllOf(HasSubstr("cat.urdf:22: <isowrench:posture>: hip_rz = -3437.75° (-60 rad) "
                              "is outside the joint's limits -143.239° (-2.5 rad) .. 28.6479° "
                              "(0.5 rad) and more than a full turn"),
                    HasSubstr("degrees where radians were meant?")));
}

TEST(Plausibility, UrdfPostureOutsideTheLimitsButWithinATurnWarns) {
  isowrench::WarningCollector warnings;
  isowrench::ReadUrdfString(Cat("degrees=\"60\"", kSlideMm), "cat.urdf");
  EXPECT_THAT(warnings.text(), AllOf(HasSubstr("hip_rz = 60° (1.0472 rad) is outside the joint's "
                                               "limits"),
                                     Not(HasSubstr("full turn"))));
}

TEST(Plausibility, PostureOptionBeyondAFullTurnWarnsNamingTheItem) {
  isowrench::WarningCollector collector;
  isowrench::Model model(isowrench::ReadUrdfString(Cat("degrees=\"-60\"", kSlideMm), "cat.urdf"));
  std::vector<std::string> warnings;
  Eigen::VectorXd q =
      isowrench::ApplyPostureAssignments(model, model.nominal_posture(), "hip_rz=-3437", &warnings);
  EXPECT_NEAR(q[0], -3437 * M_PI / 180, 1e-12);  // the value is used as given: a warning only
  ASSERT_THAT(warnings, SizeIs(1));
  EXPECT_THAT(warnings[0], AllOf(HasSubstr("--posture hip_rz=-3437: hip_rz = -3437° (-59.987 "
                                           "rad) is outside the joint's limits"),
                                 HasSubstr("more than a full turn (no limb joint turns that far")));
  // Values inside the limits, and the knee (not named), say nothing.
  isowrench::ApplyPostureAssignments(model, model.nominal_posture(), "hip_rz=-100", &warnings);
  EXPECT_THAT(warnings, IsEmpty());
}

// Found by posture_fuzzer once its dictionary held "1e308" (issue 26): -1e308 deg overflowed to
// -inf in the conversion to radians (x pi first, / 180 second) and was accepted as a posture.
// Beyond a thousand turns a value is an error; below, the conversion stays finite.
TEST(Plausibility, AngleBeyondAThousandTurnsIsAnErrorNotInfinity) {
  isowrench::Model model(isowrench::ReadUrdfString(Cat("degrees=\"-60\"", kSlideMm), "cat.urdf"));
  EXPECT_THAT(
      [&] {
        isowrench::ApplyPostureAssignments(model, model.nominal_posture(),
                                           "hip_rz=-10,knee_rz=110,knee_rz=-1e308");
      },
      ::testing::ThrowsMessage<isowrench::Error>(
          HasSubstr("posture of coordinate 'knee_rz': -1e+308 deg cannot be a joint position "
                    "(|value| > 360000 deg)")));
  EXPECT_THAT(
      [&] {
        isowrench::ParsePostureCsv(model, "hip_rz\n1e308\n", "p.csv", model.nominal_posture());
      },
      ::testing::ThrowsMessage<isowrench::Error>(
          HasSubstr("p.csv:2: column 'hip_rz': 1e308 deg cannot be a joint position")));
  EXPECT_TRUE(
      std::isfinite(isowrench::JointValueFromUserUnits(isowrench::JointType::kRevolute, 1e308)));
  isowrench::WarningCollector warnings;  // a thousand turns is still a (warned) posture
  EXPECT_NO_THROW(
      isowrench::ApplyPostureAssignments(model, model.nominal_posture(), "knee_rz=359999"));
}

TEST(Plausibility, RotationsInDegreesWarnNamingTheElement) {
  isowrench::WarningCollector warnings;
  isowrench::LimbDescription d =
      isowrench::ReadUrdfString(Cat("degrees=\"-60\"", kSlideMm, "0 0 90", "0 90 0"), "r.urdf");
  EXPECT_THAT(warnings.text(),
              AllOf(HasSubstr("r.urdf:17: <isowrench:transducer> rpy = 0 0 90 rad turns more "
                              "than a full turn about an axis: degrees written where radians are "
                              "meant? (URDF angles are radians; read as degrees these are 0 0 "
                              "1.571 rad)"),
                    HasSubstr("r.urdf:9: joint 'knee_rz': <origin> rpy = 0 90 0 rad")));
  // The rotation is what a 90 rad turn about z is: 90 - 14 (2 pi) = 2.0354 rad.
  EXPECT_NEAR(isowrench::RollPitchYaw(d.transducer.rotation)[2], 90 - 28 * M_PI, 1e-12);
  EXPECT_EQ(isowrench::FormatRotation(d.transducer.rotation), "rpy 0 0 2.035 rad (0° 0° 116.6°)");
  EXPECT_EQ(isowrench::RotationWarning(Eigen::Vector3d(0, 0, 6.28), "x"), "");
}

TEST(Plausibility, MimicInMetresPerRadianWarnsWithTheEndpointDisplacement) {
  isowrench::WarningCollector warnings;
  isowrench::Model slip(isowrench::ReadUrdfString(Cat("degrees=\"-60\"", kSlideM), "cat.urdf"));
  ASSERT_THAT(warnings.warnings(), SizeIs(1)) << warnings.text();
  // Independently: the endpoint with the slide coupled, against the same limb with the slide
  // held at 0 (multiplier 0), at the nominal posture.
  isowrench::Model held(isowrench::ReadUrdfString(Cat("degrees=\"-60\"", "0"), "held.urdf"));
  isowrench::Data a(slip), b(held);
  const double moved = (isowrench::EndpointPose(slip, a, slip.nominal_posture()).translation() -
                        isowrench::EndpointPose(held, b, held.nominal_posture()).translation())
                           .norm();
  EXPECT_NEAR(moved, 50 * M_PI / 180, 1e-12);  // 1 m/rad x 50 deg
  EXPECT_THAT(warnings.text(),
              AllOf(HasSubstr("cat.urdf:23: <isowrench:posture>: joint 'knee_slide', driven by "
                              "knee_rz = 50° (0.872665 rad), is 872.665 mm (0.872665 m), which "
                              "moves the endpoint " +
                              isowrench::util::FormatNumber(moved * 1e3, 4) +
                              " mm, more than the limb's own length 270 mm"),
                    HasSubstr("m/rad where mm/rad was meant")));
}

TEST(Plausibility, PostureCsvWarnsOncePerColumn) {
  isowrench::Model model(isowrench::ReadUrdfString(Cat("degrees=\"-60\"", kSlideMm), "cat.urdf"));
  isowrench::WarningCollector warnings;
  auto postures = isowrench::ParsePostureCsv(model, "hip_rz,knee_rz\n-60,50\n-400,50\n-500,400\n",
                                             "p.csv", model.nominal_posture());
  EXPECT_EQ(postures.size(), 3u);
  ASSERT_THAT(warnings.warnings(), SizeIs(2)) << warnings.text();
  EXPECT_THAT(warnings.warnings()[0],
              AllOf(HasSubstr("p.csv:3, column 'hip_rz': hip_rz = -400°"),
                    HasSubstr("(later rows of this column are not reported)")));
  EXPECT_THAT(warnings.warnings()[1], HasSubstr("p.csv:4, column 'knee_rz': knee_rz = 400°"));
}

TEST(Plausibility, ImportedEndpointTypedInMillimetresWarns) {
  // `isowrench import --endpoint foot:0,-5,20` (mm meant, metres read).
  isowrench::OpenSimImportOptions options;
  options.clamp_body = "pelvis";
  options.endpoint_body = "foot";
  options.endpoint_point = Eigen::Vector3d(0, -5, 20);
  isowrench::OpenSimImport imported = isowrench::ImportOpenSimFile(
      ISOWRENCH_TEST_DATA_DIR "/../opensim/data/hindlimb.osim", options);
  EXPECT_THAT(isowrench::util::Join(imported.warnings, "\n"),
              HasSubstr("endpoint point 0,-5,20 (m in body 'foot'): the endpoint sits 20.6155 m "
                        "from the origin of link 'foot', outside the plausible segment length"));
  options.endpoint_point = Eigen::Vector3d(0, -0.005, 0.02);
  imported = isowrench::ImportOpenSimFile(ISOWRENCH_TEST_DATA_DIR "/../opensim/data/hindlimb.osim",
                                          options);
  EXPECT_THAT(isowrench::util::Join(imported.warnings, "\n"), Not(HasSubstr("endpoint point")));
}

}  // namespace
