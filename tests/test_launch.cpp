// SPDX-License-Identifier: Apache-2.0
// Launch shapes: every cell kernel (kernels/launch.clh) gives the same bits in
// the rows shape (PoCL's default: a row per work-item) and the wide shape (GPUs: a cell per
// work-item in 2D groups), both run here on PoCL (TERRACL_LAUNCH forces the shape).
#include "test_helpers.hpp"

#include <terracl/edit.hpp>
#include <terracl/gradient.hpp>
#include <terracl/io.hpp>
#include <terracl/launch.hpp>
#include <terracl/reconstruct.hpp>
#include <terracl/render.hpp>

#include <cmath>
#include <cstdlib>
#include <cstring>

using namespace terracl;

namespace {

// One device per shape, opened once (PoCL builds each program once per shape).
Device& shape_device(const char* shape) {
  static std::map<std::string, std::shared_ptr<Device>> devs;
  auto& d = devs[shape];
  if (!d) {
    setenv("TERRACL_LAUNCH", shape, 1);
    d = Device::open();
    unsetenv("TERRACL_LAUNCH");
  }
  EXPECT_EQ(d->info().launch, shape);
  return *d;
}
Device& rows() { return shape_device("rows"); }
Device& wide() { return shape_device("wide"); }

bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

size_t first_difference(const std::vector<float>& a, const std::vector<float>& b) {
  for (size_t i = 0; i < std::min(a.size(), b.size()); ++i)
    if (std::memcmp(&a[i], &b[i], sizeof(float)) != 0) return i;
  return a.size() == b.size() ? a.size() : std::min(a.size(), b.size());
}

// A real DEM crop of odd, non-square size (the wide shape's rounded-up global sizes and the
// rows' loops both meet ragged ends).
Heightfield dem(int w, int h, int x0 = 500, int y0 = 300) {
  static const Heightfield tile = read_heightfield(test::data_path("dem/N44W072.hgt"));
  Heightfield out(w, h);
  out.georef = tile.georef;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) out.z[size_t(y) * w + x] = tile.z[size_t(y + y0) * tile.width + x + x0];
  return out;
}

}  // namespace

TEST(Launch, WideGroupsFollowTheKernelsQueriedSizes) {
  Device& d = wide();
  const auto groups = cell_kernel_groups(d);
  ASSERT_GE(groups.size(), 20u);
  for (const auto& [name, s] : groups) {
    EXPECT_GE(s.x, 1u) << name;
    EXPECT_LE(s.x * s.y, std::min<size_t>(256, d.info().max_work_group)) << name;
  }
  // The shape comes from the kernel's own queried sizes: (preferred multiple, the rest along y).
  cl::Kernel k = d.kernel("multigrid", "smooth_rb0");
  const size_t max = k.getWorkGroupInfo<CL_KERNEL_WORK_GROUP_SIZE>(d.device());
  const size_t pref = k.getWorkGroupInfo<CL_KERNEL_PREFERRED_WORK_GROUP_SIZE_MULTIPLE>(d.device());
  const GroupShape s = groups.at("smooth_rb0");
  EXPECT_EQ(s.x, std::min<size_t>({pref, max, 256}));
  EXPECT_EQ(s.y, std::max<size_t>(1, std::min<size_t>(max, 256) / s.x));
  EXPECT_NE(describe_launch(d).find("wide"), std::string::npos);
  EXPECT_NE(describe_launch(d).find("smooth_rb0"), std::string::npos) << describe_launch(d);
  EXPECT_NE(describe_launch(rows()).find("rows"), std::string::npos);
}

TEST(Launch, GradientKernelsSameBitsInBothShapes) {
  const Heightfield h = dem(93, 47);
  for (auto f : {GradientFormat::Staggered, GradientFormat::Central}) {
    const GradientField a = extract_gradient(rows(), h, f), b = extract_gradient(wide(), h, f);
    EXPECT_TRUE(same_bits(a.gx, b.gx));
    EXPECT_TRUE(same_bits(a.gy, b.gy));
    if (f == GradientFormat::Central) {
      const GradientField sa = to_staggered(rows(), a), sb = to_staggered(wide(), b);
      EXPECT_TRUE(same_bits(sa.gx, sb.gx));
      EXPECT_TRUE(same_bits(sa.gy, sb.gy));
    }
  }
  const GradientField g = extract_gradient(rows(), h);
  EXPECT_TRUE(same_bits(divergence(rows(), g).z, divergence(wide(), g).z));
}

