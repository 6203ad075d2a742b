// SPDX-License-Identifier: Apache-2.0
// The studio's Export dialog (POST /api/export {name, format, preset, masks}): the terrain at an
// engine size and the masks the session can make, each checked against an independent answer.
#include <httplib.h>

#include <cmath>
#include <cstring>
#include <nlohmann/json.hpp>
#include <terracl/analysis.hpp>
#include <terracl/io.hpp>

#include "studio_client.hpp"
#include "test_helpers.hpp"

namespace terracl {
namespace {

using json = nlohmann::json;
using test::post;
using test::Studio;

// A range, an erosion in a disc around its middle, and a lake 4 m deep on the plain's corner.
const json kOps = json::array({
    {{"op", "mountain_range"}, {"points", {{200, 480}, {640, 380}, {1080, 420}}}, {"height", 120}},
    {{"op", "erode"}, {"steps", 30}, {"preset", "young_alpine"}, {"center", {640, 420}}, {"radius", 300}, {"falloff", 50}},
    {{"op", "lake"}, {"seed", {30, 30}}, {"level", 4}},
});

TEST(StudioExport, TerrainAtAnEngineSizeWithEveryMask) {
  Studio s;
  auto c = s.client();
  post(c, "/api/script", {{"operations", kOps}});
  const json r = post(c, "/api/export", {{"name", "map"}, {"format", "png16"}, {"preset", "unity-513"},
                                         {"masks", {"flow", "slope", "wear", "deposition", "water"}}});
  ASSERT_EQ(r["written"].size(), 6u) << r.dump();
  EXPECT_EQ(r["size"], json({513, 513}));
  for (const auto& p : r["written"]) {
    const Heightfield m = read_heightfield(p.get<std::string>());
    EXPECT_EQ(m.width, 513) << p;
    EXPECT_EQ(m.height, 513) << p;
    EXPECT_EQ(test::file_bytes(p.get<std::string>()).substr(1, 3), "PNG") << p;
    EXPECT_EQ(uint8_t(test::file_bytes(p.get<std::string>())[24]), 16) << p << ": bit depth";
  }
  for (const char* m : {"flow", "slope", "wear", "deposition", "water"}) EXPECT_GT(r["masks"][m]["max"].get<double>(), 0) << m;
  EXPECT_EQ(r["masks"]["slope"]["unit"], "degrees");
}

TEST(StudioExport, MasksAgreeWithIndependentAnswers) {
  Studio s;
  auto c = s.client();
  post(c, "/api/script", {{"operations", kOps}});
  const json r = post(c, "/api/export", {{"name", "native"}, {"format", "tif"}, {"masks", {"slope", "wear", "deposition", "water"}}});
  const std::string ws = s.dir.path("ws") + "/";
  const Heightfield t = read_heightfield(ws + "native.tif");
  // slope: Horn's slope of the exported terrain, within the 16-bit quantisation
  const Heightfield slope = read_heightfield(ws + "native_slope.png");
  const std::vector<float> ref = analysis::slope_degrees(t);
  const double q = r["masks"]["slope"]["max"].get<double>() / 65535.0;
  double worst = 0;
  for (size_t i = 0; i < ref.size(); ++i) worst = std::max(worst, std::abs(double(slope.z[i]) - ref[i]));
  EXPECT_LT(worst, 2 * q + 1e-3);
  // wear and deposition only where the erosion's brush reached (its disc plus falloff)
  const Heightfield wear = read_heightfield(ws + "native_wear.png"), dep = read_heightfield(ws + "native_deposition.png");
  size_t worn = 0;
  for (int y = 0; y < t.height; ++y)
    for (int x = 0; x < t.width; ++x) {
      const size_t i = size_t(y) * t.width + x;
      const double d = std::hypot(x * 10.0 - 640, y * 10.0 - 420);
      if (d > 360) {
        ASSERT_LT(wear.z[i], 1e-3) << x << "," << y;
        ASSERT_LT(dep.z[i], 1e-3) << x << "," << y;
      }
      worn += wear.z[i] > 0.01;
      ASSERT_FALSE(wear.z[i] > 1e-3 && dep.z[i] > 1e-3) << "a cell both worn and filled";
    }
  EXPECT_GT(worn, 100u);
  // water: the lake's depth, only below its level
  const Heightfield water = read_heightfield(ws + "native_water.png");
  const double wq = r["masks"]["water"]["max"].get<double>() / 65535.0;
  size_t wet = 0;
  for (size_t i = 0; i < t.z.size(); ++i) {
    if (water.z[i] > wq) {
      ++wet;
      EXPECT_NEAR(t.z[i] + water.z[i], 4.0, 2 * wq + 1e-3);
    } else {
      EXPECT_GE(t.z[i] + wq, 4.0 - 2 * wq - 1e-3);
    }
  }
  EXPECT_GT(wet, 100u);
}

TEST(StudioExport, AGlbCarriesATexturedMaterial) {
  Studio s;
  auto c = s.client();
  post(c, "/api/operations", {{"op", kOps[0]}});
  const json r = post(c, "/api/export", {{"name", "mesh"}, {"format", "glb"}});
  const std::string glb = test::file_bytes(r["written"][0].get<std::string>());
  ASSERT_GT(glb.size(), 20u);
  ASSERT_EQ(glb.substr(0, 4), "glTF");
  uint32_t len = 0;
  std::memcpy(&len, glb.data() + 12, 4);
  const json gltf = json::parse(glb.substr(20, len));
  ASSERT_EQ(gltf["materials"].size(), 1u);
  EXPECT_EQ(gltf["materials"][0]["pbrMetallicRoughness"]["metallicFactor"], 0.0);
  EXPECT_EQ(gltf["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["index"], 0);
  EXPECT_EQ(gltf["images"][0]["mimeType"], "image/png");
  EXPECT_EQ(gltf["meshes"][0]["primitives"][0]["material"], 0);
}

TEST(StudioExport, BadRequestsAreRefusedAndWriteNothing) {
  Studio s;
  auto c = s.client();
  post(c, "/api/operations", {{"op", kOps[0]}});
  auto error = [&](const json& b, int status) {
    const json e = post(c, "/api/export", b, status);
    return e.value("error", std::string());
  };
  EXPECT_NE(error({{"name", "a"}, {"masks", {"height"}}}, 400).find("/masks/0"), std::string::npos);
  EXPECT_NE(error({{"name", "a"}, {"masks", {"slope", "wear"}}}, 400).find("erode"), std::string::npos);
  EXPECT_NE(error({{"name", "a"}, {"masks", {"water"}}}, 400).find("lake"), std::string::npos);
  EXPECT_NE(error({{"name", "a"}, {"format", "bmp"}}, 400).find("/format"), std::string::npos);
  EXPECT_NE(error({{"name", "a"}, {"preset", "unreal-3"}}, 400).find("/preset"), std::string::npos);
  error({{"name", "../a"}}, 403);
  EXPECT_FALSE(path_exists(s.dir.path("ws") + "/a.tif"));
  EXPECT_FALSE(path_exists(s.dir.path("ws") + "/a_slope.png"));
}

}  // namespace
}  // namespace terracl
