// Muscle path point offsets (SetPathPointOffsets, engine.hpp) and the uncertainty inputs built on
// them (point:<muscle>:<index>[:<axis>]), and uncertainty studies of muscles with a force model.
// References are independent of the hook: a Model rebuilt with its points actually moved, first-
// order propagation through central differences of such rebuilt models, and closed forms (W
// affine in the activation for a rigid tendon, linear in max_force).

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "../fast/large_chain.hpp"
#include "input_fixture.hpp"
#include "isowrench/engine.hpp"
#include "isowrench/error.hpp"
#include "isowrench/io.hpp"
#include "isowrench/kinematics.hpp"
#include "isowrench/muscle.hpp"
#include "isowrench/uncertainty.hpp"

namespace isowrench {
namespace {

using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

Model PointsRat5() {
  return Model::FromUrdfFile(std::string(ISOWRENCH_TEST_URDF_DIR) + "/rat_hindlimb_5dof.urdf");
}
Model TestModel(const std::string& file) {
  return Model::FromUrdfFile(std::string(ISOWRENCH_TEST_DATA_DIR) + "/" + file);
}

// A leg whose muscle has a conditional point and a point with two moving components (x follows
// the knee, z the hip), as tests/core/path_point_test.cpp.
Model MovingLeg() {
  return Model(ReadUrdfString(R"(<?xml version="1.0"?>
<robot name="moving_leg" xmlns:isowrench="urn:isowrench:urdf:1">
  <link name="ground"/> <link name="thigh"/> <link name="shank"/> <link name="foot"/>
  <joint name="hip" type="continuous">
    <parent link="ground"/> <child link="thigh"/> <axis xyz="0 0 1"/>
  </joint>
  <joint name="knee" type="revolute">
    <parent link="thigh"/> <child link="shank"/> <origin xyz="0.03 0 0"/> <axis xyz="0 0 1"/>
    <limit lower="-2" upper="0.5" effort="1" velocity="1"/>
  </joint>
  <joint name="ankle" type="fixed">
    <parent link="shank"/> <child link="foot"/> <origin xyz="0.04 0 0"/>
  </joint>
  <isowrench:transducer link="foot" xyz="0 0 0" stiffness="1e4 1e4 1e4 10 10 10"/>
  <isowrench:muscle name="M" max_force="2">
    <isowrench:point link="ground" xyz="-0.01 0.008 0"/>
    <isowrench:point link="thigh" xyz="0.02 0.006 0.001" active_coordinate="knee" active_range="-1.2 -0.3"/>
    <isowrench:point link="shank" xyz="0 0.004 0">
      <isowrench:moving axis="x" coordinate="knee">
        <isowrench:piecewise_linear x="-2 -0.5 0.5" y="0.010 0.016 0.012"/>
      </isowrench:moving>
      <isowrench:moving axis="z" coordinate="hip">
        <isowrench:linear slope="0.001" intercept="0.002"/>
      </isowrench:moving>
    </isowrench:point>
  </isowrench:muscle>
</robot>
)",
                              "moving.urdf"));
}

// The model with muscle `muscle`'s path point i at position + offsets.col(i): the independent
// reference (nothing of the hook in it).
Model Moved(const Model& model, int muscle, const Eigen::Matrix3Xd& offsets) {
  LimbDescription d = model.description();
  std::vector<PathPoint>& path = d.muscles[static_cast<size_t>(muscle)].path;
  for (size_t i = 0; i < path.size(); ++i) path[i].position += offsets.col(static_cast<int>(i));
  return Model(d);
}

// Offsets of a few mm, different per point and axis, none along a moving component's axis (a
// moving component replaces that coordinate of `position`, so the rebuilt model could not move
// it there).
Eigen::Matrix3Xd SomeOffsets(const Model& model, int muscle, double mm) {
  const std::vector<PathPoint>& path = model.muscle(muscle).path;
  Eigen::Matrix3Xd o(3, static_cast<int>(path.size()));
  for (int i = 0; i < o.cols(); ++i) {
    for (int a = 0; a < 3; ++a) o(a, i) = 1e-3 * mm * std::sin(1.0 + 2.3 * i + 0.7 * a);
    for (const MovingComponent& c : path[static_cast<size_t>(i)].moving) o(c.axis, i) = 0.0;
  }
  return o;
}

struct OffsetCase {
  std::string label;
  Model model;
  int muscle;
  Eigen::VectorXd q;
};

std::vector<OffsetCase> OffsetCases() {
  std::vector<OffsetCase> cases;
  const Model rat = PointsRat5();
  cases.push_back({"rat5 GP (the plain kernel)", rat, 0, rat.nominal_posture()});
  const Model moving = MovingLeg();
  Eigen::VectorXd q(2);
  q << 0.4, -0.8;  // the conditional point active, the moving ones inside their range
  cases.push_back({"moving and conditional points", moving, 0, q});
  const Model wrap = TestModel("planar_2r_wrap.urdf");
  cases.push_back(
      {"a wrapped muscle (cylinder)", wrap, wrap.MuscleIndex("extensor"), wrap.nominal_posture()});
  const Model force = TestModel("force_model_limb.urdf");
  cases.push_back({"millard2012, compliant tendon", force, force.MuscleIndex("GP_compliant"),
                   force.nominal_posture()});
  large_chain::Options o;
  o.coordinates = 20;  // more than kSmallJoints: the large workspace
  const Model large(large_chain::Description(o));
  Eigen::VectorXd ql = Eigen::VectorXd::Constant(large.dof_count(), 0.1);
  cases.push_back({"a large chain (coupled)", large, 0, ql});
  return cases;
}

TEST(PathPointOffsets, EqualAModelRebuiltWithThePointsMoved) {
  for (const OffsetCase& c : OffsetCases()) {
    SCOPED_TRACE(c.label);
    const Eigen::Matrix3Xd offsets = SomeOffsets(c.model, c.muscle, 1.5);
    const Model moved = Moved(c.model, c.muscle, offsets);
    const StiffnessSet stiffness = c.model.model_stiffness();
    Data data(c.model), reference_data(moved), fresh(c.model);
    const WrenchResult before = Evaluate(c.model, data, c.q, c.muscle, stiffness, 0.7);
    SetPathPointOffsets(c.model, data, c.muscle, offsets);
    const WrenchResult w = Evaluate(c.model, data, c.q, c.muscle, stiffness, 0.7);
    const WrenchResult ref = Evaluate(moved, reference_data, c.q, c.muscle, stiffness, 0.7);
    ASSERT_EQ(w.status, ref.status);
    ASSERT_EQ(ref.status, StaticsStatus::kOk);
    // The points do move the wrench (else the comparison below says nothing).
    EXPECT_GT((ref.wrench - before.wrench).norm(), 1e-3 * ref.wrench.norm());
    EXPECT_LE((w.wrench - ref.wrench).norm(), 1e-10 * ref.wrench.norm());
    EXPECT_NEAR(data.muscle_length(), reference_data.muscle_length(), 1e-15);
    EXPECT_LE((Eigen::VectorXd(data.tau()) - Eigen::VectorXd(reference_data.tau())).norm(),
              1e-10 * Eigen::VectorXd(reference_data.tau()).norm());
    // The kinematics functions through this Data see the moved points too.
    const std::vector<Eigen::Vector3d> path = MusclePathPoints(c.model, data, c.q, c.muscle);
    const std::vector<Eigen::Vector3d> path_ref =
        MusclePathPoints(moved, reference_data, c.q, c.muscle);
    ASSERT_EQ(path.size(), path_ref.size());
    for (size_t i = 0; i < path.size(); ++i) EXPECT_LE((path[i] - path_ref[i]).norm(), 1e-15);
    // Another muscle of the same Data keeps its points; ClearPathPointOffsets restores the
    // model's to the bit.
    for (int other = 0; other < c.model.muscle_count(); ++other) {
      if (other == c.muscle) continue;
      const WrenchResult a = Evaluate(c.model, data, c.q, other, stiffness);
      const WrenchResult b = Evaluate(c.model, fresh, c.q, other, stiffness);
      EXPECT_EQ(a.status, b.status);
      EXPECT_EQ(a.wrench, b.wrench) << "muscle " << other;
    }
    ClearPathPointOffsets(data);
    const WrenchResult after = Evaluate(c.model, data, c.q, c.muscle, stiffness, 0.7);
    EXPECT_EQ(after.wrench, before.wrench);
    // Zero offsets: the Data's copy of the muscle runs the same kernel, the same bits.
    SetPathPointOffsets(c.model, data, c.muscle,
                        Eigen::Matrix3Xd::Zero(3, static_cast<int>(offsets.cols())));
    const WrenchResult zero = Evaluate(c.model, data, c.q, c.muscle, stiffness, 0.7);
    EXPECT_EQ(zero.wrench, before.wrench);
  }
}

TEST(PathPointOffsets, BadOffsetsAreErrors) {
  const Model model = PointsRat5();
  Data data(model);
  EXPECT_THAT([&] { SetPathPointOffsets(model, data, 0, Eigen::Matrix3Xd::Zero(3, 3)); },
              ThrowsMessage<Error>(HasSubstr("muscle 'GP' has 2 path points, got offsets for 3")));
  Eigen::Matrix3Xd nan = Eigen::Matrix3Xd::Zero(3, 2);
  nan(1, 1) = std::nan("");
  EXPECT_THAT([&] { SetPathPointOffsets(model, data, 0, nan); },
              ThrowsMessage<Error>(HasSubstr("offset is not finite")));
  EXPECT_THAT([&] { SetPathPointOffsets(model, data, 3, Eigen::Matrix3Xd::Zero(3, 2)); },
              ThrowsMessage<Error>(HasSubstr("muscle index 3 is out of range")));
  const Model other = TestModel("planar_2r_wrap.urdf");
  EXPECT_THAT([&] { SetPathPointOffsets(other, data, 0, Eigen::Matrix3Xd::Zero(3, 2)); },
              ThrowsMessage<Error>(HasSubstr("this Data was made for model 'rat_hindlimb_5dof'")));
}

// One point axis of a study: the point, the axis, sd (mm).
struct PointAxis {
  int point, axis;
  double sd_mm;
};

// Monte Carlo of path point perturbations against first-order propagation J_p Sigma J_p^T, J_p
// by central differences of the engine on models rebuilt with the point moved (no hook).
// x0: the axes' central offsets (m; empty: 0).
void ExpectFirstOrder(const Model& model, const std::string& muscle,
                      const std::vector<PointAxis>& axes, const UncertaintySpec& spec,
                      Eigen::VectorXd x0 = Eigen::VectorXd()) {
  const int mu = model.MuscleIndex(muscle);
  const Eigen::VectorXd q0 = model.nominal_posture();
  UncertaintyOptions options;
  options.samples = 6000;
  options.sobol = false;
  const UncertaintyResult r = RunUncertainty(model, muscle, q0, spec, options);
  const PostureUncertainty& p = r.postures[0];
  ASSERT_EQ(p.valid, options.samples);
  const int k = static_cast<int>(axes.size());
  if (x0.size() == 0) x0 = Eigen::VectorXd::Zero(k);
  const int n_points = static_cast<int>(model.muscle(mu).path.size());
  auto reading = [&](const Eigen::VectorXd& x) {
    Eigen::Matrix3Xd o = Eigen::Matrix3Xd::Zero(3, n_points);
    for (int i = 0; i < k; ++i)
      o(axes[static_cast<size_t>(i)].axis, axes[static_cast<size_t>(i)].point) += x0[i];
    for (int i = 0; i < k; ++i)
      o(axes[static_cast<size_t>(i)].axis, axes[static_cast<size_t>(i)].point) += x[i];
    const Model moved = Moved(model, mu, o);
    Data data(moved);
    return Evaluate(moved, data, q0, mu, moved.model_stiffness()).wrench;
  };
  Eigen::VectorXd sd(k);
  for (int i = 0; i < k; ++i) sd[i] = 1e-3 * axes[static_cast<size_t>(i)].sd_mm;
  Eigen::MatrixXd Jp(6, k);
  for (int i = 0; i < k; ++i) {
    Eigen::VectorXd dx = Eigen::VectorXd::Zero(k);
    dx[i] = 1e-2 * sd[i];
    Jp.col(i) = (reading(dx) - reading(-dx)) / (2 * dx[i]);
  }
  const Eigen::MatrixXd covariance =
      Jp * sd.array().square().matrix().asDiagonal() * Jp.transpose();
  const Vector6d w0 = reading(Eigen::VectorXd::Zero(k));
  for (int i = 0; i < 6; ++i)
    EXPECT_NEAR(p.nominal[static_cast<size_t>(i)], w0[i], 1e-10 * w0.norm());
  const double n = static_cast<double>(p.valid);
  int compared = 0;
  for (int i = 0; i < 6; ++i) {
    const double sd_ref = std::sqrt(covariance(i, i));
    const QuantityStatistics& s = p.statistics[static_cast<size_t>(i)];
    if (sd_ref < 1e-6 * w0.norm()) continue;  // a component the points do not move
    ++compared;
    EXPECT_NEAR(s.sd, sd_ref, 5 * sd_ref / std::sqrt(2 * n) + 0.01 * sd_ref) << "component " << i;
    EXPECT_NEAR(s.mean, w0[i], 5 * sd_ref / std::sqrt(n) + 1e-3 * sd_ref) << "component " << i;
  }
  EXPECT_GE(compared, 2);
  // |f| and |m| (the covariance between components): gradient of the norm times J_p.
  for (int part = 0; part < 2; ++part) {
    const Eigen::Vector3d v0 = w0.segment<3>(3 * part);
    const Eigen::RowVectorXd g = v0.transpose() / v0.norm() * Jp.middleRows<3>(3 * part);
    const double sd_ref =
        std::sqrt((g * sd.array().square().matrix().asDiagonal() * g.transpose())(0, 0));
    const QuantityStatistics& s = p.statistics[static_cast<size_t>(12 + part)];
    EXPECT_NEAR(s.sd, sd_ref, 5 * sd_ref / std::sqrt(2 * n) + 0.01 * sd_ref) << "|f|, |m| " << part;
  }
}

TEST(UncertaintyPoints, AFitsAttachmentIsSampledAsPointOffsets) {
  // --from-fit: attachment:GP:0 (dx dy dz mm, the identification's MuscleSpec::path move) at
  // its estimate (0.5, 0, -0.3) mm with its standard errors: the nominal is the model rebuilt
  // with the point there, the sds the first-order propagation around it.
  const Model model = PointsRat5();
  const std::string path = ::testing::TempDir() + "/attachment_fit.json";
  {
    std::ofstream out(path);
    out << R"({"model": "rat_hindlimb_5dof", "chosen": [
      {"effect": "attachment:GP:0", "parameters": [
        {"name": "dx", "value": 0.5, "standard_error": 0.1, "log10_standard_error": 0, "unit": "mm"},
        {"name": "dy", "value": 0, "standard_error": 0.06, "log10_standard_error": 0, "unit": "mm"},
        {"name": "dz", "value": -0.3, "standard_error": 0.08, "log10_standard_error": 0, "unit": "mm"}]}],
      "correlations": {"parameters": ["attachment:GP:0.dx", "attachment:GP:0.dy", "attachment:GP:0.dz"],
                       "matrix": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]}})";
  }
  UncertaintySpec spec;
  spec.has_fit = true;
  spec.fit = ReadFitUncertainty(path, model);
  std::remove(path.c_str());
  Eigen::VectorXd x0(3);
  x0 << 0.5e-3, 0.0, -0.3e-3;
  ExpectFirstOrder(model, "GP", {{0, 0, 0.1}, {0, 1, 0.06}, {0, 2, 0.08}}, spec, x0);
}

