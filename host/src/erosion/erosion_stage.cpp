// SPDX-License-Identifier: Apache-2.0
// The `erode` stage, its brush / constraint inputs and `terracl bench erode`.
#include "pipeline/builtin.hpp"

#include <terracl/constraints.hpp>
#include <terracl/erosion.hpp>
#include <terracl/error.hpp>
#include <terracl/memory.hpp>
#include <terracl/io.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <random>

#include <sys/resource.h>

namespace terracl {

namespace {

constexpr const char* kStage = "erode";
constexpr double kDefaultTime = 400.0;  // s of simulated time when neither steps nor time is given
// Halo of a tiled erosion, in cells per sub-step of the run (docs/scale.md, "Erosion").
constexpr double kTileReachPerSubstep = 1.0;

}  // namespace

std::vector<unsigned char> read_fixed_cells(const std::string& path, const Heightfield& g) {
  // The shared constraint reader; the erosion only needs which cells are hard, so z may be omitted
  // (it defaults to the input elevation, `g` serves as the current terrain).
  ConstraintSet c(g.width, g.height);
  add_constraints_file(c, path, g.georef, &g);
  std::vector<unsigned char> fixed(g.size(), 0);
  for (int y = 0; y < g.height; ++y)
    for (int x = 0; x < g.width; ++x) fixed[size_t(y) * g.width + x] = c.is_hard(x, y) ? 1 : 0;
  return fixed;
}

std::vector<float> read_region_weight(const std::string& path, const Heightfield& g, double feather) {
  ReadOptions ro;
  const FileFormat f = format_from_extension(path);
  if (f == FileFormat::PNG || f == FileFormat::RAW16) {
    ro.zmin = 0.0;  // grey codes 0..max map to weights 0..1
    ro.zmax = 1.0;
    if (f == FileFormat::RAW16) {
      ro.width = g.width;
      ro.height = g.height;
    }
  }
  Heightfield m = read_heightfield(path, ro);
  std::vector<float> w(g.size());
  for (int y = 0; y < g.height; ++y)
    for (int x = 0; x < g.width; ++x) {
      // Bilinear resampling (cell centres aligned) when the mask's size differs from the grid's.
      const double fx = m.width == g.width ? x : (x + 0.5) * m.width / g.width - 0.5;
      const double fy = m.height == g.height ? y : (y + 0.5) * m.height / g.height - 0.5;
      const int x0 = std::clamp(int(std::floor(fx)), 0, m.width - 1), y0 = std::clamp(int(std::floor(fy)), 0, m.height - 1);
      const int x1 = std::min(x0 + 1, m.width - 1), y1 = std::min(y0 + 1, m.height - 1);
      const double tx = std::clamp(fx - x0, 0.0, 1.0), ty = std::clamp(fy - y0, 0.0, 1.0);
      auto val = [&](int xx, int yy) {
        const float v = m.at(xx, yy);
        return std::isfinite(v) ? std::clamp(double(v), 0.0, 1.0) : 0.0;
      };
      const double v = (1 - ty) * ((1 - tx) * val(x0, y0) + tx * val(x1, y0)) + ty * ((1 - tx) * val(x0, y1) + tx * val(x1, y1));
      w[size_t(y) * g.width + x] = float(v);
    }
  // 1e9 overflowed the kernel radius (a crash) and 1e5 blurred for minutes without a check for
  // Ctrl-C: the direct blur costs 6 * feather operations per cell, so the width is bounded.
  if (!(feather >= 0 && feather <= max_region_feather))
    fail("erode", "region feather {} cells is out of range; expected 0..{} cells (blur a wider edge into the mask itself)",
         feather, max_region_feather);
  if (feather > 0) {
    // Separable Gaussian blur (clamped border) for the brush's smooth edge.
    const int r = int(std::ceil(3 * feather));
    std::vector<double> k(2 * r + 1);
    double sum = 0;
    for (int i = -r; i <= r; ++i) sum += k[i + r] = std::exp(-0.5 * i * i / (feather * feather));
    for (double& v : k) v /= sum;
    std::vector<float> tmp(w.size());
    for (int y = 0; y < g.height; ++y)
      for (int x = 0; x < g.width; ++x) {
        double acc = 0;
        for (int i = -r; i <= r; ++i) acc += k[i + r] * w[size_t(y) * g.width + std::clamp(x + i, 0, g.width - 1)];
        tmp[size_t(y) * g.width + x] = float(acc);
      }
    for (int y = 0; y < g.height; ++y)
      for (int x = 0; x < g.width; ++x) {
        double acc = 0;
        for (int i = -r; i <= r; ++i) acc += k[i + r] * tmp[size_t(std::clamp(y + i, 0, g.height - 1)) * g.width + x];
        w[size_t(y) * g.width + x] = float(std::clamp(acc, 0.0, 1.0));
      }
  }
  return w;
}

namespace {

ErosionParams params_from(const json& o) {
  ErosionParams p = ErosionParams::defaults();
  auto num = [&](const char* k, double& v) {
    if (o.contains(k) && !o.at(k).is_null()) v = o.at(k).get<double>();
  };
  num("dt", p.dt);
  num("rain", p.rain);
  num("evaporation", p.evaporation);
  num("capacity", p.capacity);
  num("dissolve", p.dissolve);
  num("deposit", p.deposit);
  num("min_slope", p.min_sin_slope);
  num("critical_shear", p.critical_shear);
  num("depth_ramp", p.depth_ramp);
  num("max_change", p.max_change);
  num("damping", p.damping);
  num("pipe_area", p.pipe_area);
  num("thermal_rate", p.thermal_rate);
  num("diffusion", p.diffusion);
  num("channel_diffusion", p.channel_diffusion);
  num("talus", p.talus_deg);
  num("dry_depth", p.dry_depth);
  num("rock_erodibility", p.rock_erodibility);
  num("deposit_talus", p.deposit_talus_deg);
  num("max_concentration", p.max_concentration);
  num("recession", p.recession);
  num("settling_velocity", p.settling_velocity);
  num("recession_concentration", p.recession_concentration);
  num("recession_evaporation", p.recession_evaporation);
  if (o.contains("deposit_layer") && o.at("deposit_layer").is_boolean()) p.deposit_layer = o.at("deposit_layer").get<bool>();
  if (o.contains("cells_per_item") && o.at("cells_per_item").is_number_integer())
    p.cells_per_item = o.at("cells_per_item").get<int>();
  if (o.contains("thermal_only") && o.at("thermal_only").is_boolean()) p.thermal_only = o.at("thermal_only").get<bool>();
  if (o.contains("settle") && o.at("settle").is_boolean()) p.settle = o.at("settle").get<bool>();
  if (o.contains("thermal_banks_only") && o.at("thermal_banks_only").is_boolean())
    p.thermal_banks_only = o.at("thermal_banks_only").get<bool>();
  if (o.contains("creep_into_cuts") && o.at("creep_into_cuts").is_boolean())
    p.creep_into_cuts = o.at("creep_into_cuts").get<bool>();
  if (o.contains("boundary") && o.at("boundary").is_string())
    p.boundary = o.at("boundary").get<std::string>() == "open" ? ErosionBoundary::Open : ErosionBoundary::Closed;
  return p;
}

void run_erode(StageContext& c) {
  Heightfield& h = c.height();
  require_finite(h, c.tag, "input heightfield");
  const ErosionParams p = params_from(c.options);
  const double limit = erosion_stability_limit(p, h.georef.cell_x, h.georef.cell_y);
  const double dt = p.dt > 0 ? p.dt : p.substep_fraction * limit;
  // The default run is a simulated time, not a step count: the step shrinks with the cell size
  // (docs/erosion.md), so a fixed count would erode a 10 m grid a third as long as a 30 m one.
  int steps = c.has("steps") ? c.get<int>("steps") : 0;
  if (c.has("time") || !c.has("steps")) {
    const double t = c.has("time") ? c.get<double>("time") : kDefaultTime;
    if (!(t > 0)) fail(c.tag, "--time must be positive, got {} s", t);
    if (t / dt > 1e8) fail(c.tag, "--time {} s is {:.3g} steps of {} s; more than 1e8 steps is not a sensible run", t, t / dt, dt);
    steps = int(std::ceil(t / dt - 1e-9));
  }
  if (steps < 0) fail(c.tag, "--steps must be >= 0, got {}", steps);

  std::vector<float> weight;
  if (c.has("region")) weight = read_region_weight(c.get<std::string>("region"), h, c.get<double>("region_feather"));
  if (c.has("keep_constraints")) {
    const auto fixed = read_fixed_cells(c.get<std::string>("keep_constraints"), h);
    if (weight.empty()) weight.assign(h.size(), 1.0f);
    for (size_t i = 0; i < fixed.size(); ++i)
      if (fixed[i]) weight[i] = 0.0f;
  }
  ErosionOutputs out;
  // Before the simulation allocates (terracl/memory.hpp): ~14 float fields on the device (terrain,
  // water, sediment, 4 fluxes, velocity, deposit, temporaries), the result and optional outputs here.
  require_memory(c.tag, fmt::format("eroding a {} x {} raster", h.width, h.height), double(h.size()) * 24,
                 double(h.size()) * 56, double(h.size()) * 16, &c.device(), "crop the raster or erode it in pieces");
  Heightfield result = erode(c.device(), h, p, steps, weight.empty() ? nullptr : &weight, &out, c.progress);
  // No wall-clock time here: this goes into the outputs' metadata, which must be byte-reproducible.
  json summary = {{"steps", steps},
                  {"substeps_per_step", out.substeps},
                  {"substep_dt_s", out.substep_dt},
                  {"simulated_time_s", steps * out.substeps * out.substep_dt},
                  {"water_m3", out.totals.water},
                  {"suspended_sediment_m3", out.totals.sediment},
                  {"drained_water_m3", out.totals.drained_water},
                  {"drained_sediment_m3", out.totals.drained_sediment},
                  {"settled_sediment_m3", out.totals.settled}};
  c.provenance["terracl:erode"] = summary.dump();
  for (const auto& [key, field] : {std::pair<const char*, Heightfield*>{"water", &out.water},
                                   {"sediment", &out.sediment},
                                   {"delta", &out.delta},
                                   {"deposit_thickness", &out.deposit}}) {
    if (!c.has(key)) continue;
    if (field->z.empty()) fail(c.tag, "--deposit-thickness needs --deposit-layer");
    for (const auto& [k, v] : c.provenance) field->metadata[k] = v;
    write_heightfield(*field, c.get<std::string>(key));
  }
  h = std::move(result);
  c.data.current = DataKind::Heightfield;
}

}  // namespace

int erode_tile_halo(const json& o, const Georef& g) {
  const ErosionParams p = params_from(o);
  const double limit = erosion_stability_limit(p, g.cell_x, g.cell_y);
  const double dt_max = p.substep_fraction * limit;
  const double dt = p.dt > 0 ? p.dt : dt_max;
  double steps = o.contains("steps") && !o.at("steps").is_null() ? o.at("steps").get<double>() : 0;
  if (o.contains("time") && !o.at("time").is_null())
    steps = std::ceil(o.at("time").get<double>() / dt - 1e-9);
  else if (!(o.contains("steps") && !o.at("steps").is_null()))
    steps = std::ceil(kDefaultTime / dt - 1e-9);
  const double substeps = std::max(1.0, std::ceil(dt / dt_max * (1.0 - 1e-12)));
  // The recession phase (erode()) runs after the steps and reaches as far per sub-step.
  if (!p.thermal_only && p.recession > 0) steps += std::ceil(p.recession / dt * (1.0 - 1e-12));
  // A window edge that is not the raster's is a closed wall; the wall is felt as far as the pipe
  // fluxes (the water's pressure) carry it: one cell per sub-step (water itself moves at most half
  // a cell, the velocity cap). Faster components of the exact dependency cone (up to three cells
  // per sub-step through the three kernels) decay below float round-off: measured in docs/scale.md.
  // The load still in transit at the end runs on up to sediment_reach() cells (route_sediment).
  const double halo = std::ceil(kTileReachPerSubstep * steps * substeps) +
                      (p.settle ? sediment_reach((long long)(steps * substeps)) : 0);
  return int(std::clamp(halo, 1.0, 1e6));
}

namespace {

/// Synthetic benchmark terrain: a few sine ridges plus small-scale noise, 30 m cells.
Heightfield bench_terrain(int n) {
  Heightfield t(n, n);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x)
      t.at(x, y) = float(800.0 + 300.0 * std::sin(6.0 * x / n) * std::cos(5.0 * y / n) + 150.0 * std::sin(23.0 * (x + 0.5 * y) / n)) + u(rng);
  t.georef.cell_x = t.georef.cell_y = 30.0;
  return t;
}

void run_bench(const BenchArgs& a) {
  auto dev = Device::open(a.device);
  json o = a.extra;
  const ErosionParams p = params_from(o);
  const int steps_per_run = o.contains("steps") ? o["steps"].get<int>() : 20;
  const Heightfield t = bench_terrain(a.size);
  Erosion sim(*dev, t, p);
  sim.enqueue_steps(10);  // warm-up: kernel compilation, first touches
  sim.finish();
  auto cpu_seconds = [] {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    return u.ru_utime.tv_sec + u.ru_stime.tv_sec + 1e-6 * (u.ru_utime.tv_usec + u.ru_stime.tv_usec);
  };
  std::vector<double> ms;
  const double cpu0 = cpu_seconds();
  for (int r = 0; r < a.repeats; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    sim.enqueue_steps(steps_per_run);
    sim.finish();
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count() / steps_per_run);
  }
  // CPU time of all threads per step: a load-independent cross-check when the machine is shared.
  const double cpu_ms = 1000.0 * (cpu_seconds() - cpu0) / (double(a.repeats) * steps_per_run);
  std::vector<double> sorted = ms;
  std::sort(sorted.begin(), sorted.end());
  const double med = sorted[sorted.size() / 2];
  fmt::print("erode {}x{} on {}: {:.2f} ms/step, {:.1f} steps/s (median of {} runs of {} steps after 10 warm-up; "
             "min {:.2f}, max {:.2f} ms/step; {} sub-step(s) per step{}{}); CPU time {:.2f} ms/step over all threads\n",
             a.size, a.size, dev->info().name, med, 1000.0 / med, a.repeats, steps_per_run, sorted.front(),
             sorted.back(), sim.substeps(), p.thermal_only ? ", thermal only" : "",
             p.boundary == ErosionBoundary::Open ? ", open border" : "", cpu_ms);
}

}  // namespace

