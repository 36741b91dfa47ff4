#include "surface/inpaint.h"

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <queue>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <unordered_map>

#include "base/job.h"
#include "base/util.h"
#include "geometry/mesh.h"
#include "geometry/predicates.h"
#include "image/photo.h"
#include "io/scene.h"
#include "surface/surface_synthesis.h"
#include "surface/synthesis.h"

namespace montage {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Longest-edge bisection down to edges of `kEdgePerTexel / density` gives one to one and a half refined
// vertices per texel (measured on flat holes, tm_inpaint_bench and the inpaint tests).
constexpr double kEdgePerTexel = 1.5;
// Refined vertices per unit area for edges no longer than h: at most 3.5 / h^2 (same measurement), the
// estimate behind maxInpaintVertices.
constexpr double kVerticesPerEdgeArea = 3.5;

uint64_t edgeKey(int a, int b) {
  if (a > b) std::swap(a, b);
  return (uint64_t(uint32_t(a)) << 32) | uint32_t(b);
}

// The refinement's edges (edgeKey of two non-negative vertices) with their one or two triangles, in one
// open-addressing table: std::unordered_map's node per edge and its lookups were a tenth of a lioness
// run's samples.
class EdgeTable {
 public:
  using Faces = std::array<int, 2>;  // the triangles on the edge, -1 when fewer
  explicit EdgeTable(size_t expected) { rehash(expected); }

  Faces* find(uint64_t key) {
    for (size_t i = slot(key);; i = (i + 1) & mask_) {
      if (keys_[i] == key) return &faces_[i];
      if (keys_[i] == kFree) return nullptr;
    }
  }
  // The edge's entry, added ({-1, -1}) when missing.
  Faces& insert(uint64_t key) {
    size_t tomb = SIZE_MAX, i = slot(key);
    for (;; i = (i + 1) & mask_) {
      if (keys_[i] == key) return faces_[i];
      if (keys_[i] == kFree) break;
      if (keys_[i] == kErased && tomb == SIZE_MAX) tomb = i;
    }
    if (tomb != SIZE_MAX) {
      i = tomb, --erased_;
    } else if (4 * (used_ + erased_ + 1) > 3 * keys_.size()) {  // 3/4 full: grow (keeps the live edges)
      rehash(2 * used_ + 2);
      return insert(key);
    }
    keys_[i] = key, faces_[i] = {-1, -1}, ++used_;
    return faces_[i];
  }
  void erase(uint64_t key) {
    if (Faces* f = find(key)) {
      keys_[static_cast<size_t>(f - faces_.data())] = kErased;
      --used_, ++erased_;
    }
  }
  std::vector<uint64_t> keys() const {
    std::vector<uint64_t> out;
    out.reserve(used_);
    for (uint64_t k : keys_)
      if (k != kFree && k != kErased) out.push_back(k);
    return out;
  }

 private:
  static constexpr uint64_t kFree = ~uint64_t(0), kErased = ~uint64_t(0) - 1;  // no vertex is 0xffffffff
  size_t slot(uint64_t key) const { return size_t((key * 0x9E3779B97F4A7C15ull) >> shift_) & mask_; }
  void rehash(size_t expected) {
    std::vector<uint64_t> oldKeys = std::move(keys_);
    std::vector<Faces> oldFaces = std::move(faces_);
    size_t capacity = 16;
    int bits = 4;
    while (3 * capacity < 4 * expected) capacity *= 2, ++bits;
    keys_.assign(capacity, kFree);
    faces_.assign(capacity, {-1, -1});
    mask_ = capacity - 1, shift_ = 64 - bits, used_ = erased_ = 0;
    for (size_t i = 0; i < oldKeys.size(); ++i)
      if (oldKeys[i] != kFree && oldKeys[i] != kErased) insert(oldKeys[i]) = oldFaces[i];
  }
  std::vector<uint64_t> keys_;
  std::vector<Faces> faces_;
  size_t mask_ = 0, used_ = 0, erased_ = 0;
  int shift_ = 0;
};

// Vertex adjacency of a triangle mesh in compressed rows (an edge appears once per triangle using it,
// which Dijkstra does not mind), with edge lengths.
struct Graph {
  std::vector<int> start, next;
  std::vector<float> length;
};

Graph buildGraph(const TriangleMesh& m) {
  Graph g;
  g.start.assign(m.numVertices() + 1, 0);
  for (const auto& t : m.triangles)
    for (int v : t) g.start[v + 1] += 2;
  std::partial_sum(g.start.begin(), g.start.end(), g.start.begin());
  g.next.resize(g.start.back());
  g.length.resize(g.start.back());
  std::vector<int> fill(g.start.begin(), g.start.end() - 1);
  for (const auto& t : m.triangles)
    for (int k = 0; k < 3; ++k) {
      const int a = t[k], b = t[(k + 1) % 3];
      const float len = float((m.positions[a] - m.positions[b]).norm());
      g.next[fill[a]] = b, g.length[fill[a]++] = len;
      g.next[fill[b]] = a, g.length[fill[b]++] = len;
    }
  return g;
}

// Dijkstra over the vertices v with allowed[v], reusing its buffers between runs so that many short
// runs (RBF centres with a cut-off radius) cost only what they visit.
class Dijkstra {
 public:
  Dijkstra(const Graph& g, const std::vector<char>& allowed)
      : g_(g), allowed_(allowed), dist_(allowed.size(), kInf), origin_(allowed.size(), -1) {}

  // Multi-source run up to maxDist; visit(vertex, distance, source index) for every settled vertex.
  template <class Visit>
  void run(const std::vector<int>& sources, double maxDist, Visit&& visit) {
    for (int v : touched_) dist_[v] = kInf, origin_[v] = -1;
    touched_.clear();
    using Item = std::pair<double, int>;
    std::priority_queue<Item, std::vector<Item>, std::greater<>> heap;
    for (int s = 0; s < static_cast<int>(sources.size()); ++s) {
      const int v = sources[s];
      if (!allowed_[v] || dist_[v] == 0) continue;
      dist_[v] = 0, origin_[v] = s;
      touched_.push_back(v);
      heap.emplace(0.0, v);
    }
    while (!heap.empty()) {
      const auto [d, v] = heap.top();
      heap.pop();
      if (d > dist_[v]) continue;
      visit(v, d, origin_[v]);
      for (int i = g_.start[v]; i < g_.start[v + 1]; ++i) {
        const int w = g_.next[i];
        const double nd = d + g_.length[i];
        if (!allowed_[w] || nd >= dist_[w] || nd > maxDist) continue;
        if (dist_[w] == kInf) touched_.push_back(w);
        dist_[w] = nd, origin_[w] = origin_[v];
        heap.emplace(nd, w);
      }
    }
  }

