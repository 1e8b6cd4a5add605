// Issue 26, item 3: lab sheets as labs export them. ';' separators with decimal commas, extra
// columns, a units row, "name (unit)" headers (isowrench's own `sweep` writes them), a preamble,
// and units converted (deg/rad, mm/m, N/mN, N·m/N·mm, %) all read to the same trials as the
// plain file; the slips a sheet can hide (radians in degree columns, a flipped sign, moments in
// N·mm) are named at load and in the fit's verdict.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "isowrench/error.hpp"
#include "isowrench/input_checks.hpp"
#include "isowrench/model.hpp"
#include "isowrench/trial_csv.hpp"

namespace {

using isowrench::Error;
using isowrench::TrialSheetOptions;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::IsEmpty;
using ::testing::Not;
using ::testing::ThrowsMessage;

const isowrench::Model& Rat() {
  static const isowrench::Model model = isowrench::Model::FromUrdfFile(
      std::string(ISOWRENCH_TEST_URDF_DIR) + "/rat_hindlimb_5dof.urdf");
  return model;
}

std::vector<isowrench::Trial> Read(const std::string& text, const TrialSheetOptions& sheet = {}) {
  std::istringstream in(text);
  isowrench::TrialReader reader(Rat(), in, "s.csv", sheet);
  std::vector<isowrench::Trial> out;
  isowrench::Trial t;
  while (reader.Next(&t)) out.push_back(t);
  return out;
}

// The reference: two trials in isowrench's own format.
const std::string kPlain =
    "hip_rz,hip_ry,hip_rx,knee_rz,knee_rx,muscle,activation,fx,fy,fz,mx,my,mz\n"
    "-110,0,0,105,0,GP,1,0.0641,-0.0249,0.0887,0.00845,-0.005,0.0365\n"
    "-100,2.5,-1,95,3,GP,0.5,0.031,-0.012,0.044,0.0042,-0.0025,0.018\n";

void ExpectSameTrials(const std::vector<isowrench::Trial>& a,
                      const std::vector<isowrench::Trial>& b, double tolerance = 0.0) {
  ASSERT_EQ(a.size(), b.size());
  for (size_t k = 0; k < a.size(); ++k) {
    EXPECT_LE((a[k].q - b[k].q).cwiseAbs().maxCoeff(), tolerance) << k;
    EXPECT_LE((a[k].wrench - b[k].wrench).cwiseAbs().maxCoeff(), tolerance) << k;
    EXPECT_EQ(a[k].muscle, b[k].muscle);
    EXPECT_NEAR(a[k].activation, b[k].activation, tolerance);
  }
}

TEST(TrialSheet, SemicolonsWithDecimalCommasReadAsThePlainFile) {
  const std::string excel =
      "hip_rz;hip_ry;hip_rx;knee_rz;knee_rx;muscle;activation;fx;fy;fz;mx;my;mz\r\n"
      "-110;0;0;105;0;GP;1;0,0641;-0,0249;0,0887;0,00845;-0,005;0,0365\r\n"
      "-100;2,5;-1;95;3;GP;0,5;0,031;-0,012;0,044;0,0042;-0,0025;0,018\r\n";
  TrialSheetOptions sheet;
  sheet.delimiter = ';';
  sheet.decimal_comma = true;
  ExpectSameTrials(Read(excel, sheet), Read(kPlain));
  // Tabs too (a copy from a spreadsheet), with empty-looking blanks around fields.
  std::string tabs = kPlain;
  std::replace(tabs.begin(), tabs.end(), ',', '\t');
  sheet = {};
  sheet.delimiter = '\t';
  ExpectSameTrials(Read(tabs, sheet), Read(kPlain));
  // Undeclared, the sheet is refused with the way to declare it.
  EXPECT_THAT([&] { Read(excel); },
              ThrowsMessage<Error>(AllOf(HasSubstr("s.csv:1: the header"),
                                         HasSubstr("uses ';' as the separator"),
                                         HasSubstr("--delimiter ';' --decimal-comma"))));
  // A decimal comma needs another delimiter.
  sheet = {};
  sheet.decimal_comma = true;
  EXPECT_THAT([&] { Read(kPlain, sheet); },
              ThrowsMessage<Error>(HasSubstr("decimal commas need another delimiter")));
}

TEST(TrialSheet, ExtraColumnsAreIgnoredWithOneWarningNamingThem) {
  const std::string lab =
      "trial,date,hip_rz,hip_ry,hip_rx,knee_rz,knee_rx,muscle,activation,stimulus,fx,fy,fz,mx,"
      "my,mz,comment\n"
      "1,2026-03-02,-110,0,0,105,0,GP,1,40 Hz,0.0641,-0.0249,0.0887,0.00845,-0.005,0.0365,ok\n"
      "2,2026-03-02,-100,2.5,-1,95,3,GP,0.5,40 Hz,0.031,-0.012,0.044,0.0042,-0.0025,0.018,\n";
  {
    isowrench::WarningCollector warnings;
    ExpectSameTrials(Read(lab), Read(kPlain));
    ASSERT_EQ(warnings.warnings().size(), 1u) << warnings.text();
    EXPECT_THAT(warnings.text(),
                AllOf(HasSubstr("s.csv:1: ignoring columns 'trial', 'date', 'stimulus', "
                                "'comment': not a joint of model 'rat_hindlimb_5dof'"),
                      HasSubstr("--ignore-columns")));
  }
  TrialSheetOptions sheet;
  sheet.ignore_columns = {"trial", "date", "stimulus", "comment"};
  isowrench::WarningCollector warnings;
  ExpectSameTrials(Read(lab, sheet), Read(kPlain));
  EXPECT_THAT(warnings.warnings(), IsEmpty());
  // A misspelt column is ignored too, and the warning suggests the name.
  std::string misspelt = kPlain;
  misspelt.replace(misspelt.find("knee_rx"), 7, "knee_rxx");
  isowrench::WarningCollector more;
  Read(misspelt);
  EXPECT_THAT(more.text(), AllOf(HasSubstr("'knee_rxx' (did you mean 'knee_rx'?)"),
                                 HasSubstr("no column 'knee_rx'")));
}

TEST(TrialSheet, UnitsRowUnderTheHeaderIsReadAsUnits) {
  std::string text = kPlain;
  text.insert(text.find('\n') + 1, "deg,deg,deg,deg,deg,,,N,N,N,N·m,N·m,N·m\n");
  ExpectSameTrials(Read(text), Read(kPlain));
  // Units that differ from the defaults are converted.
  std::string converted =
      "hip_rz,hip_ry,hip_rx,knee_rz,knee_rx,muscle,activation,fx,fy,fz,mx,my,mz\n"
      "rad,rad,rad,rad,rad,-,%,mN,mN,mN,N.mm,N.mm,N.mm\n" +
      std::string(
          "-1.919862177193763,0,0,1.832595714594046,0,GP,100,64.1,-24.9,88.7,8.45,-5,36.5\n");
  const std::vector<isowrench::Trial> a = Read(converted);
  const std::vector<isowrench::Trial> b = Read(kPlain);
  ASSERT_EQ(a.size(), 1u);
  EXPECT_LE((a[0].q - b[0].q).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_LE((a[0].wrench - b[0].wrench).cwiseAbs().maxCoeff(), 1e-16);  // a few ulp of 0.09 N
  EXPECT_EQ(a[0].activation, 1.0);
}

TEST(TrialSheet, HeadersWithUnitsInParenthesesAreReadAndConverted) {
  // isowrench sweep's header style, with its extra columns.
  const std::string sweep_like =
      "hip_rz (deg),hip_ry (deg),hip_rx (deg),knee_rz (deg),knee_rx (deg),stiffness_ratio (1),"
      "status,muscle,activation (1),fx (N),fy (N),fz (N),mx (N·m),my (N·m),mz (N·m)\n"
      "-110,0,0,105,0,1,ok,GP,1,0.0641,-0.0249,0.0887,0.00845,-0.005,0.0365\n"
      "-100,2.5,-1,95,3,1,ok,GP,0.5,0.031,-0.012,0.044,0.0042,-0.0025,0.018\n";
  isowrench::WarningCollector warnings;
  ExpectSameTrials(Read(sweep_like), Read(kPlain));
  EXPECT_THAT(warnings.text(), HasSubstr("ignoring columns 'stiffness_ratio (1)', 'status'"));
  // Radians, millimetres-newton and brackets.
  const std::string si =
      "hip_rz [rad],knee_rz (radians),muscle,fx (N),fy (N),fz (N),mx (N mm),my (Nmm),mz (N.mm)\n"
      "-1.919862177193763,1.832595714594046,GP,0.0641,-0.0249,0.0887,8.45,-5,36.5\n";
  const std::vector<isowrench::Trial> t = Read(si);
  ASSERT_EQ(t.size(), 1u);
  EXPECT_NEAR(t[0].q[0], -110 * M_PI / 180, 1e-15);
  EXPECT_NEAR(t[0].q[3], 105 * M_PI / 180, 1e-15);
  EXPECT_NEAR(t[0].wrench[3], 0.00845, 1e-16);
  EXPECT_NEAR(t[0].wrench[5], 0.0365, 1e-16);
  // A unit that is not the column's is an error naming both.
  EXPECT_THAT([] { Read("hip_rz (N),muscle,fx,fy,fz,mx,my,mz\n-110,GP,0,0,0,0,0,0\n"); },
              ThrowsMessage<Error>(HasSubstr("s.csv:1, column 1 'hip_rz (N)': unit 'N' is not a "
                                             "unit of this column (deg or rad)")));
  EXPECT_THAT(
      [] { Read("hip_rz (rad),muscle,fx,fy,fz,mx,my,mz\ndeg,,,,,,,\n-1,GP,0,0,0,0,0,0\n"); },
      ThrowsMessage<Error>(HasSubstr("the units row says 'deg' but the header says 'rad'")));
}

TEST(TrialSheet, PreambleLinesAreSkipped) {
  const std::string preamble = "ATI Nano17 export v2.1\nsampled 1 kHz; mean of 200 ms\n" + kPlain;
  TrialSheetOptions sheet;
  sheet.skip_rows = 2;
  ExpectSameTrials(Read(preamble, sheet), Read(kPlain));
}

TEST(TrialSheet, AnglesRecordedInRadiansWarnAtTheEndOfTheFile) {
  // The paper's posture in radians under degree columns: -1.92 "deg" where -110 deg was meant.
  const std::string radians =
      "hip_rz,hip_ry,hip_rx,knee_rz,knee_rx,muscle,fx,fy,fz,mx,my,mz\n"
      "-1.92,0,0,1.83,0,GP,0.0641,-0.0249,0.0887,0.00845,-0.005,0.0365\n"
      "-1.75,0.04,-0.02,1.66,0.05,GP,0.031,-0.012,0.044,0.0042,-0.0025,0.018\n";
  isowrench::WarningCollector warnings;
  Read(radians);
  EXPECT_THAT(warnings.text(),
              AllOf(HasSubstr("s.csv: the angles of hip_rz, hip_ry, hip_rx, knee_rz, knee_rx all "
                              "stay within ±1.92° of 0 while the model's posture is hip_rz = "
                              "-110°, knee_rz = 105°: recorded in radians?"),
                    HasSubstr("'hip_rz (rad)'")));
  isowrench::WarningCollector none;
  Read(kPlain);
  EXPECT_THAT(none.warnings(), IsEmpty());
}

// Measured = -1 x, 1000 x the prediction: named with the axes and the factors. The prediction
// is the model's own (EvaluateWrench through PredictTrials); the data add 1 % noise.
TEST(TrialSheet, SignAndScaleSlipsAreNamedWithTheirAxes) {
  isowrench::SimulationOptions o;
  o.postures = 30;
  o.noise_force = 0.0005;
  o.noise_moment = 1e-5;
  const std::vector<isowrench::Trial> clean =
      isowrench::SimulateTrials(Rat(), isowrench::ApplyEffects(Rat().description(), {}), o);
  const isowrench::Prediction p = isowrench::PredictTrials(Rat(), clean);
  EXPECT_THAT(isowrench::UnitSlips(Rat(), clean, p.wrench), IsEmpty());
  std::vector<isowrench::Trial> flipped = clean, milli = clean;
  for (isowrench::Trial& t : flipped) t.wrench = -t.wrench;
  for (isowrench::Trial& t : milli) t.wrench.tail<3>() *= 1000.0;
  const std::string f = ::testing::PrintToString(isowrench::UnitSlips(Rat(), flipped, p.wrench));
  EXPECT_THAT(f, AllOf(HasSubstr("measured = -1 x predicted on fx, fy, fz (least-squares factors "
                                 "-1"),
                       HasSubstr("measured = -1 x predicted on mx, my, mz"),
                       HasSubstr("sign convention?")));
  const std::string m = ::testing::PrintToString(isowrench::UnitSlips(Rat(), milli, p.wrench));
  EXPECT_THAT(m, AllOf(HasSubstr("measured = 1000 x predicted on mx, my, mz"),
                       HasSubstr("moments in N·mm?"), Not(HasSubstr("on fx"))));
}

// The fit's verdict names the slip (it used to blame muscle paths): moments written in N·mm,
// and angles recorded in radians, each in a file the fit reads.
TEST(TrialSheet, FitVerdictNamesTheLikelySlip) {
  isowrench::SimulationOptions o;
  o.postures = 30;
  std::vector<isowrench::Trial> trials =
      isowrench::SimulateTrials(Rat(), isowrench::ApplyEffects(Rat().description(), {}), o);
  std::vector<isowrench::Trial> milli = trials, radians = trials;
  for (isowrench::Trial& t : milli) t.wrench.tail<3>() *= 1000.0;
  for (isowrench::Trial& t : radians) t.q *= M_PI / 180.0;  // the file shows the radian values
  isowrench::FitOptions fit;
  fit.max_rounds = 1;
  for (const auto& [data, slip] :
       std::vector<std::pair<std::vector<isowrench::Trial>*, std::string>>{
           {&milli, "likely slip: measured = 1000 x predicted on mx, my, mz"},
           {&radians,
            "likely slip: the angles of hip_rz, hip_ry, hip_rx, knee_rz, knee_rx all "
            "stay within"}}) {
    const std::string path = ::testing::TempDir() + "slip.csv";
    isowrench::WriteTrialsCsv(Rat(), *data, path);
    isowrench::WarningCollector warnings;  // the reader's own radian warning
    const isowrench::FitReport r = isowrench::FitEffectsCsv(Rat(), path, fit);
    EXPECT_THAT(r.verdict_message, HasSubstr(slip)) << r.verdict_message;
    std::remove(path.c_str());
  }
}

}  // namespace
