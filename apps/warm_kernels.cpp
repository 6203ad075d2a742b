// SPDX-License-Identifier: Apache-2.0
// Compiling every kernel ahead of use (`terracl devices --warm`, the studio's warm-up): PoCL
// compiles a kernel for each work-group shape at its first launch and caches the result on disk,
// so running small instances of the benchmarks fills the cache for every later process.
#include "cli.hpp"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <terracl/error.hpp>
#include <terracl/stage.hpp>
#include <thread>

extern char** environ;

namespace terracl::cli {
namespace {

// Small runs of the benchmarks, which between them launch every kernel the stages launch with the
// work-group shapes they use (~0.1-0.9 s of compiling each on PoCL). Longest first, so the
// parallel runs end together.
const std::vector<std::vector<std::string>> kWarmRuns = {
    {"render", "--size", "128"},
    {"reconstruct", "--size", "129"},
    {"edit", "--size", "129"},
    {"erode", "--size", "64"},
    {"reconstruct", "--size", "129", "--set", "refine=auto"},
    {"stroke", "--size", "129"},
    {"reconstruct", "--size", "129", "--set", "smoother=jacobi"},
    {"reconstruct", "--size", "129", "--set", "fixed=0"},  // the singular (pure Neumann) solve
};

std::string label(const std::vector<std::string>& a) {
  std::string s;
  for (const auto& x : a) s += (s.empty() ? "" : " ") + x;
  return s;
}

// Starts `terracl -q [--device D] bench ARGS --repeats 1` (this executable) with its output
// discarded; returns the child's pid.
pid_t spawn_bench(const std::vector<std::string>& args, const std::string& device) {
  std::vector<std::string> argv = {"terracl", "-q"};
  if (!device.empty()) argv.insert(argv.end(), {"--device", device});
  argv.push_back("bench");
  argv.insert(argv.end(), args.begin(), args.end());
  argv.insert(argv.end(), {"--repeats", "1"});
  std::vector<char*> c;
  for (auto& a : argv) c.push_back(a.data());
  c.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&fa, 2, "/dev/null", O_WRONLY, 0);
  pid_t pid = 0;
  // The runs also write terracl's program binaries (not written on PoCL otherwise: program_cache.cpp).
  std::vector<std::string> env_s;
  for (char** e = environ; *e; ++e)
    if (std::strncmp(*e, "TERRACL_PROGRAM_CACHE=", 22) != 0) env_s.emplace_back(*e);
  env_s.emplace_back("TERRACL_PROGRAM_CACHE=1");
  std::vector<char*> env;
  for (auto& e : env_s) env.push_back(e.data());
  env.push_back(nullptr);
  const int rc = posix_spawn(&pid, "/proc/self/exe", &fa, nullptr, c.data(), env.data());
  posix_spawn_file_actions_destroy(&fa);
  if (rc != 0) fail("devices", "--warm: cannot start a warm-up run ({})", std::strerror(rc));
  return pid;
}

}  // namespace

int warm_kernel_caches(const std::string& device, const std::function<bool()>& stop) {
  const size_t slots = std::max(1u, std::thread::hardware_concurrency());
  // The runs of the benchmarks this build has (the core build has no render, edit or stroke).
  std::vector<std::vector<std::string>> runs;
  for (const auto& r : kWarmRuns)
    if (BenchRegistry::instance().find(r.front())) runs.push_back(r);
  std::vector<std::pair<pid_t, std::string>> running;
  size_t next = 0, failed = 0;
  std::string failures;
  while (next < runs.size() || !running.empty()) {
    if (stop && stop()) {
      for (const auto& r : running) ::kill(r.first, SIGTERM);
      for (const auto& r : running) ::waitpid(r.first, nullptr, 0);
      return int(next - running.size());
    }
    while (next < runs.size() && running.size() < slots) {
      running.emplace_back(spawn_bench(runs[next], device), label(runs[next]));
      ++next;
    }
    // Our children only (the studio may have others), polled: a slot is refilled as soon as any
    // run ends, and `stop` is heard.
    bool reaped = false;
    for (auto it = running.begin(); it != running.end();) {
      int status = 0;
      const pid_t done = ::waitpid(it->first, &status, WNOHANG);
      if (done == 0) {
        ++it;
        continue;
      }
      if (done < 0 || !WIFEXITED(status) || WEXITSTATUS(status) != 0) {
        ++failed;
        failures += fmt::format("\n  terracl bench {} --repeats 1 (exit {})", it->second,
                                done < 0               ? -1
                                : WIFEXITED(status) ? WEXITSTATUS(status)
                                                    : 128 + WTERMSIG(status));
      }
      it = running.erase(it);
      reaped = true;
    }
    if (!reaped) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  if (failed)
    fail("devices", "--warm: {} of {} warm-up runs failed (run them to see why):{}", failed, runs.size(),
         failures);
  return int(runs.size());
}

}  // namespace terracl::cli
