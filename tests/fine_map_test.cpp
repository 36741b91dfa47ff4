// Tests of the coarse map and the coarse-to-fine map construction (core/fine_map.h, paper sections
// 3.2 and 4.1). A hand-built flat grid whose true map is a similarity (exact answer known): one
// photo, a background stripe across it, two photos meeting on a path (category-3 vertices), the
// choice of the most frontal photo, a mirrored view. Then the Spot cow seen by a synthetic camera,
// compared with the true projection (needs ../shared/data), with timings.
#include "io/mesh_io.h"
#include "mapping/fine_map.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <opencv2/imgproc.hpp>
#include <set>

#include "geometry/mesh.h"
#include "mapping/partition.h"
#include "image/photo.h"
#include "pipeline.h"
#include "geometry/raster.h"
#include "mapping/simplify.h"
#include "geometry/stretch.h"
#include "bench/synth.h"
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

  GridCase(std::vector<std::shared_ptr<Photo>> photos, std::vector<View> photoViews,
           std::vector<std::vector<int>> pathPhotos = {})
      : views(std::move(photoViews)) {
    std::vector<Vec3> vertices;
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) vertices.emplace_back(i, j, 0);
    std::vector<std::array<int, 3>> triangles;
    for (int j = 0; j + 1 < n; ++j)
      for (int i = 0; i + 1 < n; ++i) {
        triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
        triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
      }
    scene = std::make_shared<Scene>();
    scene->mesh = requireUsable(buildMesh(vertices, triangles));
    partition.mesh = *requireUsable(buildMesh(vertices, triangles));
    for (size_t k = 0; k < photos.size(); ++k) {
      scene->photos.push_back(photos[k]);
      scene->project.photos.push_back(PhotoRef{"grid" + std::to_string(k) + ".png", ""});
    }

    const int corners[4] = {id(lo, lo), id(hi, lo), id(hi, hi), id(lo, hi)};
    for (int v : corners) {
      FeaturePoint point{v, {}};
      for (size_t k = 0; k < views.size(); ++k) {
        const Vec2 px = views[k](vertices[v]);
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
      for (int k : inPhotos)
        path.curves.push_back(Curve{k, views[k](vertices[corners[from]]), views[k](vertices[corners[to]])});
      path.fromChain = true;
      path.length = (vertices[corners[to]] - vertices[corners[from]]).norm();
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
void checkGridMap(const GridCase& g, const TextureMap& map, const FineMapStats& stats, int lower = 0, int upper = 0,
                  double tolerance = 0) {
  const Mesh& mesh = g.partition.mesh;
  ASSERT_EQ(map.numFaces(), mesh.numFaces());
  EXPECT_EQ(g.partition.numCells, 3);
  EXPECT_EQ(stats.baseMappedFaces, 2);
  for (int f = 0; f < mesh.numFaces(); ++f) {
    const Vec3 c = GridCase::centroid(mesh, f);
    const int expected = !GridCase::insideSquare(c) ? TextureMap::kEmpty : c.y() < c.x() ? lower : upper;
    EXPECT_EQ(map.facePhoto[f], expected) << "face " << f;
    EXPECT_EQ(map.facePatch[f], g.partition.faceCell[f]);
  }
  EXPECT_FALSE(map.notes.empty());  // the outside's base faces have non-feature vertices
  EXPECT_EQ(countFlips(map), 0);
  EXPECT_EQ(stats.flippedFaces, 0);
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

TEST(FineMap, FlatGridReproducesTheAffineMap) {
  GridCase g(makePhoto(340, 340));
  const JobControl job;
  ProgressiveMesh pm(g.partition, SimplifyOptions{}, job);
  ASSERT_TRUE(pm.atBase());
  FineMapStats stats;
  const TextureMap map = coarseToFine(*g.scene, g.partition, pm, FineMapOptions{}, job, &stats);
  EXPECT_TRUE(pm.atFull());
  EXPECT_EQ(stats.splits, static_cast<int>(pm.records().size()));
  // The true map is a similarity: the L-infinity stretch optimum is that map (gamma = 1/s).
  checkGridMap(g, map, stats, 0, 0, 0.05);
  for (const std::string& note : map.notes) std::printf("  note: %s\n", note.c_str());
  const Mesh& mesh = g.partition.mesh;
  double maxError = 0;
  for (const auto& [key, uv] : vertexUVs(mesh, map))
    maxError = std::max(maxError, (uv - g.views[0](mesh.position(key.first))).norm());
  double maxGamma = 0, meanGamma = 0;
  mapStretch(mesh, map, maxGamma, meanGamma);
  const double ideal = 1 / g.views[0].s;
  EXPECT_NEAR(maxGamma, ideal, 0.01 * ideal);
  EXPECT_NEAR(stats.maxStretch, maxGamma, 1e-9);
  std::printf("grid: %d splits, %d fallbacks, max uv error %.3g px, stretch max %.6f mean %.6f (ideal %.6f)\n",
              stats.splits, stats.centroidFallbacks, maxError, maxGamma, meanGamma, ideal);
}

TEST(FineMap, FlatGridAvoidsABackgroundStripe) {
  // Rows 178..182 are background: the ideal images of the grid row y = 14 (pixel y = 180) lie on it.
  GridCase g(makePhoto(340, 340, 178, 183));
  const JobControl job;
  ProgressiveMesh pm(g.partition, SimplifyOptions{}, job);
  FineMapStats stats;
  const TextureMap map = coarseToFine(*g.scene, g.partition, pm, FineMapOptions{}, job, &stats);
  checkGridMap(g, map, stats);
  const Photo& photo = *g.scene->photos[0];
  int idealOnBackground = 0, onBackground = 0;
  for (const auto& [key, uv] : vertexUVs(g.partition.mesh, map)) {
    const Vec2 ideal = g.views[0](g.partition.mesh.position(key.first));
    idealOnBackground += !photo.isForeground(ideal.x(), ideal.y());
    onBackground += !photo.isForeground(uv.x(), uv.y());
  }
  EXPECT_GT(idealOnBackground, 10);  // the test means something
  EXPECT_EQ(onBackground, 0);
  double maxGamma = 0, meanGamma = 0;
  mapStretch(g.partition.mesh, map, maxGamma, meanGamma);
  EXPECT_LT(maxGamma, 1.5 / g.views[0].s);  // the detour costs some stretch, not a collapse
  std::printf(
      "stripe: %d vertices would lie on the stripe, %d do; stretch max %.4f mean %.4f (ideal %.4f); "
      "%d fallbacks\n",
      idealOnBackground, onBackground, maxGamma, meanGamma, 1 / g.views[0].s, stats.centroidFallbacks);
}

TEST(FineMap, TwoPhotosMeetOnTheDiagonal) {
  // The lower cell's paths have curves in photo 1 only, the upper cell's in photo 0 only; the
  // diagonal in both: its vertices get one UV per photo (section 4.1, third category).
  const std::vector<View> views = {View{10, 20, 320}, View{8, 40, 280}};
  const std::vector<std::vector<int>> pathPhotos = {{1}, {1}, {0}, {0}, {0, 1}};
  int calls = 0, offDiagonal = 0;
  auto run = [&](const BoundaryEnergy& boundary, FineMapStats& stats) {
    GridCase g({makePhoto(340, 340), makePhoto(300, 300)}, views, pathPhotos);
    const JobControl job;
    ProgressiveMesh pm(g.partition, SimplifyOptions{}, job);
    TextureMap map = coarseToFine(*g.scene, g.partition, pm, FineMapOptions{}, job, &stats, boundary);
    checkGridMap(g, map, stats, 1, 0, 0.05);
    return map;
  };
  FineMapStats plainStats, hookedStats;
  const TextureMap plain = run({}, plainStats);
  // A boundary energy that returns the geometric stretch: called for diagonal vertices only, same map.
  const TextureMap hooked = run(
      [&](int v, int photo, const Vec2& uv, double gamma) {
        ++calls;
        if (v % GridCase::n != v / GridCase::n) ++offDiagonal;
        return gamma;
      },
      hookedStats);
  EXPECT_GT(calls, 0);
  EXPECT_EQ(offDiagonal, 0);
  EXPECT_EQ(plain.facePhoto, hooked.facePhoto);
  EXPECT_TRUE(plain.cornerUV == hooked.cornerUV);
}

TEST(FineMap, ChoosesTheMostFrontalPhoto) {
  // Every path has a curve in both photos; photo 1 sees the square larger (smaller stretch).
  GridCase g({makePhoto(340, 340), makePhoto(360, 360)}, {View{10, 20, 320}, View{12, 0, 360}});
  const JobControl job;
  ProgressiveMesh pm(g.partition, SimplifyOptions{}, job);
  FineMapStats stats;
  const TextureMap map = coarseToFine(*g.scene, g.partition, pm, FineMapOptions{}, job, &stats);
  checkGridMap(g, map, stats, 1, 1, 0.05);
}

TEST(FineMap, MirroredPhotoIsNotUsed) {
  // A camera behind the plane sees the faces clockwise: the texture triangles are flipped.
  View mirrored{10, 320, 320, true};
  GridCase g(makePhoto(340, 340), mirrored);
  const JobControl job;
  ProgressiveMesh pm(g.partition, SimplifyOptions{}, job);
  FineMapStats stats;
  const TextureMap map = coarseToFine(*g.scene, g.partition, pm, FineMapOptions{}, job, &stats);
  EXPECT_EQ(map.numMapped(), 0);
  EXPECT_EQ(stats.baseMappedFaces, 0);
  bool noted = false;
  for (const std::string& note : map.notes) noted |= note.find("2 base faces have no common photo") == 0;
  EXPECT_TRUE(noted);
}

TEST(FineMap, PathWithAnEarDoesNotFlip) {
  // The bottom path detours (10,5) -> (10,4) -> (11,5): the face (10,4) (11,5) (10,5) has its three
  // corners on one path, hence on one straight curve. The vertex (10,4) must leave the curve.
  GridCase g(makePhoto(340, 340));
  std::vector<int>& bottom = g.partition.paths[0].vertices;
  const auto at = std::find(bottom.begin(), bottom.end(), GridCase::id(10, 5));
  ASSERT_NE(at, bottom.end());
  bottom.insert(at + 1, GridCase::id(10, 4));
  g.partition.faceCell = floodCells(g.partition.mesh, g.partition.paths, g.partition.numCells);
  const JobControl job;
  ProgressiveMesh pm(g.partition, SimplifyOptions{}, job);
  FineMapStats stats;
  const TextureMap map = coarseToFine(*g.scene, g.partition, pm, FineMapOptions{}, job, &stats);
  EXPECT_EQ(stats.baseMappedFaces, 2);
  const int side = GridCase::hi - GridCase::lo;
  EXPECT_EQ(map.numMapped(), 2 * side * side + 1);  // the square and the ear
  EXPECT_EQ(countFlips(map), 0);
  EXPECT_EQ(stats.flippedFaces, 0);
  const auto uvs = vertexUVs(g.partition.mesh, map);
  for (const FeaturePoint& fp : g.scene->project.points) {
    auto it = uvs.find({fp.vertex, 0});
    ASSERT_NE(it, uvs.end());
    EXPECT_EQ(it->second.x(), fp.at[0].x);
    EXPECT_EQ(it->second.y(), fp.at[0].y);
  }
  std::printf("ear: %d fallbacks, stretch max %.4f\n", stats.centroidFallbacks, stats.maxStretch);
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
  Vec3 lo, hi;
  mesh->bounds(lo, hi);
  const double scale = (hi - lo).norm() / 4;
  SynthOptions options;
  options.views = 1;
  options.features = 150;
  options.size = 768;
  const SynthScene synth = synthesize(
      *mesh, obj,
      [&](int f, const Vec3& b) {
        const auto q = mesh->facePositions(f);
        return solidPattern(b.x() * q[0] + b.y() * q[1] + b.z() * q[2], scale);
      },
      options);
  const std::string dir = test::tempDir("fine_map_spot");
  writeSynthScene(synth, dir);
  c.scene->project = synth.project;
  c.scene->photos.push_back(std::make_shared<Photo>(loadPhoto(dir + "/photo_0.png")));
  c.camera = synth.cameras[0];
  return c;
}

TEST(FineMap, SpotFromOneView) {
  TM_REQUIRE_SHARED(obj, "meshes/spot/spot_triangulated.obj");
  const SpotCase spot = makeSpot(obj);
  const Scene& scene = *spot.scene;
  const JobControl job;
  const Partition partition = partitionMesh(scene, PartitionOptions{}, job);
  ProgressiveMesh pm(partition, SimplifyOptions{}, job);
  ASSERT_TRUE(pm.atBase());
  const Mesh& mesh = partition.mesh;

  FineMapStats stats;
  auto start = Clock::now();
  const TextureMap map = coarseToFine(scene, partition, pm, FineMapOptions{}, job, &stats);
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  std::printf(
      "spot: %zu points, %zu paths, %d cells, %d base faces, %d mapped; %d splits in %.3f s; "
      "%d centroid fallbacks, %d optimised vertices\n",
      scene.project.points.size(), partition.paths.size(), partition.numCells, stats.baseFaces, stats.baseMappedFaces,
      stats.splits, seconds, stats.centroidFallbacks, stats.optimisedVertices);
  for (const std::string& note : map.notes) std::printf("  note: %s\n", note.c_str());

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
  EXPECT_EQ(stats.flippedFaces, 0);
  bool consistent = false;
  const auto uvs = vertexUVs(mesh, map, &consistent);
  EXPECT_TRUE(consistent);
  const Photo& photo = *scene.photos[0];
  std::vector<double> errors;
  int onBackground = 0;
  for (const auto& [key, uv] : uvs) {
    onBackground += !photo.isForeground(uv.x(), uv.y());
    Vec2 truth;
    ASSERT_TRUE(spot.camera.project(mesh.position(key.first), truth));
    errors.push_back((uv - truth).norm());
  }
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
  ASSERT_FALSE(errors.empty());
  std::sort(errors.begin(), errors.end());
  const double median = errors[errors.size() / 2], p90 = errors[errors.size() * 9 / 10];
  double maxGamma = 0, meanGamma = 0;
  mapStretch(mesh, map, maxGamma, meanGamma);
  const cv::Rect silhouette = cv::boundingRect(cv::Mat(photo.alpha > 0));
  std::printf(
      "spot: mapped %.1f%% of the visible area; %zu mapped vertices, error vs projection: median %.2f px, "
      "90%% %.2f px, max %.2f px (silhouette %dx%d px); stretch max %.5f mean %.5f\n",
      100 * mappedArea / visibleArea, errors.size(), median, p90, errors.back(), silhouette.width, silhouette.height,
      maxGamma, meanGamma);
  // Sander's stretch is not minimal at the projection (foreshortened parts get more texture space),
  // so the optimised map departs from it between the features: a few percent of the object's size.
  EXPECT_LT(median, 20.0);

  // The same from the base level again: without the final sweeps, and with the stored barycentric
  // coordinates only (no line search), to see what the optimisation does.
  auto rerun = [&](const FineMapOptions& options, const char* what) {
    while (!pm.atBase()) pm.collapse();
    FineMapStats s;
    const auto t0 = Clock::now();
    const TextureMap m = coarseToFine(scene, partition, pm, options, job, &s);
    const double sec = std::chrono::duration<double>(Clock::now() - t0).count();
    double mx = 0, mean = 0;
    mapStretch(mesh, m, mx, mean);
    std::vector<double> e;
    for (const auto& [key, uv] : vertexUVs(mesh, m)) {
      Vec2 truth;
      spot.camera.project(mesh.position(key.first), truth);
      e.push_back((uv - truth).norm());
    }
    std::sort(e.begin(), e.end());
    std::printf("spot %s: %.3f s, %d flips, stretch max %.5f mean %.5f, error median %.2f px, 90%% %.2f px\n", what,
                sec, countFlips(m), mx, mean, e.empty() ? 0.0 : e[e.size() / 2],
                e.empty() ? 0.0 : e[e.size() * 9 / 10]);
    return mx;
  };
  FineMapOptions noSweeps;
  noSweeps.finalSweeps = 0;
  const double maxGammaNoSweeps = rerun(noSweeps, "without final sweeps");
  EXPECT_LE(maxGamma, maxGammaNoSweeps * (1 + 1e-9));  // sweeps only accept improvements of the local max
  FineMapOptions storedOnly;
  storedOnly.lineSearches = 0;
  storedOnly.finalSweeps = 0;
  rerun(storedOnly, "stored coordinates only");
}

TEST(FineMap, RejectsAProgressiveMeshNotAtItsBase) {
  GridCase g(makePhoto(340, 340));
  const JobControl job;
  ProgressiveMesh pm(g.partition, SimplifyOptions{}, job);
  ASSERT_FALSE(pm.records().empty());
  pm.split();
  EXPECT_THROW(coarseToFine(*g.scene, g.partition, pm, FineMapOptions{}, job), Error);
}

TEST(FineMap, HonoursCancel) {
  GridCase g(makePhoto(340, 340));
  std::atomic<bool> cancel{true};
  const JobControl job(&cancel, {});
  ProgressiveMesh pm(g.partition, SimplifyOptions{}, JobControl{});
  EXPECT_THROW(coarseToFine(*g.scene, g.partition, pm, FineMapOptions{}, job), Cancelled);
}

}  // namespace
}  // namespace montage
