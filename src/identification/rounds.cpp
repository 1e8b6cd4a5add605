// The rounds of the fit: the model a round starts from (Current), the folds, fitting the
// screened candidates in parallel, cross-validating the best, selecting the winner and adopting
// it (joint refit); after the rounds the simplification of a per-axis base compliance.

#include <cmath>
#include <limits>
#include <numeric>

#include "identification/fit_stages.hpp"
#include "isowrench/error.hpp"
#include "util/text.hpp"

namespace isowrench::ident {
namespace {

/// True when a held-out error beats the current model's (the criterion Select applies).
bool CvImproves(const CandidateFit& f, double cv_before, const FitOptions& options) {
  return f.cv_status == CvStatus::kDone &&
         f.cv_error <= cv_before - options.min_cv_improvement * std::min(cv_before, 1.0);
}

/// Fit: every candidate in `fit` (indices into `candidates`) jointly with the chosen effects on
/// all trials, in parallel. Returns the fits and full internal solutions in `fit` order.
std::vector<CandidateFit> FitCandidates(const LimbDescription& nominal, const Current& current,
                                        const std::vector<Effect>& candidates,
                                        const std::vector<size_t>& fit,
                                        const std::vector<Trial>& trials, const FitOptions& options,
                                        const std::string& label,
                                        std::vector<std::vector<double>>* solutions) {
  const AugmentedModel base = ApplyEffects(nominal, {});
  const std::vector<int> all = AllIndices(trials.size());
  std::vector<CandidateFit> fits(fit.size());
  solutions->assign(fit.size(), {});
  StageProgress progress(options, label + ": fitted", fit.size(), false);
  ParallelFor(fit.size(), options, [&](size_t i) {
    const auto start = std::chrono::steady_clock::now();
    const double cpu = ThreadCpuSeconds();
    const Effect& e = candidates[fit[i]];
    const std::vector<AppliedEffect> kept = Kept(current.effects, e);
    fits[i] = FitOnSubset(base, kept, e, trials, all, options, nullptr, true, &(*solutions)[i]);
    int free = static_cast<int>(e.per_trial ? 0 : e.parameters.size());
    for (const AppliedEffect& a : kept)
      free += static_cast<int>(a.effect.per_trial ? 0 : a.effect.parameters.size());
    progress.Done(
        e.id + ", " + std::to_string(free) + " least-squares parameter" + (free == 1 ? "" : "s"),
        SecondsSince(start), ThreadCpuSeconds() - cpu);
  });
  return fits;
}

/// Cross-validate the candidates that could win (converged, identifiable, over the ΔBIC
/// threshold) in BIC order, at most options.cv_candidates of them, until one lowers the held-out
/// error (the ones after it cannot win: Select takes the first that passes). cv_error is the
/// held-out robust cost per residual. The folds run in parallel.
void CrossValidate(const LimbDescription& nominal, const Current& current,
                   const std::vector<Trial>& trials, const Folds& folds, const FitOptions& options,
                   double threshold, double cv_before,
                   const std::map<std::string, std::vector<double>>& solutions,
                   const std::string& label, std::vector<CandidateFit>* candidates) {
  if (folds.train.empty()) return;
  const AugmentedModel base = ApplyEffects(nominal, {});
  const size_t fold_count = folds.train.size();
  int done = 0;
  for (CandidateFit& f : *candidates) {
    if (done >= options.cv_candidates) break;
    if (!f.converged || !f.identifiable || !f.not_claimed.empty() || f.delta_bic < threshold)
      continue;
    ++done;
    const auto clock = std::chrono::steady_clock::now();
    const std::vector<double>& start = solutions.at(f.effect.id);
    const std::vector<AppliedEffect> kept = Kept(current.effects, f.effect);
    std::vector<Effect> free;
    for (const AppliedEffect& a : kept) free.push_back(a.effect);
    free.push_back(f.effect);
    // Per-trial factors are not known on held-out rows: they are predicted by the training
    // fold's levels and spread (the marginal likelihood of each held-out factor, Context::Cost).
    std::vector<double> held_cost(fold_count, 0.0);
    std::vector<int> held_n(fold_count, 0);
    std::vector<char> fold_ok(fold_count, 0);
    ParallelFor(fold_count, options, [&](size_t fold) {
      std::vector<double> x;
      CandidateFit g =
          FitOnSubset(base, kept, f.effect, trials, folds.train[fold], options, &start, false, &x);
      if (!g.converged) return;
      Context c = MakeContext(base, free, trials, folds.test[fold], options);
      Readings prediction;
      if (!c.Predict(x.data(), &prediction)) return;
      ForceLevels training;
      if (prediction.per_trial) {
        Context t = MakeContext(base, free, trials, folds.train[fold], options);
        Readings fitted;
        if (!t.Predict(x.data(), &fitted)) return;
        training = FitForceLevels(t, fitted);
      }
      held_cost[fold] = c.Cost(prediction, prediction.per_trial ? &training : nullptr);
      held_n[fold] = static_cast<int>(6 * folds.test[fold].size());
      fold_ok[fold] = 1;
    });
    double cost = 0.0;
    int n = 0;
    bool ok = true;
    for (size_t fold = 0; fold < fold_count; ++fold) {
      ok &= fold_ok[fold] != 0;
      cost += held_cost[fold];
      n += held_n[fold];
    }
    if (ok && n > 0) {
      f.cv_status = CvStatus::kDone;
      f.cv_error = cost / n;
    } else {
      f.cv_status = CvStatus::kFailed;
    }
    Say(options, label + ": cross-validated " + f.effect.id + " (" + std::to_string(fold_count) +
                     " folds, " + util::FormatNumber(SecondsSince(clock), 3) + " s)");
    if (CvImproves(f, cv_before, options)) break;
  }
}

/// Select: each candidate's verdict; the winner (if any) goes to r->chosen.
void Select(FitRound* r, bool cross_validated, const FitOptions& options) {
  for (size_t i = 0; i < r->candidates.size(); ++i) {
    CandidateFit& f = r->candidates[i];
    // The parameters the criteria charge it (its k in the round table).
    std::string p =
        std::to_string(f.added_parameters) + " parameter" + (f.added_parameters == 1 ? "" : "s");
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
    } else if (!f.not_claimed.empty()) {
      f.verdict = "not claimed: " + f.not_claimed;
    } else if (!f.identifiable) {
      f.verdict = "not identifiable from these data: " + f.identifiability;
    } else if (cross_validated && f.cv_status == CvStatus::kNotRun && !r->chosen) {
      f.verdict = "not cross-validated (the cross-validation limit was reached)";
    } else if (cross_validated && f.cv_status != CvStatus::kNotRun &&
               !CvImproves(f, r->cv_before, options)) {
      f.verdict = f.cv_status == CvStatus::kFailed
                      ? "cross-validation fit failed"
                      : "held-out error not lower: " + util::FormatNumber(f.cv_error, 4) + " vs " +
                            util::FormatNumber(r->cv_before, 4) + " per residual";
    } else if (!r->chosen) {
      r->chosen = i;
      f.accepted = true;
      f.verdict = "chosen";
    } else {
      const CandidateFit& w = r->candidates[*r->chosen];
      double gap = f.bic - w.bic;
      f.verdict = "worse than " + w.effect.id + " by ΔBIC = " + util::FormatNumber(gap, 3);
      if (gap < options.indistinguishable_bic) {
        f.verdict += " (indistinguishable at these postures)";
        r->indistinguishable.push_back(f.effect.id);
      }
    }
  }
}

/// Parameters a candidate adds to the current model (what its BIC penalty counts): the model
/// with it (replacing what it contains) less the current one.
int AddedParameters(const Current& current, const Effect& candidate,
                    const std::vector<Trial>& trials) {
  std::vector<AppliedEffect> with = Kept(current.effects, candidate);
  with.push_back({candidate, {}});
  return TotalParameters(with, trials) - current.parameters;
}

}  // namespace

