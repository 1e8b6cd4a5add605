// The force stage in the engine (issue 28 stage 2): tau = -F(L_MT, a) dL/dq with F from the
// muscle's force model, in ComputeKinematics / Evaluate / EvaluateBatch / EvaluateWrench, and
// the --force-model override. References: the force recomputed from the public normalized
// curves (MuscleForceModel::ActiveForceLength, PassiveForceLength, TendonForceLength) and the
// pennation geometry written out here, and dL/dq by central differences of the path length.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "isowrench/engine.hpp"
#include "isowrench/error.hpp"
#include "isowrench/frontend.hpp"
#include "isowrench/kinematics.hpp"
#include "isowrench/model.hpp"
#include "isowrench/muscle.hpp"
#include "isowrench/statics.hpp"

namespace isowrench {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

std::string ForceLimbPath() {
  return std::string(ISOWRENCH_TEST_DATA_DIR) + "/force_model_limb.urdf";
}

const char* const kForceMuscles[] = {"GP_compliant", "GP_rigid", "GP_thelen", "GP_no_opensim"};

// Postures around the nominal one, +-17 degrees on every coordinate (the test muscles are taut
// there).
std::vector<Eigen::VectorXd> StagePostures(const Model& model, int count, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-0.3, 0.3);
  std::vector<Eigen::VectorXd> out;
  for (int i = 0; i < count; ++i) {
    Eigen::VectorXd q = model.nominal_posture();
    for (Eigen::Index c = 0; c < q.size(); ++c) q[c] += u(rng);
    out.push_back(q);
  }
  return out;
}

// F(L_MT, a) recomputed from the public curves: the fiber length of a rigid tendon from the
// constant-width pennation geometry (l = sqrt(h^2 + (L - l_Ts)^2)), of a compliant one from the
// result (then the fiber force along the tendon must equal the tendon force to 1e-10 N).
double ForceFromCurves(const MuscleForceModel& f, const MuscleForceSpec& spec, double max_force,
                       double L, double a, const MuscleForce& result) {
  const double lo = spec.optimal_fiber_length;
  const double h = lo * std::sin(spec.pennation_angle_at_optimal);
  const double a_used = std::max(a, f.minimum_activation());
  const double l =
      f.rigid_tendon()
          ? std::sqrt(h * h + (L - spec.tendon_slack_length) * (L - spec.tendon_slack_length))
          : result.fiber_length;
  const double cos_phi = std::sqrt(1.0 - (h / l) * (h / l));
  const double fiber =
      max_force *
      (a_used * f.ActiveForceLength(l / lo).value + f.PassiveForceLength(l / lo).value) * cos_phi;
  if (f.rigid_tendon()) return fiber;
  const double l_T = L - l * cos_phi;
  const double tendon = max_force * f.TendonForceLength(l_T / spec.tendon_slack_length).value;
  EXPECT_NEAR(fiber, tendon, 1e-10) << f.muscle() << " at L_MT " << L;
  return tendon;
}

TEST(ForceStage, TorqueIsTheCurvesForceTimesTheMomentArms) {
  const Model model = Model::FromUrdfFile(ForceLimbPath());
  Data ws(model);
  for (const char* name : kForceMuscles) {
    const int m = model.MuscleIndex(name);
    const MuscleSpec& spec = model.muscle(m);
    const MuscleForceModel& f = ForceModelOf(model, m);
    ASSERT_NE(f.type(), ForceModelType::kConstant) << name;
    for (double a : {1.0, 0.4, 0.0}) {
      for (const Eigen::VectorXd& q : StagePostures(model, 6, 11)) {
        const MuscleTorque t = ComputeMuscleTorque(model, ws, q, m, a);
        ASSERT_EQ(t.force_stage.status, MuscleForceStatus::kEquilibrium) << name;
        const double F = ForceFromCurves(f, spec.force, spec.max_force, t.length, a, t.force_stage);
        EXPECT_NEAR(t.force, F, 1e-10 * std::max(1.0, F)) << name << " a " << a;
        EXPECT_GT(t.force, 0.0) << name;
        for (Eigen::Index c = 0; c < q.size(); ++c) {
          const double step = 1e-6;
          Eigen::VectorXd qp = q, qm = q;
          qp[c] += step;
          qm[c] -= step;
          const double dL = (ComputeMuscleTorque(model, ws, qp, m, a).length -
                             ComputeMuscleTorque(model, ws, qm, m, a).length) /
                            (2 * step);
          // tau = -F dL/dq: F from the curves, dL/dq from the path length alone.
          EXPECT_NEAR(t.tau[c], -F * dL, 1e-9) << name << " column " << c << " a " << a;
          // The engine's own product, exactly: the kernel's unit-force torque times F.
          EXPECT_EQ(t.tau[c], -(t.force * t.dL_dq[c])) << name << " column " << c;
        }
      }
    }
  }
}

