// Tests of core/photo and core/color: loading every supported format and layout, the foreground and
// distance maps, the error messages, bilinear sampling and the L*u*v* conversion.
#include "image/photo.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>

#include "image/color.h"
#include "io/project.h"
#include "pipeline.h"
#include "test_support.h"

namespace fs = std::filesystem;
using namespace montage;

namespace {

std::string write(const std::string& dir, const std::string& name, const cv::Mat& image) {
  const std::string path = (fs::path(dir) / name).string();
  if (!cv::imwrite(path, image)) throw std::runtime_error("cv::imwrite failed for " + path);
  return path;
}

using montage::test::errorOf;

// A 64x48 BGRA image: transparent black background, opaque red disc of radius 10 around pixel (32, 24).
cv::Mat discImage() {
  cv::Mat image(48, 64, CV_8UC4, cv::Scalar(0, 0, 0, 0));
  for (int r = 0; r < image.rows; ++r)
    for (int c = 0; c < image.cols; ++c)
      if ((c - 32) * (c - 32) + (r - 24) * (r - 24) <= 100) image.at<cv::Vec4b>(r, c) = cv::Vec4b(0, 0, 255, 255);
  return image;
}

// Brute-force distance from pixel (c, r) to the nearest pixel with non-zero alpha.
float bruteDistance(const cv::Mat& alpha, int c, int r) {
  double best = 1e30;
  for (int rr = 0; rr < alpha.rows; ++rr)
    for (int cc = 0; cc < alpha.cols; ++cc)
      if (alpha.at<float>(rr, cc) > 0) best = std::min(best, std::hypot(double(cc - c), double(rr - r)));
  return float(best);
}

// A float image whose channels are linear functions of the pixel centre (x, y):
// ch0 = 2x + 3y, ch1 = x - y, ch2 = 7.
cv::Mat rampImage(int width, int height) {
  cv::Mat image(height, width, CV_32FC3);
  for (int r = 0; r < height; ++r)
    for (int c = 0; c < width; ++c) {
      const float x = c + 0.5f, y = r + 0.5f;
      image.at<cv::Vec3f>(r, c) = cv::Vec3f(2 * x + 3 * y, x - y, 7);
    }
  return image;
}

}  // namespace

// ---- Loading ----

TEST(Photo, RgbaDiscGivesAlphaForegroundAndChannelOrder) {
  const std::string dir = test::tempDir("photo");
  const Photo photo = loadPhoto(write(dir, "disc.png", discImage()));
  EXPECT_EQ(photo.width, 64);
  EXPECT_EQ(photo.height, 48);
  EXPECT_TRUE(photo.hasBackground);
  EXPECT_TRUE(photo.maskPath.empty());
  ASSERT_EQ(photo.rgb.type(), CV_32FC3);
  ASSERT_EQ(photo.alpha.type(), CV_32FC1);
  ASSERT_EQ(photo.luv.type(), CV_32FC3);
  EXPECT_FLOAT_EQ(photo.alpha.at<float>(24, 32), 1.0f);
  EXPECT_FLOAT_EQ(photo.alpha.at<float>(0, 0), 0.0f);
  EXPECT_EQ(cv::countNonZero(photo.alpha > 0), cv::countNonZero(discImage().reshape(1, 48 * 64).col(3)));
  // BGR in the file, RGB in memory: the disc is red.
  const cv::Vec3f centre = photo.rgb.at<cv::Vec3f>(24, 32);
  EXPECT_FLOAT_EQ(centre[0], 1.0f);
  EXPECT_FLOAT_EQ(centre[1], 0.0f);
  EXPECT_FLOAT_EQ(centre[2], 0.0f);
  EXPECT_NEAR(photo.luv.at<cv::Vec3f>(24, 32)[0], 53.24f, 0.05f);
  // isForeground goes by the pixel containing the point.
  EXPECT_TRUE(photo.isForeground(32.5, 24.5));
  EXPECT_TRUE(photo.isForeground(32.99, 24.01));
  EXPECT_FALSE(photo.isForeground(0.5, 0.5));
  EXPECT_TRUE(photo.isForeground(42.5, 24.5));   // pixel (42, 24) is 10 px right of (32, 24): on the disc
  EXPECT_FALSE(photo.isForeground(43.0, 24.5));  // pixel (43, 24) is not
  EXPECT_FALSE(photo.isForeground(-1, 24.5));
  EXPECT_FALSE(photo.isForeground(64, 48));  // on the corner: pixel (63, 47), background
}

