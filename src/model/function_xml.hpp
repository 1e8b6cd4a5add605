#pragma once
// Private: the function elements of the URDF extension (docs/urdf-extensions.md), read and
// written. Used by the URDF reader/writer (couplings, moving points) and the OpenSim importer.
//
//   <isowrench:constant value="0.001"/>
//   <isowrench:linear slope="1" intercept="0"/>
//   <isowrench:simm_spline x="-2.09 -1.5 0.17" y="..."/>          (space-separated)
//   <isowrench:natural_cubic_spline x="..." y="..."/>
//   <isowrench:piecewise_linear x="..." y="..."/>
//   <isowrench:polynomial coefficients="c_n ... c_1 c_0"/>          (highest order first)
//   <isowrench:multiplier scale="2"> ONE function element </isowrench:multiplier>

#include <tinyxml2.h>

#include <string>

#include "isowrench/function.hpp"

namespace isowrench {

/// True if `e` is named isowrench:<kind> for one of the function kinds above.
bool IsFunctionElement(const tinyxml2::XMLElement& e);

/// Parse one function element. `source` is the file name used in messages.
/// @throws isowrench::Error "source:line: <element>: rule" for an unknown element, a missing
///         or non-numeric attribute, or knots the Function factories refuse.
Function ParseFunctionXml(const tinyxml2::XMLElement& e, const std::string& source);

/// Parse the one function element among the children of `parent` (children without the
/// isowrench: prefix are ignored). @throws isowrench::Error if there is none, more than one,
/// an isowrench: child that is not a function element, or as ParseFunctionXml.
Function ParseFunctionChild(const tinyxml2::XMLElement& parent, const std::string& source);

/// The element text of `f` (the contract's WriteFunctionXml, returning text): one line per
/// element, each starting with `indent` and ending in a newline; a multiplier's inner
/// function is indented by two more spaces. Numbers have 17 significant
/// digits, so ParseFunctionXml(FunctionXmlText(f)) evaluates bit for bit like f.
std::string FunctionXmlText(const Function& f, const std::string& indent);

}  // namespace isowrench
