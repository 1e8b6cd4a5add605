// The Ceres solve of a context (problem.cpp builds it): bounded
// Levenberg-Marquardt with numeric central differences, the multi-start of a stuck log10
// parameter, the covariance and identifiability from the whitened Jacobian, and a candidate's
// fit on a subset of the trials. The only file of isowrench that includes Ceres.

#include <ceres/ceres.h>
#include <glog/logging.h>

#include <Eigen/QR>
#include <Eigen/SVD>
#include <cmath>
#include <mutex>

#include "identification/fit_stages.hpp"
#include "util/text.hpp"

namespace isowrench::ident {
namespace {

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

/// Why a per-trial effect cannot be claimed, or "": its spread must earn its parameter against
/// the levels alone (likelihood ratio >= min_bic_improvement + ln n: the BIC comparison of
/// the two nested models) and the factors must not follow the posture.
std::string TrialForceClaim(const Context& c, const SolveResult& r) {
  Readings prediction;
  if (!c.Predict(r.x.data(), &prediction)) return "";
  const ForceLevels levels = FitForceLevels(c, prediction);
  const double n = 6.0 * static_cast<double>(c.subset.size());
  const double needed = c.options.min_bic_improvement + std::log(n);
  if (levels.lrt < needed) {
    return "the factors are the muscles' force levels, not trial variation: the spread (" +
           util::FormatNumber(levels.sigma, 3) +
           ") is not significant against the levels alone (likelihood ratio " +
           util::FormatNumber(levels.lrt, 3) + " < " + util::FormatNumber(needed, 3) +
           "); force_scale fits the levels";
  }
  std::shared_ptr<const Model> model = c.model;
  if (!model) model = std::make_shared<const Model>(c.base.description);
  const std::string trend = FactorTrend(*model, *c.trials, c.subset, levels);
  if (!trend.empty()) {
    return "the factors follow the posture, a systematic effect (force-length: force_length:MUSCLE "
           "for a muscle with a force model; or another effect outside the library), not trial "
           "variation: they follow " +
           trend;
  }
  return "";
}

}  // namespace

SolveResult Solve(const Context& c, std::vector<double> x) {
  SolveResult out;
  Readings prediction;
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
  double lo = ToInternal(p, p.lower), hi = ToInternal(p, p.upper);
  double x = best.x.empty() ? x0[k] : best.x[k];
  bool at_limit = x - lo <= kAtBoundFraction * (hi - lo) || hi - x <= kAtBoundFraction * (hi - lo);
  bool far_from_neutral = std::abs(x - ToInternal(p, p.neutral)) > 1.0;
  if (best.usable && !(at_limit && far_from_neutral)) return best;
  for (double shift : {-2.0, 2.0}) {
    std::vector<double> start = x0;
    start[k] += shift;
    SolveResult r = Solve(c, start);
    if (r.usable && (!best.usable || r.cost < best.cost)) best = r;
  }
  return best;
}

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
  Eigen::MatrixXd Jd = J;  // column-major, factorised in place below
  for (int i = 0; i < p; ++i) {
    if (Jd.col(i).norm() <= c.options.min_sensitivity * std::sqrt(static_cast<double>(n))) {
      reasons.push_back(ParameterLabel(c, i) + " has near-zero sensitivity (|dr/dp| = " +
                        util::FormatNumber(Jd.col(i).norm(), 3) + ")");
    }
  }
  // Singular values and V of J from the SVD of its R factor (J = Q R): the same values, a p x p
  // problem, and no further copy of the n x p Jacobian (30 crosstalk terms x 20,000 trials:
  // 29 MB each).
  Eigen::HouseholderQR<Eigen::Ref<Eigen::MatrixXd>> qr(Jd);
  const Eigen::MatrixXd R =
      qr.matrixQR().topRows(std::min<Eigen::Index>(n, p)).triangularView<Eigen::Upper>();
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(R, Eigen::ComputeThinV);
  Eigen::VectorXd s = svd.singularValues();
  bool rank_ok = s.size() == p && s[0] > 0 && s[p - 1] > c.options.min_singular_ratio * s[0];
  if (!rank_ok) {
    reasons.push_back("the parameters are not jointly identifiable (singular value ratio " +
                      util::FormatNumber(s[0] > 0 ? s[p - 1] / s[0] : 0.0, 3) + ")");
  } else {
    int dof = std::max(1, n - c.ResidualParameters());
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

CandidateFit MakeFit(const Context& c, const SolveResult& r, const Analysis& a, bool sd_stated,
                     int which) {
  const int e = which < 0 ? static_cast<int>(c.free.size()) - 1 : which;
  const Effect& effect = c.free[e];
  CandidateFit f;
  f.effect = effect;
  const int n = static_cast<int>(6 * c.subset.size());
  const int p0 = c.start[e];
  if (effect.per_trial) {
    // The per-trial factors are solved in closed form; the value is their spread around the
    // muscles' levels (the random-effects fit of force_level.cpp).
    Readings prediction;
    double spread = 0.0, spread_se = 0.0;
    if (r.usable && c.Predict(r.x.data(), &prediction)) {
      const ForceLevels levels = FitForceLevels(c, prediction);
      spread = levels.sigma;
      spread_se = levels.sigma_se;
    }
    f.values.assign(effect.parameters.size(), spread);
    f.standard_errors.assign(effect.parameters.size(), spread_se);
    f.log10_standard_errors.assign(effect.parameters.size(), 0.0);
    f.at_bound.assign(effect.parameters.size(), false);
    f.correlation = Eigen::MatrixXd::Identity(effect.parameters.size(), effect.parameters.size());
  } else {
    for (size_t i = 0; i < effect.parameters.size(); ++i) {
      const EffectParameter& p = effect.parameters[i];
      double value = ToUser(p, r.x[p0 + i]);
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

CandidateFit FitOnSubset(const AugmentedModel& base, const std::vector<AppliedEffect>& previous,
                         const Effect& effect, const std::vector<Trial>& trials,
                         const std::vector<int>& subset, const FitOptions& options,
                         const std::vector<double>* start, bool analyze,
                         std::vector<double>* x_out) {
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
  CandidateFit f = MakeFit(c, r, a, sd_stated);
  if (analyze && effect.per_trial && r.usable) f.not_claimed = TrialForceClaim(c, r);
  return f;
}

}  // namespace isowrench::ident
