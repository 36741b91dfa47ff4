// Tests of the mesh/photo partition (paper 3.1): shortest paths, the validity tests of a path-curve
// pair, Steiner vertices, chains, and a realistic run on spot.
#include "io/mesh_io.h"
#include "mapping/partition.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <map>
#include <opencv2/imgproc.hpp>
#include <random>
#include <set>

#include "pipeline.h"
#include "geometry/raster.h"
#include "geometry/shapes.h"
#include "test_support.h"

namespace montage {
namespace {

using VertexHandle = TriMesh::VertexHandle;
using HalfedgeHandle = TriMesh::HalfedgeHandle;

constexpr double kInf = std::numeric_limits<double>::infinity();

std::shared_ptr<Mesh> makeMesh(const std::vector<Vec3>& vertices, const std::vector<std::array<int, 3>>& triangles) {
  return std::shared_ptr<Mesh>(requireUsable(buildMesh(vertices, triangles)));
}

// n x n grid in the plane z = 0 with outward normal +z. Vertex (i, j) = j * n + i lies at (i, -j, 0)
// (plus optional noise in z), so a top view maps it to pixel (i, j) * scale + offset, y down.
struct Grid {
  int n = 0;
  std::shared_ptr<Mesh> mesh;
  int vertex(int i, int j) const { return j * n + i; }
};

Grid makeGrid(int n, double zNoise = 0, unsigned seed = 1) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> noise(-zNoise, zNoise);
  std::vector<Vec3> v;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) v.emplace_back(i, -j, zNoise > 0 ? noise(rng) : 0.0);
  std::vector<std::array<int, 3>> f;
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      const int a = j * n + i, b = a + 1, c = a + n, d = c + 1;
      f.push_back({a, c, d});
      f.push_back({a, d, b});
    }
  return {n, makeMesh(v, f)};
}

// A photo whose foreground is the non-zero pixels of `foreground` (CV_8UC1); all foreground when empty.
Photo makePhoto(int width, int height, const cv::Mat& foreground = {}) {
  Photo photo;
  photo.width = width;
  photo.height = height;
  photo.rgb = cv::Mat::zeros(height, width, CV_32FC3);
  cv::Mat fg = foreground.empty() ? cv::Mat(height, width, CV_8UC1, cv::Scalar(255)) : foreground;
  fg.convertTo(photo.alpha, CV_32FC1, 1.0 / 255);
  cv::threshold(photo.alpha, photo.alpha, 0, 1, cv::THRESH_BINARY);
  photo.hasBackground = cv::countNonZero(fg) < width * height;
  const cv::Mat background = fg == 0;  // distance of each pixel to the nearest foreground (zero) pixel
  cv::distanceTransform(background, photo.distance, cv::DIST_L2, cv::DIST_MASK_PRECISE, CV_32F);
  return photo;
}

Scene makeScene(std::shared_ptr<const Mesh> mesh, std::vector<FeaturePoint> points, std::vector<Photo> photos,
                std::vector<FeatureChain> chains = {}) {
  Scene scene;
  scene.mesh = std::move(mesh);
  scene.project.points = std::move(points);
  scene.project.chains = std::move(chains);
  for (Photo& p : photos) scene.photos.push_back(std::make_shared<const Photo>(std::move(p)));
  return scene;
}

FeaturePoint point(int vertex, double x, double y, int photo = 0) {
  return {vertex, {{photo, x, y}}};
}

int findPath(const Partition& part, int a, int b) {
  for (size_t k = 0; k < part.paths.size(); ++k) {
    const MeshPath& p = part.paths[k];
    if ((p.fromPoint == a && p.toPoint == b) || (p.fromPoint == b && p.toPoint == a)) return int(k);
  }
  return -1;
}

const RejectedPair* findRejection(const Partition& part, int a, int b, RejectReason reason) {
  for (const RejectedPair& r : part.rejected)
    if (((r.fromPoint == a && r.toPoint == b) || (r.fromPoint == b && r.toPoint == a)) && r.reason == reason) return &r;
  return nullptr;
}

std::string describe(const Partition& part) {
  std::string s = std::to_string(part.paths.size()) + " paths:";
  for (const MeshPath& p : part.paths) s += " " + std::to_string(p.fromPoint) + "-" + std::to_string(p.toPoint);
  s += "; rejected:";
  for (const RejectedPair& r : part.rejected)
    s += " " + std::to_string(r.fromPoint) + "-" + std::to_string(r.toPoint) + " (" +
         kRejectReasonNames[int(r.reason)] + ": " + r.detail + ")";
  return s;
}

double lengthOf(const Mesh& mesh, const std::vector<int>& path) {
  double l = 0;
  for (size_t k = 1; k < path.size(); ++k) l += (mesh.position(path[k]) - mesh.position(path[k - 1])).norm();
  return l;
}

// ---- Invariant checks ------------------------------------------------------------------------------

// The partition mesh is a manifold refinement of the input: every edge has one or two faces, every
// vertex one fan, the Euler characteristic is unchanged and each input face is exactly covered.
void expectRefinement(const Partition& part, const Mesh& input) {
  const TriMesh& tri = part.mesh.tri;
  for (auto e : tri.edges())
    EXPECT_FALSE(tri.is_boundary(tri.halfedge_handle(e, 0)) && tri.is_boundary(tri.halfedge_handle(e, 1)))
        << "edge " << e.idx() << " has no face";
  std::vector<int> outgoing(tri.n_vertices(), 0), borders(tri.n_vertices(), 0);
  for (auto h : tri.halfedges()) {
    ++outgoing[tri.from_vertex_handle(h).idx()];
    borders[tri.from_vertex_handle(h).idx()] += tri.is_boundary(h);
  }
  for (auto v : tri.vertices()) {
    int fan = 0;
    const HalfedgeHandle start = tri.halfedge_handle(v);
    if (start.is_valid()) {
      HalfedgeHandle h = start;
      do {
        ++fan;
        h = tri.ccw_rotated_halfedge_handle(h);
      } while (h != start && fan <= outgoing[v.idx()]);
    }
    EXPECT_EQ(fan, outgoing[v.idx()]) << "vertex " << v.idx() << " has more than one fan";
    EXPECT_LE(borders[v.idx()], 1) << "vertex " << v.idx();
  }
  const auto euler = [](const TriMesh& m) { return int(m.n_vertices()) - int(m.n_edges()) + int(m.n_faces()); };
  EXPECT_EQ(euler(tri), euler(input.tri));
  EXPECT_EQ(part.mesh.numVertices(), input.numVertices() + part.steinerVertices);
  for (int v = 0; v < input.numVertices(); ++v) EXPECT_EQ(part.mesh.position(v), input.position(v));

  ASSERT_EQ(int(part.faceParent.size()), part.mesh.numFaces());
  std::vector<double> covered(input.numFaces(), 0);
  for (int f = 0; f < part.mesh.numFaces(); ++f) {
    const int parent = part.faceParent[f];
    ASSERT_TRUE(parent >= 0 && parent < input.numFaces()) << "face " << f;
    covered[parent] += part.mesh.faceArea(f);
    // A child lies in its parent's plane.
    const Vec3 n = input.faceNormal(parent);
    for (const Vec3& p : part.mesh.facePositions(f))
      EXPECT_NEAR(n.dot(p - input.position(input.faceVertices(parent)[0])), 0, 1e-9);
  }
  double total = 0, totalInput = 0;
  for (int f = 0; f < input.numFaces(); ++f) {
    EXPECT_NEAR(covered[f], input.faceArea(f), 1e-9 * input.faceArea(f)) << "input face " << f;
    total += covered[f];
    totalInput += input.faceArea(f);
  }
  EXPECT_NEAR(total, totalInput, 1e-9 * totalInput);
  EXPECT_TRUE(part.mesh.cornerUV.empty());
  if (!input.faceOrigin.empty()) {
    ASSERT_EQ(int(part.mesh.faceOrigin.size()), part.mesh.numFaces());
    for (int f = 0; f < part.mesh.numFaces(); ++f)
      EXPECT_EQ(part.mesh.faceOrigin[f], input.faceOrigin[part.faceParent[f]]);
  }
}

