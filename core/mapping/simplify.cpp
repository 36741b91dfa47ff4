// Paper section 3.2: progressive mesh by constrained half-edge collapses (Schreiner et al. 2004) with
// the relative position of each removed vertex in its conformally flattened one-ring (Lee et al. 1998
// "z^a" map, Meyer et al. 2002 coordinates, Floater 2003 mean value fallback).
//
// Connectivity is an own face list (faces keep their ids forever, see simplify.h). Path edges and
// mesh border edges carry a label: the path id (>= 0) or kBorder for a border edge on no path. A
// collapse v -> u is legal when
//  - v is not a feature vertex and has faces;
//  - v has no labelled edge, or exactly two with the same label (one path, or the border) and u is
//    one of those two neighbours (a vertex on a path or the border only moves along it);
//  - the link condition holds (common neighbours of u and v = opposite vertices of the faces of uv)
//    and no two faces would get the same three vertices (closed tetrahedron);
//  - for each removed face (u, v, o) the edges (v, o) and (u, o), which merge, are not both labelled
//    (two paths, or a path and the border, never merge; a path never loses its last edge);
//  - no new unlabelled edge joins two vertices of one path (or of the border): such a shortcut could
//    never go away and would keep the path from shrinking to one edge;
//  - no moved face becomes degenerate or turns by more than maxNormalFlipDeg from its current or
//    its original normal.
// Under these rules labelled edges map to labelled edges of the same path, so every face stays in
// its cell and the path network keeps its topology.
#include "mapping/simplify.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <queue>

#include "base/job.h"
#include "geometry/predicates.h"
#include "io/scene.h"
#include "mapping/partition.h"