TEST(ForceStage, EvaluateAndBatchAgreeWithForceModels) {
  const Model model = Model::FromUrdfFile(ForceLimbPath());
  const std::vector<Eigen::VectorXd> list = StagePostures(model, 13, 5);  // lanes + a tail
  Eigen::MatrixXd postures(model.dof_count(), static_cast<Eigen::Index>(list.size()));
  for (size_t p = 0; p < list.size(); ++p) postures.col(static_cast<Eigen::Index>(p)) = list[p];
  std::vector<StiffnessSet> sets(3, model.model_stiffness());
  sets[1].s_t.tail<3>() *= 1e-3;
  sets[2].s_p.setConstant(0.05);
  Data ws(model);
  for (const char* name : kForceMuscles) {
    const int m = model.MuscleIndex(name);
    for (double a : {1.0, 0.25}) {
      std::vector<WrenchResult> batch;
      EvaluateBatch(model, postures, m, sets, batch, a);
      for (size_t p = 0; p < list.size(); ++p) {
        for (size_t s = 0; s < sets.size(); ++s) {
          const WrenchResult one = Evaluate(model, ws, list[p], m, sets[s], a);
          const WrenchResult& b = batch[p * sets.size() + s];
          ASSERT_EQ(one.status, b.status) << name << " posture " << p << " set " << s;
          const double scale = one.wrench.cwiseAbs().maxCoeff();
          EXPECT_GT(scale, 0.0);
          EXPECT_LE((one.wrench - b.wrench).cwiseAbs().maxCoeff(), 1e-12 * scale)
              << name << " posture " << p << " set " << s;
        }
      }
    }
  }
}

// A batch large enough for the compliant tendon's block force stage (batch.cpp BlockLanes:
// the kinematics of a work unit's groups of four postures kept apart, one TensionBlock over their
// lengths) on one and on two threads: every posture's wrench and status as Evaluate's, also
// for postures far enough out that the muscle goes slack. (1,153 postures: on one thread, blocks
// of the most, 512 postures, 128 groups, and a shorter last one.)
TEST(ForceStage, LargeBatchesAgreeWithEvaluate) {
  const Model model = Model::FromUrdfFile(ForceLimbPath());
  constexpr size_t kNear = 1100;
  std::vector<Eigen::VectorXd> list = StagePostures(model, static_cast<int>(kNear), 28);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> wide(-1.5, 1.5);
  for (int i = 0; i < 53; ++i) {
    Eigen::VectorXd q = model.nominal_posture();
    for (Eigen::Index c = 0; c < q.size(); ++c) q[c] += wide(rng);
    list.push_back(q);
  }
  // Inside blocks, postures whose lanes go to the scalar path (a coordinate beyond the lanes'
  // sin/cos range, 2e5 rad = itself modulo 2 pi on the scalar path): their group's other lanes
  // stay in the block.
  for (size_t p : {5, 130, 517, 700}) list[p][0] += 2e5;
  Eigen::MatrixXd postures(model.dof_count(), static_cast<Eigen::Index>(list.size()));
  for (size_t p = 0; p < list.size(); ++p) postures.col(static_cast<Eigen::Index>(p)) = list[p];
  // Two stiffness sets: each posture's lanes solved for both.
  std::vector<StiffnessSet> sets(2, model.model_stiffness());
  sets[1].s_t *= 0.5;
  Data ws(model);
  for (const char* name : kForceMuscles) {
    const int m = model.MuscleIndex(name);
    for (int threads : {1, 2}) {
      BatchOptions options;
      options.threads = threads;
      std::vector<WrenchResult> batch;
      EvaluateBatch(model, postures, m, sets, batch, 0.6, options);
      int zero = 0;
      for (size_t p = 0; p < list.size(); ++p) {
        for (size_t s = 0; s < sets.size(); ++s) {
          const WrenchResult one = Evaluate(model, ws, list[p], m, sets[s], 0.6);
          const WrenchResult& b = batch[p * sets.size() + s];
          ASSERT_EQ(one.status, b.status) << name << " posture " << p << " set " << s;
          const double scale = one.wrench.cwiseAbs().maxCoeff();
          zero += scale == 0.0;
          // (to rounding: the lanes' statics is not the scalar solve's; the far postures' K is
          // less well conditioned, 1e-12 relative near the nominal posture)
          EXPECT_LE((one.wrench - b.wrench).cwiseAbs().maxCoeff(),
                    (p < kNear ? 1e-12 : 1e-9) * scale)
              << name << " posture " << p << " set " << s << " threads " << threads;
        }
      }
      EXPECT_LT(zero, 80) << name;
    }
  }
}

