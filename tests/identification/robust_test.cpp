// Tests of the effects added with the registry (trial_force, joint_offset, gain, crosstalk,
// coactivation, sensor_origin), the robust loss and outlier rows, the trace of an unexplained
// residual and the correlation report: identities derived by hand, then simulate-then-fit round
// trips with Gaussian, Student-t(3) and 5 % gross-outlier noise.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <random>
#include <set>

#include "identification/identification_impl.hpp"
#include "isowrench/error.hpp"
#include "isowrench/identification.hpp"
#include "isowrench/trial_csv.hpp"

namespace isowrench {
namespace {

using ::testing::HasSubstr;

const std::string kRat = std::string(ISOWRENCH_TEST_URDF_DIR) + "/rat_hindlimb_5dof.urdf";
const std::string kPlanar = std::string(ISOWRENCH_TEST_URDF_DIR) + "/planar_2r.urdf";

/// Parameter recovery: |estimate - truth| <= kSigmas reported standard errors (seeded data).
constexpr double kSigmas = 4.0;
/// Algebraic identities evaluated through a different sequence of operations.
constexpr double kIdentity = 1e-12;
#if defined(__SANITIZE_ADDRESS__) || defined(ISOWRENCH_TEST_SANITIZED)
constexpr bool kSanitizer = true;
constexpr int kNullSeeds = 4;
#else
constexpr bool kSanitizer = false;
constexpr int kNullSeeds = 20;
#endif

std::vector<Trial> Simulate(const Model& model, const std::vector<std::string>& effects,
                            unsigned long long seed, int postures, int noise_dof = 0,
                            double outliers = 0.0) {
  std::vector<AppliedEffect> applied;
  for (const std::string& e : effects) applied.push_back(ParseEffectAssignment(model, e));
  SimulationOptions o;
  o.postures = postures;
  o.seed = seed;
  o.noise_dof = noise_dof;
  o.outlier_fraction = outliers;
  return SimulateTrials(model, ApplyEffects(model.description(), applied), o);
}

std::vector<Trial> Noiseless(const Model& model, const std::vector<std::string>& effects,
                             int postures) {
  std::vector<AppliedEffect> applied;
  for (const std::string& e : effects) applied.push_back(ParseEffectAssignment(model, e));
  SimulationOptions o;
  o.postures = postures;
  o.seed = 99;
  o.noise_force = 0;
  o.noise_moment = 0;
  return SimulateTrials(model, ApplyEffects(model.description(), applied), o);
}

Prediction Predict(const Model& model, const std::vector<std::string>& effects,
                   const std::vector<Trial>& trials, std::vector<double>* factors = nullptr) {
  std::vector<AppliedEffect> applied;
  for (const std::string& e : effects) applied.push_back(ParseEffectAssignment(model, e));
  return PredictTrials(ApplyEffects(model.description(), applied), trials, factors);
}

// ---- identities
// ----------------------------------------------------------------------------------

TEST(NewEffects, GainScalesOneAxisAndSensorOriginShiftsTheMoment) {
  Model model = Model::FromUrdfFile(kRat);
  std::vector<Trial> trials = Noiseless(model, {}, 5);
  Prediction nominal = PredictTrials(model, trials);
  Prediction gain = Predict(model, {"gain:my=1.25"}, trials);
  Prediction origin = Predict(model, {"sensor_origin=2,-3,4"}, trials);
  const Eigen::Vector3d d(0.002, -0.003, 0.004);
  for (size_t k = 0; k < trials.size(); ++k) {
    Vector6d expected = nominal.wrench[k];
    expected[4] *= 1.25;
    EXPECT_LE((gain.wrench[k] - expected).norm(), kIdentity * expected.norm());
    // Moment about o + d of a force f applied at o: m - d x f, written out by components.
    const Vector6d& w = nominal.wrench[k];
    Vector6d shifted = w;
    shifted[3] -= d.y() * w[2] - d.z() * w[1];
    shifted[4] -= d.z() * w[0] - d.x() * w[2];
    shifted[5] -= d.x() * w[1] - d.y() * w[0];
    EXPECT_LE((origin.wrench[k] - shifted).norm(), kIdentity * w.norm());
  }
}

// Crosstalk (all 30 terms, what it contains): tests/identification/calibration_test.cpp.

TEST(NewEffects, JointOffsetPredictsAtTheShiftedPosture) {
  Model model = Model::FromUrdfFile(kRat);
  std::vector<Trial> trials = Noiseless(model, {}, 5);
  Prediction shifted = Predict(model, {"joint_offset:knee_rz=3"}, trials);
  std::vector<Trial> moved = trials;
  const int knee = model.JointIndex("knee_rz");
  for (Trial& t : moved) t.q[knee] += 3.0 * M_PI / 180.0;
  Prediction direct = PredictTrials(model, moved);
  for (size_t k = 0; k < trials.size(); ++k) {
    EXPECT_LE((shifted.wrench[k] - direct.wrench[k]).norm(), kIdentity * direct.wrench[k].norm());
  }
}

TEST(NewEffects, CoactivationAddsTheOtherMusclesWrench) {
  // Linear statics: the reading of a trial of muscle A with B coactivated at fraction c is
  // W_A(activation) + c W_B(1).
  Model model = Model::FromUrdfFile(kPlanar);
  ASSERT_GE(model.muscle_count(), 2);
  const std::string a = model.muscle(0).name, b = model.muscle(1).name;
  std::vector<Trial> trials = Noiseless(model, {}, 6);
  Prediction with = Predict(model, {"coactivation:" + b + "=0.3"}, trials);
  Prediction plain = PredictTrials(model, trials);
  for (size_t k = 0; k < trials.size(); ++k) {
    Vector6d expected = plain.wrench[k];
    if (trials[k].muscle != b) {
      Trial t = trials[k];
      t.muscle = b;
      t.activation = 1.0;
      expected += 0.3 * PredictTrials(model, {t}).wrench[0];
    }
    EXPECT_LE((with.wrench[k] - expected).norm(), 1e-12 * (1 + expected.norm())) << "trial " << k;
  }
}

TEST(NewEffects, TrialFactorsAreSolvedExactlyOnNoiselessData) {
  Model model = Model::FromUrdfFile(kRat);
  std::vector<Trial> trials = Noiseless(model, {}, 6);
  Prediction nominal = PredictTrials(model, trials);
  const double truth[6] = {0.9, 1.1, 1.0, 0.8, 1.25, 1.05};
  for (size_t k = 0; k < trials.size(); ++k) trials[k].wrench = truth[k] * nominal.wrench[k];
  std::vector<double> factors;
  Prediction p = Predict(model, {"trial_force=0.1"}, trials, &factors);
  ASSERT_EQ(factors.size(), trials.size());
  for (size_t k = 0; k < trials.size(); ++k) {
    EXPECT_NEAR(factors[k], truth[k], 1e-12);
    EXPECT_LE((p.wrench[k] - trials[k].wrench).norm(), 1e-12 * trials[k].wrench.norm());
  }
}

TEST(NewEffects, RegistryListsEveryKindOnceWithDocumentation) {
  std::set<std::string> kinds;
  for (const EffectKindInfo& k : EffectKinds()) {
    EXPECT_TRUE(kinds.insert(k.kind).second) << k.kind;
    EXPECT_FALSE(k.summary.empty()) << k.kind;
    EXPECT_FALSE(k.parameters.empty()) << k.kind;
    EXPECT_EQ(k.id_pattern.rfind(k.kind, 0), 0u) << k.id_pattern;
  }
  for (const char* k :
       {"trial_force", "joint_offset", "gain", "crosstalk", "coactivation", "sensor_origin"}) {
    EXPECT_TRUE(kinds.count(k)) << k;
  }
  EXPECT_EQ(ParseRobustLoss("cauchy"), RobustLoss::kCauchy);
  EXPECT_THAT([] { ParseRobustLoss("l1"); }, ::testing::ThrowsMessage<Error>(HasSubstr("huber")));
}

// ---- screening

TEST(Screening, AnEffectWithoutInfluenceScoresItsBicPenaltyNotNaN) {
  // Sensitivities that are all exactly 0 (an effect that changes nothing at its neutral value,
  // such as a very stiff extra joint): the linearised gain is the BIC penalty of the two
  // parameters, -2 ln n. Before, the least-squares solve divided 0 by 0, the NaN score broke the
  // ranking of the candidates, and a round-trip fit dropped the true effect from the fitted set.
  const int n = 12;
  Eigen::VectorXd r(n);
  for (int i = 0; i < n; ++i) r[i] = 0.1 * (i + 1) * (i % 2 ? -1.0 : 1.0);
  const Eigen::MatrixXd none = Eigen::MatrixXd::Zero(n, 2);
  EXPECT_DOUBLE_EQ(ident::LinearisedDeltaBic(none, r, n, true), -2.0 * std::log(double{n}));
  EXPECT_DOUBLE_EQ(ident::LinearisedDeltaBic(none, r, n, false), -2.0 * std::log(double{n}));
  // One column along r explains all of it (cost r.r, one parameter); one orthogonal to r explains
  // nothing.
  Eigen::MatrixXd along = 3.0 * r;
  EXPECT_NEAR(ident::LinearisedDeltaBic(along, r, n, true), r.squaredNorm() - std::log(double{n}),
              1e-12);
  Eigen::MatrixXd orthogonal = Eigen::MatrixXd::Zero(n, 1);
  orthogonal(0, 0) = r[1];
  orthogonal(1, 0) = -r[0];
  EXPECT_NEAR(ident::LinearisedDeltaBic(orthogonal, r, n, true), -std::log(double{n}), 1e-12);
}

// ---- round trips
// ---------------------------------------------------------------------------------

struct RoundTrip {
  std::string model;
  std::vector<std::string> effects;   ///< simulate assignments
  std::vector<std::string> expected;  ///< ids that must be chosen (any order)
};

std::string util_label(const RoundTrip& c, int noise_dof, double outliers) {
  std::string s;
  for (const std::string& e : c.effects) s += e + " ";
  s += noise_dof ? "t(" + std::to_string(noise_dof) + ")" : "gaussian";
  if (outliers > 0) s += " + 5% outliers";
  return s;
}

/// Fit, check the chosen ids, the verdict and every least-squares parameter within kSigmas SE.
/// Sum of (error / SE)^2 over the recovered parameters and their count.
struct ZSquared {
  double sum = 0.0;
  int count = 0;
};

void CheckRoundTrip(const RoundTrip& c, int noise_dof, double outliers, unsigned long long seed,
                    ZSquared* z2 = nullptr) {
  Model model = Model::FromUrdfFile(c.model);
  std::vector<Trial> trials = Simulate(model, c.effects, seed, 60, noise_dof, outliers);
  FitOptions o;
  o.max_rounds = static_cast<int>(c.expected.size()) + 1;
  FitReport r = FitEffects(model, trials, o);
  const std::string label = util_label(c, noise_dof, outliers);
  std::cout << "[round-trip] " << label << ": "
            << r.BriefReport().substr(0, r.BriefReport().find('\n')) << "\n";
  std::set<std::string> ids;
  for (const AppliedEffect& a : r.chosen) ids.insert(a.effect.id);
  EXPECT_EQ(ids, std::set<std::string>(c.expected.begin(), c.expected.end())) << label << "\n"
                                                                              << r.BriefReport();
  EXPECT_EQ(r.verdict, FitVerdict::kExplained) << label << "\n" << r.BriefReport();
  if (outliers > 0) {
    EXPECT_GE(r.outlier_rows.size(), static_cast<size_t>(std::lround(outliers * trials.size())))
        << label;
  } else if (noise_dof == 0) {
    EXPECT_TRUE(r.outlier_rows.empty()) << label;
  }
  for (size_t e = 0; e < r.chosen.size(); ++e) {
    const CandidateFit& f = r.chosen_fits[e];
    if (f.effect.per_trial) continue;
    for (const std::string& assignment : c.effects) {
      if (assignment.substr(0, assignment.find('=')) != f.effect.id) continue;
      const std::vector<double> truth = ParseEffectAssignment(model, assignment).values;
      for (size_t i = 0; i < truth.size(); ++i) {
        const bool log = f.effect.parameters[i].scale == ParameterScale::kLog10;
        const double err =
            log ? std::log10(f.values[i]) - std::log10(truth[i]) : f.values[i] - truth[i];
        const double se = log ? f.log10_standard_errors[i] : f.standard_errors[i];
        EXPECT_GT(se, 0) << label << " " << f.effect.parameters[i].name;
        if (z2 && se > 0) {
          z2->sum += (err / se) * (err / se);
          ++z2->count;
        }
        EXPECT_LE(std::abs(err), kSigmas * se)
            << label << " " << f.effect.id << "." << f.effect.parameters[i].name << " = "
            << f.values[i] << " vs " << truth[i];
      }
    }
  }
}

const std::vector<RoundTrip>& Singles() {
  static const std::vector<RoundTrip> cases = {
      {kRat, {"trial_force=0.05"}, {"trial_force"}},
      {kRat, {"joint_offset:knee_rz=3"}, {"joint_offset:knee_rz"}},
      {kRat, {"gain:fx=1.05"}, {"gain:fx"}},
      {kRat, {"crosstalk=fx_fy:0.03,fy_fx:0.03,my_mz:0.01,mz_my:0.01"}, {"crosstalk"}},
      {kPlanar, {"coactivation:biarticular=0.2"}, {"coactivation:biarticular"}},
      {kRat, {"sensor_origin=3,0,-2"}, {"sensor_origin"}},
  };
  return cases;
}

TEST(RoundTrips, EachNewEffectAloneWithGaussianNoise) {
  // Besides each parameter within 4 SE: the reported standard errors are honest, i.e. the mean
  // of (error / SE)^2 over every recovered parameter of every effect and seed is near 1 (it is a
  // mean of chi^2_1 variables; the bounds allow for the few dozen, partly correlated, terms).
  ZSquared z2;
  const int seeds = kSanitizer ? 1 : 3;
  for (int seed = 0; seed < seeds; ++seed) {
    for (const RoundTrip& c : Singles()) CheckRoundTrip(c, 0, 0.0, 31 + 100 * seed, &z2);
  }
  std::cout << "[round-trip] mean (error/SE)^2 = " << z2.sum / z2.count << " over " << z2.count
            << " parameters\n";
  ASSERT_GT(z2.count, 0);
  if (!kSanitizer) {
    EXPECT_GT(z2.sum / z2.count, 0.4);
    EXPECT_LT(z2.sum / z2.count, 2.0);
  }
}

TEST(RoundTrips, EachNewEffectAloneWithStudentT3Noise) {
  if (kSanitizer)
    GTEST_SKIP() << "statistical repeat of the Gaussian round trips; run without sanitizers";
  for (const RoundTrip& c : Singles()) CheckRoundTrip(c, 3, 0.0, 32);
}

TEST(RoundTrips, EachNewEffectAloneWithFivePercentOutliers) {
  if (kSanitizer)
    GTEST_SKIP() << "statistical repeat of the Gaussian round trips; run without sanitizers";
  for (const RoundTrip& c : Singles()) CheckRoundTrip(c, 0, 0.05, 33);
}

TEST(RoundTrips, NewEffectsInPairsWithExistingOnes) {
  const std::vector<RoundTrip> pairs = {
      {kRat, {"trial_force=0.05", "base_isotropic=1e7"}, {"trial_force", "base_isotropic"}},
      {kRat,
       {"gain:fy=1.1", "sensor_offset=0.02,-0.01,0.01,0.001,0,-0.0005"},
       {"gain:fy", "sensor_offset"}},
      {kRat,
       {"joint_offset:knee_rz=3", "misalignment=2,-1,1"},
       {"joint_offset:knee_rz", "misalignment"}},
      {kRat, {"sensor_origin=3,0,-2", "force_scale:GP=0.9"}, {"sensor_origin", "force_scale:GP"}},
  };
  for (const RoundTrip& c : pairs) CheckRoundTrip(c, 0, kSanitizer ? 0.0 : 0.05, 34);
}

// ---- streaming -------------------------------------------------------------------------------

TEST(Streaming, SimulationInSmallChunksGivesTheSameTrialsAsInMemory) {
  // The chunked generator positions three copies of the seeded stream (postures, noise, outlier
  // signs); chunks of 7 must reproduce the one-chunk order exactly, Student-t noise, per-trial
  // force factors and gross outliers included.
  Model model = Model::FromUrdfFile(kRat);
  std::vector<AppliedEffect> applied = {ParseEffectAssignment(model, "trial_force=0.1")};
  const AugmentedModel truth = ApplyEffects(model.description(), applied);
  SimulationOptions o;
  o.postures = 45;
  o.seed = 77;
  o.noise_dof = 4;
  o.outlier_fraction = 0.1;
  const std::vector<Trial> whole = SimulateTrials(model, truth, o);
  std::vector<Trial> chunked;
  std::vector<long> progress;
  ForEachSimulatedTrial(
      model, truth, o, [&](const Trial& t) { chunked.push_back(t); },
      [&](long rows, double) { progress.push_back(rows); }, 7);
  ASSERT_EQ(chunked.size(), whole.size());
  for (size_t k = 0; k < whole.size(); ++k) {
    EXPECT_EQ(chunked[k].line, whole[k].line);
    EXPECT_EQ(chunked[k].muscle, whole[k].muscle);
    EXPECT_EQ(chunked[k].activation, whole[k].activation);
    EXPECT_EQ(chunked[k].q, whole[k].q);
    EXPECT_EQ(chunked[k].wrench, whole[k].wrench) << "trial " << k;
  }
  EXPECT_EQ(progress, (std::vector<long>{7, 14, 21, 28, 35, 42, 45}));
  // The 5 outliers (10 % of 45) sit on trials 4, 13, 22, 31, 40 (every 9th, centred), and
  // their signs are drawn after all the noise: without outliers the same seed gives the same
  // trials except that those rows are exactly 50 sd off on every component.
  SimulationOptions clean_options = o;
  clean_options.outlier_fraction = 0.0;
  const std::vector<Trial> clean = SimulateTrials(model, truth, clean_options);
  ASSERT_EQ(clean.size(), whole.size());
  for (size_t k = 0; k < whole.size(); ++k) {
    for (int c = 0; c < 6; ++c) {
      const double off = std::abs(whole[k].wrench[c] - clean[k].wrench[c]) / whole[k].sd[c];
      EXPECT_NEAR(off, k % 9 == 4 ? 50.0 : 0.0, 1e-6) << "trial " << k << " component " << c;
    }
  }
}

// ---- screening -----------------------------------------------------------------------------

TEST(Screening, TheScoreOfAnEffectLinearInItsParametersIsItsExactChi2Reduction) {
  // A sensor offset enters the reading linearly, so one Gauss-Newton step from zero is the least
  // squares solution: the linearised ΔBIC of the screening step must equal the ΔBIC of the full
  // fit (plain least squares, so no row weights move), and the candidates the screen dropped are
  // reported as such, unfitted, below the threshold of the winner.
  Model model = Model::FromUrdfFile(kRat);
  std::vector<Trial> trials = Simulate(model, {"sensor_offset=0.01,0,0,0,0,-0.0002"}, 61, 40);
  FitOptions o;
  o.max_rounds = 1;
  o.loss = RobustLoss::kNone;
  o.candidates = {"gain:fx", "sensor_offset", "misalignment", "joint_offset:knee_rz"};
  o.screen_keep = 1;
  FitReport r = FitEffects(model, trials, o);
  ASSERT_EQ(r.rounds.size(), 1u);
  const FitRound& round = r.rounds[0];
  ASSERT_EQ(round.candidates.size(), 4u);
  const CandidateFit& kept = round.candidates[0];
  EXPECT_EQ(kept.effect.id, "sensor_offset");
  EXPECT_FALSE(kept.screened_out);
  EXPECT_GT(kept.delta_bic, 100.0);
  EXPECT_NEAR(kept.screen_delta_bic, kept.delta_bic, 1e-6 * kept.delta_bic);
  for (size_t i = 1; i < round.candidates.size(); ++i) {
    const CandidateFit& f = round.candidates[i];
    EXPECT_TRUE(f.screened_out) << f.effect.id;
    EXPECT_FALSE(f.accepted) << f.effect.id;
    EXPECT_TRUE(f.values.empty()) << f.effect.id;
    EXPECT_LT(f.screen_delta_bic, kept.screen_delta_bic) << f.effect.id;
    EXPECT_THAT(f.verdict, HasSubstr("screened out")) << f.effect.id;
  }
  ASSERT_EQ(r.chosen.size(), 1u);
  EXPECT_EQ(r.chosen[0].effect.id, "sensor_offset");
}

TEST(Screening, FittingOnlyTheBestScoresChoosesWhatFittingEveryCandidateChooses) {
  // A posture effect (nonlinear in its parameter) with the whole library: the default screen and
  // no screen at all must choose the same effect with the same value.
  Model model = Model::FromUrdfFile(kRat);
  std::vector<Trial> trials = Simulate(model, {"joint_offset:knee_rz=3"}, 62, 40);
  FitOptions o;
  o.max_rounds = 1;
  FitReport screened = FitEffects(model, trials, o);
  o.screen_keep = 0;
  FitReport full = FitEffects(model, trials, o);
  ASSERT_EQ(full.chosen.size(), 1u) << full.BriefReport();
  ASSERT_EQ(screened.chosen.size(), 1u) << screened.BriefReport();
  EXPECT_EQ(screened.chosen[0].effect.id, full.chosen[0].effect.id);
  EXPECT_EQ(full.chosen[0].effect.id, "joint_offset:knee_rz");
  EXPECT_NEAR(screened.chosen[0].values[0], full.chosen[0].values[0],
              1e-3 * full.chosen_fits[0].standard_errors[0]);
  int dropped = 0;
  for (const CandidateFit& f : screened.rounds[0].candidates) dropped += f.screened_out;
  // screen_keep least-squares candidates are fitted, and the per-trial one (trial_force) besides.
  EXPECT_EQ(dropped,
            static_cast<int>(screened.rounds[0].candidates.size()) - FitOptions().screen_keep - 1);
}

// ---- null data, unexplained residual
// -------------------------------------------------------------

TEST(RobustFit, NullDataWithHeavyTailsAndOutliersRarelyProduceAClaim) {
  // Data without an effect, Student-t(3) noise and 5 % gross outliers: with the robust loss no
  // effect may be claimed in more than 5 % of the data sets (at most 1 of 20).
  Model model = Model::FromUrdfFile(kRat);
  FitOptions o;
  o.max_rounds = 1;
  int claims = 0;
  for (int seed = 1; seed <= kNullSeeds; ++seed) {
    FitReport r = FitEffects(model, Simulate(model, {}, 5000 + seed, 40, 3, 0.05), o);
    if (!r.chosen.empty()) {
      ++claims;
      std::cout << "[null-robust] seed " << seed << ": " << r.BriefReport();
    }
    EXPECT_NE(r.verdict, FitVerdict::kUnexplained) << r.BriefReport();
    // The 2 injected rows, and perhaps a t(3) tail row or two.
    EXPECT_GE(r.outlier_rows.size(), 2u) << r.BriefReport();
    EXPECT_LE(r.outlier_rows.size(), 4u) << r.BriefReport();
  }
  std::cout << "[null-robust] " << claims << " claim(s) in " << kNullSeeds << " data sets\n";
  EXPECT_LE(claims, std::max(0, kNullSeeds / 20));
}

TEST(RobustFit, PlainLeastSquaresIsPulledByOutliersWhereHuberIsNot) {
  Model model = Model::FromUrdfFile(kRat);
  std::vector<Trial> trials = Simulate(model, {"force_scale:GP=0.9"}, 41, 60, 0, 0.05);
  FitOptions o;
  o.max_rounds = 1;
  o.candidates = {"force_scale:GP"};
  FitReport huber = FitEffects(model, trials, o);
  o.loss = RobustLoss::kNone;
  FitReport none = FitEffects(model, trials, o);
  ASSERT_EQ(huber.chosen.size(), 1u);
  EXPECT_NEAR(huber.chosen[0].values[0], 0.9, kSigmas * huber.chosen_fits[0].standard_errors[0]);
  EXPECT_TRUE(none.outlier_rows.empty());
  EXPECT_EQ(none.verdict, FitVerdict::kUnexplained) << none.BriefReport();
}

TEST(Trace, ADriftOutsideTheLibraryEndsUnexplainedAndPointsAtTrialOrder) {
  // A sensor drift growing with the trial index (no effect in the library has it), Student-t(3)
  // noise: the verdict must be "unexplained" and the trace must name trial order first.
  Model model = Model::FromUrdfFile(kRat);
  std::vector<Trial> trials = Simulate(model, {}, 51, 60, 3);
  for (size_t k = 0; k < trials.size(); ++k)
    trials[k].wrench[1] += 0.02 * static_cast<double>(k) / trials.size();
  FitOptions o;
  o.max_rounds = 2;
  FitReport r = FitEffects(model, trials, o);
  EXPECT_EQ(r.verdict, FitVerdict::kUnexplained) << r.BriefReport();
  ASSERT_FALSE(r.trace.empty()) << r.BriefReport();
  EXPECT_EQ(r.trace[0].variable, "trial order") << r.BriefReport();
  EXPECT_FALSE(r.closest_rejected.empty() && r.chosen.empty());
  std::cout << "[trace drift] " << r.trace_summary << "\n";
}

TEST(Trace, AStiffJointOutsideTheLibraryIsNamedFirst) {
  // A passive stiffness on hip_ry (no candidate has it: the hip is a full ball, so no extra
  // joint is offered there) with Student-t(3) noise: "unexplained", and the trace's first item
  // is the stiffness probe of hip_ry, not another coordinate and never trial order.
  Model model = Model::FromUrdfFile(kRat);
  AugmentedModel truth;
  truth.description = WithJointStiffness(model.description(), "hip_ry", 1e4);
  SimulationOptions so;
  so.postures = 40;
  so.seed = 303;
  so.noise_dof = 3;
  FitReport r = FitEffects(model, SimulateTrials(model, truth, so), FitOptions());
  EXPECT_EQ(r.verdict, FitVerdict::kUnexplained) << r.BriefReport();
  ASSERT_FALSE(r.trace.empty()) << r.BriefReport();
  EXPECT_EQ(r.trace[0].variable, "stiffness at hip_ry") << r.BriefReport();
  for (const FitReport::TraceItem& i : r.trace) EXPECT_NE(i.variable, "trial order");
  std::cout << "[trace hip_ry] " << r.trace_summary << "\n";
  for (const FitReport::TraceItem& i : r.trace)
    std::cout << "  " << i.share << " " << i.variable << "\n";
}

TEST(Correlations, ConfoundedPairsAreNamed) {
  Model model = Model::FromUrdfFile(kRat);
  FitReport r =
      FitEffects(model, Simulate(model, {"base_isotropic=3e6", "force_scale:GP=0.9"}, 207, 40));
  ASSERT_EQ(r.chosen.size(), 2u) << r.BriefReport();
  ASSERT_EQ(r.correlations.rows(), 2);
  EXPECT_EQ(r.correlation_labels.size(), 2u);
  for (int i = 0; i < 2; ++i) EXPECT_NEAR(r.correlations(i, i), 1.0, 1e-12);
  EXPECT_NEAR(r.correlations(0, 1), r.correlations(1, 0), 1e-12);
}

}  // namespace
}  // namespace isowrench