namespace montage {
namespace {

constexpr int kNoLabel = -1;
constexpr int kBorder = -2;  // a mesh border edge that is on no path
constexpr double kPi = 3.14159265358979323846;

double angle3(const Vec3& a, const Vec3& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

// Normalises to sum 1; false when that is impossible or anything is not finite and positive.
bool normalisePositive(std::vector<double>& w) {
  double sum = 0;
  for (double x : w) {
    if (!std::isfinite(x) || x <= 0) return false;
    sum += x;
  }
  if (!(sum > 0) || !std::isfinite(sum)) return false;
  for (double& x : w) x /= sum;
  return true;
}

// Mean value coordinates from the angles at the centre between consecutive spokes (alpha[j] between
// spoke j and j + 1, cyclic) and the spoke lengths (Floater 2003).
std::vector<double> meanValueFromAngles(const std::vector<double>& alpha, const std::vector<double>& r) {
  const int n = static_cast<int>(r.size());
  std::vector<double> w(n);
  for (int j = 0; j < n; ++j) w[j] = (std::tan(alpha[(j + n - 1) % n] / 2) + std::tan(alpha[j] / 2)) / r[j];
  if (!normalisePositive(w)) return {};
  return w;
}

// Flattens a one-ring (Lee et al. 1998, the "z^a" map): spoke lengths kept, angles between
// consecutive spokes scaled to sum to `total` (2 pi for a closed ring, pi for an open one whose ends
// then lie on a line through the centre, which maps to the origin).
std::vector<Vec2> flattenRing(const Vec3& c, const std::vector<Vec3>& pts, bool closed, double total,
                              std::vector<double>* angles3d = nullptr) {
  const int n = static_cast<int>(pts.size());
  const int m = closed ? n : n - 1;
  std::vector<double> theta(m);
  double sum = 0;
  for (int j = 0; j < m; ++j) sum += theta[j] = angle3(pts[j] - c, pts[(j + 1) % n] - c);
  const double s = sum > 0 ? total / sum : 0;
  std::vector<Vec2> out(n);
  double phi = 0;
  for (int j = 0; j < n; ++j) {
    if (!closed && j == n - 1) phi = total;  // exact end angle: the chord passes through the origin
    const double r = (pts[j] - c).norm();
    out[j] = Vec2(r * std::cos(phi), r * std::sin(phi));
    if (j < m) phi += s * theta[j];
  }
  if (angles3d) *angles3d = theta;
  return out;
}

}  // namespace

std::vector<double> polygonCoordinates(const std::vector<Vec2>& polygon, const Vec2& p, CoordinateKind* kind) {
  if (kind) *kind = CoordinateKind::None;
  const int n = static_cast<int>(polygon.size());
  if (n < 2) return {};
  double scale = 0;
  for (const Vec2& x : polygon) scale = std::max(scale, (x - p).norm());
  if (!(scale > 0) || !std::isfinite(scale)) return {};

  // On an edge: the edge's linear coordinates (the nearest edge within a relative tolerance).
  int best = -1;
  double bestDist = 1e-10 * scale, bestT = 0;
  for (int j = 0; j < (n == 2 ? 1 : n); ++j) {
    const Vec2 &a = polygon[j], &b = polygon[(j + 1) % n];
    const double len2 = (b - a).squaredNorm();
    const double t = len2 > 0 ? std::clamp((p - a).dot(b - a) / len2, 0.0, 1.0) : 0.0;
    const double d = (a + t * (b - a) - p).norm();
    if (d <= bestDist) best = j, bestDist = d, bestT = t;
  }
  if (best >= 0) {
    std::vector<double> w(n, 0.0);
    w[best] += 1 - bestT;
    w[(best + 1) % n] += bestT;
    if (kind) *kind = CoordinateKind::OnEdge;
    return w;
  }
  if (n < 3) return {};

  // Meyer et al. 2002: w_j = (cot(angle at x_j towards x_j-1) + cot(angle at x_j towards x_j+1)) / |p - x_j|^2,
  // both angles measured from the direction x_j -> p.
  std::vector<double> w(n);
  for (int j = 0; j < n; ++j) {
    const Vec2& x = polygon[j];
    const Vec2 toP = p - x, toPrev = polygon[(j + n - 1) % n] - x, toNext = polygon[(j + 1) % n] - x;
    const double cotPrev = toP.dot(toPrev) / std::abs(cross2(toP, toPrev));
    const double cotNext = toP.dot(toNext) / std::abs(cross2(toP, toNext));
    w[j] = (cotPrev + cotNext) / toP.squaredNorm();
  }
  if (normalisePositive(w)) {
    if (kind) *kind = CoordinateKind::Meyer;
    return w;
  }

  // Mean value coordinates: positive when every angle at p between consecutive vertices is in (0, pi).
  std::vector<double> alpha(n), r(n);
  double sum = 0;
  for (int j = 0; j < n; ++j) {
    const Vec2 a = polygon[j] - p, b = polygon[(j + 1) % n] - p;
    alpha[j] = std::atan2(cross2(a, b), a.dot(b));
    r[j] = a.norm();
    if (!(alpha[j] > 0)) return {};
    sum += alpha[j];
  }
  if (std::abs(sum - 2 * kPi) > 1e-6) return {};  // winds more than once
  w = meanValueFromAngles(alpha, r);
  if (w.empty()) return {};
  if (kind) *kind = CoordinateKind::MeanValue;
  return w;
}

namespace {

// Why a collapse is refused.
enum class Block { None, Pinned, Path, Link, Merge, Degenerate, Turn, TurnFromOriginal, Shortcut };

// The collapse search over the progressive mesh's arrays during construction.
class Simplifier {
 public:
  Simplifier(std::vector<std::array<int, 3>>& faces, std::vector<std::vector<int>>& vertexFaces,
             std::vector<std::vector<std::pair<int, int>>>& pathEdges, const std::vector<Vec3>& pos,
             const std::vector<char>& pinned, const std::vector<std::vector<std::pair<int, int>>>& pathIndex,
             const SimplifyOptions& options, SimplifyStats& stats)
      : faces_(faces),
        vertexFaces_(vertexFaces),
        pathEdges_(pathEdges),
        pos_(pos),
        pinned_(pinned),
        pathIndex_(pathIndex),
        stats_(stats),
        cosMaxTurn_(std::cos(options.maxNormalFlipDeg * kPi / 180)),
        mark_(pos.size(), 0) {
    originalNormal_.resize(faces.size());
    for (size_t f = 0; f < faces.size(); ++f) originalNormal_[f] = normal(faces[f]);
  }

