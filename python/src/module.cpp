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
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "isowrench/diagnostics.hpp"
#include "isowrench/engine.hpp"
#include "isowrench/error.hpp"
#include "isowrench/frontend.hpp"
#include "isowrench/identification.hpp"
#include "isowrench/input_checks.hpp"
#include "isowrench/kinematics.hpp"
#include "isowrench/model.hpp"
#include "isowrench/opensim.hpp"
#include "isowrench/plots.hpp"
#include "isowrench/posture.hpp"
#include "isowrench/statics.hpp"
#include "isowrench/trial_csv.hpp"
#include "isowrench/uncertainty.hpp"
#include "isowrench/wrap.hpp"
#include "isowrench/wrap_report.hpp"

namespace py = pybind11;

namespace isowrench::python {
namespace {

using CArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

[[noreturn]] void ThrowFileNotFound(const std::string& path) {
  PyErr_SetString(PyExc_FileNotFoundError, ("no such file: '" + path + "'").c_str());
  throw py::error_already_set();
}

// ---- isowrench warnings -> Python UserWarning (issue 26) ---------------------------------------
// The library reports implausible input through isowrench::Warn
// (include/isowrench/input_checks.hpp), possibly from a thread without the GIL (fit and simulate
// release it): the module's handler only queues the message, and each binding that can warn issues
// the queue as UserWarnings when it holds the GIL again (FlushWarnings), before it returns or
// raises.

std::mutex& PendingWarningsMutex() {
  static std::mutex mutex;
  return mutex;
}

std::vector<std::string>& PendingWarnings() {
  static std::vector<std::string> pending;
  return pending;
}

void QueueWarning(const std::string& message) {
  std::lock_guard<std::mutex> lock(PendingWarningsMutex());
  PendingWarnings().push_back(message);
}

/// Issue `messages` as UserWarnings (GIL held). @throws py::error_already_set when a warnings
/// filter turns one into an exception (python -W error).
void RaiseWarnings(const std::vector<std::string>& messages) {
  for (const std::string& m : messages) {
    if (PyErr_WarnEx(PyExc_UserWarning, m.c_str(), 1) < 0) throw py::error_already_set();
  }
}

void FlushWarnings() {
  std::vector<std::string> pending;
  {
    std::lock_guard<std::mutex> lock(PendingWarningsMutex());
    pending.swap(PendingWarnings());
  }
  RaiseWarnings(pending);
}

/// f(), then the queued warnings, also when f throws (the warnings first, then the error).
template <typename F>
auto Flushing(F&& f) -> decltype(f()) {
  try {
    auto result = f();
    FlushWarnings();
    return result;
  } catch (const py::error_already_set&) {
    throw;
  } catch (...) {
    FlushWarnings();
    throw;
  }
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
  if (q.is_none()) return model.nominal_posture();
  std::vector<std::pair<std::string, double>> values;
  Eigen::VectorXd all;
  if (py::isinstance<py::dict>(q)) {
    for (const auto& item : q.cast<py::dict>()) {
      values.emplace_back(py::str(item.first), item.second.cast<double>());
    }
  } else {
    CArray a = CArray::ensure(q);
    if (!a || a.ndim() != 1 || a.shape(0) != model.dof_count()) {
      throw Error("q must be None, a dict {coordinate: value} or " +
                  std::to_string(model.dof_count()) + " values in rad / m for the coordinates " +
                  CoordinateList(model));
    }
    all = Eigen::Map<const Eigen::VectorXd>(a.data(), model.dof_count());
  }
  // The library's posture from values (sizes, finiteness, plausibility): as the CLI's.
  std::vector<std::string> warnings;
  Eigen::VectorXd out = PostureFromValues(model, model.nominal_posture(), values,
                                          all.size() ? &all : nullptr, &warnings, "q");
  RaiseWarnings(warnings);
  return out;
}

/// The model with the transducer stiffness, released dofs and locked coordinates given in Python,
/// or the model itself when all are None. transducer: a preset name or 6 values (N/m, N·m/rad);
/// released: a list of dof names (x y z rx ry rz), a comma-separated string, or [] / "none" for
/// none; locked: a list of coordinate names (a comma-separated string), replacing the model's
/// locks as the CLI's --lock does ([] / "none": nothing locked).
std::shared_ptr<PyModel> Variant(const std::shared_ptr<PyModel>& m, const py::object& transducer,
                                 const py::object& released,
                                 const py::object& locked = py::none()) {
  if (transducer.is_none() && released.is_none() && locked.is_none()) return m;
  // The library's overrides (isowrench/frontend.hpp), as the CLI's --transducer,
  // --transducer-stiffness, --release and --lock.
  ModelOverrides overrides;
  if (!transducer.is_none()) {
    if (py::isinstance<py::str>(transducer)) {
      overrides.transducer_preset = transducer.cast<std::string>();
    } else {
      CArray a = CArray::ensure(transducer);
      if (!a || a.ndim() != 1 || a.shape(0) != 6) {
        throw Error(
            "transducer must be a preset name (balanced, ati-mini40, jr3) or 6 stiffnesses "
            "kx ky kz (N/m) krx kry krz (N·m/rad)");
      }
      Vector6d s;
      for (int i = 0; i < 6; ++i) s[i] = a.at(i);
      overrides.transducer_stiffness = s;
    }
  }
  if (!released.is_none()) {
    overrides.released = py::isinstance<py::str>(released)
                             ? DofMask::Parse(released.cast<std::string>())
                             : DofMask::FromNames(released.cast<std::vector<std::string>>());
  }
  if (!locked.is_none()) {
    std::vector<std::string> names;
    if (py::isinstance<py::str>(locked)) {
      // "a,b" or "a b", as the CLI's --lock.
      std::string item;
      for (char c : locked.cast<std::string>() + ",") {
        if (c == ',' || c == ' ') {
          if (!item.empty()) names.push_back(item);
          item.clear();
        } else {
          item += c;
        }
      }
      if (names.empty()) {
        throw Error("locked: an empty string (give [] or \"none\" to lock nothing)");
      }
    } else {
      names = locked.cast<std::vector<std::string>>();
    }
    overrides.locked = names;
  }
  return std::make_shared<PyModel>(
      Model(ApplyOverrides(m->model.description(), overrides, OptionStyle::kPython)), m->path);
}

std::shared_ptr<PyModel> LoadUnflushed(const std::string& path, const py::object& clamp,
                                       const py::object& endpoint, const py::object& wrap);

std::shared_ptr<PyModel> Load(const std::string& path, const py::object& clamp,
                              const py::object& endpoint, const py::object& wrap,
                              const py::object& force_model) {
  std::shared_ptr<PyModel> m = Flushing([&] { return LoadUnflushed(path, clamp, endpoint, wrap); });
  if (force_model.is_none()) return m;
  // The CLI's --force-model (ModelOverrides::force_model).
  ModelOverrides overrides;
  overrides.force_model = force_model.cast<std::string>();
  return std::make_shared<PyModel>(
      Model(ApplyOverrides(m->model.description(), overrides, OptionStyle::kPython)), m->path);
}

std::shared_ptr<PyModel> LoadUnflushed(const std::string& path, const py::object& clamp,
                                       const py::object& endpoint, const py::object& wrap) {
  if (!std::filesystem::exists(path)) ThrowFileNotFound(path);
  OpenSimImportOptions options;
  const bool osim = std::filesystem::path(path).extension() == ".osim";
  if (osim && (clamp.is_none() || endpoint.is_none())) {
    throw Error(
        "loading an OpenSim model needs clamp_body= and endpoint_body= (the bolted body and the "
        "body carrying the transducer), e.g. isowrench.load('" +
        path + "', clamp_body='pelvis', endpoint_body='tibia')");
  }
  if (osim) {
    options.clamp_body = clamp.cast<std::string>();
    options.endpoint_body = endpoint.cast<std::string>();
  }
  // The library's loader (isowrench/frontend.hpp), as the CLI's; its warnings are queued and
  // raised as UserWarnings by Load.
  // wrap= is the CLI's --wrap (ModelOverrides::wrap, applied by the library's ApplyOverrides).
  ModelOverrides overrides;
  if (!wrap.is_none()) overrides.wrap = ParseWrapMode(wrap.cast<std::string>());
  return std::make_shared<PyModel>(Model(ApplyOverrides(LoadLimb(path, osim ? &options : nullptr),
                                                        overrides, OptionStyle::kPython)),
                                   path);
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

/// JSON text from the library (the CLI prints the same text) as Python objects.
py::object JsonToPython(const std::string& text) {
  return py::module_::import("json").attr("loads")(text);
}

/// The force stage as a dict: the library's ForceStageJson (the CLI's JSON "force" objects, key
/// for key), plus "label" (ForceModelLabel).
py::dict ForceDict(const Model& model, int muscle, const MuscleForce& force, double activation) {
  py::dict d = JsonToPython(ForceStageJson(model, muscle, force, activation));
  d["label"] = ForceModelLabel(model, muscle);
  return d;
}

py::dict Kinematics(const PyModel& m, const py::object& q_arg, double activation, bool wrap_modes) {
  const Model& model = m.model;
  const Eigen::VectorXd q = Posture(model, q_arg);
  Data ws(model);
  py::dict out;
  out["q"] = Array(q);
  out["endpoint_m"] = Array(Eigen::VectorXd(EndpointPose(model, ws, q).translation()));
  out["jacobian"] = Array(Eigen::MatrixXd(EndpointJacobianWorld(model, ws, q)));
  py::dict muscles;
  for (int i = 0; i < model.muscle_count(); ++i) {
    MuscleTorque t = ComputeMuscleTorque(model, ws, q, i, activation);
    py::dict entry;
    entry["length_m"] = t.length;
    entry["moment_arm_m"] = Array(Eigen::VectorXd(-t.dL_dq.transpose()));
    entry["force"] = ForceDict(model, i, t.force_stage, activation);
    // Where a wrap misbehaves, in words (kinematics --json's "wrap_warning").
    const unsigned status =
        model.muscle(i).wraps.empty() ? 0u : MuscleWrappedPath(model, ws, q, i).status;
    if (status != 0) entry["wrap_warning"] = WrapStatusText(status);
    muscles[py::str(model.muscle(i).name)] = entry;
  }
  out["muscles"] = muscles;
  // Per wrapping muscle, how far the opensim and exact modes differ (kinematics --json's
  // "wrap_modes", the library's WrapModeJson).
  if (wrap_modes && !WrappingMuscles(model).empty()) {
    py::dict modes;
    for (const WrapModeDifference& d : CompareWrapModes(model, ws, q)) {
      modes[py::str(model.muscle(d.muscle).name)] = JsonToPython(WrapModeJson(model, d));
    }
    out["wrap_modes"] = modes;
  }
  return out;
}

/// One wrench evaluation as Python sees it.
struct PyWrench {
  WrenchEvaluation e;
  std::vector<std::string> coordinates;
  Model model;  // (shared, cheap: the force model's report)
  double activation = 1.0;
};

/// A result that exists only at an equilibrium: NaN entries without one (never zeros).
py::array_t<double> EquilibriumArray(const PyWrench& w, const Eigen::VectorXd& v) {
  if (w.e.statics.ok()) return Array(v);
  return Array(Eigen::VectorXd(
      Eigen::VectorXd::Constant(v.size(), std::numeric_limits<double>::quiet_NaN())));
}

PyWrench Wrench(const std::shared_ptr<PyModel>& m0, const std::string& muscle, const py::object& q,
                const py::object& transducer, const py::object& released, double activation,
                const py::object& locked) {
  std::shared_ptr<PyModel> m = Variant(m0, transducer, released, locked);
  return {EvaluateWrench(m->model, Posture(m->model, q), muscle, activation),
          m->model.joint_names(), m->model, activation};
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
  Eigen::VectorXd low = Eigen::VectorXd::Constant(n, std::numeric_limits<double>::infinity());
  Eigen::VectorXd high = -low;
  for (py::ssize_t r = 0; r < rows; ++r) {
    for (long c = 0; c < n; ++c) {
      const double v = data[r * n + c];
      if (!std::isfinite(v)) {
        throw Error("Q[" + std::to_string(r) + ", " + std::to_string(c) + "] (" +
                    model.joint_names()[c] + ") is " + std::to_string(v) +
                    "; postures must be finite (rad / m)");
      }
      low[c] = std::min(low[c], v);
      high[c] = std::max(high[c], v);
    }
  }
  // Plausibility per column, from its extremes (one UserWarning per column at most).
  const double limb = LimbLength(model.description());
  std::vector<std::string> warnings;
  for (long c = 0; rows > 0 && c < n; ++c) {
    const std::string where = "Q[:, " + std::to_string(c) + "]";
    std::string w = CoordinateValueWarning(model.coordinate(c), low[c], limb, where);
    if (w.empty()) w = CoordinateValueWarning(model.coordinate(c), high[c], limb, where);
    if (!w.empty()) warnings.push_back(w);
  }
  RaiseWarnings(warnings);
  return a;
}

py::object WrenchBatch(const std::shared_ptr<PyModel>& m0, const std::string& muscle,
                       const py::object& Q, double activation, const py::object& transducer,
                       const py::object& released, int threads, bool return_status,
                       const py::object& locked) {
  std::shared_ptr<PyModel> m = Variant(m0, transducer, released, locked);
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
  py::ssize_t no_equilibrium = 0;
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
      // No equilibrium (or invalid input) is never a number: NaN rows, counted for a warning.
      constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
      for (py::ssize_t p = 0; p < count; ++p) {
        const WrenchResult& r = results[static_cast<size_t>(p)];
        const bool equilibrium =
            r.status == StaticsStatus::kOk || r.status == StaticsStatus::kSelfMotionHeld;
        if (!equilibrium) ++no_equilibrium;
        for (int k = 0; k < 6; ++k) w[p * 6 + k] = equilibrium ? r.wrench[k] : kNaN;
        s[p] = static_cast<std::uint8_t>(r.status);
      }
    }
  }
  if (no_equilibrium > 0) {
    const std::string text =
        std::to_string(no_equilibrium) + " of " + std::to_string(count) + " postures of '" +
        muscle + "' have no equilibrium (the muscle drives a self-motion, or invalid input): " +
        "their rows are NaN; return_status=True says which";
    if (PyErr_WarnEx(PyExc_RuntimeWarning, text.c_str(), 1) != 0) throw py::error_already_set();
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

/// A wrench dict, or None where there is no equilibrium (never zeros).
py::object WrenchOrNone(bool valid, const Vector6d& w) {
  return valid ? py::object(WrenchDict(w)) : py::object(py::none());
}

py::dict AssessmentDict(const ReleaseAssessment& a, int grid_points) {
  const bool range = a.range_failures < grid_points;  // some grid point had an equilibrium
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
  d["equilibrium"] = a.statics.ok();
  d["wrench"] = WrenchOrNone(a.statics.ok(), a.statics.wrench);
  d["wrench_min"] = WrenchOrNone(range, a.wrench_min);
  d["wrench_max"] = WrenchOrNone(range, a.wrench_max);
  d["spread"] = a.statics.ok() ? py::object(py::float_(a.spread)) : py::object(py::none());
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

py::dict Releases(const std::shared_ptr<PyModel>& m0, const std::string& muscle,
                  const py::object& q, const py::object& transducer, const py::object& released,
                  const py::object& locked) {
  std::shared_ptr<PyModel> m = Variant(m0, transducer, released, locked);
  const ReleaseOptions options;
  const int grid_points = static_cast<int>(options.range.rotational_ratios.size() *
                                           options.range.base_stiffness.size());
  ReleaseComparison c = CompareReleases(m->model, Posture(m->model, q), muscle, {}, options);
  py::dict d;
  d["muscle"] = c.muscle;
  d["baseline"] = AssessmentDict(c.baseline, grid_points);
  py::list list;
  for (const ReleaseAssessment& a : c.candidates) list.append(AssessmentDict(a, grid_points));
  d["candidates"] = list;
  d["recommended"] =
      c.recommended >= 0
          ? py::object(py::str(c.candidates[static_cast<size_t>(c.recommended)].candidate.name))
          : py::object(py::none());
  d["release_needed"] = c.release_needed;
  d["recommendation"] = c.recommendation;
  d["length_scale_m"] = c.length_scale;
  d["locked"] = StaticsProblem(m->model).LockedNames();
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

py::dict Diagnose(const std::shared_ptr<PyModel>& m0, const std::string& muscle,
                  const py::object& q, bool large_deflection, const py::object& transducer,
                  const py::object& released, const py::object& locked) {
  std::shared_ptr<PyModel> m = Variant(m0, transducer, released, locked);
  DiagnosisOptions options;
  options.large_deflection = large_deflection;
  Diagnosis d = DiagnoseLimb(m->model, Posture(m->model, q), muscle, options);
  const ConstraintAnalysis& a = d.constraints;
  py::dict constraints;
  constraints["class"] = ConstraintClassName(a.constraint_class);
  constraints["explanation"] = a.explanation;
  constraints["joint_dofs"] = a.joint_count;
  constraints["locked"] = a.locked;
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
  out["force_model"] =
      ForceDict(m->model, m->model.MuscleIndex(e.muscle), e.force, options.activation);
  out["tau"] = Array(e.tau);
  const bool equilibrium = e.statics.ok();
  out["passive_wrench"] =
      WrenchOrNone(equilibrium && e.passive_statics.ok(), e.passive_statics.wrench);
  out["equilibrium"] = equilibrium;
  out["wrench"] = WrenchOrNone(equilibrium, e.statics.wrench);
  out["compliance_dependent"] = d.compliance_dependent;
  out["compliance_verdict"] = d.compliance_verdict;
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
  out["classic_wrench"] = WrenchOrNone(d.classic_meaningful, e.classic.wrench);
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
    // As the CLI's JSON: None where there is no equilibrium to report.
    const bool both = l.found() && equilibrium;
    auto number = [](bool valid, double v) {
      return valid ? py::object(py::float_(v)) : py::object(py::none());
    };
    ld["wrench_linear"] = WrenchOrNone(equilibrium, l.wrench_linear);
    ld["wrench_nonlinear"] = WrenchOrNone(l.found(), l.wrench_nonlinear);
    ld["wrench_relative_difference"] = number(both, l.wrench_relative_difference);
    ld["displacement"] = number(equilibrium, l.displacement);
    ld["dtheta_difference"] = number(both, l.dtheta_difference);
    ld["dtheta_nonlinear"] =
        l.found() ? py::object(Array(l.dtheta_nonlinear)) : py::object(py::none());
    ld["dtheta_linear"] = equilibrium ? py::object(Array(l.dtheta_linear)) : py::object(py::none());
    out["large_deflection"] = ld;
  }
  return out;
}

/// The sheet keywords of fit and simulate (the CLI's --delimiter, --decimal-comma,
/// --ignore-columns, --skip-rows): TrialSheetOptions.
TrialSheetOptions Sheet(const std::string& delimiter, bool decimal_comma,
                        const std::vector<std::string>& ignore_columns, int skip_rows) {
  TrialSheetOptions sheet;
  sheet.delimiter = DelimiterChar(delimiter);  // the CLI's --delimiter syntax
  sheet.decimal_comma = decimal_comma;
  sheet.ignore_columns = ignore_columns;
  sheet.skip_rows = skip_rows;
  return sheet;
}

std::string Simulate(const PyModel& m, const std::string& output,
                     const std::vector<std::string>& effects, const py::object& trials,
                     unsigned long long seed, double noise_force, double noise_moment,
                     const py::object& joint_range, const std::vector<std::string>& muscles,
                     const py::object& postures, const std::string& delimiter, bool decimal_comma,
                     const std::vector<std::string>& ignore_columns, int skip_rows) {
  SimulationOptions options;  // the CLI's defaults too (isowrench simulate)
  if (!trials.is_none()) options.postures = trials.cast<int>();
  options.seed = seed;
  options.noise_force = noise_force;
  options.noise_moment = noise_moment;
  if (!joint_range.is_none()) options.joint_range = joint_range.cast<double>();
  options.muscles = muscles;
  options.center = m.model.nominal_posture();
  if (!postures.is_none()) {
    const std::string sheet = postures.cast<std::string>();
    if (!std::filesystem::exists(sheet)) ThrowFileNotFound(sheet);
    SimulateAtPostureSheet(m.model, sheet, trials.is_none() ? 0 : options.postures,
                           !joint_range.is_none(), &options,
                           Sheet(delimiter, decimal_comma, ignore_columns, skip_rows));
  }
  Flushing([&] {
    py::gil_scoped_release release;
    SimulateToCsv(m.model, effects, options, output);
    return 0;
  });
  return output;
}

/// `isowrench fit` from Python: the CLI's options and outputs (FitOptions, the augmented URDF,
/// the HTML and markdown reports), progress lines to a callable.
py::dict Fit(const PyModel& m, const std::string& csv, int max_fit_trials,
             unsigned long long sample_seed, int rounds, int folds, int screen,
             const std::vector<std::string>& candidates, const std::string& loss, double loss_scale,
             int threads, const std::optional<std::string>& output,
             const std::optional<std::string>& report_html,
             const std::optional<std::string>& report_markdown, const py::object& progress,
             const std::string& delimiter, bool decimal_comma,
             const std::vector<std::string>& ignore_columns, int skip_rows) {
  if (!std::filesystem::exists(csv)) ThrowFileNotFound(csv);
  const TrialSheetOptions sheet = Sheet(delimiter, decimal_comma, ignore_columns, skip_rows);
  FitOptions options;
  options.max_fit_trials = max_fit_trials;
  options.sample_seed = sample_seed;
  options.max_rounds = rounds;
  options.folds = folds;
  options.screen_keep = screen;
  options.candidates = candidates;
  options.loss = ParseRobustLoss(loss);
  options.loss_scale = loss_scale;
  options.threads = threads;
  // The fit calls progress from its worker threads (serialised): each call takes the GIL. The
  // lambda holds a pointer, so the copies FitOptions makes never touch a Python reference
  // without the GIL; an exception in the callable stops its lines and is raised after the fit.
  py::function callback;
  std::exception_ptr callback_error;
  if (!progress.is_none()) {
    if (!PyCallable_Check(progress.ptr())) throw py::type_error("fit: progress must be callable");
    callback = py::reinterpret_borrow<py::function>(progress);
    py::function* f = &callback;
    std::exception_ptr* error = &callback_error;
    options.progress = [f, error](const std::string& line) {
      py::gil_scoped_acquire gil;
      if (*error) return;
      try {
        (*f)(line);
      } catch (py::error_already_set&) {
        *error = std::current_exception();
      }
    };
  }
  FitReport report;
  std::vector<Trial> fitted;
  Flushing([&] {  // the sheet's warnings become UserWarnings once the GIL is held again
    py::gil_scoped_release release;
    report = FitEffectsCsv(m.model, csv, sheet, options, nullptr, nullptr, &fitted);
    if (output) WriteAugmentedUrdf(report, *output);
    FitReportOptions report_options;
    report_options.trials = &fitted;
    report_options.model = &m.model;
    if (report_html) WriteFitReportHtml(report, *report_html, report_options);
    if (report_markdown) WriteFitReportMarkdown(report, *report_markdown, report_options);
    return 0;
  });
  if (callback_error) std::rethrow_exception(callback_error);
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
  py::list round_list;
  for (const FitRound& r : report.rounds) {
    py::list rows;
    for (const CandidateFit& c : r.candidates) {
      py::dict row;
      row["id"] = c.effect.id;
      row["k"] = c.added_parameters;
      row["delta_bic"] = c.delta_bic;
      row["screened_out"] = c.screened_out;
      row["verdict"] = c.verdict;
      rows.append(row);
    }
    py::dict round;
    round["index"] = r.index;
    round["summary"] = r.summary;
    round["chosen"] =
        r.chosen ? py::object(py::str(r.candidates[*r.chosen].effect.id)) : py::none();
    round["candidates"] = rows;
    round_list.append(round);
  }
  out["rounds"] = round_list;
  py::list levels;
  for (const FitReport::ForceLevel& l : report.trial_force_levels) {
    py::dict level;
    level["muscle"] = l.muscle;
    level["level"] = l.level;
    level["standard_error"] = l.standard_error;
    level["trials"] = l.trials;
    levels.append(level);
  }
  out["force_levels"] = levels;
  out["trial_force_spread"] = report.trial_force_spread;
  out["trial_force_spread_se"] = report.trial_force_spread_se;
  out["force_level_summary"] = report.ForceLevelSummary();
  py::list trace;
  for (const FitReport::TraceItem& i : report.trace) {
    py::dict item;
    item["variable"] = i.variable;
    item["share"] = i.share;
    item["note"] = i.note;
    trace.append(item);
  }
  out["trace"] = trace;
  out["outlier_rows"] = report.outlier_rows;
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
  if (!w.e.statics.ok()) {
    return "<isowrench.Wrench " + w.e.muscle + ": no equilibrium, status '" +
           StatusName(w.e.statics.status) + "'>";
  }
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
  CheckStaticsOptions(options.statics, OptionStyle::kPython);
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
                       int threads, double activation, double exact_percentile_values,
                       double max_endpoint_fraction, double max_joint_rotation,
                       double rank_tolerance) {
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
  options.statics.max_endpoint_fraction = max_endpoint_fraction;
  options.statics.max_joint_rotation = max_joint_rotation;
  options.statics.rank_tolerance = rank_tolerance;
  CheckStaticsOptions(options.statics, OptionStyle::kPython);
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
          py::arg("max_endpoint_fraction") = StaticsOptions{}.max_endpoint_fraction,
          py::arg("max_joint_rotation") = StaticsOptions{}.max_joint_rotation,
          py::arg("rank_tolerance") = StaticsOptions{}.rank_tolerance,
          R"(uncertainty(muscle=None, inputs=None, spec=None, from_fit=None, q=None, postures=None, samples=4096, seed=1, sobol=True, threads=0, activation=1.0, exact_percentile_values=2e7, max_endpoint_fraction=0.001, max_joint_rotation=0.01, rank_tolerance=1e-12) -> dict

Monte Carlo uncertainty of the wrench, the dict of `isowrench uncertainty --json`. inputs: strings in the CLI's syntax ('angle:hip_rz=normal:2', 'point:GP:0=normal:1' (a muscle path point, mm), degrees and mm as on the command line) or dicts like the spec file's entries; spec: a spec file path or dict; from_fit: an `isowrench fit --json` file. q: one posture (rad / m, or a dict), or postures (P, n). max_endpoint_fraction, max_joint_rotation (rad) and rank_tolerance are the CLI's --max-endpoint-fraction, --max-joint-rotation, --rank-tolerance (the small-motion rule and the rank of K). The same seed gives the same numbers on any thread count (threads=0: every core). The GIL is released. isowrench.study runs the same study on Dask.
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

  SetWarningHandler(QueueWarning);  // isowrench::Warn -> UserWarning (FlushWarnings)
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
          [](const PyWrench& w) {
            return EquilibriumArray(w, Eigen::VectorXd(w.e.statics.wrench));
          },
          "(6,) [fx fy fz mx my mz] in the transducer's axes (N, N·m); released rows are 0; NaN "
          "when there is no equilibrium (status 'self-motion' or 'invalid input').")
      .def_property_readonly(
          "passive",
          [](const PyWrench& w) {
            if (w.e.statics.ok() && w.e.passive_statics.ok()) {
              return Array(Eigen::VectorXd(w.e.passive_statics.wrench));
            }
            return Array(Eigen::VectorXd(
                Eigen::VectorXd::Constant(6, std::numeric_limits<double>::quiet_NaN())));
          },
          "(6,) the passive wrench: the same posture at activation 0 (a force model's passive "
          "force, its minimum_activation floor included), transducer axes (N, N·m); the "
          "pre-stimulus baseline a lab subtracts. 0 for a constant-force muscle; NaN without "
          "equilibrium.")
      .def_property_readonly(
          "force",
          [](const PyWrench& w) {
            return ForceDict(w.model, w.model.MuscleIndex(w.e.muscle), w.e.force, w.activation);
          },
          "The force stage (dict, the CLI JSON's 'force_model'): 'model', 'tendon', 'label', "
          "'force_n', 'active_force_n', 'passive_force_n', 'fiber_length_m', 'pennation_rad', "
          "'tendon_strain', 'status', 'opensim_gives_no_number' (and 'opensim_note').")
      .def_property_readonly(
          "passive_force",
          [](const PyWrench& w) {
            return ForceDict(w.model, w.model.MuscleIndex(w.e.muscle), w.e.passive_force, 0.0);
          },
          "The force stage at activation 0 (dict, as force).")
      .def_property_readonly(
          "world",
          [](const PyWrench& w) { return EquilibriumArray(w, Eigen::VectorXd(w.e.wrench_world)); },
          "(6,) the same wrench in world axes (N, N·m); NaN without equilibrium.")
      .def_property_readonly(
          "equilibrium", [](const PyWrench& w) { return w.e.statics.ok(); },
          "True when the statics has an equilibrium (status 'ok' or 'self-motion (not "
          "excited)'); False: the wrench, world and dtheta are NaN.")
      .def_property_readonly(
          "classic", [](const PyWrench& w) { return Array(Eigen::VectorXd(w.e.classic.wrench)); },
          "(6,) the classic answer without compliance, J^-T tau (Eq. 11) or pinv(J^T) tau (Eq. "
          "15), transducer axes (N, N·m).")
      .def_property_readonly(
          "dtheta", [](const PyWrench& w) { return EquilibriumArray(w, w.e.statics.dtheta); },
          "(n,) equilibrium displacement K^+ tau per coordinate (rad, or m for prismatic ones); "
          "0 on locked coordinates, NaN without equilibrium.")
      .def_property_readonly(
          "locked",
          [](const PyWrench& w) {
            std::vector<std::string> out;
            for (size_t i = 0; i < w.e.locked.size(); ++i)
              if (w.e.locked[i]) out.push_back(w.coordinates[i]);
            return out;
          },
          "Names of the locked coordinates (held rigid: no dof of the statics, dtheta 0), as the "
          "CLI's JSON \"locked\".")
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
          "is NaN) or 'invalid input'.")
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
          "wrap",
          [](const PyModel& m) {
            return std::string(WrapModeName(m.model.description().wrap_mode));
          },
          "How wrapping muscles get lengths and moment arms: 'opensim' or 'exact' (load(wrap=), "
          "with_overrides(wrap=)).")
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
          "Leg length (m): from the first joint centre through each joint centre to the endpoint "
          "at the default posture (hip, knee, ankle for a hindlimb); the small-motion limit and "
          "the diagnostics' length scale.")
      .def_property_readonly(
          "locked", [](const PyModel& m) { return StaticsProblem(m.model).LockedNames(); },
          "Locked coordinates (held rigid by the statics; a URDF's locked=\"true\", or the "
          "locked= argument).")
      .def("kinematics", &Kinematics, py::arg("q") = py::none(), py::arg("activation") = 1.0,
           py::arg("wrap_modes") = true,
           R"(kinematics(q=None, activation=1.0, wrap_modes=True) -> dict

Endpoint position, endpoint Jacobian and every muscle's length, moment arm and force at posture q
(None: the default posture; n values in rad / m; or a dict {coordinate: value} over the default
posture).
Returns {'q': (n,), 'endpoint_m': (3,) world position (m), 'jacobian': (6, n) world axes, rows
vx vy vz (m/rad) wx wy wz (rad/rad), 'muscles': {name: {'length_m': float, 'moment_arm_m': (n,)
-dL/dq, 'force': dict (the force stage at `activation`), 'wrap_warning': str (only where a wrap of
the muscle misbehaves)}}, 'wrap_modes': {name: {'length_opensim_m', 'length_exact_m',
'length_difference_mm', 'moment_arm_difference_mm', 'moment_arm_difference_coordinate',
'wraps_engaged', 'opensim_misbehaves'}} (per wrapping muscle, how far the opensim and exact wrap
modes differ; only when the model has wrapping muscles and wrap_modes is True)}: the same numbers
and keys as `isowrench kinematics --json` (wrap_modes=False: its --no-wrap-modes).
Raises ValueError for a bad posture.)")
      .def("wrench", &Wrench, py::arg("muscle"), py::arg("q") = py::none(),
           py::arg("transducer") = py::none(), py::arg("released") = py::none(),
           py::arg("activation") = 1.0, py::arg("locked") = py::none(),
           "wrench(muscle, q=None, transducer=None, released=None, activation=1.0, locked=None) "
           "-> Wrench\n\n"
           "The Eq. 10 wrench muscle `muscle` applies through the limb to the transducer at "
           "posture q (None: default "
           "posture; n values in rad / m; or a dict {coordinate: value}). transducer: None (the "
           "model's S_t), a "
           "preset name ('balanced', 'ati-mini40', 'jr3') or 6 stiffnesses (N/m, N·m/rad); "
           "released: None (the "
           "model's), a list of dof names among x y z rx ry rz, or [] for none. activation scales "
           "the force "
           "(F = activation x max_force). locked: None (the model's locks) or the coordinates to "
           "hold rigid, replacing the model's ([] for none), as the CLI's --lock. Same numbers as "
           "`isowrench wrench --json`.\n"
           "Raises ValueError for an unknown muscle, a bad posture or bad stiffnesses.")
      .def("wrench_batch", &WrenchBatch, py::arg("muscle"), py::arg("Q"),
           py::arg("activation") = 1.0, py::arg("transducer") = py::none(),
           py::arg("released") = py::none(), py::arg("threads") = 0,
           py::arg("return_status") = false, py::arg("locked") = py::none(),
           "wrench_batch(muscle, Q, activation=1.0, transducer=None, released=None, threads=0, "
           "return_status=False, locked=None)"
           " -> ndarray (N, 6)\n\n"
           "The Eq. 10 wrench at every posture (row) of Q (N, n) in rad / m: row i = [fx fy fz mx "
           "my mz] (N, N·m) in "
           "transducer axes, equal to wrench(muscle, Q[i]).transducer to rounding. Runs the C++ "
           "batch kernel with "
           "the GIL released on `threads` threads (0: every core). Rows without equilibrium are "
           "NaN (a RuntimeWarning says how many); with "
           "return_status=True a uint8 status array (N,) is returned too, indexing "
           "isowrench.STATUS_NAMES.\n"
           "Raises ValueError for an unknown muscle, Q of the wrong shape (not (N, n)) or a "
           "non-finite entry.")
      .def("releases", &Releases, py::arg("muscle"), py::arg("q") = py::none(),
           py::arg("transducer") = py::none(), py::arg("released") = py::none(),
           py::arg("locked") = py::none(),
           "releases(muscle, q=None, transducer=None, released=None, locked=None) -> dict\n\n"
           "Which extra transducer dof to release (CompareReleases): the baseline and every "
           "default candidate "
           "assessed, the forbidden axes and the recommendation; the keys of `isowrench releases "
           "--json` for one "
           "muscle (wrenches as {fx..mz} dicts, N and N·m, None without equilibrium; axes as numpy "
           "arrays). transducer, released and locked as for wrench().")
      .def("diagnose", &Diagnose, py::arg("muscle"), py::arg("q") = py::none(),
           py::arg("large_deflection") = true, py::arg("transducer") = py::none(),
           py::arg("released") = py::none(), py::arg("locked") = py::none(),
           "diagnose(muscle, q=None, large_deflection=True, transducer=None, released=None, "
           "locked=None) -> dict\n\n"
           "DiagnoseLimb: constraint class, self-motions and internal wrenches ('constraints'), "
           "the Eq. 10 wrench "
           "and classic answer, sensitivities dW/dlog k and (optionally) the nonlinear "
           "equilibrium; the keys of "
           "`isowrench diagnose --json` for one muscle (wrenches None without equilibrium). "
           "transducer, released and locked as for wrench().")
      .def(
          "with_overrides",
          [](const std::shared_ptr<PyModel>& m, const py::object& released,
             const py::object& transducer, const py::object& base_stiffness,
             const std::map<std::string, double>& joint_stiffness, const py::object& locked,
             const py::object& wrap, const py::object& force_model) {
            // The library's overrides (isowrench/frontend.hpp ApplyOverrides), as the CLI's
            // --release, --transducer(-stiffness), --base-stiffness, --joint-stiffness and
            // --lock (last, as the CLI applies it, so that it can name the base dofs).
            std::shared_ptr<PyModel> v = Variant(m, transducer, released);
            ModelOverrides overrides;
            if (!base_stiffness.is_none()) overrides.base_stiffness = base_stiffness.cast<double>();
            if (!wrap.is_none()) overrides.wrap = ParseWrapMode(wrap.cast<std::string>());
            for (const auto& [joint, k] : joint_stiffness) {
              overrides.joint_stiffness.emplace_back(joint, k);
            }
            if (!force_model.is_none()) overrides.force_model = force_model.cast<std::string>();
            if (!overrides.empty()) {
              v = std::make_shared<PyModel>(
                  Model(ApplyOverrides(v->model.description(), overrides, OptionStyle::kPython)),
                  m->path);
            }
            return Variant(v, py::none(), py::none(), locked);
          },
          py::arg("released") = py::none(), py::arg("transducer") = py::none(),
          py::arg("base_stiffness") = py::none(),
          py::arg("joint_stiffness") = std::map<std::string, double>{},
          py::arg("locked") = py::none(), py::arg("wrap") = py::none(),
          py::arg("force_model") = py::none(),
          "with_overrides(released=None, transducer=None, base_stiffness=None, "
          "joint_stiffness={}, locked=None, wrap=None, force_model=None) -> Model\n\n"
          "force_model: 'model' (each muscle's own), 'constant' (F = a x max_force, the "
          "paper's) or 'rigid' (each muscle's curves with a rigid tendon), as --force-model.\n"
          "A new Model with the overrides the CLI's --release, --transducer / "
          "--transducer-stiffness, --base-stiffness (N/m; inserts base_x/y/z when the limb has "
          "none), --joint-stiffness {coordinate: N·m/rad or N/m}, --lock [coordinates] and "
          "--wrap ('opensim' or 'exact': how wrapping muscles get lengths and moment arms) apply, "
          "through the same "
          "library function (ApplyOverrides). The model itself is unchanged.\n"
          "Raises ValueError naming the keyword and the value (a negative or huge stiffness, an "
          "unknown coordinate).")
      .def("__repr__", [](const PyModel& m) {
        return "<isowrench.Model '" + m.model.name() + "': " + std::to_string(m.model.dof_count()) +
               " coordinates (" + CoordinateList(m.model) + "), " +
               std::to_string(m.model.muscle_count()) + " muscles>";
      });

