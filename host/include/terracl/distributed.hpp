// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Tiled runs over MPI ranks (`mpirun -n N terracl run P.json --tile T`, docs/scale.md). In a build
/// with TERRACL_MPI, start() joins MPI when the process was launched by mpirun / mpiexec; the tile
/// runner then gives each rank its share of the tiles and rank 0 writes every output. Without
/// TERRACL_MPI (or without mpirun) the process is the only rank. No MPI type appears here.
#include <string>
#include <vector>

namespace terracl::distributed {

/// Joins MPI when launched by mpirun (OMPI_COMM_WORLD_SIZE / PMI_SIZE / PMIX_RANK set) and the
/// build has MPI; returns the number of ranks (1 otherwise). Call once, first thing in main.
int start(int* argc, char*** argv);
/// This process's rank (0 when not under MPI) and the number of ranks (1).
int rank();
int size();
/// Rank among the ranks on the same node (for the choice of the OpenCL device: rank modulo the
/// node's device count).
int local_rank();
/// "MPI (Open MPI v4.1.4), 3 ranks" or "" when not under MPI.
std::string describe();
/// At rank 0: every rank's `text`, in rank order (elsewhere: empty). Collective.
std::vector<std::string> gather_text(const std::string& text);
/// Stops every rank with exit status `code` (MPI_Abort); the caller has printed the error. Not
/// under MPI: exits the process with `code`.
[[noreturn]] void abort(int code);
/// Leaves MPI (MPI_Finalize) after the command finished; no-op when not under MPI.
void finish();

}  // namespace terracl::distributed
