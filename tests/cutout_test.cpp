// Tests of core/image/cutout: GrabCut from a rectangle and from strokes on synthetic photos whose true
// foreground is known, the mask brush, the feathered edge, the foreground warnings, and `montage mask`.
#include "image/cutout.h"

#include <chrono>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>

#include "image/photo.h"
#include "test_support.h"

namespace fs = std::filesystem;
using namespace montage;
using montage::test::errorOf;

namespace {

double iou(const cv::Mat& a, const cv::Mat& b) {
  const double inter = cv::countNonZero((a > 0) & (b > 0)), uni = cv::countNonZero((a > 0) | (b > 0));
  return uni > 0 ? inter / uni : 1.0;
}

// A 320x240 photo (CV_32FC3 sRGB): a textured background (green-blue noise with stripes) and a
// reddish noisy disc of radius 60 around (150, 120); `truth` is the disc. `scale` > 1: the same scene
// drawn that many times larger (the disc's edge sharp at every size, the noise per pixel).
cv::Mat discScene(cv::Mat& truth, unsigned seed = 3, int scale = 1) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> noise(-0.12f, 0.12f);
  cv::Mat rgb(240 * scale, 320 * scale, CV_32FC3);
  truth = cv::Mat::zeros(rgb.size(), CV_8U);
  const double cx = 150.0 * scale, cy = 120.0 * scale, r = 60.0 * scale;
  for (int y = 0; y < rgb.rows; ++y)
    for (int x = 0; x < rgb.cols; ++x) {
      const bool disc = (x + 0.5 - cx) * (x + 0.5 - cx) + (y + 0.5 - cy) * (y + 0.5 - cy) <= r * r;
      cv::Vec3f c;
      if (disc) {
        c = cv::Vec3f(0.8f, 0.35f, 0.25f);
        truth.at<uchar>(y, x) = 255;
      } else {
        const float stripe = ((x / (12 * scale) + y / (17 * scale)) % 2) ? 0.15f : -0.05f;
        c = cv::Vec3f(0.2f, 0.5f + stripe, 0.45f - stripe);
      }
      for (int k = 0; k < 3; ++k) c[k] = std::clamp(c[k] + noise(rng), 0.0f, 1.0f);
      rgb.at<cv::Vec3f>(y, x) = c;
    }
  return rgb;
}

// Pixels where a mask and the truth differ.
int wrongPixels(const cv::Mat& mask, const cv::Mat& truth) {
  return cv::countNonZero((mask > 0) != (truth > 0));
}

}  // namespace

TEST(Cutout, GrabCutSeparatesADiscFromATexturedBackground) {
  cv::Mat truth;
  const cv::Mat rgb = discScene(truth);
  Cutout cut(rgb);
  EXPECT_FALSE(cut.started());
  EXPECT_EQ(cv::countNonZero(cut.mask()), 0);
  cut.setRect(cv::Rect2d(80, 50, 140, 140));  // a loose box around the disc
  const double score = iou(cut.binaryMask(), truth);
  std::printf("IoU from the rectangle: %.4f (%.3f s)\n", score, cut.lastSeconds());
  EXPECT_GT(score, 0.95);
  // Nothing outside the rectangle is foreground.
  cv::Mat outside = cut.binaryMask().clone();
  outside(cv::Rect(80, 50, 140, 140)).setTo(0);
  EXPECT_EQ(cv::countNonZero(outside), 0);
  // The one-shot function gives the same mask.
  EXPECT_EQ(cv::norm(cutoutMask(rgb, cv::Rect2d(80, 50, 140, 140)), cut.mask(), cv::NORM_INF), 0);
}

