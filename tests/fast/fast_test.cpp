// Tests of include/isowrench/engine.hpp: the compiled fast path equals the KDL reference
// (EndpointJacobian, ComputeMuscleTorque, EvaluateWrench) on random postures of every shipped
// URDF and of a chain built to exercise every code path (fixed joints, tilted origins, general
// axes, a transducer turning with the bone, a multi-point muscle over several links); singular
// K is solved when the muscle does not excite the self-motion; batch equals single.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "isowrench/isowrench.hpp"
#include "util/eigen_instantiations.hpp"

namespace {

using isowrench::Data;
using isowrench::Model;
using isowrench::StaticsStatus;
using isowrench::StiffnessSet;
using isowrench::WrenchResult;

constexpr double kPi = 3.14159265358979323846;
constexpr double kEps = std::numeric_limits<double>::epsilon();

// The fast path and KDL compute the same sums in a different order; for the kinematics that
// leaves differences of a few ulps of the largest entry. 1e-12 relative is ~4500 eps: generous
// for rounding, far below any modelling error (a wrong axis or sign is O(1)).
constexpr double kKinematicsRelTol = 1e-12;

// |a - b| <= rel_tol * max(|a|_max, |b|_max, floor): relative to the largest entry.
::testing::AssertionResult Near(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, double rel_tol,
                                const std::string& what) {
  if (a.rows() != b.rows() || a.cols() != b.cols()) {
    return ::testing::AssertionFailure() << what << ": size " << a.rows() << "x" << a.cols()
                                         << " vs " << b.rows() << "x" << b.cols();
  }
  if (a.size() == 0) return ::testing::AssertionSuccess();
  const double scale = std::max({a.cwiseAbs().maxCoeff(), b.cwiseAbs().maxCoeff(), 1e-300});
  const double diff = (a - b).cwiseAbs().maxCoeff();
  if (!(diff <= rel_tol * scale)) {
    Eigen::IOFormat fmt(Eigen::FullPrecision, 0, ", ", "\n", "  [", "]");
    return ::testing::AssertionFailure() << what << ": largest difference " << diff << " > "
                                         << rel_tol << " x " << scale << "\nfast:\n"
                                         << a.format(fmt) << "\nreference:\n"
                                         << b.format(fmt);
  }
  return ::testing::AssertionSuccess();
}

std::vector<std::string> ShippedUrdfs() {
  std::vector<std::string> files;
  for (const auto& entry : std::filesystem::directory_iterator(ISOWRENCH_TEST_URDF_DIR)) {
    if (entry.path().extension() == ".urdf") files.push_back(entry.path().string());
  }
  std::sort(files.begin(), files.end());
  return files;
}

Eigen::VectorXd RandomPosture(const Model& model, std::mt19937& rng) {
  std::uniform_real_distribution<double> angle(-kPi, kPi);
  std::uniform_real_distribution<double> slide(-0.005, 0.005);
  Eigen::VectorXd q(model.dof_count());
  for (int i = 0; i < model.dof_count(); ++i) {
    q[i] = model.joint(i).type == isowrench::JointType::kPrismatic ? slide(rng) : angle(rng);
  }
  return q;
}

// A chain that uses everything the compiler folds: fixed joints before, between and after the
// movable ones, tilted joint origins, a general (non-coordinate) axis, negative coordinate
// axes, a prismatic joint mid-chain, a transducer turning with the distal bone and rotated,
// a muscle over four links, and S_p on every joint so K is regular.
Model OddChain() {
  isowrench::LimbDescription d;
  d.name = "odd_chain";
  d.root_link = "ground";
  d.links = {"ground", "mount", "a", "b", "b2", "c", "d", "tip"};
  auto pose = [](double x, double y, double z, double roll, double pitch, double yaw) {
    Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
    t.translation() = Eigen::Vector3d(x, y, z);
    t.linear() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                  Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                  Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
                     .toRotationMatrix();
    return t;
  };
  auto joint = [&](const std::string& name, isowrench::JointType type, const std::string& parent,
                   const std::string& child, const Eigen::Isometry3d& origin, Eigen::Vector3d axis,
                   double stiffness) {
    isowrench::JointSpec j;
    j.name = name;
    j.type = type;
    j.parent_link = parent;
    j.child_link = child;
    j.origin = origin;
    j.axis = axis.normalized();
    j.stiffness = stiffness;
    d.joints.push_back(j);
  };
  using isowrench::JointType;
  joint("fix0", JointType::kFixed, "ground", "mount", pose(0.01, -0.02, 0.03, 0.3, -0.2, 0.5),
        Eigen::Vector3d::UnitZ(), 0);
  joint("j1", JointType::kRevolute, "mount", "a", pose(0, 0, 0.02, 0, 0, 0),
        -Eigen::Vector3d::UnitX(), 2.0);
  joint("j2", JointType::kRevolute, "a", "b", pose(0.05, 0.01, 0, 0.1, 0.2, -0.3),
        Eigen::Vector3d(1, 2, -0.5), 1.0);
  joint("fix1", JointType::kFixed, "b", "b2", pose(0.02, 0, 0, 0, 0.4, 0), Eigen::Vector3d::UnitZ(),
        0);
  joint("j3", JointType::kPrismatic, "b2", "c", pose(0.0, 0.01, 0, 0, 0, 0.2),
        Eigen::Vector3d(0.3, -1, 0.2), 3e3);
  joint("j4", JointType::kRevolute, "c", "d", pose(0.04, 0, 0, 0, 0, 0), -Eigen::Vector3d::UnitY(),
        0.5);
  joint("fix2", JointType::kFixed, "d", "tip", pose(0.03, 0.005, 0, -0.4, 0, 0.1),
        Eigen::Vector3d::UnitZ(), 0);
  d.transducer.link = "tip";
  d.transducer.endpoint = Eigen::Vector3d(0.01, 0.002, -0.003);
  d.transducer.axes_in_world = false;
  d.transducer.rotation = pose(0, 0, 0, 0.7, -0.3, 1.1).linear();
  d.transducer.stiffness << 2e6, 3e6, 1e6, 40, 70, 20;
  isowrench::MuscleSpec muscle;
  muscle.name = "wrap";
  muscle.max_force = 12.0;
  muscle.path = {{"ground", Eigen::Vector3d(0.02, 0.03, 0.01)},
                 {"mount", Eigen::Vector3d(0.01, 0.0, 0.01)},
                 {"b", Eigen::Vector3d(0.03, 0.01, 0.005)},
                 {"d", Eigen::Vector3d(0.01, -0.01, 0.0)},
                 {"tip", Eigen::Vector3d(0.02, 0.0, 0.004)}};
  d.muscles.push_back(muscle);
  return Model(d);
}

struct Case {
  Model model;
  std::string label;
};

std::vector<Case> AllModels() {
  std::vector<Case> cases;
  for (const std::string& file : ShippedUrdfs()) cases.push_back({Model::FromUrdfFile(file), file});
  cases.push_back({OddChain(), "odd_chain (built in the test)"});
  return cases;
}

TEST(FastPath, EveryShippedUrdfIsTested) {
  // Guard against an empty directory making the equality test vacuous.
  EXPECT_GE(ShippedUrdfs().size(), 5u);
}

TEST(FastPath, JacobianTorqueAndWrenchEqualKdlOnRandomPostures) {
  std::mt19937 rng(20261121);
  constexpr int kPosturesPerModel = 60;
  for (const Case& c : AllModels()) {
    SCOPED_TRACE(c.label);
    const Model& model = c.model;
    Data ws(model);
    isowrench::Data kdl(model);
    const StiffnessSet stiffness = model.model_stiffness();
    int compared_wrenches = 0;
    for (int n = 0; n < kPosturesPerModel; ++n) {
      const Eigen::VectorXd q = RandomPosture(model, rng);
      for (int mu = 0; mu < model.muscle_count(); ++mu) {
        SCOPED_TRACE("posture " + std::to_string(n) + ", muscle " + model.muscle(mu).name);
        const double activation = 0.25 + 0.5 * mu;
        ASSERT_TRUE(isowrench::ComputeKinematics(model, ws, q, mu, activation));
        const isowrench::Matrix6Xd J_ref = isowrench::EndpointJacobian(model, kdl, q);
        EXPECT_TRUE(Near(ws.jacobian(), J_ref, kKinematicsRelTol, "J_T_E"));
        EXPECT_TRUE(Near(ws.endpoint_position(),
                         isowrench::EndpointPose(model, kdl, q).translation(), kKinematicsRelTol,
                         "endpoint"));
        EXPECT_TRUE(Near(ws.transducer_rotation(), isowrench::TransducerRotation(model, kdl, q),
                         kKinematicsRelTol, "R_W_T"));
        const isowrench::MuscleTorque mt =
            isowrench::ComputeMuscleTorque(model, kdl, q, mu, activation);
        EXPECT_TRUE(Near(ws.tau(), mt.tau, kKinematicsRelTol, "tau"));
        EXPECT_TRUE(
            Near(ws.muscle_length_gradient().transpose(), mt.dL_dq, kKinematicsRelTol, "dL/dq"));
        EXPECT_NEAR(ws.muscle_length(), mt.length, 1e-15);

        const WrenchResult w = isowrench::SolveStatics(model, ws, stiffness);
        const isowrench::WrenchEvaluation ref =
            isowrench::EvaluateWrench(model, q, model.muscle(mu).name, activation);
        // Near-singular postures may fall on either side of the two solvers' rank rules
        // (Cholesky pivots vs eigenvalues); compare where the reference is clearly regular.
        if (ref.statics.status != StaticsStatus::kOk || ref.statics.k_condition > 1e10) continue;
        ++compared_wrenches;
        EXPECT_EQ(w.status, StaticsStatus::kOk);
        EXPECT_EQ(w.self_motion_count, 0);
        // Two backward-stable solves of K dtheta = tau differ by O(cond(K) eps) relative.
        const double tol = std::max(kKinematicsRelTol, 64 * kEps * ref.statics.k_condition);
        EXPECT_TRUE(Near(w.wrench, ref.statics.wrench, tol, "W"));
        EXPECT_TRUE(Near(ws.dtheta(), ref.statics.dtheta, tol, "dtheta"));
      }
    }
    EXPECT_GT(compared_wrenches, kPosturesPerModel / 2) << "too few regular postures compared";
  }
}

// The one-posture sin/cos (four joints per vector, joints beyond the reduction's range one by
// one with std::sin / std::cos): quadrant boundaries, negative and huge angles, mixed within
// one vector, against KDL.
TEST(FastPath, JacobianEqualsKdlAtQuadrantBoundariesAndHugeAngles) {
  const std::vector<double> angles = {0.0, kPi / 4,  kPi / 2, -kPi / 2,   kPi - 1e-9, -kPi,
                                      7.0, -123.456, 99999.5, 1e5 + 0.25, -2.5e6,     1e12};
  for (const Case& c : AllModels()) {
    SCOPED_TRACE(c.label);
    const Model& model = c.model;
    Data ws(model);
    isowrench::Data kdl(model);
    for (size_t a = 0; a < angles.size(); ++a) {
      Eigen::VectorXd q(model.dof_count());
      for (int i = 0; i < model.dof_count(); ++i) {
        q[i] = model.joint(i).type == isowrench::JointType::kPrismatic
                   ? 0.001 * static_cast<double>(i)
                   : angles[(a + static_cast<size_t>(3 * i)) % angles.size()];
      }
      SCOPED_TRACE("first angle " + std::to_string(angles[a]));
      ASSERT_TRUE(isowrench::ComputeKinematics(model, ws, q, 0, 1.0));
      EXPECT_TRUE(Near(ws.jacobian(), isowrench::EndpointJacobian(model, kdl, q), kKinematicsRelTol,
                       "J_T_E"));
      EXPECT_TRUE(Near(ws.endpoint_position(), isowrench::EndpointPose(model, kdl, q).translation(),
                       kKinematicsRelTol, "endpoint"));
    }
  }
}

TEST(FastPath, ReportsSelfMotionLikeTheReferenceForPlanar4rWithoutJointStiffness) {
  // Four parallel revolute axes seen by a transducer that restrains only x and y (planar_4r
  // releases z rx ry rz): with S_p = 0, K = J^T S_t J has rank 2 of 4, and the flexor
  // (link1 -> link3) drives the self-motion: no equilibrium.
  Model model(isowrench::WithJointStiffness(
      isowrench::WithJointStiffness(
          isowrench::WithJointStiffness(
              isowrench::WithJointStiffness(
                  isowrench::ReadUrdfFile(std::string(ISOWRENCH_TEST_URDF_DIR) + "/planar_4r.urdf"),
                  "j1", 0),
              "j2", 0),
          "j3", 0),
      "j4", 0));
  Data ws(model);
  const Eigen::VectorXd q = model.nominal_posture();
  const WrenchResult w = isowrench::Evaluate(model, ws, q, 0, model.model_stiffness());
  const isowrench::WrenchEvaluation ref = isowrench::EvaluateWrench(model, q, model.muscle(0).name);
  EXPECT_EQ(ref.statics.status, StaticsStatus::kSelfMotion);
  EXPECT_EQ(w.status, StaticsStatus::kSelfMotion);
  ASSERT_GE(w.self_motion_count, 1);
  ASSERT_EQ(w.self_motion_count, ref.statics.self_motion.cols());
  EXPECT_TRUE(w.wrench.isZero(0.0));
  // Bases of a repeated (zero) eigenvalue are not unique: compare the projectors N N^T, and
  // check K N = 0 on the fast basis directly.
  const Eigen::MatrixXd N = ws.self_motion();
  EXPECT_TRUE(Near(N * N.transpose(), ref.statics.self_motion * ref.statics.self_motion.transpose(),
                   1e-9, "null-space projector"));
  const Eigen::VectorXd s_t = model.model_stiffness().s_t;
  const Eigen::MatrixXd K = ws.jacobian().transpose() * s_t.asDiagonal() * ws.jacobian();
  EXPECT_LT((K * N).norm(), 1e-9 * K.norm());
}

TEST(FastPath, StraightKneeSingularKNotExcitedGivesTheUniqueWrench) {
  // 6-dof rat with the knee straight (knee_rz = 0): hip_rx and knee_rx turn about the same line
  // (the femur-tibia axis) and neither has a spring, so K is singular with self-motion
  // n = (hip_rx - knee_rx)/sqrt(2). Both joints see the same muscle moment about that line, so
  // n . tau = 0: the self-motion is not excited and W is unique.
  Model model =
      Model::FromUrdfFile(std::string(ISOWRENCH_TEST_URDF_DIR) + "/rat_hindlimb_6dof.urdf");
  Eigen::VectorXd q = model.nominal_posture();
  q[model.JointIndex("knee_rz")] = 0.0;
  q[model.JointIndex("hip_ry")] = 0.3;
  Data ws(model);
  const StiffnessSet stiffness = model.model_stiffness();
  const WrenchResult w = isowrench::Evaluate(model, ws, q, 0, stiffness);
  ASSERT_EQ(w.status, StaticsStatus::kSelfMotionHeld);
  ASSERT_EQ(w.self_motion_count, 1);
  const int hip_rx = model.JointIndex("hip_rx"), knee_rx = model.JointIndex("knee_rx");
  Eigen::VectorXd expected_n = Eigen::VectorXd::Zero(model.dof_count());
  expected_n[hip_rx] = 1.0 / std::sqrt(2.0);
  expected_n[knee_rx] = -1.0 / std::sqrt(2.0);
  const Eigen::VectorXd n = ws.self_motion().col(0);
  EXPECT_TRUE(Near(n.cwiseAbs(), expected_n.cwiseAbs(), 1e-9, "|self-motion|"));
  EXPECT_LT(std::abs(n[hip_rx] + n[knee_rx]), 1e-9);
  EXPECT_LT(std::abs(n.dot(ws.tau())), 1e-12 * ws.tau().norm());

  // Equilibrium: J^T W + S_p dtheta = tau (MODEL.md identity 3).
  const Eigen::VectorXd residual =
      ws.jacobian().transpose() * w.wrench + stiffness.s_p.cwiseProduct(ws.dtheta()) - ws.tau();
  EXPECT_LT(residual.norm(), 1e-9 * ws.tau().norm());

  // Independent check: any spring on hip_rx makes K regular without changing W (the spring can
  // sit at a solution with hip_rx displacement 0, which exists because n has a hip_rx entry).
  for (double k : {1e-3, 1.0, 1e3}) {
    StiffnessSet held = stiffness;
    held.s_p[hip_rx] = k;
    const WrenchResult regular = isowrench::SolveStatics(model, ws, held);
    ASSERT_EQ(regular.status, StaticsStatus::kOk) << "hip_rx stiffness " << k;
    EXPECT_TRUE(Near(w.wrench, regular.wrench, 1e-8, "W vs W with hip_rx spring"));
  }
  // And the KDL reference path says the same.
  const isowrench::WrenchEvaluation ref = isowrench::EvaluateWrench(model, q, "GP");
  EXPECT_EQ(ref.statics.status, StaticsStatus::kSelfMotionHeld);
  EXPECT_TRUE(Near(w.wrench, ref.statics.wrench, 1e-9, "W vs reference"));
}

TEST(FastPath, RawMatrixSolveSeparatesHeldAndExcitedSelfMotion) {
  // Two identical Jacobian columns without springs: null(K) = (e0 - e1)/sqrt(2).
  isowrench::Matrix6Xd J(6, 3);
  J << 1, 1, 0, 0, 0, 1, 2, 2, 0, 0, 0, 3, 1, 1, 1, 0, 0, 0;
  const isowrench::Vector6d s_t = isowrench::Vector6d::Constant(10.0);
  const Eigen::VectorXd s_p = Eigen::VectorXd::Zero(3);
  Data ws(3);
  Eigen::VectorXd tau(3);
  tau << 0.7, 0.7, -0.2;  // n . tau = 0: held
  WrenchResult held = isowrench::SolveStatics(ws, J, s_t, s_p, tau);
  EXPECT_EQ(held.status, StaticsStatus::kSelfMotionHeld);
  EXPECT_EQ(held.self_motion_count, 1);
  // The same answer as folding the two joints into one column with torque 0.7 (independent).
  isowrench::Matrix6Xd J2(6, 2);
  J2.col(0) = J.col(0);
  J2.col(1) = J.col(2);
  const Eigen::MatrixXd K2 = J2.transpose() * s_t.asDiagonal() * J2;
  const Eigen::Vector2d tau2(0.7, -0.2);
  const Eigen::Vector2d dtheta2 = K2.ldlt().solve(tau2);
  const isowrench::Vector6d W2 = s_t.cwiseProduct(J2 * dtheta2);
  EXPECT_TRUE(Near(held.wrench, W2, 1e-12, "W vs folded joints"));

  tau << 0.7, 0.2, -0.2;  // excites the self-motion: no equilibrium
  WrenchResult excited = isowrench::SolveStatics(ws, J, s_t, s_p, tau);
  EXPECT_EQ(excited.status, StaticsStatus::kSelfMotion);
  EXPECT_TRUE(excited.wrench.isZero(0.0));

  // Bad input is a status, not an exception.
  Eigen::VectorXd bad_s_p = s_p;
  bad_s_p[1] = -1.0;
  EXPECT_EQ(isowrench::SolveStatics(ws, J, s_t, bad_s_p, tau).status, StaticsStatus::kInvalidInput);
  tau[0] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(isowrench::SolveStatics(ws, J, s_t, s_p, tau).status, StaticsStatus::kInvalidInput);
  EXPECT_EQ(isowrench::SolveStatics(ws, J.leftCols(2), s_t, s_p, tau).status,
            StaticsStatus::kInvalidInput);
}

// The solve's input check reads four entries per vector and the rest one by one: every dof
// count up to 20 (past 16, the old fixed limit), a bad value at every position of s_t, s_p and tau
// (NaN, +inf, -inf; a negative stiffness), each alone, is kInvalidInput; the untouched input is
// solved.
TEST(FastPath, EveryBadSolveInputEntryIsInvalidForEveryDofCount) {
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (int m = 1; m <= 20; ++m) {
    Data ws(m);
    isowrench::Matrix6Xd J(6, m);
    for (int c = 0; c < m; ++c)
      for (int r = 0; r < 6; ++r) J(r, c) = u(rng);
    isowrench::Vector6d s_t;
    s_t << 1e4, 2e4, 3e4, 10, 20, 30;
    Eigen::VectorXd s_p = Eigen::VectorXd::Constant(m, 5.0);
    Eigen::VectorXd tau(m);
    for (int i = 0; i < m; ++i) tau[i] = u(rng);
    ASSERT_NE(isowrench::SolveStatics(ws, J, s_t, s_p, tau).status, StaticsStatus::kInvalidInput)
        << "m = " << m;
    for (const double bad : {nan, inf, -inf, -1.0}) {
      for (int r = 0; r < 6; ++r) {
        isowrench::Vector6d t = s_t;
        t[r] = bad;
        EXPECT_EQ(isowrench::SolveStatics(ws, J, t, s_p, tau).status, StaticsStatus::kInvalidInput)
            << "m = " << m << ", s_t[" << r << "] = " << bad;
      }
      for (int i = 0; i < m; ++i) {
        Eigen::VectorXd p = s_p;
        p[i] = bad;
        EXPECT_EQ(isowrench::SolveStatics(ws, J, s_t, p, tau).status, StaticsStatus::kInvalidInput)
            << "m = " << m << ", s_p[" << i << "] = " << bad;
        if (bad == -1.0) continue;  // a negative torque is fine
        Eigen::VectorXd t = tau;
        t[i] = bad;
        EXPECT_EQ(isowrench::SolveStatics(ws, J, s_t, s_p, t).status, StaticsStatus::kInvalidInput)
            << "m = " << m << ", tau[" << i << "] = " << bad;
      }
    }
  }
}

// The batch runs the lane kernel (four evaluations per SIMD register), which sums in the same
// order as the scalar path but may fuse multiply-adds differently. Statuses and self-motion
// counts must be identical. Wrenches must agree to the accuracy a backward-stable solve of K
// promises, 16 m eps cond(K) relative to the largest entry (at least 1e-12): the stiffness sets
// here reach cond(K) ~ 1e10, where a one-ulp change in K moves W by ~1e-6. A wrong index, lane
// or sign gives O(1) differences.
::testing::AssertionResult BatchMatchesSingle(const Model& model, const Eigen::MatrixXd& postures,
                                              const std::vector<StiffnessSet>& sets,
                                              const std::vector<WrenchResult>& batch,
                                              double activation, const std::string& label) {
  Data ws(model);
  if (batch.size() != static_cast<size_t>(postures.cols()) * sets.size()) {
    return ::testing::AssertionFailure() << label << ": " << batch.size() << " results";
  }
  for (int p = 0; p < postures.cols(); ++p) {
    for (size_t s = 0; s < sets.size(); ++s) {
      const WrenchResult single =
          isowrench::Evaluate(model, ws, postures.col(p), 0, sets[s], activation);
      const WrenchResult& b = batch[static_cast<size_t>(p) * sets.size() + s];
      const std::string where =
          label + ", posture " + std::to_string(p) + ", set " + std::to_string(s);
      if (b.status != single.status || b.self_motion_count != single.self_motion_count) {
        return ::testing::AssertionFailure() << where << ": status " << static_cast<int>(b.status)
                                             << " vs " << static_cast<int>(single.status);
      }
      if (!b.wrench.allFinite())
        return ::testing::AssertionFailure() << where << ": non-finite wrench";
      double tolerance = kKinematicsRelTol;
      if (single.status == StaticsStatus::kOk) {
        const Eigen::MatrixXd J = ws.jacobian();
        const Eigen::MatrixXd K = J.transpose() * sets[s].s_t.asDiagonal() * J +
                                  Eigen::MatrixXd(sets[s].s_p.asDiagonal());
        const Eigen::VectorXd lambda =
            Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(K).eigenvalues();
        const double cond = lambda.maxCoeff() / lambda.minCoeff();
        tolerance = std::max(tolerance, 16.0 * static_cast<double>(K.rows()) * kEps * cond);
      }
      auto near = Near(b.wrench, single.wrench, tolerance, where);
      if (!near) return near;
    }
  }
  return ::testing::AssertionSuccess();
}

TEST(FastPath, BatchEqualsSingleEvaluationsOnBothThreads) {
  Model model =
      Model::FromUrdfFile(std::string(ISOWRENCH_TEST_URDF_DIR) + "/rat_hindlimb_5dof_base.urdf");
  std::mt19937 rng(7);
  constexpr int kPostures = 701;  // many units for both threads, and a tail of one posture
  Eigen::MatrixXd postures(model.dof_count(), kPostures);
  for (int p = 0; p < kPostures; ++p) postures.col(p) = RandomPosture(model, rng);
  std::vector<StiffnessSet> sets;
  for (double ratio : {1.0, 1e-2, 1e-4}) {
    StiffnessSet s = model.model_stiffness();
    s.s_t.tail<3>() *= ratio;
    sets.push_back(s);
  }
  std::vector<WrenchResult> batch;
  long last_done = -1, last_total = -1;
  isowrench::BatchOptions options;
  options.threads = 2;
  options.progress = [&](long done, long total) {
    EXPECT_GE(done, last_done);  // monotone on the calling thread
    last_done = done;
    last_total = total;
  };
  isowrench::EvaluateBatch(model, postures, 0, sets, batch, 0.8, options);
  const long evaluations = kPostures * static_cast<long>(sets.size());
  EXPECT_EQ(last_done, evaluations);
  EXPECT_EQ(last_total, evaluations);
  EXPECT_TRUE(BatchMatchesSingle(model, postures, sets, batch, 0.8, "rat_hindlimb_5dof_base"));
}

// Every model, both lane layouts (four postures per register; one posture and four stiffness
// sets per register), padded lanes, and the lanes the kernel hands back to the scalar path:
// a singular K (no S_p; no S_t at all) and an invalid set.
TEST(FastPath, BatchLanesEqualSingleOnEveryModelIncludingUndecidedLanes) {
  bool saw_self_motion = false, saw_invalid = false;
  for (const Case& c : AllModels()) {
    const Model& model = c.model;
    SCOPED_TRACE(c.label);
    std::mt19937 rng(11);
    constexpr int kPostures = 13;  // 3 groups of 4 and a tail of 1
    Eigen::MatrixXd postures(c.model.dof_count(), kPostures);
    for (int p = 0; p < kPostures; ++p) postures.col(p) = RandomPosture(c.model, rng);
    postures.col(5).setZero();  // straight chain: a singular K without joint stiffness
    std::vector<StiffnessSet> sets;
    sets.push_back(model.model_stiffness());
    StiffnessSet soft = model.model_stiffness();
    soft.s_t.tail<3>() *= 1e-3;
    sets.push_back(soft);
    StiffnessSet no_joints = model.model_stiffness();
    no_joints.s_p.setZero();
    sets.push_back(no_joints);
    StiffnessSet nothing = no_joints;
    nothing.s_t.setZero();
    sets.push_back(nothing);
    StiffnessSet negative = model.model_stiffness();
    negative.s_t[2] = -1.0;
    sets.push_back(negative);
    for (int threads : {1, 2}) {
      isowrench::BatchOptions options;
      options.threads = threads;
      // A reused output full of stale results: EvaluateBatch must write every entry.
      WrenchResult stale;
      stale.wrench.setConstant(std::nan(""));
      stale.status = StaticsStatus::kOk;
      std::vector<WrenchResult> batch(static_cast<size_t>(kPostures) * sets.size(), stale);
      isowrench::EvaluateBatch(model, postures, 0, sets, batch, 0.7, options);
      EXPECT_TRUE(BatchMatchesSingle(model, postures, sets, batch, 0.7, "postures x sets"));
      for (const WrenchResult& w : batch) {
        saw_self_motion |=
            w.status == StaticsStatus::kSelfMotion || w.status == StaticsStatus::kSelfMotionHeld;
        saw_invalid |= w.status == StaticsStatus::kInvalidInput;
      }
    }
    // One posture, 11 sets: the sets go across the lanes (two full groups and a padded one).
    std::vector<StiffnessSet> many;
    for (int k = 0; k < 11; ++k) {
      StiffnessSet s = k % 5 == 4 ? sets[2] : model.model_stiffness();
      s.s_t.tail<3>() *= std::pow(10.0, -0.4 * k);
      many.push_back(s);
    }
    many[7] = negative;
    WrenchResult stale;
    stale.wrench.setConstant(std::nan(""));
    stale.status = StaticsStatus::kOk;
    std::vector<WrenchResult> batch(many.size(), stale);
    isowrench::EvaluateBatch(model, postures.leftCols(1), 0, many, batch, 1.0);
    EXPECT_TRUE(
        BatchMatchesSingle(model, postures.leftCols(1), many, batch, 1.0, "one posture x sets"));
  }
  EXPECT_TRUE(saw_self_motion);  // the scalar fallback ran
  EXPECT_TRUE(saw_invalid);
}

// The lane sin/cos: quadrant boundaries, negative angles, and angles beyond the reduction's
// range (handed to std::sin / std::cos) give the scalar path's wrench.
TEST(FastPath, BatchLaneAnglesAcrossQuadrantsAndHugeAnglesEqualSingle) {
  Model model = Model::FromUrdfFile(std::string(ISOWRENCH_TEST_URDF_DIR) + "/planar_2r.urdf");
  const std::vector<double> angles = {0.0,        kPi / 4,     kPi / 2, -kPi / 2,       kPi - 1e-9,
                                      -kPi,       3 * kPi / 2, 7.0,     -123.456,       99999.5,
                                      1e5 + 0.25, -2.5e6,      1e12,    kPi / 4 - 1e-15};
  Eigen::MatrixXd postures(2, static_cast<int>(angles.size()));
  for (size_t i = 0; i < angles.size(); ++i) {
    postures(0, static_cast<int>(i)) = angles[i];
    postures(1, static_cast<int>(i)) = angles[angles.size() - 1 - i] + 0.3;
  }
  std::vector<StiffnessSet> sets = {model.model_stiffness()};
  std::vector<WrenchResult> batch;
  isowrench::EvaluateBatch(model, postures, 0, sets, batch);
  EXPECT_TRUE(BatchMatchesSingle(model, postures, sets, batch, 1.0, "planar_2r angles"));
}

TEST(FastPath, BatchRejectsBadInputNamingIt) {
  Model model = Model::FromUrdfFile(std::string(ISOWRENCH_TEST_URDF_DIR) + "/planar_2r.urdf");
  std::vector<WrenchResult> out;
  std::vector<StiffnessSet> sets = {model.model_stiffness()};
  using ::testing::HasSubstr;
  EXPECT_THAT([&] { isowrench::EvaluateBatch(model, Eigen::MatrixXd::Zero(3, 4), 0, sets, out); },
              ::testing::ThrowsMessage<isowrench::Error>(HasSubstr("3 rows")));
  EXPECT_THAT([&] { isowrench::EvaluateBatch(model, Eigen::MatrixXd::Zero(2, 4), 5, sets, out); },
              ::testing::ThrowsMessage<isowrench::Error>(HasSubstr("muscle index 5")));
  Eigen::MatrixXd nan_postures = Eigen::MatrixXd::Zero(2, 4);
  nan_postures(1, 2) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THAT([&] { isowrench::EvaluateBatch(model, nan_postures, 0, sets, out); },
              ::testing::ThrowsMessage<isowrench::Error>(HasSubstr("posture 2 has a non-finite")));
  // Infinities of either sign, the largest finite number (accepted), and postures that are a
  // block of a taller matrix (columns not contiguous).
  Eigen::MatrixXd tall = Eigen::MatrixXd::Zero(5, 4);
  tall(1, 3) = -std::numeric_limits<double>::infinity();
  EXPECT_THAT([&] { isowrench::EvaluateBatch(model, tall.topRows(2), 0, sets, out); },
              ::testing::ThrowsMessage<isowrench::Error>(HasSubstr("posture 3 has a non-finite")));
  tall(1, 3) = std::numeric_limits<double>::max();
  tall(4, 0) = std::numeric_limits<double>::infinity();  // outside the block
  EXPECT_NO_THROW(isowrench::EvaluateBatch(model, tall.topRows(2), 0, sets, out));
  Eigen::MatrixXd inf_postures = Eigen::MatrixXd::Zero(2, 4);
  inf_postures(0, 1) = std::numeric_limits<double>::infinity();
  EXPECT_THAT([&] { isowrench::EvaluateBatch(model, inf_postures, 0, sets, out); },
              ::testing::ThrowsMessage<isowrench::Error>(HasSubstr("posture 1 has a non-finite")));
  EXPECT_THAT([] { Data ws(0); },
              ::testing::ThrowsMessage<isowrench::Error>(HasSubstr("dof count 0")));
}

TEST(FastPath, CoincidentPathPointsGiveInvalidInputNotNaN) {
  // Origin and insertion at the same point of the same link: the segment has no direction at
  // any posture (ComputeMuscleTorque throws; the hot path returns a status instead).
  isowrench::LimbDescription d =
      isowrench::ReadUrdfFile(std::string(ISOWRENCH_TEST_URDF_DIR) + "/planar_2r.urdf");
  d.muscles[1].path[0] = {"forearm", Eigen::Vector3d(0.04, 0.01, 0)};
  Model model(d);
  Data ws(model);
  const WrenchResult w =
      isowrench::Evaluate(model, ws, model.nominal_posture(), 1, model.model_stiffness());
  EXPECT_EQ(w.status, StaticsStatus::kInvalidInput);
  EXPECT_TRUE(w.wrench.allFinite());
  // The lane kernel flags the same lanes (here all five postures, set by set).
  Eigen::MatrixXd postures(2, 5);
  for (int p = 0; p < 5; ++p) postures.col(p) = model.nominal_posture() * (1.0 + 0.1 * p);
  std::vector<WrenchResult> batch;
  isowrench::EvaluateBatch(model, postures, 1, {model.model_stiffness(), model.model_stiffness()},
                           batch);
  ASSERT_EQ(batch.size(), 10u);
  for (const WrenchResult& b : batch) {
    EXPECT_EQ(b.status, StaticsStatus::kInvalidInput);
    EXPECT_TRUE((b.wrench.array() == 0.0).all());
  }
}

}  // namespace
