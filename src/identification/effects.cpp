// The effect registry (one kind per file in effects/, listed by CMake in effect_list.inc) and
// what is built on it: the candidate library of a model, applying effects, parsing assignments.

#include <algorithm>
#include <cmath>

#include "identification/effect_type.hpp"
#include "identification/identification_impl.hpp"
#include "isowrench/error.hpp"
#include "util/text.hpp"

namespace isowrench {
namespace ident {

#define ISOWRENCH_EFFECT(kind) std::unique_ptr<EffectType> MakeEffect_##kind();
#include "effect_list.inc"
#undef ISOWRENCH_EFFECT

const std::vector<const EffectType*>& EffectTypes() {
  static const std::vector<std::unique_ptr<EffectType>> owned = [] {
    std::vector<std::unique_ptr<EffectType>> v;
#define ISOWRENCH_EFFECT(kind) v.push_back(MakeEffect_##kind());
#include "effect_list.inc"
#undef ISOWRENCH_EFFECT
    std::sort(v.begin(), v.end(),
              [](const std::unique_ptr<EffectType>& a, const std::unique_ptr<EffectType>& b) {
                return a->Info().kind < b->Info().kind;
              });
    return v;
  }();
  static const std::vector<const EffectType*> types = [] {
    std::vector<const EffectType*> v;
    for (const auto& t : owned) v.push_back(t.get());
    return v;
  }();
  return types;
}

const EffectType& TypeOf(const Effect& effect) {
  for (const EffectType* t : EffectTypes()) {
    if (t->Info().kind == effect.kind) return *t;
  }
  throw Error("effect '" + effect.id + "': unknown kind '" + effect.kind + "'");
}

EffectParameter LogParameter(const std::string& name, const std::string& unit, double neutral,
                             double initial, double lower, double upper) {
  EffectParameter p;
  p.name = name;
  p.unit = unit;
  p.scale = ParameterScale::kLog10;
  p.neutral = neutral;
  p.initial = initial;
  p.lower = lower;
  p.upper = upper;
  return p;
}

EffectParameter LinearParameter(const std::string& name, const std::string& unit, double range) {
  EffectParameter p;
  p.name = name;
  p.unit = unit;
  p.scale = ParameterScale::kLinear;
  p.lower = -range;
  p.upper = range;
  return p;
}

const char* AxisName(int axis) {
  static const char* names[6] = {"fx", "fy", "fz", "mx", "my", "mz"};
  return axis >= 0 && axis < 6 ? names[axis] : "?";
}

int AxisIndex(const std::string& name) {
  for (int axis = 0; axis < 6; ++axis) {
    if (name == AxisName(axis)) return axis;
  }
  return -1;
}

bool Wanted(const std::vector<std::string>& muscles, const std::string& muscle) {
  return muscles.empty() || std::find(muscles.begin(), muscles.end(), muscle) != muscles.end();
}

bool Excluded(const Effect& a, const Effect& b) {
  if (a.id == b.id) return true;
  return std::find(a.excludes.begin(), a.excludes.end(), b.id) != a.excludes.end() ||
         std::find(b.excludes.begin(), b.excludes.end(), a.id) != b.excludes.end();
}

bool Contains(const Effect& a, const Effect& b) {
  return std::find(a.contains.begin(), a.contains.end(), b.id) != a.contains.end();
}

std::uint64_t Random::Next() {
  std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

double Random::Uniform() { return static_cast<double>(Next() >> 11) * 0x1.0p-53; }

double Random::Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }

double Random::Normal() {
  if (has_spare_) {
    has_spare_ = false;
    return spare_;
  }
  double u1 = 0.0;
  do {
    u1 = Uniform();
  } while (u1 <= 0.0);
  double u2 = Uniform();
  double r = std::sqrt(-2.0 * std::log(u1));
  spare_ = r * std::sin(2 * kPi * u2);
  has_spare_ = true;
  return r * std::cos(2 * kPi * u2);
}

double ToInternal(const EffectParameter& p, double user) {
  return p.scale == ParameterScale::kLog10 ? std::log10(user) : user;
}

double ToUser(const EffectParameter& p, double internal) {
  return p.scale == ParameterScale::kLog10 ? std::pow(10.0, internal) : internal;
}

}  // namespace ident

const char* EffectStageName(EffectStage stage) {
  switch (stage) {
    case EffectStage::kPosture: return "posture";
    case EffectStage::kModel: return "model";
    case EffectStage::kForce: return "muscle force";
    case EffectStage::kMeasurement: return "measurement";
  }
  return "?";
}

std::vector<EffectKindInfo> EffectKinds() {
  std::vector<EffectKindInfo> out;
  for (const ident::EffectType* t : ident::EffectTypes()) out.push_back(t->Info());
  return out;
}

std::vector<Effect> CandidateEffects(const Model& model, const std::vector<std::string>& muscles) {
  // Model-stage effects first (as the library always listed them), then the others, each group
  // in registry (kind name) order.
  std::vector<Effect> out;
  for (int pass = 0; pass < 2; ++pass) {
    for (const ident::EffectType* t : ident::EffectTypes()) {
      if ((t->Info().stage == EffectStage::kModel) != (pass == 0)) continue;
      for (Effect& e : t->Candidates(model, muscles)) out.push_back(std::move(e));
    }
  }
  return out;
}

Effect FindEffect(const Model& model, const std::string& id) {
  std::vector<Effect> all = CandidateEffects(model);
  std::vector<std::string> ids;
  for (const Effect& e : all) {
    if (e.id == id) return e;
    ids.push_back(e.id);
  }
  for (const ident::EffectType* t : ident::EffectTypes()) {
    const std::string kind = t->Info().kind;
    if (id.compare(0, kind.size() + 1, kind + ":") != 0) continue;
    const std::string why = t->WhyNotCandidate(model, id);
    if (!why.empty()) throw Error("effect '" + id + "': " + why);
  }
  throw Error("unknown effect '" + id + "' for model '" + model.name() +
              "' (known: " + util::Join(ids, ", ") + ")");
}

namespace {

void CheckValues(const Effect& effect, const std::vector<double>& values) {
  if (values.size() != effect.parameters.size()) {
    throw Error("effect '" + effect.id + "' takes " + std::to_string(effect.parameters.size()) +
                " value(s), got " + std::to_string(values.size()));
  }
  for (size_t i = 0; i < values.size(); ++i) {
    const EffectParameter& p = effect.parameters[i];
    if (!std::isfinite(values[i]) || (p.scale == ParameterScale::kLog10 && !(values[i] > 0))) {
      throw Error("effect '" + effect.id + "': parameter " + p.name + " = " +
                  util::FormatNumber(values[i]) + " must be finite" +
                  (p.scale == ParameterScale::kLog10 ? " and > 0" : ""));
    }
  }
}

}  // namespace

LimbDescription ApplyEffect(LimbDescription d, const Effect& effect,
                            const std::vector<double>& values) {
  CheckValues(effect, values);
  AugmentedModel m;
  m.description = std::move(d);
  ident::TypeOf(effect).Apply(effect, values, &m);
  return std::move(m.description);
}

AugmentedModel ApplyEffects(const LimbDescription& nominal,
                            const std::vector<AppliedEffect>& effects) {
  AugmentedModel out;
  out.description = nominal;
  for (const AppliedEffect& a : effects) {
    CheckValues(a.effect, a.values);
    ident::TypeOf(a.effect).Apply(a.effect, a.values, &out);
    out.effects.push_back(a);
  }
  return out;
}

AppliedEffect ParseEffectAssignment(const Model& model, const std::string& text) {
  size_t eq = text.find('=');
  if (eq == std::string::npos) {
    throw Error("effect '" + text +
                "': expected NAME=VALUE[,VALUE...] (user units, see docs/identification.md)");
  }
  std::string id = util::Trim(text.substr(0, eq));
  AppliedEffect out;
  out.effect = FindEffect(model, id);
  std::vector<std::string> pieces = util::Split(text.substr(eq + 1), ",");
  const bool named = text.find(':', eq) != std::string::npos;
  if (named) {
    // NAME=param:value,...: the parameters not named keep the value at which the effect
    // vanishes (crosstalk=mx_fy:0.02,fz_mx:-0.01).
    for (const EffectParameter& p : out.effect.parameters) out.values.push_back(p.neutral);
    for (const std::string& piece : pieces) {
      const size_t colon = piece.find(':');
      const std::string name = util::Trim(piece.substr(0, colon));
      size_t k = 0;
      while (k < out.effect.parameters.size() && out.effect.parameters[k].name != name) ++k;
      if (colon == std::string::npos || k == out.effect.parameters.size()) {
        std::vector<std::string> names;
        for (const EffectParameter& p : out.effect.parameters) names.push_back(p.name);
        throw Error("effect '" + id + "': '" + util::Trim(piece) +
                    "' is not PARAMETER:VALUE with a parameter of the effect (" +
                    util::Join(names, ", ") + ")");
      }
      out.values[k] = util::ParseDoubleOrThrow(piece.substr(colon + 1), "effect '" + id + "'");
    }
  } else {
    for (const std::string& p : pieces) {
      out.values.push_back(util::ParseDoubleOrThrow(p, "effect '" + id + "'"));
    }
  }
  if (out.values.size() != out.effect.parameters.size()) {
    std::vector<std::string> names;
    for (const EffectParameter& p : out.effect.parameters)
      names.push_back(p.name + " (" + p.unit + ")");
    throw Error("effect '" + id + "' takes " + std::to_string(out.effect.parameters.size()) +
                " value(s): " + util::Join(names, ", ") + "; got " +
                std::to_string(out.values.size()) + " (or name some: " + id + "=" +
                out.effect.parameters[0].name + ":VALUE,..., the others at their neutral value)");
  }
  // Validate now so the error names the effect.
  ApplyEffects(model.description(), {out});
  return out;
}

}  // namespace isowrench
