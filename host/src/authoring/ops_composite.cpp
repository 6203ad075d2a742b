// SPDX-License-Identifier: Apache-2.0
// Composite brush (paper figure 8): mesa (plateau elevation constraints + a rim drop +
// downslope-oriented noise). "Downslope oriented" = the noise's gradients are dragged across the
// slope by a tensor aligned with the rim, so its crests and gullies run down the flanks.
#include "authoring/curve_shape.hpp"
#include "authoring/state.hpp"

#include <terracl/error.hpp>
#include <terracl/noise.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace terracl::edit {
namespace {

// Distance (metres) from a point to the boundary of a disc or polygon primitive.
double distance_to_edge(const Primitive& p, double x, double y) {
  if (p.shape == PrimitiveShape::Disc) return std::abs(std::hypot(x - p.points[0].x, y - p.points[0].y) - p.disc_radius);
  double best = 1e300;
  for (size_t i = 0; i < p.points.size(); ++i) {
    const Vec2 &a = p.points[i], &b = p.points[(i + 1) % p.points.size()];
    const double ux = b.x - a.x, uy = b.y - a.y, l2 = ux * ux + uy * uy;
    const double t = l2 > 0 ? std::clamp(((x - a.x) * ux + (y - a.y) * uy) / l2, 0.0, 1.0) : 0.0;
    best = std::min(best, std::hypot(x - a.x - t * ux, y - a.y - t * uy));
  }
  return best;
}

struct OrientedNoise {
  bool enabled = false;
  NoiseParams noise;
  double strength = 0.8;
};

OrientedNoise parse_oriented_noise(Params& p, double def_amp, double def_wavelength) {
  OrientedNoise o;
  if (p.has("noise")) {
    Params q = p.child("noise");
    o.strength = q.number("orient_strength", 0.8, 0.0, 1.0);
    o.noise = parse_noise_block(q, def_amp, def_wavelength, "ridged");
  } else {
    o.noise.type = NoiseType::Ridged;
    o.noise.amplitude = def_amp;
    o.noise.wavelength = def_wavelength;
    o.noise.octaves = 5;
    o.noise.seed = p.grid().seed;
  }
  o.enabled = o.noise.amplitude != 0;
  return o;
}

// Noise masked by alpha(d/r) around `region`, oriented by `orient` (a tensor primitive), added to g.
void add_oriented_noise(EditState& s, const OrientedNoise& o, const Primitive& region, Primitive orient) {
  if (!o.enabled) return;
  Device& d = s.device();
  GradientBuffers& b = s.buffers();
  const Box box = primitives_box({region}, b.width, b.height, b.cell_x, b.cell_y);
  primitive_weight(d, b, {region}, box, false);
  if (o.strength == 0) {  // A = I: add the masked noise directly (no tensor pass)
    noise_gradient(d, b, o.noise, box, true, false);
    return;
  }
  b.clear_scratch(d, box);
  noise_gradient(d, b, o.noise, box, true, true);
  orient.strength = o.strength;
  add_tensor_field_of_scratch(d, b, {orient}, box);
  b.clear_scratch(d, box);
}

// A mesa: the rim ring is hard at `elevation`; the cap inside is free and gets gentle noise of its
// own (detail, no flat disc), and the flanks drop as a cliff face over a talus apron (the cliff's
// Drop profile with a scree share).
Operation parse_mesa(Params& p) {
  const Region r = parse_region(p, false);
  if (r.kind == Region::Path) param_error(p.where("path"), "a mesa takes center + radius or a polygon, not a painted path");
  const double top = p.vlength("elevation");
  const double height = p.vlength("height");
  if (!(height > 0)) param_error(p.where("height"), fmt::format("expected a drop > 0 m, got {}", height));
  const double radius = p.hlength("radius", {}, 0, true);
  const double talus = p.number("talus", 0.4, 0.0, 0.95);
  const double cap_detail = p.vlength("cap_detail", 0.03 * height);
  const OrientedNoise noise = parse_oriented_noise(p, 0.08 * height, radius / 2);
  return [=](EditState& s) {
    const Grid& g = s.grid();
    Primitive rim = region_primitive(r, g, std::max(radius, min_half_width(g)));
    rim.profile = Profile::Drop;
    rim.profile_amplitude = height;
    rim.scree = talus;
    rim.face_fraction = 0.35;
    add_profile_gradient(s.device(), s.buffers(), {rim});
    Primitive orient = rim;
    orient.tensor = TensorKind::Closest;
    orient.angle = M_PI / 2;  // drag gradients across u(p): gullies run towards the rim
    add_oriented_noise(s, noise, rim, orient);
    if (cap_detail != 0) {  // undulations on the cap, fading out towards the rim
      OrientedNoise cap;
      cap.enabled = true;
      cap.noise.type = NoiseType::Fbm;
      cap.noise.amplitude = cap_detail;
      cap.noise.wavelength = std::max(radius, 4 * std::max(g.cell_x, g.cell_y));
      cap.noise.octaves = 4;
      cap.noise.seed = noise.noise.seed + 1;
      cap.strength = 0;
      Primitive inner = rim;
      inner.radius = std::max(g.cell_x, g.cell_y);
      add_oriented_noise(s, cap, inner, inner);
    }
    // Hard cells: the rim ring only (cells inside the region within two cells of its edge).
    const Primitive edge = region_primitive(r, g, 0);
    const double ring = 2.0 * std::max(g.cell_x, g.cell_y);
    for (size_t i : region_cells(r, g)) {
      const double px = double(i % size_t(g.width)) * g.cell_x, py = double(i / size_t(g.width)) * g.cell_y;
      if (distance_to_edge(edge, px, py) <= ring) s.set_hard(i, float(top));
    }
    s.changed();
  };
}

}  // namespace

void add_composite_ops(std::vector<OpSpec>& ops) {
  ops.push_back({"mesa", "a plateau of fixed elevation with a steep rim and downslope-oriented noise", parse_mesa});
}

}  // namespace terracl::edit
