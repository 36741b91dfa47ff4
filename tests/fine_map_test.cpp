// Tests of the map stage, cell by cell (core/mapping/cells.h and fine_map.h, paper sections 3.2 and
// 4.1). A hand-built flat grid whose true map is a similarity (exact answer known): one photo, a
// background stripe across it, two photos meeting on a path (category-3 vertices), the choice of the
// most frontal photo, a mirrored view, a path with an ear; the cell cache. Then the Spot cow seen by
// a synthetic camera, compared with the true projection (needs ../shared/data).
#include "mapping/fine_map.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <opencv2/imgproc.hpp>
#include <set>

#include "bench/synth.h"
#include "geometry/mesh.h"
#include "geometry/raster.h"
#include "geometry/stretch.h"
#include "image/photo.h"
#include "io/mesh_io.h"
#include "mapping/cells.h"
#include "mapping/partition.h"
#include "mapping/simplify.h"
#include "pipeline.h"
#include "test_support.h"

namespace montage {
namespace {

using Clock = std::chrono::steady_clock;

// Twice the signed area of a texture triangle given in pixels (y down), in the y-flipped frame in
// which a face seen by the camera is counter-clockwise.
double flippedArea(const std::array<Vec2, 3>& uv) {
  const Vec2 a(uv[0].x(), -uv[0].y()), b(uv[1].x(), -uv[1].y()), c(uv[2].x(), -uv[2].y());
  return (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
}

int countFlips(const TextureMap& map) {
  int flips = 0;
  for (int f = 0; f < map.numFaces(); ++f)
    if (map.facePhoto[f] != TextureMap::kEmpty && !(flippedArea(map.cornerUV[f]) > 0)) ++flips;
  return flips;
}

// Per vertex and photo, the UV the map gives it (first corner found), and whether all corners agree.
std::map<std::pair<int, int>, Vec2> vertexUVs(const Mesh& mesh, const TextureMap& map, bool* consistent = nullptr) {
  std::map<std::pair<int, int>, Vec2> uvs;
  if (consistent) *consistent = true;
  for (int f = 0; f < map.numFaces(); ++f) {
    if (map.facePhoto[f] == TextureMap::kEmpty) continue;
    const auto c = mesh.faceVertices(f);
    for (int k = 0; k < 3; ++k) {
      auto [it, inserted] = uvs.emplace(std::make_pair(c[k], map.facePhoto[f]), map.cornerUV[f][k]);
      if (!inserted && consistent && it->second != map.cornerUV[f][k]) *consistent = false;
    }
  }
  return uvs;
}

// Max and mean Sander L-infinity stretch over mapped faces (flipped frame).
void mapStretch(const Mesh& mesh, const TextureMap& map, double& maxGamma, double& meanGamma) {
  maxGamma = meanGamma = 0;
  int n = 0;
  for (int f = 0; f < map.numFaces(); ++f) {
    if (map.facePhoto[f] == TextureMap::kEmpty) continue;
    std::array<Vec2, 3> uv;
    for (int k = 0; k < 3; ++k) uv[k] = Vec2(map.cornerUV[f][k].x(), -map.cornerUV[f][k].y());
    const TriangleStretch s = triangleStretch(mesh.facePositions(f), uv);
    maxGamma = std::max(maxGamma, s.gamma);
    meanGamma += s.gamma;
    ++n;
  }
  if (n) meanGamma /= n;
}

// Cells by flood fill across edges that are not on a path.
std::vector<int> floodCells(const Mesh& mesh, const std::vector<MeshPath>& paths, int& numCells) {
  std::set<std::pair<int, int>> pathEdges;
  for (const MeshPath& p : paths)
    for (size_t i = 1; i < p.vertices.size(); ++i)
      pathEdges.emplace(std::min(p.vertices[i - 1], p.vertices[i]), std::max(p.vertices[i - 1], p.vertices[i]));
  std::map<std::pair<int, int>, std::vector<int>> edgeFaces;
  for (int f = 0; f < mesh.numFaces(); ++f) {
    const auto c = mesh.faceVertices(f);
    for (int k = 0; k < 3; ++k)
      edgeFaces[{std::min(c[k], c[(k + 1) % 3]), std::max(c[k], c[(k + 1) % 3])}].push_back(f);
  }
  std::vector<int> cell(mesh.numFaces(), -1);
  numCells = 0;
  for (int seed = 0; seed < mesh.numFaces(); ++seed) {
    if (cell[seed] >= 0) continue;
    std::vector<int> stack = {seed};
    cell[seed] = numCells;
    while (!stack.empty()) {
      const int f = stack.back();
      stack.pop_back();
      const auto c = mesh.faceVertices(f);
      for (int k = 0; k < 3; ++k) {
        const std::pair<int, int> e(std::min(c[k], c[(k + 1) % 3]), std::max(c[k], c[(k + 1) % 3]));
        if (pathEdges.count(e)) continue;
        for (int g : edgeFaces[e])
          if (cell[g] < 0) cell[g] = numCells, stack.push_back(g);
      }
    }
    ++numCells;
  }
  return cell;
}

// A photo built in memory: everything foreground except rows [stripeFrom, stripeTo).
std::shared_ptr<Photo> makePhoto(int width, int height, int stripeFrom = 0, int stripeTo = 0) {
  auto photo = std::make_shared<Photo>();
  photo->width = width;
  photo->height = height;
  photo->rgb = cv::Mat(height, width, CV_32FC3, cv::Scalar(0.5, 0.5, 0.5));
  photo->alpha = cv::Mat(height, width, CV_32FC1, cv::Scalar(1));
  for (int r = std::max(0, stripeFrom); r < std::min(height, stripeTo); ++r) photo->alpha.row(r).setTo(0);
  const cv::Mat background = photo->alpha <= 0;
  cv::distanceTransform(background, photo->distance, cv::DIST_L2, cv::DIST_MASK_PRECISE, CV_32F);
  photo->hasBackground = stripeTo > stripeFrom;
  return photo;
}

// A camera looking at the plane z = 0 from +z (or from -z when mirrored): pixel = (+-s x + a, -s y + b).
struct View {
  double s = 10, a = 20, b = 320;
  bool mirrored = false;
  Vec2 operator()(const Vec3& p) const { return Vec2((mirrored ? -s : s) * p.x() + a, -s * p.y() + b); }
};

// A flat n x n grid in z = 0 (unit spacing, vertex i + n j at (i, j)), CCW seen from +z, cut by the
// four sides of the square [lo, hi]^2 and its diagonal into two triangular cells and the outside.
// Paths (bottom, right, top, left, diagonal) have curves in the photos listed in `pathPhotos`
// (default: every photo); the corners are clicked in every photo at their exact images.
struct GridCase {
  static constexpr int n = 31, lo = 5, hi = 25;
  std::shared_ptr<Scene> scene;
  Partition partition;
  std::vector<View> views;

  static int id(int i, int j) { return i + n * j; }
  // The position of grid vertex v.
  static Vec3 at(int v) { return Vec3(v % n, v / n, 0); }

  // The n x n grid in the plane z = 0, two triangles per square.
  static std::shared_ptr<const Mesh> gridMesh() {
    std::vector<Vec3> vertices;
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) vertices.emplace_back(i, j, 0);
    std::vector<std::array<int, 3>> triangles;
    for (int j = 0; j + 1 < n; ++j)
      for (int i = 0; i + 1 < n; ++i) {
        triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
        triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
      }
    return requireUsable(buildMesh(vertices, triangles));
  }

  GridCase(std::vector<std::shared_ptr<Photo>> photos, std::vector<View> photoViews,
           std::vector<std::vector<int>> pathPhotos = {})
      : views(std::move(photoViews)) {
    scene = std::make_shared<Scene>();
    scene->mesh = gridMesh();
    partition.mesh = *scene->mesh;
    for (size_t k = 0; k < photos.size(); ++k) {
      scene->photos.push_back(photos[k]);
      scene->project.photos.push_back(PhotoRef{"grid" + std::to_string(k) + ".png", ""});
    }

    const int corners[4] = {id(lo, lo), id(hi, lo), id(hi, hi), id(lo, hi)};
    for (int v : corners) {
      FeaturePoint point{v, {}};
      for (size_t k = 0; k < views.size(); ++k) {
        const Vec2 px = views[k](at(v));
        point.at.push_back(PhotoPoint{static_cast<int>(k), px.x(), px.y()});
      }
      scene->project.points.push_back(point);
      partition.featureVertex.push_back(v);
    }
    auto addPath = [&](int from, int to, int di, int dj) {
      MeshPath path;
      path.fromPoint = from;
      path.toPoint = to;
      int v = corners[from];
      path.vertices.push_back(v);
      while (v != corners[to]) {
        v += di + n * dj;
        path.vertices.push_back(v);
      }
      std::vector<int> inPhotos = pathPhotos.empty() ? std::vector<int>() : pathPhotos[partition.paths.size()];
      if (pathPhotos.empty())
        for (size_t k = 0; k < views.size(); ++k) inPhotos.push_back(static_cast<int>(k));
      for (int k : inPhotos) path.curves.push_back(Curve{k, views[k](at(corners[from])), views[k](at(corners[to]))});
      path.fromChain = true;
      path.length = (at(corners[to]) - at(corners[from])).norm();
      partition.paths.push_back(path);
    };
    addPath(0, 1, 1, 0);   // bottom
    addPath(1, 2, 0, 1);   // right
    addPath(2, 3, -1, 0);  // top
    addPath(3, 0, 0, -1);  // left
    addPath(0, 2, 1, 1);   // diagonal, along the triangulation's diagonals
    partition.faceParent.resize(partition.mesh.numFaces());
    for (int f = 0; f < partition.mesh.numFaces(); ++f) partition.faceParent[f] = f;
    partition.faceCell = floodCells(partition.mesh, partition.paths, partition.numCells);
  }
  explicit GridCase(std::shared_ptr<Photo> photo, View view = {})
      : GridCase(std::vector<std::shared_ptr<Photo>>{std::move(photo)}, std::vector<View>{view}) {}

  static Vec3 centroid(const Mesh& mesh, int f) {
    const auto q = mesh.facePositions(f);
    return (q[0] + q[1] + q[2]) / 3;
  }
  static bool insideSquare(const Vec3& p) { return p.x() > lo && p.x() < hi && p.y() > lo && p.y() < hi; }
  static bool onSquare(const Vec3& p) { return p.x() >= lo && p.x() <= hi && p.y() >= lo && p.y() <= hi; }
};

// Checks shared by the grid tests: the square's two cells are mapped (to `lower` below the diagonal,
// `upper` above) and nothing else; no flip; feature vertices bit-exact at their clicks; one UV per
// vertex and photo; every UV within `tolerance` px of its exact image, when tolerance > 0.
void checkGridMap(const GridCase& g, const CellMapping& cm, int lower = 0, int upper = 0, double tolerance = 0) {
  const TextureMap& map = cm.map;
  const Mesh& mesh = g.partition.mesh;
  ASSERT_EQ(map.numFaces(), mesh.numFaces());
  EXPECT_EQ(g.partition.numCells, 3);
  EXPECT_EQ(cm.stats.baseMappedFaces, 2);
  for (int f = 0; f < mesh.numFaces(); ++f) {
    const Vec3 c = GridCase::centroid(mesh, f);
    const int expected = !GridCase::insideSquare(c) ? TextureMap::kEmpty : c.y() < c.x() ? lower : upper;
    EXPECT_EQ(map.facePhoto[f], expected) << "face " << f;
    EXPECT_EQ(map.facePatch[f], g.partition.faceCell[f]);
  }
  EXPECT_FALSE(map.notes.empty());  // the outside touches the mesh border
  EXPECT_EQ(countFlips(map), 0);
  EXPECT_EQ(cm.stats.flippedFaces, 0);
  bool consistent = false;
  const auto uvs = vertexUVs(mesh, map, &consistent);
  EXPECT_TRUE(consistent);
  int features = 0;
  for (const FeaturePoint& fp : g.scene->project.points)
    for (const PhotoPoint& at : fp.at) {
      auto it = uvs.find({fp.vertex, at.photo});
      if (it == uvs.end()) continue;    // no mapped face of that photo at this corner
      EXPECT_EQ(it->second.x(), at.x);  // bit-identical
      EXPECT_EQ(it->second.y(), at.y);
      ++features;
    }
  EXPECT_EQ(features, lower == upper ? 4 : 6);
  if (tolerance <= 0) return;
  int checked = 0;
  for (const auto& [key, uv] : uvs) {
    const Vec3 p = mesh.position(key.first);
    EXPECT_TRUE(GridCase::onSquare(p));
    EXPECT_LT((uv - g.views[key.second](p)).norm(), tolerance) << "vertex " << key.first << " photo " << key.second;
    ++checked;
  }
  const int side = GridCase::hi - GridCase::lo + 1;
  EXPECT_EQ(checked, side * side + (lower != upper ? side : 0));  // the diagonal twice with two photos
}

int countStatus(const CellMapping& cm, CellStatus status) {
  return int(std::count_if(cm.cells.begin(), cm.cells.end(), [&](const CellPlan& c) { return c.status == status; }));
}

TEST(FineMap, FlatGridReproducesTheAffineMap) {
  GridCase g(makePhoto(340, 340));
  const CellMapping cm = mapCells(*g.scene, g.partition, FineMapOptions{}, JobControl{});
  EXPECT_EQ(countStatus(cm, CellStatus::Mapped), 2);
  EXPECT_EQ(countStatus(cm, CellStatus::TouchesBorder), 1);
  EXPECT_GT(cm.stats.splits, 0);
  // The true map is a similarity: the L-infinity stretch optimum is that map (gamma = 1/s).
  checkGridMap(g, cm, 0, 0, 0.05);
  const Mesh& mesh = g.partition.mesh;
  double maxError = 0;
  for (const auto& [key, uv] : vertexUVs(mesh, cm.map))
    maxError = std::max(maxError, (uv - g.views[0](mesh.position(key.first))).norm());
  double maxGamma = 0, meanGamma = 0;
  mapStretch(mesh, cm.map, maxGamma, meanGamma);
  const double ideal = 1 / g.views[0].s;
  EXPECT_NEAR(maxGamma, ideal, 0.01 * ideal);
  EXPECT_NEAR(cm.stats.maxStretch, maxGamma, 1e-9);
  std::printf("grid: %d splits, %d fallbacks, max uv error %.3g px, stretch max %.6f mean %.6f (ideal %.6f)\n",
              cm.stats.splits, cm.stats.centroidFallbacks, maxError, maxGamma, meanGamma, ideal);
}

TEST(FineMap, FlatGridAvoidsABackgroundStripe) {
  // Rows 178..182 are background: the ideal images of the grid row y = 14 (pixel y = 180) lie on it,
  // inner vertices as well as the vertices of the left and right paths.
  GridCase g(makePhoto(340, 340, 178, 183));
  const CellMapping cm = mapCells(*g.scene, g.partition, FineMapOptions{}, JobControl{});
  checkGridMap(g, cm);
  const Photo& photo = *g.scene->photos[0];
  int idealOnBackground = 0, onBackground = 0;
  for (const auto& [key, uv] : vertexUVs(g.partition.mesh, cm.map)) {
    const Vec2 ideal = g.views[0](g.partition.mesh.position(key.first));
    idealOnBackground += !photo.isForeground(ideal.x(), ideal.y());
    onBackground += !photo.isForeground(uv.x(), uv.y());
  }
  EXPECT_GT(idealOnBackground, 10);  // the test means something
  EXPECT_EQ(onBackground, 0);
  EXPECT_EQ(cm.stats.onBackground, 0);
  double maxGamma = 0, meanGamma = 0;
  mapStretch(g.partition.mesh, cm.map, maxGamma, meanGamma);
  EXPECT_LT(maxGamma, 1.5 / g.views[0].s);  // the detour costs some stretch, not a collapse
  std::printf(
      "stripe: %d vertices would lie on the stripe, %d do; stretch max %.4f mean %.4f (ideal %.4f); "
      "%d fallbacks\n",
      idealOnBackground, onBackground, maxGamma, meanGamma, 1 / g.views[0].s, cm.stats.centroidFallbacks);
}

TEST(PathUVs, ArcLengthAlongTheForegroundOfTheCurve) {
  // A straight path of 11 vertices, unevenly spaced, and a curve over a photo with a background gap.
  std::vector<Vec3> vertices;
  const double xs[] = {0, 1, 3, 4, 5, 6, 7, 8, 9, 10, 12};
  for (double x : xs) vertices.emplace_back(x, 0, 0), vertices.emplace_back(x, 1, 0);
  std::vector<std::array<int, 3>> tris;
  for (int i = 0; i + 1 < 11; ++i)
    tris.push_back({2 * i, 2 * i + 2, 2 * i + 3}), tris.push_back({2 * i, 2 * i + 3, 2 * i + 1});
  const auto mesh = requireUsable(buildMesh(vertices, tris));
  MeshPath path;
  for (int i = 0; i < 11; ++i) path.vertices.push_back(2 * i);
  const Curve curve{0, Vec2(10, 50), Vec2(130, 50)};
  const auto plain = makePhoto(200, 100);
  std::vector<Vec2> uv = pathUVs(*mesh, path, curve, *plain);
  ASSERT_EQ(uv.size(), 11u);
  EXPECT_EQ(uv.front(), curve.from);  // bit-identical ends
  EXPECT_EQ(uv.back(), curve.to);
  for (int i = 0; i < 11; ++i) EXPECT_NEAR(uv[i].x(), 10 + 10 * xs[i], 1e-9) << i;  // 120 px over 12 units
  // Columns 50..69 are background: the vertices skip the gap, in order, at the foreground's arc length.
  auto gap = makePhoto(200, 100);
  gap->alpha.colRange(50, 70).setTo(0);
  uv = pathUVs(*mesh, path, curve, *gap);
  for (int i = 0; i < 11; ++i) {
    EXPECT_TRUE(gap->isForeground(uv[i].x(), uv[i].y())) << i << " at " << uv[i].x();
    if (i > 0) EXPECT_GT(uv[i].x(), uv[i - 1].x());
  }
  EXPECT_NEAR(uv[3].x(), 10 + 100.0 * 4 / 12, 0.6);       // 100 px of foreground over 12 units, before the gap
  EXPECT_NEAR(uv[6].x(), 10 + 100.0 * 7 / 12 + 20, 0.6);  // after it
}

TEST(FineMap, TwoPhotosMeetOnTheDiagonal) {
  // The lower cell's paths have curves in photo 1 only, the upper cell's in photo 0 only; the
  // diagonal in both: its vertices get one UV per photo (section 4.1, third category).
  const std::vector<View> views = {View{10, 20, 320}, View{8, 40, 280}};
  const std::vector<std::vector<int>> pathPhotos = {{1}, {1}, {0}, {0}, {0, 1}};
  GridCase g({makePhoto(340, 340), makePhoto(300, 300)}, views, pathPhotos);
  const CellMapping cm = mapCells(*g.scene, g.partition, FineMapOptions{}, JobControl{});
  checkGridMap(g, cm, 1, 0, 0.05);
}

TEST(FineMap, ChoosesTheMostFrontalPhoto) {
  // Every path has a curve in both photos; photo 1 sees the square larger (smaller stretch).
  GridCase g({makePhoto(340, 340), makePhoto(360, 360)}, {View{10, 20, 320}, View{12, 0, 360}});
  const CellMapping cm = mapCells(*g.scene, g.partition, FineMapOptions{}, JobControl{});
  checkGridMap(g, cm, 1, 1, 0.05);
}

TEST(FineMap, MirroredPhotoIsNotUsed) {
  // A camera behind the plane sees the faces clockwise: the texture triangles are flipped.
  View mirrored{10, 320, 320, true};
  GridCase g(makePhoto(340, 340), mirrored);
  const CellMapping cm = mapCells(*g.scene, g.partition, FineMapOptions{}, JobControl{});
  EXPECT_EQ(cm.map.numMapped(), 0);
  EXPECT_EQ(cm.stats.baseMappedFaces, 0);
  EXPECT_EQ(countStatus(cm, CellStatus::Mirrored), 2);
  bool noted = false;
  for (const std::string& note : cm.map.notes) noted |= note.find("2 regions are left empty: mirrored") == 0;
  EXPECT_TRUE(noted);
  for (const CellPlan& c : cm.cells)
    if (c.status == CellStatus::Mirrored) EXPECT_NE(c.detail.find("mirrored"), std::string::npos);
}

TEST(FineMap, AFaceWithThreeCornersOnOneSideFailsItsCellOnly) {
  // The bottom path detours (10,5) -> (10,4) -> (11,5): the face (10,4) (11,5) (10,5) has its three
  // corners on one path, hence on one straight curve, where no map can give it an area. The
  // partitioner never makes such a face (it splits every edge joining two vertices of a path); a
  // hand-made one fails its cell, with the reason, and the other cell maps.
  GridCase g(makePhoto(340, 340));
  std::vector<int>& bottom = g.partition.paths[0].vertices;
  const auto at = std::find(bottom.begin(), bottom.end(), GridCase::id(10, 5));
  ASSERT_NE(at, bottom.end());
  bottom.insert(at + 1, GridCase::id(10, 4));
  g.partition.faceCell = floodCells(g.partition.mesh, g.partition.paths, g.partition.numCells);
  const CellMapping cm = mapCells(*g.scene, g.partition, FineMapOptions{}, JobControl{});
  EXPECT_EQ(countStatus(cm, CellStatus::Failed), 1);
  EXPECT_EQ(countStatus(cm, CellStatus::Mapped), 1);
  for (const CellPlan& c : cm.cells)
    if (c.status == CellStatus::Failed) EXPECT_NE(c.detail.find("three corners"), std::string::npos) << c.detail;
  const int side = GridCase::hi - GridCase::lo;
  EXPECT_EQ(cm.map.numMapped(), side * side);  // the upper triangle
  EXPECT_EQ(countFlips(cm.map), 0);
}

// ---- Cells that are not triangles: feature polygons, features inside, the mesh border (issue 33) ----

// A flat grid as GridCase's, one photo seeing it through `view`, features at the grid points `corners` (counter-
// clockwise, as the grid is seen from +z) joined by paths along straight grid runs (steps along the axes or the
// triangulation's diagonals), except the sides `freeSides` lists (from corner k to k + 1: no path, e.g. along the
// mesh border); features at `inner` with clicks `innerShift` px off their exact images, and no paths.
struct PolygonCase {
  static constexpr int n = GridCase::n;
  std::shared_ptr<Scene> scene;
  Partition partition;
  View view;
  std::vector<int> innerVertices;

