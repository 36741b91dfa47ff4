// The editor's display-free logic: document edits and undo, drag grouping, autosave and recovery
// files, the script parser, camera/picking maths and overlay colours. Real demo data where a
// project is needed.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <thread>

#include "autosave.h"
#include "document.h"
#include "geometry/bvh.h"
#include "geometry/predicates.h"
#include "geometry/shapes.h"
#include "overlays.h"
#include "script.h"
#include "surface/inpaint.h"
#include "test_support.h"
#include "view_math.h"

using namespace montage;
namespace fs = std::filesystem;

namespace {

Project demo() {
  return loadProject(test::assetsDir() + "/demo/project.json");
}

// A small document: two photos (the demo's files), no points.
Project twoPhotos() {
  Project p = demo();
  p.photos.resize(2);
  p.points.clear();
  p.chains.clear();
  return p;
}

// Four photos for the photo-management tests: the demo's two, then photo 0's file again with every position
// and chain of photo 0, then photo 1's file again with the positions of every other point seen in photo 1
// (so some points are seen only in photo 1).
Project fourPhotos() {
  Project p = demo();
  EXPECT_EQ(p.photos.size(), 2u);
  p.photos.push_back(p.photos[0]);
  p.photos.push_back(p.photos[1]);
  for (size_t i = 0; i < p.points.size(); ++i) {
    std::vector<PhotoPoint> extra;
    for (const PhotoPoint& a : p.points[i].at) {
      if (a.photo == 0) extra.push_back({2, a.x, a.y});
      if (a.photo == 1 && i % 2 == 0) extra.push_back({3, a.x, a.y});
    }
    p.points[i].at.insert(p.points[i].at.end(), extra.begin(), extra.end());
  }
  const size_t chains = p.chains.size();
  for (size_t c = 0; c < chains; ++c)
    if (p.chains[c].photo == 0) {
      FeatureChain copy = p.chains[c];
      copy.photo = 2;
      p.chains.push_back(copy);
    }
  return p;
}

}  // namespace

TEST(EditorDocument, SetPositionAddsMovesAndExtendsPoints) {
  Document doc(twoPhotos());
  EXPECT_FALSE(doc.modified());
  const int a = doc.setPosition(12, 0, 10, 20);
  EXPECT_EQ(a, 0);
  ASSERT_EQ(doc.project().points.size(), 1u);
  EXPECT_EQ(doc.history().back().label, "Add point (vertex 12, photo 0)");
  // The same vertex in another photo: one more position of the same point.
  EXPECT_EQ(doc.setPosition(12, 1, 30, 40), 0);
  EXPECT_EQ(doc.project().points[0].at.size(), 2u);
  // Again in photo 0: moves it (a vertex has at most one position per photo).
  EXPECT_EQ(doc.setPosition(12, 0, 11, 21), 0);
  EXPECT_EQ(doc.project().points[0].at[0], (PhotoPoint{0, 11, 21}));
  EXPECT_EQ(doc.history().size(), 3u);
  EXPECT_TRUE(doc.modified());
  // A no-op edit leaves no step.
  doc.movePosition(0, 0, 11, 21);
  EXPECT_EQ(doc.history().size(), 3u);
}

TEST(EditorDocument, UndoRedoAndTheSavedState) {
  Project original = twoPhotos();
  original.file = "/tmp/x.json";
  Document doc(original);
  const long r0 = doc.revision();
  doc.setPosition(5, 0, 1, 2);
  doc.setPosition(6, 1, 3, 4);
  EXPECT_GT(doc.revision(), r0);
  doc.undo();
  EXPECT_EQ(doc.project().points.size(), 1u);
  doc.undo();
  EXPECT_TRUE(doc.project().sameDocument(original));
  EXPECT_FALSE(doc.modified()) << "undoing every edit returns to the saved document";
  EXPECT_FALSE(doc.canUndo());
  doc.redo();
  doc.redo();
  EXPECT_EQ(doc.project().points.size(), 2u);
  EXPECT_FALSE(doc.canRedo());
  // A new edit after an undo drops the redo branch.
  doc.undo();
  doc.setPosition(7, 0, 5, 5);
  EXPECT_FALSE(doc.canRedo());
  EXPECT_EQ(doc.history().size(), 2u);
  doc.jumpTo(0);
  EXPECT_TRUE(doc.project().sameDocument(original));
  doc.jumpTo(2);
  EXPECT_EQ(doc.project().points.back().vertex, 7);
}

