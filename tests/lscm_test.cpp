// Tests of the LSCM flattening: a flat disc is recovered up to a similarity, a hemisphere flattens
// without flips, zero-area faces do not break it, the topology checks, and errors on bad input.
#include "geometry/lscm.h"

#include <Eigen/Geometry>
#include <cmath>
#include <complex>
#include <random>

#include "geometry/mesh.h"
#include "geometry/shapes.h"
#include "test_support.h"

namespace montage {
namespace {

using Tris = std::vector<std::array<int, 3>>;
using test::errorOf;

// A flat disc of `rings` concentric rings (6r vertices on ring r) around a centre, triangulated
// counter-clockwise seen from +z, its vertices jittered so the triangles are irregular.
void flatDisc(int rings, unsigned seed, std::vector<Vec2>& points, Tris& tris) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> jitter(-0.2, 0.2);
  points = {Vec2(0, 0)};
  std::vector<int> start = {0};
  for (int r = 1; r <= rings; ++r) {
    start.push_back(static_cast<int>(points.size()));
    for (int j = 0; j < 6 * r; ++j) {
      const double a = 2 * M_PI * (j + (r < rings ? jitter(rng) : 0.0)) / (6 * r);
      const double rad = r + (r < rings ? jitter(rng) : 0.0);
      points.push_back(Vec2(rad * std::cos(a), rad * std::sin(a)));
    }
  }
  tris.clear();
  for (int j = 0; j < 6; ++j) tris.push_back({0, start[1] + j, start[1] + (j + 1) % 6});
  for (int r = 2; r <= rings; ++r) {
    const int n0 = 6 * (r - 1), n1 = 6 * r;
    const auto inner = [&](int i) { return start[r - 1] + i % n0; };
    const auto outer = [&](int j) { return start[r] + j % n1; };
    for (int i = 0, j = 0; i < n0 || j < n1;) {
      const bool advanceOuter = i == n0 || (j < n1 && double(j + 1) / n1 <= double(i + 1) / n0);
      if (advanceOuter)
        tris.push_back({inner(i), outer(j), outer(j + 1)}), ++j;
      else
        tris.push_back({inner(i), outer(j), inner(i + 1)}), ++i;
    }
  }
}

// Places 2D points on a tilted plane in 3D.
std::vector<Vec3> embed(const std::vector<Vec2>& points) {
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized())).toRotationMatrix();
  std::vector<Vec3> out;
  for (const Vec2& p : points) out.push_back(R * Vec3(p.x(), p.y(), 0) + Vec3(5, -2, 1));
  return out;
}

// Largest distance between uv and the best similarity (rotation, uniform scale, translation, no
// mirror) of `original`, relative to the size of the original.
double similarityResidual(const std::vector<Vec2>& original, const std::vector<Vec2>& uv) {
  using C = std::complex<double>;
  C zm = 0, wm = 0;
  for (size_t i = 0; i < uv.size(); ++i) zm += C(original[i].x(), original[i].y()), wm += C(uv[i].x(), uv[i].y());
  zm /= double(uv.size());
  wm /= double(uv.size());
  C num = 0;
  double den = 0, radius = 0;
  for (size_t i = 0; i < uv.size(); ++i) {
    const C z = C(original[i].x(), original[i].y()) - zm, w = C(uv[i].x(), uv[i].y()) - wm;
    num += std::conj(z) * w;
    den += std::norm(z);
    radius = std::max(radius, std::abs(z));
  }
  const C a = num / den;
  double worst = 0;
  for (size_t i = 0; i < uv.size(); ++i) {
    const C z = C(original[i].x(), original[i].y()) - zm, w = C(uv[i].x(), uv[i].y()) - wm;
    worst = std::max(worst, std::abs(w - a * z));
  }
  return worst / (std::abs(a) * radius);
}

double signedArea(const std::vector<Vec2>& p, const std::array<int, 3>& t) {
  const Vec2 a = p[t[1]] - p[t[0]], b = p[t[2]] - p[t[0]];
  return 0.5 * (a.x() * b.y() - a.y() * b.x());
}

TEST(Lscm, FlatDiscIsRecoveredUpToASimilarity) {
  for (unsigned seed : {1u, 2u, 3u}) {
    std::vector<Vec2> points;
    Tris tris;
    flatDisc(12, seed, points, tris);
    for (const auto& t : tris) ASSERT_GT(signedArea(points, t), 0) << "test disc must be counter-clockwise";
    EXPECT_TRUE(patchTopology(tris).isDisc());
    const std::vector<Vec2> uv = lscm(embed(points), tris);
    ASSERT_EQ(uv.size(), points.size());
    EXPECT_LT(similarityResidual(points, uv), 1e-6) << "seed " << seed;
    const FlatteningQuality q = flatteningQuality(embed(points), tris, uv);
    EXPECT_EQ(q.flipped, 0);
    EXPECT_NEAR(q.stretchL2, 1.0, 1e-6);
    // A mirrored map would also have zero conformal residual up to reflection: it must not be chosen.
    for (const auto& t : tris) EXPECT_GT(signedArea(uv, t), 0);
  }
}

