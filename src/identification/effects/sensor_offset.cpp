// Effect sensor_offset: a constant wrench added to every reading.

#include "identification/effect_type.hpp"

namespace isowrench::ident {
namespace {

class SensorOffset final : public EffectType {
 public:
  EffectKindInfo Info() const override {
    return {"sensor_offset",
            "sensor_offset",
            EffectStage::kMeasurement,
            "Adds a constant wrench to every reading (zeroing error, drift). Written into the "
            "augmented "
            "URDF's comment: URDF cannot hold it.",
            "fx, fy, fz (N, linear, -10 to 10), mx, my, mz (N·m, linear, -1 to 1)",
            "none structurally; a slow drift shows in the trace against trial order instead"};
  }
  std::vector<Effect> Candidates(const Model&, const std::vector<std::string>&) const override {
    Effect e;
    e.kind = "sensor_offset";
    e.id = "sensor_offset";
    e.stage = EffectStage::kMeasurement;
    e.description = "constant offset wrench added to every reading (zeroing error, drift)";
    e.post_processing = true;
    for (const char* n : {"fx", "fy", "fz"}) e.parameters.push_back(LinearParameter(n, "N", 10.0));
    for (const char* n : {"mx", "my", "mz"}) e.parameters.push_back(LinearParameter(n, "N·m", 1.0));
    return {e};
  }
  void Apply(const Effect&, const std::vector<double>& v, AugmentedModel* m) const override {
    for (int c = 0; c < 6; ++c) m->sensor_offset[c] += v[c];
  }
};

}  // namespace

std::unique_ptr<EffectType> MakeEffect_sensor_offset() { return std::make_unique<SensorOffset>(); }

}  // namespace isowrench::ident
