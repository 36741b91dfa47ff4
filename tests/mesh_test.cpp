// Mesh loading (OBJ, OFF, PLY, STL), building and validation.
#include "geometry/mesh.h"

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <tuple>

#include "geometry/shapes.h"
#include "io/mesh_io.h"
#include "test_support.h"

namespace montage {
namespace {

using Severity = MeshFinding::Severity;

// ---- helpers ---------------------------------------------------------------------------------------------

std::string writeFile(const std::string& name, const std::string& content) {
  static const std::string dir = test::tempDir("mesh");
  const std::string path = dir + "/" + name;
  std::ofstream(path, std::ios::binary) << content;
  return path;
}

const MeshFinding* findFinding(const MeshReport& report, const std::string& text) {
  for (const auto& f : report.findings)
    if (f.what.find(text) != std::string::npos) return &f;
  return nullptr;
}

int countSeverity(const MeshReport& report, Severity s) {
  int n = 0;
  for (const auto& f : report.findings) n += f.severity == s;
  return n;
}

using test::errorOf;

// The unit cube: vertex i at (i&1, i>>1&1, i>>2&1), six outward quads.
const std::vector<Vec3> kCubeV = [] {
  std::vector<Vec3> v;
  for (int i = 0; i < 8; ++i) v.emplace_back(i & 1, (i >> 1) & 1, (i >> 2) & 1);
  return v;
}();
const std::vector<std::array<int, 4>> kCubeQuads = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                                    {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};

std::vector<std::array<int, 3>> cubeTriangles() {
  std::vector<std::array<int, 3>> t;
  for (const auto& q : kCubeQuads) {
    t.push_back({q[0], q[1], q[2]});
    t.push_back({q[0], q[2], q[3]});
  }
  return t;
}

// A closed cube: 8 vertices, 12 faces, outward normals, no findings.
void expectCube(const LoadedMesh& loaded, int vertices = 8) {
  ASSERT_TRUE(loaded.mesh);
  const Mesh& m = *loaded.mesh;
  const MeshReport& r = loaded.report;
  EXPECT_EQ(m.numVertices(), vertices);
  EXPECT_EQ(m.numFaces(), 12);
  EXPECT_EQ(r.faces, 12);
  EXPECT_EQ(r.edges, 18);
  EXPECT_EQ(r.components, 1);
  EXPECT_EQ(r.boundaryLoops, 0);
  EXPECT_EQ(r.genus, 0);
  EXPECT_EQ(r.droppedFaces, 0);
  EXPECT_TRUE(r.findings.empty()) << r.summary();
  EXPECT_NEAR(r.diagonal, std::sqrt(3.0), 1e-12);
  double area = 0;
  for (int f = 0; f < m.numFaces(); ++f) {
    const auto p = m.facePositions(f);
    const Vec3 outward = (p[0] + p[1] + p[2]) / 3 - Vec3(0.5, 0.5, 0.5);
    EXPECT_GT(m.faceNormal(f).dot(outward), 0.1) << "face " << f;
    area += m.faceArea(f);
  }
  EXPECT_NEAR(area, 6.0, 1e-12);
  Vec3 lo, hi;
  m.bounds(lo, hi);
  EXPECT_EQ(lo, Vec3(0, 0, 0));
  EXPECT_EQ(hi, Vec3(1, 1, 1));
}

// Writers of the cube in every format.
std::string cubeObj() {
  std::ostringstream s;
  for (const auto& p : kCubeV) s << "v " << p.x() << " " << p.y() << " " << p.z() << "\n";
  for (const auto& q : kCubeQuads)
    s << "f " << q[0] + 1 << " " << q[1] + 1 << " " << q[2] + 1 << " " << q[3] + 1 << "\n";
  return s.str();
}

std::string cubePlyHeader(const std::string& format, const std::string& vertexProps, const std::string& faceProps) {
  return "ply\nformat " + format + " 1.0\ncomment a cube\nelement vertex 8\n" + vertexProps + "element face 6\n" +
         faceProps + "end_header\n";
}

template <class T>
void putBinary(std::string& out, T value, bool bigEndian) {
  char b[sizeof(T)];
  std::memcpy(b, &value, sizeof(T));
  if (bigEndian) std::reverse(b, b + sizeof(T));
  out.append(b, sizeof(T));
}

// Binary PLY with double positions, an extra uchar property and a face list (uchar count, int indices) plus
// a trailing int face property and an extra element that must be skipped.
std::string cubePlyBinary(bool bigEndian, const std::string& listName) {
  std::string s = "ply\nformat " + std::string(bigEndian ? "binary_big_endian" : "binary_little_endian") +
                  " 1.0\nelement vertex 8\nproperty double x\nproperty uchar quality\nproperty double y\n"
                  "property double z\nelement face 6\nproperty list uchar int " +
                  listName + "\nproperty int flags\nelement edge 1\nproperty ushort a\nend_header\n";
  for (const auto& p : kCubeV) {
    putBinary<double>(s, p.x(), bigEndian);
    putBinary<uint8_t>(s, 7, bigEndian);
    putBinary<double>(s, p.y(), bigEndian);
    putBinary<double>(s, p.z(), bigEndian);
  }
  for (const auto& q : kCubeQuads) {
    putBinary<uint8_t>(s, 4, bigEndian);
    for (int v : q) putBinary<int32_t>(s, v, bigEndian);
    putBinary<int32_t>(s, -1, bigEndian);
  }
  putBinary<uint16_t>(s, 3, bigEndian);
  return s;
}

std::string stlBinary(const std::vector<Vec3>& v, const std::vector<std::array<int, 3>>& tris) {
  std::string s(80, ' ');
  s.replace(0, 5, "solid");  // a binary STL may start with "solid" too
  putBinary<uint32_t>(s, static_cast<uint32_t>(tris.size()), false);
  for (const auto& t : tris) {
    for (int k = 0; k < 3; ++k) putBinary<float>(s, 0.f, false);
    for (int c : t)
      for (int d = 0; d < 3; ++d) putBinary<float>(s, static_cast<float>(v[c][d]), false);
    putBinary<uint16_t>(s, 0, false);
  }
  return s;
}

// Minimal independent OBJ reader for checking the loader: positions, UVs and triangle corners (v, vt).
struct PlainObj {
  std::vector<Vec3> v;
  std::vector<Vec2> vt;
  std::vector<std::array<std::pair<int, int>, 3>> faces;
};

PlainObj readPlainObj(const std::string& path) {
  PlainObj obj;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream s(line);
    std::string kw;
    s >> kw;
    if (kw == "v") {
      double x, y, z;
      s >> x >> y >> z;
      obj.v.emplace_back(x, y, z);
    } else if (kw == "vt") {
      double u, v;
      s >> u >> v;
      obj.vt.emplace_back(u, v);
    } else if (kw == "f") {
      std::array<std::pair<int, int>, 3> f;
      for (auto& c : f) {
        std::string tok;
        s >> tok;
        c.first = std::stoi(tok) - 1;
        c.second = std::stoi(tok.substr(tok.find('/') + 1)) - 1;
      }
      obj.faces.push_back(f);
    }
  }
  return obj;
}

// ---- real meshes -----------------------------------------------------------------------------------------

struct RealMesh {
  const char* file;
  int vertices, faces, genus, boundaryLoops;
  bool uv;
};

TEST(MeshReal, CountsTopologyAndNoErrors) {
  const RealMesh meshes[] = {
      {"meshes/spot/spot_triangulated.obj", 2930, 5856, 0, 0, true},
      {"meshes/bunny/bunny.obj", 3301, 6598, 0, 0, false},
      {"meshes/cat/cat-low-resolution.obj", 7949, 15894, 0, 0, false},
      {"meshes/demosthenes/demosthenes-low-res.obj", 8394, 16719, 0, 1, false},
      {"meshes/bob/bob_tri.obj", 5344, 10688, 1, 0, true},
  };
  TM_REQUIRE_SHARED(dir, "meshes");
  for (const RealMesh& rm : meshes) {
    SCOPED_TRACE(rm.file);
    const std::string path = test::sharedFile(rm.file);
    if (path.empty()) continue;
    const LoadedMesh loaded = loadMesh(path);
    const MeshReport& r = loaded.report;
    EXPECT_EQ(r.format, "obj");
    EXPECT_EQ(r.inputVertices, rm.vertices);
    EXPECT_EQ(r.inputFaces, rm.faces);
    EXPECT_EQ(r.vertices, rm.vertices);
    EXPECT_EQ(r.faces, rm.faces);
    EXPECT_EQ(loaded.mesh->numFaces(), rm.faces);
    EXPECT_EQ(r.components, 1);
    EXPECT_EQ(r.genus, rm.genus);
    EXPECT_EQ(r.boundaryLoops, rm.boundaryLoops);
    EXPECT_EQ(r.edges, r.vertices + r.faces - 2 + 2 * r.genus + r.boundaryLoops);  // Euler, one component
    EXPECT_EQ(r.hasUV, rm.uv);
    EXPECT_EQ(loaded.mesh->cornerUV.size(), rm.uv ? size_t(rm.faces) : 0u);
    EXPECT_EQ(countSeverity(r, Severity::Error), 0) << r.summary();
    EXPECT_EQ(r.droppedFaces, 0);
    EXPECT_GT(r.diagonal, 0);
    EXPECT_TRUE(r.usable());
    ASSERT_EQ(loaded.mesh->faceOrigin.size(), size_t(rm.faces));
    EXPECT_EQ(loaded.mesh->faceOrigin.back(), rm.faces - 1);
  }
}

TEST(MeshReal, BobMaterialAndGroup) {
  TM_REQUIRE_SHARED(path, "meshes/bob/bob_tri.obj");
  const auto mesh = requireUsable(loadMesh(path));
  EXPECT_EQ(mesh->mtllib, "bob_tri.mtl");
  EXPECT_EQ(mesh->materialNames, std::vector<std::string>({"feathers"}));
  ASSERT_EQ(mesh->faceMaterial.size(), size_t(mesh->numFaces()));
  EXPECT_EQ(mesh->faceMaterial[0], 0);
  ASSERT_EQ(mesh->faceGroup.size(), size_t(mesh->numFaces()));
  EXPECT_EQ(mesh->groupNames, std::vector<std::string>({"Default"}));  // `g` wins over `o Mesh`
}

TEST(MeshReal, SpotCornerOrderAndUVsMatchTheFile) {
  TM_REQUIRE_SHARED(path, "meshes/spot/spot_triangulated.obj");
  const PlainObj obj = readPlainObj(path);
  const auto mesh = requireUsable(loadMesh(path));
  ASSERT_EQ(obj.faces.size(), size_t(mesh->numFaces()));
  ASSERT_TRUE(mesh->hasUV());
  for (int f = 0; f < mesh->numFaces(); ++f) {
    const auto& in = obj.faces[mesh->faceOrigin[f]];
    const auto v = mesh->faceVertices(f);
    // faceVertices is a rotation of the file's corners, and each corner's UV is the file's UV.
    int shift = 0;
    while (shift < 3 && in[shift].first != v[0]) ++shift;
    ASSERT_LT(shift, 3) << "face " << f;
    for (int k = 0; k < 3; ++k) {
      const auto& corner = in[(shift + k) % 3];
      ASSERT_EQ(v[k], corner.first) << "face " << f;
      ASSERT_EQ(mesh->position(v[k]), obj.v[corner.first]);
      ASSERT_EQ(mesh->cornerUV[f][k], obj.vt[corner.second]) << "face " << f << " corner " << k;
    }
  }
}

TEST(MeshReal, SpotSavedAndReloadedIsIdentical) {
  TM_REQUIRE_SHARED(path, "meshes/spot/spot_triangulated.obj");
  const auto mesh = requireUsable(loadMesh(path));
  const std::string copy = test::tempDir("mesh_save") + "/spot.obj";
  saveMeshObj(*mesh, copy);
  const auto again = requireUsable(loadMesh(copy));
  ASSERT_EQ(again->numVertices(), mesh->numVertices());
  ASSERT_EQ(again->numFaces(), mesh->numFaces());
  for (int v = 0; v < mesh->numVertices(); ++v) ASSERT_EQ(again->position(v), mesh->position(v));
  for (int f = 0; f < mesh->numFaces(); ++f) {
    ASSERT_EQ(again->faceVertices(f), mesh->faceVertices(f));
    for (int k = 0; k < 3; ++k) ASSERT_EQ(again->cornerUV[f][k], mesh->cornerUV[f][k]);
  }
}

TEST(MeshReal, LeePerrySmithSharedPositionsAndWeld) {
  TM_REQUIRE_SHARED(path, "meshes/leeperrysmith/LeePerrySmith.obj");
  // The file splits the head at its UV seams: 15 pieces with 22 boundary loops.
  const LoadedMesh plain = loadMesh(path);
  EXPECT_EQ(plain.report.vertices, 9279);
  EXPECT_EQ(plain.report.faces, 17684);
  EXPECT_EQ(plain.report.components, 15);
  EXPECT_EQ(plain.report.boundaryLoops, 22);
  const MeshFinding* shared = findFinding(plain.report, "same position");
  ASSERT_TRUE(shared) << plain.report.summary();
  EXPECT_EQ(shared->severity, Severity::Warning);
  EXPECT_EQ(shared->count, 435);
  EXPECT_NE(shared->what.find("weld"), std::string::npos);
  EXPECT_EQ(shared->elements.size(), 50u);
  EXPECT_TRUE(plain.report.usable());

  MeshLoadOptions weld;
  weld.weldIdenticalPositions = true;
  const LoadedMesh welded = loadMesh(path, weld);
  EXPECT_FALSE(findFinding(welded.report, "same position"));
  // Welded, it is one closed surface.
  EXPECT_EQ(welded.report.vertices, plain.report.vertices - shared->count);
  EXPECT_EQ(welded.report.components, 1);
  EXPECT_EQ(welded.report.boundaryLoops, 0);
  EXPECT_EQ(welded.report.genus, 0);
  EXPECT_TRUE(welded.report.findings.empty()) << welded.report.summary();
  EXPECT_EQ(welded.report.faces, plain.report.faces);
  EXPECT_TRUE(welded.mesh->hasUV());
  // Welding keeps the UVs of each corner.
  for (int f = 0; f < welded.mesh->numFaces(); f += 97) {
    const int g = welded.mesh->faceOrigin[f];
    ASSERT_EQ(plain.mesh->faceOrigin[g], g);
    std::set<std::pair<double, double>> a, b;
    for (int k = 0; k < 3; ++k) {
      a.insert({welded.mesh->cornerUV[f][k].x(), welded.mesh->cornerUV[f][k].y()});
      b.insert({plain.mesh->cornerUV[g][k].x(), plain.mesh->cornerUV[g][k].y()});
    }
    EXPECT_EQ(a, b);
  }
}

TEST(MeshWeld, LeePerrySmithWeldedWithTheWayBackToTheLoadedIds) {
  TM_REQUIRE_SHARED(path, "meshes/leeperrysmith/LeePerrySmith.obj");
  const auto loaded = requireUsable(loadMesh(path));
  const WeldedMesh w = weldIdenticalPositions(*loaded);
  ASSERT_TRUE(w.mesh);
  EXPECT_EQ(w.mergedVertices, 435);
  EXPECT_EQ(w.mesh->numVertices(), loaded->numVertices() - 435);
  EXPECT_EQ(w.report.components, 1);
  EXPECT_EQ(w.report.boundaryLoops, 0);
  ASSERT_EQ(static_cast<int>(w.vertexOf.size()), loaded->numVertices());
  ASSERT_EQ(static_cast<int>(w.faceOf.size()), loaded->numFaces());
  // Every loaded vertex lands on a welded vertex at its position, and back on the first loaded vertex there.
  std::map<std::tuple<double, double, double>, int> firstAt;
  for (int v = 0; v < loaded->numVertices(); ++v) {
    const Vec3 p = loaded->position(v);
    firstAt.emplace(std::make_tuple(p.x(), p.y(), p.z()), v);
  }
  for (int v = 0; v < loaded->numVertices(); ++v) {
    const int u = w.vertexOf[v];
    ASSERT_GE(u, 0) << "vertex " << v;
    EXPECT_EQ(w.mesh->position(u), loaded->position(v));
    const Vec3 p = loaded->position(v);
    EXPECT_EQ(w.mesh->vertexOrigin[u], firstAt.at(std::make_tuple(p.x(), p.y(), p.z())));
  }
  // Faces one to one, with the same corner positions, UVs and materials.
  for (int g = 0; g < loaded->numFaces(); ++g) {
    const int f = w.faceOf[g];
    ASSERT_GE(f, 0);
    EXPECT_EQ(w.mesh->faceOrigin[f], g);
    std::set<std::tuple<double, double, double>> a, b;
    for (const Vec3& q : loaded->facePositions(g)) a.insert({q.x(), q.y(), q.z()});
    for (const Vec3& q : w.mesh->facePositions(f)) b.insert({q.x(), q.y(), q.z()});
    EXPECT_EQ(a, b);
  }
  // A mesh without shared positions has nothing to weld.
  EXPECT_FALSE(weldIdenticalPositions(*w.mesh).mesh);
}

// ---- every format on a cube ------------------------------------------------------------------------------

TEST(MeshFormats, ObjCubeQuads) {
  const LoadedMesh loaded = loadMesh(writeFile("cube.obj", cubeObj()));
  expectCube(loaded);
  EXPECT_EQ(loaded.report.format, "obj");
  EXPECT_EQ(loaded.report.inputFaces, 12);
  EXPECT_FALSE(loaded.report.hasUV);
  EXPECT_TRUE(loaded.mesh->faceMaterial.empty());
  EXPECT_TRUE(loaded.mesh->faceGroup.empty());
  // Vertex ids are the file's.
  for (int v = 0; v < 8; ++v) EXPECT_EQ(loaded.mesh->position(v), kCubeV[v]);
  // Fan triangulation: triangle 2k+1 of quad k is (q0, q2, q3).
  const auto v = loaded.mesh->faceVertices(3);
  EXPECT_EQ(std::set<int>(v.begin(), v.end()), std::set<int>({4, 7, 6}));
}

TEST(MeshFormats, ObjSyntaxVariants) {
  // CRLF, comments, continuation lines, every corner syntax, negative indices, materials and groups.
  std::string s =
      "# cube\r\nmtllib  cube lib.mtl \r\n"
      "v 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nv 1 1 0\r\nv 0 0 1\r\nv 1 0 1 # comment\r\nv 0 1 1\r\nv \\\r\n 1 1 1\r\n"
      "vt 0 0\r\nvt 1 0\r\nvt 1 1\r\nvt 0 1\r\nvn 0 0 1\r\ns off\r\n"
      "usemtl red\r\ng bottom\r\n"
      "f 1/1 3/2 4/3 2/4\r\n"
      "g top\r\nf 5/1/1 6/2/1 8/3/1 7/4/1\r\n"
      "usemtl blue\r\nf 1//1 2//1 6//1 5//1\r\n"
      "f -6/-4 -2/-3 \\\r\n -1/-2 -5/-1\r\n"
      "g bottom\r\nf 1 5 7 3\r\n"
      "usemtl red\r\nf 2 4 8 6\r\n";
  const LoadedMesh loaded = loadMesh(writeFile("variants.OBJ", s));
  // Faces without vt get (0,0) UVs and a note.
  const MeshFinding* noUV = findFinding(loaded.report, "no texture coordinates");
  ASSERT_TRUE(noUV) << loaded.report.summary();
  EXPECT_EQ(noUV->count, 6);
  const Mesh& m = *loaded.mesh;
  EXPECT_EQ(m.numVertices(), 8);
  EXPECT_EQ(m.numFaces(), 12);
  EXPECT_EQ(loaded.report.genus, 0);
  EXPECT_EQ(loaded.report.boundaryLoops, 0);
  EXPECT_EQ(m.mtllib, "cube lib.mtl");
  EXPECT_EQ(m.materialNames, std::vector<std::string>({"red", "blue"}));
  EXPECT_EQ(m.faceMaterial, std::vector<int>({0, 0, 0, 0, 1, 1, 1, 1, 1, 1, 0, 0}));
  EXPECT_EQ(m.groupNames, std::vector<std::string>({"bottom", "top"}));
  EXPECT_EQ(m.faceGroup, std::vector<int>({0, 0, 1, 1, 1, 1, 1, 1, 0, 0, 0, 0}));
  // UVs: the top quad maps corners 5,6,8,7 to (0,0),(1,0),(1,1),(0,1).
  const std::map<int, Vec2> topUV = {{4, {0, 0}}, {5, {1, 0}}, {7, {1, 1}}, {6, {0, 1}}};
  for (int f = 2; f < 4; ++f) {
    const auto v = m.faceVertices(f);
    for (int k = 0; k < 3; ++k) EXPECT_EQ(m.cornerUV[f][k], topUV.at(v[k])) << "face " << f;
  }
  // The negative-index quad is the back face 3 4 8 7 with vt 1..4.
  const std::map<int, Vec2> backUV = {{2, {0, 0}}, {6, {1, 0}}, {7, {1, 1}}, {3, {0, 1}}};
  for (int f = 6; f < 8; ++f) {
    const auto v = m.faceVertices(f);
    for (int k = 0; k < 3; ++k) EXPECT_EQ(m.cornerUV[f][k], backUV.at(v[k])) << "face " << f;
  }
}

TEST(MeshFormats, ObjObjectNamesWhenNoGroupsAndUnnamedMaterial) {
  const std::string s = cubeObj();
  const size_t third = s.find("f ", s.find("f ", s.find("f ") + 1) + 1);
  const LoadedMesh loaded =
      loadMesh(writeFile("objects.obj", s.substr(0, third) + "o lid\nusemtl red\n" + s.substr(third)));
  EXPECT_EQ(loaded.mesh->groupNames, std::vector<std::string>({"default", "lid"}));
  EXPECT_EQ(loaded.mesh->faceGroup, std::vector<int>({0, 0, 0, 0, 1, 1, 1, 1, 1, 1, 1, 1}));
  // Faces before the first usemtl get the unnamed material "".
  EXPECT_EQ(loaded.mesh->materialNames, std::vector<std::string>({"", "red"}));
  EXPECT_EQ(loaded.mesh->faceMaterial, std::vector<int>({0, 0, 0, 0, 1, 1, 1, 1, 1, 1, 1, 1}));
}

TEST(MeshFormats, ObjPolygonWithNegativeIndices) {
  const LoadedMesh loaded =
      loadMesh(writeFile("pentagon.obj", "v 9 9 9\nv 0 0 0\nv 2 0 0\nv 3 1 0\nv 1 2 0\nv -1 1 0\nf -5 -4 -3 -2 -1\n"));
  const Mesh& m = *loaded.mesh;
  EXPECT_EQ(loaded.report.inputFaces, 3);
  ASSERT_EQ(m.numFaces(), 3);
  EXPECT_EQ(m.faceOrigin, std::vector<int>({0, 1, 2}));
  const std::array<int, 3> expected[] = {{1, 2, 3}, {1, 3, 4}, {1, 4, 5}};
  for (int f = 0; f < 3; ++f) {
    auto v = m.faceVertices(f);
    std::rotate(v.begin(), std::min_element(v.begin(), v.end()), v.end());
    EXPECT_EQ(v, expected[f]);
    EXPECT_GT(m.faceNormal(f).z(), 0.99);
  }
  EXPECT_EQ(loaded.report.boundaryLoops, 1);
  EXPECT_EQ(loaded.report.unreferencedVertices, 1);
  const MeshFinding* unused = findFinding(loaded.report, "used by no face");
  ASSERT_TRUE(unused);
  EXPECT_EQ(unused->elements, std::vector<int>({0}));
  EXPECT_TRUE(loaded.report.usable());
}

TEST(MeshFormats, OffCube) {
  std::ostringstream s;
  s << "OFF\n# comment\n8 6 12\n";
  for (const auto& p : kCubeV) s << p.x() << " " << p.y() << " " << p.z() << "\n";
  for (const auto& q : kCubeQuads) s << "4 " << q[0] << " " << q[1] << " " << q[2] << " " << q[3] << "\n";
  const LoadedMesh loaded = loadMesh(writeFile("cube.off", s.str()));
  expectCube(loaded);
  EXPECT_EQ(loaded.report.format, "off");
}

TEST(MeshFormats, OffWithColorsAndCountsOnHeaderLine) {
  std::ostringstream s;
  s << "COFF 8 6 0\n";
  for (const auto& p : kCubeV) s << p.x() << " " << p.y() << " " << p.z() << " 255 0 0 255\n\n";
  for (const auto& q : kCubeQuads)
    s << "4 " << q[0] << " " << q[1] << " " << q[2] << " " << q[3] << " 0.5 0.5 0.5  # grey\r\n";
  expectCube(loadMesh(writeFile("cube_colors.off", s.str())));
}

TEST(MeshFormats, PlyAsciiCube) {
  std::ostringstream s;
  s << cubePlyHeader("ascii", "property float x\nproperty float y\nproperty float z\nproperty uchar red\n",
                     "property list uchar int vertex_indices\nproperty list uchar float texcoord\n");
  for (const auto& p : kCubeV) s << p.x() << " " << p.y() << " " << p.z() << " 200\n";
  for (const auto& q : kCubeQuads)
    s << "4 " << q[0] << " " << q[1] << " " << q[2] << " " << q[3] << " 8 0 0 1 0 1 1 0 1\n";
  const LoadedMesh loaded = loadMesh(writeFile("cube.ply", s.str()));
  expectCube(loaded);
  EXPECT_EQ(loaded.report.format, "ply");
  ASSERT_TRUE(loaded.mesh->hasUV());
  // Quad corners 0..3 have UVs (0,0),(1,0),(1,1),(0,1); the first triangle of quad 0 is (0,2,3).
  const Mesh& m = *loaded.mesh;
  const std::map<int, Vec2> uv = {{0, {0, 0}}, {2, {1, 0}}, {3, {1, 1}}};
  const auto v = m.faceVertices(0);
  for (int k = 0; k < 3; ++k) EXPECT_EQ(m.cornerUV[0][k], uv.at(v[k]));
}

TEST(MeshFormats, PlyAsciiVertexUVs) {
  std::ostringstream s;
  s << cubePlyHeader("ascii",
                     "property double x\nproperty double y\nproperty double z\nproperty float s\nproperty float t\n",
                     "property list uint uint vertex_index\n");
  for (const auto& p : kCubeV)
    s << p.x() << " " << p.y() << " " << p.z() << " " << p.x() / 2 << " " << p.y() / 4 << "\n";
  for (const auto& q : kCubeQuads) s << "4 " << q[0] << " " << q[1] << " " << q[2] << " " << q[3] << "\n";
  const LoadedMesh loaded = loadMesh(writeFile("cube_vuv.ply", s.str()));
  expectCube(loaded);
  const Mesh& m = *loaded.mesh;
  ASSERT_TRUE(m.hasUV());
  for (int f = 0; f < m.numFaces(); ++f)
    for (int k = 0; k < 3; ++k) {
      const Vec3 p = m.position(m.faceVertices(f)[k]);
      EXPECT_EQ(m.cornerUV[f][k], Vec2(p.x() / 2, p.y() / 4));
    }
}

TEST(MeshFormats, PlyBinaryLittleEndianCube) {
  const LoadedMesh loaded = loadMesh(writeFile("cube_le.ply", cubePlyBinary(false, "vertex_indices")));
  expectCube(loaded);
  for (int v = 0; v < 8; ++v) EXPECT_EQ(loaded.mesh->position(v), kCubeV[v]);
}

TEST(MeshFormats, PlyBinaryBigEndianCube) {
  expectCube(loadMesh(writeFile("cube_be.ply", cubePlyBinary(true, "vertex_index"))));
}

TEST(MeshFormats, PlyBinaryTruncatedAndBadIndex) {
  const std::string full = cubePlyBinary(false, "vertex_indices");
  const std::string cut = writeFile("cut.ply", full.substr(0, full.size() - 30));
  EXPECT_NE(errorOf([&] { loadMesh(cut); }).find("cut.ply: element 'face' 4: unexpected end of file"),
            std::string::npos);

  std::string bad = full;
  const size_t firstFace = bad.find("end_header\n") + 11 + 8 * 25;
  const int32_t big = 99;
  std::memcpy(&bad[firstFace + 1 + 4], &big, 4);  // second index of face 0
  const std::string msg = errorOf([&] { loadMesh(writeFile("badindex.ply", bad)); });
  EXPECT_NE(msg.find("badindex.ply: face 0: face index 99 out of range (8 vertices)"), std::string::npos) << msg;
}

TEST(MeshFormats, StlAsciiCubeIsWelded) {
  std::ostringstream s;
  s << "solid cube\n";
  for (const auto& t : cubeTriangles()) {
    s << "  facet normal 0 0 0\n    outer loop\n";
    for (int c : t) s << "      vertex " << kCubeV[c].x() << " " << kCubeV[c].y() << " " << kCubeV[c].z() << "\n";
    s << "    endloop\n  endfacet\n";
  }
  s << "endsolid cube\n";
  const LoadedMesh loaded = loadMesh(writeFile("cube.stl", s.str()));
  expectCube(loaded);
  EXPECT_EQ(loaded.report.inputVertices, 36);
  EXPECT_EQ(loaded.report.format, "stl");
}

TEST(MeshFormats, StlBinaryCubeIsWelded) {
  const LoadedMesh loaded = loadMesh(writeFile("cube_bin.STL", stlBinary(kCubeV, cubeTriangles())));
  expectCube(loaded);
  EXPECT_EQ(loaded.report.inputVertices, 36);
}

TEST(MeshFormats, StlBinaryWithWrongSize) {
  const std::string data = stlBinary(kCubeV, cubeTriangles());
  const std::string msg = errorOf([&] { loadMesh(writeFile("short.stl", data.substr(0, data.size() - 10))); });
  EXPECT_NE(msg.find("short.stl: binary STL header says 12 triangles"), std::string::npos) << msg;
}

TEST(MeshFormats, SavedObjRoundTrip) {
  std::vector<std::array<Vec2, 3>> uv;
  for (int t = 0; t < 12; ++t) uv.push_back({Vec2(t * 0.1, 0.3), Vec2(0.1 / 3, t), Vec2(1e-9, 0.7)});
  const LoadedMesh built = buildMesh(kCubeV, cubeTriangles(), uv);
  const std::string path = writeFile("saved.obj", "");
  saveMeshObj(*built.mesh, path);
  const LoadedMesh again = loadMesh(path);
  expectCube(again);
  for (int f = 0; f < 12; ++f) {
    EXPECT_EQ(again.mesh->faceVertices(f), built.mesh->faceVertices(f));
    EXPECT_EQ(again.mesh->cornerUV[f], built.mesh->cornerUV[f]);
  }
  EXPECT_NE(errorOf([&] { saveMeshObj(*built.mesh, "/nonexistent-dir/x.obj"); }).find("/nonexistent-dir/x.obj"),
            std::string::npos);
}

// ---- dropped faces and non-manifold input ----------------------------------------------------------------

const std::vector<Vec3> kTetV = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
const std::vector<std::array<int, 3>> kTet = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {0, 3, 2}};

