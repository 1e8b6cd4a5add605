// `isowrench design <urdf> --effects ID,... --n N [--postures FILE]`: which postures to record
// so that the named effects can be identified and told apart (D-optimal on the Fisher
// information at the nominal model).

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>

#include "cli/command.hpp"
#include "isowrench/error.hpp"
#include "isowrench/frontend.hpp"
#include "isowrench/identification.hpp"
#include "isowrench/io.hpp"
#include "isowrench/plots.hpp"
#include "isowrench/posture.hpp"

namespace isowrench::cli {
namespace {

struct DesignCommandOptions {
  ModelOptions model;
  std::string effects;
  int n = 20;
  std::string postures;
  int grid = 400;
  unsigned long long seed = 1;
  double range_deg = 15.0;
  double noise_force = 0.002;
  double noise_moment = 5e-5;
  std::vector<std::string> muscles;
  std::string output;
  bool json = false;
  TrialSheetOptions sheet;
};

// Candidate trials from a posture sheet: rows with a muscle as they are, rows without one once
// per muscle (--muscle, default all), at activation 1 unless the sheet gives one.
std::vector<Trial> CandidatesFromFile(const Model& model, const DesignCommandOptions& o) {
  std::vector<std::string> muscles = o.muscles;
  if (muscles.empty()) {
    for (int i = 0; i < model.muscle_count(); ++i) muscles.push_back(model.muscle(i).name);
  }
  std::vector<Trial> out;
  for (Trial t : ReadPostureSheet(model, o.postures, o.sheet)) {
    if (!std::isfinite(t.activation)) t.activation = 1.0;
    if (!t.muscle.empty()) {
      out.push_back(t);
      continue;
    }
    for (const std::string& m : muscles) {
      t.muscle = m;
      out.push_back(t);
    }
  }
  return out;
}

const bool kDesignRegistered = RegisterCommand(
    {"design",
     "Choose the postures to record so that named effects are identifiable and separable "
     "(D-optimal), "
     "with the expected standard errors and the correlations that remain",
     42, [](CLI::App& app) -> std::function<int()> {
       auto o = std::make_shared<DesignCommandOptions>();
       AddModelOptions(app, o->model, {/*muscle=*/false, /*posture=*/true, /*statics=*/false});
       app.add_option("--effects", o->effects,
                      "Effect ids to identify, comma separated (`isowrench fit --list-effects`)")
           ->required();
       app.add_option("--n", o->n, "Number of trials to choose (default 20)");
       app.add_option("--postures", o->postures,
                      "Candidate postures: a posture sheet (coordinate columns in degrees / mm, "
                      "optional muscle and activation columns; default: a random grid)");
       AddSheetOptions(app, o->sheet, "the --postures sheet");
       app.add_option("--grid", o->grid,
                      "Random grid size when no --postures file is given (default 400)");
       app.add_option("--seed", o->seed, "Grid seed (default 1)");
       app.add_option(
           "--range", o->range_deg,
           "Grid: each limb joint in the --posture (default: the nominal one) ± this many "
           "degrees (default 15)");
       app.add_option("--noise-force", o->noise_force,
                      "Expected noise sd per force component, N (default 0.002)");
       app.add_option("--noise-moment", o->noise_moment,
                      "Expected noise sd per moment component, N·m (default 5e-5)");
       app.add_option("--muscle", o->muscles,
                      "Muscles to stimulate, comma-separated or repeated (default: all)")
           ->delimiter(',');
       app.add_option("-o,--output", o->output,
                      "Write the chosen trials here as a posture sheet: coordinates (degrees / "
                      "mm), muscle, activation and empty fx ... mz columns to fill in; `simulate "
                      "--postures` and, once filled in, `fit` read it as is");
       app.add_flag("--json", o->json, "Print everything as JSON");
       return [o]() {
         Model model = LoadModel(o->model);
         const std::vector<std::string> ids = ParseList(o->effects);
         DesignOptions d;
         d.postures = o->n;
         d.candidates = o->grid;
         d.seed = o->seed;
         d.joint_range = o->range_deg * 3.14159265358979323846 / 180.0;
         d.noise_force = o->noise_force;
         d.noise_moment = o->noise_moment;
         d.muscles = o->muscles;
         if (!o->model.posture.empty()) {
           if (!o->postures.empty()) {
             throw Error("design: --posture sets the centre of the sampled grid, and --postures " +
                         o->postures + " gives the candidate postures: give one of them");
           }
           d.center = LoadPosture(model, o->model);
         }
         std::vector<Trial> candidates;
         if (!o->postures.empty()) candidates = CandidatesFromFile(model, *o);
         DesignResult r =
             DesignExperiment(model, ids, o->postures.empty() ? nullptr : &candidates, d);
         if (!o->output.empty()) {
           WriteTextFile(
               o->output,
               PostureSheetText(model, r.chosen,
                                "isowrench design: " + util::Join(ids, ",") +
                                    "; record each row's muscle at its activation and "
                                    "fill in fx fy fz (N) mx my mz (N·m), or simulate "
                                    "it: isowrench simulate " +
                                    o->model.urdf + " --postures " + o->output + " -o data.csv"));
         }
         if (o->json) {
           nlohmann::json params = nlohmann::json::array();
           for (size_t i = 0; i < r.labels.size(); ++i) {
             params.push_back({{"parameter", r.labels[i]},
                               {"unit", r.units[i]},
                               {"at", r.values[i]},
                               {"expected_standard_error", r.standard_errors[i]},
                               {"first_n_standard_error", r.random_standard_errors[i]}});
           }
           nlohmann::json corr = nlohmann::json::array();
           for (int i = 0; i < r.correlation.rows(); ++i) {
             nlohmann::json row = nlohmann::json::array();
             for (int j = 0; j < r.correlation.cols(); ++j) row.push_back(r.correlation(i, j));
             corr.push_back(row);
           }
           nlohmann::json trials = nlohmann::json::array();
           for (size_t k = 0; k < r.chosen.size(); ++k) {
             trials.push_back({{"candidate", r.chosen_index[k]},
                               {"posture", FormatPosture(model, r.chosen[k].q, true)},
                               {"muscle", r.chosen[k].muscle}});
           }
           std::cout << nlohmann::json{{"effects", ids},
                                       {"n", o->n},
                                       {"candidates", r.candidate_count},
                                       {"chosen", trials},
                                       {"parameters", params},
                                       {"correlation", corr},
                                       {"confounded", r.confounded},
                                       {"log_det", r.log_det},
                                       {"log_det_first_n", r.log_det_random},
                                       {"notes", r.notes},
                                       {"output", o->output.empty() ? nlohmann::json(nullptr)
                                                                    : nlohmann::json(o->output)}}
                            .dump(2)
                     << "\n";
           return 0;
         }
         std::cout << "isowrench design: " << model.name() << " (" << o->model.urdf << "), effects "
                   << util::Join(ids, ", ") << "\n  " << r.chosen.size() << " of "
                   << r.candidate_count
                   << " candidate trials chosen (D-optimal: log det of the Fisher information " +
                          util::FormatNumber(r.log_det, 5) + " vs " +
                          util::FormatNumber(r.log_det_random, 5) + " for the first " +
                          std::to_string(o->n) + " candidates)\n\n";
         std::cout << "Expected standard error of each parameter (noise "
                   << util::FormatNumber(o->noise_force, 3) << " N, "
                   << util::FormatNumber(o->noise_moment, 3) << " N·m):\n";
         // The label column as wide as the longest label (force_length:MUSCLE.l_Ts_scale).
         int width = 34;
         for (const std::string& l : r.labels) width = std::max(width, static_cast<int>(l.size()));
         char header[400];
         std::snprintf(header, sizeof(header), "  %-*s %10s %14s %14s\n", width, "parameter", "at",
                       "SE (design)", "SE (first N)");
         std::cout << header;
         for (size_t i = 0; i < r.labels.size(); ++i) {
           char line[400];
           std::snprintf(line, sizeof(line), "  %-*s %10s %14s %14s  %s\n", width,
                         r.labels[i].c_str(), util::FormatNumber(r.values[i], 4).c_str(),
                         util::FormatNumber(r.standard_errors[i], 3).c_str(),
                         util::FormatNumber(r.random_standard_errors[i], 3).c_str(),
                         r.units[i].c_str());
           std::cout << line;
         }
         std::cout << "\nCorrelations that remain: ";
         std::cout << (r.confounded.empty() ? "none above 0.9\n" : "\n");
         for (const std::string& s : r.confounded) std::cout << "  " << s << "\n";
         for (const std::string& s : r.notes) std::cout << "  note: " << s << "\n";
         std::cout << "\nChosen trials:\n";
         for (size_t k = 0; k < r.chosen.size(); ++k) {
           std::cout << "  " << k + 1 << ". " << r.chosen[k].muscle << " at "
                     << FormatPosture(model, r.chosen[k].q, true) << "\n";
         }
         if (!o->output.empty())
           std::cout << "\nwrote the chosen postures to " << o->output << "\n";
         return 0;
       };
     }});

}  // namespace
}  // namespace isowrench::cli
