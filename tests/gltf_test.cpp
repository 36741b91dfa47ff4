// glTF 2.0 mesh input (io/model.h: loadGltfMesh, and loadMesh / loadModel through it): every mesh instance with
// its node's transform, mirrored instances turned over, the base colour texture's UV set, material names, skins
// and morph targets in rest pose with a warning, errors that name the mesh, primitive and accessor. The GLBs are
// made here with tinygltf; one is the shared data's spot written as a GLB.
#include <tiny_gltf.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>

#include "base/fileio.h"
#include "io/mesh_io.h"
#include "io/model.h"
#include "test_support.h"

namespace fs = std::filesystem;
using namespace montage;

namespace {

// A glTF model under construction: one buffer, accessors appended to it.
struct GltfMaker {
  tinygltf::Model m;
  GltfMaker() {
    m.asset.version = "2.0";
    m.buffers.emplace_back();
  }
  int view(const void* data, size_t size) {
    auto& bytes = m.buffers[0].data;
    while (bytes.size() % 4) bytes.push_back(0);
    tinygltf::BufferView v;
    v.buffer = 0;
    v.byteOffset = bytes.size();
    v.byteLength = size;
    const auto* p = static_cast<const unsigned char*>(data);
    bytes.insert(bytes.end(), p, p + size);
    m.bufferViews.push_back(v);
    return static_cast<int>(m.bufferViews.size()) - 1;
  }
  // Floats, `n` per element (2 or 3).
  int floats(const std::vector<float>& values, int n) {
    tinygltf::Accessor a;
    a.bufferView = view(values.data(), values.size() * sizeof(float));
    a.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
    a.count = values.size() / n;
    a.type = n == 2 ? TINYGLTF_TYPE_VEC2 : TINYGLTF_TYPE_VEC3;
    if (n == 3) {  // POSITION needs its bounds
      a.minValues.assign(3, 1e30);
      a.maxValues.assign(3, -1e30);
      for (size_t i = 0; i < values.size(); ++i) {
        a.minValues[i % 3] = std::min<double>(a.minValues[i % 3], values[i]);
        a.maxValues[i % 3] = std::max<double>(a.maxValues[i % 3], values[i]);
      }
    }
    m.accessors.push_back(a);
    return static_cast<int>(m.accessors.size()) - 1;
  }
  int indices(const std::vector<uint32_t>& values) {
    tinygltf::Accessor a;
    a.bufferView = view(values.data(), values.size() * sizeof(uint32_t));
    a.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
    a.count = values.size();
    a.type = TINYGLTF_TYPE_SCALAR;
    m.accessors.push_back(a);
    return static_cast<int>(m.accessors.size()) - 1;
  }
  int material(const std::string& name, int texCoord = -1) {
    tinygltf::Material mat;
    mat.name = name;
    if (texCoord >= 0) {
      mat.pbrMetallicRoughness.baseColorTexture.index = 0;
      mat.pbrMetallicRoughness.baseColorTexture.texCoord = texCoord;
    }
    m.materials.push_back(mat);
    return static_cast<int>(m.materials.size()) - 1;
  }
  int node(int mesh, const std::vector<double>& translation = {}, const std::vector<double>& scale = {}) {
    tinygltf::Node n;
    n.mesh = mesh;
    n.translation = translation;
    n.scale = scale;
    m.nodes.push_back(n);
    return static_cast<int>(m.nodes.size()) - 1;
  }
  std::string save(const std::string& dir, const std::string& name) {
    if (m.scenes.empty() && !m.nodes.empty()) {
      tinygltf::Scene s;
      for (size_t i = 0; i < m.nodes.size(); ++i) s.nodes.push_back(static_cast<int>(i));
      m.scenes.push_back(s);
      m.defaultScene = 0;
    }
    const std::string path = (fs::path(dir) / name).string();
    tinygltf::TinyGLTF writer;
    EXPECT_TRUE(writer.WriteGltfSceneToFile(&m, path, true, true, false, true)) << path;
    return path;
  }
};

// A unit square in z = 0 (two triangles, counter-clockwise seen from +z) as one mesh of `g` with the given
// materials per triangle (one primitive per distinct material).
int addSquare(GltfMaker& g, const std::vector<int>& materials = {-1}, const std::vector<float>& uv0 = {},
              const std::vector<float>& uv1 = {}) {
  const int pos = g.floats({0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0}, 3);
  const int t0 = uv0.empty() ? -1 : g.floats(uv0, 2), t1 = uv1.empty() ? -1 : g.floats(uv1, 2);
  tinygltf::Mesh mesh;
  mesh.name = "square";
  const std::vector<std::vector<uint32_t>> tris = {{0, 1, 2}, {0, 2, 3}};
  for (size_t p = 0; p < materials.size(); ++p) {
    tinygltf::Primitive prim;
    prim.attributes["POSITION"] = pos;
    if (t0 >= 0) prim.attributes["TEXCOORD_0"] = t0;
    if (t1 >= 0) prim.attributes["TEXCOORD_1"] = t1;
    std::vector<uint32_t> idx;
    for (size_t t = 0; t < tris.size(); ++t)
      if (materials.size() == 1 || t % materials.size() == p) idx.insert(idx.end(), tris[t].begin(), tris[t].end());
    prim.indices = g.indices(idx);
    prim.material = materials[p];
    prim.mode = TINYGLTF_MODE_TRIANGLES;
    mesh.primitives.push_back(prim);
  }
  g.m.meshes.push_back(mesh);
  return static_cast<int>(g.m.meshes.size()) - 1;
}

bool hasWarning(const MeshReport& report, const std::string& part) {
  for (const MeshFinding& f : report.findings)
    if (f.severity == MeshFinding::Severity::Warning && f.what.find(part) != std::string::npos) return true;
  return false;
}

}  // namespace

