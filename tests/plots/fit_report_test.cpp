// Tests of the fit report renderers (include/isowrench/plots.hpp): the HTML and markdown carry
// the before/after numbers of the FitReport they came from, the inline SVG plots parse and put
// each trial where its numbers say, nothing is fetched from the network, and a failed write
// leaves no file.

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <tinyxml2.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "isowrench/error.hpp"
#include "isowrench/identification.hpp"
#include "isowrench/model.hpp"
#include "isowrench/plots.hpp"
#include "svg_test_utils.hpp"

namespace isowrench_test {
namespace {

namespace fs = std::filesystem;
using isowrench::Vector6d;
using ::testing::HasSubstr;
using ::testing::Not;
using ::testing::ThrowsMessage;

// 4 significant digits as %g prints them (the tests run in the "C" locale): an independent
// rendering of the number the report must show.
std::string Format4(double v) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.4g", v);
  return buffer;
}

isowrench::Effect BaseEffect() {
  isowrench::Effect e;
  e.kind = "base_isotropic";
  e.id = "base_isotropic";
  e.description = "Base compliance, one stiffness for x y z.";
  isowrench::EffectParameter k;
  k.name = "k_base";
  k.unit = "N/m";
  k.scale = isowrench::ParameterScale::kLog10;
  e.parameters = {k};
  return e;
}

isowrench::Effect OffsetEffect() {
  isowrench::Effect e;
  e.kind = "sensor_offset";
  e.stage = isowrench::EffectStage::kMeasurement;
  e.id = "sensor_offset";
  e.description = "Constant wrench added to every reading.";
  for (const char* n : {"fx", "fy", "fz", "mx", "my", "mz"}) {
    isowrench::EffectParameter p;
    p.name = n;
    p.unit = n[0] == 'f' ? "N" : "N·m";
    e.parameters.push_back(p);
  }
  e.post_processing = true;
  return e;
}

// A report with numbers of at most 4 significant digits, so their printed form is exact.
isowrench::FitReport MakeReport() {
  isowrench::FitReport r;
  r.model_name = "rat_hindlimb_5dof";
  r.source = "trials.csv";
  r.trial_count = 4;
  r.sd_stated = true;
  r.before.rms << 0.1234, 0.2345, 0.03456, 0.001234, 0.002345, 0.003456;
  r.after.rms << 0.005012, 0.004987, 0.005003, 0.0001011, 0.00009876, 0.0001002;
  r.before.r2 << 0.5, 0.25, 0.125, 0.75, 0.375, 0.625;
  r.after.r2 << 0.9991, 0.9992, 0.9993, 0.9994, 0.9995, 0.9996;
  r.before.normalized = r.before.rms * 100;
  r.after.normalized << 1.002, 0.9974, 1.001, 1.011, 0.9876, 1.002;
  r.before.chi2 = 81230;
  r.after.chi2 = 23.5;
  r.before.reduced_chi2 = 3384;
  r.after.reduced_chi2 = 1.068;
  isowrench::CandidateFit win;
  win.effect = BaseEffect();
  win.values = {12340};
  win.standard_errors = {56.7};
  win.bic = 40.25;
  win.aic = 38.5;
  win.delta_bic = 81190;
  win.cv_status = isowrench::CvStatus::kDone;
  win.cv_error = 1.125;
  win.converged = true;
  win.accepted = true;
  win.verdict = "chosen";
  isowrench::CandidateFit lose = win;
  lose.effect = OffsetEffect();
  lose.values = {0.01, 0.02, 0.03, 0.0004, 0.0005, 0.0006};
  lose.standard_errors = {};
  lose.bic = 70120;
  lose.delta_bic = 11150;
  lose.identifiable = false;
  lose.identifiability = "fz and mx correlated (0.995)";
  lose.accepted = false;
  lose.verdict = "BIC 7.012e+04 worse than the winner";
  isowrench::FitRound round;
  round.index = 1;
  round.before = r.before;
  round.bic_before = 81230;
  round.cv_before = 3390;
  round.candidates = {win, lose};
  round.chosen = 0;
  round.summary = "base_isotropic explains most of the residual.";
  r.rounds = {round};
  r.chosen = {{BaseEffect(), {12340}}};
  r.chosen_fits = {win};
  r.verdict = isowrench::FitVerdict::kExplained;
  r.verdict_message = "the residual is at the noise level";
  for (int i = 0; i < 4; ++i) {
    isowrench::TrialResidual t;
    t.line = 2 + i;
    t.muscle = "GP";
    t.activation = 0.5 + 0.125 * i;
    t.measured << 0.25 * (i + 1), -0.5, 0.125 * i, 0.004, -0.002 * i, 0.01;
    t.before << 0.1 * (i + 1), -0.05, 0.02, 0.001, 0.0, -0.002 * i;
    t.after << 0.001 * i, -0.002, 0.0, 0.00001, 0.0, 0.00002;
    t.normalized_before = 10.0 * (i + 1);
    t.normalized_after = 1.0;
    r.trials.push_back(t);
  }
  r.seconds = 1.5;
  return r;
}

// Every <svg>...</svg> block of an HTML page.
std::vector<std::string> SvgBlocks(const std::string& html) {
  std::vector<std::string> out;
  size_t at = 0;
  while ((at = html.find("<svg", at)) != std::string::npos) {
    size_t end = html.find("</svg>", at);
    out.push_back(html.substr(at, end + 6 - at));
    at = end;
  }
  return out;
}

TEST(FitReportHtml, ContainsTheBeforeAndAfterNumbersOfTheFit) {
  const isowrench::FitReport r = MakeReport();
  const std::string html = isowrench::FitReportHtml(r);
  // RMS before/after per component with units, and the reduction of fx: (0.1234-0.005012)/0.1234.
  for (const char* s :
       {"0.1234 N", "0.2345 N", "0.03456 N", "0.001234 N·m", "0.002345 N·m", "0.003456 N·m",
        "0.005012 N", "0.004987 N", "0.0001011 N·m", "9.876e-05 N·m", "95.9 %"}) {
    EXPECT_THAT(html, HasSubstr(std::string("<td>") + s)) << s;
  }
  // R², noise multiples, chi².
  EXPECT_THAT(html, HasSubstr("<td>0.9991</td>"));
  EXPECT_THAT(html, HasSubstr("<td>12.34</td>"));  // normalized before fx = 0.1234 * 100
  EXPECT_THAT(html, HasSubstr("<td>8.123e+04</td>"));
  EXPECT_THAT(html, HasSubstr("reduced χ² 1.068"));
  // Verdict, chosen effect with value ± SE and unit, the ranked candidates in order.
  EXPECT_THAT(html, HasSubstr("Verdict: explained — the residual is at the noise level"));
  EXPECT_THAT(html, HasSubstr("k_base = 1.234e+04 ± 57 N/m"));
  const size_t first =
      html.find("<tr class=\"chosen\"><td>1</td><td>base_isotropic</td><td>8.119e+04</td>");
  const size_t second = html.find("<td>2</td><td>sensor_offset</td><td>1.115e+04</td>");
  ASSERT_NE(first, std::string::npos);
  ASSERT_NE(second, std::string::npos);
  EXPECT_LT(first, second);
  EXPECT_THAT(html, HasSubstr("no: fz and mx correlated (0.995)"));
  EXPECT_THAT(html, HasSubstr("BIC 7.012e+04 worse than the winner"));
}

TEST(FitReportHtml, ScatterAndResidualPlotsPlaceEveryTrialAtItsNumbers) {
  const isowrench::FitReport r = MakeReport();
  const std::string html = isowrench::FitReportHtml(r);
  const std::vector<std::string> blocks = SvgBlocks(html);
  // 6 scatter + 6 residual plots + glyphs of the 3 worst trials.
  ASSERT_EQ(blocks.size(), 15u);
  for (size_t b = 0; b < blocks.size(); ++b) {
    tinyxml2::XMLDocument doc;
    ASSERT_EQ(doc.Parse(blocks[b].c_str()), tinyxml2::XML_SUCCESS)
        << "block " << b << ": " << doc.ErrorStr();
    if (b >= 12) continue;
    const int component = static_cast<int>(b % 6);
    const bool scatter = b < 6;
    for (const auto* series : ByClass(doc.RootElement(), "series")) {
      const bool before = HasClass(series, "before");
      const auto points = ByClass(series, "point");
      ASSERT_EQ(points.size(), r.trials.size());
      for (size_t i = 0; i < points.size(); ++i) {
        const isowrench::TrialResidual& t = r.trials[i];
        const double residual = before ? t.before[component] : t.after[component];
        // Scatter: x = measured, y = predicted = measured - residual. Residual plot: x = trial.
        const double x = scatter ? t.measured[component] : static_cast<double>(i + 1);
        const double y = scatter ? t.measured[component] - residual : residual;
        EXPECT_DOUBLE_EQ(Num(points[i], "data-x"), x);
        EXPECT_DOUBLE_EQ(Num(points[i], "data-y"), y);
      }
    }
  }
  // The glyph blocks draw the worst trial first (normalized_before 40: trial 4), with the
  // measured wrench and both predictions.
  tinyxml2::XMLDocument doc;
  ASSERT_EQ(doc.Parse(blocks[12].c_str()), tinyxml2::XML_SUCCESS);
  EXPECT_THAT(AllText(doc.RootElement()), HasSubstr("trial 4 (line 5), GP at activation 0.875"));
  const auto which = ByClass(doc.RootElement(), "trial-glyph");
  ASSERT_EQ(which.size(), 3u);
  const Vector6d expected[3] = {r.trials[3].measured, r.trials[3].measured - r.trials[3].before,
                                r.trials[3].measured - r.trials[3].after};
  for (int k = 0; k < 3; ++k) {
    const auto vec = ByClass(which[k], "vector");
    ASSERT_EQ(vec.size(), 2u);  // force, moment
    EXPECT_NEAR(Num(vec[0], "data-x"), expected[k][0], 1e-15);
    EXPECT_NEAR(Num(vec[1], "data-z"), expected[k][5], 1e-15);
  }
}

TEST(FitReportHtml, IsSelfContained) {
  const std::string html = isowrench::FitReportHtml(MakeReport());
  EXPECT_THAT(html, Not(HasSubstr("<script")));
  EXPECT_THAT(html, Not(HasSubstr("src=")));
  EXPECT_THAT(html, Not(HasSubstr("href")));
  EXPECT_THAT(html, Not(HasSubstr("<link")));
  // The only URL is the SVG namespace name on each inline <svg>.
  std::string without_ns = html;
  const std::string ns = "xmlns=\"http://www.w3.org/2000/svg\"";
  for (size_t at = without_ns.find(ns); at != std::string::npos; at = without_ns.find(ns, at)) {
    without_ns.erase(at, ns.size());
  }
  EXPECT_THAT(without_ns, Not(HasSubstr("http")));
}

TEST(FitReportMarkdown, ContainsTheSameNumbersAsTheHtml) {
  const isowrench::FitReport r = MakeReport();
  const std::string md = isowrench::FitReportMarkdown(r);
  for (const char* s : {"| fx (N) | 0.1234 N | 0.005012 N | 95.9 % |", "0.0001011 N·m",
                        "**Verdict: explained —", "| 1 | **base_isotropic** | 8.119e+04 |",
                        "| 2 | sensor_offset | 1.115e+04 |", "k_base = 1.234e+04 ± 57 N/m"}) {
    EXPECT_THAT(md, HasSubstr(s)) << s;
  }
  // Worst trial first in the per-trial table: trial 4, measured fx 1, predicted before 1-0.4.
  EXPECT_THAT(
      md, HasSubstr("| 4 | 5 | GP | 0.875 | [1 -0.5 0.375 0.004 -0.006 0.01] | [0.6 -0.45 0.355"));
}

TEST(FitReportHtml, ReportWithoutTrialsOrEffectsStillRenders) {
  isowrench::FitReport r;
  r.model_name = "empty";
  const std::string html = isowrench::FitReportHtml(r);
  EXPECT_THAT(html, HasSubstr("None: no candidate earned its parameters."));
  EXPECT_THAT(isowrench::FitReportMarkdown(r), HasSubstr("Effects added: none."));
}

TEST(WriteFitReport, FilesHoldTheRenderedReportAndAFailedWriteLeavesNothing) {
  std::string pattern = (fs::temp_directory_path() / "isowrench-report-XXXXXX").string();
  const std::string dir = ::mkdtemp(pattern.data());
  const isowrench::FitReport r = MakeReport();
  EXPECT_THAT([&] { isowrench::WriteFitReportHtml(r, dir + "/missing/report.html"); },
              ThrowsMessage<isowrench::Error>(HasSubstr("missing/report.html")));
  EXPECT_THAT([&] { isowrench::WriteFitReportMarkdown(r, dir + "/missing/report.md"); },
              ThrowsMessage<isowrench::Error>(HasSubstr("missing/report.md")));
  EXPECT_TRUE(fs::is_empty(dir));
  isowrench::WriteFitReportHtml(r, dir + "/report.html");
  isowrench::WriteFitReportMarkdown(r, dir + "/report.md");
  std::stringstream html, md;
  html << std::ifstream(dir + "/report.html").rdbuf();
  md << std::ifstream(dir + "/report.md").rdbuf();
  EXPECT_EQ(html.str(), isowrench::FitReportHtml(r));
  EXPECT_EQ(md.str(), isowrench::FitReportMarkdown(r));
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 2);
  fs::remove_all(dir);
}