TEST(EditorDocument, SaveAsSurvivesUndo) {
  Document doc(twoPhotos());
  doc.setPosition(5, 0, 1, 2);
  doc.markSaved("/tmp/new.json");
  EXPECT_FALSE(doc.modified());
  doc.undo();
  EXPECT_EQ(doc.project().file, "/tmp/new.json") << "undo must not bring back the old file name";
  EXPECT_TRUE(doc.modified());
}

TEST(EditorDocument, DragIsOneUndoStep) {
  Document doc(twoPhotos());
  doc.setPosition(9, 0, 100, 100);
  doc.beginGroup("Move point 0");
  for (int k = 1; k <= 20; ++k) doc.movePosition(0, 0, 100 + k, 100 - k);
  EXPECT_FALSE(doc.canUndo()) << "no undo while a drag is open";
  doc.endGroup();
  EXPECT_EQ(doc.history().size(), 2u);
  EXPECT_EQ(doc.history().back().label, "Move point 0");
  EXPECT_EQ(doc.project().points[0].at[0], (PhotoPoint{0, 120, 80}));
  doc.undo();
  EXPECT_EQ(doc.project().points[0].at[0], (PhotoPoint{0, 100, 100}));
  // A drag that comes back where it started leaves no step.
  doc.beginGroup("Move point 0");
  doc.movePosition(0, 0, 150, 150);
  doc.movePosition(0, 0, 100, 100);
  doc.endGroup();
  EXPECT_EQ(doc.history().size(), 2u);
  EXPECT_EQ(doc.position(), 1);
}

TEST(EditorDocument, RemovingPositionsKeepsChainsConsistent) {
  Document doc(twoPhotos());
  for (int v = 0; v < 4; ++v) doc.setPosition(10 + v, 0, 10 * v, 5);
  doc.setPosition(11, 1, 1, 1);
  doc.addChain(FeatureChain{0, {0, 1, 2, 3}, true});
  doc.addChain(FeatureChain{0, {1, 3}, false});
  // Point 2 leaves photo 0: its only position, so the point goes and indices shift down.
  doc.removePosition(2, 0);
  ASSERT_EQ(doc.project().points.size(), 3u);
  ASSERT_EQ(doc.project().chains.size(), 2u);
  EXPECT_EQ(doc.project().chains[0].points, (std::vector<int>{0, 1, 2}));
  EXPECT_EQ(doc.project().chains[1].points, (std::vector<int>{1, 2}));
  // Point 1 leaves photo 0 but stays (it is in photo 1); the line is too short and goes, the
  // polygon too (2 points left).
  doc.removePosition(1, 0);
  EXPECT_EQ(doc.project().points.size(), 3u);
  EXPECT_TRUE(doc.project().chains.empty());
  doc.undo();
  doc.undo();
  EXPECT_EQ(doc.project().chains.size(), 2u);
}

TEST(EditorDocument, RefusedEditsNameTheProblemAndChangeNothing) {
  Document doc(twoPhotos());
  doc.setPosition(1, 0, 1, 1);
  doc.setPosition(2, 1, 1, 1);
  const auto before = doc.snapshot();
  EXPECT_NE(test::errorOf([&] {
              doc.addChain(FeatureChain{0, {0, 1}, false});
            }).find("point 1 has no position in photo 0"),
            std::string::npos);
  EXPECT_NE(test::errorOf([&] { doc.setPosition(3, 7, 1, 1); }).find("photo 7 does not exist"), std::string::npos);
  EXPECT_NE(test::errorOf([&] {
              doc.addChain(FeatureChain{0, {0, 0, 0}, true});
            }).find("point 0 appears twice"),
            std::string::npos);
  EXPECT_NE(test::errorOf([&] { doc.removePoint(5); }).find("point 5 does not exist"), std::string::npos);
  EXPECT_EQ(doc.snapshot(), before);
}

