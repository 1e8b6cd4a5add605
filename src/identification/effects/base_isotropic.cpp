// Effect base_isotropic: imperfect skeletal fixation, one stiffness for the base translations.

#include "identification/effect_type.hpp"

namespace isowrench::ident {
namespace {

double MeanTranslational(const Model& model) {
  double k = model.transducer().stiffness.head<3>().mean();
  return k > 0 ? k : 1e7;
}

class BaseIsotropic final : public EffectType {
 public:
  EffectKindInfo Info() const override {
    return {"base_isotropic",
            "base_isotropic",
            EffectStage::kModel,
            "Adds three base translation joints (world x y z) held by one stiffness: the skeleton "
            "is not "
            "rigidly fixed. Offered when the model has no base joints.",
            "k_base (N/m, log10, 1e-4 to 1e4 x the mean transducer translation stiffness)",
            "base_per_axis (nested: the same with one stiffness per axis); transducer_soft on a "
            "translation dof"};
  }
  std::vector<Effect> Candidates(const Model& model,
                                 const std::vector<std::string>&) const override {
    for (const JointSpec& j : model.description().joints) {
      if (j.role == JointRole::kBase) return {};
    }
    const double k = MeanTranslational(model);
    Effect e;
    e.kind = "base_isotropic";
    e.id = "base_isotropic";
    e.description = "imperfect skeletal fixation: one stiffness for the base translations x y z";
    e.parameters.push_back(LogParameter("k_base", "N/m", 1e4 * k, k, 1e-4 * k, 1e4 * k));
    e.confounders = {"base_per_axis"};
    e.excludes = {"base_per_axis"};
    return {e};
  }
  void Apply(const Effect&, const std::vector<double>& v, AugmentedModel* m) const override {
    m->description = WithBaseStiffness(std::move(m->description), v[0]);
  }
};

}  // namespace

std::unique_ptr<EffectType> MakeEffect_base_isotropic() {
  return std::make_unique<BaseIsotropic>();
}

}  // namespace isowrench::ident
