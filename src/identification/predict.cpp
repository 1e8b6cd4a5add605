// Predicting trials with a model (one workspace for all trials), simulating measured data,
// residual statistics.

#include <algorithm>
#include <cmath>
#include <limits>
#include <tuple>

#include "identification/identification_impl.hpp"
#include "isowrench/engine.hpp"
#include "isowrench/error.hpp"
#include "isowrench/kinematics.hpp"
#include "isowrench/statics.hpp"
#include "isowrench/trial_csv.hpp"
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
/// muscle (plus the posture offsets), then `evaluate(q, muscle_index, activation, &w)` returns ""
/// with w set, or why the model cannot predict the trial. The first failure goes to raw->message.
template <class Evaluate>
void EvaluateEach(const Model& model, const std::map<std::string, double>& posture_offset,
                  const std::vector<Trial>& trials, const std::vector<int>& subset,
                  RawWrenches* raw, Evaluate evaluate) {
  TrialMapper mapper(model);
  Eigen::VectorXd q(model.dof_count());
  std::vector<std::pair<int, double>> offsets;
  for (const auto& o : posture_offset) offsets.emplace_back(model.JointIndex(o.first), o.second);
  const std::vector<int>& other_index = raw->other_index;
  Vector6d w = Vector6d::Zero();
  for (size_t k = 0; k < subset.size(); ++k) {
    const Trial& trial = trials[subset[k]];
    try {
      const int muscle_index = mapper.Map(trial, &q);
      raw->muscle[k] = muscle_index;
      for (const auto& o : offsets) q[o.first] += o.second;
      std::string failure = evaluate(q, muscle_index, trial.activation, &w);
      if (failure.empty()) raw->own[k] = w;
      // The pre-stimulus (activation 0) wrench, where a force model makes one.
      if (failure.empty() && !raw->passive.empty() && muscle_index >= 0 &&
          model.muscle(muscle_index).force.model != ForceModelType::kConstant) {
        failure = evaluate(q, muscle_index, 0.0, &w);
        if (!failure.empty()) failure = "at activation 0 (the passive wrench): " + failure;
        raw->passive[k] = w;
      }
      for (size_t i = 0; i < other_index.size() && failure.empty(); ++i) {
        if (other_index[i] == muscle_index) continue;
        failure = evaluate(q, other_index[i], 1.0, &w);
        raw->other[i][k] = w;
      }
      if (!failure.empty()) {
        if (raw->message.empty())
          raw->message = "trial at line " + std::to_string(trial.line) + ": " + failure;
        continue;
      }
      raw->ok[k] = true;
    } catch (const Error& e) {
      if (raw->message.empty()) raw->message = e.what();
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
    throw Error("trial at line " + std::to_string(trial.line) + " has " +
                std::to_string(trial.q.size()) + " joint values and no joint names; model has " +
                std::to_string(q->size()));
  }
  if (trial.muscle != last_muscle_ || muscle_index_ < 0) {
    muscle_index_ = model.MuscleIndex(trial.muscle);
    last_muscle_ = trial.muscle;
  }
  return muscle_index_;
}

bool RawWrenches::all_ok() const { return std::find(ok.begin(), ok.end(), false) == ok.end(); }

RawWrenches EvaluateRaw(const Model& model, const std::map<std::string, double>& posture_offset,
                        const std::vector<std::string>& others, const std::vector<Trial>& trials,
                        const std::vector<int>& subset, bool passive) {
  RawWrenches raw;
  raw.others = others;
  for (const std::string& m : others) raw.other_index.push_back(model.MuscleIndex(m));
  raw.muscle.assign(subset.size(), -1);
  raw.own.assign(subset.size(), Vector6d::Zero());
  raw.other.assign(others.size(), std::vector<Vector6d>(subset.size(), Vector6d::Zero()));
  raw.ok.assign(subset.size(), false);
  if (passive) raw.passive.assign(subset.size(), Vector6d::Zero());
  for (int i = 0; i < model.muscle_count(); ++i) raw.max_force.push_back(model.muscle(i).max_force);
  Data ws(model);
  const StiffnessSet stiffness = model.model_stiffness();
  EvaluateEach(model, posture_offset, trials, subset, &raw,
               [&](const Eigen::VectorXd& q, int muscle_index, double activation,
                   Vector6d* w) -> std::string {
                 if (!q.allFinite() || !std::isfinite(activation))
                   return "non-finite posture or activation";
                 const WrenchResult f = Evaluate(model, ws, q, muscle_index, stiffness, activation);
                 if (f.status != StaticsStatus::kOk && f.status != StaticsStatus::kSelfMotionHeld) {
                   return std::string(StatusName(f.status)) +
                          " (the model cannot hold this posture; see `isowrench wrench`)";
                 }
                 *w = f.wrench;
                 return "";
               });
  return raw;
}

std::vector<std::string> CoactivatedMuscles(const AugmentedModel& model) {
  std::vector<std::string> out;
  for (const auto& c : model.coactivation) out.push_back(c.first);
  return out;
}

void ComposeReadings(const AugmentedModel& model, const std::vector<Trial>& trials,
                     const std::vector<int>& subset, const RawWrenches& raw,
                     const FitOptions& options, std::vector<Vector6d>* readings,
                     std::vector<double>* factors, std::vector<Vector6d>* unit,
                     std::vector<Vector6d>* passive_readings) {
  const std::vector<MuscleSpec>& muscles = model.description.muscles;
  // Force ratio per muscle index: the description's max force over the one evaluated (the
  // evaluated model was built from a description with the same muscles in the same order).
  std::vector<double> ratio(muscles.size(), 1.0);
  for (size_t i = 0; i < muscles.size() && i < raw.max_force.size(); ++i) {
    if (raw.max_force[i] > 0) ratio[i] = muscles[i].max_force / raw.max_force[i];
  }
  // (index in raw.others, its muscle index, fraction x ratio)
  std::vector<std::tuple<int, int, double>> coactivation;
  for (const auto& c : model.coactivation) {
    auto it = std::find(raw.others.begin(), raw.others.end(), c.first);
    if (it == raw.others.end())
      throw Error("coactivation of '" + c.first + "': its wrench was not evaluated");
    const int i = static_cast<int>(it - raw.others.begin());
    const int m = raw.other_index[i];
    coactivation.emplace_back(
        i, m, c.second * (m >= 0 && m < static_cast<int>(ratio.size()) ? ratio[m] : 1.0));
  }
  readings->assign(subset.size(), Vector6d::Zero());
  if (factors) factors->assign(subset.size(), 1.0);
  if (passive_readings) passive_readings->assign(subset.size(), Vector6d::Zero());
  const Eigen::Vector3d d = model.sensor_origin;
  const bool calibrated = !model.calibration.isIdentity(0.0);
  // Without per-trial factors the readings are written directly (the fit predicts every
  // trial once per residual evaluation: no further buffers of its size).
  const bool per_trial = model.trial_force;
  std::vector<double> factor_of(per_trial ? subset.size() : 0, 1.0);
  std::vector<Vector6d> own_force;
  std::vector<Vector6d>& force = per_trial ? own_force : *readings;
  // Per trial: the part of the reading its factor does not scale (the passive wrench).
  std::vector<Vector6d> unscaled;
  if (per_trial) {
    own_force.assign(subset.size(), Vector6d::Zero());
    unscaled.assign(subset.size(), Vector6d::Zero());
  }
  // A wrench at the transducer's origin in its axes -> the reading (sensor origin,
  // calibration).
  auto to_reading = [&](Vector6d w) {
    if (d.squaredNorm() > 0) w.tail<3>() -= d.cross(Eigen::Vector3d(w.head<3>()));
    if (calibrated) w = model.calibration * w;
    return w;
  };
  for (size_t k = 0; k < subset.size(); ++k) {
    if (!raw.ok[k]) continue;
    const Trial& trial = trials[subset[k]];
    const int muscle = raw.muscle[k];
    const double own_ratio =
        muscle >= 0 && muscle < static_cast<int>(ratio.size()) ? ratio[muscle] : 1.0;
    Vector6d w = raw.own[k] * own_ratio;
    for (const auto& c : coactivation) {
      if (std::get<1>(c) != muscle) w += std::get<2>(c) * raw.other[std::get<0>(c)][k];
    }
    w = to_reading(w);
    const Vector6d passive =
        raw.passive.empty() ? Vector6d::Zero() : to_reading(raw.passive[k] * own_ratio);
    if (passive_readings) (*passive_readings)[k] = passive;
    if (per_trial) {
      unscaled[k] = passive;
      w -= passive;
      // Closed form: the factor minimising
      // sum_c (weight_c (measured_c - offset_c - passive_c - factor w_c))^2.
      double num = 0, den = 0;
      for (int c = 0; c < 6; ++c) {
        const double weight2 = std::pow(Weight(trial, c, options), 2);
        num += weight2 * w[c] * (trial.wrench[c] - model.sensor_offset[c] - unscaled[k][c]);
        den += weight2 * w[c] * w[c];
      }
      if (den > 0 && std::isfinite(num / den)) factor_of[k] = num / den;
    }
    force[k] = w;
  }
  if (!per_trial) {
    if (unit) *unit = *readings;
    if (model.sensor_offset.squaredNorm() > 0) {
      for (size_t k = 0; k < subset.size(); ++k) {
        if (raw.ok[k]) (*readings)[k] += model.sensor_offset;
      }
    }
    return;
  }
  // With a robust loss, a row that stays beyond the outlier threshold even with its own factor
  // is an outlier, not a force variation: it gets the median factor (so per-trial factors do
  // not buy cost reductions on gross outliers).
  if (model.trial_force && options.loss != RobustLoss::kNone) {
    std::vector<double> sorted;
    for (size_t k = 0; k < subset.size(); ++k) {
      if (raw.ok[k]) sorted.push_back(factor_of[k]);
    }
    if (!sorted.empty()) {
      std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
      const double median = sorted[sorted.size() / 2];
      for (size_t k = 0; k < subset.size(); ++k) {
        const Trial& trial = trials[subset[k]];
        double s = 0;
        for (int c = 0; c < 6; ++c) {
          s += std::pow(Weight(trial, c, options) * (trial.wrench[c] - model.sensor_offset[c] -
                                                     unscaled[k][c] - factor_of[k] * force[k][c]),
                        2);
        }
        if (std::sqrt(s / 6.0) > options.outlier_threshold) factor_of[k] = median;
      }
    }
  }
  if (unit) *unit = force;
  for (size_t k = 0; k < subset.size(); ++k) {
    if (!raw.ok[k]) continue;
    if (factors) (*factors)[k] = factor_of[k];
    (*readings)[k] = factor_of[k] * force[k] + unscaled[k] + model.sensor_offset;
  }
}

void PredictSubset(const Model& model, const std::vector<Trial>& trials,
                   const std::vector<int>& subset, const Vector6d& sensor_offset,
                   std::vector<Vector6d>* wrench, std::vector<bool>* ok, std::string* message) {
  RawWrenches raw = EvaluateRaw(model, {}, {}, trials, subset);
  wrench->assign(subset.size(), Vector6d::Zero());
  for (size_t k = 0; k < subset.size(); ++k) {
    if (raw.ok[k]) (*wrench)[k] = raw.own[k] + sensor_offset;
  }
  *ok = raw.ok;
  if (message) *message = raw.message;
}

Eigen::VectorXd NominalJacobianColumn(const Model& model, const std::string& joint) {
  Data ws(model);
  Matrix6Xd J = EndpointJacobian(model, ws, model.nominal_posture());
  return J.col(model.JointIndex(joint));
}

std::vector<double> MuscleLengths(const Model& model, const std::string& muscle,
                                  const std::vector<Trial>& trials, std::string* failure) {
  std::vector<double> out(trials.size(), std::numeric_limits<double>::quiet_NaN());
  Data ws(model);
  TrialMapper mapper(model);
  Eigen::VectorXd q(model.dof_count());
  int index = -1;
  try {
    index = model.MuscleIndex(muscle);
  } catch (const Error& e) {
    if (failure) *failure = e.what();
    return out;
  }
  for (size_t k = 0; k < trials.size(); ++k) {
    try {
      mapper.Map(trials[k], &q);
      out[k] = ComputeMuscleTorque(model, ws, q, index, 1.0).length;
    } catch (const Error& e) {
      // NaN: the trial is left out of this muscle's length trend; the caller counts it.
      if (failure && failure->empty())
        *failure = "trial at line " + std::to_string(trials[k].line) + ": " + e.what();
    }
  }
  return out;
}

double ResidualAccumulator::Add(const Trial& trial, const Vector6d& predicted,
                                const FitOptions& options) {
  ++n_;
  const Vector6d r = trial.wrench - predicted;
  sum_ += r;
  const Vector6d d = trial.wrench - mean_measured_;
  mean_measured_ += d / static_cast<double>(n_);
  double norm2 = 0.0;
  for (int c = 0; c < 6; ++c) {
    ss_res_[c] += r[c] * r[c];
    ss_tot_[c] += d[c] * (trial.wrench[c] - mean_measured_[c]);
    const double w = Weight(trial, c, options) * r[c];
    ss_norm_[c] += w * w;
    norm2 += w * w;
  }
  return std::sqrt(norm2 / 6);
}

ResidualStats ResidualAccumulator::Result(int parameter_count) const {
  ResidualStats s;
  s.parameter_count = parameter_count;
  if (n_ == 0) return s;
  const double n = static_cast<double>(n_);
  s.mean = sum_ / n;
  for (int c = 0; c < 6; ++c) {
    s.rms[c] = std::sqrt(ss_res_[c] / n);
    s.normalized[c] = std::sqrt(ss_norm_[c] / n);
    s.r2[c] = ss_tot_[c] > 0 ? 1.0 - ss_res_[c] / ss_tot_[c] : 0.0;
    s.chi2 += ss_norm_[c];
  }
  s.residual_count = static_cast<int>(std::min<long>(6 * n_, std::numeric_limits<int>::max()));
  const double dof = 6.0 * n - parameter_count;
  s.reduced_chi2 = dof > 0 ? s.chi2 / dof : 0.0;
  return s;
}

}  // namespace ident

