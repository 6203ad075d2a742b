// SPDX-License-Identifier: Apache-2.0
// Launcher of kernels/render_view.cl: the whole heightfield goes to the device once (a ray may cross
// all of it), the picture comes back in one read. One work-item per pixel in a 2D range: rays take
// very different numbers of steps, so small groups balance better than rows.
#include <cmath>
#include <terracl/error.hpp>
#include <terracl/render.hpp>

#include "render/render_internal.hpp"
#include "render/view_internal.hpp"

namespace terracl::render {

Image render_view(const Heightfield& h, const Options& opt, Device& device) {
  const detail::ViewSetup s = detail::view_setup(h, opt);
  const std::vector<float> prm = detail::view_slots(s);
  const DeviceRamp ramp = device_ramp(opt.ramp, s.zmin, s.zmax);
  const std::vector<float>& rz = ramp.z;
  const std::vector<uint8_t>& rgb = ramp.rgb;
  const uint32_t nodata = ramp.nodata;
  const View& v = opt.view;
  Image img = detail::blank_view(v);
  try {
    cl::CommandQueue& q = device.queue();
    cl::Buffer z = device.buffer(h.z.size() * sizeof(float), CL_MEM_READ_ONLY, "perspective heights");
    cl::Buffer out = device.buffer(img.pixels.size(), CL_MEM_WRITE_ONLY, "perspective picture");
    cl::Buffer bp = device.buffer(prm.size() * sizeof(float), CL_MEM_READ_ONLY, "perspective parameters");
    cl::Buffer bz = device.buffer(rz.size() * sizeof(float), CL_MEM_READ_ONLY, "perspective ramp");
    cl::Buffer brgb = device.buffer(rgb.size(), CL_MEM_READ_ONLY, "perspective ramp colours");
    q.enqueueWriteBuffer(z, CL_FALSE, 0, h.z.size() * sizeof(float), h.z.data());
    q.enqueueWriteBuffer(bp, CL_FALSE, 0, prm.size() * sizeof(float), prm.data());
    q.enqueueWriteBuffer(bz, CL_FALSE, 0, rz.size() * sizeof(float), rz.data());
    q.enqueueWriteBuffer(brgb, CL_FALSE, 0, rgb.size(), rgb.data());
    cl::Kernel k = device.kernel("render_view", "render_view");
    int a = 0;
    k.setArg(a++, z);
    k.setArg(a++, cl_int(h.width));
    k.setArg(a++, cl_int(h.height));
    k.setArg(a++, bp);
    k.setArg(a++, bz);
    k.setArg(a++, brgb);
    k.setArg(a++, cl_int(rz.size()));
    k.setArg(a++, cl_uint(nodata));
    k.setArg(a++, cl_int(v.width));
    k.setArg(a++, cl_int(v.height));
    k.setArg(a++, out);
    // Bands of 64 rows, so that progress moves and no single launch runs for long on a slow device.
    const size_t gx = (size_t(v.width) + 7) / 8 * 8;
    for (int y0 = 0; y0 < v.height; y0 += 64) {
      const size_t rows = size_t(std::min(64, v.height - y0));
      q.enqueueNDRangeKernel(k, cl::NDRange(0, size_t(y0)), cl::NDRange(gx, (rows + 7) / 8 * 8), cl::NDRange(8, 8));
      q.finish();
      report_progress(opt.progress, "render", double(y0 + rows) / v.height, "perspective");
    }
    q.enqueueReadBuffer(out, CL_TRUE, 0, img.pixels.size(), img.pixels.data());
  } catch (const cl::Error& e) {
    fail("render", "OpenCL: {}", describe(e));
  }
  return img;
}

}  // namespace terracl::render
