// .osim XML -> osim::Model (OpenSim 3.x documents with joints inside bodies, and 4.x documents
// with a JointSet and PhysicalOffsetFrames). Every error names the file and the line.

#include <algorithm>
#include <cmath>
#include <cstring>
#include <set>

#include "isowrench/error.hpp"
#include "opensim/osim_model.hpp"
#include "util/text.hpp"

namespace isowrench::osim {
namespace {

using Xml = tinyxml2::XMLElement;

// Document versions read (OpenSim 3.0 to 4.6).
constexpr int kFirstVersion = 30000;
constexpr int kLastVersion = 40600;
// CustomJoint.cpp / Simbody FunctionBasedImpl: |a x b| below this makes two axes collinear.
constexpr double kCollinearTolerance = 1e-5;

struct Reader {
  std::string source;
  Model model;

  std::string Where(const Xml* e) const { return source + ":" + std::to_string(e->GetLineNum()); }
  [[noreturn]] void Fail(const Xml* e, const std::string& what) const {
    throw Error(Where(e) + ": " + what);
  }

  static std::string Text(const Xml* e) {
    return e && e->GetText() ? util::Trim(e->GetText()) : "";
  }
  static std::string ChildText(const Xml* e, const char* name) {
    return Text(e->FirstChildElement(name));
  }
  static std::string Name(const Xml* e) {
    const char* n = e->Attribute("name");
    return n ? n : "";
  }

  std::vector<double> Numbers(const Xml* e, const std::string& what) const {
    std::vector<double> values;
    for (const std::string& piece : util::Split(Text(e), " \t\r\n,")) {
      double v = 0.0;
      if (!util::ParseDouble(piece, &v)) {
        Fail(e, what + ": '" + piece + "' is not a number");
      }
      if (!std::isfinite(v)) Fail(e, what + ": '" + piece + "' is not finite");
      values.push_back(v);
    }
    return values;
  }

  std::vector<double> ChildNumbers(const Xml* parent, const char* name, size_t count,
                                   const std::string& what, bool required) const {
    const Xml* e = parent->FirstChildElement(name);
    if (!e) {
      if (required) Fail(parent, what + " needs a <" + name + "> element");
      return {};
    }
    std::vector<double> v = Numbers(e, what + " <" + name + ">");
    if (count && v.size() != count) {
      Fail(e, what + " <" + name + "> = '" + Text(e) + "' must hold " + std::to_string(count) +
                  " numbers");
    }
    return v;
  }

  Eigen::Vector3d ChildVector(const Xml* parent, const char* name, const std::string& what) const {
    std::vector<double> v = ChildNumbers(parent, name, 3, what, false);
    return v.empty() ? Eigen::Vector3d::Zero() : Eigen::Vector3d(v[0], v[1], v[2]);
  }

  bool ChildBool(const Xml* parent, const char* name, const std::string& what) const {
    const Xml* e = parent->FirstChildElement(name);
    if (!e) return false;
    const std::string t = Text(e);
    if (t == "true" || t == "1") return true;
    if (t == "false" || t == "0" || t.empty()) return false;
    Fail(e, what + " <" + name + "> = '" + t + "' must be true or false");
  }

  // ---- functions ------------------------------------------------------------------------

  static bool IsFunctionTag(const char* tag) {
    static const char* const kKnown[] = {
        "Constant",           "LinearFunction",          "SimmSpline",
        "NaturalCubicSpline", "PiecewiseLinearFunction", "PolynomialFunction",
        "MultiplierFunction"};
    for (const char* k : kKnown) {
      if (std::strcmp(tag, k) == 0) return true;
    }
    return false;
  }

  // Tags of OpenSim functions we refuse (so they are recognised as functions in messages).
  static bool IsOtherFunctionTag(const char* tag) {
    static const char* const kOther[] = {"GCVSpline",
                                         "StepFunction",
                                         "SineFunction",
                                         "PiecewiseConstantFunction",
                                         "MultivariatePolynomialFunction",
                                         "FunctionSet",
                                         "ExpressionBasedFunction",
                                         "XYFunction"};
    for (const char* k : kOther) {
      if (std::strcmp(tag, k) == 0) return true;
    }
    return std::strstr(tag, "Function") != nullptr || std::strstr(tag, "Spline") != nullptr;
  }

  // The function element among the children of `e` (looking through a <function> wrapper),
  // or null. `context` names the joint and axis (or point) for messages.
  const Xml* FindFunction(const Xml* e, const std::string& context) const {
    for (const Xml* c = e->FirstChildElement(); c; c = c->NextSiblingElement()) {
      if (IsFunctionTag(c->Name())) return c;
      if (std::strcmp(c->Name(), "function") == 0) {
        const Xml* inner = c->FirstChildElement();
        if (!inner) continue;
        if (IsFunctionTag(inner->Name())) return inner;
        Fail(inner, context + ": function type '" + inner->Name() +
                        "' is not supported (supported: Constant, LinearFunction, SimmSpline, "
                        "NaturalCubicSpline, PiecewiseLinearFunction, PolynomialFunction, "
                        "MultiplierFunction)");
      }
      if (IsOtherFunctionTag(c->Name())) {
        Fail(c, context + ": function type '" + c->Name() +
                    "' is not supported (supported: Constant, LinearFunction, SimmSpline, "
                    "NaturalCubicSpline, PiecewiseLinearFunction, PolynomialFunction, "
                    "MultiplierFunction)");
      }
    }
    return nullptr;
  }