TEST(MeshBuild, BuildMeshCornerOrderMatchesInput) {
  const LoadedMesh loaded = buildMesh(kTetV, kTet, {}, {}, "tet");
  EXPECT_EQ(loaded.report.path, "tet");
  EXPECT_EQ(loaded.report.genus, 0);
  EXPECT_TRUE(loaded.report.findings.empty());
  for (int f = 0; f < 4; ++f) {
    auto v = loaded.mesh->faceVertices(f);
    auto in = kTet[f];
    std::rotate(v.begin(), std::min_element(v.begin(), v.end()), v.end());
    std::rotate(in.begin(), std::min_element(in.begin(), in.end()), in.end());
    EXPECT_EQ(v, in);
  }
}

TEST(MeshBuild, DuplicateFaceIsDropped) {
  auto tris = kTet;
  tris.push_back({2, 3, 0});  // same as face 3, other orientation
  tris.push_back({3, 2, 0});  // same as face 3, same orientation
  const LoadedMesh loaded = loadMesh(writeFile("tetdup.obj", [&] {
    std::ostringstream s;
    for (const auto& p : kTetV) s << "v " << p.x() << " " << p.y() << " " << p.z() << "\n";
    for (const auto& t : tris) s << "f " << t[0] + 1 << " " << t[1] + 1 << " " << t[2] + 1 << "\n";
    return s.str();
  }()));
  const MeshReport& r = loaded.report;
  EXPECT_EQ(r.faces, 4);
  EXPECT_EQ(r.duplicateFaces, 2);
  EXPECT_EQ(r.droppedFaces, 2);
  EXPECT_EQ(r.nonManifoldEdges, 0);
  EXPECT_EQ(r.genus, 0);
  EXPECT_EQ(r.boundaryLoops, 0);
  const MeshFinding* dup = findFinding(r, "duplicate");
  ASSERT_TRUE(dup) << r.summary();
  EXPECT_EQ(dup->elements, std::vector<int>({4, 5}));
  EXPECT_EQ(dup->count, 2);
  EXPECT_TRUE(r.usable());
  EXPECT_NE(r.summary().find("ids: 4, 5"), std::string::npos) << r.summary();
}

