// SPDX-License-Identifier: Apache-2.0
#pragma once
// Real detail for sketched landforms (docs/authoring.md, "Detail and styles"): the relief finer
// than 4 cells in a stroke's footprint is replaced by sparse-dictionary detail (terracl/amplify.hpp)
// drawn for the new shape, so a new ridge carries the texture of real terrain instead of a fractal's.
// The dictionary comes from a style: one of the bundled exemplars cut from the repo's real DEMs
// (data/styles/, embedded in the library), the base DEM itself ("local"), or a painted `style`
// region (ops_style.cpp), blended per cell where regions overlap.
#include "authoring/landform.hpp"

#include <terracl/amplify.hpp>  // Dictionary

#include <functional>
#include <string>
#include <vector>

namespace terracl::edit {

/// How a stroke gets its fine detail: `style` is "auto" (a painted style where there is one, else
/// "local" on a real base and the tool's `fallback` style on a flat one), "procedural" (the
/// landform's own fractal detail only), a bundled style name, or "local".
struct DetailSpec {
  std::string style = "auto";
  std::string fallback = "alpine";
  double strength = 1;  ///< scales the dictionary's calibrated detail gain
};

/// The bundled styles, in documentation order (alpine, eroded_hills, dissected_plateau).
const std::vector<std::string>& bundled_styles();
/// Whether `name` is a style a stroke or a `style` region can name (bundled or "local").
bool is_style_name(const std::string& name);

/// Reads `detail` ("auto" | "procedural" | a style) and `detail_strength` [0..3] from an operation.
DetailSpec parse_detail(Params& p, const std::string& fallback);

/// Replaces the relief finer than the dictionaries' factor (4 cells) in the footprint of `change`
/// (metres, the signed change a landform adds; 0 outside its footprint) by dictionary detail drawn
/// for the terrain the change makes, blended in where the change is a tenth of its peak or more.
/// Cells where `change` is 0 stay 0. Deterministic for a seed. Returns false and leaves `change`
/// alone when nothing was added (style "procedural", previews, a footprint smaller than a patch, or
/// the core build, which has no dictionaries). With `keep`, the detail fades out within 3 cells of
/// that polyline (metres), so a line drawn with a height keeps it exactly.
bool add_real_detail(EditState& s, ShapeRaster& change, const DetailSpec& d, uint32_t seed,
                     const std::vector<Vec2>* keep = nullptr);

/// Learns `style`'s dictionary ahead of the first stroke (the studio's background warm-up): a
/// bundled style, or "local" for the windows of `base` a stroke can use, the nearest to its centre
/// first, at most kLocalWarmWindows of them; `stop` (may be empty) is asked before each. Returns
/// how many dictionaries are ready (cached ones count).
size_t warm_style(const std::string& style, const Heightfield* base, const std::function<bool()>& stop = {});
/// A bundled style's dictionary (`terracl amplify --dictionary style:NAME`): learned from its
/// embedded exemplar on first use (~0.2 s), then cached for the process. Throws, listing the
/// bundled styles, for any other name.
Dictionary bundled_style_dictionary(const std::string& name);
/// The most local-style windows warm_style learns ahead (about 4 MB each).
constexpr size_t kLocalWarmWindows = 24;

/// The `style` operation's work: records a painted style region (`weight` over its box, 1 inside)
/// for later strokes and, with `retexture`, replaces the relief finer than 4 cells of the terrain
/// under it with the style's detail (block means kept). Returns the change to add (empty box when
/// none).
ShapeRaster paint_style(EditState& s, const std::string& style, const HostRegion& weight, bool retexture, double strength,
                        uint32_t seed);

}  // namespace terracl::edit
