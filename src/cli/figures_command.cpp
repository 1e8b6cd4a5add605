// `isowrench figures <out-dir>`: the paper's Figures 2, 3 and 4 drawn from the model, as SVG
// (and PNG when a rasterizer exists) with the same numbers as CSV and JSON.

#include <filesystem>
#include <iostream>

#include "cli/command.hpp"
#include "isowrench/error.hpp"
#include "isowrench/paper.hpp"
#include "isowrench/plots.hpp"

namespace isowrench::cli {
namespace {

const bool kFiguresRegistered = RegisterCommand({
    "figures",
    "Draw the paper's Figures 2, 3 and 4 (wrench glyphs as in Fig. 1C) from the shipped rat URDFs: "
    "SVG, CSV and JSON (and PNG when rsvg-convert or ImageMagick is installed)",
    25,
    [](CLI::App& app) -> std::function<int()> {
      auto out_dir = std::make_shared<std::string>();
      auto figures = std::make_shared<std::vector<int>>();
      auto urdf_dir = std::make_shared<std::string>();
      auto no_png = std::make_shared<bool>(false);
      auto json = std::make_shared<bool>(false);
      app.add_option("out-dir", *out_dir,
                     "Directory for figure<N>.svg/.csv/.json/.png (created if missing)")
          ->required();
      app.add_option("--figure", *figures,
                     "Figures to draw: 2, 3, 4 (repeatable; default all three)")
          ->check(CLI::IsMember({2, 3, 4}));
      app.add_option("--urdf-dir", *urdf_dir,
                     "Directory holding rat_hindlimb_5dof.urdf and rat_hindlimb_6dof.urdf");
      app.add_flag("--no-png", *no_png, "Do not try to rasterize to PNG");
      app.add_flag("--json", *json, "Print the list of files written as JSON");
      return [out_dir, figures, urdf_dir, no_png, json]() {
        std::vector<int> which = figures->empty() ? std::vector<int>{2, 3, 4} : *figures;
        std::error_code ec;
        std::filesystem::create_directories(*out_dir, ec);
        if (ec) throw Error("cannot create output directory '" + *out_dir + "': " + ec.message());
        const std::string dir = urdf_dir->empty() ? DefaultUrdfDirectory() : *urdf_dir;
        FigureWriteOptions options;
        options.png = !*no_png;
        nlohmann::json out = nlohmann::json::array();
        std::vector<std::pair<int, FigureFiles>> written;
        {
          Progress progress("figures", static_cast<long>(which.size()));
          for (size_t i = 0; i < which.size(); ++i) {
            progress.Update(static_cast<long>(i));
            std::vector<PaperPanel> panels = ComputePaperFigure(which[i], dir);
            written.emplace_back(which[i], WritePaperFigure(which[i], panels, *out_dir, options));
            progress.Update(static_cast<long>(i + 1));
          }
        }
        for (const auto& [figure, files] : written) {
          if (*json) {
            out.push_back({{"figure", figure},
                           {"files", files.files},
                           {"png", files.png_written},
                           {"png_note", files.png_note}});
            continue;
          }
          std::cout << "Figure " << figure << ":\n";
          for (const std::string& f : files.files) std::cout << "  wrote " << f << "\n";
          if (!files.png_written && !*no_png) std::cout << "  " << files.png_note << "\n";
        }
        if (*json) std::cout << out.dump(2) << "\n";
        return 0;
      };
    },
});

}  // namespace
}  // namespace isowrench::cli