TEST(MeshBuild, ThreeFacesOnOneEdge) {
  const std::vector<Vec3> v = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}};
  const LoadedMesh loaded = buildMesh(v, {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}});
  const MeshReport& r = loaded.report;
  EXPECT_EQ(r.faces, 2);
  EXPECT_EQ(r.droppedFaces, 1);
  EXPECT_EQ(r.nonManifoldEdges, 1);
  EXPECT_EQ(loaded.mesh->faceOrigin, std::vector<int>({0, 1}));
  const MeshFinding* complex = findFinding(r, "complex edge");
  ASSERT_TRUE(complex) << r.summary();
  EXPECT_EQ(complex->elements, std::vector<int>({2}));
  EXPECT_EQ(r.unreferencedVertices, 1);  // vertex 4 only belonged to the dropped face
  EXPECT_TRUE(findFinding(r, "non-manifold edges"));
}

TEST(MeshBuild, OrientationConflictIsTurnedOver) {
  // Both faces walk the edge 0->1 the same way: the second (or the first, on a tie the first face's
  // orientation wins) is turned over instead of being dropped.
  const std::vector<Vec3> v = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, -1, 0}};
  const LoadedMesh loaded = buildMesh(v, {{0, 1, 2}, {0, 1, 3}});
  EXPECT_EQ(loaded.report.faces, 2);
  EXPECT_EQ(loaded.report.droppedFaces, 0);
  EXPECT_EQ(loaded.report.flippedFaces, 1);
  EXPECT_EQ(loaded.report.nonManifoldEdges, 0);
  const MeshFinding* f = findFinding(loaded.report, "turned over");
  ASSERT_TRUE(f) << loaded.report.summary();
  EXPECT_EQ(f->elements, std::vector<int>({1}));
  // Both normals now point the same way (+z and -z input faces become one consistent orientation).
  const Mesh& m = *loaded.mesh;
  EXPECT_GT(m.faceNormal(0).dot(m.faceNormal(1)), 0.99);
}

