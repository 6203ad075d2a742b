// SPDX-License-Identifier: Apache-2.0
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

/// What one rank needs of the problem for its rows [y0, y1), with [h0, h1) those rows plus the
/// row either side that its stencils reach.
struct Band {
  RowDivergence div;                 ///< rows [y0, y1); may hold the band's input until dropped
  std::vector<uint32_t> hard_index;  ///< hard cells on rows [h0, h1): whole-grid indices, sorted
  std::vector<float> hard_value;
  std::vector<float> initial;  ///< the start heightfield's rows [y0, y1) (metres), or empty
};

/// Reads a rank's band (called once per solve, on each rank): a file's band plus its halo rows,
/// or slices of a whole problem held in memory.
using BandReader = std::function<Band(int y0, int y1, int h0, int h1)>;

/// The constrained Poisson problem of reconstruct.hpp: free cells solve the 5-point Neumann
/// Laplacian = f, hard cells keep their values. The hard cells' count and mean, and the target
/// mean (NaN: the mean of the start heightfield, 0 without one) used when there is no hard cell,
/// are summed over the ranks. `gather_to_all`: every rank returns the whole heightfield;
/// otherwise only rank 0 does (the others return an empty z: memory per rank stays its band's),
/// and only rank 0 writes.
ReconstructResult solve(int W, int H, const Georef& georef, const Metadata& meta, const BandReader& band,
                        double target, const SolverOptions& o, bool gather_to_all = true);

/// A whole problem in memory as a BandReader (every rank slices its rows).
BandReader whole_problem(int W, const RowDivergence& div, const std::vector<uint32_t>& hard_index,
                         const std::vector<float>& hard_value, const Heightfield* initial);

}  // namespace terracl::hypre

namespace terracl {

/// The files of a hypre reconstruction read by bands of rows (empty: not given).
struct HypreBandFiles {
  std::string gradient;    ///< staggered or central gradient EXR, or
  std::string divergence;  ///< a divergence raster (1/m)
  std::string initial;     ///< start heightfield (also the Dirichlet border's and "freeze" values)
  std::string fixed_mask, fixed_elevation;
  std::string constraints;  ///< constraint JSON
};

/// `reconstruct --solver hypre` without loading whole fields: every MPI rank reads only its band
/// of rows (plus the halo rows its stencils and differences reach) of each file, and rasterises
/// only its rows of the constraints; rank 0 alone returns the heightfield (the other ranks' z is
/// empty and they write nothing). Rasters GDAL reads (GeoTIFF, HGT, ...) are read by windows;
/// other formats are read whole and sliced. `o.initial` must be null (give `f.initial`);
/// `o.dirichlet_border` takes the border from `f.initial`.
ReconstructResult reconstruct_hypre_files(const HypreBandFiles& f, const SolverOptions& o);

/// Reads rows [y0, y1) of a heightfield raster as read_heightfield would (windowed where GDAL
/// reads the format); `W`, `H` receive the whole raster's size.
Heightfield read_heightfield_rows(const std::string& path, int y0, int y1, int* W = nullptr, int* H = nullptr);

}  // namespace terracl
