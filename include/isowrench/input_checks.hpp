#pragma once
/// @file
/// Limits on user input and the warning channel for input that is legal but implausible.
///
/// Errors (isowrench::Error) stop a run; warnings do not: they report input that is probably a
/// mistake (a 45 m phalanx, a CSV without a joint column, an angle far outside the joint's
/// range) and let the run continue. Every warning is a complete sentence naming the culprit.

#include <Eigen/Core>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "isowrench/model.hpp"

namespace isowrench {

/// Largest stiffness isowrench accepts (N/m for translations, N·m/rad for rotations).
///
/// Why 1e15: the stiffest thing a limb experiment can contain is a short steel part; a
/// 10 cm x 10 cm steel bar 1 mm long has E·A/L = 2e11 Pa · 1e-2 m² / 1e-3 m = 2e12 N/m, and
/// rigid six-axis transducers are 1e7..1e9 N/m and 1e3..1e6 N·m/rad (datasheets, docs/model.md).
/// 1e15 is three decades above anything physical and still leaves the statics far from
/// overflow: K = J^T S J sums products of stiffness and squared lever arms (metres), so its
/// entries stay below ~1e18 for limbs under 30 m, i.e. 290 decades below DBL_MAX. A rigid
/// connection is written as a released dof's complement (omit the joint) or as a large but
/// physical stiffness, never as 1e308.
constexpr double kMaxStiffness = 1e15;

/// Largest force (N) or moment (N·m) magnitude a measured wrench may hold: no muscle or
/// transducer in a limb experiment comes near 1e6 N (a hundred tonnes-force).
constexpr double kMaxMeasuredWrench = 1e6;

/// Plausible range of one limb segment (distance between consecutive joint centres, or from
/// the last joint to the endpoint), in metres: from a mouse phalanx (~1 mm) to an elephant's
/// leg segment (~2 m). Lengths of 0 (co-located joints of a ball or universal joint) are fine.
constexpr double kMinSegmentLength = 1e-3;
constexpr double kMaxSegmentLength = 2.0;

/// Plausible straight-line muscle path length at the nominal posture (m): 1 mm .. 2 m.
constexpr double kMinMuscleLength = 1e-3;
constexpr double kMaxMuscleLength = 2.0;

/// Receives warnings. The default handler writes "isowrench: warning: <message>" to stderr.
using WarningHandler = std::function<void(const std::string& message)>;

/// Install a process-wide warning handler (thread-safe); returns the previous one. An empty
/// handler restores the default (stderr).
WarningHandler SetWarningHandler(WarningHandler handler);

/// Report a warning through the current handler (thread-safe).
void Warn(const std::string& message);

/// Collects the warnings issued during its lifetime instead of printing them (tests, GUIs);
/// restores the previous handler on destruction. Not for concurrent use from several threads
/// with different collectors.
class WarningCollector {
 public:
  WarningCollector();
  ~WarningCollector();
  WarningCollector(const WarningCollector&) = delete;
  WarningCollector& operator=(const WarningCollector&) = delete;
  /// The warnings so far, in order.
  std::vector<std::string> warnings() const;
  /// All warnings joined by newlines (for substring assertions).
  std::string text() const;

