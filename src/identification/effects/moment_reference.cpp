// Effect moment_reference: the endpoint (moment reference point) displaced in its link's frame.

#include "identification/effect_type.hpp"

namespace isowrench::ident {
namespace {

class MomentReference final : public EffectType {
 public:
  EffectKindInfo Info() const override {
    return {"moment_reference",
            "moment_reference",
            EffectStage::kModel,
            "Moves the endpoint (where the limb is attached, the moment reference point) by a "
            "vector in the "
            "endpoint link's frame: changes the statics (J) and the moment arm of the reading.",
            "dx, dy, dz (mm, linear, -20 to 20)",
            "sensor_origin (the same moment shift without the change in J, in transducer axes)"};
  }
  std::vector<Effect> Candidates(const Model&, const std::vector<std::string>&) const override {
    Effect e;
    e.kind = "moment_reference";
    e.id = "moment_reference";
    e.description = "moment reference point (endpoint) displaced, in the endpoint link's frame";
    for (const char* n : {"dx", "dy", "dz"}) e.parameters.push_back(LinearParameter(n, "mm", 20.0));
    e.confounders = {"sensor_origin"};
    return {e};
  }
  void Apply(const Effect&, const std::vector<double>& v, AugmentedModel* m) const override {
    m->description.transducer.endpoint += Eigen::Vector3d(v[0], v[1], v[2]) * kMillimetre;
  }
};

}  // namespace

std::unique_ptr<EffectType> MakeEffect_moment_reference() {
  return std::make_unique<MomentReference>();
}

}  // namespace isowrench::ident
