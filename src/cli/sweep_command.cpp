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
#include "isowrench/kinematics.hpp"
#include "isowrench/posture.hpp"
#include "isowrench/wrap.hpp"

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

// The grid values (user units) of posture p, the last axis fastest.
std::vector<double> GridValues(const std::vector<GridAxis>& axes, long p) {
  std::vector<double> user(axes.size());
  long rest = p;
  for (size_t a = axes.size(); a-- > 0;) {
    const long n = static_cast<long>(axes[a].user_values.size());
    user[a] = axes[a].user_values[static_cast<size_t>(rest % n)];
    rest /= n;
  }
  return user;
}

// The column header of grid axis a ("knee (deg)", "base_x (mm)"): the CSV's and the JSON's.
std::string AxisHeader(const GridAxis& a) { return a.joint + (a.prismatic ? " (mm)" : " (deg)"); }

// A CSV cell holding text: quoted (RFC 4180) when it holds a separator, a quote or a newline.
std::string CsvText(const std::string& text) {
  if (text.find_first_of(",\"\n\r") == std::string::npos) return text;
  std::string quoted = "\"";
  for (char c : text) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
  return quoted + "\"";
}

// The WrapStatus bits a sweep counts, in WrapStatusText's order.
constexpr unsigned kSweepWrapBits[] = {kWrapBelowStraightLine, kWrapNotConverged,  kWrapNegativeArc,
                                       kWrapDegenerate,        kWrapExactFallback, kWrapRangeEmpty};
constexpr size_t kSweepWrapBitCount = sizeof(kSweepWrapBits) / sizeof(kSweepWrapBits[0]);

// What the wraps of the swept muscle did over the postures (MuscleWrappedPath at each, in the
// model's wrap mode): the same words as wrench/diagnose/releases, counted.
struct WrapTally {
  std::vector<long> engaged;  // per wrap of the muscle: postures where it wraps
  long warned = 0;            // postures with any WrapStatus bit
  long unevaluated = 0;       // postures where the path cannot be computed (coincident points)
  long count[kSweepWrapBitCount] = {};
  long first[kSweepWrapBitCount] = {-1, -1, -1, -1, -1, -1};

  void Merge(const WrapTally& o) {  // o covers later postures than *this
    if (engaged.size() < o.engaged.size()) engaged.resize(o.engaged.size(), 0);
    for (size_t k = 0; k < o.engaged.size(); ++k) engaged[k] += o.engaged[k];
    warned += o.warned;
    unevaluated += o.unevaluated;
    for (size_t b = 0; b < kSweepWrapBitCount; ++b) {
      count[b] += o.count[b];
      if (first[b] < 0) first[b] = o.first[b];
    }
  }
};

// {"mode", "wraps": [{"object", "wrapped_postures"}], "warning_postures", "warnings":
// [{"warning", "postures", "first_posture": {"<axis header>": value}}], "unevaluated_postures"}.
nlohmann::json WrapTallyJson(const Model& model, int muscle, const std::vector<GridAxis>& axes,
                             const WrapTally& t) {
  const MuscleSpec& spec = model.muscle(muscle);
  nlohmann::json wraps = nlohmann::json::array();
  for (size_t k = 0; k < spec.wraps.size(); ++k) {
    wraps.push_back({{"object", spec.wraps[k].object}, {"wrapped_postures", t.engaged[k]}});
  }
  nlohmann::json warnings = nlohmann::json::array();
  for (size_t b = 0; b < kSweepWrapBitCount; ++b) {
    if (t.count[b] == 0) continue;
    nlohmann::json first = nlohmann::json::object();
    const std::vector<double> user = GridValues(axes, t.first[b]);
    for (size_t a = 0; a < axes.size(); ++a) first[AxisHeader(axes[a])] = user[a];
    warnings.push_back({{"warning", WrapStatusText(kSweepWrapBits[b])},
                        {"postures", t.count[b]},
                        {"first_posture", first}});
  }
  return {{"mode", WrapModeName(model.description().wrap_mode)},
          {"wraps", wraps},
          {"warning_postures", t.warned},
          {"warnings", warnings},
          {"unevaluated_postures", t.unevaluated}};
}

