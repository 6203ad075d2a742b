// SPDX-License-Identifier: Apache-2.0
// Stage table entries `extract` and `reconstruct`, and the `terracl bench reconstruct` benchmark.
#include "pipeline/builtin.hpp"
#include "reconstruct/hypre_solve.hpp"
#include "io/io_common.hpp"
#include "tile/extract_tiles.hpp"

#include <terracl/distributed.hpp>
#include <terracl/error.hpp>
#include <terracl/memory.hpp>
#include <terracl/gradient.hpp>
#include <terracl/hypre.hpp>
#include <terracl/io.hpp>
#include <terracl/reconstruct.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <random>

#include <sys/resource.h>

namespace terracl {
namespace {

void run_extract(StageContext& c) {
  const bool central = c.has("central") && c.get<bool>("central");
  c.data.gradient = extract_gradient(c.device(), c.height(),
                                     central ? GradientFormat::Central : GradientFormat::Staggered);
  c.data.current = DataKind::Gradient;
  // A tile of a tiled run: the mean is the whole raster's, from the tile engine's prepass.
  Metadata& md = c.data.gradient->metadata;
  if (auto it = md.find("terracl:tile_prepass"); it != md.end()) {
    c.data.gradient->mean_elevation = tile::extract_prepass_mean(it->second);
    md.erase(it);
    md.erase("terracl:tile_window");
  }
}

// The options of the solver from the stage's flags (the start heightfield and border aside).
SolverOptions solver_options(StageContext& c, Solver solver) {
  SolverOptions o;
  o.cycle = parse_cycle(c.get<std::string>("cycle"));
  o.smoother = parse_smoother(c.get<std::string>("smoother"));
  o.tolerance = c.get<double>("tolerance");
  o.max_cycles = int(c.get<int64_t>("max_cycles"));
  o.refine = parse_refinement(c.get<std::string>("refine"));
  o.refine_tolerance = c.get<double>("refine_tolerance");
  if (c.has("mean")) o.mean = c.get<double>("mean");
  o.dirichlet_border = c.get<std::string>("border") == "dirichlet";
  o.progress = c.progress;
  o.solver = solver;
  return o;
}

void finish_reconstruct(StageContext& c, ReconstructResult& r, const SolverOptions& o) {
  if (!r.converged && !r.stagnated && (o.cycle != Cycle::Cascade || o.solver == Solver::Hypre))
    fail("reconstruct", "did not converge in {} {} (relative residual {:.3g}, tolerance {:.3g})", r.cycles,
         o.solver == Solver::Hypre ? "CG iterations" : "cycles", r.residuals.back(), o.tolerance);
  if (o.refine != Refinement::Off && o.solver == Solver::Multigrid) r.height.metadata["terracl:refinement"] = r.refinement;
  c.data.height = std::move(r.height);
  c.data.current = DataKind::Heightfield;
}

// hypre from files: each MPI rank reads only its band of rows of every input and rasterises only
// its rows of the constraints (reconstruct_hypre_files); rank 0 keeps the result.
void run_hypre_by_bands(StageContext& c) {
  HypreBandFiles f;
  auto path = [&](const char* k) { return c.has(k) ? c.get<std::string>(k) : std::string(); };
  f.gradient = path("gradient");
  f.divergence = path("divergence");
  f.initial = path("initial");
  f.fixed_mask = path("fixed_mask");
  f.fixed_elevation = path("fixed_elevation");
  f.constraints = path("constraints");
  if (f.fixed_mask.empty() != f.fixed_elevation.empty())
    throw UsageError("reconstruct", "--fixed-mask and --fixed-elevation go together");
  SolverOptions o = solver_options(c, Solver::Hypre);
  if (o.dirichlet_border && f.initial.empty())
    throw UsageError("reconstruct", "--border dirichlet takes the border values from --initial, which is missing");
  int W = 0, H = 0;
  if (!f.gradient.empty()) W = io::read_gradient_rows(f.gradient, 0, 0, &H).width;  // the header
  else (void)read_heightfield_rows(f.divergence, 0, 0, &W, &H);
  // A rank needs its share of hypre's bytes and rank 0 the float result besides.
  require_memory("reconstruct", fmt::format("reconstructing a {} x {} grid with hypre", W, H),
                 double(W) * H * (kHypreHostBytesPerCell / distributed::size() + 4), 0, 0, nullptr,
                 "reconstruct a smaller grid (crop it)");
  ReconstructResult r = reconstruct_hypre_files(f, o);
  if (c.has("report") && hypre_is_root_rank()) write_text_file_atomic(c.get<std::string>("report"), r.to_json().dump(2) + "\n");
  finish_reconstruct(c, r, o);
}

void run_reconstruct(StageContext& c) {
  const bool has_g = c.has("gradient"), has_f = c.has("divergence");
  if (has_g && has_f) throw UsageError("reconstruct", "give either --gradient or --divergence, not both");
  const Solver solver = parse_solver(c.get<std::string>("solver"));
  // hypre from files is read by bands unless the pipeline's terrain (whole in memory anyway) is
  // the start heightfield.
  if (solver == Solver::Hypre && hypre_available() && (has_g || has_f) && (c.has("initial") || !c.data.height))
    return run_hypre_by_bands(c);
  std::optional<Heightfield> initial;
  if (c.has("initial")) initial = read_heightfield(c.get<std::string>("initial"));
  else if (c.data.height) initial = *c.data.height;  // the pipeline's current terrain

  GradientField g;
  Heightfield f;
  bool use_div = false;
  if (has_g) {
    g = read_gradient(c.get<std::string>("gradient"));
  } else if (has_f) {
    f = read_heightfield(c.get<std::string>("divergence"));
    use_div = true;
  } else if (c.data.gradient) {
    g = *c.data.gradient;
  } else {
    throw UsageError("reconstruct",
                     "needs a gradient: --gradient FILE, --divergence FILE, a gradient .exr as input, or a previous "
                     "stage that produces one");
  }
  const int W = use_div ? f.width : g.width, H = use_div ? f.height : g.height;
  const Georef& geo = use_div ? f.georef : g.georef;
  if (solver == Solver::Hypre && !hypre_available())
    throw UsageError("reconstruct", "--solver hypre: this build has no hypre (configure with -DTERRACL_MPI=ON, "
                                    "Debian's libhypre-dev and libopenmpi-dev); use --solver multigrid");
  // Before the solver allocates (terracl/memory.hpp): the multigrid hierarchy (4/3 of ~7 float
  // fields of the finest level) on the device, the constraints and the result here; hypre's
  // matrix, vectors and PFMG hierarchy in double on the host (this rank's band; every rank holds
  // the inputs and the result).
  if (solver == Solver::Hypre)
    require_memory("reconstruct", fmt::format("reconstructing a {} x {} grid with hypre", W, H),
                   double(W) * H * kHypreHostBytesPerCell, 0, 0, nullptr, "reconstruct a smaller grid (crop it)");
  else
    require_memory("reconstruct", fmt::format("reconstructing a {} x {} grid", W, H), double(W) * H * 24,
                   double(W) * H * 40, double(W) * H * 4, &c.device(), "reconstruct a smaller grid (crop it)");
  if (initial && (initial->width != W || initial->height != H))
    fail("reconstruct", "the initial heightfield is {}x{}, the gradient {}x{}", initial->width, initial->height, W, H);

  ConstraintSet cs(W, H);
  if (c.has("fixed_mask") != c.has("fixed_elevation"))
    throw UsageError("reconstruct", "--fixed-mask and --fixed-elevation go together");
  if (c.has("fixed_mask")) {
    const std::string mp = c.get<std::string>("fixed_mask"), ep = c.get<std::string>("fixed_elevation");
    Heightfield mask = read_heightfield(mp), elev = read_heightfield(ep);
    if (mask.width != W || mask.height != H)
      fail("reconstruct", "{}: fixed mask is {}x{}, the gradient {}x{}", mp, mask.width, mask.height, W, H);
    if (elev.width != W || elev.height != H)
      fail("reconstruct", "{}: fixed elevation is {}x{}, the gradient {}x{}", ep, elev.width, elev.height, W, H);
    cs.add_rasters(mask, elev, mp);
  }
  if (c.has("constraints"))
    add_constraints_file(cs, c.get<std::string>("constraints"), geo, initial ? &*initial : nullptr);

  SolverOptions o = solver_options(c, solver);
  if (o.dirichlet_border && !initial)
    throw UsageError("reconstruct", "--border dirichlet takes the border values from --initial, which is missing");
  if (initial && (c.has("initial") || o.dirichlet_border)) o.initial = &*initial;
  ReconstructResult r = use_div ? reconstruct_divergence(c.device(), f, cs, o) : reconstruct(c.device(), g, cs, o);
  if (c.has("report") && hypre_is_root_rank()) {
    nlohmann::json j = r.to_json();
    if (o.cycle == Cycle::Cascade && solver == Solver::Multigrid) {
      // How far the published one-pass schedule stays from the converged solution.
      SolverOptions fo = o;
      fo.cycle = Cycle::Fmg;
      fo.progress = nullptr;
      const ReconstructResult conv =
          use_div ? reconstruct_divergence(c.device(), f, cs, fo) : reconstruct(c.device(), g, cs, fo);
      double maxd = 0, sum2 = 0;
      for (size_t i = 0; i < conv.height.size(); ++i) {
        const double dlt = double(r.height.z[i]) - conv.height.z[i];
        maxd = std::max(maxd, std::fabs(dlt));
        sum2 += dlt * dlt;
      }
      const HeightStats hs = compute_stats(conv.height);
      j["converged_reference"] = {{"cycle", "fmg"},
                                  {"final_relative_residual", conv.residuals.back()},
                                  {"max_difference_m", maxd},
                                  {"rms_difference_m", std::sqrt(sum2 / double(conv.height.size()))},
                                  {"max_difference_of_range", hs.max > hs.min ? maxd / (hs.max - hs.min) : 0.0}};
    }
    write_text_file_atomic(c.get<std::string>("report"), j.dump(2) + "\n");
  }
  finish_reconstruct(c, r, o);
}

// ---- benchmark ----

struct BenchProblem {
  GradientField g;
  ConstraintSet c;
  std::vector<double> exact;
  double range = 0;
};

// Smooth terrain quantised to 1/1024 m on an 8 m grid: every gradient value and the device's
// divergence are then exact in float32, so the exact discrete solution is the terrain itself (a
// float64 reference without a float64 solve).
BenchProblem make_problem(int n, double fixed_fraction, unsigned seed) {
  BenchProblem p;
  const double cell = 8.0, q = 1.0 / 1024;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  struct Wave {
    double kx, ky, ph, a;
  };
  std::vector<Wave> waves;
  for (int i = 0; i < 6; ++i)
    waves.push_back({(1 + 3 * u(rng)) * 2 * M_PI / n, (1 + 3 * u(rng)) * 2 * M_PI / n, 2 * M_PI * u(rng), 500.0 / (i + 2)});
  p.exact.resize(size_t(n) * n);
  double lo = 1e300, hi = -1e300;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      double v = 1000;
      for (auto& w : waves) v += w.a * std::sin(w.kx * x + w.ky * y + w.ph);
      v = std::round(v / q) * q;
      p.exact[size_t(y) * n + x] = v;
      lo = std::min(lo, v), hi = std::max(hi, v);
    }
  p.range = hi - lo;
  p.g = GradientField(n, n);
  double sum = 0;
  for (double v : p.exact) sum += v;
  p.g.mean_elevation = sum / double(p.exact.size());  // used when no cell is fixed (--set fixed=0)
  p.g.georef.cell_x = p.g.georef.cell_y = cell;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const size_t i = size_t(y) * n + x;
      p.g.gx[i] = x + 1 < n ? float((p.exact[i + 1] - p.exact[i]) / cell) : 0.f;
      p.g.gy[i] = y + 1 < n ? float((p.exact[i + n] - p.exact[i]) / cell) : 0.f;
    }
  p.c = ConstraintSet(n, n);
  const size_t k = size_t(fixed_fraction * double(n) * n);
  std::uniform_int_distribution<int> cellpick(0, n - 1);
  for (size_t i = 0; i < k; ++i) {
    const int x = cellpick(rng), y = cellpick(rng);
    p.c.add_cell(x, y, p.exact[size_t(y) * n + x], ConstraintKind::Raster);
  }
  return p;
}

