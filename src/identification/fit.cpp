// Fitting candidate effects (Ceres, numeric central differences, robust loss per row) and
// deciding between them in staged steps: screen the candidates a round may try, fit them (in
// parallel), cross-validate the best, select, adopt the winner (joint refit); after the rounds
// simplify, then report (outliers, verdict, correlations, per-trial force factors, trace).

#include <ceres/ceres.h>
#include <glog/logging.h>

#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>
#include <numeric>
#include <sstream>
#include <thread>

#include "identification/effect_type.hpp"
#include "identification/identification_impl.hpp"
#include "isowrench/error.hpp"
#include "isowrench/trial_csv.hpp"
#include "util/atomic_file.hpp"
#include "util/eigen_instantiations.hpp"
#include "util/text.hpp"

namespace isowrench {

double ident::Bic(double chi2, int n, int k, bool sd_stated) {
  double fit = sd_stated ? chi2 : n * std::log(std::max(chi2, 1e-300) / n);
  return fit + k * std::log(static_cast<double>(n));
}

double ident::LinearisedDeltaBic(const Eigen::MatrixXd& D, const Eigen::VectorXd& r, int n,
                                 bool sd_stated) {
  const double cost = r.squaredNorm();
  if (D.cols() == 0) return 0.0;
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(D);
  // Sensitivities that are all exactly 0 (an effect with no influence at its neutral value)
  // reduce nothing; the solve would divide 0 by 0.
  if (qr.rank() == 0)
    return ident::Bic(cost, n, 0, sd_stated) -
           ident::Bic(cost, n, static_cast<int>(D.cols()), sd_stated);
  const Eigen::VectorXd projected = D * qr.solve(r);
  const double reduction = std::min(projected.squaredNorm(), cost);
  return ident::Bic(cost, n, 0, sd_stated) -
         ident::Bic(std::max(cost - reduction, 1e-300), n, static_cast<int>(D.cols()), sd_stated);
}

namespace {

using ident::Bic;

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

/// Ceres logs through glog: initialise it once, silently (no "Logging before
/// InitGoogleLogging" banner, no residual block dumps); the fit reports through its own results.
void SilenceCeres() {
  static std::once_flag once;
  std::call_once(once, [] {
    if (!google::IsGoogleLoggingInitialized()) google::InitGoogleLogging("isowrench");
    FLAGS_logtostderr = false;
    FLAGS_alsologtostderr = false;
    FLAGS_stderrthreshold = google::GLOG_FATAL;
    FLAGS_minloglevel = google::GLOG_FATAL;
  });
}

/// Robust loss of one row: rho(s) for the row's chi2 s (6 components), in chi2 units.
double RowLoss(double s, const FitOptions& o) {
  if (o.loss == RobustLoss::kNone || !(s > 0)) return s;
  const double k = o.loss_scale;
  const double u = std::sqrt(s / 6.0);  // RMS noise multiple of the row
  if (o.loss == RobustLoss::kHuber) return u <= k ? s : 6.0 * (2.0 * k * u - k * k);
  return 6.0 * k * k * std::log1p(u * u / (k * k));
}

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
  ident::RawWrenches raw;
  std::vector<std::string> others;  ///< coactivated muscles (base and free)
  std::string setup_message;        ///< why the base model cannot be evaluated, if so

  int FreeCount(int e) const {
    return free[e].per_trial ? 0 : static_cast<int>(free[e].parameters.size());
  }

  std::vector<double> UserValues(const double* x, int e) const {
    std::vector<double> v;
    const Effect& effect = free[e];
    for (size_t i = 0; i < effect.parameters.size(); ++i) {
      v.push_back(effect.per_trial ? 0.0 : ident::ToUser(effect.parameters[i], x[start[e] + i]));
    }
    return v;
  }

  /// Parameters the information criteria count: least squares plus per-trial factors.
  int CountedParameters() const {
    int k = parameter_count;
    for (const Effect& e : free) k += e.per_trial ? static_cast<int>(subset.size()) : 0;
    return k;
  }

  /// Predicted readings of the subset at internal parameters x; false if any trial fails.
  bool Predict(const double* x, std::vector<Vector6d>* out, std::string* message = nullptr,
               std::vector<double>* factors = nullptr) const {
    try {
      AugmentedModel m = base;
      for (size_t e = 0; e < free.size(); ++e) {
        ident::TypeOf(free[e]).Apply(free[e], UserValues(x, static_cast<int>(e)), &m);
      }
      for (const auto& c : m.coactivation) {
        if (std::find(others.begin(), others.end(), c.first) == others.end()) {
          throw Error("coactivation of '" + c.first + "' was not prepared");
        }
      }
      if (cached) {
        ident::ComposeReadings(m, *trials, subset, raw, options, out, factors);
        return raw.all_ok() || Fail(raw.message, message);
      }
      ident::RawWrenches r;
      if (rebuild) {
        Model built(m.description);
        r = ident::EvaluateRaw(built, m.posture_offset, others, *trials, subset);
      } else {
        r = ident::EvaluateRaw(*model, m.posture_offset, others, *trials, subset);
      }
      if (!r.all_ok()) return Fail(r.message, message);
      ident::ComposeReadings(m, *trials, subset, r, options, out, factors);
      for (const Vector6d& w : *out) {
        if (!w.allFinite()) return Fail("a predicted reading is not finite", message);
      }
      return true;
    } catch (const Error& e) {
      return Fail(e.what(), message);
    }
  }

  static bool Fail(const std::string& why, std::string* message) {
    if (message) *message = why;
    return false;
  }

  /// Row chi2 (plain weighted squares) of subset entry k.
  double RowChi2(size_t k, const Vector6d& prediction) const {
    const Trial& t = (*trials)[subset[k]];
    double s = 0;
    for (int c = 0; c < 6; ++c)
      s += std::pow(weights[6 * k + c] * (t.wrench[c] - prediction[c]), 2);
    return s;
  }

  /// Robust cost: sum of RowLoss over the rows (= chi2 without a robust loss).
  double Cost(const std::vector<Vector6d>& prediction) const {
    double cost = 0.0;
    for (size_t k = 0; k < subset.size(); ++k) cost += RowLoss(RowChi2(k, prediction[k]), options);
    return cost;
  }

