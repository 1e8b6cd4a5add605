// `isowrench import MODEL.osim -o MODEL.urdf --clamp BODY --endpoint BODY[:x,y,z]`: an OpenSim
// model as an isowrench URDF (include/isowrench/opensim.hpp, docs/opensim.md).

#include <iostream>
#include <memory>

#include "cli/command.hpp"
#include "isowrench/error.hpp"
#include "isowrench/io.hpp"
#include "isowrench/kinematics.hpp"
#include "isowrench/opensim.hpp"

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
      app.add_flag("--report", a->report,
                   "Print the bodies, joints and their URDF expansion, coordinates and muscles");
      app.add_flag("--json", a->json, "Print the report tables and the warnings as JSON");
      return [a]() {
        ParseEndpoint(a->endpoint, a->options);
        a->options.unlock = a->unlock;
        OpenSimImport import = ImportOpenSimFile(a->osim, a->options);
        const LimbDescription& d = import.description;
        CheckEvaluable(import, a->options, a->output);
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
                                      {"warnings", import.warnings}}
                           .dump(2)
                    << "\n";
          return 0;
        }
        if (a->report) std::cout << FormatOpenSimReport(import);
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
