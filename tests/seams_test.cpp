// Seam optimisation (paper 4.2-4.3): a Venus-like case built by hand (a curved sheet split in the
// middle into two photos of one texture, the second misregistered by a few pixels and 30% brighter),
// and the options' directions.
#include "mapping/seams.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>

#include "geometry/mesh.h"
#include "geometry/shapes.h"
#include "image/color.h"
#include "image/photo.h"
#include "test_support.h"

using namespace montage;

namespace {

constexpr int kSize = 800;  // photo width and height
constexpr double kPixelsPerUnit = 600;
const Vec2 kShift(3.0, -2.0);      // photo 1 shows the texture shifted by this (pixels)
constexpr double kExposure = 1.3;  // ...and 30% brighter (linear light)

Vec3f pattern(double x, double y) {
  return Vec3f(float(0.5 + 0.35 * std::sin(x / 7 + 0.8 * std::sin(y / 23))),
               float(0.5 + 0.3 * std::cos(y / 9 + x / 31)), float(0.4 + 0.3 * std::sin((x + 2 * y) / 13)));
}

Photo makePhoto(const std::function<Vec3f(double, double)>& colour) {
  Photo photo;
  photo.width = photo.height = kSize;
  photo.rgb.create(kSize, kSize, CV_32FC3);
  for (int r = 0; r < kSize; ++r)
    for (int c = 0; c < kSize; ++c) {
      const Vec3f v = colour(c + 0.5, r + 0.5);
      photo.rgb.at<cv::Vec3f>(r, c) = cv::Vec3f(v[0], v[1], v[2]);
    }
  return photo;
}

struct VenusCase {
  std::unique_ptr<Mesh> mesh;
  Photo left, right;
  TextureMap map;
  std::vector<int> features;
  SeamInput input() const {
    SeamInput in;
    in.mesh = mesh.get();
    in.map = &map;
    in.photos = {&left, &right};
    in.fixedVertices = features;
    return in;
  }
};

// A 31 x 31 sheet over [0,1]^2 bent into a half cylinder bump, split at x = 0.5: the left half mapped
// to photo 0, the right half to photo 1, both through the same projection (x, y) -> 100 + 600 (x, 1-y).
// Photo 1 shows the texture displaced by kShift, so its half is misregistered by |kShift| = 3.6 px.
VenusCase venusCase() {
  VenusCase v;
  v.mesh = makeGrid(31, 31, 1.0 / 30);
  for (auto vh : v.mesh->tri.vertices()) {
    auto p = v.mesh->tri.point(vh);
    p[2] = 0.15 * std::sin(M_PI * p[0]) * std::sin(M_PI * p[1]);
    v.mesh->tri.set_point(vh, p);
  }
  v.left = makePhoto([](double x, double y) { return pattern(x, y); });
  v.right = makePhoto([](double x, double y) {
    const Vec3f c = pattern(x - kShift.x(), y - kShift.y());
    Vec3f out;
    for (int k = 0; k < 3; ++k) out[k] = float(linearToSrgb(std::min(1.0, kExposure * srgbToLinear(c[k]))));
    return out;
  });
  const int nf = v.mesh->numFaces();
  v.map = TextureMap::allEmpty(nf);
  for (int f = 0; f < nf; ++f) {
    const auto p = v.mesh->facePositions(f);
    const double cx = (p[0].x() + p[1].x() + p[2].x()) / 3;
    v.map.facePhoto[f] = cx < 0.5 ? 0 : 1;
    v.map.facePatch[f] = v.map.facePhoto[f];
    for (int k = 0; k < 3; ++k)
      v.map.cornerUV[f][k] = Vec2(100 + kPixelsPerUnit * p[k].x(), 100 + kPixelsPerUnit * (1 - p[k].y()));
  }
  // Features: the four corners and a vertex in the middle of each half.
  for (auto vh : v.mesh->tri.vertices()) {
    const auto p = v.mesh->tri.point(vh);
    const bool corner = (p[0] < 1e-9 || p[0] > 1 - 1e-9) && (p[1] < 1e-9 || p[1] > 1 - 1e-9);
    const bool middle = std::abs(p[1] - 0.5) < 1e-9 && (std::abs(p[0] - 0.2) < 1e-6 || std::abs(p[0] - 0.8) < 1e-6);
    if (corner || middle) v.features.push_back(vh.idx());
  }
  return v;
}

// Per vertex on the seam: |(UV in photo 1 - UV in photo 0) - kShift|, the remaining misregistration.
double meanMisregistration(const Mesh& mesh, const TextureMap& map) {
  std::vector<Vec2> uv0(mesh.numVertices(), Vec2::Constant(NAN)), uv1 = uv0;
  for (int f = 0; f < mesh.numFaces(); ++f) {
    const auto fv = mesh.faceVertices(f);
    for (int k = 0; k < 3; ++k) (map.facePhoto[f] == 0 ? uv0 : uv1)[fv[k]] = map.cornerUV[f][k];
  }
  double sum = 0;
  int n = 0;
  for (int v = 0; v < mesh.numVertices(); ++v)
    if (!std::isnan(uv0[v].x()) && !std::isnan(uv1[v].x())) sum += ((uv1[v] - uv0[v]) - kShift).norm(), ++n;
  return n ? sum / n : NAN;
}

}  // namespace