Current MakeCurrent(const LimbDescription& nominal, const std::vector<AppliedEffect>& effects,
                    const std::vector<CandidateFit>& fits, const std::vector<Trial>& trials,
                    const FitOptions& options) {
  Current c;
  c.effects = effects;
  c.fits = fits;
  c.augmented = ApplyEffects(nominal, effects);
  const Context context = MakeContext(c.augmented, {}, trials, AllIndices(trials.size()), options);
  Readings p;
  std::string message;
  if (!context.Predict(nullptr, &p, &message))
    throw Error("fit: the model with the chosen effects cannot predict the trials: " + message);
  c.prediction = p.reading;
  c.cost = context.Cost(p);
  c.parameters = TotalParameters(effects, trials);
  c.residual_parameters = ResidualParameters(effects, static_cast<int>(trials.size()));
  return c;
}

Folds MakeFolds(size_t trial_count, const FitOptions& options) {
  Folds f;
  const int folds = options.folds;
  if (folds < 2 || static_cast<int>(trial_count) < folds) return f;
  std::vector<int> order = AllIndices(trial_count);
  Random rng(options.cv_seed);
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

namespace {

/// A per-axis base compliance replaced by the isotropic one (start: the geometric mean).
bool SimplifyBase(const Model& nominal, const std::vector<Trial>& trials, const FitOptions& options,
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
    Say(options, "simplify: trying base_isotropic in place of base_per_axis");
    JointFit joint = FitJointly(nominal.description(), alt, trials, options);
    const int k_alt = TotalParameters(alt, trials);
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

/// An effect that contains others replaced by the subset of them with the lowest BIC (each
/// subset refitted jointly with the other chosen effects, the contained effects from their
/// initial values), when that BIC is below the current one.
bool SimplifyContained(const Model& nominal, const std::vector<Trial>& trials,
                       const FitOptions& options, Current* current, std::string* note) {
  const int n = static_cast<int>(6 * trials.size());
  const bool sd_stated = AllSd(trials);
  const std::vector<Effect> library = CandidateEffects(nominal);
  for (size_t i = 0; i < current->effects.size(); ++i) {
    const Effect& big = current->effects[i].effect;
    std::vector<Effect> parts;
    for (const std::string& id : big.contains) {
      for (const Effect& e : library) {
        if (e.id == id) parts.push_back(e);
      }
    }
    if (parts.empty() || parts.size() > 8) continue;
    const double bic_now = Bic(current->cost, n, current->parameters, sd_stated);
    double best_bic = bic_now;
    JointFit best;
    std::vector<std::string> best_ids;
    for (unsigned mask = 0; mask < (1u << parts.size()); ++mask) {
      std::vector<AppliedEffect> alt;
      std::vector<std::string> ids;
      for (size_t e = 0; e < current->effects.size(); ++e) {
        if (e != i) alt.push_back(current->effects[e]);
      }
      for (size_t p = 0; p < parts.size(); ++p) {
        if (!(mask & (1u << p))) continue;
        std::vector<double> start;
        for (const EffectParameter& q : parts[p].parameters) start.push_back(q.initial);
        alt.push_back({parts[p], start});
        ids.push_back(parts[p].id);
      }
      Say(options, "simplify: trying " + (ids.empty() ? "nothing" : util::Join(ids, " + ")) +
                       " in place of " + big.id);
      double bic_alt = 0.0;
      JointFit joint;
      if (alt.empty()) {
        const Current none = MakeCurrent(nominal.description(), {}, {}, trials, options);
        bic_alt = Bic(none.cost, n, 0, sd_stated);
        joint.usable = true;
      } else {
        joint = FitJointly(nominal.description(), alt, trials, options);
        if (!joint.usable) continue;
        bic_alt = Bic(joint.cost, n, TotalParameters(alt, trials), sd_stated);
      }
      if (bic_alt < best_bic) {
        best_bic = bic_alt;
        best = joint;
        best_ids = ids;
      }
    }
    if (!(best_bic < bic_now)) continue;
    *note = big.id + " replaced by " +
            (best_ids.empty() ? "nothing" : util::Join(best_ids, " + ")) +
            ": the contained effect" + (best_ids.size() == 1 ? " explains" : "s explain") +
            " the data with fewer parameters (BIC " + util::FormatNumber(bic_now, 6) + " -> " +
            util::FormatNumber(best_bic, 6) + ")";
    *current = MakeCurrent(nominal.description(), best.effects, best.fits, trials, options);
    return true;
  }
  return false;
}

}  // namespace

bool Simplify(const Model& nominal, const std::vector<Trial>& trials, const FitOptions& options,
              Current* current, std::vector<std::string>* notes) {
  bool changed = false;
  std::string note;
  if (SimplifyBase(nominal, trials, options, current, &note)) {
    notes->push_back(note);
    changed = true;
  }
  // Each replacement can enable another (an effect that contains one that contains others).
  for (int pass = 0; pass < 4 && SimplifyContained(nominal, trials, options, current, &note);
       ++pass) {
    notes->push_back(note);
    changed = true;
  }
  return changed;
}

FitRound RunRound(int index, const Model& nominal, const std::vector<Effect>& library,
                  const Current& current, const std::vector<Trial>& trials, const Folds& folds,
                  const FitOptions& options,
                  std::map<std::string, std::vector<double>>* solutions) {
  const bool sd_stated = AllSd(trials);
  const int n = static_cast<int>(6 * trials.size());
  FitRound r;
  r.index = index;
  r.before = ComputeResidualStats(trials, current.prediction, current.residual_parameters, options);
  r.bic_before = Bic(current.cost, n, current.parameters, sd_stated);
  r.cv_before = current.cost / n;
  const std::vector<Effect> screened = Eligible(library, current);
  // Rank by the linearised ΔBIC and fit the screen_keep best (all when there are few).
  std::vector<size_t> order(screened.size());
  std::iota(order.begin(), order.end(), size_t{0});
  std::vector<double> score(screened.size(), 0.0);
  std::vector<std::string> why;
  const bool screening =
      options.screen_keep > 0 && static_cast<int>(screened.size()) > options.screen_keep;
  const std::string label = "round " + std::to_string(index);
  auto stage = [&](const std::string& what) { Say(options, label + ": " + what); };
  if (screening) {
    stage("screening " + std::to_string(screened.size()) +
          " candidates (linearised ΔBIC at the current model)");
    score = ScreenScores(nominal.description(), current, screened, trials, options, label, &why);
    // A score that is not a number ranks last (a NaN in the comparison would break the
    // ordering the sort needs, and with it which candidates are fitted).
    for (double& s : score) {
      if (std::isnan(s)) s = -std::numeric_limits<double>::infinity();
    }
    std::stable_sort(order.begin(), order.end(),
                     [&](size_t a, size_t b) { return score[a] > score[b]; });
  }
  // The screen_keep best of the least-squares candidates, and every per-trial one besides
  // (solved in closed form, it has no linearised score and takes no place of theirs).
  std::vector<size_t> keep, drop;
  int ranked = 0;
  for (size_t rank = 0; rank < order.size(); ++rank) {
    const size_t i = order[rank];
    const bool kept = !screening || screened[i].per_trial || ranked++ < options.screen_keep;
    (kept ? keep : drop).push_back(i);
  }
  stage("fitting " + std::to_string(keep.size()) + " of " + std::to_string(screened.size()) +
        " candidates");
  std::vector<std::vector<double>> x;
  std::vector<CandidateFit> fits =
      FitCandidates(nominal.description(), current, screened, keep, trials, options, label, &x);
  solutions->clear();
  for (size_t i = 0; i < keep.size(); ++i) {
    fits[i].delta_bic = r.bic_before - fits[i].bic;
    fits[i].added_parameters = AddedParameters(current, screened[keep[i]], trials);
    if (screening) fits[i].screen_delta_bic = score[keep[i]];
    (*solutions)[screened[keep[i]].id] = x[i];
    r.candidates.push_back(std::move(fits[i]));
  }
  for (size_t i : drop) {
    CandidateFit f;
    f.effect = screened[i];
    f.correlation = Eigen::MatrixXd::Identity(0, 0);
    f.screened_out = true;
    f.added_parameters = AddedParameters(current, screened[i], trials);
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
                r.cv_before, *solutions, label, &r.candidates);
  Select(&r, !folds.train.empty(), options);
  if (!r.chosen) {
    r.summary = "no candidate earns its parameters";
    if (!r.candidates.empty())
      r.summary += " (best: " + r.candidates[0].effect.id + ", " + r.candidates[0].verdict + ")";
  } else {
    const CandidateFit& w = r.candidates[*r.chosen];
    r.summary = "added " + w.effect.id + " (" + ValueText(w.effect, w.values, w.standard_errors) +
                "), ΔBIC = " + util::FormatNumber(w.delta_bic, 4);
  }
  return r;
}

Current Adopt(const Model& nominal, const Current& current, const FitRound& r,
              const std::vector<Trial>& trials, const FitOptions& options) {
  const CandidateFit& winner = r.candidates[*r.chosen];
  // The effects the winner contains are replaced by it.
  std::vector<AppliedEffect> chosen;
  std::vector<CandidateFit> fits;
  for (size_t e = 0; e < current.effects.size(); ++e) {
    if (Contains(winner.effect, current.effects[e].effect)) continue;
    chosen.push_back(current.effects[e]);
    fits.push_back(current.fits[e]);
  }
  chosen.push_back({winner.effect, winner.values});
  fits.push_back(winner);
  if (chosen.size() > 1) {
    Say(options, "round " + std::to_string(r.index) + ": refitting the " +
                     std::to_string(chosen.size()) + " chosen effects jointly");
    JointFit joint = FitJointly(nominal.description(), chosen, trials, options);
    if (joint.usable && joint.cost <= winner.cost * (1 + 1e-9) + 1e-12) {
      for (size_t e = 0; e < chosen.size(); ++e) {
        chosen[e].values = joint.effects[e].values;
        CandidateFit f = joint.fits[e];
        f.delta_bic = fits[e].delta_bic;
        f.added_parameters = fits[e].added_parameters;
        f.cv_status = fits[e].cv_status;
        f.cv_error = fits[e].cv_error;
        fits[e] = f;
      }
    }
  }
  return MakeCurrent(nominal.description(), chosen, fits, trials, options);
}

}  // namespace isowrench::ident