 private:
  const Graph& g_;
  const std::vector<char>& allowed_;
  std::vector<double> dist_;
  std::vector<int> origin_;
  std::vector<int> touched_;
};

// Per-vertex Laplacian of colours, Delta f = -(L f) / A (poisson.h's sign convention).
Eigen::MatrixXd laplacianOf(const TriangleMesh& m, const Eigen::MatrixXd& f) {
  const Eigen::VectorXd area = vertexAreas(m);
  Eigen::MatrixXd lap = -(cotangentLaplacian(m) * f);
  for (int v = 0; v < m.numVertices(); ++v) lap.row(v) /= std::max(area[v], 1e-300);
  return lap;
}

// Keeps a guided fill f inside the per-channel range [lo, hi] of the fixed (border) values: see
// GuidanceBound. `harmonic` is the fill with d = 0, inside the range by the maximum principle.
void boundFill(GuidanceBound bound, const std::vector<char>& fixed, const Eigen::MatrixXd& fixedValues,
               const Eigen::MatrixXd& harmonic, Eigen::MatrixXd& f) {
  if (bound == GuidanceBound::None) return;
  const int n = static_cast<int>(fixed.size());
  Eigen::RowVector3d lo = Eigen::RowVector3d::Constant(kInf), hi = Eigen::RowVector3d::Constant(-kInf);
  for (int v = 0; v < n; ++v)
    if (fixed[v]) lo = lo.cwiseMin(fixedValues.row(v)), hi = hi.cwiseMax(fixedValues.row(v));
  if (!(lo[0] < kInf)) return;
  for (int c = 0; c < 3; ++c) {
    double scale = 1;
    for (int v = 0; v < n; ++v) {
      if (fixed[v]) continue;
      const double h = std::clamp(harmonic(v, c), lo[c], hi[c]), g = f(v, c) - h;
      const double room = g > 0 ? hi[c] - h : h - lo[c];
      switch (bound) {
        case GuidanceBound::Clamp:
          f(v, c) = std::clamp(f(v, c), lo[c], hi[c]);
          break;
        case GuidanceBound::Scale:
          if (std::abs(g) > room) scale = std::min(scale, room / std::abs(g));
          break;
        case GuidanceBound::Soft:
          f(v, c) = h + (room > 0 ? room * std::tanh(g / room) : 0.0);
          break;
        case GuidanceBound::None:
          break;
      }
    }
    if (bound == GuidanceBound::Scale)
      for (int v = 0; v < n; ++v)
        if (!fixed[v]) f(v, c) = harmonic(v, c) + scale * (f(v, c) - harmonic(v, c));
  }
}

// ---------------------------------------------------------------------------------------------
// Guidance fields (paper section 5), on one region's sub-mesh. `fixed` marks the Dirichlet vertices;
// `boundaryD` holds, for fixed vertices next to the region, the boundary value of d (the Laplacian of
// the outside colours at the closest outer refined vertex); rows of other vertices are unused.

// Gaussian RBF interpolation of the boundary d over Dijkstra distances inside the region. The boundary
// values are averaged over the boundary vertices nearest to each of at most `maxCentres` centres
// (farthest-point samples): this keeps the dense RBF system small and averages out texture noise in
// single-texel Laplacians.
Eigen::MatrixXd rbfGuidance(const SubMesh& sub, const Graph& graph, const std::vector<char>& isBoundary,
                            const Eigen::MatrixXd& boundaryD, int maxCentres) {
  const int nv = sub.mesh.numVertices();
  Eigen::MatrixXd d = Eigen::MatrixXd::Zero(nv, 3);
  std::vector<int> boundary;
  for (int v = 0; v < nv; ++v)
    if (isBoundary[v]) boundary.push_back(v);
  if (boundary.empty()) return d;
  const auto& P = sub.mesh.positions;

  // Farthest-point centres (Euclidean; the boundary is a curve, so this spaces them along it).
  std::vector<int> centres{boundary[0]};
  std::vector<double> nearest(boundary.size(), kInf);
  std::vector<int> owner(boundary.size(), 0);
  while (true) {
    const int c = static_cast<int>(centres.size()) - 1;
    size_t far = 0;
    for (size_t i = 0; i < boundary.size(); ++i) {
      const double dd = (P[boundary[i]] - P[centres[c]]).squaredNorm();
      if (dd < nearest[i]) nearest[i] = dd, owner[i] = c;
      if (nearest[i] > nearest[far]) far = i;
    }
    if (static_cast<int>(centres.size()) >= maxCentres || nearest[far] == 0) break;
    centres.push_back(boundary[far]);
  }
  const int K = static_cast<int>(centres.size());
  Eigen::MatrixXd value = Eigen::MatrixXd::Zero(K, 3);
  Eigen::VectorXd count = Eigen::VectorXd::Zero(K);
  for (size_t i = 0; i < boundary.size(); ++i) value.row(owner[i]) += boundaryD.row(boundary[i]), count[owner[i]] += 1;
  for (int c = 0; c < K; ++c) value.row(c) /= std::max(count[c], 1.0);

  // Kernel width: 0.7 x the median spacing of the centres (or the region's size for one centre). Wider
  // kernels make the interpolation matrix nearly singular: its weights then alternate wildly and d
  // overshoots between centres (spot cut-outs: mean Delta E 184 at 1.5 x, 98.5 at 0.7 x; harmonic 97.9).
  constexpr double kSigmaPerSpacing = 0.7;
  std::vector<double> spacing;
  for (int a = 0; a < K; ++a) {
    double best = kInf;
    for (int b = 0; b < K; ++b)
      if (b != a) best = std::min(best, (P[centres[a]] - P[centres[b]]).norm());
    if (best < kInf) spacing.push_back(best);
  }
  double sigma;
  if (spacing.empty()) {
    Vec3 lo = P[0], hi = P[0];
    for (const Vec3& p : P) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    sigma = 0.5 * (hi - lo).norm();
  } else {
    std::nth_element(spacing.begin(), spacing.begin() + spacing.size() / 2, spacing.end());
    sigma = kSigmaPerSpacing * spacing[spacing.size() / 2];
  }
  sigma = std::max(sigma, 1e-12);

  std::vector<char> all(nv, 1);
  Dijkstra dijkstra(graph, all);
  Eigen::MatrixXd phi = Eigen::MatrixXd::Zero(K, K);
  std::vector<int> centreIndex(nv, -1);
  for (int c = 0; c < K; ++c) centreIndex[centres[c]] = c;
  std::vector<std::vector<std::pair<int, float>>> reach(K);
  for (int c = 0; c < K; ++c)
    dijkstra.run({centres[c]}, 3 * sigma, [&](int v, double dist, int) {
      const double w = std::exp(-(dist * dist) / (sigma * sigma));
      reach[c].emplace_back(v, float(w));
      if (centreIndex[v] >= 0) phi(c, centreIndex[v]) = w;
    });
  // Dijkstra distances are symmetric, but keep the system exactly so; a small ridge keeps it regular.
  phi = 0.5 * (phi + phi.transpose());
  phi.diagonal().array() += 1e-3;
  const Eigen::MatrixXd weights = phi.colPivHouseholderQr().solve(value);
  for (int c = 0; c < K; ++c)
    for (const auto& [v, w] : reach[c]) d.row(v) += w * weights.row(c);
  return d;
}

// Stroke guidance: an RBF-interpolated direction field from the strokes' vectors, then for every
// unknown vertex the flow line traced forward and backward to the region's border; d is the boundary
// d at the two ends, weighted by distance along the line (the nearer end counts more).
struct StrokeSample {
  int vertex;  // local vertex
  Vec3 direction;
};

struct FlowStats {
  int traced = 0, bothEnds = 0, oneEnd = 0, noEnd = 0;
};

Eigen::MatrixXd strokeGuidance(const SubMesh& sub, const Graph& graph, const std::vector<char>& fixed,
                               const Eigen::MatrixXd& boundaryD, const std::vector<StrokeSample>& samples,
                               FlowStats& stats) {
  const TriangleMesh& m = sub.mesh;
  const int nv = m.numVertices(), nt = m.numTriangles();
  const auto& P = m.positions;

  // Vertex normals (area weighted) for the tangent planes.
  std::vector<Vec3> normal(nv, Vec3::Zero());
  std::vector<Vec3> triNormal(nt);
  for (int t = 0; t < nt; ++t) {
    const auto& tri = m.triangles[t];
    const Vec3 n = (P[tri[1]] - P[tri[0]]).cross(P[tri[2]] - P[tri[0]]);
    triNormal[t] = n.normalized();
    for (int v : tri) normal[v] += n;
  }
  for (Vec3& n : normal) n.normalize();

  // Direction field: normalised Gaussian RBF of the stroke vectors over Dijkstra distances (the
  // normalisation keeps it non-vanishing away from the strokes), projected onto the tangent plane.
  std::vector<char> all(nv, 1);
  Dijkstra dijkstra(graph, all);
  std::vector<std::vector<double>> dist(samples.size(), std::vector<double>(nv, kInf));
  double diameter = 0;
  for (size_t s = 0; s < samples.size(); ++s)
    dijkstra.run({samples[s].vertex}, kInf, [&](int v, double d, int) {
      dist[s][v] = d;
      diameter = std::max(diameter, d);
    });
  const double sigma = std::max(diameter / 3, 1e-12);
  std::vector<Vec3> field(nv, Vec3::Zero());
  for (int v = 0; v < nv; ++v) {
    Vec3 sum = Vec3::Zero();
    int nearest = -1;
    for (size_t s = 0; s < samples.size(); ++s) {
      if (dist[s][v] == kInf) continue;
      sum += std::exp(-std::pow(dist[s][v] / sigma, 2)) * samples[s].direction;
      if (nearest < 0 || dist[s][v] < dist[nearest][v]) nearest = static_cast<int>(s);
    }
    if (sum.squaredNorm() < 1e-30 && nearest >= 0) sum = samples[nearest].direction;
    sum -= sum.dot(normal[v]) * normal[v];
    field[v] = sum.norm() > 1e-12 ? Vec3(sum.normalized()) : Vec3::Zero();
  }

  // Triangle neighbours across each edge (edge k is opposite corner k), and triangles per vertex.
  std::vector<std::array<int, 3>> across(nt, {-1, -1, -1});
  {
    std::unordered_map<uint64_t, std::pair<int, int>> open;  // edge -> (triangle, corner)
    open.reserve(size_t(nt) * 2);
    for (int t = 0; t < nt; ++t)
      for (int k = 0; k < 3; ++k) {
        const uint64_t key = edgeKey(m.triangles[t][(k + 1) % 3], m.triangles[t][(k + 2) % 3]);
        auto [it, fresh] = open.emplace(key, std::make_pair(t, k));
        if (!fresh) {
          across[t][k] = it->second.first;
          across[it->second.first][it->second.second] = t;
        }
      }
  }
  std::vector<std::vector<int>> around(nv);
  for (int t = 0; t < nt; ++t)
    for (int v : m.triangles[t]) around[v].push_back(t);

  // Barycentric velocity of a 3D direction in triangle t (the part in its plane).
  auto baryVelocity = [&](int t, const Vec3& dir) {
    const auto& tri = m.triangles[t];
    const Vec3 e1 = P[tri[1]] - P[tri[0]], e2 = P[tri[2]] - P[tri[0]];
    const double a = e1.dot(e1), b = e1.dot(e2), c = e2.dot(e2), det = a * c - b * b;
    if (!(det > 1e-30)) return Vec3(Vec3::Zero());
    const double r1 = e1.dot(dir), r2 = e2.dot(dir);
    const double x = (c * r1 - b * r2) / det, y = (a * r2 - b * r1) / det;
    return Vec3(-x - y, x, y);
  };
  auto directionAt = [&](int t, const Vec3& bary, double sign) {
    const auto& tri = m.triangles[t];
    Vec3 dir = bary[0] * field[tri[0]] + bary[1] * field[tri[1]] + bary[2] * field[tri[2]];
    dir -= dir.dot(triNormal[t]) * triNormal[t];
    return Vec3(sign * dir);
  };

  const int maxSteps = 20 * static_cast<int>(std::sqrt(double(nt))) + 100;
  // Traces from vertex v; returns true with the boundary d and the line's length at its end.
  auto trace = [&](int v, double sign, Eigen::RowVectorXd& endD, double& length) {
    // The starting triangle: the one around v into which the direction points.
    int t = -1;
    Vec3 bary, db;
    for (int cand : around[v]) {
      const int corner = m.triangles[cand][0] == v ? 0 : (m.triangles[cand][1] == v ? 1 : 2);
      Vec3 b = Vec3::Zero();
      b[corner] = 1;
      const Vec3 vel = baryVelocity(cand, directionAt(cand, b, sign));
      if (vel[(corner + 1) % 3] >= 0 && vel[(corner + 2) % 3] >= 0 && vel[corner] < 0) {
        t = cand, bary = b, db = vel;
        break;
      }
    }
    if (t < 0) return false;
    length = 0;
    for (int step = 0; step < maxSteps; ++step) {
      if (step > 0) db = baryVelocity(t, directionAt(t, bary, sign));
      double exitT = kInf;
      int exitK = -1;
      for (int k = 0; k < 3; ++k)
        if (db[k] < -1e-15) {
          const double s = std::max(bary[k], 0.0) / -db[k];
          if (s < exitT) exitT = s, exitK = k;
        }
      if (exitK < 0) return false;  // the field vanishes or turns back inside this triangle
      const auto& tri = m.triangles[t];
      const Vec3 step3 = exitT * (db[0] * P[tri[0]] + db[1] * P[tri[1]] + db[2] * P[tri[2]]);
      length += step3.norm();
      bary += exitT * db;
      bary[exitK] = 0;
      bary = bary.cwiseMax(0.0);
      bary /= std::max(bary.sum(), 1e-300);
      const int a = tri[(exitK + 1) % 3], b = tri[(exitK + 2) % 3];
      const double wa = bary[(exitK + 1) % 3], wb = bary[(exitK + 2) % 3];
      const int next = across[t][exitK];
      if (next < 0) {
        // Reached the region's border. Its d is that of the fixed end(s) of the edge crossed.
        const bool fa = fixed[a], fb = fixed[b];
        if (!fa && !fb) return false;  // an open border of the mesh: no colour to continue
        if (fa && fb)
          endD = (wa * boundaryD.row(a) + wb * boundaryD.row(b)) / std::max(wa + wb, 1e-300);
        else
          endD = boundaryD.row(fa ? a : b);
        return true;
      }
      Vec3 nb = Vec3::Zero();
      for (int k = 0; k < 3; ++k) {
        if (m.triangles[next][k] == a) nb[k] = wa;
        if (m.triangles[next][k] == b) nb[k] = wb;
      }
      t = next, bary = nb;
    }
    return false;
  };

  Eigen::MatrixXd d = Eigen::MatrixXd::Zero(nv, 3);
  Eigen::RowVectorXd fwd(3), bwd(3);
  for (int v = 0; v < nv; ++v) {
    if (fixed[v]) continue;
    ++stats.traced;
    double lf = 0, lb = 0;
    const bool okF = trace(v, +1, fwd, lf), okB = trace(v, -1, bwd, lb);
    if (okF && okB) {
      // Linear along the line: the nearer end weighs more.
      const double sum = std::max(lf + lb, 1e-300);
      d.row(v) = (lb / sum) * fwd + (lf / sum) * bwd;
      ++stats.bothEnds;
    } else if (okF || okB) {
      d.row(v) = okF ? fwd : bwd;
      ++stats.oneEnd;
    } else {
      ++stats.noEnd;
    }
  }
  return d;
}

// The frame that projects a clone's photo onto its target: the target's mean plane, the anchor vertex
// at the anchor pixel, photo x along `right`, photo y along -`up`, rotated and scaled.
struct CloneFrame {
  Vec3 origin, right, up;
  double scale = 1, cosR = 1, sinR = 0;
  Vec2 anchor;
  Vec2 pixel(const Vec3& p) const {
    const Vec3 d = p - origin;
    const double x = d.dot(right) * scale, y = -d.dot(up) * scale;
    return anchor + Vec2(cosR * x - sinR * y, sinR * x + cosR * y);
  }
};

CloneFrame cloneFrame(const Mesh& mesh, const std::vector<int>& faces, const CloneOp& clone, const std::string& path) {
  Vec3 n = Vec3::Zero();
  bool anchorOnTarget = false;
  for (int f : faces) {
    const auto p = mesh.facePositions(f);
    n += (p[1] - p[0]).cross(p[2] - p[0]);
    for (int v : mesh.faceVertices(f)) anchorOnTarget |= v == clone.anchorVertex;
  }
  TM_CHECK(anchorOnTarget, path + ".anchorVertex: vertex " + std::to_string(clone.anchorVertex) +
                               " is not a corner of any target face");
  TM_CHECK(n.norm() > 1e-12 * std::max(1.0, double(faces.size())),
           path +
               ".targetFaces: the target region has no mean plane to project the photo on (it is closed or "
               "folds back on itself); choose a smaller, roughly flat region");
  n.normalize();
  CloneFrame fr;
  fr.origin = mesh.position(clone.anchorVertex);
  // "Up" is the model's +y (or +z when the target faces along y), as a user looking at it expects.
  const Vec3 worldUp = std::abs(n.y()) < 0.9 ? Vec3::UnitY() : Vec3::UnitZ();
  fr.up = (worldUp - worldUp.dot(n) * n).normalized();
  fr.right = fr.up.cross(n);
  const double rad = clone.rotationDeg * M_PI / 180;
  fr.cosR = std::cos(rad), fr.sinR = std::sin(rad);
  fr.anchor = clone.anchor;
  if (clone.pixelsPerUnit > 0) {
    fr.scale = clone.pixelsPerUnit;
  } else {
    // Fit: the polygon's box covered by the target's projected box.
    Vec2 plo(kInf, kInf), phi(-kInf, -kInf), tlo(kInf, kInf), thi(-kInf, -kInf);
    for (const Vec2& q : clone.polygon) plo = plo.cwiseMin(q), phi = phi.cwiseMax(q);
    for (int f : faces)
      for (const Vec3& p : mesh.facePositions(f)) {
        const Vec2 q((p - fr.origin).dot(fr.right), (p - fr.origin).dot(fr.up));
        tlo = tlo.cwiseMin(q), thi = thi.cwiseMax(q);
      }
    const Vec2 ps = phi - plo, ts = thi - tlo;
    TM_CHECK(ts.x() > 0 && ts.y() > 0, path + ".targetFaces: the target region is degenerate (no area)");
    fr.scale = std::max(ps.x() / ts.x(), ps.y() / ts.y());
  }
  return fr;
}

std::vector<int> targetFacesOf(const Mesh& mesh, const std::vector<int>& faceParent, const CloneOp& clone) {
  std::vector<char> want;
  for (int f : clone.targetFaces) {
    if (f >= static_cast<int>(want.size())) want.resize(f + 1, 0);
    if (f >= 0) want[f] = 1;
  }
  std::vector<int> faces;
  for (int f = 0; f < mesh.numFaces(); ++f) {
    const int orig = faceParent.empty() ? f : faceParent[f];
    if (orig >= 0 && orig < static_cast<int>(want.size()) && want[orig]) faces.push_back(f);
  }
  return faces;
}

}  // namespace