TEST(MeshBuild, RepeatedVertexIsDropped) {
  const LoadedMesh loaded = buildMesh(kTetV, {{0, 2, 1}, {3, 3, 1}});
  EXPECT_EQ(loaded.report.faces, 1);
  const MeshFinding* f = findFinding(loaded.report, "repeated vertex");
  ASSERT_TRUE(f);
  EXPECT_EQ(f->elements, std::vector<int>({1}));
  EXPECT_EQ(loaded.report.unreferencedVertices, 1);
}

TEST(MeshBuild, BowtieVertexIsSplit) {
  const std::vector<Vec3> v = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {-1, 0, 0}, {-1, -1, 0}};
  const std::vector<std::array<int, 3>> tris = {{0, 1, 2}, {0, 3, 4}};
  const LoadedMesh split = buildMesh(v, tris);
  EXPECT_EQ(split.report.nonManifoldVertices, 1);
  EXPECT_EQ(split.report.vertices, 6);
  EXPECT_EQ(split.report.faces, 2);
  EXPECT_EQ(split.report.components, 2);
  EXPECT_EQ(split.report.boundaryLoops, 2);
  EXPECT_EQ(split.report.genus, 0);
  EXPECT_EQ(split.mesh->position(5), v[0]);
  const auto f1 = split.mesh->faceVertices(1);
  EXPECT_EQ(std::set<int>(f1.begin(), f1.end()), std::set<int>({5, 3, 4}));
  const MeshFinding* nm = findFinding(split.report, "non-manifold vertices");
  ASSERT_TRUE(nm);
  EXPECT_EQ(nm->elements, std::vector<int>({0}));
  // Every vertex now has at most one outgoing boundary halfedge.
  for (auto vh : split.mesh->tri.vertices()) {
    int boundary = 0;
    for (auto h : vh.outgoing_halfedges()) boundary += h.is_boundary();
    EXPECT_LE(boundary, 1);
  }

  MeshLoadOptions keep;
  keep.splitNonManifoldVertices = false;
  const LoadedMesh kept = buildMesh(v, tris, {}, keep);
  EXPECT_EQ(kept.report.vertices, 5);
  EXPECT_EQ(kept.report.faces, 2);
  EXPECT_EQ(kept.report.nonManifoldVertices, 1);
  EXPECT_TRUE(findFinding(kept.report, "not split"));
}