TEST(UncertaintyPoints, SmallPerturbationsMatchFirstOrderPropagationThroughRebuiltModels) {
  {
    SCOPED_TRACE("rat5 GP: origin on three axes, insertion along y");
    UncertaintySpec spec;
    spec.inputs.push_back(Input("point:GP:0", InputDistribution::kNormal, {0.1, 0.06, 0.08}));
    spec.inputs.push_back(Input("point:GP:1:y", InputDistribution::kNormal, {0.05}));
    ExpectFirstOrder(PointsRat5(), "GP", {{0, 0, 0.1}, {0, 1, 0.06}, {0, 2, 0.08}, {1, 1, 0.05}},
                     spec);
  }
  {
    SCOPED_TRACE("a wrapped muscle: the attachments move, the cylinder stays");
    UncertaintySpec spec;
    spec.inputs.push_back(Input("point:extensor:0", InputDistribution::kNormal, {0.2}));
    spec.inputs.push_back(Input("point:extensor:1:x", InputDistribution::kNormal, {0.3}));
    ExpectFirstOrder(TestModel("planar_2r_wrap.urdf"), "extensor",
                     {{0, 0, 0.2}, {0, 1, 0.2}, {0, 2, 0.2}, {1, 0, 0.3}}, spec);
  }
}

