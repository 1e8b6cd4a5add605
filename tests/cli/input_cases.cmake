# Issue 16 (INPUT): bad input, exit codes and the wrench table, each asserting the exit code
# AND the text (expect_exit.cmake). Included from tests/cli/CMakeLists.txt.

# input_cli_exit(<name> <exit code> <regex> <args...>): exact exit code and output regex.
function(input_cli_exit name rc regex)
  add_test(NAME cli_${name}
    COMMAND ${CMAKE_COMMAND} -DEXPECT_RC=${rc} "-DEXPECT_REGEX=${regex}"
            -P ${CMAKE_CURRENT_SOURCE_DIR}/expect_exit.cmake -- ${cli} ${ARGN})
  set_tests_properties(cli_${name} PROPERTIES TIMEOUT 60)
endfunction()

set(_in ${CMAKE_CURRENT_BINARY_DIR}/input_cases)
# The redundant planar 4R limb with its joint springs removed: the muscle drives a self-motion.
set(_no_eq wrench ${urdf}/planar_4r.urdf --joint-stiffness j1=0 --joint-stiffness j2=0
           --joint-stiffness j3=0 --joint-stiffness j4=0)
file(MAKE_DIRECTORY ${_in})

# ---- exit codes, one case per code (3 = internal error has no input that reaches it) ---------
input_cli_exit(exit_code_0_success 0 "statics +ok" wrench ${rat5})
input_cli_exit(exit_code_1_bad_input 1 "isowrench: error: [^\n]*no_such_limb.urdf" wrench ${data}/no_such_limb.urdf)
input_cli_exit(exit_code_2_usage 2 "--bogus" wrench ${rat5} --bogus)
input_cli_exit(exit_code_4_no_equilibrium 4 "statics +self-motion: [^\n]*no equilibrium" ${_no_eq})
input_cli_exit(exit_codes_in_help 0 "Exit codes:.*2  command-line usage error.*4  no equilibrium" --help)
input_cli_exit(exit_codes_in_wrench_help 0 "Exit codes:.*1  bad input.*4  no equilibrium" wrench --help)
input_cli_exit(exit_codes_in_fit_help 0 "Exit codes:.*3  internal error" fit --help)

# ---- defect 10: a joint loop is an error naming the joints, not a hang -----------------------
input_cli_exit(urdf_joint_loop 1 "isowrench: error: [^\n]*joint_loop.urdf:5[^\n]*'j3'[^\n]*'j4'[^\n]*loop"
  wrench ${data}/joint_loop.urdf)
# ---- defect 1: misspelt attribute -----------------------------------------------------------
input_cli_exit(urdf_misspelt_attribute 1
  "isowrench: error: [^\n]*misspelt_stiffness.urdf:37: <isowrench:transducer> has no attribute 'stifness' \\(did you mean 'stiffness'\\?\\)"
  wrench ${data}/misspelt_stiffness.urdf)
# ---- defect 3: stiffness range from the command line ----------------------------------------
input_cli_exit(cli_huge_base_stiffness 1 "isowrench: error: --base-stiffness: stiffness 1e\\+308 exceeds the physical maximum 1e\\+15"
  wrench ${rat5} --base-stiffness 1e308)
input_cli_exit(cli_huge_transducer_stiffness 1 "isowrench: error: --transducer-stiffness rx: stiffness 1e\\+300 exceeds"
  wrench ${rat5} --transducer-stiffness 1e7,1e7,1e7,1e300,1e7,1e7)
input_cli_exit(cli_huge_joint_stiffness 1 "isowrench: error: --joint-stiffness knee_ry: stiffness 1e\\+16 exceeds"
  wrench ${rat6} --joint-stiffness knee_ry=1e16)

# ---- defects 2 and 4: trial CSV through fit --------------------------------------------------
file(WRITE ${_in}/huge_force.csv "hip_rz,hip_ry,hip_rx,knee_rz,knee_rx,muscle,fx,fy,fz,mx,my,mz\n-110,0,0,105,0,GP,1e308,0,0,0,0,0\n")
input_cli_exit(csv_huge_force 1 "isowrench: error: [^\n]*huge_force.csv:2, column 7 'fx': 1e308 N cannot be a measured force"
  fit ${rat5} ${_in}/huge_force.csv)
file(WRITE ${_in}/semicolon.csv "hip_rz;knee_rz;muscle;fx;fy;fz;mx;my;mz\n-110;105;GP;0,1;0;0;0;0;0\n")
input_cli_exit(csv_semicolon 1 "isowrench: error: [^\n]*semicolon.csv:1: the header [^\n]*uses ';' as the separator"
  fit ${rat5} ${_in}/semicolon.csv)
file(WRITE ${_in}/activation.csv "hip_rz,hip_ry,hip_rx,knee_rz,knee_rx,muscle,activation,fx,fy,fz,mx,my,mz\n-110,0,0,105,0,GP,2,0,0,0,0,0,0\n")
input_cli_exit(csv_activation_above_one 1 "column 7 'activation': activation 2 must be in \\[0, 1\\]"
  fit ${rat5} ${_in}/activation.csv)

# ---- defect 7: the wrench table ------------------------------------------------------------
input_cli_exit(wrench_base_dofs_no_classic_row 0 "classic J\\^-T / pinv\\(J\\^T\\) tau not shown: the model has base dofs"
  wrench ${urdf}/rat_hindlimb_5dof_base.urdf)
input_cli_exit(wrench_no_equilibrium_rows 4 "Eq. 10, transducer axes +no equilibrium\nEq. 10, world axes +no equilibrium"
  ${_no_eq})
input_cli_exit(wrench_no_equilibrium_dtheta 4 "j2 +limb +[-0-9.e]+ N·m +no equilibrium" ${_no_eq})
input_cli_exit(wrench_no_equilibrium_small_motion 4 "small motion not applicable: no equilibrium" ${_no_eq})
input_cli_exit(wrench_no_equilibrium_json 4 "\"equilibrium\": false,.*\"wrench\": null" ${_no_eq} --json)
add_test(NAME cli_wrench_no_negative_zero COMMAND ${cli} wrench ${urdf}/planar_4r.urdf --json)
set_tests_properties(cli_wrench_no_negative_zero PROPERTIES
  PASS_REGULAR_EXPRESSION "\"wrench\"" FAIL_REGULAR_EXPRESSION "[^0-9.e]-0(\\.0+)?[^0-9.e]")
add_test(NAME cli_wrench_table_no_negative_zero COMMAND ${cli} wrench ${urdf}/planar_4r.urdf)
set_tests_properties(cli_wrench_table_no_negative_zero PROPERTIES
  PASS_REGULAR_EXPRESSION "Per joint" FAIL_REGULAR_EXPRESSION "[^0-9.e]-0(\\.0+)?[^0-9.e]")
