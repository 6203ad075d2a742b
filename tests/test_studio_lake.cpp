// SPDX-License-Identifier: Apache-2.0
// The studio's lake tool through its JSON API: the state carries each lake's figures, the water
// layer comes as float32 like the terrain, the terrain keeps its bits, and the saved script
// replays the same water on the CLI (terracl edit --water).
#include <httplib.h>

#include <cstring>
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <terracl/io.hpp>
#include <terracl/studio.hpp>

#include "lake_terrain.hpp"
#include "studio_client.hpp"
#include "test_helpers.hpp"

namespace terracl {
namespace {

using json = nlohmann::json;
using test::f32;
using test::post;


TEST(StudioApi, LakeToolFillsTheBasinAndServesTheWaterLayer) {
  test::TempDir dir;
  const Heightfield base = test::two_basins();
  write_heightfield(base, dir.path("base.tif"));
  StudioOptions o;
  o.base = dir.path("base.tif");
  o.port = 0;
  o.workspace = dir.path("ws");
  StudioServer server(test::device(), o);
  httplib::Client c("127.0.0.1", server.start());
  c.set_read_timeout(120, 0);
  c.set_default_headers({{"X-Terracl-Token", server.token()}});

  json st = json::parse(c.Get("/api/state")->body);
  EXPECT_EQ(st["lakes"], json::array());
  for (float d : f32(c, "/api/water.f32")) ASSERT_EQ(d, 0.f);  // no lake: a dry layer

  st = post(c, "/api/operations", {{"op", {{"op", "lake"}, {"seed", {test::kSeedA[0], test::kSeedA[1]}}}}});
  EXPECT_EQ(st["last"]["mode"], "append");
  ASSERT_EQ(st["lakes"].size(), 1u);
  EXPECT_EQ(st["lakes"][0]["level_m"].get<double>(), 100.0);
  EXPECT_EQ(st["lakes"][0]["cells"].get<size_t>(), 455u);
  EXPECT_EQ(f32(c, "/api/water.f32"), test::brute_force_lake(base, 11, 11, 100.0));
  EXPECT_EQ(f32(c, "/api/terrain.f32"), base.z) << "the lake leaves the terrain's bits alone";
  // Sampled like terrain.f32 (the same cells for the same max).
  auto r = c.Get("/api/water.f32?max=25");
  auto t = c.Get("/api/terrain.f32?max=25");
  ASSERT_TRUE(r && r->status == 200 && t && t->status == 200);
  EXPECT_EQ(r->get_header_value("X-Step"), "2");
  for (const char* h : {"X-Width", "X-Height", "X-Step", "X-Cell-X"}) EXPECT_EQ(r->get_header_value(h), t->get_header_value(h)) << h;
  EXPECT_EQ(r->body.size(), t->body.size());

  // An empty lake: its warning is in the state, naming the operation's seed.
  st = post(c, "/api/operations", {{"op", {{"op", "lake"}, {"seed", {230, 50}}}}});
  ASSERT_EQ(st["lakes"].size(), 2u);
  ASSERT_EQ(st["lakes"][1]["warnings"].size(), 1u);
  EXPECT_NE(st["lakes"][1]["warnings"][0].get<std::string>().find("/operations/1/seed"), std::string::npos);
  // A seed off the grid is refused with its path and changes nothing.
  json bad = post(c, "/api/operations", {{"op", {{"op", "lake"}, {"seed", {-500, 50}}}}}, 400);
  EXPECT_NE(bad["error"].get<std::string>().find("/operations/2/seed"), std::string::npos) << bad.dump();

  // The saved script replays the same water on the CLI.
  post(c, "/api/save", {{"path", "lake.json"}});
  const auto cli = test::run_cli(fmt::format("-q edit --script {} -o {} --water {}", dir.path("ws/lake.json"),
                                             dir.path("o.tif"), dir.path("w.tif")));
  ASSERT_EQ(cli.exit_code, 0) << cli.out;
  EXPECT_EQ(read_heightfield(dir.path("w.tif")).z, f32(c, "/api/water.f32"));
  server.stop();
}

}  // namespace
}  // namespace terracl
