// Effect transducer_anisotropy: the transducer's rotational stiffness differs by a factor.

#include "identification/effect_type.hpp"

namespace isowrench::ident {
namespace {

class TransducerAnisotropy final : public EffectType {
 public:
  EffectKindInfo Info() const override {
    return {"transducer_anisotropy",
            "transducer_anisotropy",
            EffectStage::kModel,
            "Scales the transducer's three rotational stiffnesses by one factor (the "
            "translation/rotation "
            "stiffness ratio of S_t is off). Only over-constrained limbs see it.",
            "rotation_factor (x, log10, 1e-4 to 1e4)",
            "transducer_soft on a rotational dof; base compliance"};
  }
  std::vector<Effect> Candidates(const Model&, const std::vector<std::string>&) const override {
    Effect e;
    e.kind = "transducer_anisotropy";
    e.id = "transducer_anisotropy";
    e.description =
        "transducer rotational stiffness differs from the stated one by a factor "
        "(translation/rotation stiffness ratio)";
    e.parameters.push_back(LogParameter("rotation_factor", "x", 1.0, 1.0, 1e-4, 1e4));
    e.confounders = {"transducer_soft:"};
    return {e};
  }
  void Apply(const Effect&, const std::vector<double>& v, AugmentedModel* m) const override {
    Vector6d s = m->description.transducer.stiffness;
    s.tail<3>() *= v[0];
    m->description = WithTransducerStiffness(std::move(m->description), s);
  }
};

}  // namespace

std::unique_ptr<EffectType> MakeEffect_transducer_anisotropy() {
  return std::make_unique<TransducerAnisotropy>();
}

}  // namespace isowrench::ident
