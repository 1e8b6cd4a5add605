// Tests of include/isowrench/diagnostics.hpp: constraint class, self-motion, internal wrench,
// compliance sensitivity, release comparison, axis sweep, large-deflection check, posture table.
// References are re-derived independently: the rat geometry by hand (MODEL.md), finite
// differences of the library's own Eq. 10 for the analytic sensitivities, forward kinematics for
// self-motions, and the potential for the nonlinear gradient.

#include "isowrench/diagnostics.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <cmath>
#include <functional>
#include <random>
#include <string>

#include "isowrench/error.hpp"
#include "isowrench/kinematics.hpp"
#include "isowrench/model.hpp"
#include "isowrench/posture.hpp"
#include "isowrench/statics.hpp"

namespace {

using isowrench::Error;
using isowrench::Model;
using isowrench::ReleaseKind;
using isowrench::Vector6d;
using ::testing::HasSubstr;
using ::testing::Not;
using ::testing::ThrowsMessage;

constexpr double kPi = 3.14159265358979323846;
double Deg(double d) { return d * kPi / 180.0; }

std::string Urdf(const std::string& file) {
  return std::string(ISOWRENCH_TEST_URDF_DIR) + "/" + file;
}
Model Load(const std::string& file) { return Model::FromUrdfFile(Urdf(file)); }

// The rat's nominal geometry by hand (MODEL.md): hip at the origin, femur 31 mm and tibia 41 mm
// along +x of their frames; hip rz -110°, knee rz 105°: the leg lies in the world xy plane.
Eigen::Vector3d RatKnee() {
  return Eigen::AngleAxisd(Deg(-110), Eigen::Vector3d::UnitZ()) * Eigen::Vector3d(0.031, 0, 0);
}
Eigen::Vector3d RatAnkle() {
  return RatKnee() +
         Eigen::AngleAxisd(Deg(-5), Eigen::Vector3d::UnitZ()) * Eigen::Vector3d(0.041, 0, 0);
}

// A release assessment with a one-point stiffness range (the range is not under test here).
isowrench::ReleaseOptions QuickOptions() {
  isowrench::ReleaseOptions o;
  o.range.rotational_ratios = {1.0};
  o.range.base_stiffness = {0.0};
  return o;
}

// |D v| with D = diag(1,1,1,1/L,1/L,1/L): forces and moments/L on one scale.
double ScaledNorm(const Vector6d& w, double L) {
  Vector6d s = w;
  s.tail<3>() /= L;
  return s.norm();
}

// ---- joint centres and geometry -------------------------------------------------------

TEST(JointCentres, RatHipAndKneeAreWhereTheGeometrySaysAndGroupedByPrefix) {
  Model model = Load("rat_hindlimb_5dof.urdf");
  auto centres = isowrench::FindJointCentres(model, model.nominal_posture());
  ASSERT_EQ(centres.size(), 2u);
  EXPECT_EQ(centres[0].name, "hip");
  EXPECT_EQ(centres[0].joints.size(), 3u);
  EXPECT_EQ(centres[1].name, "knee");
  // Positions from trigonometry agree to rounding of a 31 mm vector (~1e-17 m; 1e-15 m margin).
  EXPECT_LT(centres[0].position.norm(), 1e-15);
  EXPECT_LT((centres[1].position - RatKnee()).norm(), 1e-15);
}

// ---- releases -------------------------------------------------------------------------

TEST(Releases, RotationAboutAnkleKneeLineIsSelfMotion) {
  Model model = Load("rat_hindlimb_5dof.urdf");
  const Eigen::VectorXd q = model.nominal_posture();
  const Eigen::Vector3d axis = (RatKnee() - RatAnkle()).normalized();
  auto a = isowrench::AssessRelease(
      model, q, "GP", isowrench::MakeReleaseCandidate("ankle-knee", ReleaseKind::kRotation, axis),
      QuickOptions());
  EXPECT_TRUE(a.self_motion);
  EXPECT_FALSE(a.torques_recoverable);
  EXPECT_FALSE(a.statics.ok());
  // Independent reason: knee_rx turns the tibia about its own long axis, the ankle-knee line, so
  // its Jacobian column is exactly the release column [0; a] (up to sign).
  isowrench::Data ws(model);
  Vector6d col = isowrench::EndpointJacobian(model, ws, q).col(model.JointIndex("knee_rx"));
  EXPECT_LT(col.head<3>().norm(), 1e-15);
  EXPECT_NEAR(std::abs(col.tail<3>().dot(axis)), 1.0, 1e-14);
}

TEST(Releases, RotationAboutAnkleHipLineIsSelfMotion) {
  Model model = Load("rat_hindlimb_5dof.urdf");
  const Eigen::Vector3d axis = (Eigen::Vector3d::Zero() - RatAnkle()).normalized();
  auto a = isowrench::AssessRelease(
      model, model.nominal_posture(), "GP",
      isowrench::MakeReleaseCandidate("ankle-hip", ReleaseKind::kRotation, axis), QuickOptions());
  EXPECT_TRUE(a.self_motion);
  // The whole leg turning rigidly about the hip-ankle line (a hip ball rotation) leaves the
  // ankle in place: check by forward kinematics that such a hip motion exists. The hip's
  // angular velocity w = axis is reached by its three joints; solve for their rates.
  isowrench::Data ws(model);
  const Eigen::VectorXd q = model.nominal_posture();
  auto J = isowrench::EndpointJacobian(model, ws, q);
  Eigen::Matrix3d hip_axes = J.bottomRows<3>().leftCols<3>();
  Eigen::Vector3d rates = hip_axes.fullPivLu().solve(axis);
  Eigen::VectorXd dq = Eigen::VectorXd::Zero(model.dof_count());
  dq.head<3>() = rates;
  const double eps = 1e-6;
  Eigen::Vector3d moved = isowrench::EndpointPose(model, ws, q + eps * dq).translation();
  // First-order motion of the ankle is zero: the displacement is O(eps^2) * |leg| ~ 1e-13 m.
  EXPECT_LT((moved - RatAnkle()).norm(), 1e-11);
}

TEST(Releases, RotationAboutWorldZIsSafeAndMatched) {
  Model model = Load("rat_hindlimb_5dof.urdf");
  auto a = isowrench::AssessRelease(
      model, model.nominal_posture(), "GP",
      isowrench::MakeReleaseCandidate("z", ReleaseKind::kRotation, Eigen::Vector3d::UnitZ()));
  EXPECT_FALSE(a.self_motion);
  EXPECT_FALSE(a.near_self_motion);
  EXPECT_FALSE(a.internal_wrench);
  EXPECT_TRUE(a.torques_recoverable);
  EXPECT_GT(a.margin, 1e-2);
  // Matched: W is the same over the whole stiffness range (identity 2 of MODEL.md); the spread is
  // rounding amplified by cond(K) over a 1e4..1e9 stiffness range (< 1e-6 measured 1e-9).
  EXPECT_LT(a.spread, 1e-6);
  EXPECT_EQ(a.range_failures, 0);
}

TEST(Releases, ColumnReleaseEqualsRowRelease) {
  // MODEL.md "Released dofs": releasing rz by deleting its row equals a zero-stiffness joint
  // with column [0; e_z].
  Model model = Load("rat_hindlimb_5dof.urdf");
  const Eigen::VectorXd q = model.nominal_posture();
  auto a = isowrench::AssessRelease(
      model, q, "GP",
      isowrench::MakeReleaseCandidate("rz", ReleaseKind::kRotation, Eigen::Vector3d::UnitZ()),
      QuickOptions());
  Model released(isowrench::WithReleasedDofs(model.description(), {"rz"}));
  auto e = isowrench::EvaluateWrench(released, q, "GP");
  ASSERT_TRUE(a.statics.ok());
  // Two factorizations of systems with condition ~1e3: agreement to 1e-10 relative.
  EXPECT_LT(ScaledNorm(a.statics.wrench - e.statics.wrench, model.chain_length()),
            1e-10 * ScaledNorm(e.statics.wrench, model.chain_length()));
}

TEST(Releases, SampledAxesAreFlaggedExactlyWhenInTheLegPlane) {
  Model model = Load("rat_hindlimb_5dof.urdf");
  const Eigen::VectorXd q = model.nominal_posture();
  // The ankle, knee and hip span the plane with normal (knee - ankle) x (hip - ankle).
  const Eigen::Vector3d normal = (RatKnee() - RatAnkle()).cross(-RatAnkle()).normalized();
  auto forbidden = isowrench::FindForbiddenAxes(model, q).first;
  ASSERT_EQ(forbidden.dimension, 2);
  EXPECT_NEAR(std::abs(forbidden.plane_normal.dot(normal)), 1.0, 1e-12);

  std::mt19937_64 rng(20241121);
  std::normal_distribution<double> gauss;
  const auto options = QuickOptions();
  int in_plane = 0, off_plane = 0;
  for (int i = 0; i < 40; ++i) {
    Eigen::Vector3d a(gauss(rng), gauss(rng), gauss(rng));
    if (i % 2 == 0) a -= a.dot(normal) * normal;  // project half of them into the plane
    a.normalize();
    // |a . n| is exactly representable as "in plane" (<= 1e-15 after projection) or well off it
    // (a Gaussian sample within 1e-6 of the plane has probability ~1e-6).
    const bool lies_in_plane = std::abs(a.dot(normal)) < 1e-12;
    (lies_in_plane ? in_plane : off_plane)++;
    auto r = isowrench::AssessRelease(
        model, q, "GP", isowrench::MakeReleaseCandidate("sample", ReleaseKind::kRotation, a),
        options);
    EXPECT_EQ(r.self_motion, lies_in_plane) << "axis " << a.transpose() << ", margin " << r.margin;
  }
  EXPECT_EQ(in_plane, 20);
  EXPECT_EQ(off_plane, 20);
}

TEST(Releases, SweepIsReproducibleAndFindsNoExactSelfMotion) {
  Model model = Load("rat_hindlimb_5dof.urdf");
  auto s1 = isowrench::SweepReleaseAxes(model, model.nominal_posture(), 300, 42);
  auto s2 = isowrench::SweepReleaseAxes(model, model.nominal_posture(), 300, 42);
  EXPECT_EQ(s1.samples, 300);
  EXPECT_EQ(s1.safe + s1.near + s1.self_motion, 300);
  EXPECT_EQ(s1.safe, s2.safe);
  EXPECT_EQ(s1.worst_axis, s2.worst_axis);
  // Random axes miss the forbidden plane with probability 1; the worst one lies close to it.
  EXPECT_EQ(s1.self_motion, 0);
  EXPECT_LT(std::abs(s1.worst_axis.z()), 0.05);
  EXPECT_THAT([&] { isowrench::SweepReleaseAxes(model, model.nominal_posture(), 0, 1); },
              ThrowsMessage<Error>(HasSubstr("at least 1")));
}

TEST(Releases, CompareRanksOnlySafeCandidatesAndRecommendsOne) {
  Model model = Load("rat_hindlimb_5dof.urdf");
  auto c = isowrench::CompareReleases(model, model.nominal_posture(), "GP");
  ASSERT_GE(c.recommended, 0);
  const auto& best = c.candidates[static_cast<size_t>(c.recommended)];
  EXPECT_EQ(best.rank_order, 1);
  EXPECT_FALSE(best.self_motion);
  EXPECT_FALSE(best.internal_wrench);
  EXPECT_FALSE(c.recommendation.empty());
  for (const auto& a : c.candidates) {
    if (a.self_motion) {
      EXPECT_EQ(a.rank_order, 0) << a.candidate.name;
    }
    if (a.candidate.name == "endpoint-knee line" || a.candidate.name == "endpoint-hip line") {
      EXPECT_TRUE(a.self_motion) << a.candidate.name;
    }
    if (a.candidate.name == "rz") {
      EXPECT_FALSE(a.self_motion);
    }
  }
  // The over-constrained baseline depends on compliance: its spread is far above rounding.
  EXPECT_TRUE(c.baseline.internal_wrench);
  EXPECT_GT(c.baseline.spread, 1e-2);
}

TEST(Releases, SpringHeldJointsDoNotCountAsSelfMotion) {
  // Base dofs carry springs: releasing rz on the 5-dof limb with a base is still matched on the
  // spring-free joints, so W does not depend on the base stiffness (identity 2 of MODEL.md).
  Model model = Load("rat_hindlimb_5dof_base.urdf");
  auto a = isowrench::AssessRelease(
      model, model.nominal_posture(), "GP",
      isowrench::MakeReleaseCandidate("rz", ReleaseKind::kRotation, Eigen::Vector3d::UnitZ()));
  EXPECT_FALSE(a.self_motion);
  EXPECT_FALSE(a.internal_wrench);
  EXPECT_LT(a.spread, 1e-6);
}

TEST(Releases, BadAxesAreRejectedWithClearMessages) {
  EXPECT_THAT(
      [] { isowrench::MakeReleaseCandidate("u", ReleaseKind::kRotation, Eigen::Vector3d::Zero()); },
      ThrowsMessage<Error>(HasSubstr("'u' (0, 0, 0) has zero length")));
  EXPECT_THAT(
      [] {
        isowrench::MakeReleaseCandidate("v", ReleaseKind::kRotation, Eigen::Vector3d(NAN, 0, 1));
      },
      ThrowsMessage<Error>(HasSubstr("'v' (nan, 0, 1) has a non-finite component")));
  EXPECT_THAT(
      [] {
        isowrench::MakeReleaseCandidate("w", ReleaseKind::kTranslation,
                                        Eigen::Vector3d(INFINITY, 0, 0));
      },
      ThrowsMessage<Error>(HasSubstr("non-finite")));
  // A valid axis is normalized.
  auto c = isowrench::MakeReleaseCandidate("ok", ReleaseKind::kRotation, Eigen::Vector3d(0, 0, 3));
  EXPECT_NEAR(c.axis_world.norm(), 1.0, 1e-15);
}

TEST(Releases, AlreadyReleasedAxesAreNotCandidatesAndDegenerateModelsDoNotCrash) {
  // planar_2r restrains x, y, rz: rx, ry, z are not offered, and an in-plane rotation axis only
  // moves released dofs ("already free").
  Model planar = Load("planar_2r.urdf");
  auto candidates = isowrench::DefaultReleaseCandidates(planar, planar.nominal_posture());
  for (const auto& c : candidates) {
    EXPECT_NE(c.name, "rx");
    EXPECT_NE(c.name, "ry");
    EXPECT_NE(c.name, "z");
  }
  auto a = isowrench::AssessRelease(
      planar, planar.nominal_posture(), planar.muscle(0).name,
      isowrench::MakeReleaseCandidate("in-plane", ReleaseKind::kRotation, Eigen::Vector3d(1, 1, 0)),
      QuickOptions());
  EXPECT_THAT(a.verdict, HasSubstr("already free"));
  auto sweep = isowrench::SweepReleaseAxes(planar, planar.nominal_posture(), 20, 3);
  EXPECT_EQ(sweep.already_free + sweep.safe + sweep.near + sweep.self_motion, 20);
  // Every transducer dof released: no restrained rows; everything is self-motion, no crash.
  Model rat = Load("rat_hindlimb_5dof.urdf");
  Model free_limb(
      isowrench::WithReleasedDofs(rat.description(), {"x", "y", "z", "rx", "ry", "rz"}));
  auto c = isowrench::AnalyzeConstraints(free_limb, free_limb.nominal_posture());
  EXPECT_EQ(c.rank, 0);
  EXPECT_EQ(c.self_motion.size(), 5u);
  auto f = isowrench::FindForbiddenAxes(free_limb, free_limb.nominal_posture());
  EXPECT_EQ(f.first.dimension, 3);
  auto cmp = isowrench::CompareReleases(free_limb, free_limb.nominal_posture(), "GP");
  EXPECT_EQ(cmp.recommended, -1);
}

// ---- constraint class, self-motion, internal wrench ---------------------------------------

TEST(Constraints, ClassesOfTheRatLimbs) {
  Model five = Load("rat_hindlimb_5dof.urdf");
  auto over = isowrench::AnalyzeConstraints(five, five.nominal_posture());
  EXPECT_EQ(over.constraint_class, isowrench::ConstraintClass::kOverConstrained);
  EXPECT_EQ(over.joint_count, 5);
  EXPECT_EQ(over.restrained_count, 6);
  EXPECT_EQ(over.rank, 5);
  EXPECT_DOUBLE_EQ(over.rank_threshold, over.rank_tolerance * over.singular_values[0]);

  Model matched(isowrench::WithReleasedDofs(five.description(), {"rz"}));
  auto m = isowrench::AnalyzeConstraints(matched, matched.nominal_posture());
  EXPECT_EQ(m.constraint_class, isowrench::ConstraintClass::kMatched);
  EXPECT_TRUE(m.self_motion.empty());
  EXPECT_TRUE(m.internal_wrench.empty());

  Model base = Load("rat_hindlimb_5dof_base.urdf");
  auto b = isowrench::AnalyzeConstraints(base, base.nominal_posture());
  EXPECT_EQ(b.constraint_class, isowrench::ConstraintClass::kUnderConstrained);
  EXPECT_EQ(b.free_class, isowrench::ConstraintClass::kOverConstrained);
}

TEST(Constraints, FemurAxialRotationIsTheSelfMotionOfThe6DofLimb) {
  Model model = Load("rat_hindlimb_6dof.urdf");
  const Eigen::VectorXd q = model.nominal_posture();
  auto a = isowrench::AnalyzeConstraints(model, q);
  ASSERT_EQ(a.self_motion.size(), 1u);
  const Eigen::VectorXd d = a.self_motion[0].direction;
  EXPECT_THAT(a.self_motion[0].interpretation,
              HasSubstr("femur axial rotation (about the hip-knee line)"));
  // By forward kinematics, independent of J: moving along d by eps keeps the knee centre and the
  // whole tibia pose fixed to first order (changes are O(eps^2) ~ 1e-12 m or rad), while the
  // femur turns by ~eps about its own long axis.
  isowrench::Data ws(model);
  const double eps = 1e-6;
  const Eigen::Isometry3d X0 = isowrench::EndpointPose(model, ws, q);
  const Eigen::Isometry3d X1 = isowrench::EndpointPose(model, ws, q + eps * d);
  EXPECT_LT((X1.translation() - X0.translation()).norm(), 1e-12);
  EXPECT_LT(Eigen::AngleAxisd(X1.linear() * X0.linear().transpose()).angle(), 1e-11);
  const Eigen::Vector3d knee_on_femur(0.031, 0, 0), side_on_femur(0.0155, 0.01, 0);
  auto knee0 = isowrench::PointPosition(model, ws, q, "femur", knee_on_femur);
  auto knee1 = isowrench::PointPosition(model, ws, q + eps * d, "femur", knee_on_femur);
  EXPECT_LT((knee1 - knee0).norm(), 1e-12);
  // A point off the femur axis does move (the motion is not trivial): ~eps * 10 mm.
  auto side0 = isowrench::PointPosition(model, ws, q, "femur", side_on_femur);
  auto side1 = isowrench::PointPosition(model, ws, q + eps * d, "femur", side_on_femur);
  EXPECT_GT((side1 - side0).norm(), 1e-9);
  // knee_ry's spring holds it: null(K) is empty.
  auto diag = isowrench::DiagnoseLimb(model, q, "GP", {});
  EXPECT_TRUE(diag.stiffness_null.empty());
}

TEST(Constraints, InternalWrenchIsOrthogonalToTheRangeOfJ) {
  for (const char* file : {"rat_hindlimb_5dof.urdf", "planar_2r.urdf"}) {
    Model model = Load(file);
    auto a = isowrench::AnalyzeConstraints(model, model.nominal_posture());
    ASSERT_EQ(a.internal_wrench.size(), 1u) << file;
    const Vector6d w = a.internal_wrench[0].direction;
    // w . (J v) = 0 for every joint velocity v, i.e. J^T w = 0: rounding of |J||w| ~ 1e-16.
    Eigen::VectorXd JTw = a.jacobian.transpose() * w;
    EXPECT_LT(JTw.norm(), 1e-13 * a.jacobian.norm() * w.norm()) << file;
  }
  Model rat = Load("rat_hindlimb_5dof.urdf");
  auto a = isowrench::AnalyzeConstraints(rat, rat.nominal_posture());
  // The planar leg (xy plane): the internal wrench lives in fx, fy, mz.
  EXPECT_EQ(a.internal_wrench[0].components, (std::vector<int>{0, 1, 5}));
  // MODEL.md identity 6: two compliances give wrenches that differ only inside null(J^T).
  Model soft_rot(isowrench::WithTransducerStiffness(
      rat.description(), (Vector6d() << 1e7, 1e7, 1e7, 1e3, 1e3, 1e3).finished()));
  Vector6d dW = isowrench::EvaluateWrench(soft_rot, rat.nominal_posture(), "GP").statics.wrench -
                isowrench::EvaluateWrench(rat, rat.nominal_posture(), "GP").statics.wrench;
  const Vector6d n = a.internal_wrench[0].direction;
  const Vector6d along = n * (n.dot(dW) / n.squaredNorm());
  ASSERT_GT(dW.norm(), 1e-3);
  EXPECT_LT((dW - along).norm(), 1e-9 * dW.norm());
}

// ---- sensitivity --------------------------------------------------------------------------

// dW/dlog k by central differences of EvaluateWrench on edited models: (W(k e^h) - W(k e^-h)) / 2h.
Vector6d FiniteDifference(const Model& model,
                          const std::function<isowrench::LimbDescription(double)>& edit, double k) {
  const double h = 1e-4;
  const Eigen::VectorXd q = model.nominal_posture();
  Vector6d plus = isowrench::EvaluateWrench(Model(edit(k * std::exp(h))), q, "GP").statics.wrench;
  Vector6d minus = isowrench::EvaluateWrench(Model(edit(k * std::exp(-h))), q, "GP").statics.wrench;
  return (plus - minus) / (2 * h);
}

TEST(Sensitivity, AnalyticMatchesFiniteDifferences) {
  for (const char* file :
       {"rat_hindlimb_5dof.urdf", "rat_hindlimb_5dof_base.urdf", "rat_hindlimb_6dof.urdf"}) {
    Model model = Load(file);
    auto e = isowrench::EvaluateWrench(model, model.nominal_posture(), "GP");
    auto s = isowrench::ComputeStiffnessSensitivity(model, e);
    ASSERT_TRUE(s.ok) << s.message;
    const double L = model.chain_length();
    const double scale = ScaledNorm(e.statics.wrench, L);
    for (const auto& entry : s.entries) {
      if (entry.parameter.rfind("base (", 0) == 0) continue;  // combined entry: checked below
      std::function<isowrench::LimbDescription(double)> edit;
      if (entry.kind == "transducer") {
        int dof = 0;
        while (std::string("S_t ") + isowrench::DofName(dof) != entry.parameter) ++dof;
        edit = [&, dof](double k) {
          Vector6d st = model.transducer().stiffness;
          st[dof] = k;
          return isowrench::WithTransducerStiffness(model.description(), st);
        };
      } else {
        edit = [&](double k) {
          return isowrench::WithJointStiffness(model.description(), entry.parameter, k);
        };
      }
      Vector6d fd = FiniteDifference(model, edit, entry.stiffness);
      // Truncation h^2/6 |W'''| ~ 1e-9 |W| plus rounding eps cond(K) / h ~ 1e-12 cond(K) |W|;
      // 1e-6 |W| covers the 6-dof limb's cond(K) ~ 4e7.
      EXPECT_LT(ScaledNorm(entry.dW_dlogk - fd, L), 1e-6 * scale) << file << " " << entry.parameter;
    }
  }
}

TEST(Sensitivity, BaseTogetherIsTheSumOfTheBaseJoints) {
  Model model = Load("rat_hindlimb_5dof_base.urdf");
  auto e = isowrench::EvaluateWrench(model, model.nominal_posture(), "GP");
  auto s = isowrench::ComputeStiffnessSensitivity(model, e);
  Vector6d sum = Vector6d::Zero(), together = Vector6d::Zero();
  for (const auto& entry : s.entries) {
    if (entry.kind != "base") continue;
    if (entry.parameter.rfind("base (", 0) == 0) {
      together = entry.dW_dlogk;
    } else {
      sum += entry.dW_dlogk;
    }
  }
  // First-order effects add (linearity of the derivative): equal to rounding.
  EXPECT_GT(together.norm(), 0.0);
  EXPECT_LT((together - sum).norm(), 1e-12 * std::max(1.0, sum.norm()));
}

TEST(Sensitivity, MatchedLimbIsInsensitiveAndOverConstrainedIsNot) {
  Model over = Load("rat_hindlimb_5dof.urdf");
  Model matched(isowrench::WithReleasedDofs(over.description(), {"rz"}));
  for (const Model* m : {&over, &matched}) {
    auto e = isowrench::EvaluateWrench(*m, m->nominal_posture(), "GP");
    auto s = isowrench::ComputeStiffnessSensitivity(*m, e);
    ASSERT_TRUE(s.ok);
    ASSERT_FALSE(s.entries.empty());
    double largest = 0.0;
    for (const auto& entry : s.entries) largest = std::max(largest, entry.relative);
    if (m == &matched) {
      // Exactly zero in exact arithmetic; rounding eps * cond(K) (cond ~ 1e3 here) ~ 1e-13.
      EXPECT_LT(largest, 1e-10);
    } else {
      // The over-constrained wrench moves by percent when a transducer stiffness is doubled.
      EXPECT_GT(largest, 1e-3);
    }
  }
}

// ---- large deflection ------------------------------------------------------------------

TEST(LargeDeflection, GradientIsTheDerivativeOfThePotential) {
  Model model(
      isowrench::WithTransducerStiffness(Load("rat_hindlimb_6dof.urdf").description(),
                                         (Vector6d() << 1e3, 2e3, 3e3, 1, 2, 0.5).finished()));
  const Eigen::VectorXd q0 = model.nominal_posture();
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-0.05, 0.05);
  Eigen::VectorXd theta = q0;
  for (int i = 0; i < theta.size(); ++i) theta[i] += u(rng);
  Eigen::VectorXd g = isowrench::LargeDeflectionGradient(model, q0, theta, 0, 1.0);
  const double h = 1e-6;
  for (int i = 0; i < theta.size(); ++i) {
    Eigen::VectorXd tp = theta, tm = theta;
    tp[i] += h;
    tm[i] -= h;
    double Up = 0, Um = 0;
    isowrench::LargeDeflectionGradient(model, q0, tp, 0, 1.0, &Up);
    isowrench::LargeDeflectionGradient(model, q0, tm, 0, 1.0, &Um);
    // Central difference: truncation h^2 |U'''| ~ 1e-12, rounding eps |U| / h ~ 1e-11.
    EXPECT_NEAR((Up - Um) / (2 * h), g[i], 1e-8 + 1e-6 * g.cwiseAbs().maxCoeff()) << "joint " << i;
  }
}