TEST(Photo, DistanceMapMatchesBruteForce) {
  const std::string dir = test::tempDir("photo");
  const Photo photo = loadPhoto(write(dir, "disc.png", discImage()));
  ASSERT_EQ(photo.distance.type(), CV_32FC1);
  EXPECT_FLOAT_EQ(photo.distance.at<float>(24, 32), 0.0f);
  EXPECT_FLOAT_EQ(photo.distance.at<float>(24, 42), 0.0f);
  EXPECT_NEAR(photo.distance.at<float>(24, 45), 3.0f, 1e-4);
  // Every pixel, against brute force.
  double worst = 0;
  for (int r = 0; r < photo.height; ++r)
    for (int c = 0; c < photo.width; ++c)
      worst = std::max(worst, double(std::abs(photo.distance.at<float>(r, c) - bruteDistance(photo.alpha, c, r))));
  EXPECT_LT(worst, 1e-3);
  // The corner is far from the disc: (0, 0) to the nearest disc pixel.
  EXPECT_NEAR(photo.distance.at<float>(0, 0), bruteDistance(photo.alpha, 0, 0), 1e-3);
  EXPECT_GT(photo.distance.at<float>(0, 0), 25.0f);
}

TEST(Photo, SixteenBitPngKeepsPrecision) {
  const std::string dir = test::tempDir("photo");
  cv::Mat image(8, 10, CV_16UC3, cv::Scalar(1000, 30000, 65535));  // B, G, R
  const Photo photo = loadPhoto(write(dir, "deep.png", image));
  const cv::Vec3f p = photo.rgb.at<cv::Vec3f>(3, 4);
  EXPECT_NEAR(p[0], 1.0f, 1e-6);
  EXPECT_NEAR(p[1], 30000 / 65535.0f, 1e-6);
  EXPECT_NEAR(p[2], 1000 / 65535.0f, 1e-6);  // distinguishable from any 8-bit level
  EXPECT_FALSE(photo.hasBackground);

  cv::Mat rgba(8, 10, CV_16UC4, cv::Scalar(0, 0, 65535, 65535));
  rgba(cv::Rect(0, 0, 5, 8)).setTo(cv::Scalar(0, 0, 0, 0));
  const Photo withAlpha = loadPhoto(write(dir, "deep_rgba.png", rgba));
  EXPECT_TRUE(withAlpha.hasBackground);
  EXPECT_FLOAT_EQ(withAlpha.alpha.at<float>(0, 0), 0.0f);
  EXPECT_FLOAT_EQ(withAlpha.alpha.at<float>(0, 9), 1.0f);
  EXPECT_NEAR(withAlpha.distance.at<float>(0, 0), 5.0f, 1e-4);
}

TEST(Photo, GreyPngBecomesRgbWithoutBackground) {
  const std::string dir = test::tempDir("photo");
  cv::Mat grey(20, 30, CV_8UC1);
  for (int r = 0; r < grey.rows; ++r)
    for (int c = 0; c < grey.cols; ++c) grey.at<uint8_t>(r, c) = uint8_t(c * 8);
  const Photo photo = loadPhoto(write(dir, "grey.png", grey));
  EXPECT_EQ(photo.rgb.type(), CV_32FC3);
  const cv::Vec3f p = photo.rgb.at<cv::Vec3f>(5, 10);
  EXPECT_FLOAT_EQ(p[0], 80 / 255.0f);
  EXPECT_FLOAT_EQ(p[1], 80 / 255.0f);
  EXPECT_FLOAT_EQ(p[2], 80 / 255.0f);
  EXPECT_FALSE(photo.hasBackground);
  EXPECT_EQ(cv::countNonZero(photo.alpha == 1.0f), 20 * 30);
  EXPECT_EQ(cv::countNonZero(photo.distance), 0);
  EXPECT_TRUE(photo.isForeground(0, 0));
  EXPECT_TRUE(photo.isForeground(30, 20));
}