TEST(EditorDocument, RemovePhotoRenumbers) {
  Project p = demo();
  Document doc(p);
  doc.removePhoto(0);
  const Project& q = doc.project();
  ASSERT_GE(p.photos.size(), 2u);
  const int left = static_cast<int>(p.photos.size()) - 1;
  EXPECT_EQ(q.photos.size(), static_cast<size_t>(left));
  for (const auto& pt : q.points) {
    EXPECT_FALSE(pt.at.empty());
    for (const auto& a : pt.at) EXPECT_LT(a.photo, left);
  }
  // Every point of the demo in the other photos survives, shifted down.
  size_t expected = 0;
  for (const auto& pt : p.points)
    for (const auto& a : pt.at)
      if (a.photo != 0) {
        ++expected;
        break;
      }
  EXPECT_EQ(q.points.size(), expected);
}

TEST(EditorDocument, DemoEditSaveAndReload) {
  const Project original = demo();
  Document doc(original);
  doc.setPosition(100, 0, 200.5, 80.25);
  Project copy = doc.project();
  const std::string path = test::tempDir("editor_doc") + "/saved.json";
  saveProject(copy, path);
  doc.markSaved(copy.file);
  EXPECT_FALSE(doc.modified());
  const Project reloaded = loadProject(path);
  EXPECT_TRUE(reloaded.sameDocument(doc.project()));
  EXPECT_EQ(reloaded.points.size(), original.points.size() + 1);
  doc.undo();
  EXPECT_TRUE(doc.project().sameDocument(original));
}

TEST(EditorAutosave, SideFileRecoveryAndLifecycle) {
  const std::string dir = test::tempDir("editor_autosave");
  setenv("XDG_STATE_HOME", (dir + "/state").c_str(), 1);
  // A project of our own (copied demo), so its modification time is ours to set.
  Project project = demo();
  const std::string file = dir + "/proj.json";
  saveProject(project, file);
  const std::string side = autosavePathFor(file, project.mesh);
  EXPECT_EQ(side.rfind(dir + "/state/texturemontage/autosave/proj-", 0), 0u) << side;
  EXPECT_NE(side, autosavePathFor("", project.mesh)) << "an unsaved project has its own side file";
  EXPECT_FALSE(findRecovery(file, project.mesh).has_value());

  Project edited = project;
  edited.points.push_back(FeaturePoint{100, {PhotoPoint{0, 1.5, 2.5}}});
  // The side file must be newer than the project; file times can be coarse.
  fs::last_write_time(file, fs::last_write_time(file) - std::chrono::seconds(5));
  writeAutosave(edited, side);
  auto candidate = findRecovery(file, project.mesh);
  ASSERT_TRUE(candidate.has_value());
  EXPECT_EQ(candidate->projectFile, file);
  EXPECT_EQ(candidate->points, static_cast<int>(edited.points.size()));
  const Project recovered = loadRecovery(*candidate);
  EXPECT_EQ(recovered.file, file);
  EXPECT_TRUE(recovered.sameDocument(edited));
  EXPECT_EQ(listRecoveries().size(), 1u);

  // Saved after the autosave: the project file is newer, nothing to recover.
  fs::last_write_time(file, fs::last_write_time(side) + std::chrono::seconds(5));
  EXPECT_FALSE(findRecovery(file, project.mesh).has_value());
  removeAutosave(side);
  EXPECT_FALSE(fs::exists(side));
  removeAutosave(side);  // missing: not an error
}

