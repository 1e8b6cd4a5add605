#pragma once
/// @file
/// Kinematics of the one engine (the Model's compiled chain, the same kernel as Evaluate):
/// endpoint pose and Jacobian, point Jacobians of muscle path points, and the muscle
/// generalized force tau = -F (dL/dtheta)^T (docs/model.md "Muscle generalized force"). Columns are
/// the Model's independent coordinates (J = J_joints C for coupled joints). tests/core checks
/// them against orocos KDL (ChainJntToJacSolver) to 1e-12 on every shipped model.

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "isowrench/model.hpp"
#include "isowrench/wrap.hpp"

namespace isowrench {

/// Endpoint pose X_W_E in world (the root link's frame). Orientation is the endpoint link's.
Eigen::Isometry3d EndpointPose(const Model& model, Data& data, const Eigen::VectorXd& q);

/// Geometric endpoint Jacobian J_W_E (6 x m): rows [v; w], reference point = endpoint origin,
/// expressed in world axes; the same as KDL's ChainJntToJacSolver with the endpoint as chain tip.
Matrix6Xd EndpointJacobianWorld(const Model& model, Data& data, const Eigen::VectorXd& q);

/// Rotation R_W_T of the transducer axes at posture q (constant when axes_in_world).
Eigen::Matrix3d TransducerRotation(const Model& model, Data& data, const Eigen::VectorXd& q);

/// Endpoint Jacobian in transducer axes: J_T_E = blockdiag(R_W_T^T, R_W_T^T) J_W_E. All 6 rows
/// (released dofs are handled by the statics, not by deleting rows here).
Matrix6Xd EndpointJacobian(const Model& model, Data& data, const Eigen::VectorXd& q);

/// World position (m) of a point fixed at `p_link` (m) on link `link`.
/// @throws Error if the link is not on the chain.
Eigen::Vector3d PointPosition(const Model& model, Data& data, const Eigen::VectorXd& q,
                              const std::string& link, const Eigen::Vector3d& p_link);

/// World positions (m) of muscle `muscle_index`'s path points that are in the path at posture
/// q, origin first: moving points where their coordinates put them, conditional points only
/// while active (PathPoint). @throws Error for a muscle index out of range.
std::vector<Eigen::Vector3d> MusclePathPoints(const Model& model, Data& data,
                                              const Eigen::VectorXd& q, int muscle_index);

/// Muscle `muscle_index`'s path at posture q as the engine computes it (the model's
/// LimbDescription::wrap_mode): its length (m, the one of ComputeKinematics), the elements
/// (active path points and the tangent points of each wrap that wraps, world, m), each wrap's
/// tangent points, arc and WrapStatus bits, and the path's status (0: no wrap misbehaved). A
/// muscle without wraps gives its straight path (elements = the active points, no wraps).
/// @throws Error for a muscle index out of range, a bad posture, or coincident path points.
WrappedPath MuscleWrappedPath(const Model& model, Data& data, const Eigen::VectorXd& q,
                              int muscle_index);

/// Linear Jacobian (3 x m, world axes, m/rad or m/m) of a point fixed on a link.
/// Zero for the root link. @throws Error if the link is not on the chain.
Eigen::Matrix3Xd PointJacobian(const Model& model, Data& data, const Eigen::VectorXd& q,
                               const std::string& link, const Eigen::Vector3d& p_link);

/// A muscle's length, its derivative and its generalized force at a posture.
struct MuscleTorque {
  double length = 0.0;  ///< m, sum of segment lengths (L_MT)
  double force = 0.0;   ///< N, F(L_MT, a) of the muscle's force model (force_stage.force)
  /// The force stage at this length (MuscleForceAt): force, active and passive parts, fiber
  /// length, pennation, status (kNoEquilibrium: tau is 0 and not a number to use).
  MuscleForce force_stage;
  Eigen::RowVectorXd dL_dq;  ///< 1 x m, m/rad (revolute) or m/m (prismatic)
  Eigen::VectorXd tau;       ///< m, -force * dL_dq^T: N·m (revolute) or N (prismatic)
};

/// Evaluate muscle `muscle_index` at activation `activation` (force = MuscleForceAt(L_MT, a):
/// activation * max_force for a constant-force muscle).
/// @throws Error if a path segment has zero length (coincident points) or activation is not
///         finite or not in [0, 1].
MuscleTorque ComputeMuscleTorque(const Model& model, Data& data, const Eigen::VectorXd& q,
                                 int muscle_index, double activation = 1.0);

}  // namespace isowrench