  // Counter-clockwise one-ring of v from its faces; false when the faces do not form one fan.
  bool ring(int v, std::vector<int>& out, bool& closed) const {
    const auto& vf = vertexFaces_[v];
    out.clear();
    if (vf.empty()) return false;
    std::vector<std::pair<int, int>> spokes;  // (a, b) of face (v, a, b)
    spokes.reserve(vf.size());
    for (int f : vf) {
      const auto& t = faces_[f];
      const int k = t[0] == v ? 0 : t[1] == v ? 1 : 2;
      spokes.emplace_back(t[(k + 1) % 3], t[(k + 2) % 3]);
    }
    // Start at an `a` that is no face's `b` (border), else anywhere.
    int start = spokes[0].first;
    closed = true;
    for (const auto& s : spokes) {
      bool hasPrev = false;
      for (const auto& t : spokes) hasPrev |= t.second == s.first;
      if (!hasPrev) {
        if (!closed) return false;  // two fans
        start = s.first, closed = false;
      }
    }
    out.push_back(start);
    for (size_t step = 0; step < spokes.size(); ++step) {
      int next = -1;
      for (const auto& s : spokes)
        if (s.first == out.back()) next = s.second;
      if (next < 0) return false;
      out.push_back(next);
    }
    if (closed) {
      if (out.back() != out.front()) return false;
      out.pop_back();
    }
    // Every neighbour once: one fan.
    for (size_t i = 0; i < out.size(); ++i)
      for (size_t j = i + 1; j < out.size(); ++j)
        if (out[i] == out[j]) return false;
    return true;
  }

  int label(int a, int b) const {
    for (const auto& e : pathEdges_[a])
      if (e.first == b) return e.second;
    return kNoLabel;
  }

  // Checks the collapse v -> u; fills the connectivity part of the record when legal.
  Block check(int v, int u, CollapseRecord& r) {
    if (pinned_[v] || vertexFaces_[v].empty() || vertexFaces_[u].empty()) return Block::Pinned;
    bool closed = true;
    if (!ring(v, ring_, closed)) return Block::Pinned;
    const auto& pe = pathEdges_[v];
    if (pe.empty()) {
      if (!closed) return Block::Path;  // a border vertex always has its border edges labelled
    } else {
      if (pe.size() != 2 || pe[0].second != pe[1].second) return Block::Pinned;  // junction or two paths
      if (pe[0].first != u && pe[1].first != u) return Block::Path;              // only along the path
    }
    if (std::find(ring_.begin(), ring_.end(), u) == ring_.end()) return Block::Link;

    // Faces of uv disappear; the others of v move their v corner to u.
    r = CollapseRecord();
    r.removed = v, r.kept = u;
    std::vector<int> opposite;
    for (int f : vertexFaces_[v]) {
      const auto& t = faces_[f];
      int k = -1, ku = -1;
      for (int c = 0; c < 3; ++c) {
        if (t[c] == v) k = c;
        if (t[c] == u) ku = c;
      }
      if (ku >= 0) {
        r.removedFaces.push_back(f);
        opposite.push_back(t[3 - k - ku]);
      } else {
        r.movedCorners.emplace_back(f, k);
      }
    }
    if (r.removedFaces.size() != (closed ? 2u : 1u)) return Block::Link;
    if (!closed && ring_.front() != u && ring_.back() != u) return Block::Path;

    // Link condition: the common neighbours of u and v are the opposite vertices.
    ++stamp_;
    for (int x : ring_) mark_[x] = stamp_;
    int common = 0;
    for (int f : vertexFaces_[u])
      for (int x : faces_[f])
        if (x != u && x != v && mark_[x] == stamp_) mark_[x] = -stamp_, ++common;  // count once
    if (common != static_cast<int>(opposite.size())) return Block::Link;

    // Labels of merging edges (v, o) and (u, o).
    for (int o : opposite)
      if (label(v, o) != kNoLabel && label(u, o) != kNoLabel) return Block::Merge;

    // No shortcut: a new edge (u, x) on no path must not join two vertices of one path (or of the
    // border) that are not consecutive on it; it could never go away, and the link condition would
    // then keep the path from shrinking to one edge.
    const int along = pe.empty() ? -1 : (pe[0].first == u ? pe[1].first : pe[0].first);
    for (int x : ring_) {
      if (x == u || x == along || std::find(opposite.begin(), opposite.end(), x) != opposite.end()) continue;
      for (const auto& eu : pathEdges_[u])
        for (const auto& ex : pathEdges_[x])
          if (eu.second == ex.second) return Block::Shortcut;
    }

    // Moved faces: no duplicate of a face of u, no degeneracy, no flip.
    for (const auto& [f, k] : r.movedCorners) {
      auto t = faces_[f];
      const int x = t[(k + 1) % 3], y = t[(k + 2) % 3];
      for (int g : vertexFaces_[u]) {
        if (std::find(r.removedFaces.begin(), r.removedFaces.end(), g) != r.removedFaces.end()) continue;
        const auto& s = faces_[g];
        if (std::find(s.begin(), s.end(), x) != s.end() && std::find(s.begin(), s.end(), y) != s.end())
          return Block::Link;
      }
      const Vec3 before = normal(t);
      t[k] = u;
      const Vec3 after = normal(t);
      const double len = after.norm();
      double maxEdge2 = 0;
      for (int c = 0; c < 3; ++c) maxEdge2 = std::max(maxEdge2, (pos_[t[c]] - pos_[t[(c + 1) % 3]]).squaredNorm());
      if (!(len > 1e-8 * maxEdge2)) return Block::Degenerate;
      if (!turnOk(after, len, before)) return Block::Turn;
      if (!turnOk(after, len, originalNormal_[f])) return Block::TurnFromOriginal;
    }
    ringClosed_ = closed;
    return Block::None;
  }

