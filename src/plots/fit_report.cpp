// Fit reports a person can read at a glance: HTML (inline SVG plots and glyphs) and markdown.

#include <algorithm>
#include <cmath>
#include <numeric>

#include "isowrench/error.hpp"
#include "isowrench/plots.hpp"
#include "plots/svg_writer.hpp"
#include "plots/wrench_glyph.hpp"
#include "util/atomic_file.hpp"
#include "util/text.hpp"

namespace isowrench {
namespace {

using plots::Num;
using plots::XmlEscape;

const char* kComponent[6] = {"fx", "fy", "fz", "mx", "my", "mz"};
const char* kUnit[6] = {"N", "N", "N", "N·m", "N·m", "N·m"};
const char* kBeforeColor = "#e07b00";
const char* kAfterColor = "#1f5fbf";

// Own names so the renderer does not depend on the fitting code being linked.
const char* VerdictText(FitVerdict verdict) {
  switch (verdict) {
    case FitVerdict::kNominalFits: return "nominal model fits";
    case FitVerdict::kExplained: return "explained";
    case FitVerdict::kUnexplained: return "unexplained residual";
    case FitVerdict::kNoNoiseStated: return "no noise stated";
  }
  return "unknown";
}

std::string N4(double v) { return util::FormatNumber(v, 4); }

std::string Percent(double before, double after) {
  if (!(before > 0)) return "n/a";
  return util::FormatNumber(100.0 * (before - after) / before, 3) + " %";
}

std::string ParameterText(const Effect& effect, const std::vector<double>& values,
                          const std::vector<double>& se) {
  std::vector<std::string> items;
  for (size_t i = 0; i < effect.parameters.size() && i < values.size(); ++i) {
    const EffectParameter& p = effect.parameters[i];
    std::string item = p.name + " = " + N4(values[i]);
    if (i < se.size() && se[i] > 0) item += " ± " + util::FormatNumber(se[i], 2);
    item += " " + p.unit;
    items.push_back(item);
  }
  return util::Join(items, ", ");
}

std::string CvText(double cv) { return cv < 0 ? "–" : N4(cv); }

// Trials ordered by residual before the fit, largest first.
std::vector<size_t> WorstTrials(const FitReport& report, size_t count) {
  std::vector<size_t> order(report.trials.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return report.trials[a].normalized_before > report.trials[b].normalized_before;
  });
  order.resize(std::min(count, order.size()));
  return order;
}

// ---- small x-y plots ----------------------------------------------------------------------

struct Series {
  std::string name, color, cls;
  std::vector<Eigen::Vector2d> points;
};

// Round step: 1, 2 or 5 times a power of ten, about range / target.
double NiceStep(double range, int target) {
  double raw = range / target;
  double mag = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0, 10.0}) {
    if (m * mag >= raw) return m * mag;
  }
  return 10 * mag;
}

