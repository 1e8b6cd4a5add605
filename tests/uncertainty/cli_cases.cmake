# isowrench uncertainty end to end (issue 30): text with units, JSON, pictures, exit codes and
# messages (tests/cli/expect_exit.cmake).
set(_unc_cli $<TARGET_FILE:isowrench_cli>)
set(_unc_rat5 ${PROJECT_SOURCE_DIR}/urdf/rat_hindlimb_5dof.urdf)
set(_unc_out ${CMAKE_CURRENT_BINARY_DIR}/cli)
file(MAKE_DIRECTORY ${_unc_out})
function(uncertainty_cli_exit name rc regex)
  add_test(NAME uncertainty_cli_${name}
    COMMAND ${CMAKE_COMMAND} -DEXPECT_RC=${rc} "-DEXPECT_REGEX=${regex}"
            -P ${PROJECT_SOURCE_DIR}/tests/cli/expect_exit.cmake -- ${_unc_cli} ${ARGN})
  set_tests_properties(uncertainty_cli_${name} PROPERTIES TIMEOUT 60)
endfunction()
uncertainty_cli_exit(help 0 "--spec.*--input.*--from-fit.*--samples.*--seed.*--svg.*--report.*Exit codes:"
  uncertainty --help)
uncertainty_cli_exit(text 0 "fx \\(N\\).*mx \\(N·m\\).*sd .*\\|f\\| .* N, sd .*direction .* deg.*Sobol indices.*max_force"
  uncertainty ${_unc_rat5} --samples 512 --input max_force=normal:0.2 --input angle:hip_rz=normal:2)
uncertainty_cli_exit(json 0 "\"groups\": \\[[^]]*\"transducer_stiffness:x\".*\"direction_angle\": \\{[^}]*\"unit\": \"rad\""
  uncertainty ${_unc_rat5} --samples 256 --json --input transducer_stiffness:x=lognormal:0.5)
uncertainty_cli_exit(pictures 0 "wrote [^\n]*u.svg.*wrote [^\n]*u.html"
  uncertainty ${_unc_rat5} --samples 256 --input misalignment=normal:1 --svg ${_unc_out}/u.svg
  --report ${_unc_out}/u.html)
uncertainty_cli_exit(unknown_input 1 "isowrench: error: unknown uncertain input 'transducer_stifness:x' \\(did you mean 'transducer_stiffness'\\?\\)"
  uncertainty ${_unc_rat5} --input transducer_stifness:x=lognormal:0.5)
uncertainty_cli_exit(negative_sd 1 "isowrench: error: uncertain input 'angle:hip_rz': sd -2 must be finite and >= 0"
  uncertainty ${_unc_rat5} --input angle:hip_rz=normal:-2)
uncertainty_cli_exit(empty_support 1 "isowrench: error: uncertain input 'max_force': empty support \\[1.2, 0.8\\]"
  uncertainty ${_unc_rat5} --input max_force=uniform:1.2:0.8)
uncertainty_cli_exit(no_input 1 "isowrench: error: uncertainty: no uncertain input given"
  uncertainty ${_unc_rat5})
uncertainty_cli_exit(bad_syntax 1 "isowrench: error: --input 'angle:hip_rz' is not NAME=DISTRIBUTION:PARAMETERS"
  uncertainty ${_unc_rat5} --input angle:hip_rz)
uncertainty_cli_exit(fit_of_another_model 1 "isowrench: error: [^\n]*planar_fit.json is a fit of model 'planar_2r', not of 'rat_hindlimb_5dof'"
  uncertainty ${_unc_rat5} --from-fit ${PROJECT_SOURCE_DIR}/tests/uncertainty/data/planar_fit.json)
uncertainty_cli_exit(points 0 "point:GP:0 normal sd 1 mm.*point:GP:1:y normal sd 0.5 mm.*valid 512.*Sobol indices.*point:GP:0 .*point:GP:1:y "
  uncertainty ${_unc_rat5} --samples 256 --input point:GP:0=normal:1 --input point:GP:1:y=normal:0.5)
uncertainty_cli_exit(unknown_point 1 "isowrench: error: uncertain input 'point:GP:5': unknown path point '5' \\(did you mean '1'\\?\\): muscle 'GP' has 2 path points"
  uncertainty ${_unc_rat5} --input point:GP:5=normal:1)
uncertainty_cli_exit(unknown_point_muscle 1 "isowrench: error: uncertain input 'point:GQ:0': unknown muscle 'GQ' \\(did you mean 'GP'\\?\\)"
  uncertainty ${_unc_rat5} --input point:GQ:0=normal:1)
uncertainty_cli_exit(negative_point_sd 1 "isowrench: error: uncertain input 'point:GP:0:z': sd -1 must be finite and >= 0"
  uncertainty ${_unc_rat5} --input point:GP:0:z=normal:-1)
