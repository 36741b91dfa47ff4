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
// The distance map of a loaded photo (half floats) at row r, column c, and as a float map.
float distanceOf(const Photo& photo, int r, int c) {
  return photo.distance.depth() == CV_16F ? float(photo.distance.at<cv::float16_t>(r, c))
                                          : photo.distance.at<float>(r, c);
}
cv::Mat floatDistance(const Photo& photo) {
  cv::Mat out;
  photo.distance.convertTo(out, CV_32F);
  return out;
}

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
  // Compact: the file's 8 bits, one byte of alpha (issue 15: a 16384^2 photo took 10.8 GB as floats).
  ASSERT_EQ(photo.rgb.type(), CV_8UC3);
  ASSERT_EQ(photo.alpha.type(), CV_8UC1);
  EXPECT_EQ(photo.scale, 1.0);
  EXPECT_EQ(photo.alpha.at<uint8_t>(24, 32), 255);
  EXPECT_EQ(photo.alpha.at<uint8_t>(0, 0), 0);
  EXPECT_EQ(cv::countNonZero(photo.alpha > 0), cv::countNonZero(discImage().reshape(1, 48 * 64).col(3)));
  EXPECT_EQ(photo.bytes(), size_t(64 * 48) * (3 + 1 + 2));  // rgb, alpha, half-float distance
  // BGR in the file, RGB in memory: the disc is red.
  const Vec3f centre = photo.rgbAt(32.5, 24.5);
  EXPECT_FLOAT_EQ(centre[0], 1.0f);
  EXPECT_FLOAT_EQ(centre[1], 0.0f);
  EXPECT_FLOAT_EQ(centre[2], 0.0f);
  EXPECT_FLOAT_EQ(photo.alphaAt(32.5, 24.5), 1.0f);
  EXPECT_FLOAT_EQ(photo.alphaAt(0.5, 0.5), 0.0f);
  EXPECT_NEAR(photo.luvAt(32.5, 24.5)[0], 53.24f, 0.05f);
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
  ASSERT_EQ(photo.distance.type(), CV_16FC1);  // half floats: relative error below 2^-11
  cv::Mat alphaF;
  photo.alpha.convertTo(alphaF, CV_32F, 1.0 / 255);
  EXPECT_FLOAT_EQ(distanceOf(photo, 24, 32), 0.0f);
  EXPECT_FLOAT_EQ(photo.distanceAt(45.5, 24.5), 3.0f);
  EXPECT_FLOAT_EQ(distanceOf(photo, 24, 42), 0.0f);
  EXPECT_NEAR(distanceOf(photo, 24, 45), 3.0f, 1e-4);
  // Every pixel, against brute force.
  double worst = 0;
  for (int r = 0; r < photo.height; ++r)
    for (int c = 0; c < photo.width; ++c)
      worst = std::max(worst, double(std::abs(distanceOf(photo, r, c) - bruteDistance(alphaF, c, r))));
  EXPECT_LT(worst, 0.03);  // half floats: 2^-11 of up to 40 px
  // The corner is far from the disc: (0, 0) to the nearest disc pixel.
  EXPECT_NEAR(distanceOf(photo, 0, 0), bruteDistance(alphaF, 0, 0), 0.03);
  EXPECT_GT(distanceOf(photo, 0, 0), 25.0f);
}

TEST(Photo, SixteenBitPngKeepsPrecision) {
  const std::string dir = test::tempDir("photo");
  cv::Mat image(8, 10, CV_16UC3, cv::Scalar(1000, 30000, 65535));  // B, G, R
  const Photo photo = loadPhoto(write(dir, "deep.png", image));
  EXPECT_EQ(photo.rgb.type(), CV_16UC3);
  const Vec3f p = photo.rgbAt(4.5, 3.5);
  EXPECT_NEAR(p[0], 1.0f, 1e-6);
  EXPECT_NEAR(p[1], 30000 / 65535.0f, 1e-6);
  EXPECT_NEAR(p[2], 1000 / 65535.0f, 1e-6);  // distinguishable from any 8-bit level
  EXPECT_FALSE(photo.hasBackground);

  cv::Mat rgba(8, 10, CV_16UC4, cv::Scalar(0, 0, 65535, 65535));
  rgba(cv::Rect(0, 0, 5, 8)).setTo(cv::Scalar(0, 0, 0, 0));
  const Photo withAlpha = loadPhoto(write(dir, "deep_rgba.png", rgba));
  EXPECT_TRUE(withAlpha.hasBackground);
  EXPECT_EQ(withAlpha.alpha.at<uint8_t>(0, 0), 0);
  EXPECT_EQ(withAlpha.alpha.at<uint8_t>(0, 9), 255);
  EXPECT_NEAR(distanceOf(withAlpha, 0, 0), 5.0f, 1e-4);
}

