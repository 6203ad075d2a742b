// SPDX-License-Identifier: Apache-2.0
// Progress display (GDAL's convention: one callback, fraction + message). A bar on a terminal,
// JSON lines for machines, nothing with -q. Ctrl-C turns the next callback into a cancel.
#include "cli.hpp"

#include <terracl/interrupt.hpp>
#include <terracl/io.hpp>

#include <fmt/format.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>

namespace terracl::cli {
namespace {

std::atomic<bool> g_interrupted{false};
bool g_bar_open = false;

void on_sigint(int) {
  if (g_interrupted.exchange(true)) {
    // A second Ctrl-C stops at once; the output being written is a temporary: unlink it first.
    remove_temporaries_signal_safe();
    std::_Exit(130);
  }
  // write(2) is async-signal-safe; stdio is not.
  static const char msg[] = "\nterracl: Ctrl-C: stopping at the next safe point (Ctrl-C again to quit at once)\n";
  [[maybe_unused]] const auto n = ::write(STDERR_FILENO, msg, sizeof msg - 1);
}

// SIGTERM / SIGHUP (kill, a closed terminal, a CI timeout) stop at once, leaving no temporary.
void on_terminate(int sig) {
  remove_temporaries_signal_safe();
  std::_Exit(128 + sig);
}

}  // namespace

void install_interrupt_handler() {
  // Library calls that only poll (GDAL's GeoTIFF writer) stop on the same Ctrl-C.
  set_stop_check([] { return g_interrupted.load(); });
  std::signal(SIGINT, on_sigint);
  std::signal(SIGTERM, on_terminate);
  std::signal(SIGHUP, on_terminate);
}

bool interrupted() { return g_interrupted.load(); }

void finish_progress() {
  if (g_bar_open) {
    std::fputc('\n', stderr);
    g_bar_open = false;
  }
}

Progress make_progress(const std::string& stage) {
  const Globals& g = globals();
  std::string mode = g.quiet ? "none" : g.progress;
  if (mode == "auto") mode = isatty(STDERR_FILENO) ? "bar" : "none";
  if (mode == "none") return [](double, const std::string&) { return !interrupted(); };
  if (mode == "json") {
    return [stage](double f, const std::string& msg) {
      std::string m;
      for (char c : msg) m += (c == '"' || c == '\\') ? std::string("\\") + c : std::string(1, c);
      std::printf("{\"stage\": \"%s\", \"fraction\": %.4f, \"message\": \"%s\"}\n", stage.c_str(), f, m.c_str());
      std::fflush(stdout);
      return !interrupted();
    };
  }
  auto last = std::make_shared<std::chrono::steady_clock::time_point>();
  return [stage, last](double f, const std::string& msg) {
    const auto now = std::chrono::steady_clock::now();
    if (f < 1.0 && now - *last < std::chrono::milliseconds(100)) return !interrupted();
    *last = now;
    const int width = 30, filled = int(f * width + 0.5);
    std::fprintf(stderr, "\r%-20.20s [%s%s] %3d%% %-30.30s", stage.c_str(), std::string(filled, '#').c_str(),
                 std::string(width - filled, '.').c_str(), int(f * 100 + 0.5), msg.c_str());
    std::fflush(stderr);
    g_bar_open = true;
    return !interrupted();
  };
}

}  // namespace terracl::cli
