#pragma once
/// terracl studio: a local web server with the sketching page and its JSON API (docs/studio.md).
/// One shared session (an edit script on a base terrain) for every client.
#include <memory>
#include <string>
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

 private:
  struct Impl;
  std::unique_ptr<Impl> m;
};

}  // namespace terracl