TEST(Photo, GreyPngBecomesRgbWithoutBackground) {
  const std::string dir = test::tempDir("photo");
  cv::Mat grey(20, 30, CV_8UC1);
  for (int r = 0; r < grey.rows; ++r)
    for (int c = 0; c < grey.cols; ++c) grey.at<uint8_t>(r, c) = uint8_t(c * 8);
  const Photo photo = loadPhoto(write(dir, "grey.png", grey));
  EXPECT_EQ(photo.rgb.type(), CV_8UC3);
  const Vec3f p = photo.rgbAt(10.5, 5.5);
  EXPECT_FLOAT_EQ(p[0], 80 / 255.0f);
  EXPECT_FLOAT_EQ(p[1], 80 / 255.0f);
  EXPECT_FLOAT_EQ(p[2], 80 / 255.0f);
  EXPECT_FALSE(photo.hasBackground);
  // Without a background neither alpha nor distance is stored; the samplers answer for them.
  EXPECT_TRUE(photo.alpha.empty());
  EXPECT_TRUE(photo.distance.empty());
  EXPECT_EQ(photo.alphaAt(3, 3), 1.0f);
  EXPECT_EQ(photo.distanceAt(3, 3), 0.0f);
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
    const Vec3f p = photo.rgbAt(26.5, 18.5);
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
  EXPECT_NEAR(distanceOf(photo, 5, 5), 5.0f, 1e-4);
  EXPECT_NEAR(distanceOf(photo, 0, 5), std::hypot(5.0f, 5.0f), 4e-3);  // half float

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
  EXPECT_NE(message.find("not a PNG, JPEG, TIFF or BMP image"), std::string::npos) << message;
  message = errorOf([&] { readImageSize(text); });
  EXPECT_NE(message.find("not a PNG, JPEG, TIFF or BMP image"), std::string::npos) << message;

  const std::string photoPath = write(dir, "p.png", cv::Mat(4, 4, CV_8UC3, cv::Scalar(1, 2, 3)));
  message = errorOf([&] { loadPhoto(photoPath, missing); });
  EXPECT_NE(message.find(missing), std::string::npos) << message;

  message = errorOf([&] { loadPhoto(dir); });
  EXPECT_NE(message.find("is a folder, not a file"), std::string::npos) << message;
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

// Our L*a*b* (shift-map's working space) round-trips, and its 8-bit encoding agrees with OpenCV's
// RGB2Lab (the conversion it replaces) to within OpenCV's own table approximation (two levels).
TEST(Color, LabRoundTripsAndItsEightBitEncodingMatchesOpenCV) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0, 1);
  for (int i = 0; i < 2000; ++i) {
    const Vec3f rgb(u(rng), u(rng), u(rng));
    const Vec3f back = labToSrgb(srgbToLab(rgb));
    ASSERT_LT((back - rgb).cwiseAbs().maxCoeff(), 1e-4) << rgb.transpose() << " -> " << back.transpose();
  }
  EXPECT_NEAR(srgbToLab(Vec3f(1, 1, 1)).x(), 100, 1e-3);
  EXPECT_NEAR(srgbToLab(Vec3f(1, 1, 1)).tail<2>().norm(), 0, 1e-3);
  const Vec3f red = srgbToLab(Vec3f(1, 0, 0));  // the standard sRGB red: L 53.24, a 80.09, b 67.20
  EXPECT_NEAR(red.x(), 53.24, 0.02);
  EXPECT_NEAR(red.y(), 80.09, 0.05);
  EXPECT_NEAR(red.z(), 67.20, 0.05);

  cv::Mat rgb8(32, 32, CV_8UC3), rgb;
  cv::RNG(11).fill(rgb8, cv::RNG::UNIFORM, 0, 256);
  rgb8.convertTo(rgb, CV_32FC3, 1.0 / 255);
  const cv::Mat lab = srgbToLab8(rgb);
  cv::Mat reference;
  cv::cvtColor(rgb8, reference, cv::COLOR_RGB2Lab);
  ASSERT_EQ(lab.type(), CV_8UC3);
  cv::Mat diff;
  cv::absdiff(lab, reference, diff);
  double worst = 0;
  cv::minMaxLoc(diff.reshape(1), nullptr, &worst);
  EXPECT_LE(worst, 2.0);
  EXPECT_LT(cv::mean(diff.reshape(1))[0], 0.25);
  // Back to sRGB: within the 8-bit quantisation of L*a*b* (half a level of b* moves a saturated blue by
  // up to 0.05).
  const cv::Mat back = lab8ToSrgb(lab);
  ASSERT_EQ(back.type(), CV_32FC3);
  cv::absdiff(back, rgb, diff);
  cv::minMaxLoc(diff.reshape(1), nullptr, &worst);
  EXPECT_LT(worst, 0.06);
  EXPECT_LT(cv::mean(diff.reshape(1))[0], 0.01);
  EXPECT_THROW(srgbToLab8(rgb8), Error);
  EXPECT_THROW(lab8ToSrgb(rgb), Error);
}

