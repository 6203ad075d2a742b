# SPDX-License-Identifier: Apache-2.0
# TERRACL_CORE_ONLY=ON: the OpenCL core without the GIS stack (no GDAL, OpenImageIO, OpenEXR, FLANN,
# tinygltf, lz4, cpp-httplib). Needs a C++17 compiler, CMake, OpenCL headers + ICD loader and the
# header-only libraries (nlohmann-json, fmt, Eigen, CLI11). It is what runs on a machine that has
# a GPU driver but no package registry (docs/gpu.md, scripts/gpu-check.sh).
#
# The seam is per file: every source that includes a GIS library is left out (the list below) and
# host/core_only/unavailable.cpp defines the same functions, throwing "not available in the core
# build". RAW16 (.r16/.raw) rasters and .npy arrays are the files this build reads and writes.

find_package(OpenCL REQUIRED)
find_package(Eigen3 REQUIRED NO_MODULE)
find_package(CLI11 REQUIRED)
find_package(nlohmann_json REQUIRED)
find_package(Threads REQUIRED)
# fmt header-only, found by its headers: Debian's fmt CMake config names the shared library, which
# a prefix unpacked from libfmt-dev alone (scripts/gpu-pack.sh) does not have.
find_path(FMT_INCLUDE_DIR fmt/format.h REQUIRED)
add_library(terracl_fmt INTERFACE)
target_include_directories(terracl_fmt INTERFACE ${FMT_INCLUDE_DIR})
target_compile_definitions(terracl_fmt INTERFACE FMT_HEADER_ONLY=1)
set(TERRACL_FMT terracl_fmt)

