#pragma once
// Private: the coordinate and coupling part of the URDF reader (src/model/urdf_reader.cpp calls
// it): <isowrench:coordinate>, the standard <mimic> of a joint, <isowrench:coupling>, and
// locked= / role= / stiffness= of <isowrench:joint> elements naming a coordinate.

#include <tinyxml2.h>

#include <string>

#include "isowrench/model.hpp"

namespace isowrench::urdf_coordinates {

/// Read the free-standing coordinates, the mimics of the chain's joints and the couplings into
/// `d` (d.joints must hold the chain): every movable joint gets its independent coordinate and
/// the composed function (a mimic of a mimic resolves to the independent coordinate), and
/// d.coordinates is filled in column order (NormalizeCoordinates).
/// @throws Error "<source>:<line>: ..." for an unknown, fixed or off-chain mimicked joint, a
///         mimic cycle (naming the joints), a coupling of a fixed or unknown joint, a joint both
///         mimic and coupled, a coupling naming an unknown or driven coordinate, a bad function.
void ReadCoordinates(const tinyxml2::XMLElement& robot, const std::string& source,
                     LimbDescription& d);

/// True when an <isowrench:joint name=...> names a free-standing coordinate (no joint carries
/// it): ApplyJointTags() handles those, the reader's joint branch does not.
bool NamesFreeCoordinate(const tinyxml2::XMLElement& joint_tag, const LimbDescription& d);

/// locked= on every <isowrench:joint>, and role=/stiffness= on those naming a free-standing
/// coordinate; refuses any of them on a driven joint ("set 'knee_rz' instead"). Then
/// normalizes the coordinates again (joint stiffness and roles onto their coordinates).
/// @throws Error "<source>:<line>: ...".
void ApplyJointTags(const tinyxml2::XMLElement& robot, const std::string& source,
                    LimbDescription& d);

/// The coordinate an <isowrench:posture joint=...> sets. @throws Error "<source>:<line>: ..."
/// (FindCoordinate's message: unknown name with a suggestion, or a driven joint's driver).
const CoordinateSpec& PostureCoordinate(const tinyxml2::XMLElement& posture,
                                        const std::string& source, const LimbDescription& d);

/// m * f(x) + o as one Function of the same family (exact: splines are linear in their knot
/// values). Used to resolve a mimic of a coupled joint.
Function ComposeLinear(double multiplier, double offset, const Function& f);

}  // namespace isowrench::urdf_coordinates
