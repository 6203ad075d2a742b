// SPDX-License-Identifier: Apache-2.0
// `terracl metrics|sketch|render|mesh IN ...`: the analysis stages write files of their own (a
// report, a picture, a mesh), so `-o` names that file instead of an output heightfield. The
// options come from the stage table, so the CLI and pipelines accept the same names.
#include <fmt/format.h>

#include <cstdlib>
#include <future>
#include <map>
#include <terracl/analysis.hpp>
#include <terracl/distributed.hpp>
#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/stage.hpp>
#include <terracl/stage_memory.hpp>

#include "cli.hpp"
#include "stage_flags.hpp"
#include "tile_flags.hpp"

namespace terracl::cli {
namespace {

struct Args {
  std::string input;
  bool fill_nodata = false;
  StageFlags flags;
  InputScaleFlags in;
  TileFlags tile;  // render: --tile (docs/scale.md)
};

/// render writes pictures as .png or .tif, value rasters (aspect, tri, tpi, roughness) as .tif only.
void check_render_file(const json& resolved) {
  if (!resolved.contains("file") || !resolved["file"].is_string()) return;
  const std::string file = resolved["file"].get<std::string>();
  const FileFormat f = format_from_extension(file);
  const std::string mode = resolved.value("mode", std::string("hillshade"));
  const bool values = mode == "aspect" || mode == "tri" || mode == "tpi" || mode == "roughness";
  if (mode == "perspective" && f != FileFormat::PNG)
    throw UsageError("render", fmt::format("-o {}: a perspective picture has no georeferencing; use a .png name", file));
  if (f != FileFormat::GeoTIFF && (values || f != FileFormat::PNG))
    throw UsageError("render", values ? fmt::format("-o {}: --mode {} writes a float GeoTIFF; use a .tif name", file, mode)
                                      : fmt::format("-o {}: render writes a PNG or a GeoTIFF; use a .png name or a .tif name", file));
}

/// One subcommand for stage `name`; `-o` maps to option `output_option` ("" for none).
void add_command(CLI::App& app, const std::string& name, const std::string& output_option, const std::string& help) {
  const StageInfo* sp = StageRegistry::instance().find(name);
  if (!sp) return;
  auto a = std::make_shared<Args>();
  auto* sub = app.add_subcommand(name, help.empty() ? sp->description : help);
  sub->add_option("input", a->input, "Input raster")->required();
  sub->add_flag("--fill-nodata", a->fill_nodata, "Fill nodata cells first (harmonic)");
  // metrics prints its report, so its file option is optional here.
  a->flags.add(sub, *sp, output_option, name != "metrics");
  a->in.add(sub);
  if (name == "render") a->tile.add(sub);
  sub->callback([a, sp, sub, name] {
    const StageInfo& s = *sp;
    const json opts = a->flags.given(sub, s);
    const ReadOptions ro = a->in.read_options(a->fill_nodata);
    // The stage table's memory column, from the input's header, before anything is read.
    require_stage_memory(name, "", memory_of(name, opts, raster_shape(a->input)), nullptr);
    if (name == "metrics") {
      if (opts.contains("json") && opts["json"].is_string())
        check_output_paths(name, {{"input", a->input}}, {{"--json", opts["json"].get<std::string>()}});
      // The report goes to stdout; --json also writes it as a file.
      const Heightfield h = read_heightfield(a->input, ro);
      json report = analysis::terrain_metrics(h, make_progress(name));
      finish_progress();
      fmt::print("{}", analysis::format_metrics(report));
      if (opts.contains("json")) {
        report["provenance"] = provenance();
        write_text_file_atomic(opts["json"].get<std::string>(), report.dump(2) + "\n");
      }
      return;
    }
    json resolved;
    try {
      resolved = resolve_options(s, opts, s.name);
      check_stage_files(s, resolved, {{"input", a->input}}, {});
      if (name == "sketch" && resolved.contains("file") && resolved["file"].is_string() &&
          format_from_extension(resolved["file"].get<std::string>()) != FileFormat::PNG)
        throw UsageError(name, fmt::format("-o {}: {} writes a PNG; use a .png name", resolved["file"].get<std::string>(), name));
      if (name == "render") check_render_file(resolved);
    } catch (const UsageError&) {
      throw;
    } catch (const Error& e) {
      throw UsageError(s.name, std::string(e.what()).substr(e.stage().size() + 2));
    }
    if (a->tile.tiled()) {
      TileFlags::refuse_untiled_flag(name, a->fill_nodata || a->in.zmin || a->in.zmax || a->in.cell_size,
                                     "--fill-nodata, --zmin, --zmax, --cell-size");
      // A render that streams already holds a few strips, never the raster: --tile (or
      // --memory-budget) just streams, which tiles only slowed (docs/scale.md). Under mpirun rank 0
      // writes it and the others have nothing to do. --resume keeps the tiled run and its journal.
      StageData none;
      StageContext ctx{none, resolved, []() -> Device& { return device(); }, make_progress(s.name), s.name,
                       provenance()};
      if (name == "render" && !a->tile.resume && render_streams(a->input, ctx)) {
        (void)a->tile.options(name);  // its values are still checked
        if (distributed::rank() == 0) {
          if (!globals().quiet) fmt::print(stderr, "render: streams strip by strip; --tile is not needed (docs/scale.md)\n");
          run_render_streamed(a->input, ctx);
          finish_progress();
        }
        return;
      }
      a->tile.run_stage(name, a->input, name, resolved, "");
      return;
    }
    (void)a->tile.options(name);  // --halo alone
    // render of a GDAL raster to a picture: strip by strip, never the whole raster in memory.
    if (name == "render" && !a->fill_nodata && !a->in.zmin && !a->in.zmax && !a->in.cell_size) {
      StageData none;
      StageContext ctx{none, resolved, []() -> Device& { return device(); }, make_progress(s.name), s.name,
                       provenance()};
      if (run_render_streamed(a->input, ctx)) {
        finish_progress();
        return;
      }
    }
    // render on the device: open it (PoCL loads its compiler, ~0.3 s of CPU) while GDAL reads.
    std::future<void> opening;
    if (name == "render" && resolved.value("backend", std::string("device")) == "device")
      opening = std::async(std::launch::async, [] { (void)device(); });
    StageData data;
    data.height = read_heightfield(a->input, ro);
    if (opening.valid()) opening.get();  // rethrows a device error
    data.current = DataKind::Heightfield;
    StageContext ctx{data, resolved, []() -> Device& { return device(); }, make_progress(s.name), s.name, provenance()};
    s.run(ctx);
    finish_progress();
  });
}

CommandRegistrar reg(40, [](CLI::App& app) {
  add_command(app, "metrics", "",
              "Realism statistics of a terrain (slope, curvature, spectral slope, hypsometry, drainage, fill and "
              "breach volumes); --json writes the report");
  add_command(app, "sketch", "file", "");
  add_command(app, "render", "file", "");
  add_command(app, "mesh", "file", "");
});

}  // namespace
}  // namespace terracl::cli
