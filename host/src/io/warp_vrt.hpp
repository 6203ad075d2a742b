// SPDX-License-Identifier: Apache-2.0
#pragma once
// GDAL's warper as a virtual raster, shared by the untiled warp (io/warp.cpp) and the tiled one
// (tile/warp_tiles.cpp), so that both compute every cell by the same block warps.
#include <gdal.h>

#include <terracl/warp.hpp>

#include "io/gdal_common.hpp"

namespace terracl::io {

/// gdalwarp's VRT output (the options of gdalwarp_arguments) over `in`, which must outlive it.
/// Checks the output size first (its sides; with `whole`, also the memory to read it whole);
/// throws "<stage>: ..." on GDAL errors.
DatasetPtr warped_vrt(GDALDatasetH in, const WarpOptions& o, bool source_has_nodata, const std::string& stage,
                      bool whole);
/// What warp() keeps of its input `in` in its output `r` (metadata, vertical units, nodata).
void finish_warp_georef(Heightfield& r, const Heightfield& in, const WarpOptions& o);
/// Checks the options as warp() does (resampling, tr/ts, projwin, CRS).
void check_warp_options(const WarpOptions& o, const std::string& stage);

}  // namespace terracl::io