namespace isowrench {
namespace {

TEST(Design, ChosenPosturesBeatTheFirstNAndTheirExpectedErrorsMatchAFit) {
  // D-optimal choice of 12 of 80 grid trials for sensor_origin (linear in its parameters, so
  // the expected SE is exact): log det must beat the first 12 candidates, and a fit of noisy
  // data at the chosen trials must report the same standard errors (within 1 %: the fit's
  // covariance is max(1, chi2/dof) x (J^T J)^-1, evaluated by Ceres at the optimum).
  Model model = Model::FromUrdfFile(kRat);
  DesignOptions d;
  d.postures = 12;
  d.candidates = 80;
  DesignResult r = DesignExperiment(model, {"sensor_origin"}, nullptr, d);
  ASSERT_EQ(r.chosen.size(), 12u);
  EXPECT_GE(r.log_det, r.log_det_random);
  ASSERT_EQ(r.standard_errors.size(), 3u);
  std::vector<Trial> trials = r.chosen;
  Prediction p = Predict(model, {"sensor_origin=1,2,-1"}, trials);
  std::mt19937_64 rng(5);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (size_t k = 0; k < trials.size(); ++k) {
    for (int c = 0; c < 6; ++c)
      trials[k].wrench[c] = p.wrench[k][c] + trials[k].sd[c] * 0.5 * normal(rng);
  }
  FitOptions o;
  o.loss = RobustLoss::kNone;
  CandidateFit f = FitCandidate(ApplyEffects(model.description(), {}),
                                FindEffect(model, "sensor_origin"), trials, o);
  ASSERT_TRUE(f.converged);
  for (int i = 0; i < 3; ++i)
    EXPECT_NEAR(f.standard_errors[i], r.standard_errors[i], 0.01 * r.standard_errors[i]);
  EXPECT_THAT([&] { DesignExperiment(model, {"nonsense"}, nullptr, d); },
              ::testing::ThrowsMessage<Error>(HasSubstr("nonsense")));
}

}  // namespace
}  // namespace isowrench
