// SPDX-License-Identifier: Apache-2.0
// `terracl edit BASE --script edits.json -o out.tif [--preview out.png]`: gradient-domain authoring.
#include "cli.hpp"
#include "stage_flags.hpp"

#include <terracl/edit.hpp>
#include <terracl/error.hpp>
#include <terracl/gradient.hpp>
#include <terracl/io.hpp>
#include <terracl/memory.hpp>
#include <terracl/stage_memory.hpp>
#include <terracl/render.hpp>

#include <fmt/format.h>

#include <filesystem>

namespace terracl::cli {
namespace {

struct EditArgs {
  std::string base, script, output, preview, ramp, report, gradient_out, gradient_image, water;
  bool validate = false, list = false, keep_filled = false;
  InputScaleFlags in;
  OutputFlags out;
};

CommandRegistrar reg(40, [](CLI::App& app) {
  auto a = std::make_shared<EditArgs>();
  auto* sub = app.add_subcommand("edit", "Apply a JSON edit script to a terrain (docs/authoring.md) and reconstruct it");
  sub->add_option("base", a->base, "Base terrain: a raster, or flat:WIDTHxHEIGHT[@CELLSIZE][+ELEVATION] (metres)");
  sub->add_option("--script", a->script, "Edit script (JSON)");
  sub->add_option("-o,--output", a->output, "Output heightfield (.tif, .exr, .png, ...)");
  sub->add_option("--preview", a->preview, "Also write a shaded-relief preview PNG (render module), one pixel per cell");
  sub->add_option("--ramp", a->ramp, "Preview colour ramp: hypsometric (default), relative, grey or a gdaldem colour file");
  sub->add_option("--report", a->report, "Write per-operation timings and solver figures (JSON)");
  sub->add_option("--gradient-out", a->gradient_out, "Also write the edited gradient field (.exr, or .tif: two float32 bands gx, gy)");
  sub->add_option("--gradient-image", a->gradient_image, "Also write the edited gradient as a 16-bit gradient image (.png)");
  sub->add_option("--water", a->water,
                  "Also write the lakes' water depth (m, float32, the output's georeferencing; 0 where dry) from the "
                  "script's lake operations");
  sub->add_flag("--keep-filled", a->keep_filled,
                "Write the harmonically filled elevations where the base has nodata (default: those cells stay nodata)");
  sub->add_flag("--validate", a->validate, "Check the script against BASE and exit");
  sub->add_flag("--list", a->list, "List the operations and exit");
  a->in.add(sub);
  a->out.add(sub);
  sub->callback([a] {
    if (a->list) {
      for (const auto& [name, summary] : edit_operations()) fmt::print("{:<16} {}\n", name, summary);
      return;
    }
    if (a->script.empty()) throw UsageError("edit", "needs --script edits.json");
    const nlohmann::json script = read_edit_script(a->script);
    if (a->base.empty() && script.is_object() && script.contains("base")) {
      if (!script["base"].is_string()) throw UsageError("edit", fmt::format("{}: /base must be a string", a->script));
      // A script's own base names files relative to the script.
      a->base = resolve_path(script["base"].get<std::string>(), std::filesystem::path(a->script).parent_path().string());
    }
    if (a->base.empty())
      throw UsageError("edit", "needs BASE (a raster or flat:WIDTHxHEIGHT[@CELLSIZE][+ELEVATION]), or \"base\" in the script");
    if (a->output.empty() && !a->validate) throw UsageError("edit", "needs -o OUTPUT");
    check_output_paths("edit", {{"BASE", a->base.rfind("flat:", 0) == 0 ? "" : a->base}, {"--script", a->script}},
                       {{"-o", a->output},
                        {"--preview", a->preview},
                        {"--report", a->report},
                        {"--gradient-out", a->gradient_out},
                        {"--gradient-image", a->gradient_image},
                        {"--water", a->water}});
    if (!a->preview.empty() && format_from_extension(a->preview) != FileFormat::PNG)
      throw UsageError("edit", fmt::format("--preview {}: the preview is a PNG; use a .png name", a->preview));
    // The preview's ramp is checked before any work (a bad ramp must not leave a half-done run).
    render::ColorRamp ramp = render::ColorRamp::default_ramp();
    if (!a->ramp.empty()) ramp = render::ColorRamp::from_spec(a->ramp);
    Heightfield base;
    std::vector<size_t> nodata;  // the base's nodata cells, nodata again in the output
    if (auto flat = parse_flat_spec(a->base)) {
      base = std::move(*flat);
    } else {
      if (!path_exists(a->base)) throw UsageError("edit", fmt::format("base terrain '{}' not found", a->base));
      // From the DEM's header, before it is read (the check after reading also covers the device).
      require_stage_memory("edit", "", memory_of("edit", json::object(), raster_shape(a->base)), nullptr);
      base = read_heightfield(a->base, a->in.read_options());
      if (base.count_nodata()) {
        if (!globals().quiet) fmt::print(stderr, "edit: filling {} nodata cells of {} harmonically\n", base.count_nodata(), a->base);
        nodata = nodata_cells(base);
        fill_nodata_harmonic(base);
      }
    }
    // Before the session allocates: a 20000 x 20000 base ran the device out of memory half-way.
    require_memory("edit", fmt::format("a {} x {} edit", base.width, base.height),
                   double(base.size()) * edit_host_bytes_per_cell, double(base.size()) * edit_device_bytes_per_cell,
                   double(base.size()) * 8, &device(), "use a smaller base (flat:WxH, or crop the DEM)");
    EditOptions o;
    o.progress = make_progress("edit");
    o.base_dir = std::filesystem::path(a->script).parent_path().string();
    EditSession s(device(), base, o);
    // Warnings go to stderr even with -q: they say an operation may do nothing visible.
    auto warn = [](const std::vector<std::string>& w) {
      for (const auto& m : w) fmt::print(stderr, "terracl WARNING: edit: {}\n", m);
    };
    if (a->validate) {
      warn(s.check(script));
      fmt::print("{}: valid for a {}x{} base\n", a->script, base.width, base.height);
      return;
    }
    s.apply(script);
    Heightfield h = s.height();
    // Lakes are filled on the final terrain; their warnings (an empty lake) exist from then on.
    std::optional<Heightfield> water = s.water();
    finish_progress();
    warn(s.warnings());
    h.georef = base.georef;
    h.metadata = base.metadata;
    for (const auto& [k, v] : provenance()) h.metadata[k] = v;
    h.metadata["terracl:edit_script"] = a->script;
    if (!a->keep_filled) restore_nodata(h, nodata);
    write_heightfield(h, a->output, a->out.write_options());
    if (!a->water.empty()) {
      if (!water) {
        fmt::print(stderr, "terracl WARNING: edit: --water {}: the script has no lake operation; the water depth is 0 "
                           "everywhere\n", a->water);
        water = Heightfield(h.width, h.height, 0.f);
      }
      water->georef = h.georef;
      water->metadata = h.metadata;
      water->metadata["terracl:layer"] = "water depth (m)";
      if (!a->keep_filled) restore_nodata(*water, nodata);  // as the terrain: nodata where the base had none
      // Float32 whatever --ot says for the terrain (depths are centimetres, not whole metres), and
      // the terrain's vertical range, if given for PNG/RAW16, is not the water's.
      WriteOptions wo = a->out.write_options();
      wo.output_type = "Float32";
      wo.zmin.reset();
      wo.zmax.reset();
      write_heightfield(*water, a->water, wo);
    }
    if (!a->preview.empty()) {
      render::Options ro;
      ro.mode = render::Mode::ShadedRelief;
      ro.ramp = ramp;
      render::Image img = render::render(h, ro, device());
      if (water) render::tint_water(img, *water);
      render::write_image(img, a->preview, h.metadata);
    }
    if (!a->gradient_out.empty() || !a->gradient_image.empty()) {
      GradientField g = s.gradient();
      if (!a->gradient_out.empty()) write_gradient(g, a->gradient_out);
      if (!a->gradient_image.empty()) write_gradient_image(g, a->gradient_image);
    }
    const nlohmann::json rep = s.report();
    if (!a->report.empty()) write_text_file_atomic(a->report, rep.dump(2) + "\n");
    if (!globals().quiet) {
      double ops_ms = 0;
      for (const auto& e : rep["operations"]) ops_ms += e.value("ms", 0.0);
      const auto& ls = rep.contains("last_solve") ? rep["last_solve"] : nlohmann::json::object();
      fmt::print("edit: {} operations in {:.1f} ms, {} hard cells, reconstruction {} cycles {:.1f} ms -> {}\n",
                 rep["operations"].size(), ops_ms, rep["hard_cells"].get<size_t>(), ls.value("cycles", 0),
                 ls.value("total_ms", 0.0), a->output);
      if (rep.contains("locality") && rep["locality"].value("mode", "") == "local") {
        const auto& l = rep["locality"];
        fmt::print("edit: local solve: {} cells changed, {} cells solved within {:.0f} m (at most) of them; every other cell keeps "
                   "the base elevation (\"solve\": \"global\" for a global solve)\n",
                   l.value("changed_cells", size_t(0)), l.value("solved_cells", size_t(0)), l.value("falloff_m", 0.0));
      }
      for (const auto& e : rep["operations"])
        if (e.contains("curl_rms_before"))
          fmt::print("edit: regularize (operation {}): curl RMS {:.3g} -> {:.3g} 1/m\n", e["index"].get<int>(),
                     e["curl_rms_before"].get<double>(), e["curl_rms_after"].get<double>());
    }
  });
});

}  // namespace
}  // namespace terracl::cli
