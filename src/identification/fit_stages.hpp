#pragma once
// The stages of FitEffects (private), one source file each:
//   problem.cpp   the least-squares problem of a set of free effects (Context: prediction, robust
//                 cost, residuals), information criteria, small helpers
//   solve.cpp     the Ceres solve, multi-start, covariance and identifiability (the only file
//                 that includes Ceres), a candidate's fit on a subset of the trials
//   screen.cpp    which candidates a round may try, and their linearised ΔBIC (score test)
//   rounds.cpp    a round: fit the screened candidates, cross-validate, select, adopt; the joint
//                 refit and the simplification after the rounds
//   trace.cpp     where an unexplained residual lives (probes and trends)
//   report.cpp    per-trial residuals, outliers, correlations, verdict, BriefReport, the URDF
//   sampling.cpp  FitEffects / FitEffectsCsv: the sample and the streaming pass over every trial
//   fit.cpp       the loop over the rounds (FitEvery) and FitCandidate
// Each stage takes explicit inputs and returns explicit results (Current, FitRound, ...).

#include <Eigen/Core>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "identification/identification_impl.hpp"
#include "isowrench/identification.hpp"

namespace isowrench::ident {

/// A parameter on its search limit: within this fraction of the (internal) range.
constexpr double kAtBoundFraction = 1e-4;
/// A parameter is "not determined" when its standard error exceeds this fraction of its
/// (internal) search range: the data do not pin it down inside the range.
constexpr double kUndeterminedFraction = 0.25;
/// Chosen parameters with |correlation| above this are named as confounded pairs.
constexpr double kConfoundedCorrelation = 0.9;
/// A per-trial force factor is flagged when |ln f - median| exceeds this many robust sd.
constexpr double kFarFactor = 3.0;
/// At most this fraction of the rows can be flagged as outliers.
constexpr double kMaxOutlierFraction = 0.15;
/// Trace items explaining less than this share of the residual are not listed.
constexpr double kTraceMinShare = 0.05;

// ---- problem.cpp ------------------------------------------------------------------------------

/// Robust loss of one row: rho(s) for the row's chi2 s (6 components), in chi2 units.
double RowLoss(double s, const FitOptions& o);

/// A context's predicted readings and what the random-effects view of per-trial force factors
/// needs (force_level.cpp).
struct Readings {
  std::vector<Vector6d> reading;  ///< predicted readings (per-trial factors applied)
  std::vector<double> factor;     ///< per-trial factor applied (1 without trial_force)
  std::vector<Vector6d> unit;     ///< reading at factor 1 without the sensor offset
  bool per_trial = false;         ///< the model solves per-trial factors (trial_force)
};

struct ForceLevels;

/// Everything the residual functor needs; owned by the caller for the duration of a solve.
struct Context {
  AugmentedModel base;       ///< current model: fixed effects already applied
  std::vector<Effect> free;  ///< effects whose parameters are fitted, in order
  std::vector<int> start;    ///< first internal parameter of each free effect
  int parameter_count = 0;   ///< least-squares parameters (per-trial ones excluded)
  const std::vector<Trial>* trials = nullptr;
  std::vector<int> subset;
  std::vector<double> weights;  ///< 6 per subset entry
  FitOptions options;
  bool rebuild = true;                 ///< a free model-stage effect: build a model per evaluation
  std::shared_ptr<const Model> model;  ///< otherwise the base model, built once
  bool cached = false;                 ///< no free posture effect either: raw wrenches once
  RawWrenches raw;
  std::vector<std::string> others;  ///< coactivated muscles (base and free)
  bool passive = false;  ///< per-trial factors (base or free): raw wrenches with the passive part
  std::string setup_message;  ///< why the base model cannot be evaluated, if so

  int FreeCount(int e) const {
    return free[e].per_trial ? 0 : static_cast<int>(free[e].parameters.size());
  }
  std::vector<double> UserValues(const double* x, int e) const;
  /// Parameters the information criteria count (BIC penalty): least squares, plus for a free
  /// per-trial effect its spread and one force level per muscle of the subset.
  int CountedParameters() const;
  /// Parameters the residual has lost (its degrees of freedom): least squares plus one factor
  /// per trial for a free per-trial effect.
  int ResidualParameters() const;
  /// Predicted readings of the subset at internal parameters x; false if any trial fails.
  bool Predict(const double* x, std::vector<Vector6d>* out, std::string* message = nullptr,
               std::vector<double>* factors = nullptr) const;
  bool Predict(const double* x, Readings* out, std::string* message = nullptr) const;
  static bool Fail(const std::string& why, std::string* message) {
    if (message) *message = why;
    return false;
  }
  /// Row chi2 (plain weighted squares) of subset entry k.
  double RowChi2(size_t k, const Vector6d& prediction) const;
  /// Robust cost: sum of RowLoss over the rows (= chi2 without a robust loss). Only for
  /// models without per-trial factors; the other form covers both.
  double Cost(const std::vector<Vector6d>& prediction) const;
  /// The model's cost in chi2 units (-2 ln L up to a constant): the robust row cost, plus for
  /// per-trial factors the marginal term of their levels and spread (ForceLevels::cost;
  /// `fixed`: the levels and spread of a training fold).
  double Cost(const Readings& r, const ForceLevels* fixed = nullptr) const;
  /// Residuals whose squares sum to Cost: each row's weighted residual times sqrt(rho(s) / s).
  void Residuals(const std::vector<Vector6d>& prediction, double* residuals) const;

