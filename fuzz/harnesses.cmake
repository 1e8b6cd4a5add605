# The libFuzzer harnesses, shared by the standalone fuzz project (fuzz/CMakeLists.txt, long
# campaigns) and the main build's short CI run (ISOWRENCH_FUZZ_SMOKE, pass 2 of
# scripts/test.sh). The library they link must be compiled with -fsanitize=fuzzer-no-link.
set(ISOWRENCH_FUZZ_HARNESSES urdf_fuzzer trial_csv_fuzzer posture_fuzzer osim_import_fuzzer)
set(ISOWRENCH_FUZZ_DIR ${CMAKE_CURRENT_LIST_DIR})

function(isowrench_add_fuzz_harnesses)
  foreach(harness ${ISOWRENCH_FUZZ_HARNESSES})
    add_executable(${harness} ${ISOWRENCH_FUZZ_DIR}/${harness}.cpp)
    target_link_libraries(${harness} PRIVATE isowrench)
    target_link_options(${harness} PRIVATE -fsanitize=fuzzer)
    target_compile_definitions(${harness} PRIVATE
      ISOWRENCH_FUZZ_URDF="${ISOWRENCH_FUZZ_DIR}/../urdf/rat_hindlimb_5dof.urdf")
  endforeach()
endfunction()
