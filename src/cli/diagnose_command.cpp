// `isowrench diagnose <urdf>`: constraint class, self-motion, internal wrench, compliance
// sensitivity and the large-deflection check, for one or more postures and muscles.

#include <cstdio>
#include <iostream>

#include "cli/command.hpp"
#include "isowrench/diagnostics.hpp"
#include "isowrench/io.hpp"
#include "isowrench/posture.hpp"

namespace isowrench::cli {
namespace {

std::string N(double v, int digits = 4) { return util::FormatNumber(v, digits); }

struct DiagnoseOptions {
  ModelOptions model;
  std::vector<std::string> muscles;
  double activation = 1.0;
  std::string postures;
  bool json = false;
  bool no_large_deflection = false;
  ConstraintOptions constraints;
};

std::vector<std::string> Muscles(const Model& model, const DiagnoseOptions& o) {
  std::vector<std::string> out;
  for (const std::string& m : o.muscles) {
    model.MuscleIndex(m);  // throws listing the known muscles
    out.push_back(m);
  }
  if (out.empty()) out.push_back(ChooseMuscle(model, o.model));
  return out;
}

std::vector<NamedPosture> Postures(const Model& model, const DiagnoseOptions& o) {
  Eigen::VectorXd base = LoadPosture(model, o.model);
  if (o.postures.empty()) return {{o.model.posture.empty() ? "nominal" : "given", base}};
  return ReadPostureTable(model, o.postures, base);
}

nlohmann::json MotionJson(const JointMotion& m) {
  return {{"direction", ToJson(m.direction)},
          {"joints", m.joints},
          {"interpretation", m.interpretation}};
}

nlohmann::json ConstraintsJson(const ConstraintAnalysis& a) {
  nlohmann::json self = nlohmann::json::array(), internal = nlohmann::json::array();
  for (const JointMotion& m : a.self_motion) self.push_back(MotionJson(m));
  for (const InternalWrench& w : a.internal_wrench) {
    std::vector<std::string> names;
    for (int c : w.components) names.push_back(DofName(c));
    internal.push_back({{"direction", WrenchJson(w.direction)},
                        {"components", names},
                        {"description", w.description}});
  }
  return {{"class", ConstraintClassName(a.constraint_class)},
          {"explanation", a.explanation},
          {"joint_dofs", a.joint_count},
          {"locked", a.locked},
          {"restrained_dofs", a.restrained_count},
          {"restrained", a.restrained.names()},
          {"rank", a.rank},
          {"singular_values", ToJson(a.singular_values)},
          {"singular_value_units", "dimensionless (translation rows divided by the length scale)"},
          {"length_scale_m", a.length_scale},
          {"rank_tolerance", a.rank_tolerance},
          {"rank_threshold", a.rank_threshold},
          {"self_motion", self},
          {"internal_wrench", internal}};
}

nlohmann::json MuscleJson(const Model& model, const Diagnosis& d, double activation) {
  const WrenchEvaluation& e = d.evaluation;
  nlohmann::json null_k = nlohmann::json::array(), sens = nlohmann::json::array();
  for (const JointMotion& m : d.stiffness_null) null_k.push_back(MotionJson(m));
  for (const StiffnessSensitivity& s : d.sensitivity.entries) {
    sens.push_back({{"parameter", s.parameter},
                    {"kind", s.kind},
                    {"stiffness", s.stiffness},
                    {"unit", s.unit},
                    {"dW_dlogk", WrenchJson(s.dW_dlogk)},
                    {"relative", s.relative}});
  }
  // No equilibrium: no wrench (null), never zeros.
  const bool equilibrium = e.statics.ok();
  nlohmann::json j = {
      {"muscle", e.muscle},
      {"force_N", e.muscle_force},
      {"force_model", ForceJson(model, model.MuscleIndex(e.muscle), e.force, activation)},
      {"passive_wrench", e.passive_statics.ok() && equilibrium
                             ? WrenchJson(e.passive_statics.wrench)
                             : nlohmann::json(nullptr)},
      {"tau", ToJson(e.tau)},
      {"equilibrium", equilibrium},
      {"wrench", equilibrium ? WrenchJson(e.statics.wrench) : nlohmann::json(nullptr)},
      {"compliance_dependent", d.compliance_dependent},
      {"compliance_verdict", d.compliance_verdict},
      {"wrench_sign",
       "wrench the limb applies to the transducer; moment about the endpoint; transducer axes"},
      {"statics",
       {{"status", StatusName(e.statics.status)},
        {"message", e.statics.message},
        {"small_motion_valid", e.statics.small_motion_valid},
        {"validity_message", e.statics.validity_message}}},
      {"stiffness_null", null_k},
      {"internal_coefficients", ToJson(d.internal_coefficients)},
      {"internal_residual", d.internal_residual},
      {"classic_wrench",
       d.classic_meaningful ? WrenchJson(e.classic.wrench) : nlohmann::json(nullptr)},
      {"sensitivity",
       {{"ok", d.sensitivity.ok},
        {"message", d.sensitivity.message},
        {"entries", sens},
        {"relative_definition", "|D dW| / |D W|, D = diag(1,1,1,1/L,1/L,1/L)"}}},
  };
  if (d.large_deflection_run) {
    const LargeDeflectionResult& l = d.large_deflection;
    const bool found = l.found(), both = found && equilibrium;
    auto number = [](bool valid, double v) { return valid ? nlohmann::json(v) : nullptr; };
    j["large_deflection"] = {
        {"status", LargeDeflectionStatusName(l.status)},
        {"message", l.message},
        {"iterations", l.iterations},
        {"wrench_linear", equilibrium ? WrenchJson(l.wrench_linear) : nlohmann::json(nullptr)},
        {"wrench_nonlinear", found ? WrenchJson(l.wrench_nonlinear) : nlohmann::json(nullptr)},
        {"wrench_relative_difference", number(both, l.wrench_relative_difference)},
        {"displacement", number(equilibrium, l.displacement)},
        {"dtheta_difference", number(both, l.dtheta_difference)},
        {"dtheta_nonlinear", found ? ToJson(l.dtheta_nonlinear) : nlohmann::json(nullptr)},
        {"dtheta_linear", equilibrium ? ToJson(l.dtheta_linear) : nlohmann::json(nullptr)},
        {"units", "dtheta and displacement: rad (m for prismatic joints), max norm"}};
  }
  return j;
}

void PrintMotions(const char* title, const std::vector<JointMotion>& motions, const char* none) {
  std::cout << "  " << title << (motions.empty() ? std::string(": ") + none : ":") << "\n";
  for (const JointMotion& m : motions) {
    std::cout << "    " << m.joints
              << (m.interpretation.empty() ? "" : "  (" + m.interpretation + ")") << "\n";
  }
}

void PrintConstraints(const ConstraintAnalysis& a) {
  std::cout << "  class        " << ConstraintClassName(a.constraint_class) << ": " << a.explanation
            << "\n"
            << "  restrained   " << a.restrained.ToString(" ") << " (transducer axes)\n"
            << "  J_r singular values (translation rows / L, L = " << N(a.length_scale * 1e3)
            << " mm; rad/rad):";
  for (Eigen::Index i = 0; i < a.singular_values.size(); ++i)
    std::cout << " " << N(a.singular_values[i]);
  std::cout << "\n  rank         " << a.rank
            << " (sigma counts as zero when <= " << N(a.rank_tolerance, 3)
            << " x sigma_max = " << N(a.rank_threshold, 3) << ")\n";
  PrintMotions("self-motion, null(J_r)", a.self_motion, "none");
  std::cout << "  internal wrench, null(J_r^T)" << (a.internal_wrench.empty() ? ": none" : ":")
            << "\n";
  for (const InternalWrench& w : a.internal_wrench) {
    std::vector<std::string> names;
    for (int c : w.components) names.push_back(DofName(c));
    std::cout << "    " << w.description << "  (lives in " << util::Join(names, ", ") << ")\n";
  }
}

void PrintMuscle(const Model& model, const Diagnosis& d) {
  const WrenchEvaluation& e = d.evaluation;
  const int muscle = model.MuscleIndex(e.muscle);
  std::cout << "\n  muscle " << e.muscle << " (" << N(e.muscle_force) << " N)\n"
            << "    force model  " << ForceModelLabel(model, muscle) << "\n";
  if (model.muscle(muscle).force.model != ForceModelType::kConstant) {
    std::cout << "    force        " << ForceText(model, muscle, e.force) << "\n";
  }
  const std::string note = OpenSimNote(model, muscle, e.force);
  if (!note.empty()) std::cout << "    OpenSim      " << note << "\n";
  std::cout << "    statics      " << StatusName(e.statics.status) << ": " << e.statics.message
            << "\n";
  if (!e.statics.validity_message.empty())
    std::cout << "    warning      " << e.statics.validity_message << "\n";
  const int w = 34;
  if (!e.statics.ok()) {
    // No equilibrium: no wrench to print (the statics line says why).
    std::cout << "    W, Eq. 10      none: there is no equilibrium\n";
  } else {
    std::cout << "  " << WrenchHeader(w) << "\n  "
              << WrenchRow("  W, Eq. 10 (limb on transducer)", e.statics.wrench, w) << "\n";
    if (model.muscle(muscle).force.model != ForceModelType::kConstant && e.passive_statics.ok()) {
      std::cout << "  " << WrenchRow("  passive W (activation 0)", e.passive_statics.wrench, w)
                << "\n";
    }
    std::cout << "    compliances  " << d.compliance_verdict << "\n";
  }
  for (Eigen::Index i = 0; i < d.internal_coefficients.size(); ++i) {
    std::cout << "    internal part of W: W - pinv(J_r^T) tau = " << N(d.internal_coefficients[i])
              << " x internal wrench " << i + 1 << " (residual " << N(d.internal_residual, 2)
              << " of |W|)\n";
  }
  if (!d.classic_meaningful && !d.constraints.internal_wrench.empty() && e.statics.ok()) {
    std::cout << "    internal part of W not shown: the model has base dofs, and the classic "
                 "pinv(J_r^T) tau it is measured from treats their springs as free joints\n";
  }
  PrintMotions("  null(K), self-motion no stiffness holds", d.stiffness_null, "none");
  std::cout << "    sensitivity dW/dlog(k): " << d.sensitivity.message << "\n";
  if (d.sensitivity.ok) {
    std::cout << "  " << WrenchHeader(w) << "   relative\n";
    for (const StiffnessSensitivity& s : d.sensitivity.entries) {
      std::string label = "  " + s.parameter + " = " + N(s.stiffness, 3) + " " + s.unit;
      std::cout << "  " << WrenchRow(label, s.dW_dlogk, w) << Cell(s.relative) << "\n";
    }
    if (d.sensitivity.entries.empty()) std::cout << "      (no stiffness in the model)\n";
    std::cout << "      relative = |D dW| / |D W|, D = diag(1, 1, 1, 1/L, 1/L, 1/L)\n";
  }
  if (d.large_deflection_run) {
    const LargeDeflectionResult& l = d.large_deflection;
    std::cout << "    large deflection: " << LargeDeflectionStatusName(l.status) << ": "
              << l.message << "\n";
    if (l.found()) {
      std::cout << "  "
                << WrenchRow(l.status == LargeDeflectionStatus::kConverged
                                 ? "  W nonlinear (updated kinematics)"
                                 : "  W at the unstable point",
                             l.wrench_nonlinear, w)
                << "\n";
      if (e.statics.ok()) {
        std::cout << "      linear motion max |dtheta| = " << N(l.displacement, 3)
                  << " rad; |dtheta_nonlinear - dtheta_linear| = " << N(l.dtheta_difference, 3)
                  << " rad; wrench difference " << N(100 * l.wrench_relative_difference, 3)
                  << "% of |W|\n";
      } else {
        std::cout << "      (Eq. 10 has no equilibrium to compare with; the nonlinear one is "
                     "reached after max |dtheta| = "
                  << N(l.dtheta_nonlinear.cwiseAbs().maxCoeff(), 3) << " rad)\n";
      }
    } else {
      std::cout << "      no nonlinear equilibrium found: no wrench to compare with Eq. 10\n";
    }
  }
}

const bool kDiagnoseRegistered = RegisterCommand({
    "diagnose",
    "Constraint class (over-constrained / matched / under-constrained), self-motions, internal "
    "wrenches, sensitivity of W to every stiffness, and a nonlinear large-deflection check",
    20,
    [](CLI::App& app) -> std::function<int()> {
      auto o = std::make_shared<DiagnoseOptions>();
      AddModelOptions(app, o->model, {/*muscle=*/false});
      AddMusclesAndActivation(app, o->muscles, o->activation);
      app.add_option(
          "--postures", o->postures,
          "CSV of postures: header of joint names (optional 'label' column), rows in degrees "
          "(mm for prismatic joints); unnamed joints keep the --posture/nominal value");
      app.add_option("--svd-tolerance", o->constraints.rank_tolerance,
                     "Singular value of the scaled J_r counts as zero when <= this x the largest "
                     "(default 1e-9)");
      app.add_option("--length-scale", o->constraints.length_scale,
                     "Length L (m) dividing translation rows for the SVD (default: leg length)");
      app.add_flag("--no-large-deflection", o->no_large_deflection,
                   "Skip the nonlinear equilibrium check");
      app.add_flag("--json", o->json, "Print JSON instead of text");
      return [o]() {
        Model model = LoadModel(o->model);
        std::vector<std::string> muscles = Muscles(model, *o);
        std::vector<NamedPosture> postures = Postures(model, *o);
        DiagnosisOptions options;
        options.constraints = o->constraints;
        options.statics = o->model.statics;
        options.activation = o->activation;
        options.large_deflection = !o->no_large_deflection;
        nlohmann::json out_postures = nlohmann::json::array();
        if (!o->json)
          std::cout << "isowrench diagnose: " << model.name() << " (" << o->model.urdf << ")\n";
        Progress progress("diagnose", static_cast<long>(postures.size() * muscles.size()));
        long done = 0;
        for (const NamedPosture& p : postures) {
          ConstraintAnalysis a = AnalyzeConstraints(model, p.q, options.constraints);
          nlohmann::json jm = nlohmann::json::array();
          if (!o->json) {
            std::cout << "\nposture " << p.label << ": " << FormatPosture(model, p.q)
                      << " (degrees)\n";
            PrintConstraints(a);
          }
          for (const std::string& muscle : muscles) {
            Diagnosis d = DiagnoseLimb(model, p.q, muscle, options);
            // Which of the muscle's wraps engage here, and where one misbehaves (issue 27).
            const nlohmann::json wrap = MuscleWrapJson(model, p.q, model.MuscleIndex(muscle));
            if (o->json) {
              jm.push_back(MuscleJson(model, d, o->activation));
              if (!wrap.is_null()) jm.back()["wrap"] = wrap;
            } else {
              PrintMuscle(model, d);
              if (!wrap.is_null()) std::cout << "    " << MuscleWrapText(wrap) << "\n";
            }
            progress.Update(++done);
          }
          if (o->json) {
            out_postures.push_back({{"label", p.label},
                                    {"posture", FormatPosture(model, p.q)},
                                    {"q", ToJson(p.q)},
                                    {"q_units", "rad (m for prismatic joints)"},
                                    {"constraints", ConstraintsJson(a)},
                                    {"muscles", jm}});
          }
        }
        if (o->json) {
          nlohmann::json j = {{"command", "diagnose"},
                              {"model", model.name()},
                              {"urdf", o->model.urdf},
                              {"postures", out_postures}};
          std::cout << j.dump(2) << "\n";
        }
        return 0;
      };
    },
});

}  // namespace
}  // namespace isowrench::cli
