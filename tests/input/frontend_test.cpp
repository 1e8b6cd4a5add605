// Issue 26, item 5: what the command line and Python share lives in the library
// (include/isowrench/frontend.hpp): one loader, one place for overrides, one syntax for lists and
// assignments, one posture-from-values, one simulation into a CSV with one set of defaults.

#include "isowrench/frontend.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "isowrench/error.hpp"
#include "isowrench/input_checks.hpp"
#include "isowrench/statics.hpp"

namespace {

using isowrench::Error;
using ::testing::AllOf;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

const std::string kRat5 = std::string(ISOWRENCH_TEST_URDF_DIR) + "/rat_hindlimb_5dof.urdf";

TEST(Frontend, OverridesNameTheOptionAsTheUserTypedIt) {
  isowrench::ModelOverrides o;
  o.base_stiffness = 1e308;
  const isowrench::LimbDescription d = isowrench::LoadLimb(kRat5);
  EXPECT_THAT([&] { isowrench::ApplyOverrides(d, o); },
              ThrowsMessage<Error>(HasSubstr("--base-stiffness: stiffness 1e+308 exceeds")));
  EXPECT_THAT([&] { isowrench::ApplyOverrides(d, o, isowrench::OptionStyle::kPython); },
              ThrowsMessage<Error>(HasSubstr("base_stiffness: stiffness 1e+308 exceeds")));
  isowrench::ModelOverrides both;
  both.transducer_preset = "jr3";
  both.transducer_stiffness = isowrench::Vector6d::Constant(1e6);
  EXPECT_THAT([&] { isowrench::ApplyOverrides(d, both, isowrench::OptionStyle::kPython); },
              ThrowsMessage<Error>(HasSubstr("give either transducer or transducer_stiffness")));
}

TEST(Frontend, OverridesApplyInOnePlace) {
  isowrench::ModelOverrides o;
  EXPECT_TRUE(o.empty());
  o.released = isowrench::DofMask::Parse("rz");
  o.transducer_preset = "ati-mini40";
  o.base_stiffness = 2e5;
  o.joint_stiffness = {{"knee_rx", 3.0}};
  EXPECT_FALSE(o.empty());
  const isowrench::Model m(isowrench::ApplyOverrides(isowrench::LoadLimb(kRat5), o));
  EXPECT_EQ(m.transducer().released.ToString(), "rz");
  EXPECT_EQ(m.transducer().stiffness, isowrench::TransducerPreset("ati-mini40"));
  EXPECT_EQ(m.joint_stiffness()[m.JointIndex("base_x")], 2e5);
  EXPECT_EQ(m.joint_stiffness()[m.JointIndex("knee_rx")], 3.0);
}

TEST(Frontend, ListsAssignmentsAndVectorsHaveOneSyntax) {
  EXPECT_THAT(isowrench::ParseList(" GP, BF,,VL "), ElementsAre("GP", "BF", "VL"));
  EXPECT_EQ(isowrench::ParseAssignment("knee_rx = 2.5", "--joint-stiffness"),
            std::make_pair(std::string("knee_rx"), 2.5));
  EXPECT_THAT([] { isowrench::ParseAssignment("knee_rx", "--joint-stiffness"); },
              ThrowsMessage<Error>(HasSubstr("--joint-stiffness 'knee_rx' is not name=value")));
  EXPECT_THAT([] { isowrench::ParseTransducerStiffness("1,2,3", "transducer"); },
              ThrowsMessage<Error>(HasSubstr("transducer needs 6 values")));
  isowrench::OpenSimImportOptions options;
  isowrench::ParseEndpoint("foot:0.01,-0.005,0", options);
  EXPECT_EQ(options.endpoint_body, "foot");
  EXPECT_EQ(options.endpoint_point, Eigen::Vector3d(0.01, -0.005, 0));
}

TEST(Frontend, PostureFromValuesChecksAndWarnsAsTheCommandLine) {
  const isowrench::Model m = isowrench::Model::FromUrdfFile(kRat5);
  std::vector<std::string> warnings;
  Eigen::VectorXd q = isowrench::PostureFromValues(m, m.nominal_posture(), {{"knee_rz", -110.0}},
                                                   nullptr, &warnings);
  EXPECT_EQ(q[m.JointIndex("knee_rz")], -110.0);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_THAT(warnings[0], HasSubstr("q['knee_rz']: knee_rz = -6302.54° (-110 rad) is more than "
                                     "a full turn (degrees where radians were meant?)"));
  // The same value typed on the command line in degrees is plausible.
  q = isowrench::PostureFromUserText(m, m.nominal_posture(), "knee_rz=-110", &warnings);
  EXPECT_TRUE(warnings.empty());
  EXPECT_NEAR(q[m.JointIndex("knee_rz")], -110 * M_PI / 180, 1e-15);
  Eigen::VectorXd nan = m.nominal_posture();
  nan[2] = std::nan("");
  EXPECT_THAT([&] { isowrench::PostureFromValues(m, m.nominal_posture(), {}, &nan, nullptr); },
              ThrowsMessage<Error>(HasSubstr("q['hip_rx'] is nan")));
  EXPECT_THAT(
      [&] {
        isowrench::PostureFromValues(m, m.nominal_posture(), {{"kne_rz", 1}}, nullptr, nullptr);
      },
      ThrowsMessage<Error>(HasSubstr("did you mean 'knee_rz'?")));
}

TEST(Frontend, OsimWithoutBodiesIsAnErrorNamingBothWays) {
  EXPECT_THAT([] { isowrench::LoadLimb("model.osim"); },
              ThrowsMessage<Error>(AllOf(HasSubstr("--clamp"), HasSubstr("clamp_body="))));
}

TEST(Frontend, SimulationToCsvIsTheStreamedWriterWithTheLibraryDefaults) {
  const isowrench::Model m = isowrench::Model::FromUrdfFile(kRat5);
  const isowrench::SimulationOptions defaults;
  EXPECT_EQ(defaults.postures, 50);
  EXPECT_EQ(defaults.seed, 1u);
  const std::string path = ::testing::TempDir() + "frontend_sim.csv";
  isowrench::SimulationOptions o;
  o.postures = 7;
  const isowrench::SimulationRun run = isowrench::SimulateToCsv(m, {"base_isotropic=2e5"}, o, path);
  EXPECT_EQ(run.trials, 7);
  EXPECT_THAT(run.json, AllOf(HasSubstr("\"trials\": 7"), HasSubstr("\"id\": \"base_isotropic\"")));
  // The file is the one WriteTrialsCsv writes for SimulateTrials' trials (same seed, same data).
  std::ostringstream expected;
  isowrench::WriteTrialsCsv(
      m, isowrench::SimulateTrials(m, isowrench::ApplyEffects(m.description(), run.effects), o),
      expected);
  std::ifstream in(path);
  std::stringstream written;
  written << in.rdbuf();
  EXPECT_EQ(written.str(), expected.str());
  std::remove(path.c_str());
}

}  // namespace