TEST(LargeDeflection, ConvergesToLinearWithErrorQuadraticInDisplacement) {
  Model base = Load("rat_hindlimb_5dof.urdf");
  std::vector<double> displacement, dtheta_error, wrench_error;
  for (double k : {1e3, 1e4, 1e5}) {
    // S_t scaled as a whole: the linear W is unchanged (identity 4), the motion shrinks as 1/k.
    Model model(isowrench::WithTransducerStiffness(base.description(), Vector6d::Constant(k)));
    auto r = isowrench::SolveLargeDeflection(model, model.nominal_posture(), "GP");
    ASSERT_EQ(r.status, isowrench::LargeDeflectionStatus::kConverged) << r.message;
    displacement.push_back(r.displacement);
    dtheta_error.push_back(r.dtheta_difference);
    wrench_error.push_back(r.wrench_relative_difference);
  }
  // Slopes in log-log: |dtheta_nl - dtheta_lin| = O(d^2), and since W = S_t e with S_t ~ 1/d the
  // relative wrench error is O(d). A second-order term with a third-order correction gives
  // slopes within 0.2 of the ideal over one decade at d <= 3e-3 rad.
  for (size_t i = 0; i + 1 < displacement.size(); ++i) {
    const double dl = std::log(displacement[i] / displacement[i + 1]);
    EXPECT_NEAR(std::log(dtheta_error[i] / dtheta_error[i + 1]) / dl, 2.0, 0.2) << i;
    EXPECT_NEAR(std::log(wrench_error[i] / wrench_error[i + 1]) / dl, 1.0, 0.2) << i;
  }
  // At the stiffest setting the linear answer is good to better than 1e-3 relative.
  EXPECT_LT(wrench_error.back(), 1e-3);
}

