// `isowrench sweep` end to end: the CSV it writes equals EvaluateWrench (the KDL reference
// path) row by row, carries units in its header, orders rows with the last grid axis fastest,
// and bad input exits 1 naming the culprit without leaving a file behind.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "isowrench/isowrench.hpp"
#include "isowrench/wrap.hpp"

namespace {

constexpr double kPi = 3.14159265358979323846;

struct CliRun {
  int exit_code = -1;
  std::string output;
};

CliRun RunCli(const std::string& args, const std::filesystem::path& dir) {
  const std::filesystem::path log = dir / "cli.log";
  const std::string command =
      std::string(ISOWRENCH_CLI) + " " + args + " > " + log.string() + " 2>&1";
  const int status = std::system(command.c_str());
  CliRun run;
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream in(log);
  std::stringstream ss;
  ss << in.rdbuf();
  run.output = ss.str();
  return run;
}

std::vector<std::string> SplitCsv(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream ss(line);
  std::string cell;
  while (std::getline(ss, cell, ',')) cells.push_back(cell);
  return cells;
}

std::filesystem::path TempDir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / ("isowrench_sweep_test_" + name);
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

TEST(SweepCli, CsvRowsEqualEvaluateWrenchWithUnitsInHeader) {
  const auto dir = TempDir("rows");
  const std::string urdf = std::string(ISOWRENCH_TEST_URDF_DIR) + "/planar_2r.urdf";
  const std::string csv = (dir / "out.csv").string();
  const CliRun run = RunCli("sweep " + urdf +
                                " --grid shoulder=10:50:20 --grid elbow=0:90:45 "
                                "--stiffness-ratio 1,0.01 --muscle biarticular -o " +
                                csv,
                            dir);
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_THAT(run.output, ::testing::HasSubstr("9 postures x 2 stiffness ratios = 18 evaluations"));

  std::ifstream in(csv);
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header,
            "shoulder (deg),elbow (deg),stiffness_ratio (1),status,fx (N),fy (N),fz (N),mx (N·m),"
            "my (N·m),mz (N·m),self_motion_dims (1)");
  const isowrench::LimbDescription description = isowrench::ReadUrdfFile(urdf);
  std::vector<std::vector<std::string>> rows;
  for (std::string line; std::getline(in, line);) rows.push_back(SplitCsv(line));
  ASSERT_EQ(rows.size(), 18u);
  int row = 0;
  for (double shoulder : {10.0, 30.0, 50.0}) {
    for (double elbow : {0.0, 45.0, 90.0}) {  // the last axis varies fastest
      for (double ratio : {1.0, 0.01}) {
        const std::vector<std::string>& cells = rows[static_cast<size_t>(row++)];
        ASSERT_EQ(cells.size(), 11u);
        EXPECT_DOUBLE_EQ(std::stod(cells[0]), shoulder);
        EXPECT_DOUBLE_EQ(std::stod(cells[1]), elbow);
        EXPECT_DOUBLE_EQ(std::stod(cells[2]), ratio);
        isowrench::Vector6d s_t = description.transducer.stiffness;
        s_t.tail<3>() *= ratio;
        const isowrench::Model model(isowrench::WithTransducerStiffness(description, s_t));
        Eigen::VectorXd q = model.nominal_posture();
        q[model.JointIndex("shoulder")] = shoulder * kPi / 180;
        q[model.JointIndex("elbow")] = elbow * kPi / 180;
        const isowrench::WrenchEvaluation e = isowrench::EvaluateWrench(model, q, "biarticular");
        EXPECT_EQ(cells[3], e.statics.status == isowrench::StaticsStatus::kOk ? "ok" : "?");
        // The CSV has 10 significant digits: 1e-9 of the largest component covers rounding.
        const double scale = e.statics.wrench.cwiseAbs().maxCoeff();
        for (int k = 0; k < 6; ++k) {
          EXPECT_NEAR(std::stod(cells[static_cast<size_t>(4 + k)]), e.statics.wrench[k],
                      1e-9 * scale)
              << "row " << row << ", component " << k;
        }
      }
    }
  }
}

