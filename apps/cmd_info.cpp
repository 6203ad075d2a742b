// SPDX-License-Identifier: Apache-2.0
#include "cli.hpp"
#include "stage_flags.hpp"

#include <terracl/analysis.hpp>
#include <terracl/io.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

namespace terracl::cli {
namespace {

std::string crs_name(const std::string& wkt) {
  auto a = wkt.find('"');
  if (a == std::string::npos) return wkt.empty() ? "none" : wkt.substr(0, 40);
  auto b = wkt.find('"', a + 1);
  return wkt.substr(a + 1, b - a - 1);
}

struct InfoArgs {
  std::string input;
  bool json = false;
  InputScaleFlags in;
};

CommandRegistrar reg(11, [](CLI::App& app) {
  auto args = std::make_shared<InfoArgs>();
  auto* sub = app.add_subcommand("info", "Size, georeferencing, elevation and slope statistics of a raster");
  sub->add_option("input", args->input, "Raster file")->required();
  sub->add_flag("--json", args->json, "Print JSON");
  args->in.add(sub);
  sub->callback([args] {
    const Heightfield h = read_heightfield(args->input, args->in.read_options());
    HeightStats s = compute_stats(h);
    // The slope of `metrics` and gdaldem (Horn's 3x3 weighted differences), so both commands report
    // the same figures; compute_stats' 4-neighbour differences gave a steeper maximum.
    double slope_sum = 0, slope_max = 0;
    size_t slope_n = 0;
    for (float v : analysis::slope_degrees(h))
      if (std::isfinite(v)) slope_sum += v, slope_max = std::max<double>(slope_max, v), ++slope_n;
    s.mean_slope_deg = slope_n ? slope_sum / double(slope_n) : 0.0;
    s.max_slope_deg = slope_max;
    const Georef& g = h.georef;
    if (args->json) {
      nlohmann::json j = {{"file", args->input},       {"width", h.width},      {"height", h.height},
                          {"format", format_name(format_from_extension(args->input))},
                          {"crs", crs_name(g.crs_wkt)}, {"geographic", g.geographic},
                          {"cell_x_m", g.cell_x},       {"cell_y_m", g.cell_y}, {"min", s.min},
                          {"max", s.max},               {"mean", s.mean},       {"nodata", s.nodata},
                          {"mean_slope_deg", s.mean_slope_deg}, {"max_slope_deg", s.max_slope_deg}};
      if (g.has_geotransform) j["geotransform"] = g.geotransform;
      if (g.nodata) j["nodata_value"] = *g.nodata;
      j["vertical_units"] = g.vertical_units;
      if (auto it = h.metadata.find("terracl:source_vertical_units"); it != h.metadata.end())
        j["source_vertical_units"] = it->second;  // converted to metres on read
      fmt::print("{}\n", j.dump(2));
      return;
    }
    fmt::print("file:          {}\n", args->input);
    fmt::print("format:        {}\n", format_name(format_from_extension(args->input)));
    fmt::print("size:          {} x {}\n", h.width, h.height);
    if (g.has_geotransform) {
      fmt::print("origin:        ({:.10g}, {:.10g})\n", g.geotransform[0], g.geotransform[3]);
      fmt::print("pixel size:    ({:.10g}, {:.10g})\n", g.geotransform[1], g.geotransform[5]);
    } else {
      fmt::print("origin:        none (not georeferenced)\n");
    }
    fmt::print("crs:           {}{}\n", crs_name(g.crs_wkt), g.geographic ? " (geographic)" : "");
    fmt::print("cell size:     {:.3f} m x {:.3f} m{}\n", g.cell_x, g.cell_y, g.geographic ? " (at centre latitude)" : "");
    fmt::print("elevation:     min {:.2f}  max {:.2f}  mean {:.2f} {}\n", s.min, s.max, s.mean, g.vertical_units);
    fmt::print("nodata:        {} cell{}{}\n", s.nodata, s.nodata == 1 ? "" : "s",
               g.nodata ? fmt::format(" (value {})", *g.nodata) : "");
    fmt::print("slope:         mean {:.2f} deg  steepest {:.2f} deg (Horn 3x3, as metrics and gdaldem)\n",
               s.mean_slope_deg, s.max_slope_deg);
    for (const auto& [k, v] : h.metadata) fmt::print("{}: {}\n", k, v);
  });
});

}  // namespace
}  // namespace terracl::cli
