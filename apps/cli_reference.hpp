// SPDX-License-Identifier: Apache-2.0
#pragma once
// The CLI's own reference, generated from the parsed command tree (so it cannot drift from it):
// a man page (roff) and a bash completion script, installed by the packages.
#include <CLI/CLI.hpp>

#include <string>

namespace terracl::cli {

/// terracl(1): every subcommand with its description, positionals and options.
std::string man_page(const CLI::App& app);
/// A bash completion script: subcommand names, each subcommand's options, files for the rest.
std::string bash_completion(const CLI::App& app);

}  // namespace terracl::cli
