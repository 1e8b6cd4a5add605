// isowrench._core: the pybind11 layer of the Python module `isowrench` (issue 15).
//
// A thin layer over the public C++ API (include/isowrench/*.hpp): it converts arguments
// (numpy arrays in rad / m, names), calls the library and converts the results back (numpy
// float64 arrays, dicts with the keys of the CLI's --json). It computes nothing of its own.
// Errors: isowrench::Error -> ValueError (the C++ message, file and line included); a missing
// file -> FileNotFoundError.

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <filesystem>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "isowrench/diagnostics.hpp"
#include "isowrench/engine.hpp"
#include "isowrench/error.hpp"
#include "isowrench/identification.hpp"
#include "isowrench/kinematics.hpp"
#include "isowrench/model.hpp"
#include "isowrench/opensim.hpp"
#include "isowrench/posture.hpp"
#include "isowrench/statics.hpp"
#include "isowrench/trial_csv.hpp"
#include "isowrench/uncertainty.hpp"

namespace py = pybind11;

namespace isowrench::python {
namespace {

using CArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

[[noreturn]] void ThrowFileNotFound(const std::string& path) {
  PyErr_SetString(PyExc_FileNotFoundError, ("no such file: '" + path + "'").c_str());
  throw py::error_already_set();
}

/// A loaded model: the immutable Model and the file it came from.
struct PyModel {
  Model model;
  std::string path;