  /// Residuals whose squares sum to Cost: each row's weighted residual times sqrt(rho(s) / s).
  void Residuals(const std::vector<Vector6d>& prediction, double* residuals) const {
    for (size_t k = 0; k < subset.size(); ++k) {
      const Trial& t = (*trials)[subset[k]];
      const double s = RowChi2(k, prediction[k]);
      const double scale = s > 0 ? std::sqrt(RowLoss(s, options) / s) : 1.0;
      for (int c = 0; c < 6; ++c)
        residuals[6 * k + c] = scale * weights[6 * k + c] * (t.wrench[c] - prediction[k][c]);
    }
  }
};

struct ResidualFunctor {
  const Context* context;
  bool operator()(double const* const* parameters, double* residuals) const {
    std::vector<Vector6d> prediction;
    if (!context->Predict(parameters[0], &prediction)) return false;
    context->Residuals(prediction, residuals);
    for (size_t i = 0; i < 6 * context->subset.size(); ++i) {
      if (!std::isfinite(residuals[i])) return false;
    }
    return true;
  }
};

using CostFunction = ceres::DynamicNumericDiffCostFunction<ResidualFunctor, ceres::CENTRAL>;

Context MakeContext(const AugmentedModel& base, const std::vector<Effect>& free,
                    const std::vector<Trial>& trials, const std::vector<int>& subset,
                    const FitOptions& options) {
  Context c;
  c.base = base;
  c.free = free;
  c.trials = &trials;
  c.subset = subset;
  c.options = options;
  for (size_t e = 0; e < free.size(); ++e) {
    c.start.push_back(c.parameter_count);
    c.parameter_count += c.FreeCount(static_cast<int>(e));
  }
  c.weights.resize(6 * subset.size());
  for (size_t k = 0; k < subset.size(); ++k) {
    for (int j = 0; j < 6; ++j) c.weights[6 * k + j] = ident::Weight(trials[subset[k]], j, options);
  }
  c.others = ident::CoactivatedMuscles(base);
  bool posture = false;
  c.rebuild = false;
  for (const Effect& e : free) {
    if (e.kind == "coactivation" &&
        std::find(c.others.begin(), c.others.end(), e.muscle) == c.others.end()) {
      c.others.push_back(e.muscle);
    }
    posture |= e.stage == EffectStage::kPosture;
    c.rebuild |= e.stage == EffectStage::kModel;
  }
  if (!c.rebuild) {
    try {
      c.model = std::make_shared<const Model>(base.description);
      if (!posture) {
        c.raw = ident::EvaluateRaw(*c.model, base.posture_offset, c.others, trials, subset);
        c.cached = true;
      }
    } catch (const Error& e) {
      c.rebuild = true;  // let Predict report it
      c.setup_message = e.what();
    }
  }
  return c;
}

struct SolveResult {
  std::vector<double> x;
  double cost = 0.0;  ///< robust cost at x (chi2 without a robust loss)
  bool usable = false;
  std::string message;
};

std::vector<double> Bounds(const Context& c, bool upper) {
  std::vector<double> v;
  for (size_t e = 0; e < c.free.size(); ++e) {
    if (c.free[e].per_trial) continue;
    for (const EffectParameter& p : c.free[e].parameters)
      v.push_back(ident::ToInternal(p, upper ? p.upper : p.lower));
  }
  return v;
}

SolveResult Solve(const Context& c, std::vector<double> x) {
  SolveResult out;
  std::vector<Vector6d> prediction;
  std::string message;
  if (c.parameter_count == 0) {
    // Only per-trial (closed-form) parameters: nothing for the least squares.
    out.x = x;
    out.usable = c.Predict(x.data(), &prediction, &message);
    out.cost = out.usable ? c.Cost(prediction) : 0.0;
    out.message = out.usable ? "closed form" : "the model cannot be evaluated: " + message;
    return out;
  }
  std::vector<double> lo = Bounds(c, false), hi = Bounds(c, true);
  for (int i = 0; i < c.parameter_count; ++i) x[i] = std::min(std::max(x[i], lo[i]), hi[i]);
  if (!c.Predict(x.data(), &prediction, &message)) {
    out.x = x;
    out.message = "the model cannot be evaluated at the starting point: " + message;
    return out;
  }
  SilenceCeres();
  ceres::Problem problem;
  auto* cost = new CostFunction(new ResidualFunctor{&c});
  cost->AddParameterBlock(c.parameter_count);
  cost->SetNumResiduals(static_cast<int>(6 * c.subset.size()));
  problem.AddResidualBlock(cost, nullptr, x.data());
  for (int i = 0; i < c.parameter_count; ++i) {
    problem.SetParameterLowerBound(x.data(), i, lo[i]);
    problem.SetParameterUpperBound(x.data(), i, hi[i]);
  }
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_QR;
  options.max_num_iterations = c.options.max_iterations;
  options.function_tolerance = c.options.function_tolerance;
  options.logging_type = ceres::SILENT;
  options.minimizer_progress_to_stdout = false;
  options.num_threads = 1;
  // No projected line search after each successful step of the bounded problem (each costs a
  // numeric Jacobian): the trust region alone keeps the steps inside the bounds and descending.
  options.max_num_line_search_step_size_iterations = 0;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  out.x = x;
  out.usable = summary.IsSolutionUsable() && summary.termination_type != ceres::NO_CONVERGENCE;
  out.message = summary.message;
  if (!c.Predict(x.data(), &prediction, &message)) {
    out.usable = false;
    out.message = "the model cannot be evaluated at the solution: " + message;
    out.cost = 2.0 * summary.final_cost;
  } else {
    out.cost = c.Cost(prediction);
  }
  if (summary.termination_type == ceres::NO_CONVERGENCE && summary.IsSolutionUsable()) {
    // Hitting the iteration limit with a usable point still gives a valid (upper) cost.
    out.usable = true;
    out.message = "iteration limit reached: " + summary.message;
  }
  if (!std::isfinite(out.cost)) out.usable = false;
  return out;
}

/// Multi-start for single log10 parameters (stiffness or factor): a stiffness far on the rigid
/// side has no gradient, so also start two decades either side when the first solve failed or
/// stopped on a search limit away from the value at which the effect vanishes.
SolveResult SolveWithStarts(const Context& c, const std::vector<double>& x0) {
  SolveResult best = Solve(c, x0);
  const Effect& last = c.free.back();
  if (last.per_trial || last.parameters.size() != 1 ||
      last.parameters[0].scale != ParameterScale::kLog10)
    return best;
  const int k = c.parameter_count - 1;
  const EffectParameter& p = last.parameters[0];
  double lo = ident::ToInternal(p, p.lower), hi = ident::ToInternal(p, p.upper);
  double x = best.x.empty() ? x0[k] : best.x[k];
  bool at_limit = x - lo <= kAtBoundFraction * (hi - lo) || hi - x <= kAtBoundFraction * (hi - lo);
  bool far_from_neutral = std::abs(x - ident::ToInternal(p, p.neutral)) > 1.0;
  if (best.usable && !(at_limit && far_from_neutral)) return best;
  for (double shift : {-2.0, 2.0}) {
    std::vector<double> start = x0;
    start[k] += shift;
    SolveResult r = Solve(c, start);
    if (r.usable && (!best.usable || r.cost < best.cost)) best = r;
  }
  return best;
}

double Aicc(double chi2, int n, int k, bool sd_stated) {
  double fit = sd_stated ? chi2 : n * std::log(std::max(chi2, 1e-300) / n);
  double correction = n - k - 1 > 0 ? 2.0 * k * (k + 1) / (n - k - 1) : 0.0;
  return fit + 2.0 * k + correction;
}

bool AllSd(const std::vector<Trial>& trials) {
  return std::all_of(trials.begin(), trials.end(), [](const Trial& t) { return t.has_sd; });
}

struct Analysis {
  std::vector<double> se_internal;
  Eigen::MatrixXd correlation;
  std::vector<bool> at_bound;
  bool identifiable = true;
  std::string reason;
};

std::string ParameterLabel(const Context& c, int i, bool always_prefix = false) {
  for (size_t e = 0; e < c.free.size(); ++e) {
    int local = i - c.start[e];
    if (local >= 0 && local < c.FreeCount(static_cast<int>(e))) {
      return (c.free.size() > 1 || always_prefix ? c.free[e].id + "." : std::string()) +
             c.free[e].parameters[local].name;
    }
  }
  return "?";
}

/// Whitened Jacobian at x, SVD, covariance, correlations, identifiability.
Analysis Analyze(const Context& c, const std::vector<double>& x, double cost, bool sd_stated) {
  Analysis a;
  const int p = c.parameter_count;
  const int n = static_cast<int>(6 * c.subset.size());
  a.se_internal.assign(p, 0.0);
  a.at_bound.assign(p, false);
  a.correlation = Eigen::MatrixXd::Identity(p, p);
  if (p == 0) return a;
  std::vector<double> lo = Bounds(c, false), hi = Bounds(c, true);
  std::vector<std::string> reasons;
  for (int i = 0; i < p; ++i) {
    double range = hi[i] - lo[i];
    if (x[i] - lo[i] <= kAtBoundFraction * range || hi[i] - x[i] <= kAtBoundFraction * range) {
      a.at_bound[i] = true;
      reasons.push_back(ParameterLabel(c, i) +
                        " ended on its search limit (only bounded by the data)");
    }
  }
  CostFunction cost_function(new ResidualFunctor{&c});
  cost_function.AddParameterBlock(p);
  cost_function.SetNumResiduals(n);
  Eigen::VectorXd residuals(n);
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> J(n, p);
  const double* parameters[1] = {x.data()};
  double* jacobians[1] = {J.data()};
  if (!cost_function.Evaluate(parameters, residuals.data(), jacobians) || !J.allFinite()) {
    a.identifiable = false;
    a.reason = "the Jacobian cannot be evaluated at the solution";
    return a;
  }
  Eigen::MatrixXd Jd = J;
  for (int i = 0; i < p; ++i) {
    if (Jd.col(i).norm() <= c.options.min_sensitivity * std::sqrt(static_cast<double>(n))) {
      reasons.push_back(ParameterLabel(c, i) + " has near-zero sensitivity (|dr/dp| = " +
                        util::FormatNumber(Jd.col(i).norm(), 3) + ")");
    }
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(Jd, Eigen::ComputeThinV);
  Eigen::VectorXd s = svd.singularValues();
  bool rank_ok = s.size() == p && s[0] > 0 && s[p - 1] > c.options.min_singular_ratio * s[0];
  if (!rank_ok) {
    reasons.push_back("the parameters are not jointly identifiable (singular value ratio " +
                      util::FormatNumber(s[0] > 0 ? s[p - 1] / s[0] : 0.0, 3) + ")");
  } else {
    int dof = std::max(1, n - c.CountedParameters());
    double scale = sd_stated ? std::max(1.0, cost / dof) : cost / dof;
    Eigen::MatrixXd V = svd.matrixV();
    Eigen::MatrixXd cov = V * s.cwiseInverse().cwiseAbs2().asDiagonal() * V.transpose() * scale;
    for (int i = 0; i < p; ++i) a.se_internal[i] = std::sqrt(std::max(0.0, cov(i, i)));
    for (int i = 0; i < p; ++i) {
      for (int j = 0; j < p; ++j) {
        double d = a.se_internal[i] * a.se_internal[j];
        a.correlation(i, j) = d > 0 ? cov(i, j) / d : (i == j ? 1.0 : 0.0);
      }
    }
    for (int i = 0; i < p; ++i) {
      for (int j = i + 1; j < p; ++j) {
        if (std::abs(a.correlation(i, j)) > c.options.max_correlation) {
          reasons.push_back(ParameterLabel(c, i) + " and " + ParameterLabel(c, j) +
                            " are correlated (r = " + util::FormatNumber(a.correlation(i, j), 4) +
                            ")");
        }
      }
      if (a.se_internal[i] > kUndeterminedFraction * (hi[i] - lo[i])) {
        reasons.push_back(ParameterLabel(c, i) + " is not determined within its search range");
      }
    }
  }
  if (!a.correlation.allFinite()) a.correlation = Eigen::MatrixXd::Identity(p, p);
  for (double& se : a.se_internal) {
    if (!std::isfinite(se)) se = 0.0;
  }
  a.identifiable = reasons.empty();
  a.reason = util::Join(reasons, "; ");
  return a;
}

std::vector<double> InternalValues(const Effect& e, const std::vector<double>* values) {
  std::vector<double> x;
  if (e.per_trial) return x;
  for (size_t i = 0; i < e.parameters.size(); ++i) {
    const EffectParameter& p = e.parameters[i];
    x.push_back(ident::ToInternal(p, values ? (*values)[i] : p.initial));
  }
  return x;
}

int TotalParameters(const std::vector<AppliedEffect>& effects, int trial_count) {
  int k = 0;
  for (const AppliedEffect& a : effects) {
    k += a.effect.per_trial ? trial_count : static_cast<int>(a.effect.parameters.size());
  }
  return k;
}

std::vector<int> AllIndices(size_t n) {
  std::vector<int> v(n);
  std::iota(v.begin(), v.end(), 0);
  return v;
}

/// Robust spread of values: 1.4826 x median absolute deviation (about the median).
double RobustSpread(std::vector<double> v, double* median_out = nullptr) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const double median = v[v.size() / 2];
  if (median_out) *median_out = median;
  for (double& x : v) x = std::abs(x - median);
  std::sort(v.begin(), v.end());
  return 1.4826 * v[v.size() / 2];
}

/// Fill a CandidateFit for free effect `which` (default: the last) of the context; earlier free
/// effects are the already chosen ones, refitted jointly.
CandidateFit MakeFit(const Context& c, const SolveResult& r, const Analysis& a, bool sd_stated,
                     int which = -1) {
  const int e = which < 0 ? static_cast<int>(c.free.size()) - 1 : which;
  const Effect& effect = c.free[e];
  CandidateFit f;
  f.effect = effect;
  const int n = static_cast<int>(6 * c.subset.size());
  const int p0 = c.start[e];
  if (effect.per_trial) {
    // The per-trial factors are solved in closed form; the spread of ln(factor) is the value.
    std::vector<Vector6d> prediction;
    std::vector<double> factors;
    double spread = 0.0;
    if (r.usable && c.Predict(r.x.data(), &prediction, nullptr, &factors)) {
      std::vector<double> logs;
      for (double v : factors) logs.push_back(std::log(std::max(v, 1e-12)));
      spread = RobustSpread(logs);
    }
    f.values.assign(effect.parameters.size(), spread);
    f.standard_errors.assign(effect.parameters.size(), 0.0);
    f.log10_standard_errors.assign(effect.parameters.size(), 0.0);
    f.at_bound.assign(effect.parameters.size(), false);
    f.correlation = Eigen::MatrixXd::Identity(effect.parameters.size(), effect.parameters.size());
  } else {
    for (size_t i = 0; i < effect.parameters.size(); ++i) {
      const EffectParameter& p = effect.parameters[i];
      double value = ident::ToUser(p, r.x[p0 + i]);
      f.values.push_back(value);
      double se = a.se_internal[p0 + i];
      f.log10_standard_errors.push_back(p.scale == ParameterScale::kLog10 ? se : 0.0);
      f.standard_errors.push_back(p.scale == ParameterScale::kLog10 ? value * std::log(10.0) * se
                                                                    : se);
      f.at_bound.push_back(a.at_bound[p0 + i]);
    }
    const int pn = static_cast<int>(effect.parameters.size());
    f.correlation = a.correlation.block(p0, p0, pn, pn);
  }
  const int k_total = c.CountedParameters();
  f.cost = r.cost;
  f.bic = Bic(r.cost, n, k_total, sd_stated);
  f.aic = Aicc(r.cost, n, k_total, sd_stated);
  f.identifiable = a.identifiable;
  f.identifiability = a.reason;
  f.converged = r.usable;
  f.solver_message = r.message;
  return f;
}

/// Fit `effect` jointly with the already chosen effects `previous` (their values are the start)
/// on the trials in `subset`. `start` (optional) is a full internal start vector; the solution's
/// full internal vector goes to `x_out`.
CandidateFit FitOnSubset(const AugmentedModel& base, const std::vector<AppliedEffect>& previous,
                         const Effect& effect, const std::vector<Trial>& trials,
                         const std::vector<int>& subset, const FitOptions& options,
                         const std::vector<double>* start, bool analyze,
                         std::vector<double>* x_out = nullptr) {
  const bool sd_stated = AllSd(trials);
  std::vector<Effect> free;
  std::vector<double> x0;
  for (const AppliedEffect& a : previous) {
    free.push_back(a.effect);
    for (double v : InternalValues(a.effect, &a.values)) x0.push_back(v);
  }
  free.push_back(effect);
  for (double v : InternalValues(effect, nullptr)) x0.push_back(v);
  Context c = MakeContext(base, free, trials, subset, options);
  SolveResult r = start ? Solve(c, *start) : SolveWithStarts(c, x0);
  Analysis a;
  if (analyze && r.usable) {
    a = Analyze(c, r.x, r.cost, sd_stated);
  } else {
    a.se_internal.assign(c.parameter_count, 0.0);
    a.at_bound.assign(c.parameter_count, false);
    a.correlation = Eigen::MatrixXd::Identity(c.parameter_count, c.parameter_count);
    if (!r.usable) {
      a.identifiable = false;
      a.reason = "no usable solution";
    }
  }
  if (x_out) *x_out = r.x;
  return MakeFit(c, r, a, sd_stated);
}

std::string ValueText(const Effect& e, const std::vector<double>& v,
                      const std::vector<double>& se) {
  std::vector<std::string> items;
  for (size_t i = 0; i < e.parameters.size() && i < v.size(); ++i) {
    std::string s = e.parameters[i].name + " = " + util::FormatNumber(v[i], 4);
    if (i < se.size() && se[i] > 0) s += " ± " + util::FormatNumber(se[i], 2);
    s += " " + e.parameters[i].unit;
    items.push_back(s);
  }
  return util::Join(items, ", ");
}

// ---- the staged steps -------------------------------------------------------------------------

/// Cross-validation folds: trial indices held out (test) and kept (train) per fold; empty when
/// there are fewer trials than folds.
struct Folds {
  std::vector<std::vector<int>> train, test;
};

Folds MakeFolds(size_t trial_count, const FitOptions& options) {
  Folds f;
  const int folds = options.folds;
  if (folds < 2 || static_cast<int>(trial_count) < folds) return f;
  std::vector<int> order = AllIndices(trial_count);
  ident::Random rng(options.cv_seed);
  for (size_t i = order.size(); i > 1; --i) std::swap(order[i - 1], order[rng.Next() % i]);
  f.train.resize(folds);
  f.test.resize(folds);
  for (size_t i = 0; i < order.size(); ++i) {
    for (int k = 0; k < folds; ++k)
      (static_cast<int>(i % folds) == k ? f.test[k] : f.train[k]).push_back(order[i]);
  }
  for (int k = 0; k < folds; ++k) {
    std::sort(f.train[k].begin(), f.train[k].end());
    std::sort(f.test[k].begin(), f.test[k].end());
  }
  return f;
}

/// The model a round starts from: chosen effects with their fits, prediction and robust cost.
struct Current {
  std::vector<AppliedEffect> effects;
  std::vector<CandidateFit> fits;
  AugmentedModel augmented;
  std::vector<Vector6d> prediction;
  double cost = 0.0;   ///< robust cost of the prediction
  int parameters = 0;  ///< counted parameters (per-trial factors included)
};

Current MakeCurrent(const LimbDescription& nominal, const std::vector<AppliedEffect>& effects,
                    const std::vector<CandidateFit>& fits, const std::vector<Trial>& trials,
                    const FitOptions& options) {
  Current c;
  c.effects = effects;
  c.fits = fits;
  c.augmented = ApplyEffects(nominal, effects);
  Prediction p = PredictTrials(c.augmented, trials);
  if (p.failed)
    throw Error("fit: the model with the chosen effects cannot predict the trials: " + p.message);
  c.prediction = p.wrench;
  Context context =
      MakeContext(ApplyEffects(nominal, {}), {}, trials, AllIndices(trials.size()), options);
  c.cost = context.Cost(c.prediction);
  c.parameters = TotalParameters(effects, static_cast<int>(trials.size()));
  return c;
}

/// Screen: the candidates a round may try (not chosen yet, not excluded by a chosen effect).
std::vector<Effect> Screen(const std::vector<Effect>& library, const Current& current) {
  std::vector<Effect> out;
  for (const Effect& e : library) {
    bool excluded = false;
    for (const AppliedEffect& a : current.effects) excluded |= ident::Excluded(e, a.effect);
    if (!excluded) out.push_back(e);
  }
  return out;
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

/// Whitened, robust-row-scaled sensitivity columns of context `c` at internal x0: column j is
/// (P(x0 + step_j e_j) - P(x0)) / step_j. `p0` receives P(x0), `r` the scaled residual at x0
/// and `scale` the row scales. False (with `message`) when a prediction fails.
bool Sensitivities(const Context& c, const std::vector<double>& x0, const std::vector<double>& step,
                   Eigen::MatrixXd* D, Eigen::VectorXd* r, std::string* message) {
  const size_t rows = c.subset.size();
  std::vector<Vector6d> p0, pj;
  if (!c.Predict(x0.data(), &p0, message)) return false;
  std::vector<double> scale(rows);
  for (size_t k = 0; k < rows; ++k) {
    const double s = c.RowChi2(k, p0[k]);
    scale[k] = s > 0 ? std::sqrt(RowLoss(s, c.options) / s) : 1.0;
  }
  r->resize(6 * rows);
  c.Residuals(p0, r->data());
  D->resize(6 * rows, static_cast<int>(step.size()));
  for (size_t j = 0; j < step.size(); ++j) {
    std::vector<double> x = x0;
    x[j] += step[j];
    if (!c.Predict(x.data(), &pj, message)) return false;
    for (size_t k = 0; k < rows; ++k) {
      for (int m = 0; m < 6; ++m) {
        (*D)(6 * k + m, j) = scale[k] * c.weights[6 * k + m] * (pj[k][m] - p0[k][m]) / step[j];
      }
    }
  }
  return true;
}

/// Screen, step 2: the linearised ΔBIC of each candidate at the current model (a score test).
/// One sensitivity column per parameter: the prediction at a small step from the value at which
/// the effect vanishes (one decade towards the start for a stiffness, 1e-3 of the search range
/// otherwise) minus the prediction there, whitened and scaled per row like the robust
/// residuals. The chosen effects are refitted with the candidate, so their columns (at their
/// current values) are projected out first: Δχ² is the squared norm of the residual's
/// projection on the candidate's columns orthogonal to theirs. Exact for effects linear in
/// their parameters (sensor offset, gain, crosstalk, coactivation); per-trial factors are
/// re-solved inside every prediction, and per-trial candidates get +inf (always fitted). A
/// candidate that cannot be evaluated near its neutral value gets -inf and `why`.
std::vector<double> ScreenScores(const LimbDescription& nominal, const Current& current,
                                 const std::vector<Effect>& candidates,
                                 const std::vector<Trial>& trials, const FitOptions& options,
                                 std::vector<std::string>* why) {
  const bool sd_stated = AllSd(trials);
  const std::vector<int> all = AllIndices(trials.size());
  const int n = static_cast<int>(6 * trials.size());
  // Orthonormal basis of the chosen effects' columns (empty in the first round).
  Eigen::MatrixXd Q(n, 0);
  {
    std::vector<Effect> free;
    std::vector<double> x0, step;
    for (const AppliedEffect& a : current.effects) {
      free.push_back(a.effect);
      const std::vector<double> x = InternalValues(a.effect, &a.values);
      x0.insert(x0.end(), x.begin(), x.end());
      for (const EffectParameter& q : a.effect.parameters) {
        if (!a.effect.per_trial)
          step.push_back(1e-3 * (ident::ToInternal(q, q.upper) - ident::ToInternal(q, q.lower)));
      }
    }
    Eigen::MatrixXd D;
    Eigen::VectorXd r;
    std::string message;
    if (!step.empty() &&
        Sensitivities(MakeContext(ApplyEffects(nominal, {}), free, trials, all, options), x0, step,
                      &D, &r, &message)) {
      Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(D);
      if (qr.rank() > 0) Q = qr.householderQ() * Eigen::MatrixXd::Identity(n, qr.rank());
    }
  }
  std::vector<double> score(candidates.size(), 0.0);
  why->assign(candidates.size(), "");
  ParallelFor(candidates.size(), options, [&](size_t i) {
    const Effect& e = candidates[i];
    if (e.per_trial) {
      score[i] = std::numeric_limits<double>::infinity();
      return;
    }
    std::vector<double> x0, step;
    for (const EffectParameter& q : e.parameters) {
      const double neutral = ident::ToInternal(q, q.neutral);
      const double initial = ident::ToInternal(q, q.initial);
      const double range = ident::ToInternal(q, q.upper) - ident::ToInternal(q, q.lower);
      x0.push_back(neutral);
      if (q.scale == ParameterScale::kLog10 && std::abs(initial - neutral) > 0.5) {
        step.push_back(initial < neutral ? -1.0 : 1.0);
      } else {
        step.push_back(1e-3 * range);
      }
    }
    Eigen::MatrixXd D;
    Eigen::VectorXd r;
    std::string message;
    if (!Sensitivities(MakeContext(current.augmented, {e}, trials, all, options), x0, step, &D, &r,
                       &message)) {
      score[i] = -std::numeric_limits<double>::infinity();
      (*why)[i] = "cannot be evaluated near its neutral value: " + message;
      return;
    }
    if (D.cols() == 0) return;  // no parameter: nothing to gain (score 0)
    if (Q.cols() > 0) {
      D -= Q * (Q.transpose() * D);
      r -= Q * (Q.transpose() * r);
    }
    score[i] = ident::LinearisedDeltaBic(D, r, n, sd_stated);
  });
  return score;
}

/// Fit: every candidate in `fit` (indices into `candidates`) jointly with the chosen effects on
/// all trials, in parallel. Returns the fits and full internal solutions in `fit` order.
std::vector<CandidateFit> FitCandidates(const LimbDescription& nominal, const Current& current,
                                        const std::vector<Effect>& candidates,
                                        const std::vector<size_t>& fit,
                                        const std::vector<Trial>& trials, const FitOptions& options,
                                        std::vector<std::vector<double>>* solutions) {
  const AugmentedModel base = ApplyEffects(nominal, {});
  const std::vector<int> all = AllIndices(trials.size());
  std::vector<CandidateFit> fits(fit.size());
  solutions->assign(fit.size(), {});
  ParallelFor(fit.size(), options, [&](size_t i) {
    fits[i] = FitOnSubset(base, current.effects, candidates[fit[i]], trials, all, options, nullptr,
                          true, &(*solutions)[i]);
  });
  return fits;
}

/// True when a held-out error beats the current model's (the criterion Select applies).
bool CvImproves(double cv_error, double cv_before, const FitOptions& options) {
  return cv_error >= 0 &&
         cv_error <= cv_before - options.min_cv_improvement * std::min(cv_before, 1.0);
}

/// Cross-validate the candidates that could win (converged, identifiable, over the ΔBIC
/// threshold) in BIC order, at most options.cv_candidates of them, until one lowers the held-out
/// error (the ones after it cannot win: Select takes the first that passes). cv_error is the
/// held-out robust cost per residual, -2 for a failed fold. The folds run in parallel.
void CrossValidate(const LimbDescription& nominal, const Current& current,
                   const std::vector<Trial>& trials, const Folds& folds, const FitOptions& options,
                   double threshold, double cv_before,
                   const std::map<std::string, std::vector<double>>& solutions,
                   std::vector<CandidateFit>* candidates) {
  if (folds.train.empty()) return;
  const AugmentedModel base = ApplyEffects(nominal, {});
  const size_t fold_count = folds.train.size();
  int done = 0;
  for (CandidateFit& f : *candidates) {
    if (done >= options.cv_candidates) break;
    if (!f.converged || !f.identifiable || f.delta_bic < threshold) continue;
    ++done;
    const std::vector<double>& start = solutions.at(f.effect.id);
    std::vector<Effect> free;
    for (const AppliedEffect& a : current.effects) free.push_back(a.effect);
    free.push_back(f.effect);
    // Per-trial factors are solved on the held-out rows themselves (one of six residual dofs
    // per row): their cost is inflated by 6 / 5 to stay comparable.
    double inflate = 1.0;
    for (const Effect& e : free) inflate = e.per_trial ? 6.0 / 5.0 : inflate;
    std::vector<double> held_cost(fold_count, 0.0);
    std::vector<int> held_n(fold_count, -1);  // -1: the fold failed
    ParallelFor(fold_count, options, [&](size_t fold) {
      std::vector<double> x;
      CandidateFit g = FitOnSubset(base, current.effects, f.effect, trials, folds.train[fold],
                                   options, &start, false, &x);
      if (!g.converged) return;
      Context c = MakeContext(base, free, trials, folds.test[fold], options);
      std::vector<Vector6d> prediction;
      if (!c.Predict(x.data(), &prediction)) return;
      held_cost[fold] = inflate * c.Cost(prediction);
      held_n[fold] = static_cast<int>(6 * folds.test[fold].size());
    });
    double cost = 0.0;
    int n = 0;
    bool ok = true;
    for (size_t fold = 0; fold < fold_count; ++fold) {
      ok &= held_n[fold] >= 0;
      cost += held_cost[fold];
      n += std::max(0, held_n[fold]);
    }
    f.cv_error = ok && n > 0 ? cost / n : -2.0;
    if (CvImproves(f.cv_error, cv_before, options)) break;
  }
}

/// Select: each candidate's verdict; returns the index of the winner or -1.
int Select(FitRound* r, bool cross_validated, const FitOptions& options) {
  for (size_t i = 0; i < r->candidates.size(); ++i) {
    CandidateFit& f = r->candidates[i];
    std::string p = std::to_string(f.effect.parameters.size()) + " parameter" +
                    (f.effect.parameters.size() > 1 ? "s" : "");
    if (f.effect.per_trial) p = "per-trial parameters";
    if (f.screened_out) {
      f.verdict = f.solver_message != "not fitted (screened out)"
                      ? "screened out: " + f.solver_message
                      : "screened out: linearised ΔBIC = " + util::FormatNumber(f.delta_bic, 3) +
                            " at the current model, not among the " +
                            std::to_string(options.screen_keep) + " best fitted";
    } else if (!f.converged) {
      f.verdict = "fit failed: " + f.solver_message;
    } else if (f.delta_bic < r->bic_threshold) {
      f.verdict = "does not earn its " + p + ": ΔBIC = " + util::FormatNumber(f.delta_bic, 3) +
                  " < " + util::FormatNumber(r->bic_threshold, 3);
      if (!f.identifiable) f.verdict += "; not identifiable: " + f.identifiability;
    } else if (!f.identifiable) {
      f.verdict = "not identifiable from these data: " + f.identifiability;
    } else if (cross_validated && f.cv_error == -1.0 && r->chosen < 0) {
      f.verdict = "not cross-validated (the cross-validation limit was reached)";
    } else if (cross_validated && f.cv_error != -1.0 &&
               !CvImproves(f.cv_error, r->cv_before, options)) {
      f.verdict = f.cv_error < 0
                      ? "cross-validation fit failed"
                      : "held-out error not lower: " + util::FormatNumber(f.cv_error, 4) + " vs " +
                            util::FormatNumber(r->cv_before, 4) + " per residual";
    } else if (r->chosen < 0) {
      r->chosen = static_cast<int>(i);
      f.accepted = true;
      f.verdict = "chosen";
    } else {
      const CandidateFit& w = r->candidates[r->chosen];
      double gap = f.bic - w.bic;
      f.verdict = "worse than " + w.effect.id + " by ΔBIC = " + util::FormatNumber(gap, 3);
      if (gap < options.indistinguishable_bic) {
        f.verdict += " (indistinguishable at these postures)";
        r->indistinguishable.push_back(f.effect.id);
      }
    }
  }
  return r->chosen;
}

/// Joint fit of `effects` (values as start) on all trials: values, standard errors and the
/// full correlation matrix. False when the joint solve is not usable.
struct JointFit {
  std::vector<AppliedEffect> effects;
  std::vector<CandidateFit> fits;
  Eigen::MatrixXd correlation;
  std::vector<std::string> labels;
  double cost = 0.0;
  bool usable = false;
};

JointFit FitJointly(const LimbDescription& nominal, const std::vector<AppliedEffect>& effects,
                    const std::vector<Trial>& trials, const FitOptions& options) {
  JointFit out;
  out.effects = effects;
  std::vector<Effect> free;
  std::vector<double> x0;
  for (const AppliedEffect& a : effects) {
    free.push_back(a.effect);
    for (double v : InternalValues(a.effect, &a.values)) x0.push_back(v);
  }
  Context c =
      MakeContext(ApplyEffects(nominal, {}), free, trials, AllIndices(trials.size()), options);
  SolveResult r = Solve(c, x0);
  if (!r.usable) return out;
  Analysis a = Analyze(c, r.x, r.cost, AllSd(trials));
  for (size_t e = 0; e < effects.size(); ++e) {
    CandidateFit f = MakeFit(c, r, a, AllSd(trials), static_cast<int>(e));
    f.accepted = true;
    f.verdict = "chosen";
    if (!a.identifiable) f.identifiability = "joint fit: " + a.reason;
    f.identifiable = a.identifiable;
    out.effects[e].values = f.values;
    if (effects[e].effect.per_trial) out.effects[e].values = effects[e].values;
    out.fits.push_back(f);
  }
  out.correlation = a.correlation;
  for (int i = 0; i < c.parameter_count; ++i) out.labels.push_back(ParameterLabel(c, i, true));
  out.cost = r.cost;
  out.usable = true;
  return out;
}

/// Simplify: a per-axis base compliance is replaced by the isotropic one when that lowers the
/// BIC (the nested, simpler effect explains the data as well).
bool Simplify(const Model& nominal, const std::vector<Trial>& trials, const FitOptions& options,
              Current* current, std::string* note) {
  const int n = static_cast<int>(6 * trials.size());
  for (size_t i = 0; i < current->effects.size(); ++i) {
    if (current->effects[i].effect.kind != "base_per_axis") continue;
    Effect iso;
    bool found = false;
    for (const Effect& e : CandidateEffects(nominal)) {
      if (e.kind == "base_isotropic") {
        iso = e;
        found = true;
      }
    }
    if (!found) return false;
    std::vector<AppliedEffect> alt = current->effects;
    const std::vector<double>& k = alt[i].values;
    alt[i] = {iso, {std::cbrt(k[0] * k[1] * k[2])}};
    JointFit joint = FitJointly(nominal.description(), alt, trials, options);
    const int k_alt = TotalParameters(alt, static_cast<int>(trials.size()));
    const double bic_now = Bic(current->cost, n, current->parameters, AllSd(trials));
    const double bic_alt = Bic(joint.cost, n, k_alt, AllSd(trials));
    if (!joint.usable || bic_alt >= bic_now) return false;
    *note = "base_per_axis simplified to base_isotropic: the three axis stiffnesses agree (BIC " +
            util::FormatNumber(bic_now, 6) + " -> " + util::FormatNumber(bic_alt, 6) + ")";
    *current = MakeCurrent(nominal.description(), joint.effects, joint.fits, trials, options);
    return true;
  }
  return false;
}

/// One round: screen, fit, cross-validate, select. The winner (if any) is in r.chosen.
FitRound RunRound(int index, const Model& nominal, const std::vector<Effect>& library,
                  const Current& current, const std::vector<Trial>& trials, const Folds& folds,
                  const FitOptions& options,
                  std::map<std::string, std::vector<double>>* solutions) {
  const bool sd_stated = AllSd(trials);
  const int n = static_cast<int>(6 * trials.size());
  FitRound r;
  r.index = index;
  r.before = ComputeResidualStats(trials, current.prediction, current.parameters, options);
  r.bic_before = Bic(current.cost, n, current.parameters, sd_stated);
  r.cv_before = current.cost / n;
  const std::vector<Effect> screened = Screen(library, current);
  // Rank by the linearised ΔBIC and fit the screen_keep best (all when there are few).
  std::vector<size_t> order(screened.size());
  std::iota(order.begin(), order.end(), size_t{0});
  std::vector<double> score(screened.size(), 0.0);
  std::vector<std::string> why;
  const bool screening =
      options.screen_keep > 0 && static_cast<int>(screened.size()) > options.screen_keep;
  auto stage = [&](const std::string& what) {
    if (options.progress) options.progress("round " + std::to_string(index) + ": " + what);
  };
  if (screening) {
    stage("screening " + std::to_string(screened.size()) +
          " candidates (linearised ΔBIC at the current model)");
    score = ScreenScores(nominal.description(), current, screened, trials, options, &why);
    // A score that is not a number ranks last (a NaN in the comparison would break the
    // ordering the sort needs, and with it which candidates are fitted).
    for (double& s : score) {
      if (std::isnan(s)) s = -std::numeric_limits<double>::infinity();
    }
    std::stable_sort(order.begin(), order.end(),
                     [&](size_t a, size_t b) { return score[a] > score[b]; });
  }
  std::vector<size_t> keep, drop;
  for (size_t rank = 0; rank < order.size(); ++rank) {
    const size_t i = order[rank];
    const bool kept =
        !screening || static_cast<int>(rank) < options.screen_keep || screened[i].per_trial;
    (kept ? keep : drop).push_back(i);
  }
  stage("fitting " + std::to_string(keep.size()) + " of " + std::to_string(screened.size()) +
        " candidates");
  std::vector<std::vector<double>> x;
  std::vector<CandidateFit> fits =
      FitCandidates(nominal.description(), current, screened, keep, trials, options, &x);
  solutions->clear();
  for (size_t i = 0; i < keep.size(); ++i) {
    fits[i].delta_bic = r.bic_before - fits[i].bic;
    if (screening) fits[i].screen_delta_bic = score[keep[i]];
    (*solutions)[screened[keep[i]].id] = x[i];
    r.candidates.push_back(std::move(fits[i]));
  }
  for (size_t i : drop) {
    CandidateFit f;
    f.effect = screened[i];
    f.correlation = Eigen::MatrixXd::Identity(0, 0);
    f.screened_out = true;
    f.screen_delta_bic = std::isfinite(score[i]) ? score[i] : -1.0;
    f.delta_bic = f.screen_delta_bic;
    f.cost = -1.0;
    f.bic = -1.0;
    f.aic = -1.0;
    f.identifiable = false;
    f.identifiability = "not assessed (screened out, not fitted)";
    f.solver_message = why[i].empty() ? "not fitted (screened out)" : why[i];
    r.candidates.push_back(std::move(f));
  }
  r.bic_threshold =
      options.min_bic_improvement + (options.look_elsewhere && r.candidates.size() > 1
                                         ? 2.0 * std::log(static_cast<double>(r.candidates.size()))
                                         : 0.0);
  std::stable_sort(r.candidates.begin(), r.candidates.end(),
                   [](const CandidateFit& a, const CandidateFit& b) {
                     if (a.screened_out != b.screened_out) return b.screened_out;
                     if (a.screened_out) return a.screen_delta_bic > b.screen_delta_bic;
                     if (a.converged != b.converged) return a.converged;
                     return a.bic < b.bic;
                   });
  stage("cross-validating the best candidates (" + std::to_string(folds.train.size()) + " folds)");
  CrossValidate(nominal.description(), current, trials, folds, options, r.bic_threshold,
                r.cv_before, *solutions, &r.candidates);
  Select(&r, !folds.train.empty(), options);
  if (r.chosen < 0) {
    r.summary = "no candidate earns its parameters";
    if (!r.candidates.empty())
      r.summary += " (best: " + r.candidates[0].effect.id + ", " + r.candidates[0].verdict + ")";
  } else {
    const CandidateFit& w = r.candidates[r.chosen];
    r.summary = "added " + w.effect.id + " (" + ValueText(w.effect, w.values, w.standard_errors) +
                "), ΔBIC = " + util::FormatNumber(w.delta_bic, 4);
  }
  return r;
}

/// Adopt the round's winner: refit all chosen effects jointly (values from the candidate fit as
/// the start) and make them the current model.
Current Adopt(const Model& nominal, const Current& current, const FitRound& r,
              const std::vector<Trial>& trials, const FitOptions& options) {
  const CandidateFit& winner = r.candidates[r.chosen];
  std::vector<AppliedEffect> chosen = current.effects;
  chosen.push_back({winner.effect, winner.values});
  std::vector<CandidateFit> fits = current.fits;
  fits.push_back(winner);
  if (chosen.size() > 1) {
    JointFit joint = FitJointly(nominal.description(), chosen, trials, options);
    if (joint.usable && joint.cost <= winner.cost * (1 + 1e-9) + 1e-12) {
      for (size_t e = 0; e < chosen.size(); ++e) {
        chosen[e].values = joint.effects[e].values;
        CandidateFit f = joint.fits[e];
        f.delta_bic = fits[e].delta_bic;
        f.cv_error = fits[e].cv_error;
        fits[e] = f;
      }
    }
  }
  return MakeCurrent(nominal.description(), chosen, fits, trials, options);
}

// ---- report steps ----------------------------------------------------------------------------

/// Per-trial residuals, outlier rows (robust loss only), per-trial force factors.
void ReportTrials(const std::vector<Trial>& trials, const Prediction& nominal,
                  const Current& current, const FitOptions& options, FitReport* report) {
  for (size_t k = 0; k < trials.size(); ++k) {
    TrialResidual t;
    t.line = trials[k].line;
    t.muscle = trials[k].muscle;
    t.activation = trials[k].activation;
    t.measured = trials[k].wrench;
    t.before = trials[k].wrench - nominal.wrench[k];
    t.after = trials[k].wrench - current.prediction[k];
    double nb = 0, na = 0;
    for (int c = 0; c < 6; ++c) {
      double w = ident::Weight(trials[k], c, options);
      nb += std::pow(w * t.before[c], 2);
      na += std::pow(w * t.after[c], 2);
    }
    t.normalized_before = std::sqrt(nb / 6);
    t.normalized_after = std::sqrt(na / 6);
    report->trials.push_back(t);
    if (options.loss != RobustLoss::kNone && t.normalized_after > options.outlier_threshold) {
      report->outlier_rows.push_back(t.line);
    }
  }
  // Outliers are a minority by definition: when more rows than kMaxOutlierFraction are far off,
  // the model misses something everywhere and no row is singled out.
  if (report->outlier_rows.size() > kMaxOutlierFraction * trials.size()) {
    report->notes.push_back(std::to_string(report->outlier_rows.size()) + " of " +
                            std::to_string(trials.size()) + " rows are beyond " +
                            util::FormatNumber(options.outlier_threshold, 3) +
                            " x noise: a systematic misfit, not outliers (no row flagged)");
    report->outlier_rows.clear();
  }
  if (current.augmented.trial_force) {
    Prediction p = PredictTrials(current.augmented, trials, &report->trial_factors);
    std::vector<double> logs;
    for (double f : report->trial_factors) logs.push_back(std::log(std::max(f, 1e-12)));
    double median = 0;
    report->trial_force_spread = RobustSpread(logs, &median);
    for (size_t k = 0; k < logs.size(); ++k) {
      if (std::abs(logs[k] - median) > kFarFactor * std::max(report->trial_force_spread, 1e-12)) {
        report->trial_force_outliers.push_back(trials[k].line);
      }
    }
  }
}

/// Correlations of all chosen parameters (joint fit) and the confounded pairs.
void ReportCorrelations(const Model& nominal, const std::vector<Trial>& trials,
                        const Current& current, const FitOptions& options, FitReport* report) {
  if (current.effects.empty()) return;
  JointFit joint = FitJointly(nominal.description(), current.effects, trials, options);
  if (!joint.usable) return;
  report->correlation_labels = joint.labels;
  report->correlations = joint.correlation;
  for (int i = 0; i < joint.correlation.rows(); ++i) {
    for (int j = i + 1; j < joint.correlation.cols(); ++j) {
      if (std::abs(joint.correlation(i, j)) > kConfoundedCorrelation) {
        report->confounded.push_back(
            joint.labels[i] + " and " + joint.labels[j] +
            " are confounded (r = " + util::FormatNumber(joint.correlation(i, j), 3) + ")");
      }
    }
  }
}

/// Share of the weighted residual explained by a quadratic in x (per component, summed).
double QuadraticShare(const std::vector<Eigen::Matrix<double, 6, 1>>& r,
                      const std::vector<double>& x, const std::vector<bool>& use, double total) {
  std::vector<int> rows;
  for (size_t k = 0; k < x.size(); ++k) {
    if (use[k] && std::isfinite(x[k])) rows.push_back(static_cast<int>(k));
  }
  if (rows.size() < 8 || !(total > 0)) return 0.0;
  double mean = 0, sd = 0;
  for (int k : rows) mean += x[k];
  mean /= rows.size();
  for (int k : rows) sd += std::pow(x[k] - mean, 2);
  sd = std::sqrt(sd / rows.size());
  if (!(sd > 0)) return 0.0;
  Eigen::MatrixXd A(rows.size(), 3);
  Eigen::MatrixXd B(rows.size(), 6);
  for (size_t i = 0; i < rows.size(); ++i) {
    const double z = (x[rows[i]] - mean) / sd;
    A.row(i) << 1.0, z, z * z;
    B.row(i) = r[rows[i]].transpose();
  }
  Eigen::MatrixXd coef = A.colPivHouseholderQr().solve(B);
  Eigen::MatrixXd fitted = A * coef;
  // Explained beyond the constant (a constant is the sensor offset, not a trend).
  Eigen::RowVectorXd means = B.colwise().mean();
  double explained = 0;
  for (int c = 0; c < 6; ++c) explained += (fitted.col(c).array() - means[c]).square().sum();
  return explained / total;
}

/// Trace: where the residual lives when it stays above the noise.
void ReportTrace(const Model& nominal, const std::vector<Trial>& trials, const Current& current,
                 const FitOptions& options, FitReport* report) {
  std::vector<bool> use(trials.size(), true);
  for (size_t k = 0; k < trials.size(); ++k) {
    use[k] = std::find(report->outlier_rows.begin(), report->outlier_rows.end(), trials[k].line) ==
             report->outlier_rows.end();
  }
  std::vector<Eigen::Matrix<double, 6, 1>> r(trials.size());
  double total = 0;
  for (size_t k = 0; k < trials.size(); ++k) {
    for (int c = 0; c < 6; ++c) {
      r[k][c] =
          ident::Weight(trials[k], c, options) * (trials[k].wrench[c] - current.prediction[k][c]);
    }
    if (use[k]) total += r[k].squaredNorm();
  }
  std::vector<FitReport::TraceItem> items;
  std::vector<double> order(trials.size());
  for (size_t k = 0; k < trials.size(); ++k) order[k] = static_cast<double>(k);
  items.push_back({"trial order", QuadraticShare(r, order, use, total), "drift over the session"});
  ident::TrialMapper mapper(nominal);
  std::vector<Eigen::VectorXd> q(trials.size());
  for (size_t k = 0; k < trials.size(); ++k) {
    try {
      mapper.Map(trials[k], &q[k]);
    } catch (const Error&) {
      q[k] =
          Eigen::VectorXd::Constant(nominal.dof_count(), std::numeric_limits<double>::quiet_NaN());
    }
  }
  for (int j = 0; j < nominal.dof_count(); ++j) {
    if (nominal.joint(j).role != JointRole::kLimb) continue;
    std::vector<double> x(trials.size());
    for (size_t k = 0; k < trials.size(); ++k) x[k] = q[k][j];
    items.push_back(
        {"coordinate " + nominal.joint_names()[j], QuadraticShare(r, x, use, total),
         "a trend with this coordinate (joint_offset, a stiffness or a path outside the library)"});
  }
  for (int m = 0; m < nominal.muscle_count(); ++m) {
    const std::string& name = nominal.muscle(m).name;
    items.push_back(
        {"length of " + name,
         QuadraticShare(r, ident::MuscleLengths(nominal, name, trials), use, total),
         "a trend with the muscle's length (force-length behaviour outside the model)"});
  }
  // Probes that name a variable directly: the share of the residual in the span of the wrench
  // sensitivity to a small stiffness at each coordinate, to an offset of each coordinate, to
  // each muscle's force and to its path points (first-order columns from small steps).
  std::vector<double> chance(items.size(), 2.0 * 6.0);  // columns of each quadratic trend
  Eigen::VectorXd rv = Eigen::VectorXd::Zero(6 * trials.size());
  int used = 0;
  for (size_t k = 0; k < trials.size(); ++k) {
    if (!use[k]) continue;
    rv.segment<6>(6 * k) = r[k];
    ++used;
  }
  struct Probe {
    std::string variable, note;
    std::vector<AugmentedModel> models;
  };
  std::vector<Probe> probes;
  const AugmentedModel& at = current.augmented;
  for (int j = 0; j < nominal.dof_count(); ++j) {
    if (nominal.joint(j).role != JointRole::kLimb) continue;
    const std::string& name = nominal.joint_names()[j];
    Probe stiffness{"stiffness at " + name,
                    "a passive stiffness of this coordinate outside the model and the library",
                    {}};
    try {
      // A stiffness small against what the transducer opposes to this coordinate (j^T S_t j):
      // the wrench changes linearly with it.
      const Eigen::VectorXd jc = ident::NominalJacobianColumn(nominal, name);
      const double scale = jc.dot(nominal.transducer().stiffness.asDiagonal() * jc);
      const double k0 = FindCoordinate(at.description, name).stiffness;
      AugmentedModel m = at;
      m.description = WithJointStiffness(
          at.description, name, k0 + 1e-4 * (std::isfinite(scale) && scale > 0 ? scale : 1.0));
      stiffness.models.push_back(std::move(m));
    } catch (const Error&) {
    }
    probes.push_back(std::move(stiffness));
    Probe offset{"offset of " + name, "the recorded angle of this coordinate is off", {}};
    AugmentedModel m = at;
    m.posture_offset[name] +=
        nominal.joint(j).type == JointType::kPrismatic ? 1e-5 : 1e-4;  // m or rad
    offset.models.push_back(std::move(m));
    probes.push_back(std::move(offset));
  }
  for (size_t i = 0; i < at.description.muscles.size(); ++i) {
    const MuscleSpec& muscle = at.description.muscles[i];
    Probe force{"force of " + muscle.name,
                "this muscle's force differs from the model (max force, force-length)",
                {}};
    AugmentedModel m = at;
    m.description.muscles[i].max_force *= 1.001;
    force.models.push_back(std::move(m));
    probes.push_back(std::move(force));
    Probe path{"path of " + muscle.name,
               "this muscle's path points (moment arms) differ from the model",
               {}};
    for (size_t p = 0; p < muscle.path.size(); ++p) {
      for (int axis = 0; axis < 3; ++axis) {
        AugmentedModel shifted = at;
        shifted.description.muscles[i].path[p].position[axis] += 1e-5;  // m
        path.models.push_back(std::move(shifted));
      }
    }
    probes.push_back(std::move(path));
  }
  // Whitened prediction changes of a set of perturbed models (outlier rows zero).
  auto columns = [&](const std::vector<AugmentedModel>& models) {
    Eigen::MatrixXd D = Eigen::MatrixXd::Zero(6 * trials.size(), models.size());
    for (size_t c = 0; c < models.size(); ++c) {
      Prediction p;
      try {
        p = PredictTrials(models[c], trials);
      } catch (const Error&) {
        continue;
      }
      for (size_t k = 0; k < trials.size(); ++k) {
        if (!use[k] || !p.ok[k]) continue;
        for (int m = 0; m < 6; ++m) {
          D(6 * k + m, c) =
              ident::Weight(trials[k], m, options) * (p.wrench[k][m] - current.prediction[k][m]);
        }
      }
    }
    if (!D.allFinite()) D.setZero();
    return D;
  };
  // The tentative effects stay in the model and would be refitted with the missing variable:
  // what a probe explains is measured orthogonally to their columns (a score test), so a
  // variable they partly absorbed is still found.
  std::vector<AugmentedModel> chosen_models;
  for (size_t e = 0; e < current.effects.size(); ++e) {
    const AppliedEffect& a = current.effects[e];
    if (a.effect.per_trial) continue;
    for (size_t j = 0; j < a.values.size(); ++j) {
      const EffectParameter& q = a.effect.parameters[j];
      std::vector<AppliedEffect> stepped = current.effects;
      const double step = 1e-3 * (ident::ToInternal(q, q.upper) - ident::ToInternal(q, q.lower));
      stepped[e].values[j] = ident::ToUser(q, ident::ToInternal(q, a.values[j]) + step);
      try {
        chosen_models.push_back(ApplyEffects(nominal.description(), stepped));
      } catch (const Error&) {
      }
    }
  }
  Eigen::MatrixXd Q(6 * trials.size(), 0);
  if (!chosen_models.empty()) {
    Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(columns(chosen_models));
    if (qr.rank() > 0)
      Q = qr.householderQ() * Eigen::MatrixXd::Identity(6 * trials.size(), qr.rank());
  }
  std::vector<double> probe_share(probes.size(), 0.0);
  std::vector<int> probe_rank(probes.size(), 0);
  ParallelFor(probes.size(), options, [&](size_t i) {
    Eigen::MatrixXd D = columns(probes[i].models);
    if (D.cols() == 0 || !(total > 0)) return;
    if (Q.cols() > 0) D -= Q * (Q.transpose() * D);
    Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(D);
    probe_rank[i] = static_cast<int>(qr.rank());
    if (probe_rank[i] == 0) return;
    const Eigen::VectorXd projected = D * qr.solve(rv);
    probe_share[i] = std::min(1.0, projected.squaredNorm() / total);
  });
  for (size_t i = 0; i < probes.size(); ++i) {
    if (probe_rank[i] == 0) continue;
    items.push_back({probes[i].variable, probe_share[i], probes[i].note});
    chance.push_back(probe_rank[i]);
  }
  // Trends first (best first), then where the residual sits: per muscle and axis.
  // Ranked by the share beyond what as many random directions would explain in noise (a trend
  // has 12 columns, a stiffness probe 1), so small probes are not outranked by wide trends.
  {
    std::vector<size_t> rank(items.size());
    std::iota(rank.begin(), rank.end(), size_t{0});
    const double n = std::max(1, 6 * used);
    std::stable_sort(rank.begin(), rank.end(), [&](size_t a, size_t b) {
      return items[a].share - chance[a] / n > items[b].share - chance[b] / n;
    });
    std::vector<FitReport::TraceItem> sorted;
    for (size_t i : rank) sorted.push_back(items[i]);
    items = std::move(sorted);
  }
  const size_t trends = items.size();
  // Per muscle and axis: share of the residual in the trials of each muscle, per component.
  const char* axes[6] = {"fx", "fy", "fz", "mx", "my", "mz"};
  std::map<std::string, Vector6d> per_muscle;
  for (size_t k = 0; k < trials.size(); ++k) {
    if (!use[k]) continue;
    Vector6d& s = per_muscle.emplace(trials[k].muscle, Vector6d::Zero()).first->second;
    s += r[k].cwiseAbs2();
  }
  for (const auto& m : per_muscle) {
    for (int c = 0; c < 6; ++c) {
      items.push_back({"muscle " + m.first + " axis " + axes[c],
                       total > 0 ? m.second[c] / total : 0.0,
                       "share of the residual in this muscle's trials on this axis"});
    }
  }
  std::stable_sort(items.begin() + trends, items.end(),
                   [](const FitReport::TraceItem& a, const FitReport::TraceItem& b) {
                     return a.share > b.share;
                   });
  std::vector<std::string> top_trends, top_axes;
  for (size_t k = 0; k < items.size(); ++k) {
    const FitReport::TraceItem& i = items[k];
    if (!(i.share >= kTraceMinShare) || !std::isfinite(i.share)) continue;
    report->trace.push_back(i);
    std::vector<std::string>& top = k < trends ? top_trends : top_axes;
    if (top.size() < 2)
      top.push_back(i.variable + " (" + util::FormatNumber(100 * i.share, 3) + " %)");
  }
  if (!top_trends.empty()) report->trace_summary = "it follows " + util::Join(top_trends, ", ");
  if (!top_axes.empty()) {
    report->trace_summary += (report->trace_summary.empty() ? "it sits in " : "; it sits in ") +
                             util::Join(top_axes, ", ");
  }
  if (!report->closest_rejected.empty()) {
    report->trace_summary += (report->trace_summary.empty() ? "" : "; ") +
                             std::string("closest rejected candidate: ") + report->closest_rejected;
  }
}

/// Verdict from the residual of the rows not flagged as outliers.
void ReportVerdict(const std::vector<Trial>& trials, const Current& current,
                   const FitOptions& options, FitReport* report) {
  std::ostringstream m;
  if (!report->sd_stated) {
    report->verdict = FitVerdict::kNoNoiseStated;
    m << "the data state no standard deviations, so the residual cannot be compared with the "
         "noise; weighted with "
      << util::FormatNumber(options.default_sd_force, 3) << " N and "
      << util::FormatNumber(options.default_sd_moment, 3) << " N·m";
    report->verdict_message = m.str();
    return;
  }
  std::vector<Trial> kept;
  std::vector<Vector6d> kept_prediction;
  for (size_t k = 0; k < trials.size(); ++k) {
    if (std::find(report->outlier_rows.begin(), report->outlier_rows.end(), trials[k].line) !=
        report->outlier_rows.end()) {
      continue;
    }
    kept.push_back(trials[k]);
    kept_prediction.push_back(current.prediction[k]);
  }
  const ResidualStats s = ComputeResidualStats(kept, kept_prediction, current.parameters, options);
  const int dof = std::max(1, s.residual_count - current.parameters);
  const double reduced = s.chi2 / dof;
  const double threshold = 1.0 + options.unexplained_sigmas * std::sqrt(2.0 / dof);
  const double multiple = std::sqrt(reduced);
  const std::string outliers =
      report->outlier_rows.empty()
          ? ""
          : " (" + std::to_string(report->outlier_rows.size()) + " outlier row(s) left out)";
  if (reduced > threshold) {
    report->verdict = FitVerdict::kUnexplained;
    report->effects_claimed = report->chosen.empty();
    m << "after " << report->chosen.size() << " effect(s) the residual is "
      << util::FormatNumber(multiple, 3) << " x the stated noise (reduced chi^2 "
      << util::FormatNumber(reduced, 4) << " > " << util::FormatNumber(threshold, 4) << ")"
      << outliers << "; something outside the candidate library is missing";
    if (!report->chosen.empty()) {
      m << "; the effects tried reduce the residual but do not explain it, so none is claimed "
           "(tentative partial "
           "fits below)";
    }
  } else if (report->chosen.empty()) {
    report->verdict = FitVerdict::kNominalFits;
    m << "the nominal model explains the data to the noise (residual "
      << util::FormatNumber(multiple, 3) << " x noise)" << outliers << "; no effect is claimed";
  } else {
    report->verdict = FitVerdict::kExplained;
    std::vector<std::string> ids;
    for (const AppliedEffect& a : report->chosen) ids.push_back(a.effect.id);
    m << "explained by " << util::Join(ids, " + ") << ": residual from "
      << util::FormatNumber(std::sqrt(report->fitted_before.chi2 /
                                      std::max(1, report->fitted_before.residual_count)),
                            3)
      << " x noise to " << util::FormatNumber(multiple, 3) << " x noise" << outliers;
  }
  report->verdict_message = m.str();
}

/// No non-finite number leaves the fit: standard errors and correlations that cannot be
/// computed become 0 (unknown) and the fit is marked not identifiable.
void GuardFinite(CandidateFit* f) {
  for (size_t i = 0; i < f->values.size(); ++i) {
    if (!std::isfinite(f->standard_errors[i]) || !std::isfinite(f->log10_standard_errors[i])) {
      f->standard_errors[i] = 0.0;
      f->log10_standard_errors[i] = 0.0;
      f->identifiable = false;
    }
  }
  if (!f->correlation.allFinite())
    f->correlation.setIdentity(f->correlation.rows(), f->correlation.cols());
  for (double* v : {&f->cost, &f->aic, &f->bic, &f->delta_bic, &f->cv_error}) {
    if (!std::isfinite(*v)) *v = -1.0;
  }
}

}  // namespace

const char* FitVerdictName(FitVerdict verdict) {
  switch (verdict) {
    case FitVerdict::kNominalFits: return "nominal model fits";
    case FitVerdict::kExplained: return "explained";
    case FitVerdict::kUnexplained: return "unexplained residual";
    case FitVerdict::kNoNoiseStated: return "no noise stated";
  }
  return "?";
}

const char* RobustLossName(RobustLoss loss) {
  switch (loss) {
    case RobustLoss::kNone: return "none";
    case RobustLoss::kHuber: return "huber";
    case RobustLoss::kCauchy: return "cauchy";
  }
  return "?";
}

RobustLoss ParseRobustLoss(const std::string& text) {
  for (RobustLoss l : {RobustLoss::kNone, RobustLoss::kHuber, RobustLoss::kCauchy}) {
    if (text == RobustLossName(l)) return l;
  }
  throw Error("--loss '" + text + "': expected one of huber, cauchy, none");
}

CandidateFit FitCandidate(const AugmentedModel& current, const Effect& effect,
                          const std::vector<Trial>& trials, const FitOptions& options) {
  // The already chosen effects stay fixed: a context whose only free effect is `effect`, on a
  // base that already holds them. BIC counts their parameters too.
  CandidateFit f =
      FitOnSubset(current, {}, effect, trials, AllIndices(trials.size()), options, nullptr, true);
  const int n = static_cast<int>(6 * trials.size());
  const int k = TotalParameters(current.effects, static_cast<int>(trials.size())) +
                (effect.per_trial ? static_cast<int>(trials.size())
                                  : static_cast<int>(effect.parameters.size()));
  f.bic = Bic(f.cost, n, k, AllSd(trials));
  f.aic = Aicc(f.cost, n, k, AllSd(trials));
  GuardFinite(&f);
  return f;
}

namespace {

/// The fit of every trial given (FitEffects without a sample).
FitReport FitEvery(const Model& nominal, const std::vector<Trial>& trials,
                   const FitOptions& options) {
  auto clock_start = std::chrono::steady_clock::now();
  if (trials.empty()) throw Error("fit: no trials");
  if (options.loss != RobustLoss::kNone &&
      !(options.loss_scale > 0 && std::isfinite(options.loss_scale))) {
    throw Error("fit: the robust loss scale must be > 0 (noise multiples), got " +
                util::FormatNumber(options.loss_scale));
  }
  FitReport report;
  report.model_name = nominal.name();
  report.source = nominal.description().source;
  report.trial_count = static_cast<int>(trials.size());
  report.fitted_trial_count = report.trial_count;
  report.sampling = "every trial fitted";
  report.sd_stated = AllSd(trials);
  report.loss = options.loss;

  std::vector<Effect> library = CandidateEffects(nominal);
  if (!options.candidates.empty()) {
    std::vector<Effect> chosen;
    for (const std::string& id : options.candidates) chosen.push_back(FindEffect(nominal, id));
    library = chosen;
  }
  const Folds folds = MakeFolds(trials.size(), options);

  Prediction nominal_prediction = PredictTrials(nominal, trials);
  if (nominal_prediction.failed) {
    throw Error("fit: the nominal model cannot predict the trials: " + nominal_prediction.message);
  }
  report.before = ComputeResidualStats(trials, nominal_prediction.wrench, 0, options);
  report.fitted_before = report.before;
  Current current = MakeCurrent(nominal.description(), {}, {}, trials, options);

  for (int round = 1; round <= options.max_rounds; ++round) {
    std::map<std::string, std::vector<double>> solutions;
    FitRound r = RunRound(round, nominal, library, current, trials, folds, options, &solutions);
    for (const CandidateFit& f : r.candidates) {
      if (!f.accepted && report.closest_rejected.empty() && f.converged) {
        report.closest_rejected = f.effect.id + " (" + f.verdict + ")";
      }
    }
    if (r.chosen < 0) {
      report.rounds.push_back(std::move(r));
      break;
    }
    report.closest_rejected.clear();
    const CandidateFit& winner = r.candidates[r.chosen];
    if (!r.indistinguishable.empty()) {
      report.indistinguishable.push_back(
          "At the sampled postures " + winner.effect.id + " cannot be told apart from " +
          util::Join(r.indistinguishable, ", ") + " (BIC within " +
          util::FormatNumber(options.indistinguishable_bic, 3) + ")");
    }
    current = Adopt(nominal, current, r, trials, options);
    report.rounds.push_back(std::move(r));
  }

  if (options.progress) options.progress("report: residuals, correlations, verdict");
  std::string note;
  if (Simplify(nominal, trials, options, &current, &note)) report.notes.push_back(note);

  report.chosen = current.effects;
  report.chosen_fits = current.fits;
  for (CandidateFit& f : report.chosen_fits) GuardFinite(&f);
  report.augmented = current.augmented;
  report.after = ComputeResidualStats(trials, current.prediction, current.parameters, options);
  report.fitted_after = report.after;
  ReportTrials(trials, nominal_prediction, current, options, &report);
  for (const TrialResidual& t : report.trials) {
    if (t.normalized_after > options.outlier_threshold) ++report.beyond_threshold_count;
  }
  ReportCorrelations(nominal, trials, current, options, &report);
  ReportVerdict(trials, current, options, &report);
  for (const std::string& slip : UnitSlips(nominal, trials, nominal_prediction.wrench))
    report.verdict_message += "; likely slip: " + slip;  // trial_csv.cpp (issue 26)
  if (report.verdict == FitVerdict::kUnexplained) {
    if (options.progress) options.progress("report: tracing the unexplained residual");
    ReportTrace(nominal, trials, current, options, &report);
  }
  report.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - clock_start).count();
  return report;
}

/// The second pass of a sampled fit: every trial predicted by the nominal and the augmented
/// model, kChunk trials at a time, into the report's before / after (memory: one chunk).
class EveryTrialPass {
 public:
  static constexpr size_t kChunk = 4096;
  EveryTrialPass(const Model& nominal, const FitReport& report, const FitOptions& options)
      : nominal_(nominal), augmented_(report.augmented), options_(options) {
    chunk_.resize(kChunk);
    for (const AppliedEffect& a : report.chosen) {
      if (a.effect.per_trial) {
        per_trial_ = true;
      } else {
        fixed_parameters_ += static_cast<int>(a.effect.parameters.size());
      }
    }
  }
  void Add(const Trial& t) {
    chunk_[used_++] = t;
    if (used_ == kChunk) Flush();
  }
  /// Fill the report's whole-data statistics. @returns the trials seen.
  long Finish(FitReport* report) {
    Flush();
    const long n = before_.count();
    const long parameters = fixed_parameters_ + (per_trial_ ? n : 0);
    report->before = before_.Result(0);
    report->after = after_.Result(
        static_cast<int>(std::min<long>(parameters, std::numeric_limits<int>::max())));
    report->beyond_threshold_count = beyond_;
    return n;
  }

