// SPDX-License-Identifier: Apache-2.0
#pragma once
/// 2D launches of the cell kernels (kernels/launch.clh), one helper for every launcher.
// The device's info().launch picks the shape: "rows" launches (1, rows) with the x-loop inside
// the kernel (fastest on PoCL), "wide" launches one work-item per cell, x fastest, in groups of
// (preferred multiple, max / preferred) clipped to 256 work-items, queried once per kernel.
#include <terracl/device.hpp>

#include <map>
#include <string>

namespace terracl {

/// Work-group shape of one kernel on one device: (x, y) local sizes.
struct GroupShape {
  size_t x = 1, y = 4;
};

/// The local size launch_grid uses for `k` on `d` (queried and cached per device and kernel name).
GroupShape group_shape(Device& d, const cl::Kernel& k);

/// Kernel name -> group shape of every kernel launched so far on `d` (for --report / devices).
std::map<std::string, GroupShape> group_shapes(Device& d);

/// Launches a converted kernel over `w` x `h` cells (x over columns, y over rows). In the rows
/// shape only `h` matters (each work-item loops over x); the wide shape rounds both sizes up to
/// the group shape and the kernel bounds-checks.
void launch_grid(Device& d, cl::Kernel& k, size_t w, size_t h);

/// Queries the group shape of every cell kernel (builds their programs) and returns them all.
std::map<std::string, GroupShape> cell_kernel_groups(Device& d);

/// "rows" or "wide: groups 32x8 (smooth_rb0), ..." for reports.
std::string describe_launch(Device& d);

}  // namespace terracl
