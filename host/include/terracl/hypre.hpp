// SPDX-License-Identifier: Apache-2.0
#pragma once
/// hypre's structured solver as a reconstruction back end (SolverOptions::solver = Solver::Hypre):
/// PFMG-preconditioned CG in double on the host, distributed by bands of rows over the MPI ranks
/// when the program runs under mpirun (one rank otherwise). Present only in builds configured
/// with -DTERRACL_MPI=ON; elsewhere the solver is refused with an error saying so.

namespace terracl {

/// Host memory of a hypre reconstruction per cell of the grid, in bytes (the stage's memory check):
/// measured 193 (peak-RSS slope of `reconstruct --solver hypre` between 400^2 and 1201^2), rounded up.
constexpr double kHypreHostBytesPerCell = 240;

/// True when this build has hypre (TERRACL_HAVE_HYPRE).
bool hypre_available();

/// False only on MPI ranks other than 0 once MPI is initialised (by a hypre solve): callers that
/// write files write them on rank 0 only. True in builds without hypre.
bool hypre_is_root_rank();

}  // namespace terracl
