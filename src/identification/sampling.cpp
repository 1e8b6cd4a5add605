// Scale: FitEffects and FitEffectsCsv fit at most FitOptions::max_fit_trials trials (a uniform
// random sample, TrialReservoir) and predict every trial in a streaming second pass, 4096 at a
// time, for the error before and after.

#include <chrono>
#include <limits>

#include "identification/fit_stages.hpp"
#include "isowrench/error.hpp"
#include "isowrench/trial_csv.hpp"

namespace isowrench {
namespace {

/// The second pass of a sampled fit: every trial predicted by the nominal and the augmented
/// model, kChunk trials at a time, into the report's before / after (memory: one chunk).
class EveryTrialPass {
 public:
  static constexpr size_t kChunk = 4096;
  EveryTrialPass(const Model& nominal, const FitReport& report, const FitOptions& options)
      : nominal_(nominal), augmented_(report.augmented), options_(options) {
    chunk_.resize(kChunk);
    for (const AppliedEffect& a : report.chosen) {
      if (a.effect.per_trial) {
        per_trial_ = true;
      } else {
        fixed_parameters_ += static_cast<int>(a.effect.parameters.size());
      }
    }
  }
  void Add(const Trial& t) {
    chunk_[used_++] = t;
    if (used_ == kChunk) Flush();
  }
  /// Fill the report's whole-data statistics. @returns the trials seen.
  long Finish(FitReport* report) {
    Flush();
    const long n = before_.count();
    const long parameters = fixed_parameters_ + (per_trial_ ? n : 0);
    report->before = before_.Result(0);
    report->after = after_.Result(
        static_cast<int>(std::min<long>(parameters, std::numeric_limits<int>::max())));
    report->beyond_threshold_count = beyond_;
    return n;
  }

 private:
  void Flush() {
    if (used_ == 0) return;
    chunk_.resize(used_);
    const Prediction a = PredictTrials(nominal_, chunk_);
    if (a.failed) throw Error("fit: the nominal model cannot predict the trials: " + a.message);
    const Prediction b = PredictTrials(augmented_, chunk_);
    if (b.failed) {
      throw Error("fit: the model with the chosen effects cannot predict the trials: " + b.message);
    }
    for (size_t k = 0; k < used_; ++k) {
      before_.Add(chunk_[k], a.wrench[k], options_);
      if (after_.Add(chunk_[k], b.wrench[k], options_) > options_.outlier_threshold) ++beyond_;
    }
    chunk_.resize(kChunk);
    used_ = 0;
  }

  const Model& nominal_;
  AugmentedModel augmented_;
  const FitOptions& options_;
  std::vector<Trial> chunk_;
  size_t used_ = 0;
  ident::ResidualAccumulator before_, after_;
  long beyond_ = 0;
  int fixed_parameters_ = 0;
  bool per_trial_ = false;
};

/// The options every front end passes (CLI, Python) are checked here, once, by the names of
/// both the library and the CLI.
void CheckSampleOptions(const FitOptions& options) {
  if (options.max_fit_trials < 0) {
    throw Error("fit: max_fit_trials (--max-fit-trials) must be >= 0 (0 = fit every trial), got " +
                std::to_string(options.max_fit_trials));
  }
  const std::pair<const char*, int> counts[] = {{"max_rounds (--rounds)", options.max_rounds},
                                                {"screen_keep (--screen)", options.screen_keep},
                                                {"folds (--folds)", options.folds},
                                                {"threads (--threads)", options.threads}};
  for (const auto& c : counts) {
    if (c.second < 0)
      throw Error(std::string("fit: ") + c.first + " must be >= 0, got " +
                  std::to_string(c.second));
  }
}

/// Mark a report as the fit of a sample of `total` trials.
void DescribeSample(long total, const FitOptions& options, FitReport* report) {
  report->trial_count = static_cast<int>(std::min<long>(total, std::numeric_limits<int>::max()));
  report->sample_seed = options.sample_seed;
  report->sampling = std::to_string(report->fitted_trial_count) + " of " + std::to_string(total) +
                     " trials fitted: a uniform random sample (reservoir sampling, seed " +
                     std::to_string(options.sample_seed) +
                     "); the error before and after covers every trial";
}

}  // namespace

FitReport FitEffects(const Model& nominal, const std::vector<Trial>& trials,
                     const FitOptions& options) {
  CheckSampleOptions(options);
  const size_t max = static_cast<size_t>(options.max_fit_trials);
  if (max == 0 || trials.size() <= max) return ident::FitEvery(nominal, trials, options);
  auto clock_start = std::chrono::steady_clock::now();
  TrialReservoir reservoir(options.max_fit_trials, options.sample_seed);
  for (const Trial& t : trials) reservoir.Add(t);
  FitReport report = ident::FitEvery(nominal, reservoir.Take(), options);
  if (options.progress) options.progress("predicting every trial with the chosen effects");
  EveryTrialPass pass(nominal, report, options);
  for (const Trial& t : trials) pass.Add(t);
  DescribeSample(pass.Finish(&report), options, &report);
  report.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - clock_start).count();
  return report;
}

FitReport FitEffectsCsv(const Model& nominal, const std::string& path, const FitOptions& options,
                        const TrialProgress& read_progress, const TrialProgress& check_progress,
                        std::vector<Trial>* fitted) {
  return FitEffectsCsv(nominal, path, TrialSheetOptions(), options, read_progress, check_progress,
                       fitted);
}

FitReport FitEffectsCsv(const Model& nominal, const std::string& path,
                        const TrialSheetOptions& sheet, const FitOptions& options,
                        const TrialProgress& read_progress, const TrialProgress& check_progress,
                        std::vector<Trial>* fitted) {
  CheckSampleOptions(options);
  auto clock_start = std::chrono::steady_clock::now();
  TrialReservoir reservoir(options.max_fit_trials, options.sample_seed);
  const long rows = ForEachTrial(
      nominal, path, sheet, [&](const Trial& t) { reservoir.Add(t); }, read_progress);
  std::vector<Trial> sample = reservoir.Take();
  if (options.progress && static_cast<long>(sample.size()) < rows) {
    options.progress("fitting a uniform random sample of " + std::to_string(sample.size()) +
                     " of " + std::to_string(rows) + " trials (seed " +
                     std::to_string(options.sample_seed) + ")");
  }
  FitReport report = ident::FitEvery(nominal, sample, options);
  if (static_cast<long>(sample.size()) < rows) {
    if (options.progress) options.progress("predicting every row with the chosen effects");
    EveryTrialPass pass(nominal, report, options);
    ForEachTrial(
        nominal, path, sheet, [&](const Trial& t) { pass.Add(t); }, check_progress);
    const long again = pass.Finish(&report);
    if (again != rows) {
      throw Error("fit: " + path + " changed while it was read: " + std::to_string(rows) +
                  " rows in the first pass, " + std::to_string(again) + " in the second");
    }
    DescribeSample(rows, options, &report);
  }
  report.source = path;
  if (fitted) *fitted = std::move(sample);
  report.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - clock_start).count();
  return report;
}

}  // namespace isowrench
