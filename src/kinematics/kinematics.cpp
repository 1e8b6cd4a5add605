// Kinematics through KDL: the one place that calls KDL solvers and checks their error codes.

#include "isowrench/kinematics.hpp"

#include <cassert>
#include <cmath>

#include "isowrench/error.hpp"
#include "isowrench/posture.hpp"
#include "kinematics/kinematics_impl.hpp"
#include "model/model_impl.hpp"

namespace isowrench {
namespace {

Eigen::Isometry3d ToEigen(const KDL::Frame& f) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) t.linear()(r, c) = f.M(r, c);
    t.translation()[r] = f.p(r);
  }
  return t;
}

void Load(KinematicsWorkspace::Impl& ws, const Eigen::VectorXd& q) {
  for (int i = 0; i < q.size(); ++i) ws.q(i) = q[i];
}

int SegmentsOf(const Model& model, const std::string& link) {
  const auto& segments = model.impl().link_segments;
  auto it = segments.find(link);
  if (it == segments.end()) {
    throw Error("link '" + link + "' is not on the chain of model '" + model.name() + "'");
  }
  return it->second;
}

// Pose of the frame at the end of the first `segments` KDL segments.
KDL::Frame FramePose(KinematicsWorkspace::Impl& ws, int segments) {
  KDL::Frame frame = KDL::Frame::Identity();
  if (segments == 0) return frame;
  int code = ws.fk.JntToCart(ws.q, frame, segments);
  assert(code >= 0 && "KDL forward kinematics failed on a validated chain");
  (void)code;
  return frame;
}

// Geometric Jacobian of the frame at the end of `segments` segments, reference point its origin.
void FrameJacobian(KinematicsWorkspace::Impl& ws, int segments) {
  KDL::SetToZero(ws.jac);
  if (segments == 0) return;
  int code = ws.jac_solver.JntToJac(ws.q, ws.jac, segments);
  assert(code >= 0 && "KDL Jacobian solver failed on a validated chain");
  (void)code;
}

}  // namespace

KinematicsWorkspace::KinematicsWorkspace(const Model& model)
    : impl_(std::make_unique<Impl>(model.impl().chain)) {}
KinematicsWorkspace::~KinematicsWorkspace() = default;
KinematicsWorkspace::KinematicsWorkspace(KinematicsWorkspace&&) noexcept = default;
KinematicsWorkspace& KinematicsWorkspace::operator=(KinematicsWorkspace&&) noexcept = default;

Eigen::Isometry3d EndpointPose(const Model& model, KinematicsWorkspace& ws, const Eigen::VectorXd& q) {
  ValidatePosture(model, q);
  Load(ws.impl(), q);
  return ToEigen(FramePose(ws.impl(), static_cast<int>(ws.impl().chain.getNrOfSegments())));
}

Matrix6Xd EndpointJacobianWorld(const Model& model, KinematicsWorkspace& ws, const Eigen::VectorXd& q) {
  ValidatePosture(model, q);
  Load(ws.impl(), q);
  FrameJacobian(ws.impl(), static_cast<int>(ws.impl().chain.getNrOfSegments()));
  return ws.impl().jac.data;
}

Eigen::Matrix3d TransducerRotation(const Model& model, KinematicsWorkspace& ws, const Eigen::VectorXd& q) {
  const TransducerSpec& t = model.transducer();
  if (t.axes_in_world) return t.rotation;
  ValidatePosture(model, q);
  Load(ws.impl(), q);
  return ToEigen(FramePose(ws.impl(), model.impl().endpoint_link_segments)).linear() * t.rotation;
}

Matrix6Xd EndpointJacobian(const Model& model, KinematicsWorkspace& ws, const Eigen::VectorXd& q) {
  Eigen::Matrix3d R = TransducerRotation(model, ws, q);
  Matrix6Xd J = EndpointJacobianWorld(model, ws, q);
  J.topRows<3>() = R.transpose() * J.topRows<3>();
  J.bottomRows<3>() = R.transpose() * J.bottomRows<3>();
  return J;
}

Eigen::Vector3d PointPosition(const Model& model, KinematicsWorkspace& ws, const Eigen::VectorXd& q,
                              const std::string& link, const Eigen::Vector3d& p_link) {
  int segments = SegmentsOf(model, link);
  ValidatePosture(model, q);
  Load(ws.impl(), q);
  return ToEigen(FramePose(ws.impl(), segments)) * p_link;
}

Eigen::Matrix3Xd PointJacobian(const Model& model, KinematicsWorkspace& ws, const Eigen::VectorXd& q,
                               const std::string& link, const Eigen::Vector3d& p_link) {
  int segments = SegmentsOf(model, link);
  ValidatePosture(model, q);
  Load(ws.impl(), q);
  if (segments == 0) return Eigen::Matrix3Xd::Zero(3, model.dof_count());
  KDL::Frame frame = FramePose(ws.impl(), segments);
  FrameJacobian(ws.impl(), segments);
  KDL::Vector offset = frame.M * KDL::Vector(p_link.x(), p_link.y(), p_link.z());
  ws.impl().jac.changeRefPoint(offset);
  return ws.impl().jac.data.topRows<3>();
}

MuscleTorque ComputeMuscleTorque(const Model& model, KinematicsWorkspace& ws, const Eigen::VectorXd& q,
                                 int muscle_index, double activation) {
  if (muscle_index < 0 || muscle_index >= model.muscle_count()) {
    throw Error("muscle index " + std::to_string(muscle_index) + " is out of range for model '" +
                model.name() + "'");
  }
  const MuscleSpec& muscle = model.muscle(muscle_index);
  if (!std::isfinite(activation)) {
    throw Error("muscle '" + muscle.name + "': activation is not finite");
  }
  MuscleTorque out;
  out.force = activation * muscle.max_force;
  out.dL_dq = Eigen::RowVectorXd::Zero(model.dof_count());
  Eigen::Vector3d previous = PointPosition(model, ws, q, muscle.path[0].link, muscle.path[0].position);
  Eigen::Matrix3Xd previous_jac = PointJacobian(model, ws, q, muscle.path[0].link, muscle.path[0].position);
  for (size_t i = 1; i < muscle.path.size(); ++i) {
    const PathPoint& p = muscle.path[i];
    Eigen::Vector3d position = PointPosition(model, ws, q, p.link, p.position);
    Eigen::Matrix3Xd jac = PointJacobian(model, ws, q, p.link, p.position);
    Eigen::Vector3d segment = position - previous;
    double length = segment.norm();
    // A segment shorter than a nanometre has no direction: the path is degenerate.
    constexpr double kMinSegmentLength = 1e-9;
    if (length < kMinSegmentLength) {
      throw Error("muscle '" + muscle.name + "': path points " + std::to_string(i - 1) + " and " +
                  std::to_string(i) + " coincide at this posture");
    }
    Eigen::Vector3d u = segment / length;
    out.length += length;
    out.dL_dq += u.transpose() * (jac - previous_jac);
    previous = position;
    previous_jac = jac;
  }
  out.tau = -out.force * out.dL_dq.transpose();
  return out;
}

}  // namespace isowrench
