// SPDX-License-Identifier: Apache-2.0
#pragma once
// Shared pieces of the terracl CLI. Each apps/cmd_*.cpp registers its subcommands with a static
// CommandRegistrar; they are linked straight into the executable, so registration always runs.
#include <terracl/device.hpp>
#include <terracl/heightfield.hpp>
#include <terracl/progress.hpp>

#include <CLI/CLI.hpp>

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace terracl::cli {

/// Options that every subcommand understands (declared on the main app, with fallthrough).
struct Globals {
  std::string device;          ///< --device: index or name substring
  bool quiet = false;          ///< -q
  std::string progress = "auto";  ///< --progress=auto|bar|json|none
  bool verbose = false;        ///< -v
  std::string command_line;    ///< for provenance
};
Globals& globals();

/// The device chosen by --device / OCL_* (opened once).
Device& device();
/// Progress callback for the chosen display: a bar on a terminal, JSON lines, or nothing.
/// Returns false (cancel) after Ctrl-C.
Progress make_progress(const std::string& stage);
/// Ends a progress bar line if one is being drawn.
void finish_progress();

/// The process's allocator settings (apps/allocator.cpp): glibc's arenas and trimming, and 2 MB
/// pages, for which use_huge_pages may execute the CLI again with the same arguments.
void keep_freed_memory();
void use_huge_pages(int argc, char** argv);
/// Installs SIGINT handling: the first Ctrl-C asks running stages to stop cleanly.
void install_interrupt_handler();
bool interrupted();

/// Compiles every kernel for `device` (--device syntax; empty: the default) into the kernel
/// caches by running small benchmark runs of this executable, one per core at a time
/// (apps/warm_kernels.cpp); returns how many ran. `stop`, polled every 50 ms, ends them early.
/// Throws naming the runs that failed.
int warm_kernel_caches(const std::string& device, const std::function<bool()>& stop = {});

/// Provenance entries every output carries: version and command line.
Metadata provenance();

using Setup = std::function<void(CLI::App& app)>;
struct CommandRegistrar {
  CommandRegistrar(int order, Setup setup);
};
std::vector<std::pair<int, Setup>>& command_setups();

}  // namespace terracl::cli
