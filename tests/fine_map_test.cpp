// Tests of the coarse map and the coarse-to-fine map construction (core/fine_map.h, paper sections
// 3.2 and 4.1): a hand-built flat grid whose true map is affine (exact answer known), the same with
// a background stripe across it, and the Spot cow seen by a synthetic camera (needs ../shared/data).
#include "fine_map.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <set>

#include <opencv2/imgproc.hpp>

#include "mesh.h"
#include "partition.h"
#include "photo.h"
#include "pipeline.h"
#include "raster.h"
#include "simplify.h"
#include "stretch.h"
#include "synth.h"
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
    for (int k = 0; k < 3; ++k) edgeFaces[{std::min(c[k], c[(k + 1) % 3]), std::max(c[k], c[(k + 1) % 3])}].push_back(f);
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
  photo->luv = cv::Mat(height, width, CV_32FC3, cv::Scalar(50, 0, 0));
  photo->alpha = cv::Mat(height, width, CV_32FC1, cv::Scalar(1));
  for (int r = std::max(0, stripeFrom); r < std::min(height, stripeTo); ++r) photo->alpha.row(r).setTo(0);
  const cv::Mat background = photo->alpha <= 0;
  cv::distanceTransform(background, photo->distance, cv::DIST_L2, cv::DIST_MASK_PRECISE, CV_32F);
  photo->hasBackground = stripeTo > stripeFrom;
  return photo;
}

// A flat n x n grid in z = 0 (unit spacing, vertex i + n j at (i, j)), CCW seen from +z, cut by the
// four sides of the square [lo, hi]^2 and its diagonal into two triangular cells and the outside.
// The camera looks from +z: pixel = (s x + a, -s y + b).
struct GridCase {
  static constexpr int n = 31, lo = 5, hi = 25;
  static constexpr double s = 10, a = 20, b = 320;
  std::shared_ptr<Scene> scene;
  Partition partition;

  static Vec2 pixel(const Vec3& p) { return Vec2(s * p.x() + a, -s * p.y() + b); }
  static int id(int i, int j) { return i + n * j; }

  explicit GridCase(std::shared_ptr<Photo> photo) {
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
    scene->photos.push_back(photo);
    scene->project.photos.push_back(PhotoRef{"grid.png", ""});

    const int corners[4] = {id(lo, lo), id(hi, lo), id(hi, hi), id(lo, hi)};
    for (int v : corners) {
      const Vec2 px = pixel(vertices[v]);
      scene->project.points.push_back(FeaturePoint{v, {PhotoPoint{0, px.x(), px.y()}}});
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
      path.curves.push_back(Curve{0, pixel(vertices[corners[from]]), pixel(vertices[corners[to]])});
      path.fromChain = true;
      path.length = (vertices[corners[to]] - vertices[corners[from]]).norm();
      partition.paths.push_back(path);
    };
    addPath(0, 1, 1, 0);
    addPath(1, 2, 0, 1);
    addPath(2, 3, -1, 0);
    addPath(3, 0, 0, -1);
    addPath(0, 2, 1, 1);  // along the triangulation's diagonals
    partition.faceParent.resize(partition.mesh.numFaces());
    for (int f = 0; f < partition.mesh.numFaces(); ++f) partition.faceParent[f] = f;
    partition.faceCell = floodCells(partition.mesh, partition.paths, partition.numCells);
  }

  bool insideSquare(const Vec3& p) const { return p.x() > lo && p.x() < hi && p.y() > lo && p.y() < hi; }
  bool onSquare(const Vec3& p) const { return p.x() >= lo && p.x() <= hi && p.y() >= lo && p.y() <= hi; }
};

