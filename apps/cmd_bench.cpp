// SPDX-License-Identifier: Apache-2.0
#include "cli.hpp"

#include <terracl/error.hpp>
#include <terracl/stage.hpp>

#include <fmt/format.h>

namespace terracl::cli {
namespace {

struct BenchCmd {
  std::string name;
  int size = 1025;
  int repeats = 10;
  std::vector<std::string> sets;
};

CommandRegistrar reg(90, [](CLI::App& app) {
  auto a = std::make_shared<BenchCmd>();
  auto* sub = app.add_subcommand("bench", "Run a benchmark and print its figures (no name: list them)");
  sub->add_option("name", a->name, "Benchmark name");
  sub->add_option("--size", a->size, "Grid size N (N x N)");
  sub->add_option("--repeats", a->repeats, "Timed repetitions after warm-up");
  sub->add_option("--set", a->sets, "Benchmark-specific KEY=VALUE");
  sub->callback([a] {
    auto& reg = BenchRegistry::instance();
    if (a->name.empty()) {
      for (const auto& b : reg.all()) fmt::print("{:<16} {}\n", b.name, b.description);
      return;
    }
    const BenchInfo* b = reg.find(a->name);
    if (!b) throw UsageError("bench", fmt::format("no benchmark '{}' (run `terracl bench` to list them)", a->name));
    if (a->size < 2) throw UsageError("bench", "--size must be at least 2");
    BenchArgs args;
    args.size = a->size;
    args.repeats = std::max(1, a->repeats);
    args.device = globals().device;
    args.extra = json::object();
    for (const auto& kv : a->sets) {
      auto eq = kv.find('=');
      if (eq == std::string::npos) throw UsageError("bench", fmt::format("--set expects KEY=VALUE, got '{}'", kv));
      std::string v = kv.substr(eq + 1);
      try {
        args.extra[kv.substr(0, eq)] = json::parse(v);
      } catch (const json::exception&) {
        args.extra[kv.substr(0, eq)] = v;
      }
    }
    b->run(args);
  });
});

}  // namespace
}  // namespace terracl::cli