TEST(Cutout, StrokesFixWhatTheRectangleGetsWrong) {
  cv::Mat truth;
  cv::Mat rgb = discScene(truth);
  // A patch of the disc's colour in the background, inside the rectangle and touching the disc: from the
  // rectangle alone GrabCut keeps it (it looks like the object), so the user strokes it as background.
  const cv::Rect patch(200, 100, 25, 40);
  rgb(patch).setTo(cv::Scalar(0.8, 0.35, 0.25));
  Cutout cut(rgb);
  cut.setRect(cv::Rect2d(80, 50, 150, 140));
  const double fromRect = iou(cut.binaryMask(), truth);
  const auto wrongInPatch = [&] { return cv::countNonZero((cut.binaryMask() & ~truth)(patch)); };
  const int wrongBefore = wrongInPatch();
  EXPECT_GT(wrongBefore, 400) << "the test needs a rectangle-only error";
  CutoutStroke stroke;
  stroke.points = {Vec2(214, 102), Vec2(214, 138)};
  stroke.radius = 9;
  stroke.foreground = false;
  cut.addStroke(stroke);
  const double afterStroke = iou(cut.binaryMask(), truth);
  std::printf("IoU: rectangle %.4f, + background stroke %.4f\n", fromRect, afterStroke);
  EXPECT_LT(wrongInPatch(), wrongBefore / 10);
  EXPECT_GT(afterStroke, 0.95);
  EXPECT_GT(afterStroke, fromRect + 0.02);

  // The same from stroke images (the command line's --bg file).
  cv::Mat bg = cv::Mat::zeros(rgb.size(), CV_8U);
  cv::line(bg, cv::Point(212, 105), cv::Point(212, 135), 255, 10);
  const cv::Mat viaFiles = cutoutMask(rgb, cv::Rect2d(80, 50, 150, 140), {}, bg);
  EXPECT_GT(iou(viaFiles, truth), 0.95);
}

TEST(Cutout, StrokesAloneStartACutOutAndWorkAtAReducedWorkingSize) {
  cv::Mat truth;
  const cv::Mat rgb = discScene(truth);
  CutoutOptions options;
  options.workingSide = 160;  // half size: the mask comes back at full size with a smooth edge
  Cutout cut(rgb, options);
  CutoutStroke fg;
  fg.points = {Vec2(120, 120), Vec2(180, 120)};
  fg.radius = 8;
  CutoutStroke bg;
  bg.points = {Vec2(10, 10), Vec2(310, 10), Vec2(310, 230), Vec2(10, 230), Vec2(10, 10)};
  bg.radius = 8;
  bg.foreground = false;
  cut.addStrokes({fg, bg});
  const cv::Mat mask = cut.binaryMask();
  ASSERT_EQ(mask.size(), rgb.size());
  const double score = iou(mask, truth);
  std::printf("IoU from strokes alone at half size: %.4f\n", score);
  EXPECT_GT(score, 0.9);
  // Without any foreground mark there is nothing to learn the object from.
  Cutout empty(rgb);
  EXPECT_NE(errorOf([&] { empty.addStroke(bg); }).find("nothing is marked as foreground"), std::string::npos);
}

TEST(Cutout, BrushEditsTheMaskWithoutGrabCut) {
  cv::Mat truth;
  const cv::Mat rgb = discScene(truth);
  Cutout cut(rgb);
  cut.setRect(cv::Rect2d(80, 50, 140, 140));
  const cv::Mat before = cut.binaryMask().clone();
  CutoutStroke erase;
  erase.points = {Vec2(150.5, 120.5)};
  erase.radius = 10;
  erase.foreground = false;
  cut.brush(erase);
  const cv::Mat erased = cut.binaryMask();
  EXPECT_EQ(erased.at<uchar>(120, 150), 0);
  EXPECT_EQ(erased.at<uchar>(120, 157), 0);    // 7 px away: under the brush (radius 10)
  EXPECT_EQ(erased.at<uchar>(120, 175), 255);  // 25 px away: untouched
  const int removed = cv::countNonZero(before) - cv::countNonZero(erased);
  EXPECT_NEAR(removed, M_PI * 100, 40);  // the brush's disc, no more
  CutoutStroke add;
  add.points = {Vec2(20.5, 20.5), Vec2(40.5, 20.5)};
  add.radius = 3;
  cut.brush(add);
  EXPECT_EQ(cut.binaryMask().at<uchar>(20, 30), 255);
  // Brushed pixels are certain: a later GrabCut run keeps them.
  CutoutStroke fg;
  fg.points = {Vec2(130, 120)};
  fg.radius = 4;
  cut.addStroke(fg);
  EXPECT_EQ(cut.binaryMask().at<uchar>(20, 30), 255);
  EXPECT_EQ(cut.binaryMask().at<uchar>(120, 150), 0);
}

