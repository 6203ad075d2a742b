# SPDX-License-Identifier: Apache-2.0
# The CLI loads GDAL and libtiff at its first call into them instead of at start-up: GDAL brings
# about a hundred shared libraries, ~55 ms of loading and relocation on every run, which commands
# that open no GeoTIFF/HGT/ASCII grid never use (docs/performance.md, "Start-up").
# cmake/GenLazyStubs.cmake writes a stub per function the CLI calls in them; apps/lazy/ resolves it.
# x86-64 Linux only (the stubs are assembly); elsewhere, and under the sanitizers, the CLI links them
# as usual. The library, the Python module and the tests always link them as usual.
option(TERRACL_LAZY_LIBRARIES "CLI: load GDAL and libtiff at their first use (x86-64 Linux)" ON)
set(TERRACL_LAZY_ACTIVE OFF)
if(NOT TERRACL_LAZY_LIBRARIES OR NOT TARGET terracl_cli OR TERRACL_SANITIZE
   OR NOT CMAKE_SYSTEM_NAME STREQUAL "Linux" OR NOT CMAKE_SYSTEM_PROCESSOR MATCHES "^(x86_64|AMD64|amd64)$")
  return()
endif()
set(TERRACL_LAZY_ACTIVE ON)
set(_lazy_stubs ${CMAKE_BINARY_DIR}/generated/lazy_stubs.cpp)
add_custom_command(
  OUTPUT ${_lazy_stubs}
  COMMAND ${CMAKE_COMMAND} -DNM=${CMAKE_NM} -DOBJDUMP=${CMAKE_OBJDUMP} -DOUT=${_lazy_stubs}
          "-DINPUTS=$<TARGET_FILE:terracl_static>|$<JOIN:$<TARGET_OBJECTS:terracl_cli_objects>,|>"
          "-DLIBS=$<TARGET_FILE:GDAL::GDAL>|$<TARGET_FILE:TIFF::TIFF>"
          -P ${CMAKE_SOURCE_DIR}/cmake/GenLazyStubs.cmake
  DEPENDS terracl_static $<TARGET_FILE:terracl_static> $<TARGET_OBJECTS:terracl_cli_objects>
          ${CMAKE_SOURCE_DIR}/cmake/GenLazyStubs.cmake
  COMMENT "Stubs for the CLI's lazily loaded libraries" VERBATIM)
target_sources(terracl_cli PRIVATE ${_lazy_stubs} ${CMAKE_SOURCE_DIR}/apps/lazy/lazy_resolve.cpp)
# The stubs define every GDAL/libtiff function the CLI calls, so --as-needed leaves both libraries
# out of its NEEDED entries; dlopen needs libdl (part of libc since glibc 2.34).
target_link_libraries(terracl_cli PRIVATE ${CMAKE_DL_LIBS})