TEST(EditorAutosave, ClockAndRecentFiles) {
  AutosaveClock clock(120);
  EXPECT_FALSE(clock.due(500, 3, false)) << "nothing unsaved";
  EXPECT_TRUE(clock.due(500, 3, true));
  clock.written(500, 3);
  EXPECT_FALSE(clock.due(700, 3, true)) << "already autosaved";
  EXPECT_FALSE(clock.due(560, 4, true)) << "interval not over";
  EXPECT_TRUE(clock.due(620, 4, true));

  const std::string store = test::tempDir("editor_recent") + "/recent.json";
  {
    RecentFiles recent(store);
    for (int i = 0; i < 12; ++i) recent.add("/tmp/f" + std::to_string(i) + ".json");
    recent.add("/tmp/f3.json");
    EXPECT_EQ(recent.files().size(), RecentFiles::kMax);
    EXPECT_EQ(recent.files().front(), "/tmp/f3.json");
  }
  RecentFiles reloaded(store);
  EXPECT_EQ(reloaded.files().size(), RecentFiles::kMax);
  EXPECT_EQ(reloaded.files()[1], "/tmp/f11.json");
}

TEST(EditorScript, ParsesActionsAndReportsErrorsWithTheLine) {
  const auto actions = parseScript(
      "# a session\n\nclick_photo 0 412.5 300   # first point\nsave \"/tmp/a b.json\"\nkey ctrl+shift+z\nquit\n",
      "s.txt");
  ASSERT_EQ(actions.size(), 4u);
  EXPECT_EQ(actions[0].line, 3);
  EXPECT_EQ(actions[0].integer(0), 0);
  EXPECT_DOUBLE_EQ(actions[0].number(1), 412.5);
  EXPECT_EQ(actions[1].text(0), "/tmp/a b.json");
  const KeyCombo k = parseKeyCombo(actions[2].text(0));
  EXPECT_TRUE(k.ctrl && k.shift && !k.alt);
  EXPECT_EQ(k.key, "z");

  EXPECT_NE(test::errorOf([] { parseScript("quit\nfly 1\n", "s.txt"); }).find("s.txt:2: unknown action 'fly'"),
            std::string::npos);
  EXPECT_NE(test::errorOf([] {
              parseScript("click_photo 0 1\n", "s.txt");
            }).find("s.txt:1: click_photo: expected 3 argument(s) (P X Y), got 2"),
            std::string::npos);
  EXPECT_NE(test::errorOf([] { parseScript("key ctrl+banana\n", "s.txt"); }).find("unknown key 'banana'"),
            std::string::npos);
  EXPECT_NE(test::errorOf([] { parseScript("save \"open\n", "s.txt"); }).find("s.txt:1: unterminated quote"),
            std::string::npos);
  const auto bad = parseScript("wait_frames x\n", "s.txt");
  EXPECT_NE(test::errorOf([&] { bad[0].integer(0); }).find("argument 1 must be a number, not 'x'"), std::string::npos);
  EXPECT_NE(test::errorOf([] { loadScript("/nonexistent/s.txt"); }).find("/nonexistent/s.txt"), std::string::npos);
}

TEST(EditorViewMath, GlMatricesMatchTheCoreCameraAndPickingFindsVertices) {
  auto sphere = makeIcosphere(3);
  TriangleBvh bvh(*sphere);
  Vec3 lo, hi;
  sphere->bounds(lo, hi);
  OrbitCamera orbit;
  orbit.frame(lo, hi);
  orbit.yawDeg = 40;
  orbit.pitchDeg = -25;
  const Camera cam = orbit.camera(640, 400);
  const Mat4f mvp = multiply(glProjectionMatrix(cam, orbit.nearPlane(), orbit.farPlane()), glViewMatrix(cam));
  int picked = 0, visible = 0;
  for (int v = 0; v < sphere->numVertices(); v += 7) {
    const Vec3 p = sphere->position(v);
    Vec2 px;
    ASSERT_TRUE(cam.project(p, px));
    // GL: clip = mvp * p; window x = (ndc + 1) / 2 * w, window y from the top = (1 - ndc) / 2 * h.
    double clip[4] = {0, 0, 0, 0};
    for (int r = 0; r < 4; ++r) clip[r] = mvp[r] * p.x() + mvp[4 + r] * p.y() + mvp[8 + r] * p.z() + mvp[12 + r];
    EXPECT_NEAR((clip[0] / clip[3] + 1) / 2 * cam.width, px.x(), 1e-3);
    EXPECT_NEAR((1 - clip[1] / clip[3]) / 2 * cam.height, px.y(), 1e-3);
    EXPECT_GT(clip[2] / clip[3], -1);
    EXPECT_LT(clip[2] / clip[3], 1);
    if (!vertexVisible(*sphere, bvh, cam, v)) continue;
    // At grazing angles a fraction of a pixel is far on the surface: test vertices facing the camera.
    if (p.normalized().dot((cam.center() - p).normalized()) < 0.3) continue;
    ++visible;
    // A click on the pixel that contains the vertex picks it (mouse positions are whole pixels).
    const VertexPick pick = pickVertex(*sphere, bvh, cam, std::floor(px.x()) + 0.5, std::floor(px.y()) + 0.5);
    picked += pick.vertex == v;
  }
  EXPECT_GT(visible, 10);
  EXPECT_EQ(picked, visible);
  // Nothing under the cursor outside the sphere.
  EXPECT_EQ(pickVertex(*sphere, bvh, cam, 2, 2).vertex, -1);
}