  PolygonCase(const std::vector<std::pair<int, int>>& corners, const std::vector<std::pair<int, int>>& inner,
              const std::vector<int>& freeSides = {}, Vec2 innerShift = Vec2::Zero()) {
    scene = std::make_shared<Scene>();
    scene->mesh = GridCase::gridMesh();
    partition.mesh = *scene->mesh;
    scene->photos.push_back(makePhoto(340, 340));
    scene->project.photos.push_back(PhotoRef{"grid.png", ""});
    auto addPoint = [&](int v, Vec2 shift) {
      const Vec2 px = view(GridCase::at(v)) + shift;
      scene->project.points.push_back(FeaturePoint{v, {PhotoPoint{0, px.x(), px.y()}}});
      partition.featureVertex.push_back(v);
    };
    for (const auto& [i, j] : corners) addPoint(GridCase::id(i, j), Vec2::Zero());
    for (const auto& [i, j] : inner)
      addPoint(GridCase::id(i, j), innerShift), innerVertices.push_back(GridCase::id(i, j));
    const int k = static_cast<int>(corners.size());
    for (int c = 0; c < k; ++c) {
      if (std::find(freeSides.begin(), freeSides.end(), c) != freeSides.end()) continue;
      const auto [i0, j0] = corners[c];
      const auto [i1, j1] = corners[(c + 1) % k];
      const int di = (i1 > i0) - (i1 < i0), dj = (j1 > j0) - (j1 < j0);
      MeshPath path;
      path.fromPoint = c;
      path.toPoint = (c + 1) % k;
      for (int i = i0, j = j0;; i += di, j += dj) {
        path.vertices.push_back(GridCase::id(i, j));
        if (i == i1 && j == j1) break;
      }
      path.curves.push_back(
          Curve{0, view(GridCase::at(GridCase::id(i0, j0))), view(GridCase::at(GridCase::id(i1, j1)))});
      path.fromChain = true;
      partition.paths.push_back(path);
    }
    partition.faceParent.resize(partition.mesh.numFaces());
    for (int f = 0; f < partition.mesh.numFaces(); ++f) partition.faceParent[f] = f;
    partition.faceCell = floodCells(partition.mesh, partition.paths, partition.numCells);
  }

