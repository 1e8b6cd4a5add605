#pragma once
/// @file
/// The one exception type isowrench throws for bad user input.
///
/// Error policy (three tiers):
///  1. Bad input (malformed URDF, unknown joint/muscle/link names, NaN, negative stiffness,
///     broken CSV rows, missing files) throws isowrench::Error. The message names the culprit
///     (file and line, joint, column), the offending value and the rule it breaks.
///  2. Numerical outcomes (singular stiffness, self-motion, invalid small-motion assumption,
///     non-converged fit) are reported as a status plus message inside the result, never as an
///     exception and never as NaN.
///  3. Internal invariants use assert().

#include <stdexcept>
#include <string>

namespace isowrench {

/// Thrown for bad user input; what() is a complete sentence naming the culprit.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace isowrench
