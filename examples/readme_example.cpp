// The README's library example, built and run as a test so it never rots.
#include <iostream>
#include <isowrench/isowrench.hpp>

int main(int argc, char** argv) {
  const std::string urdf = argc > 1 ? argv[1] : "urdf/rat_hindlimb_5dof.urdf";
  try {
    isowrench::Model model = isowrench::Model::FromUrdfFile(urdf);
    // Release the transducer's z rotation: 5 restrained dofs for a 5-dof limb.
    model = isowrench::Model(isowrench::WithReleasedDofs(model.description(), {"rz"}));
    isowrench::WrenchEvaluation e = isowrench::EvaluateWrench(model, model.nominal_posture(), "GP");
    if (!e.statics.ok()) {
      std::cerr << e.statics.message << "\n";
      return 2;
    }
    const isowrench::Vector6d& w = e.statics.wrench;  // limb -> transducer, transducer axes
    std::cout << "force  [N]   " << w.head<3>().transpose() << "\n"
              << "moment [N·m] " << w.tail<3>().transpose() << "\n"
              << "small motion valid: " << (e.statics.small_motion_valid ? "yes" : "no") << "\n";
  } catch (const isowrench::Error& error) {
    std::cerr << "error: " << error.what() << "\n";
    return 1;
  }
  return 0;
}