// Paths run along edges between their feature vertices, share no vertex but end points and no edge,
// never pass through a feature vertex, and cells are separated exactly by paths.
void expectValidPaths(const Partition& part, const Scene& scene) {
  const TriMesh& tri = part.mesh.tri;
  std::set<int> features(part.featureVertex.begin(), part.featureVertex.end());
  std::set<int> inner;
  std::set<std::pair<int, int>> edges, pairs;
  for (const MeshPath& p : part.paths) {
    ASSERT_GE(p.vertices.size(), 2u);
    EXPECT_EQ(p.vertices.front(), part.featureVertex[p.fromPoint]);
    EXPECT_EQ(p.vertices.back(), part.featureVertex[p.toPoint]);
    EXPECT_TRUE(pairs.insert(std::minmax(p.fromPoint, p.toPoint)).second) << "pair stored twice";
    EXPECT_NEAR(p.length, lengthOf(part.mesh, p.vertices), 1e-9);
    EXPECT_GE(p.curves.size(), 1u);
    std::set<int> photos;
    for (const Curve& c : p.curves) {
      EXPECT_TRUE(photos.insert(c.photo).second);
      // Some point with the path's first vertex has a position in the curve's photo, at c.from.
      bool found = false;
      for (const FeaturePoint& q : scene.project.points)
        for (const PhotoPoint& at : q.at)
          found = found || (q.vertex == p.vertices.front() && at.photo == c.photo && Vec2(at.x, at.y) == c.from);
      EXPECT_TRUE(found) << "curve of path " << p.fromPoint << "-" << p.toPoint << " in photo " << c.photo;
    }
    for (size_t k = 0; k < p.vertices.size(); ++k) {
      if (k > 0) {
        EXPECT_TRUE(tri.find_halfedge(VertexHandle(p.vertices[k - 1]), VertexHandle(p.vertices[k])).is_valid());
        EXPECT_TRUE(edges.insert(std::minmax(p.vertices[k - 1], p.vertices[k])).second) << "edge shared by paths";
      }
      if (k > 0 && k + 1 < p.vertices.size()) {
        EXPECT_TRUE(inner.insert(p.vertices[k]).second) << "vertex " << p.vertices[k] << " on two paths";
        EXPECT_FALSE(features.count(p.vertices[k])) << "path through feature vertex " << p.vertices[k];
      }
    }
  }
  ASSERT_EQ(int(part.faceCell.size()), part.mesh.numFaces());
  std::set<int> cells(part.faceCell.begin(), part.faceCell.end());
  EXPECT_EQ(int(cells.size()), part.numCells);
  for (auto e : tri.edges()) {
    const auto f0 = tri.face_handle(tri.halfedge_handle(e, 0)), f1 = tri.face_handle(tri.halfedge_handle(e, 1));
    if (!f0.is_valid() || !f1.is_valid()) continue;
    const std::pair<int, int> ends = std::minmax(tri.from_vertex_handle(tri.halfedge_handle(e, 0)).idx(),
                                                 tri.to_vertex_handle(tri.halfedge_handle(e, 0)).idx());
    if (!edges.count(ends)) EXPECT_EQ(part.faceCell[f0.idx()], part.faceCell[f1.idx()]);
  }
}

// Around every feature vertex and in every photo, the accepted pairs keep the photo's cyclic order.
void expectCyclicOrder(const Partition& part) {
  const TriMesh& tri = part.mesh.tri;
  std::map<std::pair<int, int>, std::vector<std::pair<int, double>>> around;  // (vertex, photo) -> (exit, angle)
  for (const MeshPath& p : part.paths)
    for (int end = 0; end < 2; ++end) {
      const int v = end ? p.vertices.back() : p.vertices.front();
      const int next = end ? p.vertices[p.vertices.size() - 2] : p.vertices[1];
      for (const Curve& c : p.curves) {
        const Vec2 d = end ? Vec2(c.from - c.to) : Vec2(c.to - c.from);
        around[{v, c.photo}].emplace_back(next, std::atan2(-d.y(), d.x()));
      }
    }
  for (auto& [key, list] : around) {
    if (list.size() < 3) continue;
    std::vector<int> ring;  // neighbours counter-clockwise
    const HalfedgeHandle start = tri.halfedge_handle(VertexHandle(key.first));
    HalfedgeHandle h = start;
    do {
      ring.push_back(tri.to_vertex_handle(h).idx());
      h = tri.ccw_rotated_halfedge_handle(h);
    } while (h != start);
    std::vector<std::pair<int, int>> byMesh, byImage;  // (rank, id)
    for (size_t k = 0; k < list.size(); ++k) {
      byMesh.emplace_back(int(std::find(ring.begin(), ring.end(), list[k].first) - ring.begin()), int(k));
      byImage.emplace_back(0, int(k));
    }
    std::sort(byMesh.begin(), byMesh.end());
    std::sort(byImage.begin(), byImage.end(),
              [&](const auto& x, const auto& y) { return list[x.second].second < list[y.second].second; });
    std::vector<int> m, i;
    for (auto& x : byMesh) m.push_back(x.second);
    for (auto& x : byImage) i.push_back(x.second);
    std::rotate(m.begin(), std::find(m.begin(), m.end(), 0), m.end());
    std::rotate(i.begin(), std::find(i.begin(), i.end(), 0), i.end());
    EXPECT_EQ(m, i) << "vertex " << key.first << " photo " << key.second;
  }
}

