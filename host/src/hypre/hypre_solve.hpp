#pragma once
// Internal entry of the hypre back end (reconstruct.cpp dispatches here after validating the
// options and resolving the hard cells).
#include <terracl/heightfield.hpp>
#include <terracl/reconstruct.hpp>

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace terracl::hypre {

/// Writes the divergence f (1/m) of row y into f[0..W-1], in double.
using RowDivergence = std::function<void(int y, double* f)>;

/// The divergence of rows [y0, y1) (a rank's band): reads what those rows need (a gradient file's
/// band plus the row above it) and returns the row function; called once per solve, on each rank.
using BandDivergence = std::function<RowDivergence(int y0, int y1)>;

/// The constrained Poisson problem of reconstruct.hpp: free cells solve the 5-point Neumann
/// Laplacian = f, hard cells (sorted row-major index list) keep their values. `target`: the mean
/// of the result when there is no hard cell. `gather_to_all`: every rank returns the whole
/// heightfield; otherwise only rank 0 does (the others return an empty z: memory per rank stays
/// its band's), and only rank 0 writes.
ReconstructResult solve(int W, int H, const Georef& georef, const Metadata& meta, const BandDivergence& div,
                        const std::vector<uint32_t>& hard_index, const std::vector<float>& hard_value, double target,
                        const SolverOptions& o, bool gather_to_all = true);

}  // namespace terracl::hypre

namespace terracl {

/// `reconstruct GRAD.exr --solver hypre` without loading the gradient: every MPI rank reads only
/// its band of rows (plus one halo row) from `path`; rank 0 alone returns the heightfield (the
/// other ranks' z is empty and they write nothing). `c` is the whole grid's constraint set (may
/// be empty: width 0). Refuses --initial, a Dirichlet border and central gradients (the stage
/// reads those whole and calls reconstruct()).
ReconstructResult reconstruct_hypre_file(Device& d, const std::string& path, const ConstraintSet& c,
                                         const SolverOptions& o);

}  // namespace terracl
