#pragma once
/// @file
/// A model's wrapping muscles at one posture for the reports that show the wraps: `draw` (the
/// wrapped path and the wrap surfaces), `import --report` and `kinematics` (how far the opensim
/// and exact modes differ, and where OpenSim's algorithm misbehaves). The paths are the
/// engine's (MuscleWrappedPath, include/isowrench/kinematics.hpp: the one walk of a muscle's
/// points and wraps); the other mode is the same model in that mode (ModelInWrapMode).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "isowrench/kinematics.hpp"
#include "isowrench/model.hpp"
#include "isowrench/wrap.hpp"

namespace isowrench {

/// The world pose of a wrap object's frame S at posture q: X_W_link(q) * WrapObjectSpec::Pose().
/// @throws Error for a link not on the chain.
Eigen::Isometry3d WrapObjectPose(const Model& model, Data& data, const Eigen::VectorXd& q,
                                 const WrapObjectSpec& object);

/// `model` with its wraps computed in `mode` (LimbDescription::wrap_mode = mode, everything else
/// the same): how a report evaluates the mode the model is not in (a Model costs about 0.2 ms
/// to build for the 39-wrap rat hindlimb).
Model ModelInWrapMode(const Model& model, WrapMode mode);

/// How far the opensim and exact modes differ for one wrapping muscle at one posture.
struct WrapModeDifference {
  int muscle = -1;                     ///< index of the muscle
  double length_opensim = 0.0;         ///< m
  double length_exact = 0.0;           ///< m
  double length_straight = 0.0;        ///< m, through the active points without wrapping
  Eigen::VectorXd moment_arm_opensim;  ///< m (m/m prismatic), per coordinate
  Eigen::VectorXd moment_arm_exact;    ///< m (m/m prismatic), per coordinate
  /// m: |moment_arm_opensim - moment_arm_exact| at `coordinate`, the largest over coordinates
  double moment_arm_difference = 0.0;
  int coordinate = -1;          ///< column of the largest difference (-1: no coordinate)
  unsigned status_opensim = 0;  ///< WrappedPath::status in opensim mode (WrapStatus bits)
  unsigned status_exact = 0;    ///< WrappedPath::status in exact mode
  int wraps_engaged = 0;        ///< wraps whose tangent points are in the opensim path
  /// m: length_opensim - length_exact (positive: OpenSim's path is longer than the shortest)
  double LengthDifference() const { return length_opensim - length_exact; }
};

/// The two modes of muscle `muscle` at posture q: in each, the engine's length, status and
/// moment arms (MuscleWrappedPath, -ComputeMuscleTorque().dL_dq) of `model` (on `data`) for its
/// own mode and of ModelInWrapMode(model, other) for the other; the straight length through the
/// active points (MusclePathPoints). @throws Error for a bad index, posture or coincident points.
WrapModeDifference CompareWrapModes(const Model& model, Data& data, const Eigen::VectorXd& q,
                                    int muscle);

/// CompareWrapModes of every wrapping muscle (WrappingMuscles order) at posture q, the model
/// in the other mode built once: `kinematics` and Python's Model.kinematics() "wrap_modes".
std::vector<WrapModeDifference> CompareWrapModes(const Model& model, Data& data,
                                                 const Eigen::VectorXd& q);

/// The status bits of OpenSim's algorithm that mean it misbehaves (a path below the straight
/// line, no convergence, a negative arc, a degenerate configuration): the bits a report names.
inline constexpr unsigned kWrapMisbehaviour =
    kWrapBelowStraightLine | kWrapNotConverged | kWrapNegativeArc | kWrapDegenerate;

/// CompareWrapModes over a small sweep: posture q0, then each coordinate with a finite range
/// [lower, upper] in turn at `steps` (>= 2) evenly spaced values over it, the others at q0
/// (coordinates with an infinite range are not swept).
struct WrapModeSweep {
  WrapModeDifference at_q0;  ///< at q0
  int postures = 0;          ///< postures evaluated, q0 included
  /// m: the largest |length_opensim - length_exact| and where
  double max_length_difference = 0.0;
  Eigen::VectorXd max_length_posture;
  /// m (m/m prismatic): the largest moment-arm difference, its coordinate and where
  double max_moment_arm_difference = 0.0;
  int max_moment_arm_coordinate = -1;
  Eigen::VectorXd max_moment_arm_posture;
  /// Union over the postures of status_opensim & kWrapMisbehaviour, and the postures with any
  unsigned misbehaviour = 0;
  int misbehaving_postures = 0;
  Eigen::VectorXd first_misbehaving_posture;  ///< empty when none
};

/// The sweep of WrapModeSweep for muscle `muscle`. @throws Error for steps < 2 or a bad index.
WrapModeSweep SweepWrapModes(const Model& model, Data& data, const Eigen::VectorXd& q0, int muscle,
                             int steps);

/// Differences between the modes below this (m, or m/m) are the rounding of two computations
/// of one path: the reports print them as 0.
inline constexpr double kWrapReportNoise = 1e-12;

/// A difference (m, or m/m) as mm (mm/m) text with 3 significant digits, "0" when its size is
/// below kWrapReportNoise.
std::string FormatWrapMm(double difference);

/// Indices of the muscles with at least one wrap (MuscleSpec::wraps not empty), model order.
std::vector<int> WrappingMuscles(const Model& model);

}  // namespace isowrench