std::string Bits(const UncertaintyResult& r, const Model& model) {
  UncertaintyResult copy = r;
  copy.seconds = 0;
  return UncertaintyJson(copy, model);
}

TEST(UncertaintyPoints, SameBitsOnOneTwoAndFourThreadsAndAnyPartition) {
  const Model model = PointsRat5();
  UncertaintySpec spec;
  spec.inputs.push_back(Input("point:GP:0", InputDistribution::kNormal, {1.0}));
  spec.inputs.push_back(Input("point:GP:1:z", InputDistribution::kUniform, {}, -1, 1.5));
  spec.inputs.push_back(Input("angle:knee_rz", InputDistribution::kNormal, {2.0}));
  spec.inputs.push_back(Input("transducer_stiffness:x", InputDistribution::kLogNormal, {0.3}));
  UncertaintyOptions options;
  options.samples = 2 * kUncertaintyBlockSamples + 77;
  options.threads = 1;
  const std::string reference =
      Bits(RunUncertainty(model, "GP", model.nominal_posture(), spec, options), model);
  for (int threads : {2, 4}) {
    options.threads = threads;
    EXPECT_EQ(Bits(RunUncertainty(model, "GP", model.nominal_posture(), spec, options), model),
              reference)
        << threads << " threads";
  }
  const UncertaintyStudy study(model, "GP", model.nominal_posture(), spec, options);
  std::vector<UncertaintyPartial> parts;
  for (auto [a, b] : {std::pair<long, long>{1, 3}, {0, 1}})
    parts.push_back(UncertaintyPartial::FromBytes(RunUncertaintyBlocks(study, a, b, 2).ToBytes()));
  EXPECT_EQ(Bits(FinishUncertainty(study, parts), model), reference);
  // The points matter: another seed gives other numbers, and so does the study without them.
  UncertaintySpec without = spec;
  without.inputs.erase(without.inputs.begin(), without.inputs.begin() + 2);
  EXPECT_NE(Bits(RunUncertainty(model, "GP", model.nominal_posture(), without, options), model),
            reference);
}

