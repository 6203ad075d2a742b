// SPDX-License-Identifier: Apache-2.0
// `crop`: a window of a heightfield, keeping its georeferencing. Demos and tests use it to run
// heavy stages (amplify, erode) on a part of a tile.
#include <terracl/error.hpp>

#include <cstdint>

#include "pipeline/builtin.hpp"

namespace terracl {
namespace {

void run_crop(StageContext& c) {
  Heightfield& h = c.height();
  // 64-bit: x 2147483647 + width 2 wrapped negative in int and passed the check.
  const int64_t x0 = c.get<int64_t>("x"), y0 = c.get<int64_t>("y");
  const int64_t w = c.has("width") ? c.get<int64_t>("width") : h.width - x0;
  const int64_t ht = c.has("height") ? c.get<int64_t>("height") : h.height - y0;
  if (x0 < 0 || y0 < 0 || w < 1 || ht < 1 || x0 + w > h.width || y0 + ht > h.height)
    fail(c.tag,
         "window x {}..{}, y {}..{} does not fit in the {} x {} raster (x and y start at 0; width and height >= 1)", x0,
         x0 + w - 1, y0, y0 + ht - 1, h.width, h.height);
  Heightfield out{int(w), int(ht)};
  for (int y = 0; y < ht; ++y)
    for (int x = 0; x < w; ++x) out.at(x, y) = h.at(int(x0) + x, int(y0) + y);
  out.georef = h.georef;
  out.metadata = h.metadata;
  if (h.georef.has_geotransform) {
    auto& gt = out.georef.geotransform;
    gt[0] += x0 * gt[1] + y0 * gt[2];
    gt[3] += x0 * gt[4] + y0 * gt[5];
    // A geographic window has its own centre latitude; a projected one keeps the metric cell size,
    // which update_metric_cell_size would reset to map units (feet in a US State Plane CRS).
    if (out.georef.geographic) out.georef.update_metric_cell_size(int(w), int(ht));
  }
  h = std::move(out);
}

}  // namespace

void register_crop_stage(StageRegistry& r) {
  r.add({"crop",
         "Cut a window out of a heightfield, keeping its georeferencing (the window's own metric cell size).",
         DataKind::Heightfield,
         DataKind::Heightfield,
         {OptionSpec{"x", OptionType::Int, 0, "cells", "First column of the window (0 = west edge)"}.range(0, {}),
          OptionSpec{"y", OptionType::Int, 0, "cells", "First row of the window (0 = north edge)"}.range(0, {}),
          OptionSpec{"width", OptionType::Int, nullptr, "cells", "Window width (default: to the east edge)"}.range(1, {}),
          OptionSpec{"height", OptionType::Int, nullptr, "cells", "Window height (default: to the south edge)"}.range(1, {})},
         run_crop});
}

}  // namespace terracl
