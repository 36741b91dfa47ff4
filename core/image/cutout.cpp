#include "image/cutout.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <opencv2/core.hpp>  // gcgraph.hpp needs it first
#include <opencv2/imgproc.hpp>
#include <opencv2/imgproc/detail/gcgraph.hpp>

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

// The background GrabCut learns from around the object: this much of the rectangle's longer side on
// every side of it. Nearby background is what the edge has to be told from; the far corners of a
// cluttered photo only crowd the five colour components (and cost time at a camera's resolution).
constexpr double kMarginShare = 0.3;

cv::Rect grown(const cv::Rect& r, const cv::Size& size) {
  const int margin = std::max(16, int(std::lround(kMarginShare * std::max(r.width, r.height))));
  return cv::Rect(r.x - margin, r.y - margin, r.width + 2 * margin, r.height + 2 * margin) & cv::Rect(cv::Point(), size);
}

// One of GrabCut's colour models as OpenCV stores it (a row of K weights, K means, K 3x3 covariances),
// evaluated at a colour: the mixture's density, up to the constant both models share.
class ColourModel {
 public:
  explicit ColourModel(const cv::Mat& model) {
    const int k = model.cols / 13;
    const double* coefs = model.ptr<double>(0);
    const double* means = coefs + k;
    const double* covs = means + 3 * k;
    for (int c = 0; c < k; ++c) {
      if (coefs[c] <= 0) continue;
      const cv::Matx33d cov(covs + 9 * c);
      const double det = cv::determinant(cov);
      if (!(det > 0)) continue;
      components_.push_back({coefs[c] / std::sqrt(det), cv::Vec3d(means + 3 * c), cov.inv()});
    }
  }
  // -log of the density: what labelling a pixel of this colour with this model costs.
  double cost(const cv::Vec3b& colour) const {
    double p = 0;
    for (const Component& c : components_) {
      const cv::Vec3d d = cv::Vec3d(colour[0], colour[1], colour[2]) - c.mean;
      p += c.weight * std::exp(-0.5 * d.dot(c.inverse * d));
    }
    return -std::log(std::max(p, 1e-300));
  }

 private:
  struct Component {
    double weight;  // the mixture weight over sqrt(det(covariance))
    cv::Vec3d mean;
    cv::Matx33d inverse;
  };
  std::vector<Component> components_;
};

}  // namespace

Cutout::Cutout(const cv::Mat& rgb, const CutoutOptions& options, cv::Size photoSize) : options_(options) {
  TM_CHECK(options.iterations >= 1, "cut-out: iterations must be >= 1, not " + std::to_string(options.iterations));
  TM_CHECK(options.strokeIterations >= 1, "cut-out: stroke iterations must be >= 1");
  TM_CHECK(options.bandPx >= 0, "cut-out: the band must be >= 0 working pixels");
  TM_CHECK(options.workingSide == 0 || options.workingSide >= 64,
           "cut-out: the working size must be 0 (full resolution) or >= 64 pixels, not " +
               std::to_string(options.workingSide));
  TM_CHECK(std::isfinite(options.featherPx) && options.featherPx >= 0, "cut-out: the feather must be >= 0 pixels");
  stored_ = to8uc3(rgb);
  const cv::Mat& stored = stored_;
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
  roi_ = cv::Rect(cv::Point(), image_.size());
}

Cutout Cutout::copy() const {
  Cutout c = *this;  // cv::Mat copies share their pixels: deep copies of what runs and strokes write
  c.labels_ = labels_.clone();
  c.bgdModel_ = bgdModel_.clone();
  c.fgdModel_ = fgdModel_.clone();
  return c;  // image_ and stored_ are written only by the constructor, result_ and marks' images never: shared
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
  roi_ = grown(rect_, image_.size());
  marks_.clear();
  modelsReady_ = false;
  runGrabCut();
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
  rect_ = cv::Rect();
  roi_ = cv::Rect(cv::Point(), image_.size());
  marks_.clear();
  cv::resize(foreground, result_, stored_.size(), 0, 0, cv::INTER_NEAREST);
  modelsReady_ = false;
  started_ = true;
}

