// What the command line and the Python module share (include/isowrench/frontend.hpp).

#include "isowrench/frontend.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "isowrench/engine.hpp"
#include "isowrench/error.hpp"
#include "isowrench/input_checks.hpp"
#include "isowrench/io.hpp"
#include "isowrench/muscle.hpp"
#include "isowrench/posture.hpp"
#include "isowrench/statics.hpp"
#include "isowrench/wrap.hpp"
#include "isowrench/wrap_report.hpp"

namespace isowrench {

std::string OptionName(const std::string& cli_name, OptionStyle style) {
  if (style == OptionStyle::kCommandLine) return cli_name;
  std::string name = cli_name.substr(cli_name.find_first_not_of('-'));
  std::replace(name.begin(), name.end(), '-', '_');
  return name;
}

LimbDescription LoadLimb(const std::string& path, const OpenSimImportOptions* osim) {
  if (std::filesystem::path(path).extension() != ".osim") return ReadUrdfFile(path);
  if (!osim || osim->clamp_body.empty() || osim->endpoint_body.empty()) {
    throw Error("loading the OpenSim model '" + path +
                "' needs the clamped body and the endpoint body (isowrench import --clamp "
                "--endpoint; Python clamp_body=, endpoint_body=)");
  }
  OpenSimImport imported = ImportOpenSimFile(path, *osim);
  for (const std::string& w : imported.warnings) Warn(path + ": " + w);
  return std::move(imported.description);
}

bool ModelOverrides::empty() const {
  return !released && transducer_preset.empty() && !transducer_stiffness && !base_stiffness &&
         joint_stiffness.empty() && !locked && !wrap &&
         (force_model.empty() || force_model == "model");
}

LimbDescription ApplyOverrides(LimbDescription d, const ModelOverrides& o, OptionStyle style) {
  auto name = [&](const char* cli) { return OptionName(cli, style); };
  if (o.released) d = WithReleasedDofs(std::move(d), *o.released);
  if (!o.transducer_preset.empty() && o.transducer_stiffness) {
    throw Error("give either " + name("--transducer") + " or " + name("--transducer-stiffness") +
                ", not both");
  }
  if (!o.transducer_preset.empty()) {
    d = WithTransducerStiffness(std::move(d), TransducerPreset(o.transducer_preset));
  }
  if (o.transducer_stiffness) {
    for (int i = 0; i < 6; ++i) {
      CheckStiffnessValue((*o.transducer_stiffness)[i],
                          name("--transducer-stiffness") + " " + DofName(i));
    }
    d = WithTransducerStiffness(std::move(d), *o.transducer_stiffness);
  }
  if (o.base_stiffness) {
    CheckStiffnessValue(*o.base_stiffness, name("--base-stiffness"));
    d = WithBaseStiffness(std::move(d), *o.base_stiffness);
  }
  // Errors of the edits below name the option as the user typed it.
  auto naming = [](const std::string& option, auto&& edit) {
    try {
      edit();
    } catch (const Error& e) {
      throw Error(option + ": " + e.what());
    }
  };
  for (const std::pair<std::string, double>& entry : o.joint_stiffness) {
    // (not a structured binding: C++17 lambdas cannot capture those; clang refuses)
    const std::string& joint = entry.first;
    const double k = entry.second;
    CheckStiffnessValue(k, name("--joint-stiffness") + " " + joint);
    naming(name("--joint-stiffness"), [&] { d = WithJointStiffness(std::move(d), joint, k); });
  }
  if (o.locked) {
    const std::string lock =
        style == OptionStyle::kPython ? "locked" : "--lock";  // Python's keyword
    const std::vector<std::string>& names = *o.locked;
    const bool none = std::find(names.begin(), names.end(), "none") != names.end();
    for (const std::string& n : names) {
      if (util::Trim(n).empty()) {
        throw Error(lock + ": an empty coordinate name (give coordinates, or 'none' to " +
                    "lock nothing)");
      }
      if (none && n != "none") {
        throw Error(lock + ": 'none' together with '" + n +
                    "' (give the coordinates to lock, or 'none' alone)");
      }
    }
    naming(lock, [&] { d = WithLockedCoordinates(std::move(d), names); });
  }
  if (o.wrap) d.wrap_mode = *o.wrap;
  if (!o.force_model.empty() && o.force_model != "model") {
    if (o.force_model != "constant" && o.force_model != "rigid") {
      throw Error(name("--force-model") + " '" + o.force_model +
                  "' is not a force model override: model (each muscle's own), constant (F = a "
                  "x max_force) or rigid (each muscle's curves with a rigid tendon)");
    }
    for (MuscleSpec& m : d.muscles) {
      if (o.force_model == "constant") {
        m.force.model = ForceModelType::kConstant;
      } else {
        m.force.ignore_tendon_compliance = true;
      }
    }
  }
  // A new override: one line here, in the order of ModelOverrides' fields.
  return d;
}

void CheckStaticsOptions(const StaticsOptions& options, OptionStyle style) {
  auto check = [&](const char* cli, double value, double below) {
    if (!(std::isfinite(value) && value > 0 && value < below)) {
      throw Error(OptionName(cli, style) + " " + util::FormatNumber(value) +
                  ": must be a finite number > 0" +
                  (below < 1e300 ? " and < " + util::FormatNumber(below) : std::string()));
    }
  };
  check("--max-endpoint-fraction", options.max_endpoint_fraction, 1e308);
  check("--max-joint-rotation", options.max_joint_rotation, 1e308);
  check("--rank-tolerance", options.rank_tolerance, 1.0);
}

std::vector<std::string> ParseList(const std::string& text) { return util::Split(text, ","); }

std::pair<std::string, double> ParseAssignment(const std::string& text, const std::string& option) {
  const size_t eq = text.find('=');
  if (eq == std::string::npos || util::Trim(text.substr(0, eq)).empty()) {
    throw Error(option + " '" + text + "' is not name=value");
  }
  const std::string name = util::Trim(text.substr(0, eq));
  return {name, util::ParseDoubleOrThrow(text.substr(eq + 1), option + " " + name)};
}

char DelimiterChar(const std::string& text) {
  if (text == "," || text == "comma") return ',';
  if (text == ";" || text == "semicolon") return ';';
  if (text == "\t" || text == "\\t" || text == "tab") return '\t';
  if (text == "|" || text == "pipe") return '|';
  throw Error("delimiter '" + text +
              "' is not one of ',' ';' tab '|' (or comma, semicolon, tab, pipe)");
}

Vector6d ParseTransducerStiffness(const std::string& text, const std::string& option) {
  const std::vector<std::string> items = util::Split(text, ", ");
  if (items.size() != 6) {
    throw Error(option + " needs 6 values kx,ky,kz,krx,kry,krz; got '" + text + "'");
  }
  Vector6d s;
  for (int i = 0; i < 6; ++i) {
    s[i] = util::ParseDoubleOrThrow(items[static_cast<size_t>(i)], option + " " + DofName(i));
    CheckStiffnessValue(s[i], option + " " + DofName(i));
  }
  return s;
}

void ParseEndpoint(const std::string& text, OpenSimImportOptions& options,
                   const std::string& option) {
  const size_t colon = text.find(':');
  options.endpoint_body = util::Trim(text.substr(0, colon));
  if (colon == std::string::npos) return;
  const std::vector<std::string> parts = util::Split(text.substr(colon + 1), ",");
  if (parts.size() != 3) {
    throw Error(option + " '" + text + "': the point after ':' must be three numbers x,y,z (m)");
  }
  for (int i = 0; i < 3; ++i) {
    options.endpoint_point[i] =
        util::ParseDoubleOrThrow(parts[static_cast<size_t>(i)], option + " '" + text + "'");
  }
}

Eigen::VectorXd PostureFromUserText(const Model& model, const Eigen::VectorXd& base,
                                    const std::string& text, std::vector<std::string>* warnings,
                                    const std::string& option) {
  return ApplyPostureAssignments(model, base, text, warnings, option);
}

Eigen::VectorXd PostureFromValues(const Model& model, const Eigen::VectorXd& base,
                                  const std::vector<std::pair<std::string, double>>& values,
                                  const Eigen::VectorXd* all, std::vector<std::string>* warnings,
                                  const std::string& label) {
  Eigen::VectorXd q = base;
  std::vector<std::string> given;
  if (all) {
    if (all->size() != model.dof_count()) {
      throw Error(label + " has " + std::to_string(all->size()) + " values; it must have " +
                  std::to_string(model.dof_count()) + " in rad / m, one per coordinate (" +
                  util::Join(model.joint_names(), ", ") + ")");
    }
    q = *all;
    given = model.joint_names();
  }
  for (const auto& [name, value] : values) {
    const CoordinateSpec& c = FindCoordinate(model.description(), name);
    q[model.JointIndex(c.name)] = value;
    given.push_back(c.name);
  }
  for (int i = 0; i < model.dof_count(); ++i) {
    if (!std::isfinite(q[i])) {
      throw Error(label + "['" + model.joint_names()[i] + "'] is " + util::FormatNumber(q[i]) +
                  "; posture values must be finite (rad / m)");
    }
  }
  if (warnings) {
    warnings->clear();
    if (!given.empty()) {
      *warnings = PostureWarnings(
          model.description(), q, [&](const std::string& c) { return label + "['" + c + "']"; },
          given);
    }
  }
  return q;
}

SimulationRun SimulateToCsv(const Model& model, const std::vector<std::string>& effects,
                            const SimulationOptions& options, const std::string& path,
                            const TrialProgress& progress) {
  SimulationRun run;
  run.output = path;
  for (const std::string& text : effects) run.effects.push_back(ParseEffectAssignment(model, text));
  const AugmentedModel truth = ApplyEffects(model.description(), run.effects);
  // Streamed: each chunk of trials is written as soon as it is simulated (bounded memory); the
  // file appears only when complete.
  util::AtomicOutputFile file(path);
  TrialCsvWriter writer(model, file.stream(), /*with_sd=*/true);
  ForEachSimulatedTrial(
      model, truth, options,
      [&](const Trial& t) {
        writer.Write(t);
        ++run.trials;
      },
      progress);
  file.Commit();
  nlohmann::json e = nlohmann::json::array();
  for (const AppliedEffect& a : run.effects) {
    nlohmann::json params = nlohmann::json::array();
    for (size_t i = 0; i < a.values.size(); ++i) {
      params.push_back({{"name", a.effect.parameters[i].name},
                        {"value", a.values[i]},
                        {"unit", a.effect.parameters[i].unit}});
    }
    e.push_back({{"id", a.effect.id}, {"parameters", params}});
  }
  run.json = nlohmann::json{
      {"output", path},
      {"trials", run.trials},
      {"seed", options.seed},
      {"noise_force_N", options.noise_force},
      {"noise_moment_Nm", options.noise_moment},
      {"range_deg", options.joint_range * 180.0 / M_PI},
      {"effects",
       e}}.dump(2);
  return run;
}

std::vector<Trial> ReadPostureSheet(const Model& model, const std::string& path,
                                    TrialSheetOptions sheet) {
  sheet.postures_only = true;
  return ReadTrialsCsv(model, path, sheet);
}

void SimulateAtPostureSheet(const Model& model, const std::string& path, int trials,
                            bool keep_ranges, SimulationOptions* options,
                            const TrialSheetOptions& sheet) {
  options->at = ReadPostureSheet(model, path, sheet);
  options->postures = trials > 0 ? trials : static_cast<int>(options->at.size());
  if (!keep_ranges) options->joint_range = options->prismatic_range = 0;
}

std::string PostureSheetText(const Model& model, const std::vector<Trial>& trials,
                             const std::string& comment) {
  std::string text = "# " + comment + "\n";
  std::vector<std::string> header = model.joint_names();
  for (const char* c : {"muscle", "activation", "fx", "fy", "fz", "mx", "my", "mz"}) {
    header.push_back(c);
  }
  text += util::Join(header, ",") + "\n";
  for (const Trial& t : trials) {
    std::vector<std::string> row;
    for (int j = 0; j < model.dof_count(); ++j) {
      row.push_back(util::FormatNumber(JointValueToUserUnits(model.joint(j).type, t.q[j]), 10));
    }
    row.push_back(t.muscle);
    row.push_back(util::FormatNumber(std::isfinite(t.activation) ? t.activation : 1.0, 10));
    text += util::Join(row, ",") + ",,,,,,\n";
  }
  return text;
}

// The CLI's ForceJson (src/cli/force_report.cpp) and Python's ForceDict parse this: one list of
// keys (issue 28).
std::string ForceStageJson(const Model& model, int muscle, const MuscleForce& force,
                           double activation) {
  const MuscleForceModel& f = ForceModelOf(model, muscle);
  nlohmann::ordered_json j;
  j["model"] = ForceModelName(f.type());
  j["tendon"] = f.type() == ForceModelType::kConstant ? "none"
                : f.rigid_tendon()                    ? "rigid"
                                                      : "compliant";
  j["activation"] = activation;
  j["force_n"] = force.force + 0.0;  // (+ 0.0: no -0)
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
  return j.dump();
}

// `kinematics --json` and Python's Model.kinematics() parse this (issue 27).
std::string WrapModeJson(const Model& model, const WrapModeDifference& d) {
  const unsigned bad = d.status_opensim & kWrapMisbehaviour;
  nlohmann::ordered_json j;
  j["length_opensim_m"] = d.length_opensim;
  j["length_exact_m"] = d.length_exact;
  j["length_difference_mm"] = d.LengthDifference() * 1e3;
  j["moment_arm_difference_mm"] = d.moment_arm_difference * 1e3;
  j["moment_arm_difference_coordinate"] =
      d.coordinate >= 0 ? nlohmann::ordered_json(model.joint_names()[d.coordinate])
                        : nlohmann::ordered_json();
  j["wraps_engaged"] = d.wraps_engaged;
  j["opensim_misbehaves"] = WrapStatusText(bad);
  return j.dump();
}

}  // namespace isowrench
