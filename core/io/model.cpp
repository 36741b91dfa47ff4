#include "io/model.h"

#include <tiny_gltf.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <numeric>
#include <opencv2/imgproc.hpp>
#include <set>
#include <sstream>
#include <tuple>
#include <unordered_map>

#include "base/fileio.h"
#include "base/util.h"
#include "image/codec.h"
#include "image/color.h"
#include "image/photo.h"
#include "io/gltf_document.h"
#include "io/mesh_io.h"

namespace fs = std::filesystem;

namespace montage {

namespace {

const Vec3f kDefaultDiffuse(0.7f, 0.7f, 0.7f);

// ---------------------------------------------------------------------------------------------
// Small utilities

std::string trim(const std::string& s) {
  const size_t b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return "";
  const size_t e = s.find_last_not_of(" \t\r\n");
  return s.substr(b, e - b + 1);
}

std::string quote(const std::string& s) {
  return "'" + s + "'";
}

// A name as it may appear in OBJ statements and file names: letters, digits, '_', '-' and '.' only.
std::string fileNamePart(std::string name) {
  for (char& c : name)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.')) c = '_';
  return name;
}

// Shortest decimal text that reads back to exactly the same value.
template <class T>
std::string number(T value) {
  char buf[64];
  const auto res = std::to_chars(buf, buf + sizeof buf, value);
  return std::string(buf, res.ptr);
}

// Checks that the per-face arrays of a model agree with its mesh before writing it.
void checkModel(const TexturedModel& model, const std::string& where) {
  const size_t nf = static_cast<size_t>(model.mesh.numFaces());
  TM_CHECK(nf > 0, located(where, "the model has no faces"));
  TM_CHECK(model.uv.empty() || model.uv.size() == nf,
           located(where, "model has " + std::to_string(model.uv.size()) + " UV triples for " + std::to_string(nf) +
                              " faces"));
  TM_CHECK(model.faceMaterial.empty() || model.faceMaterial.size() == nf,
           located(where, "model has " + std::to_string(model.faceMaterial.size()) + " face materials for " +
                              std::to_string(nf) + " faces"));
  TM_CHECK(model.faceSource.empty() || model.faceSource.size() == nf,
           located(where, "model has " + std::to_string(model.faceSource.size()) + " face sources for " +
                              std::to_string(nf) + " faces"));
  for (size_t f = 0; f < model.faceMaterial.size(); ++f) {
    const int m = model.faceMaterial[f];
    TM_CHECK(m >= 0 && m < static_cast<int>(model.materials.size()),
             located(where, "face " + std::to_string(f) + ": material " + std::to_string(m) + " does not exist (" +
                                std::to_string(model.materials.size()) + " materials)"));
  }
  for (size_t f = 0; f < model.faceSource.size(); ++f)
    TM_CHECK(model.faceSource[f] >= kSourceEmpty,
             located(where, "face " + std::to_string(f) + ": invalid source " + std::to_string(model.faceSource[f])));
}

int materialOf(const TexturedModel& model, int f) {
  return model.faceMaterial.empty() ? 0 : model.faceMaterial[f];
}

// Material of face f, or null when the model has none.
const Material* faceMaterialPtr(const TexturedModel& model, int f) {
  const int m = materialOf(model, f);
  return m >= 0 && m < static_cast<int>(model.materials.size()) ? &model.materials[m] : nullptr;
}

bool hasTexture(const TexturedModel& model, int m) {
  return model.textured() && m < static_cast<int>(model.materials.size()) && !model.materials[m].texture.empty();
}

// Group name of a face source in OBJ files, and back.
std::string sourceGroupName(int source) {
  if (source == kSourceInpainted) return "tm_inpainted";
  if (source == kSourceEmpty) return "tm_empty";
  return "tm_source_" + std::to_string(source);
}

// Returns true and sets `source` when `name` (or one of its words) is a TextureMontage source group.
bool parseSourceGroup(const std::string& name, int& source) {
  std::istringstream words(name);
  std::string w;
  while (words >> w) {
    if (w == "tm_inpainted") {
      source = kSourceInpainted;
      return true;
    }
    if (w == "tm_empty") {
      source = kSourceEmpty;
      return true;
    }
    static const std::string prefix = "tm_source_";
    if (w.size() > prefix.size() && w.compare(0, prefix.size(), prefix) == 0) {
      const char* b = w.data() + prefix.size();
      const char* e = w.data() + w.size();
      int k = -1;
      const auto res = std::from_chars(b, e, k);
      if (res.ec == std::errc() && res.ptr == e && k >= 0) {
        source = k;
        return true;
      }
    }
  }
  return false;
}

// Per-face values of the built mesh from per-input-face values (`perInput`, indexed like the
// triangles handed to the builder) through Mesh::faceOrigin.
template <class T>
std::vector<T> perMeshFace(const Mesh& mesh, const std::vector<T>& perInput) {
  const size_t nf = static_cast<size_t>(mesh.numFaces());
  if (mesh.faceOrigin.size() != nf) {
    TM_ASSERT(perInput.size() == nf);
    return perInput;
  }
  std::vector<T> out(nf);
  for (size_t f = 0; f < nf; ++f) {
    const int o = mesh.faceOrigin[f];
    TM_ASSERT(o >= 0 && o < static_cast<int>(perInput.size()));
    out[f] = perInput[o];
  }
  return out;
}

std::vector<int> meshFaceArray(const Mesh& mesh, const std::vector<int>& values) {
  return meshFaceValues(mesh, values);
}

std::vector<std::array<Vec2f, 3>> floatUV(const std::vector<std::array<Vec2, 3>>& uv) {
  std::vector<std::array<Vec2f, 3>> out(uv.size());
  for (size_t f = 0; f < uv.size(); ++f)
    for (int k = 0; k < 3; ++k) out[f][k] = uv[f][k].cast<float>();
  return out;
}

// ---------------------------------------------------------------------------------------------
// OBJ + MTL

// Reads the image a map_Kd statement names; `where` is "file.mtl:line".
cv::Mat readTexture(const fs::path& file, const std::string& where, const std::string& written) {
  if (const std::string problem = fileProblem(file.string()); !problem.empty())
    throw Error(
        located(where, "map_Kd texture " + quote(written) + " " + problem + " (looked for " + file.string() + ")"));
  try {
    return readImageRgba8(file.string());
  } catch (const Error& e) {
    // The reason without the file name it starts with, which the message already gives.
    std::string reason = e.what();
    if (const std::string prefix = file.string() + ": "; reason.rfind(prefix, 0) == 0) reason.erase(0, prefix.size());
    throw Error(located(
        where, "map_Kd texture " + quote(written) + " (" + file.string() + ") cannot be read as an image: " + reason));
  }
}

// The file name of a map_Kd statement: options (-bm 1, -o u v w, ...) are skipped.
std::string mapFileName(const std::string& args) {
  std::istringstream in(args);
  std::vector<std::string> tokens;
  for (std::string t; in >> t;) tokens.push_back(t);
  static const std::map<std::string, int> kOptionArgs = {
      {"-blendu", 1}, {"-blendv", 1}, {"-bm", 1}, {"-boost", 1}, {"-cc", 1}, {"-clamp", 1}, {"-imfchan", 1},
      {"-texres", 1}, {"-type", 1},   {"-mm", 2}, {"-o", 3},     {"-s", 3},  {"-t", 3}};
  const auto isNumber = [](const std::string& s) {
    double v;
    const auto res = std::from_chars(s.data(), s.data() + s.size(), v);
    return res.ec == std::errc() && res.ptr == s.data() + s.size();
  };
  size_t i = 0;
  while (i < tokens.size()) {
    const auto it = kOptionArgs.find(tokens[i]);
    if (it == kOptionArgs.end()) break;
    ++i;
    if (it->second == 3) {  // -o/-s/-t take one to three numbers
      for (int k = 0; k < 3 && i < tokens.size() && isNumber(tokens[i]); ++k) ++i;
    } else {
      i += static_cast<size_t>(it->second);
    }
  }
  // The rest is the file name (it may contain spaces).
  std::string name;
  for (; i < tokens.size(); ++i) name += (name.empty() ? "" : " ") + tokens[i];
  std::replace(name.begin(), name.end(), '\\', '/');
  return name;
}

// Refuses a file a model names (material library, texture, buffer) outside the model's folder.
void requireInsideModelFolder(const fs::path& file, const fs::path& modelDir, const std::string& where,
                              const std::string& what) {
  TM_CHECK(isInsideFolder(file.string(), modelDir.string()),
           located(where, what + " is outside the model's folder " + quote(modelDir.string()) + " (resolved to " +
                              quote(file.string()) + "): a model never reads outside its folder"));
}

// Parses one .mtl file: newmtl, Kd and map_Kd. Textures are read; a missing one is an error naming
// the .mtl file, its line and the texture.
void parseMtl(const fs::path& mtlPath, const fs::path& modelDir, std::map<std::string, Material>& out) {
  std::istringstream in(readFileBytes(mtlPath.string(), "material library"));
  std::map<std::string, cv::Mat> cache;  // textures shared between materials
  Material* current = nullptr;
  std::string line;
  for (int lineNo = 1; std::getline(in, line); ++lineNo) {
    const std::string where = mtlPath.string() + ":" + std::to_string(lineNo);
    line = trim(line);
    if (line.empty() || line[0] == '#') continue;
    const size_t sp = line.find_first_of(" \t");
    const std::string key = line.substr(0, sp);
    const std::string rest = sp == std::string::npos ? "" : trim(line.substr(sp));
    if (key == "newmtl") {
      TM_CHECK(!rest.empty(), located(where, "newmtl without a material name"));
      Material m;
      m.name = rest;
      current = &(out[rest] = m);
    } else if (key == "Kd" && current) {
      std::istringstream vals(rest);
      double r, g, b;
      if (!(vals >> r)) throw Error(located(where, "Kd needs three numbers, got " + quote(rest)));
      if (!(vals >> g >> b)) g = b = r;
      current->diffuse = Vec3f(static_cast<float>(std::clamp(r, 0.0, 1.0)), static_cast<float>(std::clamp(g, 0.0, 1.0)),
                               static_cast<float>(std::clamp(b, 0.0, 1.0)));
    } else if (key == "map_Kd" && current) {
      const std::string name = mapFileName(rest);
      TM_CHECK(!name.empty(), located(where, "map_Kd without a file name"));
      const fs::path file = (mtlPath.parent_path() / name).lexically_normal();
      requireInsideModelFolder(file, modelDir, where, "map_Kd texture " + quote(name));
      auto it = cache.find(file.string());
      if (it == cache.end()) it = cache.emplace(file.string(), readTexture(file, where, name)).first;
      current->texture = it->second;
      current->textureFile = file.lexically_relative(modelDir).generic_string();
      if (current->textureFile.empty()) current->textureFile = file.string();
    }
  }
}

TexturedModel loadObjModel(const std::string& path) {
  std::unique_ptr<Mesh> mesh = requireUsable(loadMesh(path));
  TexturedModel model;
  model.mesh = std::move(*mesh);
  const Mesh& m = model.mesh;
  const int nf = m.numFaces();
  const fs::path modelDir = fs::absolute(path).lexically_normal().parent_path();

  // Material definitions from the material library (or libraries).
  std::map<std::string, Material> defs;
  const std::string lib = trim(m.mtllib);
  if (!lib.empty()) {
    std::vector<std::string> files;
    std::error_code ec;
    if (fs::is_regular_file(modelDir / lib, ec)) {
      files.push_back(lib);
    } else {
      std::istringstream words(lib);
      for (std::string w; words >> w;) files.push_back(w);
    }
    for (const std::string& file : files) {
      const fs::path mtl = (modelDir / file).lexically_normal();
      requireInsideModelFolder(mtl, modelDir, path, "material library " + quote(file));
      if (const std::string problem = fileProblem(mtl.string()); !problem.empty())
        throw Error(
            located(path, "material library " + quote(file) + " " + problem + " (looked for " + mtl.string() + ")"));
      parseMtl(mtl, modelDir, defs);
    }
  }

  // One material per name the OBJ uses, in order of first use; a single default one otherwise.
  const std::vector<int> faceMaterial = meshFaceArray(m, m.faceMaterial);
  if (m.materialNames.empty() || faceMaterial.empty()) {
    Material def;
    def.name = "default";
    if (m.materialNames.size() == 1 && defs.count(m.materialNames[0])) def = defs[m.materialNames[0]];
    model.materials.push_back(def);
    model.faceMaterial.assign(nf, 0);
  } else {
    for (const std::string& name : m.materialNames) {
      const auto it = defs.find(name);
      Material mat;
      if (it != defs.end()) mat = it->second;
      mat.name = name;
      model.materials.push_back(mat);
    }
    model.faceMaterial = faceMaterial;
    // Faces before the first usemtl (or with an unknown index) get a default material.
    const int count = static_cast<int>(model.materials.size());
    for (int& fm : model.faceMaterial) {
      if (fm >= 0 && fm < count) continue;
      if (static_cast<int>(model.materials.size()) == count) {
        Material def;
        def.name = "default";
        model.materials.push_back(def);
      }
      fm = count;
    }
  }
  if (m.hasUV()) model.uv = floatUV(m.cornerUV);

  // Face sources from the groups.
  const std::vector<int> faceGroup = meshFaceArray(m, m.faceGroup);
  std::vector<int> groupSource(m.groupNames.size(), 0);
  bool any = false;
  for (size_t g = 0; g < m.groupNames.size(); ++g) {
    int source;
    const bool known = parseSourceGroup(m.groupNames[g], source);
    groupSource[g] = known ? source : kSourceEmpty;
    any = any || known;
  }
  if (any && !faceGroup.empty()) {
    model.faceSource.assign(nf, kSourceEmpty);
    for (int f = 0; f < nf; ++f) {
      const int g = faceGroup[f];
      if (g >= 0 && g < static_cast<int>(groupSource.size())) model.faceSource[f] = groupSource[g];
    }
  }
  return model;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// glTF reading (io/gltf_document.h)

namespace gltf {

double decodeComponent(const unsigned char* p, int componentType, bool normalized) {
  switch (componentType) {
    case TINYGLTF_COMPONENT_TYPE_FLOAT: {
      float v;
      std::memcpy(&v, p, 4);
      return v;
    }
    case TINYGLTF_COMPONENT_TYPE_BYTE: {
      const double v = static_cast<int8_t>(*p);
      return normalized ? std::max(v / 127.0, -1.0) : v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: {
      const double v = *p;
      return normalized ? v / 255.0 : v;
    }
    case TINYGLTF_COMPONENT_TYPE_SHORT: {
      int16_t v;
      std::memcpy(&v, p, 2);
      return normalized ? std::max(v / 32767.0, -1.0) : v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
      uint16_t v;
      std::memcpy(&v, p, 2);
      return normalized ? v / 65535.0 : v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
      uint32_t v;
      std::memcpy(&v, p, 4);
      return v;
    }
    case TINYGLTF_COMPONENT_TYPE_DOUBLE: {
      double v;
      std::memcpy(&v, p, 8);
      return v;
    }
    default:
      return std::numeric_limits<double>::quiet_NaN();
  }
}

AccessorBytes accessorBytes(const tinygltf::Model& gm, int index, const std::string& where) {
  TM_CHECK(index >= 0 && index < static_cast<int>(gm.accessors.size()),
           located(where, "accessor " + std::to_string(index) + " does not exist"));
  const tinygltf::Accessor& acc = gm.accessors[index];
  const std::string at = where + " (accessor " + std::to_string(index) + ")";
  AccessorBytes out;
  out.componentType = acc.componentType;
  out.normalized = acc.normalized;
  const int components = tinygltf::GetNumComponentsInType(static_cast<uint32_t>(acc.type));
  const int csize = tinygltf::GetComponentSizeInBytes(static_cast<uint32_t>(acc.componentType));
  TM_CHECK(components > 0 && csize > 0, located(at, "invalid type or component type"));
  const std::array<unsigned char, 8> zero{};
  TM_CHECK(!std::isnan(decodeComponent(zero.data(), acc.componentType, false)),
           located(at, "unsupported component type " + std::to_string(acc.componentType)));
  out.components = components;
  out.componentSize = csize;
  const size_t count = acc.count;
  // A declared count is bounded by the bytes that could hold it (an accessor without a bufferView is
  // all zeros, but still no larger than the buffers), before anything is allocated.
  size_t bufferBytes = 0;
  for (const auto& b : gm.buffers) bufferBytes += b.data.size();
  TM_CHECK(count <= bufferBytes / size_t(components * csize) + 1,
           located(at, "count " + std::to_string(count) + " is larger than the buffers could hold (" +
                           std::to_string(bufferBytes) + " bytes)"));
  const size_t elementSize = static_cast<size_t>(components) * csize;
  out.count = count;
  out.bytes.assign(count * elementSize, 0);

  // Bytes of a buffer view with bounds checks.
  const auto viewBytes = [&](int viewIndex, size_t offset, size_t stride, size_t n,
                             size_t elementSize) -> const unsigned char* {
    TM_CHECK(viewIndex >= 0 && viewIndex < static_cast<int>(gm.bufferViews.size()),
             located(at, "bufferView " + std::to_string(viewIndex) + " does not exist"));
    const tinygltf::BufferView& view = gm.bufferViews[viewIndex];
    TM_CHECK(view.buffer >= 0 && view.buffer < static_cast<int>(gm.buffers.size()),
             located(at, "buffer " + std::to_string(view.buffer) + " does not exist"));
    const tinygltf::Buffer& buffer = gm.buffers[view.buffer];
    // Written so that no sum or product of untrusted sizes can overflow.
    TM_CHECK(view.byteOffset <= buffer.data.size() && view.byteLength <= buffer.data.size() - view.byteOffset,
             located(at, "bufferView " + std::to_string(viewIndex) + " lies outside its buffer (file truncated?)"));
    TM_CHECK(n == 0 || (offset <= view.byteLength && elementSize <= view.byteLength - offset &&
                        n - 1 <= (view.byteLength - offset - elementSize) / std::max<size_t>(stride, 1)),
             located(at, "data lies outside bufferView " + std::to_string(viewIndex)));
    return buffer.data.data() + view.byteOffset + offset;
  };

  if (acc.bufferView >= 0) {
    TM_CHECK(acc.bufferView < static_cast<int>(gm.bufferViews.size()),
             located(at, "bufferView " + std::to_string(acc.bufferView) + " does not exist"));
    const tinygltf::BufferView& view = gm.bufferViews[acc.bufferView];
    const size_t stride = view.byteStride ? view.byteStride : elementSize;
    const unsigned char* base = viewBytes(acc.bufferView, acc.byteOffset, stride, count, elementSize);
    for (size_t i = 0; i < count; ++i) std::memcpy(&out.bytes[i * elementSize], base + i * stride, elementSize);
  }
  if (acc.sparse.isSparse && acc.sparse.count > 0) {
    const size_t n = static_cast<size_t>(acc.sparse.count);
    const int isize = tinygltf::GetComponentSizeInBytes(static_cast<uint32_t>(acc.sparse.indices.componentType));
    TM_CHECK(isize > 0, located(at, "invalid sparse index component type"));
    const unsigned char* idx =
        viewBytes(acc.sparse.indices.bufferView, static_cast<size_t>(acc.sparse.indices.byteOffset), isize, n, isize);
    const unsigned char* val = viewBytes(
        acc.sparse.values.bufferView, static_cast<size_t>(acc.sparse.values.byteOffset), elementSize, n, elementSize);
    for (size_t i = 0; i < n; ++i) {
      const double target = decodeComponent(idx + i * isize, acc.sparse.indices.componentType, false);
      TM_CHECK(target >= 0 && target < static_cast<double>(count), located(at, "sparse index out of range"));
      std::memcpy(&out.bytes[static_cast<size_t>(target) * elementSize], val + i * elementSize, elementSize);
    }
  }
  return out;
}

std::vector<double> readAccessor(const tinygltf::Model& gm, int index, const std::string& where, int& components) {
  const AccessorBytes data = accessorBytes(gm, index, where);
  components = data.components;
  std::vector<double> out(data.count * components);
  for (size_t i = 0; i < out.size(); ++i)
    out[i] = decodeComponent(&data.bytes[i * data.componentSize], data.componentType, data.normalized);
  return out;
}

Eigen::Matrix4d nodeMatrix(const tinygltf::Node& node) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  if (node.matrix.size() == 16) {
    for (int c = 0; c < 4; ++c)
      for (int r = 0; r < 4; ++r) m(r, c) = node.matrix[c * 4 + r];  // column-major
    return m;
  }
  Eigen::Affine3d a = Eigen::Affine3d::Identity();
  if (node.translation.size() == 3) a.translate(Vec3(node.translation[0], node.translation[1], node.translation[2]));
  if (node.rotation.size() == 4)
    a.rotate(Eigen::Quaterniond(node.rotation[3], node.rotation[0], node.rotation[1], node.rotation[2]).normalized());
  if (node.scale.size() == 3) a.scale(Vec3(node.scale[0], node.scale[1], node.scale[2]));
  return a.matrix();
}

// Every node that shows a mesh, depth first from the default scene's roots (every root node when the
// file has no scene), children in order; each mesh once at the origin when no node shows any.
std::vector<Instance> meshInstances(const tinygltf::Model& gm) {
  std::vector<int> roots;
  const int scene = gm.defaultScene >= 0 ? gm.defaultScene : 0;
  if (scene < static_cast<int>(gm.scenes.size())) {
    roots = gm.scenes[scene].nodes;
  } else {
    std::vector<bool> isChild(gm.nodes.size(), false);
    for (const auto& n : gm.nodes)
      for (int c : n.children)
        if (c >= 0 && c < static_cast<int>(gm.nodes.size())) isChild[c] = true;
    for (size_t i = 0; i < gm.nodes.size(); ++i)
      if (!isChild[i]) roots.push_back(static_cast<int>(i));
  }
  // Depth first with an explicit stack (a file may chain millions of nodes), children in order.
  std::vector<Instance> out;
  std::vector<bool> visited(gm.nodes.size(), false);
  std::vector<std::pair<int, Eigen::Matrix4d>> stack;
  for (auto r = roots.rbegin(); r != roots.rend(); ++r) stack.emplace_back(*r, Eigen::Matrix4d::Identity());
  while (!stack.empty()) {
    const auto [n, parent] = stack.back();
    stack.pop_back();
    if (n < 0 || n >= static_cast<int>(gm.nodes.size()) || visited[n]) continue;
    visited[n] = true;
    const Eigen::Matrix4d world = parent * nodeMatrix(gm.nodes[n]);
    if (gm.nodes[n].mesh >= 0) out.push_back({n, gm.nodes[n].mesh, world});
    const auto& children = gm.nodes[n].children;
    for (auto c = children.rbegin(); c != children.rend(); ++c) stack.emplace_back(*c, world);
  }
  if (out.empty())
    for (size_t m = 0; m < gm.meshes.size(); ++m) out.push_back({-1, static_cast<int>(m), Eigen::Matrix4d::Identity()});
  return out;
}

// The base colour texture of a glTF material as RGBA8 (empty when there is none).
cv::Mat gltfBaseColorTexture(const tinygltf::Model& gm, const tinygltf::Material& mat, const std::string& where,
                             std::string& file) {
  const int t = mat.pbrMetallicRoughness.baseColorTexture.index;
  if (t < 0) return {};
  TM_CHECK(t < static_cast<int>(gm.textures.size()),
           located(where, "texture " + std::to_string(t) + " does not exist"));
  const int s = gm.textures[t].source;
  TM_CHECK(s >= 0 && s < static_cast<int>(gm.images.size()),
           located(where, "texture " + std::to_string(t) + " has no image"));
  const tinygltf::Image& img = gm.images[s];
  const std::string at = where + ": image " + std::to_string(s);
  TM_CHECK(img.width > 0 && img.height > 0 && !img.image.empty(), located(at, "image could not be decoded"));
  TM_CHECK(img.component >= 1 && img.component <= 4 && (img.bits == 8 || img.bits == 16),
           located(at, "unsupported image format (" + std::to_string(img.component) + " channels, " +
                           std::to_string(img.bits) + " bits)"));
  const size_t expected = static_cast<size_t>(img.width) * img.height * img.component * (img.bits / 8);
  TM_CHECK(img.image.size() >= expected, located(at, "image data is shorter than its size"));
  const int type = CV_MAKETYPE(img.bits == 8 ? CV_8U : CV_16U, img.component);
  const cv::Mat view(img.height, img.width, type, const_cast<unsigned char*>(img.image.data()));
  file = img.uri.rfind("data:", 0) == 0 ? "" : img.uri;
  return toRgba8(view, false, at);
}

Material gltfMaterial(const tinygltf::Model& gm, int index, const std::string& path, bool withTexture) {
  Material out;
  if (index < 0) {
    out.name = "default";
    return out;
  }
  TM_CHECK(index < static_cast<int>(gm.materials.size()),
           located(path, "material " + std::to_string(index) + " does not exist"));
  const tinygltf::Material& mat = gm.materials[index];
  out.name = mat.name.empty() ? "material_" + std::to_string(index) : mat.name;
  const auto& f = mat.pbrMetallicRoughness.baseColorFactor;
  if (f.size() >= 3)
    out.diffuse = Vec3f(static_cast<float>(linearToSrgb(std::clamp(f[0], 0.0, 1.0))),
                        static_cast<float>(linearToSrgb(std::clamp(f[1], 0.0, 1.0))),
                        static_cast<float>(linearToSrgb(std::clamp(f[2], 0.0, 1.0))));
  if (withTexture)
    out.texture = gltfBaseColorTexture(gm, mat, path + ": materials[" + std::to_string(index) + "]", out.textureFile);
  return out;
}

const char* modeName(int mode) {
  switch (mode) {
    case TINYGLTF_MODE_POINTS:
      return "POINTS";
    case TINYGLTF_MODE_LINE:
      return "LINES";
    case TINYGLTF_MODE_LINE_LOOP:
      return "LINE_LOOP";
    case 3:
      return "LINE_STRIP";
    case TINYGLTF_MODE_TRIANGLE_STRIP:
      return "TRIANGLE_STRIP";
    case TINYGLTF_MODE_TRIANGLE_FAN:
      return "TRIANGLE_FAN";
    default:
      return "unknown";
  }
}

uint32_t littleEndian32(const std::string& bytes, size_t at) {
  const auto* p = reinterpret_cast<const unsigned char*>(bytes.data()) + at;
  return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
}

// Checks the layout of a binary glTF file (header, JSON chunk, optional BIN chunk) and returns the JSON
// text, with messages that say which length is wrong.
std::string glbJsonChunk(const std::string& bytes, const std::string& path) {
  const std::string size = std::to_string(bytes.size());
  TM_CHECK(bytes.size() >= 12 && bytes.compare(0, 4, "glTF") == 0,
           located(path, "not a binary glTF file (no 'glTF' header)"));
  const uint32_t version = littleEndian32(bytes, 4), length = littleEndian32(bytes, 8);
  TM_CHECK(version == 2,
           located(path, "binary glTF version " + std::to_string(version) + " is not supported (only 2)"));
  TM_CHECK(length <= bytes.size(), located(path, "file is truncated: its header announces " + std::to_string(length) +
                                                     " bytes but it has " + size));
  TM_CHECK(length >= 20, located(path, "header length " + std::to_string(length) +
                                           " leaves no room for the JSON chunk (at least 20 bytes)"));
  const uint64_t jsonLength = littleEndian32(bytes, 12), jsonType = littleEndian32(bytes, 16);
  TM_CHECK(jsonType == 0x4E4F534A,
           located(path, "the first chunk is not JSON (chunk type " + std::to_string(jsonType) + ")"));
  TM_CHECK(jsonLength > 0, located(path, "the JSON chunk is empty"));
  const uint64_t jsonEnd = 20 + jsonLength;
  TM_CHECK(jsonEnd <= length,
           located(path, "the JSON chunk length " + std::to_string(jsonLength) +
                             " runs past the end announced by the header (" + std::to_string(length) + " bytes)"));
  if (jsonEnd < length) {
    TM_CHECK(jsonEnd % 4 == 0, located(path, "the JSON chunk length " + std::to_string(jsonLength) +
                                                 " is not a multiple of 4 (the chunks are misaligned)"));
    TM_CHECK(jsonEnd + 8 <= length, located(path, "the header length " + std::to_string(length) +
                                                      " leaves a partial chunk header after the JSON chunk"));
    const uint64_t binLength = littleEndian32(bytes, size_t(jsonEnd)),
                   binType = littleEndian32(bytes, size_t(jsonEnd) + 4);
    TM_CHECK(binType == 0x004E4942,
             located(path, "the second chunk is not BIN (chunk type " + std::to_string(binType) + ")"));
    TM_CHECK(jsonEnd + 8 + binLength <= length,
             located(path, "the BIN chunk length " + std::to_string(binLength) +
                               " runs past the end announced by the header (" + std::to_string(length) + " bytes)"));
    TM_CHECK(binLength >= 4 && binLength % 4 == 0,
             located(path, "the BIN chunk length " + std::to_string(binLength) + " is not a positive multiple of 4"));
  }
  return bytes.substr(20, size_t(jsonLength));
}

// The file a relative URI names (percent-decoded, as tinygltf resolves it) in the model's folder.
fs::path uriFile(const fs::path& modelDir, const std::string& uri) {
  std::string decoded;
  for (size_t k = 0; k < uri.size(); ++k) {
    int value = 0;
    if (uri[k] == '%' && k + 2 < uri.size() &&
        std::from_chars(uri.data() + k + 1, uri.data() + k + 3, value, 16).ptr == uri.data() + k + 3) {
      decoded += char(value);
      k += 2;
    } else {
      decoded += uri[k];
    }
  }
  return (modelDir / decoded).lexically_normal();
}

std::vector<unsigned char> imageBytes(const tinygltf::Image& image, const std::string& path, std::string& mimeType) {
  std::vector<unsigned char> bytes;
  mimeType = image.mimeType;
  if (tinygltf::IsDataURI(image.uri)) {
    TM_CHECK(tinygltf::DecodeDataURI(&bytes, mimeType, image.uri, 0, false),
             located(path, "image " + quote(image.name) + ": its data URI cannot be decoded"));
  } else {
    const fs::path modelDir = fs::absolute(path).lexically_normal().parent_path();
    const fs::path file = uriFile(modelDir, image.uri);
    requireInsideModelFolder(file, modelDir, path, "image uri " + quote(image.uri));
    const std::string data = readFileBytes(file.string(), "image", uint64_t(UINT32_MAX));
    bytes.assign(data.begin(), data.end());
  }
  // The type from the bytes: a GLB embeds only PNG and JPEG.
  if (bytes.size() >= 8 && bytes[0] == 0x89 && bytes[1] == 'P' && bytes[2] == 'N' && bytes[3] == 'G')
    mimeType = "image/png";
  else if (bytes.size() >= 3 && bytes[0] == 0xFF && bytes[1] == 0xD8 && bytes[2] == 0xFF)
    mimeType = "image/jpeg";
  else
    throw Error(located(path, "image " + quote(image.uri.substr(0, 64)) + " is neither PNG nor JPEG"));
  return bytes;
}

// Checks the JSON of a glTF file before tinygltf reads it: nesting depth (its reader recurses), and that
// every buffer and image URI that is not a data: URI stays inside the model's folder.
void checkGltfJson(const std::string& text, const fs::path& modelDir, const std::string& path) {
  constexpr int kMaxDepth = 64;
  int depth = 0;
  bool inString = false, escaped = false;
  for (const char c : text) {
    if (inString) {
      if (escaped)
        escaped = false;
      else if (c == '\\')
        escaped = true;
      else if (c == '"')
        inString = false;
    } else if (c == '"') {
      inString = true;
    } else if (c == '[' || c == '{') {
      TM_CHECK(++depth <= kMaxDepth,
               located(path, "JSON values nested more than " + std::to_string(kMaxDepth) + " deep"));
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
  if (!j.is_object()) return;  // tinygltf names the syntax error
  for (const char* list : {"buffers", "images"}) {
    const auto it = j.find(list);
    if (it == j.end() || !it->is_array()) continue;
    for (size_t i = 0; i < it->size(); ++i) {
      const nlohmann::json& entry = (*it)[i];
      if (!entry.is_object() || !entry.contains("uri") || !entry["uri"].is_string()) continue;
      const std::string uri = entry["uri"].get<std::string>();
      if (uri.rfind("data:", 0) == 0) continue;
      const fs::path file = uriFile(modelDir, uri);
      requireInsideModelFolder(file, modelDir, path,
                               std::string(list) + "[" + std::to_string(i) + "].uri " + quote(uri));
    }
  }
}

// File access for tinygltf: reads only regular files inside the model's folder, never expands "~" or
// shell words, never writes.
struct GltfFiles {
  fs::path dir;
  std::string path;
  bool decodeImages = true;  // false: images are left undecoded (only the geometry is read)
  static bool exists(const std::string& file, void* self) {
    // Files outside the folder "exist" so that read() refuses them with the reason, not "not found".
    const auto* me = static_cast<GltfFiles*>(self);
    std::error_code ec;
    return !isInsideFolder(file, me->dir.string()) || fs::exists(file, ec);
  }
  static std::string expand(const std::string& file, void*) { return file; }
  static bool read(std::vector<unsigned char>* out, std::string* err, const std::string& file, void* self) {
    const auto* me = static_cast<GltfFiles*>(self);
    try {
      requireInsideModelFolder(fs::path(file).lexically_normal(), me->dir, file, "the file");
      const std::string bytes = readFileBytes(file, "file", uint64_t(UINT32_MAX));
      out->assign(bytes.begin(), bytes.end());
      return true;
    } catch (const Error& e) {
      if (err) *err = e.what();
      return false;
    }
  }
  static bool write(std::string* err, const std::string&, const std::vector<unsigned char>&, void*) {
    if (err) *err = "writing is not allowed while reading";
    return false;
  }
  // Images through our decoder: the same formats and size limit as photos, decoded as RGBA8.
  static bool image(tinygltf::Image* image, const int index, std::string* err, std::string*, int, int,
                    const unsigned char* bytes, int size, void* self) {
    const auto* me = static_cast<GltfFiles*>(self);
    if (!me->decodeImages) return true;
    try {
      const cv::Mat rgba =
          decodeImageRgba8(bytes, size_t(std::max(size, 0)), me->path + ": images[" + std::to_string(index) + "]");
      image->width = rgba.cols;
      image->height = rgba.rows;
      image->component = 4;
      image->bits = 8;
      image->pixel_type = TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE;
      image->image.assign(rgba.datastart, rgba.dataend);
      return true;
    } catch (const Error& e) {
      if (err) *err += std::string(e.what()) + "\n";
      return false;
    }
  }
};

tinygltf::Model loadDocument(const std::string& path, bool decodeImages) {
  return parseDocument(readFileBytes(path, "glTF file", uint64_t(UINT32_MAX)), path, lowerExtension(path) == ".glb",
                       decodeImages);
}

tinygltf::Model parseDocument(const std::string& bytes, const std::string& path, bool binary, bool decodeImages) {
  tinygltf::TinyGLTF loader;
  tinygltf::Model gm;
  std::string err, warn;
  GltfFiles files{fs::absolute(path).lexically_normal().parent_path(), path, decodeImages};
  loader.SetFsCallbacks({&GltfFiles::exists, &GltfFiles::expand, &GltfFiles::read, &GltfFiles::write, &files});
  loader.SetImageLoader(&GltfFiles::image, &files);
  bool ok;
  if (binary) {
    checkGltfJson(glbJsonChunk(bytes, path), files.dir, path);
    ok = loader.LoadBinaryFromMemory(&gm, &err, &warn, reinterpret_cast<const unsigned char*>(bytes.data()),
                                     static_cast<unsigned int>(bytes.size()), files.dir.string());
  } else {
    checkGltfJson(bytes, files.dir, path);
    ok = loader.LoadASCIIFromString(&gm, &err, &warn, bytes.data(), static_cast<unsigned int>(bytes.size()),
                                    files.dir.string());
  }
  TM_CHECK(ok, located(path, "cannot read glTF: " + trim(err.empty() ? warn : err)));
  TM_CHECK(!gm.meshes.empty(), located(path, "the file contains no mesh"));
  return gm;
}

Soup readSoup(const tinygltf::Model& gm, const std::string& path, bool withTextures) {
  Soup soup;
  soup.instances = meshInstances(gm);
  std::map<int, int> materialIndex;  // glTF material -> ours
  std::set<int> skinned, morphed;    // nodes with a skin, meshes with morph targets (noted once each)
  for (size_t n = 0; n < soup.instances.size(); ++n) {
    const Instance& instance = soup.instances[n];
    const std::string nodeName =
        instance.node < 0 ? "" : "nodes[" + std::to_string(instance.node) + "] " + quote(gm.nodes[instance.node].name);
    TM_CHECK(instance.mesh < static_cast<int>(gm.meshes.size()),
             located(path, nodeName + ": mesh " + std::to_string(instance.mesh) + " does not exist"));
    const tinygltf::Mesh& gmesh = gm.meshes[instance.mesh];
    const std::string meshName =
        "meshes[" + std::to_string(instance.mesh) + "]" + (gmesh.name.empty() ? "" : " " + quote(gmesh.name));
    if (instance.node >= 0 && gm.nodes[instance.node].skin >= 0 && skinned.insert(instance.node).second)
      soup.notes.push_back({MeshFinding::Severity::Warning,
                            nodeName + " (" + meshName +
                                ") has a skin: textured in its rest pose (the GLB export keeps its joints and "
                                "weights)",
                            {},
                            1});
    const Eigen::Matrix3d linear = instance.world.topLeftCorner<3, 3>();
    const bool mirrored = linear.determinant() < 0;  // keep front faces counter-clockwise
    std::map<std::pair<int, int>, int> vertexBase;   // (POSITION, TEXCOORD accessor) -> first vertex

    for (size_t p = 0; p < gmesh.primitives.size(); ++p) {
      const tinygltf::Primitive& prim = gmesh.primitives[p];
      const std::string where = path + ": " + meshName + ".primitives[" + std::to_string(p) + "]";
      const int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
      TM_CHECK(mode == TINYGLTF_MODE_TRIANGLES,
               located(where, std::string("mode ") + modeName(mode) + " is not supported (only TRIANGLES)"));
      if (!prim.targets.empty() && morphed.insert(instance.mesh).second)
        soup.notes.push_back({MeshFinding::Severity::Warning,
                              meshName + " has " + std::to_string(prim.targets.size()) +
                                  " morph targets: textured in its rest pose (the GLB export keeps the targets)",
                              {},
                              static_cast<int>(prim.targets.size())});
      const auto pos = prim.attributes.find("POSITION");
      TM_CHECK(pos != prim.attributes.end(), located(where, "has no POSITION attribute"));
      int comps;
      const std::vector<double> positions = readAccessor(gm, pos->second, where + ".POSITION", comps);
      TM_CHECK(comps == 3, located(where + ".POSITION", "is not a VEC3"));
      const size_t nv = positions.size() / 3;

      // Texture coordinates of the set the material's base colour texture uses (TEXCOORD_0 by default).
      int texCoordSet = 0;
      if (prim.material >= 0 && prim.material < static_cast<int>(gm.materials.size()))
        texCoordSet = std::max(0, gm.materials[prim.material].pbrMetallicRoughness.baseColorTexture.texCoord);
      std::vector<double> texcoords;
      const auto tc = prim.attributes.find("TEXCOORD_" + std::to_string(texCoordSet));
      if (tc != prim.attributes.end()) {
        texcoords = readAccessor(gm, tc->second, where + "." + tc->first, comps);
        TM_CHECK(comps == 2 && texcoords.size() == nv * 2,
                 located(where + "." + tc->first + " (accessor " + std::to_string(tc->second) + ")",
                         "must be a VEC2 with one element per vertex (" + std::to_string(nv) + ")"));
        soup.anyUV = true;
      }

      std::vector<size_t> indices;
      if (prim.indices >= 0) {
        const std::string at = where + ".indices (accessor " + std::to_string(prim.indices) + ")";
        const std::vector<double> raw = readAccessor(gm, prim.indices, where + ".indices", comps);
        TM_CHECK(comps == 1, located(at, "is not SCALAR"));
        indices.reserve(raw.size());
        for (double i : raw) {
          TM_CHECK(i >= 0 && i < static_cast<double>(nv),
                   located(at, "index " + number(i) + " is out of range (" + std::to_string(nv) + " vertices)"));
          indices.push_back(static_cast<size_t>(i));
        }
      } else {
        for (size_t i = 0; i < nv; ++i) indices.push_back(i);
      }
      TM_CHECK(indices.size() % 3 == 0,
               located(where, std::to_string(indices.size()) + " indices is not a multiple of 3 (TRIANGLES)"));

      // Primitives that share their vertex accessors share their vertices.
      const int tcAccessor = tc != prim.attributes.end() ? tc->second : -1;
      const auto shared = vertexBase.find({pos->second, tcAccessor});
      const int base = shared != vertexBase.end() ? shared->second : static_cast<int>(soup.vertices.size());
      if (shared == vertexBase.end()) {
        vertexBase.emplace(std::make_pair(pos->second, tcAccessor), base);
        // Normals, turned by the inverse transpose of the node's matrix (none: the mesh has no normals of its own).
        std::vector<double> normals;
        if (const auto n = prim.attributes.find("NORMAL"); n != prim.attributes.end()) {
          normals = readAccessor(gm, n->second, where + ".NORMAL", comps);
          TM_CHECK(comps == 3 && normals.size() == nv * 3,
                   located(where + ".NORMAL (accessor " + std::to_string(n->second) + ")",
                           "must be a VEC3 with one element per vertex (" + std::to_string(nv) + ")"));
        }
        soup.allNormals &= !normals.empty();
        const Eigen::Matrix3d normalMatrix = linear.inverse().transpose();
        for (size_t i = 0; i < nv && !normals.empty(); ++i) {
          const Vec3 n = normalMatrix * Vec3(normals[3 * i], normals[3 * i + 1], normals[3 * i + 2]);
          soup.normals.push_back(n.squaredNorm() > 0 ? Vec3(n.normalized()) : Vec3::Zero());
        }
        for (size_t i = 0; i < nv; ++i) {
          const Eigen::Vector4d h =
              instance.world * Eigen::Vector4d(positions[3 * i], positions[3 * i + 1], positions[3 * i + 2], 1);
          soup.vertices.emplace_back(h.head<3>());
          soup.vertexElement.push_back(static_cast<int>(i));
        }
      }
      auto mit = materialIndex.find(prim.material);
      if (mit == materialIndex.end()) {
        mit = materialIndex.emplace(prim.material, static_cast<int>(soup.materials.size())).first;
        soup.materials.push_back(gltfMaterial(gm, prim.material, path, withTextures));
      }
      int source = kSourceEmpty;
      if (prim.extras.IsObject() && prim.extras.Has("tm_source")) {
        const tinygltf::Value& s = prim.extras.Get("tm_source");
        TM_CHECK(s.IsNumber() && s.GetNumberAsDouble() == std::floor(s.GetNumberAsDouble()) &&
                     s.GetNumberAsDouble() >= kSourceEmpty,
                 located(where, "extras.tm_source must be an integer >= -2"));
        source = s.GetNumberAsInt();
        soup.anySource = true;
      }
      for (size_t t = 0; t + 2 < indices.size(); t += 3) {
        std::array<size_t, 3> c = {indices[t], indices[t + 1], indices[t + 2]};
        soup.triangleOrigin.push_back(
            {static_cast<int>(n),
             static_cast<int>(p),
             {base + static_cast<int>(c[0]), base + static_cast<int>(c[1]), base + static_cast<int>(c[2])}});
        if (mirrored) std::swap(c[1], c[2]);
        soup.triangles.push_back(
            {base + static_cast<int>(c[0]), base + static_cast<int>(c[1]), base + static_cast<int>(c[2])});
        std::array<Vec2, 3> tuv;
        for (int k = 0; k < 3; ++k)
          tuv[k] = texcoords.empty() ? Vec2::Zero() : Vec2(texcoords[2 * c[k]], 1.0 - texcoords[2 * c[k] + 1]);
        soup.uv.push_back(tuv);
        soup.triMaterial.push_back(mit->second);
        soup.triSource.push_back(source);
      }
    }
  }
  TM_CHECK(!soup.triangles.empty(), located(path, "no mesh of the scene has triangles"));
  if (!soup.anyUV) soup.uv.clear();
  return soup;
}

int appendView(std::vector<unsigned char>& bin, std::vector<tinygltf::BufferView>& views, const void* data, size_t size,
               int target, size_t stride) {
  while (bin.size() % 4) bin.push_back(0);
  tinygltf::BufferView view;
  view.buffer = 0;
  view.byteOffset = bin.size();
  view.byteLength = size;
  view.byteStride = stride;
  view.target = target;
  const auto* p = static_cast<const unsigned char*>(data);
  bin.insert(bin.end(), p, p + size);
  views.push_back(view);
  return static_cast<int>(views.size()) - 1;
}

int addTexture(tinygltf::Model& gm, const Material& mat, const std::string& name, int bufferView, int& sampler) {
  if (sampler < 0) {
    tinygltf::Sampler s;
    s.minFilter = TINYGLTF_TEXTURE_FILTER_LINEAR_MIPMAP_LINEAR;
    s.magFilter = TINYGLTF_TEXTURE_FILTER_LINEAR;
    s.wrapS = s.wrapT = TINYGLTF_TEXTURE_WRAP_REPEAT;
    gm.samplers.push_back(s);
    sampler = static_cast<int>(gm.samplers.size()) - 1;
  }
  tinygltf::Image image;
  image.name = mat.textureName.empty() ? name : mat.textureName;
  if (image.name.size() > 1 && image.name[0] == '.') image.name.erase(0, 1);  // a UDIM tile: ".1001"
  image.mimeType = "image/png";
  image.bufferView = bufferView;
  gm.images.push_back(image);
  tinygltf::Texture t;
  t.sampler = sampler;
  t.source = static_cast<int>(gm.images.size()) - 1;
  gm.textures.push_back(t);
  return static_cast<int>(gm.textures.size()) - 1;
}

void writeGlb(tinygltf::Model& gm, const std::string& path) {
  std::ostringstream out(std::ios::binary);
  tinygltf::TinyGLTF writer;
  TM_CHECK(writer.WriteGltfSceneToStream(&gm, out, false, true) && out,
           located(path, "cannot serialise the glTF model"));
  std::error_code ec;
  const fs::path parent = fs::path(path).parent_path();
  if (!parent.empty()) fs::create_directories(parent, ec);
  writeFileAtomic(path, out.str());
}

}  // namespace gltf

namespace {

TexturedModel loadGltfModel(const std::string& path) {
  gltf::Soup soup = gltf::readSoup(gltf::loadDocument(path, true), path, true);
  MeshLoadOptions options;
  options.weldIdenticalPositions = true;  // glTF splits vertices at UV seams; the surface is connected
  std::unique_ptr<Mesh> mesh = requireUsable(buildMesh(soup.vertices, soup.triangles, soup.uv, options, path));
  TexturedModel model;
  model.mesh = std::move(*mesh);
  model.materials = std::move(soup.materials);
  model.faceMaterial = perMeshFace(model.mesh, soup.triMaterial);
  if (soup.anySource) model.faceSource = perMeshFace(model.mesh, soup.triSource);
  if (soup.anyUV) {
    TM_ASSERT(model.mesh.cornerUV.size() == static_cast<size_t>(model.mesh.numFaces()));
    model.uv = floatUV(model.mesh.cornerUV);
  }
  return model;
}

// ---------------------------------------------------------------------------------------------
// glTF writing

struct GlbBuilder {
  tinygltf::Model gm;

  // Appends bytes to the single buffer and returns a new buffer view.
  int addView(const void* data, size_t size, int target) {
    return gltf::appendView(gm.buffers[0].data, gm.bufferViews, data, size, target);
  }

  template <int N>
  int addFloatAccessor(const std::vector<Eigen::Matrix<float, N, 1>>& values, int type, bool minMax) {
    tinygltf::Accessor acc;
    acc.bufferView = addView(values.data(), values.size() * sizeof(float) * N, TINYGLTF_TARGET_ARRAY_BUFFER);
    acc.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
    acc.count = values.size();
    acc.type = type;
    if (minMax) {
      Eigen::Matrix<float, N, 1> lo = values[0], hi = values[0];
      for (const auto& v : values) {
        lo = lo.cwiseMin(v);
        hi = hi.cwiseMax(v);
      }
      for (int k = 0; k < N; ++k) {
        acc.minValues.push_back(lo[k]);
        acc.maxValues.push_back(hi[k]);
      }
    }
    gm.accessors.push_back(acc);
    return static_cast<int>(gm.accessors.size()) - 1;
  }

  int addIndexAccessor(const std::vector<uint32_t>& indices) {
    tinygltf::Accessor acc;
    acc.bufferView = addView(indices.data(), indices.size() * sizeof(uint32_t), TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
    acc.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
    acc.count = indices.size();
    acc.type = TINYGLTF_TYPE_SCALAR;
    gm.accessors.push_back(acc);
    return static_cast<int>(gm.accessors.size()) - 1;
  }
};

// Area-weighted vertex normals, unit length (a face normal or +z where the area vanishes).
std::vector<Vec3> vertexNormals(const Mesh& mesh) {
  std::vector<Vec3> normals(mesh.numVertices(), Vec3::Zero());
  std::vector<Vec3> fallback(mesh.numVertices(), Vec3::Zero());
  for (int f = 0; f < mesh.numFaces(); ++f) {
    const auto p = mesh.facePositions(f);
    const Vec3 n = (p[1] - p[0]).cross(p[2] - p[0]);  // twice the area times the unit normal
    for (int v : mesh.faceVertices(f)) normals[v] += n;
  }
  for (Vec3& n : normals) {
    const double len = n.norm();
    n = len > 0 && std::isfinite(len) ? Vec3(n / len) : Vec3(0, 0, 1);
  }
  return normals;
}

}  // namespace

// ---------------------------------------------------------------------------------------------

LoadedMesh loadGltfMesh(const std::string& path, const MeshLoadOptions& options) {
  const std::string ext = lowerExtension(path);
  TM_CHECK(ext == ".glb" || ext == ".gltf", located(path, "not a glTF file (expected .glb or .gltf)"));
  return gltf::documentMesh(gltf::loadDocument(path, false), path, options);
}

namespace gltf {

LoadedMesh documentMesh(const tinygltf::Model& gm, const std::string& path, const MeshLoadOptions& options) {
  const Soup soup = readSoup(gm, path, false);
  LoadedMesh loaded = buildMesh(soup.vertices, soup.triangles, soup.uv, options, path);
  loaded.report.format = lowerExtension(path).substr(1);
  loaded.report.findings.insert(loaded.report.findings.end(), soup.notes.begin(), soup.notes.end());
  if (loaded.mesh) {
    Mesh& mesh = *loaded.mesh;
    mesh.faceMaterial = perMeshFace(mesh, soup.triMaterial);
    for (const Material& m : soup.materials) mesh.materialNames.push_back(m.name);
    if (soup.allNormals && soup.normals.size() == soup.vertices.size()) {  // every primitive has its normals
      mesh.cornerNormal.resize(mesh.numFaces());
      for (int f = 0; f < mesh.numFaces(); ++f) {
        const auto fv = mesh.faceVertices(f);
        for (int k = 0; k < 3; ++k) {
          const Vec3& n = soup.normals[mesh.vertexOrigin[fv[k]]];
          mesh.cornerNormal[f][k] = usableNormal(mesh, f, n);
        }
      }
    }
  }
  return loaded;
}

}  // namespace gltf

std::vector<int> meshFaceValues(const Mesh& mesh, const std::vector<int>& values) {
  const size_t nf = static_cast<size_t>(mesh.numFaces());
  if (values.size() == nf || values.empty()) return values;
  if (mesh.faceOrigin.size() == nf && std::all_of(mesh.faceOrigin.begin(), mesh.faceOrigin.end(),
                                                  [&](int o) { return o >= 0 && o < static_cast<int>(values.size()); }))
    return perMeshFace(mesh, values);
  return {};
}

const std::vector<unsigned char>& PngCache::encode(const cv::Mat& rgba, const std::string& where) {
  for (const auto& [texture, bytes] : cache_)
    if (texture.data == rgba.data && texture.size == rgba.size && texture.type() == rgba.type()) return bytes;
  const auto start = Clock::now();
  TM_CHECK(rgba.type() == CV_8UC4, located(where, "texture is not RGBA8"));
  cv::Mat alpha;
  cv::extractChannel(rgba, alpha, 3);
  double minAlpha = 0;
  cv::minMaxLoc(alpha, &minAlpha);
  cv::Mat rgb;
  if (minAlpha >= 255) cv::cvtColor(rgba, rgb, cv::COLOR_RGBA2RGB);  // opaque: no alpha channel
  std::vector<unsigned char> bytes = encodePng(minAlpha >= 255 ? rgb : rgba, where, compression_, false);
  ++encodes_;
  seconds_ += secondsSince(start);
  cache_.emplace_back(rgba, std::move(bytes));
  return cache_.back().second;
}

Vec3f TexturedModel::colorAt(int f, const Vec3& b) const {
  const Material* mat = faceMaterialPtr(*this, f);
  if (!mat) return kDefaultDiffuse;
  if (mat->texture.empty() || uv.empty() || f < 0 || f >= static_cast<int>(uv.size())) return mat->diffuse;
  const cv::Mat& tex = mat->texture;
  TM_ASSERT(tex.type() == CV_8UC4);
  const auto& t = uv[f];
  const double u = b[0] * t[0].x() + b[1] * t[1].x() + b[2] * t[2].x();
  const double v = b[0] * t[0].y() + b[1] * t[1].y() + b[2] * t[2].y();
  if (!std::isfinite(u) || !std::isfinite(v)) return mat->diffuse;
  const int w = tex.cols, h = tex.rows;
  // Pixel coordinates (photo.h convention, v up), then relative to pixel centres.
  double x = u * w - 0.5, y = (1.0 - v) * h - 0.5;
  x -= w * std::floor(x / w);  // repeat wrapping; x in [0, w)
  y -= h * std::floor(y / h);
  int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const double fx = x - x0, fy = y - y0;
  x0 = std::min(x0, w - 1);
  y0 = std::min(y0, h - 1);
  const int x1 = x0 + 1 == w ? 0 : x0 + 1;
  const int y1 = y0 + 1 == h ? 0 : y0 + 1;
  const auto* r0 = tex.ptr<cv::Vec4b>(y0);
  const auto* r1 = tex.ptr<cv::Vec4b>(y1);
  Vec3f out;
  for (int c = 0; c < 3; ++c) {
    const double top = (1 - fx) * r0[x0][c] + fx * r0[x1][c];
    const double bottom = (1 - fx) * r1[x0][c] + fx * r1[x1][c];
    out[c] = static_cast<float>(((1 - fy) * top + fy * bottom) / 255.0);
  }
  return mat->transform.apply(out);
}

TexturedModel loadModel(const std::string& path) {
  const std::string ext = lowerExtension(path);
  TM_CHECK(isMeshExtension(ext),
           located(path, "unsupported model format " + quote(ext.empty() ? "(no extension)" : ext) + " (expected " +
                             meshExtensionList() + ")"));
  std::error_code ec;
  TM_CHECK(fs::is_regular_file(path, ec), located(path, "file not found"));
  if (ext == ".obj") return loadObjModel(path);
  if (ext == ".glb" || ext == ".gltf") return loadGltfModel(path);
  // Plain mesh formats: untextured, one default material.
  std::unique_ptr<Mesh> mesh = requireUsable(loadMesh(path));
  TexturedModel model;
  model.mesh = std::move(*mesh);
  Material def;
  def.name = "default";
  model.materials.push_back(def);
  model.faceMaterial.assign(model.mesh.numFaces(), 0);
  return model;
}

std::string textureFileName(const std::string& base, const std::string& textureName) {
  return base + (textureName.rfind('.', 0) == 0 ? "" : "_") + fileNamePart(textureName) + ".png";
}

TexturedModel modelFromMesh(const Mesh& mesh, const cv::Mat& textureRgba, const std::string& textureName) {
  TM_CHECK(mesh.hasUV(), "modelFromMesh: the mesh has no texture coordinates");
  TM_CHECK(mesh.cornerUV.size() == static_cast<size_t>(mesh.numFaces()),
           "modelFromMesh: the mesh has " + std::to_string(mesh.cornerUV.size()) + " UV triples for " +
               std::to_string(mesh.numFaces()) + " faces");
  TexturedModel model;
  model.mesh = mesh;
  model.uv = floatUV(mesh.cornerUV);
  Material mat;
  mat.name = textureName.empty() ? "texture" : textureName;
  if (!textureRgba.empty()) {
    TM_CHECK(textureRgba.channels() == 4 || textureRgba.channels() == 3 || textureRgba.channels() == 1,
             "modelFromMesh: texture " + quote(mat.name) + " must have 1, 3 or 4 channels");
    mat.texture = toRgba8(textureRgba, false, "modelFromMesh: texture " + quote(mat.name));
  }
  model.materials.push_back(mat);
  model.faceMaterial.assign(mesh.numFaces(), 0);
  return model;
}

void exportObj(const TexturedModel& model, const std::string& dir, const std::string& base, PngCache* pngs) {
  const fs::path folder(dir);
  const std::string objPath = (folder / (base + ".obj")).string();
  checkModel(model, objPath);
  TM_CHECK(!base.empty() && base.find('/') == std::string::npos, located(dir, "invalid base name " + quote(base)));
  std::error_code ec;
  fs::create_directories(folder, ec);
  TM_CHECK(fs::is_directory(folder, ec), located(dir, "cannot create folder: " + ec.message()));

  const Mesh& mesh = model.mesh;
  const int nf = mesh.numFaces();

  // Material names as written: no whitespace, unique, non-empty (they also name the PNG files).
  std::vector<std::string> names;
  std::set<std::string> used;
  for (size_t m = 0; m < model.materials.size(); ++m) {
    std::string name = fileNamePart(model.materials[m].name);
    if (name.empty()) name = "material_" + std::to_string(m);
    std::string unique = name;
    for (int k = 2; used.count(unique); ++k) unique = name + "_" + std::to_string(k);
    used.insert(unique);
    names.push_back(unique);
  }
  const std::vector<std::string> materialNames = names.empty() ? std::vector<std::string>{"default"} : names;

  // Textures first, then the .mtl, then the .obj: an .obj on disk always has its companions. One PNG
  // per distinct texture, shared by the materials that show it.
  PngCache localPngs;
  PngCache& cache = pngs ? *pngs : localPngs;
  std::vector<std::pair<const uchar*, std::string>> written;  // texture data -> file name
  std::string mtl = "# TextureMontage\n";
  for (size_t m = 0; m < materialNames.size(); ++m) {
    const Material* mat = m < model.materials.size() ? &model.materials[m] : nullptr;
    // Consumers multiply map_Kd by Kd (the MTL format, three.js, Blender): a textured material's Kd is white, as the
    // GLB's base colour factor is; the diffuse colour is for untextured faces.
    const bool textured = mat && hasTexture(model, static_cast<int>(m));
    const Vec3f kd = textured ? Vec3f(1, 1, 1) : mat ? mat->diffuse : kDefaultDiffuse;
    mtl += "\nnewmtl " + materialNames[m] + "\nKa 0 0 0\nKd " + number(kd[0]) + " " + number(kd[1]) + " " +
           number(kd[2]) + "\nKs 0 0 0\nd 1\nillum 1\n";
    if (textured) {
      std::string png;
      for (const auto& [data, file] : written)
        if (data == mat->texture.data) png = file;
      if (png.empty()) {
        png = textureFileName(base, mat->textureName.empty() ? materialNames[m] : mat->textureName);
        const std::vector<unsigned char>& bytes = cache.encode(mat->texture, (folder / png).string());
        writeFileAtomic((folder / png).string(), std::string(bytes.begin(), bytes.end()));
        written.emplace_back(mat->texture.data, png);
      }
      mtl += "map_Kd " + png + "\n";
    }
  }
  writeFileAtomic((folder / (base + ".mtl")).string(), mtl);

  std::string obj;
  obj.reserve(static_cast<size_t>(mesh.numVertices()) * 40 + static_cast<size_t>(nf) * 60);
  obj += "# TextureMontage\nmtllib " + base + ".mtl\no " + fileNamePart(model.name.empty() ? base : model.name) + "\n";
  for (int v = 0; v < mesh.numVertices(); ++v) {
    const Vec3 p = mesh.position(v);
    obj += "v " + number(p.x()) + " " + number(p.y()) + " " + number(p.z()) + "\n";
  }
  // Normals: the mesh's own per corner (the file's, hard edges kept), one vn per distinct normal; else one per
  // vertex, area-weighted as the GLB's (without normals viewers shade every face flat).
  std::vector<std::array<int, 3>> vn(nf);
  if (mesh.cornerNormal.size() == static_cast<size_t>(nf)) {
    struct Bits {  // a normal's float bits, hashed
      size_t operator()(const std::array<uint32_t, 3>& b) const {
        return (size_t(b[0]) * 73856093u) ^ (size_t(b[1]) * 19349663u) ^ (size_t(b[2]) * 83492791u);
      }
    };
    std::unordered_map<std::array<uint32_t, 3>, int, Bits> index;
    for (int f = 0; f < nf; ++f)
      for (int k = 0; k < 3; ++k) {
        const Vec3f& n = mesh.cornerNormal[f][k];
        std::array<uint32_t, 3> bits;
        std::memcpy(bits.data(), n.data(), 12);
        const auto [it, inserted] = index.emplace(bits, int(index.size()) + 1);
        if (inserted) obj += "vn " + number(n.x()) + " " + number(n.y()) + " " + number(n.z()) + "\n";
        vn[f][k] = it->second;
      }
  } else {
    for (const Vec3& n : vertexNormals(mesh))
      obj += "vn " + number(n.x()) + " " + number(n.y()) + " " + number(n.z()) + "\n";
    for (int f = 0; f < nf; ++f) {
      const auto fv = mesh.faceVertices(f);
      for (int k = 0; k < 3; ++k) vn[f][k] = fv[k] + 1;
    }
  }
  // One vt per distinct corner UV, in order of first use.
  std::vector<std::array<int, 3>> vt;
  if (model.textured()) {
    std::unordered_map<uint64_t, int> index;
    vt.resize(nf);
    for (int f = 0; f < nf; ++f)
      for (int k = 0; k < 3; ++k) {
        const Vec2f& t = model.uv[f][k];
        uint32_t bu, bv;
        std::memcpy(&bu, &t.x(), 4);
        std::memcpy(&bv, &t.y(), 4);
        const auto [it, inserted] = index.emplace((uint64_t(bu) << 32) | bv, static_cast<int>(index.size()) + 1);
        if (inserted) obj += "vt " + number(t.x()) + " " + number(t.y()) + "\n";
        vt[f][k] = it->second;
      }
  }
  // With sources: faces ordered by (source, material), model order within each, so that every group
  // and material appears once: tools list one object per group (the model's own order interleaves
  // them). Without: the model's order, with the mesh's own groups, as a loaded mesh had them.
  std::vector<int> order(nf);
  std::iota(order.begin(), order.end(), 0);
  const bool bySource = !model.faceSource.empty();
  if (bySource)
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
      const int sa = model.faceSource[a], sb = model.faceSource[b];
      return sa != sb ? sa < sb : materialOf(model, a) < materialOf(model, b);
    });
  const std::vector<int> meshGroup = bySource ? std::vector<int>{} : meshFaceValues(mesh, mesh.faceGroup);
  const auto groupOf = [&](int f) { return bySource ? model.faceSource[f] : meshGroup.empty() ? -1 : meshGroup[f]; };
  // A face corner as the OBJ names it: vertex, texture coordinate (0: none), normal.
  using Corner = std::array<int, 3>;
  const auto corner = [&](int f, int k) {
    return Corner{mesh.faceVertices(f)[k] + 1, vt.empty() ? 0 : vt[f][k], vn[f][k]};
  };
  // The file's polygon that faces order[i..j) were cut from, as one face: they fan around one corner, every corner
  // they share has one texture coordinate and one normal, and they share group and material. Empty otherwise (its
  // triangles are written, e.g. where a chart border crosses the polygon).
  const auto polygonOf = [&](size_t i, size_t j) -> std::vector<Corner> {
    for (size_t q = i + 1; q < j; ++q)
      if (groupOf(order[q]) != groupOf(order[i]) || materialOf(model, order[q]) != materialOf(model, order[i]))
        return {};
    for (int c = 0; c < 3; ++c) {
      const Corner center = corner(order[i], c);
      std::vector<Corner> out = {center};
      for (size_t q = i; q < j && !out.empty(); ++q) {
        int k = 0;
        while (k < 3 && corner(order[q], k) != center) ++k;
        if (k == 3 || (q > i && corner(order[q], (k + 1) % 3) != out.back())) {
          out.clear();
          break;
        }
        if (q == i) out.push_back(corner(order[q], (k + 1) % 3));
        out.push_back(corner(order[q], (k + 2) % 3));
      }
      if (!out.empty() && out.back() != out[1]) return out;
    }
    return {};
  };
  const auto writeFace = [&](const std::vector<Corner>& corners) {
    obj += "f";
    for (const Corner& c : corners)
      obj += " " + std::to_string(c[0]) + "/" + (c[1] ? std::to_string(c[1]) : "") + "/" + std::to_string(c[2]);
    obj += "\n";
  };
  const bool polygons = !bySource && mesh.facePolygon.size() == static_cast<size_t>(nf);
  bool firstGroup = true;
  int group = 0, material = -1;
  for (size_t i = 0; i < order.size();) {
    const int f = order[i];
    const int g = groupOf(f);
    if ((bySource || !meshGroup.empty()) && (firstGroup || g != group)) {
      group = g;
      firstGroup = false;
      if (bySource)
        obj += "g " + sourceGroupName(group) + "\n";
      else
        obj += "g " + (g >= 0 && g < static_cast<int>(mesh.groupNames.size()) ? mesh.groupNames[g] : "default") + "\n";
      material = -1;  // restate the material in every group
    }
    const int m = materialOf(model, f);
    if (m != material) {
      obj += "usemtl " + materialNames[std::min<size_t>(m, materialNames.size() - 1)] + "\n";
      material = m;
    }
    size_t j = i + 1;
    while (polygons && j < order.size() && mesh.facePolygon[order[j]] == mesh.facePolygon[f]) ++j;
    const std::vector<Corner> polygon = j > i + 1 ? polygonOf(i, j) : std::vector<Corner>{};
    if (!polygon.empty()) {
      writeFace(polygon);
      i = j;
    } else {
      writeFace({corner(f, 0), corner(f, 1), corner(f, 2)});
      ++i;
    }
  }
  writeFileAtomic(objPath, obj);
}

void exportGlb(const TexturedModel& model, const std::string& path, PngCache* pngs) {
  checkModel(model, path);
  const Mesh& mesh = model.mesh;
  const int nf = mesh.numFaces();
  const std::vector<Vec3> normals = vertexNormals(mesh);
  PngCache localPngs;
  PngCache& cache = pngs ? *pngs : localPngs;
  const std::string name = model.name.empty() ? "model" : model.name;

  GlbBuilder b;
  tinygltf::Model& gm = b.gm;
  gm.asset.version = "2.0";
  gm.asset.generator = "TextureMontage";
  gm.buffers.emplace_back();

  // Materials actually used, in model order; textured ones get a texture (one per distinct image,
  // shared by the materials that show it) and a shared sampler.
  std::map<int, int> materialIndex;
  for (int f = 0; f < nf; ++f) materialIndex.emplace(materialOf(model, f), 0);
  int sampler = -1;
  std::vector<std::pair<const uchar*, int>> textures;  // image data -> glTF texture
  for (auto& [m, index] : materialIndex) {
    tinygltf::Material out;
    const Material* mat = m < static_cast<int>(model.materials.size()) ? &model.materials[m] : nullptr;
    out.name = mat && !mat->name.empty() ? mat->name : "material_" + std::to_string(m);
    out.pbrMetallicRoughness.metallicFactor = 0;
    out.pbrMetallicRoughness.roughnessFactor = 1;
    out.doubleSided = false;
    if (mat && hasTexture(model, m)) {
      int texture = -1;
      for (const auto& [data, t] : textures)
        if (data == mat->texture.data) texture = t;
      if (texture < 0) {
        const std::vector<unsigned char>& png = cache.encode(mat->texture, path + ": texture " + quote(out.name));
        texture = gltf::addTexture(gm, *mat, out.name, b.addView(png.data(), png.size(), 0), sampler);
        textures.emplace_back(mat->texture.data, texture);
      }
      out.pbrMetallicRoughness.baseColorTexture.index = texture;
    } else {
      const Vec3f kd = mat ? mat->diffuse : kDefaultDiffuse;
      out.pbrMetallicRoughness.baseColorFactor = {srgbToLinear(kd[0]), srgbToLinear(kd[1]), srgbToLinear(kd[2]), 1.0};
    }
    gm.materials.push_back(out);
    index = static_cast<int>(gm.materials.size()) - 1;
  }

  // One vertex list for all primitives: the mesh's vertices in order (each with the texture coordinate and normal
  // of its first use), then a copy per further (vertex, texture coordinate, normal). Normals: the mesh's own per
  // corner (the file's, hard edges kept), else area-weighted per vertex.
  const bool withUV = model.textured(), ownNormals = mesh.cornerNormal.size() == static_cast<size_t>(nf);
  const int nv = mesh.numVertices();
  std::vector<Vec3f> positions(nv), vnormals(nv);
  std::vector<Vec2f> texcoords(withUV ? nv : 0, Vec2f::Zero());
  std::vector<char> assigned(nv, 0);
  for (int v = 0; v < nv; ++v) {
    positions[v] = mesh.position(v).cast<float>();
    vnormals[v] = normals[v].cast<float>().normalized();
  }
  std::map<std::array<uint32_t, 6>, uint32_t> copies;  // vertex, texture coordinate, normal (bits) -> its copy
  std::vector<std::array<uint32_t, 3>> corner(nf);
  for (int f = 0; f < nf; ++f) {
    const auto fv = mesh.faceVertices(f);
    for (int k = 0; k < 3; ++k) {
      const int v = fv[k];
      const Vec2f t = withUV ? Vec2f(model.uv[f][k].x(), 1.0f - model.uv[f][k].y())  // glTF: origin at the top-left
                             : Vec2f::Zero();
      const Vec3f n = ownNormals ? mesh.cornerNormal[f][k] : vnormals[v];
      if (!assigned[v]) {
        assigned[v] = 1;
        if (withUV) texcoords[v] = t;
        vnormals[v] = n;
      }
      if ((!withUV || texcoords[v] == t) && vnormals[v] == n) {
        corner[f][k] = static_cast<uint32_t>(v);
        continue;
      }
      std::array<uint32_t, 6> key{static_cast<uint32_t>(v)};
      std::memcpy(&key[1], t.data(), 8);
      std::memcpy(&key[3], n.data(), 12);
      const auto [it, inserted] = copies.emplace(key, static_cast<uint32_t>(positions.size()));
      if (inserted) {
        positions.push_back(positions[v]);
        vnormals.push_back(n);
        if (withUV) texcoords.push_back(t);
      }
      corner[f][k] = it->second;
    }
  }
  const int positionAccessor = b.addFloatAccessor<3>(positions, TINYGLTF_TYPE_VEC3, true);
  const int normalAccessor = b.addFloatAccessor<3>(vnormals, TINYGLTF_TYPE_VEC3, false);
  const int uvAccessor = withUV ? b.addFloatAccessor<2>(texcoords, TINYGLTF_TYPE_VEC2, false) : -1;

  // One primitive per (material, source); faces keep their model order inside a primitive.
  std::map<std::pair<int, int>, std::vector<int>> groups;
  for (int f = 0; f < nf; ++f)
    groups[{materialOf(model, f), model.faceSource.empty() ? 0 : model.faceSource[f]}].push_back(f);

  tinygltf::Mesh gmesh;
  gmesh.name = name;
  for (const auto& [key, faces] : groups) {
    std::vector<uint32_t> indices;
    indices.reserve(faces.size() * 3);
    for (int f : faces) indices.insert(indices.end(), corner[f].begin(), corner[f].end());
    tinygltf::Primitive prim;
    prim.mode = TINYGLTF_MODE_TRIANGLES;
    prim.material = materialIndex.at(key.first);
    prim.attributes["POSITION"] = positionAccessor;
    prim.attributes["NORMAL"] = normalAccessor;
    if (withUV) prim.attributes["TEXCOORD_0"] = uvAccessor;
    prim.indices = b.addIndexAccessor(indices);
    if (!model.faceSource.empty()) {
      tinygltf::Value::Object extras;
      extras["tm_source"] = tinygltf::Value(key.second);
      prim.extras = tinygltf::Value(extras);
    }
    gmesh.primitives.push_back(prim);
  }
  gm.meshes.push_back(gmesh);
  tinygltf::Node node;
  node.name = name;
  node.mesh = 0;
  gm.nodes.push_back(node);
  tinygltf::Scene scene;
  scene.nodes.push_back(0);
  gm.scenes.push_back(scene);
  gm.defaultScene = 0;
  gltf::writeGlb(gm, path);
}

}  // namespace montage
