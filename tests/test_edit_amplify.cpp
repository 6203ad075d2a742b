// SPDX-License-Identifier: Apache-2.0
// The "amplify" edit operation (studio issue: amplification of the terrain or a region as an
// operation): detail finer than the factor replaced by sparse-dictionary detail, block means kept,
// nothing changed outside the region, replays bit for bit, bad parameters refused with their path.
#include "test_helpers.hpp"

#include <terracl/amplify.hpp>
#include <terracl/edit.hpp>
#include <terracl/error.hpp>
#include <terracl/io.hpp>

#include <cmath>
#include <cstring>

using namespace terracl;
using json = nlohmann::json;

namespace {

const std::string kExemplar = test::data_path("crops/presidential_128x96.tif");

Heightfield n44_crop(int x0, int y0, int n) {
  Heightfield h = read_heightfield(test::data_path("dem/N44W072.hgt"));
  Heightfield c(n, n);
  c.georef = h.georef;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) c.at(x, y) = h.at(x0 + x, y0 + y);
  return c;
}

double rms(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x * x;
  return v.empty() ? 0 : std::sqrt(s / double(v.size()));
}

}  // namespace

TEST(EditAmplify, ReplacesDetailInsideTheRegionOnly) {
  const int n = 193, c = 96, f = 4;
  const Heightfield base = n44_crop(500, 300, n);
  const double cx = base.georef.cell_x, cy = base.georef.cell_y;
  json op = {{"op", "amplify"}, {"exemplar", kExemplar}, {"center", {c, c}}, {"radius", 16}, {"falloff", 4}};
  EditSession s(test::device(), base);
  s.apply(json{{"units", "cells"}, {"operations", {op}}});
  const Heightfield& h = s.height();
  size_t far = 0, far_exact = 0;
  std::vector<double> change, block_change;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const double d = std::hypot((x - c) * cx, (y - c) * cy) / cx;  // in x cells
      const float a = h.at(x, y), b = base.at(x, y);
      if (d > 90) {
        ++far;
        far_exact += std::memcmp(&a, &b, sizeof a) == 0;
      }
    }
  // Inside the disc: f x f blocks wholly inside, aligned with the operation's blocks (origin 0).
  for (int by = 0; by + f <= n; by += f)
    for (int bx = 0; bx + f <= n; bx += f) {
      if (std::hypot((bx + 2 - c) * cx, (by + 2 - c) * cy) / cx > 12) continue;
      double m = 0;
      for (int y = by; y < by + f; ++y)
        for (int x = bx; x < bx + f; ++x) {
          const double d = double(h.at(x, y)) - base.at(x, y);
          change.push_back(d);
          m += d;
        }
      block_change.push_back(m / (f * f));
    }
  ASSERT_GT(far, size_t(1000));
  EXPECT_EQ(far_exact, far) << "cells far outside the region keep the base bit for bit";
  ASSERT_FALSE(change.empty());
  const double detail = rms(change), means = rms(block_change);
  std::printf("amplify region: detail change rms %.2f m, block-mean change rms %.2f m\n", detail, means);
  EXPECT_GT(detail, 1.0) << "the detail was replaced";
  EXPECT_LT(means, 0.35 * detail) << "the f x f block means stay (the forms are kept, the texture changes)";
  EXPECT_GT(s.log()[0].value("dictionary_atoms", 0), 100);
}

TEST(EditAmplify, GivesASmoothSketchTheExemplarsRoughness) {
  const json crest = {{"op", "crest"}, {"points", {{20, 30, 500}, {100, 90, 800}}}, {"radius", 30}, {"profile", "round"}};
  const json amp = {{"op", "amplify"}, {"exemplar", kExemplar}};
  auto run = [&](bool amplified) {
    EditSession s(test::device(), *parse_flat_spec("flat:129x129@90"));
    json ops = {crest};
    if (amplified) ops.push_back(amp);
    s.apply(json{{"units", "cells"}, {"operations", ops}});
    return s.height();
  };
  const Heightfield smooth = run(false), rough = run(true), again = run(true);
  const double r0 = roughness(smooth, 4), r1 = roughness(rough, 4);
  std::printf("roughness (4 cells) of the sketch %.3f m, amplified %.3f m\n", r0, r1);
  EXPECT_GT(r1, 1.8 * r0) << "the detail was not replaced by the exemplar's";
  require_finite(rough, "test", "amplified");
  ASSERT_EQ(rough.z.size(), again.z.size());
  EXPECT_EQ(0, std::memcmp(rough.z.data(), again.z.data(), rough.z.size() * sizeof(float))) << "replays bit for bit";
}

TEST(EditAmplify, RefusesBadParametersWithTheirPath) {
  EditSession s(test::device(), *parse_flat_spec("flat:65x65@30"));
  auto message = [&](const json& op) {
    try {
      s.validate(json{{"operations", {op}}});
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message({{"op", "amplify"}}).find("/operations/0: give either dictionary"), std::string::npos);
  EXPECT_NE(message({{"op", "amplify"}, {"exemplar", kExemplar}, {"dictionary", "x.tdic"}}).find("give either"),
            std::string::npos);
  EXPECT_NE(message({{"op", "amplify"}, {"exemplar", "no/such/dem.tif"}}).find("/operations/0/exemplar: file 'no/such/dem.tif' not found"),
            std::string::npos);
  // The exemplar's cells (~67 x 93 m) are not the terrain's 30 m: without rescale that is an error.
  EXPECT_NE(message({{"op", "amplify"}, {"exemplar", kExemplar}, {"rescale", false}}).find("/operations/0/exemplar: its cells are"),
            std::string::npos);
  EXPECT_NE(message({{"op", "amplify"}, {"exemplar", kExemplar}, {"strength", -1}}).find("/operations/0/strength"),
            std::string::npos);
}
