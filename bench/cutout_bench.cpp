// GrabCut cut-out quality against a true alpha: each cut-out with real alpha (STAMP, e.g. Debian's
// tuxpaint-stamps-default animals) is composited onto each real, cluttered photo (BACKGROUND, e.g.
// python3-skimage's data images) and cut out again, scored by IoU against the stamp's alpha (> 0.5):
// from a rectangle alone (the true bounding box grown by 8% a side, as a user draws it), and after two
// strokes where that result is most wrong (as a user corrects it: a foreground stroke in the largest
// missed region and a background stroke in the largest wrongly kept one, kept inside the true class).
// --megapixels M scales each background up to M megapixels first (a camera's photo: the stamp and the
// strokes scale with it, so the cases match the small ones); --runs R times the stroke update (the two
// strokes, then the full-size mask the editor shows) R times from the rectangle's state and takes the
// median. Times are wall and CPU (user + sys of the process); the load average is printed before and after.
//   tm_cutout_bench [--working N] [--band B] [--size S] [--megapixels M] [--runs R] STAMP... -- BACKGROUND...
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <string>
#include <vector>

#include "base/cpu_time.h"
#include "base/util.h"
#include "image/codec.h"
#include "image/cutout.h"
#include "image/photo.h"

using namespace montage;

namespace {

std::string loadAverage() {
  double load[3] = {0, 0, 0};
  if (getloadavg(load, 3) < 3) return "unknown";
  char text[64];
  std::snprintf(text, sizeof text, "%.2f %.2f %.2f", load[0], load[1], load[2]);
  return text;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

double iou(const cv::Mat& a, const cv::Mat& b) {
  const double inter = cv::countNonZero((a > 0) & (b > 0)), uni = cv::countNonZero((a > 0) | (b > 0));
  return uni > 0 ? inter / uni : 1.0;
}

// A stroke a careful user would draw in the largest connected region of `wrong`: through its innermost
// point, along its long axis, over 60% of its length, no wider than the region nor than 8 px at the
// photos' own size (`unit`: photo pixels per pixel of that size).
std::optional<CutoutStroke> strokeIn(const cv::Mat& wrong, bool foreground, double unit) {
  cv::Mat labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(wrong, labels, stats, centroids, 8);
  int best = -1;
  for (int i = 1; i < n; ++i)
    if (best < 0 || stats.at<int>(i, cv::CC_STAT_AREA) > stats.at<int>(best, cv::CC_STAT_AREA)) best = i;
  if (best < 0 || stats.at<int>(best, cv::CC_STAT_AREA) < 20 * unit * unit) return std::nullopt;
  const cv::Mat region = labels == best;
  cv::Mat distance;
  cv::distanceTransform(region, distance, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  double maxDistance = 0;
  cv::Point inner;
  cv::minMaxLoc(distance, nullptr, &maxDistance, nullptr, &inner);
  const cv::Moments m = cv::moments(region, true);
  const double angle = 0.5 * std::atan2(2 * m.mu11, m.mu20 - m.mu02);
  const double length =
      0.6 * std::sqrt(stats.at<int>(best, cv::CC_STAT_WIDTH) * stats.at<int>(best, cv::CC_STAT_WIDTH) +
                      stats.at<int>(best, cv::CC_STAT_HEIGHT) * stats.at<int>(best, cv::CC_STAT_HEIGHT));
  CutoutStroke stroke;
  stroke.foreground = foreground;
  stroke.radius = std::clamp(0.6 * maxDistance, 1.5 * unit, 8.0 * unit);
  const Vec2 centre(inner.x + 0.5, inner.y + 0.5), dir(std::cos(angle), std::sin(angle));
  // Walk both ways from the innermost point while staying well inside the region.
  for (int side : {-1, 1}) {
    std::vector<Vec2> half;
    for (double t = 0; t <= length / 2; t += unit) {
      const Vec2 p = centre + side * t * dir;
      const int x = int(p.x()), y = int(p.y());
      if (x < 0 || y < 0 || x >= region.cols || y >= region.rows || distance.at<float>(y, x) < stroke.radius) break;
      half.push_back(p);
    }
    if (side < 0) std::reverse(half.begin(), half.end());
    stroke.points.insert(stroke.points.end(), half.begin(), half.end());
  }
  if (stroke.points.empty()) stroke.points.push_back(centre);
  return stroke;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> stamps, backgrounds;
  CutoutOptions options;
  double stampShare = 0.55;  // the stamp's longer side, as a share of the background's shorter side
  double megapixels = 0;     // 0: the backgrounds at their own size
  int runs = 1;
  std::string dump;  // a folder: each case's composite with the cut's edge and the truth's, as PNGs
  bool afterDash = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--working" && i + 1 < argc) {
      options.workingSide = std::stoi(argv[++i]);
    } else if (a == "--band" && i + 1 < argc) {
      options.bandPx = std::stoi(argv[++i]);
    } else if (a == "--size" && i + 1 < argc) {
      stampShare = std::stod(argv[++i]);
    } else if (a == "--megapixels" && i + 1 < argc) {
      megapixels = std::stod(argv[++i]);
    } else if (a == "--dump" && i + 1 < argc) {
      dump = argv[++i];
    } else if (a == "--runs" && i + 1 < argc) {
      runs = std::max(1, std::stoi(argv[++i]));
    } else if (a == "--") {
      afterDash = true;
    } else {
      (afterDash ? backgrounds : stamps).push_back(a);
    }
  }
  if (stamps.empty() || backgrounds.empty()) {
    std::fprintf(stderr, "usage: tm_cutout_bench [--working N] [--band B] [--size S] [--megapixels M] [--runs R] STAMP... -- "
                 "BACKGROUND...\n");
    return 2;
  }
  try {
    double sumRect = 0, sumStrokes = 0, minStrokes = 1;
    int cases = 0, reached = 0;
    std::vector<double> rectWall, rectCpu, updateWall, updateCpu;
    std::printf("load average at the start: %s\n", loadAverage().c_str());
    std::printf("%-22s %-20s %10s %8s %8s %8s %8s %8s %8s %8s\n", "stamp", "background", "size", "IoU rect",
                "+2 strk", "rect s", "cpu s", "update s", "cpu s", "band s");
    for (const std::string& bgPath : backgrounds) {
      cv::Mat bgRgba = readImageRgba8(bgPath), bg;
      cv::cvtColor(bgRgba, bg, cv::COLOR_RGBA2RGB);
      // Photo pixels per pixel of the background's own size: strokes and small regions scale with it.
      double unit = 1;
      if (megapixels > 0) {
        unit = std::sqrt(megapixels * 1e6 / (double(bg.cols) * bg.rows));
        cv::resize(bg, bg, cv::Size(int(std::lround(bg.cols * unit)), int(std::lround(bg.rows * unit))), 0, 0,
                   cv::INTER_CUBIC);
      }
      for (size_t k = 0; k < stamps.size(); ++k) {
        const cv::Mat stamp = readImageRgba8(stamps[k]);
        const double scale = stampShare * std::min(bg.cols, bg.rows) / std::max(stamp.cols, stamp.rows);
        cv::Mat big;
        cv::resize(stamp, big, cv::Size(), scale, scale, scale > 1 ? cv::INTER_CUBIC : cv::INTER_AREA);
        // Placed off centre, a different place for each stamp, so the background under it varies.
        const int x0 = int((bg.cols - big.cols) * (0.3 + 0.4 * ((k * 7) % 5) / 4.0));
        const int y0 = int((bg.rows - big.rows) * (0.3 + 0.4 * ((k * 3) % 5) / 4.0));
        cv::Mat composite = bg.clone(), truth = cv::Mat::zeros(bg.size(), CV_8U);
        for (int y = 0; y < big.rows; ++y)
          for (int x = 0; x < big.cols; ++x) {
            const cv::Vec4b s = big.at<cv::Vec4b>(y, x);
            const double a = s[3] / 255.0;
            cv::Vec3b& d = composite.at<cv::Vec3b>(y0 + y, x0 + x);
            for (int c = 0; c < 3; ++c) d[c] = cv::saturate_cast<uchar>(a * s[c] + (1 - a) * d[c]);
            if (a >= 0.5) truth.at<uchar>(y0 + y, x0 + x) = 255;
          }
        const cv::Rect box = cv::boundingRect(truth);
        const double gx = 0.08 * box.width, gy = 0.08 * box.height;
        const cv::Rect2d rect(box.x - gx, box.y - gy, box.width + 2 * gx, box.height + 2 * gy);

        // The rectangle: the photo handed to the cut-out (its working image made once), then GrabCut.
        auto start = Clock::now();
        double cpu = cpuSeconds();
        Cutout cut(composite, options);
        cut.setRect(rect);
        const cv::Mat mask = cut.binaryMask();
        rectWall.push_back(secondsSince(start));
        rectCpu.push_back(cpuSeconds() - cpu);
        const double fromRect = iou(mask, truth);
        // Two corrections where the rectangle's result is most wrong: one of each kind when both exist.
        std::vector<CutoutStroke> strokes;
        const auto fg = strokeIn(truth & ~mask, true, unit), bgStroke = strokeIn(mask & ~truth, false, unit);
        if (fg) strokes.push_back(*fg);
        if (bgStroke) strokes.push_back(*bgStroke);
        for (int extra = 0; strokes.size() < 2 && extra < 2; ++extra) {
          // Only one kind of error: a second stroke of that kind in what is still wrong after the first.
          cv::Mat wrong = strokes.empty() || strokes[0].foreground ? truth & ~mask : mask & ~truth;
          for (const auto& s : strokes)
            for (size_t i = 0; i < s.points.size(); ++i)
              cv::circle(wrong, cv::Point(int(s.points[i].x()), int(s.points[i].y())), int(s.radius * 4), 0, -1);
          const auto next = strokeIn(wrong, strokes.empty() ? true : strokes[0].foreground, unit);
          if (!next) break;
          strokes.push_back(*next);
        }
        double afterStrokes = fromRect, wall = 0, cpuUpdate = 0, band = 0;
        if (!strokes.empty()) {
          // The update a stroke costs in the editor: GrabCut again, then the mask at the photo's size.
          std::vector<double> walls, cpus;
          cv::Mat after;
          for (int r = 0; r < runs; ++r) {
            Cutout again = cut.copy();
            start = Clock::now();
            cpu = cpuSeconds();
            again.addStrokes(strokes);
            after = again.binaryMask();
            walls.push_back(secondsSince(start));
            cpus.push_back(cpuSeconds() - cpu);
            band = again.lastBandSeconds();
          }
          afterStrokes = iou(after, truth);
          wall = median(walls), cpuUpdate = median(cpus);
          updateWall.push_back(wall), updateCpu.push_back(cpuUpdate);
        }
        const std::string stampName = stamps[k].substr(stamps[k].find_last_of('/') + 1);
        const std::string bgName = bgPath.substr(bgPath.find_last_of('/') + 1);
        const std::string size = std::to_string(bg.cols) + "x" + std::to_string(bg.rows);
        if (!dump.empty()) {
          // Truth's edge in green, the rectangle's cut in red, the cut after strokes in blue, strokes in white.
          cv::Mat picture = composite.clone();
          const auto edge = [&](const cv::Mat& m, const cv::Scalar& colour) {
            std::vector<std::vector<cv::Point>> contours;
            cv::findContours(m.clone(), contours, cv::RETR_LIST, cv::CHAIN_APPROX_NONE);
            cv::drawContours(picture, contours, -1, colour, std::max(1, int(unit)));
          };
          edge(truth, {0, 255, 0});
          edge(mask, {255, 0, 0});
          Cutout again = cut.copy();
          if (!strokes.empty()) again.addStrokes(strokes);
          edge(again.binaryMask(), {0, 0, 255});
          for (const auto& s : strokes)
            for (size_t i = 0; i + 1 < s.points.size(); ++i)
              cv::line(picture, cv::Point(int(s.points[i].x()), int(s.points[i].y())),
                       cv::Point(int(s.points[i + 1].x()), int(s.points[i + 1].y())),
                       s.foreground ? cv::Scalar(255, 255, 255) : cv::Scalar(0, 0, 0), int(2 * s.radius));
          const std::string stem = stampName.substr(0, stampName.find('.')) + "_" + bgName.substr(0, bgName.find('.'));
          writePng(dump + "/" + stem + ".png", picture, kPngFast, false);
        }
        std::printf("%-22s %-20s %10s %8.3f %8.3f %8.2f %8.2f %8.2f %8.2f %8.2f\n", stampName.c_str(), bgName.c_str(),
                    size.c_str(), fromRect, afterStrokes, rectWall.back(), rectCpu.back(), wall, cpuUpdate, band);
        std::fflush(stdout);
        sumRect += fromRect, sumStrokes += afterStrokes, ++cases;
        minStrokes = std::min(minStrokes, afterStrokes);
        reached += afterStrokes >= 0.95;
      }
    }
    std::printf("mean IoU: rectangle %.3f, rectangle + 2 strokes %.3f (min %.3f, %d of %d >= 0.95)\n",
                sumRect / cases, sumStrokes / cases, minStrokes, reached, cases);
    std::printf("median over cases: rectangle %.2f s wall, %.2f s CPU; stroke update (median of %d runs each) "
                "%.2f s wall, %.2f s CPU (slowest case %.2f s wall)\n",
                median(rectWall), median(rectCpu), runs, median(updateWall), median(updateCpu),
                updateWall.empty() ? 0.0 : *std::max_element(updateWall.begin(), updateWall.end()));
    std::printf("load average at the end: %s\n", loadAverage().c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
