// Effect base_per_axis: imperfect skeletal fixation, a stiffness per world axis.

#include "identification/effect_type.hpp"

namespace isowrench::ident {
namespace {

class BasePerAxis final : public EffectType {
 public:
  EffectKindInfo Info() const override {
    return {"base_per_axis",
            "base_per_axis",
            EffectStage::kModel,
            "Adds three base translation joints (world x y z), each held by its own stiffness. "
            "Replaced by "
            "base_isotropic after the rounds when the three agree (lower BIC).",
            "k_base_x, k_base_y, k_base_z (N/m, log10, same range as base_isotropic)",
            "base_isotropic (nested); transducer_soft on a translation dof"};
  }
  std::vector<Effect> Candidates(const Model& model,
                                 const std::vector<std::string>&) const override {
    for (const JointSpec& j : model.description().joints) {
      if (j.role == JointRole::kBase) return {};
    }
    double k = model.transducer().stiffness.head<3>().mean();
    if (!(k > 0)) k = 1e7;
    Effect e;
    e.kind = "base_per_axis";
    e.id = "base_per_axis";
    e.description =
        "imperfect skeletal fixation: a stiffness per world axis for the base translations";
    for (const char* axis : {"x", "y", "z"}) {
      e.parameters.push_back(
          LogParameter(std::string("k_base_") + axis, "N/m", 1e4 * k, k, 1e-4 * k, 1e4 * k));
    }
    e.confounders = {"base_isotropic"};
    e.excludes = {"base_isotropic"};
    return {e};
  }
  void Apply(const Effect&, const std::vector<double>& v, AugmentedModel* m) const override {
    LimbDescription d = WithBaseStiffness(std::move(m->description), v[0]);
    std::vector<std::pair<std::string, double>> stiffness;
    for (const JointSpec& j : d.joints) {
      if (j.role == JointRole::kBase && j.type == JointType::kPrismatic) {
        // base joints translate along world x, y, z (WithBaseStiffness)
        int k = 0;
        j.axis.cwiseAbs().maxCoeff(&k);
        stiffness.emplace_back(j.name, v[k]);
      }
    }
    for (const auto& s : stiffness) d = WithJointStiffness(std::move(d), s.first, s.second);
    m->description = std::move(d);
  }
};

}  // namespace

std::unique_ptr<EffectType> MakeEffect_base_per_axis() { return std::make_unique<BasePerAxis>(); }

}  // namespace isowrench::ident
