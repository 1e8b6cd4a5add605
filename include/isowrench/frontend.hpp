#pragma once
/// @file
/// What the command line (src/cli) and the Python module (python/src/module.cpp) share, so that
/// their syntax, units, defaults and overrides cannot drift: loading a limb (URDF or .osim),
/// the model overrides (one struct, applied in one place), the syntax of lists, assignments and
/// stiffness vectors, postures from user values (with the plausibility warnings of
/// isowrench/input_checks.hpp), and a simulation written to a trial CSV. The defaults are the
/// library's option structs' (SimulationOptions): neither layer has its own.
///
/// Units: the command line types joint values in degrees and millimetres (PostureFromUserText);
/// Python passes radians and metres (PostureFromValues). Stiffnesses are N/m and N·m/rad in
/// both.

#include <Eigen/Core>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "isowrench/identification.hpp"
#include "isowrench/model.hpp"
#include "isowrench/opensim.hpp"
#include "isowrench/trial_csv.hpp"

namespace isowrench {

struct MuscleForce;         // isowrench/muscle.hpp
struct WrapModeDifference;  // isowrench/wrap_report.hpp

/// Whose names an option has in messages: the command line's ("--joint-stiffness") or Python's
/// keyword ("joint_stiffness").
enum class OptionStyle { kCommandLine, kPython };

/// `cli_name` ("--joint-stiffness") as the user typed it in `style` ("joint_stiffness" in
/// Python).
std::string OptionName(const std::string& cli_name, OptionStyle style);

/// Read a limb: a URDF with isowrench tags, or an OpenSim model (.osim, by its extension) imported
/// with `osim` (clamp and endpoint bodies required). Import warnings and the readers'
/// plausibility warnings go through Warn().
/// @throws Error naming the file (a missing file, a bad model, a .osim without `osim`).
LimbDescription LoadLimb(const std::string& path, const OpenSimImportOptions* osim = nullptr);

/// The changes to a loaded limb a user asks for on the command line or in Python. Applied in
/// one place, ApplyOverrides, in the order of the fields; a new override is one field here and
/// one line there.
struct ModelOverrides {
  /// Released transducer dofs, replacing the model's (--release; Python released=).
  std::optional<DofMask> released;
  /// Transducer stiffness preset (--transducer; Python transducer="jr3"): balanced, ati-mini40,
  /// jr3. Exclusive with transducer_stiffness.
  std::string transducer_preset;
  /// S_t diagonal kx ky kz (N/m) krx kry krz (N·m/rad) (--transducer-stiffness; Python
  /// transducer=[6 values]).
  std::optional<Vector6d> transducer_stiffness;
  /// Base translation stiffness, N/m (--base-stiffness): sets base_x/y/z, inserting them when
  /// the limb has none.
  std::optional<double> base_stiffness;
  /// S_p entries by coordinate, N·m/rad or N/m, applied in order (--joint-stiffness J=K).
  std::vector<std::pair<std::string, double>> joint_stiffness;
  /// Locked coordinates replacing the model's locks (--lock A,B; Python locked=[...]); an empty
  /// list or {"none"} unlocks every coordinate. Applied last, so it can name the base dofs
  /// base_stiffness added.
  std::optional<std::vector<std::string>> locked;
  /// How wrapped muscle paths are computed (--wrap opensim|exact; Python wrap="exact"):
  /// LimbDescription::wrap_mode, read by every length, moment arm, torque and wrench.
  std::optional<WrapMode> wrap;
  /// The force model of every muscle for this run (--force-model; Python force_model=):
  /// "" or "model": each muscle's own (MuscleSpec::force); "constant": F = a * max_force for
  /// every muscle (the paper's model, today's numbers); "rigid": each muscle's own curves with
  /// a rigid tendon (MuscleForceSpec::ignore_tendon_compliance; constant muscles stay
  /// constant). Anything else: an Error naming the value and the known ones.
  std::string force_model;

