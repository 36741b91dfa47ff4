// Tests of the CPU rasterizer (cameras, z-buffer, fill rule), the triangle BVH and texture stretch.
#include "io/mesh_io.h"
#include "geometry/raster.h"

#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <random>

#include "geometry/bvh.h"
#include "geometry/mesh.h"
#include "geometry/stretch.h"
#include "geometry/shapes.h"
#include "test_support.h"

namespace montage {
namespace {

std::unique_ptr<Mesh> makeMesh(const std::vector<Vec3>& vertices, const std::vector<std::array<int, 3>>& triangles) {
  LoadedMesh loaded = buildMesh(vertices, triangles);
  EXPECT_TRUE(loaded.mesh) << loaded.report.summary();
  EXPECT_EQ(loaded.mesh->numFaces(), static_cast<int>(triangles.size())) << loaded.report.summary();
  return std::move(loaded.mesh);
}

// An identity-pose camera (camera space = world space).
Camera identityCamera(int width, int height, double f) {
  Camera cam;
  cam.width = width;
  cam.height = height;
  cam.fx = cam.fy = f;
  cam.cx = 0.5 * width;
  cam.cy = 0.5 * height;
  return cam;
}

// The spot mesh when the shared data is there, an icosphere otherwise.
std::unique_ptr<Mesh> spotOrSphere(std::string* name) {
  const std::string spot = test::sharedFile("meshes/spot/spot_triangulated.obj");
  if (!spot.empty()) {
    *name = "spot";
    return requireUsable(loadMesh(spot));
  }
  *name = "icosphere (shared data absent)";
  return makeIcosphere(4);
}

// ----------------------------------------------------------------------------------------------
// Camera

TEST(Camera, ProjectsToPixelCentres) {
  const Camera cam = identityCamera(100, 80, 100);
  Vec2 px;
  double depth = 0;
  ASSERT_TRUE(cam.project(Vec3(0, 0, 1), px, &depth));
  EXPECT_NEAR(px.x(), 50.0, 1e-12);
  EXPECT_NEAR(px.y(), 40.0, 1e-12);
  EXPECT_NEAR(depth, 1.0, 1e-12);
  // The centre of pixel (col 50, row 40) is (50.5, 40.5).
  ASSERT_TRUE(cam.project(Vec3(0.01, 0.01, 2), px));
  EXPECT_NEAR(px.x(), 50.5, 1e-12);
  EXPECT_NEAR(px.y(), 40.5, 1e-12);
  // The top-left corner of the image is pixel coordinate (0, 0).
  ASSERT_TRUE(cam.project(Vec3(-0.5, -0.4, 1), px));
  EXPECT_NEAR(px.x(), 0.0, 1e-12);
  EXPECT_NEAR(px.y(), 0.0, 1e-12);
  EXPECT_FALSE(cam.project(Vec3(0, 0, -1), px));
  EXPECT_FALSE(cam.project(Vec3(1, 1, 0), px));
}

TEST(Camera, LookAtOrientation) {
  const Camera cam = Camera::lookAt(Vec3(0, 0, -5), Vec3::Zero(), Vec3(0, 1, 0), 60, 200, 100);
  EXPECT_NEAR((cam.center() - Vec3(0, 0, -5)).norm(), 0, 1e-12);
  EXPECT_NEAR((cam.R * cam.R.transpose() - Eigen::Matrix3d::Identity()).norm(), 0, 1e-12);
  EXPECT_NEAR(cam.R.determinant(), 1, 1e-12);
  Vec2 px;
  double depth;
  ASSERT_TRUE(cam.project(Vec3::Zero(), px, &depth));
  EXPECT_NEAR(px.x(), 100, 1e-9);
  EXPECT_NEAR(px.y(), 50, 1e-9);
  EXPECT_NEAR(depth, 5, 1e-12);
  // World up appears up (smaller y); the top edge of the image is at half the field of view.
  ASSERT_TRUE(cam.project(Vec3(0, 5 * std::tan(M_PI / 6), 0), px));
  EXPECT_NEAR(px.x(), 100, 1e-9);
  EXPECT_NEAR(px.y(), 0, 1e-9);
  // Looking along +z with +y up, world +x is on the left (right-handed world).
  ASSERT_TRUE(cam.project(Vec3(1, 0, 0), px));
  EXPECT_LT(px.x(), 100);
  EXPECT_NEAR(cam.fx, cam.fy, 1e-12);
  // Up parallel to the view direction still gives a valid rotation.
  const Camera top = Camera::lookAt(Vec3(0, 3, 0), Vec3::Zero(), Vec3(0, 1, 0), 45, 64, 64);
  EXPECT_NEAR(top.R.determinant(), 1, 1e-12);
  ASSERT_TRUE(top.project(Vec3::Zero(), px));
  EXPECT_NEAR(px.x(), 32, 1e-9);
}

// ----------------------------------------------------------------------------------------------
// rasterize()

// The square [-0.5, 0.5]^2 at z = 0, facing -z (towards a camera at (0, 0, -d)) unless `flip`.
std::unique_ptr<Mesh> unitSquare(bool flip) {
  std::vector<std::array<int, 3>> tris = {{0, 2, 1}, {0, 3, 2}};
  if (flip)
    for (auto& t : tris) std::swap(t[1], t[2]);
  return makeMesh({{-0.5, -0.5, 0}, {0.5, -0.5, 0}, {0.5, 0.5, 0}, {-0.5, 0.5, 0}}, tris);
}

TEST(Rasterize, SquareCoverageAndDepth) {
  const auto mesh = unitSquare(false);
  const Camera cam = Camera::lookAt(Vec3(0, 0, -2), Vec3::Zero(), Vec3(0, 1, 0), 60, 200, 160);
  const RasterBuffers rb = rasterize(*mesh, cam);
  ASSERT_EQ(rb.width, 200);
  ASSERT_EQ(rb.height, 160);
  // Analytic footprint of the square in pixels.
  const double half = 0.5 / 2 * cam.fy;
  const double x0 = 100 - half, x1 = 100 + half, y0 = 80 - half, y1 = 80 + half;
  int covered = 0;
  for (int y = 0; y < rb.height; ++y)
    for (int x = 0; x < rb.width; ++x) {
      const int i = rb.index(x, y);
      const bool inside = x + 0.5 > x0 && x + 0.5 < x1 && y + 0.5 > y0 && y + 0.5 < y1;
      ASSERT_EQ(rb.face[i] >= 0, inside) << "pixel " << x << "," << y;
      if (!inside) {
        EXPECT_TRUE(std::isinf(rb.depth[i]));
        continue;
      }
      ++covered;
      EXPECT_NEAR(rb.depth[i], 2.0, 1e-5);
      EXPECT_NEAR(rb.bary[i].sum(), 1.0f, 1e-5);
      EXPECT_TRUE((rb.bary[i].array() >= -1e-6f).all());
    }
  const double area = (x1 - x0) * (y1 - y0);
  const double perimeter = 2 * ((x1 - x0) + (y1 - y0));
  EXPECT_NEAR(covered, area, perimeter + 4);
  const int expected = (static_cast<int>(std::floor(x1 - 0.5)) - static_cast<int>(std::ceil(x0 - 0.5)) + 1) *
                       (static_cast<int>(std::floor(y1 - 0.5)) - static_cast<int>(std::ceil(y0 - 0.5)) + 1);
  EXPECT_EQ(covered, expected);
}

TEST(Rasterize, PerspectiveCorrectBarycentrics) {
  // A strongly slanted triangle: depths 2, 8 and 3.
  const std::vector<Vec3> v = {{-1, -1, 2}, {1, -1, 8}, {0.2, 1, 3}};
  const auto mesh = makeMesh(v, {{0, 1, 2}});
  const Camera cam = identityCamera(200, 200, 150);
  const RasterBuffers rb = rasterize(*mesh, cam);
  const std::array<int, 3> fv = mesh->faceVertices(0);
  const Vec3 a = mesh->position(fv[0]), b = mesh->position(fv[1]), c = mesh->position(fv[2]);
  const Vec3 n = (b - a).cross(c - a);
  std::array<Vec2, 3> screen;
  for (int k = 0; k < 3; ++k) ASSERT_TRUE(cam.project(mesh->position(fv[k]), screen[k]));
  int checked = 0;
  double maxAffineError = 0;
  for (int y = 0; y < rb.height; ++y)
    for (int x = 0; x < rb.width; ++x) {
      const int i = rb.index(x, y);
      if (rb.face[i] < 0) continue;
      // Ray through the pixel centre, intersected with the triangle's plane.
      const Vec3 dir((x + 0.5 - cam.cx) / cam.fx, (y + 0.5 - cam.cy) / cam.fy, 1);
      const Vec3 p = dir * (n.dot(a) / n.dot(dir));
      const double area = n.squaredNorm();
      const Vec3 exact(n.dot((c - b).cross(p - b)) / area, n.dot((a - c).cross(p - c)) / area,
                       n.dot((b - a).cross(p - a)) / area);
      for (int k = 0; k < 3; ++k) ASSERT_NEAR(rb.bary[i][k], exact[k], 1e-5) << "pixel " << x << "," << y;
      EXPECT_NEAR(rb.depth[i], p.z(), 1e-5 * p.z());
      // Screen-space (affine) barycentrics of the same pixel: what a wrong rasterizer would give.
      const Vec2 q(x + 0.5, y + 0.5);
      const auto cross2 = [](const Vec2& u, const Vec2& w) { return u.x() * w.y() - u.y() * w.x(); };
      const double s = cross2(screen[1] - screen[0], screen[2] - screen[0]);
      const Vec3 affine(cross2(screen[1] - q, screen[2] - q) / s, cross2(screen[2] - q, screen[0] - q) / s,
                        cross2(screen[0] - q, screen[1] - q) / s);
      maxAffineError = std::max(maxAffineError, (affine - exact).cwiseAbs().maxCoeff());
      ++checked;
    }
  EXPECT_GT(checked, 1000);
  EXPECT_GT(maxAffineError, 0.05) << "the test triangle is not slanted enough to tell the difference";
}

TEST(Rasterize, NearerTriangleWins) {
  const Camera cam = identityCamera(64, 64, 64);
  const std::vector<Vec3> near = {{-1, -1, 2}, {1, -1, 2}, {0, 1, 2}};
  const std::vector<Vec3> far = {{-2, -0.5, 3}, {2, -0.5, 3}, {0, 2.5, 3}};
  for (int order = 0; order < 2; ++order) {
    std::vector<Vec3> v = order == 0 ? near : far;
    const std::vector<Vec3>& second = order == 0 ? far : near;
    v.insert(v.end(), second.begin(), second.end());
    const auto mesh = makeMesh(v, {{0, 1, 2}, {3, 4, 5}});
    const int nearFace = order == 0 ? 0 : 1;
    const RasterBuffers rb = rasterize(*mesh, cam);
    int nearCount = 0, farCount = 0;
    for (int i = 0; i < rb.width * rb.height; ++i) {
      if (rb.face[i] < 0) continue;
      if (rb.face[i] == nearFace) {
        ++nearCount;
        EXPECT_NEAR(rb.depth[i], 2, 1e-5);
      } else {
        ++farCount;
        EXPECT_NEAR(rb.depth[i], 3, 1e-5);
      }
    }
    // The centre is covered by both: the near one must be there.
    EXPECT_EQ(rb.face[rb.index(32, 32)], nearFace);
    EXPECT_GT(nearCount, 100);
    EXPECT_GT(farCount, 100);  // the far triangle sticks out on both sides of the near one
  }
}

// The rasterizer draws bands of rows in parallel: a triangle over many bands must cover exactly the
// pixels one scan of it covers (no row lost or drawn twice at a band's border), and of two triangles at
// the same depth the first one listed must win in every band.
TEST(Rasterize, BandsCoverWhatOneScanCoversAndTheFirstFaceWinsTies) {
  const Camera cam = identityCamera(96, 333, 200);
  const std::vector<Vec3> corners = {{-0.9, -1.6, 2}, {0.7, -1.5, 2}, {0.1, 1.65, 2}};
  std::vector<Vec3> v = corners;
  v.insert(v.end(), corners.begin(), corners.end());  // the same triangle again, on vertices of its own
  const auto mesh = makeMesh(v, {{0, 1, 2}, {3, 4, 5}});
  const RasterBuffers rb = rasterize(*mesh, cam);
  std::array<Vec2, 3> pixels;
  for (int k = 0; k < 3; ++k) ASSERT_TRUE(cam.project(corners[k], pixels[k]));
  std::vector<char> scanned(size_t(cam.width) * cam.height, 0);
  scanTriangle(pixels, cam.width, cam.height, [&](int x, int y, const Vec3&) { ++scanned[rb.index(x, y)]; });
  int covered = 0, rows = 0;
  for (int y = 0; y < cam.height; ++y) {
    bool any = false;
    for (int x = 0; x < cam.width; ++x) {
      const int i = rb.index(x, y);
      ASSERT_LE(scanned[i], 1);
      EXPECT_EQ(rb.face[i], scanned[i] ? 0 : -1) << "pixel " << x << ", " << y;
      covered += scanned[i];
      any = any || scanned[i];
    }
    rows += any;
  }
  EXPECT_GT(rows, 300) << "the triangle must span many bands of rows";
  EXPECT_GT(covered, 10000);
}

TEST(Rasterize, BackFaceCulling) {
  const Camera cam = Camera::lookAt(Vec3(0, 0, -2), Vec3::Zero(), Vec3(0, 1, 0), 60, 64, 64);
  RasterOptions cull;
  cull.cullBackFaces = true;
  const auto count = [](const RasterBuffers& rb) {
    return std::count_if(rb.face.begin(), rb.face.end(), [](int f) { return f >= 0; });
  };
  const auto front = unitSquare(false), back = unitSquare(true);
  const auto all = count(rasterize(*front, cam));
  EXPECT_GT(all, 500);
  EXPECT_EQ(count(rasterize(*front, cam, cull)), all);
  EXPECT_EQ(count(rasterize(*back, cam)), all);
  EXPECT_EQ(count(rasterize(*back, cam, cull)), 0);
}

TEST(Rasterize, DropsTrianglesBehindTheCamera) {
  const Camera cam = identityCamera(64, 64, 64);
  const auto mesh = makeMesh({{-1, -1, 2}, {1, -1, 2}, {0, 1, -1}}, {{0, 1, 2}});
  const RasterBuffers rb = rasterize(*mesh, cam);
  EXPECT_EQ(std::count(rb.face.begin(), rb.face.end(), -1), 64 * 64);
}

// ----------------------------------------------------------------------------------------------
// scanTriangle()

TEST(ScanTriangle, SharedEdgeCoveredExactlyOnce) {
  // A square whose corners and diagonal pass exactly through pixel centres.
  const int w = 16, h = 16;
  const Vec2 a(2.5, 2.5), b(12.5, 2.5), c(12.5, 12.5), d(2.5, 12.5);
  std::vector<int> hits(w * h, 0);
  const auto count = [&](int x, int y, const Vec3& bary) {
    ASSERT_NEAR(bary.sum(), 1.0, 1e-12);
    ++hits[y * w + x];
  };
  scanTriangle({a, b, c}, w, h, count);
  scanTriangle({a, c, d}, w, h, count);  // the other orientation
  int total = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      // Top-left rule: centres on the left and top edges of the square belong to it, right and bottom do not.
      const bool inside = x + 0.5 >= 2.5 && x + 0.5 < 12.5 && y + 0.5 >= 2.5 && y + 0.5 < 12.5;
      EXPECT_EQ(hits[y * w + x], inside ? 1 : 0) << "pixel " << x << "," << y;
      total += hits[y * w + x];
    }
  EXPECT_EQ(total, 100);
}

TEST(ScanTriangle, JitteredGridCoversEveryPixelOnce) {
  // A grid with vertices on a half-pixel lattice (many centres exactly on edges and vertices),
  // random windings, extending beyond the image: every pixel must be visited exactly once.
  const int w = 48, h = 40, n = 14;
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> jitter(-2, 2);
  std::vector<Vec2> grid((n + 1) * (n + 1));
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      const bool border = i == 0 || j == 0 || i == n || j == n;
      grid[j * (n + 1) + i] =
          Vec2(-4.5 + i * 4.0 + (border ? 0 : 0.5 * jitter(rng)), -4.5 + j * 4.0 + (border ? 0 : 0.5 * jitter(rng)));
    }
  std::vector<int> hits(w * h, 0);
  std::bernoulli_distribution coin(0.5);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const Vec2 p00 = grid[j * (n + 1) + i], p10 = grid[j * (n + 1) + i + 1];
      const Vec2 p01 = grid[(j + 1) * (n + 1) + i], p11 = grid[(j + 1) * (n + 1) + i + 1];
      std::array<std::array<Vec2, 3>, 2> tris =
          coin(rng) ? std::array<std::array<Vec2, 3>, 2>{{{p00, p10, p11}, {p00, p11, p01}}}
                    : std::array<std::array<Vec2, 3>, 2>{{{p00, p10, p01}, {p10, p11, p01}}};
      for (auto& t : tris) {
        if (coin(rng)) std::swap(t[1], t[2]);
        scanTriangle(t, w, h, [&](int x, int y, const Vec3& b) {
          ASSERT_TRUE(x >= 0 && x < w && y >= 0 && y < h);
          ASSERT_TRUE((b.array() >= -1e-12).all());
          ++hits[y * w + x];
        });
      }
    }
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) EXPECT_EQ(hits[y * w + x], 1) << "pixel " << x << "," << y;
}

