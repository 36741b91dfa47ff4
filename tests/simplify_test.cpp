// Progressive mesh (paper section 3.2): constrained collapses down to a base mesh whose edges are
// the paths, exact replay of splits/collapses, and the barycentric coordinates of removed vertices.
// Partitions are built by hand (grid lines, a Dijkstra written here), never by partitionMesh().
#include "io/mesh_io.h"
#include "mapping/simplify.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <queue>
#include <random>
#include <set>

#include "mapping/partition.h"
#include "pipeline.h"
#include "geometry/shapes.h"
#include "test_support.h"

namespace montage {
namespace {

constexpr double kPi = 3.14159265358979323846;

// ---- Meshes and hand-made partitions ----

std::vector<std::vector<int>> adjacency(const Mesh& mesh) {
  std::vector<std::set<int>> s(mesh.numVertices());
  for (int f = 0; f < mesh.numFaces(); ++f) {
    const auto t = mesh.faceVertices(f);
    for (int k = 0; k < 3; ++k) s[t[k]].insert(t[(k + 1) % 3]), s[t[(k + 1) % 3]].insert(t[k]);
  }
  std::vector<std::vector<int>> out(s.size());
  for (size_t v = 0; v < s.size(); ++v) out[v].assign(s[v].begin(), s[v].end());
  return out;
}

// Dijkstra along edges avoiding blocked vertices (ends allowed), giving up beyond maxLength.
std::vector<int> dijkstra(const Mesh& mesh, const std::vector<std::vector<int>>& adj, int from, int to,
                          const std::vector<char>& blocked, double maxLength = 1e300) {
  std::vector<double> dist(adj.size(), 1e300);
  std::vector<int> prev(adj.size(), -1);
  using Item = std::pair<double, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> q;
  dist[from] = 0;
  q.push({0, from});
  while (!q.empty()) {
    const auto [d, x] = q.top();
    q.pop();
    if (d > dist[x] || d > maxLength) continue;
    if (x == to) break;
    for (int y : adj[x]) {
      if (blocked[y] && y != to) continue;
      const double nd = d + (mesh.position(x) - mesh.position(y)).norm();
      if (nd < dist[y]) dist[y] = nd, prev[y] = x, q.push({nd, y});
    }
  }
  if (prev[to] < 0) return {};
  std::vector<int> path = {to};
  while (path.back() != from) path.push_back(prev[path.back()]);
  std::reverse(path.begin(), path.end());
  return path;
}

Partition makePartition(std::unique_ptr<Mesh> mesh, const std::vector<int>& features) {
  Partition p;
  p.mesh = std::move(*mesh);
  p.featureVertex = features;
  return p;
}

// Adds the path between features a and b (indices into featureVertex); false when none exists.
bool addPath(Partition& p, const std::vector<std::vector<int>>& adj, std::vector<char>& used, int a, int b,
             double maxLength = 1e300) {
  std::vector<char> blocked = used;
  for (int f : p.featureVertex) blocked[f] = 1;
  auto path = dijkstra(p.mesh, adj, p.featureVertex[a], p.featureVertex[b], blocked, maxLength);
  if (path.empty()) return false;
  // Two paths between the same feature pair would share the single edge between them.
  if (path.size() == 2)
    for (const auto& q : p.paths)
      if (q.vertices.size() == 2 && std::minmax(q.vertices[0], q.vertices[1]) == std::minmax(path[0], path[1]))
        return false;
  for (size_t i = 1; i + 1 < path.size(); ++i) used[path[i]] = 1;
  MeshPath mp;
  mp.fromPoint = a, mp.toPoint = b;
  mp.vertices = path;
  for (size_t i = 1; i < path.size(); ++i)
    mp.length += (p.mesh.position(path[i]) - p.mesh.position(path[i - 1])).norm();
  p.paths.push_back(mp);
  return true;
}

// Paths between each feature and its k nearest ones (Euclidean), shortest pairs first.
void connectNearest(Partition& p, int k) {
  const auto adj = adjacency(p.mesh);
  std::vector<char> used(p.mesh.numVertices(), 0);
  const int n = static_cast<int>(p.featureVertex.size());
  std::set<std::pair<int, int>> pairs;
  for (int i = 0; i < n; ++i) {
    std::vector<std::pair<double, int>> d;
    for (int j = 0; j < n; ++j)
      if (j != i) d.push_back({(p.mesh.position(p.featureVertex[i]) - p.mesh.position(p.featureVertex[j])).norm(), j});
    std::sort(d.begin(), d.end());
    for (int m = 0; m < std::min<int>(k, d.size()); ++m) pairs.insert(std::minmax(i, d[m].second));
  }
  std::vector<std::tuple<double, int, int>> sorted;
  for (auto [a, b] : pairs)
    sorted.push_back({(p.mesh.position(p.featureVertex[a]) - p.mesh.position(p.featureVertex[b])).norm(), a, b});
  std::sort(sorted.begin(), sorted.end());
  for (auto [d, a, b] : sorted) addPath(p, adj, used, a, b, 3 * d);
}

// Feature vertices spread by farthest point sampling (Euclidean), from vertex `seed`.
std::vector<int> farthestPoints(const Mesh& mesh, int count, int seed) {
  std::vector<double> d(mesh.numVertices(), 1e300);
  std::vector<int> out = {seed};
  while (static_cast<int>(out.size()) < count) {
    const Vec3 last = mesh.position(out.back());
    int best = 0;
    for (int v = 0; v < mesh.numVertices(); ++v) {
      d[v] = std::min(d[v], (mesh.position(v) - last).squaredNorm());
      if (d[v] > d[best]) best = v;
    }
    out.push_back(best);
  }
  return out;
}

// ---- Checks on the progressive mesh at its current level ----

using Edge = std::pair<int, int>;

std::map<Edge, int> edgeFaceCounts(const ProgressiveMesh& pm) {
  std::map<Edge, int> e;
  for (int f = 0; f < pm.numFaces(); ++f) {
    if (!pm.faceAlive(f)) continue;
    const auto& t = pm.face(f);
    for (int k = 0; k < 3; ++k) ++e[std::minmax(t[k], t[(k + 1) % 3])];
  }
  return e;
}

int eulerCharacteristic(const ProgressiveMesh& pm) {
  std::set<int> vertices;
  for (int f = 0; f < pm.numFaces(); ++f)
    if (pm.faceAlive(f))
      for (int x : pm.face(f)) vertices.insert(x);
  return static_cast<int>(vertices.size()) - static_cast<int>(edgeFaceCounts(pm).size()) + pm.aliveFaces();
}

// Cell of each alive face: face-connected through edges on no path (border edges have one face).
std::vector<int> cells(const ProgressiveMesh& pm, int& count) {
  std::map<Edge, std::vector<int>> edgeFaces;
  for (int f = 0; f < pm.numFaces(); ++f) {
    if (!pm.faceAlive(f)) continue;
    const auto& t = pm.face(f);
    for (int k = 0; k < 3; ++k) edgeFaces[std::minmax(t[k], t[(k + 1) % 3])].push_back(f);
  }
  std::vector<int> cell(pm.numFaces(), -1);
  count = 0;
  for (int f0 = 0; f0 < pm.numFaces(); ++f0) {
    if (!pm.faceAlive(f0) || cell[f0] >= 0) continue;
    std::vector<int> stack = {f0};
    cell[f0] = count;
    while (!stack.empty()) {
      const int f = stack.back();
      stack.pop_back();
      const auto& t = pm.face(f);
      for (int k = 0; k < 3; ++k) {
        if (pm.pathOfEdge(t[k], t[(k + 1) % 3]) >= 0) continue;
        for (int g : edgeFaces[std::minmax(t[k], t[(k + 1) % 3])])
          if (cell[g] < 0) cell[g] = count, stack.push_back(g);
      }
    }
    ++count;
  }
  return cell;
}

// The counter-clockwise ring of v from the current faces (as the records describe it).
std::vector<int> ringOf(const ProgressiveMesh& pm, int v, bool& closed) {
  std::map<int, int> next;
  std::set<int> hasPrev;
  for (int f : pm.vertexFaces(v)) {
    const auto& t = pm.face(f);
    const int k = t[0] == v ? 0 : t[1] == v ? 1 : 2;
    next[t[(k + 1) % 3]] = t[(k + 2) % 3];
    hasPrev.insert(t[(k + 2) % 3]);
  }
  int start = next.begin()->first;
  closed = true;
  for (auto [a, b] : next)
    if (!hasPrev.count(a)) start = a, closed = false;
  std::vector<int> ring = {start};
  while (next.count(ring.back()) && ring.size() <= next.size()) ring.push_back(next[ring.back()]);
  if (closed) ring.pop_back();
  return ring;
}

std::vector<std::array<int, 3>> facesOf(const ProgressiveMesh& pm) {
  std::vector<std::array<int, 3>> out;
  for (int f = 0; f < pm.numFaces(); ++f) out.push_back(pm.faceAlive(f) ? pm.face(f) : std::array<int, 3>{-1, -1, -1});
  return out;
}

std::vector<Vec3> positionsOf(const Mesh& mesh) {
  std::vector<Vec3> out;
  for (int v = 0; v < mesh.numVertices(); ++v) out.push_back(mesh.position(v));
  return out;
}

struct BaseSummary {
  int vertices = 0, faces = 0, extraVertices = 0, longPaths = 0;
};

// Base-level checks shared by all meshes; returns figures for the caller's expectations.
BaseSummary checkBase(const ProgressiveMesh& pm, const Partition& part, bool closedMesh, int originalEuler,
                      const std::vector<int>& originalCell) {
  EXPECT_TRUE(pm.atBase());
  BaseSummary s;
  std::set<int> features(part.featureVertex.begin(), part.featureVertex.end());
  for (int f : part.featureVertex) EXPECT_TRUE(pm.vertexAlive(f)) << "feature vertex " << f << " collapsed";
  for (int v = 0; v < pm.numVertices(); ++v)
    if (pm.vertexAlive(v) && !pm.vertexFaces(v).empty()) ++s.vertices, s.extraVertices += !features.count(v);
  s.faces = pm.aliveFaces();
  EXPECT_EQ(s.extraVertices, pm.stats().baseExtraVertices);
  for (int p = 0; p < static_cast<int>(part.paths.size()); ++p)
    s.longPaths += pm.pathOfEdge(part.paths[p].vertices.front(), part.paths[p].vertices.back()) != p;
  EXPECT_EQ(eulerCharacteristic(pm), originalEuler);
  // Manifold: every edge has two faces on a closed mesh, one or two otherwise.
  for (const auto& [e, n] : edgeFaceCounts(pm)) {
    if (closedMesh)
      EXPECT_EQ(n, 2) << "edge " << e.first << "-" << e.second;
    else
      EXPECT_TRUE(n == 1 || n == 2) << "edge " << e.first << "-" << e.second;
  }
  // No face turned by more than 90 degrees from its original.
  int flipped = 0;
  for (int f = 0; f < pm.numFaces(); ++f) {
    if (!pm.faceAlive(f)) continue;
    const auto& t = pm.face(f);
    const auto o = part.mesh.facePositions(f);
    const Vec3 n0 = (o[1] - o[0]).cross(o[2] - o[0]);
    const Vec3 a = part.mesh.position(t[0]), b = part.mesh.position(t[1]), c = part.mesh.position(t[2]);
    const Vec3 n1 = (b - a).cross(c - a);
    EXPECT_GT(n1.norm(), 0) << "degenerate base face " << f;
    flipped += n0.dot(n1) < 0;
  }
  EXPECT_EQ(flipped, 0);
  // Faces stay in their cell: base cells and original cells correspond one to one.
  int baseCount = 0;
  const auto baseCell = cells(pm, baseCount);
  std::map<int, std::set<int>> baseToOriginal, originalToBase;
  for (int f = 0; f < pm.numFaces(); ++f)
    if (pm.faceAlive(f))
      baseToOriginal[baseCell[f]].insert(originalCell[f]), originalToBase[originalCell[f]].insert(baseCell[f]);
  for (const auto& [c, set] : baseToOriginal) EXPECT_EQ(set.size(), 1u) << "base cell " << c << " mixes original cells";
  for (const auto& [c, set] : originalToBase) EXPECT_EQ(set.size(), 1u) << "original cell " << c << " was split";
  std::printf(
      "  base: %d vertices (%d not features), %d faces, %d of %zu paths not a single edge, %d cells, "
      "%zu collapses\n",
      s.vertices, s.extraVertices, s.faces, s.longPaths, part.paths.size(), baseCount, pm.records().size());
  const auto& st = pm.stats();
  std::printf(
      "  weights: %d on edge, %d Meyer, %d mean value, %d mean value 3D, %d uniform; sides: %d on edge, %d other\n",
      st.weights[0], st.weights[1], st.weights[2], st.weights[3], st.weights[4], st.sides[0],
      st.sides[1] + st.sides[2] + st.sides[3] + st.sides[4]);
  return s;
}

// Splits down to the original mesh and collapses back: exact connectivity both ways, Euler
// characteristic every 1000 levels, each split's ring as recorded.
void checkReplay(ProgressiveMesh& pm, const Partition& part, int originalEuler) {
  const auto base = facesOf(pm);
  std::vector<std::vector<int>> baseVertexFaces;
  for (int v = 0; v < pm.numVertices(); ++v) {
    auto vf = pm.vertexFaces(v);
    std::sort(vf.begin(), vf.end());
    baseVertexFaces.push_back(vf);
  }
  // Every 1000th level, more often on small meshes.
  const int every = std::clamp(static_cast<int>(pm.records().size()) / 50, 1, 1000);
  int ringMismatches = 0;
  while (!pm.atFull()) {
    const CollapseRecord& r = pm.split();
    bool closed = true;
    auto ring = ringOf(pm, r.removed, closed);
    if (closed) {  // rotate to the record's start
      auto it = std::find(ring.begin(), ring.end(), r.ring.empty() ? -1 : r.ring[0]);
      if (it != ring.end()) std::rotate(ring.begin(), it, ring.end());
    }
    ringMismatches += ring != r.ring;
    if (pm.level() % every == 0) ASSERT_EQ(eulerCharacteristic(pm), originalEuler) << "level " << pm.level();
  }
  EXPECT_EQ(ringMismatches, 0);
  EXPECT_EQ(pm.aliveVertices(), part.mesh.numVertices());
  EXPECT_EQ(pm.aliveFaces(), part.mesh.numFaces());
  int cornerMismatches = 0;
  for (int f = 0; f < pm.numFaces(); ++f)
    cornerMismatches += !pm.faceAlive(f) || pm.face(f) != part.mesh.faceVertices(f);
  EXPECT_EQ(cornerMismatches, 0);
  std::vector<std::vector<int>> expected(pm.numVertices());
  for (int f = 0; f < part.mesh.numFaces(); ++f)
    for (int v : part.mesh.faceVertices(f)) expected[v].push_back(f);
  for (int v = 0; v < pm.numVertices(); ++v) {
    auto got = pm.vertexFaces(v);
    std::sort(got.begin(), got.end());
    ASSERT_EQ(got, expected[v]) << "vertexFaces of " << v;
  }
  for (int p = 0; p < static_cast<int>(part.paths.size()); ++p) {
    const auto& pv = part.paths[p].vertices;
    for (size_t i = 1; i < pv.size(); ++i) ASSERT_EQ(pm.pathOfEdge(pv[i - 1], pv[i]), p);
  }
  while (!pm.atBase()) {
    pm.collapse();
    if (pm.level() % every == 0) ASSERT_EQ(eulerCharacteristic(pm), originalEuler) << "level " << pm.level();
  }
  EXPECT_EQ(facesOf(pm), base);
  for (int v = 0; v < pm.numVertices(); ++v) {
    auto vf = pm.vertexFaces(v);
    std::sort(vf.begin(), vf.end());
    ASSERT_EQ(vf, baseVertexFaces[v]) << "vertexFaces of " << v;
  }
}

// Coordinates of every record: sum 1, positive (non-negative for sides), and each side
// interpolates linearly between the two path neighbours by their distance to the removed vertex.
void checkRecordCoordinates(const ProgressiveMesh& pm, const Mesh& mesh) {
  int bad = 0;
  for (const auto& r : pm.records()) {
    ASSERT_EQ(r.weights.size(), r.ring.size());
    double sum = 0;
    for (double w : r.weights) sum += w, bad += !(w >= 0);
    EXPECT_NEAR(sum, 1, 1e-12);
    if (r.pathA < 0) continue;
    const int n = static_cast<int>(r.ring.size());
    const Vec3 v = mesh.position(r.removed);
    const double ra = (mesh.position(r.ring[r.pathA]) - v).norm(), rb = (mesh.position(r.ring[r.pathB]) - v).norm();
    std::vector<const std::vector<double>*> sides = {&r.left};
    if (!r.right.empty()) sides.push_back(&r.right);
    ASSERT_EQ(r.left.size(), static_cast<size_t>((r.pathB - r.pathA + n) % n + 1));
    if (!r.right.empty()) ASSERT_EQ(r.right.size(), static_cast<size_t>((r.pathA - r.pathB + n) % n + 1));
    for (size_t s = 0; s < sides.size(); ++s) {
      const auto& w = *sides[s];
      // left starts at a and ends at b; right starts at b and ends at a
      const double wa = s == 0 ? w.front() : w.back(), wb = s == 0 ? w.back() : w.front();
      EXPECT_NEAR(wa, rb / (ra + rb), 1e-9);
      EXPECT_NEAR(wb, ra / (ra + rb), 1e-9);
      for (size_t k = 1; k + 1 < w.size(); ++k) EXPECT_EQ(w[k], 0.0);
    }
  }
  EXPECT_EQ(bad, 0);
}

struct Run {
  std::unique_ptr<ProgressiveMesh> pm;
  BaseSummary base;
};

// Builds the PM of a partition and runs every structural check.
Run buildAndCheck(const Partition& part, bool closedMesh, const JobControl& job = {}) {
  const auto positions = positionsOf(part.mesh);
  Run run;
  run.pm = std::make_unique<ProgressiveMesh>(part, SimplifyOptions{}, job);
  ProgressiveMesh& pm = *run.pm;
  // Original Euler characteristic and cells, from the full level.
  while (!pm.atFull()) pm.split();
  const int euler = eulerCharacteristic(pm);
  int originalCells = 0;
  const auto originalCell = cells(pm, originalCells);
  while (!pm.atBase()) pm.collapse();
  std::printf("  %d vertices, %d faces, %zu features, %zu paths, %d cells, Euler %d, PM built in %.3f s\n",
              part.mesh.numVertices(), part.mesh.numFaces(), part.featureVertex.size(), part.paths.size(),
              originalCells, euler, pm.stats().seconds);
  run.base = checkBase(pm, part, closedMesh, euler, originalCell);
  checkRecordCoordinates(pm, part.mesh);
  checkReplay(pm, part, euler);
  EXPECT_EQ(positionsOf(part.mesh), positions) << "the progressive mesh moved vertices";
  return run;
}

// ---- Tests ----

TEST(PolygonCoordinates, ConvexPolygonUsesMeyerAndReproducesThePoint) {
  std::vector<Vec2> hexagon;
  for (int k = 0; k < 6; ++k) hexagon.emplace_back(std::cos(k * kPi / 3) * (1 + 0.1 * k), std::sin(k * kPi / 3));
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-0.5, 0.5);
  for (int trial = 0; trial < 100; ++trial) {
    const Vec2 p(u(rng), u(rng));
    CoordinateKind kind;
    const auto w = polygonCoordinates(hexagon, p, &kind);
    ASSERT_EQ(w.size(), 6u);
    EXPECT_EQ(kind, CoordinateKind::Meyer);
    Vec2 q = Vec2::Zero();
    double sum = 0;
    for (int k = 0; k < 6; ++k) {
      q += w[k] * hexagon[k];
      sum += w[k];
      EXPECT_GT(w[k], 0);
    }
    EXPECT_NEAR(sum, 1, 1e-12);
    EXPECT_LT((q - p).norm(), 1e-12);
  }
}

TEST(PolygonCoordinates, StarShapedFallsBackToPositiveMeanValue) {
  // A star: reflex vertices make Wachspress weights negative; the centre sees every edge.
  std::vector<Vec2> star;
  for (int k = 0; k < 10; ++k) {
    const double r = k % 2 ? 0.4 : 1.0, a = k * kPi / 5;
    star.emplace_back(r * std::cos(a), r * std::sin(a));
  }
  for (const Vec2 p : {Vec2(0, 0), Vec2(0.05, -0.1), Vec2(-0.2, 0.1)}) {
    CoordinateKind kind;
    const auto w = polygonCoordinates(star, p, &kind);
    ASSERT_EQ(w.size(), 10u);
    EXPECT_EQ(kind, CoordinateKind::MeanValue);
    Vec2 q = Vec2::Zero();
    for (int k = 0; k < 10; ++k) {
      q += w[k] * star[k];
      EXPECT_GE(w[k], 0);
    }
    EXPECT_LT((q - p).norm(), 1e-12);
  }
  // Outside, or not star-shaped around p: no coordinates.
  CoordinateKind kind;
  EXPECT_TRUE(polygonCoordinates(star, Vec2(2, 2), &kind).empty());
  EXPECT_EQ(kind, CoordinateKind::None);
}

TEST(PolygonCoordinates, PointOnAnEdgeGetsLinearCoordinates) {
  const std::vector<Vec2> quad = {{0, 0}, {4, 0}, {4, 2}, {0, 2}};
  CoordinateKind kind;
  auto w = polygonCoordinates(quad, Vec2(4, 0.5), &kind);
  EXPECT_EQ(kind, CoordinateKind::OnEdge);
  EXPECT_EQ(w, (std::vector<double>{0, 0.75, 0.25, 0}));
  w = polygonCoordinates(quad, Vec2(0, 0.5), &kind);  // closing edge 3 -> 0
  EXPECT_EQ(kind, CoordinateKind::OnEdge);
  EXPECT_NEAR(w[0], 0.75, 1e-15);
  EXPECT_NEAR(w[3], 0.25, 1e-15);
  // A two-point polygon (a sub-polygon of one face) is the segment itself.
  w = polygonCoordinates({{1, 0}, {-3, 0}}, Vec2::Zero(), &kind);
  EXPECT_EQ(kind, CoordinateKind::OnEdge);
  EXPECT_NEAR(w[0], 0.75, 1e-15);
  EXPECT_NEAR(w[1], 0.25, 1e-15);
}

// Features at the grid corners, paths along the four sides (on the border) and the diagonal: two
// triangular cells, so the base is exactly two triangles.
TEST(ProgressiveMesh, GridWithBorderPathsReducesToTwoTriangles) {
  const int n = 21;
  auto part = makePartition(makeGrid(n, n), {0, n - 1, n * n - 1, n * n - n});
  const auto adj = adjacency(part.mesh);
  std::vector<char> used(n * n, 0);
  for (auto [a, b] : std::vector<Edge>{{0, 1}, {1, 2}, {2, 3}, {3, 0}, {0, 2}})
    ASSERT_TRUE(addPath(part, adj, used, a, b));
  ASSERT_EQ(part.paths[4].vertices.size(), static_cast<size_t>(n));  // the straight diagonal
  auto run = buildAndCheck(part, false);
  EXPECT_EQ(run.base.vertices, 4);
  EXPECT_EQ(run.base.faces, 2);
  EXPECT_EQ(run.base.longPaths, 0);
  EXPECT_EQ(run.base.extraVertices, 0);
}

// Features inside the grid: the annulus between the quad and the border keeps a few border
// vertices (a border loop cannot shrink below a triangle).
TEST(ProgressiveMesh, GridWithInnerQuadKeepsFewBorderVertices) {
  const int n = 21;
  auto part = makePartition(makeGrid(n, n), {4 * n + 4, 4 * n + 16, 16 * n + 16, 16 * n + 4});
  const auto adj = adjacency(part.mesh);
  std::vector<char> used(n * n, 0);
  for (auto [a, b] : std::vector<Edge>{{0, 1}, {1, 2}, {2, 3}, {3, 0}, {0, 2}})
    ASSERT_TRUE(addPath(part, adj, used, a, b));
  auto run = buildAndCheck(part, false);
  EXPECT_EQ(run.base.longPaths, 0);
  EXPECT_GE(run.base.extraVertices, 3);  // the border triangle
  EXPECT_LE(run.base.extraVertices, 6);
}

// On a flat grid the flattening is an isometry: the coordinates reproduce the removed vertex, and
// a path vertex lies on the segment of its path neighbours at the ratio of the coordinates.
TEST(ProgressiveMesh, FlatGridCoordinatesReproduceTheRemovedVertex) {
  const int n = 21;
  // Corners, the centre and a point (15, 3); the diagonal through the centre, and a staircase
  // path from the centre to (15, 3) that ends inside a cell.
  auto part = makePartition(makeGrid(n, n), {0, n - 1, n * n - 1, n * n - n, 10 * n + 10, 3 * n + 15});
  const auto adj = adjacency(part.mesh);
  std::vector<char> used(n * n, 0);
  for (auto [a, b] : std::vector<Edge>{{0, 1}, {1, 2}, {2, 3}, {3, 0}, {0, 4}, {4, 2}, {4, 5}})
    ASSERT_TRUE(addPath(part, adj, used, a, b));
  ProgressiveMesh pm(part, {}, {});
  int interior = 0, onPath = 0, straight = 0;
  for (const auto& r : pm.records()) {
    const Vec3 v = part.mesh.position(r.removed);
    Vec3 q = Vec3::Zero();
    for (size_t k = 0; k < r.ring.size(); ++k) q += r.weights[k] * part.mesh.position(r.ring[k]);
    EXPECT_LT((q - v).norm(), 1e-9) << "removed " << r.removed;
    interior += r.pathA < 0;
    if (r.pathA < 0) continue;
    ++onPath;
    const int m = static_cast<int>(r.ring.size());
    // On a straight path (the border, the diagonal) the side coordinates reproduce v in 3D too.
    const Vec3 a = part.mesh.position(r.ring[r.pathA]), b = part.mesh.position(r.ring[r.pathB]);
    if ((a - v).cross(b - v).norm() > 1e-12) continue;
    ++straight;
    for (const auto* side : {&r.left, &r.right}) {
      if (side->empty()) continue;
      const int from = side == &r.left ? r.pathA : r.pathB;
      Vec3 s = Vec3::Zero();
      for (size_t k = 0; k < side->size(); ++k) s += (*side)[k] * part.mesh.position(r.ring[(from + k) % m]);
      EXPECT_LT((s - v).norm(), 1e-9) << "removed " << r.removed;
    }
  }
  const auto& st = pm.stats();
  EXPECT_GT(interior, 100);
  EXPECT_GT(onPath, 40);
  EXPECT_GT(straight, 40);
  EXPECT_LT(straight, onPath);            // the staircase is not straight
  checkRecordCoordinates(pm, part.mesh);  // distance ratio on every path, straight or not
  EXPECT_GT(st.weights[static_cast<int>(CoordinateKind::Meyer)], 0);
  EXPECT_EQ(st.weights[static_cast<int>(CoordinateKind::MeanValue3d)], 0);  // flat: never needed
  EXPECT_EQ(st.weights[static_cast<int>(CoordinateKind::Uniform)], 0);
  EXPECT_EQ(st.sides[static_cast<int>(CoordinateKind::OnEdge)], [&] {
    int sides = 0;
    for (const auto& r : pm.records()) sides += !r.left.empty() + !r.right.empty();
    return sides;
  }());
  // Left lies left of the path direction: ring[a] comes after ring[b] along the path, and the ring
  // runs counter-clockwise from a to b through the left side.
  int checked = 0;
  for (const auto& r : pm.records()) {
    if (r.pathA < 0 || r.right.empty()) continue;
    for (const auto& path : part.paths) {
      const auto& pv = path.vertices;
      if (std::find(pv.begin() + 1, pv.end() - 1, r.removed) == pv.end() - 1) continue;
      const auto ia = std::find(pv.begin(), pv.end(), r.ring[r.pathA]) - pv.begin();
      const auto ib = std::find(pv.begin(), pv.end(), r.ring[r.pathB]) - pv.begin();
      EXPECT_GT(ia, ib) << "removed " << r.removed;
      ++checked;
    }
  }
  EXPECT_GT(checked, 10);
}

// Icosphere with the icosahedron's vertices as features and its 30 edges as paths: the base is the
// icosahedron.
TEST(ProgressiveMesh, IcosphereReducesToTheIcosahedron) {
  auto part = makePartition(makeIcosphere(4), {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11});
  connectNearest(part, 5);
  ASSERT_EQ(part.paths.size(), 30u);
  auto run = buildAndCheck(part, true);
  EXPECT_EQ(run.base.vertices, 12);
  EXPECT_EQ(run.base.faces, 20);
  EXPECT_EQ(run.base.longPaths, 0);
}

// Irregular features and paths between near ones: cells of any shape, some not closed by paths.
TEST(ProgressiveMesh, IcosphereWithScatteredFeatures) {
  auto mesh = makeIcosphere(4);
  const auto features = farthestPoints(*mesh, 10, 17);
  auto part = makePartition(std::move(mesh), features);
  connectNearest(part, 3);
  ASSERT_GE(part.paths.size(), 10u);
  auto run = buildAndCheck(part, true);
  EXPECT_EQ(run.base.longPaths, 0);
  EXPECT_LE(run.base.extraVertices, 6);
}

TEST(ProgressiveMesh, SpotWithFeatures) {
  TM_REQUIRE_SHARED(file, "meshes/spot/spot_triangulated.obj");
  auto mesh = requireUsable(loadMesh(file));
  const auto features = farthestPoints(*mesh, 12, 0);
  auto part = makePartition(std::move(mesh), features);
  connectNearest(part, 3);
  auto run = buildAndCheck(part, true);
  EXPECT_EQ(run.base.longPaths, 0);
  EXPECT_LE(run.base.extraVertices, 10);
}

// Without features everything may go, down to the smallest complex of the same topology: a
// tetrahedron for a closed sphere (one more collapse would give two faces on the same three
// vertices), one triangle for a disk (the border never merges with itself).
TEST(ProgressiveMesh, WithoutFeaturesStopsAtATetrahedronOrATriangle) {
  const std::vector<Vec3> octahedron = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  const std::vector<std::array<int, 3>> octFaces = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                                                    {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  auto oct = makePartition(requireUsable(buildMesh(octahedron, octFaces)), {});
  auto run = buildAndCheck(oct, true);
  EXPECT_EQ(run.base.vertices, 4);
  EXPECT_EQ(run.base.faces, 4);

  auto square =
      makePartition(requireUsable(buildMesh({{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}}, {{0, 1, 2}, {0, 2, 3}})), {});
  run = buildAndCheck(square, false);
  EXPECT_EQ(run.base.vertices, 3);
  EXPECT_EQ(run.base.faces, 1);

  auto grid = makePartition(makeGrid(11, 11), {});
  run = buildAndCheck(grid, false);
  EXPECT_LE(run.base.vertices, 6);
}

// A torus keeps its genus: near the end its tube is three edges around, a cycle that is no face,
// and only the link condition stops the collapse that would pinch it.
TEST(ProgressiveMesh, TorusKeepsItsGenus) {
  const int n = 24, m = 12;
  std::vector<Vec3> v;
  std::vector<std::array<int, 3>> t;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < m; ++j) {
      const double a = 2 * kPi * i / n, b = 2 * kPi * j / m;
      v.emplace_back((1 + 0.4 * std::cos(b)) * std::cos(a), (1 + 0.4 * std::cos(b)) * std::sin(a), 0.4 * std::sin(b));
      const int p = i * m + j, q = ((i + 1) % n) * m + j, r = ((i + 1) % n) * m + (j + 1) % m, s = i * m + (j + 1) % m;
      t.push_back({p, q, r});
      t.push_back({p, r, s});
    }
  auto part = makePartition(requireUsable(buildMesh(v, t)), {});
  auto run = buildAndCheck(part, true);
  EXPECT_GE(run.base.vertices, 7);  // the smallest torus triangulation
  EXPECT_LE(run.base.vertices, 20);
}

TEST(ProgressiveMesh, CancelStopsTheConstruction) {
  auto part = makePartition(makeIcosphere(4), {0, 1, 2, 3});
  std::atomic<bool> cancel{true};
  EXPECT_THROW(ProgressiveMesh(part, {}, JobControl(&cancel, nullptr)), Cancelled);
}

// ~50k faces, ~350 features: invariants and progress reports (its time is in `montage bench`).
TEST(ProgressiveMesh, LargeMeshWithProgress) {
  std::unique_ptr<Mesh> mesh;
  bool closed = true;
  const std::string armadillo = "/tmp/tm_simplify_test/data/meshes/armadillo.off";
  if (!std::filesystem::exists(armadillo) && std::filesystem::exists("/usr/share/doc/libcgal-dev/data.tar.gz"))
    test::runCommand(
        "mkdir -p /tmp/tm_simplify_test && tar -xzf /usr/share/doc/libcgal-dev/data.tar.gz -C "
        "/tmp/tm_simplify_test data/meshes/armadillo.off");
  if (std::filesystem::exists(armadillo)) {
    auto loaded = loadMesh(armadillo);
    if (loaded.report.usable()) closed = loaded.report.boundaryLoops == 0, mesh = std::move(loaded.mesh);
  }
  std::string name = mesh ? "armadillo" : "icosphere level 6";
  if (!mesh) mesh = makeIcosphere(6);
  const auto features = farthestPoints(*mesh, 350, 0);
  auto part = makePartition(std::move(mesh), features);
  const auto t0 = std::chrono::steady_clock::now();
  connectNearest(part, 3);
  const double pathSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  int progressCalls = 0;
  double lastFraction = -1;
  bool monotone = true;
  JobControl job(nullptr, [&](StageId stage, double fraction, const std::string& what) {
    EXPECT_EQ(stage, StageId::Map);
    EXPECT_EQ(what, "simplify");
    monotone &= fraction >= lastFraction;
    lastFraction = fraction;
    ++progressCalls;
  });
  std::printf("  %s: %d vertices, %d faces, %zu features, %zu paths (%.2f s)\n", name.c_str(), part.mesh.numVertices(),
              part.mesh.numFaces(), part.featureVertex.size(), part.paths.size(), pathSeconds);
  auto run = buildAndCheck(part, closed, job);
  const auto& pm = *run.pm;
  std::printf("  PM build %.3f s, %zu collapses, base %d vertices (%d not features), %d faces, %d progress calls\n",
              pm.stats().seconds, pm.records().size(), run.base.vertices, run.base.extraVertices, run.base.faces,
              progressCalls);
  EXPECT_GT(progressCalls, 5);
  EXPECT_TRUE(monotone);
  EXPECT_DOUBLE_EQ(lastFraction, 1.0);
  // A few vertices may stay where the link condition or a face turn blocks every collapse.
  EXPECT_LE(run.base.extraVertices, 10);
  EXPECT_LE(run.base.longPaths, 10);
}

}  // namespace
}  // namespace montage
