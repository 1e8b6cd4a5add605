// One outcome convention (issue 12 item 5): ClassicWrench reports a status and a message for
// every call instead of silent zeros. References: the projection of tau onto range(J_r^T)
// from an independent QR, and closed forms on the planar 2R limb.

#include <gtest/gtest.h>

#include <Eigen/QR>
#include <cmath>

#include "test_models.hpp"

namespace isowrench_test {
namespace {

using isowrench::StaticsStatus;

TEST(ClassicOutcome, BadInputIsNamedNotSilentZeros) {
  const isowrench::Matrix6Xd J = isowrench::Matrix6Xd::Identity(6, 2);
  const Eigen::Vector2d tau(1.0, 2.0);
  const isowrench::ClassicResult none =
      isowrench::ClassicWrench(J, {"x", "y", "z", "rx", "ry", "rz"}, tau);
  EXPECT_EQ(none.status, StaticsStatus::kInvalidInput);
  EXPECT_NE(none.message.find("released"), std::string::npos) << none.message;
  EXPECT_EQ(none.wrench, isowrench::Vector6d::Zero());
  const isowrench::ClassicResult nan =
      isowrench::ClassicWrench(J, isowrench::DofMask{}, Eigen::Vector2d(1.0, std::nan("")));
  EXPECT_EQ(nan.status, StaticsStatus::kInvalidInput);
  EXPECT_NE(nan.message.find("tau"), std::string::npos) << nan.message;
  const isowrench::ClassicResult sizes =
      isowrench::ClassicWrench(J, isowrench::DofMask{}, Eigen::Vector3d(1, 2, 3));
  EXPECT_EQ(sizes.status, StaticsStatus::kInvalidInput);
  EXPECT_NE(sizes.message.find("3 entries for 2 columns"), std::string::npos) << sizes.message;
}

// Planar 2R (links 1 and 1, q = (0.3, 0.5)), rows x and y restrained: J_r square, W = J_r^-T tau.
TEST(ClassicOutcome, SquareRestrainedRowsAreOk) {
  const double q1 = 0.3, q12 = 0.8;
  isowrench::Matrix6Xd J = isowrench::Matrix6Xd::Zero(6, 2);
  J(0, 0) = -std::sin(q1) - std::sin(q12);
  J(0, 1) = -std::sin(q12);
  J(1, 0) = std::cos(q1) + std::cos(q12);
  J(1, 1) = std::cos(q12);
  J(5, 0) = J(5, 1) = 1.0;
  const Eigen::Vector2d tau(0.2, -0.1);
  const isowrench::ClassicResult r = isowrench::ClassicWrench(J, {"z", "rx", "ry", "rz"}, tau);
  EXPECT_EQ(r.status, StaticsStatus::kOk) << r.message;
  EXPECT_TRUE(r.square_inverse);
  // Cramer's rule on J_r^T W = tau.
  const double a = J(0, 0), b = J(1, 0), c = J(0, 1), d = J(1, 1), det = a * d - b * c;
  EXPECT_NEAR(r.wrench[0], (tau[0] * d - b * tau[1]) / det, 1e-12);
  EXPECT_NEAR(r.wrench[1], (a * tau[1] - c * tau[0]) / det, 1e-12);
}

// Fewer restrained rows than joints: J_r^T W = tau has no solution for a generic tau; the
// status says so and the residual is the part of tau outside range(J_r^T).
TEST(ClassicOutcome, UnreachableTorqueIsSelfMotionWithTheResidual) {
  const isowrench::Model model = LoadModel("planar_4r.urdf");
  const isowrench::WrenchEvaluation e =
      isowrench::EvaluateWrench(model, model.nominal_posture(), model.muscle(0).name);
  const isowrench::ClassicResult r =
      isowrench::ClassicWrench(e.jacobian, {"z", "rx", "ry", "rz"}, e.tau);
  Eigen::MatrixXd JrT(e.jacobian.cols(), 2);
  JrT << e.jacobian.row(0).transpose(), e.jacobian.row(1).transpose();
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(JrT);
  const Eigen::MatrixXd Q = qr.householderQ() * Eigen::MatrixXd::Identity(JrT.rows(), 2);
  const double outside = (e.tau - Q * (Q.transpose() * e.tau)).norm();
  ASSERT_GT(outside, 1e-6 * e.tau.norm());
  EXPECT_EQ(r.status, StaticsStatus::kSelfMotion) << r.message;
  EXPECT_NEAR(r.residual, outside, 1e-12 * std::max(1.0, e.tau.norm()));
  EXPECT_NE(r.message.find("cannot balance tau"), std::string::npos) << r.message;
}

}  // namespace
}  // namespace isowrench_test

