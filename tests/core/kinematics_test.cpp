// Tests of include/isowrench/kinematics.hpp: Jacobians against finite differences of forward
// kinematics, closed forms on the rat and the planar 2R limb, and muscle torques against
// finite differences of muscle length.

#include "isowrench/kinematics.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>

#include "eigen_compare.hpp"
#include "test_models.hpp"

namespace isowrench_test {
namespace {

using isowrench::Data;
using isowrench::Matrix6Xd;
using isowrench::Model;

// Central differences with step h: truncation error h^2/6 |f'''| <= 1e-12 * 0.6 m / 6 ~ 1e-13
// for the limbs here (all lengths <= 0.6 m, third derivatives of rotations bounded by 1), and
// rounding error ~ eps * |f| / h <= 2.2e-16 * 0.6 / 1e-6 ~ 1.3e-10. kFdTol is 75x that bound.
constexpr double kFdStep = 1e-6;
constexpr double kFdTol = 1e-8;
// Quantities computed two independent ways from the same closed form differ by rounding only:
// a few dozen operations on numbers <= 1 give well below 1e-14; 1e-12 leaves room for KDL's
// composition of frames.
constexpr double kClosedFormTol = 1e-12;
constexpr int kPosturesPerModel = 10;

Matrix6Xd FiniteDifferenceEndpointJacobian(const Model& model, Data& ws, const Eigen::VectorXd& q) {
  const Eigen::Matrix3d R = isowrench::EndpointPose(model, ws, q).linear();
  Matrix6Xd J(6, model.dof_count());
  for (int i = 0; i < model.dof_count(); ++i) {
    Eigen::VectorXd qp = q, qm = q;
    qp[i] += kFdStep;
    qm[i] -= kFdStep;
    const Eigen::Isometry3d Xp = isowrench::EndpointPose(model, ws, qp);
    const Eigen::Isometry3d Xm = isowrench::EndpointPose(model, ws, qm);
    J.block<3, 1>(0, i) = (Xp.translation() - Xm.translation()) / (2 * kFdStep);
    // dR/dq_i = [w_i]x R  =>  [w_i]x = dR/dq_i R^T.
    const Eigen::Matrix3d dR = (Xp.linear() - Xm.linear()) / (2 * kFdStep);
    J.block<3, 1>(3, i) = Vee(dR * R.transpose());
  }
  return J;
}

Eigen::Matrix3Xd FiniteDifferencePointJacobian(const Model& model, Data& ws,
                                               const Eigen::VectorXd& q, const std::string& link,
                                               const Eigen::Vector3d& p) {
  Eigen::Matrix3Xd Jp(3, model.dof_count());
  for (int i = 0; i < model.dof_count(); ++i) {
    Eigen::VectorXd qp = q, qm = q;
    qp[i] += kFdStep;
    qm[i] -= kFdStep;
    Jp.col(i) = (isowrench::PointPosition(model, ws, qp, link, p) -
                 isowrench::PointPosition(model, ws, qm, link, p)) /
                (2 * kFdStep);
  }
  return Jp;
}

class EveryShippedUrdf : public ::testing::TestWithParam<std::string> {};

TEST_P(EveryShippedUrdf, EndpointJacobianMatchesFiniteDifferences) {
  const Model model = LoadModel(GetParam());
  Data ws(model);
  std::mt19937 rng(1234);
  for (int k = 0; k < kPosturesPerModel; ++k) {
    const Eigen::VectorXd q = RandomPosture(model, rng);
    const Matrix6Xd J = isowrench::EndpointJacobianWorld(model, ws, q);
    EXPECT_TRUE(MatricesNear(J, FiniteDifferenceEndpointJacobian(model, ws, q), kFdTol))
        << GetParam() << " posture " << q.transpose();
  }
}

TEST_P(EveryShippedUrdf, PointJacobianMatchesFiniteDifferencesOnEveryLink) {
  const Model model = LoadModel(GetParam());
  Data ws(model);
  std::mt19937 rng(5678);
  const Eigen::Vector3d p(0.012, -0.007, 0.004);  // an arbitrary point, m, in each link
  for (int k = 0; k < kPosturesPerModel / 2; ++k) {
    const Eigen::VectorXd q = RandomPosture(model, rng);
    for (const std::string& link : model.description().links) {
      const Eigen::Matrix3Xd Jp = isowrench::PointJacobian(model, ws, q, link, p);
      EXPECT_TRUE(MatricesNear(Jp, FiniteDifferencePointJacobian(model, ws, q, link, p), kFdTol))
          << GetParam() << " link " << link;
    }
  }
}

TEST_P(EveryShippedUrdf, RootLinkPointsDoNotMove) {
  const Model model = LoadModel(GetParam());
  Data ws(model);
  std::mt19937 rng(91);
  const Eigen::Vector3d p(0.1, 0.2, 0.3);
  const std::string& root = model.description().root_link;
  const Eigen::VectorXd q = RandomPosture(model, rng);
  EXPECT_TRUE(MatricesNear(isowrench::PointPosition(model, ws, q, root, p), p, kClosedFormTol));
  EXPECT_TRUE(MatricesNear(isowrench::PointJacobian(model, ws, q, root, p),
                           Eigen::Matrix3Xd::Zero(3, model.dof_count()), 0.0));
}

TEST_P(EveryShippedUrdf, EndpointIsThePointOfTheTransducerLink) {
  const Model model = LoadModel(GetParam());
  Data ws(model);
  std::mt19937 rng(17);
  const auto& t = model.transducer();
  for (int k = 0; k < 3; ++k) {
    const Eigen::VectorXd q = RandomPosture(model, rng);
    EXPECT_TRUE(MatricesNear(isowrench::EndpointPose(model, ws, q).translation(),
                             isowrench::PointPosition(model, ws, q, t.link, t.endpoint),
                             kClosedFormTol));
    const Matrix6Xd J = isowrench::EndpointJacobianWorld(model, ws, q);
    EXPECT_TRUE(MatricesNear(J.topRows<3>(),
                             isowrench::PointJacobian(model, ws, q, t.link, t.endpoint),
                             kClosedFormTol));
  }
}

TEST_P(EveryShippedUrdf, TransducerAxesInWorldGiveTheWorldJacobian) {
  // All shipped transducers are bolted to ground with world axes: R_W_T = I and J_T_E = J_W_E.
  const Model model = LoadModel(GetParam());
  ASSERT_TRUE(model.transducer().axes_in_world);
  Data ws(model);
  std::mt19937 rng(23);
  const Eigen::VectorXd q = RandomPosture(model, rng);
  EXPECT_TRUE(MatricesNear(isowrench::TransducerRotation(model, ws, q), Eigen::Matrix3d::Identity(),
                           kClosedFormTol));
  EXPECT_TRUE(MatricesNear(isowrench::EndpointJacobian(model, ws, q),
                           isowrench::EndpointJacobianWorld(model, ws, q), kClosedFormTol));
}

TEST_P(EveryShippedUrdf, MuscleTorqueIsMinusForceTimesLengthGradient) {
  const Model model = LoadModel(GetParam());
  Data ws(model);
  std::mt19937 rng(4242);
  for (int m = 0; m < model.muscle_count(); ++m) {
    const isowrench::MuscleSpec& spec = model.muscle(m);
    for (int k = 0; k < kPosturesPerModel / 2; ++k) {
      const Eigen::VectorXd q = RandomPosture(model, rng);
      const isowrench::MuscleTorque mt = isowrench::ComputeMuscleTorque(model, ws, q, m, 1.0);
      // Length from the path points' world positions (independent of the library's sum).
      double length = 0.0;
      for (size_t s = 0; s + 1 < spec.path.size(); ++s) {
        length += (isowrench::PointPosition(model, ws, q, spec.path[s + 1].link,
                                            spec.path[s + 1].position) -
                   isowrench::PointPosition(model, ws, q, spec.path[s].link, spec.path[s].position))
                      .norm();
      }
      EXPECT_NEAR(mt.length, length, kClosedFormTol) << spec.name;
      EXPECT_DOUBLE_EQ(mt.force, spec.max_force);
      // dL/dq by central differences of the length.
      Eigen::RowVectorXd dL(model.dof_count());
      for (int i = 0; i < model.dof_count(); ++i) {
        Eigen::VectorXd qp = q, qm = q;
        qp[i] += kFdStep;
        qm[i] -= kFdStep;
        dL[i] = (isowrench::ComputeMuscleTorque(model, ws, qp, m).length -
                 isowrench::ComputeMuscleTorque(model, ws, qm, m).length) /
                (2 * kFdStep);
      }
      EXPECT_TRUE(MatricesNear(mt.dL_dq, dL, kFdTol)) << spec.name;
      // tau = -F dL/dq^T; the FD error scales with F.
      EXPECT_TRUE(
          MatricesNear(mt.tau, (-spec.max_force * dL).transpose().eval(), kFdTol * spec.max_force))
          << spec.name;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Urdfs, EveryShippedUrdf, ::testing::ValuesIn(ShippedUrdfs()),
                         [](const ::testing::TestParamInfo<std::string>& info) {
                           std::string name = info.param.substr(0, info.param.find('.'));
                           return name;
                         });

TEST(RatKinematics, NominalEndpointMatchesHandComputedPose) {
  // Nominal posture: hip_rz = -110 deg, knee_rz = 105 deg, others 0. The knee sits at
  // Rz(-110) [0.031 0 0]; the tibia's orientation is Rz(-110 + 105) = Rz(-5 deg); the ankle is
  // the knee plus Rz(-5) [0.041 0 0].
  const Model model = LoadModel("rat_hindlimb_5dof.urdf");
  Data ws(model);
  const Eigen::VectorXd q = model.nominal_posture();
  const Eigen::Vector3d knee(0.031 * std::cos(Deg(-110)), 0.031 * std::sin(Deg(-110)), 0.0);
  const Eigen::Vector3d ankle =
      knee + Eigen::Vector3d(0.041 * std::cos(Deg(-5)), 0.041 * std::sin(Deg(-5)), 0.0);
  const Eigen::Isometry3d X = isowrench::EndpointPose(model, ws, q);
  EXPECT_TRUE(MatricesNear(X.translation(), ankle, kClosedFormTol));
  EXPECT_TRUE(MatricesNear(X.linear(),
                           Eigen::AngleAxisd(Deg(-5), Eigen::Vector3d::UnitZ()).toRotationMatrix(),
                           kClosedFormTol));
  // Column of hip_rz: rotation about world z through the hip (origin): v = z x ankle, w = z.
  const Matrix6Xd J = isowrench::EndpointJacobianWorld(model, ws, q);
  isowrench::Vector6d hip_rz;
  hip_rz << Eigen::Vector3d::UnitZ().cross(ankle), Eigen::Vector3d::UnitZ();
  EXPECT_TRUE(MatricesNear(J.col(model.JointIndex("hip_rz")), hip_rz, kClosedFormTol));
  // Column of knee_rz: rotation about z through the knee.
  isowrench::Vector6d knee_rz;
  knee_rz << Eigen::Vector3d::UnitZ().cross(ankle - knee), Eigen::Vector3d::UnitZ();
  EXPECT_TRUE(MatricesNear(J.col(model.JointIndex("knee_rz")), knee_rz, kClosedFormTol));
  // knee_rx turns the tibia about its own long axis, which passes through the ankle: pure w.
  isowrench::Vector6d knee_rx;
  knee_rx << Eigen::Vector3d::Zero(), (ankle - knee).normalized();
  EXPECT_TRUE(MatricesNear(J.col(model.JointIndex("knee_rx")), knee_rx, kClosedFormTol));
}

// Planar 2R, l1 = 0.30 m, l2 = 0.25 m, both joints about world z (derivation by hand):
//   x = l1 c1 + l2 c12, y = l1 s1 + l2 s12, phi = q1 + q2
//   J (rows x, y, rz) = [[-l1 s1 - l2 s12, -l2 s12], [l1 c1 + l2 c12, l2 c12], [1, 1]],
// rows z, rx, ry identically 0.
TEST(Planar2rKinematics, JacobianMatchesClosedForm) {
  const Model model = LoadModel("planar_2r.urdf");
  Data ws(model);
  const double l1 = 0.30, l2 = 0.25;
  std::mt19937 rng(77);
  std::vector<Eigen::VectorXd> postures = {model.nominal_posture()};
  for (int k = 0; k < 5; ++k) postures.push_back(RandomPosture(model, rng));
  for (const Eigen::VectorXd& q : postures) {
    const double s1 = std::sin(q[0]), c1 = std::cos(q[0]);
    const double s12 = std::sin(q[0] + q[1]), c12 = std::cos(q[0] + q[1]);
    Matrix6Xd expected = Matrix6Xd::Zero(6, 2);
    expected(0, 0) = -l1 * s1 - l2 * s12;
    expected(0, 1) = -l2 * s12;
    expected(1, 0) = l1 * c1 + l2 * c12;
    expected(1, 1) = l2 * c12;
    expected(5, 0) = 1.0;
    expected(5, 1) = 1.0;
    EXPECT_TRUE(
        MatricesNear(isowrench::EndpointJacobianWorld(model, ws, q), expected, kClosedFormTol))
        << "q = " << q.transpose();
    EXPECT_TRUE(MatricesNear(isowrench::EndpointPose(model, ws, q).translation(),
                             Eigen::Vector3d(l1 * c1 + l2 * c12, l1 * s1 + l2 * s12, 0.0),
                             kClosedFormTol));
  }
}

// Biarticular muscle of the 2R limb: origin o on ground, insertion p on the forearm. With u the
// unit vector from p toward o, L = |o - p| and dL/dq_i = -u . (z x (p - c_i)) for joint centre
// c_i, so tau_i = F u . (z x (p - c_i)), the moment of the pull F u about joint i.
TEST(Planar2rKinematics, BiarticularMuscleTorqueMatchesMomentOfThePull) {
  const Model model = LoadModel("planar_2r.urdf");
  Data ws(model);
  const int m = model.MuscleIndex("biarticular");
  const double F = 100.0;
  std::mt19937 rng(99);
  for (int k = 0; k < 5; ++k) {
    const Eigen::VectorXd q = RandomPosture(model, rng);
    const Eigen::Vector3d o(0.05, 0.06, 0.0);
    const Eigen::Vector3d elbow(0.30 * std::cos(q[0]), 0.30 * std::sin(q[0]), 0.0);
    const Eigen::Vector3d p = elbow + Eigen::AngleAxisd(q[0] + q[1], Eigen::Vector3d::UnitZ()) *
                                          Eigen::Vector3d(0.05, 0.02, 0.0);
    const Eigen::Vector3d u = (o - p).normalized();
    const Eigen::Vector3d z = Eigen::Vector3d::UnitZ();
    Eigen::Vector2d tau(F * u.dot(z.cross(p)), F * u.dot(z.cross(p - elbow)));
    const isowrench::MuscleTorque mt = isowrench::ComputeMuscleTorque(model, ws, q, m, 1.0);
    EXPECT_NEAR(mt.length, (o - p).norm(), kClosedFormTol);
    EXPECT_TRUE(MatricesNear(mt.tau, tau, 0.0, kClosedFormTol)) << "q = " << q.transpose();
  }
}

TEST(MuscleTorque, ScalesWithActivation) {
  const Model model = LoadModel("rat_hindlimb_5dof.urdf");
  Data ws(model);
  const Eigen::VectorXd q = model.nominal_posture();
  const int gp = model.MuscleIndex("GP");
  const isowrench::MuscleTorque full = isowrench::ComputeMuscleTorque(model, ws, q, gp, 1.0);
  const isowrench::MuscleTorque half = isowrench::ComputeMuscleTorque(model, ws, q, gp, 0.5);
  EXPECT_DOUBLE_EQ(full.force, 2.3);
  EXPECT_DOUBLE_EQ(half.force, 1.15);
  EXPECT_TRUE(MatricesNear(half.tau, (0.5 * full.tau).eval(), 0.0, 1e-15));
  EXPECT_TRUE(MatricesNear(half.dL_dq, full.dL_dq, 0.0));
}

TEST(Data, IsMovable) {
  const Model model = LoadModel("planar_2r.urdf");
  Data a(model);
  const Eigen::VectorXd q = model.nominal_posture();
  const Matrix6Xd J = isowrench::EndpointJacobianWorld(model, a, q);
  Data b(std::move(a));
  EXPECT_TRUE(MatricesNear(isowrench::EndpointJacobianWorld(model, b, q), J, 0.0));
}

}  // namespace
}  // namespace isowrench_test
