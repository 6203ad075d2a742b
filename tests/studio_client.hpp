// SPDX-License-Identifier: Apache-2.0
#pragma once
// A real studio server on a free port of 127.0.0.1 and the client calls its API tests make.
#include <httplib.h>

#include <cstring>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <terracl/studio.hpp>

#include "test_helpers.hpp"

namespace terracl::test {

using json = nlohmann::json;

struct Studio {
  test::TempDir dir;
  std::unique_ptr<StudioServer> server;
  int port = 0;
  /// `tweak` changes the options before the server starts (time limits, allowed folders).
  explicit Studio(const std::string& base = "flat:129x97@10", const std::function<void(StudioOptions&)>& tweak = {}) {
    StudioOptions o;
    o.base = base;
    o.port = 0;
    o.workspace = dir.path("ws");
    if (tweak) tweak(o);
    server = std::make_unique<StudioServer>(test::device(), o);
    port = server->start();
  }
  httplib::Client client() const {
    httplib::Client c("127.0.0.1", port);
    c.set_read_timeout(120, 0);
    c.set_default_headers({{"X-Terracl-Token", server->token()}});
    return c;
  }
};

inline json body(const httplib::Result& r) {
  EXPECT_TRUE(r) << "no answer";
  if (!r) return json();
  return json::parse(r->body);
}

inline json post(httplib::Client& c, const std::string& path, const json& b, int expect = 200) {
  auto r = c.Post(path.c_str(), b.dump(), "application/json");
  EXPECT_TRUE(r);
  if (!r) return json();
  EXPECT_EQ(r->status, expect) << path << " " << r->body;
  return json::parse(r->body);
}

/// A float32 layer of the API (terrain.f32, water.f32).
inline std::vector<float> f32(httplib::Client& c, const std::string& path) {
  auto r = c.Get(path.c_str());
  EXPECT_TRUE(r && r->status == 200) << path;
  if (!r) return {};
  std::vector<float> v(r->body.size() / sizeof(float));
  std::memcpy(v.data(), r->body.data(), r->body.size());
  return v;
}

}  // namespace terracl::test
