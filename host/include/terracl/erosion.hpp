// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Hydraulic (virtual-pipe) and thermal erosion on the OpenCL device (kernels/erosion.cl).
///
/// State per cell, float32 structure-of-arrays: bed elevation b (m), water depth d (m), suspended
/// sediment s (m of material per cell area), outflow fluxes fL fR fT fB of the four virtual pipes
/// (m^3/s). Per sub-step: rain -> fluxes -> water and sediment transport + velocity -> erosion and
/// deposition -> evaporation -> thermal erosion. With a closed border water and solid (bed +
/// suspended sediment) are conserved to round-off; with an open border what leaves is counted.
/// See docs/erosion.md for the model and the parameters.
#include <terracl/device.hpp>
#include <terracl/heightfield.hpp>
#include <terracl/progress.hpp>

#include <memory>
#include <string>
#include <vector>

namespace terracl {

/// Closed: no flux leaves the grid (water and solid conserved). Open: water and sediment drain
/// out at the border and are counted in ErosionTotals.
enum class ErosionBoundary { Closed, Open };

/// Parameters in SI units. Defaults carve visible gullies on 30-100 m DEMs in a few hundred steps.
struct ErosionParams {
  double dt = 0.0;             ///< s, time step; 0 = automatic (half the stability limit). A dt above
                               ///< that is split into equal sub-steps automatically.
  double rain = 0.0;           ///< m/s of rain added uniformly to every cell
  double evaporation = 0.0;    ///< 1/s, water depth decays as d *= (1 - evaporation*dt)
  double gravity = 9.81;       ///< m/s^2
  double pipe_area = 0.0;      ///< m^2, cross-section A of a virtual pipe; 0 = automatic:
                               ///< sqrt(cell area) x pipe_reference_length, which keeps flow speeds,
                               ///< the time step per metre and so the result of a given simulated
                               ///< time independent of the cell size
  static constexpr double pipe_reference_length = 80.0;  ///< m (the tuning scale, SRTM3 cells)
  double damping = 0.0;        ///< 1/s, k_f: semi-implicit damping of the pipe fluxes
  double capacity = 0.0;       ///< s, K_c: capacity (m) per (m/s of speed x sine of slope)
  double dissolve = 0.0;       ///< 1/s, K_s: rate of picking up (C - s)
  double deposit = 0.0;        ///< 1/s, K_d: rate of settling (s - C)
  double min_sin_slope = 0.0;  ///< lower bound of sin(slope) in the capacity, so flats still carry
  double critical_shear = 0.0; ///< Pa, tau_c: the flow detaches the bed only where its shear stress
                               ///< rho_w*g*d*S exceeds this (excess shear: the capacity's slope term is
                               ///< S - tau_c/(rho_w*g*d)); thin sheet flow on hillslopes cuts nothing
  double depth_ramp = 0.0;     ///< m, K_dmax: capacity ramps up linearly with depth until this depth
  double max_change = 0.0;     ///< m, cap on the bed change of one cell in one sub-step
  double dry_depth = 1e-4;     ///< m, d_min: below it a cell has no velocity and deposits all it carries
  double thermal_rate = 0.0;   ///< 1/s, K_t: fraction of the excess above talus moved per second
                               ///< (capped at 1/12 per sub-step for monotone behaviour)
  double diffusion = 0.0;      ///< m^2/s, D: linear diffusion of the bed (hillslope creep). It smooths a
                               ///< feature of width w in about w^2/D seconds, so it removes one-cell
                               ///< crinkles on fine grids and leaves features of tens of metres alone
  double channel_diffusion = 0.0;  ///< K_q (dimensionless): extra bed diffusion K_q * q where water flows,
                                   ///< q = |v| * d the unit discharge (m^2/s): widens channels to metres
  double talus_deg = 35.0;     ///< deg, talus (angle of repose) of the rock (of all material
                               ///< without a deposit layer)
  bool thermal_banks_only = false;  ///< with water: the talus exchange runs only on pairs where the flow
                                    ///< cuts at one of the two cells (bank failure into a stream); the
                                    ///< input's cliffs away from the water stand. Not with thermal_only
  bool creep_into_cuts = false;  ///< with water: creep (diffusion) runs only into cells below their input
                                 ///< height, healing cuts; the input's hillslope texture stays
  bool deposit_layer = false;  ///< track a softer deposit layer on top of the rock
  double rock_erodibility = 0.3;   ///< with a deposit layer: rock dissolves at this fraction of K_s
  double deposit_talus_deg = 30.0; ///< deg, with a deposit layer: talus of the deposit
  bool thermal_only = false;   ///< no water at all: only thermal erosion
  double max_concentration = 0.0;  ///< the flow picks up no more once its load is this times its depth
                                  ///< (m of sediment per m of water); 0 = no bound
  double recession = 0.0;      ///< s, erode(): simulated time after the rain stops (no rain, the load
                               ///< bounded by the depth and settling at w_s/d), so that the water drains
                               ///< and drops its load along its way instead of all at once where it
                               ///< stands at the end (a flat valley ribbon); 0 = off
  double settling_velocity = 0.0;  ///< m/s, w_s: during the recession the load above capacity settles
                                   ///< at the rate w_s/d (capped at 1 per sub-step)
  double recession_concentration = 0.0;  ///< during the recession the capacity is at most this times
                                         ///< the water depth (m of sediment per m of water); 0 = no bound
  double recession_evaporation = 0.0;  ///< 1/s, evaporation during the recession (the water should
                                      ///< drain with its load, not vanish and leave it where it stands)
  bool settle = true;          ///< erode(): at the end the suspended sediment settles onto the bed
                               ///< (times the brush weight), so the output conserves the material
  ErosionBoundary boundary = ErosionBoundary::Closed;
  double substep_fraction = 0.5;  ///< sub-steps are at most this fraction of the stability limit
  int cells_per_item = 0;  ///< cells of a row per work-item (multiple of 8); 0 = automatic: the whole
                           ///< row on CPUs, 32 on GPUs. Results are bitwise the same for any value.

