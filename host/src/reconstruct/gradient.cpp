// SPDX-License-Identifier: Apache-2.0
// Launcher for kernels/gradient.cl: extraction, divergence and central-difference conversion.
#include <terracl/error.hpp>
#include <terracl/gradient.hpp>

#include <terracl/launch.hpp>
#include "cl/row_launch.hpp"

namespace terracl {
namespace {

const char* kFormatKey = "terracl:gradient";

void check_cell(const Georef& g, const char* stage) {
  if (!(g.cell_x > 0) || !(g.cell_y > 0) || !std::isfinite(g.cell_x) || !std::isfinite(g.cell_y))
    fail(stage, "cell size must be positive and finite, got {} x {} m", g.cell_x, g.cell_y);
}

cl::Buffer upload(Device& d, const std::vector<float>& v, const char* what) {
  cl::Buffer b = d.buffer(v.size() * sizeof(float), CL_MEM_READ_WRITE, what);
  d.queue().enqueueWriteBuffer(b, CL_FALSE, 0, v.size() * sizeof(float), v.data());
  return b;
}

}  // namespace

GradientFormat gradient_format(const GradientField& g) {
  auto it = g.metadata.find(kFormatKey);
  return (it != g.metadata.end() && it->second == "central") ? GradientFormat::Central : GradientFormat::Staggered;
}

GradientField extract_gradient(Device& d, const Heightfield& h, GradientFormat format) {
  require_finite(h, "extract", "the input heightfield");
  check_cell(h.georef, "extract");
  if (h.width < 1 || h.height < 1) fail("extract", "empty heightfield");
  GradientField g(h.width, h.height);
  g.georef = h.georef;
  g.metadata = h.metadata;
  g.metadata[kFormatKey] = format == GradientFormat::Central ? "central" : "staggered";
  double sum = 0;
  for (float v : h.z) sum += v;
  g.mean_elevation = sum / double(h.size());
  try {
    cl::Buffer hb = upload(d, h.z, "heightfield");
    const size_t bytes = h.size() * sizeof(float);
    cl::Buffer gx = d.buffer(bytes, CL_MEM_READ_WRITE, "gradient gx");
    cl::Buffer gy = d.buffer(bytes, CL_MEM_READ_WRITE, "gradient gy");
    cl::Kernel k = d.kernel("gradient", format == GradientFormat::Central ? "extract_central" : "extract_staggered");
    k.setArg(0, hb);
    k.setArg(1, gx);
    k.setArg(2, gy);
    k.setArg(3, h.width);
    k.setArg(4, h.height);
    k.setArg(5, float(1.0 / h.georef.cell_x));
    k.setArg(6, float(1.0 / h.georef.cell_y));
    launch_grid(d, k, size_t(h.width), size_t(h.height));
    d.queue().enqueueReadBuffer(gx, CL_FALSE, 0, bytes, g.gx.data());
    d.queue().enqueueReadBuffer(gy, CL_TRUE, 0, bytes, g.gy.data());
  } catch (const cl::Error& e) {
    fail("extract", "{}", describe(e));
  }
  return g;
}

GradientField to_staggered(Device& d, const GradientField& g) {
  if (gradient_format(g) == GradientFormat::Staggered) return g;
  GradientField out(g.width, g.height);
  out.georef = g.georef;
  out.metadata = g.metadata;
  out.metadata[kFormatKey] = "staggered";
  out.mean_elevation = g.mean_elevation;
  try {
    const size_t bytes = g.size() * sizeof(float);
    cl::Buffer cx = upload(d, g.gx, "central gx"), cy = upload(d, g.gy, "central gy");
    cl::Buffer gx = d.buffer(bytes, CL_MEM_READ_WRITE, "gradient gx");
    cl::Buffer gy = d.buffer(bytes, CL_MEM_READ_WRITE, "gradient gy");
    cl::Kernel k = d.kernel("gradient", "central_to_staggered");
    k.setArg(0, cx);
    k.setArg(1, cy);
    k.setArg(2, gx);
    k.setArg(3, gy);
    k.setArg(4, g.width);
    k.setArg(5, g.height);
    launch_grid(d, k, size_t(g.width), size_t(g.height));
    d.queue().enqueueReadBuffer(gx, CL_FALSE, 0, bytes, out.gx.data());
    d.queue().enqueueReadBuffer(gy, CL_TRUE, 0, bytes, out.gy.data());
  } catch (const cl::Error& e) {
    fail("gradient", "{}", describe(e));
  }
  return out;
}

void enqueue_divergence(Device& d, const cl::Buffer& gx, const cl::Buffer& gy, const cl::Buffer& out, int width,
                        int height, double cell_x, double cell_y, float scale) {
  cl::Kernel k = d.kernel("gradient", "divergence");
  k.setArg(0, gx);
  k.setArg(1, gy);
  k.setArg(2, out);
  k.setArg(3, width);
  k.setArg(4, height);
  k.setArg(5, float(1.0 / cell_x));
  k.setArg(6, float(1.0 / cell_y));
  k.setArg(7, scale);
  launch_grid(d, k, size_t(width), size_t(height));
}

Heightfield divergence(Device& d, const GradientField& gin) {
  check_cell(gin.georef, "divergence");
  const GradientField g = to_staggered(d, gin);
  Heightfield f(g.width, g.height);
  f.georef = g.georef;
  f.metadata = g.metadata;
  f.metadata.erase(kFormatKey);
  f.georef.vertical_units = "1/m";
  try {
    cl::Buffer gx = upload(d, g.gx, "gradient gx"), gy = upload(d, g.gy, "gradient gy");
    cl::Buffer fb = d.buffer(f.size() * sizeof(float), CL_MEM_READ_WRITE, "divergence");
    enqueue_divergence(d, gx, gy, fb, g.width, g.height, g.georef.cell_x, g.georef.cell_y, 1.0f);
    d.queue().enqueueReadBuffer(fb, CL_TRUE, 0, f.size() * sizeof(float), f.z.data());
  } catch (const cl::Error& e) {
    fail("divergence", "{}", describe(e));
  }
  return f;
}

}  // namespace terracl
