#pragma once
/// @file
/// Closing the loop with measured data (MODEL.md "Closing the loop with measured data"):
/// read measured wrenches (CSV, docs/identification.md), predict them with a model, fit a
/// library of candidate effects (each a parameterized change of the model) by nonlinear least
/// squares, decide which effect the data support (information criterion + K-fold
/// cross-validation + identifiability), add the winner to the model and repeat on the residual.
///
/// Residuals are measured - predicted, in the transducer's axes, [f; m] in N and N·m (moment
/// about the endpoint). Weighted residuals divide by the row's stated standard deviation (the
/// sd_* columns); without them by FitOptions::default_sd_force / default_sd_moment.

#include <Eigen/Core>
#include <istream>
#include <memory>
#include <string>
#include <vector>

#include "isowrench/model.hpp"
#include "isowrench/statics.hpp"

namespace isowrench {

// ---- Data ------------------------------------------------------------------------------------

/// One measured trial: a posture, a stimulated muscle at an activation, the measured wrench.
struct Trial {
  /// Posture in the columns of the model the data were read against (rad / m), nominal
  /// posture for joints without a CSV column.
  Eigen::VectorXd q;
  /// Joint names of q's entries (the reading model's joint_names()); lets a trial be mapped
  /// onto an augmented model with more joints (new joints sit at 0).
  std::shared_ptr<const std::vector<std::string>> joint_names;
  std::string muscle;
  double activation = 1.0;  ///< force scale: muscle force = activation * max_force
  /// Measured wrench [fx fy fz mx my mz] in transducer axes (N, N·m).
  Vector6d wrench = Vector6d::Zero();
  /// Stated standard deviation per component (N, N·m); has_sd false when the CSV has none.
  Vector6d sd = Vector6d::Zero();
  bool has_sd = false;
  long line = 0;  ///< 1-based CSV line number (0 when built in code)
};

/// Streaming CSV reader (format in docs/identification.md): one row per trial, a header naming
/// the columns. Joint columns by joint name (degrees for revolute joints, mm for prismatic),
/// `muscle`, optional `activation`, `fx fy fz mx my mz` (N, N·m, transducer axes), optional
/// `sd_fx ... sd_mz` (all six or none). Blank lines and lines starting with '#' are skipped.
/// Memory does not depend on the number of rows.
class TrialReader {
 public:
  /// Reads and checks the header. @throws Error naming the source, line and column for a
  /// missing header, unknown joint columns, duplicate or missing required columns.
  TrialReader(const Model& model, std::istream& input, std::string source_name);
  ~TrialReader();
  TrialReader(const TrialReader&) = delete;
  TrialReader& operator=(const TrialReader&) = delete;

  /// Read the next trial; false at end of input.
  /// @throws Error naming source:line and the column for wrong field counts, non-numbers,
  ///         NaN/inf, negative sd or activation, unknown muscles.
  bool Next(Trial* trial);

