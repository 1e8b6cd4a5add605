# Installation and the exported CMake package (issue 6). Included by the top-level
# CMakeLists.txt after every layer has added its sources, so the link interface is complete.
#
#   cmake --install build --prefix /opt/isowrench
#   find_package(isowrench CONFIG REQUIRED)            # in the consumer
#   target_link_libraries(app isowrench::isowrench)
#   pkg-config --cflags --libs isowrench                # without CMake
#
# Installs: lib/libisowrench.{a,so}, include/isowrench/*.hpp (public headers only; private
# headers stay in src/), bin/isowrench, share/isowrench/urdf/*.urdf,
# lib/cmake/isowrench/{isowrenchConfig,isowrenchConfigVersion,isowrenchTargets}.cmake and
# lib/pkgconfig/isowrench.pc.

include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(ISOWRENCH_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/isowrench)

install(TARGETS isowrench EXPORT isowrenchTargets
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
get_target_property(_isowrench_links isowrench LINK_LIBRARIES)
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

# pkg-config: the static library's private dependencies go to Requires.private / Libs.private.
set(ISOWRENCH_PC_REQUIRES_PRIVATE "orocos-kdl urdfdom tinyxml2")
file(RELATIVE_PATH ISOWRENCH_PC_TO_PREFIX "/${CMAKE_INSTALL_LIBDIR}/pkgconfig" "/")
string(REGEX REPLACE "/$" "" ISOWRENCH_PC_TO_PREFIX "${ISOWRENCH_PC_TO_PREFIX}")
configure_file(${PROJECT_SOURCE_DIR}/cmake/isowrench.pc.in ${PROJECT_BINARY_DIR}/isowrench.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/isowrench.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)