TEST(ForceStage, EvaluateWrenchReportsTheForceStageTheKernelApplied) {
  const Model model = Model::FromUrdfFile(ForceLimbPath());
  Data ws(model);
  for (const char* name : kForceMuscles) {
    const int m = model.MuscleIndex(name);
    const Eigen::VectorXd q = model.nominal_posture();
    const WrenchEvaluation e = EvaluateWrench(model, ws, q, m, 0.7);
    const MuscleForce F = MuscleForceAt(model, m, e.muscle_length, 0.7);
    EXPECT_EQ(e.muscle_force, F.force);
    EXPECT_EQ(e.force.active_force, F.active_force);
    EXPECT_EQ(e.force.passive_force, F.passive_force);
    // The engine's fast path gives the same W (another solver: to rounding).
    const WrenchResult w = Evaluate(model, ws, q, m, model.model_stiffness(), 0.7);
    ASSERT_EQ(w.status, StaticsStatus::kOk);
    EXPECT_LE((w.wrench - e.statics.wrench).cwiseAbs().maxCoeff(),
              1e-9 * w.wrench.cwiseAbs().maxCoeff())
        << name;
  }
}

TEST(ForceStage, PassiveWrenchIsTheEngineAtActivationZero) {
  const Model model = Model::FromUrdfFile(ForceLimbPath());
  Data ws(model);
  for (const char* name : kForceMuscles) {
    const int m = model.MuscleIndex(name);
    for (const Eigen::VectorXd& q : StagePostures(model, 4, 3)) {
      const WrenchEvaluation e = EvaluateWrench(model, ws, q, m, 0.9);
      const WrenchResult zero = Evaluate(model, ws, q, m, model.model_stiffness(), 0.0);
      ASSERT_EQ(zero.status, StaticsStatus::kOk);
      ASSERT_TRUE(e.passive_statics.ok());
      const double scale = zero.wrench.cwiseAbs().maxCoeff();
      EXPECT_GT(scale, 0.0) << name << ": the activation floor pulls at activation 0";
      EXPECT_LE((e.passive_statics.wrench - zero.wrench).cwiseAbs().maxCoeff(), 1e-9 * scale)
          << name;
      EXPECT_EQ(e.passive_force.force, MuscleForceAt(model, m, e.muscle_length, 0.0).force);
      // F(a) does not decrease with a at a fixed length (equal beyond the active curve's end).
      EXPECT_LE(e.passive_force.force, e.force.force) << name;
    }
  }
  // The constant model pulls with nothing at activation 0.
  const int c = model.MuscleIndex("GP_constant");
  const WrenchEvaluation e = EvaluateWrench(model, ws, model.nominal_posture(), c, 0.9);
  EXPECT_EQ(e.passive_statics.wrench, Vector6d::Zero());
  EXPECT_EQ(e.passive_force.force, 0.0);
}

// The constant model keeps today's numbers bit for bit: tau = -(a max_force) dL/dq in the
// kernel, and --force-model constant on a force-model muscle gives exactly the constant muscle.
TEST(ForceStage, ConstantModelAndOverrideKeepTheOldNumbersBitForBit) {
  const LimbDescription d = ReadUrdfFile(ForceLimbPath());
  const Model model(d);
  ModelOverrides o;
  o.force_model = "constant";
  const Model constant(ApplyOverrides(d, o));
  Data ws(model), wc(constant);
  const int reference = model.MuscleIndex("GP_constant");
  for (const Eigen::VectorXd& q : StagePostures(model, 5, 9)) {
    ASSERT_TRUE(ComputeKinematics(model, ws, q, reference, 0.6));
    for (int c = 0; c < model.dof_count(); ++c) {
      EXPECT_EQ(ws.tau()[c], -(0.6 * 2.35) * ws.muscle_length_gradient()[c]);
    }
    const WrenchResult old = Evaluate(model, ws, q, reference, model.model_stiffness(), 0.6);
    for (const char* name : kForceMuscles) {
      const int m = constant.MuscleIndex(name);
      EXPECT_EQ(ForceModelOf(constant, m).type(), ForceModelType::kConstant);
      const WrenchResult w = Evaluate(constant, wc, q, m, constant.model_stiffness(), 0.6);
      EXPECT_EQ(w.status, old.status);
      EXPECT_EQ(w.wrench, old.wrench) << name;  // bit for bit
    }
  }
  // "rigid": every force model with a rigid tendon; "model": nothing changes.
  o.force_model = "rigid";
  const Model rigid(ApplyOverrides(d, o));
  for (const char* name : kForceMuscles)
    EXPECT_TRUE(ForceModelOf(rigid, rigid.MuscleIndex(name)).rigid_tendon()) << name;
  EXPECT_EQ(ForceModelOf(rigid, rigid.MuscleIndex("GP_constant")).type(),
            ForceModelType::kConstant);
  o.force_model = "model";
  EXPECT_TRUE(o.empty());
  o.force_model = "hill";
  EXPECT_THAT([&] { ApplyOverrides(d, o); },
              ThrowsMessage<Error>(AllOf(HasSubstr("--force-model 'hill'"), HasSubstr("rigid"))));
}

