// glTF 2.0 mesh input (io/model.h: loadGltfMesh, and loadMesh / loadModel through it): every mesh instance with
// its node's transform, mirrored instances turned over, the base colour texture's UV set, material names, skins
// and morph targets in rest pose with a warning, errors that name the mesh, primitive and accessor. The GLBs are
// made here with tinygltf; one is the shared data's spot written as a GLB.
#include <tiny_gltf.h>

#include <filesystem>

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
  EXPECT_TRUE(hasWarning(loaded.report, "has a skin: read in its rest pose")) << loaded.report.summary();
  EXPECT_TRUE(hasWarning(loaded.report, "1 morph targets: read in its rest pose")) << loaded.report.summary();
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