double meanDistance(const Photo& photo, const Vec2& a, const Vec2& b) {
  const int n = int(std::ceil((b - a).norm() / 0.5)) + 1;
  double sum = 0;
  for (int k = 0; k <= n; ++k) {
    const Vec2 q = a + (b - a) * (double(k) / n);
    sum += sampleBilinear1(photo.distance, q.x(), q.y());
  }
  return sum / (n + 1);
}

// ---- shortestPath -----------------------------------------------------------------------------------

// All-pairs shortest path lengths by Floyd-Warshall, with blocked vertices never in between.
std::vector<double> floydWarshall(const Mesh& mesh, const std::vector<char>& blocked) {
  const int n = mesh.numVertices();
  std::vector<double> d(size_t(n) * n, kInf);
  for (int v = 0; v < n; ++v) d[size_t(v) * n + v] = 0;
  for (auto e : mesh.tri.edges()) {
    const int a = mesh.tri.from_vertex_handle(mesh.tri.halfedge_handle(e, 0)).idx();
    const int b = mesh.tri.to_vertex_handle(mesh.tri.halfedge_handle(e, 0)).idx();
    d[size_t(a) * n + b] = d[size_t(b) * n + a] = (mesh.position(a) - mesh.position(b)).norm();
  }
  for (int k = 0; k < n; ++k) {
    if (!blocked.empty() && blocked[k]) continue;
    for (int i = 0; i < n; ++i) {
      const double dik = d[size_t(i) * n + k];
      if (dik == kInf) continue;
      for (int j = 0; j < n; ++j) d[size_t(i) * n + j] = std::min(d[size_t(i) * n + j], dik + d[size_t(k) * n + j]);
    }
  }
  return d;
}

void expectShortestPaths(const Mesh& mesh, const std::vector<char>& blocked, unsigned seed) {
  const int n = mesh.numVertices();
  const std::vector<double> d = floydWarshall(mesh, blocked);
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> pick(0, n - 1);
  int unreachable = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const int a = pick(rng), b = pick(rng);
    const std::vector<int> path = shortestPath(mesh, a, b, blocked);
    const double expected = d[size_t(a) * n + b];
    if (expected == kInf) {
      EXPECT_TRUE(path.empty()) << a << " -> " << b;
      ++unreachable;
      continue;
    }
    ASSERT_FALSE(path.empty()) << a << " -> " << b;
    EXPECT_EQ(path.front(), a);
    EXPECT_EQ(path.back(), b);
    for (size_t k = 1; k < path.size(); ++k) {
      EXPECT_TRUE(mesh.tri.find_halfedge(VertexHandle(path[k - 1]), VertexHandle(path[k])).is_valid());
      if (k + 1 < path.size() && !blocked.empty()) EXPECT_FALSE(blocked[path[k]]) << "through blocked " << path[k];
    }
    EXPECT_NEAR(lengthOf(mesh, path), expected, 1e-9) << a << " -> " << b;
  }
  if (!blocked.empty()) EXPECT_GT(unreachable, 0) << "the blocked set should cut some pairs apart";
}

TEST(ShortestPath, MatchesFloydWarshallOnAGrid) {
  const Grid grid = makeGrid(12, 0.3);
  expectShortestPaths(*grid.mesh, {}, 1);
  // A wall across the grid with one gap, plus a closed ring around vertex (2, 2).
  std::vector<char> blocked(grid.mesh->numVertices(), 0);
  for (int j = 0; j < 11; ++j) blocked[grid.vertex(6, j)] = 1;
  for (int i = 1; i <= 3; ++i)
    for (int j = 1; j <= 3; ++j) blocked[grid.vertex(i, j)] = !(i == 2 && j == 2);
  expectShortestPaths(*grid.mesh, blocked, 2);
  EXPECT_TRUE(shortestPath(*grid.mesh, grid.vertex(2, 2), grid.vertex(8, 8), blocked).empty());
  // End points are allowed even when blocked.
  EXPECT_FALSE(shortestPath(*grid.mesh, grid.vertex(6, 3), grid.vertex(9, 9), blocked).empty());
}

TEST(ShortestPath, MatchesFloydWarshallOnAnIcosphere) {
  const std::shared_ptr<Mesh> sphere = makeIcosphere(3);  // 642 vertices
  expectShortestPaths(*sphere, {}, 3);
  std::vector<char> blocked(sphere->numVertices(), 0);
  for (int v = 0; v < sphere->numVertices(); ++v) blocked[v] = std::abs(sphere->position(v).z()) < 0.12;  // equator
  expectShortestPaths(*sphere, blocked, 4);
  EXPECT_EQ(shortestPath(*sphere, 5, 5), std::vector<int>{5});
  EXPECT_THROW(shortestPath(*sphere, 0, sphere->numVertices()), Error);
}

// ---- Validity tests of a pair -----------------------------------------------------------------------

// Grid points seen from the top: pixel = (i, j) * 10 + 20.
Vec2 topView(int i, int j) {
  return Vec2(20 + 10.0 * i, 20 + 10.0 * j);
}

TEST(Partition, CrossingCurvesAreRejected) {
  const Grid grid = makeGrid(41);
  // On the mesh A-C and B-D are short and far apart; in the photo they form an X.
  const std::vector<FeaturePoint> points = {point(grid.vertex(10, 10), 100, 100),   // A
                                            point(grid.vertex(12, 10), 300, 300),   // C
                                            point(grid.vertex(10, 30), 300, 100),   // B
                                            point(grid.vertex(12, 30), 100, 300)};  // D
  Scene scene = makeScene(grid.mesh, points, {makePhoto(440, 440)});
  const Partition part = partitionMesh(scene, {}, {});
  ASSERT_GE(findPath(part, 0, 1), 0) << describe(part);
  EXPECT_EQ(findPath(part, 2, 3), -1) << describe(part);
  const RejectedPair* r = findRejection(part, 2, 3, RejectReason::CurveCrossesCurve);
  ASSERT_TRUE(r) << describe(part);
  EXPECT_EQ(r->photo, 0);
  EXPECT_NE(r->detail.find("0-1"), std::string::npos) << r->detail;
  // The mesh had room for it.
  std::vector<char> blocked(part.mesh.numVertices(), 0);
  for (int v : part.paths[findPath(part, 0, 1)].vertices) blocked[v] = 1;
  EXPECT_FALSE(shortestPath(part.mesh, grid.vertex(10, 30), grid.vertex(12, 30), blocked).empty());
  expectValidPaths(part, scene);
}