std::string XYPlotSvg(const std::string& title, const std::string& xlabel,
                      const std::string& ylabel, const std::vector<Series>& series, bool diagonal,
                      bool zero_line) {
  constexpr double kW = 280, kH = 240, kL = 58, kR = 12, kT = 34, kB = 40;
  double xmin = 1e300, xmax = -1e300, ymin = 1e300, ymax = -1e300;
  for (const Series& s : series) {
    for (const Eigen::Vector2d& p : s.points) {
      xmin = std::min(xmin, p.x());
      xmax = std::max(xmax, p.x());
      ymin = std::min(ymin, p.y());
      ymax = std::max(ymax, p.y());
    }
  }
  if (xmin > xmax) xmin = -1, xmax = 1, ymin = -1, ymax = 1;
  if (diagonal) {  // same range on both axes so y = x is the 45° line
    xmin = ymin = std::min(xmin, ymin);
    xmax = ymax = std::max(xmax, ymax);
  }
  if (zero_line) {
    ymin = std::min(ymin, 0.0);
    ymax = std::max(ymax, 0.0);
  }
  auto widen = [](double& lo, double& hi) {
    double span = hi - lo;
    double pad = span > 0 ? 0.06 * span : std::max(1e-12, 0.1 * std::abs(lo));
    lo -= pad;
    hi += pad;
  };
  widen(xmin, xmax);
  widen(ymin, ymax);
  const double pw = kW - kL - kR, ph = kH - kT - kB;
  auto sx = [&](double x) { return kL + (x - xmin) / (xmax - xmin) * pw; };
  auto sy = [&](double y) { return kT + (ymax - y) / (ymax - ymin) * ph; };
  plots::SvgWriter svg(kW, kH, title);
  svg.Text(kL, 15, title, 11, "start", {{"font-weight", "bold"}});
  svg.Element("rect", {{"x", Num(kL)},
                       {"y", Num(kT)},
                       {"width", Num(pw)},
                       {"height", Num(ph)},
                       {"fill", "none"},
                       {"stroke", "#999999"}});
  const double xs = NiceStep(xmax - xmin, 4), ys = NiceStep(ymax - ymin, 4);
  // Ticks by integer index (t = k * step), at most kMaxTicks, so a step below the spacing of
  // doubles near a large value cannot stall the loop.
  constexpr int kMaxTicks = 12;
  const double kx0 = std::ceil(xmin / xs), ky0 = std::ceil(ymin / ys);
  for (int k = 0; k < kMaxTicks && std::isfinite(kx0) && (kx0 + k) * xs <= xmax; ++k) {
    const double t = (kx0 + k) * xs;
    svg.Line(sx(t), kT + ph, sx(t), kT + ph + 4, "#666666", 1);
    svg.Text(sx(t), kT + ph + 14, util::FormatNumber(std::abs(t) < 1e-9 * xs ? 0.0 : t, 3), 9,
             "middle");
  }
  for (int k = 0; k < kMaxTicks && std::isfinite(ky0) && (ky0 + k) * ys <= ymax; ++k) {
    const double t = (ky0 + k) * ys;
    svg.Line(kL - 4, sy(t), kL, sy(t), "#666666", 1);
    svg.Text(kL - 6, sy(t) + 3, util::FormatNumber(std::abs(t) < 1e-9 * ys ? 0.0 : t, 3), 9, "end");
  }
  svg.Text(kL + pw / 2, kH - 6, xlabel, 10, "middle", {{"class", "xlabel"}});
  svg.Text(12, kT + ph / 2, ylabel, 10, "middle",
           {{"class", "ylabel"}, {"transform", "rotate(-90 12 " + Num(kT + ph / 2, 1) + ")"}});
  if (diagonal) {
    svg.Line(sx(xmin), sy(xmin), sx(xmax), sy(xmax), "#aaaaaa", 1,
             {{"class", "identity"}, {"stroke-dasharray", "4,3"}});
  }
  if (zero_line)
    svg.Line(kL, sy(0), kL + pw, sy(0), "#aaaaaa", 1,
             {{"class", "zero"}, {"stroke-dasharray", "4,3"}});
  double legend_x = kL + 6;
  for (const Series& s : series) {
    svg.Open("g", {{"class", "series " + s.cls}, {"data-series", s.name}});
    for (const Eigen::Vector2d& p : s.points) {
      svg.Element("circle", {{"class", "point"},
                             {"cx", Num(sx(p.x()), 2)},
                             {"cy", Num(sy(p.y()), 2)},
                             {"r", "2.2"},
                             {"fill", s.color},
                             {"fill-opacity", "0.7"},
                             {"data-x", plots::Exact(p.x())},
                             {"data-y", plots::Exact(p.y())}});
    }
    svg.Close();
    // Legend in the top margin, between the title and the plot area.
    svg.Element("circle",
                {{"cx", Num(legend_x + 3)}, {"cy", Num(kT - 9)}, {"r", "3"}, {"fill", s.color}});
    svg.Text(legend_x + 9, kT - 6, s.name, 9);
    legend_x += 12 + 5.5 * static_cast<double>(s.name.size()) + 10;
  }
  return svg.Finish(false);
}

