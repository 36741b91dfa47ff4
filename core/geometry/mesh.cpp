// Mesh geometry queries, building the half-edge mesh from a triangle soup, and the validation report.
#include "geometry/mesh.h"

#include <Eigen/Geometry>
#include <OpenMesh/Core/System/omstream.hh>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <numeric>
#include <sstream>
#include <tuple>

#include "base/util.h"

namespace montage {

namespace {

using VertexHandle = TriMesh::VertexHandle;
using FaceHandle = TriMesh::FaceHandle;

}  // namespace

// ---- Mesh ------------------------------------------------------------------------------------------------

VertexFaces facesAroundVertices(const Mesh& mesh) {
  VertexFaces out;
  out.offset.assign(mesh.numVertices() + 1, 0);
  for (int f = 0; f < mesh.numFaces(); ++f)
    for (int v : mesh.faceVertices(f)) ++out.offset[v + 1];
  for (int v = 0; v < mesh.numVertices(); ++v) out.offset[v + 1] += out.offset[v];
  out.faces.resize(out.offset.back());
  std::vector<int> next(out.offset.begin(), out.offset.end() - 1);
  for (int f = 0; f < mesh.numFaces(); ++f)
    for (int v : mesh.faceVertices(f)) out.faces[next[v]++] = f;
  return out;
}

double Mesh::faceArea(int f) const {
  const auto p = facePositions(f);
  return 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).norm();
}

Vec3 Mesh::faceNormal(int f) const {
  const auto p = facePositions(f);
  const Vec3 n = (p[1] - p[0]).cross(p[2] - p[0]);
  const double len = n.norm();
  return len > 0 ? Vec3(n / len) : Vec3::Zero();
}

void Mesh::bounds(Vec3& lo, Vec3& hi) const {
  lo = hi = Vec3::Zero();
  for (int v = 0; v < numVertices(); ++v) {
    const Vec3 p = position(v);
    lo = v == 0 ? p : Vec3(lo.cwiseMin(p));
    hi = v == 0 ? p : Vec3(hi.cwiseMax(p));
  }
}

// ---- Report ----------------------------------------------------------------------------------------------

bool MeshReport::usable() const {
  return std::none_of(findings.begin(), findings.end(),
                      [](const MeshFinding& f) { return f.severity == MeshFinding::Severity::Error; });
}

std::string MeshReport::summary() const {
  constexpr int kShown = 10;  // element ids printed per finding
  std::ostringstream out;
  out << (path.empty() ? std::string("mesh") : path) << (format.empty() ? "" : " (" + format + ")") << "\n";
  out << "  file:     " << inputVertices << " vertices, " << inputFaces << " triangles\n";
  out << "  mesh:     " << vertices << " vertices, " << faces << " faces, " << edges << " edges\n";
  out << "  topology: " << components << (components == 1 ? " component, " : " components, ") << boundaryLoops
      << (boundaryLoops == 1 ? " boundary loop, " : " boundary loops, ") << "genus " << genus << "\n";
  out << "  texture coordinates: " << (hasUV ? "yes" : "no") << "; bounding-box diagonal " << diagonal << "\n";
  if (findings.empty()) out << "  no problems found\n";
  for (const MeshFinding& f : findings) {
    out << (f.severity == MeshFinding::Severity::Error ? "  ERROR: " : "  warning: ") << f.what << "\n";
    if (f.elements.empty()) continue;
    out << "    ids:";
    const int shown = std::min<int>(kShown, static_cast<int>(f.elements.size()));
    for (int i = 0; i < shown; ++i) out << (i ? ", " : " ") << f.elements[i];
    if (f.count > shown) out << " ... (" << f.count - shown << " more)";
    out << "\n";
  }
  out << "  usable: " << (usable() ? "yes" : "no") << "\n";
  return out.str();
}

