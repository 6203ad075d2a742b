// SPDX-License-Identifier: Apache-2.0
// The studio as a local app only its own page drives (docs/studio.md, "Threat model"), against a
// real server on 127.0.0.1: hostile JSON, foreign Host / Origin, missing token, non-JSON bodies,
// files outside the workspace, slow clients, and long operations cancelled or stopped by the
// time budget with the session left as it was.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <future>
#include <terracl/io.hpp>
#include <thread>

#include "studio_client.hpp"

using namespace terracl;
using terracl::test::json;
namespace fs = std::filesystem;

namespace {

int status_of(const httplib::Result& r) { return r ? r->status : -1; }

// The body of an answer, which must be {"error": "..."} for every refusal.
std::string error_of(const httplib::Result& r) {
  if (!r) return "(no answer)";
  const json j = json::parse(r->body, nullptr, false);
  EXPECT_TRUE(j.is_object() && j.contains("error")) << r->status << " " << r->body.substr(0, 200);
  return j.is_object() && j.contains("error") ? j["error"].get<std::string>() : r->body;
}

json erode_op(int steps) { return {{"op", {{"op", "erode"}, {"steps", steps}}}}; }

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

TEST(StudioSecurity, DeeplyNestedJsonIsRefusedAndTheServerLives) {
  test::Studio s;
  auto c = s.client();
  const std::string deep = "{\"rain\":" + std::string(100000, '[') + std::string(100000, ']') + "}";
  auto r = c.Post("/api/erosion/start", deep, "application/json");
  EXPECT_EQ(status_of(r), 400);
  EXPECT_NE(error_of(r).find("deeper than 64"), std::string::npos) << error_of(r);
  const std::string op = "{\"op\":{\"op\":\"crest\",\"x\":" + std::string(150000, '[') + std::string(150000, ']') + "}}";
  r = c.Post("/api/operations", op, "application/json");
  EXPECT_EQ(status_of(r), 400);
  // A number that does not fit a double is the request's fault, not the server's.
  r = c.Post("/api/erosion/start", "{\"rain\": 1e999}", "application/json");
  EXPECT_EQ(status_of(r), 400);
  EXPECT_NE(error_of(r).find("out of range"), std::string::npos) << error_of(r);
  EXPECT_EQ(status_of(c.Get("/api/state")), 200);
}

TEST(StudioSecurity, ForeignHostOriginAndSitesAreRefused) {
  test::Studio s;
  auto c = s.client();
  const std::string script = json{{"operations", json::array()}}.dump();
  // DNS rebinding: a foreign name in Host, even on 127.0.0.1, reads nothing (not even the page,
  // which holds the token).
  for (const char* path : {"/", "/api/state", "/api/terrain.f32"}) {
    auto r = c.Get(path, {{"Host", "evil.example:" + std::to_string(s.port)}});
    EXPECT_EQ(status_of(r), 403) << path;
    EXPECT_NE(error_of(r).find("evil.example"), std::string::npos);
  }
  // Cross-site requests, including the "simple" text/plain POST a page can send without preflight.
  for (const auto& [header, value] : std::vector<std::pair<std::string, std::string>>{
           {"Origin", "http://evil.example"},
           {"Origin", "null"},
           {"Origin", "http://127.0.0.1:1"},
           {"Sec-Fetch-Site", "cross-site"},
           {"Sec-Fetch-Site", "same-site"}}) {
    for (const char* path : {"/api/script", "/api/save", "/api/export"}) {
      auto r = c.Post(path, {{header, value}}, script, "application/json");
      EXPECT_EQ(status_of(r), 403) << header << ": " << value << " " << path;
      error_of(r);
    }
  }
  auto r = c.Post("/api/script", script, "text/plain");
  EXPECT_EQ(status_of(r), 415);
  EXPECT_NE(error_of(r).find("application/json"), std::string::npos);
  r = c.Post("/api/operations", "op=crest", "application/x-www-form-urlencoded");
  EXPECT_EQ(status_of(r), 415);
  // The page's own origin is welcome.
  r = c.Post("/api/script", {{"Origin", "http://127.0.0.1:" + std::to_string(s.port)}, {"Sec-Fetch-Site", "same-origin"}},
             script, "application/json");
  EXPECT_EQ(status_of(r), 200) << (r ? r->body : "");
  r = c.Get("/api/state", {{"Host", "localhost:" + std::to_string(s.port)}});
  EXPECT_EQ(status_of(r), 200);
}

TEST(StudioSecurity, TheApiWantsThePagesToken) {
  test::Studio s;
  httplib::Client bare("127.0.0.1", s.port);  // no token
  auto r = bare.Get("/api/state");
  EXPECT_EQ(status_of(r), 403);
  EXPECT_NE(error_of(r).find("X-Terracl-Token"), std::string::npos);
  r = bare.Get("/api/state", {{"X-Terracl-Token", std::string(s.server->token().size(), '0')}});
  EXPECT_EQ(status_of(r), 403);
  // The page carries it, is never framed by another site and is not cached.
  r = bare.Get("/");
  ASSERT_EQ(status_of(r), 200);
  EXPECT_NE(r->body.find("<meta name=\"terracl-token\" content=\"" + s.server->token() + "\">"), std::string::npos);
  EXPECT_EQ(r->get_header_value("X-Frame-Options"), "DENY");
  EXPECT_EQ(r->get_header_value("Cache-Control"), "no-store");
  EXPECT_GE(s.server->token().size(), 32u);
  EXPECT_NE(s.server->token(), test::Studio().server->token());
}

TEST(StudioSecurity, OperationsReadOnlyFilesInsideTheWorkspace) {
  test::TempDir outside;
  Heightfield h(40, 30, 100.f);
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 40; ++x) h.at(x, y) = float(100 + x + 2 * y);
  write_heightfield(h, outside.path("secret.tif"));
  test::TempDir allowed;
  write_heightfield(h, allowed.path("shared.tif"));