TEST(ScanTriangle, BarycentricsAndDegenerates) {
  const std::array<Vec2, 3> p = {Vec2(1, 1), Vec2(30, 4), Vec2(8, 25)};
  int visited = 0;
  scanTriangle(p, 32, 32, [&](int x, int y, const Vec3& b) {
    const Vec2 q = b[0] * p[0] + b[1] * p[1] + b[2] * p[2];
    EXPECT_NEAR(q.x(), x + 0.5, 1e-9);
    EXPECT_NEAR(q.y(), y + 0.5, 1e-9);
    ++visited;
  });
  EXPECT_NEAR(visited, 0.5 * std::abs((p[1] - p[0]).x() * (p[2] - p[0]).y() - (p[1] - p[0]).y() * (p[2] - p[0]).x()),
              60);
  int degenerate = 0;
  scanTriangle({Vec2(1, 1), Vec2(10, 10), Vec2(20, 20)}, 32, 32, [&](int, int, const Vec3&) { ++degenerate; });
  EXPECT_EQ(degenerate, 0);
  // Clipped to the image.
  scanTriangle({Vec2(-100, -100), Vec2(100, -100), Vec2(-100, 100)}, 8, 8,
               [&](int x, int y, const Vec3&) { EXPECT_TRUE(x >= 0 && x < 8 && y >= 0 && y < 8); });
}

