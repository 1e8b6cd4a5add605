// Tests of the paper-figure part of include/isowrench/plots.hpp: the SVG is valid XML with the
// expected panels and labels, every glyph's drawn lengths match the wrench it draws (read back
// from the SVG geometry), CSV/JSON carry the same numbers, and errors leave no file behind.

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <tinyxml2.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "isowrench/error.hpp"
#include "isowrench/paper.hpp"
#include "isowrench/plots.hpp"
#include "svg_test_utils.hpp"

namespace isowrench_test {
namespace {

namespace fs = std::filesystem;
using isowrench::GlyphOptions;
using isowrench::PaperPanel;
using isowrench::Vector6d;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

// The SVG writes coordinates with 3 decimals, so each coordinate is within 5e-4 px of the
// exact value and a line's length within 1e-3 px. The scale is read back from a scale-bar line
// (>= 20 px long with these data), so its relative error is <= 1e-3 / 20 = 5e-5; on a glyph line
// of at most max_component_px = 90 px that adds 4.5e-3 px. 0.01 px bounds both with margin.
constexpr double kPixelTol = 0.01;

std::vector<PaperPanel> Figure(int n) {
  return isowrench::ComputePaperFigure(n, ISOWRENCH_TEST_URDF_DIR);
}

struct Parsed {
  tinyxml2::XMLDocument doc;
  const tinyxml2::XMLElement* root = nullptr;
};

void Parse(const std::string& svg, Parsed* p) {
  ASSERT_EQ(p->doc.Parse(svg.c_str(), svg.size()), tinyxml2::XML_SUCCESS) << p->doc.ErrorStr();
  p->root = p->doc.RootElement();
  ASSERT_NE(p->root, nullptr);
  ASSERT_STREQ(p->root->Name(), "svg");
}

const tinyxml2::XMLElement* PanelFor(const tinyxml2::XMLElement* root, const PaperPanel& panel) {
  for (const tinyxml2::XMLElement* g : ByClass(root, "panel")) {
    if (panel.row == g->Attribute("data-row") && panel.column == g->Attribute("data-column"))
      return g;
  }
  return nullptr;
}

TEST(PaperFigureSvg, IsValidXmlWithOnePanelPerWrenchAndTheirLabels) {
  for (int figure : {2, 3, 4}) {
    SCOPED_TRACE("figure " + std::to_string(figure));
    const std::vector<PaperPanel> panels = Figure(figure);
    Parsed p;
    Parse(isowrench::PaperFigureSvg(figure, panels), &p);
    ASSERT_EQ(ByClass(p.root, "panel").size(), panels.size());
    const std::string text = AllText(p.root);
    EXPECT_THAT(text, HasSubstr("Figure " + std::to_string(figure) + ":"));
    for (const PaperPanel& panel : panels) {
      const tinyxml2::XMLElement* g = PanelFor(p.root, panel);
      ASSERT_NE(g, nullptr) << panel.row << " / " << panel.column;
      // Column titles, row letters and the panel's method are written out.
      if (!panel.column.empty()) {
        EXPECT_THAT(text, HasSubstr(panel.column));
      }
      EXPECT_THAT(AllText(g), HasSubstr(panel.method));
      // The condition with its stiffness values and units is printed under the panel (wrapped
      // at "; " boundaries): joining the lines gives it back exactly.
      std::vector<std::string> lines;
      for (const tinyxml2::XMLElement* t : ByClass(g, "condition")) lines.push_back(t->GetText());
      std::string joined;
      for (size_t i = 0; i < lines.size(); ++i) joined += (i ? "; " : "") + lines[i];
      EXPECT_EQ(joined, panel.condition);
      // Two glyphs, each with three projections, a vector, a scale bar and x y z labels.
      const auto glyphs = ByClass(g, "glyph");
      ASSERT_EQ(glyphs.size(), 2u);
      for (const tinyxml2::XMLElement* glyph : glyphs) {
        EXPECT_EQ(ByClass(glyph, "component").size(), 3u);
        EXPECT_EQ(ByClass(glyph, "vector").size(), 1u);
        EXPECT_EQ(ByClass(glyph, "scale-bar").size(), 1u);
        EXPECT_EQ(AllText(glyph).substr(0, 6), "x\ny\nz\n");
      }
      // A panel that fails the small-motion check says so.
      if (!panel.valid) {
        EXPECT_EQ(ByClass(g, "note").size(), 1u);
      }
    }
    // Row titles: one per row letter.
    std::set<std::string> rows;
    for (const PaperPanel& panel : panels) rows.insert(panel.row);
    EXPECT_EQ(ByClass(p.root, "row-title").size(), rows.size());
  }
}

// 3 significant digits as %g prints them in the "C" locale the tests run in.
std::string Format3(double v) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.3g", v);
  return buffer;
}

TEST(PaperFigureSvg, RowLabelsCarryTheStiffnessValuesOfTheirRow) {
  for (int figure : {2, 3, 4}) {
    const std::vector<PaperPanel> panels = Figure(figure);
    Parsed p;
    Parse(isowrench::PaperFigureSvg(figure, panels), &p);
    for (const tinyxml2::XMLElement* header : ByClass(p.root, "row-header")) {
      const std::string row = header->Attribute("data-row");
      SCOPED_TRACE("figure " + std::to_string(figure) + " row " + row);
      std::string label;
      for (const auto* t : ByClass(header, "row-label")) label += std::string(t->GetText()) + " ";
      for (const PaperPanel& panel : panels) {
        // Every Eq. 10 panel of the row with all six transducer dofs restrained shares the
        // row's stiffness values; the label must show them with units.
        if (panel.row != row || panel.method != "Eq. 10" || !(panel.s_t.array() > 0).all())
          continue;
        EXPECT_THAT(label, HasSubstr(Format3(panel.s_t[0])));
        EXPECT_THAT(label, HasSubstr(Format3(panel.s_t[3])));
        EXPECT_THAT(label, HasSubstr("N/m"));
        EXPECT_THAT(label, HasSubstr("N·m/rad"));
        if (panel.base_stiffness > 0) {
          EXPECT_THAT(label, HasSubstr("base " + Format3(panel.base_stiffness) + " N/m"));
        }
      }
      if (figure == 3 && row == "E") {
        EXPECT_THAT(label, HasSubstr("femur removed"));
      }
    }
  }
}

TEST(PaperFigureSvg, HasNoExternalReferences) {
  Parsed p;
  Parse(isowrench::PaperFigureSvg(3, Figure(3)), &p);
  std::vector<std::string> attributes;
  AllAttributes(p.root, &attributes);
  for (const std::string& a : attributes) {
    if (a.rfind("xmlns=", 0) == 0) continue;  // the SVG namespace name, not a reference
    EXPECT_THAT(a, ::testing::Not(HasSubstr("href"))) << a;
    EXPECT_THAT(a, ::testing::Not(HasSubstr("url("))) << a;
    EXPECT_THAT(a, ::testing::Not(HasSubstr("http"))) << a;
  }
  EXPECT_TRUE(ByTag(p.root, "image").empty());
  EXPECT_TRUE(ByTag(p.root, "script").empty());
  EXPECT_TRUE(ByTag(p.root, "style").empty());
}

// Check one glyph's geometry against the 3-vector `v` it must draw, with the scale read back
// from the scale bar's length (and the bar's value known from the options). Returns the scale.
double CheckGlyph(const tinyxml2::XMLElement* glyph, const Eigen::Vector3d& v, double bar_value,
                  const GlyphOptions& options) {
  const auto bars = ByClass(glyph, "scale-bar");
  EXPECT_EQ(bars.size(), 1u);
  const LineGeom bar = Line(bars[0]);
  EXPECT_NEAR(bar.d().y(), 0.0, 1e-9);  // horizontal
  const double px_per_unit = bar.d().norm() / bar_value;
  // Unit screen directions of +x, +y, +z under the documented projection: x right, y up, z at
  // oblique_angle_deg with ratio oblique_ratio (SVG y grows downward).
  const double a = options.oblique_angle_deg * M_PI / 180.0;
  const Eigen::Vector2d dir[3] = {
      {1, 0}, {0, -1}, {options.oblique_ratio * std::cos(a), -options.oblique_ratio * std::sin(a)}};
  Eigen::Vector2d origin(Num(glyph, "data-origin-x"), Num(glyph, "data-origin-y"));
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  const auto components = ByClass(glyph, "component");
  EXPECT_EQ(components.size(), 3u);
  for (int i = 0; i < 3 && i < static_cast<int>(components.size()); ++i) {
    EXPECT_EQ(std::string(components[i]->Attribute("data-axis")), std::string(1, "xyz"[i]));
    const LineGeom line = Line(components[i]);
    EXPECT_NEAR((line.a - origin).norm(), 0.0, kPixelTol) << "projections start at the origin";
    // Drawn length = |component| * scale (cavalier projection: every axis at true length).
    EXPECT_NEAR(line.d().norm(),
                std::abs(v[i]) * px_per_unit * (i == 2 ? options.oblique_ratio : 1.0), kPixelTol)
        << "axis "
        << "xyz"[i];
    // Drawn along the axis, on the side of the component's sign.
    EXPECT_NEAR((line.d() - v[i] * px_per_unit * dir[i]).norm(), 0.0, kPixelTol) << "axis "
                                                                                 << "xyz"[i];
    sum += line.d();
    // The projection is drawn in the paper's colour for its axis.
    EXPECT_STREQ(components[i]->Attribute("stroke"), isowrench::kAxisColors[i]);
  }
  // The black vector ends at the sum of its projections (the 3-D vector in oblique projection).
  const auto vectors = ByClass(glyph, "vector");
  EXPECT_EQ(vectors.size(), 1u);
  const LineGeom vec = Line(vectors[0]);
  EXPECT_NEAR((vec.d() - sum).norm(), 0.0, 2 * kPixelTol);
  return px_per_unit;
}

TEST(PaperFigureSvg, GlyphLengthsMatchTheWrenchesTheyDraw) {
  const GlyphOptions options;
  for (int figure : {2, 3, 4}) {
    SCOPED_TRACE("figure " + std::to_string(figure));
    // Wrenches from the library, independent of the SVG's own data attributes.
    const std::vector<PaperPanel> panels = Figure(figure);
    Parsed p;
    Parse(isowrench::PaperFigureSvg(figure, panels, options), &p);
    double force_scale = -1, moment_scale = -1;
    double largest = 0;
    for (const PaperPanel& panel : panels) {
      SCOPED_TRACE(panel.row + " " + panel.column);
      const tinyxml2::XMLElement* g = PanelFor(p.root, panel);
      ASSERT_NE(g, nullptr);
      const auto force = ByClass(g, "force");
      const auto moment = ByClass(g, "moment");
      ASSERT_EQ(force.size(), 1u);
      ASSERT_EQ(moment.size(), 1u);
      const double fs =
          CheckGlyph(force[0], panel.wrench.head<3>(), options.force_scale_bar, options);
      const double ms =
          CheckGlyph(moment[0], panel.wrench.tail<3>(), options.moment_scale_bar, options);
      // One scale per quantity for the whole figure, so panels compare by eye.
      if (force_scale < 0) force_scale = fs, moment_scale = ms;
      EXPECT_NEAR(fs, force_scale, 1e-3 * force_scale);
      EXPECT_NEAR(ms, moment_scale, 1e-3 * moment_scale);
      largest = std::max(largest, panel.wrench.head<3>().cwiseAbs().maxCoeff() * fs);
    }
    // The scale is the paper's bar length unless the largest projection would exceed the limit.
    EXPECT_LE(largest, options.max_component_px + kPixelTol);
  }
}

TEST(GlyphScales, UseTheScaleBarUnlessAProjectionWouldBeTooLong) {
  GlyphOptions options;
  Vector6d small;
  small << 0.1, -0.2, 0.05, 0.001, 0.002, -0.003;  // 0.2 N * 40/0.3 px/N = 26.7 px < 90 px
  Eigen::Vector2d s = isowrench::GlyphScales({small}, options);
  EXPECT_DOUBLE_EQ(s[0], options.scale_bar_px / options.force_scale_bar);
  EXPECT_DOUBLE_EQ(s[1], options.scale_bar_px / options.moment_scale_bar);
  Vector6d large;
  large << 2.0, 0, 0, 0, -0.05, 0;  // 2 N would be 267 px; 0.05 N·m would be 200 px
  s = isowrench::GlyphScales({small, large}, options);
  EXPECT_DOUBLE_EQ(s[0] * 2.0, options.max_component_px);
  EXPECT_DOUBLE_EQ(s[1] * 0.05, options.max_component_px);
}

TEST(GlyphScales, RefusesNonFiniteWrenchesAndBadOptions) {
  Vector6d w = Vector6d::Zero();
  w[4] = std::nan("");
  EXPECT_THAT([&] { isowrench::GlyphScales({w}); },
              ThrowsMessage<isowrench::Error>(HasSubstr("not finite")));
  GlyphOptions bad;
  bad.force_scale_bar = 0;
  EXPECT_THAT([&] { isowrench::GlyphScales({Vector6d::Zero()}, bad); },
              ThrowsMessage<isowrench::Error>(HasSubstr("must be > 0")));
}

TEST(ObliqueProjection, CavalierKeepsEveryAxisAtTrueLength) {
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(isowrench::ObliqueProjection(Eigen::Vector3d::Unit(i), 7.0).norm(), 7.0, 1e-12);
  }
  // x right, y up (SVG y down), z down-left at 225 degrees.
  EXPECT_NEAR(
      (isowrench::ObliqueProjection(Eigen::Vector3d(1, 2, 0), 1.0) - Eigen::Vector2d(1, -2)).norm(),
      0, 1e-12);
  EXPECT_NEAR((isowrench::ObliqueProjection(Eigen::Vector3d(0, 0, 1), 1.0) -
               Eigen::Vector2d(-std::sqrt(0.5), std::sqrt(0.5)))
                  .norm(),
              0, 1e-12);
}

