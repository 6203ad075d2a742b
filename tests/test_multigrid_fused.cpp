// SPDX-License-Identifier: Apache-2.0
// The fused coarse cycle (kernels/multigrid_coarse.cl): the coarse levels of a
// cycle in one work-group launch give the same bits as one launch per stage and level
// (TERRACL_MG_FUSED=0), for every cycle kind, with and without hard cells, with dead coarse nodes;
// and the launch count per solve drops.
#include "test_helpers.hpp"

#include <terracl/reconstruct.hpp>

#include <cstdlib>
#include <cstring>
#include <regex>

using namespace terracl;

namespace {

// The fused path is the default on GPUs only; these tests force it on the test device and
// compare it with the multi-launch path (TERRACL_MG_FUSED=0).
struct ForceFused {
  ForceFused() { setenv("TERRACL_MG_FUSED", "1", 1); }
  ~ForceFused() { unsetenv("TERRACL_MG_FUSED"); }
};

// Runs `f` with TERRACL_MG_FUSED=0 (the multi-launch path), then forces the fused path again.
template <class F>
auto multi_launch(F f) {
  setenv("TERRACL_MG_FUSED", "0", 1);
  auto r = f();
  setenv("TERRACL_MG_FUSED", "1", 1);
  return r;
}

bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

// Divergence of a smooth terrain and `n` scattered hard cells, plus (dead) a solid hard block
// whose coarse nodes have no free fine node below them.
struct Problem {
  Heightfield f;
  ConstraintSet c;
};
Problem problem(int w, int h, int n, bool dead) {
  const Heightfield t = test::smooth_terrain(w, h);
  Problem p;
  p.f = Heightfield(w, h);
  p.f.georef = t.georef;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      auto z = [&](int xx, int yy) { return t.z[size_t(std::clamp(yy, 0, h - 1)) * w + std::clamp(xx, 0, w - 1)]; };
      p.f.z[size_t(y) * w + x] = (z(x - 1, y) + z(x + 1, y) + z(x, y - 1) + z(x, y + 1) - 4 * z(x, y)) / 100.0f;
    }
  p.c = ConstraintSet(w, h);
  for (int k = 0; k < n; ++k) {
    const int x = (k * 37 + 5) % w, y = (k * 53 + 3) % h;
    p.c.add_cell(x, y, t.z[size_t(y) * w + x], ConstraintKind::Point);
  }
  if (dead)
    for (int y = h / 4; y < h / 4 + 20; ++y)
      for (int x = w / 3; x < w / 3 + 24; ++x) p.c.add_cell(x, y, t.z[size_t(y) * w + x], ConstraintKind::Point);
  return p;
}

}  // namespace

TEST(MultigridFused, SameBitsAsOneLaunchPerStage) {
  const ForceFused force;
  struct Case {
    int w, h, hard;
    bool dead;
    Cycle cycle;
  };
  // 129 x 97: fused from level 1 (65 x 49); 203 x 150: fused from level 2 (52 x 39) with odd
  // sizes on the way; no hard cell (singular, pseudo-inverse); a dead block; V and W cycles.
  for (const Case& k : {Case{129, 97, 12, false, Cycle::Fmg}, Case{203, 150, 0, false, Cycle::Fmg},
                        Case{129, 97, 6, true, Cycle::W}, Case{203, 150, 30, true, Cycle::V}}) {
    const Problem p = problem(k.w, k.h, k.hard, k.dead);
    SolverOptions o;
    o.cycle = k.cycle;
    o.max_cycles = 6;
    const ReconstructResult a = reconstruct_divergence(test::device(), p.f, p.c, o);
    const ReconstructResult b =
        multi_launch([&] { return reconstruct_divergence(test::device(), p.f, p.c, o); });
    EXPECT_GT(a.cycles, 0);
    EXPECT_EQ(a.cycles, b.cycles) << k.w << "x" << k.h;
    EXPECT_EQ(a.residuals, b.residuals) << k.w << "x" << k.h;
    EXPECT_TRUE(same_bits(a.height.z, b.height.z)) << k.w << "x" << k.h << " cycle " << int(k.cycle);
    EXPECT_LT(a.residuals.back(), 1e-3);
  }
}

TEST(MultigridFused, RefinementSameBitsBothPaths) {
  const ForceFused force;
  // The refinement's correction cycles go through the fused kernel too.
  const Problem p = problem(129, 129, 4, false);
  SolverOptions o;
  o.refine = Refinement::Auto;
  const ReconstructResult a = reconstruct_divergence(test::device(), p.f, p.c, o);
  const ReconstructResult b = multi_launch([&] { return reconstruct_divergence(test::device(), p.f, p.c, o); });
  EXPECT_GE(a.refine_cycles, 1);
  EXPECT_EQ(a.refine_residuals, b.refine_residuals);
  EXPECT_TRUE(same_bits(a.height.z, b.height.z));
}

TEST(MultigridFused, FewerLaunchesPerSolve) {
  // TERRACL_MG_PROFILE counts every launch of the solve (the CLI prints the total).
  auto launches = [](bool fused) {
    setenv("TERRACL_MG_PROFILE", "1", 1);
    setenv("TERRACL_MG_FUSED", fused ? "1" : "0", 1);
    const test::CmdResult r = test::run_cli("bench reconstruct --size 257 --repeats 1");
    unsetenv("TERRACL_MG_PROFILE");
    unsetenv("TERRACL_MG_FUSED");
    EXPECT_EQ(r.exit_code, 0) << r.out;
    std::smatch m;
    const bool found = std::regex_search(r.out, m, std::regex(R"(total\s+(\d+) launches)"));
    EXPECT_TRUE(found) << r.out;
    EXPECT_EQ(fused, r.out.find("coarse_cycle") != std::string::npos) << r.out;
    return found ? std::stoi(m[1]) : 0;
  };
  const int fused = launches(true), multi = launches(false);
  EXPECT_GT(fused, 0);
  EXPECT_LT(2 * fused, multi) << "fused " << fused << ", one per stage " << multi;
}
