// SPDX-License-Identifier: Apache-2.0
// terracl studio's HTTP server (cpp-httplib): the embedded page, three.js from libjs-three, and
// the JSON API of docs/studio.md over one shared Session, serialised by one mutex (the OpenCL
// queue and the session are not thread-safe). Requests pass the guard first (studio/guard.hpp);
// each holds the session at most the time budget, and POST /api/cancel stops the one running.
#include <fmt/format.h>
#include <httplib.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>
#include <terracl/error.hpp>
#include <terracl/interrupt.hpp>
#include <terracl/json_limits.hpp>
#include <terracl/io.hpp>
#include <terracl/render.hpp>
#include <terracl/studio.hpp>
#include <thread>

#include "studio/guard.hpp"
#include "studio/session.hpp"

namespace terracl::detail {
const std::map<std::string, std::string>& embedded_web();
}

namespace fs = std::filesystem;

namespace terracl {

using studio::json;
using studio::RequestError;

namespace {

// httplib compresses a response the browser accepts brotli for when its type is exactly
// "application/json" or "application/javascript", or any text/ type, at brotli's top quality: 4.5 ms
// for a 1 KB state (it grows with the script) and 2.1 s for three.module.js. On a loopback server
// bytes cost nothing, so the API and the scripts use types httplib leaves alone (the same types
// with their charset); the page and its style sheet (7 KB, once) stay text/.
const char* const kJson = "application/json; charset=utf-8";
const char* const kJavascript = "application/javascript; charset=utf-8";

std::string mime_of(const std::string& name) {
  const std::string ext = fs::path(name).extension().string();
  if (ext == ".html") return "text/html; charset=utf-8";
  if (ext == ".js") return kJavascript;
  if (ext == ".css") return "text/css; charset=utf-8";
  if (ext == ".png") return "image/png";
  return "application/octet-stream";
}

// The CLI's limits on JSON (depth, size, numbers that fit a double) apply to requests too.
json parse_body(const httplib::Request& req) {
  if (req.body.empty()) return json::object();
  try {
    return parse_json_limited(req.body, "studio", "request body");
  } catch (const Error& e) {
    throw RequestError(400, e.what());
  }
}

/// {"error": message} (bytes that are not UTF-8, e.g. echoed from a binary file, are replaced).
void send_error(httplib::Response& res, int status, const std::string& message) {
  res.status = status;
  res.set_content(json{{"error", message}}.dump(-1, ' ', false, json::error_handler_t::replace), kJson);
}

size_t parse_index(const std::string& s, const char* what) {
  if (s.empty() || s.size() > 9) throw RequestError(404, fmt::format("{}: no operation '{}'", what, s));
  return size_t(std::stoul(s));
}

size_t index_field(const json& b, const char* key) {
  if (!b.contains(key) || !b[key].is_number_unsigned())
    throw RequestError(400, fmt::format("/{}: expected a non-negative integer", key));
  return b[key].get<size_t>();
}

/// A window of cells [x0, x1) x [y0, y1) (the whole grid by default), every `step`-th cell so that
/// a side has at most `max_side` cells.
struct Window {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
};

std::string f32_body(const Heightfield& h, int max_side, httplib::Response& res, Window win = {}, int step = 0) {
  if (win.x1 <= win.x0 || win.y1 <= win.y0) win = {0, 0, h.width, h.height};
  const int side = std::max(win.x1 - win.x0, win.y1 - win.y0);
  if (step <= 0) step = studio::sample_step(side, max_side);
  const int w = (win.x1 - win.x0 - 1) / step + 1, hh = (win.y1 - win.y0 - 1) / step + 1;
  std::string out(size_t(w) * hh * sizeof(float), '\0');
  float* o = reinterpret_cast<float*>(out.data());
  for (int y = 0; y < hh; ++y)
    for (int x = 0; x < w; ++x) *o++ = h.at(win.x0 + x * step, win.y0 + y * step);
  res.set_header("X-Width", std::to_string(w));
  res.set_header("X-Height", std::to_string(hh));
  res.set_header("X-Cell-X", fmt::format("{}", h.georef.cell_x * step));
  res.set_header("X-Cell-Y", fmt::format("{}", h.georef.cell_y * step));
  res.set_header("X-Step", std::to_string(step));
  res.set_header("X-X0", std::to_string(win.x0));
  res.set_header("X-Y0", std::to_string(win.y0));
  return out;
}

int int_param(const httplib::Request& req, const char* key, int def, int lo, int hi) {
  if (!req.has_param(key)) return def;
  const std::string v = req.get_param_value(key);
  char* end = nullptr;
  const long n = std::strtol(v.c_str(), &end, 10);
  if (v.empty() || *end || n < lo || n > hi)
    throw RequestError(400, fmt::format("?{}: expected an integer in [{}, {}], got '{}'", key, lo, hi, v));
  return int(n);
}

/// ?x0=&y0=&x1=&y1= (cells, x1/y1 exclusive), clamped to the grid; absent: the whole grid.
Window window_param(const httplib::Request& req, const Heightfield& h) {
  if (!req.has_param("x0") && !req.has_param("y0") && !req.has_param("x1") && !req.has_param("y1")) return {};
  Window w;
  w.x0 = int_param(req, "x0", 0, -(1 << 20), 1 << 20);
  w.y0 = int_param(req, "y0", 0, -(1 << 20), 1 << 20);
  w.x1 = int_param(req, "x1", h.width, -(1 << 20), 1 << 20);
  w.y1 = int_param(req, "y1", h.height, -(1 << 20), 1 << 20);
  w.x0 = std::clamp(w.x0, 0, h.width - 1), w.y0 = std::clamp(w.y0, 0, h.height - 1);
  w.x1 = std::clamp(w.x1, w.x0 + 1, h.width), w.y1 = std::clamp(w.y1, w.y0 + 1, h.height);
  return w;
}

std::string read_file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// A temp file name for in-memory answers written by the io code (which writes files).
std::string temp_name(const std::string& ext) {
  static std::atomic<int> n{0};
  return (fs::temp_directory_path() / fmt::format("terracl-studio-{}-{}{}", ::getpid(), n++, ext)).string();
}

}  // namespace

struct StudioServer::Impl {
  Device& device;
  StudioOptions opts;
  std::unique_ptr<studio::Session> session;
  std::mutex mutex;
  studio::GuardedServer server;
  studio::RequestGuard guard;
  std::thread thread;
  int port = 0;
  // The stop condition of the request holding the session (terracl/interrupt.hpp).
  std::atomic<bool> cancel{false};
  std::atomic<long long> deadline_ns{0};  ///< steady clock; 0 = no request running
  // A preview holds the session; a change to the script posted meanwhile makes it stale, so the
  // change stops it (a drag's first preview can replay slow layers on the coarse grid, seconds
  // that the mouse release would otherwise wait for).
  std::atomic<bool> previewing{false}, superseded{false};
  void supersede_preview() {
    if (!previewing) return;
    superseded = true;
    cancel = true;
  }
  int stop_check_id = -1;

