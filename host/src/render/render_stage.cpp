// SPDX-License-Identifier: Apache-2.0
// The `render` stage: its option table (gdaldem's options under terracl's names) and its run
// function. Pictures (hillshade, relief, slope, shaded-relief) go to .png or a georeferenced .tif;
// value rasters (slope, aspect, tri, tpi, roughness) to a float32 GeoTIFF like gdaldem's. The
// heightfield passes through unchanged.
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/render.hpp>

#include "pipeline/builtin.hpp"
#include "render/render_internal.hpp"

namespace terracl {

// Also read by the tiled render (host/src/tile/render_tiles.cpp), so both draw the same picture.
render::Options render_stage_options(const StageContext& c) {
  render::Options o;
  o.mode = render::mode_from_name(c.get<std::string>("mode"));
  o.azimuth_deg = c.get<double>("azimuth");
  o.altitude_deg = c.get<double>("altitude");
  o.z_factor = c.get<double>("z_factor");
  o.slope_max_deg = c.get<double>("slope_max");
  if (c.has("ramp")) o.ramp = render::ColorRamp::from_spec(c.get<std::string>("ramp"));
  o.shading = render::shading_from_name(c.get<std::string>("shading"));
  o.compute_edges = c.get<bool>("compute_edges");
  o.slope_percent = c.get<std::string>("slope_format") == "percent";
  o.tri_alg = c.get<std::string>("tri_alg") == "wilson" ? render::TriAlg::Wilson : render::TriAlg::Riley;
  o.aspect_trigonometric = c.get<bool>("trigonometric");
  o.zero_for_flat = c.get<bool>("zero_for_flat");
  o.gradient_alg = c.get<std::string>("alg") == "zevenbergenthorne" ? render::GradientAlg::ZevenbergenThorne
                                                                     : render::GradientAlg::Horn;
  o.scale = c.get<double>("scale");
  o.compress = c.get<std::string>("compress") == "deflate";
  o.view.azimuth_deg = c.get<double>("view_azimuth");
  o.view.elevation_deg = c.get<double>("view_elevation");
  o.view.fov_deg = c.get<double>("fov");
  o.view.zoom = c.get<double>("view_zoom");
  o.view.haze = c.get<double>("haze");
  o.view.shadows = c.get<bool>("shadows");
  // The natural material is the perspective default unless a ramp is asked for.
  o.view.material = c.has("material")  ? render::material_from_name(c.get<std::string>("material"))
                    : c.has("ramp")    ? render::Material::Ramp
                                       : render::Material::Natural;
  o.view.water = c.get<bool>("water");
  if (c.has("water_level")) {
    o.view.has_water_level = true;
    o.view.water_level = c.get<double>("water_level");
  }
  o.view.water_clarity = c.get<double>("water_clarity");
  {
    const std::string size = c.get<std::string>("size");
    int w = 0, h = 0;
    char x = 0, extra = 0;
    if (std::sscanf(size.c_str(), "%d%c%d%c", &w, &x, &h, &extra) != 3 || (x != 'x' && x != 'X'))
      fail("render", "size (--size) must be WxH in pixels, e.g. 1024x640; got '{}'", size);
    o.view.width = w;
    o.view.height = h;
  }
  if (c.has("view_target")) {
    const std::string t = c.get<std::string>("view_target");
    double col = 0, row = 0;
    char comma = 0, extra = 0;
    if (std::sscanf(t.c_str(), "%lf%c%lf%c", &col, &comma, &row, &extra) != 3 || comma != ',')
      fail("render", "view_target (--view-target) must be COL,ROW in cells, e.g. 600,300; got '{}'", t);
    o.view.has_target = true;
    o.view.target[0] = col;
    o.view.target[1] = row;
  }
  if (o.mode == render::Mode::Perspective) render::check_view(o.view);
  o.progress = c.progress;
  return o;
}

namespace {

void run_render(StageContext& c) {
  const render::Options o = render_stage_options(c);
  const std::string file = c.get<std::string>("file");
  const bool tif = format_from_extension(file) == FileFormat::GeoTIFF;
  const bool host = c.get<std::string>("backend") == "host";
  const Heightfield& h = c.height();
  if (o.mode == render::Mode::Perspective && tif)
    fail("render", "{}: a perspective picture has no georeferencing; write it as .png", file);
  // Slope to a GeoTIFF is gdaldem's float raster; to a PNG the grey picture.
  if (render::is_value_mode(o.mode) && (tif || o.mode != render::Mode::Slope)) {
    if (!tif) fail("render", "{}: mode {} writes values; use a .tif name", file, c.get<std::string>("mode"));
    Heightfield v = host ? render::values(h, o) : render::values(h, o, c.device());
    for (const auto& [k, val] : c.provenance) v.metadata[k] = val;
    WriteOptions wo;
    if (!o.compress) wo.creation_options = {"COMPRESS=NONE", "PREDICTOR=1"};
    write_heightfield(v, file, wo);
    return;
  }
  const render::Image img = host ? render::render(h, o) : render::render(h, o, c.device());
  render::write_image(img, file, c.provenance);
}

}  // namespace

bool render_streams(const std::string& input, const StageContext& c) {
  return render::can_stream_render(input, c.get<std::string>("file"), render_stage_options(c));
}

bool run_render_streamed(const std::string& input, StageContext& c) {
  const render::Options o = render_stage_options(c);
  const std::string file = c.get<std::string>("file");
  if (!render::can_stream_render(input, file, o)) return false;
  const bool host = c.get<std::string>("backend") == "host";
  render::render_file(input, file, o, [&]() -> Device* { return host ? nullptr : &c.device(); }, c.provenance, 0);
  return true;
}

StageInfo render_stage_info() {
  return {"render",
          "Write a picture (hillshade as gdaldem's, colour relief, slope, shaded relief; 8-bit grey or RGB, alpha "
          "where nodata) as .png or a georeferenced .tif, or gdaldem's value rasters (slope, aspect, tri, tpi, "
          "roughness) and GRASS's profile/tangential curvature as a float32 GeoTIFF; passes the heightfield through.",
          DataKind::Heightfield,
          DataKind::Heightfield,
          {{"file", OptionType::OutputPath, nullptr, "", "Picture or value raster to write (.png or .tif)", {}, true},
           {"mode",
            OptionType::Enum,
            "hillshade",
            "",
            "What to draw: pictures hillshade|relief|slope|shaded-relief, a perspective view (.png), values (.tif) "
            "slope|aspect|tri|tpi|roughness|profile-curvature|tangential-curvature (1/m, as GRASS r.slope.aspect)",
            {"hillshade", "relief", "slope", "shaded-relief", "aspect", "tri", "tpi", "roughness", "profile-curvature",
             "tangential-curvature", "perspective"},
            false},
           {"azimuth", OptionType::Float, 315.0, "deg", "Sun azimuth, clockwise from north", {}, false},
           {"altitude", OptionType::Float, 45.0, "deg", "Sun altitude above the horizon", {}, false},
           {"z_factor", OptionType::Float, 1.0, "", "Vertical exaggeration", {}, false},
           {"shading",
            OptionType::Enum,
            "standard",
            "",
            "Hillshade variant: gdaldem's default, -multidirectional, -combined or -igor",
            {"standard", "multidirectional", "combined", "igor"},
            false},
           {"compute_edges",
            OptionType::Bool,
            false,
            "",
            "Shade the border cells too (gdaldem -compute_edges); otherwise they are nodata (transparent)",
            {},
            false},
           {"ramp",
            OptionType::String,
            nullptr,
            "",
            "Colour ramp: hypsometric (metres, sea below 0 m blue; the default), relative (over the data range), "
            "grey, or a gdaldem color-relief file",
            {},
            false},
           {"slope_max", OptionType::Float, 60.0, "deg", "Slope picture: this slope and steeper are black", {}, false},
           {"slope_format",
            OptionType::Enum,
            "degrees",
            "",
            "Slope values (.tif) in degrees or percent (gdaldem -p)",
            {"degrees", "percent"},
            false},
           {"tri_alg",
            OptionType::Enum,
            "riley",
            "",
            "TRI algorithm (gdaldem -alg): riley (terrestrial) or wilson (bathymetric)",
            {"riley", "wilson"},
            false},
           {"trigonometric",
            OptionType::Bool,
            false,
            "",
            "Aspect counter-clockwise from east (gdaldem -trigonometric) instead of an azimuth",
            {},
            false},
           {"zero_for_flat",
            OptionType::Bool,
            false,
            "",
            "Aspect 0 on flat ground instead of nodata (gdaldem -zero_for_flat)",
            {},
            false},
           {"alg",
            OptionType::Enum,
            "horn",
            "",
            "Slope/aspect/hillshade gradient (gdaldem -alg): horn, or zevenbergenthorne (smoother terrain)",
            {"horn", "zevenbergenthorne"},
            false},
           {"scale",
            OptionType::Float,
            1.0,
            "",
            "Horizontal units per vertical unit (gdaldem -s), e.g. 111120 for a DEM in degrees with metres",
            {},
            false,
            1e-12,
            1e15},
           {"view_azimuth",
            OptionType::Float,
            200.0,
            "deg",
            "Perspective: where the camera looks from, clockwise from north (200: from the south-south-west)",
            {},
            false},
           {"view_elevation",
            OptionType::Float,
            35.0,
            "deg",
            "Perspective: camera pitch below the horizon, in (0, 90)",
            {},
            false},
           {"fov", OptionType::Float, 40.0, "deg", "Perspective: field of view across the picture's width, in (0, 180)", {}, false},
           {"size", OptionType::String, "1024x640", "px", "Perspective: picture size WxH", {}, false},
           {"view_zoom",
            OptionType::Float,
            1.0,
            "",
            "Perspective: 1 frames the whole terrain; 2 moves the camera half way toward the frame's centre",
            {},
            false},
           {"view_target",
            OptionType::String,
            nullptr,
            "cells",
            "Perspective: aim at cell COL,ROW (from the framing's distance / view_zoom) instead of the terrain's centre",
            {},
            false},
           {"haze", OptionType::Float, 1.0, "", "Perspective: strength of the distance haze (0: none)", {}, false},
           {"shadows", OptionType::Bool, true, "", "Perspective: cast shadows toward the sun", {}, false},
           {"material",
            OptionType::Enum,
            nullptr,
            "",
            "Perspective: surface colours: natural (rock, scree, grass, snow, sand by slope and elevation; the default "
            "unless ramp is given) or ramp (the colour ramp by elevation)",
            {"natural", "ramp"},
            false},
           {"water_level",
            OptionType::Float,
            nullptr,
            "m",
            "Perspective: elevation of a water surface (default: sea level 0 m where cells lie below it and the look is "
            "natural or the hypsometric ramp, else none)",
            {},
            false},
           {"water", OptionType::Bool, true, "", "Perspective: draw the water surface (--no-water: none)", {}, false},
           {"water_clarity",
            OptionType::Float,
            20.0,
            "m",
            "Perspective: the water's red extinction length along the ray (green 2.5x, blue 5x); larger is clearer",
            {},
            false,
            1e-3,
            1e6},
           {"compress",
            OptionType::Enum,
            "deflate",
            "",
            "Value rasters (.tif): DEFLATE with the floating-point predictor at level 1, or none (gdaldem's default: "
            "a third larger, less CPU); pictures are written uncompressed, tiled or not",
            {"deflate", "none"},
            false},
           {"backend",
            OptionType::Enum,
            "device",
            "",
            "Compute with kernels/render*.cl on the OpenCL device, or with the host reference code",
            {"device", "host"},
            false}},
          run_render,
          false};
}

// `terracl bench render`: the shading alone (no file I/O, device already open), host reference
// against the kernels, on a DEM (--set dem=FILE, whole raster) or an N x N synthetic grid.
void register_render_benches(BenchRegistry& r) {
  r.add({"render",
         "Shading time of render (hillshade, shaded-relief, tri, perspective) on the host and on the OpenCL device, file I/O "
         "excluded; --set dem=FILE renders a whole DEM, else an N x N synthetic grid",
         [](const BenchArgs& a) {
           Heightfield h;
           std::string source;
           if (a.extra.contains("dem")) {
             source = a.extra["dem"].get<std::string>();
             h = read_heightfield(source);
           } else {
             h = Heightfield(a.size, a.size);
             h.georef.cell_x = h.georef.cell_y = 30;
             for (int y = 0; y < a.size; ++y)
               for (int x = 0; x < a.size; ++x)
                 h.at(x, y) =
                     float(300 * std::sin(x * 0.013) * std::cos(y * 0.011) + 40 * std::sin(x * 0.1 + y * 0.07));
             source = "synthetic sines, 30 m cells";
           }
           auto dev = Device::open(a.device);
           fmt::print("render bench: {} x {} cells ({}), device {}; median of {} runs (wall s, process CPU s)\n",
                      h.width, h.height, source, dev->info().name, a.repeats);
           auto time = [&](const std::string& what, auto&& f) {
             f();  // warm-up: kernel build / cache load, first-touch of the output
             std::vector<double> wall;
             const std::clock_t c0 = std::clock();
             for (int k = 0; k < a.repeats; ++k) {
               const auto t0 = std::chrono::steady_clock::now();
               f();
               wall.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
             }
             std::sort(wall.begin(), wall.end());
             const double cpu = double(std::clock() - c0) / CLOCKS_PER_SEC / a.repeats;
             fmt::print("  {:<24} {:8.4f} s (cpu {:.4f} s)\n", what, wall[wall.size() / 2], cpu);
           };
           for (auto mode : {render::Mode::Hillshade, render::Mode::ShadedRelief, render::Mode::TRI}) {
             render::Options o;
             o.mode = mode;
             o.compute_edges = false;
             const std::string name = mode == render::Mode::Hillshade      ? "hillshade"
                                      : mode == render::Mode::ShadedRelief ? "shaded-relief"
                                                                           : "tri";
             if (mode == render::Mode::TRI) {
               time(name + " host", [&] { (void)render::values(h, o); });
               time(name + " device", [&] { (void)render::values(h, o, *dev); });
             } else {
               time(name + " host", [&] { (void)render::render(h, o); });
               time(name + " device", [&] { (void)render::render(h, o, *dev); });
             }
           }
           // The perspective view at its default size and camera (rays, shadows, haze).
           render::Options o;
           o.mode = render::Mode::Perspective;
           time("perspective 1024x640 host", [&] { (void)render::render_view(h, o); });
           time("perspective 1024x640 device", [&] { (void)render::render_view(h, o, *dev); });
         }});
}

}  // namespace terracl
