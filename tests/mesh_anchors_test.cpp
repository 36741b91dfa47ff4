// A project that survives a changed mesh (io/mesh_anchors.h): the bundled demo's clicks carried to the cat
// re-exported with another vertex order, and to one whose clicked vertices moved; refused when nothing says where
// an id went; the anchors through save and load.
#include "io/mesh_anchors.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <random>

#include "bench/eval.h"
#include "io/mesh_io.h"
#include "io/project.h"
#include "pipeline.h"
#include "test_support.h"

using namespace montage;
namespace fs = std::filesystem;

namespace {

std::string demoProject() {
  return test::assetsDir() + "/demo/project.json";
}

// Positions and faces (0-based) as OBJ, positions with 17 digits, so that each reads back to the same bits.
void writeObj(const std::string& path, const std::vector<Vec3>& positions,
              const std::vector<std::array<int, 3>>& faces) {
  std::ofstream out(path);
  char line[128];
  for (const Vec3& p : positions) {
    std::snprintf(line, sizeof line, "v %.17g %.17g %.17g\n", p.x(), p.y(), p.z());
    out << line;
  }
  for (const auto& c : faces) out << "f " << c[0] + 1 << ' ' << c[1] + 1 << ' ' << c[2] + 1 << '\n';
}

// `mesh` written as OBJ with its vertices in a random order, its faces shuffled and each face's corners rotated
// (what a re-export does).
void writeReordered(const Mesh& mesh, const std::string& path, unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<int> order(mesh.numVertices()), faces(mesh.numFaces());
  std::iota(order.begin(), order.end(), 0);
  std::iota(faces.begin(), faces.end(), 0);
  std::shuffle(order.begin(), order.end(), rng);
  std::shuffle(faces.begin(), faces.end(), rng);
  std::vector<int> newIndex(mesh.numVertices());
  std::vector<Vec3> positions;
  for (int i = 0; i < mesh.numVertices(); ++i) newIndex[order[i]] = i, positions.push_back(mesh.position(order[i]));
  std::vector<std::array<int, 3>> corners;
  for (int f : faces) {
    const auto c = mesh.faceVertices(f);
    const int r = int(rng() % 3);
    corners.push_back({newIndex[c[r]], newIndex[c[(r + 1) % 3]], newIndex[c[(r + 2) % 3]]});
  }
  writeObj(path, positions, corners);
}

Vec3 centroid(const Mesh& m, int f) {
  const auto q = m.facePositions(f);
  return (q[0] + q[1] + q[2]) / 3.0;
}

// The demo with one of everything that names a vertex or a face: a stroke, a clone, a hole mode, a declined
// proposal, anchored to the cat.
Project anchoredDemo(const Mesh& cat) {
  Project p = loadProject(demoProject());
  p.strokes.push_back(Stroke{{10, 11, 12, 400}});
  CloneOp clone;
  clone.photo = 0;
  clone.polygon = {Vec2(10, 10), Vec2(60, 10), Vec2(30, 50)};
  clone.targetFaces = {5, 6, 7, 800};
  clone.anchorVertex = 13;
  p.clones.push_back(clone);
  p.holeModes.push_back(HoleMode{900, InpaintMode::Harmonic, std::nullopt});
  p.declinedProposals.push_back(DeclinedProposal{14, 1});
  p.anchors = anchorsOf(p, cat);
  return p;
}

}  // namespace