  // Mapped cells, flips, the largest distance of a mapped vertex from its exact image (the inner features'
  // clicks excepted), and whether every inner feature sits exactly on its click.
  struct Figures {
    int mapped = 0, flips = 0;
    double maxError = 0;
    bool innerExact = true;
  };
  Figures figures(const CellMapping& cm) const {
    Figures out;
    out.mapped = countStatus(cm, CellStatus::Mapped);
    out.flips = countFlips(cm.map);
    const auto uvs = vertexUVs(partition.mesh, cm.map);
    for (const auto& [key, uv] : uvs)
      if (std::find(innerVertices.begin(), innerVertices.end(), key.first) == innerVertices.end())
        out.maxError = std::max(out.maxError, (uv - view(partition.mesh.position(key.first))).norm());
    for (size_t i = 0; i < innerVertices.size(); ++i) {
      const auto it = uvs.find({innerVertices[i], 0});
      const PhotoPoint& click = scene->project.points[scene->project.points.size() - innerVertices.size() + i].at[0];
      out.innerExact = out.innerExact && it != uvs.end() && it->second == Vec2(click.x, click.y);
    }
    return out;
  }
};

TEST(FineMap, APolygonCellMapsWithZeroOneAndThreeFeaturesInside) {
  // A square of four paths (no diagonal): one cell bounded by four sides, mapped into the photo polygon. Features
  // inside without paths constrain it: their clicks are 6 px off the flat map, and the map goes through them.
  const std::vector<std::pair<int, int>> square = {{5, 5}, {25, 5}, {25, 25}, {5, 25}};
  const std::vector<std::vector<std::pair<int, int>>> insides = {{}, {{15, 15}}, {{10, 12}, {19, 11}, {14, 20}}};
  for (const auto& inner : insides) {
    SCOPED_TRACE(std::to_string(inner.size()) + " features inside");
    const PolygonCase c(square, inner, {}, Vec2(6, -4));
    const CellMapping cm = mapCells(*c.scene, c.partition, FineMapOptions{}, JobControl{});
    const auto f = c.figures(cm);
    EXPECT_EQ(f.mapped, 1);
    EXPECT_EQ(countStatus(cm, CellStatus::TouchesBorder), 1);  // the ring around the square
    EXPECT_EQ(f.flips, 0);
    EXPECT_EQ(cm.stats.flippedFaces, 0);
    EXPECT_TRUE(f.innerExact);
    EXPECT_EQ(cm.map.numMapped(), 20 * 20 * 2);
    // The square's true map is a similarity: without inner features it is reproduced; with a feature moved
    // 7 px, the map bends smoothly towards it (not further than the move).
    if (inner.empty()) EXPECT_LT(f.maxError, 0.05);
    EXPECT_LT(f.maxError, 7.3);
    std::printf("square, %zu inside: max error %.3f px, max stretch %.4f\n", inner.size(), f.maxError,
                cm.stats.maxStretch);
  }
}

TEST(FineMap, AConcavePolygonCellMapsWithoutFolds) {
  // An L: six sides, the corner (15, 15) reflex.
  const PolygonCase c({{5, 5}, {25, 5}, {25, 15}, {15, 15}, {15, 25}, {5, 25}}, {});
  const CellMapping cm = mapCells(*c.scene, c.partition, FineMapOptions{}, JobControl{});
  const auto f = c.figures(cm);
  EXPECT_EQ(f.mapped, 1);
  EXPECT_EQ(f.flips, 0);
  EXPECT_EQ(cm.map.numMapped(), 2 * (20 * 10 + 10 * 10));
  EXPECT_LT(f.maxError, 0.5);
  std::printf("L polygon: max error %.3f px, base inner vertices %d\n", f.maxError, cm.stats.baseInnerVertices);
}

TEST(FineMap, ACellOnTheMeshBorderMapsWithoutFolds) {
  // The square's left side lies on the mesh border (i = 0) with no path: the cell is closed by three paths and
  // the border, which stays free in the photo. The rest of the grid, a disc around it, touches the border too.
  const PolygonCase c({{0, 5}, {20, 5}, {20, 25}, {0, 25}}, {}, {3});
  const CellMapping cm = mapCells(*c.scene, c.partition, FineMapOptions{}, JobControl{});
  const auto f = c.figures(cm);
  EXPECT_EQ(f.mapped, 2);
  EXPECT_EQ(f.flips, 0);
  EXPECT_EQ(cm.stats.flippedFaces, 0);
  EXPECT_EQ(cm.map.numMapped(), cm.map.numFaces());
  // Conformal with the three paths held: the free border stays near the flat map.
  EXPECT_LT(f.maxError, 3.0);
  std::printf("border cell: max error %.3f px\n", f.maxError);
}

TEST(FineMap, CellCacheReusesUnchangedCellsExactly) {
  // Two grids side by side would share nothing; here the same grid is mapped three times: from
  // scratch, from the cache (every cell reused, the very same map), and after one corner's click
  // moved in the photo (the cells with that corner are mapped again, the result equals a fresh run).
  GridCase g(makePhoto(340, 340));
  g.scene->photoKeys = {"grid0"};
  CellCache cache;
  const CellMapping first = mapCells(*g.scene, g.partition, FineMapOptions{}, JobControl{}, &cache);
  EXPECT_EQ(first.cellsMapped, 2);
  EXPECT_EQ(first.cellsReused, 0);
  cache.endRun();
  const CellMapping second = mapCells(*g.scene, g.partition, FineMapOptions{}, JobControl{}, &cache);
  EXPECT_EQ(second.cellsMapped, 0);
  EXPECT_EQ(second.cellsReused, 2);
  EXPECT_TRUE(first.map.cornerUV == second.map.cornerUV);
  cache.endRun();
  // Corner 1 (only on the lower cell) moves 3 px: its two paths' curves move with it.
  g.scene->project.points[1].at[0].x += 3;
  for (MeshPath& path : g.partition.paths)
    for (Curve& c : path.curves) {
      if (path.fromPoint == 1) c.from.x() += 3;
      if (path.toPoint == 1) c.to.x() += 3;
    }
  const CellMapping third = mapCells(*g.scene, g.partition, FineMapOptions{}, JobControl{}, &cache);
  EXPECT_EQ(third.cellsMapped, 1);
  EXPECT_EQ(third.cellsReused, 1);
  const CellMapping fresh = mapCells(*g.scene, g.partition, FineMapOptions{}, JobControl{});
  EXPECT_TRUE(third.map.cornerUV == fresh.map.cornerUV);
  EXPECT_FALSE(third.map.cornerUV == first.map.cornerUV);
}

TEST(FineMap, HonoursCancel) {
  GridCase g(makePhoto(340, 340));
  std::atomic<bool> cancel{true};
  EXPECT_THROW(mapCells(*g.scene, g.partition, FineMapOptions{}, JobControl(&cancel, {})), Cancelled);
}

// The Spot cow seen by one synthetic camera, its feature clicks at their true projections.
struct SpotCase {
  std::shared_ptr<Scene> scene;
  Camera camera;
};

SpotCase makeSpot(const std::string& obj) {
  SpotCase c;
  c.scene = std::make_shared<Scene>();
  std::shared_ptr<const Mesh> mesh = requireUsable(loadMesh(obj));
  c.scene->mesh = mesh;
  SynthOptions options;
  options.views = 1;
  options.features = 150;
  options.size = 768;
  const SynthScene synth = synthesize(*mesh, obj, meshPattern(*mesh), options);
  const std::string dir = test::tempDir("fine_map_spot");
  writeSynthScene(synth, dir);
  c.scene->project = synth.project;
  c.scene->photos.push_back(std::make_shared<Photo>(loadPhoto(dir + "/photo_0.png")));
  c.camera = synth.cameras[0];
  return c;
}

// Errors of the mapped vertices' UVs against the true projection (sorted) and the map's stretch.
struct SpotFigures {
  std::vector<double> errors;
  double maxGamma = 0, meanGamma = 0;
  double median() const { return errors.empty() ? 0 : errors[errors.size() / 2]; }
  double p90() const { return errors.empty() ? 0 : errors[errors.size() * 9 / 10]; }
};

SpotFigures spotFigures(const SpotCase& spot, const Mesh& mesh, const TextureMap& map) {
  SpotFigures s;
  for (const auto& [key, uv] : vertexUVs(mesh, map)) {
    Vec2 truth;
    if (spot.camera.project(mesh.position(key.first), truth)) s.errors.push_back((uv - truth).norm());
  }
  std::sort(s.errors.begin(), s.errors.end());
  mapStretch(mesh, map, s.maxGamma, s.meanGamma);
  return s;
}

TEST(FineMap, SpotFromOneView) {
  TM_REQUIRE_SHARED(obj, "meshes/spot/spot_triangulated.obj");
  const SpotCase spot = makeSpot(obj);
  const Scene& scene = *spot.scene;
  const JobControl job;
  const Partition partition = partitionMesh(scene, PartitionOptions{}, job);
  const Mesh& mesh = partition.mesh;

  const auto start = Clock::now();
  const CellMapping cm = mapCells(scene, partition, FineMapOptions{}, job);
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  const TextureMap& map = cm.map;
  std::printf(
      "spot: %zu points, %zu paths, %d cells (%d mapped); %d splits in %.3f s; %d centroid fallbacks, %d "
      "base inner vertices, %d optimised vertices\n",
      scene.project.points.size(), partition.paths.size(), partition.numCells, countStatus(cm, CellStatus::Mapped),
      cm.stats.splits, seconds, cm.stats.centroidFallbacks, cm.stats.baseInnerVertices, cm.stats.optimisedVertices);
  for (const std::string& note : map.notes) std::printf("  note: %s\n", note.c_str());
  EXPECT_EQ(countStatus(cm, CellStatus::Failed), 0);  // real partitions never give a cell that cannot be embedded

  // Mapped share of the visible side (by area; faces seen by the camera, via the input face).
  const RasterBuffers raster = rasterize(*scene.mesh, spot.camera);
  std::set<int> visible(raster.face.begin(), raster.face.end());
  visible.erase(-1);
  double visibleArea = 0, mappedArea = 0;
  for (int f : visible) visibleArea += scene.mesh->faceArea(f);
  for (int f = 0; f < mesh.numFaces(); ++f)
    if (map.facePhoto[f] != TextureMap::kEmpty) mappedArea += mesh.faceArea(f);
  EXPECT_GT(mappedArea, 0.3 * visibleArea);

  EXPECT_EQ(countFlips(map), 0);
  EXPECT_EQ(cm.stats.flippedFaces, 0);
  bool consistent = false;
  const auto uvs = vertexUVs(mesh, map, &consistent);
  EXPECT_TRUE(consistent);
  const Photo& photo = *scene.photos[0];
  int onBackground = 0;
  for (const auto& [key, uv] : uvs) onBackground += !photo.isForeground(uv.x(), uv.y());
  EXPECT_EQ(onBackground, 0);
  int featuresChecked = 0;
  for (size_t i = 0; i < scene.project.points.size(); ++i) {
    const int v = partition.featureVertex[i];
    for (const PhotoPoint& at : scene.project.points[i].at) {
      auto it = uvs.find({v, at.photo});
      if (it == uvs.end()) continue;
      EXPECT_EQ(it->second.x(), at.x);
      EXPECT_EQ(it->second.y(), at.y);
      ++featuresChecked;
    }
  }
  EXPECT_GT(featuresChecked, 3);
  const SpotFigures fig = spotFigures(spot, mesh, map);
  ASSERT_FALSE(fig.errors.empty());
  const cv::Rect silhouette = cv::boundingRect(cv::Mat(photo.alpha > 0));
  std::printf(
      "spot: mapped %.1f%% of the visible area; %zu mapped vertices, error vs projection: median %.2f px, "
      "90%% %.2f px, max %.2f px (silhouette %dx%d px); stretch max %.5f mean %.5f\n",
      100 * mappedArea / visibleArea, fig.errors.size(), fig.median(), fig.p90(), fig.errors.back(), silhouette.width,
      silhouette.height, fig.maxGamma, fig.meanGamma);
  // Sander's stretch is not minimal at the projection (foreshortened parts get more texture space),
  // so the optimised map departs from it between the features: a few percent of the object's size.
  EXPECT_LT(fig.median(), 20.0);

  // Without the final sweeps, and with the stored barycentric coordinates only (no line search).
  auto rerun = [&](const FineMapOptions& options, const char* what) {
    const auto t0 = Clock::now();
    const CellMapping m = mapCells(scene, partition, options, job);
    const double sec = std::chrono::duration<double>(Clock::now() - t0).count();
    const SpotFigures f = spotFigures(spot, mesh, m.map);
    std::printf("spot %s: %.3f s, %d flips, stretch max %.5f mean %.5f, error median %.2f px, 90%% %.2f px\n", what,
                sec, countFlips(m.map), f.maxGamma, f.meanGamma, f.median(), f.p90());
    EXPECT_EQ(countFlips(m.map), 0) << what;
    return f;
  };
  FineMapOptions noSweeps;
  noSweeps.finalSweeps = 0;
  const SpotFigures withoutSweeps = rerun(noSweeps, "without final sweeps");
  EXPECT_LE(fig.maxGamma, withoutSweeps.maxGamma * (1 + 1e-9));  // sweeps only accept improvements of the local max
  FineMapOptions storedOnly;
  storedOnly.lineSearches = 0;
  storedOnly.finalSweeps = 0;
  const SpotFigures stored = rerun(storedOnly, "stored coordinates only");
  EXPECT_GT(stored.maxGamma, fig.maxGamma);  // the line searches lower the stretch
}

}  // namespace
}  // namespace montage