  /// Raw wrenches of the last two values of the free model- and posture-stage parameters
  /// (Predict). A context is used by one thread at a time.
  struct RawCache {
    std::vector<double> key;
    RawWrenches raw;
    bool valid = false;
  };
  mutable RawCache raw_cache_[2];
  mutable int raw_cache_next_ = 0;
};

Context MakeContext(const AugmentedModel& base, const std::vector<Effect>& free,
                    const std::vector<Trial>& trials, const std::vector<int>& subset,
                    const FitOptions& options);

/// Lower or upper bounds of the internal parameters of a context.
std::vector<double> Bounds(const Context& c, bool upper);

/// AICc on chi2 (known-sd Gaussian likelihood, constants dropped), or on n ln(chi2 / n).
double Aicc(double chi2, int n, int k, bool sd_stated);
/// Every trial states its noise (sd columns).
bool AllSd(const std::vector<Trial>& trials);
/// "effect.parameter" (the effect prefix only with several free effects or always_prefix).
std::string ParameterLabel(const Context& c, int i, bool always_prefix = false);
/// Internal values of an effect's parameters: `values` (user units) or the initial values.
std::vector<double> InternalValues(const Effect& e, const std::vector<double>* values);
/// Parameters the criteria count for chosen effects (BIC penalty): a per-trial effect counts
/// its spread and one force level per muscle of the trials.
int TotalParameters(const std::vector<AppliedEffect>& effects, const std::vector<Trial>& trials);
/// Parameters the residual has lost (degrees of freedom): a per-trial effect one per trial.
int ResidualParameters(const std::vector<AppliedEffect>& effects, int trial_count);
/// Distinct muscles of the trials in `subset` (the force levels of a per-trial effect).
int MuscleCount(const std::vector<Trial>& trials, const std::vector<int>& subset);
std::vector<int> AllIndices(size_t n);
/// Robust spread of values: 1.4826 x median absolute deviation (about the median).
double RobustSpread(std::vector<double> v, double* median_out = nullptr);
/// "name = value ± se unit, ...".
std::string ValueText(const Effect& e, const std::vector<double>& v, const std::vector<double>& se);

/// A progress line (FitOptions::progress), serialised across threads and fits.
void Say(const FitOptions& options, const std::string& line);

/// Progress of one stage whose `total` items run in parallel: every finished item is reported
/// ("round 2: fitted 3 of 9 candidates (force_scale:MG, 2.2 s)"), or, when `throttled`, at most
/// one line per kProgressSeconds (and the last). Silent without FitOptions::progress.
class StageProgress {
 public:
  StageProgress(const FitOptions& options, std::string prefix, size_t total, bool throttled);
  /// Item `what` finished after `seconds` of wall time and `cpu` seconds of its thread's CPU.
  void Done(const std::string& what, double seconds, double cpu = -1.0);

