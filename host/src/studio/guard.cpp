// SPDX-License-Identifier: Apache-2.0
#include "studio/guard.hpp"

#include <fmt/format.h>
#include <netdb.h>
#include <netinet/in.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <filesystem>
#include <random>

namespace terracl::studio {

namespace {

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return s;
}

bool starts_with(const std::string& s, const std::string& prefix) { return s.compare(0, prefix.size(), prefix) == 0; }

// Compares every byte so that the time taken says nothing of where a guess went wrong.
bool same_secret(const std::string& a, const std::string& b) {
  if (a.size() != b.size()) return false;
  unsigned char diff = 0;
  for (size_t i = 0; i < a.size(); ++i) diff |= static_cast<unsigned char>(a[i] ^ b[i]);
  return diff == 0;
}

std::string peer_of(socket_t sock) {
  sockaddr_storage addr{};
  socklen_t len = sizeof addr;
  if (getpeername(sock, reinterpret_cast<sockaddr*>(&addr), &len) != 0) return {};
  char host[NI_MAXHOST], port[NI_MAXSERV];
  if (getnameinfo(reinterpret_cast<sockaddr*>(&addr), len, host, sizeof host, port, sizeof port,
                  NI_NUMERICHOST | NI_NUMERICSERV) != 0)
    return {};
  return fmt::format("{}:{}", host, port);
}

std::string peer_of(const httplib::Request& req) { return fmt::format("{}:{}", req.remote_addr, req.remote_port); }

}  // namespace

RequestGuard::RequestGuard(const std::string& bind, const std::vector<std::string>& hosts, std::string token)
    : m_token(std::move(token)) {
  m_hosts = {"127.0.0.1", "localhost", "[::1]"};
  const bool v6 = bind.find(':') != std::string::npos;
  // A wildcard bind answers whatever name the user gives with --allow-host, not any name.
  if (bind != "0.0.0.0" && bind != "::") m_hosts.push_back(lower(v6 ? "[" + bind + "]" : bind));
  for (const std::string& h : hosts) m_hosts.push_back(lower(h));
}

bool RequestGuard::known_host(const std::string& host_port) const {
  const std::string hp = lower(host_port);
  std::string name = hp, port;
  const size_t close = hp.rfind(']');
  const size_t colon = hp.rfind(':');
  if (colon != std::string::npos && (close == std::string::npos || colon > close)) {
    name = hp.substr(0, colon);
    port = hp.substr(colon + 1);
  }
  if (std::find(m_hosts.begin(), m_hosts.end(), name) == m_hosts.end()) return false;
  // Browsers leave out only the default port.
  return port.empty() ? m_port == 80 : port == std::to_string(m_port);
}

std::optional<Refusal> RequestGuard::check(const httplib::Request& req) const {
  const std::string host = req.get_header_value("Host");
  if (!known_host(host))
    return Refusal{403, fmt::format("Host '{}' is not this studio's address (open http://127.0.0.1:{}/; "
                                    "other names need --allow-host)",
                                    host.substr(0, 100), m_port)};
  if (!starts_with(req.path, "/api/")) return std::nullopt;
  // Browsers send Origin on cross-origin fetches and on every POST; a page elsewhere must not
  // reach the API, even with requests that need no CORS preflight (a text/plain POST).
  if (req.has_header("Origin")) {
    const std::string origin = req.get_header_value("Origin");
    if (!starts_with(lower(origin), "http://") || !known_host(origin.substr(7)))
      return Refusal{403, fmt::format("Origin '{}' may not use this studio's API", origin.substr(0, 100))};
  }
  if (req.has_header("Sec-Fetch-Site")) {
    const std::string site = req.get_header_value("Sec-Fetch-Site");
    if (site != "same-origin" && site != "none")
      return Refusal{403, fmt::format("a {} request may not use this studio's API", site.substr(0, 40))};
  }
  if (!same_secret(req.get_header_value("X-Terracl-Token"), m_token))
    return Refusal{403, "missing or wrong X-Terracl-Token header (the token is in the studio page, "
                        "<meta name=\"terracl-token\">)"};
  const std::string type = lower(req.get_header_value("Content-Type"));
  const bool has_body =
      std::strtoull(req.get_header_value("Content-Length").c_str(), nullptr, 10) > 0 || req.has_header("Transfer-Encoding");
  if ((has_body || !type.empty()) && !starts_with(type, "application/json"))
    return Refusal{415, fmt::format("Content-Type '{}': the API takes application/json", type.substr(0, 60))};
  return std::nullopt;
}

