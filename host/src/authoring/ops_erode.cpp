// SPDX-License-Identifier: Apache-2.0
// The "erode" operation: solve, erode on the device, and replace the gradient field by the eroded
// terrain's (its reconstruction is the eroded terrain; hard cells have weight 0 and keep their
// elevation). Recorded in scripts like any operation, so a studio session with erosion replays.
#include "authoring/ops_erode.hpp"

#include <terracl/interrupt.hpp>

#include <algorithm>
#include <cmath>
#include <terracl/gradient.hpp>

namespace terracl::edit {

namespace {
// Looks of erosion in physical units (docs/authoring.md, "Erosion presets"): what differs from the
// defaults; keys given in the operation override them.
void apply_preset(ErosionParams& q, const std::string& name) {
  // critical_shear (Pa) sets how concentrated the water must be to cut; channel_diffusion how wide the
  // cut grows with discharge; diffusion (m^2/s) the creep of the slopes between the channels.
  if (name == "young_alpine") {  // deep narrow gullies, sharp ridges, banks slumping at a steep repose
    q.rain = 0.004, q.dissolve = 0.012, q.deposit = 0.001, q.diffusion = 0.2, q.channel_diffusion = 1;
    q.thermal_rate = 0.08, q.talus_deg = 40, q.creep_into_cuts = false;
  } else if (name == "old_hills") {  // rounded slopes (creep), wide shallow channels, valleys filling
    q.rain = 0.002, q.dissolve = 0.005, q.deposit = 0.004, q.diffusion = 6, q.channel_diffusion = 2;
    q.thermal_rate = 0.03, q.talus_deg = 25, q.creep_into_cuts = false;  // creep rounds the whole relief
  } else if (name == "badlands") {  // dense sharp rills on soft rock (a low threshold), little creep
    q.rain = 0.005, q.dissolve = 0.015, q.deposit = 0.001, q.diffusion = 0.1;
    q.channel_diffusion = 0.5, q.thermal_rate = 0.06, q.talus_deg = 45, q.critical_shear = 50;
  } else if (name == "desert_wash") {  // rare water that drops its load in fans and wide washes
    q.rain = 0.0015, q.evaporation = 0.01, q.dissolve = 0.006, q.deposit = 0.006, q.diffusion = 0.5;
    q.channel_diffusion = 4, q.thermal_rate = 0.06, q.talus_deg = 33, q.critical_shear = 150;
  }
}
}  // namespace

ErodeSpec parse_erode_spec(Params& p) {
  ErodeSpec e;
  e.params = ErosionParams::defaults();
  apply_preset(e.params, p.choice("preset", "default", {"default", "young_alpine", "old_hills", "badlands", "desert_wash"}));
  // Settles like the erode stage; the studio previews with Erosion::settled_bed, the same
  // settle_sediment on the same bits, so the committed script replays to the preview.
  e.params.settle = p.boolean("settle", true);
  // No recession phase here: the live preview is the settled state after each step, and the
  // committed operation must replay to exactly what it showed (docs/erosion.md, "The valley
  // ribbon: recession phase and a depth-bounded pick-up").
  e.params.recession = 0;
  e.steps = p.integer("steps", {}, 1, 100000);
  e.params.rain = p.number("rain", e.params.rain, 0.0, 1.0);
  e.params.capacity = p.number("capacity", e.params.capacity, 0.0, 1e6);
  e.params.dissolve = p.number("dissolve", e.params.dissolve, 0.0, 100.0);
  e.params.deposit = p.number("deposit", e.params.deposit, 0.0, 100.0);
  e.params.evaporation = p.number("evaporation", e.params.evaporation, 0.0, 100.0);
  e.params.thermal_rate = p.number("thermal_rate", e.params.thermal_rate, 0.0, 100.0);
  e.params.talus_deg = p.number("talus", e.params.talus_deg, 0.0, 89.0);
  e.params.critical_shear = p.number("critical_shear", e.params.critical_shear, 0.0, 1e6);
  e.params.max_concentration = p.number("max_concentration", e.params.max_concentration, 0.0, 1e6);
  e.params.min_sin_slope = p.number("min_slope", e.params.min_sin_slope, 0.0, 1.0);
  e.params.deposit_layer = p.boolean("deposit_layer", e.params.deposit_layer);
  e.params.thermal_banks_only = p.boolean("thermal_banks_only", e.params.thermal_banks_only);
  e.params.creep_into_cuts = p.boolean("creep_into_cuts", e.params.creep_into_cuts);
  // Creep and channel widening (docs/erosion.md): on a steep range the default channel diffusion
  // planes the sheet-flow flanks smooth; a gallery pass lowers both to keep the gullies it cuts.
  e.params.diffusion = p.number("diffusion", e.params.diffusion, 0.0, 1e4);
  e.params.channel_diffusion = p.number("channel_diffusion", e.params.channel_diffusion, 0.0, 1e4);
  e.region = parse_region(p, true);
  e.falloff = p.hlength("falloff", 0.0);
  return e;
}

std::vector<float> erode_weight(const ErodeSpec& e, const Grid& g, const std::vector<float>& hard) {
  const size_t n = size_t(g.width) * g.height;
  std::vector<float> w(n, e.region.kind == Region::Everywhere ? 1.f : 0.f);
  if (e.region.kind == Region::Disc || e.region.kind == Region::Path) {
    const double r0 = e.region.radius, r1 = e.region.radius + e.falloff;
    for (int y = 0; y < g.height; ++y)
      for (int x = 0; x < g.width; ++x) {
        // distance to the disc's centre or the path's line (the band is the disc swept along it)
        const double d = e.region.kind == Region::Disc
                             ? std::hypot(x * g.cell_x - e.region.center.x, y * g.cell_y - e.region.center.y)
                             : e.region.distance(x * g.cell_x, y * g.cell_y) + r0;
        double v = d <= r0 ? 1.0 : (d >= r1 ? 0.0 : 1.0 - (d - r0) / (r1 - r0));
        v = v * v * (3 - 2 * v);  // smoothstep: no crease at the brush edge
        w[size_t(y) * g.width + x] = float(v);
      }
  } else if (e.region.kind == Region::Polygon) {
    for (size_t i : region_cells(e.region, g)) w[i] = 1.f;
  }
  for (size_t i = 0; i < n && i < hard.size(); ++i)
    if (!std::isnan(hard[i])) w[i] = 0.f;
  return w;
}

namespace {

Operation parse_erode(Params& p) {
  const ErodeSpec e = parse_erode_spec(p);
  return [e](EditState& s) {
    const Heightfield h = s.height();
    const std::vector<float> w = erode_weight(e, s.grid(), s.hard());
    // Long runs stop on Ctrl-C (CLI) or a cancel / time budget (studio): Cancelled, nothing changed.
    const Progress stop = [](double, const std::string&) { return !stop_requested(); };
    const Heightfield bed = erode(s.device(), h, e.params, e.steps, &w, nullptr, stop);
    double mean = 0;
    for (float z : bed.z) mean += z;
    s.add_erosion_change(h, bed);
    s.upload(extract_gradient(s.device(), bed));
    s.set_mean(mean / double(std::max<size_t>(1, bed.z.size())));
    s.changed();
    s.log().back()["steps"] = e.steps;
  };
}

}  // namespace

void add_erode_ops(std::vector<OpSpec>& ops) {
  ops.push_back({"erode",
                 "virtual-pipe erosion of the current terrain (steps, rain, capacity, ...; optional brush region)",
                 parse_erode});
}

}  // namespace terracl::edit
