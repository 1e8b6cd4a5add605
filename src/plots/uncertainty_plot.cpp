// Pictures of an uncertainty study: wrench glyphs with the 95 % ranges of components, size and
// direction drawn on them, and the HTML report (distributions, Sobol indices).

#include <algorithm>
#include <cmath>

#include "isowrench/error.hpp"
#include "isowrench/posture.hpp"
#include "isowrench/uncertainty.hpp"
#include "plots/svg_writer.hpp"
#include "plots/wrench_glyph.hpp"
#include "util/text.hpp"

namespace isowrench {
namespace {

constexpr double kUncertaintyPi = 3.14159265358979323846;
const char* const kUncertaintyAxis[3] = {"x", "y", "z"};

// The world-axes mean reading of a posture, and the 2.5 / 97.5 % corners of each component.
Vector6d MeanWorld(const PostureUncertainty& p) {
  Vector6d w;
  for (int i = 0; i < 6; ++i) w[i] = p.statistics[static_cast<size_t>(6 + i)].mean;
  return w;
}

std::string Points(double ox, double oy, const std::vector<Eigen::Vector2d>& points) {
  std::string out;
  for (const Eigen::Vector2d& p : points)
    out += (out.empty() ? "" : " ") + plots::Num(ox + p.x()) + "," + plots::Num(oy + p.y());
  return out;
}

// The uncertainty drawn over one glyph whose origin is (ox, oy): component bands, the size band
// and (force only) the direction wedge.
void DrawUncertaintyOverlay(plots::SvgWriter& svg, double ox, double oy,
                            const PostureUncertainty& p, bool force, double px_per_unit,
                            const GlyphOptions& options) {
  const int first = force ? 6 : 9;
  svg.Open("g", {{"class", std::string("uncertainty ") + (force ? "force" : "moment")}});
  for (int axis = 0; axis < 3; ++axis) {
    const QuantityStatistics& s = p.statistics[static_cast<size_t>(first + axis)];
    if (s.count == 0) continue;
    Eigen::Vector3d lo = Eigen::Vector3d::Zero(), hi = Eigen::Vector3d::Zero();
    lo[axis] = s.percentiles[0];
    hi[axis] = s.percentiles[3];
    const Eigen::Vector2d a = ObliqueProjection(lo, px_per_unit, options);
    const Eigen::Vector2d b = ObliqueProjection(hi, px_per_unit, options);
    svg.Line(ox + a.x(), oy + a.y(), ox + b.x(), oy + b.y(), kAxisColors[axis], 9.0,
             {{"class", "component-range"},
              {"data-axis", kUncertaintyAxis[axis]},
              {"data-p2.5", plots::Exact(s.percentiles[0])},
              {"data-p97.5", plots::Exact(s.percentiles[3])},
              {"stroke-opacity", "0.3"},
              {"stroke-linecap", "butt"}});
  }
  const Eigen::Vector3d mean(p.statistics[static_cast<size_t>(first)].mean,
                             p.statistics[static_cast<size_t>(first + 1)].mean,
                             p.statistics[static_cast<size_t>(first + 2)].mean);
  const QuantityStatistics& size = p.statistics[force ? 12 : 13];
  if (mean.norm() > 0 && size.count > 0) {
    const Eigen::Vector3d u = mean / mean.norm();
    const Eigen::Vector2d a = ObliqueProjection(u * size.percentiles[0], px_per_unit, options);
    const Eigen::Vector2d b = ObliqueProjection(u * size.percentiles[3], px_per_unit, options);
    svg.Line(ox + a.x(), oy + a.y(), ox + b.x(), oy + b.y(), "#000000", 7.0,
             {{"class", "size-range"},
              {"data-p2.5", plots::Exact(size.percentiles[0])},
              {"data-p97.5", plots::Exact(size.percentiles[3])},
              {"stroke-opacity", "0.25"},
              {"stroke-linecap", "butt"}});
    const QuantityStatistics& angle = p.statistics[14];
    if (force && angle.count > 0) {
      // Wedge of half-angle theta_95 around the drawn force, in the picture plane.
      const Eigen::Vector2d tip = ObliqueProjection(u * size.percentiles[3], px_per_unit, options);
      const double theta = std::min(angle.percentiles[2], kUncertaintyPi);
      std::vector<Eigen::Vector2d> wedge = {Eigen::Vector2d::Zero()};
      for (int k = 0; k <= 16; ++k) {
        const double t = -theta + 2 * theta * k / 16.0;
        wedge.push_back(Eigen::Rotation2Dd(t) * tip);
      }
      svg.Element("polygon", {{"class", "direction-range"},
                              {"data-angle-p95-rad", plots::Exact(angle.percentiles[2])},
                              {"points", Points(ox, oy, wedge)},
                              {"fill", "#7f7f7f"},
                              {"fill-opacity", "0.18"},
                              {"stroke", "#7f7f7f"},
                              {"stroke-width", "0.6"}});
    }
  }
  svg.Close();
}

// The glyphs of every posture, one row each, into `svg` from (x, y); returns the height used.
double DrawPostureGlyphs(plots::SvgWriter& svg, double x, double y, const UncertaintyResult& r,
                         const Model& model, const Eigen::Vector2d& scales,
                         const GlyphOptions& options, size_t index, double* width = nullptr) {
  const PostureUncertainty& p = r.postures[index];
  std::vector<Eigen::Vector3d> forces, moments;
  for (int k : {0, 3}) {
    Eigen::Vector3d f, m;
    for (int i = 0; i < 3; ++i) {
      f[i] = p.statistics[static_cast<size_t>(6 + i)].percentiles[static_cast<size_t>(k)];
      m[i] = p.statistics[static_cast<size_t>(9 + i)].percentiles[static_cast<size_t>(k)];
    }
    forces.push_back(f);
    moments.push_back(m);
  }
  const Vector6d mean = MeanWorld(p);
  forces.push_back(mean.head<3>() / std::max(mean.head<3>().norm(), 1e-300) *
                   p.statistics[12].percentiles[3]);
  moments.push_back(mean.tail<3>() / std::max(mean.tail<3>().norm(), 1e-300) *
                    p.statistics[13].percentiles[3]);
  const plots::GlyphBox fbox = plots::MakeGlyphBox(forces, scales[0], options);
  const plots::GlyphBox mbox = plots::MakeGlyphBox(moments, scales[1], options);
  svg.Text(x, y + 12, "posture " + FormatPosture(model, p.posture), 11, "start",
           {{"class", "posture-label"}});
  const double gy = y + 18;
  if (width != nullptr)
    *width = std::max(*width, x + fbox.width() + plots::kGlyphGap + mbox.width() + 10);
  plots::DrawWrenchGlyphs(svg, x, gy, mean, fbox, mbox, scales, options);
  DrawUncertaintyOverlay(svg, x + fbox.left, gy + fbox.up, p, true, scales[0], options);
  DrawUncertaintyOverlay(svg, x + fbox.width() + plots::kGlyphGap + mbox.left, gy + mbox.up, p,
                         false, scales[1], options);
  return 18 + std::max(fbox.height(), mbox.height()) + 10;
}

// 1, 2 or 5 x 10^k, the largest not above x (x > 0).
double NiceBelow(double x) {
  const double decade = std::pow(10.0, std::floor(std::log10(x)));
  for (double m : {5.0, 2.0, 1.0})
    if (m * decade <= x) return m * decade;
  return decade;
}

// Scale bars chosen for the study (a nice value about half the largest 97.5 % component), so
// that the ranges are large enough to read, whatever the force.
GlyphOptions StudyGlyphOptions(const UncertaintyResult& r) {
  GlyphOptions options;
  double force = 0, moment = 0;
  for (const PostureUncertainty& p : r.postures) {
    if (p.statistics[6].count == 0) continue;
    for (int i = 0; i < 3; ++i) {
      for (int k : {0, 3}) {
        force = std::max(
            force,
            std::abs(p.statistics[static_cast<size_t>(6 + i)].percentiles[static_cast<size_t>(k)]));
        moment = std::max(
            moment,
            std::abs(p.statistics[static_cast<size_t>(9 + i)].percentiles[static_cast<size_t>(k)]));
      }
    }
  }
  if (force > 0 && std::isfinite(force)) options.force_scale_bar = NiceBelow(force / 2);
  if (moment > 0 && std::isfinite(moment)) options.moment_scale_bar = NiceBelow(moment / 2);
  return options;
}

Eigen::Vector2d StudyScales(const UncertaintyResult& r, const GlyphOptions& options) {
  std::vector<Vector6d> extremes;
  for (const PostureUncertainty& p : r.postures) {
    if (p.statistics[6].count == 0) continue;
    for (int k : {0, 3}) {
      Vector6d w;
      for (int i = 0; i < 6; ++i)
        w[i] = p.statistics[static_cast<size_t>(6 + i)].percentiles[static_cast<size_t>(k)];
      extremes.push_back(w);
    }
  }
  if (extremes.empty()) extremes.push_back(Vector6d::Zero());
  return GlyphScales(extremes, options);
}

std::string GlyphDocument(const UncertaintyResult& r, const Model& model, bool declaration) {
  const GlyphOptions options = StudyGlyphOptions(r);
  const Eigen::Vector2d scales = StudyScales(r, options);
  const std::string title = "Wrench uncertainty: " + r.model + ", muscle " + r.muscle + " (" +
                            std::to_string(r.samples) + " samples, 95 % ranges)";
  // Size: measure with a throw-away writer first (the boxes depend on the data).
  double height = 40, width = 8.5 * static_cast<double>(title.size()) + 20;
  for (size_t i = 0; i < r.postures.size(); ++i) {
    if (r.postures[i].statistics[6].count == 0) {
      height += 24;
      continue;
    }
    plots::SvgWriter probe(10, 10, "");
    height += DrawPostureGlyphs(probe, 10, 0, r, model, scales, options, i, &width);
  }
  plots::SvgWriter svg(width, height + 20, title);
  svg.Text(10, 18, title, 13, "start", {{"class", "title"}, {"font-weight", "bold"}});
  svg.Text(10, 32,
           "world axes; pale bands: 2.5-97.5 % of each component, grey band: of |F| and |M|, "
           "wedge: 95 % of the force direction",
           9, "start", {{"class", "legend"}, {"fill", "#555555"}});
  double y = 40;
  for (size_t i = 0; i < r.postures.size(); ++i) {
    if (r.postures[i].statistics[6].count == 0) {
      svg.Text(10, y + 12,
               "posture " + FormatPosture(model, r.postures[i].posture) +
                   ": no sample has a wrench (no equilibrium)",
               11);
      y += 24;
      continue;
    }
    y += DrawPostureGlyphs(svg, 10, y, r, model, scales, options, i);
  }
  return svg.Finish(declaration);
}

// A bar chart of a histogram (kUncertaintyHistogramBins bins) with its axis in `unit`.
std::string HistogramSvg(const QuantityStatistics& s, const std::string& label,
                         const std::string& unit, double unit_scale) {
  const double w = 220, h = 120, left = 8, bottom = 28, top = 16;
  plots::SvgWriter svg(w, h, label);
  svg.Text(left, 11, label + " (" + unit + ")", 10, "start", {{"class", "label"}});
  long most = 1;
  for (long c : s.histogram) most = std::max(most, c);
  const double bw = (w - 2 * left) / kUncertaintyHistogramBins;
  for (size_t k = 0; k < s.histogram.size(); ++k) {
    const double bar =
        (h - bottom - top) * static_cast<double>(s.histogram[k]) / static_cast<double>(most);
    svg.Element("rect", {{"x", plots::Num(left + bw * static_cast<double>(k))},
                         {"y", plots::Num(h - bottom - bar)},
                         {"width", plots::Num(bw * 0.9)},
                         {"height", plots::Num(bar)},
                         {"fill", "#4a78b5"},
                         {"data-count", std::to_string(s.histogram[k])}});
  }
  svg.Line(left, h - bottom, w - left, h - bottom, "#888888", 0.8);
  const double span = s.histogram_upper - s.histogram_lower;
  for (int k : {0, 3}) {
    const double v = s.percentiles[static_cast<size_t>(k)];
    if (span <= 0) break;
    const double px = left + (w - 2 * left) * (v - s.histogram_lower) / span;
    svg.Line(px, top, px, h - bottom, "#d7191c", 0.8, {{"stroke-dasharray", "3,2"}});
  }
  svg.Text(left, h - bottom + 12, util::FormatNumber(s.histogram_lower * unit_scale, 4), 9);
  svg.Text(w - left, h - bottom + 12, util::FormatNumber(s.histogram_upper * unit_scale, 4), 9,
           "end");
  svg.Text(w / 2, h - 4, "dashed: 2.5 and 97.5 %", 8, "middle", {{"fill", "#777777"}});
  return svg.Finish(false);
}

std::string Cell(double v) { return util::FormatNumber(v, 4); }

}  // namespace

std::string UncertaintyGlyphSvg(const UncertaintyResult& result, const Model& model) {
  if (result.postures.empty()) throw Error("uncertainty glyphs: the result has no posture");
  return GlyphDocument(result, model, true);
}

std::string UncertaintyReportHtml(const UncertaintyResult& r, const Model& model,
                                  const UncertaintySpec& spec) {
  using plots::XmlEscape;
  std::string h = "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>";
  const std::string title = "isowrench uncertainty: " + r.model + ", muscle " + r.muscle;
  h += XmlEscape(title) + "</title>\n";
  h += "<style>\nbody{font-family:Helvetica,Arial,sans-serif;margin:24px;color:#222;max-width:"
       "1100px}\ntable{border-collapse:collapse;margin:8px 0 16px}\ntd,th{border:1px solid "
       "#ccc;padding:3px 8px;text-align:right;font-size:13px}\nth{background:#f0f0f0}\n"
       "td:first-child,th:first-child{text-align:left}\n.plots{display:flex;flex-wrap:wrap;gap:"
       "8px}\n.bar{display:inline-block;height:10px;background:#4a78b5}\n.note{color:#555}\n"
       "</style>\n</head>\n<body>\n";
  h += "<h1>" + XmlEscape(title) + "</h1>\n";
  h += "<p>" + std::to_string(r.samples) + " samples (seed " + std::to_string(r.seed) + "), " +
       std::to_string(r.evaluations) + " evaluations, " + util::FormatNumber(r.seconds, 3) +
       " s. Percentiles: " + XmlEscape(r.percentile_method) + ".</p>\n";
  h += "<h2>Uncertain inputs</h2>\n<ul>\n";
  for (const UncertainInput& in : spec.inputs) {
    std::string params;
    if (in.distribution == InputDistribution::kUniform ||
        in.distribution == InputDistribution::kLogUniform) {
      params = "[" + util::FormatNumber(in.lower) + ", " + util::FormatNumber(in.upper) + "]";
    } else {
      std::vector<std::string> sd;
      for (double s : in.sd) sd.push_back(util::FormatNumber(s));
      params = "sd " + util::Join(sd, ", ");
    }
    h += "<li><code>" + XmlEscape(in.name) + "</code> " + DistributionName(in.distribution) + " " +
         XmlEscape(params) + "</li>\n";
  }
  if (spec.has_fit) {
    h += "<li>fit <code>" + XmlEscape(spec.fit.source) +
         "</code>: " + XmlEscape(util::Join(spec.fit.names, ", ")) +
         " (multivariate normal)</li>\n";
  }
  h += "</ul>\n";
  for (const std::string& note : r.notes) h += "<p class=\"note\">" + XmlEscape(note) + "</p>\n";
  h += "<h2>Wrench glyphs</h2>\n<div class=\"glyphs\">" + GlyphDocument(r, model, false) +
       "</div>\n";
  for (const PostureUncertainty& p : r.postures) {
    h += "<h2>Posture " + XmlEscape(FormatPosture(model, p.posture)) + "</h2>\n";
    const double n = static_cast<double>(std::max<long>(p.samples, 1));
    h += "<p>" + std::to_string(p.samples) + " samples: " + std::to_string(p.valid) + " valid, " +
         std::to_string(p.no_equilibrium) + " without equilibrium (" +
         util::FormatNumber(100 * p.no_equilibrium / n, 3) + " %), " + std::to_string(p.invalid) +
         " invalid, " + std::to_string(p.small_motion_failed) + " outside the small-motion rule (" +
         util::FormatNumber(100 * p.small_motion_failed / n, 3) +
         " %). Samples without a wrench are left out of every statistic.</p>\n";
    if (p.statistics[0].count == 0) continue;
    h += "<table>\n<tr><th>quantity</th><th>unit</th><th>nominal</th><th>mean</th><th>sd</th>"
         "<th>2.5 %</th><th>50 %</th><th>97.5 %</th></tr>\n";
    for (int q = 0; q < kUncertaintyQuantities; ++q) {
      const QuantityStatistics& s = p.statistics[static_cast<size_t>(q)];
      const bool angle = q == 14;
      const double k = angle ? 180.0 / kUncertaintyPi : 1.0;
      h += "<tr><td>" + std::string(UncertaintyQuantityName(q)) + "</td><td>" +
           (angle ? "deg" : UncertaintyQuantityUnit(q)) + "</td><td>" +
           (p.nominal_defined() ? Cell(p.nominal[static_cast<size_t>(q)] * k) : "none") +
           "</td><td>" + Cell(s.mean * k) + "</td><td>" + Cell(s.sd * k) + "</td><td>" +
           Cell(s.percentiles[0] * k) + "</td><td>" + Cell(s.percentiles[1] * k) + "</td><td>" +
           Cell(s.percentiles[3] * k) + "</td></tr>\n";
    }
    h += "</table>\n<h3>Distributions (transducer axes)</h3>\n<div class=\"plots\">\n";
    for (int q : {0, 1, 2, 3, 4, 5, 12, 14}) {
      const QuantityStatistics& s = p.statistics[static_cast<size_t>(q)];
      if (s.count == 0 || s.sd == 0) continue;
      const bool angle = q == 14;
      h += "<div class=\"plot histogram\" data-quantity=\"" +
           std::string(UncertaintyQuantityName(q)) + "\">" +
           HistogramSvg(s, UncertaintyQuantityName(q), angle ? "deg" : UncertaintyQuantityUnit(q),
                        angle ? 180.0 / kUncertaintyPi : 1.0) +
           "</div>\n";
    }
    h += "</div>\n";
    if (r.sobol && !p.sobol.empty()) {
      h += "<h3>Sobol indices</h3>\n<p>First-order S_i (Saltelli 2010) and total ST_i (Jansen "
           "1999): the share of each component's variance an input explains alone / with its "
           "interactions, over " +
           std::to_string(p.sobol_rows) + " rows. Reduce the input with the largest share.</p>\n";
      h += "<table>\n<tr><th>input</th>";
      const int qs[8] = {0, 1, 2, 3, 4, 5, 12, 14};
      for (int q : qs) h += "<th>" + std::string(UncertaintyQuantityName(q)) + "</th>";
      h += "</tr>\n";
      for (size_t g = 0; g < r.groups.size(); ++g) {
        h += "<tr><td>" + XmlEscape(r.groups[g]) + "</td>";
        for (int q : qs) {
          const SobolIndex& idx = p.sobol[g][static_cast<size_t>(q)];
          if (p.statistics[static_cast<size_t>(q)].sd == 0) {
            h += "<td>-</td>";
            continue;
          }
          const double width = 60.0 * std::clamp(idx.first, 0.0, 1.0);
          h += "<td title=\"total " + Cell(idx.total) + "\">" + Cell(idx.first) +
               " <span class=\"bar\" style=\"width:" + plots::Num(width, 1) + "px\"></span></td>";
        }
        h += "</tr>\n";
      }
      h += "</table>\n";
    }
  }
  h += "</body>\n</html>\n";
  return h;
}

}  // namespace isowrench
