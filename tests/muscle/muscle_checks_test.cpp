// Bad input of issue 28 item 7 not caught before: a tendon slack length longer than the
// musculotendon path at every posture (a warning when the Model is built), and an activation
// outside [0, 1] given to Evaluate / EvaluateBatch for a constant-force muscle.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "isowrench/engine.hpp"
#include "isowrench/error.hpp"
#include "isowrench/input_checks.hpp"
#include "isowrench/kinematics.hpp"
#include "isowrench/model.hpp"

namespace isowrench {
namespace {

using ::testing::HasSubstr;

LimbDescription ChecksLimb() {
  return ReadUrdfFile(std::string(ISOWRENCH_TEST_DATA_DIR) + "/force_model_limb.urdf");
}

MuscleSpec& ChecksMuscle(LimbDescription& d, const std::string& name) {
  for (MuscleSpec& m : d.muscles) {
    if (m.name == name) return m;
  }
  throw Error("no muscle " + name);
}

/// An upper bound on GP's path length at any posture, by the triangle inequality: origin to the
/// hip centre (the world origin), hip to knee (31 mm), knee to the insertion on the tibia.
double ChecksLongestPossiblePath(const MuscleSpec& m) {
  return m.path.front().position.norm() + 0.031 + m.path.back().position.norm();
}

TEST(TendonCheck, ATendonLongerThanThePathEverywhereIsAWarningNamingTheMuscle) {
  LimbDescription d = ChecksLimb();
  d.name = "tendon_check_everywhere";  // (the warning is given once per model and muscle)
  MuscleSpec& m = ChecksMuscle(d, "GP_thelen");
  const double bound = ChecksLongestPossiblePath(m);
  EXPECT_NEAR(bound, 0.0648, 1e-4);
  m.force.tendon_slack_length = bound + 0.001;
  {
    WarningCollector warnings;
    Model model(d);
    EXPECT_THAT(warnings.text(), HasSubstr("muscle 'GP_thelen': tendon_slack_length 65.75 mm"));
    EXPECT_THAT(warnings.text(),
                HasSubstr("is longer than its musculotendon path at every posture"));
    EXPECT_THAT(warnings.text(), HasSubstr("longest path"));
    // The muscle never pulls: force 0 (slack) at the nominal posture.
    Data data(model);
    EXPECT_EQ(
        ComputeMuscleTorque(model, data, model.nominal_posture(), model.MuscleIndex("GP_thelen"))
            .force,
        0.0);
  }
  WarningCollector again;  // the same model built again (a fit's rebuild): no repetition
  Model rebuilt(d);
  EXPECT_EQ(again.warnings().size(), 0u) << again.text();
}

TEST(TendonCheck, ATendonSlackAtTheNominalPostureButStretchedElsewhereIsAccepted) {
  // Slack at the nominal posture (path ~37 mm) but not with the leg stretched out: the check
  // searches the coordinates' ranges and finds such a posture.
  LimbDescription d = ChecksLimb();
  const Model reference(d);
  Data data(reference);
  const int gp = reference.MuscleIndex("GP_rigid");
  const double nominal =
      ComputeMuscleTorque(reference, data, reference.nominal_posture(), gp).length;
  Eigen::VectorXd straight = reference.nominal_posture();
  straight[reference.JointIndex("knee_rz")] = 0.0;
  const double stretched = ComputeMuscleTorque(reference, data, straight, gp).length;
  ASSERT_LT(nominal + 0.005, stretched);
  ChecksMuscle(d, "GP_rigid").force.tendon_slack_length = 0.5 * (nominal + stretched);
  d.name = "tendon_check_stretched";
  WarningCollector warnings;
  EXPECT_NO_THROW(Model model(d));
  EXPECT_EQ(warnings.warnings().size(), 0u) << warnings.text();
  // A constant-force muscle or a tendon of length 0 is never checked (no tendon to be slack).
  LimbDescription c = ChecksLimb();
  ChecksMuscle(c, "GP_constant").force.tendon_slack_length = 1.0;
  EXPECT_NO_THROW(Model model(c));
}

TEST(ConstantActivation, EvaluateAndEvaluateBatchRejectAnActivationOutsideZeroOne) {
  const Model model(ChecksLimb());
  const int constant = model.MuscleIndex("GP_constant");
  Data data(model);
  const Eigen::VectorXd q = model.nominal_posture();
  const StiffnessSet& k = model.model_stiffness();
  const Eigen::MatrixXd postures = q.replicate(1, 5);
  for (double a : {1.5, -0.25, std::numeric_limits<double>::quiet_NaN()}) {
    try {
      Evaluate(model, data, q, constant, k, a);
      FAIL() << "Evaluate: no error for " << a;
    } catch (const Error& e) {
      EXPECT_THAT(e.what(), HasSubstr("muscle 'GP_constant': activation"));
      EXPECT_THAT(e.what(), HasSubstr("outside [0, 1]"));
    }
    std::vector<WrenchResult> out;
    try {
      EvaluateBatch(model, postures, constant, {k}, out, a);
      FAIL() << "EvaluateBatch: no error for " << a;
    } catch (const Error& e) {
      EXPECT_THAT(e.what(), HasSubstr("EvaluateBatch: muscle 'GP_constant': activation"));
    }
  }
  // The bounds themselves are valid, and the wrench is linear in the activation.
  const Vector6d full = Evaluate(model, data, q, constant, k, 1.0).wrench;
  EXPECT_EQ(Evaluate(model, data, q, constant, k, 0.0).wrench, Vector6d::Zero());
  EXPECT_TRUE(Evaluate(model, data, q, constant, k, 0.5).wrench.isApprox(0.5 * full, 1e-14));
  std::vector<WrenchResult> out;
  EvaluateBatch(model, postures, constant, {k}, out, 1.0);
  EXPECT_TRUE(out[4].wrench.isApprox(full, 1e-12));
}

}  // namespace
}  // namespace isowrench
