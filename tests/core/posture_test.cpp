// Tests of include/isowrench/posture.hpp: user units (degrees, millimetres) at the boundary.

#include "isowrench/posture.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <limits>

#include "eigen_compare.hpp"
#include "test_models.hpp"

namespace isowrench_test {
namespace {

using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

TEST(Posture, AssignmentsAreDegreesForRevoluteJoints) {
  const isowrench::Model rat = LoadModel("rat_hindlimb_5dof.urdf");
  const Eigen::VectorXd q =
      isowrench::ApplyPostureAssignments(rat, Eigen::VectorXd::Zero(5), "hip_rz=-110,knee_rz=105");
  EXPECT_TRUE(MatricesNear(q, rat.nominal_posture(), 1e-15));
  EXPECT_NEAR(q[0], -110.0 * kPi / 180.0, 1e-15);
  // Unassigned joints keep their value.
  Eigen::VectorXd start = Eigen::VectorXd::Constant(5, 0.25);
  const Eigen::VectorXd q2 = isowrench::ApplyPostureAssignments(rat, start, "knee_rx=90");
  EXPECT_NEAR(q2[4], kPi / 2, 1e-15);
  EXPECT_DOUBLE_EQ(q2[0], 0.25);
  EXPECT_DOUBLE_EQ(q2[3], 0.25);
}

TEST(Posture, AssignmentsAreMillimetresForPrismaticJoints) {
  const isowrench::Model base = LoadModel("rat_hindlimb_5dof_base.urdf");
  const Eigen::VectorXd q =
      isowrench::ApplyPostureAssignments(base, Eigen::VectorXd::Zero(8), "base_x=2,base_z=-0.5");
  EXPECT_NEAR(q[base.JointIndex("base_x")], 0.002, 1e-18);
  EXPECT_NEAR(q[base.JointIndex("base_z")], -0.0005, 1e-18);
  Eigen::VectorXd q2 = Eigen::VectorXd::Zero(8);
  isowrench::SetJointFromUserUnits(base, q2, "base_y", 1.5);
  isowrench::SetJointFromUserUnits(base, q2, "knee_rz", 45);
  EXPECT_NEAR(q2[base.JointIndex("base_y")], 0.0015, 1e-18);
  EXPECT_NEAR(q2[base.JointIndex("knee_rz")], kPi / 4, 1e-15);
}

TEST(Posture, FormatShowsNonZeroJointsInDegrees) {
  const isowrench::Model rat = LoadModel("rat_hindlimb_5dof.urdf");
  const std::string text = isowrench::FormatPosture(rat, rat.nominal_posture());
  EXPECT_THAT(text, HasSubstr("hip_rz=-110"));
  EXPECT_THAT(text, HasSubstr("knee_rz=105"));
  EXPECT_THAT(text, ::testing::Not(HasSubstr("hip_ry")));
  EXPECT_THAT(isowrench::FormatPosture(rat, rat.nominal_posture(), true), HasSubstr("hip_ry"));
}

TEST(Posture, FormatThenApplyRoundTrips) {
  // FormatPosture's "name=value°" list, stripped of units, is a valid assignment string.
  const isowrench::Model rat = LoadModel("rat_hindlimb_5dof.urdf");
  std::string text = isowrench::FormatPosture(rat, rat.nominal_posture());
  std::string cleaned;
  for (size_t i = 0; i < text.size(); ++i) {
    if (text.compare(i, 2, "\xC2\xB0") == 0) {  // UTF-8 degree sign
      ++i;
      continue;
    }
    if (text[i] != ' ') cleaned += text[i];
  }
  const Eigen::VectorXd q =
      isowrench::ApplyPostureAssignments(rat, Eigen::VectorXd::Zero(5), cleaned);
  // FormatPosture prints at least one decimal: 0.05 deg = 8.7e-4 rad is the rounding bound.
  EXPECT_TRUE(MatricesNear(q, rat.nominal_posture(), 8.8e-4)) << cleaned;
}

TEST(Posture, ValidateChecksSizeAndFiniteness) {
  const isowrench::Model rat = LoadModel("rat_hindlimb_5dof.urdf");
  EXPECT_NO_THROW(isowrench::ValidatePosture(rat, rat.nominal_posture()));
  EXPECT_THROW(isowrench::ValidatePosture(rat, Eigen::VectorXd::Zero(4)), isowrench::Error);
  Eigen::VectorXd q = rat.nominal_posture();
  q[2] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THAT([&] { isowrench::ValidatePosture(rat, q); },
              ThrowsMessage<isowrench::Error>(HasSubstr("hip_rx")));
}

}  // namespace
}  // namespace isowrench_test
