// SPDX-License-Identifier: Apache-2.0
#pragma once
// glTF output through tinygltf, apart from the triangulation so that the core build
// (TERRACL_CORE_ONLY) keeps meshes and .obj without tinygltf.
#include <terracl/mesh.hpp>

#include <string>
#include <vector>

namespace terracl::mesh {
/// Unit vertex normals: area-weighted sums of the adjacent faces' normals (mesh.cpp).
std::vector<float> vertex_normals(const Mesh& m);
/// Writes .glb (binary) or .gltf (JSON, buffer embedded) atomically; `placement` (JSON text from
/// placement_json, may be empty) becomes the terrain node's extras.
void write_gltf(const Mesh& m, const std::string& path, bool binary, const Metadata& meta,
                const std::string& placement = {});
}  // namespace terracl::mesh