TEST(WrenchGlyphSvg, StandaloneGlyphParsesAndDrawsTheGivenWrench) {
  Vector6d w;
  w << 0.25, -0.1, 0.05, 0.004, 0.0, -0.008;
  Parsed p;
  Parse(isowrench::WrenchGlyphSvg(w, "test wrench"), &p);
  const GlyphOptions options;
  ASSERT_EQ(ByClass(p.root, "force").size(), 1u);
  CheckGlyph(ByClass(p.root, "force")[0], w.head<3>(), options.force_scale_bar, options);
  CheckGlyph(ByClass(p.root, "moment")[0], w.tail<3>(), options.moment_scale_bar, options);
  EXPECT_THAT(AllText(p.root), HasSubstr("test wrench"));
}

// Split one CSV line with quoted fields.
std::vector<std::string> CsvSplit(const std::string& line) {
  std::vector<std::string> out(1);
  bool quoted = false;
  for (size_t i = 0; i < line.size(); ++i) {
    char c = line[i];
    if (quoted && c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
      out.back() += '"';
      ++i;
    } else if (c == '"') {
      quoted = !quoted;
    } else if (c == ',' && !quoted) {
      out.emplace_back();
    } else {
      out.back() += c;
    }
  }
  return out;
}

TEST(PaperFigureCsv, CarriesTheExactNumbersOfEveryPanel) {
  const std::vector<PaperPanel> panels = Figure(2);
  std::istringstream in(isowrench::PaperFigureCsv(panels));
  std::string line;
  std::getline(in, line);
  const std::vector<std::string> header = CsvSplit(line);
  ASSERT_EQ(header.size(), 20u);
  EXPECT_EQ(header[5], "fx_N");
  EXPECT_EQ(header[10], "mz_Nm");
  for (const PaperPanel& panel : panels) {
    ASSERT_TRUE(std::getline(in, line));
    const std::vector<std::string> f = CsvSplit(line);
    ASSERT_EQ(f.size(), 20u) << line;
    EXPECT_EQ(f[1], panel.row);
    EXPECT_EQ(f[2], panel.column);
    EXPECT_EQ(f[4], panel.condition);  // contains commas: quoted
    // Shortest round-trip digits: the parsed value is the same double.
    for (int i = 0; i < 6; ++i) EXPECT_EQ(std::strtod(f[5 + i].c_str(), nullptr), panel.wrench[i]);
    for (int i = 0; i < 6; ++i) EXPECT_EQ(std::strtod(f[11 + i].c_str(), nullptr), panel.s_t[i]);
    EXPECT_EQ(f[18], panel.valid ? "true" : "false");
  }
  EXPECT_FALSE(std::getline(in, line));
}