TEST(UncertaintyPoints, BadPointInputsAreErrorsNamingThem) {
  const Model model = TestModel("force_model_limb.urdf");
  auto run = [&](std::vector<UncertainInput> inputs) {
    UncertaintySpec spec;
    spec.inputs = std::move(inputs);
    UncertaintyStudy study(model, "GP_rigid", model.nominal_posture(), spec, UncertaintyOptions{});
  };
  auto one = [&](const std::string& name, std::vector<double> sd = {1}) {
    run({Input(name, InputDistribution::kNormal, std::move(sd))});
  };
  EXPECT_THAT([&] { one("point:GP_rigd:0"); },
              ThrowsMessage<Error>(HasSubstr(
                  "uncertain input 'point:GP_rigd:0': unknown muscle 'GP_rigd' (did you mean "
                  "'GP_rigid'?)")));
  EXPECT_THAT([&] { one("point:GP_thelen:0"); },
              ThrowsMessage<Error>(HasSubstr("the study is of muscle 'GP_rigid'; a path point of "
                                             "'GP_thelen' does not change its wrench")));
  EXPECT_THAT([&] { one("point:GP_rigid:2"); },
              ThrowsMessage<Error>(HasSubstr(
                  "unknown path point '2' (did you mean '1'?): muscle 'GP_rigid' has 2 path "
                  "points, 0 (origin) to 1 (insertion)")));
  EXPECT_THAT([&] { one("point:GP_rigid:first"); },
              ThrowsMessage<Error>(HasSubstr("unknown path point 'first'")));
  EXPECT_THAT([&] { one("point:GP_rigid:1:w"); },
              ThrowsMessage<Error>(HasSubstr("unknown axis 'w'")));
  EXPECT_THAT([&] { one("point:GP_rigid:1:xx"); },
              ThrowsMessage<Error>(HasSubstr("unknown axis 'xx' (did you mean 'x'?)")));
  EXPECT_THAT([&] { one("point:GP_rigid"); },
              ThrowsMessage<Error>(HasSubstr("name a path point as point:<muscle>:<index>")));
  EXPECT_THAT([&] { one("point:GP_rigid:0", {-0.5}); },
              ThrowsMessage<Error>(HasSubstr("sd -0.5 must be finite and >= 0")));
  EXPECT_THAT(
      [&] {
        one("point:GP_rigid:0", {1, 2});
      },
      ThrowsMessage<Error>(HasSubstr("sd has 2 values; give 1 or 3")));
  EXPECT_THAT(
      [&] {
        run({Input("point:GP_rigid:0", InputDistribution::kNormal, {1}),
             Input("point:GP_rigid:0:y", InputDistribution::kNormal, {1})});
      },
      ThrowsMessage<Error>(HasSubstr("'point:GP_rigid:0' and 'point:GP_rigid:0:y' both move path "
                                     "point 0 of 'GP_rigid' along y")));
  EXPECT_THAT([&] { one("point:GP_rigid:0", {}); }, ThrowsMessage<Error>(HasSubstr("needs sd")));
  EXPECT_THAT([&] { run({Input("point:GP_rigid:0", InputDistribution::kLogNormal, {0.1})}); },
              ThrowsMessage<Error>(HasSubstr("distribution lognormal is not available for it")));
  // The command-line syntax reads the name up to '='.
  const UncertainInput parsed = ParseUncertainInput("point:GP_rigid:1:z=normal:0.5");
  EXPECT_EQ(parsed.name, "point:GP_rigid:1:z");
  EXPECT_EQ(parsed.sd, std::vector<double>{0.5});
}

