// Coordinates and couplings of a URDF: <isowrench:coordinate>, <mimic>, <isowrench:coupling>,
// and the coordinate attributes of <isowrench:joint> (see urdf_coordinates.hpp).

#include "model/urdf_coordinates.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "isowrench/error.hpp"
#include "isowrench/input_checks.hpp"
#include "model/function_xml.hpp"
#include "util/text.hpp"

namespace isowrench::urdf_coordinates {
namespace {

std::string Line(const std::string& source, const tinyxml2::XMLElement& e) {
  return source + ":" + std::to_string(e.GetLineNum());
}

[[noreturn]] void Fail(const std::string& source, const tinyxml2::XMLElement& e,
                       const std::string& what) {
  throw Error(Line(source, e) + ": " + what);
}

/// A finite number from attribute `name`, or `fallback` when the attribute is absent.
double Number(const std::string& source, const tinyxml2::XMLElement& e, const char* name,
              double fallback) {
  const char* text = e.Attribute(name);
  if (!text) return fallback;
  double value = 0.0;
  if (!util::ParseDouble(text, &value) || !std::isfinite(value)) {
    Fail(source, e,
         std::string("<") + e.Name() + "> attribute " + name + "='" + text +
             "' is not a finite number");
  }
  return value;
}

std::string Required(const std::string& source, const tinyxml2::XMLElement& e, const char* name) {
  const char* text = e.Attribute(name);
  if (!text || !*text)
    Fail(source, e, std::string("<") + e.Name() + "> needs the attribute '" + name + "'");
  return text;
}

/// locked="true|false|1|0"; `fallback` when absent.
bool Flag(const std::string& source, const tinyxml2::XMLElement& e, const char* name,
          bool fallback) {
  const char* text = e.Attribute(name);
  if (!text) return fallback;
  const std::string value = text;
  if (value == "true" || value == "1") return true;
  if (value == "false" || value == "0") return false;
  Fail(source, e,
       std::string("<") + e.Name() + "> attribute " + name + "='" + value +
           "' must be true or false");
}

/// What drives a movable joint of the chain, as written in the file.
struct Driver {
  const tinyxml2::XMLElement* element = nullptr;  ///< the <mimic> or <isowrench:coupling>
  bool mimic = false;
  std::string target;  ///< the mimicked joint, or the coupling's coordinate
  Function f;          ///< Linear(multiplier, offset) for a mimic
};

struct Resolved {
  std::string coordinate;
  Function f;
};

class CouplingReader {
 public:
  CouplingReader(const tinyxml2::XMLElement& robot, const std::string& source, LimbDescription& d)
      : robot_(robot), source_(source), d_(d) {
    for (auto* e = robot.FirstChildElement("joint"); e; e = e->NextSiblingElement("joint")) {
      if (const char* name = e->Attribute("name")) elements_[name] = e;
    }
    for (JointSpec& j : d.joints) {
      chain_[j.name] = &j;
      if (j.type != JointType::kFixed) movable_.push_back(j.name);
    }
  }

  void Read() {
    ReadFreeCoordinates();
    ReadMimics();
    ReadCouplings();
    for (JointSpec& j : d_.joints) {
      if (j.type == JointType::kFixed) continue;
      Resolved r = Resolve(j.name);
      j.coordinate = r.coordinate;
      j.coupling = r.f;
    }
    try {
      d_ = NormalizeCoordinates(std::move(d_));
    } catch (const Error& e) {
      throw Error(source_ + ": " + e.what());
    }
    ReadJointLimits();
  }