TEST(Photo, JpgBmpAndTiffLoadWithTheirSizes) {
  const std::string dir = test::tempDir("photo");
  cv::Mat image(37, 53, CV_8UC3, cv::Scalar(40, 120, 200));  // B, G, R
  std::vector<std::string> files = {write(dir, "a.jpg", image), write(dir, "a.bmp", image)};
  if (cv::haveImageWriter("a.tiff"))
    files.push_back(write(dir, "a.tiff", image));
  else
    std::fprintf(stderr, "note: this OpenCV cannot write TIFF; TIFF not tested\n");
  for (const std::string& file : files) {
    SCOPED_TRACE(file);
    const Photo photo = loadPhoto(file);
    EXPECT_EQ(photo.width, 53);
    EXPECT_EQ(photo.height, 37);
    EXPECT_EQ(readImageSize(file), cv::Size(53, 37));
    const cv::Vec3f p = photo.rgb.at<cv::Vec3f>(18, 26);
    const float tolerance = fs::path(file).extension() == ".jpg" ? 0.02f : 1e-6f;  // JPEG is lossy
    EXPECT_NEAR(p[0], 200 / 255.0f, tolerance);
    EXPECT_NEAR(p[1], 120 / 255.0f, tolerance);
    EXPECT_NEAR(p[2], 40 / 255.0f, tolerance);
    EXPECT_FALSE(photo.hasBackground);
  }
}

TEST(Photo, ReadImageSizeParsesHeaders) {
  const std::string dir = test::tempDir("photo");
  const cv::Mat image(123, 457, CV_8UC3, cv::Scalar(1, 2, 3));
  for (const char* name : {"s.png", "s.jpg", "s.bmp"})
    EXPECT_EQ(readImageSize(write(dir, name, image)), cv::Size(457, 123)) << name;
  const cv::Mat grey(9, 1000, CV_16UC1, cv::Scalar(7));
  EXPECT_EQ(readImageSize(write(dir, "g.png", grey)), cv::Size(1000, 9));
  EXPECT_EQ(readImageSize(write(dir, "g.bmp", cv::Mat(9, 1000, CV_8UC1, cv::Scalar(3)))), cv::Size(1000, 9));
  // A progressive JPEG has a SOF2 frame header.
  const std::string progressive = (fs::path(dir) / "p.jpg").string();
  ASSERT_TRUE(cv::imwrite(progressive, image, {cv::IMWRITE_JPEG_PROGRESSIVE, 1}));
  EXPECT_EQ(readImageSize(progressive), cv::Size(457, 123));
}

TEST(Photo, MaskFileGivesForeground) {
  const std::string dir = test::tempDir("photo");
  const std::string photoPath = write(dir, "p.png", cv::Mat(30, 40, CV_8UC3, cv::Scalar(255, 255, 255)));
  cv::Mat mask(30, 40, CV_8UC1, cv::Scalar(0));
  mask(cv::Rect(10, 5, 20, 10)).setTo(17);  // any non-zero value is foreground
  const std::string maskPath = write(dir, "m.png", mask);
  const Photo photo = loadPhoto(photoPath, maskPath);
  EXPECT_EQ(photo.maskPath, maskPath);
  EXPECT_TRUE(photo.hasBackground);
  EXPECT_EQ(cv::countNonZero(photo.alpha > 0), 200);
  EXPECT_TRUE(photo.isForeground(10.5, 5.5));
  EXPECT_FALSE(photo.isForeground(9.5, 5.5));
  EXPECT_NEAR(photo.distance.at<float>(5, 5), 5.0f, 1e-4);
  EXPECT_NEAR(photo.distance.at<float>(0, 5), std::hypot(5.0f, 5.0f), 1e-4);

  // A colour mask with alpha: foreground where a colour channel is non-zero and alpha is non-zero.
  cv::Mat rgbaMask(30, 40, CV_8UC4, cv::Scalar(0, 0, 0, 255));
  rgbaMask(cv::Rect(0, 0, 10, 30)).setTo(cv::Scalar(0, 255, 0, 255));
  rgbaMask(cv::Rect(0, 0, 10, 10)).setTo(cv::Scalar(0, 255, 0, 0));
  const Photo fromRgba = loadPhoto(photoPath, write(dir, "m4.png", rgbaMask));
  EXPECT_EQ(cv::countNonZero(fromRgba.alpha > 0), 200);
  EXPECT_TRUE(fromRgba.isForeground(5, 15));
  EXPECT_FALSE(fromRgba.isForeground(5, 5));
  EXPECT_FALSE(fromRgba.isForeground(15, 15));
}

