// SPDX-License-Identifier: Apache-2.0
// `terracl warp` and `terracl resize`: GDAL's warper with gdalwarp's option names (--tr X Y, not
// the pipeline's JSON arrays), and the engine import scale printed after a resize.
#include "cli.hpp"
#include "stage_flags.hpp"
#include "tile_flags.hpp"

#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/warp.hpp>

#include <fmt/format.h>

namespace terracl::cli {
namespace {

struct WarpArgs {
  std::string input, output;
  std::string t_srs, resampling = "near";
  std::vector<double> tr, projwin;
  std::vector<int> ts;
  bool fill_nodata = false;
  InputScaleFlags in;
  OutputFlags out;
  TileFlags tile;  // --tile: out of core (docs/scale.md, "Tiled warp and resize")
};

// --size's words: "W H" or "WxH", each a whole number of cells >= 1.
std::pair<int, int> parse_size(const std::vector<std::string>& words) {
  std::vector<std::string> v = words;
  if (v.size() == 1) {
    const size_t x = v[0].find_first_of("xX");
    if (x == std::string::npos) throw UsageError("resize", fmt::format("--size {}: expected WIDTH HEIGHT or WIDTHxHEIGHT", v[0]));
    v = {v[0].substr(0, x), v[0].substr(x + 1)};
  }
  int out[2];
  for (int k = 0; k < 2; ++k) {
    size_t used = 0;
    long n = 0;
    try {
      n = std::stol(v[size_t(k)], &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != v[size_t(k)].size() || n < 1 || n > (1L << 30))
      throw UsageError("resize", fmt::format("--size: '{}' is not a size in cells (a whole number >= 1)", v[size_t(k)]));
    out[k] = int(n);
  }
  return {out[0], out[1]};
}

struct ResizeArgs {
  std::string input, output, preset, resampling = "bilinear";
  std::vector<std::string> size;  // WIDTH HEIGHT, or WIDTHxHEIGHT as `render --size` takes it
  bool fill_nodata = false;
  InputScaleFlags in;
  OutputFlags out;
  TileFlags tile;  // --tile: out of core (docs/scale.md, "Tiled warp and resize")
};

void print_engine_scale(const Heightfield& h, const EngineScale& s) {
  if (globals().quiet) return;
  fmt::print("size:            {} x {} cells of {:.4f} x {:.4f} m\n", h.width, h.height, h.georef.cell_x, h.georef.cell_y);
  fmt::print("Unreal import:   Scale X {:.4f}  Scale Y {:.4f}  Scale Z {:.4f}  Location Z {:.2f} cm (16-bit over the data range)\n",
             s.unreal_x_scale, s.unreal_y_scale, s.unreal_z_scale, s.unreal_z_location);
  fmt::print("Unity import:    Terrain Height {:.4f} m  Position Y {:.4f} m\n", s.unity_height, s.unity_position_y);
  if (std::fabs(h.georef.cell_x - h.georef.cell_y) > 1e-3 * h.georef.cell_x)
    fmt::print(stderr, "terracl: warning: {}\n", square_cell_advice(h));
}

// As the stage subcommands: what a tiled run (GDAL windows in, tiled float32 GeoTIFF out) cannot honour.
void refuse_untiled_flags(const std::string& command, bool fill_nodata, const InputScaleFlags& in,
                          const OutputFlags& out) {
  TileFlags::refuse_untiled_flag(command, fill_nodata || in.zmin || in.zmax || in.cell_size,
                                 "--fill-nodata, --zmin, --zmax, --cell-size");
  TileFlags::refuse_untiled_flag(command, out.cog || !out.creation_options.empty() || out.output_type != "Float32",
                                 "--co, --cog, --ot");
}

CommandRegistrar reg(13, [](CLI::App& app) {
  {
    auto a = std::make_shared<WarpArgs>();
    auto* sub = app.add_subcommand("warp", "Reproject / resample a heightfield with GDAL's warper (gdalwarp's options "
                                           "and results; nodata stays nodata)");
    sub->add_option("input", a->input, "Input raster")->required();
    sub->add_option("-o,--output", a->output, "Output raster (.tif .exr .png .r16)")->required();
    sub->add_option("--t-srs", a->t_srs, "Target CRS: EPSG:32619, WKT or PROJ string (default: keep the CRS)");
    sub->add_option("--tr", a->tr, "Target cell size X Y in target CRS units")->expected(2);
    sub->add_option("--ts", a->ts, "Target size WIDTH HEIGHT in cells (0 in one keeps the aspect ratio)")->expected(2);
    sub->add_option("--resampling,-r", a->resampling, "Resampling method")
        ->check(CLI::IsMember(warp_resamplings()))
        ->capture_default_str();
    sub->add_option("--projwin", a->projwin, "Map window ULX ULY LRX LRY in target CRS units")->expected(4);
    sub->add_flag("--fill-nodata", a->fill_nodata, "Fill nodata cells of the input first (harmonic)");
    a->in.add(sub);
    a->out.add(sub);
    a->tile.add(sub);
    sub->callback([a] {
      check_output_paths("warp", {{"input", a->input}}, {{"-o", a->output}});
      WarpOptions o;
      o.t_srs = a->t_srs;
      o.resampling = a->resampling;
      if (!a->tr.empty()) o.tr = std::array<double, 2>{a->tr[0], a->tr[1]};
      if (!a->ts.empty()) o.ts = std::array<int, 2>{a->ts[0], a->ts[1]};
      if (!a->projwin.empty()) o.projwin = std::array<double, 4>{a->projwin[0], a->projwin[1], a->projwin[2], a->projwin[3]};
      if (a->tile.tiled()) {
        refuse_untiled_flags("warp", a->fill_nodata, a->in, a->out);
        json st{{"resampling", o.resampling}};
        if (!o.t_srs.empty()) st["t_srs"] = o.t_srs;
        if (o.tr) st["tr"] = *o.tr;
        if (o.ts) st["ts"] = *o.ts;
        if (o.projwin) st["projwin"] = *o.projwin;
        a->tile.run_stage("warp", a->input, "warp", st, a->output);
        return;
      }
      (void)a->tile.options("warp");  // --halo alone
      Heightfield h = read_heightfield(a->input, a->in.read_options(a->fill_nodata));
      Heightfield r = warp(h, o, make_progress("warp"));
      finish_progress();
      for (const auto& [k, v] : provenance()) r.metadata[k] = v;
      write_heightfield(r, a->output, a->out.write_options_keeping_type(a->input, a->output));
    });
  }
  {
    auto a = std::make_shared<ResizeArgs>();
    auto* sub = app.add_subcommand("resize", "Resize to a size or an engine preset over the same extent (GDAL's "
                                             "warper) and print the engine import scale");
    sub->add_option("input", a->input, "Input raster")->required();
    sub->add_option("-o,--output", a->output, "Output raster (.r16 .png for engines; .tif .exr)")->required();
    std::vector<std::string> presets;
    for (const auto& [n, s] : engine_presets()) presets.push_back(n);
    auto* preset = sub->add_option("--preset", a->preset, "Engine size (square)")->check(CLI::IsMember(presets));
    auto* size = sub->add_option("--size", a->size, "Target size in cells: WIDTH HEIGHT (as gdalwarp -ts) or WIDTHxHEIGHT")
                     ->expected(1, 2);
    preset->excludes(size);
    sub->add_option("--resampling,-r", a->resampling, "Resampling method")
        ->check(CLI::IsMember(warp_resamplings()))
        ->capture_default_str();
    sub->add_flag("--fill-nodata", a->fill_nodata, "Fill nodata cells of the input first (harmonic)");
    a->in.add(sub);
    a->out.add(sub);
    a->tile.add(sub);
    sub->callback([a] {
      if (a->preset.empty() && a->size.empty()) throw UsageError("resize", "needs --preset NAME or --size WIDTH HEIGHT");
      check_output_paths("resize", {{"input", a->input}}, {{"-o", a->output}});
      const auto [sw, sh] = a->preset.empty() ? parse_size(a->size) : std::pair<int, int>{0, 0};
      const int w = a->preset.empty() ? sw : engine_preset_size(a->preset);
      const int ht = a->preset.empty() ? sh : w;
      if (a->tile.tiled()) {  // the engine scale is in the output's metadata (engine_*)
        refuse_untiled_flags("resize", a->fill_nodata, a->in, a->out);
        a->tile.run_stage("resize", a->input, "resize", json{{"width", w}, {"height", ht}, {"resampling", a->resampling}},
                          a->output);
        return;
      }
      (void)a->tile.options("resize");  // --halo alone
      Heightfield h = read_heightfield(a->input, a->in.read_options(a->fill_nodata));
      Heightfield r = resize(h, w, ht, a->resampling, make_progress("resize"));
      finish_progress();
      const EngineScale s = record_engine_scale(r);
      for (const auto& [k, v] : provenance()) r.metadata[k] = v;
      write_heightfield(r, a->output, a->out.write_options_keeping_type(a->input, a->output));
      print_engine_scale(r, s);
    });
  }
});

}  // namespace
}  // namespace terracl::cli
