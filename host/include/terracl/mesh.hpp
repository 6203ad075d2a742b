// SPDX-License-Identifier: Apache-2.0
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
  /// u, v per vertex (glTF TEXCOORD_0, v down): u = (column + 0.5) / width, v = (row + 0.5) / height,
  /// so a picture of the raster at its own size (terracl render) drapes pixel on cell.
  std::vector<float> texcoords;
  /// A PNG to drape over the mesh by its texcoords (glTF: the material's base colour texture,
  /// embedded); empty: a plain rough material.
  std::vector<unsigned char> texture_png;
  size_t vertex_count() const { return positions.size() / 3; }
  size_t triangle_count() const { return indices.size() / 3; }
};

/// Two triangles per grid cell whose four corners are valid (nodata cells leave holes).
Mesh triangulate_full(const Heightfield& h);

/// Simplified so that no grid cell centre lies more than `max_error_m` vertically from the mesh:
/// greedy insertion (triangulate_greedy) when the grid has no nodata, the RTIN otherwise.
Mesh triangulate_simplified(const Heightfield& h, double max_error_m, const Progress& progress = {});

/// Right-triangulated irregular network (the RTIN hierarchy of Evans, Kirkpatrick & Townsend 2001,
/// as in Mapbox's Martini) within `max_error_m`. Crack-free; nodata cells and the area beyond the
/// grid are left out.
Mesh triangulate_rtin(const Heightfield& h, double max_error_m, const Progress& progress = {});

/// Greedy insertion into a Delaunay triangulation (Garland & Heckbert 1995): the grid point
/// furthest from the mesh is inserted until none is further than `max_error_m` (checked on every
/// cell centre). Needs a grid without nodata. Keeps far fewer vertices than the RTIN.
Mesh triangulate_greedy(const Heightfield& h, double max_error_m, const Progress& progress = {});

/// The mesh's place on the map, as JSON text: CRS (WKT and EPSG code when it has one), the map
/// coordinates of the vertex at X = Z = 0 (the north-west cell centre), metric and CRS cell sizes,
/// Z scale (1: metres), axes and the texture-coordinate convention. Written as the glTF node's
/// `extras` and as the sidecar `<mesh>.json`.
std::string placement_json(const Heightfield& h);

/// Engine import settings for a 16-bit heightmap (PNG16/RAW16) of `h` whose codes 0..65535 span
/// [zmin, zmax] m, as JSON text: Unreal Landscape scale (X/Y = cell size in cm; Z in % =
/// (zmax - zmin) * 100 * 128 / 65535, since Z scale 100 spans 512 m) and location Z (cm) that put
/// every code back at its elevation; Unity terrain size (m); whether the cells are square (engines
/// assume they are; geographic DEMs' are not). Written into the heightmap's sidecar.
std::string heightmap_import_json(const Heightfield& h, double zmin, double zmax);
/// The same as one or two lines for the terminal; the second is a warning when cells are not square.
std::string heightmap_import_summary(const Heightfield& h, double zmin, double zmax);

/// Writes .glb (binary glTF 2.0), .gltf (JSON with the buffer embedded) or .obj, atomically.
/// With `grid` (the heightfield the mesh was made of) its placement_json goes into the glTF
/// node's extras and into the sidecar `<path>.json` (all formats).
void write_mesh(const Mesh& m, const std::string& path, const Metadata& meta = {}, const Heightfield* grid = nullptr);

}  // namespace terracl::mesh
