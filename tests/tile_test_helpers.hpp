// SPDX-License-Identifier: Apache-2.0
// Shared by the tiled-pipeline tests: SRTM windows as inputs, pipelines run untiled and tiled, and
// one comparison of two rasters (cells as stored, georeferencing, the metadata items each test names).
#pragma once

#include <gdal.h>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <nlohmann/json.hpp>
#include <optional>
#include <random>
#include <string>
#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/pipeline.hpp>
#include <terracl/tile.hpp>
#include <vector>

#include "test_helpers.hpp"

namespace terracl::test {

/// A raster held in memory behind the tiled algorithms' read and write callbacks: windows of `src`
/// in, cores into `out`, each cell's writes counted (every cell must be written exactly once).
struct MemoryTiles {
  explicit MemoryTiles(const Heightfield& source)
      : src(source), out(source.width, source.height, -12345.f), written(source.size(), 0) {}
  Heightfield read(int x, int y, int w, int ht) const {
    Heightfield win(w, ht);
    win.georef = src.georef;
    for (int r = 0; r < ht; ++r)
      for (int c = 0; c < w; ++c) win.at(c, r) = src.at(x + c, y + r);
    return win;
  }
  void write(int x, int y, const Heightfield& core) {
    for (int r = 0; r < core.height; ++r)
      for (int c = 0; c < core.width; ++c) {
        out.at(x + c, y + r) = core.at(c, r);
        written[size_t(y + r) * src.width + x + c]++;
      }
  }
  void expect_each_cell_written_once() const {
    for (size_t i = 0; i < written.size(); ++i) EXPECT_EQ(written[i], 1) << "cell " << i;
  }
  const Heightfield& src;
  Heightfield out;
  std::vector<int> written;
};

/// Rough terrain with pits and flats at every scale: smooth relief plus white noise, rounded to
/// integer metres (many exact ties), with a `nodata_fraction` of random cells NaN.
inline Heightfield pitted_terrain(int w, int h, unsigned seed, double nodata_fraction = 0) {
  Heightfield t = smooth_terrain(w, h, 30.0, 300.0, seed);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> noise(-8.f, 8.f), u(0.f, 1.f);
  for (float& v : t.z) v = std::round(v + noise(rng));
  for (size_t i = 0; i < t.size(); ++i)
    if (u(rng) < nodata_fraction) t.z[i] = NAN;
  return t;
}

/// Runs `p` tiled (tiles of `tile` cells) expecting it to throw an E; returns the message (a
/// failure is added when it runs through).
template <typename E = Error>
std::string tiled_run_error(const Pipeline& p, int tile = 32) {
  RunReport r;
  TileOptions to;
  to.tile = tile;
  try {
    run_tiled(p, to, RunOptions{}, r);
  } catch (const E& e) {
    return e.what();
  }
  ADD_FAILURE() << p.source() << " ran tiled";
  return {};
}

/// The bundled SRTM tile N44W072 (geographic), read once.
inline const Heightfield& srtm_tile() {
  static const Heightfield dem = read_heightfield(data_path("dem/N44W072.hgt"));
  return dem;
}

/// Nodata in an SRTM window: the rectangle [x0, x1) x [y0, y1) (clipped to the window) and `voids`
/// random cells drawn with `seed`; the window's nodata value becomes -32768.
struct Holes {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  int voids = 0;
  unsigned seed = 0;
};

/// The w x h window at (x0, y0) of the SRTM tile, with its own geotransform and metric cell size
/// (a geographic raster's depends on the window's centre latitude).
inline Heightfield srtm_crop(int w, int h, int x0 = 300, int y0 = 200, const std::optional<Holes>& holes = {}) {
  const Heightfield& dem = srtm_tile();
  Heightfield t(w, h);
  t.georef = dem.georef;
  auto& gt = t.georef.geotransform;
  gt[0] += x0 * gt[1];
  gt[3] += y0 * gt[5];
  t.georef.update_metric_cell_size(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) t.at(x, y) = dem.at(x0 + x, y0 + y);
  if (holes) {
    t.georef.nodata = -32768;
    for (int y = holes->y0; y < std::min(h, holes->y1); ++y)
      for (int x = holes->x0; x < std::min(w, holes->x1); ++x) t.at(x, y) = NAN;
    std::mt19937 rng(holes->seed);
    for (int k = 0; k < holes->voids; ++k) t.at(int(rng() % w), int(rng() % h)) = NAN;
  }
  return t;
}

/// srtm_crop written as the GeoTIFF dir/name; returns its path.
inline std::string srtm_window(const TempDir& dir, const std::string& name, int w, int h, int x0 = 300, int y0 = 200,
                               const std::optional<Holes>& holes = {}) {
  const std::string f = dir.path(name);
  write_heightfield(srtm_crop(w, h, x0, y0, holes), f);
  return f;
}

/// Runs the pipeline `doc` (JSON text), tiled when `tiled` is given.
inline void run_pipeline(const std::string& doc, const TileOptions* tiled, const std::string& name = "tiles") {
  Pipeline p = Pipeline::parse(nlohmann::json::parse(doc), name, name + ".json");
  p.validate();
  RunOptions ro;
  ro.device = []() -> Device& { return device(); };
  ro.write_resolved = false;
  RunReport r;
  if (tiled)
    run_tiled(p, *tiled, ro, r);
  else
    p.run(ro, r);
}

/// Runs `doc` (with OUT in file names replaced by the folder) untiled into dir/u and tiled into dir/t.
inline void run_untiled_and_tiled(const TempDir& dir, const std::string& doc, const TileOptions& to) {
  for (const char* which : {"u", "t"}) {
    std::string text = doc;
    const std::string out = dir.path(which);
    for (size_t p; (p = text.find("OUT")) != std::string::npos;) text.replace(p, 3, out);
    run_pipeline(text, which[0] == 'u' ? nullptr : &to);
  }
}

/// What expect_same_raster compares besides every band's stored bytes, the size, band types and
/// descriptions, nodata values, geotransform and CRS (all always compared).
struct SameRaster {
  /// The provenance: terracl_stages equal, terracl_pipeline_hash in both (the hashes differ: the
  /// two runs write to different folders).
  bool provenance = true;
  /// GDAL metadata items that must be present in the untiled file and equal in the tiled one
  /// (the metric cell size the writer stored, read_heightfield consumes it).
  std::vector<std::string> items = {"terracl_cell_x", "terracl_cell_y"};
  /// Items compared when present in either (equal, or missing in both).
  std::vector<std::string> optional_items;
};

/// A metadata item as GDAL stores it ("(missing)" when absent).
inline std::string metadata_item(const std::string& file, const std::string& key) {
  GDALAllRegister();
  GDALDatasetH ds = GDALOpen(file.c_str(), GA_ReadOnly);
  if (!ds) return "(unreadable)";
  const char* v = GDALGetMetadataItem(ds, key.c_str(), nullptr);
  std::string s = v ? v : "(missing)";
  GDALClose(ds);
  return s;
}

/// Every band's bytes and the header of a raster, read through GDAL.
struct StoredRaster {
  int w = 0, h = 0;
  std::vector<GDALDataType> types;
  std::vector<std::string> descriptions;
  std::vector<std::optional<double>> nodata;
  std::vector<std::vector<uint8_t>> bands;
  std::array<double, 6> gt{};
  bool has_gt = false;
  std::string crs;
};

inline StoredRaster load_stored(const std::string& f) {
  StoredRaster r;
  GDALAllRegister();
  GDALDatasetH ds = GDALOpen(f.c_str(), GA_ReadOnly);
  if (!ds) {
    ADD_FAILURE() << "cannot open " << f;
    return r;
  }
  r.w = GDALGetRasterXSize(ds);
  r.h = GDALGetRasterYSize(ds);
  r.has_gt = GDALGetGeoTransform(ds, r.gt.data()) == CE_None;
  r.crs = GDALGetProjectionRef(ds);
  for (int b = 1; b <= GDALGetRasterCount(ds); ++b) {
    GDALRasterBandH band = GDALGetRasterBand(ds, b);
    const GDALDataType type = GDALGetRasterDataType(band);
    r.types.push_back(type);
    r.descriptions.push_back(GDALGetDescription(band));
    int has = 0;
    const double nd = GDALGetRasterNoDataValue(band, &has);
    r.nodata.push_back(has ? std::optional<double>(nd) : std::nullopt);
    std::vector<uint8_t> buf(size_t(r.w) * r.h * GDALGetDataTypeSizeBytes(type));
    EXPECT_EQ(GDALRasterIO(band, GF_Read, 0, 0, r.w, r.h, buf.data(), r.w, r.h, type, 0, 0), CE_None) << f;
    r.bands.push_back(std::move(buf));
  }
  GDALClose(ds);
  return r;
}

/// The tiled output `tiled` stores what the untiled `untiled` does: bytes of every band (cells bit
/// for bit, nodata substituted alike), header, and the metadata `what` names.
inline void expect_same_raster(const std::string& untiled, const std::string& tiled, const SameRaster& what = {}) {
  SCOPED_TRACE(tiled);
  const StoredRaster a = load_stored(untiled), b = load_stored(tiled);
  ASSERT_EQ(a.w, b.w);
  ASSERT_EQ(a.h, b.h);
  ASSERT_EQ(a.bands.size(), b.bands.size());
  EXPECT_EQ(a.types, b.types);
  EXPECT_EQ(a.descriptions, b.descriptions);
  EXPECT_EQ(a.has_gt, b.has_gt);
  EXPECT_EQ(a.gt, b.gt);
  EXPECT_EQ(a.crs, b.crs);
  for (size_t k = 0; k < a.bands.size(); ++k) {
    EXPECT_EQ(a.nodata[k].has_value(), b.nodata[k].has_value()) << "band " << k + 1;
    if (a.nodata[k] && b.nodata[k] && !(std::isnan(*a.nodata[k]) && std::isnan(*b.nodata[k])))
      EXPECT_EQ(*a.nodata[k], *b.nodata[k]) << "band " << k + 1;
    size_t diff = 0;
    for (size_t i = 0; i < a.bands[k].size(); ++i) diff += a.bands[k][i] != b.bands[k][i];
    EXPECT_EQ(diff, 0u) << "bytes differ in band " << k + 1;
  }
  for (const auto& k : what.items) {
    EXPECT_NE(metadata_item(untiled, k), "(missing)") << k;
    EXPECT_EQ(metadata_item(untiled, k), metadata_item(tiled, k)) << k;
  }
  for (const auto& k : what.optional_items) EXPECT_EQ(metadata_item(untiled, k), metadata_item(tiled, k)) << k;
  if (what.provenance) {
    EXPECT_NE(metadata_item(untiled, "terracl_stages"), "(missing)");
    EXPECT_EQ(metadata_item(untiled, "terracl_stages"), metadata_item(tiled, "terracl_stages"));
    EXPECT_NE(metadata_item(tiled, "terracl_pipeline_hash"), "(missing)");
  }
}

}  // namespace terracl::test