 private:
  void Flush() {
    if (used_ == 0) return;
    chunk_.resize(used_);
    const Prediction a = PredictTrials(nominal_, chunk_);
    if (a.failed) throw Error("fit: the nominal model cannot predict the trials: " + a.message);
    const Prediction b = PredictTrials(augmented_, chunk_);
    if (b.failed) {
      throw Error("fit: the model with the chosen effects cannot predict the trials: " + b.message);
    }
    for (size_t k = 0; k < used_; ++k) {
      before_.Add(chunk_[k], a.wrench[k], options_);
      if (after_.Add(chunk_[k], b.wrench[k], options_) > options_.outlier_threshold) ++beyond_;
    }
    chunk_.resize(kChunk);
    used_ = 0;
  }

  const Model& nominal_;
  AugmentedModel augmented_;
  const FitOptions& options_;
  std::vector<Trial> chunk_;
  size_t used_ = 0;
  ident::ResidualAccumulator before_, after_;
  long beyond_ = 0;
  int fixed_parameters_ = 0;
  bool per_trial_ = false;
};

void CheckSampleOptions(const FitOptions& options) {
  if (options.max_fit_trials < 0) {
    throw Error("fit: max_fit_trials (--max-fit-trials) must be >= 0 (0 = fit every trial), got " +
                std::to_string(options.max_fit_trials));
  }
}

/// Mark a report as the fit of a sample of `total` trials.
void DescribeSample(long total, const FitOptions& options, FitReport* report) {
  report->trial_count = static_cast<int>(std::min<long>(total, std::numeric_limits<int>::max()));
  report->sample_seed = options.sample_seed;
  report->sampling = std::to_string(report->fitted_trial_count) + " of " + std::to_string(total) +
                     " trials fitted: a uniform random sample (reservoir sampling, seed " +
                     std::to_string(options.sample_seed) +
                     "); the error before and after covers every trial";
}

}  // namespace

