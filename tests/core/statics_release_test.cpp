// Tests of include/isowrench/statics.hpp, part 2: the release equivalence of docs/model.md
// "Released dofs", the base-compliance limit and the 6-dof knee's self-motion.
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

// ---- Released dofs: row deletion == explicit zero-stiffness joint --------------------------

// Add a joint between the tibia and a new "transducer_mount" link at the endpoint, turning
// (revolute) or sliding (prismatic) along `axis_world` (world axes, at posture q), role
// kRelease, zero stiffness, and move the transducer to the new link (endpoint at its origin).
LimbDescription WithExplicitRelease(const Model& model, const Eigen::VectorXd& q,
                                    isowrench::JointType type, const Eigen::Vector3d& axis_world) {
  LimbDescription d = model.description();
  Data ws(model);
  const Eigen::Matrix3d R_W_tibia = isowrench::EndpointPose(model, ws, q).linear();
  isowrench::JointSpec j;
  j.name = "release";
  j.type = type;
  j.parent_link = d.transducer.link;
  j.child_link = "transducer_mount";
  j.origin = Eigen::Isometry3d::Identity();
  j.origin.translation() = d.transducer.endpoint;
  j.axis = R_W_tibia.transpose() * axis_world;  // in the joint frame = tibia axes
  j.role = isowrench::JointRole::kRelease;
  j.stiffness = 0.0;
  d.joints.push_back(j);
  d.links.push_back("transducer_mount");
  d.transducer.link = "transducer_mount";
  d.transducer.endpoint = Eigen::Vector3d::Zero();
  return d;
}

struct ReleaseCase {
  const char* dof;
  isowrench::JointType type;
  Eigen::Vector3d axis;
};

TEST(ReleasedDofs, RowDeletionEqualsExplicitZeroStiffnessJoint) {
  const Model limb = LoadModel("rat_hindlimb_5dof.urdf");
  std::mt19937 rng(404);
  std::vector<Eigen::VectorXd> postures = {limb.nominal_posture(), RandomPosture(limb, rng)};
  const std::vector<ReleaseCase> cases = {
      {"rz", isowrench::JointType::kRevolute, Eigen::Vector3d::UnitZ()},
      {"x", isowrench::JointType::kPrismatic, Eigen::Vector3d::UnitX()}};
  for (const ReleaseCase& c : cases) {
    for (const Eigen::VectorXd& q : postures) {
      for (const Vector6d& s_t : SomeTransducerStiffnesses()) {
        const Model deleted(isowrench::WithTransducerStiffness(
            isowrench::WithReleasedDofs(limb.description(), {c.dof}), s_t));
        const Model joint(
            isowrench::WithTransducerStiffness(WithExplicitRelease(limb, q, c.type, c.axis), s_t));
        ASSERT_EQ(joint.dof_count(), 6);
        Eigen::VectorXd q6(6);
        q6 << q, 0.0;
        const auto a = EvaluateWrench(deleted, q, "GP");
        const auto b = EvaluateWrench(joint, q6, "GP");
        ASSERT_EQ(a.statics.status, StaticsStatus::kOk) << a.statics.message;
        ASSERT_EQ(b.statics.status, StaticsStatus::kOk) << b.statics.message;
        // The muscle does not cross the release joint.
        EXPECT_NEAR(b.tau[5], 0.0, 1e-15 * b.tau.norm());
        const double tol = SolveTolerance(StiffnessAtJoints(a.jacobian, a.s_t, a.s_p)) +
                           SolveTolerance(StiffnessAtJoints(b.jacobian, b.s_t, b.s_p));
        EXPECT_TRUE(MatricesNear(b.statics.wrench, a.statics.wrench, 0.0, tol))
            << "release " << c.dof << ", S_t " << s_t.transpose();
      }
    }
  }
}