// A wrapping muscle: per posture, the CSV says how many wraps engage and OpenSim's warnings in
// the words of wrench/diagnose/releases; the summary (text and JSON) counts them with the first
// posture of each. Reference: the wrap library (ComputeWrappedPath) fed by the file's geometry
// built by hand at each grid posture (not the engine's path stage): the femur's point fixed,
// the tibia's turned about the knee at (40, 0, 0) mm, the sphere (10 mm, +y) centred there.
// sphere_far_side.urdf wraps the far side of a constrained sphere (negative arc, below the
// straight line) from knee about -65 to +20 degrees, and behaves elsewhere.
TEST(SweepCli, WrapWarningsPerPostureInTheCsvAndCountedInTheSummary) {
  const auto dir = TempDir("wrap");
  const std::string urdf = std::string(ISOWRENCH_TEST_WRAP_DIR) + "/sphere_far_side.urdf";
  const std::string csv = (dir / "out.csv").string();
  const CliRun text =
      RunCli("sweep " + urdf + " --grid knee=-90:40:5 --stiffness-ratio 1,0.5 -o " + csv, dir);
  ASSERT_EQ(text.exit_code, 0) << text.output;
  isowrench::WrapPathInput hand;
  hand.active = {1, 1};
  isowrench::WrapPathWrap ball;
  ball.surface.shape = isowrench::WrapShape::kSphere;
  ball.surface.radius = 0.01;
  ball.surface.quadrant = isowrench::WrapQuadrant::Parse("+y");
  ball.X_W_S.translation() = Eigen::Vector3d(0.04, 0, 0);
  ball.first = 0;
  ball.last = 1;
  hand.wraps = {ball};
  std::ifstream in(csv);
  std::string header;
  std::getline(in, header);
  EXPECT_THAT(header, ::testing::EndsWith(",self_motion_dims (1),wraps_engaged (1),wrap_warning"));
  int rows = 0, warned = 0, negative = 0, engaged = 0, clean_wrapped = 0;
  double first_negative = 1e9;
  for (std::string line; std::getline(in, line); ++rows) {
    std::vector<std::string> cells = SplitCsv(line);
    if (!line.empty() && line.back() == ',') cells.emplace_back();  // an empty last cell
    ASSERT_EQ(cells.size(), 12u) << line;
    const double knee = std::stod(cells[0]);
    hand.points = {Eigen::Vector3d(0.046, -0.009, 0.0005),
                   Eigen::Vector3d(0.04, 0, 0) +
                       Eigen::AngleAxisd(knee * kPi / 180, Eigen::Vector3d::UnitZ()) *
                           Eigen::Vector3d(-0.006, -0.009, 0)};
    isowrench::WrappedPath path;
    isowrench::ComputeWrappedPath(hand, isowrench::WrapMode::kOpenSim, path);
    EXPECT_EQ(cells[10], path.wraps[0].wrapped ? "1" : "0") << knee;
    EXPECT_EQ(cells[11], isowrench::WrapStatusText(path.status)) << knee;
    if (rows % 2 == 1) continue;  // the same posture at the second ratio
    engaged += path.wraps[0].wrapped ? 1 : 0;
    warned += path.status != 0 ? 1 : 0;
    if (path.status & isowrench::kWrapNegativeArc) {
      ++negative;
      first_negative = std::min(first_negative, knee);
    }
    clean_wrapped += path.wraps[0].wrapped && path.status == 0 ? 1 : 0;
  }
  ASSERT_EQ(rows, 54);
  // Both kinds of posture are in the grid, so the counts below can fail.
  ASSERT_GT(negative, 5);
  ASSERT_GT(clean_wrapped, 2);
  ASSERT_LT(warned, 27);
  EXPECT_THAT(text.output, ::testing::HasSubstr("wrap (opensim): knee_ball wraps at " +
                                                std::to_string(engaged) + " of 27 postures"));
  EXPECT_THAT(text.output, ::testing::HasSubstr("wrap warnings at " + std::to_string(warned) +
                                                " of 27 postures"));
  std::ostringstream first;
  first << "negative arc (OpenSim's far-side sphere wrap): " << negative
        << " postures, first at knee=" << first_negative << "°";
  EXPECT_THAT(text.output, ::testing::HasSubstr(first.str()));

  const CliRun json = RunCli("sweep " + urdf + " --grid knee=-90:40:5 --json -o " + csv, dir);
  ASSERT_EQ(json.exit_code, 0) << json.output;
  const auto j = nlohmann::json::parse(json.output);
  EXPECT_EQ(j["wrap"]["mode"], "opensim");
  EXPECT_EQ(j["wrap"]["wraps"][0]["object"], "knee_ball");
  EXPECT_EQ(j["wrap"]["wraps"][0]["wrapped_postures"], engaged);
  EXPECT_EQ(j["wrap"]["warning_postures"], warned);
  bool found = false;
  for (const auto& w : j["wrap"]["warnings"]) {
    if (w["warning"] != isowrench::WrapStatusText(isowrench::kWrapNegativeArc)) continue;
    found = true;
    EXPECT_EQ(w["postures"], negative);
    EXPECT_EQ(w["first_posture"]["knee (deg)"], first_negative);
  }
  EXPECT_TRUE(found) << json.output;
  // A muscle without wraps: no wrap columns, "wrap": null.
  const CliRun plain = RunCli("sweep " + std::string(ISOWRENCH_TEST_URDF_DIR) +
                                  "/planar_2r.urdf --grid elbow=0:90:45 --json -o " + csv,
                              dir);
  ASSERT_EQ(plain.exit_code, 0) << plain.output;
  EXPECT_TRUE(nlohmann::json::parse(plain.output)["wrap"].is_null());
}

