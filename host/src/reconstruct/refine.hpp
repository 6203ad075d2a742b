// SPDX-License-Identifier: Apache-2.0
#pragma once
// Mixed-precision iterative refinement of a multigrid solve (internal; kernels/refine.cl).
#include "reconstruct/multigrid.hpp"

#include <functional>

namespace terracl {
class WorkspaceBuffers;
}

namespace terracl::mg {

/// Refines p.u (already solved in float) in place: residual in double (on the device with
/// cl_khr_fp64, else on the host as o.refine asks), `fine_cycle` (one float multigrid cycle on
/// p.u / p.g from a zero guess) for the correction, accumulated in double. Fills st.refinement,
/// st.refine_cycles, st.refine_residuals and st.peak_bytes (from `scope`).
/// Its vectors are taken from `ws` (the solve's workspace buffers).
void refine(Device& d, Problem& p, const SolverOptions& o, SolveStats& st, const AllocationScope& scope, WorkspaceBuffers& ws,
            const std::function<void()>& fine_cycle);

}  // namespace terracl::mg
