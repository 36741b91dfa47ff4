// The GLB export of a model whose mesh came from a glTF file: the file itself, written back with the montage
// (io/model.h: exportGlbInto).
#include <algorithm>
#include <array>
#include <cstring>
#include <limits>
#include <map>
#include <set>

#include "base/util.h"
#include "image/color.h"
#include "io/gltf_document.h"
#include "io/model.h"

namespace montage {

namespace {

// The written file's one buffer, its views and its accessors.
struct Packer {
  std::vector<unsigned char> bin;
  std::vector<tinygltf::BufferView> views;
  std::vector<tinygltf::Accessor> accessors;

  int view(const unsigned char* data, size_t size, int target, size_t stride = 0) {
    return gltf::appendView(bin, views, data, size, target, stride);
  }

  // An accessor shaped like `like` (type, component type, normalised, name, extras) over `count` elements packed in
  // `bytes`. A vertex attribute keeps each element on a 4-byte boundary, as the format asks (a stride when an
  // element is not a multiple of 4 bytes). With `bounds`, min and max are measured over the elements.
  int accessor(const tinygltf::Accessor& like, const gltf::AccessorBytes& layout,
               const std::vector<unsigned char>& bytes, size_t count, int target, bool bounds) {
    const size_t element = layout.elementSize();
    tinygltf::Accessor a;
    a.name = like.name;
    a.type = like.type;
    a.componentType = like.componentType;
    a.normalized = like.normalized;
    a.extras = like.extras;
    a.count = count;
    const size_t stride = target == TINYGLTF_TARGET_ARRAY_BUFFER && element % 4 ? (element + 3) / 4 * 4 : 0;
    if (stride) {
      std::vector<unsigned char> padded(count * stride, 0);
      for (size_t i = 0; i < count; ++i) std::memcpy(&padded[i * stride], &bytes[i * element], element);
      a.bufferView = view(padded.data(), padded.size(), target, stride);
    } else {
      a.bufferView = view(bytes.data(), bytes.size(), target);
    }
    if (bounds && count > 0) {
      a.minValues.assign(layout.components, std::numeric_limits<double>::infinity());
      a.maxValues.assign(layout.components, -std::numeric_limits<double>::infinity());
      for (size_t i = 0; i < count; ++i)
        for (int c = 0; c < layout.components; ++c) {
          const double v =
              gltf::decodeComponent(&bytes[i * element + c * layout.componentSize], layout.componentType, false);
          a.minValues[c] = std::min(a.minValues[c], v);
          a.maxValues[c] = std::max(a.maxValues[c], v);
        }
    }
    accessors.push_back(a);
    return static_cast<int>(accessors.size()) - 1;
  }

