#include "io/mesh_anchors.h"

#include <algorithm>
#include <cstdio>
#include <memory>
#include <nanoflann.hpp>
#include <set>

#include "base/hash.h"

namespace montage {

namespace {

// Points as a nanoflann dataset.
struct Cloud {
  std::vector<Vec3> p;
  size_t kdtree_get_point_count() const { return p.size(); }
  double kdtree_get_pt(size_t i, size_t d) const { return p[i][int(d)]; }
  template <class Box>
  bool kdtree_get_bbox(Box&) const {
    return false;
  }
};
using CloudTree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, Cloud>, Cloud, 3, uint32_t>;

// The nearest of `cloud` to `q` and its distance.
std::pair<int, double> nearest(const CloudTree& tree, const Vec3& q) {
  uint32_t index = 0;
  double d2 = 0;
  nanoflann::KNNResultSet<double, uint32_t> result(1);
  result.init(&index, &d2);
  tree.findNeighbors(result, q.data(), nanoflann::SearchParams());
  return {int(index), std::sqrt(d2)};
}

Vec3 centroid(const Mesh& mesh, int f) {
  const auto q = mesh.facePositions(f);
  return (q[0] + q[1] + q[2]) / 3.0;
}

// Every vertex and face id the project names.
void idsOf(const Project& p, std::set<int>& vertices, std::set<int>& faces) {
  for (const FeaturePoint& point : p.points) vertices.insert(point.vertex);
  for (const Stroke& s : p.strokes) vertices.insert(s.vertices.begin(), s.vertices.end());
  for (const CloneOp& c : p.clones) {
    vertices.insert(c.anchorVertex);
    faces.insert(c.targetFaces.begin(), c.targetFaces.end());
  }
  for (const DeclinedProposal& d : p.declinedProposals) vertices.insert(d.vertex);
  for (const HoleMode& h : p.holeModes) faces.insert(h.face);
}

std::string sizes(int vertices, int faces) {
  return std::to_string(vertices) + " vertices and " + std::to_string(faces) + " faces";
}

}  // namespace

std::string meshFingerprint(const Mesh& mesh) {
  uint64_t h = hashMix(hashMix(0x5441ull, mesh.numVertices()), mesh.numFaces());
  for (int v = 0; v < mesh.numVertices(); ++v) h = hashMix(h, mesh.position(v));
  for (int f = 0; f < mesh.numFaces(); ++f)
    for (int v : mesh.faceVertices(f)) h = hashMix(h, v);
  char text[17];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(h));
  return text;
}

MeshAnchors anchorsOf(const Project& project, const Mesh& mesh, const std::string& fingerprint) {
  MeshAnchors a;
  a.present = true;
  a.fingerprint = fingerprint.empty() ? meshFingerprint(mesh) : fingerprint;
  a.vertices = mesh.numVertices(), a.faces = mesh.numFaces();
  std::set<int> vertices, faces;
  idsOf(project, vertices, faces);
  for (int v : vertices)
    if (v >= 0 && v < mesh.numVertices()) a.vertex[v] = mesh.position(v);
  for (int f : faces)
    if (f >= 0 && f < mesh.numFaces()) a.face[f] = centroid(mesh, f);
  return a;
}

bool meshChanged(const Project& project, const std::string& fingerprint) {
  return project.anchors.present && project.anchors.fingerprint != fingerprint;
}