TEST(MeshBuild, TwoClosedTetrahedraSharingAVertex) {
  std::vector<Vec3> v = kTetV;
  for (int i = 1; i < 4; ++i) v.push_back(-kTetV[i]);
  std::vector<std::array<int, 3>> tris = kTet;
  for (const auto& t : kTet) {
    std::array<int, 3> u;
    for (int k = 0; k < 3; ++k) u[k] = t[k] == 0 ? 0 : t[k] + 3;
    tris.push_back({u[0], u[2], u[1]});  // mirrored: flip to keep it outward
  }
  const LoadedMesh split = buildMesh(v, tris);
  EXPECT_EQ(split.report.faces, 8);
  EXPECT_EQ(split.report.vertices, 8);
  EXPECT_EQ(split.report.components, 2);
  EXPECT_EQ(split.report.genus, 0);
  EXPECT_EQ(split.report.boundaryLoops, 0);
  EXPECT_EQ(split.report.nonManifoldVertices, 1);

  // Without splitting, OpenMesh cannot attach the second closed fan: its faces at vertex 0 are dropped.
  MeshLoadOptions keep;
  keep.splitNonManifoldVertices = false;
  testing::internal::CaptureStderr();
  const LoadedMesh kept = buildMesh(v, tris, {}, keep);
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "");  // OpenMesh's own complaints are silenced
  EXPECT_LT(kept.report.faces, 8);
  const MeshFinding* f = findFinding(kept.report, "vertex splitting is off");
  ASSERT_TRUE(f) << kept.report.summary();
  EXPECT_EQ(f->count, 8 - kept.report.faces);
}

TEST(MeshBuild, ZeroAreaFaceIsKept) {
  const std::vector<Vec3> v = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {2, 0, 0}};
  const LoadedMesh loaded = buildMesh(v, {{0, 1, 2}, {1, 0, 3}});
  EXPECT_EQ(loaded.report.faces, 2);
  EXPECT_EQ(loaded.report.zeroAreaFaces, 1);
  const MeshFinding* f = findFinding(loaded.report, "zero area");
  ASSERT_TRUE(f);
  EXPECT_EQ(f->elements, std::vector<int>({1}));
  EXPECT_EQ(loaded.mesh->faceNormal(1), Vec3::Zero());
  EXPECT_TRUE(loaded.report.usable());
}

