#pragma once
/// @file
/// Pictures as files that open anywhere: the paper's wrench figures (Figure 1C glyphs in the
/// grids of Figures 2-4), a two-view stick figure of a limb, and fit reports (HTML, markdown).
///
/// All SVG is self-contained (no external references, no scripts, no fonts to fetch) and valid
/// XML. Every output file is written atomically: to a temporary name, then renamed, so an error
/// never leaves a half-written file behind (src/util/atomic_file.hpp).
///
/// Wrench glyph (the paper's Figure 1C): the force [fx fy fz] (N) and the moment [mx my mz]
/// (N·m) are drawn as two separate glyphs. Each shows the 3-D vector (black arrow) in an oblique
/// projection and its projections on the x, y and z axes in green, blue and red, with a scale
/// bar (0.3 N for force, 0.01 N·m for moment) and axis labels.
///
/// Oblique projection (screen coordinates in px, SVG axes: x to the right, y downward):
///   screen(v) = px_per_unit * (vx * (1, 0) + vy * (0, -1) + r * vz * (cos a, -sin a))
/// with a = GlyphOptions::oblique_angle_deg and r = GlyphOptions::oblique_ratio. With the
/// defaults (a = 225°, r = 1, a cavalier projection) world x points right, world y up and world
/// z toward the viewer (down-left), and every axis keeps its true length: the drawn length of
/// each coloured projection is exactly |component| * px_per_unit.

#include <Eigen/Core>
#include <functional>
#include <string>
#include <vector>

#include "isowrench/identification.hpp"
#include "isowrench/model.hpp"
#include "isowrench/paper.hpp"
#include "isowrench/wrap.hpp"

