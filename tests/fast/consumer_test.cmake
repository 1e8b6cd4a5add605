# cmake -DBUILD_DIR=... -DSOURCE_DIR=... -DWORK_DIR=... [-DSANITIZE=ON] -P consumer_test.cmake
# Installs the build into a temporary prefix, checks what was installed (public headers only,
# CMake package, pkg-config file, URDFs, CLI), then configures, builds and runs
# examples/consumer against it with find_package(isowrench CONFIG REQUIRED), and compiles it
# again with exactly `pkg-config --cflags --libs --static isowrench` (Ceres included).
file(REMOVE_RECURSE ${WORK_DIR})
set(prefix ${WORK_DIR}/prefix)

function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "failed (${rc}): ${ARGN}\n${out}\n${err}")
  endif()
  set(last_output "${out}" PARENT_SCOPE)
endfunction()

run(${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix})

foreach(f include/isowrench/isowrench.hpp include/isowrench/engine.hpp share/isowrench/urdf/rat_hindlimb_5dof.urdf
          bin/isowrench)
  if(NOT EXISTS ${prefix}/${f})
    message(FATAL_ERROR "not installed: ${f}")
  endif()
endforeach()
file(GLOB_RECURSE configs ${prefix}/*/isowrenchConfig.cmake ${prefix}/*/isowrenchConfigVersion.cmake
     ${prefix}/*/isowrench.pc)
list(LENGTH configs n)
if(NOT n EQUAL 3)
  message(FATAL_ERROR "expected isowrenchConfig.cmake, isowrenchConfigVersion.cmake and isowrench.pc; found: ${configs}")
endif()
# Only public headers: nothing from src/ (private headers are *_impl.hpp, util/, cli/ ...).
file(GLOB_RECURSE headers RELATIVE ${prefix}/include ${prefix}/include/*)
foreach(h IN LISTS headers)
  if(NOT h MATCHES "^isowrench/[a-z_]+\\.hpp$" OR h MATCHES "_impl\\.hpp$")
    message(FATAL_ERROR "unexpected installed header: ${h}")
  endif()
endforeach()
run(${prefix}/bin/isowrench --version)

set(flags "")
if(SANITIZE)
  set(flags "-DCMAKE_CXX_FLAGS=-fsanitize=address,undefined" "-DCMAKE_EXE_LINKER_FLAGS=-fsanitize=address,undefined")
endif()
# The compiler the library was built with (a clang-built sanitized library needs clang's runtime).
if(CXX_COMPILER)
  list(APPEND flags "-DCMAKE_CXX_COMPILER=${CXX_COMPILER}")
endif()
run(${CMAKE_COMMAND} -S ${SOURCE_DIR}/examples/consumer -B ${WORK_DIR}/build
    -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_BUILD_TYPE=Release ${flags})
run(${CMAKE_COMMAND} --build ${WORK_DIR}/build)
run(${WORK_DIR}/build/app)
message(STATUS "consumer app:\n${last_output}")

# pkg-config, when available: compile the same program without CMake.
find_program(PKG_CONFIG pkg-config)
if(CXX_COMPILER)
  set(CXX ${CXX_COMPILER})
else()
  find_program(CXX NAMES c++ g++)
endif()
if(PKG_CONFIG AND CXX AND NOT SANITIZE)
  set(ENV{PKG_CONFIG_PATH} "")
  file(GLOB pcdirs ${prefix}/lib*/pkgconfig ${prefix}/lib/*/pkgconfig)
  string(REPLACE ";" ":" pcpath "${pcdirs}")
  set(ENV{PKG_CONFIG_PATH} "${pcpath}")
  run(${PKG_CONFIG} --cflags --libs --static isowrench)
  string(STRIP "${last_output}" pc_flags)
  separate_arguments(pc_flags UNIX_COMMAND "${pc_flags}")
  run(${CXX} -O1 "-DAPP_URDF_DIR=\"${prefix}/share/isowrench/urdf\"" ${SOURCE_DIR}/examples/consumer/main.cpp
      -o ${WORK_DIR}/app_pkgconfig ${pc_flags})
  run(${WORK_DIR}/app_pkgconfig)
  message(STATUS "pkg-config app:\n${last_output}")
endif()