TEST(ReleasedDofs, ReleaseAboutTheTibiaAxisAllowsSelfMotion) {
  // Paper, Discussion: releasing rotation about the ankle-knee line lets the limb move without
  // loading the transducer (knee_rx turns the tibia about that very line).
  const Model limb = LoadModel("rat_hindlimb_5dof.urdf");
  const Eigen::VectorXd q = limb.nominal_posture();
  Data ws(limb);
  const Eigen::Vector3d tibia_axis = isowrench::EndpointPose(limb, ws, q).linear().col(0);
  const Model joint(WithExplicitRelease(limb, q, isowrench::JointType::kRevolute, tibia_axis));
  Eigen::VectorXd q6(6);
  q6 << q, 0.0;
  const auto eval = EvaluateWrench(joint, q6, "GP");
  EXPECT_TRUE(eval.statics.status == StaticsStatus::kSelfMotion ||
              eval.statics.status == StaticsStatus::kSelfMotionHeld)
      << isowrench::StatusName(eval.statics.status);
  ASSERT_EQ(eval.statics.self_motion.cols(), 1);
  // The self-motion is knee_rx against the release joint, in equal and opposite amounts.
  const Eigen::VectorXd n = eval.statics.self_motion.col(0);
  EXPECT_NEAR(std::abs(n[joint.JointIndex("knee_rx")]), std::sqrt(0.5), 1e-9);
  EXPECT_NEAR(n[joint.JointIndex("knee_rx")] + n[joint.JointIndex("release")], 0.0, 1e-9);
  EXPECT_TRUE(AllFinite(eval.statics.wrench));
  EXPECT_TRUE(AllFinite(eval.statics.dtheta));
}

// ---- Base compliance: soft base -> femur-removed wrench ----------------------------------

TEST(BaseCompliance, FemurRemovedWrenchIsThePullOnTheTibia) {
  // W = [F u; (p_ins - p_E) x F u], u from the insertion toward the origin: the tibia, held
  // only by the transducer, passes the muscle's pull on to it.
  const Model model = LoadModel("rat_hindlimb_5dof.urdf");
  Data ws(model);
  const Eigen::VectorXd q = model.nominal_posture();
  const Eigen::Vector3d o(0.01267, -0.010403, -0.00478);
  const Eigen::Vector3d p =
      isowrench::PointPosition(model, ws, q, "tibia", Eigen::Vector3d(0.0156, -0.00452, -0.00378));
  const Eigen::Vector3d e = isowrench::EndpointPose(model, ws, q).translation();
  const Eigen::Vector3d f = 2.3 * (o - p).normalized();
  Vector6d w;
  w << f, (p - e).cross(f);
  EXPECT_TRUE(MatricesNear(isowrench::FemurRemovedWrench(model, q, "GP"), w, 0.0, 1e-12));
  EXPECT_TRUE(MatricesNear(isowrench::FemurRemovedWrench(model, q, "GP", 0.5), (0.5 * w).eval(),
                           0.0, 1e-12));
}

TEST(BaseCompliance, SoftBaseTendsToFemurRemovedWrench) {
  // With the base springs k far below S_t, the femur can only pass a force ~ k * (tibia
  // displacement) to the tibia: the error to the femur-removed wrench is linear in k, so each
  // factor 100 in k must shrink it by about 100 (asserted: by more than 10).
  const Model model = LoadModel("rat_hindlimb_5dof_base.urdf");
  const Vector6d w_fr = isowrench::FemurRemovedWrench(model, model.nominal_posture(), "GP");
  double previous = std::numeric_limits<double>::infinity();
  for (double k_base : {1e3, 1e1, 1e-1}) {
    const Model m(isowrench::WithTransducerStiffness(
        isowrench::WithBaseStiffness(model.description(), k_base), Vector6d::Constant(1e7)));
    const auto eval = EvaluateWrench(m, m.nominal_posture(), "GP");
    ASSERT_EQ(eval.statics.status, StaticsStatus::kOk) << eval.statics.message;
    const double error = (eval.statics.wrench - w_fr).norm();
    EXPECT_LT(error, 0.1 * previous) << "k_base = " << k_base;
    RecordProperty("error_at_k_base_" + std::to_string(k_base), std::to_string(error));
    previous = error;
  }
  EXPECT_LT(previous, 1e-4 * w_fr.norm());
}