std::unique_ptr<Mesh> requireUsable(LoadedMesh loaded) {
  std::string errors;
  for (const MeshFinding& f : loaded.report.findings)
    if (f.severity == MeshFinding::Severity::Error) errors += (errors.empty() ? "" : "; ") + f.what;
  if (!loaded.mesh && errors.empty()) errors = "no mesh";
  if (!errors.empty()) throw Error(located(loaded.report.path, "mesh is not usable: " + errors));
  return std::move(loaded.mesh);
}

// ---- Building --------------------------------------------------------------------------------------------

namespace {

constexpr int kMaxListed = 50;  // element ids kept per finding
// Coordinates beyond this (model units) are refused: squared lengths, areas and their products must
// stay far from overflow (1e30^4 = 1e120), and no real model is this large. Likewise a mesh whose
// bounding box is below kMinDiagonal would underflow.
constexpr double kMaxCoordinate = 1e30, kMinDiagonal = 1e-30;

// The elements of one kind of finding: the first kMaxListed ids and the total count.
struct IdList {
  std::vector<int> ids;
  int count = 0;
  void add(int id) {
    if (count++ < kMaxListed) ids.push_back(id);
  }
};

void addFinding(MeshReport& report, MeshFinding::Severity severity, const IdList& list, const std::string& what) {
  if (list.count > 0)
    report.findings.push_back({severity, std::to_string(list.count) + " " + what, list.ids, list.count});
}

std::string shortNumber(double x) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", x);
  return text;
}

// For each point, the first point with a bit-identical position (itself when none); -0 equals +0.
std::vector<int> firstWithSamePosition(const std::vector<Vec3>& points) {
  const int n = static_cast<int>(points.size());
  using Key = std::tuple<uint64_t, uint64_t, uint64_t, int>;  // position bits, index
  std::vector<Key> keys(n);
  for (int i = 0; i < n; ++i) {
    uint64_t bits[3];
    for (int d = 0; d < 3; ++d) {
      const double x = points[i][d] + 0.0;
      std::memcpy(&bits[d], &x, sizeof x);
    }
    keys[i] = {bits[0], bits[1], bits[2], i};
  }
  std::sort(keys.begin(), keys.end());
  auto samePosition = [](const Key& a, const Key& b) {
    return std::get<0>(a) == std::get<0>(b) && std::get<1>(a) == std::get<1>(b) && std::get<2>(a) == std::get<2>(b);
  };
  std::vector<int> first(n);
  for (int i = 0, j = 0; i < n; i = j)
    for (j = i; j < n && samePosition(keys[j], keys[i]); ++j) first[std::get<3>(keys[j])] = std::get<3>(keys[i]);
  return first;
}

// Directed edges of the triangle corners, grouped by from-vertex and sorted by (to-vertex, corner), so that
// all corners with edge a->b form one range found by binary search. Corner c = 3t+k is the edge from
// corner k to corner k+1 of triangle t.
class CornerEdges {
 public:
  using Entry = std::pair<int, int>;  // (to-vertex, corner)

  CornerEdges(int numVertices, const std::vector<int>& cornerVertex, const std::vector<char>& use)
      : start_(numVertices + 1, 0) {
    const int nc = static_cast<int>(cornerVertex.size());
    for (int c = 0; c < nc; ++c)
      if (use[c / 3]) ++start_[cornerVertex[c] + 1];
    std::partial_sum(start_.begin(), start_.end(), start_.begin());
    entries_.resize(start_.back());
    std::vector<int> fill(start_.begin(), start_.end() - 1);
    for (int c = 0; c < nc; ++c)
      if (use[c / 3]) entries_[fill[cornerVertex[c]]++] = {cornerVertex[nextCorner(c)], c};
    for (int v = 0; v < numVertices; ++v) std::sort(entries_.begin() + start_[v], entries_.begin() + start_[v + 1]);
  }

  static int nextCorner(int c) { return c % 3 == 2 ? c - 2 : c + 1; }

  // The corners whose edge goes from a to b.
  std::pair<const Entry*, const Entry*> range(int a, int b) const {
    const Entry* lo = entries_.data() + start_[a];
    const Entry* hi = entries_.data() + start_[a + 1];
    return {std::lower_bound(lo, hi, Entry{b, -1}), std::lower_bound(lo, hi, Entry{b + 1, -1})};
  }

