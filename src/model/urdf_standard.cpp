// The standard URDF elements checked before urdfdom reads them, and urdfdom called without any
// logging (see urdf_standard.hpp for why both).

#include "model/urdf_standard.hpp"

// console_bridge comes with urdfdom (urdfdom::urdfdom_model links console_bridge::console_bridge).
#include <console_bridge/console.h>
#include <urdf_parser/urdf_parser.h>

#include <cmath>
#include <locale>
#include <map>
#include <mutex>
#include <sstream>

#include "isowrench/error.hpp"
#include "isowrench/input_checks.hpp"
#include "util/text.hpp"

namespace isowrench::urdf_standard {
namespace {

std::string StandardLine(const std::string& source, const tinyxml2::XMLElement& e) {
  return source + ":" + std::to_string(e.GetLineNum());
}

[[noreturn]] void StandardFail(const std::string& source, const tinyxml2::XMLElement& e,
                               const std::string& what) {
  throw Error(StandardLine(source, e) + ": " + what);
}

/// "joint 'hip_rz': " for an element inside a joint or link, "" otherwise.
std::string Owner(const tinyxml2::XMLElement& e) {
  for (const tinyxml2::XMLNode* n = &e; n; n = n->Parent()) {
    const tinyxml2::XMLElement* p = n->ToElement();
    if (!p || !p->Parent() || !p->Parent()->ToElement()) continue;
    const std::string tag = p->Name();
    const std::string parent = p->Parent()->ToElement()->Name();
    if ((tag == "joint" || tag == "link") && parent == "robot") {
      const char* name = p->Attribute("name");
      return tag + " '" + (name ? name : "") + "': ";
    }
  }
  return "";
}

/// Elements at `path` ("link/visual/origin") below `e`, in document order.
void Collect(const tinyxml2::XMLElement& e, const std::vector<std::string>& path, size_t depth,
             std::vector<const tinyxml2::XMLElement*>* out) {
  for (auto* c = e.FirstChildElement(path[depth].c_str()); c;
       c = c->NextSiblingElement(path[depth].c_str())) {
    if (depth + 1 == path.size()) {
      out->push_back(c);
    } else {
      Collect(*c, path, depth + 1, out);
    }
  }
}

std::vector<const tinyxml2::XMLElement*> Elements(const tinyxml2::XMLElement& robot,
                                                  const std::string& path) {
  std::vector<const tinyxml2::XMLElement*> out;
  Collect(robot, util::Split(path, "/"), 0, &out);
  return out;
}

/// Check one attribute as urdfdom reads it. `text` is the attribute's value.
void CheckValue(const std::string& source, const tinyxml2::XMLElement& e,
                const StandardAttribute& a, const std::string& text) {
  const std::string what =
      Owner(e) + "<" + e.Name() + "> attribute " + a.attribute + " = '" + text + "'";
  if (a.numbers == 1) {
    double value = 0;
    if (!ParseUrdfdomNumber(text, &value)) {
      StandardFail(source, e,
                   what +
                       " is not a finite number (a URDF number: digits, '.', an "
                       "exponent, no blanks around it)");
    }
    return;
  }
  // urdf_model/pose.h Vector3::init and color.h Color::init: split on ' ' only, empty pieces
  // skipped, each piece a number.
  std::vector<std::string> pieces;
  size_t start = 0;
  while (start <= text.size()) {
    size_t end = text.find(' ', start);
    if (end == std::string::npos) end = text.size();
    if (end > start) pieces.push_back(text.substr(start, end - start));
    start = end + 1;
  }
  for (const std::string& piece : pieces) {
    double value = 0;
    if (!ParseUrdfdomNumber(piece, &value)) {
      const bool blank = piece.find_first_of("\t\r\n") != std::string::npos;
      StandardFail(source, e,
                   what + ": '" + piece + "' is not a finite number" +
                       (blank ? " (URDF separates the numbers with spaces only)" : ""));
    }
    if (a.numbers == 4 && (value < 0 || value > 1)) {
      StandardFail(source, e, what + ": component " + piece + " is outside [0, 1]");
    }
  }
  if (static_cast<int>(pieces.size()) != a.numbers) {
    StandardFail(source, e,
                 what + " holds " + std::to_string(pieces.size()) + " numbers; it must hold " +
                     std::to_string(a.numbers) + " separated by spaces");
  }
}

[[noreturn]] void Missing(const std::string& source, const tinyxml2::XMLElement& e,
                          const std::string& attribute, const std::string& why = "") {
  StandardFail(source, e,
               Owner(e) + "<" + e.Name() + "> needs the attribute '" + attribute + "'" + why);
}

[[noreturn]] void MissingChild(const std::string& source, const tinyxml2::XMLElement& e,
                               const std::string& child, const std::string& why) {
  StandardFail(source, e, Owner(e) + "<" + e.Name() + "> needs a <" + child + "> element" + why);
}

/// Elements of `tag` directly under <robot> must have distinct name= values.
void CheckUnique(const tinyxml2::XMLElement& robot, const std::string& source, const char* tag) {
  std::map<std::string, const tinyxml2::XMLElement*> seen;
  for (auto* e = robot.FirstChildElement(tag); e; e = e->NextSiblingElement(tag)) {
    const char* name = e->Attribute("name");
    if (!name) continue;
    auto [it, inserted] = seen.emplace(name, e);
    if (!inserted) {
      StandardFail(source, *e,
                   std::string(tag) + " '" + name + "' is defined twice (also at line " +
                       std::to_string(it->second->GetLineNum()) + ")");
    }
  }
}

void CheckVersion(const tinyxml2::XMLElement& robot, const std::string& source) {
  const char* version = robot.Attribute("version");
  if (!version) return;
  // urdf_parser.h URDFVersion: "major.minor" of unsigned integers; only 1.0 is supported.
  const std::string v = version;
  const size_t dot = v.find('.');
  auto digits = [](const std::string& s) {
    return !s.empty() && s.find_first_not_of("0123456789") == std::string::npos;
  };
  if (dot != std::string::npos && digits(v.substr(0, dot)) && digits(v.substr(dot + 1)) &&
      std::stoul(v.substr(0, dot)) == 1 && v.size() - dot - 1 <= 9 &&
      std::stoul(v.substr(dot + 1)) == 0) {
    return;
  }
  StandardFail(source, robot,
               "<robot> attribute version = '" + v +
                   "': only URDF version 1.0 is "
                   "supported (or leave version= out)");
}

std::string DidYouMeanLink(const std::string& name,
                           const std::map<std::string, const tinyxml2::XMLElement*>& links) {
  std::vector<std::string> names;
  for (const auto& l : links) names.push_back(l.first);
  return DidYouMean(name, names);
}

void CheckTree(const tinyxml2::XMLElement& robot, const std::string& source) {
  std::map<std::string, const tinyxml2::XMLElement*> links;
  for (auto* e = robot.FirstChildElement("link"); e; e = e->NextSiblingElement("link")) {
    links.emplace(e->Attribute("name"), e);
  }
  if (links.empty()) StandardFail(source, robot, "the <robot> has no <link> element");
  std::map<std::string, bool> has_parent;
  for (auto* j = robot.FirstChildElement("joint"); j; j = j->NextSiblingElement("joint")) {
    for (const char* end : {"parent", "child"}) {
      const tinyxml2::XMLElement* e = j->FirstChildElement(end);
      if (!e) {
        MissingChild(source, *j, end, " with link= (the joint connects a parent and a child link)");
      }
      const char* link = e->Attribute("link");
      if (!link) Missing(source, *e, "link");
      if (!links.count(link)) {
        StandardFail(source, *e,
                     Owner(*e) + "<" + end + " link='" + link + "'> names no <link> of the file" +
                         DidYouMeanLink(link, links));
      }
      if (std::string(end) == "child") has_parent[link] = true;
    }
  }
  const tinyxml2::XMLElement* root = nullptr;
  for (const auto& [name, e] : links) {
    if (has_parent.count(name)) continue;
    if (root) {
      const tinyxml2::XMLElement* later = root->GetLineNum() < e->GetLineNum() ? e : root;
      const tinyxml2::XMLElement* first = later == e ? root : e;
      StandardFail(source, *later,
                   "links '" + std::string(first->Attribute("name")) + "' (line " +
                       std::to_string(first->GetLineNum()) + ") and '" + later->Attribute("name") +
                       "' are both roots (no joint has them as its child); a URDF is one tree "
                       "with one root link");
    }
    root = e;
  }
}

}  // namespace

const std::vector<StandardAttribute>& StandardAttributes() {
  // urdfdom 3.0.1: pose.cpp (origin), joint.cpp (parseJoint, parseJointLimits, parseJointSafety,
  // parseJointCalibration, parseJointMimic, parseJointDynamics), link.cpp (parseInertial,
  // parseVisual, parseCollision, parseGeometry, parseMaterial), model.cpp (parseURDF).
  static const std::vector<StandardAttribute> kTable = {
      {"joint", "name", 0, true},
      {"joint", "type", 0, true},
      {"joint/origin", "xyz", 3, false},
      {"joint/origin", "rpy", 3, false},
      {"joint/axis", "xyz", 3, false},
      {"joint/limit", "lower", 1, false},
      {"joint/limit", "upper", 1, false},
      {"joint/limit", "effort", 1, true},
      {"joint/limit", "velocity", 1, true},
      {"joint/safety_controller", "soft_lower_limit", 1, false},
      {"joint/safety_controller", "soft_upper_limit", 1, false},
      {"joint/safety_controller", "k_position", 1, false},
      {"joint/safety_controller", "k_velocity", 1, true},
      {"joint/calibration", "rising", 1, false},
      {"joint/calibration", "falling", 1, false},
      {"joint/mimic", "joint", 0, true},
      {"joint/mimic", "multiplier", 1, false},
      {"joint/mimic", "offset", 1, false},
      {"joint/dynamics", "damping", 1, false},
      {"joint/dynamics", "friction", 1, false},
      {"link", "name", 0, true},
      {"link/inertial/origin", "xyz", 3, false},
      {"link/inertial/origin", "rpy", 3, false},
      {"link/inertial/mass", "value", 1, true},
      {"link/inertial/inertia", "ixx", 1, true},
      {"link/inertial/inertia", "ixy", 1, true},
      {"link/inertial/inertia", "ixz", 1, true},
      {"link/inertial/inertia", "iyy", 1, true},
      {"link/inertial/inertia", "iyz", 1, true},
      {"link/inertial/inertia", "izz", 1, true},
      {"link/visual/origin", "xyz", 3, false},
      {"link/visual/origin", "rpy", 3, false},
      {"link/visual/geometry/sphere", "radius", 1, true},
      {"link/visual/geometry/box", "size", 3, true},
      {"link/visual/geometry/cylinder", "length", 1, true},
      {"link/visual/geometry/cylinder", "radius", 1, true},
      {"link/visual/geometry/mesh", "filename", 0, true},
      {"link/visual/geometry/mesh", "scale", 3, false},
      {"link/visual/material", "name", 0, true},
      {"link/visual/material/color", "rgba", 4, false},
      {"link/collision/origin", "xyz", 3, false},
      {"link/collision/origin", "rpy", 3, false},
      {"link/collision/geometry/sphere", "radius", 1, true},
      {"link/collision/geometry/box", "size", 3, true},
      {"link/collision/geometry/cylinder", "length", 1, true},
      {"link/collision/geometry/cylinder", "radius", 1, true},
      {"link/collision/geometry/mesh", "filename", 0, true},
      {"link/collision/geometry/mesh", "scale", 3, false},
      {"material", "name", 0, true},
      {"material/color", "rgba", 4, false},
  };
  return kTable;
}

bool ParseUrdfdomNumber(const std::string& text, double* value) {
  // urdf_model/utils.h strToDouble, then finiteness (std::isfinite) on top.
  std::istringstream in(text);
  in.imbue(std::locale::classic());
  double v = 0;
  in >> v;
  if (in.fail() || !in.eof() || !std::isfinite(v)) return false;
  // Also a number for isowrench's own parser (std::from_chars), which reads it again for the
  // URDF's joint limits: the two must agree on what is a number.
  double again = 0;
  if (!util::ParseDouble(text, &again)) return false;
  *value = v;
  return true;
}

void CheckStandardElements(const tinyxml2::XMLElement& robot, const std::string& source) {
  if (!robot.Attribute("name")) Missing(source, robot, "name", " (the robot's name)");
  CheckVersion(robot, source);
  // Every attribute of the table, element by element in table order.
  for (const StandardAttribute& a : StandardAttributes()) {
    for (const tinyxml2::XMLElement* e : Elements(robot, a.element)) {
      const char* text = e->Attribute(a.attribute);
      if (!text) {
        if (a.required) Missing(source, *e, a.attribute);
        continue;
      }
      if (a.numbers > 0) CheckValue(source, *e, a, text);
    }
  }
  // Elements urdfdom requires.
  for (auto* j = robot.FirstChildElement("joint"); j; j = j->NextSiblingElement("joint")) {
    const std::string type = j->Attribute("type");
    if ((type == "revolute" || type == "prismatic") && !j->FirstChildElement("limit")) {
      MissingChild(source, *j, "limit",
                   " (a " + type +
                       " joint needs <limit lower= upper= effort= velocity=/>; "
                       "effort and velocity are not used by isowrench, any number will do)");
    }
    for (auto* d = j->FirstChildElement("dynamics"); d; d = d->NextSiblingElement("dynamics")) {
      if (!d->Attribute("damping") && !d->Attribute("friction")) {
        Missing(source, *d, "damping' or 'friction");
      }
    }
  }
  for (auto* i : Elements(robot, "link/inertial")) {
    if (!i->FirstChildElement("mass")) MissingChild(source, *i, "mass", " with value= (kg)");
    if (!i->FirstChildElement("inertia")) {
      MissingChild(source, *i, "inertia", " with ixx= ixy= ixz= iyy= iyz= izz= (kg·m²)");
    }
  }
  for (const char* path : {"link/visual", "link/collision"}) {
    for (auto* v : Elements(robot, path)) {
      const tinyxml2::XMLElement* g = v->FirstChildElement("geometry");
      if (!g) MissingChild(source, *v, "geometry", "");
      const tinyxml2::XMLElement* shape = g->FirstChildElement();
      const std::string kind = shape ? shape->Name() : "";
      if (kind != "sphere" && kind != "box" && kind != "cylinder" && kind != "mesh") {
        StandardFail(source, shape ? *shape : *g,
                     Owner(*g) + "<geometry> needs one of <sphere>, <box>, <cylinder>, <mesh>" +
                         (kind.empty() ? std::string() : ", not <" + kind + ">"));
      }
    }
  }
  CheckUnique(robot, source, "link");
  CheckUnique(robot, source, "joint");
  CheckUnique(robot, source, "material");
  CheckTree(robot, source);
}

urdf::ModelInterfaceSharedPtr ParseQuietly(const std::string& xml) {
  static std::mutex mutex;
  std::lock_guard<std::mutex> lock(mutex);
  const console_bridge::LogLevel previous = console_bridge::getLogLevel();
  console_bridge::setLogLevel(console_bridge::CONSOLE_BRIDGE_LOG_NONE);
  urdf::ModelInterfaceSharedPtr model;
  try {
    model = urdf::parseURDF(xml);
  } catch (...) {
    console_bridge::setLogLevel(previous);
    throw;
  }
  console_bridge::setLogLevel(previous);
  return model;
}

}  // namespace isowrench::urdf_standard
