// SPDX-License-Identifier: Apache-2.0
#include "cli.hpp"
#include "stage_flags.hpp"
#include "tile_flags.hpp"

#include <fmt/format.h>

#include <terracl/io.hpp>
#include <terracl/mesh.hpp>

namespace terracl::cli {
namespace {

struct ConvertArgs {
  std::string input, output;
  std::optional<double> zmin, zmax, out_zmin, out_zmax, cell;
  std::optional<int> width, height;
  bool fill = false;
  OutputFlags out;
  TileFlags tile;  // --tile: GeoTIFF/VRT/... to a tiled GeoTIFF window by window (docs/scale.md)
};

CommandRegistrar reg(12, [](CLI::App& app) {
  auto a = std::make_shared<ConvertArgs>();
  auto* sub = app.add_subcommand("convert", "Convert between raster formats (format from the extension)");
  sub->add_option("input", a->input, "Input raster")->required();
  sub->add_option("output", a->output, "Output raster (.tif .exr .png .r16 .raw)")->required();
  sub->add_option("--zmin", a->zmin, "Input PNG/RAW16: elevation of code 0 (m)");
  sub->add_option("--zmax", a->zmax, "Input PNG/RAW16: elevation of the largest code (m)");
  sub->add_option("--width", a->width, "Input RAW16 width (cells)");
  sub->add_option("--height", a->height, "Input RAW16 height (cells)");
  sub->add_option("--cell-size", a->cell, "Cell size in metres for inputs without georeferencing");
  sub->add_option("--out-zmin", a->out_zmin, "Output PNG16/RAW16: elevation of code 0 (default: data minimum)");
  sub->add_option("--out-zmax", a->out_zmax, "Output PNG16/RAW16: elevation of code 65535 (default: data maximum)");
  sub->add_flag("--fill-nodata", a->fill, "Fill nodata cells by harmonic interpolation");
  a->out.add(sub);
  a->tile.add(sub);
  sub->callback([a] {
    check_output_paths("convert", {{"input", a->input}}, {{"output", a->output}});
    if (a->tile.tiled()) {
      TileFlags::refuse_untiled_flag("convert", a->fill || a->zmin || a->zmax || a->width || a->height || a->cell,
                                     "--fill-nodata, --zmin, --zmax, --width, --height, --cell-size");
      TileFlags::refuse_untiled_flag("convert",
                                     a->out.cog || !a->out.creation_options.empty() || a->out.output_type != "Float32" ||
                                         a->out_zmin || a->out_zmax,
                                     "--co, --cog, --ot, --out-zmin, --out-zmax");
      a->tile.run_stage("convert", a->input, "", json::object(), a->output);
      return;
    }
    (void)a->tile.options("convert");  // --halo alone
    if (is_gradient_file(a->input)) {
      GradientField g = read_gradient(a->input);
      for (const auto& [k, v] : provenance()) g.metadata[k] = v;
      write_gradient(g, a->output);
      return;
    }
    ReadOptions ro;
    ro.zmin = a->zmin;
    ro.zmax = a->zmax;
    ro.width = a->width;
    ro.height = a->height;
    ro.cell_size = a->cell;
    ro.fill_nodata = a->fill;
    Heightfield h = read_heightfield(a->input, ro);
    for (const auto& [k, v] : provenance()) h.metadata[k] = v;
    WriteOptions wo = a->out.write_options_keeping_type(a->input, a->output);
    wo.zmin = a->out_zmin;
    wo.zmax = a->out_zmax;
    write_heightfield(h, a->output, wo);
    const FileFormat of = format_from_extension(a->output);
    if ((of == FileFormat::PNG || of == FileFormat::RAW16) && !globals().quiet) {
      // Engine heightmaps: how to import them at their true scale (also in the sidecar).
      auto [lo, hi] = std::pair{a->out_zmin, a->out_zmax};
      const HeightStats st = compute_stats(h);
      fmt::print(stderr, "{}", mesh::heightmap_import_summary(h, lo.value_or(st.min), hi.value_or(st.max)));
    }
  });
});

}  // namespace
}  // namespace terracl::cli
