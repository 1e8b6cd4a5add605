// LimbDescription -> URDF text with isowrench tags (the inverse of urdf_reader.cpp).

#include <algorithm>
#include <cmath>
#include <sstream>

#include "isowrench/model.hpp"
#include "util/atomic_file.hpp"
#include "util/text.hpp"

namespace isowrench {
namespace {

// 17 significant digits round-trip a double exactly.
std::string N(double v) { return util::FormatNumber(v, 17); }

std::string Vec(const Eigen::Vector3d& v) { return N(v.x()) + " " + N(v.y()) + " " + N(v.z()); }

Eigen::Vector3d Rpy(const Eigen::Matrix3d& R) {
  // URDF rpy: R = Rz(yaw) Ry(pitch) Rx(roll).
  double pitch = std::asin(std::clamp(-R(2, 0), -1.0, 1.0));
  double roll, yaw;
  if (std::abs(std::cos(pitch)) > 1e-9) {
    roll = std::atan2(R(2, 1), R(2, 2));
    yaw = std::atan2(R(1, 0), R(0, 0));
  } else {  // gimbal lock: put everything in yaw
    roll = 0.0;
    yaw = std::atan2(-R(0, 1), R(1, 1));
  }
  return Eigen::Vector3d(roll, pitch, yaw);
}

}  // namespace

std::string WriteUrdfString(const LimbDescription& d) {
  std::ostringstream o;
  o << "<?xml version=\"1.0\"?>\n";
  o << "<!-- Written by isowrench";
  if (!d.source.empty()) o << " from " << d.source;
  o << ". Extension tags: docs/urdf-extensions.md -->\n";
  o << "<robot name=\"" << d.name << "\" xmlns:isowrench=\"urn:isowrench:urdf:1\">\n";
  for (const std::string& link : d.links) o << "  <link name=\"" << link << "\"/>\n";
  for (const JointSpec& j : d.joints) {
    const char* type = j.type == JointType::kRevolute    ? "continuous"
                       : j.type == JointType::kPrismatic ? "prismatic"
                                                         : "fixed";
    o << "  <joint name=\"" << j.name << "\" type=\"" << type << "\">\n";
    o << "    <parent link=\"" << j.parent_link << "\"/> <child link=\"" << j.child_link
      << "\"/>\n";
    o << "    <origin xyz=\"" << Vec(j.origin.translation()) << "\" rpy=\""
      << Vec(Rpy(j.origin.linear())) << "\"/>\n";
    if (j.type != JointType::kFixed) o << "    <axis xyz=\"" << Vec(j.axis) << "\"/>\n";
    if (j.type == JointType::kPrismatic) {
      o << "    <limit lower=\"-1\" upper=\"1\" effort=\"1000\" velocity=\"1\"/>\n";
    }
    o << "  </joint>\n";
  }
  for (const JointSpec& j : d.joints) {
    if (j.type == JointType::kFixed) continue;
    if (j.role == JointRole::kLimb && j.stiffness == 0.0) continue;
    o << "  <isowrench:joint name=\"" << j.name << "\" role=\"" << RoleName(j.role)
      << "\" stiffness=\"" << N(j.stiffness) << "\"/>\n";
  }
  const TransducerSpec& t = d.transducer;
  std::string released;
  for (int i = 0; i < 6; ++i) {
    if (t.released[i]) released += std::string(released.empty() ? "" : " ") + DofName(i);
  }
  o << "  <isowrench:transducer link=\"" << t.link << "\" xyz=\"" << Vec(t.endpoint)
    << "\" rpy=\"" << Vec(Rpy(t.rotation)) << "\" axes=\""
    << (t.axes_in_world ? "world" : "link") << "\"\n      stiffness=\"";
  for (int i = 0; i < 6; ++i) o << (i ? " " : "") << N(t.stiffness[i]);
  o << "\" released=\"" << released << "\"/>\n";
  for (const MuscleSpec& m : d.muscles) {
    o << "  <isowrench:muscle name=\"" << m.name << "\" max_force=\"" << N(m.max_force) << "\">\n";
    for (const PathPoint& p : m.path) {
      o << "    <isowrench:point link=\"" << p.link << "\" xyz=\"" << Vec(p.position) << "\"/>\n";
    }
    o << "  </isowrench:muscle>\n";
  }
  for (const auto& [joint, value] : d.nominal_posture) {
    o << "  <isowrench:posture joint=\"" << joint << "\" value=\"" << N(value) << "\"/>\n";
  }
  o << "</robot>\n";
  return o.str();
}

void WriteUrdfFile(const LimbDescription& description, const std::string& path) {
  util::WriteFileAtomically(path, WriteUrdfString(description));
}

}  // namespace isowrench
