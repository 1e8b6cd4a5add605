# cmake -DHARNESS=... -DSEEDS=... -DWORK=... -DSECONDS=... -DSUPPRESSIONS=... -P smoke.cmake
# One short libFuzzer run of HARNESS (the CI smoke test, ISOWRENCH_FUZZ_SMOKE): a fresh work
# corpus in WORK (libFuzzer adds the inputs it finds to its first corpus folder, never to the
# committed seeds), then SECONDS of fuzzing with the dictionary fuzz/<corpus>.dict. Fails on a
# crash, a sanitizer report, ASan's "unexpected format specifier" warning (input text reached a
# printf format: issue 26), a leak (except urdfdom's own, fuzz/lsan.supp) or an input slower
# than 10 s.
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK}/corpus ${WORK}/findings)
set(ENV{LSAN_OPTIONS} "suppressions=${SUPPRESSIONS}:print_suppressions=0")
get_filename_component(_corpus "${SEEDS}" NAME)
get_filename_component(_dict "${SEEDS}/../../${_corpus}.dict" ABSOLUTE)
set(_dict_option)
if(EXISTS ${_dict})
  set(_dict_option -dict=${_dict})
endif()
execute_process(
  COMMAND ${HARNESS} -max_total_time=${SECONDS} -timeout=10 -rss_limit_mb=2048
          -artifact_prefix=${WORK}/findings/ -print_final_stats=1 ${_dict_option} ${WORK}/corpus ${SEEDS}
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
string(REGEX MATCH "stat::number_of_executed_units: *([0-9]+)" _ "${err}")
set(runs ${CMAKE_MATCH_1})
if(NOT rc EQUAL 0 OR err MATCHES "ERROR: (AddressSanitizer|LeakSanitizer|libFuzzer)|runtime error:|unexpected format specifier")
  message(FATAL_ERROR "${HARNESS} failed (exit ${rc}); the input is in ${WORK}/findings/\n${err}")
endif()
message(STATUS "${HARNESS}: ${runs} executions in ${SECONDS} s, no finding")