TEST(MeshBuild, WeldOptionMergesIdenticalPositions) {
  // Two triangles of a square, each with its own copy of the shared edge's vertices.
  const std::vector<Vec3> v = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 0, -0.0}, {1, 1, 0}, {0, 1, 0}};
  const std::vector<std::array<int, 3>> tris = {{0, 1, 2}, {3, 4, 5}};
  const LoadedMesh plain = buildMesh(v, tris);
  EXPECT_EQ(plain.report.vertices, 6);
  EXPECT_EQ(plain.report.boundaryLoops, 2);
  const MeshFinding* shared = findFinding(plain.report, "same position");
  ASSERT_TRUE(shared);
  EXPECT_EQ(shared->elements, std::vector<int>({3, 4}));

  MeshLoadOptions weld;
  weld.weldIdenticalPositions = true;
  const LoadedMesh welded = buildMesh(v, tris, {}, weld);
  EXPECT_EQ(welded.report.vertices, 4);
  EXPECT_EQ(welded.report.boundaryLoops, 1);
  EXPECT_EQ(welded.report.edges, 5);
  EXPECT_FALSE(findFinding(welded.report, "same position"));
  EXPECT_EQ(welded.mesh->position(3), Vec3(0, 1, 0));
}

TEST(MeshBuild, CornerUVsFollowFaceVertices) {
  std::vector<std::array<Vec2, 3>> uv;
  for (const auto& t : kTet) uv.push_back({Vec2(t[0], 10), Vec2(t[1], 20), Vec2(t[2], 30)});
  const LoadedMesh loaded = buildMesh(kTetV, kTet, uv);
  for (int f = 0; f < 4; ++f) {
    const auto v = loaded.mesh->faceVertices(f);
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(loaded.mesh->cornerUV[f][k].x(), v[k]);
      EXPECT_EQ(loaded.mesh->cornerUV[f][(k + 1) % 3].y() - loaded.mesh->cornerUV[f][k].y(),
                loaded.mesh->cornerUV[f][k].y() == 30 ? -20 : 10);
    }
  }
}

TEST(MeshBuild, BadArgumentsThrow) {
  EXPECT_NE(errorOf([] {
              buildMesh(kTetV, {{0, 1, 4}}, {}, {}, "soup");
            }).find("soup: face 0: vertex index 4 out of range (4 vertices)"),
            std::string::npos);
  EXPECT_NE(errorOf([] { buildMesh(kTetV, kTet, {{}}); }).find("1 UV triples for 4 triangles"), std::string::npos);
}

// ---- unusable and broken files ---------------------------------------------------------------------------

TEST(MeshErrors, IndexOutOfRangeNamesFileAndLine) {
  const std::string path = writeFile("range.obj", "v 0 0 0\nv 1 0 0\n# c\nv 0 1 0\nf 1 2 3\nf 1 2 9001\n");
  const std::string msg = errorOf([&] { loadMesh(path); });
  EXPECT_NE(msg.find(path + ":6: face index 9001 out of range (3 vertices)"), std::string::npos) << msg;
  const std::string rel = writeFile("relative.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n");
  EXPECT_NE(errorOf([&] { loadMesh(rel); }).find("relative.obj:4: face index -4 out of range"), std::string::npos);
  const std::string zero = writeFile("zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n");
  EXPECT_NE(errorOf([&] { loadMesh(zero); }).find("zero.obj:4: face index 0 is invalid"), std::string::npos);
  const std::string vt = writeFile("vt.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/1 3/2\n");
  EXPECT_NE(errorOf([&] { loadMesh(vt); }).find("vt.obj:5: texture coordinate index 2 out of range (1 texture"),
            std::string::npos);
  std::ostringstream off;
  off << "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n";
  EXPECT_NE(
      errorOf([&] { loadMesh(writeFile("range.off", off.str())); }).find("range.off:6: face index 3 out of range"),
      std::string::npos);
}

TEST(MeshErrors, MalformedLinesNameFileAndLine) {
  EXPECT_NE(errorOf([] {
              loadMesh(writeFile("badv.obj", "v 0 0 0\nv 1 x 0\n"));
            }).find("badv.obj:2: expected a number for y coordinate, got 'x'"),
            std::string::npos);
  EXPECT_NE(errorOf([] { loadMesh(writeFile("shortv.obj", "v 0 0\n")); }).find("shortv.obj:1: missing z coordinate"),
            std::string::npos);
  EXPECT_NE(errorOf([] {
              loadMesh(writeFile("twof.obj", "v 0 0 0\nv 1 0 0\nf 1 2\n"));
            }).find("twof.obj:3: a face needs at least 3 vertices"),
            std::string::npos);
  EXPECT_NE(
      errorOf([] { loadMesh(writeFile("badf.obj", "v 0 0 0\nf 1 a 1\n")); }).find("badf.obj:2: bad face corner 'a'"),
      std::string::npos);
  EXPECT_NE(errorOf([] {
              loadMesh(writeFile("trunc.off", "OFF\n4 2 0\n0 0 0\n1 0 0\n"));
            }).find("trunc.off:2: the header declares 4 vertices and 2 faces, but only 12 bytes follow"),
            std::string::npos);
  EXPECT_NE(errorOf([] {
              loadMesh(writeFile("trunc2.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1\n# a comment\n"));
            }).find("trunc2.off:6: missing face vertex index"),
            std::string::npos);
  EXPECT_NE(
      errorOf([] {
        loadMesh(writeFile("noxyz.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n1\n"));
      }).find("noxyz.ply:5: vertex element lacks an x, y or z property"),
      std::string::npos);
  EXPECT_NE(errorOf([] {
              loadMesh(writeFile("badply.ply",
                                 "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
                                 "property float z\nend_header\n0 0 0\n1 q 0\n"));
            }).find("badply.ply:9: expected a number for y, got 'q'"),
            std::string::npos);
  EXPECT_NE(errorOf([] {
              loadMesh(writeFile("bad.stl", "solid x\n facet normal 0 0 1\n  outer loop\n   vertex 0 0\n"));
            }).find("bad.stl:4: missing z coordinate"),
            std::string::npos);
}

TEST(MeshErrors, GarbageFiles) {
  // Unknown OBJ statements are ignored (and reported); with no faces the mesh is unusable.
  const LoadedMesh obj = loadMesh(writeFile("garbage.obj", "hello world\nthis is not a mesh\n"));
  EXPECT_FALSE(obj.report.usable());
  EXPECT_TRUE(findFinding(obj.report, "no faces"));
  const MeshFinding* unknown = findFinding(obj.report, "unknown statements");
  ASSERT_TRUE(unknown);
  EXPECT_NE(unknown->what.find("line 1: 'hello'"), std::string::npos) << unknown->what;
  EXPECT_NE(errorOf([] {
              loadMesh(writeFile("binary.obj", std::string("v 0 0 0\n\x01\x02\x03 7\n", 14)));
            }).find("binary.obj:2: unexpected binary data"),
            std::string::npos);
  EXPECT_NE(errorOf([] { loadMesh(writeFile("garbage.ply", "hello world\n")); }).find("garbage.ply:1: not a PLY file"),
            std::string::npos);
  EXPECT_NE(errorOf([] { loadMesh(writeFile("garbage.off", "hello world\n")); }).find("garbage.off:1: not an OFF file"),
            std::string::npos);
  EXPECT_NE(errorOf([] { loadMesh(writeFile("garbage.stl", "hello world\n")); }).find("garbage.stl: not an STL file"),
            std::string::npos);
  EXPECT_NE(errorOf([] { loadMesh(writeFile("mesh.xyz", "1 2 3\n")); }).find("unsupported mesh format 'xyz'"),
            std::string::npos);
}