  // The geometric part of the record (section 3.2): ring, coordinates, path split.
  void fillCoordinates(CollapseRecord& r) {
    const int v = r.removed;
    const Vec3 c = pos_[v];
    r.ring = ring_;
    const int n = static_cast<int>(ring_.size());
    std::vector<Vec3> pts(n);
    for (int j = 0; j < n; ++j) pts[j] = pos_[ring_[j]];
    auto indexOf = [&](int x) { return static_cast<int>(std::find(ring_.begin(), ring_.end(), x) - ring_.begin()); };

    if (ringClosed_) {
      std::vector<double> angles;
      const auto flat = flattenRing(c, pts, true, 2 * kPi, &angles);
      CoordinateKind kind;
      r.weights = polygonCoordinates(flat, Vec2::Zero(), &kind);
      if (r.weights.empty()) {
        // Not star-shaped once flattened (a spoke angle scaled to pi or more): mean value
        // coordinates with the 3D angles, each below pi, hence positive.
        std::vector<double> radii(n);
        for (int j = 0; j < n; ++j) radii[j] = (pts[j] - c).norm();
        r.weights = meanValueFromAngles(angles, radii);
        kind = CoordinateKind::MeanValue3d;
      }
      if (r.weights.empty()) r.weights.assign(n, 1.0 / n), kind = CoordinateKind::Uniform;
      ++stats_.weights[static_cast<int>(kind)];
    }
    if (pathEdges_[v].empty()) return;

    if (!ringClosed_) {
      r.pathA = 0, r.pathB = n - 1;
    } else {
      // Path direction: the neighbour further along MeshPath::vertices is `a` (left = ring[a..b]).
      const int p = pathEdges_[v][0].second;
      const int x = pathEdges_[v][0].first, y = pathEdges_[v][1].first;
      const int iv = positionOnPath(v, p);
      int ix = positionOnPath(x, p), iy = positionOnPath(y, p);
      bool xAfter = true;
      if (ix >= 0 && ix != iv)
        xAfter = ix > iv;
      else if (iy >= 0 && iy != iv)
        xAfter = iy < iv;
      r.pathA = indexOf(xAfter ? x : y);
      r.pathB = indexOf(xAfter ? y : x);
    }
    r.left = sideCoordinates(c, pts, r.pathA, r.pathB);
    if (ringClosed_)
      r.right = sideCoordinates(c, pts, r.pathB, r.pathA);
    else
      r.weights = r.left, ++stats_.weights[static_cast<int>(CoordinateKind::OnEdge)];
  }

  Vec3 normal(const std::array<int, 3>& t) const { return (pos_[t[1]] - pos_[t[0]]).cross(pos_[t[2]] - pos_[t[0]]); }

 private:
  bool turnOk(const Vec3& after, double afterLen, const Vec3& reference) const {
    const double refLen = reference.norm();
    if (!(refLen > 0)) return true;  // a zero-area reference has no direction
    return after.dot(reference) >= cosMaxTurn_ * afterLen * refLen;
  }