MeshCarry carryToMesh(Project& project, const Mesh& mesh, const std::string& fingerprint) {
  MeshCarry out;
  if (!project.anchors.present) return out;
  const std::string current = fingerprint.empty() ? meshFingerprint(mesh) : fingerprint;
  if (!meshChanged(project, current)) return out;
  const MeshAnchors& a = project.anchors;
  const std::string file = project.file.empty() ? "project" : project.file;
  const std::string then = sizes(a.vertices, a.faces), now = sizes(mesh.numVertices(), mesh.numFaces());
  std::set<int> vertices, faces;
  idsOf(project, vertices, faces);
  for (int v : vertices)
    TM_CHECK(a.vertex.count(v),
             located(file, "the mesh changed since the project was saved (" + then + " then, " + now +
                               " now, another fingerprint), and the position of vertex " + std::to_string(v) +
                               " is not stored (anchors.vertex): open the project with the mesh it was made on, "
                               "save it, then relink the new mesh"));
  for (int f : faces)
    TM_CHECK(a.face.count(f), located(file, "the mesh changed since the project was saved (" + then + " then, " + now +
                                                " now, another fingerprint), and the centre of face " +
                                                std::to_string(f) + " is not stored (anchors.face)"));

  double edges = 0;
  int count = 0;
  for (int f = 0; f < mesh.numFaces(); ++f) {
    const auto q = mesh.facePositions(f);
    for (int k = 0; k < 3; ++k) edges += (q[k] - q[(k + 1) % 3]).norm(), ++count;
  }
  const double edge = count ? edges / count : 1;

  Cloud points, centres;
  for (int v = 0; v < mesh.numVertices(); ++v) points.p.push_back(mesh.position(v));
  for (int f = 0; f < mesh.numFaces(); ++f) centres.p.push_back(centroid(mesh, f));
  CloudTree pointTree(3, points, nanoflann::KDTreeSingleIndexAdaptorParams(16));
  CloudTree centreTree(3, centres, nanoflann::KDTreeSingleIndexAdaptorParams(16));
  std::map<int, int> vertexTo, faceTo;
  std::set<int> movedVertices;
  auto land = [&](const std::pair<int, double>& hit, int id, std::map<int, int>& to, bool vertex) {
    to[id] = hit.first;
    out.farthest = std::max(out.farthest, hit.second / edge);
    if (hit.second > 0.5 * edge) {
      ++out.moved;
      if (vertex) movedVertices.insert(id);
    }
  };
  for (const auto& [v, position] : a.vertex)
    if (vertices.count(v)) land(nearest(pointTree, position), v, vertexTo, true);
  for (const auto& [f, c] : a.face)
    if (faces.count(f)) land(nearest(centreTree, c), f, faceTo, false);
  out.vertexIds = int(vertexTo.size()), out.faceIds = int(faceTo.size());

  for (size_t i = 0; i < project.points.size(); ++i) {
    FeaturePoint& p = project.points[i];
    if (movedVertices.count(p.vertex)) out.movedPoints.push_back(p.id >= 0 ? p.id : int(i));
    p.vertex = vertexTo.at(p.vertex);
  }
  for (Stroke& s : project.strokes) {
    for (int& v : s.vertices) v = vertexTo.at(v);
    s.vertices.erase(std::unique(s.vertices.begin(), s.vertices.end()), s.vertices.end());
  }
  for (CloneOp& c : project.clones) {
    c.anchorVertex = vertexTo.at(c.anchorVertex);
    std::set<int> seen;
    std::vector<int> kept;
    for (int f : c.targetFaces)
      if (seen.insert(faceTo.at(f)).second) kept.push_back(faceTo.at(f));
    c.targetFaces = std::move(kept);
  }
  for (DeclinedProposal& d : project.declinedProposals) d.vertex = vertexTo.at(d.vertex);
  for (HoleMode& h : project.holeModes) h.face = faceTo.at(h.face);
  project.anchors = anchorsOf(project, mesh, current);
  out.changed = true;

  char farthest[32];
  std::snprintf(farthest, sizeof farthest, "%.2f", out.farthest);
  out.message = "the mesh changed since the project was saved (" + then + " then, " + now +
                " now): " + std::to_string(out.vertexIds) + " vertex and " + std::to_string(out.faceIds) +
                " face references carried to the nearest of the new mesh, farthest " + farthest + " mean edges";
  if (out.moved == 0) {
    out.message += "; none moved";
  } else {
    out.message += "; " + std::to_string(out.moved) + " moved more than half an edge";
    if (!out.movedPoints.empty()) {
      out.message += " (points";
      for (size_t i = 0; i < out.movedPoints.size() && i < 12; ++i)
        out.message += " " + std::to_string(out.movedPoints[i]);
      if (out.movedPoints.size() > 12) out.message += " ...";
      out.message += ": check them)";
    }
  }
  return out;
}

}  // namespace montage
