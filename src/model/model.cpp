// Model: validation of a LimbDescription, its compiled flat chain, and the KDL chain built from
// it for the tests' independent cross-check.

#include "isowrench/model.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <map>
#include <set>

#include "isowrench/engine.hpp"
#include "isowrench/error.hpp"
#include "isowrench/input_checks.hpp"
#include "kinematics/kinematics_impl.hpp"
#include "model/function_impl.hpp"
#include "model/model_impl.hpp"
#include "muscle/tendon_check.hpp"
#include "util/text.hpp"

namespace isowrench {
namespace {

KDL::Vector ToKdl(const Eigen::Vector3d& v) { return KDL::Vector(v.x(), v.y(), v.z()); }

KDL::Frame ToKdl(const Eigen::Isometry3d& t) {
  const Eigen::Matrix3d& R = t.linear();
  return KDL::Frame(KDL::Rotation(R(0, 0), R(0, 1), R(0, 2), R(1, 0), R(1, 1), R(1, 2), R(2, 0),
                                  R(2, 1), R(2, 2)),
                    ToKdl(t.translation()));
}

// A moving component or a conditional point must name an independent coordinate.
void CheckPointCoordinate(const LimbDescription& d, const std::string& what,
                          const std::string& name) {
  try {
    FindCoordinate(d, name);
  } catch (const Error& e) {
    throw Error(what + ": " + e.what());
  }
}

void Validate(const LimbDescription& d) {
  const std::string model = "model '" + d.name + "'";
  if (d.joints.empty())
    throw Error(model + " has no joints between '" + d.root_link + "' and the endpoint");
  std::set<std::string> names;
  std::set<std::string> links(d.links.begin(), d.links.end());
  if (links.size() != d.links.size()) throw Error(model + ": a link name appears twice");
  std::string parent = d.root_link;
  int movable = 0;
  for (const JointSpec& j : d.joints) {
    const std::string what = model + ", joint '" + j.name + "'";
    if (j.name.empty()) throw Error(model + ": a joint has no name");
    if (!names.insert(j.name).second) throw Error(what + " is defined twice");
    if (j.parent_link != parent) {
      throw Error(what + ": parent link '" + j.parent_link +
                  "' does not continue the chain (expected '" + parent + "')");
    }
    if (!links.count(j.child_link))
      throw Error(what + ": child link '" + j.child_link + "' is not listed");
    parent = j.child_link;
    if (!j.origin.matrix().allFinite()) throw Error(what + ": origin is not finite");
    if (j.type == JointType::kFixed) continue;
    ++movable;
    if (!j.axis.allFinite() || std::abs(j.axis.norm() - 1.0) > 1e-9) {
      throw Error(what + ": axis must be a finite unit vector");
    }
    if (!std::isfinite(j.stiffness) || j.stiffness < 0) {
      throw Error(what + ": stiffness " + util::FormatNumber(j.stiffness) +
                  " must be finite and >= 0");
    }
    CheckStiffnessValue(j.stiffness, what);
  }
  if (movable == 0) throw Error(model + " has no movable joint");
  const TransducerSpec& t = d.transducer;
  if (t.link != parent) {
    throw Error(model + ": transducer link '" + t.link + "' is not the chain's last link '" +
                parent + "'");
  }
  if (!t.endpoint.allFinite()) throw Error(model + ": transducer endpoint position is not finite");
  if (!t.rotation.allFinite() ||
      !(t.rotation.transpose() * t.rotation).isApprox(Eigen::Matrix3d::Identity(), 1e-9)) {
    throw Error(model + ": transducer rotation is not a rotation matrix");
  }
  for (int i = 0; i < 6; ++i) {
    if (!std::isfinite(t.stiffness[i]) || t.stiffness[i] < 0) {
      throw Error(model + ": transducer stiffness " + DofName(i) + " = " +
                  util::FormatNumber(t.stiffness[i]) + " must be finite and >= 0");
    }
    CheckStiffnessValue(t.stiffness[i], model + ": transducer " + DofName(i));
  }
  std::set<std::string> muscles;
  for (const MuscleSpec& m : d.muscles) {
    const std::string what = model + ", muscle '" + m.name + "'";
    if (!muscles.insert(m.name).second) throw Error(what + " is defined twice");
    if (!std::isfinite(m.max_force) || m.max_force <= 0) {
      throw Error(what + ": max_force " + util::FormatNumber(m.max_force) +
                  " N must be finite and > 0");
    }
    if (m.path.size() < 2) throw Error(what + " needs at least two path points");
    try {
      static_cast<void>(MuscleForceModel(m.name, m.max_force, m.force));  // its parameter checks
    } catch (const Error& e) {
      throw Error(model + ": " + e.what());
    }
    for (const PathPoint& p : m.path) {
      if (!links.count(p.link)) {
        throw Error(what + ": path point on link '" + p.link + "', which is not on the chain");
      }
      if (!p.position.allFinite()) throw Error(what + ": a path point position is not finite");
      const std::string point = what + ", point on '" + p.link + "'";
      bool axes[3] = {false, false, false};
      for (const MovingComponent& c : p.moving) {
        if (c.axis < 0 || c.axis > 2) {
          throw Error(point + ": moving axis " + std::to_string(c.axis) + " is not 0, 1 or 2");
        }
        if (axes[c.axis]) throw Error(point + ": two moving functions for axis " + "xyz"[c.axis]);
        axes[c.axis] = true;
        CheckPointCoordinate(d, point + ", moving axis " + "xyz"[c.axis], c.coordinate);
      }
      if (!p.active_coordinate.empty()) {
        CheckPointCoordinate(d, point + ", active_coordinate", p.active_coordinate);
        if (!std::isfinite(p.active_lower) || !std::isfinite(p.active_upper) ||
            p.active_lower > p.active_upper) {
          throw Error(point + ": active range [" + util::FormatNumber(p.active_lower) + ", " +
                      util::FormatNumber(p.active_upper) + "] must be finite with lower <= upper");
        }
      }
    }
    if (std::count_if(m.path.begin(), m.path.end(),
                      [](const PathPoint& p) { return p.active_coordinate.empty(); }) < 2) {
      throw Error(what + " needs at least two points that are not conditional (active_coordinate)");
    }
  }
  for (const auto& [joint, value] : d.nominal_posture) {
    const bool coordinate =
        std::any_of(d.coordinates.begin(), d.coordinates.end(),
                    [&name = joint](const CoordinateSpec& c) { return c.name == name; });
    if (!coordinate) {
      try {
        FindCoordinate(d, joint);  // names a driven joint's driver, or suggests the closest name
      } catch (const Error& e) {
        throw Error(model + ": nominal posture: " + e.what());
      }
      throw Error(model + ": nominal posture names '" + joint + "', which is not a coordinate");
    }
    if (!std::isfinite(value))
      throw Error(model + ": nominal posture of '" + joint + "' is not finite");
  }
}

}  // namespace

bool ConstantCoupling(const Function& coupling, double lower, double upper, double* value) {
  // Over [lower, upper] when it is a finite interval with an interior; else over all reals.
  const bool range = std::isfinite(lower) && std::isfinite(upper) && lower < upper;
  if (!range) {
    lower = -std::numeric_limits<double>::infinity();
    upper = std::numeric_limits<double>::infinity();
  }
  const Function::Impl& f = FunctionAccess::Of(coupling);
  switch (f.kind) {
    case FunctionKind::kConstant:
    case FunctionKind::kLinear:
      if (coupling.slope() != 0.0) return false;
      *value = coupling.intercept();
      return true;
    case FunctionKind::kMultiplier: {
      if (f.scale == 0.0) {
        *value = 0.0;
        return true;
      }
      double inner = 0.0;
      if (!ConstantCoupling(f.inner.at(0), lower, upper, &inner)) return false;
      *value = f.scale * inner;
      return true;
    }
    case FunctionKind::kPolynomial: {
      const std::vector<double>& c = f.coefficients;  // highest order first
      if (!std::all_of(c.begin(), c.end() - 1, [](double v) { return v == 0.0; })) return false;
      *value = c.back();
      return true;
    }
    case FunctionKind::kSimmSpline:
    case FunctionKind::kNaturalCubicSpline:
    case FunctionKind::kPiecewiseLinear: {
      // Interval k's cubic is y_k + dx (b_k + dx (c_k + dx d_k)) on [x_k, x_k+1]; below x_0
      // the function is y_0 + (a - x_0) b_0, above x_n-1 it is y_n-1 + (a - x_n-1) b_n-1, and
      // within OpenSim's roundoff of an end knot y and b of that knot. Every interval that
      // meets the closed range (a touching end too: OpenSim's bisection may pick either
      // interval at a knot), and each end knot the range reaches, must be flat at one y.
      const std::vector<double>& x = f.x;
      const auto n = x.size();
      const double* p = f.ybcd.data();
      const double y = lower <= x[0]
                           ? p[0]
                           : p[4 * (std::upper_bound(x.begin(), x.end(), lower) - x.begin() - 1)];
      auto flat_knot = [&](size_t k, bool cubic) {
        const double* q = p + 4 * k;
        return q[0] == y && q[1] == 0.0 && (!cubic || (q[2] == 0.0 && q[3] == 0.0));
      };
      if (lower <= x[0] + kKnotRoundoffError && !flat_knot(0, false)) return false;
      if (upper >= x[n - 1] - kKnotRoundoffError && !flat_knot(n - 1, false)) return false;
      for (size_t k = 0; k + 1 < n; ++k) {
        if (x[k + 1] < lower || x[k] > upper) continue;  // interval k misses the range
        if (!flat_knot(k, true) || p[4 * (k + 1)] != y) return false;
      }
      *value = y;
      return true;
    }
  }
  return false;
}

KDL::Chain BuildKdlChain(const LimbDescription& d) {
  KDL::Chain chain;
  for (const JointSpec& j : d.joints) {
    KDL::Frame origin = ToKdl(j.origin);
    KDL::Joint joint(j.name, KDL::Joint::Fixed);
    if (j.type == JointType::kRevolute) {
      joint = KDL::Joint(j.name, origin.p, origin.M * ToKdl(j.axis), KDL::Joint::RotAxis);
    } else if (j.type == JointType::kPrismatic) {
      joint = KDL::Joint(j.name, origin.p, origin.M * ToKdl(j.axis), KDL::Joint::TransAxis);
    }
    // Segment pose(q) = joint.pose(q) * joint.pose(0)^-1 * origin = origin * motion(axis, q).
    chain.addSegment(KDL::Segment(j.child_link, joint, origin));
  }
  KDL::Frame endpoint(ToKdl(d.transducer.endpoint));
  chain.addSegment(KDL::Segment("isowrench_endpoint",
                                KDL::Joint("isowrench_endpoint", KDL::Joint::Fixed), endpoint));
  return chain;
}

namespace {

// FastJoint::op of a joint with these fixed transform, axis and type.
int JointOp(const Eigen::Isometry3d& origin, const Eigen::Vector3d& a, bool revolute) {
  int op = (revolute ? 1 : 0) | (origin.translation() == Eigen::Vector3d::Zero() ? 0 : 8) |
           (origin.linear() == Eigen::Matrix3d::Identity() ? 0 : 16);
  for (int k = 0; k < 3; ++k) {
    const int k1 = (k + 1) % 3, k2 = (k + 2) % 3;
    if (a[k1] == 0.0 && a[k2] == 0.0 && std::abs(a[k]) == 1.0) {
      return op | k << 1 | (a[k] < 0 ? 32 : 0);
    }
  }
  return op | 3 << 1;
}

// The motion of a joint at position `value` (rad or m): a turn about or a shift along its axis.
Eigen::Isometry3d JointMotion(const JointSpec& j, double value) {
  Eigen::Isometry3d motion = Eigen::Isometry3d::Identity();
  if (j.type == JointType::kRevolute) {
    motion.linear() = Eigen::AngleAxisd(value, j.axis).toRotationMatrix();
  } else {
    motion.translation() = value * j.axis;
  }
  return motion;
}

// Walk the chain, folding fixed joints, and movable joints whose coupling is constant over their
// coordinate's range (ConstantCoupling), into the next movable joint (or the endpoint).
FlatChain Compile(const LimbDescription& d) {
  static std::atomic<std::uint64_t> next_id{1};
  FlatChain flat;
  flat.id = next_id.fetch_add(1, std::memory_order_relaxed);
  flat.name = d.name;
  const std::string model = "model '" + d.name + "'";
  std::map<std::string, const CoordinateSpec*> coordinates;
  for (const CoordinateSpec& c : d.coordinates) coordinates[c.name] = &c;
  Eigen::Isometry3d since_last = Eigen::Isometry3d::Identity();
  int frame = -1;
  flat.links[d.root_link] = {-1, since_last};
  for (const JointSpec& j : d.joints) {
    if (j.type == JointType::kFixed) {
      since_last = since_last * j.origin;
      flat.links[j.child_link] = {frame, since_last};
      continue;
    }
    const CoordinateSpec& c = *coordinates.at(j.coordinate.empty() ? j.name : j.coordinate);
    double constant = 0.0;
    if (ConstantCoupling(j.coupling, c.lower, c.upper, &constant)) {
      since_last = since_last * j.origin * JointMotion(j, constant);
      flat.links[j.child_link] = {frame, since_last};
      flat.folded_joints.push_back(j.name);
      continue;
    }
    const Eigen::Isometry3d origin = since_last * j.origin;
    FastJoint fj;
    fj.origin_rotation = origin.linear();
    fj.origin_translation = origin.translation();
    fj.axis = j.axis;
    fj.revolute = j.type == JointType::kRevolute;
    fj.op = JointOp(origin, fj.axis, fj.revolute);
    flat.joints.push_back(fj);
    ++frame;
    since_last = Eigen::Isometry3d::Identity();
    flat.links[j.child_link] = {frame, since_last};
  }
  flat.m = frame + 1;
  flat.n = static_cast<int>(d.coordinates.size());
  // The joints whose sin and cos one posture computes: from the first to the last revolute
  // joint, widened towards the chain's start to whole groups of 4 where the chain allows.
  for (int k = 0; k < flat.m; ++k) {
    const bool revolute = flat.joints[static_cast<size_t>(k)].revolute;
    flat.revolute.push_back(revolute ? 1 : 0);
    if (!revolute) continue;
    if (k < 32) flat.revolute_mask |= 1u << k;
    if (flat.trig_end == 0) flat.trig_begin = k;
    flat.trig_end = k + 1;
  }
  flat.trig_begin = std::max(0, flat.trig_end - (flat.trig_end - flat.trig_begin + 3) / 4 * 4);
  std::map<std::string, int> column;
  for (int c = 0; c < flat.n; ++c) {
    column[d.coordinates[c].name] = c;
    flat.locked.push_back(d.coordinates[c].locked);
    flat.any_locked = flat.any_locked || d.coordinates[c].locked;
  }
  flat.coupled = flat.n != flat.m;
  for (const JointSpec& j : d.joints) {
    if (j.type == JointType::kFixed ||
        std::find(flat.folded_joints.begin(), flat.folded_joints.end(), j.name) !=
            flat.folded_joints.end()) {
      continue;
    }
    const int k = static_cast<int>(flat.coordinate.size());
    const int c = column.at(j.coordinate.empty() ? j.name : j.coordinate);
    flat.coordinate.push_back(c);
    flat.coupling.push_back(j.coupling);
    flat.coupled = flat.coupled || c != k || !j.coupling.is_identity();
  }
  // Slots: a column's owner (its first joint with the identity coupling) writes the column
  // itself; every other joint, driven by the coupling step, writes a slot past the columns
  // (from the stride on) that is folded into its column afterwards.
  std::vector<char> owned(static_cast<size_t>(flat.n), 0);
  std::vector<char> owner(static_cast<size_t>(flat.m), 0);
  int driven = 0;
  for (int k = 0; k < flat.m; ++k) {
    const auto c = static_cast<size_t>(flat.coordinate[static_cast<size_t>(k)]);
    owner[static_cast<size_t>(k)] =
        !owned[c] && flat.coupling[static_cast<size_t>(k)].is_identity();
    owned[c] = owned[c] || owner[static_cast<size_t>(k)];
    driven += owner[static_cast<size_t>(k)] ? 0 : 1;
  }
  std::size_t max_points = 0;  // (a muscle's points: its path points and two per wrap)
  for (const MuscleSpec& spec : d.muscles) {
    max_points = std::max(max_points, spec.path.size() + 2 * spec.wraps.size());
  }
  flat.large = flat.m > kSmallJoints || flat.n > kSmallJoints ||
               kSmallJoints + driven > kSmallSlots || max_points > kSmallPoints;
  flat.stride = flat.large ? RoundUpTo4(flat.n) : kSmallJoints;
  flat.slot_count = flat.large ? flat.stride + driven : kSmallSlots;
  int extra = 0;
  for (int k = 0; k < flat.m; ++k) {
    const auto c = static_cast<size_t>(flat.coordinate[static_cast<size_t>(k)]);
    flat.slot.push_back(owner[static_cast<size_t>(k)] ? static_cast<int>(c)
                                                      : flat.stride + extra++);
    if (owner[static_cast<size_t>(k)] && static_cast<int>(c) != k)
      flat.moved_positions.push_back({k, static_cast<int>(c)});
  }
  while (flat.plain_joints < flat.m &&
         flat.slot[static_cast<size_t>(flat.plain_joints)] == flat.plain_joints) {
    ++flat.plain_joints;
  }
  for (int k = 0; k < flat.m; ++k) {
    const int c = flat.coordinate[static_cast<size_t>(k)];
    const int slot = flat.slot[static_cast<size_t>(k)];
    if (slot == c) continue;
    const Function::Impl& f = FunctionAccess::Of(flat.coupling[static_cast<size_t>(k)]);
    flat.driven_joints.push_back({k, c, slot, !owned[static_cast<size_t>(c)], &f, KnotScan(f)});
    owned[static_cast<size_t>(c)] = 1;  // the next fold into c adds
  }
  for (int c = 0; c < flat.n; ++c) {  // (owned now: an owner or a driven joint carries c)
    if (!owned[static_cast<size_t>(c)]) flat.undriven_columns.push_back(c);
  }
  const TransducerSpec& t = d.transducer;
  flat.endpoint = since_last * t.endpoint;
  flat.endpoint_rotation = since_last.linear();
  flat.transducer_in_world = t.axes_in_world;
  flat.transducer_rotation =
      t.axes_in_world ? t.rotation : Eigen::Matrix3d(since_last.linear() * t.rotation);
  flat.transducer_identity = t.axes_in_world && t.rotation == Eigen::Matrix3d::Identity();
  for (const MuscleSpec& spec : d.muscles) {
    FastMuscle muscle;
    muscle.max_force = spec.max_force;
    muscle.force_model = MuscleForceModel(spec.name, spec.max_force, spec.force);
    muscle.force_curve = spec.force.model != ForceModelType::kConstant;
    for (const PathPoint& p : spec.path) {
      const LinkFrame& link = flat.links.at(p.link);
      FastPathPoint point;
      point.frame = link.frame;
      Eigen::Vector3d fixed = p.position;
      for (const MovingComponent& c : p.moving) {
        const CoordinateSpec& coordinate = d.coordinates[column.at(c.coordinate)];
        fixed[c.axis] = 0.0;
        muscle.moving.push_back({static_cast<int>(muscle.points.size()), column.at(c.coordinate),
                                 c.function, link.offset.linear().col(c.axis), coordinate.lower,
                                 coordinate.upper});
      }
      point.position = link.offset * fixed;
      if (!p.active_coordinate.empty()) {
        point.active_column = column.at(p.active_coordinate);
        point.active_lower = p.active_lower - kActiveRangeTolerance;
        point.active_upper = p.active_upper + kActiveRangeTolerance;
      }
      muscle.dynamic = muscle.dynamic || !p.moving.empty() || point.active_column >= 0;
      if (point.frame < 0) muscle.ground_points.push_back(static_cast<int>(muscle.points.size()));
      muscle.points.push_back(point);
    }
    muscle.path_points = static_cast<int>(muscle.points.size());
    // Wraps (issue 27): two tangent-point slots each, points of the wrap object's frame at the
    // origin of S (FastWrap).
    muscle.wrap_mode = d.wrap_mode;
    for (const PathWrapSpec& w : spec.wraps) {
      const auto object =
          std::find_if(d.wrap_objects.begin(), d.wrap_objects.end(),
                       [&w](const WrapObjectSpec& o) { return o.name == w.object; });
      const LinkFrame& link = flat.links.at(object->link);  // (CheckWraps: both exist)
      const Eigen::Isometry3d X_frame_S = link.offset * object->Pose();
      FastWrap fw;
      fw.wrap.surface = WrapSurface::From(*object);
      fw.wrap.first = w.range_first < 1 ? 0 : w.range_first - 1;
      fw.wrap.last = w.range_last < 1 ? muscle.path_points - 1 : w.range_last - 1;
      fw.wrap.method = w.method;
      fw.wrap.active = object->active;
      fw.wrap.object = static_cast<int>(object - d.wrap_objects.begin());
      fw.slot = static_cast<int>(muscle.points.size());
      fw.rotation = X_frame_S.linear();
      FastPathPoint slot;
      slot.frame = link.frame;
      slot.position = X_frame_S.translation();
      for (int e = 0; e < 2; ++e) {
        if (slot.frame < 0) muscle.ground_points.push_back(static_cast<int>(muscle.points.size()));
        muscle.points.push_back(slot);
      }
      muscle.wraps.push_back(fw);
      muscle.dynamic = true;
    }
    muscle.one_cylinder = muscle.wraps.size() == 1 && muscle.moving.empty() &&
                          muscle.wraps[0].wrap.active &&
                          muscle.wraps[0].wrap.surface.shape == WrapShape::kCylinder &&
                          std::all_of(muscle.points.begin(), muscle.points.end(),
                                      [](const FastPathPoint& p) { return p.active_column < 0; });
    if (!muscle.wraps.empty()) muscle.wrap_frame = muscle.points[muscle.wraps[0].slot].frame;
    muscle.special = muscle.dynamic || muscle.force_curve;
    // Point groups {frame, count, indices} for the kernel's joint loops (FastMuscle).
    std::vector<std::vector<int>> by_frame(static_cast<size_t>(flat.m));
    for (size_t k = 0; k < muscle.points.size(); ++k) {
      const int f = muscle.points[k].frame;
      if (f >= 0) by_frame[static_cast<size_t>(f)].push_back(static_cast<int>(k));
    }
    // A wrap's second tangent-point slot is only written by the path stage (the first one's
    // frame gives X_W_S): the forward groups leave it out, the backward ones keep it (its pull).
    std::vector<char> placed(muscle.points.size(), 1);
    for (const FastWrap& w : muscle.wraps) placed[static_cast<size_t>(w.slot + 1)] = 0;
    // (one_cylinder: the backward groups without the slots, the cylinder's frame kept)
    auto add_group = [&](std::vector<int>& list, int f, bool forward, bool no_slots = false) {
      std::vector<int> group;
      for (const int k : by_frame[static_cast<size_t>(f)]) {
        if (no_slots && k >= muscle.path_points) continue;
        if (!forward || placed[static_cast<size_t>(k)]) group.push_back(k);
      }
      if (group.empty() && !(no_slots && f == muscle.wrap_frame)) return;
      list.push_back(f);
      list.push_back(static_cast<int>(group.size()));
      list.insert(list.end(), group.begin(), group.end());
    };
    for (int f = 0; f < flat.m; ++f) add_group(muscle.forward_points, f, true);
    for (int f = flat.m - 1; f >= 0; --f) add_group(muscle.backward_points, f, false);
    muscle.forward_points.push_back(flat.m);  // the sentinels
    muscle.backward_points.push_back(-1);
    if (muscle.one_cylinder) {
      for (int f = flat.m - 1; f >= 0; --f) {
        add_group(muscle.one_cylinder_backward_points, f, false, true);
      }
      muscle.one_cylinder_backward_points.push_back(-1);
    }
    flat.max_points = std::max(flat.max_points, static_cast<int>(muscle.points.size()));
    flat.max_moving = std::max(flat.max_moving, static_cast<int>(muscle.moving.size()));
    flat.muscles.push_back(std::move(muscle));
  }
  return flat;
}

}  // namespace

Model::Model(LimbDescription description) {
  description = NormalizeCoordinates(std::move(description));
  Validate(description);
  CheckWraps(description, "model '" + description.name + "'");  // src/wrap (issue 27)
  auto impl = std::make_shared<Impl>();
  impl->flat = Compile(description);
  for (const CoordinateSpec& c : description.coordinates) {
    impl->joint_names.push_back(c.name);
    impl->revolute.push_back(c.type == JointType::kRevolute);
    JointSpec column;
    auto carrier =
        std::find_if(description.joints.begin(), description.joints.end(),
                     [&c](const JointSpec& j) { return !c.joint.empty() && j.name == c.joint; });
    if (carrier != description.joints.end()) {
      column = *carrier;
    } else {
      // A free-standing coordinate: its name and kind, on the link of the last joint it drives.
      column.name = c.name;
      column.type = c.type;
      for (const JointSpec& j : description.joints) {
        if (j.type != JointType::kFixed && j.coordinate == c.name) {
          column.parent_link = j.parent_link;
          column.child_link = j.child_link;
        }
      }
    }
    column.role = c.role;
    column.stiffness = c.stiffness;
    impl->columns.push_back(column);
  }
  impl->stiffness.s_t = description.transducer.stiffness;
  for (int i = 0; i < 6; ++i) {
    if (description.transducer.released[i]) impl->stiffness.s_t[i] = 0.0;
  }
  impl->stiffness.s_p.resize(static_cast<Eigen::Index>(impl->columns.size()));
  for (std::size_t i = 0; i < impl->columns.size(); ++i) {
    impl->stiffness.s_p[static_cast<Eigen::Index>(i)] = impl->columns[i].stiffness;
  }
  impl->description = std::move(description);
  impl_ = impl;
  // The leg length through the joint centres (docs/model.md "Leg length"): kinematics of the
  // compiled chain at the nominal posture.
  impl->chain_length = ComputeLegLength(*this);
  // A tendon longer than the path at every posture: the muscle never pulls (src/muscle).
  CheckTendonsCanStretch(*this);
}

Model Model::FromUrdfFile(const std::string& path) { return Model(ReadUrdfFile(path)); }

const LimbDescription& Model::description() const { return impl_->description; }
int Model::dof_count() const { return static_cast<int>(impl_->columns.size()); }
bool Model::revolute(int column) const { return impl_->revolute.at(column); }
const StiffnessSet& Model::model_stiffness() const { return impl_->stiffness; }
const std::vector<std::string>& Model::joint_names() const { return impl_->joint_names; }
const JointSpec& Model::joint(int i) const { return impl_->columns.at(i); }
const CoordinateSpec& Model::coordinate(int i) const {
  return impl_->description.coordinates.at(i);
}

int Model::JointIndex(const std::string& name) const {
  for (int i = 0; i < dof_count(); ++i) {
    if (impl_->joint_names[i] == name) return i;
  }
  // Not a column: FindCoordinate names a driven joint's driver or suggests the closest name.
  const CoordinateSpec& c = FindCoordinate(description(), name);
  for (int i = 0; i < dof_count(); ++i) {
    if (impl_->joint_names[i] == c.name) return i;
  }
  throw Error("unknown coordinate '" + name + "' in model '" + this->name() +
              "' (coordinates: " + util::Join(impl_->joint_names, ", ") + ")");
}

Eigen::VectorXd Model::joint_stiffness() const {
  Eigen::VectorXd s(dof_count());
  for (int i = 0; i < dof_count(); ++i) s[i] = joint(i).stiffness;
  return s;
}

int Model::muscle_count() const { return static_cast<int>(description().muscles.size()); }
const MuscleSpec& Model::muscle(int i) const { return description().muscles.at(i); }

int Model::MuscleIndex(const std::string& name) const {
  std::vector<std::string> known;
  for (int i = 0; i < muscle_count(); ++i) {
    if (muscle(i).name == name) return i;
    known.push_back(muscle(i).name);
  }
  throw Error("unknown muscle '" + name + "' in model '" + this->name() + "' (muscles: " +
              (known.empty() ? std::string("none") : util::Join(known, ", ")) + ")");
}

Eigen::VectorXd Model::nominal_posture() const {
  Eigen::VectorXd q(dof_count());
  for (int i = 0; i < dof_count(); ++i) q[i] = coordinate(i).default_value;
  for (const auto& [joint, value] : description().nominal_posture) q[JointIndex(joint)] = value;
  return q;
}

double Model::chain_length() const { return impl_->chain_length; }

}  // namespace isowrench
