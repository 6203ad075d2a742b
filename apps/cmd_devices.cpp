// SPDX-License-Identifier: Apache-2.0
#include "cli.hpp"
#include <terracl/error.hpp>
#include <terracl/launch.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <thread>

namespace terracl::cli {
namespace {

// Compiles every kernel for the chosen device into the kernel caches (warm_kernel_caches), and
// says how long it took.
void warm_kernels() {
  const auto t0 = std::chrono::steady_clock::now();
  const int runs = warm_kernel_caches(globals().device);
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!globals().quiet)
    fmt::print("warmed the kernel caches for {} in {:.1f} s ({} runs, {} at a time): later commands do not compile\n",
               globals().device.empty() ? "the default device" : "device " + globals().device, s, runs,
               std::max(1u, std::thread::hardware_concurrency()));
}

CommandRegistrar reg(10, [](CLI::App& app) {
  auto* sub = app.add_subcommand("devices", "List OpenCL platforms and devices");
  static bool groups = false, warm = false;
  sub->add_flag("--groups", groups,
                "Also print each cell kernel's work-group shape on each device (builds the kernels; see docs/gpu.md)");
  sub->add_flag("--warm", warm,
                "Compile every kernel for the chosen device (--device) into the kernel caches now, so that no later "
                "command pays a first-use compile (~25 s on 2 cores with PoCL; run after installing or upgrading)");
  sub->callback([] {
    const auto devs = list_devices();
    if (devs.empty()) {
      fmt::print("no OpenCL device found (install an ICD such as pocl-opencl-icd; check `clinfo -l`)\n");
      if (warm) fail("devices", "--warm: no OpenCL device to compile the kernels for");
      return;
    }
    fmt::print("{:>3}  {:<28} {:<40} {:<5} {:>4} {:>10} {:>10}  {:<12} {:<6} {}\n", "idx", "platform", "device", "type",
               "CUs", "global MB", "maxalloc", "OpenCL C", "launch", "driver");
    for (const auto& d : devs)
      fmt::print("{:>3}  {:<28} {:<40} {:<5} {:>4} {:>10} {:>10}  {:<12} {:<6} {}\n", d.index, d.platform.substr(0, 28),
                 d.name.substr(0, 40), d.type, d.compute_units, d.global_mem >> 20, d.max_alloc >> 20,
                 d.opencl_c_version.substr(0, 12), d.launch, d.driver_version);
    std::fflush(stdout);
    if (warm) warm_kernels();
    if (!groups) return;
    for (const auto& d : devs) {
      auto dev = Device::open(std::to_string(d.index));
      fmt::print("\n{}: {}\n", d.name, d.launch == "wide" ? "wide, work-group x*y per cell kernel" : describe_launch(*dev));
      if (d.launch != "wide") continue;
      for (const auto& [n, s] : cell_kernel_groups(*dev)) fmt::print("  {:<22} {}x{}\n", n, s.x, s.y);
    }
  });
});

}  // namespace
}  // namespace terracl::cli
