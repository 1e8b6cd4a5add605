// Effect force_scale:MUSCLE: a muscle's max force is off by a factor.

#include "identification/effect_type.hpp"
#include "isowrench/error.hpp"

namespace isowrench::ident {
namespace {

class ForceScale final : public EffectType {
 public:
  EffectKindInfo Info() const override {
    return {"force_scale",
            "force_scale:MUSCLE",
            EffectStage::kForce,
            "Scales MUSCLE's max_force by a factor (the whole wrench of its trials scales: W is "
            "linear in "
            "the force). Written into the augmented URDF's max_force.",
            "scale (x, log10, 0.01 to 100)",
            "trial_force (contains it: its per-muscle levels are force scales); gain on every "
            "axis at once"};
  }
  std::vector<Effect> Candidates(const Model& model,
                                 const std::vector<std::string>& muscles) const override {
    std::vector<Effect> out;
    for (const MuscleSpec& m : model.description().muscles) {
      if (!Wanted(muscles, m.name)) continue;
      Effect e;
      e.kind = "force_scale";
      e.id = "force_scale:" + m.name;
      e.muscle = m.name;
      e.stage = EffectStage::kForce;
      e.description = "muscle " + m.name + " force differs from max_force by a factor";
      e.post_processing = true;
      e.parameters.push_back(LogParameter("scale", "x", 1.0, 1.0, 1e-2, 1e2));
      e.confounders = {"trial_force", "gain:"};
      out.push_back(e);
    }
    return out;
  }
  void Apply(const Effect& e, const std::vector<double>& v, AugmentedModel* m) const override {
    for (MuscleSpec& muscle : m->description.muscles) {
      if (muscle.name == e.muscle) {
        muscle.max_force *= v[0];
        return;
      }
    }
    throw Error("effect '" + e.id + "': unknown muscle '" + e.muscle + "'");
  }
};

}  // namespace

std::unique_ptr<EffectType> MakeEffect_force_scale() { return std::make_unique<ForceScale>(); }

}  // namespace isowrench::ident
