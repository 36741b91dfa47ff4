// 3D-view navigation maths (ui/navigation.h) and overlay building (ui/overlay_buffers.h), no display:
// zoom to the cursor and orbit about a point keep that point's pixel, frame all fits the box at
// several aspect ratios, the orthographic toggle keeps the target plane's scale, click-versus-drag,
// label placement without overlaps, and the photo-pane overlay buffer's contents.
#include "navigation.h"

#include <gtest/gtest.h>

#include "overlay_buffers.h"

using namespace montage;

namespace {

Vec2 pixelOf(const OrbitCamera& c, int w, int h, const Vec3& p) {
  Vec2 px;
  EXPECT_TRUE(c.camera(w, h).project(p, px));
  return px;
}

OrbitCamera framed(int w, int h) {
  OrbitCamera c;
  c.frame(Vec3(-1, -2, -0.5), Vec3(1, 2, 0.5));
  frameBox(c, Vec3(-1, -2, -0.5), Vec3(1, 2, 0.5), w, h);
  return c;
}

}  // namespace

TEST(Navigation, ZoomToCursorKeepsThePointUnderTheCursor) {
  const int w = 800, h = 600;
  OrbitCamera c = framed(w, h);
  const Vec3 anchor = anchorAt(c, w, h, 610.5, 140.5, nullptr);  // off-centre, on the target's plane
  const Vec2 before = pixelOf(c, w, h, anchor);
  EXPECT_NEAR(before.x(), 610.5, 1e-6);
  EXPECT_NEAR(before.y(), 140.5, 1e-6);
  const Vec3 surface(0.7, 1.1, 0.4);  // a surface hit off the target's plane
  const Vec2 surfaceBefore = pixelOf(c, w, h, surface);
  const double d0 = c.distance;
  zoomAbout(c, surface, 3);
  EXPECT_LT(c.distance, d0 * 0.7);
  const Vec2 surfaceAfter = pixelOf(c, w, h, surface);
  EXPECT_NEAR((surfaceAfter - surfaceBefore).norm(), 0, 1e-6);
  // Zooming about the target instead would move that point on screen: the test can fail.
  OrbitCamera plain = framed(w, h);
  plain.zoom(3);
  EXPECT_GT((pixelOf(plain, w, h, surface) - surfaceBefore).norm(), 20);
}

TEST(Navigation, OrbitAboutAPickedPointKeepsItsPixel) {
  const int w = 640, h = 480;
  OrbitCamera c = framed(w, h);
  const Vec3 pivot(0.8, -1.5, 0.3);
  const Vec2 before = pixelOf(c, w, h, pivot);
  const double yaw0 = c.yawDeg;
  orbitAbout(c, pivot, 40, -25);
  EXPECT_NE(c.yawDeg, yaw0);
  EXPECT_NEAR((pixelOf(c, w, h, pivot) - before).norm(), 0, 1e-6);
}

TEST(Navigation, FrameAllFitsWidthAndHeight) {
  const Vec3 lo(-1, -2, -0.5), hi(1, 2, 0.5);
  for (const auto& [w, h] : {std::pair{800, 600}, std::pair{600, 800}, std::pair{2560, 1600}, std::pair{300, 900}})
    for (double yaw : {0.0, 37.0, 90.0})
      for (double pitch : {-60.0, 0.0, 20.0}) {
        OrbitCamera c;
        c.yawDeg = yaw, c.pitchDeg = pitch;
        frameBox(c, lo, hi, w, h);
        double fill = 0;
        for (int k = 0; k < 8; ++k) {
          const Vec3 p((k & 1) ? hi.x() : lo.x(), (k & 2) ? hi.y() : lo.y(), (k & 4) ? hi.z() : lo.z());
          const Vec2 px = pixelOf(c, w, h, p);
          EXPECT_GE(px.x(), 0) << w << "x" << h;
          EXPECT_LE(px.x(), w) << w << "x" << h;
          EXPECT_GE(px.y(), 0) << w << "x" << h;
          EXPECT_LE(px.y(), h) << w << "x" << h;
          fill = std::max({fill, std::abs(px.x() - w / 2.0) / (w / 2.0), std::abs(px.y() - h / 2.0) / (h / 2.0)});
        }
        EXPECT_GT(fill, 0.25) << "the box should not be tiny in " << w << "x" << h;
      }
}

