// Tests of core/surface/trust (issue 37): face trust from the angle and density of a face's map into its
// photo, clipped colours, and seam levelling that takes a grazing edge's difference from its pair's
// trusted edges instead of from its own smeared texels.
#include "surface/trust.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <opencv2/imgproc.hpp>

#include "base/job.h"
#include "geometry/mesh.h"
#include "geometry/shapes.h"
#include "image/photo.h"
#include "surface/level.h"
#include "test_support.h"

using namespace montage;

namespace {

// The unit square (41 x 41 vertices): faces left of x = 0.5 on photo 0, seen head on at 400 px per unit
// (uv = 50 + 400 (x, y)); faces right of it on photo 1, `squeeze(y)` times narrower across x (a view that
// many times more oblique: the stretch ratio is squeeze) and `scale` times as many pixels per unit.
struct SplitScene {
  std::unique_ptr<Mesh> mesh = makeGrid(41, 41, 1.0 / 40);
  TextureMap map;
};

SplitScene splitScene(const std::function<double(double)>& squeeze, double scale = 1) {
  SplitScene s;
  for (int f = 0; f < s.mesh->numFaces(); ++f) {
    const auto p = s.mesh->facePositions(f);
    const Vec3 c = (p[0] + p[1] + p[2]) / 3;
    const bool right = c.x() > 0.5;
    s.map.facePhoto.push_back(right ? 1 : 0);
    s.map.facePatch.push_back(0);
    std::array<Vec2, 3> uv;
    for (int k = 0; k < 3; ++k)
      uv[k] = right ? Vec2(250 + 400 * scale * squeeze(c.y()) * (p[k].x() - 0.5), 50 + 400 * scale * p[k].y())
                    : Vec2(50 + 400 * p[k].x(), 450 - 400 * p[k].y());  // y down: the winding flips
    s.map.cornerUV.push_back(uv);
  }
  return s;
}

// A 500 x 500 photo of one colour, `other` in the rectangle `where` (pixels).
Photo flatPhoto(float value, float other = 0, cv::Rect where = {}) {
  Photo p;
  p.width = p.height = 500;
  p.rgb = cv::Mat(500, 500, CV_32FC3, cv::Scalar::all(value));
  if (where.area() > 0) p.rgb(where).setTo(cv::Scalar::all(other));
  p.alpha = cv::Mat(500, 500, CV_32FC1, cv::Scalar(1));
  p.distance = cv::Mat(500, 500, CV_32FC1, cv::Scalar(0));
  return p;
}

float largestOffset(const SeamLevelling& lev) {
  float most = 0;
  for (const auto& corners : lev.cornerOffset)
    for (const Vec3f& o : corners) most = std::max(most, o.cwiseAbs().maxCoeff());
  return most;
}

}  // namespace

TEST(Trust, HeadOnFacesAreTrustedGrazingOnesNotAndSparseOnesLess) {
  struct Case {
    double squeeze, scale, ratio, trust;
  };
  // The median density is photo 0's (the larger half of the faces' densities): photo 1's density term is
  // sqrt(squeeze * scale^2) where that is below 1.
  for (const Case& c :
       {Case{1, 1, 1, 1}, Case{0.45, 1, 0.45, 0.5 * std::sqrt(0.45)}, Case{0.25, 1, 0.25, 0}, Case{1, 0.5, 1, 0.5}}) {
    SCOPED_TRACE("squeeze " + std::to_string(c.squeeze) + ", scale " + std::to_string(c.scale));
    const SplitScene s = splitScene([&](double) { return c.squeeze; }, c.scale);
    const FaceTrust t = faceTrust(*s.mesh, s.map);
    EXPECT_NEAR(t.medianDensity, 400.0 * 400.0, 1e-6 * 400 * 400);
    for (int f = 0; f < s.mesh->numFaces(); ++f) {
      const bool right = s.map.facePhoto[f] == 1;
      ASSERT_NEAR(t.ratio[f], right ? c.ratio : 1.0, 1e-5) << "face " << f;
      ASSERT_NEAR(t.trust[f], right ? c.trust : 1.0, 1e-5) << "face " << f;
    }
  }
  // Unmapped faces have no trust.
  SplitScene s = splitScene([](double) { return 1.0; });
  s.map.facePhoto[0] = TextureMap::kEmpty;
  EXPECT_EQ(faceTrust(*s.mesh, s.map).trust[0], 0.0f);
}

TEST(Trust, ClippedColorsAreThoseAtEitherEndOfTheRange) {
  EXPECT_FALSE(clippedColor(Vec3f(0.5f, 0.5f, 0.5f)));
  EXPECT_FALSE(clippedColor(Vec3f(0.02f, 0.5f, 0.98f)));
  EXPECT_TRUE(clippedColor(Vec3f(1.0f, 0.5f, 0.5f)));
  EXPECT_TRUE(clippedColor(Vec3f(0.5f, 252 / 255.0f, 0.5f)));
  EXPECT_TRUE(clippedColor(Vec3f(0.5f, 0.5f, 0.01f)));
}

// Photo 1 is seen obliquely along the upper half of the seam (y > 0.5, stretch ratio 0.2: not trusted) and head
// on along the lower half.
TEST(Trust, LevellingTakesAGrazingEdgesDifferenceFromItsPairsTrustedEdges) {
  const SplitScene mixed = splitScene([](double y) { return y > 0.5 ? 0.2 : 1.0; });
  const Photo a = flatPhoto(0.5f);
  // A real difference (photo 1 brighter everywhere): the trusted edges show it, the grazing ones are closed too.
  const Photo brighter = flatPhoto(0.6f);
  const SeamLevelling closed = levelSeams(*mixed.mesh, mixed.map, {&a, &brighter}, LevelMode::Vertex, {});
  std::printf("a real difference: mismatch %.4f -> %.4f\n", closed.meanMismatchBefore, closed.meanMismatchAfter);
  EXPECT_NEAR(closed.meanMismatchBefore, 0.1, 1e-4);
  EXPECT_LT(closed.meanMismatchAfter, 0.005);
  // A difference only in photo 1's pixels of the grazing part (y > 255 px there): the trusted edges agree, so the
  // grazing edges are levelled by nothing, and no offset spreads into either photo.
  const Photo smeared = flatPhoto(0.5f, 0.6f, cv::Rect(0, 255, 500, 245));
  const SeamLevelling kept = levelSeams(*mixed.mesh, mixed.map, {&a, &smeared}, LevelMode::Vertex, {});
  std::printf("smeared grazing texels: mismatch %.4f -> %.4f, largest offset %.5f\n", kept.meanMismatchBefore,
              kept.meanMismatchAfter, largestOffset(kept));
  EXPECT_GT(kept.meanMismatchBefore, 0.04);
  EXPECT_LT(largestOffset(kept), 1e-4);
  // A seam that is grazing all along: no trusted sample in the pair, nothing to level by (offsets 0).
  const SplitScene grazing = splitScene([](double) { return 0.2; });
  const SeamLevelling pinned = levelSeams(*grazing.mesh, grazing.map, {&a, &brighter}, LevelMode::Vertex, {});
  EXPECT_LT(largestOffset(pinned), 1e-6);
  EXPECT_NEAR(pinned.meanMismatchAfter, pinned.meanMismatchBefore, 1e-6);
  // Head on all along: levelled as before.
  const SplitScene headOn = splitScene([](double) { return 1.0; });
  const SeamLevelling levelled = levelSeams(*headOn.mesh, headOn.map, {&a, &brighter}, LevelMode::Vertex, {});
  EXPECT_LT(levelled.meanMismatchAfter, 0.005);
}
