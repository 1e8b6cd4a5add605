// URDF (+ isowrench extension tags) -> LimbDescription.
//
// urdfdom only logs why it rejects a file and returns null, so the XML is parsed with tinyxml2
// first (file:line messages, joint types we refuse, our extension tags), then handed to urdfdom
// for the standard robot model. Numbers are parsed with std::from_chars (locale independent).

#include <tinyxml2.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "isowrench/error.hpp"
#include "isowrench/input_checks.hpp"
#include "isowrench/model.hpp"
#include "isowrench/muscle.hpp"
#include "isowrench/wrap.hpp"
#include "model/function_xml.hpp"
#include "model/urdf_checks.hpp"
#include "model/urdf_coordinates.hpp"
#include "model/urdf_standard.hpp"
#include "util/text.hpp"

namespace isowrench {
namespace {

constexpr const char* kPrefix = "isowrench:";

struct Reader {
  std::string source;  // file name used in messages

  std::string Where(const tinyxml2::XMLElement* e) const {
    return source + ":" + std::to_string(e->GetLineNum());
  }

  [[noreturn]] void Fail(const tinyxml2::XMLElement* e, const std::string& what) const {
    throw Error(Where(e) + ": " + what);
  }

  std::string Attribute(const tinyxml2::XMLElement* e, const char* name, bool required) const {
    const char* value = e->Attribute(name);
    if (!value) {
      if (required) {
        Fail(e, std::string("<") + e->Name() + "> needs the attribute '" + name + "'");
      }
      return "";
    }
    return value;
  }

  double Number(const tinyxml2::XMLElement* e, const char* name, const std::string& text) const {
    double value = 0.0;
    if (!util::ParseDouble(text, &value)) {
      Fail(e, std::string("attribute '") + name + "' = '" + text + "' is not a number");
    }
    if (!std::isfinite(value)) {
      Fail(e, std::string("attribute '") + name + "' = '" + text + "' is not finite");
    }
    return value;
  }

  std::vector<double> Numbers(const tinyxml2::XMLElement* e, const char* name, size_t count,
                              bool required) const {
    std::string text = Attribute(e, name, required);
    if (text.empty() && !required) return {};
    std::vector<double> values;
    for (const std::string& piece : util::Split(text, " \t\n,")) {
      values.push_back(Number(e, name, piece));
    }
    if (values.size() != count) {
      Fail(e, std::string("attribute '") + name + "' = '" + text + "' must hold " +
                  std::to_string(count) + " numbers");
    }
    return values;
  }