TEST(SweepCli, UnknownGridJointExitsOneNamingItAndWritesNothing) {
  const auto dir = TempDir("bad_joint");
  const std::string csv = (dir / "out.csv").string();
  const CliRun run = RunCli("sweep " + std::string(ISOWRENCH_TEST_URDF_DIR) +
                                "/planar_2r.urdf --grid wrist=0:10:1 -o " + csv,
                            dir);
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_THAT(run.output, ::testing::HasSubstr("isowrench: error: unknown coordinate 'wrist'"));
  EXPECT_FALSE(std::filesystem::exists(csv));
}

TEST(SweepCli, NonPositiveStepAndRatioAreRejected) {
  const auto dir = TempDir("bad_step");
  const std::string urdf = std::string(ISOWRENCH_TEST_URDF_DIR) + "/planar_2r.urdf";
  const std::string csv = (dir / "out.csv").string();
  CliRun run = RunCli("sweep " + urdf + " --grid elbow=0:10:0 -o " + csv, dir);
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_THAT(run.output, ::testing::HasSubstr("step 0 degrees must be > 0"));
  run = RunCli("sweep " + urdf + " --grid elbow=0:10:5 --stiffness-ratio 1,-2 -o " + csv, dir);
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_THAT(run.output, ::testing::HasSubstr("--stiffness-ratio -2 must be finite and > 0"));
  EXPECT_FALSE(std::filesystem::exists(csv));
}

TEST(SweepCli, NoEquilibriumLeavesTheWrenchCellsEmptyAndLocksAreHonoured) {
  const auto dir = TempDir("no_equilibrium");
  const std::string urdf = std::string(ISOWRENCH_TEST_URDF_DIR) + "/rat_hindlimb_5dof.urdf";
  const std::string csv = (dir / "out.csv").string();
  // Released x and y: the in-plane hip-knee motion is a self-motion GP drives (no equilibrium).
  CliRun run = RunCli("sweep " + urdf + " --release x,y --grid knee_rz=100:110:10 -o " + csv, dir);
  ASSERT_EQ(run.exit_code, 0) << run.output;
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);  // header
  int rows = 0;
  for (; std::getline(in, line); ++rows) {
    const std::vector<std::string> cells = SplitCsv(line + ",");  // keep a trailing empty cell
    ASSERT_GE(cells.size(), 10u) << line;
    EXPECT_EQ(cells[2], "self_motion") << line;
    for (int k = 3; k < 9; ++k) EXPECT_EQ(cells[static_cast<size_t>(k)], "") << line;
  }
  EXPECT_EQ(rows, 2);
  // Locking hip_rz removes the self-motion (knee_rz alone cannot move the ankle in x-y without
  // loading the transducer): every row has an equilibrium and equals EvaluateWrench.
  run = RunCli("sweep " + urdf + " --release x,y --lock hip_rz --grid knee_rz=105:105:1 -o " + csv,
               dir);
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_THAT(run.output, ::testing::HasSubstr("locked (rigid, no dof): hip_rz"));
  std::ifstream locked(csv);
  std::getline(locked, line);
  std::getline(locked, line);
  const std::vector<std::string> cells = SplitCsv(line);
  ASSERT_GE(cells.size(), 9u) << line;
  EXPECT_EQ(cells[2], "ok") << line;
  isowrench::Model model(isowrench::WithLockedCoordinates(
      isowrench::WithReleasedDofs(isowrench::ReadUrdfFile(urdf), {"x", "y"}), {"hip_rz"}));
  const isowrench::Vector6d w =
      isowrench::EvaluateWrench(model, model.nominal_posture(), "GP").statics.wrench;
  for (int k = 0; k < 6; ++k) {
    // Ten significant digits in the CSV.
    EXPECT_NEAR(std::stod(cells[static_cast<size_t>(3 + k)]), w[k], 1e-9 * w.norm()) << k;
  }
}

}  // namespace
