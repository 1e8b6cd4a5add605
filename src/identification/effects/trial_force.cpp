// Effect trial_force: every trial's muscle force has its own factor s_m exp(z_t) around its
// muscle's level s_m.

#include "identification/effect_type.hpp"

namespace isowrench::ident {
namespace {

constexpr const char* kTrialForceSummary =
    R"(Each trial's muscle wrench has its own factor g_t = s_m exp(z_t): a level s_m per muscle (what force_scale fits) and a variation z_t ~ N(0, spread^2) from trial to trial (stimulus variation, fatigue). The factor scales the stimulated part W(a) - W(0) of the trial's wrench (coactivated muscles' wrenches included); its part at activation 0, W(0) (the passive force and the model's minimum activation; zero for a constant-force muscle), is there before the stimulus and stays. W is linear in the force, so each trial's factor is solved in closed form (weighted least squares against its measured wrench, after the other effects); the levels and the spread are the maximum of the marginal likelihood of those factors (the z_t integrated out), and the criteria charge 1 + (number of muscles) parameters. The spread is claimed only when it is significant against the levels alone (nested likelihood-ratio test, evidence threshold min_bic_improvement + ln n) and only when the factors do not follow the posture (a smooth trend in a muscle's length or a coordinate is a systematic effect, reported as not claimed). The report gives each level ("force_scale:GP = 0.90 ± ..."), the spread and trials far from their level.)";

class TrialForce final : public EffectType {
 public:
  EffectKindInfo Info() const override {
    return {"trial_force",
            "trial_force",
            EffectStage::kForce,
            kTrialForceSummary,
            "spread (sd of ln factor around the level; simulate draws it, the fit estimates it), "
            "plus one force level per muscle (derived, counted by the criteria: k = 1 + muscles)",
            "force_scale (its levels are force_scale's: it contains them and replaces them when "
            "added after them); gain on all axes"};
  }
  std::vector<Effect> Candidates(const Model& model,
                                 const std::vector<std::string>&) const override {
    Effect e;
    e.kind = "trial_force";
    e.id = "trial_force";
    e.stage = EffectStage::kForce;
    e.description =
        "the muscle force varies from trial to trial around each muscle's level (one factor per "
        "trial)";
    e.post_processing = true;
    e.per_trial = true;
    EffectParameter p = LinearParameter("spread", "ln", 1.0);
    p.lower = 0.0;
    e.parameters.push_back(p);
    for (const MuscleSpec& m : model.description().muscles)
      e.contains.push_back("force_scale:" + m.name);
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
