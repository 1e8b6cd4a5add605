# Run a command and check its exit code and output (stdout + stderr):
#   cmake -DEXPECT_RC=<n> -DEXPECT_REGEX=<regex> -P expect_exit.cmake -- <command> [args...]
# PASS_REGULAR_EXPRESSION ignores the exit code and WILL_FAIL ignores the message; this checks
# both at once (exact code: 1 for bad input, 2 for command-line usage errors).
set(cmd)
set(after_dashes FALSE)
math(EXPR last "${CMAKE_ARGC} - 1")
foreach(i RANGE ${last})
  if(after_dashes)
    list(APPEND cmd "${CMAKE_ARGV${i}}")
  elseif("${CMAKE_ARGV${i}}" STREQUAL "--")
    set(after_dashes TRUE)
  endif()
endforeach()
execute_process(COMMAND ${cmd} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
set(all "${out}${err}")
if(NOT "${rc}" STREQUAL "${EXPECT_RC}")
  message(FATAL_ERROR "exit code ${rc}, expected ${EXPECT_RC}\ncommand: ${cmd}\noutput:\n${all}")
endif()
if(DEFINED EXPECT_REGEX AND NOT "${all}" MATCHES "${EXPECT_REGEX}")
  message(FATAL_ERROR "output does not match '${EXPECT_REGEX}'\ncommand: ${cmd}\noutput:\n${all}")
endif()
message(STATUS "exit code ${rc}; output matches '${EXPECT_REGEX}'")