// ---- shared table content --------------------------------------------------------------

struct Table {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
  std::vector<std::string> row_class;  // HTML class per row ("" = none)
};

Table ErrorTable(const FitReport& r) {
  Table t;
  t.header = {"component",
              "RMS before",
              "RMS after",
              "reduction",
              "R² before",
              "R² after",
              "noise multiples before",
              "noise multiples after",
              "mean before",
              "mean after"};
  for (int i = 0; i < 6; ++i) {
    const std::string u = std::string(" ") + kUnit[i];
    t.rows.push_back({std::string(kComponent[i]) + " (" + kUnit[i] + ")", N4(r.before.rms[i]) + u,
                      N4(r.after.rms[i]) + u, Percent(r.before.rms[i], r.after.rms[i]),
                      N4(r.before.r2[i]), N4(r.after.r2[i]), N4(r.before.normalized[i]),
                      N4(r.after.normalized[i]), N4(r.before.mean[i]) + u,
                      N4(r.after.mean[i]) + u});
    t.row_class.push_back("");
  }
  t.rows.push_back({"χ² (all)", N4(r.before.chi2), N4(r.after.chi2),
                    Percent(r.before.chi2, r.after.chi2), "", "",
                    "reduced χ² " + N4(r.before.reduced_chi2),
                    "reduced χ² " + N4(r.after.reduced_chi2), "", ""});
  t.row_class.push_back("total");
  return t;
}

Table ChosenTable(const FitReport& r) {
  Table t;
  t.header = {"#", "effect", "description", "parameters (± standard error)"};
  for (size_t i = 0; i < r.chosen.size(); ++i) {
    const AppliedEffect& a = r.chosen[i];
    std::vector<double> se =
        i < r.chosen_fits.size() ? r.chosen_fits[i].standard_errors : std::vector<double>{};
    t.rows.push_back({std::to_string(i + 1), a.effect.id, a.effect.description,
                      ParameterText(a.effect, a.values, se)});
    t.row_class.push_back("");
  }
  return t;
}

// Outlier rows, confounded pairs and the trace, one row each.
Table DiagnosticsTable(const FitReport& r) {
  Table t;
  t.header = {"diagnostic", "value"};
  std::vector<std::string> lines;
  for (long l : r.outlier_rows) lines.push_back(std::to_string(l));
  t.rows.push_back({"outlier rows (CSV lines, " + std::string(RobustLossName(r.loss)) + " loss)",
                    lines.empty() ? "none" : util::Join(lines, ", ")});
  t.row_class.push_back("outliers");
  for (const std::string& c : r.confounded) {
    t.rows.push_back({"confounded pair", c});
    t.row_class.push_back("confounded");
  }
  if (!r.trial_factors.empty()) {
    std::vector<std::string> far;
    for (long l : r.trial_force_outliers) far.push_back(std::to_string(l));
    t.rows.push_back(
        {"force level and trial variation",
         r.ForceLevelSummary() +
             (far.empty() ? "" : "; far from their level: lines " + util::Join(far, ", "))});
    t.row_class.push_back("trial-force");
  }
  if (!r.closest_rejected.empty()) {
    t.rows.push_back({"closest rejected candidate", r.closest_rejected});
    t.row_class.push_back("closest");
  }
  return t;
}

