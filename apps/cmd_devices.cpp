// SPDX-License-Identifier: Apache-2.0
#include "cli.hpp"
#include <terracl/launch.hpp>

#include <fmt/format.h>

namespace terracl::cli {
namespace {

CommandRegistrar reg(10, [](CLI::App& app) {
  auto* sub = app.add_subcommand("devices", "List OpenCL platforms and devices");
  static bool groups = false;
  sub->add_flag("--groups", groups,
                "Also print each cell kernel's work-group shape on each device (builds the kernels; see docs/gpu.md)");
  sub->callback([] {
    const auto devs = list_devices();
    if (devs.empty()) {
      fmt::print("no OpenCL device found (install an ICD such as pocl-opencl-icd; check `clinfo -l`)\n");
      return;
    }
    fmt::print("{:>3}  {:<28} {:<40} {:<5} {:>4} {:>10} {:>10}  {:<12} {:<6} {}\n", "idx", "platform", "device", "type",
               "CUs", "global MB", "maxalloc", "OpenCL C", "launch", "driver");
    for (const auto& d : devs)
      fmt::print("{:>3}  {:<28} {:<40} {:<5} {:>4} {:>10} {:>10}  {:<12} {:<6} {}\n", d.index, d.platform.substr(0, 28),
                 d.name.substr(0, 40), d.type, d.compute_units, d.global_mem >> 20, d.max_alloc >> 20,
                 d.opencl_c_version.substr(0, 12), d.launch, d.driver_version);
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
