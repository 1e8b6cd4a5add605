// Wrench glyphs as in the paper's Figure 1C: a 3-D vector in oblique projection with its
// projections on x, y and z in green, blue and red, a scale bar and axis labels.

#include "plots/wrench_glyph.hpp"

#include <algorithm>
#include <cmath>

#include "isowrench/error.hpp"
#include "util/text.hpp"

namespace isowrench::plots {
namespace {

constexpr double kPi = 3.14159265358979323846;
// Axes are drawn a little longer than the longest projection so its end stays visible.
constexpr double kAxisOvershoot = 1.15;
// Shortest axis drawn (px), so that a tiny vector still shows a readable frame.
constexpr double kMinAxisPx = 28.0;
// Room for the axis labels beyond the axis ends (px).
constexpr double kLabelPad = 12.0;
// Half the width of the numbers line "(-0.01234, -0.01234, -0.01234) N·m" at 9 px (~5 px/char).
constexpr double kMinHalfWidth = 88.0;
const char* kAxisNames[3] = {"x", "y", "z"};

Eigen::Vector2d AxisDirection(int axis, const GlyphOptions& options) {
  Eigen::Vector3d e = Eigen::Vector3d::Zero();
  e[axis] = 1.0;
  return ObliqueProjection(e, 1.0, options);
}

}  // namespace

std::string Short(double value) { return util::FormatNumber(value, 4); }

GlyphBox MakeGlyphBox(const std::vector<Eigen::Vector3d>& values, double px_per_unit,
                      const GlyphOptions& options) {
  double max_component_px = 0;
  for (const Eigen::Vector3d& v : values) {
    max_component_px = std::max(max_component_px, v.cwiseAbs().maxCoeff() * px_per_unit);
  }
  GlyphBox box;
  box.axis_px = std::max(kMinAxisPx, kAxisOvershoot * max_component_px);
  // The box holds both ends of every axis and the tip of every vector drawn with it.
  for (int axis = 0; axis < 3; ++axis) {
    Eigen::Vector2d d = AxisDirection(axis, options) * box.axis_px;
    box.right = std::max(box.right, std::abs(d.x()));
    box.down = std::max(box.down, std::abs(d.y()));
  }
  box.left = box.right;
  box.up = box.down;
  for (const Eigen::Vector3d& v : values) {
    const Eigen::Vector2d tip = ObliqueProjection(v, px_per_unit, options);
    box.right = std::max(box.right, tip.x());
    box.left = std::max(box.left, -tip.x());
    box.down = std::max(box.down, tip.y());
    box.up = std::max(box.up, -tip.y());
  }
  // Wide enough for the numbers line under the glyph.
  box.right = std::max(box.right + kLabelPad, kMinHalfWidth);
  box.left = std::max(box.left + kLabelPad, kMinHalfWidth);
  box.up += kLabelPad;
  box.down += kLabelPad;
  return box;
}

std::pair<GlyphBox, GlyphBox> MakeWrenchBoxes(const std::vector<Vector6d>& wrenches,
                                              const Eigen::Vector2d& scales,
                                              const GlyphOptions& options) {
  std::vector<Eigen::Vector3d> forces, moments;
  for (const Vector6d& w : wrenches) {
    forces.push_back(w.head<3>());
    moments.push_back(w.tail<3>());
  }
  return {MakeGlyphBox(forces, scales[0], options), MakeGlyphBox(moments, scales[1], options)};
}

void DrawGlyph(SvgWriter& svg, double x, double y, const GlyphBox& box, const GlyphSpec& spec,
               const GlyphOptions& options) {
  const double ox = x + box.left;
  const double oy = y + box.up;
  svg.Open("g", {{"class", "glyph " + spec.quantity},
                 {"data-quantity", spec.quantity},
                 {"data-unit", spec.unit},
                 {"data-px-per-unit", Exact(spec.px_per_unit)},
                 {"data-origin-x", Num(ox)},
                 {"data-origin-y", Num(oy)}});
  // Axes: thin grey lines through the origin, labelled at their positive ends.
  for (int axis = 0; axis < 3; ++axis) {
    Eigen::Vector2d d = AxisDirection(axis, options) * box.axis_px;
    svg.Line(ox - d.x(), oy - d.y(), ox + d.x(), oy + d.y(), "#b0b0b0", 0.8,
             {{"class", "axis"}, {"data-axis", kAxisNames[axis]}});
    Eigen::Vector2d label = d * (1.0 + 7.0 / box.axis_px);
    svg.Text(ox + label.x(), oy + label.y() + 4, kAxisNames[axis], 11, "middle",
             {{"class", "axis-label"}, {"fill", kAxisColors[axis]}, {"font-style", "italic"}});
  }
  // Parallelepiped guides from the x projection to the tip, so the 3-D vector reads as a sum.
  Eigen::Vector2d p[3];
  for (int axis = 0; axis < 3; ++axis) {
    Eigen::Vector3d component = Eigen::Vector3d::Zero();
    component[axis] = spec.value[axis];
    p[axis] = ObliqueProjection(component, spec.px_per_unit, options);
  }
  const Eigen::Vector2d tip = p[0] + p[1] + p[2];
  svg.Element("polyline",
              {{"class", "guide"},
               {"points", Num(ox + p[0].x()) + "," + Num(oy + p[0].y()) + " " +
                              Num(ox + p[0].x() + p[1].x()) + "," + Num(oy + p[0].y() + p[1].y()) +
                              " " + Num(ox + tip.x()) + "," + Num(oy + tip.y())},
               {"fill", "none"},
               {"stroke", "#909090"},
               {"stroke-width", "0.7"},
               {"stroke-dasharray", "2,2"}});
  // Projections on x, y, z in green, blue, red.
  for (int axis = 0; axis < 3; ++axis) {
    svg.Line(ox, oy, ox + p[axis].x(), oy + p[axis].y(), kAxisColors[axis], 3.0,
             {{"class", "component"},
              {"data-axis", kAxisNames[axis]},
              {"data-value", Exact(spec.value[axis])},
              {"stroke-linecap", "butt"}});
  }
  // The vector itself, black, with an arrowhead.
  svg.Line(ox, oy, ox + tip.x(), oy + tip.y(), "black", 1.6,
           {{"class", "vector"},
            {"data-x", Exact(spec.value.x())},
            {"data-y", Exact(spec.value.y())},
            {"data-z", Exact(spec.value.z())}});
  const double length = tip.norm();
  if (length > 1.0) {
    const Eigen::Vector2d u = tip / length;
    const Eigen::Vector2d n(-u.y(), u.x());
    const double head = std::min(7.0, 0.5 * length);
    Eigen::Vector2d a = tip - head * u + 0.45 * head * n;
    Eigen::Vector2d b = tip - head * u - 0.45 * head * n;
    svg.Element("polygon", {{"class", "arrowhead"},
                            {"points", Num(ox + tip.x()) + "," + Num(oy + tip.y()) + " " +
                                           Num(ox + a.x()) + "," + Num(oy + a.y()) + " " +
                                           Num(ox + b.x()) + "," + Num(oy + b.y())},
                            {"fill", "black"}});
  }
  // Scale bar and numbers under the box.
  const double bar_y = y + box.up + box.down + 10;
  const double bar_px = spec.scale_bar * spec.px_per_unit;
  svg.Line(
      x + 4, bar_y, x + 4 + bar_px, bar_y, "black", 2.0,
      {{"class", "scale-bar"}, {"data-value", Exact(spec.scale_bar)}, {"data-unit", spec.unit}});
  svg.Line(x + 4, bar_y - 3, x + 4, bar_y + 3, "black", 1.0);
  svg.Line(x + 4 + bar_px, bar_y - 3, x + 4 + bar_px, bar_y + 3, "black", 1.0);
  svg.Text(x + 10 + bar_px, bar_y + 4, Short(spec.scale_bar) + " " + spec.unit, 10, "start",
           {{"class", "scale-label"}});
  svg.Text(x + 4, bar_y + 20,
           "(" + Short(spec.value.x()) + ", " + Short(spec.value.y()) + ", " +
               Short(spec.value.z()) + ") " + spec.unit,
           9, "start", {{"class", "numbers"}});
  svg.Text(x + 2, y + 10, spec.quantity, 10, "start",
           {{"class", "glyph-label"}, {"fill", "#555555"}});
  svg.Close();
}

double DrawWrenchGlyphs(SvgWriter& svg, double x, double y, const Vector6d& wrench,
                        const GlyphBox& force_box, const GlyphBox& moment_box,
                        const Eigen::Vector2d& scales, const GlyphOptions& options) {
  GlyphSpec force{wrench.head<3>(), "force", "F", "N", scales[0], options.force_scale_bar};
  GlyphSpec moment{wrench.tail<3>(), "moment", "M", "N·m", scales[1], options.moment_scale_bar};
  DrawGlyph(svg, x, y, force_box, force, options);
  DrawGlyph(svg, x + force_box.width() + kGlyphGap, y, moment_box, moment, options);
  return force_box.width() + kGlyphGap + moment_box.width();
}

}  // namespace isowrench::plots

