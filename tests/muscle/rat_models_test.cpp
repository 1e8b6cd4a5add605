// The published rat models of UVA-MAMP-Lab/RatHindlimb (no licence: not in the repository).
// The tests run when the files are present (ISOWRENCH_RAT_HINDLIMB_DIR, default
// /work/ext/RatHindlimb/models/osim) and are skipped otherwise.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <string>

#include "isowrench/engine.hpp"
#include "isowrench/model.hpp"
#include "isowrench/muscle.hpp"
#include "isowrench/opensim.hpp"

namespace isowrench {
namespace {

using ::testing::HasSubstr;

std::string RatFile(const std::string& name) {
  const char* dir = std::getenv("ISOWRENCH_RAT_HINDLIMB_DIR");
  return std::string(dir ? dir : "/work/ext/RatHindlimb/models/osim") + "/" + name;
}

#define SKIP_WITHOUT(path)                                                        \
  if (!std::ifstream(path)) {                                                     \
    GTEST_SKIP() << path << " is absent (RatHindlimb has no licence to ship it)"; \
  }

OpenSimImport ImportRat(const std::string& path) {
  OpenSimImportOptions options;
  options.clamp_body = "pelvis_r";
  options.endpoint_body = "foot_r";
  return ImportOpenSimFile(path, options);
}

TEST(RatModels, ThelenModelFlagsEveryMuscleOpenSimCannotEvaluate) {
  const std::string path = RatFile("rat_hindlimb.osim");
  SKIP_WITHOUT(path);
  const OpenSimImport imported = ImportRat(path);
  ASSERT_EQ(imported.description.muscles.size(), 38u);
  int flagged = 0;
  for (const MuscleSpec& m : imported.description.muscles) {
    EXPECT_EQ(m.force.model, ForceModelType::kThelen2003) << m.name;
    EXPECT_EQ(m.force.tendon_slack_length, 0.0) << m.name;
    const MuscleForceModel model(m.name, m.max_force, m.force);
    EXPECT_TRUE(model.rigid_tendon());
    for (const std::string& w : imported.warnings) {
      if (w.find("'" + m.name + "'") != std::string::npos &&
          w.find("tendon_slack_length is 0") != std::string::npos) {
        ++flagged;
      }
    }
  }
  EXPECT_EQ(flagged, 38);
}

TEST(RatModels, MillardModelEquilibriaAcrossTheKneeRange) {
  const std::string path = RatFile("rat_hindlimb_unilateral.osim");
  SKIP_WITHOUT(path);
  const OpenSimImport imported = ImportRat(path);
  const Model model(imported.description);
  ASSERT_EQ(model.muscle_count(), 38);
  Data data(model);
  const int knee = model.JointIndex("knee_r_flx");
  const double lo = model.coordinate(knee).lower, hi = model.coordinate(knee).upper;
  int rigid = 0, equilibria = 0;
  double worst = 0;
  for (int i = 0; i < model.muscle_count(); ++i) {
    const MuscleSpec& spec = model.muscle(i);
    EXPECT_EQ(spec.force.model, ForceModelType::kMillard2012) << spec.name;
    const MuscleForceModel m(spec.name, spec.max_force, spec.force);
    EXPECT_TRUE(m.opensim_limitation().empty()) << spec.name;
    rigid += m.rigid_tendon();
    Eigen::VectorXd q = model.nominal_posture();
    double guess = 0;
    for (int k = 0; k <= 30; ++k) {
      q[knee] = lo + (hi - lo) * k / 30.0;
      ASSERT_TRUE(ComputeKinematics(model, data, q, i, 1.0));
      const double length = data.muscle_length();
      const MuscleForce cold = m.Evaluate(length, 1.0), warm = m.Evaluate(length, 1.0, guess);
      guess = warm.fiber_length;
      EXPECT_FALSE(cold.opensim_gives_no_number) << spec.name;
      EXPECT_NE(cold.status, MuscleForceStatus::kNoEquilibrium) << spec.name;
      EXPECT_NEAR(cold.force, warm.force, 1e-10) << spec.name << " " << k;
      EXPECT_LE(cold.force, 1.1 * spec.max_force) << spec.name;
      if (cold.status == MuscleForceStatus::kEquilibrium) {
        ++equilibria;
        worst = std::max(worst, std::abs(cold.residual));
      }
    }
  }
  EXPECT_EQ(rigid, 5);  // R_CF, R_STp, R_GMa, R_AL, R_IP
  EXPECT_GT(equilibria, 1100);
  EXPECT_LT(worst, 1e-10);
}

}  // namespace
}  // namespace isowrench
