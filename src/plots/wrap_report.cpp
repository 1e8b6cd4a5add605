// A model's wrapping muscles through the wrap library at one posture (include/isowrench/
// wrap_report.hpp): the input of ComputeWrappedPath built from the model, the moment arms of a
// wrapped path, and the opensim-versus-exact comparison the reports print.

#include "isowrench/wrap_report.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "isowrench/error.hpp"
#include "util/text.hpp"

namespace isowrench {
namespace {

// X_W_link(q) from three point positions (the link's frame may be offset from its chain frame,
// which PointPosition accounts for).
Eigen::Isometry3d WrapReportLinkPose(const Model& model, Data& data, const Eigen::VectorXd& q,
                                     const std::string& link) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  const Eigen::Vector3d origin = PointPosition(model, data, q, link, Eigen::Vector3d::Zero());
  X.translation() = origin;
  for (int k = 0; k < 3; ++k) {
    X.linear().col(k) = PointPosition(model, data, q, link, Eigen::Vector3d::Unit(k)) - origin;
  }
  return X;
}

const WrapObjectSpec& WrapReportObject(const LimbDescription& d, const std::string& name,
                                       int* index) {
  for (size_t i = 0; i < d.wrap_objects.size(); ++i) {
    if (d.wrap_objects[i].name == name) {
      *index = static_cast<int>(i);
      return d.wrap_objects[i];
    }
  }
  throw Error("wrap object '" + name + "' is not in model '" + d.name + "'");
}

void WrapReportCheckMuscle(const Model& model, int muscle) {
  if (muscle < 0 || muscle >= model.muscle_count()) {
    throw Error("muscle index " + std::to_string(muscle) + " is out of range for model '" +
                model.name() + "'");
  }
}

// The value a moving component's function reads: q clamped to its coordinate's range
// (MovingComponent); `inside` false where the clamp acts (the derivative is 0 there).
double WrapReportMovingArgument(const Model& model, const MovingComponent& c,
                                const Eigen::VectorXd& q, bool* inside) {
  const int column = model.JointIndex(c.coordinate);
  const CoordinateSpec& spec = model.coordinate(column);
  const double x = std::clamp(q[column], spec.lower, spec.upper);
  if (inside) *inside = x == q[column];
  return x;
}

// The position of path point p in its link's frame at q (moving components evaluated).
Eigen::Vector3d WrapReportLocal(const Model& model, const PathPoint& p, const Eigen::VectorXd& q) {
  Eigen::Vector3d local = p.position;
  for (const MovingComponent& c : p.moving)
    local[c.axis] = c.function.Value(WrapReportMovingArgument(model, c, q, nullptr));
  return local;
}

}  // namespace

Eigen::Isometry3d WrapObjectPose(const Model& model, Data& data, const Eigen::VectorXd& q,
                                 const WrapObjectSpec& object) {
  return WrapReportLinkPose(model, data, q, object.link) * object.Pose();
}

WrapPathInput MuscleWrapPathInput(const Model& model, Data& data, const Eigen::VectorXd& q,
                                  int muscle) {
  WrapReportCheckMuscle(model, muscle);
  const MuscleSpec& m = model.muscle(muscle);
  const LimbDescription& d = model.description();
  WrapPathInput in;
  for (const PathPoint& p : m.path) {
    in.points.push_back(PointPosition(model, data, q, p.link, WrapReportLocal(model, p, q)));
    bool active = true;
    if (!p.active_coordinate.empty()) {
      const double x = q[model.JointIndex(p.active_coordinate)];
      active = p.active_lower - kActiveRangeTolerance <= x &&
               x <= p.active_upper + kActiveRangeTolerance;
    }
    in.active.push_back(active ? 1 : 0);
  }
  const int n = static_cast<int>(m.path.size());
  for (const PathWrapSpec& w : m.wraps) {
    WrapPathWrap pw;
    const WrapObjectSpec& o = WrapReportObject(d, w.object, &pw.object);
    pw.surface = WrapSurface::From(o);
    pw.X_W_S = WrapObjectPose(model, data, q, o);
    pw.first = w.range_first < 1 ? 0 : w.range_first - 1;
    pw.last = w.range_last < 1 ? n - 1 : w.range_last - 1;
    pw.method = w.method;
    pw.active = o.active;
    in.wraps.push_back(pw);
  }
  return in;
}