TEST(LargeDeflection, PaperLiteralJr3StiffnessDepartsFromLinear) {
  Model base = Load("rat_hindlimb_5dof.urdf");
  Model model(
      isowrench::WithTransducerStiffness(base.description(), isowrench::TransducerPreset("jr3")));
  auto lin = isowrench::EvaluateWrench(model, model.nominal_posture(), "GP");
  EXPECT_FALSE(lin.statics.small_motion_valid);
  auto r = isowrench::SolveLargeDeflection(model, model.nominal_posture(), "GP");
  // Either no equilibrium near the posture, or one far from the linear answer.
  const bool departs = r.status != isowrench::LargeDeflectionStatus::kConverged ||
                       r.wrench_relative_difference > 0.5;
  EXPECT_TRUE(departs) << r.message << " relative difference " << r.wrench_relative_difference;
  EXPECT_GT(r.dtheta_difference, 0.1);
  EXPECT_FALSE(r.message.empty());
}

// ---- locked coordinates: every diagnostic agrees with EvaluateWrench (issue 25) --------------

// urdf/rat_hindlimb_6dof.urdf with knee_rx locked.
Model LockedRat() {
  return Model::FromUrdfFile(std::string(ISOWRENCH_TEST_DATA_DIR) +
                             "/rat_hindlimb_6dof_locked.urdf");
}