TEST(Seams, VenusCaseMisregistrationFallsAndFeaturesStay) {
  const VenusCase v = venusCase();
  const SeamResult res = optimiseSeams(v.input(), SeamOptions{}, {});
  EXPECT_EQ(res.seamEdges, 30);
  EXPECT_GE(res.seamVertices, 29);
  // E_tex falls: the mean colour difference across the seam, and the misregistration itself.
  EXPECT_LT(res.deltaEAfter, 0.7 * res.deltaEBefore) << res.deltaEBefore << " -> " << res.deltaEAfter;
  const double before = meanMisregistration(*v.mesh, v.map), after = meanMisregistration(*v.mesh, res.map);
  EXPECT_NEAR(before, kShift.norm(), 1e-9);
  EXPECT_LT(after, 0.5 * before) << "misregistration " << before << " px -> " << after << " px";
  // Features do not move, nothing flips, the stretch stays bounded.
  for (int f = 0; f < v.mesh->numFaces(); ++f) {
    const auto fv = v.mesh->faceVertices(f);
    for (int k = 0; k < 3; ++k)
      if (std::count(v.features.begin(), v.features.end(), fv[k]))
        EXPECT_EQ(res.map.cornerUV[f][k], v.map.cornerUV[f][k]) << "feature vertex " << fv[k] << " moved";
    const auto& a = v.map.cornerUV[f];
    const auto& b = res.map.cornerUV[f];
    const double sa = (a[1] - a[0]).x() * (a[2] - a[0]).y() - (a[1] - a[0]).y() * (a[2] - a[0]).x();
    const double sb = (b[1] - b[0]).x() * (b[2] - b[0]).y() - (b[1] - b[0]).y() * (b[2] - b[0]).x();
    EXPECT_GT(sa * sb, 0) << "face " << f << " flipped";
  }
  EXPECT_LT(res.maxStretchAfter, 1.5 * res.maxStretchBefore);
  // Per-face seam error: on the faces along the seam only.
  int onSeam = 0;
  for (float e : res.faceError) onSeam += e >= 0;
  EXPECT_EQ(onSeam, 60);
}