Eigen::VectorXd WrappedMomentArms(const Model& model, Data& data, const Eigen::VectorXd& q,
                                  int muscle, const WrappedPath& path) {
  WrapReportCheckMuscle(model, muscle);
  const MuscleSpec& m = model.muscle(muscle);
  const LimbDescription& d = model.description();
  if (path.point_pull.size() != m.path.size() || path.wraps.size() != m.wraps.size()) {
    throw Error("the wrapped path given for muscle '" + m.name + "' is not this muscle's");
  }
  Eigen::VectorXd arm = Eigen::VectorXd::Zero(model.dof_count());
  for (size_t i = 0; i < m.path.size(); ++i) {
    const Eigen::Vector3d& pull = path.point_pull[i];
    if (pull.isZero(0.0)) continue;
    const PathPoint& p = m.path[i];
    const Eigen::Vector3d local = WrapReportLocal(model, p, q);
    arm -= (pull.transpose() * PointJacobian(model, data, q, p.link, local)).transpose();
    if (p.moving.empty()) continue;
    // A moving component x_axis = f(q_c) moves the point along the link's axis in world.
    const Eigen::Isometry3d X = WrapReportLinkPose(model, data, q, p.link);
    for (const MovingComponent& c : p.moving) {
      bool inside = false;
      const double x = WrapReportMovingArgument(model, c, q, &inside);
      if (!inside) continue;
      arm[model.JointIndex(c.coordinate)] -=
          pull.dot(X.linear().col(c.axis)) * c.function.Derivative(x);
    }
  }
  for (size_t w = 0; w < m.wraps.size(); ++w) {
    const WrappedPath::Wrap& r = path.wraps[w];
    if (!r.wrapped) continue;
    int index = -1;
    const WrapObjectSpec& o = WrapReportObject(d, m.wraps[w].object, &index);
    // The tangent points, fixed in S, are points of the object's link.
    const Eigen::Isometry3d X_link_S = o.Pose();
    arm -= (r.pull_r1.transpose() * PointJacobian(model, data, q, o.link, X_link_S * r.r1_S))
               .transpose();
    arm -= (r.pull_r2.transpose() * PointJacobian(model, data, q, o.link, X_link_S * r.r2_S))
               .transpose();
  }
  return arm;
}

WrapModeDifference CompareWrapModes(const Model& model, Data& data, const Eigen::VectorXd& q,
                                    int muscle) {
  const WrapPathInput in = MuscleWrapPathInput(model, data, q, muscle);
  WrapModeDifference out;
  out.muscle = muscle;
  WrappedPath path;
  ComputeWrappedPath(in, WrapMode::kOpenSim, path);
  out.length_opensim = path.length;
  out.status_opensim = path.status;
  for (const WrappedPath::Wrap& w : path.wraps) out.wraps_engaged += w.wrapped ? 1 : 0;
  out.moment_arm_opensim = WrappedMomentArms(model, data, q, muscle, path);
  ComputeWrappedPath(in, WrapMode::kExact, path);
  out.length_exact = path.length;
  out.status_exact = path.status;
  out.moment_arm_exact = WrappedMomentArms(model, data, q, muscle, path);
  const Eigen::Vector3d* previous = nullptr;
  for (size_t i = 0; i < in.points.size(); ++i) {
    if (!in.active[i]) continue;
    if (previous) out.length_straight += (in.points[i] - *previous).norm();
    previous = &in.points[i];
  }
  for (int c = 0; c < model.dof_count(); ++c) {
    const double diff = std::abs(out.moment_arm_opensim[c] - out.moment_arm_exact[c]);
    if (out.coordinate < 0 || diff > out.moment_arm_difference) {
      out.moment_arm_difference = diff;
      out.coordinate = c;
    }
  }
  return out;
}

WrapModeSweep SweepWrapModes(const Model& model, Data& data, const Eigen::VectorXd& q0, int muscle,
                             int steps) {
  if (steps < 2) {
    throw Error("a sweep of the wrap modes needs at least 2 values per coordinate, got " +
                std::to_string(steps));
  }
  WrapModeSweep out;
  auto add = [&](const Eigen::VectorXd& q) {
    const WrapModeDifference d = CompareWrapModes(model, data, q, muscle);
    if (out.postures++ == 0) {
      out.at_q0 = d;
      out.max_length_posture = q;
      out.max_moment_arm_posture = q;
    }
    if (std::abs(d.LengthDifference()) > out.max_length_difference) {
      out.max_length_difference = std::abs(d.LengthDifference());
      out.max_length_posture = q;
    }
    if (d.moment_arm_difference > out.max_moment_arm_difference) {
      out.max_moment_arm_difference = d.moment_arm_difference;
      out.max_moment_arm_coordinate = d.coordinate;
      out.max_moment_arm_posture = q;
    }
    const unsigned bad = d.status_opensim & kWrapMisbehaviour;
    if (bad != 0) {
      if (out.misbehaving_postures++ == 0) out.first_misbehaving_posture = q;
      out.misbehaviour |= bad;
    }
  };
  add(q0);
  out.max_moment_arm_coordinate = out.at_q0.coordinate;
  for (int c = 0; c < model.dof_count(); ++c) {
    const CoordinateSpec& spec = model.coordinate(c);
    if (!std::isfinite(spec.lower) || !std::isfinite(spec.upper)) continue;
    Eigen::VectorXd q = q0;
    for (int k = 0; k < steps; ++k) {
      q[c] = spec.lower + (spec.upper - spec.lower) * k / (steps - 1);
      add(q);
    }
  }
  return out;
}

std::string FormatWrapMm(double difference) {
  return util::FormatNumber(std::abs(difference) < kWrapReportNoise ? 0.0 : difference * 1e3, 3);
}

std::vector<int> WrappingMuscles(const Model& model) {
  std::vector<int> out;
  for (int m = 0; m < model.muscle_count(); ++m) {
    if (!model.muscle(m).wraps.empty()) out.push_back(m);
  }
  return out;
}

}  // namespace isowrench