  test::Studio s("flat:129x97@10", [&](StudioOptions& o) { o.allow_dirs = {allowed.path("")}; });
  auto c = s.client();
  auto paste = [](const std::string& source) {
    return json{{"op", {{"op", "copy_paste"}, {"source", source}, {"from", {0, 0, 20, 20}}, {"to", {500, 400}}}}};
  };
  auto add = [&](const json& b) { return c.Post("/api/operations", b.dump(), "application/json"); };

  auto r = add(paste(outside.path("secret.tif")));
  EXPECT_EQ(status_of(r), 400);
  EXPECT_NE(error_of(r).find("outside the workspace"), std::string::npos) << error_of(r);
  r = add(paste("../../" + fs::relative(outside.path("secret.tif"), "/").string()));
  EXPECT_EQ(status_of(r), 400);
  // A link inside the workspace that leads out is followed before the check.
  fs::create_symlink(outside.path("secret.tif"), s.dir.path("ws/link.tif"));
  r = add(paste("link.tif"));
  EXPECT_EQ(status_of(r), 400);
  EXPECT_NE(error_of(r).find("outside the workspace"), std::string::npos) << error_of(r);
  for (const char* key : {"exemplar", "dictionary"}) {
    r = add(json{{"op", {{"op", "amplify"}, {key, outside.path("secret.tif")}}}});
    EXPECT_EQ(status_of(r), 400) << key;
    EXPECT_NE(error_of(r).find("outside the workspace"), std::string::npos) << error_of(r);
  }
  r = add(json{{"op", {{"op", "fit"}, {"file", "/etc/passwd"}}}});
  EXPECT_EQ(status_of(r), 400);
  EXPECT_NE(error_of(r).find("outside the workspace"), std::string::npos) << error_of(r);
  EXPECT_EQ(json::parse(c.Get("/api/state")->body)["operations"].size(), 0u);

  // Inside the workspace, and in a folder given with --allow-dir, files are read.
  write_heightfield(h, s.dir.path("ws/mine.tif"));
  r = add(paste("mine.tif"));
  EXPECT_EQ(status_of(r), 200) << (r ? r->body : "");
  r = add(paste(allowed.path("shared.tif")));
  EXPECT_EQ(status_of(r), 200) << (r ? r->body : "");
  EXPECT_EQ(json::parse(c.Get("/api/state")->body)["operations"].size(), 2u);

  // The base raster the studio was started on is readable too (the page amplifies with its texture).
  test::Studio on_dem(outside.path("secret.tif"));
  auto c2 = on_dem.client();
  json on_base = paste(outside.path("secret.tif"));
  on_base["op"]["to"] = {20, 15};  // the 40 x 30 m base
  r = c2.Post("/api/operations", on_base.dump(), "application/json");
  EXPECT_EQ(status_of(r), 200) << (r ? r->body : "");
}

