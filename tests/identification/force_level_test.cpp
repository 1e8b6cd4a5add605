// Tests of force level vs trial variation (issue 29, item 2): per-trial factors
// g_t = s_m exp(z_t) as levels s_m plus a spread, the marginal likelihood against closed forms,
// which of force_scale / trial_force the fit names, and factors that follow a muscle's length.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <random>
#include <set>

#include "identification/fit_stages.hpp"
#include "isowrench/identification.hpp"
#include "isowrench/kinematics.hpp"

namespace isowrench {
namespace {

using ::testing::HasSubstr;

const std::string kLevelRat = std::string(ISOWRENCH_TEST_URDF_DIR) + "/rat_hindlimb_5dof.urdf";
const std::string kLevelPlanar = std::string(ISOWRENCH_TEST_URDF_DIR) + "/planar_2r.urdf";

/// Parameter recovery: |estimate - truth| <= kLevelSigmas reported standard errors.
constexpr double kLevelSigmas = 4.0;
/// Seeds of the spread-and-level recovery: fewer under the sanitizers (every code path still
/// runs; pass 1 measures all of them).
#if defined(__SANITIZE_ADDRESS__) || defined(ISOWRENCH_TEST_SANITIZED)
const std::vector<unsigned long long> kLevelSeeds = {21};
#else
const std::vector<unsigned long long> kLevelSeeds = {21, 22, 23};
#endif

std::vector<Trial> LevelSimulate(const Model& model, const std::vector<std::string>& effects,
                                 unsigned long long seed, int postures) {
  std::vector<AppliedEffect> applied;
  for (const std::string& e : effects) applied.push_back(ParseEffectAssignment(model, e));
  SimulationOptions o;
  o.postures = postures;
  o.seed = seed;
  return SimulateTrials(model, ApplyEffects(model.description(), applied), o);
}

std::set<std::string> LevelChosen(const FitReport& r) {
  std::set<std::string> ids;
  for (const AppliedEffect& a : r.chosen) ids.insert(a.effect.id);
  return ids;
}

// ---- the marginal likelihood against closed forms ------------------------------------------

/// A context of n one-muscle trials whose readings are exactly g_t times a unit reading a_t of
/// whitened norm `norm` / g_t (no residual beyond the factor): x_t = ln g_t and the same
/// variance v_t = 1 / (|a_t| g_t)^2 = 1 / norm^2 for every trial.
struct FactorData {
  std::vector<Trial> trials;
  ident::Context context;
  ident::Readings readings;
};

void MakeFactorData(const std::vector<double>& factors, double norm, FactorData* d) {
  const size_t n = factors.size();
  d->trials.assign(n, Trial());
  d->context.trials = &d->trials;
  d->context.subset = ident::AllIndices(n);
  d->context.weights.assign(6 * n, 1.0);
  d->context.options.loss = RobustLoss::kNone;
  d->readings.per_trial = true;
  for (size_t t = 0; t < n; ++t) {
    Vector6d unit = Vector6d::Zero();
    unit[t % 6] = norm / factors[t];  // weights 1: whitened norm norm / g_t
    d->trials[t].muscle = "M";
    d->trials[t].wrench = factors[t] * unit;
    d->readings.unit.push_back(unit);
    d->readings.factor.push_back(factors[t]);
    d->readings.reading.push_back(factors[t] * unit);
  }
}

TEST(ForceLevels, SpreadLevelAndLikelihoodRatioMatchTheirClosedForms) {
  // Equal variances v for every x_t: the maximum of the marginal likelihood is
  // σ² = max(0, S / n - v) with S = Σ (x - x̄)², the level exp(x̄), and
  // Λ = S / v - n - n ln(S / (n v)) (Q(0) - Q(σ̂) with Q(σ²) = S / (σ² + v) + n ln(1 + σ² / v)).
  // Here v = (0.025)^2, a quarter of the spread's variance, so it matters.
  std::mt19937 rng(3);
  std::normal_distribution<double> z(0.0, 0.05);
  std::vector<double> g;
  for (int t = 0; t < 200; ++t) g.push_back(0.9 * std::exp(z(rng)));
  FactorData d;
  const double norm = 40.0;
  MakeFactorData(g, norm, &d);
  const ident::ForceLevels f = ident::FitForceLevels(d.context, d.readings);
  double mean = 0, S = 0;
  for (double v : g) mean += std::log(v) / g.size();
  for (double v : g) S += std::pow(std::log(v) - mean, 2);
  const double n = static_cast<double>(g.size()), v = 1.0 / (norm * norm);
  const double tau = S / n;  // σ̂² + v
  ASSERT_EQ(f.muscles, std::vector<std::string>{"M"});
  EXPECT_EQ(f.used, 200);
  // The 1-D search stops within 1e-10 in ln σ²: 1e-10 relative in σ.
  EXPECT_NEAR(f.sigma, std::sqrt(tau - v), 1e-8);
  EXPECT_NEAR(f.log_level[0], mean, 1e-12);
  EXPECT_NEAR(f.lrt, S / v - n - n * std::log(tau / v), 1e-8 * (S / v));
  // Standard errors: of the level sqrt(τ / n); of σ, from Q'' = 4 σ² n / τ² at the optimum,
  // τ / (σ sqrt(2 n)) (the numeric second difference: 1e-4 relative).
  // (σ̂ from a 1-D minimum: its square to ~sqrt(machine epsilon) relative.)
  EXPECT_NEAR(f.log_level_se[0], std::sqrt(tau / n), 1e-6 * std::sqrt(tau / n));
  const double sigma_se = tau / (f.sigma * std::sqrt(2.0 * n));
  EXPECT_NEAR(f.sigma_se, sigma_se, 1e-4 * sigma_se);
  // Factors with no spread beyond their own noise: σ = 0 and Λ = 0 (the boundary).
  std::vector<double> same(50, 0.8);
  FactorData flat;
  MakeFactorData(same, 10.0, &flat);
  const ident::ForceLevels f0 = ident::FitForceLevels(flat.context, flat.readings);
  EXPECT_EQ(f0.sigma, 0.0);
  EXPECT_EQ(f0.lrt, 0.0);
  EXPECT_NEAR(std::exp(f0.log_level[0]), 0.8, 1e-12);
}

// ---- which effect the fit names ----------------------------------------------------------------

TEST(ForceLevelFit, BothMusclesWeakerAreForceScalesNotTrialVariation) {
  // Both muscles at 0.8 of their max force (issue 29: the fit used to read "trial_force, spread
  // 0.001"): a force scale for each, no trial_force claim.
  Model model = Model::FromUrdfFile(kLevelPlanar);
  const std::vector<Trial> trials =
      LevelSimulate(model, {"force_scale:biarticular=0.8", "force_scale:elbow_flexor=0.8"}, 20, 60);
  const FitReport r = FitEffects(model, trials);
  EXPECT_EQ(LevelChosen(r),
            (std::set<std::string>{"force_scale:biarticular", "force_scale:elbow_flexor"}))
      << r.BriefReport();
  EXPECT_EQ(r.verdict, FitVerdict::kExplained) << r.BriefReport();
  EXPECT_TRUE(r.trial_factors.empty());
  for (const CandidateFit& f : r.chosen_fits)
    EXPECT_LE(std::abs(f.values[0] - 0.8), kLevelSigmas * f.standard_errors[0]) << f.effect.id;
  // The verdict names the levels found.
  EXPECT_THAT(r.verdict_message, HasSubstr("force_scale:biarticular = 0.8"));
  // trial_force was fitted in round 1, explained as much, and was refused for it.
  bool refused = false;
  for (const CandidateFit& f : r.rounds.at(0).candidates) {
    if (f.effect.id != "trial_force") continue;
    refused = !f.accepted;
    EXPECT_THAT(f.verdict, HasSubstr("not claimed: the factors are the muscles' force levels"));
    EXPECT_EQ(f.added_parameters, 3);  // the spread and two levels
  }
  EXPECT_TRUE(refused);
}

TEST(ForceLevelFit, ASpreadAroundAWeakerLevelGivesBoth) {
  // Per-trial spread 0.05 around a level of 0.9: trial_force with the level and the spread.
  Model model = Model::FromUrdfFile(kLevelRat);
  double z2 = 0;
  int count = 0;
  for (unsigned long long seed : kLevelSeeds) {
    const std::vector<Trial> trials =
        LevelSimulate(model, {"force_scale:GP=0.9", "trial_force=0.05"}, seed, 60);
    const FitReport r = FitEffects(model, trials);
    std::cout << "[levels] seed " << seed << ": " << r.ForceLevelSummary() << "\n";
    EXPECT_EQ(LevelChosen(r), std::set<std::string>{"trial_force"}) << r.BriefReport();
    EXPECT_EQ(r.verdict, FitVerdict::kExplained) << r.BriefReport();
    ASSERT_EQ(r.trial_force_levels.size(), 1u);
    const FitReport::ForceLevel& level = r.trial_force_levels[0];
    EXPECT_EQ(level.muscle, "GP");
    EXPECT_EQ(level.trials, 60);
    EXPECT_LE(std::abs(level.level - 0.9), kLevelSigmas * level.standard_error);
    EXPECT_LE(std::abs(r.trial_force_spread - 0.05), kLevelSigmas * r.trial_force_spread_se);
    z2 += std::pow((level.level - 0.9) / level.standard_error, 2) +
          std::pow((r.trial_force_spread - 0.05) / r.trial_force_spread_se, 2);
    count += 2;
    // Both findings are named, and the level is the augmented model's max force.
    EXPECT_THAT(r.ForceLevelSummary(), ::testing::ContainsRegex("force_scale:GP = 0\\.[89]"));
    EXPECT_THAT(r.ForceLevelSummary(), HasSubstr("trial_force spread 0.0"));
    EXPECT_THAT(r.verdict_message, ::testing::ContainsRegex("force_scale:GP = 0\\.[89]"));
    const double nominal = model.muscle(0).max_force;
    EXPECT_NEAR(r.augmented.description.muscles[0].max_force, nominal * level.level,
                1e-12 * nominal);
    // k = the spread and GP's level.
    EXPECT_EQ(r.rounds.at(0).candidates.at(0).added_parameters, 2);
  }
  std::cout << "[levels] mean (error/SE)^2 of level and spread: " << z2 / count << "\n";
  EXPECT_LT(z2 / count, 4.0);
}

TEST(ForceLevelFit, FactorsThatFollowTheMuscleLengthAreNotTrialVariation) {
  // A force-length curve outside the model: each trial's force is f(l_GP) = 1 - 0.28 u^2,
  // u = (l - l_opt) / max |l - l_opt| (0.72 to 1 over the postures). The fit must not call it
  // trial variation: "unexplained", with the muscle's force following its length first.
  Model model = Model::FromUrdfFile(kLevelRat);
  SimulationOptions o;
  o.postures = 40;
  o.seed = 31;
  o.noise_force = o.noise_moment = 0;
  std::vector<Trial> trials = SimulateTrials(model, ApplyEffects(model.description(), {}), o);
  Data data(model);
  std::vector<double> lengths;
  for (const Trial& t : trials) lengths.push_back(ComputeMuscleTorque(model, data, t.q, 0).length);
  std::vector<double> sorted = lengths;
  std::sort(sorted.begin(), sorted.end());
  const double optimum = sorted[sorted.size() / 2];
  double reach = 0;
  for (double l : lengths) reach = std::max(reach, std::abs(l - optimum));
  std::mt19937 rng(32);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (size_t k = 0; k < trials.size(); ++k) {
    const double u = (lengths[k] - optimum) / reach;
    Trial& t = trials[k];
    for (int c = 0; c < 6; ++c) {
      t.sd[c] = c < 3 ? 0.002 : 5e-5;
      t.wrench[c] = (1.0 - 0.28 * u * u) * t.wrench[c] + t.sd[c] * normal(rng);
    }
  }
  FitOptions fit;
  fit.max_rounds = 1;  // one round: trial_force is tried (and refused) there; keeps it fast
  const FitReport r = FitEffects(model, trials, fit);
  EXPECT_EQ(LevelChosen(r).count("trial_force"), 0u) << r.BriefReport();
  EXPECT_EQ(r.verdict, FitVerdict::kUnexplained) << r.BriefReport();
  ASSERT_FALSE(r.trace.empty()) << r.BriefReport();
  EXPECT_EQ(r.trace[0].variable, "force of GP following its length") << r.BriefReport();
  // trial_force was refused in round 1 because its factors follow the length.
  bool refused = false;
  for (const CandidateFit& f : r.rounds.at(0).candidates) {
    if (f.effect.id != "trial_force") continue;
    refused = true;
    EXPECT_THAT(f.verdict, HasSubstr("the factors follow the posture"));
    EXPECT_THAT(f.verdict, HasSubstr("length of GP"));
  }
  EXPECT_TRUE(refused);
  std::cout << "[force-length] " << r.trace_summary << "\n";
}

}  // namespace
}  // namespace isowrench
