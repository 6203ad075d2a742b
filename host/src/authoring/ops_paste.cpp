// SPDX-License-Identifier: Apache-2.0
// copy_paste (paper section 4.1): gradients of a region of a source DEM (or gradient .exr) placed
// with an affine warp (translate, rotate, scale) into the target. Only gradients move, so the
// solve blends the pasted relief into its surroundings with no step at the boundary.
#include "authoring/state.hpp"

#include <terracl/error.hpp>
#include <terracl/gradient.hpp>
#include <terracl/io.hpp>

#include <fmt/format.h>

#include <filesystem>
#include <memory>

namespace terracl::edit {
namespace {

struct Source {
  GradientField g;  // staggered, m/m
};

float smoother(double t) {
  t = std::clamp(t, 0.0, 1.0);
  return float(t * t * t * (t * (t * 6 - 15) + 10));
}

// Bilinear sample of a staggered component stored at (i + ox, j + oy) (source cells), clamped to
// the valid faces [0, nx) x [0, ny).
float sample(const std::vector<float>& v, int W, int nx, int ny, double x, double y) {
  x = std::clamp(x, 0.0, double(nx - 1));
  y = std::clamp(y, 0.0, double(ny - 1));
  const int x0 = std::min(int(x), nx - 1), y0 = std::min(int(y), ny - 1);
  const int x1 = std::min(x0 + 1, nx - 1), y1 = std::min(y0 + 1, ny - 1);
  const double fx = x - x0, fy = y - y0;
  auto at = [&](int a, int b) { return double(v[size_t(b) * W + a]); };
  return float((1 - fy) * ((1 - fx) * at(x0, y0) + fx * at(x1, y0)) + fy * ((1 - fx) * at(x0, y1) + fx * at(x1, y1)));
}

Operation parse_copy_paste(Params& p) {
  const std::string path = operation_file(p, "source");
  auto src = std::make_shared<Source>();
  try {
    if (is_gradient_file(path)) {
      src->g = read_gradient(path);
    } else {
      Heightfield h = read_heightfield(path);
      if (h.count_nodata()) fill_nodata_harmonic(h);
      GradientField g(h.width, h.height);
      g.georef = h.georef;
      for (int y = 0; y < h.height; ++y)
        for (int x = 0; x < h.width; ++x) {
          const size_t o = size_t(y) * h.width + x;
          if (x + 1 < h.width) g.gx[o] = float((h.at(x + 1, y) - h.at(x, y)) / h.georef.cell_x);
          if (y + 1 < h.height) g.gy[o] = float((h.at(x, y + 1) - h.at(x, y)) / h.georef.cell_y);
        }
      src->g = std::move(g);
    }
  } catch (const Error& e) {
    param_error(p.where("source"), e.what());
  }
  const json& from = p.raw("from");
  if (!from.is_array() || from.size() != 4 || !std::all_of(from.begin(), from.end(), [](const json& v) { return v.is_number_integer(); }))
    param_error(p.where("from"), fmt::format("expected [x0, y0, width, height] in source pixels, got {}", from.dump()));
  const int fx0 = from[0], fy0 = from[1], fw = from[2], fh = from[3];
  if (fx0 < 0 || fy0 < 0 || fw < 2 || fh < 2 || fx0 + fw > src->g.width || fy0 + fh > src->g.height)
    param_error(p.where("from"), fmt::format("box [{}, {}, {}, {}] is not inside the {}x{} source (width, height >= 2)", fx0,
                                             fy0, fw, fh, src->g.width, src->g.height));
  const Vec2 to = p.point("to");
  const double rot = grid_angle(p.angle("rotate", 0.0));
  const double scale = p.number("scale", 1.0, 0.05, 20.0);
  const double hscale = p.number("height_scale", 1.0, -100.0, 100.0);
  const double scx = src->g.georef.cell_x, scy = src->g.georef.cell_y;
  const double half_w = fw * scx / 2, half_h = fh * scy / 2;  // source metres
  const double feather = p.hlength("feather", 0.1 * std::min(half_w, half_h) * 2 * scale, 0, false);
  p.note_reach(std::hypot(half_w, half_h) * scale);  // the pasted box around "to"
  return [=](EditState& s) {
    const Grid& g = s.grid();
    GradientField t = s.download();
    const double c = std::cos(rot), sn = std::sin(rot);
    const double cx = (fx0 + (fw - 1) / 2.0) * scx, cy = (fy0 + (fh - 1) / 2.0) * scy;  // source centre
    const double ext = std::hypot(half_w, half_h) * scale;
    const int x0 = std::max(0, cell_index(std::floor((to.x - ext) / g.cell_x)) - 1), x1 = std::min(g.width - 1, cell_index(std::ceil((to.x + ext) / g.cell_x)) + 1);
    const int y0 = std::max(0, cell_index(std::floor((to.y - ext) / g.cell_y)) - 1), y1 = std::min(g.height - 1, cell_index(std::ceil((to.y + ext) / g.cell_y)) + 1);
    const GradientField& sg = src->g;
    size_t pasted = 0;
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x)
        for (int comp = 0; comp < 2; ++comp) {
          if (comp == 0 && x == g.width - 1) continue;
          if (comp == 1 && y == g.height - 1) continue;
          const double px = (x + (comp == 0 ? 0.5 : 0.0)) * g.cell_x, py = (y + (comp == 1 ? 0.5 : 0.0)) * g.cell_y;
          // Target -> source: undo the translation, rotation and scale.
          const double dx = (px - to.x) / scale, dy = (py - to.y) / scale;
          const double lx = c * dx + sn * dy, ly = -sn * dx + c * dy;
          const double edge = std::min(half_w - std::abs(lx), half_h - std::abs(ly)) * scale;
          if (edge <= 0) continue;
          const float w = feather > 0 ? smoother(edge / feather) : 1.0f;
          const double qx = (cx + lx) / scx, qy = (cy + ly) / scy;  // source cells
          const double sgx = sample(sg.gx, sg.width, sg.width - 1, sg.height, qx - 0.5, qy);
          const double sgy = sample(sg.gy, sg.width, sg.width, sg.height - 1, qx, qy - 0.5);
          const double k = hscale / scale;
          const double v = comp == 0 ? k * (c * sgx - sn * sgy) : k * (sn * sgx + c * sgy);
          float& dst = (comp == 0 ? t.gx : t.gy)[size_t(y) * g.width + x];
          dst = (1 - w) * dst + w * float(v);
          ++pasted;
        }
    s.upload(t);
    s.log().back()["pasted_faces"] = pasted;
  };
}

}  // namespace

void add_paste_ops(std::vector<OpSpec>& ops) {
  ops.push_back({"copy_paste", "paste the gradients of a source DEM region with translation, rotation and scale",
                 parse_copy_paste});
}

}  // namespace terracl::edit
