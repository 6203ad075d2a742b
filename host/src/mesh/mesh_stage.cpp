// SPDX-License-Identifier: Apache-2.0
// The `mesh` stage: a triangle mesh of the heightfield (full grid, greedy or RTIN simplification)
// written as .glb/.gltf/.obj; the heightfield passes through.
#include <terracl/mesh.hpp>

#include "pipeline/builtin.hpp"

namespace terracl {

namespace {

void run_mesh(StageContext& c) {
  const Heightfield& h = c.height();
  mesh::Mesh m;
  if (!c.has("max_error"))
    m = mesh::triangulate_full(h);
  else if (c.get<std::string>("simplifier") == "rtin")
    m = mesh::triangulate_rtin(h, c.get<double>("max_error"), c.progress);
  else  // greedy; falls back to the RTIN where the grid has nodata
    m = mesh::triangulate_simplified(h, c.get<double>("max_error"), c.progress);
  mesh::write_mesh(m, c.get<std::string>("file"), c.provenance, &h);
}

}  // namespace

StageInfo mesh_stage_info() {
  return {"mesh",
         "Export a triangle mesh in metres (.glb, .gltf or .obj) with texture coordinates and its map placement "
         "(glTF node extras and a <file>.json sidecar), optionally simplified within a vertical error; passes the "
         "heightfield through.",
         DataKind::Heightfield,
         DataKind::Heightfield,
         {{"file", OptionType::OutputPath, nullptr, "", "Mesh file (.glb, .gltf or .obj)", {}, true},
          {"max_error",
           OptionType::Float,
           nullptr,
           "m",
           "Simplify so that no cell is further than this from the mesh (default: full grid)",
           {},
           false},
          {"simplifier",
           OptionType::Enum,
           "greedy",
           "",
           "greedy: Delaunay greedy insertion, fewest vertices (the RTIN where the grid has nodata); rtin: "
           "right-triangulated irregular network",
           {"greedy", "rtin"},
           false}},
         run_mesh,
         false};
}

}  // namespace terracl
