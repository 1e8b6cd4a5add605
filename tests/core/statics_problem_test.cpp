// Tests of StaticsProblem (include/isowrench/statics.hpp): which coordinates are columns of K,
// the reduced problem and the map back, and the leg length it reports (Model::chain_length(),
// docs/model.md "Leg length"). References: the statics of the same leg with the locked column
// deleted (SolveStatics on a hand-made J), and leg geometry written down by hand.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <sstream>
#include <string>

#include "isowrench/isowrench.hpp"
#include "test_models.hpp"

namespace isowrench_test {
namespace {

using isowrench::CoordinateUse;
using isowrench::Model;
using isowrench::StaticsProblem;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

Model LockedRat() { return Model::FromUrdfFile(DataPath("rat_hindlimb_6dof_locked.urdf")); }

TEST(StaticsProblem, SaysFreeSpringOrLockedPerCoordinate) {
  const Model model = LockedRat();  // knee_ry has 1 N·m/rad, knee_rx is locked
  const StaticsProblem problem(model);
  ASSERT_EQ(problem.coordinate_count(), 6);
  for (const char* name : {"hip_rz", "hip_ry", "hip_rx", "knee_rz"}) {
    EXPECT_EQ(problem.use(model.JointIndex(name)), CoordinateUse::kFree) << name;
  }
  EXPECT_EQ(problem.use(model.JointIndex("knee_ry")), CoordinateUse::kSpring);
  EXPECT_EQ(problem.use(model.JointIndex("knee_rx")), CoordinateUse::kLocked);
  EXPECT_EQ(problem.columns(), (std::vector<int>{0, 1, 2, 3, 4}));
  EXPECT_EQ(problem.spring_free_columns(), (std::vector<int>{0, 1, 2, 3}));
  EXPECT_EQ(problem.locked_columns(), std::vector<int>{5});
  EXPECT_TRUE(problem.base_columns().empty());
  EXPECT_STREQ(problem.RoleLabel(5), "locked");
  EXPECT_STREQ(problem.RoleLabel(4), "extra");
  EXPECT_EQ(problem.leg_length(), model.chain_length());
  // Other compliances: a spring on knee_rz makes it kSpring; the lock stays.
  isowrench::StiffnessSet s = model.model_stiffness();
  s.s_p[3] = 5.0;
  const StaticsProblem sprung(model, s);
  EXPECT_EQ(sprung.use(3), CoordinateUse::kSpring);
  EXPECT_EQ(sprung.use(5), CoordinateUse::kLocked);
  s.s_p.resize(3);
  EXPECT_THAT([&] { StaticsProblem(model, s); },
              ThrowsMessage<isowrench::Error>(HasSubstr("S_p has 3 entries")));
}

TEST(StaticsProblem, SolveIsTheStaticsWithTheLockedColumnDeleted) {
  const Model model = LockedRat();
  const StaticsProblem problem(model);
  isowrench::Data data(model);
  const Eigen::VectorXd q = model.nominal_posture();
  const isowrench::Matrix6Xd J = isowrench::EndpointJacobian(model, data, q);
  const Eigen::VectorXd tau = isowrench::ComputeMuscleTorque(model, data, q, 0).tau;
  // Reference: the 5-column problem written by hand.
  isowrench::Matrix6Xd J5(6, 5);
  Eigen::VectorXd tau5(5), s_p5(5);
  for (int c = 0; c < 5; ++c) {
    J5.col(c) = J.col(c);
    tau5[c] = tau[c];
    s_p5[c] = model.joint_stiffness()[c];
  }
  const isowrench::StaticsResult reference =
      isowrench::SolveStatics(J5, model.model_stiffness().s_t, s_p5, tau5);
  const isowrench::StaticsResult r = problem.Solve(J, tau);
  ASSERT_EQ(r.status, reference.status);
  EXPECT_EQ(r.wrench, reference.wrench);
  ASSERT_EQ(r.dtheta.size(), 6);
  EXPECT_EQ(r.dtheta.head(5), reference.dtheta);
  EXPECT_EQ(r.dtheta[5], 0.0);
  // EvaluateWrench is this solve, and the engine's fast path agrees to rounding.
  const isowrench::WrenchEvaluation e = isowrench::EvaluateWrench(model, q, "GP");
  EXPECT_EQ(e.statics.wrench, r.wrench);
  EXPECT_EQ(e.locked, (std::vector<bool>{false, false, false, false, false, true}));
  const isowrench::WrenchResult fast =
      isowrench::Evaluate(model, data, q, 0, model.model_stiffness());
  EXPECT_LT((fast.wrench - r.wrench).norm(), 1e-9 * r.wrench.norm());
  // Reduce and Expand are inverse on the columns of K.
  EXPECT_EQ(problem.Expand(problem.Reduce(tau)).head(5), tau.head(5));
  EXPECT_EQ(problem.Expand(problem.Reduce(tau))[5], 0.0);
}

TEST(StaticsProblem, EveryCoordinateLockedIsInvalidInputNotACrash) {
  const Model model(isowrench::WithLockedCoordinates(
      isowrench::ReadUrdfFile(UrdfPath("planar_2r.urdf")), {"shoulder", "elbow"}));
  const isowrench::WrenchEvaluation e =
      isowrench::EvaluateWrench(model, model.nominal_posture(), model.muscle(0).name);
  EXPECT_EQ(e.statics.status, isowrench::StaticsStatus::kInvalidInput);
  EXPECT_THAT(e.statics.message, HasSubstr("every coordinate"));
  EXPECT_EQ(e.statics.dtheta.size(), 2);
}

// ---- leg length ------------------------------------------------------------------------------

TEST(LegLength, IsHipKneeAnkleOfThePapersRat) {
  // Femur 31 mm, tibia 41 mm (MODEL.md).
  EXPECT_NEAR(LoadModel("rat_hindlimb_5dof.urdf").chain_length(), 0.072, 1e-15);
  EXPECT_NEAR(LoadModel("rat_hindlimb_6dof.urdf").chain_length(), 0.072, 1e-15);
  // Base dofs translate only: they add no joint centre.
  EXPECT_NEAR(LoadModel("rat_hindlimb_5dof_base.urdf").chain_length(), 0.072, 1e-15);
}

// A planar leg clamped away from the world origin: hip (rz), then the knee. Femur a, tibia b.
// With `rolling`, the tibia's frame sits at the ankle and the femur and tibia lengths live in
// the knee's coupled translations, tx = a + b cos(k), ty = b sin(k), before the knee's rotation
// (as in an OpenSim knee whose child frame is at the ankle): the tibia turns about the true knee
// at (a, 0) of the femur. Otherwise the femur is a fixed offset and the tibia a fixed endpoint
// offset, as in the paper's rat.
std::string ClampedLeg(double a, double b, bool rolling) {
  std::ostringstream x, cx, cy;
  x.precision(17);
  cx.precision(17);
  cy.precision(17);
  for (int i = 0; i <= 125; ++i) {
    const double k = 0.5 + 0.02 * i;
    x << (i ? " " : "") << k;
    cx << (i ? " " : "") << a + b * std::cos(k);
    cy << (i ? " " : "") << b * std::sin(k);
  }
  const std::string femur = rolling ? "0 0 0" : std::to_string(a) + " 0 0";
  const std::string endpoint = rolling ? "0 0 0" : std::to_string(b) + " 0 0";
  std::string urdf = R"(<?xml version="1.0"?>
<robot name="clamped_leg" xmlns:isowrench="urn:isowrench:urdf:1">
  <link name="ground"/> <link name="pelvis"/> <link name="femur"/> <link name="slide_x"/>
  <link name="slide_y"/> <link name="tibia"/>
  <joint name="clamp" type="fixed">
    <parent link="ground"/> <child link="pelvis"/> <origin xyz="0.02 0.05 0.01" rpy="0 0 0.6"/>
  </joint>
  <joint name="hip" type="continuous">
    <parent link="pelvis"/> <child link="femur"/> <origin xyz="0 0 0"/> <axis xyz="0 0 1"/>
  </joint>
  <joint name="knee_tx" type="prismatic">
    <parent link="femur"/> <child link="slide_x"/> <origin xyz=")" +
                     femur + R"("/> <axis xyz="1 0 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
  <joint name="knee_ty" type="prismatic">
    <parent link="slide_x"/> <child link="slide_y"/> <origin xyz="0 0 0"/> <axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
  <joint name="knee" type="revolute">
    <parent link="slide_y"/> <child link="tibia"/> <origin xyz="0 0 0"/> <axis xyz="0 0 1"/>
    <limit lower="0.5" upper="3" effort="1" velocity="1"/>
  </joint>
  <isowrench:transducer link="tibia" xyz=")" +
                     endpoint + R"("/>
  <isowrench:muscle name="M" max_force="2">
    <isowrench:point link="pelvis" xyz="0.01 0.012 0"/>
    <isowrench:point link="tibia" xyz="-0.01 -0.004 0"/>
  </isowrench:muscle>
  <isowrench:posture joint="hip" degrees="-110"/>
  <isowrench:posture joint="knee" degrees="105"/>
)";
  if (rolling) {
    urdf +=
        R"(  <isowrench:coupling joint="knee_tx" coordinate="knee"><isowrench:simm_spline x=")" +
        x.str() + R"(" y=")" + cx.str() + R"("/></isowrench:coupling>
  <isowrench:coupling joint="knee_ty" coordinate="knee"><isowrench:simm_spline x=")" +
        x.str() + R"(" y=")" + cy.str() + R"("/></isowrench:coupling>
)";
  } else {
    // Translations that do nothing (an OpenSim ankle's all-zero splines).
    urdf +=
        R"(  <isowrench:coupling joint="knee_tx" coordinate="knee"><isowrench:constant value="0"/></isowrench:coupling>
  <isowrench:coupling joint="knee_ty" coordinate="knee"><isowrench:constant value="0"/></isowrench:coupling>
)";
  }
  return urdf + "</robot>\n";
}

