// FBX, Collada, 3DS and 3MF meshes through Assimp (io/mesh_io.h): real meshes written by Assimp's own
// exporters read back as their OBJ does; broken files get errors that name the file and the reason.
#include <assimp/scene.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <assimp/Exporter.hpp>
#include <assimp/Importer.hpp>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <random>

#include "geometry/mesh.h"
#include "io/mesh_io.h"
#include "test_support.h"

using namespace montage;
namespace fs = std::filesystem;

namespace {

// A binary FBX 7.4 file as Blender and Maya write them (Assimp 5.2's own binary FBX exporter writes files its
// reader refuses, assimp#4686): node records with 32-bit offsets, each nested list closed by a 13-byte null record.
struct FbxNode {
  std::string name;
  std::string props;
  uint32_t count = 0;
  std::vector<FbxNode> children;

  template <class T>
  void raw(const T& v) {
    props.append(reinterpret_cast<const char*>(&v), sizeof v);
  }
  FbxNode& S(const std::string& s) {
    props += 'S', raw(uint32_t(s.size())), props += s, ++count;
    return *this;
  }
  FbxNode& I(int32_t v) { return props += 'I', raw(v), ++count, *this; }
  FbxNode& L(int64_t v) { return props += 'L', raw(v), ++count, *this; }
  template <class T>
  FbxNode& array(char type, const std::vector<T>& v) {
    props += type, raw(uint32_t(v.size())), raw(uint32_t(0)), raw(uint32_t(v.size() * sizeof(T)));
    for (const T& x : v) raw(x);
    return ++count, *this;
  }
  FbxNode& child(const std::string& n) {
    children.push_back(FbxNode{n});
    return children.back();
  }
  void write(std::string& out) const {
    const size_t start = out.size();
    out.append(12, '\0');
    out += char(name.size()), out += name, out += props;
    for (const FbxNode& c : children) c.write(out);
    if (!children.empty()) out.append(13, '\0');
    const uint32_t head[3] = {uint32_t(out.size()), count, uint32_t(props.size())};
    std::memcpy(&out[start], head, sizeof head);
  }
};

// An object's name as binary FBX writes it: "name", 0x00 0x01, "class".
std::string binaryName(const std::string& name, const std::string& type) {
  return name + '\0' + '\x01' + type;
}

// A mesh of polygons (corner lists into `positions`) and, when given, one UV per polygon corner, as one model.
std::string binaryFbx(const std::vector<Vec3>& positions, const std::vector<std::vector<int>>& polygons,
                      const std::vector<Vec2>& cornerUV = {}) {
  std::vector<FbxNode> top(4);
  top[0].name = "FBXHeaderExtension";
  top[0].child("FBXHeaderVersion").I(1003);
  top[0].child("FBXVersion").I(7400);
  top[1].name = "Objects";
  FbxNode& geometry = top[1].child("Geometry").L(100).S(binaryName("mesh", "Geometry")).S("Mesh");
  std::vector<double> xyz;
  for (const Vec3& p : positions) xyz.insert(xyz.end(), {p.x(), p.y(), p.z()});
  geometry.child("Vertices").array('d', xyz);
  std::vector<int32_t> index;
  for (const auto& poly : polygons)
    for (size_t k = 0; k < poly.size(); ++k) index.push_back(k + 1 == poly.size() ? ~poly[k] : poly[k]);
  geometry.child("PolygonVertexIndex").array('i', index);
  if (!cornerUV.empty()) {
    FbxNode& uv = geometry.child("LayerElementUV").I(0);
    uv.child("Version").I(101);
    uv.child("Name").S("UVMap");
    uv.child("MappingInformationType").S("ByPolygonVertex");
    uv.child("ReferenceInformationType").S("IndexToDirect");
    std::vector<double> uvs;
    std::vector<int32_t> uvIndex;
    for (const Vec2& t : cornerUV) uvIndex.push_back(int32_t(uvIndex.size())), uvs.insert(uvs.end(), {t.x(), t.y()});
    uv.child("UV").array('d', uvs);
    uv.child("UVIndex").array('i', uvIndex);
    FbxNode& layer = geometry.child("Layer").I(0);
    layer.child("Version").I(100);
    FbxNode& element = layer.child("LayerElement");
    element.child("Type").S("LayerElementUV");
    element.child("TypedIndex").I(0);
  }
  top[1].child("Model").L(200).S(binaryName("mesh", "Model")).S("Mesh").child("Version").I(232);
  top[2].name = "Connections";
  top[2].child("C").S("OO").L(100).L(200);
  top[2].child("C").S("OO").L(200).L(0);
  top.pop_back();
  std::string out("Kaydara FBX Binary  \0\x1a\0", 23);
  const uint32_t version = 7400;
  out.append(reinterpret_cast<const char*>(&version), 4);
  for (const FbxNode& n : top) n.write(out);
  out.append(13, '\0');
  return out;
}

struct Format {
  const char* exporter;  // Assimp's export format id
  const char* ext;
  bool uv;   // whether the format keeps texture coordinates
  bool zUp;  // whether Assimp writes it Z up: read back as (x, z, -y)
};
// Assimp writes FBX as text here (its binary writer is broken, above); binary FBX is tested with binaryFbx.
const Format kFormats[] = {{"fbxa", "fbx", true, false},
                           {"collada", "dae", true, false},
                           {"3ds", "3ds", true, true},
                           {"3mf", "3mf", false, false}};

Vec3 axesOf(const Format& f, const Vec3& p) {
  return f.zUp ? Vec3(p.x(), -p.z(), p.y()) : p;
}

// `obj` written in each format by Assimp's exporters, into `dir`; the paths by extension.
std::vector<std::pair<Format, std::string>> exportAll(const std::string& obj, const std::string& dir) {
  Assimp::Importer importer;
  const aiScene* scene = importer.ReadFile(obj, 0);
  EXPECT_NE(scene, nullptr) << importer.GetErrorString();
  std::vector<std::pair<Format, std::string>> out;
  if (!scene) return out;
  Assimp::Exporter exporter;
  for (const Format& f : kFormats) {
    const std::string path = (fs::path(dir) / (std::string("mesh.") + f.ext)).string();
    EXPECT_EQ(exporter.Export(scene, f.exporter, path), aiReturn_SUCCESS) << f.ext << ": " << exporter.GetErrorString();
    out.emplace_back(f, path);
  }
  return out;
}

// Each vertex of `read` matched to the vertex of `obj` at its place (within 1e-5 of the model's size: the
// formats store floats), after `axes` (a format's own up axis); -1 where none is.
std::vector<int> matchVertices(const Mesh& read, const Mesh& obj, const std::function<Vec3(const Vec3&)>& axes) {
  std::vector<std::pair<double, int>> byX;
  for (int v = 0; v < obj.numVertices(); ++v) byX.emplace_back(obj.position(v).x(), v);
  std::sort(byX.begin(), byX.end());
  std::vector<int> match(read.numVertices(), -1);
  const double tol = 1e-5;
  for (int v = 0; v < read.numVertices(); ++v) {
    const Vec3 p = axes(read.position(v));
    auto it = std::lower_bound(byX.begin(), byX.end(), std::make_pair(p.x() - tol, -1));
    for (; it != byX.end() && it->first <= p.x() + tol; ++it)
      if ((obj.position(it->second) - p).norm() < tol) match[v] = it->second;
  }
  return match;
}

// A face as its matched corners, rotated to start at the smallest (orientation kept), with its corner UVs.
std::map<std::array<int, 3>, std::array<Vec2, 3>> faceSet(const Mesh& m, const std::vector<int>& match) {
  std::map<std::array<int, 3>, std::array<Vec2, 3>> out;
  for (int f = 0; f < m.numFaces(); ++f) {
    const auto v = m.faceVertices(f);
    std::array<int, 3> c;
    for (int k = 0; k < 3; ++k) c[k] = match.empty() ? v[k] : match[v[k]];
    const int first = int(std::min_element(c.begin(), c.end()) - c.begin());
    std::array<int, 3> key;
    std::array<Vec2, 3> uv;
    for (int k = 0; k < 3; ++k) {
      key[k] = c[(first + k) % 3];
      uv[k] = m.hasUV() ? m.cornerUV[f][(first + k) % 3] : Vec2::Zero();
    }
    out[key] = uv;
  }
  return out;
}

// The same vertices (welded), the same triangles in the same orientation, and where `uv`, the same corner UVs.
void expectSameMesh(
    const Mesh& read, const Mesh& obj, const std::string& what, bool uv = false,
    const std::function<Vec3(const Vec3&)>& axes = [](const Vec3& p) { return p; }) {
  EXPECT_EQ(read.numFaces(), obj.numFaces()) << what;
  EXPECT_EQ(read.numVertices(), obj.numVertices()) << what << ": identical positions welded";
  const std::vector<int> match = matchVertices(read, obj, axes);
  EXPECT_EQ(std::count(match.begin(), match.end(), -1), 0) << what << ": vertices at no vertex of the OBJ";
  const auto got = faceSet(read, match), want = faceSet(obj, {});
  ASSERT_EQ(got.size(), want.size()) << what;
  int missing = 0;
  double worstUV = 0;
  for (const auto& [key, uvs] : want) {
    const auto it = got.find(key);
    if (it == got.end()) {
      ++missing;
      continue;
    }
    if (uv)
      for (int k = 0; k < 3; ++k) worstUV = std::max(worstUV, (it->second[k] - uvs[k]).norm());
  }
  EXPECT_EQ(missing, 0) << what << ": triangles of the OBJ not in the file, or turned over";
  if (uv) {
    EXPECT_TRUE(read.hasUV()) << what;
    EXPECT_LT(worstUV, 1e-5) << what;
  }
}

}  // namespace

