// Launcher of kernels/render.cl: uploads the heights and the resolved colour ramp, shades one row
// per work-item, reads the RGB picture back (one finish for the whole picture).
#include <cmath>
#include <terracl/error.hpp>
#include <terracl/render.hpp>

namespace terracl::render {

Image render(const Heightfield& h, const Options& opt, Device& device) {
  if (h.width <= 0 || h.height <= 0) fail("render", "empty heightfield");
  if (!(opt.altitude_deg >= 0 && opt.altitude_deg <= 90))
    fail("render", "altitude must be in 0..90 deg, got {}", opt.altitude_deg);
  if (!(opt.slope_max_deg > 0 && opt.slope_max_deg <= 90))
    fail("render", "slope_max must be in (0, 90] deg, got {}", opt.slope_max_deg);
  const HeightStats st = compute_stats(h);
  // Ramp entries with percentages resolved against this heightfield's range, in file order.
  std::vector<float> rz;
  std::vector<uint8_t> rgb;
  for (const auto& e : opt.ramp.entries) {
    rz.push_back(float(e.percent ? st.min + e.value / 100.0 * (st.max - st.min) : e.value));
    rgb.insert(rgb.end(), e.rgb, e.rgb + 3);
  }
  const uint32_t nodata =
      uint32_t(opt.ramp.nodata_rgb[0]) | uint32_t(opt.ramp.nodata_rgb[1]) << 8 | uint32_t(opt.ramp.nodata_rgb[2]) << 16;
  int mode = 0;
  switch (opt.mode) {
    case Mode::Hillshade:
      mode = 0;
      break;
    case Mode::Relief:
      mode = 1;
      break;
    case Mode::Slope:
      mode = 2;
      break;
    case Mode::ShadedRelief:
      mode = 3;
      break;
  }
  const double d2r = M_PI / 180.0, zs = opt.z_factor / 8.0;
  const double cos_alt_z = std::cos(opt.altitude_deg * d2r) * zs, az = opt.azimuth_deg * d2r;
  Image img;
  img.width = h.width;
  img.height = h.height;
  img.pixels.assign(size_t(3) * h.size(), 0);
  try {
    cl::CommandQueue& q = device.queue();
    cl::Buffer z = device.buffer(h.size() * sizeof(float), CL_MEM_READ_ONLY, "render heights");
    cl::Buffer out = device.buffer(img.pixels.size(), CL_MEM_WRITE_ONLY, "render picture");
    cl::Buffer bz = device.buffer(rz.size() * sizeof(float), CL_MEM_READ_ONLY, "render ramp");
    cl::Buffer brgb = device.buffer(rgb.size(), CL_MEM_READ_ONLY, "render ramp colours");
    q.enqueueWriteBuffer(z, CL_FALSE, 0, h.size() * sizeof(float), h.z.data());
    q.enqueueWriteBuffer(bz, CL_FALSE, 0, rz.size() * sizeof(float), rz.data());
    q.enqueueWriteBuffer(brgb, CL_FALSE, 0, rgb.size(), rgb.data());
    cl::Kernel k = device.kernel("render", "render_rows");
    int a = 0;
    k.setArg(a++, z);
    k.setArg(a++, cl_int(h.width));
    k.setArg(a++, cl_int(h.height));
    k.setArg(a++, cl_int(mode));
    k.setArg(a++, cl_float(1.0 / h.georef.cell_x));
    k.setArg(a++, cl_float(-1.0 / h.georef.cell_y));
    k.setArg(a++, cl_float(zs));
    k.setArg(a++, cl_float(254.0 * std::sin(opt.altitude_deg * d2r)));
    k.setArg(a++, cl_float(254.0 * std::cos(az) * cos_alt_z));
    k.setArg(a++, cl_float(254.0 * std::sin(az) * cos_alt_z));
    k.setArg(a++, cl_float(opt.z_factor / (8.0 * h.georef.cell_x)));
    k.setArg(a++, cl_float(opt.z_factor / (8.0 * h.georef.cell_y)));
    k.setArg(a++, cl_float(opt.slope_max_deg));
    k.setArg(a++, cl_float(1.0 + 254.0 * std::sin(opt.altitude_deg * d2r)));
    k.setArg(a++, bz);
    k.setArg(a++, brgb);
    k.setArg(a++, cl_int(rz.size()));
    k.setArg(a++, cl_uint(nodata));
    k.setArg(a++, out);
    q.enqueueNDRangeKernel(k, cl::NullRange, cl::NDRange(size_t(h.height)), cl::NullRange);
    q.enqueueReadBuffer(out, CL_TRUE, 0, img.pixels.size(), img.pixels.data());
  } catch (const cl::Error& e) {
    fail("render", "OpenCL: {}", describe(e));
  }
  return img;
}

}  // namespace terracl::render
