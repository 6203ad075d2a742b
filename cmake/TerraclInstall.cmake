# SPDX-License-Identifier: Apache-2.0
# `cmake --install` and the CMake package (docs/cpp.md): headers, the static and the shared
# library, the CLI, terraclConfig.cmake + terraclConfigVersion.cmake + the exported targets.
#
# Install components (CPack makes one Debian package per component, cmake/TerraclPackage.cmake):
#   runtime      the CLI and the shared library (libterracl.so.0)
#   development  headers, the static library, the libterracl.so link, the CMake package
#   python       the Python module (python/CMakeLists.txt installs into it; packaged when present)
include(CMakePackageConfigHelpers)

set(TERRACL_INSTALL_CMAKEDIR ${CMAKE_INSTALL_LIBDIR}/cmake/terracl CACHE STRING
    "Where terraclConfig.cmake is installed (relative to the prefix)")

install(DIRECTORY ${CMAKE_SOURCE_DIR}/host/include/terracl DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}
        COMPONENT development FILES_MATCHING PATTERN "*.hpp")
install(FILES ${CMAKE_BINARY_DIR}/generated/terracl/version.hpp
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/terracl COMPONENT development)

install(TARGETS terracl_static terracl_shared EXPORT terraclTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT development
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT runtime NAMELINK_COMPONENT development)
if(TARGET terracl_cli)
  install(TARGETS terracl_cli RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT runtime)
endif()

# The licence (Apache-2.0) in every package, where Debian policy puts it.
install(FILES ${CMAKE_SOURCE_DIR}/cmake/copyright DESTINATION ${CMAKE_INSTALL_DATAROOTDIR}/doc/terracl COMPONENT runtime)
install(FILES ${CMAKE_SOURCE_DIR}/cmake/copyright DESTINATION ${CMAKE_INSTALL_DATAROOTDIR}/doc/terracl-dev COMPONENT development)
install(EXPORT terraclTargets NAMESPACE terracl:: DESTINATION ${TERRACL_INSTALL_CMAKEDIR}
        COMPONENT development)
configure_package_config_file(${CMAKE_SOURCE_DIR}/cmake/terraclConfig.cmake.in
                              ${CMAKE_BINARY_DIR}/terraclConfig.cmake
                              INSTALL_DESTINATION ${TERRACL_INSTALL_CMAKEDIR})
# 0.x: a minor release may change the API and the ABI (semver item 4), so find_package(terracl 0.1)
# accepts 0.1.z only. From 1.0 on this becomes SameMajorVersion.
write_basic_package_version_file(${CMAKE_BINARY_DIR}/terraclConfigVersion.cmake
                                 VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_BINARY_DIR}/terraclConfig.cmake ${CMAKE_BINARY_DIR}/terraclConfigVersion.cmake
        DESTINATION ${TERRACL_INSTALL_CMAKEDIR} COMPONENT development)

# The installed package as a user gets it: install into a temporary prefix, build and run
# examples/cpp against it (shared and static), cpack -G DEB and check the packages
# (scripts/package-check.sh). terracl_tests depends on the shared library so that building the
# usual targets (terracl_cli terracl_tests) is enough to run it.
if(TERRACL_BUILD_TESTS AND TARGET terracl_cli AND TARGET terracl_tests)
  add_dependencies(terracl_tests terracl_shared)
  add_test(NAME package_install COMMAND bash ${CMAKE_SOURCE_DIR}/scripts/package-check.sh ${CMAKE_BINARY_DIR})
  set_tests_properties(package_install PROPERTIES LABELS package TIMEOUT 600)
endif()