TEST(FitReportHtml, ResidualVsPosturePlotsEachJointThatVaries) {
  const isowrench::Model model = isowrench::Model::FromUrdfFile(
      std::string(ISOWRENCH_TEST_URDF_DIR) + "/rat_hindlimb_5dof.urdf");
  const isowrench::FitReport r = MakeReport();
  // The report's four trials at postures where only hip_rz and knee_rz vary.
  std::vector<isowrench::Trial> trials;
  for (size_t k = 0; k < r.trials.size(); ++k) {
    isowrench::Trial t;
    t.q = model.nominal_posture();
    t.q[model.JointIndex("hip_rz")] += 0.1 * static_cast<double>(k);
    t.q[model.JointIndex("knee_rz")] -= 0.05 * static_cast<double>(k);
    t.line = r.trials[k].line;
    trials.push_back(t);
  }
  isowrench::FitReportOptions options;
  options.trials = &trials;
  options.model = &model;
  const std::string html = isowrench::FitReportHtml(r, options);
  EXPECT_THAT(html, HasSubstr("<div class=\"plot posture\" data-joint=\"hip_rz\">"));
  EXPECT_THAT(html, HasSubstr("<div class=\"plot posture\" data-joint=\"knee_rz\">"));
  EXPECT_THAT(html, Not(HasSubstr("data-joint=\"hip_ry\"")));  // constant: nothing to show
  // The hip_rz plot: x = posture in degrees, y = the trial's residual size.
  const size_t at = html.find("data-joint=\"hip_rz\">");
  const std::string block = SvgBlocks(html.substr(at))[0];
  tinyxml2::XMLDocument doc;
  ASSERT_EQ(doc.Parse(block.c_str()), tinyxml2::XML_SUCCESS);
  for (const auto* series : ByClass(doc.RootElement(), "series")) {
    const bool before = HasClass(series, "before");
    const auto points = ByClass(series, "point");
    ASSERT_EQ(points.size(), trials.size());
    for (size_t k = 0; k < points.size(); ++k) {
      EXPECT_NEAR(Num(points[k], "data-x"), trials[k].q[model.JointIndex("hip_rz")] * 180.0 / M_PI,
                  1e-12);
      EXPECT_EQ(Num(points[k], "data-y"),
                before ? r.trials[k].normalized_before : r.trials[k].normalized_after);
    }
  }
  // Trials that are not the fit's are refused, naming the mismatch.
  trials.pop_back();
  EXPECT_THAT([&] { isowrench::FitReportHtml(r, options); },
              ThrowsMessage<isowrench::Error>(HasSubstr("3 trials given for a report of 4")));
}

