// A scene Assimp read (an FBX or Collada character, a mesh with several UV sets or vertex colours) in glTF form, so
// that the model reader and the write-back export treat it as they treat a GLB: its node hierarchy, skins, joint
// weights, morph targets, UV sets, colours and animations come back out in model.glb with the montage in it.
#include "io/assimp_gltf.h"

#include <assimp/scene.h>
#include <tiny_gltf.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "base/common.h"
#include "io/gltf_document.h"

namespace montage::gltf {

namespace {

// Builds the document's accessors in one buffer.
class Writer {
 public:
  explicit Writer(tinygltf::Model& gm) : gm_(gm) {}

  // An accessor of `count` elements of `type` (TINYGLTF_TYPE_*) made of `componentType`; `min`/`max` for POSITION.
  template <class T>
  int accessor(const std::vector<T>& data, size_t count, int type, int componentType, int target,
               bool withBounds = false) {
    tinygltf::Accessor a;
    a.bufferView = appendView(bin_, gm_.bufferViews, data.data(), data.size() * sizeof(T), target);
    a.count = count;
    a.type = type;
    a.componentType = componentType;
    if (withBounds && count > 0) {
      const int n = int(data.size() / count);
      a.minValues.assign(n, std::numeric_limits<double>::infinity());
      a.maxValues.assign(n, -std::numeric_limits<double>::infinity());
      for (size_t i = 0; i < data.size(); ++i) {
        a.minValues[i % n] = std::min(a.minValues[i % n], double(data[i]));
        a.maxValues[i % n] = std::max(a.maxValues[i % n], double(data[i]));
      }
    }
    gm_.accessors.push_back(a);
    return int(gm_.accessors.size()) - 1;
  }
  void finish() {
    tinygltf::Buffer buffer;
    buffer.data = std::move(bin_);
    gm_.buffers = {buffer};
  }

 private:
  tinygltf::Model& gm_;
  std::vector<unsigned char> bin_;
};

std::vector<double> columnMajor(const aiMatrix4x4& m) {
  std::vector<double> out(16);
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) out[c * 4 + r] = m[r][c];
  return out;
}

// A node's transform as translation, rotation and scale (animations may only target those), or as a matrix when
// it has a shear they cannot give.
void setTransform(tinygltf::Node& node, const aiMatrix4x4& m) {
  if (m.IsIdentity()) return;
  aiVector3D scale, position;
  aiQuaternion rotation;
  m.Decompose(scale, rotation, position);
  rotation.Normalize();
  const aiMatrix4x4 again(scale, rotation, position);
  double error = 0, size = 0;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      error = std::max(error, std::abs(double(again[r][c] - m[r][c]))),
      size = std::max(size, std::abs(double(m[r][c])));
  if (!(error <= 1e-5 * std::max(1.0, size))) {
    node.matrix = columnMajor(m);
    return;
  }
  if (position != aiVector3D(0, 0, 0)) node.translation = {position.x, position.y, position.z};
  if (!(rotation.x == 0 && rotation.y == 0 && rotation.z == 0))
    node.rotation = {rotation.x, rotation.y, rotation.z, rotation.w};
  if (scale != aiVector3D(1, 1, 1)) node.scale = {scale.x, scale.y, scale.z};
}

}  // namespace

bool assimpSceneNeedsGltf(const aiScene& scene) {
  for (unsigned i = 0; i < scene.mNumMeshes; ++i) {
    const aiMesh& m = *scene.mMeshes[i];
    if (m.HasBones() || m.mNumAnimMeshes > 0 || m.GetNumUVChannels() > 1 || m.GetNumColorChannels() > 0) return true;
  }
  return false;
}

