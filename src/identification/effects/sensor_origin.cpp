// Effect sensor_origin: the transducer's moment origin is offset, in the transducer's axes.

#include "identification/effect_type.hpp"

namespace isowrench::ident {
namespace {

class SensorOrigin final : public EffectType {
 public:
  EffectKindInfo Info() const override {
    return {"sensor_origin",
            "sensor_origin",
            EffectStage::kMeasurement,
            "The transducer resolves moments about a point offset by d (transducer axes) from the "
            "nominal "
            "one: it reads m - d x f. Unlike moment_reference the limb's attachment (and J) is "
            "unchanged.",
            "dx, dy, dz (mm, linear, -20 to 20, transducer axes)",
            "moment_reference (same moment shift, world/link axes, plus a change of J); "
            "crosstalk contains it exactly (E_mf = -[d]x, the skew part of the moment-from-force "
            "block of the calibration error): crosstalk added after it replaces it"};
  }
  std::vector<Effect> Candidates(const Model&, const std::vector<std::string>&) const override {
    Effect e;
    e.kind = "sensor_origin";
    e.id = "sensor_origin";
    e.stage = EffectStage::kMeasurement;
    e.post_processing = true;
    e.description = "the transducer's moment origin is offset (transducer axes)";
    for (const char* n : {"dx", "dy", "dz"}) e.parameters.push_back(LinearParameter(n, "mm", 20.0));
    e.confounders = {"moment_reference", "crosstalk"};
    return {e};
  }
  void Apply(const Effect&, const std::vector<double>& v, AugmentedModel* m) const override {
    m->sensor_origin += Eigen::Vector3d(v[0], v[1], v[2]) * kMillimetre;
  }
};

}  // namespace

std::unique_ptr<EffectType> MakeEffect_sensor_origin() { return std::make_unique<SensorOrigin>(); }

}  // namespace isowrench::ident