// Two nodes show one mesh: one moved by +5 in x, one mirrored in x (scale -1). Both come in, placed by their
// node, and the mirrored one is turned over so that its faces still face +z.
TEST(Gltf, EveryInstanceWithItsTransformMirroredOnesTurnedOver) {
  const std::string dir = test::tempDir("gltf_instances");
  GltfMaker g;
  const int mesh = addSquare(g);
  g.node(mesh, {5, 0, 0});
  g.node(mesh, {}, {-1, 1, 1});
  const std::string path = g.save(dir, "two.glb");
  const LoadedMesh loaded = loadMesh(path);
  ASSERT_TRUE(loaded.mesh) << loaded.report.summary();
  const Mesh& m = *loaded.mesh;
  EXPECT_EQ(loaded.report.format, "glb");
  ASSERT_EQ(m.numVertices(), 8);
  ASSERT_EQ(m.numFaces(), 4);
  Vec3 lo, hi;
  m.bounds(lo, hi);
  EXPECT_NEAR(lo.x(), -1, 1e-12);
  EXPECT_NEAR(hi.x(), 6, 1e-12);
  // Vertex order: the file's, instance by instance.
  EXPECT_NEAR(m.position(1).x(), 6, 1e-12);
  EXPECT_NEAR(m.position(5).x(), -1, 1e-12);
  for (int f = 0; f < m.numFaces(); ++f) EXPECT_GT(m.faceNormal(f).z(), 0.99) << "face " << f;
  // The model reader is the same reader: both instances, welded nowhere (they do not touch).
  const TexturedModel model = loadModel(path);
  EXPECT_EQ(model.mesh.numFaces(), 4);
  EXPECT_EQ(model.mesh.numVertices(), 8);
}

// The material's base colour texture reads TEXCOORD_1: those are the mesh's UVs (v flipped to OBJ's v up).
TEST(Gltf, TakesTheUvSetOfTheBaseColourTexture) {
  const std::string dir = test::tempDir("gltf_uvset");
  GltfMaker g;
  const int mat = g.material("painted", 1);
  const std::vector<float> uv0 = {0, 0, 0, 0, 0, 0, 0, 0};
  const std::vector<float> uv1 = {0.1f, 0.9f, 0.6f, 0.9f, 0.6f, 0.4f, 0.1f, 0.4f};
  g.node(addSquare(g, {mat}, uv0, uv1));
  const LoadedMesh loaded = loadMesh(g.save(dir, "uv1.glb"));
  ASSERT_TRUE(loaded.mesh);
  const Mesh& m = *loaded.mesh;
  ASSERT_TRUE(m.hasUV());
  for (int f = 0; f < m.numFaces(); ++f) {
    const auto fv = m.faceVertices(f);
    for (int k = 0; k < 3; ++k) {
      const int v = fv[k];
      EXPECT_NEAR(m.cornerUV[f][k].x(), uv1[2 * v], 1e-6) << "face " << f << " corner " << k;
      EXPECT_NEAR(m.cornerUV[f][k].y(), 1.0 - uv1[2 * v + 1], 1e-6) << "face " << f << " corner " << k;
    }
  }
}

// Two primitives with two named materials: the faces keep them (Mesh::faceMaterial, materialNames).
TEST(Gltf, KeepsMaterialNames) {
  const std::string dir = test::tempDir("gltf_materials");
  GltfMaker g;
  const int skin = g.material("skin"), cloth = g.material("cloth");
  g.node(addSquare(g, {skin, cloth}));
  const LoadedMesh loaded = loadMesh(g.save(dir, "materials.glb"));
  ASSERT_TRUE(loaded.mesh);
  const Mesh& m = *loaded.mesh;
  ASSERT_EQ(m.materialNames, (std::vector<std::string>{"skin", "cloth"}));
  ASSERT_EQ(m.faceMaterial.size(), 2u);
  EXPECT_EQ(m.faceMaterial[0], 0);
  EXPECT_EQ(m.faceMaterial[1], 1);
  // Both primitives share their POSITION accessor: one set of four vertices.
  EXPECT_EQ(m.numVertices(), 4);
}

// A skinned node and a mesh with a morph target come in in their rest pose, each with a warning.
TEST(Gltf, SkinsAndMorphTargetsInRestPoseWithAWarning) {
  const std::string dir = test::tempDir("gltf_rig");
  GltfMaker g;
  const int mesh = addSquare(g);
  const int target = g.floats({0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1}, 3);
  g.m.meshes[mesh].primitives[0].targets.push_back({{"POSITION", target}});
  g.m.meshes[mesh].weights = {1.0};
  const int node = g.node(mesh);
  const int joint = g.node(-1, {0, 0, 3});
  tinygltf::Skin skin;
  skin.joints = {joint};
  g.m.skins.push_back(skin);
  g.m.nodes[node].skin = 0;
  const LoadedMesh loaded = loadMesh(g.save(dir, "rig.glb"));
  ASSERT_TRUE(loaded.mesh) << loaded.report.summary();
  EXPECT_TRUE(hasWarning(loaded.report, "has a skin: textured in its rest pose")) << loaded.report.summary();
  EXPECT_TRUE(hasWarning(loaded.report, "1 morph targets: textured in its rest pose")) << loaded.report.summary();
  for (int v = 0; v < loaded.mesh->numVertices(); ++v) EXPECT_EQ(loaded.mesh->position(v).z(), 0.0);
}

// Errors name the file, the mesh, the primitive and the accessor.
TEST(Gltf, ErrorsNameTheMeshPrimitiveAndAccessor) {
  const std::string dir = test::tempDir("gltf_errors");
  GltfMaker g;
  const int mesh = addSquare(g);
  g.node(mesh);
  g.m.meshes[mesh].primitives[0].indices = g.indices({0, 1, 7});
  const std::string path = g.save(dir, "bad.glb");
  const std::string e = test::errorOf([&] { loadMesh(path); });
  EXPECT_NE(e.find(path), std::string::npos) << e;
  EXPECT_NE(e.find("meshes[0] 'square'.primitives[0].indices (accessor 2)"), std::string::npos) << e;
  EXPECT_NE(e.find("index 7 is out of range (4 vertices)"), std::string::npos) << e;
  // TEXCOORD_0 of the wrong size.
  GltfMaker h;
  h.node(addSquare(h, {-1}, {0, 0, 1, 0}));
  const std::string path2 = h.save(dir, "short_uv.glb");
  const std::string e2 = test::errorOf([&] { loadMesh(path2); });
  EXPECT_NE(e2.find("primitives[0].TEXCOORD_0 (accessor 1)"), std::string::npos) << e2;
  EXPECT_NE(e2.find("one element per vertex (4)"), std::string::npos) << e2;
}

