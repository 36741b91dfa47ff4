#include "geometry/bvh.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <utility>

#include "geometry/mesh.h"

namespace montage {

namespace {

constexpr int kLeafSize = 4;
constexpr int kMaxStack = 128;  // median splits give depth ~log2(F / kLeafSize); 128 is never reached

// Closest point on segment [a, b] to p; t is the parameter along the segment.
Vec3 closestOnSegment(const Vec3& p, const Vec3& a, const Vec3& b, double& t) {
  const Vec3 ab = b - a;
  const double len2 = ab.squaredNorm();
  t = len2 > 0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return a + t * ab;
}

// Exact closest point on triangle (a, b, c) to p by Voronoi regions (Ericson, Real-Time Collision
// Detection, 5.1.5); `bary` receives its barycentrics.
Vec3 closestOnTriangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c, Vec3& bary) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) {
    bary = Vec3(1, 0, 0);
    return a;
  }
  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) {
    bary = Vec3(0, 1, 0);
    return b;
  }
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0 && d1 - d3 > 0) {
    const double v = d1 / (d1 - d3);
    bary = Vec3(1 - v, v, 0);
    return a + v * ab;
  }
  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) {
    bary = Vec3(0, 0, 1);
    return c;
  }
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0 && d2 - d6 > 0) {
    const double w = d2 / (d2 - d6);
    bary = Vec3(1 - w, 0, w);
    return a + w * ac;
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0 && (d4 - d3) + (d5 - d6) > 0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    bary = Vec3(0, 1 - w, w);
    return b + w * (c - b);
  }
  const double sum = va + vb + vc;
  if (sum > 0 && std::isfinite(sum)) {
    const double v = vb / sum, w = vc / sum;
    bary = Vec3(1 - v - w, v, w);
    return a + v * ab + w * ac;
  }
  // Degenerate (zero-area) triangle: the closest point lies on one of its edges.
  double tab, tbc, tca;
  const Vec3 qab = closestOnSegment(p, a, b, tab);
  const Vec3 qbc = closestOnSegment(p, b, c, tbc);
  const Vec3 qca = closestOnSegment(p, c, a, tca);
  const double dab = (p - qab).squaredNorm(), dbc = (p - qbc).squaredNorm(), dca = (p - qca).squaredNorm();
  if (dab <= dbc && dab <= dca) {
    bary = Vec3(1 - tab, tab, 0);
    return qab;
  }
  if (dbc <= dca) {
    bary = Vec3(0, 1 - tbc, tbc);
    return qbc;
  }
  bary = Vec3(tca, 0, 1 - tca);
  return qca;
}

// Moller-Trumbore ray/triangle intersection, both sides. Returns false when there is no hit.
bool intersectTriangle(const Vec3& o, const Vec3& d, const std::array<Vec3, 3>& tri, double& t, double& u, double& v) {
  const Vec3 e1 = tri[1] - tri[0], e2 = tri[2] - tri[0];
  const Vec3 pvec = d.cross(e2);
  const double det = e1.dot(pvec);
  if (det == 0 || !std::isfinite(det)) return false;
  const double inv = 1.0 / det;
  const Vec3 tvec = o - tri[0];
  u = tvec.dot(pvec) * inv;
  if (u < 0 || u > 1) return false;
  const Vec3 qvec = tvec.cross(e1);
  v = d.dot(qvec) * inv;
  if (v < 0 || u + v > 1) return false;
  t = e2.dot(qvec) * inv;
  return true;
}

// Slab test: entry parameter of the ray into the box within [tMin, tMax], or +inf when it misses.
double rayBoxEntry(const Eigen::AlignedBox3d& box, const Vec3& o, const Vec3& invDir, double tMin, double tMax) {
  for (int k = 0; k < 3; ++k) {
    double t0 = (box.min()[k] - o[k]) * invDir[k];
    double t1 = (box.max()[k] - o[k]) * invDir[k];
    if (std::isnan(t0) || std::isnan(t1)) {
      // Direction component zero and origin on a slab plane: inside iff within the slab.
      if (o[k] < box.min()[k] || o[k] > box.max()[k]) return std::numeric_limits<double>::infinity();
      continue;
    }
    if (t0 > t1) std::swap(t0, t1);
    tMin = std::max(tMin, t0);
    tMax = std::min(tMax, t1);
    if (tMin > tMax) return std::numeric_limits<double>::infinity();
  }
  return tMin;
}

}  // namespace

TriangleBvh::TriangleBvh(const Mesh& mesh) {
  const int nf = mesh.numFaces();
  tris_.resize(nf);
  for (int f = 0; f < nf; ++f) tris_[f] = mesh.facePositions(f);
  order_.resize(nf);
  std::iota(order_.begin(), order_.end(), 0);
  if (nf == 0) return;
  nodes_.reserve(static_cast<size_t>(2 * nf / kLeafSize + 2));
  build(0, nf, 0);
  // Store the triangles in leaf order: tris_[i] is face order_[i], so leaves read contiguous memory.
  std::vector<std::array<Vec3, 3>> sorted(nf);
  for (int i = 0; i < nf; ++i) sorted[i] = tris_[order_[i]];
  tris_.swap(sorted);
}