// LuvTiles gives luvImage's samples and gradients bit for bit (8-bit and 16-bit photos, points across
// tile borders, outside the photo and NaN), converting only the tiles read.
TEST(Color, LuvTilesSampleAsTheWholeImageAndMakeOnlyTheTilesRead) {
  for (const int depth : {CV_8U, CV_16U}) {
    Photo photo;
    photo.width = 300, photo.height = 200;  // file pixels; stored at 150 x 100 (scale 0.5)
    photo.scale = 0.5;
    photo.rgb = cv::Mat(100, 150, CV_MAKETYPE(depth, 3));
    cv::randu(photo.rgb, 0, depth == CV_8U ? 256 : 65536);
    const cv::Mat whole = luvImage(photo);
    const LuvTiles tiles(photo);
    EXPECT_EQ(tiles.tilesMade(), 0);
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> x(-3, 40), y(-3, 40);  // the top-left corner's tiles, and beyond
    for (int i = 0; i < 2000; ++i) {
      const double px = x(rng), py = y(rng);
      const Vec3f want = sampleBilinear3(whole, px, py), got = tiles.sample(px, py);
      ASSERT_EQ(got, want) << px << ", " << py;
      Vec3f dx, dy, wx, wy;
      tiles.gradient(px, py, dx, dy);
      sampleGradient3(whole, px, py, wx, wy);
      ASSERT_EQ(dx, wx) << px << ", " << py;
      ASSERT_EQ(dy, wy) << px << ", " << py;
    }
    EXPECT_EQ(tiles.sample(std::nan(""), 7), sampleBilinear3(whole, std::nan(""), 7));
    EXPECT_EQ(tiles.sample(1e6, 1e6), sampleBilinear3(whole, 1e6, 1e6));  // the last tile, clamped
    EXPECT_EQ(tiles.tiles(), 5 * 4);
    EXPECT_EQ(tiles.tilesMade(), 4 + 1);  // the 2 x 2 tiles the points cover, and the corner
  }
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
    for (int k = 0; k < 100; ++k) {
      const Vec3f luv = photo.luvAt(k * 6.1, k * 6.0);
      EXPECT_GE(luv.minCoeff(), -200);
      EXPECT_LE(luv.maxCoeff(), 200);
    }
    cv::Scalar mean = cv::mean(photo.rgb);
    EXPECT_GT(mean[0], 0.05 * 255);  // not a black image
  }
}