// A real mesh: spot written as a GLB (the exporter's layout: vertices split at UV seams) reads back with the
// same faces, positions and UVs as the OBJ, and the pipeline's loader welds it to the OBJ's vertex count.
TEST(Gltf, SpotAsGlbReadsLikeItsObj) {
  TM_REQUIRE_SHARED(obj, "meshes/spot/spot_triangulated.obj");
  const auto mesh = requireUsable(loadMesh(obj));
  const std::string dir = test::tempDir("gltf_spot");
  const std::string glb = (fs::path(dir) / "spot.glb").string();
  exportGlb(modelFromMesh(*mesh, cv::Mat(4, 4, CV_8UC4, cv::Scalar(200, 100, 50, 255))), glb);
  const LoadedMesh loaded = loadMesh(glb);
  ASSERT_TRUE(loaded.mesh) << loaded.report.summary();
  const Mesh& m = *loaded.mesh;
  ASSERT_EQ(m.numFaces(), mesh->numFaces());
  ASSERT_TRUE(m.hasUV());
  double worstPos = 0, worstUV = 0;
  for (int f = 0; f < m.numFaces(); ++f) {
    const auto a = m.facePositions(f), b = mesh->facePositions(f);
    // The same triangle, its corners possibly starting elsewhere, in the same orientation.
    double best = 1e30;
    int shift = 0;
    for (int r = 0; r < 3; ++r) {
      double d = 0;
      for (int k = 0; k < 3; ++k) d = std::max(d, (a[k] - b[(k + r) % 3]).norm());
      if (d < best) best = d, shift = r;
    }
    worstPos = std::max(worstPos, best);
    for (int k = 0; k < 3; ++k)
      worstUV = std::max(worstUV, (m.cornerUV[f][k] - mesh->cornerUV[f][(k + shift) % 3]).norm());
  }
  EXPECT_LT(worstPos, 1e-6);
  EXPECT_LT(worstUV, 1e-6);
  EXPECT_GT(m.numVertices(), mesh->numVertices());  // split at UV seams
  const WeldedMesh welded = weldIdenticalPositions(m);
  ASSERT_TRUE(welded.mesh);
  EXPECT_EQ(welded.mesh->numVertices(), mesh->numVertices());
}

// ---------------------------------------------------------------------------------------------
// Writing the montage back into the user's glTF file (exportGlbInto, and `montage run` through it).

namespace {

// An accessor over raw elements (`count` of them), with its component type; bounds when asked (POSITION and
// animation inputs need them).
int rawAccessor(GltfMaker& g, const void* data, size_t bytes, size_t count, int type, int componentType,
                bool normalized = false, const std::vector<float>& values = {}, int n = 0) {
  tinygltf::Accessor a;
  a.bufferView = g.view(data, bytes);
  a.componentType = componentType;
  a.normalized = normalized;
  a.count = count;
  a.type = type;
  if (!values.empty()) {
    a.minValues.assign(n, 1e30);
    a.maxValues.assign(n, -1e30);
    for (size_t i = 0; i < values.size(); ++i) {
      a.minValues[i % n] = std::min<double>(a.minValues[i % n], values[i]);
      a.maxValues[i % n] = std::max<double>(a.maxValues[i % n], values[i]);
    }
  }
  g.m.accessors.push_back(a);
  return static_cast<int>(g.m.accessors.size()) - 1;
}

// A rigged, morph-targeted cylinder as an artist brings it: 16 sides, 8 rings, caps whose rim vertices are split
// from the side's (hard edges: two normals at one position), NORMAL, the user's TEXCOORD_0 (textured by their own
// PNG) and a second set TEXCOORD_1, COLOR_0 as normalised bytes (3 bytes an element), JOINTS_0 and WEIGHTS_0 on a
// two-bone skin with inverse bind matrices, a morph target (a bulge) with its weight, and an animation of the upper
// bone. Material "skin_material".
std::string riggedCylinder(const std::string& dir, const std::string& name = "rig.glb") {
  constexpr int S = 16, R = 8;
  constexpr float kPi = 3.14159265f, H = 2.0f, r = 0.5f;
  std::vector<float> pos, nrm, uv0, uv1, weights, bulge;
  std::vector<uint8_t> color, joints;
  std::vector<uint32_t> idx;
  const auto vertex = [&](float x, float y, float z, float nx, float ny, float nz, float u, float v) {
    pos.insert(pos.end(), {x, y, z});
    nrm.insert(nrm.end(), {nx, ny, nz});
    uv0.insert(uv0.end(), {u, v});
    uv1.insert(uv1.end(), {0.5f + 0.4f * x, 0.5f + 0.4f * z});
    color.insert(color.end(), {uint8_t(40 + 200 * y / H), uint8_t(128), uint8_t(255 - 200 * y / H)});
    const float w = std::clamp(y / H, 0.0f, 1.0f);
    joints.insert(joints.end(), {0, uint8_t(w > 0 ? 1 : 0), 0, 0});  // a joint without weight is joint 0
    weights.insert(weights.end(), {1 - w, w, 0, 0});
    const float b = 0.2f * std::sin(kPi * y / H);
    bulge.insert(bulge.end(), {b * x, 0, b * z});
    return static_cast<uint32_t>(pos.size() / 3 - 1);
  };
  for (int ring = 0; ring <= R; ++ring)
    for (int s = 0; s <= S; ++s) {
      const float a = 2 * kPi * s / S, y = H * ring / R;
      vertex(r * std::cos(a), y, -r * std::sin(a), std::cos(a), 0, -std::sin(a), float(s) / S, 0.5f * ring / R);
    }
  for (int ring = 0; ring < R; ++ring)
    for (int s = 0; s < S; ++s) {
      const uint32_t a = ring * (S + 1) + s, b = a + 1, c = a + S + 1, d = c + 1;
      idx.insert(idx.end(), {a, b, d, a, d, c});
    }
  for (int cap = 0; cap < 2; ++cap) {  // bottom (normal -y), top (+y)
    const float y = cap ? H : 0, ny = cap ? 1.0f : -1.0f;
    const uint32_t center = vertex(0, y, 0, 0, ny, 0, 0.25f + 0.5f * cap, 0.75f);
    std::vector<uint32_t> rim;
    for (int s = 0; s < S; ++s) {
      const float a = 2 * kPi * s / S;
      rim.push_back(vertex(r * std::cos(a), y, -r * std::sin(a), 0, ny, 0, 0.25f + 0.5f * cap + 0.2f * std::cos(a),
                           0.75f + 0.2f * std::sin(a)));
    }
    for (int s = 0; s < S; ++s) {
      const uint32_t p = rim[s], q = rim[(s + 1) % S];
      if (cap)
        idx.insert(idx.end(), {center, p, q});
      else
        idx.insert(idx.end(), {center, q, p});
    }
  }
  const size_t nv = pos.size() / 3;
  GltfMaker g;
  tinygltf::Primitive prim;
  prim.attributes["POSITION"] = g.floats(pos, 3);
  prim.attributes["NORMAL"] =
      rawAccessor(g, nrm.data(), nrm.size() * 4, nv, TINYGLTF_TYPE_VEC3, TINYGLTF_COMPONENT_TYPE_FLOAT);
  prim.attributes["TEXCOORD_0"] = g.floats(uv0, 2);
  prim.attributes["TEXCOORD_1"] = g.floats(uv1, 2);
  prim.attributes["COLOR_0"] =
      rawAccessor(g, color.data(), color.size(), nv, TINYGLTF_TYPE_VEC3, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, true);
  prim.attributes["JOINTS_0"] =
      rawAccessor(g, joints.data(), joints.size(), nv, TINYGLTF_TYPE_VEC4, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE);
  prim.attributes["WEIGHTS_0"] =
      rawAccessor(g, weights.data(), weights.size() * 4, nv, TINYGLTF_TYPE_VEC4, TINYGLTF_COMPONENT_TYPE_FLOAT);
  prim.targets.push_back({{"POSITION", g.floats(bulge, 3)}});
  prim.indices = g.indices(idx);
  prim.mode = TINYGLTF_MODE_TRIANGLES;
  // The user's own texture: a 4 x 4 PNG, embedded.
  PngCache pngs;
  const std::vector<unsigned char>& png = pngs.encode(cv::Mat(4, 4, CV_8UC4, cv::Scalar(30, 60, 90, 255)), "t");
  tinygltf::Image image;
  image.name = "users_paint";
  image.mimeType = "image/png";
  image.bufferView = g.view(png.data(), png.size());
  g.m.images.push_back(image);
  tinygltf::Texture texture;
  texture.source = 0;
  g.m.textures.push_back(texture);
  prim.material = g.material("skin_material", 0);
  tinygltf::Mesh mesh;
  mesh.name = "cylinder";
  mesh.primitives.push_back(prim);
  mesh.weights = {0.0};
  g.m.meshes.push_back(mesh);
  // Nodes: 0 the skinned mesh, 1 the root bone, 2 the upper bone one unit up.
  g.node(0);
  g.node(-1);
  g.node(-1, {0, 1, 0});
  g.m.nodes[1].name = "root_bone";
  g.m.nodes[1].children = {2};
  g.m.nodes[2].name = "upper_bone";
  g.m.nodes[0].skin = 0;
  const std::vector<float> ibm = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0,  0, 1,   // root at the origin
                                  1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, -1, 0, 1};  // upper bone at y = 1
  tinygltf::Skin skin;
  skin.name = "armature";
  skin.joints = {1, 2};
  skin.skeleton = 1;
  skin.inverseBindMatrices =
      rawAccessor(g, ibm.data(), ibm.size() * 4, 2, TINYGLTF_TYPE_MAT4, TINYGLTF_COMPONENT_TYPE_FLOAT);
  g.m.skins.push_back(skin);
  const std::vector<float> times = {0, 1}, turns = {0, 0, 0, 1, 0, 0, 0.3826834f, 0.9238795f};
  tinygltf::Animation anim;
  anim.name = "bend";
  tinygltf::AnimationSampler sampler;
  sampler.input =
      rawAccessor(g, times.data(), 8, 2, TINYGLTF_TYPE_SCALAR, TINYGLTF_COMPONENT_TYPE_FLOAT, false, times, 1);
  sampler.output = rawAccessor(g, turns.data(), 32, 2, TINYGLTF_TYPE_VEC4, TINYGLTF_COMPONENT_TYPE_FLOAT);
  sampler.interpolation = "LINEAR";
  anim.samplers.push_back(sampler);
  tinygltf::AnimationChannel channel;
  channel.sampler = 0;
  channel.target_node = 2;
  channel.target_path = "rotation";
  anim.channels.push_back(channel);
  g.m.animations.push_back(anim);
  tinygltf::Scene scene;
  scene.nodes = {0, 1};
  g.m.scenes.push_back(scene);
  g.m.defaultScene = 0;
  return g.save(dir, name);
}

