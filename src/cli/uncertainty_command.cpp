// `isowrench uncertainty <urdf>`: Monte Carlo uncertainty of the wrench (docs/uncertainty.md).

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <iostream>

#include "cli/command.hpp"
#include "isowrench/error.hpp"
#include "isowrench/io.hpp"
#include "isowrench/muscle.hpp"
#include "isowrench/posture.hpp"
#include "isowrench/uncertainty.hpp"

namespace isowrench::cli {
namespace {

struct UncertaintyCommandOptions {
  ModelOptions model;
  std::string spec;
  std::vector<std::string> inputs;
  std::string from_fit;
  std::string postures_csv;
  long samples = UncertaintyOptions{}.samples;
  unsigned long long seed = UncertaintyOptions{}.seed;
  bool no_sobol = false;
  int threads = UncertaintyOptions{}.threads;
  double exact_values = UncertaintyOptions{}.exact_percentile_values;
  bool json = false;
  bool progress = false;
  std::string svg;
  std::string report;
};

std::string InputText(const UncertainInput& in, const Model& model) {
  std::string unit;
  const std::string kind = in.name.substr(0, in.name.find(':'));
  if (kind == "angle") {
    const std::string c = in.name.substr(6);
    unit = model.joint(model.JointIndex(c)).type == JointType::kPrismatic ? " mm" : " deg";
  } else if (kind == "misalignment") {
    unit = " deg";
  } else if (kind == "point") {
    unit = " mm";
  } else if (kind == "activation") {
    unit = "";
  } else if (kind == "transducer_stiffness" || kind == "base_stiffness" ||
             kind == "joint_stiffness") {
    bool rotational = false;
    if (kind == "transducer_stiffness") rotational = in.name.find(":r") != std::string::npos;
    if (kind == "joint_stiffness")
      rotational = model.joint(model.JointIndex(in.name.substr(16))).type != JointType::kPrismatic;
    unit = in.distribution == InputDistribution::kLogNormal ? " (sd of ln)"
           : rotational                                     ? " N·m/rad"
                                                            : " N/m";
  } else {
    unit = " (x)";
  }
  std::string text = in.name + " " + DistributionName(in.distribution);
  if (in.distribution == InputDistribution::kUniform ||
      in.distribution == InputDistribution::kLogUniform) {
    text += " [" + util::FormatNumber(in.lower, 4) + ", " + util::FormatNumber(in.upper, 4) + "]" +
            unit;
  } else {
    std::vector<std::string> sd;
    for (double s : in.sd) sd.push_back(util::FormatNumber(s, 4));
    text += " sd " + util::Join(sd, ",") + unit;
  }
  return text;
}

std::string Percent(double fraction) { return util::FormatNumber(100.0 * fraction, 3) + " %"; }

void PrintText(const UncertaintyResult& r, const UncertaintySpec& spec, const Model& model,
               const UncertaintyCommandOptions& o) {
  const int w = 14;
  const MuscleSpec& spec_muscle = model.muscle(model.MuscleIndex(r.muscle));
  std::cout << "isowrench uncertainty: " << model.name() << " (" << o.model.urdf << "), muscle "
            << r.muscle << " ("
            << (spec_muscle.force.model == ForceModelType::kConstant
                    ? util::FormatNumber(o.model.activation * spec_muscle.max_force, 6) + " N"
                    : std::string(ForceModelName(spec_muscle.force.model)) + ", max_force " +
                          util::FormatNumber(spec_muscle.max_force, 6) + " N, activation " +
                          util::FormatNumber(o.model.activation, 6))
            << ")\n";
  std::cout << "  inputs       ";
  for (size_t i = 0; i < spec.inputs.size(); ++i)
    std::cout << (i ? "\n               " : "") << InputText(spec.inputs[i], model);
  if (spec.has_fit) {
    std::cout << (spec.inputs.empty() ? "" : "\n               ") << "fit " << spec.fit.source
              << ": " << spec.fit.names.size() << " parameters, multivariate normal ("
              << util::Join(spec.fit.names, ", ") << ")";
  }
  const long rows = r.sobol ? static_cast<long>(r.groups.size()) + 2 : 1;
  std::cout << "\n  design       N = " << r.samples << " samples"
            << (r.sobol ? ", Sobol design A, B, A_B^i: " + std::to_string(r.samples) + " x (" +
                              std::to_string(r.groups.size()) + " + 2)"
                        : std::string(": ") + std::to_string(r.samples))
            << " = " << r.samples * rows << " evaluations per posture; seed " << r.seed << "; "
            << o.threads << " threads; " << util::FormatNumber(r.seconds, 3) << " s\n"
            << "  percentiles  " << r.percentile_method << "\n";
  for (const std::string& note : r.notes) std::cout << "  note         " << note << "\n";
  for (const PostureUncertainty& p : r.postures) {
    std::cout << "\nposture " << FormatPosture(model, p.posture) << "\n";
    const double n = static_cast<double>(std::max<long>(p.samples, 1));
    std::cout << "  samples      " << p.samples << (r.sobol ? " (rows of A and B)" : "")
              << ": valid " << p.valid << ", no equilibrium " << p.no_equilibrium << " ("
              << Percent(p.no_equilibrium / n) << "), invalid " << p.invalid
              << ", small-motion rule failed " << p.small_motion_failed << " ("
              << Percent(p.small_motion_failed / n) << ")"
              << (p.no_equilibrium + p.invalid > 0
                      ? "; samples without a wrench are left out of every statistic"
                      : "")
              << "\n";
    if (p.statistics[0].count == 0) {
      std::cout << "  no sample has a wrench: no statistics\n";
      continue;
    }
    std::cout << "  reading of the transducer (transducer axes, moment about the endpoint):\n"
              << WrenchHeader(w) << "\n";
    auto row = [&](const std::string& label, auto value) {
      Vector6d v;
      for (int i = 0; i < 6; ++i) v[i] = value(i);
      std::cout << WrenchRow("  " + label, v, w) << "\n";
    };
    const auto& st = p.statistics;
    if (p.nominal_defined()) {
      row("nominal", [&](int i) { return p.nominal[static_cast<size_t>(i)]; });
    } else {
      std::cout << "  nominal      no wrench at the central values ("
                << StatusName(p.nominal_status) << ")\n";
    }
    row("mean", [&](int i) { return st[static_cast<size_t>(i)].mean; });
    row("sd", [&](int i) { return st[static_cast<size_t>(i)].sd; });
    row("2.5 %", [&](int i) { return st[static_cast<size_t>(i)].percentiles[0]; });
    row("50 %", [&](int i) { return st[static_cast<size_t>(i)].percentiles[1]; });
    row("97.5 %", [&](int i) { return st[static_cast<size_t>(i)].percentiles[3]; });
    std::cout << "  world axes (R_W_T at this posture x reading):\n";
    row("mean", [&](int i) { return st[static_cast<size_t>(6 + i)].mean; });
    row("sd", [&](int i) { return st[static_cast<size_t>(6 + i)].sd; });
    const QuantityStatistics& f = st[12];
    const QuantityStatistics& a = st[14];
    constexpr double kDegrees = 180.0 / 3.14159265358979323846;
    std::cout << "  |f|          " << util::FormatNumber(f.mean, 4) << " N, sd "
              << util::FormatNumber(f.sd, 3) << " N (" << Percent(f.sd / std::max(f.mean, 1e-300))
              << "), 95 % in [" << util::FormatNumber(f.percentiles[0], 4) << ", "
              << util::FormatNumber(f.percentiles[3], 4) << "] N\n";
    if (a.count > 0) {
      std::cout << "  direction    angle between f and the nominal f: median "
                << util::FormatNumber(a.percentiles[1] * kDegrees, 3) << " deg, 95 % below "
                << util::FormatNumber(a.percentiles[2] * kDegrees, 3) << " deg\n";
    }
    if (r.sobol && !p.sobol.empty()) {
      std::cout << "  Sobol indices, first order S_i (total ST_i in --json); share of the variance "
                   "of each component, "
                << p.sobol_rows << " rows:\n";
      const int qs[8] = {0, 1, 2, 3, 4, 5, 12, 14};
      const char* names[8] = {"fx", "fy", "fz", "mx", "my", "mz", "|f|", "angle"};
      size_t label = 12;
      for (const std::string& g : r.groups) label = std::max(label, g.size() + 4);
      std::string header(label, ' ');
      for (const char* name : names) {
        char b[16];
        std::snprintf(b, sizeof b, "%8s", name);
        header += b;
      }
      std::cout << header << "\n";
      for (size_t g = 0; g < r.groups.size(); ++g) {
        std::string line = "    " + r.groups[g];
        line += std::string(label - line.size(), ' ');
        for (int q : qs) {
          char b[16];
          const double s = p.sobol[g][static_cast<size_t>(q)].first;
          if (st[static_cast<size_t>(q)].sd == 0.0) {
            std::snprintf(b, sizeof b, "%8s", "-");
          } else {
            std::snprintf(b, sizeof b, "%8.3f", s == 0.0 ? 0.0 : s);
          }
          line += b;
        }
        std::cout << line << "\n";
      }
      std::cout << "    (- : the component does not vary)\n";
    }
  }
}

const bool kUncertaintyRegistered = RegisterCommand({
    "uncertainty",
    "Monte Carlo uncertainty of the wrench: mean, sd and percentiles of every component, the "
    "spread of the force direction, no-equilibrium and small-motion fractions, Sobol indices",
    45,
    [](CLI::App& app) -> std::function<int()> {
      auto o = std::make_shared<UncertaintyCommandOptions>();
      AddModelOptions(app, o->model);
      app.add_option("--spec", o->spec,
                     "Uncertain inputs from a JSON spec file (docs/uncertainty.md \"Spec file\")");
      app.add_option("--input", o->inputs,
                     "An uncertain input NAME=DISTRIBUTION:PARAMETERS, repeatable: "
                     "angle:hip_rz=normal:2 (deg), misalignment=normal:1,1,2 (deg), "
                     "transducer_stiffness:x=lognormal:0.35 (sd of ln), "
                     "base_stiffness=loguniform:1e4:1e7 (N/m), max_force=normal:0.2 (x), "
                     "gain:fx=normal:0.01 (x), crosstalk=normal:0.005 (normalised), "
                     "point:GP:0=normal:1 (mm, each axis of path point 0 of muscle GP; "
                     "point:GP:0:x one axis)");
      app.add_option("--from-fit", o->from_fit,
                     "The parameters and covariance of `isowrench fit --json` output, sampled as "
                     "a multivariate normal (a fit of another model is refused)");
      app.add_option("--postures", o->postures_csv,
                     "Postures CSV (header: coordinate names; degrees, mm for prismatic); default "
                     "the --posture / nominal posture");
      app.add_option("--samples", o->samples,
                     "N, samples of each design matrix (default 4096); evaluations: N x (inputs "
                     "+ 2) per posture with Sobol indices, N without")
          ->check(CLI::Range(1L, 1000000000L));
      app.add_option("--seed", o->seed, "Random seed (default 1): the same seed, the same numbers");
      app.add_flag("--no-sobol", o->no_sobol, "Skip the Sobol indices (N evaluations per posture)");
      app.add_option("--threads", o->threads,
                     "Worker threads (default 2); the numbers do not depend on it")
          ->check(CLI::Range(1, 256));
      app.add_option("--exact-percentile-values", o->exact_values,
                     "Exact percentiles while 2 N x postures x 15 <= this (default 2e7, 8 bytes "
                     "each); beyond, a log-linear histogram (within 0.1 % of the value)");
      app.add_option("--svg", o->svg,
                     "Write wrench glyphs with the 95 % range of direction and size (SVG)");
      app.add_option("--report", o->report,
                     "Write an HTML report: glyphs, distributions, Sobol indices");
      app.add_flag("--json", o->json, "Print the result as JSON");
      app.add_flag("--progress", o->progress,
                   "Report progress on stderr even when it is not a terminal");
      return [o]() {
        Model model = LoadModel(o->model);
        const std::string muscle = ChooseMuscle(model, o->model);
        UncertaintySpec spec;
        if (!o->spec.empty()) spec = ReadUncertaintySpecFile(o->spec);
        for (const std::string& text : o->inputs) spec.inputs.push_back(ParseUncertainInput(text));
        if (!o->from_fit.empty()) {
          spec.fit = ReadFitUncertainty(o->from_fit, model);
          spec.has_fit = true;
        }
        Eigen::MatrixXd postures;
        if (o->postures_csv.empty()) {
          postures = LoadPosture(model, o->model);
        } else {
          const std::vector<Eigen::VectorXd> list =
              ReadPostureCsv(model, o->postures_csv, LoadPosture(model, o->model));
          postures.resize(model.dof_count(), static_cast<Eigen::Index>(list.size()));
          for (size_t p = 0; p < list.size(); ++p)
            postures.col(static_cast<Eigen::Index>(p)) = list[p];
        }
        UncertaintyOptions options;
        options.samples = o->samples;
        options.seed = o->seed;
        options.sobol = !o->no_sobol;
        options.threads = o->threads;
        options.activation = o->model.activation;
        options.statics = o->model.statics;
        options.exact_percentile_values = o->exact_values;
        const bool show_progress = o->progress || ::isatty(STDERR_FILENO);
        long last_percent = -1;
        if (show_progress) {
          options.progress = [&last_percent](long done, long total) {
            const long percent = total > 0 ? done * 100 / total : 100;
            if (percent == last_percent) return;
            last_percent = percent;
            std::cerr << "\runcertainty: " << done << " / " << total << " evaluations (" << percent
                      << " %)" << (done == total ? "\n" : "") << std::flush;
          };
        }
        const UncertaintyResult result = RunUncertainty(model, muscle, postures, spec, options);
        if (!o->svg.empty()) util::WriteFileAtomically(o->svg, UncertaintyGlyphSvg(result, model));
        if (!o->report.empty())
          util::WriteFileAtomically(o->report, UncertaintyReportHtml(result, model, spec));
        if (o->json) {
          std::cout << UncertaintyJson(result, model) << "\n";
        } else {
          PrintText(result, spec, model, *o);
          if (!o->svg.empty()) std::cout << "\nwrote " << o->svg << "\n";
          if (!o->report.empty())
            std::cout << (o->svg.empty() ? "\n" : "") << "wrote " << o->report << "\n";
        }
        return 0;
      };
    },
});

}  // namespace
}  // namespace isowrench::cli
