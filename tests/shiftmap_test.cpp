// Tests of the shift-map fill (image/shiftmap): periodic texture restored from its period, small
// canvases with few offsets filled whole, the same result on every call, bad input rejected.
#include "image/shiftmap.h"

#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <random>

#include "base/common.h"

namespace montage {
namespace {

// A pattern with periods 8 (x) and 6 (y): four colours in blocks, plus a little seeded noise that
// makes the patches of one period similar, not equal.
cv::Mat periodic(int w, int h, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> noise(-3, 3);
  cv::Mat img(h, w, CV_8UC3);
  const cv::Vec3b colours[4] = {{200, 120, 130}, {60, 140, 110}, {150, 90, 170}, {90, 160, 90}};
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      cv::Vec3b c = colours[((x % 8) / 4) + 2 * ((y % 6) / 3)];
      for (int k = 0; k < 3; ++k) c[k] = cv::saturate_cast<uchar>(c[k] + noise(rng));
      img.at<cv::Vec3b>(y, x) = c;
    }
  return img;
}

// Mean over the unknown pixels of the largest channel difference to the truth.
double holeError(const cv::Mat& filled, const cv::Mat& truth, const cv::Mat& known) {
  double sum = 0;
  int n = 0;
  for (int y = 0; y < known.rows; ++y)
    for (int x = 0; x < known.cols; ++x)
      if (!known.at<uchar>(y, x)) {
        const cv::Vec3b a = filled.at<cv::Vec3b>(y, x), b = truth.at<cv::Vec3b>(y, x);
        sum += std::max({std::abs(a[0] - b[0]), std::abs(a[1] - b[1]), std::abs(a[2] - b[2])});
        ++n;
      }
  return sum / std::max(n, 1);
}

TEST(ShiftMap, FillsAPeriodicTextureFromItsPeriodAndTheSameEveryTime) {
  const cv::Mat truth = periodic(96, 64, 1);
  cv::Mat known(truth.size(), CV_8UC1, cv::Scalar(255));
  known(cv::Rect(38, 22, 21, 17)).setTo(0);
  cv::Mat holed = truth.clone();
  holed.setTo(cv::Scalar(0, 0, 0), known == 0);
  ShiftMapStats stats;
  const cv::Mat filled = shiftMapFill(holed, known, {}, &stats);
  EXPECT_GT(stats.labels, 0);
  EXPECT_EQ(stats.unreached, 0);
  EXPECT_GE(stats.domain, 21 * 17);
  // The control: the hole filled with the mean of the known colours misses the blocks.
  cv::Mat flat = truth.clone();
  flat.setTo(cv::mean(truth, known), known == 0);
  const double error = holeError(filled, truth, known), flatError = holeError(flat, truth, known);
  std::printf("periodic hole: mean error %.2f (mean-colour fill %.2f), %d offsets\n", error, flatError, stats.labels);
  EXPECT_LT(error, 8.0) << "the blocks must continue through the hole (noise alone differs by up to 6)";
  EXPECT_GT(flatError, 40.0);
  // Known pixels beyond the band keep their values.
  EXPECT_EQ(cv::norm(filled(cv::Rect(0, 0, 96, 18)), truth(cv::Rect(0, 0, 96, 18)), cv::NORM_INF), 0.0);
  // A seeded search: the same fill again.
  EXPECT_EQ(cv::norm(shiftMapFill(holed, known), filled, cv::NORM_INF), 0.0);
}

// xphoto's shift-map read past its list of 60 offsets on canvases like this one (27 x 16, as a small
// structure hole's chart) and filled them differently from run to run.
TEST(ShiftMap, ASmallCanvasWithFewOffsetsIsFilledWholeAndTheSameEveryTime) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> value(0, 255);
  cv::Mat image(16, 27, CV_8UC3);
  for (int y = 0; y < image.rows; ++y)
    for (int x = 0; x < image.cols; ++x)
      image.at<cv::Vec3b>(y, x) = cv::Vec3b(((x / 3 + y / 5) % 2) * 120 + value(rng) % 30, 100 + value(rng) % 40, 50);
  cv::Mat known(image.size(), CV_8UC1, cv::Scalar(255));
  known(cv::Rect(9, 5, 9, 5)).setTo(0);
  ShiftMapStats stats;
  const cv::Mat a = shiftMapFill(image, known, {}, &stats);
  std::printf("27 x 16 canvas: %d offsets, %d pixels labelled, %d unreached\n", stats.labels, stats.domain,
              stats.unreached);
  EXPECT_LT(stats.labels, ShiftMapOptions{}.offsets) << "the case needs fewer offsets than asked for";
  for (int k = 0; k < 5; ++k) EXPECT_EQ(cv::norm(shiftMapFill(image, known), a, cv::NORM_INF), 0.0);
  // Every unknown pixel takes a colour from the known ones: all three channels within their range.
  double lo[3], hi[3];
  for (int c = 0; c < 3; ++c) {
    cv::Mat channel;
    cv::extractChannel(image, channel, c);
    cv::minMaxLoc(channel, &lo[c], &hi[c], nullptr, nullptr, known);
  }
  for (int y = 5; y < 10; ++y)
    for (int x = 9; x < 18; ++x)
      for (int c = 0; c < 3; ++c) {
        EXPECT_GE(a.at<cv::Vec3b>(y, x)[c], lo[c]);
        EXPECT_LE(a.at<cv::Vec3b>(y, x)[c], hi[c]);
      }
}