TEST(Partition, CyclicOrderInversionIsRejected) {
  const Grid grid = makeGrid(21);
  // V in the middle with spokes east, north, west on the mesh; the photo shows north mirrored south.
  const std::vector<FeaturePoint> points = {point(grid.vertex(10, 10), topView(10, 10).x(), topView(10, 10).y()),
                                            point(grid.vertex(13, 10), topView(13, 10).x(), topView(13, 10).y()),
                                            point(grid.vertex(10, 7), topView(10, 13).x(), topView(10, 13).y()),
                                            point(grid.vertex(7, 10), topView(7, 10).x(), topView(7, 10).y())};
  Scene scene = makeScene(grid.mesh, points, {makePhoto(240, 240)});
  const Partition part = partitionMesh(scene, {}, {});
  EXPECT_GE(findPath(part, 0, 1), 0) << describe(part);
  EXPECT_GE(findPath(part, 0, 2), 0) << describe(part);
  EXPECT_EQ(findPath(part, 0, 3), -1) << describe(part);
  const RejectedPair* r = findRejection(part, 0, 3, RejectReason::CyclicOrder);
  ASSERT_TRUE(r) << describe(part);
  EXPECT_EQ(r->photo, 0);
  expectValidPaths(part, scene);
  expectCyclicOrder(part);

  // Unmirrored, the same pair is accepted.
  Scene good = scene;
  good.project.points[2] = point(grid.vertex(10, 7), topView(10, 7).x(), topView(10, 7).y());
  const Partition fine = partitionMesh(good, {}, {});
  EXPECT_GE(findPath(fine, 0, 3), 0) << describe(fine);
  expectCyclicOrder(fine);
}

TEST(Partition, PhotosWithAConflictingOrderAreDropped) {
  const Grid grid = makeGrid(21);
  // As above, with two photos: photo 0 shows the true order, photo 1 has B mirrored.
  const auto both = [&](int i, int j, int mirroredJ) {
    return FeaturePoint{
        grid.vertex(i, j),
        {{0, topView(i, j).x(), topView(i, j).y()}, {1, topView(i, mirroredJ).x(), topView(i, mirroredJ).y()}}};
  };
  const std::vector<FeaturePoint> points = {both(10, 10, 10), both(13, 10, 10), both(10, 7, 13), both(7, 10, 10)};
  Scene scene = makeScene(grid.mesh, points, {makePhoto(240, 240), makePhoto(240, 240)});
  const Partition part = partitionMesh(scene, {}, {});
  const int id = findPath(part, 0, 3);
  ASSERT_GE(id, 0) << describe(part);
  ASSERT_EQ(part.paths[id].curves.size(), 1u);
  EXPECT_EQ(part.paths[id].curves[0].photo, 0);
  const RejectedPair* r = findRejection(part, 0, 3, RejectReason::CyclicOrder);
  ASSERT_TRUE(r) << describe(part);
  EXPECT_EQ(r->photo, 1);
  EXPECT_EQ(part.paths[findPath(part, 0, 1)].curves.size(), 2u);
  expectValidPaths(part, scene);
  expectCyclicOrder(part);
}

TEST(Partition, CurvesOverTheBackgroundAreRejected) {
  // A foreground disc of radius 100 px around (200, 200); the grid maps pixel (x, y) to vertex (x/10, y/10).
  cv::Mat disc = cv::Mat::zeros(400, 400, CV_8UC1);
  cv::circle(disc, cv::Point(200, 200), 100, cv::Scalar(255), cv::FILLED);
  const Grid grid = makeGrid(41);
  const auto at = [&](double x, double y) {
    return point(grid.vertex(int(std::lround(x / 10)), int(std::lround(y / 10))), x, y);
  };
  const std::vector<FeaturePoint> points = {
      at(130, 200), at(270, 200),  // 0-1: a chord through the centre
      at(110, 110), at(290, 110),  // 2-3: mostly over the background
      at(160, 295), at(240, 295),  // 4-5: grazes the border, its ends ~3 px outside
  };
  Scene scene = makeScene(grid.mesh, points, {makePhoto(400, 400, disc)});
  const Photo& photo = *scene.photos[0];
  ASSERT_GT(meanDistance(photo, {110, 110}, {290, 110}), 2.0);
  ASSERT_LT(meanDistance(photo, {160, 295}, {240, 295}), 2.0);
  ASSERT_GT(photo.distance.at<float>(295, 160), 1.0f);
  const Partition part = partitionMesh(scene, {}, {});
  EXPECT_GE(findPath(part, 0, 1), 0) << describe(part);
  EXPECT_GE(findPath(part, 4, 5), 0) << describe(part);
  EXPECT_EQ(findPath(part, 2, 3), -1) << describe(part);
  const RejectedPair* r = findRejection(part, 2, 3, RejectReason::CurveOverBackground);
  ASSERT_TRUE(r) << describe(part);
  EXPECT_NE(r->detail.find("mean distance"), std::string::npos) << r->detail;
  for (const MeshPath& p : part.paths)
    for (const Curve& c : p.curves) EXPECT_LE(meanDistance(photo, c.from, c.to), 2.0 + 1e-3);
  // A lower threshold rejects the grazing pair too.
  PartitionOptions strict;
  strict.backgroundThresholdPx = 0.1;
  const Partition strictPart = partitionMesh(scene, strict, {});
  EXPECT_EQ(findPath(strictPart, 4, 5), -1);
  EXPECT_TRUE(findRejection(strictPart, 4, 5, RejectReason::CurveOverBackground)) << describe(strictPart);
}

// ---- Steiner vertices ------------------------------------------------------------------------------

