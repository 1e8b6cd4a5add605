// Bad user input: every error throws isowrench::Error naming the culprit (file and line, joint,
// link, value), and numerical entry points report kInvalidInput instead of producing NaN.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <limits>

#include "eigen_compare.hpp"
#include "isowrench/isowrench.hpp"
#include "test_models.hpp"

namespace isowrench_test {
namespace {

using isowrench::Error;
using ::testing::AllOf;
using ::testing::ContainsRegex;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

auto Load(const std::string& fixture) {
  return [fixture] { isowrench::Model::FromUrdfFile(DataPath(fixture)); };
}

TEST(BadUrdf, MalformedXmlNamesFileAndLine) {
  // tests/data/malformed_xml.urdf: the start tag of <link name="femur" on line 6 never closes.
  EXPECT_THAT(Load("malformed_xml.urdf"),
              ThrowsMessage<Error>(
                  AllOf(HasSubstr("malformed_xml.urdf"), ContainsRegex("[^0-9]6([^0-9]|$)"))));
  EXPECT_THAT([] { isowrench::ReadUrdfFile(DataPath("malformed_xml.urdf")); },
              ThrowsMessage<Error>(HasSubstr("malformed_xml.urdf")));
}

TEST(BadUrdf, MalformedStringNamesItsSourceName) {
  EXPECT_THAT(
      [] { isowrench::ReadUrdfString("<robot name=\"r\">\n<link name=\"a\">\n", "inline-text"); },
      ThrowsMessage<Error>(HasSubstr("inline-text")));
}

TEST(BadUrdf, MissingFileIsNamed) {
  EXPECT_THAT(Load("no_such_file.urdf"), ThrowsMessage<Error>(HasSubstr("no_such_file.urdf")));
}

TEST(BadUrdf, FloatingJointIsRefused) {
  EXPECT_THAT(Load("floating_joint.urdf"),
              ThrowsMessage<Error>(AllOf(HasSubstr("elbow_float"), HasSubstr("floating"))));
}

TEST(BadUrdf, PlanarJointIsRefused) {
  EXPECT_THAT(Load("planar_joint.urdf"),
              ThrowsMessage<Error>(AllOf(HasSubstr("elbow_planar"), HasSubstr("planar"))));
}

TEST(BadUrdf, UnknownLinkInMusclePointIsNamed) {
  EXPECT_THAT(Load("unknown_link_muscle.urdf"), ThrowsMessage<Error>(HasSubstr("shin")));
}

TEST(BadUrdf, NegativeJointStiffnessIsNamed) {
  EXPECT_THAT(Load("negative_stiffness.urdf"),
              ThrowsMessage<Error>(AllOf(HasSubstr("elbow"), HasSubstr("-2.5"))));
}

TEST(BadUrdf, NanJointStiffnessIsNamed) {
  EXPECT_THAT(Load("nan_stiffness.urdf"),
              ThrowsMessage<Error>(AllOf(HasSubstr("elbow"), HasSubstr("nan"))));
}

TEST(BadUrdf, UnknownJointInIsowrenchTagIsNamed) {
  EXPECT_THAT(Load("unknown_joint_tag.urdf"), ThrowsMessage<Error>(HasSubstr("ankle_ry")));
}

TEST(BadEdits, JointStiffnessMustBeFiniteAndNonNegative) {
  const isowrench::LimbDescription d = LoadDescription("rat_hindlimb_6dof.urdf");
  EXPECT_THAT([&] { isowrench::WithJointStiffness(d, "knee_ry", -1.0); },
              ThrowsMessage<Error>(HasSubstr("knee_ry")));
  EXPECT_THAT([&] { isowrench::WithJointStiffness(d, "knee_ry", kNaN); },
              ThrowsMessage<Error>(HasSubstr("knee_ry")));
  EXPECT_THAT([&] { isowrench::WithJointStiffness(d, "ankle_ry", 1.0); },
              ThrowsMessage<Error>(HasSubstr("ankle_ry")));
}

TEST(BadEdits, BaseTransducerAndReleaseValues) {
  const isowrench::LimbDescription d = LoadDescription("rat_hindlimb_5dof.urdf");
  EXPECT_THROW(isowrench::WithBaseStiffness(d, -5.0), Error);
  EXPECT_THROW(isowrench::WithBaseStiffness(d, kNaN), Error);
  isowrench::Vector6d s = isowrench::Vector6d::Constant(1e7);
  s[4] = -1.0;
  EXPECT_THROW(isowrench::WithTransducerStiffness(d, s), Error);
  s[4] = kNaN;
  EXPECT_THROW(isowrench::WithTransducerStiffness(d, s), Error);
  EXPECT_THAT([&] { isowrench::WithReleasedDofs(d, {"rw"}); },
              ThrowsMessage<Error>(HasSubstr("rw")));
  EXPECT_THAT(
      [&] { isowrench::WithExtraJoint(d, "knee_qq", "extra", Eigen::Vector3d::UnitY(), 1.0); },
      ThrowsMessage<Error>(HasSubstr("knee_qq")));
}

TEST(BadPosture, UnknownJointIsNamed) {
  const isowrench::Model rat = LoadModel("rat_hindlimb_5dof.urdf");
  EXPECT_THAT(
      [&] { isowrench::ApplyPostureAssignments(rat, rat.nominal_posture(), "ankle_rz=10"); },
      ThrowsMessage<Error>(HasSubstr("ankle_rz")));
}

TEST(BadPosture, MalformedAndNonFiniteValuesNameTheJoint) {
  const isowrench::Model rat = LoadModel("rat_hindlimb_5dof.urdf");
  for (const char* text : {"hip_rz=abc", "hip_rz=nan", "hip_rz=", "hip_rz=1e999"}) {
    EXPECT_THAT([&] { isowrench::ApplyPostureAssignments(rat, rat.nominal_posture(), text); },
                ThrowsMessage<Error>(HasSubstr("hip_rz")))
        << text;
  }
  EXPECT_THAT(
      [&] {
        Eigen::VectorXd q = rat.nominal_posture();
        isowrench::SetJointFromUserUnits(rat, q, "knee_rz", kNaN);
      },
      ThrowsMessage<Error>(HasSubstr("knee_rz")));
}

TEST(BadEvaluation, UnknownMuscleAndWrongPosture) {
  const isowrench::Model rat = LoadModel("rat_hindlimb_5dof.urdf");
  EXPECT_THAT([&] { isowrench::EvaluateWrench(rat, rat.nominal_posture(), "TA"); },
              ThrowsMessage<Error>(HasSubstr("TA")));
  EXPECT_THROW(isowrench::EvaluateWrench(rat, Eigen::VectorXd::Zero(3), "GP"), Error);
  isowrench::Data ws(rat);
  EXPECT_THROW(isowrench::ComputeMuscleTorque(rat, ws, rat.nominal_posture(), 0, kNaN), Error);
  EXPECT_THAT(
      [&] {
        isowrench::PointPosition(rat, ws, rat.nominal_posture(), "pelvis", Eigen::Vector3d::Zero());
      },
      ThrowsMessage<Error>(HasSubstr("pelvis")));
}

TEST(BadEvaluation, ZeroLengthMuscleSegmentThrows) {
  // Origin on ground at the shoulder centre, insertion on the upper arm at its origin: the two
  // points coincide at every posture.
  isowrench::LimbDescription d = LoadDescription("planar_2r.urdf");
  d.muscles[0].path[0] = {"ground", Eigen::Vector3d::Zero()};
  d.muscles[0].path[1] = {"upper", Eigen::Vector3d::Zero()};
  EXPECT_THROW(
      {
        const isowrench::Model m(d);
        isowrench::Data ws(m);
        isowrench::ComputeMuscleTorque(m, ws, m.nominal_posture(), 0);
      },
      Error);
}

TEST(BadStatics, NonFiniteOrNegativeInputGivesInvalidInputNeverNaN) {
  const isowrench::Model rat = LoadModel("rat_hindlimb_5dof.urdf");
  isowrench::Data ws(rat);
  const Eigen::VectorXd q = rat.nominal_posture();
  const isowrench::Matrix6Xd J = isowrench::EndpointJacobian(rat, ws, q);
  const Eigen::VectorXd tau = isowrench::ComputeMuscleTorque(rat, ws, q, 0).tau;
  const isowrench::Vector6d s_t = isowrench::Vector6d::Constant(1e7);
  const Eigen::VectorXd s_p = Eigen::VectorXd::Zero(5);

  auto expect_invalid = [](const isowrench::StaticsResult& r, const char* what) {
    EXPECT_EQ(r.status, isowrench::StaticsStatus::kInvalidInput) << what;
    EXPECT_FALSE(r.ok()) << what;
    EXPECT_FALSE(r.message.empty()) << what;
    EXPECT_TRUE(AllFinite(r.wrench)) << what;
    EXPECT_TRUE(AllFinite(r.dtheta)) << what;
  };
  Eigen::VectorXd bad_tau = tau;
  bad_tau[1] = kNaN;
  expect_invalid(isowrench::SolveStatics(J, s_t, s_p, bad_tau), "NaN tau");
  isowrench::Vector6d bad_st = s_t;
  bad_st[0] = -1.0;
  expect_invalid(isowrench::SolveStatics(J, bad_st, s_p, tau), "negative S_t");
  bad_st[0] = kNaN;
  expect_invalid(isowrench::SolveStatics(J, bad_st, s_p, tau), "NaN S_t");
  Eigen::VectorXd bad_sp = s_p;
  bad_sp[3] = -2.0;
  expect_invalid(isowrench::SolveStatics(J, s_t, bad_sp, tau), "negative S_p");
  expect_invalid(isowrench::SolveStatics(J, s_t, Eigen::VectorXd::Zero(4), tau), "S_p size");
  expect_invalid(isowrench::SolveStatics(J, s_t, s_p, Eigen::VectorXd::Zero(3)), "tau size");
  isowrench::Matrix6Xd bad_J = J;
  bad_J(2, 2) = std::numeric_limits<double>::infinity();
  expect_invalid(isowrench::SolveStatics(bad_J, s_t, s_p, tau), "infinite J");
}

}  // namespace
}  // namespace isowrench_test
