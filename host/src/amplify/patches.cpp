// SPDX-License-Identifier: Apache-2.0
// Disc-support patches (section 4.1-4.2 of the sparse terrain paper): extraction with the disc mean
// removed, and the weighted blend that turns patches back into a heightfield.
#include <terracl/amplify.hpp>
#include <terracl/error.hpp>

#include <cmath>

namespace terracl {

double disc_weight(double r) {
  if (r >= 1.0) return 0.0;
  const double a = 1.0 - r * r;
  return a * a * a;
}

std::vector<float> patch_weights(int size) {
  std::vector<float> w(size_t(size) * size);
  const double c = 0.5 * (size - 1), radius = 0.5 * size;
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x)
      w[size_t(y) * size + x] = float(disc_weight(std::hypot(x - c, y - c) / radius));
  return w;
}

std::vector<float> patch_mask(int size) {
  auto w = patch_weights(size);
  for (auto& v : w) v = v > 0 ? 1.f : 0.f;
  return w;
}

namespace {
std::vector<int> grid_positions(int extent, int size, int stride) {
  std::vector<int> p;
  for (int x = 0; x + size <= extent; x += stride) p.push_back(x);
  if (p.empty() || p.back() + size < extent) p.push_back(extent - size);
  return p;
}
}  // namespace

MatrixF extract_patches(const Heightfield& h, int size, int stride, std::vector<float>* means,
                        std::vector<std::pair<int, int>>* positions) {
  if (size < 2 || stride < 1) fail("patches", "patch size must be >= 2 and stride >= 1 (got {} and {})", size, stride);
  if (h.width < size || h.height < size)
    fail("patches", "a {}x{} grid is smaller than one {}x{} patch", h.width, h.height, size, size);
  const auto xs = grid_positions(h.width, size, stride), ys = grid_positions(h.height, size, stride);
  const auto mask = patch_mask(size);
  double msum = 0;
  for (float m : mask) msum += m;
  const size_t K = size_t(size) * size;
  MatrixF F(K, xs.size() * ys.size());
  if (means) means->assign(F.cols(), 0.f);
  if (positions) positions->clear();
  size_t i = 0;
  for (int y : ys)
    for (int x : xs) {
      double mean = 0;
      for (int v = 0; v < size; ++v)
        for (int u = 0; u < size; ++u) mean += mask[size_t(v) * size + u] * h.at(x + u, y + v);
      mean /= msum;
      for (int v = 0; v < size; ++v)
        for (int u = 0; u < size; ++u) {
          const size_t k = size_t(v) * size + u;
          F(k, i) = float(mask[k] * (h.at(x + u, y + v) - mean));
        }
      if (means) (*means)[i] = float(mean);
      if (positions) positions->push_back({x, y});
      ++i;
    }
  return F;
}

Heightfield blend_patches(int width, int height, int size, const MatrixF& patches, const std::vector<float>& means,
                          const std::vector<std::pair<int, int>>& positions) {
  const auto w = patch_weights(size);
  std::vector<double> num(size_t(width) * height, 0.0), den(num.size(), 0.0);
  for (size_t i = 0; i < positions.size(); ++i) {
    const auto [px, py] = positions[i];
    for (int v = 0; v < size; ++v) {
      const int y = py + v;
      if (y < 0 || y >= height) continue;
      for (int u = 0; u < size; ++u) {
        const int x = px + u;
        if (x < 0 || x >= width) continue;
        const size_t k = size_t(v) * size + u;
        num[size_t(y) * width + x] += w[k] * (means[i] + patches(k, i));
        den[size_t(y) * width + x] += w[k];
      }
    }
  }
  Heightfield out(width, height);
  for (size_t j = 0; j < num.size(); ++j) out.z[j] = den[j] > 0 ? float(num[j] / den[j]) : NAN;
  return out;
}

}  // namespace terracl