std::string assimpSceneAsGlb(const aiScene& scene) {
  tinygltf::Model gm;
  gm.asset.version = "2.0";
  gm.asset.generator = "TextureMontage (from Assimp)";
  Writer w(gm);

  // Nodes, depth first, as Assimp holds them.
  std::map<std::string, int> nodeByName;
  std::vector<const aiNode*> nodes;
  const auto addNode = [&](const auto& self, const aiNode* n) -> int {
    const int index = int(gm.nodes.size());
    gm.nodes.emplace_back();
    nodes.push_back(n);
    gm.nodes[index].name = n->mName.C_Str();
    setTransform(gm.nodes[index], n->mTransformation);
    nodeByName.emplace(n->mName.C_Str(), index);
    for (unsigned c = 0; c < n->mNumChildren; ++c) {
      const int child = self(self, n->mChildren[c]);
      gm.nodes[index].children.push_back(child);
    }
    return index;
  };
  const int root = addNode(addNode, scene.mRootNode);
  tinygltf::Scene s;
  s.nodes = {root};
  gm.scenes = {s};
  gm.defaultScene = 0;

  // Materials: names and base colours (the file's textures are not carried: the montage replaces the base colour).
  for (unsigned i = 0; i < scene.mNumMaterials; ++i) {
    const aiMaterial& m = *scene.mMaterials[i];
    tinygltf::Material mat;
    mat.name = m.GetName().C_Str();
    aiColor4D diffuse(1, 1, 1, 1);
    if (m.Get(AI_MATKEY_COLOR_DIFFUSE, diffuse) == AI_SUCCESS)
      mat.pbrMetallicRoughness.baseColorFactor = {std::clamp<double>(diffuse.r, 0, 1),
                                                  std::clamp<double>(diffuse.g, 0, 1),
                                                  std::clamp<double>(diffuse.b, 0, 1), 1.0};
    mat.pbrMetallicRoughness.metallicFactor = 0;
    gm.materials.push_back(mat);
  }

  // One glTF mesh per node that shows meshes, a primitive per Assimp mesh, a skin per node whose meshes have bones.
  for (size_t ni = 0; ni < nodes.size(); ++ni) {
    const aiNode& node = *nodes[ni];
    if (node.mNumMeshes == 0) continue;
    tinygltf::Mesh mesh;
    mesh.name = node.mName.C_Str();
    std::vector<int> joints;  // node indices of the skin's joints
    std::vector<float> inverseBinds;
    std::map<std::string, int> jointOf;
    size_t targets = 0;
    for (unsigned k = 0; k < node.mNumMeshes; ++k)
      targets = std::max<size_t>(targets, scene.mMeshes[node.mMeshes[k]]->mNumAnimMeshes);
    for (unsigned k = 0; k < node.mNumMeshes; ++k) {
      const aiMesh& m = *scene.mMeshes[node.mMeshes[k]];
      if (!(m.mPrimitiveTypes & aiPrimitiveType_TRIANGLE)) continue;
      const size_t nv = m.mNumVertices;
      tinygltf::Primitive p;
      p.mode = TINYGLTF_MODE_TRIANGLES;
      if (m.mMaterialIndex < gm.materials.size()) p.material = int(m.mMaterialIndex);
      std::vector<float> pos(3 * nv);
      for (size_t v = 0; v < nv; ++v)
        for (int d = 0; d < 3; ++d) pos[3 * v + d] = m.mVertices[v][d];
      p.attributes["POSITION"] =
          w.accessor(pos, nv, TINYGLTF_TYPE_VEC3, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TARGET_ARRAY_BUFFER, true);
      if (m.HasNormals()) {
        std::vector<float> nrm(3 * nv);
        for (size_t v = 0; v < nv; ++v) {
          aiVector3D n = m.mNormals[v];
          const float len = n.Length();
          n = len > 0 && std::isfinite(len) ? n / len : aiVector3D(0, 0, 1);
          for (int d = 0; d < 3; ++d) nrm[3 * v + d] = n[d];
        }
        p.attributes["NORMAL"] =
            w.accessor(nrm, nv, TINYGLTF_TYPE_VEC3, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TARGET_ARRAY_BUFFER);
      }
      for (unsigned set = 0, out = 0; set < AI_MAX_NUMBER_OF_TEXTURECOORDS; ++set) {
        if (!m.HasTextureCoords(set)) continue;
        std::vector<float> uv(2 * nv);
        for (size_t v = 0; v < nv; ++v)
          uv[2 * v] = m.mTextureCoords[set][v].x, uv[2 * v + 1] = 1.0f - m.mTextureCoords[set][v].y;  // glTF: v down
        p.attributes["TEXCOORD_" + std::to_string(out++)] =
            w.accessor(uv, nv, TINYGLTF_TYPE_VEC2, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TARGET_ARRAY_BUFFER);
      }
      for (unsigned set = 0, out = 0; set < AI_MAX_NUMBER_OF_COLOR_SETS; ++set) {
        if (!m.HasVertexColors(set)) continue;
        std::vector<float> colour(4 * nv);
        for (size_t v = 0; v < nv; ++v) {
          const aiColor4D& c = m.mColors[set][v];
          const float rgba[4] = {c.r, c.g, c.b, c.a};
          for (int d = 0; d < 4; ++d) colour[4 * v + d] = std::clamp(std::isfinite(rgba[d]) ? rgba[d] : 0.f, 0.f, 1.f);
        }
        p.attributes["COLOR_" + std::to_string(out++)] =
            w.accessor(colour, nv, TINYGLTF_TYPE_VEC4, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TARGET_ARRAY_BUFFER);
      }
      if (m.HasBones()) {
        // The four largest weights of each vertex, normalised (glTF's JOINTS_0 / WEIGHTS_0).
        std::vector<std::vector<std::pair<float, int>>> influences(nv);
        for (unsigned b = 0; b < m.mNumBones; ++b) {
          const aiBone& bone = *m.mBones[b];
          const std::string name = bone.mName.C_Str();
          auto [it, added] = jointOf.emplace(name, int(joints.size()));
          if (added) {
            const auto node = nodeByName.find(name);
            TM_CHECK(node != nodeByName.end(), "the bone '" + name + "' has no node in the scene");
            joints.push_back(node->second);
            for (double x : columnMajor(bone.mOffsetMatrix)) inverseBinds.push_back(float(x));
          }
          for (unsigned i = 0; i < bone.mNumWeights; ++i) {
            const aiVertexWeight& vw = bone.mWeights[i];
            if (vw.mVertexId < nv && vw.mWeight > 0) influences[vw.mVertexId].push_back({vw.mWeight, it->second});
          }
        }
        std::vector<uint16_t> jointIndex(4 * nv, 0);
        std::vector<float> weight(4 * nv, 0.f);
        for (size_t v = 0; v < nv; ++v) {
          auto& in = influences[v];
          std::sort(in.begin(), in.end(),
                    [](auto& a, auto& b) { return a.first > b.first || (a.first == b.first && a.second < b.second); });
          if (in.size() > 4) in.resize(4);
          float sum = 0;
          for (auto& [wgt, j] : in) sum += wgt;
          for (size_t i = 0; i < in.size(); ++i)
            jointIndex[4 * v + i] = uint16_t(in[i].second), weight[4 * v + i] = in[i].first / sum;
          if (in.empty()) weight[4 * v] = 1;  // an unweighted vertex follows the skin's first joint
        }
        p.attributes["JOINTS_0"] = w.accessor(jointIndex, nv, TINYGLTF_TYPE_VEC4,
                                              TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT, TINYGLTF_TARGET_ARRAY_BUFFER);
        p.attributes["WEIGHTS_0"] =
            w.accessor(weight, nv, TINYGLTF_TYPE_VEC4, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TARGET_ARRAY_BUFFER);
      }
      // Morph targets: glTF keeps the displacement from the base. Every primitive of a mesh needs as many targets
      // (a zero displacement where this mesh has fewer).
      for (size_t t = 0; t < targets; ++t) {
        std::vector<float> delta(3 * nv, 0.f);
        if (t < m.mNumAnimMeshes && m.mAnimMeshes[t]->mVertices && m.mAnimMeshes[t]->mNumVertices == nv)
          for (size_t v = 0; v < nv; ++v)
            for (int d = 0; d < 3; ++d) delta[3 * v + d] = m.mAnimMeshes[t]->mVertices[v][d] - m.mVertices[v][d];
        std::map<std::string, int> target;
        target["POSITION"] = w.accessor(delta, nv, TINYGLTF_TYPE_VEC3, TINYGLTF_COMPONENT_TYPE_FLOAT,
                                        TINYGLTF_TARGET_ARRAY_BUFFER, true);
        p.targets.push_back(target);
      }
      std::vector<uint32_t> indices;
      indices.reserve(3 * m.mNumFaces);
      for (unsigned f = 0; f < m.mNumFaces; ++f)
        if (m.mFaces[f].mNumIndices == 3) indices.insert(indices.end(), m.mFaces[f].mIndices, m.mFaces[f].mIndices + 3);
      if (indices.empty()) continue;
      p.indices = w.accessor(indices, indices.size(), TINYGLTF_TYPE_SCALAR, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT,
                             TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
      mesh.primitives.push_back(p);
    }
    if (mesh.primitives.empty()) continue;
    if (targets > 0) {
      mesh.weights.assign(targets, 0.0);
      const aiMesh& first = *scene.mMeshes[node.mMeshes[0]];
      std::vector<std::string> names;
      // Weights 0: the rest pose the montage textured (Assimp gives a shape's full weight, not its current one).
      for (size_t t = 0; t < targets; ++t)
        names.push_back(t < first.mNumAnimMeshes ? first.mAnimMeshes[t]->mName.C_Str() : "");
      // The names as Blender's and three.js's importers read them.
      mesh.extras = tinygltf::Value(tinygltf::Value::Object{
          {"targetNames", tinygltf::Value(std::vector<tinygltf::Value>(names.begin(), names.end()))}});
    }
    gm.nodes[ni].mesh = int(gm.meshes.size());
    gm.meshes.push_back(mesh);
    if (!joints.empty()) {
      tinygltf::Skin skin;
      skin.name = mesh.name;
      skin.joints = joints;
      skin.inverseBindMatrices =
          w.accessor(inverseBinds, joints.size(), TINYGLTF_TYPE_MAT4, TINYGLTF_COMPONENT_TYPE_FLOAT, -1);
      gm.nodes[ni].skin = int(gm.skins.size());
      gm.skins.push_back(skin);
    }
  }

  // Animations of the nodes (translation, rotation, scale), linear, in seconds.
  for (unsigned a = 0; a < scene.mNumAnimations; ++a) {
    const aiAnimation& anim = *scene.mAnimations[a];
    const double ticks = anim.mTicksPerSecond > 0 ? anim.mTicksPerSecond : 25.0;
    tinygltf::Animation out;
    out.name = anim.mName.C_Str();
    for (unsigned c = 0; c < anim.mNumChannels; ++c) {
      const aiNodeAnim& ch = *anim.mChannels[c];
      const auto node = nodeByName.find(ch.mNodeName.C_Str());
      if (node == nodeByName.end()) continue;
      const auto add = [&](const char* path, unsigned count, auto key, int type) {
        if (count == 0) return;
        std::vector<float> times(count), values;
        float last = -1;
        for (unsigned i = 0; i < count; ++i) {
          const auto [time, value] = key(i);
          times[i] = std::max(float(time / ticks), last + 1e-6f);  // glTF asks for increasing times
          last = times[i];
          values.insert(values.end(), value.begin(), value.end());
        }
        tinygltf::AnimationSampler sampler;
        sampler.input = w.accessor(times, count, TINYGLTF_TYPE_SCALAR, TINYGLTF_COMPONENT_TYPE_FLOAT, -1, true);
        sampler.output = w.accessor(values, count, type, TINYGLTF_COMPONENT_TYPE_FLOAT, -1);
        sampler.interpolation = "LINEAR";
        out.samplers.push_back(sampler);
        tinygltf::AnimationChannel channel;
        channel.sampler = int(out.samplers.size()) - 1;
        channel.target_node = node->second;
        channel.target_path = path;
        out.channels.push_back(channel);
      };
      const auto vec3 = [](const aiVectorKey& k) {
        return std::pair{k.mTime, std::vector<float>{float(k.mValue.x), float(k.mValue.y), float(k.mValue.z)}};
      };
      add(
          "translation", ch.mNumPositionKeys, [&](unsigned i) { return vec3(ch.mPositionKeys[i]); },
          TINYGLTF_TYPE_VEC3);
      add(
          "rotation", ch.mNumRotationKeys,
          [&](unsigned i) {
            aiQuaternion q = ch.mRotationKeys[i].mValue;
            q.Normalize();
            return std::pair{ch.mRotationKeys[i].mTime,
                             std::vector<float>{float(q.x), float(q.y), float(q.z), float(q.w)}};
          },
          TINYGLTF_TYPE_VEC4);
      add(
          "scale", ch.mNumScalingKeys, [&](unsigned i) { return vec3(ch.mScalingKeys[i]); }, TINYGLTF_TYPE_VEC3);
    }
    if (!out.channels.empty()) gm.animations.push_back(out);
  }
  TM_CHECK(!gm.meshes.empty(), "the scene holds no triangles");
  w.finish();
  std::ostringstream bytes(std::ios::binary);
  tinygltf::TinyGLTF writer;
  TM_CHECK(writer.WriteGltfSceneToStream(&gm, bytes, false, true) && bytes, "cannot serialise the scene as glTF");
  return bytes.str();
}

}  // namespace montage::gltf
