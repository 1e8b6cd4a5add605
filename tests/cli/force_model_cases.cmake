# The force stage in the reports (issue 28 stage 2, docs/muscle.md "In the engine"), included
# from tests/cli/CMakeLists.txt after the isowrench_cli_test / isowrench_cli_error helpers. The
# numbers are checked in tests/muscle/force_stage_test.cpp and python/tests/test_force_model.py.
set(force_limb ${data}/force_model_limb.urdf)

isowrench_cli_test(force_wrench_names_the_model
  "force model  millard2012, compliant tendon\n  force        F [0-9.e+-]+ N = active [0-9.e+-]+ N \\+ passive [0-9.e+-]+ N; fiber [0-9.e+-]+ mm, pennation [0-9.e+-]+°.*passive \\(a = 0\\), transducer.*active = Eq. 10 - passive"
  wrench ${force_limb} --muscle GP_compliant)
isowrench_cli_test(force_wrench_constant_model_line "force model  constant \\(F = a x max_force\\)"
  wrench ${rat5})
isowrench_cli_test(force_wrench_opensim_gives_no_number
  "thelen2003, rigid-tendon limit.*OpenSim      OpenSim gives no number for this muscle"
  wrench ${force_limb} --muscle GP_no_opensim)
isowrench_cli_test(force_wrench_json_passive "\"passive_wrench\": \\{.*\"status\": \"ok\""
  wrench ${force_limb} --muscle GP_rigid --json)
# --force-model constant: F = a x max_force (2.35 N at activation 1).
isowrench_cli_test(force_model_override_constant "GP_thelen: 2.35 N.*force model  constant"
  wrench ${force_limb} --muscle GP_thelen --force-model constant)
isowrench_cli_test(force_model_override_rigid "force model  millard2012, rigid tendon"
  wrench ${force_limb} --muscle GP_compliant --force-model rigid)
isowrench_cli_test(force_kinematics_every_muscle
  "muscle forces at activation 0.5.*GP_compliant \\[millard2012, compliant tendon\\]: F .*GP_rigid \\[millard2012, rigid tendon\\]: F .*GP_thelen \\[thelen2003, compliant tendon\\]: F .*GP_no_opensim \\[thelen2003, rigid-tendon limit.*OpenSim gives no number.*GP_constant \\[constant \\(F = a x max_force\\)\\]: F 1.175 N = a x max_force"
  kinematics ${force_limb} --activation 0.5)
isowrench_cli_test(force_sweep_columns "millard2012, compliant tendon, activation 1: F\\(L_MT\\) per posture"
  sweep ${force_limb} --muscle GP_compliant --grid knee_rz=90:120:10 -o ${CMAKE_CURRENT_BINARY_DIR}/force_sweep.csv)
isowrench_cli_test(force_diagnose_names_the_model "force model  millard2012, rigid tendon.*passive W \\(activation 0\\)"
  diagnose ${force_limb} --muscle GP_rigid --no-large-deflection)
isowrench_cli_test(force_releases_names_the_model "muscle GP_thelen \\[thelen2003, compliant tendon\\]: F "
  releases ${force_limb} --muscle GP_thelen)
isowrench_cli_error(force_activation_out_of_range 2 "--activation: Value 1.5 not in range"
  wrench ${rat5} --activation 1.5)
isowrench_cli_error(force_model_unknown 2 "--force-model: hill not in \\{model,constant,rigid\\}"
  wrench ${rat5} --force-model hill)
isowrench_cli_test(force_uncertainty_of_a_force_model "muscle GP_compliant.*activation uniform \\[0.3, 0.7\\].*valid 128"
  uncertainty ${force_limb} --muscle GP_compliant --activation 0.5 --input max_force=normal:0.1
  --input activation=uniform:0.3:0.7 --samples 64)
isowrench_cli_error(force_uncertainty_activation_beyond_one 1
  "isowrench: error: [^\n]*activation \\[0.5, 1.2\\] leaves \\[0, 1\\][^\n]*GP_compliant"
  uncertainty ${force_limb} --muscle GP_compliant --input activation=uniform:0.5:1.2 --samples 10)
