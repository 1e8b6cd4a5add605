// Tests of the force_length:MUSCLE effect (issue 28 item 4): what it changes, the derivative of
// the prediction against the chain rule through the public force-length curves, recovery of a
// planted optimal fiber length by the fit, the trace naming it when it is not a candidate, and
// design's expected standard error against the fit's.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <set>

#include "isowrench/engine.hpp"
#include "isowrench/error.hpp"
#include "isowrench/identification.hpp"
#include "isowrench/kinematics.hpp"
#include "isowrench/muscle.hpp"

namespace isowrench {
namespace {

using ::testing::HasSubstr;

const std::string kForceLengthLimb =
    std::string(ISOWRENCH_TEST_DATA_DIR) + "/force_model_limb.urdf";

/// Parameter recovery: |estimate - truth| <= kForceLengthSigmas reported standard errors.
constexpr double kForceLengthSigmas = 4.0;

const MuscleSpec& SpecOf(const LimbDescription& d, const std::string& name) {
  for (const MuscleSpec& m : d.muscles) {
    if (m.name == name) return m;
  }
  throw Error("no muscle " + name);
}

std::vector<Trial> ForceLengthSimulate(const Model& model, const std::vector<std::string>& effects,
                                       const std::string& muscle, unsigned long long seed,
                                       int postures) {
  std::vector<AppliedEffect> applied;
  for (const std::string& e : effects) applied.push_back(ParseEffectAssignment(model, e));
  SimulationOptions o;
  o.postures = postures;
  o.seed = seed;
  o.muscles = {muscle};
  return SimulateTrials(model, ApplyEffects(model.description(), applied), o);
}

const CandidateFit* ChosenFit(const FitReport& r, const std::string& id) {
  for (const CandidateFit& f : r.chosen_fits) {
    if (f.effect.id == id) return &f;
  }
  return nullptr;
}

// ---- what the effect is ---------------------------------------------------------------------

TEST(ForceLengthEffect, ScalesTheFiberAndTendonLengthsOfForceModelMusclesOnly) {
  const Model model = Model::FromUrdfFile(kForceLengthLimb);
  std::set<std::string> ids;
  for (const Effect& e : CandidateEffects(model)) {
    if (e.kind != "force_length") continue;
    ids.insert(e.id);
    EXPECT_EQ(e.stage, EffectStage::kModel);
    // A tendon of slack length 0 (the rigid-tendon limit) has no tendon factor.
    EXPECT_EQ(e.parameters.size(), e.muscle == "GP_no_opensim" ? 1u : 2u) << e.id;
  }
  EXPECT_EQ(ids, (std::set<std::string>{"force_length:GP_compliant", "force_length:GP_rigid",
                                        "force_length:GP_thelen", "force_length:GP_no_opensim"}));
  const MuscleSpec& before = SpecOf(model.description(), "GP_compliant");
  const LimbDescription after =
      ApplyEffect(model.description(), FindEffect(model, "force_length:GP_compliant"), {1.25, 0.8});
  const MuscleSpec& m = SpecOf(after, "GP_compliant");
  EXPECT_DOUBLE_EQ(m.force.optimal_fiber_length, 1.25 * before.force.optimal_fiber_length);
  EXPECT_DOUBLE_EQ(m.force.tendon_slack_length, 0.8 * before.force.tendon_slack_length);
  // Nothing else of the muscle, nor the other muscles, changes.
  EXPECT_EQ(m.max_force, before.max_force);
  EXPECT_EQ(m.force.pennation_angle_at_optimal, before.force.pennation_angle_at_optimal);
  EXPECT_EQ(SpecOf(after, "GP_rigid").force, SpecOf(model.description(), "GP_rigid").force);
  // Named parameters: the other keeps its neutral value.
  const AppliedEffect named = ParseEffectAssignment(model, "force_length:GP_rigid=l_Ts_scale:1.1");
  EXPECT_EQ(named.values, (std::vector<double>{1.0, 1.1}));
}

TEST(ForceLengthEffect, AConstantForceMuscleIsAnErrorNamingIt) {
  const Model model = Model::FromUrdfFile(kForceLengthLimb);
  try {
    FindEffect(model, "force_length:GP_constant");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("muscle 'GP_constant' has the constant force model"));
  }
  EXPECT_THROW(ParseEffectAssignment(model, "force_length:GP_constant=1.1"), Error);
  // Applied to a muscle made constant afterwards (e.g. --force-model constant): the same error.
  const Effect e = FindEffect(model, "force_length:GP_thelen");
  LimbDescription constant = model.description();
  for (MuscleSpec& m : constant.muscles) m.force.model = ForceModelType::kConstant;
  try {
    ApplyEffect(constant, e, {1.1, 1.0});
    FAIL() << "no error";
  } catch (const Error& err) {
    EXPECT_THAT(err.what(), HasSubstr("effect 'force_length:GP_thelen': muscle 'GP_thelen' has "
                                      "the constant force model"));
  }
  // A model whose muscles are all constant offers no force_length candidate.
  for (const Effect& c : CandidateEffects(Model(constant))) EXPECT_NE(c.kind, "force_length");
}

// ---- the derivative of the prediction ---------------------------------------------------------

/// dF/ds of a rigid tendon (Millard2012 ignore_tendon_compliance, or the rigid-tendon limit of a
/// tendon of length 0) when the optimal fiber length is s l_o, at s = 1, from the public curves:
/// F = F_max (a f_L(x) + f_PE(x)) cos phi with l = sqrt((L - l_Ts)^2 + h^2), h = s l_o sin phi_o
/// (constant-width pennation), x = l / (s l_o), cos phi = (L - l_Ts) / l. Returns F too.
double RigidForceSlope(const MuscleForceModel& curves, const MuscleSpec& spec, double length,
                       double activation, double* force) {
  const double lo = spec.force.optimal_fiber_length, lts = spec.force.tendon_slack_length;
  const double sin_o = std::sin(spec.force.pennation_angle_at_optimal);
  const double along = length - lts, h = lo * sin_o;
  const double l = std::sqrt(along * along + h * h);
  const double x = l / lo, cos_phi = along / l;
  const double a = std::max(activation, curves.minimum_activation());
  const CurvePoint fl = curves.ActiveForceLength(x), fp = curves.PassiveForceLength(x);
  const double dl = h * lo * sin_o / l;  // dl/ds
  const double dx = dl / lo - x;         // d(l / (s l_o))/ds at s = 1
  const double dcos = -along / (l * l) * dl;
  *force = spec.max_force * (a * fl.value + fp.value) * cos_phi;
  return spec.max_force *
         ((a * fl.slope + fp.slope) * dx * cos_phi + (a * fl.value + fp.value) * dcos);
}

TEST(ForceLengthEffect, PredictionSlopeEqualsTheChainRuleThroughTheCurves) {
  // W is linear in the muscle force at a fixed posture, so dW/ds = W (dF/ds) / F, with dF/ds
  // from the curves (RigidForceSlope); the fit's prediction is differentiated by central
  // differences through ApplyEffects and PredictTrials.
  const Model model = Model::FromUrdfFile(kForceLengthLimb);
  for (const std::string muscle : {"GP_rigid", "GP_no_opensim"}) {
    const MuscleSpec& spec = SpecOf(model.description(), muscle);
    const int index = model.MuscleIndex(muscle);
    const MuscleForceModel curves(muscle, spec.max_force, spec.force);
    std::vector<Trial> trials = ForceLengthSimulate(model, {}, muscle, 5, 12);
    const Effect e = FindEffect(model, "force_length:" + muscle);
    auto predict = [&](double s) {
      std::vector<double> v(e.parameters.size(), 1.0);
      v[0] = s;
      return PredictTrials(ApplyEffects(model.description(), {{e, v}}), trials);
    };
    const double h = 1e-5;
    const Prediction plus = predict(1 + h), minus = predict(1 - h), at = predict(1.0);
    ASSERT_EQ(plus.failed + minus.failed + at.failed, 0) << plus.message << minus.message;
    Data data(model);
    double worst = 0, scale = 0;
    for (size_t k = 0; k < trials.size(); ++k) {
      const double length = ComputeMuscleTorque(model, data, trials[k].q, index, 1.0).length;
      double force = 0;
      const double slope = RigidForceSlope(curves, spec, length, trials[k].activation, &force);
      // The formula is the engine's force (an independent re-derivation of F first).
      EXPECT_NEAR(force, MuscleForceAt(model, index, length, trials[k].activation).force,
                  1e-12 * spec.max_force)
          << muscle;
      const Vector6d expected = at.wrench[k] * (slope / force);
      const Vector6d numeric = (plus.wrench[k] - minus.wrench[k]) / (2 * h);
      worst = std::max(worst, (numeric - expected).cwiseAbs().maxCoeff());
      scale = std::max(scale, expected.cwiseAbs().maxCoeff());
    }
    EXPECT_GT(scale, 1e-3) << muscle << ": the force must depend on l_o here";
    EXPECT_LT(worst, 1e-6 * scale) << muscle << ": worst " << worst << " of " << scale;
  }
}

// ---- the fit -----------------------------------------------------------------------------------

TEST(ForceLengthFit, RecoversAPlantedOptimalFiberLength) {
  // l_o 15 % longer than the model's (compliant tendon, both parameters free), and a Thelen
  // rigid-tendon-limit muscle 10 % shorter (one parameter): the fit names force_length among
  // force_scale, a joint offset and per-trial factors, and each value comes back within its SE.
  const Model model = Model::FromUrdfFile(kForceLengthLimb);
  struct Case {
    std::string muscle, planted;
    std::vector<double> truth;
  };
  for (const Case& c : {Case{"GP_compliant", "l_o_scale:1.15", {1.15, 1.0}},
                        Case{"GP_no_opensim", "l_o_scale:0.9", {0.9}}}) {
    const std::string id = "force_length:" + c.muscle;
    const std::vector<Trial> trials =
        ForceLengthSimulate(model, {id + "=" + c.planted}, c.muscle, 3, 60);
    FitOptions o;
    o.max_rounds = 2;
    o.candidates = {id, "force_scale:" + c.muscle, "joint_offset:knee_rz", "trial_force"};
    const FitReport r = FitEffects(model, trials, o);
    EXPECT_EQ(r.verdict, FitVerdict::kExplained) << r.BriefReport();
    ASSERT_EQ(r.chosen.size(), 1u) << r.BriefReport();
    const CandidateFit* f = ChosenFit(r, id);
    ASSERT_NE(f, nullptr) << r.BriefReport();
    ASSERT_LE(f->values.size(), c.truth.size());  // (l_Ts_scale may be held at 1)
    for (size_t i = 0; i < f->values.size(); ++i) {
      std::cout << "[force_length] " << id << "." << f->effect.parameters[i].name << " = "
                << f->values[i] << " +- " << f->standard_errors[i] << " (truth " << c.truth[i]
                << ")\n";
      EXPECT_GT(f->standard_errors[i], 0);
      EXPECT_LE(std::abs(f->values[i] - c.truth[i]), kForceLengthSigmas * f->standard_errors[i])
          << f->effect.parameters[i].name;
    }
    // The augmented model carries the fitted lengths.
    const MuscleSpec& nominal = SpecOf(model.description(), c.muscle);
    EXPECT_NEAR(SpecOf(r.augmented.description, c.muscle).force.optimal_fiber_length,
                f->values[0] * nominal.force.optimal_fiber_length, 1e-15);
  }
}

TEST(ForceLengthFit, TheTraceNamesItWhenItIsNotACandidate) {
  // Without force_length in the library the data end "unexplained" and the trace's first line
  // names the muscle's force-length parameters.
  const Model model = Model::FromUrdfFile(kForceLengthLimb);
  const std::vector<Trial> trials = ForceLengthSimulate(
      model, {"force_length:GP_compliant=l_o_scale:1.15"}, "GP_compliant", 3, 60);
  FitOptions o;
  o.max_rounds = 1;
  o.candidates = {"force_scale:GP_compliant"};
  const FitReport r = FitEffects(model, trials, o);
  EXPECT_EQ(r.verdict, FitVerdict::kUnexplained) << r.BriefReport();
  ASSERT_FALSE(r.trace.empty()) << r.BriefReport();
  EXPECT_EQ(r.trace[0].variable, "force-length of GP_compliant (force_length:GP_compliant)")
      << r.BriefReport();
  EXPECT_GT(r.trace[0].share, 0.8);
  std::cout << "[force_length trace] " << r.trace_summary << "\n";
}

TEST(ForceLengthDesign, ExpectedStandardErrorIsTheFits) {
  // design's expected SE (Fisher information of its chosen postures) against the SE the fit
  // reports on data simulated at exactly those postures with a small planted effect (the
  // Thelen muscle of tendon slack length 0: l_o_scale alone).
  const Model model = Model::FromUrdfFile(kForceLengthLimb);
  DesignOptions d;
  d.postures = 12;
  d.candidates = 150;
  d.muscles = {"GP_no_opensim"};
  const DesignResult design = DesignExperiment(model, {"force_length:GP_no_opensim"}, nullptr, d);
  ASSERT_EQ(design.standard_errors.size(), 1u);
  SimulationOptions s;
  s.postures = 48;  // each chosen trial four times
  s.seed = 8;
  s.at = design.chosen;
  s.joint_range = s.prismatic_range = 0;
  const std::vector<Trial> trials = SimulateTrials(
      model,
      ApplyEffects(model.description(),
                   {ParseEffectAssignment(model, "force_length:GP_no_opensim=1.0005")}),
      s);
  FitOptions o;
  o.max_rounds = 1;
  o.candidates = {"force_length:GP_no_opensim"};
  const FitReport r = FitEffects(model, trials, o);
  const CandidateFit* f = ChosenFit(r, "force_length:GP_no_opensim");
  ASSERT_NE(f, nullptr) << r.BriefReport();
  // Four repeats of the design: half its standard error.
  const double expected = design.standard_errors[0] / 2;
  std::cout << "[force_length design] " << design.labels[0] << ": design SE/2 " << expected
            << ", fit SE " << f->standard_errors[0] << "\n";
  EXPECT_NEAR(f->standard_errors[0], expected, 0.1 * expected);
  EXPECT_LE(std::abs(f->values[0] - 1.0005), kForceLengthSigmas * f->standard_errors[0]);
}

TEST(ForceLengthFit, TendonFactorHeldWhenTheTrialsCannotSeparateIt) {
  // Over the design's postures the two factors of the rigid Millard muscle are correlated
  // beyond max_correlation: the fit holds l_Ts_scale at 1 and says so, rather than refusing the
  // effect as not identifiable.
  const Model model = Model::FromUrdfFile(kForceLengthLimb);
  const std::vector<Trial> trials =
      ForceLengthSimulate(model, {"force_length:GP_rigid=l_o_scale:1.1"}, "GP_rigid", 4, 40);
  FitOptions o;
  o.max_rounds = 1;
  o.candidates = {"force_length:GP_rigid"};
  o.max_correlation = 0.5;  // (forces the restriction on any data)
  const FitReport r = FitEffects(model, trials, o);
  const CandidateFit* f = ChosenFit(r, "force_length:GP_rigid");
  ASSERT_NE(f, nullptr) << r.BriefReport();
  ASSERT_EQ(f->values.size(), 1u);
  EXPECT_LE(std::abs(f->values[0] - 1.1), kForceLengthSigmas * f->standard_errors[0]);
  bool noted = false;
  for (const std::string& n : r.notes) noted |= n.find("l_Ts_scale held at 1") != std::string::npos;
  EXPECT_TRUE(noted) << r.BriefReport();
}

// ---- per-trial factors on a muscle with a force model -----------------------------------------

/// The engine's wrench of `muscle` at the trial's posture and activation `a` (N, N·m).
Vector6d EngineWrench(const Model& model, Data& data, const Trial& t, double a) {
  const WrenchResult r =
      Evaluate(model, data, t.q, model.MuscleIndex(t.muscle), model.model_stiffness(), a);
  EXPECT_EQ(r.status, StaticsStatus::kOk);
  return r.wrench;
}

TEST(TrialForceWithAForceModel, FactorsScaleTheStimulatedPartOnly) {
  // A stimulus that varies from trial to trial changes W(a) - W(0), not the pre-stimulus passive
  // wrench W(0): readings g_t (W(a) - W(0)) + W(0) built from the engine give back g_t exactly.
  const Model model = Model::FromUrdfFile(kForceLengthLimb);
  Data data(model);
  const double truth[6] = {0.9, 1.1, 1.0, 0.8, 1.25, 1.05};
  for (const std::string muscle : {"GP_compliant", "GP_rigid"}) {
    SimulationOptions o;
    o.postures = 6;
    o.seed = 5;
    o.muscles = {muscle};
    std::vector<Trial> trials = SimulateTrials(model, ApplyEffects(model.description(), {}), o);
    double largest_share = 0.0;
    for (size_t k = 0; k < trials.size(); ++k) {
      const Vector6d active = EngineWrench(model, data, trials[k], trials[k].activation);
      const Vector6d passive = EngineWrench(model, data, trials[k], 0.0);
      largest_share = std::max(largest_share, passive.norm() / active.norm());
      trials[k].wrench = truth[k] * (active - passive) + passive;
    }
    // (The passive part is large enough to matter: scaling the whole wrench would be off.)
    EXPECT_GT(largest_share, 0.05) << muscle;
    std::vector<AppliedEffect> applied = {ParseEffectAssignment(model, "trial_force=0.1")};
    std::vector<double> factors;
    const Prediction p =
        PredictTrials(ApplyEffects(model.description(), applied), trials, &factors);
    ASSERT_EQ(factors.size(), trials.size());
    for (size_t k = 0; k < trials.size(); ++k) {
      EXPECT_NEAR(factors[k], truth[k], 1e-9) << muscle << " trial " << k;
      EXPECT_LE((p.wrench[k] - trials[k].wrench).norm(), 1e-9 * trials[k].wrench.norm())
          << muscle << " trial " << k;
    }
  }
}

TEST(TrialForceWithAForceModel, SimulatedFactorsScaleTheStimulatedPartOnly) {
  // simulate with a trial_force spread of 0.2 at a low activation (a large passive share): the
  // factors the fit reads back, (reading - W(0)) / (W(a) - W(0)) with the engine's W(a) and W(0)
  // (the wrenches at one posture are parallel: both are F times the same unit wrench), have
  // ln-sd 0.2 and mean 0. Had simulate scaled the whole wrench, their ln-sd would be
  // 0.2 / (1 - passive share).
  const Model model = Model::FromUrdfFile(kForceLengthLimb);
  Data data(model);
  std::vector<AppliedEffect> applied = {ParseEffectAssignment(model, "trial_force=0.2")};
  const AugmentedModel truth = ApplyEffects(model.description(), applied);
  SimulationOptions o;
  o.postures = 200;
  o.seed = 11;
  o.muscles = {"GP_compliant"};
  o.activation_min = o.activation_max = 0.1;
  o.noise_force = 0;
  o.noise_moment = 0;
  const std::vector<Trial> trials = SimulateTrials(model, truth, o);
  double sum = 0.0, sum2 = 0.0, share = 0.0;
  for (const Trial& t : trials) {
    const Vector6d active = EngineWrench(model, data, t, t.activation);
    const Vector6d passive = EngineWrench(model, data, t, 0.0);
    const Vector6d stimulated = active - passive;
    const double g = (t.wrench - passive).dot(stimulated) / stimulated.squaredNorm();
    sum += std::log(g);
    sum2 += std::log(g) * std::log(g);
    share += passive.norm() / active.norm() / trials.size();
  }
  EXPECT_GT(share, 0.25);  // (so that the two readings of the factor differ by far)
  const double n = static_cast<double>(trials.size());
  const double mean = sum / n, sd = std::sqrt((sum2 - n * mean * mean) / (n - 1));
  // 4 standard errors: of the mean 0.2 / sqrt(n), of the sd 0.2 / sqrt(2 (n - 1)).
  EXPECT_LE(std::abs(mean), 4 * 0.2 / std::sqrt(n));
  EXPECT_LE(std::abs(sd - 0.2), 4 * 0.2 / std::sqrt(2 * (n - 1))) << "passive share " << share;
  // The fit's model is simulate's: at its own factors every reading is predicted exactly.
  const Prediction p = PredictTrials(truth, trials);
  for (size_t k = 0; k < trials.size(); ++k) {
    EXPECT_LE((p.wrench[k] - trials[k].wrench).norm(), 1e-9 * trials[k].wrench.norm());
  }
}

TEST(TrialForceWithAForceModel, TheFitReadsTheSpreadOfTheStimulatedPart) {
  // The fit itself (trial_force a candidate: Context's raw wrenches with the passive part) on
  // data simulated with a spread of 0.2 at a = 0.1 (passive share ~52 %): trial_force chosen,
  // its spread within 4 SE of 0.2 and the level within 4 SE of 1 (scaling the whole wrench
  // would read a spread of about 0.1 and a level of about 0.5 + 0.5 g).
  const Model model = Model::FromUrdfFile(kForceLengthLimb);
  std::vector<AppliedEffect> applied = {ParseEffectAssignment(model, "trial_force=0.2")};
  SimulationOptions s;
  s.postures = 60;
  s.seed = 17;
  s.muscles = {"GP_compliant"};
  s.activation_min = s.activation_max = 0.1;
  const std::vector<Trial> trials =
      SimulateTrials(model, ApplyEffects(model.description(), applied), s);
  FitOptions o;
  o.max_rounds = 1;
  o.candidates = {"trial_force"};
  const FitReport r = FitEffects(model, trials, o);
  const CandidateFit* f = ChosenFit(r, "trial_force");
  ASSERT_NE(f, nullptr) << r.BriefReport();
  std::cout << "[trial_force] " << r.ForceLevelSummary() << "; as a candidate: spread "
            << f->values.at(0) << "\n";
  // The spread the round fitted (trial_force free) and the report's (trial_force in the model).
  EXPECT_LE(std::abs(f->values.at(0) - 0.2), kForceLengthSigmas * r.trial_force_spread_se);
  EXPECT_LE(std::abs(r.trial_force_spread - 0.2), kForceLengthSigmas * r.trial_force_spread_se);
  ASSERT_EQ(r.trial_force_levels.size(), 1u);
  const FitReport::ForceLevel& level = r.trial_force_levels[0];
  EXPECT_LE(std::abs(level.level - 1.0), kForceLengthSigmas * level.standard_error);
}

}  // namespace
}  // namespace isowrench