TEST(Cutout, FeatheredEdgeKeepsTheForegroundAndSoftensItsEdge) {
  cv::Mat binary = cv::Mat::zeros(50, 50, CV_8U);
  binary(cv::Rect(10, 10, 30, 30)).setTo(255);
  const cv::Mat hard = featherMask(binary, 0);
  EXPECT_EQ(cv::norm(hard, binary, cv::NORM_INF), 0);
  const cv::Mat soft = featherMask(binary, 4);
  EXPECT_EQ(cv::countNonZero(soft), cv::countNonZero(binary));  // same foreground
  EXPECT_EQ(soft.at<uchar>(25, 25), 255);                       // inside: full alpha
  EXPECT_EQ(soft.at<uchar>(25, 10), 64);                        // edge pixel, 1 px from the background: 1/4
  EXPECT_EQ(soft.at<uchar>(25, 12), 191);                       // 3 px in: 3/4
  EXPECT_EQ(soft.at<uchar>(0, 0), 0);
  // Written and loaded as a photo's mask: the alpha the loader sees is the feathered one.
  const std::string dir = test::tempDir("cutout");
  const std::string photoPath = (fs::path(dir) / "p.png").string();
  cv::imwrite(photoPath, cv::Mat(50, 50, CV_8UC3, cv::Scalar(90, 90, 90)));
  writeMaskPng(soft, (fs::path(dir) / "masks/p_mask.png").string());
  const Photo photo = loadPhoto(photoPath, (fs::path(dir) / "masks/p_mask.png").string());
  ASSERT_EQ(photo.alpha.type(), CV_8UC1);
  EXPECT_EQ(photo.alpha.at<uchar>(25, 10), 64);
  EXPECT_NEAR(photo.alphaAt(10.5, 25.5), 64 / 255.0f, 1e-6);
  EXPECT_EQ(photo.alpha.at<uchar>(25, 25), 255);
  EXPECT_EQ(cv::countNonZero(photo.alpha > 0), cv::countNonZero(binary));
}

TEST(Cutout, WarningsForNoBackgroundAndForABorderCoveringForeground) {
  const std::string dir = test::tempDir("cutout");
  const std::string photoPath = (fs::path(dir) / "p.png").string();
  cv::imwrite(photoPath, cv::Mat(60, 80, CV_8UC3, cv::Scalar(90, 120, 150)));
  // No alpha, no mask.
  auto warnings = foregroundWarnings(loadPhoto(photoPath));
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("no alpha channel and no mask"), std::string::npos) << warnings[0];
  // A mask that keeps most of the border (background kept around the object).
  cv::Mat mask(60, 80, CV_8U, cv::Scalar(255));
  mask(cv::Rect(0, 50, 30, 10)).setTo(0);
  const std::string maskPath = (fs::path(dir) / "m.png").string();
  writeMaskPng(mask, maskPath);
  EXPECT_NEAR(borderForegroundShare(mask), 1 - 30.0 / (2 * 80 + 2 * 58) - 9.0 / (2 * 80 + 2 * 58), 1e-9);
  warnings = foregroundWarnings(loadPhoto(photoPath, maskPath));
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("of the image border"), std::string::npos) << warnings[0];
  // An object cut out inside the frame, touching one side: no warning.
  mask.setTo(0);
  mask(cv::Rect(20, 10, 40, 50)).setTo(255);
  writeMaskPng(mask, maskPath);
  EXPECT_LT(borderForegroundShare(mask), 0.2);
  EXPECT_TRUE(foregroundWarnings(loadPhoto(photoPath, maskPath)).empty());
}