// ---------------------------------------------------------------------------------------------

RefinedSurface refineFaces(const Mesh& mesh, const std::vector<int>& faceLabel, const std::vector<double>& faceMaxEdge,
                           std::vector<int>* baseVertex) {
  const int nf = mesh.numFaces();
  TM_CHECK(static_cast<int>(faceLabel.size()) == nf && static_cast<int>(faceMaxEdge.size()) == nf,
           "refineFaces: faceLabel and faceMaxEdge need one entry per face (" + std::to_string(nf) + ")");
  RefinedSurface out;
  auto& P = out.mesh.positions;
  auto& T = out.mesh.triangles;
  std::vector<int> vmap(mesh.numVertices(), -1);
  for (int f = 0; f < nf; ++f) {
    if (faceLabel[f] < -1) continue;
    TM_CHECK(faceMaxEdge[f] > 0 && std::isfinite(faceMaxEdge[f]),
             "refineFaces: face " + std::to_string(f) + " has no positive finite edge length limit");
    std::array<int, 3> tri{};
    const auto fv = mesh.faceVertices(f);
    for (int k = 0; k < 3; ++k) {
      if (vmap[fv[k]] < 0) vmap[fv[k]] = static_cast<int>(P.size()), P.push_back(mesh.position(fv[k]));
      tri[k] = vmap[fv[k]];
    }
    T.push_back(tri);
    out.parentFace.push_back(f);
    out.parentBary.push_back({Vec3::UnitX(), Vec3::UnitY(), Vec3::UnitZ()});
    out.region.push_back(faceLabel[f]);
  }
  if (baseVertex) *baseVertex = vmap;

  // Reserve for the final size (at most kVerticesPerEdgeArea / h^2 vertices per unit area, about three
  // edges and two triangles per vertex), so the edge table never rehashes.
  double expected = P.size();
  for (int t = 0; t < static_cast<int>(T.size()); ++t) {
    const double h = faceMaxEdge[out.parentFace[t]];
    expected += kVerticesPerEdgeArea * mesh.faceArea(out.parentFace[t]) / (h * h);
  }
  expected = std::min(expected, 5e7);
  P.reserve(size_t(expected));
  T.reserve(size_t(2 * expected));
  out.parentBary.reserve(size_t(2 * expected));
  out.parentFace.reserve(size_t(2 * expected));
  out.region.reserve(size_t(2 * expected));
  EdgeTable edges(size_t(3 * expected));
  auto addEdgeFace = [&](int a, int b, int t) {
    EdgeTable::Faces& e = edges.insert(edgeKey(a, b));
    if (e[0] < 0)
      e[0] = t;
    else if (e[1] < 0)
      e[1] = t;
  };
  auto replaceEdgeFace = [&](int a, int b, int from, int to) {
    EdgeTable::Faces* e = edges.find(edgeKey(a, b));
    if (!e) return;
    for (int& t : *e)
      if (t == from) t = to;
  };
  using Item = std::pair<double, uint64_t>;
  std::priority_queue<Item> queue;  // longest first: every split edge is the longest of its triangles
  auto consider = [&](int a, int b) {
    const uint64_t key = edgeKey(a, b);
    const EdgeTable::Faces* e = edges.find(key);
    if (!e) return;
    double limit = kInf;
    for (int t : *e)
      if (t >= 0) limit = std::min(limit, faceMaxEdge[out.parentFace[t]]);
    const double len = (P[a] - P[b]).norm();
    if (len > limit) queue.emplace(len, key);
  };
  for (int t = 0; t < static_cast<int>(T.size()); ++t)
    for (int k = 0; k < 3; ++k) addEdgeFace(T[t][k], T[t][(k + 1) % 3], t);
  // The queue orders its items by length, then key: the order they are pushed in does not matter.
  for (const uint64_t key : edges.keys()) consider(int(key >> 32), int(key & 0xffffffffu));

  while (!queue.empty()) {
    const uint64_t key = queue.top().second;
    queue.pop();
    EdgeTable::Faces* found = edges.find(key);
    if (!found) continue;  // split already (queued twice)
    const EdgeTable::Faces e = *found;
    edges.erase(key);
    const int a = int(key >> 32), b = int(key & 0xffffffffu);
    const int m = static_cast<int>(P.size());
    P.push_back(0.5 * (P[a] + P[b]));
    std::array<int, 2> opposite{};
    int numOpposite = 0;
    for (int t : e) {
      if (t < 0) continue;
      int i = 0;
      while (!((T[t][i] == a && T[t][(i + 1) % 3] == b) || (T[t][i] == b && T[t][(i + 1) % 3] == a))) ++i;
      const int p = T[t][i], q = T[t][(i + 1) % 3], r = T[t][(i + 2) % 3];
      const Vec3 bp = out.parentBary[t][i], bq = out.parentBary[t][(i + 1) % 3], br = out.parentBary[t][(i + 2) % 3];
      const Vec3 bm = 0.5 * (bp + bq);
      const int t2 = static_cast<int>(T.size());
      T[t] = {p, m, r};
      out.parentBary[t] = {bp, bm, br};
      T.push_back({m, q, r});
      out.parentBary.push_back({bm, bq, br});
      out.parentFace.push_back(out.parentFace[t]);
      out.region.push_back(out.region[t]);
      replaceEdgeFace(q, r, t, t2);
      addEdgeFace(p, m, t);
      addEdgeFace(m, q, t2);
      addEdgeFace(m, r, t);
      addEdgeFace(m, r, t2);
      opposite[numOpposite++] = r;
    }
    consider(a, m);
    consider(m, b);
    for (int i = 0; i < numOpposite; ++i) consider(m, opposite[i]);
  }
  return out;
}