TEST(Launch, ReconstructSameBitsInBothShapes) {
  // 263 x 257: level 1 has 132 x 129 >= 128^2 nodes (four-colour smoothing, one node per
  // work-item in the wide shape), the smaller levels zebra rows. Sparse hard cells.
  const Heightfield h = dem(263, 257);
  const GradientField g = extract_gradient(rows(), h);
  ConstraintSet c(h.width, h.height);
  for (int k = 0; k < 40; ++k) {
    const int x = (k * 37) % h.width, y = (k * 53) % h.height;
    c.add_cell(x, y, h.z[size_t(y) * h.width + x], ConstraintKind::Point);
  }
  struct Case {
    Cycle cycle;
    Smoother smoother;
    bool hard;
  };
  for (const Case& k : {Case{Cycle::Fmg, Smoother::Rbgs, true}, Case{Cycle::W, Smoother::Jacobi, false},
                        Case{Cycle::Cascade, Smoother::Rbgs, true}}) {
    SolverOptions o;
    o.cycle = k.cycle;
    o.smoother = k.smoother;
    o.max_cycles = 4;
    const ConstraintSet none;
    const ReconstructResult a = reconstruct(rows(), g, k.hard ? c : none, o);
    const ReconstructResult b = reconstruct(wide(), g, k.hard ? c : none, o);
    EXPECT_EQ(a.cycles, b.cycles);
    EXPECT_EQ(a.residuals, b.residuals);
    EXPECT_TRUE(same_bits(a.height.z, b.height.z))
        << "cycle " << int(k.cycle) << " smoother " << int(k.smoother) << ": first difference at cell "
        << first_difference(a.height.z, b.height.z);
    // And a real solve, not a no-op.
    EXPECT_GT(a.cycles, 0);
  }
}

TEST(Launch, EditExamplesSameBitsInBothShapes) {
  // Gallery scripts (ravines, rivers, cliffs, noise, freeze, tensors, mountain ranges): profiles,
  // tensor fields and constraints all go through the converted kernels.
  for (const std::string name : {"canyon", "mountain_chain_tensors", "cliff"}) {
    const std::string path = test::data_path("examples/" + name + ".json");
    const nlohmann::json script = read_edit_script(path);
    auto flat = parse_flat_spec(script.at("base").get<std::string>());
    ASSERT_TRUE(flat) << name;
    // Scripts in metres keep their primitives on a coarser base; scripts in cells run as written.
    const int k = script.value("units", "m") == "m" ? 4 : 1;
    Heightfield base((flat->width - 1) / k + 1, (flat->height - 1) / k + 1);
    base.georef = flat->georef;
    base.georef.cell_x *= k;
    base.georef.cell_y *= k;
    EditOptions o;
    o.base_dir = test::data_path("examples");
    EditSession a(rows(), base, o), b(wide(), base, o);
    a.apply(script);
    b.apply(script);
    const Heightfield& ha = a.height();
    const Heightfield& hb = b.height();
    EXPECT_TRUE(same_bits(ha.z, hb.z)) << name << ": first difference at cell " << first_difference(ha.z, hb.z);
    float lo = 1e30f, hi = -1e30f;
    for (float v : ha.z) lo = std::min(lo, v), hi = std::max(hi, v);
    EXPECT_GT(hi - lo, 10.0f) << name;
    EXPECT_NE(b.report().at("launch").get<std::string>().find("wide"), std::string::npos);
  }
}

TEST(Launch, RenderSameBytesInBothShapes) {
  Heightfield h = dem(131, 77);
  // Nodata holes: the general window path inside rows, and an all-NaN corner.
  for (int y = 30; y < 36; ++y)
    for (int x = 50; x < 57; ++x) h.z[size_t(y) * h.width + x] = NAN;
  h.z[0] = NAN;
  using render::Mode;
  for (Mode m : {Mode::Hillshade, Mode::Relief, Mode::Slope, Mode::ShadedRelief})
    for (bool edges : {true, false}) {
      render::Options o;
      o.mode = m;
      o.compute_edges = edges;
      o.strip_rows = 29;  // several strips, a short last one
      const render::Image a = render::render(h, o, rows()), b = render::render(h, o, wide());
      EXPECT_EQ(a.pixels, b.pixels) << "mode " << int(m) << " edges " << edges;
    }
  // The rows shape's branch-free hillshade passes (one per shading) against the wide shape's cells.
  for (auto s : {render::Shading::Multidirectional, render::Shading::Combined, render::Shading::Igor}) {
    render::Options o;
    o.shading = s;
    o.compute_edges = false;
    o.strip_rows = 29;
    EXPECT_EQ(render::render(h, o, rows()).pixels, render::render(h, o, wide()).pixels) << "shading " << int(s);
  }
  for (Mode m : {Mode::Slope, Mode::Aspect, Mode::TRI, Mode::TPI, Mode::Roughness}) {
    render::Options o;
    o.mode = m;
    o.strip_rows = 29;
    EXPECT_TRUE(same_bits(render::values(h, o, rows()).z, render::values(h, o, wide()).z)) << "mode " << int(m);
  }
}
