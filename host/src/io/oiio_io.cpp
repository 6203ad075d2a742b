// SPDX-License-Identifier: Apache-2.0
// OpenImageIO backend: PNG (8/16-bit codes mapped to a vertical range) and float EXR with
// terracl attributes. PNG16 output is linear: integer codes written as-is, so no gamma or dither.
#include "io/io_common.hpp"
#include "io/gradient_tiff.hpp"
#include "io/oiio_checked.hpp"

#include <terracl/error.hpp>
#include <terracl/memory.hpp>

#include <OpenImageIO/imageio.h>
#include <fmt/format.h>

#include <cmath>
#include <cstdlib>

namespace terracl::io {
namespace {

using OIIO::ImageInput;
using OIIO::ImageOutput;
using OIIO::ImageSpec;
using OIIO::TypeDesc;

void apply_georef_attributes(const ImageSpec& spec, Georef& g, Metadata& md) {
  if (const auto* p = spec.find_attribute("terracl:georef", TypeDesc::STRING)) {
    try {
      georef_from_json(nlohmann::json::parse(p->get_string()), g, "EXR attribute terracl:georef");
    } catch (const nlohmann::json::exception&) {
    }
  }
  for (const auto& a : spec.extra_attribs) {
    const std::string name = a.name().string();
    if (name.rfind("terracl:", 0) == 0 && name != "terracl:georef" && a.type() == TypeDesc::STRING)
      md[name] = a.get_string();
  }
}

void set_attributes(ImageSpec& spec, const Georef& g, const Metadata& md) {
  spec.attribute("terracl:georef", georef_to_json(g).dump());
  spec.attribute("terracl:cell_x", float(g.cell_x));
  spec.attribute("terracl:cell_y", float(g.cell_y));
  spec.attribute("terracl:units", g.vertical_units);
  for (const auto& [k, v] : md) spec.attribute(k, v);
  spec.attribute("Software", "terracl");
  // Without a DateTime, the EXR writer stamps the wall-clock time (capDate), so the same input
  // would give different bytes on every run (DESIGN: determinism).
  if (!md.count("DateTime")) spec.attribute("DateTime", "");
}

}  // namespace

Heightfield read_oiio(const std::string& path, const ReadOptions& opts) {
  const std::string magic = sniff_magic(path);
  if (magic == "EXR") check_exr_header(path);
  if (magic == "PNG") check_png_chunks(path);
  auto in = ImageInput::open(path);
  if (!in) fail("io", "{}: not an image OpenImageIO can read ({})", path, OIIO::geterror());
  const ImageSpec& spec = in->spec();
  if (spec.width <= 0 || spec.height <= 0) fail("io", "{}: image has no pixels", path);
  require_raster_size("io", path, spec.width, spec.height, 8);  // a PNG header may claim 100000^2
  if (io::sniff_magic(path) == "EXR" && spec.nchannels == 2)
    fail("io", "{}: is a gradient field (2 channels, gx and gy), not a heightfield; reconstruct it first "
         "(terracl reconstruct --gradient {} -o height.tif)", path, path);
  // Grey + alpha reads the grey channel (alpha is transparency); any other second channel would be
  // dropped without a word.
  const bool grey_alpha = magic == "PNG" && spec.nchannels == 2 && spec.alpha_channel == 1;
  if (spec.nchannels > 1 && !grey_alpha)
    fail("io", "{}: has {} channels; terracl reads single-channel elevation images: keep the elevation channel "
         "first (e.g. oiiotool {} --ch 0 -o elevation{})", path, spec.nchannels, path,
         magic == "EXR" ? ".exr" : ".png");
  Heightfield h(spec.width, spec.height);
  const bool is_float = spec.format.basetype == TypeDesc::FLOAT || spec.format.basetype == TypeDesc::HALF ||
                        spec.format.basetype == TypeDesc::DOUBLE;
  if (is_float) {
    if (!in->read_image(0, 0, 0, 1, TypeDesc::FLOAT, h.z.data()))
      fail("io", "{}: reading pixels failed: {}", path, in->geterror());
    apply_georef_attributes(spec, h.georef, h.metadata);
  } else {
    // Integer images hold codes; map them to metres with zmin + code/max_code*(zmax - zmin).
    const bool sixteen = spec.format.size() >= 2;
    const double max_code = sixteen ? 65535.0 : 255.0;
    std::vector<uint16_t> codes(h.size());
    if (!in->read_image(0, 0, 0, 1, TypeDesc::UINT16, codes.data()))
      fail("io", "{}: reading pixels failed: {}", path, in->geterror());
    // OIIO rescales 8-bit to the full 16-bit range on read; undo that so 8-bit codes stay 0..255.
    const double scale_back = sixteen ? 1.0 : 255.0 / 65535.0;
    double zmin = 0.0, zmax = max_code;
    const nlohmann::json sc = read_sidecar(path);
    if (!sc.is_null()) {
      try {
        if (sc.contains("zmin")) zmin = sc.at("zmin").get<double>();
        if (sc.contains("zmax")) zmax = sc.at("zmax").get<double>();
      } catch (const nlohmann::json::exception& e) {
        fail("io", "{}: sidecar fields zmin/zmax must be numbers ({})", sidecar_path(path), e.what());
      }
      check_sidecar_size(sc, path, spec.width, spec.height);
      georef_from_json(sc, h.georef, sidecar_path(path));
      if (sc.contains("metadata") && sc["metadata"].is_object())
        for (auto& [k, v] : sc["metadata"].items())
          if (v.is_string()) h.metadata[k] = v.get<std::string>();
    }
    if (opts.zmin) zmin = *opts.zmin;
    if (opts.zmax) zmax = *opts.zmax;
    check_vertical_range(zmin, zmax, sc.is_null() ? path : sidecar_path(path));
    if (sc.is_null() && sixteen && !opts.zmin && !opts.zmax && !opts.cell_size) warn_sidecarless(path, magic == "EXR" ? "integer EXR" : "16-bit PNG");
    Quantiser q{zmin, zmax, max_code};
    if (sixteen) quantiser_from_sidecar(sc, q, sidecar_path(path));
    for (size_t i = 0; i < codes.size(); ++i) h.z[i] = q.decode(unsigned(std::round(codes[i] * scale_back)));
    if (q.reserve_nodata && !h.georef.nodata) h.georef.nodata = double(NAN);
  }
  if (opts.cell_size) h.georef.cell_x = h.georef.cell_y = *opts.cell_size;
  in->close();
  return h;
}

void write_png16(const Heightfield& h, const std::string& tmp_path, double zmin, double zmax) {
  std::vector<uint16_t> codes(h.size());
  const Quantiser q{zmin, zmax, 65535.0, h.count_nodata() > 0};
  for (size_t i = 0; i < codes.size(); ++i) codes[i] = q.encode(h.z[i]);
  ImageSpec spec(h.width, h.height, 1, TypeDesc::UINT16);
  spec.attribute("oiio:ColorSpace", "Linear");
  spec.attribute("Software", "terracl");
  write_image_checked(tmp_path, spec, TypeDesc::UINT16, codes.data());
}

void write_exr(const Heightfield& h, const std::string& tmp_path) {
  ImageSpec spec(h.width, h.height, 1, TypeDesc::FLOAT);
  spec.channelnames = {"Y"};
  spec.attribute("compression", "zip");
  set_attributes(spec, h.georef, h.metadata);
  write_image_checked(tmp_path, spec, TypeDesc::FLOAT, h.z.data());
}


// Rows [y0, y1) of a gradient EXR: EXR stores scanline chunks, so OpenImageIO reads only the chunks
// of the band (the hypre solve's per-rank read). The georef is the whole raster's.
GradientField read_gradient_rows(const std::string& path, int y0, int y1, int* full_height) {
  require_readable(path);
  if (sniff_magic(path) == "TIFF") return read_gradient_geotiff_rows(path, y0, y1, full_height);
  if (sniff_magic(path) != "EXR")
    fail("io", "{}: a gradient field must be a two-channel float EXR or a two-band (gx, gy) GeoTIFF", path);
  check_exr_header(path);
  auto in = OIIO::ImageInput::open(path);
  if (!in) fail("io", "{}: cannot open EXR ({})", path, OIIO::geterror());
  const OIIO::ImageSpec& spec = in->spec();
  if (spec.nchannels != 2)
    fail("io", "{}: a gradient field has 2 channels (gx, gy), this file has {}", path, spec.nchannels);
  require_raster_size("io", path, spec.width, spec.height, 16);
  if (full_height) *full_height = spec.height;
  if (y0 < 0 || y1 < y0 || y1 > spec.height)
    fail("io", "{}: rows [{}, {}) are outside the gradient's {} rows", path, y0, y1, spec.height);
  GradientField g(spec.width, y1 - y0);
  if (y1 > y0) {
    std::vector<float> px(size_t(spec.width) * size_t(y1 - y0) * 2);
    if (!in->read_scanlines(0, 0, spec.y + y0, spec.y + y1, 0, 0, 2, OIIO::TypeDesc::FLOAT, px.data()))
      fail("io", "{}: reading pixels failed: {}", path, in->geterror());
    // Channel order on disk is alphabetical in EXR; find gx/gy by name when present.
    int ix = 0, iy = 1;
    if (spec.channelnames.size() == 2 && spec.channelnames[0] == "gy") std::swap(ix, iy);
    for (size_t i = 0; i < g.size(); ++i) {
      g.gx[i] = px[2 * i + ix];
      g.gy[i] = px[2 * i + iy];
    }
  }
  apply_georef_attributes(spec, g.georef, g.metadata);
  if (auto it = g.metadata.find("terracl:mean_elevation"); it != g.metadata.end()) {
    g.mean_elevation = std::strtod(it->second.c_str(), nullptr);
    g.metadata.erase(it);
  }
  for (size_t i = 0; i < g.size(); ++i)
    if (!std::isfinite(g.gx[i]) || !std::isfinite(g.gy[i]))
      fail("io", "{}: gradient has a non-finite value at cell ({}, {})", path, i % g.width, y0 + i / g.width);
  return g;
}

}  // namespace terracl::io