TEST(MeshErrors, EmptyFileIsUnusable) {
  const std::string path = writeFile("empty.obj", "");
  const LoadedMesh loaded = loadMesh(path);
  ASSERT_TRUE(loaded.mesh);
  EXPECT_FALSE(loaded.report.usable());
  EXPECT_EQ(loaded.report.faces, 0);
  const MeshFinding* f = findFinding(loaded.report, "no faces");
  ASSERT_TRUE(f);
  EXPECT_EQ(f->severity, Severity::Error);
  EXPECT_NE(loaded.report.summary().find("ERROR: no faces"), std::string::npos);
  const std::string msg = errorOf([&] { requireUsable(loadMesh(path)); });
  EXPECT_NE(msg.find(path), std::string::npos);
  EXPECT_NE(msg.find("no faces"), std::string::npos);
}

TEST(MeshErrors, NonFiniteCoordinateIsUnusable) {
  const LoadedMesh loaded =
      loadMesh(writeFile("nan.obj", "v 0 0 0\nv 1 nan 0\nv 0 1 0\nv 0 0 1e999\nf 1 2 3\nf 1 3 4\n"));
  EXPECT_FALSE(loaded.report.usable());
  const MeshFinding* f = findFinding(loaded.report, "non-finite");
  ASSERT_TRUE(f);
  EXPECT_EQ(f->severity, Severity::Error);
  EXPECT_EQ(f->elements, std::vector<int>({1, 3}));
  EXPECT_THROW(
      requireUsable(buildMesh({{0, 0, 0}, {1, 0, 0}, {0, std::numeric_limits<double>::infinity(), 0}}, {{0, 1, 2}})),
      Error);
}

TEST(MeshErrors, MissingFileNamesThePath) {
  const std::string path = test::tempDir("mesh_missing") + "/nothing-here.obj";
  const std::string msg = errorOf([&] { loadMesh(path); });
  EXPECT_NE(msg.find(path), std::string::npos);
  EXPECT_NE(msg.find("mesh file not found"), std::string::npos) << msg;
}

TEST(MeshReportText, SummaryHasCountsAndFindings) {
  const std::vector<Vec3> v = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}};
  const LoadedMesh loaded = buildMesh(v, {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}}, {}, {}, "three.obj");
  const std::string s = loaded.report.summary();
  EXPECT_NE(s.find("three.obj"), std::string::npos);
  EXPECT_NE(s.find("5 vertices, 3 triangles"), std::string::npos) << s;
  EXPECT_NE(s.find("5 vertices, 2 faces, 5 edges"), std::string::npos) << s;
  EXPECT_NE(s.find("1 component, 1 boundary loop, genus 0"), std::string::npos) << s;
  EXPECT_NE(s.find("warning: 1 faces dropped: complex edge"), std::string::npos) << s;
  EXPECT_NE(s.find("ids: 2\n"), std::string::npos) << s;
  EXPECT_NE(s.find("usable: yes"), std::string::npos) << s;
}

// ---- a large file -----------------------------------------------------------------------------------------------

TEST(MeshLarge, MillionFaceObjLoads) {
  const int nx = 1000, ny = 500;  // 1,000,000 triangles
  std::string s;
  s.reserve(40 * 1000000);
  char line[96];
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i)
      s.append(line,
               std::snprintf(line, sizeof line, "v %.6f %.6f %.6f\n", i * 0.001, j * 0.001, 0.0001 * ((i * j) % 7)));
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const int a = j * (nx + 1) + i + 1, b = a + 1, c = a + nx + 1, d = c + 1;
      s.append(line, std::snprintf(line, sizeof line, "f %d %d %d\nf %d %d %d\n", a, b, d, a, d, c));
    }
  const std::string path = writeFile("grid.obj", s);
  const LoadedMesh loaded = loadMesh(path);  // its speed is measured by tm_microbench, not here
  EXPECT_EQ(loaded.report.faces, 1000000);
  EXPECT_EQ(loaded.report.vertices, 501 * 1001);
  EXPECT_EQ(loaded.report.boundaryLoops, 1);
  EXPECT_EQ(loaded.report.genus, 0);
  EXPECT_TRUE(loaded.report.findings.empty()) << loaded.report.summary();
}

// ---- orientation (issue 15) ------------------------------------------------------------------------------

// The faces of a mesh as index triples in faceVertices order.
std::vector<std::array<int, 3>> trianglesOf(const Mesh& m) {
  std::vector<std::array<int, 3>> t;
  for (int f = 0; f < m.numFaces(); ++f) t.push_back(m.faceVertices(f));
  return t;
}

std::vector<Vec3> positionsOf(const Mesh& m) {
  std::vector<Vec3> p;
  for (int v = 0; v < m.numVertices(); ++v) p.push_back(m.position(v));
  return p;
}

TEST(MeshOrientation, EveryTenthFaceFlippedIsReorientedNotDropped) {
  // The case: an icosphere of 20,480 faces with every tenth face flipped lost 2,812 faces.
  const auto sphere = makeIcosphere(5);
  ASSERT_EQ(sphere->numFaces(), 20480);
  auto tris = trianglesOf(*sphere);
  std::vector<std::array<Vec2, 3>> uv(tris.size());
  for (size_t t = 0; t < tris.size(); ++t) {
    uv[t] = {Vec2(tris[t][0], 0), Vec2(tris[t][1], 0), Vec2(tris[t][2], 0)};  // u = vertex id
    if (t % 10 == 0) {
      std::swap(tris[t][1], tris[t][2]);
      std::swap(uv[t][1], uv[t][2]);
    }
  }
  const LoadedMesh loaded = buildMesh(positionsOf(*sphere), tris, uv);
  const MeshReport& r = loaded.report;
  EXPECT_EQ(r.faces, 20480) << r.summary();
  EXPECT_EQ(r.droppedFaces, 0);
  EXPECT_EQ(r.flippedFaces, 2048);
  EXPECT_EQ(r.nonOrientableFaces, 0);
  EXPECT_EQ(r.genus, 0);
  EXPECT_EQ(r.boundaryLoops, 0);
  const MeshFinding* f = findFinding(r, "turned over");
  ASSERT_TRUE(f) << r.summary();
  EXPECT_EQ(f->count, 2048);
  EXPECT_EQ(f->elements.front(), 0);
  EXPECT_EQ(f->elements[1], 10);
  // Every face points outwards again, and every corner UV still belongs to its vertex.
  const Mesh& m = *loaded.mesh;
  for (int face = 0; face < m.numFaces(); ++face) {
    const auto p = m.facePositions(face);
    ASSERT_GT(m.faceNormal(face).dot(p[0] + p[1] + p[2]), 0) << "face " << face;
    for (int k = 0; k < 3; ++k) ASSERT_EQ(m.cornerUV[face][k].x(), m.faceVertices(face)[k]) << "face " << face;
  }
}

TEST(MeshOrientation, MajorityOrientationWinsPerComponent) {
  // Two separate spheres: one with 60% of its faces flipped (its file orientation is mostly inward, so
  // the 40% are turned), one consistent and left alone.
  const auto sphere = makeIcosphere(1);  // 80 faces
  std::vector<Vec3> v = positionsOf(*sphere);
  const int n = static_cast<int>(v.size());
  for (int i = 0; i < n; ++i) v.push_back(v[i] + Vec3(5, 0, 0));
  std::vector<std::array<int, 3>> tris;
  const auto base = trianglesOf(*sphere);
  for (size_t t = 0; t < base.size(); ++t) {
    auto tri = base[t];
    if (t % 5 < 3) std::swap(tri[1], tri[2]);
    tris.push_back(tri);
  }
  for (auto tri : base) tris.push_back({tri[0] + n, tri[1] + n, tri[2] + n});
  const LoadedMesh loaded = buildMesh(v, tris);
  EXPECT_EQ(loaded.report.faces, 160);
  EXPECT_EQ(loaded.report.flippedFaces, 32);  // the 40% of the first sphere
  EXPECT_EQ(loaded.report.components, 2);
  const Mesh& m = *loaded.mesh;
  for (int f = 0; f < 80; ++f) {
    const auto p = m.facePositions(f);
    EXPECT_LT(m.faceNormal(f).dot(p[0] + p[1] + p[2]), 0) << "first sphere, face " << f << " points inwards";
  }
}