std::string random_token() {
  std::random_device rd;  // the system's generator (getrandom / /dev/urandom on Linux)
  std::string out;
  for (int i = 0; i < 8; ++i) out += fmt::format("{:08x}", rd());
  return out;
}

GuardedServer::GuardedServer(double timeout_s, int workers)
    : m_timeout(std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(timeout_s))) {
  new_task_queue = [workers] { return new httplib::ThreadPool(size_t(workers)); };
  // httplib closes idle keep-alive connections itself before the watchdog would.
  set_keep_alive_timeout(std::max<time_t>(1, time_t(timeout_s / 2)));
}

GuardedServer::~GuardedServer() {
  {
    std::lock_guard<std::mutex> lock(m_mutex);
    m_quit = true;
  }
  m_wake.notify_all();
  if (m_thread.joinable()) m_thread.join();
}

void GuardedServer::watch(int port) {
  m_port = port;
  if (!m_thread.joinable()) m_thread = std::thread([this] { watchdog(); });
}

void GuardedServer::busy(const httplib::Request& req, bool busy) {
  std::lock_guard<std::mutex> lock(m_mutex);
  Conn& c = m_conns[peer_of(req)];
  c.busy = busy;
  c.deadline = std::chrono::steady_clock::now() + m_timeout;
}

void GuardedServer::watchdog() {
  std::unique_lock<std::mutex> lock(m_mutex);
  while (!m_quit) {
    m_wake.wait_for(lock, std::chrono::milliseconds(500));
    if (!m_quit) scan();
  }
}

// Called with m_mutex held.
void GuardedServer::scan() {
  const auto now = std::chrono::steady_clock::now();
  for (auto& [peer, c] : m_conns) c.seen = false;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator("/proc/self/fd", ec)) {
    char* end = nullptr;
    const long fd = std::strtol(entry.path().filename().c_str(), &end, 10);
    if (*end) continue;
    sockaddr_storage local{};
    socklen_t len = sizeof local;
    if (getsockname(int(fd), reinterpret_cast<sockaddr*>(&local), &len) != 0) continue;  // not a socket
    int port = -1;
    if (local.ss_family == AF_INET) port = ntohs(reinterpret_cast<sockaddr_in*>(&local)->sin_port);
    if (local.ss_family == AF_INET6) port = ntohs(reinterpret_cast<sockaddr_in6*>(&local)->sin6_port);
    if (port != m_port) continue;
    const std::string peer = peer_of(socket_t(fd));
    if (peer.empty()) continue;  // the listening socket
    auto [it, fresh] = m_conns.try_emplace(peer);
    Conn& c = it->second;
    if (fresh) c.deadline = now + m_timeout;
    c.seen = true;
    // Unread bytes: the connection waits for a free worker (a worker reading a slow client takes
    // each byte as it comes). Its time starts when a worker takes it.
    int unread = 0;
    if (::ioctl(int(fd), FIONREAD, &unread) == 0 && unread > 0) c.deadline = now + m_timeout;
    if (!c.busy && now > c.deadline) ::shutdown(int(fd), SHUT_RDWR);  // the worker's read fails; it closes
  }
  for (auto it = m_conns.begin(); it != m_conns.end();) it = it->second.seen || it->second.busy ? std::next(it) : m_conns.erase(it);
}

}  // namespace terracl::studio
