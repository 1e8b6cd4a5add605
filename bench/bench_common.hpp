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

/// A chain of `coordinates` revolute joints (3 mm to 6 mm apart, axes cycling through x, y, z
/// and a general one, tilted fixed offsets), each driving, when `coupled`, a second joint: a
/// prismatic translation through a 6-knot SimmSpline of it (as an OpenSim knee's). S_p on every
/// coordinate, a transducer turning with the last link, one muscle with a point on every second
/// link: the size of real OpenSim limbs (a coupled knee or ankle spends up to six joints per
/// coordinate) for the instruction counts of chains past 16 joints.
inline isowrench::Model ChainModel(int coordinates, bool coupled) {
  isowrench::LimbDescription d;
  d.name = "chain_" + std::to_string(coordinates) + (coupled ? "_coupled" : "");
  d.root_link = "ground";
  d.links = {"ground"};
  std::string parent = "ground";
  auto add = [&](const std::string& name, isowrench::JointType type, const Eigen::Vector3d& xyz,
                 const Eigen::Vector3d& rpy, const Eigen::Vector3d& axis) -> isowrench::JointSpec& {
    isowrench::JointSpec j;
    j.name = name;
    j.type = type;
    j.parent_link = parent;
    j.child_link = name + "_link";
    j.origin.translation() = xyz;
    j.origin.linear() = (Eigen::AngleAxisd(rpy.z(), Eigen::Vector3d::UnitZ()) *
                         Eigen::AngleAxisd(rpy.y(), Eigen::Vector3d::UnitY()) *
                         Eigen::AngleAxisd(rpy.x(), Eigen::Vector3d::UnitX()))
                            .toRotationMatrix();
    j.axis = axis.normalized();
    d.joints.push_back(j);
    d.links.push_back(j.child_link);
    parent = j.child_link;
    return d.joints.back();
  };
  const Eigen::Vector3d axes[4] = {Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitX(),
                                   Eigen::Vector3d::UnitY(), Eigen::Vector3d(1, 2, -0.5)};
  for (int c = 0; c < coordinates; ++c) {
    isowrench::JointSpec& own = add("q" + std::to_string(c), isowrench::JointType::kRevolute,
                                    Eigen::Vector3d(0.003 + 0.001 * (c % 4), 0.001, 0),
                                    Eigen::Vector3d(0.1, -0.2, 0.3), axes[c % 4]);
    own.stiffness = 0.5;
    if (!coupled) continue;
    isowrench::JointSpec& slide =
        add("slide" + std::to_string(c), isowrench::JointType::kPrismatic, Eigen::Vector3d::Zero(),
            Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX());
    slide.coordinate = "q" + std::to_string(c);
    slide.coupling = isowrench::Function::SimmSpline({-3, -1.5, -0.2, 0.4, 1.1, 3},
                                                     {0.001, 0.0004, 0, -0.0003, -0.0009, -0.002});
  }
  d.transducer.link = parent;
  d.transducer.endpoint = Eigen::Vector3d(0.005, 0.001, -0.002);
  d.transducer.axes_in_world = false;
  d.transducer.rotation =
      Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 1, 0).normalized()).toRotationMatrix();
  isowrench::MuscleSpec muscle;
  muscle.name = "along";
  muscle.max_force = 5.0;
  muscle.path.push_back({"ground", Eigen::Vector3d(-0.01, 0.02, 0.0)});
  for (size_t l = 1; l < d.links.size(); l += 2) {
    muscle.path.push_back(
        {d.links[l], Eigen::Vector3d(0.001, (l / 2) % 2 ? 0.004 : -0.004, 0.002)});
  }
  d.muscles.push_back(muscle);
  return isowrench::Model(d);
}

/// Kernel K with GP wrapping over a cylinder on the femur at the knee (axis z, the knee flexion
/// axis, radius 4 mm, 20 mm long, constrained to -y: it wraps GP at every posture of
/// KernelPostures): the cost of one active cylinder against the same muscle without it
/// (docs/performance.md "Wrapping muscles"). `mode`: the wrap mode.
inline isowrench::Model WrappedKernelModel(isowrench::WrapMode mode) {
  isowrench::LimbDescription d = isowrench::ReadUrdfFile(KernelUrdf());
  isowrench::WrapObjectSpec cylinder;
  cylinder.name = "knee_cyl";
  cylinder.link = "femur";
  cylinder.shape = isowrench::WrapShape::kCylinder;
  cylinder.translation = Eigen::Vector3d(0.031, 0, 0);
  cylinder.radius = 0.004;
  cylinder.length = 0.02;
  cylinder.quadrant = isowrench::WrapQuadrant::Parse("-y");
  d.wrap_objects.push_back(cylinder);
  isowrench::PathWrapSpec wrap;
  wrap.object = "knee_cyl";
  d.muscles[0].wraps.push_back(wrap);
  d.wrap_mode = mode;
  return isowrench::Model(d);
}

/// `count` postures around the nominal one: hip and knee angles within +-60 degrees, base
/// translations within +-1 mm, from a fixed seed (the same postures in every run).
/// Kernel K with GP under a Millard2012 force model (docs/muscle.md "In the engine"), rigid or
/// compliant tendon: l_o 18 mm, l_Ts 4 mm, 3 degrees of pennation (GP's path is 26 mm at the
/// nominal posture), OpenSim's default curves. The force-stage counts compare with "fast".
inline isowrench::Model ForceKernelModel(bool rigid) {
  isowrench::LimbDescription d = isowrench::ReadUrdfFile(KernelUrdf());
  isowrench::MuscleForceSpec& f = d.muscles[0].force;
  f.model = isowrench::ForceModelType::kMillard2012;
  f.optimal_fiber_length = 0.018;
  f.tendon_slack_length = 0.004;
  f.pennation_angle_at_optimal = 0.0524;
  f.ignore_tendon_compliance = rigid;
  return isowrench::Model(d);
}

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
