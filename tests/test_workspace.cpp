// SPDX-License-Identifier: Apache-2.0
// The reconstruction's per-device buffer cache, pinned staging and threaded host passes (issue 19
// point 5): every path gives the same bits as fresh buffers and direct transfers, the cache is
// bounded to one grid size and releases its memory, and the peak figure stays honest.
#include "test_helpers.hpp"

#include "../host/src/cl/workspace.hpp"

#include <terracl/error.hpp>
#include <terracl/gradient.hpp>
#include <terracl/reconstruct.hpp>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <thread>

using namespace terracl;

namespace {

// Sets an environment variable for one scope (the tests run one at a time in a process).
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const char* value) : m_name(name) {
    if (const char* old = std::getenv(name)) m_old = old, m_had = true;
    setenv(name, value, 1);
  }
  ~ScopedEnv() {
    if (m_had) setenv(m_name.c_str(), m_old.c_str(), 1);
    else unsetenv(m_name.c_str());
  }

 private:
  std::string m_name, m_old;
  bool m_had = false;
};

// Released buffers return their bytes in a destructor callback a driver may run later.
uint64_t settled_bytes(Device& d, uint64_t want) {
  d.queue().finish();
  for (int i = 0; i < 200 && d.allocated_bytes() != want; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  return d.allocated_bytes();
}

struct Problem {
  GradientField g;
  ConstraintSet c;
  Heightfield h;
};

Problem problem(int W, int H, unsigned seed) {
  Problem p;
  p.h = test::smooth_terrain(W, H, 10.0, 400.0, seed);
  p.g = extract_gradient(test::device(), p.h);
  p.c = ConstraintSet(W, H);
  for (int y = 3; y < H; y += 37)
    for (int x = 5; x < W; x += 41) p.c.add_cell(x, y, p.h.at(x, y), ConstraintKind::Raster);
  return p;
}

}  // namespace

TEST(Workspace, CachedBuffersGiveTheSameBitsAndAreReleased) {
  Device& d = test::device();
  release_workspace();
  const uint64_t before = settled_bytes(d, d.allocated_bytes());
  Problem p = problem(97, 66, 3);
  SolverOptions warm;
  warm.initial = &p.h;
  warm.tolerance = 1e-7;

  ReconstructResult fresh, fresh_warm;
  {
    ScopedEnv off("TERRACL_NO_WORKSPACE", "1");
    fresh = reconstruct(d, p.g, p.c);
    fresh_warm = reconstruct(d, p.g, p.c, warm);
    EXPECT_EQ(settled_bytes(d, before), before) << "without the cache nothing stays allocated";
  }
  ReconstructResult first = reconstruct(d, p.g, p.c);
  const uint64_t cached = d.allocated_bytes() - before;
  // u, g, the gradient staging (4 x N floats) and the hard-cell list stay for the next solve.
  EXPECT_GE(cached, 4 * p.g.size() * sizeof(float));
  ReconstructResult second = reconstruct(d, p.g, p.c);
  ReconstructResult second_warm = reconstruct(d, p.g, p.c, warm);
  EXPECT_EQ(d.allocated_bytes() - before, cached) << "the second solve reuses, it does not add";
  EXPECT_EQ(0u, test::bit_differences(fresh.height, first.height));
  EXPECT_EQ(0u, test::bit_differences(fresh.height, second.height));
  EXPECT_EQ(0u, test::bit_differences(fresh_warm.height, second_warm.height));
  EXPECT_EQ(fresh.cycles, second.cycles);
  // The peak figure counts the reused buffers: the same for the first and the second solve.
  EXPECT_EQ(first.device_bytes, second.device_bytes);
  EXPECT_GE(second.device_bytes, fresh.device_bytes);

  EXPECT_EQ(release_workspace(), cached);
  EXPECT_EQ(settled_bytes(d, before), before);
}

