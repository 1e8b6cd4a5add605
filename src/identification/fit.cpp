// Fitting candidate effects (Ceres, numeric central differences), deciding between them
// (BIC + K-fold cross-validation + identifiability), the round loop and the report.

#include <ceres/ceres.h>

#include <Eigen/SVD>
#include <algorithm>
#include <chrono>
#include <map>
#include <cmath>
#include <numeric>
#include <sstream>

#include "identification/identification_impl.hpp"
#include "isowrench/error.hpp"
#include "util/atomic_file.hpp"
#include "util/text.hpp"

namespace isowrench {
namespace {

/// A parameter on its search limit: within this fraction of the (internal) range.
constexpr double kAtBoundFraction = 1e-4;
/// A parameter is "not determined" when its standard error exceeds this fraction of its
/// (internal) search range: the data do not pin it down inside the range.
constexpr double kUndeterminedFraction = 0.25;

/// Everything the residual functor needs; owned by the caller for the duration of a solve.
struct Context {
  const LimbDescription* base = nullptr;
  Vector6d base_offset = Vector6d::Zero();
  std::vector<Effect> free;          ///< effects whose parameters are fitted, in order
  std::vector<int> start;            ///< first internal parameter of each free effect
  int parameter_count = 0;
  const std::vector<Trial>* trials = nullptr;
  std::vector<int> subset;
  std::vector<double> weights;       ///< 6 per subset entry
  bool post_only = false;
  std::vector<Vector6d> base_prediction;  ///< post_only: prediction of `base` without base_offset
  FitOptions options;

  std::vector<double> UserValues(const double* x, int e) const {
    std::vector<double> v;
    const Effect& effect = free[e];
    for (size_t i = 0; i < effect.parameters.size(); ++i) v.push_back(ident::ToUser(effect.parameters[i], x[start[e] + i]));
    return v;
  }

  /// Predicted readings of the subset at internal parameters x; false if any trial fails.
  bool Predict(const double* x, std::vector<Vector6d>* out, std::string* message = nullptr) const {
    if (post_only) {
      *out = base_prediction;
      Vector6d offset = base_offset;
      for (size_t e = 0; e < free.size(); ++e) {
        std::vector<double> v = UserValues(x, static_cast<int>(e));
        if (free[e].kind == EffectKind::kSensorOffset) {
          for (int c = 0; c < 6; ++c) offset[c] += v[c];
        } else if (free[e].kind == EffectKind::kMuscleForceScale) {
          for (size_t k = 0; k < subset.size(); ++k) {
            if ((*trials)[subset[k]].muscle == free[e].muscle) (*out)[k] *= v[0];
          }
        }
      }
      for (Vector6d& w : *out) w += offset;
      return true;
    }
    try {
      LimbDescription d = *base;
      Vector6d offset = base_offset;
      for (size_t e = 0; e < free.size(); ++e) {
        std::vector<double> v = UserValues(x, static_cast<int>(e));
        d = ApplyEffect(std::move(d), free[e], v);
        if (free[e].kind == EffectKind::kSensorOffset) {
          for (int c = 0; c < 6; ++c) offset[c] += v[c];
        }
      }
      Model model(std::move(d));
      std::vector<bool> ok;
      std::string msg;
      ident::PredictSubset(model, *trials, subset, offset, out, &ok, &msg);
      for (bool b : ok) {
        if (!b) {
          if (message) *message = msg;
          return false;
        }
      }
      return true;
    } catch (const Error& e) {
      if (message) *message = e.what();
      return false;
    }
  }