void Cutout::startFromTrimap(const cv::Mat& labels) {
  TM_CHECK(labels.type() == CV_8UC1 && labels.size() == size_,
           "cut-out: the trimap is " + std::to_string(labels.cols) + "x" + std::to_string(labels.rows) +
               " but the photo is " + std::to_string(size_.width) + "x" + std::to_string(size_.height));
  if (labels.size() != image_.size())
    cv::resize(labels, labels_, image_.size(), 0, 0, cv::INTER_NEAREST);
  else
    labels_ = labels.clone();
  rect_ = cv::boundingRect(labels_ != cv::GC_BGD);
  roi_ = grown(rect_, image_.size());
  marks_.clear();
  modelsReady_ = false;
  runGrabCut();
}

void Cutout::paint(cv::Mat& labels, double scale, const CutoutStroke& stroke, int value) const {
  TM_CHECK(std::isfinite(stroke.radius) && stroke.radius > 0, "cut-out: a stroke's radius must be > 0 pixels");
  // Fixed-point drawing (4 fractional bits) so that thin strokes at a reduced working size land where drawn.
  constexpr int kShift = 4;
  const double unit = 1 << kShift;
  const int thickness = std::max(1, int(std::lround(2 * stroke.radius * scale)));
  auto fixed = [&](const Vec2& p) {
    TM_CHECK(std::isfinite(p.x()) && std::isfinite(p.y()), "cut-out: a stroke point must be finite");
    // Pixel centres at +0.5.
    return cv::Point(int(std::lround((p.x() * scale - 0.5) * unit)), int(std::lround((p.y() * scale - 0.5) * unit)));
  };
  if (stroke.points.size() == 1) {
    cv::circle(labels, fixed(stroke.points[0]), int(std::lround(thickness * 0.5 * unit)), cv::Scalar(value), -1,
               cv::LINE_8, kShift);
    return;
  }
  for (size_t k = 0; k + 1 < stroke.points.size(); ++k)
    cv::line(labels, fixed(stroke.points[k]), fixed(stroke.points[k + 1]), cv::Scalar(value), thickness, cv::LINE_8,
             kShift);
}

void Cutout::spreadStroke(const CutoutStroke& stroke) {
  // The region the stroke was drawn in: pixels the cut gave to the other side, reached from the stroke
  // without crossing a colour more than kRange levels (per channel) from the stroke's own where it starts.
  // They change sides as probable labels: GrabCut re-learns its colour models from them (the issue's
  // background stroke moved a cut from 36.8% to 35.4% foreground because its pixels alone were too few to
  // move the models) and its graph cut still has the last word on each pixel.
  constexpr double kRange = 24;
  const int other = stroke.foreground ? cv::GC_PR_BGD : cv::GC_PR_FGD;
  cv::Mat under = cv::Mat::zeros(labels_.size(), CV_8UC1);
  paint(under, scale_, stroke, 255);
  cv::Mat smooth;
  cv::GaussianBlur(image_(roi_), smooth, cv::Size(5, 5), 0);
  // floodFill's mask: 1 stops the fill, 255 is what it filled (one pixel of border around the image).
  cv::Mat fill(roi_.height + 2, roi_.width + 2, CV_8UC1, cv::Scalar(1));
  fill(cv::Rect(1, 1, roi_.width, roi_.height)).setTo(0, (labels_(roi_) == other) | under(roi_));
  const double step = std::max(1.0, stroke.radius * scale_);
  for (size_t k = 0; k < stroke.points.size(); ++k) {
    const Vec2 a = stroke.points[k], b = stroke.points[std::min(k + 1, stroke.points.size() - 1)];
    const double length = (b - a).norm() * scale_;
    for (double t = 0; t <= length; t += step) {
      const Vec2 p = length > 0 ? a + (b - a) * (t / length) : a;
      const cv::Point seed(int(p.x() * scale_) - roi_.x, int(p.y() * scale_) - roi_.y);
      if (seed.x < 0 || seed.y < 0 || seed.x >= roi_.width || seed.y >= roi_.height) continue;
      if (fill.at<uchar>(seed.y + 1, seed.x + 1) != 0) continue;  // filled already, or not in the region
      cv::floodFill(smooth, fill, seed, cv::Scalar(), nullptr, cv::Scalar::all(kRange), cv::Scalar::all(kRange),
                    8 | cv::FLOODFILL_FIXED_RANGE | cv::FLOODFILL_MASK_ONLY | (255 << 8));
    }
  }
  cv::Mat labels = labels_(roi_);
  labels.setTo(cv::Scalar(stroke.foreground ? cv::GC_PR_FGD : cv::GC_PR_BGD),
               (fill(cv::Rect(1, 1, roi_.width, roi_.height)) == 255) & (labels == other));
}

void Cutout::addStroke(const CutoutStroke& stroke) {
  addStrokes({stroke});
}

