// LimbDescription -> URDF text with isowrench tags (the inverse of urdf_reader.cpp).

#include <algorithm>
#include <cmath>
#include <sstream>

#include "isowrench/error.hpp"
#include "isowrench/model.hpp"
#include "isowrench/wrap.hpp"
#include "model/function_xml.hpp"
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

// The force model of a muscle: attributes of <isowrench:muscle> (after max_force) and its curve
// elements; OpenSim defaults are left out (the reader restores them).
std::string ForceAttributes(const MuscleForceSpec& f) {
  if (f.model == ForceModelType::kConstant) return "";
  const MuscleForceSpec defaults;
  std::string a = std::string(" model=\"") + ForceModelName(f.model) +
                  "\" optimal_fiber_length=\"" + N(f.optimal_fiber_length) +
                  "\" tendon_slack_length=\"" + N(f.tendon_slack_length) + "\"";
  auto add = [&](const char* name, double v, double def) {
    if (v != def) a += std::string(" ") + name + "=\"" + N(v) + "\"";
  };
  add("pennation_angle_at_optimal", f.pennation_angle_at_optimal,
      defaults.pennation_angle_at_optimal);
  add("maximum_pennation_angle", f.maximum_pennation_angle, defaults.maximum_pennation_angle);
  add("minimum_activation", f.minimum_activation, defaults.minimum_activation);
  if (f.ignore_tendon_compliance) a += " ignore_tendon_compliance=\"true\"";
  if (f.model == ForceModelType::kMillard2012) {
    add("fiber_damping", f.fiber_damping, defaults.fiber_damping);
  }
  return a;
}

std::string ForceElements(const MuscleForceSpec& f, const std::string& indent) {
  std::ostringstream o;
  const MuscleForceSpec d;
  auto attr = [&](const char* name, double v) { o << " " << name << "=\"" << N(v) << "\""; };
  auto opt = [&](const char* name, const std::optional<double>& v) {
    if (v) attr(name, *v);
  };
  if (f.model == ForceModelType::kMillard2012) {
    if (f.active_force_length != d.active_force_length) {
      const ActiveForceLengthCurveSpec& c = f.active_force_length;
      o << indent << "<isowrench:active_force_length";
      attr("min_norm_active_fiber_length", c.min_norm_active_fiber_length);
      attr("transition_norm_fiber_length", c.transition_norm_fiber_length);
      attr("max_norm_active_fiber_length", c.max_norm_active_fiber_length);
      attr("shallow_ascending_slope", c.shallow_ascending_slope);
      attr("minimum_value", c.minimum_value);
      o << "/>\n";
    }
    if (f.fiber_force_length != d.fiber_force_length) {
      const FiberForceLengthCurveSpec& c = f.fiber_force_length;
      o << indent << "<isowrench:fiber_force_length";
      attr("strain_at_zero_force", c.strain_at_zero_force);
      attr("strain_at_one_norm_force", c.strain_at_one_norm_force);
      opt("stiffness_at_low_force", c.stiffness_at_low_force);
      opt("stiffness_at_one_norm_force", c.stiffness_at_one_norm_force);
      opt("curviness", c.curviness);
      o << "/>\n";
    }
    if (f.tendon_force_length != d.tendon_force_length) {
      const TendonForceLengthCurveSpec& c = f.tendon_force_length;
      o << indent << "<isowrench:tendon_force_length";
      attr("strain_at_one_norm_force", c.strain_at_one_norm_force);
      opt("stiffness_at_one_norm_force", c.stiffness_at_one_norm_force);
      opt("norm_force_at_toe_end", c.norm_force_at_toe_end);
      opt("curviness", c.curviness);
      o << "/>\n";
    }
  } else if (f.model == ForceModelType::kThelen2003 && f.thelen != d.thelen) {
    const Thelen2003CurveSpec& c = f.thelen;
    o << indent << "<isowrench:thelen2003_curves";
    attr("FmaxTendonStrain", c.FmaxTendonStrain);
    attr("FmaxMuscleStrain", c.FmaxMuscleStrain);
    attr("KshapeActive", c.KshapeActive);
    attr("KshapePassive", c.KshapePassive);
    o << "/>\n";
  }
  return o.str();
}

