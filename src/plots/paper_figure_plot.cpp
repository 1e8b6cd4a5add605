// The paper's Figures 2-4 drawn from PaperPanel values: a grid of wrench glyphs with row and
// column titles and each panel's stiffness values, plus CSV and JSON of the same numbers.

#include <sys/stat.h>

#include <algorithm>
#include <nlohmann/json.hpp>

#include "isowrench/error.hpp"
#include "isowrench/plots.hpp"
#include "plots/svg_writer.hpp"
#include "plots/wrench_glyph.hpp"
#include "util/atomic_file.hpp"
#include "util/text.hpp"

namespace isowrench {
namespace {

using plots::Num;
using plots::SvgWriter;

const char* FigureTitle(int figure) {
  switch (figure) {
    case 2:
      return "Figure 2: transducer compliance alters the measured wrench when over-constrained "
             "(rigid base, S_p = 0)";
    case 3:
      return "Figure 3: base compliance alters the measured wrench when over-constrained (balanced "
             "S_t = 1e7)";
    case 4:
      return "Figure 4: knee ab/adduction as a joint dof with 1 N·m/rad stiffness (6-dof limb, all "
             "6 transducer dofs restrained)";
    default: return "Paper figure";
  }
}

// Layout constants (px).
constexpr double kMargin = 16;
constexpr double kTitleHeight = 58;  // title + two subtitle lines
constexpr double kColumnHeader = 24;
constexpr double kRowLabelWidth = 150;
constexpr double kPanelPad = 10;
constexpr double kMethodLine = 18;
constexpr double kTextLine = 13;
constexpr double kCharWidth = 5.6;     // average glyph width of 10 px Helvetica, for wrapping
constexpr size_t kRowLabelChars = 26;  // kRowLabelWidth / kCharWidth, less a margin

std::vector<std::string> Unique(const std::vector<PaperPanel>& panels,
                                std::string PaperPanel::*field) {
  std::vector<std::string> out;
  for (const PaperPanel& p : panels) {
    if (std::find(out.begin(), out.end(), p.*field) == out.end()) out.push_back(p.*field);
  }
  return out;
}

// Split the condition at "; " into lines no wider than max_chars (a piece longer is kept whole).
std::vector<std::string> WrapCondition(const std::string& condition, size_t max_chars) {
  std::vector<std::string> lines;
  std::string current;
  size_t start = 0;
  while (start <= condition.size()) {
    size_t end = condition.find("; ", start);
    std::string piece =
        condition.substr(start, end == std::string::npos ? std::string::npos : end - start);
    if (!current.empty() && current.size() + 2 + piece.size() > max_chars) {
      lines.push_back(current);
      current.clear();
    }
    current += (current.empty() ? "" : "; ") + piece;
    if (end == std::string::npos) break;
    start = end + 2;
  }
  if (!current.empty()) lines.push_back(current);
  return lines;
}

// Greedy word wrap at spaces.
std::vector<std::string> WrapWords(const std::string& text, size_t max_chars) {
  std::vector<std::string> lines;
  std::string current;
  for (const std::string& word : util::Split(text, " ")) {
    if (!current.empty() && current.size() + 1 + word.size() > max_chars) {
      lines.push_back(current);
      current.clear();
    }
    current += (current.empty() ? "" : " ") + word;
  }
  if (!current.empty()) lines.push_back(current);
  return lines;
}

std::string Fmt(double v) { return util::FormatNumber(v, 3); }

// Row label: what the row varies, with the stiffness values of its Eq. 10 panel.
std::string RowLabel(const std::vector<PaperPanel>& panels, const std::string& row) {
  const PaperPanel* chosen = nullptr;
  // Prefer an Eq. 10 panel with every transducer dof restrained: released dofs show S_t = 0.
  auto rank = [](const PaperPanel& p) {
    return (p.method == "Eq. 10" ? 2 : 0) + ((p.s_t.array() > 0).all() ? 1 : 0);
  };
  for (const PaperPanel& p : panels) {
    if (p.row == row && (!chosen || rank(p) > rank(*chosen))) chosen = &p;
  }
  if (!chosen) return "";
  if (chosen->method != "Eq. 10") {
    return chosen->method == "femur removed" ? "femur removed"
                                             : "inverse / pseudoinverse, no compliance";
  }
  std::string label = chosen->condition.substr(0, chosen->condition.find("; "));
  const Vector6d& s = chosen->s_t;
  if (s.head<3>().isConstant(s[0]) && s.tail<3>().isConstant(s[3])) {
    label += ": S_t = " + Fmt(s[0]) + " N/m, " + Fmt(s[3]) + " N·m/rad";
  } else {
    label += ": S_t = [" + Fmt(s[0]) + " " + Fmt(s[1]) + " " + Fmt(s[2]) + "] N/m, [" + Fmt(s[3]) +
             " " + Fmt(s[4]) + " " + Fmt(s[5]) + "] N·m/rad";
  }
  if (chosen->base_stiffness > 0) label += "; base " + Fmt(chosen->base_stiffness) + " N/m";
  return label;
}

std::string ShortNote(const std::string& note) {
  size_t colon = note.find(':');
  return "! " + (colon == std::string::npos ? note : note.substr(0, colon));
}

std::string CsvField(const std::string& text) {
  if (text.find_first_of(",\"\n") == std::string::npos) return text;
  std::string out = "\"";
  for (char c : text) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

bool IsDirectory(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

}  // namespace

std::string PaperFigureSvg(int figure, const std::vector<PaperPanel>& panels,
                           const GlyphOptions& options) {
  if (panels.empty()) throw Error("figure " + std::to_string(figure) + ": no panels to draw");
  std::vector<Vector6d> wrenches;
  for (const PaperPanel& p : panels) wrenches.push_back(p.wrench);
  const Eigen::Vector2d scales = GlyphScales(wrenches, options);
  const auto [force_box, moment_box] = plots::MakeWrenchBoxes(wrenches, scales, options);

  const std::vector<std::string> rows = Unique(panels, &PaperPanel::row);
  const std::vector<std::string> columns = Unique(panels, &PaperPanel::column);
  const double glyphs_width = force_box.width() + plots::kGlyphGap + moment_box.width();
  const double panel_width = glyphs_width + 2 * kPanelPad;
  const size_t wrap_chars = static_cast<size_t>(glyphs_width / kCharWidth);
  // Panel height: method line, glyphs, condition lines (max over panels), note line.
  size_t condition_lines = 1;
  for (const PaperPanel& p : panels) {
    condition_lines = std::max(condition_lines, WrapCondition(p.condition, wrap_chars).size());
  }
  const double glyph_height = std::max(force_box.height(), moment_box.height());
  const double panel_height = kMethodLine + glyph_height +
                              kTextLine * static_cast<double>(condition_lines + 1) + 2 * kPanelPad;
  const double width =
      2 * kMargin + kRowLabelWidth + panel_width * static_cast<double>(columns.size());
  const double height =
      2 * kMargin + kTitleHeight + kColumnHeader + panel_height * static_cast<double>(rows.size());

  SvgWriter svg(width, height, FigureTitle(figure));
  svg.Open("g", {{"class", "figure"}, {"data-figure", std::to_string(figure)}});
  svg.Text(kMargin, kMargin + 14, FigureTitle(figure), 15, "start",
           {{"class", "title"}, {"font-weight", "bold"}});
  svg.Text(kMargin, kMargin + 32,
           "GP muscle, 2.3 N, posture hip_rz = -110°, knee_rz = 105°. W = wrench the limb applies "
           "to the "
           "transducer, world axes, moment about the ankle.",
           11, "start", {{"class", "subtitle"}});
  svg.Text(kMargin, kMargin + 47,
           "Each panel: force (left) and moment (right), the 3-D vector in black and its "
           "projections on x, y, z "
           "in green, blue, red. Scale: " +
               plots::Short(options.force_scale_bar) +
               " N = " + Num(options.force_scale_bar * scales[0], 1) + " px, " +
               plots::Short(options.moment_scale_bar) +
               " N·m = " + Num(options.moment_scale_bar * scales[1], 1) + " px in every panel.",
           11, "start", {{"class", "subtitle"}});

  const double grid_top = kMargin + kTitleHeight;
  for (size_t c = 0; c < columns.size(); ++c) {
    const double x = kMargin + kRowLabelWidth + panel_width * static_cast<double>(c);
    svg.Text(x + panel_width / 2, grid_top + 15,
             "Column " + std::to_string(c + 1) + (columns[c].empty() ? "" : ": " + columns[c]), 13,
             "middle", {{"class", "column-title"}, {"font-weight", "bold"}});
  }
  for (size_t r = 0; r < rows.size(); ++r) {
    const double y = grid_top + kColumnHeader + panel_height * static_cast<double>(r);
    svg.Line(kMargin, y, width - kMargin, y, "#cccccc", 0.8);
    svg.Open("g", {{"class", "row-header"}, {"data-row", rows[r]}});
    svg.Text(kMargin, y + 30, rows[r], 22, "start",
             {{"class", "row-title"}, {"font-weight", "bold"}});
    double line_y = y + 48;
    for (const std::string& line : WrapWords(RowLabel(panels, rows[r]), kRowLabelChars)) {
      svg.Text(kMargin, line_y, line, 10, "start", {{"class", "row-label"}});
      line_y += kTextLine;
    }
    svg.Close();
  }
  for (const PaperPanel& p : panels) {
    const size_t r = static_cast<size_t>(std::find(rows.begin(), rows.end(), p.row) - rows.begin());
    const size_t c =
        static_cast<size_t>(std::find(columns.begin(), columns.end(), p.column) - columns.begin());
    const double x = kMargin + kRowLabelWidth + panel_width * static_cast<double>(c) + kPanelPad;
    const double y = grid_top + kColumnHeader + panel_height * static_cast<double>(r) + kPanelPad;
    svg.Open("g",
             {{"class", "panel"},
              {"id", "fig" + std::to_string(figure) + "-" + p.row + "-col" + std::to_string(c + 1)},
              {"data-row", p.row},
              {"data-column", p.column},
              {"data-method", p.method},
              {"data-condition", p.condition},
              {"data-valid", p.valid ? "true" : "false"}});
    svg.Text(x, y + 12, p.row + std::to_string(c + 1) + "   " + p.method, 12, "start",
             {{"class", "method"}, {"font-weight", "bold"}});
    plots::DrawWrenchGlyphs(svg, x, y + kMethodLine, p.wrench, force_box, moment_box, scales,
                            options);
    double line_y = y + kMethodLine + glyph_height + 10;
    for (const std::string& line : WrapCondition(p.condition, wrap_chars)) {
      svg.Text(x, line_y, line, 10, "start", {{"class", "condition"}});
      line_y += kTextLine;
    }
    if (!p.note.empty()) {
      svg.Text(
          x, line_y, ShortNote(p.note), 10, "start",
          {{"class", "note"}, {"fill", p.valid ? "#555555" : "#c00000"}, {"data-note", p.note}});
    }
    svg.Close();
  }
  return svg.Finish();
}

std::string PaperFigureCsv(const std::vector<PaperPanel>& panels) {
  std::string out =
      "figure,row,column,method,condition,fx_N,fy_N,fz_N,mx_Nm,my_Nm,mz_Nm,st_x_N_per_m,st_y_N_per_"
      "m,"
      "st_z_N_per_m,st_rx_Nm_per_rad,st_ry_Nm_per_rad,st_rz_Nm_per_rad,base_stiffness_N_per_m,"
      "valid,note\n";
  for (const PaperPanel& p : panels) {
    out += std::to_string(p.figure) + "," + CsvField(p.row) + "," + CsvField(p.column) + "," +
           CsvField(p.method) + "," + CsvField(p.condition);
    for (int i = 0; i < 6; ++i) out += "," + plots::Exact(p.wrench[i]);
    for (int i = 0; i < 6; ++i) out += "," + plots::Exact(p.s_t[i]);
    out += "," + plots::Exact(p.base_stiffness) + "," + (p.valid ? "true" : "false") + "," +
           CsvField(p.note) + "\n";
  }
  return out;
}

std::string PaperFigureJson(int figure, const std::vector<PaperPanel>& panels) {
  nlohmann::json out;
  out["figure"] = figure;
  out["title"] = FigureTitle(figure);
  out["units"] = {{"force", "N"},
                  {"moment", "N·m"},
                  {"s_t", "N/m for x y z, N·m/rad for rx ry rz"},
                  {"base_stiffness", "N/m"}};
  out["wrench_sign"] =
      "wrench the limb applies to the transducer; world axes; moment about the endpoint";
  out["panels"] = nlohmann::json::array();
  for (const PaperPanel& p : panels) {
    nlohmann::json w = nlohmann::json::object();
    for (int i = 0; i < 6; ++i) w[std::string(i < 3 ? "f" : "m") + "xyz"[i % 3]] = p.wrench[i];
    out["panels"].push_back({{"row", p.row},
                             {"column", p.column},
                             {"method", p.method},
                             {"condition", p.condition},
                             {"s_t", std::vector<double>(p.s_t.data(), p.s_t.data() + 6)},
                             {"base_stiffness", p.base_stiffness},
                             {"wrench", w},
                             {"valid", p.valid},
                             {"note", p.note}});
  }
  return out.dump(2) + "\n";
}

void WriteTextFile(const std::string& path, const std::string& content) {
  util::WriteFileAtomically(path, content);
}

FigureFiles WritePaperFigure(int figure, const std::vector<PaperPanel>& panels,
                             const std::string& out_dir, const FigureWriteOptions& options) {
  if (!IsDirectory(out_dir)) throw Error("output directory '" + out_dir + "' does not exist");
  // Everything is rendered before the first file is written, so a rendering error writes nothing.
  const std::string base = out_dir + "/figure" + std::to_string(figure);
  const std::pair<std::string, std::string> contents[] = {
      {base + ".svg", PaperFigureSvg(figure, panels, options.glyph)},
      {base + ".csv", PaperFigureCsv(panels)},
      {base + ".json", PaperFigureJson(figure, panels)},
  };
  FigureFiles files;
  for (const auto& [path, content] : contents) {
    util::WriteFileAtomically(path, content);
    files.files.push_back(path);
  }
  if (options.png) {
    files.png_written = RasterizeSvgToPng(base + ".svg", base + ".png", &files.png_note);
    if (files.png_written) files.files.push_back(base + ".png");
  } else {
    files.png_note = "PNG not requested";
  }
  return files;
}

}  // namespace isowrench
