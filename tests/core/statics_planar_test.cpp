// Tests of include/isowrench/statics.hpp, part 3: closed forms on planar limbs, the small-motion
// check and EvaluateWrench's bookkeeping.
//
// Sign: W is the wrench the limb applies to the transducer, [f; m] (N, N·m), moment about the
// endpoint, in transducer axes (= world axes for every model here).

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <Eigen/QR>
#include <cmath>
#include <random>

#include "eigen_compare.hpp"
#include "isowrench/kinematics.hpp"
#include "isowrench/paper.hpp"
#include "isowrench/statics.hpp"
#include "statics_test_helpers.hpp"
#include "test_models.hpp"

namespace isowrench_test {
namespace {

// ---- Planar 2R closed forms --------------------------------------------------------------

// Over-constrained: restrained x, y, rz with S_t = diag(kx, ky, kr), S_p = 0. With a, b the x
// and y rows of J (a1 = -l1 s1 - l2 s12, a2 = -l2 s12, b1 = l1 c1 + l2 c12, b2 = l2 c12) and
// the rz row (1, 1): K = [[kx a1^2 + ky b1^2 + kr, kx a1 a2 + ky b1 b2 + kr],
//                        [ same,                  kx a2^2 + ky b2^2 + kr]],
// dtheta by Cramer's rule, W = (kx (a.dtheta), ky (b.dtheta), kr (dtheta1 + dtheta2)).
Vector6d Planar2rOverConstrainedWrench(double q1, double q2, double kx, double ky, double kr,
                                       const Eigen::Vector2d& tau) {
  const double l1 = 0.30, l2 = 0.25;
  const double s1 = std::sin(q1), c1 = std::cos(q1);
  const double s12 = std::sin(q1 + q2), c12 = std::cos(q1 + q2);
  const double a1 = -l1 * s1 - l2 * s12, a2 = -l2 * s12;
  const double b1 = l1 * c1 + l2 * c12, b2 = l2 * c12;
  const double k11 = kx * a1 * a1 + ky * b1 * b1 + kr;
  const double k12 = kx * a1 * a2 + ky * b1 * b2 + kr;
  const double k22 = kx * a2 * a2 + ky * b2 * b2 + kr;
  const double det = k11 * k22 - k12 * k12;
  const double d1 = (tau[0] * k22 - tau[1] * k12) / det;
  const double d2 = (k11 * tau[1] - k12 * tau[0]) / det;
  Vector6d w = Vector6d::Zero();
  w[0] = kx * (a1 * d1 + a2 * d2);
  w[1] = ky * (b1 * d1 + b2 * d2);
  w[5] = kr * (d1 + d2);
  return w;
}

// Matched: rz released too, J_r = [[a1, a2], [b1, b2]], det J_r = l1 l2 sin(q2);
// J_r^T W = tau  =>  Wx = (tau1 b2 - tau2 b1) / det, Wy = (a1 tau2 - a2 tau1) / det.
Vector6d Planar2rMatchedWrench(double q1, double q2, const Eigen::Vector2d& tau) {
  const double l1 = 0.30, l2 = 0.25;
  const double s1 = std::sin(q1), c1 = std::cos(q1);
  const double s12 = std::sin(q1 + q2), c12 = std::cos(q1 + q2);
  const double a1 = -l1 * s1 - l2 * s12, a2 = -l2 * s12;
  const double b1 = l1 * c1 + l2 * c12, b2 = l2 * c12;
  const double det = l1 * l2 * std::sin(q2);
  Vector6d w = Vector6d::Zero();
  w[0] = (tau[0] * b2 - tau[1] * b1) / det;
  w[1] = (a1 * tau[1] - a2 * tau[0]) / det;
  return w;
}

// Closed form vs library: the 2x2 solves are well conditioned at these postures
// (|sin q2| >= 0.3), so both sides carry rounding ~ cond * eps; 1e-9 relative covers
// cond(K) up to ~4e6 with a 1000x margin (cond here <= 1e4: S_t ratio 1e2 times J's).
constexpr double kPlanarTol = 1e-9;

TEST(Planar2rStatics, OverConstrainedWrenchMatchesCramerSolution) {
  const Model model = LoadModel("planar_2r.urdf");
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> angle(-kPi, kPi), torque(-2.0, 2.0);
  std::vector<Eigen::Vector2d> postures = {{Deg(30), Deg(60)}};
  while (postures.size() < 6) {
    Eigen::Vector2d q(angle(rng), angle(rng));
    if (std::abs(std::sin(q[1])) >= 0.3) postures.push_back(q);
  }
  const std::vector<Eigen::Vector3d> gains = {{1e4, 1e4, 1e2}, {1e3, 5e4, 1.0}, {7.0, 7.0, 7.0}};
  for (const Eigen::Vector2d& q : postures) {
    Data ws(model);
    const Matrix6Xd J = isowrench::EndpointJacobian(model, ws, q);
    const Eigen::Vector2d tau(torque(rng), torque(rng));
    for (const Eigen::Vector3d& g : gains) {
      const StaticsResult r =
          SolveStatics(J, Diag6(g[0], g[1], 0, 0, 0, g[2]), Eigen::VectorXd::Zero(2), tau);
      ASSERT_EQ(r.status, StaticsStatus::kOk) << r.message;
      EXPECT_TRUE(MatricesNear(r.wrench,
                               Planar2rOverConstrainedWrench(q[0], q[1], g[0], g[1], g[2], tau),
                               0.0, kPlanarTol))
          << "q = " << q.transpose() << " gains " << g.transpose();
    }
    // The model's own S_t (1e4, 1e4, 1e2 on x, y, rz) with the muscle torque.
    const auto eval = EvaluateWrench(model, q, "biarticular");
    ASSERT_EQ(eval.statics.status, StaticsStatus::kOk);
    EXPECT_TRUE(MatricesNear(eval.statics.wrench,
                             Planar2rOverConstrainedWrench(q[0], q[1], 1e4, 1e4, 1e2, eval.tau),
                             0.0, kPlanarTol));
  }
}

TEST(Planar2rStatics, MatchedWrenchIsInverseTranspose) {
  const Model model(
      isowrench::WithReleasedDofs(LoadDescription("planar_2r.urdf"), {"z", "rx", "ry", "rz"}));
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> angle(-kPi, kPi);
  for (int k = 0; k < 5; ++k) {
    Eigen::VectorXd q(2);
    do {
      q << angle(rng), angle(rng);
    } while (std::abs(std::sin(q[1])) < 0.3);
    const auto eval = EvaluateWrench(model, q, "biarticular");
    ASSERT_EQ(eval.statics.status, StaticsStatus::kOk);
    const Vector6d expected = Planar2rMatchedWrench(q[0], q[1], eval.tau);
    EXPECT_TRUE(MatricesNear(eval.statics.wrench, expected, 0.0, kPlanarTol));
    EXPECT_TRUE(eval.classic.square_inverse);
    EXPECT_TRUE(MatricesNear(eval.classic.wrench, expected, 0.0, kPlanarTol));
  }
}

// ---- Planar 4R: redundant limb -----------------------------------------------------------

TEST(Planar4rStatics, WithoutJointStiffnessTheNullSpaceOfJIsASelfMotion) {
  LimbDescription d = LoadDescription("planar_4r.urdf");
  for (const char* j : {"j1", "j2", "j3", "j4"}) d = isowrench::WithJointStiffness(d, j, 0.0);
  const Model model(d);
  const auto eval = EvaluateWrench(model, model.nominal_posture(), "flexor");
  const StaticsResult& r = eval.statics;
  // Restrained rows x, y: J_r is 2 x 4, null(K) = null(J_r) is 2-dimensional.
  Eigen::MatrixXd Jr(2, 4);
  Jr << eval.jacobian.row(0), eval.jacobian.row(1);
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(Jr, Eigen::ComputeFullV);
  const Eigen::MatrixXd N = svd.matrixV().rightCols(2);
  // tau is zero on j1 and j4 (the muscle spans j2, j3 only), and a nonzero tau in
  // range(J_r^T) would need a force orthogonal to both j1's and j4's endpoint velocities: so
  // tau excites the self-motion and no equilibrium exists.
  const double excitation = (N.transpose() * eval.tau).norm() / eval.tau.norm();
  ASSERT_GT(excitation, 1e-3);
  EXPECT_EQ(r.status, StaticsStatus::kSelfMotion) << isowrench::StatusName(r.status);
  EXPECT_FALSE(r.message.empty());
  EXPECT_EQ(r.k_rank, 2);
  ASSERT_EQ(r.self_motion.cols(), 2);
  EXPECT_TRUE(MatricesNear((Jr * r.self_motion).eval(), Eigen::MatrixXd::Zero(2, 2), 1e-12));
  for (int c = 0; c < 2; ++c) EXPECT_NEAR(r.self_motion.col(c).norm(), 1.0, 1e-12);
  EXPECT_EQ(Eigen::FullPivLU<Eigen::MatrixXd>(r.self_motion).rank(), 2);
  // Same subspace as the SVD's null space: projecting one onto the other loses nothing.
  EXPECT_TRUE(MatricesNear((N * N.transpose() * r.self_motion).eval(), r.self_motion, 1e-12));
  EXPECT_TRUE(MatricesNear(r.wrench, Vector6d::Zero(), 0.0));
  EXPECT_TRUE(AllFinite(r.dtheta));
}

TEST(Planar4rStatics, JointStiffnessMakesTheRedundantLimbSolvable) {
  const Model model = LoadModel("planar_4r.urdf");  // 0.5 N·m/rad on every joint
  const auto eval = EvaluateWrench(model, model.nominal_posture(), "flexor");
  ASSERT_EQ(eval.statics.status, StaticsStatus::kOk) << eval.statics.message;
  EXPECT_EQ(eval.statics.self_motion.cols(), 0);
  // Independent solve of Eq. 10 on the restrained rows.
  const Eigen::MatrixXd K = StiffnessAtJoints(eval.jacobian, eval.s_t, eval.s_p);
  const Eigen::VectorXd dtheta = K.ldlt().solve(eval.tau);
  const Vector6d w = eval.s_t.asDiagonal() * (eval.jacobian * dtheta);
  const double tol = SolveTolerance(K);
  EXPECT_TRUE(MatricesNear(eval.statics.wrench, w, 0.0, tol));
  EXPECT_TRUE(MatricesNear(eval.statics.dtheta, dtheta, 0.0, tol));
  const Eigen::VectorXd lhs =
      eval.jacobian.transpose() * eval.statics.wrench + eval.s_p.asDiagonal() * eval.statics.dtheta;
  EXPECT_TRUE(MatricesNear(lhs, eval.tau, tol * eval.tau.norm()));
  // Eigenvalues of K reported ascending and matching an independent eigen-solve.
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(K);
  EXPECT_TRUE(MatricesNear(eval.statics.k_eigenvalues, eig.eigenvalues(), 0.0, 1e-10));
  EXPECT_NEAR(eval.statics.k_condition, eig.eigenvalues().maxCoeff() / eig.eigenvalues().minCoeff(),
              1e-6 * eval.statics.k_condition);
}

// ---- Small-motion validity ---------------------------------------------------------------

TEST(SmallMotion, Jr3PresetOnTheRatIsInvalidAndBalancedIsValid) {
  const LimbDescription d = LoadDescription("rat_hindlimb_5dof.urdf");
  const Model jr3(isowrench::WithTransducerStiffness(d, isowrench::TransducerPreset("jr3")));
  const auto bad = EvaluateWrench(jr3, jr3.nominal_posture(), "GP");
  ASSERT_TRUE(bad.statics.ok()) << bad.statics.message;
  EXPECT_FALSE(bad.statics.small_motion_valid);
  EXPECT_FALSE(bad.statics.validity_message.empty());
  // The rule by hand: leg length 31 + 41 mm; the endpoint may move 0.1% of it (72 um) and each
  // joint 0.01 rad. JR3's ~0.5 N/m against ~1 N moves the ankle by metres.
  const Vector6d disp = bad.jacobian * bad.statics.dtheta;
  EXPECT_GT(disp.head<3>().norm(), 1e-3 * 0.072);
  EXPECT_NEAR(bad.statics.endpoint_translation, disp.head<3>().norm(),
              1e-9 * disp.head<3>().norm());
  EXPECT_NEAR(bad.statics.endpoint_translation_limit, 1e-3 * 0.072, 1e-15);
  EXPECT_NEAR(bad.statics.max_joint_rotation, bad.statics.dtheta.cwiseAbs().maxCoeff(),
              1e-9 * bad.statics.max_joint_rotation);

  const Model balanced(isowrench::WithTransducerStiffness(d, Vector6d::Constant(1e7)));
  const auto good = EvaluateWrench(balanced, balanced.nominal_posture(), "GP");
  EXPECT_TRUE(good.statics.small_motion_valid) << good.statics.validity_message;
  EXPECT_TRUE(good.statics.validity_message.empty());
  EXPECT_LE((good.jacobian * good.statics.dtheta).head<3>().norm(), 1e-3 * 0.072);
  EXPECT_LE(good.statics.dtheta.cwiseAbs().maxCoeff(), 0.01);
}

// ---- EvaluateWrench bookkeeping ----------------------------------------------------------

TEST(EvaluateWrench, ReportsTheInputsItUsed) {
  const Model model(isowrench::WithReleasedDofs(LoadDescription("rat_hindlimb_5dof.urdf"), {"rz"}));
  const Eigen::VectorXd q = model.nominal_posture();
  const auto eval = EvaluateWrench(model, q, "GP", 0.5);
  Data ws(model);
  EXPECT_TRUE(MatricesNear(eval.q, q, 0.0));
  EXPECT_TRUE(MatricesNear(eval.jacobian, isowrench::EndpointJacobian(model, ws, q), 1e-15));
  EXPECT_DOUBLE_EQ(eval.muscle_force, 1.15);
  EXPECT_EQ(eval.muscle, "GP");
  EXPECT_TRUE(MatricesNear(eval.s_t, Diag6(1e7, 1e7, 1e7, 1e7, 1e7, 0.0), 0.0));
  EXPECT_TRUE(MatricesNear(eval.wrench_world, eval.statics.wrench, 1e-15));  // world axes
  EXPECT_EQ(eval.statics.wrench[isowrench::kRZ], 0.0);
}

}  // namespace
}  // namespace isowrench_test