// A trimap (the camera stage's, around a mesh's outline 6 px off the object): GrabCut decides the band between the
// certain inside and outside, and finds the disc's edge, not the trimap's.
TEST(Cutout, ATrimapAroundAShiftedOutlineFindsTheObjectsEdge) {
  cv::Mat truth;
  const cv::Mat rgb = discScene(truth);
  cv::Mat outline = cv::Mat::zeros(truth.size(), CV_8U);
  cv::circle(outline, cv::Point(156, 116), 61, cv::Scalar(255), cv::FILLED);  // the disc 6 px right, 4 up
  cv::Mat inside, outside;
  cv::erode(outline, inside, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(25, 25)));
  cv::dilate(outline, outside, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(25, 25)));
  cv::Mat labels(truth.size(), CV_8U, cv::Scalar(cv::GC_BGD));
  labels.setTo(cv::Scalar(cv::GC_PR_BGD), outside);
  labels.setTo(cv::Scalar(cv::GC_PR_FGD), outline);
  labels.setTo(cv::Scalar(cv::GC_FGD), inside);
  Cutout cut(rgb);
  cut.startFromTrimap(labels);
  std::printf("trimap: IoU %.4f (the outline's %.4f)\n", iou(cut.binaryMask(), truth), iou(outline, truth));
  EXPECT_GT(iou(cut.binaryMask(), truth), 0.98);
  EXPECT_LT(iou(outline, truth), 0.9);
  EXPECT_NE(errorOf([&] { cut.startFromTrimap(cv::Mat::zeros(10, 10, CV_8U)); }).find("trimap is 10x10"),
            std::string::npos);
  EXPECT_NE(errorOf([&] {
              cut.startFromTrimap(cv::Mat(truth.size(), CV_8U, cv::Scalar(cv::GC_BGD)));
            }).find("nothing is marked as foreground"),
            std::string::npos);
}

TEST(Cutout, BadRequestsAreClearErrors) {
  cv::Mat truth;
  const cv::Mat rgb = discScene(truth);
  Cutout cut(rgb);
  EXPECT_NE(errorOf([&] { cut.setRect(cv::Rect2d(400, 300, 50, 50)); }).find("outside the photo"), std::string::npos);
  EXPECT_NE(errorOf([&] { cut.setRect(cv::Rect2d(-10, -10, 400, 300)); }).find("covers the whole photo"),
            std::string::npos);
  CutoutStroke bad;
  bad.radius = 0;
  bad.points = {Vec2(1, 1)};
  EXPECT_NE(errorOf([&] { cut.brush(bad); }).find("radius must be > 0"), std::string::npos);
  CutoutOptions options;
  options.iterations = 0;
  EXPECT_NE(errorOf([&] { Cutout c(rgb, options); }).find("iterations must be >= 1"), std::string::npos);
  EXPECT_NE(errorOf([&] { Cutout c{cv::Mat()}; }).find("empty"), std::string::npos);
  EXPECT_NE(errorOf([&] { cut.addStrokeMasks(cv::Mat::zeros(10, 10, CV_8U), {}); }).find("10x10"), std::string::npos);
}