  /// The defaults of the `erode` stage (carve gullies on the bundled SRTM tiles).
  static ErosionParams defaults();
};

/// Pipe cross-section A (m^2) used for a cell of lx x ly metres (ErosionParams::pipe_area).
double erosion_pipe_area(const ErosionParams& p, double lx, double ly);

/// Stability limit (s) of the pipe model for a cell of lx x ly metres:
/// dt_max = sqrt(a / (g * (A/lx + A/ly))), i.e. sqrt(l*a / (2*A*g)) for square cells.
double erosion_stability_limit(const ErosionParams& p, double lx, double ly);
/// Build options of kernels/erosion.cl for an Erosion on a grid `width` cells wide with these
/// parameters, with or without a weight (what the studio compiles ahead: Device::warm_up).
std::string erosion_program_options(const Device& dev, int width, const ErosionParams& params, bool weight);

/// The host copy of the state (row-major width x height, no halo).
struct ErosionState {
  int width = 0, height = 0;
  std::vector<float> bed, water, sediment, flux_l, flux_r, flux_t, flux_b;
  std::vector<float> deposit;  ///< deposit layer thickness (m); empty without a deposit layer
};

/// Totals in double precision, summed on the host: volumes in m^3.
struct ErosionTotals {
  double water = 0;          ///< sum of d * cell area
  double solid = 0;          ///< sum of (b + s) * cell area (bed + suspended sediment)
  double sediment = 0;       ///< sum of s * cell area
  double drained_water = 0;  ///< water that left through an open border since the start
  double drained_sediment = 0;
  double rained = 0;         ///< rain added since the start
  double settled = 0;        ///< erode() with settle: sediment settled onto the bed at the end
};

/// A running simulation on one device. Not thread-safe.
class Erosion {
 public:
  /// `terrain` must be finite; `weight` (optional, width*height values in [0, 1]) scales erosion,
  /// deposition and thermal transfer per cell: 0 keeps a cell's bed fixed (hard constraints, outside
  /// of a brush). `water` (optional) is the initial depth in m (finite, >= 0); `deposit` (optional,
  /// needs params.deposit_layer) the initial deposit thickness in m (finite, >= 0), part of `terrain`.
  Erosion(Device& dev, const Heightfield& terrain, const ErosionParams& params,
          const std::vector<float>* weight = nullptr, const std::vector<float>* water = nullptr,
          const std::vector<float>* deposit = nullptr);
  ~Erosion();
  Erosion(const Erosion&) = delete;
  Erosion& operator=(const Erosion&) = delete;

  /// Enqueues `n` steps (each `substeps()` sub-steps) without waiting for them.
  void enqueue_steps(int n);
  /// Runs `n` steps, reporting progress (fraction of n) and honouring cancellation.
  void run(int n, const Progress& progress = {}, const std::string& stage = "erode");
  /// Waits for the queue.
  void finish();
  /// Switches to the recession phase (ErosionParams::recession): no more rain, the capacity bounded
  /// by recession_concentration x depth, the excess settling at settling_velocity / depth. Steps run
  /// after this call are recession steps.
  void begin_recession();
  /// Steps of the recession phase: ceil(recession / step_dt()), 0 without rain or water.
  int recession_steps() const;

