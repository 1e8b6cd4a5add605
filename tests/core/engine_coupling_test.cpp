// The engine on coupled joints (issue 12 item 2): columns are the independent coordinates,
// J = J_joints C, tau = C^T tau_joints, locked coordinates rigid in the statics only. The
// references are written here: forward kinematics of the test leg composed by hand (planar
// rotations and the coupling laws evaluated from their formulas), central differences of it,
// the same leg written with one joint instead of a mimic pair, and the leg with the locked
// joint turned into a fixed one.

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>

#include "isowrench/engine.hpp"
#include "test_models.hpp"

namespace isowrench_test {
namespace {

using isowrench::Model;

constexpr double kTol = 1e-12;  // the same formula two ways: rounding only (lengths <= 0.1 m)
constexpr double kFdStep = 1e-6;
// Central differences: truncation h^2/6 |f'''| ~ 1e-13, rounding eps |f| / h ~ 2e-11 (|f| <= 0.1
// m).
constexpr double kFdTol = 1e-9;

// hip (rz) - knee_tx (prismatic x, mimic of knee: tx = 0.004 knee + 0.001) - knee_ty (prismatic
// y, `ty_law`) - knee (rz) - weld (fixed, 4 cm) - foot; muscle from ground to the shank.
std::string Leg(const std::string& ty_law) {
  return R"(<?xml version="1.0"?>
<robot name="coupled_leg" xmlns:isowrench="urn:isowrench:urdf:1">
  <link name="ground"/> <link name="thigh"/> <link name="slide_x"/> <link name="slide_y"/>
  <link name="shank"/> <link name="foot"/>
  <joint name="hip" type="continuous">
    <parent link="ground"/> <child link="thigh"/> <origin xyz="0 0 0"/> <axis xyz="0 0 1"/>
  </joint>
  <joint name="knee_tx" type="prismatic">
    <parent link="thigh"/> <child link="slide_x"/> <origin xyz="0.03 0 0"/> <axis xyz="1 0 0"/>
    <limit lower="-0.01" upper="0.01" effort="1" velocity="1"/>
    <mimic joint="knee" multiplier="0.004" offset="0.001"/>
  </joint>
  <joint name="knee_ty" type="prismatic">
    <parent link="slide_x"/> <child link="slide_y"/> <origin xyz="0 0 0"/> <axis xyz="0 1 0"/>
    <limit lower="-0.01" upper="0.01" effort="1" velocity="1"/>
  </joint>
  <joint name="knee" type="revolute">
    <parent link="slide_y"/> <child link="shank"/> <origin xyz="0 0 0"/> <axis xyz="0 0 1"/>
    <limit lower="-1" upper="2.5" effort="1" velocity="1"/>
  </joint>
  <joint name="weld" type="fixed">
    <parent link="shank"/> <child link="foot"/> <origin xyz="0.04 0 0"/>
  </joint>
  <isowrench:transducer link="foot" xyz="0 0 0"/>
  <isowrench:muscle name="M" max_force="2">
    <isowrench:point link="ground" xyz="0.01 0.012 0.003"/>
    <isowrench:point link="shank" xyz="0.012 -0.004 0.002"/>
  </isowrench:muscle>
  <isowrench:coupling joint="knee_ty" coordinate="knee">)" +
         ty_law + R"(</isowrench:coupling>
</robot>
)";
}

// ty = 0.003 k^2 - 0.002 k + 0.0015 (polynomial, highest order first).
const char* kPolynomial = R"(<isowrench:polynomial coefficients="0.003 -0.002 0.0015"/>)";
double PolynomialTy(double k) { return 0.003 * k * k - 0.002 * k + 0.0015; }
// A SimmSpline through knots of the cubic ty = 0.001 k^3 - 0.002 k + 0.0015 reproduces the
// cubic between its end knots (FMM end conditions, shared/OPENSIM.md).
const char* kSpline = R"(<isowrench:simm_spline x="-1 -0.5 0 0.5 1 1.5 2 2.5" )"
                      R"(y="0.0025 0.002375 0.0015 0.000625 0.0005 0.0018750 0.0055 0.0121250"/>)";