  const SimulationOptions defaults;  // the library's, which the CLI's simulate uses too
  mod.def("simulate", &Simulate, py::arg("model"), py::arg("path"),
          py::arg("effects") = std::vector<std::string>{}, py::arg("trials") = py::none(),
          py::arg("seed") = defaults.seed, py::arg("noise_force") = defaults.noise_force,
          py::arg("noise_moment") = defaults.noise_moment, py::arg("joint_range") = py::none(),
          py::arg("muscles") = std::vector<std::string>{}, py::arg("postures") = py::none(),
          py::arg("delimiter") = ",", py::arg("decimal_comma") = false,
          py::arg("ignore_columns") = std::vector<std::string>{}, py::arg("skip_rows") = 0,
          "simulate(model, path, effects=[], trials=None, seed=1, noise_force=0.002, "
          "noise_moment=5e-5, joint_range=None, muscles=[], postures=None, delimiter=',', "
          "decimal_comma=False, ignore_columns=[], skip_rows=0) -> str\n\n"
          "Synthetic trials (SimulateToCsv, as `isowrench simulate`, with its defaults: trials "
          "None = 50, joint_range None = 0.2618 rad): trials "
          "postures drawn uniformly within +- joint_range "
          "(rad) of the default posture, wrenches of the model with `effects` applied (strings "
          "'NAME=V1,V2' in the "
          "CLI's user units, e.g. 'base_isotropic=2e5'; `isowrench fit --list-effects` lists them) "
          "plus Gaussian "
          "noise (N, N·m); written as a trial CSV at `path` (the file isowrench.fit and `isowrench "
          "fit` read). With postures= (a posture sheet, e.g. from `isowrench design -o`; "
          "simulate --postures) the trials are at its rows, with their muscles and activations "
          "(one per row unless trials=, exactly unless joint_range=). "
          "Returns path. Same seed, same data.");
  mod.def(
      "fit", &Fit, py::arg("model"), py::arg("csv"),
      py::arg("max_fit_trials") = FitOptions().max_fit_trials,
      py::arg("sample_seed") = FitOptions().sample_seed,
      py::arg("rounds") = FitOptions().max_rounds, py::arg("folds") = FitOptions().folds,
      py::arg("screen") = FitOptions().screen_keep,
      py::arg("candidates") = std::vector<std::string>{}, py::arg("loss") = "huber",
      py::arg("loss_scale") = FitOptions().loss_scale, py::arg("threads") = 0,
      py::arg("output") = py::none(), py::arg("report") = py::none(),
      py::arg("report_md") = py::none(), py::arg("progress") = py::none(),
      py::arg("delimiter") = ",", py::arg("decimal_comma") = false,
      py::arg("ignore_columns") = std::vector<std::string>{}, py::arg("skip_rows") = 0,
      R"(fit(model, csv, max_fit_trials=20000, sample_seed=1, rounds=3, folds=5, screen=8, candidates=[], loss="huber", loss_scale=2.0, threads=0, output=None, report=None, report_md=None, progress=None, delimiter=",", decimal_comma=False, ignore_columns=[], skip_rows=0) -> dict

FitEffectsCsv on a trial CSV, as `isowrench fit` with the same options: rounds (--rounds, most
effects added), folds (--folds), screen (--screen, candidates fitted per round, 0 = all),
candidates (--candidates, effect ids; [] = the whole library), loss ("huber", "cauchy", "none")
and loss_scale (--loss, --loss-scale), threads (--threads, 0 = every core). With more rows than
max_fit_trials (0 = no limit) a uniform random sample is fitted (reservoir sampling,
sample_seed) and every row is predicted for rms_before / rms_after. Outputs as the CLI's: output
(-o, the augmented URDF), report (--report, HTML) and report_md (--report-md). progress: a
callable given each progress line of the fit (the CLI's stderr lines: rounds, every candidate
fit, cross-validation, trace); it is called with the GIL held, from the fit's threads, one line
at a time; an exception it raises stops its lines and is raised when the fit ends. The sheet
keywords are the CLI's --delimiter (',', ';', '\t' or '|'), --decimal-comma, --ignore-columns
and --skip-rows (TrialSheetOptions); units in the header ('fx (N)', 'mx (N·mm)', 'hip_rz (rad)')
or a units row are read and converted.
Returns {'verdict', 'verdict_message', 'effects_claimed', 'chosen': [{'id', 'parameters':
[{'name', 'value', 'standard_error', 'unit'}]}], 'rounds': [{'index', 'summary', 'chosen',
'candidates': [{'id', 'k', 'delta_bic', 'screened_out', 'verdict'}]}], 'force_levels':
[{'muscle', 'level', 'standard_error', 'trials'}], 'trial_force_spread',
'trial_force_spread_se', 'force_level_summary', 'trace': [{'variable', 'share', 'note'}],
'outlier_rows', 'trial_count', 'fitted_trial_count', 'sampling', 'rms_before', 'rms_after'
(6,) N and N·m, 'normalized_before', 'normalized_after' (noise multiples),
'indistinguishable', 'notes', 'report' (text), 'seconds'}. The GIL is released while fitting.
Raises ValueError for bad options (a negative count, an unknown loss or effect id) or data.)");
  mod.def("load", &Load, py::arg("path"), py::arg("clamp_body") = py::none(),
          py::arg("endpoint_body") = py::none(), py::arg("wrap") = py::none(),
          py::arg("force_model") = py::none(),
          "load(path, clamp_body=None, endpoint_body=None, wrap=None, force_model=None) -> "
          "Model\n\n"
          "force_model: the CLI's --force-model, 'model' (each muscle's own, the default), "
          "'constant' (F = a x max_force) or 'rigid' (each muscle's curves, rigid tendon).\n"
          "Read a limb model: a URDF with isowrench extension tags, or an OpenSim .osim (then "
          "clamp_body and "
          "endpoint_body are required, as for `isowrench import`; import warnings become "
          "UserWarnings). wrap: 'opensim' (OpenSim 4.x's wrapping algorithms and moment arms) or "
          "'exact' (shortest paths, moment arm = -dL/dq), the CLI's --wrap; default: the URDF's "
          "isowrench:wrap_mode, else 'opensim'.\n"
          "Raises FileNotFoundError for a missing file and ValueError (with file and line) for a "
          "bad model.");
  auto model_class =
      py::reinterpret_borrow<py::class_<PyModel, std::shared_ptr<PyModel>>>(mod.attr("Model"));
  BindUncertainty(mod, model_class);
}