file(GLOB TERRACL_KERNELS CONFIGURE_DEPENDS ${CMAKE_SOURCE_DIR}/kernels/*.cl ${CMAKE_SOURCE_DIR}/kernels/*.clh)
set(EMBEDDED_KERNELS_CPP ${CMAKE_BINARY_DIR}/generated/embedded_kernels.cpp)
add_custom_command(
  OUTPUT ${EMBEDDED_KERNELS_CPP}
  COMMAND ${CMAKE_COMMAND} -DOUT=${EMBEDDED_KERNELS_CPP} -DDIR=${CMAKE_SOURCE_DIR}/kernels "-DPATTERNS=*.cl,*.clh"
          -DFUNC=embedded_kernels -DDELIM=tclkernel -P ${CMAKE_SOURCE_DIR}/cmake/EmbedFiles.cmake
  DEPENDS ${TERRACL_KERNELS} ${CMAKE_SOURCE_DIR}/cmake/EmbedFiles.cmake
  COMMENT "Embedding OpenCL kernels" VERBATIM)
configure_file(${CMAKE_SOURCE_DIR}/cmake/version.hpp.in ${CMAKE_BINARY_DIR}/generated/terracl/version.hpp)

file(GLOB_RECURSE TERRACL_CORE_SOURCES CONFIGURE_DEPENDS ${CMAKE_SOURCE_DIR}/host/src/*.cpp)
# Sources that need a GIS / image / mesh / web library, and the features built on them
# (amplify/resample.cpp and parallel.cpp stay: the downsample stage uses them).
list(FILTER TERRACL_CORE_SOURCES EXCLUDE REGEX
     "/host/src/(mpi/.*|reconstruct/hypre_bands|io/gdal_io|io/gdal_window|io/tiff_blocks|io/gradient_tiff|io/image_io|io/image_file|io/png_codec|io/exr_codec|render/render_stream|io/warp|tile/tile_run|tile/tile_segment|tile/tiled_run_parts|tile/render_tiles|tile/warp_tiles|tile/metrics_tiles|tile/amplify_tiles|authoring/gradient_image|authoring/landform_detail|analysis/sketch_vectors|analysis/pour_points|authoring/ops_amplify|render/render_png|mesh/mesh_gltf|studio/.*|amplify/(amplify|amplify_stage|amplify_step|amplify_calibration|amplify_cascade|amplify_gain|dictionary|eval|exemplar_warp|flann_search|ksvd|omp|patches|regression|spectral))\\.cpp$")
list(APPEND TERRACL_CORE_SOURCES ${CMAKE_SOURCE_DIR}/host/core_only/unavailable.cpp)

add_library(terracl STATIC ${TERRACL_CORE_SOURCES} ${EMBEDDED_KERNELS_CPP})
target_include_directories(terracl
  PUBLIC ${CMAKE_SOURCE_DIR}/host/include ${CMAKE_BINARY_DIR}/generated
  PRIVATE ${CMAKE_SOURCE_DIR}/host/src)
target_compile_definitions(terracl PUBLIC
  CL_HPP_TARGET_OPENCL_VERSION=120 CL_HPP_MINIMUM_OPENCL_VERSION=120 CL_HPP_ENABLE_EXCEPTIONS
  CL_TARGET_OPENCL_VERSION=120)
target_link_libraries(terracl PUBLIC OpenCL::OpenCL nlohmann_json::nlohmann_json ${TERRACL_FMT} Eigen3::Eigen Threads::Threads)
target_compile_options(terracl PRIVATE -Wall -Wextra -Wno-ignored-attributes)

# The CLI: `terracl bench` and `terracl devices` are what the core build is for.
add_executable(terracl_cli ${CMAKE_SOURCE_DIR}/apps/terracl.cpp ${CMAKE_SOURCE_DIR}/apps/cmd_bench.cpp
               ${CMAKE_SOURCE_DIR}/apps/cmd_devices.cpp ${CMAKE_SOURCE_DIR}/apps/warm_kernels.cpp
               ${CMAKE_SOURCE_DIR}/apps/progress_display.cpp ${CMAKE_SOURCE_DIR}/apps/allocator.cpp)
set_target_properties(terracl_cli PROPERTIES OUTPUT_NAME terracl RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/bin)
target_link_libraries(terracl_cli PRIVATE terracl CLI11::CLI11)
target_compile_options(terracl_cli PRIVATE -Wall -Wextra -Wno-ignored-attributes)

# The core test subset: device, gradient, reconstruction, edit and erosion suites, GoogleTest built
# from source when no installed one is found (TERRACL_GTEST_SOURCE: Debian's /usr/src/googletest).
if(TERRACL_BUILD_TESTS)
  enable_testing()
  find_package(GTest QUIET)
  if(NOT GTest_FOUND)
    set(TERRACL_GTEST_SOURCE "/usr/src/googletest" CACHE PATH "GoogleTest source tree (googletest package)")
    set(INSTALL_GTEST OFF CACHE BOOL "" FORCE)
    set(BUILD_GMOCK OFF CACHE BOOL "" FORCE)
    add_subdirectory(${TERRACL_GTEST_SOURCE} ${CMAKE_BINARY_DIR}/googletest EXCLUDE_FROM_ALL)
    if(NOT TARGET GTest::gtest)  # googletest >= 1.11 defines them itself
      add_library(GTest::gtest ALIAS gtest)
      add_library(GTest::gtest_main ALIAS gtest_main)
    endif()
  endif()
  set(TERRACL_CORE_TESTS test_helpers test_device test_gradient test_reconstruct test_refine test_npy test_edit test_erosion)
  list(TRANSFORM TERRACL_CORE_TESTS PREPEND ${CMAKE_SOURCE_DIR}/tests/)
  list(TRANSFORM TERRACL_CORE_TESTS APPEND .cpp)
  add_executable(terracl_tests ${TERRACL_CORE_TESTS})
  add_executable(terracl_peak_rss ${CMAKE_SOURCE_DIR}/tests/tools/peak_rss.cpp)
  target_link_libraries(terracl_tests PRIVATE terracl GTest::gtest GTest::gtest_main)
  target_compile_definitions(terracl_tests PRIVATE
    TERRACL_SOURCE_DIR="${CMAKE_SOURCE_DIR}" TERRACL_CLI="$<TARGET_FILE:terracl_cli>"
    TERRACL_PEAK_RSS="$<TARGET_FILE:terracl_peak_rss>")
  target_compile_options(terracl_tests PRIVATE -Wno-ignored-attributes)
  add_dependencies(terracl_tests terracl_cli terracl_peak_rss)
  # Tests that read or write GeoTIFF/EXR/PNG, or run CLI commands the core CLI lacks, are left out.
  include(${CMAKE_SOURCE_DIR}/cmake/CoreTestFilter.cmake)
  add_test(NAME core_tests COMMAND terracl_tests --gtest_filter=${TERRACL_CORE_TEST_FILTER})
  set_tests_properties(core_tests PROPERTIES TIMEOUT 900)
endif()
