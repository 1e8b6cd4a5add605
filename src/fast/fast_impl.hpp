#pragma once
// Private: the buffers of Data and the kinematics kernel every evaluation runs.

#include <Eigen/Eigenvalues>
#include <array>
#include <cassert>
#include <utility>
#include <vector>

#include "fast/vec3.hpp"
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
  // Kinematics of the last posture (Vec3: x, y, z in one SIMD vector, fast/vec3.hpp): per
  // movable joint its world axis and origin (a point on the axis); per path point of the
  // muscle its world position and pull dL/dx (a sum of unit segment directions).
  std::array<Vec3<double>, kMaxDofs> origin;
  std::array<Vec3<double>, kMaxDofs> axis;
  std::array<Vec3<double>, kFastMaxPathPoints> points;
  std::array<Vec3<double>, kFastMaxPathPoints> pulls;
  /// World rotation (three columns) of the frame after each movable joint; written only by the
  /// kernel with frames (the public kinematics functions), not by the evaluation path.
  std::array<std::array<Vec3<double>, 3>, kMaxDofs> frames;
  /// Coupled chains only: each movable joint's position q_joint = f(q_c), and dq_joint/dq_c of
  /// the driven joints (FlatChain::driven_joints).
  double q_joint[kMaxDofs];
  double dq_joint[kMaxDofs];
  /// The endpoint (pose[0]) and the columns of R_W_T (pose[1 .. 3]), as the kernel stores them.
  Vec3<double> pose[4] = {};
  void SetPose(const Vec3<double>& endpoint, const Vec3<double>* R_W_T) {
    pose[0] = endpoint;
    for (int c = 0; c < 3; ++c) pose[1 + c] = R_W_T[c];
  }
  Eigen::Vector3d Endpoint() const { return ToEigen(pose[0]); }
  Eigen::Matrix3d TransducerRotation() const { return ToEigen(pose + 1); }
  Eigen::Matrix3d Frame(int k) const { return ToEigen(frames[k].data()); }
  /// The storage behind Data::endpoint_position() and Data::transducer_rotation(), filled only
  /// by those calls: never read them directly (call Endpoint() / TransducerRotation()).
  mutable Eigen::Vector3d endpoint_copy = Eigen::Vector3d::Zero();
  mutable Eigen::Matrix3d R_W_T_copy = Eigen::Matrix3d::Identity();
  /// One posture stages the Jacobian columns [v; w] (world axes) and the x, y, z terms of
  /// dL/dq_c here, column (or FlatChain::slot) s at staged[s] (v), staged[kW + s] (w) and
  /// staged[kP + s] (the terms of dL/dq); kernel::FinishColumns moves the first m columns into
  /// Jr, dL and tau, four at a time (the columns from m to the next multiple of 4 are 0 from
  /// construction on).
  static constexpr int kW = kMaxSlots, kP = 2 * kMaxSlots;
  Vec3<double> staged[3 * kMaxSlots];
  /// The endpoint Jacobian as the kernel writes it: row-major with a fixed row stride (row r at
  /// Jr + r * kMaxDofs, columns 0 .. m - 1), the layout the statics reads rows of; the
  /// unused entries stay 0.
  alignas(32) double Jr[6 * kMaxDofs];
  JointVector dL;
  JointVector tau;
  double length = 0.0;
  /// J, dL and tau have the m columns of the model from construction on (the kernel asks for
  /// its chain's n, which is m).
  void Resize([[maybe_unused]] int n) const { assert(n == m); }
  /// J (6 x m) as a matrix: Data::jacobian(), copied from Jr on each call.
  const JacobianBuffer& Jacobian() const {
    J.resize(6, m);
    for (int c = 0; c < m; ++c) {
      for (int r = 0; r < 6; ++r) J(r, c) = Jr[r * kMaxDofs + c];
    }
    return J;
  }
  /// Sets J (6 x m): Jr from a matrix of m columns.
  template <class Matrix>
  void SetJacobian(const Matrix& jacobian) {
    assert(jacobian.cols() == m);
    for (int c = 0; c < m; ++c) {
      for (int r = 0; r < 6; ++r) Jr[r * kMaxDofs + c] = jacobian(r, c);
    }
  }
  mutable JacobianBuffer J;  // Jacobian()'s copy
  // Statics.
  // Cholesky factor of K, K = U^T U: row k at U + k * kMaxDofs, its strict upper part U_ki
  // (i > k) read; the entries from 4 floor(k / 4) to k hold leftovers of the vector row updates
  // (U_kk included: the reciprocal diagonal is kept apart) and are never read.
  double U[kMaxDofs * kMaxDofs];
  JointVector dtheta;
  JointMatrix K_full;
  Eigen::SelfAdjointEigenSolver<JointMatrix> eigen;
  JointMatrix self_motion;
  /// Muscles with moving or conditional points (FastMuscle::dynamic), from PreparePathPoints:
  /// each point's position in its frame, the active points in path order, per moving
  /// component df/dq (0 where the coordinate is clamped); the kernel adds each point's frame
  /// rotation in world.
  std::array<Eigen::Vector3d, kFastMaxPathPoints> local;
  std::array<std::array<Vec3<double>, 3>, kFastMaxPathPoints> point_rotation;
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