TEST(Navigation, OrthographicKeepsTheTargetPlaneScale) {
  const int w = 800, h = 600;
  OrbitCamera c = framed(w, h);
  const Vec3 side = c.target + 0.5 * Vec3(c.camera(w, h).R.row(0).transpose());  // in the target's plane
  const double before = (pixelOf(c, w, h, side) - pixelOf(c, w, h, c.target)).norm();
  setOrthographic(c, true);
  EXPECT_TRUE(isOrthographic(c));
  const double ortho = (pixelOf(c, w, h, side) - pixelOf(c, w, h, c.target)).norm();
  EXPECT_NEAR(ortho, before, 1e-6 * before);
  // Nearly parallel projection: a point 1 unit nearer the camera scales by less than 1%.
  const Vec3 toEye = (c.eye() - c.target).normalized();
  const double nearer = (pixelOf(c, w, h, side + toEye) - pixelOf(c, w, h, c.target + toEye)).norm();
  EXPECT_NEAR(nearer / ortho, 1, 0.01);
  setOrthographic(c, false);
  EXPECT_FALSE(isOrthographic(c));
  EXPECT_NEAR(c.fovYDeg, kPerspectiveFovDeg, 1e-12);
}

TEST(Navigation, PresetsLookAlongTheAxes) {
  OrbitCamera c;
  applyPreset(c, ViewPreset::Front);
  EXPECT_NEAR((c.eye() - c.target).normalized().z(), 1, 1e-9);
  applyPreset(c, ViewPreset::Right);
  EXPECT_NEAR((c.eye() - c.target).normalized().x(), 1, 1e-9);
  applyPreset(c, ViewPreset::Top);
  EXPECT_GT((c.eye() - c.target).normalized().y(), 0.99);
}

TEST(Navigation, ClickVersusDragByDistanceAndTime) {
  ClickDrag cd;
  cd.press(100, 100, 0);
  EXPECT_FALSE(cd.move(108, 103, 0.1));  // a quick jitter of 8.5 px
  EXPECT_TRUE(cd.releaseIsClick(108, 103, 0.15));
  cd.press(100, 100, 1);
  EXPECT_FALSE(cd.move(103, 100, 1.1));
  EXPECT_TRUE(cd.move(106, 100, 1.5));  // slow and beyond 4 px: a drag
  EXPECT_FALSE(cd.releaseIsClick(106, 100, 1.6));
  cd.press(100, 100, 2);
  EXPECT_TRUE(cd.move(120, 100, 2.05));  // fast and far: a drag at once
  EXPECT_EQ(dragAction(MouseBindings::MeshLab, 0, false, false), DragAction::Orbit);
  EXPECT_EQ(dragAction(MouseBindings::Blender, 0, false, false), DragAction::None);
  EXPECT_EQ(dragAction(MouseBindings::Blender, 2, false, false), DragAction::Orbit);
  EXPECT_EQ(dragAction(MouseBindings::Blender, 2, true, false), DragAction::Pan);
}

