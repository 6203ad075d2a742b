// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Multigrid Poisson reconstruction: elevations from a gradient field (or a divergence) with hard
/// elevation constraints.
///
/// Discrete problem: sum over in-grid 4-neighbours n of (h_n - h)/d^2 = f (d = cx along rows, cy
/// along columns) at every free cell, h = c at every hard cell, natural Neumann border. With a
/// gradient input f = div(g) by backward differences of the staggered gradient, which makes
/// reconstruct(extract(h)) == h up to the solver tolerance.
#include <terracl/constraints.hpp>
#include <terracl/device.hpp>
#include <terracl/heightfield.hpp>
#include <terracl/progress.hpp>

#include <nlohmann/json.hpp>

#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace terracl {

/// Multigrid schedule. Fmg: full multigrid (coarse-to-fine with one V-cycle per level) followed by
/// V-cycles. Cascade: the published one-pass coarse-to-fine Jacobi schedule (comparison only).
enum class Cycle { V, W, Fmg, Cascade };
/// Rbgs: red-black Gauss-Seidel on the 5-point finest level and zebra (row red-black,
/// lexicographic in a row) Gauss-Seidel on the 9-point coarse levels. Jacobi: weighted Jacobi.
enum class Smoother { Rbgs, Jacobi };
/// Mixed-precision iterative refinement after the float32 solve: the solution is accumulated and
/// its residual computed in double, the float multigrid solves for corrections (one cycle each).
/// Auto: on the device where it has cl_khr_fp64, else on the host; Device: fp64 on the device
/// (error without cl_khr_fp64); Host: residual and accumulation on the host (any device).
enum class Refinement { Off, Auto, Device, Host };
/// Multigrid: the device's float32 geometric multigrid. Hypre: hypre's structured solver
/// (PFMG-preconditioned CG in double on the host, distributed over MPI ranks under mpirun; the
/// same discretisation; only in builds with -DTERRACL_MPI=ON, see terracl/hypre.hpp).
enum class Solver { Multigrid, Hypre };

Cycle parse_cycle(const std::string& s);          ///< "v" | "w" | "fmg" | "cascade"
Smoother parse_smoother(const std::string& s);    ///< "rbgs" | "jacobi"
Refinement parse_refinement(const std::string& s);  ///< "off" | "auto" | "device" | "host"
Solver parse_solver(const std::string& s);          ///< "multigrid" | "hypre"
/// Names as the parsers take them (reports, --help).
const char* cycle_name(Cycle c);
const char* smoother_name(Smoother s);
const char* refinement_name(Refinement r);
const char* solver_name(Solver s);

/// Multigrid settings (defaults: FMG then V-cycles, red-black Gauss-Seidel, 1e-6 relative residual).
struct SolverOptions {
  Cycle cycle = Cycle::Fmg;
  Smoother smoother = Smoother::Rbgs;
  /// Stop when ||f - L h|| / ||b|| <= tolerance, where b is the residual of the trivial guess
  /// (hard values, reference level elsewhere), i.e. the right-hand side of the reduced system.
  double tolerance = 1e-6;
  int max_cycles = 50;
  int pre_smooth = 2, post_smooth = 2;
  double jacobi_omega = 0.8;
  /// Mixed-precision refinement (not for the cascade) and its stop: the last correction is at
  /// most refine_tolerance of the solution's range, or corrections stop shrinking, or max_cycles.
  Refinement refine = Refinement::Off;
  double refine_tolerance = 1e-7;
  /// Fix the border cells to `initial` (Dirichlet border) instead of the natural Neumann border.
  bool dirichlet_border = false;
  /// Mean elevation of the result when no cell is hard (default: the gradient's source mean,
  /// else the mean of `initial`, else 0).
  std::optional<double> mean;
  /// Warm start (e.g. the previous solution of an interactive edit); not copied, may be null.
  const Heightfield* initial = nullptr;
  Progress progress;
  /// Solver::Hypre: tolerance is hypre's relative residual (same definition, in double) and
  /// max_cycles its CG iteration limit; cycle, smoother and refine do not apply.
  Solver solver = Solver::Multigrid;
};

/// The solved heightfield and the solver's figures (the --report file).
struct ReconstructResult {
  Heightfield height;
  int cycles = 0;                    ///< fine-level cycles (FMG's initial pass not counted)
  std::vector<double> residuals;     ///< relative residual before the first and after each cycle
  bool converged = false;            ///< reached the tolerance
  bool stagnated = false;            ///< stopped at the float32 rounding floor
  int levels = 0;
  double setup_ms = 0, solve_ms = 0, total_ms = 0;
  uint64_t device_bytes = 0;         ///< peak device memory of the solve
  std::string device;
  Cycle cycle = Cycle::Fmg;
  Smoother smoother = Smoother::Rbgs;
  size_t hard_cells = 0;
  /// Refinement path used: "off", "device-fp64" or "host-double"; its cycles and the relative
  /// residual (in double) before the first and after each of them.
  std::string refinement = "off";
  int refine_cycles = 0;
  std::vector<double> refine_residuals;
  /// "multigrid" or "hypre"; MPI ranks that took part (hypre; 1 otherwise).
  std::string solver = "multigrid";
  int ranks = 1;
  /// Wall time per set-up/solve phase, in order (host constraints, upload, device init, hierarchy,
  /// cycles, refinement, read-back, host finish). Filled only when TERRACL_PHASES or
  /// TERRACL_MG_PROFILE is set: the queue is then drained between phases, which adds waits.
  std::vector<std::pair<std::string, double>> phases_ms;
  /// cycles, residuals, times, memory and device as JSON (the --report file).
  nlohmann::json to_json() const;
};

/// Reconstructs elevations from a gradient field (staggered, or central which is converted
/// first). `c` may be empty (then the mean rule of SolverOptions applies) and must match the
/// gradient's size otherwise. Throws on NaN/Inf input, size mismatch or a device failure.
ReconstructResult reconstruct(Device& d, const GradientField& g, const ConstraintSet& c, const SolverOptions& o = {});

/// Same with a staggered gradient already on the device (gx, gy: width x height floats each, read
/// only; cell size from `like.georef`, which also gives the result's georef, metadata and the mean
/// rule's source mean). Saves the round trip through the host for editors that keep the field
/// on the device. A NaN/Inf in the buffers is reported as a non-finite result.
ReconstructResult reconstruct_device(Device& d, const cl::Buffer& gx, const cl::Buffer& gy, const GradientField& like,
                                     const ConstraintSet& c, const SolverOptions& o = {});

/// Same with the divergence f (1/m) given directly: (sum of in-grid neighbours - k h)/d^2 = f,
/// d from f.georef (1 when the raster has no georeferencing). With no hard cell f is projected
/// onto the solvable (zero-mean) part first.
ReconstructResult reconstruct_divergence(Device& d, const Heightfield& f, const ConstraintSet& c,
                                         const SolverOptions& o = {});

/// Number of multigrid levels and their sizes for a W x H grid (coarse n = n/2 + 1 until the
/// coarsest has at most 64 cells).
std::vector<std::pair<int, int>> multigrid_levels(int width, int height);

}  // namespace terracl