 private:
  struct State;
  std::shared_ptr<State> state_;
  WarningHandler previous_;
};

/// Check a stiffness value: finite, >= 0 and <= kMaxStiffness.
/// @throws Error "<where>: stiffness <value> <unit> ..." naming the rule that failed; `where`
///         says where the value came from (file:line and element, a CLI option, an API call).
void CheckStiffnessValue(double stiffness, const std::string& where);

// ---- Plausibility: one place for every reader and option -----------------------------------
// The URDF reader, --posture, Python's q, the trial CSV reader and the OpenSim importer all ask
// these functions and only these, so a value means the same everywhere and the thresholds and
// wording live here. They return complete sentences and never throw for a legal value: callers
// print them (Warn: "isowrench: warning: ..." on stderr) or raise them as Python UserWarnings.

/// Largest plausible value of a revolute coordinate or joint, rad: a full turn. Beyond it no
/// limb joint goes; it is usually degrees written where radians are meant (-60 "rad" is
/// -3437.75 deg), or an angle typed in the wrong file.
constexpr double kFullTurn = 2 * 3.14159265358979323846;

/// Beyond these a value cannot be a joint position at all (an error, not a warning): a
/// thousand turns (rad) for a revolute coordinate, 2 km (m) for a prismatic one. Posture
/// options, posture and trial CSVs refuse them; they also keep the conversion from user units
/// finite (-1e308 deg overflowed to -inf: posture_fuzzer).
constexpr double kImpossibleRevolute = 1e3 * kFullTurn;
constexpr double kImpossiblePrismatic = 2000.0;

/// The limb's own length (m): the distances between consecutive joint origins along the chain
/// plus the endpoint offset (the definition of Model::chain_length, computed from a
/// description so that readers can use it before a Model exists).
double LimbLength(const LimbDescription& description);

/// The warning for one coordinate value (rad for revolute, m for prismatic), or "" when it is
/// plausible: outside the coordinate's URDF limits [lower, upper]; beyond a full turn
/// (revolute); moving the endpoint more than `limb_length` (prismatic; ignored when
/// limb_length <= 0). The sentence starts with `where` ("limb.urdf:47", "--posture", "q") and
/// gives the value in user units (deg, mm) and model units (rad, m), and the likely slip:
/// degrees or millimetres typed where radians or metres are read, unless the value was typed in
/// user units (`typed_in_user_units`: --posture, a posture or trial CSV), where it is a typo or
/// another column.
std::string CoordinateValueWarning(const CoordinateSpec& coordinate, double value,
                                   double limb_length, const std::string& where,
                                   bool typed_in_user_units = false);

/// Warnings about posture `q` (rad / m, one entry per coordinate of `description` in column
/// order, as Model::nominal_posture): CoordinateValueWarning for each coordinate in `only` (all
/// when empty), then for each joint driven by one of them through a coupling (a <mimic> or an
/// <isowrench:coupling>), its value at q: a revolute joint beyond a full turn, a prismatic joint
/// moving the endpoint more than the limb's own length (a mimic multiplier in m/rad where
/// mm/rad was meant). `where(coordinate)` starts each sentence; when empty, "posture".
/// `typed_in_user_units` as for CoordinateValueWarning.
/// @throws Error if q does not have one entry per coordinate.
std::vector<std::string> PostureWarnings(
    const LimbDescription& description, const Eigen::VectorXd& q,
    const std::function<std::string(const std::string& coordinate)>& where = {},
    const std::vector<std::string>& only = {}, bool typed_in_user_units = false);

/// The warning for a rotation written as URDF roll-pitch-yaw (rad), or "" when no component
/// exceeds a full turn (degrees written where radians are meant: rpy="0 0 90" turns 90 rad).
/// `what` names it ("limb.urdf:37: <isowrench:transducer> rpy").
std::string RotationWarning(const Eigen::Vector3d& rpy, const std::string& what);

/// Warnings about a whole description: each joint origin's distance and the endpoint offset
/// outside the plausible segment length (kMinSegmentLength .. kMaxSegmentLength), each muscle's
/// path length at the nominal posture outside kMinMuscleLength .. kMaxMuscleLength, and the
/// nominal posture (PostureWarnings with the limb's length). `where(name)` gives the location
/// (file:line) of joint `name`, of muscle "muscle:<name>", of the nominal posture of coordinate
/// "posture:<name>", or of the transducer (""); when empty, the description's source.
std::vector<std::string> DescriptionWarnings(
    const LimbDescription& description,
    const std::function<std::string(const std::string& name)>& where = {});

/// Warn() each message, in order.
void WarnAll(const std::vector<std::string>& messages);

/// The name in `candidates` closest to `name` by edit distance (Levenshtein, case-insensitive),
/// or "" if none is close (distance > max(2, |name| / 3)).
std::string ClosestName(const std::string& name, const std::vector<std::string>& candidates);

/// " (did you mean 'x'?)" for ClosestName, or "" when nothing is close.
std::string DidYouMean(const std::string& name, const std::vector<std::string>& candidates);

}  // namespace isowrench
