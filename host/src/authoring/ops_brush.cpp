// SPDX-License-Identifier: Apache-2.0
// Brushes: scale_slopes, noise, freeze, tensor (paper sections 4.1, 4.3, 4.4).
#include "authoring/state.hpp"

#include <terracl/error.hpp>
#include <terracl/noise.hpp>

#include <fmt/format.h>

namespace terracl::edit {
namespace {

Operation parse_scale_slopes(Params& p) {
  const Region r = parse_region(p, false);
  const double falloff = p.hlength("falloff", 0.0);
  const double factor = p.number("factor", {}, 0.0, 100.0);
  return [=](EditState& s) {
    Primitive pr = region_primitive(r, s.grid(), falloff);
    pr.tensor = TensorKind::Scale;
    pr.strength = factor - 1.0;
    apply_tensor_field(s.device(), s.buffers(), {pr});
    s.changed();
  };
}

// Shared by noise, mountain_range, mesa and fit: the noise block's parameters.
NoiseParams parse_noise_params(Params& p, std::optional<double> def_amp, std::optional<double> def_wavelength, const std::string& def_type) {
  NoiseParams n;
  n.type = parse_noise_type(p.choice("type", def_type, {"perlin", "fbm", "ridged"}));
  n.amplitude = p.vlength("amplitude", def_amp);
  n.wavelength = p.hlength("wavelength", def_wavelength, 0, true);
  n.octaves = p.integer("octaves", 4, 1, 16);
  n.lacunarity = p.number("lacunarity", 2.0, 1.0, 8.0);
  n.gain = p.number("gain", 0.5, 0.01, 1.0);
  n.seed = unsigned(p.integer("seed", int(p.grid().seed % 1000000007u), 0, 2147483647));
  return n;
}

Operation parse_noise(Params& p) {
  const Region r = parse_region(p, true);
  const NoiseParams n = parse_noise_params(p, {}, {}, "fbm");
  // A hard region edge would be a step of the noise's height (the exact gradient of w n): fade
  // over one wavelength unless told otherwise.
  const double falloff = p.hlength("falloff", n.wavelength);
  bool orient = false;
  double theta = 0, mu = 0;
  if (p.has("orient")) {
    Params o = p.child("orient");
    theta = grid_angle(o.angle("angle"));
    mu = o.number("strength", 0.8, 0.0, 1.0);
    o.done();
    orient = true;
  }
  return [=](EditState& s) {
    Device& d = s.device();
    GradientBuffers& b = s.buffers();
    const Primitive region = region_primitive(r, s.grid(), falloff);
    const bool masked = r.kind != Region::Everywhere;
    const Box box = masked ? primitives_box({region}, b.width, b.height, b.cell_x, b.cell_y) : full_box(b.width, b.height);
    if (masked) primitive_weight(d, b, {region}, box, false);
    if (!orient) {
      noise_gradient(d, b, n, box, masked, false);
    } else {
      b.clear_scratch(d, box);
      noise_gradient(d, b, n, box, masked, true);
      Primitive t = region;
      t.tensor = TensorKind::Directional;
      t.angle = theta;
      t.strength = mu;
      add_tensor_field_of_scratch(d, b, {t}, box);
      b.clear_scratch(d, box);
    }
    s.changed();
  };
}

Operation parse_freeze(Params& p) {
  const Region r = parse_region(p, true);
  return [=](EditState& s) {
    const Heightfield& h = s.height();
    const std::vector<size_t> cells = region_cells(r, s.grid());
    for (size_t i : cells) s.set_hard(i, h.z[i]);
    s.log().back()["frozen_cells"] = cells.size();
    s.changed();
  };
}

Primitive parse_tensor_primitive(Params& q) {
  Primitive pr;
  const std::string shape = q.choice("shape", {}, {"point", "segment", "polyline", "disc", "polygon"});
  if (shape == "point" || shape == "disc") {
    pr.shape = shape == "point" ? PrimitiveShape::Point : PrimitiveShape::Disc;
    pr.points = {q.point("center")};
    if (shape == "disc") pr.disc_radius = q.hlength("disc_radius", {}, 0, true);
  } else if (shape == "polygon") {
    pr.shape = PrimitiveShape::Polygon;
    pr.points = xy(q.points("points", 3));
  } else {
    pr.shape = PrimitiveShape::Polyline;
    pr.points = xy(q.points("points", 2));
    if (shape == "segment" && pr.points.size() != 2) param_error(q.where("points"), "a segment has exactly 2 points");
  }
  pr.radius = q.hlength("radius", {}, 0, true);
  const std::string kind = q.choice("tensor", "directional", {"directional", "scale", "tangent", "closest"});
  pr.tensor = kind == "directional" ? TensorKind::Directional
              : kind == "scale"     ? TensorKind::Scale
              : kind == "tangent"   ? TensorKind::Tangent
                                    : TensorKind::Closest;
  pr.strength = q.number("strength", kind == "scale" ? 0.0 : 0.8, kind == "scale" ? -1.0 : 0.0, kind == "scale" ? 100.0 : 1.0);
  pr.angle = grid_angle(q.angle("angle", 0.0));
  pr.aniso_ratio = q.number("anisotropy", 1.0, 0.01, 100.0);
  pr.aniso_angle = grid_angle(q.angle("anisotropy_angle", 0.0));
  q.done();
  return pr;
}

Operation parse_tensor(Params& p) {
  const json& arr = p.raw("primitives");
  if (!arr.is_array() || arr.empty()) param_error(p.where("primitives"), "expected a non-empty array of primitives");
  std::vector<Primitive> prims;
  for (size_t i = 0; i < arr.size(); ++i) {
    Params q(arr[i], p.where("primitives") + "/" + std::to_string(i), p.grid());
    prims.push_back(parse_tensor_primitive(q));
  }
  return [=](EditState& s) {
    apply_tensor_field(s.device(), s.buffers(), prims);
    s.changed();
  };
}

}  // namespace

NoiseParams parse_noise_block(Params& p, std::optional<double> def_amp, std::optional<double> def_wavelength,
                              const std::string& def_type) {
  NoiseParams n = parse_noise_params(p, def_amp, def_wavelength, def_type);
  p.done();
  return n;
}

void add_brush_ops(std::vector<OpSpec>& ops) {
  ops.push_back({"scale_slopes", "amplify or suppress slopes inside a disc or polygon, with a smooth falloff", parse_scale_slopes});
  ops.push_back({"noise", "add gradient noise (perlin, fbm, ridged) in a region, optionally oriented by a tensor", parse_noise});
  ops.push_back({"freeze", "turn a region into hard constraints at the current elevation", parse_freeze});
  ops.push_back({"tensor", "apply skeleton tensor primitives (directional, scale, tangent-, closest-aligned)", parse_tensor});
}

}  // namespace terracl::edit