// Another vertex order: every id lands on the vertex or face at the same place, nothing moves, the anchors become
// the new mesh's, and a second carry changes nothing.
TEST(MeshAnchors, AReexportWithAnotherVertexOrderCarriesEveryIdExactly) {
  const Project demo = loadProject(demoProject());
  const auto cat = requireUsable(loadMesh(demo.mesh));
  const Project before = anchoredDemo(*cat);
  const std::string dir = test::tempDir("anchors_reorder");
  const std::string reordered = dir + "/cat.obj";
  writeReordered(*cat, reordered, 1);
  const auto other = requireUsable(loadMesh(reordered));
  ASSERT_NE(meshFingerprint(*other), meshFingerprint(*cat));
  ASSERT_EQ(meshFingerprint(*cat), before.anchors.fingerprint);

  Project after = before;
  const MeshCarry carry = carryToMesh(after, *other);
  EXPECT_TRUE(carry.changed);
  EXPECT_EQ(carry.moved, 0);
  EXPECT_LT(carry.farthest, 1e-9);
  EXPECT_NE(carry.message.find("none moved"), std::string::npos) << carry.message;
  ASSERT_EQ(after.points.size(), before.points.size());
  int differentIds = 0;
  for (size_t i = 0; i < before.points.size(); ++i) {
    EXPECT_EQ(other->position(after.points[i].vertex), cat->position(before.points[i].vertex)) << "point " << i;
    differentIds += after.points[i].vertex != before.points[i].vertex;
    EXPECT_EQ(after.points[i].at, before.points[i].at);
  }
  EXPECT_GT(differentIds, int(before.points.size()) / 2);  // the ids did change
  ASSERT_EQ(after.strokes[0].vertices.size(), 4u);
  for (size_t k = 0; k < 4; ++k)
    EXPECT_EQ(other->position(after.strokes[0].vertices[k]), cat->position(before.strokes[0].vertices[k]));
  EXPECT_EQ(other->position(after.clones[0].anchorVertex), cat->position(before.clones[0].anchorVertex));
  ASSERT_EQ(after.clones[0].targetFaces.size(), 4u);
  for (size_t k = 0; k < 4; ++k)
    EXPECT_LT(
        (centroid(*other, after.clones[0].targetFaces[k]) - centroid(*cat, before.clones[0].targetFaces[k])).norm(),
        1e-12);
  EXPECT_LT((centroid(*other, after.holeModes[0].face) - centroid(*cat, before.holeModes[0].face)).norm(), 1e-12);
  EXPECT_EQ(other->position(after.declinedProposals[0].vertex), cat->position(before.declinedProposals[0].vertex));
  EXPECT_EQ(after.anchors.fingerprint, meshFingerprint(*other));
  Project again = after;
  EXPECT_FALSE(carryToMesh(again, *other).changed);
  // Back to the first mesh: the same ids as at first.
  EXPECT_TRUE(carryToMesh(again, *cat).changed);
  EXPECT_TRUE(again.sameDocument(before));
}

// Retopology moved two clicked vertices by three mean edges: the carry names the points whose vertex moved more
// than half an edge, and only them.
TEST(MeshAnchors, ClicksWhoseVertexMovedAreNamed) {
  const Project demo = loadProject(demoProject());
  const auto cat = requireUsable(loadMesh(demo.mesh));
  Project project = anchoredDemo(*cat);
  double edges = 0;
  for (int f = 0; f < cat->numFaces(); ++f) {
    const auto q = cat->facePositions(f);
    edges += (q[0] - q[1]).norm() + (q[1] - q[2]).norm() + (q[2] - q[0]).norm();
  }
  const double edge = edges / (3.0 * cat->numFaces());
  // The mesh as OBJ with points 2 and 5's vertices pushed out along the x axis.
  const int a = project.points[2].vertex, b = project.points[5].vertex;
  const std::string dir = test::tempDir("anchors_moved");
  std::vector<Vec3> positions;
  for (int v = 0; v < cat->numVertices(); ++v)
    positions.push_back(cat->position(v) + Vec3(v == a || v == b ? 3 * edge : 0, 0, 0));
  std::vector<std::array<int, 3>> faces;
  for (int f = 0; f < cat->numFaces(); ++f) faces.push_back(cat->faceVertices(f));
  writeObj(dir + "/cat.obj", positions, faces);
  const auto moved = requireUsable(loadMesh(dir + "/cat.obj"));
  const MeshCarry carry = carryToMesh(project, *moved);
  ASSERT_TRUE(carry.changed);
  EXPECT_EQ(carry.movedPoints, (std::vector<int>{2, 5})) << carry.message;
  EXPECT_EQ(carry.moved, 2);
  EXPECT_GT(carry.farthest, 0.5);
  EXPECT_LT(carry.farthest, 3.0);
  EXPECT_NE(carry.message.find("(points 2 5: check them)"), std::string::npos) << carry.message;
  EXPECT_NE(project.points[2].vertex, a);  // the nearest vertex to where it was is a neighbour now
}

