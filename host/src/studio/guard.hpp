// SPDX-License-Identifier: Apache-2.0
#pragma once
// What keeps the studio a local app that only its own page drives (docs/studio.md, "Threat
// model"): every request must name this server in Host (DNS rebinding), API calls must come from
// the page's own origin with its token and a JSON body, and each connection must deliver its
// request within a deadline so that slow clients cannot hold the workers.
#include <httplib.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace terracl::studio {

/// A refusal: HTTP status and the message of its {"error": ...} body.
struct Refusal {
  int status;
  std::string message;
};

class RequestGuard {
 public:
  /// `hosts`: names accepted in Host and Origin besides the loopback names; `token`: the API token.
  RequestGuard(const std::string& bind, const std::vector<std::string>& hosts, std::string token);
  void set_port(int port) { m_port = port; }
  const std::string& token() const { return m_token; }
  /// nullopt when `req` may go on.
  std::optional<Refusal> check(const httplib::Request& req) const;

 private:
  bool known_host(const std::string& host_port) const;
  std::vector<std::string> m_hosts;
  std::string m_token;
  int m_port = 0;
};

/// 32 random bytes from the system's generator, as hex.
std::string random_token();

/// An httplib server whose connections must each deliver a request (headers and body) within
/// `timeout` of their start or of their previous answer; a watchdog shuts down the others.
/// Requests being answered are exempt (a long edit is bounded by the studio's time budget).
/// httplib hands its sockets to no code of ours, so the watchdog finds them as the process's
/// TCP sockets on the server's port.
class GuardedServer : public httplib::Server {
 public:
  GuardedServer(double timeout_s, int workers);
  ~GuardedServer() override;
  /// Starts watching the connections of `port` (once bound).
  void watch(int port);
  /// Call when a handler starts working on `req` and when it is done with it.
  void busy(const httplib::Request& req, bool busy);

 private:
  struct Conn {
    std::chrono::steady_clock::time_point deadline;
    bool busy = false;
    bool seen = false;
  };
  void watchdog();
  void scan();
  std::chrono::steady_clock::duration m_timeout;
  int m_port = 0;
  std::mutex m_mutex;
  std::condition_variable m_wake;
  std::map<std::string, Conn> m_conns;  ///< by the peer's "address:port"
  bool m_quit = false;
  std::thread m_thread;
};

}  // namespace terracl::studio
