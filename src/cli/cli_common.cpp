#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <iostream>

#include "cli/command.hpp"
#include "isowrench/engine.hpp"
#include "isowrench/error.hpp"
#include "isowrench/frontend.hpp"
#include "isowrench/input_checks.hpp"
#include "isowrench/io.hpp"
#include "isowrench/kinematics.hpp"
#include "isowrench/posture.hpp"
#include "isowrench/wrap.hpp"

namespace isowrench::cli {

std::vector<Command>& RegisteredCommands() {
  static std::vector<Command> commands;
  return commands;
}

bool RegisterCommand(Command command) {
  RegisteredCommands().push_back(std::move(command));
  return true;
}

void AddSheetOptions(CLI::App& app, TrialSheetOptions& sheet, const std::string& what) {
  app.add_option_function<std::string>(
         "--delimiter",
         [&sheet](const std::string& text) { sheet.delimiter = DelimiterChar(text); },
         "Field separator of " + what +
             ": , (default) ; tab or | (or by name: comma, semicolon, tab, pipe)")
      ->check(CLI::IsMember({",", ";", "tab", "\\t", "|", "comma", "semicolon", "pipe"}));
  app.add_flag("--decimal-comma", sheet.decimal_comma,
               "Numbers of " + what + " are written 1,5 (with --delimiter ';' or tab)");
  app.add_option("--ignore-columns", sheet.ignore_columns,
                 "Columns of " + what +
                     " not to read (trial id, date, comment...), comma-separated; other "
                     "unknown columns are ignored with a warning naming them")
      ->delimiter(',');
  app.add_option("--skip-rows", sheet.skip_rows,
                 "Lines before the header of " + what + " to skip (an instrument's preamble)")
      ->check(CLI::NonNegativeNumber);
}

void AddWrapOption(CLI::App& app, std::string& wrap) {
  app.add_option("--wrap", wrap,
                 "How muscles that wrap over wrap objects get their length and moment arms: "
                 "opensim (OpenSim 4.x's algorithms and moment arms) or exact (the shortest "
                 "path on the side OpenSim chooses; moment arm = -dL/dq); default: the URDF's "
                 "isowrench:wrap_mode, else opensim")
      ->check(CLI::IsMember({"opensim", "exact"}));
}

namespace {

void AddActivationOption(CLI::App& app, double& activation) {
  app.add_option("--activation", activation,
                 "Activation in [0, 1]: F = F(L_MT, activation) of the muscle's force model "
                 "(constant model: activation x max_force) (default 1)")
      ->check(CLI::Range(0.0, 1.0));
}

}  // namespace

void AddMusclesAndActivation(CLI::App& app, std::vector<std::string>& muscles, double& activation) {
  app.add_option("--muscle", muscles,
                 "Muscle name(s), repeatable or comma-separated (default: the first)")
      ->delimiter(',');
  AddActivationOption(app, activation);
}

void AddModelOptions(CLI::App& app, ModelOptions& o, ModelOptionParts parts) {
  app.add_option("urdf", o.urdf,
                 "Limb URDF with isowrench extension tags (e.g. urdf/rat_hindlimb_5dof.urdf)")
      ->required();
  if (parts.posture) {
    app.add_option("--posture", o.posture,
                   "Joint positions over the URDF's nominal posture: joint=value,... in degrees "
                   "(mm for prismatic joints), e.g. hip_rz=-110,knee_rz=105");
  }
  app.add_option("--release", o.release,
                 "Released transducer dofs (x y z rx ry rz, in transducer axes), replacing the "
                 "URDF's; 'none' restrains all six")
      ->delimiter(',')
      ->each([&o](const std::string&) { o.release_given = true; });
  app.add_option("--transducer", o.transducer,
                 "Transducer stiffness preset: balanced, ati-mini40, jr3")
      ->check(CLI::IsMember({"balanced", "ati-mini40", "jr3"}));
  app.add_option("--transducer-stiffness", o.transducer_stiffness,
                 "S_t diagonal kx,ky,kz,krx,kry,krz in N/m and N·m/rad (transducer axes)");
  app.add_option(
         "--base-stiffness", o.base_stiffness,
         "Base translation stiffness in N/m; adds base_x/y/z prismatic dofs if the URDF has none")
      ->each([&o](const std::string&) { o.base_given = true; });
  app.add_option("--joint-stiffness", o.joint_stiffness,
                 "Passive joint stiffness joint=value (N·m/rad, or N/m for prismatic); repeatable")
      ->delimiter(',');
  app.add_option("--lock", o.lock,
                 "Locked coordinates (held rigid by the statics), replacing the URDF's locks: "
                 "coord,coord,...; 'none' locks nothing")
      ->delimiter(',')
      ->each([&o](const std::string&) { o.lock_given = true; });
  AddWrapOption(app, o.wrap);
  app.add_option("--force-model", o.force_model,
                 "Force model of every muscle for this run: model (default: each muscle's own, "
                 "docs/muscle.md), constant (F = activation x max_force, the paper's), rigid "
                 "(each muscle's curves with a rigid tendon)")
      ->check(CLI::IsMember({"model", "constant", "rigid"}));
  if (parts.muscle) {
    app.add_option("--muscle", o.muscle, "Muscle name (default: the first muscle in the URDF)");
    AddActivationOption(app, o.activation);
  }
  if (!parts.statics) return;
  app.add_option("--max-endpoint-fraction", o.statics.max_endpoint_fraction,
                 "Small-motion rule: endpoint translation <= this x leg length (default 0.001)");
  app.add_option("--max-joint-rotation", o.statics.max_joint_rotation,
                 "Small-motion rule: every joint rotation <= this, rad (default 0.01)");
  app.add_option("--rank-tolerance", o.statics.rank_tolerance,
                 "Eigenvalue of K counts as zero when <= this x the largest (default 1e-12)");
}

ModelOverrides Overrides(const ModelOptions& o) {
  ModelOverrides overrides;
  if (o.release_given) overrides.released = DofMask::FromNames(o.release);
  overrides.transducer_preset = o.transducer;
  if (!o.transducer_stiffness.empty()) {
    overrides.transducer_stiffness =
        ParseTransducerStiffness(o.transducer_stiffness, "--transducer-stiffness");
  }
  if (o.base_given) overrides.base_stiffness = o.base_stiffness;
  for (const std::string& item : o.joint_stiffness) {
    overrides.joint_stiffness.push_back(ParseAssignment(item, "--joint-stiffness"));
  }
  if (o.lock_given) overrides.locked = o.lock;
  if (!o.wrap.empty()) overrides.wrap = ParseWrapMode(o.wrap);
  overrides.force_model = o.force_model;
  return overrides;
}

Model LoadModel(const ModelOptions& o) {
  CheckStaticsOptions(o.statics);
  return Model(ApplyOverrides(LoadLimb(o.urdf), Overrides(o)));
}

Eigen::VectorXd LoadPosture(const Model& model, const ModelOptions& o) {
  std::vector<std::string> warnings;
  Eigen::VectorXd q = PostureFromUserText(model, model.nominal_posture(), o.posture, &warnings);
  WarnAll(warnings);
  return q;
}

std::string ChooseMuscle(const Model& model, const ModelOptions& o) {
  if (!o.muscle.empty()) {
    model.MuscleIndex(o.muscle);  // throws with the list of muscles
    return o.muscle;
  }
  if (model.muscle_count() == 0)
    throw Error("model '" + model.name() + "' has no <isowrench:muscle>");
  return model.muscle(0).name;
}

nlohmann::json MuscleWrapJson(const Model& model, const Eigen::VectorXd& q, int muscle) {
  const MuscleSpec& spec = model.muscle(muscle);
  if (spec.wraps.empty()) return nullptr;
  Data ws(model);
  const WrappedPath path = MuscleWrappedPath(model, ws, q, muscle);
  nlohmann::json wraps = nlohmann::json::array();
  for (size_t k = 0; k < spec.wraps.size(); ++k) {
    wraps.push_back({{"object", spec.wraps[k].object},
                     {"wrapped", path.wraps[k].wrapped},
                     {"arc_m", path.wraps[k].wrapped ? path.wraps[k].arc_length : 0.0}});
  }
  return {{"mode", WrapModeName(model.description().wrap_mode)},
          {"wraps", wraps},
          {"warning", WrapStatusText(path.status)}};
}

std::string MuscleWrapText(const nlohmann::json& wrap) {
  if (wrap.is_null()) return "";
  std::string text = "wrap (" + wrap["mode"].get<std::string>() + "):";
  for (const auto& w : wrap["wraps"]) {
    text += " " + w["object"].get<std::string>() +
            (w["wrapped"].get<bool>()
                 ? " wraps, arc " + util::FormatNumber(w["arc_m"].get<double>() * 1e3, 4) + " mm"
                 : " does not wrap");
    text += ";";
  }
  text.pop_back();
  const std::string warning = wrap["warning"].get<std::string>();
  if (!warning.empty()) text += "; warning: " + warning;
  return text;
}

std::string Cell(double value, int width) {
  char buffer[64];
  if (value == 0.0) value = 0.0;  // no "-0"
  std::snprintf(buffer, sizeof(buffer), "%*.4g", width, value);
  return buffer;
}

std::string StiffnessText(const Vector6d& s) {
  return "[" + util::FormatNumber(s[0], 4) + " " + util::FormatNumber(s[1], 4) + " " +
         util::FormatNumber(s[2], 4) + " N/m; " + util::FormatNumber(s[3], 4) + " " +
         util::FormatNumber(s[4], 4) + " " + util::FormatNumber(s[5], 4) + " N·m/rad]";
}

std::string WrenchHeader(int label_width) {
  std::string line(static_cast<size_t>(label_width), ' ');
  const char* names[6] = {"fx (N)", "fy (N)", "fz (N)", "mx (N·m)", "my (N·m)", "mz (N·m)"};
  for (int i = 0; i < 6; ++i) {
    std::string name = names[i];
    // "·" is 2 bytes but one column wide.
    size_t columns = name.size() - (i >= 3 ? 1 : 0);
    line += std::string(11 - columns, ' ') + name;
  }
  return line;
}

std::string WrenchRow(const std::string& label, const Vector6d& w, int label_width) {
  std::string line = label;
  if (static_cast<int>(line.size()) < label_width)
    line += std::string(label_width - line.size(), ' ');
  for (int i = 0; i < 6; ++i) line += Cell(w[i]);
  return line;
}

// JSON never holds -0 (x == 0 maps -0 to +0).
nlohmann::json ToJson(const Vector6d& v) { return ToJson(Eigen::VectorXd(v)); }
nlohmann::json ToJson(const Eigen::VectorXd& v) {
  std::vector<double> out(v.data(), v.data() + v.size());
  for (double& x : out) x = x == 0.0 ? 0.0 : x;
  return out;
}

nlohmann::json WrenchJson(const Vector6d& wrench) {
  Vector6d w = wrench.unaryExpr([](double x) { return x == 0.0 ? 0.0 : x; });
  return {{"fx", w[0]},
          {"fy", w[1]},
          {"fz", w[2]},
          {"mx", w[3]},
          {"my", w[4]},
          {"mz", w[5]},
          {"units", {{"force", "N"}, {"moment", "N·m"}}}};
}

Progress::Progress(std::string label, long total)
    : label_(std::move(label)), total_(total), enabled_(::isatty(STDERR_FILENO) && total > 0) {}

Progress::~Progress() {
  if (enabled_ && last_percent_ >= 0) std::cerr << "\n";
}

void Progress::Update(long done) {
  if (!enabled_) return;
  int percent = static_cast<int>(100.0 * static_cast<double>(done) / static_cast<double>(total_));
  if (percent == last_percent_) return;
  last_percent_ = percent;
  int filled = percent * 30 / 100;
  std::cerr << "\r" << label_ << " [" << std::string(filled, '#') << std::string(30 - filled, '.')
            << "] " << percent << "% (" << done << "/" << total_ << ")" << std::flush;
}

}  // namespace isowrench::cli