  double Chi2(const std::vector<Vector6d>& prediction) const {
    double chi2 = 0.0;
    for (size_t k = 0; k < subset.size(); ++k) {
      const Trial& t = (*trials)[subset[k]];
      for (int c = 0; c < 6; ++c) {
        double r = weights[6 * k + c] * (t.wrench[c] - prediction[k][c]);
        chi2 += r * r;
      }
    }
    return chi2;
  }
};

struct ResidualFunctor {
  const Context* context;
  bool operator()(double const* const* parameters, double* residuals) const {
    std::vector<Vector6d> prediction;
    if (!context->Predict(parameters[0], &prediction)) return false;
    for (size_t k = 0; k < context->subset.size(); ++k) {
      const Trial& t = (*context->trials)[context->subset[k]];
      for (int c = 0; c < 6; ++c) {
        residuals[6 * k + c] = context->weights[6 * k + c] * (t.wrench[c] - prediction[k][c]);
      }
    }
    return true;
  }
};

using CostFunction = ceres::DynamicNumericDiffCostFunction<ResidualFunctor, ceres::CENTRAL>;

Context MakeContext(const LimbDescription& base, const Vector6d& base_offset, const std::vector<Effect>& free,
                    const std::vector<Trial>& trials, const std::vector<int>& subset, const FitOptions& options) {
  Context c;
  c.base = &base;
  c.base_offset = base_offset;
  c.free = free;
  c.trials = &trials;
  c.subset = subset;
  c.options = options;
  for (const Effect& e : free) {
    c.start.push_back(c.parameter_count);
    c.parameter_count += static_cast<int>(e.parameters.size());
  }
  c.weights.resize(6 * subset.size());
  for (size_t k = 0; k < subset.size(); ++k) {
    for (int j = 0; j < 6; ++j) c.weights[6 * k + j] = ident::Weight(trials[subset[k]], j, options);
  }
  c.post_only = std::all_of(free.begin(), free.end(), [](const Effect& e) { return e.post_processing; });
  if (c.post_only) {
    Model model(base);
    std::vector<bool> ok;
    std::string message;
    ident::PredictSubset(model, trials, subset, Vector6d::Zero(), &c.base_prediction, &ok, &message);
    if (std::find(ok.begin(), ok.end(), false) != ok.end()) c.post_only = false;  // let Predict report it
  }
  return c;
}

struct SolveResult {
  std::vector<double> x;
  double chi2 = 0.0;
  bool usable = false;
  std::string message;
};

std::vector<double> Lower(const Context& c) {
  std::vector<double> v;
  for (const Effect& e : c.free) {
    for (const EffectParameter& p : e.parameters) v.push_back(ident::ToInternal(p, p.lower));
  }
  return v;
}
std::vector<double> Upper(const Context& c) {
  std::vector<double> v;
  for (const Effect& e : c.free) {
    for (const EffectParameter& p : e.parameters) v.push_back(ident::ToInternal(p, p.upper));
  }
  return v;
}

SolveResult Solve(const Context& c, std::vector<double> x) {
  SolveResult out;
  std::vector<double> lo = Lower(c), hi = Upper(c);
  for (int i = 0; i < c.parameter_count; ++i) x[i] = std::min(std::max(x[i], lo[i]), hi[i]);
  std::vector<Vector6d> prediction;
  std::string message;
  if (!c.Predict(x.data(), &prediction, &message)) {
    out.x = x;
    out.message = "the model cannot be evaluated at the starting point: " + message;
    return out;
  }
  ceres::Problem::Options problem_options;
  ceres::Problem problem(problem_options);
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
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  out.x = x;
  out.usable = summary.IsSolutionUsable() && summary.termination_type != ceres::NO_CONVERGENCE;
  out.message = summary.message;
  if (!c.Predict(x.data(), &prediction, &message)) {
    out.usable = false;
    out.message = "the model cannot be evaluated at the solution: " + message;
    out.chi2 = 2.0 * summary.final_cost;
  } else {
    out.chi2 = c.Chi2(prediction);
  }
  if (summary.termination_type == ceres::NO_CONVERGENCE && summary.IsSolutionUsable()) {
    // Hitting the iteration limit with a usable point still gives a valid (upper) cost.
    out.usable = true;
    out.message = "iteration limit reached: " + summary.message;
  }
  return out;
}

/// Multi-start for single log10 parameters (stiffness or factor): a stiffness far on the rigid
/// side has no gradient, so also start two decades either side.
SolveResult SolveWithStarts(const Context& c, const std::vector<double>& x0) {
  SolveResult best = Solve(c, x0);
  const Effect& last = c.free.back();
  if (last.parameters.size() == 1 && last.parameters[0].scale == ParameterScale::kLog10) {
    // Multi-start on the candidate's single log10 parameter (stiffness or factor): retry only
    // when the first solve failed or stopped on a search limit away from the value at which
    // the effect vanishes (a flat, saturated region); the rigid side is a real answer.
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
      if (r.usable && (!best.usable || r.chi2 < best.chi2)) best = r;
    }
  }
  return best;
}

double Bic(double chi2, int n, int k, bool sd_stated) {
  double fit = sd_stated ? chi2 : n * std::log(std::max(chi2, 1e-300) / n);
  return fit + k * std::log(static_cast<double>(n));
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

std::string ParameterLabel(const Context& c, int i) {
  for (size_t e = 0; e < c.free.size(); ++e) {
    int local = i - c.start[e];
    if (local >= 0 && local < static_cast<int>(c.free[e].parameters.size())) {
      return (c.free.size() > 1 ? c.free[e].id + "." : std::string()) + c.free[e].parameters[local].name;
    }
  }
  return "?";
}

/// Whitened Jacobian at x, SVD, covariance, correlations, identifiability.
Analysis Analyze(const Context& c, const std::vector<double>& x, double chi2, bool sd_stated) {
  Analysis a;
  const int p = c.parameter_count;
  const int n = static_cast<int>(6 * c.subset.size());
  a.se_internal.assign(p, 0.0);
  a.at_bound.assign(p, false);
  a.correlation = Eigen::MatrixXd::Identity(p, p);
  std::vector<double> lo = Lower(c), hi = Upper(c);
  std::vector<std::string> reasons;
  for (int i = 0; i < p; ++i) {
    double range = hi[i] - lo[i];
    if (x[i] - lo[i] <= kAtBoundFraction * range || hi[i] - x[i] <= kAtBoundFraction * range) {
      a.at_bound[i] = true;
      reasons.push_back(ParameterLabel(c, i) + " ended on its search limit (only bounded by the data)");
    }
  }
  CostFunction cost(new ResidualFunctor{&c});
  cost.AddParameterBlock(p);
  cost.SetNumResiduals(n);
  Eigen::VectorXd residuals(n);
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> J(n, p);
  const double* parameters[1] = {x.data()};
  double* jacobians[1] = {J.data()};
  if (!cost.Evaluate(parameters, residuals.data(), jacobians) || !J.allFinite()) {
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
    int dof = std::max(1, n - p);
    double scale = sd_stated ? std::max(1.0, chi2 / dof) : chi2 / dof;
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
          reasons.push_back(ParameterLabel(c, i) + " and " + ParameterLabel(c, j) + " are correlated (r = " +
                            util::FormatNumber(a.correlation(i, j), 4) + ")");
        }
      }
      if (a.se_internal[i] > kUndeterminedFraction * (hi[i] - lo[i])) {
        reasons.push_back(ParameterLabel(c, i) + " is not determined within its search range");
      }
    }
  }
  a.identifiable = reasons.empty();
  a.reason = util::Join(reasons, "; ");
  return a;
}

