#pragma once
// Private: the buffers of FastWorkspace and the kinematics kernel every evaluation runs.

#include <Eigen/Eigenvalues>
#include <array>
#include <utility>
#include <vector>

#include "isowrench/fast.hpp"
#include "model/model_impl.hpp"

namespace isowrench {

/// A path segment shorter than this (m) has no direction (same rule as ComputeMuscleTorque).
inline constexpr double kFastMinSegmentLength = 1e-9;

struct CompiledModel::Data {
  explicit Data(Model m) : model(std::move(m)) {}
  Model model;
  StiffnessSet stiffness;
  const FlatChain& flat() const { return model.impl().flat; }
};

struct FastWorkspace::Impl {
  explicit Impl(int dofs);
  int m = 0;
  // Kinematics of the last posture: per movable joint its world axis and origin (a point on
  // the axis); per path point of the muscle its world position and pull dL/dx (a sum of unit
  // segment directions).
  std::array<Eigen::Vector3d, kFastMaxDofs> origin;
  std::array<Eigen::Vector3d, kFastMaxDofs> axis;
  std::array<Eigen::Vector3d, kFastMaxPathPoints> points;
  std::array<Eigen::Vector3d, kFastMaxPathPoints> pulls;
  /// World rotation of the frame after each movable joint; written only by the kernel with
  /// frames (the public kinematics functions), not by the evaluation path.
  std::array<Eigen::Matrix3d, kFastMaxDofs> frames;
  /// Coupled chains only: each movable joint's position q_joint = f(q_c) and dq_joint/dq_c.
  double q_joint[kFastMaxDofs];
  double dq_joint[kFastMaxDofs];
  Eigen::Vector3d endpoint = Eigen::Vector3d::Zero();
  Eigen::Matrix3d R_W_T = Eigen::Matrix3d::Identity();
  FastJacobian J;
  FastJointVector dL;
  FastJointVector tau;
  double length = 0.0;
  // Statics.
  double K[kFastMaxDofs * kFastMaxDofs];  // upper triangle by rows: K_ij (j >= i) at i * 16 + j
  FastJointVector dtheta;
  FastJointMatrix K_full;
  Eigen::SelfAdjointEigenSolver<FastJointMatrix> eigen;
  FastJointMatrix self_motion;
  /// J of the last kinematics (or SolveStaticsFast) row-major, row r at r * kFastMaxDofs (the
  /// same values as J): the statics build K from rows of J (vectorisable). Entries beyond m
  /// stay 0.
  double J_rows[6 * kFastMaxDofs];
};

/// The kinematics kernel of ComputeFastKinematics with every movable joint's world rotation
/// stored in ws.frames, for the public kinematics functions. `muscle` < 0: no muscle (dL and
/// tau zero). `world_axes`: J in world axes instead of transducer axes. Returns false when two
/// consecutive path points coincide (as ComputeFastKinematics). q: chain.m entries.
bool ComputeKinematicsWithFrames(const FlatChain& chain, FastWorkspace::Impl& ws, const double* q,
                                 int muscle, double activation, bool world_axes);

}  // namespace isowrench