void Cutout::addStrokes(const std::vector<CutoutStroke>& strokes) {
  for (const CutoutStroke& s : strokes) {
    TM_CHECK(!s.points.empty(), "cut-out: a stroke needs at least one point");
    paint(labels_, scale_, s, s.foreground ? cv::GC_FGD : cv::GC_BGD);
    marks_.push_back({s, {}});
    if (!rect_.empty()) {
      // A stroke outside the rectangle's surroundings widens where GrabCut runs to take it in.
      std::vector<cv::Point> points;
      for (const Vec2& p : s.points) points.emplace_back(int(p.x() * scale_), int(p.y() * scale_));
      const int r = int(std::ceil(s.radius * scale_)) + 1;
      const cv::Rect box = cv::boundingRect(points);
      roi_ |= cv::Rect(box.x - r, box.y - r, box.width + 2 * r, box.height + 2 * r) & cv::Rect(cv::Point(), image_.size());
    }
  }
  if (modelsReady_)
    for (const CutoutStroke& s : strokes) spreadStroke(s);
  runGrabCut();
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
    Mark mark;
    mark.stroke.foreground = m == &fg;
    mark.image = marked;
    marks_.push_back(mark);
    if (!rect_.empty()) roi_ |= cv::boundingRect(small);
  }
  runGrabCut();
}

void Cutout::brush(const CutoutStroke& stroke) {
  TM_CHECK(!stroke.points.empty(), "cut-out: a brush stroke needs at least one point");
  paint(labels_, scale_, stroke, stroke.foreground ? cv::GC_FGD : cv::GC_BGD);
  marks_.push_back({stroke, {}});
  // A new result, not the old one written over: copies of this cut-out share the old one.
  result_ = result_.empty() ? cv::Mat::zeros(stored_.size(), CV_8UC1) : result_.clone();
  paint(result_, double(stored_.cols) / size_.width, stroke, stroke.foreground ? 255 : 0);
  started_ = true;
}

void Cutout::runGrabCut() {
  const auto start = Clock::now();
  const int fg = cv::countNonZero((labels_ == cv::GC_FGD) | (labels_ == cv::GC_PR_FGD));
  const int bg = labels_.rows * labels_.cols - fg;
  TM_CHECK(fg > 0,
           "cut-out: nothing is marked as foreground: draw a rectangle around the object, or a "
           "foreground stroke on it");
  TM_CHECK(bg > 0, "cut-out: nothing is marked as background: the rectangle or the strokes cover the whole photo");
  // Outside roi_ every label is certain background (outside the rectangle): GrabCut runs on roi_ alone.
  const cv::Mat image = image_(roi_);
  cv::Mat labels = labels_(roi_);
  // GrabCut seeds its colour models by k-means++ from the calling thread's random state, which every earlier draw on
  // that thread moves: seeded here, the same photo and labels give the same cut on any thread, at any time (the
  // camera stage's silhouettes, and with them the final result, are then those of a fresh run).
  cv::theRNG() = cv::RNG(0x9e3779b9u);
  try {
    if (!modelsReady_) {
      // From the rectangle, or strokes alone: the colour models are learnt from the current labels.
      cv::grabCut(image, labels, cv::Rect(), bgdModel_, fgdModel_, options_.iterations, cv::GC_INIT_WITH_MASK);
      modelsReady_ = true;
    } else {
      cv::grabCut(image, labels, cv::Rect(), bgdModel_, fgdModel_, options_.strokeIterations,
                  cv::GC_EVAL);
    }
  } catch (const cv::Exception& e) {
    throw Error("cut-out: GrabCut failed: " + e.msg);
  }
  started_ = true;
  const auto band = Clock::now();
  refine();
  lastBandSeconds_ = secondsSince(band);
  lastSeconds_ = secondsSince(start);
}