namespace terracl {

bool is_gradient_file(const std::string& path) {
  if (io::sniff_magic(path) == "TIFF") return io::is_gradient_geotiff(path);
  if (io::sniff_magic(path) != "EXR") return false;
  io::check_exr_header(path);
  auto in = OIIO::ImageInput::open(path);
  if (!in) return false;
  return in->spec().nchannels == 2;
}

GradientField read_gradient(const std::string& path) {
  int height = 0;
  io::read_gradient_rows(path, 0, 0, &height);
  return io::read_gradient_rows(path, 0, height);
}

void write_gradient(const GradientField& g, const std::string& path) {
  if (format_from_extension(path) == FileFormat::GeoTIFF) return io::write_gradient_geotiff(g, path);
  if (format_from_extension(path) != FileFormat::EXR)
    fail("io", "{}: gradient fields are written as .exr (two float channels) or .tif (two float32 bands)", path);
  io::require_writable_folder(path);
  std::vector<float> px(g.size() * 2);
  for (size_t i = 0; i < g.size(); ++i) {
    px[2 * i] = g.gx[i];
    px[2 * i + 1] = g.gy[i];
  }
  OIIO::ImageSpec spec(g.width, g.height, 2, OIIO::TypeDesc::FLOAT);
  spec.channelnames = {"gx", "gy"};
  spec.attribute("compression", "zip");
  io::set_attributes(spec, g.georef, g.metadata);
  // As text: a float attribute would lose centimetres at mountain elevations.
  if (std::isfinite(g.mean_elevation)) spec.attribute("terracl:mean_elevation", fmt::format("{:.17g}", g.mean_elevation));
  write_atomically(path,
                   [&](const std::string& tmp) { io::write_image_checked(tmp, spec, OIIO::TypeDesc::FLOAT, px.data()); });
}

}  // namespace terracl
