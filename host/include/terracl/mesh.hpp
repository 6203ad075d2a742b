#pragma once
/// Triangle meshes of heightfields for 3D tools (Blender, game engines), in metres.
/// Axes follow glTF (Y up, right-handed): X = column * cell_x (east), Y = elevation,
/// Z = row * cell_y (south); the north-west cell centre is at X = Z = 0.
#include <cstdint>
#include <string>
#include <terracl/heightfield.hpp>
#include <terracl/progress.hpp>
#include <vector>

namespace terracl::mesh {

/// An indexed triangle mesh in metres (axes as above).
struct Mesh {
  std::vector<float> positions;   ///< x, y, z per vertex
  std::vector<uint32_t> indices;  ///< three per triangle, counter-clockwise seen from above (+Y)
  size_t vertex_count() const { return positions.size() / 3; }
  size_t triangle_count() const { return indices.size() / 3; }
};

/// Two triangles per grid cell whose four corners are valid (nodata cells leave holes).
Mesh triangulate_full(const Heightfield& h);

/// Right-triangulated irregular network (the RTIN hierarchy of Evans, Kirkpatrick & Townsend 2001,
/// as in Mapbox's Martini) simplified so that no grid cell centre lies more than `max_error_m`
/// vertically from the mesh. Crack-free; nodata cells and the area beyond the grid are left out.
Mesh triangulate_simplified(const Heightfield& h, double max_error_m, const Progress& progress = {});

/// Writes .glb (binary glTF 2.0), .gltf (JSON with the buffer embedded) or .obj, atomically.
void write_mesh(const Mesh& m, const std::string& path, const Metadata& meta = {});

}  // namespace terracl::mesh