TEST(BaseCompliance, FreeBaseHoldsTheFemurSelfMotionAndGivesFemurRemovedWrench) {
  // k = 0: hip centre free, tibia fixed by the transducer; the femur can swing about the knee
  // (2 dof) without changing the muscle length, so the self-motion is held and W is exactly the
  // femur-removed wrench.
  const Model model(
      isowrench::WithBaseStiffness(LoadDescription("rat_hindlimb_5dof_base.urdf"), 0.0));
  const auto eval = EvaluateWrench(model, model.nominal_posture(), "GP");
  EXPECT_EQ(eval.statics.status, StaticsStatus::kSelfMotionHeld) << eval.statics.message;
  EXPECT_EQ(eval.statics.self_motion.cols(), 2);
  EXPECT_TRUE(AllFinite(eval.statics.wrench));
  EXPECT_TRUE(MatricesNear(eval.statics.wrench,
                           isowrench::FemurRemovedWrench(model, model.nominal_posture(), "GP"), 0.0,
                           1e-8));
}

// ---- 6-dof knee: femur axial rotation ----------------------------------------------------

// Femur axial rotation at the nominal posture (derived by hand): turning the femur by w about
// its own axis (hip_rx) leaves the knee in place; the tibia stays put if the knee turns by -w
// about the femur axis. In femur axes the knee's ry axis is Rz(105)y = (-s, c, 0) and its rx
// axis Rz(105)x = (c, s, 0) (c = cos 105, s = sin 105), so b (-s, c) + r (c, s) = (-w, 0) gives
// r = -w c, b = w s: direction (hip_rx, knee_ry, knee_rx) = (1, s, -c) / sqrt(2),
// knee_ry / knee_rx = -tan(105 deg) = 3.732.
Eigen::VectorXd FemurAxialRotation(const Model& m) {
  Eigen::VectorXd n = Eigen::VectorXd::Zero(m.dof_count());
  n[m.JointIndex("hip_rx")] = 1.0;
  n[m.JointIndex("knee_ry")] = std::sin(Deg(105));
  n[m.JointIndex("knee_rx")] = -std::cos(Deg(105));
  return n / std::sqrt(2.0);
}

TEST(SixDofKnee, WithoutAbductionStiffnessFemurRotationIsASelfMotion) {
  const Model model(
      isowrench::WithJointStiffness(LoadDescription("rat_hindlimb_6dof.urdf"), "knee_ry", 0.0));
  const Eigen::VectorXd q = model.nominal_posture();
  const auto eval = EvaluateWrench(model, q, "GP");
  const StaticsResult& r = eval.statics;
  EXPECT_TRUE(r.status == StaticsStatus::kSelfMotion || r.status == StaticsStatus::kSelfMotionHeld)
      << isowrench::StatusName(r.status);
  EXPECT_FALSE(r.message.empty());
  EXPECT_EQ(r.k_rank, 5);
  ASSERT_EQ(r.self_motion.rows(), 6);
  ASSERT_EQ(r.self_motion.cols(), 1);
  Eigen::VectorXd n = r.self_motion.col(0);
  const Eigen::VectorXd expected = FemurAxialRotation(model);
  if (n.dot(expected) < 0) n = -n;
  EXPECT_TRUE(MatricesNear(n, expected, 1e-9));
  EXPECT_NEAR(n[model.JointIndex("knee_ry")] / n[model.JointIndex("knee_rx")], -std::tan(Deg(105)),
              1e-8);
  // The mechanism check behind it: J n = 0.
  EXPECT_TRUE(MatricesNear((eval.jacobian * expected).eval(), Vector6d::Zero(), 1e-14));
  EXPECT_TRUE(AllFinite(r.wrench));
  EXPECT_TRUE(AllFinite(r.dtheta));
  EXPECT_TRUE(AllFinite(r.self_motion));
  EXPECT_TRUE(AllFinite(r.k_eigenvalues));
  // The muscle runs from ground to the tibia, which does not move: tau . n = 0 up to rounding,
  // so the self-motion is held and W is the 5-dof wrench (range(J6) = range(J5)).
  const double excitation = std::abs(expected.dot(eval.tau)) / eval.tau.norm();
  ASSERT_LT(excitation, 1e-12);
  EXPECT_EQ(r.status, StaticsStatus::kSelfMotionHeld);
  const Model five = LoadModel("rat_hindlimb_5dof.urdf");
  const auto e5 = EvaluateWrench(five, five.nominal_posture(), "GP");
  const double tol = SolveTolerance(StiffnessAtJoints(e5.jacobian, e5.s_t, e5.s_p));
  if (r.status == StaticsStatus::kSelfMotionHeld) {
    EXPECT_TRUE(MatricesNear(r.wrench, e5.statics.wrench, 0.0, 100 * tol));
  } else {
    EXPECT_TRUE(MatricesNear(r.wrench, Vector6d::Zero(), 0.0));
  }
  EXPECT_NE(isowrench::DescribeJointMotion(model, n).find("knee_ry"), std::string::npos);
}

