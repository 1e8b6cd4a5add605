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
