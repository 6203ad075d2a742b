// SPDX-License-Identifier: Apache-2.0
// terracl studio's JSON API end to end: a real server on a free port of 127.0.0.1 (in this
// process), real httplib clients, and the saved script replayed by the real `terracl edit`.
#include <httplib.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <terracl/io.hpp>
#include <terracl/studio.hpp>

#include "studio_client.hpp"
#include "test_helpers.hpp"

namespace terracl {
namespace {

using json = nlohmann::json;
using test::TempDir;
using test::body;
using test::post;
using test::Studio;


std::vector<float> terrain(httplib::Client& c) {
  auto r = c.Get("/api/terrain.f32");
  EXPECT_TRUE(r && r->status == 200);
  std::vector<float> v(r->body.size() / sizeof(float));
  std::memcpy(v.data(), r->body.data(), r->body.size());
  return v;
}

const json kCrest = {{"op", "crest"}, {"points", {{200, 480}, {1080, 400}}}, {"elevation", 120}, {"radius", 300}};
const json kNoise = {{"op", "noise"}, {"amplitude", 15}, {"wavelength", 200}};
const json kRiver = {{"op", "river"}, {"points", {{100, 100, 20}, {1200, 800, 5}}}, {"radius", 150}};

TEST(StudioApi, EditsUndoRedoReorderSaveAndReplayBitForBitOnTheCli) {
  Studio s;
  auto c = s.client();
  const std::vector<float> flat = terrain(c);
  EXPECT_EQ(flat.size(), 129u * 97u);

  json st = post(c, "/api/operations", {{"op", kCrest}});
  EXPECT_EQ(st["operations"].size(), 1u);
  EXPECT_EQ(st["last"]["mode"], "append");  // warm: one operation and a warm solve
  const std::vector<float> crest = terrain(c);
  EXPECT_NEAR(*std::max_element(crest.begin(), crest.end()), 120.f, 1e-3);

  post(c, "/api/operations", {{"op", kNoise}});
  {
    // The appended noise ran alone (warm) but with its script index, hence its default seed: the
    // live terrain matches the canonical replay (GeoTIFF) within the solver's tolerance.
    const std::vector<float> live = terrain(c);
    auto tif = c.Get("/api/terrain.tif");
    ASSERT_TRUE(tif && tif->status == 200);
    std::ofstream(s.dir.path("canon.tif"), std::ios::binary) << tif->body;
    const Heightfield canon = read_heightfield(s.dir.path("canon.tif"));
    ASSERT_EQ(canon.z.size(), live.size());
    double d = 0;
    for (size_t i = 0; i < live.size(); ++i) d = std::max(d, double(std::fabs(live[i] - canon.z[i])));
    EXPECT_LT(d, 0.5);
  }
  post(c, "/api/operations", {{"op", kRiver}, {"index", 0}});  // inserted first: a replay
  st = post(c, "/api/undo", json::object());
  EXPECT_EQ(st["operations"].size(), 2u);
  EXPECT_EQ(st["last"]["mode"], "replay");
  st = post(c, "/api/redo", json::object());
  EXPECT_EQ(st["operations"].size(), 3u);
  EXPECT_EQ(st["operations"][0]["op"], "river");
  st = post(c, "/api/operations/0/move", {{"to", 2}});
  EXPECT_EQ(st["operations"][2]["op"], "river");
  st = post(c, "/api/operations/1/visible", {{"visible", false}});
  EXPECT_EQ(st["operations"][1]["enabled"], false);
  auto upd = c.Put(
      "/api/operations/0",
      json{{"op", {{"op", "crest"}, {"points", {{200, 480}, {1080, 400}}}, {"elevation", 90}, {"radius", 250}}}}.dump(),
      "application/json");
  ASSERT_TRUE(upd);
  EXPECT_EQ(upd->status, 200) << upd->body;

  // A second client (another tab) sees the same session.
  httplib::Client c2 = s.client();
  const json st2 = body(c2.Get("/api/state"));
  EXPECT_EQ(st2["version"], body(c.Get("/api/state"))["version"]);
  EXPECT_EQ(st2["operations"].size(), 3u);  // (before the append below)
  EXPECT_EQ(st2["operations"][0]["elevation"], 90);

  // The last change an append: the live terrain is the warm incremental solve, the export must
  // still be what `terracl edit` computes.
  st = post(c, "/api/operations",
            {{"op", {{"op", "ravine"}, {"points", {{300, 700}, {900, 200}}}, {"depth", 30}, {"radius", 120}}}});
  EXPECT_EQ(st["last"]["mode"], "append");

  post(c, "/api/save", {{"path", "sessions/s.json"}});
  post(c, "/api/export", {{"path", "out.tif"}});
  for (const char* f : {"out.exr", "out.png", "out.r16", "out.glb"}) post(c, "/api/export", {{"path", f}});
  const std::string script = s.dir.path("ws/sessions/s.json");
  const std::string cli_out = s.dir.path("cli.tif");
  const auto r = test::run_cli("-q edit --script " + script + " -o " + cli_out);
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const Heightfield a = read_heightfield(s.dir.path("ws/out.tif"));
  const Heightfield b = read_heightfield(cli_out);
  ASSERT_EQ(a.z.size(), b.z.size());
  EXPECT_EQ(0, std::memcmp(a.z.data(), b.z.data(), a.z.size() * sizeof(float))) << "studio export != terracl edit";
  // The live (warm, incremental) terrain is the same solve within the solver's tolerance.
  const std::vector<float> live = terrain(c);
  double maxdiff = 0;
  for (size_t i = 0; i < live.size(); ++i) maxdiff = std::max(maxdiff, double(std::fabs(live[i] - b.z[i])));
  EXPECT_LT(maxdiff, 0.5);

  // Loading the saved script back reproduces the operation list.
  post(c, "/api/operations", {{"op", kNoise}});
  st = post(c, "/api/load", {{"path", "sessions/s.json"}});
  EXPECT_EQ(st["operations"].size(), 4u);
}

TEST(StudioApi, BadInputIsRejectedWithItsPathAndTheSessionIsUnharmed) {
  Studio s;
  auto c = s.client();
  post(c, "/api/operations", {{"op", kCrest}});
  const json before = body(c.Get("/api/state"));
  const std::vector<float> t0 = terrain(c);

  auto bad = c.Post("/api/operations", "{\"op\": {\"op\": \"crest\",", "application/json");
  ASSERT_TRUE(bad);
  EXPECT_EQ(bad->status, 400);
  EXPECT_NE(bad->body.find("malformed JSON"), std::string::npos);
  json e = post(c, "/api/operations", {{"op", {{"op", "caldera"}}}}, 400);
  EXPECT_NE(e["error"].get<std::string>().find("/operations/1/op"), std::string::npos) << e;
  EXPECT_NE(e["error"].get<std::string>().find("unknown operation"), std::string::npos) << e;
  e = post(c, "/api/operations",
           {{"op", {{"op", "noise"}, {"amplitude", 5}, {"wavelength", 100}, {"octaves", 100000}}}}, 400);
  EXPECT_NE(e["error"].get<std::string>().find("/operations/1/octaves"), std::string::npos) << e;
  e = post(c, "/api/operations", {{"op", {{"op", "noise"}, {"amplitude", "NaN"}, {"wavelength", 100}}}}, 400);
  EXPECT_NE(e["error"].get<std::string>().find("/operations/1/amplitude"), std::string::npos) << e;
  json many = json::array();
  for (int i = 0; i < 1001; ++i) many.push_back(kNoise);
  e = post(c, "/api/script", {{"operations", many}}, 413);
  EXPECT_NE(e["error"].get<std::string>().find("at most 1000"), std::string::npos) << e;
  auto huge = c.Post("/api/script", std::string(17u << 20, ' '), "application/json");
  ASSERT_TRUE(huge);
  EXPECT_EQ(huge->status, 413);
  e = post(c, "/api/operations", {{"op", kNoise}, {"index", 99}}, 404);
  e = post(c, "/api/operations/7/move", {{"to", 0}}, 404);
  e = post(c, "/api/operations", {{"nope", 1}}, 400);
  e = post(c, "/api/erosion/step", json::object(), 409);
  auto big = c.Get("/api/terrain.f32?max=-3");
  ASSERT_TRUE(big);
  EXPECT_EQ(big->status, 400);

  // The workspace confines files.
  for (const char* p : {"../escape.json", "/tmp/escape.json", "a/../../escape.json", "sub/../../../etc/x.json"}) {
    e = post(c, "/api/save", {{"path", p}}, 403);
    EXPECT_NE(e["error"].get<std::string>().find("workspace"), std::string::npos) << p;
  }
  post(c, "/api/load", {{"path", "../../etc/passwd"}}, 403);
  post(c, "/api/export", {{"path", "../out.tif"}}, 403);
  post(c, "/api/export", {{"path", "out.txt"}}, 400);
  post(c, "/api/load", {{"path", "missing.json"}}, 404);
  // The page and three.js are served; nothing outside three.js's folder is.
  auto page = c.Get("/");
  ASSERT_TRUE(page);
  EXPECT_NE(page->body.find("studio.js"), std::string::npos);
  auto three = c.Get("/three/build/three.module.js");
  ASSERT_TRUE(three);
  EXPECT_EQ(three->status, 200);
  for (const char* p : {"/three/../../../etc/passwd.js", "/three/..%2f..%2fetc/x.js", "/web/..%2fstudio.js"}) {
    auto r = c.Get(p);
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 404) << p;
  }
  EXPECT_FALSE(std::filesystem::exists(s.dir.path("escape.json")));

