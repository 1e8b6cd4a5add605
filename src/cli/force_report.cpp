// How the reports print a muscle's force stage (docs/muscle.md): which force model, the force
// with its active and passive parts, the fiber state, and where OpenSim gives no number.

#include <cmath>
#include <string>

#include "cli/command.hpp"
#include "isowrench/engine.hpp"
#include "isowrench/io.hpp"
#include "isowrench/muscle.hpp"

namespace isowrench::cli {

std::string ForceText(const Model& model, int muscle, const MuscleForce& force) {
  const auto N = [](double v) { return util::FormatNumber(v + 0.0, 4) + " N"; };
  if (ForceModelOf(model, muscle).type() == ForceModelType::kConstant) {
    return "F " + N(force.force) + " = a x max_force";
  }
  std::string text = "F " + N(force.force) + " = active " + N(force.active_force) + " + passive " +
                     N(force.passive_force);
  text += "; fiber " + util::FormatNumber(force.fiber_length * 1e3, 4) + " mm, pennation " +
          util::FormatNumber(force.pennation_angle * 180.0 / M_PI, 3) + "°, a used " +
          util::FormatNumber(force.activation, 3) + ", " + MuscleForceStatusName(force.status);
  return text;
}

nlohmann::ordered_json ForceJson(const Model& model, int muscle, const MuscleForce& force,
                                 double activation) {
  const MuscleForceModel& f = ForceModelOf(model, muscle);
  nlohmann::ordered_json j;
  j["model"] = ForceModelName(f.type());
  j["tendon"] = f.type() == ForceModelType::kConstant ? "none"
                : f.rigid_tendon()                    ? "rigid"
                                                      : "compliant";
  j["activation"] = activation;
  j["force_n"] = force.force + 0.0;
  j["active_force_n"] = force.active_force + 0.0;
  j["passive_force_n"] = force.passive_force + 0.0;
  j["fiber_length_m"] = force.fiber_length + 0.0;
  j["pennation_rad"] = force.pennation_angle + 0.0;
  j["tendon_strain"] = force.tendon_strain + 0.0;
  j["activation_used"] = force.activation;
  j["status"] = MuscleForceStatusName(force.status);
  j["opensim_gives_no_number"] = force.opensim_gives_no_number;
  const std::string note = OpenSimNote(model, muscle, force);
  if (!note.empty()) j["opensim_note"] = note;
  return j;
}

}  // namespace isowrench::cli