int TriangleBvh::build(int first, int count, int depth) {
  const int index = static_cast<int>(nodes_.size());
  nodes_.emplace_back();
  Eigen::AlignedBox3d box, centroids;
  for (int i = first; i < first + count; ++i) {
    const auto& tri = tris_[order_[i]];
    for (const Vec3& p : tri) box.extend(p);
    centroids.extend((tri[0] + tri[1] + tri[2]) / 3.0);
  }
  nodes_[index].box = box;
  if (count <= kLeafSize || depth >= kMaxStack / 2 - 2) {
    nodes_[index].first = first;
    nodes_[index].count = count;
    return index;
  }
  // Median split along the longest axis of the centroid bounds.
  Eigen::Index axis;
  centroids.sizes().maxCoeff(&axis);
  const int half = count / 2;
  std::nth_element(order_.begin() + first, order_.begin() + first + half, order_.begin() + first + count,
                   [&](int a, int b) {
                     const auto& ta = tris_[a];
                     const auto& tb = tris_[b];
                     return ta[0][axis] + ta[1][axis] + ta[2][axis] < tb[0][axis] + tb[1][axis] + tb[2][axis];
                   });
  const int left = build(first, half, depth + 1);
  const int right = build(first + half, count - half, depth + 1);
  nodes_[index].left = left;
  nodes_[index].right = right;
  return index;
}

RayHit TriangleBvh::raycast(const Vec3& origin, const Vec3& direction, double tMin, double tMax) const {
  RayHit hit;
  if (nodes_.empty() || !(direction.squaredNorm() > 0)) return hit;
  const Vec3 invDir = direction.cwiseInverse();
  double best = tMax;
  int stack[kMaxStack];
  int top = 0;
  if (rayBoxEntry(nodes_[0].box, origin, invDir, tMin, best) <= best) stack[top++] = 0;
  while (top > 0) {
    const Node& node = nodes_[stack[--top]];
    if (node.count > 0) {
      for (int i = node.first; i < node.first + node.count; ++i) {
        double t, u, v;
        if (intersectTriangle(origin, direction, tris_[i], t, u, v) && t >= tMin && t <= best) {
          if (hit.face >= 0 && t == best && order_[i] > hit.face) continue;  // deterministic on ties
          best = t;
          hit.face = order_[i];
          hit.t = t;
          hit.bary = Vec3(1 - u - v, u, v);
        }
      }
      continue;
    }
    const double tl = rayBoxEntry(nodes_[node.left].box, origin, invDir, tMin, best);
    const double tr = rayBoxEntry(nodes_[node.right].box, origin, invDir, tMin, best);
    // Push the farther child first so the nearer one is visited first.
    if (tl <= tr) {
      if (tr <= best) stack[top++] = node.right;
      if (tl <= best) stack[top++] = node.left;
    } else {
      if (tl <= best) stack[top++] = node.left;
      if (tr <= best) stack[top++] = node.right;
    }
  }
  return hit;
}

ClosestPoint TriangleBvh::closest(const Vec3& query) const {
  ClosestPoint result;
  if (nodes_.empty()) return result;
  double best = std::numeric_limits<double>::infinity();  // squared distance
  std::pair<int, double> stack[kMaxStack];
  int top = 0;
  stack[top++] = {0, nodes_[0].box.squaredExteriorDistance(query)};
  while (top > 0) {
    const auto [index, bound] = stack[--top];
    if (bound > best) continue;
    const Node& node = nodes_[index];
    if (node.count > 0) {
      for (int i = node.first; i < node.first + node.count; ++i) {
        const auto& tri = tris_[i];
        Vec3 bary;
        const Vec3 p = closestOnTriangle(query, tri[0], tri[1], tri[2], bary);
        const double d2 = (p - query).squaredNorm();
        if (d2 < best || (d2 == best && order_[i] < result.face)) {
          best = d2;
          result.face = order_[i];
          result.point = p;
          result.bary = bary;
        }
      }
      continue;
    }
    const double dl = nodes_[node.left].box.squaredExteriorDistance(query);
    const double dr = nodes_[node.right].box.squaredExteriorDistance(query);
    if (dl <= dr) {
      if (dr <= best) stack[top++] = {node.right, dr};
      if (dl <= best) stack[top++] = {node.left, dl};
    } else {
      if (dl <= best) stack[top++] = {node.left, dl};
      if (dr <= best) stack[top++] = {node.right, dr};
    }
  }
  result.distance = std::sqrt(best);
  return result;
}

}  // namespace montage
