// Issue 26, item 5: what the command line and Python share lives in the library
// (include/isowrench/frontend.hpp): one loader, one place for overrides, one syntax for lists and
// assignments, one posture-from-values, one simulation into a CSV with one set of defaults.

#include "isowrench/frontend.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <sstream>

#include "isowrench/error.hpp"
#include "isowrench/input_checks.hpp"

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
