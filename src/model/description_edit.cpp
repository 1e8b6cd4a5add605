// Editing a LimbDescription: base dofs, joint stiffness, extra joints, releases, presets.

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "isowrench/error.hpp"
#include "isowrench/input_checks.hpp"
#include "isowrench/model.hpp"
#include "util/text.hpp"

namespace isowrench {
namespace {

JointSpec& FindMovable(LimbDescription& d, const std::string& name) {
  std::vector<std::string> known;
  for (JointSpec& j : d.joints) {
    if (j.type == JointType::kFixed) continue;
    if (j.name == name) return j;
    known.push_back(j.name);
  }
  throw Error("unknown joint '" + name + "' in model '" + d.name +
              "' (movable joints: " + util::Join(known, ", ") + ")");
}

void CheckStiffness(double stiffness, const std::string& what) {
  if (!std::isfinite(stiffness) || stiffness < 0) {
    throw Error(what + ": stiffness " + util::FormatNumber(stiffness) + " must be finite and >= 0");
  }
  CheckStiffnessValue(stiffness, what);  // <= kMaxStiffness
}

bool HasLink(const LimbDescription& d, const std::string& name) {
  return std::find(d.links.begin(), d.links.end(), name) != d.links.end();
}

/// A movable joint that is its own coordinate (q_joint = q_coordinate).
bool CarriesOwnCoordinate(const JointSpec& j) {
  return j.type != JointType::kFixed && j.coordinate == j.name;
}

void CheckFreeCoordinate(const CoordinateSpec& c, const std::string& model) {
  const std::string what = model + ", coordinate '" + c.name + "'";
  if (c.name.empty()) throw Error(model + ": a coordinate has no name");
  if (c.type == JointType::kFixed) throw Error(what + ": type must be revolute or prismatic");
  CheckStiffness(c.stiffness, what);
  if (!std::isfinite(c.default_value)) {
    throw Error(what + ": default value " + util::FormatNumber(c.default_value) + " is not finite");
  }
  if (std::isnan(c.lower) || std::isnan(c.upper) || c.lower > c.upper) {
    throw Error(what + ": range [" + util::FormatNumber(c.lower) + ", " +
                util::FormatNumber(c.upper) + "] needs lower <= upper");
  }
}

}  // namespace

LimbDescription NormalizeCoordinates(LimbDescription d) {
  const std::string model = "model '" + d.name + "'";
  std::map<std::string, CoordinateSpec> declared;
  for (const CoordinateSpec& c : d.coordinates) {
    if (!declared.emplace(c.name, c).second)
      throw Error(model + ": coordinate '" + c.name + "' is defined twice");
  }
  std::set<std::string> carried;  // coordinates a joint carries with the identity
  for (JointSpec& j : d.joints) {
    if (j.type == JointType::kFixed) continue;
    if (j.coordinate.empty()) {
      if (!j.coupling.is_identity()) {
        throw Error(model + ", joint '" + j.name +
                    "': a coupling needs the coordinate that drives it");
      }
      j.coordinate = j.name;
    }
    if (CarriesOwnCoordinate(j)) {
      if (!j.coupling.is_identity()) {
        throw Error(model + ", joint '" + j.name +
                    "' is coupled to itself; name another coordinate");
      }
      carried.insert(j.name);
    }
  }
  std::vector<CoordinateSpec> ordered;
  std::map<std::string, size_t> position;
  for (const JointSpec& j : d.joints) {
    if (j.type == JointType::kFixed) continue;
    if (!position.count(j.coordinate)) {
      auto it = declared.find(j.coordinate);
      if (it != declared.end()) {
        ordered.push_back(it->second);
      } else if (carried.count(j.coordinate)) {
        CoordinateSpec c;
        c.name = j.coordinate;
        ordered.push_back(c);
      } else {
        throw Error(model + ", joint '" + j.name + "' is driven by unknown coordinate '" +
                    j.coordinate + "'");
      }
      position[j.coordinate] = ordered.size() - 1;
    }
    CoordinateSpec& c = ordered[position[j.coordinate]];
    if (CarriesOwnCoordinate(j)) {
      c.type = j.type;
      c.role = j.role;
      c.stiffness = j.stiffness;
      c.joint = j.name;
    } else if (j.stiffness != 0.0) {
      throw Error(model + ", joint '" + j.name + "': stiffness " + util::FormatNumber(j.stiffness) +
                  " on a joint driven by coordinate '" + j.coordinate +
                  "'; a driven joint has no dof of its "
                  "own: give the stiffness to '" +
                  j.coordinate + "'");
    }
  }
  for (const CoordinateSpec& c : d.coordinates) {
    // Drop coordinates whose carrier joint is gone and which drive nothing; keep free ones.
    if (!position.count(c.name) && c.joint.empty()) {
      position[c.name] = ordered.size();
      ordered.push_back(c);
    }
  }
  for (CoordinateSpec& c : ordered) {
    if (!carried.count(c.name)) {
      c.joint.clear();
      CheckFreeCoordinate(c, model);
    }
  }
  d.coordinates = std::move(ordered);
  return d;
}

const CoordinateSpec& FindCoordinate(const LimbDescription& d, const std::string& name) {
  std::vector<std::string> known;
  for (const CoordinateSpec& c : d.coordinates) {
    if (c.name == name) return c;
    known.push_back(c.name);
  }
  for (const JointSpec& j : d.joints) {
    if (j.name != name) continue;
    if (j.type == JointType::kFixed) {
      throw Error("joint '" + name + "' of model '" + d.name +
                  "' is fixed; it has no coordinate (coordinates: " + util::Join(known, ", ") +
                  ")");
    }
    if (!j.coordinate.empty() && j.coordinate != j.name) {
      auto driver = std::find_if(d.coordinates.begin(), d.coordinates.end(),
                                 [&](const CoordinateSpec& c) { return c.name == j.coordinate; });
      const bool mimic =
          j.coupling.is_linear() && driver != d.coordinates.end() && !driver->joint.empty();
      throw Error("joint '" + name + "' is driven by coordinate '" + j.coordinate + "' (" +
                  (mimic ? "mimic" : "isowrench:coupling") + "); set '" + j.coordinate +
                  "' instead");
    }
  }
  throw Error("unknown coordinate '" + name + "' in model '" + d.name + "'" +
              DidYouMean(name, known) + " (coordinates: " + util::Join(known, ", ") + ")");
}

const char* RoleName(JointRole role) {
  switch (role) {
    case JointRole::kLimb: return "limb";
    case JointRole::kBase: return "base";
    case JointRole::kExtra: return "extra";
    case JointRole::kRelease: return "release";
  }
  return "limb";
}

const char* DofName(int dof) {
  static const char* kNames[6] = {"x", "y", "z", "rx", "ry", "rz"};
  return (dof >= 0 && dof < 6) ? kNames[dof] : "?";
}

Vector6d TransducerPreset(const std::string& name) {
  Vector6d s;
  if (name == "balanced") {
    s.setConstant(1e7);
  } else if (name == "ati-mini40") {
    s << 1.1e7, 1.1e7, 2.0e7, 2.8e3, 2.8e3, 4.0e3;  // datasheet, MODEL.md
  } else if (name == "jr3") {
    s << 0.519, 0.519, 5.279, 0.0054, 0.0054, 0.0015;  // as printed in the paper
  } else {
    throw Error("unknown transducer preset '" + name + "' (known: balanced, ati-mini40, jr3)");
  }
  return s;
}

LimbDescription WithBaseStiffness(LimbDescription d, double stiffness) {
  CheckStiffness(stiffness, "base");
  bool found = false;
  for (JointSpec& j : d.joints) {
    if (j.role == JointRole::kBase) {
      j.stiffness = stiffness;
      found = true;
    }
  }
  if (found) return NormalizeCoordinates(std::move(d));
  const char* names[3] = {"base_x", "base_y", "base_z"};
  std::vector<JointSpec> base;
  std::string parent = d.root_link;
  for (int i = 0; i < 3; ++i) {
    JointSpec j;
    j.name = names[i];
    for (const JointSpec& other : d.joints) {
      if (other.name == j.name) throw Error("cannot add base dofs: joint '" + j.name + "' exists");
    }
    j.type = JointType::kPrismatic;
    j.role = JointRole::kBase;
    j.stiffness = stiffness;
    j.axis = Eigen::Vector3d::Unit(i);
    j.parent_link = parent;
    j.child_link = std::string(names[i]) + "_link";
    if (HasLink(d, j.child_link))
      throw Error("cannot add base dofs: link '" + j.child_link + "' exists");
    parent = j.child_link;
    base.push_back(j);
  }
  if (!d.joints.empty()) d.joints.front().parent_link = parent;
  d.joints.insert(d.joints.begin(), base.begin(), base.end());
  d.links.insert(d.links.begin() + 1, {"base_x_link", "base_y_link", "base_z_link"});
  return NormalizeCoordinates(std::move(d));
}

LimbDescription WithJointStiffness(LimbDescription d, const std::string& joint, double stiffness) {
  CheckStiffness(stiffness, "joint '" + joint + "'");
  d = NormalizeCoordinates(std::move(d));
  const CoordinateSpec& c = FindCoordinate(d, joint);
  if (!c.joint.empty()) FindMovable(d, c.joint).stiffness = stiffness;
  for (CoordinateSpec& coordinate : d.coordinates) {
    if (coordinate.name == joint) coordinate.stiffness = stiffness;
  }
  return d;
}

LimbDescription WithExtraJoint(LimbDescription d, const std::string& after_joint,
                               const std::string& new_joint, const Eigen::Vector3d& axis,
                               double stiffness) {
  CheckStiffness(stiffness, "joint '" + new_joint + "'");
  if (!axis.allFinite() || axis.norm() < 1e-12) {
    throw Error("extra joint '" + new_joint + "': axis must be a finite non-zero vector");
  }
  for (const JointSpec& j : d.joints) {
    if (j.name == new_joint) throw Error("extra joint '" + new_joint + "' already exists");
  }
  FindMovable(d, after_joint);
  auto it = std::find_if(d.joints.begin(), d.joints.end(),
                         [&](const JointSpec& j) { return j.name == after_joint; });
  JointSpec extra;
  extra.name = new_joint;
  extra.type = JointType::kRevolute;
  extra.role = JointRole::kExtra;
  extra.stiffness = stiffness;
  extra.axis = axis.normalized();
  extra.parent_link = it->child_link;
  extra.child_link = new_joint + "_link";
  if (HasLink(d, extra.child_link))
    throw Error("extra joint: link '" + extra.child_link + "' exists");
  // Everything that hung on after_joint's child now hangs on the new joint's child.
  auto next = it + 1;
  if (next != d.joints.end()) next->parent_link = extra.child_link;
  // Links, muscle points and the transducer stay on their links: the new link is massless
  // and coincides with after_joint's child at zero extra angle. But anything attached to
  // after_joint's child link must now move with the extra joint, so move those to the new link.
  std::string old_child = it->child_link;
  for (MuscleSpec& m : d.muscles) {
    for (PathPoint& p : m.path) {
      if (p.link == old_child) p.link = extra.child_link;
    }
  }
  if (d.transducer.link == old_child) d.transducer.link = extra.child_link;
  auto link_it = std::find(d.links.begin(), d.links.end(), old_child);
  d.links.insert(link_it + 1, extra.child_link);
  d.joints.insert(next, extra);
  return NormalizeCoordinates(std::move(d));
}

LimbDescription WithLockedCoordinates(LimbDescription d, const std::vector<std::string>& locked) {
  d = NormalizeCoordinates(std::move(d));
  std::set<std::string> names;
  for (const std::string& name : locked) {
    if (name == "none") continue;
    names.insert(FindCoordinate(d, name).name);  // throws for unknown or driven names
  }
  for (CoordinateSpec& c : d.coordinates) c.locked = names.count(c.name) > 0;
  return d;
}

LimbDescription WithReleasedDofs(LimbDescription d, const DofMask& released) {
  d.transducer.released = released;
  return d;
}

DofMask::DofMask(std::initializer_list<std::string> names)
    : DofMask(FromNames(std::vector<std::string>(names))) {}

DofMask DofMask::FromNames(const std::vector<std::string>& names) {
  DofMask mask;
  for (const std::string& name : names) {
    if (name == "none") continue;
    int index = -1;
    for (int i = 0; i < 6; ++i) {
      if (name == DofName(i)) index = i;
    }
    if (index < 0) throw Error("dof '" + name + "' is not one of x y z rx ry rz");
    mask.set(index);
  }
  return mask;
}

DofMask DofMask::Parse(const std::string& text) {
  std::vector<std::string> names;
  std::string token;
  for (char c : text + ",") {
    if (c == ',' || c == ' ' || c == '\t') {
      if (!token.empty()) names.push_back(token);
      token.clear();
    } else {
      token += c;
    }
  }
  return FromNames(names);
}

int DofMask::count() const {
  int n = 0;
  for (int i = 0; i < 6; ++i) n += (*this)[i] ? 1 : 0;
  return n;
}

std::vector<std::string> DofMask::names() const {
  std::vector<std::string> out;
  for (int i = 0; i < 6; ++i) {
    if ((*this)[i]) out.emplace_back(DofName(i));
  }
  return out;
}

std::string DofMask::ToString(const std::string& separator) const {
  std::string out;
  for (const std::string& name : names()) out += (out.empty() ? "" : separator) + name;
  return out.empty() ? "none" : out;
}

LimbDescription WithTransducerStiffness(LimbDescription d, const Vector6d& stiffness) {
  for (int i = 0; i < 6; ++i) {
    if (!std::isfinite(stiffness[i]) || stiffness[i] < 0) {
      throw Error(std::string("transducer stiffness ") + DofName(i) + " = " +
                  util::FormatNumber(stiffness[i]) + " must be finite and >= 0");
    }
    CheckStiffnessValue(stiffness[i],
                        std::string("WithTransducerStiffness: transducer ") + DofName(i));
  }
  d.transducer.stiffness = stiffness;
  return d;
}

}  // namespace isowrench