// The trace as a horizontal bar chart: share of the residual per variable.
std::string TraceSvg(const FitReport& r) {
  const double bar_w = 360, row_h = 18, label_w = 220;
  const double height = 30 + row_h * r.trace.size();
  plots::SvgWriter svg(label_w + bar_w + 80, height, "where the residual lives");
  svg.Text(10, 16, "share of the weighted residual", 12, "start", {{"font-weight", "bold"}});
  for (size_t i = 0; i < r.trace.size(); ++i) {
    const double y = 26 + row_h * i;
    const double share = std::min(1.0, std::max(0.0, r.trace[i].share));
    svg.Text(label_w - 6, y + 12, r.trace[i].variable, 11, "end");
    svg.Open("g", {{"class", "trace-bar"}, {"data-variable", r.trace[i].variable}});
    svg.Element("rect", {{"x", plots::Num(label_w)},
                         {"y", plots::Num(y + 2)},
                         {"width", plots::Num(std::max(1.0, bar_w * share))},
                         {"height", plots::Num(row_h - 4)},
                         {"fill", kAfterColor}});
    svg.Close();
    svg.Text(label_w + bar_w * share + 6, y + 12, N4(100 * share) + " %", 11, "start");
  }
  return svg.Finish(false);
}

Table CandidateTable(const FitRound& round) {
  Table t;
  t.header = {"rank",         "effect",    "ΔBIC",
              "BIC",          "AICc",      "held-out χ²/residual",
              "identifiable", "converged", "parameters (± standard error)",
              "verdict"};
  for (size_t i = 0; i < round.candidates.size(); ++i) {
    const CandidateFit& c = round.candidates[i];
    std::string ident =
        c.identifiable ? "yes" : "no" + (c.identifiability.empty() ? "" : ": " + c.identifiability);
    std::string params = ParameterText(c.effect, c.values, c.standard_errors);
    for (size_t k = 0; k < c.at_bound.size(); ++k) {
      if (c.at_bound[k] && k < c.effect.parameters.size())
        params += " [" + c.effect.parameters[k].name + " at bound]";
    }
    t.rows.push_back(
        {std::to_string(i + 1), c.effect.id, N4(c.delta_bic), N4(c.bic), N4(c.aic),
         c.cv_status == CvStatus::kDone ? CvText(c.cv_error) : CvText(-1.0), ident,
         c.converged ? "yes" : "no" + (c.solver_message.empty() ? "" : ": " + c.solver_message),
         params, c.verdict});
    t.row_class.push_back(round.chosen == i ? "chosen" : "");
  }
  return t;
}

std::string HtmlTable(const Table& t, const std::string& cls) {
  std::string out = "<table class=\"" + cls + "\">\n<tr>";
  for (const std::string& h : t.header) out += "<th>" + XmlEscape(h) + "</th>";
  out += "</tr>\n";
  for (size_t r = 0; r < t.rows.size(); ++r) {
    out += t.row_class[r].empty() ? "<tr>" : "<tr class=\"" + t.row_class[r] + "\">";
    for (const std::string& cell : t.rows[r]) out += "<td>" + XmlEscape(cell) + "</td>";
    out += "</tr>\n";
  }
  return out + "</table>\n";
}

std::string MarkdownCell(const std::string& text) {
  std::string out;
  for (char c : text) out += c == '|' ? std::string("\\|") : std::string(1, c);
  return out;
}

std::string MarkdownTable(const Table& t) {
  std::string out = "|";
  for (const std::string& h : t.header) out += " " + MarkdownCell(h) + " |";
  out += "\n|";
  for (size_t i = 0; i < t.header.size(); ++i) out += "---|";
  out += "\n";
  for (size_t r = 0; r < t.rows.size(); ++r) {
    out += "|";
    for (size_t c = 0; c < t.rows[r].size(); ++c) {
      std::string cell = MarkdownCell(t.rows[r][c]);
      if (t.row_class[r] == "chosen" && c == 1) cell = "**" + cell + "**";
      out += " " + cell + " |";
    }
    out += "\n";
  }
  return out;
}

std::string Title(const FitReport& r, const FitReportOptions& o) {
  return o.title.empty() ? "Fit report: " + r.model_name : o.title;
}

