#pragma once
/// @file
/// Synthetic chains of any size for the engine's tests (large_chain_test.cpp,
/// fast_alloc_test.cpp): `coordinates` independent coordinates, each carried by a revolute
/// joint with the identity and, when `coupled`, driving a second joint (a revolute mimic, a
/// prismatic SimmSpline, or a prismatic joint of the previous coordinate's through a natural
/// cubic spline), over tilted fixed offsets and every axis kind, with fixed joints in between,
/// a transducer turning with the last link, and two muscles: one over every link (and the
/// ground), one short.

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "isowrench/isowrench.hpp"

namespace large_chain {

struct Options {
  int coordinates = 32;
  bool coupled = true;
  /// Extra points of the long muscle, on the last link (to pass a muscle-size boundary).
  int extra_points = 0;
  /// Put a joint driven by a SimmSpline whose knot values are all 0 after every 8th
  /// coordinate's joint (ConstantCoupling folds it).
  bool constant_joints = false;
};

inline Eigen::Isometry3d Pose(double x, double y, double z, double roll, double pitch, double yaw) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translation() = Eigen::Vector3d(x, y, z);
  t.linear() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  return t;
}

/// The description (see the file comment); every coordinate has S_p so that K is regular.
inline isowrench::LimbDescription Description(const Options& o) {
  using isowrench::JointSpec;
  using isowrench::JointType;
  isowrench::LimbDescription d;
  d.name = "chain_" + std::to_string(o.coordinates) + (o.coupled ? "_coupled" : "");
  d.root_link = "ground";
  d.links = {"ground"};
  std::string parent = "ground";
  int link = 0;
  auto add = [&](const std::string& name, JointType type, const Eigen::Isometry3d& origin,
                 const Eigen::Vector3d& axis) -> JointSpec& {
    JointSpec j;
    j.name = name;
    j.type = type;
    j.parent_link = parent;
    j.child_link = "l" + std::to_string(link++);
    j.origin = origin;
    j.axis = axis.normalized();
    d.joints.push_back(j);
    d.links.push_back(j.child_link);
    parent = j.child_link;
    return d.joints.back();
  };
  const Eigen::Vector3d axes[7] = {Eigen::Vector3d::UnitZ(),  -Eigen::Vector3d::UnitX(),
                                   Eigen::Vector3d::UnitY(),  Eigen::Vector3d(1, 2, -0.5),
                                   -Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitX(),
                                   -Eigen::Vector3d::UnitY()};
  for (int c = 0; c < o.coordinates; ++c) {
    const double t = 0.1 * c;
    if (c % 5 == 2) {
      add("fix" + std::to_string(c), JointType::kFixed, Pose(0.004, 0.002, 0, 0.2, 0, -0.1),
          Eigen::Vector3d::UnitZ());
    }
    // Short links (a few mm) so that the chain's reach stays near 0.1 m at any length.
    JointSpec& own =
        add("q" + std::to_string(c), JointType::kRevolute,
            Pose(0.006, 0.001 * (c % 3), -0.0005 * (c % 2), 0.1 + t, -0.2, 0.3 - t), axes[c % 7]);
    own.stiffness = 0.5 + 0.1 * (c % 4);
    if (o.constant_joints && c % 8 == 7) {
      JointSpec& flat = add("flat" + std::to_string(c), JointType::kPrismatic,
                            Pose(0, 0.002, 0, 0, 0.1, 0), Eigen::Vector3d(0.3, -1, 0.2));
      flat.coordinate = "q" + std::to_string(c);
      flat.coupling = isowrench::Function::SimmSpline({-3, -1, 0, 1, 3}, {0, 0, 0, 0, 0});
    }
    if (!o.coupled) continue;
    const std::string driver = "q" + std::to_string(c);
    switch (c % 3) {
      case 0: {  // a revolute mimic about a general axis
        JointSpec& j = add("mimic" + std::to_string(c), JointType::kRevolute,
                           Pose(0.002, 0, 0.001, 0, 0.3, 0.1), Eigen::Vector3d(0.2, 1, 0.4));
        j.coordinate = driver;
        j.coupling = isowrench::Function::Linear(0.5, 0.1);
        break;
      }
      case 1: {  // a prismatic translation along x through a SimmSpline (mm over +-3 rad)
        JointSpec& j = add("slide" + std::to_string(c), JointType::kPrismatic,
                           Pose(0, 0, 0, 0, 0, 0.2), Eigen::Vector3d::UnitX());
        j.coordinate = driver;
        j.coupling = isowrench::Function::SimmSpline({-3, -1.5, -0.2, 0.4, 1.1, 3},
                                                     {0.001, 0.0004, 0, -0.0003, -0.0009, -0.002});
        break;
      }
      default: {  // a prismatic joint of the previous coordinate (a driven joint away from it)
        JointSpec& j = add("cross" + std::to_string(c), JointType::kPrismatic,
                           Pose(0.001, 0, 0, 0.4, 0, 0), Eigen::Vector3d(1, -1, 2));
        j.coordinate = "q" + std::to_string(c - 1);
        j.coupling =
            isowrench::Function::NaturalCubicSpline({-4, 0, 2, 4}, {-0.002, 0.0, 0.001, 0.0015});
        break;
      }
    }
  }
  add("tip_offset", JointType::kFixed, Pose(0.01, 0.003, -0.002, -0.3, 0.2, 0.1),
      Eigen::Vector3d::UnitZ());
  d.transducer.link = parent;
  d.transducer.endpoint = Eigen::Vector3d(0.005, 0.001, -0.002);
  d.transducer.axes_in_world = false;
  d.transducer.rotation = Pose(0, 0, 0, 0.7, -0.3, 1.1).linear();
  d.transducer.stiffness << 2e5, 3e5, 1e5, 4, 7, 2;
  // The long muscle: a point on every fourth link and on the ground, alternating sides.
  isowrench::MuscleSpec along;
  along.name = "along";
  along.max_force = 5.0;
  along.path.push_back({"ground", Eigen::Vector3d(-0.01, 0.02, 0.0)});
  for (size_t l = 1; l < d.links.size(); l += 4) {
    const double side = (l / 4) % 2 == 0 ? 1.0 : -1.0;
    along.path.push_back({d.links[l], Eigen::Vector3d(0.001, 0.004 * side, 0.002)});
  }
  for (int e = 0; e < o.extra_points; ++e) {
    const double side = e % 2 == 0 ? 1.0 : -1.0;
    along.path.push_back({parent, Eigen::Vector3d(0.001 * (e + 1), 0.003 * side, 0.001)});
  }
  d.muscles.push_back(along);
  isowrench::MuscleSpec shortm;
  shortm.name = "short";
  shortm.max_force = 2.0;
  shortm.path = {{d.links[d.links.size() / 2], Eigen::Vector3d(0.002, -0.003, 0.001)},
                 {parent, Eigen::Vector3d(-0.002, 0.004, 0.0)}};
  d.muscles.push_back(shortm);
  return d;
}

inline isowrench::Model Model(const Options& o) { return isowrench::Model(Description(o)); }

}  // namespace large_chain