  Function ParseFunction(const Xml* f, const std::string& context) const {
    const std::string tag = f->Name();
    const std::string what = context + ": " + tag;
    try {
      if (tag == "Constant") {
        std::vector<double> v = ChildNumbers(f, "value", 1, what, false);
        return Function::Constant(v.empty() ? 0.0 : v[0]);
      }
      if (tag == "LinearFunction") {
        std::vector<double> c = ChildNumbers(f, "coefficients", 2, what, true);
        return Function::Linear(c[0], c[1]);
      }
      if (tag == "SimmSpline" || tag == "NaturalCubicSpline") {
        // OpenSim 4 reads NaturalCubicSpline as a SimmSpline (RegisterTypes_osimCommon.cpp).
        return Function::SimmSpline(ChildNumbers(f, "x", 0, what, true),
                                    ChildNumbers(f, "y", 0, what, true));
      }
      if (tag == "PiecewiseLinearFunction") {
        return Function::PiecewiseLinear(ChildNumbers(f, "x", 0, what, true),
                                         ChildNumbers(f, "y", 0, what, true));
      }
      if (tag == "PolynomialFunction") {
        return Function::Polynomial(ChildNumbers(f, "coefficients", 0, what, true));
      }
      if (tag == "MultiplierFunction") {
        std::vector<double> s = ChildNumbers(f, "scale", 1, what, false);
        const Xml* inner = FindFunction(f, context);
        if (!inner) Fail(f, what + " has no function to scale");
        return Function::Multiplier(ParseFunction(inner, context), s.empty() ? 1.0 : s[0]);
      }
    } catch (const Error& error) {
      const std::string message = error.what();
      if (message.compare(0, source.size() + 1, source + ":") == 0) throw;
      Fail(f, what + ": " + message);
    }
    Fail(f, what + ": function type is not supported");
  }

  // ---- frames ---------------------------------------------------------------------------

  struct OffsetFrame {
    std::string parent_path;
    Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
    const Xml* element = nullptr;
  };

  Eigen::Isometry3d Offset(const Xml* e, const char* translation, const char* orientation,
                           const std::string& what) const {
    Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
    X.translation() = ChildVector(e, translation, what);
    X.linear() = BodyFixedXyz(ChildVector(e, orientation, what));
    return X;
  }

  bool IsBody(const std::string& name) const {
    return std::find(model.bodies.begin(), model.bodies.end(), name) != model.bodies.end();
  }

  // Resolve a socket path seen from a joint: a body, the ground, or one of the joint's frames
  // (possibly offset from another). Returns the body and X_body_frame.
  std::pair<std::string, Eigen::Isometry3d> ResolveFrame(
      const std::string& path, const std::map<std::string, OffsetFrame>& frames, const Xml* where,
      const std::string& context, int depth = 0) const {
    if (depth > 8) Fail(where, context + ": offset frames refer to each other in a loop");
    std::vector<std::string> parts;
    for (const std::string& p : util::Split(path, "/")) {
      if (p != "." && p != "..") parts.push_back(p);
    }
    if (parts.empty()) Fail(where, context + ": empty frame path '" + path + "'");
    const std::string& last = parts.back();
    auto frame = frames.find(last);
    if (frame != frames.end() && (parts.size() == 1 || parts.front() == "jointset")) {
      auto [body, X] = ResolveFrame(frame->second.parent_path, frames, frame->second.element,
                                    context, depth + 1);
      return {body, X * frame->second.X};
    }
    if (parts.size() <= 2 && IsBody(last) && (parts.size() == 1 || parts.front() == "bodyset")) {
      return {last, Eigen::Isometry3d::Identity()};
    }
    Fail(where,
         context + ": '" + path + "' names no body of the model and no frame of " + "this joint");
  }

  // ---- bodies, joints, coordinates ------------------------------------------------------

  void ReadCoordinate(const Xml* c, const std::string& joint) {
    Coordinate coordinate;
    coordinate.name = Name(c);
    coordinate.joint = joint;
    coordinate.line = c->GetLineNum();
    if (coordinate.name.empty()) Fail(c, "a <Coordinate> of joint '" + joint + "' has no name");
    if (model.coordinates.count(coordinate.name)) {
      Fail(c, "coordinate '" + coordinate.name + "' is declared twice (first at line " +
                  std::to_string(model.coordinates[coordinate.name].line) + ")");
    }
    const std::string what = "coordinate '" + coordinate.name + "'";
    std::vector<double> d = ChildNumbers(c, "default_value", 1, what, false);
    if (!d.empty()) coordinate.default_value = d[0];
    std::vector<double> r = ChildNumbers(c, "range", 2, what, false);
    if (!r.empty()) {
      if (r[0] > r[1]) {
        Fail(c->FirstChildElement("range"), what + ": range " + util::FormatNumber(r[0]) + " " +
                                                util::FormatNumber(r[1]) + " has lower > upper");
      }
      coordinate.lower = r[0];
      coordinate.upper = r[1];
    }
    coordinate.locked = ChildBool(c, "locked", what);
    const std::string motion = ChildText(c, "motion_type");
    if (!motion.empty()) coordinate.rotational = motion != "translational";
    model.coordinates[coordinate.name] = coordinate;
  }

  // The fixed axes of the joint types built on Simbody mobilizers.
  struct FixedAxis {
    bool rotation;
    int axis;  // 0 x, 1 y, 2 z
  };

