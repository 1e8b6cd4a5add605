#pragma once
/// @file
/// Postures: joint positions in the model's column order (rad for revolute joints, m for
/// prismatic ones), and the user-facing "name=value" syntax in degrees / millimetres.

#include <Eigen/Core>
#include <string>
#include <vector>

#include "isowrench/model.hpp"

namespace isowrench {

/// Apply assignments like "hip_rz=-110,knee_rz=105" to `q` (a copy is returned). Values are
/// degrees for revolute joints and millimetres for prismatic joints.
/// @throws Error naming the joint for unknown joints, malformed or non-finite values.
Eigen::VectorXd ApplyPostureAssignments(const Model& model, Eigen::VectorXd q,
                                        const std::string& assignments);

/// ApplyPostureAssignments, and in `warnings` the plausibility warnings of the values it set
/// (PostureWarnings of isowrench/input_checks.hpp for the named coordinates: outside the joint's
/// limits, beyond a full turn, coupled joints moved too far), each starting with `label` and
/// the item ("--posture hip_rz=-3437: hip_rz = -3437° (-59.99 rad) is more than a full turn").
/// @throws Error as ApplyPostureAssignments.
Eigen::VectorXd ApplyPostureAssignments(const Model& model, Eigen::VectorXd q,
                                        const std::string& assignments,
                                        std::vector<std::string>* warnings,
                                        const std::string& label = "--posture");

/// A joint value in user units (degrees for revolute joints, mm for prismatic ones) in the
/// model's units (rad, m), and back.
double JointValueFromUserUnits(JointType type, double user_value);
double JointValueToUserUnits(JointType type, double model_value);

/// Set one joint from a user value (degrees or mm). @throws Error as above.
void SetJointFromUserUnits(const Model& model, Eigen::VectorXd& q, const std::string& joint,
                           double value);

/// A readable posture, e.g. "hip_rz=-110.0°, knee_rz=105.0°" (non-zero joints only, or all
/// joints when `all` is true).
std::string FormatPosture(const Model& model, const Eigen::VectorXd& q, bool all = false);

/// Postures from CSV text: a header row naming coordinates (FindCoordinate: a driven joint is
/// refused with the name of its driver), then one posture per row in user units (degrees, mm
/// for prismatic coordinates). Coordinates without a column, and empty cells, keep their value
/// in `base` (e.g. model.nominal_posture()). Fields are separated by commas; blank lines and
/// lines starting with '#' are skipped. `source` names the text in messages. An implausible
/// value (PostureWarnings: outside the joint's limits, beyond a full turn...) warns through
/// Warn(), once per column.
/// @throws Error "<source>:<line>: ..." for an unknown or repeated column (with the closest
///         coordinate name), a row with the wrong number of fields, or a value that is not a
///         finite number (naming the column), or a file with no posture row.
std::vector<Eigen::VectorXd> ParsePostureCsv(const Model& model, const std::string& text,
                                             const std::string& source,
                                             const Eigen::VectorXd& base);

/// ParsePostureCsv on the contents of a file. @throws Error also if it cannot be read.
std::vector<Eigen::VectorXd> ReadPostureCsv(const Model& model, const std::string& path,
                                            const Eigen::VectorXd& base);

/// URDF roll-pitch-yaw (rad) of a rotation matrix: R = Rz(yaw) Ry(pitch) Rx(roll), roll and yaw
/// in (-pi, pi], pitch in [-pi/2, pi/2] (at pitch = ±pi/2 the roll is 0 and yaw carries it).
Eigen::Vector3d RollPitchYaw(const Eigen::Matrix3d& rotation);

/// "rpy 0 0 1.571 rad (0° 0° 90°)" for a rotation matrix, or "not rotated" for the identity.
std::string FormatRotation(const Eigen::Matrix3d& rotation);

/// Check that q has model.dof_count() finite entries. @throws Error otherwise.
void ValidatePosture(const Model& model, const Eigen::VectorXd& q);

}  // namespace isowrench
