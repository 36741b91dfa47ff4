// Tests of textured models: colour lookup, OBJ/MTL and glTF loading and export, round trips, error
// messages, and the exported files checked by the Khronos glTF validator and assimp.
#include "io/model.h"

#include <tiny_gltf.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <regex>
#include <set>
#include <sstream>

#include "geometry/bvh.h"
#include "geometry/mesh.h"
#include "image/photo.h"
#include "io/mesh_io.h"
#include "test_support.h"

namespace fs = std::filesystem;

namespace montage {
namespace {

void writeText(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  ASSERT_TRUE(out.good()) << path;
}

using test::errorOf;

// Spot with its texture, some faces from photo 0, some from photo 3, some inpainted, some empty.
TexturedModel spotModel(const std::string& obj) {
  auto mesh = requireUsable(loadMesh(obj));
  TexturedModel model =
      modelFromMesh(*mesh, readImageRgba8((fs::path(obj).parent_path() / "spot_texture.png").string()), "spot");
  const int sources[4] = {0, 3, kSourceInpainted, kSourceEmpty};
  model.faceSource.resize(model.mesh.numFaces());
  for (int f = 0; f < model.mesh.numFaces(); ++f) model.faceSource[f] = sources[(f / 97) % 4];
  return model;
}

// A closed cube with no UVs and a coloured material; sources by face.
TexturedModel cubeModel() {
  const std::vector<Vec3> v = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
  const std::vector<std::array<int, 3>> t = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7}, {0, 1, 5}, {0, 5, 4},
                                             {1, 2, 6}, {1, 6, 5}, {2, 3, 7}, {2, 7, 6}, {3, 0, 4}, {3, 4, 7}};
  TexturedModel model;
  model.mesh = *requireUsable(buildMesh(v, t));
  Material red, blue;
  red.name = "red paint";  // a space: must be sanitised in the MTL
  red.diffuse = Vec3f(0.8f, 0.1f, 0.1f);
  blue.name = "blue";
  blue.diffuse = Vec3f(0.1f, 0.2f, 0.9f);
  model.materials = {red, blue};
  for (int f = 0; f < model.mesh.numFaces(); ++f) {
    model.faceMaterial.push_back(f < 6 ? 0 : 1);
    model.faceSource.push_back(f % 3 == 0 ? 1 : kSourceInpainted);
  }
  return model;
}

// Checks that `b` is `a` after a round trip: faceMap[f] is the face of b matching face f of a;
// corners are matched by position.
void expectSameModel(const TexturedModel& a, const TexturedModel& b, const std::vector<int>& faceMap, double uvTol,
                     double colorTol) {
  ASSERT_EQ(a.mesh.numFaces(), b.mesh.numFaces());
  ASSERT_EQ(a.textured(), b.textured());
  ASSERT_EQ(a.faceSource.empty(), b.faceSource.empty());
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0, 1);
  int samples = 0;
  for (int f = 0; f < a.mesh.numFaces(); ++f) {
    const int g = faceMap[f];
    ASSERT_GE(g, 0);
    const auto pa = a.mesh.facePositions(f), pb = b.mesh.facePositions(g);
    std::array<int, 3> corner;
    for (int k = 0; k < 3; ++k) {
      corner[k] = -1;
      for (int j = 0; j < 3; ++j)
        if ((pa[k] - pb[j]).norm() < 1e-5) corner[k] = j;
      ASSERT_GE(corner[k], 0) << "face " << f << " corner " << k;
      if (a.textured()) {
        EXPECT_NEAR(a.uv[f][k].x(), b.uv[g][corner[k]].x(), uvTol) << "face " << f;
        EXPECT_NEAR(a.uv[f][k].y(), b.uv[g][corner[k]].y(), uvTol) << "face " << f;
      }
    }
    if (!a.faceSource.empty()) EXPECT_EQ(a.faceSource[f], b.faceSource[g]) << "face " << f;
    for (int s = 0; s < 2; ++s) {
      double b0 = u(rng), b1 = u(rng);
      if (b0 + b1 > 1) b0 = 1 - b0, b1 = 1 - b1;
      const Vec3 ba(b0, b1, 1 - b0 - b1);
      Vec3 bb;
      for (int k = 0; k < 3; ++k) bb[corner[k]] = ba[k];
      const Vec3f ca = a.colorAt(f, ba), cb = b.colorAt(g, bb);
      ASSERT_LE((ca - cb).cwiseAbs().maxCoeff(), colorTol) << "face " << f;
      ++samples;
    }
  }
  EXPECT_GT(samples, 0);
}

// Faces of b matching the faces of a by centroid (the writers group faces by source and material).
std::vector<int> matchFaces(const TexturedModel& a, const TexturedModel& b) {
  const TriangleBvh bvh(b.mesh);
  std::vector<int> map(a.mesh.numFaces(), -1);
  for (int f = 0; f < a.mesh.numFaces(); ++f) {
    const auto p = a.mesh.facePositions(f);
    const ClosestPoint cp = bvh.closest((p[0] + p[1] + p[2]) / 3);
    if (cp.distance < 1e-6) map[f] = cp.face;
  }
  return map;
}

// ----------------------------------------------------------------------------------------------
// colorAt

