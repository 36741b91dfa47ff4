#include "geometry/raster.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <utility>

#include "geometry/mesh.h"

namespace montage {

namespace {

constexpr double kNearPlane = 1e-6;

// Edge function of the directed edge a->b: E(p) > 0 when p is on the left of a->b in a y-down image
// (the interior side for a triangle with positive area E(p0, p1, p2)). It is evaluated from the
// endpoints in a canonical order and multiplied by the sign of the direction, so E(a, b, p) ==
// -E(b, a, p) holds exactly in floating point: two triangles sharing an edge agree on the side of
// every pixel centre, which makes the fill rule exact.
struct EdgeFunction {
  double sx, sy, dx, dy, sign;
  // Top-left rule for a triangle with positive area: an edge whose interior normal (-dy, dx) points
  // down (a horizontal "top" edge) or right (a "left" edge) owns the pixel centres lying on it.
  bool ownsTies;

  EdgeFunction(const Vec2& a, const Vec2& b) {
    const bool swap = b.x() < a.x() || (b.x() == a.x() && b.y() < a.y());
    const Vec2& s = swap ? b : a;
    const Vec2& e = swap ? a : b;
    sx = s.x();
    sy = s.y();
    dx = e.x() - s.x();
    dy = e.y() - s.y();
    sign = swap ? -1.0 : 1.0;
    const double ddx = b.x() - a.x(), ddy = b.y() - a.y();
    ownsTies = ddy < 0 || (ddy == 0 && ddx > 0);
  }
  double rowTerm(double py) const { return dx * (py - sy); }
  double atRow(double rowTerm, double px) const { return sign * (rowTerm - dy * (px - sx)); }
  double at(double px, double py) const { return atRow(rowTerm(py), px); }
  bool inside(double e) const { return e > 0 || (e == 0 && ownsTies); }
};

// The first and last pixel whose centre (i + 0.5) lies within [lo, hi], clamped to [first, last]; as
// doubles, so that a far coordinate is clamped before any cast. Empty when the first exceeds the last.
std::pair<double, double> centresWithin(double lo, double hi, double first, double last) {
  return {std::max(first, std::ceil(lo - 0.5)), std::min(last, std::floor(hi - 0.5))};
}

// Scan-converts a triangle and calls visit(x, y, e) with e[k] the (unnormalised) edge function
// opposite corner k, so that e / e.sum() are the barycentrics of the pixel centre. Visits nothing
// for degenerate triangles. Only rows in [rowLo, rowHi) are visited: a row's pixels do not depend on
// which rows are visited.
template <class Visit>
void scan(const std::array<Vec2, 3>& p, int width, int height, Visit&& visit, int rowLo = 0,
          int rowHi = std::numeric_limits<int>::max()) {
  for (const Vec2& q : p)
    if (!std::isfinite(q.x()) || !std::isfinite(q.y())) return;
  // Orient the triangle so that its area is positive; `perm` maps oriented corners to input corners.
  std::array<int, 3> perm = {0, 1, 2};
  const double area = EdgeFunction(p[0], p[1]).at(p[2].x(), p[2].y());
  if (area == 0) return;
  if (area < 0) std::swap(perm[1], perm[2]);
  const Vec2& a = p[perm[0]];
  const Vec2& b = p[perm[1]];
  const Vec2& c = p[perm[2]];
  const double minX = std::min({a.x(), b.x(), c.x()}), maxX = std::max({a.x(), b.x(), c.x()});
  const double minY = std::min({a.y(), b.y(), c.y()}), maxY = std::max({a.y(), b.y(), c.y()});
  // Pixels whose centre (x + 0.5, y + 0.5) lies in the bounding box.
  const auto [fx0, fx1] = centresWithin(minX, maxX, 0, width - 1.0);
  const auto [fy0, fy1] = centresWithin(minY, maxY, std::max(0, rowLo), std::min(height, rowHi) - 1.0);
  if (fx0 > fx1 || fy0 > fy1) return;
  const int x0 = static_cast<int>(fx0), x1 = static_cast<int>(fx1);
  const int y0 = static_cast<int>(fy0), y1 = static_cast<int>(fy1);
  // Edge k is opposite oriented corner k.
  const EdgeFunction ea(b, c), eb(c, a), ec(a, b);
  Vec3 e;
  for (int y = y0; y <= y1; ++y) {
    const double py = y + 0.5;
    const double ra = ea.rowTerm(py), rb = eb.rowTerm(py), rc = ec.rowTerm(py);
    // Conservative span of the row (one pixel of slack on each side); the exact test follows.
    double lo = x0, hi = x1;
    bool empty = false;
    for (const auto& [edge, r] : {std::pair<const EdgeFunction&, double>{ea, ra}, {eb, rb}, {ec, rc}}) {
      if (edge.dy == 0) {
        empty = empty || !edge.inside(edge.atRow(r, 0.0));
        continue;
      }
      const double cross = edge.sx + r / edge.dy - 0.5;  // pixel index where the edge crosses the row
      if (-edge.sign * edge.dy > 0)
        lo = std::max(lo, std::floor(cross) - 1);
      else
        hi = std::min(hi, std::ceil(cross) + 1);
    }
    if (empty || !(lo <= hi)) continue;
    const int xa = static_cast<int>(lo), xb = static_cast<int>(hi);
    for (int x = xa; x <= xb; ++x) {
      const double px = x + 0.5;
      const double va = ea.atRow(ra, px);
      if (!ea.inside(va)) continue;
      const double vb = eb.atRow(rb, px);
      if (!eb.inside(vb)) continue;
      const double vc = ec.atRow(rc, px);
      if (!ec.inside(vc)) continue;
      if (!(va + vb + vc > 0)) continue;  // numerically degenerate
      e[perm[0]] = va;
      e[perm[1]] = vb;
      e[perm[2]] = vc;
      visit(x, y, e);
    }
  }
}

}  // namespace

Camera Camera::lookAt(const Vec3& eye, const Vec3& target, const Vec3& up, double fovYDeg, int width, int height) {
  TM_CHECK(width > 0 && height > 0,
           "camera: image size " + std::to_string(width) + "x" + std::to_string(height) + " must be positive");
  TM_CHECK(fovYDeg > 0 && fovYDeg < 180,
           "camera: vertical field of view " + std::to_string(fovYDeg) + " degrees must be in (0, 180)");
  Vec3 forward = target - eye;
  TM_CHECK(forward.norm() > 0, "camera: eye and target are the same point");
  forward.normalize();
  Vec3 right = forward.cross(up);
  if (right.norm() < 1e-9 * std::max(1.0, up.norm())) {
    // `up` is parallel to the viewing direction: use the world axis least aligned with it.
    Vec3 axis = Vec3::Zero();
    Eigen::Index i;
    forward.cwiseAbs().minCoeff(&i);
    axis[i] = 1;
    right = forward.cross(axis);
  }
  right.normalize();
  const Vec3 down = forward.cross(right);  // camera y axis (z x x = y)

  Camera cam;
  cam.width = width;
  cam.height = height;
  cam.R.row(0) = right.transpose();
  cam.R.row(1) = down.transpose();
  cam.R.row(2) = forward.transpose();
  cam.t = -cam.R * eye;
  cam.fy = 0.5 * height / std::tan(0.5 * fovYDeg * M_PI / 180.0);
  cam.fx = cam.fy;
  cam.cx = 0.5 * width;
  cam.cy = 0.5 * height;
  return cam;
}

bool Camera::project(const Vec3& p, Vec2& pixel, double* depth) const {
  const Vec3 c = toCamera(p);
  if (depth) *depth = c.z();
  if (!(c.z() > 1e-12)) return false;
  pixel = Vec2(fx * c.x() / c.z() + cx, fy * c.y() / c.z() + cy);
  return true;
}

double cameraShiftPx(const Mesh& mesh, const Camera& a, const Camera& b) {
  const int nv = mesh.numVertices();
  const int step = std::max(1, nv / 512);
  double shift = 0;
  for (int v = 0; v < nv; v += step) {
    Vec2 pa, pb;
    if (!a.project(mesh.position(v), pa) || !b.project(mesh.position(v), pb))
      return std::numeric_limits<double>::infinity();
    shift = std::max(shift, (pa - pb).norm());
  }
  return shift;
}

RasterBuffers rasterize(const Mesh& mesh, const Camera& camera, const RasterOptions& options) {
  TM_CHECK(camera.width > 0 && camera.height > 0, "rasterize: camera image size " + std::to_string(camera.width) + "x" +
                                                      std::to_string(camera.height) + " must be positive");
  RasterBuffers out;
  out.width = camera.width;
  out.height = camera.height;
  const size_t n = static_cast<size_t>(out.width) * out.height;
  out.depth.assign(n, std::numeric_limits<float>::infinity());
  out.face.assign(n, -1);
  if (options.barycentrics) out.bary.assign(n, Vec3f::Zero());

  // Camera-space positions and pixel coordinates of every vertex.
  const int nv = mesh.numVertices();
  std::vector<Vec3> cam(nv);
  std::vector<Vec2> pix(nv);
  tbb::parallel_for(tbb::blocked_range<int>(0, nv, 4096), [&](const tbb::blocked_range<int>& range) {
    for (int v = range.begin(); v < range.end(); ++v) {
      cam[v] = camera.toCamera(mesh.position(v));
      const double z = cam[v].z();
      pix[v] = z > kNearPlane ? Vec2(camera.fx * cam[v].x() / z + camera.cx, camera.fy * cam[v].y() / z + camera.cy)
                              : Vec2::Zero();
    }
  });

  // The faces drawn, listed by bands of rows in face order; the bands are drawn in parallel. Every
  // pixel still meets its faces in face order (the first face wins ties): the same buffers as one
  // sequential pass over the faces.
  constexpr int kBandRows = 16;
  const int bands = (out.height + kBandRows - 1) / kBandRows;
  const int nf = mesh.numFaces();
  std::vector<std::array<int, 2>> faceBands(nf, {0, -1});  // first and last band; empty when last < first
  for (int f = 0; f < nf; ++f) {
    const std::array<int, 3> fv = mesh.faceVertices(f);
    const Vec3& c0 = cam[fv[0]];
    const Vec3& c1 = cam[fv[1]];
    const Vec3& c2 = cam[fv[2]];
    if (c0.z() <= kNearPlane || c1.z() <= kNearPlane || c2.z() <= kNearPlane) continue;
    if (options.cullBackFaces) {
      // Front faces are counter-clockwise seen from outside: their normal points towards the eye (the origin).
      const Vec3 normal = (c1 - c0).cross(c2 - c0);
      if (normal.dot(c0) >= 0) continue;
    }
    const double minY = std::min({pix[fv[0]].y(), pix[fv[1]].y(), pix[fv[2]].y()});
    const double maxY = std::max({pix[fv[0]].y(), pix[fv[1]].y(), pix[fv[2]].y()});
    const auto [r0, r1] = centresWithin(minY, maxY, 0, out.height - 1.0);  // the rows scan visits
    if (r0 <= r1) faceBands[f] = {static_cast<int>(r0) / kBandRows, static_cast<int>(r1) / kBandRows};
  }
  std::vector<int> bandStart(bands + 1, 0);
  for (const auto& [b0, b1] : faceBands)
    for (int b = b0; b <= b1; ++b) ++bandStart[b + 1];
  for (int b = 0; b < bands; ++b) bandStart[b + 1] += bandStart[b];
  std::vector<int> bandFaces(bandStart[bands]);
  {
    std::vector<int> fill(bandStart.begin(), bandStart.end() - 1);
    for (int f = 0; f < nf; ++f)
      for (int b = faceBands[f][0]; b <= faceBands[f][1]; ++b) bandFaces[fill[b]++] = f;
  }
  tbb::parallel_for(tbb::blocked_range<int>(0, bands, 1), [&](const tbb::blocked_range<int>& range) {
    for (int band = range.begin(); band < range.end(); ++band)
      for (int k = bandStart[band]; k < bandStart[band + 1]; ++k) {
        const int f = bandFaces[k];
        const std::array<int, 3> fv = mesh.faceVertices(f);
        const Vec3 invZ(1.0 / cam[fv[0]].z(), 1.0 / cam[fv[1]].z(), 1.0 / cam[fv[2]].z());
        scan(
            {pix[fv[0]], pix[fv[1]], pix[fv[2]]}, out.width, out.height,
            [&](int x, int y, const Vec3& e) {
              // 1/z is affine in screen space: interpolate b_k / z_k and normalise.
              const Vec3 w = e.cwiseProduct(invZ);
              const double sum = w.sum(), esum = e.sum();
              const int i = out.index(x, y);
              if (!(esum < out.depth[i] * sum)) return;  // depth = esum / sum; the first face wins ties
              const double invSum = 1.0 / sum;
              out.depth[i] = static_cast<float>(esum * invSum);
              out.face[i] = f;
              if (options.barycentrics) out.bary[i] = (w * invSum).cast<float>();
            },
            band * kBandRows, (band + 1) * kBandRows);
      }
  });
  return out;
}

void scanTriangle(const std::array<Vec2, 3>& p, int width, int height,
                  const std::function<void(int x, int y, const Vec3& b)>& visit) {
  scan(p, width, height, [&](int x, int y, const Vec3& e) { visit(x, y, e / e.sum()); });
}

}  // namespace montage