  static bool FixedAxes(const std::string& type, std::vector<FixedAxis>* axes) {
    if (type == "PinJoint")
      *axes = {{true, 2}};
    else if (type == "SliderJoint")
      *axes = {{false, 0}};
    else if (type == "UniversalJoint")
      *axes = {{true, 0}, {true, 1}};
    else if (type == "GimbalJoint" || type == "BallJoint")
      *axes = {{true, 0}, {true, 1}, {true, 2}};
    else if (type == "PlanarJoint")
      *axes = {{true, 2}, {false, 0}, {false, 1}};
    else if (type == "FreeJoint")
      *axes = {{true, 0}, {true, 1}, {true, 2}, {false, 0}, {false, 1}, {false, 2}};
    else if (type == "WeldJoint")
      *axes = {};
    else
      return false;
    return true;
  }

  void ReadSpatialTransform(const Xml* j, Joint& joint) {
    const Xml* st = j->FirstChildElement("SpatialTransform");
    if (!st) Fail(j, "CustomJoint '" + joint.name + "' has no <SpatialTransform>");
    static const char* const kNames[] = {"rotation1",    "rotation2",    "rotation3",
                                         "translation1", "translation2", "translation3"};
    std::vector<const Xml*> found(6, nullptr);
    int next = 0;
    for (const Xml* t = st->FirstChildElement("TransformAxis"); t;
         t = t->NextSiblingElement("TransformAxis")) {
      std::string name = Name(t);
      int index = -1;
      for (int i = 0; i < 6; ++i) {
        if (name == kNames[i]) index = i;
      }
      if (index < 0) index = next;  // 3.x files may leave the axes unnamed: in order
      if (index > 5 || found[index]) {
        Fail(t, "CustomJoint '" + joint.name + "': TransformAxis '" + name +
                    "' is repeated or beyond the six axes rotation1-3, translation1-3");
      }
      found[index] = t;
      next = index + 1;
    }
    for (int i = 0; i < 6; ++i) {
      Axis axis;
      axis.name = kNames[i];
      axis.rotation = i < 3;
      const std::string context = "joint '" + joint.name + "' axis '" + axis.name + "'";
      const Xml* t = found[i];
      if (!t) {  // absent axis: no motion
        axis.axis = Eigen::Vector3d::Unit(i % 3);
        axis.function = Function::Constant(0.0);
        joint.axes.push_back(axis);
        continue;
      }
      axis.line = t->GetLineNum();
      std::vector<double> a = ChildNumbers(t, "axis", 3, context, true);
      Eigen::Vector3d v(a[0], a[1], a[2]);
      if (v.norm() == 0.0) Fail(t, context + ": the axis is the zero vector");
      axis.axis = v.normalized();
      std::vector<std::string> coordinates = util::Split(ChildText(t, "coordinates"), " \t\r\n");
      if (coordinates.size() > 1) {
        Fail(t, context + " depends on " + std::to_string(coordinates.size()) +
                    " coordinates; only functions of one coordinate are supported");
      }
      if (!coordinates.empty()) {
        axis.coordinate = coordinates[0];
        if (std::find(joint.coordinates.begin(), joint.coordinates.end(), axis.coordinate) ==
            joint.coordinates.end()) {
          Fail(t, context + " names coordinate '" + axis.coordinate +
                      "', which is not one of the joint's coordinates (" +
                      util::Join(joint.coordinates, ", ") + ")");
        }
      }
      const Xml* f = FindFunction(t, context);
      if (f) {
        axis.function = ParseFunction(f, context);
      } else {
        // No function: the identity of its coordinate, or 0 (CustomJoint semantics).
        axis.function = axis.coordinate.empty() ? Function::Constant(0.0) : Function::Linear(1, 0);
      }
      if (axis.coordinate.empty() && axis.function.kind() != FunctionKind::kConstant) {
        // A function of no coordinate is evaluated at 0 by OpenSim: a constant.
        axis.function = Function::Constant(axis.function.Value(0.0));
      }
      joint.axes.push_back(axis);
    }
    // Collinear axes within a group are an error in OpenSim
    // (CustomJoint::extendFinalizeFromProperties).
    for (int group = 0; group < 2; ++group) {
      for (int a = 0; a < 3; ++a) {
        for (int b = a + 1; b < 3; ++b) {
          const Axis& p = joint.axes[group * 3 + a];
          const Axis& q = joint.axes[group * 3 + b];
          if (p.axis.cross(q.axis).norm() < kCollinearTolerance) {
            Fail(found[group * 3 + b] ? found[group * 3 + b] : st,
                 "joint '" + joint.name + "': axes '" + p.name + "' and '" + q.name +
                     "' are collinear (|a x b| < 1e-5); OpenSim refuses such a CustomJoint");
          }
        }
      }
    }
  }

