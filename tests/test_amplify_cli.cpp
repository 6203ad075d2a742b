// SPDX-License-Identifier: Apache-2.0
// `terracl amplify` and `terracl dictionary` run as a user runs them.
#include "test_helpers.hpp"

#include <terracl/amplify.hpp>
#include <terracl/io.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>

using namespace terracl;

namespace {
struct Files {
  test::TempDir tmp;
  std::string exemplar = test::data_path("crops/presidential_128x96.tif");
  std::string low;
  Files() {
    low = tmp.path("low.tif");
    write_heightfield(block_mean(read_heightfield(exemplar), 4), low);
  }
};
}  // namespace

TEST(AmplifyCli, LearnThenAmplifyWithDictionary) {
  Files f;
  const auto learn = test::run_cli("dictionary learn " + f.exemplar + " -o " + f.tmp.path("d.tdic") +
                                   " --atoms 48 --sparsity 1 --patch 16 --iterations 2 --constrained");
  ASSERT_EQ(learn.exit_code, 0) << learn.out;
  EXPECT_NE(learn.out.find("48 atoms"), std::string::npos) << learn.out;
  const auto amp = test::run_cli("amplify " + f.low + " -o " + f.tmp.path("out.tif") + " --dictionary " + f.tmp.path("d.tdic"));
  ASSERT_EQ(amp.exit_code, 0) << amp.out;
  const Heightfield out = read_heightfield(f.tmp.path("out.tif"));
  const Heightfield low = read_heightfield(f.low);
  EXPECT_EQ(out.width, 128);
  EXPECT_EQ(out.height, 96);
  EXPECT_NEAR(out.georef.cell_x * 4, low.georef.cell_x, 1e-6 * low.georef.cell_x);
  EXPECT_NEAR(out.georef.geotransform[1] * 4, low.georef.geotransform[1], 1e-12);
  const Heightfield m = block_mean(out, 4);
  for (size_t i = 0; i < m.size(); ++i) ASSERT_NEAR(m.z[i], low.z[i], 0.05f);
}

// A bundled style's dictionary needs no file: --dictionary style:NAME, in a pipeline as well
// (validation accepts it); an unknown style is refused with the list.
TEST(AmplifyCli, BundledStyleDictionaries) {
  Files f;
  const auto amp = test::run_cli("-q amplify " + f.low + " -o " + f.tmp.path("s.tif") + " --dictionary style:eroded_hills");
  ASSERT_EQ(amp.exit_code, 0) << amp.out;
  const Heightfield out = read_heightfield(f.tmp.path("s.tif"));
  const Heightfield low = read_heightfield(f.low);
  ASSERT_EQ(out.width, 128);
  const Heightfield m = block_mean(out, 4);
  double detail = 0;
  for (size_t i = 0; i < m.size(); ++i) ASSERT_NEAR(m.z[i], low.z[i], 0.05f);
  for (size_t i = 1; i < out.z.size(); ++i) detail += std::fabs(double(out.z[i]) - out.z[i - 1]);
  EXPECT_GT(detail, 0);
  {
    std::ofstream(f.tmp.path("p.json")) << "[\"" << f.low << "\", {\"type\": \"amplify\", \"dictionary\": \"style:alpine\"}, \""
                                        << f.tmp.path("p.tif") << "\"]";
  }
  const auto run = test::run_cli("-q run " + f.tmp.path("p.json"));
  EXPECT_EQ(run.exit_code, 0) << run.out;
  const auto bad = test::run_cli("-q amplify " + f.low + " -o " + f.tmp.path("b.tif") + " --dictionary style:lunar");
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.out.find("dissected_plateau"), std::string::npos) << bad.out;
  EXPECT_FALSE(std::filesystem::exists(f.tmp.path("b.tif")));
}