namespace {

// simulate --postures: with no noise and no jitter, each simulated trial is the true model's
// Eq. 10 wrench at the sheet's posture, muscle and activation (EvaluateWrench, independently).
TEST(PostureSheet, SimulationAtASheetIsTheTrueWrenchAtEachRow) {
  const isowrench::Model m =
      isowrench::Model::FromUrdfFile(std::string(ISOWRENCH_TEST_URDF_DIR) + "/planar_2r.urdf");
  const std::string sheet = ::testing::TempDir() + "sheet.csv";
  {
    std::ofstream out(sheet);
    out << "# two rows, two muscles, one without an activation, empty measured columns\n"
        << "shoulder,elbow,muscle,activation,fx,fy,fz,mx,my,mz\n"
        << "10,80,elbow_flexor,0.5,,,,,,\n"
        << "-20,45,biarticular,,,,,,,\n";
  }
  const std::vector<isowrench::Trial> rows = isowrench::ReadPostureSheet(m, sheet);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].muscle, "elbow_flexor");
  EXPECT_EQ(rows[0].activation, 0.5);
  EXPECT_TRUE(std::isnan(rows[1].activation));  // not given: drawn by the simulation
  isowrench::SimulationOptions o;
  o.noise_force = o.noise_moment = 0;
  o.activation_min = o.activation_max = 0.8;  // what a row without activation gets
  isowrench::SimulateAtPostureSheet(m, sheet, 0, /*keep_ranges=*/false, &o);
  EXPECT_EQ(o.postures, 2);
  EXPECT_EQ(o.joint_range, 0.0);
  const std::vector<isowrench::Trial> simulated =
      isowrench::SimulateTrials(m, isowrench::ApplyEffects(m.description(), {}), o);
  ASSERT_EQ(simulated.size(), 2u);
  const double activation[2] = {0.5, 0.8};
  for (int i = 0; i < 2; ++i) {
    const isowrench::Trial& t = simulated[static_cast<size_t>(i)];
    EXPECT_EQ(t.muscle, rows[static_cast<size_t>(i)].muscle);
    EXPECT_EQ(t.q, rows[static_cast<size_t>(i)].q);
    const isowrench::WrenchEvaluation e =
        isowrench::EvaluateWrench(m, t.q, t.muscle, activation[i]);
    EXPECT_LE((t.wrench - e.statics.wrench).cwiseAbs().maxCoeff(),
              1e-12 * e.statics.wrench.cwiseAbs().maxCoeff())
        << t.wrench.transpose() << "\n"
        << e.statics.wrench.transpose();
  }
  // The rows in degrees: shoulder 10°, elbow 80° of the first row.
  EXPECT_NEAR(rows[0].q[0], 10 * M_PI / 180, 1e-15);
  EXPECT_NEAR(rows[0].q[1], 80 * M_PI / 180, 1e-15);
  // design -o writes what ReadPostureSheet reads back.
  const std::string written = ::testing::TempDir() + "written.csv";
  {
    std::ofstream out(written);
    out << isowrench::PostureSheetText(m, rows, "a test");
  }
  const std::vector<isowrench::Trial> back = isowrench::ReadPostureSheet(m, written);
  ASSERT_EQ(back.size(), 2u);
  EXPECT_LE((back[0].q - rows[0].q).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_EQ(back[1].muscle, "biarticular");
  EXPECT_EQ(back[1].activation, 1.0);  // written as 1 where the source had none
  std::remove(sheet.c_str());
  std::remove(written.c_str());
}

}  // namespace