TEST(Workspace, AnotherGridSizeReleasesTheCachedOne) {
  Device& d = test::device();
  release_workspace();
  const uint64_t before = settled_bytes(d, d.allocated_bytes());
  Problem big = problem(130, 120, 4), small = problem(40, 30, 5);
  reconstruct(d, big.g, big.c);
  const uint64_t cached_big = d.allocated_bytes() - before;
  ReconstructResult r = reconstruct(d, small.g, small.c);
  d.queue().finish();  // the released bytes may come back later (driver callback): bounded wait
  for (int i = 0; i < 200 && d.allocated_bytes() - before >= cached_big / 4; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  const uint64_t cached_small = d.allocated_bytes() - before;
  EXPECT_LT(cached_small, cached_big / 4) << "one grid size is cached at a time";
  EXPECT_GE(cached_small, 4 * small.g.size() * sizeof(float));
  // The big grid's cache went back mid-solve: the small solve's peak figure counts its own buffers
  // (u and g at least), neither 0 nor a wrapped-around difference (CI saw both).
  EXPECT_GE(r.device_bytes, 2 * small.g.size() * sizeof(float));
  EXPECT_LT(r.device_bytes, cached_big);
  ScopedEnv off("TERRACL_NO_WORKSPACE", "1");
  EXPECT_EQ(0u, test::bit_differences(r.height, reconstruct(d, small.g, small.c).height));
  release_workspace();
}

// Pinned staging is the default only where the device does not share host memory; forced on
// PoCL it must give the same bits. 700 x 500 cells also run the threaded host passes (> 4 chunks).
TEST(Workspace, PinnedStagingAndThreadedHostPassesGiveTheSameBits) {
  Device& d = test::device();
  Problem p = problem(700, 500, 6);
  SolverOptions o;
  o.tolerance = 1e-5;
  SolverOptions warm = o;
  warm.initial = &p.h;
  Heightfield f(700, 500);
  for (int y = 0; y < 500; ++y)
    for (int x = 0; x < 700; ++x) f.z[size_t(y) * 700 + x] = float(std::sin(x * 0.05) * std::cos(y * 0.07));
  f.georef.cell_x = f.georef.cell_y = 10.0;
  ReconstructResult direct, direct_warm, direct_div;
  {
    ScopedEnv s("TERRACL_STAGING", "direct");
    direct = reconstruct(d, p.g, p.c, o);
    direct_warm = reconstruct(d, p.g, p.c, warm);
    direct_div = reconstruct_divergence(d, f, ConstraintSet(), o);  // singular: the mean path
  }
  ScopedEnv s("TERRACL_STAGING", "pinned");
  for (int rep = 0; rep < 2; ++rep) {  // fresh staging, then the cached one
    EXPECT_EQ(0u, test::bit_differences(direct.height, reconstruct(d, p.g, p.c, o).height));
    EXPECT_EQ(0u, test::bit_differences(direct_warm.height, reconstruct(d, p.g, p.c, warm).height));
    EXPECT_EQ(0u, test::bit_differences(direct_div.height, reconstruct_divergence(d, f, ConstraintSet(), o).height));
  }
  // Hard cells come back bit-exact from the threaded restore.
  std::vector<uint32_t> idx;
  std::vector<float> val;
  p.c.hard_cells(idx, val);
  ReconstructResult r = reconstruct(d, p.g, p.c, o);
  for (size_t k = 0; k < idx.size(); ++k) ASSERT_EQ(r.height.z[idx[k]], val[k]);
  release_workspace();
}

TEST(Workspace, BadStagingVariableIsAClearError) {
  ScopedEnv s("TERRACL_STAGING", "fast");
  try {
    reconstruct(test::device(), GradientField(20, 20), ConstraintSet());
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("TERRACL_STAGING must be pinned or direct, got 'fast'"), std::string::npos)
        << e.what();
  }
}

// The threaded input check still names the first bad cell in row-major order.
TEST(Workspace, ThreadedInputCheckNamesTheFirstBadCell) {
  GradientField g(700, 500);
  g.gy[size_t(490) * 700 + 10] = NAN;
  g.gx[size_t(300) * 700 + 650] = INFINITY;
  try {
    reconstruct(test::device(), g, ConstraintSet());
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("cell (650, 300)"), std::string::npos) << e.what();
  }
}

// Issue 19 (branch gpuedit): the multigrid hierarchy and the refinement's vectors come from the
// workspace as well: a second solve of the same size allocates nothing, the bits are those of
// fresh buffers, and the peak figure counts the reused buffers.
TEST(Workspace, HierarchyAndRefinementBuffersAreCachedToo) {
  Device& d = test::device();
  release_workspace();
  const uint64_t before = settled_bytes(d, d.allocated_bytes());
  Problem p = problem(129, 97, 5);
  SolverOptions o;
  o.refine = Refinement::Auto;
  o.refine_tolerance = 1e-9;  // at least one refinement cycle
  ReconstructResult fresh;
  {
    ScopedEnv off("TERRACL_NO_WORKSPACE", "1");
    fresh = reconstruct(d, p.g, p.c, o);
    EXPECT_EQ(settled_bytes(d, before), before);
  }
  ASSERT_NE(fresh.refinement, "off");
  ReconstructResult first = reconstruct(d, p.g, p.c, o);
  const uint64_t cached = d.allocated_bytes() - before;
  // Level 1's arrays carry a ghost frame of one cell.
  const size_t N = p.g.size(), N1 = size_t(129 / 2 + 1 + 2) * (97 / 2 + 1 + 2);
  // Level 0 (u, g), level 1 (e, r and six stencil planes) and, on the device path, the
  // refinement's g, U, R and three directions.
  uint64_t want = 2 * N * sizeof(float) + 8 * N1 * sizeof(float);
  if (fresh.refinement == "device-fp64") want += 4 * N * sizeof(float) + 2 * N * sizeof(double) + 3 * N * sizeof(float);
  EXPECT_GE(cached, want);
  ReconstructResult second = reconstruct(d, p.g, p.c, o);
  EXPECT_EQ(d.allocated_bytes() - before, cached) << "the second solve reuses, it does not add";
  EXPECT_EQ(0u, test::bit_differences(fresh.height, first.height));
  EXPECT_EQ(0u, test::bit_differences(fresh.height, second.height));
  EXPECT_EQ(fresh.refine_cycles, second.refine_cycles);
  EXPECT_EQ(first.device_bytes, second.device_bytes);
  EXPECT_GE(second.device_bytes, fresh.device_bytes);
  EXPECT_EQ(release_workspace(), cached);
  EXPECT_EQ(settled_bytes(d, before), before);
}
