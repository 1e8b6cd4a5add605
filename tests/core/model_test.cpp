// Tests of include/isowrench/model.hpp: reading the shipped URDFs, description edits that
// must reproduce the shipped variants, URDF round trips and presets.

#include "isowrench/model.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdio>
#include <random>

#include "eigen_compare.hpp"
#include "isowrench/kinematics.hpp"
#include "test_models.hpp"

namespace isowrench_test {
namespace {

using isowrench::JointRole;
using isowrench::LimbDescription;
using isowrench::Model;
using isowrench::Vector6d;
using ::testing::AllOf;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

// Two models of the same mechanism give Jacobians equal up to KDL's rounding of frame products.
constexpr double kSameMechanismTol = 1e-12;

// J_W_E of two models agrees at random postures (same joint count and order).
::testing::AssertionResult SameKinematics(const Model& a, const Model& b, unsigned seed) {
  if (a.dof_count() != b.dof_count()) {
    return ::testing::AssertionFailure() << a.dof_count() << " vs " << b.dof_count() << " dofs";
  }
  isowrench::Data wa(a), wb(b);
  std::mt19937 rng(seed);
  for (int k = 0; k < 5; ++k) {
    const Eigen::VectorXd q = RandomPosture(a, rng);
    auto r = MatricesNear(isowrench::EndpointJacobianWorld(a, wa, q),
                          isowrench::EndpointJacobianWorld(b, wb, q), kSameMechanismTol);
    if (!r) return r;
    r = MatricesNear(isowrench::EndpointPose(a, wa, q).matrix(),
                     isowrench::EndpointPose(b, wb, q).matrix(), kSameMechanismTol);
    if (!r) return r;
  }
  return ::testing::AssertionSuccess();
}

TEST(ShippedModels, HaveTheDocumentedJoints) {
  EXPECT_THAT(LoadModel("rat_hindlimb_5dof.urdf").joint_names(),
              ElementsAre("hip_rz", "hip_ry", "hip_rx", "knee_rz", "knee_rx"));
  EXPECT_THAT(LoadModel("rat_hindlimb_6dof.urdf").joint_names(),
              ElementsAre("hip_rz", "hip_ry", "hip_rx", "knee_rz", "knee_ry", "knee_rx"));
  EXPECT_THAT(LoadModel("rat_hindlimb_5dof_base.urdf").joint_names(),
              ElementsAre("base_x", "base_y", "base_z", "hip_rz", "hip_ry", "hip_rx", "knee_rz",
                          "knee_rx"));
  EXPECT_THAT(LoadModel("planar_2r.urdf").joint_names(), ElementsAre("shoulder", "elbow"));
  EXPECT_THAT(LoadModel("planar_4r.urdf").joint_names(), ElementsAre("j1", "j2", "j3", "j4"));
}

TEST(ShippedModels, RatNominalPostureAndGeometry) {
  const Model rat = LoadModel("rat_hindlimb_5dof.urdf");
  Eigen::VectorXd q(5);
  q << Deg(-110), 0, 0, Deg(105), 0;
  EXPECT_TRUE(MatricesNear(rat.nominal_posture(), q, 1e-15));
  EXPECT_NEAR(rat.chain_length(), 0.031 + 0.041, 1e-15);  // femur + tibia
  EXPECT_NEAR(LoadModel("planar_2r.urdf").chain_length(), 0.55, 1e-15);
  EXPECT_NEAR(LoadModel("planar_4r.urdf").chain_length(), 0.40, 1e-15);
  const auto& t = rat.transducer();
  EXPECT_EQ(t.link, "tibia");
  EXPECT_TRUE(MatricesNear(t.endpoint, Eigen::Vector3d(0.041, 0, 0), 0.0));
  EXPECT_TRUE(t.axes_in_world);
  EXPECT_TRUE(MatricesNear(t.stiffness, Vector6d::Constant(1e7), 0.0));
  EXPECT_TRUE(t.released.none());
  EXPECT_TRUE(MatricesNear(rat.joint_stiffness(), Eigen::VectorXd::Zero(5), 0.0));
  for (int i = 0; i < rat.dof_count(); ++i) EXPECT_EQ(rat.joint(i).role, JointRole::kLimb);
}

TEST(ShippedModels, GracilisPosticusIsThePaperMuscle) {
  const Model rat = LoadModel("rat_hindlimb_5dof.urdf");
  ASSERT_EQ(rat.muscle_count(), 1);
  const isowrench::MuscleSpec& gp = rat.muscle(rat.MuscleIndex("GP"));
  EXPECT_DOUBLE_EQ(gp.max_force, 2.3);
  ASSERT_EQ(gp.path.size(), 2u);
  EXPECT_EQ(gp.path[0].link, "ground");
  EXPECT_TRUE(
      MatricesNear(gp.path[0].position, Eigen::Vector3d(0.01267, -0.010403, -0.00478), 0.0));
  EXPECT_EQ(gp.path[1].link, "tibia");
  EXPECT_TRUE(MatricesNear(gp.path[1].position, Eigen::Vector3d(0.0156, -0.00452, -0.00378), 0.0));
}

TEST(ShippedModels, RolesAndStiffnessesFromIsowrenchTags) {
  const Model base = LoadModel("rat_hindlimb_5dof_base.urdf");
  for (const char* j : {"base_x", "base_y", "base_z"}) {
    const auto& spec = base.joint(base.JointIndex(j));
    EXPECT_EQ(spec.role, JointRole::kBase) << j;
    EXPECT_EQ(spec.type, isowrench::JointType::kPrismatic) << j;
    EXPECT_DOUBLE_EQ(spec.stiffness, 1e5) << j;
  }
  const Model six = LoadModel("rat_hindlimb_6dof.urdf");
  EXPECT_EQ(six.joint(six.JointIndex("knee_ry")).role, JointRole::kExtra);
  Eigen::VectorXd s(6);
  s << 0, 0, 0, 0, 1.0, 0;
  EXPECT_TRUE(MatricesNear(six.joint_stiffness(), s, 0.0));
  const Model planar = LoadModel("planar_2r.urdf");
  const auto& released = planar.transducer().released;
  EXPECT_FALSE(released[isowrench::kX]);
  EXPECT_FALSE(released[isowrench::kY]);
  EXPECT_TRUE(released[isowrench::kZ]);
  EXPECT_TRUE(released[isowrench::kRX]);
  EXPECT_TRUE(released[isowrench::kRY]);
  EXPECT_FALSE(released[isowrench::kRZ]);
}

TEST(Names, RolesAndDofs) {
  EXPECT_STREQ(isowrench::RoleName(JointRole::kLimb), "limb");
  EXPECT_STREQ(isowrench::RoleName(JointRole::kBase), "base");
  EXPECT_STREQ(isowrench::RoleName(JointRole::kExtra), "extra");
  EXPECT_STREQ(isowrench::RoleName(JointRole::kRelease), "release");
  const char* dofs[] = {"x", "y", "z", "rx", "ry", "rz"};
  for (int d = 0; d < 6; ++d) EXPECT_STREQ(isowrench::DofName(d), dofs[d]);
}

TEST(TransducerPresets, MatchModelMd) {
  EXPECT_TRUE(MatricesNear(isowrench::TransducerPreset("balanced"), Vector6d::Constant(1e7), 0.0));
  Vector6d ati, jr3;
  ati << 1.1e7, 1.1e7, 2.0e7, 2.8e3, 2.8e3, 4.0e3;
  jr3 << 0.519, 0.519, 5.279, 0.0054, 0.0054, 0.0015;
  EXPECT_TRUE(MatricesNear(isowrench::TransducerPreset("ati-mini40"), ati, 0.0));
  EXPECT_TRUE(MatricesNear(isowrench::TransducerPreset("jr3"), jr3, 0.0));
  EXPECT_THAT([] { isowrench::TransducerPreset("kistler"); },
              ThrowsMessage<isowrench::Error>(
                  AllOf(HasSubstr("kistler"), HasSubstr("balanced"), HasSubstr("jr3"))));
}

TEST(DescriptionEdits, WithBaseStiffnessReproducesTheBaseUrdf) {
  const Model built(isowrench::WithBaseStiffness(LoadDescription("rat_hindlimb_5dof.urdf"), 1e5));
  const Model shipped = LoadModel("rat_hindlimb_5dof_base.urdf");
  EXPECT_EQ(built.joint_names(), shipped.joint_names());
  EXPECT_TRUE(MatricesNear(built.joint_stiffness(), shipped.joint_stiffness(), 0.0));
  for (int i = 0; i < 3; ++i) EXPECT_EQ(built.joint(i).role, JointRole::kBase);
  EXPECT_TRUE(SameKinematics(built, shipped, 11));
  // On a description that has base joints already, only the stiffness changes.
  const Model again(isowrench::WithBaseStiffness(shipped.description(), 42.0));
  EXPECT_EQ(again.dof_count(), 8);
  EXPECT_DOUBLE_EQ(again.joint(again.JointIndex("base_y")).stiffness, 42.0);
}

TEST(DescriptionEdits, WithExtraJointReproducesTheSixDofKnee) {
  const Model built(isowrench::WithExtraJoint(LoadDescription("rat_hindlimb_5dof.urdf"), "knee_rz",
                                              "knee_ry", Eigen::Vector3d::UnitY(), 1.0));
  const Model shipped = LoadModel("rat_hindlimb_6dof.urdf");
  EXPECT_EQ(built.joint_names(), shipped.joint_names());
  EXPECT_TRUE(MatricesNear(built.joint_stiffness(), shipped.joint_stiffness(), 0.0));
  EXPECT_EQ(built.joint(built.JointIndex("knee_ry")).role, JointRole::kExtra);
  EXPECT_TRUE(SameKinematics(built, shipped, 12));
}

TEST(DofMask, ParsesEverySpellingAndNamesTheBadToken) {
  using isowrench::DofMask;
  // x y z rx ry rz are bits 0..5 (Dof order).
  EXPECT_EQ(DofMask::Parse("rz").bits(), 0x20u);
  EXPECT_EQ(DofMask::Parse("rx,ry").bits(), 0x18u);
  EXPECT_EQ(DofMask::Parse(" rx  ry ").bits(), 0x18u);
  EXPECT_EQ(DofMask::Parse("x, z").bits(), 0x05u);
  EXPECT_TRUE(DofMask::Parse("").none());
  EXPECT_TRUE(DofMask::Parse("none").none());
  EXPECT_EQ(DofMask::FromNames({"y", "rx"}), (DofMask{"rx", "y"}));
  EXPECT_EQ(DofMask::All().count(), 6);
  EXPECT_EQ((~DofMask{"rz"}).bits(), 0x1fu);
  EXPECT_EQ((~DofMask{"rz"}).count(), 5);
  EXPECT_EQ(DofMask::Parse("ry,x").ToString(), "x,ry");
  EXPECT_EQ(DofMask{}.ToString(" "), "none");
  EXPECT_EQ(DofMask::Parse("rz y").names(), (std::vector<std::string>{"y", "rz"}));
  DofMask m;
  m.set(isowrench::kRY).set(isowrench::kZ).set(isowrench::kRY, false);
  EXPECT_TRUE(m[isowrench::kZ]);
  EXPECT_FALSE(m[isowrench::kRY]);
  EXPECT_THAT([] { DofMask::Parse("rx,rw"); }, ThrowsMessage<isowrench::Error>(HasSubstr("'rw'")));
  EXPECT_THAT([] { DofMask::FromNames({"X"}); }, ThrowsMessage<isowrench::Error>(HasSubstr("'X'")));
}

TEST(DescriptionEdits, ReleasedDofsStiffnessAndTransducer) {
  const LimbDescription d = LoadDescription("rat_hindlimb_5dof.urdf");
  const LimbDescription r = isowrench::WithReleasedDofs(d, {"rz", "x"});
  EXPECT_EQ(r.transducer.released.bits(), (1u << isowrench::kX) | (1u << isowrench::kRZ));
  EXPECT_TRUE(isowrench::WithReleasedDofs(r, {}).transducer.released.none());
  const Model k(isowrench::WithJointStiffness(d, "knee_rx", 3.5));
  EXPECT_DOUBLE_EQ(k.joint_stiffness()[k.JointIndex("knee_rx")], 3.5);
  Vector6d s;
  s << 1, 2, 3, 4, 5, 6;
  EXPECT_TRUE(MatricesNear(isowrench::WithTransducerStiffness(d, s).transducer.stiffness, s, 0.0));
  // Edits return copies: the input is unchanged.
  EXPECT_TRUE(MatricesNear(d.transducer.stiffness, Vector6d::Constant(1e7), 0.0));
}

void ExpectSameDescription(const LimbDescription& a, const LimbDescription& b) {
  EXPECT_EQ(a.name, b.name);
  EXPECT_EQ(a.root_link, b.root_link);
  EXPECT_EQ(a.links, b.links);
  ASSERT_EQ(a.joints.size(), b.joints.size());
  for (size_t i = 0; i < a.joints.size(); ++i) {
    const auto& ja = a.joints[i];
    const auto& jb = b.joints[i];
    EXPECT_EQ(ja.name, jb.name);
    EXPECT_EQ(ja.type, jb.type) << ja.name;
    EXPECT_EQ(ja.parent_link, jb.parent_link) << ja.name;
    EXPECT_EQ(ja.child_link, jb.child_link) << ja.name;
    EXPECT_TRUE(MatricesNear(ja.origin.matrix(), jb.origin.matrix(), 1e-15)) << ja.name;
    EXPECT_TRUE(MatricesNear(ja.axis, jb.axis, 1e-15)) << ja.name;
    EXPECT_EQ(ja.role, jb.role) << ja.name;
    EXPECT_DOUBLE_EQ(ja.stiffness, jb.stiffness) << ja.name;
  }
  ASSERT_EQ(a.muscles.size(), b.muscles.size());
  for (size_t m = 0; m < a.muscles.size(); ++m) {
    EXPECT_EQ(a.muscles[m].name, b.muscles[m].name);
    EXPECT_DOUBLE_EQ(a.muscles[m].max_force, b.muscles[m].max_force);
    ASSERT_EQ(a.muscles[m].path.size(), b.muscles[m].path.size());
    for (size_t p = 0; p < a.muscles[m].path.size(); ++p) {
      EXPECT_EQ(a.muscles[m].path[p].link, b.muscles[m].path[p].link);
      EXPECT_TRUE(MatricesNear(a.muscles[m].path[p].position, b.muscles[m].path[p].position, 0.0));
    }
  }
  EXPECT_EQ(a.transducer.link, b.transducer.link);
  EXPECT_TRUE(MatricesNear(a.transducer.endpoint, b.transducer.endpoint, 0.0));
  EXPECT_TRUE(MatricesNear(a.transducer.rotation, b.transducer.rotation, 1e-15));
  EXPECT_EQ(a.transducer.axes_in_world, b.transducer.axes_in_world);
  EXPECT_TRUE(MatricesNear(a.transducer.stiffness, b.transducer.stiffness, 0.0));
  EXPECT_EQ(a.transducer.released, b.transducer.released);
  ASSERT_EQ(a.nominal_posture.size(), b.nominal_posture.size());
  for (size_t i = 0; i < a.nominal_posture.size(); ++i) {
    EXPECT_EQ(a.nominal_posture[i].first, b.nominal_posture[i].first);
    EXPECT_NEAR(a.nominal_posture[i].second, b.nominal_posture[i].second, 1e-15);
  }
}

class RoundTrip : public ::testing::TestWithParam<std::string> {};

TEST_P(RoundTrip, WriteThenReadGivesAnEqualDescription) {
  const LimbDescription d = LoadDescription(GetParam());
  const LimbDescription back =
      isowrench::ReadUrdfString(isowrench::WriteUrdfString(d), "round-trip");
  ExpectSameDescription(d, back);
  EXPECT_TRUE(SameKinematics(Model(d), Model(back), 13));
}

TEST_P(RoundTrip, WriteUrdfFileThenReadUrdfFile) {
  const LimbDescription d = isowrench::WithReleasedDofs(
      isowrench::WithJointStiffness(LoadDescription(GetParam()),
                                    Model(LoadDescription(GetParam())).joint_names().back(), 2.5),
      {"ry"});
  const std::string path = ::testing::TempDir() + "isowrench_roundtrip_" + GetParam();
  isowrench::WriteUrdfFile(d, path);
  ExpectSameDescription(d, isowrench::ReadUrdfFile(path));
  std::remove(path.c_str());
}

INSTANTIATE_TEST_SUITE_P(Urdfs, RoundTrip, ::testing::ValuesIn(ShippedUrdfs()),
                         [](const ::testing::TestParamInfo<std::string>& info) {
                           return info.param.substr(0, info.param.find('.'));
                         });

TEST(Model, CopiesShareTheSameModel) {
  const Model a = LoadModel("rat_hindlimb_6dof.urdf");
  const Model b = a;  // NOLINT(performance-unnecessary-copy-initialization)
  EXPECT_EQ(&a.impl(), &b.impl());
  EXPECT_EQ(b.name(), "rat_hindlimb_6dof");
}

TEST(Model, LookupsNameTheKnownEntries) {
  const Model rat = LoadModel("rat_hindlimb_5dof.urdf");
  EXPECT_EQ(rat.JointIndex("knee_rz"), 3);
  EXPECT_THAT([&] { rat.JointIndex("ankle_rz"); },
              ThrowsMessage<isowrench::Error>(AllOf(HasSubstr("ankle_rz"), HasSubstr("knee_rz"))));
  EXPECT_THAT([&] { rat.MuscleIndex("TA"); },
              ThrowsMessage<isowrench::Error>(AllOf(HasSubstr("TA"), HasSubstr("GP"))));
}

}  // namespace
}  // namespace isowrench_test
