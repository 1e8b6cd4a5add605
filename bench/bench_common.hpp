#pragma once
// Shared setup of the benchmarks and the callgrind driver: kernel K is one evaluation of the
// GP muscle on rat_hindlimb_5dof_base.urdf (3 prismatic base dofs + hip ball + knee universal).

#include <random>
#include <string>
#include <vector>

#include "isowrench/isowrench.hpp"

namespace isowrench_bench {

inline std::string KernelUrdf() {
  return std::string(ISOWRENCH_BENCH_URDF_DIR) + "/rat_hindlimb_5dof_base.urdf";
}

/// Kernel K with a coupled knee: a prismatic tibial translation along x inserted after knee_rz
/// and driven by it through a 7-knot SimmSpline (millimetres over the knee's range), so the
/// model keeps kernel K's 8 columns on 9 joints.
inline isowrench::Model CoupledKernelModel() {
  isowrench::LimbDescription d = isowrench::WithExtraJoint(
      isowrench::ReadUrdfFile(KernelUrdf()), "knee_rz", "knee_tx", Eigen::Vector3d::UnitX(), 0.0);
  for (isowrench::JointSpec& j : d.joints) {
    if (j.name != "knee_tx") continue;
    j.type = isowrench::JointType::kPrismatic;
    j.role = isowrench::JointRole::kLimb;
    j.coordinate = "knee_rz";
    j.coupling =
        isowrench::Function::SimmSpline({-0.5, 0.25, 1.0, 1.5, 2.0, 2.5, 3.0},
                                        {0.0004, 0.0002, 0.0, -0.0003, -0.0007, -0.0012, -0.0018});
  }
  return isowrench::Model(d);
}

/// `count` postures around the nominal one: hip and knee angles within +-60 degrees, base
/// translations within +-1 mm, from a fixed seed (the same postures in every run).
inline Eigen::MatrixXd KernelPostures(const isowrench::Model& model, int count) {
  std::mt19937 rng(2026);
  std::uniform_real_distribution<double> angle(-1.0, 1.0);
  Eigen::MatrixXd postures(model.dof_count(), count);
  const Eigen::VectorXd nominal = model.nominal_posture();
  for (int p = 0; p < count; ++p) {
    for (int i = 0; i < model.dof_count(); ++i) {
      const bool prismatic = model.joint(i).type == isowrench::JointType::kPrismatic;
      postures(i, p) = nominal[i] + (prismatic ? 1e-3 : 1.047) * angle(rng);
    }
  }
  return postures;
}

/// 20 transducer stiffness sets: rotational stiffness = ratio x the model's, ratios
/// logarithmically spaced from 1 to 1e-4 (the paper's Fig. 2 rows B-D span this range).
inline std::vector<isowrench::StiffnessSet> KernelStiffnessSets(const isowrench::Model& model,
                                                                int count = 20) {
  std::vector<isowrench::StiffnessSet> sets;
  for (int k = 0; k < count; ++k) {
    isowrench::StiffnessSet s = model.model_stiffness();
    s.s_t.tail<3>() *= std::pow(10.0, -4.0 * k / (count - 1));
    sets.push_back(s);
  }
  return sets;
}

}  // namespace isowrench_bench