// The preview's warm start (SeamMemo). A refitted camera moves its whole photo's UVs by a fraction of a
// pixel: with the tolerance the sides take their kept moves (start + the last run's move), sleep, and
// match about as well as a fresh optimisation; without it, or beyond it, they are optimised again.
TEST(Seams, WarmStartKeepsMovesOfSidesThatMovedLessThanTheTolerance) {
  VenusCase v = venusCase();
  const SeamResult first = optimiseSeams(v.input(), SeamOptions{}, {});
  ASSERT_TRUE(first.memo);
  // The same map again: every optimised side is warm, by its exact key.
  SeamInput in = v.input();
  in.warm = first.memo.get();
  const SeamResult same = optimiseSeams(in, SeamOptions{}, {});
  EXPECT_GT(same.warmSides, 0);
  EXPECT_EQ(same.warmNearSides, 0);
  auto shifted = [&](const Vec2& by) {
    VenusCase w = venusCase();
    for (int f = 0; f < w.mesh->numFaces(); ++f)
      if (w.map.facePhoto[f] == 1)
        for (Vec2& uv : w.map.cornerUV[f]) uv += by;
    return w;
  };
  struct Runs {
    SeamResult exact, tolerant, fresh;
  };
  auto run = [&](const Vec2& by) {
    const VenusCase w = shifted(by);
    SeamInput warm = w.input();
    warm.warm = first.memo.get();
    Runs r;
    r.exact = optimiseSeams(warm, SeamOptions{}, {});
    warm.warmTolerancePx = 0.5;
    r.tolerant = optimiseSeams(warm, SeamOptions{}, {});
    r.fresh = optimiseSeams(w.input(), SeamOptions{}, {});
    std::printf("photo 1 moved by %.2f px: warm sides exact %d, with the tolerance %d (%d near), rounds %d against %d "
                "fresh; Delta E after %.3f, fresh %.3f (before %.3f)\n",
                by.norm(), r.exact.warmSides, r.tolerant.warmSides, r.tolerant.warmNearSides, r.tolerant.rounds,
                r.fresh.rounds, r.tolerant.deltaEAfter, r.fresh.deltaEAfter, r.fresh.deltaEBefore);
    return r;
  };
  const Runs within = run(Vec2(0.2, -0.1));
  EXPECT_EQ(within.exact.warmNearSides, 0);
  EXPECT_LT(within.exact.warmSides, within.tolerant.warmSides);
  EXPECT_GT(within.tolerant.warmNearSides, 0);
  EXPECT_EQ(within.fresh.warmSides, 0);
  EXPECT_LT(within.tolerant.deltaEAfter, 1.1 * within.fresh.deltaEAfter + 0.1);
  EXPECT_LT(within.tolerant.deltaEAfter, 0.7 * within.tolerant.deltaEBefore);
  const Runs beyond = run(Vec2(0.6, 0.3));
  EXPECT_EQ(beyond.tolerant.warmNearSides, 0);
}

// SeamMemo::structure: a warm run on the same mesh whose corners share UVs as in the last run takes the
// last run's sides and seam edges, and comes out exactly as when it builds them; a map whose corners group
// differently, or another mesh, builds them.
TEST(Seams, AKeptStructureGivesTheRunABuiltOneGives) {
  VenusCase v = venusCase();
  SeamInput in = v.input();
  in.meshHash = 7;
  const SeamResult first = optimiseSeams(in, SeamOptions{}, {});
  ASSERT_TRUE(first.memo && first.memo->structure);
  SeamMemo withoutStructure = *first.memo;
  withoutStructure.structure.reset();
  auto compare = [](const SeamResult& a, const SeamResult& b) {
    EXPECT_EQ(a.map.cornerUV, b.map.cornerUV);
    EXPECT_EQ(a.faceError, b.faceError);
    EXPECT_EQ(a.deltaEBefore, b.deltaEBefore);
    EXPECT_EQ(a.deltaEAfter, b.deltaEAfter);
    EXPECT_EQ(a.maxStretchAfter, b.maxStretchAfter);
    EXPECT_EQ(a.movedSides, b.movedSides);
    EXPECT_EQ(a.rounds, b.rounds);
    EXPECT_EQ(a.warmSides, b.warmSides);
    EXPECT_EQ(a.seamEdges, b.seamEdges);
  };
  // Photo 1 moved by a fraction of a pixel, and one interior vertex of photo 0 moved on all its faces:
  // the corners group as before.
  VenusCase w = venusCase();
  for (int f = 0; f < w.mesh->numFaces(); ++f)
    for (int k = 0; k < 3; ++k) {
      Vec2& uv = w.map.cornerUV[f][k];
      if (w.map.facePhoto[f] == 1) uv += Vec2(0.2, -0.1);
      if (w.mesh->faceVertices(f)[k] == 5 * 31 + 5) uv += Vec2(0.7, 0.4);
    }
  SeamInput warm = w.input();
  warm.meshHash = 7;
  warm.warmTolerancePx = 0.5;
  warm.warm = first.memo.get();
  const SeamResult kept = optimiseSeams(warm, SeamOptions{}, {});
  warm.warm = &withoutStructure;
  const SeamResult built = optimiseSeams(warm, SeamOptions{}, {});
  EXPECT_TRUE(kept.structureKept);
  EXPECT_FALSE(built.structureKept);
  EXPECT_GT(kept.warmSides, 0);
  compare(kept, built);
  // Another mesh hash, or one corner of a vertex moved alone (a new side): built again.
  warm.warm = first.memo.get();
  warm.meshHash = 8;
  EXPECT_FALSE(optimiseSeams(warm, SeamOptions{}, {}).structureKept);
  warm.meshHash = 7;
  VenusCase split = venusCase();
  for (int f = 0; f < split.mesh->numFaces(); ++f) {
    const auto fv = split.mesh->faceVertices(f);
    const int k = int(std::find(fv.begin(), fv.end(), 7 * 31 + 9) - fv.begin());
    if (k < 3) {
      split.map.cornerUV[f][k] += Vec2(0.5, 0);
      break;
    }
  }
  warm.map = &split.map;
  const SeamResult regrouped = optimiseSeams(warm, SeamOptions{}, {});
  EXPECT_FALSE(regrouped.structureKept);
  warm.warm = &withoutStructure;
  compare(regrouped, optimiseSeams(warm, SeamOptions{}, {}));
}

