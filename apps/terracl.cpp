// SPDX-License-Identifier: Apache-2.0
// terracl: one CLI with subcommands. Every subcommand is a thin call into the library; errors
// print as `terracl ERROR: <stage>: <message>` and exit 1 (2 for usage errors).
#include "cli.hpp"

#include <terracl/distributed.hpp>
#include <terracl/error.hpp>
#include <terracl/json_limits.hpp>
#include <terracl/version.hpp>

#include <unistd.h>

#include <algorithm>
#include <climits>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <map>
#include <string>
#include <vector>

namespace terracl::cli {

Globals& globals() {
  static Globals g;
  return g;
}

Device& device() {
  // Never destroyed: OpenCL platforms (oclgrind's, some GPU drivers) tear down their own state in
  // static destructors or atexit handlers, and releasing our objects after that corrupts their
  // heap. The process exit reclaims everything anyway.
  static auto* holder = new std::shared_ptr<Device>();
  auto& d = *holder;
  if (!d) {
    d = Device::open(globals().device);
    if (globals().verbose) std::cerr << "terracl: using device " << d->info().name << " (" << d->info().platform << ")\n";
  }
  return *d;
}

Metadata provenance() {
  return {{"terracl:version", terracl::version()}, {"terracl:command", globals().command_line}};
}

std::vector<std::pair<int, Setup>>& command_setups() {
  static std::vector<std::pair<int, Setup>> v;
  return v;
}

CommandRegistrar::CommandRegistrar(int order, Setup setup) { command_setups().emplace_back(order, std::move(setup)); }

namespace {

// PoCL keeps its own kernel cache under $XDG_CACHE_HOME too, and reports no device at all when it
// cannot write there; so an unwritable cache folder turns both caches off (with a warning) instead
// of "no OpenCL device found".
void disable_caches_if_unwritable() {
  namespace fs = std::filesystem;
  fs::path base;
  if (const char* x = std::getenv("XDG_CACHE_HOME"); x && *x) base = x;
  else if (const char* home = std::getenv("HOME"); home && *home) base = fs::path(home) / ".cache";
  if (base.empty()) return;
  std::error_code ec;
  fs::create_directories(base, ec);
  bool writable = !ec && fs::is_directory(base, ec) && ::access(base.c_str(), W_OK) == 0;
  if (writable) {
    // access() says yes to root on a read-only mount: try a file.
    std::string probe = (base / ".terracl-probe-XXXXXX").string();
    const int fd = ::mkstemp(probe.data());
    writable = fd >= 0;
    if (fd >= 0) ::close(fd), ::unlink(probe.c_str());
  }
  if (writable) return;
  std::cerr << "terracl: warning: cache folder " << base.string()
            << " is not writable; kernel caches are off for this run (kernels are compiled each time)\n";
  ::setenv("TERRACL_NO_CACHE", "1", 1);
  ::setenv("POCL_KERNEL_CACHE", "0", 0);
  if (!std::getenv("POCL_CACHE_DIR")) {
    static std::string dir = (fs::temp_directory_path(ec) / "terracl-pocl-XXXXXX").string();
    if (::mkdtemp(dir.data())) {
      ::setenv("POCL_CACHE_DIR", dir.c_str(), 1);
      std::atexit([] {
        std::error_code e;
        fs::remove_all(dir, e);
      });
    }
  }
}

// Under mpirun with several ranks (docs/scale.md): progress on rank 0 only, each rank on its own
// OpenCL device where the node has several (the node's rank modulo its GPUs, else its devices),
// and only tiled runs or a hypre reconstruction (each rank would otherwise write the same files).
// Returns false to refuse.
bool setup_ranks(int argc, char** argv) {
  if (distributed::size() <= 1) return true;
  auto& g = globals();
  if (distributed::rank() != 0) g.quiet = true;
  bool tiled = false, reconstruct = false, hypre = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    tiled |= a == "--tile" || a.rfind("--tile=", 0) == 0 || a == "--memory-budget" || a.rfind("--memory-budget=", 0) == 0;
    reconstruct |= a == "reconstruct";
    hypre |= a == "--solver=hypre" || (a == "--solver" && i + 1 < argc && std::string(argv[i + 1]) == "hypre");
  }
  // `reconstruct --solver hypre` distributes its solve over the ranks itself (rank 0 writes).
  if (reconstruct && hypre) return true;
  if (!tiled) {
    if (distributed::rank() == 0)
      std::cerr << "terracl ERROR: usage: under mpirun with " << distributed::size()
                << " ranks only tiled runs are distributed (give --tile or --memory-budget to run, or a tiled "
                   "subcommand); run other commands without mpirun\n";
    return false;
  }
  const bool env_choice = std::getenv("OCL_DEVICE") || std::getenv("OCL_PLATFORM") || std::getenv("OCL_TYPE");
  bool device_given = false;
  for (int i = 1; i < argc; ++i) device_given |= std::string(argv[i]).rfind("--device", 0) == 0;
  if (!device_given && !env_choice) {
    const auto devices = list_devices();
    std::vector<int> pick;
    for (const auto& d : devices)
      if (d.type == "GPU") pick.push_back(d.index);
    if (pick.empty())
      for (const auto& d : devices) pick.push_back(d.index);
    if (pick.size() > 1) g.device = std::to_string(pick[size_t(distributed::local_rank()) % pick.size()]);
  }
  return true;
}

}  // namespace

}  // namespace terracl::cli

