// SPDX-License-Identifier: Apache-2.0
// PNG (8/16-bit codes mapped to a vertical range, libpng) and float EXR with terracl attributes
// (OpenEXR). PNG16 output is linear: integer codes written as-is, so no gamma or dither.
#include "io/checked_output.hpp"
#include "io/exr_codec.hpp"
#include "io/gradient_tiff.hpp"
#include "io/io_common.hpp"
#include "io/png_codec.hpp"

#include <terracl/error.hpp>
#include <terracl/memory.hpp>

#include <fmt/format.h>

#include <cmath>
#include <cstdlib>

namespace terracl::io {
namespace {

void apply_georef_attributes(const exr::Header& header, Georef& g, Metadata& md) {
  for (const auto& [name, value] : header.strings) {
    if (name == "terracl:georef") {
      try {
        georef_from_json(nlohmann::json::parse(value), g, "EXR attribute terracl:georef");
      } catch (const nlohmann::json::exception&) {
      }
    } else if (name.rfind("terracl:", 0) == 0) {
      md[name] = value;
    }
  }
}

exr::Attributes attributes(const Georef& g, const Metadata& md) {
  exr::Attributes a;
  a.strings.emplace_back("terracl:georef", georef_to_json(g).dump());
  a.floats.emplace_back("terracl:cell_x", float(g.cell_x));
  a.floats.emplace_back("terracl:cell_y", float(g.cell_y));
  a.strings.emplace_back("terracl:units", g.vertical_units);
  for (const auto& [k, v] : md) a.strings.emplace_back(k, v);
  a.strings.emplace_back("Software", "terracl");
  return a;
}

// Integer images hold codes; map them to metres with zmin + code/max_code*(zmax - zmin).
void decode_codes(const std::string& path, const ReadOptions& opts, bool sixteen, const char* kind,
                  const std::vector<uint16_t>& codes, Heightfield& h) {
  const double max_code = sixteen ? 65535.0 : 255.0;
  double zmin = 0.0, zmax = max_code;
  const nlohmann::json sc = read_sidecar(path);
  if (!sc.is_null()) {
    try {
      if (sc.contains("zmin")) zmin = sc.at("zmin").get<double>();
      if (sc.contains("zmax")) zmax = sc.at("zmax").get<double>();
    } catch (const nlohmann::json::exception& e) {
      fail("io", "{}: sidecar fields zmin/zmax must be numbers ({})", sidecar_path(path), e.what());
    }
    check_sidecar_size(sc, path, h.width, h.height);
    georef_from_json(sc, h.georef, sidecar_path(path));
    if (sc.contains("metadata") && sc["metadata"].is_object())
      for (auto& [k, v] : sc["metadata"].items())
        if (v.is_string()) h.metadata[k] = v.get<std::string>();
  }
  if (opts.zmin) zmin = *opts.zmin;
  if (opts.zmax) zmax = *opts.zmax;
  check_vertical_range(zmin, zmax, sc.is_null() ? path : sidecar_path(path));
  if (sc.is_null() && sixteen && !opts.zmin && !opts.zmax && !opts.cell_size) warn_sidecarless(path, kind);
  Quantiser q{zmin, zmax, max_code};
  if (sixteen) quantiser_from_sidecar(sc, q, sidecar_path(path));
  for (size_t i = 0; i < codes.size(); ++i) h.z[i] = q.decode(codes[i]);
  if (q.reserve_nodata && !h.georef.nodata) h.georef.nodata = double(NAN);
}

Heightfield read_png(const std::string& path, const ReadOptions& opts) {
  check_png_chunks(path);
  const png::Pixels px = png::read(path, [&](const png::Header& hd) {
    require_raster_size("io", path, hd.width, hd.height, 8);  // a PNG header may claim 100000^2
    // Grey + alpha reads the grey channel (alpha is transparency); any other second channel would
    // be dropped without a word.
    if (hd.channels > 2)
      fail("io", "{}: has {} channels; terracl reads single-channel elevation images: keep the elevation channel "
           "first (e.g. gdal_translate -b 1 {} elevation.png)", path, hd.channels, path);
  });
  const png::Header& hd = px.header;
  Heightfield h(hd.width, hd.height);
  std::vector<uint16_t> codes(h.size());
  for (size_t i = 0; i < codes.size(); ++i) codes[i] = px.sample(i * size_t(hd.channels));
  decode_codes(path, opts, hd.bit_depth == 16, "16-bit PNG", codes, h);
  return h;
}

Heightfield read_exr(const std::string& path, const ReadOptions& opts) {
  check_exr_header(path);
  exr::Reader in(path);
  const exr::Header& hd = in.header();
  if (hd.width <= 0 || hd.height <= 0) fail("io", "{}: image has no pixels", path);
  require_raster_size("io", path, hd.width, hd.height, 8);
  if (hd.channels.size() == 2)
    fail("io", "{}: is a gradient field (2 channels, gx and gy), not a heightfield; reconstruct it first "
         "(terracl reconstruct --gradient {} -o height.tif)", path, path);
  if (hd.channels.size() != 1)
    fail("io", "{}: has {} channels; terracl reads single-channel elevation images: keep the elevation channel "
         "first (e.g. oiiotool {} --ch 0 -o elevation.exr)", path, hd.channels.size(), path);
  Heightfield h(hd.width, hd.height);
  if (hd.all_float) {
    in.read_float(0, hd.height, hd.channels, h.z.data());
    apply_georef_attributes(hd, h.georef, h.metadata);
  } else {
    std::vector<uint32_t> wide(h.size());
    in.read_uint(0, hd.height, hd.channels[0], wide.data());
    std::vector<uint16_t> codes(h.size());
    for (size_t i = 0; i < codes.size(); ++i) codes[i] = uint16_t(std::min<uint32_t>(wide[i], 65535u));
    decode_codes(path, opts, true, "integer EXR", codes, h);
  }
  return h;
}

}  // namespace

Heightfield read_image(const std::string& path, const ReadOptions& opts) {
  Heightfield h = sniff_magic(path) == "EXR" ? read_exr(path, opts) : read_png(path, opts);
  if (opts.cell_size) h.georef.cell_x = h.georef.cell_y = *opts.cell_size;
  return h;
}

void write_png16(const Heightfield& h, const std::string& tmp_path, double zmin, double zmax) {
  std::vector<uint16_t> codes(h.size());
  const Quantiser q{zmin, zmax, 65535.0, h.count_nodata() > 0};
  for (size_t i = 0; i < codes.size(); ++i) codes[i] = q.encode(h.z[i]);
  CheckedImageFile file(tmp_path);
  png::write(file, h.width, h.height, 1, 16, codes.data(), {{"Software", "terracl"}}, true, "io");
  file.finish("io");
}

void write_exr(const Heightfield& h, const std::string& tmp_path) {
  CheckedImageFile file(tmp_path);
  exr::write_float(file, h.width, h.height, {"Y"}, h.z.data(), attributes(h.georef, h.metadata));
  file.finish("io");
}

// Rows [y0, y1) of a gradient EXR: EXR stores scanline chunks, so OpenEXR reads only the chunks
// of the band (the hypre solve's per-rank read). The georef is the whole raster's.
GradientField read_gradient_rows(const std::string& path, int y0, int y1, int* full_height) {
  require_readable(path);
  if (sniff_magic(path) == "TIFF") return read_gradient_geotiff_rows(path, y0, y1, full_height);
  if (sniff_magic(path) != "EXR")
    fail("io", "{}: a gradient field must be a two-channel float EXR or a two-band (gx, gy) GeoTIFF", path);
  check_exr_header(path);
  exr::Reader in(path);
  const exr::Header& hd = in.header();
  if (hd.channels.size() != 2)
    fail("io", "{}: a gradient field has 2 channels (gx, gy), this file has {}", path, hd.channels.size());
  require_raster_size("io", path, hd.width, hd.height, 16);
  if (full_height) *full_height = hd.height;
  if (y0 < 0 || y1 < y0 || y1 > hd.height)
    fail("io", "{}: rows [{}, {}) are outside the gradient's {} rows", path, y0, y1, hd.height);
  GradientField g(hd.width, y1 - y0);
  if (y1 > y0) {
    std::vector<float> px(size_t(hd.width) * size_t(y1 - y0) * 2);
    // Channels are stored alphabetically; gx/gy by name when the file has them.
    std::vector<std::string> names = hd.channels;
    if (names[0] == "gy" && names[1] == "gx") std::swap(names[0], names[1]);
    in.read_float(y0, y1, names, px.data());
    for (size_t i = 0; i < g.size(); ++i) {
      g.gx[i] = px[2 * i];
      g.gy[i] = px[2 * i + 1];
    }
  }
  apply_georef_attributes(hd, g.georef, g.metadata);
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
  try {
    return io::exr::Reader(path).header().channels.size() == 2;
  } catch (const Error&) {
    return false;
  }
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
  io::exr::Attributes attrs = io::attributes(g.georef, g.metadata);
  // As text: a float attribute would lose centimetres at mountain elevations.
  if (std::isfinite(g.mean_elevation)) attrs.strings.emplace_back("terracl:mean_elevation", fmt::format("{:.17g}", g.mean_elevation));
  write_atomically(path, [&](const std::string& tmp) {
    io::CheckedImageFile file(tmp);
    io::exr::write_float(file, g.width, g.height, {"gx", "gy"}, px.data(), attrs);
    file.finish("io");
  });
}

}  // namespace terracl