TEST(Photo, MaskOfAnotherSizeIsRejected) {
  const std::string dir = test::tempDir("photo");
  const std::string photoPath = write(dir, "p.png", cv::Mat(48, 64, CV_8UC3, cv::Scalar(9, 9, 9)));
  const std::string maskPath = write(dir, "m.png", cv::Mat(30, 40, CV_8UC1, cv::Scalar(255)));
  const std::string message = errorOf([&] { loadPhoto(photoPath, maskPath); });
  EXPECT_NE(message.find(photoPath), std::string::npos) << message;
  EXPECT_NE(message.find(maskPath), std::string::npos) << message;
  EXPECT_NE(message.find("40x30"), std::string::npos) << message;
  EXPECT_NE(message.find("64x48"), std::string::npos) << message;
}

TEST(Photo, LoadErrorsNameTheFileAndReason) {
  const std::string dir = test::tempDir("photo");
  const std::string missing = (fs::path(dir) / "nothere.png").string();
  std::string message = errorOf([&] { loadPhoto(missing); });
  EXPECT_NE(message.find(missing), std::string::npos) << message;
  EXPECT_NE(message.find("not found"), std::string::npos) << message;
  message = errorOf([&] { readImageSize(missing); });
  EXPECT_NE(message.find(missing), std::string::npos) << message;

  const std::string text = (fs::path(dir) / "notes.png").string();
  std::ofstream(text) << "this is not a picture\n";
  message = errorOf([&] { loadPhoto(text); });
  EXPECT_NE(message.find(text), std::string::npos) << message;
  EXPECT_NE(message.find("not a readable image"), std::string::npos) << message;
  message = errorOf([&] { readImageSize(text); });
  EXPECT_NE(message.find("not a readable image"), std::string::npos) << message;

  const std::string photoPath = write(dir, "p.png", cv::Mat(4, 4, CV_8UC3, cv::Scalar(1, 2, 3)));
  message = errorOf([&] { loadPhoto(photoPath, missing); });
  EXPECT_NE(message.find(missing), std::string::npos) << message;

  message = errorOf([&] { loadPhoto(dir); });
  EXPECT_NE(message.find("not a regular file"), std::string::npos) << message;
}

TEST(Photo, AllBackgroundIsRejected) {
  const std::string dir = test::tempDir("photo");
  const std::string clear = write(dir, "clear.png", cv::Mat(10, 10, CV_8UC4, cv::Scalar(50, 60, 70, 0)));
  std::string message = errorOf([&] { loadPhoto(clear); });
  EXPECT_NE(message.find("no foreground pixel"), std::string::npos) << message;
  EXPECT_NE(message.find(clear), std::string::npos) << message;

  const std::string photoPath = write(dir, "p.png", cv::Mat(10, 10, CV_8UC3, cv::Scalar(1, 2, 3)));
  const std::string black = write(dir, "black.png", cv::Mat(10, 10, CV_8UC1, cv::Scalar(0)));
  message = errorOf([&] { loadPhoto(photoPath, black); });
  EXPECT_NE(message.find("no foreground pixel"), std::string::npos) << message;
  EXPECT_NE(message.find(black), std::string::npos) << message;
}

