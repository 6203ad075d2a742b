# SPDX-License-Identifier: Apache-2.0
# hypre's structured solver for `reconstruct --solver hypre` (docs/scale.md), under the MPI option
# (cmake/Mpi.cmake declares the same option for the tile distribution). Defines TERRACL_HAVE_HYPRE
# for the library sources and builds the hypre tests (ctest label `mpi`).
option(TERRACL_MPI "Build the MPI parts: tiles over ranks and the hypre reconstruction (OpenMPI, hypre)" OFF)
if(NOT TERRACL_MPI)
  return()
endif()

find_package(MPI REQUIRED COMPONENTS CXX)
find_path(HYPRE_INCLUDE_DIR HYPRE_struct_ls.h PATH_SUFFIXES hypre REQUIRED)  # Debian: /usr/include/hypre
find_library(HYPRE_LIBRARY NAMES HYPRE REQUIRED)
message(STATUS "hypre: ${HYPRE_LIBRARY} (${HYPRE_INCLUDE_DIR})")

target_include_directories(terracl_objects SYSTEM PRIVATE ${HYPRE_INCLUDE_DIR} ${MPI_CXX_INCLUDE_DIRS})
target_compile_definitions(terracl_objects PRIVATE TERRACL_HAVE_HYPRE)
# Library paths rather than imported targets, so that the exported static library's link
# interface needs nothing from terraclConfig.cmake.
foreach(lib terracl_static terracl_shared)
  target_link_libraries(${lib} PRIVATE ${HYPRE_LIBRARY} ${MPI_CXX_LIBRARIES})
endforeach()

if(TERRACL_BUILD_TESTS AND TERRACL_BUILD_APPS)
  add_executable(terracl_hypre_tests ${CMAKE_SOURCE_DIR}/tests/hypre/test_hypre.cpp ${CMAKE_SOURCE_DIR}/tests/test_helpers.cpp)
  target_include_directories(terracl_hypre_tests PRIVATE ${CMAKE_SOURCE_DIR}/tests)
  target_link_libraries(terracl_hypre_tests PRIVATE terracl GTest::gtest GTest::gtest_main
                        OpenImageIO::OpenImageIO GDAL::GDAL)
  target_compile_definitions(terracl_hypre_tests PRIVATE TERRACL_SOURCE_DIR="${CMAKE_SOURCE_DIR}"
                             TERRACL_CLI="$<TARGET_FILE:terracl_cli>" TERRACL_PEAK_RSS="$<TARGET_FILE:terracl_peak_rss>")
  add_dependencies(terracl_hypre_tests terracl_cli terracl_peak_rss)
  target_compile_options(terracl_hypre_tests PRIVATE -Wno-ignored-attributes)
  gtest_discover_tests(terracl_hypre_tests DISCOVERY_TIMEOUT 60 PROPERTIES LABELS mpi TIMEOUT 300)
  # 2 ranks under mpirun against 1 rank (the CLI; scripts/hypre-ranks-check.sh).
  add_test(NAME hypre_two_ranks
           COMMAND bash ${CMAKE_SOURCE_DIR}/scripts/hypre-ranks-check.sh $<TARGET_FILE:terracl_cli> ${MPIEXEC_EXECUTABLE})
  set_tests_properties(hypre_two_ranks PROPERTIES LABELS mpi TIMEOUT 300)
endif()