// Checks shared by the grid tests: the square's two cells are mapped and nothing else; no flip;
// feature vertices bit-exact at their clicks; one UV per vertex.
void checkGridMap(const GridCase& g, const TextureMap& map, const FineMapStats& stats) {
  const Mesh& mesh = g.partition.mesh;
  ASSERT_EQ(map.numFaces(), mesh.numFaces());
  EXPECT_EQ(g.partition.numCells, 3);
  EXPECT_EQ(stats.baseMappedFaces, 2);
  for (int f = 0; f < mesh.numFaces(); ++f) {
    const Vec3 centre = (mesh.facePositions(f)[0] + mesh.facePositions(f)[1] + mesh.facePositions(f)[2]) / 3;
    EXPECT_EQ(map.facePhoto[f], g.insideSquare(centre) ? 0 : TextureMap::kEmpty) << "face " << f;
    EXPECT_EQ(map.facePatch[f], g.partition.faceCell[f]);
  }
  EXPECT_FALSE(map.notes.empty());  // the outside's base faces have non-feature vertices
  EXPECT_EQ(countFlips(map), 0);
  EXPECT_EQ(stats.flippedFaces, 0);
  bool consistent = false;
  const auto uvs = vertexUVs(mesh, map, &consistent);
  EXPECT_TRUE(consistent);
  for (const FeaturePoint& fp : g.scene->project.points) {
    auto it = uvs.find({fp.vertex, 0});
    ASSERT_NE(it, uvs.end());
    EXPECT_EQ(it->second.x(), fp.at[0].x);  // bit-identical
    EXPECT_EQ(it->second.y(), fp.at[0].y);
  }
}

TEST(FineMap, FlatGridReproducesTheAffineMap) {
  GridCase g(makePhoto(340, 340));
  const JobControl job;
  ProgressiveMesh pm(g.partition, SimplifyOptions{}, job);
  ASSERT_TRUE(pm.atBase());
  FineMapStats stats;
  const TextureMap map = coarseToFine(*g.scene, g.partition, pm, FineMapOptions{}, job, &stats);
  EXPECT_TRUE(pm.atFull());
  checkGridMap(g, map, stats);
  for (const std::string& note : map.notes) std::printf("  note: %s\n", note.c_str());

  // The true map is a similarity: the L-infinity stretch optimum is that map (gamma = 1/s).
  const Mesh& mesh = g.partition.mesh;
  double maxError = 0;
  int checked = 0;
  for (const auto& [key, uv] : vertexUVs(mesh, map)) {
    const Vec3 p = mesh.position(key.first);
    EXPECT_TRUE(g.onSquare(p));
    maxError = std::max(maxError, (uv - GridCase::pixel(p)).norm());
    ++checked;
  }
  EXPECT_EQ(checked, (GridCase::hi - GridCase::lo + 1) * (GridCase::hi - GridCase::lo + 1));
  EXPECT_LT(maxError, 0.05) << "px";
  double maxGamma = 0, meanGamma = 0;
  mapStretch(mesh, map, maxGamma, meanGamma);
  EXPECT_NEAR(maxGamma, 1 / GridCase::s, 0.01 / GridCase::s);
  EXPECT_NEAR(stats.maxStretch, maxGamma, 1e-9);
  std::printf("grid: %d splits, %d centroid fallbacks, max uv error %.3g px, stretch max %.6f mean %.6f (ideal %.6f)\n",
              stats.splits, stats.centroidFallbacks, maxError, maxGamma, meanGamma, 1 / GridCase::s);
}