TEST(ColorAt, BilinearExactOnTinyTexture) {
  // 2x2 RGBA texture; pixel centres are at u, v in {0.25, 0.75} (row 0 = top = v 0.75).
  cv::Mat tex(2, 2, CV_8UC4);
  tex.at<cv::Vec4b>(0, 0) = {0, 100, 200, 255};
  tex.at<cv::Vec4b>(0, 1) = {40, 60, 20, 255};
  tex.at<cv::Vec4b>(1, 0) = {255, 0, 10, 255};
  tex.at<cv::Vec4b>(1, 1) = {80, 180, 30, 0};
  const std::vector<Vec2> uvOf = {{0.25, 0.75}, {0.75, 0.75}, {0.25, 0.25}};
  auto mesh = requireUsable(buildMesh({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 2}}, {{uvOf[0], uvOf[1], uvOf[2]}}));
  TexturedModel model = modelFromMesh(*mesh, tex);
  const auto fv = model.mesh.faceVertices(0);
  const auto texel = [&](int r, int c) -> Vec3f {
    const cv::Vec4b p = tex.at<cv::Vec4b>(r, c);
    return Vec3f(p[0], p[1], p[2]) / 255.0f;
  };
  const auto at = [&](const Vec3& perVertex) {  // barycentrics given per original vertex 0, 1, 2
    Vec3 b;
    for (int k = 0; k < 3; ++k) b[k] = perVertex[fv[k]];
    return model.colorAt(0, b);
  };
  const auto near = [](const Vec3f& x, const Vec3f& y) { return (x - y).cwiseAbs().maxCoeff() < 1e-6f; };
  EXPECT_TRUE(near(at({1, 0, 0}), texel(0, 0)));
  EXPECT_TRUE(near(at({0, 1, 0}), texel(0, 1)));
  EXPECT_TRUE(near(at({0, 0, 1}), texel(1, 0)));
  EXPECT_TRUE(near(at({0.5, 0.5, 0}), (texel(0, 0) + texel(0, 1)) / 2));
  EXPECT_TRUE(near(at({0.5, 0, 0.5}), (texel(0, 0) + texel(1, 0)) / 2));
  // (u, v) = (0.375, 0.625): a quarter of the way from each centre: weights 9/16, 3/16, 3/16, 1/16.
  const Vec3f quarter = (9 * texel(0, 0) + 3 * texel(0, 1) + 3 * texel(1, 0) + texel(1, 1)) / 16;
  EXPECT_TRUE(near(at({0.5, 0.25, 0.25}), quarter)) << at({0.5, 0.25, 0.25}).transpose();

  // Repeat wrapping: u = 0 lies halfway between column 1 (wrapped) and column 0; u + 1 is the same.
  TexturedModel wrapped = model;
  for (int k = 0; k < 3; ++k) wrapped.uv[0][k] = Vec2f(0.0f, 0.75f);
  EXPECT_TRUE(near(wrapped.colorAt(0, Vec3(1, 0, 0)), (texel(0, 0) + texel(0, 1)) / 2));
  for (int k = 0; k < 3; ++k) wrapped.uv[0][k] = Vec2f(1.25f, -0.25f);  // same as (0.25, 0.75)
  EXPECT_TRUE(near(wrapped.colorAt(0, Vec3(1, 0, 0)), texel(0, 0)));
  for (int k = 0; k < 3; ++k) wrapped.uv[0][k] = Vec2f(-0.75f, 1.0f);  // v = 1: halfway between rows 1 and 0
  EXPECT_TRUE(near(wrapped.colorAt(0, Vec3(1, 0, 0)), (texel(0, 0) + texel(1, 0)) / 2));

  // Without a texture the material's diffuse colour is used.
  TexturedModel plain = model;
  plain.materials[0].texture = cv::Mat();
  plain.materials[0].diffuse = Vec3f(0.1f, 0.2f, 0.3f);
  EXPECT_TRUE(near(plain.colorAt(0, Vec3(0.2, 0.3, 0.5)), Vec3f(0.1f, 0.2f, 0.3f)));
}

// ----------------------------------------------------------------------------------------------
// Round trips

