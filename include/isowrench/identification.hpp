#pragma once
/// @file
/// Closing the loop with measured data (docs/model.md "Closing the loop with measured data"):
/// read measured wrenches (CSV, docs/identification.md), predict them with a model, fit a
/// library of candidate effects (each a parameterized change of the model) by nonlinear least
/// squares, decide which effect the data support (information criterion + K-fold
/// cross-validation + identifiability), add the winner to the model and repeat on the residual.
///
/// Residuals are measured - predicted, in the transducer's axes, [f; m] in N and N·m (moment
/// about the endpoint). Weighted residuals divide by the row's stated standard deviation (the
/// sd_* columns); without them by FitOptions::default_sd_force / default_sd_moment.

#include <Eigen/Core>
#include <functional>
#include <istream>
#include <map>
#include <memory>
#include <optional>
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

struct TrialSheetOptions;  // isowrench/trial_csv.hpp: the sheet's dialect and kind

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
  /// The same for a sheet laid out as `sheet` says (isowrench/trial_csv.hpp).
  TrialReader(const Model& model, std::istream& input, std::string source_name,
              const TrialSheetOptions& sheet);
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

/// A uniform random sample of at most `capacity` trials from a stream of trials of unknown
/// length (reservoir sampling, Vitter's Algorithm R): after n trials were added each of them is
/// in the sample with probability min(1, capacity / n), and every subset of that size is equally
/// likely. The random numbers come from isowrench's splitmix64 generator (as SimulateTrials),
/// so a seed gives the same sample on every platform. Memory: `capacity` trials, whatever the
/// number added. FitEffects and FitEffectsCsv (isowrench/trial_csv.hpp) choose the trials they
/// fit with it (FitOptions::max_fit_trials).
class TrialReservoir {
 public:
  /// `capacity` 0 keeps every trial. @throws Error for a negative capacity.
  TrialReservoir(long capacity, unsigned long long seed);
  /// Offer the next trial of the stream.
  void Add(const Trial& trial);
  /// Trials offered so far.
  long seen() const { return seen_; }
  /// The sample, in the order the trials were added (all of them while seen() <= capacity);
  /// leaves the reservoir empty.
  std::vector<Trial> Take();