tinygltf::Model readGlb(const std::string& path) {
  tinygltf::TinyGLTF loader;
  tinygltf::Model m;
  std::string err, warn;
  EXPECT_TRUE(loader.LoadBinaryFromFile(&m, &err, &warn, path)) << path << ": " << err;
  return m;
}

// Element i of an accessor as bytes (its view's stride honoured).
std::vector<unsigned char> elementOf(const tinygltf::Model& m, int accessor, size_t i) {
  const tinygltf::Accessor& a = m.accessors.at(accessor);
  const tinygltf::BufferView& v = m.bufferViews.at(a.bufferView);
  const size_t size = tinygltf::GetNumComponentsInType(a.type) * tinygltf::GetComponentSizeInBytes(a.componentType);
  const size_t stride = v.byteStride ? v.byteStride : size;
  const unsigned char* p = m.buffers.at(v.buffer).data.data() + v.byteOffset + a.byteOffset + i * stride;
  return std::vector<unsigned char>(p, p + size);
}

uint32_t indexOf(const tinygltf::Model& m, int accessor, size_t i) {
  const std::vector<unsigned char> e = elementOf(m, accessor, i);
  const int type = m.accessors.at(accessor).componentType;
  if (type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT) return e[0] | e[1] << 8 | e[2] << 16 | uint32_t(e[3]) << 24;
  if (type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT) return e[0] | e[1] << 8;
  return e[0];
}

Vec2f floats2(const std::vector<unsigned char>& e) {
  Vec2f v;
  std::memcpy(v.data(), e.data(), 8);
  return v;
}

// `montage synth` (3 views of the rigged cylinder, 40 clicks, its solid pattern) and `montage run` into DIR/out.
void montageRun(const std::string& dir, const std::string& mesh, int features) {
  const std::string exe = test::montageExe();
  std::string log;
  ASSERT_EQ(test::runCommand("'" + exe + "' synth --mesh '" + mesh + "' --views 3 --features " +
                                 std::to_string(features) + " --size 256 --out '" + dir + "/scene'",
                             &log),
            0)
      << log;
  ASSERT_EQ(test::runCommand("'" + exe + "' run '" + dir + "/scene/project.json' --out '" + dir + "/out'", &log), 0)
      << log;
}
void montageRunOnRig(const std::string& dir) {
  montageRun(dir, riggedCylinder(dir), 40);
}

// The export stage's word on the GLB in DIR/out/report.json.
nlohmann::json glbReport(const std::string& dir) {
  const nlohmann::json report = test::readJson(dir + "/out/report.json");
  const nlohmann::json stages = report["stages"];
  for (const auto& stage : stages)
    if (stage["stage"] == "export") return stage["counts"]["glb"];
  return {};
}

