// Trial CSV input (issue 16 defects 2, 4, 5): RFC 4180 files from spreadsheets and pandas
// (byte-order mark, quoted headers and fields), ';' separators and decimal commas named, values
// that cannot be a measurement refused with row and column, missing joint columns and angles
// beyond a full turn warned about. Expected postures are the CSV's degrees converted by hand.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

#include "isowrench/input_checks.hpp"
#include "isowrench/isowrench.hpp"
#include "isowrench/trial_csv.hpp"

namespace {

using isowrench::Error;
using isowrench::Trial;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

constexpr double kPi = 3.14159265358979323846;

const isowrench::Model& Rat5() {
  static const isowrench::Model model = isowrench::Model::FromUrdfFile(
      std::string(ISOWRENCH_TEST_URDF_DIR) + "/rat_hindlimb_5dof.urdf");
  return model;
}

std::vector<Trial> Read(const std::string& text, const std::string& name = "t.csv") {
  std::istringstream in(text);
  isowrench::TrialReader reader(Rat5(), in, name);
  std::vector<Trial> trials;
  Trial t;
  while (reader.Next(&t)) trials.push_back(t);
  return trials;
}

const std::string kHeader =
    "hip_rz,hip_ry,hip_rx,knee_rz,knee_rx,muscle,activation,fx,fy,fz,mx,my,mz\n";

TEST(TrialCsv, ByteOrderMarkAndQuotedHeadersAndFieldsArePandasAndSpreadsheetFiles) {
  std::string text =
      "\xEF\xBB\xBF\"hip_rz\",\"hip_ry\",\"hip_rx\",\"knee_rz\",\"knee_rx\",\"muscle\","
      "\"activation\","
      "\"fx\",\"fy\",\"fz\",\"mx\",\"my\",\"mz\"\r\n"
      "\"-110\",0,0,\"105\",0,\"GP\",\"0.5\",\"0.25\",-1e-3,0,0,0,\"2E-4\"\r\n";
  std::vector<Trial> trials = Read(text);
  ASSERT_EQ(trials.size(), 1u);
  EXPECT_DOUBLE_EQ(trials[0].q[0], -110 * kPi / 180);
  EXPECT_DOUBLE_EQ(trials[0].q[3], 105 * kPi / 180);
  EXPECT_EQ(trials[0].muscle, "GP");
  EXPECT_DOUBLE_EQ(trials[0].activation, 0.5);
  EXPECT_DOUBLE_EQ(trials[0].wrench[0], 0.25);
  EXPECT_DOUBLE_EQ(trials[0].wrench[1], -1e-3);
  EXPECT_DOUBLE_EQ(trials[0].wrench[5], 2e-4);
  EXPECT_EQ(trials[0].line, 2);
}

TEST(TrialCsv, QuotedFieldMayHoldLineBreaksAndLineNumbersFollow) {
  // A quoted comment-like field spanning two lines, then a row on line 4.
  std::string text =
      "muscle,fx,fy,fz,mx,my,mz,hip_rz,hip_ry,hip_rx,knee_rz,knee_rx\n"
      "\"G\"\"P\",1,2,3,4,5,6,0,0,0,0,0\n";
  EXPECT_THAT([&] { Read(text); },
              ThrowsMessage<Error>(AllOf(HasSubstr("t.csv:2"), HasSubstr("G\"P"))));
  std::string broken = kHeader + "0,0,0,0,0,\"GP,1,0,0,0,0,0,0\n";
  EXPECT_THAT([&] { Read(broken); },
              ThrowsMessage<Error>(AllOf(HasSubstr("t.csv:2"), HasSubstr("never closes"))));
  std::string two_lines =
      kHeader + "0,0,0,0,0,GP,1,\"0.5\n\",0,0,0,0,0\n0,0,0,0,0,GP,1,x,0,0,0,0,0\n";
  EXPECT_THAT([&] { Read(two_lines); },
              ThrowsMessage<Error>(HasSubstr("t.csv:4, column 8 'fx': 'x'")));
}

TEST(TrialCsv, SemicolonSeparatorsAreNamed) {
  std::string text = "hip_rz;knee_rz;muscle;fx;fy;fz;mx;my;mz\n-110;105;GP;0,1;0;0;0;0;0\n";
  EXPECT_THAT([&] { Read(text); },
              ThrowsMessage<Error>(AllOf(HasSubstr("t.csv:1"), HasSubstr("';' as the separator"),
                                         HasSubstr("--delimiter ';' --decimal-comma"),
                                         HasSubstr("delimiter=';', decimal_comma=True"))));
}

TEST(TrialCsv, DecimalCommasAreNamed) {
  EXPECT_THAT([&] { Read(kHeader + "-110,0,0,105,0,GP,1,\"0,25\",0,0,0,0,0\n"); },
              ThrowsMessage<Error>(AllOf(HasSubstr("t.csv:2, column 8 'fx'"),
                                         HasSubstr("'0,25' uses a decimal comma"))));
  EXPECT_THAT([&] { Read(kHeader + "-110,0,0,105,0,GP,1,0,25,0,0,0,0,0\n"); },
              ThrowsMessage<Error>(AllOf(HasSubstr("found 14"), HasSubstr("decimal commas"))));
}

TEST(TrialCsv, ValuesThatCannotBeMeasuredAreErrorsNamingRowAndColumn) {
  EXPECT_THAT([&] { Read(kHeader + "-110,0,0,105,0,GP,1,1e308,0,0,0,0,0\n"); },
              ThrowsMessage<Error>(AllOf(HasSubstr("t.csv:2, column 8 'fx'"), HasSubstr("1e308"),
                                         HasSubstr("cannot be a measured force"))));
  EXPECT_THAT([&] { Read(kHeader + "-110,0,0,105,0,GP,1,0,0,0,0,0,-2e6\n"); },
              ThrowsMessage<Error>(AllOf(HasSubstr("column 13 'mz'"), HasSubstr("moment"))));
  EXPECT_THAT([&] { Read(kHeader + "-110,0,0,105,0,GP,1.5,0,0,0,0,0,0\n"); },
              ThrowsMessage<Error>(
                  AllOf(HasSubstr("t.csv:2, column 7 'activation'"), HasSubstr("[0, 1]"))));
  EXPECT_THAT([&] { Read(kHeader + "-110,0,0,1e300,0,GP,1,0,0,0,0,0,0\n"); },
              ThrowsMessage<Error>(
                  AllOf(HasSubstr("column 4 'knee_rz'"), HasSubstr("cannot be a joint position"))));
  // The limit itself is a legal (if large) reading.
  EXPECT_EQ(Read(kHeader + "-110,0,0,105,0,GP,1,1e6,0,0,0,0,0\n").size(), 1u);
}

TEST(TrialCsv, MissingJointColumnWarnsNamingTheValueUsed) {
  isowrench::WarningCollector warnings;
  std::vector<Trial> trials =
      Read("knee_rz,hip_ry,hip_rx,knee_rx,muscle,fx,fy,fz,mx,my,mz\n0,0,0,0,GP,0,0,0,0,0,0\n");
  ASSERT_EQ(trials.size(), 1u);
  EXPECT_DOUBLE_EQ(trials[0].q[0], -110 * kPi / 180);  // the URDF's nominal hip_rz
  EXPECT_THAT(warnings.text(), AllOf(HasSubstr("no column 'hip_rz'"), HasSubstr("-110 deg")));
}

TEST(TrialCsv, AnglesBeyondAFullTurnWarnOncePerColumn) {
  isowrench::WarningCollector warnings;
  Read(kHeader + "-110,0,0,400,0,GP,1,0,0,0,0,0,0\n-110,0,0,500,0,GP,1,0,0,0,0,0,0\n");
  ASSERT_EQ(warnings.warnings().size(), 1u);
  EXPECT_THAT(warnings.text(),
              AllOf(HasSubstr("t.csv:2, column 4 'knee_rz': knee_rz = 400° (6.98132 rad) is "
                              "more than a full turn"),
                    HasSubstr("(later rows of this column are not reported)")));
}

TEST(TrialCsv, WriterAndStreamingReaderRoundTrip) {
  Trial t;
  t.q = Rat5().nominal_posture();
  t.q[4] = 0.1;
  t.muscle = "GP";
  t.activation = 0.75;
  t.wrench << 0.1, -0.2, 0.3, 1e-3, -2e-3, 3e-3;
  std::ostringstream out;
  {
    isowrench::TrialCsvWriter writer(Rat5(), out, false);
    for (int i = 0; i < 3; ++i) writer.Write(t);
  }
  std::vector<Trial> back = Read(out.str());
  ASSERT_EQ(back.size(), 3u);
  EXPECT_NEAR(back[2].q[4], 0.1, 1e-10);
  EXPECT_DOUBLE_EQ(back[2].activation, 0.75);
  EXPECT_DOUBLE_EQ(back[2].wrench[3], 1e-3);
}

}  // namespace