 private:
  long capacity_;
  unsigned long long state_;  ///< splitmix64 state
  long seen_ = 0;
  std::vector<Trial> kept_;
  std::vector<long> order_;  ///< position in the stream of each kept trial
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

/// Where in the prediction an effect acts (the order the prediction applies them):
/// the recorded posture, the model (URDF description), the muscle force, the measurement chain.
enum class EffectStage { kPosture, kModel, kForce, kMeasurement };

/// "posture", "model", "muscle force", "measurement".
const char* EffectStageName(EffectStage stage);

/// How a parameter is handled by the least squares: stiffnesses and factors by log10 (so the
/// problem is well scaled over decades), the rest linearly in their user unit.
enum class ParameterScale { kLog10, kLinear };

/// One parameter of an effect, in user units.
struct EffectParameter {
  std::string name;  ///< e.g. "k_base", "rx", "fx", "scale"
  std::string unit;  ///< user unit: "N/m", "N·m/rad", "deg", "mm", "N", "N·m", "x"
  ParameterScale scale = ParameterScale::kLinear;
  double neutral = 0.0;  ///< value at which the effect vanishes (or nearly: a rigid stiffness)
  double initial = 0.0;  ///< starting value of the fit (user units)
  double lower = 0.0;    ///< search range (user units); hitting it is reported
  double upper = 0.0;
};

/// A candidate effect: what it changes and its parameters (values given separately). Effects
/// come from the effect registry (src/identification/effects/, one file per kind).
struct Effect {
  /// Registry kind, the id's first part: "base_isotropic", "base_per_axis", "extra_joint",
  /// "transducer_anisotropy", "transducer_soft", "misalignment", "sensor_offset",
  /// "force_scale", "attachment", "moment_reference", "trial_force", "joint_offset", "gain",
  /// "crosstalk", "coactivation", "sensor_origin".
  std::string kind;
  /// Unique id, e.g. "base_isotropic", "extra_joint:knee_rx:y", "transducer_soft:rz",
  /// "force_scale:GP", "attachment:GP:1" (path point index), "gain:fx", "joint_offset:knee_rz".
  std::string id;
  std::string description;  ///< one readable sentence
  EffectStage stage = EffectStage::kModel;
  std::string joint;  ///< extra_joint: insert after this joint; joint_offset: the column
  Eigen::Vector3d axis =
      Eigen::Vector3d::UnitZ();  ///< extra_joint: axis in that joint's child frame
  int dof = -1;        ///< transducer_soft, gain: 0..5 (x y z rx ry rz / fx fy fz mx my mz)
  std::string muscle;  ///< force_scale, attachment, coactivation
  int point = -1;      ///< attachment: path point index
  std::vector<EffectParameter> parameters;
  /// True when the effect does not change the model (stage other than kModel): the fit then
  /// reuses one model for all its evaluations.
  bool post_processing = false;
  /// True when the parameters are not fitted by least squares but profiled per trial in
  /// closed form (trial_force: one factor per trial; its parameter is the spread).
  bool per_trial = false;
  /// Effect ids (or kinds, ending in ':') this effect is known to be confounded with.
  std::vector<std::string> confounders;
  /// Effect ids that cannot be in one model with this one (they edit the same thing).
  std::vector<std::string> excludes;
  /// Effect ids this effect contains (any change of theirs is, to first order, one of its own,
  /// e.g. crosstalk contains misalignment and sensor_origin): added after them it replaces
  /// them, and they cannot be added after it. After the rounds a chosen effect is replaced by
  /// the contained ones when they explain the data with a lower BIC.
  std::vector<std::string> contains;
};

/// What the registry says about one kind (for --list-effects and the docs).
struct EffectKindInfo {
  std::string kind;        ///< e.g. "gain"
  std::string id_pattern;  ///< e.g. "gain:AXIS (AXIS one of fx fy fz mx my mz)"
  EffectStage stage = EffectStage::kModel;
  std::string summary;      ///< what it changes, one paragraph
  std::string parameters;   ///< names, units, scale and range
  std::string confounders;  ///< known confounders, one sentence
};

/// Every kind in the registry, sorted by kind name.
std::vector<EffectKindInfo> EffectKinds();

/// The candidate library for a model (every kind that applies to it): base compliance
/// (isotropic and per axis; skipped when the model already has base joints), an extra joint
/// for each axis missing from each group of co-located revolute joints, transducer
/// anisotropy, a soft dof per restrained transducer dof, misalignment, sensor offset, a force
/// scale per muscle in `muscles` (all muscles when empty), an attachment offset per path point
/// on a moving link (and the origin), moment reference offset.
std::vector<Effect> CandidateEffects(const Model& model,
                                     const std::vector<std::string>& muscles = {});

/// Find an effect by id in CandidateEffects(model). @throws Error listing the known ids.
Effect FindEffect(const Model& model, const std::string& id);

/// A description with the effect applied at `values` (user units, one per parameter). Effects
/// outside the model (measurement chain, posture, per-trial force) return it unchanged; use
/// ApplyEffects for the whole augmented model.
/// @throws Error for a wrong number of values, non-finite values or bad names.
LimbDescription ApplyEffect(LimbDescription description, const Effect& effect,
                            const std::vector<double>& values);

/// An effect with its values, as added to a model.
struct AppliedEffect {
  Effect effect;
  std::vector<double> values;  ///< user units
};

/// Description + applied effects, plus what no URDF can hold: the recorded-posture offsets,
/// the force corrections and the measurement chain. The reading of a trial is
///   W  = Eq. 10 wrench of the trial's muscle at (recorded posture + posture_offset), plus
///        coactivation[j] * (wrench of muscle j at full activation) for every other muscle j,
///   W' = [f; m - sensor_origin x f]     (moment about the transducer's true origin),
///   reading = trial factor * calibration * W' + sensor_offset.
struct AugmentedModel {
  LimbDescription description;
  Vector6d sensor_offset = Vector6d::Zero();  ///< N, N·m, transducer axes
  std::vector<AppliedEffect> effects;
  /// Added to the recorded value of a column (rad or m), by column name (joint_offset).
  std::map<std::string, double> posture_offset;
  /// Muscle -> fraction of its max force with which it also pulls in trials of other muscles.
  std::map<std::string, double> coactivation;
  /// Per-trial force factors are fitted in closed form (trial_force).
  bool trial_force = false;
  /// Spread (sd of ln factor) used when simulating per-trial factors.
  double trial_force_spread = 0.0;
  /// Offset of the transducer's moment origin (m, transducer axes).
  Eigen::Vector3d sensor_origin = Eigen::Vector3d::Zero();
  /// Calibration error of the transducer: reading = calibration * W' (gain on the diagonal,
  /// crosstalk off it), dimensionless for f<-f and m<-m, m for m<-f, 1/m for f<-m.
  Matrix6d calibration = Matrix6d::Identity();
};

/// Apply effects in order. @throws Error as ApplyEffect.
AugmentedModel ApplyEffects(const LimbDescription& nominal,
                            const std::vector<AppliedEffect>& effects);

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

/// Predicted readings of an augmented model (the chain in AugmentedModel's comment). With
/// trial_force the per-trial factors are solved in closed form against each trial's measured
/// wrench (weighted least squares) and returned in `factors` (1 otherwise).
Prediction PredictTrials(const AugmentedModel& model, const std::vector<Trial>& trials,
                         std::vector<double>* factors = nullptr);

// ---- Simulation ------------------------------------------------------------------------------

/// Options of SimulateTrials.
struct SimulationOptions {
  int postures = 50;            ///< number of trials, >= 1
  unsigned long long seed = 1;  ///< std::mt19937_64 seed: same seed, same data
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
  /// Noise distribution: 0 = Gaussian; otherwise Student-t with this many degrees of freedom
  /// (> 2), scaled so its standard deviation is the stated noise.
  int noise_dof = 0;
  /// Fraction of trials made gross outliers (in [0, 0.5]): their wrench gets an extra error of
  /// outlier_size stated noise sd per component, random signs.
  double outlier_fraction = 0.0;
  double outlier_size = 50.0;
  /// Centre of the posture sampling in the columns of the nominal model (rad / m); empty =
  /// the nominal posture.
  Eigen::VectorXd center;
  /// Trials to simulate at instead of around `center` (a posture sheet: simulate --postures,
  /// design's output; ReadPostureSheet of isowrench/frontend.hpp): trial i uses at[i % size]:
  /// its posture (columns of the nominal model, rad / m) as the centre of the draw (set the
  /// ranges to 0 for exactly that posture), its muscle when not empty (else `muscles`, cycled),
  /// its activation when finite (else drawn). The random stream is the same either way.
  std::vector<Trial> at;
};

/// Synthetic measured data: postures sampled around the nominal posture of `nominal`, wrenches
/// predicted by `truth` (nominal + effects) plus seeded Gaussian noise. Trials carry the
/// joint columns of `nominal`.
/// @throws Error for bad options, or if the true model cannot hold a sampled posture
///         (self-motion), naming the trial.
std::vector<Trial> SimulateTrials(const Model& nominal, const AugmentedModel& truth,
                                  const SimulationOptions& options);

/// Parse "NAME=V1,V2,..." (user units, every parameter in order) or "NAME=P1:V1,P2:V2,..."
/// (named parameters; the others keep their neutral value, e.g. "crosstalk=mx_fy:0.02") into an
/// applied effect of CandidateEffects(model). A single value for a multi-parameter effect is
/// refused.
/// @throws Error naming the effect and listing the known ids.
AppliedEffect ParseEffectAssignment(const Model& model, const std::string& text);

// ---- Fitting ------------------------------------------------------------------------------

/// Loss applied to each trial's (row's) weighted residual norm.
enum class RobustLoss {
  kNone,    ///< plain least squares
  kHuber,   ///< quadratic up to loss_scale noise multiples, linear beyond
  kCauchy,  ///< log(1 + u^2 / loss_scale^2): outliers have bounded influence
};
/// "none", "huber", "cauchy".
const char* RobustLossName(RobustLoss loss);
/// Parse "none" | "huber" | "cauchy". @throws Error naming the value and the choices.
RobustLoss ParseRobustLoss(const std::string& text);

/// Options of FitEffects. Each states the inequality it controls.
struct FitOptions {
  /// Robust loss on each row's RMS noise multiple u = sqrt(row chi2 / 6) (default Huber with
  /// its knee at loss_scale = 2 stated noise sd: Gaussian rows are nearly unaffected).
  RobustLoss loss = RobustLoss::kHuber;
  double loss_scale = 2.0;
  /// A row is flagged an outlier when u > outlier_threshold after the fit (with a robust loss);
  /// flagged rows are left out of the verdict's noise comparison.
  double outlier_threshold = 3.0;
  /// Candidates fitted in parallel on this many threads (0 = hardware concurrency).
  int threads = 0;
  /// Screening: each round ranks the candidates by a linearised ΔBIC at the current model (a
  /// score test from one sensitivity column per parameter, exact for effects linear in their
  /// parameters) and fits only the screen_keep best fully (per-trial effects, solved in closed
  /// form, always, besides those); the others are reported as screened out. 0 = fit every
  /// candidate. The ΔBIC threshold still counts every candidate tried (look_elsewhere).
  int screen_keep = 8;
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
  /// ... and its held-out error is lower: cv_candidate <= cv_current - min_cv_improvement *
  /// min(cv_current, 1) (robust cost per residual; 1 = at the noise, so gross outliers, which
  /// inflate both, do not hide an improvement).
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
  /// Called with a one-line description of each stage as it starts ("round 1: fitting 8 of 30
  /// candidates", ...), for progress on long fits; empty = silent.
  std::function<void(const std::string&)> progress;
  unsigned long long cv_seed = 7;  ///< fold assignment
  /// Scale: fit at most this many trials (0 = every trial; must be >= 0). With more trials a
  /// uniform random sample of max_fit_trials of them is fitted (TrialReservoir with
  /// sample_seed, kept in the trials' order): screening, rounds, cross-validation, verdict,
  /// outliers, trace and the per-trial rows of the report use the sample only, and a second
  /// pass predicts every trial (4096 at a time) for FitReport::before / after. The fit's memory
  /// and time then do not grow with the number of trials (FitEffectsCsv also reads the file in
  /// bounded memory). The standard errors are those of the sample: about
  /// sqrt(trials / max_fit_trials) times those of a fit of every trial. With no more trials than
  /// max_fit_trials the report is exactly that of a fit of every trial.
  int max_fit_trials = 20000;
  unsigned long long sample_seed = 1;  ///< seed of the sample (TrialReservoir)
};

/// Error statistics of a set of residuals, per component [fx fy fz mx my mz].
struct ResidualStats {
  Vector6d rms = Vector6d::Zero();         ///< RMS of measured - predicted (N, N·m)
  Vector6d r2 = Vector6d::Zero();          ///< 1 - SS_res / SS_tot (about the component mean)
  Vector6d normalized = Vector6d::Zero();  ///< RMS of (measured - predicted) / sd: noise multiples
  Vector6d mean = Vector6d::Zero();  ///< mean residual (N, N·m): a constant offset shows here
  double chi2 = 0.0;                 ///< sum of squared weighted residuals
  double reduced_chi2 = 0.0;         ///< chi2 / (residual count - parameter count)
  int residual_count = 0;            ///< scalar residuals used (6 per trial)
  int parameter_count = 0;
};

/// Whether a candidate was cross-validated (CandidateFit::cv_status).
enum class CvStatus {
  kNotRun,  ///< not cross-validated: it could not win (not converged, not identifiable, below
            ///< the ΔBIC threshold), a better one passed first, FitOptions::cv_candidates were
            ///< tried already, or there are fewer trials than folds
  kFailed,  ///< a fold's fit or its held-out prediction failed
  kDone,    ///< cv_error holds the held-out cost per residual
};

/// One candidate fitted in one round.
struct CandidateFit {
  Effect effect;
  std::vector<double> values;  ///< fitted parameters, user units
  std::vector<double>
      standard_errors;  ///< user units (log10 parameters: delta method); 0 if unknown
  std::vector<double> log10_standard_errors;  ///< for kLog10 parameters: SE of log10(value)
  Eigen::MatrixXd correlation;                ///< parameter correlation matrix (internal scale)
  std::vector<bool> at_bound;                 ///< parameter ended on its search range limit
  double cost = 0.0;       ///< chi2 = sum of squared weighted residuals at the optimum
  double aic = 0.0;        ///< AICc on chi2 (known-sd Gaussian likelihood, constants dropped)
  double bic = 0.0;        ///< chi2 + k ln(n)
  double delta_bic = 0.0;  ///< BIC of the current model minus this BIC (> 0: better)
  /// Parameters the candidate adds to the current model, what the criteria charge it (BIC
  /// penalty added_parameters x ln n): its own parameters, less those of chosen effects it
  /// replaces (Effect::contains).
  int added_parameters = 0;
  CvStatus cv_status = CvStatus::kNotRun;  ///< whether cv_error was computed
  /// Held-out robust cost per residual (K-fold cross-validation; 1 = at the noise), when
  /// cv_status is kDone (0 otherwise).
  double cv_error = 0.0;
  bool identifiable = true;
  std::string identifiability;  ///< why not identifiable (sensitivity, correlation), or ""
  bool converged = false;
  std::string solver_message;
  /// Why the candidate cannot be claimed whatever its BIC, or "" (trial_force: its spread is
  /// not significant against the muscles' force levels alone, or its factors follow the
  /// posture, a systematic effect: docs/identification.md "Force level and trial variation").
  std::string not_claimed;
  bool accepted = false;  ///< chosen in this round
  std::string verdict;    ///< "chosen", or why it lost
  /// Linearised ΔBIC of the screening step (score test at the current model); 0 when the round
  /// did not screen (no more candidates than FitOptions::screen_keep).
  double screen_delta_bic = 0.0;
  /// Not fitted: its linearised ΔBIC was below the screen_keep best (values and standard errors
  /// empty, converged false, delta_bic = screen_delta_bic).
  bool screened_out = false;
};

/// One round: the model before, every candidate, the winner (if any).
struct FitRound {
  int index = 0;         ///< 1-based
  ResidualStats before;  ///< residual of the current model at the start of the round
  double bic_before = 0.0;
  double cv_before = -1.0;  ///< held-out chi2 per residual of the current model
  /// ΔBIC an effect needed in this round (min_bic_improvement + look-elsewhere term).
  double bic_threshold = 0.0;
  std::vector<CandidateFit> candidates;  ///< sorted best BIC first
  /// Index in candidates of the winner; empty when nothing earned its parameters.
  std::optional<size_t> chosen;
  /// Effect ids indistinguishable from the winner at these postures (BIC within
  /// FitOptions::indistinguishable_bic and passing the thresholds).
  std::vector<std::string> indistinguishable;
  std::string summary;  ///< one readable sentence
};

/// Final verdict of FitEffects.
enum class FitVerdict {
  kNominalFits,    ///< no effect needed: the nominal model explains the data to the noise
  kExplained,      ///< effects added; the residual is at the noise level
  kUnexplained,    ///< residual stays well above the noise: something outside the library
  kNoNoiseStated,  ///< effects may have been added, but no sd given: cannot compare with noise
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
  std::string source;   ///< data file, if known
  int trial_count = 0;  ///< trials given (every row of the file)
  /// Trials fitted: trial_count, or FitOptions::max_fit_trials when the fit used a sample.
  int fitted_trial_count = 0;
  unsigned long long sample_seed = 0;  ///< FitOptions::sample_seed of the sample (if sampled)
  /// How the fitted trials were chosen, one sentence: "every trial fitted", or "20000 of
  /// 1000000 trials fitted: a uniform random sample (reservoir sampling, seed 1); ...".
  std::string sampling;
  /// True when a sample was fitted (fitted_trial_count < trial_count).
  bool sampled() const { return fitted_trial_count < trial_count; }
  bool sd_stated = false;  ///< every trial had sd columns
  ResidualStats before;    ///< nominal model, over every trial
  ResidualStats after;     ///< augmented model, over every trial
  /// The same over the fitted trials (what the rounds and the verdict used); equal to before /
  /// after when every trial was fitted.
  ResidualStats fitted_before;
  ResidualStats fitted_after;
  /// Trials (of all of them) whose |weighted residual| / sqrt(6) after the fit exceeds
  /// FitOptions::outlier_threshold (counted whatever the loss; outlier_rows names the fitted ones).
  long beyond_threshold_count = 0;
  std::vector<FitRound> rounds;
  std::vector<AppliedEffect> chosen;      ///< effects added, in order
  std::vector<CandidateFit> chosen_fits;  ///< the accepted fit of each (values, SE, ...)
  std::vector<TrialResidual> trials;      ///< the fitted trials, in their order
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
  double seconds = 0.0;  ///< wall time of the fit (FitEffectsCsv: both passes over the file)

