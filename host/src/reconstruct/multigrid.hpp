// SPDX-License-Identifier: Apache-2.0
#pragma once
// Launcher for kernels/multigrid.cl (internal): the level hierarchy, smoothers, cycles and the
// published cascade, all enqueued without host waits except one norm read per cycle.
#include <terracl/device.hpp>
#include <terracl/reconstruct.hpp>

#include "cl/alloc_scope.hpp"

#include <vector>

namespace terracl::mg {

/// The level-0 problem already on the device: u (hard cells hold value - m, free cells the
/// initial guess - m) and g = -f with NaN at hard cells.
struct Problem {
  int width = 0, height = 0;
  double cell_x = 1, cell_y = 1;
  cl::Buffer u, g;
  bool singular = false;  ///< no hard cell: pure Neumann, defined up to a constant
  bool phases = false;    ///< drain the queue after the hierarchy build so the phase times are honest
};

struct SolveStats {
  int cycles = 0;
  std::vector<double> residuals;
  bool converged = false, stagnated = false;
  int levels = 0;
  int fused_level = -1;  ///< first level of the fused coarse cycle (multigrid_coarse.cl), -1: none
  double setup_ms = 0;
  double cycles_ms = 0, refine_ms = 0;  ///< wall time of the fine-level cycles and of the refinement
  uint64_t peak_bytes = 0;
  double rhs_norm = 0;  ///< the norm the relative residuals divide by
  std::string refinement = "off";  ///< refinement path used (refine.cpp)
  int refine_cycles = 0;
  std::vector<double> refine_residuals;
};

/// Runs the solve in place on p.u. `scope` counts the solve's own device buffers (for the peak
/// memory figure).
SolveStats solve(Device& d, Problem& p, const SolverOptions& o, const AllocationScope& scope);

}  // namespace terracl::mg