 private:
  void ReadFreeCoordinates() {
    for (auto* e = robot_.FirstChildElement("isowrench:coordinate"); e;
         e = e->NextSiblingElement("isowrench:coordinate")) {
      CoordinateSpec c;
      c.name = Required(source_, *e, "name");
      if (elements_.count(c.name)) {
        Fail(source_, *e,
             "coordinate '" + c.name +
                 "' has the name of a joint; a joint is its own coordinate "
                 "already, so give the free-standing coordinate another name");
      }
      for (const CoordinateSpec& other : d_.coordinates) {
        if (other.name == c.name) Fail(source_, *e, "coordinate '" + c.name + "' is defined twice");
      }
      const char* type = e->Attribute("type");
      const std::string t = type ? type : "revolute";
      if (t == "revolute" || t == "continuous") {
        c.type = JointType::kRevolute;
      } else if (t == "prismatic") {
        c.type = JointType::kPrismatic;
      } else {
        Fail(source_, *e,
             "coordinate '" + c.name + "': type '" + t + "' must be revolute or prismatic");
      }
      c.default_value = Number(source_, *e, "default", 0.0);
      c.lower = Number(source_, *e, "lower", -std::numeric_limits<double>::infinity());
      c.upper = Number(source_, *e, "upper", std::numeric_limits<double>::infinity());
      if (c.lower > c.upper) {
        Fail(source_, *e,
             "coordinate '" + c.name + "': lower " + util::FormatNumber(c.lower) + " > upper " +
                 util::FormatNumber(c.upper));
      }
      c.locked = Flag(source_, *e, "locked", false);
      d_.coordinates.push_back(c);
    }
  }

  /// A joint that may be coupled: on the chain and movable.
  JointSpec& CoupledJoint(const tinyxml2::XMLElement& e, const std::string& name, const char* how) {
    auto it = chain_.find(name);
    if (it == chain_.end()) {
      if (elements_.count(name)) {
        Fail(source_, e,
             std::string(how) + " joint '" + name + "', which is not on the chain from '" +
                 d_.root_link + "' to the endpoint link '" + d_.transducer.link + "'");
      }
      Fail(source_, e,
           std::string(how) + " unknown joint '" + name + "'" + DidYouMean(name, movable_));
    }
    if (it->second->type == JointType::kFixed) {
      Fail(source_, e,
           std::string(how) + " joint '" + name + "', which is fixed: it has no dof to couple");
    }
    return *it->second;
  }

  void ReadMimics() {
    for (const JointSpec& j : d_.joints) {
      const tinyxml2::XMLElement* joint_element =
          elements_.count(j.name) ? elements_.at(j.name) : nullptr;
      const tinyxml2::XMLElement* mimic =
          joint_element ? joint_element->FirstChildElement("mimic") : nullptr;
      if (!mimic) continue;
      if (j.type == JointType::kFixed) {
        Fail(source_, *mimic,
             "joint '" + j.name +
                 "' is fixed and has a <mimic>: a fixed joint has no dof to couple");
      }
      Driver driver;
      driver.element = mimic;
      driver.mimic = true;
      driver.target = Required(source_, *mimic, "joint");
      driver.f = Function::Linear(Number(source_, *mimic, "multiplier", 1.0),
                                  Number(source_, *mimic, "offset", 0.0));
      drivers_[j.name] = driver;
    }
  }

  void ReadCouplings() {
    for (auto* e = robot_.FirstChildElement("isowrench:coupling"); e;
         e = e->NextSiblingElement("isowrench:coupling")) {
      JointSpec& j = CoupledJoint(*e, Required(source_, *e, "joint"), "<isowrench:coupling> of");
      auto previous = drivers_.find(j.name);
      if (previous != drivers_.end()) {
        Fail(source_, *e,
             "joint '" + j.name + "' is coupled twice: it already has a " +
                 (previous->second.mimic ? "<mimic>" : "<isowrench:coupling>") + " at line " +
                 std::to_string(previous->second.element->GetLineNum()));
      }
      Driver driver;
      driver.element = e;
      driver.target = Required(source_, *e, "coordinate");
      try {
        driver.f = ParseFunctionChild(*e, source_);
      } catch (const Error& error) {
        throw Error(std::string(error.what()) + " (coupling of joint '" + j.name + "')");
      }
      drivers_[j.name] = driver;
    }
  }

  bool IsFreeCoordinate(const std::string& name) const {
    for (const CoordinateSpec& c : d_.coordinates) {
      if (c.name == name) return true;
    }
    return false;
  }