TEST(Photo, OversizedImageIsRejected) {
  const std::string dir = test::tempDir("photo");
  const std::string wide = write(dir, "wide.png", cv::Mat(1, 16385, CV_8UC1, cv::Scalar(200)));
  EXPECT_EQ(readImageSize(wide), cv::Size(16385, 1));
  const std::string message = errorOf([&] { loadPhoto(wide); });
  EXPECT_NE(message.find(wide), std::string::npos) << message;
  EXPECT_NE(message.find("16384"), std::string::npos) << message;
  EXPECT_NO_THROW(loadPhoto(write(dir, "ok.png", cv::Mat(1, 16384, CV_8UC1, cv::Scalar(200)))));
}

// ---- Sampling ----

TEST(Sampling, BilinearIsExactOnALinearRamp) {
  const cv::Mat ramp = rampImage(40, 30);
  const Vec3f s = sampleBilinear3(ramp, 10.3, 7.8);
  EXPECT_NEAR(s.x(), 2 * 10.3 + 3 * 7.8, 1e-4);
  EXPECT_NEAR(s.y(), 10.3 - 7.8, 1e-4);
  EXPECT_NEAR(s.z(), 7.0, 1e-6);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> ux(0.5, 39.5), uy(0.5, 29.5);
  for (int i = 0; i < 200; ++i) {
    const double x = ux(rng), y = uy(rng);
    const Vec3f v = sampleBilinear3(ramp, x, y);
    ASSERT_NEAR(v.x(), 2 * x + 3 * y, 1e-4) << x << ", " << y;
    ASSERT_NEAR(v.y(), x - y, 1e-4) << x << ", " << y;
  }
  cv::Mat single;
  cv::extractChannel(ramp, single, 0);
  EXPECT_NEAR(sampleBilinear1(single, 10.3, 7.8), 2 * 10.3 + 3 * 7.8, 1e-4);
  EXPECT_NEAR(sampleBilinear1(ramp, 10.3, 7.8), 2 * 10.3 + 3 * 7.8, 1e-4);  // first channel
}

TEST(Sampling, PixelCentresAndBorderClamp) {
  cv::Mat image(3, 4, CV_32FC1);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) image.at<float>(r, c) = float(10 * r + c);
  EXPECT_FLOAT_EQ(sampleBilinear1(image, 2.5, 1.5), 12.0f);  // centre of pixel (2, 1)
  EXPECT_FLOAT_EQ(sampleBilinear1(image, 2.0, 1.5), 11.5f);  // edge between pixels 1 and 2
  EXPECT_FLOAT_EQ(sampleBilinear1(image, 0.0, 0.0), 0.0f);   // corner: clamped to pixel (0, 0)
  EXPECT_FLOAT_EQ(sampleBilinear1(image, 0.2, 0.5), 0.0f);
  EXPECT_FLOAT_EQ(sampleBilinear1(image, -5.0, -5.0), 0.0f);
  EXPECT_FLOAT_EQ(sampleBilinear1(image, 4.0, 3.0), 23.0f);  // far corner
  EXPECT_FLOAT_EQ(sampleBilinear1(image, 100.0, 1.5), 13.0f);
  EXPECT_FLOAT_EQ(sampleBilinear1(image, 3.5, 2.75), 23.0f);
}

TEST(Sampling, GradientOfRampIsItsSlope) {
  const cv::Mat ramp = rampImage(40, 30);
  Vec3f ddx, ddy;
  for (const auto& [x, y] : {std::pair{10.3, 7.8}, std::pair{1.0, 1.0}, std::pair{38.9, 28.9}, std::pair{20.0, 15.5}}) {
    sampleGradient3(ramp, x, y, ddx, ddy);
    EXPECT_NEAR(ddx.x(), 2, 1e-4);
    EXPECT_NEAR(ddy.x(), 3, 1e-4);
    EXPECT_NEAR(ddx.y(), 1, 1e-4);
    EXPECT_NEAR(ddy.y(), -1, 1e-4);
    EXPECT_NEAR(ddx.z(), 0, 1e-6);
    EXPECT_NEAR(ddy.z(), 0, 1e-6);
  }
}