TEST(MeshOrientation, MoebiusBandDropsOnlyWhatCannotBeOriented) {
  // A strip of 2 * 24 triangles closed with a half twist: not orientable. Closing it needs one face
  // removed; the rest stays, consistently oriented, and the dropped face is named.
  const int segments = 24;
  std::vector<Vec3> v;
  for (int i = 0; i < segments; ++i) {
    const double a = 2 * M_PI * i / segments, twist = a / 2;
    const Vec3 centre(std::cos(a), std::sin(a), 0), radial = centre, up(0, 0, 1);
    const Vec3 across = 0.3 * (std::cos(twist) * radial + std::sin(twist) * up);
    v.push_back(centre + across);
    v.push_back(centre - across);
  }
  std::vector<std::array<int, 3>> tris;
  for (int i = 0; i < segments; ++i) {
    const int a = 2 * i, b = 2 * i + 1;
    const bool last = i + 1 == segments;
    const int c = last ? 1 : 2 * i + 2, d = last ? 0 : 2 * i + 3;  // the half twist swaps the sides
    tris.push_back({a, b, c});
    tris.push_back({b, d, c});
  }
  const LoadedMesh loaded = buildMesh(v, tris);
  const MeshReport& r = loaded.report;
  EXPECT_EQ(r.nonOrientableFaces, 1) << r.summary();
  EXPECT_EQ(r.faces, 2 * segments - 1);
  EXPECT_EQ(r.components, 1);
  const MeshFinding* f = findFinding(r, "not orientable");
  ASSERT_TRUE(f) << r.summary();
  EXPECT_EQ(f->count, 1);
  EXPECT_EQ(f->elements.size(), 1u);
  EXPECT_TRUE(r.usable());
}

TEST(MeshOrientation, ConsistentMeshIsUntouched) {
  const auto sphere = makeIcosphere(2);
  const LoadedMesh loaded = buildMesh(positionsOf(*sphere), trianglesOf(*sphere));
  EXPECT_EQ(loaded.report.flippedFaces, 0);
  EXPECT_TRUE(loaded.report.findings.empty()) << loaded.report.summary();
  for (int f = 0; f < sphere->numFaces(); ++f) EXPECT_EQ(loaded.mesh->faceVertices(f), sphere->faceVertices(f));
}

// ---- hostile files (issue 15) ----------------------------------------------------------------------------

TEST(MeshHostile, PlyDeclaredCountsAreCheckedAgainstTheBytesLeft) {
  // The 70-byte PLY took 19 s: 2^31 - 1 elements of nothing.
  auto timed = [](const std::string& name, const std::string& text) {
    const auto start = std::chrono::steady_clock::now();
    std::string message;
    try {
      const LoadedMesh loaded = loadMesh(writeFile(name, text));
      message = loaded.report.usable() ? "usable" : loaded.report.summary();
    } catch (const Error& e) {
      message = e.what();
    }
    return std::make_pair(message, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  };
  const auto [none, t1] = timed("foo.ply", "ply\nformat ascii 1.0\nelement foo 2147483647\nend_header\n");
  EXPECT_NE(none.find("no faces"), std::string::npos) << none;
  const auto [ascii, t2] = timed("bigv.ply",
                                 "ply\nformat ascii 1.0\nelement vertex 2147483647\nproperty float x\nproperty float "
                                 "y\nproperty float z\nend_header\n0 0 0\n");
  EXPECT_NE(ascii.find("bigv.ply:7: element 'vertex' declares 2147483647 instances of at least 6 bytes, but only 6 "
                       "bytes follow the header"),
            std::string::npos)
      << ascii;
  const auto [binary, t3] =
      timed("bigf.ply",
            "ply\nformat binary_little_endian 1.0\nelement foo 2147483647\nproperty uchar a\nelement vertex "
            "2147483647\nproperty double x\nproperty double y\nproperty double z\nend_header\n");
  EXPECT_NE(binary.find("element 'foo' declares 2147483647 instances of at least 1 bytes"), std::string::npos)
      << binary;
  // Not a timed test: a generous bound that only a hang (the 19 s and 69 s) can miss.
  EXPECT_LT(t1 + t2 + t3, 5.0);
}

TEST(MeshHostile, OffDeclaredCountsAreCheckedAgainstTheBytesLeft) {
  const std::string msg = errorOf([] { loadMesh(writeFile("big.off", "OFF\n2147483647 2147483647 0\n")); });
  EXPECT_NE(msg.find("big.off:2: the header declares 2147483647 vertices and 2147483647 faces, but only 0 bytes "
                     "follow"),
            std::string::npos)
      << msg;
}

TEST(MeshHostile, ObjMostNegativeIndexIsNamedNotUndefined) {
  // -2^63 cannot be negated (undefined behaviour, once reported as "index 5").
  const std::string msg =
      errorOf([] { loadMesh(writeFile("neg.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -9223372036854775808\n")); });
  EXPECT_NE(msg.find("neg.obj:4: face index -9223372036854775808 out of range (3 defined before this line)"),
            std::string::npos)
      << msg;
  const std::string big =
      errorOf([] { loadMesh(writeFile("big.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9223372036854775808\n")); });
  EXPECT_NE(big.find("big.obj:4: bad face corner"), std::string::npos) << big;
}

TEST(MeshHostile, AbsurdCoordinatesAreAnError) {
  // 1e308 passed `info` as usable, then `run` failed inside with "vector::reserve" (a NaN turned into a size).
  const LoadedMesh loaded = loadMesh(
      writeFile("huge.obj",
                "v 1e308 0 0\nv 0 1e308 0\nv 0 0 1e308\nv -1e308 -1e308 -1e308\nf 1 2 3\nf 1 3 4\nf 1 4 2\nf 2 4 3\n"));
  EXPECT_FALSE(loaded.report.usable());
  const MeshFinding* f = findFinding(loaded.report, "beyond +-1e30");
  ASSERT_TRUE(f) << loaded.report.summary();
  EXPECT_EQ(f->severity, Severity::Error);
  EXPECT_EQ(f->count, 4);
  const LoadedMesh tiny = buildMesh({{0, 0, 0}, {1e-40, 0, 0}, {0, 1e-40, 0}}, {{0, 1, 2}});
  EXPECT_FALSE(tiny.report.usable());
  EXPECT_TRUE(findFinding(tiny.report, "too small")) << tiny.report.summary();
  // Large but sane coordinates stay usable.
  const LoadedMesh big = buildMesh({{0, 0, 0}, {1e12, 0, 0}, {0, 1e12, 0}}, {{0, 1, 2}});
  EXPECT_TRUE(big.report.usable()) << big.report.summary();
}

TEST(MeshHostile, PathProblemsAreNamed) {
  const std::string dir = test::tempDir("mesh_paths");
  namespace fs = std::filesystem;
  fs::create_symlink("b.obj", dir + "/a.obj");
  fs::create_symlink("a.obj", dir + "/b.obj");
  std::string msg = errorOf([&] { loadMesh(dir + "/a.obj"); });
  EXPECT_NE(msg.find("symbolic link loop"), std::string::npos) << msg;
  fs::create_symlink("gone.obj", dir + "/dangling.obj");
  msg = errorOf([&] { loadMesh(dir + "/dangling.obj"); });
  EXPECT_NE(msg.find("dangling symbolic link to 'gone.obj'"), std::string::npos) << msg;
  msg = errorOf([&] { loadMesh("/dev/null.obj"); });
  EXPECT_NE(msg.find("not found"), std::string::npos) << msg;
  fs::create_symlink("/dev/zero", dir + "/zero.obj");
  msg = errorOf([&] { loadMesh(dir + "/zero.obj"); });  // would never end if it were read
  EXPECT_NE(msg.find("is not a regular file"), std::string::npos) << msg;
}

TEST(MeshHostile, ControlCharactersAreEscapedInMessages) {
  const std::string msg = errorOf([] { loadMesh(writeFile("esc.obj", "v 0 0 \x1b[31mred\x07\n")); });
  EXPECT_EQ(msg.find('\x1b'), std::string::npos) << msg;
  EXPECT_EQ(msg.find('\x07'), std::string::npos) << msg;
  EXPECT_NE(msg.find("\\x1b"), std::string::npos) << msg;
}

}  // namespace
}  // namespace montage
