// `isowrench wrench <urdf>`: one muscle, one posture, one set of compliances.

#include <iostream>

#include "cli/command.hpp"
#include "isowrench/io.hpp"
#include "isowrench/posture.hpp"
#include "isowrench/statics.hpp"

namespace isowrench::cli {
namespace {

std::string ReleasedText(const TransducerSpec& t) {
  return t.released.none() ? "none (all 6 dofs restrained)" : t.released.ToString(" ");
}

std::string Unit(const Model& model, int i, const char* revolute, const char* prismatic) {
  return model.joint(i).type == JointType::kPrismatic ? prismatic : revolute;
}

/// +0 for -0, so no table or JSON prints "-0".
double NoNegativeZero(double v) { return v == 0.0 ? 0.0 : v; }

/// The base dofs of the model (role base), whose zero torque makes the classic answer
/// (J^-T tau / pinv(J^T) tau) meaningless: it has no compliance to share the load with.
std::vector<std::string> BaseDofs(const Model& model) {
  std::vector<std::string> names;
  const StaticsProblem problem(model);
  for (int i : problem.base_columns()) names.push_back(model.joint_names()[i]);
  return names;
}

std::string ClassicOmitted(const std::vector<std::string>& base) {
  return "the model has base dofs (" + util::Join(base, ", ") +
         ") with zero torque; the rigid-skeleton classic answer treats them as free joints and "
         "means nothing here (Eq. 10 is the answer)";
}

bool NoEquilibrium(const StaticsResult& s) { return s.status == StaticsStatus::kSelfMotion; }

nlohmann::json EvaluationJson(const Model& model, const WrenchEvaluation& e,
                              const std::string& urdf, double activation) {
  const StaticsResult& s = e.statics;
  nlohmann::json joints = nlohmann::json::array();
  for (int i = 0; i < model.dof_count(); ++i) {
    const bool locked = e.locked[static_cast<size_t>(i)];
    joints.push_back(
        {{"name", model.joint_names()[i]},
         {"role", RoleName(model.joint(i).role)},
         {"locked", locked},
         {"q", NoNegativeZero(e.q[i])},
         {"stiffness", locked ? nlohmann::json(nullptr) : nlohmann::json(e.s_p[i])},
         {"tau", NoNegativeZero(e.tau[i])},
         {"dtheta",
          NoEquilibrium(s) ? nlohmann::json(nullptr) : nlohmann::json(NoNegativeZero(s.dtheta[i]))},
         {"units",
          model.joint(i).type == JointType::kPrismatic
              ? nlohmann::json{{"q", "m"}, {"stiffness", "N/m"}, {"tau", "N"}, {"dtheta", "m"}}
              : nlohmann::json{
                    {"q", "rad"}, {"stiffness", "N·m/rad"}, {"tau", "N·m"}, {"dtheta", "rad"}}}});
  }
  nlohmann::json self_motion = nlohmann::json::array();
  for (int c = 0; c < s.self_motion.cols(); ++c) {
    Eigen::VectorXd v = s.self_motion.col(c);
    self_motion.push_back(
        {{"direction", ToJson(v)}, {"description", DescribeJointMotion(model, v)}});
  }
  const std::vector<std::string> released = model.transducer().released.names();
  const bool none = NoEquilibrium(s);
  const std::vector<std::string> base = BaseDofs(model);
  nlohmann::json classic =
      base.empty() ? nlohmann::json{{"method", e.classic.square_inverse ? "J^-T tau (Eq. 11)"
                                                                        : "pinv(J^T) tau (Eq. 15)"},
                                    {"wrench", WrenchJson(e.classic.wrench)},
                                    {"rank", e.classic.rank},
                                    {"residual", e.classic.residual}}
                   : nlohmann::json{{"method", nullptr}, {"omitted", ClassicOmitted(base)}};
  std::vector<std::string> locked;
  for (int i = 0; i < model.dof_count(); ++i) {
    if (e.locked[static_cast<size_t>(i)]) locked.push_back(model.joint_names()[i]);
  }
  return {
      {"model", model.name()},
      {"urdf", urdf},
      {"locked", locked},
      {"muscle",
       {{"name", e.muscle},
        {"force_N", e.muscle_force},
        {"length_m", e.muscle_length},
        {"force_model", ForceJson(model, model.MuscleIndex(e.muscle), e.force, activation)},
        {"passive_force_model",
         ForceJson(model, model.MuscleIndex(e.muscle), e.passive_force, 0.0)}}},
      {"transducer",
       {{"stiffness", ToJson(e.s_t)},
        {"released", released},
        {"units", "N/m for x y z, N·m/rad for rx ry rz"}}},
      {"joints", joints},
      {"equilibrium", !none},
      {"wrench", none ? nlohmann::json(nullptr) : WrenchJson(s.wrench)},
      {"wrench_world", none ? nlohmann::json(nullptr) : WrenchJson(e.wrench_world)},
      {"passive_wrench",
       {{"activation", 0.0},
        {"status", StatusName(e.passive_statics.status)},
        {"wrench", NoEquilibrium(e.passive_statics) || !e.passive_statics.ok()
                       ? nlohmann::json(nullptr)
                       : WrenchJson(e.passive_statics.wrench)},
        {"meaning",
         "the wrench at activation 0 (the force model's passive force; a force model's "
         "minimum_activation floor included), the baseline a lab subtracts; 0 for the constant "
         "model"}}},
      {"wrench_sign", "wrench the limb applies to the transducer; moment about the endpoint"},
      {"classic", classic},
      {"statics",
       {{"status", StatusName(s.status)},
        {"message", s.message},
        {"k_rank", s.k_rank},
        {"k_condition", s.k_condition},
        {"rank_threshold", s.rank_threshold},
        {"k_eigenvalues", ToJson(s.k_eigenvalues)},
        {"equilibrium_residual", s.equilibrium_residual},
        {"self_motion", self_motion}}},
      {"endpoint_displacement",
       {{"value", none ? nlohmann::json(nullptr) : ToJson(s.endpoint_displacement)},
        {"units", "m for x y z, rad for rx ry rz"}}},
      {"small_motion",
       {{"valid", none ? nlohmann::json(nullptr) : nlohmann::json(s.small_motion_valid)},
        {"endpoint_translation_m", s.endpoint_translation},
        {"endpoint_translation_limit_m", s.endpoint_translation_limit},
        {"max_joint_rotation_rad", s.max_joint_rotation},
        {"max_joint_rotation_limit_rad", s.max_joint_rotation_limit},
        {"message", s.validity_message}}},
  };
}

void PrintEvaluation(const Model& model, const WrenchEvaluation& e, const std::string& urdf) {
  const StaticsResult& s = e.statics;
  const TransducerSpec& t = model.transducer();
  const int muscle = model.MuscleIndex(e.muscle);
  const bool constant = model.muscle(muscle).force.model == ForceModelType::kConstant;
  std::cout << "isowrench wrench: " << model.name() << " (" << urdf << ")\n"
            << "  posture      " << FormatPosture(model, e.q) << "\n"
            << "  muscle       " << e.muscle << ": " << util::FormatNumber(e.muscle_force, 4)
            << " N, length " << util::FormatNumber(e.muscle_length * 1e3, 4) << " mm\n"
            << "  force model  " << ForceModelLabel(model, muscle) << "\n";
  if (!constant) {
    std::cout << "  force        " << ForceText(model, muscle, e.force) << "\n"
              << "  passive      at activation 0: " << ForceText(model, muscle, e.passive_force)
              << "\n";
  }
  const std::string note = OpenSimNote(model, muscle, e.force);
  if (!note.empty()) std::cout << "  OpenSim      " << note << "\n";
  std::cout << "  transducer   S_t = " << StiffnessText(t.stiffness) << ", axes "
            << (t.axes_in_world ? "world" : "of link " + t.link) << ", "
            << FormatRotation(t.rotation) << ", released: " << ReleasedText(t) << "\n";
  std::vector<std::string> springs, locked;
  for (int i = 0; i < model.dof_count(); ++i) {
    if (e.locked[static_cast<size_t>(i)]) {
      locked.push_back(model.joint_names()[i]);
    } else if (e.s_p[i] > 0) {
      springs.push_back(model.joint_names()[i] + " " + util::FormatNumber(e.s_p[i], 4) +
                        Unit(model, i, " N·m/rad", " N/m"));
    }
  }
  std::string s_p = springs.empty() ? (locked.empty() ? "none (all joints free)" : "none")
                                    : util::Join(springs, ", ");
  if (!locked.empty()) s_p += "; locked (rigid, no dof): " + util::Join(locked, ", ");
  std::cout << "  S_p          " << s_p << "\n"
            << "  statics      " << StatusName(s.status) << ": " << s.message << "\n";
  for (int c = 0; c < s.self_motion.cols(); ++c) {
    std::cout << "  self-motion  " << DescribeJointMotion(model, s.self_motion.col(c)) << "\n";
  }
  const bool none = NoEquilibrium(s);
  if (none) {
    // The small-motion check needs a displacement, and there is none without equilibrium.
    std::cout << "  small motion not applicable: no equilibrium (the muscle torque drives a "
                 "self-motion)\n";
  } else {
    std::cout << "  small motion " << (s.small_motion_valid ? "valid" : "INVALID")
              << ": endpoint moves " << util::FormatNumber(s.endpoint_translation, 3)
              << " m (limit " << util::FormatNumber(s.endpoint_translation_limit, 3)
              << " m), largest joint rotation " << util::FormatNumber(s.max_joint_rotation, 3)
              << " rad (limit " << util::FormatNumber(s.max_joint_rotation_limit, 3) << " rad)\n";
    if (!s.validity_message.empty()) std::cout << "  warning      " << s.validity_message << "\n";
  }

  const int w = 30;
  const std::vector<std::string> base = BaseDofs(model);
  const bool no_force = e.force.status == MuscleForceStatus::kNoEquilibrium;
  auto eq10 = [&](const std::string& label, const Vector6d& value) {
    if (!none && !no_force) return WrenchRow(label, value, w);
    std::string line = label + std::string(static_cast<size_t>(w) - label.size(), ' ');
    return line +
           (no_force ? "no equilibrium of the force model at this length" : "no equilibrium");
  };
  std::cout << "\nWrench the limb applies to the transducer (moment about the endpoint):\n"
            << WrenchHeader(w) << "\n"
            << eq10("Eq. 10, transducer axes", s.wrench) << "\n"
            << eq10("Eq. 10, world axes", e.wrench_world) << "\n";
  if (!constant) {  // (the constant model pulls with 0 at activation 0)
    const StaticsResult& p = e.passive_statics;
    if (p.ok() && !none && !no_force) {
      std::cout << WrenchRow("passive (a = 0), transducer", p.wrench, w) << "\n"
                << WrenchRow("active = Eq. 10 - passive", s.wrench - p.wrench, w) << "\n";
    } else {
      std::cout << "passive (a = 0), transducer    no equilibrium\n";
    }
  }
  if (!base.empty()) {
    std::cout << "  (classic J^-T / pinv(J^T) tau not shown: " << ClassicOmitted(base) << ")\n";
  } else {
    std::cout << WrenchRow(
                     e.classic.square_inverse ? "J^-T tau (Eq. 11)" : "pinv(J^T) tau (Eq. 15)",
                     e.classic.wrench, w)
              << "\n";
  }
  if (base.empty() && e.classic.residual > 1e-9 * std::max(1.0, e.tau.norm())) {
    std::cout << "  (the classic answer leaves |J^T W - tau| = "
              << util::FormatNumber(e.classic.residual, 3)
              << " N·m: the restrained dofs cannot balance the muscle torque without compliance)\n";
  }
  std::cout << "\nPer joint:\n"
            << "  joint        role       tau            dtheta         stiffness\n";
  for (int i = 0; i < model.dof_count(); ++i) {
    char line[200];
    char dtheta[64];
    if (none) {
      std::snprintf(dtheta, sizeof(dtheta), "%-16s", "no equilibrium");
    } else {
      std::snprintf(dtheta, sizeof(dtheta), "%11.4g %-4s", NoNegativeZero(s.dtheta[i]),
                    Unit(model, i, "rad", "m").c_str());
    }
    const bool is_locked = e.locked[static_cast<size_t>(i)];
    char stiffness[64];
    if (is_locked) {
      std::snprintf(stiffness, sizeof(stiffness), "%10s", "rigid");
    } else {
      std::snprintf(stiffness, sizeof(stiffness), "%10.4g %s", NoNegativeZero(e.s_p[i]),
                    Unit(model, i, "N·m/rad", "N/m").c_str());
    }
    std::snprintf(line, sizeof(line), "  %-12s %-8s %11.4g %-4s %s %s\n",
                  model.joint_names()[i].c_str(),
                  is_locked ? "locked" : RoleName(model.joint(i).role), NoNegativeZero(e.tau[i]),
                  Unit(model, i, "N·m", "N").c_str(), dtheta, stiffness);
    std::cout << line;
  }
}

const bool kWrenchRegistered = RegisterCommand({
    "wrench",
    "Compute the wrench one muscle applies through the limb to the transducer (Eq. 10), with the "
    "classic J^-T / pseudoinverse answer beside it",
    10,
    [](CLI::App& app) -> std::function<int()> {
      auto options = std::make_shared<ModelOptions>();
      auto json = std::make_shared<bool>(false);
      AddModelOptions(app, *options);
      app.add_flag("--json", *json, "Print JSON instead of the table");
      return [options, json]() {
        Model model = LoadModel(*options);
        Eigen::VectorXd q = LoadPosture(model, *options);
        WrenchEvaluation e = EvaluateWrench(model, q, ChooseMuscle(model, *options),
                                            options->activation, options->statics);
        // Where the muscle wraps (issue 27): which wraps engage, and where one misbehaves.
        const nlohmann::json wrap = MuscleWrapJson(model, q, model.MuscleIndex(e.muscle));
        if (*json) {
          nlohmann::json out = EvaluationJson(model, e, options->urdf, options->activation);
          if (!wrap.is_null()) out["muscle"]["wrap"] = wrap;
          std::cout << out.dump(2) << "\n";
        } else {
          PrintEvaluation(model, e, options->urdf);
          if (!wrap.is_null()) std::cout << "  " << MuscleWrapText(wrap) << "\n";
        }
        return e.statics.status == StaticsStatus::kSelfMotion ? 4 : 0;
      };
    },
});

}  // namespace
}  // namespace isowrench::cli
