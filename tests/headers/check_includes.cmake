# SPDX-License-Identifier: Apache-2.0
# Fails when a public header includes something an installed package cannot promise: a private
# header of host/src ("multigrid.hpp"), or a library terracl uses only inside (GDAL, libpng,
# OpenEXR, FLANN, tinygltf, lz4, httplib). Allowed: <terracl/...>, the standard library (no
# extension or <c...>), <CL/...>, <nlohmann/...>, <fmt/...>, <Eigen/...>.
#   cmake -DHEADER_DIR=host/include/terracl -P tests/headers/check_includes.cmake
file(GLOB headers ${HEADER_DIR}/*.hpp)
if(NOT headers)
  message(FATAL_ERROR "check_includes: no headers in '${HEADER_DIR}'")
endif()
set(bad "")
foreach(h IN LISTS headers)
  file(STRINGS ${h} lines REGEX "^[ \t]*#[ \t]*include")
  foreach(line IN LISTS lines)
    string(REGEX REPLACE "^[ \t]*#[ \t]*include[ \t]*" "" inc "${line}")
    string(REGEX REPLACE "[ \t]*//.*" "" inc "${inc}")
    string(STRIP "${inc}" inc)
    if(inc MATCHES "^<(terracl|CL|nlohmann|fmt|Eigen)/[A-Za-z0-9_./]+>$" OR inc MATCHES "^<[a-z_]+>$")
      continue()
    endif()
    get_filename_component(name ${h} NAME)
    string(APPEND bad "  ${name}: #include ${inc}\n")
  endforeach()
endforeach()
if(bad)
  message(FATAL_ERROR "public headers include private or non-public headers:\n${bad}")
endif()
list(LENGTH headers n)
message(STATUS "check_includes: ${n} public headers include only public dependencies")
