// `isowrench simulate <urdf>`: synthetic measured wrenches from a model with undeclared effects.

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>

#include "cli/command.hpp"
#include "isowrench/error.hpp"
#include "isowrench/frontend.hpp"
#include "isowrench/identification.hpp"
#include "isowrench/io.hpp"
#include "isowrench/trial_csv.hpp"

namespace isowrench::cli {
namespace {

// The defaults are the library's (SimulationOptions{}), which Python's isowrench.simulate uses
// too: one set of defaults.
const SimulationOptions kSimulationDefaults;

struct SimulateOptions {
  ModelOptions model;
  std::vector<std::string> effects;
  double noise_force = kSimulationDefaults.noise_force;
  double noise_moment = kSimulationDefaults.noise_moment;
  int trials = kSimulationDefaults.postures;
  bool trials_given = false;
  std::string postures;  ///< a posture sheet to simulate at
  TrialSheetOptions sheet;
  bool range_given = false;
  unsigned long long seed = kSimulationDefaults.seed;
  double range_deg = kSimulationDefaults.joint_range * 180.0 / M_PI;
  double range_mm = kSimulationDefaults.prismatic_range * 1e3;
  double activation_min = kSimulationDefaults.activation_min;
  double activation_max = kSimulationDefaults.activation_max;
  std::vector<std::string> muscles;
  int noise_dof = kSimulationDefaults.noise_dof;
  double outliers = kSimulationDefaults.outlier_fraction;
  double outlier_size = kSimulationDefaults.outlier_size;
  std::string output;
  bool json = false;
  bool progress = false;
};

std::string Default(double value) { return " (default " + util::FormatNumber(value, 6) + ")"; }

const bool kSimulateRegistered = RegisterCommand(
    {"simulate",
     "Write synthetic measured wrenches (CSV) from the model plus effects the URDF does not "
     "declare, "
     "with seeded Gaussian or Student-t noise and optional gross outliers",
     40, [](CLI::App& app) -> std::function<int()> {
       auto o = std::make_shared<SimulateOptions>();
       AddModelOptions(app, o->model, {/*muscle=*/false, /*posture=*/true, /*statics=*/false});
       app.add_option("--effect", o->effects,
                      "Undeclared effect NAME=V1[,V2...] in user units, repeatable; e.g. "
                      "base_isotropic=1e6 (N/m), "
                      "misalignment=2,0,0 (deg), sensor_offset=0.01,0,0,0,0,0 (N, N·m); "
                      "`isowrench fit --list-effects` lists the names");
       app.add_option("--noise-force", o->noise_force,
                      "Gaussian noise sd per force component, N" + Default(o->noise_force));
       app.add_option("--noise-moment", o->noise_moment,
                      "Gaussian noise sd per moment component, N·m" + Default(o->noise_moment));
       app.add_option("--trials", o->trials,
                      "Number of trials" + Default(o->trials) +
                          "; with --postures, the sheet's rows are cycled (default: each row once)")
           ->each([o](const std::string&) { o->trials_given = true; });
       app.add_option("--postures", o->postures,
                      "Simulate at the postures of this sheet (FILE: coordinate columns in "
                      "degrees / mm, optional muscle and activation columns, e.g. from `isowrench "
                      "design -o`), exactly (--range 0 unless given) instead of drawn around the "
                      "nominal posture")
           ->check([](const std::string& value) -> std::string {
             // --postures used to be the count: say where the count went.
             const bool number =
                 !value.empty() && value.find_first_not_of("0123456789") == std::string::npos;
             if (number && !std::ifstream(value)) {
               return "takes a posture sheet (a CSV file); '" + value +
                      "' is a number: the number of trials is --trials " + value;
             }
             return "";
           });
       AddSheetOptions(app, o->sheet, "the --postures sheet");
       app.add_option("--noise-dof", o->noise_dof,
                      "Student-t noise with this many degrees of freedom (> 2), scaled to the "
                      "stated sd (default 0: "
                      "Gaussian)");
       app.add_option("--outliers", o->outliers,
                      "Fraction of trials made gross outliers, 0 to 0.5" + Default(o->outliers));
       app.add_option(
           "--outlier-size", o->outlier_size,
           "Error of an outlier per component, in stated noise sd" + Default(o->outlier_size));
       app.add_option("--seed", o->seed,
                      "Random seed: the same seed gives the same file" +
                          Default(static_cast<double>(o->seed)));
       app.add_option(
              "--range", o->range_deg,
              "Each limb joint is drawn uniformly in the --posture (default: the nominal one) ± "
              "this many degrees" +
                  Default(o->range_deg) + "; with --postures, around each row (default 0)")
           ->each([o](const std::string&) { o->range_given = true; });
       app.add_option("--range-mm", o->range_mm,
                      "Same for prismatic limb joints, mm" + Default(o->range_mm))
           ->each([o](const std::string&) { o->range_given = true; });
       app.add_option("--activation-min", o->activation_min,
                      "Lowest activation" + Default(o->activation_min));
       app.add_option("--activation-max", o->activation_max,
                      "Highest activation" + Default(o->activation_max));
       app.add_option("--muscle", o->muscles,
                      "Muscles to stimulate, comma-separated or repeated, cycled over trials "
                      "(default: all; a --postures sheet's muscle column comes first)")
           ->delimiter(',');
       app.add_option("-o,--output", o->output, "Output CSV file (written atomically)")->required();
       app.add_flag("--json", o->json, "Print a JSON summary instead of text");
       app.add_flag("--progress", o->progress,
                    "Report progress on stderr even when it is not a terminal (it is reported on "
                    "a terminal anyway)");
       return [o]() {
         Model model = LoadModel(o->model);
         SimulationOptions s;
         s.postures = o->trials;
         s.seed = o->seed;
         s.joint_range = o->range_deg * M_PI / 180.0;
         s.prismatic_range = o->range_mm * 1e-3;
         s.activation_min = o->activation_min;
         s.activation_max = o->activation_max;
         s.noise_force = o->noise_force;
         s.noise_moment = o->noise_moment;
         s.muscles = o->muscles;
         s.noise_dof = o->noise_dof;
         s.outlier_fraction = o->outliers;
         s.outlier_size = o->outlier_size;
         s.center = LoadPosture(model, o->model);
         if (!o->postures.empty() && !o->model.posture.empty()) {
           throw Error(
               "simulate: --posture sets the centre of the sampled postures, and --postures " +
               o->postures + " gives the postures: give one of them");
         }
         if (!o->postures.empty()) {
           SimulateAtPostureSheet(model, o->postures, o->trials_given ? o->trials : 0,
                                  o->range_given, &s, o->sheet);
           o->range_deg = s.joint_range * 180.0 / M_PI;
         }
         const SimulationRun run =
             SimulateToCsv(model, o->effects, s, o->output,
                           TerminalProgress("simulate " + o->output, o->progress));
         const std::vector<AppliedEffect>& effects = run.effects;
         const bool sheet_activations =
             !s.at.empty() && std::all_of(s.at.begin(), s.at.end(), [](const Trial& t) {
               return std::isfinite(t.activation);
             });
         const long written = run.trials;
         if (o->json) {
           std::cout << run.json << "\n";
           return 0;
         }
         std::cout << "isowrench simulate: " << model.name() << " (" << o->model.urdf << ")\n"
                   << "  trials       " << written
                   << (o->postures.empty() ? ", limb joints nominal ± "
                                           : " at the " + std::to_string(s.at.size()) +
                                                 " postures of " + o->postures + " ± ")
                   << util::FormatNumber(o->range_deg, 4) << "°, activation "
                   << (sheet_activations ? "from " + o->postures
                                         : util::FormatNumber(o->activation_min, 3) + " to " +
                                               util::FormatNumber(o->activation_max, 3))
                   << ", seed " << o->seed << "\n"
                   << "  noise        " << util::FormatNumber(o->noise_force, 4) << " N (forces), "
                   << util::FormatNumber(o->noise_moment, 4) << " N·m (moments), Gaussian sd\n";
         if (effects.empty()) std::cout << "  effects      none (data follow the URDF)\n";
         for (const AppliedEffect& a : effects) {
           std::vector<std::string> items;
           for (size_t i = 0; i < a.values.size(); ++i) {
             items.push_back(a.effect.parameters[i].name + " = " +
                             util::FormatNumber(a.values[i], 6) + " " +
                             a.effect.parameters[i].unit);
           }
           std::cout << "  effect       " << a.effect.id << ": " << util::Join(items, ", ") << "\n";
         }
         std::cout << "  wrote        " << o->output << "\n";
         return 0;
       };
     }});

}  // namespace
}  // namespace isowrench::cli