TEST(Lscm, HemisphereHasNoFlips) {
  for (int levels : {2, 3, 4}) {
    auto sphere = makeIcosphere(levels);
    std::vector<Vec3> positions;
    for (int v = 0; v < sphere->numVertices(); ++v) positions.push_back(sphere->position(v));
    Tris tris;
    for (int f = 0; f < sphere->numFaces(); ++f) {
      const auto q = sphere->facePositions(f);
      if ((q[0] + q[1] + q[2]).z() > 0) tris.push_back(sphere->faceVertices(f));
    }
    const PatchTopology topo = patchTopology(tris);
    ASSERT_TRUE(topo.isDisc()) << "chi " << topo.eulerCharacteristic() << ", pinched " << topo.pinchedVertices;
    const std::vector<Vec2> uv = lscm(positions, tris);
    const FlatteningQuality q = flatteningQuality(positions, tris, uv);
    EXPECT_EQ(q.flipped, 0) << "level " << levels;
    for (const auto& t : tris) EXPECT_GT(signedArea(uv, t), 0);
    // Conformal maps of a hemisphere compress the pole relative to the rim (by about 2x in length),
    // which bounds the L2 stretch; a broken solve (collapse, fold) is far above this.
    EXPECT_LT(q.stretchL2, 1.3) << "level " << levels;
    EXPECT_GT(q.stretchL2, 1.01) << "a hemisphere cannot flatten isometrically";
    std::printf("hemisphere level %d: %zu faces, L2 %.3f, Linf %.3f\n", levels, tris.size(), q.stretchL2,
                q.stretchLinf);
  }
}

// A flat grid with zero-area faces inserted: a vertex exactly on an interior edge (a collinear face)
// and a vertex coinciding with another one (faces with a repeated position).
TEST(Lscm, ZeroAreaFacesAreHarmless) {
  auto grid = makeGrid(8, 8, 1.0);
  std::vector<Vec2> points;
  for (int v = 0; v < grid->numVertices(); ++v) points.push_back(grid->position(v).head<2>());
  Tris tris;
  for (int f = 0; f < grid->numFaces(); ++f) tris.push_back(grid->faceVertices(f));
  // Splits the face holding directed edge a->b at a new vertex m on that edge, adding the zero-area
  // face (a, b, m) in the same way a mesh simplifier or a Steiner vertex leaves them.
  const auto splitWithCap = [&](int a, int b, const Vec2& at) {
    const int m = static_cast<int>(points.size());
    points.push_back(at);
    for (size_t t = 0; t < tris.size(); ++t)
      for (int k = 0; k < 3; ++k)
        if (tris[t][k] == b && tris[t][(k + 1) % 3] == a) {  // face with b->a: the other side keeps a->b
          const int c = tris[t][(k + 2) % 3];
          tris[t] = {b, m, c};
          tris.push_back({m, a, c});
          tris.push_back({a, b, m});  // zero area (or collapsed when m sits on a corner)
          return;
        }
    FAIL() << "edge not found";
  };
  const int a = 3 * 8 + 3, b = 3 * 8 + 4;             // an interior horizontal edge
  splitWithCap(a, b, 0.5 * (points[a] + points[b]));  // collinear
  const int c = 5 * 8 + 5, d = 5 * 8 + 6;
  splitWithCap(c, d, points[c]);  // coincident with c
  const PatchTopology topo = patchTopology(tris);
  ASSERT_TRUE(topo.isDisc()) << "chi " << topo.eulerCharacteristic();
  const std::vector<Vec3> positions = embed(points);
  const std::vector<Vec2> uv = lscm(positions, tris);
  for (const Vec2& p : uv) ASSERT_TRUE(p.allFinite());
  EXPECT_EQ(flatteningQuality(positions, tris, uv).flipped, 0);
  EXPECT_LT(similarityResidual(points, uv), 1e-4);
  // Only zero-area faces: every point collinear. Still finite, no exception.
  std::vector<Vec3> line = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0}};
  const std::vector<Vec2> flat = lscm(line, {{0, 1, 2}, {0, 2, 3}});
  for (const Vec2& p : flat) EXPECT_TRUE(p.allFinite());
}

TEST(PatchTopology, ClassifiesDiscsSpheresAnnuliAndPinches) {
  auto sphere = makeIcosphere(1);
  Tris all;
  for (int f = 0; f < sphere->numFaces(); ++f) all.push_back(sphere->faceVertices(f));
  const PatchTopology closed = patchTopology(all);
  EXPECT_EQ(closed.eulerCharacteristic(), 2);
  EXPECT_EQ(closed.boundaryLoops, 0);
  EXPECT_FALSE(closed.isDisc());
  // A band around the equator: an annulus (chi 0, two boundary loops).
  Tris band;
  for (int f = 0; f < sphere->numFaces(); ++f) {
    const auto q = sphere->facePositions(f);
    if (std::abs((q[0] + q[1] + q[2]).z() / 3) < 0.5) band.push_back(sphere->faceVertices(f));
  }
  const PatchTopology annulus = patchTopology(band);
  EXPECT_EQ(annulus.eulerCharacteristic(), 0);
  EXPECT_EQ(annulus.boundaryLoops, 2);
  EXPECT_FALSE(annulus.isDisc());
  // Two triangles sharing only a vertex: two components; joined by a third face into a fan with a gap
  // they stay pinched at the shared vertex.
  const PatchTopology bow = patchTopology({{0, 1, 2}, {0, 3, 4}});
  EXPECT_EQ(bow.components, 2);
  EXPECT_EQ(bow.pinchedVertices, 1);
  EXPECT_FALSE(bow.isDisc());
  EXPECT_TRUE(patchTopology({{0, 1, 2}}).isDisc());
}

TEST(Lscm, ErrorsOnBadInput) {
  std::vector<Vec3> p = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  EXPECT_NE(errorOf([&] { lscm(p, {}); }).find("no triangles"), std::string::npos);
  EXPECT_NE(errorOf([&] { lscm(p, {{0, 1, 5}}); }).find("vertex index 5"), std::string::npos);
  p[2] = Vec3(0, std::nan(""), 0);
  EXPECT_NE(errorOf([&] { lscm(p, {{0, 1, 2}}); }).find("not finite"), std::string::npos);
}

}  // namespace
}  // namespace montage