TEST(Cutout, MontageMaskWritesAMaskTheProjectCanUse) {
  cv::Mat truth;
  const cv::Mat rgb = discScene(truth);
  const std::string dir = test::tempDir("cutout_cli");
  cv::Mat bgr8;
  rgb.convertTo(bgr8, CV_8UC3, 255);
  cv::cvtColor(bgr8, bgr8, cv::COLOR_RGB2BGR);
  cv::imwrite(dir + "/photo.png", bgr8);
  std::string out;
  ASSERT_EQ(test::runCommand(test::montageExe() + " mask " + dir +
                                 "/photo.png --rect 80,50,140,140 --feather 2 --out " + dir + "/mask.png 2>&1",
                             &out),
            0)
      << out;
  EXPECT_NE(out.find("wrote " + dir + "/mask.png (320x240)"), std::string::npos) << out;
  const Photo photo = loadPhoto(dir + "/photo.png", dir + "/mask.png");
  EXPECT_GT(iou(photo.alpha > 0, truth), 0.95);
  EXPECT_TRUE(foregroundWarnings(photo).empty());
  // Errors name what is wrong.
  EXPECT_NE(test::runCommand(
                test::montageExe() + " mask " + dir + "/photo.png --rect 1,2,3 --out " + dir + "/m2.png 2>&1", &out),
            0);
  EXPECT_NE(out.find("--rect: expected x,y,w,h"), std::string::npos) << out;
  EXPECT_NE(test::runCommand(test::montageExe() + " mask " + dir + "/photo.png --rect 0,0,10,10 --fg " + dir +
                                 "/nothere.png --out " + dir + "/m2.png 2>&1",
                             &out),
            0);
  EXPECT_NE(out.find("nothere.png: image file not found"), std::string::npos) << out;
}

// GrabCut runs at a working size 8 times smaller than the photo; the band around its edge is cut again at
// the photo's own pixels, so the edge follows the disc to the pixel, not the working size's 8-pixel steps.
TEST(Cutout, TheMaskEdgeIsAtThePhotosResolutionNotTheWorkingSizes) {
  cv::Mat truth;
  const cv::Mat rgb = discScene(truth, 3, 5);  // 1600x1200, the disc's radius 300
  CutoutOptions options;
  options.workingSide = 200;
  Cutout cut(rgb, options);
  cut.setRect(cv::Rect2d(400, 250, 700, 700));
  const cv::Mat mask = cut.binaryMask();
  ASSERT_EQ(mask.size(), rgb.size());
  options.bandPx = 0;  // the working result scaled up (bilinear, cut at 1/2), no band
  Cutout coarse(rgb, options);
  coarse.setRect(cv::Rect2d(400, 250, 700, 700));
  const double perimeter = 2 * M_PI * 300;
  const int wrong = wrongPixels(mask, truth), wrongCoarse = wrongPixels(coarse.binaryMask(), truth);
  std::printf("pixels off the disc: %d with the band (%.2f per edge pixel), %d scaled up from the working size\n",
              wrong, wrong / perimeter, wrongCoarse);
  // A working pixel is 8 photo pixels: its edge is off by about 2 pixels on average along the disc.
  EXPECT_LT(wrong, 0.5 * perimeter);
  EXPECT_LT(wrong, wrongCoarse / 2);
  // The edge has steps of single pixels: edge pixels at every position modulo the working pixel's 8.
  std::vector<int> columns(8, 0);
  for (int y = 1; y < mask.rows; ++y)
    for (int x = 1; x < mask.cols; ++x)
      if (mask.at<uchar>(y, x) != mask.at<uchar>(y, x - 1)) ++columns[x % 8];
  for (int k = 0; k < 8; ++k) EXPECT_GT(columns[k], 30) << "edge pixels in column " << k << " modulo 8";
}

