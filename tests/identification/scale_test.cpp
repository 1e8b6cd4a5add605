// Issue 16 "Scale": FitOptions::max_fit_trials. The fitted sample (TrialReservoir) is uniform and
// reproducible, a fit with max_fit_trials >= trials is exactly the fit of every trial, a planted
// effect is recovered from a sample with standard errors sqrt(trials / sample) larger, the error
// before/after of a sampled fit covers every trial, and the file and in-memory paths agree.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <vector>

#include "isowrench/error.hpp"
#include "isowrench/identification.hpp"
#include "isowrench/trial_csv.hpp"

namespace isowrench {
namespace {

using ::testing::HasSubstr;

const std::string kScaleUrdf = std::string(ISOWRENCH_TEST_URDF_DIR) + "/rat_hindlimb_5dof.urdf";

std::vector<Trial> ScaleSimulate(const Model& model, const std::string& effect, int postures,
                                 unsigned long long seed) {
  SimulationOptions o;
  o.postures = postures;
  o.seed = seed;
  return SimulateTrials(
      model, ApplyEffects(model.description(), {ParseEffectAssignment(model, effect)}), o);
}

/// Trials that only carry their position in the stream (line = 1 + index).
std::vector<Trial> Numbered(int n) {
  std::vector<Trial> t(n);
  for (int i = 0; i < n; ++i) t[i].line = i + 1;
  return t;
}

std::vector<long> SampleLines(const std::vector<Trial>& stream, long capacity,
                              unsigned long long seed) {
  TrialReservoir r(capacity, seed);
  for (const Trial& t : stream) r.Add(t);
  std::vector<long> lines;
  for (const Trial& t : r.Take()) lines.push_back(t.line);
  return lines;
}

/// Binomial bound: |count - n p| <= 5 sd (one such test in ~1.7 million fails by chance; the
/// seeds are fixed, so the outcome is deterministic).
void ExpectBinomial(long count, long n, double p, const std::string& what) {
  const double mean = n * p;
  const double sd = std::sqrt(n * p * (1 - p));
  EXPECT_LE(std::abs(count - mean), 5 * sd)
      << what << ": " << count << " of " << n << ", expected " << mean << " ± " << sd;
}

TEST(TrialReservoir, EveryRowAndEveryPairIsEquallyLikelyOverSeeds) {
  const int rows = 40;
  const long capacity = 8;
  const int seeds = 5000;
  const std::vector<Trial> stream = Numbered(rows);
  std::vector<long> included(rows, 0);
  long first_and_last = 0, first_two = 0;
  std::set<std::vector<long>> distinct;
  for (int s = 0; s < seeds; ++s) {
    const std::vector<long> lines = SampleLines(stream, capacity, 1000 + s);
    ASSERT_EQ(lines.size(), static_cast<size_t>(capacity));
    for (size_t i = 1; i < lines.size(); ++i) ASSERT_LT(lines[i - 1], lines[i]);  // file order
    for (long l : lines) ++included[l - 1];
    const std::set<long> in(lines.begin(), lines.end());
    first_and_last += in.count(1) && in.count(rows);
    first_two += in.count(1) && in.count(2);
    distinct.insert(lines);
  }
  // Each row is in the sample with probability capacity / rows, wherever it is in the stream.
  for (int i = 0; i < rows; ++i) {
    ExpectBinomial(included[i], seeds, double(capacity) / rows, "row " + std::to_string(i + 1));
  }
  // Pairs too (a uniform subset, not only uniform marginals): capacity (capacity - 1) /
  // (rows (rows - 1)).
  const double pair = double(capacity * (capacity - 1)) / (rows * (rows - 1));
  ExpectBinomial(first_and_last, seeds, pair, "rows 1 and 40");
  ExpectBinomial(first_two, seeds, pair, "rows 1 and 2");
  // Different seeds give different samples (C(40, 8) = 7.7e7 subsets, 5000 draws).
  EXPECT_GT(distinct.size(), static_cast<size_t>(seeds - 5));
}

TEST(TrialReservoir, ASeedGivesTheSameSampleAndShortStreamsAreKeptWhole) {
  const std::vector<Trial> stream = Numbered(1000);
  EXPECT_EQ(SampleLines(stream, 50, 42), SampleLines(stream, 50, 42));
  EXPECT_NE(SampleLines(stream, 50, 42), SampleLines(stream, 50, 43));
  std::vector<long> all;
  for (int i = 1; i <= 1000; ++i) all.push_back(i);
  EXPECT_EQ(SampleLines(stream, 0, 42), all);     // 0 = keep every trial
  EXPECT_EQ(SampleLines(stream, 1000, 42), all);  // capacity = rows
  EXPECT_EQ(SampleLines(stream, 5000, 42), all);  // capacity > rows
  TrialReservoir r(10, 1);
  for (const Trial& t : stream) r.Add(t);
  EXPECT_EQ(r.seen(), 1000);
  EXPECT_THROW(TrialReservoir(-1, 1), Error);
}

/// Two reports of the same fit, compared exactly.
void ExpectSameFit(const FitReport& a, const FitReport& b) {
  EXPECT_EQ(a.verdict, b.verdict);
  EXPECT_EQ(a.verdict_message, b.verdict_message);
  EXPECT_EQ(a.trial_count, b.trial_count);
  EXPECT_EQ(a.fitted_trial_count, b.fitted_trial_count);
  EXPECT_EQ(a.before.chi2, b.before.chi2);
  EXPECT_EQ(a.after.chi2, b.after.chi2);
  EXPECT_EQ(a.before.rms, b.before.rms);
  EXPECT_EQ(a.after.rms, b.after.rms);
  EXPECT_EQ(a.after.r2, b.after.r2);
  EXPECT_EQ(a.beyond_threshold_count, b.beyond_threshold_count);
  ASSERT_EQ(a.chosen_fits.size(), b.chosen_fits.size());
  for (size_t i = 0; i < a.chosen_fits.size(); ++i) {
    EXPECT_EQ(a.chosen_fits[i].effect.id, b.chosen_fits[i].effect.id);
    EXPECT_EQ(a.chosen_fits[i].values, b.chosen_fits[i].values);
    EXPECT_EQ(a.chosen_fits[i].standard_errors, b.chosen_fits[i].standard_errors);
  }
  ASSERT_EQ(a.rounds.size(), b.rounds.size());
  for (size_t r = 0; r < a.rounds.size(); ++r) {
    ASSERT_EQ(a.rounds[r].candidates.size(), b.rounds[r].candidates.size());
    for (size_t c = 0; c < a.rounds[r].candidates.size(); ++c) {
      EXPECT_EQ(a.rounds[r].candidates[c].delta_bic, b.rounds[r].candidates[c].delta_bic);
    }
  }
  ASSERT_EQ(a.trials.size(), b.trials.size());
  for (size_t k = 0; k < a.trials.size(); ++k) {
    EXPECT_EQ(a.trials[k].line, b.trials[k].line);
    EXPECT_EQ(a.trials[k].after, b.trials[k].after);
  }
}

FitOptions QuickOptions() {
  FitOptions o;
  o.max_rounds = 1;
  o.candidates = {"base_isotropic", "sensor_offset"};
  return o;
}

TEST(FitScale, MaxFitTrialsAtOrAboveTheTrialCountIsTheFitOfEveryTrial) {
  Model model = Model::FromUrdfFile(kScaleUrdf);
  const std::vector<Trial> trials = ScaleSimulate(model, "base_isotropic=1e7", 60, 4);
  FitOptions every = QuickOptions();
  every.max_fit_trials = 0;
  const FitReport reference = FitEffects(model, trials, every);
  EXPECT_FALSE(reference.sampled());
  EXPECT_EQ(reference.fitted_trial_count, 60);
  EXPECT_EQ(reference.sampling, "every trial fitted");
  EXPECT_EQ(reference.fitted_after.chi2, reference.after.chi2);
  ASSERT_EQ(reference.chosen_fits.size(), 1u);
  for (int max : {60, 61, 20000}) {
    FitOptions o = QuickOptions();
    o.max_fit_trials = max;
    o.sample_seed = 99;  // irrelevant when nothing is left out
    SCOPED_TRACE("max_fit_trials " + std::to_string(max));
    ExpectSameFit(FitEffects(model, trials, o), reference);
  }
  // From a file: FitEffectsCsv equals FitEffects on the trials read.
  const std::string path = ::testing::TempDir() + "/isowrench_scale_every.csv";
  WriteTrialsCsv(model, trials, path);
  FitOptions o = QuickOptions();
  o.max_fit_trials = 60;
  std::vector<Trial> fitted;
  const FitReport from_file = FitEffectsCsv(model, path, o, {}, {}, &fitted);
  ExpectSameFit(from_file, FitEffects(model, ReadTrialsCsv(model, path), o));
  EXPECT_EQ(from_file.source, path);
  EXPECT_EQ(fitted.size(), 60u);
}

TEST(FitScale, APlantedEffectIsRecoveredFromASampleWithStandardErrorsScaledBySqrtMOverN) {
  Model model = Model::FromUrdfFile(kScaleUrdf);
  const int rows = 2000, sample = 200;
  const double truth = std::log10(1e7);
  const std::vector<Trial> trials = ScaleSimulate(model, "base_isotropic=1e7", rows, 11);
  FitOptions o;
  o.max_rounds = 1;
  o.candidates = {"base_isotropic"};
  o.max_fit_trials = 0;
  const FitReport full = FitEffects(model, trials, o);
  o.max_fit_trials = sample;
  o.sample_seed = 5;
  const FitReport part = FitEffects(model, trials, o);

  ASSERT_EQ(full.chosen_fits.size(), 1u);
  ASSERT_EQ(part.chosen_fits.size(), 1u);
  EXPECT_EQ(part.verdict, FitVerdict::kExplained) << part.verdict_message;
  const double se_full = full.chosen_fits[0].log10_standard_errors[0];
  const double se_part = part.chosen_fits[0].log10_standard_errors[0];
  ASSERT_GT(se_full, 0);
  EXPECT_LE(std::abs(std::log10(full.chosen_fits[0].values[0]) - truth), 4 * se_full);
  EXPECT_LE(std::abs(std::log10(part.chosen_fits[0].values[0]) - truth), 4 * se_part);
  // The information is a sum over trials: the sample's is N / M of the whole's, up to the
  // spread of the sampled postures (3.158 against sqrt(10) = 3.162 for this seed).
  EXPECT_NEAR(se_part / se_full, std::sqrt(double(rows) / sample), 0.1 * std::sqrt(10.0));

  // What the report says about the sample.
  EXPECT_TRUE(part.sampled());
  EXPECT_EQ(part.trial_count, rows);
  EXPECT_EQ(part.fitted_trial_count, sample);
  EXPECT_EQ(part.sample_seed, 5u);
  EXPECT_THAT(part.sampling, HasSubstr("200 of 2000 trials fitted"));
  EXPECT_THAT(part.sampling, HasSubstr("reservoir sampling, seed 5"));
  EXPECT_EQ(part.trials.size(), static_cast<size_t>(sample));
  EXPECT_EQ(part.fitted_after.residual_count, 6 * sample);

  // The error before / after covers every trial: the streamed statistics equal the in-memory
  // ComputeResidualStats of all of them, and the sample's model fits every trial to the noise.
  EXPECT_EQ(part.before.residual_count, 6 * rows);
  EXPECT_EQ(part.after.residual_count, 6 * rows);
  const ResidualStats nominal =
      ComputeResidualStats(trials, PredictTrials(model, trials).wrench, 0, o);
  EXPECT_NEAR(part.before.chi2, nominal.chi2, 1e-9 * nominal.chi2);
  for (int c = 0; c < 6; ++c) {
    EXPECT_NEAR(part.before.rms[c], nominal.rms[c], 1e-9 * nominal.rms[c]);
    EXPECT_NEAR(part.before.r2[c], nominal.r2[c], 1e-9 * std::abs(nominal.r2[c]) + 1e-12);
    EXPECT_NEAR(part.before.mean[c], nominal.mean[c], 1e-9 * std::abs(nominal.mean[c]) + 1e-15);
  }
  const ResidualStats after = ComputeResidualStats(
      trials, PredictTrials(part.augmented, trials).wrench, part.after.parameter_count, o);
  EXPECT_NEAR(part.after.chi2, after.chi2, 1e-9 * after.chi2);
  EXPECT_NEAR(part.after.reduced_chi2, 1.0, 0.1);
  EXPECT_GT(part.before.reduced_chi2, 100.0);
  // Gaussian noise: about 1 row in 1.5e4 beyond 3 x noise (chi2 of 6 above 54).
  EXPECT_LE(part.beyond_threshold_count, 5);
}

TEST(FitScale, TheFileAndTheInMemoryPathsFitTheSameSample) {
  Model model = Model::FromUrdfFile(kScaleUrdf);
  const std::string path = ::testing::TempDir() + "/isowrench_scale_sample.csv";
  WriteTrialsCsv(model, ScaleSimulate(model, "base_isotropic=1e7", 300, 8), path);
  FitOptions o = QuickOptions();
  o.max_fit_trials = 100;
  o.sample_seed = 3;
  long read_rows = 0, checked_rows = 0;
  std::vector<Trial> fitted;
  const FitReport streamed = FitEffectsCsv(
      model, path, o, [&](long rows, double) { read_rows = rows; },
      [&](long rows, double) { checked_rows = rows; }, &fitted);
  EXPECT_EQ(read_rows, 300);  // both passes report progress
  EXPECT_EQ(checked_rows, 300);
  ExpectSameFit(streamed, FitEffects(model, ReadTrialsCsv(model, path), o));
  ASSERT_EQ(fitted.size(), 100u);
  for (size_t k = 0; k < fitted.size(); ++k) EXPECT_EQ(fitted[k].line, streamed.trials[k].line);
  EXPECT_EQ(streamed.trial_count, 300);
  EXPECT_EQ(streamed.after.residual_count, 6 * 300);
  EXPECT_THAT(streamed.BriefReport(), HasSubstr("sample: 100 of 300 trials fitted"));
}

TEST(FitScale, ANegativeMaxFitTrialsIsRefused) {
  Model model = Model::FromUrdfFile(kScaleUrdf);
  const std::vector<Trial> trials = ScaleSimulate(model, "base_isotropic=1e7", 10, 1);
  FitOptions o = QuickOptions();
  o.max_fit_trials = -1;
  try {
    FitEffects(model, trials, o);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("max_fit_trials (--max-fit-trials) must be >= 0"));
  }
  const std::string path = ::testing::TempDir() + "/isowrench_scale_negative.csv";
  WriteTrialsCsv(model, trials, path);
  try {
    FitEffectsCsv(model, path, o);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("max_fit_trials (--max-fit-trials) must be >= 0"));
  }
}

}  // namespace
}  // namespace isowrench
