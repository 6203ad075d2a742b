// SPDX-License-Identifier: Apache-2.0
// The studio's zoomed-in windows and its previews while drawing (docs/studio.md, "Feedback while
// drawing"): a window is exactly the cells of the full terrain; a preview records nothing and shows
// the stroke (new, or replacing one) on a coarse grid.
#include <httplib.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <thread>
#include <nlohmann/json.hpp>

#include "studio_client.hpp"
#include "test_helpers.hpp"

namespace terracl {
namespace {

using json = nlohmann::json;
using test::post;
using test::Studio;

struct Layer {
  int w = 0, h = 0, step = 0, x0 = 0, y0 = 0;
  std::vector<float> z;
  float at(int x, int y) const { return z[size_t(y) * w + x]; }
};

Layer layer(const httplib::Result& r) {
  Layer l;
  EXPECT_TRUE(r && r->status == 200) << (r ? r->body : "no answer");
  if (!r || r->status != 200) return l;
  l.w = std::stoi(r->get_header_value("X-Width"));
  l.h = std::stoi(r->get_header_value("X-Height"));
  l.step = std::stoi(r->get_header_value("X-Step"));
  l.x0 = std::stoi(r->get_header_value("X-X0"));
  l.y0 = std::stoi(r->get_header_value("X-Y0"));
  l.z.resize(r->body.size() / sizeof(float));
  std::memcpy(l.z.data(), r->body.data(), r->body.size());
  EXPECT_EQ(l.z.size(), size_t(l.w) * l.h);
  return l;
}

Layer preview(httplib::Client& c, const json& b, int max) {
  return layer(c.Post(("/api/preview?max=" + std::to_string(max)).c_str(), b.dump(), "application/json"));
}

// A crest relative to the ground, across the middle of a 1290 x 970 m plain.
const json kCrest = {{"op", "crest"}, {"points", {{200, 480}, {1080, 400}}}, {"height", 80}, {"radius", 200}};

TEST(StudioPreview, AWindowIsExactlyTheCellsOfTheTerrain) {
  Studio s;
  auto c = s.client();
  post(c, "/api/operations", {{"op", kCrest}});
  const Layer full = layer(c.Get("/api/terrain.f32"));
  ASSERT_EQ(full.w, 129);
  const Layer win = layer(c.Get("/api/terrain.f32?x0=30&y0=20&x1=90&y1=61"));
  ASSERT_EQ(win.w, 60);
  ASSERT_EQ(win.h, 41);
  EXPECT_EQ(win.step, 1);
  EXPECT_EQ(win.x0, 30);
  EXPECT_EQ(win.y0, 20);
  for (int y = 0; y < win.h; ++y)
    for (int x = 0; x < win.w; ++x) ASSERT_EQ(win.at(x, y), full.at(30 + x, 20 + y));
  // sampled: every step-th cell from the window's corner
  const Layer coarse = layer(c.Get("/api/terrain.f32?x0=10&y0=5&x1=129&y1=97&max=30"));
  ASSERT_GT(coarse.step, 1);
  for (int y = 0; y < coarse.h; ++y)
    for (int x = 0; x < coarse.w; ++x) ASSERT_EQ(coarse.at(x, y), full.at(10 + x * coarse.step, 5 + y * coarse.step));
  // a window reaching off the grid is clipped to it
  const Layer clipped = layer(c.Get("/api/terrain.f32?x0=-50&y0=90&x1=500&y1=200"));
  EXPECT_EQ(clipped.x0, 0);
  EXPECT_EQ(clipped.w, 129);
  EXPECT_EQ(clipped.h, 7);
  auto bad = c.Get("/api/terrain.f32?x0=abc");
  ASSERT_TRUE(bad);
  EXPECT_EQ(bad->status, 400);
}

TEST(StudioPreview, ANewStrokeShowsOnACoarseGridAndNothingIsRecorded) {
  Studio s;
  auto c = s.client();
  const json before = test::body(c.Get("/api/state"));
  const Layer p = preview(c, {{"op", kCrest}}, 33);
  ASSERT_EQ(p.step, 4);  // 129 cells -> every 4th: 33 x 25
  ASSERT_EQ(p.w, 33);
  ASSERT_EQ(p.h, 25);
  const json after = test::body(c.Get("/api/state"));
  EXPECT_EQ(after["version"], before["version"]);
  EXPECT_TRUE(after["operations"].empty());
  // The stroke, recorded now, gives the full-resolution terrain; the preview agrees with it on the
  // coarse cells to within a fraction of the crest's height (the same landform, solved coarser).
  post(c, "/api/operations", {{"op", kCrest}});
  const Layer full = layer(c.Get("/api/terrain.f32"));
  float top_p = 0, top_f = 0;
  double diff = 0;
  for (int y = 0; y < p.h; ++y)
    for (int x = 0; x < p.w; ++x) {
      const float f = full.at(x * 4, y * 4);
      top_p = std::max(top_p, p.at(x, y));
      top_f = std::max(top_f, f);
      diff += std::abs(p.at(x, y) - f);
    }
  EXPECT_GT(top_p, 40.f);
  EXPECT_NEAR(top_p, top_f, 0.35 * top_f);
  EXPECT_LT(diff / double(p.z.size()), 0.1 * top_f);
  // The far corners stay on the plain.
  EXPECT_NEAR(p.at(0, 0), 0.f, 0.5f);
  EXPECT_NEAR(p.at(p.w - 1, p.h - 1), 0.f, 0.5f);
}

TEST(StudioPreview, ADraggedStrokeReplacesItsOperation) {
  Studio s;
  auto c = s.client();
  post(c, "/api/operations", {{"op", kCrest}});
  const json st = test::body(c.Get("/api/state"));
  json moved = kCrest;
  moved["points"] = {{200, 120}, {1080, 80}};  // the crest dragged to the north edge
  const Layer p = preview(c, {{"op", moved}, {"index", 0}}, 33);
  // Where the crest was, the plain; where it went, the ridge.
  EXPECT_NEAR(p.at(160 / 40, 480 / 40), 0.f, 2.f);
  EXPECT_GT(p.at(640 / 40, 100 / 40), 40.f);
  EXPECT_EQ(test::body(c.Get("/api/state"))["operations"], st["operations"]);
  // Bad input: a message, and the session as it was.
  json bad = kCrest;
  bad["points"] = {{200, 480}};
  auto r = c.Post("/api/preview", json{{"op", bad}}.dump(), "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 400);
  EXPECT_NE(json::parse(r->body)["error"].get<std::string>().find("points"), std::string::npos) << r->body;
  r = c.Post("/api/preview", json{{"op", kCrest}, {"index", 5}}.dump(), "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 404);
  EXPECT_EQ(test::body(c.Get("/api/state"))["version"], st["version"]);
}

TEST(StudioPreview, AnAppendNamesTheWindowOfCellsItMoved) {
  Studio s("flat:385x289@10+300");
  auto c = s.client();
  post(c, "/api/operations", {{"op", kCrest}});
  const Layer before = layer(c.Get("/api/terrain.f32"));
  json peak = {{"op", "peak"}, {"center", {1000, 250}}, {"height", 60}, {"radius", 120}};
  const json st = post(c, "/api/operations", {{"op", peak}});
  ASSERT_EQ(st["last"]["mode"], "append");
  ASSERT_TRUE(st["last"]["window"].is_array() && st["last"]["window"].size() == 4) << st["last"].dump();
  const int x0 = st["last"]["window"][0], y0 = st["last"]["window"][1], w = st["last"]["window"][2], h = st["last"]["window"][3];
  EXPECT_LT(size_t(w) * h, size_t(385 * 289) / 2);  // local: not the whole map
  const Layer after = layer(c.Get("/api/terrain.f32"));
  size_t moved = 0;
  for (int y = 0; y < after.h; ++y)
    for (int x = 0; x < after.w; ++x) {
      if (after.at(x, y) == before.at(x, y)) continue;
      ++moved;
      ASSERT_TRUE(x >= x0 && x < x0 + w && y >= y0 && y < y0 + h) << "cell " << x << "," << y << " moved outside the window";
    }
  EXPECT_GT(moved, 50u);
  // The page patches its overview with ?step=k windows: the same samples as a whole fetch.
  const Layer patch = layer(c.Get("/api/terrain.f32?step=3&x0=9&y0=6&x1=100&y1=70"));
  EXPECT_EQ(patch.step, 3);
  for (int y = 0; y < patch.h; ++y)
    for (int x = 0; x < patch.w; ++x) ASSERT_EQ(patch.at(x, y), after.at(9 + 3 * x, 6 + 3 * y));
}

TEST(StudioPreview, AChangePostedDuringAPreviewStopsIt) {
  // A drag's first preview replays the layers before the dragged one on the coarse grid, an
  // erosion included: the change posted at the mouse release must not wait for that stale preview.
  Studio s;
  auto c = s.client();
  post(c, "/api/operations", {{"op", kCrest}});
  const auto t0 = std::chrono::steady_clock::now();
  post(c, "/api/operations", {{"op", {{"op", "erode"}, {"steps", 6000}, {"rain", 0.02}}}});
  const double erode_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const json far = {{"op", "crest"}, {"points", {{300, 150}, {900, 120}}}, {"height", 40}, {"radius", 100}};
  json moved = far;
  moved["points"][1] = {900, 200};
  post(c, "/api/operations", {{"op", far}});
  int status = 0;
  std::string answer;
  std::thread drag([&] {
    auto c2 = s.client();
    auto r = c2.Post("/api/preview?max=257", json{{"op", moved}, {"index", 2}}.dump(), "application/json");
    if (r) status = r->status, answer = r->body;
  });
  std::this_thread::sleep_for(std::chrono::duration<double>(0.4 * erode_s));  // the preview is replaying the erosion
  auto put = c.Put("/api/operations/2", json{{"op", moved}}.dump(), "application/json");
  drag.join();
  EXPECT_EQ(status, 409) << answer;
  EXPECT_NE(answer.find("superseded"), std::string::npos) << answer;
  ASSERT_TRUE(put);
  EXPECT_EQ(put->status, 200) << put->body;
  EXPECT_EQ(json::parse(put->body)["operations"][2], moved);
  // The next preview runs normally.
  EXPECT_GT(preview(c, {{"op", far}, {"index", 2}}, 257).z.size(), 0u);
}

}  // namespace
}  // namespace terracl