TEST(ModelRoundTrip, SpotObj) {
  TM_REQUIRE_SHARED(obj, "meshes/spot/spot_triangulated.obj");
  const TexturedModel model = spotModel(obj);
  const std::string dir = test::tempDir("model_obj") + "/nested/out";  // created by the export
  exportObj(model, dir, "spot");
  for (const char* f : {"spot.obj", "spot.mtl", "spot_spot.png"}) EXPECT_TRUE(fs::exists(fs::path(dir) / f)) << f;
  int files = 0;
  for (const auto& e : fs::directory_iterator(dir)) files += e.is_regular_file() ? 1 : 0;
  EXPECT_EQ(files, 3) << "no temporary files may be left behind";
  // Consumers multiply the texture by Kd: a textured material's is white (three.js showed it darkened by 0.7).
  std::ifstream mtl(dir + "/spot.mtl");
  const std::string text((std::istreambuf_iterator<char>(mtl)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("Kd 1 1 1\n"), std::string::npos) << text;

  const TexturedModel back = loadModel(dir + "/spot.obj");
  ASSERT_EQ(back.mesh.numFaces(), model.mesh.numFaces());
  EXPECT_EQ(back.mesh.numVertices(), model.mesh.numVertices());
  ASSERT_EQ(back.materials.size(), 1u);
  EXPECT_EQ(back.materials[0].textureFile, "spot_spot.png");
  EXPECT_EQ(cv::norm(back.materials[0].texture, model.materials[0].texture, cv::NORM_INF), 0);
  expectSameModel(model, back, matchFaces(model, back), 1e-6, 1e-6);
}

TEST(ModelRoundTrip, SpotGlb) {
  TM_REQUIRE_SHARED(obj, "meshes/spot/spot_triangulated.obj");
  const TexturedModel model = spotModel(obj);
  const std::string path = test::tempDir("model_glb") + "/spot.glb";
  exportGlb(model, path);
  const TexturedModel back = loadModel(path);
  ASSERT_EQ(back.mesh.numFaces(), model.mesh.numFaces());
  EXPECT_EQ(back.mesh.numVertices(), model.mesh.numVertices()) << "vertices split at UV seams must be welded";
  ASSERT_EQ(back.materials.size(), 1u);
  EXPECT_EQ(cv::norm(back.materials[0].texture, model.materials[0].texture, cv::NORM_INF), 0);
  const std::vector<int> map = matchFaces(model, back);
  expectSameModel(model, back, map, 1e-6, 2e-3);
  // Reloading an export of the reloaded model changes nothing.
  const std::string again = fs::path(path).parent_path() / "again.glb";
  exportGlb(back, again);
  const TexturedModel back2 = loadModel(again);
  expectSameModel(back, back2, matchFaces(back, back2), 1e-6, 2e-3);
}

TEST(ModelRoundTrip, UntexturedCubeKeepsColoursAndSources) {
  const TexturedModel cube = cubeModel();
  const std::string dir = test::tempDir("model_cube");
  exportObj(cube, dir, "cube");
  EXPECT_FALSE(fs::exists(dir + "/cube_red_paint.png"));
  const TexturedModel obj = loadModel(dir + "/cube.obj");
  ASSERT_EQ(obj.materials.size(), 2u);
  EXPECT_EQ(obj.materials[0].name, "red_paint");
  EXPECT_FALSE(obj.textured());
  expectSameModel(cube, obj, matchFaces(cube, obj), 0, 1e-6);

  exportGlb(cube, dir + "/cube.glb");
  const TexturedModel glb = loadModel(dir + "/cube.glb");
  EXPECT_EQ(glb.mesh.numVertices(), 8);
  ASSERT_EQ(glb.materials.size(), 2u);
  expectSameModel(cube, glb, matchFaces(cube, glb), 0, 1e-5);  // diffuse goes through linear baseColorFactor
}

// ----------------------------------------------------------------------------------------------
// Loading

TEST(LoadModel, ObjWithMtlOptionsAndGroups) {
  const std::string dir = test::tempDir("model_mtl");
  fs::create_directories(dir + "/tex");
  cv::Mat bgr(4, 8, CV_8UC3, cv::Scalar(10, 20, 30));  // B, G, R
  ASSERT_TRUE(cv::imwrite(dir + "/tex/my tex.png", bgr));
  writeText(dir + "/m.mtl",
            "# comment\r\n"
            "newmtl skin\r\n"
            "Kd 0.5 0.25 1\r\n"
            "map_Kd -bm 0.5 -s 1 1 1 -clamp on tex/my tex.png\r\n"
            "newmtl flat\n"
            "Kd 0.2 0.4 0.6\n");
  writeText(dir + "/m.obj",
            "mtllib m.mtl\n"
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\n"
            "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
            "g tm_source_2\nusemtl skin\nf 1/1 2/2 3/3\n"
            "g tm_inpainted\nf 1/1 3/3 4/4\n"
            "g tm_empty\nusemtl flat\nf 2/1 5/2 3/3\n");
  const TexturedModel m = loadModel(dir + "/m.obj");
  ASSERT_EQ(m.mesh.numFaces(), 3);
  ASSERT_EQ(m.materials.size(), 2u);
  EXPECT_EQ(m.materials[0].name, "skin");
  EXPECT_EQ(m.materials[0].textureFile, "tex/my tex.png");
  ASSERT_EQ(m.materials[0].texture.type(), CV_8UC4);
  EXPECT_EQ(m.materials[0].texture.at<cv::Vec4b>(0, 0), cv::Vec4b(30, 20, 10, 255));  // RGBA
  EXPECT_NEAR(m.materials[0].diffuse[1], 0.25f, 1e-6);
  EXPECT_TRUE(m.materials[1].texture.empty());
  EXPECT_NEAR(m.materials[1].diffuse[2], 0.6f, 1e-6);
  EXPECT_EQ(m.faceMaterial, (std::vector<int>{0, 0, 1}));
  EXPECT_EQ(m.faceSource, (std::vector<int>{2, kSourceInpainted, kSourceEmpty}));
  EXPECT_TRUE((m.colorAt(0, Vec3(0.3, 0.3, 0.4)) - Vec3f(30, 20, 10) / 255).cwiseAbs().maxCoeff() < 1e-6);
  EXPECT_TRUE((m.colorAt(2, Vec3(0.3, 0.3, 0.4)) - Vec3f(0.2f, 0.4f, 0.6f)).cwiseAbs().maxCoeff() < 1e-6);
}

TEST(LoadModel, PlainMeshIsUntextured) {
  const std::string dir = test::tempDir("model_plain");
  writeText(dir + "/t.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  const TexturedModel m = loadModel(dir + "/t.off");
  EXPECT_EQ(m.mesh.numFaces(), 1);
  EXPECT_FALSE(m.textured());
  ASSERT_EQ(m.materials.size(), 1u);
  EXPECT_EQ(m.faceMaterial, std::vector<int>{0});
  EXPECT_TRUE(m.faceSource.empty());
  EXPECT_TRUE((m.colorAt(0, Vec3(1, 0, 0)) - Vec3f(0.7f, 0.7f, 0.7f)).cwiseAbs().maxCoeff() < 1e-6);
}

// A glTF model written with tinygltf directly: two primitives of a unit square split along the
// diagonal (vertices duplicated, as glTF exporters do), UNSIGNED_BYTE and UNSIGNED_SHORT indices, a node
// transform, and a primitive mode that can be changed.
tinygltf::Model squareGltf(int mode) {
  tinygltf::Model gm;
  gm.asset.version = "2.0";
  gm.buffers.emplace_back();
  auto& bytes = gm.buffers[0].data;
  const auto addView = [&](const void* data, size_t size) {
    while (bytes.size() % 4) bytes.push_back(0);
    tinygltf::BufferView view;
    view.buffer = 0;
    view.byteOffset = bytes.size();
    view.byteLength = size;
    bytes.insert(bytes.end(), static_cast<const unsigned char*>(data), static_cast<const unsigned char*>(data) + size);
    gm.bufferViews.push_back(view);
    return static_cast<int>(gm.bufferViews.size()) - 1;
  };
  const auto addAccessor = [&](int view, int componentType, int type, size_t count) {
    tinygltf::Accessor acc;
    acc.bufferView = view;
    acc.componentType = componentType;
    acc.type = type;
    acc.count = count;
    gm.accessors.push_back(acc);
    return static_cast<int>(gm.accessors.size()) - 1;
  };
  const float posA[] = {0, 0, 0, 1, 0, 0, 1, 1, 0}, posB[] = {0, 0, 0, 1, 1, 0, 0, 1, 0};
  const float uvA[] = {0, 1, 1, 1, 1, 0}, uvB[] = {0, 1, 1, 0, 0, 0};  // glTF v down
  const uint8_t idxA[] = {0, 1, 2};
  const uint16_t idxB[] = {0, 1, 2};
  tinygltf::Mesh mesh;
  for (int p = 0; p < 2; ++p) {
    tinygltf::Primitive prim;
    prim.mode = mode;
    prim.attributes["POSITION"] =
        addAccessor(addView(p ? posB : posA, sizeof posA), TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, 3);
    prim.attributes["TEXCOORD_0"] =
        addAccessor(addView(p ? uvB : uvA, sizeof uvA), TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC2, 3);
    prim.indices =
        p ? addAccessor(addView(idxB, sizeof idxB), TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT, TINYGLTF_TYPE_SCALAR, 3)
          : addAccessor(addView(idxA, sizeof idxA), TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_TYPE_SCALAR, 3);
    prim.material = 0;
    tinygltf::Value::Object extras;
    extras["tm_source"] = tinygltf::Value(p ? 5 : kSourceInpainted);
    prim.extras = tinygltf::Value(extras);
    mesh.primitives.push_back(prim);
  }
  gm.meshes.push_back(mesh);
  tinygltf::Material mat;
  mat.name = "grey";
  mat.pbrMetallicRoughness.baseColorFactor = {0.2140, 0.2140, 0.2140, 1};  // sRGB 0.5
  gm.materials.push_back(mat);
  // Parent scales by 2, child translates by (10, 0, 0) and holds the mesh.
  tinygltf::Node parent, child;
  parent.scale = {2, 2, 2};
  parent.children = {1};
  child.translation = {10, 0, 0};
  child.mesh = 0;
  gm.nodes = {parent, child};
  tinygltf::Scene scene;
  scene.nodes = {0};
  gm.scenes.push_back(scene);
  gm.defaultScene = 0;
  return gm;
}

void writeGltf(const tinygltf::Model& gm, const std::string& path, bool binary) {
  tinygltf::TinyGLTF writer;
  ASSERT_TRUE(writer.WriteGltfSceneToFile(&gm, path, true, true, false, binary)) << path;
}

TEST(LoadModel, GltfNodeTransformIndexTypesAndWelding) {
  const std::string dir = test::tempDir("model_gltf");
  for (const bool binary : {true, false}) {
    const std::string path = dir + (binary ? "/square.glb" : "/square.gltf");
    writeGltf(squareGltf(TINYGLTF_MODE_TRIANGLES), path, binary);
    const TexturedModel m = loadModel(path);
    ASSERT_EQ(m.mesh.numFaces(), 2);
    EXPECT_EQ(m.mesh.numVertices(), 4) << "identical positions of the two primitives must be welded";
    Vec3 lo, hi;
    m.mesh.bounds(lo, hi);
    EXPECT_NEAR((lo - Vec3(20, 0, 0)).norm(), 0, 1e-12);  // world = scale(2) * translate(10, 0, 0)
    EXPECT_NEAR((hi - Vec3(22, 2, 0)).norm(), 0, 1e-12);
    ASSERT_TRUE(m.textured());
    // UVs back in OBJ convention: u = x / 2 - 10, v = y / 2 at every corner.
    for (int f = 0; f < 2; ++f) {
      const auto p = m.mesh.facePositions(f);
      for (int k = 0; k < 3; ++k) {
        EXPECT_NEAR(m.uv[f][k].x(), p[k].x() / 2 - 10, 1e-6);
        EXPECT_NEAR(m.uv[f][k].y(), p[k].y() / 2, 1e-6);
      }
    }
    ASSERT_EQ(m.faceSource.size(), 2u);
    EXPECT_EQ(std::set<int>(m.faceSource.begin(), m.faceSource.end()), (std::set<int>{kSourceInpainted, 5}));
    ASSERT_EQ(m.materials.size(), 1u);
    EXPECT_EQ(m.materials[0].name, "grey");
    EXPECT_NEAR(m.materials[0].diffuse[0], 0.5f, 1e-3);
    EXPECT_GT(m.mesh.faceNormal(0).z(), 0.99);  // winding kept
  }
}

TEST(LoadModel, GltfRejectsNonTriangleModes) {
  const std::string path = test::tempDir("model_lines") + "/lines.glb";
  writeGltf(squareGltf(TINYGLTF_MODE_LINE), path, true);
  const std::string msg = errorOf([&] { loadModel(path); });
  EXPECT_NE(msg.find(path), std::string::npos) << msg;
  EXPECT_NE(msg.find("primitives[0]"), std::string::npos) << msg;
  EXPECT_NE(msg.find("LINES"), std::string::npos) << msg;
}

TEST(LoadModel, RealFiles) {
  TM_REQUIRE_SHARED(bob, "meshes/bob/bob_tri.obj");
  TM_REQUIRE_SHARED(lee, "meshes/leeperrysmith/LeePerrySmith.glb");
  const TexturedModel b = loadModel(bob);
  EXPECT_EQ(b.mesh.numFaces(), 10688);
  ASSERT_EQ(b.materials.size(), 1u);
  EXPECT_FALSE(b.materials[0].texture.empty());
  EXPECT_EQ(b.materials[0].textureFile, "bob_diffuse.png");
  const TexturedModel l = loadModel(lee);
  EXPECT_EQ(l.mesh.numFaces(), 17684);
  EXPECT_TRUE(l.textured());
  ASSERT_EQ(l.materials.size(), 1u);
  EXPECT_TRUE(l.materials[0].texture.empty());
}

// ----------------------------------------------------------------------------------------------
// Errors

TEST(LoadModel, ErrorMissingTexture) {
  const std::string dir = test::tempDir("model_err_tex");
  writeText(dir + "/a.mtl", "newmtl m\nKd 1 1 1\nmap_Kd -bm 1 missing_texture.png\n");
  writeText(dir + "/a.obj", "mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nusemtl m\nf 1/1 2/1 3/1\n");
  const std::string msg = errorOf([&] { loadModel(dir + "/a.obj"); });
  EXPECT_NE(msg.find("a.mtl:3"), std::string::npos) << msg;
  EXPECT_NE(msg.find("missing_texture.png"), std::string::npos) << msg;
  EXPECT_NE(msg.find("not found"), std::string::npos) << msg;
  // A missing material library is named too.
  writeText(dir + "/b.obj", "mtllib nothere.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  const std::string lib = errorOf([&] { loadModel(dir + "/b.obj"); });
  EXPECT_NE(lib.find("b.obj"), std::string::npos) << lib;
  EXPECT_NE(lib.find("nothere.mtl"), std::string::npos) << lib;
}

TEST(LoadModel, ErrorTruncatedGlb) {
  const std::string dir = test::tempDir("model_err_glb");
  exportGlb(cubeModel(), dir + "/cube.glb");
  std::ifstream in(dir + "/cube.glb", std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_GT(bytes.size(), 100u);
  writeText(dir + "/cut.glb", bytes.substr(0, bytes.size() / 2));
  const std::string msg = errorOf([&] { loadModel(dir + "/cut.glb"); });
  EXPECT_NE(msg.find("cut.glb"), std::string::npos) << msg;
  EXPECT_NE(msg.find("truncated"), std::string::npos) << msg;
  writeText(dir + "/junk.glb", "this is not a glb file at all");
  const std::string junk = errorOf([&] { loadModel(dir + "/junk.glb"); });
  EXPECT_NE(junk.find("junk.glb"), std::string::npos) << junk;
}

// ---- hostile files (issue 15) ----------------------------------------------------------------------------

std::string readBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void putU32(std::string& bytes, size_t at, uint32_t v) {
  for (int k = 0; k < 4; ++k) bytes[at + k] = char(v >> (8 * k) & 0xff);
}

TEST(LoadModelHostile, GlbWrongLengthFieldsAreNamed) {
  // Was "Invalid glTF binary." for all of them.
  const std::string dir = test::tempDir("model_glb_len");
  exportGlb(cubeModel(), dir + "/cube.glb");
  const std::string good = readBytes(dir + "/cube.glb");
  const uint32_t jsonLength = uint32_t((unsigned char)good[12]) | uint32_t((unsigned char)good[13]) << 8 |
                              uint32_t((unsigned char)good[14]) << 16 | uint32_t((unsigned char)good[15]) << 24;
  struct Case {
    const char* name;
    size_t at;
    uint32_t value;
    const char* expected;
  };
  const Case cases[] = {
      {"version", 4, 1, "binary glTF version 1 is not supported"},
      {"length", 8, 0xffffffffu, "file is truncated: its header announces 4294967295 bytes"},
      {"small", 8, 12, "header length 12 leaves no room for the JSON chunk"},
      {"jsonlen", 12, 0x7ffffff0u, "the JSON chunk length 2147483632 runs past the end"},
      {"jsontype", 16, 0x12345678u, "the first chunk is not JSON"},
      {"binlen", 20 + jsonLength, 0xfffffff0u, "the BIN chunk length 4294967280 runs past the end"},
      {"bintype", 24 + jsonLength, 7, "the second chunk is not BIN"},
  };
  for (const Case& c : cases) {
    std::string bytes = good;
    putU32(bytes, c.at, c.value);
    const std::string path = dir + "/" + c.name + ".glb";
    writeText(path, bytes);
    const std::string msg = errorOf([&] { loadModel(path); });
    EXPECT_NE(msg.find(path + ": " + c.expected), std::string::npos) << c.name << ": " << msg;
  }
}

TEST(LoadModelHostile, GltfNeverReadsOutsideItsFolder) {
  // A buffer URI of /etc/passwd was followed and reported as "File not found".
  const std::string dir = test::tempDir("model_outside");
  fs::create_directories(dir + "/model");
  writeText(dir + "/secret.bin", std::string(64, 'x'));
  for (const std::string uri : {"/etc/passwd", "../secret.bin", "sub/../../secret.bin", "%2E%2E/secret.bin"}) {
    tinygltf::Model gm = squareGltf(TINYGLTF_MODE_TRIANGLES);
    writeGltf(gm, dir + "/model/base.gltf", false);
    std::string text = readBytes(dir + "/model/base.gltf");
    // Point the buffer at the outside file instead of the written one.
    const std::regex bufferUri("\"uri\"\\s*:\\s*\"[^\"]*\"");
    text = std::regex_replace(text, bufferUri, "\"uri\": \"" + uri + "\"", std::regex_constants::format_first_only);
    writeText(dir + "/model/evil.gltf", text);
    const std::string msg = errorOf([&] { loadModel(dir + "/model/evil.gltf"); });
    EXPECT_NE(msg.find("buffers[0].uri '" + uri + "' is outside the model's folder"), std::string::npos)
        << uri << ": " << msg;
  }
  // A link inside the folder that points out of it is outside too.
  fs::create_symlink(dir + "/secret.bin", dir + "/model/link.bin");
  tinygltf::Model gm = squareGltf(TINYGLTF_MODE_TRIANGLES);
  writeGltf(gm, dir + "/model/base.gltf", false);
  std::string text = readBytes(dir + "/model/base.gltf");
  text = std::regex_replace(text, std::regex("\"uri\"\\s*:\\s*\"[^\"]*\""), "\"uri\": \"link.bin\"",
                            std::regex_constants::format_first_only);
  writeText(dir + "/model/link.gltf", text);
  const std::string msg = errorOf([&] { loadModel(dir + "/model/link.gltf"); });
  EXPECT_NE(msg.find("is outside the model's folder"), std::string::npos) << msg;
}

TEST(LoadModelHostile, ObjMaterialsNeverReadOutsideTheFolder) {
  const std::string dir = test::tempDir("model_obj_outside");
  fs::create_directories(dir + "/model");
  writeText(dir + "/outside.mtl", "newmtl a\nKd 1 0 0\n");
  const std::string obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nusemtl a\nf 1/1 2/2 3/3\n";
  writeText(dir + "/model/a.obj", "mtllib ../outside.mtl\n" + obj);
  std::string msg = errorOf([&] { loadModel(dir + "/model/a.obj"); });
  EXPECT_NE(msg.find("material library '../outside.mtl' is outside the model's folder"), std::string::npos) << msg;
  writeText(dir + "/model/b.mtl", "newmtl a\nmap_Kd /etc/passwd\n");
  writeText(dir + "/model/b.obj", "mtllib b.mtl\n" + obj);
  msg = errorOf([&] { loadModel(dir + "/model/b.obj"); });
  EXPECT_NE(msg.find("b.mtl:2: map_Kd texture '/etc/passwd' is outside the model's folder"), std::string::npos)
      << msg;
}

TEST(LoadModelHostile, DeepNestingLongNodeChainsAndHugeCounts) {
  const std::string dir = test::tempDir("model_deep");
  // Extras nested 100000 deep (tinygltf recurses into them).
  tinygltf::Model gm = squareGltf(TINYGLTF_MODE_TRIANGLES);
  writeGltf(gm, dir + "/base.gltf", false);
  std::string text = readBytes(dir + "/base.gltf");
  const size_t brace = text.rfind('}');
  writeText(dir + "/deep.gltf", text.substr(0, brace) + ", \"extras\": " + std::string(100000, '[') +
                                    std::string(100000, ']') + "}");
  std::string msg = errorOf([&] { loadModel(dir + "/deep.gltf"); });
  EXPECT_NE(msg.find("nested more than 64 deep"), std::string::npos) << msg;

  // 200000 nodes, each the child of the one before, the mesh at the end: no recursion.
  gm = squareGltf(TINYGLTF_MODE_TRIANGLES);
  gm.nodes.clear();
  const int chain = 200000;
  for (int i = 0; i < chain; ++i) {
    tinygltf::Node node;
    if (i + 1 < chain) node.children = {i + 1};
    if (i + 1 == chain) node.mesh = 0;
    gm.nodes.push_back(node);
  }
  writeGltf(gm, dir + "/chain.glb", true);
  const TexturedModel model = loadModel(dir + "/chain.glb");
  EXPECT_EQ(model.mesh.numFaces(), 2);

  // An accessor declaring 2^62 elements is refused before anything is allocated.
  gm = squareGltf(TINYGLTF_MODE_TRIANGLES);
  gm.accessors[0].count = size_t(1) << 62;
  writeGltf(gm, dir + "/count.glb", true);
  msg = errorOf([&] { loadModel(dir + "/count.glb"); });
  EXPECT_NE(msg.find("larger than the buffers could hold"), std::string::npos) << msg;
  // A bufferView whose offset + length wraps around.
  gm = squareGltf(TINYGLTF_MODE_TRIANGLES);
  gm.bufferViews[0].byteOffset = ~size_t(0) - 3;
  gm.bufferViews[0].byteLength = 40;
  writeGltf(gm, dir + "/wrap.glb", true);
  msg = errorOf([&] { loadModel(dir + "/wrap.glb"); });
  EXPECT_NE(msg.find("lies outside its buffer"), std::string::npos) << msg;
}

TEST(LoadModel, ErrorUnsupportedExtensionAndMissingFile) {
  const std::string dir = test::tempDir("model_err_ext");
  writeText(dir + "/model.blend", "whatever");
  const std::string msg = errorOf([&] { loadModel(dir + "/model.blend"); });
  EXPECT_NE(msg.find("model.blend"), std::string::npos) << msg;
  EXPECT_NE(msg.find("unsupported"), std::string::npos) << msg;
  EXPECT_NE(msg.find(".blend"), std::string::npos) << msg;
  EXPECT_NE(msg.find(".fbx"), std::string::npos) << msg;  // the formats it does read are listed
  // A supported format that does not parse names the format's reader.
  writeText(dir + "/model.fbx", "whatever");
  const std::string fbx = errorOf([&] { loadModel(dir + "/model.fbx"); });
  EXPECT_NE(fbx.find("model.fbx: cannot read as FBX"), std::string::npos) << fbx;
  const std::string missing = errorOf([&] { loadModel(dir + "/none.glb"); });
  EXPECT_NE(missing.find("none.glb"), std::string::npos) << missing;
}

TEST(ExportModel, RejectsInconsistentModel) {
  TexturedModel cube = cubeModel();
  cube.faceMaterial[3] = 7;
  const std::string dir = test::tempDir("model_err_export");
  const std::string msg = errorOf([&] { exportGlb(cube, dir + "/bad.glb"); });
  EXPECT_NE(msg.find("bad.glb"), std::string::npos) << msg;
  EXPECT_NE(msg.find("face 3"), std::string::npos) << msg;
  EXPECT_FALSE(fs::exists(dir + "/bad.glb"));
}

// ----------------------------------------------------------------------------------------------
// External checkers

#ifndef TM_GLTF_NODE_DIR
#define TM_GLTF_NODE_DIR ""
#define TM_GLTF_VALIDATE_JS ""
#endif

// An artist's cube as an OBJ: six quads, a UV square on each, one normal per side (hard edges).
std::string quadCubeObj(const std::string& dir) {
  const std::string path = dir + "/quads.obj";
  std::ofstream out(path);
  out << "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
         "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
         "vn 0 0 -1\nvn 0 0 1\nvn 0 -1 0\nvn 1 0 0\nvn 0 1 0\nvn -1 0 0\n"
         "f 1/1/1 4/2/1 3/3/1 2/4/1\nf 5/1/2 6/2/2 7/3/2 8/4/2\nf 1/1/3 2/2/3 6/3/3 5/4/3\n"
         "f 2/1/4 3/2/4 7/3/4 6/4/4\nf 3/1/5 4/2/5 8/3/5 7/4/5\nf 4/1/6 1/2/6 5/3/6 8/4/6\n";
  return path;
}

// Exported GLBs: spot (when the shared data is there), an untextured cube, and the quad cube with its hard normals.
std::vector<std::string> exportedGlbs(const std::string& dir) {
  std::vector<std::string> files;
  const std::string spot = test::sharedFile("meshes/spot/spot_triangulated.obj");
  if (!spot.empty()) {
    files.push_back(dir + "/spot.glb");
    exportGlb(spotModel(spot), files.back());
  }
  files.push_back(dir + "/cube.glb");
  exportGlb(cubeModel(), files.back());
  files.push_back(dir + "/quads.glb");
  exportGlb(modelFromMesh(*requireUsable(loadMesh(quadCubeObj(dir))), cv::Mat(4, 4, CV_8UC4, cv::Scalar(9, 9, 9, 255))),
            files.back());
  return files;
}

// Lines of `file` starting with `prefix` (with `corners` words after it, when given).
int countLines(const std::string& file, const std::string& prefix, int corners = -1) {
  std::ifstream in(file);
  int n = 0;
  for (std::string line; std::getline(in, line);) {
    if (line.rfind(prefix, 0) != 0) continue;
    std::istringstream words(line);
    int w = -1;
    for (std::string word; words >> word;) ++w;
    n += corners < 0 || w == corners;
  }
  return n;
}

// The OBJ export writes the quad cube's quads back as quads with the file's normals; a quad whose two triangles the
// texture splits apart (a chart border on its diagonal) comes out as its two triangles; the GLB keeps the hard edges
// (three normals at each corner of the cube).
TEST(ExportModel, ObjKeepsTheFilesQuadsAndNormalsGlbItsHardEdges) {
  const std::string dir = test::tempDir("model_quads");
  const LoadedMesh loaded = loadMesh(quadCubeObj(dir));
  ASSERT_TRUE(loaded.mesh) << loaded.report.summary();
  const Mesh& mesh = *loaded.mesh;
  ASSERT_EQ(mesh.numFaces(), 12);
  ASSERT_EQ(mesh.cornerNormal.size(), 12u);
  ASSERT_EQ(mesh.facePolygon.size(), 12u);
  for (int f = 0; f < 12; ++f)
    for (int k = 0; k < 3; ++k) EXPECT_GT(mesh.cornerNormal[f][k].cast<double>().dot(mesh.faceNormal(f)), 0.999);

  TexturedModel model = modelFromMesh(mesh, cv::Mat(8, 8, CV_8UC4, cv::Scalar(10, 200, 30, 255)));
  exportObj(model, dir, "out");
  const std::string obj = dir + "/out.obj";
  EXPECT_EQ(countLines(obj, "f "), 6);
  EXPECT_EQ(countLines(obj, "f ", 4), 6);
  EXPECT_EQ(countLines(obj, "vn "), 6);
  // Read back: the same surface, UVs and normals.
  const LoadedMesh again = loadMesh(obj);
  ASSERT_TRUE(again.mesh);
  ASSERT_EQ(again.mesh->numFaces(), 12);
  for (int f = 0; f < 12; ++f)
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(again.mesh->cornerNormal[f][k], mesh.cornerNormal[f][k]) << f;
      EXPECT_NEAR((again.mesh->cornerUV[f][k] - mesh.cornerUV[f][k]).norm(), 0, 1e-6) << f;
    }

  // A chart border on the first quad's diagonal: its second triangle's texture moves; that quad is two triangles.
  for (int k = 0; k < 3; ++k) model.uv[1][k] += Vec2f(0.5f, 0);
  exportObj(model, dir, "split");
  EXPECT_EQ(countLines(dir + "/split.obj", "f ", 4), 5);
  EXPECT_EQ(countLines(dir + "/split.obj", "f ", 3), 2);

  // The GLB: every corner of the cube with its side's normal (8 corners x 3 sides), all axis-aligned.
  exportGlb(modelFromMesh(mesh, cv::Mat(8, 8, CV_8UC4, cv::Scalar(10, 200, 30, 255))), dir + "/out.glb");
  tinygltf::TinyGLTF loader;
  tinygltf::Model gm;
  std::string err, warn;
  ASSERT_TRUE(loader.LoadBinaryFromFile(&gm, &err, &warn, dir + "/out.glb")) << err;
  const tinygltf::Accessor& normals = gm.accessors.at(gm.meshes[0].primitives[0].attributes.at("NORMAL"));
  EXPECT_EQ(normals.count, 24u);
  const tinygltf::BufferView& view = gm.bufferViews.at(normals.bufferView);
  const auto* n = reinterpret_cast<const float*>(gm.buffers[0].data.data() + view.byteOffset + normals.byteOffset);
  for (size_t i = 0; i < normals.count; ++i)
    EXPECT_NEAR(std::max({std::abs(n[3 * i]), std::abs(n[3 * i + 1]), std::abs(n[3 * i + 2])}), 1.0, 1e-6) << i;
  // And loaded back, the GLB's normals are the mesh's.
  const LoadedMesh glb = loadMesh(dir + "/out.glb");
  ASSERT_TRUE(glb.mesh);
  ASSERT_EQ(glb.mesh->cornerNormal.size(), 12u);
  for (int f = 0; f < 12; ++f)
    EXPECT_GT(glb.mesh->cornerNormal[f][0].cast<double>().dot(glb.mesh->faceNormal(f)), 0.999) << f;
}

// A PLY's vertex normals (nx ny nz) come in as the corners' normals, unit length.
TEST(ExportModel, PlyVertexNormalsAreTheCornersNormals) {
  const std::string dir = test::tempDir("model_ply_normals");
  const std::string path = dir + "/tet.ply";
  std::ofstream(path) << "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                         "property float z\nproperty float nx\nproperty float ny\nproperty float nz\n"
                         "element face 4\nproperty list uchar int vertex_indices\nend_header\n"
                         "0 0 0 -1 -1 -1\n1 0 0 2 0 0\n0 1 0 0 3 0\n0 0 1 0 0 4\n"
                         "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
  const LoadedMesh loaded = loadMesh(path);
  ASSERT_TRUE(loaded.mesh) << loaded.report.summary();
  const Mesh& mesh = *loaded.mesh;
  ASSERT_EQ(mesh.cornerNormal.size(), 4u);
  EXPECT_TRUE(mesh.facePolygon.empty());  // triangles only
  for (int f = 0; f < 4; ++f)
    for (int k = 0; k < 3; ++k) {
      const int v = mesh.faceVertices(f)[k];
      const Vec3 expected = v == 0 ? Vec3(-1, -1, -1).normalized() : Vec3::Unit(v - 1);
      EXPECT_NEAR((mesh.cornerNormal[f][k].cast<double>() - expected).norm(), 0, 1e-6) << f << " " << k;
    }
}

TEST(GltfValidator, ExportedGlbsHaveNoErrors) {
  if (const std::string why = test::gltfValidatorMissing(); !why.empty()) GTEST_SKIP() << why;
  for (const std::string& file : exportedGlbs(test::tempDir("gltf_validator"))) {
    int rc = 0;
    const std::string out = test::runGltfValidator(file, &rc);
    ASSERT_NE(rc, 77) << "validator missing although setup reported it ready:\n" << out;
    EXPECT_EQ(rc, 0) << out;
    EXPECT_NE(out.find("errors: 0,"), std::string::npos) << out;
    EXPECT_NE(out.find("warnings: 0,"), std::string::npos) << out;
  }
}

TEST(Assimp, ReadsExportedObjAndGlb) {
  if (test::runCommand("command -v assimp") != 0)
    GTEST_SKIP() << "assimp is not installed (Debian package assimp-utils): exports not checked with assimp";
  const std::string dir = test::tempDir("assimp");
  std::vector<std::pair<std::string, int>> files;  // file, expected face count
  const std::string spot = test::sharedFile("meshes/spot/spot_triangulated.obj");
  if (!spot.empty()) {
    const TexturedModel model = spotModel(spot);
    exportObj(model, dir, "spot");
    exportGlb(model, dir + "/spot.glb");
    files = {{dir + "/spot.obj", model.mesh.numFaces()}, {dir + "/spot.glb", model.mesh.numFaces()}};
  }
  const TexturedModel cube = cubeModel();
  exportObj(cube, dir, "cube");
  exportGlb(cube, dir + "/cube.glb");
  files.push_back({dir + "/cube.obj", 12});
  files.push_back({dir + "/cube.glb", 12});
  for (const auto& [file, faces] : files) {
    std::string out;
    const int rc = test::runCommand("assimp info '" + file + "'", &out);
    EXPECT_EQ(rc, 0) << file << ":\n" << out;
    std::smatch m;
    ASSERT_TRUE(std::regex_search(out, m, std::regex("Faces:\\s+(\\d+)"))) << file << ":\n" << out;
    EXPECT_EQ(std::stoi(m[1]), faces) << file;
  }
}

}  // namespace
}  // namespace montage