// The same model with a description edit applied.
Model Edited(const Model& model,
             const std::function<isowrench::LimbDescription(isowrench::LimbDescription)>& edit) {
  return Model(edit(model.description()));
}

TEST(Locks, ConstraintClassCountsOnlyTheColumnsOfK) {
  Model model = LockedRat();
  const Eigen::VectorXd q = model.nominal_posture();
  const int locked = model.JointIndex("knee_rx");
  ASSERT_TRUE(model.coordinate(locked).locked);
  auto a = isowrench::AnalyzeConstraints(model, q);
  // Independent reference: the scaled J_r without the locked column, by its own SVD.
  isowrench::Data ws(model);
  isowrench::Matrix6Xd J = isowrench::EndpointJacobian(model, ws, q);
  Eigen::MatrixXd Jk(6, 5);
  for (int c = 0, k = 0; c < 6; ++c) {
    if (c != locked) Jk.col(k++) = J.col(c);
  }
  Jk.topRows<3>() /= model.chain_length();
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(Jk);
  int rank = 0;
  for (int i = 0; i < 5; ++i) rank += svd.singularValues()[i] > 1e-9 * svd.singularValues()[0];
  EXPECT_EQ(rank, 5);
  EXPECT_EQ(a.joint_count, 5);
  EXPECT_EQ(a.rank, rank);
  ASSERT_EQ(a.singular_values.size(), 5);
  for (int i = 0; i < 5; ++i) EXPECT_NEAR(a.singular_values[i], svd.singularValues()[i], 1e-12);
  // 5 dofs, 6 restrained, rank 5: over-constrained, and no self-motion (the unlocked 6-dof limb
  // has the femur's axial rotation).
  EXPECT_EQ(a.constraint_class, isowrench::ConstraintClass::kOverConstrained);
  EXPECT_TRUE(a.self_motion.empty());
  EXPECT_EQ(a.locked, std::vector<std::string>{"knee_rx"});
  EXPECT_THAT(a.explanation, HasSubstr("5 joint dofs (1 locked coordinate not counted: knee_rx)"));
  // Spring-free columns: hip rz ry rx and knee rz (knee_ry has a spring, knee_rx is locked).
  EXPECT_EQ(a.free_joint_count, 4);
}