  ErosionState state();
  ErosionTotals totals();
  /// The current bed as a heightfield with the input's georef and metadata.
  Heightfield bed();
  /// The current bed with the suspended sediment settled onto it (settle_sediment), as erode()
  /// returns it with params.settle: what a live preview shows. The simulation itself is unchanged.
  Heightfield settled_bed(const std::vector<float>* weight = nullptr);

  int substeps() const { return m_substeps; }
  double substep_dt() const { return m_dt_sub; }  ///< s
  double step_dt() const { return m_dt_sub * m_substeps; }  ///< s
  double stability_limit() const { return m_dt_limit; }    ///< s
  long long steps_done() const { return m_steps; }

 private:
  struct Impl;
  std::unique_ptr<Impl> m;
  int m_substeps = 1;
  double m_dt_sub = 0, m_dt_limit = 0;
  long long m_steps = 0;
};

/// Optional extra outputs of erode().
struct ErosionOutputs {
  Heightfield water, sediment, delta;  ///< depth (m), suspended sediment (m), bed change (m, + = deposit)
  Heightfield deposit;                 ///< deposit layer thickness (m), only with a deposit layer
  ErosionTotals totals;
  int substeps = 1;
  double substep_dt = 0;
};

/// Settles the suspended sediment (m) onto `bed` where it is, times the brush weight (a weight-0
/// cell keeps its elevation); `sediment` keeps what stays suspended, `deposit` (if not empty) gains
/// what landed. Returns the settled volume (m^3).
double settle_sediment(Heightfield& bed, std::vector<float>& sediment, std::vector<float>& deposit,
                       const std::vector<float>* weight);

/// The load still in transit at the end of a run, run on down the valleys and settled (what erode()
/// and Erosion::settled_bed do): cells are visited from the highest bed down; each refills its bed
/// with the load it holds (its own suspended sediment plus what reached it from above), but never
/// above `initial` (its elevation before the erosion) and times its brush weight; the rest passes on
/// to its steepest lower neighbour (D8 on the bed). A cell with no lower neighbour takes all that
/// reaches it (a depression fills), except on an open border, where it leaves the grid
/// (`*drained`, m^3). So the load refills carved channels, fills depressions and leaves the crop; it
/// never raises a bank above the ground it was cut from. The load runs at most `reach` cells (its
/// load-weighted mean path length; 0 = no limit) and settles where it is when it has run that far,
/// so a cell's result depends only on the cells within `reach` (tiles: erode_tile_halo adds it).
/// `sediment` keeps what stays suspended (weight < 1), `deposit` (if not empty) gains what landed.
/// Returns the settled volume (m^3).
double route_sediment(Heightfield& bed, const std::vector<float>& initial, std::vector<float>& sediment,
                      std::vector<float>& deposit, const std::vector<float>* weight, bool open_border,
                      double* drained = nullptr, int reach = 0);
/// How far (cells) erode() and Erosion::settled_bed let the load run on after `substeps_run`
/// sub-steps: as far again as the water can go in that time at the velocity cap (half a cell per
/// sub-step), at least 64 cells.
int sediment_reach(long long substeps_run);

/// Runs `steps` steps on `terrain` and returns the eroded bed (with params.settle, the suspended
/// sediment settled onto it). `weight` as for Erosion.
Heightfield erode(Device& dev, const Heightfield& terrain, const ErosionParams& params, int steps,
                  const std::vector<float>* weight = nullptr, ErosionOutputs* outputs = nullptr,
                  const Progress& progress = {});

/// The cells of a constraint JSON file (the format of `reconstruct --constraints`, read by
/// add_constraints_file; z may be omitted here) as a width*height mask, 1 = fixed, for
/// `--keep-constraints`. Errors name the file and the JSON path.
std::vector<unsigned char> read_fixed_cells(const std::string& path, const Heightfield& grid);

/// Brush weight from a mask raster (any format read_heightfield reads; values scaled so the mask's
/// maximum is 1, resampled bilinearly when its size differs), blurred with a Gaussian of `feather`
/// cells for a smooth edge.
/// Largest region feather (cells) accepted: the blur costs 6 * feather operations per cell.
constexpr double max_region_feather = 100;
/// Brush weight (width*height values in [0, 1]) read from `path` as described above.
std::vector<float> read_region_weight(const std::string& path, const Heightfield& grid, double feather);

}  // namespace terracl