// The finding: a background stroke barely moved the cut (36.8% -> 35.4% foreground). Here the
// rectangle keeps a patch of the disc's colour beside it, and one background stroke across the patch
// takes nearly all of it out, also at a reduced working size with the band.
TEST(Cutout, ABackgroundStrokeTakesOutTheRegionItIsDrawnIn) {
  cv::Mat truth;
  cv::Mat rgb = discScene(truth, 3, 4);  // 1280x960
  const cv::Rect patch(800, 400, 100, 160);
  rgb(patch).setTo(cv::Scalar(0.8, 0.35, 0.25));
  CutoutOptions options;
  options.workingSide = 320;
  Cutout cut(rgb, options);
  cut.setRect(cv::Rect2d(320, 200, 600, 560));
  const auto share = [&] { return cv::countNonZero(cut.binaryMask()) / double(rgb.total()); };
  const double before = share();
  const int keptBefore = cv::countNonZero(cut.binaryMask()(patch));
  ASSERT_GT(keptBefore, patch.area() / 2) << "the test needs the rectangle to keep the patch";
  CutoutStroke stroke;
  stroke.points = {Vec2(850, 420), Vec2(850, 540)};
  stroke.radius = 12;
  stroke.foreground = false;
  cut.addStroke(stroke);
  const double after = share();
  std::printf("foreground %.1f%% -> %.1f%% after one background stroke; patch kept %d -> %d pixels\n", 100 * before,
              100 * after, keptBefore, cv::countNonZero(cut.binaryMask()(patch)));
  // The patch is 1.3% of the photo, the stroke's pixels 0.2%: the share drops by at least half the patch.
  EXPECT_LT(after, before - 0.5 * patch.area() / double(rgb.total()));
  EXPECT_LT(cv::countNonZero(cut.binaryMask()(patch)), keptBefore / 2);
}

// A real stamp with real alpha (Debian tuxpaint-stamps-default) composited onto a real cluttered photo
// (python3-skimage's data), cut out from a rectangle and two strokes, as bench/cutout_bench.cpp does.
TEST(Cutout, RealStampOnAClutteredPhotoFromARectangleAndTwoStrokes) {
  const std::string stampPath = "/usr/share/tuxpaint/stamps/animals/mammals/cats/tiger.png";
  const std::string photoPath = "/usr/lib/python3/dist-packages/skimage/data/coffee.png";
  if (!fs::exists(stampPath) || !fs::exists(photoPath))
    GTEST_SKIP() << "needs Debian's tuxpaint-stamps-default (" << stampPath << ") and python3-skimage (" << photoPath
                 << ")";
  cv::Mat background;
  cv::cvtColor(readImageRgba8(photoPath), background, cv::COLOR_RGBA2RGB);
  const cv::Mat stamp = readImageRgba8(stampPath);
  const double scale = 0.55 * std::min(background.cols, background.rows) / std::max(stamp.cols, stamp.rows);
  cv::Mat big;
  cv::resize(stamp, big, cv::Size(), scale, scale, cv::INTER_AREA);
  const cv::Point at(int((background.cols - big.cols) * 0.3), int((background.rows - big.rows) * 0.3));
  cv::Mat truth = cv::Mat::zeros(background.size(), CV_8U);
  for (int y = 0; y < big.rows; ++y)
    for (int x = 0; x < big.cols; ++x) {
      const cv::Vec4b s = big.at<cv::Vec4b>(y, x);
      cv::Vec3b& d = background.at<cv::Vec3b>(at.y + y, at.x + x);
      for (int c = 0; c < 3; ++c) d[c] = cv::saturate_cast<uchar>((s[3] * s[c] + (255 - s[3]) * d[c]) / 255.0);
      if (s[3] >= 128) truth.at<uchar>(at.y + y, at.x + x) = 255;
    }
  const cv::Rect box = cv::boundingRect(truth);
  Cutout cut(background);
  cut.setRect(cv::Rect2d(box.x - 0.08 * box.width, box.y - 0.08 * box.height, 1.16 * box.width, 1.16 * box.height));
  const double fromRect = iou(cut.binaryMask(), truth);
  // One stroke of each kind through the innermost point of the largest region still wrong.
  std::vector<CutoutStroke> strokes;
  for (bool foreground : {true, false}) {
    const cv::Mat mask = cut.binaryMask();
    const cv::Mat wrong = foreground ? truth & ~mask : mask & ~truth;
    cv::Mat labels, stats, centroids;
    const int n = cv::connectedComponentsWithStats(wrong, labels, stats, centroids, 8);
    int best = 0;
    for (int i = 1; i < n; ++i)
      if (best == 0 || stats.at<int>(i, cv::CC_STAT_AREA) > stats.at<int>(best, cv::CC_STAT_AREA)) best = i;
    if (best == 0 || stats.at<int>(best, cv::CC_STAT_AREA) < 20) continue;
    cv::Mat distance;
    cv::distanceTransform(labels == best, distance, cv::DIST_L2, cv::DIST_MASK_PRECISE);
    double inner = 0;
    cv::Point p;
    cv::minMaxLoc(distance, nullptr, &inner, nullptr, &p);
    CutoutStroke stroke;
    stroke.points = {Vec2(p.x + 0.5, p.y + 0.5)};
    stroke.radius = std::clamp(0.6 * inner, 1.5, 8.0);
    stroke.foreground = foreground;
    strokes.push_back(stroke);
  }
  if (!strokes.empty()) cut.addStrokes(strokes);
  const double afterStrokes = iou(cut.binaryMask(), truth);
  std::printf("tiger on coffee: IoU %.3f from the rectangle, %.3f after %zu strokes\n", fromRect, afterStrokes,
              strokes.size());
  EXPECT_GE(afterStrokes, 0.95);
}

