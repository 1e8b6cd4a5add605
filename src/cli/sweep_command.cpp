// `isowrench sweep <urdf> --grid joint=from:to:step ... --stiffness-ratio r1,r2 -o out.csv`:
// the wrench over a posture grid x transducer stiffness ratios, on the fast path, both cores.

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <iostream>
#include <map>
#include <optional>
#include <thread>

#include "cli/command.hpp"
#include "isowrench/engine.hpp"
#include "isowrench/error.hpp"
#include "isowrench/io.hpp"
#include "isowrench/posture.hpp"

namespace isowrench::cli {
namespace {

// Largest sweep accepted: the results are held in memory (64 bytes each) before the CSV is
// written; 5e7 evaluations is 3.2 GB.
constexpr double kMaxEvaluations = 5e7;

/// One --grid axis, values in user units (degrees or mm) and in model units (rad or m).
struct GridAxis {
  std::string joint;
  int column = 0;
  bool prismatic = false;
  std::vector<double> user_values;
  std::vector<double> model_values;
};

GridAxis ParseGrid(const Model& model, const std::string& text) {
  const std::string what = "--grid '" + text + "'";
  const size_t eq = text.find('=');
  if (eq == std::string::npos) throw Error(what + " is not joint=from:to:step");
  GridAxis axis;
  axis.joint = util::Trim(text.substr(0, eq));
  axis.column = model.JointIndex(axis.joint);  // throws with the known joints
  axis.prismatic = model.joint(axis.column).type == JointType::kPrismatic;
  const std::vector<std::string> parts = util::Split(text.substr(eq + 1), ":");
  if (parts.size() != 3) throw Error(what + " needs from:to:step (three numbers separated by ':')");
  const char* unit = axis.prismatic ? "mm" : "degrees";
  const double from = util::ParseDoubleOrThrow(parts[0], what + " from");
  const double to = util::ParseDoubleOrThrow(parts[1], what + " to");
  const double step = util::ParseDoubleOrThrow(parts[2], what + " step");
  if (!std::isfinite(from) || !std::isfinite(to) || !std::isfinite(step)) {
    throw Error(what + ": from, to and step must be finite");
  }
  if (!(step > 0))
    throw Error(what + ": step " + util::FormatNumber(step) + " " + unit + " must be > 0");
  if (to < from)
    throw Error(what + ": to (" + util::FormatNumber(to) + ") is below from (" +
                util::FormatNumber(from) + ")");
  // Steps that land within 1e-9 of a step of `to` include it (0:180:1 gives 181 values).
  const double count = std::floor((to - from) / step + 1e-9) + 1;
  if (count > kMaxEvaluations) throw Error(what + " has " + util::FormatNumber(count) + " values");
  for (long k = 0; k < static_cast<long>(count); ++k) {
    const double v = from + static_cast<double>(k) * step;
    axis.user_values.push_back(v);
    axis.model_values.push_back(JointValueFromUserUnits(model.joint(axis.column).type, v));
  }
  return axis;
}

std::vector<double> ParseRatios(const std::vector<std::string>& items) {
  std::vector<double> ratios;
  for (const std::string& item : items) {
    const double r = util::ParseDoubleOrThrow(item, "--stiffness-ratio");
    if (!std::isfinite(r) || r <= 0) {
      throw Error("--stiffness-ratio " + item +
                  " must be finite and > 0 (it scales S_t's rotational terms)");
    }
    ratios.push_back(r);
  }
  if (ratios.empty()) ratios.push_back(1.0);
  return ratios;
}

// Ten significant digits, locale independent (the model's inputs are not known better).
void Append(std::string& line, double v) {
  char buffer[32];
  if (v == 0.0) v = 0.0;  // no "-0"
  auto result = std::to_chars(buffer, buffer + sizeof(buffer), v, std::chars_format::general, 10);
  line.append(buffer, result.ptr);
}

const char* StatusWord(StaticsStatus s) {
  switch (s) {
    case StaticsStatus::kOk: return "ok";
    case StaticsStatus::kSelfMotionHeld: return "self_motion_held";
    case StaticsStatus::kSelfMotion: return "self_motion";
    case StaticsStatus::kInvalidInput: return "invalid";
  }
  return "?";
}

const bool kSweepRegistered = RegisterCommand({
    "sweep",
    "Wrench over a posture grid x transducer stiffness ratios on the fast path (both cores), "
    "written to a CSV",
    40,
    [](CLI::App& app) -> std::function<int()> {
      auto options = std::make_shared<ModelOptions>();
      auto grids = std::make_shared<std::vector<std::string>>();
      auto ratios = std::make_shared<std::vector<std::string>>();
      auto output = std::make_shared<std::string>();
      auto threads = std::make_shared<int>(2);
      auto json = std::make_shared<bool>(false);
      AddModelOptions(app, *options);
      app.add_option("--grid", *grids,
                     "Grid axis joint=from:to:step in degrees (mm for prismatic joints), ends "
                     "included; repeat for a product grid (the last axis varies fastest). Other "
                     "joints stay at the --posture / nominal posture")
          ->required();
      app.add_option("--stiffness-ratio", *ratios,
                     "Comma-separated ratios r: the transducer's rotational stiffness "
                     "(krx, kry, krz) is r x the model's; translational stays (default 1)")
          ->delimiter(',');
      app.add_option("-o,--output", *output, "CSV file to write (atomically)")->required();
      app.add_option("--threads", *threads, "Worker threads (default 2)")->check(CLI::Range(1, 64));
      app.add_flag("--json", *json, "Print the summary as JSON");
      return [options, grids, ratios, output, threads, json]() {
        Model model = LoadModel(*options);
        const std::string muscle_name = ChooseMuscle(model, *options);
        const int muscle = model.MuscleIndex(muscle_name);
        const Eigen::VectorXd base = LoadPosture(model, *options);
        std::vector<GridAxis> axes;
        for (const std::string& g : *grids) {
          GridAxis axis = ParseGrid(model, g);
          for (const GridAxis& other : axes) {
            if (other.column == axis.column)
              throw Error("--grid names joint '" + axis.joint + "' twice");
          }
          axes.push_back(std::move(axis));
        }
        const std::vector<double> r = ParseRatios(*ratios);
        double postures_d = 1;
        for (const GridAxis& a : axes) postures_d *= static_cast<double>(a.model_values.size());
        if (postures_d * static_cast<double>(r.size()) > kMaxEvaluations) {
          throw Error(
              "the sweep has " + util::FormatNumber(postures_d * static_cast<double>(r.size())) +
              " evaluations; at most " + util::FormatNumber(kMaxEvaluations) + " are accepted");
        }
        const long P = static_cast<long>(postures_d);
        const auto start = std::chrono::steady_clock::now();

        std::vector<StiffnessSet> sets;
        for (double ratio : r) {
          StiffnessSet s = model.model_stiffness();
          s.s_t.tail<3>() *= ratio;
          sets.push_back(s);
        }
        // Postures: the last axis varies fastest.
        Eigen::MatrixXd postures(model.dof_count(), P);
        std::vector<size_t> index(axes.size(), 0);
        for (long p = 0; p < P; ++p) {
          postures.col(p) = base;
          for (size_t a = 0; a < axes.size(); ++a)
            postures(axes[a].column, p) = axes[a].model_values[index[a]];
          for (size_t a = axes.size(); a-- > 0;) {
            if (++index[a] < axes[a].model_values.size()) break;
            index[a] = 0;
          }
        }
        std::vector<WrenchResult> results;
        {
          Progress progress("sweep", P * static_cast<long>(sets.size()));
          BatchOptions batch;
          batch.threads = *threads;
          batch.solve.rank_tolerance = options->statics.rank_tolerance;
          batch.progress = [&progress](long done, long) { progress.Update(done); };
          EvaluateBatch(model, postures, muscle, sets, results, options->activation, batch);
        }
        // A muscle with a force model: the passive (activation 0) wrenches too, and per posture
        // the force stage (F with its active and passive parts) in the CSV.
        const bool force_model = model.muscle(muscle).force.model != ForceModelType::kConstant;
        std::vector<WrenchResult> passive;
        if (force_model) {
          BatchOptions batch;
          batch.threads = *threads;
          batch.solve.rank_tolerance = options->statics.rank_tolerance;
          EvaluateBatch(model, postures, muscle, sets, passive, 0.0, batch);
        }
        const double compute_seconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

        // CSV: one row per posture and ratio, units in the header. Rows are formatted by the
        // worker threads (each a contiguous block of postures), then written in order.
        util::AtomicOutputFile file(*output);
        std::ostream& os = file.stream();
        std::string header;
        for (const GridAxis& a : axes) header += a.joint + (a.prismatic ? " (mm)," : " (deg),");
        header +=
            "stiffness_ratio (1),status,"
            "fx (N),fy (N),fz (N),mx (N·m),my (N·m),mz (N·m),self_motion_dims (1)";
        if (force_model) {
          header +=
              ",force (N),active_force (N),passive_force (N),fiber_length (m),force_status,"
              "passive fx (N),passive fy (N),passive fz (N),passive mx (N·m),passive my (N·m),"
              "passive mz (N·m)";
        }
        header += "\n";
        os << header;
        const long S = static_cast<long>(sets.size());
        const int blocks = static_cast<int>(std::clamp<long>(*threads, 1, std::max<long>(P, 1)));
        std::vector<std::string> text(static_cast<size_t>(blocks));
        std::vector<std::map<StaticsStatus, long>> block_counts(static_cast<size_t>(blocks));
        auto format_block = [&](int b) {
          const long begin = P * b / blocks, end = P * (b + 1) / blocks;
          std::string& out = text[static_cast<size_t>(b)];
          out.reserve(static_cast<size_t>((end - begin) * S * 120));
          std::optional<Data> ws;
          if (force_model) ws.emplace(model);
          for (long p = begin; p < end; ++p) {
            MuscleForce force;
            if (force_model) {  // the force stage at this posture's path length
              if (ComputeKinematics(model, *ws, postures.col(p), muscle, options->activation)) {
                force = MuscleForceAt(model, muscle, ws->muscle_length(), options->activation);
              }  // (else: no force, status "no equilibrium", empty cells)
            }
            // Grid indices of posture p (last axis fastest).
            std::vector<double> user(axes.size());
            long rest = p;
            for (size_t a = axes.size(); a-- > 0;) {
              const long n = static_cast<long>(axes[a].user_values.size());
              user[a] = axes[a].user_values[static_cast<size_t>(rest % n)];
              rest /= n;
            }
            for (long s = 0; s < S; ++s) {
              const WrenchResult& w = results[static_cast<size_t>(p * S + s)];
              ++block_counts[static_cast<size_t>(b)][w.status];
              for (double u : user) {
                Append(out, u);
                out += ',';
              }
              Append(out, r[static_cast<size_t>(s)]);
              out += ',';
              out += StatusWord(w.status);
              // No equilibrium is never a number: the wrench cells stay empty.
              const bool equilibrium =
                  w.status == StaticsStatus::kOk || w.status == StaticsStatus::kSelfMotionHeld;
              for (int k = 0; k < 6; ++k) {
                out += ',';
                if (equilibrium) Append(out, w.wrench[k]);
              }
              out += ',';
              out += std::to_string(w.self_motion_count);
              if (force_model) {
                const bool has_force = force.status != MuscleForceStatus::kNoEquilibrium;
                for (double v :
                     {force.force, force.active_force, force.passive_force, force.fiber_length}) {
                  out += ',';
                  if (has_force) Append(out, v);
                }
                out += ',';
                out += MuscleForceStatusName(force.status);
                const WrenchResult& pw = passive[static_cast<size_t>(p * S + s)];
                const bool passive_equilibrium =
                    pw.status == StaticsStatus::kOk || pw.status == StaticsStatus::kSelfMotionHeld;
                for (int k = 0; k < 6; ++k) {
                  out += ',';
                  if (passive_equilibrium) Append(out, pw.wrench[k]);
                }
              }
              out += '\n';
            }
          }
        };
        {
          std::vector<std::thread> helpers;
          for (int b = 1; b < blocks; ++b) helpers.emplace_back(format_block, b);
          format_block(0);
          for (std::thread& t : helpers) t.join();
        }
        std::map<StaticsStatus, long> counts;
        for (int b = 0; b < blocks; ++b) {
          os << text[static_cast<size_t>(b)];
          std::string().swap(text[static_cast<size_t>(b)]);
          for (const auto& [status, n] : block_counts[static_cast<size_t>(b)]) counts[status] += n;
        }
        file.Commit();
        const double total_seconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        const long evaluations = P * S;
        if (*json) {
          nlohmann::json status_counts;
          for (const auto& [status, n] : counts) status_counts[StatusWord(status)] = n;
          std::cout << nlohmann::json{{"model", model.name()},
                                      {"muscle", muscle_name},
                                      {"force_model", ForceModelLabel(model, muscle)},
                                      {"postures", P},
                                      {"stiffness_ratios", r},
                                      {"evaluations", evaluations},
                                      {"threads", *threads},
                                      {"compute_seconds", compute_seconds},
                                      {"total_seconds", total_seconds},
                                      {"status_counts", status_counts},
                                      {"locked", StaticsProblem(model).LockedNames()},
                                      {"output", *output}}
                           .dump(2)
                    << "\n";
        } else {
          std::cout << "isowrench sweep: " << model.name() << ", muscle " << muscle_name << " ("
                    << (force_model ? ForceModelLabel(model, muscle) + ", activation " +
                                          util::FormatNumber(options->activation, 4) +
                                          ": F(L_MT) per posture and the passive (activation 0) "
                                          "wrench in the CSV"
                                    : util::FormatNumber(
                                          options->activation * model.muscle(muscle).max_force, 6) +
                                          " N")
                    << "), other joints at " << FormatPosture(model, base) << "\n"
                    << "  " << P << " postures x " << S << " stiffness ratios = " << evaluations
                    << " evaluations on " << *threads
                    << " threads: " << util::FormatNumber(compute_seconds, 3) << " s computing ("
                    << util::FormatNumber(
                           compute_seconds * 1e9 * *threads / static_cast<double>(evaluations), 3)
                    << " ns per evaluation per thread), " << util::FormatNumber(total_seconds, 3)
                    << " s with the CSV\n  status:";
          for (const auto& [status, n] : counts) std::cout << " " << StatusWord(status) << " " << n;
          const std::vector<std::string> locked = StaticsProblem(model).LockedNames();
          if (!locked.empty()) {
            std::cout << "\n  locked (rigid, no dof): " << util::Join(locked, ", ");
          }
          std::cout << "\n  wrote " << *output
                    << " (W in N and N·m, transducer axes; empty where there is no "
                       "equilibrium)\n";
        }
        return 0;
      };
    },
});

}  // namespace
}  // namespace isowrench::cli