namespace {

bool sameMat(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return false;
  if (a.depth() != CV_16F) return cv::norm(a, b, cv::NORM_INF) == 0;
  cv::Mat fa, fb;  // cv::norm has no half floats
  a.convertTo(fa, CV_32F);
  b.convertTo(fb, CV_32F);
  return cv::norm(fa, fb, cv::NORM_INF) == 0;
}

Photo loadMirrored(const std::string& path, const std::string& mask) {
  PhotoLoadOptions options;
  options.mirror = true;
  return loadPhoto(path, mask, options);
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
    const Photo mirrored = loadMirrored(photoPath, withMask ? maskPath : "");
    const Photo copy = loadPhoto(copyPath, withMask ? copyMaskPath : "");
    EXPECT_TRUE(mirrored.mirrored);
    EXPECT_FALSE(copy.mirrored);
    EXPECT_EQ(mirrored.width, 60);
    EXPECT_TRUE(sameMat(mirrored.rgb, copy.rgb)) << "mask " << withMask;
    EXPECT_TRUE(sameMat(mirrored.alpha, copy.alpha)) << "mask " << withMask;
    EXPECT_TRUE(sameMat(mirrored.distance, copy.distance)) << "mask " << withMask;
  }
  // And it really is mirrored: the pixel at column c is the file's column 59 - c.
  const Photo plain = loadPhoto(photoPath, maskPath), mirrored = loadMirrored(photoPath, maskPath);
  EXPECT_FALSE(plain.mirrored);
  ASSERT_EQ(mirrored.rgb.type(), CV_8UC3);  // compact: the file's depth
  for (int c : {0, 7, 59})
    EXPECT_EQ(mirrored.rgb.at<cv::Vec3b>(3, c), plain.rgb.at<cv::Vec3b>(3, 59 - c)) << "column " << c;
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
  ASSERT_EQ(fromLabels.alpha.type(), CV_8UC1);  // compact: 8-bit alpha
  EXPECT_EQ(fromLabels.alpha.at<uchar>(3, 3), 255);
  EXPECT_EQ(fromLabels.alpha.at<uchar>(0, 0), 0);
  EXPECT_EQ(fromLabels.alphaAt(3.5, 3.5), 1.0f);
  // A feathered mask: partial alpha on its edge, the same foreground as its binary version.
  cv::Mat feathered = cv::Mat::zeros(10, 10, CV_8UC1);
  feathered(cv::Rect(2, 2, 5, 5)).setTo(255);
  feathered.at<uchar>(2, 2) = 51;
  const Photo fromFeathered = loadPhoto(photoPath, write(dir, "feathered.png", feathered));
  EXPECT_EQ(fromFeathered.alpha.at<uchar>(2, 2), 51);
  EXPECT_NEAR(fromFeathered.alphaAt(2.5, 2.5), 0.2f, 1e-6);
  EXPECT_EQ(fromFeathered.alpha.at<uchar>(4, 4), 255);
  // A 16-bit mask with a faint largest value: alpha relative to it, and a tiny value stays foreground.
  cv::Mat faint = cv::Mat::zeros(10, 10, CV_16UC1);
  faint(cv::Rect(2, 2, 5, 5)).setTo(1000);
  faint.at<uint16_t>(2, 2) = 1;
  const Photo fromFaint = loadPhoto(photoPath, write(dir, "faint.png", faint));
  EXPECT_EQ(fromFaint.alpha.at<uchar>(4, 4), 255);
  EXPECT_EQ(fromFaint.alpha.at<uchar>(2, 2), 1);
  EXPECT_EQ(cv::countNonZero(fromFaint.alpha > 0), cv::countNonZero(fromLabels.alpha > 0));
  EXPECT_EQ(cv::countNonZero(fromFeathered.alpha > 0), cv::countNonZero(fromLabels.alpha > 0));
  EXPECT_TRUE(sameMat(fromFeathered.distance, fromLabels.distance));
}

