#include <terracl/error.hpp>
#include <terracl/heightfield.hpp>

#include <algorithm>
#include <cmath>

namespace terracl {

void Georef::update_metric_cell_size(int width, int height) {
  if (!has_geotransform) {
    cell_x = cell_y = 1.0;
    return;
  }
  const double dx = std::hypot(geotransform[1], geotransform[4]);
  const double dy = std::hypot(geotransform[2], geotransform[5]);
  if (!geographic) {
    cell_x = dx;
    cell_y = dy;
    return;
  }
  // WGS84 radii of curvature at the centre latitude: meridional M for north-south, prime
  // vertical N cos(phi) for east-west. Good to ~0.1 % across an SRTM tile.
  const double a = 6378137.0, f = 1.0 / 298.257223563, e2 = f * (2 - f);
  const double lat_c = geotransform[3] + geotransform[5] * height * 0.5 + geotransform[4] * width * 0.5;
  const double phi = lat_c * M_PI / 180.0;
  const double s2 = std::sin(phi) * std::sin(phi);
  const double M = a * (1 - e2) / std::pow(1 - e2 * s2, 1.5);
  const double N = a / std::sqrt(1 - e2 * s2);
  cell_x = dx * M_PI / 180.0 * N * std::cos(phi);
  cell_y = dy * M_PI / 180.0 * M;
}

Georef Georef::resampled(double factor) const {
  Georef g = *this;
  for (int i : {1, 2, 4, 5}) g.geotransform[i] /= factor;
  g.cell_x /= factor;
  g.cell_y /= factor;
  return g;
}

size_t Heightfield::count_nodata() const {
  return size_t(std::count_if(z.begin(), z.end(), [](float v) { return !std::isfinite(v); }));
}

HeightStats compute_stats(const Heightfield& h) {
  HeightStats s;
  double sum = 0;
  s.min = INFINITY;
  s.max = -INFINITY;
  for (float v : h.z) {
    if (!std::isfinite(v)) {
      ++s.nodata;
      continue;
    }
    ++s.valid;
    sum += v;
    s.min = std::min<double>(s.min, v);
    s.max = std::max<double>(s.max, v);
  }
  if (s.valid == 0) {
    s.min = s.max = s.mean = NAN;
    return s;
  }
  s.mean = sum / double(s.valid);
  // Slope by central differences in the interior (one-sided at borders), in metric units.
  double slope_sum = 0, slope_max = 0;
  size_t n = 0;
  const double cx = h.georef.cell_x, cy = h.georef.cell_y;
  for (int y = 0; y < h.height; ++y)
    for (int x = 0; x < h.width; ++x) {
      if (h.width < 2 || h.height < 2) break;
      const int x0 = std::max(0, x - 1), x1 = std::min(h.width - 1, x + 1);
      const int y0 = std::max(0, y - 1), y1 = std::min(h.height - 1, y + 1);
      const double a = h.at(x1, y), b = h.at(x0, y), c = h.at(x, y1), d = h.at(x, y0);
      if (!std::isfinite(a + b + c + d)) continue;
      const double gx = (a - b) / ((x1 - x0) * cx), gy = (c - d) / ((y1 - y0) * cy);
      const double deg = std::atan(std::hypot(gx, gy)) * 180.0 / M_PI;
      slope_sum += deg;
      slope_max = std::max(slope_max, deg);
      ++n;
    }
  s.mean_slope_deg = n ? slope_sum / double(n) : 0.0;
  s.max_slope_deg = slope_max;
  return s;
}

void require_finite(const Heightfield& h, const std::string& stage, const std::string& what) {
  const size_t bad = h.count_nodata();
  if (bad)
    fail(stage, "{} has {} nodata/NaN cell{} of {}; this stage needs a complete grid (use --fill-nodata)", what, bad,
         bad == 1 ? "" : "s", h.size());
}

void fill_nodata_harmonic(Heightfield& h) {
  const size_t bad = h.count_nodata();
  if (bad == 0) return;
  if (bad == h.size()) fail("fill-nodata", "every cell is nodata; nothing to interpolate from");
  // Gauss-Seidel on the holes only, started from the mean of the valid cells. Holes in real DEMs
  // are small, so a few hundred sweeps over just the hole cells converge quickly.
  std::vector<size_t> holes;
  double sum = 0;
  size_t valid = 0;
  for (size_t i = 0; i < h.z.size(); ++i) {
    if (std::isfinite(h.z[i])) {
      sum += h.z[i];
      ++valid;
    } else {
      holes.push_back(i);
    }
  }
  const float mean = float(sum / double(valid));
  for (size_t i : holes) h.z[i] = mean;
  const int W = h.width, H = h.height;
  for (int it = 0; it < 5000; ++it) {
    double change = 0;
    for (size_t i : holes) {
      const int x = int(i % W), y = int(i / W);
      double s = 0;
      int k = 0;
      if (x > 0) s += h.z[i - 1], ++k;
      if (x + 1 < W) s += h.z[i + 1], ++k;
      if (y > 0) s += h.z[i - W], ++k;
      if (y + 1 < H) s += h.z[i + W], ++k;
      const float v = float(s / k);
      change = std::max(change, double(std::fabs(v - h.z[i])));
      h.z[i] = v;
    }
    if (change < 1e-4) break;
  }
}

}  // namespace terracl