  Impl(Device& d, StudioOptions o)
      : device(d),
        opts(std::move(o)),
        server(opts.request_timeout_s, 32),
        guard(opts.bind, opts.allow_hosts, opts.token.empty() ? studio::random_token() : opts.token) {}

  static long long now_ns() {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
        .count();
  }
  bool should_stop() const {
    const long long d = deadline_ns.load();
    return d != 0 && (cancel.load() || now_ns() > d);
  }

  void routes();
  /// Runs `f` under the session lock and within the time budget, and answers its JSON (or the
  /// error with its status).
  template <typename F>
  void api(const httplib::Request& req, httplib::Response& res, F&& f) {
    server.busy(req, true);
    try {
      std::lock_guard<std::mutex> lock(mutex);
      cancel = false;
      superseded = false;
      deadline_ns = now_ns() + static_cast<long long>(opts.time_limit_s * 1e9);
      struct Done {
        std::atomic<long long>& d;
        ~Done() { d = 0; }
      } done{deadline_ns};
      json out;
      try {
        out = f();
      } catch (const Cancelled& e) {
        // Why it stopped is read while the session is still held: the request waiting for the
        // session (the change that superseded a preview) resets the flags once it has it.
        if (superseded) throw RequestError(409, fmt::format("preview superseded by a change to the script: {}", e.what()));
        if (cancel) throw RequestError(409, fmt::format("cancelled (POST /api/cancel); the session is as it was: {}", e.what()));
        throw RequestError(503, fmt::format("stopped after the studio's time budget of {} s (--time-limit); the session "
                                            "is as it was: {}", opts.time_limit_s, e.what()));
      }
      if (!out.is_null()) res.set_content(out.dump(-1, ' ', false, json::error_handler_t::replace), kJson);
    } catch (const RequestError& e) {
      send_error(res, e.status, e.what());
    } catch (const Error& e) {  // validation (JSON paths) and library errors
      send_error(res, 400, e.what());
    } catch (const std::exception& e) {
      send_error(res, 500, e.what());
    } catch (...) {
      send_error(res, 500, "internal error");
    }
    server.busy(req, false);
  }
};

void StudioServer::Impl::routes() {
  server.set_payload_max_length(16u << 20);
  // httplib sends a response's headers and body in separate writes; with Nagle's algorithm the
  // body of a small answer (a stroke's window of terrain) then waits for the browser's delayed
  // ACK, 40 ms on Linux, more than the solve.
  server.set_tcp_nodelay(true);
  server.set_read_timeout(5, 0);
  server.set_write_timeout(30, 0);
  auto& s = server;
  s.set_pre_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
    if (auto refused = guard.check(req)) {
      send_error(res, refused->status, refused->message);
      return httplib::Server::HandlerResponse::Handled;
    }
    return httplib::Server::HandlerResponse::Unhandled;
  });
  // Answers httplib gives itself (unknown route, a POST without Content-Length) get a JSON body too.
  s.set_error_handler([](const httplib::Request& req, httplib::Response& res) {
    if (!res.body.empty()) return;
    send_error(res, res.status, res.status == 404 ? fmt::format("no such resource: {} {}", req.method, req.path)
                                                  : fmt::format("bad request (HTTP {})", res.status));
  });
  // Only the page itself, never inside another site's frame; the token it carries is not cached.
  s.set_default_headers({{"X-Content-Type-Options", "nosniff"},
                         {"X-Frame-Options", "DENY"},
                         {"Content-Security-Policy", "frame-ancestors 'none'"},
                         {"Referrer-Policy", "no-referrer"}});
  s.Get("/", [this](const httplib::Request&, httplib::Response& res) {
    std::string page = detail::embedded_web().at("index.html");
    const std::string slot = "{{TERRACL_TOKEN}}";
    const size_t at = page.find(slot);
    if (at != std::string::npos) page.replace(at, slot.size(), guard.token());
    res.set_header("Cache-Control", "no-store");
    res.set_content(page, mime_of("index.html"));
  });
  s.Get(R"(/web/([A-Za-z0-9_.-]+))", [](const httplib::Request& req, httplib::Response& res) {
    const auto& web = detail::embedded_web();
    auto it = web.find(req.matches[1].str());
    if (it == web.end()) {
      res.status = 404;
      return;
    }
    res.set_content(it->second, mime_of(it->first));
  });
  s.Get("/favicon.ico", [](const httplib::Request&, httplib::Response& res) { res.status = 204; });
  // three.js from libjs-three; the pattern admits no "..".
  s.Get(R"(/three/((?:[A-Za-z0-9_-]+/)*[A-Za-z0-9_-]+(?:\.[A-Za-z0-9_-]+)*\.js))",
        [this](const httplib::Request& req, httplib::Response& res) {
          const fs::path p = fs::path(opts.three_dir) / req.matches[1].str();
          if (!path_exists(p.string(), true)) {
            res.status = 404;
            res.set_content(fmt::format("{} not found (install libjs-three)", p.string()), "text/plain");
            return;
          }
          res.set_content(read_file_bytes(p.string()), kJavascript);
        });

  s.Get("/api/state",
        [this](const httplib::Request& req, httplib::Response& res) { api(req, res, [&] { return session->state(); }); });
  s.Get("/api/script",
        [this](const httplib::Request& req, httplib::Response& res) { api(req, res, [&] { return session->script(); }); });
  s.Get("/api/catalog", [this](const httplib::Request& req, httplib::Response& res) {
    api(req, res, [&] {
      json c = json::array();
      for (const auto& [name, summary] : edit_operations()) c.push_back({{"op", name}, {"summary", summary}});
      return c;
    });
  });
  s.Post("/api/operations", [this](const httplib::Request& req, httplib::Response& res) {
    supersede_preview();
    api(req, res, [&] {
      const json b = parse_body(req);
      if (!b.is_object() || !b.contains("op")) throw RequestError(400, "/op: missing: the operation object");
      std::optional<size_t> at;
      if (b.contains("index")) at = index_field(b, "index");
      session->add(b["op"], at);
      return session->state();
    });
  });
  s.Put(R"(/api/operations/(\d+))", [this](const httplib::Request& req, httplib::Response& res) {
    supersede_preview();
    api(req, res, [&] {
      const json b = parse_body(req);
      if (!b.is_object() || !b.contains("op")) throw RequestError(400, "/op: missing: the operation object");
      session->update(parse_index(req.matches[1], "index"), b["op"]);
      return session->state();
    });
  });
  s.Delete(R"(/api/operations/(\d+))", [this](const httplib::Request& req, httplib::Response& res) {
    supersede_preview();
    api(req, res, [&] {
      session->remove(parse_index(req.matches[1], "index"));
      return session->state();
    });
  });
  s.Post(R"(/api/operations/(\d+)/move)", [this](const httplib::Request& req, httplib::Response& res) {
    api(req, res, [&] {
      const json b = parse_body(req);
      session->move(parse_index(req.matches[1], "index"), index_field(b, "to"));
      return session->state();
    });
  });
  s.Post(R"(/api/operations/(\d+)/visible)", [this](const httplib::Request& req, httplib::Response& res) {
    api(req, res, [&] {
      const json b = parse_body(req);
      if (!b.contains("visible") || !b["visible"].is_boolean())
        throw RequestError(400, "/visible: expected true or false");
      session->set_visible(parse_index(req.matches[1], "index"), b["visible"].get<bool>());
      return session->state();
    });
  });
  s.Post("/api/undo", [this](const httplib::Request& req, httplib::Response& res) {
    api(req, res, [&] {
      session->undo();
      return session->state();
    });
  });
  s.Post("/api/redo", [this](const httplib::Request& req, httplib::Response& res) {
    api(req, res, [&] {
      session->redo();
      return session->state();
    });
  });
  s.Post("/api/script", [this](const httplib::Request& req, httplib::Response& res) {
    api(req, res, [&] {
      session->load_script(parse_body(req));
      return session->state();
    });
  });
  auto path_of = [](const json& b) {
    if (!b.is_object() || !b.contains("path") || !b["path"].is_string())
      throw RequestError(400, "/path: expected a file name (string) inside the workspace");
    return b["path"].get<std::string>();
  };
  s.Post("/api/save", [this, path_of](const httplib::Request& req, httplib::Response& res) {
    api(req, res, [&] {
      session->save(path_of(parse_body(req)));
      return session->state();
    });
  });
  s.Post("/api/load", [this, path_of](const httplib::Request& req, httplib::Response& res) {
    api(req, res, [&] {
      session->load(path_of(parse_body(req)));
      return session->state();
    });
  });
  s.Post("/api/export", [this, path_of](const httplib::Request& req, httplib::Response& res) {
    api(req, res, [&] {
      const json b = parse_body(req);
      if (b.is_object() && b.contains("name")) return session->export_set(b);  // the Export dialog
      const std::string p = session->export_to(path_of(b));
      return json{{"written", p}};
    });
  });
  s.Get("/api/terrain.f32", [this](const httplib::Request& req, httplib::Response& res) {
    api(req, res, [&] {
      const int max_side = int_param(req, "max", 1 << 16, 2, 1 << 16);
      const Heightfield& h = session->terrain();
      // ?step=k: every k-th cell of the window (the page patches its overview with a window)
      const int step = int_param(req, "step", 0, 1, 1 << 16);
      res.set_content(f32_body(h, max_side, res, window_param(req, h), step), "application/octet-stream");
      res.set_header("X-Version", std::to_string(session->version()));
      return json();
    });
  });
  // The lakes' water depth on the live terrain, sampled as terrain.f32 (zeros without a lake).
  s.Get("/api/water.f32", [this](const httplib::Request& req, httplib::Response& res) {
    api(req, res, [&] {
      const int max_side = int_param(req, "max", 1 << 16, 2, 1 << 16);
      std::optional<Heightfield> w = session->water();
      if (!w) w = Heightfield(session->terrain().width, session->terrain().height, 0.f);
      res.set_content(f32_body(*w, max_side, res, window_param(req, *w)), "application/octet-stream");
      res.set_header("X-Version", std::to_string(session->version()));
      return json();
    });
  });
  // Feedback while drawing: the terrain with a stroke not yet recorded, on a coarse grid.
  s.Post("/api/preview", [this](const httplib::Request& req, httplib::Response& res) {
    api(req, res, [&] {
      const json b = parse_body(req);
      if (!b.is_object() || !b.contains("op")) throw RequestError(400, "/op: missing: the operation object");
      std::optional<size_t> replace;
      if (b.contains("index")) replace = index_field(b, "index");
      const int max_side = int_param(req, "max", 257, 2, 1025);
      struct Previewing {
        std::atomic<bool>& on;
        ~Previewing() { on = false; }
      } previewing_now{previewing};
      previewing = true;
      const Heightfield h = session->preview(b["op"], replace, max_side);
      res.set_content(f32_body(h, 1 << 16, res), "application/octet-stream");
      // The coarse grid's cell is the sampling step of the full grid.
      res.headers.erase("X-Step");
      res.set_header("X-Step", std::to_string(studio::preview_step(session->base(), max_side)));
      res.set_header("X-Preview-Ms", fmt::format("{:.1f}", session->preview_ms()));
      res.set_header("X-Version", std::to_string(session->version()));
      return json();
    });
  });
  s.Get("/api/terrain.tif", [this](const httplib::Request& req, httplib::Response& res) {
    api(req, res, [&] {
      Heightfield h = session->canonical();
      h.georef = session->base().georef;
      const std::string tmp = temp_name(".tif");
      write_heightfield(h, tmp);
      res.set_content(read_file_bytes(tmp), "image/tiff");
      fs::remove(tmp);
      return json();
    });
  });
  s.Get("/api/preview.png", [this](const httplib::Request& req, httplib::Response& res) {
    api(req, res, [&] {
      render::Options ro;
      ro.mode = render::Mode::ShadedRelief;
      const std::string tmp = temp_name(".png");
      render::write_image(render::render(session->terrain(), ro, device), tmp);
      res.set_content(read_file_bytes(tmp), "image/png");
      fs::remove(tmp);
      return json();
    });
  });
  // Stops the request holding the session (an operation, a replay, an export), without waiting for
  // the session: that request then answers 409 and the session stays as it was.
  s.Post("/api/cancel", [this](const httplib::Request&, httplib::Response& res) {
    const bool running = deadline_ns.load() != 0;
    if (running) cancel = true;
    res.set_content(json{{"cancelling", running}}.dump(), kJson);
  });
  s.Post("/api/erosion/start", [this](const httplib::Request& req, httplib::Response& res) {
    api(req, res, [&] {
      session->erosion_start(parse_body(req));
      return session->state();
    });
  });
  s.Post("/api/erosion/step", [this](const httplib::Request& req, httplib::Response& res) {
    api(req, res, [&] {
      const int steps = int_param(req, "steps", 1, 1, 1000);
      const int max_side = int_param(req, "max", 1 << 16, 2, 1 << 16);
      const Heightfield bed = session->erosion_step(steps);
      res.set_content(f32_body(bed, max_side, res), "application/octet-stream");
      return json();
    });
  });
  s.Post("/api/erosion/commit", [this](const httplib::Request& req, httplib::Response& res) {
    api(req, res, [&] {
      session->erosion_commit();
      return session->state();
    });
  });
  s.Post("/api/erosion/cancel", [this](const httplib::Request& req, httplib::Response& res) {
    api(req, res, [&] {
      session->erosion_cancel();
      return session->state();
    });
  });
}