// The tally as text lines (each indented by two spaces, ending in a newline).
std::string WrapTallyText(const nlohmann::json& j, long postures) {
  std::string text = "  wrap (" + j["mode"].get<std::string>() + "):";
  for (const auto& w : j["wraps"]) {
    text += " " + w["object"].get<std::string>() + " wraps at " +
            std::to_string(w["wrapped_postures"].get<long>()) + " of " + std::to_string(postures) +
            " postures;";
  }
  text.pop_back();
  text += "\n";
  const long warned = j["warning_postures"].get<long>();
  if (warned == 0) {
    text += "  wrap warnings: none (OpenSim's algorithm behaves at every posture)\n";
  } else {
    text += "  wrap warnings at " + std::to_string(warned) + " of " + std::to_string(postures) +
            " postures (column wrap_warning of the CSV):\n";
    for (const auto& w : j["warnings"]) {
      std::string first;
      for (const auto& [axis, value] : w["first_posture"].items()) {
        const bool mm = axis.size() > 5 && axis.compare(axis.size() - 5, 5, " (mm)") == 0;
        first += (first.empty() ? "" : ", ") + axis.substr(0, axis.rfind(" (")) + "=" +
                 util::FormatNumber(value.get<double>(), 6) + (mm ? " mm" : "°");
      }
      text += "    " + w["warning"].get<std::string>() + ": " +
              std::to_string(w["postures"].get<long>()) + " postures, first at " + first + "\n";
    }
  }
  const long unevaluated = j["unevaluated_postures"].get<long>();
  if (unevaluated > 0) {
    text += "  wrapped path not computed at " + std::to_string(unevaluated) +
            " postures (coincident path points; status invalid)\n";
  }
  return text;
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
        for (const GridAxis& a : axes) header += AxisHeader(a) + ",";
        header +=
            "stiffness_ratio (1),status,"
            "fx (N),fy (N),fz (N),mx (N·m),my (N·m),mz (N·m),self_motion_dims (1)";
        if (force_model) {
          header +=
              ",force (N),active_force (N),passive_force (N),fiber_length (m),force_status,"
              "passive fx (N),passive fy (N),passive fz (N),passive mx (N·m),passive my (N·m),"
              "passive mz (N·m)";
        }
        // A wrapping muscle: per posture, how many of its wraps engage and OpenSim's algorithm's
        // warnings in words (MuscleWrappedPath, the model's wrap mode; "" when none).
        const size_t wrap_count = model.muscle(muscle).wraps.size();
        if (wrap_count > 0) header += ",wraps_engaged (1),wrap_warning";
        header += "\n";
        os << header;
        const long S = static_cast<long>(sets.size());
        const int blocks = static_cast<int>(std::clamp<long>(*threads, 1, std::max<long>(P, 1)));
        std::vector<std::string> text(static_cast<size_t>(blocks));
        std::vector<std::map<StaticsStatus, long>> block_counts(static_cast<size_t>(blocks));
        std::vector<WrapTally> block_wraps(static_cast<size_t>(blocks));
        auto format_block = [&](int b) {
          const long begin = P * b / blocks, end = P * (b + 1) / blocks;
          std::string& out = text[static_cast<size_t>(b)];
          out.reserve(static_cast<size_t>((end - begin) * S * 120));
          std::optional<Data> ws;
          if (force_model || wrap_count > 0) ws.emplace(model);
          WrapTally& tally = block_wraps[static_cast<size_t>(b)];
          tally.engaged.assign(wrap_count, 0);
          for (long p = begin; p < end; ++p) {
            std::string wrap_cells;
            if (wrap_count > 0) {
              try {
                const WrappedPath path = MuscleWrappedPath(model, *ws, postures.col(p), muscle);
                int engaged = 0;
                for (size_t k = 0; k < wrap_count && k < path.wraps.size(); ++k) {
                  if (!path.wraps[k].wrapped) continue;
                  ++engaged;
                  ++tally.engaged[k];
                }
                if (path.status != 0) {
                  ++tally.warned;
                  for (size_t k = 0; k < kSweepWrapBitCount; ++k) {
                    if ((path.status & kSweepWrapBits[k]) == 0) continue;
                    ++tally.count[k];
                    if (tally.first[k] < 0) tally.first[k] = p;
                  }
                }
                wrap_cells =
                    "," + std::to_string(engaged) + "," + CsvText(WrapStatusText(path.status));
              } catch (const Error&) {  // coincident path points: the batch says invalid
                ++tally.unevaluated;
                wrap_cells = ",,";
              }
            }
            MuscleForce force;
            if (force_model) {  // the force stage at this posture's path length
              if (ComputeKinematics(model, *ws, postures.col(p), muscle, options->activation)) {
                force = MuscleForceAt(model, muscle, ws->muscle_length(), options->activation);
              }  // (else: no force, status "no equilibrium", empty cells)
            }
            const std::vector<double> user = GridValues(axes, p);
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
              out += wrap_cells;
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
        WrapTally wrap_tally;
        wrap_tally.engaged.assign(wrap_count, 0);
        for (const WrapTally& t : block_wraps) wrap_tally.Merge(t);
        const nlohmann::json wrap_json =
            wrap_count > 0 ? WrapTallyJson(model, muscle, axes, wrap_tally) : nlohmann::json();
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
                                      {"wrap", wrap_json},
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
          std::cout << "\n";
          if (wrap_count > 0) std::cout << WrapTallyText(wrap_json, P);
          std::cout << "  wrote " << *output
                    << " (W in N and N·m, transducer axes; empty where there is no "
                       "equilibrium)\n";
        }
        return 0;
      };
    },
});

}  // namespace
}  // namespace isowrench::cli