namespace {
OptionSpec opt(std::string name, OptionType type, json def, std::string unit, std::string help,
               std::vector<std::string> choices = {}) {
  OptionSpec o;
  o.name = std::move(name);
  o.type = type;
  o.default_value = std::move(def);
  o.unit = std::move(unit);
  o.help = std::move(help);
  o.choices = std::move(choices);
  return o;
}
}  // namespace

void register_erosion_stages(StageRegistry& r) {
  const ErosionParams d = ErosionParams::defaults();
  r.add({"erode",
         "Hydraulic (virtual pipes) and thermal erosion on the device; mass-conserving, optional brush "
         "region and fixed hard constraints.",
         DataKind::Heightfield,
         DataKind::Heightfield,
         {
             opt("steps", OptionType::Int, nullptr, "", "Number of time steps (default: --time 400 s)").range(0, 100000000),
             opt("time", OptionType::Float, nullptr, "s",
                 "Simulated time (default 400 s when --steps is not given); overrides steps (steps = ceil(time / dt))"),
             opt("dt", OptionType::Float, 0.0, "s",
              "Time step; 0 = half the stability limit sqrt(l*a/(2*A*g)); a larger dt is split into sub-steps").range(0, {}),
             opt("rain", OptionType::Float, d.rain, "m/s", "Rain added uniformly to every cell (e.g. \"36000 mm/h\")"),
             opt("evaporation", OptionType::Float, d.evaporation, "1/s", "Evaporation rate: depth decays by (1 - rate*dt)"),
             opt("thermal_only", OptionType::Bool, false, "", "Only thermal erosion (no water)"),
             opt("capacity", OptionType::Float, d.capacity, "s",
              "Sediment capacity K_c: C = K_c * (max(min_slope, S) - tau_c/(rho_w*g*depth)) * speed * min(1, depth/depth_ramp), "
              "S the sine of the bed slope along the flow"),
             opt("dissolve", OptionType::Float, d.dissolve, "1/s", "Rate K_s of picking up sediment below capacity"),
             opt("deposit", OptionType::Float, d.deposit, "1/s", "Rate K_d of depositing sediment above capacity"),
             opt("min_slope", OptionType::Float, d.min_sin_slope, "", "Lower bound of sin(slope) in the capacity"),
             opt("depth_ramp", OptionType::Float, d.depth_ramp, "m", "Capacity ramps up with water depth until this depth"),
             opt("critical_shear", OptionType::Float, d.critical_shear, "Pa",
                 "Critical bed shear stress tau_c: the flow detaches the bed only where rho_w*g*depth*slope exceeds it "
                 "(0 = any flow)"),
             opt("max_change", OptionType::Float, d.max_change, "m/s",
                 "Largest bed change of a cell per second (the cap of a sub-step is this times its dt)"),
             opt("damping", OptionType::Float, d.damping, "1/s", "Pipe flux damping k_f (semi-implicit)"),
             opt("pipe_area", OptionType::Float, 0.0, "m2",
                 "Virtual pipe cross-section A; 0 = sqrt(cell area) x 80 m (flow speeds and dt/cell size independent of "
                 "the cell size)"),
             opt("dry_depth", OptionType::Float, d.dry_depth, "m", "Depth below which a cell is dry (no velocity, deposits all)"),
             opt("thermal_rate", OptionType::Float, d.thermal_rate, "1/s", "Thermal erosion rate K_t (0 = off)"),
             opt("diffusion", OptionType::Float, d.diffusion, "m2/s",
                 "Bed diffusion D (hillslope creep): smooths features of width w in w^2/D s (0 = off)"),
             opt("channel_diffusion", OptionType::Float, d.channel_diffusion, "",
                 "Channel diffusion K_q: banks slump into water that cuts at K_q * q (q = speed x depth above the "
                 "critical shear, m2/s); widens channels with discharge (0 = off)"),
             opt("talus", OptionType::Float, d.talus_deg, "deg", "Talus angle: steeper slopes shed material"),
             opt("thermal_banks_only", OptionType::Bool, d.thermal_banks_only, "",
                 "With water: the talus exchange only into cells where the flow cuts (banks slump into streams; "
                 "the input's cliffs away from water stand)"),
             opt("creep_into_cuts", OptionType::Bool, d.creep_into_cuts, "",
                 "With water: creep only into cells below their input height (heals cuts, keeps the input's "
                 "hillslope texture); off: plain diffusion everywhere"),
             opt("deposit_layer", OptionType::Bool, false, "",
                 "Track a softer deposit layer on the rock (own talus, rock dissolves slower)"),
             opt("rock_erodibility", OptionType::Float, d.rock_erodibility, "",
                 "With --deposit-layer: rock dissolves at this fraction of the deposit's rate (0..1)"),
             opt("deposit_talus", OptionType::Float, d.deposit_talus_deg, "deg", "With --deposit-layer: talus angle of the deposit"),
             opt("boundary", OptionType::Enum, "open", "", "closed: nothing leaves; open: water and sediment drain over the edge",
              {"closed", "open"}),
             opt("region", OptionType::Path, nullptr, "", "Brush mask raster (PNG grey 0..1, or float); erosion only where painted"),
             opt("region_feather", OptionType::Float, 3.0, "cells", "Gaussian blur (sigma) of the region mask for a smooth edge")
                 .range(0, max_region_feather),
             opt("keep_constraints", OptionType::Path, nullptr, "",
              "Constraints JSON (points/polygons/polylines, pixels or \"units\": \"georeferenced\"): those cells stay fixed"),
             opt("max_concentration", OptionType::Float, d.max_concentration, "",
                 "The flow picks up no more once its load is this times its depth (0 = no bound)"),
             opt("recession", OptionType::Float, d.recession, "s",
                 "After the rain: this much simulated time without rain in which the water drains and drops its "
                 "load along its way (0 = off)"),
             opt("settling_velocity", OptionType::Float, d.settling_velocity, "m/s",
                 "In the recession: the load above capacity settles at this speed (rate w_s / depth)"),
             opt("recession_concentration", OptionType::Float, d.recession_concentration, "",
                 "In the recession: capacity at most this times the water depth (0 = no bound)"),
             opt("recession_evaporation", OptionType::Float, d.recession_evaporation, "1/s",
                 "In the recession: evaporation rate (the water drains with its load rather than vanish)"),
             opt("settle", OptionType::Bool, true, "",
                 "At the end, settle the suspended sediment onto the bed (the output keeps all the material)"),
             opt("water", OptionType::OutputPath, nullptr, "", "Write the final water depth (m), e.g. water.exr"),
             opt("sediment", OptionType::OutputPath, nullptr, "", "Write the final suspended sediment (m, after settling), e.g. sediment.exr"),
             opt("delta", OptionType::OutputPath, nullptr, "", "Write the bed change (m, + = deposition), e.g. delta.exr"),
             opt("deposit_thickness", OptionType::OutputPath, nullptr, "",
                 "With --deposit-layer: write the deposit thickness (m), e.g. deposit.exr"),
         },
         run_erode});
}

void register_erosion_benches(BenchRegistry& r) {
  r.add({"erode",
         "Erosion steps on a synthetic NxN terrain (30 m cells); ms per step and steps/s (median). "
         "--set thermal_only=true|boundary=open|steps=K|cells_per_item=N|<any erode option>=v",
         run_bench});
}

}  // namespace terracl
