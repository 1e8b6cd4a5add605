# Installation and the exported CMake package (issue 6). Included by the top-level
# CMakeLists.txt after every layer has added its sources, so the link interface is complete.
#
#   cmake --install build --prefix /opt/isowrench
#   find_package(isowrench CONFIG REQUIRED)            # in the consumer
#   target_link_libraries(app isowrench::isowrench)    # or isowrench::core (no Ceres)
#   pkg-config --cflags --libs --static isowrench       # without CMake
#
# Installs: lib/libisowrench_core.{a,so}, lib/libisowrench_identification.{a,so},
# include/isowrench/*.hpp (public headers only; private
# headers stay in src/), bin/isowrench, share/isowrench/urdf/*.urdf,
# lib/cmake/isowrench/{isowrenchConfig,isowrenchConfigVersion,isowrenchTargets}.cmake and
# lib/pkgconfig/isowrench.pc.

include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(ISOWRENCH_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/isowrench)

install(TARGETS isowrench_core isowrench_identification isowrench EXPORT isowrenchTargets
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR}
  INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(TARGETS isowrench_cli RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/include/isowrench
  DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}
  FILES_MATCHING PATTERN "*.hpp")
install(DIRECTORY ${PROJECT_SOURCE_DIR}/urdf/
  DESTINATION ${CMAKE_INSTALL_DATADIR}/isowrench/urdf
  FILES_MATCHING PATTERN "*.urdf")
install(EXPORT isowrenchTargets NAMESPACE isowrench:: DESTINATION ${ISOWRENCH_CMAKE_DIR})

# find_dependency() lines for every imported target the library links. A static library
# carries its private dependencies into the consumer's link line ($<LINK_ONLY:...>), so all
# of them must be found, not only the public Eigen3. Package names: the target's namespace.
get_target_property(_isowrench_core_links isowrench_core LINK_LIBRARIES)
get_target_property(_isowrench_identification_links isowrench_identification LINK_LIBRARIES)
set(_isowrench_links ${_isowrench_core_links} ${_isowrench_identification_links})
set(ISOWRENCH_FIND_DEPENDENCIES "")
set(_isowrench_packages "")
foreach(_lib IN LISTS _isowrench_links)
  if(_lib MATCHES "^([A-Za-z0-9_]+)::")
    set(_package ${CMAKE_MATCH_1})
    if(NOT _package IN_LIST _isowrench_packages)
      list(APPEND _isowrench_packages ${_package})
      if(_package STREQUAL "Eigen3")
        string(APPEND ISOWRENCH_FIND_DEPENDENCIES "find_dependency(Eigen3 3.3 NO_MODULE)\n")
      else()
        string(APPEND ISOWRENCH_FIND_DEPENDENCIES "find_dependency(${_package})\n")
      endif()
    endif()
  endif()
endforeach()

configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/isowrenchConfig.cmake.in
  ${PROJECT_BINARY_DIR}/isowrenchConfig.cmake
  INSTALL_DESTINATION ${ISOWRENCH_CMAKE_DIR}
  PATH_VARS CMAKE_INSTALL_DATADIR CMAKE_INSTALL_INCLUDEDIR)
# 0.x: a minor version may break the API, so only the same major.minor is compatible.
write_basic_package_version_file(${PROJECT_BINARY_DIR}/isowrenchConfigVersion.cmake
  VERSION ${PROJECT_VERSION}
  COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/isowrenchConfig.cmake ${PROJECT_BINARY_DIR}/isowrenchConfigVersion.cmake
  DESTINATION ${ISOWRENCH_CMAKE_DIR})

