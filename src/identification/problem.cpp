// The least-squares problem of a set of free effects on a subset of the trials (Context): its
// prediction, robust cost and residuals; the information criteria; small helpers the stages
// share. No Ceres here (solve.cpp drives the solver).

#include <time.h>

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <numeric>

#include "identification/effect_type.hpp"
#include "identification/fit_stages.hpp"
#include "isowrench/error.hpp"
#include "util/text.hpp"

namespace isowrench {

double ident::Bic(double chi2, int n, int k, bool sd_stated) {
  double fit = sd_stated ? chi2 : n * std::log(std::max(chi2, 1e-300) / n);
  return fit + k * std::log(static_cast<double>(n));
}

double ident::LinearisedDeltaBic(const Eigen::MatrixXd& D, const Eigen::VectorXd& r, int n,
                                 bool sd_stated, int k) {
  const double cost = r.squaredNorm();
  if (D.cols() == 0) return 0.0;
  if (k < 0) k = static_cast<int>(D.cols());
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(D);
  // Sensitivities that are all exactly 0 (an effect with no influence at its neutral value)
  // reduce nothing; the solve would divide 0 by 0.
  if (qr.rank() == 0) return ident::Bic(cost, n, 0, sd_stated) - ident::Bic(cost, n, k, sd_stated);
  const Eigen::VectorXd projected = D * qr.solve(r);
  const double reduction = std::min(projected.squaredNorm(), cost);
  return ident::Bic(cost, n, 0, sd_stated) -
         ident::Bic(std::max(cost - reduction, 1e-300), n, k, sd_stated);
}

namespace ident {

double ThreadCpuSeconds() {
#if defined(CLOCK_THREAD_CPUTIME_ID)
  timespec t{};
  if (clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t) == 0) return t.tv_sec + 1e-9 * t.tv_nsec;
#endif
  return 0.0;
}

void Say(const FitOptions& options, const std::string& line) {
  if (!options.progress) return;
  static std::mutex mutex;
  std::lock_guard<std::mutex> lock(mutex);
  options.progress(line);
}

StageProgress::StageProgress(const FitOptions& options, std::string prefix, size_t total,
                             bool throttled)
    : options_(options),
      prefix_(std::move(prefix)),
      total_(total),
      throttled_(throttled),
      start_(std::chrono::steady_clock::now()),
      last_(start_) {}

void StageProgress::Done(const std::string& what, double seconds, double cpu) {
  if (!options_.progress) return;
  std::lock_guard<std::mutex> lock(mutex_);
  ++done_;
  if (throttled_ && done_ < total_ && SecondsSince(last_) < kProgressSeconds) return;
  last_ = std::chrono::steady_clock::now();
  std::string line = prefix_ + " " + std::to_string(done_) + " of " + std::to_string(total_);
  if (throttled_) {
    line += " (" + util::FormatNumber(SecondsSince(start_), 3) + " s)";
  } else {
    line += " (" + what + ", " + util::FormatNumber(seconds, 3) + " s";
    if (cpu >= 0) line += ", " + util::FormatNumber(cpu, 3) + " s CPU";
    line += ")";
  }
  Say(options_, line);
}

double RowLoss(double s, const FitOptions& o) {
  if (o.loss == RobustLoss::kNone || !(s > 0)) return s;
  const double k = o.loss_scale;
  const double u = std::sqrt(s / 6.0);  // RMS noise multiple of the row
  if (o.loss == RobustLoss::kHuber) return u <= k ? s : 6.0 * (2.0 * k * u - k * k);
  return 6.0 * k * k * std::log1p(u * u / (k * k));
}

std::vector<double> Context::UserValues(const double* x, int e) const {
  std::vector<double> v;
  const Effect& effect = free[e];
  for (size_t i = 0; i < effect.parameters.size(); ++i) {
    // Per-trial parameters are solved in closed form inside the prediction: their value here
    // only switches the effect on.
    v.push_back(effect.per_trial ? effect.parameters[i].neutral
                                 : ToUser(effect.parameters[i], x[start[e] + i]));
  }
  return v;
}

int Context::CountedParameters() const {
  int k = parameter_count;
  for (const Effect& e : free) k += e.per_trial ? 1 + MuscleCount(*trials, subset) : 0;
  return k;
}

int Context::ResidualParameters() const {
  int k = parameter_count;
  for (const Effect& e : free) k += e.per_trial ? static_cast<int>(subset.size()) : 0;
  return k;
}

bool Context::Predict(const double* x, std::vector<Vector6d>* out, std::string* message,
                      std::vector<double>* factors) const {
  Readings r;
  if (!Predict(x, &r, message)) return false;
  *out = std::move(r.reading);
  if (factors) *factors = std::move(r.factor);
  return true;
}

bool Context::Predict(const double* x, Readings* result, std::string* message) const {
  std::vector<Vector6d>* out = &result->reading;
  std::vector<double>* factors = &result->factor;
  try {
    AugmentedModel m = base;
    for (size_t e = 0; e < free.size(); ++e) {
      TypeOf(free[e]).Apply(free[e], UserValues(x, static_cast<int>(e)), &m);
    }
    for (const auto& c : m.coactivation) {
      if (std::find(others.begin(), others.end(), c.first) == others.end()) {
        throw Error("coactivation of '" + c.first + "' was not prepared");
      }
    }
    result->per_trial = m.trial_force;
    // The reading at factor 1 is needed for per-trial factors only (ForceLevels).
    std::vector<Vector6d>* unit = m.trial_force ? &result->unit : nullptr;
    if (cached) {
      ComposeReadings(m, *trials, subset, raw, options, out, factors, unit);
      return raw.all_ok() || Fail(raw.message, message);
    }
    // The statics depend only on the free model- and posture-stage parameters: numeric
    // derivatives along the others (a crosstalk term, a sensor offset) reuse the raw wrenches
    // of the last two such points (the muscle forces are rescaled by ComposeReadings).
    std::vector<double> key;
    for (size_t e = 0; e < free.size(); ++e) {
      if (free[e].stage != EffectStage::kModel && free[e].stage != EffectStage::kPosture) continue;
      for (int i = 0; i < FreeCount(static_cast<int>(e)); ++i) key.push_back(x[start[e] + i]);
    }
    const RawWrenches* found = nullptr;
    for (const RawCache& c : raw_cache_) {
      if (c.valid && c.key == key) found = &c.raw;
    }
    if (!found) {
      RawCache& slot = raw_cache_[raw_cache_next_];
      raw_cache_next_ = 1 - raw_cache_next_;
      slot.valid = false;
      if (rebuild) {
        Model built(m.description);
        slot.raw = EvaluateRaw(built, m.posture_offset, others, *trials, subset, passive);
      } else {
        slot.raw = EvaluateRaw(*model, m.posture_offset, others, *trials, subset, passive);
      }
      slot.key = key;
      slot.valid = true;
      found = &slot.raw;
    }
    const RawWrenches& r = *found;
    if (!r.all_ok()) return Fail(r.message, message);
    ComposeReadings(m, *trials, subset, r, options, out, factors, unit);
    for (const Vector6d& w : *out) {
      if (!w.allFinite()) return Fail("a predicted reading is not finite", message);
    }
    return true;
  } catch (const Error& e) {
    return Fail(e.what(), message);
  }
}

double Context::RowChi2(size_t k, const Vector6d& prediction) const {
  const Trial& t = (*trials)[subset[k]];
  double s = 0;
  for (int c = 0; c < 6; ++c) s += std::pow(weights[6 * k + c] * (t.wrench[c] - prediction[c]), 2);
  return s;
}

double Context::Cost(const std::vector<Vector6d>& prediction) const {
  double cost = 0.0;
  for (size_t k = 0; k < subset.size(); ++k) cost += RowLoss(RowChi2(k, prediction[k]), options);
  return cost;
}

double Context::Cost(const Readings& r, const ForceLevels* fixed) const {
  if (!r.per_trial) return Cost(r.reading);
  return FitForceLevels(*this, r, fixed).cost;
}

void Context::Residuals(const std::vector<Vector6d>& prediction, double* residuals) const {
  for (size_t k = 0; k < subset.size(); ++k) {
    const Trial& t = (*trials)[subset[k]];
    const double s = RowChi2(k, prediction[k]);
    const double scale = s > 0 ? std::sqrt(RowLoss(s, options) / s) : 1.0;
    for (int c = 0; c < 6; ++c)
      residuals[6 * k + c] = scale * weights[6 * k + c] * (t.wrench[c] - prediction[k][c]);
  }
}

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
    for (int j = 0; j < 6; ++j) c.weights[6 * k + j] = Weight(trials[subset[k]], j, options);
  }
  c.others = CoactivatedMuscles(base);
  c.passive = base.trial_force;
  bool posture = false;
  c.rebuild = false;
  for (const Effect& e : free) {
    if (e.kind == "coactivation" &&
        std::find(c.others.begin(), c.others.end(), e.muscle) == c.others.end()) {
      c.others.push_back(e.muscle);
    }
    posture |= e.stage == EffectStage::kPosture;
    c.rebuild |= e.stage == EffectStage::kModel;
    c.passive |= e.kind == "trial_force";
  }
  if (!c.rebuild) {
    try {
      c.model = std::make_shared<const Model>(base.description);
      if (!posture) {
        c.raw = EvaluateRaw(*c.model, base.posture_offset, c.others, trials, subset, c.passive);
        c.cached = true;
      }
    } catch (const Error& e) {
      c.rebuild = true;  // let Predict report it
      c.setup_message = e.what();
    }
  }
  return c;
}