// ---- force models ----

TEST(UncertaintyForceModels, MaxForceScalesTheWrenchOfEveryForceModel) {
  // The study multiplies W by the max_force factor: the force models' F is max_force times a
  // function of (L_MT, a) (the equilibrium's every term scales with it). Checked against models
  // rebuilt with max_force x 1.3 (an independent evaluation), then the study's sd against the
  // closed form sd(fx) = 0.1 |fx0|.
  const Model model = TestModel("force_model_limb.urdf");
  for (const char* name : {"GP_compliant", "GP_rigid", "GP_thelen"}) {
    SCOPED_TRACE(name);
    const int mu = model.MuscleIndex(name);
    const Eigen::VectorXd q = model.nominal_posture();
    LimbDescription d = model.description();
    d.muscles[static_cast<size_t>(mu)].max_force *= 1.3;
    const Model stronger(d);
    Data a(model), b(stronger);
    const Vector6d w = Evaluate(model, a, q, mu, model.model_stiffness(), 0.6).wrench;
    const Vector6d w13 = Evaluate(stronger, b, q, mu, stronger.model_stiffness(), 0.6).wrench;
    ASSERT_GT(w.norm(), 0.0);
    EXPECT_LE((w13 - 1.3 * w).norm(), 1e-9 * w.norm());

    UncertaintySpec spec;
    spec.inputs.push_back(Input("max_force", InputDistribution::kNormal, {0.1}));
    UncertaintyOptions options;
    options.samples = 4000;
    options.activation = 0.6;
    const UncertaintyResult r = RunUncertainty(model, name, q, spec, options);
    const PostureUncertainty& p = r.postures[0];
    ASSERT_EQ(p.valid, p.samples);
    const double n = static_cast<double>(p.samples);
    for (int i = 0; i < 6; ++i) {
      EXPECT_NEAR(p.nominal[static_cast<size_t>(i)], w[i], 1e-12 * w.norm());
      const double sd = 0.1 * std::abs(w[i]);
      EXPECT_NEAR(p.statistics[static_cast<size_t>(i)].sd, sd, 5 * sd / std::sqrt(2 * n) + 1e-12)
          << i;
    }
  }
}

