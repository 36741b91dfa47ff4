#include "geometry/lscm.h"

#include <Eigen/Geometry>
#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>

#include "geometry/stretch.h"

namespace montage {

namespace {

// Corner positions of triangle t in an orthonormal frame of its own plane (x along its longest edge,
// so that a collinear triangle still gets a meaningful 1D frame).
std::array<Vec2, 3> localFrame(const std::array<Vec3, 3>& q, double& longest) {
  int k0 = 0;
  longest = 0;
  for (int k = 0; k < 3; ++k) {
    const double len = (q[(k + 1) % 3] - q[k]).norm();
    if (len > longest) longest = len, k0 = k;
  }
  std::array<Vec2, 3> out;
  for (auto& p : out) p.setZero();
  if (!(longest > 0)) return out;
  const Vec3 origin = q[k0];
  const Vec3 ex = (q[(k0 + 1) % 3] - origin) / longest;
  const Vec3 n = ex.cross(q[(k0 + 2) % 3] - origin);
  // For a collinear triangle n = 0 and every y stays 0: the triangle is a segment in its frame.
  const Vec3 ey = n.norm() > 0 ? Vec3(n.normalized().cross(ex)) : Vec3::Zero();
  for (int k = 0; k < 3; ++k) out[k] = Vec2((q[k] - origin).dot(ex), (q[k] - origin).dot(ey));
  return out;
}

}  // namespace

namespace {

// The conformal solve with the vertices of `pins` held at their UVs (at least two distinct ones).
std::vector<Vec2> solveLscm(const std::vector<Vec3>& positions, const std::vector<std::array<int, 3>>& triangles,
                            const std::vector<std::pair<int, Vec2>>& pins, const std::vector<char>& used,
                            const LscmOptions& options) {
  const int n = static_cast<int>(positions.size());
  std::vector<Vec2> uv(n, Vec2::Zero());
  std::vector<char> pinnedVertex(n, 0);
  for (const auto& [v, at] : pins) uv[v] = at, pinnedVertex[v] = 1;

  // Unknowns: u of the free vertices, then their v.
  std::vector<int> freeIndex(n, -1);
  int nf = 0;
  for (int v = 0; v < n; ++v)
    if (used[v] && !pinnedVertex[v]) freeIndex[v] = nf++;
  if (nf == 0) return uv;
  const auto var = [&](int v, int c) { return freeIndex[v] < 0 ? -1 : freeIndex[v] + c * nf; };
  const auto pinned = [&](int v, int c) { return uv[v][c]; };

  std::vector<Eigen::Triplet<double>> triplets;
  triplets.reserve(triangles.size() * 72 + triangles.size() * 24);
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(2 * nf);
  // Adds the squared residual (sum_j coef_j * x_j)^2 of one row over (vertex, component) pairs.
  const auto addRow = [&](const std::array<std::pair<int, int>, 6>& vc, const std::array<double, 6>& coef) {
    for (int i = 0; i < 6; ++i) {
      const int vi = var(vc[i].first, vc[i].second);
      if (vi < 0 || coef[i] == 0) continue;
      for (int j = 0; j < 6; ++j) {
        if (coef[j] == 0) continue;
        const int vj = var(vc[j].first, vc[j].second);
        if (vj >= 0)
          triplets.emplace_back(vi, vj, coef[i] * coef[j]);
        else
          rhs[vi] -= coef[i] * coef[j] * pinned(vc[j].first, vc[j].second);
      }
    }
  };

  for (const auto& tri : triangles) {
    double longest = 0;
    const std::array<Vec2, 3> p = localFrame({positions[tri[0]], positions[tri[1]], positions[tri[2]]}, longest);
    if (!(longest > 0)) continue;  // all three corners coincide: no constraint at all
    const double twiceArea = (p[1] - p[0]).x() * (p[2] - p[0]).y() - (p[2] - p[0]).x() * (p[1] - p[0]).y();
    // Energy of the triangle: area * |Cauchy-Riemann residual|^2 = (X1^2 + X2^2) / (4 area).
    const double w = 1.0 / std::sqrt(std::max(2.0 * std::abs(twiceArea), options.degenerateRatio * longest * longest));
    std::array<double, 3> a, b;
    for (int j = 0; j < 3; ++j) {
      a[j] = w * (p[(j + 1) % 3].y() - p[(j + 2) % 3].y());  // d/dx weights
      b[j] = w * (p[(j + 2) % 3].x() - p[(j + 1) % 3].x());  // d/dy weights
    }
    const std::array<std::pair<int, int>, 6> vc = {std::pair{tri[0], 0}, {tri[1], 0}, {tri[2], 0},
                                                   {tri[0], 1},          {tri[1], 1}, {tri[2], 1}};
    addRow(vc, {a[0], a[1], a[2], -b[0], -b[1], -b[2]});  // du/dx - dv/dy
    addRow(vc, {b[0], b[1], b[2], a[0], a[1], a[2]});     // du/dy + dv/dx
  }
  // Tiny uniform Laplacian (see LscmOptions::regularisation): reg * |x_i - x_j|^2 per triangle edge.
  const double r = std::sqrt(options.regularisation);
  for (const auto& tri : triangles)
    for (int k = 0; k < 3; ++k) {
      const int i = tri[k], j = tri[(k + 1) % 3];
      for (int c = 0; c < 2; ++c)
        addRow({std::pair{i, c}, {j, c}, {i, c}, {i, c}, {i, c}, {i, c}}, {r, -r, 0, 0, 0, 0});
    }

  Eigen::SparseMatrix<double> Q(2 * nf, 2 * nf);
  Q.setFromTriplets(triplets.begin(), triplets.end());
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(Q);
  TM_CHECK(solver.info() == Eigen::Success,
           "lscm: the conformal system of a " + std::to_string(triangles.size()) + "-triangle chart is singular");
  const Eigen::VectorXd x = solver.solve(rhs);
  TM_CHECK(solver.info() == Eigen::Success && x.allFinite(),
           "lscm: solving the conformal system of a " + std::to_string(triangles.size()) + "-triangle chart failed");
  for (int v = 0; v < n; ++v)
    if (freeIndex[v] >= 0) uv[v] = Vec2(x[freeIndex[v]], x[freeIndex[v] + nf]);
  return uv;
}

std::vector<char> checkedUse(const std::vector<Vec3>& positions, const std::vector<std::array<int, 3>>& triangles) {
  const int n = static_cast<int>(positions.size());
  TM_CHECK(!triangles.empty(), "lscm: the chart has no triangles");
  std::vector<char> used(n, 0);
  for (size_t t = 0; t < triangles.size(); ++t)
    for (int v : triangles[t]) {
      TM_CHECK(v >= 0 && v < n, "lscm: triangle " + std::to_string(t) + " has vertex index " + std::to_string(v) +
                                    " outside [0, " + std::to_string(n) + ")");
      used[v] = 1;
    }
  for (const Vec3& p : positions) TM_CHECK(p.allFinite(), "lscm: a vertex position is not finite");
  return used;
}

}  // namespace

std::vector<Vec2> lscm(const std::vector<Vec3>& positions, const std::vector<std::array<int, 3>>& triangles,
                       const LscmOptions& options) {
  const int n = static_cast<int>(positions.size());
  const std::vector<char> used = checkedUse(positions, triangles);
  // Pins: the extreme used vertices along the longest axis of the bounding box. Any two distinct
  // points fix the similarity LSCM leaves free; far-apart ones keep the system well conditioned.
  Vec3 lo = Vec3::Constant(HUGE_VAL), hi = Vec3::Constant(-HUGE_VAL);
  for (int v = 0; v < n; ++v)
    if (used[v]) lo = lo.cwiseMin(positions[v]), hi = hi.cwiseMax(positions[v]);
  int axis = 0;
  (hi - lo).maxCoeff(&axis);
  int pinA = -1, pinB = -1;
  for (int v = 0; v < n; ++v) {
    if (!used[v]) continue;
    if (pinA < 0 || positions[v][axis] < positions[pinA][axis]) pinA = v;
    if (pinB < 0 || positions[v][axis] > positions[pinB][axis]) pinB = v;
  }
  const double span = (positions[pinB] - positions[pinA]).norm();
  if (pinA == pinB || !(span > 0)) return std::vector<Vec2>(n, Vec2::Zero());  // every vertex at one point
  std::vector<Vec2> uv = solveLscm(positions, triangles, {{pinA, Vec2(0, 0)}, {pinB, Vec2(span, 0)}}, used, options);

  double signedArea = 0;
  for (const auto& t : triangles) {
    const Vec2 e1 = uv[t[1]] - uv[t[0]], e2 = uv[t[2]] - uv[t[0]];
    signedArea += e1.x() * e2.y() - e1.y() * e2.x();
  }
  if (signedArea < 0)
    for (Vec2& q : uv) q.x() = -q.x();
  return uv;
}

std::vector<Vec2> lscm(const std::vector<Vec3>& positions, const std::vector<std::array<int, 3>>& triangles,
                       const std::vector<std::pair<int, Vec2>>& pins, const LscmOptions& options) {
  const std::vector<char> used = checkedUse(positions, triangles);
  TM_CHECK(pins.size() >= 2,
           "lscm: at least two pinned vertices are needed, " + std::to_string(pins.size()) + " given");
  for (const auto& [v, at] : pins)
    TM_CHECK(v >= 0 && v < static_cast<int>(positions.size()) && at.allFinite(),
             "lscm: pinned vertex " + std::to_string(v) + " is out of range or not finite");
  return solveLscm(positions, triangles, pins, used, options);
}

FlatteningQuality flatteningQuality(const std::vector<Vec3>& positions,
                                    const std::vector<std::array<int, 3>>& triangles, const std::vector<Vec2>& uv) {
  FlatteningQuality out;
  double area3 = 0, areaUv = 0;
  std::vector<double> faceArea(triangles.size());
  for (size_t t = 0; t < triangles.size(); ++t) {
    const auto& f = triangles[t];
    faceArea[t] = 0.5 * (positions[f[1]] - positions[f[0]]).cross(positions[f[2]] - positions[f[0]]).norm();
    area3 += faceArea[t];
    const Vec2 e1 = uv[f[1]] - uv[f[0]], e2 = uv[f[2]] - uv[f[0]];
    areaUv += 0.5 * std::abs(e1.x() * e2.y() - e1.y() * e2.x());
  }
  if (!(area3 > 0) || !(areaUv > 0)) return out;
  out.areaScale = std::sqrt(area3 / areaUv);
  const double minArea = 1e-12 * area3;
  double sum = 0, weight = 0;
  out.stretchLinf = 0;
  for (size_t t = 0; t < triangles.size(); ++t) {
    if (!(faceArea[t] > minArea)) continue;
    const auto& f = triangles[t];
    const TriangleStretch s =
        triangleStretch({positions[f[0]], positions[f[1]], positions[f[2]]},
                        {uv[f[0]] * out.areaScale, uv[f[1]] * out.areaScale, uv[f[2]] * out.areaScale});
    if (s.flipped) {
      ++out.flipped;
      continue;
    }
    sum += faceArea[t] * s.l2() * s.l2();
    weight += faceArea[t];
    out.stretchLinf = std::max(out.stretchLinf, s.gamma);
  }
  out.stretchL2 = weight > 0 ? std::sqrt(sum / weight) : 1;
  if (weight == 0) out.stretchLinf = 1;
  return out;
}

PatchTopology patchTopology(const std::vector<std::array<int, 3>>& triangles) {
  PatchTopology topo;
  topo.faces = static_cast<int>(triangles.size());
  // Undirected edges as sorted (min, max, face) records: equal keys are adjacent after sorting.
  struct EdgeRec {
    int a, b, face;
  };
  std::vector<EdgeRec> edges;
  edges.reserve(triangles.size() * 3);
  std::vector<int> vertexIds;
  for (size_t t = 0; t < triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      const int a = triangles[t][k], b = triangles[t][(k + 1) % 3];
      edges.push_back({std::min(a, b), std::max(a, b), static_cast<int>(t)});
      vertexIds.push_back(a);
    }
  std::sort(vertexIds.begin(), vertexIds.end());
  vertexIds.erase(std::unique(vertexIds.begin(), vertexIds.end()), vertexIds.end());
  topo.vertices = static_cast<int>(vertexIds.size());
  std::sort(edges.begin(), edges.end(),
            [](const EdgeRec& x, const EdgeRec& y) { return x.a != y.a ? x.a < y.a : x.b < y.b; });

  std::vector<int> parent(triangles.size());
  std::iota(parent.begin(), parent.end(), 0);
  const auto find = [&](int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  std::vector<std::pair<int, int>> boundary;
  for (size_t i = 0; i < edges.size();) {
    size_t j = i;
    while (j < edges.size() && edges[j].a == edges[i].a && edges[j].b == edges[i].b) ++j;
    ++topo.edges;
    if (j - i == 1) boundary.push_back({edges[i].a, edges[i].b});
    for (size_t k = i + 1; k < j; ++k) parent[find(edges[k].face)] = find(edges[i].face);
    i = j;
  }
  for (size_t t = 0; t < triangles.size(); ++t) topo.components += find(static_cast<int>(t)) == static_cast<int>(t);

  // Boundary loops: components of the boundary-edge graph; a vertex with more than two boundary edges
  // is where the region's faces meet in more than one fan.
  const auto local = [&](int v) {
    return static_cast<int>(std::lower_bound(vertexIds.begin(), vertexIds.end(), v) - vertexIds.begin());
  };
  std::vector<int> degree(vertexIds.size(), 0), vparent(vertexIds.size());
  std::iota(vparent.begin(), vparent.end(), 0);
  const auto vfind = [&](int x) {
    while (vparent[x] != x) x = vparent[x] = vparent[vparent[x]];
    return x;
  };
  for (const auto& [a, b] : boundary) {
    const int la = local(a), lb = local(b);
    ++degree[la], ++degree[lb];
    vparent[vfind(la)] = vfind(lb);
  }
  for (size_t v = 0; v < vertexIds.size(); ++v) {
    if (degree[v] > 2) ++topo.pinchedVertices;
    if (degree[v] > 0 && vfind(static_cast<int>(v)) == static_cast<int>(v)) ++topo.boundaryLoops;
  }
  return topo;
}

}  // namespace montage