 private:
  std::vector<int> start_;
  std::vector<Entry> entries_;
};

enum class Drop { None, RepeatedVertex, Duplicate, ComplexEdge, Orientation, NonManifoldVertex, NonOrientable };
constexpr int kNumDrops = 7;

// Consistent orientation (breadth first over the faces, through the edges that exactly two faces
// share): a face that walks a shared edge in the same direction as its neighbour is turned over. In
// each edge-connected part the orientation most faces had in the file wins. Where the part cannot be
// oriented (a Moebius band), the face met last at each edge that still disagrees is marked
// `nonOrientable`; removing those leaves every shared edge consistent. Returns per face whether to
// turn it over.
std::vector<char> orientFaces(int nt, const std::vector<int>& cornerVertex, const std::vector<char>& candidate,
                              const CornerEdges& edges, std::vector<char>& nonOrientable) {
  // The neighbour across the edge of corner c, and whether it walks the edge the same way (-1: none).
  const auto across = [&](int c, bool& sameWay) {
    const int a = cornerVertex[c], b = cornerVertex[CornerEdges::nextCorner(c)];
    const auto ab = edges.range(a, b), ba = edges.range(b, a);
    if ((ab.second - ab.first) + (ba.second - ba.first) != 2) return -1;  // boundary or non-manifold
    if (ba.first != ba.second) {
      sameWay = false;
      return ba.first->second / 3;
    }
    sameWay = true;
    return (ab.first->second == c ? ab.first + 1 : ab.first)->second / 3;
  };
  std::vector<char> flip(nt, 0), seen(nt, 0);
  std::vector<int> order(nt, -1), queue, component;
  int visited = 0;
  for (int start = 0; start < nt; ++start) {
    if (!candidate[start] || seen[start]) continue;
    component.clear();
    queue.assign(1, start);
    seen[start] = 1;
    for (size_t q = 0; q < queue.size(); ++q) {
      const int t = queue[q];
      order[t] = visited++;
      component.push_back(t);
      for (int k = 0; k < 3; ++k) {
        bool sameWay = false;
        const int u = across(3 * t + k, sameWay);
        if (u < 0 || seen[u]) continue;
        seen[u] = 1;
        flip[u] = flip[t] ^ sameWay;
        queue.push_back(u);
      }
    }
    size_t turned = 0;
    for (int t : component) turned += flip[t];
    if (2 * turned > component.size())
      for (int t : component) flip[t] ^= 1;
  }
  for (int t = 0; t < nt; ++t) {
    if (!candidate[t]) continue;
    for (int k = 0; k < 3; ++k) {
      bool sameWay = false;
      const int u = across(3 * t + k, sameWay);
      if (u >= 0 && (flip[t] ^ flip[u] ^ sameWay)) nonOrientable[order[t] > order[u] ? t : u] = 1;
    }
  }
  return flip;
}

// Silences OpenMesh's error stream while the mesh is built: dropped faces are reported instead.
struct OmerrSilencer {
  bool wasEnabled = ::omerr().is_enabled();
  OmerrSilencer() { ::omerr().disable(); }
  ~OmerrSilencer() {
    if (wasEnabled) ::omerr().enable();
  }
};

