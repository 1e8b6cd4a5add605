# cmake -DCLI=<isowrench> -DURDF=<limb> -DWORK=<dir> -P design_chain.cmake
# Issue 26 item 4: the postures `design` chooses are simulated and fitted as they are:
#   isowrench design URDF --effects base_isotropic -o d.csv
#   isowrench simulate URDF --postures d.csv --effect base_isotropic=3e6 -o data.csv
#   isowrench fit URDF data.csv
# Each step must exit 0; the simulated rows must be at the sheet's postures, muscles and
# activations (the first 7 columns equal, row by row); the fit must find the planted effect.
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})
function(run)
  execute_process(COMMAND ${ARGN} WORKING_DIRECTORY ${WORK} RESULT_VARIABLE rc
                  OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "exit code ${rc}: ${ARGN}\n${out}${err}")
  endif()
  set(out "${out}" PARENT_SCOPE)
endfunction()
run(${CLI} design ${URDF} --effects base_isotropic --n 12 --grid 200 -o d.csv)
run(${CLI} simulate ${URDF} --postures d.csv --effect base_isotropic=3e6 -o data.csv)
if(NOT out MATCHES "trials       12 at the 12 postures of d.csv ± 0°, activation from d.csv")
  message(FATAL_ERROR "simulate did not use the sheet:\n${out}")
endif()
run(${CLI} fit ${URDF} data.csv)
if(NOT out MATCHES "verdict      explained: explained by base_isotropic")
  message(FATAL_ERROR "fit did not find the planted base_isotropic:\n${out}")
endif()
# Row by row: coordinates, muscle and activation of the sheet (comment and header lines skipped).
file(STRINGS ${WORK}/d.csv sheet REGEX "^[-0-9]")
file(STRINGS ${WORK}/data.csv data REGEX "^[-0-9]")
list(LENGTH sheet n_sheet)
list(LENGTH data n_data)
if(NOT n_sheet EQUAL 12 OR NOT n_data EQUAL 12)
  message(FATAL_ERROR "expected 12 rows in d.csv and data.csv, found ${n_sheet} and ${n_data}")
endif()
foreach(i RANGE 11)
  list(GET sheet ${i} a)
  list(GET data ${i} b)
  string(REGEX MATCH "^([^,]*,){7}" a7 "${a},")
  string(REGEX MATCH "^([^,]*,){7}" b7 "${b},")
  if(NOT a7 STREQUAL b7)
    message(FATAL_ERROR "row ${i}: the sheet says '${a7}', the simulated data '${b7}'")
  endif()
endforeach()
message(STATUS "design -> simulate --postures -> fit: 12 trials at the design's postures, base_isotropic found")
