// Screening: the candidates a round may try, ranked by their linearised ΔBIC at the current
// model (a score test) so that only the best are fitted fully (rounds.cpp).

#include <Eigen/QR>
#include <cmath>
#include <limits>

#include "identification/fit_stages.hpp"

namespace isowrench::ident {

std::vector<Effect> Eligible(const std::vector<Effect>& library, const Current& current) {
  std::vector<Effect> out;
  for (const Effect& e : library) {
    bool excluded = false;
    // A candidate that contains a chosen effect stays eligible: it would replace it.
    for (const AppliedEffect& a : current.effects)
      excluded |= Excluded(e, a.effect) || Contains(a.effect, e);
    if (!excluded) out.push_back(e);
  }
  return out;
}

std::vector<AppliedEffect> Kept(const std::vector<AppliedEffect>& chosen, const Effect& candidate) {
  std::vector<AppliedEffect> out;
  for (const AppliedEffect& a : chosen) {
    if (!Contains(candidate, a.effect)) out.push_back(a);
  }
  return out;
}

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

namespace {

/// One candidate's linearised ΔBIC (ScreenScores): +inf for a per-trial one (always fitted),
/// -inf with `why` when it cannot be evaluated near its neutral value.
void ScoreCandidate(const Current& current, const Effect& e, const std::vector<Trial>& trials,
                    const std::vector<int>& all, int n, bool sd_stated, const Eigen::MatrixXd& Q,
                    const FitOptions& options, double* score, std::string* why) {
  if (e.per_trial) {
    *score = std::numeric_limits<double>::infinity();
    return;
  }

  std::vector<double> x0, step;
  for (const EffectParameter& q : e.parameters) {
    const double neutral = ToInternal(q, q.neutral);
    const double initial = ToInternal(q, q.initial);
    const double range = ToInternal(q, q.upper) - ToInternal(q, q.lower);
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
    *score = -std::numeric_limits<double>::infinity();
    *why = "cannot be evaluated near its neutral value: " + message;
    return;
  }
  if (D.cols() == 0) return;  // no parameter: nothing to gain (score 0)
  if (Q.cols() > 0) {
    D -= Q * (Q.transpose() * D);
    r -= Q * (Q.transpose() * r);
  }
  // The penalty of what it adds: a candidate that contains chosen effects replaces them.
  int k = static_cast<int>(e.parameters.size());
  for (const AppliedEffect& a : current.effects)
    k -= Contains(e, a.effect) ? static_cast<int>(a.effect.parameters.size()) : 0;
  *score = LinearisedDeltaBic(D, r, n, sd_stated, k);
}

}  // namespace

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
                                 const std::string& label, std::vector<std::string>* why) {
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
          step.push_back(1e-3 * (ToInternal(q, q.upper) - ToInternal(q, q.lower)));
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
  StageProgress progress(options, label + ": screened", candidates.size(), true);
  ParallelFor(candidates.size(), options, [&](size_t i) {
    const auto start = std::chrono::steady_clock::now();
    ScoreCandidate(current, candidates[i], trials, all, n, sd_stated, Q, options, &score[i],
                   &(*why)[i]);
    progress.Done(candidates[i].id, SecondsSince(start));
  });
  return score;
}
}  // namespace isowrench::ident
