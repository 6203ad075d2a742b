// SPDX-License-Identifier: Apache-2.0
// `warp` and `resize` stages: GDAL's warper (host/src/io/warp.cpp) in pipelines. On the command
// line `terracl warp` / `terracl resize` (apps/cmd_warp.cpp) take gdalwarp's spelling
// (--tr X Y) and print the engine scale, so the stage table marks them cli = false.
#include <terracl/error.hpp>
#include <terracl/warp.hpp>

#include <fmt/format.h>

#include "pipeline/builtin.hpp"

namespace terracl {
namespace {

template <typename T, size_t N>
std::optional<std::array<T, N>> json_array(const StageContext& c, const std::string& name) {
  if (!c.has(name)) return std::nullopt;
  const json& v = c.options.at(name);
  auto bad = [&] { fail(c.tag, "{}: expected an array of {} numbers, got {}", name, N, v.dump()); };
  if (!v.is_array() || v.size() != N) bad();
  std::array<T, N> a{};
  for (size_t i = 0; i < N; ++i) {
    if (!v[i].is_number() || (std::is_integral_v<T> && !v[i].is_number_integer())) bad();
    a[i] = v[i].get<T>();
  }
  return a;
}

WarpOptions warp_options(const StageContext& c) {
  WarpOptions o;
  if (c.has("t_srs")) o.t_srs = c.get<std::string>("t_srs");
  o.tr = json_array<double, 2>(c, "tr");
  o.ts = json_array<int, 2>(c, "ts");
  o.projwin = json_array<double, 4>(c, "projwin");
  o.resampling = c.get<std::string>("resampling");
  return o;
}

std::vector<std::string> preset_names() {
  std::vector<std::string> n;
  for (const auto& [name, size] : engine_presets()) n.push_back(name);
  return n;
}

}  // namespace

void register_warp_stages(StageRegistry& r) {
  StageInfo warp_stage{
      "warp",
      "Reproject / resample with GDAL's warper (gdalwarp's options and results); nodata stays nodata and cells "
      "outside the input become nodata.",
      DataKind::Heightfield,
      DataKind::Heightfield,
      {{"t_srs", OptionType::String, nullptr, "", "Target CRS (EPSG:32619, WKT, PROJ; default: keep)"},
       {"tr", OptionType::Json, nullptr, "", "Target cell size [xres, yres] in target CRS units"},
       {"ts", OptionType::Json, nullptr, "", "Target size [width, height] in cells (excludes tr)"},
       {"resampling", OptionType::Enum, "near", "", "Resampling method (gdalwarp -r)", warp_resamplings()},
       {"projwin", OptionType::Json, nullptr, "", "Map window [ulx, uly, lrx, lry] in target CRS units"}},
      [](StageContext& c) { c.height() = warp(c.height(), warp_options(c), c.progress, c.tag); },
      false};
  r.add(std::move(warp_stage));

  StageInfo resize_stage{
      "resize",
      "Resize to width x height cells or an engine preset (unreal-1009, unity-1025, ...) over the same extent, "
      "through GDAL's warper; records the engine Z scale in the metadata.",
      DataKind::Heightfield,
      DataKind::Heightfield,
      {{"preset", OptionType::Enum, nullptr, "", "Engine size (square)", preset_names()},
       OptionSpec{"width", OptionType::Int, nullptr, "cells", "Target width (with height; excludes preset)"}.range(2, 65536),
       OptionSpec{"height", OptionType::Int, nullptr, "cells", "Target height (with width; excludes preset)"}.range(2, 65536),
       {"resampling", OptionType::Enum, "bilinear", "", "Resampling method (gdalwarp -r)", warp_resamplings()}},
      [](StageContext& c) {
        int w = 0, h = 0;
        if (c.has("preset")) {
          if (c.has("width") || c.has("height")) fail(c.tag, "give a preset or width/height, not both");
          w = h = engine_preset_size(c.get<std::string>("preset"), c.tag);
        } else {
          if (!c.has("width") || !c.has("height")) fail(c.tag, "give a preset, or both width and height");
          w = c.get<int>("width");
          h = c.get<int>("height");
        }
        Heightfield& hf = c.height();
        hf = resize(hf, w, h, c.get<std::string>("resampling"), c.progress, c.tag);
        record_engine_scale(hf);
      },
      false};
  r.add(std::move(resize_stage));
}

}  // namespace terracl