FitReport FitEffects(const Model& nominal, const std::vector<Trial>& trials,
                     const FitOptions& options) {
  CheckSampleOptions(options);
  const size_t max = static_cast<size_t>(options.max_fit_trials);
  if (max == 0 || trials.size() <= max) return FitEvery(nominal, trials, options);
  auto clock_start = std::chrono::steady_clock::now();
  TrialReservoir reservoir(options.max_fit_trials, options.sample_seed);
  for (const Trial& t : trials) reservoir.Add(t);
  FitReport report = FitEvery(nominal, reservoir.Take(), options);
  if (options.progress) options.progress("predicting every trial with the chosen effects");
  EveryTrialPass pass(nominal, report, options);
  for (const Trial& t : trials) pass.Add(t);
  DescribeSample(pass.Finish(&report), options, &report);
  report.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - clock_start).count();
  return report;
}

FitReport FitEffectsCsv(const Model& nominal, const std::string& path, const FitOptions& options,
                        const TrialProgress& read_progress, const TrialProgress& check_progress,
                        std::vector<Trial>* fitted) {
  return FitEffectsCsv(nominal, path, TrialSheetOptions(), options, read_progress, check_progress,
                       fitted);
}

FitReport FitEffectsCsv(const Model& nominal, const std::string& path,
                        const TrialSheetOptions& sheet, const FitOptions& options,
                        const TrialProgress& read_progress, const TrialProgress& check_progress,
                        std::vector<Trial>* fitted) {
  CheckSampleOptions(options);
  auto clock_start = std::chrono::steady_clock::now();
  TrialReservoir reservoir(options.max_fit_trials, options.sample_seed);
  const long rows = ForEachTrial(
      nominal, path, sheet, [&](const Trial& t) { reservoir.Add(t); }, read_progress);
  std::vector<Trial> sample = reservoir.Take();
  if (options.progress && static_cast<long>(sample.size()) < rows) {
    options.progress("fitting a uniform random sample of " + std::to_string(sample.size()) +
                     " of " + std::to_string(rows) + " trials (seed " +
                     std::to_string(options.sample_seed) + ")");
  }
  FitReport report = FitEvery(nominal, sample, options);
  if (static_cast<long>(sample.size()) < rows) {
    if (options.progress) options.progress("predicting every row with the chosen effects");
    EveryTrialPass pass(nominal, report, options);
    ForEachTrial(
        nominal, path, sheet, [&](const Trial& t) { pass.Add(t); }, check_progress);
    const long again = pass.Finish(&report);
    if (again != rows) {
      throw Error("fit: " + path + " changed while it was read: " + std::to_string(rows) +
                  " rows in the first pass, " + std::to_string(again) + " in the second");
    }
    DescribeSample(rows, options, &report);
  }
  report.source = path;
  if (fitted) *fitted = std::move(sample);
  report.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - clock_start).count();
  return report;
}

