// The report steps after the rounds: per-trial residuals and outlier rows, per-trial force
// factors, correlations of the chosen parameters, the verdict; the report's text forms
// (BriefReport) and the augmented URDF.

#include <cmath>
#include <sstream>

#include "identification/fit_stages.hpp"
#include "isowrench/error.hpp"
#include "util/atomic_file.hpp"
#include "util/text.hpp"

namespace isowrench {
namespace ident {

void ReportTrials(const std::vector<Trial>& trials, const Prediction& nominal,
                  const Current& current, const FitOptions& options, FitReport* report) {
  for (size_t k = 0; k < trials.size(); ++k) {
    TrialResidual t;
    t.line = trials[k].line;
    t.muscle = trials[k].muscle;
    t.activation = trials[k].activation;
    t.measured = trials[k].wrench;
    t.before = trials[k].wrench - nominal.wrench[k];
    t.after = trials[k].wrench - current.prediction[k];
    double nb = 0, na = 0;
    for (int c = 0; c < 6; ++c) {
      double w = Weight(trials[k], c, options);
      nb += std::pow(w * t.before[c], 2);
      na += std::pow(w * t.after[c], 2);
    }
    t.normalized_before = std::sqrt(nb / 6);
    t.normalized_after = std::sqrt(na / 6);
    report->trials.push_back(t);
    if (options.loss != RobustLoss::kNone && t.normalized_after > options.outlier_threshold) {
      report->outlier_rows.push_back(t.line);
    }
  }
  // Outliers are a minority by definition: when more rows than kMaxOutlierFraction are far off,
  // the model misses something everywhere and no row is singled out.
  if (report->outlier_rows.size() > kMaxOutlierFraction * trials.size()) {
    report->notes.push_back(std::to_string(report->outlier_rows.size()) + " of " +
                            std::to_string(trials.size()) + " rows are beyond " +
                            util::FormatNumber(options.outlier_threshold, 3) +
                            " x noise: a systematic misfit, not outliers (no row flagged)");
    report->outlier_rows.clear();
  }
  if (current.augmented.trial_force) {
    const Context c =
        MakeContext(current.augmented, {}, trials, AllIndices(trials.size()), options);
    Readings p;
    if (!c.Predict(nullptr, &p)) return;
    report->trial_factors = p.factor;
    const ForceLevels levels = FitForceLevels(c, p);
    report->trial_force_spread = levels.sigma;
    report->trial_force_spread_se = levels.sigma_se;
    report->trial_force_lrt = levels.lrt;
    for (size_t m = 0; m < levels.muscles.size(); ++m) {
      const double s = std::exp(levels.log_level[m]);
      report->trial_force_levels.push_back(
          {levels.muscles[m], s, s * levels.log_level_se[m], levels.trials[m]});
    }
    const double s2 = levels.sigma * levels.sigma;
    for (size_t k = 0; k < trials.size(); ++k) {
      if (levels.muscle[k] < 0) continue;
      const double d = levels.x[k] - levels.log_level[levels.muscle[k]];
      if (std::abs(d) > kFarFactor * std::sqrt(s2 + levels.v[k]))
        report->trial_force_outliers.push_back(trials[k].line);
    }
  }
}

void ReportCorrelations(const Model& nominal, const std::vector<Trial>& trials,
                        const Current& current, const FitOptions& options, FitReport* report) {
  if (current.effects.empty()) return;
  Say(options, "report: joint fit of the " + std::to_string(current.effects.size()) +
                   " chosen effects (correlations)");
  JointFit joint = FitJointly(nominal.description(), current.effects, trials, options);
  if (!joint.usable) return;
  report->correlation_labels = joint.labels;
  report->correlations = joint.correlation;
  for (int i = 0; i < joint.correlation.rows(); ++i) {
    for (int j = i + 1; j < joint.correlation.cols(); ++j) {
      if (std::abs(joint.correlation(i, j)) > kConfoundedCorrelation) {
        report->confounded.push_back(
            joint.labels[i] + " and " + joint.labels[j] +
            " are confounded (r = " + util::FormatNumber(joint.correlation(i, j), 3) + ")");
      }
    }
  }
}

void ReportVerdict(const std::vector<Trial>& trials, const Current& current,
                   const FitOptions& options, FitReport* report) {
  std::ostringstream m;
  if (!report->sd_stated) {
    report->verdict = FitVerdict::kNoNoiseStated;
    m << "the data state no standard deviations, so the residual cannot be compared with the "
         "noise; weighted with "
      << util::FormatNumber(options.default_sd_force, 3) << " N and "
      << util::FormatNumber(options.default_sd_moment, 3) << " N·m";
    report->verdict_message = m.str();
    return;
  }
  std::vector<Trial> kept;
  std::vector<Vector6d> kept_prediction;
  for (size_t k = 0; k < trials.size(); ++k) {
    if (std::find(report->outlier_rows.begin(), report->outlier_rows.end(), trials[k].line) !=
        report->outlier_rows.end()) {
      continue;
    }
    kept.push_back(trials[k]);
    kept_prediction.push_back(current.prediction[k]);
  }
  const ResidualStats s =
      ComputeResidualStats(kept, kept_prediction, current.residual_parameters, options);
  const int dof = std::max(1, s.residual_count - current.residual_parameters);
  const double reduced = s.chi2 / dof;
  const double threshold = 1.0 + options.unexplained_sigmas * std::sqrt(2.0 / dof);
  const double multiple = std::sqrt(reduced);
  const std::string outliers =
      report->outlier_rows.empty()
          ? ""
          : " (" + std::to_string(report->outlier_rows.size()) + " outlier row(s) left out)";
  if (reduced > threshold) {
    report->verdict = FitVerdict::kUnexplained;
    report->effects_claimed = report->chosen.empty();
    m << "after " << report->chosen.size() << " effect(s) the residual is "
      << util::FormatNumber(multiple, 3) << " x the stated noise (reduced chi^2 "
      << util::FormatNumber(reduced, 4) << " > " << util::FormatNumber(threshold, 4) << ")"
      << outliers << "; something outside the candidate library is missing";
    if (!report->chosen.empty()) {
      m << "; the effects tried reduce the residual but do not explain it, so none is claimed "
           "(tentative partial "
           "fits below)";
    }
  } else if (report->chosen.empty()) {
    report->verdict = FitVerdict::kNominalFits;
    m << "the nominal model explains the data to the noise (residual "
      << util::FormatNumber(multiple, 3) << " x noise)" << outliers << "; no effect is claimed";
  } else {
    report->verdict = FitVerdict::kExplained;
    // Force levels and trial variation are named with their values (what was found, not only
    // which effect): "force_scale:GP = 0.8 ± 0.0012 x", "trial_force (...)".
    std::vector<std::string> ids;
    for (size_t e = 0; e < report->chosen.size(); ++e) {
      const AppliedEffect& a = report->chosen[e];
      std::string id = a.effect.id;
      if (a.effect.kind == "force_scale" && e < report->chosen_fits.size()) {
        const CandidateFit& f = report->chosen_fits[e];
        id += " = " + util::FormatNumber(f.values[0], 4);
        if (f.standard_errors[0] > 0) id += " ± " + util::FormatNumber(f.standard_errors[0], 2);
        id += " x";
      }
      if (a.effect.per_trial) id += " (" + report->ForceLevelSummary() + ")";
      ids.push_back(id);
    }
    m << "explained by " << util::Join(ids, " + ") << ": residual from "
      << util::FormatNumber(std::sqrt(report->fitted_before.chi2 /
                                      std::max(1, report->fitted_before.residual_count)),
                            3)
      << " x noise to " << util::FormatNumber(multiple, 3) << " x noise" << outliers;
  }
  report->verdict_message = m.str();
}

void GuardFinite(CandidateFit* f) {
  for (size_t i = 0; i < f->values.size(); ++i) {
    if (!std::isfinite(f->standard_errors[i]) || !std::isfinite(f->log10_standard_errors[i])) {
      f->standard_errors[i] = 0.0;
      f->log10_standard_errors[i] = 0.0;
      f->identifiable = false;
    }
  }
  if (!f->correlation.allFinite())
    f->correlation.setIdentity(f->correlation.rows(), f->correlation.cols());
  for (double* v : {&f->cost, &f->aic, &f->bic, &f->delta_bic}) {
    if (!std::isfinite(*v)) *v = -1.0;
  }
  if (!std::isfinite(f->cv_error)) {
    f->cv_status = CvStatus::kFailed;
    f->cv_error = 0.0;
  }
}

}  // namespace ident

const char* FitVerdictName(FitVerdict verdict) {
  switch (verdict) {
    case FitVerdict::kNominalFits: return "nominal model fits";
    case FitVerdict::kExplained: return "explained";
    case FitVerdict::kUnexplained: return "unexplained residual";
    case FitVerdict::kNoNoiseStated: return "no noise stated";
  }
  return "?";
}

const char* RobustLossName(RobustLoss loss) {
  switch (loss) {
    case RobustLoss::kNone: return "none";
    case RobustLoss::kHuber: return "huber";
    case RobustLoss::kCauchy: return "cauchy";
  }
  return "?";
}

RobustLoss ParseRobustLoss(const std::string& text) {
  for (RobustLoss l : {RobustLoss::kNone, RobustLoss::kHuber, RobustLoss::kCauchy}) {
    if (text == RobustLossName(l)) return l;
  }
  throw Error("--loss '" + text + "': expected one of huber, cauchy, none");
}

std::string FitReport::BriefReport() const {
  std::ostringstream o;
  o << "verdict: " << FitVerdictName(verdict) << ": " << verdict_message << "\n";
  if (sampled()) o << "sample: " << sampling << "\n";
  for (size_t i = 0; i < chosen_fits.size(); ++i) {
    const CandidateFit& f = chosen_fits[i];
    o << (effects_claimed ? "effect " : "tentative, not claimed: ") << i + 1 << ": " << f.effect.id
      << ": " << ident::ValueText(f.effect, f.values, f.standard_errors) << "\n";
  }
  const char* names[6] = {"fx", "fy", "fz", "mx", "my", "mz"};
  for (int c = 0; c < 6; ++c) {
    o << "  " << names[c] << " RMS " << util::FormatNumber(before.rms[c], 3) << " -> "
      << util::FormatNumber(after.rms[c], 3) << (c < 3 ? " N" : " N·m");
    if (sd_stated) {
      o << " (" << util::FormatNumber(before.normalized[c], 3) << " -> "
        << util::FormatNumber(after.normalized[c], 3) << " x noise)";
    }
    o << "\n";
  }
  if (!outlier_rows.empty()) {
    std::vector<std::string> lines;
    for (long l : outlier_rows) lines.push_back(std::to_string(l));
    o << "outlier rows (CSV lines, " << RobustLossName(loss)
      << " loss): " << util::Join(lines, ", ") << "\n";
  }
  if (!trial_factors.empty()) {
    o << "trial force: " << ForceLevelSummary();
    if (!trial_force_outliers.empty()) {
      std::vector<std::string> lines;
      for (long l : trial_force_outliers) lines.push_back(std::to_string(l));
      o << "; far from the rest: lines " << util::Join(lines, ", ");
    }
    o << "\n";
  }
  for (const std::string& s : confounded) o << "confounded: " << s << "\n";
  if (!trace_summary.empty()) o << "trace: " << trace_summary << "\n";
  for (const std::string& s : indistinguishable) o << "note: " << s << "\n";
  for (const std::string& s : notes) o << "note: " << s << "\n";
  return o.str();
}

std::string FitReport::ForceLevelSummary() const {
  if (trial_factors.empty()) return "";
  std::vector<std::string> parts;
  for (const ForceLevel& l : trial_force_levels) {
    // A level within 3 standard errors of 1 is no finding: the muscle is as strong as declared.
    const bool found = std::abs(l.level - 1.0) > 3.0 * l.standard_error;
    parts.push_back("force_scale:" + l.muscle + " = " + util::FormatNumber(l.level, 4) + " ± " +
                    util::FormatNumber(l.standard_error, 2) + " x (level of " + l.muscle + "'s " +
                    std::to_string(l.trials) + " trials" +
                    (found ? "" : ", consistent with its max_force") + ")");
  }
  parts.push_back("trial_force spread " + util::FormatNumber(trial_force_spread, 3) + " ± " +
                  util::FormatNumber(trial_force_spread_se, 2) +
                  " (sd of ln factor around the level; likelihood ratio " +
                  util::FormatNumber(trial_force_lrt, 4) + " against the levels alone)");
  return util::Join(parts, "; ");
}

void WriteAugmentedUrdf(const FitReport& report, const std::string& path) {
  std::string xml = WriteUrdfString(report.augmented.description);
  std::string comment = "isowrench fit of " + report.model_name + " (" +
                        std::to_string(report.trial_count) + " trials): " + report.BriefReport();
  const AugmentedModel& a = report.augmented;
  const Vector6d& o = a.sensor_offset;
  if (o.norm() > 0) {
    comment += "sensor offset (not representable in URDF; subtract it from the readings): ";
    for (int c = 0; c < 6; ++c) comment += util::FormatNumber(o[c], 4) + (c < 3 ? " N " : " N·m ");
    comment += "\n";
  }
  for (const auto& p : a.posture_offset) {
    comment += "recorded " + p.first +
               " is offset (add to the recorded value): " + util::FormatNumber(p.second, 6) +
               " rad or m\n";
  }
  for (const auto& c : a.coactivation) {
    comment += "muscle " + c.first + " also pulls in other muscles' trials with " +
               util::FormatNumber(c.second, 4) + " x its max force\n";
  }
  if (a.sensor_origin.norm() > 0) {
    comment += "transducer moment origin offset (transducer axes, m): " +
               util::FormatNumber(a.sensor_origin[0], 4) + " " +
               util::FormatNumber(a.sensor_origin[1], 4) + " " +
               util::FormatNumber(a.sensor_origin[2], 4) + "\n";
  }
  if (!a.calibration.isIdentity(0.0)) {
    comment += "transducer calibration error (reading = C x wrench), rows fx..mz:";
    for (int i = 0; i < 6; ++i) {
      comment += "\n ";
      for (int j = 0; j < 6; ++j) comment += " " + util::FormatNumber(a.calibration(i, j), 5);
    }
    comment += "\n";
  }
  if (a.trial_force) {
    comment += "per-trial force factors were fitted (max_force holds each muscle's level): " +
               report.ForceLevelSummary() + "\n";
  }
  size_t pos;
  while ((pos = comment.find("--")) != std::string::npos) comment.replace(pos, 2, "- -");
  comment = "<!-- " + comment + "-->\n";
  size_t insert = 0;
  if (xml.compare(0, 5, "<?xml") == 0) insert = xml.find('\n') + 1;
  xml.insert(insert, comment);
  util::WriteFileAtomically(path, xml);
}

}  // namespace isowrench