  /// The independent coordinate of a movable chain joint and q_joint = f(q_coordinate).
  Resolved Resolve(const std::string& name) {
    auto done = resolved_.find(name);
    if (done != resolved_.end()) return done->second;
    auto it = drivers_.find(name);
    if (it == drivers_.end()) return {name, Function::Linear(1.0, 0.0)};
    const Driver& driver = it->second;
    if (std::find(visiting_.begin(), visiting_.end(), name) != visiting_.end()) {
      std::vector<std::string> cycle(std::find(visiting_.begin(), visiting_.end(), name),
                                     visiting_.end());
      cycle.push_back(name);
      Fail(source_, *driver.element,
           "joint '" + name + "' " + (driver.mimic ? "mimics" : "is coupled to") + " '" +
               driver.target + "', which in turn depends on '" + name + "': a coupling cycle (" +
               util::Join(cycle, " -> ") + ")");
    }
    visiting_.push_back(name);
    Resolved result;
    if (driver.mimic) {
      if (driver.target == name)
        Fail(source_, *driver.element, "joint '" + name + "' mimics itself");
      CoupledJoint(*driver.element, driver.target, ("joint '" + name + "' mimics").c_str());
      Resolved inner = Resolve(driver.target);
      result = {inner.coordinate, ComposeLinear(driver.f.slope(), driver.f.intercept(), inner.f)};
    } else if (IsFreeCoordinate(driver.target)) {
      result = {driver.target, driver.f};
    } else {
      auto target = chain_.find(driver.target);
      if (target == chain_.end() || target->second->type == JointType::kFixed) {
        std::vector<std::string> known;
        for (const CoordinateSpec& c : d_.coordinates) known.push_back(c.name);
        for (const std::string& j : movable_) {
          if (!drivers_.count(j)) known.push_back(j);
        }
        Fail(source_, *driver.element,
             "coupling of joint '" + name + "' names coordinate '" + driver.target + "'" +
                 (target == chain_.end() ? ", which is unknown" : ", a fixed joint") +
                 DidYouMean(driver.target, known) + " (coordinates: " + util::Join(known, ", ") +
                 ")");
      }
      if (driver.target == name)
        Fail(source_, *driver.element, "joint '" + name + "' is coupled to itself");
      Resolved inner = Resolve(driver.target);
      if (inner.coordinate != driver.target) {
        Fail(source_, *driver.element,
             "coupling of joint '" + name + "' names joint '" + driver.target +
                 "', which is driven by coordinate '" + inner.coordinate +
                 "'; a coupling must name an independent coordinate: write it in terms "
                 "of '" +
                 inner.coordinate + "'");
      }
      result = {driver.target, driver.f};
    }
    visiting_.pop_back();
    resolved_[name] = result;
    return result;
  }

  /// <limit lower= upper=> of a revolute or prismatic joint that is its own coordinate.
  void ReadJointLimits() {
    for (CoordinateSpec& c : d_.coordinates) {
      if (c.joint.empty() || !elements_.count(c.joint)) continue;
      const tinyxml2::XMLElement* joint = elements_.at(c.joint);
      const char* type = joint->Attribute("type");
      if (!type || std::string(type) == "continuous") continue;
      const tinyxml2::XMLElement* limit = joint->FirstChildElement("limit");
      if (!limit) continue;
      c.lower = Number(source_, *limit, "lower", 0.0);
      c.upper = Number(source_, *limit, "upper", 0.0);
    }
  }