// The bundled cat (15,894 faces) read from FBX, Collada, 3DS and 3MF as written by Assimp: the same triangles,
// the same orientation, the same vertex count once identical positions are welded.
TEST(Assimp, TheDemoCatInFourFormatsReadsLikeItsObj) {
  const std::string obj = test::assetsDir() + "/demo/cat.obj";
  const auto cat = requireUsable(loadMesh(obj));
  const std::string dir = test::tempDir("assimp_cat");
  for (const auto& [format, path] : exportAll(obj, dir)) {
    const LoadedMesh loaded = loadMesh(path);
    ASSERT_TRUE(loaded.mesh) << path << ": " << loaded.report.summary();
    EXPECT_EQ(loaded.report.format, format.ext);
    expectSameMesh(*loaded.mesh, *cat, path, false, [&](const Vec3& p) { return axesOf(format, p); });
    EXPECT_TRUE(isMeshExtension(std::string(".") + format.ext));
  }
}

// A mesh with UVs (spot): the corners keep their texture coordinates where the format carries them.
TEST(Assimp, SpotKeepsItsUvsInFbxColladaAnd3ds) {
  TM_REQUIRE_SHARED(obj, "meshes/spot/spot_triangulated.obj");
  const auto spot = requireUsable(loadMesh(obj));
  ASSERT_TRUE(spot->hasUV());
  const std::string dir = test::tempDir("assimp_spot");
  for (const auto& [format, path] : exportAll(obj, dir)) {
    if (!format.uv) continue;
    const LoadedMesh loaded = loadMesh(path);
    ASSERT_TRUE(loaded.mesh) << path << ": " << loaded.report.summary();
    expectSameMesh(*loaded.mesh, *spot, path, true, [&](const Vec3& p) { return axesOf(format, p); });
  }
}