TEST(PaperFigureJson, CarriesTheSameNumbers) {
  const std::vector<PaperPanel> panels = Figure(3);
  const nlohmann::json j = nlohmann::json::parse(isowrench::PaperFigureJson(3, panels));
  EXPECT_EQ(j["figure"], 3);
  ASSERT_EQ(j["panels"].size(), panels.size());
  const char* names[6] = {"fx", "fy", "fz", "mx", "my", "mz"};
  for (size_t k = 0; k < panels.size(); ++k) {
    EXPECT_EQ(j["panels"][k]["row"], panels[k].row);
    EXPECT_EQ(j["panels"][k]["base_stiffness"].get<double>(), panels[k].base_stiffness);
    for (int i = 0; i < 6; ++i)
      EXPECT_EQ(j["panels"][k]["wrench"][names[i]].get<double>(), panels[k].wrench[i]);
  }
}

class TempDir {
 public:
  TempDir() {
    std::string pattern = (fs::temp_directory_path() / "isowrench-plots-XXXXXX").string();
    path_ = ::mkdtemp(pattern.data());
  }
  ~TempDir() { fs::remove_all(path_); }
  const std::string& path() const { return path_; }
  std::vector<std::string> Files() const {
    std::vector<std::string> out;
    for (const auto& e : fs::directory_iterator(path_)) out.push_back(e.path().filename().string());
    std::sort(out.begin(), out.end());
    return out;
  }