TEST(EditorViewMath, PaneZoomKeepsThePointUnderTheCursor) {
  PaneView view;
  view.fit(768, 512, Vec2(100, 50), Vec2(400, 300));
  EXPECT_NEAR(view.toScreen(Vec2(384, 256)).x(), 300, 1e-9);
  const Vec2 cursor(250, 170);
  const Vec2 under = view.toPhoto(cursor);
  view.zoomAt(cursor, 3.0);
  EXPECT_NEAR((view.toPhoto(cursor) - under).norm(), 0, 1e-9);
}

TEST(EditorOverlays, StretchIsOneForAnIsometricMapAndClonePreviewFits) {
  auto grid = makeGrid(5, 4, 0.5);
  TextureMap map;
  map.facePhoto.assign(grid->numFaces(), 0);
  map.facePatch.assign(grid->numFaces(), 0);
  map.cornerUV.resize(grid->numFaces());
  for (int f = 0; f < grid->numFaces(); ++f) {
    const auto q = grid->facePositions(f);
    // A camera looking down -z at the grid: photo x = 37 x, photo y (down) = 200 - 37 y.
    for (int k = 0; k < 3; ++k) map.cornerUV[f][k] = Vec2(q[k].x() * 37, -q[k].y() * 37 + 200);
  }
  map.facePhoto[0] = TextureMap::kEmpty;
  const auto stretch = normalizedStretch(*grid, map);
  EXPECT_TRUE(std::isnan(stretch[0]));
  for (size_t f = 1; f < stretch.size(); ++f) EXPECT_NEAR(stretch[f], 1.0, 1e-9);
  // A face mirrored in the photo is flipped: +inf, shown black; the others stay near 1.
  for (auto& uv : map.cornerUV[1]) uv.x() = 300 - uv.x();
  const auto flipped = normalizedStretch(*grid, map);
  EXPECT_TRUE(std::isinf(flipped[1]));
  EXPECT_NEAR(flipped[5], 1.0, 0.2);
  EXPECT_EQ(stretchOverlay(flipped)[1], Vec4f(0.05f, 0.05f, 0.05f, 0.9f));

  CloneOp clone;
  clone.photo = 0;
  clone.polygon = {Vec2(100, 100), Vec2(200, 100), Vec2(200, 180), Vec2(100, 180)};
  clone.anchor = Vec2(150, 140);
  clone.anchorVertex = 7;  // (2, 1) in the grid: the region's middle
  for (int f = 0; f < grid->numFaces(); ++f) clone.targetFaces.push_back(f);
  // The preview is core's projection (inpaint.h), the map the clone itself uses.
  const CloneProjection preview = projectClone(*grid, {}, clone, "clone");
  ASSERT_EQ(preview.faces.size(), clone.targetFaces.size());
  // Fitted: the grid is 2 x 1.5 units, the polygon 100 x 80 px; the polygon must fit inside the
  // target, so 80 / 1.5 = 53.3 px per unit (the larger of 50 and 53.3).
  EXPECT_NEAR(preview.pixelsPerUnit, 80 / 1.5, 1e-9);
  double minX = 1e9, maxX = -1e9;
  for (const auto& c : preview.cornerPixel)
    for (const Vec2& p : c) minX = std::min(minX, p.x()), maxX = std::max(maxX, p.x());
  EXPECT_NEAR(maxX - minX, 2 * 80 / 1.5, 1e-6);
  EXPECT_TRUE(insidePolygon(clone.polygon, Vec2(150, 140)));
  EXPECT_FALSE(insidePolygon(clone.polygon, Vec2(250, 140)));
}

