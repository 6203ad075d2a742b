// SPDX-License-Identifier: Apache-2.0
// `warp` on GDAL's warper through gdal_utils' GDALWarp (the code of the gdalwarp program), so the
// options mean and do exactly what they do in gdalwarp; no resampler of our own. The heightfield
// goes in as an in-memory (MEM) dataset and comes out of an in-memory one (tiled: a VRT).
#include "io/gdal_common.hpp"
#include "io/warp_vrt.hpp"

#include <terracl/error.hpp>
#include <terracl/json_limits.hpp>
#include <terracl/memory.hpp>
#include <terracl/warp.hpp>

#include <cpl_string.h>
#include <gdal_alg.h>
#include <gdal_utils.h>
#include <ogr_spatialref.h>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace terracl {
namespace {

std::string num(double v) { return fmt::format("{:.17g}", v); }

void check_options(const WarpOptions& o, const std::string& stage) {
  const auto& r = warp_resamplings();
  if (std::find(r.begin(), r.end(), o.resampling) == r.end())
    fail(stage, "resampling '{}' is not one of {}", abbreviate(o.resampling, 30), fmt::join(r, "|"));
  if (o.tr && o.ts) fail(stage, "--tr and --ts exclude each other (give a cell size or a size, as in gdalwarp)");
  if (o.tr && !((*o.tr)[0] > 0 && (*o.tr)[1] > 0 && std::isfinite((*o.tr)[0]) && std::isfinite((*o.tr)[1])))
    fail(stage, "--tr {} {}: the target cell size must be two positive numbers", (*o.tr)[0], (*o.tr)[1]);
  if (o.ts) {
    const auto [w, h] = *o.ts;
    if (w < 0 || h < 0 || (w == 0 && h == 0) || w > 65536 || h > 65536)
      fail(stage, "--ts {} {}: the target size must be in 1..65536 cells (0 in one of them keeps the aspect ratio)", w,
           h);
  }
  if (o.projwin) {
    const auto& p = *o.projwin;
    if (!std::all_of(p.begin(), p.end(), [](double v) { return std::isfinite(v); }) || !(p[2] > p[0]) || !(p[1] > p[3]))
      fail(stage, "--projwin {} {} {} {}: expected ulx uly lrx lry with lrx > ulx and uly > lry", p[0], p[1], p[2], p[3]);
  }
  if (!o.t_srs.empty()) {
    OGRSpatialReference srs;
    if (srs.SetFromUserInput(o.t_srs.c_str()) != OGRERR_NONE)
      fail(stage, "--t-srs '{}': not a CRS GDAL knows (try EPSG:32619, a WKT or a PROJ string)", abbreviate(o.t_srs, 60));
  }
}

// The output size gdalwarp will choose, computed as it does (GDALSuggestedWarpOutput2, then -te /
// -tr / -ts), and refused before GDAL allocates it: `--tr 1e-7` asked GDAL for 3.4 TB, `--tr
// 1e-12` and a 1e300 --projwin overflowed its int sizes ("-2147483648x-2147483648 dataset").
void check_output_size(GDALDatasetH in, const WarpOptions& o, const std::string& stage, bool whole) {
  std::string dst_wkt;
  if (!o.t_srs.empty()) {
    OGRSpatialReference srs;
    srs.SetFromUserInput(o.t_srs.c_str());
    char* wkt = nullptr;
    if (srs.exportToWkt(&wkt) == OGRERR_NONE && wkt) dst_wkt = wkt;
    CPLFree(wkt);
  }
  void* tr = GDALCreateGenImgProjTransformer(in, nullptr, nullptr, dst_wkt.empty() ? nullptr : dst_wkt.c_str(), FALSE,
                                             0.0, 0);
  if (!tr) return;  // GDALWarp reports it
  double gt[6] = {0, 1, 0, 0, 0, -1}, ext[4] = {0, 0, 0, 0};
  int sw = 0, sh = 0;
  const CPLErr e = GDALSuggestedWarpOutput2(in, GDALGenImgProjTransform, tr, gt, &sw, &sh, ext, 0);
  GDALDestroyGenImgProjTransformer(tr);
  if (e != CE_None || sw <= 0 || sh <= 0) return;  // GDALWarp reports it
  double minx = ext[0], miny = ext[1], maxx = ext[2], maxy = ext[3];
  if (o.projwin) minx = (*o.projwin)[0], maxy = (*o.projwin)[1], maxx = (*o.projwin)[2], miny = (*o.projwin)[3];
  const double ex = maxx - minx, ey = maxy - miny;
  double w = 0, h = 0;
  if (o.tr) {
    w = ex / (*o.tr)[0] + 0.5, h = ey / (*o.tr)[1] + 0.5;
  } else if (o.ts) {
    w = (*o.ts)[0], h = (*o.ts)[1];
    if (w == 0) w = h * ex / ey + 0.5;
    if (h == 0) h = w * ey / ex + 0.5;
  } else {
    w = ex / gt[1] + 0.5, h = ey / std::fabs(gt[5]) + 0.5;
  }
  const char* hint = "use a larger --tr, a smaller --projwin or --ts";
  const auto cells = [](double v) { return v < 1e15 ? fmt::format("{:.0f}", v) : fmt::format("{:.3g}", v); };
  if (!(w <= double(max_raster_side) && h <= double(max_raster_side)))
    fail(stage, "the output would be {} x {} cells; each side may be at most {} cells: {}", cells(w), cells(h),
         max_raster_side, hint);
  if (!whole) return;  // a tiled warp holds one tile of it
  // The output read whole and the heightfield copied from it.
  const int64_t iw = std::max<int64_t>(1, int64_t(w)), ih = std::max<int64_t>(1, int64_t(h));
  require_memory(stage, fmt::format("the warp output ({} x {} cells)", iw, ih), double(iw) * double(ih) * 8, 0, 0,
                 nullptr, hint);
}

}  // namespace

