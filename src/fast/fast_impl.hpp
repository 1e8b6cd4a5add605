#pragma once
// Private: the buffers of Data and the kinematics kernel every evaluation runs.

#include <Eigen/Eigenvalues>
#include <array>
#include <utility>
#include <vector>

#include "isowrench/engine.hpp"
#include "model/model_impl.hpp"

namespace isowrench {

/// A path segment shorter than this (m) has no direction (same rule as ComputeMuscleTorque).
inline constexpr double kFastMinSegmentLength = 1e-9;

/// The scalar workspace of the engine (src/fast/kernel.hpp describes what the kernel needs).
struct Data::Impl {
  using Scalar = double;
  explicit Impl(int dofs);
  int m = 0;
  // Kinematics of the last posture: per movable joint its world axis and origin (a point on
  // the axis); per path point of the muscle its world position and pull dL/dx (a sum of unit
  // segment directions).
  std::array<Eigen::Vector3d, kMaxDofs> origin;
  std::array<Eigen::Vector3d, kMaxDofs> axis;
  std::array<Eigen::Vector3d, kFastMaxPathPoints> points;
  std::array<Eigen::Vector3d, kFastMaxPathPoints> pulls;
  /// World rotation of the frame after each movable joint; written only by the kernel with
  /// frames (the public kinematics functions), not by the evaluation path.
  std::array<Eigen::Matrix3d, kMaxDofs> frames;
  /// Coupled chains only: each movable joint's position q_joint = f(q_c) and dq_joint/dq_c.
  double q_joint[kMaxDofs];
  double dq_joint[kMaxDofs];
  Eigen::Vector3d endpoint = Eigen::Vector3d::Zero();
  Eigen::Matrix3d R_W_T = Eigen::Matrix3d::Identity();
  JacobianBuffer J;
  JointVector dL;
  JointVector tau;
  double length = 0.0;
  double* JacobianData() { return J.data(); }
  double* DlData() { return dL.data(); }
  double* TauData() { return tau.data(); }
  double* EndpointData() { return endpoint.data(); }
  double* TransducerData() { return R_W_T.data(); }
  void Resize(int columns) {
    J.resize(6, columns);
    dL.resize(columns);
    tau.resize(columns);
  }
  // Statics.
  double U[kMaxDofs * kMaxDofs];  // Cholesky factor of K, K = U^T U (upper triangle by rows)
  JointVector dtheta;
  JointMatrix K_full;
  Eigen::SelfAdjointEigenSolver<JointMatrix> eigen;
  JointMatrix self_motion;
  /// Muscles with moving or conditional points (FastMuscle::dynamic), from PreparePathPoints:
  /// each point's position in its frame, the active points in path order, per moving
  /// component df/dq (0 where the coordinate is clamped); the kernel adds each point's frame
  /// rotation in world.
  std::array<Eigen::Vector3d, kFastMaxPathPoints> local;
  std::array<Eigen::Matrix3d, kFastMaxPathPoints> point_rotation;
  std::array<int, kFastMaxPathPoints> active;
  int active_count = 0;
  std::array<double, 3 * kFastMaxPathPoints> moving_slope;
};

/// Moving and conditional path points (src/fast/path_points.cpp), for a muscle with
/// FastMuscle::dynamic. Before the kernel: each point's position in its frame (ws.local), the
/// active points (ws.active) and df/dq of each moving component at coordinates `q` (columns).
void PreparePathPoints(const FastMuscle& muscle, const double* q, Data::Impl& ws);
/// The kernel's segment step over the active points only: unit directions, pulls (0 at
/// inactive points) and the length. Returns false when two consecutive active points coincide.
bool ActivePathPulls(Data::Impl& ws, double* length);
/// After the kernel (dL and tau in coordinate columns): dL/dq_c += pull_i . R_i direction df/dq_c
/// for every moving component, and tau = minus_force dL.
void AddMovingPointTerms(const FastMuscle& muscle, Data::Impl& ws, double minus_force);

/// The kinematics kernel of ComputeKinematics with every movable joint's world rotation
/// stored in ws.frames, for the public kinematics functions. `muscle` < 0: no muscle (dL and
/// tau zero). `world_axes`: J in world axes instead of transducer axes. Returns false when two
/// consecutive path points coincide (as ComputeKinematics). q: chain.n coordinates.
bool ComputeKinematicsWithFrames(const FlatChain& chain, Data::Impl& ws, const double* q,
                                 int muscle, double activation, bool world_axes);

}  // namespace isowrench