  /// Column names of the header, in file order.
  const std::vector<std::string>& columns() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Read a whole CSV file into trials (TrialReader over a file).
/// @throws Error if the file cannot be opened, has no trials, or as TrialReader.
std::vector<Trial> ReadTrialsCsv(const Model& model, const std::string& path);

/// Write trials as CSV (the format TrialReader reads; sd columns when trials[0].has_sd),
/// atomically. Joint values in degrees / mm, %.10g. @throws Error if the file cannot be written.
void WriteTrialsCsv(const Model& model, const std::vector<Trial>& trials, const std::string& path);

/// Same as WriteTrialsCsv to a stream (no atomicity).
void WriteTrialsCsv(const Model& model, const std::vector<Trial>& trials, std::ostream& out);

// ---- Candidate effects -------------------------------------------------------------------------

/// The kinds of effect the library can add to a model.
enum class EffectKind {
  kBaseIsotropic,          ///< base compliance, one stiffness for x y z (N/m)
  kBasePerAxis,            ///< base compliance, stiffness per world axis (N/m, 3 parameters)
  kExtraJoint,             ///< an extra revolute dof after `joint`, about `axis`, with stiffness
  kTransducerAnisotropy,   ///< rotational transducer stiffness scaled by a factor (translation kept)
  kTransducerSoftDof,      ///< one transducer dof partially released (its stiffness, N/m or N·m/rad)
  kTransducerMisalignment, ///< transducer axes rotated by a small rotation vector (deg, 3 parameters)
  kSensorOffset,           ///< constant wrench added to every reading (N, N·m; 6 parameters)
  kMuscleForceScale,       ///< a muscle's max force scaled by a factor
  kAttachmentOffset,       ///< one muscle path point moved (mm, in its link's frame; 3 parameters)
  kMomentReferenceOffset,  ///< endpoint (moment reference point) moved (mm, in its link's frame)
};

/// Stable kind name used in effect ids: "base_isotropic", "base_per_axis", "extra_joint",
/// "transducer_anisotropy", "transducer_soft", "misalignment", "sensor_offset",
/// "force_scale", "attachment", "moment_reference".
const char* EffectKindName(EffectKind kind);

/// How a parameter is handled by the least squares: stiffnesses and factors by log10 (so the
/// problem is well scaled over decades), the rest linearly in their user unit.
enum class ParameterScale { kLog10, kLinear };

/// One parameter of an effect, in user units.
struct EffectParameter {
  std::string name;   ///< e.g. "k_base", "rx", "fx", "scale"
  std::string unit;   ///< user unit: "N/m", "N·m/rad", "deg", "mm", "N", "N·m", "x"
  ParameterScale scale = ParameterScale::kLinear;
  double neutral = 0.0;  ///< value at which the effect vanishes (or nearly: a rigid stiffness)
  double initial = 0.0;  ///< starting value of the fit (user units)
  double lower = 0.0;    ///< search range (user units); hitting it is reported
  double upper = 0.0;
};

/// A candidate effect: what it changes and its parameters (values given separately).
struct Effect {
  EffectKind kind = EffectKind::kSensorOffset;
  /// Unique id, e.g. "base_isotropic", "extra_joint:knee_rx:y", "transducer_soft:rz",
  /// "force_scale:GP", "attachment:GP:1" (path point index), "moment_reference".
  std::string id;
  std::string description;  ///< one readable sentence
  std::string joint;        ///< kExtraJoint: insert after this joint
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();  ///< kExtraJoint: axis in that joint's child frame
  int dof = -1;             ///< kTransducerSoftDof: 0..5 (x y z rx ry rz)
  std::string muscle;       ///< kMuscleForceScale, kAttachmentOffset
  int point = -1;           ///< kAttachmentOffset: path point index
  std::vector<EffectParameter> parameters;
  /// True when the effect changes the prediction only by post-processing the nominal wrench
  /// (sensor offset, force scale): no model rebuild needed.
  bool post_processing = false;
};

/// The candidate library for a model (every kind that applies to it): base compliance
/// (isotropic and per axis; skipped when the model already has base joints), an extra joint
/// for each axis missing from each group of co-located revolute joints, transducer
/// anisotropy, a soft dof per restrained transducer dof, misalignment, sensor offset, a force
/// scale per muscle in `muscles` (all muscles when empty), an attachment offset per path point
/// on a moving link (and the origin), moment reference offset.
std::vector<Effect> CandidateEffects(const Model& model, const std::vector<std::string>& muscles = {});

/// Find an effect by id in CandidateEffects(model). @throws Error listing the known ids.
Effect FindEffect(const Model& model, const std::string& id);

/// A description with the effect applied at `values` (user units, one per parameter).
/// Post-processing effects: kMuscleForceScale scales max_force; kSensorOffset is returned
/// unchanged (it is not a model property; see ApplyEffectToWrench).
/// @throws Error for a wrong number of values, non-finite values or bad names.
LimbDescription ApplyEffect(LimbDescription description, const Effect& effect,
                            const std::vector<double>& values);

/// An effect with its values, as added to a model.
struct AppliedEffect {
  Effect effect;
  std::vector<double> values;  ///< user units
};

/// Description + applied effects, plus the sensor offset that no URDF can hold (N, N·m).
struct AugmentedModel {
  LimbDescription description;
  Vector6d sensor_offset = Vector6d::Zero();
  std::vector<AppliedEffect> effects;
};

/// Apply effects in order. @throws Error as ApplyEffect.
AugmentedModel ApplyEffects(const LimbDescription& nominal, const std::vector<AppliedEffect>& effects);

// ---- Prediction -------------------------------------------------------------------------------

/// Predicted reading for each trial: W (Eq. 10, transducer axes) of the trial's muscle at its
/// activation on `model` (trial postures mapped by joint name; joints the trial lacks at 0),
/// plus `sensor_offset`. A trial whose statics fails (self-motion) gets status false.
struct Prediction {
  std::vector<Vector6d> wrench;
  std::vector<bool> ok;
  int failed = 0;
  std::string message;  ///< first failure, if any
};
Prediction PredictTrials(const Model& model, const std::vector<Trial>& trials,
                         const Vector6d& sensor_offset = Vector6d::Zero());

// ---- Simulation ------------------------------------------------------------------------------

/// Options of SimulateTrials.
struct SimulationOptions {
  int postures = 50;              ///< number of trials, >= 1
  unsigned long long seed = 1;    ///< std::mt19937_64 seed: same seed, same data
  /// Each limb joint (role kLimb) is drawn uniformly in nominal +- joint_range (rad for
  /// revolute joints); prismatic limb joints in nominal +- prismatic_range (m). Base, extra and
  /// release joints stay at 0.
  double joint_range = 15.0 * 3.14159265358979323846 / 180.0;
  double prismatic_range = 0.005;
  /// Activation drawn uniformly in [activation_min, activation_max].
  double activation_min = 0.3;
  double activation_max = 1.0;
  /// Gaussian noise sd per force component (N) and moment component (N·m), >= 0; written as
  /// the sd_* columns (0 noise writes sd = the floor below, so weights stay finite).
  double noise_force = 0.002;
  double noise_moment = 5e-5;
  /// sd written when a noise level is 0 (N or N·m).
  double sd_floor = 1e-9;
  /// Muscles used, cycled over trials; empty = all muscles of the model.
  std::vector<std::string> muscles;
  /// Centre of the posture sampling in the columns of the nominal model (rad / m); empty =
  /// the nominal posture.
  Eigen::VectorXd center;
};

/// Synthetic measured data: postures sampled around the nominal posture of `nominal`, wrenches
/// predicted by `truth` (nominal + effects) plus seeded Gaussian noise. Trials carry the
/// joint columns of `nominal`.
/// @throws Error for bad options, or if the true model cannot hold a sampled posture
///         (self-motion), naming the trial.
std::vector<Trial> SimulateTrials(const Model& nominal, const AugmentedModel& truth,
                                  const SimulationOptions& options);

/// Parse "NAME=V1,V2,..." (user units) into an applied effect of CandidateEffects(model).
/// A single value for a multi-parameter effect is refused.
/// @throws Error naming the effect and listing the known ids.
AppliedEffect ParseEffectAssignment(const Model& model, const std::string& text);

// ---- Fitting ------------------------------------------------------------------------------

/// Options of FitEffects. Each states the inequality it controls.
struct FitOptions {
  /// At most this many effects are added (rounds).
  int max_rounds = 3;
  /// Folds for cross-validation (>= 2; fewer trials than folds disables CV).
  int folds = 5;
  /// An effect is added only when BIC_current - BIC_candidate >= min_bic_improvement
  /// (10 = "very strong" evidence on the Kass & Raftery scale).
  double min_bic_improvement = 10.0;
  /// Look-elsewhere correction: with M candidates tried in a round, the threshold above is
  /// raised by 2 ln(M) (a Bonferroni-style penalty for picking the best of M).
  bool look_elsewhere = true;
  /// ... and its held-out error is lower: cv_candidate <= (1 - min_cv_improvement) * cv_current.
  double min_cv_improvement = 0.02;
  /// Runner-ups with BIC within indistinguishable_bic of the winner (and also passing the
  /// thresholds) are reported as indistinguishable from it at these postures.
  double indistinguishable_bic = 6.0;
  /// A parameter is unidentifiable when its whitened sensitivity column norm is
  /// <= min_sensitivity * sqrt(residual count), or when
  /// sigma_min / sigma_max of the whitened Jacobian <= min_singular_ratio.
  double min_sensitivity = 1e-6;
  double min_singular_ratio = 1e-8;
  /// Two parameters are too correlated to identify separately when |corr| > max_correlation.
  double max_correlation = 0.99;
  /// Verdict "unexplained residual" when the final reduced chi^2 (cost per residual with the
  /// stated sd) exceeds 1 + unexplained_sigmas * sqrt(2 / dof).
  double unexplained_sigmas = 5.0;
  /// Weights used when a trial has no stated sd (N and N·m).
  double default_sd_force = 0.01;
  double default_sd_moment = 0.0005;
  /// Ceres limits.
  int max_iterations = 50;
  double function_tolerance = 1e-10;
  /// Only the `cv_candidates` best candidates by BIC are cross-validated (the rest cannot win).
  int cv_candidates = 4;
  /// Candidate ids to try; empty = CandidateEffects(model).
  std::vector<std::string> candidates;
  unsigned long long cv_seed = 7;  ///< fold assignment
};

/// Error statistics of a set of residuals, per component [fx fy fz mx my mz].
struct ResidualStats {
  Vector6d rms = Vector6d::Zero();        ///< RMS of measured - predicted (N, N·m)
  Vector6d r2 = Vector6d::Zero();         ///< 1 - SS_res / SS_tot (about the component mean)
  Vector6d normalized = Vector6d::Zero(); ///< RMS of (measured - predicted) / sd: noise multiples
  Vector6d mean = Vector6d::Zero();       ///< mean residual (N, N·m): a constant offset shows here
  double chi2 = 0.0;            ///< sum of squared weighted residuals
  double reduced_chi2 = 0.0;    ///< chi2 / (residual count - parameter count)
  int residual_count = 0;       ///< scalar residuals used (6 per trial)
  int parameter_count = 0;
};

/// One candidate fitted in one round.
struct CandidateFit {
  Effect effect;
  std::vector<double> values;          ///< fitted parameters, user units
  std::vector<double> standard_errors; ///< user units (log10 parameters: delta method); 0 if unknown
  std::vector<double> log10_standard_errors;  ///< for kLog10 parameters: SE of log10(value)
  Eigen::MatrixXd correlation;         ///< parameter correlation matrix (internal scale)
  std::vector<bool> at_bound;          ///< parameter ended on its search range limit
  double cost = 0.0;    ///< chi2 = sum of squared weighted residuals at the optimum
  double aic = 0.0;     ///< AICc on chi2 (known-sd Gaussian likelihood, constants dropped)
  double bic = 0.0;     ///< chi2 + k ln(n)
  double delta_bic = 0.0;  ///< BIC of the current model minus this BIC (> 0: better)
  double cv_error = -1.0;  ///< held-out chi2 per residual (K-fold); < 0 when not computed
  bool identifiable = true;
  std::string identifiability;  ///< why not identifiable (sensitivity, correlation), or ""
  bool converged = false;
  std::string solver_message;
  bool accepted = false;   ///< chosen in this round
  std::string verdict;     ///< "chosen", or why it lost
};

/// One round: the model before, every candidate, the winner (if any).
struct FitRound {
  int index = 0;                 ///< 1-based
  ResidualStats before;          ///< residual of the current model at the start of the round
  double bic_before = 0.0;
  double cv_before = -1.0;       ///< held-out chi2 per residual of the current model
  /// ΔBIC an effect needed in this round (min_bic_improvement + look-elsewhere term).
  double bic_threshold = 0.0;
  std::vector<CandidateFit> candidates;  ///< sorted best BIC first
  int chosen = -1;               ///< index in candidates, -1 when nothing earned its parameters
  /// Effect ids indistinguishable from the winner at these postures (BIC within
  /// FitOptions::indistinguishable_bic and passing the thresholds).
  std::vector<std::string> indistinguishable;
  std::string summary;           ///< one readable sentence
};

/// Final verdict of FitEffects.
enum class FitVerdict {
  kNominalFits,        ///< no effect needed: the nominal model explains the data to the noise
  kExplained,          ///< effects added; the residual is at the noise level
  kUnexplained,        ///< residual stays well above the noise: something outside the library
  kNoNoiseStated,      ///< effects may have been added, but no sd given: cannot compare with noise
};
const char* FitVerdictName(FitVerdict verdict);

/// Per-trial residual before and after (measured - predicted, N and N·m).
struct TrialResidual {
  long line = 0;
  std::string muscle;
  double activation = 1.0;
  Vector6d measured = Vector6d::Zero();
  Vector6d before = Vector6d::Zero();
  Vector6d after = Vector6d::Zero();
  double normalized_before = 0.0;  ///< |weighted residual| / sqrt(6)
  double normalized_after = 0.0;
};

/// Everything FitEffects found (Ceres-style summary).
struct FitReport {
  std::string model_name;
  std::string source;        ///< data file, if known
  int trial_count = 0;
  bool sd_stated = false;    ///< every trial had sd columns
  ResidualStats before;      ///< nominal model
  ResidualStats after;       ///< augmented model
  std::vector<FitRound> rounds;
  std::vector<AppliedEffect> chosen;         ///< effects added, in order
  std::vector<CandidateFit> chosen_fits;     ///< the accepted fit of each (values, SE, ...)
  std::vector<TrialResidual> trials;
  FitVerdict verdict = FitVerdict::kNominalFits;
  std::string verdict_message;
  /// False when the verdict is kUnexplained: the effects in `chosen` then reduce the residual
  /// but do not bring it to the noise, so they are reported as tentative partial fits, not as
  /// found effects (an effect outside the library is not attributed to one inside it).
  bool effects_claimed = true;
  /// Pairs/groups of effects that cannot be told apart from these data, one sentence each.
  std::vector<std::string> indistinguishable;
  AugmentedModel augmented;  ///< nominal + chosen effects (write with WriteAugmentedUrdf)
  /// Other remarks, e.g. "base_per_axis simplified to base_isotropic" after the rounds.
  std::vector<std::string> notes;
  double seconds = 0.0;      ///< wall time of the fit

  /// A few lines: verdict, chosen effects, error before/after.
  std::string BriefReport() const;
};

/// Residual statistics of predictions against trials (weights as described in the file
/// comment; parameter_count only enters reduced_chi2).
ResidualStats ComputeResidualStats(const std::vector<Trial>& trials,
                                   const std::vector<Vector6d>& predicted, int parameter_count,
                                   const FitOptions& options = {});

/// Fit one candidate effect on top of `current` (nominal + effects already chosen).
/// Never throws for numerical trouble (converged false, message set).
CandidateFit FitCandidate(const AugmentedModel& current, const Effect& effect,
                          const std::vector<Trial>& trials, const FitOptions& options = {});

/// The whole loop: nominal residual, rounds of candidate fits and decisions, final report.
/// @throws Error for empty trials or unknown candidate ids; numerical outcomes are in the report.
FitReport FitEffects(const Model& nominal, const std::vector<Trial>& trials,
                     const FitOptions& options = {});

/// Write the augmented model as URDF (nominal file + chosen effects; the sensor offset and the
/// fit summary go into an XML comment since URDF cannot hold them), atomically.
/// @throws Error if the file cannot be written.
void WriteAugmentedUrdf(const FitReport& report, const std::string& path);

}  // namespace isowrench
