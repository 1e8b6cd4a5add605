#pragma once
// Private checks of a URDF before and after it is read (src/model/urdf_reader.cpp calls them):
// the joint tree's structure (so urdfdom never sees a loop), the attributes of every isowrench:
// element (one table per element, with "did you mean" suggestions), and declarations made twice
// or where nothing reads them. Plausibility warnings are DescriptionWarnings()
// (include/isowrench/input_checks.hpp), shared with every other reader.

#include <tinyxml2.h>

#include <functional>
#include <string>
#include <vector>

#include "isowrench/model.hpp"

namespace isowrench::urdf_checks {

/// The joints of <robot> must form a tree: no joint whose parent link is its child link, no
/// link that is the child of two joints, no loop of joints. Runs in O(joints log joints).
/// @throws Error "<source>:<line>: ..." naming the joints involved.
void CheckJointTree(const tinyxml2::XMLElement& robot, const std::string& source);

/// Every attribute of every isowrench: element inside `robot` (at any depth) must be one the
/// element understands. Elements without a table (unknown ones) are left to their parser.
/// @throws Error "<source>:<line>: <isowrench:joint> has no attribute 'stifness' (did you mean
///         'stiffness'?); its attributes are name, role, stiffness, locked".
void CheckExtensionAttributes(const tinyxml2::XMLElement& robot, const std::string& source);

/// isowrench's XML namespace, as the writer declares it: xmlns:isowrench="urn:isowrench:urdf:1".
inline constexpr const char* kNamespaceUri = "urn:isowrench:urdf:1";

/// Declarations the reader would otherwise drop or silently override, each an error naming both
/// lines involved:
///  - an element in isowrench's namespace under another prefix (xmlns:iw="urn:isowrench:urdf:1"
///    then <iw:muscle>, or a default xmlns= bound to it): isowrench reads the prefix isowrench:;
///  - an element whose prefix no xmlns: declares (<iw:muscle> with no xmlns:iw);
///  - an isowrench: element inside a standard element, where nothing reads it
///    (<isowrench:muscle> inside a <link>): table Placement() in urdf_checks.cpp;
///  - the same declaration twice: two <isowrench:joint name="base_z">, two
///    <isowrench:transducer>, two postures of one coordinate...: table UniqueKeys().
/// @throws Error "<source>:<line>: ... (first at line <n>)".
void CheckDeclarations(const tinyxml2::XMLElement& robot, const std::string& source);

/// The attribute names an isowrench element (local name, e.g. "joint") accepts; empty for an
/// element without a table.
const std::vector<std::string>& AllowedAttributes(const std::string& local_name);

}  // namespace isowrench::urdf_checks