  void ReadJoint(const Xml* j, const std::string& child_body_v3, const Xml* body_v3) {
    Joint joint;
    joint.name = Name(j);
    joint.type = j->Name();
    joint.line = j->GetLineNum();
    // 3.x files may leave a joint unnamed: name it after its child body.
    if (joint.name.empty() && body_v3) joint.name = child_body_v3 + "_joint";
    if (joint.name.empty()) Fail(j, "a <" + joint.type + "> has no name");
    for (const Joint& other : model.joints) {
      if (other.name == joint.name) {
        Fail(j, "joint '" + joint.name + "' is declared twice (first at line " +
                    std::to_string(other.line) + ")");
      }
    }
    std::vector<FixedAxis> fixed;
    if (joint.type != "CustomJoint" && !FixedAxes(joint.type, &fixed)) {
      Fail(j, "joint '" + joint.name + "' has the type '" + joint.type +
                  "', which is not supported (CustomJoint, PinJoint, SliderJoint, UniversalJoint, "
                  "BallJoint, GimbalJoint, PlanarJoint, WeldJoint, FreeJoint)");
    }
    if (ChildBool(j, "reverse", "joint '" + joint.name + "'")) {
      Fail(j->FirstChildElement("reverse"),
           "joint '" + joint.name +
               "' is reversed (<reverse>true</reverse>); reversed joints "
               "are not supported");
    }
    const std::string context = "joint '" + joint.name + "'";
    // Coordinates: 4.x <coordinates>, 3.x <CoordinateSet><objects>.
    const Xml* list = j->FirstChildElement("coordinates");
    if (!list) {
      const Xml* set = j->FirstChildElement("CoordinateSet");
      list = set ? set->FirstChildElement("objects") : nullptr;
    }
    if (list) {
      for (const Xml* c = list->FirstChildElement("Coordinate"); c;
           c = c->NextSiblingElement("Coordinate")) {
        ReadCoordinate(c, joint.name);
        joint.coordinates.push_back(Name(c));
      }
    }
    if (body_v3) {  // 3.x: parent_body, location_in_parent, ... inside the child body
      joint.child_body = child_body_v3;
      joint.parent_body = ChildText(j, "parent_body");
      if (joint.parent_body.empty()) Fail(j, context + " has no <parent_body>");
      if (!IsBody(joint.parent_body)) {
        Fail(j->FirstChildElement("parent_body"),
             context + ": parent body '" + joint.parent_body + "' does not exist");
      }
      joint.X_Pb_P = Offset(j, "location_in_parent", "orientation_in_parent", context);
      joint.X_Cb_C = Offset(j, "location", "orientation", context);
    } else {
      std::map<std::string, OffsetFrame> frames;
      if (const Xml* fs = j->FirstChildElement("frames")) {
        for (const Xml* f = fs->FirstChildElement(); f; f = f->NextSiblingElement()) {
          OffsetFrame frame;
          frame.element = f;
          frame.parent_path = ChildText(f, "socket_parent");
          if (frame.parent_path.empty()) {
            Fail(f, context + ": frame '" + Name(f) + "' has no <socket_parent>");
          }
          frame.X = Offset(f, "translation", "orientation", context + " frame '" + Name(f) + "'");
          frames[Name(f)] = frame;
        }
      }
      for (int side = 0; side < 2; ++side) {
        const char* socket = side == 0 ? "socket_parent_frame" : "socket_child_frame";
        const Xml* s = j->FirstChildElement(socket);
        if (!s || Text(s).empty()) Fail(j, context + " has no <" + socket + ">");
        auto [body, X] = ResolveFrame(Text(s), frames, s, context + " <" + socket + ">");
        (side == 0 ? joint.parent_body : joint.child_body) = body;
        (side == 0 ? joint.X_Pb_P : joint.X_Cb_C) = X;
      }
    }
    if (joint.type == "CustomJoint") {
      ReadSpatialTransform(j, joint);
    } else {
      if (fixed.size() != joint.coordinates.size()) {
        Fail(j, context + " (" + joint.type + ") has " + std::to_string(joint.coordinates.size()) +
                    " coordinates; it needs " + std::to_string(fixed.size()));
      }
      int rotations = 0, translations = 0;
      std::vector<Axis> rot, trans;
      for (size_t i = 0; i < fixed.size(); ++i) {
        Axis axis;
        axis.rotation = fixed[i].rotation;
        axis.name = axis.rotation ? "rotation" + std::to_string(++rotations)
                                  : "translation" + std::to_string(++translations);
        axis.axis = Eigen::Vector3d::Unit(fixed[i].axis);
        axis.coordinate = joint.coordinates[i];
        axis.function = Function::Linear(1, 0);
        axis.line = joint.line;
        (axis.rotation ? rot : trans).push_back(axis);
      }
      joint.axes = rot;
      joint.axes.insert(joint.axes.end(), trans.begin(), trans.end());
    }
    // Motion type of the coordinates: rotational if they drive a rotation axis.
    for (const std::string& c : joint.coordinates) {
      bool rotation = false, any = false;
      for (const Axis& a : joint.axes) {
        if (a.coordinate != c || a.function.kind() == FunctionKind::kConstant) continue;
        any = true;
        rotation |= a.rotation;
      }
      Coordinate& coordinate = model.coordinates[c];
      if (any && coordinate.line && !j->FirstChildElement("motion_type"))
        coordinate.rotational = rotation;
    }
    model.joints.push_back(joint);
  }