// Components, edges, boundary loops and genus of the built mesh.
void analyzeTopology(const TriMesh& tri, MeshReport& report) {
  const int nf = static_cast<int>(tri.n_faces());
  UnionFind faces(nf);
  for (auto e : tri.edges())
    if (!e.is_boundary()) faces.unite(e.h0().face().idx(), e.h1().face().idx());
  std::vector<int> component(nf);
  int numComponents = 0;
  for (int f = 0; f < nf; ++f) component[f] = faces.find(f) == f ? numComponents++ : component[faces.find(f)];

  std::vector<long long> V(numComponents), E(numComponents), F(numComponents), B(numComponents);
  for (int f = 0; f < nf; ++f) ++F[component[f]];
  for (auto e : tri.edges()) ++E[component[(e.h0().is_boundary() ? e.h1() : e.h0()).face().idx()]];
  std::vector<int> seen;
  for (auto v : tri.vertices()) {
    seen.clear();
    for (auto f : v.faces())
      if (std::find(seen.begin(), seen.end(), component[f.idx()]) == seen.end()) seen.push_back(component[f.idx()]);
    for (int c : seen) ++V[c];
  }
  std::vector<char> visited(tri.n_halfedges(), 0);
  for (auto h : tri.halfedges()) {
    if (!h.is_boundary() || visited[h.idx()]) continue;
    ++B[component[h.opp().face().idx()]];
    for (auto g = h; !visited[g.idx()]; g = g.next()) visited[g.idx()] = 1;
  }

  report.edges = static_cast<int>(tri.n_edges());
  report.components = numComponents;
  report.boundaryLoops = static_cast<int>(std::accumulate(B.begin(), B.end(), 0LL));
  report.genus = 0;
  for (int c = 0; c < numComponents; ++c) report.genus += static_cast<int>((2 - (V[c] - E[c] + F[c]) - B[c]) / 2);
}

}  // namespace

