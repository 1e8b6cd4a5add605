// How the reports print a muscle's force stage (docs/muscle.md): which force model, the force
// with its active and passive parts, the fiber state, and where OpenSim gives no number.

#include <cmath>
#include <string>

#include "cli/command.hpp"
#include "isowrench/engine.hpp"
#include "isowrench/frontend.hpp"
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

// The keys and values are the library's (ForceStageJson), which Python's force dicts parse too.
nlohmann::ordered_json ForceJson(const Model& model, int muscle, const MuscleForce& force,
                                 double activation) {
  return nlohmann::ordered_json::parse(ForceStageJson(model, muscle, force, activation));
}

}  // namespace isowrench::cli
