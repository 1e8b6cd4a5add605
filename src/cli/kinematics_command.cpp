// `isowrench kinematics <urdf>`: endpoint position, endpoint Jacobian, muscle lengths and moment
// arms at one or more postures, in independent coordinates.

#include <iostream>
#include <sstream>

#include "cli/command.hpp"
#include "isowrench/error.hpp"
#include "isowrench/frontend.hpp"
#include "isowrench/input_checks.hpp"
#include "isowrench/io.hpp"
#include "isowrench/kinematics.hpp"
#include "isowrench/posture.hpp"
#include "isowrench/statics.hpp"
#include "isowrench/wrap.hpp"
#include "isowrench/wrap_report.hpp"

namespace isowrench::cli {
namespace {

struct KinematicsOptions {
  std::string urdf;
  std::vector<std::string> posture;
  std::string postures_csv;
  bool json = false;
  bool wrap_modes = true;   // compare the opensim and exact wrap modes of wrapping muscles
  std::string wrap;         // --wrap
  double activation = 1.0;  // the force stage's (force per muscle)
  std::string force_model;  // --force-model (ModelOverrides::force_model)
};

/// Everything the command prints for one posture (SI units, world axes).
struct PostureKinematics {
  Eigen::VectorXd q;
  Eigen::Vector3d endpoint;
  Matrix6Xd jacobian;
  std::vector<double> length;                  // per muscle, m
  std::vector<Eigen::VectorXd> moment_arm;     // per muscle, -dL/dq
  std::vector<MuscleForce> force;              // per muscle, the force stage at `activation`
  std::vector<WrapModeDifference> wrap_modes;  // per wrapping muscle (wrap_report.hpp)
  std::vector<unsigned> wrap_status;           // per muscle, WrapStatus bits (0: none or fine)
};

PostureKinematics EvaluatePosture(const Model& model, Data& ws, const Eigen::VectorXd& q,
                                  bool wrap_modes, double activation) {
  PostureKinematics k;
  k.q = q;
  k.endpoint = EndpointPose(model, ws, q).translation();
  k.jacobian = EndpointJacobianWorld(model, ws, q);
  for (int m = 0; m < model.muscle_count(); ++m) {
    MuscleTorque t = ComputeMuscleTorque(model, ws, q, m, activation);
    k.length.push_back(t.length);
    k.moment_arm.push_back(-t.dL_dq.transpose());
    k.wrap_status.push_back(
        model.muscle(m).wraps.empty() ? 0u : MuscleWrappedPath(model, ws, q, m).status);
    k.force.push_back(t.force_stage);
  }
  if (wrap_modes) {
    k.wrap_modes = CompareWrapModes(model, ws, q);  // every wrapping muscle
  }
  return k;
}

/// "mm" for a revolute column's moment arm difference, "mm/m" for a prismatic one.
const char* WrapArmUnit(const Model& model, int column);

/// The wrap-mode lines of one posture: per wrapping muscle how far opensim and exact differ and
/// where OpenSim's algorithm misbehaves (include/isowrench/wrap_report.hpp).
std::string WrapModeLines(const Model& model, const std::vector<WrapModeDifference>& modes) {
  if (modes.empty()) return "";
  std::ostringstream o;
  o << "wrapping muscles, opensim - exact mode (wrap library; docs/opensim.md \"Wrapping\"):\n";
  for (const WrapModeDifference& d : modes) {
    o << "  " << model.muscle(d.muscle).name << ": length "
      << util::FormatNumber(d.length_opensim * 1e3, 6) << " - "
      << util::FormatNumber(d.length_exact * 1e3, 6) << " = " << FormatWrapMm(d.LengthDifference())
      << " mm";
    if (d.coordinate >= 0 && d.moment_arm_difference >= kWrapReportNoise) {
      o << ", largest moment-arm difference " << FormatWrapMm(d.moment_arm_difference) << " "
        << WrapArmUnit(model, d.coordinate) << " (" << model.joint_names()[d.coordinate] << ")";
    } else {
      o << ", moment arms equal";
    }
    o << ", " << d.wraps_engaged << " of " << model.muscle(d.muscle).wraps.size()
      << " wraps engaged";
    const unsigned bad = d.status_opensim & kWrapMisbehaviour;
    o << "; OpenSim " << (bad ? "misbehaves: " + WrapStatusText(bad) : "behaves") << "\n";
  }
  return o.str();
}

bool Prismatic(const Model& model, int column) {
  return FindCoordinate(model.description(), model.joint_names()[column]).type ==
         JointType::kPrismatic;
}

const char* WrapArmUnit(const Model& model, int column) {
  return Prismatic(model, column) ? "mm/m" : "mm";
}

/// v with -0 written as 0.
std::vector<double> Values(const double* data, Eigen::Index size) {
  std::vector<double> v(data, data + size);
  for (double& x : v) x += 0.0;
  return v;
}

nlohmann::ordered_json Json(const Model& model, const std::vector<PostureKinematics>& results,
                            double activation) {
  nlohmann::ordered_json out;
  out["coordinates"] = model.joint_names();
  nlohmann::ordered_json postures = nlohmann::ordered_json::array();
  for (const PostureKinematics& k : results) {
    nlohmann::ordered_json p;
    p["endpoint_m"] = Values(k.endpoint.data(), 3);
    nlohmann::ordered_json rows = nlohmann::ordered_json::array();
    for (int r = 0; r < 6; ++r) {
      Eigen::RowVectorXd row = k.jacobian.row(r);
      rows.push_back(Values(row.data(), row.size()));
    }
    p["jacobian"] = rows;
    nlohmann::ordered_json muscles = nlohmann::ordered_json::object();
    for (int m = 0; m < model.muscle_count(); ++m) {
      const Eigen::VectorXd& r = k.moment_arm[m];
      muscles[model.muscle(m).name] = {{"length_m", k.length[m]},
                                       {"moment_arm_m", Values(r.data(), r.size())},
                                       {"force", ForceJson(model, m, k.force[m], activation)}};
      if (k.wrap_status[m] != 0) {  // where a wrap misbehaves (WrapStatusText)
        muscles[model.muscle(m).name]["wrap_warning"] = WrapStatusText(k.wrap_status[m]);
      }
    }
    p["muscles"] = muscles;
    if (!k.wrap_modes.empty()) {
      nlohmann::ordered_json wraps = nlohmann::ordered_json::object();
      for (const WrapModeDifference& d : k.wrap_modes) {  // the library's keys (WrapModeJson)
        wraps[model.muscle(d.muscle).name] = nlohmann::ordered_json::parse(WrapModeJson(model, d));
      }
      p["wrap_modes"] = wraps;
    }
    postures.push_back(p);
  }
  out["postures"] = postures;
  return out;
}

/// The JSON laid out as in the documentation: one line per posture item and Jacobian row.
std::string JsonText(const nlohmann::ordered_json& j) {
  std::string out = "{\"coordinates\": " + j["coordinates"].dump() + ",\n \"postures\": [";
  const auto& postures = j["postures"];
  for (size_t i = 0; i < postures.size(); ++i) {
    const auto& p = postures[i];
    out += std::string(i ? ",\n  " : "") + "{\"endpoint_m\": " + p["endpoint_m"].dump() +
           ",\n   \"jacobian\": [";
    for (size_t r = 0; r < p["jacobian"].size(); ++r)
      out += std::string(r ? ",\n                " : "") + p["jacobian"][r].dump();
    out += "],\n   \"muscles\": {";
    size_t m = 0;
    for (const auto& [name, muscle] : p["muscles"].items()) {
      out += std::string(m++ ? ",\n               " : "") + nlohmann::ordered_json(name).dump() +
             ": " + muscle.dump();
    }
    out += "}";
    if (p.contains("wrap_modes")) {
      out += ",\n   \"wrap_modes\": {";
      size_t w = 0;
      for (const auto& [name, modes] : p["wrap_modes"].items()) {
        out += std::string(w++ ? ",\n                 " : "") +
               nlohmann::ordered_json(name).dump() + ": " + modes.dump();
      }
      out += "}";
    }
    out += "}";
  }
  return out + "]}\n";
}

std::string Padded(const std::string& text, int width) {
  return text.size() >= static_cast<size_t>(width) ? text + " "
                                                   : text + std::string(width - text.size(), ' ');
}

// The force stage of every muscle at one posture: model, F with its active and passive parts,
// fiber length, pennation, status, and where OpenSim gives no number.
void ForceTable(std::ostream& o, const Model& model, const PostureKinematics& k,
                double activation) {
  o << "muscle forces at activation " << util::FormatNumber(activation, 4)
    << " (force along the tendon, N; docs/muscle.md)\n";
  for (int m = 0; m < model.muscle_count(); ++m) {
    o << "  " << model.muscle(m).name << " [" << ForceModelLabel(model, m)
      << "]: " << ForceText(model, m, k.force[m]) << "\n";
    const std::string note = OpenSimNote(model, m, k.force[m]);
    if (!note.empty()) o << "    " << note << "\n";
  }
}

std::string Table(const Model& model, const std::vector<PostureKinematics>& results,
                  double activation) {
  const int n = model.dof_count();
  bool wraps = false;
  for (int m = 0; m < model.muscle_count(); ++m) wraps = wraps || !model.muscle(m).wraps.empty();
  const int label = 10;
  std::ostringstream o;
  o << "model " << model.name() << ": " << n << " coordinates (columns), world axes";
  const std::vector<std::string> locked = StaticsProblem(model).LockedNames();
  if (!locked.empty()) {
    o << "; locked (rigid in the statics, still columns here): " << util::Join(locked, ", ");
  }
  o << "\n";
  std::string header = std::string(label, ' ');
  for (const std::string& name : model.joint_names())
    header += std::string(name.size() < 11 ? 11 - name.size() : 1, ' ') + name;
  std::string units = std::string(label, ' ');
  for (int c = 0; c < n; ++c)
    units += std::string(Prismatic(model, c) ? "      (m/m)" : "    (m/rad)");
  for (size_t i = 0; i < results.size(); ++i) {
    const PostureKinematics& k = results[i];
    o << "\nposture " << i + 1 << ": " << FormatPosture(model, k.q, true) << "\n";
    o << "endpoint (m)  x " << util::FormatNumber(k.endpoint.x(), 6) << "  y "
      << util::FormatNumber(k.endpoint.y(), 6) << "  z " << util::FormatNumber(k.endpoint.z(), 6)
      << "\n";
    o << "Jacobian: rows vx vy vz in m/rad (m/m for a prismatic column), wx wy wz in rad/rad "
         "(rad/m)\n"
      << header << "\n";
    const char* rows[6] = {"vx", "vy", "vz", "wx", "wy", "wz"};
    for (int r = 0; r < 6; ++r) {
      o << Padded(rows[r], label);
      for (int c = 0; c < n; ++c) o << Cell(k.jacobian(r, c));
      o << "\n";
    }
    if (model.muscle_count() == 0) continue;
    o << "muscles: length (m) and moment arm -dL/dq about each coordinate\n";
    if (wraps) {
      o << (model.description().wrap_mode == WrapMode::kExact
                ? "(wrapping muscles: --wrap exact, shortest paths over the wrap objects)\n"
                : "(wrapping muscles: --wrap opensim, OpenSim's paths and moment arms, which are "
                  "-dL/dq only where OpenSim's path is a shortest path)\n");
    }
    o << header << "  length (m)\n" << units << "\n";
    for (int m = 0; m < model.muscle_count(); ++m) {
      o << Padded(model.muscle(m).name, label);
      for (int c = 0; c < n; ++c) o << Cell(k.moment_arm[m][c]);
      o << Cell(k.length[m], 12) << "\n";
    }
    for (int m = 0; m < model.muscle_count(); ++m) {
      if (k.wrap_status[m] == 0) continue;
      o << "  " << model.muscle(m).name << ": wrap (" << WrapModeName(model.description().wrap_mode)
        << "): " << WrapStatusText(k.wrap_status[m]) << "\n";
    }
    o << WrapModeLines(model, k.wrap_modes);
    ForceTable(o, model, k, activation);
  }
  return o.str();
}

const bool kKinematicsRegistered = RegisterCommand({
    "kinematics",
    "Endpoint position, 6 x n endpoint Jacobian and every muscle's length, moment arms (-dL/dq) "
    "and force (active, passive, fiber length, pennation) at one or more postures, in "
    "independent coordinates",
    15,
    [](CLI::App& app) -> std::function<int()> {
      auto options = std::make_shared<KinematicsOptions>();
      app.add_option("urdf", options->urdf, "Limb URDF with isowrench extension tags")->required();
      app.add_option(
          "--posture", options->posture,
          "Coordinates over the URDF's nominal posture: name=value in degrees (mm for prismatic "
          "coordinates); repeatable or comma-separated, e.g. --posture hip_rz=-110 --posture "
          "knee_rz=105");
      app.add_option("--postures", options->postures_csv,
                     "CSV file: a header naming coordinates, then one posture per row (degrees, mm "
                     "for prismatic); "
                     "coordinates without a column keep the nominal (or --posture) value");
      app.add_option("--activation", options->activation,
                     "Activation in [0, 1] of the muscle forces printed (default 1)")
          ->check(CLI::Range(0.0, 1.0));
      app.add_option("--force-model", options->force_model,
                     "Force model of every muscle: model (default: each muscle's own), constant, "
                     "rigid (docs/muscle.md)")
          ->check(CLI::IsMember({"model", "constant", "rigid"}));
      app.add_flag(
          "--json", options->json,
          "Print {\"coordinates\": [...], \"postures\": [{\"endpoint_m\", \"jacobian\" (6 rows), "
          "\"muscles\": {name: {\"length_m\", \"moment_arm_m\", \"force\": {\"model\", "
          "\"force_n\", \"active_force_n\", \"passive_force_n\", \"fiber_length_m\", "
          "\"pennation_rad\", \"status\", ...}[, \"wrap_warning\"]}}, and for wrapping muscles "
          "\"wrap_modes\": {name: {\"length_opensim_m\", \"length_exact_m\", "
          "\"length_difference_mm\", \"moment_arm_difference_mm\", "
          "\"moment_arm_difference_coordinate\", \"wraps_engaged\", \"opensim_misbehaves\"}}}]} "
          "in SI units (differences in mm), world axes; wrap_warning where a wrap of the muscle "
          "misbehaves in the --wrap mode");
      app.add_flag("!--no-wrap-modes", options->wrap_modes,
                   "Leave out the opensim-versus-exact comparison of wrapping muscles (about 10 ms "
                   "per posture on the imported rat hindlimb's 22 wrapping muscles)");
      AddWrapOption(app, options->wrap);
      return [options]() {
        ModelOptions load;
        load.urdf = options->urdf;
        load.wrap = options->wrap;
        load.force_model = options->force_model;
        Model model = LoadModel(load);
        Eigen::VectorXd base = model.nominal_posture();
        for (const std::string& assignment : options->posture) {
          std::vector<std::string> warnings;
          base = PostureFromUserText(model, base, assignment, &warnings);
          WarnAll(warnings);
        }
        std::vector<Eigen::VectorXd> postures = {base};
        if (!options->postures_csv.empty())
          postures = ReadPostureCsv(model, options->postures_csv, base);
        Data ws(model);
        std::vector<PostureKinematics> results;
        for (const Eigen::VectorXd& q : postures)
          results.push_back(
              EvaluatePosture(model, ws, q, options->wrap_modes, options->activation));
        // Everything is computed before anything is printed: an error leaves no partial output.
        if (options->json) {
          std::cout << JsonText(Json(model, results, options->activation));
        } else {
          std::cout << Table(model, results, options->activation);
        }
        return 0;
      };
    },
});

}  // namespace
}  // namespace isowrench::cli
