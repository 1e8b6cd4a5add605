#pragma once
// Private: the flat chain of CompiledModel and the buffers of FastWorkspace.

#include <Eigen/Eigenvalues>
#include <array>
#include <utility>
#include <vector>

#include "isowrench/fast.hpp"

namespace isowrench {

/// One movable joint, relative to the frame after the previous movable joint (world for the
/// first one), with the fixed joints in between folded into `origin_*`.
struct FastJoint {
  Eigen::Matrix3d origin_rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d origin_translation = Eigen::Vector3d::Zero();
  bool rotation_is_identity = true;
  bool translation_is_zero = true;
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();  ///< unit, in the joint frame
  /// 0/1/2: axis = axis_sign * unit x/y/z (specialised rotation); 3: general axis.
  int axis_kind = 3;
  double axis_sign = 1.0;
  bool revolute = true;
};

/// A muscle path point in the frame after movable joint `frame` (-1 = world).
struct FastPathPoint {
  int frame = -1;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< m, in that frame
};

struct FastMuscle {
  double max_force = 0.0;
  std::vector<FastPathPoint> points;  ///< path order
  /// Point indices ordered by decreasing frame (ground points left out): the order of the
  /// backward torque sweep.
  std::vector<int> sweep_order;
};

/// A path segment shorter than this (m) has no direction (same rule as ComputeMuscleTorque).
inline constexpr double kFastMinSegmentLength = 1e-9;

/// Most path points per muscle the workspace holds.
inline constexpr int kFastMaxPathPoints = 64;

struct CompiledModel::Data {
  explicit Data(Model m) : model(std::move(m)) {}
  Model model;
  int m = 0;
  std::vector<FastJoint> joints;
  std::vector<FastMuscle> muscles;
  /// Endpoint in the frame after the last movable joint (m).
  Eigen::Vector3d endpoint = Eigen::Vector3d::Zero();
  /// Transducer axes: R_W_T = rotation (axes_in_world) or R_last * rotation (turning with
  /// the distal bone; fixed joints after the last movable one folded in).
  bool transducer_in_world = true;
  Eigen::Matrix3d transducer_rotation = Eigen::Matrix3d::Identity();
  bool transducer_identity = true;  ///< in world and R_W_T = I: no rotation of J needed
  StiffnessSet stiffness;
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

}  // namespace isowrench
