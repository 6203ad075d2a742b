// SPDX-License-Identifier: Apache-2.0
// The studio's Export dialog (docs/studio.md): the canonical terrain in a format and an engine
// size, and the masks the session can make, as 16-bit PNGs of the same size whose sidecars give the
// value of code 65535.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <terracl/analysis.hpp>
#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/mesh.hpp>
#include <terracl/render.hpp>
#include <terracl/warp.hpp>

#include "studio/session.hpp"

namespace fs = std::filesystem;

namespace terracl::studio {
namespace {

struct Format {
  const char* name;
  const char* ext;
};
constexpr Format kFormats[] = {{"tif", ".tif"}, {"png16", ".png"}, {"exr", ".exr"}, {"r16", ".r16"}, {"glb", ".glb"}};
constexpr const char* kMasks[] = {"flow", "slope", "wear", "deposition", "water"};

// A shaded relief of `h` as PNG bytes: the colours a glb's material drapes over its mesh.
std::vector<unsigned char> texture_png(const Heightfield& h, Device& device, const std::string& tmp) {
  render::Options ro;
  ro.mode = render::Mode::ShadedRelief;
  render::write_image(render::render(h, ro, device), tmp);
  std::ifstream in(tmp, std::ios::binary);
  std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  fs::remove(tmp);
  return bytes;
}

}  // namespace

json Session::export_set(const json& req) {
  if (!req.is_object() || !req.contains("name") || !req["name"].is_string())
    throw RequestError(400, "/name: expected a file name (without extension) inside the workspace");
  std::string name = req["name"].get<std::string>();
  for (const Format& f : kFormats)  // "terrain.tif" means "terrain"
    if (fs::path(name).extension() == f.ext) name = fs::path(name).replace_extension().string();
  const std::string format = req.value("format", std::string("tif"));
  const Format* fmt_ = nullptr;
  for (const Format& f : kFormats)
    if (format == f.name) fmt_ = &f;
  if (!fmt_) throw RequestError(400, fmt::format("/format: '{}': expected tif, png16, exr, r16 or glb", format));
  std::optional<int> size;
  if (req.contains("preset") && !req["preset"].is_null()) {
    if (!req["preset"].is_string()) throw RequestError(400, "/preset: expected an engine preset name");
    try {
      size = engine_preset_size(req["preset"].get<std::string>(), "export");
    } catch (const Error& e) {
      throw RequestError(400, std::string("/preset: ") + e.what());
    }
  }
  std::vector<std::string> masks;
  if (req.contains("masks")) {
    if (!req["masks"].is_array()) throw RequestError(400, "/masks: expected a list of mask names");
    for (size_t i = 0; i < req["masks"].size(); ++i) {
      const json& m = req["masks"][i];
      const std::string where = fmt::format("/masks/{}", i);
      if (!m.is_string() || std::find(std::begin(kMasks), std::end(kMasks), m.get<std::string>()) == std::end(kMasks))
        throw RequestError(400, fmt::format("{}: {}: expected flow, slope, wear, deposition or water", where, m.dump()));
      masks.push_back(m.get<std::string>());
    }
  }
  // Every path is checked (inside the workspace) before anything is written.
  const std::string terrain_path = resolve(name + fmt_->ext, false);
  std::vector<std::string> mask_paths;
  for (const std::string& m : masks) mask_paths.push_back(resolve(fmt::format("{}_{}.png", name, m), false));

  Heightfield h = canonical();  // m_edit is now the canonical replay: its layers are the script's
  h.georef = m_base.georef;
  h.metadata = m_base.metadata;
  h.metadata["terracl:edit_script"] = script().dump();
  const std::optional<Heightfield> change = m_edit->erosion_change();
  const std::optional<Heightfield> water = m_edit->water();
  for (size_t i = 0; i < masks.size(); ++i) {
    const std::string where = fmt::format("/masks/{}", i);
    if ((masks[i] == "wear" || masks[i] == "deposition") && !change)
      throw RequestError(400, fmt::format("{}: {} needs an erode layer in the script", where, masks[i]));
    if (masks[i] == "water" && !water) throw RequestError(400, fmt::format("{}: water needs a lake layer in the script", where));
  }
  auto sized = [&](Heightfield f) {
    f.georef = h.georef;
    return size ? resize(f, *size, *size, "bilinear", {}, "export") : f;
  };

  json out = {{"written", json::array()}, {"masks", json::object()}};
  fs::create_directories(fs::path(terrain_path).parent_path());
  Heightfield t = sized(h);
  t.metadata = h.metadata;
  if (fmt_->name == std::string("glb")) {
    mesh::Mesh m = mesh::triangulate_simplified(t, 0.5);
    m.texture_png = texture_png(t, m_device, terrain_path + ".texture.png");
    mesh::write_mesh(m, terrain_path, t.metadata, &t);
  } else {
    if (!size) restore_nodata(t, m_nodata);  // as `terracl edit` writes it
    write_heightfield(t, terrain_path);
  }
  out["written"].push_back(terrain_path);
  out["size"] = {t.width, t.height};

  for (size_t i = 0; i < masks.size(); ++i) {
    const std::string& m = masks[i];
    Heightfield v(h.width, h.height);
    std::string unit = "m";
    if (m == "slope") {
      v.z = analysis::slope_degrees(h);
      unit = "degrees";
    } else if (m == "flow") {
      // log10 of the D-infinity contributing area: channels stand out over the hillslopes.
      const analysis::DinfResult f = analysis::dinf_flow(h);
      for (size_t k = 0; k < v.z.size(); ++k) v.z[k] = float(std::log10(std::max(1.0, f.cells[k] * f.cell_area_m2)));
      unit = "log10(m^2)";
    } else if (m == "wear" || m == "deposition") {
      const float sign = m == "wear" ? -1.f : 1.f;
      for (size_t k = 0; k < v.z.size(); ++k) v.z[k] = std::max(0.f, sign * change->z[k]);
    } else {
      v.z = water->z;
    }
    for (float& z : v.z)
      if (!std::isfinite(z)) z = 0;
    v = sized(v);
    float top = 0;
    for (float& z : v.z) top = std::max(top, z = std::max(0.f, z));
    WriteOptions wo;
    wo.zmin = 0;
    wo.zmax = top > 0 ? double(top) : 1.0;  // code 65535 is the largest value
    write_heightfield(v, mask_paths[i], wo);
    out["written"].push_back(mask_paths[i]);
    out["masks"][m] = {{"max", top}, {"unit", unit}};
  }
  return out;
}

}  // namespace terracl::studio
