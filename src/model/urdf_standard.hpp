#pragma once
// Private: the standard URDF part of a file, checked by isowrench before urdfdom sees it, and
// urdfdom itself called so that no text of the file can reach a printf format.
//
// Why both. urdfdom (3.0.1, Debian's) reports why it rejects an element by logging through
// console_bridge, and several of its messages put the offending text into the printf *format*
// (pose.cpp: CONSOLE_BRIDGE_logError(e.what()) with "Unable to parse component [<text>] to a
// double"; link.cpp: "Material [<name>] ..." and "Inertial: mass [<text>] ..."). An origin
// xyz="%s%s%s 0 0" then crashes the process, "%n" aborts it. console_bridge::log() formats the
// message with vsnprintf *before* it hands it to the output handler (console_bridge console.cpp),
// so no handler can make this safe: the only safe setting is one where log() formats nothing,
// i.e. a log level above every message (CONSOLE_BRIDGE_LOG_NONE) while urdfdom runs. Since
// urdfdom then says nothing, every rule it enforces is checked here first with file:line
// messages (CheckStandardElements), so that urdfdom only ever sees a file it accepts.

#include <tinyxml2.h>
#include <urdf_parser/urdf_parser.h>

#include <string>
#include <vector>

namespace isowrench::urdf_standard {

/// How urdfdom reads one attribute of a standard URDF element.
struct StandardAttribute {
  const char* element;    ///< path below <robot>, e.g. "joint/origin", "link/visual/geometry/box"
  const char* attribute;  ///< e.g. "xyz"
  int numbers;            ///< 0: text; 1: one number; 3: three numbers separated by spaces; 4: rgba
  bool required;          ///< urdfdom rejects the element without it
};

/// Every attribute of a standard URDF element that urdfdom 3.0.1 reads (joint.cpp, link.cpp,
/// pose.cpp, model.cpp), with how it reads it. One row per attribute: extending the checks to
/// another urdfdom attribute is one line in urdf_standard.cpp.
const std::vector<StandardAttribute>& StandardAttributes();

/// A number exactly as urdfdom reads it (urdf_model/utils.h strToDouble: a classic-locale
/// stream that must consume the whole text), and finite. The locale never matters.
bool ParseUrdfdomNumber(const std::string& text, double* value);

/// Check everything urdfdom would reject, before it sees the file: every numeric attribute of
/// StandardAttributes() (a finite number, or 3 / 4 finite numbers separated by spaces, colour
/// components in [0, 1]), the attributes urdfdom requires (robot, link and joint names, limit
/// effort= and velocity=, a <limit> on a revolute or prismatic joint, mass and inertia, a known
/// geometry, mimic joint=, a material's colour or texture), version="1.0", links and materials
/// declared once, joints naming declared links, exactly one root link.
/// @throws Error "<source>:<line>: <origin> attribute xyz = '1 x 0': 'x' is not a number ..."
///         naming the element, the attribute and the value.
void CheckStandardElements(const tinyxml2::XMLElement& robot, const std::string& source);

/// urdf::parseURDF with console_bridge silenced (log level CONSOLE_BRIDGE_LOG_NONE, so that
/// console_bridge::log() returns before it formats anything), the previous level restored
/// afterwards. Calls are serialized (console_bridge's level is process-wide). Returns null when
/// urdfdom rejects the text (CheckStandardElements should have said why first).
urdf::ModelInterfaceSharedPtr ParseQuietly(const std::string& xml);

}  // namespace isowrench::urdf_standard