LoadedMesh buildMesh(const std::vector<Vec3>& vertices, const std::vector<std::array<int, 3>>& triangles,
                     const std::vector<std::array<Vec2, 3>>& uv, const MeshLoadOptions& options,
                     const std::string& name) {
  const int nIn = static_cast<int>(vertices.size());
  const int nt = static_cast<int>(triangles.size());
  TM_CHECK(uv.empty() || uv.size() == triangles.size(),
           located(name, std::to_string(uv.size()) + " UV triples for " + std::to_string(nt) + " triangles"));
  for (int t = 0; t < nt; ++t)
    for (int v : triangles[t])
      TM_CHECK(v >= 0 && v < nIn, located(name, "face " + std::to_string(t) + ": vertex index " + std::to_string(v) +
                                                    " out of range (" + std::to_string(nIn) + " vertices)"));

  LoadedMesh out;
  MeshReport& report = out.report;
  report.path = name;
  report.inputVertices = nIn;
  report.inputFaces = nt;
  using Severity = MeshFinding::Severity;

  // Mesh vertices: the input vertices, or one per distinct position when welding. `origin` maps every
  // mesh vertex (including the copies made by splitting below) to its input vertex.
  const std::vector<int> first = firstWithSamePosition(vertices);
  std::vector<int> meshVertex(nIn), origin;
  IdList sharedPositions, nonFinite, huge;
  for (int i = 0; i < nIn; ++i) {
    if (!vertices[i].allFinite())
      nonFinite.add(i);
    else if (vertices[i].cwiseAbs().maxCoeff() > kMaxCoordinate)
      huge.add(i);
    if (options.weldIdenticalPositions) {
      if (first[i] == i) origin.push_back(i);
      meshVertex[i] = first[i] == i ? static_cast<int>(origin.size()) - 1 : meshVertex[first[i]];
    } else {
      meshVertex[i] = i;
      origin.push_back(i);
      if (first[i] != i) sharedPositions.add(i);
    }
  }
  const int nv = static_cast<int>(origin.size());

  // Faces that cannot enter the mesh: repeated vertex, then duplicate vertex set (any orientation).
  std::vector<int> cornerVertex(3 * nt);
  std::vector<Drop> drop(nt, Drop::None);
  std::vector<std::pair<std::array<int, 3>, int>> sorted;  // (sorted vertex set, face)
  sorted.reserve(nt);
  for (int t = 0; t < nt; ++t) {
    std::array<int, 3> c;
    for (int k = 0; k < 3; ++k) c[k] = cornerVertex[3 * t + k] = meshVertex[triangles[t][k]];
    if (c[0] == c[1] || c[1] == c[2] || c[2] == c[0]) {
      drop[t] = Drop::RepeatedVertex;
      continue;
    }
    std::sort(c.begin(), c.end());
    sorted.push_back({c, t});
  }
  std::sort(sorted.begin(), sorted.end());
  for (size_t i = 1; i < sorted.size(); ++i)
    if (sorted[i].first == sorted[i - 1].first) drop[sorted[i].second] = Drop::Duplicate;

  // Consistent orientation: faces turned over, faces of non-orientable parts dropped.
  std::vector<char> candidate(nt);
  for (int t = 0; t < nt; ++t) candidate[t] = drop[t] == Drop::None;
  std::vector<char> nonOrientable(nt, 0);
  const std::vector<char> flip =
      orientFaces(nt, cornerVertex, candidate, CornerEdges(nv, cornerVertex, candidate), nonOrientable);
  IdList flipped;
  for (int t = 0; t < nt; ++t) {
    if (!candidate[t]) continue;
    if (nonOrientable[t]) {
      drop[t] = Drop::NonOrientable;
      candidate[t] = 0;
    } else if (flip[t]) {
      std::swap(cornerVertex[3 * t + 1], cornerVertex[3 * t + 2]);
      flipped.add(t);
    }
  }
  report.flippedFaces = flipped.count;
  // Corner k of the built face t is corner inputCorner(t, k) of the input triangle.
  const auto inputCorner = [&](int t, int k) { return flip[t] && !nonOrientable[t] ? (3 - k) % 3 : k; };

  // Non-manifold input edges (more than two of the remaining faces), counted once at their lowest corner.
  const CornerEdges edges(nv, cornerVertex, candidate);
  for (int c = 0; c < 3 * nt; ++c) {
    if (!candidate[c / 3]) continue;
    const int a = cornerVertex[c], b = cornerVertex[CornerEdges::nextCorner(c)];
    auto ab = edges.range(a, b), ba = edges.range(b, a);
    if ((ab.second - ab.first) + (ba.second - ba.first) > 2 && ab.first->second == c &&
        (ba.first == ba.second || ba.first->second > c))
      ++report.nonManifoldEdges;
  }

  // In file order, a face is accepted when none of its directed edges is taken by an accepted face; this is
  // OpenMesh's complex-edge rule, decided here so that vertices can be split before building.
  std::vector<char> accepted(nt, 0);
  auto taken = [&](int a, int b) {
    auto r = edges.range(a, b);
    return std::any_of(r.first, r.second, [&](const CornerEdges::Entry& e) { return accepted[e.second / 3]; });
  };
  for (int t = 0; t < nt; ++t) {
    if (!candidate[t]) continue;
    for (int k = 0; k < 3 && drop[t] == Drop::None; ++k) {
      const int a = cornerVertex[3 * t + k], b = cornerVertex[3 * t + (k + 1) % 3];
      if (taken(a, b)) drop[t] = taken(b, a) ? Drop::ComplexEdge : Drop::Orientation;
    }
    accepted[t] = drop[t] == Drop::None;
  }

  // Fans: corners at one vertex joined across shared edges. The fan met first keeps the vertex id, each
  // further fan makes the vertex non-manifold and gets a new vertex appended (when splitting).
  UnionFind fans(3 * nt);
  size_t numEdges = 0;
  for (int c = 0; c < 3 * nt; ++c) {
    if (!accepted[c / 3]) continue;
    const int v = cornerVertex[c], w = cornerVertex[CornerEdges::nextCorner(c)];
    auto twin = edges.range(w, v);
    bool interior = false;
    for (auto e = twin.first; e != twin.second; ++e)
      if (accepted[e->second / 3]) {
        fans.unite(c, CornerEdges::nextCorner(e->second));
        interior = true;
      }
    numEdges += !interior || v < w;
  }
  std::vector<int> fanVertex(3 * nt, -1), finalVertex(3 * nt, -1);
  std::vector<char> hasFan(nv, 0), nonManifold(nv, 0);
  IdList nonManifoldVertices;
  int extraVertices = 0;
  for (int c = 0; c < 3 * nt; ++c) {
    if (!accepted[c / 3]) continue;
    const int root = fans.find(c), v = cornerVertex[c];
    if (fanVertex[root] < 0) {
      if (!hasFan[v]) {
        hasFan[v] = 1;
        fanVertex[root] = v;
      } else {
        if (!nonManifold[v]) nonManifoldVertices.add(origin[v]);
        nonManifold[v] = 1;
        fanVertex[root] = v;
        if (options.splitNonManifoldVertices) {
          fanVertex[root] = static_cast<int>(origin.size());
          origin.push_back(origin[v]);
          ++extraVertices;
        }
      }
    }
    finalVertex[c] = fanVertex[root];
  }
  report.nonManifoldVertices = nonManifoldVertices.count;

  // The half-edge mesh. add_face only fails at non-manifold vertices when splitting is off.
  out.mesh = std::make_unique<Mesh>();
  Mesh& mesh = *out.mesh;
  TriMesh& tri = mesh.tri;
  tri.reserve(origin.size(), numEdges, nt);
  for (int o : origin) tri.add_vertex(TriMesh::Point(vertices[o][0], vertices[o][1], vertices[o][2]));
  mesh.vertexOrigin = origin;
  {
    OmerrSilencer silence;
    for (int t = 0; t < nt; ++t) {
      if (!accepted[t]) continue;
      const auto f = tri.add_face(VertexHandle(finalVertex[3 * t]), VertexHandle(finalVertex[3 * t + 1]),
                                  VertexHandle(finalVertex[3 * t + 2]));
      if (f.is_valid())
        mesh.faceOrigin.push_back(t);
      else
        drop[t] = Drop::NonManifoldVertex;
    }
  }

  // Corner UVs, rotated into faceVertices() order.
  if (!uv.empty()) {
    mesh.cornerUV.resize(mesh.numFaces());
    for (int f = 0; f < mesh.numFaces(); ++f) {
      const int t = mesh.faceOrigin[f];
      const int v0 = mesh.faceVertices(f)[0];
      const int k = finalVertex[3 * t] == v0 ? 0 : finalVertex[3 * t + 1] == v0 ? 1 : 2;
      TM_ASSERT(finalVertex[3 * t + k] == v0);
      mesh.cornerUV[f] = {uv[t][inputCorner(t, k)], uv[t][inputCorner(t, (k + 1) % 3)],
                          uv[t][inputCorner(t, (k + 2) % 3)]};
    }
  }

  // Counts and findings.
  report.vertices = mesh.numVertices();
  report.faces = mesh.numFaces();
  report.hasUV = mesh.hasUV();
  analyzeTopology(tri, report);
  Vec3 lo, hi;
  mesh.bounds(lo, hi);
  report.diagonal = (hi - lo).norm();

  if (report.faces == 0)
    report.findings.push_back(
        {Severity::Error, nt == 0 ? "no faces" : "no faces left after dropping invalid ones", {}, 0});
  addFinding(report, Severity::Error, nonFinite, "vertices with non-finite coordinates (NaN or infinite)");
  addFinding(report, Severity::Error, huge,
             "vertices with coordinates beyond +-1e30 model units: the geometry would overflow (scale the mesh down)");
  if (nonFinite.count == 0 && huge.count == 0 && report.faces > 0 && report.diagonal < kMinDiagonal)
    report.findings.push_back({Severity::Error,
                               "the mesh is too small (bounding-box diagonal " + shortNumber(report.diagonal) +
                                   " model units, below 1e-30): its areas would underflow (scale the mesh up)",
                               {},
                               0});

  IdList dropped[kNumDrops];
  for (int t = 0; t < nt; ++t)
    if (drop[t] != Drop::None) dropped[static_cast<int>(drop[t])].add(t);
  report.duplicateFaces = dropped[static_cast<int>(Drop::Duplicate)].count;
  report.droppedFaces = nt - report.faces;
  addFinding(report, Severity::Warning, dropped[static_cast<int>(Drop::RepeatedVertex)],
             "faces dropped: degenerate (repeated vertex)");
  addFinding(report, Severity::Warning, dropped[static_cast<int>(Drop::Duplicate)],
             "faces dropped: duplicate (same vertices as an earlier face)");
  addFinding(report, Severity::Warning, dropped[static_cast<int>(Drop::ComplexEdge)],
             "faces dropped: complex edge (the edge would have more than two faces)");
  addFinding(report, Severity::Warning, dropped[static_cast<int>(Drop::Orientation)],
             "faces dropped: orientation conflict (an edge used twice in the same direction)");
  addFinding(report, Severity::Warning, dropped[static_cast<int>(Drop::NonManifoldVertex)],
             "faces dropped: non-manifold vertex (vertex splitting is off)");
  addFinding(report, Severity::Warning, flipped,
             "faces turned over to agree with their neighbours (the file's orientation was inconsistent)");
  report.nonOrientableFaces = dropped[static_cast<int>(Drop::NonOrientable)].count;
  addFinding(report, Severity::Warning, dropped[static_cast<int>(Drop::NonOrientable)],
             "faces dropped: the surface is not orientable there (a Moebius-like band); each closed an orientation "
             "conflict");
  if (report.nonManifoldEdges > 0)
    report.findings.push_back(
        {Severity::Warning,
         std::to_string(report.nonManifoldEdges) + " non-manifold edges in the file (used by more than two faces)",
         {},
         report.nonManifoldEdges});
  addFinding(report, Severity::Warning, nonManifoldVertices,
             options.splitNonManifoldVertices ? "non-manifold vertices (faces form several fans): split into " +
                                                    std::to_string(extraVertices) + " extra vertices"
                                              : "non-manifold vertices (faces form several fans): not split");

  IdList zeroArea, unreferenced;
  const double minArea = 1e-12 * report.diagonal * report.diagonal;
  if (nonFinite.count == 0 && huge.count == 0)
    for (int f = 0; f < mesh.numFaces(); ++f)
      if (const double a = mesh.faceArea(f); a < minArea || a == 0) zeroArea.add(mesh.faceOrigin[f]);
  for (int v = 0; v < nv; ++v)
    if (tri.is_isolated(VertexHandle(v))) unreferenced.add(origin[v]);
  report.zeroAreaFaces = zeroArea.count;
  report.unreferencedVertices = unreferenced.count;
  addFinding(report, Severity::Warning, zeroArea, "faces with zero area (kept)");
  addFinding(report, Severity::Warning, unreferenced, "vertices used by no face (kept, ignored)");
  addFinding(report, Severity::Warning, sharedPositions,
             "vertices have the same position as an earlier vertex (e.g. a mesh split at UV seams), which "
             "leaves the seams open; the project option weldIdenticalPositions (on by default) welds them");
  return out;
}