  // Index of x on path p, or -1 when x is on it ambiguously (a closed path's end) or not at all.
  int positionOnPath(int x, int p) const {
    int found = -1, count = 0;
    for (const auto& [path, index] : pathIndex_[x])
      if (path == p) found = index, ++count;
    return count == 1 ? found : -1;
  }

  // Coordinates of the centre over the sub-polygon ring[a..b] (cyclic), flattened with its angles
  // scaled to pi: the ends lie on a line through the centre, which then lies on the closing edge
  // and gets that edge's linear coordinates (distance ratio of the two path neighbours).
  std::vector<double> sideCoordinates(const Vec3& c, const std::vector<Vec3>& pts, int a, int b) {
    const int n = static_cast<int>(pts.size());
    std::vector<Vec3> sub;
    for (int j = a;; j = (j + 1) % n) {
      sub.push_back(pts[j]);
      if (j == b) break;
    }
    const auto flat = flattenRing(c, sub, false, kPi);
    CoordinateKind kind;
    auto w = polygonCoordinates(flat, Vec2::Zero(), &kind);
    if (w.empty()) {  // not reached: the origin is on the chord by construction
      const int m = static_cast<int>(sub.size());
      w.assign(m, 1.0 / m);
      kind = CoordinateKind::Uniform;
    }
    ++stats_.sides[static_cast<int>(kind)];
    return w;
  }