TEST(SixDofKnee, AbductionStiffnessGivesTheFiveDofWrench) {
  // With a spring k on knee_ry, the energy along the self-motion n (J n = 0, tau . n = 0) is
  // only the spring's; adding a multiple of n to any displacement zeroes knee_ry without
  // changing J dtheta or tau . dtheta, so the minimum has knee_ry = 0: the 5-dof solution,
  // for every k > 0. The only difference is rounding, bounded by the solve tolerance of K.
  const Model five = LoadModel("rat_hindlimb_5dof.urdf");
  const auto e5 = EvaluateWrench(five, five.nominal_posture(), "GP");
  ASSERT_EQ(e5.statics.status, StaticsStatus::kOk);
  const LimbDescription six = LoadDescription("rat_hindlimb_6dof.urdf");
  for (double k : {1e-2, 1.0, 1e2, 1e4}) {
    const Model model(isowrench::WithJointStiffness(six, "knee_ry", k));
    const auto eval = EvaluateWrench(model, model.nominal_posture(), "GP");
    ASSERT_EQ(eval.statics.status, StaticsStatus::kOk) << eval.statics.message;
    EXPECT_TRUE(AllFinite(eval.statics.wrench));
    const double tol = SolveTolerance(StiffnessAtJoints(eval.jacobian, eval.s_t, eval.s_p));
    EXPECT_TRUE(MatricesNear(eval.statics.wrench, e5.statics.wrench, 0.0, tol)) << "k = " << k;
    EXPECT_NEAR(eval.statics.dtheta[model.JointIndex("knee_ry")], 0.0,
                tol * eval.statics.dtheta.norm());
  }
}

// ---- A rotated transducer: the world-axes wrench is R_W_T times the transducer-axes one ------

Eigen::Matrix3d Rpy(double r, double p, double y) {
  return (Eigen::AngleAxisd(y, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(p, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(r, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

// With a balanced transducer, all 6 dofs restrained and S_p = 0, W = pinv(J^T) tau in any axes,
// so the world-axes wrench cannot depend on how the transducer is turned; and in every case the
// world wrench is R_W_T W_T with R_W_T built here from the spec (world axes: the rotation itself;
// link axes: the endpoint link's rotation times it), not read from the result.
TEST(RotatedTransducer, WorldWrenchIsTheRotatedTransducerWrench) {
  const Model aligned = LoadModel("rat_hindlimb_5dof.urdf");
  const Eigen::VectorXd q = aligned.nominal_posture();
  const isowrench::WrenchEvaluation reference = isowrench::EvaluateWrench(aligned, q, "GP");
  ASSERT_TRUE(reference.statics.ok());
  Data ws(aligned);
  const Eigen::Matrix3d R_W_link = isowrench::EndpointPose(aligned, ws, q).linear();
  const Eigen::Matrix3d R = Rpy(0.4, 0.5, -0.3);
  for (bool in_world : {true, false}) {
    SCOPED_TRACE(in_world ? "axes world" : "axes link");
    LimbDescription d = aligned.description();
    d.transducer.rotation = R;
    d.transducer.axes_in_world = in_world;
    const Model turned(d);
    const isowrench::WrenchEvaluation e = isowrench::EvaluateWrench(turned, q, "GP");
    ASSERT_TRUE(e.statics.ok());
    const Eigen::Matrix3d R_W_T = in_world ? R : Eigen::Matrix3d(R_W_link * R);
    Vector6d expected;
    expected << R_W_T * e.statics.wrench.head<3>(), R_W_T * e.statics.wrench.tail<3>();
    const double scale = reference.statics.wrench.norm();
    EXPECT_TRUE(MatricesNear(e.wrench_world, expected, 1e-12 * scale));
    EXPECT_TRUE(MatricesNear(e.wrench_world, reference.wrench_world, 1e-9 * scale));
    // The transducer-axes wrench really is turned (the test would pass trivially otherwise).
    EXPECT_GT((e.statics.wrench - reference.statics.wrench).norm(), 0.05 * scale);
  }
}

}  // namespace
}  // namespace isowrench_test
