// A plain hillshade preview for `terracl edit --preview` (the render module, when present, draws
// nicer pictures; this one only needs the heights).
#include <terracl/edit.hpp>
#include <terracl/error.hpp>
#include <terracl/io.hpp>

#include <OpenImageIO/imageio.h>

#include <cmath>

namespace terracl {

void write_hillshade_png(const Heightfield& h, const std::string& path) {
  if (h.width < 2 || h.height < 2) fail("preview", "terrain too small for a hillshade");
  const double az = 315 * M_PI / 180, alt = 45 * M_PI / 180;
  // Light direction in the grid frame (x east, y south): north-west is (-1, -1).
  const double lx = std::cos(alt) * std::sin(az), ly = -std::cos(alt) * std::cos(az), lz = std::sin(alt);
  std::vector<uint8_t> px(h.size());
  for (int y = 0; y < h.height; ++y)
    for (int x = 0; x < h.width; ++x) {
      const int x0 = std::max(0, x - 1), x1 = std::min(h.width - 1, x + 1);
      const int y0 = std::max(0, y - 1), y1 = std::min(h.height - 1, y + 1);
      double dzdx = (h.at(x1, y) - h.at(x0, y)) / ((x1 - x0) * h.georef.cell_x);
      double dzdy = (h.at(x, y1) - h.at(x, y0)) / ((y1 - y0) * h.georef.cell_y);
      if (!std::isfinite(dzdx)) dzdx = 0;
      if (!std::isfinite(dzdy)) dzdy = 0;
      // Normal (-dz/dx, -dz/dy, 1); light towards the sun.
      const double n = std::sqrt(dzdx * dzdx + dzdy * dzdy + 1);
      const double shade = std::max(0.0, (-dzdx * lx - dzdy * ly + lz) / n);
      px[size_t(y) * h.width + x] = uint8_t(std::lround(30 + 225 * shade));
    }
  write_atomically(path, [&](const std::string& tmp) {
    std::unique_ptr<OIIO::ImageOutput> out = OIIO::ImageOutput::create(tmp);
    if (!out) fail("preview", "{}: cannot create an image writer", path);
    OIIO::ImageSpec spec(h.width, h.height, 1, OIIO::TypeDesc::UINT8);
    if (!out->open(tmp, spec) || !out->write_image(OIIO::TypeDesc::UINT8, px.data()) || !out->close())
      fail("preview", "{}: write failed: {}", path, out->geterror());
  });
}

}  // namespace terracl