// The test: a photo mirrored by its flag maps the same as a pre-mirrored copy of the file. The demo's
// photo 1 (tiger_right.png, with its mask) is the pre-mirrored copy of photo 0's file (scripts/make_demo.py):
// photo 1 given as photo 0's file and mask with the mirror flag must map exactly as the demo does, with the
// same points. And the flag is not inert: the same file without it maps otherwise.
TEST(Photo, AMirroredPhotoMapsLikeAPreMirroredCopy) {
  const Project demo = loadProject(test::assetsDir() + "/demo/project.json");
  ASSERT_EQ(demo.photos.size(), 2u);
  Project flagged = demo, unflagged = demo;
  flagged.photos[1] = unflagged.photos[1] = demo.photos[0];
  flagged.photos[1].mirror = true;
  const auto copyScene = loadScene(demo);
  // The random line searches of each cell are seeded by the cell's content, which names the photo by its
  // key (photoContentKey: the file's bytes and the mirror flag; mapping/cells.cpp): the two scenes use the
  // same keys, so that any difference comes from the pixels.
  auto flaggedScene = std::make_shared<Scene>(*loadScene(flagged));
  ASSERT_NE(flaggedScene->photoKeys[1], copyScene->photoKeys[1]);
  flaggedScene->photoKeys = copyScene->photoKeys;
  ASSERT_TRUE(sameMat(flaggedScene->photos[1]->rgb, copyScene->photos[1]->rgb)) << "tiger_right is not the mirror";
  ASSERT_TRUE(sameMat(flaggedScene->photos[1]->alpha, copyScene->photos[1]->alpha));
  ASSERT_TRUE(sameMat(flaggedScene->photos[1]->distance, copyScene->photos[1]->distance));

  const Mapping byFlag = mapTexture(*flaggedScene), byCopy = mapTexture(*copyScene);
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
  auto unflaggedScene = std::make_shared<Scene>(*loadScene(unflagged));
  unflaggedScene->photoKeys = copyScene->photoKeys;
  const Mapping withoutFlag = mapTexture(*unflaggedScene);
  // Another partition may have another number of faces: those beyond the common range count as moved.
  const size_t common = std::min(byFlag.map.facePhoto.size(), withoutFlag.map.facePhoto.size());
  int moved = int(std::max(byFlag.map.facePhoto.size(), withoutFlag.map.facePhoto.size()) - common);
  for (size_t f = 0; f < common; ++f)
    moved += withoutFlag.map.facePhoto[f] != byFlag.map.facePhoto[f] ||
             (byFlag.map.facePhoto[f] >= 0 && (withoutFlag.map.cornerUV[f][0] - byFlag.map.cornerUV[f][0]).norm() > 1);
  EXPECT_GT(moved, 100) << "without the flag, photo 1's points fall elsewhere in the file";
}

// ---- Memory and working resolution (issue 15) ----

TEST(Photo, WorkingResolutionKeepsFileCoordinates) {
  // A 400x300 photo with a foreground rectangle, kept at 100x75: the samplers still take file pixels.
  const std::string dir = test::tempDir("photo_working");
  cv::Mat image(300, 400, CV_8UC4, cv::Scalar(0, 0, 0, 0));
  image(cv::Rect(100, 60, 200, 120)).setTo(cv::Scalar(0, 200, 50, 255));  // B, G, R, A
  const std::string path = write(dir, "big.png", image);
  const Photo full = loadPhoto(path);
  PhotoLoadOptions options;
  options.maxSide = 100;
  const Photo small = loadPhoto(path, "", options);
  EXPECT_EQ(small.width, 400);
  EXPECT_EQ(small.height, 300);
  EXPECT_EQ(small.rgb.size(), cv::Size(100, 75));
  EXPECT_DOUBLE_EQ(small.scale, 0.25);
  EXPECT_LT(small.bytes() * 15, full.bytes());
  // The same answers at file coordinates, up to a stored pixel (4 file pixels).
  EXPECT_TRUE(small.isForeground(200, 120));
  EXPECT_FALSE(small.isForeground(20, 20));
  EXPECT_NEAR(small.rgbAt(200, 120)[0], 50 / 255.0f, 1e-6);
  EXPECT_NEAR(small.rgbAt(200, 120)[1], 200 / 255.0f, 1e-6);
  for (const Vec2 q : {Vec2(10, 10), Vec2(50, 150), Vec2(390, 290), Vec2(200, 20)})
    EXPECT_NEAR(small.distanceAt(q.x(), q.y()), full.distanceAt(q.x(), q.y()), 4.0) << q.transpose();
  EXPECT_GT(small.distanceAt(10, 10), 50);  // in file pixels, not stored ones
  // A working resolution above the photo's size changes nothing.
  options.maxSide = 1000;
  EXPECT_EQ(loadPhoto(path, "", options).rgb.size(), cv::Size(400, 300));
}

