// SPDX-License-Identifier: Apache-2.0
// Snapshots (docs/studio.md, "Snapshots"): EditSession::snapshot() continues bit for bit, edit
// scripts note each operation's support causally, and the studio replays a change after an
// expensive layer from the snapshot taken after it, with the terrain `terracl edit` computes.
#include <httplib.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <terracl/edit.hpp>
#include <terracl/io.hpp>

#include "studio_client.hpp"
#include "test_helpers.hpp"

namespace terracl {
namespace {

using json = nlohmann::json;
using test::body;
using test::post;

// A real (not flat) base: solves are local, so each operation's support matters.
Heightfield hills(int n) {
  Heightfield h(n, n);
  h.georef.cell_x = h.georef.cell_y = 10;
  h.georef.geotransform = {0, 10, 0, 0, 0, -10};
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) h.at(x, y) = float(200 + 40 * std::sin(x * 0.09) * std::cos(y * 0.07) + 0.3 * x);
  return h;
}

const json kCrestA = {{"op", "crest"}, {"points", {{150, 200}, {600, 260}}}, {"elevation", 300}, {"radius", 80}};
const json kNoise = {{"op", "noise"}, {"amplitude", 6}, {"wavelength", 150}};
const json kErode = {{"op", "erode"}, {"steps", 20}, {"rain", 0.02}};
// Far from crest A, and a radius wider than the map (a reach that would widen every local solve).
const json kCrestB = {{"op", "crest"}, {"points", {{1000, 1050}, {1200, 1150}}}, {"elevation", 260}, {"radius", 3000}};
const json kCrestC = {{"op", "crest"}, {"points", {{900, 500}, {1100, 700}}}, {"elevation", 280}, {"radius", 60}};
const json kHole = {{"op", "regularize"}, {"enabled", false}};  // an already applied operation

json script(const json& ops) { return {{"units", "m"}, {"seed", 1}, {"operations", ops}}; }

// What `terracl edit --script` computes: one EditSession from the base, the whole script.
std::vector<float> full_replay(const Heightfield& base, const json& ops) {
  EditSession e(test::device(), base);
  e.apply(script(ops));
  return e.height().z;
}

TEST(StudioSnapshots, EditSessionSnapshotContinuesBitForBit) {
  const Heightfield base = hills(129);
  EditSession a(test::device(), base);
  a.apply(script({kCrestA, kNoise, kErode}));
  auto b = a.snapshot();
  {
    // Work on another copy must not leak into the original or the first copy (no shared buffers).
    auto c = a.snapshot();
    c->apply(script({kHole, kHole, kHole, kCrestC, kNoise}));
    c->height();
  }
  const json tail = script({kHole, kHole, kHole, kCrestB, kNoise});
  b->apply(tail);
  a.apply(tail);
  const std::vector<float> ha = a.height().z, hb = b->height().z;
  EXPECT_EQ(ha, hb) << "a snapshot and its original diverged on the same operations";
  EXPECT_EQ(ha, full_replay(base, {kCrestA, kNoise, kErode, kCrestB, kNoise}))
      << "applying a script in two parts differs from applying it whole";
  EXPECT_EQ(a.log().size(), b->log().size());
  EXPECT_EQ(a.hard_cells(), b->hard_cells());
}

// An operation that reconstructs mid-script (erode) solves with the supports of the operations
// before it only: what follows it cannot change its result.
TEST(StudioSnapshots, SupportsAreNotedCausally) {
  const Heightfield base = hills(129);
  EditSession whole(test::device(), base);
  whole.apply(script({kCrestA, kErode, kCrestB}));
  EditSession parts(test::device(), base);
  parts.apply(script({kCrestA, kErode}));
  parts.apply(script({kHole, kHole, kCrestB}));
  EXPECT_EQ(whole.height().z, parts.height().z);
}

struct HillsStudio {
  test::TempDir dir;
  Heightfield base;
  std::unique_ptr<test::Studio> studio;
  HillsStudio() {
    write_heightfield(hills(129), dir.path("hills.tif"));
    base = read_heightfield(dir.path("hills.tif"));  // exactly what the studio reads
    studio = std::make_unique<test::Studio>(dir.path("hills.tif"));
  }
};

json put(httplib::Client& c, size_t i, const json& op) {
  auto r = c.Put(("/api/operations/" + std::to_string(i)).c_str(), json{{"op", op}}.dump(), "application/json");
  EXPECT_TRUE(r && r->status == 200) << (r ? r->body : "no answer");
  return r ? json::parse(r->body) : json();
}

TEST(StudioSnapshots, ChangingALayerAfterAnErosionReplaysFromItsSnapshot) {
  HillsStudio s;
  auto c = s.studio->client();
  post(c, "/api/operations", {{"op", kCrestA}});
  // An appended erosion replays (from the base here) so that a snapshot is kept after it.
  json st = post(c, "/api/operations", {{"op", kErode}});
  EXPECT_EQ(st["last"]["mode"], "replay");
  EXPECT_EQ(st["last"]["from"], 0);
  EXPECT_EQ(st["last"]["snapshots"], 1);
  EXPECT_EQ(test::f32(c, "/api/terrain.f32"), full_replay(s.base, {kCrestA, kErode}));
  post(c, "/api/operations", {{"op", kCrestC}});  // a stroke: the warm append

  // (b) The last crest changes: the replay starts after the erosion, and gives the bits of a
  // full replay (with a crest whose reach covers the map: noted after the erosion ran).
  st = put(c, 2, kCrestB);
  EXPECT_EQ(st["last"]["mode"], "replay");
  EXPECT_EQ(st["last"]["from"], 2);
  EXPECT_EQ(test::f32(c, "/api/terrain.f32"), full_replay(s.base, {kCrestA, kErode, kCrestB}));
  // Undo goes through the same path.
  st = post(c, "/api/undo", json::object());
  EXPECT_EQ(st["last"]["from"], 2);
  EXPECT_EQ(test::f32(c, "/api/terrain.f32"), full_replay(s.base, {kCrestA, kErode, kCrestC}));

  // (c) A change before the erosion: no snapshot holds, the replay starts from the base.
  json moved = kCrestA;
  moved["elevation"] = 320;
  st = put(c, 0, moved);
  EXPECT_EQ(st["last"]["mode"], "replay");
  EXPECT_EQ(st["last"]["from"], 0);
  EXPECT_EQ(test::f32(c, "/api/terrain.f32"), full_replay(s.base, {moved, kErode, kCrestC}));
  // ... and that replay kept a snapshot after its erosion for the next change.
  st = put(c, 2, kCrestB);
  EXPECT_EQ(st["last"]["from"], 2);
  EXPECT_EQ(test::f32(c, "/api/terrain.f32"), full_replay(s.base, {moved, kErode, kCrestB}));
  // Deleting the layer after the erosion: the snapshot alone (nothing left to run).
  auto del = c.Delete("/api/operations/2");
  ASSERT_TRUE(del && del->status == 200);
  EXPECT_EQ(json::parse(del->body)["last"]["from"], 2);
  EXPECT_EQ(test::f32(c, "/api/terrain.f32"), full_replay(s.base, {moved, kErode}));
}

// (d) A script replayed whole keeps at the erosion what the erosion alone gives: loading
// [crest, erode, far crest] replays from the base; changing the far crest then starts from the
// snapshot taken during that replay, and equals replaying [crest, erode] and adding the crest.
TEST(StudioSnapshots, TheStateAtTheErosionDoesNotDependOnLaterLayers) {
  HillsStudio s;
  auto c = s.studio->client();
  json st = post(c, "/api/script", {{"operations", {kCrestA, kErode, kCrestB}}});
  EXPECT_EQ(st["last"]["from"], 0);
  const std::vector<float> loaded = test::f32(c, "/api/terrain.f32");
  EditSession parts(test::device(), s.base);
  parts.apply(script({kCrestA, kErode}));
  auto snap = parts.snapshot();
  snap->apply(script({kHole, kHole, kCrestB}));
  EXPECT_EQ(loaded, snap->height().z);
  // ... and what `terracl edit` gives for the whole script in one go.
  EXPECT_EQ(loaded, full_replay(s.base, {kCrestA, kErode, kCrestB}));
  st = put(c, 2, kCrestC);
  EXPECT_EQ(st["last"]["from"], 2);
  EXPECT_EQ(test::f32(c, "/api/terrain.f32"), full_replay(s.base, {kCrestA, kErode, kCrestC}));
}

}  // namespace
}  // namespace terracl