std::vector<double> Bounds(const Context& c, bool upper) {
  std::vector<double> v;
  for (size_t e = 0; e < c.free.size(); ++e) {
    if (c.free[e].per_trial) continue;
    for (const EffectParameter& p : c.free[e].parameters)
      v.push_back(ToInternal(p, upper ? p.upper : p.lower));
  }
  return v;
}

double Aicc(double chi2, int n, int k, bool sd_stated) {
  double fit = sd_stated ? chi2 : n * std::log(std::max(chi2, 1e-300) / n);
  double correction = n - k - 1 > 0 ? 2.0 * k * (k + 1) / (n - k - 1) : 0.0;
  return fit + 2.0 * k + correction;
}

bool AllSd(const std::vector<Trial>& trials) {
  return std::all_of(trials.begin(), trials.end(), [](const Trial& t) { return t.has_sd; });
}

std::string ParameterLabel(const Context& c, int i, bool always_prefix) {
  for (size_t e = 0; e < c.free.size(); ++e) {
    int local = i - c.start[e];
    if (local >= 0 && local < c.FreeCount(static_cast<int>(e))) {
      return (c.free.size() > 1 || always_prefix ? c.free[e].id + "." : std::string()) +
             c.free[e].parameters[local].name;
    }
  }
  return "?";
}