double SplineTy(double k) { return 0.001 * k * k * k - 0.002 * k + 0.0015; }

Eigen::Matrix3d Rz(double a) {
  return Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

// The leg's forward kinematics by hand: a point `p` on the shank at posture (hip, knee).
Eigen::Vector3d ShankPoint(double (*ty)(double), double hip, double knee,
                           const Eigen::Vector3d& p) {
  const Eigen::Vector3d slide(0.03 + 0.004 * knee + 0.001, ty(knee), 0.0);
  return Rz(hip) * (slide + Rz(knee) * p);
}
double MuscleLength(double (*ty)(double), double hip, double knee) {
  return (ShankPoint(ty, hip, knee, Eigen::Vector3d(0.012, -0.004, 0.002)) -
          Eigen::Vector3d(0.01, 0.012, 0.003))
      .norm();
}

struct Law {
  const char* xml;
  double (*ty)(double);
};

class CoupledLeg : public ::testing::TestWithParam<int> {
 protected:
  Law law() const {
    return GetParam() == 0 ? Law{kPolynomial, PolynomialTy} : Law{kSpline, SplineTy};
  }
};

TEST_P(CoupledLeg, ColumnsAreTheIndependentCoordinates) {
  const Model model(isowrench::ReadUrdfString(Leg(law().xml), "leg.urdf"));
  ASSERT_EQ(model.dof_count(), 2);
  EXPECT_EQ(model.joint_names(), (std::vector<std::string>{"hip", "knee"}));
  EXPECT_EQ(model.JointIndex("knee"), 1);
  EXPECT_THROW(model.JointIndex("knee_tx"), isowrench::Error);
}

TEST_P(CoupledLeg, PoseJacobianAndMomentArmsEqualHandKinematicsAndItsDifferences) {
  const Model model(isowrench::ReadUrdfString(Leg(law().xml), "leg.urdf"));
  const auto ty = law().ty;
  isowrench::Data ws(model);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> hip(-kPi, kPi), knee(-0.9, 2.4);
  const Eigen::Vector3d foot(0.04, 0, 0);
  for (int p = 0; p < 200; ++p) {
    const Eigen::Vector2d q(hip(rng), knee(rng));
    const Eigen::Isometry3d pose = isowrench::EndpointPose(model, ws, q);
    EXPECT_LE((pose.translation() - ShankPoint(ty, q[0], q[1], foot)).norm(), kTol);
    EXPECT_LE((pose.linear() - Rz(q[0] + q[1])).cwiseAbs().maxCoeff(), kTol);
    const isowrench::Matrix6Xd J = isowrench::EndpointJacobianWorld(model, ws, q);
    const isowrench::MuscleTorque mt = isowrench::ComputeMuscleTorque(model, ws, q, 0);
    EXPECT_NEAR(mt.length, MuscleLength(ty, q[0], q[1]), kTol);
    for (int c = 0; c < 2; ++c) {
      Eigen::Vector2d qp = q, qm = q;
      qp[c] += kFdStep;
      qm[c] -= kFdStep;
      const Eigen::Vector3d v =
          (ShankPoint(ty, qp[0], qp[1], foot) - ShankPoint(ty, qm[0], qm[1], foot)) / (2 * kFdStep);
      EXPECT_LE((J.col(c).head<3>() - v).norm(), kFdTol) << "column " << c;
      // Both coordinates turn the foot about z at unit rate (the slides do not rotate it).
      EXPECT_LE((J.col(c).tail<3>() - Eigen::Vector3d::UnitZ()).norm(), kTol);
      const double dL =
          (MuscleLength(ty, qp[0], qp[1]) - MuscleLength(ty, qm[0], qm[1])) / (2 * kFdStep);
      EXPECT_NEAR(mt.dL_dq[c], dL, kFdTol) << "column " << c;
      EXPECT_NEAR(mt.tau[c], -2.0 * mt.dL_dq[c], kTol);
      // A shank point's Jacobian: the same differences.
      const Eigen::Vector3d a(0.02, 0.005, -0.001);
      const Eigen::Vector3d va =
          (ShankPoint(ty, qp[0], qp[1], a) - ShankPoint(ty, qm[0], qm[1], a)) / (2 * kFdStep);
      EXPECT_LE((isowrench::PointJacobian(model, ws, q, "shank", a).col(c) - va).norm(), kFdTol);
    }
  }
}

TEST_P(CoupledLeg, FastSingleBatchAndReferenceAgree) {
  isowrench::LimbDescription d = isowrench::ReadUrdfString(Leg(law().xml), "leg.urdf");
  d.transducer.released = isowrench::DofMask{"rx", "ry"};  // 4 restrained, 2 dofs
  const Model model(d);
  isowrench::Data ws(model);
  std::mt19937 rng(6);
  std::uniform_real_distribution<double> hip(-kPi, kPi), knee(-0.9, 2.4);
  const int postures = 37;  // not a multiple of the lane count
  Eigen::MatrixXd Q(2, postures);
  for (int p = 0; p < postures; ++p) {
    Q(0, p) = hip(rng);
    Q(1, p) = knee(rng);
  }
  std::vector<isowrench::StiffnessSet> sets(3, model.model_stiffness());
  sets[1].s_p.setConstant(0.3);
  sets[2].s_t *= 0.01;
  std::vector<isowrench::WrenchResult> batch;
  isowrench::EvaluateBatch(model, Q, 0, sets, batch, 0.7);
  for (int p = 0; p < postures; ++p) {
    const Eigen::VectorXd q = Q.col(p);
    const isowrench::WrenchEvaluation ref = isowrench::EvaluateWrench(model, q, "M", 0.7);
    for (size_t s = 0; s < sets.size(); ++s) {
      const isowrench::WrenchResult single = isowrench::Evaluate(model, ws, q, 0, sets[s], 0.7);
      const isowrench::WrenchResult& b = batch[p * sets.size() + s];
      ASSERT_EQ(single.status, b.status);
      const double scale = std::max(1.0, single.wrench.norm());
      EXPECT_LE((single.wrench - b.wrench).norm(), 1e-9 * scale) << p << " " << s;
      if (s == 0) {
        EXPECT_EQ(single.status, ref.statics.status);
        EXPECT_LE((single.wrench - ref.statics.wrench).norm(), 1e-9 * scale) << p;
        EXPECT_LE((ws.jacobian() - ref.jacobian).cwiseAbs().maxCoeff(), kTol);
      }
    }
  }
}

TEST(CoupledLegKnots, BatchEqualsSingleAtKnotsNearEndKnotsAndBeyondThem) {
  // The batch evaluates a knot coupling of four postures at once, with OpenSim's branches as
  // selects and the interval found by counting knots; an argument exactly on an interior knot
  // goes back to OpenSim's bisection, which decides which interval's polynomial is used. On a
  // piecewise-linear law that choice changes the slope (the knee_ty column of J), so a wrong
  // interval shows as an O(1) difference. Arguments: every knot, 1e-14 and 1e-13 from the end
  // knots (OpenSim snaps within 2e-13), beyond both ends, and between knots.
  const std::vector<double> knots = {-1, -0.5, 0, 0.5, 1, 1.5, 2, 2.5};
  std::vector<double> knee = knots;
  for (double x : {-1 + 1e-14, -1 - 1e-14, -1 + 1e-13, 2.5 - 1e-14, 2.5 + 1e-14, 2.5 - 3e-13, -1.7,
                   3.1, -0.26, 0.74, 1.99, 2.3})
    knee.push_back(x);
  const char* laws[] = {R"(<isowrench:piecewise_linear x="-1 -0.5 0 0.5 1 1.5 2 2.5" )"
                        R"(y="0.0025 0.001 0.0015 0.0002 0.0005 0.0019 0.0055 0.002"/>)",
                        kSpline,
                        R"(<isowrench:natural_cubic_spline x="-1 -0.5 0 0.5 1 1.5 2 2.5" )"
                        R"(y="0.0025 0.001 0.0015 0.0002 0.0005 0.0019 0.0055 0.002"/>)"};
  for (const char* law : laws) {
    const Model model(isowrench::ReadUrdfString(Leg(law), "leg.urdf"));
    isowrench::Data ws(model);
    Eigen::MatrixXd Q(2, static_cast<Eigen::Index>(knee.size()));
    for (size_t p = 0; p < knee.size(); ++p) {
      Q(0, static_cast<Eigen::Index>(p)) = 0.3 + 0.1 * static_cast<double>(p);
      Q(1, static_cast<Eigen::Index>(p)) = knee[p];
    }
    std::vector<isowrench::StiffnessSet> sets = {model.model_stiffness()};
    std::vector<isowrench::WrenchResult> batch;
    isowrench::EvaluateBatch(model, Q, 0, sets, batch);
    for (size_t p = 0; p < knee.size(); ++p) {
      const isowrench::WrenchResult single =
          isowrench::Evaluate(model, ws, Q.col(static_cast<Eigen::Index>(p)), 0, sets[0]);
      ASSERT_EQ(single.status, batch[p].status) << law << " knee " << knee[p];
      EXPECT_LE((single.wrench - batch[p].wrench).norm(), 1e-12 * single.wrench.norm())
          << law << " knee " << knee[p];
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Laws, CoupledLeg, ::testing::Values(0, 1),
                         [](const ::testing::TestParamInfo<int>& info) {
                           return std::string(info.param == 0 ? "Polynomial" : "SimmSpline");
                         });

// Two coaxial joints at one origin, the second a mimic (multiplier 1, offset `offset`) of the
// first, are one joint turning theta = 2 q + offset: J_mimic(q) = 2 J_one(theta), dL/dq
// likewise, and (S_p = 0) the same wrench, since W = S_t J (J^T S_t J)^-1 tau is invariant
// under q -> 2q. With offset 0 the mimic's coupling is the identity: a second joint carrying
// the column with the identity, which the engine folds into it like any other coupled joint.
std::string TwoOrOne(bool mimic, double offset = 0.3) {
  const std::string knee = mimic ? R"(
  <joint name="knee_a" type="revolute">
    <parent link="thigh"/> <child link="mid"/> <origin xyz="0.03 0 0"/> <axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/>
  </joint>
  <joint name="knee_b" type="revolute">
    <parent link="mid"/> <child link="shank"/> <origin xyz="0 0 0"/> <axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/>
    <mimic joint="knee_a" multiplier="1" offset=")" +
                                       std::to_string(offset) + R"("/>
  </joint>)"
                                 : R"(
  <joint name="knee" type="revolute">
    <parent link="thigh"/> <child link="shank"/> <origin xyz="0.03 0 0"/> <axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/>
  </joint>)";
  return std::string(R"(<?xml version="1.0"?>
<robot name="two_or_one" xmlns:isowrench="urn:isowrench:urdf:1">
  <link name="ground"/> <link name="thigh"/>)") +
         (mimic ? R"( <link name="mid"/>)" : "") + R"( <link name="shank"/>
  <joint name="hip" type="continuous">
    <parent link="ground"/> <child link="thigh"/> <origin xyz="0 0 0"/> <axis xyz="0 0 1"/>
  </joint>)" +
         knee + R"(
  <isowrench:transducer link="shank" xyz="0.04 0.002 0"/>
  <isowrench:muscle name="M" max_force="2">
    <isowrench:point link="ground" xyz="0.01 0.012 0.003"/>
    <isowrench:point link="shank" xyz="0.012 -0.004 0.002"/>
  </isowrench:muscle>
</robot>
)";
}