TEST(ForceStage, ActivationOutsideZeroOneIsAnErrorNamingTheValue) {
  const Model model = Model::FromUrdfFile(ForceLimbPath());
  Data ws(model);
  const Eigen::VectorXd q = model.nominal_posture();
  for (const char* name : {"GP_compliant", "GP_constant"}) {
    EXPECT_THAT([&] { EvaluateWrench(model, q, name, 1.5); },
                ThrowsMessage<Error>(AllOf(HasSubstr(name), HasSubstr("1.5"))));
    EXPECT_THAT([&] { ComputeMuscleTorque(model, ws, q, model.MuscleIndex(name), -0.2); },
                ThrowsMessage<Error>(AllOf(HasSubstr(name), HasSubstr("-0.2"))));
  }
  std::vector<WrenchResult> out;
  EXPECT_THAT(
      [&] {
        EvaluateBatch(model, q, model.MuscleIndex("GP_thelen"), {model.model_stiffness()}, out,
                      1.25);
      },
      // (checked before the threads start: "EvaluateBatch: ...")
      ThrowsMessage<Error>(
          AllOf(HasSubstr("EvaluateBatch: "), HasSubstr("GP_thelen"), HasSubstr("1.25"))));
}

// A length where the force model has no number (Thelen's exponential passive curve overflows
// with l/l_o ~ 360): a status that says so, never a NaN.
TEST(ForceStage, NoEquilibriumIsAStatusNeverANumber) {
  LimbDescription d = ReadUrdfFile(ForceLimbPath());
  for (MuscleSpec& m : d.muscles) {
    if (m.name == "GP_no_opensim") m.force.optimal_fiber_length = 1e-4;
  }
  const Model model(d);
  const int m = model.MuscleIndex("GP_no_opensim");
  Data ws(model);
  const Eigen::VectorXd q = model.nominal_posture();
  const WrenchResult w = Evaluate(model, ws, q, m, model.model_stiffness(), 1.0);
  EXPECT_EQ(w.status, StaticsStatus::kInvalidInput);
  EXPECT_EQ(w.wrench, Vector6d::Zero());
  EXPECT_THAT(StatusMessage(w), HasSubstr("no equilibrium"));
  const WrenchEvaluation e = EvaluateWrench(model, ws, q, m, 1.0);
  EXPECT_EQ(e.force.status, MuscleForceStatus::kNoEquilibrium);
  EXPECT_EQ(e.statics.status, StaticsStatus::kInvalidInput);
  EXPECT_THAT(e.statics.message, HasSubstr("no equilibrium"));
  EXPECT_TRUE(e.statics.wrench.allFinite());
  EXPECT_TRUE(e.tau.allFinite());
  std::vector<WrenchResult> batch;
  Eigen::MatrixXd postures(q.size(), 5);
  for (int p = 0; p < 5; ++p) postures.col(p) = q;
  EvaluateBatch(model, postures, m, {model.model_stiffness()}, batch, 1.0);
  for (const WrenchResult& b : batch) {
    EXPECT_EQ(b.status, StaticsStatus::kInvalidInput);
    EXPECT_EQ(b.wrench, Vector6d::Zero());
  }
}

TEST(ForceStage, ReportsNameTheModelAndWhereOpenSimGivesNoNumber) {
  const Model model = Model::FromUrdfFile(ForceLimbPath());
  EXPECT_EQ(ForceModelLabel(model, model.MuscleIndex("GP_compliant")),
            "millard2012, compliant tendon");
  EXPECT_EQ(ForceModelLabel(model, model.MuscleIndex("GP_rigid")), "millard2012, rigid tendon");
  EXPECT_EQ(ForceModelLabel(model, model.MuscleIndex("GP_constant")),
            "constant (F = a x max_force)");
  const int m = model.MuscleIndex("GP_no_opensim");
  EXPECT_THAT(ForceModelLabel(model, m),
              AllOf(HasSubstr("rigid-tendon limit"), HasSubstr("OpenSim gives no number")));
  const WrenchEvaluation e = EvaluateWrench(model, model.nominal_posture(), "GP_no_opensim");
  EXPECT_TRUE(e.force.opensim_gives_no_number);
  EXPECT_THAT(OpenSimNote(model, m, e.force),
              AllOf(HasSubstr("OpenSim gives no number"), HasSubstr("rigid-tendon limit")));
  EXPECT_EQ(OpenSimNote(model, model.MuscleIndex("GP_compliant"),
                        EvaluateWrench(model, model.nominal_posture(), "GP_compliant").force),
            "");
}

}  // namespace
}  // namespace isowrench