// ---- Colour ----

TEST(Color, KnownLuvValues) {
  const Vec3f white = srgbToLuv(Vec3f(1, 1, 1));
  EXPECT_NEAR(white.x(), 100, 1e-3);
  EXPECT_NEAR(white.y(), 0, 1e-3);
  EXPECT_NEAR(white.z(), 0, 1e-3);
  const Vec3f red = srgbToLuv(Vec3f(1, 0, 0));
  EXPECT_NEAR(red.x(), 53.24, 0.05);
  EXPECT_NEAR(red.y(), 175.01, 0.05);
  EXPECT_NEAR(red.z(), 37.76, 0.05);
  const Vec3f black = srgbToLuv(Vec3f(0, 0, 0));
  EXPECT_EQ(black, Vec3f::Zero());
  EXPECT_EQ(luvToSrgb(Vec3f(0, 0, 0)), Vec3f::Zero());
  EXPECT_EQ(luvToSrgb(Vec3f(0, 20, -30)), Vec3f::Zero());  // L = 0 is black whatever u, v
  // Mid grey: linear 0.214041, L* = 116 * cbrt(0.214041) - 16.
  const Vec3f grey = srgbToLuv(Vec3f(0.5f, 0.5f, 0.5f));
  EXPECT_NEAR(grey.x(), 116 * std::cbrt(std::pow((0.5 + 0.055) / 1.055, 2.4)) - 16, 1e-3);
  EXPECT_NEAR(grey.x(), 53.39, 0.01);
  EXPECT_NEAR(grey.y(), 0, 1e-3);
  EXPECT_NEAR(grey.z(), 0, 1e-3);
  // Very dark colours use the linear part of L*(Y).
  EXPECT_NEAR(srgbToLuv(Vec3f(0.01f, 0.01f, 0.01f)).x(), 24389.0 / 27 * (0.01 / 12.92), 1e-3);
  EXPECT_NEAR(deltaEuv(Vec3f(1, 1, 1), Vec3f(0, 0, 0)), 100, 1e-3);
  EXPECT_NEAR(deltaEuv(Vec3f(1, 0, 0), Vec3f(1, 0, 0)), 0, 1e-6);
  EXPECT_NEAR(deltaEuv(Vec3f(1, 0, 0), Vec3f(1, 1, 1)), (red - white).norm(), 1e-3);
}

TEST(Color, RoundTripOnRandomColours) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0, 1);
  for (int i = 0; i < 2000; ++i) {
    const Vec3f rgb(u(rng), u(rng), u(rng));
    const Vec3f back = luvToSrgb(srgbToLuv(rgb));
    ASSERT_LT((back - rgb).cwiseAbs().maxCoeff(), 1e-4) << rgb.transpose() << " -> " << back.transpose();
  }
  for (const Vec3f& rgb : {Vec3f(0, 0, 1), Vec3f(0, 1, 0), Vec3f(1, 1, 0), Vec3f(0.001f, 0, 0), Vec3f(1, 1, 1)})
    EXPECT_LT((luvToSrgb(srgbToLuv(rgb)) - rgb).cwiseAbs().maxCoeff(), 1e-4) << rgb.transpose();
}

TEST(Color, ImageConversionMatchesPerPixel) {
  cv::Mat rgb(5, 7, CV_32FC3);
  cv::randu(rgb, 0.0f, 1.0f);
  const cv::Mat luv = srgbToLuv(rgb);
  ASSERT_EQ(luv.type(), CV_32FC3);
  ASSERT_EQ(luv.size(), rgb.size());
  for (int r = 0; r < rgb.rows; ++r)
    for (int c = 0; c < rgb.cols; ++c) {
      const cv::Vec3f p = rgb.at<cv::Vec3f>(r, c);
      const Vec3f expected = srgbToLuv(Vec3f(p[0], p[1], p[2]));
      const cv::Vec3f got = luv.at<cv::Vec3f>(r, c);
      EXPECT_FLOAT_EQ(got[0], expected.x());
      EXPECT_FLOAT_EQ(got[1], expected.y());
      EXPECT_FLOAT_EQ(got[2], expected.z());
    }
  EXPECT_THROW(srgbToLuv(cv::Mat(3, 3, CV_8UC3)), Error);
}