TEST(AmplifyCli, AmplifyFromExemplarAndBadArguments) {
  Files f;
  const auto ok = test::run_cli("amplify " + f.low + " -o " + f.tmp.path("a.tif") + " --exemplar " + f.exemplar +
                                " --method complete");
  ASSERT_EQ(ok.exit_code, 0) << ok.out;
  const auto bad_factor = test::run_cli("amplify " + f.low + " -o " + f.tmp.path("b.tif") + " --exemplar " + f.exemplar + " --factor 8");
  EXPECT_NE(bad_factor.exit_code, 0);
  EXPECT_NE(bad_factor.out.find("factor 8 is not supported"), std::string::npos) << bad_factor.out;
  const auto none = test::run_cli("amplify " + f.low + " -o " + f.tmp.path("c.tif"));
  EXPECT_NE(none.exit_code, 0);
  EXPECT_NE(none.out.find("--exemplar"), std::string::npos) << none.out;
  // The exemplar at the input's own resolution cannot supply 4x finer detail.
  const auto coarse = test::run_cli("amplify " + f.low + " -o " + f.tmp.path("d.tif") + " --exemplar " + f.low);
  EXPECT_NE(coarse.exit_code, 0);
  EXPECT_NE(coarse.out.find("mismatched cell sizes"), std::string::npos) << coarse.out;
  std::ofstream(f.tmp.path("bad.tdic"), std::ios::binary) << "TDIC\x01\x00\x00\x00garbage";
  const auto corrupt = test::run_cli("amplify " + f.low + " -o " + f.tmp.path("e.tif") + " --dictionary " + f.tmp.path("bad.tdic"));
  EXPECT_NE(corrupt.exit_code, 0);
  EXPECT_NE(corrupt.out.find("bad.tdic"), std::string::npos) << corrupt.out;
  EXPECT_FALSE(std::filesystem::exists(f.tmp.path("e.tif")));
}

TEST(AmplifyCli, FlannAmplificationIsReproducibleAcrossProcesses) {
  Files f;
  auto run = [&](const std::string& out, int seed) {
    const auto r = test::run_cli("amplify " + f.low + " -o " + f.tmp.path(out) + " --exemplar " + f.exemplar +
                                 " --method complete --search flann --checks 4 --seed " + std::to_string(seed));
    EXPECT_EQ(r.exit_code, 0) << r.out;
    return read_heightfield(f.tmp.path(out)).z;
  };
  const auto a = run("a.tif", 3), b = run("b.tif", 3), c = run("c.tif", 4);
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(0, std::memcmp(a.data(), b.data(), a.size() * sizeof(float)));
  EXPECT_NE(0, std::memcmp(a.data(), c.data(), a.size() * sizeof(float)));
}

