// SPDX-License-Identifier: Apache-2.0
// The stage table's tiling column (terracl/tile.hpp): how each stage runs in a tiled pipeline.
// Kept in one table beside the tile engine so that a stage's footprint and the engine that
// honours it are read together; a stage added to the registry is untileable until it is listed
// here with its footprint (and a test that its tiled output equals the untiled one).
#include <fmt/format.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/render.hpp>
#include <terracl/tile.hpp>

#include "pipeline/builtin.hpp"
#include "tile/amplify_tiles.hpp"
#include "tile/extract_tiles.hpp"
#include "tile/tile_sinks.hpp"

namespace terracl {
namespace {

StageTiling refuse(std::string why) {
  StageTiling t;
  t.limit = std::move(why);
  return t;
}
StageTiling kind(TileKind k, int halo = 0, int down = 1) {
  StageTiling t;
  t.kind = k, t.halo = halo, t.down = down;
  return t;
}

std::string extension(const std::string& f) {
  const std::string e = std::filesystem::path(f).extension().string();
  return e.empty() ? "(no extension)" : e;
}

}  // namespace

namespace tile {
std::string render_tiling_limit(const json& o) {
  if (render::mode_from_name(o.at("mode").get<std::string>()) == render::Mode::Perspective)
    return "a perspective picture is one view of the whole terrain (any ray may cross every tile); run it untiled";
  const std::string file = o.at("file").get<std::string>();
  if (format_from_extension(file) != FileFormat::GeoTIFF)
    return fmt::format(
        "tiled runs draw pictures into a tiled GeoTIFF window by window; {} is written whole: use a .tif name",
        file);
  const render::Mode m = render::mode_from_name(o.at("mode").get<std::string>());
  if (m == render::Mode::Relief || m == render::Mode::ShadedRelief) {
    const render::ColorRamp ramp = o.contains("ramp") && !o.at("ramp").is_null()
                                       ? render::ColorRamp::from_spec(o.at("ramp").get<std::string>())
                                       : render::ColorRamp::default_ramp();
    for (const auto& e : ramp.entries)
      if (e.percent)
        return "its colour ramp is given in percentages of the whole raster's data range, which one tile does not "
               "know; use a ramp in metres (hypsometric or a gdaldem colour file without %)";
  }
  return "";
}

}  // namespace tile

StageTiling tiling_of(const PipelineStage& st) {
  const json& o = st.options;
  const std::string& t = st.type;
  if (t == "read") {
    const std::string f = o.at("filename").get<std::string>();
    const FileFormat ff = format_from_extension(f);
    if (o.value("fill_nodata", false))
      return refuse(
          "fill_nodata is a global (harmonic) solve over the whole raster; fill nodata in an untiled run first");
    if (ff == FileFormat::GeoTIFF && path_exists(f) && is_gradient_file(f))
      return refuse("it reads a gradient field, which only reconstruct and edit take (they are not tiled); run it untiled");
    if (ff == FileFormat::GeoTIFF || ff == FileFormat::HGT || ff == FileFormat::AsciiGrid ||
        ff == FileFormat::GDALOther)
      return kind(TileKind::Source);
    return refuse(
        fmt::format("tiled runs read GDAL rasters window by window (.tif .hgt .asc .vrt ...); {} files are "
                    "read whole",
                    extension(f)));
  }
  if (t == "write") {
    const std::string f = o.at("filename").get<std::string>();
    if (format_from_extension(f) == FileFormat::GeoTIFF) return kind(TileKind::Sink);
    return refuse(
        fmt::format("tiled runs write tiled GeoTIFF (.tif) window by window; {} needs the whole raster in "
                    "memory",
                    extension(f)));
  }
  if (t == "crop") return kind(TileKind::Window);
  if (t == "downsample") return kind(TileKind::Local, 0, o.at("factor").get<int>());
  if (t == "fill_depressions") {
    if (o.value("epsilon", false))
      return refuse(
          "epsilon filling raises flats in the order of one global flood, which tiles cannot reproduce "
          "exactly; run it tiled without epsilon, or untiled");
    return kind(TileKind::Global);
  }
  if (t == "reconstruct" || t == "edit")
    return refuse(
        "a Poisson solve couples every cell: the whole raster must fit on one device (its largest "
        "allocation); run it untiled (a distributed solver is not available yet)");
  if (t == "fill_nodata") return refuse("harmonic interpolation of nodata is a global solve; run it untiled");
  if (t == "amplify") return tile::amplify_tiling(o);
  if (t == "extract") return tile::extract_tiling(o);  // to a 2-band gradient GeoTIFF (extract_tiles.cpp)
  if (t == "render") {
    // gdaldem's 3x3 window: a halo of one cell; written by its own sink (tile/render_tiles.cpp).
    const std::string why = tile::render_tiling_limit(o);
    return why.empty() ? kind(TileKind::Sink, 1) : refuse(why);
  }
  if (t == "mesh")
    return refuse(
        "it writes one mesh of the whole raster; run it untiled on the tiled GeoTIFF output or a window of it");
  if (t == "erode") {
    for (const char* k : {"water", "sediment", "delta", "deposit_thickness"})
      if (o.contains(k) && !o.at(k).is_null())
        return refuse(fmt::format("its {} output is written whole by the stage; write it from an untiled run", k));
    for (const char* k : {"region", "keep_constraints"})
      if (o.contains(k) && !o.at(k).is_null())
        return refuse(fmt::format("its {} is laid over the whole raster, not a tile; run it untiled", k));
    // Not exact: a halo as far as water can travel in the run (docs/scale.md, "Erosion").
    StageTiling tl = kind(TileKind::Local, 1);
    tl.halo_of = [o](const Georef& g) { return erode_tile_halo(o, g); };
    return tl;
  }
  if (t == "drainage") {
    if (o.value("method", std::string("d8")) == "dinf")
      return refuse(
          "D-infinity splits each cell's flow between two receivers in fractional shares summed in double, "
          "so the result depends on the order of the sums, which tiles cannot reproduce; use method d8 "
          "(exact tiled) or run it untiled");
    return kind(TileKind::Global);  // exact tiled D8 (Barnes 2017) on a surface that drains
  }
  if (t == "breach")
    return refuse(
        "a cell's breach path follows the back-links of one global priority flood (first reached, ties "
        "by raster index) and each cut lowers cells that later comparisons see, so tiles cannot reproduce "
        "it; run it untiled (docs/scale.md says what a tiled form needs)");
  if (t == "warp" || t == "resize") return kind(TileKind::Global);  // GDAL's warped VRT, window by window (warp_tiles.cpp)
  if (t == "metrics") return kind(TileKind::Sink, 1);  // local statistics, exact; global figures left out (metrics_tiles.cpp)
  if (t == "sketch")
    return refuse(
        "its river and ridge thresholds are fractions of the whole raster's cells on a D8 accumulation of the "
        "whole raster, and its polylines are traced across it; run it untiled");
  return refuse("it needs the whole raster (no tiled form)");
}

uint64_t parse_memory_size(const std::string& text, const std::string& what) {
  const char* s = text.c_str();
  char* end = nullptr;
  const double v = std::strtod(s, &end);
  std::string unit = end ? std::string(end) : "";
  while (!unit.empty() && unit.front() == ' ') unit.erase(0, 1);
  double scale = 0;
  if (unit.empty() || unit == "B")
    scale = 1;
  else if (unit == "K" || unit == "KB" || unit == "KiB")
    scale = 1024.0;
  else if (unit == "M" || unit == "MB" || unit == "MiB")
    scale = 1024.0 * 1024;
  else if (unit == "G" || unit == "GB" || unit == "GiB")
    scale = 1024.0 * 1024 * 1024;
  else if (unit == "T" || unit == "TB" || unit == "TiB")
    scale = 1024.0 * 1024 * 1024 * 1024;
  if (end == s || scale == 0 || !(v > 0) || !std::isfinite(v) || v * scale > 1e18)
    throw UsageError("run",
                     fmt::format("{}: '{}' is not a memory size (e.g. 512M, 2G, 1.5GiB, 300000000)", what, text));
  return uint64_t(v * scale);
}

}  // namespace terracl