std::vector<double> InitialInternal(const Effect& e) {
  std::vector<double> x;
  for (const EffectParameter& p : e.parameters) x.push_back(ident::ToInternal(p, p.initial));
  return x;
}

int TotalParameters(const std::vector<AppliedEffect>& effects) {
  int k = 0;
  for (const AppliedEffect& a : effects) k += static_cast<int>(a.effect.parameters.size());
  return k;
}

std::vector<int> AllIndices(size_t n) {
  std::vector<int> v(n);
  std::iota(v.begin(), v.end(), 0);
  return v;
}

/// Fill a CandidateFit for `effect`, the last free effect of the context (its parameters start
/// at c.start.back(); earlier free effects are the already chosen ones, refitted jointly).
CandidateFit MakeFit(const Context& c, const Effect& effect, const SolveResult& r, const Analysis& a, bool sd_stated,
                     int which = -1) {
  CandidateFit f;
  f.effect = effect;
  const int n = static_cast<int>(6 * c.subset.size());
  const int k_total = c.parameter_count;
  const int p0 = which < 0 ? c.start.back() : c.start[which];
  for (size_t i = 0; i < effect.parameters.size(); ++i) {
    const EffectParameter& p = effect.parameters[i];
    double value = ident::ToUser(p, r.x[p0 + i]);
    f.values.push_back(value);
    double se = a.se_internal[p0 + i];
    f.log10_standard_errors.push_back(p.scale == ParameterScale::kLog10 ? se : 0.0);
    f.standard_errors.push_back(p.scale == ParameterScale::kLog10 ? value * std::log(10.0) * se : se);
    f.at_bound.push_back(a.at_bound[p0 + i]);
  }
  const int pn = static_cast<int>(effect.parameters.size());
  f.correlation = a.correlation.block(p0, p0, pn, pn);
  f.cost = r.chi2;
  f.bic = Bic(r.chi2, n, k_total, sd_stated);
  f.aic = Aicc(r.chi2, n, k_total, sd_stated);
  f.identifiable = a.identifiable;
  f.identifiability = a.reason;
  f.converged = r.usable;
  f.solver_message = r.message;
  return f;
}