  /// Robust loss used, and the CSV line numbers of the rows flagged as outliers.
  RobustLoss loss = RobustLoss::kHuber;
  std::vector<long> outlier_rows;
  /// Correlation matrix of all chosen parameters (joint fit), labels "effect.parameter", and
  /// one sentence per pair with |r| > 0.9 (confounded).
  std::vector<std::string> correlation_labels;
  Eigen::MatrixXd correlations;
  std::vector<std::string> confounded;
  /// trial_force (docs/identification.md "Force level and trial variation"): trial t of muscle
  /// m has the factor g_t = s_m exp(z_t), z_t ~ N(0, spread^2). The per-trial factors g_t (one
  /// per fitted trial, in trial order, relative to the nominal max_force), the spread (sd of
  /// ln factor around the muscle's level, maximum marginal likelihood) with its standard error,
  /// the likelihood ratio of the spread against the levels alone, and the lines of trials whose
  /// factor is far from their level (|ln g_t - ln s_m| > 3 sqrt(spread^2 + its variance)).
  std::vector<double> trial_factors;
  double trial_force_spread = 0.0;
  double trial_force_spread_se = 0.0;
  double trial_force_lrt = 0.0;
  std::vector<long> trial_force_outliers;
  /// trial_force: the level s_m of each muscle's trials (what force_scale fits: the factor on its
  /// max_force, written into the augmented model) with its standard error.
  struct ForceLevel {
    std::string muscle;
    double level = 1.0;           ///< x
    double standard_error = 0.0;  ///< x
    int trials = 0;               ///< trials it is the level of
  };
  std::vector<ForceLevel> trial_force_levels;
  /// trial_force's findings in words: "force_scale:GP = 0.9012 ± 0.0071 x (level of GP's 60
  /// trials); trial_force spread 0.0503 ± 0.0046 (...)"; "" without trial_force.
  std::string ForceLevelSummary() const;
  /// Where the residual lives when it stays above the noise (empty otherwise): first the
  /// trends (trial order, coordinates, muscle lengths; best first), then the muscle/axis shares.
  struct TraceItem {
    std::string
        variable;  ///< "trial order", "coordinate hip_rz", "length of GP", "muscle GP axis fx"
    double share = 0.0;  ///< fraction of the excess chi^2 it explains (0..1)
    std::string note;
  };
  std::vector<TraceItem> trace;
  std::string trace_summary;
  std::string closest_rejected;  ///< the best candidate of the last round that was not chosen

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
/// More trials than FitOptions::max_fit_trials: a sample is fitted and every trial predicted
/// (see there). FitEffectsCsv (isowrench/trial_csv.hpp) does the same from a file in bounded
/// memory.
/// @throws Error for empty trials, unknown candidate ids or max_fit_trials < 0; numerical
///         outcomes are in the report.
FitReport FitEffects(const Model& nominal, const std::vector<Trial>& trials,
                     const FitOptions& options = {});

// ---- Experiment design ---------------------------------------------------------------------

/// Options of DesignExperiment.
struct DesignOptions {
  int postures = 20;            ///< N, the trials to choose (>= 1)
  int candidates = 400;         ///< grid size when no candidate trials are given
  unsigned long long seed = 1;  ///< grid sampling (as SimulateTrials)
  double joint_range = 15.0 * 3.14159265358979323846 / 180.0;  ///< grid: nominal +- (rad)
  double noise_force = 0.002;        ///< expected noise sd (N), weights the Fisher information
  double noise_moment = 5e-5;        ///< expected noise sd (N·m)
  std::vector<std::string> muscles;  ///< grid muscles, cycled (empty = all)
  /// Grid centre (rad / m per coordinate, the model's order); empty = the nominal posture.
  /// Unused when candidate trials are given.
  Eigen::VectorXd center;
};

/// The chosen postures and what they are expected to give.
struct DesignResult {
  std::vector<Trial> chosen;            ///< the N trials (posture, muscle, activation)
  std::vector<int> chosen_index;        ///< their index among the candidates
  std::vector<std::string> labels;      ///< "effect.parameter" per parameter
  std::vector<std::string> units;       ///< user unit per parameter
  std::vector<double> values;           ///< parameter values the information is computed at
  std::vector<double> standard_errors;  ///< expected SE, user units (log10 ones: delta method)
  std::vector<double> random_standard_errors;  ///< same with N candidates taken in file/grid order
  Eigen::MatrixXd correlation;                 ///< expected parameter correlations
  std::vector<std::string> confounded;         ///< pairs with |r| > 0.9, one sentence each
  double log_det = 0.0;                        ///< log det of the Fisher information of the design
  double log_det_random = 0.0;                 ///< ... of the first N candidates
  int candidate_count = 0;
  std::vector<std::string> notes;
};

/// D-optimal choice of N trials among candidates (`candidates`, or a grid sampled like
/// SimulateTrials) for identifying the effects `effect_ids` at their initial values: the
/// Fisher information J^T W J of the whitened prediction (central differences on each
/// parameter's internal scale) is maximised in log det by greedy addition and exchange passes.
/// Per-trial effects (trial_force) are nuisance parameters and cannot be designed for (noted).
/// @throws Error for unknown ids, N < 1, fewer candidates than N, or a singular information
///         (the effects cannot be identified from any choice: message names the parameter).
DesignResult DesignExperiment(const Model& model, const std::vector<std::string>& effect_ids,
                              const std::vector<Trial>* candidates, const DesignOptions& options);

/// Write the augmented model as URDF (nominal file + chosen effects; the sensor offset and the
/// fit summary go into an XML comment since URDF cannot hold them), atomically.
/// @throws Error if the file cannot be written.
void WriteAugmentedUrdf(const FitReport& report, const std::string& path);

}  // namespace isowrench