CloneProjection projectClone(const Mesh& mesh, const std::vector<int>& faceParent, const CloneOp& clone,
                             const std::string& where) {
  CloneProjection out;
  out.faces = targetFacesOf(mesh, faceParent, clone);
  TM_CHECK(!out.faces.empty(), where + ".targetFaces: the target faces are not on the mesh");
  const CloneFrame fr = cloneFrame(mesh, out.faces, clone, where);
  out.pixelsPerUnit = fr.scale;
  for (int f : out.faces) {
    const auto p = mesh.facePositions(f);
    out.cornerPixel.push_back({fr.pixel(p[0]), fr.pixel(p[1]), fr.pixel(p[2])});
  }
  return out;
}

Vec3f InpaintResult::colourAt(int t, const Vec3& w) const {
  const auto& tri = refined.mesh.triangles[t];
  Vec3f c = float(w[0]) * colors.row(tri[0]).transpose() + float(w[1]) * colors.row(tri[1]).transpose() +
            float(w[2]) * colors.row(tri[2]).transpose();
  if (detailPoint.empty()) return c;
  const std::array<int, 3> index = {detailPoint[tri[0]], detailPoint[tri[1]], detailPoint[tri[2]]};
  if (index[0] < 0 && index[1] < 0 && index[2] < 0) return c;
  const int r = refined.region[t];
  if (r < 0 || r >= int(regions.size()) || !regions[r].detail) return c;
  const auto& p = refined.mesh.positions;
  return c + regions[r].detail->residual(index, {&p[tri[0]], &p[tri[1]], &p[tri[2]]}, w);
}