// A click added after the anchors were taken, on a mesh that changed: nothing says where it went, so the project
// is refused with the file, the vertex and what to do; the pipeline refuses it the same way.
TEST(MeshAnchors, AnIdWithoutAnchorOnAChangedMeshIsRefused) {
  const Project demo = loadProject(demoProject());
  const auto cat = requireUsable(loadMesh(demo.mesh));
  Project project = anchoredDemo(*cat);
  project.points.push_back(FeaturePoint{4321, {PhotoPoint{0, 100, 100}}});
  const std::string dir = test::tempDir("anchors_missing");
  writeReordered(*cat, dir + "/cat.obj", 2);
  const auto other = requireUsable(loadMesh(dir + "/cat.obj"));
  Project copy = project;
  const std::string e = test::errorOf([&] { carryToMesh(copy, *other); });
  EXPECT_NE(e.find(project.file), std::string::npos) << e;
  EXPECT_NE(e.find("vertex 4321 is not stored (anchors.vertex)"), std::string::npos) << e;
  EXPECT_NE(e.find("the mesh changed since the project was saved"), std::string::npos) << e;
  project.mesh = dir + "/cat.obj";
  Pipeline pipeline;
  const std::string run = test::errorOf([&] { pipeline.run(project, JobControl()); });
  EXPECT_NE(run.find("vertex 4321 is not stored"), std::string::npos) << run;
  // The same mesh: nothing to carry, nothing refused.
  Project same = anchoredDemo(*cat);
  same.points.push_back(FeaturePoint{4321, {PhotoPoint{0, 100, 100}}});
  EXPECT_FALSE(carryToMesh(same, *cat).changed);
}

// Anchors go through save and load unchanged; a damaged anchor is named by its field.
TEST(MeshAnchors, SavedAndLoadedAndCheckedByField) {
  const Project demo = loadProject(demoProject());
  const auto cat = requireUsable(loadMesh(demo.mesh));
  Project project = anchoredDemo(*cat);
  const std::string dir = test::tempDir("anchors_file");
  for (const auto& entry : fs::directory_iterator(test::assetsDir() + "/demo"))
    fs::copy(entry.path(), dir + "/" + entry.path().filename().string());
  project.mesh = dir + "/cat.obj";
  for (PhotoRef& ref : project.photos) {
    ref.path = dir + "/" + fs::path(ref.path).filename().string();
    if (!ref.mask.empty()) ref.mask = dir + "/" + fs::path(ref.mask).filename().string();
  }
  saveProject(project, dir + "/p.json");
  const Project back = loadProject(dir + "/p.json");
  EXPECT_TRUE(back.anchors == project.anchors);
  EXPECT_TRUE(back.sameDocument(project));
  EXPECT_TRUE(back.unknownFields.empty());

  std::ifstream in(dir + "/p.json");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto damaged = [&](const std::string& from, const std::string& to) {
    std::string t = text;
    const size_t at = t.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) t.replace(at, from.size(), to);
    return test::errorOf([&] { parseProject(t, dir + "/p.json"); });
  };
  const std::string fingerprint = "\"fingerprint\": \"" + project.anchors.fingerprint + "\"";
  const std::string e1 = damaged(fingerprint, "\"fingerprint\": \"cat\"");
  EXPECT_NE(e1.find("anchors.fingerprint"), std::string::npos) << e1;
  EXPECT_NE(e1.find("16 hexadecimal digits"), std::string::npos) << e1;
  const std::string e2 =
      damaged("\"vertex\": [\n      [\n        " + std::to_string(project.anchors.vertex.begin()->first),
              "\"vertex\": [\n      [\n        99999999");
  EXPECT_NE(e2.find("anchors.vertex[0][0]"), std::string::npos) << e2;
}

// The target: the demo run on its mesh and on the mesh re-exported with another vertex order gives the same
// texture (compared on the surface: 200,000 samples of one result looked up in the other), and the run says what
// it carried.
TEST(MeshAnchors, TheDemoOnItsMeshReexportedGivesTheSameResult) {
  const Project demo = loadProject(demoProject());
  const auto cat = requireUsable(loadMesh(demo.mesh));
  Project project = demo;
  project.anchors = anchorsOf(project, *cat);
  const std::string dir = test::tempDir("anchors_run");
  writeReordered(*cat, dir + "/cat.obj", 3);
  Project reexported = project;
  reexported.mesh = dir + "/cat.obj";
  Pipeline a, b;
  const PipelineResult first = a.run(project, JobControl());
  const PipelineResult second = b.run(reexported, JobControl());
  ASSERT_TRUE(first.model && second.model);
  const auto& warnings = second.scene->warnings;
  ASSERT_FALSE(warnings.empty());
  EXPECT_NE(warnings[0].find("references carried to the nearest of the new mesh"), std::string::npos) << warnings[0];
  ASSERT_TRUE(first.exported && second.exported);
  const EvalResult e = evaluate(*second.exported, *first.exported);
  std::printf("re-exported against the original: %.2f dB over the surface, %.2f dB where a photo textures it\n",
              e.psnrAll, e.psnrCovered);
  EXPECT_GE(e.psnrCovered, 40.0) << e.summary();
  EXPECT_GE(e.psnrAll, 40.0) << e.summary();
}
