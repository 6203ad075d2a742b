// terracl: one CLI with subcommands. Every subcommand is a thin call into the library; errors
// print as `terracl ERROR: <stage>: <message>` and exit 1 (2 for usage errors).
#include "cli.hpp"

#include <terracl/error.hpp>
#include <terracl/version.hpp>

#include <algorithm>
#include <iostream>

namespace terracl::cli {

Globals& globals() {
  static Globals g;
  return g;
}

Device& device() {
  static std::shared_ptr<Device> d;
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

}  // namespace terracl::cli

int main(int argc, char** argv) {
  using namespace terracl;
  auto& g = cli::globals();
  for (int i = 0; i < argc; ++i) g.command_line += (i ? " " : "") + std::string(argv[i]);

  CLI::App app{"terracl: terrain authoring and amplification in the gradient domain, on any OpenCL device"};
  app.set_version_flag("--version", std::string("terracl ") + terracl::version());
  app.require_subcommand(1);
  app.fallthrough();
  app.add_option("--device", g.device, "OpenCL device: index or name substring (see `terracl devices`)")
      ->check(CLI::Validator(
          [](std::string& spec) -> std::string {
            // Checked up front so that every command, not only those that open the device, refuses it.
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
  try {
    app.parse(argc, argv);
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
