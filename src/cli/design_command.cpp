// `isowrench design <urdf> --effects ID,... --n N [--postures FILE]`: which postures to record
// so that the named effects can be identified and told apart (D-optimal on the Fisher
// information at the nominal model).

#include <cstdio>
#include <iostream>

#include "cli/command.hpp"
#include "isowrench/error.hpp"
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
};

std::vector<Trial> CandidatesFromFile(const Model& model, const DesignCommandOptions& o) {
  std::vector<Eigen::VectorXd> postures =
      ReadPostureCsv(model, o.postures, model.nominal_posture());
  std::vector<std::string> muscles = o.muscles;
  if (muscles.empty()) {
    for (int i = 0; i < model.muscle_count(); ++i) muscles.push_back(model.muscle(i).name);
  }
  auto names = std::make_shared<const std::vector<std::string>>(model.joint_names());
  std::vector<Trial> out;
  for (size_t k = 0; k < postures.size(); ++k) {
    for (const std::string& m : muscles) {
      Trial t;
      t.q = postures[k];
      t.joint_names = names;
      t.muscle = m;
      t.activation = 1.0;
      t.line = static_cast<long>(k + 1);
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
       AddModelOptions(app, o->model, /*with_muscle=*/false);
       app.add_option("--effects", o->effects,
                      "Effect ids to identify, comma separated (`isowrench fit --list-effects`)")
           ->required();
       app.add_option("--n", o->n, "Number of trials to choose (default 20)");
       app.add_option("--postures", o->postures,
                      "Candidate postures, CSV with coordinate columns in degrees / mm (default: a "
                      "random grid)");
       app.add_option("--grid", o->grid,
                      "Random grid size when no --postures file is given (default 400)");
       app.add_option("--seed", o->seed, "Grid seed (default 1)");
       app.add_option("--range", o->range_deg,
                      "Grid: each limb joint in nominal ± this many degrees (default 15)");
       app.add_option("--noise-force", o->noise_force,
                      "Expected noise sd per force component, N (default 0.002)");
       app.add_option("--noise-moment", o->noise_moment,
                      "Expected noise sd per moment component, N·m (default 5e-5)");
       app.add_option("--muscle", o->muscles, "Muscles to stimulate (default: all)");
       app.add_option("-o,--output", o->output,
                      "Write the chosen trials as a posture CSV (degrees / mm) here");
       app.add_flag("--json", o->json, "Print everything as JSON");
       return [o]() {
         Model model = LoadModel(o->model);
         std::vector<std::string> ids;
         for (const std::string& id : util::Split(o->effects, ",")) {
           if (!util::Trim(id).empty()) ids.push_back(util::Trim(id));
         }
         DesignOptions d;
         d.postures = o->n;
         d.candidates = o->grid;
         d.seed = o->seed;
         d.joint_range = o->range_deg * 3.14159265358979323846 / 180.0;
         d.noise_force = o->noise_force;
         d.noise_moment = o->noise_moment;
         d.muscles = o->muscles;
         std::vector<Trial> candidates;
         if (!o->postures.empty()) candidates = CandidatesFromFile(model, *o);
         DesignResult r =
             DesignExperiment(model, ids, o->postures.empty() ? nullptr : &candidates, d);
         if (!o->output.empty()) {
           std::vector<std::string> muscles;
           for (const Trial& t : r.chosen) muscles.push_back(t.muscle);
           std::string csv = "# isowrench design: " + util::Join(ids, ",") +
                             "; stimulate, row by row: " + util::Join(muscles, " ") + "\n";
           std::vector<std::string> header;
           for (const std::string& name : model.joint_names()) header.push_back(name);
           csv += util::Join(header, ",") + "\n";
           for (const Trial& t : r.chosen) {
             std::vector<std::string> row;
             for (int j = 0; j < model.dof_count(); ++j) {
               row.push_back(
                   util::FormatNumber(JointValueToUserUnits(model.joint(j).type, t.q[j]), 10));
             }
             csv += util::Join(row, ",") + "\n";
           }
           WriteTextFile(o->output, csv);
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
         std::cout
             << "Expected standard error of each parameter (noise "
             << util::FormatNumber(o->noise_force, 3) << " N, "
             << util::FormatNumber(o->noise_moment, 3) << " N·m):\n"
             << "  parameter                              at         SE (design)   SE (first N)\n";
         for (size_t i = 0; i < r.labels.size(); ++i) {
           char line[200];
           std::snprintf(line, sizeof(line), "  %-34s %10s %14s %14s  %s\n", r.labels[i].c_str(),
                         util::FormatNumber(r.values[i], 4).c_str(),
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