TEST(FineMap, FlatGridAvoidsABackgroundStripe) {
  // Rows 178..182 are background: the ideal images of the grid row y = 14 (pixel y = 180) lie on it.
  GridCase g(makePhoto(340, 340, 178, 183));
  const JobControl job;
  ProgressiveMesh pm(g.partition, SimplifyOptions{}, job);
  FineMapStats stats;
  FineMapOptions fo; if (getenv("SWEEPS")) fo.finalSweeps = atoi(getenv("SWEEPS"));
  if (getenv("LS")) fo.lineSearches = atoi(getenv("LS"));
  const TextureMap map = coarseToFine(*g.scene, g.partition, pm, fo, job, &stats);
  checkGridMap(g, map, stats);
  const Photo& photo = *g.scene->photos[0];
  int idealOnBackground = 0, onBackground = 0;
  for (const auto& [key, uv] : vertexUVs(g.partition.mesh, map)) {
    const Vec2 ideal = GridCase::pixel(g.partition.mesh.position(key.first));
    idealOnBackground += !photo.isForeground(ideal.x(), ideal.y());
    onBackground += !photo.isForeground(uv.x(), uv.y());
  }
  EXPECT_GT(idealOnBackground, 10);  // the test means something
  EXPECT_EQ(onBackground, 0);
  double maxGamma = 0, meanGamma = 0;
  mapStretch(g.partition.mesh, map, maxGamma, meanGamma);
  std::printf("stripe: %d vertices would lie on the stripe, %d do; stretch max %.4f mean %.4f; %d fallbacks\n",
              idealOnBackground, onBackground, maxGamma, meanGamma, stats.centroidFallbacks);
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

  {
    std::set<std::pair<int,int>> edges;
    for (int f = 0; f < mesh.numFaces(); ++f) { auto c = mesh.faceVertices(f); for (int k = 0; k < 3; ++k) edges.emplace(std::min(c[k], c[(k+1)%3]), std::max(c[k], c[(k+1)%3])); }
    int shortcuts = 0;
    for (size_t pi = 0; pi < partition.paths.size(); ++pi) {
      const auto& pv = partition.paths[pi].vertices;
      for (size_t i = 0; i < pv.size(); ++i) for (size_t j = i + 2; j < pv.size(); ++j)
        if (edges.count({std::min(pv[i], pv[j]), std::max(pv[i], pv[j])})) { ++shortcuts; std::printf("DIAG shortcut path %zu (chain %d, n %zu, steiner?) %zu-%zu v %d %d\n", pi, partition.paths[pi].fromChain, pv.size(), i, j, pv[i], pv[j]); }
    }
    std::printf("DIAG shortcuts %d, steiner %d\n", shortcuts, partition.steinerVertices);
  }
  FineMapStats stats;
  auto start = Clock::now();
  const TextureMap map = coarseToFine(scene, partition, pm, FineMapOptions{}, job, &stats);
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  std::printf("spot: %zu points, %zu paths, %d cells, %d base faces, %d mapped; %d splits in %.3f s; "
              "%d centroid fallbacks, %d optimised vertices\n",
              scene.project.points.size(), partition.paths.size(), partition.numCells, stats.baseFaces,
              stats.baseMappedFaces, stats.splits, seconds, stats.centroidFallbacks, stats.optimisedVertices);
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
  std::printf("spot: mapped %.1f%% of the visible area; %zu mapped vertices, error vs projection: median %.2f px, "
              "90%% %.2f px, max %.2f px; stretch max %.5f mean %.5f\n",
              100 * mappedArea / visibleArea, errors.size(), median, p90, errors.back(), maxGamma, meanGamma);
  EXPECT_LT(median, 3.0);

  {
    // DIAG: error split by boundary vs interior, and pure barycentric placement, and projection stretch.
    std::vector<char> boundary(mesh.numVertices(), 0);
    for (int f = 0; f < mesh.numFaces(); ++f)
      for (int v : mesh.faceVertices(f)) (void)v;
    std::map<int, std::set<int>> cellsOf;
    for (int f = 0; f < mesh.numFaces(); ++f)
      for (int v : mesh.faceVertices(f)) cellsOf[v].insert(map.facePhoto[f] == TextureMap::kEmpty ? -1 : partition.faceCell[f]);
    std::vector<double> eb, ei;
    for (const auto& [key, uv] : uvs) {
      Vec2 t; spot.camera.project(mesh.position(key.first), t);
      (cellsOf[key.first].size() > 1 ? eb : ei).push_back((uv - t).norm());
    }
    std::sort(eb.begin(), eb.end()); std::sort(ei.begin(), ei.end());
    if (!eb.empty() && !ei.empty()) std::printf("DIAG boundary median %.2f (%zu), interior median %.2f (%zu)\n", eb[eb.size()/2], eb.size(), ei[ei.size()/2], ei.size());
    {
      std::vector<Vec3> nrm(mesh.numVertices(), Vec3::Zero());
      for (int f = 0; f < mesh.numFaces(); ++f) for (int v : mesh.faceVertices(f)) nrm[v] += mesh.faceNormal(f) * mesh.faceArea(f);
      std::vector<double> ef, eo;
      for (const auto& [key, uv] : uvs) {
        const Vec3 p = mesh.position(key.first);
        const double c = nrm[key.first].normalized().dot((spot.camera.center() - p).normalized());
        Vec2 t; spot.camera.project(p, t);
        (c > 0.7 ? ef : eo).push_back((uv - t).norm());
      }
      std::sort(ef.begin(), ef.end()); std::sort(eo.begin(), eo.end());
      if (!ef.empty() && !eo.empty()) std::printf("DIAG frontal(cos>0.7) median %.2f (%zu), oblique median %.2f (%zu)\n", ef[ef.size()/2], ef.size(), eo[eo.size()/2], eo.size());
      int backMapped = 0, mapped = 0;
      for (int f = 0; f < mesh.numFaces(); ++f) if (map.facePhoto[f] != TextureMap::kEmpty) { ++mapped; const Vec3 c = (mesh.facePositions(f)[0]+mesh.facePositions(f)[1]+mesh.facePositions(f)[2])/3; backMapped += mesh.faceNormal(f).dot(spot.camera.center() - c) <= 0; }
      std::printf("DIAG mapped faces %d, back-facing %d\n", mapped, backMapped);
    }
    double pmax = 0, pmean = 0; int n = 0;
    for (int f = 0; f < mesh.numFaces(); ++f) {
      if (map.facePhoto[f] == TextureMap::kEmpty) continue;
      std::array<Vec2, 3> uv; auto c = mesh.faceVertices(f);
      for (int k = 0; k < 3; ++k) { Vec2 t; spot.camera.project(mesh.position(c[k]), t); uv[k] = Vec2(t.x(), -t.y()); }
      auto st = triangleStretch(mesh.facePositions(f), uv);
      pmax = std::max(pmax, st.gamma); pmean += st.gamma; ++n;
    }
    std::printf("DIAG projection stretch max %.5f mean %.5f\n", pmax, pmean / n);
    while (!pm.atBase()) pm.collapse();
    FineMapOptions none; none.lineSearches = 0; none.finalSweeps = 0;
    FineMapStats st;
    const TextureMap m2 = coarseToFine(scene, partition, pm, none, job, &st);
    std::vector<double> e2;
    for (const auto& [key, uv] : vertexUVs(mesh, m2)) { Vec2 t; spot.camera.project(mesh.position(key.first), t); e2.push_back((uv - t).norm()); }
    std::sort(e2.begin(), e2.end());
    double mg, mm; mapStretch(mesh, m2, mg, mm);
    std::printf("DIAG barycentric only: median %.2f px, flips %d, stretch max %.5f mean %.5f\n", e2[e2.size()/2], countFlips(m2), mg, mm);
  }
  // The final sweeps: same run without them, from the base level again.
  while (!pm.atBase()) pm.collapse();
  FineMapOptions noSweeps;
  noSweeps.finalSweeps = 0;
  FineMapStats stats0;
  start = Clock::now();
  const TextureMap map0 = coarseToFine(scene, partition, pm, noSweeps, job, &stats0);
  const double seconds0 = std::chrono::duration<double>(Clock::now() - start).count();
  double maxGamma0 = 0, meanGamma0 = 0;
  mapStretch(mesh, map0, maxGamma0, meanGamma0);
  std::vector<double> errors0;
  for (const auto& [key, uv] : vertexUVs(mesh, map0)) {
    Vec2 truth;
    spot.camera.project(mesh.position(key.first), truth);
    errors0.push_back((uv - truth).norm());
  }
  std::sort(errors0.begin(), errors0.end());
  std::printf("spot without final sweeps: %.3f s, stretch max %.5f mean %.5f, median error %.2f px\n", seconds0,
              maxGamma0, meanGamma0, errors0.empty() ? 0.0 : errors0[errors0.size() / 2]);
  EXPECT_EQ(countFlips(map0), 0);
  EXPECT_LE(maxGamma, maxGamma0 * (1 + 1e-9));  // sweeps only accept improvements of the local max
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