TEST(Navigation, ReducedResolutionWhileTheCameraMoves) {
  // The divisor keeps a reduced view at 120k pixels or fewer, in whole pixels, at most 4.
  EXPECT_EQ(navigationDivisor(300, 300), 1);    // 90k pixels: small enough already
  EXPECT_EQ(navigationDivisor(486, 729), 2);    // the 1280x800 window's view
  EXPECT_EQ(navigationDivisor(972, 1458), 4);   // the same at 2560x1600 (UI scale 2)
  EXPECT_EQ(navigationDivisor(4000, 4000), 4);  // never below a quarter per axis
  EXPECT_EQ(navigationDivisor(0, 0), 1);
  NavigationMotion m;
  m.update(true, 10, 1.0);  // a lone change (frame all): drawn full size at once
  EXPECT_FALSE(m.moving());
  m.update(false, 11, 1.5);
  m.update(true, 12, 2.0);  // an orbit: changes in consecutive frames
  EXPECT_FALSE(m.moving());
  m.update(true, 13, 2.04);
  EXPECT_TRUE(m.moving());
  m.update(true, 14, 2.5);  // a slow frame (0.46 s) during the orbit: still moving
  EXPECT_TRUE(m.moving());
  m.update(false, 15, 2.6);  // stopped, within the settle time
  EXPECT_TRUE(m.moving());
  EXPECT_NEAR(m.secondsToSettle(2.6), 0.1, 1e-9);
  m.update(false, 16, 2.5 + kNavigationSettleSeconds);  // settled: the next redraw is full size
  EXPECT_FALSE(m.moving());
  EXPECT_EQ(m.secondsToSettle(3.0), 0);
  m.update(true, 30, 5.0);  // wheel notches 0.1 s apart, frames in between: moving from the second
  m.update(false, 31, 5.05);
  m.update(true, 32, 5.1);
  EXPECT_TRUE(m.moving());
}

TEST(Overlays, LabelsDoNotOverlapExceptTheAlwaysShown) {
  std::vector<LabelCandidate> labels;
  for (int i = 0; i < 50; ++i) {
    LabelCandidate l;
    l.lo = Vec2(100 + 3 * i, 100);  // heavily overlapping row
    l.size = Vec2(20, 14);
    labels.push_back(l);
  }
  labels[30].always = true;
  const std::vector<int> chosen = placeLabels(labels);
  EXPECT_NE(std::find(chosen.begin(), chosen.end(), 30), chosen.end());
  EXPECT_LT(chosen.size(), 12u);
  EXPECT_GT(chosen.size(), 3u);
  for (size_t a = 0; a < chosen.size(); ++a)
    for (size_t b = a + 1; b < chosen.size(); ++b) {
      const LabelCandidate &p = labels[chosen[a]], &q = labels[chosen[b]];
      const bool overlap = p.lo.x() < q.lo.x() + q.size.x() && q.lo.x() < p.lo.x() + p.size.x();
      EXPECT_FALSE(overlap) << chosen[a] << " and " << chosen[b];
    }
}

TEST(Overlays, PaneBufferHoldsTheMarkersCurvesAndRejectedPairsOfItsPhoto) {
  Project p;
  for (int k = 0; k < 4; ++k) {
    FeaturePoint fp;
    fp.vertex = k;
    fp.at.push_back(PhotoPoint{0, 10.0 * k, 20.0});
    if (k < 2) fp.at.push_back(PhotoPoint{1, 5.0, 5.0 * k});
    p.points.push_back(fp);
  }
  Partition part;
  MeshPath path;
  path.fromPoint = 0, path.toPoint = 1;
  path.curves.push_back(Curve{0, Vec2(0, 20), Vec2(10, 20)});
  part.paths.push_back(path);
  part.rejected.push_back(RejectedPair{2, 3, 0, RejectReason::CurveCrossesCurve, ""});
  part.rejected.push_back(RejectedPair{0, 1, 1, RejectReason::CurveCrossesCurve, ""});
  const PaneOverlay o = buildPaneOverlay(p, &part, 0);
  EXPECT_EQ(o.points.size() / kPaneVertexFloats, 4u);
  EXPECT_EQ(o.lines.size() / kPaneVertexFloats, 4u);  // one curve + one rejected pair
  EXPECT_EQ(o.rejectedInPhoto, 1);
  const PaneOverlay one = buildPaneOverlay(p, &part, 1);
  EXPECT_EQ(one.points.size() / kPaneVertexFloats, 2u);
  PaneOverlayOptions none;
  none.curves = none.rejected = none.features = false;
  EXPECT_TRUE(buildPaneOverlay(p, &part, 0, none).lines.empty());
}
