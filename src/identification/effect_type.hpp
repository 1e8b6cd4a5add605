#pragma once
// The effect registry: one effect kind = one file in src/identification/effects/<kind>.cpp that
// defines `std::unique_ptr<EffectType> MakeEffect_<kind>()`. CMake generates the list of kinds
// from the files found there (effect_list.inc), so adding a kind touches no other file.

#include <memory>
#include <string>
#include <vector>

#include "isowrench/identification.hpp"

namespace isowrench::ident {

/// One kind of effect: which candidates it offers for a model and how it changes the
/// augmented model (description, posture offsets, force corrections or measurement chain).
class EffectType {
 public:
  virtual ~EffectType() = default;
  /// Kind name, id pattern, stage, parameters and confounders (for listings and the docs).
  virtual EffectKindInfo Info() const = 0;
  /// The candidates of this kind for `model`; `muscles` restricts muscle-specific ones (empty =
  /// all muscles).
  virtual std::vector<Effect> Candidates(const Model& model,
                                         const std::vector<std::string>& muscles) const = 0;
  /// Apply `effect` at `values` (user units, already checked: right count, finite, > 0 for
  /// log10 parameters). @throws Error for names the model does not have.
  virtual void Apply(const Effect& effect, const std::vector<double>& values,
                     AugmentedModel* model) const = 0;
  /// The candidate restricted to the parameters the data can determine, before the rounds
  /// (default: unchanged). `wrench` is each trial's wrench predicted by the nominal model
  /// (transducer axes, N and N·m); weights from the trials' sd as in the fit. Returns one
  /// sentence saying what was left out and why, or "" when nothing was. An effect left without
  /// parameters is dropped from the library.
  virtual std::string RestrictToData(const Model& model, const std::vector<Trial>& trials,
                                     const std::vector<Vector6d>& wrench, const FitOptions& options,
                                     Effect* effect) const {
    (void)model, (void)trials, (void)wrench, (void)options, (void)effect;
    return "";
  }
  /// Why `id` (an id of this kind's pattern) is not a candidate of `model`, or "" when the
  /// kind has nothing to say (FindEffect then lists the known ids). Default "".
  virtual std::string WhyNotCandidate(const Model& model, const std::string& id) const {
    (void)model, (void)id;
    return "";
  }
};

/// Every registered kind, sorted by kind name.
const std::vector<const EffectType*>& EffectTypes();
/// The kind of an effect. @throws Error for an unknown kind.
const EffectType& TypeOf(const Effect& effect);

/// Parameter helpers for the effect files.
EffectParameter LogParameter(const std::string& name, const std::string& unit, double neutral,
                             double initial, double lower, double upper);
EffectParameter LinearParameter(const std::string& name, const std::string& unit, double range);
/// "fx" ... "mz" for 0..5.
const char* AxisName(int axis);
/// 0..5 for "fx" ... "mz", -1 for anything else.
int AxisIndex(const std::string& name);
/// A model's limb columns may carry a muscle subset; true when `muscle` is wanted.
bool Wanted(const std::vector<std::string>& muscles, const std::string& muscle);

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegree = kPi / 180.0;
constexpr double kMillimetre = 1e-3;

}  // namespace isowrench::ident