  PyModel(Model m, std::string p) : model(std::move(m)), path(std::move(p)) {}
};

std::string CoordinateList(const Model& model) {
  std::string out;
  for (const std::string& name : model.joint_names()) out += (out.empty() ? "" : ", ") + name;
  return out;
}

/// The posture argument: None (the model's default posture), a sequence / 1-D array of n values
/// (rad / m), or a dict {coordinate: value} applied over the default posture.
Eigen::VectorXd Posture(const Model& model, const py::object& q) {
  Eigen::VectorXd out = model.nominal_posture();
  if (q.is_none()) return out;
  if (py::isinstance<py::dict>(q)) {
    for (const auto& item : q.cast<py::dict>()) {
      const std::string name = py::str(item.first);
      out[model.JointIndex(FindCoordinate(model.description(), name).name)] =
          item.second.cast<double>();
    }
  } else {
    CArray a = CArray::ensure(q);
    if (!a || a.ndim() != 1 || a.shape(0) != model.dof_count()) {
      throw Error("q must be None, a dict {coordinate: value} or " +
                  std::to_string(model.dof_count()) + " values in rad / m for the coordinates " +
                  CoordinateList(model));
    }
    for (int i = 0; i < model.dof_count(); ++i) out[i] = a.at(i);
  }
  for (int i = 0; i < model.dof_count(); ++i) {
    if (!std::isfinite(out[i])) {
      throw Error("q[" + std::to_string(i) + "] (" + model.joint_names()[i] + ") is " +
                  std::to_string(out[i]) + "; posture values must be finite (rad / m)");
    }
  }
  return out;
}

/// The model with the transducer stiffness and released dofs given in Python, or the model
/// itself when both are None. transducer: a preset name or 6 values (N/m, N·m/rad); released: a
/// list of dof names (x y z rx ry rz), a comma-separated string, or [] / "none" for none.
std::shared_ptr<PyModel> Variant(const std::shared_ptr<PyModel>& m, const py::object& transducer,
                                 const py::object& released) {
  if (transducer.is_none() && released.is_none()) return m;
  LimbDescription d = m->model.description();
  if (!transducer.is_none()) {
    if (py::isinstance<py::str>(transducer)) {
      d = WithTransducerStiffness(std::move(d), TransducerPreset(transducer.cast<std::string>()));
    } else {
      CArray a = CArray::ensure(transducer);
      if (!a || a.ndim() != 1 || a.shape(0) != 6) {
        throw Error(
            "transducer must be a preset name (balanced, ati-mini40, jr3) or 6 stiffnesses "
            "kx ky kz (N/m) krx kry krz (N·m/rad)");
      }
      Vector6d s;
      for (int i = 0; i < 6; ++i) s[i] = a.at(i);
      d = WithTransducerStiffness(std::move(d), s);
    }
  }
  if (!released.is_none()) {
    d = WithReleasedDofs(std::move(d),
                         py::isinstance<py::str>(released)
                             ? DofMask::Parse(released.cast<std::string>())
                             : DofMask::FromNames(released.cast<std::vector<std::string>>()));
  }
  return std::make_shared<PyModel>(Model(std::move(d)), m->path);
}

std::shared_ptr<PyModel> Load(const std::string& path, const py::object& clamp,
                              const py::object& endpoint) {
  if (!std::filesystem::exists(path)) ThrowFileNotFound(path);
  const std::string ext = std::filesystem::path(path).extension().string();
  if (ext == ".osim") {
    if (clamp.is_none() || endpoint.is_none()) {
      throw Error(
          "loading an OpenSim model needs clamp_body= and endpoint_body= (the bolted body and the "
          "body "
          "carrying the transducer), e.g. isowrench.load('" +
          path +
          "', clamp_body='pelvis', "
          "endpoint_body='tibia')");
    }
    OpenSimImportOptions options;
    options.clamp_body = clamp.cast<std::string>();
    options.endpoint_body = endpoint.cast<std::string>();
    OpenSimImport imported = ImportOpenSimFile(path, options);
    for (const std::string& w : imported.warnings) {
      PyErr_WarnEx(PyExc_UserWarning, (path + ": " + w).c_str(), 1);
    }
    return std::make_shared<PyModel>(Model(std::move(imported.description)), path);
  }
  return std::make_shared<PyModel>(Model::FromUrdfFile(path), path);
}

py::array_t<double> Array(const Eigen::VectorXd& v) {
  py::array_t<double> a(v.size());
  for (Eigen::Index i = 0; i < v.size(); ++i) a.mutable_at(i) = v[i] == 0.0 ? 0.0 : v[i];
  return a;
}

py::array_t<double> Array(const Eigen::MatrixXd& m) {
  py::array_t<double> a({m.rows(), m.cols()});
  for (Eigen::Index r = 0; r < m.rows(); ++r) {
    for (Eigen::Index c = 0; c < m.cols(); ++c) a.mutable_at(r, c) = m(r, c) == 0.0 ? 0.0 : m(r, c);
  }
  return a;
}

py::dict Kinematics(const PyModel& m, const py::object& q_arg) {
  const Model& model = m.model;
  const Eigen::VectorXd q = Posture(model, q_arg);
  Data ws(model);
  py::dict out;
  out["q"] = Array(q);
  out["endpoint_m"] = Array(Eigen::VectorXd(EndpointPose(model, ws, q).translation()));
  out["jacobian"] = Array(Eigen::MatrixXd(EndpointJacobianWorld(model, ws, q)));
  py::dict muscles;
  for (int i = 0; i < model.muscle_count(); ++i) {
    MuscleTorque t = ComputeMuscleTorque(model, ws, q, i);
    py::dict entry;
    entry["length_m"] = t.length;
    entry["moment_arm_m"] = Array(Eigen::VectorXd(-t.dL_dq.transpose()));
    muscles[py::str(model.muscle(i).name)] = entry;
  }
  out["muscles"] = muscles;
  return out;
}

/// One wrench evaluation as Python sees it.
struct PyWrench {
  WrenchEvaluation e;
  std::vector<std::string> coordinates;
};

PyWrench Wrench(const std::shared_ptr<PyModel>& m0, const std::string& muscle, const py::object& q,
                const py::object& transducer, const py::object& released, double activation) {
  std::shared_ptr<PyModel> m = Variant(m0, transducer, released);
  return {EvaluateWrench(m->model, Posture(m->model, q), muscle, activation),
          m->model.joint_names()};
}

/// (N, n) float64 C-contiguous postures checked for shape and finiteness.
CArray Postures(const Model& model, const py::object& Q) {
  CArray a = CArray::ensure(Q);
  if (!a) throw Error("Q must be a 2-D array of float64 postures (N, n) in rad / m");
  const long n = model.dof_count();
  if (a.ndim() != 2 || a.shape(1) != n) {
    std::string shape = "(";
    for (py::ssize_t i = 0; i < a.ndim(); ++i)
      shape += (i ? ", " : "") + std::to_string(a.shape(i));
    shape += a.ndim() == 1 ? ",)" : ")";
    throw Error("Q has shape " + shape + "; it must be (N, " + std::to_string(n) +
                "): one row per posture, one column " + "per coordinate (" + CoordinateList(model) +
                "), rad / m");
  }
  const double* data = a.data();
  const py::ssize_t rows = a.shape(0);
  for (py::ssize_t r = 0; r < rows; ++r) {
    for (long c = 0; c < n; ++c) {
      const double v = data[r * n + c];
      if (!std::isfinite(v)) {
        throw Error("Q[" + std::to_string(r) + ", " + std::to_string(c) + "] (" +
                    model.joint_names()[c] + ") is " + std::to_string(v) +
                    "; postures must be finite (rad / m)");
      }
    }
  }
  return a;
}

py::object WrenchBatch(const std::shared_ptr<PyModel>& m0, const std::string& muscle,
                       const py::object& Q, double activation, const py::object& transducer,
                       const py::object& released, int threads, bool return_status) {
  std::shared_ptr<PyModel> m = Variant(m0, transducer, released);
  const int muscle_index = m->model.MuscleIndex(muscle);
  CArray postures = Postures(m->model, Q);
  const py::ssize_t count = postures.shape(0);
  const int n = m->model.dof_count();
  if (!std::isfinite(activation))
    throw Error("activation is " + std::to_string(activation) + "; it must be finite");
  if (threads < 0)
    throw Error("threads is " + std::to_string(threads) + "; it must be >= 1, or 0 for every core");
  py::array_t<double> out({count, static_cast<py::ssize_t>(6)});
  py::array_t<std::uint8_t> status(count);
  double* w = out.mutable_data();
  std::uint8_t* s = status.mutable_data();
  const double* q = postures.data();
  {
    py::gil_scoped_release release;
    if (count > 0) {
      // A C-contiguous (N, n) array is an n x N column-major matrix: no copy.
      Eigen::Map<const Eigen::MatrixXd> columns(q, n, count);
      std::vector<WrenchResult> results;
      BatchOptions options;
      options.threads = threads > 0 ? threads : std::max(1u, std::thread::hardware_concurrency());
      EvaluateBatch(m->model, columns, muscle_index, {m->model.model_stiffness()}, results,
                    activation, options);
      for (py::ssize_t p = 0; p < count; ++p) {
        for (int k = 0; k < 6; ++k) w[p * 6 + k] = results[static_cast<size_t>(p)].wrench[k];
        s[p] = static_cast<std::uint8_t>(results[static_cast<size_t>(p)].status);
      }
    }
  }
  if (return_status) return py::make_tuple(out, status);
  return std::move(out);
}

py::dict WrenchDict(const Vector6d& w) {
  py::dict d;
  const char* names[6] = {"fx", "fy", "fz", "mx", "my", "mz"};
  for (int i = 0; i < 6; ++i) d[names[i]] = w[i] == 0.0 ? 0.0 : w[i];
  return d;
}

py::dict AssessmentDict(const ReleaseAssessment& a) {
  py::dict d;
  d["name"] = a.candidate.name;
  d["kind"] = a.candidate.kind == ReleaseKind::kNone       ? "none"
              : a.candidate.kind == ReleaseKind::kRotation ? "rotation"
                                                           : "translation";
  d["source"] = a.candidate.source;
  d["axis_world"] = Array(Eigen::VectorXd(a.candidate.axis_world));
  d["axis_transducer"] = Array(Eigen::VectorXd(a.axis_transducer));
  d["rank"] = a.rank;
  d["columns"] = a.columns;
  d["margin"] = a.margin;
  d["self_motion"] = a.self_motion;
  d["near_self_motion"] = a.near_self_motion;
  d["internal_wrench"] = a.internal_wrench;
  d["torques_recoverable"] = a.torques_recoverable;
  d["statics_status"] = StatusName(a.statics.status);
  d["small_motion_valid"] = a.statics.small_motion_valid;
  d["wrench"] = WrenchDict(a.statics.wrench);
  d["wrench_min"] = WrenchDict(a.wrench_min);
  d["wrench_max"] = WrenchDict(a.wrench_max);
  d["spread"] = a.spread;
  d["range_failures"] = a.range_failures;
  d["rank_order"] = a.rank_order;
  d["verdict"] = a.verdict;
  return d;
}

py::dict ForbiddenDict(const ForbiddenAxes& f) {
  py::dict d;
  d["dimension"] = f.dimension;
  d["basis_world"] = Array(Eigen::MatrixXd(f.basis.transpose()));
  d["description"] = f.description;
  return d;
}

py::dict Releases(const PyModel& m, const std::string& muscle, const py::object& q) {
  ReleaseComparison c = CompareReleases(m.model, Posture(m.model, q), muscle);
  py::dict d;
  d["muscle"] = c.muscle;
  d["baseline"] = AssessmentDict(c.baseline);
  py::list list;
  for (const ReleaseAssessment& a : c.candidates) list.append(AssessmentDict(a));
  d["candidates"] = list;
  d["recommended"] =
      c.recommended >= 0
          ? py::object(py::str(c.candidates[static_cast<size_t>(c.recommended)].candidate.name))
          : py::object(py::none());
  d["recommendation"] = c.recommendation;
  d["length_scale_m"] = c.length_scale;
  d["stiffness_range"] = c.range_description;
  d["forbidden_rotations"] = ForbiddenDict(c.forbidden_rotations);
  d["forbidden_translations"] = ForbiddenDict(c.forbidden_translations);
  return d;
}

py::dict MotionDict(const JointMotion& m) {
  py::dict d;
  d["direction"] = Array(m.direction);
  d["joints"] = m.joints;
  d["interpretation"] = m.interpretation;
  return d;
}

py::dict Diagnose(const PyModel& m, const std::string& muscle, const py::object& q,
                  bool large_deflection) {
  DiagnosisOptions options;
  options.large_deflection = large_deflection;
  Diagnosis d = DiagnoseLimb(m.model, Posture(m.model, q), muscle, options);
  const ConstraintAnalysis& a = d.constraints;
  py::dict constraints;
  constraints["class"] = ConstraintClassName(a.constraint_class);
  constraints["explanation"] = a.explanation;
  constraints["joint_dofs"] = a.joint_count;
  constraints["restrained_dofs"] = a.restrained_count;
  constraints["restrained"] = a.restrained.names();
  constraints["rank"] = a.rank;
  constraints["singular_values"] = Array(a.singular_values);
  constraints["length_scale_m"] = a.length_scale;
  constraints["rank_tolerance"] = a.rank_tolerance;
  constraints["rank_threshold"] = a.rank_threshold;
  py::list self, internal;
  for (const JointMotion& j : a.self_motion) self.append(MotionDict(j));
  for (const InternalWrench& w : a.internal_wrench) {
    py::dict i;
    std::vector<std::string> names;
    for (int c : w.components) names.push_back(DofName(c));
    i["direction"] = WrenchDict(w.direction);
    i["components"] = names;
    i["description"] = w.description;
    internal.append(i);
  }
  constraints["self_motion"] = self;
  constraints["internal_wrench"] = internal;

  const WrenchEvaluation& e = d.evaluation;
  py::dict out;
  out["constraints"] = constraints;
  out["muscle"] = e.muscle;
  out["force_N"] = e.muscle_force;
  out["tau"] = Array(e.tau);
  out["wrench"] = WrenchDict(e.statics.wrench);
  py::dict statics;
  statics["status"] = StatusName(e.statics.status);
  statics["message"] = e.statics.message;
  statics["small_motion_valid"] = e.statics.small_motion_valid;
  statics["validity_message"] = e.statics.validity_message;
  out["statics"] = statics;
  py::list null_k;
  for (const JointMotion& j : d.stiffness_null) null_k.append(MotionDict(j));
  out["stiffness_null"] = null_k;
  out["internal_coefficients"] = Array(d.internal_coefficients);
  out["internal_residual"] = d.internal_residual;
  out["classic_wrench"] = WrenchDict(e.classic.wrench);
  py::dict sensitivity;
  sensitivity["ok"] = d.sensitivity.ok;
  sensitivity["message"] = d.sensitivity.message;
  py::list entries;
  for (const StiffnessSensitivity& s : d.sensitivity.entries) {
    py::dict entry;
    entry["parameter"] = s.parameter;
    entry["kind"] = s.kind;
    entry["stiffness"] = s.stiffness;
    entry["unit"] = s.unit;
    entry["dW_dlogk"] = WrenchDict(s.dW_dlogk);
    entry["relative"] = s.relative;
    entries.append(entry);
  }
  sensitivity["entries"] = entries;
  out["sensitivity"] = sensitivity;
  if (d.large_deflection_run) {
    const LargeDeflectionResult& l = d.large_deflection;
    py::dict ld;
    ld["status"] = LargeDeflectionStatusName(l.status);
    ld["message"] = l.message;
    ld["iterations"] = l.iterations;
    ld["wrench_linear"] = WrenchDict(l.wrench_linear);
    ld["wrench_nonlinear"] = WrenchDict(l.wrench_nonlinear);
    ld["wrench_relative_difference"] = l.wrench_relative_difference;
    ld["displacement"] = l.displacement;
    ld["dtheta_difference"] = l.dtheta_difference;
    ld["dtheta_nonlinear"] = Array(l.dtheta_nonlinear);
    ld["dtheta_linear"] = Array(l.dtheta_linear);
    out["large_deflection"] = ld;
  }
  return out;
}

std::string Simulate(const PyModel& m, const std::string& output,
                     const std::vector<std::string>& effects, int n, unsigned long long seed,
                     double noise_force, double noise_moment, double joint_range,
                     const std::vector<std::string>& muscles) {
  std::vector<AppliedEffect> applied;
  for (const std::string& text : effects) applied.push_back(ParseEffectAssignment(m.model, text));
  SimulationOptions options;
  options.postures = n;
  options.seed = seed;
  options.noise_force = noise_force;
  options.noise_moment = noise_moment;
  options.joint_range = joint_range;
  options.muscles = muscles;
  options.center = m.model.nominal_posture();
  std::vector<Trial> trials;
  {
    py::gil_scoped_release release;
    AugmentedModel truth = ApplyEffects(m.model.description(), applied);
    trials = SimulateTrials(m.model, truth, options);
    WriteTrialsCsv(m.model, trials, output);
  }
  return output;
}

py::dict Fit(const PyModel& m, const std::string& csv, int max_fit_trials,
             unsigned long long sample_seed) {
  if (!std::filesystem::exists(csv)) ThrowFileNotFound(csv);
  FitReport report;
  {
    py::gil_scoped_release release;
    FitOptions options;
    options.max_fit_trials = max_fit_trials;
    options.sample_seed = sample_seed;
    report = FitEffectsCsv(m.model, csv, options);
  }
  py::dict out;
  out["verdict"] = FitVerdictName(report.verdict);
  out["verdict_message"] = report.verdict_message;
  out["effects_claimed"] = report.effects_claimed;
  py::list chosen;
  for (const CandidateFit& c : report.chosen_fits) {
    py::dict effect;
    effect["id"] = c.effect.id;
    py::list parameters;
    for (size_t i = 0; i < c.values.size(); ++i) {
      py::dict p;
      p["name"] = c.effect.parameters[i].name;
      p["value"] = c.values[i];
      p["standard_error"] = i < c.standard_errors.size() ? c.standard_errors[i] : 0.0;
      p["unit"] = c.effect.parameters[i].unit;
      parameters.append(p);
    }
    effect["parameters"] = parameters;
    chosen.append(effect);
  }
  out["chosen"] = chosen;
  out["trial_count"] = report.trial_count;
  out["fitted_trial_count"] = report.fitted_trial_count;
  out["sampling"] = report.sampling;
  out["rms_before"] = Array(Eigen::VectorXd(report.before.rms));
  out["rms_after"] = Array(Eigen::VectorXd(report.after.rms));
  out["normalized_before"] = Array(Eigen::VectorXd(report.before.normalized));
  out["normalized_after"] = Array(Eigen::VectorXd(report.after.normalized));
  out["indistinguishable"] = report.indistinguishable;
  out["notes"] = report.notes;
  out["report"] = report.BriefReport();
  out["seconds"] = report.seconds;
  return out;
}

std::string WrenchRepr(const PyWrench& w) {
  const Vector6d& t = w.e.statics.wrench;
  char buffer[256];
  std::snprintf(buffer, sizeof(buffer),
                "<isowrench.Wrench %s: fx=%.6g fy=%.6g fz=%.6g N, mx=%.6g my=%.6g mz=%.6g N·m "
                "(transducer axes), "
                "status '%s'%s>",
                w.e.muscle.c_str(), t[0], t[1], t[2], t[3], t[4], t[5],
                StatusName(w.e.statics.status),
                w.e.statics.small_motion_valid ? "" : ", small motion INVALID");
  return buffer;
}

// ---- Monte Carlo uncertainty (issue 30; docs/uncertainty.md, python/isowrench/study.py) ----

UncertaintyOptions UncertaintyOptionsFrom(const py::dict& o) {
  UncertaintyOptions options;
  for (const auto& item : o) {
    const std::string key = py::str(item.first);
    if (key == "samples") {
      options.samples = item.second.cast<long>();
    } else if (key == "seed") {
      options.seed = item.second.cast<std::uint64_t>();
    } else if (key == "sobol") {
      options.sobol = item.second.cast<bool>();
    } else if (key == "activation") {
      options.activation = item.second.cast<double>();
    } else if (key == "exact_percentile_values") {
      options.exact_percentile_values = item.second.cast<double>();
    } else if (key == "max_endpoint_fraction") {
      options.statics.max_endpoint_fraction = item.second.cast<double>();
    } else if (key == "max_joint_rotation") {
      options.statics.max_joint_rotation = item.second.cast<double>();
    } else if (key == "rank_tolerance") {
      options.statics.rank_tolerance = item.second.cast<double>();
    } else {
      throw Error("uncertainty option '" + key +
                  "' is unknown (samples, seed, sobol, activation, exact_percentile_values, "
                  "max_endpoint_fraction, max_joint_rotation, rank_tolerance)");
    }
  }
  return options;
}

/// A study from plain values (what isowrench.study ships to worker processes): the model as
/// URDF text, the muscle, postures (P, n) rows in rad / m, the spec as JSON (fit included) and
/// the options dict.
UncertaintyStudy MakeUncertaintyStudy(const std::string& urdf, const std::string& muscle,
                                      const Eigen::MatrixXd& postures_rows,
                                      const std::string& spec_json, const py::dict& options) {
  const Model model(ReadUrdfString(urdf, "<study model>"));
  const Eigen::MatrixXd postures = postures_rows.transpose();
  return UncertaintyStudy(model, muscle, postures, ParseUncertaintySpec(spec_json, "<study spec>"),
                          UncertaintyOptionsFrom(options));
}

py::object JsonToPython(const std::string& text) {
  return py::module_::import("json").attr("loads")(text);
}

/// The spec of Model.uncertainty / isowrench.study: `inputs` (strings in the CLI's syntax, or
/// dicts like the spec file's entries), a spec file path or dict, a fit JSON path.
UncertaintySpec SpecFromPython(const Model& model, const py::object& inputs, const py::object& spec,
                               const py::object& from_fit) {
  UncertaintySpec out;
  py::module_ json = py::module_::import("json");
  if (!spec.is_none()) {
    if (py::isinstance<py::dict>(spec)) {
      out = ParseUncertaintySpec(json.attr("dumps")(spec).cast<std::string>(), "spec");
    } else {
      const std::string path = py::str(spec);
      if (!std::filesystem::exists(path)) ThrowFileNotFound(path);
      out = ReadUncertaintySpecFile(path);
    }
  }
  if (!inputs.is_none()) {
    for (const py::handle item : inputs) {
      if (py::isinstance<py::str>(item)) {
        out.inputs.push_back(ParseUncertainInput(item.cast<std::string>(), "inputs"));
      } else if (py::isinstance<py::dict>(item)) {
        const std::string text =
            "{\"inputs\": [" + json.attr("dumps")(item).cast<std::string>() + "]}";
        out.inputs.push_back(ParseUncertaintySpec(text, "inputs").inputs.at(0));
      } else {
        throw Error(
            "inputs: each input is a string 'NAME=DISTRIBUTION:PARAMETERS' or a dict "
            "{'name': ..., 'distribution': ..., 'sd' or 'lower'/'upper': ...}");
      }
    }
  }
  if (!from_fit.is_none()) {
    const std::string path = py::str(from_fit);
    if (!std::filesystem::exists(path)) ThrowFileNotFound(path);
    out.fit = ReadFitUncertainty(path, model);
    out.has_fit = true;
  }
  return out;
}

/// Postures (P, n) rows in rad / m: `postures` when given, else the one posture q.
Eigen::MatrixXd PosturesFromPython(const Model& model, const py::object& q,
                                   const py::object& postures) {
  if (postures.is_none()) return Posture(model, q).transpose();
  CArray a = CArray::ensure(postures);
  if (!a || a.ndim() != 2 || a.shape(1) != model.dof_count() || a.shape(0) < 1) {
    throw Error("postures must be an array (P, " + std::to_string(model.dof_count()) +
                ") in rad / m for the coordinates " + CoordinateList(model));
  }
  Eigen::MatrixXd out(a.shape(0), a.shape(1));
  for (py::ssize_t i = 0; i < a.shape(0); ++i)
    for (py::ssize_t k = 0; k < a.shape(1); ++k) out(i, k) = a.at(i, k);
  return out;
}

py::object Uncertainty(const PyModel& m, const py::object& muscle, const py::object& inputs,
                       const py::object& spec, const py::object& from_fit, const py::object& q,
                       const py::object& postures, long samples, std::uint64_t seed, bool sobol,
                       int threads, double activation, double exact_percentile_values) {
  std::string name;
  if (!muscle.is_none()) {
    name = muscle.cast<std::string>();
  } else if (m.model.muscle_count() > 0) {
    name = m.model.muscle(0).name;
  }
  const UncertaintySpec s = SpecFromPython(m.model, inputs, spec, from_fit);
  const Eigen::MatrixXd P = PosturesFromPython(m.model, q, postures).transpose();
  UncertaintyOptions options;
  options.samples = samples;
  options.seed = seed;
  options.sobol = sobol;
  options.threads =
      threads > 0 ? threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  options.activation = activation;
  options.exact_percentile_values = exact_percentile_values;
  std::string json;
  {
    py::gil_scoped_release release;
    json = UncertaintyJson(RunUncertainty(m.model, name, P, s, options), m.model);
  }
  return JsonToPython(json);
}

void BindUncertainty(py::module_& mod, py::class_<PyModel, std::shared_ptr<PyModel>>& model) {
  model
      .def(
          "uncertainty", &Uncertainty, py::arg("muscle") = py::none(),
          py::arg("inputs") = py::none(), py::arg("spec") = py::none(),
          py::arg("from_fit") = py::none(), py::arg("q") = py::none(),
          py::arg("postures") = py::none(), py::arg("samples") = UncertaintyOptions{}.samples,
          py::arg("seed") = UncertaintyOptions{}.seed, py::arg("sobol") = true,
          py::arg("threads") = 0, py::arg("activation") = 1.0,
          py::arg("exact_percentile_values") = UncertaintyOptions{}.exact_percentile_values,
          R"(uncertainty(muscle=None, inputs=None, spec=None, from_fit=None, q=None, postures=None, samples=4096, seed=1, sobol=True, threads=0, activation=1.0, exact_percentile_values=2e7) -> dict

Monte Carlo uncertainty of the wrench, the dict of `isowrench uncertainty --json`. inputs: strings in the CLI's syntax ('angle:hip_rz=normal:2', degrees and mm as on the command line) or dicts like the spec file's entries; spec: a spec file path or dict; from_fit: an `isowrench fit --json` file. q: one posture (rad / m, or a dict), or postures (P, n). The same seed gives the same numbers on any thread count (threads=0: every core). The GIL is released. isowrench.study runs the same study on Dask.
Raises ValueError naming a bad input (unknown name with the closest one, negative sd, empty support, a fit of another model).)")
      .def_property_readonly(
          "urdf_text", [](const PyModel& m) { return WriteUrdfString(m.model.description()); },
          "The model as URDF text (17 digits: reading it back gives the same model).")
      .def(
          "uncertainty_spec",
          [](const PyModel& m, const py::object& inputs, const py::object& spec,
             const py::object& from_fit) {
            return UncertaintySpecJson(SpecFromPython(m.model, inputs, spec, from_fit));
          },
          py::arg("inputs") = py::none(), py::arg("spec") = py::none(),
          py::arg("from_fit") = py::none(),
          "uncertainty_spec(inputs=None, spec=None, from_fit=None) -> str: the study's spec as "
          "JSON text with the fit's parameters and covariance inside (isowrench.study ships it "
          "to workers).");
  mod.def(
      "_uncertainty_blocks",
      [](const std::string& urdf, const std::string& muscle, const Eigen::MatrixXd& postures,
         const std::string& spec, const py::dict& options) {
        const UncertaintyStudy study = MakeUncertaintyStudy(urdf, muscle, postures, spec, options);
        return py::make_tuple(study.block_count(), study.evaluation_count());
      },
      "(urdf, muscle, postures (P, n), spec_json, options) -> (blocks, evaluations)");
  mod.def(
      "_uncertainty_run",
      [](const std::string& urdf, const std::string& muscle, const Eigen::MatrixXd& postures,
         const std::string& spec, const py::dict& options, long first, long last, int threads) {
        const UncertaintyStudy study = MakeUncertaintyStudy(urdf, muscle, postures, spec, options);
        std::string bytes;
        {
          py::gil_scoped_release release;
          bytes = RunUncertaintyBlocks(study, first, last, threads).ToBytes();
        }
        return py::bytes(bytes);
      },
      "(urdf, muscle, postures, spec_json, options, first_block, last_block, threads) -> bytes");
  mod.def(
      "_uncertainty_finish",
      [](const std::string& urdf, const std::string& muscle, const Eigen::MatrixXd& postures,
         const std::string& spec, const py::dict& options, const std::vector<py::bytes>& parts,
         double seconds) {
        const UncertaintyStudy study = MakeUncertaintyStudy(urdf, muscle, postures, spec, options);
        std::vector<UncertaintyPartial> partials;
        for (const py::bytes& b : parts) partials.push_back(UncertaintyPartial::FromBytes(b));
        UncertaintyResult result = FinishUncertainty(study, partials);
        result.seconds = seconds;
        return JsonToPython(UncertaintyJson(result, study.model()));
      },
      "(urdf, muscle, postures, spec_json, options, [bytes], seconds) -> dict");
}

}  // namespace
}  // namespace isowrench::python

