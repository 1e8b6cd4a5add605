// Force level vs trial variation: the random-effects view of per-trial force factors
// (trial_force). Trial t of muscle m has the factor g_t = s_m exp(z_t), z_t ~ N(0, σ²): the
// level s_m per muscle (what force_scale fits) and the spread σ (the stimulus varying from
// trial to trial). The spread is claimed only when the marginal likelihood prefers σ > 0 to the
// levels alone, and only when the factors do not follow the posture (FactorTrend).

#include <cmath>
#include <limits>

#include "identification/fit_stages.hpp"
#include "isowrench/error.hpp"
#include "util/text.hpp"

namespace isowrench::ident {
namespace {

/// Q(σ²) at given levels μ (no profiling): also the held-out evaluation of a training fold.
double MarginalQAt(const ForceLevels& f, double sigma2, const std::vector<double>& mu) {
  double q = 0.0;
  for (size_t t = 0; t < f.x.size(); ++t) {
    if (f.muscle[t] < 0) continue;
    const double d = f.x[t] - mu[f.muscle[t]];
    q += d * d / (sigma2 + f.v[t]) + std::log1p(sigma2 / f.v[t]);
  }
  return q;
}

/// Q(σ²) = Σ_t [(x_t - μ_m)² / (σ² + v_t) + ln(1 + σ² / v_t)] with each μ_m the weighted mean of
/// its muscle's x_t (weights 1 / (σ² + v_t)): -2 ln of the marginal likelihood of the x_t,
/// relative to σ = 0 in its log-determinant part. `mu` and `mu_se` receive the levels.
double MarginalQ(const ForceLevels& f, double sigma2, std::vector<double>* mu,
                 std::vector<double>* mu_se) {
  const size_t m = f.muscles.size();
  std::vector<double> sw(m, 0.0), swx(m, 0.0);
  for (size_t t = 0; t < f.x.size(); ++t) {
    if (f.muscle[t] < 0) continue;
    const double w = 1.0 / (sigma2 + f.v[t]);
    sw[f.muscle[t]] += w;
    swx[f.muscle[t]] += w * f.x[t];
  }
  mu->assign(m, 0.0);
  if (mu_se) mu_se->assign(m, 0.0);
  for (size_t i = 0; i < m; ++i) {
    (*mu)[i] = sw[i] > 0 ? swx[i] / sw[i] : 0.0;
    if (mu_se) (*mu_se)[i] = sw[i] > 0 ? 1.0 / std::sqrt(sw[i]) : 0.0;
  }
  return MarginalQAt(f, sigma2, *mu);
}

}  // namespace

ForceLevels FitForceLevels(const Context& c, const Readings& r, const ForceLevels* fixed) {
  ForceLevels f;
  const size_t n = c.subset.size();
  f.x.assign(n, 0.0);
  f.v.assign(n, 0.0);
  f.muscle.assign(n, -1);
  double rows = 0.0;
  for (size_t k = 0; k < n; ++k) {
    const Trial& t = (*c.trials)[c.subset[k]];
    // Whitened residual r (with the factor the prediction used), whitened reading a at factor
    // 1, and e0 = r + g a the whitened measured reading less the offset.
    Vector6d res, a;
    for (int j = 0; j < 6; ++j) {
      res[j] = c.weights[6 * k + j] * (t.wrench[j] - r.reading[k][j]);
      a[j] = c.weights[6 * k + j] * r.unit[k][j];
    }
    const double s = res.squaredNorm();
    rows += RowLoss(s, c.options);
    const double aa = a.squaredNorm();
    if (!(aa > 0)) continue;
    const Vector6d e0 = res + r.factor[k] * a;
    const double g = a.dot(e0) / aa;  // the trial's own factor
    // A row still beyond the outlier threshold with its own factor is an outlier (its factor
    // was replaced by the median), and a factor <= 0 has no logarithm: both stay out of the
    // marginal likelihood and count their row cost only.
    const bool outlier =
        c.options.loss != RobustLoss::kNone && std::sqrt(s / 6.0) > c.options.outlier_threshold;
    if (outlier || !(g > 0)) continue;
    size_t m = 0;
    while (m < f.muscles.size() && f.muscles[m] != t.muscle) ++m;
    if (m == f.muscles.size()) {
      f.muscles.push_back(t.muscle);
      f.trials.push_back(0);
    }
    f.muscle[k] = static_cast<int>(m);
    ++f.trials[m];
    f.x[k] = std::log(g);
    f.v[k] = 1.0 / (aa * g * g);
    ++f.used;
  }
  std::vector<double> mu;
  if (fixed) {
    // Held out: the training fold's levels and spread (a muscle it did not see at level 1).
    f.sigma = fixed->sigma;
    f.log_level.assign(f.muscles.size(), 0.0);
    for (size_t m = 0; m < f.muscles.size(); ++m) {
      for (size_t i = 0; i < fixed->muscles.size(); ++i) {
        if (fixed->muscles[i] == f.muscles[m]) f.log_level[m] = fixed->log_level[i];
      }
    }
    f.log_level_se.assign(f.muscles.size(), 0.0);
    f.cost = rows + MarginalQAt(f, f.sigma * f.sigma, f.log_level);
    return f;
  }
  // σ² by a grid in ln σ² from 1e-12 to 4 (σ from 1e-6 to 2) refined by golden section, against
  // σ = 0 (the boundary: the levels alone).
  const double q0 = MarginalQ(f, 0.0, &mu, nullptr);
  auto q_of = [&](double log_s2) { return MarginalQ(f, std::exp(log_s2), &mu, nullptr); };
  const double lo = std::log(1e-12), hi = std::log(4.0);
  const int grid = 56;
  double best_t = lo, best_q = std::numeric_limits<double>::infinity();
  for (int i = 0; i <= grid; ++i) {
    const double t = lo + (hi - lo) * i / grid;
    const double q = q_of(t);
    if (q < best_q) best_q = q, best_t = t;
  }
  double a = std::max(lo, best_t - (hi - lo) / grid), b = std::min(hi, best_t + (hi - lo) / grid);
  const double golden = 0.5 * (std::sqrt(5.0) - 1.0);
  double c1 = b - golden * (b - a), c2 = a + golden * (b - a);
  double f1 = q_of(c1), f2 = q_of(c2);
  for (int i = 0; i < 60 && b - a > 1e-10; ++i) {
    if (f1 < f2) {
      b = c2, c2 = c1, f2 = f1, c1 = b - golden * (b - a), f1 = q_of(c1);
    } else {
      a = c1, c1 = c2, f1 = f2, c2 = a + golden * (b - a), f2 = q_of(c2);
    }
  }
  const double t_hat = f1 < f2 ? c1 : c2;
  const double q_hat = std::min(f1, f2);
  double sigma2 = 0.0, q = q0;
  if (q_hat < q0) sigma2 = std::exp(t_hat), q = q_hat;
  f.sigma = std::sqrt(sigma2);
  f.lrt = std::max(0.0, q0 - q);
  MarginalQ(f, sigma2, &f.log_level, &f.log_level_se);
  // Standard error of σ from the curvature of Q = -2 ln L: var(σ) = 2 / Q''(σ).
  if (f.sigma > 0) {
    const double h = 1e-3 * f.sigma;
    const double qp = MarginalQ(f, std::pow(f.sigma + h, 2), &mu, nullptr);
    const double qm = MarginalQ(f, std::pow(f.sigma - h, 2), &mu, nullptr);
    const double curvature = (qp - 2.0 * q + qm) / (h * h);
    f.sigma_se = curvature > 0 ? std::sqrt(2.0 / curvature) : 0.0;
  }
  f.cost = rows + q;
  return f;
}

std::string FactorTrend(const Model& model, const std::vector<Trial>& trials,
                        const std::vector<int>& subset, const ForceLevels& levels) {
  if (levels.used < 8) return "";
  // Weighted residual log-factors about each muscle's level (weights 1 / (σ² + v_t)): pure trial
  // variation makes them independent of any posture variable.
  const double s2 = levels.sigma * levels.sigma;
  std::vector<double> d(subset.size(), 0.0), w(subset.size(), 0.0);
  for (size_t k = 0; k < subset.size(); ++k) {
    if (levels.muscle[k] < 0) continue;
    d[k] = levels.x[k] - levels.log_level[levels.muscle[k]];
    w[k] = 1.0 / (s2 + levels.v[k]);
  }
  struct Variable {
    std::string name;
    std::vector<double> value;  ///< per subset entry; NaN = not in this variable's trials
  };
  std::vector<Variable> variables;
  TrialMapper mapper(model);
  std::vector<Eigen::VectorXd> q(subset.size());
  for (size_t k = 0; k < subset.size(); ++k) {
    try {
      mapper.Map(trials[subset[k]], &q[k]);
    } catch (const Error&) {
      q[k] = Eigen::VectorXd::Constant(model.dof_count(), std::numeric_limits<double>::quiet_NaN());
    }
  }
  for (int j = 0; j < model.dof_count(); ++j) {
    if (model.joint(j).role != JointRole::kLimb) continue;
    Variable v{"coordinate " + model.joint_names()[j], {}};
    for (size_t k = 0; k < subset.size(); ++k) v.value.push_back(q[k][j]);
    variables.push_back(std::move(v));
  }
  std::vector<Trial> picked;
  for (int t : subset) picked.push_back(trials[t]);
  for (int m = 0; m < model.muscle_count(); ++m) {
    const std::string& name = model.muscle(m).name;
    Variable v{"length of " + name, MuscleLengths(model, name, picked)};
    for (size_t k = 0; k < subset.size(); ++k) {
      if (picked[k].muscle != name) v.value[k] = std::numeric_limits<double>::quiet_NaN();
    }
    variables.push_back(std::move(v));
  }
  // Under pure trial variation the weighted sum of squares a quadratic (beyond the constant)
  // explains is chi^2 with 2 dof: significant when above 2 ln(1000 K), p < 1e-3 / K for K
  // variables.
  const double critical = 2.0 * std::log(1000.0 * static_cast<double>(variables.size()));
  std::string found;
  double found_share = 0.0;
  for (const Variable& v : variables) {
    std::vector<size_t> rows;
    for (size_t k = 0; k < subset.size(); ++k) {
      if (w[k] > 0 && std::isfinite(v.value[k])) rows.push_back(k);
    }
    if (rows.size() < 8) continue;
    double mean = 0, spread = 0;
    for (size_t k : rows) mean += v.value[k];
    mean /= rows.size();
    for (size_t k : rows) spread += std::pow(v.value[k] - mean, 2);
    spread = std::sqrt(spread / rows.size());
    if (!(spread > 0)) continue;
    Eigen::MatrixXd A(rows.size(), 3);
    Eigen::VectorXd b(rows.size());
    for (size_t i = 0; i < rows.size(); ++i) {
      const double z = (v.value[rows[i]] - mean) / spread, sw = std::sqrt(w[rows[i]]);
      A.row(i) << sw, sw * z, sw * z * z;
      b[i] = sw * d[rows[i]];
    }
    const Eigen::VectorXd coef = A.colPivHouseholderQr().solve(b);
    const Eigen::VectorXd ones = A.col(0);
    const double constant = ones.dot(b) / ones.squaredNorm();
    const double total = (b - constant * ones).squaredNorm();
    const double explained = total - (b - A * coef).squaredNorm();
    if (!(total > 0) || explained <= critical) continue;
    const double share = explained / total;
    if (share >= kTrendShare && share > found_share) {
      found_share = share;
      found = v.name + " (a quadratic in it explains " + util::FormatNumber(100 * share, 3) +
              " % of the factors' variance; chi^2 " + util::FormatNumber(explained, 3) + " > " +
              util::FormatNumber(critical, 3) + ")";
    }
  }
  return found;
}

}  // namespace isowrench::ident