TEST(AmplifyCli, EncodeReportsRhoAndPsnr) {
  const auto r = test::run_cli("dictionary encode " + test::data_path("crops/frontrange_64.asc") +
                               " --atoms 16 --patch 8 --iterations 2 --sparsity 1 2");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_NE(r.out.find("| sparsity | rho"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("|        2 |"), std::string::npos) << r.out;
}

TEST(AmplifyCli, SketchSynthesis) {
  test::TempDir tmp;
  Heightfield sketch(24, 20, 0.f);
  for (int y = 6; y < 14; ++y)
    for (int x = 6; x < 18; ++x) sketch.at(x, y) = 1000.f;  // a painted plateau
  write_heightfield(sketch, tmp.path("sketch.png"));
  const auto learn = test::run_cli("dictionary learn " + test::data_path("crops/presidential_128x96.tif") + " -o " +
                                   tmp.path("d.tdic") + " --method complete");
  ASSERT_EQ(learn.exit_code, 0) << learn.out;
  const auto r = test::run_cli("dictionary sketch " + tmp.path("sketch.png") + " -o " + tmp.path("out.tif") + " --dictionary " +
                               tmp.path("d.tdic") + " --zmin 0 --zmax 1000 --cell 200 --factor 4");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const Heightfield out = read_heightfield(tmp.path("out.tif"));
  EXPECT_EQ(out.width, 96);
  EXPECT_EQ(out.height, 80);
  EXPECT_NEAR(out.georef.cell_x, 50.0, 1e-6);
  EXPECT_EQ(out.count_nodata(), 0u);
  EXPECT_GT(out.at(48, 40), 800.f);  // plateau centre stays high
  EXPECT_LT(out.at(4, 4), 200.f);    // the plain stays low
}

TEST(AmplifyCli, ResampleExemplarToTheOutputCellSize) {
  // Output cells 1.5 x the exemplar's: not a whole multiple, so the exemplar is refused as it is and
  // accepted once GDAL has averaged it to the output's cells.
  test::TempDir tmp;
  const std::string ex = test::data_path("crops/presidential_128x96.tif");
  const Heightfield e = read_heightfield(ex);
  const Heightfield low = block_mean(e, 6);
  write_heightfield(low, tmp.path("low.tif"));
  const auto refused = test::run_cli("amplify " + tmp.path("low.tif") + " -o " + tmp.path("a.tif") + " --exemplar " + ex);
  EXPECT_NE(refused.exit_code, 0);
  EXPECT_NE(refused.out.find("mismatched cell sizes"), std::string::npos) << refused.out;
  const auto ok = test::run_cli("amplify " + tmp.path("low.tif") + " -o " + tmp.path("b.tif") + " --exemplar " + ex +
                                " --resample-exemplar");
  ASSERT_EQ(ok.exit_code, 0) << ok.out;
  const Heightfield out = read_heightfield(tmp.path("b.tif"));
  EXPECT_EQ(out.width, low.width * 4);
  EXPECT_NEAR(out.georef.cell_x, 1.5 * e.georef.cell_x, 1e-3 * e.georef.cell_x);
  const Heightfield m = block_mean(out, 4);
  for (size_t i = 0; i < m.size(); ++i) ASSERT_NEAR(m.z[i], low.z[i], 0.05f);
  // An exemplar coarser than the output cannot be resampled into detail.
  const auto coarse = test::run_cli("amplify " + tmp.path("low.tif") + " -o " + tmp.path("c.tif") + " --exemplar " +
                                    tmp.path("low.tif") + " --resample-exemplar");
  EXPECT_NE(coarse.exit_code, 0);
  EXPECT_NE(coarse.out.find("resampling cannot add detail"), std::string::npos) << coarse.out;
}

TEST(AmplifyCli, ResampledExemplarMatchesItsBlockMeans) {
  // Output cells 2 x the exemplar's: amplify block-averages the exemplar itself, and with
  // --resample-exemplar the shared GDAL warp (io/warp.cpp, -r average) does it instead. On an aligned
  // whole ratio both are the same means, so the outputs must be identical (exact atom search).
  test::TempDir tmp;
  const std::string ex = test::data_path("crops/presidential_128x96.tif");
  write_heightfield(block_mean(read_heightfield(ex), 8), tmp.path("low.tif"));
  const std::string base = "amplify " + tmp.path("low.tif") + " --exemplar " + ex + " --search exact -o ";
  const auto a = test::run_cli(base + tmp.path("a.tif"));
  ASSERT_EQ(a.exit_code, 0) << a.out;
  const auto b = test::run_cli(base + tmp.path("b.tif") + " --resample-exemplar");
  ASSERT_EQ(b.exit_code, 0) << b.out;
  const Heightfield ha = read_heightfield(tmp.path("a.tif")), hb = read_heightfield(tmp.path("b.tif"));
  ASSERT_EQ(ha.width, hb.width);
  ASSERT_EQ(ha.height, hb.height);
  double worst = 0;
  for (size_t i = 0; i < ha.size(); ++i) worst = std::max(worst, double(std::fabs(ha.z[i] - hb.z[i])));
  EXPECT_LT(worst, 1e-3) << "the warped exemplar differs from its block means";
}

TEST(AmplifyCli, FaithfulModeWithAStoredRegression) {
  // `dictionary learn` stores the faithful regression (format version 3); `amplify --mode faithful
  // --dictionary` uses it without the exemplar and gives what --exemplar gives, bit for bit.
  Files f;
  const auto learn = test::run_cli("dictionary learn " + f.exemplar + " -o " + f.tmp.path("d.tdic") +
                                   " --method complete --max-patches 2000");
  ASSERT_EQ(learn.exit_code, 0) << learn.out;
  EXPECT_NE(learn.out.find("faithful regression radius 3"), std::string::npos) << learn.out;
  const auto a = test::run_cli("amplify " + f.low + " -o " + f.tmp.path("a.tif") + " --mode faithful --dictionary " +
                               f.tmp.path("d.tdic"));
  ASSERT_EQ(a.exit_code, 0) << a.out;
  const auto b = test::run_cli("amplify " + f.low + " -o " + f.tmp.path("b.tif") + " --mode faithful --exemplar " + f.exemplar);
  ASSERT_EQ(b.exit_code, 0) << b.out;
  const Heightfield ha = read_heightfield(f.tmp.path("a.tif")), hb = read_heightfield(f.tmp.path("b.tif"));
  ASSERT_EQ(ha.size(), hb.size());
  EXPECT_EQ(0, std::memcmp(ha.z.data(), hb.z.data(), ha.size() * sizeof(float)));
  // Without the regression: an error naming the dictionary, and no output.
  const auto none = test::run_cli("dictionary learn " + f.exemplar + " -o " + f.tmp.path("n.tdic") +
                                  " --method complete --max-patches 2000 --faithful-radius 0");
  ASSERT_EQ(none.exit_code, 0) << none.out;
  const auto c = test::run_cli("amplify " + f.low + " -o " + f.tmp.path("c.tif") + " --mode faithful --dictionary " +
                               f.tmp.path("n.tdic"));
  EXPECT_NE(c.exit_code, 0);
  EXPECT_NE(c.out.find("n.tdic stores no faithful regression"), std::string::npos) << c.out;
  EXPECT_FALSE(std::filesystem::exists(f.tmp.path("c.tif")));
}

TEST(AmplifyCli, EvaluateAveragesThePeriodicTraceOverSeeds) {
  // `dictionary evaluate --trace-seeds N`: pk S and pk f come from N seeds' curvature spectra, every
  // other column from --seed's output alone.
  const std::string dem = test::data_path("crops/presidential_utm30_192.tif");
  auto row = [&](const std::string& extra) {
    const auto r = test::run_cli("-q dictionary evaluate " + dem + " --factor 4 --max-patches 3000 " + extra);
    EXPECT_EQ(r.exit_code, 0) << r.out;
    const size_t at = r.out.find("complete P16");
    EXPECT_NE(at, std::string::npos) << r.out;
    std::vector<std::string> cols;
    std::string cell;
    for (size_t i = at == std::string::npos ? 0 : at; i < r.out.size() && r.out[i] != '\n'; ++i)
      if (r.out[i] == '|') cols.push_back(cell), cell.clear();
      else cell += r.out[i];
    return cols;  // method, RMSE, PSNR, HF, rough, slope, LR, pk S, pk f, D8
  };
  const auto one = row(""), two = row("--trace-seeds 2");
  ASSERT_GE(one.size(), 9u);
  ASSERT_EQ(one.size(), two.size());
  for (size_t i = 1; i <= 6; ++i) EXPECT_EQ(one[i], two[i]) << "column " << i;
  EXPECT_NE(one[7], two[7]) << "pk S over two seeds";
  EXPECT_NE(test::run_cli("-q dictionary evaluate " + dem + " --trace-seeds 0").exit_code, 0);
}
