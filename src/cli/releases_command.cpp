// `isowrench releases <urdf>`: which extra transducer dof to release, and which never to.

#include <cstdio>
#include <iostream>

#include "cli/command.hpp"
#include "isowrench/diagnostics.hpp"
#include "isowrench/error.hpp"
#include "isowrench/io.hpp"
#include "isowrench/posture.hpp"

namespace isowrench::cli {
namespace {

std::string N(double v, int digits = 3) { return util::FormatNumber(v, digits); }

struct ReleasesOptions {
  ModelOptions model;
  std::vector<std::string> muscles;
  double activation = 1.0;
  std::string postures;
  std::vector<std::string> axes;
  std::vector<std::string> translation_axes;
  int sweep = 0;
  std::uint64_t seed = 1;
  bool json = false;
  ReleaseOptions release;
};

// "x,y,z" or "name:x,y,z".
ReleaseCandidate ParseAxis(const std::string& text, ReleaseKind kind, int number) {
  std::string name =
      std::string(kind == ReleaseKind::kRotation ? "user axis " : "user translation ") +
      std::to_string(number);
  std::string values = text;
  size_t colon = text.find(':');
  if (colon != std::string::npos) {
    name = util::Trim(text.substr(0, colon));
    values = text.substr(colon + 1);
  }
  std::vector<std::string> items = util::Split(values, ", ");
  if (items.size() != 3) {
    throw Error("release axis '" + text +
                "' needs three components x,y,z (world axes), optionally name:x,y,z");
  }
  Eigen::Vector3d a;
  for (int i = 0; i < 3; ++i) {
    double v = 0.0;
    if (!util::ParseDouble(items[static_cast<size_t>(i)], &v)) {
      throw Error("release axis '" + name + "': component " + std::to_string(i + 1) + " '" +
                  items[static_cast<size_t>(i)] + "' is not a number");
    }
    a[i] = v;
  }
  return MakeReleaseCandidate(name, kind, a);
}

std::string AxisText(const Eigen::Vector3d& a) {
  char buffer[96];
  std::snprintf(buffer, sizeof(buffer), "(%+.3f %+.3f %+.3f)", a.x(), a.y(), a.z());
  return buffer;
}

const char* Kind(ReleaseKind k) {
  return k == ReleaseKind::kRotation      ? "rotation"
         : k == ReleaseKind::kTranslation ? "translation"
                                          : "none";
}

nlohmann::json AxisJson(const Eigen::Vector3d& a) { return {a.x(), a.y(), a.z()}; }

// No equilibrium is never a number: null instead of a wrench.
nlohmann::json WrenchOrNull(bool valid, const Vector6d& w) {
  return valid ? WrenchJson(w) : nlohmann::json(nullptr);
}

nlohmann::json AssessmentJson(const ReleaseAssessment& a, int grid_points) {
  const bool range = a.range_failures < grid_points;  // some grid point had an equilibrium
  return {{"name", a.candidate.name},
          {"kind", Kind(a.candidate.kind)},
          {"source", a.candidate.source},
          {"axis_world", AxisJson(a.candidate.axis_world)},
          {"axis_transducer", AxisJson(a.axis_transducer)},
          {"rank", a.rank},
          {"columns", a.columns},
          {"margin", a.margin},
          {"self_motion", a.self_motion},
          {"near_self_motion", a.near_self_motion},
          {"internal_wrench", a.internal_wrench},
          {"torques_recoverable", a.torques_recoverable},
          {"statics_status", StatusName(a.statics.status)},
          {"small_motion_valid", a.statics.small_motion_valid},
          {"equilibrium", a.statics.ok()},
          {"wrench", WrenchOrNull(a.statics.ok(), a.statics.wrench)},
          {"wrench_min", WrenchOrNull(range, a.wrench_min)},
          {"wrench_max", WrenchOrNull(range, a.wrench_max)},
          {"spread", a.statics.ok() ? nlohmann::json(a.spread) : nlohmann::json(nullptr)},
          {"range_failures", a.range_failures},
          {"rank_order", a.rank_order},
          {"verdict", a.verdict}};
}

nlohmann::json ForbiddenJson(const ForbiddenAxes& f) {
  nlohmann::json basis = nlohmann::json::array();
  for (Eigen::Index c = 0; c < f.basis.cols(); ++c) basis.push_back(AxisJson(f.basis.col(c)));
  nlohmann::json j = {
      {"dimension", f.dimension}, {"basis_world", basis}, {"description", f.description}};
  if (f.dimension == 2) j["plane_normal_world"] = AxisJson(f.plane_normal);
  return j;
}

void PrintRow(const ReleaseAssessment& a) {
  char line[400];
  std::string rank = a.rank_order > 0 ? std::to_string(a.rank_order) : "-";
  char spread[32] = "         -";  // no equilibrium: no spread
  if (a.statics.ok()) std::snprintf(spread, sizeof(spread), "%10.3g", 100 * a.spread);
  std::snprintf(
      line, sizeof(line), "  %-4s %-22s %-11s %-24s %9.3g  %d/%-3d %-8s %s   %s\n", rank.c_str(),
      a.candidate.name.c_str(), Kind(a.candidate.kind),
      a.candidate.kind == ReleaseKind::kNone ? "" : AxisText(a.candidate.axis_world).c_str(),
      a.margin, a.rank, a.columns,
      a.self_motion       ? "-"
      : a.internal_wrench ? "yes"
                          : "no",
      spread, a.verdict.c_str());
  std::cout << line;
}

const bool kReleasesRegistered = RegisterCommand({
    "releases",
    "Compare released-dof choices: which extra transducer dof (axis through the endpoint) can be "
    "released without self-motion, the wrench each gives, its spread over a stiffness range, "
    "the forbidden axes and a ranked recommendation",
    21,
    [](CLI::App& app) -> std::function<int()> {
      auto o = std::make_shared<ReleasesOptions>();
      AddModelOptions(app, o->model, {/*muscle=*/false});
      AddMusclesAndActivation(app, o->muscles, o->activation);
      app.add_option(
          "--postures", o->postures,
          "CSV of postures: header of joint names (optional 'label' column), rows in degrees");
      app.add_option(
          "--axis", o->axes,
          "Extra candidate: rotation about x,y,z (world axes) through the endpoint, optionally "
          "name:x,y,z; repeatable");
      app.add_option("--translation-axis", o->translation_axes,
                     "Extra candidate: translation along x,y,z (world axes), optionally "
                     "name:x,y,z; repeatable");
      app.add_option("--sweep", o->sweep,
                     "Sample N random rotation axes through the endpoint and count the safe ones");
      app.add_option("--seed", o->seed,
                     "Seed of the --sweep generator (std::mt19937_64; default 1)");
      app.add_option("--margin-warning", o->release.margin_warning,
                     "A release is safe only when sigma_min / sigma_max of the expanded Jacobian > "
                     "this (default 0.01)");
      app.add_option("--svd-tolerance", o->release.rank_tolerance,
                     "Self-motion when sigma_min <= this x sigma_max (default 1e-9)");
      app.add_flag("--json", o->json, "Print JSON instead of text");
      return [o]() {
        Model model = LoadModel(o->model);
        std::vector<std::string> muscles;
        for (const std::string& m : o->muscles) {
          model.MuscleIndex(m);
          muscles.push_back(m);
        }
        if (muscles.empty()) muscles.push_back(ChooseMuscle(model, o->model));
        Eigen::VectorXd base = LoadPosture(model, o->model);
        std::vector<NamedPosture> postures =
            o->postures.empty()
                ? std::vector<NamedPosture>{{o->model.posture.empty() ? "nominal" : "given", base}}
                : ReadPostureTable(model, o->postures, base);
        std::vector<ReleaseCandidate> user;
        for (size_t i = 0; i < o->axes.size(); ++i) {
          user.push_back(ParseAxis(o->axes[i], ReleaseKind::kRotation, static_cast<int>(i + 1)));
        }
        for (size_t i = 0; i < o->translation_axes.size(); ++i) {
          user.push_back(ParseAxis(o->translation_axes[i], ReleaseKind::kTranslation,
                                   static_cast<int>(i + 1)));
        }
        if (o->sweep < 0) throw Error("--sweep " + std::to_string(o->sweep) + " must be >= 0");
        ReleaseOptions options = o->release;
        options.activation = o->activation;
        options.statics = o->model.statics;
        const int grid_points = static_cast<int>(options.range.rotational_ratios.size() *
                                                 options.range.base_stiffness.size());
        const std::vector<std::string> locked = StaticsProblem(model).LockedNames();

        nlohmann::json jp = nlohmann::json::array();
        if (!o->json)
          std::cout << "isowrench releases: " << model.name() << " (" << o->model.urdf << ")\n";
        for (const NamedPosture& p : postures) {
          std::vector<ReleaseCandidate> candidates = DefaultReleaseCandidates(model, p.q);
          candidates.insert(candidates.end(), user.begin(), user.end());
          nlohmann::json jm = nlohmann::json::array();
          nlohmann::json jsweep;
          bool first = true;
          for (const std::string& muscle : muscles) {
            ReleaseComparison c = CompareReleases(model, p.q, muscle, candidates, options);
            // Which of the muscle's wraps engage here, and where one misbehaves (issue 27).
            const nlohmann::json wrap = MuscleWrapJson(model, p.q, model.MuscleIndex(muscle));
            // The force stage at this posture (force model, active and passive parts) and the
            // passive (activation 0) wrench of the model as given.
            const WrenchEvaluation e =
                EvaluateWrench(model, p.q, muscle, o->activation, o->model.statics);
            const int index = model.MuscleIndex(muscle);
            const bool constant = model.muscle(index).force.model == ForceModelType::kConstant;
            if (o->json) {
              nlohmann::json list = nlohmann::json::array();
              for (const ReleaseAssessment& a : c.candidates)
                list.push_back(AssessmentJson(a, grid_points));
              jm.push_back(
                  {{"muscle", muscle},
                   {"force_model", ForceJson(model, index, e.force, o->activation)},
                   {"passive_wrench", e.passive_statics.ok() ? WrenchJson(e.passive_statics.wrench)
                                                             : nlohmann::json(nullptr)},
                   {"baseline", AssessmentJson(c.baseline, grid_points)},
                   {"candidates", list},
                   {"recommended",
                    c.recommended >= 0
                        ? nlohmann::json(
                              c.candidates[static_cast<size_t>(c.recommended)].candidate.name)
                        : nlohmann::json(nullptr)},
                   {"release_needed", c.release_needed},
                   {"recommendation", c.recommendation}});
              if (!wrap.is_null()) jm.back()["wrap"] = wrap;
              if (first) {
                jsweep = {{"length_scale_m", c.length_scale},
                          {"locked", locked},
                          {"stiffness_range", c.range_description},
                          {"forbidden_rotations", ForbiddenJson(c.forbidden_rotations)},
                          {"forbidden_translations", ForbiddenJson(c.forbidden_translations)}};
              }
            } else {
              if (first) {
                std::cout << "\nposture " << p.label << ": " << FormatPosture(model, p.q)
                          << " (degrees)\n"
                          << "  forbidden rotation axes (through the endpoint): "
                          << c.forbidden_rotations.description << "\n  forbidden translation axes: "
                          << c.forbidden_translations.description << "\n"
                          << "  stiffness range: " << c.range_description << "\n"
                          << "  margin = sigma_min / sigma_max of the expanded Jacobian [J_r | "
                             "j_release] "
                             "(translation rows / L, L = "
                          << N(c.length_scale * 1e3, 4) << " mm)\n";
                if (!locked.empty()) {
                  std::cout << "  locked coordinates (rigid, not joint dofs here): "
                            << util::Join(locked, ", ") << "\n";
                }
              }
              std::cout << "\n  muscle " << muscle << " [" << ForceModelLabel(model, index)
                        << "]: " << ForceText(model, index, e.force) << "\n";
              const std::string note = OpenSimNote(model, index, e.force);
              if (!note.empty()) std::cout << "  OpenSim: " << note << "\n";
              if (!constant && e.passive_statics.ok()) {
                std::cout << "  passive W (activation 0), model as given: "
                          << util::FormatNumber(e.passive_statics.wrench.head<3>().norm(), 4)
                          << " N force, "
                          << util::FormatNumber(e.passive_statics.wrench.tail<3>().norm(), 4)
                          << " N·m moment (the baseline a lab subtracts)\n";
              }
              if (!wrap.is_null()) std::cout << "  " << MuscleWrapText(wrap) << "\n";
              std::cout << "  rank candidate              kind        axis (world)                "
                           "margin  rank    "
                           "internal  spread (%)  verdict\n";
              PrintRow(c.baseline);
              for (const ReleaseAssessment& a : c.candidates) PrintRow(a);
              const int w = 30;
              // A row without equilibrium shows no numbers.
              auto row = [w](const std::string& label, const StaticsResult& r) {
                if (r.ok()) return WrenchRow(label, r.wrench, w);
                std::string line = label;
                line.resize(static_cast<size_t>(std::max<int>(w, static_cast<int>(line.size()))),
                            ' ');
                return line + "no equilibrium (" + StatusName(r.status) + ")";
              };
              std::cout << "\n  Wrench the limb applies to the transducer with each release (Eq. "
                           "10, model "
                           "stiffness, transducer axes):\n  "
                        << WrenchHeader(w) << "\n  " << row("none (baseline)", c.baseline.statics)
                        << "\n";
              for (const ReleaseAssessment& a : c.candidates) {
                std::cout << "  " << row(a.candidate.name, a.statics) << "\n";
              }
              std::cout << "\n  recommendation: " << c.recommendation << "\n";
            }
            first = false;
          }
          nlohmann::json js;
          if (o->sweep > 0) {
            AxisSweep s = SweepReleaseAxes(model, p.q, o->sweep, o->seed, options);
            if (o->json) {
              js = {{"samples", s.samples},
                    {"seed", s.seed},
                    {"safe", s.safe},
                    {"near_self_motion", s.near},
                    {"self_motion", s.self_motion},
                    {"already_free", s.already_free},
                    {"smallest_margin", s.smallest_margin},
                    {"worst_axis_world", AxisJson(s.worst_axis)},
                    {"margin_warning", options.margin_warning}};
            } else {
              std::cout << "\n  sweep: " << s.samples
                        << " random rotation axes through the endpoint (seed " << s.seed
                        << "): " << s.safe << " safe (margin > " << N(options.margin_warning)
                        << "), " << s.near << " near self-motion, " << s.self_motion
                        << " self-motion"
                        << (s.already_free ? ", " + std::to_string(s.already_free) + " already free"
                                           : "")
                        << "; smallest margin " << N(s.smallest_margin) << " at axis "
                        << AxisText(s.worst_axis) << " (world)\n";
            }
          }
          if (o->json) {
            nlohmann::json entry = {
                {"label", p.label}, {"posture", FormatPosture(model, p.q)}, {"muscles", jm}};
            entry.update(jsweep);
            if (o->sweep > 0) entry["sweep"] = js;
            jp.push_back(entry);
          }
        }
        if (o->json) {
          std::cout << nlohmann::json({{"command", "releases"},
                                       {"model", model.name()},
                                       {"urdf", o->model.urdf},
                                       {"postures", jp}})
                           .dump(2)
                    << "\n";
        }
        return 0;
      };
    },
});

}  // namespace
}  // namespace isowrench::cli
