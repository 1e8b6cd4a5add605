# cmake -DVALGRIND=... -DDRIVER=... -DWORK_DIR=... -P instructions.cmake
# Runs the kernel driver under callgrind, collecting only inside isowrench_measured_loop, and
# prints instructions (Ir) per evaluation for each kernel.
foreach(kernel_count IN ITEMS "fast:20000" "fast-stiffness:2000" "fast-coupled:20000" "fast-wrap:20000" "fast-wrap-exact:20000" "fast-rigid:20000" "fast-compliant:5000" "batch:20" "batch-stiffness:2" "batch-coupled:20" "batch-wrap:5" "batch-rigid:20" "batch-compliant:5" "kdl:2000" "reference:500" "fast-chain-33c:2000" "batch-chain-33c:2")
  string(REPLACE ":" ";" kc "${kernel_count}")
  list(GET kc 0 kernel)
  list(GET kc 1 count)
  set(out "${WORK_DIR}/callgrind.${kernel}.out")
  execute_process(
    COMMAND ${VALGRIND} --tool=callgrind --callgrind-out-file=${out}
            --toggle-collect=isowrench_measured_loop ${DRIVER} ${kernel} ${count}
    OUTPUT_VARIABLE stdout ERROR_VARIABLE stderr RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "callgrind on ${kernel} failed:\n${stderr}")
  endif()
  string(REGEX MATCH "([0-9]+) evaluations collected" _ "${stdout}")
  set(evaluations ${CMAKE_MATCH_1})
  string(REGEX MATCH "Collected : ([0-9]+)" _ "${stderr}")
  set(ir ${CMAKE_MATCH_1})
  math(EXPR per_eval "${ir} / ${evaluations}")
  message(STATUS "${kernel}: ${per_eval} instructions per evaluation (${ir} Ir / ${evaluations} evaluations)")
endforeach()
