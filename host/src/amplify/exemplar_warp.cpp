// `amplify --resample-exemplar`: an exemplar at another resolution or CRS is warped by GDAL to the
// output's cell size (and the input's CRS when both are known and differ). Averaging is the model
// of a coarser DEM cell (the amplification's input is the block mean of its output).
#include "amplify/exemplar_warp.hpp"

#include <terracl/error.hpp>

#include <fmt/format.h>
#include <gdal_priv.h>
#include <gdal_utils.h>
#include <ogr_spatialref.h>

#include <cmath>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace terracl {

namespace {

struct DatasetCloser {
  void operator()(GDALDatasetH d) const {
    if (d) GDALClose(d);
  }
};
using DatasetPtr = std::unique_ptr<void, DatasetCloser>;

std::string gdal_error() {
  const char* m = CPLGetLastErrorMsg();
  return (m && *m) ? std::string(m) : std::string("no details from GDAL");
}

DatasetPtr to_mem(const Heightfield& h, const std::string& name) {
  GDALDriverH mem = GDALGetDriverByName("MEM");
  if (!mem) fail("amplify", "--resample-exemplar: GDAL has no MEM driver");
  DatasetPtr ds(GDALCreate(mem, "", h.width, h.height, 1, GDT_Float32, nullptr));
  if (!ds) fail("amplify", "--resample-exemplar: {}: cannot create a {}x{} raster ({})", name, h.width, h.height, gdal_error());
  std::array<double, 6> gt = h.georef.geotransform;
  GDALSetGeoTransform(ds.get(), gt.data());
  if (!h.georef.crs_wkt.empty()) GDALSetProjection(ds.get(), h.georef.crs_wkt.c_str());
  GDALRasterBandH b = GDALGetRasterBand(ds.get(), 1);
  GDALSetRasterNoDataValue(b, std::nan(""));
  std::vector<float> z = h.z;
  if (GDALRasterIO(b, GF_Write, 0, 0, h.width, h.height, z.data(), h.width, h.height, GDT_Float32, 0, 0) != CE_None)
    fail("amplify", "--resample-exemplar: {}: cannot copy the raster ({})", name, gdal_error());
  return ds;
}

}  // namespace

Heightfield resample_exemplar(const Heightfield& ex, const Georef& target, double cell_x, double cell_y,
                              const std::string& name) {
  static std::once_flag once;
  std::call_once(once, [] { GDALAllRegister(); });
  if (!ex.georef.has_geotransform)
    fail("amplify", "--resample-exemplar: {} has no georeferencing: its cell size is unknown", name);
  if (!(cell_x > 0) || !(cell_y > 0)) fail("amplify", "--resample-exemplar: the output cell size is unknown");
  // Averaging can only make cells coarser: a coarser exemplar has no detail to give.
  if (ex.georef.cell_x > 1.05 * cell_x || ex.georef.cell_y > 1.05 * cell_y)
    fail("amplify", "--resample-exemplar: {}'s {:.3f} x {:.3f} m cells are coarser than the output's {:.3f} x {:.3f} m; "
         "resampling cannot add detail", name, ex.georef.cell_x, ex.georef.cell_y, cell_x, cell_y);
  bool reproject = false;
  if (!ex.georef.crs_wkt.empty() && !target.crs_wkt.empty() && target.has_geotransform) {
    OGRSpatialReference a, b;
    a.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    b.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    if (a.importFromWkt(ex.georef.crs_wkt.c_str()) == OGRERR_NONE && b.importFromWkt(target.crs_wkt.c_str()) == OGRERR_NONE)
      reproject = !a.IsSame(&b);
  }
  // Target resolution in the units of the target CRS (the input's when reprojecting, else the
  // exemplar's): the metric cell size scaled by the grid's metres per unit.
  const Georef& g = reproject ? target : ex.georef;
  const double rx = std::fabs(g.geotransform[1]) * cell_x / g.cell_x, ry = std::fabs(g.geotransform[5]) * cell_y / g.cell_y;
  const DatasetPtr src = to_mem(ex, name);
  std::vector<std::string> args = {"-of", "MEM", "-r", "average", "-tr", fmt::format("{:.17g}", rx), fmt::format("{:.17g}", ry),
                                   "-dstnodata", "nan"};
  if (reproject) args.insert(args.end(), {"-t_srs", target.crs_wkt});
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  std::unique_ptr<GDALWarpAppOptions, void (*)(GDALWarpAppOptions*)> opts(GDALWarpAppOptionsNew(argv.data(), nullptr),
                                                                          GDALWarpAppOptionsFree);
  if (!opts) fail("amplify", "--resample-exemplar: bad warp options ({})", gdal_error());
  CPLErrorReset();
  GDALDatasetH in = src.get();
  int usage_error = 0;
  const DatasetPtr dst(GDALWarp("", nullptr, 1, &in, opts.get(), &usage_error));
  if (!dst || usage_error) fail("amplify", "--resample-exemplar: GDAL could not warp {} ({})", name, gdal_error());
  const int w = GDALGetRasterXSize(dst.get()), h = GDALGetRasterYSize(dst.get());
  Heightfield out(w, h);
  out.metadata = ex.metadata;
  out.georef = ex.georef;
  GDALGetGeoTransform(dst.get(), out.georef.geotransform.data());
  if (const char* wkt = GDALGetProjectionRef(dst.get()); wkt && *wkt) {
    out.georef.crs_wkt = wkt;
    OGRSpatialReference s;
    if (s.importFromWkt(wkt) == OGRERR_NONE) out.georef.geographic = s.IsGeographic();
  }
  if (GDALRasterIO(GDALGetRasterBand(dst.get(), 1), GF_Read, 0, 0, w, h, out.z.data(), w, h, GDT_Float32, 0, 0) != CE_None)
    fail("amplify", "--resample-exemplar: cannot read the warped {} ({})", name, gdal_error());
  out.georef.update_metric_cell_size(w, h);
  // Cells outside the source (a reprojected exemplar's corners) are filled smoothly; the dictionary
  // drops flat patches, so they add no fake detail.
  if (out.count_nodata() == out.size()) fail("amplify", "--resample-exemplar: nothing of {} is left after the warp", name);
  if (out.count_nodata() > 0) fill_nodata_harmonic(out);
  out.metadata["amplify_exemplar_resampled"] =
      fmt::format("{}: {}x{} at {:.3f} x {:.3f} m -> {}x{} at {:.3f} x {:.3f} m{}", name, ex.width, ex.height,
                  ex.georef.cell_x, ex.georef.cell_y, w, h, out.georef.cell_x, out.georef.cell_y, reproject ? ", reprojected" : "");
  return out;
}

}  // namespace terracl
