# Issue 26 (inputs as labs write them): each case asserts the exit code AND the text
# (expect_exit.cmake). Included from tests/cli/CMakeLists.txt; uses input_cli_exit() of
# input_cases.cmake.

set(_in26 ${CMAKE_CURRENT_BINARY_DIR}/inputs_cases)
file(MAKE_DIRECTORY ${_in26})
file(READ ${rat5} _rat5_text)

# ---- item 0: no URDF text reaches a printf format --------------------------------------------
# Both crashed every command: exit 139 (segmentation fault) and 134 ("%n in writable segment").
input_cli_exit(urdf_format_directives_s 1
  "isowrench: error: [^\n]*format_directives.urdf:17: joint 'hip_rz': <origin> attribute xyz = '%s%s%s%s%s%s%s%s%s%s%s%s 0 0': '%s%s%s%s%s%s%s%s%s%s%s%s' is not a finite number"
  wrench ${data}/format_directives.urdf)
string(REPLACE "<origin xyz=\"0.031 0 0\"" "<origin xyz=\"%n%n%n 0 0\"" _text "${_rat5_text}")
file(WRITE ${_in26}/percent_n.urdf "${_text}")
input_cli_exit(urdf_format_directives_n 1
  "isowrench: error: [^\n]*percent_n.urdf:29: joint 'knee_rz': <origin> attribute xyz = '%n%n%n 0 0'"
  kinematics ${_in26}/percent_n.urdf)
string(REPLACE "type=\"continuous\"" "type=\"revolute\"" _text "${_rat5_text}")
string(REPLACE "<axis xyz=\"0 0 1\"/>" "<axis xyz=\"0 0 1\"/> <limit lower=\"%99999d\" upper=\"1\" effort=\"1\" velocity=\"1\"/>" _text "${_text}")
file(WRITE ${_in26}/percent_d.urdf "${_text}")
input_cli_exit(urdf_format_directives_limit 1
  "isowrench: error: [^\n]*percent_d.urdf:17: joint 'hip_rz': <limit> attribute lower = '%99999d' is not a finite number"
  wrench ${_in26}/percent_d.urdf)

# ---- item 2: duplicate and misplaced declarations, errors naming both lines ------------------
file(READ ${urdf}/rat_hindlimb_5dof_base.urdf _base_text)
string(REPLACE "<isowrench:joint name=\"base_z\" role=\"base\" stiffness=\"1e5\"/>"
  "<isowrench:joint name=\"base_z\" role=\"base\" stiffness=\"1e5\"/>\n  <isowrench:joint name=\"base_z\" stiffness=\"2e5\"/>"
  _text "${_base_text}")
file(WRITE ${_in26}/base_z_twice.urdf "${_text}")
input_cli_exit(urdf_joint_declared_twice 1
  "isowrench: error: [^\n]*base_z_twice.urdf:60: <isowrench:joint> 'base_z' is declared twice \\(first at line 59\\)"
  wrench ${_in26}/base_z_twice.urdf)
string(REPLACE "xmlns:isowrench=\"urn:isowrench:urdf:1\"" "xmlns:isowrench=\"urn:isowrench:urdf:1\" xmlns:iw=\"urn:isowrench:urdf:1\"" _text "${_rat5_text}")
string(REPLACE "  <isowrench:posture joint=\"hip_rz\"" "  <iw:muscle name=\"BF\" max_force=\"1\"/>\n  <isowrench:posture joint=\"hip_rz\"" _text "${_text}")
file(WRITE ${_in26}/iw_prefix.urdf "${_text}")
input_cli_exit(urdf_other_prefix_for_isowrench 1
  "isowrench: error: [^\n]*iw_prefix.urdf:47: <iw:muscle> is in isowrench's namespace through the prefix 'iw' \\(xmlns:iw=\"urn:isowrench:urdf:1\" at line 7\\)[^\n]*write <isowrench:muscle>"
  kinematics ${_in26}/iw_prefix.urdf)
string(REPLACE "  <isowrench:posture joint=\"hip_rz\"" "  <isowrench:joint name=\"knee_rx\" role=\"base\" stiffness=\"1e5\"/>\n  <isowrench:posture joint=\"hip_rz\"" _text "${_rat5_text}")
file(WRITE ${_in26}/base_role_revolute.urdf "${_text}")
input_cli_exit(urdf_base_role_on_revolute 1
  "isowrench: error: [^\n]*base_role_revolute.urdf:47: joint 'knee_rx' \\(line 31\\) is revolute but has role=\"base\""
  wrench ${_in26}/base_role_revolute.urdf)

# ---- item 1: plausibility warnings (exit 0: a legal value is never an error) -----------------
# (expect_exit.cmake matches stdout followed by stderr, where the warnings are.)
input_cli_exit(warn_urdf_posture_in_radians 0
  "isowrench: warning: [^\n]*cat_slips.urdf:26: <isowrench:posture>: hip_rz = -3437.75° \\(-60 rad\\) is outside the joint's limits -143.239° \\(-2.5 rad\\) .. 28.6479° \\(0.5 rad\\) and more than a full turn \\(degrees where radians were meant\\?\\)"
  wrench ${data}/cat_slips.urdf)
input_cli_exit(warn_mimic_in_m_per_rad 0
  "isowrench: warning: [^\n]*cat_slips.urdf:27: <isowrench:posture>: joint 'knee_slide', driven by knee_rz = 50° \\(0.872665 rad\\), is 872.665 mm \\(0.872665 m\\), which moves the endpoint 872.7 mm, more than the limb's own length 270 mm"
  kinematics ${data}/cat_slips.urdf)