# pkg-config: one isowrench.pc for both layers. The static libraries' private dependencies go
# to Requires.private / Libs.private, so that `pkg-config --static --libs isowrench` is a complete
# link line: KDL, urdfdom, tinyxml2 through their own .pc files, Ceres (Debian ships no ceres.pc)
# and everything its CMake target links, flattened here into -l flags.
set(ISOWRENCH_PC_REQUIRES_PRIVATE "orocos-kdl urdfdom tinyxml2")
set(_isowrench_pc_libs "")
set(_isowrench_pc_seen "")
# isowrench_pc_flatten(<item>): append the linker flags of one link item (imported target, full
# path, or plain name) and, for targets, of everything it links.
function(isowrench_pc_flatten item)
  if(item MATCHES "^\\$<LINK_ONLY:(.*)>$")
    set(item "${CMAKE_MATCH_1}")
  endif()
  if(item IN_LIST _isowrench_pc_seen OR item MATCHES "^\\$<" OR item STREQUAL "")
    return()
  endif()
  list(APPEND _isowrench_pc_seen "${item}")
  set(_isowrench_pc_seen "${_isowrench_pc_seen}" PARENT_SCOPE)
  if(item STREQUAL "Threads::Threads")
    list(APPEND _isowrench_pc_libs -pthread)
  elseif(item MATCHES "^Eigen3::")
    # header-only, already in Requires
  elseif(TARGET ${item})
    get_target_property(_type ${item} TYPE)
    if(NOT _type STREQUAL "INTERFACE_LIBRARY")
      set(_location "")
      foreach(_property IMPORTED_LOCATION_RELEASE IMPORTED_LOCATION_NOCONFIG IMPORTED_LOCATION)
        get_target_property(_candidate ${item} ${_property})
        if(_candidate AND NOT _location)
          set(_location "${_candidate}")
        endif()
      endforeach()
      if(_location)
        isowrench_pc_flatten("${_location}")
      endif()
    endif()
    get_target_property(_deps ${item} INTERFACE_LINK_LIBRARIES)
    if(_deps)
      foreach(_dep IN LISTS _deps)
        isowrench_pc_flatten("${_dep}")
      endforeach()
    endif()
  elseif(IS_ABSOLUTE "${item}")
    get_filename_component(_dir "${item}" DIRECTORY)
    get_filename_component(_name "${item}" NAME)
    if(_name MATCHES "^lib(.+)\\.(so|a)(\\..*)?$")
      if(NOT _dir IN_LIST CMAKE_CXX_IMPLICIT_LINK_DIRECTORIES)
        list(APPEND _isowrench_pc_libs "-L${_dir}")
      endif()
      list(APPEND _isowrench_pc_libs "-l${CMAKE_MATCH_1}")
    else()
      list(APPEND _isowrench_pc_libs "${item}")
    endif()
  elseif(item MATCHES "^-")
    list(APPEND _isowrench_pc_libs "${item}")
  else()
    list(APPEND _isowrench_pc_libs "-l${item}")
  endif()
  set(_isowrench_pc_libs "${_isowrench_pc_libs}" PARENT_SCOPE)
  set(_isowrench_pc_seen "${_isowrench_pc_seen}" PARENT_SCOPE)
endfunction()
isowrench_pc_flatten(Ceres::ceres)
list(APPEND _isowrench_pc_libs -pthread)
# A static archive must come after every library that needs it: keep the last occurrence.
list(REVERSE _isowrench_pc_libs)
list(REMOVE_DUPLICATES _isowrench_pc_libs)
list(REVERSE _isowrench_pc_libs)
list(JOIN _isowrench_pc_libs " " ISOWRENCH_PC_LIBS_PRIVATE)
file(RELATIVE_PATH ISOWRENCH_PC_TO_PREFIX "/${CMAKE_INSTALL_LIBDIR}/pkgconfig" "/")
string(REGEX REPLACE "/$" "" ISOWRENCH_PC_TO_PREFIX "${ISOWRENCH_PC_TO_PREFIX}")
configure_file(${PROJECT_SOURCE_DIR}/cmake/isowrench.pc.in ${PROJECT_BINARY_DIR}/isowrench.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/isowrench.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)

# Python module (issue 15, python/): the package isowrench (extension _core, __init__.py, stubs)
# into the interpreter's site-packages, Python3_SITEARCH (an absolute path: --prefix does not
# move it; set ISOWRENCH_PYTHON_INSTALL_DIR to install elsewhere).
if(TARGET isowrench_python)
  set(ISOWRENCH_PYTHON_INSTALL_DIR "${Python3_SITEARCH}" CACHE PATH
      "Directory cmake --install puts the Python package isowrench in (default: Python3_SITEARCH)")
  install(TARGETS isowrench_python LIBRARY DESTINATION ${ISOWRENCH_PYTHON_INSTALL_DIR}/isowrench)
  install(FILES ${PROJECT_SOURCE_DIR}/python/isowrench/__init__.py ${PROJECT_SOURCE_DIR}/python/isowrench/__init__.pyi
                ${PROJECT_SOURCE_DIR}/python/isowrench/py.typed
          DESTINATION ${ISOWRENCH_PYTHON_INSTALL_DIR}/isowrench)
endif()