TEST(Locks, SensitivitiesAreDifferencesOfTheWrench) {
  // A stiffness on the locked coordinate must change nothing.
  Model model = Edited(LockedRat(), [](isowrench::LimbDescription d) {
    return isowrench::WithJointStiffness(d, "knee_rx", 2.0);
  });
  const Eigen::VectorXd q = model.nominal_posture();
  auto e = isowrench::EvaluateWrench(model, q, "GP");
  ASSERT_TRUE(e.statics.ok());
  auto s = isowrench::ComputeStiffnessSensitivity(model, e);
  ASSERT_TRUE(s.ok) << s.message;
  const double L = model.chain_length();
  const double scale = ScaledNorm(e.statics.wrench, L);
  bool knee_ry = false;
  for (const auto& entry : s.entries) {
    EXPECT_NE(entry.parameter, "knee_rx");  // locked: its stiffness is no parameter of W
    knee_ry = knee_ry || entry.parameter == "knee_ry";
    // Central difference of EvaluateWrench in log k: step h = 1e-4, truncation h^2/6 |W'''|
    // ~ 1e-9 |W|, rounding eps cond(K) / h ~ 1e-12 cond(K) |W| (cond ~ 1e3..1e7 here).
    auto wrench = [&](double factor) {
      Model edited = Edited(model, [&](isowrench::LimbDescription d) {
        if (entry.kind == "transducer") {
          int dof = 0;
          while (std::string("S_t ") + isowrench::DofName(dof) != entry.parameter) ++dof;
          Vector6d st = model.transducer().stiffness;
          st[dof] *= factor;
          return isowrench::WithTransducerStiffness(d, st);
        }
        return isowrench::WithJointStiffness(d, entry.parameter, entry.stiffness * factor);
      });
      return isowrench::EvaluateWrench(edited, q, "GP").statics.wrench;
    };
    const double h = 1e-4;
    const Vector6d fd = (wrench(std::exp(h)) - wrench(std::exp(-h))) / (2 * h);
    EXPECT_LT(ScaledNorm(entry.dW_dlogk - fd, L), 1e-6 * scale) << entry.parameter;
  }
  EXPECT_TRUE(knee_ry);
  // And the locked coordinate's stiffness changes nothing in EvaluateWrench either.
  Model stiffer = Edited(model, [](isowrench::LimbDescription d) {
    return isowrench::WithJointStiffness(d, "knee_rx", 2e3);
  });
  EXPECT_EQ(isowrench::EvaluateWrench(stiffer, q, "GP").statics.wrench, e.statics.wrench);
}

