// The public kinematics functions: thin views of the one kinematics kernel (fast/fast.cpp) run
// on the model's flat chain. KDL is not used here; tests/core check this against KDL.

#include "isowrench/kinematics.hpp"

#include <cmath>
#include <vector>

#include "isowrench/engine.hpp"
#include "isowrench/error.hpp"
#include "isowrench/posture.hpp"
#include "kinematics/kinematics_impl.hpp"
#include "model/model_impl.hpp"

namespace isowrench {
namespace {

const LinkFrame& LinkOf(const Model& model, const std::string& link) {
  const auto& links = model.impl().flat.links;
  auto it = links.find(link);
  if (it == links.end()) {
    throw Error("link '" + link + "' is not on the chain of model '" + model.name() + "'");
  }
  return it->second;
}

}  // namespace

Data::Impl& RunKinematics(const Model& model, Data& ws, const Eigen::VectorXd& q, int muscle,
                          double activation, bool world_axes) {
  ValidatePosture(model, q);
  if (muscle >= model.muscle_count()) {
    throw Error("muscle index " + std::to_string(muscle) + " is out of range for model '" +
                model.name() + "'");
  }
  if (muscle >= 0 && !std::isfinite(activation)) {
    throw Error("muscle '" + model.muscle(muscle).name + "': activation is not finite");
  }
  Data::Impl& b = ws.impl();
  if (!ComputeKinematicsWithFrames(model.impl().flat, b, q.data(), muscle, activation,
                                   world_axes)) {
    // The force stage found no equilibrium at this length (tau zero): the callers report the
    // force's status (MuscleForceAt), not an error.
    if (model.impl().flat.muscles[muscle].force_curve &&
        b.force_status == MuscleForceStatus::kNoEquilibrium) {
      return b;
    }
    const MuscleSpec& spec = model.muscle(muscle);
    // The points in the path at this posture (conditional ones may be out).
    std::vector<int> path;
    for (int i = 0; i < static_cast<int>(spec.path.size()); ++i) path.push_back(i);
    if (model.impl().flat.muscles[muscle].dynamic) {
      path.assign(b.active.begin(), b.active.begin() + b.active_count);
    }
    size_t i = 1;
    while (i + 1 < path.size() &&
           ToEigen(b.points[path[i]] - b.points[path[i - 1]]).norm() >= kFastMinSegmentLength)
      ++i;
    throw Error("muscle '" + spec.name + "': path points " + std::to_string(path[i - 1]) + " and " +
                std::to_string(path[i]) + " coincide at this posture");
  }
  return b;
}

Eigen::Isometry3d EndpointPose(const Model& model, Data& ws, const Eigen::VectorXd& q) {
  const Data::Impl& b = RunKinematics(model, ws, q, -1, 1.0, true);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  const FlatChain& chain = model.impl().flat;
  pose.linear() = b.Frame(chain.m - 1) * chain.endpoint_rotation;
  pose.translation() = b.Endpoint();
  return pose;
}

Matrix6Xd EndpointJacobianWorld(const Model& model, Data& ws, const Eigen::VectorXd& q) {
  return RunKinematics(model, ws, q, -1, 1.0, true).Jacobian();
}

Eigen::Matrix3d TransducerRotation(const Model& model, Data& ws, const Eigen::VectorXd& q) {
  const TransducerSpec& t = model.transducer();
  if (t.axes_in_world) return t.rotation;
  return RunKinematics(model, ws, q, -1, 1.0, false).TransducerRotation();
}

Matrix6Xd EndpointJacobian(const Model& model, Data& ws, const Eigen::VectorXd& q) {
  return RunKinematics(model, ws, q, -1, 1.0, false).Jacobian();
}

Eigen::Vector3d PointPosition(const Model& model, Data& ws, const Eigen::VectorXd& q,
                              const std::string& link, const Eigen::Vector3d& p_link) {
  const LinkFrame& frame = LinkOf(model, link);
  const Data::Impl& b = RunKinematics(model, ws, q, -1, 1.0, true);
  const Eigen::Vector3d p = frame.offset * p_link;
  if (frame.frame < 0) return p;
  return b.Frame(frame.frame) * p + ToEigen(b.origin[frame.frame]);
}

std::vector<Eigen::Vector3d> MusclePathPoints(const Model& model, Data& ws,
                                              const Eigen::VectorXd& q, int muscle_index) {
  if (muscle_index < 0 || muscle_index >= model.muscle_count()) {
    throw Error("muscle index " + std::to_string(muscle_index) + " is out of range for model '" +
                model.name() + "'");
  }
  Data::Impl& b = RunKinematics(model, ws, q, -1, 1.0, true);
  const FastMuscle& mu = EvaluatedMuscle(model.impl().flat, b, muscle_index);  // (moved points)
  const int n = mu.path_points;  // (not the wraps' tangent-point slots)
  if (mu.dynamic) PreparePathPoints(mu, q.data(), b);
  std::vector<Eigen::Vector3d> out;
  for (int k = 0; k < (mu.dynamic ? b.active_count : n); ++k) {
    const int i = mu.dynamic ? b.active[k] : k;
    const Eigen::Vector3d& local = mu.dynamic ? b.local[i] : mu.points[i].position;
    const int f = mu.points[i].frame;
    out.push_back(f < 0 ? local : Eigen::Vector3d(b.Frame(f) * local + ToEigen(b.origin[f])));
  }
  return out;
}

WrappedPath MuscleWrappedPath(const Model& model, Data& ws, const Eigen::VectorXd& q,
                              int muscle_index) {
  if (muscle_index < 0 || muscle_index >= model.muscle_count()) {
    throw Error("muscle index " + std::to_string(muscle_index) + " is out of range for model '" +
                model.name() + "'");
  }
  const Data::Impl& b = RunKinematics(model, ws, q, muscle_index, 1.0, true);
  const FastMuscle& mu = model.impl().flat.muscles[muscle_index];
  if (!mu.wraps.empty()) return b.wrap->path;  // (WrappedPathPulls ran for this muscle)
  WrappedPath out;
  out.length = b.length;
  out.point_pull.assign(static_cast<size_t>(mu.path_points), Eigen::Vector3d::Zero());
  const int n = mu.dynamic ? b.active_count : mu.path_points;
  for (int k = 0; k < n; ++k) {
    const int i = mu.dynamic ? b.active[k] : k;
    WrappedPath::Element e;
    e.point = i;
    e.position = ToEigen(b.points[i]);
    out.elements.push_back(e);
    out.point_pull[static_cast<size_t>(i)] = ToEigen(b.pulls[i]);
  }
  out.passes = 1;
  return out;
}

Eigen::Matrix3Xd PointJacobian(const Model& model, Data& ws, const Eigen::VectorXd& q,
                               const std::string& link, const Eigen::Vector3d& p_link) {
  const LinkFrame& frame = LinkOf(model, link);
  const Data::Impl& b = RunKinematics(model, ws, q, -1, 1.0, true);
  Eigen::Matrix3Xd J = Eigen::Matrix3Xd::Zero(3, model.dof_count());
  if (frame.frame < 0) return J;
  const Eigen::Vector3d x =
      b.Frame(frame.frame) * (frame.offset * p_link) + ToEigen(b.origin[frame.frame]);
  // Joint k's column of a point on the frame after joint f (k <= f): z_k x (x - o_k) for a
  // revolute joint, z_k for a prismatic one (the endpoint Jacobian's formula with x for p_E);
  // on a coupled chain it adds to its coordinate's column times dq_joint_k/dq_c (1 for the
  // column's owner, whose slot is the column; FlatChain::driven_joints have dq_joint).
  const FlatChain& chain = model.impl().flat;
  for (int k = 0; k <= frame.frame; ++k) {
    const Eigen::Vector3d z = ToEigen(b.axis[k]);
    const Eigen::Vector3d column =
        chain.joints[k].revolute ? Eigen::Vector3d(z.cross(x - ToEigen(b.origin[k]))) : z;
    if (chain.coupled) {
      const int c = chain.coordinate[k];
      J.col(c) += (chain.slot[k] == c ? 1.0 : b.dq_joint[k]) * column;
    } else {
      J.col(k) = column;
    }
  }
  return J;
}

double ComputeLegLength(const Model& model) {
  const Eigen::VectorXd q = model.nominal_posture();
  const LimbDescription& d = model.description();
  Data ws(model);
  // A joint frame's origin before the joint's motion: <origin> on the parent link.
  auto origin = [&](const JointSpec& j) {
    return PointPosition(model, ws, q, j.parent_link, j.origin.translation());
  };
  const Matrix6Xd J = EndpointJacobianWorld(model, ws, q);  // columns [v; w] at the endpoint
  const Eigen::Vector3d p_E = EndpointPose(model, ws, q).translation();
  std::vector<Eigen::Vector3d> points;
  for (int c = 0; c < model.dof_count(); ++c) {
    // The first revolute joint the coordinate drives: where its joint centre is looked for.
    const JointSpec* first = nullptr;
    for (const JointSpec& j : d.joints) {
      if (j.type == JointType::kRevolute && j.coordinate == model.joint_names()[c]) {
        first = &j;
        break;
      }
    }
    if (!first) continue;  // a translation: no joint centre
    const Eigen::Vector3d ref = origin(*first);
    // The coordinate's instantaneous screw axis (its column is a twist referenced at the
    // endpoint): it passes through p_E + w x v / |w|^2 along w. With coupled translations (an
    // OpenSim knee whose femur length lives in them) the joint frame is not the centre of the
    // motion; the point of the axis nearest the joint frame is.
    const Eigen::Vector3d v = J.col(c).head<3>(), w = J.col(c).tail<3>();
    // Below this (rad per rad) the coupling turns nothing at this posture: keep the frame.
    constexpr double kNoRotation = 1e-9;
    if (w.norm() <= kNoRotation) {
      points.push_back(ref);
      continue;
    }
    const Eigen::Vector3d on_axis = p_E + w.cross(v) / w.squaredNorm();
    const Eigen::Vector3d u = w.normalized();
    points.push_back(on_axis + u * u.dot(ref - on_axis));
  }
  if (points.empty()) {
    // Prismatic joints only: from the first movable joint.
    for (const JointSpec& j : d.joints) {
      if (j.type != JointType::kFixed) {
        points.push_back(origin(j));
        break;
      }
    }
  }
  if (points.empty()) return 0.0;
  points.push_back(p_E);
  double length = 0.0;
  for (size_t i = 1; i < points.size(); ++i) length += (points[i] - points[i - 1]).norm();
  return length;
}

MuscleTorque ComputeMuscleTorque(const Model& model, Data& ws, const Eigen::VectorXd& q,
                                 int muscle_index, double activation) {
  if (muscle_index < 0 || muscle_index >= model.muscle_count()) {
    throw Error("muscle index " + std::to_string(muscle_index) + " is out of range for model '" +
                model.name() + "'");
  }
  const Data::Impl& b = RunKinematics(model, ws, q, muscle_index, activation, false);
  MuscleTorque out;
  out.length = b.length;
  out.force_stage = MuscleForceAt(model, muscle_index, b.length, activation);
  out.force = out.force_stage.force;
  out.dL_dq = b.dL.transpose();
  out.tau = b.tau;
  return out;
}

}  // namespace isowrench