// The mean colour difference (sRGB, 0..1) between the run's GLB and OBJ at each face's centre, faces matched by their
// centroids; every face must match.
double glbAgainstObj(const std::string& dir) {
  const TexturedModel fromGlb = loadModel(dir + "/out/model.glb"), fromObj = loadModel(dir + "/out/model.obj");
  EXPECT_EQ(fromGlb.mesh.numFaces(), fromObj.mesh.numFaces());
  std::map<std::array<long, 3>, int> objFace;
  const auto key = [](const Mesh& m, int f) {
    const auto p = m.facePositions(f);
    const Vec3 c = (p[0] + p[1] + p[2]) / 3.0;
    return std::array<long, 3>{std::lround(c.x() * 1e5), std::lround(c.y() * 1e5), std::lround(c.z() * 1e5)};
  };
  for (int f = 0; f < fromObj.mesh.numFaces(); ++f) objFace[key(fromObj.mesh, f)] = f;
  double diff = 0;
  int matched = 0;
  for (int f = 0; f < fromGlb.mesh.numFaces(); ++f) {
    const auto it = objFace.find(key(fromGlb.mesh, f));
    if (it == objFace.end()) continue;
    ++matched;
    diff += (fromGlb.colorAt(f, Vec3(1, 1, 1) / 3.0) - fromObj.colorAt(it->second, Vec3(1, 1, 1) / 3.0)).norm();
  }
  EXPECT_EQ(matched, fromGlb.mesh.numFaces());
  return diff / std::max(matched, 1);
}

}  // namespace

// The montage written back into the rigged cylinder: every attribute of every corner is the file's (skin joints and
// weights, normals with their hard edges, both UV sets, colours, the morph target), the skin, its bones and the
// animation are there, and the montage's own coordinates come as TEXCOORD_2, which the material's base colour reads.
TEST(GltfWriteBack, KeepsSkinMorphTargetsNormalsColoursAndEveryUvSet) {
  const std::string dir = test::tempDir("gltf_write_back");
  const std::string rig = riggedCylinder(dir);
  const LoadedMesh loaded = loadMesh(rig);
  ASSERT_TRUE(loaded.mesh) << loaded.report.summary();
  // The model as the export has it: the mesh as loaded, a texture, coordinates with seams (every other face moved
  // right by half the texture, so that vertices split).
  TexturedModel model;
  model.mesh = *loaded.mesh;
  const int nf = model.mesh.numFaces();
  model.uv.resize(nf);
  for (int f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) {
      const Vec3 p = model.mesh.facePositions(f)[k];
      model.uv[f][k] = Vec2f(float(0.2 * p.x() + 0.25 + (f % 2) * 0.5), float(0.2 * p.y() + 0.3 * p.z() + 0.4));
    }
  Material atlas;
  atlas.name = "skin_material";
  atlas.texture = cv::Mat(8, 8, CV_8UC4, cv::Scalar(200, 120, 40, 255));
  model.materials.push_back(atlas);
  model.faceMaterial.assign(nf, 0);
  const std::string out = (fs::path(dir) / "out.glb").string();
  const GltfWriteBack w = exportGlbInto(model, rig, out);
  EXPECT_EQ(w.triangles, nf);
  EXPECT_EQ(w.leftOutTriangles, 0);
  EXPECT_EQ(w.primitives, 1);
  EXPECT_EQ(w.droppedImages, 1);  // the user's own base colour image, which nothing shows any more

  const tinygltf::Model src = readGlb(rig), got = readGlb(out);
  // The rig: nodes, skin, bones, inverse bind matrices, animation, morph weights.
  ASSERT_EQ(got.nodes.size(), 3u);
  EXPECT_EQ(got.nodes[0].skin, 0);
  EXPECT_EQ(got.nodes[2].name, "upper_bone");
  ASSERT_EQ(got.skins.size(), 1u);
  EXPECT_EQ(got.skins[0].joints, (std::vector<int>{1, 2}));
  for (size_t j = 0; j < 2; ++j)
    EXPECT_EQ(elementOf(got, got.skins[0].inverseBindMatrices, j), elementOf(src, src.skins[0].inverseBindMatrices, j));
  ASSERT_EQ(got.animations.size(), 1u);
  EXPECT_EQ(elementOf(got, got.animations[0].samplers[0].output, 1),
            elementOf(src, src.animations[0].samplers[0].output, 1));
  EXPECT_EQ(got.accessors[got.animations[0].samplers[0].input].maxValues, (std::vector<double>{1.0}));
  ASSERT_EQ(got.meshes.size(), 1u);
  EXPECT_EQ(got.meshes[0].weights, (std::vector<double>{0.0}));
  ASSERT_EQ(got.meshes[0].primitives.size(), 1u);
  const tinygltf::Primitive& gp = got.meshes[0].primitives[0];
  const tinygltf::Primitive& sp = src.meshes[0].primitives[0];
  for (const char* name :
       {"POSITION", "NORMAL", "TEXCOORD_0", "TEXCOORD_1", "TEXCOORD_2", "COLOR_0", "JOINTS_0", "WEIGHTS_0"})
    EXPECT_TRUE(gp.attributes.count(name)) << name;
  ASSERT_EQ(gp.targets.size(), 1u);
  ASSERT_TRUE(gp.targets[0].count("POSITION"));
  EXPECT_EQ(got.accessors[gp.attributes.at("COLOR_0")].normalized, true);
  // The material: the file's name, the montage's texture on TEXCOORD_2.
  const tinygltf::Material& mat = got.materials.at(gp.material);
  EXPECT_EQ(mat.name, "skin_material");
  EXPECT_EQ(mat.pbrMetallicRoughness.baseColorTexture.texCoord, 2);
  const int image = got.textures.at(mat.pbrMetallicRoughness.baseColorTexture.index).source;
  EXPECT_EQ(got.images.at(image).width, 8);
  EXPECT_EQ(got.images.size(), 1u);     // the montage's texture only
  EXPECT_EQ(got.materials.size(), 1u);  // the file's material, showing it

  // Corner by corner (one group: the file's triangle order), every attribute is the file's element's, and
  // TEXCOORD_2 is the model's coordinate of that corner.
  std::vector<int> faceOf(nf, -1);
  for (int f = 0; f < nf; ++f) faceOf[model.mesh.faceOrigin[f]] = f;
  const size_t corners = got.accessors[gp.indices].count;
  ASSERT_EQ(corners, src.accessors[sp.indices].count);
  std::set<uint32_t> outVertices;
  for (size_t c = 0; c < corners; ++c) {
    const uint32_t o = indexOf(got, gp.indices, c), s = indexOf(src, sp.indices, c);
    outVertices.insert(o);
    for (const auto& [name, accessor] : sp.attributes)
      ASSERT_EQ(elementOf(got, gp.attributes.at(name), o), elementOf(src, accessor, s)) << name << " corner " << c;
    ASSERT_EQ(elementOf(got, gp.targets[0].at("POSITION"), o), elementOf(src, sp.targets[0].at("POSITION"), s));
    const int f = faceOf[c / 3];
    ASSERT_GE(f, 0);
    const auto fv = model.mesh.faceVertices(f);
    int k = 0;
    while (model.mesh.vertexOrigin[fv[k]] != static_cast<int>(s)) ++k;
    const Vec2f t = floats2(elementOf(got, gp.attributes.at("TEXCOORD_2"), o));
    EXPECT_EQ(t, Vec2f(model.uv[f][k].x(), 1.0f - model.uv[f][k].y())) << "corner " << c;
  }
  // Vertices split at the montage's seams, no more: more than the file's, at most one per corner.
  EXPECT_GT(outVertices.size(), src.accessors[sp.attributes.at("POSITION")].count);
  EXPECT_EQ(outVertices.size(), got.accessors[gp.attributes.at("POSITION")].count);
  // Hard edges: the caps' rims keep two normals at one position.
  std::map<std::vector<unsigned char>, std::set<std::vector<unsigned char>>> normalsAt;
  for (uint32_t v : outVertices)
    normalsAt[elementOf(got, gp.attributes.at("POSITION"), v)].insert(elementOf(got, gp.attributes.at("NORMAL"), v));
  int hard = 0;
  for (const auto& [p, normals] : normalsAt) hard += normals.size() >= 2;
  EXPECT_EQ(hard, 32);  // 16 rim positions on each cap
}

