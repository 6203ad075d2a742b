// Launchers of kernels/noise.cl.
#include <terracl/error.hpp>
#include <terracl/noise.hpp>

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

void set_params(cl::Kernel& k, int& a, const NoiseParams& p) {
  k.setArg(a++, float(p.amplitude));
  k.setArg(a++, float(p.wavelength));
  k.setArg(a++, p.octaves);
  k.setArg(a++, float(p.lacunarity));
  k.setArg(a++, float(p.gain));
  k.setArg(a++, int(p.type));
  k.setArg(a++, cl_uint(p.seed));
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
  int a = 0;
  k.setArg(a++, g.nv);
  k.setArg(a++, g.nx);
  k.setArg(a++, g.ny);
  k.setArg(a++, g.width);
  k.setArg(a++, g.height);
  k.setArg(a++, float(g.cell_x));
  k.setArg(a++, float(g.cell_y));
  k.setArg(a++, box.x0);
  k.setArg(a++, box.y0);
  k.setArg(a++, cw);
  k.setArg(a++, ch);
  k.setArg(a++, g.mask);
  k.setArg(a++, use_mask ? 1 : 0);
  k.setArg(a++, box.w);  // the mask is valid on the face box only
  k.setArg(a++, box.h);
  k.setArg(a++, float(p.wavelength));
  k.setArg(a++, octaves);
  k.setArg(a++, float(p.lacunarity));
  k.setArg(a++, float(p.gain));
  k.setArg(a++, int(p.type));
  k.setArg(a++, cl_uint(p.seed));
  // 8 cells per work-item (explicit vectors in the kernel), work-groups of 8 x 1.
  const size_t runs = (size_t(cw) + 7) / 8;
  d.queue().enqueueNDRangeKernel(k, cl::NullRange, cl::NDRange(round_up(runs, 8), size_t(ch)), cl::NDRange(8, 1));
  cl::Kernel f = d.kernel("noise", "noise_faces");
  a = 0;
  f.setArg(a++, to_scratch ? g.tx : g.gx);
  f.setArg(a++, to_scratch ? g.ty : g.gy);
  f.setArg(a++, g.nv);
  f.setArg(a++, g.nx);
  f.setArg(a++, g.ny);
  f.setArg(a++, g.width);
  f.setArg(a++, g.height);
  f.setArg(a++, float(g.cell_x));
  f.setArg(a++, float(g.cell_y));
  f.setArg(a++, box.x0);
  f.setArg(a++, box.y0);
  f.setArg(a++, box.w);
  f.setArg(a++, box.h);
  f.setArg(a++, g.mask);
  f.setArg(a++, use_mask ? 1 : 0);
  f.setArg(a++, float(p.amplitude));
  f.setArg(a++, to_scratch ? 0 : 1);
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
  int a = 0;
  k.setArg(a++, out);
  k.setArg(a++, width);
  k.setArg(a++, height);
  k.setArg(a++, float(cell_x));
  k.setArg(a++, float(cell_y));
  k.setArg(a++, dummy);
  k.setArg(a++, 0);
  set_params(k, a, p);
  d.queue().enqueueNDRangeKernel(k, cl::NullRange, cl::NDRange(size_t(height)), cl::NullRange);
  d.queue().enqueueReadBuffer(out, CL_TRUE, 0, h.size() * sizeof(float), h.z.data());
  return h;
}

}  // namespace terracl