TEST(MimicPair, EqualsOneJointTurningTwiceAsFast) {
  for (const double offset : {0.3, 0.0}) {
    const Model two(isowrench::ReadUrdfString(TwoOrOne(true, offset), "two.urdf"));
    const Model one(isowrench::ReadUrdfString(TwoOrOne(false), "one.urdf"));
    ASSERT_EQ(two.dof_count(), 2);
    ASSERT_EQ(one.dof_count(), 2);
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> angle(-1.5, 1.5);
    const int postures = 100;
    Eigen::MatrixXd Q(2, postures);
    for (int p = 0; p < postures; ++p) {
      const Eigen::Vector2d q(angle(rng), angle(rng));
      Q.col(p) = q;
      const Eigen::Vector2d theta(q[0], 2 * q[1] + offset);
      const isowrench::WrenchEvaluation a = isowrench::EvaluateWrench(two, q, "M");
      const isowrench::WrenchEvaluation b = isowrench::EvaluateWrench(one, theta, "M");
      EXPECT_LE((a.jacobian.col(0) - b.jacobian.col(0)).cwiseAbs().maxCoeff(), kTol);
      EXPECT_LE((a.jacobian.col(1) - 2 * b.jacobian.col(1)).cwiseAbs().maxCoeff(), kTol);
      EXPECT_NEAR(a.muscle_length, b.muscle_length, kTol);
      EXPECT_NEAR(a.tau[0], b.tau[0], kTol);
      EXPECT_NEAR(a.tau[1], 2 * b.tau[1], kTol);
      ASSERT_EQ(a.statics.status, b.statics.status);
      EXPECT_LE((a.statics.wrench - b.statics.wrench).norm(),
                1e-9 * std::max(1.0, b.statics.wrench.norm()));
    }
    // The batch (four postures per lane group) gives the single evaluations' wrenches.
    const std::vector<isowrench::StiffnessSet> sets = {two.model_stiffness()};
    std::vector<isowrench::WrenchResult> batch;
    isowrench::EvaluateBatch(two, Q, 0, sets, batch);
    isowrench::Data ws(two);
    for (int p = 0; p < postures; ++p) {
      const isowrench::WrenchResult single = isowrench::Evaluate(two, ws, Q.col(p), 0, sets[0]);
      ASSERT_EQ(single.status, batch[p].status);
      EXPECT_LE((single.wrench - batch[p].wrench).norm(),
                1e-12 * std::max(1.0, single.wrench.norm()))
          << "offset " << offset << " posture " << p;
    }
  }
}