  void ReadWrapObjects(const Xml* body, const std::string& body_name) {
    const Xml* set = body->FirstChildElement("WrapObjectSet");
    const Xml* objects = set ? set->FirstChildElement("objects") : nullptr;
    if (!objects) return;
    for (const Xml* w = objects->FirstChildElement(); w; w = w->NextSiblingElement()) {
      WrapObject o;
      o.name = Name(w);
      o.type = w->Name();
      o.body = body_name;
      o.line = w->GetLineNum();
      const std::string what = o.type + " '" + o.name + "' on '" + body_name + "'";
      o.translation = ChildVector(w, "translation", what);
      o.xyz_body_rotation = ChildVector(w, "xyz_body_rotation", what);
      if (w->FirstChildElement("active")) o.active = ChildBool(w, "active", what);
      const std::string quadrant = ChildText(w, "quadrant");
      if (!quadrant.empty()) o.quadrant = quadrant;
      auto number = [&](const char* name, double& value) {
        std::vector<double> v = ChildNumbers(w, name, 1, what, false);
        if (!v.empty()) value = v[0];
      };
      number("radius", o.radius);
      number("length", o.length);
      number("inner_radius", o.inner_radius);
      number("outer_radius", o.outer_radius);
      std::vector<double> dims = ChildNumbers(w, "dimensions", 3, what, false);
      if (!dims.empty()) o.dimensions = Eigen::Vector3d(dims[0], dims[1], dims[2]);
      model.wrap_objects.push_back(o);
    }
  }

  // ---- muscles --------------------------------------------------------------------------

  // Body and X_body_frame of a path point's frame: 4.x socket_parent_frame, 3.x <body>.
  void PointFrame(const Xml* p, Point& point, const std::string& context) const {
    std::string path = ChildText(p, "socket_parent_frame");
    if (path.empty()) path = ChildText(p, "body");
    if (path.empty()) Fail(p, context + " has no <socket_parent_frame> (or <body>)");
    std::vector<std::string> parts;
    for (const std::string& s : util::Split(path, "/")) {
      if (s != "." && s != "..") parts.push_back(s);
    }
    const std::string last = parts.empty() ? "" : parts.back();
    if (IsBody(last) && (parts.size() == 1 || (parts.size() == 2 && parts[0] == "bodyset"))) {
      point.body = last;
      return;
    }
    Fail(p, context + ": frame '" + path + "' is not a body of the model");
  }

  std::string CoordinateSocket(const Xml* p, const char* socket4, const char* name3) const {
    std::string path = ChildText(p, socket4);
    if (path.empty()) path = ChildText(p, name3);
    if (path.empty()) return "";
    std::vector<std::string> parts = util::Split(path, "/");
    const std::string name = parts.empty() ? path : parts.back();
    if (!model.coordinates.count(name)) {
      Fail(p, "path point '" + Name(p) + "': coordinate '" + path + "' does not exist");
    }
    return name;
  }

  // ---- muscle force models ---------------------------------------------------------------

  // The document's <defaults>: OpenSim registers each object there as the default instance of
  // its type (Object::updateDefaultObjectsFromXMLNode), so a property an object leaves out takes
  // the value of that default object, else the class default.
  const Xml* defaults = nullptr;
  const Xml* DefaultObject(const char* type) const {
    return defaults ? defaults->FirstChildElement(type) : nullptr;
  }

  // Property `name` of `object`, else of `fallback` (its <defaults> object); null when neither
  // has it or the element holds no value (an empty optional property).
  const Xml* Property(const Xml* object, const Xml* fallback, const char* name) const {
    for (const Xml* o : {object, fallback}) {
      const Xml* e = o ? o->FirstChildElement(name) : nullptr;
      if (e && !Text(e).empty()) return e;
    }
    return nullptr;
  }

  void ForceNumber(const Xml* object, const Xml* fallback, const char* name,
                   const std::string& what, double* out) const {
    if (const Xml* e = Property(object, fallback, name)) {
      const std::vector<double> v = Numbers(e, what + " <" + name + ">");
      if (v.size() != 1) Fail(e, what + " <" + name + "> = '" + Text(e) + "' must hold 1 number");
      *out = v[0];
    }
  }

  void ForceOptional(const Xml* object, const Xml* fallback, const char* name,
                     const std::string& what, std::optional<double>* out) const {
    if (Property(object, fallback, name)) {
      double v = 0.0;
      ForceNumber(object, fallback, name, what, &v);
      *out = v;
    }
  }

