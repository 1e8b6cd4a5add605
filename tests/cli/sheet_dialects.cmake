# cmake -DCLI=<isowrench> -DURDF=<limb> -DWORK=<dir> -P sheet_dialects.cmake
# Issue 26 item 3: one simulated data set (planted base_isotropic) written as labs' tools write
# it, and `isowrench fit` on each: every variant must give the verdict of the plain file.
#   excel:   ';' separators and decimal commas (--delimiter ';' --decimal-comma)
#   extras:  trial id, date and comment columns (ignored with a warning; --ignore-columns)
#   units:   a units row under the header
#   headers: "name (unit)" headers, as isowrench sweep writes them
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})
function(run expect_rc)
  execute_process(COMMAND ${ARGN} WORKING_DIRECTORY ${WORK} RESULT_VARIABLE rc
                  OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL expect_rc)
    message(FATAL_ERROR "exit code ${rc} (expected ${expect_rc}): ${ARGN}\n${out}${err}")
  endif()
  set(out "${out}" PARENT_SCOPE)
  set(err "${err}" PARENT_SCOPE)
endfunction()
function(same text wanted what)
  if(NOT text STREQUAL wanted)
    message(FATAL_ERROR "${what}: '${text}' differs from the plain file's '${wanted}'")
  endif()
endfunction()
function(expect text regex what)
  if(NOT text MATCHES "${regex}")
    message(FATAL_ERROR "${what}: output does not match '${regex}':\n${text}")
  endif()
endfunction()

run(0 ${CLI} simulate ${URDF} --effect base_isotropic=3e6 --trials 40 --seed 9 -o plain.csv)
run(0 ${CLI} fit ${URDF} plain.csv)
string(REGEX MATCH "verdict      [^\n]*" verdict "${out}")
expect("${verdict}" "explained by base_isotropic" "plain")
if(verdict MATCHES "slip")
  message(FATAL_ERROR "a slip named on clean data: ${verdict}")
endif()
file(READ ${WORK}/plain.csv plain)

# excel: the comment line aside, ',' -> ';' then '.' -> ','.
string(REPLACE "," ";" excel "${plain}")
string(REPLACE "." "," excel "${excel}")
file(WRITE ${WORK}/excel.csv "${excel}")
run(1 ${CLI} fit ${URDF} excel.csv)
expect("${err}" "excel.csv:2: the header [^\n]*uses ';' as the separator[^\n]*--delimiter ';' --decimal-comma" "excel undeclared")
run(0 ${CLI} fit ${URDF} excel.csv --delimiter semicolon --decimal-comma)
string(REGEX MATCH "verdict      [^\n]*" v "${out}")
same("${v}" "${verdict}" "excel")

# extras: a trial id and a date before, a comment after.
string(REGEX REPLACE "\n([^#\n][^\n]*)" "\nX,2026-03-02,\\1,ok" extras "${plain}")
string(REPLACE "X,2026-03-02,hip_rz" "trial,date,hip_rz" extras "${extras}")
string(REPLACE "sd_mz,ok" "sd_mz,comment" extras "${extras}")
file(WRITE ${WORK}/extras.csv "${extras}")
run(0 ${CLI} fit ${URDF} extras.csv)
expect("${err}" "isowrench: warning: [^\n]*extras.csv:2: ignoring columns 'trial', 'date', 'comment'" "extras warning")
string(REGEX MATCH "verdict      [^\n]*" v "${out}")
same("${v}" "${verdict}" "extras")
run(0 ${CLI} fit ${URDF} extras.csv --ignore-columns trial,date,comment)
if(err MATCHES "ignoring")
  message(FATAL_ERROR "--ignore-columns still warns:\n${err}")
endif()

# units: a units row under the header.
string(REPLACE "sd_mz\n" "sd_mz\ndeg,deg,deg,deg,deg,,1,N,N,N,N·m,N·m,N·m,N,N,N,N·m,N·m,N·m\n" units "${plain}")
file(WRITE ${WORK}/units.csv "${units}")
run(0 ${CLI} fit ${URDF} units.csv)
string(REGEX MATCH "verdict      [^\n]*" v "${out}")
same("${v}" "${verdict}" "units row")

# headers: "name (unit)" as isowrench sweep writes them.
string(REPLACE "hip_rz,hip_ry,hip_rx,knee_rz,knee_rx,muscle,activation,fx,fy,fz,mx,my,mz,"
       "hip_rz (deg),hip_ry (deg),hip_rx (deg),knee_rz (deg),knee_rx (deg),muscle,activation (1),fx (N),fy (N),fz (N),mx (N·m),my (N·m),mz (N·m),"
       headers "${plain}")
file(WRITE ${WORK}/headers.csv "${headers}")
run(0 ${CLI} fit ${URDF} headers.csv)
string(REGEX MATCH "verdict      [^\n]*" v "${out}")
same("${v}" "${verdict}" "headers")
message(STATUS "plain, excel, extras, units row and unit headers: ${verdict}")
