// SPDX-License-Identifier: Apache-2.0
// Water over a rendered picture (edit previews with lakes): the picture's own shading stays
// visible under the tint, so a lake reads as water over its bed rather than as a flat blue shape.
#include <terracl/error.hpp>
#include <terracl/render.hpp>

#include <algorithm>
#include <cmath>

namespace terracl::render {

void tint_water(Image& img, const Heightfield& depth) {
  if (img.width != depth.width || img.height != depth.height)
    fail("render", "water tint: a {}x{} depth layer over a {}x{} picture", depth.width, depth.height, img.width, img.height);
  double deepest = 0;
  for (float d : depth.z)
    if (d > 0) deepest = std::max(deepest, double(d));  // NaN compares false: dry
  if (!(deepest > 0)) return;
  if (img.channels < 3) {  // grey (+ alpha) -> RGB (+ alpha)
    const bool alpha = img.channels == 2;
    std::vector<uint8_t> rgb(size_t(img.width) * img.height * (alpha ? 4 : 3));
    for (size_t i = 0, n = size_t(img.width) * img.height; i < n; ++i) {
      const uint8_t* s = &img.pixels[i * img.channels];
      uint8_t* o = &rgb[i * (alpha ? 4 : 3)];
      o[0] = o[1] = o[2] = s[0];
      if (alpha) o[3] = s[1];
    }
    img.pixels = std::move(rgb);
    img.channels = alpha ? 4 : 3;
  }
  // Shallow water pale cyan, the deepest a dark blue; the ground's shading shows at 1 - opacity.
  const double shallow[3] = {120, 190, 235}, deep[3] = {20, 60, 150};
  for (size_t i = 0, n = depth.z.size(); i < n; ++i) {
    const double d = depth.z[i];
    if (!(d > 0)) continue;
    const double t = std::sqrt(std::min(1.0, d / deepest));  // shallows distinct near the shore
    const double a = 0.55 + 0.3 * t;
    uint8_t* px = &img.pixels[i * img.channels];
    for (int c = 0; c < 3; ++c) {
      const double water = shallow[c] + t * (deep[c] - shallow[c]);
      px[c] = uint8_t(std::clamp(std::lround((1 - a) * px[c] + a * water), 0L, 255L));
    }
  }
}

}  // namespace terracl::render