std::string FitReport::BriefReport() const {
  std::ostringstream o;
  o << "verdict: " << FitVerdictName(verdict) << ": " << verdict_message << "\n";
  if (sampled()) o << "sample: " << sampling << "\n";
  for (size_t i = 0; i < chosen_fits.size(); ++i) {
    const CandidateFit& f = chosen_fits[i];
    o << (effects_claimed ? "effect " : "tentative, not claimed: ") << i + 1 << ": " << f.effect.id
      << ": " << ValueText(f.effect, f.values, f.standard_errors) << "\n";
  }
  const char* names[6] = {"fx", "fy", "fz", "mx", "my", "mz"};
  for (int c = 0; c < 6; ++c) {
    o << "  " << names[c] << " RMS " << util::FormatNumber(before.rms[c], 3) << " -> "
      << util::FormatNumber(after.rms[c], 3) << (c < 3 ? " N" : " N·m");
    if (sd_stated) {
      o << " (" << util::FormatNumber(before.normalized[c], 3) << " -> "
        << util::FormatNumber(after.normalized[c], 3) << " x noise)";
    }
    o << "\n";
  }
  if (!outlier_rows.empty()) {
    std::vector<std::string> lines;
    for (long l : outlier_rows) lines.push_back(std::to_string(l));
    o << "outlier rows (CSV lines, " << RobustLossName(loss)
      << " loss): " << util::Join(lines, ", ") << "\n";
  }
  if (!trial_factors.empty()) {
    o << "trial force factors: spread (sd of ln factor) "
      << util::FormatNumber(trial_force_spread, 3);
    if (!trial_force_outliers.empty()) {
      std::vector<std::string> lines;
      for (long l : trial_force_outliers) lines.push_back(std::to_string(l));
      o << "; far from the rest: lines " << util::Join(lines, ", ");
    }
    o << "\n";
  }
  for (const std::string& s : confounded) o << "confounded: " << s << "\n";
  if (!trace_summary.empty()) o << "trace: " << trace_summary << "\n";
  for (const std::string& s : indistinguishable) o << "note: " << s << "\n";
  for (const std::string& s : notes) o << "note: " << s << "\n";
  return o.str();
}