std::vector<double> InternalValues(const Effect& e, const std::vector<double>* values) {
  std::vector<double> x;
  if (e.per_trial) return x;
  for (size_t i = 0; i < e.parameters.size(); ++i) {
    const EffectParameter& p = e.parameters[i];
    x.push_back(ToInternal(p, values ? (*values)[i] : p.initial));
  }
  return x;
}

int MuscleCount(const std::vector<Trial>& trials, const std::vector<int>& subset) {
  std::vector<const std::string*> seen;
  for (int t : subset) {
    const std::string& m = trials[t].muscle;
    if (std::none_of(seen.begin(), seen.end(), [&](const std::string* s) { return *s == m; }))
      seen.push_back(&m);
  }
  return static_cast<int>(seen.size());
}

int TotalParameters(const std::vector<AppliedEffect>& effects, const std::vector<Trial>& trials) {
  int k = 0;
  for (const AppliedEffect& a : effects) {
    k += a.effect.per_trial ? 1 + MuscleCount(trials, AllIndices(trials.size()))
                            : static_cast<int>(a.effect.parameters.size());
  }
  return k;
}

int ResidualParameters(const std::vector<AppliedEffect>& effects, int trial_count) {
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

double RobustSpread(std::vector<double> v, double* median_out) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const double median = v[v.size() / 2];
  if (median_out) *median_out = median;
  for (double& x : v) x = std::abs(x - median);
  std::sort(v.begin(), v.end());
  return 1.4826 * v[v.size() / 2];
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

}  // namespace ident
}  // namespace isowrench