namespace isowrench {

/// Colours of the x, y and z projections, as in the paper's Figure 1C: green, blue, red.
inline constexpr const char* kAxisColors[3] = {"#1a9641", "#2458c9", "#d7191c"};

/// How wrench glyphs are scaled and projected.
struct GlyphOptions {
  /// Force scale bar (N); the paper uses 0.3 N in every figure. > 0.
  double force_scale_bar = 0.3;
  /// Moment scale bar (N·m); the paper uses 0.01 N·m. > 0.
  double moment_scale_bar = 0.01;
  /// Drawn length (px) of a scale bar when nothing needs shrinking; > 0.
  double scale_bar_px = 40.0;
  /// Largest drawn projection (px): when max |component| * px_per_unit would exceed this, the
  /// scale of that quantity (force or moment) is reduced for the whole figure, so all panels of
  /// a figure share one scale per quantity and the scale bar shows it. > 0.
  double max_component_px = 90.0;
  /// Screen direction of +z (degrees, counter-clockwise from screen right).
  double oblique_angle_deg = 225.0;
  /// Foreshortening of the z axis (1 = cavalier: true length). > 0.
  double oblique_ratio = 1.0;
};

/// Screen displacement (px; SVG axes, y downward) of a 3-vector `v` drawn at `px_per_unit` px
/// per unit of v under the oblique projection documented in this file.
Eigen::Vector2d ObliqueProjection(const Eigen::Vector3d& v, double px_per_unit,
                                  const GlyphOptions& options = {});

/// Scales (px per N, px per N·m) a figure uses to draw `wrenches` with `options`:
/// scale_bar_px / scale bar, reduced so that max |component| * scale <= max_component_px.
Eigen::Vector2d GlyphScales(const std::vector<Vector6d>& wrenches,
                            const GlyphOptions& options = {});

/// An SVG document (with XML declaration) of one wrench: force and moment glyphs side by side,
/// with `title` above them. Scales from GlyphScales({wrench}) unless `scales` is given
/// (px per N, px per N·m; both > 0).
std::string WrenchGlyphSvg(const Vector6d& wrench, const std::string& title,
                           const GlyphOptions& options = {},
                           const Eigen::Vector2d& scales = Eigen::Vector2d::Zero());

// ---- The paper's figures ------------------------------------------------------------------

/// SVG of a paper figure: a title, one column per transducer condition ("released rz (5
/// forces)", "over-constrained (6 forces)"), one row per row letter, each panel the force and
/// moment glyphs of PaperPanel::wrench with the panel's method and condition (stiffness values
/// with units) written under it, and a warning line for panels whose small-motion check fails.
/// Panels are <g class="panel" data-row=".." data-column=".."> elements; glyph lines carry
/// class and data-* attributes (docs/figures.md) so tests can read the geometry back.
/// @throws Error if `panels` is empty.
std::string PaperFigureSvg(int figure, const std::vector<PaperPanel>& panels,
                           const GlyphOptions& options = {});

/// The same numbers as CSV: one line per panel, header
/// figure,row,column,method,condition,fx_N,fy_N,fz_N,mx_Nm,my_Nm,mz_Nm,
/// st_x_N_per_m,st_y_N_per_m,st_z_N_per_m,st_rx_Nm_per_rad,st_ry_Nm_per_rad,st_rz_Nm_per_rad,
/// base_stiffness_N_per_m,valid,note. Numbers with 17 significant digits, '.' decimal point.
std::string PaperFigureCsv(const std::vector<PaperPanel>& panels);

/// The same numbers as JSON: {"figure": N, "units": {...}, "panels": [...]}.
std::string PaperFigureJson(int figure, const std::vector<PaperPanel>& panels);

/// Options of WritePaperFigure.
struct FigureWriteOptions {
  GlyphOptions glyph;
  /// Also write a PNG when a rasterizer is found (FindSvgRasterizer).
  bool png = true;
};

/// What WritePaperFigure wrote.
struct FigureFiles {
  std::vector<std::string> files;  ///< paths written, in order svg, csv, json[, png]
  bool png_written = false;
  std::string png_note;  ///< why no PNG was written, empty when one was
};

/// Write figure<N>.svg, figure<N>.csv and figure<N>.json (and figure<N>.png when a rasterizer
/// exists) into `out_dir`. Each file is complete or absent.
/// @throws Error if `out_dir` does not exist or a file cannot be written.
FigureFiles WritePaperFigure(int figure, const std::vector<PaperPanel>& panels,
                             const std::string& out_dir, const FigureWriteOptions& options = {});

/// Path of an SVG rasterizer found on PATH at run time: rsvg-convert first, then ImageMagick
/// (`magick`, `convert`) if `-version` reports ImageMagick and exits 0. Empty when none.
std::string FindSvgRasterizer();

/// Rasterize `svg_path` to `png_path` with the found rasterizer (written to a temporary name and
/// renamed only if it starts with the PNG signature). Returns false and sets `message` (why)
/// when no rasterizer exists or it fails; never throws for that.
bool RasterizeSvgToPng(const std::string& svg_path, const std::string& png_path,
                       std::string* message);

// ---- Stick figure of a limb ---------------------------------------------------------------

/// Options of LimbStickFigureSvg.
struct LimbDrawingOptions {
  /// Length (m) of the joint-axis segments and endpoint/transducer frame axes; <= 0 means
  /// 12% of Model::chain_length().
  double axis_length = 0.0;
  /// Width (px) of one view; the two views share one scale. > 0.
  double view_px = 420.0;
  /// Title above the views; empty = "<model name> at <posture>".
  std::string title;
  /// Muscles to draw (names); empty = every muscle. @throws Error (from LimbStickFigureSvg)
  /// naming an unknown muscle.
  std::vector<std::string> muscles;
  /// How wrapped paths are computed (wrap.hpp): a muscle with wraps is drawn through its wrapped
  /// path (straight segments to each wrap's tangent points, the arc over the surface sampled).
  /// `isowrench draw` sets the model's mode unless --wrap says otherwise.
  WrapMode wrap_mode = WrapMode::kOpenSim;
};

/// Two-view stick figure of `model` at posture `q`: top view (world x-y, looking down -z) and
/// side view (world x-z, looking along +y), same scale, with a 10 mm (or suitable) scale bar.
/// Draws joint centres (circles, labelled with the joints located there), joint axes as short
/// segments through the centres, bones between consecutive joint centres and the endpoint, every
/// muscle path (or those named in options.muscles), the endpoint frame (x, y, z in green, blue,
/// red) and the transducer axes when they differ from it. Labels never overlap: each (endpoint,
/// joint centres, then muscles) goes to the first free place around its point or along its
/// path, a label of n characters at f px taken as 0.62 n f px wide and 1.1 f px high plus 1 px
/// clearance; a label with no free place is left out and counted under the view (class
/// "label-note", names in data-left-out separated by ';'); a label put away from its point gets a
/// thin leader line, and a joint centre whose list of joints would take over half the view's width
/// is labelled "<first joint> +N joints". Uses EndpointPose / PointPosition.
/// Wraps (docs/opensim.md "Wrapping"): the wrap objects of the drawn muscles (all of the model's
/// when every muscle is drawn) are drawn on their links as their orthographic outline in each view
/// (class "wrap-surface", data-wrap, data-shape, data-active): a cylinder's end circles and two
/// silhouette lines, a sphere's circle, an ellipsoid's shadow ellipse, a torus's equator circles
/// and the circles along the top and bottom of its tube; an inactive object (`active` false) is
/// drawn dashed and unfilled and never bends a path. A muscle with wraps is drawn through the
/// elements of the engine's MuscleWrappedPath in options.wrap_mode (the model itself when that
/// is its mode, else ModelInWrapMode); each engaged wrap adds its arc (class
/// "wrap-arc", sampled on the surface; data-arc-m the world coordinates along the view's axes, m)
/// and its tangent points (class "tangent-point", data-end r1/r2, data-right-m/data-up-m in m).
/// @throws Error for a posture of the wrong size or non-finite entries.
std::string LimbStickFigureSvg(const Model& model, const Eigen::VectorXd& q,
                               const LimbDrawingOptions& options = {});

// ---- Fit reports --------------------------------------------------------------------------

/// Options of the fit report renderers.
struct FitReportOptions {
  /// Wrench glyphs (measured, predicted by the nominal model, predicted by the fitted model)
  /// are drawn for this many trials, those with the largest residual before the fit. >= 0.
  int glyph_trials = 3;
  /// Rows of the per-trial residual table in the markdown report (largest residual before
  /// first). >= 0.
  int markdown_trials = 15;
  /// Heading; empty = "Fit report: <model name>".
  std::string title;
  /// The trials the fit used, in the order given to FitEffects (which FitReport::trials keeps).
  /// With `model`, the HTML adds "residual vs posture": the residual size before and after
  /// against each joint that varies across the trials (degrees, or mm for prismatic joints).
  /// Not owned; null = no posture plots. @throws Error (from the renderers) if the count or the
  /// CSV line numbers do not match the report's trials.
  const std::vector<Trial>* trials = nullptr;
  /// The model the trials were read against (joint types, for units). Not owned.
  const Model* model = nullptr;
};

/// A self-contained HTML page (inline CSS and SVG, no scripts, no network) of a FitReport:
/// verdict; RMS, R^2, noise multiples and mean of the residual (measured - predicted) per
/// component before and after; the effects added with their parameters and standard errors;
/// per round the candidates ranked by BIC with delta BIC, AICc, held-out error,
/// identifiability, parameters and verdict; per component a measured-vs-predicted scatter and
/// a residual-vs-trial plot (before in orange, after in blue); residual size vs each varying
/// joint when FitReportOptions::trials and ::model are given; and the wrench glyphs of the
/// trials with the largest residual before the fit. Units: N and N·m, transducer axes.
std::string FitReportHtml(const FitReport& report, const FitReportOptions& options = {});

/// The same content as markdown for lab notebooks: the tables of FitReportHtml plus a table of
/// the trials with the largest residual (measured, predicted before and after); the plots are
/// in the HTML report only.
std::string FitReportMarkdown(const FitReport& report, const FitReportOptions& options = {});

/// Write FitReportHtml to `path` atomically. @throws Error if it cannot be written.
void WriteFitReportHtml(const FitReport& report, const std::string& path,
                        const FitReportOptions& options = {});

/// Write FitReportMarkdown to `path` atomically. @throws Error if it cannot be written.
void WriteFitReportMarkdown(const FitReport& report, const std::string& path,
                            const FitReportOptions& options = {});

/// Write `content` to `path` atomically (temporary file, then rename).
/// @throws Error naming the path if it cannot be written (e.g. its directory does not exist).
void WriteTextFile(const std::string& path, const std::string& content);

}  // namespace isowrench