// ---- Real photos (shared data) ----

TEST(Photo, RealPhotosLoadWithTheirSizes) {
  TM_REQUIRE_SHARED(tiger, "photos/tiger/tiger_head.jpg");
  TM_REQUIRE_SHARED(zebra, "photos/zebra/zebra.jpg");
  for (const auto& [file, size] : {std::pair{tiger, cv::Size(610, 610)}, std::pair{zebra, cv::Size(960, 640)}}) {
    SCOPED_TRACE(file);
    EXPECT_EQ(readImageSize(file), size);
    const Photo photo = loadPhoto(file);
    EXPECT_EQ(photo.width, size.width);
    EXPECT_EQ(photo.height, size.height);
    EXPECT_EQ(photo.rgb.size(), size);
    EXPECT_FALSE(photo.hasBackground);
    double lo, hi;
    cv::minMaxLoc(photo.luv.reshape(1), &lo, &hi);
    EXPECT_GE(lo, -200);
    EXPECT_LE(hi, 200);
    cv::Scalar mean = cv::mean(photo.rgb);
    EXPECT_GT(mean[0], 0.05);  // not a black image
  }
}

namespace {

bool sameMat(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0;
}

}  // namespace

TEST(Photo, MirrorFlipsThePhotoAndItsMaskOnLoadLikeAMirroredCopy) {
  const std::string dir = test::tempDir("photo");
  // An asymmetric photo with alpha, and a mask (in the file's own pixels) that differs from the alpha.
  cv::Mat image(40, 60, CV_8UC4);
  cv::randu(image, cv::Scalar::all(0), cv::Scalar::all(255));
  image(cv::Rect(0, 0, 60, 40)).forEach<cv::Vec4b>([](cv::Vec4b& p, const int* at) { p[3] = at[1] < 35 ? 255 : 0; });
  cv::Mat mask = cv::Mat::zeros(40, 60, CV_8UC1);
  mask(cv::Rect(5, 5, 20, 30)).setTo(255);
  cv::Mat flippedImage, flippedMask;
  cv::flip(image, flippedImage, 1);
  cv::flip(mask, flippedMask, 1);
  const std::string photoPath = write(dir, "p.png", image), maskPath = write(dir, "m.png", mask);
  const std::string copyPath = write(dir, "p_mirrored.png", flippedImage);
  const std::string copyMaskPath = write(dir, "m_mirrored.png", flippedMask);

  for (const bool withMask : {false, true}) {
    const Photo mirrored = loadPhoto(photoPath, withMask ? maskPath : "", true);
    const Photo copy = loadPhoto(copyPath, withMask ? copyMaskPath : "");
    EXPECT_TRUE(mirrored.mirrored);
    EXPECT_FALSE(copy.mirrored);
    EXPECT_EQ(mirrored.width, 60);
    EXPECT_TRUE(sameMat(mirrored.rgb, copy.rgb)) << "mask " << withMask;
    EXPECT_TRUE(sameMat(mirrored.alpha, copy.alpha)) << "mask " << withMask;
    EXPECT_TRUE(sameMat(mirrored.distance, copy.distance)) << "mask " << withMask;
    EXPECT_TRUE(sameMat(mirrored.luv, copy.luv)) << "mask " << withMask;
  }
  // And it really is mirrored: the pixel at column c is the file's column 59 - c.
  const Photo plain = loadPhoto(photoPath, maskPath), mirrored = loadPhoto(photoPath, maskPath, true);
  EXPECT_FALSE(plain.mirrored);
  for (int c : {0, 7, 59})
    EXPECT_EQ(mirrored.rgb.at<cv::Vec3f>(3, c), plain.rgb.at<cv::Vec3f>(3, 59 - c)) << "column " << c;
  EXPECT_TRUE(plain.isForeground(6, 6));
  EXPECT_FALSE(mirrored.isForeground(6, 6));
  EXPECT_TRUE(mirrored.isForeground(60 - 6, 6));
}

