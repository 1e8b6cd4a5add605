// Tests of include/isowrench/identification.hpp: CSV trials, effects, prediction, simulation,
// and the fit loop on data with undeclared effects (detection, parameter recovery, false
// alarms, two effects, an effect outside the library, unidentifiable effects).

#include "isowrench/identification.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <set>
#include <sstream>

#include "isowrench/error.hpp"
#include "isowrench/input_checks.hpp"
#include "isowrench/statics.hpp"

namespace isowrench {
namespace {

using ::testing::HasSubstr;

const std::string kUrdf = std::string(ISOWRENCH_TEST_URDF_DIR) + "/rat_hindlimb_5dof.urdf";

/// Trials per simulated data set: enough for 5-fold CV and small enough to keep the suite fast.
constexpr int kTrials = 40;
/// Parameter recovery: |estimate - truth| <= kSigmas * reported standard error. Data are seeded,
/// so this is deterministic; 4 sigma keeps an honest estimator passing for every case here.
constexpr double kSigmas = 4.0;
/// Seeds for the statistical tests. Under AddressSanitizer (CI) everything runs ~20x slower, so
/// the rates are measured on fewer seeds there; the numbers in docs come from the full run.
#if defined(__SANITIZE_ADDRESS__) || defined(ISOWRENCH_TEST_SANITIZED)
constexpr int kRateSeeds = 2;
constexpr int kFalseAlarmSeeds = 6;
#else
constexpr int kRateSeeds = 5;
constexpr int kFalseAlarmSeeds = 20;
#endif
/// Identities that go through the same floating-point operations in a different order.
constexpr double kIdentityTolerance = 1e-12;

Model Rat() { return Model::FromUrdfFile(kUrdf); }

/// The rat limb with hip_rx fixed (a 4-dof limb whose hip lacks the x rotation): the extra
/// joint effect can only be seen where it is not a self-motion (see docs/identification.md).
Model RatWithoutHipRx() {
  LimbDescription d = ReadUrdfFile(kUrdf);
  for (JointSpec& j : d.joints) {
    if (j.name == "hip_rx") j.type = JointType::kFixed;
  }
  return Model(d);
}

std::vector<Trial> Simulate(const Model& model, const std::vector<std::string>& effects,
                            unsigned long long seed, int postures = kTrials) {
  std::vector<AppliedEffect> applied;
  for (const std::string& e : effects) applied.push_back(ParseEffectAssignment(model, e));
  SimulationOptions o;
  o.postures = postures;
  o.seed = seed;
  return SimulateTrials(model, ApplyEffects(model.description(), applied), o);
}

std::string TempPath(const std::string& name) {
  return ::testing::TempDir() + "/isowrench_ident_" + name;
}

// ---- CSV --------------------------------------------------------------------------------------

TEST(TrialCsv, WriteThenReadReturnsTheSameTrials) {
  Model model = Rat();
  std::vector<Trial> trials = Simulate(model, {"sensor_offset=0.01,0,0,0,0,0"}, 3, 7);
  std::string path = TempPath("roundtrip.csv");
  WriteTrialsCsv(model, trials, path);
  std::vector<Trial> read = ReadTrialsCsv(model, path);
  ASSERT_EQ(read.size(), trials.size());
  // Written with 10 significant digits: relative error below 1e-9.
  for (size_t k = 0; k < trials.size(); ++k) {
    EXPECT_EQ(read[k].muscle, trials[k].muscle);
    EXPECT_NEAR(read[k].activation, trials[k].activation, 1e-9);
    EXPECT_TRUE(read[k].has_sd);
    for (int c = 0; c < 6; ++c) {
      EXPECT_NEAR(read[k].wrench[c], trials[k].wrench[c],
                  1e-9 * std::max(1.0, std::abs(trials[k].wrench[c])));
      EXPECT_NEAR(read[k].sd[c], trials[k].sd[c], 1e-12);
    }
    for (int j = 0; j < model.dof_count(); ++j) EXPECT_NEAR(read[k].q[j], trials[k].q[j], 1e-9);
  }
}

TEST(TrialCsv, MissingJointColumnsTakeTheNominalPostureAndSdIsOptional) {
  Model model = Rat();
  std::istringstream in("# comment\nknee_rz,muscle,fx,fy,fz,mx,my,mz\n90,GP,1,2,3,4,5,6\n");
  TrialReader reader(model, in, "mem.csv");
  Trial t;
  ASSERT_TRUE(reader.Next(&t));
  EXPECT_EQ(t.line, 3);
  EXPECT_FALSE(t.has_sd);
  EXPECT_DOUBLE_EQ(t.activation, 1.0);
  EXPECT_NEAR(t.q[model.JointIndex("knee_rz")], M_PI / 2, 1e-15);
  EXPECT_NEAR(t.q[model.JointIndex("hip_rz")], model.nominal_posture()[model.JointIndex("hip_rz")],
              1e-15);
  EXPECT_EQ(t.wrench, (Vector6d() << 1, 2, 3, 4, 5, 6).finished());
  EXPECT_FALSE(reader.Next(&t));
}

std::string ReadError(const std::string& text) {
  Model model = Rat();
  std::istringstream in(text);
  try {
    TrialReader reader(model, in, "bad.csv");
    Trial t;
    while (reader.Next(&t)) {
    }
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(TrialCsv, ErrorsNameTheLineAndColumn) {
  const std::string header = "hip_rz,muscle,activation,fx,fy,fz,mx,my,mz\n";
  {
    // An unknown column is ignored with a warning naming it (issue 26: lab sheets have trial
    // ids, dates, comments); the closest known name is suggested.
    isowrench::WarningCollector warnings;
    EXPECT_EQ(ReadError("hip_zz,muscle,fx,fy,fz,mx,my,mz\n"), "(no error)");
    EXPECT_THAT(warnings.text(), AllOf(HasSubstr("bad.csv:1: ignoring column 'hip_zz' (did you "
                                                 "mean 'hip_rz'?)")));
  }
  EXPECT_THAT(ReadError("hip_rz,muscle,fx,fz,mx,my,mz\n"),
              AllOf(HasSubstr("bad.csv:1"), HasSubstr("fy")));
  EXPECT_THAT(ReadError(header + "-110,GP,1,0.1,0.2,nan,0,0,0\n"),
              AllOf(HasSubstr("bad.csv:2"), HasSubstr("column 6 'fz'"), HasSubstr("not finite")));
  EXPECT_THAT(ReadError(header + "-110,GP,1,0.1,0.2,abc,0,0,0\n"),
              AllOf(HasSubstr("bad.csv:2"), HasSubstr("'fz'"), HasSubstr("'abc' is not a number")));
  EXPECT_THAT(ReadError(header + "-110,GP,1,0.1,0.2,0.3,0,0\n"),
              AllOf(HasSubstr("bad.csv:2"), HasSubstr("expected 9 fields"), HasSubstr("found 8")));
  EXPECT_THAT(ReadError(header + "-110,TA,1,0.1,0.2,0.3,0,0,0\n"),
              AllOf(HasSubstr("bad.csv:2"), HasSubstr("'muscle'"), HasSubstr("TA")));
  EXPECT_THAT(
      ReadError(header + "\n# note\n-110,GP,1,0.1,0.2,0.3,0,0,0\n-110,GP,-1,0.1,0.2,0.3,0,0,0\n"),
      AllOf(HasSubstr("bad.csv:5"), HasSubstr("activation")));
  EXPECT_THAT(ReadError("muscle,fx,fy,fz,mx,my,mz,sd_fx\n"), HasSubstr("sd_fy"));
  EXPECT_THAT(ReadError(""), HasSubstr("no header"));
}

// ---- Prediction and effects --------------------------------------------------------------------

TEST(Prediction, MatchesEvaluateWrenchTrialByTrial) {
  Model model = Rat();
  std::vector<Trial> trials = Simulate(model, {}, 11, 5);
  Prediction p = PredictTrials(model, trials);
  ASSERT_EQ(p.failed, 0);
  for (size_t k = 0; k < trials.size(); ++k) {
    Vector6d w =
        EvaluateWrench(model, trials[k].q, trials[k].muscle, trials[k].activation).statics.wrench;
    EXPECT_LE((p.wrench[k] - w).norm(), kIdentityTolerance * w.norm());
  }
}

TEST(Effects, SensorOffsetAddsAndForceScaleMultiplies) {
  Model model = Rat();
  std::vector<Trial> trials = Simulate(model, {}, 12, 4);
  Prediction nominal = PredictTrials(model, trials);
  Vector6d offset;
  offset << 0.1, -0.2, 0.3, 0.01, -0.02, 0.03;
  AugmentedModel shifted =
      ApplyEffects(model.description(),
                   {ParseEffectAssignment(model, "sensor_offset=0.1,-0.2,0.3,0.01,-0.02,0.03")});
  AugmentedModel scaled =
      ApplyEffects(model.description(), {ParseEffectAssignment(model, "force_scale:GP=0.8")});
  Prediction a = PredictTrials(Model(shifted.description), trials, shifted.sensor_offset);
  Prediction b = PredictTrials(Model(scaled.description), trials, scaled.sensor_offset);
  for (size_t k = 0; k < trials.size(); ++k) {
    EXPECT_LE((a.wrench[k] - nominal.wrench[k] - offset).norm(), kIdentityTolerance);
    EXPECT_LE((b.wrench[k] - 0.8 * nominal.wrench[k]).norm(),
              kIdentityTolerance * nominal.wrench[k].norm());
  }
}

TEST(Effects, MisalignmentRotatesTheReadingWithAnIsotropicTransducer) {
  // With S_t isotropic the statics do not depend on the transducer axes, so a transducer turned
  // by R reads blockdiag(R^T, R^T) W.
  Model model = Rat();
  std::vector<Trial> trials = Simulate(model, {}, 13, 4);
  Prediction nominal = PredictTrials(model, trials);
  AugmentedModel turned =
      ApplyEffects(model.description(), {ParseEffectAssignment(model, "misalignment=3,-2,5")});
  Prediction p = PredictTrials(Model(turned.description), trials);
  Eigen::Vector3d v(3, -2, 5);
  v *= M_PI / 180;
  Eigen::Matrix3d R = Eigen::AngleAxisd(v.norm(), v.normalized()).toRotationMatrix();
  for (size_t k = 0; k < trials.size(); ++k) {
    Vector6d expected;
    expected << R.transpose() * nominal.wrench[k].head<3>(),
        R.transpose() * nominal.wrench[k].tail<3>();
    EXPECT_LE((p.wrench[k] - expected).norm(), 1e-10 * expected.norm());
  }
}

TEST(Effects, NamedAssignmentsSetTheNamedParametersAndLeaveTheOthersNeutral) {
  Model model = Rat();
  const AppliedEffect a = ParseEffectAssignment(model, "sensor_offset=fy:0.02, mz:-0.001");
  EXPECT_EQ(a.values, (std::vector<double>{0, 0.02, 0, 0, 0, -0.001}));
  // Every term not named stays at its neutral value (0: no crosstalk).
  const AppliedEffect g = ParseEffectAssignment(model, "crosstalk=mx_fy:0.5");
  ASSERT_EQ(g.values.size(), 30u);
  int set = 0;
  for (size_t k = 0; k < g.values.size(); ++k) {
    if (g.effect.parameters[k].name == "mx_fy") {
      EXPECT_EQ(g.values[k], 0.5);
      ++set;
    } else {
      EXPECT_EQ(g.values[k], 0.0);
    }
  }
  EXPECT_EQ(set, 1);
  EXPECT_THAT([&] { ParseEffectAssignment(model, "sensor_offset=fq:1"); },
              ::testing::ThrowsMessage<Error>(HasSubstr("'fq:1' is not PARAMETER:VALUE")));
  EXPECT_THAT([&] { ParseEffectAssignment(model, "sensor_offset=fx:1,2"); },
              ::testing::ThrowsMessage<Error>(HasSubstr("fx, fy, fz, mx, my, mz")));
  EXPECT_THAT([&] { ParseEffectAssignment(model, "sensor_offset=1,2"); },
              ::testing::ThrowsMessage<Error>(HasSubstr("or name some: sensor_offset=fx:VALUE")));
}

TEST(Effects, LibraryOfTheRatLimbHasEveryKind) {
  // Every registered kind but coactivation (the rat limb has one muscle) and force_length (its
  // muscle has the constant force model) applies to the rat.
  std::set<std::string> kinds;
  for (const Effect& e : CandidateEffects(RatWithoutHipRx())) kinds.insert(e.kind);
  std::set<std::string> registered;
  for (const EffectKindInfo& k : EffectKinds()) registered.insert(k.kind);
  EXPECT_EQ(registered.size(), 17u);
  registered.erase("coactivation");
  registered.erase("force_length");
  EXPECT_EQ(kinds, registered);
  EXPECT_THAT(ParseEffectAssignment(Rat(), "base_isotropic=1e6").effect.id, "base_isotropic");
  EXPECT_THROW(ParseEffectAssignment(Rat(), "misalignment=1"), Error);
  EXPECT_THAT(
      [] { ParseEffectAssignment(Rat(), "wobble=1"); },
      ::testing::ThrowsMessage<Error>(AllOf(HasSubstr("wobble"), HasSubstr("base_isotropic"))));
}

TEST(Simulation, SameSeedSameDataAndNoiseHasTheStatedSd) {
  Model model = Rat();
  std::vector<Trial> a = Simulate(model, {}, 21, 60);
  std::vector<Trial> b = Simulate(model, {}, 21, 60);
  std::vector<Trial> c = Simulate(model, {}, 22, 60);
  for (size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].wrench, b[k].wrench);
    EXPECT_EQ(a[k].q, b[k].q);
  }
  EXPECT_NE(a[0].wrench, c[0].wrench);
  // chi2 / n of the noise alone: 1 within 5 standard deviations sqrt(2/n).
  Prediction p = PredictTrials(model, a);
  ResidualStats s = ComputeResidualStats(a, p.wrench, 0);
  double n = s.residual_count;
  EXPECT_NEAR(s.chi2 / n, 1.0, 5 * std::sqrt(2.0 / n));
}

// ---- The loop ----------------------------------------------------------------------------------

FitOptions TestOptions() {
  FitOptions o;
  o.max_rounds = 2;  // one effect, then a round that must find nothing
  return o;
}

/// Check a parameter against its truth within kSigmas reported standard errors (in log10 for
/// log-scaled parameters). Returns the error in standard errors.
double CheckParameter(const CandidateFit& f, size_t i, double truth) {
  const EffectParameter& p = f.effect.parameters[i];
  double error = 0, se = 0;
  if (p.scale == ParameterScale::kLog10) {
    error = std::log10(f.values[i]) - std::log10(truth);
    se = f.log10_standard_errors[i];
  } else {
    error = f.values[i] - truth;
    se = f.standard_errors[i];
  }
  EXPECT_GT(se, 0) << f.effect.id << "." << p.name;
  EXPECT_LE(std::abs(error), kSigmas * se)
      << f.effect.id << "." << p.name << " = " << f.values[i] << " vs " << truth;
  return se > 0 ? error / se : 0;
}

struct DetectionCase {
  std::string effect;                   ///< simulate assignment
  std::vector<std::string> equivalent;  ///< ids accepted as the first choice (the effect first)
  bool four_dof = false;                ///< use RatWithoutHipRx()
};

const std::vector<DetectionCase>& AllCases() {
  static const std::vector<DetectionCase> cases = {
      {"base_isotropic=1e7", {"base_isotropic", "base_per_axis"}},
      {"base_per_axis=3e6,3e7,1e7", {"base_per_axis"}},
      {"extra_joint:hip_ry:x=1e6", {"extra_joint:hip_ry:x", "extra_joint:knee_rx:y"}, true},
      {"transducer_anisotropy=0.1", {"transducer_anisotropy"}},
      {"transducer_soft:rz=1e5", {"transducer_soft:rz"}},
      {"misalignment=2,-1,1", {"misalignment"}},
      {"sensor_offset=0.02,-0.01,0.01,0.001,0,-0.0005", {"sensor_offset"}},
      {"force_scale:GP=0.85", {"force_scale:GP"}},
      {"attachment:GP:0=1,-0.5,0.5", {"attachment:GP:0"}},
      {"attachment:GP:1=1,-0.5,0.5", {"attachment:GP:1"}},
      {"moment_reference=2,1,-1", {"moment_reference"}}};
  return cases;
}

TEST(FitLoop, DetectionRatesAndParameterErrorsOverSeeds) {
  // Every candidate of the library, simulated at a realistic magnitude, over 5 seeds: the fit
  // must name it (or an equivalent) first, claim nothing else, bring the residual to the noise
  // (verdict kExplained) and recover each parameter within kSigmas reported SEs; the rate and
  // the errors in units of the reported SE are printed for the closing note. If the
  // standard errors are honest, z = error / SE is ~N(0, 1): mean z^2 ~ 1. With ~100 z values
  // (correlated within an effect) mean z^2 within [0.4, 2.5] rejects SEs off by a factor ~1.6.
  const int seeds = kRateSeeds;
  double z2 = 0;
  int nz = 0, detected_total = 0, runs = 0;
  for (const DetectionCase& c : AllCases()) {
    Model model = c.four_dof ? RatWithoutHipRx() : Rat();
    AppliedEffect truth = ParseEffectAssignment(model, c.effect);
    int detected = 0, exact = 0, flagged = 0;
    double worst = 0;
    for (int seed = 0; seed < seeds; ++seed) {
      FitReport r = FitEffects(model, Simulate(model, {c.effect}, 7000 + 13 * seed), TestOptions());
      ++runs;
      if (seed == 0) {
        std::cout << "[detection] " << c.effect << ": " << r.BriefReport();
      }
      if (r.chosen.size() != 1 || r.verdict != FitVerdict::kExplained) continue;
      if (std::find(c.equivalent.begin(), c.equivalent.end(), r.chosen[0].effect.id) ==
          c.equivalent.end()) {
        // Not named first: acceptable only when the report says the truth is indistinguishable.
        const std::vector<std::string>& same = r.rounds.at(0).indistinguishable;
        if (std::find(same.begin(), same.end(), truth.effect.id) != same.end()) ++flagged;
        continue;
      }
      ++detected;
      if (r.chosen[0].effect.id != truth.effect.id) continue;
      ++exact;
      const CandidateFit& f = r.chosen_fits[0];
      for (size_t i = 0; i < truth.values.size(); ++i) {
        const EffectParameter& p = f.effect.parameters[i];
        double z = p.scale == ParameterScale::kLog10
                       ? (std::log10(f.values[i]) - std::log10(truth.values[i])) /
                             f.log10_standard_errors[i]
                       : (f.values[i] - truth.values[i]) / f.standard_errors[i];
        z2 += z * z;
        ++nz;
        worst = std::max(worst, std::abs(z));
        EXPECT_LE(std::abs(z), kSigmas)
            << c.effect << " seed " << seed << ": " << p.name << " = " << f.values[i];
      }
    }
    detected_total += detected;
    std::cout << "[rates] " << c.effect << ": named first " << detected << "/" << seeds
              << " (exact id " << exact << "/" << seeds
              << "), otherwise reported indistinguishable from the winner " << flagged << "/"
              << seeds << ", largest |error|/SE " << worst << "\n";
    EXPECT_GE(detected, seeds - 1) << c.effect;
    EXPECT_EQ(detected + flagged, seeds) << c.effect;
  }
  std::cout << "[rates] overall " << detected_total << "/" << runs
            << ", mean (error/SE)^2 = " << z2 / nz << " over " << nz << " parameters\n";
  EXPECT_GT(z2 / nz, 0.4);
  EXPECT_LT(z2 / nz, 2.5);
}

TEST(FitLoop, DataWithoutAnEffectRarelyProduceAClaim) {
  // False-alarm rate over 20 seeds of small data sets (30 trials, one round): with the BIC
  // threshold 10 + 2 ln(M) a claim should be rare; allow at most 1.
  Model model = Rat();
  FitOptions o;
  o.max_rounds = 1;
  int claims = 0;
  const int seeds = kFalseAlarmSeeds;
  for (int seed = 1; seed <= seeds; ++seed) {
    std::vector<Trial> trials = Simulate(model, {}, 1000 + seed, 30);
    FitReport r = FitEffects(model, trials, o);
    if (!r.chosen.empty()) ++claims;
    EXPECT_NE(r.verdict, FitVerdict::kUnexplained);
  }
  std::cout << "[false-alarm] " << claims << " claimed effect(s) in " << seeds
            << " data sets without an effect\n";
  EXPECT_LE(claims, 1);
}

TEST(FitLoop, TheTablesKIsTheBicPenaltyOfEveryCandidate) {
  // Every fitted candidate of every round: BIC - cost = (k of the current model + the row's k)
  // ln n, the current model's k being the sum of the previous winners' k (stated sd: BIC =
  // cost + k ln n). Covers k = 1, 3, 6, 30 (fitted in round 1 by the default screen) and
  // trial_force's 1 + muscles.
  Model model = Rat();
  const std::vector<Trial> trials =
      Simulate(model, {"base_isotropic=3e6", "force_scale:GP=0.9"}, 207);
  FitOptions o;
  o.max_rounds = 3;
  const FitReport r = FitEffects(model, trials, o);
  ASSERT_EQ(r.chosen.size(), 2u) << r.BriefReport();
  const double log_n = std::log(6.0 * trials.size());
  int current_k = 0, checked = 0, scaled = 0;
  std::set<int> ks;
  for (const FitRound& round : r.rounds) {
    for (const CandidateFit& f : round.candidates) {
      if (f.screened_out || !f.converged) continue;
      const double penalty = (f.bic - f.cost) / log_n;
      EXPECT_NEAR(penalty, current_k + f.added_parameters, 1e-9 * (1 + penalty))
          << "round " << round.index << " " << f.effect.id;
      if (f.effect.id == "trial_force") {
        // The spread and GP's level, less force_scale:GP once chosen (it would replace it).
        EXPECT_EQ(f.added_parameters, 2 - scaled) << "round " << round.index;
      }
      ks.insert(f.added_parameters);
      ++checked;
    }
    if (!round.chosen) continue;
    current_k += round.candidates[*round.chosen].added_parameters;
    scaled += round.candidates[*round.chosen].effect.id == "force_scale:GP";
  }
  EXPECT_GE(checked, 25);
  for (int k : {1, 2, 3, 6, 30}) EXPECT_TRUE(ks.count(k)) << k;
}

TEST(FitLoop, TwoEffectsAreTracedInTwoRounds) {
  Model model = Rat();
  std::vector<Trial> trials =
      Simulate(model, {"base_isotropic=1e7", "sensor_offset=0.02,-0.01,0.01,0.001,0,-0.0005"}, 202);
  FitOptions o;
  o.max_rounds = 3;
  FitReport r = FitEffects(model, trials, o);
  ASSERT_EQ(r.chosen.size(), 2u) << r.BriefReport();
  std::set<std::string> ids = {r.chosen[0].effect.id, r.chosen[1].effect.id};
  EXPECT_TRUE(ids.count("sensor_offset")) << r.BriefReport();
  EXPECT_TRUE(ids.count("base_isotropic") || ids.count("base_per_axis")) << r.BriefReport();
  EXPECT_EQ(r.verdict, FitVerdict::kExplained) << r.BriefReport();
  EXPECT_GE(r.rounds.size(), 2u);
  for (size_t e = 0; e < 2; ++e) {
    if (r.chosen[e].effect.id == "sensor_offset") {
      const double truth[6] = {0.02, -0.01, 0.01, 0.001, 0, -0.0005};
      for (int i = 0; i < 6; ++i) CheckParameter(r.chosen_fits[e], i, truth[i]);
    } else {
      for (size_t i = 0; i < r.chosen[e].values.size(); ++i)
        CheckParameter(r.chosen_fits[e], i, 1e7);
    }
  }
  std::cout << "[two-effects] " << r.BriefReport();
}

TEST(FitLoop, TwoEffectsWhoseFirstFitIsBiasedAreStillTraced) {
  // Fitted alone, a base compliance absorbs part of a force scale (round 1 is biased); the
  // second round refits the first effect jointly, so both are found with their true values.
  Model model = Rat();
  std::vector<Trial> trials = Simulate(model, {"base_isotropic=3e6", "force_scale:GP=0.9"}, 207);
  FitOptions o;
  o.max_rounds = 3;
  FitReport r = FitEffects(model, trials, o);
  ASSERT_EQ(r.chosen.size(), 2u) << r.BriefReport();
  EXPECT_EQ(r.verdict, FitVerdict::kExplained) << r.BriefReport();
  for (size_t e = 0; e < 2; ++e) {
    const std::string& id = r.chosen[e].effect.id;
    if (id == "force_scale:GP") {
      CheckParameter(r.chosen_fits[e], 0, 0.9);
    } else {
      EXPECT_TRUE(id == "base_isotropic" || id == "base_per_axis") << id;
      for (size_t i = 0; i < r.chosen[e].values.size(); ++i)
        CheckParameter(r.chosen_fits[e], i, 3e6);
    }
  }
  std::cout << "[two-effects-biased] " << r.BriefReport();
}

TEST(FitLoop, AnEffectOutsideTheLibraryEndsUnexplained) {
  // A passive stiffness on hip_ry (not a candidate) makes the residual structured; no candidate
  // can remove it, so the verdict must be "unexplained residual" and nothing is claimed.
  Model model = Rat();
  Model truth(WithJointStiffness(model.description(), "hip_ry", 1e4));
  SimulationOptions so;
  so.postures = kTrials;
  so.seed = 303;
  AugmentedModel t;
  t.description = truth.description();
  std::vector<Trial> trials = SimulateTrials(model, t, so);
  FitReport r = FitEffects(model, trials, TestOptions());
  EXPECT_EQ(r.verdict, FitVerdict::kUnexplained) << r.BriefReport();
  EXPECT_FALSE(r.effects_claimed);
  EXPECT_THAT(r.BriefReport(), HasSubstr("not claimed"));
  std::cout << "[absent] " << r.BriefReport();
}

TEST(FitLoop, AnEffectTheWrenchCannotSeeIsNotClaimedAndIsFlagged) {
  // An extra knee dof on the 5-dof rat limb combines with the ball hip into a spin of the femur
  // about its axis that leaves the endpoint fixed: the GP wrench does not depend on its
  // stiffness, so the data equal nominal data and the candidate must be flagged.
  Model model = Rat();
  std::vector<Trial> trials = Simulate(model, {"extra_joint:knee_rx:y=1e3"}, 404);
  FitOptions o;
  o.max_rounds = 1;
  FitReport r = FitEffects(model, trials, o);
  EXPECT_TRUE(r.chosen.empty()) << r.BriefReport();
  EXPECT_EQ(r.verdict, FitVerdict::kNominalFits);
  bool found = false;
  for (const CandidateFit& f : r.rounds.at(0).candidates) {
    if (f.effect.id != "extra_joint:knee_rx:y") continue;
    found = true;
    EXPECT_FALSE(f.accepted);
    EXPECT_LT(f.delta_bic, r.rounds.at(0).bic_threshold);
  }
  EXPECT_TRUE(found);
}

TEST(FitLoop, AugmentedUrdfReproducesTheFittedPrediction) {
  Model model = Rat();
  std::vector<Trial> trials = Simulate(model, {"transducer_soft:rz=1e5"}, 505);
  FitOptions o;
  o.max_rounds = 1;
  o.candidates = {"transducer_soft:rz", "base_isotropic"};
  FitReport r = FitEffects(model, trials, o);
  ASSERT_EQ(r.chosen.size(), 1u);
  std::string path = TempPath("augmented.urdf");
  WriteAugmentedUrdf(r, path);
  Model augmented = Model::FromUrdfFile(path);
  Prediction p = PredictTrials(augmented, trials, r.augmented.sensor_offset);
  ResidualStats s = ComputeResidualStats(trials, p.wrench, 1);
  // URDF numbers are written with full precision: the chi2 agrees to rounding.
  EXPECT_NEAR(s.chi2, r.after.chi2, 1e-6 * r.after.chi2);
  EXPECT_NEAR(augmented.transducer().stiffness[kRZ], r.chosen[0].values[0],
              1e-6 * r.chosen[0].values[0]);
}

TEST(FitLoop, RejectsEmptyDataAndUnknownCandidates) {
  Model model = Rat();
  EXPECT_THROW(FitEffects(model, {}), Error);
  FitOptions o;
  o.candidates = {"nonsense"};
  EXPECT_THAT([&] { FitEffects(model, Simulate(model, {}, 1, 5), o); },
              ::testing::ThrowsMessage<Error>(HasSubstr("nonsense")));
}

}  // namespace
}  // namespace isowrench
