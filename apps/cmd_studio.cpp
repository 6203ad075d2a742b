// SPDX-License-Identifier: Apache-2.0
// `terracl studio [BASE] [--script S.json] [--port 8080] [--bind 127.0.0.1] [--workspace DIR]
//  [--allow-dir DIR] [--allow-host NAME] [--time-limit S]`:
// the interactive sketching page and its JSON API (docs/studio.md).
#include <fmt/format.h>

#include <chrono>
#include <climits>
#include <cstdlib>
#include <filesystem>
#include <terracl/edit.hpp>
#include <terracl/error.hpp>
#include <terracl/studio.hpp>
#include <thread>

#include "cli.hpp"

#ifdef __GLIBC__
#include <malloc.h>
#endif

namespace terracl::cli {
namespace {

// Every studio change copies and frees tens of megabytes (a snapshot's layers, the solver's
// levels, previews): trimmed, the next change page-faulted them in again. Changing a layer after an
// erosion spent 150 of its 300 ms at 1025^2 in the page faults of copying the 50 MB snapshot; never
// trimming the heap (main() sets one arena and 32 MB blocks from the heap): 111 ms. The process
// keeps its peak memory.
void keep_freed_memory() {
#ifdef __GLIBC__
  mallopt(M_TRIM_THRESHOLD, INT_MAX);
#endif
}

CommandRegistrar reg(45, [](CLI::App& app) {
  auto o = std::make_shared<StudioOptions>();
  auto* sub = app.add_subcommand("studio", "Sketch a terrain interactively in the browser (docs/studio.md)");
  sub->add_option("base", o->base, "Base terrain: a raster, or flat:WIDTHxHEIGHT[@CELLSIZE][+ELEVATION] (metres)")
      ->capture_default_str();
  sub->add_option("--script", o->script, "Edit script to start from (JSON, as `terracl edit`)");
  sub->add_option("--port", o->port, "TCP port (0: any free port)")->capture_default_str();
  sub->add_option("--bind", o->bind, "Address to listen on (default: this machine only)")->capture_default_str();
  sub->add_option("--workspace", o->workspace, "Folder that saves, loads and exports are confined to")
      ->capture_default_str();
  sub->add_option("--three", o->three_dir, "Folder of three.js (Debian's libjs-three)")->capture_default_str();
  sub->add_option("--allow-dir", o->allow_dirs,
                  "Folder operations may read files from besides the workspace (copy_paste, amplify, fit); repeatable");
  sub->add_option("--allow-host", o->allow_hosts,
                  "Host name the server answers besides 127.0.0.1, localhost and --bind (e.g. with --bind 0.0.0.0); repeatable");
  sub->add_option("--time-limit", o->time_limit_s, "Longest one change may run (seconds); longer ones are stopped")
      ->check(CLI::Range(1.0, 86400.0))
      ->capture_default_str();
  sub->callback([o, sub] {
    keep_freed_memory();
    // Like `terracl edit`: without BASE, a script's own "base" (relative to the script) is used.
    if (sub->count("base") == 0 && !o->script.empty()) {
      const nlohmann::json script = read_edit_script(o->script);
      if (script.is_object() && script.contains("base") && script["base"].is_string())
        o->base =
            resolve_path(script["base"].get<std::string>(), std::filesystem::path(o->script).parent_path().string());
    }
    // Scripts that drive the API can fix the token; otherwise it is random and only the page has it.
    if (const char* t = std::getenv("TERRACL_STUDIO_TOKEN")) o->token = t;
    // The warm-up compiles every kernel ahead in child processes (`devices --warm`'s runs).
    o->compile_ahead = [](const std::function<bool()>& stop) { warm_kernel_caches(globals().device, stop); };
    StudioServer server(device(), *o);
    const int port = server.start();
    // One line a script can read to find the server (tests start it on port 0).
    fmt::print("studio: http://{}:{}/  (workspace {}; Ctrl-C stops)\n", o->bind, port, o->workspace);
    std::fflush(stdout);
    while (!interrupted()) std::this_thread::sleep_for(std::chrono::milliseconds(100));
    server.stop();
  });
});

}  // namespace
}  // namespace terracl::cli