  const tinyxml2::XMLElement& robot_;
  const std::string& source_;
  LimbDescription& d_;
  std::map<std::string, const tinyxml2::XMLElement*> elements_;  // every <joint> of the file
  std::map<std::string, JointSpec*> chain_;                      // the chain's joints
  std::vector<std::string> movable_;
  std::map<std::string, Driver> drivers_;
  std::map<std::string, Resolved> resolved_;
  std::vector<std::string> visiting_;
};

JointRole RoleFromName(const std::string& source, const tinyxml2::XMLElement& e,
                       const std::string& role, const std::string& name) {
  if (role.empty() || role == "limb") return JointRole::kLimb;
  if (role == "base") return JointRole::kBase;
  if (role == "extra") return JointRole::kExtra;
  if (role == "release") return JointRole::kRelease;
  Fail(source, e,
       "coordinate '" + name + "': role '" + role + "' is not one of limb, base, extra, release");
}

CoordinateSpec* FindMutable(LimbDescription& d, const std::string& name) {
  for (CoordinateSpec& c : d.coordinates) {
    if (c.name == name) return &c;
  }
  return nullptr;
}

}  // namespace

Function ComposeLinear(double multiplier, double offset, const Function& f) {
  if (f.kind() == FunctionKind::kConstant)
    return Function::Constant(multiplier * f.intercept() + offset);
  if (f.is_linear())
    return Function::Linear(multiplier * f.slope(), multiplier * f.intercept() + offset);
  if (offset == 0.0) return multiplier == 1.0 ? f : Function::Multiplier(f, multiplier);
  std::vector<double> y = f.y();
  for (double& v : y) v = multiplier * v + offset;
  switch (f.kind()) {
    case FunctionKind::kSimmSpline: return Function::SimmSpline(f.x(), y);
    case FunctionKind::kNaturalCubicSpline: return Function::NaturalCubicSpline(f.x(), y);
    case FunctionKind::kPiecewiseLinear: return Function::PiecewiseLinear(f.x(), y);
    case FunctionKind::kPolynomial: {
      std::vector<double> c = f.coefficients();
      for (double& v : c) v *= multiplier;
      c.back() += offset;
      return Function::Polynomial(c);
    }
    case FunctionKind::kMultiplier: return ComposeLinear(multiplier * f.scale(), offset, f.inner());
    case FunctionKind::kConstant:
    case FunctionKind::kLinear: break;
  }
  return Function::Linear(multiplier * f.slope(), multiplier * f.intercept() + offset);
}

void ReadCoordinates(const tinyxml2::XMLElement& robot, const std::string& source,
                     LimbDescription& d) {
  CouplingReader(robot, source, d).Read();
}

bool NamesFreeCoordinate(const tinyxml2::XMLElement& joint_tag, const LimbDescription& d) {
  const char* name = joint_tag.Attribute("name");
  if (!name) return false;
  for (const CoordinateSpec& c : d.coordinates) {
    if (c.name == name) return c.joint.empty();
  }
  return false;
}

void ApplyJointTags(const tinyxml2::XMLElement& robot, const std::string& source,
                    LimbDescription& d) {
  for (auto* e = robot.FirstChildElement("isowrench:joint"); e;
       e = e->NextSiblingElement("isowrench:joint")) {
    const std::string name = Required(source, *e, "name");
    CoordinateSpec* c = FindMutable(d, name);
    if (!c) {
      // A driven or unknown joint: FindCoordinate names the driver ("set 'knee_rz' instead").
      try {
        FindCoordinate(d, name);
      } catch (const Error& error) {
        Fail(source, *e, error.what());
      }
      continue;
    }
    c->locked = Flag(source, *e, "locked", c->locked);
    if (!c->joint.empty()) continue;  // role and stiffness went onto the joint
    c->role = RoleFromName(source, *e, e->Attribute("role") ? e->Attribute("role") : "", name);
    if (c->role == JointRole::kBase && c->type != JointType::kPrismatic) {
      int declared = 0;
      for (auto* k = robot.FirstChildElement("isowrench:coordinate"); k;
           k = k->NextSiblingElement("isowrench:coordinate")) {
        if (k->Attribute("name", name.c_str())) declared = k->GetLineNum();
      }
      Fail(source, *e,
           "coordinate '" + name + "' (line " + std::to_string(declared) +
               ") is revolute but has role=\"base\": base dofs are the "
               "translations of the skeleton's fixation (type=\"prismatic\"); a rotation held by "
               "a stiffness is role=\"extra\"");
    }
    if (e->Attribute("stiffness")) {
      c->stiffness = Number(source, *e, "stiffness", 0.0);
      CheckStiffnessValue(c->stiffness, Line(source, *e) + ": <isowrench:joint name=\"" + name +
                                            "\"> attribute stiffness");
    }
  }
  try {
    d = NormalizeCoordinates(std::move(d));
  } catch (const Error& e) {
    throw Error(source + ": " + e.what());
  }
}

const CoordinateSpec& PostureCoordinate(const tinyxml2::XMLElement& posture,
                                        const std::string& source, const LimbDescription& d) {
  const std::string name = Required(source, posture, "joint");
  try {
    return FindCoordinate(d, name);
  } catch (const Error& error) {
    Fail(source, posture, error.what());
  }
}

}  // namespace isowrench::urdf_coordinates
