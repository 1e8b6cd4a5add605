// Effect extra_joint:JOINT:AXIS: an extra revolute dof held by a passive stiffness.

#include <cmath>

#include "identification/effect_type.hpp"
#include "identification/identification_impl.hpp"
#include "isowrench/error.hpp"

namespace isowrench::ident {
namespace {

/// Joints whose origins are closer than this (m) belong to one group (a ball/universal joint).
constexpr double kColocated = 1e-9;
/// An axis is already covered by a group when |cos(angle)| with one of its axes exceeds this.
constexpr double kCoveredAxis = 0.9;
const char* kAxes[3] = {"x", "y", "z"};

/// Rotational stiffness of the transducer felt by a unit rotation about an extra joint at the
/// nominal posture: j^T S_t j (N·m/rad), the scale the extra joint's stiffness is compared to.
double ExtraJointScale(const Model& model, const std::string& joint, const Eigen::Vector3d& axis) {
  try {
    LimbDescription d = WithExtraJoint(model.description(), joint, "isowrench_probe", axis, 1.0);
    Model probe(d);
    Eigen::VectorXd j = NominalJacobianColumn(probe, "isowrench_probe");
    Vector6d s_t = probe.transducer().stiffness;
    for (int i = 0; i < 6; ++i) {
      if (probe.transducer().released[i]) s_t[i] = 0;
    }
    double k = j.dot(s_t.asDiagonal() * j);
    if (std::isfinite(k) && k > 0) return k;
  } catch (const Error&) {
  }
  return 1.0;
}

class ExtraJoint final : public EffectType {
 public:
  EffectKindInfo Info() const override {
    return {"extra_joint",
            "extra_joint:JOINT:AXIS (AXIS x, y or z in JOINT's child frame)",
            EffectStage::kModel,
            "Adds a revolute dof after JOINT about AXIS, held by a passive stiffness: a joint the "
            "URDF treats "
            "as rigid gives. Offered for each axis missing from each group of co-located revolute "
            "limb joints.",
            "k_joint (N·m/rad, log10, 1e-6 to 1e4 x j^T S_t j of that axis at the nominal posture)",
            "extra joints of neighbouring groups about parallel axes; invisible when it forms a "
            "self-motion "
            "with the other joints (flagged as not identifiable)"};
  }
  std::vector<Effect> Candidates(const Model& model,
                                 const std::vector<std::string>&) const override {
    std::vector<Effect> out;
    const LimbDescription& d = model.description();
    std::vector<const JointSpec*> movable;
    for (const JointSpec& j : d.joints) {
      if (j.type != JointType::kFixed) movable.push_back(&j);
    }
    for (size_t start = 0; start < movable.size();) {
      size_t stop = start + 1;
      while (stop < movable.size() && movable[stop]->origin.translation().norm() < kColocated &&
             movable[stop]->type == JointType::kRevolute) {
        ++stop;
      }
      if (movable[start]->type == JointType::kRevolute &&
          movable[start]->role == JointRole::kLimb) {
        // Axes of the group expressed in the child frame of its last joint at q = 0.
        std::vector<Eigen::Vector3d> axes;
        Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
        for (size_t k = stop; k-- > start;) {
          // A locked joint is rigid: its axis can still give (an extra joint about it).
          if (!FindCoordinate(d, movable[k]->coordinate).locked)
            axes.push_back(R * movable[k]->axis);
          if (k > start) R = R * movable[k]->origin.linear().transpose();
        }
        const JointSpec& last = *movable[stop - 1];
        for (int a = 0; a < 3; ++a) {
          Eigen::Vector3d axis = Eigen::Vector3d::Unit(a);
          bool covered = false;
          for (const Eigen::Vector3d& g : axes)
            covered |= std::abs(g.normalized().dot(axis)) > kCoveredAxis;
          if (covered) continue;
          Effect e;
          e.kind = "extra_joint";
          e.joint = last.name;
          e.axis = axis;
          e.id = "extra_joint:" + last.name + ":" + kAxes[a];
          e.description = std::string("an extra revolute dof about ") + kAxes[a] + " after joint " +
                          last.name + ", held by a passive stiffness";
          double scale = ExtraJointScale(model, last.name, axis);
          e.parameters.push_back(
              LogParameter("k_joint", "N·m/rad", 1e4 * scale, scale, 1e-6 * scale, 1e4 * scale));
          e.confounders = {"extra_joint:"};
          out.push_back(e);
        }
      }
      start = stop;
    }
    return out;
  }
  void Apply(const Effect& e, const std::vector<double>& v, AugmentedModel* m) const override {
    int a = 0;
    e.axis.cwiseAbs().maxCoeff(&a);
    std::string name = e.joint + "_extra_r" + kAxes[a];
    m->description = WithExtraJoint(std::move(m->description), e.joint, name, e.axis, v[0]);
  }
};

}  // namespace

std::unique_ptr<EffectType> MakeEffect_extra_joint() { return std::make_unique<ExtraJoint>(); }

}  // namespace isowrench::ident