// ----------------------------------------------------------------------------------------------
// TriangleBvh, checked against brute force with independent formulas.

double bruteDistance(const std::array<Vec3, 3>& t, const Vec3& q) {
  const Vec3 n = (t[1] - t[0]).cross(t[2] - t[0]);
  double best = std::numeric_limits<double>::infinity();
  if (n.squaredNorm() > 0) {
    const Vec3 p = q - n * (n.dot(q - t[0]) / n.squaredNorm());  // projection on the plane
    bool inside = true;
    for (int k = 0; k < 3; ++k) inside = inside && n.dot((t[(k + 1) % 3] - t[k]).cross(p - t[k])) >= 0;
    if (inside) best = (p - q).norm();
  }
  for (int k = 0; k < 3; ++k) {
    const Vec3 a = t[k], b = t[(k + 1) % 3];
    const double s = std::clamp((q - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
    best = std::min(best, (a + s * (b - a) - q).norm());
  }
  return best;
}

// Ray/plane intersection and an inside test: the nearest t over all faces.
double bruteRay(const Mesh& mesh, const Vec3& o, const Vec3& d, int* face) {
  double best = std::numeric_limits<double>::infinity();
  *face = -1;
  for (int f = 0; f < mesh.numFaces(); ++f) {
    const auto t = mesh.facePositions(f);
    const Vec3 n = (t[1] - t[0]).cross(t[2] - t[0]);
    const double den = n.dot(d);
    if (den == 0) continue;
    const double s = n.dot(t[0] - o) / den;
    if (s < 0 || s >= best) continue;
    const Vec3 p = o + s * d;
    bool inside = true;
    for (int k = 0; k < 3; ++k) inside = inside && n.dot((t[(k + 1) % 3] - t[k]).cross(p - t[k])) >= 0;
    if (inside) {
      best = s;
      *face = f;
    }
  }
  return best;
}

TEST(Bvh, AgreesWithBruteForce) {
  std::string name;
  const auto mesh = spotOrSphere(&name);
  SCOPED_TRACE(name);
  const TriangleBvh bvh(*mesh);
  Vec3 lo, hi;
  mesh->bounds(lo, hi);
  const Vec3 centre = 0.5 * (lo + hi), size = hi - lo;
  const double diag = size.norm();
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> u(-1, 1);
  int rayHits = 0;
  for (int q = 0; q < 1000; ++q) {
    const Vec3 query = centre + 0.75 * Vec3(u(rng) * size.x(), u(rng) * size.y(), u(rng) * size.z());
    // Closest point.
    const ClosestPoint cp = bvh.closest(query);
    ASSERT_GE(cp.face, 0);
    double brute = std::numeric_limits<double>::infinity();
    for (int f = 0; f < mesh->numFaces(); ++f) brute = std::min(brute, bruteDistance(mesh->facePositions(f), query));
    ASSERT_NEAR(cp.distance, brute, 1e-9 * diag) << "query " << q;
    const auto t = mesh->facePositions(cp.face);
    EXPECT_NEAR((cp.bary[0] * t[0] + cp.bary[1] * t[1] + cp.bary[2] * t[2] - cp.point).norm(), 0, 1e-9 * diag);
    EXPECT_NEAR((cp.point - query).norm(), cp.distance, 1e-9 * diag);
    EXPECT_NEAR(bruteDistance(t, query), brute, 1e-9 * diag);
    // Ray from the query towards a random point of the box.
    const Vec3 target = centre + 0.5 * Vec3(u(rng) * size.x(), u(rng) * size.y(), u(rng) * size.z());
    const Vec3 dir = target - query;
    const RayHit hit = bvh.raycast(query, dir);
    int bruteFace;
    const double bruteT = bruteRay(*mesh, query, dir, &bruteFace);
    ASSERT_EQ(hit.face >= 0, bruteFace >= 0) << "query " << q;
    if (hit.face < 0) continue;
    ++rayHits;
    EXPECT_NEAR(hit.t, bruteT, 1e-9 * (1 + bruteT));
    const auto h = mesh->facePositions(hit.face);
    EXPECT_NEAR((hit.bary[0] * h[0] + hit.bary[1] * h[1] + hit.bary[2] * h[2] - (query + hit.t * dir)).norm(), 0,
                1e-9 * diag);
  }
  EXPECT_GT(rayHits, 300);
  // tMax limits the search; a ray pointing away hits nothing.
  const RayHit none = bvh.raycast(centre + Vec3(0, 0, 10 * diag), Vec3(0, 0, 1));
  EXPECT_EQ(none.face, -1);
  const RayHit capped = bvh.raycast(centre + Vec3(0, 0, 10 * diag), Vec3(0, 0, -1), 0, diag);
  EXPECT_EQ(capped.face, -1);
}

TEST(Bvh, RaycastBothSidesAndEdges) {
  const auto mesh = unitSquare(false);
  const TriangleBvh bvh(*mesh);
  for (double z : {-3.0, 3.0}) {
    const RayHit hit = bvh.raycast(Vec3(0.1, 0.2, z), Vec3(0, 0, -z));
    ASSERT_GE(hit.face, 0);
    EXPECT_NEAR(hit.t, 1.0, 1e-12);
  }
  // On the shared diagonal the ray still hits.
  EXPECT_GE(bvh.raycast(Vec3(0.25, 0.25, 1), Vec3(0, 0, -1)).face, 0);
  EXPECT_EQ(bvh.raycast(Vec3(0.6, 0.2, 1), Vec3(0, 0, -1)).face, -1);
  // tMin excludes hits before it.
  EXPECT_EQ(bvh.raycast(Vec3(0.1, 0.2, 1), Vec3(0, 0, -1), 1.5).face, -1);
  const ClosestPoint cp = bvh.closest(Vec3(2, 0.1, 0.5));
  EXPECT_NEAR(cp.distance, std::sqrt(1.5 * 1.5 + 0.25), 1e-12);
  EXPECT_NEAR((cp.point - Vec3(0.5, 0.1, 0)).norm(), 0, 1e-12);
}


// ----------------------------------------------------------------------------------------------
// Texture stretch

TEST(Stretch, SingularValues) {
  // Right triangle in the z = 1 plane; the identity map has no stretch.
  const std::array<Vec3, 3> q = {Vec3(0, 0, 1), Vec3(2, 0, 1), Vec3(0, 2, 1)};
  const std::array<Vec2, 3> id = {Vec2(0, 0), Vec2(2, 0), Vec2(0, 2)};
  TriangleStretch s = triangleStretch(q, id);
  EXPECT_FALSE(s.flipped);
  EXPECT_NEAR(s.gamma, 1, 1e-12);
  EXPECT_NEAR(s.sigma, 1, 1e-12);
  EXPECT_NEAR(s.l2(), 1, 1e-12);
  // Texture half as wide: one texture unit along u covers two surface units.
  s = triangleStretch(q, {Vec2(0, 0), Vec2(1, 0), Vec2(0, 2)});
  EXPECT_NEAR(s.gamma, 2, 1e-12);
  EXPECT_NEAR(s.sigma, 1, 1e-12);
  EXPECT_NEAR(s.l2(), std::sqrt(2.5), 1e-12);
  // A rotated, uniformly scaled map.
  const double c = std::cos(0.7), n = std::sin(0.7);
  std::array<Vec2, 3> rot;
  for (int k = 0; k < 3; ++k) rot[k] = 4 * Vec2(c * id[k].x() - n * id[k].y(), n * id[k].x() + c * id[k].y());
  s = triangleStretch(q, rot);
  EXPECT_NEAR(s.gamma, 0.25, 1e-12);
  EXPECT_NEAR(s.sigma, 0.25, 1e-12);
  // A shear: singular values of [[1, 1], [0, 1]] are the golden ratio and its inverse.
  s = triangleStretch({Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0)}, {Vec2(0, 0), Vec2(1, 0), Vec2(0, 1)});
  const double phi = (1 + std::sqrt(5.0)) / 2;
  EXPECT_NEAR(s.gamma, phi, 1e-12);
  EXPECT_NEAR(s.sigma, 1 / phi, 1e-12);
}

TEST(Stretch, FlippedAndDegenerate) {
  const std::array<Vec3, 3> q = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)};
  for (const auto& uv : {std::array<Vec2, 3>{Vec2(0, 0), Vec2(0, 1), Vec2(1, 0)},
                         std::array<Vec2, 3>{Vec2(0, 0), Vec2(1, 1), Vec2(2, 2)}}) {
    const TriangleStretch s = triangleStretch(q, uv);
    EXPECT_TRUE(s.flipped);
    EXPECT_TRUE(std::isinf(s.gamma));
    EXPECT_TRUE(std::isinf(s.sigma));
    EXPECT_TRUE(std::isinf(s.l2()));
  }
}

}  // namespace
}  // namespace montage
