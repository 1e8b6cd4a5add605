// Example and CTest case: simulate measured wrenches with a hidden base compliance on the rat
// hindlimb, fit the candidate effects, and write the HTML and markdown fit reports.
//   fit_report_example <out-dir>   -> <out-dir>/fit_report.html, <out-dir>/fit_report.md

#include <iostream>

#include "isowrench/identification.hpp"
#include "isowrench/paper.hpp"
#include "isowrench/plots.hpp"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: fit_report_example <out-dir>\n";
    return 2;
  }
  try {
    const std::string out = argv[1];
    const isowrench::Model model = isowrench::Model::FromUrdfFile(
        isowrench::DefaultUrdfDirectory() + "/rat_hindlimb_5dof.urdf");
    isowrench::SimulationOptions sim;
    sim.postures = 30;
    sim.seed = 3;
    const auto truth = isowrench::ApplyEffects(
        model.description(), {isowrench::ParseEffectAssignment(model, "base_isotropic=2e4")});
    std::vector<isowrench::Trial> trials = isowrench::SimulateTrials(model, truth, sim);
    isowrench::FitOptions options;
    options.candidates = {"base_isotropic", "base_per_axis", "sensor_offset",
                          "transducer_anisotropy", "force_scale:GP"};
    options.max_rounds = 2;
    isowrench::FitReport report = isowrench::FitEffects(model, trials, options);
    report.source = "simulated: base_isotropic=2e4 N/m, 30 postures, seed 3";
    isowrench::FitReportOptions report_options;
    report_options.trials = &trials;
    report_options.model = &model;
    isowrench::WriteFitReportHtml(report, out + "/fit_report.html", report_options);
    isowrench::WriteFitReportMarkdown(report, out + "/fit_report.md");
    std::cout << report.BriefReport() << "\n"
              << "wrote " << out << "/fit_report.html and " << out << "/fit_report.md\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "fit_report_example: error: " << e.what() << "\n";
    return 1;
  }
}