TEST(LegLength, CountsNoClampOffsetAndFindsAFemurInTheKneesCoupledTranslations) {
  const double a = 0.031, b = 0.041;
  const Model fixed(isowrench::ReadUrdfString(ClampedLeg(a, b, false), "fixed.urdf"));
  // The clamp's 55 mm offset from the world to the hip is not leg.
  EXPECT_NEAR(fixed.chain_length(), a + b, 1e-15);
  const Model rolling(isowrench::ReadUrdfString(ClampedLeg(a, b, true), "rolling.urdf"));
  // The knee's frame is at the ankle; its centre is where the coupled translations turn the
  // tibia about. The splines' derivative errs by ~(0.02 rad)^3 |f''''| ~ 3e-7 m/rad, which moves
  // the centre by as much: 1e-6 m.
  EXPECT_NEAR(rolling.chain_length(), a + b, 1e-6);
  // Both legs are the same leg: the same ankle at the nominal posture.
  isowrench::Data df(fixed), dr(rolling);
  EXPECT_LT((isowrench::EndpointPose(fixed, df, fixed.nominal_posture()).translation() -
             isowrench::EndpointPose(rolling, dr, rolling.nominal_posture()).translation())
                .norm(),
            1e-9);
}

}  // namespace
}  // namespace isowrench_test
