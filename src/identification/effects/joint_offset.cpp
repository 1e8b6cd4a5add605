// Effect joint_offset:COORD: the recorded value of a coordinate is offset by a constant.

#include "identification/effect_type.hpp"

namespace isowrench::ident {
namespace {

class JointOffset final : public EffectType {
 public:
  EffectKindInfo Info() const override {
    return {"joint_offset",
            "joint_offset:COORD (a limb coordinate)",
            EffectStage::kPosture,
            "The true value of COORD is the recorded one plus a constant (goniometer zero, marker "
            "placement): every trial is predicted at the shifted posture.",
            "offset (deg for revolute, mm for prismatic coordinates, linear, -20 to 20)",
            "attachment of a muscle crossing COORD; offsets of coordinates with parallel axes"};
  }
  std::vector<Effect> Candidates(const Model& model,
                                 const std::vector<std::string>&) const override {
    std::vector<Effect> out;
    for (int i = 0; i < model.dof_count(); ++i) {
      const JointSpec& j = model.joint(i);
      if (j.role != JointRole::kLimb) continue;
      const std::string& name = model.joint_names()[i];
      Effect e;
      e.kind = "joint_offset";
      e.id = "joint_offset:" + name;
      e.joint = name;
      e.stage = EffectStage::kPosture;
      e.post_processing = true;
      e.description = "the recorded " + name + " is offset from the true value by a constant";
      e.parameters.push_back(
          LinearParameter("offset", j.type == JointType::kPrismatic ? "mm" : "deg", 20.0));
      e.confounders = {"attachment:", "joint_offset:"};
      out.push_back(e);
    }
    return out;
  }
  void Apply(const Effect& e, const std::vector<double>& v, AugmentedModel* m) const override {
    const double unit = e.parameters[0].unit == "mm" ? kMillimetre : kDegree;
    m->posture_offset[e.joint] += v[0] * unit;
  }
};

}  // namespace

std::unique_ptr<EffectType> MakeEffect_joint_offset() { return std::make_unique<JointOffset>(); }

}  // namespace isowrench::ident
