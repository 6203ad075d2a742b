// SPDX-License-Identifier: Apache-2.0
#pragma once
// GDAL's warper, shared by the untiled warp (io/warp.cpp, in memory, as the gdalwarp program) and
// the tiled one (tile/warp_tiles.cpp, a virtual raster read window by window).
#include <gdal.h>

#include <terracl/warp.hpp>

#include "io/gdal_common.hpp"

namespace terracl::io {

/// gdalwarp's output (the options of gdalwarp_arguments) over `in`, which must outlive it: "VRT"
/// (warped block by block as windows are read; the tiled warp) or "MEM" (warped at once, equal to
/// the gdalwarp program's cells). Checks the output size first (its sides; with `whole`, also the
/// memory to read it whole); throws "<stage>: ..." on GDAL errors.
DatasetPtr warped_vrt(GDALDatasetH in, const WarpOptions& o, bool source_has_nodata, const std::string& stage,
                      bool whole, const char* format = "VRT");
/// What warp() keeps of its input `in` in its output `r` (metadata, vertical units, nodata).
void finish_warp_georef(Heightfield& r, const Heightfield& in, const WarpOptions& o);
/// Checks the options as warp() does (resampling, tr/ts, projwin, CRS).
void check_warp_options(const WarpOptions& o, const std::string& stage);

}  // namespace terracl::io