InpaintResult inpaintSurface(const InpaintInput& in, const JobControl& job, std::vector<std::string>* warnings) {
  const auto start = Clock::now();
  TM_CHECK(in.mesh && in.map, "inpaintSurface: no mesh or texture map");
  const Mesh& mesh = *in.mesh;
  const TextureMap& map = *in.map;
  const int nf = mesh.numFaces(), nv = mesh.numVertices();
  TM_CHECK(map.numFaces() == nf, "inpaintSurface: the texture map has " + std::to_string(map.numFaces()) +
                                     " faces, the mesh " + std::to_string(nf));
  const InpaintOptions& opt = in.options;
  auto warn = [&](const std::string& w) {
    if (warnings) warnings->push_back(w);
  };
  auto origFace = [&](int f) { return in.faceParent.empty() ? f : in.faceParent[f]; };

  InpaintResult res;
  res.faceRegion.assign(nf, -1);

  // Holes: vertex-connected components of the faces no photo covers.
  UnionFind sets(nf);
  {
    std::vector<int> firstEmpty(nv, -1);
    for (int f = 0; f < nf; ++f) {
      if (map.facePhoto[f] != TextureMap::kEmpty) continue;
      for (int v : mesh.faceVertices(f)) {
        if (firstEmpty[v] < 0)
          firstEmpty[v] = f;
        else
          sets.unite(f, firstEmpty[v]);
      }
    }
  }
  std::vector<int> holeOf(nf, -1);
  std::vector<int> rootHole(nf, -1);
  int numHoles = 0;
  for (int f = 0; f < nf; ++f) {
    if (map.facePhoto[f] != TextureMap::kEmpty) continue;
    const int r = sets.find(f);
    if (rootHole[r] < 0) rootHole[r] = numHoles++;
    holeOf[f] = rootHole[r];
  }

  // Strokes: per hole, the stroke vertices on it with their direction of travel, and the strokes' segments
  // that touch it.
  std::vector<std::vector<std::pair<int, Vec3>>> holeStrokes(numHoles);
  std::vector<std::vector<std::array<Vec3, 2>>> holeSegments(numHoles);
  {
    std::vector<int> vertexHole(nv, -1);
    for (int f = 0; f < nf; ++f)
      if (holeOf[f] >= 0)
        for (int v : mesh.faceVertices(f)) vertexHole[v] = holeOf[f];
    for (size_t s = 0; s < in.strokes.size(); ++s) {
      const auto& vs = in.strokes[s].vertices;
      bool used = false;
      for (size_t i = 0; i < vs.size(); ++i) {
        TM_CHECK(vs[i] >= 0 && vs[i] < nv,
                 located(in.where, "strokes[" + std::to_string(s) + "].vertices[" + std::to_string(i) + "]: vertex " +
                                       std::to_string(vs[i]) + " is not on the mesh"));
        if (vs.size() < 2 || vertexHole[vs[i]] < 0) continue;
        const Vec3 dir = mesh.position(vs[std::min(i + 1, vs.size() - 1)]) - mesh.position(vs[i ? i - 1 : 0]);
        if (dir.norm() <= 0) continue;
        holeStrokes[vertexHole[vs[i]]].emplace_back(vs[i], dir.normalized());
        const size_t a = i + 1 < vs.size() ? i : i - 1;  // the segment from this vertex, or to it at the end
        holeSegments[vertexHole[vs[i]]].push_back({mesh.position(vs[a]), mesh.position(vs[a + 1])});
        used = true;
      }
      if (!used) warn("strokes[" + std::to_string(s) + "] crosses no hole: it guides nothing");
    }
  }

  // Per-hole mode: HoleMode entry, else the option; strokes drawn on a hole make it "strokes" (flow lines),
  // except under "texture", whose grain follows them.
  std::vector<InpaintMode> holeMode(numHoles, opt.mode == InpaintMode::Strokes ? InpaintMode::Rbf : opt.mode);
  for (int h = 0; h < numHoles; ++h)
    if (!holeStrokes[h].empty() && opt.mode != InpaintMode::Texture) holeMode[h] = InpaintMode::Strokes;
  std::vector<const HoleExemplar*> holeExemplar(numHoles, nullptr);  // the user's photo region, texture only
  for (size_t i = 0; i < in.holeModes.size(); ++i) {
    int hole = -1;
    for (int f = 0; f < nf && hole < 0; ++f)
      if (origFace(f) == in.holeModes[i].face) hole = holeOf[f];
    if (hole < 0) {
      warn("holeModes[" + std::to_string(i) + "]: face " + std::to_string(in.holeModes[i].face) +
           " is in no hole (it is mapped): ignored");
      continue;
    }
    holeMode[hole] = in.holeModes[i].mode;
    holeExemplar[hole] = in.holeModes[i].exemplar ? &*in.holeModes[i].exemplar : nullptr;
    if (holeMode[hole] == InpaintMode::Strokes && holeStrokes[hole].empty()) {
      warn("holeModes[" + std::to_string(i) + "]: the hole has no strokes: using \"rbf\"");
      holeMode[hole] = InpaintMode::Rbf;
    }
  }

  // Regions: holes being filled, then clone targets on mapped faces.
  std::vector<int> faceLabel(nf, -2);
  std::vector<int> regionOfHole(numHoles, -1), holeOfRegion;
  for (int f = 0; f < nf; ++f) {
    const int h = holeOf[f];
    if (h < 0 || holeMode[h] == InpaintMode::Off) continue;
    if (regionOfHole[h] < 0) {
      regionOfHole[h] = static_cast<int>(res.regions.size());
      holeOfRegion.push_back(h);
      InpaintRegion r;
      r.mode = holeMode[h];
      res.regions.push_back(r);
    }
    faceLabel[f] = regionOfHole[h];
    res.regions[regionOfHole[h]].baseFaces++;
  }
  const int numHoleRegions = static_cast<int>(res.regions.size());
  std::vector<CloneProjection> projections;
  std::vector<double> cloneDensity;
  for (size_t c = 0; c < in.clones.size(); ++c) {
    const CloneOp& clone = in.clones[c];
    const std::string path = "clones[" + std::to_string(c) + "]";
    TM_CHECK(clone.photo >= 0 && clone.photo < static_cast<int>(in.photos.size()),
             located(in.where, path + ".photo: photo " + std::to_string(clone.photo) +
                                   " does not exist (the project has " + std::to_string(in.photos.size()) + ")"));
    TM_CHECK(clone.polygon.size() >= 3, located(in.where, path + ".polygon: needs at least 3 points"));
    CloneProjection proj = projectClone(mesh, in.faceParent, clone, located(in.where, path));
    InpaintRegion r;
    r.kind = InpaintRegion::Kind::Clone;
    r.clone = static_cast<int>(c);
    const int id = static_cast<int>(res.regions.size());
    for (int f : proj.faces) {
      r.baseFaces++;
      if (faceLabel[f] < 0) faceLabel[f] = id;
    }
    res.regions.push_back(r);
    cloneDensity.push_back(proj.pixelsPerUnit);
    projections.push_back(std::move(proj));
  }
  const int numRegions = static_cast<int>(res.regions.size());
  for (int f = 0; f < nf; ++f) res.faceRegion[f] = std::max(faceLabel[f], -1);
  if (numRegions == 0) {
    res.seconds = secondsSince(start);
    return res;
  }
  job.progress(StageId::Inpaint, 0.05, "refining " + std::to_string(numRegions) + " region(s)");

  // Densities: each region's from the mapped faces around it (texels per model unit).
  auto pixelArea = [&](int f) {
    const auto& uv = map.cornerUV[f];
    return 0.5 * std::abs(cross2(uv[1] - uv[0], uv[2] - uv[0]));
  };
  double allPix = 0, allArea = 0;
  for (int f = 0; f < nf; ++f)
    if (map.facePhoto[f] >= 0) allPix += pixelArea(f), allArea += mesh.faceArea(f);
  double fallback = opt.emptyTexelsPerUnit;
  if (fallback <= 0) {
    if (allArea > 0 && allPix > 0) {
      fallback = std::sqrt(allPix / allArea);
    } else {
      Vec3 lo, hi;
      mesh.bounds(lo, hi);
      fallback = 1024 / std::max((hi - lo).maxCoeff(), 1e-12);
    }
  }
  std::vector<double> ringPix(numRegions, 0), ringArea(numRegions, 0);
  std::vector<int> stamp(nf, -1);
  const VertexFaces vertexFaces = facesAroundVertices(mesh);
  for (int f = 0; f < nf; ++f) {
    const int r = faceLabel[f];
    if (r < 0) continue;
    for (int v : mesh.faceVertices(f))
      for (int g : vertexFaces[v]) {
        if (faceLabel[g] == r || map.facePhoto[g] < 0 || stamp[g] == r) continue;
        stamp[g] = r;
        ringPix[r] += pixelArea(g), ringArea[r] += mesh.faceArea(g);
        if (faceLabel[g] == -2) faceLabel[g] = -1;  // ring
      }
  }
  // A hole that touches no mapped face is filled with one flat colour (below): it is not refined, and the
  // bake gives it a sixteenth of the fallback density (a flat colour needs no texels; a mesh with no photos
  // then bakes in a fraction of a second instead of refining and baking the whole surface at full density).
  std::vector<char> flat(numRegions, 0);
  for (int r = 0; r < numRegions; ++r) {
    double density = fallback;
    if (res.regions[r].kind == InpaintRegion::Kind::Clone)
      density = cloneDensity[res.regions[r].clone];
    else if (ringArea[r] > 0 && ringPix[r] > 0)
      density = std::sqrt(ringPix[r] / ringArea[r]);
    else if (ringArea[r] == 0)
      flat[r] = 1, density = fallback / 16;
    if (opt.texelsPerUnit > 0) density = opt.texelsPerUnit;
    res.regions[r].texelsPerUnit = density * opt.detail;
  }
  std::vector<double> maxEdge(nf, kInf);
  for (int f = 0; f < nf; ++f) {
    const int r = faceLabel[f];
    if (r < 0 || flat[r]) continue;
    const double h = kEdgePerTexel / res.regions[r].texelsPerUnit;
    for (int v : mesh.faceVertices(f))
      for (int g : vertexFaces[v]) maxEdge[g] = std::min(maxEdge[g], h);
  }
  // The refined vertex cap: coarser everywhere when the estimate exceeds it.
  double estimate = 0;
  for (int f = 0; f < nf; ++f)
    if (faceLabel[f] >= -1) estimate += kVerticesPerEdgeArea * mesh.faceArea(f) / (maxEdge[f] * maxEdge[f]);
  if (estimate > opt.maxRefinedVertices) {
    const double grow = std::sqrt(estimate / opt.maxRefinedVertices);
    for (double& h : maxEdge) h *= grow;
    for (auto& r : res.regions) r.texelsPerUnit /= grow;
    warn("inpainting: " + std::to_string(long(estimate)) + " refined vertices needed for one per texel, more than " +
         "maxInpaintVertices (" + std::to_string(opt.maxRefinedVertices) + "): refined " +
         std::to_string(grow).substr(0, 4) + "x coarser");
  }
  for (int f = 0; f < nf; ++f)
    if (faceLabel[f] < -1 || maxEdge[f] == kInf) maxEdge[f] = 1e300;  // unused, or a flat hole's: not refined
  const auto refineStart = Clock::now();
  std::vector<int> baseVertex;
  res.refined = refineFaces(mesh, faceLabel, maxEdge, &baseVertex);
  const double refineSeconds = secondsSince(refineStart);
  const RefinedSurface& rs = res.refined;
  const TriangleMesh& rm = rs.mesh;
  const int rv = rm.numVertices(), rt = rm.numTriangles();
  job.progress(StageId::Inpaint, 0.3, std::to_string(rv) + " refined vertices");

  // Known colours: refined vertices of mapped faces take their photo's colour (levelled), averaged
  // where faces of different photos meet. Samples on a photo's background (a mapped face along a
  // silhouette can reach it) do not count: such a vertex on a hole's border is solved for instead of
  // bleeding the background into the fill.
  res.colors = VertexColors::Zero(rv, 3);
  bool anyTexture = false;
  for (const InpaintRegion& reg : res.regions)
    anyTexture |= reg.kind == InpaintRegion::Kind::Hole && reg.mode == InpaintMode::Texture;
  if (anyTexture) res.detailPoint.assign(rv, -1);
  std::vector<int> known(rv, 0);
  std::vector<char> starKnown(rv, 1);  // every triangle around the vertex is mapped
  for (int t = 0; t < rt; ++t) {
    const int f = rs.parentFace[t];
    if (map.facePhoto[f] < 0) {
      for (int v : rm.triangles[t]) starKnown[v] = 0;
      continue;
    }
    const Photo& photo = *in.photos[map.facePhoto[f]];
    for (int k = 0; k < 3; ++k) {
      const int v = rm.triangles[t][k];
      const Vec3& b = rs.parentBary[t][k];
      if (photo.hasBackground) {
        const auto& uv = map.cornerUV[f];
        const Vec2 q = b[0] * uv[0] + b[1] * uv[1] + b[2] * uv[2];
        if (photo.alphaAt(q.x(), q.y()) < 0.5f) continue;
      }
      res.colors.row(v) += mappedColor(map, in.photos, in.levelling, f, b).transpose();
      known[v]++;
    }
  }
  Eigen::RowVector3f meanKnown = Eigen::RowVector3f::Constant(0.5f);
  {
    Eigen::RowVector3d sum = Eigen::RowVector3d::Zero();
    int n = 0;
    for (int v = 0; v < rv; ++v)
      if (known[v]) res.colors.row(v) /= float(known[v]), sum += res.colors.row(v).cast<double>(), ++n;
    if (n) meanKnown = (sum / n).cast<float>();
  }
  for (int v = 0; v < rv; ++v)
    if (!known[v]) starKnown[v] = 0;

  const Graph graph = buildGraph(rm);
  // Boundary d (paper): the Laplacian of the known colours at the closest "outer" refined vertex (one
  // all of whose triangles are mapped), found by one multi-source Dijkstra over the known vertices.
  // Averaging it over a band outside the hole instead was measured and not kept (docs/pipeline.md).
  Eigen::MatrixXd boundaryD;  // per refined vertex (rows of known vertices meaningful)
  bool needBoundaryD = false;
  for (const auto& r : res.regions)
    needBoundaryD |= r.kind == InpaintRegion::Kind::Hole && r.mode != InpaintMode::Harmonic;
  if (needBoundaryD) {
    std::vector<int> outerTris, outer;
    for (int t = 0; t < rt; ++t)
      if (map.facePhoto[rs.parentFace[t]] >= 0) outerTris.push_back(t);
    std::vector<char> isKnown(rv);
    for (int v = 0; v < rv; ++v) {
      isKnown[v] = known[v] > 0;
      if (starKnown[v]) outer.push_back(v);
    }
    std::vector<int> localOf(rv, -1);
    const SubMesh knownMesh = extractTriangles(rm, outerTris, localOf);
    Eigen::MatrixXd c(knownMesh.mesh.numVertices(), 3);
    for (int l = 0; l < knownMesh.mesh.numVertices(); ++l)
      c.row(l) = res.colors.row(knownMesh.vertex[l]).cast<double>();
    const Eigen::MatrixXd lapLocal = laplacianOf(knownMesh.mesh, c);
    Eigen::MatrixXd lap = Eigen::MatrixXd::Zero(rv, 3);
    for (int l = 0; l < knownMesh.mesh.numVertices(); ++l) lap.row(knownMesh.vertex[l]) = lapLocal.row(l);
    boundaryD = Eigen::MatrixXd::Zero(rv, 3);
    Dijkstra dijkstra(graph, isKnown);
    dijkstra.run(outer, kInf, [&](int v, double, int source) { boundaryD.row(v) = lap.row(outer[source]); });
  }

  // Factorises a region once, solves all three channels and writes the unknowns' colours back.
  // Guided hole fills (`bounded`) stay inside their border's colour range (GuidanceBound).
  auto solverFor = [&](InpaintRegion& reg, const SubMesh& sub, const std::vector<char>& fixed) {
    bool made = true;
    std::shared_ptr<const PoissonSolver> kept = in.solvers ? in.solvers->solver(sub.mesh, fixed, &made)
                                                           : std::make_shared<const PoissonSolver>(sub.mesh, fixed);
    reg.factorSeconds = made ? kept->factorSeconds() : 0;  // 0: reused
    return kept;
  };
  auto solveRegion = [&](InpaintRegion& reg, const SubMesh& sub, const std::vector<char>& fixed,
                         const Eigen::MatrixXd& d, const Eigen::MatrixXd& fixedValues, bool bounded = false,
                         std::shared_ptr<const PoissonSolver> kept = nullptr) {
    if (!kept) kept = solverFor(reg, sub, fixed);
    const PoissonSolver& solver = *kept;
    const auto solveStart = Clock::now();
    Eigen::MatrixXd f = solver.solve(d, fixedValues);
    if (bounded && opt.bound != GuidanceBound::None)
      boundFill(opt.bound, fixed, fixedValues, solver.solve(Eigen::MatrixXd::Zero(d.rows(), 3), fixedValues), f);
    reg.solveSeconds = secondsSince(solveStart);
    for (int l = 0; l < sub.mesh.numVertices(); ++l)
      if (!fixed[l]) res.colors.row(sub.vertex[l]) = f.row(l).cast<float>().cwiseMax(0.f).cwiseMin(1.f);
  };

  // Synthesised guidance (synthesis and structure modes) depends on the mapping around each hole only,
  // not on the refinement: the holes' syntheses run in parallel, each one's shift-map taken from the memo
  // when its canvas is kept there.
  std::vector<std::vector<int>> holeFaces(numHoleRegions);
  for (int f = 0; f < nf; ++f)
    if (faceLabel[f] >= 0 && faceLabel[f] < numHoleRegions) holeFaces[faceLabel[f]].push_back(f);
  // Hole r and what it is filled from, for either synthesis.
  auto holeInput = [&](int r) {
    HoleInput h;
    h.mesh = &mesh;
    h.map = &map;
    h.photos = in.photos;
    h.levelling = in.levelling;
    h.vertexFaces = &vertexFaces;
    h.holeFaces = holeFaces[r];
    h.job = &job;
    return h;
  };
  std::vector<SynthesisResult> synthesised(numHoleRegions);
  std::vector<double> synthesisSeconds(numHoleRegions, 0);
  std::vector<int> toSynthesise;
  for (int r = 0; r < numHoleRegions; ++r)
    if (res.regions[r].mode == InpaintMode::Synthesis || res.regions[r].mode == InpaintMode::Structure)
      toSynthesise.push_back(r);
  if (!toSynthesise.empty()) {
    job.progress(StageId::Inpaint, 0.3, "synthesising " + std::to_string(toSynthesise.size()) + " hole(s)");
    tbb::parallel_for(size_t(0), toSynthesise.size(), [&](size_t k) {
      const int r = toSynthesise[k];
      const auto synStart = Clock::now();
      SynthesisInput sin;
      static_cast<HoleInput&>(sin) = holeInput(r);
      sin.texelsPerUnit = res.regions[r].texelsPerUnit;
      sin.memo = in.synthesis;
      sin.reuseCharts = opt.synthesisReuseCharts;
      sin.photosKey = in.photosKey;
      SynthesisOptions synOptions;
      if (res.regions[r].mode == InpaintMode::Structure)
        synOptions.blur = opt.structureBlur, synOptions.bandAreaRatio = opt.structureBand;
      synthesised[r] = synthesiseHole(sin, synOptions);
      synthesisSeconds[r] = secondsSince(synStart);
    });
  }

  // Solve each hole. Holes are vertex-connected components: no two share an unknown vertex, so they are
  // solved in parallel (each writes only its own unknowns); their warnings are reported in hole order.
  std::vector<std::vector<int>> regionTris(numRegions);
  for (int t = 0; t < rt; ++t)
    if (rs.region[t] >= 0) regionTris[rs.region[t]].push_back(t);
  std::vector<std::vector<std::string>> holeWarnings(numHoleRegions);
  tbb::enumerable_thread_specific<std::vector<int>> scratch([rv] { return std::vector<int>(rv, -1); });
  std::atomic<int> started{0};
  tbb::parallel_for(0, numHoleRegions, [&](int r) {
    const auto warn = [&](const std::string& w) { holeWarnings[r].push_back(w); };
    std::vector<int>& localOf = scratch.local();
    job.checkCancel();
    job.progress(StageId::Inpaint, 0.35 + 0.5 * started++ / std::max(numRegions, 1), "hole " + std::to_string(r));
    InpaintRegion& reg = res.regions[r];
    reg.refineSeconds = refineSeconds * regionTris[r].size() / std::max(rt, 1);
    const SubMesh sub = extractTriangles(rm, regionTris[r], localOf);
    const int n = sub.mesh.numVertices();
    reg.refinedVertices = n;
    std::vector<char> fixed(n);
    int numFixed = 0;
    for (int l = 0; l < n; ++l) numFixed += fixed[l] = known[sub.vertex[l]] > 0;
    reg.unknowns = n - numFixed;
    const auto guideStart = Clock::now();
    std::shared_ptr<const PoissonSolver> solver;
    Eigen::MatrixXd fixedValues(n, 3);
    for (int l = 0; l < n; ++l) fixedValues.row(l) = res.colors.row(sub.vertex[l]).cast<double>();
    SurfaceSynthesisResult textured;
    if (reg.mode == InpaintMode::Texture) {
      // Texture optimisation on the surface (surface_synthesis.h): its direction field uses the hole's
      // factorisation, which the Poisson solve below reuses.
      if (numFixed > 0) solver = solverFor(reg, sub, fixed);
      SurfaceSynthesisInput tin;
      static_cast<HoleInput&>(tin) = holeInput(r);
      tin.surface = &sub.mesh;
      tin.triangleFace.reserve(regionTris[r].size());
      for (int t : regionTris[r]) tin.triangleFace.push_back(rs.parentFace[t]);
      tin.fixed = fixed;
      tin.fixedValues = &fixedValues;
      tin.solver = solver.get();
      SurfaceSynthesisOptions topt;
      topt.seed = opt.textureSeed;
      topt.rareChi2 = opt.textureRareChi2;
      tin.strokes = holeSegments[holeOfRegion[r]];
      tin.exemplar = holeExemplar[holeOfRegion[r]];
      textured = synthesiseOnSurface(tin, topt);
      reg.note = textured.note;
      if (textured.strokeVertices > 0)
        reg.note += "; its grain follows " + std::to_string(textured.strokeVertices) + " stroke vertices";
      if (textured.ok && textured.detail) {
        // Each hole writes only its own unknown vertices' entries (holes share none).
        reg.detail = textured.detail;
        for (int l = 0; l < n; ++l)
          if (textured.detailPoint[l] >= 0) res.detailPoint[sub.vertex[l]] = textured.detailPoint[l];
      }
      if (!textured.ok && numFixed > 0)
        warn("hole " + std::to_string(r) + ": " + textured.note + ": filled with \"" +
             (tin.strokes.empty() ? "rbf" : "strokes") + "\" instead");
    }
    if (numFixed == 0 && textured.ok) {
      // Nothing to blend into: the synthesised texture is the fill.
      for (int l = 0; l < n; ++l) res.colors.row(sub.vertex[l]) = textured.colours.row(l).cast<float>();
      reg.guidanceSeconds = secondsSince(guideStart);
      return;
    }
    if (numFixed == 0) {
      for (int v : sub.vertex) res.colors.row(v) = meanKnown;
      reg.note = "no mapped neighbour: filled with the mean colour of the mapped surface";
      warn("hole " + std::to_string(r) + " (" + std::to_string(reg.baseFaces) +
           " faces) touches no mapped face: " + "filled with one flat colour");
      return;
    }
    Eigen::MatrixXd d = Eigen::MatrixXd::Zero(n, 3);
    if (textured.ok) {
      // d = the Laplacian of the synthesised texture: the Poisson solve keeps it and blends its border. The
      // guidance at a border vertex is the mean of its synthesised neighbours (the texture carried one texel
      // on), not its photo colour: the step between the two would stay in d as a seam, where the solve
      // instead spreads the difference smoothly over the hole (Pérez et al. 2003).
      Eigen::MatrixXd g = textured.colours;
      Eigen::MatrixXd sum = Eigen::MatrixXd::Zero(n, 3);
      std::vector<int> count(n, 0);
      for (const auto& tri : sub.mesh.triangles)
        for (int k = 0; k < 3; ++k)
          for (int j = 1; j < 3; ++j) {
            const int a = tri[k], b = tri[(k + j) % 3];
            if (fixed[a] && !fixed[b]) sum.row(a) += textured.colours.row(b), ++count[a];
          }
      for (int l = 0; l < n; ++l)
        if (fixed[l] && count[l]) g.row(l) = sum.row(l) / count[l];
      d = laplacianOf(sub.mesh, g);
    } else if (reg.mode != InpaintMode::Harmonic) {
      Eigen::MatrixXd bd(n, 3);
      for (int l = 0; l < n; ++l) bd.row(l) = boundaryD.row(sub.vertex[l]);
      const Graph subGraph = buildGraph(sub.mesh);
      bool synthesisUsed = false;
      if (reg.mode == InpaintMode::Synthesis || reg.mode == InpaintMode::Structure) {
        const SynthesisResult& syn = synthesised[r];
        reg.note = syn.note;
        reg.synthesisKept = syn.kept;
        if (syn.ok) {
          // d = the Laplacian of the synthesised texture: the Poisson solve keeps its structure and
          // blends its border into the photos' colours.
          Eigen::MatrixXd g(n, 3);
          for (size_t i = 0; i < regionTris[r].size(); ++i) {
            const int t = regionTris[r][i];
            for (int k = 0; k < 3; ++k)
              g.row(sub.mesh.triangles[i][k]) = syn.colorAt(rs.parentFace[t], rs.parentBary[t][k]).cast<double>();
          }
          d = laplacianOf(sub.mesh, g);
          synthesisUsed = true;
        } else {
          warn("hole " + std::to_string(r) + ": " + syn.note + ": filled with \"rbf\" instead");
        }
      }
      if (synthesisUsed) {
        // d is the synthesised texture's Laplacian (above)
      } else if (reg.mode == InpaintMode::Rbf || reg.mode == InpaintMode::Synthesis ||
                 reg.mode == InpaintMode::Structure ||
                 (reg.mode == InpaintMode::Texture && holeSegments[holeOfRegion[r]].empty())) {
        d = rbfGuidance(sub, subGraph, fixed, bd, opt.rbfCentres);
      } else {
        std::vector<StrokeSample> samples;
        std::unordered_map<int, int> local;
        for (int l = 0; l < n; ++l) local.emplace(sub.vertex[l], l);
        for (const auto& [v, dir] : holeStrokes[holeOfRegion[r]]) {
          const auto it = local.find(baseVertex[v]);
          if (it != local.end()) samples.push_back({it->second, dir});
        }
        FlowStats stats;
        d = strokeGuidance(sub, subGraph, fixed, bd, samples, stats);
        reg.note = std::to_string(stats.traced) + " flow lines: " + std::to_string(stats.bothEnds) +
                   " reach the border at both ends, " + std::to_string(stats.oneEnd) + " at one, " +
                   std::to_string(stats.noEnd) + " at none (d = 0)";
      }
    }
    reg.guidanceSeconds = secondsSince(guideStart) + synthesisSeconds[r];
    synthesised[r] = {};  // its canvas is no longer needed
    solveRegion(reg, sub, fixed, d, fixedValues, reg.mode != InpaintMode::Harmonic, solver);
  });
  for (const auto& ws : holeWarnings)
    for (const std::string& w : ws) warn(w);
  std::vector<int> localOf(rv, -1);

  // Clones, in project order, on top of everything else: d = Laplacian of the photo projected onto the
  // target, colours outside the polygon (or on the target's border) fixed.
  std::vector<char> inTarget(nf, 0);
  for (int r = numHoleRegions; r < numRegions; ++r) {
    job.checkCancel();
    InpaintRegion& reg = res.regions[r];
    const CloneOp& clone = in.clones[reg.clone];
    const std::string path = "clones[" + std::to_string(reg.clone) + "]";
    const CloneProjection& proj = projections[reg.clone];
    std::fill(inTarget.begin(), inTarget.end(), 0);
    for (int f : proj.faces) inTarget[f] = 1;
    std::vector<int> tris;
    std::vector<int> outside(rv, 0);  // triangles around a vertex that are not in the target
    for (int t = 0; t < rt; ++t) {
      if (inTarget[rs.parentFace[t]])
        tris.push_back(t);
      else
        for (int v : rm.triangles[t]) outside[v]++;
    }
    const SubMesh sub = extractTriangles(rm, tris, localOf);
    const int n = sub.mesh.numVertices();
    reg.refinedVertices = n;
    const Photo& photo = *in.photos[clone.photo];
    // The photo position of each target vertex, through its parent face's projected corners.
    std::vector<int> faceSlot(nf, -1);
    for (size_t i = 0; i < proj.faces.size(); ++i) faceSlot[proj.faces[i]] = static_cast<int>(i);
    std::vector<Vec2> pixel(n, Vec2::Zero());
    for (size_t i = 0; i < tris.size(); ++i) {
      const int t = tris[i];
      const auto& corners = proj.cornerPixel[faceSlot[rs.parentFace[t]]];
      for (int k = 0; k < 3; ++k) {
        const Vec3& b = rs.parentBary[t][k];
        pixel[sub.mesh.triangles[i][k]] = b[0] * corners[0] + b[1] * corners[1] + b[2] * corners[2];
      }
    }
    std::vector<char> fixed(n, 1);
    Eigen::MatrixXd g(n, 3), fixedValues(n, 3);
    int unknowns = 0;
    for (int l = 0; l < n; ++l) {
      const Vec2& q = pixel[l];
      g.row(l) = photo.rgbAt(q.x(), q.y()).cast<double>().transpose();
      fixedValues.row(l) = res.colors.row(sub.vertex[l]).cast<double>();
      if (outside[sub.vertex[l]] == 0 && photo.inside(q.x(), q.y()) && insidePolygon(clone.polygon, q))
        fixed[l] = 0, ++unknowns;
    }
    TM_CHECK(unknowns > 0, located(in.where, path + ": the polygon maps onto no vertex inside the target region "
                                                    "(check the anchor, the scale and the rotation)"));
    reg.unknowns = unknowns;
    solveRegion(reg, sub, fixed, laplacianOf(sub.mesh, g), fixedValues);
  }
  res.seconds = secondsSince(start);
  return res;
}

}  // namespace montage