// Broken files: an error naming the file and the format, never a crash; an unknown extension lists the formats.
TEST(Assimp, BrokenFilesAreRefusedWithTheFileAndTheReason) {
  const std::string dir = test::tempDir("assimp_broken");
  const std::string obj = test::assetsDir() + "/demo/cat.obj";
  auto write = [&](const std::string& name, const std::string& bytes) {
    const std::string path = (fs::path(dir) / name).string();
    std::ofstream(path, std::ios::binary) << bytes;
    return path;
  };
  for (const char* ext : {"fbx", "dae", "3ds", "3mf"}) {
    const std::string path = write(std::string("noise.") + ext, std::string(600, '\x07') + "not a mesh");
    const std::string e = test::errorOf([&] { loadMesh(path); });
    EXPECT_NE(e.find(path), std::string::npos) << e;
    EXPECT_NE(e.find("cannot read as"), std::string::npos) << e;
    EXPECT_EQ(e.find("magic"), std::string::npos) << e << ": Assimp's name for a file in memory";
  }
  // A real FBX cut in half.
  const auto files = exportAll(obj, dir);
  ASSERT_FALSE(files.empty());
  std::ifstream in(files[0].second, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string half = write("half.fbx", bytes.substr(0, bytes.size() / 2));
  const std::string e = test::errorOf([&] { loadMesh(half); });
  EXPECT_NE(e.find(half), std::string::npos) << e;
  EXPECT_NE(e.find("FBX"), std::string::npos) << e;
  const std::string u = test::errorOf([&] { loadMesh(write("x.blend", "BLENDER")); });
  EXPECT_NE(u.find(".fbx .dae .3ds .3mf"), std::string::npos) << u;
}

// A binary FBX (the kind Blender and Maya write): the bundled cat's triangles as they are in its OBJ, and a
// strip of quads with UVs per corner, fanned as OBJ's polygons are, each corner with its UV.
TEST(Assimp, BinaryFbxReadsTrianglesQuadsAndUvs) {
  const std::string obj = test::assetsDir() + "/demo/cat.obj";
  const auto cat = requireUsable(loadMesh(obj));
  const std::string dir = test::tempDir("assimp_binary");
  std::vector<Vec3> positions;
  for (int v = 0; v < cat->numVertices(); ++v) positions.push_back(cat->position(v));
  std::vector<std::vector<int>> triangles;
  for (int f = 0; f < cat->numFaces(); ++f) {
    const auto v = cat->faceVertices(f);
    triangles.push_back({v[0], v[1], v[2]});
  }
  const std::string catFbx = (fs::path(dir) / "cat.fbx").string();
  std::ofstream(catFbx, std::ios::binary) << binaryFbx(positions, triangles);
  const LoadedMesh loaded = loadMesh(catFbx);
  ASSERT_TRUE(loaded.mesh) << loaded.report.summary();
  expectSameMesh(*loaded.mesh, *cat, catFbx);

  // Three quads in a row (8 vertices), UVs = positions' x/3 and y.
  std::vector<Vec3> strip;
  for (int i = 0; i <= 3; ++i) strip.emplace_back(i, 0, 0), strip.emplace_back(i, 1, 0);
  std::vector<std::vector<int>> quads;
  std::vector<Vec2> uv;
  for (int i = 0; i < 3; ++i) {
    quads.push_back({2 * i, 2 * i + 2, 2 * i + 3, 2 * i + 1});
    for (int v : quads.back()) uv.emplace_back(strip[v].x() / 3, strip[v].y());
  }
  const std::string stripFbx = (fs::path(dir) / "strip.fbx").string();
  std::ofstream(stripFbx, std::ios::binary) << binaryFbx(strip, quads, uv);
  const LoadedMesh s = loadMesh(stripFbx);
  ASSERT_TRUE(s.mesh) << s.report.summary();
  EXPECT_EQ(s.mesh->numFaces(), 6);
  EXPECT_EQ(s.mesh->numVertices(), 8);
  ASSERT_TRUE(s.mesh->hasUV());
  for (int f = 0; f < s.mesh->numFaces(); ++f)
    for (int k = 0; k < 3; ++k) {
      const Vec3 p = s.mesh->facePositions(f)[k];
      EXPECT_NEAR((s.mesh->cornerUV[f][k] - Vec2(p.x() / 3, p.y())).norm(), 0, 1e-6) << "face " << f;
    }
}

// Files damaged in transit (bytes flipped, with a fixed seed): each reads as a mesh or gets an error naming the
// file; none crashes or hangs. Assimp's parsers are not ours, so this is where their robustness is checked.
TEST(Assimp, DamagedFilesReadOrFailCleanly) {
  const std::string dir = test::tempDir("assimp_damaged");
  const auto files = exportAll(test::assetsDir() + "/demo/cat.obj", dir);
  std::mt19937 rng(7);
  for (const auto& [format, path] : files) {
    std::ifstream in(path, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    int read = 0, refused = 0;
    for (int trial = 0; trial < 30; ++trial) {
      std::string damaged = bytes;
      const int flips = 1 + int(rng() % 8);
      for (int k = 0; k < flips; ++k) damaged[rng() % damaged.size()] = char(rng());
      if (trial % 4 == 3) damaged.resize(rng() % damaged.size());  // and cut short
      try {
        const LoadedMesh m = parseMesh(damaged, format.ext, path);
        read += m.mesh != nullptr;
      } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
        ++refused;
      }
    }
    EXPECT_EQ(read + refused, 30) << path;
  }
}