TEST(Locks, LargeDeflectionLeavesLockedJointsAtZero) {
  Model model = LockedRat();
  const Eigen::VectorXd q = model.nominal_posture();
  const int locked = model.JointIndex("knee_rx");
  auto r = isowrench::SolveLargeDeflection(model, q, "GP");
  ASSERT_EQ(r.status, isowrench::LargeDeflectionStatus::kConverged) << r.message;
  EXPECT_EQ(r.dtheta_nonlinear[locked], 0.0);
  EXPECT_EQ(r.dtheta_linear[locked], 0.0);
  // Balanced 1e7 transducer: motion ~1e-7 rad, so the nonlinear answer is the linear one to
  // O(motion) relative (LargeDeflection.ConvergesToLinearWithErrorQuadraticInDisplacement).
  EXPECT_LT(r.wrench_relative_difference, 1e-5);
  EXPECT_LT(r.dtheta_difference, 1e-9);
}

// For each transducer-axis candidate, the verdict of CompareReleases against EvaluateWrench of
// the model with that dof released, under the balanced and the ATI Mini40 transducer:
// forbidden = K singular; matched = the same W under both; depending on the compliances = not.
void ExpectVerdictsMatchWrench(const Model& model) {
  const Eigen::VectorXd q = model.nominal_posture();
  auto c = isowrench::CompareReleases(model, q, "GP");
  const int columns = static_cast<int>(isowrench::StaticsProblem(model).columns().size());
  const double L = model.chain_length();
  int checked = 0;
  for (const auto& a : c.candidates) {
    if (a.candidate.source != "transducer axis") continue;
    SCOPED_TRACE(a.candidate.name + ": " + a.verdict);
    isowrench::DofMask released = model.transducer().released;
    for (int dof = 0; dof < 6; ++dof) {
      if (a.candidate.name == isowrench::DofName(dof)) released.set(dof);
    }
    ASSERT_EQ(released.count(), model.transducer().released.count() + 1);
    auto under = [&](const char* preset) {
      Model m(isowrench::WithTransducerStiffness(
          isowrench::WithReleasedDofs(model.description(), released),
          isowrench::TransducerPreset(preset)));
      return isowrench::EvaluateWrench(m, q, "GP").statics;
    };
    const isowrench::StaticsResult balanced = under("balanced"), mini40 = under("ati-mini40");
    if (a.self_motion) {
      // Forbidden: the limb moves without loading the transducer, whatever its stiffness.
      EXPECT_LT(balanced.k_rank, columns);
      EXPECT_LT(mini40.k_rank, columns);
    } else {
      ASSERT_TRUE(balanced.ok() && mini40.ok());
      const double difference =
          ScaledNorm(balanced.wrench - mini40.wrench, L) / ScaledNorm(balanced.wrench, L);
      if (!a.internal_wrench) {
        // Matched: W = J_e^-T [tau; 0] whatever S_t; two solves with cond(K) <= 1e8 agree to
        // 1e-7 relative.
        EXPECT_LT(difference, 1e-7);
      } else if (a.spread > 1e-6) {
        // The compliances move W over the range: balanced and Mini40 differ (by percent).
        EXPECT_GT(difference, 1e-4);
      }
    }
    ++checked;
  }
  EXPECT_EQ(checked, 6);
}