// A column whose owner is prismatic and into which a revolute joint is folded: hip (rz) -
// slide (prismatic x, coordinate `slide`) - twist (rz, mimic of slide: 20 slide + 0.1) - foot
// (fixed, 4 cm). Column `slide` is [x_slide; 0] + 20 [z x (p_E - o_twist); z]: its angular
// rows come from the folded joint only. References: the leg's kinematics by hand and central
// differences of it, and the batch (whose lane workspace keeps J from one lane group to the
// next) against single evaluations over many groups.
std::string SlideAndTwist() {
  return R"(<?xml version="1.0"?>
<robot name="slide_and_twist" xmlns:isowrench="urn:isowrench:urdf:1">
  <link name="ground"/> <link name="thigh"/> <link name="carriage"/> <link name="shank"/>
  <link name="foot"/>
  <joint name="hip" type="continuous">
    <parent link="ground"/> <child link="thigh"/> <origin xyz="0 0 0"/> <axis xyz="0 0 1"/>
  </joint>
  <joint name="slide" type="prismatic">
    <parent link="thigh"/> <child link="carriage"/> <origin xyz="0.03 0 0"/> <axis xyz="1 0 0"/>
    <limit lower="-0.01" upper="0.01" effort="1" velocity="1"/>
  </joint>
  <joint name="twist" type="revolute">
    <parent link="carriage"/> <child link="shank"/> <origin xyz="0 0 0"/> <axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/>
    <mimic joint="slide" multiplier="20" offset="0.1"/>
  </joint>
  <joint name="weld" type="fixed">
    <parent link="shank"/> <child link="foot"/> <origin xyz="0.04 0 0"/>
  </joint>
  <isowrench:transducer link="foot" xyz="0 0 0"/>
  <isowrench:muscle name="M" max_force="2">
    <isowrench:point link="ground" xyz="0.01 0.012 0.003"/>
    <isowrench:point link="foot" xyz="-0.01 -0.004 0.002"/>
  </isowrench:muscle>
</robot>
)";
}