void io::check_warp_options(const WarpOptions& o, const std::string& stage) { check_options(o, stage); }

std::vector<std::string> gdalwarp_arguments(const WarpOptions& o, bool source_has_nodata) {
  std::vector<std::string> a = {"-r", o.resampling, "-ot", "Float32"};
  if (!o.t_srs.empty()) a.insert(a.end(), {"-t_srs", o.t_srs});
  if (o.tr) a.insert(a.end(), {"-tr", num((*o.tr)[0]), num((*o.tr)[1])});
  if (o.ts) a.insert(a.end(), {"-ts", std::to_string((*o.ts)[0]), std::to_string((*o.ts)[1])});
  if (o.projwin) {
    const auto& p = *o.projwin;
    a.insert(a.end(), {"-te", num(p[0]), num(p[3]), num(p[2]), num(p[1])});
  }
  // Without a source nodata, gdalwarp fills cells outside the source with 0, an elevation.
  if (!source_has_nodata) a.insert(a.end(), {"-dstnodata", "nan"});
  return a;
}

io::DatasetPtr io::warped_vrt(GDALDatasetH in, const WarpOptions& o, bool source_has_nodata,
                              const std::string& stage, bool whole, const char* format) {
  check_output_size(in, o, stage, whole);
  std::vector<std::string> args = gdalwarp_arguments(o, source_has_nodata);
  // MEM (the untiled warp): GDALWarp chunks the output by its memory limit exactly as the gdalwarp
  // program does, so the cells equal gdalwarp's bit for bit. VRT (the tiled warp): nothing is
  // warped until a window is read, and each block is warped on its own (its own source window and
  // approximate transformer along the block's rows), so a cell depends on its block only, not on
  // the window that asked for it; it differs from gdalwarp by the transformer's -et 0.125 px
  // approximation (~1e-3 m on a 30 m DEM).
  args.insert(args.begin(), {"-of", format});
  CPLStringList argv;
  for (const auto& s : args) argv.AddString(s.c_str());
  GDALWarpAppOptions* wo = GDALWarpAppOptionsNew(argv.List(), nullptr);
  if (!wo) fail(stage, "GDAL refused the warp options ({})", io::last_gdal_error());
  int usage_error = FALSE;
  CPLErrorReset();
  GDALDatasetH out = GDALWarp("", nullptr, 1, &in, wo, &usage_error);
  GDALWarpAppOptionsFree(wo);
  if (!out) fail(stage, "GDAL's warp failed ({})", io::last_gdal_error());
  return io::DatasetPtr(GDALDataset::FromHandle(out));
}

void io::finish_warp_georef(Heightfield& r, const Heightfield& in, const WarpOptions& o) {
  r.metadata = in.metadata;
  // The source's CRS note ("assumed WGS 84") says nothing true of a reprojected output.
  if (!o.t_srs.empty()) r.metadata.erase("terracl:crs_assumed");
  r.georef.vertical_units = in.georef.vertical_units;
  r.georef.nodata = in.georef.nodata;
}

Heightfield warp(const Heightfield& h, const WarpOptions& o, const Progress& progress, const std::string& stage) {
  io::init_gdal();
  check_options(o, stage);
  if (h.width <= 0 || h.height <= 0) fail(stage, "the input has no cells");
  if (!o.t_srs.empty() && h.georef.crs_wkt.empty())
    fail(stage, "--t-srs needs an input with a CRS; this raster has none (a PNG/RAW16 sidecar or a GeoTIFF carries it)");
  Heightfield src_copy;
  const Heightfield* src = &h;
  const bool local = !h.georef.has_geotransform;
  if (local) {
    // A grid without georeferencing: x east, y south, in metres of its cell size.
    src_copy = h;
    src_copy.georef.geotransform = {0.0, h.georef.cell_x, 0.0, 0.0, 0.0, -h.georef.cell_y};
    src_copy.georef.has_geotransform = true;
    src = &src_copy;
  }
  const bool has_nodata = h.georef.nodata.has_value() || h.count_nodata() > 0;
  io::DatasetPtr mem = io::to_mem_dataset(*src, GDT_Float32);
  if (progress && !progress(0.0, "warping")) throw Cancelled(stage, "cancelled");
  Heightfield r;
  {
    io::DatasetPtr dst = io::warped_vrt(GDALDataset::ToHandle(mem.get()), o, has_nodata, stage, true, "MEM");
    CPLErrorReset();
    r = io::from_dataset(*dst, "warp output");
    if (CPLGetLastErrorType() >= CE_Failure) fail(stage, "GDAL's warp failed ({})", io::last_gdal_error());
  }  // the VRT goes before the source it reads
  if (progress && !progress(1.0, "warping")) throw Cancelled(stage, "cancelled");
  io::finish_warp_georef(r, h, o);
  if (local) {
    r.georef.cell_x = std::fabs(r.georef.geotransform[1]);
    r.georef.cell_y = std::fabs(r.georef.geotransform[5]);
    r.georef.has_geotransform = false;
    r.georef.crs_wkt.clear();
  }
  if (r.count_nodata() == r.size())
    fail(stage, "every output cell is nodata: the window or CRS does not overlap the input");
  return r;
}

}  // namespace terracl