// ---- Managing photos: remove, reorder, mirror, mask, lock, relink (issue 13) ----

TEST(EditorDocument, RemovingAPhotoReindexesPointsAndUndoRestoresThemExactly) {
  const Project p = fourPhotos();
  Document doc(p);
  // Photo 1's positions go; points seen only in photo 1 go (later point indices shift down); chains in
  // photo 1 go; positions in photos 2 and 3 become photos 1 and 2.
  doc.removePhoto(1);
  const Project& q = doc.project();
  ASSERT_EQ(q.photos.size(), 3u);
  EXPECT_EQ(q.photos[1].path, p.photos[2].path);
  size_t kept = 0;
  for (const FeaturePoint& pt : p.points) {
    std::vector<PhotoPoint> expect;
    for (const PhotoPoint& a : pt.at)
      if (a.photo != 1) expect.push_back({a.photo > 1 ? a.photo - 1 : a.photo, a.x, a.y});
    if (expect.empty()) continue;
    ASSERT_LT(kept, q.points.size());
    EXPECT_EQ(q.points[kept].vertex, pt.vertex);
    EXPECT_EQ(q.points[kept].at, expect) << "point " << kept;
    ++kept;
  }
  EXPECT_EQ(kept, q.points.size());
  EXPECT_LT(q.points.size(), p.points.size()) << "fourPhotos() has points seen only in photo 1";
  for (const FeatureChain& c : q.chains) EXPECT_LT(c.photo, 3);
  EXPECT_EQ(doc.history().back().label, "Remove photo 1");
  doc.undo();
  EXPECT_TRUE(doc.project().sameDocument(p));
  EXPECT_EQ(doc.project().points, p.points);
  EXPECT_EQ(doc.project().chains, p.chains);
  doc.redo();
  EXPECT_TRUE(doc.project().sameDocument(q));
}

TEST(EditorDocument, MovingAPhotoCarriesItsPositionsChainsAndClones) {
  Project p = fourPhotos();
  CloneOp clone;
  clone.photo = 3;
  clone.polygon = {Vec2(1, 1), Vec2(20, 1), Vec2(1, 20)};
  clone.targetFaces = {0};
  p.clones = {clone};
  Document doc(p);
  doc.movePhoto(3, 0);  // 3 first: 0, 1, 2 become 1, 2, 3
  const Project& q = doc.project();
  EXPECT_EQ(q.photos[0].path, p.photos[3].path);
  EXPECT_EQ(q.photos[1].path, p.photos[0].path);
  EXPECT_EQ(q.photos[3].path, p.photos[2].path);
  const int newIndex[4] = {1, 2, 3, 0};
  ASSERT_EQ(q.points.size(), p.points.size());
  for (size_t i = 0; i < p.points.size(); ++i)
    for (size_t k = 0; k < p.points[i].at.size(); ++k) {
      EXPECT_EQ(q.points[i].at[k].photo, newIndex[p.points[i].at[k].photo]);
      EXPECT_EQ(q.points[i].at[k].x, p.points[i].at[k].x);
    }
  for (size_t i = 0; i < p.chains.size(); ++i) EXPECT_EQ(q.chains[i].photo, newIndex[p.chains[i].photo]);
  EXPECT_EQ(q.clones[0].photo, 0);
  doc.movePhoto(0, 3);  // and back
  EXPECT_TRUE(doc.project().sameDocument(p));
  doc.undo();
  doc.undo();
  EXPECT_TRUE(doc.project().sameDocument(p));
  EXPECT_EQ(doc.history().size(), 2u);
  EXPECT_NE(test::errorOf([&] { doc.movePhoto(0, 4); }).find("move photo: position 4 does not exist"),
            std::string::npos);
}

