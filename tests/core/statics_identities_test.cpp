// Tests of include/isowrench/statics.hpp, part 1: every identity of docs/model.md "Statics"
// (pseudoinverse, inverse transpose, equilibrium, common scaling, re-parametrization, null-space).
// Parts 2 and 3: statics_release_test.cpp, statics_planar_test.cpp.
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
        isowrench::ClassicWrench(p.J, isowrench::DofMask{}, p.tau);
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
  const auto classic = isowrench::ClassicWrench(p.J, {"z", "rx", "ry"}, p.tau);
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
    const auto classic = isowrench::ClassicWrench(p.J, {"rz"}, p.tau);
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
  const Model rigid(isowrench::WithReleasedDofs(LoadDescription("rat_hindlimb_5dof.urdf"), {"rz"}));
  const Problem p5 = ProblemAt(rigid, rigid.nominal_posture(), "GP");
  const Vector6d w_ref = InverseTransposeWrench(p5.J, p5.tau, isowrench::kRZ);
  const LimbDescription base_desc =
      isowrench::WithReleasedDofs(LoadDescription("rat_hindlimb_5dof_base.urdf"), {"rz"});
  for (double k_base : {1e3, 1e5, 1e7, 1e9}) {
    const Model m(isowrench::WithBaseStiffness(base_desc, k_base));
    ASSERT_EQ(m.dof_count(), 8);
    const auto eval = EvaluateWrench(m, m.nominal_posture(), "GP");
    ASSERT_EQ(eval.statics.status, StaticsStatus::kOk) << eval.statics.message;
    const double tol = SolveTolerance(StiffnessAtJoints(eval.jacobian, eval.s_t, eval.s_p));
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
    const Eigen::VectorXd lhs = eval.jacobian.transpose() * eval.statics.wrench +
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

INSTANTIATE_TEST_SUITE_P(Models, Equilibrium,
                         ::testing::Values(EquilibriumCase{"rat_hindlimb_5dof.urdf", "GP"},
                                           EquilibriumCase{"rat_hindlimb_6dof.urdf", "GP"},
                                           EquilibriumCase{"rat_hindlimb_5dof_base.urdf", "GP"},
                                           EquilibriumCase{"planar_2r.urdf", "biarticular"},
                                           EquilibriumCase{"planar_2r.urdf", "elbow_flexor"},
                                           EquilibriumCase{"planar_4r.urdf", "flexor"}),
                         [](const ::testing::TestParamInfo<EquilibriumCase>& info) {
                           return info.param.urdf.substr(0, info.param.urdf.find('.')) + "_" +
                                  info.param.muscle;
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
    const double tol = SolveTolerance(StiffnessAtJoints(Jp, s_t, Eigen::VectorXd::Zero(5))) +
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
  Data ws_zyx(zyx), ws_xyz(xyz);
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
    if (std::abs(std::cos(xyz_angles[1])) < 0.2) continue;      // new chain near gimbal lock
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
    const StaticsResult r1 =
        SolveStatics(p.J, Vector6d::Constant(1e7), Eigen::VectorXd::Zero(5), p.tau);
    const auto stiffnesses = SomeTransducerStiffnesses();
    for (size_t i = 1; i < stiffnesses.size(); ++i) {
      const StaticsResult r2 = SolveStatics(p.J, stiffnesses[i], Eigen::VectorXd::Zero(5), p.tau);
      ASSERT_TRUE(r1.ok() && r2.ok());
      const Vector6d dW = r2.wrench - r1.wrench;
      // The compliance matters (otherwise the test says nothing)...
      EXPECT_GT(dW.norm(), 1e-3 * r1.wrench.norm()) << stiffnesses[i].transpose();
      // ...and only along n: J^T dW = 0, dW = (n . dW) n.
      const double tol =
          SolveTolerance(StiffnessAtJoints(p.J, stiffnesses[i], Eigen::VectorXd::Zero(5)));
      EXPECT_TRUE(MatricesNear((p.J.transpose() * dW).eval(), Eigen::VectorXd::Zero(5),
                               tol * p.J.norm() * r2.wrench.norm()));
      EXPECT_TRUE(MatricesNear(dW, (n.dot(dW) * n).eval(), tol * r2.wrench.norm()));
    }
  }
}

}  // namespace
}  // namespace isowrench_test
