#include "mapping/found_silhouette.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "base/util.h"
#include "geometry/mesh.h"
#include "image/photo.h"

namespace montage {

cv::Mat projectedCoverage(const Mesh& mesh, const PhotoCamera& camera) {
  const int w = camera.pinhole.width, h = camera.pinhole.height;
  cv::Mat out(h, w, CV_8UC1, cv::Scalar(0));
  constexpr int kShift = 4;  // sub-pixel vertex positions for fillConvexPoly: 1/16 px
  std::vector<cv::Point> pixel(mesh.numVertices());
  std::vector<char> front(mesh.numVertices(), 0);
  const double limit = 4.0 * std::max(w, h);  // farther out, a vertex lies beyond any plausible lens's reach
  for (int v = 0; v < mesh.numVertices(); ++v) {
    Vec2 q;
    if (!camera.project(mesh.position(v), q) || !q.allFinite() || q.cwiseAbs().maxCoeff() > limit) continue;
    front[v] = 1;
    pixel[v] =
        cv::Point(int(std::lround((q.x() - 0.5) * (1 << kShift))), int(std::lround((q.y() - 0.5) * (1 << kShift))));
  }
  for (int f = 0; f < mesh.numFaces(); ++f) {
    const auto v = mesh.faceVertices(f);
    if (!front[v[0]] || !front[v[1]] || !front[v[2]]) continue;
    const cv::Point tri[3] = {pixel[v[0]], pixel[v[1]], pixel[v[2]]};
    cv::fillConvexPoly(out, tri, 3, cv::Scalar(255), cv::LINE_8, kShift);
  }
  return out;
}

namespace {

// Intersection over union of two masks of one size (> 127: inside).
double overlap(const cv::Mat& a, const cv::Mat& b) {
  const cv::Mat x = a > 127, y = b > 127;
  return double(cv::countNonZero(x & y)) / std::max(1, cv::countNonZero(x | y));
}

}  // namespace

double outlineAgreement(const Mesh& mesh, const PhotoCamera& camera, const cv::Mat& mask) {
  cv::Mat coverage = projectedCoverage(mesh, camera);
  if (coverage.size() != mask.size()) cv::resize(coverage, coverage, mask.size(), 0, 0, cv::INTER_AREA);
  return overlap(coverage, mask);
}

namespace {

// A soft edge for a binary cut-out: each pixel on either side of its edge takes the alpha that unmixes its colour
// between the foreground's and the background's nearby (the mean colours of the pixels at least 2 px inside and
// outside the edge, in the 9 x 9 window around it), alpha = (c - B).(F - B) / |F - B|^2, where the two differ enough to tell (a plain matting step, after
// Chuang et al. 2001's compositing model with the colours known). The silhouette's distance reads the edge where
// alpha crosses 1/2: within a pixel's fraction, where the binary cut's staircase is half a pixel off either way.
// `rgb` and `binary` are of one size (the photo's stored pixels).
cv::Mat softEdge(const cv::Mat& rgb, const cv::Mat& binary) {
  cv::Mat colour;
  const double unit = rgb.depth() == CV_8U ? 1.0 / 255 : rgb.depth() == CV_16U ? 1.0 / 65535 : 1.0;
  rgb.convertTo(colour, CV_32FC3, unit);
  cv::Mat inner, outer, near;
  const cv::Mat square = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(3, 3));
  cv::erode(binary, inner, square, cv::Point(-1, -1), 2);
  cv::erode(binary == 0, outer, square, cv::Point(-1, -1), 2);
  cv::Mat shrunk, grown;
  cv::erode(binary, shrunk, square);
  cv::dilate(binary, grown, square);
  near = grown != shrunk;  // the pixels on either side of the edge
  const auto meanOver = [&](const cv::Mat& where, cv::Mat& mean, cv::Mat& weight) {
    cv::Mat w, masked;
    where.convertTo(w, CV_32F, 1.0 / 255);
    cv::Mat w3;
    cv::merge(std::vector<cv::Mat>{w, w, w}, w3);
    masked = colour.mul(w3);
    cv::boxFilter(masked, mean, -1, cv::Size(9, 9), cv::Point(-1, -1), false);
    cv::boxFilter(w, weight, -1, cv::Size(9, 9), cv::Point(-1, -1), false);
  };
  cv::Mat fgSum, fgWeight, bgSum, bgWeight;
  meanOver(inner, fgSum, fgWeight);
  meanOver(outer, bgSum, bgWeight);
  cv::Mat alpha;
  binary.convertTo(alpha, CV_32F, 1.0 / 255);
  for (int y = 0; y < binary.rows; ++y)
    for (int x = 0; x < binary.cols; ++x) {
      if (!near.at<uchar>(y, x)) continue;
      const float wf = fgWeight.at<float>(y, x), wb = bgWeight.at<float>(y, x);
      if (wf < 3 || wb < 3) continue;  // too few pixels of either side nearby to tell their colours
      const cv::Vec3f f = fgSum.at<cv::Vec3f>(y, x) / wf, b = bgSum.at<cv::Vec3f>(y, x) / wb;
      const cv::Vec3f d = f - b;
      const float span = d.dot(d);
      if (span < 0.01f) continue;  // the two sides' colours too close: the binary edge stays
      alpha.at<float>(y, x) = std::clamp((colour.at<cv::Vec3f>(y, x) - b).dot(d) / span, 0.0f, 1.0f);
    }
  cv::Mat out;
  alpha.convertTo(out, CV_8U, 255);
  return out;
}

}  // namespace