StudioServer::StudioServer(Device& d, StudioOptions o) : m(std::make_unique<Impl>(d, std::move(o))) {
  if (!(m->opts.time_limit_s > 0) || !(m->opts.request_timeout_s > 0))
    throw UsageError("studio", "--time-limit and the request timeout must be positive numbers of seconds");
  m->session = std::make_unique<studio::Session>(d, m->opts.base, m->opts.workspace, m->opts.allow_dirs,
                                                  m->opts.compile_ahead);
  if (!m->opts.script.empty()) {
    try {
      m->session->load_script(read_edit_script(m->opts.script));
    } catch (const RequestError& e) {
      throw Error("studio", fmt::format("{}: {}", m->opts.script, e.what()));
    }
  }
  m->routes();
}

StudioServer::~StudioServer() { stop(); }

int StudioServer::start() {
  if (m->opts.port < 0 || m->opts.port > 65535) throw UsageError("studio", "--port must be in [0, 65535]");
  if (m->opts.port == 0) {
    m->port = m->server.bind_to_any_port(m->opts.bind);
  } else {
    m->port = m->server.bind_to_port(m->opts.bind, m->opts.port) ? m->opts.port : -1;
  }
  if (m->port <= 0)
    fail("studio", "cannot listen on {}:{} (in use, or not an address of this machine)", m->opts.bind, m->opts.port);
  m->guard.set_port(m->port);
  m->server.watch(m->port);
  // Long operations poll stop_requested(): the studio's cancel and time budget join the CLI's Ctrl-C.
  m->stop_check_id = add_stop_check([impl = m.get()] { return impl->should_stop(); });
  m->thread = std::thread([this] { m->server.listen_after_bind(); });
  // httplib's stop() does nothing before the accept loop runs: a server stopped right after its
  // start would leave that loop waiting for ever.
  for (int i = 0; i < 5000 && !m->server.is_running(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  return m->port;
}

void StudioServer::stop() {
  if (m->thread.joinable()) {
    m->server.stop();
    m->thread.join();
    remove_stop_check(m->stop_check_id);
  }
}

const std::string& StudioServer::token() const { return m->guard.token(); }

bool StudioServer::running() const { return m->server.is_running(); }

}  // namespace terracl
