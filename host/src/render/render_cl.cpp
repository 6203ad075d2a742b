// SPDX-License-Identifier: Apache-2.0
// Launchers of kernels/render.cl (pictures) and kernels/render_terrain.cl (value rasters). The
// grid goes to the device one strip of rows at a time (with its one-row halo), so device memory
// stays bounded by the strip size whatever the raster, and progress is reported per strip.
#include <cmath>
#include <terracl/error.hpp>
#include <terracl/render.hpp>

#include "render/render_internal.hpp"
#include "render/render_window.hpp"
#include <terracl/launch.hpp>
#include "cl/row_launch.hpp"

namespace terracl::render {

namespace {

int shading_code(Shading s) {
  switch (s) {
    case Shading::Multidirectional:
      return 1;
    case Shading::Combined:
      return 2;
    case Shading::Igor:
      return 3;
    default:
      return 0;
  }
}

/// Runs `launch(kernel rows, strip)` for each strip after uploading its input rows into `zbuf`;
/// `read(strip)` copies the strip's output back. Buffers are sized for the largest strip.
template <typename Launch, typename Read>
void for_each_strip(Device& device, const Heightfield& h, const Options& opt, cl::Buffer& zbuf, Launch&& launch,
                    Read&& read) {
  cl::CommandQueue& q = device.queue();
  const auto strips = detail::strips(h.height, opt.strip_rows);
  for (size_t s = 0; s < strips.size(); ++s) {
    const detail::Strip& st = strips[s];
    q.enqueueWriteBuffer(zbuf, CL_FALSE, 0, size_t(st.r1 - st.r0) * h.width * sizeof(float),
                         h.z.data() + size_t(st.r0) * h.width);
    launch(st);
    read(st);
    report_progress(opt.progress, "render", double(st.y0 + st.rows) / h.height, "shading");
  }
}

size_t strip_cells(const Heightfield& h, const Options& opt) {
  return size_t(std::min(h.height, std::max(1, opt.strip_rows) + 2)) * h.width;
}

}  // namespace

Image render(const Heightfield& h, const Options& opt, Device& device) {
  if (opt.mode == Mode::Perspective) return render_view(h, opt, device);
  check_options(h, opt);
  return render(h, opt, picture_layout(h, opt), device);
}

Image render(const Heightfield& h, const Options& opt, const PictureLayout& l, Device& device) {
  check_options(h, opt);
  // Ramp entries with percentages resolved against this heightfield's range, in file order.
  const DeviceRamp ramp = device_ramp(opt.ramp, l.zmin, l.zmax);
  const std::vector<float>& rz = ramp.z;
  const std::vector<uint8_t>& rgb = ramp.rgb;
  const uint32_t nodata = ramp.nodata;
  const int mode = opt.mode == Mode::Hillshade ? 0 : opt.mode == Mode::Relief ? 1 : opt.mode == Mode::Slope ? 2 : 3;
  const std::vector<float> prm = detail::ShadeParams(h, opt).slots();
  Image img;
  img.width = h.width;
  img.height = h.height;
  img.channels = l.channels;
  img.georef = h.georef;
  img.pixels.assign(size_t(l.channels) * h.size(), 0);
  const size_t cells = strip_cells(h, opt), out_row = size_t(l.channels) * h.width;
  try {
    cl::CommandQueue& q = device.queue();
    cl::Buffer z = device.buffer(cells * sizeof(float), CL_MEM_READ_ONLY, "render heights (one strip)");
    cl::Buffer out = device.buffer(out_row * std::max(1, std::min(opt.strip_rows, h.height)), CL_MEM_WRITE_ONLY,
                                   "render picture (one strip)");
    cl::Buffer bp = device.buffer(prm.size() * sizeof(float), CL_MEM_READ_ONLY, "render parameters");
    cl::Buffer bz = device.buffer(rz.size() * sizeof(float), CL_MEM_READ_ONLY, "render ramp");
    cl::Buffer brgb = device.buffer(rgb.size(), CL_MEM_READ_ONLY, "render ramp colours");
    q.enqueueWriteBuffer(bp, CL_FALSE, 0, prm.size() * sizeof(float), prm.data());
    q.enqueueWriteBuffer(bz, CL_FALSE, 0, rz.size() * sizeof(float), rz.data());
    q.enqueueWriteBuffer(brgb, CL_FALSE, 0, rgb.size(), rgb.data());
    cl::Kernel k = device.kernel("render", "render_rows");
    for_each_strip(
        device, h, opt, z,
        [&](const detail::Strip& st) {
          set_args(k, z, cl_int(h.width), cl_int(h.height), cl_int(st.r0), cl_int(st.y0), cl_int(st.rows), cl_int(mode),
                   cl_int(shading_code(opt.shading)), cl_int(opt.compute_edges ? 1 : 0), bp, bz, brgb,
                   cl_int(rz.size()), cl_uint(nodata), cl_int(l.channels), out);
          launch_grid(device, k, size_t(h.width), size_t(st.rows));
        },
        [&](const detail::Strip& st) {
          q.enqueueReadBuffer(out, CL_TRUE, 0, out_row * st.rows, img.pixels.data() + out_row * st.y0);
        });
  } catch (const cl::Error& e) {
    fail("render", "OpenCL: {}", describe(e));
  }
  return img;
}

Heightfield values(const Heightfield& h, const Options& opt, Device& device) {
  check_options(h, opt);
  if (!is_value_mode(opt.mode)) fail("render", "mode has no value raster (expected slope|aspect|tri|tpi|roughness|profile-curvature|tangential-curvature)");
  Heightfield out = value_raster_like(h, opt);
  const int mode = opt.mode == Mode::Slope                 ? 0
                   : opt.mode == Mode::Aspect              ? 1
                   : opt.mode == Mode::TRI                 ? 2
                   : opt.mode == Mode::TPI                 ? 3
                   : opt.mode == Mode::Roughness           ? 4
                   : opt.mode == Mode::ProfileCurvature    ? 5
                                                           : 6;
  const int flags = (opt.slope_percent ? 1 : 0) | (opt.tri_alg == TriAlg::Wilson ? 2 : 0) |
                    (opt.aspect_trigonometric ? 4 : 0) | (opt.zero_for_flat ? 8 : 0);
  const std::vector<float> prm = detail::ShadeParams(h, opt).slots();
  const size_t cells = strip_cells(h, opt), out_row = size_t(h.width);
  try {
    cl::CommandQueue& q = device.queue();
    cl::Buffer z = device.buffer(cells * sizeof(float), CL_MEM_READ_ONLY, "terrain heights (one strip)");
    cl::Buffer bo = device.buffer(out_row * std::max(1, std::min(opt.strip_rows, h.height)) * sizeof(float),
                                  CL_MEM_WRITE_ONLY, "terrain values (one strip)");
    cl::Buffer bp = device.buffer(prm.size() * sizeof(float), CL_MEM_READ_ONLY, "terrain parameters");
    q.enqueueWriteBuffer(bp, CL_FALSE, 0, prm.size() * sizeof(float), prm.data());
    cl::Kernel k = device.kernel("render_terrain", "terrain_rows");
    for_each_strip(
        device, h, opt, z,
        [&](const detail::Strip& st) {
          set_args(k, z, cl_int(h.width), cl_int(h.height), cl_int(st.r0), cl_int(st.y0), cl_int(st.rows), cl_int(mode),
                   cl_int(flags), cl_int(opt.compute_edges ? 1 : 0), bp, bo);
          launch_grid(device, k, size_t(h.width), size_t(st.rows));
        },
        [&](const detail::Strip& st) {
          q.enqueueReadBuffer(bo, CL_TRUE, 0, out_row * st.rows * sizeof(float), out.z.data() + out_row * st.y0);
        });
  } catch (const cl::Error& e) {
    fail("render", "OpenCL: {}", describe(e));
  }
  return out;
}

}  // namespace terracl::render
