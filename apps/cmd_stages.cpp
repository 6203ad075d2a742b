// SPDX-License-Identifier: Apache-2.0
// `terracl stages` and one auto-generated subcommand per stage, built from the stage table:
// `terracl <stage> [IN] -o OUT [--option value ...]`.
#include "cli.hpp"
#include "cli_reference.hpp"
#include "stage_flags.hpp"
#include "tile_flags.hpp"

#include <terracl/error.hpp>
#include <terracl/hypre.hpp>
#include <terracl/io.hpp>
#include <terracl/stage.hpp>
#include <terracl/stage_memory.hpp>

#include <fmt/format.h>

#include <cstdlib>
#include <map>

namespace terracl::cli {
namespace {

struct StageArgs {
  std::string input, output;
  bool fill_nodata = false;
  StageFlags flags;
  InputScaleFlags in;
  OutputFlags out;
  TileFlags tile;  // stages from heightfield to heightfield: --tile (docs/scale.md)
};

void add_stage_command(CLI::App& app, const StageInfo& s) {
  auto a = std::make_shared<StageArgs>();
  auto* sub = app.add_subcommand(s.name, s.description);
  auto* in = sub->add_option("input", a->input,
                             s.input == DataKind::Gradient ? "Input gradient field (.exr, or a 2-band gx/gy .tif)" : "Input raster");
  if (s.input != DataKind::None) in->required();
  // A stage that passes its input on (it reports, or writes files of its own) needs no -o.
  const bool passes = s.output == DataKind::None || s.output == DataKind::Any;
  auto* out = sub->add_option("-o,--output", a->output, "Output file (format from the extension)");
  if (!passes) out->required();
  if (s.input == DataKind::Heightfield) sub->add_flag("--fill-nodata", a->fill_nodata, "Fill nodata cells first");
  // amplify: --tile is a tiled run (docs/scale.md); its work tiling stays the pipeline option "tile".
  if (s.name == "amplify") a->flags.skip = {"tile"};
  a->flags.add(sub, s);
  if (s.input == DataKind::Heightfield || s.input == DataKind::Any) a->in.add(sub);
  if (s.output == DataKind::Heightfield) a->out.add(sub);
  // extract: its 2-band gradient GeoTIFF is written tile by tile too.
  bool tileable = s.input == DataKind::Heightfield && (s.output == DataKind::Heightfield || s.name == "extract");
  for (const auto& o : s.options)
    tileable &= (o.name != "tile" || s.name == "amplify") && o.name != "halo" && o.name != "memory_budget";
  if (tileable) a->tile.add(sub);
  if (s.name == "amplify")  // the stage option it stands in for, named (its help and unit) for `--help`
    for (const auto& o : s.options)
      if (o.name == "tile")
        sub->get_option("--tile")->description("Tiled out-of-core run with tiles of this many input cells [" + o.unit +
                                               "]; in a pipeline, \"tile\" is the work tiling: " + o.help);
  const StageInfo* sp = &s;
  sub->callback([a, sp, sub] {
    const StageInfo& s = *sp;
    const json opts = a->flags.given(sub, s);
    json resolved;
    try {
      resolved = resolve_options(s, opts, s.name);
      // Refuse an output we could not write before spending time on the stage.
      if (!a->output.empty()) {
        const FileFormat f = format_from_extension(a->output);
        const bool gradient_out = s.output == DataKind::Gradient;
        if (gradient_out ? (f != FileFormat::EXR && f != FileFormat::GeoTIFF)
                         : (f != FileFormat::GeoTIFF && f != FileFormat::EXR && f != FileFormat::PNG && f != FileFormat::RAW16 &&
                            f != FileFormat::NPY))
          fail(s.name, "-o {}: cannot write a {} with this extension; use {}", a->output, gradient_out ? "gradient" : "heightfield",
               gradient_out ? ".exr or .tif (two float32 bands)" : ".tif, .exr, .png, .r16 or .npy");
      }
      // The same check as a pipeline's: no output may replace an input, another output or a device.
      check_stage_files(s, resolved, {{"input", a->input}}, {{"-o", a->output}});
    } catch (const Error& e) {
      throw UsageError(s.name, std::string(e.what()).substr(e.stage().size() + 2));
    }
    if (a->tile.tiled()) {
      TileFlags::refuse_untiled_flag(s.name, a->fill_nodata || a->in.zmin || a->in.zmax || a->in.cell_size,
                                     "--fill-nodata, --zmin, --zmax, --cell-size");
      TileFlags::refuse_untiled_flag(s.name, a->out.cog || !a->out.creation_options.empty() || a->out.output_type != "Float32",
                                     "--co, --cog, --ot");
      a->tile.run_stage(s.name, a->input, s.name, resolved, a->output);
      return;
    }
    (void)a->tile.options(s.name);  // --halo alone
    // The stage table's memory column, from the input's header, before anything is read.
    if (!a->input.empty()) require_stage_memory(s.name, "", memory_of(s.name, resolved, raster_shape(a->input)), nullptr);
    StageData data;
    // `reconstruct GRAD.exr --solver hypre`: the stage reads the file itself, each MPI rank only
    // its band of rows (docs/scale.md), instead of every rank loading all of it here.
    auto unset = [&](const char* k) { return !resolved.contains(k) || resolved.at(k).is_null(); };
    const bool hypre_reads = s.name == "reconstruct" && resolved.value("solver", std::string()) == "hypre" &&
                             unset("gradient") && unset("divergence") && !a->input.empty() &&
                             is_gradient_file(a->input);
    if (hypre_reads) {
      resolved["gradient"] = a->input;
    } else if (!a->input.empty()) {
      if (s.input == DataKind::Gradient || (s.input == DataKind::None && is_gradient_file(a->input))) {
        data.gradient = read_gradient(a->input);
        data.current = DataKind::Gradient;
      } else {
        data.height = read_heightfield(a->input, a->in.read_options(a->fill_nodata));
        data.current = DataKind::Heightfield;
      }
    }
    StageContext ctx{data, resolved, [] () -> Device& { return device(); }, make_progress(s.name), s.name, provenance()};
    ctx.provenance["terracl:stages"] = json::array({json{{"type", s.name}, {"options", resolved}}}).dump();
    try {
      s.run(ctx);
    } catch (const Cancelled&) {
      finish_progress();
      throw Cancelled(s.name, "cancelled by Ctrl-C; no output was written");
    }
    finish_progress();
    // Under mpirun a hypre reconstruct runs on every rank; rank 0 writes the result.
    if (a->output.empty() || !hypre_is_root_rank()) return;
    if (data.current == DataKind::Gradient || (s.output == DataKind::Gradient && data.gradient)) {
      GradientField& g = *data.gradient;
      for (const auto& [k, v] : ctx.provenance) g.metadata[k] = v;
      write_gradient(g, a->output);
    } else {
      if (!data.height) fail(s.name, "produced no heightfield to write");
      Heightfield& h = *data.height;
      for (const auto& [k, v] : ctx.provenance) h.metadata[k] = v;
      write_heightfield(h, a->output, a->out.write_options());
    }
  });
}

bool has_subcommand(const CLI::App& app, const std::string& name) {
  for (const CLI::App* sub : app.get_subcommands({}))
    if (sub->get_name() == name) return true;
  return false;
}

struct StagesArgs {
  bool markdown = false, man = false, completion = false;
};

CommandRegistrar reg(50, [](CLI::App& app) {
  auto a = std::make_shared<StagesArgs>();
  auto* sub = app.add_subcommand("stages", "List the pipeline stages and their options");
  CLI::App* app_ptr = &app;
  sub->add_flag("--markdown", a->markdown, "Print docs/stages.md");
  sub->add_flag("--man", a->man, "Print the terracl(1) man page (roff), generated from the commands");
  sub->add_flag("--bash-completion", a->completion, "Print a bash completion script for terracl");
  sub->callback([a, app_ptr] {
    if (a->man) return (void)fmt::print("{}", man_page(*app_ptr));
    if (a->completion) return (void)fmt::print("{}", bash_completion(*app_ptr));
    if (a->markdown) {
      std::vector<std::string> commands;
      for (const CLI::App* c : app_ptr->get_subcommands({})) commands.push_back(c->get_name());
      fmt::print("{}", stages_markdown(commands));
      return;
    }
    // Stages without a generated subcommand may still have a hand-written one (render, warp, ...).
    for (const auto& s : StageRegistry::instance().all())
      fmt::print("{:<16} {}{}\n", s.name, s.description, has_subcommand(*app_ptr, s.name) ? "" : " (pipeline only)");
  });
  for (const auto& s : StageRegistry::instance().all())
    if (s.cli) add_stage_command(app, s);
});

}  // namespace
}  // namespace terracl::cli
