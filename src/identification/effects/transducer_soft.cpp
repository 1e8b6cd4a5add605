// Effect transducer_soft:DOF: one transducer dof partially released.

#include "identification/effect_type.hpp"

namespace isowrench::ident {
namespace {

class TransducerSoft final : public EffectType {
 public:
  EffectKindInfo Info() const override {
    return {"transducer_soft",
            "transducer_soft:DOF (DOF one of x y z rx ry rz, restrained)",
            EffectStage::kModel,
            "Sets one restrained transducer dof's stiffness to a fitted value (a partly released "
            "attachment: a loose clamp, a compliant adapter).",
            "k_DOF (N/m or N·m/rad, log10, 1e-6 to 1e2 x the stated stiffness)",
            "transducer_anisotropy (rotational dofs); base compliance (translations)"};
  }
  std::vector<Effect> Candidates(const Model& model,
                                 const std::vector<std::string>&) const override {
    std::vector<Effect> out;
    const TransducerSpec& t = model.description().transducer;
    for (int dof = 0; dof < 6; ++dof) {
      if (t.released[dof] || !(t.stiffness[dof] > 0)) continue;
      Effect e;
      e.kind = "transducer_soft";
      e.dof = dof;
      e.id = std::string("transducer_soft:") + DofName(dof);
      e.description =
          std::string("transducer dof ") + DofName(dof) + " partially released (low stiffness)";
      double k = t.stiffness[dof];
      e.parameters.push_back(LogParameter(std::string("k_") + DofName(dof),
                                          dof < 3 ? "N/m" : "N·m/rad", k, 0.1 * k, 1e-6 * k,
                                          1e2 * k));
      e.confounders = {"transducer_anisotropy"};
      out.push_back(e);
    }
    return out;
  }
  void Apply(const Effect& e, const std::vector<double>& v, AugmentedModel* m) const override {
    Vector6d s = m->description.transducer.stiffness;
    s[e.dof] = v[0];
    m->description = WithTransducerStiffness(std::move(m->description), s);
  }
};

}  // namespace

std::unique_ptr<EffectType> MakeEffect_transducer_soft() {
  return std::make_unique<TransducerSoft>();
}

}  // namespace isowrench::ident
