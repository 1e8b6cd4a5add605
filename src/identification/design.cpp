// Experiment design: D-optimal choice of postures on the Fisher information of the effects'
// parameters at the nominal model (greedy addition, then exchange passes).

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <numeric>

#include "identification/identification_impl.hpp"
#include "isowrench/error.hpp"
#include "util/text.hpp"

namespace isowrench {
namespace {

/// Relative step of the central differences on internal parameter values (log10 or user unit).
constexpr double kLogStep = 1e-3;
/// Linear parameters: step as a fraction of the search range.
constexpr double kLinearStepFraction = 1e-4;
/// Added to the diagonal during greedy addition so the first picks have a finite log det.
constexpr double kRidge = 1e-9;
/// Exchange passes at most (each tries every chosen x every candidate).
constexpr int kExchangePasses = 3;
/// Pairs with |r| above this are named as confounded.
constexpr double kConfounded = 0.9;

double LogDet(const Eigen::MatrixXd& F) {
  Eigen::LDLT<Eigen::MatrixXd> ldlt(F);
  if (ldlt.info() != Eigen::Success) return -std::numeric_limits<double>::infinity();
  double sum = 0;
  for (int i = 0; i < F.rows(); ++i) {
    const double d = ldlt.vectorD()[i];
    if (!(d > 0)) return -std::numeric_limits<double>::infinity();
    sum += std::log(d);
  }
  return sum;
}

Eigen::MatrixXd Information(const std::vector<Eigen::MatrixXd>& blocks,
                            const std::vector<int>& chosen, int p, double ridge) {
  Eigen::MatrixXd F = ridge * Eigen::MatrixXd::Identity(p, p);
  for (int i : chosen) F += blocks[i].transpose() * blocks[i];
  return F;
}

}  // namespace

DesignResult DesignExperiment(const Model& model, const std::vector<std::string>& effect_ids,
                              const std::vector<Trial>* candidates, const DesignOptions& options) {
  if (options.postures < 1)
    throw Error("design: --n must be >= 1, got " + std::to_string(options.postures));
  if (!(options.noise_force > 0) || !(options.noise_moment > 0)) {
    throw Error("design: the expected noise levels must be > 0");
  }
  if (effect_ids.empty())
    throw Error("design: no effect named (--effects ID,...; `isowrench fit --list-effects`)");
  DesignResult out;
  std::vector<AppliedEffect> effects;
  for (const std::string& id : effect_ids) {
    Effect e = FindEffect(model, id);
    if (e.per_trial) {
      out.notes.push_back(
          id + " has one nuisance parameter per trial: no posture choice identifies it better");
      continue;
    }
    AppliedEffect a{e, {}};
    for (const EffectParameter& p : e.parameters) a.values.push_back(p.initial);
    effects.push_back(a);
  }
  // Candidates: given, or a grid sampled like SimulateTrials (noise-free wrenches, unused).
  std::vector<Trial> grid;
  if (candidates) {
    grid = *candidates;
  } else {
    SimulationOptions so;
    so.postures = options.candidates;
    so.seed = options.seed;
    so.joint_range = options.joint_range;
    so.muscles = options.muscles;
    so.center = options.center;
    so.noise_force = 0;
    so.noise_moment = 0;
    grid = SimulateTrials(model, ApplyEffects(model.description(), {}), so);
  }
  out.candidate_count = static_cast<int>(grid.size());
  if (static_cast<int>(grid.size()) < options.postures) {
    throw Error("design: " + std::to_string(grid.size()) + " candidate postures for --n " +
                std::to_string(options.postures));
  }
  for (Trial& t : grid) {
    t.has_sd = true;
    t.sd << options.noise_force, options.noise_force, options.noise_force, options.noise_moment,
        options.noise_moment, options.noise_moment;
  }
  // Whitened sensitivities: one 6 x P block per candidate.
  int p = 0;
  for (const AppliedEffect& a : effects) p += static_cast<int>(a.values.size());
  std::vector<Eigen::MatrixXd> blocks(grid.size(), Eigen::MatrixXd::Zero(6, p));
  int column = 0;
  for (size_t e = 0; e < effects.size(); ++e) {
    for (size_t i = 0; i < effects[e].values.size(); ++i, ++column) {
      const EffectParameter& par = effects[e].effect.parameters[i];
      out.labels.push_back(effects[e].effect.id + "." + par.name);
      out.units.push_back(par.unit);
      out.values.push_back(effects[e].values[i]);
      const double x0 = ident::ToInternal(par, effects[e].values[i]);
      const double h = par.scale == ParameterScale::kLog10
                           ? kLogStep
                           : kLinearStepFraction * (par.upper - par.lower);
      std::vector<AppliedEffect> plus = effects, minus = effects;
      plus[e].values[i] = ident::ToUser(par, x0 + h);
      minus[e].values[i] = ident::ToUser(par, x0 - h);
      Prediction a = PredictTrials(ApplyEffects(model.description(), plus), grid);
      Prediction b = PredictTrials(ApplyEffects(model.description(), minus), grid);
      if (a.failed || b.failed) {
        throw Error("design: the model with " + out.labels.back() +
                    " changed cannot predict a candidate: " + (a.failed ? a.message : b.message));
      }
      for (size_t k = 0; k < grid.size(); ++k) {
        for (int c = 0; c < 6; ++c)
          blocks[k](c, column) = (a.wrench[k][c] - b.wrench[k][c]) / (2 * h) / grid[k].sd[c];
      }
    }
  }
  // Greedy addition on log det(F + ridge), then exchange passes.
  std::vector<int> chosen;
  std::vector<bool> used(grid.size(), false);
  double scale = 0;
  for (const Eigen::MatrixXd& b : blocks) scale = std::max(scale, b.squaredNorm());
  const double ridge = kRidge * std::max(scale, 1e-300);
  for (int n = 0; n < options.postures; ++n) {
    const Eigen::MatrixXd F = Information(blocks, chosen, p, ridge);
    int best = -1;
    double best_value = -std::numeric_limits<double>::infinity();
    for (size_t k = 0; k < grid.size(); ++k) {
      if (used[k]) continue;
      const double v = LogDet(F + blocks[k].transpose() * blocks[k]);
      if (v > best_value) {
        best_value = v;
        best = static_cast<int>(k);
      }
    }
    if (best < 0) break;
    chosen.push_back(best);
    used[best] = true;
  }
  for (int pass = 0; pass < kExchangePasses; ++pass) {
    bool improved = false;
    for (size_t slot = 0; slot < chosen.size(); ++slot) {
      double current = LogDet(Information(blocks, chosen, p, ridge));
      for (size_t k = 0; k < grid.size(); ++k) {
        if (used[k]) continue;
        std::vector<int> trial = chosen;
        trial[slot] = static_cast<int>(k);
        const double v = LogDet(Information(blocks, trial, p, ridge));
        if (v > current + 1e-9) {
          used[chosen[slot]] = false;
          used[k] = true;
          chosen = trial;
          current = v;
          improved = true;
        }
      }
    }
    if (!improved) break;
  }
  std::sort(chosen.begin(), chosen.end());
  out.chosen_index = chosen;
  for (int k : chosen) out.chosen.push_back(grid[k]);
  const Eigen::MatrixXd F = Information(blocks, chosen, p, 0.0);
  std::vector<int> first(options.postures);
  std::iota(first.begin(), first.end(), 0);
  const Eigen::MatrixXd F_random = Information(blocks, first, p, 0.0);
  out.log_det = LogDet(F);
  out.log_det_random = LogDet(F_random);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(F);
  if (p > 0 && !(eig.eigenvalues()[0] > 1e-12 * std::max(eig.eigenvalues()[p - 1], 1e-300))) {
    // Name the parameter direction that carries no information.
    const Eigen::VectorXd v = eig.eigenvectors().col(0);
    int worst = 0;
    v.cwiseAbs().maxCoeff(&worst);
    throw Error("design: no choice of these candidate postures identifies " + out.labels[worst] +
                " (the Fisher information is singular in its direction); remove an effect or give "
                "other postures");
  }
  auto covariance_se = [&](const Eigen::MatrixXd& info, std::vector<double>* se,
                           Eigen::MatrixXd* corr) {
    const Eigen::MatrixXd cov = info.ldlt().solve(Eigen::MatrixXd::Identity(p, p));
    se->assign(p, 0.0);
    for (int i = 0; i < p; ++i) {
      const EffectParameter* par = nullptr;
      int k = i;
      for (const AppliedEffect& a : effects) {
        if (k < static_cast<int>(a.values.size())) {
          par = &a.effect.parameters[k];
          break;
        }
        k -= static_cast<int>(a.values.size());
      }
      const double s = std::sqrt(std::max(0.0, cov(i, i)));
      (*se)[i] =
          par && par->scale == ParameterScale::kLog10 ? out.values[i] * std::log(10.0) * s : s;
      if (!std::isfinite((*se)[i])) (*se)[i] = 0.0;
    }
    if (corr) {
      *corr = Eigen::MatrixXd::Identity(p, p);
      for (int i = 0; i < p; ++i) {
        for (int j = 0; j < p; ++j) {
          const double d = std::sqrt(cov(i, i) * cov(j, j));
          if (d > 0 && std::isfinite(cov(i, j) / d)) (*corr)(i, j) = cov(i, j) / d;
        }
      }
    }
  };
  covariance_se(F, &out.standard_errors, &out.correlation);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig_random(F_random);
  if (p > 0 &&
      eig_random.eigenvalues()[0] > 1e-12 * std::max(eig_random.eigenvalues()[p - 1], 1e-300)) {
    covariance_se(F_random, &out.random_standard_errors, nullptr);
  } else {
    out.random_standard_errors.assign(p, 0.0);
    out.notes.push_back("the first " + std::to_string(options.postures) +
                        " candidates alone do not identify every parameter (random SE shown as 0)");
  }
  for (int i = 0; i < p; ++i) {
    for (int j = i + 1; j < p; ++j) {
      if (std::abs(out.correlation(i, j)) > kConfounded) {
        out.confounded.push_back(
            out.labels[i] + " and " + out.labels[j] +
            " stay correlated (r = " + util::FormatNumber(out.correlation(i, j), 3) + ")");
      }
    }
  }
  return out;
}

}  // namespace isowrench