FoundSilhouette findSilhouette(const Mesh& mesh, const Photo& photo, const PhotoCamera& camera, double thresholdPx,
                               const FoundSilhouetteOptions& o) {
  const auto start = Clock::now();
  FoundSilhouette out;
  out.bandPx = std::max(o.minBandPx, o.bandThresholds * thresholdPx);
  const auto done = [&](const std::string& why) {
    out.why = why;
    out.seconds = secondsSince(start);
    return out;
  };
  if (photo.rgb.empty() || camera.pinhole.width != photo.width || camera.pinhole.height != photo.height)
    return done("the camera is not of the photo's size");
  const cv::Mat coverage = projectedCoverage(mesh, camera);
  // Distances to the outline, inside and out: certain foreground beyond the band inside, certain background beyond
  // it outside, the band between uncertain on the outline's side.
  cv::Mat inside, outside;
  cv::distanceTransform(coverage, inside, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  cv::distanceTransform(coverage == 0, outside, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  const float band = static_cast<float>(out.bandPx);
  cv::Mat labels(coverage.size(), CV_8UC1, cv::Scalar(cv::GC_PR_BGD));
  labels.setTo(cv::Scalar(cv::GC_BGD), outside > band);
  labels.setTo(cv::Scalar(cv::GC_PR_FGD), coverage);
  labels.setTo(cv::Scalar(cv::GC_FGD), inside > band);
  if (cv::countNonZero(labels == cv::GC_FGD) == 0)
    return done("the mesh's outline is narrower than the band (" + formatFixed(2 * out.bandPx, 0) + " px)");
  if (cv::countNonZero(labels == cv::GC_BGD) == 0) return done("the mesh's outline leaves no background in the photo");
  Cutout cut(photo.rgb, o.cutout, cv::Size(photo.width, photo.height));
  cut.startFromTrimap(labels);
  const cv::Mat mask = cut.binaryMask();
  out.iou = overlap(mask, coverage);
  // The found edge, and how much of it runs along the band's limits.
  cv::Mat shrunk;
  cv::erode(mask, shrunk, cv::Mat());
  const cv::Mat edge = mask != shrunk;
  const cv::Mat limit = (cv::abs(inside - band) < 1.0f) | (cv::abs(outside - band) < 1.0f);
  const int edgePixels = cv::countNonZero(edge);
  out.atLimit = edgePixels > 0 ? double(cv::countNonZero(edge & limit)) / edgePixels : 1;
  if (out.iou < o.minIoU)
    return done("the cut-out found around the outline covers " + formatFixed(100 * out.iou, 1) +
                "% of it jointly (intersection over union; needs " + formatFixed(100 * o.minIoU, 0) + "%)");
  if (out.atLimit > o.maxAtLimit)
    return done(formatFixed(100 * out.atLimit, 1) + "% of the edge found runs along the band's limits, " +
                formatFixed(out.bandPx, 1) +
                " px from the outline (more of the object than the mesh, or a background "
                "GrabCut cannot tell from it)");
  out.found = true;
  if (mask.size() == photo.rgb.size()) {
    out.mask = softEdge(photo.rgb, mask);
  } else {  // a working resolution: the stored pixels' share of the cut
    cv::resize(mask, out.mask, photo.rgb.size(), 0, 0, cv::INTER_AREA);
  }
  return done("found around the mesh's outline: " + formatFixed(100 * out.iou, 1) + "% of it jointly, " +
              formatFixed(100 * out.atLimit, 1) + "% of its edge at the band's limits");
}

Photo withForeground(const Photo& photo, const cv::Mat& mask) {
  Photo out = photo;
  out.distance.release();
  if (mask.size() == photo.rgb.size())
    out.alpha = mask;
  else
    cv::resize(mask, out.alpha, photo.rgb.size(), 0, 0, cv::INTER_AREA);
  out.hasBackground = true;
  return out;
}

}  // namespace montage
