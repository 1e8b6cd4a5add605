#pragma once
/// @file
/// Import an OpenSim model (.osim, OpenSim 3.x/4.x documents, versions 30000-40600) as a
/// LimbDescription: the chain from a clamped body to an endpoint body, its coordinates and
/// couplings, and the muscles that stay on it. No OpenSim or Simbody code is needed: the file
/// is read with tinyxml2 and OpenSim's semantics are reproduced (docs/opensim.md).
///
/// Mapping (frames as in OpenSim: X_G_child = X_G_parentbody X_parentbody_P X_PC(q)
/// X_childbody_C^-1):
///  - every joint on the chain becomes a fixed URDF joint for the parent offset frame, then
///    prismatic joints for the translation axes (in the parent frame P, not rotated), then
///    revolute joints for the rotation axes (body-fixed sequence), then a fixed joint for the
///    inverse child offset frame;
///  - an axis driven by a coordinate with the identity carries it (the URDF joint is named
///    after the coordinate); any other function makes a coupled joint (q_joint = f(q_coord));
///    a coordinate no axis carries with the identity becomes a free-standing coordinate;
///  - the joints from ground to the clamped body are baked at their coordinates' default
///    values into one fixed joint, so world axes and positions are those of the .osim;
///  - muscles keep their PathPoints; a MovingPathPoint becomes a PathPoint with moving
///    components (the coordinate clamped to its range, as OpenSim), a ConditionalPathPoint one
///    with an active range (OpenSim's 1e-5 tolerance); wrap objects are ignored with a warning.
/// Lengths are metres, angles radians (the .osim values, never rescaled).

#include <Eigen/Core>
#include <string>
#include <vector>

#include "isowrench/model.hpp"

namespace isowrench {

/// What to import.
struct OpenSimImportOptions {
  /// The body bolted in the experiment (often the pelvis or the femur); "ground" is allowed.
  std::string clamp_body;
  /// The body carrying the transducer; must be distal to clamp_body.
  std::string endpoint_body;
  /// The endpoint in endpoint_body's frame, m (default its origin).
  Eigen::Vector3d endpoint_point = Eigen::Vector3d::Zero();
  /// Coordinates that are locked in the .osim but should be free in the import.
  std::vector<std::string> unlock;
};

/// One line of the import report: a row of a table, already formatted as cells.
struct OpenSimReportTable {
  std::string title;
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
};

/// The result of an import.
struct OpenSimImport {
  /// The imported limb, ready for WriteUrdfFile() or Model.
  LimbDescription description;
  /// Everything the user must know: wrap objects ignored, muscles skipped (and why), units
  /// label disagreeing with the magnitudes, constraints not imported, ... One sentence each.
  std::vector<std::string> warnings;
  /// Bodies, joints (and their URDF expansion), coordinates, muscles: for --report.
  std::vector<OpenSimReportTable> tables;
  /// The .osim document version (e.g. 40000).
  int version = 0;
};

/// Import the .osim file at `path`.
/// @throws isowrench::Error naming the file and line for malformed XML, an unsupported
///         document version, missing sockets, bodies or frames, unknown joint or function
///         types (naming the joint, axis and type), NaN or non-monotonic knots, collinear
///         rotation or translation axes, reversed joints, a clamp or endpoint body that does
///         not exist or is not on one path from ground, and an unknown --unlock coordinate.
OpenSimImport ImportOpenSimFile(const std::string& path, const OpenSimImportOptions& options);

/// Same for a document already in memory; `source_name` appears in messages.
OpenSimImport ImportOpenSimString(const std::string& xml, const std::string& source_name,
                                  const OpenSimImportOptions& options);

/// The tables and warnings of an import as plain text (fixed-width columns).
std::string FormatOpenSimReport(const OpenSimImport& import);

}  // namespace isowrench