namespace {
int run_cli(int argc, char** argv);

}  // namespace

int main(int argc, char** argv) {
  terracl::cli::use_huge_pages(argc, argv);  // may start the process again (apps/allocator.cpp)
  terracl::cli::keep_freed_memory();          // before MPI, OpenCL, GDAL or the studio's server start threads
  // Joins MPI when launched by mpirun (a build with TERRACL_MPI); else the only rank.
  terracl::distributed::start(&argc, &argv);
  if (!terracl::cli::setup_ranks(argc, argv)) {
    terracl::distributed::finish();
    return 2;
  }
  const int code = run_cli(argc, argv);
  // An error on any rank stops every rank (the message is printed already).
  if (code != 0 && terracl::distributed::size() > 1) {
    std::cerr.flush();
    terracl::distributed::abort(code);
  }
  terracl::distributed::finish();
  return code;
}

namespace {
int run_cli(int argc, char** argv) {
  using namespace terracl;
  auto& g = cli::globals();
  for (int i = 0; i < argc; ++i) g.command_line += (i ? " " : "") + std::string(argv[i]);
  cli::disable_caches_if_unwritable();

  CLI::App app{"terracl: terrain authoring and amplification in the gradient domain, on any OpenCL device"};
  app.set_version_flag("--version", std::string("terracl ") + terracl::version() +
                                        "\nLicensed under the Apache License, Version 2.0 (SPDX: Apache-2.0)");
  app.require_subcommand(1);
  app.fallthrough();
  app.add_option("--device", g.device, "OpenCL device: index or name substring (see `terracl devices`)")
      ->check(CLI::Validator(
          [](std::string& spec) -> std::string {
            // Checked up front so that every command, not only those that open the device, refuses it.
            // An all-digit spec is an index; one too long for an int is refused here (not "stol").
            if (!spec.empty() && spec.size() > 9 && spec.find_first_not_of("0123456789") == std::string::npos)
              return "device index " + terracl::abbreviate(spec, 20) + " is out of range (see `terracl devices`)";
            try {
              (void)Device::open(spec);
            } catch (const std::exception& e) {
              return e.what();
            }
            return {};
          },
          "DEVICE"));
  app.add_flag("-q,--quiet", g.quiet, "Print no progress");
  app.add_flag("-v,--verbose", g.verbose, "Name the device and print more detail");
  app.add_option("--progress", g.progress, "Progress display")->check(CLI::IsMember({"auto", "bar", "json", "none"}));

  auto& setups = cli::command_setups();
  std::stable_sort(setups.begin(), setups.end(), [](auto& a, auto& b) { return a.first < b.first; });
  for (auto& [order, setup] : setups) setup(app);

  cli::install_interrupt_handler();
  // GDAL's programs spell their options with one dash (gdalwarp -t_srs EPSG:4326 -tr 30 30 -of
  // AAIGrid): the same words are accepted here as aliases of terracl's options.
  static const std::map<std::string, std::string> gdal_spellings = {
      {"-t_srs", "--t-srs"}, {"-tr", "--tr"}, {"-ts", "--ts"}, {"-of", "--of"},
      {"-co", "--co"},       {"-ot", "--ot"}, {"-projwin", "--projwin"}};
  std::vector<std::string> words(argv, argv + argc);
  for (size_t i = 1; i < words.size(); ++i)
    if (auto it = gdal_spellings.find(words[i]); it != gdal_spellings.end()) words[i] = it->second;
  std::vector<char*> args;
  for (std::string& w : words) args.push_back(w.data());
  try {
    app.parse(int(args.size()), args.data());
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    cli::finish_progress();
    std::cerr << "terracl ERROR: usage: " << e.what() << "\n(run `terracl --help` or `terracl <command> --help`)\n";
    return 2;
  } catch (const terracl::UsageError& e) {
    cli::finish_progress();
    std::cerr << "terracl ERROR: " << e.what() << "\n";
    return 2;
  } catch (const terracl::Cancelled& e) {
    cli::finish_progress();
    std::cerr << "terracl ERROR: " << e.what() << "\n";
    return 130;  // 128 + SIGINT, as a shell reports a command stopped by Ctrl-C
  } catch (const terracl::Error& e) {
    cli::finish_progress();
    std::cerr << "terracl ERROR: " << e.what() << "\n";
    return 1;
  } catch (const cl::Error& e) {
    cli::finish_progress();
    std::cerr << "terracl ERROR: opencl: " << describe(e) << "\n";
    return 1;
  } catch (const std::exception& e) {
    cli::finish_progress();
    std::cerr << "terracl ERROR: internal: " << e.what() << "\n";
    return 1;
  }
  cli::finish_progress();
  return 0;
}
}  // namespace