TEST(Partition, SteinerVerticesMakeRoomOnACoarseMesh) {
  // Octahedron with all six vertices as features: T (top), E0..E3 (equator), B (bottom). The photo is
  // a top view of T and the equator with B drawn beyond the T-E0-E1 face; its foreground is the
  // spokes T-Ek and T-B, so only they are valid curves. T-B must leave T between two spokes, where
  // the input mesh has no free vertex: it runs through the Steiner vertex on edge E0-E1.
  const std::vector<Vec3> v = {{0, 0, 1}, {1, 0, 0}, {0, 1, 0}, {-1, 0, 0}, {0, -1, 0}, {0, 0, -1}};
  const std::vector<std::array<int, 3>> f = {{0, 1, 2}, {0, 2, 3}, {0, 3, 4}, {0, 4, 1},
                                             {5, 2, 1}, {5, 3, 2}, {5, 4, 3}, {5, 1, 4}};
  const std::shared_ptr<Mesh> octa = makeMesh(v, f);
  const Vec2 c(200, 200);
  const std::vector<Vec2> px = {
      c, c + Vec2(100, 0), c + Vec2(0, -100), c + Vec2(-100, 0), c + Vec2(0, 100), c + Vec2(141, -141)};
  std::vector<FeaturePoint> points;
  for (int k = 0; k < 6; ++k) points.push_back(point(k, px[k].x(), px[k].y()));
  cv::Mat spokes = cv::Mat::zeros(400, 400, CV_8UC1);
  for (int k = 1; k < 6; ++k)
    cv::line(spokes, cv::Point(int(c.x()), int(c.y())), cv::Point(int(px[k].x()), int(px[k].y())), cv::Scalar(255), 3);
  Scene scene = makeScene(octa, points, {makePhoto(400, 400, spokes)});
  const Partition part = partitionMesh(scene, {}, {});
  for (int k = 1; k < 6; ++k) EXPECT_GE(findPath(part, 0, k), 0) << "T-" << k << ": " << describe(part);
  EXPECT_EQ(part.paths.size(), 5u) << describe(part);
  EXPECT_GT(part.steinerVertices, 0);
  EXPECT_GT(part.paths[findPath(part, 0, 5)].vertices.size(), 2u);
  EXPECT_EQ(part.numCells, 1);  // a tree of paths does not separate the sphere
  expectRefinement(part, *octa);
  expectValidPaths(part, scene);
  expectCyclicOrder(part);

  // With no Steiner budget per path T-B is refused (it would leave bridges next to the spokes).
  PartitionOptions none;
  none.maxSteinerPerPath = 0;
  const Partition stuck = partitionMesh(scene, none, {});
  EXPECT_EQ(findPath(stuck, 0, 5), -1);
  EXPECT_TRUE(findRejection(stuck, 0, 5, RejectReason::NoPath)) << describe(stuck);
}

TEST(Partition, CoarseCubeWithEveryCornerAFeature) {
  // A cube of 12 triangles with features on its 8 corners and one photo per face: an orthographic
  // view from outside showing that face's 4 corners. The face diagonal that is not a mesh edge can
  // only be a path through a Steiner vertex.
  std::vector<Vec3> v;
  for (int k = 0; k < 8; ++k) v.emplace_back(k & 1 ? 1 : -1, k & 2 ? 1 : -1, k & 4 ? 1 : -1);
  const auto corner = [](const Vec3& p) { return (p.x() > 0) + 2 * (p.y() > 0) + 4 * (p.z() > 0); };
  std::vector<std::array<int, 3>> f;
  std::vector<Photo> photos;
  std::vector<FeaturePoint> points(8);
  for (int k = 0; k < 8; ++k) points[k].vertex = k;
  for (int axis = 0; axis < 3; ++axis)
    for (int sign : {1, -1}) {
      Vec3 n = Vec3::Zero(), right = Vec3::Zero(), up = Vec3::Zero();
      n[axis] = sign;
      right[(axis + 1) % 3] = sign;
      up[(axis + 2) % 3] = 1;  // right x up = n
      std::array<int, 4> c{};
      const double uv[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};  // counter-clockwise seen from outside
      for (int k = 0; k < 4; ++k) {
        const Vec3 p = n + uv[k][0] * right + uv[k][1] * up;
        c[k] = corner(p);
        points[c[k]].at.push_back({int(photos.size()), 200 + 100 * uv[k][0], 200 - 100 * uv[k][1]});
      }
      f.push_back({c[0], c[1], c[2]});
      f.push_back({c[0], c[2], c[3]});
      photos.push_back(makePhoto(400, 400));
    }
  const std::shared_ptr<Mesh> cube = makeMesh(v, f);
  Scene scene = makeScene(cube, points, std::move(photos));
  const Partition part = partitionMesh(scene, {}, {});
  std::printf("cube: %zu paths, %zu rejected, %d cells, %d Steiner vertices\n", part.paths.size(), part.rejected.size(),
              part.numCells, part.steinerVertices);
  EXPECT_EQ(part.paths.size(), 18u) << describe(part);  // 12 edges + one diagonal per face
  EXPECT_EQ(part.numCells, 12);
  for (int k = 0; k < 8; ++k)
    for (int l = k + 1; l < 8; ++l)
      if ((v[k] - v[l]).norm() < 2.1) {
        const int id = findPath(part, k, l);
        ASSERT_GE(id, 0) << "cube edge " << k << "-" << l << ": " << describe(part);
        EXPECT_EQ(part.paths[id].curves.size(), 2u);  // seen in both faces' photos
      }
  EXPECT_GT(part.steinerVertices, 0);
  expectRefinement(part, *cube);
  expectValidPaths(part, scene);
  expectCyclicOrder(part);
}

// ---- Chains ----------------------------------------------------------------------------------------

TEST(Partition, ChainsEnterBeforeShorterPairs) {
  const Grid grid = makeGrid(21);
  const auto at = [&](int i, int j) { return point(grid.vertex(i, j), topView(i, j).x(), topView(i, j).y()); };
  // A square polygon A B C D (sides 8) and a short pair E-F (length 2) across side A-B.
  const std::vector<FeaturePoint> points = {at(6, 6), at(14, 6), at(14, 14), at(6, 14), at(10, 5), at(10, 7)};
  const FeatureChain square{0, {0, 1, 2, 3}, true};
  Scene scene = makeScene(grid.mesh, points, {makePhoto(240, 240)}, {square});
  const Partition part = partitionMesh(scene, {}, {});
  for (int k = 0; k < 4; ++k) {
    const int id = findPath(part, k, (k + 1) % 4);
    ASSERT_GE(id, 0) << describe(part);
    EXPECT_TRUE(part.paths[id].fromChain);
    EXPECT_EQ(part.paths[id].fromPoint, k);  // oriented along the chain
    EXPECT_LT(id, 4);                        // before any other pair
  }
  EXPECT_EQ(findPath(part, 4, 5), -1);
  EXPECT_TRUE(findRejection(part, 4, 5, RejectReason::CurveCrossesCurve)) << describe(part);
  EXPECT_GE(part.numCells, 2);  // inside and outside the square, at least
  expectValidPaths(part, scene);

  // Without the chain the short pair wins and side A-B is rejected.
  scene.project.chains.clear();
  const Partition plain = partitionMesh(scene, {}, {});
  EXPECT_GE(findPath(plain, 4, 5), 0) << describe(plain);
  EXPECT_EQ(findPath(plain, 0, 1), -1) << describe(plain);
}