  Eigen::Vector3d Vector3(const tinyxml2::XMLElement* e, const char* name) const {
    std::vector<double> v = Numbers(e, name, 3, false);
    if (v.empty()) return Eigen::Vector3d::Zero();
    return Eigen::Vector3d(v[0], v[1], v[2]);
  }
};

Eigen::Matrix3d RotationFromRpy(const Eigen::Vector3d& rpy) {
  return (Eigen::AngleAxisd(rpy.z(), Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(rpy.y(), Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(rpy.x(), Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

Eigen::Isometry3d ToIsometry(const urdf::Pose& pose) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translation() = Eigen::Vector3d(pose.position.x, pose.position.y, pose.position.z);
  t.linear() =
      Eigen::Quaterniond(pose.rotation.w, pose.rotation.x, pose.rotation.y, pose.rotation.z)
          .normalized()
          .toRotationMatrix();
  return t;
}

// The coordinate a moving component or a conditional point names: an independent coordinate.
const CoordinateSpec& PointCoordinate(const Reader& r, const tinyxml2::XMLElement& e,
                                      const LimbDescription& d, const std::string& what,
                                      const std::string& name) {
  try {
    return FindCoordinate(d, name);
  } catch (const Error& error) {
    r.Fail(&e, what + ": " + error.what());
  }
}

// <isowrench:moving axis= coordinate=> FUNCTION </isowrench:moving> children of a point, and
// its active_coordinate= / active_range= attributes (docs/urdf-extensions.md, Muscles).
void ReadMovingAndActive(const Reader& r, const tinyxml2::XMLElement& p, const LimbDescription& d,
                         const std::string& muscle, PathPoint& point) {
  const std::string what = "muscle '" + muscle + "', point on '" + point.link + "'";
  for (auto* c = p.FirstChildElement(); c; c = c->NextSiblingElement()) {
    if (std::string(c->Name()) != "isowrench:moving") {
      r.Fail(c, what + ": unexpected <" + c->Name() + ">; expected <isowrench:moving>");
    }
    MovingComponent component;
    const std::string axis = r.Attribute(c, "axis", true);
    if (axis != "x" && axis != "y" && axis != "z") {
      r.Fail(c, what + ": moving axis '" + axis + "' is not one of x, y, z");
    }
    component.axis = axis[0] - 'x';
    for (const MovingComponent& other : point.moving) {
      if (other.axis == component.axis) {
        r.Fail(c, what + ": axis '" + axis + "' has two <isowrench:moving> elements");
      }
    }
    component.coordinate = PointCoordinate(r, *c, d, what + ", moving axis " + axis,
                                           r.Attribute(c, "coordinate", true))
                               .name;
    component.function = ParseFunctionChild(*c, r.source);
    point.moving.push_back(component);
  }
  const std::string coordinate = r.Attribute(&p, "active_coordinate", false);
  const std::string range = r.Attribute(&p, "active_range", false);
  if (coordinate.empty() != range.empty()) {
    r.Fail(&p,
           what + ": give both active_coordinate= and active_range=\"lower upper\", or neither");
  }
  if (coordinate.empty()) return;
  point.active_coordinate = PointCoordinate(r, p, d, what + ", active_coordinate", coordinate).name;
  const std::vector<double> bounds = r.Numbers(&p, "active_range", 2, true);
  if (bounds[0] > bounds[1]) {
    r.Fail(&p, what + ": active_range lower " + util::FormatNumber(bounds[0]) + " > upper " +
                   util::FormatNumber(bounds[1]));
  }
  point.active_lower = bounds[0];
  point.active_upper = bounds[1];
}

// ---- wrapping (issue 27; docs/urdf-extensions.md "Wrap objects") ----------------------------

// <isowrench:path_wrap object= range= method=/> inside a muscle.
PathWrapSpec ReadPathWrap(const Reader& r, const tinyxml2::XMLElement& e,
                          const std::string& muscle) {
  PathWrapSpec w;
  w.object = r.Attribute(&e, "object", true);
  const std::string what = "muscle '" + muscle + "', path_wrap '" + w.object + "'";
  const std::vector<double> range = r.Numbers(&e, "range", 2, false);
  if (!range.empty()) {
    for (int i = 0; i < 2; ++i) {
      if (range[i] != std::floor(range[i]) || std::abs(range[i]) > 1e6) {
        r.Fail(&e, what + ": range '" + r.Attribute(&e, "range", true) +
                       "' must hold two whole numbers (1-based point numbers, -1 = first/last)");
      }
    }
    w.range_first = static_cast<int>(range[0]);
    w.range_last = static_cast<int>(range[1]);
  }
  const std::string method = r.Attribute(&e, "method", false);
  if (method.empty() || method == "hybrid") {
    w.method = WrapMethod::kHybrid;
  } else if (method == "midpoint") {
    w.method = WrapMethod::kMidpoint;
  } else if (method == "axial") {
    w.method = WrapMethod::kAxial;
  } else {
    r.Fail(&e, what + ": method '" + method + "' is not one of hybrid, midpoint, axial");
  }
  return w;
}

// <isowrench:wrap name= link= shape= .../> objects.
template <class CheckLink>
void ReadWrapObjects(const Reader& r, const tinyxml2::XMLElement& robot, LimbDescription& d,
                     const CheckLink& check_link) {
  for (auto* e = robot.FirstChildElement("isowrench:wrap"); e;
       e = e->NextSiblingElement("isowrench:wrap")) {
    WrapObjectSpec w;
    w.name = r.Attribute(e, "name", true);
    for (const WrapObjectSpec& other : d.wrap_objects) {
      if (other.name == w.name) r.Fail(e, "wrap object '" + w.name + "' is defined twice");
    }
    w.link = r.Attribute(e, "link", true);
    if (w.link != d.root_link) check_link(e, w.link);
    const std::string shape = r.Attribute(e, "shape", true);
    const std::string what = "wrap object '" + w.name + "' (" + shape + ")";
    auto positive = [&](const char* name) {
      const double v = r.Number(e, name, r.Attribute(e, name, true));
      if (!(v > 0)) r.Fail(e, what + ": " + name + " " + util::FormatNumber(v) + " m must be > 0");
      return v;
    };
    auto forbid = [&](std::initializer_list<const char*> names) {
      for (const char* name : names) {
        if (e->Attribute(name)) r.Fail(e, what + ": a " + shape + " has no '" + name + "'");
      }
    };
    if (shape == "cylinder") {
      w.shape = WrapShape::kCylinder;
      w.radius = positive("radius");
      w.length = positive("length");
      forbid({"radii", "inner_radius", "outer_radius"});
    } else if (shape == "sphere") {
      w.shape = WrapShape::kSphere;
      w.radius = positive("radius");
      forbid({"length", "radii", "inner_radius", "outer_radius"});
    } else if (shape == "ellipsoid") {
      w.shape = WrapShape::kEllipsoid;
      const std::vector<double> radii = r.Numbers(e, "radii", 3, true);
      for (int i = 0; i < 3; ++i) {
        if (!(radii[i] > 0)) {
          r.Fail(e, what + ": radii '" + r.Attribute(e, "radii", true) + "' must all be > 0");
        }
      }
      w.radii = Eigen::Vector3d(radii[0], radii[1], radii[2]);
      forbid({"radius", "length", "inner_radius", "outer_radius"});
    } else if (shape == "torus") {
      w.shape = WrapShape::kTorus;
      w.inner_radius = positive("inner_radius");
      w.outer_radius = positive("outer_radius");
      if (!(w.inner_radius < w.outer_radius)) {
        r.Fail(e, what + ": inner_radius " + util::FormatNumber(w.inner_radius) +
                      " m must be below outer_radius " + util::FormatNumber(w.outer_radius) + " m");
      }
      forbid({"radius", "length", "radii"});
    } else if (shape == "cylinder_obst" || shape == "double_cylinder_obst") {
      r.Fail(e, what +
                    ": OpenSim's WrapCylinderObst and WrapDoubleCylinderObst are not "
                    "supported yet");
    } else {
      r.Fail(e, what + ": shape '" + shape + "' is not one of cylinder, sphere, ellipsoid, torus");
    }
    w.translation = r.Vector3(e, "translation");
    w.xyz_body_rotation = r.Vector3(e, "xyz_body_rotation");
    const std::string active = r.Attribute(e, "active", false);
    if (active == "false" || active == "0") {
      w.active = false;
    } else if (!active.empty() && active != "true" && active != "1") {
      r.Fail(e, what + ": active='" + active + "' must be true or false");
    }
    const std::string quadrant = r.Attribute(e, "quadrant", false);
    if (!quadrant.empty()) {
      try {
        w.quadrant = WrapQuadrant::Parse(quadrant);
      } catch (const Error& error) {
        r.Fail(e, what + ": " + error.what());
      }
    }
    d.wrap_objects.push_back(w);
  }
}

// Every path_wrap names a wrap object, with a range inside its muscle's path.
void CheckPathWraps(const Reader& r, const LimbDescription& d,
                    const std::vector<std::pair<std::string, const tinyxml2::XMLElement*>>& wraps) {
  std::vector<std::string> names;
  for (const WrapObjectSpec& w : d.wrap_objects) names.push_back(w.name);
  size_t next = 0;
  for (const MuscleSpec& m : d.muscles) {
    for (const PathWrapSpec& w : m.wraps) {
      const tinyxml2::XMLElement* e = wraps.at(next++).second;
      const std::string what = "muscle '" + m.name + "', path_wrap '" + w.object + "'";
      if (std::find(names.begin(), names.end(), w.object) == names.end()) {
        r.Fail(e, what + ": no <isowrench:wrap> is called '" + w.object + "'" +
                      DidYouMean(w.object, names));
      }
      const int n = static_cast<int>(m.path.size());
      auto valid = [&](int i) { return i == -1 || (i >= 1 && i <= n); };
      if (!valid(w.range_first) || !valid(w.range_last) ||
          (w.range_first != -1 && w.range_last != -1 && w.range_first > w.range_last)) {
        r.Fail(e, what + ": range " + std::to_string(w.range_first) + " " +
                      std::to_string(w.range_last) + " is outside the muscle's " +
                      std::to_string(n) +
                      " points (1-based, -1 = the first/last point, first <= last)");
      }
    }
  }
}

// The force model of <isowrench:muscle> (docs/urdf-extensions.md "Muscle force models"): the
// attributes model= and the OpenSim properties, and the curve children. Attribute names are
// OpenSim's property names; lengths in m, angles in rad.
bool IsMuscleForceChild(const std::string& tag) {
  return tag == "isowrench:active_force_length" || tag == "isowrench:fiber_force_length" ||
         tag == "isowrench:tendon_force_length" || tag == "isowrench:thelen2003_curves";
}

void ReadMuscleForce(const Reader& r, const tinyxml2::XMLElement& e, MuscleSpec& m) {
  const std::string what = "muscle '" + m.name + "'";
  MuscleForceSpec& f = m.force;
  const std::string model = r.Attribute(&e, "model", false);
  if (!model.empty()) {
    try {
      f.model = ParseForceModel(model);
    } catch (const Error& error) {
      r.Fail(&e, what + ": " + error.what());
    }
  }
  static const char* const kForceAttributes[] = {"optimal_fiber_length",
                                                 "tendon_slack_length",
                                                 "pennation_angle_at_optimal",
                                                 "maximum_pennation_angle",
                                                 "minimum_activation",
                                                 "ignore_tendon_compliance",
                                                 "fiber_damping"};
  auto number = [&](const tinyxml2::XMLElement& el, const char* name, double* out, bool required) {
    const std::string text = r.Attribute(&el, name, required);
    if (!text.empty()) *out = r.Number(&el, name, text);
  };
  auto optional = [&](const tinyxml2::XMLElement& el, const char* name,
                      std::optional<double>* out) {
    const std::string text = r.Attribute(&el, name, false);
    if (!text.empty()) *out = r.Number(&el, name, text);
  };
  if (f.model == ForceModelType::kConstant) {
    for (const char* name : kForceAttributes) {
      if (e.Attribute(name)) {
        r.Fail(&e, what + ": attribute '" + name +
                       "' needs model=\"thelen2003\" or model=\"millard2012\" (this muscle's "
                       "force model is constant: F = activation * max_force)");
      }
    }
  } else {
    number(e, "optimal_fiber_length", &f.optimal_fiber_length, true);
    number(e, "tendon_slack_length", &f.tendon_slack_length, true);
    number(e, "pennation_angle_at_optimal", &f.pennation_angle_at_optimal, false);
    number(e, "maximum_pennation_angle", &f.maximum_pennation_angle, false);
    number(e, "minimum_activation", &f.minimum_activation, false);
    const std::string rigid = r.Attribute(&e, "ignore_tendon_compliance", false);
    if (!rigid.empty()) {
      if (rigid != "true" && rigid != "false") {
        r.Fail(&e, what + ": ignore_tendon_compliance '" + rigid + "' must be true or false");
      }
      f.ignore_tendon_compliance = rigid == "true";
    }
    if (e.Attribute("fiber_damping") && f.model != ForceModelType::kMillard2012) {
      r.Fail(&e, what + ": fiber_damping is a millard2012 property");
    }
    number(e, "fiber_damping", &f.fiber_damping, false);
  }
  std::set<std::string> seen;
  for (auto* c = e.FirstChildElement(); c; c = c->NextSiblingElement()) {
    const std::string tag = c->Name();
    if (!IsMuscleForceChild(tag)) continue;
    if (!seen.insert(tag).second) r.Fail(c, what + ": a second <" + tag + ">");
    const bool thelen_tag = tag == "isowrench:thelen2003_curves";
    const ForceModelType wanted =
        thelen_tag ? ForceModelType::kThelen2003 : ForceModelType::kMillard2012;
    if (f.model != wanted) {
      r.Fail(c, what + ": <" + tag + "> belongs to model=\"" + ForceModelName(wanted) +
                    "\", not \"" + ForceModelName(f.model) + "\"");
    }
    if (tag == "isowrench:active_force_length") {
      ActiveForceLengthCurveSpec& a = f.active_force_length;
      number(*c, "min_norm_active_fiber_length", &a.min_norm_active_fiber_length, false);
      number(*c, "transition_norm_fiber_length", &a.transition_norm_fiber_length, false);
      number(*c, "max_norm_active_fiber_length", &a.max_norm_active_fiber_length, false);
      number(*c, "shallow_ascending_slope", &a.shallow_ascending_slope, false);
      number(*c, "minimum_value", &a.minimum_value, false);
    } else if (tag == "isowrench:fiber_force_length") {
      FiberForceLengthCurveSpec& p = f.fiber_force_length;
      number(*c, "strain_at_zero_force", &p.strain_at_zero_force, false);
      number(*c, "strain_at_one_norm_force", &p.strain_at_one_norm_force, false);
      optional(*c, "stiffness_at_low_force", &p.stiffness_at_low_force);
      optional(*c, "stiffness_at_one_norm_force", &p.stiffness_at_one_norm_force);
      optional(*c, "curviness", &p.curviness);
    } else if (tag == "isowrench:tendon_force_length") {
      TendonForceLengthCurveSpec& t = f.tendon_force_length;
      number(*c, "strain_at_one_norm_force", &t.strain_at_one_norm_force, false);
      optional(*c, "stiffness_at_one_norm_force", &t.stiffness_at_one_norm_force);
      optional(*c, "norm_force_at_toe_end", &t.norm_force_at_toe_end);
      optional(*c, "curviness", &t.curviness);
    } else {
      Thelen2003CurveSpec& t = f.thelen;
      number(*c, "FmaxTendonStrain", &t.FmaxTendonStrain, false);
      number(*c, "FmaxMuscleStrain", &t.FmaxMuscleStrain, false);
      number(*c, "KshapeActive", &t.KshapeActive, false);
      number(*c, "KshapePassive", &t.KshapePassive, false);
    }
  }
  try {
    static_cast<void>(MuscleForceModel(m.name, m.max_force, f));  // OpenSim's parameter checks
  } catch (const Error& error) {
    r.Fail(&e, error.what());
  }
}

// isowrench: attributes of <robot> (docs/urdf-extensions.md "Wrap mode"): isowrench:wrap_mode.
void ReadRobotAttributes(const Reader& r, const tinyxml2::XMLElement& robot, LimbDescription& d) {
  static const std::vector<std::string> kKnown = {"isowrench:wrap_mode"};
  for (const tinyxml2::XMLAttribute* a = robot.FirstAttribute(); a; a = a->Next()) {
    const std::string name = a->Name();
    if (name.rfind(kPrefix, 0) != 0 ||
        std::find(kKnown.begin(), kKnown.end(), name) != kKnown.end()) {
      continue;
    }
    r.Fail(&robot, "<robot> has no attribute '" + name + "'" + DidYouMean(name, kKnown) +
                       "; its isowrench attribute is isowrench:wrap_mode");
  }
  if (const char* mode = robot.Attribute("isowrench:wrap_mode")) {
    const std::string text = mode;
    if (text != WrapModeName(WrapMode::kOpenSim) && text != WrapModeName(WrapMode::kExact)) {
      r.Fail(&robot, "<robot> isowrench:wrap_mode = '" + text +
                         "' is not one of opensim, exact (how wrapped muscle paths are computed)");
    }
    d.wrap_mode = ParseWrapMode(text);
  }
}

int DofIndex(const std::string& name) {
  for (int i = 0; i < 6; ++i) {
    if (name == DofName(i)) return i;
  }
  return -1;
}

}  // namespace

LimbDescription ReadUrdfFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("cannot open URDF file '" + path + "'");
  std::stringstream buffer;
  buffer << in.rdbuf();
  return ReadUrdfString(buffer.str(), path);
}

LimbDescription ReadUrdfString(const std::string& xml, const std::string& source_name) {
  Reader r{source_name.empty() ? std::string("<string>") : source_name};
  tinyxml2::XMLDocument doc;
  if (doc.Parse(xml.c_str(), xml.size()) != tinyxml2::XML_SUCCESS) {
    throw Error(r.source + ":" + std::to_string(doc.ErrorLineNum()) + ": malformed XML (" +
                tinyxml2::XMLDocument::ErrorIDToName(doc.ErrorID()) + ")");
  }
  const tinyxml2::XMLElement* robot = doc.FirstChildElement("robot");
  if (!robot) throw Error(r.source + ": no <robot> element: not a URDF file");
  // Before anything walks the joints: urdfdom and the chain walk below loop forever on a
  // joint loop, so the tree structure is checked first; then every isowrench: attribute.
  urdf_checks::CheckJointTree(*robot, r.source);
  // Everything urdfdom would reject (it only logs why, and some of its messages use the file's
  // text as a printf format: urdf_standard.hpp), then every isowrench: attribute.
  urdf_standard::CheckStandardElements(*robot, r.source);
  urdf_checks::CheckDeclarations(*robot, r.source);
  urdf_checks::CheckExtensionAttributes(*robot, r.source);

  // Pass 1 (tinyxml2): joint types we refuse, line numbers for messages.
  std::map<std::string, const tinyxml2::XMLElement*> joint_elements;
  std::map<std::string, const tinyxml2::XMLElement*> link_elements;
  for (auto* e = robot->FirstChildElement("joint"); e; e = e->NextSiblingElement("joint")) {
    std::string name = r.Attribute(e, "name", true);
    std::string type = r.Attribute(e, "type", true);
    if (type == "floating" || type == "planar") {
      r.Fail(e, "joint '" + name + "' has type '" + type +
                    "', which isowrench cannot represent; model it as revolute/prismatic "
                    "joints (one per dof) joined by massless links");
    }
    if (type != "revolute" && type != "continuous" && type != "prismatic" && type != "fixed") {
      r.Fail(e, "joint '" + name + "' has unknown type '" + type + "'");
    }
    if (joint_elements.count(name)) r.Fail(e, "joint '" + name + "' is defined twice");
    joint_elements[name] = e;
  }
  for (auto* e = robot->FirstChildElement("link"); e; e = e->NextSiblingElement("link")) {
    link_elements[r.Attribute(e, "name", true)] = e;
  }

  // Pass 2 (urdfdom, silenced): the standard robot model.
  urdf::ModelInterfaceSharedPtr urdf_model = urdf_standard::ParseQuietly(xml);
  if (!urdf_model) {
    throw Error(r.source +
                ": urdfdom rejected the robot description although isowrench's checks of it "
                "passed (its XML parser, TinyXML 1, may read this file differently); please "
                "report it with the file");
  }
  urdf::LinkConstSharedPtr root = urdf_model->getRoot();
  if (!root) throw Error(r.source + ": the URDF has no root link");

  LimbDescription d;
  d.name = urdf_model->getName();
  d.source = source_name;
  d.root_link = root->name;
  ReadRobotAttributes(r, *robot, d);

  // Extension tags.
  const tinyxml2::XMLElement* transducer = nullptr;
  for (auto* e = robot->FirstChildElement(); e; e = e->NextSiblingElement()) {
    std::string tag = e->Name();
    if (tag.rfind(kPrefix, 0) != 0) continue;
    std::string local = tag.substr(std::string(kPrefix).size());
    if (local == "transducer") {
      if (transducer) r.Fail(e, "a second <isowrench:transducer>; a limb has one");
      transducer = e;
    } else if (local != "joint" && local != "muscle" && local != "posture" &&
               local != "coordinate" && local != "coupling" && local != "wrap") {
      r.Fail(e, "unknown extension element <" + tag +
                    ">; known: isowrench:joint, isowrench:transducer, isowrench:muscle, "
                    "isowrench:posture, isowrench:coordinate, isowrench:coupling, "
                    "isowrench:wrap");
    }
  }
  if (!transducer) {
    throw Error(r.source +
                ": no <isowrench:transducer link=\"...\" xyz=\"...\"/> element: "
                "isowrench needs to know where the endpoint is");
  }

  // Chain from the root to the endpoint link.
  std::string endpoint_link = r.Attribute(transducer, "link", true);
  urdf::LinkConstSharedPtr link = urdf_model->getLink(endpoint_link);
  if (!link)
    r.Fail(transducer, "transducer link '" + endpoint_link + "' is not a link of the URDF");
  std::vector<urdf::JointConstSharedPtr> chain;
  while (link && link->parent_joint) {
    chain.push_back(link->parent_joint);
    link = urdf_model->getLink(link->parent_joint->parent_link_name);
  }
  std::reverse(chain.begin(), chain.end());
  d.links.push_back(d.root_link);
  for (const auto& j : chain) {
    JointSpec spec;
    spec.name = j->name;
    spec.parent_link = j->parent_link_name;
    spec.child_link = j->child_link_name;
    spec.origin = ToIsometry(j->parent_to_joint_origin_transform);
    Eigen::Vector3d axis(j->axis.x, j->axis.y, j->axis.z);
    switch (j->type) {
      case urdf::Joint::REVOLUTE:
      case urdf::Joint::CONTINUOUS: spec.type = JointType::kRevolute; break;
      case urdf::Joint::PRISMATIC: spec.type = JointType::kPrismatic; break;
      case urdf::Joint::FIXED: spec.type = JointType::kFixed; break;
      default:
        r.Fail(joint_elements.at(j->name), "joint '" + j->name + "' has an unsupported type");
    }
    if (spec.type != JointType::kFixed) {
      if (!(axis.norm() > 1e-12) || !axis.allFinite()) {
        r.Fail(joint_elements.at(j->name), "joint '" + j->name + "' has a zero or invalid axis");
      }
      spec.axis = axis.normalized();
    }
    d.joints.push_back(spec);
    d.links.push_back(spec.child_link);
  }

  auto find_joint = [&](const tinyxml2::XMLElement* e, const std::string& name) -> JointSpec& {
    for (JointSpec& j : d.joints) {
      if (j.name == name) {
        if (j.type == JointType::kFixed) r.Fail(e, "joint '" + name + "' is fixed; it has no dof");
        return j;
      }
    }
    if (joint_elements.count(name)) {
      r.Fail(e, "joint '" + name + "' is not on the chain from '" + d.root_link +
                    "' to the "
                    "endpoint link '" +
                    endpoint_link + "'");
    }
    std::vector<std::string> movable;
    for (const JointSpec& j : d.joints) {
      if (j.type != JointType::kFixed) movable.push_back(j.name);
    }
    r.Fail(e, "unknown joint '" + name + "'" + DidYouMean(name, movable) +
                  "; the movable joints are " + util::Join(movable, ", "));
  };
  auto check_link = [&](const tinyxml2::XMLElement* e, const std::string& name) {
    if (std::find(d.links.begin(), d.links.end(), name) != d.links.end()) return;
    if (link_elements.count(name)) {
      r.Fail(e, "link '" + name + "' is not on the chain from '" + d.root_link +
                    "' to the endpoint link '" + endpoint_link + "'");
    }
    r.Fail(e, "unknown link '" + name + "'");
  };

  // Transducer.
  TransducerSpec& t = d.transducer;
  t.link = endpoint_link;
  t.endpoint = r.Vector3(transducer, "xyz");
  const Eigen::Vector3d transducer_rpy = r.Vector3(transducer, "rpy");
  t.rotation = RotationFromRpy(transducer_rpy);
  std::string axes = r.Attribute(transducer, "axes", false);
  if (axes.empty() || axes == "world") {
    t.axes_in_world = true;
  } else if (axes == "link") {
    t.axes_in_world = false;
  } else {
    r.Fail(transducer, "axes='" + axes + "' must be 'world' or 'link'");
  }
  std::string preset = r.Attribute(transducer, "preset", false);
  std::vector<double> stiffness = r.Numbers(transducer, "stiffness", 6, false);
  if (!preset.empty() && !stiffness.empty()) {
    r.Fail(transducer, "give either preset= or stiffness=, not both");
  }
  if (!preset.empty()) {
    try {
      t.stiffness = TransducerPreset(preset);
    } catch (const Error& e) {
      r.Fail(transducer, e.what());
    }
  } else if (!stiffness.empty()) {
    for (int i = 0; i < 6; ++i) {
      if (stiffness[i] < 0) {
        r.Fail(transducer, "transducer stiffness " + std::string(DofName(i)) + " = " +
                               util::FormatNumber(stiffness[i]) + " is negative");
      }
      CheckStiffnessValue(
          stiffness[i],
          r.Where(transducer) + ": <isowrench:transducer> attribute stiffness, " + DofName(i));
      t.stiffness[i] = stiffness[i];
    }
  }
  for (const std::string& dof : util::Split(r.Attribute(transducer, "released", false), " ,")) {
    int index = DofIndex(dof);
    if (index < 0) r.Fail(transducer, "released dof '" + dof + "' is not one of x y z rx ry rz");
    t.released.set(index);
  }

  std::vector<std::pair<std::string, const tinyxml2::XMLElement*>> path_wrap_elements;
  // Coordinates, mimics and couplings first: postures and joint tags name coordinates.
  urdf_coordinates::ReadCoordinates(*robot, r.source, d);
  for (auto* e = robot->FirstChildElement(); e; e = e->NextSiblingElement()) {
    std::string tag = e->Name();
    if (tag == "isowrench:joint" && !urdf_coordinates::NamesFreeCoordinate(*e, d)) {
      JointSpec& j = find_joint(e, r.Attribute(e, "name", true));
      std::string role = r.Attribute(e, "role", false);
      if (role.empty() || role == "limb") {
        j.role = JointRole::kLimb;
      } else if (role == "base") {
        if (j.type != JointType::kPrismatic) {
          r.Fail(e, "joint '" + j.name + "' (line " +
                        std::to_string(joint_elements.at(j.name)->GetLineNum()) +
                        ") is revolute but has role=\"base\": base dofs are the translations of "
                        "the skeleton's fixation, prismatic joints (docs/urdf-extensions.md); a "
                        "rotation held by a stiffness is role=\"extra\"");
        }
        j.role = JointRole::kBase;
      } else if (role == "extra") {
        j.role = JointRole::kExtra;
      } else if (role == "release") {
        j.role = JointRole::kRelease;
      } else {
        r.Fail(e, "joint '" + j.name + "': role '" + role +
                      "' is not one of limb, base, extra, release");
      }
      std::string s = r.Attribute(e, "stiffness", false);
      if (!s.empty()) {
        if (!util::ParseDouble(s, &j.stiffness) || !std::isfinite(j.stiffness)) {
          r.Fail(e, "joint '" + j.name + "': stiffness '" + s + "' is not a finite number");
        }
        if (j.stiffness < 0) {
          r.Fail(e, "joint '" + j.name + "': stiffness " + s + " is negative");
        }
        CheckStiffnessValue(j.stiffness, r.Where(e) + ": <isowrench:joint name=\"" + j.name +
                                             "\"> attribute stiffness");
      }
    } else if (tag == "isowrench:muscle") {
      MuscleSpec m;
      m.name = r.Attribute(e, "name", true);
      for (const MuscleSpec& other : d.muscles) {
        if (other.name == m.name) r.Fail(e, "muscle '" + m.name + "' is defined twice");
      }
      std::string f = r.Attribute(e, "max_force", true);
      m.max_force = r.Number(e, "max_force", f);
      if (!(m.max_force > 0)) r.Fail(e, "muscle '" + m.name + "': max_force " + f + " must be > 0");
      ReadMuscleForce(r, *e, m);
      for (auto* p = e->FirstChildElement(); p; p = p->NextSiblingElement()) {
        if (IsMuscleForceChild(p->Name())) continue;
        if (std::string(p->Name()) == "isowrench:path_wrap") {
          m.wraps.push_back(ReadPathWrap(r, *p, m.name));
          path_wrap_elements.push_back({m.name, p});
          continue;
        }
        if (std::string(p->Name()) != "isowrench:point") {
          r.Fail(p, std::string("unexpected <") + p->Name() + "> in muscle '" + m.name +
                        "'; expected <isowrench:point>, <isowrench:path_wrap> or a force-model "
                        "curve element");
        }
        if (!m.wraps.empty()) {
          r.Fail(p, "muscle '" + m.name +
                        "': <isowrench:point> after <isowrench:path_wrap>; "
                        "list the points first, then the wraps");
        }
        PathPoint point;
        point.link = r.Attribute(p, "link", true);
        check_link(p, point.link);
        point.position = r.Vector3(p, "xyz");
        ReadMovingAndActive(r, *p, d, m.name, point);
        m.path.push_back(point);
      }
      if (m.path.size() < 2) {
        r.Fail(e, "muscle '" + m.name + "' needs at least two <isowrench:point> elements");
      }
      if (std::count_if(m.path.begin(), m.path.end(),
                        [](const PathPoint& p) { return p.active_coordinate.empty(); }) < 2) {
        r.Fail(e, "muscle '" + m.name +
                      "' needs at least two points without active_coordinate (an origin and an "
                      "insertion that are always in the path)");
      }
      d.muscles.push_back(m);
    } else if (tag == "isowrench:posture") {
      std::string name = r.Attribute(e, "joint", true);
      const CoordinateSpec& j = urdf_coordinates::PostureCoordinate(*e, r.source, d);
      std::string deg = r.Attribute(e, "degrees", false);
      std::string value = r.Attribute(e, "value", false);
      if (deg.empty() == value.empty()) {
        r.Fail(e, "posture of '" + name + "' needs exactly one of degrees= or value= (rad or m)");
      }
      double q = 0;
      if (!deg.empty()) {
        if (j.type != JointType::kRevolute)
          r.Fail(e, "joint '" + name + "' is prismatic; use value= (m)");
        q = r.Number(e, "degrees", deg) * M_PI / 180.0;
      } else {
        q = r.Number(e, "value", value);
      }
      d.nominal_posture.emplace_back(name, q);
    }
  }
  ReadWrapObjects(r, *robot, d, check_link);
  CheckPathWraps(r, d, path_wrap_elements);
  urdf_coordinates::ApplyJointTags(*robot, r.source, d);
  // Plausibility (warnings, never errors): rotations written in degrees, then the description's
  // dimensions and nominal posture, each located at its line.
  std::vector<std::string> warnings;
  for (const JointSpec& j : d.joints) {
    const tinyxml2::XMLElement* origin = joint_elements.at(j.name)->FirstChildElement("origin");
    const char* rpy = origin ? origin->Attribute("rpy") : nullptr;
    std::vector<std::string> parts = rpy ? util::Split(rpy, " ") : std::vector<std::string>();
    if (parts.size() != 3) continue;
    Eigen::Vector3d angles;
    for (int k = 0; k < 3; ++k) util::ParseDouble(parts[static_cast<size_t>(k)], &angles[k]);
    std::string w =
        RotationWarning(angles, r.Where(origin) + ": joint '" + j.name + "': <origin> rpy");
    if (!w.empty()) warnings.push_back(w);
  }
  {
    std::string w =
        RotationWarning(transducer_rpy, r.Where(transducer) + ": <isowrench:transducer> rpy");
    if (!w.empty()) warnings.push_back(w + "; the wrench header shows the rotation it gives");
  }
  auto where = [&](const std::string& name) -> std::string {
    if (name.rfind("muscle:", 0) == 0) {
      const std::string muscle = name.substr(7);
      for (auto* e = robot->FirstChildElement("isowrench:muscle"); e;
           e = e->NextSiblingElement("isowrench:muscle")) {
        const char* n = e->Attribute("name");
        if (n && muscle == n) return r.Where(e);
      }
    }
    if (name.rfind("posture:", 0) == 0) {
      const std::string coordinate = name.substr(8);
      for (auto* e = robot->FirstChildElement("isowrench:posture"); e;
           e = e->NextSiblingElement("isowrench:posture")) {
        const char* n = e->Attribute("joint");
        if (n && coordinate == n) return r.Where(e) + ": <isowrench:posture>";
      }
      for (auto* e = robot->FirstChildElement("isowrench:coordinate"); e;
           e = e->NextSiblingElement("isowrench:coordinate")) {
        const char* n = e->Attribute("name");
        if (n && coordinate == n) return r.Where(e) + ": default";
      }
      auto it = joint_elements.find(coordinate);
      return it != joint_elements.end() ? r.Where(it->second) + ": nominal posture"
                                        : r.source + ": nominal posture";
    }
    auto it = joint_elements.find(name);
    return it != joint_elements.end() ? r.Where(it->second) : r.Where(transducer);
  };
  for (std::string& w : DescriptionWarnings(d, where)) warnings.push_back(std::move(w));
  WarnAll(warnings);
  return d;
}

}  // namespace isowrench