const CoordinateSpec* Coordinate(const LimbDescription& d, const std::string& name) {
  for (const CoordinateSpec& c : d.coordinates) {
    if (c.name == name) return &c;
  }
  return nullptr;
}

/// A driven joint whose coupling URDF's own <mimic> can say: linear, driven by a joint.
bool IsMimic(const LimbDescription& d, const JointSpec& j) {
  if (j.type == JointType::kFixed || j.coordinate.empty() || j.coordinate == j.name) return false;
  const CoordinateSpec* driver = Coordinate(d, j.coordinate);
  return driver && !driver->joint.empty() && j.coupling.is_linear();
}

bool IsCoupled(const LimbDescription& d, const JointSpec& j) {
  return j.type != JointType::kFixed && !j.coordinate.empty() && j.coordinate != j.name &&
         !IsMimic(d, j);
}

/// The <isowrench:joint> element for a coordinate, or "" when everything is at its default.
std::string CoordinateTag(const std::string& name, JointRole role, double stiffness, bool locked) {
  if (role == JointRole::kLimb && stiffness == 0.0 && !locked) return "";
  std::string tag = "  <isowrench:joint name=\"" + name + "\" role=\"" + RoleName(role) +
                    "\" stiffness=\"" + N(stiffness) + "\"";
  if (locked) tag += " locked=\"true\"";
  return tag + "/>\n";
}

/// Length of the well-formed UTF-8 sequence (RFC 3629: no overlong forms, no surrogates, at
/// most U+10FFFF) starting at text[i], or 0 when there is none.
size_t Utf8SequenceLength(const std::string& text, size_t i) {
  const auto byte = [&](size_t k) { return static_cast<unsigned char>(text[k]); };
  const unsigned char lead = byte(i);
  if (lead < 0x80) return 1;
  size_t length = 0;
  unsigned char low = 0x80, high = 0xBF;  // the range of the second byte
  if (lead >= 0xC2 && lead <= 0xDF) {
    length = 2;
  } else if (lead >= 0xE0 && lead <= 0xEF) {
    length = 3;
    if (lead == 0xE0) low = 0xA0;   // overlong
    if (lead == 0xED) high = 0x9F;  // surrogates
  } else if (lead >= 0xF0 && lead <= 0xF4) {
    length = 4;
    if (lead == 0xF0) low = 0x90;   // overlong
    if (lead == 0xF4) high = 0x8F;  // beyond U+10FFFF
  } else {
    return 0;
  }
  if (i + length > text.size() || byte(i + 1) < low || byte(i + 1) > high) return 0;
  for (size_t k = 2; k < length; ++k) {
    if (byte(i + k) < 0x80 || byte(i + k) > 0xBF) return 0;
  }
  return length;
}

bool IsUtf8(const std::string& text) {
  for (size_t i = 0; i < text.size();) {
    const size_t length = Utf8SequenceLength(text, i);
    if (length == 0) return false;
    i += length;
  }
  return true;
}

// Names are written into XML attributes verbatim: refuse one that XML would change or reject
// (an OpenSim file read leniently can carry a raw '&' or a byte that is not UTF-8; found by
// fuzz/osim_import_fuzzer.cpp).
void CheckXmlName(const char* what, const std::string& name) {
  for (const char c : name) {
    if (c == '&' || c == '<' || c == '>' || c == '"' || c == '\'' ||
        static_cast<unsigned char>(c) < 0x20) {
      throw Error(std::string("cannot write URDF: ") + what + " name '" + name +
                  "' contains a character XML attribute values cannot hold as is (& < > \" ' or a "
                  "control character); rename it");
    }
  }
  if (!IsUtf8(name)) {
    std::string shown;  // the name with its bytes that are not UTF-8 as \xHH
    for (size_t i = 0; i < name.size();) {
      const size_t length = Utf8SequenceLength(name, i);
      if (length > 0) {
        shown += name.substr(i, length);
        i += length;
      } else {
        static const char kHex[] = "0123456789ABCDEF";
        const unsigned char b = static_cast<unsigned char>(name[i++]);
        shown += std::string("\\x") + kHex[b >> 4] + kHex[b & 15];
      }
    }
    throw Error(std::string("cannot write URDF: ") + what + " name '" + shown +
                "' is not UTF-8 text (its file saved in another encoding, e.g. Latin-1?); "
                "rename it in that file or save the file as UTF-8");
  }
}

