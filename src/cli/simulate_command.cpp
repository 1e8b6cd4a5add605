// `isowrench simulate <urdf>`: synthetic measured wrenches from a model with undeclared effects.

#include <cmath>
#include <iostream>

#include "cli/command.hpp"
#include "isowrench/error.hpp"
#include "isowrench/identification.hpp"
#include "isowrench/io.hpp"
#include "isowrench/trial_csv.hpp"

namespace isowrench::cli {
namespace {

struct SimulateOptions {
  ModelOptions model;
  std::vector<std::string> effects;
  double noise_force = 0.002;
  double noise_moment = 5e-5;
  int postures = 50;
  unsigned long long seed = 1;
  double range_deg = 15.0;
  double range_mm = 5.0;
  double activation_min = 0.3;
  double activation_max = 1.0;
  std::vector<std::string> muscles;
  int noise_dof = 0;
  double outliers = 0.0;
  double outlier_size = 50.0;
  std::string output;
  bool json = false;
  bool progress = false;
};

const bool kSimulateRegistered = RegisterCommand(
    {"simulate",
     "Write synthetic measured wrenches (CSV) from the model plus effects the URDF does not "
     "declare, "
     "with seeded Gaussian or Student-t noise and optional gross outliers",
     40, [](CLI::App& app) -> std::function<int()> {
       auto o = std::make_shared<SimulateOptions>();
       AddModelOptions(app, o->model, /*with_muscle=*/false);
       app.add_option("--effect", o->effects,
                      "Undeclared effect NAME=V1[,V2...] in user units, repeatable; e.g. "
                      "base_isotropic=1e6 (N/m), "
                      "misalignment=2,0,0 (deg), sensor_offset=0.01,0,0,0,0,0 (N, N·m); "
                      "`isowrench fit --list-effects` lists the names");
       app.add_option("--noise-force", o->noise_force,
                      "Gaussian noise sd per force component, N (default 0.002)");
       app.add_option("--noise-moment", o->noise_moment,
                      "Gaussian noise sd per moment component, N·m (default 5e-5)");
       app.add_option("--postures", o->postures, "Number of trials (default 50)");
       app.add_option("--noise-dof", o->noise_dof,
                      "Student-t noise with this many degrees of freedom (> 2), scaled to the "
                      "stated sd (default 0: "
                      "Gaussian)");
       app.add_option("--outliers", o->outliers,
                      "Fraction of trials made gross outliers, 0 to 0.5 (default 0)");
       app.add_option("--outlier-size", o->outlier_size,
                      "Error of an outlier per component, in stated noise sd (default 50)");
       app.add_option("--seed", o->seed,
                      "Random seed: the same seed gives the same file (default 1)");
       app.add_option(
           "--range", o->range_deg,
           "Each limb joint is drawn uniformly in nominal ± this many degrees (default 15)");
       app.add_option("--range-mm", o->range_mm, "Same for prismatic limb joints, mm (default 5)");
       app.add_option("--activation-min", o->activation_min, "Lowest activation (default 0.3)");
       app.add_option("--activation-max", o->activation_max, "Highest activation (default 1)");
       app.add_option("--muscle", o->muscles,
                      "Muscles to stimulate, cycled over trials (default: all)");
       app.add_option("-o,--output", o->output, "Output CSV file (written atomically)")->required();
       app.add_flag("--json", o->json, "Print a JSON summary instead of text");
       app.add_flag("--progress", o->progress,
                    "Report progress on stderr even when it is not a terminal (it is reported on "
                    "a terminal anyway)");
       return [o]() {
         Model model = LoadModel(o->model);
         std::vector<AppliedEffect> effects;
         for (const std::string& text : o->effects)
           effects.push_back(ParseEffectAssignment(model, text));
         AugmentedModel truth = ApplyEffects(model.description(), effects);
         SimulationOptions s;
         s.postures = o->postures;
         s.seed = o->seed;
         s.joint_range = o->range_deg * 3.14159265358979323846 / 180.0;
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
         // Streamed: each chunk of trials is written as soon as it is simulated (bounded
         // memory); the file appears only when complete.
         util::AtomicOutputFile file(o->output);
         TrialCsvWriter writer(model, file.stream(), /*with_sd=*/true);
         long written = 0;
         ForEachSimulatedTrial(
             model, truth, s,
             [&](const Trial& t) {
               writer.Write(t);
               ++written;
             },
             TerminalProgress("simulate " + o->output, o->progress));
         file.Commit();
         if (o->json) {
           nlohmann::json e = nlohmann::json::array();
           for (const AppliedEffect& a : effects) {
             nlohmann::json params = nlohmann::json::array();
             for (size_t i = 0; i < a.values.size(); ++i) {
               params.push_back({{"name", a.effect.parameters[i].name},
                                 {"value", a.values[i]},
                                 {"unit", a.effect.parameters[i].unit}});
             }
             e.push_back({{"id", a.effect.id}, {"parameters", params}});
           }
           std::cout << nlohmann::json{{"output", o->output},
                                       {"trials", written},
                                       {"seed", o->seed},
                                       {"noise_force_N", o->noise_force},
                                       {"noise_moment_Nm", o->noise_moment},
                                       {"range_deg", o->range_deg},
                                       {"effects", e}}
                            .dump(2)
                     << "\n";
           return 0;
         }
         std::cout << "isowrench simulate: " << model.name() << " (" << o->model.urdf << ")\n"
                   << "  trials       " << written << ", limb joints nominal ± "
                   << util::FormatNumber(o->range_deg, 4) << "°, activation "
                   << util::FormatNumber(o->activation_min, 3) << " to "
                   << util::FormatNumber(o->activation_max, 3) << ", seed " << o->seed << "\n"
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