// A mesh shown by two nodes gets a copy per node (each instance has its own place in the atlas), and a file that
// no longer holds the model's mesh is refused, naming it.
TEST(GltfWriteBack, CopiesAMeshPerInstanceAndRefusesAChangedFile) {
  const std::string dir = test::tempDir("gltf_write_back_instances");
  GltfMaker g;
  const int mesh = addSquare(g, {g.material("paint")});
  g.node(mesh, {5, 0, 0});
  g.node(mesh, {}, {-1, 1, 1});
  const std::string path = g.save(dir, "two.glb");
  const LoadedMesh loaded = loadMesh(path);
  ASSERT_TRUE(loaded.mesh);
  TexturedModel model;
  model.mesh = *loaded.mesh;
  model.uv.resize(model.mesh.numFaces());
  for (int f = 0; f < model.mesh.numFaces(); ++f)
    for (int k = 0; k < 3; ++k) model.uv[f][k] = Vec2f(0.25f * f, 0.1f * k);
  Material m;
  m.name = "paint";
  m.texture = cv::Mat(4, 4, CV_8UC4, cv::Scalar(1, 2, 3, 255));
  model.materials = {m};
  const std::string out = (fs::path(dir) / "out.glb").string();
  const GltfWriteBack w = exportGlbInto(model, path, out);
  EXPECT_EQ(w.copiedMeshes, 1);
  const tinygltf::Model got = readGlb(out);
  ASSERT_EQ(got.meshes.size(), 2u);
  EXPECT_EQ(got.nodes[0].mesh, 0);
  EXPECT_EQ(got.nodes[1].mesh, 1);
  // Each copy carries its own instance's coordinates: faces 0-1 on the first node, 2-3 on the second.
  for (int n = 0; n < 2; ++n) {
    const tinygltf::Primitive& p = got.meshes[n].primitives.at(0);
    const Vec2f t = floats2(elementOf(got, p.attributes.at("TEXCOORD_0"), indexOf(got, p.indices, 0)));
    EXPECT_NEAR(t.x(), 0.5f * n, 1e-6) << "node " << n;
  }
  // The file changed since the model was made: refused with the file's name.
  GltfMaker h;
  h.node(addSquare(h));  // one instance where the model has two
  h.save(dir, "two.glb");
  const std::string e = test::errorOf([&] { exportGlbInto(model, path, out); });
  EXPECT_NE(e.find(path), std::string::npos) << e;
  EXPECT_NE(e.find("is not the mesh the model was made from"), std::string::npos) << e;
}

// A .gltf whose material's normal map is a PNG file beside it: the written GLB embeds that file byte for byte (the
// normal map stays; the base colour is the montage's).
TEST(GltfWriteBack, EmbedsTheFilesOtherImagesAsTheyAre) {
  const std::string dir = test::tempDir("gltf_write_back_external");
  PngCache pngs;
  const std::vector<unsigned char>& png = pngs.encode(cv::Mat(4, 4, CV_8UC4, cv::Scalar(128, 128, 255, 255)), "n");
  writeFileAtomic(dir + "/normal map.png", std::string(png.begin(), png.end()));
  GltfMaker g;
  tinygltf::Image image;
  image.uri = "normal%20map.png";
  g.m.images.push_back(image);
  tinygltf::Texture texture;
  texture.source = 0;
  g.m.textures.push_back(texture);
  const int mat = g.material("painted", 0);
  g.m.materials[mat].normalTexture.index = 0;
  g.node(addSquare(g, {mat}, {0, 0, 1, 0, 1, 1, 0, 1}));
  g.m.asset.version = "2.0";
  tinygltf::TinyGLTF writer;
  writer.SetImageWriter(nullptr, nullptr);  // the image stays the file it names
  const std::string path = dir + "/square.gltf";
  ASSERT_TRUE(writer.WriteGltfSceneToFile(&g.m, path, false, true, true, false));
  ASSERT_NE(readFileBytes(path, "glTF").find("\"normal%20map.png\""), std::string::npos);  // named, not embedded
  const LoadedMesh loaded = loadMesh(path);
  ASSERT_TRUE(loaded.mesh) << loaded.report.summary();
  TexturedModel model = modelFromMesh(*loaded.mesh, cv::Mat(8, 8, CV_8UC4, cv::Scalar(1, 2, 3, 255)));
  model.materials[0].name = "painted";
  exportGlbInto(model, path, dir + "/out.glb");
  const tinygltf::Model got = readGlb(dir + "/out.glb");
  const tinygltf::Material& m = got.materials.at(got.meshes[0].primitives[0].material);
  ASSERT_GE(m.normalTexture.index, 0);
  const tinygltf::Image& normal = got.images.at(got.textures.at(m.normalTexture.index).source);
  EXPECT_EQ(normal.mimeType, "image/png");
  EXPECT_TRUE(normal.uri.empty());
  const tinygltf::BufferView& v = got.bufferViews.at(normal.bufferView);
  const auto* bytes = got.buffers[0].data.data() + v.byteOffset;
  EXPECT_EQ(std::vector<unsigned char>(bytes, bytes + v.byteLength), png);
  EXPECT_NE(m.pbrMetallicRoughness.baseColorTexture.index, m.normalTexture.index);
}