namespace isowrench {

Eigen::Vector2d ObliqueProjection(const Eigen::Vector3d& v, double px_per_unit,
                                  const GlyphOptions& options) {
  const double a = options.oblique_angle_deg * plots::kPi / 180.0;
  const double r = options.oblique_ratio;
  return px_per_unit *
         Eigen::Vector2d(v.x() + r * v.z() * std::cos(a), -v.y() - r * v.z() * std::sin(a));
}

Eigen::Vector2d GlyphScales(const std::vector<Vector6d>& wrenches, const GlyphOptions& options) {
  if (!(options.force_scale_bar > 0) || !(options.moment_scale_bar > 0) ||
      !(options.scale_bar_px > 0) || !(options.max_component_px > 0) ||
      !(options.oblique_ratio > 0) || !std::isfinite(options.oblique_angle_deg)) {
    throw Error(
        "glyph options: scale bars, scale_bar_px, max_component_px and oblique_ratio must be > 0");
  }
  double max_force = 0, max_moment = 0;
  for (const Vector6d& w : wrenches) {
    if (!w.allFinite()) throw Error("glyph: a wrench to draw is not finite");
    max_force = std::max(max_force, w.head<3>().cwiseAbs().maxCoeff());
    max_moment = std::max(max_moment, w.tail<3>().cwiseAbs().maxCoeff());
  }
  double force = options.scale_bar_px / options.force_scale_bar;
  double moment = options.scale_bar_px / options.moment_scale_bar;
  if (max_force * force > options.max_component_px) force = options.max_component_px / max_force;
  if (max_moment * moment > options.max_component_px)
    moment = options.max_component_px / max_moment;
  return {force, moment};
}

std::string WrenchGlyphSvg(const Vector6d& wrench, const std::string& title,
                           const GlyphOptions& options, const Eigen::Vector2d& scales_in) {
  Eigen::Vector2d scales = scales_in;
  if (!(scales[0] > 0) || !(scales[1] > 0)) scales = GlyphScales({wrench}, options);
  plots::GlyphBox force_box = plots::MakeGlyphBox({wrench.head<3>()}, scales[0], options);
  plots::GlyphBox moment_box = plots::MakeGlyphBox({wrench.tail<3>()}, scales[1], options);
  const double margin = 10, title_h = 22;
  const double width = 2 * margin + force_box.width() + plots::kGlyphGap + moment_box.width();
  const double height = 2 * margin + title_h + std::max(force_box.height(), moment_box.height());
  plots::SvgWriter svg(width, height, title);
  svg.Text(margin, margin + 13, title, 13, "start", {{"class", "title"}, {"font-weight", "bold"}});
  plots::DrawWrenchGlyphs(svg, margin, margin + title_h, wrench, force_box, moment_box, scales,
                          options);
  return svg.Finish();
}

}  // namespace isowrench