void Cutout::refine() {
  const cv::Mat working = (labels_ & 1) != 0;  // GC_FGD and GC_PR_FGD are the odd labels
  const double up = double(stored_.cols) / image_.cols;  // stored pixels per working pixel
  if (up < 1.5 || options_.bandPx <= 0) {
    // No finer pixels to decide (or no band asked for): the 0/1 result scaled up bilinearly and cut at
    // 1/2, a smooth edge rather than a staircase.
    if (working.size() == stored_.size()) {
      result_ = working;
    } else {
      cv::Mat soft, full;
      working.convertTo(soft, CV_32F, 1.0 / 255);
      cv::resize(soft, full, stored_.size(), 0, 0, cv::INTER_LINEAR);
      result_ = full >= 0.5f;
    }
    applyMarks(result_);
    return;
  }
  // The band: probable pixels within bandPx working pixels of GrabCut's edge. Their stored pixels are
  // decided again by a graph cut with GrabCut's energy (its two colour models, contrast-sensitive
  // smoothness) at the stored resolution; every other pixel keeps the working label.
  const cv::Mat kernel = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * options_.bandPx + 1, 2 * options_.bandPx + 1));
  cv::Mat grownFg, shrunkFg;
  cv::dilate(working, grownFg, kernel);
  cv::erode(working, shrunkFg, kernel);
  const cv::Mat probable = (labels_ == cv::GC_PR_FGD) | (labels_ == cv::GC_PR_BGD);
  const cv::Mat bandWorking = (grownFg != shrunkFg) & probable;
  cv::Mat full;
  cv::resize(working, full, stored_.size(), 0, 0, cv::INTER_NEAREST);
  const cv::Rect box = cv::boundingRect(bandWorking);
  if (box.empty()) {
    result_ = full;
    applyMarks(result_);
    return;
  }
  // Only the band's bounding box, in stored pixels, is scaled up and visited.
  const cv::Rect area = cv::Rect(int(std::floor(box.x * up)), int(std::floor(box.y * up)),
                                 int(std::ceil(box.width * up)) + 2, int(std::ceil(box.height * up)) + 2) &
                        cv::Rect(cv::Point(), stored_.size());
  cv::Mat band;
  cv::resize(bandWorking, band, stored_.size(), 0, 0, cv::INTER_NEAREST);
  // GrabCut's beta: the inverse of twice the mean squared colour difference between neighbours (here in the
  // band), and its gamma (50) for a pair of working pixels. A stored pixel's edge is 1/up of a working
  // pixel's and its colour cost 1/up^2 of one: gamma * up keeps the smoothness against the colours as it was.
  const int dx[4] = {1, -1, 0, 1}, dy[4] = {0, 1, 1, 1};  // the 4 later neighbours (each pair once)
  double sum = 0;
  long pairs = 0;
  for (int y = area.y; y < area.y + area.height; ++y) {
    const uchar* b = band.ptr<uchar>(y);
    for (int x = area.x; x < area.x + area.width; ++x) {
      if (!b[x]) continue;
      const cv::Vec3d c = stored_.at<cv::Vec3b>(y, x);
      for (int d = 0; d < 4; ++d) {
        const int u = x + dx[d], v = y + dy[d];
        if (u < 0 || v < 0 || u >= stored_.cols || v >= stored_.rows) continue;
        const cv::Vec3d e = c - cv::Vec3d(stored_.at<cv::Vec3b>(v, u));
        sum += e.dot(e), ++pairs;
      }
    }
  }
  const double beta = sum > 0 ? pairs / (2 * sum) : 0;
  const double gamma = 50.0 * up;
  const ColourModel fgModel(fgdModel_), bgModel(bgdModel_);
  cv::Mat decided = full.clone();
  // The band in tiles, each cut on its own with a margin around it that is solved but not kept: one
  // graph of the whole band (370k pixels on a 12-megapixel photo) took Boykov-Kolmogorov 1-2 s, tiles
  // of a few thousand pixels take a tenth of it together, and run on every core.
  constexpr int kTile = 128, kMargin = 16;
  std::vector<cv::Rect> tiles;
  for (int y = area.y; y < area.y + area.height; y += kTile)
    for (int x = area.x; x < area.x + area.width; x += kTile) {
      const cv::Rect tile = cv::Rect(x, y, kTile, kTile) & area;
      if (cv::countNonZero(band(tile)) > 0) tiles.push_back(tile);
    }
  cv::parallel_for_(cv::Range(0, int(tiles.size())), [&](const cv::Range& range) {
    for (int t = range.start; t < range.end; ++t) {
      const cv::Rect inner = tiles[t];
      const cv::Rect tile = cv::Rect(inner.x - kMargin, inner.y - kMargin, inner.width + 2 * kMargin,
                                     inner.height + 2 * kMargin) &
                            area;
      cv::Mat index(tile.size(), CV_32S, cv::Scalar(-1));
      int n = 0;
      for (int y = 0; y < tile.height; ++y) {
        const uchar* b = band.ptr<uchar>(tile.y + y) + tile.x;
        int* idx = index.ptr<int>(y);
        for (int x = 0; x < tile.width; ++x)
          if (b[x]) idx[x] = n++;
      }
      if (n == 0) continue;
      cv::detail::GCGraph<double> graph(n, 8 * n);
      for (int i = 0; i < n; ++i) graph.addVtx();
      for (int y = 0; y < tile.height; ++y)
        for (int x = 0; x < tile.width; ++x) {
          const int i = index.at<int>(y, x);
          if (i < 0) continue;
          const int gx = tile.x + x, gy = tile.y + y;
          const cv::Vec3b c = stored_.at<cv::Vec3b>(gy, gx);
          // The source side is foreground: its edge is cut (paid) when the pixel goes to the background.
          double toBackground = bgModel.cost(c), toForeground = fgModel.cost(c);
          for (int d = 0; d < 8; ++d) {
            // All 8 neighbours for the fixed ones (outside the band or the tile), the 4 later ones for pairs.
            const int ddx = d < 4 ? dx[d] : -dx[d - 4], ddy = d < 4 ? dy[d] : -dy[d - 4];
            const int u = x + ddx, v = y + ddy;
            if (gx + ddx < 0 || gy + ddy < 0 || gx + ddx >= stored_.cols || gy + ddy >= stored_.rows) continue;
            const cv::Vec3d e = cv::Vec3d(c) - cv::Vec3d(stored_.at<cv::Vec3b>(gy + ddy, gx + ddx));
            const double w = gamma / std::sqrt(double(ddx * ddx + ddy * ddy)) * std::exp(-beta * e.dot(e));
            const int j = u >= 0 && v >= 0 && u < tile.width && v < tile.height ? index.at<int>(v, u) : -1;
            if (j >= 0) {
              if (d < 4) graph.addEdges(i, j, w, w);
            } else if (full.at<uchar>(gy + ddy, gx + ddx)) {
              toBackground += w;  // a foreground neighbour: going to the background cuts the pair
            } else {
              toForeground += w;
            }
          }
          graph.addTermWeights(i, toBackground, toForeground);
        }
      graph.maxFlow();
      for (int y = inner.y - tile.y; y < inner.y - tile.y + inner.height; ++y)
        for (int x = inner.x - tile.x; x < inner.x - tile.x + inner.width; ++x) {
          const int i = index.at<int>(y, x);
          if (i >= 0) decided.at<uchar>(tile.y + y, tile.x + x) = graph.inSourceSegment(i) ? 255 : 0;
        }
    }
  });
  result_ = decided;
  applyMarks(result_);
}

