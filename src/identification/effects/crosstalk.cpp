// Effect crosstalk: the off-diagonal terms of the transducer's calibration matrix.

#include "identification/effect_type.hpp"

namespace isowrench::ident {
namespace {

/// Length that makes moments comparable with forces (m): the sum of the joint offsets and the
/// endpoint offset of the description (the limb's reach).
double ReachLength(const LimbDescription& d) {
  double length = d.transducer.endpoint.norm();
  for (const JointSpec& j : d.joints) length += j.origin.translation().norm();
  return length > 0 ? length : 1.0;
}

class Crosstalk final : public EffectType {
 public:
  EffectKindInfo Info() const override {
    return {
        "crosstalk",
        "crosstalk",
        EffectStage::kMeasurement,
        "Off-diagonal calibration terms: reading = D (I + E) D^-1 W with D = diag(1, 1, 1, L, L, "
        "L) "
        "(L = the limb's reach, so moments and forces are comparable) and E symmetric with a zero "
        "diagonal. Only the symmetric part is a parameter because the rest is another effect: the "
        "diagonal is gain:, the skew part of the force and moment blocks is a small rotation "
        "(misalignment), and the skew part of the moment-from-force block is a moment origin shift "
        "(sensor_origin). Fitting those twice would make the parameters unidentifiable.",
        "15 terms named AXIS1_AXIS2 (x, linear, -0.2 to 0.2) in the normalised units",
        "gain:, misalignment, sensor_origin (parametrised away, see above)"};
  }
  std::vector<Effect> Candidates(const Model&, const std::vector<std::string>&) const override {
    Effect e;
    e.kind = "crosstalk";
    e.id = "crosstalk";
    e.stage = EffectStage::kMeasurement;
    e.post_processing = true;
    e.description =
        "the transducer's calibration matrix has off-diagonal (crosstalk) terms, symmetric part";
    for (int i = 0; i < 6; ++i) {
      for (int j = i + 1; j < 6; ++j) {
        e.parameters.push_back(
            LinearParameter(std::string(AxisName(i)) + "_" + AxisName(j), "x", 0.2));
      }
    }
    e.confounders = {"gain:", "misalignment", "sensor_origin"};
    return {e};
  }
  void Apply(const Effect&, const std::vector<double>& v, AugmentedModel* m) const override {
    const double length = ReachLength(m->description);
    Matrix6d c = Matrix6d::Identity();
    int k = 0;
    for (int i = 0; i < 6; ++i) {
      for (int j = i + 1; j < 6; ++j, ++k) {
        const double di = i < 3 ? 1.0 : length, dj = j < 3 ? 1.0 : length;
        c(i, j) = di * v[k] / dj;
        c(j, i) = dj * v[k] / di;
      }
    }
    m->calibration = c * m->calibration;
  }
};

}  // namespace

std::unique_ptr<EffectType> MakeEffect_crosstalk() { return std::make_unique<Crosstalk>(); }

}  // namespace isowrench::ident
