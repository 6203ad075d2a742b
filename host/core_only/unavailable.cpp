// SPDX-License-Identifier: Apache-2.0
// The core build (TERRACL_CORE_ONLY, cmake/CoreOnly.cmake) leaves out every source that needs a
// GIS, image, mesh or nearest-neighbour library. These definitions stand in for their entry
// points so that everything else links unchanged; each says what is missing instead of crashing.
// RAW16 (.r16/.raw, host/src/io/raw16.cpp) stays available.
#include "authoring/state.hpp"
#include "authoring/landform_detail.hpp"
#include "reconstruct/hypre_solve.hpp"
#include "io/io_common.hpp"
#include "mesh/mesh_gltf.hpp"
#include "pipeline/builtin.hpp"
#include "render/render_internal.hpp"
#include "tile/amplify_tiles.hpp"

#include <terracl/analysis.hpp>
#include <terracl/edit.hpp>
#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/render.hpp>
#include <terracl/tile.hpp>
#include <terracl/warp.hpp>

namespace terracl {
namespace {

[[noreturn]] void unavailable(const std::string& what, const std::string& path) {
  fail("io", "{}: {} is not available in the core build (TERRACL_CORE_ONLY); use .r16/.raw rasters "
       "or the full build", path, what);
}

}  // namespace

std::string stored_band_type(const std::string&) { return {}; }
bool analysis::is_sketch_vector_path(const std::string&) { return false; }
std::vector<std::array<double, 2>> analysis::read_pour_points(const std::string& path, const Georef&) {
  unavailable("vector (OGR) reading", path);
}
void analysis::write_sketch_vectors(const analysis::Sketch&, const Heightfield&, const std::string& path) {
  unavailable("vector (OGR) writing", path);
}
namespace io {
Heightfield read_gdal(const std::string& path) { unavailable("GDAL reading", path); }
std::optional<std::pair<int64_t, int64_t>> raster_header_size(const std::string&) { return std::nullopt; }
void write_geotiff(const Heightfield&, const std::string& tmp_path, const WriteOptions&) { unavailable("GeoTIFF writing", tmp_path); }
std::string gdal_driver_for_output(const std::string& path, const std::string&) { unavailable("GDAL writing", path); }
std::vector<std::string> write_gdal_copy(const Heightfield&, const std::string& tmp_path, const std::string&,
                                         const WriteOptions&) {
  unavailable("GDAL writing", tmp_path);
}
Heightfield read_image(const std::string& path, const ReadOptions&) { unavailable("PNG/EXR reading", path); }
void write_png16(const Heightfield&, const std::string& tmp_path, double, double) {
  unavailable("PNG writing", tmp_path);
}
void write_exr(const Heightfield&, const std::string& tmp_path) { unavailable("EXR writing", tmp_path); }
GradientField read_gradient_rows(const std::string& path, int, int, int*) { unavailable("EXR gradient reading", path); }
}  // namespace io

Heightfield warp(const Heightfield&, const WarpOptions&, const Progress&, const std::string& stage) {
  fail(stage, "GDAL's warper is not available in the core build (TERRACL_CORE_ONLY); use the full build");
}

bool is_gradient_file(const std::string&) { return false; }
GradientField read_gradient(const std::string& path) { unavailable("EXR gradient reading", path); }
void write_gradient(const GradientField&, const std::string& path) { unavailable("EXR gradient writing", path); }
void write_gradient_image(const GradientField&, const std::string& path) { unavailable("gradient PNG writing", path); }
GradientField read_gradient_image(const std::string& path) { unavailable("gradient PNG reading", path); }

namespace render {
void write_image(const Image&, const std::string& path, const Metadata&) { unavailable("PNG preview writing", path); }
bool can_stream_render(const std::string&, const std::string&, const Options&) { return false; }
void render_file(const std::string& input, const std::string&, const Options&, Device*, const Metadata&, int) {
  unavailable("GDAL window reading", input);
}
void render_file(const std::string& input, const std::string&, const Options&, const std::function<Device*()>&,
                 const Metadata&, int) {
  unavailable("GDAL window reading", input);
}
}  // namespace render

namespace mesh {
void write_gltf(const Mesh&, const std::string& path, bool, const Metadata&, const std::string&) {
  unavailable("glTF writing (use .obj)", path);
}
}  // namespace mesh

// Tiled runs read and write GDAL windows.
namespace tile {
StageTiling amplify_tiling(const json&) {
  StageTiling t;
  t.limit = "amplify is not available in the core build (TERRACL_CORE_ONLY); use the full build";
  return t;
}
}  // namespace tile

void run_tiled(const Pipeline&, const TileOptions&, const RunOptions&, RunReport&, TileCounts*) {
  fail("run", "--tile: tiled runs read and write GeoTIFF windows through GDAL, which the core build "
       "(TERRACL_CORE_ONLY) leaves out; use the full build");
}

// Amplification needs FLANN: no stages, no benchmarks in the core build.
void register_amplify_stages(StageRegistry&) {}
void register_amplify_benches(BenchRegistry&) {}
// ... and no "amplify" edit operation (scripts using it get "unknown operation").
void edit::add_amplify_ops(std::vector<edit::OpSpec>&) {}

// hypre's band reader (reconstruct/hypre_bands.cpp reads GDAL windows; the core build has no hypre).
ReconstructResult reconstruct_hypre_files(const HypreBandFiles& f, const SolverOptions&) {
  unavailable("hypre's band reader", f.gradient.empty() ? f.divergence : f.gradient);
}
Heightfield read_heightfield_rows(const std::string& path, int, int, int*, int*) { unavailable("row reading", path); }

}  // namespace terracl

namespace terracl::edit {
// No dictionaries in the core build: strokes keep their procedural detail, and a painted style
// only records its region for them.
bool add_real_detail(EditState&, ShapeRaster&, const DetailSpec&, uint32_t, const std::vector<Vec2>*) { return false; }
ShapeRaster paint_style(EditState& s, const std::string& style, const HostRegion& weight, bool retexture, double, uint32_t) {
  s.add_style({style, weight});
  if (retexture) fail("edit", "style '{}': retexturing needs the sparse dictionaries, not available in the core build "
                      "(TERRACL_CORE_ONLY); set \"retexture\": false or use the full build", style);
  return {};
}
}  // namespace terracl::edit
