#include "image/cutout.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <opencv2/imgproc.hpp>

#include "base/fileio.h"
#include "base/util.h"
#include "image/codec.h"
#include "image/photo.h"

namespace fs = std::filesystem;

namespace montage {

namespace {

cv::Mat to8uc3(const cv::Mat& rgb) {
  TM_CHECK(!rgb.empty(), "cut-out: the photo is empty");
  TM_CHECK(rgb.channels() == 3,
           "cut-out: expected a 3-channel colour image, not " + std::to_string(rgb.channels()) + " channels");
  cv::Mat out;
  if (rgb.depth() == CV_8U)
    out = rgb;
  else if (rgb.depth() == CV_16U)
    rgb.convertTo(out, CV_8UC3, 1.0 / 257);
  else if (rgb.depth() == CV_32F)
    rgb.convertTo(out, CV_8UC3, 255.0);
  else
    throw Error("cut-out: expected an 8-bit, 16-bit or float colour image");
  return out;
}

std::string percent(double share) {
  return std::to_string(int(std::lround(100 * share))) + "%";
}

}  // namespace

Cutout::Cutout(const cv::Mat& rgb, const CutoutOptions& options, cv::Size photoSize) : options_(options) {
  TM_CHECK(options.iterations >= 1, "cut-out: iterations must be >= 1, not " + std::to_string(options.iterations));
  TM_CHECK(options.workingSide == 0 || options.workingSide >= 64,
           "cut-out: the working size must be 0 (full resolution) or >= 64 pixels, not " +
               std::to_string(options.workingSide));
  TM_CHECK(std::isfinite(options.featherPx) && options.featherPx >= 0, "cut-out: the feather must be >= 0 pixels");
  const cv::Mat stored = to8uc3(rgb);
  size_ = photoSize.empty() ? stored.size() : photoSize;
  const int side = std::max(size_.width, size_.height);
  scale_ = options.workingSide > 0 && side > options.workingSide ? double(options.workingSide) / side : 1.0;
  // The working image: the photo at scale_, from its stored pixels (which a working resolution may have
  // made fewer than the file's: never scaled up beyond them).
  const double fromStored = double(stored.cols) / size_.width;
  scale_ = std::min(scale_, fromStored);
  const cv::Size working(std::max(1, int(std::lround(size_.width * scale_))),
                         std::max(1, int(std::lround(size_.height * scale_))));
  if (working != stored.size())
    cv::resize(stored, image_, working, 0, 0, cv::INTER_AREA);
  else
    image_ = stored.clone();
  labels_ = cv::Mat(image_.size(), CV_8UC1, cv::Scalar(cv::GC_PR_BGD));
}

Cutout Cutout::copy() const {
  Cutout c = *this;  // cv::Mat copies share their pixels: deep copies of what runs and strokes write
  c.labels_ = labels_.clone();
  c.bgdModel_ = bgdModel_.clone();
  c.fgdModel_ = fgdModel_.clone();
  return c;  // image_ is written only by the constructor: shared
}

cv::Point2d Cutout::toWorking(const Vec2& p) const {
  return cv::Point2d(p.x() * scale_ - 0.5, p.y() * scale_ - 0.5);  // pixel centres at +0.5
}

void Cutout::setRect(const cv::Rect2d& rect) {
  TM_CHECK(std::isfinite(rect.x) && std::isfinite(rect.y) && std::isfinite(rect.width) && std::isfinite(rect.height),
           "cut-out: the rectangle must have finite coordinates");
  const cv::Rect2d photo(0, 0, size_.width, size_.height);
  const cv::Rect2d clipped = rect & photo;
  TM_CHECK(clipped.width >= 1 && clipped.height >= 1,
           "cut-out: the rectangle (" + std::to_string(int(rect.x)) + ", " + std::to_string(int(rect.y)) + ", " +
               std::to_string(int(rect.width)) + " x " + std::to_string(int(rect.height)) +
               ") is empty or outside the photo (" + std::to_string(size_.width) + " x " +
               std::to_string(size_.height) + ")");
  const int x0 = std::clamp(int(std::floor(clipped.x * scale_)), 0, image_.cols - 1);
  const int y0 = std::clamp(int(std::floor(clipped.y * scale_)), 0, image_.rows - 1);
  const int x1 = std::clamp(int(std::ceil((clipped.x + clipped.width) * scale_)), x0 + 1, image_.cols);
  const int y1 = std::clamp(int(std::ceil((clipped.y + clipped.height) * scale_)), y0 + 1, image_.rows);
  rect_ = cv::Rect(x0, y0, x1 - x0, y1 - y0);
  TM_CHECK(rect_.area() < image_.cols * image_.rows,
           "cut-out: the rectangle covers the whole photo; leave some background outside it");
  labels_.setTo(cv::Scalar(cv::GC_BGD));
  labels_(rect_).setTo(cv::Scalar(cv::GC_PR_FGD));
  modelsReady_ = false;
  runGrabCut(true);
}

void Cutout::startFrom(const cv::Mat& alpha) {
  const bool sameShape = std::abs(double(alpha.cols) * size_.height - double(alpha.rows) * size_.width) <=
                         std::max(alpha.cols, size_.width);  // the photo's size or a scaled copy of it
  TM_CHECK(!alpha.empty() && sameShape && alpha.channels() == 1,
           "cut-out: the mask to start from is " + std::to_string(alpha.cols) + "x" + std::to_string(alpha.rows) +
               " but the photo is " + std::to_string(size_.width) + "x" + std::to_string(size_.height));
  cv::Mat foreground = alpha > 0, small;
  if (foreground.size() != image_.size())
    cv::resize(foreground, small, image_.size(), 0, 0, cv::INTER_NEAREST);
  else
    small = foreground;
  labels_.setTo(cv::Scalar(cv::GC_PR_BGD));
  labels_.setTo(cv::Scalar(cv::GC_PR_FGD), small);
  modelsReady_ = false;
  started_ = true;
}

void Cutout::paint(const CutoutStroke& stroke, bool hard) {
  TM_CHECK(std::isfinite(stroke.radius) && stroke.radius > 0, "cut-out: a stroke's radius must be > 0 pixels");
  const int value =
      hard ? (stroke.foreground ? cv::GC_FGD : cv::GC_BGD) : (stroke.foreground ? cv::GC_PR_FGD : cv::GC_PR_BGD);
  // Fixed-point drawing (4 fractional bits) so that thin strokes at a reduced working size land where drawn.
  constexpr int kShift = 4;
  const double unit = 1 << kShift;
  const int thickness = std::max(1, int(std::lround(2 * stroke.radius * scale_)));
  auto fixed = [&](const Vec2& p) {
    TM_CHECK(std::isfinite(p.x()) && std::isfinite(p.y()), "cut-out: a stroke point must be finite");
    const cv::Point2d w = toWorking(p);
    return cv::Point(int(std::lround(w.x * unit)), int(std::lround(w.y * unit)));
  };
  if (stroke.points.size() == 1) {
    cv::circle(labels_, fixed(stroke.points[0]), int(std::lround(thickness * 0.5 * unit)), cv::Scalar(value), -1,
               cv::LINE_8, kShift);
    return;
  }
  for (size_t k = 0; k + 1 < stroke.points.size(); ++k)
    cv::line(labels_, fixed(stroke.points[k]), fixed(stroke.points[k + 1]), cv::Scalar(value), thickness, cv::LINE_8,
             kShift);
}

void Cutout::addStroke(const CutoutStroke& stroke) {
  addStrokes({stroke});
}

void Cutout::addStrokes(const std::vector<CutoutStroke>& strokes) {
  for (const CutoutStroke& s : strokes) {
    TM_CHECK(!s.points.empty(), "cut-out: a stroke needs at least one point");
    paint(s, true);
  }
  runGrabCut(false);
}

void Cutout::addStrokeMasks(const cv::Mat& fg, const cv::Mat& bg) {
  for (const cv::Mat* m : {&fg, &bg}) {
    if (m->empty()) continue;
    TM_CHECK(m->size() == size_, "cut-out: a stroke image is " + std::to_string(m->cols) + "x" +
                                     std::to_string(m->rows) + " but the photo is " + std::to_string(size_.width) +
                                     "x" + std::to_string(size_.height));
    cv::Mat grey = *m;
    if (grey.channels() > 1) {
      std::vector<cv::Mat> channels;
      cv::split(grey, channels);
      grey = channels[0] != 0;
      for (size_t c = 1; c < std::min<size_t>(channels.size(), 3); ++c) grey |= channels[c] != 0;
    }
    cv::Mat marked = grey != 0, small;
    if (scale_ < 1)
      cv::resize(marked, small, image_.size(), 0, 0, cv::INTER_AREA);  // a pixel partly marked counts
    else
      small = marked;
    labels_.setTo(cv::Scalar(m == &fg ? cv::GC_FGD : cv::GC_BGD), small > 0);
  }
  runGrabCut(false);
}

void Cutout::brush(const CutoutStroke& stroke) {
  TM_CHECK(!stroke.points.empty(), "cut-out: a brush stroke needs at least one point");
  paint(stroke, true);
  started_ = true;
}

void Cutout::runGrabCut(bool fromRect) {
  const auto start = Clock::now();
  const int fg = cv::countNonZero((labels_ == cv::GC_FGD) | (labels_ == cv::GC_PR_FGD));
  const int bg = labels_.rows * labels_.cols - fg;
  TM_CHECK(fg > 0,
           "cut-out: nothing is marked as foreground: draw a rectangle around the object, or a "
           "foreground stroke on it");
  TM_CHECK(bg > 0, "cut-out: nothing is marked as background: the rectangle or the strokes cover the whole photo");
  try {
    if (!modelsReady_) {
      // From the rectangle, or strokes alone: the colour models are learnt from the current labels.
      cv::grabCut(image_, labels_, fromRect ? rect_ : cv::Rect(), bgdModel_, fgdModel_, options_.iterations,
                  cv::GC_INIT_WITH_MASK);
      modelsReady_ = true;
    } else {
      cv::grabCut(image_, labels_, cv::Rect(), bgdModel_, fgdModel_, options_.iterations, cv::GC_EVAL);
    }
  } catch (const cv::Exception& e) {
    throw Error("cut-out: GrabCut failed: " + e.msg);
  }
  started_ = true;
  lastSeconds_ = secondsSince(start);
}

cv::Mat Cutout::binaryMask() const {
  cv::Mat working = (labels_ == cv::GC_FGD) | (labels_ == cv::GC_PR_FGD);
  if (!started_) working.setTo(0);
  if (scale_ >= 1) return working;
  // Back to the photo's size with a smooth edge: bilinear interpolation of the 0/1 mask, cut at 1/2.
  cv::Mat soft, full;
  working.convertTo(soft, CV_32F, 1.0 / 255);
  cv::resize(soft, full, size_, 0, 0, cv::INTER_LINEAR);
  return full >= 0.5f;
}

cv::Mat Cutout::mask() const {
  return featherMask(binaryMask(), options_.featherPx);
}

cv::Mat cutoutMask(const cv::Mat& rgb, const cv::Rect2d& rect, const cv::Mat& fgStrokes, const cv::Mat& bgStrokes,
                   const CutoutOptions& options) {
  Cutout cut(rgb, options);
  cut.setRect(rect);
  if (!fgStrokes.empty() || !bgStrokes.empty()) cut.addStrokeMasks(fgStrokes, bgStrokes);
  return cut.mask();
}

cv::Mat featherMask(const cv::Mat& binary, double featherPx) {
  TM_CHECK(!binary.empty() && binary.channels() == 1, "feather: expected a one-channel mask");
  const cv::Mat foreground = binary != 0;
  if (!(featherPx > 0)) return foreground;
  cv::Mat distance;
  cv::distanceTransform(foreground, distance, cv::DIST_L2, cv::DIST_MASK_PRECISE, CV_32F);
  cv::Mat alpha;
  distance.convertTo(alpha, CV_32F, 255.0 / featherPx);
  cv::min(alpha, 255.0, alpha);
  cv::max(alpha, 1.0, alpha);  // every foreground pixel keeps alpha > 0
  cv::Mat out;
  alpha.convertTo(out, CV_8U);
  out.setTo(0, foreground == 0);
  return out;
}

double borderForegroundShare(const cv::Mat& alpha) {
  TM_CHECK(!alpha.empty() && alpha.channels() == 1, "border share: expected a one-channel alpha image");
  const int w = alpha.cols, h = alpha.rows;
  cv::Mat fg = alpha > 0;
  long count = 0, total = 0;
  auto visit = [&](int x, int y) {
    ++total;
    count += fg.at<uchar>(y, x) != 0;
  };
  for (int x = 0; x < w; ++x) {
    visit(x, 0);
    if (h > 1) visit(x, h - 1);
  }
  for (int y = 1; y + 1 < h; ++y) {
    visit(0, y);
    if (w > 1) visit(w - 1, y);
  }
  return total ? double(count) / total : 0.0;
}

std::vector<std::string> foregroundWarnings(const Photo& photo) {
  return foregroundWarnings(photo.hasBackground, photo.hasBackground ? borderForegroundShare(photo.alpha) : 1.0);
}

std::vector<std::string> foregroundWarnings(bool hasBackground, double borderShare) {
  std::vector<std::string> out;
  if (!hasBackground) {
    out.push_back(
        "no background: the photo has no alpha channel and no mask (or they mark everything as foreground), so the "
        "whole photo, background included, counts as the object; cut it out (montage mask, or the editor's cut-out "
        "tool)");
    return out;
  }
  if (borderShare > 0.5)
    out.push_back("the foreground covers " + percent(borderShare) +
                  " of the image border: the cut-out probably keeps background, which would be mapped onto the mesh; "
                  "refine it (montage mask, or the editor's cut-out tool)");
  return out;
}

void writeMaskPng(const cv::Mat& mask, const std::string& path) {
  TM_CHECK(!mask.empty() && mask.type() == CV_8UC1, located(path, "a mask must be a non-empty 8-bit grey image"));
  const fs::path parent = fs::path(path).parent_path();
  std::error_code ec;
  if (!parent.empty()) fs::create_directories(parent, ec);
  writePng(path, mask);
}

}  // namespace montage