TEST(Partition, ChainSegmentsRepeatedOrInAnotherPhoto) {
  const Grid grid = makeGrid(21);
  const auto at = [&](int i, int j) {
    return FeaturePoint{grid.vertex(i, j),
                        {{0, topView(i, j).x(), topView(i, j).y()}, {1, topView(i, j).x(), topView(i, j).y()}}};
  };
  const std::vector<FeaturePoint> points = {at(4, 4), at(12, 4), at(12, 12)};
  // A line 0-1-2 in photo 0, the segment 0-1 again in photo 0 and in photo 1.
  const std::vector<FeatureChain> chains = {{0, {0, 1, 2}, false}, {0, {1, 0}, false}, {1, {0, 1}, false}};
  Scene scene = makeScene(grid.mesh, points, {makePhoto(240, 240), makePhoto(240, 240)}, chains);
  const Partition part = partitionMesh(scene, {}, {});
  ASSERT_EQ(findPath(part, 0, 1), 0) << describe(part);
  EXPECT_EQ(findPath(part, 1, 2), 1) << describe(part);
  const MeshPath& p01 = part.paths[0];
  ASSERT_EQ(p01.curves.size(), 2u);  // photo 0 from the first chain, photo 1 from the third
  EXPECT_EQ(p01.curves[1].photo, 1);
  const RejectedPair* r = findRejection(part, 0, 1, RejectReason::Duplicate);
  ASSERT_TRUE(r) << describe(part);
  EXPECT_EQ(r->photo, 0);
  // The all-pairs queue adds photo 1 to 1-2 and does not report the chain pairs again.
  EXPECT_EQ(part.paths[1].curves.size(), 2u);
  EXPECT_EQ(std::count_if(part.rejected.begin(), part.rejected.end(),
                          [](const RejectedPair& x) { return x.reason == RejectReason::Duplicate; }),
            1);
  expectValidPaths(part, scene);
}

// ---- Robustness ------------------------------------------------------------------------------------

TEST(Partition, NoFeaturesGivesOneCellPerComponent) {
  const Grid a = makeGrid(5);
  std::vector<Vec3> v;
  std::vector<std::array<int, 3>> f;
  for (int copy = 0; copy < 2; ++copy) {
    const int base = int(v.size());
    for (int k = 0; k < a.mesh->numVertices(); ++k) v.push_back(a.mesh->position(k) + Vec3(10 * copy, 0, 0));
    for (int k = 0; k < a.mesh->numFaces(); ++k) {
      const auto c = a.mesh->faceVertices(k);
      f.push_back({base + c[0], base + c[1], base + c[2]});
    }
  }
  const std::shared_ptr<Mesh> two = makeMesh(v, f);
  Scene scene = makeScene(two, {}, {makePhoto(100, 100)});
  const Partition part = partitionMesh(scene, {}, {});
  EXPECT_TRUE(part.paths.empty());
  EXPECT_TRUE(part.rejected.empty());
  EXPECT_EQ(part.numCells, 2);
  EXPECT_EQ(part.steinerVertices, 0);
  expectRefinement(part, *two);
}

TEST(Partition, LonelyPointsAndPhotosDoNotBreakAnything) {
  const Grid grid = makeGrid(11);
  const auto at = [&](int i, int j, int photo) {
    return point(grid.vertex(i, j), topView(i, j).x(), topView(i, j).y(), photo);
  };
  // Point 0 alone in photo 0, points 1 and 2 share photo 1, point 3 alone in photo 2.
  const std::vector<FeaturePoint> points = {at(2, 2, 0), at(5, 5, 1), at(8, 8, 1), at(2, 8, 2)};
  Scene scene = makeScene(grid.mesh, points, {makePhoto(140, 140), makePhoto(140, 140), makePhoto(140, 140)});
  const Partition part = partitionMesh(scene, {}, {});
  ASSERT_EQ(part.paths.size(), 1u) << describe(part);
  EXPECT_EQ(findPath(part, 1, 2), 0);
  EXPECT_TRUE(findRejection(part, 0, 3, RejectReason::NoCommonPhoto)) << describe(part);
  EXPECT_EQ(part.featureVertex,
            (std::vector<int>{grid.vertex(2, 2), grid.vertex(5, 5), grid.vertex(8, 8), grid.vertex(2, 8)}));
  expectValidPaths(part, scene);

  // One photo with a single point, and a point with no position at all.
  Scene single = makeScene(grid.mesh, {at(3, 3, 0), FeaturePoint{grid.vertex(7, 7), {}}}, {makePhoto(140, 140)});
  const Partition lone = partitionMesh(single, {}, {});
  EXPECT_TRUE(lone.paths.empty());
  EXPECT_EQ(lone.numCells, 1);
}

TEST(Partition, BadIndicesAreUserErrors) {
  const Grid grid = makeGrid(5);
  Scene scene = makeScene(grid.mesh, {point(3, 10, 10), point(99, 20, 20)}, {makePhoto(40, 40)});
  try {
    partitionMesh(scene, {}, {});
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("points[1].vertex: 99"), std::string::npos) << e.what();
  }
  scene.project.points[1] = point(4, 20, 20, 3);
  EXPECT_THROW(partitionMesh(scene, {}, {}), Error);
}

TEST(Partition, PointsSharingAVertexAreMerged) {
  const Grid grid = makeGrid(11);
  // Points 0 and 2 name the same vertex in different photos; 1 is in photo 0, 3 in photo 1.
  const std::vector<FeaturePoint> points = {point(grid.vertex(5, 5), 70, 70, 0), point(grid.vertex(8, 5), 100, 70, 0),
                                            point(grid.vertex(5, 5), 70, 70, 1), point(grid.vertex(5, 8), 70, 100, 1)};
  Scene scene = makeScene(grid.mesh, points, {makePhoto(140, 140), makePhoto(140, 140)});
  const Partition part = partitionMesh(scene, {}, {});
  EXPECT_GE(findPath(part, 0, 1), 0) << describe(part);
  EXPECT_GE(findPath(part, 0, 3), 0) << describe(part);  // via the merged point 0
  EXPECT_EQ(part.featureVertex[2], grid.vertex(5, 5));
  expectValidPaths(part, scene);
}

