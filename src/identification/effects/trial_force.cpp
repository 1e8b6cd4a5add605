// Effect trial_force: every trial's muscle force has its own factor exp(z_t) around 1.

#include "identification/effect_type.hpp"

namespace isowrench::ident {
namespace {

class TrialForce final : public EffectType {
 public:
  EffectKindInfo Info() const override {
    return {"trial_force",
            "trial_force",
            EffectStage::kForce,
            "Multiplies each trial's muscle wrench by its own factor exp(z_t) (fatigue, stimulus "
            "variation). "
            "W is linear in the force, so the factors are solved in closed form per trial "
            "(weighted least "
            "squares against the measured wrench, after the other effects); the fit counts one "
            "parameter per "
            "trial. The report gives the spread of ln(factor) and flags trials far from the rest.",
            "spread (sd of ln factor, used by simulate; the fit reports the spread of the solved "
            "factors)",
            "force_scale (contained in the per-trial factors); gain on all axes"};
  }
  std::vector<Effect> Candidates(const Model& model,
                                 const std::vector<std::string>&) const override {
    Effect e;
    e.kind = "trial_force";
    e.id = "trial_force";
    e.stage = EffectStage::kForce;
    e.description = "the muscle force varies from trial to trial (one factor per trial)";
    e.post_processing = true;
    e.per_trial = true;
    EffectParameter p = LinearParameter("spread", "ln", 1.0);
    p.lower = 0.0;
    e.parameters.push_back(p);
    for (const MuscleSpec& m : model.description().muscles)
      e.excludes.push_back("force_scale:" + m.name);
    e.confounders = {"force_scale:", "gain:"};
    return {e};
  }
  void Apply(const Effect&, const std::vector<double>& v, AugmentedModel* m) const override {
    m->trial_force = true;
    m->trial_force_spread = v[0];
  }
};

}  // namespace

std::unique_ptr<EffectType> MakeEffect_trial_force() { return std::make_unique<TrialForce>(); }

}  // namespace isowrench::ident
