// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Compiling ahead: the programs a tool will use, built (or loaded from the disk cache) before
/// their first use, e.g. in a background thread while the studio waits for its first stroke.
#include <terracl/device.hpp>

#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace terracl {

/// Builds (or loads from the disk cache) each (file, options) program of the embedded kernels
/// (Device::program), so that their first use does not compile; returns how many are ready. It
/// touches only the Device's program cache (under the cache's own lock), never the queue: another
/// thread may call it while the Device runs work. A program that fails to build is skipped (its
/// first use reports the error). `stop`, polled between programs, ends it early.
size_t warm_up(Device& device, const std::vector<std::pair<std::string, std::string>>& programs,
               const std::function<bool()>& stop = {});

}  // namespace terracl