TEST(UncertaintyForceModels, ActivationOfARigidTendonGivesTheAffineClosedForm) {
  // Rigid tendon: F = max_force (a f_L(l) + f_P(l)) cos(phi), l fixed by L_MT, so W(a) is affine
  // in a: for a uniform on [0.2, 0.8], mean W(0.5), sd |W(0.8) - W(0.2)| / sqrt(12), and the
  // p-quantile of a component is W(0.2 + 0.6 p) (or 1 - p where it decreases). The constant
  // model's shortcut (W proportional to a) would give mean 0.5 W(1) and miss the passive force.
  const Model model = TestModel("force_model_limb.urdf");
  const int mu = model.MuscleIndex("GP_rigid");
  // A posture where the active and the passive force are both a good part of F (57 % and 43 %
  // at a = 0.5).
  Eigen::VectorXd q = model.nominal_posture();
  q[model.JointIndex("knee_rz")] = 95 * 3.14159265358979323846 / 180;
  Data data(model);
  auto W = [&](double a) {
    return Evaluate(model, data, q, mu, model.model_stiffness(), a).wrench;
  };
  ComputeKinematics(model, data, q, mu, 0.5);
  const MuscleForce f = MuscleForceAt(model, mu, data.muscle_length(), 0.5);
  ASSERT_EQ(f.status, MuscleForceStatus::kEquilibrium);
  ASSERT_GT(f.passive_force, 0.2 * f.force) << "the posture must stretch the fibers";
  ASSERT_GT(f.active_force, 0.2 * f.force) << "and leave them an active force";
  const Vector6d w2 = W(0.2), w5 = W(0.5), w8 = W(0.8);
  ASSERT_LE((w5 - 0.5 * (w2 + w8)).norm(), 1e-9 * w5.norm()) << "W is affine in a";
  ASSERT_GT((w5 - 0.5 * W(1.0)).norm(), 0.1 * w5.norm()) << "the shortcut would be wrong here";

  UncertaintySpec spec;
  spec.inputs.push_back(Input("activation", InputDistribution::kUniform, {}, 0.2, 0.8));
  spec.inputs.push_back(Input("transducer_stiffness:y", InputDistribution::kLogNormal, {0.01}));
  UncertaintyOptions options;
  options.samples = 8000;
  options.activation = 0.5;
  const UncertaintyResult r = RunUncertainty(model, "GP_rigid", q, spec, options);
  const PostureUncertainty& p = r.postures[0];
  ASSERT_EQ(p.valid, p.samples);
  const double n = static_cast<double>(p.samples);
  int compared = 0;
  for (int i = 0; i < 6; ++i) {
    const double slope = (w8[i] - w2[i]) / 0.6;
    const double sd = std::abs(slope) * 0.6 / std::sqrt(12.0);
    if (sd < 1e-6 * w5.norm()) continue;
    ++compared;
    const QuantityStatistics& s = p.statistics[static_cast<size_t>(i)];
    EXPECT_NEAR(p.nominal[static_cast<size_t>(i)], w5[i], 1e-12 * w5.norm()) << i;
    EXPECT_NEAR(s.mean, w5[i], 5 * sd / std::sqrt(n) + 2e-3 * sd) << i;
    EXPECT_NEAR(s.sd, sd, 5 * sd / std::sqrt(2 * n) + 0.01 * sd) << i;
    const double levels[4] = {0.025, 0.5, 0.95, 0.975};
    for (int k = 0; k < 4; ++k) {
      const double level = slope > 0 ? levels[k] : 1 - levels[k];
      const double expected = w2[i] + slope * 0.6 * level;
      // A uniform's quantile: sampling sd sqrt(p (1 - p) / n) of the range.
      EXPECT_NEAR(s.percentiles[static_cast<size_t>(k)], expected,
                  5 * std::abs(slope) * 0.6 * std::sqrt(0.25 / n) + 0.01 * sd)
          << i << " p" << levels[k];
    }
    // The activation has (nearly) all the variance.
    EXPECT_NEAR(p.sobol[0][static_cast<size_t>(i)].first, 1.0, 0.05) << i;
  }
  EXPECT_GE(compared, 3);
}