  void ReadMuscleForce(const Xml* m, Muscle& muscle) {
    const bool thelen = muscle.type == "Thelen2003Muscle";
    const bool millard = muscle.type == "Millard2012EquilibriumMuscle";
    if (!thelen && !millard) {
      muscle.force_note = "force model " + muscle.type +
                          " is not modelled: imported with the constant force model "
                          "(F = activation * max_isometric_force)";
      return;
    }
    const std::string what = "muscle '" + muscle.name + "'";
    const Xml* def = DefaultObject(muscle.type.c_str());
    MuscleForceSpec& f = muscle.force;
    f.model = thelen ? ForceModelType::kThelen2003 : ForceModelType::kMillard2012;
    // Muscle::constructProperties defaults (MuscleForceSpec has OpenSim's other defaults).
    f.optimal_fiber_length = 0.1;
    f.tendon_slack_length = 0.2;
    ForceNumber(m, def, "optimal_fiber_length", what, &f.optimal_fiber_length);
    ForceNumber(m, def, "tendon_slack_length", what, &f.tendon_slack_length);
    ForceNumber(m, def, "pennation_angle_at_optimal", what, &f.pennation_angle_at_optimal);
    ForceNumber(m, def, "maximum_pennation_angle", what, &f.maximum_pennation_angle);
    ForceNumber(m, def, "minimum_activation", what, &f.minimum_activation);
    if (const Xml* e = Property(m, def, "ignore_tendon_compliance")) {
      const std::string t = Text(e);
      if (t != "true" && t != "false" && t != "1" && t != "0") {
        Fail(e, what + " <ignore_tendon_compliance> = '" + t + "' must be true or false");
      }
      f.ignore_tendon_compliance = t == "true" || t == "1";
    }
    if (thelen) {
      Thelen2003CurveSpec& t = f.thelen;
      ForceNumber(m, def, "FmaxTendonStrain", what, &t.FmaxTendonStrain);
      ForceNumber(m, def, "FmaxMuscleStrain", what, &t.FmaxMuscleStrain);
      ForceNumber(m, def, "KshapeActive", what, &t.KshapeActive);
      ForceNumber(m, def, "KshapePassive", what, &t.KshapePassive);
      return;
    }
    ForceNumber(m, def, "fiber_damping", what, &f.fiber_damping);
    auto curve = [&](const char* type) {
      const Xml* c = m->FirstChildElement(type);
      if (!c && def) c = def->FirstChildElement(type);
      return std::pair<const Xml*, const Xml*>{c, DefaultObject(type)};
    };
    {
      const auto [c, cdef] = curve("ActiveForceLengthCurve");
      const std::string cw = what + " ActiveForceLengthCurve";
      ActiveForceLengthCurveSpec& a = f.active_force_length;
      ForceNumber(c, cdef, "min_norm_active_fiber_length", cw, &a.min_norm_active_fiber_length);
      ForceNumber(c, cdef, "transition_norm_fiber_length", cw, &a.transition_norm_fiber_length);
      ForceNumber(c, cdef, "max_norm_active_fiber_length", cw, &a.max_norm_active_fiber_length);
      ForceNumber(c, cdef, "shallow_ascending_slope", cw, &a.shallow_ascending_slope);
      ForceNumber(c, cdef, "minimum_value", cw, &a.minimum_value);
    }
    {
      const auto [c, cdef] = curve("FiberForceLengthCurve");
      const std::string cw = what + " FiberForceLengthCurve";
      FiberForceLengthCurveSpec& p = f.fiber_force_length;
      ForceNumber(c, cdef, "strain_at_zero_force", cw, &p.strain_at_zero_force);
      ForceNumber(c, cdef, "strain_at_one_norm_force", cw, &p.strain_at_one_norm_force);
      ForceOptional(c, cdef, "stiffness_at_low_force", cw, &p.stiffness_at_low_force);
      ForceOptional(c, cdef, "stiffness_at_one_norm_force", cw, &p.stiffness_at_one_norm_force);
      ForceOptional(c, cdef, "curviness", cw, &p.curviness);
    }
    {
      const auto [c, cdef] = curve("TendonForceLengthCurve");
      const std::string cw = what + " TendonForceLengthCurve";
      TendonForceLengthCurveSpec& t = f.tendon_force_length;
      ForceNumber(c, cdef, "strain_at_one_norm_force", cw, &t.strain_at_one_norm_force);
      ForceOptional(c, cdef, "stiffness_at_one_norm_force", cw, &t.stiffness_at_one_norm_force);
      ForceOptional(c, cdef, "norm_force_at_toe_end", cw, &t.norm_force_at_toe_end);
      ForceOptional(c, cdef, "curviness", cw, &t.curviness);
    }
  }

