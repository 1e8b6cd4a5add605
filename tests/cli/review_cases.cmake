# Defects found by the review of the day's merges (2026-11-26): each case asserts the exit code
# AND the text (expect_exit.cmake). Included from tests/cli/CMakeLists.txt; uses input_cli_exit()
# of input_cases.cmake.

# A list option takes one argument per occurrence: the data file after --lock / --release /
# --candidates is the positional argument, not a coordinate (was: "unknown coordinate
# '.../trials_declared_units.csv'").
input_cli_exit(list_option_leaves_the_positional 0 "verdict "
  fit ${rat5} --base-stiffness 1e5 --lock knee_rx ${data}/trials_declared_units.csv --rounds 0)
input_cli_exit(candidates_list_leaves_the_positional 0 "verdict "
  fit ${rat5} --candidates base_isotropic,sensor_offset ${data}/trials_declared_units.csv
  --rounds 0)
# The statics options: finite and > 0 (NaN printed "limit nan rad" as a valid check).
input_cli_exit(statics_option_nan 1
  "isowrench: error: --max-joint-rotation nan: must be a finite number > 0"
  wrench ${rat5} --max-joint-rotation nan)
input_cli_exit(statics_option_negative 1
  "isowrench: error: --max-endpoint-fraction -1: must be a finite number > 0"
  wrench ${rat5} --max-endpoint-fraction -1)
input_cli_exit(rank_tolerance_one 1
  "isowrench: error: --rank-tolerance 1: must be a finite number > 0 and < 1"
  diagnose ${rat5} --rank-tolerance 1)
# --lock's errors name the option; 'none' is alone or absent.
input_cli_exit(lock_unknown_names_the_option 1
  "isowrench: error: --lock: unknown coordinate 'nope'"
  wrench ${rat5} --lock nope)
input_cli_exit(lock_none_with_a_name 1
  "isowrench: error: --lock: 'none' together with 'knee_rx' \\(give the coordinates to lock, or 'none' alone\\)"
  wrench ${rat5} --lock none,knee_rx)
# An uncertain stiffness the statics cannot see is an error, not a silent sd of 0 or a silently
# restrained dof.
input_cli_exit(uncertainty_stiffness_of_a_locked_coordinate 1
  "joint_stiffness:knee_rx[^\n]*coordinate 'knee_rx' is locked"
  uncertainty ${rat5} --lock knee_rx --input joint_stiffness:knee_rx=loguniform:0.01:1)
input_cli_exit(uncertainty_stiffness_of_a_released_dof 1
  "transducer_stiffness:rz[^\n]*transducer dof 'rz' is released"
  uncertainty ${rat5} --release rz --input transducer_stiffness:rz=loguniform:1e3:1e5)
# No equilibrium at the central values: no nominal number (JSON null, the text says so).
input_cli_exit(uncertainty_nominal_without_equilibrium_json 0
  "\"nominal_status\": \"self-motion\".*\"fx\": {\n *\"unit\": \"N\",\n *\"nominal\": null"
  uncertainty ${urdf}/planar_4r.urdf --joint-stiffness j1=0,j2=0,j3=0,j4=0
  --input max_force=normal:0.1 --samples 64 --json)
# A command takes only the options it reads (AddModelOptions' ModelOptionParts): fit reads each
# trial's posture from its data, and fit/design/simulate/draw run no statics check.
input_cli_exit(fit_takes_no_posture 2 "not expected: [^\n]*--posture"
  fit ${rat5} ${data}/trials_declared_units.csv --posture knee_rz=90)
input_cli_exit(simulate_takes_no_statics_option 2 "not expected: [^\n]*--max-joint-rotation"
  simulate ${rat5} --max-joint-rotation 0.1 -o never.csv)
# design --posture is the centre of its grid: knee 60° +- 5° (the nominal knee is 105°).
input_cli_exit(design_grid_centre_is_the_posture 0
  "1\\. GP at [^\n]*knee_rz=(5[5-9]|6[0-5])[.0-9]*°"
  design ${rat5} --effects base_isotropic --n 1 --grid 20 --range 5 --posture knee_rz=60)
input_cli_exit(design_posture_with_a_posture_sheet 1
  "design: --posture sets the centre of the sampled grid, and --postures [^\n]* gives the candidate postures: give one of them"
  design ${rat5} --effects base_isotropic --postures ${data}/trials_declared_units.csv
  --posture knee_rz=60)