  std::vector<std::array<int, 3>>& faces_;
  std::vector<std::vector<int>>& vertexFaces_;
  std::vector<std::vector<std::pair<int, int>>>& pathEdges_;
  const std::vector<Vec3>& pos_;
  const std::vector<char>& pinned_;
  const std::vector<std::vector<std::pair<int, int>>>& pathIndex_;
  SimplifyStats& stats_;
  double cosMaxTurn_;
  std::vector<Vec3> originalNormal_;
  std::vector<int> mark_;
  int stamp_ = 0;
  std::vector<int> ring_;
  bool ringClosed_ = true;
};

void eraseValue(std::vector<int>& list, int value) {
  auto it = std::find(list.begin(), list.end(), value);
  TM_ASSERT(it != list.end());
  *it = list.back();
  list.pop_back();
}

void eraseNeighbour(std::vector<std::pair<int, int>>& list, int neighbour) {
  auto it = std::find_if(list.begin(), list.end(), [&](const auto& e) { return e.first == neighbour; });
  TM_ASSERT(it != list.end());
  *it = list.back();
  list.pop_back();
}

}  // namespace

SimplifyInput simplifyInput(const Partition& partition) {
  const Mesh& mesh = partition.mesh;
  SimplifyInput in;
  in.positions.resize(mesh.numVertices());
  for (int v = 0; v < mesh.numVertices(); ++v) in.positions[v] = mesh.position(v);
  in.faces.resize(mesh.numFaces());
  for (int f = 0; f < mesh.numFaces(); ++f) in.faces[f] = mesh.faceVertices(f);
  in.pinned.assign(mesh.numVertices(), 0);
  for (int v : partition.featureVertex)
    if (v >= 0 && v < mesh.numVertices()) in.pinned[v] = 1;
  for (const MeshPath& path : partition.paths) in.paths.push_back(path.vertices);
  return in;
}

ProgressiveMesh::ProgressiveMesh(const SimplifyInput& input, const SimplifyOptions& options, const JobControl& job) {
  const auto start = std::chrono::steady_clock::now();
  const int nv = static_cast<int>(input.positions.size()), nf = static_cast<int>(input.faces.size());
  const std::vector<Vec3>& pos = input.positions;
  faces_.resize(nf);
  faceAlive_.assign(nf, 1);
  vertexAlive_.assign(nv, 1);
  vertexFaces_.assign(nv, {});
  pathEdges_.assign(nv, {});
  for (int f = 0; f < nf; ++f) {
    faces_[f] = input.faces[f];
    for (int v : faces_[f]) {
      TM_ASSERT(v >= 0 && v < nv);
      vertexFaces_[v].push_back(f);
    }
  }
  std::vector<char> isFeature(nv, 0);
  if (!input.pinned.empty()) {
    TM_ASSERT(static_cast<int>(input.pinned.size()) == nv);
    isFeature = input.pinned;
  }
  std::vector<char> pinned = isFeature;  // feature vertices and vertices whose faces are not one fan

  // Path edges (section 3.1 paths) with their path id; vertex positions along each path.
  std::vector<std::vector<std::pair<int, int>>> pathIndex(nv);
  auto adjacent = [&](int a, int b) {
    for (int f : vertexFaces_[a])
      for (int x : faces_[f])
        if (x == b) return true;
    return false;
  };
  for (int p = 0; p < static_cast<int>(input.paths.size()); ++p) {
    const auto& pv = input.paths[p];
    for (int i = 0; i < static_cast<int>(pv.size()); ++i) {
      TM_ASSERT(pv[i] >= 0 && pv[i] < nv);
      pathIndex[pv[i]].emplace_back(p, i);
      if (i == 0) continue;
      const int a = pv[i - 1], b = pv[i];
      TM_ASSERT(a != b && adjacent(a, b));
      TM_ASSERT(pathOfEdge(a, b) < 0);  // no edge on two paths
      pathEdges_[a].emplace_back(b, p);
      pathEdges_[b].emplace_back(a, p);
    }
  }

  Simplifier s(faces_, vertexFaces_, pathEdges_, pos, pinned, pathIndex, options, stats_);
  // Border edges act like paths; a vertex whose faces are not one fan never moves.
  std::vector<int> ring;
  for (int v = 0; v < nv; ++v) {
    bool closed = true;
    if (vertexFaces_[v].empty()) continue;
    if (!s.ring(v, ring, closed)) {
      pinned[v] = 1;
      continue;
    }
    if (closed) continue;
    for (int x : {ring.front(), ring.back()})
      if (s.label(v, x) == kNoLabel) pathEdges_[v].emplace_back(x, kBorder);
  }

  // Shortest half-edge first. Positions never change and an edge between two alive vertices never
  // disappears, so each half-edge is queued once; one found illegal is parked at both ends and
  // queued again when the neighbourhood of either end changes.
  struct Candidate {
    double length;
    int v, u;
    bool operator<(const Candidate& o) const { return length > o.length; }
  };
  std::priority_queue<Candidate> queue;
  std::vector<Candidate> parked;               // by park id
  std::vector<char> parkedWaiting;             // by park id: not queued again yet
  std::vector<std::vector<int>> parkedAt(nv);  // park ids per end vertex
  // A vertex that can ever move: static, as collapses keep the labelled edges of a vertex (two of
  // one path or of the border, or none).
  std::vector<char> movable(nv, 0);
  int movableCount = 0;
  for (int v = 0; v < nv; ++v) {
    const auto& pe = pathEdges_[v];
    movable[v] =
        !pinned[v] && !vertexFaces_[v].empty() && (pe.empty() || (pe.size() == 2 && pe[0].second == pe[1].second));
    movableCount += movable[v];
  }
  auto push = [&](int v, int u) {
    if (movable[v]) queue.push({(pos[v] - pos[u]).norm(), v, u});
  };
  std::vector<int> seen(nv, -1);
  for (int v = 0; v < nv; ++v) {
    if (!movable[v]) continue;
    for (int f : vertexFaces_[v])
      for (int x : faces_[f])
        if (x != v && seen[x] != v) seen[x] = v, push(v, x);
  }

  CollapseRecord record;
  std::vector<int> opposite;
  while (!queue.empty()) {
    const Candidate c = queue.top();
    queue.pop();
    if (!vertexAlive_[c.v] || !vertexAlive_[c.u]) continue;
    if (s.check(c.v, c.u, record) != Block::None) {
      const int id = static_cast<int>(parked.size());
      parked.push_back(c);
      parkedWaiting.push_back(1);
      parkedAt[c.v].push_back(id);
      parkedAt[c.u].push_back(id);
      continue;
    }
    s.fillCoordinates(record);
    records_.push_back(std::move(record));
    apply(records_.back());
    const auto& r = records_.back();
    // The ring of the removed vertex (the kept one included) changed: its parked half-edges are
    // queued again; the edges (u, x) that did not exist before are queued for the first time.
    for (int x : r.ring) {
      for (int id : parkedAt[x])
        if (parkedWaiting[id]) {
          parkedWaiting[id] = 0;
          if (vertexAlive_[parked[id].v] && vertexAlive_[parked[id].u]) queue.push(parked[id]);
        }
      parkedAt[x].clear();
    }
    opposite.clear();
    for (int f : r.removedFaces)
      for (int x : faces_[f])
        if (x != r.removed && x != r.kept) opposite.push_back(x);
    for (int x : r.ring)
      if (x != r.kept && std::find(opposite.begin(), opposite.end(), x) == opposite.end()) {
        push(r.kept, x);
        push(x, r.kept);
      }
    if (records_.size() % 2000 == 0) {
      job.checkCancel();
      job.progress(StageId::Map, std::min(0.99, static_cast<double>(records_.size()) / std::max(1, movableCount)),
                   "simplify");
    }
  }
  level_ = static_cast<int>(records_.size());
  for (int v = 0; v < nv; ++v) stats_.baseExtraVertices += vertexAlive_[v] && !vertexFaces_[v].empty() && !isFeature[v];
  stats_.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  job.progress(StageId::Map, 1.0, "simplify");
}

void ProgressiveMesh::apply(const CollapseRecord& r) {
  const int v = r.removed, u = r.kept;
  for (int f : r.removedFaces) {
    faceAlive_[f] = 0;
    for (int x : faces_[f])
      if (x != v) eraseValue(vertexFaces_[x], f);
  }
  for (const auto& [f, k] : r.movedCorners) {
    faces_[f][k] = u;
    vertexFaces_[u].push_back(f);
  }
  vertexFaces_[v].clear();
  vertexAlive_[v] = 0;
  // The path (border) edge (v, w) becomes (u, w); (v, u) disappears.
  if (!pathEdges_[v].empty()) {
    int w = -1, label = kNoLabel;
    for (const auto& [x, l] : pathEdges_[v]) {
      eraseNeighbour(pathEdges_[x], v);
      if (x != u) w = x, label = l;
    }
    TM_ASSERT(w >= 0);
    pathEdges_[u].emplace_back(w, label);
    pathEdges_[w].emplace_back(u, label);
    pathEdges_[v].clear();
  }
}

void ProgressiveMesh::undo(const CollapseRecord& r) {
  const int v = r.removed, u = r.kept;
  for (auto it = r.movedCorners.rbegin(); it != r.movedCorners.rend(); ++it) {
    faces_[it->first][it->second] = v;
    eraseValue(vertexFaces_[u], it->first);
    vertexFaces_[v].push_back(it->first);
  }
  for (int f : r.removedFaces) {
    faceAlive_[f] = 1;
    for (int x : faces_[f]) vertexFaces_[x].push_back(f);
  }
  vertexAlive_[v] = 1;
  if (r.pathA >= 0) {
    const int a = r.ring[r.pathA], b = r.ring[r.pathB];
    const int w = a == u ? b : a;
    int label = kNoLabel;
    for (const auto& [x, l] : pathEdges_[u])
      if (x == w) label = l;
    TM_ASSERT(label != kNoLabel);
    eraseNeighbour(pathEdges_[u], w);
    eraseNeighbour(pathEdges_[w], u);
    for (int x : {a, b}) {
      pathEdges_[v].emplace_back(x, label);
      pathEdges_[x].emplace_back(v, label);
    }
  }
}

const CollapseRecord& ProgressiveMesh::split() {
  TM_ASSERT(level_ > 0);
  const CollapseRecord& r = records_[--level_];
  undo(r);
  return r;
}

const CollapseRecord& ProgressiveMesh::collapse() {
  TM_ASSERT(level_ < static_cast<int>(records_.size()));
  const CollapseRecord& r = records_[level_++];
  apply(r);
  return r;
}

int ProgressiveMesh::aliveFaces() const {
  return static_cast<int>(std::count(faceAlive_.begin(), faceAlive_.end(), 1));
}

int ProgressiveMesh::aliveVertices() const {
  return static_cast<int>(std::count(vertexAlive_.begin(), vertexAlive_.end(), 1));
}

int ProgressiveMesh::pathOfEdge(int a, int b) const {
  if (a < 0 || a >= numVertices()) return -1;
  for (const auto& [x, l] : pathEdges_[a])
    if (x == b) return l >= 0 ? l : -1;
  return -1;
}

}  // namespace montage
