// Effect misalignment: the transducer axes are rotated by a small rotation.

#include <Eigen/Geometry>

#include "identification/effect_type.hpp"

namespace isowrench::ident {
namespace {

class Misalignment final : public EffectType {
 public:
  EffectKindInfo Info() const override {
    return {"misalignment",
            "misalignment",
            EffectStage::kModel,
            "Rotates the transducer axes by a small rotation vector (in transducer axes): the "
            "sensor is "
            "mounted turned. Changes the readings' axes and, for an anisotropic S_t, the statics.",
            "rx, ry, rz (deg, linear, -20 to 20)",
            "crosstalk contains it to first order (E_ff = E_mm = -[r]x, the same skew part of "
            "the force and moment blocks of the calibration error): crosstalk added after it "
            "replaces it"};
  }
  std::vector<Effect> Candidates(const Model&, const std::vector<std::string>&) const override {
    Effect e;
    e.kind = "misalignment";
    e.id = "misalignment";
    e.description =
        "transducer axes rotated by a small rotation (rotation vector in transducer axes)";
    for (const char* n : {"rx", "ry", "rz"})
      e.parameters.push_back(LinearParameter(n, "deg", 20.0));
    e.confounders = {"crosstalk"};
    return {e};
  }
  void Apply(const Effect&, const std::vector<double>& v, AugmentedModel* m) const override {
    Eigen::Vector3d r(v[0], v[1], v[2]);
    r *= kDegree;
    if (r.norm() > 0) {
      m->description.transducer.rotation =
          m->description.transducer.rotation *
          Eigen::AngleAxisd(r.norm(), r.normalized()).toRotationMatrix();
    }
  }
};

}  // namespace

std::unique_ptr<EffectType> MakeEffect_misalignment() { return std::make_unique<Misalignment>(); }

}  // namespace isowrench::ident