// `montage run` on a project whose mesh is the rigged GLB: the run's model.glb is that file with the montage, it
// shows the same colours as the run's model.obj (the material reads the right coordinate set), and a copy of the
// project in another folder, its mesh touched, gives the same bytes.
TEST(GltfWriteBack, MontageRunWritesTheRigBack) {
  const std::string dir = test::tempDir("gltf_write_back_run");
  ASSERT_NO_FATAL_FAILURE(montageRunOnRig(dir));
  const nlohmann::json glb = glbReport(dir);
  ASSERT_TRUE(glb.is_object());
  EXPECT_TRUE(glb["written_into_source"].get<bool>()) << glb.dump();
  const tinygltf::Model got = readGlb(dir + "/out/model.glb");
  ASSERT_EQ(got.skins.size(), 1u);
  ASSERT_EQ(got.animations.size(), 1u);
  const tinygltf::Primitive& p = got.meshes.at(0).primitives.at(0);
  EXPECT_TRUE(p.attributes.count("JOINTS_0") && p.attributes.count("WEIGHTS_0") && p.attributes.count("TEXCOORD_1"));
  EXPECT_EQ(p.targets.size(), 1u);
  EXPECT_EQ(got.materials.at(p.material).name, "skin_material");
  EXPECT_LT(glbAgainstObj(dir), 0.01);  // the same colours as the OBJ

  // The same bytes from a copy of the project in another folder, its mesh touched.
  const std::string copy = test::tempDir("gltf_write_back_copy");
  fs::copy(dir + "/scene", copy + "/scene", fs::copy_options::recursive);
  fs::copy_file(dir + "/rig.glb", copy + "/rig.glb");
  fs::last_write_time(copy + "/rig.glb", fs::file_time_type::clock::now() + std::chrono::hours(1));
  std::string log;
  ASSERT_EQ(test::runCommand(
                "'" + test::montageExe() + "' run '" + copy + "/scene/project.json' --out '" + copy + "/out'", &log),
            0)
      << log;
  for (const char* file : {"model.glb", "model.obj"})
    EXPECT_EQ(readFileBytes(dir + "/out/" + file, "a"), readFileBytes(copy + "/out/" + file, "b")) << file;
}

// A real third-party GLB (the Lee Perry-Smith head of the shared data: a camera and a lamp node beside the mesh, its
// own UV set) through `montage run`: written back, every node kept, its UV set kept beside the montage's, the same
// colours as the OBJ.
TEST(GltfWriteBack, ARealHeadGlbIsWrittenBack) {
  TM_REQUIRE_SHARED(head, "meshes/leeperrysmith/LeePerrySmith.glb");
  const std::string dir = test::tempDir("gltf_write_back_head");
  ASSERT_NO_FATAL_FAILURE(montageRun(dir, head, 60));
  const nlohmann::json glb = glbReport(dir);
  ASSERT_TRUE(glb.is_object());
  EXPECT_TRUE(glb["written_into_source"].get<bool>()) << glb.dump();
  EXPECT_EQ(glb["left_out_triangles"], 0);
  const tinygltf::Model src = readGlb(head), got = readGlb(dir + "/out/model.glb");
  ASSERT_EQ(got.nodes.size(), src.nodes.size());
  for (size_t n = 0; n < src.nodes.size(); ++n) EXPECT_EQ(got.nodes[n].name, src.nodes[n].name);
  const tinygltf::Primitive& p = got.meshes.at(0).primitives.at(0);
  EXPECT_TRUE(p.attributes.count("TEXCOORD_0") && p.attributes.count("TEXCOORD_1") && p.attributes.count("NORMAL"));
  EXPECT_EQ(got.materials.at(p.material).pbrMetallicRoughness.baseColorTexture.texCoord, 1);
  EXPECT_LT(glbAgainstObj(dir), 0.01);
}

// The rigged FBX of tests/data (made by tests/blender/make_rig_fbx.py: a cylinder on a two-bone armature, a shape
// key, a second UV set, vertex colours, an animation of the upper bone) through `montage run`: read in glTF form, so
// model.glb keeps the armature, the weights, the shape key, both UV sets, the colours and the animation, with the
// montage's texture on a third set.
void montageRunOnFbxRig(const std::string& dir) {
  fs::copy_file(test::testDataDir() + "/rig.fbx", dir + "/rig.fbx");
  montageRun(dir, dir + "/rig.fbx", 40);
}