// The cut-out's undo steps keep their masks run-length encoded (issue 35: 100 full-size copies of a 12-megapixel
// mask were 1.2 GB). A real outline (tuxpaint's tiger stamp, its alpha scaled to 4000 x 3000 and feathered as
// the cut-out does) comes back bit for bit and takes under 2% of its raw size; so do an empty mask, a mask of
// noise (the worst case: longer than raw, still exact) and a one-pixel one.
TEST(Cutout, UndoStepsKeepMasksPackedAndExact) {
  const std::string stampPath = "/usr/share/tuxpaint/stamps/animals/mammals/cats/tiger.png";
  if (!fs::exists(stampPath)) GTEST_SKIP() << "needs Debian's tuxpaint-stamps-default (" << stampPath << ")";
  const cv::Mat stamp = readImageRgba8(stampPath);
  cv::Mat alpha, big;
  cv::extractChannel(stamp, alpha, 3);
  cv::resize(alpha, big, cv::Size(4000, 3000), 0, 0, cv::INTER_LINEAR);
  const auto t0 = std::chrono::steady_clock::now();
  const cv::Mat mask = featherMask(big >= 128, CutoutOptions{}.featherPx);
  const auto t1 = std::chrono::steady_clock::now();
  const PackedMask packed(mask);
  const auto t2 = std::chrono::steady_clock::now();
  const cv::Mat unpacked = packed.unpack();
  const auto t3 = std::chrono::steady_clock::now();
  auto ms = [](auto a, auto b) { return std::chrono::duration<double, std::milli>(b - a).count(); };
  std::printf("12 MP: feather %.0f ms (the editor makes it on GrabCut's thread), pack %.0f ms, unpack %.0f ms\n",
              ms(t0, t1), ms(t1, t2), ms(t2, t3));
  EXPECT_EQ(cv::norm(unpacked, mask, cv::NORM_INF), 0);
  std::printf("12 MP feathered mask: %zu bytes packed (%.2f%% of %zu)\n", packed.bytes(),
              100.0 * double(packed.bytes()) / double(mask.total()), mask.total());
  EXPECT_LT(packed.bytes(), mask.total() / 50);
  EXPECT_TRUE(PackedMask(cv::Mat()).unpack().empty());
  cv::Mat noise(97, 131, CV_8UC1);
  cv::randu(noise, 0, 256);
  EXPECT_EQ(cv::norm(PackedMask(noise).unpack(), noise, cv::NORM_INF), 0);
  const cv::Mat one(1, 1, CV_8UC1, cv::Scalar(7));
  EXPECT_EQ(PackedMask(one).unpack().at<uchar>(0, 0), 7);
  EXPECT_THROW(PackedMask(cv::Mat(4, 4, CV_32F)), Error);
}