namespace isowrench_test {
namespace {

// The lean solve reports the same outcomes with a message made on demand: a planar 2R limb
// (J written by hand) whose K = J^T S_t J + S_p is built to be regular, singular with tau
// orthogonal to its null space, and singular with tau along it.
TEST(LeanOutcome, StatusMessageSaysWhatTheSolveFound) {
  isowrench::Data data(2);
  isowrench::Matrix6Xd J = isowrench::Matrix6Xd::Zero(6, 2);
  J(0, 0) = 1.0;  // joint 1 moves the endpoint along x, joint 2 does not move it at all
  isowrench::Vector6d s_t = isowrench::Vector6d::Zero();
  s_t[0] = 100.0;
  // S_p = diag(0, 0): K = diag(100, 0), null(K) = e2.
  const isowrench::WrenchResult held =
      isowrench::SolveStatics(data, J, s_t, Eigen::Vector2d(0, 0), Eigen::Vector2d(1, 0));
  EXPECT_EQ(held.status, StaticsStatus::kSelfMotionHeld);
  EXPECT_EQ(held.self_motion_count, 1);
  EXPECT_NEAR(held.wrench[0], 1.0, 1e-12);  // W = S_t J K^+ tau = 100 * 1/100
  EXPECT_EQ(isowrench::StatusMessage(held).rfind("self-motion (not excited): null(K) has 1 "
                                                 "direction that tau does not drive",
                                                 0),
            0u)
      << isowrench::StatusMessage(held);
  const isowrench::WrenchResult moves =
      isowrench::SolveStatics(data, J, s_t, Eigen::Vector2d(0, 0), Eigen::Vector2d(1, 2));
  EXPECT_EQ(moves.status, StaticsStatus::kSelfMotion);
  EXPECT_EQ(moves.wrench, isowrench::Vector6d::Zero());
  EXPECT_EQ(
      isowrench::StatusMessage(moves).rfind("self-motion: tau drives 1 direction of null(K)", 0),
      0u)
      << isowrench::StatusMessage(moves);
  const isowrench::WrenchResult ok =
      isowrench::SolveStatics(data, J, s_t, Eigen::Vector2d(0, 3), Eigen::Vector2d(1, 2));
  EXPECT_EQ(ok.status, StaticsStatus::kOk);
  EXPECT_EQ(isowrench::StatusMessage(ok).rfind("ok: ", 0), 0u);
  const isowrench::WrenchResult negative =
      isowrench::SolveStatics(data, J, s_t, Eigen::Vector2d(0, -3), Eigen::Vector2d(1, 2));
  EXPECT_EQ(negative.status, StaticsStatus::kInvalidInput);
  EXPECT_EQ(isowrench::StatusMessage(negative).rfind("invalid input: ", 0), 0u);
  isowrench::WrenchResult two;
  two.status = StaticsStatus::kSelfMotion;
  two.self_motion_count = 2;
  EXPECT_NE(isowrench::StatusMessage(two).find("drives 2 directions"), std::string::npos);
}

}  // namespace
}  // namespace isowrench_test
