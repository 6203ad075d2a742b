// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Core raster values that flow between stages: Heightfield (elevations) and GradientField.
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace terracl {

/// Free-form key/value metadata carried to outputs (provenance: version, command line, stages).
using Metadata = std::map<std::string, std::string>;

/// Georeferencing of a raster, in GDAL's conventions.
struct Georef {
  /// GDAL geotransform: x = gt[0] + col*gt[1] + row*gt[2]; y = gt[3] + col*gt[4] + row*gt[5],
  /// for the top-left corner of a cell. Default: unit pixels, north up.
  std::array<double, 6> geotransform{0.0, 1.0, 0.0, 0.0, 0.0, -1.0};
  bool has_geotransform = false;
  std::string crs_wkt;                ///< empty when unknown
  bool geographic = false;            ///< CRS units are degrees (e.g. SRTM)
  std::optional<double> nodata;       ///< nodata value of the source file (cells are NaN in memory)
  std::string vertical_units = "m";
  /// Metric cell size in metres (x: along a row, y: along a column). For geographic CRSs this is
  /// the size at the raster's centre latitude on the WGS84 ellipsoid; otherwise |gt[1]|, |gt[5]|
  /// (1 when the file has no georeferencing).
  double cell_x = 1.0;
  double cell_y = 1.0;

  /// Recomputes cell_x/cell_y from the geotransform, CRS type and raster size.
  void update_metric_cell_size(int width, int height);
  /// Georef for a grid `factor` times finer (or coarser when < 1) covering the same extent.
  Georef resampled(double factor) const;
};

/// Float32 elevations in metres, row-major, row 0 at the top (north). NaN marks nodata.
struct Heightfield {
  int width = 0;
  int height = 0;
  std::vector<float> z;
  Georef georef;
  Metadata metadata;

  Heightfield() = default;
  Heightfield(int w, int h, float value = 0.0f) : width(w), height(h), z(size_t(w) * h, value) {}

  size_t size() const { return z.size(); }
  float& at(int x, int y) { return z[size_t(y) * width + x]; }
  float at(int x, int y) const { return z[size_t(y) * width + x]; }
  size_t count_nodata() const;
};

/// Summary statistics used by `terracl info` and reports.
struct HeightStats {
  double min = 0, max = 0, mean = 0;
  size_t valid = 0, nodata = 0;
  double mean_slope_deg = 0, max_slope_deg = 0;
};
/// Statistics of the valid cells; slopes use the metric cell size.
HeightStats compute_stats(const Heightfield& h);

/// Gradient in metres per metre on the staggered (face) grid:
///   gx(x, y) = (h(x+1, y) - h(x, y)) / cell_x   for x < width-1, and 0 in the last column;
///   gy(x, y) = (h(x, y+1) - h(x, y)) / cell_y   for y < height-1, and 0 in the last row
/// (y grows downwards, southwards for north-up rasters). This is the internal representation: its
/// backward-difference divergence is exactly the solver's 5-point Laplacian.
struct GradientField {
  int width = 0;
  int height = 0;
  std::vector<float> gx, gy;
  Georef georef;
  Metadata metadata;
  /// Mean elevation of the source heightfield (NaN when unknown); reconstruction keeps it.
  double mean_elevation = std::numeric_limits<double>::quiet_NaN();

  GradientField() = default;
  GradientField(int w, int h) : width(w), height(h), gx(size_t(w) * h, 0.f), gy(size_t(w) * h, 0.f) {}
  size_t size() const { return gx.size(); }
};

/// Replaces nodata (NaN) cells by the harmonic interpolation of their valid neighbours: the
/// discrete Laplace equation of the metric grid (weights 1/cell_x^2, 1/cell_y^2) with the valid
/// cells as Dirichlet values and a natural border, solved exactly (sparse Cholesky). Throws if no
/// cell is valid.
void fill_nodata_harmonic(Heightfield& h);
/// Indices of the nodata (NaN) cells: taken before fill_nodata_harmonic, so that a stage that needs
/// a complete grid (edit, studio) can give its output the input's nodata mask back.
std::vector<size_t> nodata_cells(const Heightfield& h);
/// Marks `cells` nodata (NaN) again.
void restore_nodata(Heightfield& h, const std::vector<size_t>& cells);

/// Throws a clear error naming `stage` and `what` when `h` has NaN/Inf cells.
void require_finite(const Heightfield& h, const std::string& stage, const std::string& what);

}  // namespace terracl