  void ReadMuscle(const Xml* m) {
    Muscle muscle;
    muscle.name = Name(m);
    muscle.type = m->Name();
    muscle.line = m->GetLineNum();
    for (const Muscle& other : model.muscles) {
      if (other.name == muscle.name) {
        Fail(m, "muscle '" + muscle.name + "' is declared twice (first at line " +
                    std::to_string(other.line) + ")");
      }
    }
    const std::string context = "muscle '" + muscle.name + "'";
    muscle.max_force = ChildNumbers(m, "max_isometric_force", 1, context, true)[0];
    const Xml* path = m->FirstChildElement("GeometryPath");
    const Xml* set = path->FirstChildElement("PathPointSet");
    const Xml* objects = set ? set->FirstChildElement("objects") : nullptr;
    if (!objects) Fail(path, context + ": <GeometryPath> has no <PathPointSet><objects>");
    for (const Xml* p = objects->FirstChildElement(); p; p = p->NextSiblingElement()) {
      Point point;
      point.name = Name(p);
      point.type = p->Name();
      point.line = p->GetLineNum();
      const std::string pc = context + " point '" + point.name + "'";
      if (point.type != "PathPoint" && point.type != "MovingPathPoint" &&
          point.type != "ConditionalPathPoint") {
        Fail(p, pc + " has the type '" + point.type +
                    "', which is not supported (PathPoint, MovingPathPoint, ConditionalPathPoint)");
      }
      PointFrame(p, point, pc);
      point.location = ChildVector(p, "location", pc);
      if (point.type == "MovingPathPoint") {
        point.moving = true;
        static const char* const kLocation4[] = {"x_location", "y_location", "z_location"};
        static const char* const kLocation3[] = {"XAttachment", "YAttachment", "ZAttachment"};
        static const char* const kSocket4[] = {"socket_x_coordinate", "socket_y_coordinate",
                                               "socket_z_coordinate"};
        static const char* const kName3[] = {"x_coordinate", "y_coordinate", "z_coordinate"};
        for (int i = 0; i < 3; ++i) {
          const Xml* holder = p->FirstChildElement(kLocation4[i]);
          if (!holder) holder = p->FirstChildElement(kLocation3[i]);
          const std::string fc = pc + " " + kLocation4[i];
          const Xml* f = holder ? FindFunction(holder, fc) : nullptr;
          // A missing component is OpenSim's default Constant(0) (MovingPathPoint::
          // constructProperties); a <location> in a MovingPathPoint is not read by OpenSim 4.
          point.functions[i] = f ? ParseFunction(f, fc) : Function::Constant(0.0);
          point.moving_coordinates[i] = CoordinateSocket(p, kSocket4[i], kName3[i]);
        }
        const std::string* c = point.moving_coordinates;
        if (c[0] != c[1] || c[0] != c[2]) {
          auto quoted = [](const std::string& name) { return "'" + name + "'"; };
          Fail(p, pc + ": its x, y and z locations depend on the coordinates " + quoted(c[0]) +
                      ", " + quoted(c[1]) + ", " + quoted(c[2]) +
                      "; OpenSim 4 refuses a MovingPathPoint whose three components do not all "
                      "depend on the same coordinate (MovingPathPoint::extendConnectToModel)");
        }
      } else if (point.type == "ConditionalPathPoint") {
        point.conditional = true;
        std::vector<double> r = ChildNumbers(p, "range", 2, pc, true);
        point.range[0] = r[0];
        point.range[1] = r[1];
        point.condition_coordinate = CoordinateSocket(p, "socket_coordinate", "coordinate");
        if (point.condition_coordinate.empty()) {
          Fail(p, pc + ": ConditionalPathPoint names no coordinate");
        }
      }
      muscle.points.push_back(point);
    }
    if (const Xml* wraps = path->FirstChildElement("PathWrapSet")) {
      if (const Xml* wo = wraps->FirstChildElement("objects")) {
        for (const Xml* w = wo->FirstChildElement(); w; w = w->NextSiblingElement()) {
          PathWrap wrap;
          wrap.object = ChildText(w, "wrap_object");
          if (wrap.object.empty()) wrap.object = Name(w);
          wrap.line = w->GetLineNum();
          const std::string method = ChildText(w, "method");
          if (!method.empty()) wrap.method = method;
          const std::string what = context + " PathWrap '" + wrap.object + "'";
          std::vector<double> range = ChildNumbers(w, "range", 2, what, false);
          for (size_t i = 0; i < range.size(); ++i) {
            if (range[i] != std::floor(range[i])) {
              Fail(w->FirstChildElement("range"),
                   what + ": range holds '" + ChildText(w, "range") + "', not two whole numbers");
            }
            wrap.range[i] = range[i] < 1 ? -1 : static_cast<int>(std::min(range[i], 1e6));
          }
          muscle.wraps.push_back(wrap);
        }
      }
    }
    ReadMuscleForce(m, muscle);
    model.muscles.push_back(muscle);
  }

  // q_dependent = scale_factor * f(q_independent); one independent coordinate only.
  void ReadCoupler(const Xml* c, const std::string& what) {
    Coupler coupler;
    coupler.name = Name(c);
    coupler.line = c->GetLineNum();
    coupler.dependent = ChildText(c, "dependent_coordinate_name");
    std::vector<std::string> independent =
        util::Split(ChildText(c, "independent_coordinate_names"), " \t\r\n");
    if (independent.size() != 1 || coupler.dependent.empty()) {
      Fail(c, what + " must name one independent and one dependent coordinate");
    }
    coupler.independent = independent[0];
    for (const std::string& name : {coupler.dependent, coupler.independent}) {
      if (!model.coordinates.count(name)) {
        Fail(c, what + " names coordinate '" + name + "', which does not exist");
      }
    }
    const Xml* holder = c->FirstChildElement("coupled_coordinates_function");
    const Xml* f = holder ? FindFunction(holder, what) : nullptr;
    if (!f) Fail(c, what + " has no <coupled_coordinates_function>");
    coupler.function = ParseFunction(f, what);
    std::vector<double> scale = ChildNumbers(c, "scale_factor", 1, what, false);
    if (!scale.empty() && scale[0] != 1.0) {
      coupler.function = Function::Multiplier(coupler.function, scale[0]);
    }
    model.couplers.push_back(coupler);
  }

  // ---- the document ---------------------------------------------------------------------