void CheckXmlNames(const LimbDescription& d) {
  CheckXmlName("model", d.name);
  for (const std::string& link : d.links) CheckXmlName("link", link);
  for (const JointSpec& j : d.joints) CheckXmlName("joint", j.name);
  for (const CoordinateSpec& c : d.coordinates) CheckXmlName("coordinate", c.name);
  for (const MuscleSpec& m : d.muscles) CheckXmlName("muscle", m.name);
  for (const WrapObjectSpec& w : d.wrap_objects) CheckXmlName("wrap object", w.name);
}

}  // namespace

std::string WriteUrdfString(const LimbDescription& description) {
  const LimbDescription d = NormalizeCoordinates(description);
  CheckXmlNames(d);
  std::ostringstream o;
  o << "<?xml version=\"1.0\"?>\n";
  o << "<!-- Written by isowrench";
  // The source path goes into a comment only when a comment can hold it.
  if (!d.source.empty() && IsUtf8(d.source) && d.source.find("--") == std::string::npos &&
      d.source.back() != '-') {
    o << " from " << d.source;
  }
  o << ". Extension tags: docs/urdf-extensions.md -->\n";
  o << "<robot name=\"" << d.name << "\" xmlns:isowrench=\"urn:isowrench:urdf:1\"";
  // The wrap mode (docs/urdf-extensions.md "Wrap mode"): written whenever the limb has wrap
  // objects, so that a file carries how its lengths were computed, and whenever it is not the
  // default.
  if (!d.wrap_objects.empty() || d.wrap_mode != WrapMode::kOpenSim) {
    o << " isowrench:wrap_mode=\"" << WrapModeName(d.wrap_mode) << "\"";
  }
  o << ">\n";
  for (const std::string& link : d.links) o << "  <link name=\"" << link << "\"/>\n";
  for (const JointSpec& j : d.joints) {
    const CoordinateSpec* own = j.coordinate == j.name ? Coordinate(d, j.name) : nullptr;
    const bool limited = own && std::isfinite(own->lower) && std::isfinite(own->upper);
    const char* type = j.type == JointType::kRevolute    ? (limited ? "revolute" : "continuous")
                       : j.type == JointType::kPrismatic ? "prismatic"
                                                         : "fixed";
    o << "  <joint name=\"" << j.name << "\" type=\"" << type << "\">\n";
    o << "    <parent link=\"" << j.parent_link << "\"/> <child link=\"" << j.child_link
      << "\"/>\n";
    o << "    <origin xyz=\"" << Vec(j.origin.translation()) << "\" rpy=\""
      << Vec(Rpy(j.origin.linear())) << "\"/>\n";
    if (j.type != JointType::kFixed) o << "    <axis xyz=\"" << Vec(j.axis) << "\"/>\n";
    if (limited) {
      o << "    <limit lower=\"" << N(own->lower) << "\" upper=\"" << N(own->upper)
        << "\" effort=\"1000\" velocity=\"1\"/>\n";
    } else if (j.type == JointType::kPrismatic) {
      o << "    <limit lower=\"-1\" upper=\"1\" effort=\"1000\" velocity=\"1\"/>\n";
    }
    if (IsMimic(d, j)) {
      o << "    <mimic joint=\"" << Coordinate(d, j.coordinate)->joint << "\" multiplier=\""
        << N(j.coupling.slope()) << "\" offset=\"" << N(j.coupling.intercept()) << "\"/>\n";
    }
    o << "  </joint>\n";
  }
  for (const CoordinateSpec& c : d.coordinates) {
    if (!c.joint.empty()) continue;
    o << "  <isowrench:coordinate name=\"" << c.name << "\" type=\""
      << (c.type == JointType::kPrismatic ? "prismatic" : "revolute") << "\" default=\""
      << N(c.default_value) << "\"";
    if (std::isfinite(c.lower)) o << " lower=\"" << N(c.lower) << "\"";
    if (std::isfinite(c.upper)) o << " upper=\"" << N(c.upper) << "\"";
    o << " locked=\"" << (c.locked ? "true" : "false") << "\"/>\n";
    o << CoordinateTag(c.name, c.role, c.stiffness, false);
  }
  for (const JointSpec& j : d.joints) {
    if (j.type == JointType::kFixed || j.coordinate != j.name) continue;
    const CoordinateSpec* own = Coordinate(d, j.name);
    o << CoordinateTag(j.name, j.role, j.stiffness, own && own->locked);
  }
  for (const JointSpec& j : d.joints) {
    if (!IsCoupled(d, j)) continue;
    o << "  <isowrench:coupling joint=\"" << j.name << "\" coordinate=\"" << j.coordinate << "\">\n"
      << FunctionXmlText(j.coupling, "    ") << "  </isowrench:coupling>\n";
  }
  const TransducerSpec& t = d.transducer;
  std::string released;
  for (int i = 0; i < 6; ++i) {
    if (t.released[i]) released += std::string(released.empty() ? "" : " ") + DofName(i);
  }
  o << "  <isowrench:transducer link=\"" << t.link << "\" xyz=\"" << Vec(t.endpoint) << "\" rpy=\""
    << Vec(Rpy(t.rotation)) << "\" axes=\"" << (t.axes_in_world ? "world" : "link")
    << "\"\n      stiffness=\"";
  for (int i = 0; i < 6; ++i) o << (i ? " " : "") << N(t.stiffness[i]);
  o << "\" released=\"" << released << "\"/>\n";
  for (const WrapObjectSpec& w : d.wrap_objects) {  // docs/urdf-extensions.md "Wrap objects"
    o << "  <isowrench:wrap name=\"" << w.name << "\" link=\"" << w.link << "\" shape=\""
      << WrapShapeName(w.shape) << "\"";
    switch (w.shape) {
      case WrapShape::kCylinder:
        o << " radius=\"" << N(w.radius) << "\" length=\"" << N(w.length) << "\"";
        break;
      case WrapShape::kSphere: o << " radius=\"" << N(w.radius) << "\""; break;
      case WrapShape::kEllipsoid: o << " radii=\"" << Vec(w.radii) << "\""; break;
      case WrapShape::kTorus:
        o << " inner_radius=\"" << N(w.inner_radius) << "\" outer_radius=\"" << N(w.outer_radius)
          << "\"";
        break;
    }
    o << "\n      translation=\"" << Vec(w.translation) << "\" xyz_body_rotation=\""
      << Vec(w.xyz_body_rotation) << "\" quadrant=\"" << w.quadrant.ToString() << "\" active=\""
      << (w.active ? "true" : "false") << "\"/>\n";
  }
  for (const MuscleSpec& m : d.muscles) {
    o << "  <isowrench:muscle name=\"" << m.name << "\" max_force=\"" << N(m.max_force) << "\""
      << ForceAttributes(m.force) << ">\n"
      << ForceElements(m.force, "    ");
    for (const PathPoint& p : m.path) {
      o << "    <isowrench:point link=\"" << p.link << "\" xyz=\"" << Vec(p.position) << "\"";
      if (!p.active_coordinate.empty()) {
        o << " active_coordinate=\"" << p.active_coordinate << "\" active_range=\""
          << N(p.active_lower) << " " << N(p.active_upper) << "\"";
      }
      if (p.moving.empty()) {
        o << "/>\n";
        continue;
      }
      o << ">\n";
      for (const MovingComponent& c : p.moving) {
        o << "      <isowrench:moving axis=\""
          << "xyz"[c.axis] << "\" coordinate=\"" << c.coordinate << "\">\n"
          << FunctionXmlText(c.function, "        ") << "      </isowrench:moving>\n";
      }
      o << "    </isowrench:point>\n";
    }
    for (const PathWrapSpec& w : m.wraps) {
      o << "    <isowrench:path_wrap object=\"" << w.object << "\" range=\"" << w.range_first << " "
        << w.range_last << "\" method=\"" << WrapMethodName(w.method) << "\"/>\n";
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