TEST(GltfWriteBack, AnFbxRigComesBackInTheGlb) {
  const std::string dir = test::tempDir("gltf_write_back_fbx");
  // The mesh the FBX gives in glTF form is the mesh the plain reader gives: the same faces at the same places.
  const LoadedMesh loaded = loadMesh(test::testDataDir() + "/rig.fbx");
  ASSERT_TRUE(loaded.mesh);
  EXPECT_EQ(loaded.report.format, "fbx");
  EXPECT_EQ(loaded.mesh->numFaces(), 634);
  Vec3 lo = Vec3::Constant(1e9), hi = -lo;
  for (int v = 0; v < loaded.mesh->numVertices(); ++v)
    lo = lo.cwiseMin(loaded.mesh->position(v)), hi = hi.cwiseMax(loaded.mesh->position(v));
  // Blender's metres as the FBX's centimetres: the cylinder of radius 0.5 and height 2, 100 times.
  EXPECT_LT((lo - Vec3(-50, 0, -50)).norm(), 1e-3) << lo.transpose();
  EXPECT_LT((hi - Vec3(50, 200, 50)).norm(), 1e-3) << hi.transpose();

  ASSERT_NO_FATAL_FAILURE(montageRunOnFbxRig(dir));
  const nlohmann::json glb = glbReport(dir);
  ASSERT_TRUE(glb.is_object());
  EXPECT_TRUE(glb["written_into_source"].get<bool>()) << glb.dump();
  EXPECT_EQ(glb["left_out_triangles"], 0);
  const tinygltf::Model got = readGlb(dir + "/out/model.glb");
  ASSERT_EQ(got.skins.size(), 1u);
  std::set<std::string> joints;
  for (int j : got.skins[0].joints) joints.insert(got.nodes.at(j).name);
  EXPECT_EQ(joints, (std::set<std::string>{"root", "tip"}));
  ASSERT_EQ(got.animations.size(), 1u);
  EXPECT_FALSE(got.animations[0].channels.empty());
  ASSERT_EQ(got.meshes.size(), 1u);
  const tinygltf::Primitive& p = got.meshes[0].primitives.at(0);
  for (const char* a : {"JOINTS_0", "WEIGHTS_0", "NORMAL", "COLOR_0", "TEXCOORD_0", "TEXCOORD_1", "TEXCOORD_2"})
    EXPECT_TRUE(p.attributes.count(a)) << a;
  ASSERT_EQ(p.targets.size(), 1u);
  // The shape key's bulge: 0.3 of the radius (0.5 in the mesh's own metres) at the middle ring.
  const tinygltf::Accessor& bulge = got.accessors.at(p.targets[0].at("POSITION"));
  ASSERT_EQ(bulge.maxValues.size(), 3u);
  EXPECT_NEAR(bulge.maxValues[0], 0.15, 1e-3);
  EXPECT_EQ(got.materials.at(p.material).name, "skin_material");
  EXPECT_EQ(got.materials.at(p.material).pbrMetallicRoughness.baseColorTexture.texCoord, 2);
  EXPECT_LT(glbAgainstObj(dir), 0.01);  // the same colours as the OBJ
}

// The written-back GLB passes the Khronos validator without errors or warnings.
TEST(GltfValidator, WrittenBackRigHasNoErrors) {
  if (const std::string why = test::gltfValidatorMissing(); !why.empty()) GTEST_SKIP() << why;
  const std::string dir = test::tempDir("gltf_write_back_validator");
  const std::string rig = riggedCylinder(dir);
  TexturedModel model;
  model.mesh = *requireUsable(loadMesh(rig));
  model.uv.assign(model.mesh.numFaces(), {Vec2f(0.1f, 0.1f), Vec2f(0.9f, 0.1f), Vec2f(0.5f, 0.9f)});
  Material m;
  m.name = "skin_material";
  m.texture = cv::Mat(4, 4, CV_8UC4, cv::Scalar(1, 2, 3, 255));
  model.materials = {m};
  const std::string out = dir + "/out.glb";
  exportGlbInto(model, rig, out);
  int rc = 0;
  const std::string log = test::runGltfValidator(out, &rc);
  EXPECT_EQ(rc, 0) << log;
  EXPECT_NE(log.find("errors: 0,"), std::string::npos) << log;
  EXPECT_NE(log.find("warnings: 0,"), std::string::npos) << log;
}

// The GLB written from the rigged FBX passes the validator without errors. Its two warnings are those of every
// exporter that keeps an artist's hierarchy (Blender's own too): the skinned mesh's node is a child of the scene's
// root and has a transform, which viewers ignore for a skinned mesh.
TEST(GltfValidator, FbxRigWrittenBackHasNoErrors) {
  if (const std::string why = test::gltfValidatorMissing(); !why.empty()) GTEST_SKIP() << why;
  const std::string dir = test::tempDir("gltf_fbx_validator");
  ASSERT_NO_FATAL_FAILURE(montageRunOnFbxRig(dir));
  int rc = 0;
  const std::string log = test::runGltfValidator(dir + "/out/model.glb", &rc);
  EXPECT_EQ(rc, 0) << log;
  EXPECT_NE(log.find("errors: 0,"), std::string::npos) << log;
}

// Blender (Debian's 3.4, headless) imports the run's GLB and OBJ as an artist would get them: the armature deforms
// the textured mesh, the shape key, three UV layers with the texture on the montage's, custom normals, vertex
// colours, the material's name, a rendered frame that shows the texture; the OBJ with its texture and normals
// (tests/blender/check_import.py). `scripts/test.sh --with-blender` installs Blender; without it this skips.
// Runs a Blender check script (tests/blender) on DIR/out/model.glb and model.obj and any further arguments; prints
// its own lines and expects it to pass.
void blenderCheck(const std::string& script, const std::string& dir, const std::string& more = "") {
  std::string log;
  const int rc = test::runCommand("blender -b --factory-startup --python-exit-code 1 -P '" + script + "' -- '" + dir +
                                      "/out/model.glb' '" + dir + "/out/model.obj' " + more,
                                  &log);
  std::string checks;  // the script's own lines, not Blender's chatter
  std::istringstream lines(log);
  for (std::string line; std::getline(lines, line);)
    if (line.rfind("ok ", 0) == 0 || line.rfind("FAIL", 0) == 0 || line.rfind("all checks", 0) == 0 ||
        line.find("Error") != std::string::npos)
      checks += line + "\n";
  std::printf("%s", checks.c_str());
  EXPECT_EQ(rc, 0) << log;
  EXPECT_NE(checks.find("all checks passed"), std::string::npos) << log;
}

TEST(Blender, ImportsTheWrittenBackRigAndTheObj) {
  if (test::runCommand("command -v blender") != 0)
    GTEST_SKIP() << "Blender is not installed: `scripts/test.sh --with-blender` installs it (Debian package blender)";
  const std::string dir = test::tempDir("gltf_blender");
  ASSERT_NO_FATAL_FAILURE(montageRunOnRig(dir));
  blenderCheck(TM_BLENDER_CHECK_PY, dir, "'" + dir + "/render.png'");
}

// The GLB from the rigged FBX in Blender: the FBX's armature deforms the textured mesh, whose bind pose is where the
// OBJ has it; the shape key and the three UV layers (tests/blender/check_fbx_rig.py).
TEST(Blender, TheFbxRigDeformsTheTexturedGlb) {
  if (test::runCommand("command -v blender") != 0)
    GTEST_SKIP() << "Blender is not installed: `scripts/test.sh --with-blender` installs it (Debian package blender)";
  const std::string dir = test::tempDir("gltf_blender_fbx");
  ASSERT_NO_FATAL_FAILURE(montageRunOnFbxRig(dir));
  blenderCheck(fs::path(TM_BLENDER_CHECK_PY).parent_path().string() + "/check_fbx_rig.py", dir);
}
