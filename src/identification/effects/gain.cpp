// Effect gain:AXIS: the transducer reads one axis times a factor.

#include "identification/effect_type.hpp"

namespace isowrench::ident {
namespace {

class Gain final : public EffectType {
 public:
  EffectKindInfo Info() const override {
    return {"gain",
            "gain:AXIS (AXIS one of fx fy fz mx my mz)",
            EffectStage::kMeasurement,
            "The transducer reads AXIS times a factor: the diagonal of its 6 x 6 calibration "
            "matrix is off.",
            "factor (x, log10, 0.1 to 10)",
            "force_scale and trial_force (a common gain on all axes is a force factor); crosstalk"};
  }
  std::vector<Effect> Candidates(const Model&, const std::vector<std::string>&) const override {
    std::vector<Effect> out;
    for (int axis = 0; axis < 6; ++axis) {
      Effect e;
      e.kind = "gain";
      e.id = std::string("gain:") + AxisName(axis);
      e.dof = axis;
      e.stage = EffectStage::kMeasurement;
      e.post_processing = true;
      e.description = std::string("the transducer reads ") + AxisName(axis) +
                      " times a factor (calibration gain)";
      e.parameters.push_back(LogParameter("factor", "x", 1.0, 1.0, 0.1, 10.0));
      e.confounders = {"force_scale:", "trial_force"};
      out.push_back(e);
    }
    return out;
  }
  void Apply(const Effect& e, const std::vector<double>& v, AugmentedModel* m) const override {
    m->calibration.row(e.dof) *= v[0];
  }
};

}  // namespace

std::unique_ptr<EffectType> MakeEffect_gain() { return std::make_unique<Gain>(); }

}  // namespace isowrench::ident
