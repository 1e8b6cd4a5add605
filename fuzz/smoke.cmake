# cmake -DHARNESS=... -DSEEDS=... -DWORK=... -DSECONDS=... -DSUPPRESSIONS=... -P smoke.cmake
# One short libFuzzer run of HARNESS (the CI smoke test, ISOWRENCH_FUZZ_SMOKE): a fresh work
# corpus in WORK (libFuzzer adds the inputs it finds to its first corpus folder, never to the
# committed seeds), then SECONDS of fuzzing. Fails on a crash, a sanitizer report, a leak
# (except urdfdom's own, fuzz/lsan.supp) or an input slower than 10 s.
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK}/corpus ${WORK}/findings)
set(ENV{LSAN_OPTIONS} "suppressions=${SUPPRESSIONS}:print_suppressions=0")
execute_process(
  COMMAND ${HARNESS} -max_total_time=${SECONDS} -timeout=10 -rss_limit_mb=2048
          -artifact_prefix=${WORK}/findings/ -print_final_stats=1 ${WORK}/corpus ${SEEDS}
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
string(REGEX MATCH "stat::number_of_executed_units: *([0-9]+)" _ "${err}")
set(runs ${CMAKE_MATCH_1})
if(NOT rc EQUAL 0 OR err MATCHES "ERROR: (AddressSanitizer|LeakSanitizer|libFuzzer)|runtime error:")
  message(FATAL_ERROR "${HARNESS} failed (exit ${rc}); the input is in ${WORK}/findings/\n${err}")
endif()
message(STATUS "${HARNESS}: ${runs} executions in ${SECONDS} s, no finding")
