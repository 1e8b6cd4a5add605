#pragma once
// Private helpers shared by the identification sources.

#include <Eigen/Core>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "isowrench/identification.hpp"

namespace isowrench::ident {

/// Reproducible random numbers independent of the standard library's distributions.
class Random {
 public:
  explicit Random(unsigned long long seed) : state_(seed) {}
  std::uint64_t Next();                  ///< splitmix64
  double Uniform();                      ///< [0, 1)
  double Uniform(double lo, double hi);  ///< [lo, hi)
  double Normal();                       ///< standard normal (Box-Muller)
  /// Advance as if Next() had been called n times (splitmix64 steps by a constant).
  void Skip(std::uint64_t n) { state_ += n * 0x9E3779B97F4A7C15ULL; }

 private:
  std::uint64_t state_;
  bool has_spare_ = false;
  double spare_ = 0.0;
};

/// Bayesian information criterion of a fit with k parameters to n residuals: chi2 + k ln n
/// when every trial states its noise, else n ln(chi2 / n) + k ln n.
double Bic(double chi2, int n, int k, bool sd_stated);

/// Linearised BIC gain of adding the parameters whose residual sensitivities are the columns of
/// D to a fit with residual r (a score test: the cost falls by the part of r in the span of D).
/// Columns that are all exactly 0 (no influence) gain nothing and cost their BIC penalty: the
/// result is always a number. The penalty counts `k` parameters (default: D's columns; less for
/// a candidate that replaces chosen effects it contains).
double LinearisedDeltaBic(const Eigen::MatrixXd& D, const Eigen::VectorXd& r, int n, bool sd_stated,
                          int k = -1);

/// Internal (least-squares) value of a parameter from its user value and back.
double ToInternal(const EffectParameter& p, double user);
double ToUser(const EffectParameter& p, double internal);

/// Weight (1/sd) of component c of a trial.
double Weight(const Trial& trial, int c, const FitOptions& options);

/// Residual statistics (ResidualStats, the residual measured - predicted) accumulated one
/// trial at a time in O(1) memory; ComputeResidualStats over a vector and the streaming second
/// pass of a sampled fit both use it. The spread of the measured wrench for R^2 is summed about
/// the running mean (Welford's update).
class ResidualAccumulator {
 public:
  /// Adds one trial; returns its |weighted residual| / sqrt(6) (the fit's outlier measure).
  double Add(const Trial& trial, const Vector6d& predicted, const FitOptions& options);
  ResidualStats Result(int parameter_count) const;
  long count() const { return n_; }

 private:
  long n_ = 0;
  Vector6d sum_ = Vector6d::Zero(), mean_measured_ = Vector6d::Zero();
  Vector6d ss_res_ = Vector6d::Zero(), ss_tot_ = Vector6d::Zero(), ss_norm_ = Vector6d::Zero();
};

/// Map a trial's joint names onto a model's columns (index per trial entry, -1 = absent).
std::vector<int> JointMap(const Model& model, const std::vector<std::string>& names);

/// Maps trials onto a model's posture vector and muscle index, caching the last mapping.
class TrialMapper {
 public:
  explicit TrialMapper(const Model& model);
  /// Fill q (model columns; joints the trial lacks at 0) and return the muscle index.
  /// @throws Error for unknown muscles or unmappable postures.
  int Map(const Trial& trial, Eigen::VectorXd* q);

 private:
  const Model* model_;
  const std::vector<std::string>* last_names_ = nullptr;
  std::vector<int> map_;
  std::string last_muscle_;
  int muscle_index_ = -1;
};

/// Prediction on a subset of trials (indices), without rebuilding anything but a workspace.
void PredictSubset(const Model& model, const std::vector<Trial>& trials,
                   const std::vector<int>& subset, const Vector6d& sensor_offset,
                   std::vector<Vector6d>* wrench, std::vector<bool>* ok, std::string* message);

/// Statics wrenches of a subset of trials on one model, at the recorded posture plus
/// `posture_offset`: own[k] = the trial's muscle at its activation; other[i][k] = muscle
/// others[i] at activation 1 (for coactivation). The only place identification calls the engine
/// for wrenches.
struct RawWrenches {
  std::vector<std::string> others;
  std::vector<int> other_index;  ///< model muscle index of each of `others`
  std::vector<int> muscle;       ///< model muscle index of each subset trial (-1: not mapped)
  std::vector<Vector6d> own;
  std::vector<std::vector<Vector6d>> other;
  std::vector<bool> ok;
  std::string message;            ///< first failure
  std::vector<double> max_force;  ///< max force per muscle of the model evaluated (N)
  /// With EvaluateRaw's `passive`: each subset trial's own-muscle wrench at activation 0 (the
  /// pre-stimulus, passive wrench; zero for a constant-force muscle). Empty otherwise.
  std::vector<Vector6d> passive;
  bool all_ok() const;
};
/// The wrench of each subset trial's muscle at its posture and activation (and of each of
/// `others` at activation 1); with `passive` also the own muscle's wrench at activation 0 (for
/// per-trial factors, which scale only the stimulated part).
RawWrenches EvaluateRaw(const Model& model, const std::map<std::string, double>& posture_offset,
                        const std::vector<std::string>& others, const std::vector<Trial>& trials,
                        const std::vector<int>& subset, bool passive = false);

/// Readings from raw wrenches and the rest of the chain of `model` (AugmentedModel's comment):
/// muscle forces rescaled by model.description's max_force / raw.max_force, coactivation,
/// sensor origin, calibration, per-trial factors (closed form, weights 1/sd), sensor offset.
/// A per-trial factor scales the stimulated part of the trial's own wrench only: the reading
/// is factor x (W(a) - W(0)) + W(0) + offset with W(0) the passive wrench (raw.passive; zero
/// for a constant-force muscle or when raw has none), as a stimulus that varies leaves the
/// pre-stimulus force unchanged. `factors` (optional) receives the per-trial factors (1 without
/// trial_force), `unit` (optional) each trial's stimulated part W(a) - W(0) (the reading at
/// factor 1 less the passive part and the sensor offset), `passive_readings` (optional) each
/// trial's passive part as read (zero without raw.passive). Trials whose raw wrench failed keep
/// a zero reading.
void ComposeReadings(const AugmentedModel& model, const std::vector<Trial>& trials,
                     const std::vector<int>& subset, const RawWrenches& raw,
                     const FitOptions& options, std::vector<Vector6d>* readings,
                     std::vector<double>* factors, std::vector<Vector6d>* unit = nullptr,
                     std::vector<Vector6d>* passive_readings = nullptr);

/// Coactivated muscles of an augmented model (keys of `coactivation`).
std::vector<std::string> CoactivatedMuscles(const AugmentedModel& model);

/// Column `joint` of the endpoint Jacobian at the nominal posture (transducer-frame twist per
/// unit joint motion). @throws Error for an unknown joint.
Eigen::VectorXd NominalJacobianColumn(const Model& model, const std::string& joint);

/// Muscle length of `muscle` at each trial's recorded posture (m); NaN where it cannot be
/// evaluated (`failure`, if given, receives the first reason).
std::vector<double> MuscleLengths(const Model& model, const std::string& muscle,
                                  const std::vector<Trial>& trials, std::string* failure = nullptr);

/// Two effects that cannot both be in one model (same id, or one excludes the other).
bool Excluded(const Effect& a, const Effect& b);
/// `a` contains `b` (Effect::contains names b's id).
bool Contains(const Effect& a, const Effect& b);

}  // namespace isowrench::ident
