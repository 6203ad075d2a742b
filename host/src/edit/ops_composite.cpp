// Composite brushes (paper figure 8): mountain_range (gradient profile + downslope-oriented noise)
// and mesa (plateau elevation constraints + a rim drop + downslope-oriented noise). "Downslope
// oriented" = the noise's gradients are dragged across the slope by a tensor aligned with the
// stroke (or with the rim), so its crests and gullies run down the flanks.
#include "edit/state.hpp"

#include <terracl/error.hpp>
#include <terracl/noise.hpp>

#include <fmt/format.h>

namespace terracl::edit {
namespace {

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
  b.clear_scratch(d, box);
  noise_gradient(d, b, o.noise, box, true, true);
  orient.strength = o.strength;
  add_tensor_field_of_scratch(d, b, {orient}, box);
  b.clear_scratch(d, box);
}

Operation parse_mountain_range(Params& p) {
  const auto pts = p.points("points", 2);
  const double radius = p.hlength("radius", {}, 0, true);
  size_t with_z = 0;
  for (const auto& v : pts) with_z += std::isnan(v.z) ? 0 : 1;
  if (with_z != 0 && with_z != pts.size()) param_error(p.where("points"), "give z for every point or for none");
  Primitive ridge;
  ridge.shape = PrimitiveShape::Polyline;
  ridge.points = xy(pts);
  ridge.radius = radius;
  ridge.profile = p.choice("profile", "round", {"round", "sharp"}) == "round" ? Profile::Round : Profile::Sharp;
  double height = 0;
  if (with_z) {
    for (const auto& v : pts) ridge.amplitude.push_back(v.z), height = std::max(height, v.z);
    ridge.profile_amplitude = 1;
    if (p.has("height")) param_error(p.where("height"), "the points already carry heights [x, y, z]");
  } else {
    height = p.vlength("height");
    ridge.profile_amplitude = height;
  }
  const OrientedNoise noise = parse_oriented_noise(p, 0.12 * std::abs(height), radius / 4);
  return [=](EditState& s) {
    add_profile_gradient(s.device(), s.buffers(), {ridge});
    Primitive orient = ridge;
    orient.tensor = TensorKind::Tangent;
    add_oriented_noise(s, noise, ridge, orient);
    s.changed();
  };
}

Operation parse_mesa(Params& p) {
  const Region r = parse_region(p, false);
  const double top = p.vlength("elevation");
  const double height = p.vlength("height");
  if (!(height > 0)) param_error(p.where("height"), fmt::format("expected a drop > 0 m, got {}", height));
  const double radius = p.hlength("radius", {}, 0, true);
  const OrientedNoise noise = parse_oriented_noise(p, 0.08 * height, radius / 2);
  return [=](EditState& s) {
    Primitive rim = region_primitive(r, s.grid(), radius);
    rim.profile = Profile::Drop;
    rim.profile_amplitude = height;
    add_profile_gradient(s.device(), s.buffers(), {rim});
    Primitive orient = rim;
    orient.tensor = TensorKind::Closest;
    orient.angle = M_PI / 2;  // drag gradients across u(p): gullies run towards the rim
    add_oriented_noise(s, noise, rim, orient);
    for (size_t i : region_cells(r, s.grid())) s.set_hard(i, float(top));
    s.changed();
  };
}

}  // namespace

void add_composite_ops(std::vector<OpSpec>& ops) {
  ops.push_back({"mountain_range", "one stroke: a ridge profile plus downslope-oriented ridged noise", parse_mountain_range});
  ops.push_back({"mesa", "a plateau of fixed elevation with a steep rim and downslope-oriented noise", parse_mesa});
}

}  // namespace terracl::edit
