// `isowrench paper --figure N`: the paper's Figure 2, 3 or 4 conditions on the shipped rat limb.

#include <algorithm>
#include <iostream>

#include "cli/command.hpp"
#include "isowrench/paper.hpp"

namespace isowrench::cli {
namespace {

void PrintFigure(int figure, const std::vector<PaperPanel>& panels) {
  static const char* kTitles[] = {
      "", "",
      "Figure 2: transducer compliance alters the measured wrench when over-constrained "
      "(rigid base, S_p = 0)",
      "Figure 3: base compliance alters the measured wrench when over-constrained "
      "(balanced S_t = 1e7)",
      "Figure 4: knee ab/adduction as a joint dof with 1 N·m/rad stiffness (6-dof limb, all 6 "
      "transducer dofs restrained)"};
  std::cout
      << kTitles[figure] << "\n"
      << "GP muscle, 2.3 N, posture hip_rz=-110°, knee_rz=105°. W = wrench the limb applies to "
         "the transducer, world axes, moment about the ankle.\n\n";
  const int w = 34;
  std::vector<std::string> columns;
  for (const PaperPanel& p : panels) {
    if (std::find(columns.begin(), columns.end(), p.column) == columns.end())
      columns.push_back(p.column);
  }
  for (const std::string& column : columns) {
    if (!column.empty()) std::cout << "[" << column << "]\n";
    std::cout << WrenchHeader(w) << "\n";
    for (const PaperPanel& p : panels) {
      if (p.column != column) continue;
      std::cout << WrenchRow(p.row + "  " + p.method, p.wrench, w) << "\n";
      std::cout << "     " << p.condition << "\n";
      if (!p.valid || !p.note.empty())
        std::cout << "     ! " << (p.note.empty() ? "not valid" : p.note) << "\n";
    }
    std::cout << "\n";
  }
  std::cout << "\n";
}

const bool kPaperRegistered = RegisterCommand({
    "paper",
    "Recompute the seed paper's Figure 2, 3 or 4 wrenches on the shipped rat hindlimb URDFs",
    20,
    [](CLI::App& app) -> std::function<int()> {
      auto figure = std::make_shared<int>(2);
      auto json = std::make_shared<bool>(false);
      auto dir = std::make_shared<std::string>();
      app.add_option("--figure", *figure, "Figure number: 2, 3 or 4 (default 2)")
          ->check(CLI::IsMember({2, 3, 4}));
      app.add_option("--urdf-dir", *dir,
                     "Directory holding rat_hindlimb_5dof.urdf and rat_hindlimb_6dof.urdf");
      app.add_flag("--json", *json, "Print JSON instead of the table");
      return [figure, json, dir]() {
        std::string urdf_dir = dir->empty() ? DefaultUrdfDirectory() : *dir;
        std::vector<PaperPanel> panels = ComputePaperFigure(*figure, urdf_dir);
        if (*json) {
          nlohmann::json out = nlohmann::json::array();
          for (const PaperPanel& p : panels) {
            out.push_back({{"figure", p.figure},
                           {"row", p.row},
                           {"column", p.column},
                           {"method", p.method},
                           {"condition", p.condition},
                           {"s_t", ToJson(p.s_t)},
                           {"base_stiffness_N_per_m", p.base_stiffness},
                           {"wrench", WrenchJson(p.wrench)},
                           {"valid", p.valid},
                           {"note", p.note}});
          }
          std::cout << out.dump(2) << "\n";
        } else {
          PrintFigure(*figure, panels);
        }
        return 0;
      };
    },
});

}  // namespace
}  // namespace isowrench::cli
