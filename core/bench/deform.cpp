// Deformed copies of a mesh (see deform.h).
#include "bench/deform.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "geometry/bvh.h"
#include "geometry/mesh.h"
#include "io/model.h"

namespace montage {

namespace {

double smoothstep(double t) {
  t = std::clamp(t, 0.0, 1.0);
  return t * t * (3 - 2 * t);
}

double degrees(double d) {
  return d * M_PI / 180.0;
}

}  // namespace

std::string Deformation::text() const {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%s:%g", kDeformKindNames[size_t(kind)], amount);
  return buffer;
}

Deformation parseDeformation(const std::string& text) {
  const size_t colon = text.find(':');
  const std::string name = text.substr(0, colon);
  Deformation d;
  const auto it = std::find(kDeformKindNames.begin(), kDeformKindNames.end(), name);
  if (it == kDeformKindNames.end())
    throw Error("--deform: " + text + ": unknown kind \"" + name + "\" (bend, twist, scale, limbs, turn or none)");
  d.kind = DeformKind(it - kDeformKindNames.begin());
  d.amount = d.kind == DeformKind::Scale ? 1.3 : 1.0;
  if (colon != std::string::npos) {
    const std::string number = text.substr(colon + 1);
    char* end = nullptr;
    d.amount = std::strtod(number.c_str(), &end);
    if (number.empty() || end != number.c_str() + number.size() || !std::isfinite(d.amount))
      throw Error("--deform: " + text + ": the amount \"" + number + "\" is not a number");
  }
  if (d.kind == DeformKind::Scale && !(d.amount > 0)) throw Error("--deform: " + text + ": a scale must be > 0");
  return d;
}

std::vector<Vec3> deformPositions(const Mesh& mesh, const Deformation& deformation) {
  const int n = mesh.numVertices();
  std::vector<Vec3> out(n);
  for (int v = 0; v < n; ++v) out[v] = mesh.position(v);
  if (deformation.kind == DeformKind::None || n == 0) return out;

  // The frame: the box's longest axis, +Y (or the second-longest axis) as up, side = a x up.
  Vec3 lo, hi;
  mesh.bounds(lo, hi);
  const Vec3 centre = (lo + hi) / 2, extent = hi - lo;
  int order[3] = {0, 1, 2};
  std::sort(order, order + 3, [&](int i, int j) { return extent[i] > extent[j]; });
  const int longest = order[0];
  const int upAxis = longest == 1 ? order[1] : 1;
  const Vec3 a = Vec3::Unit(longest), up = Vec3::Unit(upAxis), side = a.cross(up);
  const double half = std::max(extent[longest] / 2, 1e-12);
  const double amount = deformation.amount;

  for (int v = 0; v < n; ++v) {
    const Vec3 d = out[v] - centre;
    const double s = d.dot(a), w = d.dot(up), x = d.dot(side), u = s / half;
    Vec3 p = out[v];
    switch (deformation.kind) {
      case DeformKind::Bend: {  // a circular bend in the (a, up) plane, lengths along a kept
        const double total = amount * M_PI / 2;
        if (std::abs(total) < 1e-9) break;
        const double radius = 2 * half / total, phi = s / radius;
        p = centre + (radius - w) * std::sin(phi) * a + (radius - (radius - w) * std::cos(phi)) * up + x * side;
        break;
      }
      case DeformKind::Twist:
        p = centre + Eigen::AngleAxisd(amount * M_PI / 4 * u, a) * d;
        break;
      case DeformKind::Scale:
        p = centre + amount * s * a + (w * up + x * side) / std::sqrt(amount);
        break;
      case DeformKind::Limbs: {  // both ends droop about `side` through their plane's centre
        const double weight = smoothstep((std::abs(u) - 0.4) / 0.2);
        if (weight == 0) break;
        const double sign = u > 0 ? 1 : -1;
        const Vec3 pivot = centre + sign * 0.5 * half * a;
        p = pivot + Eigen::AngleAxisd(-sign * weight * degrees(35 * amount), side) * (out[v] - pivot);
        break;
      }
      case DeformKind::Turn: {  // the + end turned about `up`
        const double weight = smoothstep((u - 0.2) / 0.2);
        if (weight == 0) break;
        const Vec3 pivot = centre + 0.3 * half * a;
        p = pivot + Eigen::AngleAxisd(weight * degrees(40 * amount), up) * (out[v] - pivot);
        break;
      }
      case DeformKind::None:
        break;
    }
    out[v] = p;
  }
  return out;
}

std::unique_ptr<Mesh> withPositions(const Mesh& mesh, const std::vector<Vec3>& positions) {
  TM_CHECK(static_cast<int>(positions.size()) == mesh.numVertices(),
           "withPositions: " + std::to_string(positions.size()) + " positions for " +
               std::to_string(mesh.numVertices()) + " vertices");
  auto out = std::make_unique<Mesh>(mesh);
  for (int v = 0; v < mesh.numVertices(); ++v) {
    const Vec3& p = positions[v];
    out->tri.set_point(OpenMesh::VertexHandle(v), TriMesh::Point(p.x(), p.y(), p.z()));
  }
  return out;
}

void moveToRest(TexturedModel& model, const Mesh& photographed, const Mesh& rest) {
  TM_CHECK(photographed.numFaces() == rest.numFaces() && photographed.numVertices() == rest.numVertices(),
           "moveToRest: the photographed mesh (" + std::to_string(photographed.numVertices()) + " vertices, " +
               std::to_string(photographed.numFaces()) + " faces) is not a deformed copy of the rest mesh (" +
               std::to_string(rest.numVertices()) + ", " + std::to_string(rest.numFaces()) + ")");
  const TriangleBvh bvh(photographed);
  Mesh& mesh = model.mesh;
  for (int v = 0; v < mesh.numVertices(); ++v) {
    const ClosestPoint hit = bvh.closest(mesh.position(v));
    TM_ASSERT(hit.face >= 0);
    const auto q = rest.facePositions(hit.face);
    const Vec3 p = hit.bary[0] * q[0] + hit.bary[1] * q[1] + hit.bary[2] * q[2];
    mesh.tri.set_point(OpenMesh::VertexHandle(v), TriMesh::Point(p.x(), p.y(), p.z()));
  }
}

}  // namespace montage