void Cutout::applyMarks(cv::Mat& full) const {
  const double scale = double(stored_.cols) / size_.width;
  for (const Mark& m : marks_) {
    const int value = m.stroke.foreground ? 255 : 0;
    if (m.image.empty()) {
      paint(full, scale, m.stroke, value);
    } else {
      cv::Mat marked = m.image;
      if (marked.size() != full.size()) cv::resize(m.image, marked, full.size(), 0, 0, cv::INTER_NEAREST);
      full.setTo(cv::Scalar(value), marked);
    }
  }
}

cv::Mat Cutout::binaryMask() const {
  if (!started_ || result_.empty()) return cv::Mat::zeros(size_, CV_8UC1);
  if (result_.size() == size_) return result_.clone();
  // The photo is stored smaller than its file: to the file's size with a smooth edge (bilinear, cut at 1/2).
  cv::Mat soft, full;
  result_.convertTo(soft, CV_32F, 1.0 / 255);
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

PackedMask::PackedMask(const cv::Mat& mask) {
  if (mask.empty()) return;
  TM_CHECK(mask.type() == CV_8UC1, "PackedMask: a CV_8UC1 mask is expected");
  size_ = mask.size();
  for (int y = 0; y < mask.rows; ++y) {
    const uchar* row = mask.ptr<uchar>(y);
    for (int x = 0; x < mask.cols; ++x) {
      if (!values_.empty() && values_.back() == row[x] && lengths_.back() < UINT32_MAX)
        ++lengths_.back();
      else
        values_.push_back(row[x]), lengths_.push_back(1);
    }
  }
}

cv::Mat PackedMask::unpack() const {
  if (size_.empty()) return {};
  cv::Mat mask(size_, CV_8UC1);
  uchar* out = mask.data;  // freshly allocated: continuous
  for (size_t i = 0; i < values_.size(); ++i) out = std::fill_n(out, lengths_[i], values_[i]);
  return mask;
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