  /// True when nothing is overridden.
  bool empty() const;
};

/// `description` with `overrides` applied. Each value is checked where it is applied
/// (CheckStiffnessValue, DofMask, TransducerPreset) with messages naming the option in `style`.
/// @throws Error naming the option and the value ("--base-stiffness: stiffness 1e+308 exceeds
///         the physical maximum 1e+15 ...", an unknown coordinate with the closest name).
LimbDescription ApplyOverrides(LimbDescription description, const ModelOverrides& overrides,
                               OptionStyle style = OptionStyle::kCommandLine);

/// The statics options a user sets (--max-endpoint-fraction, --max-joint-rotation,
/// --rank-tolerance; Python max_endpoint_fraction=, ...): each finite and > 0, rank_tolerance
/// also < 1. @throws Error naming the option in `style` and the value ("--max-joint-rotation
///         nan: must be a finite number > 0").
void CheckStaticsOptions(const StaticsOptions& options,
                         OptionStyle style = OptionStyle::kCommandLine);

/// "A,B, C" -> {"A", "B", "C"}: the one syntax of every list option (muscles, dofs, effects,
/// columns); blanks around items are dropped, as are empty items.
std::vector<std::string> ParseList(const std::string& text);

/// "name=value" -> {name, value}. @throws Error "<option> '<text>' is not name=value" or naming
///         the value that is not a number.
std::pair<std::string, double> ParseAssignment(const std::string& text, const std::string& option);

/// A sheet's field separator as a user names it: ",", ";", "\t" or "tab", "|", or "comma",
/// "semicolon", "pipe" (names survive shells and CMake lists). @throws Error for anything else.
char DelimiterChar(const std::string& text);

/// "kx,ky,kz,krx,kry,krz" (N/m, N·m/rad) -> the S_t diagonal, each value checked
/// (CheckStiffnessValue). @throws Error naming `option` and the dof.
Vector6d ParseTransducerStiffness(const std::string& text, const std::string& option);

/// "foot" or "foot:0.01,-0.005,0" (m, in the body's frame) into options.endpoint_body and
/// endpoint_point. @throws Error naming `option` when the point is not three numbers.
void ParseEndpoint(const std::string& text, OpenSimImportOptions& options,
                   const std::string& option = "--endpoint");

/// `base` (rad / m, column order) with coordinates set from values typed in user units
/// ("hip_rz=-110,knee_rz=105": degrees, mm for prismatic ones); the plausibility warnings of
/// the values set go to `warnings` (PostureWarnings), each starting with `option` and the item.
/// @throws Error as ApplyPostureAssignments.
Eigen::VectorXd PostureFromUserText(const Model& model, const Eigen::VectorXd& base,
                                    const std::string& text, std::vector<std::string>* warnings,
                                    const std::string& option = "--posture");

/// A posture from values in model units: `values` by coordinate name over `base` (Python's
/// dict), or all of them when `all` is given (Python's sequence, column order). Checks the
/// size and that every value is finite, then puts the plausibility warnings of the values given
/// in `warnings`, each starting with "<label>['<coordinate>']".
/// @throws Error naming the coordinate (unknown, with the closest name; not finite) or the size.
Eigen::VectorXd PostureFromValues(const Model& model, const Eigen::VectorXd& base,
                                  const std::vector<std::pair<std::string, double>>& values,
                                  const Eigen::VectorXd* all, std::vector<std::string>* warnings,
                                  const std::string& label = "q");

/// What SimulateToCsv did.
struct SimulationRun {
  long trials = 0;                     ///< rows written
  std::vector<AppliedEffect> effects;  ///< the effects, parsed
  std::string output;                  ///< the file written
  /// {"output", "trials", "seed", "noise_force_N", "noise_moment_Nm", "range_deg", "effects":
  /// [{"id", "parameters": [{"name", "value", "unit"}]}]}: `isowrench simulate --json`.
  std::string json;
};

/// Simulated trials of `model` with the undeclared `effects` ("NAME=V1,V2" in user units,
/// ParseEffectAssignment) written to `path` as a trial CSV (TrialCsvWriter, with sd columns),
/// streamed (ForEachSimulatedTrial) and atomically (nothing at `path` on error). The CLI's
/// `simulate` and Python's isowrench.simulate; their defaults are SimulationOptions{}'s.
/// @throws Error as ParseEffectAssignment, ForEachSimulatedTrial, or naming the file.
SimulationRun SimulateToCsv(const Model& model, const std::vector<std::string>& effects,
                            const SimulationOptions& options, const std::string& path,
                            const TrialProgress& progress = {});

/// The trials a posture sheet asks for (simulate --postures, Python simulate(postures=),
/// design --postures; isowrench design -o writes such a sheet): one trial per row at the row's
/// posture (coordinate columns in degrees / mm, others at the nominal posture), with the row's
/// muscle when the sheet has a `muscle` column and its activation when it has an `activation`
/// column (NaN otherwise: "draw it"). Measured columns are not read. TrialReader with
/// TrialSheetOptions::postures_only (the fields of `sheet` otherwise apply).
/// @throws Error "<path>:<line>: ..." as TrialReader, or for a sheet without rows.
std::vector<Trial> ReadPostureSheet(const Model& model, const std::string& path,
                                    TrialSheetOptions sheet = {});

/// Set `options` to simulate at the postures of the posture sheet `path` (simulate --postures,
/// Python simulate(postures=)): options->at = ReadPostureSheet(model, path); one trial per row
/// unless `trials` > 0 (rows cycled); exactly at each row unless `keep_ranges` (the ranges are
/// then the jitter around each row).
/// @throws Error as ReadPostureSheet.
void SimulateAtPostureSheet(const Model& model, const std::string& path, int trials,
                            bool keep_ranges, SimulationOptions* options,
                            const TrialSheetOptions& sheet = {});

/// The header and rows of a posture sheet for `trials` (columns of `model`, degrees / mm, the
/// muscle and activation of each trial), with empty measured columns fx ... mz for the lab to
/// fill in: what isowrench design -o writes, ReadPostureSheet and (filled in) the fit read.
/// `comment` becomes the first line ("# ...").
std::string PostureSheetText(const Model& model, const std::vector<Trial>& trials,
                             const std::string& comment);

/// Muscle `muscle`'s force stage `force` (at the asked `activation`) as one JSON object, in
/// text: the "force" entry of every report's --json (kinematics, wrench, releases, diagnose) and,
/// parsed, Python's force dicts, so the two cannot drift: {"model" (ForceModelName), "tendon"
/// ("none", "rigid", "compliant"), "activation" (as asked), "force_n", "active_force_n",
/// "passive_force_n" (N, along the tendon), "fiber_length_m" (m), "pennation_rad" (rad),
/// "tendon_strain" (1), "activation_used" (as the force model clamps it), "status"
/// (MuscleForceStatusName), "opensim_gives_no_number"[, "opensim_note" (OpenSimNote, when
/// not empty)]}. Numbers round-trip exactly (shortest text that reads back the same double).
std::string ForceStageJson(const Model& model, int muscle, const MuscleForce& force,
                           double activation);

/// How far the opensim and exact wrap modes differ for one wrapping muscle at one posture
/// (CompareWrapModes, include/isowrench/wrap_report.hpp) as one JSON object, in text: the
/// "wrap_modes" entries of `kinematics --json` and, parsed, of Python's Model.kinematics():
/// {"length_opensim_m", "length_exact_m" (m), "length_difference_mm" (opensim - exact, mm),
/// "moment_arm_difference_mm" (the largest |opensim - exact| over the coordinates, mm; mm/m for
/// a prismatic coordinate), "moment_arm_difference_coordinate" (its coordinate, null when the
/// model has none), "wraps_engaged", "opensim_misbehaves" (WrapStatusText of the
/// kWrapMisbehaviour bits, "" when OpenSim's algorithm behaves)}.
std::string WrapModeJson(const Model& model, const WrapModeDifference& difference);

}  // namespace isowrench