TEST(Locks, ReleaseVerdictsMatchTheWrenchUnderTwoTransducers) {
  Model model = LockedRat();
  ExpectVerdictsMatchWrench(model);
  // The verdict on rz differs from the unlocked limb's (urdf/rat_hindlimb_6dof.urdf, knee_rx
  // free and without a spring): there the 5 spring-free joints and the release column make J_e
  // square (6 x 6) and regular: matched, W = J_e^-T [tau; 0] whatever the compliances. With
  // knee_rx locked only 4 spring-free joints remain: 5 columns on 6 rows, one internal wrench
  // direction, and W moves with the compliances.
  auto locked = isowrench::CompareReleases(model, model.nominal_posture(), "GP");
  Model unlocked = Edited(model, [](isowrench::LimbDescription d) {
    return isowrench::WithJointStiffness(isowrench::WithLockedCoordinates(d, {}), "knee_rx", 0.0);
  });
  auto free = isowrench::CompareReleases(unlocked, unlocked.nominal_posture(), "GP");
  auto find = [](const isowrench::ReleaseComparison& c, const std::string& name) {
    for (const auto& a : c.candidates) {
      if (a.candidate.name == name) return a;
    }
    ADD_FAILURE() << "no candidate " << name;
    return isowrench::ReleaseAssessment();
  };
  EXPECT_TRUE(find(locked, "rz").internal_wrench);
  EXPECT_GT(find(locked, "rz").spread, 1e-4);
  EXPECT_FALSE(find(free, "rz").internal_wrench);
  EXPECT_FALSE(find(free, "rz").self_motion);
  EXPECT_LT(find(free, "rz").spread, 1e-6);
  ExpectVerdictsMatchWrench(unlocked);
}

TEST(Locks, WithLockedCoordinatesReplacesTheLocksAndNamesBadNames) {
  Model model = LockedRat();
  Model other = Edited(model, [](isowrench::LimbDescription d) {
    return isowrench::WithLockedCoordinates(d, {"hip_rx", "knee_rz"});
  });
  EXPECT_FALSE(other.coordinate(other.JointIndex("knee_rx")).locked);
  EXPECT_TRUE(other.coordinate(other.JointIndex("hip_rx")).locked);
  EXPECT_TRUE(other.coordinate(other.JointIndex("knee_rz")).locked);
  EXPECT_EQ(isowrench::StaticsProblem(other).LockedNames(),
            (std::vector<std::string>{"hip_rx", "knee_rz"}));
  Model none = Edited(model, [](isowrench::LimbDescription d) {
    return isowrench::WithLockedCoordinates(d, {"none"});
  });
  EXPECT_TRUE(isowrench::StaticsProblem(none).locked_columns().empty());
  EXPECT_THAT([&] { isowrench::WithLockedCoordinates(model.description(), {"kne_rx"}); },
              ThrowsMessage<Error>(HasSubstr("kne_rx")));
}

// ---- what diagnose and releases say agrees with their numbers (issue 25 item 5) ------------

// A planar cat hindlimb with base dofs and an in-plane muscle: over-constrained (fz, mx, my are
// internal wrench directions of the spring-free limb) but W depends on no stiffness.
Model PlanarCat() {
  return Model::FromUrdfFile(std::string(ISOWRENCH_TEST_DATA_DIR) + "/planar_cat_base.urdf");
}

TEST(Diagnosis, ComplianceVerdictFollowsTheSensitivitiesNotTheClass) {
  Model cat = PlanarCat();
  const Eigen::VectorXd q = cat.nominal_posture();
  auto d = isowrench::DiagnoseLimb(cat, q, "gastrocnemius");
  EXPECT_EQ(d.constraints.free_class, isowrench::ConstraintClass::kOverConstrained);
  EXPECT_THAT(d.constraints.explanation, Not(HasSubstr("so W depends on the compliances")));
  EXPECT_FALSE(d.compliance_dependent) << d.compliance_verdict;
  EXPECT_THAT(d.compliance_verdict, HasSubstr("does not depend on any compliance"));
  // Independently: W under other transducers and base stiffnesses (1e3 .. 1e12 N/m) is the same.
  const Vector6d w = d.evaluation.statics.wrench;
  const double L = cat.chain_length();
  for (const char* preset : {"balanced", "ati-mini40"}) {
    for (double k : {1e3, 1e12}) {
      Model other(
          isowrench::WithBaseStiffness(isowrench::WithTransducerStiffness(
                                           cat.description(), isowrench::TransducerPreset(preset)),
                                       k));
      const Vector6d wk = isowrench::EvaluateWrench(other, q, "gastrocnemius").statics.wrench;
      // Rounding of solves with cond(K) up to 1e12 / 1e3 ~ 1e9: 1e-6 relative.
      EXPECT_LT(ScaledNorm(wk - w, L), 1e-6 * ScaledNorm(w, L)) << preset << " " << k;
    }
  }
  // The over-constrained rat limb's W does depend on the compliances, and says so.
  Model rat = Load("rat_hindlimb_5dof.urdf");
  auto r = isowrench::DiagnoseLimb(rat, rat.nominal_posture(), "GP");
  EXPECT_TRUE(r.compliance_dependent);
  EXPECT_THAT(r.compliance_verdict, HasSubstr("W depends on the compliances: S_t"));
  // The classic answer means nothing with base dofs: no internal part against it.
  EXPECT_FALSE(d.classic_meaningful);
  EXPECT_EQ(d.internal_coefficients.size(), 0);
  EXPECT_TRUE(r.classic_meaningful);
}

