// SPDX-License-Identifier: Apache-2.0
// Launchers of kernels/noise.cl.
#include <terracl/error.hpp>
#include <terracl/noise.hpp>

#include "cl/row_launch.hpp"

#include <algorithm>
#include <cmath>

namespace terracl {

NoiseType parse_noise_type(const std::string& s) {
  if (s == "perlin") return NoiseType::Perlin;
  if (s == "fbm") return NoiseType::Fbm;
  if (s == "ridged") return NoiseType::Ridged;
  fail("noise", "unknown noise type '{}' (expected perlin, fbm or ridged)", s);
}

namespace {
void check(const NoiseParams& p) {
  if (!(p.wavelength > 0)) fail("noise", "wavelength must be > 0 m, got {}", p.wavelength);
  if (p.octaves < 1 || p.octaves > 16) fail("noise", "octaves must be in [1, 16], got {}", p.octaves);
  if (!std::isfinite(p.amplitude)) fail("noise", "amplitude must be finite");
  if (!(p.lacunarity >= 1) || !(p.gain > 0 && p.gain <= 1)) fail("noise", "lacunarity >= 1 and gain in (0, 1] expected");
}

}  // namespace

int band_limited_octaves(const NoiseParams& p, double cell_x, double cell_y) {
  // Octaves finer than kMinWavelengthCells cells are not resolved by the grid: they alias into a
  // cell-sized grid pattern in the shaded relief, so they are left out (never the first one).
  constexpr double kMinWavelengthCells = 4.0;
  const double finest = kMinWavelengthCells * std::max(cell_x, cell_y);
  int n = p.octaves;
  while (n > 1 && p.wavelength / std::pow(p.lacunarity, n - 1) < finest) --n;
  return n;
}

void noise_gradient(Device& d, GradientBuffers& g, const NoiseParams& p, const Box& box, bool use_mask, bool to_scratch) {
  check(p);
  if (box.empty()) return;
  const int octaves = band_limited_octaves(p, g.cell_x, g.cell_y);
  const size_t bytes = g.cells() * sizeof(float);
  if (!g.nv()) {  // allocated on first use: most edits need no noise
    g.nv = d.buffer(bytes, CL_MEM_READ_WRITE, "noise values");
    g.nx = d.buffer(bytes, CL_MEM_READ_WRITE, "noise d/dx");
    g.ny = d.buffer(bytes, CL_MEM_READ_WRITE, "noise d/dy");
  }
  // Cells of the face box plus the column and row beyond it (the far cell of its last faces).
  const int cw = std::min(box.w + 1, g.width - box.x0), ch = std::min(box.h + 1, g.height - box.y0);
  cl::Kernel k = d.kernel("noise", "noise_cells");
  // The mask is valid on the face box only (box.w x box.h).
  set_args(k, g.nv, g.nx, g.ny, g.width, g.height, float(g.cell_x), float(g.cell_y), box.x0, box.y0, cw, ch, g.mask,
           use_mask ? 1 : 0, box.w, box.h, float(p.wavelength), octaves, float(p.lacunarity), float(p.gain),
           int(p.type), cl_uint(p.seed));
  // 8 cells per work-item (explicit vectors in the kernel), work-groups of 8 x 1.
  const size_t runs = (size_t(cw) + 7) / 8;
  d.queue().enqueueNDRangeKernel(k, cl::NullRange, cl::NDRange(round_up(runs, 8), size_t(ch)), cl::NDRange(8, 1));
  cl::Kernel f = d.kernel("noise", "noise_faces");
  set_args(f, to_scratch ? g.tx : g.gx, to_scratch ? g.ty : g.gy, g.nv, g.nx, g.ny, g.width, g.height, float(g.cell_x),
           float(g.cell_y), box.x0, box.y0, box.w, box.h, g.mask, use_mask ? 1 : 0, float(p.amplitude),
           to_scratch ? 0 : 1);
  d.queue().enqueueNDRangeKernel(f, cl::NullRange, cl::NDRange(round_up(size_t(box.w), 64), size_t(box.h)), cl::NDRange(64, 1));
}

Heightfield noise_values(Device& d, int width, int height, double cell_x, double cell_y, const NoiseParams& p) {
  check(p);
  Heightfield h(width, height);
  h.georef.cell_x = cell_x;
  h.georef.cell_y = cell_y;
  cl::Buffer out = d.buffer(h.size() * sizeof(float), CL_MEM_WRITE_ONLY, "noise values");
  cl::Buffer dummy = d.buffer(sizeof(float), CL_MEM_READ_ONLY, "mask");
  cl::Kernel k = d.kernel("noise", "noise_value");
  set_args(k, out, width, height, float(cell_x), float(cell_y), dummy, 0, float(p.amplitude), float(p.wavelength),
           p.octaves, float(p.lacunarity), float(p.gain), int(p.type), cl_uint(p.seed));
  d.queue().enqueueNDRangeKernel(k, cl::NullRange, cl::NDRange(size_t(height)), cl::NullRange);
  d.queue().enqueueReadBuffer(out, CL_TRUE, 0, h.size() * sizeof(float), h.z.data());
  return h;
}

}  // namespace terracl