 private:
  std::string path_;
};

std::string ReadAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(WritePaperFigure, WritesSvgCsvJsonWithTheRenderedContentAndNoTemporaries) {
  TempDir dir;
  const std::vector<PaperPanel> panels = Figure(4);
  isowrench::FigureWriteOptions options;
  options.png = false;
  const isowrench::FigureFiles files = isowrench::WritePaperFigure(4, panels, dir.path(), options);
  EXPECT_EQ(dir.Files(), (std::vector<std::string>{"figure4.csv", "figure4.json", "figure4.svg"}));
  EXPECT_EQ(files.files.size(), 3u);
  EXPECT_FALSE(files.png_written);
  EXPECT_EQ(ReadAll(dir.path() + "/figure4.svg"), isowrench::PaperFigureSvg(4, panels));
  EXPECT_EQ(ReadAll(dir.path() + "/figure4.csv"), isowrench::PaperFigureCsv(panels));
  EXPECT_EQ(ReadAll(dir.path() + "/figure4.json"), isowrench::PaperFigureJson(4, panels));
}

TEST(WritePaperFigure, PngIsWrittenOrItsAbsenceExplained) {
  TempDir dir;
  const isowrench::FigureFiles files = isowrench::WritePaperFigure(4, Figure(4), dir.path());
  if (files.png_written) {
    const std::string png = ReadAll(dir.path() + "/figure4.png");
    EXPECT_EQ(png.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
    EXPECT_EQ(dir.Files().size(), 4u);
  } else {
    EXPECT_THAT(files.png_note, HasSubstr("PNG skipped"));
    EXPECT_EQ(dir.Files().size(), 3u) << "a failed rasterization leaves no partial PNG";
  }
}

// A stand-in rasterizer on PATH: `rsvg-convert -f png -o OUT IN` running `body` (sh).
class FakeRasterizer {
 public:
  explicit FakeRasterizer(const std::string& body) {
    const std::string script = bin_.path() + "/rsvg-convert";
    std::ofstream(script) << "#!/bin/sh\n" << body << "\n";
    fs::permissions(script, fs::perms::owner_all);
    old_path_ = std::getenv("PATH") ? std::getenv("PATH") : "";
    ::setenv("PATH", (bin_.path() + ":" + old_path_).c_str(), 1);
  }
  ~FakeRasterizer() { ::setenv("PATH", old_path_.c_str(), 1); }

 private:
  TempDir bin_;
  std::string old_path_;
};

TEST(RasterizeSvgToPng, KeepsAPngOnlyWhenTheRasterizerMadeOne) {
  TempDir dir;
  const std::string svg = dir.path() + "/f.svg", png = dir.path() + "/f.png";
  isowrench::WriteTextFile(svg, isowrench::WrenchGlyphSvg(Vector6d::Constant(0.01), "w"));
  std::string message;
  {
    // $4 is the output path of "-f png -o OUT IN": write a PNG signature there.
    FakeRasterizer fake("printf '\\211PNG\\r\\n\\032\\n' > \"$4\"");
    EXPECT_THAT(isowrench::FindSvgRasterizer(), HasSubstr("rsvg-convert"));
    EXPECT_TRUE(isowrench::RasterizeSvgToPng(svg, png, &message)) << message;
    EXPECT_EQ(ReadAll(png).substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  }
  fs::remove(png);
  {
    // Exit 0 but write something that is not a PNG: refused, nothing left behind.
    FakeRasterizer fake("echo not-a-png > \"$4\"");
    EXPECT_FALSE(isowrench::RasterizeSvgToPng(svg, png, &message));
    EXPECT_THAT(message, HasSubstr("PNG skipped"));
  }
  {
    // Fails half way: exit 1 after a partial write.
    FakeRasterizer fake("printf '\\211PN' > \"$4\"; exit 1");
    EXPECT_FALSE(isowrench::RasterizeSvgToPng(svg, png, &message));
    EXPECT_THAT(message, HasSubstr("exit 1"));
  }
  EXPECT_EQ(dir.Files(), std::vector<std::string>{"f.svg"});
}

TEST(WritePaperFigure, MissingDirectoryThrowsAndWritesNothing) {
  TempDir dir;
  const std::string missing = dir.path() + "/no/such/dir";
  EXPECT_THAT([&] { isowrench::WritePaperFigure(2, Figure(2), missing); },
              ThrowsMessage<isowrench::Error>(HasSubstr("'" + missing + "' does not exist")));
  EXPECT_TRUE(dir.Files().empty());
}

TEST(WriteTextFile, UnwritablePathThrowsAndLeavesNothing) {
  TempDir dir;
  const std::string path = dir.path() + "/missing/figure.svg";
  EXPECT_THAT([&] { isowrench::WriteTextFile(path, "<svg/>"); },
              ThrowsMessage<isowrench::Error>(HasSubstr(path)));
  EXPECT_TRUE(dir.Files().empty());
  // Overwriting an existing file replaces it whole.
  isowrench::WriteTextFile(dir.path() + "/a.svg", "first");
  isowrench::WriteTextFile(dir.path() + "/a.svg", "second");
  EXPECT_EQ(ReadAll(dir.path() + "/a.svg"), "second");
  EXPECT_EQ(dir.Files(), std::vector<std::string>{"a.svg"});
}

TEST(PaperFigureSvg, EmptyPanelListIsRefused) {
  EXPECT_THAT([] { isowrench::PaperFigureSvg(2, {}); },
              ThrowsMessage<isowrench::Error>(HasSubstr("no panels")));
}

}  // namespace
}  // namespace isowrench_test
