// Effect coactivation:MUSCLE: MUSCLE also pulls in the trials that stimulate another muscle.

#include "identification/effect_type.hpp"

namespace isowrench::ident {
namespace {

class Coactivation final : public EffectType {
 public:
  EffectKindInfo Info() const override {
    return {"coactivation",
            "coactivation:MUSCLE (models with two or more muscles)",
            EffectStage::kForce,
            "In every trial that stimulates another muscle, MUSCLE also pulls with a fraction of "
            "its max "
            "force (stimulus spread). The statics are linear, so its wrench adds to the stimulated "
            "one's.",
            "fraction (of max force, linear, -1 to 1; negative values only keep the estimate "
            "unbiased near 0)",
            "force_scale and attachment of the stimulated muscle when the two lines of action are "
            "close"};
  }
  std::vector<Effect> Candidates(const Model& model,
                                 const std::vector<std::string>& muscles) const override {
    std::vector<Effect> out;
    if (model.muscle_count() < 2) return out;
    for (const MuscleSpec& m : model.description().muscles) {
      if (!Wanted(muscles, m.name)) continue;
      Effect e;
      e.kind = "coactivation";
      e.id = "coactivation:" + m.name;
      e.muscle = m.name;
      e.stage = EffectStage::kForce;
      e.post_processing = true;
      e.description = "muscle " + m.name +
                      " also pulls (a fraction of its max force) when another muscle is stimulated";
      EffectParameter p = LinearParameter("fraction", "x", 1.0);
      e.parameters.push_back(p);
      e.confounders = {"force_scale:", "attachment:"};
      out.push_back(e);
    }
    return out;
  }
  void Apply(const Effect& e, const std::vector<double>& v, AugmentedModel* m) const override {
    m->coactivation[e.muscle] += v[0];
  }
};

}  // namespace

std::unique_ptr<EffectType> MakeEffect_coactivation() { return std::make_unique<Coactivation>(); }

}  // namespace isowrench::ident