  // An accessor of plain values: `count` elements of `components` components of `componentType` (4 bytes each).
  int plain(const void* data, size_t count, int type, int components, int componentType, int target) {
    tinygltf::Accessor like;
    like.type = type;
    like.componentType = componentType;
    gltf::AccessorBytes layout;
    layout.components = components;
    layout.componentSize = 4;
    layout.componentType = componentType;
    const auto* p = static_cast<const unsigned char*>(data);
    return accessor(like, layout, std::vector<unsigned char>(p, p + count * components * 4), count, target, false);
  }
};

// Leaves out the materials no primitive uses and the textures, images and samplers no material shows (a material's
// five texture slots), renumbering what stays; `newImages` (image index first) follows. Returns the images left out.
int dropUnused(tinygltf::Model& gm, std::vector<std::pair<int, const std::vector<unsigned char>*>>& newImages) {
  // Keeps the marked entries of `list` in order; returns old index -> new (-1 when left out).
  const auto compact = [](auto& list, const std::vector<char>& keep) {
    std::vector<int> map(list.size(), -1);
    size_t n = 0;
    for (size_t i = 0; i < list.size(); ++i)
      if (keep[i]) {
        map[i] = static_cast<int>(n);
        if (n != i) list[n] = std::move(list[i]);
        ++n;
      }
    list.resize(n);
    return map;
  };
  const auto inRange = [](int i, size_t n) { return i >= 0 && static_cast<size_t>(i) < n; };
  std::vector<char> usedMaterial(gm.materials.size(), 0);
  for (const auto& m : gm.meshes)
    for (const auto& p : m.primitives)
      if (inRange(p.material, usedMaterial.size())) usedMaterial[p.material] = 1;
  const std::vector<int> materialMap = compact(gm.materials, usedMaterial);
  for (auto& m : gm.meshes)
    for (auto& p : m.primitives)
      if (inRange(p.material, materialMap.size())) p.material = materialMap[p.material];

  const auto slots = [](tinygltf::Material& m) {
    return std::array<int*, 5>{&m.pbrMetallicRoughness.baseColorTexture.index,
                               &m.pbrMetallicRoughness.metallicRoughnessTexture.index, &m.normalTexture.index,
                               &m.occlusionTexture.index, &m.emissiveTexture.index};
  };
  std::vector<char> usedTexture(gm.textures.size(), 0);
  for (auto& m : gm.materials)
    for (int* t : slots(m))
      if (inRange(*t, usedTexture.size())) usedTexture[*t] = 1;
  const std::vector<int> textureMap = compact(gm.textures, usedTexture);
  for (auto& m : gm.materials)
    for (int* t : slots(m))
      if (inRange(*t, textureMap.size())) *t = textureMap[*t];

  std::vector<char> usedImage(gm.images.size(), 0), usedSampler(gm.samplers.size(), 0);
  for (const auto& t : gm.textures) {
    if (inRange(t.source, usedImage.size())) usedImage[t.source] = 1;
    if (inRange(t.sampler, usedSampler.size())) usedSampler[t.sampler] = 1;
  }
  const size_t images = gm.images.size();
  const std::vector<int> imageMap = compact(gm.images, usedImage), samplerMap = compact(gm.samplers, usedSampler);
  for (auto& t : gm.textures) {
    if (inRange(t.source, imageMap.size())) t.source = imageMap[t.source];
    if (inRange(t.sampler, samplerMap.size())) t.sampler = samplerMap[t.sampler];
  }
  for (auto& [image, png] : newImages) image = imageMap[image];
  return static_cast<int>(images - gm.images.size());
}

// Extensions that keep geometry outside the accessors this writer copies.
constexpr const char* kGeometryExtensions[] = {"KHR_draco_mesh_compression", "EXT_meshopt_compression",
                                               "EXT_mesh_gpu_instancing"};

}  // namespace

GltfWriteBack exportGlbInto(const TexturedModel& model, const std::string& source, const std::string& path,
                            PngCache* pngs) {
  TM_CHECK(model.textured(), located(path, "the model has no texture coordinates to write back"));
  tinygltf::Model gm = gltf::loadSourceDocument(source);
  for (const char* ext : kGeometryExtensions)
    TM_CHECK(std::find(gm.extensionsUsed.begin(), gm.extensionsUsed.end(), ext) == gm.extensionsUsed.end(),
             located(source, std::string("uses ") + ext + ": its geometry cannot be written back"));
  const gltf::Soup soup = gltf::readSoup(gm, source, false);

  // The model must be this file's mesh: its vertices and faces name the soup's.
  const Mesh& mesh = model.mesh;
  const int nv = mesh.numVertices(), nf = mesh.numFaces();
  const std::string changed = "is not the mesh the model was made from (did the file change during the run?)";
  TM_CHECK(mesh.vertexOrigin.size() == size_t(nv) && mesh.faceOrigin.size() == size_t(nf), located(source, changed));
  for (int v = 0; v < nv; ++v) {
    const int o = mesh.vertexOrigin[v];
    TM_CHECK(o >= 0 && o < static_cast<int>(soup.vertices.size()) && soup.vertices[o] == mesh.position(v),
             located(source, changed));
  }
  std::vector<int> faceOf(soup.triangles.size(), -1);
  for (int f = 0; f < nf; ++f) {
    const int t = mesh.faceOrigin[f];
    TM_CHECK(t >= 0 && t < static_cast<int>(faceOf.size()), located(source, changed));
    faceOf[t] = f;
  }
  // A triangle's corner j (the file's order): its texture coordinate in glTF's convention (v down), (0, 0) for a
  // triangle the mesh left out (a complex edge, a repeated vertex).
  const auto cornerUV = [&](int t, int j) -> Vec2f {
    const int f = faceOf[t];
    if (f < 0) return Vec2f::Zero();
    const auto fv = mesh.faceVertices(f);
    const int id = soup.triangleOrigin[t].vertices[j];
    int k = 0;
    while (k < 2 && mesh.vertexOrigin[fv[k]] != id) ++k;
    return Vec2f(model.uv[f][k].x(), 1.0f - model.uv[f][k].y());
  };
  const auto modelMaterial = [&](int t) {
    const int f = faceOf[t];
    return f < 0 ? -1 : model.faceMaterial.empty() ? 0 : model.faceMaterial[f];
  };

  GltfWriteBack out;
  PngCache localPngs;
  PngCache& cache = pngs ? *pngs : localPngs;
  Packer pack;
  const std::vector<tinygltf::Material> originalMaterials = gm.materials;
  const std::vector<tinygltf::Mesh> originalMeshes = gm.meshes;
  std::map<int, gltf::AccessorBytes> dense;  // source accessor -> its bytes, read once
  const auto bytesOf = [&](int accessor, const std::string& where) -> const gltf::AccessorBytes& {
    auto it = dense.find(accessor);
    if (it == dense.end()) it = dense.emplace(accessor, gltf::accessorBytes(gm, accessor, where)).first;
    return it->second;
  };

  // The montage's textures: one image per distinct texture, one sampler.
  int sampler = -1;
  std::map<const uchar*, int> textureOf;
  std::vector<std::pair<int, const std::vector<unsigned char>*>> newImages;  // image -> PNG bytes
  const auto textureFor = [&](const Material& mat) {
    if (const auto it = textureOf.find(mat.texture.data); it != textureOf.end()) return it->second;
    const int texture = gltf::addTexture(gm, mat, mat.name, -1, sampler);
    newImages.emplace_back(gm.textures[texture].source,
                           &cache.encode(mat.texture, path + ": texture " + gm.images.back().name));
    return textureOf[mat.texture.data] = texture;
  };
  // The material of a written primitive: the file's (`file`, -1 for none) showing the model's material `m` through
  // texture coordinate set `set`.
  std::map<std::tuple<int, int, int>, int> materialOf;
  const auto materialFor = [&](int file, int m, int set) {
    const auto key = std::make_tuple(file, m, set);
    if (const auto it = materialOf.find(key); it != materialOf.end()) return it->second;
    tinygltf::Material mat =
        file >= 0 && file < static_cast<int>(originalMaterials.size()) ? originalMaterials[file] : tinygltf::Material{};
    const Material* ours = m >= 0 && m < static_cast<int>(model.materials.size()) ? &model.materials[m] : nullptr;
    if (ours && !ours->name.empty()) mat.name = ours->name;
    auto& pbr = mat.pbrMetallicRoughness;
    const double alpha = pbr.baseColorFactor.size() == 4 ? pbr.baseColorFactor[3] : 1.0;
    pbr.baseColorTexture = tinygltf::TextureInfo{};
    if (ours && !ours->texture.empty()) {
      pbr.baseColorTexture.index = textureFor(*ours);
      pbr.baseColorTexture.texCoord = set;
      pbr.baseColorFactor = {1.0, 1.0, 1.0, alpha};
    } else {
      const Vec3f kd = ours ? ours->diffuse : Vec3f(0.7f, 0.7f, 0.7f);
      pbr.baseColorFactor = {srgbToLinear(kd[0]), srgbToLinear(kd[1]), srgbToLinear(kd[2]), alpha};
    }
    gm.materials.push_back(mat);
    return materialOf[key] = static_cast<int>(gm.materials.size()) - 1;
  };

  // The scene's triangles by instance and primitive, in file order.
  std::vector<std::vector<std::vector<int>>> triangles(soup.instances.size());
  for (size_t i = 0; i < soup.instances.size(); ++i)
    triangles[i].resize(originalMeshes[soup.instances[i].mesh].primitives.size());
  for (size_t t = 0; t < soup.triangleOrigin.size(); ++t) {
    const auto& o = soup.triangleOrigin[t];
    triangles[o.instance][o.primitive].push_back(static_cast<int>(t));
  }

  // Each instance's primitives, rewritten: per model material, the vertices its triangles use (a vertex split where
  // the montage's texture coordinates differ), every attribute and morph target gathered for them, and the
  // montage's texture coordinates as one more set.
  std::set<int> written;  // meshes rewritten for an instance
  for (size_t i = 0; i < soup.instances.size(); ++i) {
    const gltf::Instance& instance = soup.instances[i];
    const tinygltf::Mesh& sourceMesh = originalMeshes[instance.mesh];
    int target = instance.mesh;
    if (!written.insert(instance.mesh).second) {  // a second node shows the mesh: it gets its own copy
      gm.meshes.push_back(sourceMesh);
      target = static_cast<int>(gm.meshes.size()) - 1;
      gm.nodes[instance.node].mesh = target;
      written.insert(target);
      ++out.copiedMeshes;
    }
    std::vector<tinygltf::Primitive> primitives;
    for (size_t p = 0; p < sourceMesh.primitives.size(); ++p) {
      const tinygltf::Primitive& prim = sourceMesh.primitives[p];
      const std::string where =
          source + ": meshes[" + std::to_string(instance.mesh) + "].primitives[" + std::to_string(p) + "]";
      std::map<int, std::vector<int>> groups;  // model material -> triangles
      for (int t : triangles[i][p]) groups[modelMaterial(t)].push_back(t);
      if (groups.size() > 1 && groups.count(-1)) {  // triangles the mesh left out go with the first group
        std::vector<int> left = std::move(groups[-1]);
        groups.erase(-1);
        auto& first = groups.begin()->second;
        first.insert(first.end(), left.begin(), left.end());
      }
      int set = 0;
      while (prim.attributes.count("TEXCOORD_" + std::to_string(set))) ++set;
      for (const auto& [m, tris] : groups) {
        std::map<std::tuple<int, uint32_t, uint32_t>, uint32_t> vertexOf;
        std::vector<size_t> elements;
        std::vector<Vec2f> uv;
        std::vector<uint32_t> indices;
        for (int t : tris) {
          if (faceOf[t] < 0) ++out.leftOutTriangles;
          for (int j = 0; j < 3; ++j) {
            const Vec2f tc = cornerUV(t, j);
            const int e = soup.vertexElement[soup.triangleOrigin[t].vertices[j]];
            uint32_t bu, bv;
            std::memcpy(&bu, &tc.x(), 4);
            std::memcpy(&bv, &tc.y(), 4);
            const auto [it, inserted] =
                vertexOf.emplace(std::make_tuple(e, bu, bv), static_cast<uint32_t>(elements.size()));
            if (inserted) elements.push_back(static_cast<size_t>(e)), uv.push_back(tc);
            indices.push_back(it->second);
          }
        }
        const auto gather = [&](int accessor, const std::string& name, bool position) {
          const gltf::AccessorBytes& d = bytesOf(accessor, where + "." + name);
          const size_t element = d.elementSize();
          std::vector<unsigned char> bytes(elements.size() * element);
          for (size_t k = 0; k < elements.size(); ++k) {
            TM_CHECK(elements[k] < d.count,
                     located(where + "." + name + " (accessor " + std::to_string(accessor) + ")",
                             "has fewer elements (" + std::to_string(d.count) + ") than the primitive's POSITION"));
            std::memcpy(&bytes[k * element], &d.bytes[elements[k] * element], element);
          }
          const tinygltf::Accessor& like = gm.accessors[accessor];
          return pack.accessor(like, d, bytes, elements.size(), TINYGLTF_TARGET_ARRAY_BUFFER,
                               position || !like.minValues.empty());
        };
        tinygltf::Primitive np = prim;
        np.attributes.clear();
        for (const auto& [name, accessor] : prim.attributes)
          np.attributes[name] = gather(accessor, name, name == "POSITION");
        np.attributes["TEXCOORD_" + std::to_string(set)] = pack.plain(
            uv.data(), uv.size(), TINYGLTF_TYPE_VEC2, 2, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TARGET_ARRAY_BUFFER);
        for (size_t k = 0; k < prim.targets.size(); ++k)
          for (const auto& [name, accessor] : prim.targets[k])
            np.targets[k][name] = gather(accessor, "targets[" + std::to_string(k) + "]." + name, name == "POSITION");
        np.indices = pack.plain(indices.data(), indices.size(), TINYGLTF_TYPE_SCALAR, 1,
                                TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
        np.material = materialFor(prim.material, m, set);
        if (np.extras.IsObject() && np.extras.Has("tm_source")) {  // a source tag of an earlier export
          tinygltf::Value::Object extras = np.extras.Get<tinygltf::Value::Object>();
          extras.erase("tm_source");
          np.extras = extras.empty() ? tinygltf::Value() : tinygltf::Value(extras);
        }
        primitives.push_back(std::move(np));
        out.triangles += static_cast<int>(tris.size());
      }
    }
    gm.meshes[target].primitives = std::move(primitives);
    out.primitives += static_cast<int>(gm.meshes[target].primitives.size());
  }

  // The materials the rewritten primitives replaced, and the textures, images and samplers only they showed (the
  // file's own base colour images), are left out, so that the file does not carry a texture nothing shows. Only
  // when the file uses no extension, which might name them where this writer does not look.
  if (gm.extensionsUsed.empty()) {
    out.droppedImages = dropUnused(gm, newImages);
  }

  // Everything else that names an accessor keeps it, copied into the new buffer.
  std::map<int, int> carried;
  const auto carry = [&](int& accessor, const std::string& where, int target) {
    if (accessor < 0) return;
    if (const auto it = carried.find(accessor); it != carried.end()) {
      accessor = it->second;
      return;
    }
    const gltf::AccessorBytes& d = bytesOf(accessor, where);
    tinygltf::Accessor like = gm.accessors[accessor];
    const int index = pack.accessor(like, d, d.bytes, d.count, target, false);
    pack.accessors[index].minValues = like.minValues;
    pack.accessors[index].maxValues = like.maxValues;
    carried[accessor] = index;
    accessor = index;
  };
  for (size_t m = 0; m < gm.meshes.size(); ++m) {
    if (written.count(static_cast<int>(m))) continue;
    for (size_t p = 0; p < gm.meshes[m].primitives.size(); ++p) {
      tinygltf::Primitive& prim = gm.meshes[m].primitives[p];
      const std::string where = source + ": meshes[" + std::to_string(m) + "].primitives[" + std::to_string(p) + "]";
      for (auto& [name, accessor] : prim.attributes) carry(accessor, where + "." + name, TINYGLTF_TARGET_ARRAY_BUFFER);
      for (auto& targetMap : prim.targets)
        for (auto& [name, accessor] : targetMap) carry(accessor, where + ".targets", TINYGLTF_TARGET_ARRAY_BUFFER);
      carry(prim.indices, where + ".indices", TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
    }
  }
  for (size_t s = 0; s < gm.skins.size(); ++s)
    carry(gm.skins[s].inverseBindMatrices, source + ": skins[" + std::to_string(s) + "].inverseBindMatrices", 0);
  for (size_t a = 0; a < gm.animations.size(); ++a)
    for (auto& s : gm.animations[a].samplers) {
      const std::string where = source + ": animations[" + std::to_string(a) + "].samplers";
      carry(s.input, where + ".input", 0);
      carry(s.output, where + ".output", 0);
    }
  // Images: the file's own bytes, embedded.
  for (size_t k = 0; k < gm.images.size(); ++k) {
    tinygltf::Image& image = gm.images[k];
    const std::string where = source + ": images[" + std::to_string(k) + "]";
    const auto fresh =
        std::find_if(newImages.begin(), newImages.end(), [&](const auto& n) { return n.first == int(k); });
    if (fresh != newImages.end()) {
      image.bufferView = pack.view(fresh->second->data(), fresh->second->size(), 0);
    } else if (image.bufferView >= 0) {
      TM_CHECK(image.bufferView < static_cast<int>(gm.bufferViews.size()), located(where, "bufferView does not exist"));
      const tinygltf::BufferView& v = gm.bufferViews[image.bufferView];
      TM_CHECK(v.buffer >= 0 && v.buffer < static_cast<int>(gm.buffers.size()) &&
                   v.byteOffset <= gm.buffers[v.buffer].data.size() &&
                   v.byteLength <= gm.buffers[v.buffer].data.size() - v.byteOffset,
               located(where, "its bufferView lies outside its buffer"));
      image.bufferView = pack.view(gm.buffers[v.buffer].data.data() + v.byteOffset, v.byteLength, 0);
    } else {  // named by URI: its own bytes, embedded
      const std::vector<unsigned char> bytes = gltf::imageBytes(image, source, image.mimeType);
      image.bufferView = pack.view(bytes.data(), bytes.size(), 0);
      image.uri.clear();
    }
  }

  gm.accessors = std::move(pack.accessors);
  gm.bufferViews = std::move(pack.views);
  gm.buffers.assign(1, tinygltf::Buffer{});
  gm.buffers[0].data = std::move(pack.bin);
  gm.asset.generator = "TextureMontage" + (gm.asset.generator.empty() ? "" : " (from " + gm.asset.generator + ")");

  gltf::writeGlb(gm, path);
  return out;
}

}  // namespace montage