TEST(Constraints, InternalWrenchDirectionsAreNormalisedOnTheirComponents) {
  for (const Model& model : {PlanarCat(), Load("rat_hindlimb_5dof.urdf"), LockedRat()}) {
    const Eigen::VectorXd q = model.nominal_posture();
    auto a = isowrench::AnalyzeConstraints(model, q);
    ASSERT_FALSE(a.internal_wrench.empty()) << model.name();
    const double L = a.length_scale;
    const isowrench::StaticsProblem problem(model);
    for (const auto& w : a.internal_wrench) {
      SCOPED_TRACE(model.name() + ": " + w.description);
      const double f = w.direction.head<3>().cwiseAbs().maxCoeff();
      const double m = w.direction.tail<3>().cwiseAbs().maxCoeff();
      // Largest force 1 N when forces dominate in the D metric, else largest moment 1 N·m.
      EXPECT_DOUBLE_EQ(f >= m / L ? f : m, 1.0);
      EXPECT_LE(w.direction.cwiseAbs().maxCoeff(), std::max(1.0, 1.0 / L) * (1 + 1e-15));
      // A wrench the joints do not feel: J^T w = 0 on the columns of K (N·m per unit).
      const Eigen::VectorXd feel =
          problem.Reduce(isowrench::Matrix6Xd(a.jacobian)).transpose() * w.direction;
      EXPECT_LT(feel.cwiseAbs().maxCoeff(), 1e-12 * std::max(1.0, L));
      for (int k = 0; k < 6; ++k) {
        const bool touched =
            std::find(w.components.begin(), w.components.end(), k) != w.components.end();
        if (!touched) {
          EXPECT_EQ(w.direction[k], 0.0) << k;
        }
      }
    }
  }
}

TEST(Releases, NoReleaseNeededWhenWDoesNotDependOnTheCompliances) {
  Model cat = PlanarCat();
  auto c = isowrench::CompareReleases(cat, cat.nominal_posture(), "gastrocnemius");
  EXPECT_FALSE(c.release_needed);
  EXPECT_EQ(c.recommended, -1);
  EXPECT_THAT(c.recommendation, HasSubstr("no release needed"));
  EXPECT_LE(c.baseline.spread, 1e-6);
  EXPECT_THAT(c.baseline.verdict, HasSubstr("but W does not depend on the compliances"));
  Model rat = Load("rat_hindlimb_5dof.urdf");
  auto r = isowrench::CompareReleases(rat, rat.nominal_posture(), "GP");
  EXPECT_TRUE(r.release_needed);
  EXPECT_GE(r.recommended, 0);
}

// ---- diagnosis and posture table ---------------------------------------------------------

TEST(Diagnosis, PutsEverythingTogether) {
  Model model = Load("rat_hindlimb_5dof.urdf");
  auto d = isowrench::DiagnoseLimb(model, model.nominal_posture(), "GP");
  EXPECT_EQ(d.constraints.constraint_class, isowrench::ConstraintClass::kOverConstrained);
  EXPECT_TRUE(d.evaluation.statics.ok());
  EXPECT_TRUE(d.sensitivity.ok);
  EXPECT_TRUE(d.large_deflection_run);
  EXPECT_EQ(d.large_deflection.status, isowrench::LargeDeflectionStatus::kConverged);
  // Balanced 1e7 stiffness moves the ankle ~1e-8 m: the linear answer is good to ~1e-6.
  EXPECT_LT(d.large_deflection.wrench_relative_difference, 1e-5);
  // No joint springs: W - pinv(J^T) tau lies entirely in null(J^T) (MODEL.md identities 3, 6).
  ASSERT_EQ(d.internal_coefficients.size(), 1);
  EXPECT_LT(d.internal_residual, 1e-10);
  EXPECT_THAT([&] { isowrench::DiagnoseLimb(model, model.nominal_posture(), "nosuch"); },
              ThrowsMessage<Error>(HasSubstr("nosuch")));
}

TEST(PostureTable, ParsesDegreesAndKeepsUnlistedJoints) {
  Model model = Load("rat_hindlimb_5dof.urdf");
  auto rows = isowrench::ParsePostureTable(
      model, "# comment\nlabel, hip_rz, knee_rx\nA, -100, 5\n\n, -90, 0\n", "mem.csv",
      model.nominal_posture());
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].label, "A");
  EXPECT_EQ(rows[1].label, "row 2");
  EXPECT_NEAR(rows[0].q[model.JointIndex("hip_rz")], Deg(-100), 1e-15);
  EXPECT_NEAR(rows[0].q[model.JointIndex("knee_rx")], Deg(5), 1e-15);
  EXPECT_NEAR(rows[0].q[model.JointIndex("knee_rz")], Deg(105), 1e-15);  // nominal kept
}

TEST(PostureTable, ErrorsNameFileLineAndColumn) {
  Model model = Load("rat_hindlimb_5dof.urdf");
  const Eigen::VectorXd q = model.nominal_posture();
  EXPECT_THAT([&] { isowrench::ParsePostureTable(model, "hip_rz,elbow\n1,2\n", "p.csv", q); },
              ThrowsMessage<Error>(HasSubstr("p.csv:1: column 2 header 'elbow'")));
  EXPECT_THAT(
      [&] { isowrench::ParsePostureTable(model, "hip_rz,knee_rz\n1,abc\n", "p.csv", q); },
      ThrowsMessage<Error>(HasSubstr("p.csv:2: column 2 (knee_rz): 'abc' is not a finite number")));
  EXPECT_THAT([&] { isowrench::ParsePostureTable(model, "hip_rz,knee_rz\n1,nan\n", "p.csv", q); },
              ThrowsMessage<Error>(HasSubstr("'nan' is not a finite number")));
  EXPECT_THAT([&] { isowrench::ParsePostureTable(model, "hip_rz,knee_rz\n1\n", "p.csv", q); },
              ThrowsMessage<Error>(HasSubstr("p.csv:2: 1 values for 2 header columns")));
  EXPECT_THAT([&] { isowrench::ParsePostureTable(model, "hip_rz,hip_rz\n1,1\n", "p.csv", q); },
              ThrowsMessage<Error>(HasSubstr("repeats joint 'hip_rz'")));
  EXPECT_THAT([&] { isowrench::ReadPostureTable(model, "/nonexistent/p.csv", q); },
              ThrowsMessage<Error>(HasSubstr("/nonexistent/p.csv")));
}

}  // namespace