TEST(Partition, ReportsProgressAndHonoursCancel) {
  const Grid grid = makeGrid(31);
  std::vector<FeaturePoint> points;
  for (int j = 2; j < 30; j += 4)
    for (int i = 2; i < 30; i += 4) points.push_back(point(grid.vertex(i, j), topView(i, j).x(), topView(i, j).y()));
  Scene scene = makeScene(grid.mesh, points, {makePhoto(340, 340)});
  int calls = 0;
  double last = -1;
  bool monotone = true;
  JobControl job(nullptr, [&](StageId stage, double fraction, const std::string& what) {
    EXPECT_EQ(stage, StageId::Partition);
    EXPECT_EQ(what, "partition");
    monotone = monotone && fraction >= last && fraction <= 1;
    last = fraction;
    ++calls;
  });
  const Partition part = partitionMesh(scene, {}, job);
  EXPECT_GT(calls, 0);
  EXPECT_TRUE(monotone);
  // A regular lattice seen from the top: the grid edges and one diagonal per square at least.
  EXPECT_GE(part.paths.size(), 2u * 7 * 6) << describe(part);
  expectValidPaths(part, scene);
  expectCyclicOrder(part);
  expectRefinement(part, *grid.mesh);

  std::atomic<bool> cancel{true};
  JobControl cancelled(&cancel, nullptr);
  EXPECT_THROW(partitionMesh(scene, {}, cancelled), Cancelled);
}

// ---- A realistic case --------------------------------------------------------------------------------

// 1-to-4 midpoint subdivision (flat), to get a denser mesh of the same shape.
std::shared_ptr<const Mesh> subdivide(const Mesh& mesh) {
  std::vector<Vec3> v;
  for (int k = 0; k < mesh.numVertices(); ++k) v.push_back(mesh.position(k));
  std::map<std::pair<int, int>, int> mid;
  const auto midpoint = [&](int a, int b) {
    const auto key = std::minmax(a, b);
    const auto it = mid.find(key);
    if (it != mid.end()) return it->second;
    v.push_back(0.5 * (v[a] + v[b]));
    return mid[key] = static_cast<int>(v.size()) - 1;
  };
  std::vector<std::array<int, 3>> f;
  for (int k = 0; k < mesh.numFaces(); ++k) {
    const auto c = mesh.faceVertices(k);
    const int a = midpoint(c[0], c[1]), b = midpoint(c[1], c[2]), d = midpoint(c[2], c[0]);
    f.push_back({c[0], a, d});
    f.push_back({c[1], b, a});
    f.push_back({c[2], d, b});
    f.push_back({a, b, d});
  }
  return makeMesh(v, f);
}

// An orthographic side view (from +x: image right = -z, down = -y) of `mesh` in a size x size photo
// whose foreground is the projected faces, with `count` features spread over the visible vertices
// (farthest-point order, at least 8 px inside the silhouette) at their projected positions.
Scene sideViewScene(std::shared_ptr<const Mesh> mesh, int count, int size = 1024) {
  Vec3 lo, hi;
  mesh->bounds(lo, hi);
  const double scale = 0.9 * size / std::max(hi.z() - lo.z(), hi.y() - lo.y());
  const Vec3 mid = 0.5 * (lo + hi);
  const auto project = [&](const Vec3& p) {
    return Vec2(0.5 * size - scale * (p.z() - mid.z()), 0.5 * size - scale * (p.y() - mid.y()));
  };
  // Orthographic z-buffer (depth = x, nearer is larger) for the mask and vertex visibility.
  std::vector<double> depth(size_t(size) * size, -kInf);
  cv::Mat mask = cv::Mat::zeros(size, size, CV_8UC1);
  for (int fi = 0; fi < mesh->numFaces(); ++fi) {
    const auto p = mesh->facePositions(fi);
    scanTriangle({project(p[0]), project(p[1]), project(p[2])}, size, size, [&](int x, int y, const Vec3& b) {
      const double d = b[0] * p[0].x() + b[1] * p[1].x() + b[2] * p[2].x();
      double& z = depth[size_t(y) * size + x];
      z = std::max(z, d);
      mask.at<uint8_t>(y, x) = 255;
    });
  }
  cv::Mat inside;
  cv::distanceTransform(mask, inside, cv::DIST_L2, cv::DIST_MASK_PRECISE, CV_32F);
  std::vector<int> candidates;
  for (int v = 0; v < mesh->numVertices(); ++v) {
    const Vec2 q = project(mesh->position(v));
    const int x = int(q.x()), y = int(q.y());
    if (x < 0 || y < 0 || x >= size || y >= size) continue;
    if (inside.at<float>(y, x) > 8 && mesh->position(v).x() > depth[size_t(y) * size + x] - 0.01)
      candidates.push_back(v);
  }
  EXPECT_GT(int(candidates.size()), 2 * count);
  std::vector<int> chosen = {candidates.front()};
  std::vector<double> far(candidates.size(), kInf);
  while (int(chosen.size()) < count) {
    size_t best = 0;
    for (size_t k = 0; k < candidates.size(); ++k) {
      far[k] = std::min(far[k], (mesh->position(candidates[k]) - mesh->position(chosen.back())).norm());
      if (far[k] > far[best]) best = k;
    }
    chosen.push_back(candidates[best]);
  }
  std::vector<FeaturePoint> points;
  for (int v : chosen) {
    const Vec2 q = project(mesh->position(v));
    points.push_back(point(v, q.x(), q.y()));
  }
  return makeScene(std::move(mesh), points, {makePhoto(size, size, mask)});
}

// Runs the partition, prints its figures and checks every invariant; returns it with its time.
Partition runAndCheck(const Scene& scene, const std::string& name, double& seconds) {
  const auto start = std::chrono::steady_clock::now();
  Partition part = partitionMesh(scene, {}, {});
  seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::map<RejectReason, int> reasons;
  for (const RejectedPair& r : part.rejected) ++reasons[r.reason];
  std::printf("%s: %d vertices, %zu features, %zu paths accepted, %zu rejections (", name.c_str(),
              scene.mesh->numVertices(), scene.project.points.size(), part.paths.size(), part.rejected.size());
  for (const auto& [reason, count] : reasons) std::printf(" %s: %d;", kRejectReasonNames[int(reason)], count);
  std::printf(" ), %d cells, %d Steiner vertices, %.3f s\n", part.numCells, part.steinerVertices, seconds);
  for (const RejectedPair& r : part.rejected)
    if (r.reason == RejectReason::NoPath || r.reason == RejectReason::CyclicOrder)
      std::printf("  %d-%d photo %d: %s: %s\n", r.fromPoint, r.toPoint, r.photo, kRejectReasonNames[int(r.reason)],
                  r.detail.c_str());

  const Photo& photo = *scene.photos[0];
  for (const MeshPath& p : part.paths)
    for (const Curve& c : p.curves) EXPECT_LE(meanDistance(photo, c.from, c.to), 2.1);
  expectRefinement(part, *scene.mesh);
  expectValidPaths(part, scene);
  expectCyclicOrder(part);
  return part;
}

