// `isowrench fit <urdf> <data.csv>`: trace the residual of measured wrenches to a missing effect.

#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>

#include "cli/command.hpp"
#include "isowrench/error.hpp"
#include "isowrench/identification.hpp"
#include "isowrench/io.hpp"
#include "isowrench/plots.hpp"
#include "isowrench/trial_csv.hpp"

namespace isowrench::cli {
namespace {

struct FitCommandOptions {
  ModelOptions model;
  std::string data;
  TrialSheetOptions sheet;  ///< --delimiter, --decimal-comma, ... (AddSheetOptions)
  std::string output;
  std::string report_html;
  std::string report_markdown;
  bool json = false;
  bool list_effects = false;
  int rounds = 3;
  int folds = 5;
  int screen = 8;
  int threads = 0;
  int rows = 20;
  int max_fit_trials = FitOptions().max_fit_trials;
  unsigned long long sample_seed = FitOptions().sample_seed;
  std::string loss = "huber";
  bool progress = false;
  double loss_scale = 2.0;
  std::vector<std::string> candidates;
};

nlohmann::json StatsJson(const ResidualStats& s) {
  return {{"rms", ToJson(s.rms)},
          {"r2", ToJson(s.r2)},
          {"noise_multiple", ToJson(s.normalized)},
          {"mean", ToJson(s.mean)},
          {"chi2", s.chi2},
          {"reduced_chi2", s.reduced_chi2},
          {"residual_count", s.residual_count},
          {"parameter_count", s.parameter_count},
          {"order", "fx fy fz mx my mz"},
          {"units", "N for fx fy fz, N·m for mx my mz; noise multiples and r2 dimensionless"}};
}

nlohmann::json EffectJson(const Effect& e) {
  nlohmann::json params = nlohmann::json::array();
  for (const EffectParameter& p : e.parameters) {
    params.push_back({{"name", p.name},
                      {"unit", p.unit},
                      {"scale", p.scale == ParameterScale::kLog10 ? "log10" : "linear"},
                      {"neutral", p.neutral},
                      {"initial", p.initial},
                      {"lower", p.lower},
                      {"upper", p.upper}});
  }
  return {{"id", e.id},
          {"kind", e.kind},
          {"stage", EffectStageName(e.stage)},
          {"description", e.description},
          {"parameters", params}};
}

nlohmann::json CandidateJson(const CandidateFit& f) {
  nlohmann::json params = nlohmann::json::array();
  for (size_t i = 0; i < f.values.size(); ++i) {
    params.push_back({{"name", f.effect.parameters[i].name},
                      {"value", f.values[i]},
                      {"standard_error", f.standard_errors[i]},
                      {"log10_standard_error", f.log10_standard_errors[i]},
                      {"unit", f.effect.parameters[i].unit},
                      {"at_bound", static_cast<bool>(f.at_bound[i])}});
  }
  nlohmann::json corr = nlohmann::json::array();
  for (int i = 0; i < f.correlation.rows(); ++i) {
    nlohmann::json row = nlohmann::json::array();
    for (int j = 0; j < f.correlation.cols(); ++j) row.push_back(f.correlation(i, j));
    corr.push_back(row);
  }
  nlohmann::json j = {{"effect", f.effect.id},
                      {"description", f.effect.description},
                      {"parameters", params},
                      {"correlation", corr},
                      {"chi2", f.cost},
                      {"aicc", f.aic},
                      {"bic", f.bic},
                      {"delta_bic", f.delta_bic},
                      {"added_parameters", f.added_parameters},
                      {"identifiable", f.identifiable},
                      {"identifiability", f.identifiability},
                      {"converged", f.converged},
                      {"solver_message", f.solver_message},
                      {"not_claimed", f.not_claimed},
                      {"accepted", f.accepted},
                      {"verdict", f.verdict},
                      {"screened_out", f.screened_out},
                      {"screen_delta_bic", f.screen_delta_bic}};
  j["cv_error"] =
      f.cv_status == CvStatus::kDone ? nlohmann::json(f.cv_error) : nlohmann::json(nullptr);
  return j;
}

nlohmann::json CorrelationsJson(const FitReport& r) {
  nlohmann::json matrix = nlohmann::json::array();
  for (int i = 0; i < r.correlations.rows(); ++i) {
    nlohmann::json row = nlohmann::json::array();
    for (int j = 0; j < r.correlations.cols(); ++j) row.push_back(r.correlations(i, j));
    matrix.push_back(row);
  }
  return {{"parameters", r.correlation_labels}, {"matrix", matrix}, {"confounded", r.confounded}};
}

nlohmann::json TrialForceJson(const FitReport& r) {
  if (r.trial_factors.empty()) return nullptr;
  nlohmann::json levels = nlohmann::json::array();
  for (const FitReport::ForceLevel& l : r.trial_force_levels) {
    levels.push_back({{"muscle", l.muscle},
                      {"level", l.level},
                      {"standard_error", l.standard_error},
                      {"trials", l.trials},
                      {"unit", "x (factor on max_force)"}});
  }
  return {{"factors", r.trial_factors},
          {"levels", levels},
          {"spread_ln", r.trial_force_spread},
          {"spread_ln_standard_error", r.trial_force_spread_se},
          {"likelihood_ratio", r.trial_force_lrt},
          {"summary", r.ForceLevelSummary()},
          {"far_lines", r.trial_force_outliers}};
}

nlohmann::json TraceJson(const FitReport& r) {
  nlohmann::json items = nlohmann::json::array();
  for (const FitReport::TraceItem& i : r.trace) {
    items.push_back({{"variable", i.variable}, {"share", i.share}, {"note", i.note}});
  }
  return {{"summary", r.trace_summary},
          {"items", items},
          {"closest_rejected", r.closest_rejected.empty() ? nlohmann::json(nullptr)
                                                          : nlohmann::json(r.closest_rejected)}};
}

nlohmann::json ReportJson(const FitReport& r, const std::string& urdf, const std::string& data,
                          const std::string& output) {
  nlohmann::json rounds = nlohmann::json::array();
  for (const FitRound& round : r.rounds) {
    nlohmann::json c = nlohmann::json::array();
    for (const CandidateFit& f : round.candidates) c.push_back(CandidateJson(f));
    rounds.push_back(
        {{"index", round.index},
         {"before", StatsJson(round.before)},
         {"bic_before", round.bic_before},
         {"bic_threshold", round.bic_threshold},
         {"cv_before", round.cv_before},
         {"candidates", c},
         {"chosen", round.chosen ? nlohmann::json(round.candidates[*round.chosen].effect.id)
                                 : nlohmann::json(nullptr)},
         {"indistinguishable", round.indistinguishable},
         {"summary", round.summary}});
  }
  nlohmann::json chosen = nlohmann::json::array();
  for (const CandidateFit& f : r.chosen_fits) chosen.push_back(CandidateJson(f));
  nlohmann::json trials = nlohmann::json::array();
  for (const TrialResidual& t : r.trials) {
    trials.push_back({{"line", t.line},
                      {"muscle", t.muscle},
                      {"activation", t.activation},
                      {"measured", ToJson(t.measured)},
                      {"residual_before", ToJson(t.before)},
                      {"residual_after", ToJson(t.after)},
                      {"noise_multiple_before", t.normalized_before},
                      {"noise_multiple_after", t.normalized_after}});
  }
  return {{"model", r.model_name},
          {"urdf", urdf},
          {"data", data},
          {"trials_count", r.trial_count},
          {"fitted_trials_count", r.fitted_trial_count},
          {"sampling",
           {{"method", r.sampled() ? "uniform random sample (reservoir sampling)" : "every trial"},
            {"seed", r.sampled() ? nlohmann::json(r.sample_seed) : nlohmann::json(nullptr)},
            {"description", r.sampling}}},
          {"sd_stated", r.sd_stated},
          {"verdict", FitVerdictName(r.verdict)},
          {"verdict_message", r.verdict_message},
          {"effects_claimed", r.effects_claimed},
          {"before", StatsJson(r.before)},
          {"after", StatsJson(r.after)},
          {"fitted_before", StatsJson(r.fitted_before)},
          {"fitted_after", StatsJson(r.fitted_after)},
          {"beyond_threshold_count", r.beyond_threshold_count},
          {"chosen", chosen},
          {"sensor_offset", WrenchJson(r.augmented.sensor_offset)},
          {"rounds", rounds},
          {"loss", RobustLossName(r.loss)},
          {"outlier_rows", r.outlier_rows},
          {"correlations", CorrelationsJson(r)},
          {"trial_force", TrialForceJson(r)},
          {"trace", TraceJson(r)},
          {"indistinguishable", r.indistinguishable},
          {"notes", r.notes},
          {"trials", trials},
          {"trials_note", r.sampled() ? "the fitted trials only (the sample)" : "every trial"},
          {"residual_sign", "measured - predicted, transducer axes, moment about the endpoint"},
          {"augmented_urdf", output.empty() ? nlohmann::json(nullptr) : nlohmann::json(output)},
          {"seconds", r.seconds}};
}

std::string Fixed(double v, int width, int precision) {
  char b[64];
  std::snprintf(b, sizeof(b), "%*.*f", width, precision, v);
  return b;
}

void PrintReport(const FitReport& r, const FitCommandOptions& o) {
  const int w = 24;
  std::cout << "isowrench fit: " << r.model_name << " (" << o.model.urdf << ") against " << o.data
            << "\n"
            << "  trials       " << r.trial_count;
  if (r.sampled()) {
    std::cout << " read, " << r.fitted_trial_count
              << " fitted (a uniform random sample: reservoir sampling, seed " << r.sample_seed
              << "; --max-fit-trials, --sample-seed)";
  }
  std::cout << ", stated noise (sd columns): " << (r.sd_stated ? "yes" : "no") << "\n"
            << "  verdict      " << FitVerdictName(r.verdict) << ": " << r.verdict_message << "\n";
  std::cout << "\nError before (nominal model) and after (with the chosen effects)"
            << (r.sampled() ? " over all " + std::to_string(r.trial_count) + " trials" : "")
            << "; residual = measured - predicted,\n"
            << "transducer axes, moment about the endpoint:\n"
            << WrenchHeader(w) << "\n"
            << WrenchRow("RMS before", r.before.rms, w) << "\n"
            << WrenchRow("RMS after", r.after.rms, w) << "\n"
            << WrenchRow("mean residual before", r.before.mean, w) << "\n"
            << WrenchRow("mean residual after", r.after.mean, w) << "\n";
  if (r.sd_stated) {
    std::cout << WrenchRow("x noise before", r.before.normalized, w) << "\n"
              << WrenchRow("x noise after", r.after.normalized, w) << "\n";
  }
  std::cout << WrenchRow("R^2 before", r.before.r2, w) << "\n"
            << WrenchRow("R^2 after", r.after.r2, w) << "\n";
  std::cout << "  reduced chi^2: " << util::FormatNumber(r.before.reduced_chi2, 4) << " before, "
            << util::FormatNumber(r.after.reduced_chi2, 4) << " after (1 = at the noise)\n";
  if (r.sampled()) {
    std::cout << "  the " << r.fitted_trial_count << " fitted trials: reduced chi^2 "
              << util::FormatNumber(r.fitted_before.reduced_chi2, 4) << " before, "
              << util::FormatNumber(r.fitted_after.reduced_chi2, 4)
              << " after (the rounds and the verdict use these)\n"
              << "  rows beyond " << util::FormatNumber(FitOptions().outlier_threshold, 3)
              << " x noise after the fit: " << r.beyond_threshold_count << " of " << r.trial_count
              << "\n";
  }

  for (const FitRound& round : r.rounds) {
    std::cout << "\nRound " << round.index << ": " << round.summary << "\n"
              << "  BIC of the current model " << util::FormatNumber(round.bic_before, 6)
              << ", held-out chi^2 per residual " << util::FormatNumber(round.cv_before, 4)
              << "; an effect needs ΔBIC >= " << util::FormatNumber(round.bic_threshold, 3)
              << " and a lower held-out error\n"
              << "  candidate                        k      ΔBIC  held-out  verdict\n";
    for (const CandidateFit& f : round.candidates) {
      char line[160];
      std::snprintf(
          line, sizeof(line), "  %-30s %3d %9s %9s  ", f.effect.id.c_str(), f.added_parameters,
          util::FormatNumber(f.delta_bic, 4).c_str(),
          f.cv_status == CvStatus::kDone ? util::FormatNumber(f.cv_error, 4).c_str() : "-");
      std::cout << line << f.verdict << "\n";
    }
  }
  std::cout
      << (r.effects_claimed
              ? "\nChosen effects (parameters ± standard error from the covariance):\n"
              : "\nTentative partial fits, NOT claimed (the residual stays above the noise):\n");
  if (r.chosen_fits.empty()) std::cout << "  none\n";
  for (size_t i = 0; i < r.chosen_fits.size(); ++i) {
    const CandidateFit& f = r.chosen_fits[i];
    std::cout << "  " << i + 1 << ". " << f.effect.id << ": " << f.effect.description << "\n";
    for (size_t k = 0; k < f.values.size(); ++k) {
      const EffectParameter& p = f.effect.parameters[k];
      std::cout << "       " << p.name << " = " << util::FormatNumber(f.values[k], 5) << " ± "
                << util::FormatNumber(f.standard_errors[k], 3) << " " << p.unit;
      if (p.scale == ParameterScale::kLog10) {
        std::cout << "  (log10 ± " << util::FormatNumber(f.log10_standard_errors[k], 3) << ")";
      }
      if (f.at_bound[k]) std::cout << "  [at search limit]";
      std::cout << "\n";
    }
    if (f.effect.per_trial) {
      for (const FitReport::ForceLevel& l : r.trial_force_levels) {
        std::cout << "       force_scale:" << l.muscle << " = " << util::FormatNumber(l.level, 5)
                  << " ± " << util::FormatNumber(l.standard_error, 3) << " x  (level of its "
                  << l.trials << " trials)\n";
      }
    }
    if (!f.identifiable) std::cout << "       warning: " << f.identifiability << "\n";
  }
  for (const std::string& note : r.notes) std::cout << "  note: " << note << "\n";
  if (!r.confounded.empty()) {
    std::cout << "\nConfounded parameter pairs (|correlation| > 0.9 in the joint fit):\n";
    for (const std::string& s : r.confounded) std::cout << "  " << s << "\n";
  }
  std::cout << "\nRobust loss: " << RobustLossName(r.loss) << "; outlier rows (CSV line numbers): ";
  if (r.outlier_rows.empty()) std::cout << "none";
  for (size_t i = 0; i < r.outlier_rows.size(); ++i)
    std::cout << (i ? ", " : "") << r.outlier_rows[i];
  std::cout << "\n";
  if (!r.trial_factors.empty()) {
    std::cout << "Force level and trial variation: " << r.ForceLevelSummary();
    if (!r.trial_force_outliers.empty()) {
      std::cout << "; trials far from the rest (CSV lines):";
      for (long l : r.trial_force_outliers) std::cout << " " << l;
    }
    std::cout << "\n";
  }
  if (!r.trace.empty() || !r.trace_summary.empty()) {
    std::cout << "\nWhere the unexplained residual lives (share of the weighted residual explained "
                 "by a variable's\n"
              << "first-order effect (stiffness, offset, force, path), by a smooth trend, or held "
                 "by one muscle's\n"
              << "trials on one axis; ranked by the share beyond chance):\n";
    for (const FitReport::TraceItem& i : r.trace) {
      std::cout << "  " << Fixed(100 * i.share, 5, 1) << " %  " << i.variable << "  (" << i.note
                << ")\n";
    }
    if (!r.closest_rejected.empty())
      std::cout << "  closest rejected candidate: " << r.closest_rejected << "\n";
  }
  if (!r.indistinguishable.empty()) {
    std::cout << "\nEffects wrench data cannot tell apart at these postures:\n";
    for (const std::string& s : r.indistinguishable) std::cout << "  " << s << "\n";
  }
  std::cout << "\nPer-trial residuals after the fit" << (r.sampled() ? " (fitted trials)" : "")
            << " (N, N·m) and |weighted residual| in noise multiples:\n"
            << "  line  muscle  activ.   x noise before  x noise after  " << WrenchHeader(0)
            << "\n";
  size_t shown = 0;
  for (const TrialResidual& t : r.trials) {
    if (o.rows > 0 && static_cast<int>(shown) >= o.rows) break;
    char line[128];
    std::snprintf(line, sizeof(line), "  %4ld  %-6s %6.3f %16s %14s  ", t.line, t.muscle.c_str(),
                  t.activation, Fixed(t.normalized_before, 10, 2).c_str(),
                  Fixed(t.normalized_after, 10, 2).c_str());
    std::cout << line;
    for (int c = 0; c < 6; ++c) std::cout << Cell(t.after[c]);
    std::cout << "\n";
    ++shown;
  }
  if (shown < r.trials.size()) {
    std::cout << "  ... " << r.trials.size() - shown
              << " more (--rows 0 shows all, --json gives everything)\n";
  }
  std::cout << "\nfit took " << util::FormatNumber(r.seconds, 3) << " s\n";
  if (!o.output.empty()) std::cout << "wrote the augmented model to " << o.output << "\n";
  if (!o.report_html.empty()) std::cout << "wrote the HTML report to " << o.report_html << "\n";
  if (!o.report_markdown.empty())
    std::cout << "wrote the markdown report to " << o.report_markdown << "\n";
}

const bool kFitRegistered = RegisterCommand(
    {"fit",
     "Fit measured wrenches (CSV): trace the residual to missing effects, report the error "
     "before/after "
     "and write the augmented model",
     41, [](CLI::App& app) -> std::function<int()> {
       auto o = std::make_shared<FitCommandOptions>();
       AddModelOptions(app, o->model, {/*muscle=*/false, /*posture=*/false, /*statics=*/false});
       app.add_option("data", o->data, "Measured wrenches, CSV (format: docs/identification.md)");
       AddSheetOptions(app, o->sheet, "the data");
       app.add_option("-o,--output", o->output,
                      "Write the augmented model (URDF + chosen effects) here");
       app.add_flag("--json", o->json, "Print everything as JSON");
       app.add_option(
           "--report", o->report_html,
           "Also write a self-contained HTML report (plots, ranked candidates, glyphs) here");
       app.add_option("--report-md", o->report_markdown,
                      "Also write the report as markdown (lab notebooks) here");
       app.add_option("--rounds", o->rounds, "Most effects to add (default 3)");
       app.add_option("--folds", o->folds, "Cross-validation folds (default 5)");
       app.add_option("--screen", o->screen,
                      "Per round, fit only the N candidates with the best linearised ΔBIC (a "
                      "score test at the current model; default 8, 0 = fit every candidate)");
       app.add_option("--threads", o->threads,
                      "Fit candidates (and cross-validation folds, trace probes) on this many "
                      "threads (default 0: every core)");
       app.add_option("--candidates", o->candidates,
                      "Only try these effect ids, comma-separated (default: the whole library)")
           ->delimiter(',');
       app.add_option("--loss", o->loss,
                      "Loss per row: huber (default), cauchy or none (plain least squares)");
       app.add_option(
           "--loss-scale", o->loss_scale,
           "Knee of the robust loss in stated-noise multiples of a row's RMS residual (default 2)");
       app.add_flag("--progress", o->progress,
                    "Report reading and fitting progress on stderr even when it is not a "
                    "terminal (it is reported on a terminal anyway)");
       app.add_option("--max-fit-trials", o->max_fit_trials,
                      "Fit at most N trials: with more rows, a uniform random sample of N "
                      "(reservoir sampling) is fitted and every row is predicted in a second "
                      "pass for the error before/after; memory does not grow with the rows "
                      "(default 20000, 0 = fit every row)")
           ->check(CLI::Validator(
               [](std::string& v) -> std::string {
                 char* end = nullptr;
                 errno = 0;
                 const long n = std::strtol(v.c_str(), &end, 10);
                 if (v.empty() || *end != '\0' || errno != 0 || n < 0 || n > 2147483647L) {
                   return "expected a whole number of trials >= 0 (0 = fit every row), got '" + v +
                          "'";
                 }
                 return std::string();
               },
               "N >= 0"));
       app.add_option("--sample-seed", o->sample_seed,
                      "Seed of the --max-fit-trials sample (default 1; same seed, same sample)");
       app.add_option("--rows", o->rows, "Per-trial rows in the table (default 20, 0 = all)");
       app.add_flag("--list-effects", o->list_effects,
                    "List the candidate effects for the model and exit");
       return [o]() {
         Model model = LoadModel(o->model);
         if (o->list_effects) {
           std::vector<Effect> effects = CandidateEffects(model);
           if (o->json) {
             nlohmann::json j = nlohmann::json::array();
             for (const Effect& e : effects) j.push_back(EffectJson(e));
             std::cout << j.dump(2) << "\n";
             return 0;
           }
           std::cout << "Effect kinds in the registry:\n";
           for (const EffectKindInfo& k : EffectKinds()) {
             std::cout << "  " << k.id_pattern << "  [" << EffectStageName(k.stage) << "]\n      "
                       << k.summary << "\n      parameters: " << k.parameters
                       << "\n      confounded with: " << k.confounders << "\n";
           }
           std::cout << "\nCandidate effects for " << model.name()
                     << " (simulate: --effect ID=V1,V2,... in these units):\n";
           for (const Effect& e : effects) {
             std::vector<std::string> p;
             for (const EffectParameter& q : e.parameters) {
               p.push_back(q.name + " (" + q.unit + ", " + util::FormatNumber(q.lower, 3) + " to " +
                           util::FormatNumber(q.upper, 3) + ")");
             }
             std::cout << "  " << e.id << "\n      " << e.description << "\n      "
                       << util::Join(p, ", ") << "\n";
           }
           return 0;
         }
         if (o->data.empty())
           throw Error("fit: missing <data.csv> (measured wrenches; see docs/identification.md)");
         const bool progress = o->progress || isatty(fileno(stderr));
         FitOptions options;
         options.max_fit_trials = o->max_fit_trials;
         options.sample_seed = o->sample_seed;
         options.max_rounds = o->rounds;
         options.folds = o->folds;
         options.screen_keep = o->screen;
         options.threads = o->threads;
         options.candidates = o->candidates;
         options.loss = ParseRobustLoss(o->loss);
         options.loss_scale = o->loss_scale;
         if (progress) {
           options.progress = [](const std::string& stage) {
             std::cerr << "fit: " << stage << "\n" << std::flush;
           };
         }
         // Streamed twice in bounded memory: the first pass reads and checks every row and keeps
         // the sample, the second (only when rows were left out) predicts every row.
         std::vector<Trial> trials;  // the fitted trials
         FitReport report = FitEffectsCsv(
             model, o->data, o->sheet, options, TerminalProgress("reading " + o->data, o->progress),
             TerminalProgress("predicting every row of " + o->data, o->progress), &trials);
         if (!o->output.empty()) WriteAugmentedUrdf(report, o->output);
         FitReportOptions report_options;
         report_options.trials = &trials;
         report_options.model = &model;
         if (!o->report_html.empty()) WriteFitReportHtml(report, o->report_html, report_options);
         if (!o->report_markdown.empty())
           WriteFitReportMarkdown(report, o->report_markdown, report_options);
         if (o->json) {
           std::cout << ReportJson(report, o->model.urdf, o->data, o->output).dump(2) << "\n";
         } else {
           PrintReport(report, *o);
         }
         return 0;
       };
     }});

}  // namespace
}  // namespace isowrench::cli