  void Read(const std::string& xml) {
    tinyxml2::XMLDocument doc;
    if (doc.Parse(xml.c_str(), xml.size()) != tinyxml2::XML_SUCCESS) {
      throw Error(source + ":" + std::to_string(doc.ErrorLineNum()) + ": malformed XML (" +
                  tinyxml2::XMLDocument::ErrorIDToName(doc.ErrorID()) + ")");
    }
    const Xml* root = doc.RootElement();
    if (!root || std::strcmp(root->Name(), "OpenSimDocument") != 0) {
      throw Error(source + ":" + std::to_string(root ? root->GetLineNum() : 1) +
                  ": not an OpenSim model: the root element must be <OpenSimDocument>");
    }
    const char* version = root->Attribute("Version");
    double v = 0;
    if (!version || !util::ParseDouble(version, &v)) {
      Fail(root, "<OpenSimDocument> has no numeric Version attribute");
    }
    model.version = static_cast<int>(v);
    if (model.version < kFirstVersion) {
      Fail(root, "document version " + std::string(version) + " is older than OpenSim 3.0 (" +
                     std::to_string(kFirstVersion) + "); open and save it in OpenSim 4 first");
    }
    if (model.version > kLastVersion) {
      model.warnings.push_back(
          "document version " + std::string(version) + " is newer than the versions checked (" +
          std::to_string(kFirstVersion) + "-" + std::to_string(kLastVersion) + "); read as 4.6");
    }
    const Xml* m = root->FirstChildElement("Model");
    if (!m) Fail(root, "<OpenSimDocument> has no <Model>");
    model.name = Name(m);
    model.length_units = ChildText(m, "length_units");
    model.force_units = ChildText(m, "force_units");
    const Xml* ground = m->FirstChildElement("Ground");
    if (ground) {
      model.ground = Name(ground).empty() ? "ground" : Name(ground);
      ReadWrapObjects(ground, model.ground);
    }
    model.bodies.push_back(model.ground);
    model.body_lines[model.ground] = ground ? ground->GetLineNum() : m->GetLineNum();
    const Xml* body_set = m->FirstChildElement("BodySet");
    const Xml* bodies = body_set ? body_set->FirstChildElement("objects") : nullptr;
    if (!bodies) Fail(m, "<Model> has no <BodySet><objects>");
    std::vector<const Xml*> body_elements;
    for (const Xml* b = bodies->FirstChildElement("Body"); b; b = b->NextSiblingElement("Body")) {
      const std::string name = Name(b);
      if (name.empty()) Fail(b, "a <Body> has no name");
      if (name == model.ground) {  // 3.x: the ground is a body
        ReadWrapObjects(b, name);
        continue;
      }
      if (IsBody(name)) Fail(b, "body '" + name + "' is declared twice");
      model.bodies.push_back(name);
      model.body_lines[name] = b->GetLineNum();
      body_elements.push_back(b);
      ReadWrapObjects(b, name);
    }
    const Xml* joint_set = m->FirstChildElement("JointSet");
    if (joint_set) {
      if (const Xml* objects = joint_set->FirstChildElement("objects")) {
        for (const Xml* j = objects->FirstChildElement(); j; j = j->NextSiblingElement()) {
          ReadJoint(j, "", nullptr);
        }
      }
    } else {  // 3.x: <Body><Joint><CustomJoint ...> inside the child body
      for (const Xml* b : body_elements) {
        const Xml* holder = b->FirstChildElement("Joint");
        const Xml* j = holder ? holder->FirstChildElement() : nullptr;
        if (j) ReadJoint(j, Name(b), b);
      }
    }
    if (const Xml* cs = m->FirstChildElement("ConstraintSet")) {
      if (const Xml* objects = cs->FirstChildElement("objects")) {
        for (const Xml* c = objects->FirstChildElement(); c; c = c->NextSiblingElement()) {
          const std::string what = "constraint '" + Name(c) + "' (" + c->Name() + ", line " +
                                   std::to_string(c->GetLineNum()) + ")";
          const std::string enforced = ChildText(c, "isEnforced");
          if (enforced == "false" || ChildText(c, "isDisabled") == "true") {
            model.warnings.push_back(what + " is disabled in the .osim: ignored");
            continue;
          }
          if (std::strcmp(c->Name(), "CoordinateCouplerConstraint") == 0) {
            ReadCoupler(c, what);
            continue;
          }
          model.warnings.push_back(what +
                                   " is not imported: coordinates it would tie are "
                                   "independent");
        }
      }
    }
    defaults = m->FirstChildElement("defaults");
    // Muscles: in the ForceSet, or (4.x) among the model's own <components>.
    std::vector<const Xml*> holders;
    if (const Xml* fs = m->FirstChildElement("ForceSet"))
      holders.push_back(fs->FirstChildElement("objects"));
    holders.push_back(m->FirstChildElement("components"));
    for (const Xml* holder : holders) {
      for (const Xml* f = holder ? holder->FirstChildElement() : nullptr; f;
           f = f->NextSiblingElement()) {
        if (f->FirstChildElement("GeometryPath") && f->FirstChildElement("max_isometric_force")) {
          ReadMuscle(f);
        }
      }
    }
  }
};

}  // namespace

Eigen::Matrix3d BodyFixedXyz(const Eigen::Vector3d& a) {
  return (Eigen::AngleAxisd(a.x(), Eigen::Vector3d::UnitX()) *
          Eigen::AngleAxisd(a.y(), Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(a.z(), Eigen::Vector3d::UnitZ()))
      .toRotationMatrix();
}

Eigen::Isometry3d AxisMotion(const Axis& axis, double value) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  if (axis.rotation) {
    X.linear() = Eigen::AngleAxisd(value, axis.axis).toRotationMatrix();
  } else {
    X.translation() = value * axis.axis;
  }
  return X;
}

Eigen::Isometry3d JointTransform(const Model& model, const Joint& joint,
                                 const std::map<std::string, double>& q) {
  // X_PC = [R1 R2 R3, sum f_i a_i]: translations in P, not rotated (Simbody FunctionBased).
  Eigen::Isometry3d X_PC = Eigen::Isometry3d::Identity();
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  for (const Axis& a : joint.axes) {
    double x = 0.0;
    if (!a.coordinate.empty()) {
      auto it = q.find(a.coordinate);
      x = it != q.end() ? it->second : model.coordinates.at(a.coordinate).default_value;
    }
    const double value = a.function.Value(x);
    if (a.rotation) {
      R = R * Eigen::AngleAxisd(value, a.axis).toRotationMatrix();
    } else {
      X_PC.translation() += value * a.axis;
    }
  }
  X_PC.linear() = R;
  return joint.X_Pb_P * X_PC * joint.X_Cb_C.inverse();
}

Model ReadModel(const std::string& xml, const std::string& source) {
  Reader reader{source, {}};
  reader.model.source = source;
  reader.Read(xml);
  return std::move(reader.model);
}

}  // namespace isowrench::osim