Prediction PredictTrials(const Model& model, const std::vector<Trial>& trials,
                         const Vector6d& sensor_offset) {
  std::vector<int> all(trials.size());
  for (size_t i = 0; i < trials.size(); ++i) all[i] = static_cast<int>(i);
  Prediction p;
  ident::PredictSubset(model, trials, all, sensor_offset, &p.wrench, &p.ok, &p.message);
  for (bool b : p.ok) p.failed += !b;
  return p;
}

Prediction PredictTrials(const AugmentedModel& model, const std::vector<Trial>& trials,
                         std::vector<double>* factors) {
  std::vector<int> all(trials.size());
  for (size_t i = 0; i < trials.size(); ++i) all[i] = static_cast<int>(i);
  Model built(model.description);
  ident::RawWrenches raw =
      ident::EvaluateRaw(built, model.posture_offset, ident::CoactivatedMuscles(model), trials, all,
                         model.trial_force);
  Prediction p;
  ident::ComposeReadings(model, trials, all, raw, FitOptions(), &p.wrench, factors);
  p.ok = raw.ok;
  p.message = raw.message;
  for (bool b : p.ok) p.failed += !b;
  return p;
}

void ForEachSimulatedTrial(const Model& nominal, const AugmentedModel& truth,
                           const SimulationOptions& o,
                           const std::function<void(const Trial&)>& on_trial,
                           const TrialProgress& progress, int chunk) {
  if (o.postures < 1)
    throw Error("simulate: --postures must be >= 1, got " + std::to_string(o.postures));
  if (!(o.noise_force >= 0) || !(o.noise_moment >= 0) || !std::isfinite(o.noise_force) ||
      !std::isfinite(o.noise_moment)) {
    throw Error("simulate: noise levels must be finite and >= 0");
  }
  if (!(o.joint_range >= 0) || !(o.prismatic_range >= 0))
    throw Error("simulate: posture ranges must be >= 0");
  if (!(o.activation_min >= 0) || !(o.activation_max >= o.activation_min)) {
    throw Error("simulate: activation range must satisfy 0 <= min <= max");
  }
  if (o.noise_dof != 0 && o.noise_dof <= 2) {
    throw Error("simulate: Student-t noise needs more than 2 degrees of freedom (finite sd), got " +
                std::to_string(o.noise_dof));
  }
  if (!(o.outlier_fraction >= 0 && o.outlier_fraction <= 0.5) || !std::isfinite(o.outlier_size)) {
    throw Error("simulate: outlier fraction must be in [0, 0.5] and the outlier size finite");
  }
  std::vector<std::string> muscles = o.muscles;
  if (muscles.empty()) {
    for (int i = 0; i < nominal.muscle_count(); ++i) muscles.push_back(nominal.muscle(i).name);
  }
  if (muscles.empty()) throw Error("simulate: model '" + nominal.name() + "' has no muscle");
  for (const std::string& m : muscles) nominal.MuscleIndex(m);
  Eigen::VectorXd center = o.center.size() ? o.center : nominal.nominal_posture();
  if (center.size() != nominal.dof_count())
    throw Error("simulate: centre posture has the wrong size");
  for (const Trial& t : o.at) {
    if (t.q.size() != nominal.dof_count())
      throw Error("simulate: a posture to simulate at has the wrong size");
    if (!t.muscle.empty()) nominal.MuscleIndex(t.muscle);
    if (std::isfinite(t.activation) && !(t.activation >= 0 && t.activation <= 1)) {
      throw Error("simulate: activation " + std::to_string(t.activation) + " (line " +
                  std::to_string(t.line) + ") must be in [0, 1]");
    }
  }
  auto names = std::make_shared<const std::vector<std::string>>(nominal.joint_names());
  // One seeded stream in three passes: postures and activations of every trial, then the noise
  // of every trial, then the signs of the gross outliers. The passes are interleaved chunk by
  // chunk with three copies of the stream positioned where each pass starts (a posture draw
  // takes one step per limb joint plus one for the activation; the noise pass is replayed once
  // ahead when there are outliers), so the data equal the all-in-memory order exactly.
  // The postures vary the limb coordinates a lab moves: not the compliance dofs (base, extra,
  // release) and not the locked ones (held rigid at the centre's value; StaticsProblem).
  const StaticsProblem problem(nominal);
  auto varied = [&](int j) {
    return nominal.joint(j).role == JointRole::kLimb && !problem.locked(j);
  };
  int limb = 0;
  for (int j = 0; j < nominal.dof_count(); ++j) limb += varied(j);
  ident::Random posture_rng(o.seed);
  ident::Random noise_rng(o.seed);
  noise_rng.Skip(static_cast<std::uint64_t>(o.postures) * static_cast<std::uint64_t>(limb + 1));
  // Student-t with nu dof scaled to unit variance: N / sqrt(chi2_nu / nu) * sqrt((nu - 2) / nu).
  auto noise = [&](ident::Random& rng) {
    double z = rng.Normal();
    if (o.noise_dof <= 0) return z;
    double chi2 = 0;
    for (int i = 0; i < o.noise_dof; ++i) chi2 += std::pow(rng.Normal(), 2);
    return z / std::sqrt(chi2 / o.noise_dof) * std::sqrt((o.noise_dof - 2.0) / o.noise_dof);
  };
  auto draw = [&](ident::Random& rng, double* factor, Vector6d* z) {
    *factor =
        truth.trial_force_spread > 0 ? std::exp(truth.trial_force_spread * rng.Normal()) : 1.0;
    for (int c = 0; c < 6; ++c) (*z)[c] = noise(rng);
  };
  const int outliers = static_cast<int>(std::lround(o.outlier_fraction * o.postures));
  ident::Random outlier_rng = noise_rng;
  if (outliers > 0) {
    double factor = 1.0;
    Vector6d z;
    for (int k = 0; k < o.postures; ++k) draw(outlier_rng, &factor, &z);
  }
  // Gross outliers on evenly spread trials (every n / outliers-th): each component off by
  // outlier_size sd with a random sign.
  int next_outlier = 0;
  auto outlier_index = [&](int i) {
    return static_cast<int>((static_cast<long>(i) * o.postures) / outliers +
                            (o.postures / outliers) / 2);
  };
  // The force part of the reading (no per-trial factor, no offset), then factor and offset.
  AugmentedModel force_part = truth;
  force_part.trial_force = false;
  force_part.sensor_offset.setZero();
  const Model built(force_part.description);
  const std::vector<std::string> coactivated = ident::CoactivatedMuscles(force_part);
  const bool per_trial_factors = truth.trial_force_spread > 0;
  chunk = std::max(1, chunk);
  std::vector<Trial> trials;
  for (int first = 0; first < o.postures; first += chunk) {
    const int count = std::min(chunk, o.postures - first);
    trials.assign(count, Trial());
    for (int i = 0; i < count; ++i) {
      Trial& t = trials[i];
      const Trial* at =
          o.at.empty() ? nullptr : &o.at[static_cast<size_t>(first + i) % o.at.size()];
      t.joint_names = names;
      t.q = at ? at->q : center;
      for (int j = 0; j < nominal.dof_count(); ++j) {
        if (!varied(j)) continue;
        double r =
            nominal.joint(j).type == JointType::kPrismatic ? o.prismatic_range : o.joint_range;
        t.q[j] += posture_rng.Uniform(-r, r);
      }
      t.muscle = at && !at->muscle.empty() ? at->muscle : muscles[(first + i) % muscles.size()];
      t.activation = posture_rng.Uniform(o.activation_min, o.activation_max);
      if (at && std::isfinite(at->activation)) t.activation = at->activation;
      t.line = first + i + 3;  // comment line + header line come first in the written file
    }
    // Each trial's reading at factor 1 and, with per-trial factors, its passive part (which a
    // varying stimulus leaves unchanged: the factor scales the rest).
    std::vector<int> all(trials.size());
    for (size_t i = 0; i < trials.size(); ++i) all[i] = static_cast<int>(i);
    const ident::RawWrenches raw = ident::EvaluateRaw(built, force_part.posture_offset, coactivated,
                                                      trials, all, per_trial_factors);
    if (!raw.all_ok())
      throw Error("simulate: the model with the effects cannot be evaluated: " + raw.message);
    std::vector<Vector6d> reading, passive;
    ident::ComposeReadings(force_part, trials, all, raw, FitOptions(), &reading, nullptr, nullptr,
                           &passive);
    for (int i = 0; i < count; ++i) {
      Trial& t = trials[i];
      t.has_sd = true;
      double factor = 1.0;
      Vector6d z;
      draw(noise_rng, &factor, &z);
      for (int c = 0; c < 6; ++c) {
        double sd = c < 3 ? o.noise_force : o.noise_moment;
        t.wrench[c] = factor * (reading[i][c] - passive[i][c]) + passive[i][c] +
                      truth.sensor_offset[c] + sd * z[c];
        t.sd[c] = sd > 0 ? sd : o.sd_floor;
      }
      if (next_outlier < outliers && outlier_index(next_outlier) == first + i) {
        for (int c = 0; c < 6; ++c)
          t.wrench[c] += (outlier_rng.Uniform() < 0.5 ? -1 : 1) * o.outlier_size * t.sd[c];
        ++next_outlier;
      }
      on_trial(t);
    }
    if (progress) progress(first + count, static_cast<double>(first + count) / o.postures);
  }
}

std::vector<Trial> SimulateTrials(const Model& nominal, const AugmentedModel& truth,
                                  const SimulationOptions& o) {
  std::vector<Trial> trials;
  if (o.postures > 0) trials.reserve(o.postures);
  ForEachSimulatedTrial(nominal, truth, o, [&](const Trial& t) { trials.push_back(t); });
  return trials;
}

ResidualStats ComputeResidualStats(const std::vector<Trial>& trials,
                                   const std::vector<Vector6d>& predicted, int parameter_count,
                                   const FitOptions& options) {
  if (trials.empty() || predicted.size() != trials.size()) {
    ResidualStats s;
    s.parameter_count = parameter_count;
    return s;
  }
  ident::ResidualAccumulator accumulator;
  for (size_t k = 0; k < trials.size(); ++k) accumulator.Add(trials[k], predicted[k], options);
  return accumulator.Result(parameter_count);
}

}  // namespace isowrench