void WriteAugmentedUrdf(const FitReport& report, const std::string& path) {
  std::string xml = WriteUrdfString(report.augmented.description);
  std::string comment = "isowrench fit of " + report.model_name + " (" +
                        std::to_string(report.trial_count) + " trials): " + report.BriefReport();
  const AugmentedModel& a = report.augmented;
  const Vector6d& o = a.sensor_offset;
  if (o.norm() > 0) {
    comment += "sensor offset (not representable in URDF; subtract it from the readings): ";
    for (int c = 0; c < 6; ++c) comment += util::FormatNumber(o[c], 4) + (c < 3 ? " N " : " N·m ");
    comment += "\n";
  }
  for (const auto& p : a.posture_offset) {
    comment += "recorded " + p.first +
               " is offset (add to the recorded value): " + util::FormatNumber(p.second, 6) +
               " rad or m\n";
  }
  for (const auto& c : a.coactivation) {
    comment += "muscle " + c.first + " also pulls in other muscles' trials with " +
               util::FormatNumber(c.second, 4) + " x its max force\n";
  }
  if (a.sensor_origin.norm() > 0) {
    comment += "transducer moment origin offset (transducer axes, m): " +
               util::FormatNumber(a.sensor_origin[0], 4) + " " +
               util::FormatNumber(a.sensor_origin[1], 4) + " " +
               util::FormatNumber(a.sensor_origin[2], 4) + "\n";
  }
  if (!a.calibration.isIdentity(0.0)) {
    comment += "transducer calibration error (reading = C x wrench), rows fx..mz:";
    for (int i = 0; i < 6; ++i) {
      comment += "\n ";
      for (int j = 0; j < 6; ++j) comment += " " + util::FormatNumber(a.calibration(i, j), 5);
    }
    comment += "\n";
  }
  if (a.trial_force) comment += "per-trial force factors were fitted (see the fit report)\n";
  size_t pos;
  while ((pos = comment.find("--")) != std::string::npos) comment.replace(pos, 2, "- -");
  comment = "<!-- " + comment + "-->\n";
  size_t insert = 0;
  if (xml.compare(0, 5, "<?xml") == 0) insert = xml.find('\n') + 1;
  xml.insert(insert, comment);
  util::WriteFileAtomically(path, xml);
}

}  // namespace isowrench