input_cli_exit(warn_posture_option_full_turn 0
  "statics +ok.*isowrench: warning: --posture hip_rz=-3437: hip_rz = -3437° \\(-59.987 rad\\) is more than a full turn"
  wrench ${rat5} --posture hip_rz=-3437)
string(REPLACE "rpy=\"0 0 0\" axes=\"world\"" "rpy=\"0 0 90\" axes=\"world\"" _text "${_rat5_text}")
file(WRITE ${_in26}/rpy_degrees.urdf "${_text}")
input_cli_exit(warn_transducer_rpy_in_degrees 0
  "transducer   S_t = [^\n]*axes world, rpy 0 0 2.035 rad \\(0° 0° 116.6°\\).*isowrench: warning: [^\n]*rpy_degrees.urdf:37: <isowrench:transducer> rpy = 0 0 90 rad turns more than a full turn about an axis: degrees written where radians are meant\\?"
  wrench ${_in26}/rpy_degrees.urdf)
input_cli_exit(wrench_header_shows_unrotated_axes 0 "axes world, not rotated, released" wrench ${rat5})
input_cli_exit(warn_import_endpoint_in_mm 0
  "! endpoint point 0,-5,20 \\(m in body 'foot'\\): the endpoint sits 20.6155 m from the origin of link 'foot', outside the plausible segment length"
  import ${PROJECT_SOURCE_DIR}/tests/opensim/data/hindlimb.osim -o ${_in26}/hindlimb_mm.urdf
  --clamp pelvis --endpoint foot:0,-5,20)

# ---- item 4: one meaning per option -------------------------------------------------------------
add_test(NAME cli_design_simulate_fit_chain
  COMMAND ${CMAKE_COMMAND} -DCLI=${cli} -DURDF=${rat5} -DWORK=${_in26}/chain
          -P ${CMAKE_CURRENT_SOURCE_DIR}/design_chain.cmake)
set_tests_properties(cli_design_simulate_fit_chain PROPERTIES TIMEOUT 60)
input_cli_exit(simulate_postures_is_a_sheet_not_a_count 2
  "--postures: takes a posture sheet \\(a CSV file\\); '60' is a number: the number of trials is --trials 60"
  simulate ${rat5} --postures 60 -o ${_in26}/never.csv)
input_cli_exit(simulate_trials_count 0 "trials       7, limb joints nominal"
  simulate ${rat5} --trials 7 -o ${_in26}/seven.csv)
input_cli_exit(simulate_muscle_list_comma_separated 0 "trials       4, "
  simulate ${urdf}/planar_2r.urdf --trials 4 --muscle biarticular,elbow_flexor -o ${_in26}/two.csv)
input_cli_exit(simulate_muscle_list_names_unknown 1 "isowrench: error: [^\n]*'flexor'"
  simulate ${urdf}/planar_2r.urdf --trials 4 --muscle biarticular,flexor -o ${_in26}/two.csv)
input_cli_exit(unknown_command_with_help_is_usage_error 2
  "isowrench: error: unknown command 'nosuchcommand'; the commands are wrench, "
  nosuchcommand --help)
input_cli_exit(unknown_command_suggests 2 "unknown command 'wrnch' \\(did you mean 'wrench'\\?\\)" wrnch ${rat5})
file(WRITE ${_in26}/design_sheet.csv "# a design sheet not yet recorded\nhip_rz,knee_rz,muscle,activation,fx,fy,fz,mx,my,mz\n-110,105,GP,1,,,,,,\n")
input_cli_exit(fit_of_an_unrecorded_design_sheet 1
  "isowrench: error: [^\n]*design_sheet.csv:3, column 5 'fx': empty: this row's trial has no measured fx \\(a posture sheet lists the trials to record"
  fit ${rat5} ${_in26}/design_sheet.csv)
file(WRITE ${_in26}/posture_sheet.csv "hip_rz,knee_rz,muscle\n-110,105,GP\n")
input_cli_exit(fit_of_a_posture_sheet 1
  "isowrench: error: [^\n]*posture_sheet.csv:1: no measured wrench columns \\(fx fy fz mx my mz\\): this is a posture sheet[^\n]*isowrench simulate <urdf> --postures [^\n]*posture_sheet.csv -o data.csv"
  fit ${rat5} ${_in26}/posture_sheet.csv)

# ---- item 3: lab sheets --------------------------------------------------------------------------
add_test(NAME cli_fit_sheet_dialects
  COMMAND ${CMAKE_COMMAND} -DCLI=${cli} -DURDF=${rat5} -DWORK=${_in26}/dialects
          -P ${CMAKE_CURRENT_SOURCE_DIR}/sheet_dialects.cmake)
set_tests_properties(cli_fit_sheet_dialects PROPERTIES TIMEOUT 60)
input_cli_exit(fit_names_radians_slip 0
  "likely slip: the angles of hip_rz, hip_ry, hip_rx, knee_rz, knee_rx all stay within ±[0-9.]+° of 0 while the model's posture is hip_rz = -110°, knee_rz = 105°: recorded in radians\\?.*isowrench: warning: [^\n]*trials_radians.csv: the angles of"
  fit ${rat5} ${data}/trials_radians.csv)
input_cli_exit(fit_names_moments_slip 0
  "likely slip: measured = 1000 x predicted on mx, my, mz \\(least-squares factors [^)]*\\): moments in N·mm\\?"
  fit ${rat5} ${data}/trials_moments_nmm.csv)
input_cli_exit(fit_reads_declared_units 0 "verdict      nominal model fits: the nominal model explains the data to the noise"
  fit ${rat5} ${data}/trials_declared_units.csv)
