// Tests of include/isowrench/statics.hpp: every identity of MODEL.md "Statics", the release
// equivalence of MODEL.md "Released dofs", the base-compliance limit, the 6-dof knee's
// self-motion, closed forms on planar limbs and the small-motion check.
//
// Sign: W is the wrench the limb applies to the transducer, [f; m] (N, N·m), moment about the
// endpoint, in transducer axes (= world axes for every model here).

#include "isowrench/statics.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <Eigen/QR>
#include <cmath>
#include <random>

#include "eigen_compare.hpp"
#include "isowrench/kinematics.hpp"
#include "isowrench/paper.hpp"
#include "test_models.hpp"

namespace isowrench_test {
namespace {

using isowrench::EvaluateWrench;
using isowrench::KinematicsWorkspace;
using isowrench::LimbDescription;
using isowrench::Matrix6Xd;
using isowrench::Model;
using isowrench::SolveStatics;
using isowrench::StaticsResult;
using isowrench::StaticsStatus;
using isowrench::Vector6d;

Vector6d Diag6(double kx, double ky, double kz, double krx, double kry, double krz) {
  Vector6d s;
  s << kx, ky, kz, krx, kry, krz;
  return s;
}

// Transducer stiffnesses used across the identities: balanced, the two presets, a stiff-force /
// soft-moment attachment (paper Fig. 2D) and an anisotropic one with every entry different.
std::vector<Vector6d> SomeTransducerStiffnesses() {
  return {Vector6d::Constant(1e7), isowrench::TransducerPreset("ati-mini40"),
          isowrench::TransducerPreset("jr3"), Diag6(1e7, 1e7, 1e7, 1e3, 1e3, 1e3),
          Diag6(3e6, 2e7, 5e5, 40.0, 900.0, 7.0)};
}

struct Problem {
  Matrix6Xd J;
  Eigen::VectorXd tau;
  Eigen::VectorXd s_p;
};

Problem ProblemAt(const Model& model, const Eigen::VectorXd& q, const std::string& muscle) {
  KinematicsWorkspace ws(model);
  Problem p;
  p.J = isowrench::EndpointJacobian(model, ws, q);
  p.tau = isowrench::ComputeMuscleTorque(model, ws, q, model.MuscleIndex(muscle)).tau;
  p.s_p = model.joint_stiffness();
  return p;
}

Vector6d EffectiveSt(const Model& model) {
  Vector6d s = model.transducer().stiffness;
  for (int d = 0; d < 6; ++d) {
    if (model.transducer().released[d]) s[d] = 0.0;
  }
  return s;
}

// ---- Identity 1: isotropic S_t and S_p = 0  =>  W = pinv(J^T) tau ------------------------

TEST(StaticsIdentities, IsotropicTransducerGivesPseudoinverse) {
  const Model model = LoadModel("rat_hindlimb_5dof.urdf");
  std::mt19937 rng(2024);
  std::vector<Eigen::VectorXd> postures = {model.nominal_posture()};
  for (int k = 0; k < 5; ++k) postures.push_back(RandomPosture(model, rng));
  for (const Eigen::VectorXd& q : postures) {
    const Problem p = ProblemAt(model, q, "GP");
    // Reference: minimum-norm solution of J^T W = tau by a complete orthogonal decomposition.
    const Vector6d w_ref = p.J.transpose().completeOrthogonalDecomposition().solve(p.tau);
    const isowrench::ClassicResult classic =
        isowrench::ClassicWrench(p.J, {{true, true, true, true, true, true}}, p.tau);
    EXPECT_FALSE(classic.square_inverse);
    EXPECT_EQ(classic.rank, 5);
    for (double k : {1e-3, 1.0, 1e7}) {
      const Vector6d s_t = Vector6d::Constant(k);
      const StaticsResult r = SolveStatics(p.J, s_t, Eigen::VectorXd::Zero(5), p.tau);
      ASSERT_EQ(r.status, StaticsStatus::kOk) << r.message;
      const double tol = SolveTolerance(StiffnessAtJoints(p.J, s_t, Eigen::VectorXd::Zero(5)));
      EXPECT_TRUE(MatricesNear(r.wrench, w_ref, 0.0, tol)) << "k = " << k;
      EXPECT_TRUE(MatricesNear(classic.wrench, w_ref, 0.0, tol));
    }
  }
}

TEST(StaticsIdentities, IsotropicRestrainedRowsGivePseudoinverseOnPlanar2r) {
  // 2R: restrained x, y, rz (3 x 2 J_r). Isotropic on the restrained rows, 0 on released rows.
  const Model model = LoadModel("planar_2r.urdf");
  const Problem p = ProblemAt(model, model.nominal_posture(), "biarticular");
  Eigen::Matrix<double, 3, 2> Jr;
  Jr << p.J.row(0), p.J.row(1), p.J.row(5);
  const Eigen::Vector3d wr = Jr.transpose().completeOrthogonalDecomposition().solve(p.tau);
  Vector6d w_ref = Vector6d::Zero();
  w_ref << wr[0], wr[1], 0, 0, 0, wr[2];
  const Vector6d s_t = Diag6(50, 50, 0, 0, 0, 50);
  const StaticsResult r = SolveStatics(p.J, s_t, Eigen::VectorXd::Zero(2), p.tau);
  ASSERT_EQ(r.status, StaticsStatus::kOk) << r.message;
  EXPECT_TRUE(MatricesNear(r.wrench, w_ref, 0.0, 1e-12));
  const auto classic = isowrench::ClassicWrench(p.J, {{true, true, false, false, false, true}}, p.tau);
  EXPECT_TRUE(MatricesNear(classic.wrench, w_ref, 0.0, 1e-12));
}

// ---- Identity 2: J square and full rank, S_p = 0  =>  W = J^-T tau whatever S_t ------------

Vector6d InverseTransposeWrench(const Matrix6Xd& J, const Eigen::VectorXd& tau, int released) {
  // Delete the released row, solve the square system J_r^T W_r = tau by LU.
  Eigen::MatrixXd Jr(5, J.cols());
  for (int r = 0, k = 0; r < 6; ++r) {
    if (r != released) Jr.row(k++) = J.row(r);
  }
  const Eigen::VectorXd wr = Jr.transpose().partialPivLu().solve(tau);
  Vector6d w = Vector6d::Zero();
  for (int r = 0, k = 0; r < 6; ++r) {
    if (r != released) w[r] = wr[k++];
  }
  return w;
}

TEST(StaticsIdentities, MatchedDofsGiveInverseTransposeWhateverTransducerStiffness) {
  const LimbDescription desc =
      isowrench::WithReleasedDofs(LoadDescription("rat_hindlimb_5dof.urdf"), {"rz"});
  const Model released(desc);
  std::mt19937 rng(7);
  std::vector<Eigen::VectorXd> postures = {released.nominal_posture()};
  for (int k = 0; k < 3; ++k) postures.push_back(RandomPosture(released, rng));
  for (const Eigen::VectorXd& q : postures) {
    const Problem p = ProblemAt(released, q, "GP");
    ASSERT_EQ(p.J.cols(), 5);
    const Vector6d w_ref = InverseTransposeWrench(p.J, p.tau, isowrench::kRZ);
    const auto classic =
        isowrench::ClassicWrench(p.J, {{true, true, true, true, true, false}}, p.tau);
    EXPECT_TRUE(classic.square_inverse);
    EXPECT_TRUE(MatricesNear(classic.wrench, w_ref, 0.0, 1e-10));
    for (Vector6d s_t : SomeTransducerStiffnesses()) {
      s_t[isowrench::kRZ] = 0.0;  // released
      const StaticsResult r = SolveStatics(p.J, s_t, Eigen::VectorXd::Zero(5), p.tau);
      ASSERT_EQ(r.status, StaticsStatus::kOk) << r.message;
      const double tol = SolveTolerance(StiffnessAtJoints(p.J, s_t, Eigen::VectorXd::Zero(5)));
      EXPECT_TRUE(MatricesNear(r.wrench, w_ref, 0.0, tol)) << "S_t = " << s_t.transpose();
      EXPECT_EQ(r.wrench[isowrench::kRZ], 0.0);
      // The same through the model (released flag instead of a zero entry).
      const Model m(isowrench::WithTransducerStiffness(desc, s_t));
      const auto eval = EvaluateWrench(m, q, "GP");
      ASSERT_TRUE(eval.statics.ok()) << eval.statics.message;
      EXPECT_TRUE(MatricesNear(eval.statics.wrench, w_ref, 0.0, tol));
    }
  }
}

TEST(StaticsIdentities, MatchedDofsGiveInverseTransposeWhateverBaseStiffness) {
  // Base translations carry springs; the 5 limb joints carry none, so their 5 equilibrium rows
  // read J_limb^T W = tau_limb: W = J_limb^-T tau_limb, the 5-dof rigid-base answer.
  const Model rigid(
      isowrench::WithReleasedDofs(LoadDescription("rat_hindlimb_5dof.urdf"), {"rz"}));
  const Problem p5 = ProblemAt(rigid, rigid.nominal_posture(), "GP");
  const Vector6d w_ref = InverseTransposeWrench(p5.J, p5.tau, isowrench::kRZ);
  const LimbDescription base_desc =
      isowrench::WithReleasedDofs(LoadDescription("rat_hindlimb_5dof_base.urdf"), {"rz"});
  for (double k_base : {1e3, 1e5, 1e7, 1e9}) {
    const Model m(isowrench::WithBaseStiffness(base_desc, k_base));
    ASSERT_EQ(m.dof_count(), 8);
    const auto eval = EvaluateWrench(m, m.nominal_posture(), "GP");
    ASSERT_EQ(eval.statics.status, StaticsStatus::kOk) << eval.statics.message;
    const double tol =
        SolveTolerance(StiffnessAtJoints(eval.jacobian, eval.s_t, eval.s_p));
    EXPECT_TRUE(MatricesNear(eval.statics.wrench, w_ref, 0.0, tol)) << "k_base = " << k_base;
  }
}

// ---- Identity 3: equilibrium J^T W + S_p dtheta = tau ------------------------------------

struct EquilibriumCase {
  std::string urdf;
  std::string muscle;
};

void PrintTo(const EquilibriumCase& c, std::ostream* os) { *os << c.urdf << " / " << c.muscle; }

class Equilibrium : public ::testing::TestWithParam<EquilibriumCase> {};

TEST_P(Equilibrium, JointTorquesAreBalanced) {
  const Model model = LoadModel(GetParam().urdf);
  std::mt19937 rng(31);
  std::vector<Eigen::VectorXd> postures = {model.nominal_posture()};
  for (int k = 0; k < 3; ++k) postures.push_back(RandomPosture(model, rng));
  for (const Eigen::VectorXd& q : postures) {
    const auto eval = EvaluateWrench(model, q, GetParam().muscle);
    ASSERT_EQ(eval.statics.status, StaticsStatus::kOk) << eval.statics.message;
    const Eigen::VectorXd lhs =
        eval.jacobian.transpose() * eval.statics.wrench +
        eval.s_p.asDiagonal() * eval.statics.dtheta;
    const double tol = SolveTolerance(StiffnessAtJoints(eval.jacobian, eval.s_t, eval.s_p));
    EXPECT_TRUE(MatricesNear(lhs, eval.tau, tol * eval.tau.norm())) << GetParam().urdf;
    EXPECT_LE(eval.statics.equilibrium_residual, tol * eval.tau.norm());
    // W = S_t J dtheta, and released rows are exactly 0.
    const Vector6d w = eval.s_t.asDiagonal() * (eval.jacobian * eval.statics.dtheta);
    EXPECT_TRUE(MatricesNear(eval.statics.wrench, w, 0.0, tol));
    for (int d = 0; d < 6; ++d) {
      if (model.transducer().released[d]) {
        EXPECT_EQ(eval.statics.wrench[d], 0.0);
      }
    }
    EXPECT_TRUE(MatricesNear(eval.statics.endpoint_displacement,
                             (eval.jacobian * eval.statics.dtheta).eval(), 0.0, tol));
  }
}

INSTANTIATE_TEST_SUITE_P(
    Models, Equilibrium,
    ::testing::Values(EquilibriumCase{"rat_hindlimb_5dof.urdf", "GP"},
                      EquilibriumCase{"rat_hindlimb_6dof.urdf", "GP"},
                      EquilibriumCase{"rat_hindlimb_5dof_base.urdf", "GP"},
                      EquilibriumCase{"planar_2r.urdf", "biarticular"},
                      EquilibriumCase{"planar_2r.urdf", "elbow_flexor"},
                      EquilibriumCase{"planar_4r.urdf", "flexor"}),
    [](const ::testing::TestParamInfo<EquilibriumCase>& info) {
      return info.param.urdf.substr(0, info.param.urdf.find('.')) + "_" + info.param.muscle;
    });

// ---- Identity 4: scaling S_t and S_p together leaves W unchanged ---------------------------

TEST(StaticsIdentities, CommonScalingOfStiffnessesLeavesWrenchUnchanged) {
  for (const char* urdf : {"rat_hindlimb_6dof.urdf", "rat_hindlimb_5dof_base.urdf",
                           "planar_4r.urdf", "planar_2r.urdf"}) {
    const Model model = LoadModel(urdf);
    const Problem p = ProblemAt(model, model.nominal_posture(), model.muscle(0).name);
    const Vector6d s_t = EffectiveSt(model);
    const StaticsResult r0 = SolveStatics(p.J, s_t, p.s_p, p.tau);
    ASSERT_EQ(r0.status, StaticsStatus::kOk) << urdf << ": " << r0.message;
    const double tol = SolveTolerance(StiffnessAtJoints(p.J, s_t, p.s_p));
    for (double c : {1e-4, 3.0, 1e4}) {
      const StaticsResult r = SolveStatics(p.J, c * s_t, c * p.s_p, p.tau);
      ASSERT_EQ(r.status, StaticsStatus::kOk) << r.message;
      EXPECT_TRUE(MatricesNear(r.wrench, r0.wrench, 0.0, 2 * tol)) << urdf << " c = " << c;
      // dtheta scales as 1/c.
      EXPECT_TRUE(MatricesNear((c * r.dtheta).eval(), r0.dtheta, 0.0, 2 * tol));
    }
  }
}

// ---- Identity 5: invariance to re-parametrizing the joints (S_p = 0) -----------------------

TEST(StaticsIdentities, WrenchIsInvariantToJointCoordinateChange) {
  // Algebraic content: new coordinates theta = A theta' give J' = J A and tau' = A^T tau;
  // W' = S J A (A^T J^T S J A)^-1 A^T tau = S J (J^T S J)^-1 tau = W for any invertible A.
  const Model model = LoadModel("rat_hindlimb_5dof.urdf");
  const Problem p = ProblemAt(model, model.nominal_posture(), "GP");
  std::mt19937 rng(55);
  std::uniform_real_distribution<double> u(-0.4, 0.4);
  Eigen::MatrixXd A = Eigen::MatrixXd::Identity(5, 5);
  for (int i = 0; i < 5; ++i)
    for (int j = 0; j < 5; ++j) A(i, j) += u(rng);
  ASSERT_GT(A.fullPivLu().rank(), 4);
  const Matrix6Xd Jp = p.J * A;
  const Eigen::VectorXd taup = A.transpose() * p.tau;
  for (const Vector6d& s_t : SomeTransducerStiffnesses()) {
    const StaticsResult r = SolveStatics(p.J, s_t, Eigen::VectorXd::Zero(5), p.tau);
    const StaticsResult rp = SolveStatics(Jp, s_t, Eigen::VectorXd::Zero(5), taup);
    ASSERT_EQ(r.status, StaticsStatus::kOk);
    ASSERT_EQ(rp.status, StaticsStatus::kOk);
    const double tol =
        SolveTolerance(StiffnessAtJoints(Jp, s_t, Eigen::VectorXd::Zero(5))) +
        SolveTolerance(StiffnessAtJoints(p.J, s_t, Eigen::VectorXd::Zero(5)));
    EXPECT_TRUE(MatricesNear(rp.wrench, r.wrench, 0.0, tol)) << s_t.transpose();
  }
}

// The hip ball joint written with the other Euler order: chain rx, ry, rz (R = Rx Ry Rz)
// instead of rz, ry, rx (R = Rz Ry Rx). At each posture the hip angles of the new chain are
// chosen to give the same femur orientation; the limb is then the same mechanism in other
// coordinates, and W must not change (over-constrained, S_p = 0).
LimbDescription HipOrderXyz(LimbDescription d) {
  // joints[0..2] are hip_rz, hip_ry, hip_rx (all origins identity at the hip centre).
  EXPECT_EQ(d.joints[0].name, "hip_rz");
  EXPECT_EQ(d.joints[2].name, "hip_rx");
  d.joints[0].name = "hip_rx";
  d.joints[0].axis = Eigen::Vector3d::UnitX();
  d.joints[2].name = "hip_rz";
  d.joints[2].axis = Eigen::Vector3d::UnitZ();
  return d;
}

TEST(StaticsIdentities, WrenchIsInvariantToHipEulerOrder) {
  const Model zyx = LoadModel("rat_hindlimb_5dof.urdf");
  const Model xyz(HipOrderXyz(zyx.description()));
  KinematicsWorkspace ws_zyx(zyx), ws_xyz(xyz);
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> angle(-kPi, kPi), tilt(-1.0, 1.0);
  std::vector<Eigen::VectorXd> postures = {zyx.nominal_posture()};
  for (int k = 0; k < 4; ++k) {
    Eigen::VectorXd q = zyx.nominal_posture();
    q[0] = angle(rng);  // hip_rz
    q[1] = tilt(rng);   // hip_ry, away from gimbal lock at +-90 deg
    q[2] = angle(rng);  // hip_rx
    q[3] += tilt(rng);  // knee_rz
    q[4] = tilt(rng);   // knee_rx
    postures.push_back(q);
  }
  int checked = 0;
  for (const Eigen::VectorXd& q : postures) {
    const Eigen::Matrix3d R = (Eigen::AngleAxisd(q[0], Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(q[1], Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(q[2], Eigen::Vector3d::UnitX()))
                                  .toRotationMatrix();
    const Eigen::Vector3d xyz_angles = R.eulerAngles(0, 1, 2);  // R = Rx(a) Ry(b) Rz(c)
    if (std::abs(std::cos(xyz_angles[1])) < 0.2) continue;     // new chain near gimbal lock
    Eigen::VectorXd qp = q;
    qp.head<3>() = xyz_angles;
    // Same mechanism state: same endpoint pose and muscle length.
    const Eigen::Isometry3d X = isowrench::EndpointPose(zyx, ws_zyx, q);
    const Eigen::Isometry3d Xp = isowrench::EndpointPose(xyz, ws_xyz, qp);
    ASSERT_TRUE(MatricesNear(Xp.matrix(), X.matrix(), 1e-12));
    for (const Vector6d& s_t : SomeTransducerStiffnesses()) {
      const Model a(isowrench::WithTransducerStiffness(zyx.description(), s_t));
      const Model b(isowrench::WithTransducerStiffness(xyz.description(), s_t));
      const auto ea = EvaluateWrench(a, q, "GP");
      const auto eb = EvaluateWrench(b, qp, "GP");
      ASSERT_EQ(ea.statics.status, StaticsStatus::kOk);
      ASSERT_EQ(eb.statics.status, StaticsStatus::kOk);
      EXPECT_NEAR(eb.muscle_length, ea.muscle_length, 1e-14);
      const double tol = SolveTolerance(StiffnessAtJoints(ea.jacobian, ea.s_t, ea.s_p)) +
                         SolveTolerance(StiffnessAtJoints(eb.jacobian, eb.s_t, eb.s_p));
      EXPECT_TRUE(MatricesNear(eb.statics.wrench, ea.statics.wrench, 0.0, tol))
          << "q = " << q.transpose() << " S_t = " << s_t.transpose();
    }
    ++checked;
  }
  EXPECT_GE(checked, 3);
}

// ---- Identity 6: two compliances differ only inside null(J^T) ------------------------------

TEST(StaticsIdentities, CompliancesDifferOnlyInNullSpaceOfJacobianTranspose) {
  const Model model = LoadModel("rat_hindlimb_5dof.urdf");
  std::mt19937 rng(66);
  std::vector<Eigen::VectorXd> postures = {model.nominal_posture(), RandomPosture(model, rng)};
  for (const Eigen::VectorXd& q : postures) {
    const Problem p = ProblemAt(model, q, "GP");
    // null(J^T) of the 6 x 5 J: the last column of the full Q of J's QR.
    const Eigen::HouseholderQR<Eigen::MatrixXd> qr(p.J);
    const Vector6d n = (qr.householderQ() * Eigen::MatrixXd::Identity(6, 6)).col(5);
    const StaticsResult r1 = SolveStatics(p.J, Vector6d::Constant(1e7), Eigen::VectorXd::Zero(5), p.tau);
    const auto stiffnesses = SomeTransducerStiffnesses();
    for (size_t i = 1; i < stiffnesses.size(); ++i) {
      const StaticsResult r2 = SolveStatics(p.J, stiffnesses[i], Eigen::VectorXd::Zero(5), p.tau);
      ASSERT_TRUE(r1.ok() && r2.ok());
      const Vector6d dW = r2.wrench - r1.wrench;
      // The compliance matters (otherwise the test says nothing)...
      EXPECT_GT(dW.norm(), 1e-3 * r1.wrench.norm()) << stiffnesses[i].transpose();
      // ...and only along n: J^T dW = 0, dW = (n . dW) n.
      const double tol = SolveTolerance(StiffnessAtJoints(p.J, stiffnesses[i], Eigen::VectorXd::Zero(5)));
      EXPECT_TRUE(MatricesNear((p.J.transpose() * dW).eval(), Eigen::VectorXd::Zero(5),
                               tol * p.J.norm() * r2.wrench.norm()));
      EXPECT_TRUE(MatricesNear(dW, (n.dot(dW) * n).eval(), tol * r2.wrench.norm()));
    }
  }
}

// ---- Released dofs: row deletion == explicit zero-stiffness joint --------------------------

// Add a joint between the tibia and a new "transducer_mount" link at the endpoint, turning
// (revolute) or sliding (prismatic) along `axis_world` (world axes, at posture q), role
// kRelease, zero stiffness, and move the transducer to the new link (endpoint at its origin).
LimbDescription WithExplicitRelease(const Model& model, const Eigen::VectorXd& q,
                                    isowrench::JointType type, const Eigen::Vector3d& axis_world) {
  LimbDescription d = model.description();
  KinematicsWorkspace ws(model);
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
  KinematicsWorkspace ws(limb);
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
  KinematicsWorkspace ws(model);
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
                           isowrench::FemurRemovedWrench(model, model.nominal_posture(), "GP"),
                           0.0, 1e-8));
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
  EXPECT_TRUE(r.status == StaticsStatus::kSelfMotion ||
              r.status == StaticsStatus::kSelfMotionHeld)
      << isowrench::StatusName(r.status);
  EXPECT_FALSE(r.message.empty());
  EXPECT_EQ(r.k_rank, 5);
  ASSERT_EQ(r.self_motion.rows(), 6);
  ASSERT_EQ(r.self_motion.cols(), 1);
  Eigen::VectorXd n = r.self_motion.col(0);
  const Eigen::VectorXd expected = FemurAxialRotation(model);
  if (n.dot(expected) < 0) n = -n;
  EXPECT_TRUE(MatricesNear(n, expected, 1e-9));
  EXPECT_NEAR(n[model.JointIndex("knee_ry")] / n[model.JointIndex("knee_rx")],
              -std::tan(Deg(105)), 1e-8);
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
    KinematicsWorkspace ws(model);
    const Matrix6Xd J = isowrench::EndpointJacobian(model, ws, q);
    const Eigen::Vector2d tau(torque(rng), torque(rng));
    for (const Eigen::Vector3d& g : gains) {
      const StaticsResult r = SolveStatics(J, Diag6(g[0], g[1], 0, 0, 0, g[2]),
                                           Eigen::VectorXd::Zero(2), tau);
      ASSERT_EQ(r.status, StaticsStatus::kOk) << r.message;
      EXPECT_TRUE(MatricesNear(r.wrench, Planar2rOverConstrainedWrench(q[0], q[1], g[0], g[1], g[2], tau),
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
  KinematicsWorkspace ws(model);
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