PYBIND11_MODULE(_core, mod) {
  using namespace isowrench;
  using namespace isowrench::python;
  mod.doc() =
      "isowrench._core: the C++ engine behind the isowrench package (pybind11). Use `import "
      "isowrench`.";
  mod.attr("__version__") = ISOWRENCH_VERSION;
  mod.attr("STATUS_NAMES") = py::make_tuple(
      StatusName(StaticsStatus::kOk), StatusName(StaticsStatus::kSelfMotionHeld),
      StatusName(StaticsStatus::kSelfMotion), StatusName(StaticsStatus::kInvalidInput));

  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const Error& e) {
      PyErr_SetString(PyExc_ValueError, e.what());
    }
  });

  py::class_<PyWrench>(
      mod, "Wrench",
      "One muscle at one posture: the Eq. 10 wrench W = S_t J (J^T S_t J + S_p)^-1 tau that the "
      "limb "
      "applies to the transducer (forces N, moments N·m about the endpoint), with the statics "
      "behind it. Returned by Model.wrench().")
      .def_property_readonly(
          "transducer",
          [](const PyWrench& w) { return Array(Eigen::VectorXd(w.e.statics.wrench)); },
          "(6,) [fx fy fz mx my mz] in the transducer's axes (N, N·m); released rows are 0; zeros "
          "when status is 'self-motion' (no equilibrium).")
      .def_property_readonly(
          "world", [](const PyWrench& w) { return Array(Eigen::VectorXd(w.e.wrench_world)); },
          "(6,) the same wrench in world axes (N, N·m).")
      .def_property_readonly(
          "classic", [](const PyWrench& w) { return Array(Eigen::VectorXd(w.e.classic.wrench)); },
          "(6,) the classic answer without compliance, J^-T tau (Eq. 11) or pinv(J^T) tau (Eq. "
          "15), transducer axes (N, N·m).")
      .def_property_readonly(
          "dtheta", [](const PyWrench& w) { return Array(w.e.statics.dtheta); },
          "(n,) equilibrium displacement K^+ tau per coordinate (rad, or m for prismatic ones).")
      .def_property_readonly(
          "tau", [](const PyWrench& w) { return Array(w.e.tau); },
          "(n,) muscle generalized force -F dL/dq per coordinate (N·m, or N for prismatic ones).")
      .def_property_readonly(
          "q", [](const PyWrench& w) { return Array(w.e.q); }, "(n,) the posture (rad / m).")
      .def_property_readonly(
          "jacobian", [](const PyWrench& w) { return Array(Eigen::MatrixXd(w.e.jacobian)); },
          "(6, n) endpoint Jacobian in transducer axes, rows [v; w].")
      .def_property_readonly(
          "status", [](const PyWrench& w) { return std::string(StatusName(w.e.statics.status)); },
          "'ok', 'self-motion (not excited)' (W still unique), 'self-motion' (no equilibrium, W "
          "is zeros) or 'invalid input'.")
      .def_property_readonly(
          "message", [](const PyWrench& w) { return w.e.statics.message; },
          "The statics' one-sentence explanation of the status.")
      .def_property_readonly(
          "small_motion", [](const PyWrench& w) { return w.e.statics.small_motion_valid; },
          "True when the linear (small-motion) answer is valid: endpoint translation <= 0.1% of "
          "the leg length and every joint rotation <= 0.01 rad.")
      .def_property_readonly(
          "small_motion_message", [](const PyWrench& w) { return w.e.statics.validity_message; },
          "Why the small-motion check failed ('' when valid).")
      .def_property_readonly(
          "muscle", [](const PyWrench& w) { return w.e.muscle; }, "The muscle's name.")
      .def_property_readonly(
          "muscle_force_N", [](const PyWrench& w) { return w.e.muscle_force; },
          "Muscle force F = activation x max_force (N).")
      .def_property_readonly(
          "muscle_length_m", [](const PyWrench& w) { return w.e.muscle_length; },
          "Muscle path length (m).")
      .def_property_readonly(
          "coordinates", [](const PyWrench& w) { return w.coordinates; },
          "Coordinate names: the order of dtheta, tau and q.")
      .def("__repr__", &WrenchRepr);

  py::class_<PyModel, std::shared_ptr<PyModel>>(
      mod, "Model",
      "An immutable limb model (URDF with isowrench tags, or an imported .osim): the chain from "
      "ground to the "
      "endpoint, its coordinates, muscles and transducer. Create it with isowrench.load(). "
      "Thread-safe.")
      .def_property_readonly(
          "name", [](const PyModel& m) { return m.model.name(); }, "The model's (robot's) name.")
      .def_property_readonly(
          "path", [](const PyModel& m) { return m.path; }, "The file it was loaded from.")
      .def_property_readonly(
          "coordinates", [](const PyModel& m) { return m.model.joint_names(); },
          "Independent coordinate names in column order (the Jacobian's columns, a posture's "
          "entries).")
      .def_property_readonly(
          "coordinate_types",
          [](const PyModel& m) {
            std::vector<std::string> out;
            for (const std::string& name : m.model.joint_names()) {
              out.push_back(FindCoordinate(m.model.description(), name).type ==
                                    JointType::kPrismatic
                                ? "prismatic"
                                : "revolute");
            }
            return out;
          },
          "'revolute' (rad) or 'prismatic' (m) per coordinate.")
      .def_property_readonly(
          "muscles",
          [](const PyModel& m) {
            std::vector<std::string> out;
            for (int i = 0; i < m.model.muscle_count(); ++i) out.push_back(m.model.muscle(i).name);
            return out;
          },
          "Muscle names.")
      .def_property_readonly(
          "default_posture", [](const PyModel& m) { return Array(m.model.nominal_posture()); },
          "(n,) the model's nominal posture (rad / m), used when q is None.")
      .def_property_readonly(
          "joint_stiffness", [](const PyModel& m) { return Array(m.model.joint_stiffness()); },
          "(n,) S_p diagonal per coordinate (N·m/rad or N/m).")
      .def_property_readonly(
          "transducer_stiffness",
          [](const PyModel& m) { return Array(Eigen::VectorXd(m.model.transducer().stiffness)); },
          "(6,) S_t diagonal [kx ky kz (N/m), krx kry krz (N·m/rad)] in transducer axes.")
      .def_property_readonly(
          "released", [](const PyModel& m) { return m.model.transducer().released.names(); },
          "Released transducer dofs (names among x y z rx ry rz).")
      .def_property_readonly(
          "leg_length_m", [](const PyModel& m) { return m.model.chain_length(); },
          "Sum of joint-to-joint distances plus the endpoint offset (m).")
      .def("kinematics", &Kinematics, py::arg("q") = py::none(),
           "kinematics(q=None) -> dict\n\n"
           "Endpoint position, endpoint Jacobian and every muscle's length and moment arm at "
           "posture q (None: the "
           "default posture; n values in rad / m; or a dict {coordinate: value} over the default "
           "posture).\n"
           "Returns {'q': (n,), 'endpoint_m': (3,) world position (m), 'jacobian': (6, n) world "
           "axes, rows vx vy vz "
           "(m/rad) wx wy wz (rad/rad), 'muscles': {name: {'length_m': float, 'moment_arm_m': (n,) "
           "-dL/dq}}}: the "
           "same numbers as `isowrench kinematics --json`.\nRaises ValueError for a bad posture.")
      .def("wrench", &Wrench, py::arg("muscle"), py::arg("q") = py::none(),
           py::arg("transducer") = py::none(), py::arg("released") = py::none(),
           py::arg("activation") = 1.0,
           "wrench(muscle, q=None, transducer=None, released=None, activation=1.0) -> Wrench\n\n"
           "The Eq. 10 wrench muscle `muscle` applies through the limb to the transducer at "
           "posture q (None: default "
           "posture; n values in rad / m; or a dict {coordinate: value}). transducer: None (the "
           "model's S_t), a "
           "preset name ('balanced', 'ati-mini40', 'jr3') or 6 stiffnesses (N/m, N·m/rad); "
           "released: None (the "
           "model's), a list of dof names among x y z rx ry rz, or [] for none. activation scales "
           "the force "
           "(F = activation x max_force). Same numbers as `isowrench wrench --json`.\n"
           "Raises ValueError for an unknown muscle, a bad posture or bad stiffnesses.")
      .def("wrench_batch", &WrenchBatch, py::arg("muscle"), py::arg("Q"),
           py::arg("activation") = 1.0, py::arg("transducer") = py::none(),
           py::arg("released") = py::none(), py::arg("threads") = 0,
           py::arg("return_status") = false,
           "wrench_batch(muscle, Q, activation=1.0, transducer=None, released=None, threads=0, "
           "return_status=False)"
           " -> ndarray (N, 6)\n\n"
           "The Eq. 10 wrench at every posture (row) of Q (N, n) in rad / m: row i = [fx fy fz mx "
           "my mz] (N, N·m) in "
           "transducer axes, equal to wrench(muscle, Q[i]).transducer to rounding. Runs the C++ "
           "batch kernel with "
           "the GIL released on `threads` threads (0: every core). Rows without equilibrium are "
           "zeros; with "
           "return_status=True a uint8 status array (N,) is returned too, indexing "
           "isowrench.STATUS_NAMES.\n"
           "Raises ValueError for an unknown muscle, Q of the wrong shape (not (N, n)) or a "
           "non-finite entry.")
      .def("releases", &Releases, py::arg("muscle"), py::arg("q") = py::none(),
           "releases(muscle, q=None) -> dict\n\n"
           "Which extra transducer dof to release (CompareReleases): the baseline and every "
           "default candidate "
           "assessed, the forbidden axes and the recommendation; the keys of `isowrench releases "
           "--json` for one "
           "muscle (wrenches as {fx..mz} dicts, N and N·m; axes as numpy arrays).")
      .def("diagnose", &Diagnose, py::arg("muscle"), py::arg("q") = py::none(),
           py::arg("large_deflection") = true,
           "diagnose(muscle, q=None, large_deflection=True) -> dict\n\n"
           "DiagnoseLimb: constraint class, self-motions and internal wrenches ('constraints'), "
           "the Eq. 10 wrench "
           "and classic answer, sensitivities dW/dlog k and (optionally) the nonlinear "
           "equilibrium; the keys of "
           "`isowrench diagnose --json` for one muscle.")
      .def("__repr__", [](const PyModel& m) {
        return "<isowrench.Model '" + m.model.name() + "': " + std::to_string(m.model.dof_count()) +
               " coordinates (" + CoordinateList(m.model) + "), " +
               std::to_string(m.model.muscle_count()) + " muscles>";
      });

  mod.def("simulate", &Simulate, py::arg("model"), py::arg("path"),
          py::arg("effects") = std::vector<std::string>{}, py::arg("n") = 60, py::arg("seed") = 7,
          py::arg("noise_force") = 0.002, py::arg("noise_moment") = 5e-5,
          py::arg("joint_range") = 15.0 * 3.14159265358979323846 / 180.0,
          py::arg("muscles") = std::vector<std::string>{},
          "simulate(model, path, effects=[], n=60, seed=7, noise_force=0.002, noise_moment=5e-5, "
          "joint_range=0.2618, "
          "muscles=[]) -> str\n\n"
          "Synthetic trials (SimulateTrials, as `isowrench simulate`): n postures drawn uniformly "
          "within +- joint_range "
          "(rad) of the default posture, wrenches of the model with `effects` applied (strings "
          "'NAME=V1,V2' in the "
          "CLI's user units, e.g. 'base_isotropic=2e5'; `isowrench fit --list-effects` lists them) "
          "plus Gaussian "
          "noise (N, N·m); written as a trial CSV at `path` (the file isowrench.fit and `isowrench "
          "fit` read). "
          "Returns path. Same seed, same data.");
  mod.def("fit", &Fit, py::arg("model"), py::arg("csv"),
          py::arg("max_fit_trials") = FitOptions().max_fit_trials,
          py::arg("sample_seed") = FitOptions().sample_seed,
          "fit(model, csv, max_fit_trials=20000, sample_seed=1) -> dict\n\n"
          "FitEffectsCsv on a trial CSV (as `isowrench fit`): which unmodelled effects explain the "
          "measured wrenches. With more rows than max_fit_trials (0 = no limit) a uniform random "
          "sample of that many is fitted (reservoir sampling, sample_seed) and every row is "
          "predicted for rms_before / rms_after, in memory that does not grow with the rows. "
          "Returns {'verdict', 'verdict_message', 'effects_claimed', 'chosen': [{'id', "
          "'parameters': [{'name', "
          "'value', 'standard_error', 'unit'}]}], 'trial_count', 'fitted_trial_count', "
          "'sampling' (text), 'rms_before', 'rms_after' (6,) N "
          "and N·m, "
          "'normalized_before', 'normalized_after' (noise multiples), 'indistinguishable', "
          "'notes', 'report' (text), "
          "'seconds'}. The GIL is released while fitting.");
  mod.def("load", &Load, py::arg("path"), py::arg("clamp_body") = py::none(),
          py::arg("endpoint_body") = py::none(),
          "load(path, clamp_body=None, endpoint_body=None) -> Model\n\n"
          "Read a limb model: a URDF with isowrench extension tags, or an OpenSim .osim (then "
          "clamp_body and "
          "endpoint_body are required, as for `isowrench import`; import warnings become "
          "UserWarnings).\n"
          "Raises FileNotFoundError for a missing file and ValueError (with file and line) for a "
          "bad model.");
  auto model_class =
      py::reinterpret_borrow<py::class_<PyModel, std::shared_ptr<PyModel>>>(mod.attr("Model"));
  BindUncertainty(mod, model_class);
}