TEST(EditorDocument, MirroringAPhotoKeepsItsPointsOnTheSameContent) {
  Project p = fourPhotos();
  Document doc(p);
  doc.setPhotoMirror(2, true, 1024);
  const Project& q = doc.project();
  EXPECT_TRUE(q.photos[2].mirror);
  for (size_t i = 0; i < p.points.size(); ++i)
    for (size_t k = 0; k < p.points[i].at.size(); ++k) {
      const PhotoPoint& a = p.points[i].at[k];
      EXPECT_EQ(q.points[i].at[k].x, a.photo == 2 ? 1024 - a.x : a.x);
      EXPECT_EQ(q.points[i].at[k].y, a.y);
    }
  doc.setPhotoMirror(2, false, 1024);  // mirrored twice: as before (up to rounding of width - x)
  for (size_t i = 0; i < p.points.size(); ++i)
    for (size_t k = 0; k < p.points[i].at.size(); ++k)
      EXPECT_NEAR(doc.project().points[i].at[k].x, p.points[i].at[k].x, 1e-9);
  EXPECT_FALSE(doc.project().photos[2].mirror);
  doc.undo();
  doc.undo();  // undo is exact
  EXPECT_TRUE(doc.project().sameDocument(p));
  // A photo with points needs its width.
  EXPECT_NE(test::errorOf([&] { doc.setPhotoMirror(2, true, 0); }).find("width is unknown"), std::string::npos);
  Document empty(twoPhotos());
  empty.setPhotoMirror(1, true, 0);  // no points: no width needed
  EXPECT_TRUE(empty.project().photos[1].mirror);
}

TEST(EditorDocument, MaskLockAndRelinkAreUndoableEdits) {
  const Project p = twoPhotos();
  Document doc(p);
  doc.setPhotoMask(0, "/tmp/a_mask.png");
  doc.setColorLocked(1, true);
  doc.relinkPhoto(0, "/elsewhere/photo_0.png");
  doc.relinkMesh("/elsewhere/demo_mesh.obj");
  const Project& q = doc.project();
  EXPECT_EQ(q.photos[0].mask, "/tmp/a_mask.png");
  EXPECT_TRUE(q.photos[1].colorLocked);
  EXPECT_EQ(q.photos[0].path, "/elsewhere/photo_0.png");
  EXPECT_EQ(q.mesh, "/elsewhere/demo_mesh.obj");
  EXPECT_EQ(doc.history().size(), 4u);
  EXPECT_EQ(doc.history()[0].label, "Set mask of photo 0");
  EXPECT_EQ(doc.history()[1].label, "Lock colours of photo 1");
  doc.jumpTo(0);
  EXPECT_TRUE(doc.project().sameDocument(p));
}

// A mask written before the first save moves beside the project when it is saved (issue 35): the document
// then names the moved file in its current state and in every undo step, without a step of its own.
TEST(EditorDocument, RenamedMasksAreRenamedInEveryUndoStep) {
  Project p = twoPhotos();
  for (PhotoRef& ref : p.photos) ref.mask.clear();
  Document doc(p);
  doc.setPhotoMask(0, "/state/unsaved/a_mask.png");
  doc.setPhotoMask(1, "/state/unsaved/b_mask.png");
  doc.setColorLocked(1, true);
  doc.undo();  // the lock can be redone
  EXPECT_EQ(doc.masksNamed(), (std::set<std::string>{"/state/unsaved/a_mask.png", "/state/unsaved/b_mask.png"}));
  const long revision = doc.revision();
  doc.renameMasks({{"/state/unsaved/a_mask.png", "/project/masks/a_mask.png"},
                   {"/state/unsaved/b_mask.png", "/project/masks/b_mask.png"}});
  EXPECT_GT(doc.revision(), revision);
  EXPECT_EQ(doc.history().size(), 3u) << "renaming is not an edit";
  EXPECT_EQ(doc.project().photos[0].mask, "/project/masks/a_mask.png");
  EXPECT_EQ(doc.project().photos[1].mask, "/project/masks/b_mask.png");
  EXPECT_EQ(doc.masksNamed(), (std::set<std::string>{"/project/masks/a_mask.png", "/project/masks/b_mask.png"}));
  doc.redo();
  EXPECT_TRUE(doc.project().photos[1].colorLocked);
  EXPECT_EQ(doc.project().photos[1].mask, "/project/masks/b_mask.png");
  doc.jumpTo(1);
  EXPECT_EQ(doc.project().photos[0].mask, "/project/masks/a_mask.png");
  EXPECT_TRUE(doc.project().photos[1].mask.empty());
  doc.jumpTo(0);
  EXPECT_TRUE(doc.project().sameDocument(p));
}