  const json after = body(c.Get("/api/state"));
  EXPECT_EQ(after["version"], before["version"]);
  EXPECT_EQ(after["operations"], before["operations"]);
  EXPECT_EQ(terrain(c), t0);
}

// An operation whose support is smaller than a cell is accepted with a warning the page shows.
TEST(StudioApi, ResponsesAreNotCompressedForABrowserThatAcceptsIt) {
  // A browser accepts brotli; compressing a state or a script at brotli's top quality costs more
  // than the change it answers (server.cpp). The page itself (text/html, 7 KB) may be.
  Studio s;
  auto c = s.client();
  post(c, "/api/operations", {{"op", kCrest}});
  const httplib::Headers accept = {{"Accept-Encoding", "br, gzip, deflate"}};
  for (const char* path : {"/api/state", "/web/studio.js", "/three/build/three.module.js"}) {
    auto r = c.Get(path, accept);
    ASSERT_TRUE(r) << path;
    EXPECT_EQ(r->status, 200) << path;
    EXPECT_FALSE(r->has_header("Content-Encoding")) << path << ": " << r->get_header_value("Content-Encoding");
  }
  auto r = c.Get("/api/state", accept);
  EXPECT_EQ(body(r)["operations"].size(), 1u);
  EXPECT_EQ(r->get_header_value("Content-Type"), "application/json; charset=utf-8");
  EXPECT_EQ(c.Get("/web/studio.js")->get_header_value("Content-Type"), "application/javascript; charset=utf-8");
}

TEST(StudioApi, SubCellSupportIsAWarningInTheState) {
  Studio s;
  auto c = s.client();
  post(c, "/api/operations", {{"op", {{"op", "scale_slopes"}, {"center", {300, 300}}, {"radius", 2}, {"factor", 2}}}});
  const json st = body(c.Get("/api/state"));
  ASSERT_TRUE(st["last"].contains("warnings")) << st;
  ASSERT_EQ(st["last"]["warnings"].size(), 1u) << st;
  EXPECT_NE(st["last"]["warnings"][0].get<std::string>().find("/operations/0/radius"), std::string::npos) << st;
  post(c, "/api/operations", {{"op", kNoise}});
  EXPECT_TRUE(body(c.Get("/api/state"))["last"]["warnings"].empty());
}

TEST(StudioApi, LiveErosionBecomesAnErodeOperationThatReplays) {
  Studio s("flat:65x65@30");
  auto c = s.client();
  post(c, "/api/operations",
       {{"op", {{"op", "mountain_range"}, {"points", {{300, 900, 400}, {1600, 1000, 500}}}, {"radius", 600}}}});
  post(c, "/api/erosion/start", {{"rain", 0.02}, {"center", {960, 960}}, {"radius", 700}, {"falloff", 200}});
  std::vector<float> bed;
  for (int i = 0; i < 3; ++i) {
    auto r = c.Post("/api/erosion/step?steps=5", "", "application/json");
    ASSERT_TRUE(r);
    ASSERT_EQ(r->status, 200) << r->body;
    bed.resize(r->body.size() / 4);
    std::memcpy(bed.data(), r->body.data(), r->body.size());
  }
  const std::vector<float> before = terrain(c);
  double change = 0;
  for (size_t i = 0; i < bed.size(); ++i) change = std::max(change, double(std::fabs(bed[i] - before[i])));
  EXPECT_GT(change, 1e-3) << "15 erosion steps changed nothing";
  const json st = post(c, "/api/erosion/commit", json::object());
  ASSERT_EQ(st["operations"].size(), 2u);
  EXPECT_EQ(st["operations"][1]["op"], "erode");
  EXPECT_EQ(st["operations"][1]["steps"], 15);
  // The committed terrain is the preview's eroded bed (re-solved from its gradient).
  const std::vector<float> after = terrain(c);
  double diff = 0;
  for (size_t i = 0; i < bed.size(); ++i) diff = std::max(diff, double(std::fabs(after[i] - bed[i])));
  EXPECT_LT(diff, 0.05 * change + 1e-3);
  // The preview shows the settled bed, as the committed operation gives it (the re-solve keeps the
  // bed's mean): an unsettled preview would sit lower by the suspended load.
  double mean_bed = 0, mean_after = 0;
  for (size_t i = 0; i < bed.size(); ++i) mean_bed += bed[i], mean_after += after[i];
  EXPECT_NEAR(mean_after / double(bed.size()), mean_bed / double(bed.size()), 1e-3);

  post(c, "/api/save", {{"path", "eroded.json"}});
  post(c, "/api/export", {{"path", "eroded.tif"}});
  const auto r = test::run_cli("-q edit --script " + s.dir.path("ws/eroded.json") + " -o " + s.dir.path("cli.tif"));
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const Heightfield a = read_heightfield(s.dir.path("ws/eroded.tif"));
  const Heightfield b = read_heightfield(s.dir.path("cli.tif"));
  EXPECT_EQ(a.z, b.z);
}

// The page's drainage and layered-rock tools post these operations (apps/web/studio.js: a dragged
// disc or the whole map, and a clicked disc whose caprock is the highest preview cell in it); the
// session applies them and the terrain changes where they act.
TEST(StudioApi, DrainageAndLayeredRockToolsEditTheTerrain) {
  Studio s;
  auto c = s.client();
  post(c, "/api/operations", {{"op", {{"op", "mountain_range"}, {"points", {{200, 480}, {1080, 400}}}, {"height", 300}, {"radius", 300}}}});
  post(c, "/api/operations", {{"op", {{"op", "noise"}, {"amplitude", 20}, {"wavelength", 150}}}});
  const std::vector<float> t0 = terrain(c);
  json st = post(c, "/api/operations",
                 {{"op", {{"op", "drainage"}, {"depth", 60}, {"max_depth", 40}, {"threshold", 1000}, {"channel_width", 30}}}});
  EXPECT_EQ(st["operations"].size(), 3u);
  const std::vector<float> t1 = terrain(c);
  ASSERT_EQ(t0.size(), t1.size());
  double cut = 0;
  for (size_t i = 0; i < t0.size(); ++i) cut = std::max(cut, double(t0[i]) - double(t1[i]));
  EXPECT_GT(cut, 1.0) << "the drainage tool carves channels";
  float top = -1e30f;
  for (float v : t1) top = std::max(top, v);
  st = post(c, "/api/operations", {{"op", {{"op", "strata"}, {"center", {640, 440}}, {"radius", 500}, {"falloff", 25}, {"top", top},
                                            {"thickness", 25}, {"soft_thickness", 12}, {"min_slope", 25}}}});
  EXPECT_EQ(st["operations"].size(), 4u);
  const std::vector<float> t2 = terrain(c);
  size_t changed = 0;
  for (size_t i = 0; i < t1.size(); ++i) changed += std::abs(t2[i] - t1[i]) > 0.5f;
  EXPECT_GT(changed, 20u) << "the layered-rock tool steps the steep flanks";
}

}  // namespace
}  // namespace terracl