/// Fit `effect` jointly with the already chosen effects `previous` (their values are the start)
/// on the trials in `subset`. `start` (optional) is a full internal start vector; the solution's
/// full internal vector goes to `x_out`.
CandidateFit FitOnSubset(const LimbDescription& base, const Vector6d& base_offset,
                         const std::vector<AppliedEffect>& previous, const Effect& effect,
                         const std::vector<Trial>& trials, const std::vector<int>& subset, const FitOptions& options,
                         const std::vector<double>* start, bool analyze, std::vector<double>* x_out = nullptr) {
  bool sd_stated = AllSd(trials);
  std::vector<Effect> free;
  std::vector<double> x0;
  for (const AppliedEffect& a : previous) {
    free.push_back(a.effect);
    for (size_t i = 0; i < a.values.size(); ++i) x0.push_back(ident::ToInternal(a.effect.parameters[i], a.values[i]));
  }
  free.push_back(effect);
  for (double v : InitialInternal(effect)) x0.push_back(v);
  Context c = MakeContext(base, base_offset, free, trials, subset, options);
  SolveResult r = start ? Solve(c, *start) : SolveWithStarts(c, x0);
  Analysis a;
  if (analyze && r.usable) {
    a = Analyze(c, r.x, r.chi2, sd_stated);
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
  return MakeFit(c, effect, r, a, sd_stated);
}

std::string ValueText(const Effect& e, const std::vector<double>& v, const std::vector<double>& se) {
  std::vector<std::string> items;
  for (size_t i = 0; i < e.parameters.size() && i < v.size(); ++i) {
    std::string s = e.parameters[i].name + " = " + util::FormatNumber(v[i], 4);
    if (i < se.size() && se[i] > 0) s += " ± " + util::FormatNumber(se[i], 2);
    s += " " + e.parameters[i].unit;
    items.push_back(s);
  }
  return util::Join(items, ", ");
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

CandidateFit FitCandidate(const AugmentedModel& current, const Effect& effect, const std::vector<Trial>& trials,
                          const FitOptions& options) {
  // The already chosen effects stay fixed: a context whose only free effect is `effect`, on a
  // base that already holds them. BIC counts their parameters too.
  CandidateFit f = FitOnSubset(current.description, current.sensor_offset, {}, effect, trials,
                               AllIndices(trials.size()), options, nullptr, true);
  const int n = static_cast<int>(6 * trials.size());
  const int k = TotalParameters(current.effects) + static_cast<int>(effect.parameters.size());
  f.bic = Bic(f.cost, n, k, AllSd(trials));
  f.aic = Aicc(f.cost, n, k, AllSd(trials));
  return f;
}

FitReport FitEffects(const Model& nominal, const std::vector<Trial>& trials, const FitOptions& options) {
  auto clock_start = std::chrono::steady_clock::now();
  if (trials.empty()) throw Error("fit: no trials");
  FitReport report;
  report.model_name = nominal.name();
  report.source = nominal.description().source;
  report.trial_count = static_cast<int>(trials.size());
  report.sd_stated = AllSd(trials);
  const bool sd_stated = report.sd_stated;
  const int n = static_cast<int>(6 * trials.size());
  const std::vector<int> all = AllIndices(trials.size());

  std::vector<Effect> library = CandidateEffects(nominal);
  if (!options.candidates.empty()) {
    std::vector<Effect> chosen;
    for (const std::string& id : options.candidates) chosen.push_back(FindEffect(nominal, id));
    library = chosen;
  }

  // Folds for cross-validation.
  std::vector<std::vector<int>> train, test;
  const int folds = options.folds;
  if (folds >= 2 && static_cast<int>(trials.size()) >= folds) {
    std::vector<int> order = all;
    ident::Random rng(options.cv_seed);
    for (size_t i = order.size(); i > 1; --i) std::swap(order[i - 1], order[rng.Next() % i]);
    train.resize(folds);
    test.resize(folds);
    for (size_t i = 0; i < order.size(); ++i) {
      for (int f = 0; f < folds; ++f) (static_cast<int>(i % folds) == f ? test[f] : train[f]).push_back(order[i]);
    }
    for (int f = 0; f < folds; ++f) {
      std::sort(train[f].begin(), train[f].end());
      std::sort(test[f].begin(), test[f].end());
    }
  }

  AugmentedModel current = ApplyEffects(nominal.description(), {});
  Prediction nominal_prediction = PredictTrials(nominal, trials);
  if (nominal_prediction.failed) {
    throw Error("fit: the nominal model cannot predict the trials: " + nominal_prediction.message);
  }
  std::vector<Vector6d> current_prediction = nominal_prediction.wrench;
  report.before = ComputeResidualStats(trials, current_prediction, 0, options);
  double chi2_current = report.before.chi2;
  // Make `effects` (with their fits) the current model: its prediction and chi2.
  auto adopt = [&](const std::vector<AppliedEffect>& effects, const std::vector<CandidateFit>& fits) {
    current = ApplyEffects(nominal.description(), effects);
    report.chosen = effects;
    report.chosen_fits = fits;
    current_prediction = PredictTrials(Model(current.description), trials, current.sensor_offset).wrench;
    chi2_current = ComputeResidualStats(trials, current_prediction, 0, options).chi2;
  };

  for (int round = 1; round <= options.max_rounds; ++round) {
    FitRound r;
    r.index = round;
    const int k_current = TotalParameters(current.effects);
    r.before = ComputeResidualStats(trials, current_prediction, k_current, options);
    r.bic_before = Bic(chi2_current, n, k_current, sd_stated);
    r.cv_before = chi2_current / n;
    std::map<std::string, std::vector<double>> full_x;  // joint solution per candidate id
    std::vector<std::string> taken;
    for (const AppliedEffect& a : current.effects) taken.push_back(ident::ConflictKey(a.effect));
    for (const Effect& effect : library) {
      if (std::find(taken.begin(), taken.end(), ident::ConflictKey(effect)) != taken.end()) continue;
      std::vector<double> x_full;
      CandidateFit f = FitOnSubset(nominal.description(), Vector6d::Zero(), current.effects, effect, trials, all,
                                   options, nullptr, true, &x_full);
      full_x[effect.id] = x_full;
      f.delta_bic = r.bic_before - f.bic;
      r.candidates.push_back(std::move(f));
    }
    const double threshold =
        options.min_bic_improvement +
        (options.look_elsewhere && r.candidates.size() > 1 ? 2.0 * std::log(static_cast<double>(r.candidates.size())) : 0.0);
    r.bic_threshold = threshold;
    std::stable_sort(r.candidates.begin(), r.candidates.end(), [](const CandidateFit& a, const CandidateFit& b) {
      if (a.converged != b.converged) return a.converged;
      return a.bic < b.bic;
    });
    // Cross-validate the best few that could win.
    int cv_done = 0;
    for (CandidateFit& f : r.candidates) {
      if (cv_done >= options.cv_candidates) break;
      if (!f.converged || !f.identifiable || f.delta_bic < threshold || train.empty()) continue;
      ++cv_done;
      double held_chi2 = 0.0;
      int held_n = 0;
      const std::vector<double>& start = full_x[f.effect.id];
      std::vector<Effect> free;
      for (const AppliedEffect& a : current.effects) free.push_back(a.effect);
      free.push_back(f.effect);
      bool ok = true;
      for (int fold = 0; fold < folds && ok; ++fold) {
        std::vector<double> x;
        CandidateFit g = FitOnSubset(nominal.description(), Vector6d::Zero(), current.effects, f.effect, trials,
                                     train[fold], options, &start, false, &x);
        if (!g.converged) {
          ok = false;
          break;
        }
        Context c = MakeContext(nominal.description(), Vector6d::Zero(), free, trials, test[fold], options);
        std::vector<Vector6d> prediction;
        if (!c.Predict(x.data(), &prediction)) {
          ok = false;
          break;
        }
        held_chi2 += c.Chi2(prediction);
        held_n += static_cast<int>(6 * test[fold].size());
      }
      f.cv_error = ok && held_n > 0 ? held_chi2 / held_n : std::numeric_limits<double>::infinity();
      if (!ok) f.cv_error = -2.0;  // marks "failed"
    }
    // Decide.
    for (size_t i = 0; i < r.candidates.size(); ++i) {
      CandidateFit& f = r.candidates[i];
      std::string p = std::to_string(f.effect.parameters.size()) + " parameter" + (f.effect.parameters.size() > 1 ? "s" : "");
      if (!f.converged) {
        f.verdict = "fit failed: " + f.solver_message;
      } else if (f.delta_bic < threshold) {
        f.verdict = "does not earn its " + p + ": ΔBIC = " + util::FormatNumber(f.delta_bic, 3) + " < " +
                    util::FormatNumber(threshold, 3);
        if (!f.identifiable) f.verdict += "; not identifiable: " + f.identifiability;
      } else if (!f.identifiable) {
        f.verdict = "not identifiable from these data: " + f.identifiability;
      } else if (!train.empty() && f.cv_error == -1.0) {
        f.verdict = "not cross-validated (a better candidate was)";
      } else if (!train.empty() && (f.cv_error < 0 || f.cv_error > (1.0 - options.min_cv_improvement) * r.cv_before)) {
        f.verdict = f.cv_error < 0 ? "cross-validation fit failed"
                                   : "held-out error not lower: " + util::FormatNumber(f.cv_error, 4) + " vs " +
                                         util::FormatNumber(r.cv_before, 4) + " per residual";
      } else if (r.chosen < 0) {
        r.chosen = static_cast<int>(i);
        f.accepted = true;
        f.verdict = "chosen";
      } else {
        const CandidateFit& w = r.candidates[r.chosen];
        double gap = f.bic - w.bic;
        f.verdict = "worse than " + w.effect.id + " by ΔBIC = " + util::FormatNumber(gap, 3);
        if (gap < options.indistinguishable_bic) {
          f.verdict += " (indistinguishable at these postures)";
          r.indistinguishable.push_back(f.effect.id);
        }
      }
    }
    if (r.chosen < 0) {
      r.summary = "no candidate earns its parameters";
      if (!r.candidates.empty()) {
        r.summary += " (best: " + r.candidates[0].effect.id + ", " + r.candidates[0].verdict + ")";
      }
      report.rounds.push_back(std::move(r));
      break;
    }
    CandidateFit& winner = r.candidates[r.chosen];
    r.summary = "added " + winner.effect.id + " (" +
                ValueText(winner.effect, winner.values, winner.standard_errors) + "), ΔBIC = " +
                util::FormatNumber(winner.delta_bic, 4);
    if (!r.indistinguishable.empty()) {
      std::string s = "At the sampled postures " + winner.effect.id + " cannot be told apart from " +
                      util::Join(r.indistinguishable, ", ") + " (BIC within " +
                      util::FormatNumber(options.indistinguishable_bic, 3) + ")";
      report.indistinguishable.push_back(s);
    }
    // Add the winner; the candidate fit already refitted all chosen effects jointly: take their
    // values from it and their standard errors from the joint covariance.
    std::vector<AppliedEffect> chosen = current.effects;
    chosen.push_back({winner.effect, winner.values});
    std::vector<CandidateFit> chosen_fits = report.chosen_fits;
    chosen_fits.push_back(winner);
    if (chosen.size() > 1) {
      std::vector<Effect> free;
      for (const AppliedEffect& a : chosen) free.push_back(a.effect);
      const std::vector<double>& x0 = full_x[winner.effect.id];
      Context c = MakeContext(nominal.description(), Vector6d::Zero(), free, trials, all, options);
      SolveResult joint = Solve(c, x0);
      if (joint.usable && joint.chi2 <= winner.cost * (1 + 1e-9) + 1e-12) {
        Analysis a = Analyze(c, joint.x, joint.chi2, sd_stated);
        for (size_t e = 0; e < chosen.size(); ++e) {
          CandidateFit& f = chosen_fits[e];
          for (size_t i = 0; i < chosen[e].values.size(); ++i) {
            int k = c.start[e] + static_cast<int>(i);
            const EffectParameter& p = chosen[e].effect.parameters[i];
            double value = ident::ToUser(p, joint.x[k]);
            chosen[e].values[i] = value;
            f.values[i] = value;
            f.log10_standard_errors[i] = p.scale == ParameterScale::kLog10 ? a.se_internal[k] : 0.0;
            f.standard_errors[i] = p.scale == ParameterScale::kLog10 ? value * std::log(10.0) * a.se_internal[k]
                                                                      : a.se_internal[k];
            f.at_bound[i] = a.at_bound[k];
          }
          int p0 = c.start[e], pn = static_cast<int>(chosen[e].values.size());
          f.correlation = a.correlation.block(p0, p0, pn, pn);
          f.cost = joint.chi2;
          if (!a.identifiable) {
            f.identifiable = false;
            f.identifiability = "joint refit: " + a.reason;
          }
        }
      }
    }
    adopt(chosen, chosen_fits);
    report.rounds.push_back(std::move(r));
  }

  // Simplify: a per-axis base compliance whose axes agree is replaced by the isotropic one when
  // that lowers the BIC (the nested, simpler effect explains the data as well).
  for (size_t i = 0; i < current.effects.size(); ++i) {
    if (current.effects[i].effect.kind != EffectKind::kBasePerAxis) continue;
    Effect iso;
    bool found = false;
    for (const Effect& e : CandidateEffects(nominal)) {
      if (e.kind == EffectKind::kBaseIsotropic) {
        iso = e;
        found = true;
      }
    }
    if (!found) break;
    std::vector<AppliedEffect> alt = current.effects;
    const std::vector<double>& k = alt[i].values;
    alt[i] = {iso, {std::cbrt(k[0] * k[1] * k[2])}};
    std::vector<Effect> free;
    std::vector<double> x0;
    for (const AppliedEffect& a : alt) {
      free.push_back(a.effect);
      for (size_t j = 0; j < a.values.size(); ++j) x0.push_back(ident::ToInternal(a.effect.parameters[j], a.values[j]));
    }
    Context c = MakeContext(nominal.description(), Vector6d::Zero(), free, trials, all, options);
    SolveResult r = Solve(c, x0);
    const int k_now = TotalParameters(current.effects);
    double bic_now = Bic(chi2_current, n, k_now, sd_stated);
    double bic_alt = Bic(r.chi2, n, c.parameter_count, sd_stated);
    if (!r.usable || bic_alt >= bic_now) break;
    Analysis a = Analyze(c, r.x, r.chi2, sd_stated);
    std::vector<CandidateFit> fits;
    for (size_t e = 0; e < alt.size(); ++e) {
      CandidateFit f = MakeFit(c, alt[e].effect, r, a, sd_stated, static_cast<int>(e));
      f.accepted = true;
      f.verdict = "chosen";
      alt[e].values = f.values;
      fits.push_back(f);
    }
    report.notes.push_back("base_per_axis simplified to base_isotropic: the three axis stiffnesses agree (BIC " +
                           util::FormatNumber(bic_now, 6) + " -> " + util::FormatNumber(bic_alt, 6) + ")");
    adopt(alt, fits);
    break;
  }

  report.augmented = current;
  const int k_final = TotalParameters(current.effects);
  report.after = ComputeResidualStats(trials, current_prediction, k_final, options);
  for (size_t k = 0; k < trials.size(); ++k) {
    TrialResidual t;
    t.line = trials[k].line;
    t.muscle = trials[k].muscle;
    t.activation = trials[k].activation;
    t.measured = trials[k].wrench;
    t.before = trials[k].wrench - nominal_prediction.wrench[k];
    t.after = trials[k].wrench - current_prediction[k];
    double nb = 0, na = 0;
    for (int c = 0; c < 6; ++c) {
      double w = ident::Weight(trials[k], c, options);
      nb += std::pow(w * t.before[c], 2);
      na += std::pow(w * t.after[c], 2);
    }
    t.normalized_before = std::sqrt(nb / 6);
    t.normalized_after = std::sqrt(na / 6);
    report.trials.push_back(t);
  }

  std::ostringstream m;
  if (!sd_stated) {
    report.verdict = FitVerdict::kNoNoiseStated;
    m << "the data state no standard deviations, so the residual cannot be compared with the noise; weighted with "
      << util::FormatNumber(options.default_sd_force, 3) << " N and " << util::FormatNumber(options.default_sd_moment, 3)
      << " N·m";
  } else {
    int dof = std::max(1, report.after.residual_count - k_final);
    double threshold = 1.0 + options.unexplained_sigmas * std::sqrt(2.0 / dof);
    double multiple = std::sqrt(report.after.reduced_chi2);
    if (report.after.reduced_chi2 > threshold) {
      report.verdict = FitVerdict::kUnexplained;
      report.effects_claimed = report.chosen.empty();
      m << "after " << report.chosen.size() << " effect(s) the residual is "
        << util::FormatNumber(multiple, 3) << " x the stated noise (reduced chi^2 "
        << util::FormatNumber(report.after.reduced_chi2, 4) << " > " << util::FormatNumber(threshold, 4)
        << "); something outside the candidate library is missing";
      if (!report.chosen.empty()) {
        m << "; the effects tried reduce the residual but do not explain it, so none is claimed (tentative partial "
             "fits below)";
      }
    } else if (report.chosen.empty()) {
      report.verdict = FitVerdict::kNominalFits;
      m << "the nominal model explains the data to the noise (residual " << util::FormatNumber(multiple, 3)
        << " x noise); no effect is claimed";
    } else {
      report.verdict = FitVerdict::kExplained;
      std::vector<std::string> ids;
      for (const AppliedEffect& a : report.chosen) ids.push_back(a.effect.id);
      m << "explained by " << util::Join(ids, " + ") << ": residual from "
        << util::FormatNumber(std::sqrt(report.before.chi2 / std::max(1, report.before.residual_count)), 3)
        << " x noise to " << util::FormatNumber(multiple, 3) << " x noise";
    }
  }
  report.verdict_message = m.str();
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - clock_start).count();
  return report;
}

std::string FitReport::BriefReport() const {
  std::ostringstream o;
  o << "verdict: " << FitVerdictName(verdict) << ": " << verdict_message << "\n";
  for (size_t i = 0; i < chosen_fits.size(); ++i) {
    const CandidateFit& f = chosen_fits[i];
    o << (effects_claimed ? "effect " : "tentative, not claimed: ") << i + 1 << ": " << f.effect.id << ": " << ValueText(f.effect, f.values, f.standard_errors) << "\n";
  }
  const char* names[6] = {"fx", "fy", "fz", "mx", "my", "mz"};
  for (int c = 0; c < 6; ++c) {
    o << "  " << names[c] << " RMS " << util::FormatNumber(before.rms[c], 3) << " -> "
      << util::FormatNumber(after.rms[c], 3) << (c < 3 ? " N" : " N·m");
    if (sd_stated) {
      o << " (" << util::FormatNumber(before.normalized[c], 3) << " -> " << util::FormatNumber(after.normalized[c], 3)
        << " x noise)";
    }
    o << "\n";
  }
  for (const std::string& s : indistinguishable) o << "note: " << s << "\n";
  for (const std::string& s : notes) o << "note: " << s << "\n";
  return o.str();
}

void WriteAugmentedUrdf(const FitReport& report, const std::string& path) {
  std::string xml = WriteUrdfString(report.augmented.description);
  std::string comment = "isowrench fit of " + report.model_name + " (" + std::to_string(report.trial_count) +
                        " trials): " + report.BriefReport();
  const Vector6d& o = report.augmented.sensor_offset;
  if (o.norm() > 0) {
    comment += "sensor offset (not representable in URDF; subtract it from the readings): ";
    for (int c = 0; c < 6; ++c) comment += util::FormatNumber(o[c], 4) + (c < 3 ? " N " : " N·m ");
    comment += "\n";
  }
  size_t pos;
  while ((pos = comment.find("--")) != std::string::npos) comment.replace(pos, 2, "- -");
  comment = "<!-- " + comment + "-->\n";
  size_t insert = 0;
  if (xml.compare(0, 5, "<?xml") == 0) insert = xml.find('\n') + 1;
  xml.insert(insert, comment);
  util::WriteFileAtomically(path, xml);
}

}  // namespace isowrench