TEST(Seams, LambdaKeepsTheStretchLower) {
  const VenusCase v = venusCase();
  SeamOptions low, high, geometryOnly;
  low.lambda = 0.02;
  high.lambda = 0.5;
  geometryOnly.lambda = 1;
  const SeamResult a = optimiseSeams(v.input(), low, {}), b = optimiseSeams(v.input(), high, {});
  // Higher lambda: the stretch counts more, the colour less.
  EXPECT_LE(b.maxStretchAfter, a.maxStretchAfter);
  EXPECT_GT(b.deltaEAfter, a.deltaEAfter);
  // lambda = 1 is the geometric stretch alone: colours play no part.
  const SeamResult c = optimiseSeams(v.input(), geometryOnly, {});
  EXPECT_GT(c.deltaEAfter, b.deltaEAfter);
  EXPECT_LE(c.maxStretchAfter, b.maxStretchAfter);
}

TEST(Seams, RoundsAreTheEffort) {
  const VenusCase v = venusCase();
  SeamOptions none, one, many;
  none.rounds = 0;
  one.rounds = 1;
  const SeamResult a = optimiseSeams(v.input(), none, {}), b = optimiseSeams(v.input(), one, {}),
                   c = optimiseSeams(v.input(), many, {});
  EXPECT_EQ(a.movedSides, 0);
  EXPECT_EQ(a.deltaEAfter, a.deltaEBefore);
  EXPECT_LT(b.deltaEAfter, a.deltaEAfter);
  EXPECT_LT(c.deltaEAfter, b.deltaEAfter);
  EXPECT_GT(c.rounds, 1);
}

TEST(Seams, GradientWeightMatchesGradientsAndMovesNeighbours) {
  const VenusCase v = venusCase();
  SeamOptions colour, gradient;
  gradient.gradientWeight = 0.7;
  const SeamResult a = optimiseSeams(v.input(), colour, {}), b = optimiseSeams(v.input(), gradient, {});
  EXPECT_EQ(a.neighbourVertices, 0);
  EXPECT_GT(b.neighbourVertices, 0);
  EXPECT_LT(b.gradientAfter, b.gradientBefore);
  EXPECT_LT(b.gradientAfter, a.gradientAfter)
      << "colour only " << a.gradientAfter << ", with gradients " << b.gradientAfter;
}

TEST(Seams, BadInputIsAnError) {
  const VenusCase v = venusCase();
  SeamInput in = v.input();
  in.photos.pop_back();
  EXPECT_NE(test::errorOf([&] { optimiseSeams(in, {}, {}); }).find("photo 1"), std::string::npos);
  SeamOptions bad;
  bad.lambda = 2;
  EXPECT_NE(test::errorOf([&] { optimiseSeams(v.input(), bad, {}); }).find("seamLambda"), std::string::npos);
}