std::vector<std::string> SummaryLines(const FitReport& r) {
  std::vector<std::string> lines;
  lines.push_back("Verdict: " + std::string(VerdictText(r.verdict)) +
                  (r.verdict_message.empty() ? "" : " — " + r.verdict_message));
  lines.push_back("Data: " + std::to_string(r.trial_count) + " trials" +
                  (r.source.empty() ? "" : " from " + r.source) +
                  (r.sd_stated ? ", standard deviations stated per trial"
                               : ", no standard deviations stated (default weights)") +
                  "; fit took " + util::FormatNumber(r.seconds, 3) + " s.");
  if (r.sampled()) lines.push_back("Sample: " + r.sampling + ".");
  std::vector<std::string> ids;
  for (const AppliedEffect& a : r.chosen) ids.push_back(a.effect.id);
  if (ids.empty() || r.effects_claimed) {
    lines.push_back(
        "Effects added: " + (ids.empty() ? std::string("none") : util::Join(ids, ", ")) + ".");
  } else {
    lines.push_back(
        "Effects tried (tentative: they reduce the residual but do not bring it to the noise, so "
        "they are not claimed as found): " +
        util::Join(ids, ", ") + ".");
  }
  lines.push_back(
      "Residual = measured - predicted, in transducer axes (N, N·m; moment about the endpoint).");
  return lines;
}

std::string RoundLine(const FitRound& round) {
  return "Current model: χ² " + N4(round.before.chi2) + ", BIC " + N4(round.bic_before) +
         ", held-out χ²/residual " + CvText(round.cv_before) +
         (round.bic_threshold > 0 ? "; an effect needs ΔBIC ≥ " + N4(round.bic_threshold) : "") +
         ". " + round.summary;
}

void CheckOptions(const FitReport& r, const FitReportOptions& o) {
  if (o.glyph_trials < 0 || o.markdown_trials < 0)
    throw Error("fit report: glyph_trials and markdown_trials must be >= 0");
  if (!o.trials) return;
  if (o.trials->size() != r.trials.size()) {
    throw Error("fit report: " + std::to_string(o.trials->size()) +
                " trials given for a report of " + std::to_string(r.trials.size()) +
                " trials; pass the trials the fit used");
  }
  for (size_t k = 0; k < r.trials.size(); ++k) {
    if ((*o.trials)[k].line != r.trials[k].line) {
      throw Error("fit report: trial " + std::to_string(k + 1) + " comes from line " +
                  std::to_string((*o.trials)[k].line) + " but the report's from line " +
                  std::to_string(r.trials[k].line) + "; pass the trials in the order the fit used");
    }
  }
}

// Residual size before/after against each joint that varies across the trials.
std::string PosturePlots(const FitReport& r, const std::vector<Trial>& trials, const Model& model) {
  // Spread below this (rad or m) counts as a joint held fixed: nothing to plot against.
  constexpr double kMinSpread = 1e-9;
  std::string out;
  const std::vector<std::string>& names =
      trials.front().joint_names ? *trials.front().joint_names : model.joint_names();
  for (size_t j = 0; j < names.size(); ++j) {
    double lo = 1e300, hi = -1e300;
    for (const Trial& t : trials) {
      if (static_cast<Eigen::Index>(j) >= t.q.size()) return out;
      lo = std::min(lo, t.q[static_cast<Eigen::Index>(j)]);
      hi = std::max(hi, t.q[static_cast<Eigen::Index>(j)]);
    }
    if (!(hi - lo > kMinSpread)) continue;
    const auto& model_names = model.joint_names();
    const auto it = std::find(model_names.begin(), model_names.end(), names[j]);
    const bool prismatic =
        it != model_names.end() &&
        model.joint(static_cast<int>(it - model_names.begin())).type == JointType::kPrismatic;
    const double to_user = prismatic ? 1e3 : 180.0 / 3.14159265358979323846;
    Series before{"before", kBeforeColor, "before", {}}, after{"after", kAfterColor, "after", {}};
    for (size_t k = 0; k < trials.size(); ++k) {
      const double x = trials[k].q[static_cast<Eigen::Index>(j)] * to_user;
      before.points.emplace_back(x, r.trials[k].normalized_before);
      after.points.emplace_back(x, r.trials[k].normalized_after);
    }
    out += "<div class=\"plot posture\" data-joint=\"" + XmlEscape(names[j]) + "\">" +
           XYPlotSvg("residual size vs " + names[j], names[j] + (prismatic ? " (mm)" : " (°)"),
                     "|weighted residual| / √6", {before, after}, false, true) +
           "</div>\n";
  }
  return out;
}

}  // namespace