// The photo region a hole's texture comes from: one undoable edit that makes the hole's fill "texture"; it follows
// its photo when photos are removed, moved or mirrored; choosing another fill drops it, texture keeps it.
TEST(EditorDocument, AHolesPickedPhotoRegionFollowsItsPhotoAndItsFill) {
  const Project p = fourPhotos();
  Document doc(p);
  const std::vector<int> hole = {5, 6, 7};
  const HoleExemplar picked{2, {Vec2(10, 10), Vec2(90, 10), Vec2(90, 60)}};
  doc.setHoleFill(hole, 6, InpaintMode::Rbf);
  doc.setHoleExemplar(hole, 6, picked);
  ASSERT_EQ(doc.project().holeModes.size(), 1u);
  EXPECT_EQ(doc.project().holeModes[0].face, 6);
  EXPECT_EQ(doc.project().holeModes[0].mode, InpaintMode::Texture);
  EXPECT_EQ(doc.project().holeModes[0].exemplar, picked);
  EXPECT_EQ(doc.history().back().label, "Texture a hole from photo 2");
  doc.undo();
  EXPECT_EQ(doc.project().holeModes[0].mode, InpaintMode::Rbf);
  EXPECT_FALSE(doc.project().holeModes[0].exemplar);
  doc.redo();

  doc.setHoleFill(hole, 6, InpaintMode::Texture);  // texture again: the region stays
  EXPECT_EQ(doc.project().holeModes[0].exemplar, picked);
  doc.movePhoto(2, 0);
  EXPECT_EQ(doc.project().holeModes[0].exemplar->photo, 0);
  doc.setPhotoMirror(0, true, 1000);
  EXPECT_EQ(doc.project().holeModes[0].exemplar->polygon[1], Vec2(910, 10));
  doc.removePhoto(1);  // another photo: the region's index stays 0
  EXPECT_EQ(doc.project().holeModes[0].exemplar->photo, 0);
  doc.removePhoto(0);  // its own photo: the hole takes its texture from around it again
  ASSERT_EQ(doc.project().holeModes.size(), 1u);
  EXPECT_EQ(doc.project().holeModes[0].mode, InpaintMode::Texture);
  EXPECT_FALSE(doc.project().holeModes[0].exemplar);
  for (int i = 0; i < 3; ++i) doc.undo();
  EXPECT_EQ(doc.project().holeModes[0].exemplar->photo, 0);

  doc.setHoleFill(hole, 6, InpaintMode::Harmonic);  // another fill: the region goes
  EXPECT_FALSE(doc.project().holeModes[0].exemplar);
  doc.undo();
  doc.setHoleExemplar(hole, 6, std::nullopt);  // cleared: the mode stays
  EXPECT_EQ(doc.project().holeModes[0].mode, InpaintMode::Texture);
  EXPECT_FALSE(doc.project().holeModes[0].exemplar);
  EXPECT_EQ(doc.history().back().label, "Texture a hole from around it");
  const size_t steps = doc.history().size();
  doc.setHoleExemplar({1, 2}, 1, std::nullopt);  // a hole without an entry: nothing to clear, no step
  EXPECT_EQ(doc.history().size(), steps);
  EXPECT_NE(test::errorOf([&] { doc.setHoleExemplar(hole, 6, HoleExemplar{9, picked.polygon}); }).find("photo 9"),
            std::string::npos);
}
