// SPDX-License-Identifier: Apache-2.0
#pragma once
// Each stage module exposes one registration function; builtin_stages.cpp calls them all.
// Add yours here and in builtin_stages.cpp (one line each).
#include <terracl/stage.hpp>

namespace terracl {
void register_io_stages(StageRegistry& r);       // host/src/pipeline/io_stages.cpp (read, write, crop)
void register_core_stages(StageRegistry& r);     // host/src/core/core_stages.cpp
void register_core_benches(BenchRegistry& r);    // host/src/core/core_stages.cpp
void register_reconstruct_stages(StageRegistry& r);   // host/src/reconstruct/reconstruct_stages.cpp
void register_reconstruct_benches(BenchRegistry& r);  // host/src/reconstruct/reconstruct_stages.cpp
void register_edit_stages(StageRegistry& r);   // host/src/authoring/edit_stage.cpp
void register_edit_benches(BenchRegistry& r);  // host/src/authoring/edit_stage.cpp
void register_amplify_stages(StageRegistry& r);  // host/src/amplify/amplify_stage.cpp
void register_amplify_benches(BenchRegistry& r);  // host/src/amplify/amplify_stage.cpp
void register_analysis_stages(StageRegistry& r); // host/src/analysis/analysis_stages.cpp
void register_analysis_benches(BenchRegistry& r); // host/src/analysis/analysis_stages.cpp
StageInfo render_stage_info();                 // host/src/render/render_stage.cpp
StageInfo mesh_stage_info();                   // host/src/mesh/mesh_stage.cpp
namespace render { struct Options; }
render::Options render_stage_options(const StageContext& c);  // host/src/render/render_stage.cpp
void register_render_benches(BenchRegistry& r);  // host/src/render/render_stage.cpp
int erode_tile_halo(const json& options, const Georef& level);  // host/src/erosion/erosion_stage.cpp (tiled runs)
void register_erosion_stages(StageRegistry& r); void register_erosion_benches(BenchRegistry& r);  // host/src/erosion/erosion_stage.cpp
}  // namespace terracl