std::string FitReportHtml(const FitReport& r, const FitReportOptions& o) {
  CheckOptions(r, o);
  const std::string title = Title(r, o);
  std::string h;
  h += "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>" +
       XmlEscape(title) + "</title>\n";
  h += "<style>\nbody{font-family:Helvetica,Arial,sans-serif;margin:24px;color:#222;max-width:"
       "1400px}\n"
       "table{border-collapse:collapse;margin:8px 0 16px}td,th{border:1px solid #ccc;padding:3px "
       "7px;font-size:13px;"
       "text-align:right}th{background:#f2f2f2}td:nth-child(2),td:first-child{text-align:left}\n"
       "tr.chosen{background:#e6f0ff;font-weight:bold}tr.total{background:#fafafa}\n"
       ".plots{display:flex;flex-wrap:wrap;gap:6px}.verdict{font-size:17px;font-weight:bold}\n"
       ".before{color:#e07b00}.after{color:#1f5fbf}\n</style>\n</head>\n<body>\n";
  h += "<h1>" + XmlEscape(title) + "</h1>\n";
  std::vector<std::string> summary = SummaryLines(r);
  h += "<p class=\"verdict\" data-verdict=\"" + std::string(VerdictText(r.verdict)) + "\">" +
       XmlEscape(summary[0]) + "</p>\n";
  for (size_t i = 1; i < summary.size(); ++i) h += "<p>" + XmlEscape(summary[i]) + "</p>\n";
  for (const std::string& s : r.indistinguishable)
    h += "<p class=\"indistinguishable\">Cannot be told apart: " + XmlEscape(s) + "</p>\n";

  h += "<h2>Residual before and after, per component</h2>\n";
  h += "<p><span class=\"before\">●</span> before (nominal model) &#160; <span "
       "class=\"after\">●</span> after (fitted model)</p>\n";
  h += HtmlTable(ErrorTable(r), "errors");

  h += r.effects_claimed ? "<h2>Effects added</h2>\n" : "<h2>Effects tried (tentative)</h2>\n";
  h += r.chosen.empty() ? "<p>None: no candidate earned its parameters.</p>\n"
                        : HtmlTable(ChosenTable(r), "chosen");
  h += "<h2>Outliers, confounding, trace</h2>\n" + HtmlTable(DiagnosticsTable(r), "diagnostics");
  if (!r.trace.empty()) {
    h += "<h2>Where the unexplained residual lives</h2>\n<p>" + XmlEscape(r.trace_summary) +
         "</p>\n<div class=\"plot trace\">" + TraceSvg(r) + "</div>\n";
  }

  // Plots.
  if (!r.trials.empty()) {
    h += "<h2>Measured vs predicted</h2>\n<div class=\"plots\">\n";
    for (int c = 0; c < 6; ++c) {
      Series before{"before", kBeforeColor, "before", {}}, after{"after", kAfterColor, "after", {}};
      for (const TrialResidual& t : r.trials) {
        before.points.emplace_back(t.measured[c], t.measured[c] - t.before[c]);
        after.points.emplace_back(t.measured[c], t.measured[c] - t.after[c]);
      }
      const std::string u = std::string(" (") + kUnit[c] + ")";
      h += "<div class=\"plot scatter\" data-component=\"" + std::string(kComponent[c]) + "\">" +
           XYPlotSvg(std::string(kComponent[c]) + ": predicted vs measured", "measured" + u,
                     "predicted" + u, {before, after}, true, false) +
           "</div>\n";
    }
    h += "</div>\n<h2>Residual vs trial</h2>\n<div class=\"plots\">\n";
    for (int c = 0; c < 6; ++c) {
      Series before{"before", kBeforeColor, "before", {}}, after{"after", kAfterColor, "after", {}};
      for (size_t i = 0; i < r.trials.size(); ++i) {
        before.points.emplace_back(static_cast<double>(i + 1), r.trials[i].before[c]);
        after.points.emplace_back(static_cast<double>(i + 1), r.trials[i].after[c]);
      }
      h += "<div class=\"plot residual\" data-component=\"" + std::string(kComponent[c]) + "\">" +
           XYPlotSvg(std::string(kComponent[c]) + ": residual", "trial (file order)",
                     std::string("measured - predicted (") + kUnit[c] + ")", {before, after}, false,
                     true) +
           "</div>\n";
    }
    h += "</div>\n";
    if (o.trials && o.model && !o.trials->empty()) {
      h += "<h2>Residual vs posture</h2>\n<p>Size of the weighted residual of each trial (noise "
           "multiples; "
           "|weighted residual| / √6) against each joint that varies across the trials.</p>\n"
           "<div class=\"plots\">\n" +
           PosturePlots(r, *o.trials, *o.model) + "</div>\n";
    }
  }

  // Ranked candidates per round.
  for (const FitRound& round : r.rounds) {
    h += "<h2>Round " + std::to_string(round.index) + ": candidates ranked by BIC</h2>\n";
    h += "<p>" + XmlEscape(RoundLine(round)) + "</p>\n";
    if (!round.indistinguishable.empty()) {
      h += "<p>Indistinguishable from the winner: " +
           XmlEscape(util::Join(round.indistinguishable, ", ")) + "</p>\n";
    }
    h += HtmlTable(CandidateTable(round), "candidates");
  }

  // Glyphs of the trials with the largest residual before.
  const std::vector<size_t> worst = WorstTrials(r, static_cast<size_t>(o.glyph_trials));
  if (!worst.empty()) {
    h += "<h2>Wrench glyphs of the trials with the largest residual before the fit</h2>\n"
         "<p>Force and moment as in the paper's Figure 1C (x, y, z projections in green, blue, "
         "red); measured, "
         "predicted by the nominal model (before) and by the fitted model (after), one scale for "
         "all.</p>\n";
    std::vector<Vector6d> all;
    for (size_t i : worst) {
      const TrialResidual& t = r.trials[i];
      all.push_back(t.measured);
      all.push_back(t.measured - t.before);
      all.push_back(t.measured - t.after);
    }
    GlyphOptions go;
    go.max_component_px = 60;
    const Eigen::Vector2d scales = GlyphScales(all, go);
    const auto [fb, mb] = plots::MakeWrenchBoxes(all, scales, go);
    const double pair_w = fb.width() + plots::kGlyphGap + mb.width(), gap = 30;
    for (size_t i : worst) {
      const TrialResidual& t = r.trials[i];
      const std::string label = "trial " + std::to_string(i + 1) +
                                (t.line > 0 ? " (line " + std::to_string(t.line) + ")" : "") +
                                ", " + t.muscle + " at activation " + N4(t.activation);
      plots::SvgWriter svg(3 * pair_w + 2 * gap + 20, std::max(fb.height(), mb.height()) + 50,
                           label);
      svg.Text(10, 16, label, 12, "start", {{"font-weight", "bold"}});
      const char* names[3] = {"measured", "predicted before", "predicted after"};
      const Vector6d w[3] = {t.measured, t.measured - t.before, t.measured - t.after};
      for (int k = 0; k < 3; ++k) {
        const double x = 10 + k * (pair_w + gap);
        svg.Open("g", {{"class", "trial-glyph"}, {"data-which", names[k]}});
        svg.Text(x, 34, names[k], 11, "start",
                 {{"fill", k == 1   ? kBeforeColor
                           : k == 2 ? kAfterColor
                                    : "#222222"}});
        plots::DrawWrenchGlyphs(svg, x, 40, w[k], fb, mb, scales, go);
        svg.Close();
      }
      h += "<div class=\"glyphs\">" + svg.Finish(false) + "</div>\n";
    }
  }
  h += "</body>\n</html>\n";
  return h;
}

