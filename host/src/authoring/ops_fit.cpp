// SPDX-License-Identifier: Apache-2.0
// fit (paper section 5.1, figures 10 and 11): contours with elevations and ridge / river polylines
// become elevation constraints on a blank (null-Laplacian) gradient, with optional noise whose
// gradients are dragged along the features (so its gullies run perpendicular to the ridges) and
// whose amplitude fades with the distance to the nearest ridge or river.
// regularize (section 3): reconstruct, re-extract, drop the hard constraints; lowers the curl.
#include "authoring/state.hpp"

#include <terracl/error.hpp>
#include <terracl/json_limits.hpp>
#include <terracl/gradient.hpp>
#include <terracl/noise.hpp>

#include <fmt/format.h>

#include <filesystem>
#include <fstream>

namespace terracl::edit {
namespace {

struct Features {
  std::vector<std::vector<Vec3>> contours, ridges, rivers;
  std::vector<Vec3> points;  // peaks and basins of a sketch file
};

// {"contours": [{"points": [[x, y], ...], "elevation": z, "closed": false}],
//  "ridges": [{"points": [[x, y, z], ...]}], "rivers": [...]}; `p` may have other keys.
void read_features(Params& p, Features& f, bool strict = true) {
  auto list = [&](const std::string& key, std::vector<std::vector<Vec3>>& out, bool contour) {
    if (!p.has(key)) return;
    const json& arr = p.raw(key);
    if (!arr.is_array()) param_error(p.where(key), "expected an array of polylines");
    for (size_t i = 0; i < arr.size(); ++i) {
      Params q(arr[i], p.where(key) + "/" + std::to_string(i), p.grid());
      std::vector<Vec3> pts = q.points("points", contour ? 2 : 2);
      if (contour) {
        const double z = q.vlength("elevation");
        for (auto& v : pts) {
          if (!std::isnan(v.z)) param_error(q.where("points"), "contour points are [x, y]; the elevation is \"elevation\"");
          v.z = z;
        }
        if (q.boolean("closed", false)) pts.push_back(pts.front());
      } else {
        const bool has_elev = q.has("elevation");
        for (size_t k = 0; k < pts.size(); ++k) {
          if (std::isnan(pts[k].z) && !has_elev)
            param_error(q.where("points") + "/" + std::to_string(k), "needs an elevation: [x, y, z], or give \"elevation\"");
        }
        if (has_elev) {
          const double z = q.vlength("elevation");
          for (auto& v : pts)
            if (std::isnan(v.z)) v.z = z;
        }
      }
      if (strict) q.done();
      out.push_back(std::move(pts));
    }
  };
  list("contours", f.contours, true);
  list("ridges", f.ridges, false);
  list("rivers", f.rivers, false);
}

Operation parse_fit(Params& p) {
  Features f;
  if (p.has("file")) {
    const std::string given = p.string("file");
    const std::string path = operation_file(p, "file");
    std::ifstream in(path);
    if (!in) param_error(p.where("file"), fmt::format("cannot open '{}'", given));
    json doc;
    try {
      doc = read_json_file(path, "edit");  // depth and size limits (terracl/json_limits.hpp)
    } catch (const Error& e) {
      param_error(p.where("file"), fmt::format("'{}': {}", given, std::string(e.what()).substr(6)));
    }
    // The analysis module's `terracl sketch --json` files (format "terracl-sketch") give pixel
    // coordinates of their own grid: scale them onto ours; their extra keys are ignored.
    const bool sketch = doc.is_object() && doc.value("format", std::string()) == "terracl-sketch";
    Grid fg = p.grid();
    if (sketch) {
      fg.map = false;  // a sketch file has its own pixel coordinates
      const Grid& g = p.grid();
      const int sw = doc.value("width", g.width), sh = doc.value("height", g.height);
      fg.unit = g.cell_x * (sw > 1 ? double(g.width - 1) / (sw - 1) : 1.0);
      fg.unit_y = g.cell_y * (sh > 1 ? double(g.height - 1) / (sh - 1) : 1.0);
    }
    Params fp(doc, path + ":", fg);
    read_features(fp, f, !sketch);
    if (sketch) {
      for (const char* key : {"peaks", "basins"}) {
        if (!doc.contains(key) || !doc[key].is_array()) continue;
        for (size_t i = 0; i < doc[key].size(); ++i) {
          const json& pk = doc[key][i];
          const std::string w = path + ":/" + key + "/" + std::to_string(i);
          if (!pk.is_object() || !pk.contains("x") || !pk.contains("y") || !pk.contains("z") || !pk["x"].is_number() ||
              !pk["y"].is_number() || !pk["z"].is_number())
            param_error(w, "expected {\"x\": .., \"y\": .., \"z\": ..}");
          f.points.push_back({pk["x"].get<double>() * fg.unit, pk["y"].get<double>() * fg.unit_y, pk["z"].get<double>()});
        }
      }
    }
  }
  read_features(p, f);
  if (f.contours.empty() && f.ridges.empty() && f.rivers.empty() && f.points.empty())
    param_error(p.path(), "needs at least one of contours, ridges, rivers (inline or in \"file\")");
  const bool clear = p.boolean("clear", true);
  const double width = p.hlength("width", 0.0);
  bool noise = false;
  NoiseParams np;
  double fade = 0, strength = 0.8;
  if (p.has("noise")) {
    Params q = p.child("noise");
    fade = q.hlength("fade", {}, 0, true);
    strength = q.number("orient_strength", 0.8, 0.0, 1.0);
    np = parse_noise_block(q, {}, fade / 4, "fbm");
    noise = true;
    if (f.ridges.empty() && f.rivers.empty()) param_error(p.where("noise"), "fades with the distance to ridges/rivers: give some");
  }
  return [=](EditState& s) {
    Device& d = s.device();
    GradientBuffers& b = s.buffers();
    if (clear) {
      d.fill(b.gx, 0.0f, 0, b.cells());
      d.fill(b.gy, 0.0f, 0, b.cells());
    }
    if (noise) {
      std::vector<Primitive> feats;
      for (const auto* set : {&f.ridges, &f.rivers})
        for (const auto& pl : *set) {
          Primitive pr;
          pr.shape = PrimitiveShape::Polyline;
          pr.points = xy(pl);
          pr.radius = fade;
          pr.tensor = TensorKind::Tangent;
          pr.strength = strength;
          feats.push_back(pr);
        }
      const Box box = primitives_box(feats, b.width, b.height, b.cell_x, b.cell_y);
      d.fill(b.mask, 0.0f, 0, b.cells());
      primitive_weight(d, b, feats, box, false);
      b.clear_scratch(d, box);
      noise_gradient(d, b, np, box, true, true);
      // Several overlapping features would sum their tensors; the strongest is enough here.
      add_tensor_field_of_scratch(d, b, feats, box);
      b.clear_scratch(d, box);
    }
    for (const auto* set : {&f.contours, &f.ridges, &f.rivers})
      for (const auto& pl : *set) rasterize_polyline(s, pl, width);
    for (const auto& pt : f.points) rasterize_polyline(s, {pt, pt}, width);
    s.log().back()["features"] = {{"contours", f.contours.size()}, {"ridges", f.ridges.size()},
                                  {"rivers", f.rivers.size()}, {"points", f.points.size()}};
    s.changed();
  };
}

Operation parse_regularize(Params&) {
  return [](EditState& s) {
    const double before = curl_rms(s.download());
    const Heightfield h = s.solve();
    GradientField g = extract_gradient(s.device(), h);
    const double after = curl_rms(g);
    double mean = 0;
    for (float v : h.z) mean += v;
    mean /= double(h.size());
    s.upload(g);
    const size_t dropped = s.hard_count();
    s.clear_hard();
    s.set_mean(mean);
    s.mark_fresh();  // the solution is the field's own reconstruction now
    s.rebase();      // and the base of later local solves (the whole field changed by rounding)
    s.log().back()["curl_rms_before"] = before;
    s.log().back()["curl_rms_after"] = after;
    s.log().back()["dropped_constraints"] = dropped;
  };
}

}  // namespace

void add_fit_ops(std::vector<OpSpec>& ops) {
  ops.push_back({"fit", "contours, ridges and rivers become constraints; optional noise along the features", parse_fit});
  ops.push_back({"regularize", "reconstruct, re-extract the gradient, drop the hard constraints (lowers the curl)",
                 parse_regularize});
}

}  // namespace terracl::edit
