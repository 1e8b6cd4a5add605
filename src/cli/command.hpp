#pragma once
// Private: the CLI's command registry and the options every model-based command shares.
// Each command lives in src/cli/<name>_command.cpp and registers itself with a static
// `const bool k<Name>Registered = RegisterCommand({...});` (a name unique to the file: the
// commands are compiled together as a unity build, CMakeLists.txt).

#include <CLI/CLI.hpp>
#include <Eigen/Core>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "isowrench/frontend.hpp"
#include "isowrench/model.hpp"
#include "isowrench/statics.hpp"
#include "isowrench/trial_csv.hpp"

namespace isowrench::cli {

/// A subcommand: `setup` adds its options to the CLI11 subcommand and returns the function that
/// runs it after parsing (returning the process exit code).
struct Command {
  std::string name;
  std::string description;
  int order = 100;  ///< position in --help
  std::function<std::function<int()>(CLI::App&)> setup;
};

bool RegisterCommand(Command command);
std::vector<Command>& RegisteredCommands();

/// Options shared by commands that load one limb and override parts of it.
struct ModelOptions {
  std::string urdf;
  std::string posture;               ///< "joint=deg,..." applied over the nominal posture
  std::vector<std::string> release;  ///< transducer dofs to release ("none" clears)
  bool release_given = false;
  std::string transducer;            ///< preset name
  std::string transducer_stiffness;  ///< "kx,ky,kz,krx,kry,krz"
  double base_stiffness = 0;         ///< N/m, used when base_given
  bool base_given = false;
  std::vector<std::string> joint_stiffness;  ///< "joint=value"
  std::vector<std::string> lock;             ///< locked coordinates ("none" unlocks all)
  bool lock_given = false;
  std::string wrap;         ///< --wrap: "opensim" or "exact" ("": the default, opensim)
  std::string force_model;  ///< --force-model: "", model, constant, rigid (ModelOverrides)
  std::string muscle;       ///< empty = the first muscle
  double activation = 1.0;
  StaticsOptions statics;
};

/// --delimiter, --decimal-comma, --ignore-columns, --skip-rows: how the trial or posture sheet
/// a command reads is laid out (TrialSheetOptions). `what` names the file in the help text.
void AddSheetOptions(CLI::App& app, TrialSheetOptions& sheet, const std::string& what);

/// Which of the shared options a command takes: a command offers only options it reads, so an
/// option it would ignore is an error ("The following argument was not expected") instead.
struct ModelOptionParts {
  bool muscle = true;   ///< --muscle, --activation (one muscle per run)
  bool posture = true;  ///< --posture (fit reads each trial's posture from its data)
  bool statics = true;  ///< --max-endpoint-fraction, --max-joint-rotation, --rank-tolerance
};

/// Add the shared options (positional <urdf> included) to a subcommand.
void AddModelOptions(CLI::App& app, ModelOptions& options, ModelOptionParts parts = {});

/// --muscle NAME[,NAME...] (repeatable; default: the first muscle) and --activation: for the
/// commands that compare several muscles in one run (diagnose, releases).
void AddMusclesAndActivation(CLI::App& app, std::vector<std::string>& muscles, double& activation);

/// --wrap opensim|exact into `wrap` (the commands that take no other model option call it too).
void AddWrapOption(CLI::App& app, std::string& wrap);

/// The overrides the options ask for (parsed with the library's parsers, isowrench/frontend.hpp).
ModelOverrides Overrides(const ModelOptions& options);
/// Load the limb (LoadLimb) and apply the overrides (ApplyOverrides). @throws isowrench::Error.
Model LoadModel(const ModelOptions& options);
/// Nominal posture with --posture applied.
Eigen::VectorXd LoadPosture(const Model& model, const ModelOptions& options);
/// --muscle or the model's first muscle. @throws isowrench::Error if the model has none.
std::string ChooseMuscle(const Model& model, const ModelOptions& options);

/// Number formatting for tables: fixed width, signed, 4 significant digits.
std::string Cell(double value, int width = 11);

/// Muscle `muscle`'s wraps at posture q (issue 27), for the reports: {"mode", "wraps": [{"object",
/// "wrapped", "arc_m"}], "warning"} (warning: the WrapStatus bits in words, "" when none), or null
/// when the muscle has no wraps.
nlohmann::json MuscleWrapJson(const Model& model, const Eigen::VectorXd& q, int muscle);

/// The same as one line of text ("wrap (opensim): knee_cyl wraps, arc 3.21 mm"), "" without wraps.
std::string MuscleWrapText(const nlohmann::json& wrap);
/// "[1e+07 1e+07 1e+07 N/m; 1e+07 1e+07 1e+07 N·m/rad]"
std::string StiffnessText(const Vector6d& s_t);
/// Header line "fx (N) fy (N) fz (N) mx (N·m) my (N·m) mz (N·m)" aligned with Cell().
std::string WrenchHeader(int label_width);
std::string WrenchRow(const std::string& label, const Vector6d& w, int label_width);

nlohmann::json ToJson(const Vector6d& v);
nlohmann::json ToJson(const Eigen::VectorXd& v);
/// {"fx": .., "fy": .., ...,"units": {...}}
nlohmann::json WrenchJson(const Vector6d& w);

/// (ForceModelLabel and OpenSimNote: isowrench/statics.hpp, shared with Python.)
/// One line of the force stage: "F 1.234 N = active 1.0 N + passive 0.234 N; fiber 12.3 mm,
/// pennation 4.5°, equilibrium" (the constant model: "F 2.35 N = a x max_force").
std::string ForceText(const Model& model, int muscle, const MuscleForce& force);
/// The library's ForceStageJson (isowrench/frontend.hpp: the keys Python's force dicts have
/// too) as a JSON object: {"model", "tendon", "activation" (requested), "force_n", ...}.
nlohmann::ordered_json ForceJson(const Model& model, int muscle, const MuscleForce& force,
                                 double activation);

/// A progress bar on stderr when it is a terminal; silent when piped.
class Progress {
 public:
  Progress(std::string label, long total);
  ~Progress();
  void Update(long done);

 private:
  std::string label_;
  long total_;
  bool enabled_;
  int last_percent_ = -1;
};

}  // namespace isowrench::cli