TEST(Photo, MaskAlphaIsRelativeToTheMasksLargestValue) {
  const std::string dir = test::tempDir("photo");
  const std::string photoPath = write(dir, "p.png", cv::Mat(10, 10, CV_8UC3, cv::Scalar(40, 80, 120)));
  // A 0/1 label image: full alpha (not 1/255), so a label mask is not a faint one.
  cv::Mat labels = cv::Mat::zeros(10, 10, CV_8UC1);
  labels(cv::Rect(2, 2, 5, 5)).setTo(1);
  const Photo fromLabels = loadPhoto(photoPath, write(dir, "labels.png", labels));
  EXPECT_EQ(fromLabels.alpha.at<float>(3, 3), 1.0f);
  EXPECT_EQ(fromLabels.alpha.at<float>(0, 0), 0.0f);
  // A feathered mask: partial alpha on its edge, the same foreground as its binary version.
  cv::Mat feathered = cv::Mat::zeros(10, 10, CV_8UC1);
  feathered(cv::Rect(2, 2, 5, 5)).setTo(255);
  feathered.at<uchar>(2, 2) = 51;
  const Photo fromFeathered = loadPhoto(photoPath, write(dir, "feathered.png", feathered));
  EXPECT_NEAR(fromFeathered.alpha.at<float>(2, 2), 0.2f, 1e-6);
  EXPECT_EQ(fromFeathered.alpha.at<float>(4, 4), 1.0f);
  EXPECT_EQ(cv::countNonZero(fromFeathered.alpha > 0), cv::countNonZero(fromLabels.alpha > 0));
  EXPECT_TRUE(sameMat(fromFeathered.distance, fromLabels.distance));
}

// The test: a photo mirrored by its flag maps the same as a pre-mirrored copy of the file. On the
// demo: photo 1's file mirrored on disk (a side view taken "the wrong way round"), then loaded with the flag,
// against the demo's own photo 1, which is the pre-mirrored copy of that file; same points. And the flag is
// not inert: the same file without it maps otherwise.
TEST(Photo, AMirroredPhotoMapsLikeAPreMirroredCopy) {
  const std::string dir = test::tempDir("photo_mirror");
  const Project demo = loadProject(test::assetsDir() + "/demo/project.json");
  const cv::Mat file = cv::imread(demo.photos[1].path, cv::IMREAD_UNCHANGED);
  ASSERT_FALSE(file.empty()) << demo.photos[1].path;
  cv::Mat flipped;
  cv::flip(file, flipped, 1);
  const std::string flippedPath = write(dir, "photo_1_flipped.png", flipped);
  Project flagged = demo, unflagged = demo;
  flagged.photos[1].path = unflagged.photos[1].path = flippedPath;
  flagged.photos[1].mirror = true;

  const Mapping byFlag = mapTexture(*loadScene(flagged)), byCopy = mapTexture(*loadScene(demo));
  ASSERT_EQ(byFlag.map.facePhoto.size(), byCopy.map.facePhoto.size());
  EXPECT_EQ(byFlag.map.facePhoto, byCopy.map.facePhoto);
  double largest = 0;
  int inPhoto1 = 0;
  for (size_t f = 0; f < byFlag.map.facePhoto.size(); ++f) {
    for (int k = 0; k < 3; ++k)
      largest = std::max(largest, (byFlag.map.cornerUV[f][k] - byCopy.map.cornerUV[f][k]).norm());
    if (byFlag.map.facePhoto[f] == 1) ++inPhoto1;
  }
  EXPECT_EQ(largest, 0.0) << "the two mappings differ by up to " << largest << " px";
  EXPECT_GT(inPhoto1, 100) << "photo 1 textures part of the mesh";
  const Mapping withoutFlag = mapTexture(*loadScene(unflagged));
  EXPECT_NE(withoutFlag.map.facePhoto, byFlag.map.facePhoto);
}