TEST(StudioSecurity, SlowClientsDoNotBlockOthers) {
  test::Studio s("flat:65x65@10", [](StudioOptions& o) { o.request_timeout_s = 2; });
  const int port = s.port;
  // More dribbling connections than the server has workers (32): a header byte each second.
  constexpr int kSlow = 40;
  std::vector<int> socks;
  for (int i = 0; i < kSlow; ++i) {
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(uint16_t(port));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ASSERT_EQ(::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
    timeval tv{0, 100000};
    setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    socks.push_back(fd);
  }
  std::atomic<bool> quit{false};
  std::atomic<int> closed{0};
  std::thread dribble([&] {
    const std::string text = "GET /api/state HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Slow: ";
    std::vector<bool> done(socks.size(), false);
    for (size_t k = 0; !quit && k < 60; ++k) {
      for (size_t i = 0; i < socks.size(); ++i) {
        if (done[i]) continue;
        char b;
        if (::recv(socks[i], &b, 1, MSG_DONTWAIT) == 0 ||
            ::send(socks[i], &text[k % text.size()], 1, MSG_NOSIGNAL) < 0) {
          done[i] = true;
          ++closed;
        }
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(250));
    }
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const auto t0 = std::chrono::steady_clock::now();
  auto c = s.client();
  EXPECT_EQ(status_of(c.Get("/api/state")), 200);
  EXPECT_LT(seconds_since(t0), 4.0) << "a normal request waited behind slow clients";
  // The slow ones are closed after the 2 s request timeout.
  while (closed < kSlow && seconds_since(t0) < 10) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_EQ(closed.load(), kSlow);
  quit = true;
  dribble.join();
  for (int fd : socks) ::close(fd);
}

TEST(StudioSecurity, ALongOperationIsCancelledAndTheSessionStaysAsItWas) {
  test::Studio s("flat:129x97@10");
  auto c = s.client();
  test::post(c, "/api/operations", {{"op", {{"op", "peak"}, {"center", {600, 500}}}}});
  const std::vector<float> before = test::f32(c, "/api/terrain.f32");
  const auto t0 = std::chrono::steady_clock::now();
  auto pending = std::async(std::launch::async, [&] {
    auto c2 = s.client();
    return c2.Post("/api/operations", erode_op(100000).dump(), "application/json");
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  auto cancel = c.Post("/api/cancel", "", "application/json");
  ASSERT_EQ(status_of(cancel), 200);
  EXPECT_EQ(json::parse(cancel->body)["cancelling"], true);
  const auto r = pending.get();
  EXPECT_EQ(status_of(r), 409);
  EXPECT_NE(error_of(r).find("cancelled"), std::string::npos) << error_of(r);
  EXPECT_LT(seconds_since(t0), 10.0);
  const json st = json::parse(c.Get("/api/state")->body);
  EXPECT_EQ(st["operations"].size(), 1u);
  EXPECT_EQ(test::f32(c, "/api/terrain.f32"), before);
  // Nothing running: a cancel changes nothing.
  EXPECT_EQ(json::parse(c.Post("/api/cancel", "", "application/json")->body)["cancelling"], false);
}

TEST(StudioSecurity, TheTimeBudgetStopsALongOperation) {
  test::Studio s("flat:129x97@10", [](StudioOptions& o) { o.time_limit_s = 1; });
  auto c = s.client();
  const auto t0 = std::chrono::steady_clock::now();
  auto r = c.Post("/api/operations", erode_op(100000).dump(), "application/json");
  EXPECT_EQ(status_of(r), 503);
  EXPECT_NE(error_of(r).find("time budget of 1 s"), std::string::npos) << error_of(r);
  EXPECT_LT(seconds_since(t0), 8.0);
  EXPECT_EQ(json::parse(c.Get("/api/state")->body)["operations"].size(), 0u);
  // A short one still fits.
  r = c.Post("/api/operations", erode_op(5).dump(), "application/json");
  EXPECT_EQ(status_of(r), 200) << (r ? r->body : "");
}

TEST(StudioSecurity, RefusalsAreJsonAndLinksAreNotWrittenThrough) {
  test::Studio s;
  auto c = s.client();
  auto r = c.Post("/api/undo");  // no body, no Content-Type
  EXPECT_EQ(status_of(r), 409);
  EXPECT_EQ(error_of(r), "nothing to undo");
  r = c.Get("/api/nothing-here");
  EXPECT_EQ(status_of(r), 404);
  error_of(r);
  // A binary file in the workspace is not a script: 400 with a readable body.
  {
    std::ofstream f(s.dir.path("ws/binary.json"), std::ios::binary);
    for (int i = 0; i < 256; ++i) f.put(char(255 - i));
  }
  r = c.Post("/api/load", json{{"path", "binary.json"}}.dump(), "application/json");
  EXPECT_EQ(status_of(r), 400);
  error_of(r);
  // A dangling link is refused, not replaced by the saved file.
  fs::create_symlink(s.dir.path("gone.json"), s.dir.path("ws/dangling.json"));
  r = c.Post("/api/save", json{{"path", "dangling.json"}}.dump(), "application/json");
  EXPECT_EQ(status_of(r), 403);
  error_of(r);
  EXPECT_TRUE(fs::is_symlink(s.dir.path("ws/dangling.json")));
  EXPECT_FALSE(fs::exists(s.dir.path("gone.json")));
}
