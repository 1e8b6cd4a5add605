// `isowrench draw <urdf> -o limb.svg`: two-view stick figure of a limb at a posture, to check a
// custom URDF by eye.

#include <iostream>

#include "cli/command.hpp"
#include "isowrench/error.hpp"
#include "isowrench/io.hpp"
#include "isowrench/plots.hpp"
#include "isowrench/posture.hpp"
#include "isowrench/wrap.hpp"

namespace isowrench::cli {
namespace {

const bool kDrawRegistered = RegisterCommand({
    "draw",
    "Draw a two-view stick figure (top x-y, side x-z) of the limb at a posture: joint centres and "
    "axes, "
    "bones, muscle paths (wrapped over their wrap surfaces), endpoint frame (SVG)",
    70,
    [](CLI::App& app) -> std::function<int()> {
      auto options = std::make_shared<ModelOptions>();
      auto output = std::make_shared<std::string>();
      auto axis_mm = std::make_shared<double>(0.0);
      auto title = std::make_shared<std::string>();
      AddModelOptions(app, *options, {/*muscle=*/false, /*posture=*/true, /*statics=*/false});
      app.add_option("-o,--output", *output, "SVG file to write ('-' = standard output)")
          ->required();
      app.add_option(
          "--axis-length", *axis_mm,
          "Length of joint-axis segments and frame axes in mm (default: 12% of the leg length)");
      app.add_option("--title", *title, "Title above the views (default: model name and posture)");
      auto muscles = std::make_shared<std::vector<std::string>>();
      app.add_option("--muscle", *muscles,
                     "Draw only these muscles: name,name,... (default: every muscle)")
          ->delimiter(',');
      return [options, output, axis_mm, title, muscles]() {
        Model model = LoadModel(*options);
        Eigen::VectorXd q = LoadPosture(model, *options);
        LimbDrawingOptions drawing;
        drawing.axis_length = *axis_mm * 1e-3;
        drawing.title = *title;
        drawing.muscles = *muscles;
        drawing.wrap_mode = model.description().wrap_mode;  // the model's, or --wrap
        const std::string svg = LimbStickFigureSvg(model, q, drawing);
        if (*output == "-") {
          std::cout << svg;
          return 0;
        }
        WriteTextFile(*output, svg);
        std::cout << "wrote " << *output << ": " << model.name() << " at "
                  << FormatPosture(model, q) << " (" << model.dof_count() << " joints, "
                  << model.muscle_count() << " muscle" << (model.muscle_count() == 1 ? "" : "s")
                  << (muscles->empty() ? "" : ", " + std::to_string(muscles->size()) + " drawn")
                  << ", leg length " << util::FormatNumber(model.chain_length() * 1e3, 4)
                  << " mm)\n";
        // Each wrap object is drawn once per view (limb_drawing.cpp, class "wrap-surface").
        size_t surfaces = 0;
        for (size_t at = svg.find("class=\"wrap-surface\""); at != std::string::npos;
             at = svg.find("class=\"wrap-surface\"", at + 1)) {
          ++surfaces;
        }
        if (surfaces > 0) {
          std::cout << "  " << surfaces / 2 << " wrap object" << (surfaces == 2 ? "" : "s")
                    << " drawn; wrapping muscles drawn over them in "
                    << WrapModeName(drawing.wrap_mode) << " mode\n";
        }
        const size_t note = svg.find("class=\"label-note\"");
        if (note != std::string::npos) {
          std::cout << "  some labels were left out where they would overlap (see the note under "
                       "each view); draw fewer muscles with --muscle\n";
        }
        return 0;
      };
    },
});

}  // namespace
}  // namespace isowrench::cli