TEST(Photo, InfoStatsMatchTheLoadedPhoto) {
  const std::string dir = test::tempDir("photo_stats");
  const std::string path = write(dir, "disc.png", discImage());
  const PhotoStats stats = photoStats(path);
  const Photo photo = loadPhoto(path);
  EXPECT_EQ(stats.width, 64);
  EXPECT_EQ(stats.height, 48);
  EXPECT_EQ(stats.channels, 4);
  EXPECT_EQ(stats.bitsPerChannel, 8);
  EXPECT_TRUE(stats.hasBackground);
  EXPECT_NEAR(stats.foreground, cv::countNonZero(photo.alpha) / double(64 * 48), 1e-12);
  double maxDistance = 0;
  cv::minMaxLoc(floatDistance(photo), nullptr, &maxDistance);
  EXPECT_NEAR(stats.maxDistance, maxDistance, maxDistance / 1024);  // the photo keeps half floats
}

TEST(Photo, InfoStatsOfALargePhotoAreWithinTheirStatedError) {
  // Above 4096 pixels a side the distance is measured on a coarse mask: the answer must stay within
  // the stated bound of the exact one (from the loaded photo's full-resolution distance map).
  const std::string dir = test::tempDir("photo_stats_large");
  cv::Mat rgba(300, 4500, CV_8UC4, cv::Scalar(0, 0, 0, 0));
  cv::circle(rgba, cv::Point(4301, 37), 5, cv::Scalar(20, 40, 60, 255), cv::FILLED);
  rgba.at<cv::Vec4b>(250, 3) = cv::Vec4b(1, 2, 3, 255);  // one lone pixel at an odd position
  const std::string path = write(dir, "wide.png", rgba);
  const PhotoStats stats = photoStats(path);
  EXPECT_EQ(stats.width, 4500);
  EXPECT_EQ(stats.distanceScale, 2);
  EXPECT_GT(stats.maxDistanceError, 0);
  EXPECT_LE(stats.maxDistanceError, 3);
  const Photo photo = loadPhoto(path);
  double exact = 0;
  cv::minMaxLoc(floatDistance(photo), nullptr, &exact);
  EXPECT_GT(exact, 1000);
  EXPECT_NEAR(stats.maxDistance, exact, stats.maxDistanceError);
  EXPECT_NEAR(stats.foreground, cv::countNonZero(photo.alpha) / (4500.0 * 300), 1e-12);
}

TEST(Photo, SoftAlphaBelowOneLevelStaysForeground) {
  // 16-bit alpha of 100 (of 65535) and float-like levels must not round to background.
  const std::string dir = test::tempDir("photo_soft");
  cv::Mat rgba(4, 4, CV_16UC4, cv::Scalar(1000, 1000, 1000, 0));
  rgba.at<cv::Vec4w>(1, 1) = cv::Vec4w(1000, 1000, 1000, 100);
  const Photo photo = loadPhoto(write(dir, "soft.png", rgba));
  EXPECT_TRUE(photo.hasBackground);
  EXPECT_TRUE(photo.isForeground(1.5, 1.5));
  EXPECT_FALSE(photo.isForeground(2.5, 2.5));
}

TEST(Photo, OnlyKnownFormatsAreDecoded) {
  // OpenCV picks a decoder by content: a PNM (or WebP, JPEG 2000...) named .png would be decoded.
  const std::string dir = test::tempDir("photo_formats");
  const std::string path = (fs::path(dir) / "fake.png").string();
  std::ofstream(path, std::ios::binary) << "P5\n2 2\n255\n\x01\x02\x03\x04";
  const std::string message = errorOf([&] { loadPhoto(path); });
  EXPECT_NE(message.find("not a PNG, JPEG, TIFF or BMP image"), std::string::npos) << message;
  // A PNG header announcing 20000 x 20000 is refused before anything is allocated.
  std::string png = "\x89PNG\r\n\x1a\n";
  png += std::string("\0\0\0\x0dIHDR", 8);
  png += std::string("\0\0\x4e\x20\0\0\x4e\x20\x08\x06\0\0\0", 13);
  png += std::string(4, '\0');
  const std::string huge = (fs::path(dir) / "huge.png").string();
  std::ofstream(huge, std::ios::binary) << png;
  EXPECT_NE(errorOf([&] { loadPhoto(huge); }).find("20000x20000 pixels; at most 16384"), std::string::npos);
  const std::string fromMemory =
      errorOf([&] { decodeImageRgba8(reinterpret_cast<const unsigned char*>(png.data()), png.size(), "mem"); });
  EXPECT_NE(fromMemory.find("mem: image is 20000x20000 pixels"), std::string::npos) << fromMemory;
}