double cpu_ms() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return (u.ru_utime.tv_sec + u.ru_stime.tv_sec) * 1e3 + (u.ru_utime.tv_usec + u.ru_stime.tv_usec) * 1e-3;
}

void bench_reconstruct(const BenchArgs& a) {
  auto dev = Device::open(a.device);
  const json& e = a.extra;
  SolverOptions o;
  o.cycle = parse_cycle(e.value("cycle", std::string("fmg")));
  o.smoother = parse_smoother(e.value("smoother", std::string("rbgs")));
  o.tolerance = e.value("tolerance", 1e-6);
  o.max_cycles = e.value("max_cycles", 50);
  o.pre_smooth = e.value("pre", o.pre_smooth);
  o.post_smooth = e.value("post", o.post_smooth);
  o.refine = parse_refinement(e.value("refine", std::string("off")));
  o.refine_tolerance = e.value("refine_tolerance", o.refine_tolerance);
  o.solver = parse_solver(e.value("solver", std::string("multigrid")));
  const double fixed = e.value("fixed", 0.01);
  const int n = a.size;
  BenchProblem p = make_problem(n, fixed, 7);
  ReconstructResult r = reconstruct(*dev, p.g, p.c, o);  // warm-up: builds kernels, first-touch memory
  // Under mpirun (hypre) every rank runs the benchmark; rank 0 prints.
  const bool print = hypre_is_root_rank();
  if (print && o.solver == Solver::Hypre)
    fmt::print("reconstruct {}x{}: solver hypre (PFMG-CG), {:.4g} % fixed cells, {}\n", n, n, 100 * fixed, r.device);
  else if (print)
    fmt::print("reconstruct {}x{}: cycle {}, smoother {}, {:.4g} % fixed cells, refine {}, device {}\n", n, n,
               cycle_name(o.cycle), smoother_name(o.smoother), 100 * fixed, refinement_name(o.refine), dev->info().name);
  std::vector<double> ms, cpu;
  for (int i = 0; i < a.repeats; ++i) {
    const double c0 = cpu_ms();
    r = reconstruct(*dev, p.g, p.c, o);
    cpu.push_back(cpu_ms() - c0);
    ms.push_back(r.total_ms);
  }
  std::sort(ms.begin(), ms.end());
  std::sort(cpu.begin(), cpu.end());
  if (!print) return;
  double err = 0;
  for (size_t i = 0; i < p.exact.size(); ++i) err = std::max(err, std::fabs(double(r.height.z[i]) - p.exact[i]));
  fmt::print("median_ms {:.2f}   (min {:.2f}, max {:.2f}, {} runs after 1 warm-up; setup {:.2f} ms, cycles {:.2f} ms "
             "in the last run)\n",
             ms[ms.size() / 2], ms.front(), ms.back(), ms.size(), r.setup_ms, r.solve_ms);
  if (!r.phases_ms.empty()) {  // TERRACL_PHASES=1: the queue is drained between phases
    fmt::print("phases_ms (last run, queue drained between phases):");
    for (const auto& [name, v] : r.phases_ms) fmt::print("  {} {:.2f}", name, v);
    fmt::print("\n");
  }
  fmt::print("median_cpu_ms {:.2f}   (CPU time of all threads per solve: on a shared machine wall time is inflated "
             "by other processes, CPU time much less)\n",
             cpu[cpu.size() / 2]);
  if (o.solver == Solver::Hypre)
    fmt::print("cg_iterations {}   (one PFMG V(1,1) cycle each)\n", r.cycles);
  else
    fmt::print("cycles {}{}   levels {}\n", r.cycles, o.cycle == Cycle::Fmg ? " V(2,2) after the FMG pass" : "", r.levels);
  fmt::print("final_relative_residual {:.3e}   ({})\n", r.residuals.back(),
             r.converged ? "converged" : r.stagnated ? "stopped at the float32 floor" : "not converged");
  fmt::print("residual_history");
  for (double v : r.residuals) fmt::print(" {:.2e}", v);
  if (o.refine != Refinement::Off) {
    fmt::print("\nrefinement {} cycles {}   refine_residual_history", r.refinement, r.refine_cycles);
    for (double v : r.refine_residuals) fmt::print(" {:.2e}", v);
  }
  fmt::print("\nmax_error_m {:.3e}   ({:.2e} of the {:.1f} m range, vs the exact float64 solution)\n", err,
             err / p.range, p.range);
  fmt::print("device_memory_mb {:.1f}\n", r.device_bytes / 1048576.0);
}

}  // namespace

