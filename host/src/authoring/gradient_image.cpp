// SPDX-License-Identifier: Apache-2.0
// Gradient images (paper section 3): two 16-bit channels (r, g) = 2^(p-1) (1 + g/m), so that image
// tools can process gradients. m and the cell size travel in the JSON sidecar "<file>.json".
#include <terracl/edit.hpp>
#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/memory.hpp>

#include "io/checked_output.hpp"
#include "io/io_common.hpp"
#include "io/image_file.hpp"
#include "io/png_codec.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>

namespace terracl {

namespace {
constexpr int kBits = 16;
constexpr double kHalf = 32768.0;  // 2^(p-1)
}  // namespace

void write_gradient_image(const GradientField& g, const std::string& path) {
  if (g.width < 1 || g.height < 1) fail("gradient-image", "empty gradient field");
  double m = 0;
  for (size_t i = 0; i < g.size(); ++i) {
    if (!std::isfinite(g.gx[i]) || !std::isfinite(g.gy[i])) fail("gradient-image", "the gradient has NaN/Inf values");
    m = std::max({m, double(std::abs(g.gx[i])), double(std::abs(g.gy[i]))});
  }
  if (m == 0) m = 1;  // a flat field: any scale decodes to 0
  std::vector<uint16_t> px(g.size() * 2);
  auto enc = [&](float v) {
    const double c = std::round(kHalf * (1.0 + double(v) / m));
    return uint16_t(std::clamp(c, 0.0, 65535.0));
  };
  for (size_t i = 0; i < g.size(); ++i) px[2 * i] = enc(g.gx[i]), px[2 * i + 1] = enc(g.gy[i]);
  nlohmann::json sc = {{"terracl", "gradient-image"}, {"bits", kBits}, {"m", m},
                       {"width", g.width}, {"height", g.height}, {"cell_x", g.georef.cell_x},
                       {"cell_y", g.georef.cell_y}, {"encoding", "(r, g) = 2^(p-1) (1 + g/m), staggered faces"}};
  if (std::isfinite(g.mean_elevation)) sc["mean_elevation"] = g.mean_elevation;
  write_atomically(path, [&](const std::string& tmp) {
    // Two 16-bit channels make a grey + alpha PNG: its samples are stored as they are (unassociated).
    io::CheckedImageFile file(tmp);
    io::png::write(file, g.width, g.height, 2, 16, px.data(), {{"Software", "terracl"}}, true, "gradient-image");
    file.finish("gradient-image");
    // The sidecar (renamed after the image) names the image it was written for: an image beside
    // an older sidecar (a failed second rename) would decode with the wrong scale m.
    const io::FileDigest d = io::file_digest(tmp);
    sc["image_bytes"] = d.bytes;
    sc["image_fnv1a64"] = io::hex64(d.fnv1a);
  });
  write_text_file_atomic(path + ".json", sc.dump(2) + "\n");
}

GradientField read_gradient_image(const std::string& path) {
  std::ifstream sin(path + ".json");
  if (!sin) fail("gradient-image", "{}: the sidecar {}.json with the scale m is missing", path, path);
  nlohmann::json sc;
  try {
    sc = nlohmann::json::parse(sin);
  } catch (const nlohmann::json::exception& e) {
    fail("gradient-image", "{}.json: malformed JSON: {}", path, e.what());
  }
  io::check_sidecar_image(sc, path);
  if (!sc.contains("m") || !sc["m"].is_number() || !(sc["m"].get<double>() > 0))
    fail("gradient-image", "{}.json: needs \"m\" > 0 (the gradient scale)", path);
  const double m = sc["m"].get<double>();
  io::check_png_chunks(path);
  const io::png::Pixels px = io::png::read(path, [&](const io::png::Header& h) {
    if (h.channels < 2) fail("gradient-image", "{}: expected 2 channels, has {}", path, h.channels);
    require_raster_size("gradient-image", path, h.width, h.height, 16);
  }, "gradient-image");
  const int nch = px.header.channels;
  const double widen = px.header.bit_depth == 8 ? 257.0 : 1.0;  // an 8-bit copy (saved by an image editor)
  GradientField g(px.header.width, px.header.height);
  g.georef.cell_x = sc.value("cell_x", 1.0);
  g.georef.cell_y = sc.value("cell_y", 1.0);
  if (sc.contains("mean_elevation") && sc["mean_elevation"].is_number()) g.mean_elevation = sc["mean_elevation"].get<double>();
  for (size_t i = 0; i < g.size(); ++i) {
    g.gx[i] = float(m * (px.sample(i * nch) * widen / kHalf - 1.0));
    g.gy[i] = float(m * (px.sample(i * nch + 1) * widen / kHalf - 1.0));
  }
  return g;
}

}  // namespace terracl
