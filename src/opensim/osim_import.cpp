// osim::Model -> LimbDescription: the chain from the clamped body to the endpoint body, its
// coordinates and couplings, and the muscles on it (include/isowrench/opensim.hpp).

#include <algorithm>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include "isowrench/error.hpp"
#include "isowrench/input_checks.hpp"
#include "isowrench/muscle.hpp"
#include "isowrench/opensim.hpp"
#include "model/model_impl.hpp"
#include "model/urdf_coordinates.hpp"
#include "opensim/osim_model.hpp"
#include "util/text.hpp"

namespace isowrench {
namespace {

using osim::Axis;

std::string Num(double v) { return util::FormatNumber(v, 6); }

// A transform equal to the identity up to rounding of the products that built it.
bool IsIdentity(const Eigen::Isometry3d& X) {
  constexpr double kTiny = 1e-15;
  return X.translation().cwiseAbs().maxCoeff() <= kTiny &&
         (X.linear() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() <= kTiny;
}

std::string Closest(const std::vector<std::string>& names) {
  std::string list;
  for (size_t i = 0; i < names.size() && i < 12; ++i) list += (i ? ", " : "") + names[i];
  if (names.size() > 12) list += ", ...";
  return list;
}

struct Builder {
  Builder(const osim::Model& model, const OpenSimImportOptions& import_options,
          std::map<std::string, std::string> coupled_coordinates)
      : m(model), options(import_options), coupled(std::move(coupled_coordinates)) {}

  const osim::Model& m;
  const OpenSimImportOptions& options;
  OpenSimImport out;

  std::vector<const osim::Joint*> baked;               // ground -> clamp
  std::vector<const osim::Joint*> chain;               // clamp -> endpoint
  std::set<std::string> chain_bodies;                  // clamp and the bodies after it on the path
  std::map<std::string, Eigen::Isometry3d> X_G_baked;  // ground and bodies up to the clamp
  std::map<std::string, double> defaults;
  std::map<std::string, std::string> coupled;  // dependent coordinate -> report text

  [[noreturn]] void Fail(const std::string& what) const { throw Error(m.source + ": " + what); }

  const osim::Joint* ParentJoint(const std::string& body) const {
    const osim::Joint* found = nullptr;
    for (const osim::Joint& j : m.joints) {
      if (j.child_body != body) continue;
      if (found) {
        throw Error(m.source + ":" + std::to_string(j.line) + ": body '" + body +
                    "' is the child of two joints ('" + found->name + "' and '" + j.name +
                    "'); closed loops are not supported");
      }
      found = &j;
    }
    return found;
  }

  void CheckBody(const std::string& body, const char* option) const {
    if (std::find(m.bodies.begin(), m.bodies.end(), body) == m.bodies.end()) {
      Fail(std::string(option) + " body '" + body + "' does not exist; the bodies are " +
           Closest(m.bodies));
    }
  }

  void ChoosePath() {
    CheckBody(options.clamp_body, "--clamp");
    CheckBody(options.endpoint_body, "--endpoint");
    std::vector<const osim::Joint*> path;  // ground -> endpoint
    std::vector<std::string> names = {options.endpoint_body};
    for (std::string body = options.endpoint_body; body != m.ground;) {
      const osim::Joint* j = ParentJoint(body);
      if (!j) Fail("body '" + body + "' is connected to the ground by no joint");
      if (path.size() > m.joints.size()) Fail("the joints form a loop above body '" + body + "'");
      path.insert(path.begin(), j);
      body = j->parent_body;
      names.insert(names.begin(), body);
    }
    auto clamp = std::find(names.begin(), names.end(), options.clamp_body);
    if (clamp == names.end()) {
      Fail("--clamp body '" + options.clamp_body + "' is not on the path from ground to the " +
           "--endpoint body '" + options.endpoint_body + "' (" + util::Join(names, " -> ") +
           "); clamp a body between the ground and the endpoint");
    }
    if (options.clamp_body == options.endpoint_body) {
      Fail("--clamp and --endpoint are the same body '" + options.clamp_body +
           "': no joint would be left between them");
    }
    const size_t k = clamp - names.begin();  // joints [0, k) are baked
    for (size_t i = 0; i < path.size(); ++i) (i < k ? baked : chain).push_back(path[i]);
    for (size_t i = k; i < names.size(); ++i) chain_bodies.insert(names[i]);
    for (const auto& [name, c] : m.coordinates) defaults[name] = c.default_value;
    Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
    X_G_baked[m.ground] = X;
    for (const osim::Joint* j : baked) {
      X = X * osim::JointTransform(m, *j, defaults);
      X_G_baked[j->child_body] = X;
    }
  }

  void Build() {
    ChoosePath();
    for (const std::string& u : options.unlock) {
      if (!m.coordinates.count(u)) {
        std::vector<std::string> names;
        for (const auto& [name, c] : m.coordinates) names.push_back(name);
        Fail("--unlock names coordinate '" + u + "', which does not exist; the coordinates are " +
             Closest(names));
      }
    }
    LimbDescription& d = out.description;
    d.name = m.name;
    d.source = m.source;
    d.root_link = m.ground;
    d.links = {m.ground};
    std::set<std::string> used_names(m.bodies.begin(), m.bodies.end());
    auto unique = [&](const std::string& name) {
      if (!used_names.insert(name).second) {
        Fail("the generated URDF name '" + name + "' collides with a body, joint or coordinate " +
             "of the same name; rename one in the .osim");
      }
      return name;
    };
    if (options.clamp_body != m.ground) {
      JointSpec clamp;
      clamp.name = unique(options.clamp_body + "_clamp");
      clamp.type = JointType::kFixed;
      clamp.parent_link = m.ground;
      clamp.child_link = options.clamp_body;
      clamp.origin = X_G_baked.at(options.clamp_body);
      d.joints.push_back(clamp);
      d.links.push_back(options.clamp_body);
    }
    // Which axis carries each coordinate with the identity: the first, in emission order.
    std::map<std::string, const Axis*> carrier;
    auto emission = [](const osim::Joint& j) {
      std::vector<const Axis*> order;
      for (const Axis& a : j.axes)
        if (!a.rotation) order.push_back(&a);
      for (const Axis& a : j.axes)
        if (a.rotation) order.push_back(&a);
      return order;
    };
    // Coordinates of the chain joints (a coupler may make an axis follow another joint's).
    std::set<std::string> chain_coordinates;
    for (const osim::Joint* j : chain) {
      for (const std::string& c : j->coordinates) {
        if (!coupled.count(c)) chain_coordinates.insert(c);
      }
    }
    // An axis that does not move with a chain coordinate is fixed at its default value; one
    // whose function is constant over its coordinate's range (ConstantCoupling: e.g. a
    // SimmSpline of zeros) is fixed at that constant, as Model compile folds it: written into
    // the fixed transform, not as a joint.
    auto moves = [&](const Axis& a) {
      return !a.coordinate.empty() && chain_coordinates.count(a.coordinate) != 0;
    };
    auto flat_value = [&](const Axis& a, double* value) {
      const osim::Coordinate& c = m.coordinates.at(a.coordinate);
      return ConstantCoupling(a.function, c.lower, c.upper, value);
    };
    auto constant = [&](const Axis& a) {
      double value = 0.0;
      return !moves(a) || flat_value(a, &value);
    };
    auto constant_value = [&](const Axis& a) {
      double value = 0.0;
      if (moves(a) && flat_value(a, &value)) return value;
      return a.function.Value(a.coordinate.empty() ? 0.0 : defaults.at(a.coordinate));
    };
    for (const osim::Joint* j : chain) {
      for (const Axis* a : emission(*j)) {
        if (!constant(*a) && a->function.is_identity() && !carrier.count(a->coordinate)) {
          carrier[a->coordinate] = a;
        }
      }
    }
    OpenSimReportTable joints{
        "Joints (OpenSim -> URDF)", {"joint", "type", "parent -> child", "URDF joints"}, {}};
    for (const osim::Joint* j : chain) {
      std::vector<std::string> expansion;
      Eigen::Isometry3d pending = j->X_Pb_P;
      std::string link = j->parent_body;
      size_t first = d.joints.size();
      for (const Axis* a : emission(*j)) {
        if (constant(*a)) {
          pending = pending * osim::AxisMotion(*a, constant_value(*a));
          if (moves(*a)) {  // (a constant function of a chain coordinate: say so)
            const double scale = a->rotation ? 180.0 / M_PI : 1e3;
            expansion.push_back(j->name + "_" + a->name + " fixed at " +
                                Num(constant_value(*a) * scale) + (a->rotation ? " deg" : " mm") +
                                " (" + FunctionKindName(a->function.kind()) + " of " +
                                a->coordinate + ", constant over its range)");
          }
          continue;
        }
        JointSpec s;
        const bool carries = carrier.count(a->coordinate) && carrier[a->coordinate] == a;
        s.name = unique(carries ? a->coordinate : j->name + "_" + a->name);
        s.type = a->rotation ? JointType::kRevolute : JointType::kPrismatic;
        s.parent_link = link;
        s.child_link = unique(j->name + "_" + a->name + "_link");
        s.origin = pending;
        s.axis = a->axis;
        s.coordinate = a->coordinate;
        s.coupling = carries ? Function::Linear(1, 0) : a->function;
        pending = Eigen::Isometry3d::Identity();
        link = s.child_link;
        std::string text =
            s.name + " (" + (a->rotation ? "revolute" : "prismatic") + ", " + a->name;
        if (!carries) {
          text += std::string(", ") + (a->function.is_linear() ? "mimic" : "coupling") + " " +
                  FunctionKindName(a->function.kind()) + " of " + a->coordinate;
        }
        expansion.push_back(text + ")");
        d.joints.push_back(s);
        d.links.push_back(s.child_link);
      }
      const Eigen::Isometry3d last = pending * j->X_Cb_C.inverse();
      if (d.joints.size() > first && IsIdentity(last)) {
        // The last movable joint ends in the child body itself.
        JointSpec& s = d.joints.back();
        used_names.erase(s.child_link);
        s.child_link = j->child_body;
        d.links.back() = j->child_body;
      } else {
        JointSpec f;
        f.name = unique(d.joints.size() > first ? j->name + "_child_offset" : j->name);
        f.type = JointType::kFixed;
        f.parent_link = link;
        f.child_link = j->child_body;
        f.origin = last;
        d.joints.push_back(f);
        d.links.push_back(j->child_body);
        expansion.push_back(f.name + " (fixed)");
      }
      joints.rows.push_back(
          {j->name, j->type, j->parent_body + " -> " + j->child_body, util::Join(expansion, "; ")});
    }
    // Coordinates of the chain joints: the columns.
    OpenSimReportTable coordinates{
        "Coordinates (independent: one column each)",
        {"coordinate", "unit", "default", "range", "locked", "carried by / drives"},
        {}};
    for (const osim::Joint* j : chain) {
      for (const std::string& name : j->coordinates) {
        const osim::Coordinate& c = m.coordinates.at(name);
        if (coupled.count(name)) {
          coordinates.rows.push_back(
              {name, c.rotational ? "deg" : "mm", "-", "-", "coupled", coupled.at(name)});
          continue;
        }
        CoordinateSpec spec;
        spec.name = name;
        spec.type = c.rotational ? JointType::kRevolute : JointType::kPrismatic;
        spec.default_value = c.default_value;
        spec.lower = c.lower;
        spec.upper = c.upper;
        spec.locked = c.locked && std::find(options.unlock.begin(), options.unlock.end(), name) ==
                                      options.unlock.end();
        spec.joint = carrier.count(name) ? name : "";
        if (!carrier.count(name)) unique(name);
        d.coordinates.push_back(spec);
        std::vector<std::string> driven;
        for (const JointSpec& s : d.joints) {
          if (s.type != JointType::kFixed && s.coordinate == name && s.name != name) {
            driven.push_back(s.name);
          }
        }
        std::string role = carrier.count(name) ? "joint " + name : "free-standing";
        if (!driven.empty()) role += "; drives " + util::Join(driven, ", ");
        const double scale = c.rotational ? 180.0 / M_PI : 1e3;
        coordinates.rows.push_back(
            {name, c.rotational ? "deg" : "mm", Num(c.default_value * scale),
             std::isfinite(c.lower) ? Num(c.lower * scale) + " .. " + Num(c.upper * scale) : "-",
             spec.locked ? "locked" : (c.locked ? "unlocked" : "no"), role});
      }
    }
    for (const osim::Joint* j : baked) {
      for (const std::string& name : j->coordinates) {
        coordinates.rows.push_back(
            {name, m.coordinates.at(name).rotational ? "deg" : "mm",
             Num(m.coordinates.at(name).default_value *
                 (m.coordinates.at(name).rotational ? 180.0 / M_PI : 1e3)),
             "-", "baked", "fixed at its default (joint '" + j->name + "' is above the clamp)"});
      }
    }
    d.transducer.link = options.endpoint_body;
    d.transducer.endpoint = options.endpoint_point;
    d.transducer.axes_in_world = true;
    d = NormalizeCoordinates(d);
    // The .osim default values are the nominal posture (written as isowrench:posture).
    for (const CoordinateSpec& c : d.coordinates)
      d.nominal_posture.emplace_back(c.name, c.default_value);
    out.tables.push_back(joints);
    out.tables.push_back(coordinates);
    Muscles();
    Bodies();
    UnitsCheck();
    for (const std::string& w : m.warnings) out.warnings.push_back(w);
    out.version = m.version;
  }

  void Bodies() {
    OpenSimReportTable bodies{"Bodies", {"body", "role"}, {}};
    for (const std::string& b : m.bodies) {
      std::string role;
      if (b == options.clamp_body)
        role = "clamped (fixed to the world)";
      else if (b == options.endpoint_body)
        role = "endpoint (transducer)";
      else if (chain_bodies.count(b))
        role = "chain";
      else if (X_G_baked.count(b))
        role = b == m.ground ? "ground (world frame)"
                             : "above the clamp: baked at default coordinates";
      else
        role = "dropped (off the clamp -> endpoint path)";
      bodies.rows.push_back({b, role});
    }
    out.tables.insert(out.tables.begin(), bodies);
  }

  // A coordinate that is a column of the import (not baked, not dropped, not coupled).
  bool IsColumn(const std::string& name) const {
    for (const CoordinateSpec& c : out.description.coordinates) {
      if (c.name == name) return true;
    }
    return false;
  }

  // The value OpenSim gives a coordinate that is not a column: its default (clamped to its
  // range for a MovingPathPoint, as MovingPathPoint::getLocation does).
  double Fixed(const std::string& name, bool clamp) const {
    const osim::Coordinate& c = m.coordinates.at(name);
    return clamp ? std::clamp(c.default_value, c.lower, c.upper) : c.default_value;
  }

  // Fill `point` (link and position already set for the fixed part) with the moving components
  // and the active range of a MovingPathPoint or ConditionalPathPoint. Coordinates that are not
  // columns are constants at their default. A conditional point on such a coordinate that is
  // inactive gets active_lower > active_upper (the caller drops it). Returns why the muscle
  // cannot be imported, or "".
  std::string MovingOrConditional(const osim::Point& p, PathPoint& point) const {
    const std::string what = p.type + " '" + p.name + "'";
    auto unsupported = [&](const std::string& name) -> std::string {
      if (!coupled.count(name)) return "";
      return what + " depends on '" + name + "', a coupled coordinate (" + coupled.at(name) +
             "); points moved by coupled coordinates are not supported";
    };
    if (p.conditional) {
      const std::string& name = p.condition_coordinate;
      if (std::string why = unsupported(name); !why.empty()) return why;
      if (IsColumn(name)) {
        if (!(p.range[0] <= p.range[1])) {
          point.active_lower = 1.0;  // never active in OpenSim: dropped
          point.active_upper = 0.0;
          return "";
        }
        point.active_coordinate = name;
        point.active_lower = p.range[0];
        point.active_upper = p.range[1];
      } else {
        const double q = Fixed(name, false);
        const bool active =
            q >= p.range[0] - kActiveRangeTolerance && q <= p.range[1] + kActiveRangeTolerance;
        point.active_lower = active ? 0.0 : 1.0;
        point.active_upper = 0.0;
      }
      return "";
    }
    // MovingPathPoint: one coordinate (or none) for the three components.
    const std::string& name = p.moving_coordinates[0];
    if (std::string why = unsupported(name); !why.empty()) return why;
    Eigen::Vector3d r;
    for (int i = 0; i < 3; ++i) {
      r[i] = p.functions[i].Value(name.empty() ? 0.0 : Fixed(name, true));
    }
    const Eigen::Isometry3d X =
        point.link == m.ground ? X_G_baked.at(p.body) * p.X_body_frame : p.X_body_frame;
    point.position = X * r;
    if (name.empty() || !IsColumn(name)) return "";
    if ((X.linear() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-15) {
      return what + " on body '" + p.body + "' (above the clamp, so in the ground frame) moves " +
             "with chain coordinate '" + name + "' along axes rotated from the ground's; " +
             "moving points are supported along their link's axes only";
    }
    // Component i in the link frame = X.translation()[i] + f_i(q).
    for (int i = 0; i < 3; ++i) {
      if (p.functions[i].kind() == FunctionKind::kConstant) continue;
      MovingComponent c;
      c.axis = i;
      c.coordinate = name;
      c.function = urdf_coordinates::ComposeLinear(1.0, X.translation()[i], p.functions[i]);
      point.moving.push_back(c);
    }
    return "";
  }

  // ---- wrapping (docs/opensim.md "Wrapping") ----

  const osim::WrapObject* FindWrapObject(const std::string& name) const {
    // PathWrap::extendConnectToModel: the first frame (in component order) holding the name.
    for (const osim::WrapObject& w : m.wrap_objects) {
      if (w.name == name) return &w;
    }
    return nullptr;
  }

  [[noreturn]] void FailAt(int line, const std::string& what) const {
    throw Error(m.source + ":" + std::to_string(line) + ": " + what);
  }

  // Body-fixed X-Y-Z angles of R = Rx(a) Ry(b) Rz(c) (the inverse of osim::BodyFixedXyz).
  static Eigen::Vector3d BodyFixedXyzAngles(const Eigen::Matrix3d& R) {
    const double b = std::asin(std::clamp(R(0, 2), -1.0, 1.0));
    if (std::abs(R(0, 2)) < 1.0 - 1e-12) {
      return Eigen::Vector3d(std::atan2(-R(1, 2), R(2, 2)), b, std::atan2(-R(0, 1), R(0, 0)));
    }
    return Eigen::Vector3d(std::atan2(R(2, 1), R(1, 1)), b, 0.0);
  }

  // The muscle's PathWrapSet as PathWrapSpecs (ranges renumbered to the imported points), or
  // why the muscle cannot be imported. @throws Error for what OpenSim itself would refuse or we
  // do not support (an unknown object, WrapCylinderObst, bad dimensions, method or quadrant).
  std::string Wraps(const osim::Muscle& muscle, const std::vector<int>& kept, MuscleSpec& spec) {
    const int n = static_cast<int>(muscle.points.size());
    for (const osim::PathWrap& pw : muscle.wraps) {
      const std::string what = "muscle '" + muscle.name + "' PathWrap '" + pw.object + "'";
      const osim::WrapObject* o = FindWrapObject(pw.object);
      if (!o) {
        std::vector<std::string> names;
        for (const osim::WrapObject& w : m.wrap_objects) names.push_back(w.name);
        FailAt(pw.line, what + ": no body has a wrap object of that name" +
                            (names.empty() ? "" : "; the wrap objects are " + Closest(names)));
      }
      const std::string object = o->type + " '" + o->name + "' on '" + o->body + "'";
      if (o->type == "WrapCylinderObst" || o->type == "WrapDoubleCylinderObst") {
        FailAt(o->line, what + " wraps over " + object +
                            ": WrapCylinderObst and WrapDoubleCylinderObst are not supported yet");
      }
      if (o->type != "WrapCylinder" && o->type != "WrapSphere" && o->type != "WrapEllipsoid" &&
          o->type != "WrapTorus") {
        FailAt(o->line,
               what + " wraps over " + object + ": wrap object type '" + o->type +
                   "' is not supported (WrapCylinder, WrapSphere, WrapEllipsoid, WrapTorus)");
      }
      if (!chain_bodies.count(o->body) && !X_G_baked.count(o->body)) {
        return "wrap object '" + o->name + "' is on body '" + o->body +
               "', which is off the imported chain";
      }
      PathWrapSpec w;
      w.object = o->name;
      if (pw.method == "hybrid" || pw.method == "Hybrid" || pw.method == "HYBRID" ||
          pw.method == "Unassigned") {
        w.method = WrapMethod::kHybrid;
      } else if (pw.method == "midpoint" || pw.method == "Midpoint" || pw.method == "MIDPOINT") {
        w.method = WrapMethod::kMidpoint;
      } else if (pw.method == "axial" || pw.method == "Axial" || pw.method == "AXIAL") {
        w.method = WrapMethod::kAxial;
      } else {
        FailAt(pw.line,
               what + ": method '" + pw.method +
                   "' is not one of hybrid, midpoint, axial (PathWrap::extendConnectToModel)");
      }
      // OpenSim's range counts every point of the PathPointSet; the import drops conditional
      // points that are never active, whose place the scan of applyWrapObjects skips anyway.
      const int first = pw.range[0] < 1 ? 1 : pw.range[0];
      const int last = pw.range[1] < 1 ? n : pw.range[1];
      if (first > n || last > n || first > last) {
        FailAt(pw.line, what + ": range " + std::to_string(pw.range[0]) + " " +
                            std::to_string(pw.range[1]) + " is outside the path's " +
                            std::to_string(n) + " points");
      }
      int new_first = -1, new_last = -1;
      for (int i = first - 1; i < last && new_first < 0; ++i) new_first = kept[i];
      for (int i = last - 1; i >= first - 1 && new_last < 0; --i) new_last = kept[i];
      if (new_first < 0) {
        return "wrap '" + o->name + "': range " + std::to_string(pw.range[0]) + " " +
               std::to_string(pw.range[1]) +
               " holds no point that is ever in the path (OpenSim would stop applying its wraps)";
      }
      w.range_first = pw.range[0] < 1 ? -1 : new_first + 1;
      w.range_last = pw.range[1] < 1 ? -1 : new_last + 1;
      spec.wraps.push_back(w);
    }
    return "";
  }

  // Add the wrap object `name` (checked by Wraps) to the description once: on its body's link,
  // or on the ground at the baked pose when its body is above the clamp.
  void AddWrapObject(const std::string& name) {
    for (const WrapObjectSpec& w : out.description.wrap_objects) {
      if (w.name == name) return;
    }
    const osim::WrapObject& o = *FindWrapObject(name);
    const std::string what = o.type + " '" + o.name + "' on '" + o.body + "'";
    WrapObjectSpec w;
    w.name = o.name;
    w.active = o.active;
    try {
      w.quadrant = WrapQuadrant::Parse(o.quadrant);
    } catch (const Error& e) {
      FailAt(o.line, what + ": " + e.what());
    }
    auto positive = [&](double v, const char* property) {
      if (!(v > 0.0) || !std::isfinite(v)) {
        FailAt(o.line, what + ": " + property + " " + Num(v) + " m must be > 0");
      }
      return v;
    };
    if (o.type == "WrapCylinder") {
      w.shape = WrapShape::kCylinder;
      w.radius = positive(o.radius, "radius");
      w.length = positive(o.length, "length");
    } else if (o.type == "WrapSphere") {
      w.shape = WrapShape::kSphere;
      w.radius = positive(o.radius, "radius");
    } else if (o.type == "WrapEllipsoid") {
      w.shape = WrapShape::kEllipsoid;
      for (int i = 0; i < 3; ++i) positive(o.dimensions[i], "dimensions");
      w.radii = o.dimensions;
    } else {
      w.shape = WrapShape::kTorus;
      w.inner_radius = positive(o.inner_radius, "inner_radius");
      w.outer_radius = positive(o.outer_radius, "outer_radius");
      if (!(w.inner_radius < w.outer_radius)) {
        FailAt(o.line, what + ": inner_radius " + Num(w.inner_radius) +
                           " m is not below outer_radius " + Num(w.outer_radius) + " m");
      }
    }
    if (chain_bodies.count(o.body)) {
      w.link = o.body;
      w.translation = o.translation;
      w.xyz_body_rotation = o.xyz_body_rotation;
    } else {  // above the clamp (or the ground): fixed in the world at the baked pose
      w.link = m.ground;
      WrapObjectSpec local;
      local.translation = o.translation;
      local.xyz_body_rotation = o.xyz_body_rotation;
      const Eigen::Isometry3d X = X_G_baked.at(o.body) * local.Pose();
      w.translation = X.translation();
      w.xyz_body_rotation = BodyFixedXyzAngles(X.linear());
    }
    out.description.wrap_objects.push_back(w);
  }

  // "constant", "millard2012 compliant", "millard2012 rigid", "thelen2003 compliant",
  // "thelen2003 rigid-tendon limit" (tendon_slack_length 0 with a compliant tendon), ...
  static std::string ForceModelSummary(const MuscleForceSpec& f) {
    std::string text = ForceModelName(f.model);
    if (f.model == ForceModelType::kConstant) return text;
    if (f.ignore_tendon_compliance) return text + " rigid";
    return text + (f.tendon_slack_length > 0 ? " compliant" : " rigid-tendon limit");
  }

  // Checks an imported muscle's force model with OpenSim's rules (an Error with the file and
  // line: OpenSim refuses such a model) and warns where OpenSim gives no number or the model is
  // not modelled. Returns the status words for the report ("" when nothing to say).
  std::string ForceModelStatus(const osim::Muscle& muscle, const MuscleSpec& spec) {
    const std::string where = m.source + ":" + std::to_string(muscle.line) + ": ";
    if (!muscle.force_note.empty()) {
      out.warnings.push_back("muscle '" + muscle.name + "' (line " + std::to_string(muscle.line) +
                             "): " + muscle.force_note);
      return "constant force (" + muscle.type + " not modelled)";
    }
    std::string limitation;
    try {
      limitation = MuscleForceModel(spec.name, spec.max_force, spec.force).opensim_limitation();
    } catch (const Error& e) {
      throw Error(where + e.what() + " (OpenSim refuses this " + muscle.type + ")");
    }
    if (limitation.empty()) return "";
    out.warnings.push_back("muscle '" + muscle.name + "' (" + muscle.type + ", line " +
                           std::to_string(muscle.line) + "): " + limitation +
                           "; OpenSim gives no force for this muscle");
    return "OpenSim gives no force (see warning)";
  }

  void Muscles() {
    OpenSimReportTable muscles{
        "Muscles", {"muscle", "type", "max force (N)", "points", "force model", "status"}, {}};
    for (const osim::Muscle& muscle : m.muscles) {
      std::string problem;
      MuscleSpec spec;
      spec.name = muscle.name;
      spec.max_force = muscle.max_force;
      spec.force = muscle.force;
      // kept[i]: the index in spec.path of .osim point i (PathPointSet order), or -1.
      std::vector<int> kept(muscle.points.size(), -1);
      for (size_t index = 0; index < muscle.points.size(); ++index) {
        const osim::Point& p = muscle.points[index];
        if (!problem.empty()) break;
        PathPoint point;
        if (chain_bodies.count(p.body)) {
          point.link = p.body;
          point.position = p.X_body_frame * p.location;
        } else if (X_G_baked.count(p.body)) {
          point.link = m.ground;
          point.position = X_G_baked.at(p.body) * (p.X_body_frame * p.location);
        } else {
          problem =
              "point '" + p.name + "' is on body '" + p.body + "', which is off the imported chain";
          break;
        }
        if (p.moving || p.conditional) {
          problem = MovingOrConditional(p, point);
          if (!problem.empty()) break;
          if (p.conditional && point.active_coordinate.empty() &&
              !(point.active_lower <= point.active_upper)) {
            continue;  // a conditional point on a constant coordinate that is never active
          }
        }
        kept[index] = static_cast<int>(spec.path.size());
        spec.path.push_back(point);
      }
      if (problem.empty()) problem = Wraps(muscle, kept, spec);
      if (problem.empty() && !(muscle.max_force > 0.0)) {
        problem = "max_isometric_force " + Num(muscle.max_force) + " N is not positive";
      }
      if (problem.empty() &&
          std::count_if(spec.path.begin(), spec.path.end(),
                        [](const PathPoint& p) { return p.active_coordinate.empty(); }) < 2) {
        problem = spec.path.size() < 2 ? "fewer than two points remain"
                                       : "fewer than two points are always in the path (the "
                                         "others are ConditionalPathPoints)";
      }
      std::string status = "imported";
      const auto moving = std::count_if(spec.path.begin(), spec.path.end(),
                                        [](const PathPoint& p) { return !p.moving.empty(); });
      const auto conditional =
          std::count_if(spec.path.begin(), spec.path.end(),
                        [](const PathPoint& p) { return !p.active_coordinate.empty(); });
      if (moving) status += ", " + std::to_string(moving) + " moving";
      if (conditional) status += ", " + std::to_string(conditional) + " conditional";
      if (moving || conditional) status += (moving + conditional > 1 ? " points" : " point");
      if (!problem.empty()) {
        status = "skipped: " + problem;
        out.warnings.push_back("muscle '" + muscle.name + "' (line " + std::to_string(muscle.line) +
                               ") skipped: " + problem);
      } else {
        for (const PathWrapSpec& w : spec.wraps) AddWrapObject(w.object);
        const std::string force_status = ForceModelStatus(muscle, spec);
        out.description.muscles.push_back(spec);
        if (!spec.wraps.empty()) {
          std::vector<std::string> names;
          for (const PathWrapSpec& w : spec.wraps) names.push_back(w.object);
          status += ", wraps over " + util::Join(names, ", ");
        }
        if (!force_status.empty()) status += "; " + force_status;
      }
      muscles.rows.push_back({muscle.name, muscle.type, Num(muscle.max_force),
                              std::to_string(muscle.points.size()), ForceModelSummary(spec.force),
                              status});
    }
    out.tables.push_back(muscles);
  }

  void UnitsCheck() {
    double largest = 0.0;
    for (const osim::Joint& j : m.joints) {
      largest = std::max({largest, j.X_Pb_P.translation().norm(), j.X_Cb_C.translation().norm()});
    }
    for (const osim::Muscle& muscle : m.muscles) {
      for (const osim::Point& p : muscle.points) largest = std::max(largest, p.location.norm());
    }
    std::string units = m.length_units;
    std::transform(units.begin(), units.end(), units.begin(), ::tolower);
    const bool says_mm =
        units.find("mm") != std::string::npos || units.find("milli") != std::string::npos;
    const bool says_cm =
        units.find("cm") != std::string::npos || units.find("centi") != std::string::npos;
    // Limb offsets in metres are below a metre; the same limb in mm has offsets of 10s of mm.
    if ((says_mm || says_cm) && largest < 1.0) {
      out.warnings.push_back("<length_units> says '" + m.length_units +
                             "' but the largest offset is " + Num(largest) +
                             ": the values look like metres; read as metres, nothing "
                             "rescaled");
    } else if (!says_mm && !says_cm && largest > 5.0) {
      out.warnings.push_back("the largest offset is " + Num(largest) + " m (<length_units> '" +
                             m.length_units +
                             "'): the values look like millimetres; read as "
                             "metres, nothing rescaled");
    }
  }
};

}  // namespace

// CoordinateCouplerConstraint q_D = f(q_I): every axis driven by D through the identity (or a
// linear function through the origin, a q_D) is driven by I through f (or a f). D is then no
// longer independent: OpenSim's moment arms about I include the coupled motion, as here.
std::map<std::string, std::string> ApplyCouplers(osim::Model& model) {
  std::map<std::string, std::string> coupled;
  for (const osim::Coupler& c : model.couplers) {
    const std::string what = "constraint '" + c.name + "' (CoordinateCouplerConstraint, line " +
                             std::to_string(c.line) + ")";
    std::string problem;
    for (const osim::Joint& j : model.joints) {
      for (const Axis& a : j.axes) {
        if (a.coordinate != c.dependent || a.function.kind() == FunctionKind::kConstant) continue;
        if (!a.function.is_linear() || a.function.intercept() != 0.0) {
          problem = "'" + c.dependent + "' drives axis '" + a.name + "' of joint '" + j.name +
                    "' through a " + FunctionKindName(a.function.kind()) + " function";
        }
      }
    }
    if (!problem.empty() || coupled.count(c.independent)) {
      model.warnings.push_back(
          what + " is not imported (" +
          (problem.empty() ? "its independent coordinate is itself coupled" : problem) + "): '" +
          c.dependent + "' stays independent");
      continue;
    }
    for (osim::Joint& j : model.joints) {
      for (Axis& a : j.axes) {
        if (a.coordinate != c.dependent || a.function.kind() == FunctionKind::kConstant) continue;
        const double slope = a.function.slope();
        a.function = slope == 1.0 ? c.function : Function::Multiplier(c.function, slope);
        a.coordinate = c.independent;
      }
    }
    coupled[c.dependent] = "= " + std::string(FunctionKindName(c.function.kind())) + " of " +
                           c.independent + " (" + what + ")";
  }
  return coupled;
}

OpenSimImport ImportOpenSimString(const std::string& xml, const std::string& source_name,
                                  const OpenSimImportOptions& options) {
  const std::string source = source_name.empty() ? "<string>" : source_name;
  osim::Model model = osim::ReadModel(xml, source);
  std::map<std::string, std::string> coupled = ApplyCouplers(model);
  Builder builder(model, options, std::move(coupled));
  builder.Build();
  // Plausibility as for a URDF, the endpoint point given in the options included (one place:
  // DescriptionWarnings, include/isowrench/input_checks.hpp).
  const Eigen::Vector3d& p = options.endpoint_point;
  for (std::string& w : DescriptionWarnings(builder.out.description, [&](const std::string& name) {
         return name.empty() ? "endpoint point " + Num(p.x()) + "," + Num(p.y()) + "," +
                                   Num(p.z()) + " (m in body '" + options.endpoint_body + "')"
                             : source;
       })) {
    builder.out.warnings.push_back(std::move(w));
  }
  return std::move(builder.out);
}

OpenSimImport ImportOpenSimFile(const std::string& path, const OpenSimImportOptions& options) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("cannot open OpenSim model '" + path + "'");
  std::stringstream buffer;
  buffer << in.rdbuf();
  return ImportOpenSimString(buffer.str(), path, options);
}

std::string FormatOpenSimReport(const OpenSimImport& import) {
  std::ostringstream o;
  for (const OpenSimReportTable& t : import.tables) {
    std::vector<size_t> width(t.header.size(), 0);
    for (size_t i = 0; i < t.header.size(); ++i) width[i] = t.header[i].size();
    for (const auto& row : t.rows) {
      for (size_t i = 0; i < row.size() && i < width.size(); ++i) {
        width[i] = std::max(width[i], row[i].size());
      }
    }
    o << t.title << "\n";
    auto line = [&](const std::vector<std::string>& cells) {
      std::string s = " ";
      for (size_t i = 0; i < cells.size(); ++i) {
        std::string cell = cells[i];
        if (i + 1 < cells.size()) cell.resize(std::max(width[i], cell.size()), ' ');
        s += " " + cell;
      }
      o << s << "\n";
    };
    line(t.header);
    for (const auto& row : t.rows) line(row);
    o << "\n";
  }
  if (!import.warnings.empty()) {
    o << "Warnings (" << import.warnings.size() << ")\n";
    for (const std::string& w : import.warnings) o << "  ! " << w << "\n";
  }
  return o.str();
}

}  // namespace isowrench
