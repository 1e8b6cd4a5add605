// `isowrench import MODEL.osim -o MODEL.urdf --clamp BODY --endpoint BODY[:x,y,z]`: an OpenSim
// model as an isowrench URDF (include/isowrench/opensim.hpp, docs/opensim.md).

#include <iostream>
#include <memory>
#include <sstream>

#include "cli/command.hpp"
#include "isowrench/error.hpp"
#include "isowrench/io.hpp"
#include "isowrench/kinematics.hpp"
#include "isowrench/opensim.hpp"
#include "isowrench/posture.hpp"
#include "isowrench/wrap_report.hpp"

namespace isowrench::cli {
namespace {

// --endpoint "tibia" or "tibia:0.01,-0.2,0": ParseEndpoint of isowrench/frontend.hpp.

// What the engine can evaluate, checked before anything is written: the URDF text read back
// builds a Model (the joint and coordinate limits, couplings and muscles all validated), which
// has a movable joint and a muscle, and each muscle has a length and moment arms at the default
// posture (a muscle whose path points coincide there gets a warning: only it cannot be
// evaluated). @throws Error naming what fails; nothing is written then.
void CheckEvaluable(OpenSimImport& import, const OpenSimImportOptions& options,
                    const std::string& output) {
  const LimbDescription& d = import.description;
  const std::string chain =
      "the chain from '" + options.clamp_body + "' to '" + options.endpoint_body + "'";
  const std::string nothing = "; nothing was written to " + output;
  std::unique_ptr<Model> model;
  try {
    model = std::make_unique<Model>(ReadUrdfString(WriteUrdfString(d), output));
  } catch (const Error& e) {
    throw Error("the imported model cannot be evaluated: " + std::string(e.what()) + nothing);
  }
  if (model->dof_count() == 0) {
    throw Error(chain + " has no movable joint: nothing can move, so no wrench can be computed" +
                nothing + " (choose a clamp body proximal to the joints)");
  }
  if (model->muscle_count() == 0) {
    throw Error(chain +
                " carries no muscle path (no muscle has points on it and on ground or "
                "the clamped body)" +
                nothing);
  }
  Data data(*model);
  const Eigen::VectorXd q = model->nominal_posture();
  for (int m = 0; m < model->muscle_count(); ++m) {
    try {
      ComputeMuscleTorque(*model, data, q, m);
    } catch (const Error& e) {
      import.warnings.push_back("muscle '" + model->muscle(m).name +
                                "' cannot be evaluated at the default posture: " + e.what());
    }
  }
}

// Values per coordinate of the wrap-mode sweep of `import --report` (SweepWrapModes).
constexpr int kWrapSweepSteps = 5;

// For each wrapping muscle: how far the opensim and exact modes differ at the default posture
// and over the sweep, and where OpenSim's algorithm misbehaves (wrap_report.hpp). The rows, and
// the JSON the same numbers.
struct WrapModeReport {
  std::string text;
  nlohmann::ordered_json json = nlohmann::ordered_json::array();
};

WrapModeReport ReportWrapModes(const LimbDescription& description) {
  WrapModeReport out;
  const Model model(description);
  const std::vector<int> muscles = WrappingMuscles(model);
  if (muscles.empty()) return out;
  Data data(model);
  const Eigen::VectorXd q0 = model.nominal_posture();
  std::ostringstream o;
  o << "\nWrapping muscles: opensim - exact mode at the default posture, and the largest "
       "differences over a sweep of each coordinate's range ("
    << kWrapSweepSteps
    << " values, one coordinate at a time); moment arms in mm (mm/m for a prismatic "
       "coordinate); where OpenSim's algorithm misbehaves (docs/opensim.md \"Wrapping\")\n";
  for (int m : muscles) {
    const WrapModeSweep s = SweepWrapModes(model, data, q0, m, kWrapSweepSteps);
    const WrapModeDifference& d = s.at_q0;
    const std::string& name = model.muscle(m).name;
    auto arm_unit = [&](int c) {
      return model.coordinate(c).type == JointType::kPrismatic ? " mm/m" : " mm";
    };
    o << "  " << name << " (" << d.wraps_engaged << " of " << model.muscle(m).wraps.size()
      << " wraps engaged): length " << util::FormatNumber(d.length_opensim * 1e3, 6) << " - "
      << util::FormatNumber(d.length_exact * 1e3, 6) << " = " << FormatWrapMm(d.LengthDifference())
      << " mm";
    if (d.coordinate >= 0 && d.moment_arm_difference >= kWrapReportNoise) {
      o << ", moment arm " << FormatWrapMm(d.moment_arm_difference) << arm_unit(d.coordinate)
        << " (" << model.joint_names()[d.coordinate] << ")";
    } else {
      o << ", moment arms equal";
    }
    o << "; sweep of " << s.postures << " postures: length up to "
      << FormatWrapMm(s.max_length_difference) << " mm";
    if (s.max_moment_arm_coordinate >= 0 && s.max_moment_arm_difference >= kWrapReportNoise) {
      o << ", moment arm up to " << FormatWrapMm(s.max_moment_arm_difference)
        << arm_unit(s.max_moment_arm_coordinate) << " ("
        << model.joint_names()[s.max_moment_arm_coordinate] << " at "
        << FormatPosture(model, s.max_moment_arm_posture) << ")";
    } else {
      o << ", moment arms equal";
    }
    const unsigned bad = d.status_opensim & kWrapMisbehaviour;
    o << "\n    OpenSim at the default posture: "
      << (bad ? "misbehaves: " + WrapStatusText(bad) : "behaves") << "; over the sweep: ";
    if (s.misbehaving_postures == 0) {
      o << "behaves\n";
    } else {
      o << "misbehaves at " << s.misbehaving_postures << " of " << s.postures
        << " postures: " << WrapStatusText(s.misbehaviour) << " (first at "
        << FormatPosture(model, s.first_misbehaving_posture) << ")\n";
    }
    out.json.push_back(
        {{"muscle", name},
         {"wraps", model.muscle(m).wraps.size()},
         {"wraps_engaged", d.wraps_engaged},
         {"length_opensim_m", d.length_opensim},
         {"length_exact_m", d.length_exact},
         {"length_difference_mm", d.LengthDifference() * 1e3},
         {"moment_arm_difference_mm", d.moment_arm_difference * 1e3},
         {"moment_arm_difference_coordinate",
          d.coordinate >= 0 ? nlohmann::ordered_json(model.joint_names()[d.coordinate])
                            : nlohmann::ordered_json()},
         {"opensim_misbehaves", WrapStatusText(bad)},
         {"sweep_postures", s.postures},
         {"sweep_max_length_difference_mm", s.max_length_difference * 1e3},
         {"sweep_max_moment_arm_difference_mm", s.max_moment_arm_difference * 1e3},
         {"sweep_opensim_misbehaves", WrapStatusText(s.misbehaviour)},
         {"sweep_misbehaving_postures", s.misbehaving_postures}});
  }
  out.text = o.str();
  return out;
}

const bool kImportRegistered = RegisterCommand({
    "import",
    "Import an OpenSim model (.osim) as an isowrench URDF: the chain from the clamped body to the "
    "endpoint body, coordinates, spline couplings and muscles (docs/opensim.md)",
    80,
    [](CLI::App& app) -> std::function<int()> {
      struct Args {
        std::string osim, output, endpoint;
        OpenSimImportOptions options;
        std::vector<std::string> unlock;
        bool report = false;
        bool json = false;
      };
      auto a = std::make_shared<Args>();
      app.add_option("model", a->osim, "OpenSim model (.osim, document versions 30000-40600)")
          ->required();
      app.add_option("-o,--output", a->output, "URDF file to write (written only on success)")
          ->required();
      app.add_option("--clamp", a->options.clamp_body,
                     "The body bolted in the experiment (e.g. pelvis or femur_r); the joints from "
                     "ground to it are fixed at their default coordinates")
          ->required();
      app.add_option("--endpoint", a->endpoint,
                     "BODY or BODY:x,y,z - the body carrying the transducer and the endpoint in "
                     "its frame in metres (default its origin)")
          ->required();
      app.add_option("--unlock", a->unlock, "Coordinates locked in the .osim to import as free")
          ->delimiter(',');
      app.add_flag(
          "--report", a->report,
          "Print the bodies, joints and their URDF expansion, coordinates and muscles, and for "
          "each wrapping muscle how far the opensim and exact wrap modes differ (default "
          "posture and a sweep of each coordinate) and where OpenSim's algorithm "
          "misbehaves");
      app.add_flag("--json", a->json,
                   "Print the report tables, the wrap-mode comparison (\"wrap_modes\") and the "
                   "warnings as JSON");
      return [a]() {
        ParseEndpoint(a->endpoint, a->options);
        a->options.unlock = a->unlock;
        OpenSimImport import = ImportOpenSimFile(a->osim, a->options);
        const LimbDescription& d = import.description;
        CheckEvaluable(import, a->options, a->output);
        // Computed before the file is written: an error leaves no file and no partial report.
        const WrapModeReport wraps = a->report || a->json ? ReportWrapModes(d) : WrapModeReport{};
        WriteUrdfFile(d, a->output);
        if (a->json) {
          nlohmann::json tables = nlohmann::json::object();
          for (const OpenSimReportTable& t : import.tables) {
            nlohmann::json rows = nlohmann::json::array();
            for (const auto& row : t.rows) {
              nlohmann::json r;
              for (size_t i = 0; i < row.size() && i < t.header.size(); ++i)
                r[t.header[i]] = row[i];
              rows.push_back(r);
            }
            tables[t.title] = rows;
          }
          std::cout << nlohmann::json{{"output", a->output},
                                      {"model", a->osim},
                                      {"document_version", import.version},
                                      {"coordinates", d.coordinates.size()},
                                      {"muscles", d.muscles.size()},
                                      {"tables", tables},
                                      {"wrap_modes", wraps.json},
                                      {"warnings", import.warnings}}
                           .dump(2)
                    << "\n";
          return 0;
        }
        if (a->report) std::cout << FormatOpenSimReport(import) << wraps.text;
        size_t movable = 0, coupled = 0, locked = 0;
        for (const JointSpec& j : d.joints) {
          if (j.type == JointType::kFixed) continue;
          ++movable;
          if (j.coordinate != j.name) ++coupled;
        }
        for (const CoordinateSpec& c : d.coordinates) locked += c.locked ? 1 : 0;
        std::cout << "wrote " << a->output << ": " << d.coordinates.size() << " coordinate"
                  << (d.coordinates.size() == 1 ? "" : "s") << " (" << locked << " locked), "
                  << movable << " movable URDF joints (" << coupled << " coupled), "
                  << d.muscles.size() << " muscle" << (d.muscles.size() == 1 ? "" : "s")
                  << ", endpoint on " << d.transducer.link << "; " << import.warnings.size()
                  << " warning" << (import.warnings.size() == 1 ? "" : "s") << "\n";
        if (!a->report) {
          for (const std::string& w : import.warnings) std::cout << "  ! " << w << "\n";
        }
        return 0;
      };
    },
});

}  // namespace
}  // namespace isowrench::cli
