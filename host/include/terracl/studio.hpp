// SPDX-License-Identifier: Apache-2.0
#pragma once
/// terracl studio: a local web server with the sketching page and its JSON API (docs/studio.md).
/// One shared session (an edit script on a base terrain) for every client.
#include <memory>
#include <functional>
#include <string>
#include <vector>
#include <terracl/device.hpp>

namespace terracl {

/// Settings of `terracl studio`.
struct StudioOptions {
  std::string base = "flat:513x513@10";  ///< raster path or flat:WxH[@cell]
  std::string script;                    ///< optional edit script loaded at start (any path)
  std::string bind = "127.0.0.1";
  int port = 8080;                                        ///< 0: any free port
  std::string workspace = ".";                            ///< scripts and exports stay inside this folder
  std::string three_dir = "/usr/share/javascript/three";  ///< Debian's libjs-three
  /// Host names the server answers besides 127.0.0.1, localhost, [::1] and `bind` (requests
  /// naming any other Host are refused: DNS rebinding).
  std::vector<std::string> allow_hosts;
  /// Folders operations may read files from besides the workspace (copy_paste, amplify, fit).
  std::vector<std::string> allow_dirs;
  /// The API token every /api request carries (X-Terracl-Token); empty: a random one. The page
  /// gets it embedded; scripts read it from the page or set it here.
  std::string token;
  /// Longest a request may hold the session (seconds): a longer operation is stopped and the
  /// session stays as it was.
  double time_limit_s = 120;
  /// A connection must deliver each request (headers and body) within this many seconds of its
  /// start or of the previous answer, else it is closed (slow clients cannot hold the workers).
  double request_timeout_s = 10;
  /// Run by the background warm-up once the programs are built (its argument: poll it, true means
  /// stop): compiles every kernel ahead of the first stroke (the CLI runs `devices --warm`'s
  /// workloads in child processes). Empty: only the programs are built ahead.
  std::function<void(const std::function<bool()>& stop)> compile_ahead;
};

/// The server; stop() (or the destructor) ends the background thread.
class StudioServer {
 public:
  StudioServer(Device& d, StudioOptions o);
  ~StudioServer();
  /// Binds and serves in a background thread; returns the port (throws when binding fails).
  int start();
  void stop();
  bool running() const;
  /// The API token of this server (what the page embeds).
  const std::string& token() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> m;
};

}  // namespace terracl