TEST(FitReportHtml, PlotsOfConstantOrNearlyConstantLargeValuesStillRender) {
  // Axis ranges far below the spacing of doubles near the values (1e12 N +- 1e-9 N), and a
  // component with no spread at all: the tick loop must end and every point must still parse.
  isowrench::FitReport r = MakeReport();
  for (size_t i = 0; i < r.trials.size(); ++i) {
    r.trials[i].measured[0] = 1e12 + 1e-9 * static_cast<double>(i);
    r.trials[i].before[1] = 0.0;
    r.trials[i].after[1] = 0.0;
  }
  const std::vector<std::string> blocks = SvgBlocks(isowrench::FitReportHtml(r));
  ASSERT_EQ(blocks.size(), 15u);
  for (const std::string& b : blocks) {
    tinyxml2::XMLDocument doc;
    EXPECT_EQ(doc.Parse(b.c_str()), tinyxml2::XML_SUCCESS);
  }
}

// End to end: a real fit (base compliance hidden in simulated data) rendered as HTML carries
// that fit's own before/after RMS per component and plots every trial.
TEST(FitReportHtml, RealFitReportCarriesItsOwnBeforeAndAfterNumbers) {
  const isowrench::Model model = isowrench::Model::FromUrdfFile(
      std::string(ISOWRENCH_TEST_URDF_DIR) + "/rat_hindlimb_5dof.urdf");
  isowrench::SimulationOptions sim;
  sim.postures = 20;  // small: a fast end-to-end check, not a study of the fit
  sim.seed = 11;
  const std::vector<isowrench::Trial> trials = isowrench::SimulateTrials(
      model,
      isowrench::ApplyEffects(model.description(),
                              {isowrench::ParseEffectAssignment(model, "base_isotropic=1e4")}),
      sim);
  isowrench::FitOptions options;
  options.candidates = {"base_isotropic", "sensor_offset"};
  options.max_rounds = 1;
  const isowrench::FitReport report = isowrench::FitEffects(model, trials, options);
  const std::string html = isowrench::FitReportHtml(report);
  for (int i = 0; i < 6; ++i) {
    const std::string unit = i < 3 ? " N" : " N·m";
    EXPECT_THAT(html, HasSubstr("<td>" + Format4(report.before.rms[i]) + unit + "</td>")) << i;
    EXPECT_THAT(html, HasSubstr("<td>" + Format4(report.after.rms[i]) + unit + "</td>")) << i;
  }
  for (const isowrench::AppliedEffect& e : report.chosen) EXPECT_THAT(html, HasSubstr(e.effect.id));
  // Each scatter plot has one "before" and one "after" point per trial.
  const std::vector<std::string> blocks = SvgBlocks(html);
  ASSERT_GE(blocks.size(), 12u);
  tinyxml2::XMLDocument doc;
  ASSERT_EQ(doc.Parse(blocks[0].c_str()), tinyxml2::XML_SUCCESS);
  EXPECT_EQ(ByClass(doc.RootElement(), "point").size(), 2 * trials.size());
}

}  // namespace
}  // namespace isowrench_test
