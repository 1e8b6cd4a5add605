// The fit loop (docs/identification.md "The loop"): the nominal residual, rounds of screening,
// candidate fits, cross-validation and selection (rounds.cpp), then the report steps
// (report.cpp, trace.cpp). fit_stages.hpp lists the stages and the file of each.

#include <chrono>
#include <cmath>

#include "identification/effect_type.hpp"
#include "identification/fit_stages.hpp"
#include "isowrench/error.hpp"
#include "util/text.hpp"

namespace isowrench {

CandidateFit FitCandidate(const AugmentedModel& current, const Effect& effect,
                          const std::vector<Trial>& trials, const FitOptions& options) {
  // The already chosen effects stay fixed: a context whose only free effect is `effect`, on a
  // base that already holds them. BIC counts their parameters too.
  CandidateFit f = ident::FitOnSubset(current, {}, effect, trials, ident::AllIndices(trials.size()),
                                      options, nullptr, true);
  const int n = static_cast<int>(6 * trials.size());
  std::vector<AppliedEffect> with = current.effects;
  with.push_back({effect, {}});
  const int k = ident::TotalParameters(with, trials);
  f.bic = ident::Bic(f.cost, n, k, ident::AllSd(trials));
  f.aic = ident::Aicc(f.cost, n, k, ident::AllSd(trials));
  ident::GuardFinite(&f);
  return f;
}

namespace ident {

FitReport FitEvery(const Model& nominal, const std::vector<Trial>& trials,
                   const FitOptions& options) {
  auto clock_start = std::chrono::steady_clock::now();
  if (trials.empty()) throw Error("fit: no trials");
  if (options.loss != RobustLoss::kNone &&
      !(options.loss_scale > 0 && std::isfinite(options.loss_scale))) {
    throw Error("fit: the robust loss scale must be > 0 (noise multiples), got " +
                util::FormatNumber(options.loss_scale));
  }
  FitReport report;
  report.model_name = nominal.name();
  report.source = nominal.description().source;
  report.trial_count = static_cast<int>(trials.size());
  report.fitted_trial_count = report.trial_count;
  report.sampling = "every trial fitted";
  report.sd_stated = AllSd(trials);
  report.loss = options.loss;

  std::vector<Effect> library = CandidateEffects(nominal);
  if (!options.candidates.empty()) {
    std::vector<Effect> chosen;
    for (const std::string& id : options.candidates) chosen.push_back(FindEffect(nominal, id));
    library = chosen;
  }
  const Folds folds = MakeFolds(trials.size(), options);

  Prediction nominal_prediction = PredictTrials(nominal, trials);
  if (nominal_prediction.failed) {
    throw Error("fit: the nominal model cannot predict the trials: " + nominal_prediction.message);
  }
  // Candidates restricted to what these trials can determine (crosstalk terms whose source
  // axes the wrenches never vary along); each restriction is a note.
  for (size_t e = 0; e < library.size();) {
    const std::string note =
        TypeOf(library[e])
            .RestrictToData(nominal, trials, nominal_prediction.wrench, options, &library[e]);
    if (!note.empty()) report.notes.push_back(note);
    if (library[e].parameters.empty()) {
      library.erase(library.begin() + static_cast<long>(e));
    } else {
      ++e;
    }
  }
  report.before = ComputeResidualStats(trials, nominal_prediction.wrench, 0, options);
  report.fitted_before = report.before;
  Current current = MakeCurrent(nominal.description(), {}, {}, trials, options);

  for (int round = 1; round <= options.max_rounds; ++round) {
    std::map<std::string, std::vector<double>> solutions;
    FitRound r = RunRound(round, nominal, library, current, trials, folds, options, &solutions);
    for (const CandidateFit& f : r.candidates) {
      if (!f.accepted && report.closest_rejected.empty() && f.converged) {
        report.closest_rejected = f.effect.id + " (" + f.verdict + ")";
      }
    }
    if (!r.chosen) {
      report.rounds.push_back(std::move(r));
      break;
    }
    report.closest_rejected.clear();
    const CandidateFit& winner = r.candidates[*r.chosen];
    if (!r.indistinguishable.empty()) {
      report.indistinguishable.push_back(
          "At the sampled postures " + winner.effect.id + " cannot be told apart from " +
          util::Join(r.indistinguishable, ", ") + " (BIC within " +
          util::FormatNumber(options.indistinguishable_bic, 3) + ")");
    }
    current = Adopt(nominal, current, r, trials, options);
    report.rounds.push_back(std::move(r));
  }

  if (options.progress) options.progress("report: residuals, correlations, verdict");
  Simplify(nominal, trials, options, &current, &report.notes);

  report.chosen = current.effects;
  report.chosen_fits = current.fits;
  for (CandidateFit& f : report.chosen_fits) GuardFinite(&f);
  report.augmented = current.augmented;
  report.after =
      ComputeResidualStats(trials, current.prediction, current.residual_parameters, options);
  report.fitted_after = report.after;
  ReportTrials(trials, nominal_prediction, current, options, &report);
  // The force levels trial_force found are the muscles' max_force in the augmented model (the
  // per-trial factors are solved around whatever max_force holds, so no prediction changes).
  for (const FitReport::ForceLevel& l : report.trial_force_levels) {
    for (MuscleSpec& m : report.augmented.description.muscles) {
      if (m.name == l.muscle) m.max_force *= l.level;
    }
  }
  for (const TrialResidual& t : report.trials) {
    if (t.normalized_after > options.outlier_threshold) ++report.beyond_threshold_count;
  }
  ReportCorrelations(nominal, trials, current, options, &report);
  ReportVerdict(trials, current, options, &report);
  for (const std::string& slip : UnitSlips(nominal, trials, nominal_prediction.wrench))
    report.verdict_message += "; likely slip: " + slip;  // trial_csv.cpp (issue 26)
  if (report.verdict == FitVerdict::kUnexplained) {
    if (options.progress) options.progress("report: tracing the unexplained residual");
    ReportTrace(nominal, trials, current, options, &report);
  }
  report.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - clock_start).count();
  return report;
}

}  // namespace ident
}  // namespace isowrench