void register_reconstruct_stages(StageRegistry& r) {
  r.add({"extract",
         "Gradient of a heightfield (staggered forward differences in m/m, or the paper's central differences).",
         DataKind::Heightfield,
         DataKind::Gradient,
         {{"central", OptionType::Bool, false, "", "write central differences (h[i+1]-h[i-1])/2d (export format)"}},
         run_extract});
  r.add({"reconstruct",
         "Multigrid Poisson reconstruction of elevations from a gradient (or divergence) with hard constraints.",
         DataKind::None,
         DataKind::Heightfield,
         {
             {"gradient", OptionType::Path, nullptr, "", "gradient field .exr or 2-band .tif (default: the previous stage's gradient)"},
             {"divergence", OptionType::Path, nullptr, "", "divergence raster (1/m) instead of a gradient"},
             {"fixed_mask", OptionType::Path, nullptr, "", "raster; non-zero cells are hard constraints"},
             {"fixed_elevation", OptionType::Path, nullptr, "", "raster of elevations for --fixed-mask cells"},
             {"constraints", OptionType::Path, nullptr, "", "constraint JSON (points, polylines, polygons)"},
             {"initial", OptionType::Path, nullptr, "",
              "warm start / current elevations (for 'freeze' polygons and a Dirichlet border)"},
             {"cycle", OptionType::Enum, "fmg", "", "multigrid schedule", {"v", "w", "fmg", "cascade"}},
             {"smoother", OptionType::Enum, "rbgs", "", "smoother", {"rbgs", "jacobi"}},
             OptionSpec{"tolerance", OptionType::Float, 1e-6, "", "relative residual to stop at"}.range(1e-15, 1),
             OptionSpec{"max_cycles", OptionType::Int, 50, "", "maximum number of cycles"}.range(1, 100000),
             {"refine",
              OptionType::Enum,
              "auto",
              "",
              "mixed-precision refinement after the float32 solve, so that the answer is the asked one (residual in "
              "double; auto: on the device with fp64, else the host). off: float32 alone, about twice as fast but "
              "stopping at its rounding floor, up to ~1e-4 of the range off on sparse constraints",
              {"off", "auto", "device", "host"}},
             OptionSpec{"refine_tolerance", OptionType::Float, 1e-7, "",
                        "refinement stops when a correction is at most this fraction of the range"}
                 .range(1e-16, 1),
             {"mean", OptionType::Float, nullptr, "m", "mean elevation when no cell is fixed (default: the source's)"},
             {"solver",
              OptionType::Enum,
              "multigrid",
              "",
              "multigrid: the device's float32 multigrid; hypre: PFMG-preconditioned CG in double on the host, "
              "over the MPI ranks under mpirun (builds with -DTERRACL_MPI=ON; max_cycles = CG iterations)",
              {"multigrid", "hypre"}},
             {"border", OptionType::Enum, "neumann", "", "grid border condition", {"neumann", "dirichlet"}},
             {"report", OptionType::OutputPath, nullptr, "", "write cycles, residuals, times and device as JSON"},
         },
         run_reconstruct,
         true,
         // --validate: a reconstruction needs something to integrate (docs/pipelines.md promises this).
         [](const json& o, DataKind input, const std::string& where) {
           const bool given = (o.contains("gradient") && !o["gradient"].is_null()) ||
                              (o.contains("divergence") && !o["divergence"].is_null());
           if (o.contains("gradient") && !o["gradient"].is_null() && o.contains("divergence") && !o["divergence"].is_null())
             fail("pipeline", "{}: give either \"gradient\" or \"divergence\", not both", where);
           if (!given && input != DataKind::Gradient)
             fail("pipeline", "{}: reconstruct needs a gradient: a previous stage producing one (extract, a gradient "
                  ".exr) or the \"gradient\" or \"divergence\" option", where);
           return DataKind::Heightfield;
         }});
}

void register_reconstruct_benches(BenchRegistry& r) {
  r.add({"reconstruct",
         "Multigrid reconstruction of an NxN smooth terrain with 1 % random fixed cells (--set cycle=, smoother=, "
         "fixed=, tolerance=, refine=off|auto|device|host, solver=multigrid|hypre)",
         bench_reconstruct});
}

}  // namespace terracl
