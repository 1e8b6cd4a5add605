// The installed-package consumer: the GP muscle's wrench on the shipped 5-dof rat limb at its
// nominal posture, through the full report (EvaluateWrench) and through the fast path, which
// must agree. Exit code 0 when they do. It also names a fit verdict, a function of the
// identification layer's Ceres-based fitting code, so that a static link needs the Ceres
// dependencies that `pkg-config --static --libs isowrench` lists.

#include <cstdio>
#include <isowrench/isowrench.hpp>
#include <string>

int main(int argc, char** argv) {
  const std::string urdf =
      argc > 1 ? argv[1] : std::string(APP_URDF_DIR) + "/rat_hindlimb_5dof.urdf";
  try {
    const isowrench::Model model = isowrench::Model::FromUrdfFile(urdf);
    const Eigen::VectorXd q = model.nominal_posture();
    const isowrench::WrenchEvaluation e = isowrench::EvaluateWrench(model, q, "GP");

    isowrench::Data data(model);
    const isowrench::WrenchResult lean =
        isowrench::Evaluate(model, data, q, model.MuscleIndex("GP"), model.model_stiffness());

    const isowrench::Vector6d& w = e.statics.wrench;
    std::printf("%s, GP at the nominal posture: %s\n", model.name().c_str(),
                isowrench::StatusName(e.statics.status));
    std::printf("W = [%.6g %.6g %.6g] N, [%.6g %.6g %.6g] N·m (limb on transducer)\n", w[0], w[1],
                w[2], w[3], w[4], w[5]);
    const double difference = (lean.wrench - w).norm();
    std::printf("Evaluate (%s) differs from EvaluateWrench by %.3g\n",
                isowrench::StatusMessage(lean).c_str(), difference);
    std::printf("identification layer linked: verdict names such as '%s'\n",
                isowrench::FitVerdictName(isowrench::FitVerdict::kExplained));
    return difference <= 1e-9 * w.norm() ? 0 : 1;
  } catch (const isowrench::Error& error) {
    std::fprintf(stderr, "app: error: %s\n", error.what());
    return 1;
  }
}
