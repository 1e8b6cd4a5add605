// Predicting trials with a model (one workspace for all trials), simulating measured data,
// residual statistics.

#include <cmath>

#include "identification/identification_impl.hpp"
#include "isowrench/error.hpp"
#include "isowrench/fast.hpp"
#include "isowrench/kinematics.hpp"
#include "util/text.hpp"

namespace isowrench {
namespace ident {

double Weight(const Trial& trial, int c, const FitOptions& options) {
  if (trial.has_sd && trial.sd[c] > 0) return 1.0 / trial.sd[c];
  return 1.0 / (c < 3 ? options.default_sd_force : options.default_sd_moment);
}

std::vector<int> JointMap(const Model& model, const std::vector<std::string>& names) {
  std::vector<int> map(names.size(), -1);
  const std::vector<std::string>& columns = model.joint_names();
  for (size_t i = 0; i < names.size(); ++i) {
    for (size_t j = 0; j < columns.size(); ++j) {
      if (columns[j] == names[i]) {
        map[i] = static_cast<int>(j);
        break;
      }
    }
  }
  return map;
}

namespace {

/// The loop over the trials of `subset` both prediction paths share: map each trial's joints and
/// muscle, then `evaluate(q, muscle_index, trial, &w)` returns "" with w set, or why the model
/// cannot predict the trial. The first failure's reason goes to `message`.
template <class Evaluate>
void PredictEach(const Model& model, const std::vector<Trial>& trials, const std::vector<int>& subset,
                 const Vector6d& sensor_offset, std::vector<Vector6d>* wrench, std::vector<bool>* ok,
                 std::string* message, Evaluate evaluate) {
  TrialMapper mapper(model);
  Eigen::VectorXd q(model.dof_count());
  Vector6d w = Vector6d::Zero();
  for (size_t k = 0; k < subset.size(); ++k) {
    const Trial& trial = trials[subset[k]];
    try {
      const int muscle_index = mapper.Map(trial, &q);
      const std::string failure = evaluate(q, muscle_index, trial, &w);
      if (!failure.empty()) {
        if (message && message->empty()) *message = "trial at line " + std::to_string(trial.line) + ": " + failure;
        continue;
      }
      (*wrench)[k] = w + sensor_offset;
      (*ok)[k] = true;
    } catch (const Error& e) {
      if (message && message->empty()) *message = e.what();
    }
  }
}

}  // namespace

TrialMapper::TrialMapper(const Model& model) : model_(&model) {}

int TrialMapper::Map(const Trial& trial, Eigen::VectorXd* q) {
  const Model& model = *model_;
  q->setZero(model.dof_count());
  if (trial.joint_names) {
    if (trial.joint_names.get() != last_names_) {
      map_ = JointMap(model, *trial.joint_names);
      last_names_ = trial.joint_names.get();
    }
    for (size_t i = 0; i < map_.size(); ++i) {
      if (map_[i] >= 0) (*q)[map_[i]] = trial.q[i];
    }
  } else if (trial.q.size() == q->size()) {
    *q = trial.q;
  } else {
    throw Error("trial at line " + std::to_string(trial.line) + " has " + std::to_string(trial.q.size()) +
                " joint values and no joint names; model has " + std::to_string(q->size()));
  }
  if (trial.muscle != last_muscle_ || muscle_index_ < 0) {
    muscle_index_ = model.MuscleIndex(trial.muscle);
    last_muscle_ = trial.muscle;
  }
  return muscle_index_;
}

void PredictSubset(const Model& model, const std::vector<Trial>& trials, const std::vector<int>& subset,
                   const Vector6d& sensor_offset, std::vector<Vector6d>* wrench, std::vector<bool>* ok,
                   std::string* message) {
  wrench->assign(subset.size(), Vector6d::Zero());
  ok->assign(subset.size(), false);
  if (model.dof_count() > kFastMaxDofs || model.dof_count() < 1) {
    // Reference path (KDL kinematics + SolveStatics): the fast path cannot compile the model.
    KinematicsWorkspace kinematics(model);
    PredictEach(model, trials, subset, sensor_offset, wrench, ok, message,
                [&](const Eigen::VectorXd& q, int muscle_index, const Trial& trial, Vector6d* w) -> std::string {
                  const StaticsResult s = EvaluateWrench(model, kinematics, q, muscle_index, trial.activation).statics;
                  if (!s.ok()) return std::string(StatusName(s.status)) + ": " + s.message;
                  *w = s.wrench;
                  return "";
                });
    return;
  }
  CompiledModel compiled(model);
  FastWorkspace ws(compiled);
  const StiffnessSet stiffness = compiled.model_stiffness();
  PredictEach(model, trials, subset, sensor_offset, wrench, ok, message,
              [&](const Eigen::VectorXd& q, int muscle_index, const Trial& trial, Vector6d* w) -> std::string {
                if (!q.allFinite() || !std::isfinite(trial.activation)) {
                  throw Error("trial at line " + std::to_string(trial.line) + ": non-finite posture or activation");
                }
                const FastWrench f = EvaluateFast(compiled, ws, q, muscle_index, stiffness, trial.activation);
                if (f.status != StaticsStatus::kOk && f.status != StaticsStatus::kSelfMotionHeld) {
                  return std::string(StatusName(f.status)) +
                         " (the model cannot hold this posture; see `isowrench wrench`)";
                }
                *w = f.wrench;
                return "";
              });
}

}  // namespace ident

Prediction PredictTrials(const Model& model, const std::vector<Trial>& trials, const Vector6d& sensor_offset) {
  std::vector<int> all(trials.size());
  for (size_t i = 0; i < trials.size(); ++i) all[i] = static_cast<int>(i);
  Prediction p;
  ident::PredictSubset(model, trials, all, sensor_offset, &p.wrench, &p.ok, &p.message);
  for (bool b : p.ok) p.failed += !b;
  return p;
}

std::vector<Trial> SimulateTrials(const Model& nominal, const AugmentedModel& truth, const SimulationOptions& o) {
  if (o.postures < 1) throw Error("simulate: --postures must be >= 1, got " + std::to_string(o.postures));
  if (!(o.noise_force >= 0) || !(o.noise_moment >= 0) || !std::isfinite(o.noise_force) ||
      !std::isfinite(o.noise_moment)) {
    throw Error("simulate: noise levels must be finite and >= 0");
  }
  if (!(o.joint_range >= 0) || !(o.prismatic_range >= 0)) throw Error("simulate: posture ranges must be >= 0");
  if (!(o.activation_min >= 0) || !(o.activation_max >= o.activation_min)) {
    throw Error("simulate: activation range must satisfy 0 <= min <= max");
  }
  Model true_model(truth.description);
  std::vector<std::string> muscles = o.muscles;
  if (muscles.empty()) {
    for (int i = 0; i < nominal.muscle_count(); ++i) muscles.push_back(nominal.muscle(i).name);
  }
  if (muscles.empty()) throw Error("simulate: model '" + nominal.name() + "' has no muscle");
  for (const std::string& m : muscles) nominal.MuscleIndex(m);
  Eigen::VectorXd center = o.center.size() ? o.center : nominal.nominal_posture();
  if (center.size() != nominal.dof_count()) throw Error("simulate: centre posture has the wrong size");
  auto names = std::make_shared<const std::vector<std::string>>(nominal.joint_names());
  ident::Random rng(o.seed);
  std::vector<Trial> trials(o.postures);
  for (int k = 0; k < o.postures; ++k) {
    Trial& t = trials[k];
    t.joint_names = names;
    t.q = center;
    for (int j = 0; j < nominal.dof_count(); ++j) {
      if (nominal.joint(j).role != JointRole::kLimb) continue;
      double r = nominal.joint(j).type == JointType::kPrismatic ? o.prismatic_range : o.joint_range;
      t.q[j] += rng.Uniform(-r, r);
    }
    t.muscle = muscles[k % muscles.size()];
    t.activation = rng.Uniform(o.activation_min, o.activation_max);
    t.line = k + 3;  // comment line + header line come first in the written file
  }
  Prediction p = PredictTrials(true_model, trials, truth.sensor_offset);
  if (p.failed) throw Error("simulate: the model with the effects cannot be evaluated: " + p.message);
  for (int k = 0; k < o.postures; ++k) {
    Trial& t = trials[k];
    t.has_sd = true;
    for (int c = 0; c < 6; ++c) {
      double sd = c < 3 ? o.noise_force : o.noise_moment;
      t.wrench[c] = p.wrench[k][c] + sd * rng.Normal();
      t.sd[c] = sd > 0 ? sd : o.sd_floor;
    }
  }
  return trials;
}

ResidualStats ComputeResidualStats(const std::vector<Trial>& trials, const std::vector<Vector6d>& predicted,
                                   int parameter_count, const FitOptions& options) {
  ResidualStats s;
  s.parameter_count = parameter_count;
  const size_t n = trials.size();
  if (n == 0 || predicted.size() != n) return s;
  Vector6d mean_measured = Vector6d::Zero();
  for (const Trial& t : trials) mean_measured += t.wrench;
  mean_measured /= static_cast<double>(n);
  Vector6d ss_res = Vector6d::Zero(), ss_tot = Vector6d::Zero(), ss_norm = Vector6d::Zero();
  for (size_t k = 0; k < n; ++k) {
    Vector6d r = trials[k].wrench - predicted[k];
    s.mean += r;
    for (int c = 0; c < 6; ++c) {
      ss_res[c] += r[c] * r[c];
      double d = trials[k].wrench[c] - mean_measured[c];
      ss_tot[c] += d * d;
      double w = ident::Weight(trials[k], c, options) * r[c];
      ss_norm[c] += w * w;
    }
  }
  s.mean /= static_cast<double>(n);
  for (int c = 0; c < 6; ++c) {
    s.rms[c] = std::sqrt(ss_res[c] / n);
    s.normalized[c] = std::sqrt(ss_norm[c] / n);
    s.r2[c] = ss_tot[c] > 0 ? 1.0 - ss_res[c] / ss_tot[c] : 0.0;
    s.chi2 += ss_norm[c];
  }
  s.residual_count = static_cast<int>(6 * n);
  int dof = s.residual_count - parameter_count;
  s.reduced_chi2 = dof > 0 ? s.chi2 / dof : 0.0;
  return s;
}

}  // namespace isowrench