TEST(UncertaintyForceModels, CompliantTendonActivationMatchesFirstOrderAndCountsTailsInvalid) {
  const Model model = TestModel("force_model_limb.urdf");
  const int mu = model.MuscleIndex("GP_compliant");
  const Eigen::VectorXd q = model.nominal_posture();
  Data data(model);
  auto W = [&](double a) {
    return Evaluate(model, data, q, mu, model.model_stiffness(), a).wrench;
  };
  {
    // Small sd: sd(W_i) = |dW_i/da| sd_a, dW/da by central differences of the engine.
    const double a0 = 0.5, sd_a = 0.01;
    const Vector6d slope = (W(a0 + 1e-4) - W(a0 - 1e-4)) / 2e-4;
    UncertaintySpec spec;
    spec.inputs.push_back(Input("activation", InputDistribution::kNormal, {sd_a}));
    UncertaintyOptions options;
    options.samples = 6000;
    options.sobol = false;
    options.activation = a0;
    const PostureUncertainty p =
        RunUncertainty(model, "GP_compliant", q, spec, options).postures[0];
    ASSERT_EQ(p.valid, p.samples);
    const double n = static_cast<double>(p.samples);
    const Vector6d w0 = W(a0);
    int compared = 0;
    for (int i = 0; i < 6; ++i) {
      const double sd = std::abs(slope[i]) * sd_a;
      if (sd < 1e-6 * w0.norm()) continue;
      ++compared;
      EXPECT_NEAR(p.statistics[static_cast<size_t>(i)].sd, sd,
                  5 * sd / std::sqrt(2 * n) + 0.01 * sd)
          << i;
      EXPECT_NEAR(p.statistics[static_cast<size_t>(i)].mean, w0[i],
                  5 * sd / std::sqrt(n) + 0.01 * sd)
          << i;
    }
    EXPECT_GE(compared, 3);
  }
  {
    // A normal activation near 1: the samples beyond 1 (P(z > 1) = 15.87 %) have no force model
    // value; they are counted invalid and leave every statistic.
    UncertaintySpec spec;
    spec.inputs.push_back(Input("activation", InputDistribution::kNormal, {0.05}));
    UncertaintyOptions options;
    options.samples = 6000;
    options.sobol = false;
    options.activation = 0.95;
    const UncertaintyResult r = RunUncertainty(model, "GP_compliant", q, spec, options);
    const PostureUncertainty& p = r.postures[0];
    const double n = static_cast<double>(p.samples);
    const double tail = 0.158655253931457;
    EXPECT_NEAR(static_cast<double>(p.invalid), tail * n, 5 * std::sqrt(tail * (1 - tail) * n));
    EXPECT_EQ(p.valid + p.invalid, p.samples);
    EXPECT_EQ(p.statistics[0].count, p.valid);
    const Vector6d w95 = W(0.95);
    EXPECT_THAT(UncertaintyJson(r, model), ::testing::Not(HasSubstr("NaN")));
    EXPECT_NEAR(p.nominal[0], w95[0], 1e-12 * w95.norm());
  }
  // A uniform beyond [0, 1], or a nominal activation outside it: errors.
  UncertaintySpec spec;
  spec.inputs.push_back(Input("activation", InputDistribution::kUniform, {}, 0.5, 1.2));
  EXPECT_THAT([&] { UncertaintyStudy(model, "GP_compliant", q, spec, UncertaintyOptions{}); },
              ThrowsMessage<Error>(HasSubstr("activation [0.5, 1.2] leaves [0, 1]")));
  spec.inputs[0] = Input("max_force", InputDistribution::kNormal, {0.1});
  UncertaintyOptions options;
  options.activation = 1.5;
  EXPECT_THAT([&] { UncertaintyStudy(model, "GP_compliant", q, spec, options); },
              ThrowsMessage<Error>(HasSubstr("activation 1.5 of muscle 'GP_compliant'")));
}

}  // namespace
}  // namespace isowrench
