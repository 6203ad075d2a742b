// SPDX-License-Identifier: Apache-2.0
// Tiled `warp` and `resize` (docs/scale.md, "Tiled warp"): the output grid is GDAL's for the whole
// input (the warped VRT of the level before the stage, as the untiled warp builds it), and the
// output is read from that VRT window by window into a tiled GeoTIFF. The VRT warps each of its
// blocks on its own, from the source window the block's footprint needs (kernel radius included),
// so every cell equals the untiled warp's bit for bit, whatever the tile size; only GDAL's block
// cache and one tile are held.
#include "tile/warp_tiles.hpp"

#include <fmt/format.h>
#include <gdal_priv.h>

#include <algorithm>
#include <cmath>
#include <terracl/error.hpp>

#include "io/gdal_window.hpp"
#include "io/io_common.hpp"
#include "io/warp_vrt.hpp"

namespace terracl::tile {
namespace {

template <typename T, size_t N>
std::optional<std::array<T, N>> array_option(const PipelineStage& st, const char* key) {
  const json& o = st.options;
  if (!o.contains(key) || o.at(key).is_null()) return std::nullopt;
  const json& v = o.at(key);
  auto bad = [&]() {
    fail(st.tag, "option '{}' (pipeline stage {}) must be an array of {} {}", key, st.where, N,
         std::is_integral_v<T> ? "integers" : "numbers");
  };
  if (!v.is_array() || v.size() != N) bad();
  std::array<T, N> a{};
  for (size_t i = 0; i < N; ++i) {
    if (!v[i].is_number() || (std::is_integral_v<T> && !v[i].is_number_integer())) bad();
    a[i] = v[i].get<T>();
  }
  return a;
}

bool has(const json& o, const char* k) { return o.contains(k) && !o.at(k).is_null(); }

}  // namespace

bool is_warp_stage(const PipelineStage& st) { return st.type == "warp" || st.type == "resize"; }

WarpOptions warp_options_of(const PipelineStage& st) {
  const json& o = st.options;
  WarpOptions w;
  w.resampling = o.at("resampling").get<std::string>();
  if (st.type == "resize") {
    int width = 0, height = 0;
    if (has(o, "preset")) {
      if (has(o, "width") || has(o, "height")) fail(st.tag, "give a preset or width/height, not both");
      width = height = engine_preset_size(o.at("preset").get<std::string>(), st.tag);
    } else {
      if (!has(o, "width") || !has(o, "height")) fail(st.tag, "give a preset, or both width and height");
      width = o.at("width").get<int>();
      height = o.at("height").get<int>();
    }
    if (width < 2 || height < 2 || width > 65536 || height > 65536)
      fail(st.tag, "size {} x {} is out of range; width and height must be in 2..65536", width, height);
    w.ts = std::array<int, 2>{width, height};
    return w;
  }
  if (has(o, "t_srs")) w.t_srs = o.at("t_srs").get<std::string>();
  w.tr = array_option<double, 2>(st, "tr");
  w.ts = array_option<int, 2>(st, "ts");
  w.projwin = array_option<double, 4>(st, "projwin");
  return w;
}

Heightfield warp_tiles(const PipelineStage& st, const std::string& in_path, const Georef& in_georef,
                       const std::string& out_path, int T, const Metadata& metadata, bool write,
                       const Progress& progress) {
  io::init_gdal();
  const WarpOptions o = warp_options_of(st);
  io::check_warp_options(o, st.tag);
  if (!in_georef.has_geotransform)
    fail(st.tag,
         "a tiled warp needs a georeferenced raster (this one has no geotransform: its local grid is warped "
         "whole); run it untiled");
  if (!o.t_srs.empty() && in_georef.crs_wkt.empty())
    fail(st.tag, "--t-srs needs an input with a CRS; this raster has none");
  CPLErrorReset();
  io::DatasetPtr in(static_cast<GDALDataset*>(
      GDALOpenEx(in_path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY, nullptr, nullptr, nullptr)));
  if (!in) fail(st.tag, "{}: cannot reopen the warp's input ({})", in_path, io::last_gdal_error());
  // The tile writer stored NaN cells as the level's nodata, or declared NaN the nodata when the
  // level had none: a nodata value exactly when the untiled warp's input has missing cells.
  int has_nodata = FALSE;
  in->GetRasterBand(1)->GetNoDataValue(&has_nodata);
  Heightfield header;
  {
    io::DatasetPtr vrt = io::warped_vrt(GDALDataset::ToHandle(in.get()), o, has_nodata != FALSE, st.tag, false);
    header.width = vrt->GetRasterXSize();
    header.height = vrt->GetRasterYSize();
    io::read_gdal_header(*vrt, header);
    const Georef vrt_georef = header.georef;  // its nodata: what the warper wrote outside the source
    Heightfield in_header;
    in_header.georef = in_georef;
    io::finish_warp_georef(header, in_header, o);
    header.metadata = metadata;
    if (!write) return header;

    io::GeoTiffWindowWriter out(out_path, header.width, header.height, header.georef, metadata);
    GDALRasterBand* band = vrt->GetRasterBand(1);
    double lo = INFINITY, hi = -INFINITY;
    size_t nodata = 0;
    const int tx = (header.width + T - 1) / T, ty = (header.height + T - 1) / T;
    for (int j = 0; j < ty; ++j)
      for (int i = 0; i < tx; ++i) {
        const int x0 = i * T, y0 = j * T, w = std::min(T, header.width - x0), h = std::min(T, header.height - y0);
        Heightfield tile(w, h);
        tile.georef = vrt_georef;
        CPLErrorReset();
        if (band->RasterIO(GF_Read, x0, y0, w, h, tile.z.data(), w, h, GDT_Float32, 0, 0) != CE_None ||
            CPLGetLastErrorType() >= CE_Failure)
          fail(st.tag, "GDAL's warp failed at output window {},{} {} x {} ({})", x0, y0, w, h, io::last_gdal_error());
        io::convert_nodata(tile);
        for (float v : tile.z)
          if (std::isfinite(v))
            lo = std::min<double>(lo, v), hi = std::max<double>(hi, v);
          else
            ++nodata;
        out.write(x0, y0, tile, 0, 0, w, h);
        const size_t done = size_t(j) * tx + i + 1;
        if (progress && !progress(double(done) / (double(tx) * ty), fmt::format("warp tile {}/{}", done, tx * ty)))
          throw Cancelled(st.tag, "cancelled");
      }
    if (nodata == size_t(header.width) * header.height)
      fail(st.tag, "every output cell is nodata: the window or CRS does not overlap the input");
    if (st.type == "resize") {  // as record_engine_scale on the untiled output
      if (lo > hi) lo = hi = 0.0;
      const EngineScale s = engine_scale(lo, hi, nodata > 0, header.georef.cell_x, header.georef.cell_y);
      for (const auto& [k, v] : engine_scale_entries(s)) {
        const std::string value = fmt::format("{:.6f}", v);
        header.metadata["engine:" + k] = value;
        out.set_metadata_item("engine:" + k, value);
      }
    }
    out.commit();
  }  // the VRT goes before the input it reads
  return header;
}

}  // namespace terracl::tile
