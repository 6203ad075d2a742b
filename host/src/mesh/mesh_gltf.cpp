// SPDX-License-Identifier: Apache-2.0
#include "mesh/mesh_gltf.hpp"

#include "io/checked_output.hpp"

#include <terracl/error.hpp>
#include <terracl/io.hpp>

#include <tiny_gltf.h>

#include <cstring>
#include <nlohmann/json.hpp>

namespace terracl::mesh {

namespace {

tinygltf::Value to_value(const nlohmann::json& j) {
  if (j.is_object()) {
    tinygltf::Value::Object o;
    for (auto it = j.begin(); it != j.end(); ++it) o[it.key()] = to_value(it.value());
    return tinygltf::Value(std::move(o));
  }
  if (j.is_array()) {
    tinygltf::Value::Array a;
    for (const auto& v : j) a.push_back(to_value(v));
    return tinygltf::Value(std::move(a));
  }
  if (j.is_string()) return tinygltf::Value(j.get<std::string>());
  if (j.is_boolean()) return tinygltf::Value(j.get<bool>());
  if (j.is_number_integer()) return tinygltf::Value(j.get<int>());
  if (j.is_number()) return tinygltf::Value(j.get<double>());
  return tinygltf::Value();  // null
}

}  // namespace

void write_gltf(const Mesh& m, const std::string& path, bool binary, const Metadata& meta, const std::string& placement) {
  tinygltf::Model model;
  tinygltf::Buffer buffer;
  const size_t pos_bytes = m.positions.size() * sizeof(float), idx_bytes = m.indices.size() * sizeof(uint32_t);
  const std::vector<float> normals = vertex_normals(m);
  const bool uv = m.texcoords.size() == 2 * m.vertex_count();
  const size_t uv_bytes = uv ? m.texcoords.size() * sizeof(float) : 0;
  const bool textured = uv && !m.texture_png.empty();
  const size_t tex_offset = 2 * pos_bytes + idx_bytes + uv_bytes;
  buffer.data.resize(tex_offset + (textured ? m.texture_png.size() : 0));
  if (textured) std::memcpy(buffer.data.data() + tex_offset, m.texture_png.data(), m.texture_png.size());
  std::memcpy(buffer.data.data(), m.positions.data(), pos_bytes);
  std::memcpy(buffer.data.data() + pos_bytes, m.indices.data(), idx_bytes);
  std::memcpy(buffer.data.data() + pos_bytes + idx_bytes, normals.data(), pos_bytes);
  if (uv) std::memcpy(buffer.data.data() + 2 * pos_bytes + idx_bytes, m.texcoords.data(), uv_bytes);
  model.buffers.push_back(std::move(buffer));

  tinygltf::BufferView pos_view;
  pos_view.buffer = 0;
  pos_view.byteOffset = 0;
  pos_view.byteLength = pos_bytes;
  pos_view.target = TINYGLTF_TARGET_ARRAY_BUFFER;
  tinygltf::BufferView idx_view;
  idx_view.buffer = 0;
  idx_view.byteOffset = pos_bytes;
  idx_view.byteLength = idx_bytes;
  idx_view.target = TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER;
  tinygltf::BufferView nrm_view = pos_view;
  nrm_view.byteOffset = pos_bytes + idx_bytes;
  tinygltf::BufferView uv_view = pos_view;
  uv_view.byteOffset = 2 * pos_bytes + idx_bytes;
  uv_view.byteLength = uv_bytes;
  model.bufferViews = {pos_view, idx_view, nrm_view};
  if (uv) model.bufferViews.push_back(uv_view);
  if (textured) {
    tinygltf::BufferView img_view;
    img_view.buffer = 0;
    img_view.byteOffset = tex_offset;
    img_view.byteLength = m.texture_png.size();
    model.bufferViews.push_back(img_view);
  }

  tinygltf::Accessor pos;
  pos.bufferView = 0;
  pos.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
  pos.count = m.vertex_count();
  pos.type = TINYGLTF_TYPE_VEC3;
  pos.minValues = {INFINITY, INFINITY, INFINITY};
  pos.maxValues = {-INFINITY, -INFINITY, -INFINITY};
  for (size_t v = 0; v < m.vertex_count(); ++v)
    for (int c = 0; c < 3; ++c) {
      pos.minValues[c] = std::min(pos.minValues[c], double(m.positions[3 * v + c]));
      pos.maxValues[c] = std::max(pos.maxValues[c], double(m.positions[3 * v + c]));
    }
  tinygltf::Accessor idx;
  idx.bufferView = 1;
  idx.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
  idx.count = m.indices.size();
  idx.type = TINYGLTF_TYPE_SCALAR;
  tinygltf::Accessor nrm;
  nrm.bufferView = 2;
  nrm.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
  nrm.count = m.vertex_count();
  nrm.type = TINYGLTF_TYPE_VEC3;
  model.accessors = {pos, idx, nrm};
  if (uv) {
    tinygltf::Accessor tex;
    tex.bufferView = 3;
    tex.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
    tex.count = m.vertex_count();
    tex.type = TINYGLTF_TYPE_VEC2;
    model.accessors.push_back(tex);
  }

  tinygltf::Primitive prim;
  prim.attributes["POSITION"] = 0;
  prim.attributes["NORMAL"] = 2;
  if (uv) prim.attributes["TEXCOORD_0"] = 3;
  prim.indices = 1;
  prim.mode = TINYGLTF_MODE_TRIANGLES;
  // A material: ground is rough and not metallic (glTF's default material is half-metallic, which
  // renders terrain as grey plastic); with a texture, its colours draped by the texcoords.
  tinygltf::Material mat;
  mat.name = "terrain";
  mat.pbrMetallicRoughness.metallicFactor = 0.0;
  mat.pbrMetallicRoughness.roughnessFactor = 1.0;
  mat.doubleSided = false;
  if (textured) {
    tinygltf::Image img;
    img.name = "terrain";
    img.mimeType = "image/png";
    img.bufferView = int(model.bufferViews.size()) - 1;
    model.images.push_back(img);
    tinygltf::Sampler smp;
    smp.magFilter = TINYGLTF_TEXTURE_FILTER_LINEAR;
    smp.minFilter = TINYGLTF_TEXTURE_FILTER_LINEAR_MIPMAP_LINEAR;
    smp.wrapS = smp.wrapT = TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE;
    model.samplers.push_back(smp);
    tinygltf::Texture tex;
    tex.source = 0;
    tex.sampler = 0;
    model.textures.push_back(tex);
    mat.pbrMetallicRoughness.baseColorTexture.index = 0;
  } else {
    mat.pbrMetallicRoughness.baseColorFactor = {0.55, 0.50, 0.42, 1.0};
  }
  model.materials.push_back(mat);
  prim.material = 0;
  tinygltf::Mesh mesh;
  mesh.name = "terrain";
  mesh.primitives.push_back(prim);
  model.meshes.push_back(mesh);
  tinygltf::Node node;
  node.mesh = 0;
  node.name = "terrain";
  // The map placement on the node (glTF's place for application data; Blender's importer keeps
  // node extras as custom properties of the object).
  if (!placement.empty()) node.extras = to_value(nlohmann::json::parse(placement));
  model.nodes.push_back(node);
  tinygltf::Scene scene;
  scene.nodes.push_back(0);
  model.scenes.push_back(scene);
  model.defaultScene = 0;
  model.asset.version = "2.0";
  model.asset.generator = "terracl";
  if (!meta.empty()) {  // provenance in asset.extras (glTF's place for application data)
    tinygltf::Value::Object extras;
    for (const auto& [k, v] : meta) extras[k] = tinygltf::Value(v);
    model.asset.extras = tinygltf::Value(extras);
  }

  write_atomically(path, [&](const std::string& tmp) {
    // Through a checked stream: tinygltf's own file writer does not see a failed flush or close
    // (a full disk gave a truncated .glb and exit 0).
    tinygltf::TinyGLTF writer;
    io::CheckedFileStream out(tmp);
    const bool ok = writer.WriteGltfSceneToStream(&model, out.stream(), !binary, binary);
    out.finish();  // a write error is named first: it is why tinygltf stopped
    if (!ok) fail("mesh", "tinygltf could not write {}", path);
  });
}

}  // namespace terracl::mesh
