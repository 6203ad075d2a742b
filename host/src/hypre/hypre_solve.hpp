#pragma once
// Internal entry of the hypre back end (reconstruct.cpp dispatches here after validating the
// options and resolving the hard cells).
#include <terracl/heightfield.hpp>
#include <terracl/reconstruct.hpp>

#include <cstdint>
#include <functional>
#include <vector>

namespace terracl::hypre {

/// Writes the divergence f (1/m) of row y into f[0..W-1], in double.
using RowDivergence = std::function<void(int y, double* f)>;

/// The constrained Poisson problem of reconstruct.hpp: free cells solve the 5-point Neumann
/// Laplacian = f, hard cells (sorted row-major index list) keep their values. `target`: the mean
/// of the result when there is no hard cell. Every rank returns the whole heightfield.
ReconstructResult solve(int W, int H, const Georef& georef, const Metadata& meta, const RowDivergence& div,
                        const std::vector<uint32_t>& hard_index, const std::vector<float>& hard_value, double target,
                        const SolverOptions& o);

}  // namespace terracl::hypre
