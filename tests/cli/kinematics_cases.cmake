# `isowrench kinematics` (issue 12 item 3), included from tests/cli/CMakeLists.txt after the
# isowrench_cli_test / isowrench_cli_error helpers. The numbers themselves are checked against
# finite differences of an independent forward kinematics in tests/core/coupling_test.cpp.
set(coupled ${urdf}/rat_hindlimb_coupled_knee.urdf)

isowrench_cli_test(kinematics_help "--postures.*--json" kinematics --help)
isowrench_cli_test(kinematics_table_units
  "endpoint \\(m\\).*Jacobian: rows vx vy vz in m/rad.*moment arm -dL/dq.*GP"
  kinematics ${rat5})
isowrench_cli_test(kinematics_json_layout
  "^\\{\"coordinates\": \\[\"hip_rz\",\"hip_ry\",\"hip_rx\",\"knee_rz\",\"knee_rx\"\\],\n \"postures\": \\[\\{\"endpoint_m\": \\[[^]]*\\],\n   \"jacobian\": \\[\\[.*\"muscles\": \\{\"GP\": \\{\"length_m\":[^,]*,\"moment_arm_m\":\\[[^]]*\\],\"force\":\\{\"model\":\"constant\"[^}]*\\}\\}\\}\\}\\]\\}"
  kinematics ${rat5} --json)
# Three CSV rows -> three postures; the second row's empty knee_rx keeps the nominal value.
isowrench_cli_test(kinematics_postures_csv "\"endpoint_m\".*\"endpoint_m\".*\"endpoint_m\""
  kinematics ${rat5} --postures ${data}/postures_rat.csv --json)
isowrench_cli_test(kinematics_repeated_posture "posture 1: hip_rz=-100°, hip_ry=0°, hip_rx=0°, knee_rz=90°, knee_rx=10°"
  kinematics ${rat5} --posture hip_rz=-100 --posture knee_rz=90,knee_rx=10)

# A posture naming a driven joint is refused with its driver named.
isowrench_cli_error(kinematics_driven_joint 1
  "isowrench: error: joint 'knee_tx' is driven by coordinate 'knee_rz' \\(isowrench:coupling\\); set 'knee_rz' instead"
  kinematics ${coupled} --posture knee_tx=1)
isowrench_cli_error(kinematics_driven_joint_mimic 1
  "isowrench: error: joint 'knee_ty' is driven by coordinate 'knee_rz' \\(mimic\\); set 'knee_rz' instead"
  kinematics ${coupled} --posture knee_ty=1)
isowrench_cli_error(kinematics_csv_unknown_column 1
  "isowrench: error: [^\n]*postures_bad_column.csv:1: column 'knee_rzz'[^\n]*did you mean 'knee_rz'"
  kinematics ${rat5} --postures ${data}/postures_bad_column.csv)
isowrench_cli_error(kinematics_csv_missing 1 "isowrench: error: [^\n]*no_such_postures.csv"
  kinematics ${rat5} --postures ${data}/no_such_postures.csv)

# --wrap (issue 27): a mode other than opensim / exact is a usage error naming both; where the
# cylinder wraps QUAD (knee flexed back) the two modes differ, and exact is shorter than OpenSim's
# path (its ends are at different heights along the axis); the values themselves are checked in
# tests/wrap/wrap_engine_test.cpp and python/tests/test_wrap.py.
set(knee_wrap ${PROJECT_SOURCE_DIR}/tests/wrap/data/knee_wrap.urdf)
isowrench_cli_test(kinematics_wrap_help "--wrap.*opensim.*exact" kinematics --help)
isowrench_cli_test(wrench_wrap_help "--wrap.*opensim.*exact" wrench --help)
isowrench_cli_error(kinematics_wrap_unknown 2 "--wrap: shortest not in \\{opensim,exact\\}"
  kinematics ${knee_wrap} --wrap shortest)
# wrench says which wraps engage (arc in mm) and in which mode; --json puts it under "muscle".
isowrench_cli_test(wrench_wrap_engaged "wrap \\(exact\\): knee_cyl wraps, arc [0-9.]+ mm"
  wrench ${knee_wrap} --muscle QUAD --posture knee=-60 --wrap exact)
isowrench_cli_test(wrench_wrap_clear "wrap \\(opensim\\): knee_cyl does not wrap"
  wrench ${knee_wrap} --muscle QUAD --posture knee=0)
isowrench_cli_test(wrench_wrap_json "\"wrap\": \\{[^}]*\"mode\": \"opensim\""
  wrench ${knee_wrap} --muscle QUAD --posture knee=-60 --json)
# diagnose and releases say the same per muscle and posture.
isowrench_cli_test(diagnose_wrap_line "muscle QUAD.*wrap \\(opensim\\): knee_cyl wraps, arc"
  diagnose ${knee_wrap} --muscle QUAD --posture knee=-60 --no-large-deflection)
isowrench_cli_test(releases_wrap_json "\"wrap\": \\{[^}]*\"mode\": \"exact\""
  releases ${knee_wrap} --muscle QUAD --posture knee=-60 --wrap exact --json)
# sweep says where OpenSim's wrap algorithm misbehaves (issue 27): per posture in the CSV
# (wraps_engaged, wrap_warning), counted with the first posture in the summary and the JSON.
# sphere_far_side.urdf wraps the far side of a constrained sphere from knee -65 to +20 degrees.
set(sphere_far_side ${PROJECT_SOURCE_DIR}/tests/wrap/data/sphere_far_side.urdf)
isowrench_cli_test(sweep_wrap_warnings
  "wrap \\(opensim\\): knee_ball wraps at 23 of 27 postures\n  wrap warnings at 18 of 27 postures \\(column wrap_warning of the CSV\\):\n[^\n]*below the straight line[^\n]*: 18 postures, first at knee=-65°\n    negative arc \\(OpenSim's far-side sphere wrap\\): 18 postures, first at knee=-65°"
  sweep ${sphere_far_side} --grid knee=-90:40:5 -o ${CMAKE_CURRENT_BINARY_DIR}/sweep_wrap_warnings.csv)
isowrench_cli_test(sweep_wrap_warnings_json
  "\"wrap\": \\{\n    \"mode\": \"exact\",\n    \"unevaluated_postures\": 0,\n    \"warning_postures\": 0,\n    \"warnings\": \\[\\]"
  sweep ${sphere_far_side} --grid knee=-90:40:5 --wrap exact --json
  -o ${CMAKE_CURRENT_BINARY_DIR}/sweep_wrap_warnings_exact.csv)