WeldedMesh weldIdenticalPositions(const Mesh& loaded, bool canonicalOrder) {
  WeldedMesh out;
  const int nv = loaded.numVertices(), nf = loaded.numFaces();
  std::vector<Vec3> positions(nv);
  for (int v = 0; v < nv; ++v) positions[v] = loaded.position(v);
  const std::vector<int> first = firstWithSamePosition(positions);
  for (int v = 0; v < nv; ++v) out.mergedVertices += first[v] != v;
  if (out.mergedVertices == 0 && !canonicalOrder) return out;

  // The loaded faces as a soup, built again with welding; in canonical order, the vertices sorted by position
  // (then id) and the faces by their corners' ranks, each face rotated to start at its smallest (orientation
  // kept). `vertexAt` and `faceAt` give the loaded id of a soup vertex and face, so that the welded mesh's
  // vertexOrigin and faceOrigin index the loaded mesh.
  std::vector<int> vertexAt(nv), faceAt(nf);
  std::iota(vertexAt.begin(), vertexAt.end(), 0);
  std::iota(faceAt.begin(), faceAt.end(), 0);
  std::vector<std::array<int, 3>> corners(nf);
  std::vector<std::array<Vec2, 3>> uv = loaded.cornerUV;
  for (int f = 0; f < nf; ++f) corners[f] = loaded.faceVertices(f);
  if (canonicalOrder) {
    std::stable_sort(vertexAt.begin(), vertexAt.end(), [&](int a, int b) {
      return std::lexicographical_compare(positions[a].data(), positions[a].data() + 3, positions[b].data(),
                                          positions[b].data() + 3);
    });
    std::vector<int> rank(nv);
    for (int i = 0; i < nv; ++i) rank[vertexAt[i]] = i;
    for (int f = 0; f < nf; ++f) {
      std::array<int, 3> c = {rank[corners[f][0]], rank[corners[f][1]], rank[corners[f][2]]};
      const int r = int(std::min_element(c.begin(), c.end()) - c.begin());
      corners[f] = {c[r], c[(r + 1) % 3], c[(r + 2) % 3]};
      if (!uv.empty())
        uv[f] = {loaded.cornerUV[f][r], loaded.cornerUV[f][(r + 1) % 3], loaded.cornerUV[f][(r + 2) % 3]};
    }
    std::stable_sort(faceAt.begin(), faceAt.end(), [&](int a, int b) { return corners[a] < corners[b]; });
  }
  std::vector<Vec3> soupPositions(nv);
  std::vector<std::array<int, 3>> triangles(nf);
  std::vector<std::array<Vec2, 3>> soupUV(uv.empty() ? 0 : nf);
  for (int i = 0; i < nv; ++i) soupPositions[i] = positions[vertexAt[i]];
  for (int j = 0; j < nf; ++j) {
    triangles[j] = canonicalOrder ? corners[faceAt[j]] : corners[j];
    if (!uv.empty()) soupUV[j] = uv[faceAt[j]];
  }
  MeshLoadOptions options;
  options.weldIdenticalPositions = true;
  LoadedMesh built = buildMesh(soupPositions, triangles, soupUV, options, "welded mesh");
  out.report = std::move(built.report);
  out.mesh = std::move(built.mesh);
  Mesh& mesh = *out.mesh;
  for (int& v : mesh.vertexOrigin) v = vertexAt[v];
  for (int& f : mesh.faceOrigin) f = faceAt[f];
  auto labels = [&](const std::vector<int>& from, std::vector<int>& ids) {
    if (from.empty()) return;
    ids.resize(mesh.numFaces());
    for (int f = 0; f < mesh.numFaces(); ++f) ids[f] = from[mesh.faceOrigin[f]];
  };
  labels(loaded.faceMaterial, mesh.faceMaterial);
  mesh.materialNames = loaded.materialNames;
  mesh.mtllib = loaded.mtllib;
  labels(loaded.faceGroup, mesh.faceGroup);
  mesh.groupNames = loaded.groupNames;

  // Faces map one to one; a vertex maps to the welded corner at its position in a face around it (exact
  // at vertices a non-manifold fan split into several), else to the first welded vertex at its position.
  out.faceOf.assign(nf, -1);
  out.vertexOf.assign(nv, -1);
  for (int w = 0; w < mesh.numFaces(); ++w) {
    const int g = mesh.faceOrigin[w];
    out.faceOf[g] = w;
    const auto wv = mesh.faceVertices(w);
    for (int v : loaded.faceVertices(g))
      for (int u : wv)
        if (positions[v] == mesh.position(u)) out.vertexOf[v] = u;
  }
  std::vector<int> weldedOfFirst(nv, -1);
  for (int u = 0; u < mesh.numVertices(); ++u)
    if (weldedOfFirst[mesh.vertexOrigin[u]] < 0) weldedOfFirst[mesh.vertexOrigin[u]] = u;
  for (int v = 0; v < nv; ++v)
    if (out.vertexOf[v] < 0 && !loaded.tri.is_isolated(VertexHandle(v))) out.vertexOf[v] = weldedOfFirst[first[v]];
  return out;
}

}  // namespace montage