// A point given in the foot frame, at posture (hip, slide), by hand.
Eigen::Vector3d FootPoint(double hip, double slide, const Eigen::Vector3d& p) {
  const Eigen::Matrix3d R_hip = Eigen::AngleAxisd(hip, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Matrix3d R_twist =
      Eigen::AngleAxisd(20 * slide + 0.1, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return R_hip *
         (Eigen::Vector3d(0.03 + slide, 0, 0) + R_twist * (Eigen::Vector3d(0.04, 0, 0) + p));
}

TEST(FoldIntoPrismaticOwner, JacobianMomentArmsAndBatchMatchTheHandKinematics) {
  const Model model(isowrench::ReadUrdfString(SlideAndTwist(), "slide.urdf"));
  ASSERT_EQ(model.dof_count(), 2);
  isowrench::Data ws(model);
  const Eigen::Vector3d origin(0.01, 0.012, 0.003), insertion(-0.01, -0.004, 0.002);
  auto length = [&](double hip, double slide) {
    return (FootPoint(hip, slide, insertion) - origin).norm();
  };
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> hip(-kPi, kPi), slide(-0.01, 0.01);
  const int postures = 29;  // seven lane groups and one posture
  Eigen::MatrixXd Q(2, postures);
  for (int p = 0; p < postures; ++p) {
    const Eigen::Vector2d q(hip(rng), slide(rng));
    Q.col(p) = q;
    ASSERT_TRUE(isowrench::ComputeKinematics(model, ws, q, 0, 1.0));
    EXPECT_LE((ws.endpoint_position() - FootPoint(q[0], q[1], Eigen::Vector3d::Zero())).norm(),
              kTol);
    const isowrench::JacobianBuffer& J = ws.jacobian();
    for (int c = 0; c < 2; ++c) {
      Eigen::Vector2d qp = q, qm = q;
      qp[c] += kFdStep;
      qm[c] -= kFdStep;
      const Eigen::Vector3d v = (FootPoint(qp[0], qp[1], Eigen::Vector3d::Zero()) -
                                 FootPoint(qm[0], qm[1], Eigen::Vector3d::Zero())) /
                                (2 * kFdStep);
      EXPECT_LE((J.col(c).head<3>() - v).norm(), kFdTol) << "column " << c;
      // tau = -F dL/dq (F = 2 N)
      const double dL = (length(qp[0], qp[1]) - length(qm[0], qm[1])) / (2 * kFdStep);
      EXPECT_NEAR(ws.tau()[c], -2.0 * dL, 10 * kFdTol) << "column " << c;
    }
    EXPECT_LE((J.col(0).tail<3>() - Eigen::Vector3d::UnitZ()).norm(), kTol);
    EXPECT_LE((J.col(1).tail<3>() - 20 * Eigen::Vector3d::UnitZ()).norm(), kTol);
  }
  std::vector<isowrench::StiffnessSet> sets(2, model.model_stiffness());
  sets[1].s_t.tail<3>() *= 1e-3;
  std::vector<isowrench::WrenchResult> batch;
  isowrench::EvaluateBatch(model, Q, 0, sets, batch);
  for (int p = 0; p < postures; ++p) {
    for (size_t s = 0; s < sets.size(); ++s) {
      const isowrench::WrenchResult single = isowrench::Evaluate(model, ws, Q.col(p), 0, sets[s]);
      const isowrench::WrenchResult& b = batch[p * sets.size() + s];
      ASSERT_EQ(single.status, b.status);
      EXPECT_LE((single.wrench - b.wrench).norm(), 1e-12 * std::max(1.0, single.wrench.norm()))
          << "posture " << p << " set " << s;
    }
  }
}

// A locked coordinate is rigid in the statics: the wrench is that of the same leg with the
// locked joint made fixed at its value, while J and the moment arms keep its column.
TEST(LockedCoordinate, StaticsEqualTheLegWithThatJointFixed) {
  isowrench::LimbDescription d = isowrench::ReadUrdfString(Leg(kPolynomial), "leg.urdf");
  d.transducer.released = isowrench::DofMask{"rx", "ry", "rz"};  // 3 restrained, 2 dofs
  d.joints[0].stiffness = 0.0;
  isowrench::LimbDescription locked = d;
  for (isowrench::CoordinateSpec& c : locked.coordinates) {
    if (c.name == "knee") c.locked = true;
  }
  const Model model(locked);
  isowrench::Data ws(model);
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> hip(-kPi, kPi), knee(-0.9, 2.4);
  for (int p = 0; p < 50; ++p) {
    const Eigen::Vector2d q(hip(rng), knee(rng));
    // The same leg with knee, knee_tx and knee_ty fixed at their values for this posture.
    isowrench::LimbDescription fixed = d;
    fixed.coordinates.clear();
    fixed.nominal_posture.clear();
    for (isowrench::JointSpec& j : fixed.joints) {
      const double value = j.name == "knee_tx"   ? 0.004 * q[1] + 0.001
                           : j.name == "knee_ty" ? PolynomialTy(q[1])
                           : j.name == "knee"    ? q[1]
                                                 : 0.0;
      if (j.name == "hip" || j.type == isowrench::JointType::kFixed) continue;
      Eigen::Isometry3d motion = Eigen::Isometry3d::Identity();
      if (j.type == isowrench::JointType::kPrismatic) {
        motion.translation() = j.axis * value;
      } else {
        motion.linear() = Eigen::AngleAxisd(value, j.axis).toRotationMatrix();
      }
      j.origin = j.origin * motion;
      j.type = isowrench::JointType::kFixed;
      j.coordinate.clear();
      j.coupling = isowrench::Function::Linear(1.0, 0.0);
    }
    const Model rigid(fixed);
    ASSERT_EQ(rigid.dof_count(), 1);
    const isowrench::WrenchEvaluation a = isowrench::EvaluateWrench(model, q, "M");
    Eigen::VectorXd q_rigid(1);
    q_rigid[0] = q[0];
    const isowrench::WrenchEvaluation b = isowrench::EvaluateWrench(rigid, q_rigid, "M");
    ASSERT_EQ(a.statics.status, b.statics.status);
    EXPECT_LE((a.statics.wrench - b.statics.wrench).norm(),
              1e-9 * std::max(1.0, b.statics.wrench.norm()));
    EXPECT_EQ(a.statics.dtheta[1], 0.0);
    EXPECT_NEAR(a.statics.dtheta[0], b.statics.dtheta[0],
                1e-9 * std::abs(b.statics.dtheta[0]) + 1e-15);
    EXPECT_NE(a.tau[1], 0.0);  // the moment arm about the locked knee is still reported
    EXPECT_LE((a.jacobian.col(0) - b.jacobian.col(0)).cwiseAbs().maxCoeff(), kTol);
    const isowrench::WrenchResult fast =
        isowrench::Evaluate(model, ws, q, 0, model.model_stiffness());
    ASSERT_EQ(fast.status, a.statics.status);
    EXPECT_LE((fast.wrench - a.statics.wrench).norm(),
              1e-9 * std::max(1.0, a.statics.wrench.norm()));
    EXPECT_EQ(ws.dtheta()[1], 0.0);
  }
}

}  // namespace
}  // namespace isowrench_test