 private:
  const FitOptions& options_;
  std::string prefix_;
  size_t total_;
  bool throttled_;
  std::mutex mutex_;
  size_t done_ = 0;
  std::chrono::steady_clock::time_point start_, last_;
};

/// Throttled stages report at most once per this many seconds.
constexpr double kProgressSeconds = 2.0;

/// CPU seconds the calling thread has used (POSIX CLOCK_THREAD_CPUTIME_ID; 0 where missing).
double ThreadCpuSeconds();

/// Seconds since `start`.
inline double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

/// Run task(i) for i in [0, count) on `options.threads` threads (0 = hardware concurrency);
/// each task builds its own models and workspaces, so tasks share nothing mutable.
template <class Task>
void ParallelFor(size_t count, const FitOptions& options, Task task) {
  std::atomic<size_t> next{0};
  auto work = [&]() {
    for (size_t i = next++; i < count; i = next++) task(i);
  };
  int threads =
      options.threads > 0 ? options.threads : static_cast<int>(std::thread::hardware_concurrency());
  threads = std::max(1, std::min<int>(threads, static_cast<int>(count)));
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(work);
  work();
  for (std::thread& t : pool) t.join();
}

// ---- force_level.cpp --------------------------------------------------------------------------

/// The random-effects view of per-trial force factors (docs/identification.md "Force level and
/// trial variation"): trial t of muscle m has the factor g_t = s_m exp(z_t), z_t ~ N(0, σ²).
/// Each trial's closed-form factor gives x_t = ln g_t with variance v_t = 1 / (|a_t| g_t)^2 (a_t
/// the whitened reading at factor 1); the marginal likelihood of the x_t, integrated over z_t,
/// gives the levels s_m = exp(μ_m), σ and the likelihood ratio of σ = 0 (the levels alone).
struct ForceLevels {
  std::vector<std::string> muscles;  ///< in order of first appearance
  std::vector<double> log_level;     ///< μ_m = ln s_m
  std::vector<double> log_level_se;  ///< standard error of μ_m
  std::vector<int> trials;           ///< trials of each muscle in the marginal likelihood
  double sigma = 0.0;                ///< spread: sd of ln factor around the level
  double sigma_se = 0.0;             ///< its standard error (curvature of the likelihood)
  double lrt = 0.0;   ///< -2 ln likelihood ratio of σ = 0 (levels alone) against σ (>= 0)
  double cost = 0.0;  ///< rows' robust cost + the marginal term: the model's cost (chi2 units)
  int used = 0;       ///< trials in the marginal likelihood (not outliers, positive factor)
  // Per subset entry:
  std::vector<double> x, v;  ///< ln g_t and its variance (used entries only)
  std::vector<int> muscle;   ///< index into muscles, -1 when not used
};

/// Levels and spread from a context's readings. `fixed`: evaluate the levels and spread of a
/// training fold on these rows instead (held-out cost).
ForceLevels FitForceLevels(const Context& c, const Readings& r, const ForceLevels* fixed = nullptr);

/// The smooth trend the log-factors follow, if any: a weighted quadratic in a muscle's length
/// (its trials) or in a limb coordinate (all trials), significant at p < 1e-3 / (variables)
/// and explaining at least kTrendShare of their variance. "" when they follow none.
std::string FactorTrend(const Model& model, const std::vector<Trial>& trials,
                        const std::vector<int>& subset, const ForceLevels& levels);

/// The per-trial factors follow a trend at least this share of their variance.
constexpr double kTrendShare = 0.25;

// ---- solve.cpp (Ceres) ------------------------------------------------------------------------

struct SolveResult {
  std::vector<double> x;
  double cost = 0.0;  ///< robust cost at x (chi2 without a robust loss)
  bool usable = false;
  std::string message;
};

/// Bounded Levenberg-Marquardt from x (clamped into the bounds).
SolveResult Solve(const Context& c, std::vector<double> x);
/// Solve, restarted two decades either side for a single log10 parameter stuck on a limit.
SolveResult SolveWithStarts(const Context& c, const std::vector<double>& x0);

/// Covariance, correlations and identifiability at a solution.
struct Analysis {
  std::vector<double> se_internal;
  Eigen::MatrixXd correlation;
  std::vector<bool> at_bound;
  bool identifiable = true;
  std::string reason;
};
/// Whitened Jacobian at x, SVD, covariance, correlations, identifiability.
Analysis Analyze(const Context& c, const std::vector<double>& x, double cost, bool sd_stated);

/// Fill a CandidateFit for free effect `which` (default: the last) of the context; earlier free
/// effects are the already chosen ones, refitted jointly.
CandidateFit MakeFit(const Context& c, const SolveResult& r, const Analysis& a, bool sd_stated,
                     int which = -1);

/// Fit `effect` jointly with the already chosen effects `previous` (their values are the start)
/// on the trials in `subset`. `start` (optional) is a full internal start vector; the solution's
/// full internal vector goes to `x_out`.
CandidateFit FitOnSubset(const AugmentedModel& base, const std::vector<AppliedEffect>& previous,
                         const Effect& effect, const std::vector<Trial>& trials,
                         const std::vector<int>& subset, const FitOptions& options,
                         const std::vector<double>* start, bool analyze,
                         std::vector<double>* x_out = nullptr);

// ---- rounds.cpp -------------------------------------------------------------------------------

/// The model a round starts from: chosen effects with their fits, prediction and robust cost.
struct Current {
  std::vector<AppliedEffect> effects;
  std::vector<CandidateFit> fits;
  AugmentedModel augmented;
  std::vector<Vector6d> prediction;
  double cost = 0.0;            ///< the model's cost (Context::Cost)
  int parameters = 0;           ///< parameters the criteria count (TotalParameters)
  int residual_parameters = 0;  ///< degrees of freedom the residual lost (ResidualParameters)
};

Current MakeCurrent(const LimbDescription& nominal, const std::vector<AppliedEffect>& effects,
                    const std::vector<CandidateFit>& fits, const std::vector<Trial>& trials,
                    const FitOptions& options);

/// Cross-validation folds: trial indices held out (test) and kept (train) per fold; empty when
/// there are fewer trials than folds.
struct Folds {
  std::vector<std::vector<int>> train, test;
};
Folds MakeFolds(size_t trial_count, const FitOptions& options);

/// One round: screen, fit, cross-validate, select. The winner (if any) is in r.chosen.
FitRound RunRound(int index, const Model& nominal, const std::vector<Effect>& library,
                  const Current& current, const std::vector<Trial>& trials, const Folds& folds,
                  const FitOptions& options, std::map<std::string, std::vector<double>>* solutions);

/// Adopt the round's winner: refit all chosen effects jointly (values from the candidate fit as
/// the start) and make them the current model.
Current Adopt(const Model& nominal, const Current& current, const FitRound& r,
              const std::vector<Trial>& trials, const FitOptions& options);

/// Joint fit of `effects` (values as start) on all trials: values, standard errors and the
/// full correlation matrix. usable is false when the joint solve is not usable.
struct JointFit {
  std::vector<AppliedEffect> effects;
  std::vector<CandidateFit> fits;
  Eigen::MatrixXd correlation;
  std::vector<std::string> labels;
  double cost = 0.0;
  bool usable = false;
};
JointFit FitJointly(const LimbDescription& nominal, const std::vector<AppliedEffect>& effects,
                    const std::vector<Trial>& trials, const FitOptions& options);

/// Simplify: a per-axis base compliance is replaced by the isotropic one, and an effect that
/// contains others (Effect::contains) by the subset of them with the lowest BIC, when that
/// lowers the BIC (the nested, simpler effects explain the data as well). One note per change.
bool Simplify(const Model& nominal, const std::vector<Trial>& trials, const FitOptions& options,
              Current* current, std::vector<std::string>* notes);

// ---- screen.cpp -------------------------------------------------------------------------------

/// The candidates a round may try: not chosen yet, not excluded by a chosen effect, not
/// contained in one (a candidate that contains chosen effects replaces them).
std::vector<Effect> Eligible(const std::vector<Effect>& library, const Current& current);

/// The chosen effects a candidate is fitted with: all but those it contains (it replaces them).
std::vector<AppliedEffect> Kept(const std::vector<AppliedEffect>& chosen, const Effect& candidate);

/// Whitened, robust-row-scaled sensitivity columns of context `c` at internal x0: column j is
/// (P(x0 + step_j e_j) - P(x0)) / step_j; `r` receives the scaled residual at x0. False (with
/// `message`) when a prediction fails.
bool Sensitivities(const Context& c, const std::vector<double>& x0, const std::vector<double>& step,
                   Eigen::MatrixXd* D, Eigen::VectorXd* r, std::string* message);

/// The linearised ΔBIC of each candidate at the current model (a score test); see screen.cpp.
/// `label` names the round in the progress lines ("round 2").
std::vector<double> ScreenScores(const LimbDescription& nominal, const Current& current,
                                 const std::vector<Effect>& candidates,
                                 const std::vector<Trial>& trials, const FitOptions& options,
                                 const std::string& label, std::vector<std::string>* why);

// ---- report.cpp and trace.cpp -----------------------------------------------------------------

/// Per-trial residuals, outlier rows (robust loss only), per-trial force factors.
void ReportTrials(const std::vector<Trial>& trials, const Prediction& nominal,
                  const Current& current, const FitOptions& options, FitReport* report);
/// Correlations of all chosen parameters (joint fit) and the confounded pairs.
void ReportCorrelations(const Model& nominal, const std::vector<Trial>& trials,
                        const Current& current, const FitOptions& options, FitReport* report);
/// Verdict from the residual of the rows not flagged as outliers.
void ReportVerdict(const std::vector<Trial>& trials, const Current& current,
                   const FitOptions& options, FitReport* report);
/// No non-finite number leaves the fit: standard errors and correlations that cannot be
/// computed become 0 (unknown) and the fit is marked not identifiable.
void GuardFinite(CandidateFit* f);
/// Trace: where the residual lives when it stays above the noise.
void ReportTrace(const Model& nominal, const std::vector<Trial>& trials, const Current& current,
                 const FitOptions& options, FitReport* report);

// ---- fit.cpp ----------------------------------------------------------------------------------

/// The fit of every trial given (FitEffects without a sample).
FitReport FitEvery(const Model& nominal, const std::vector<Trial>& trials,
                   const FitOptions& options);

}  // namespace isowrench::ident
