#pragma once
// Private: drawing one vector glyph (the paper's Figure 1C) into an SvgWriter.

#include <Eigen/Core>
#include <string>
#include <utility>
#include <vector>

#include "isowrench/plots.hpp"
#include "plots/svg_writer.hpp"

namespace isowrench::plots {

/// Extents of a glyph around its origin (px), shared by every glyph of one quantity in a figure
/// so that panels line up.
struct GlyphBox {
  double axis_px = 0;                            ///< half-length of the drawn axes
  double left = 0, right = 0, up = 0, down = 0;  ///< box around the origin (all >= 0)
  double width() const { return left + right; }
  double height() const { return up + down + kFooter; }
  /// Space under the box for the scale bar and the numbers.
  static constexpr double kFooter = 34.0;
};

/// Smallest box holding the axes and the vector tips of all `values` drawn at `px_per_unit`.
GlyphBox MakeGlyphBox(const std::vector<Eigen::Vector3d>& values, double px_per_unit,
                      const GlyphOptions& options);

/// Force and moment boxes shared by all `wrenches` of one figure drawn at `scales`.
std::pair<GlyphBox, GlyphBox> MakeWrenchBoxes(const std::vector<Vector6d>& wrenches,
                                              const Eigen::Vector2d& scales,
                                              const GlyphOptions& options);

/// What a glyph draws: one 3-vector.
struct GlyphSpec {
  Eigen::Vector3d value = Eigen::Vector3d::Zero();
  std::string quantity;      ///< "force" or "moment" (the CSS class)
  std::string symbol;        ///< "F" or "M"
  std::string unit;          ///< "N" or "N·m"
  double px_per_unit = 1.0;  ///< drawing scale
  double scale_bar = 0.3;    ///< value the scale bar stands for (unit)
};

/// Draw the glyph with its box's top-left corner at (x, y).
void DrawGlyph(SvgWriter& svg, double x, double y, const GlyphBox& box, const GlyphSpec& spec,
               const GlyphOptions& options);

/// Draw force and moment glyphs of `wrench` side by side at (x, y); returns the width used.
double DrawWrenchGlyphs(SvgWriter& svg, double x, double y, const Vector6d& wrench,
                        const GlyphBox& force_box, const GlyphBox& moment_box,
                        const Eigen::Vector2d& scales, const GlyphOptions& options);

/// Gap (px) between the force and the moment glyph.
inline constexpr double kGlyphGap = 16.0;

/// Short number for labels: 4 significant digits.
std::string Short(double value);

}  // namespace isowrench::plots
