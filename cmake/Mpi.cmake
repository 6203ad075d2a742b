# SPDX-License-Identifier: Apache-2.0
# TERRACL_MPI=ON: tiled runs distributed over MPI ranks (`mpirun -n N terracl run P.json --tile T`,
# docs/scale.md). Debian's OpenMPI (libopenmpi-dev, openmpi-bin). The MPI code lives in
# host/src/mpi/ (compiled only here); without the option the library runs tiles in one process.
find_package(MPI REQUIRED COMPONENTS CXX)
file(GLOB TERRACL_MPI_SOURCES CONFIGURE_DEPENDS ${CMAKE_SOURCE_DIR}/host/src/mpi/*.cpp)
target_sources(terracl_objects PRIVATE ${TERRACL_MPI_SOURCES})
# No public header names MPI: the define and the headers are the library's own.
target_compile_definitions(terracl_objects PRIVATE TERRACL_HAVE_MPI=1)
foreach(lib terracl_objects terracl_static terracl_shared)
  # The static library exports it as $<LINK_ONLY:MPI::MPI_CXX> (terraclConfig.cmake finds MPI).
  target_link_libraries(${lib} PRIVATE MPI::MPI_CXX)
endforeach()
if(TERRACL_BUILD_TESTS)
  enable_testing()
  # mpirun with 2 and 3 ranks (--oversubscribe: the CI machine has 2 cores) against one process.
  add_test(NAME mpi_tiles COMMAND bash ${CMAKE_SOURCE_DIR}/scripts/mpi-check.sh ${CMAKE_BINARY_DIR})
  set_tests_properties(mpi_tiles PROPERTIES LABELS mpi TIMEOUT 300)
endif()