std::string FitReportMarkdown(const FitReport& r, const FitReportOptions& o) {
  CheckOptions(r, o);
  std::string m = "# " + Title(r, o) + "\n\n";
  std::vector<std::string> summary = SummaryLines(r);
  m += "**" + summary[0] + "**\n\n";
  for (size_t i = 1; i < summary.size(); ++i) m += summary[i] + "\n";
  for (const std::string& s : r.indistinguishable) m += "\nCannot be told apart: " + s + "\n";
  m += "\n## Residual before and after, per component\n\n" + MarkdownTable(ErrorTable(r));
  m += r.effects_claimed ? "\n## Effects added\n\n" : "\n## Effects tried (tentative)\n\n";
  m += r.chosen.empty() ? "None: no candidate earned its parameters.\n"
                        : MarkdownTable(ChosenTable(r));
  m += "\n## Outliers, confounding, trace\n\n" + MarkdownTable(DiagnosticsTable(r));
  for (const FitReport::TraceItem& i : r.trace)
    m += "- " + i.variable + ": " + N4(100 * i.share) + " % of the residual\n";
  for (const FitRound& round : r.rounds) {
    m += "\n## Round " + std::to_string(round.index) + ": candidates ranked by BIC\n\n";
    m += RoundLine(round) + "\n\n";
    if (!round.indistinguishable.empty())
      m += "Indistinguishable from the winner: " + util::Join(round.indistinguishable, ", ") +
           "\n\n";
    m += MarkdownTable(CandidateTable(round));
  }
  const std::vector<size_t> worst = WorstTrials(r, static_cast<size_t>(o.markdown_trials));
  if (!worst.empty()) {
    m +=
        "\n## Trials with the largest residual before the fit\n\n"
        "Wrenches [fx fy fz] N, [mx my mz] N·m; residual size = |weighted residual| / sqrt(6).\n\n";
    Table t;
    t.header = {"trial",           "line",        "muscle",
                "activation",      "measured",    "predicted before",
                "predicted after", "size before", "size after"};
    auto vec = [](const Vector6d& w) {
      std::vector<std::string> items;
      for (int i = 0; i < 6; ++i) items.push_back(util::FormatNumber(w[i], 3));
      return "[" + util::Join(items, " ") + "]";
    };
    for (size_t i : worst) {
      const TrialResidual& tr = r.trials[i];
      t.rows.push_back({std::to_string(i + 1), std::to_string(tr.line), tr.muscle,
                        N4(tr.activation), vec(tr.measured), vec(tr.measured - tr.before),
                        vec(tr.measured - tr.after), N4(tr.normalized_before),
                        N4(tr.normalized_after)});
      t.row_class.push_back("");
    }
    m += MarkdownTable(t);
    m += "\nPlots (measured vs predicted, residual vs trial) and wrench glyphs are in the HTML "
         "report.\n";
  }
  return m;
}

void WriteFitReportHtml(const FitReport& report, const std::string& path,
                        const FitReportOptions& options) {
  util::WriteFileAtomically(path, FitReportHtml(report, options));
}

void WriteFitReportMarkdown(const FitReport& report, const std::string& path,
                            const FitReportOptions& options) {
  util::WriteFileAtomically(path, FitReportMarkdown(report, options));
}

}  // namespace isowrench