// Each option changes the fill in the direction its comment says.
TEST(ShiftMap, OptionsChangeTheFill) {
  const cv::Mat truth = periodic(96, 64, 2);
  cv::Mat known(truth.size(), CV_8UC1, cv::Scalar(255));
  known(cv::Rect(38, 22, 21, 17)).setTo(0);
  ShiftMapStats base, s;
  const cv::Mat baseFill = shiftMapFill(truth, known, {}, &base);
  ShiftMapOptions o;
  o.offsets = 5;
  shiftMapFill(truth, known, o, &s);
  EXPECT_EQ(s.labels, 5) << "offsets caps the labels";
  o = {};
  o.band = 0;
  shiftMapFill(truth, known, o, &s);
  EXPECT_EQ(s.domain, 21 * 17) << "without a band only the unknown pixels are labelled";
  o.band = 4;
  shiftMapFill(truth, known, o, &s);
  EXPECT_GT(s.domain, base.domain) << "a wider band labels more known pixels";
  o = {};
  o.rounds = 0;
  const cv::Mat noRounds = shiftMapFill(truth, known, o, &s);
  EXPECT_EQ(s.moves, 0);
  EXPECT_GT(base.moves, 0);
  EXPECT_GT(cv::norm(noRounds, baseFill, cv::NORM_INF), 0.0) << "the expansion moves relabel pixels";
  o = {};
  o.minOffset = 97;  // wider than the image: no patch has a match that far
  shiftMapFill(truth, known, o, &s);
  EXPECT_EQ(s.labels, 0);
  EXPECT_EQ(s.unreached, 21 * 17) << "without offsets every unknown pixel is filled from its neighbours";
  o = {};
  o.seed = 99;
  o.searchIterations = 1;
  const cv::Mat otherSearch = shiftMapFill(truth, known, o, &s);
  std::printf("another seed and one search pass: %.0f max channel difference to the default fill\n",
              cv::norm(otherSearch, baseFill, cv::NORM_INF));
  EXPECT_GT(cv::norm(otherSearch, baseFill, cv::NORM_INF), 0.0) << "the search decides the offsets";
}

TEST(ShiftMap, RejectsMismatchedInput) {
  const cv::Mat image(10, 10, CV_8UC3, cv::Scalar::all(0));
  EXPECT_THROW(shiftMapFill(image, cv::Mat(9, 10, CV_8UC1, cv::Scalar(255))), Error);
  EXPECT_THROW(shiftMapFill(cv::Mat(10, 10, CV_32FC3), cv::Mat(10, 10, CV_8UC1)), Error);
  ShiftMapOptions bad;
  bad.patch = 1;
  EXPECT_THROW(shiftMapFill(image, cv::Mat(10, 10, CV_8UC1, cv::Scalar(255)), bad), Error);
}

}  // namespace
}  // namespace montage