TEST(Partition, SpotSideViewWithFortyFeatures) {
  TM_REQUIRE_SHARED(path, "meshes/spot/spot_triangulated.obj");
  const Scene scene = sideViewScene(std::shared_ptr<const Mesh>(requireUsable(loadMesh(path))), 40);
  double seconds = 0;
  const Partition part = runAndCheck(scene, "spot", seconds);
  EXPECT_GE(part.paths.size(), 80u);  // a triangulation of 40 points in the plane has up to 111 edges
  EXPECT_GT(part.numCells, 40);
}

TEST(Partition, DenseSpotWith350FeaturesScales) {
  TM_REQUIRE_SHARED(path, "meshes/spot/spot_triangulated.obj");
  const std::unique_ptr<Mesh> spot = requireUsable(loadMesh(path));
  const Scene scene = sideViewScene(subdivide(*subdivide(*spot)), 350, 2048);  // 46.8k vertices
  double seconds = 0;
  const Partition part = runAndCheck(scene, "spot subdivided twice", seconds);
  EXPECT_GE(part.paths.size(), 700u);
}

void expectSamePartition(const Partition& a, const Partition& b) {
  EXPECT_EQ(a.faceParent, b.faceParent);
  EXPECT_EQ(a.faceCell, b.faceCell);
  EXPECT_EQ(a.numCells, b.numCells);
  EXPECT_EQ(a.steinerVertices, b.steinerVertices);
  ASSERT_EQ(a.paths.size(), b.paths.size());
  for (size_t k = 0; k < a.paths.size(); ++k) {
    EXPECT_EQ(a.paths[k].vertices, b.paths[k].vertices) << "path " << k;
    ASSERT_EQ(a.paths[k].curves.size(), b.paths[k].curves.size()) << "path " << k;
    for (size_t c = 0; c < a.paths[k].curves.size(); ++c) {
      EXPECT_EQ(a.paths[k].curves[c].photo, b.paths[k].curves[c].photo);
      EXPECT_EQ(a.paths[k].curves[c].from, b.paths[k].curves[c].from);
      EXPECT_EQ(a.paths[k].curves[c].to, b.paths[k].curves[c].to);
    }
  }
  ASSERT_EQ(a.rejected.size(), b.rejected.size());
  for (size_t k = 0; k < a.rejected.size(); ++k) {
    EXPECT_EQ(a.rejected[k].reason, b.rejected[k].reason) << "rejection " << k;
    EXPECT_EQ(a.rejected[k].detail, b.rejected[k].detail) << "rejection " << k;
  }
}

TEST(Partition, MemoGivesTheSamePartitionAsAFreshRun) {
  TM_REQUIRE_SHARED(path, "meshes/spot/spot_triangulated.obj");
  Scene scene = sideViewScene(std::shared_ptr<const Mesh>(requireUsable(loadMesh(path))), 60);
  // A second photo of the same view, every point clicked in both.
  scene.photos.push_back(scene.photos[0]);
  for (FeaturePoint& p : scene.project.points) p.at.push_back({1, p.at[0].x, p.at[0].y});
  scene.photoKeys = {"side view a", "side view b"};  // what identifies their pixels (the background memo)
  PartitionMemo memo;
  const Partition plain = partitionMesh(scene, {}, {});
  EXPECT_EQ(plain.searchesReused, 0);
  const Partition first = partitionMesh(scene, {}, {}, &memo);
  expectSamePartition(first, plain);
  const Partition again = partitionMesh(scene, {}, {}, &memo);
  expectSamePartition(again, plain);
  EXPECT_EQ(again.searchesReused, again.searches);
  // A point dragged 3 px in photo 1: the searches are the last run's, the result a fresh run's.
  scene.project.points[7].at[1].x += 3;
  const Partition dragged = partitionMesh(scene, {}, {}, &memo);
  expectSamePartition(dragged, partitionMesh(scene, {}, {}));
  EXPECT_GT(dragged.searchesReused, dragged.searches / 2);
}

// Drags of 1 to 60 px, seeded, in either photo: each result equals a fresh run's (curves, rejection
// details and all), whether the memo replayed the last run's decisions or had to run again; both
// happen.
TEST(Partition, ReplayedDragsGiveAFreshRunsPartition) {
  TM_REQUIRE_SHARED(path, "meshes/spot/spot_triangulated.obj");
  Scene scene = sideViewScene(std::shared_ptr<const Mesh>(requireUsable(loadMesh(path))), 60);
  scene.photos.push_back(scene.photos[0]);
  for (FeaturePoint& p : scene.project.points) p.at.push_back({1, p.at[0].x, p.at[0].y});
  scene.photoKeys = {"side view a", "side view b"};
  PartitionMemo memo;
  partitionMesh(scene, {}, {}, &memo);
  std::mt19937 rng(7);
  int replayed = 0, rerun = 0;
  for (int step = 0; step < 24; ++step) {
    FeaturePoint& p = scene.project.points[rng() % scene.project.points.size()];
    PhotoPoint& at = p.at[rng() % p.at.size()];
    const double size = step % 3 == 2 ? 60 : 1 + rng() % 4;
    at.x += std::uniform_real_distribution<double>(-size, size)(rng);
    at.y += std::uniform_real_distribution<double>(-size, size)(rng);
    const int before = memo.replays;
    const Partition incremental = partitionMesh(scene, {}, {}, &memo);
    SCOPED_TRACE("step " + std::to_string(step));
    expectSamePartition(incremental, partitionMesh(scene, {}, {}));
    EXPECT_EQ(incremental.replayed, memo.replays > before);
    (incremental.replayed ? replayed : rerun) += 1;
  }
  std::printf("24 drags: %d replayed, %d run again\n", replayed, rerun);
  EXPECT_GT(replayed, 0);
  EXPECT_GT(rerun, 0);
}

}  // namespace
}  // namespace montage
