// Camera fit per photo (see camera.h).
//
// Choices beyond the outline:
// - Start: the principal point is known (the image centre) and pixels are square, so the only unknown
//   intrinsic is the focal length. A sweep of log-spaced focal lengths over the plausible field of
//   view, each with OpenCV's RANSAC PnP (EPnP on minimal samples, iterative PnP on the inliers), gives
//   pose hypotheses; the one with the lowest MSAC score (sum of min(r^2, tau^2)) starts the refinement.
//   This works for planar and non-planar click sets alike (a DLT start needs non-planar points).
// - Refinement: Levenberg-Marquardt (OpenCV's LMSolver) over rotation vector, translation, focal and
//   the radial terms, with the Jacobian of cv::projectPoints. Object points are centred on their mean
//   first, so the translation is well conditioned whatever the mesh's units and placement.
// - Radial distortion is kept only when an F-test says its terms explain more than noise (F >
//   distortionF): on an undistorted photo they would fit the click noise, and the projection of the
//   unclicked surface, far from the clicks, would suffer for it (bob, 15 clicks with 1 px noise:
//   k1 = 0.08 and 9 dB lost).
#include "mapping/camera.h"

#include <tbb/parallel_for.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <sstream>

#include "base/util.h"
#include "geometry/mesh.h"
#include "image/photo.h"
#include "io/project.h"

namespace montage {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// The parameters LM works on: rotation vector, translation (of the centred points), focal, radial terms.
struct Params {
  cv::Vec3d rvec, tvec;
  double focal = 1;
  double k1 = 0, k2 = 0;
};

cv::Matx33d intrinsics(double focal, double cx, double cy) {
  return cv::Matx33d(focal, 0, cx, 0, focal, cy, 0, 0, 1);
}

// Projection of the centred object points with OpenCV's model; optionally the Jacobian (2N x 14 for
// rvec, tvec, fx, fy, cx, cy, k1, k2, p1, p2).
void projectAll(const std::vector<cv::Point3d>& obj, const Params& p, double cx, double cy,
                std::vector<cv::Point2d>& out, cv::Mat* jacobian = nullptr) {
  const cv::Vec4d dist(p.k1, p.k2, 0, 0);
  if (jacobian)
    cv::projectPoints(obj, p.rvec, p.tvec, intrinsics(p.focal, cx, cy), dist, out, *jacobian);
  else
    cv::projectPoints(obj, p.rvec, p.tvec, intrinsics(p.focal, cx, cy), dist, out);
}

// Depth (camera z) of a centred object point.
double depthOf(const cv::Point3d& q, const Params& p) {
  cv::Matx33d R;
  cv::Rodrigues(p.rvec, R);
  const cv::Vec3d c = R * cv::Vec3d(q.x, q.y, q.z) + p.tvec;
  return c[2];
}

// Residual distances of every click (inf behind the camera).
std::vector<double> residuals(const std::vector<cv::Point3d>& obj, const std::vector<cv::Point2d>& img, const Params& p,
                              double cx, double cy) {
  std::vector<cv::Point2d> proj;
  projectAll(obj, p, cx, cy, proj);
  std::vector<double> r(obj.size());
  for (size_t i = 0; i < obj.size(); ++i) {
    const bool front = depthOf(obj[i], p) > 0;
    r[i] = front ? std::hypot(proj[i].x - img[i].x, proj[i].y - img[i].y) : kInf;
    if (!std::isfinite(r[i])) r[i] = kInf;
  }
  return r;
}

double msac(const std::vector<double>& r, double tau) {
  double s = 0;
  for (double x : r) s += std::min(x * x, tau * tau);
  return s;
}

// The clicked vertices about their centroid (a well-conditioned PnP) and their pixels, as OpenCV takes them.
struct CentredClicks {
  Vec3 centre = Vec3::Zero();
  std::vector<cv::Point3d> object;
  std::vector<cv::Point2d> image;
};

CentredClicks centredClicks(const Mesh& mesh, const std::vector<CameraClick>& clicks) {
  CentredClicks c;
  for (const CameraClick& k : clicks) c.centre += mesh.position(k.vertex);
  c.centre /= std::max<size_t>(clicks.size(), 1);
  for (const CameraClick& k : clicks) {
    const Vec3 q = mesh.position(k.vertex) - c.centre;
    c.object.emplace_back(q.x(), q.y(), q.z());
    c.image.emplace_back(k.pixel.x(), k.pixel.y());
  }
  return c;
}

// A prior on the focal length (the EXIF's): one more residual, weight x (focal - focal0), in the clicks' units: weight
// = the clicks' noise per axis over the prior's deviation in pixels. weight 0: none.
struct FocalPrior {
  double focal = 0, weight = 0;
  // The prior of options (focalPriorPx, focalPriorSigma) against clicks of `clickNoisePx` per axis.
  static FocalPrior of(const CameraFitOptions& o, double clickNoisePx) {
    if (!(o.focalPriorPx > 0) || !(o.focalPriorSigma > 0)) return {};
    return {o.focalPriorPx, std::max(clickNoisePx, 0.1) / (o.focalPriorSigma * o.focalPriorPx)};
  }
  double residual(double f) const { return weight * (f - focal); }  // its derivative in f is `weight`
};

// LM callback: residuals (projection - click) of the selected clicks, with the chosen free parameters.
class Reprojection : public cv::LMSolver::Callback {
 public:
  // `weights` (may be empty: all 1): per click, the weight of its squared residual.
  // `fixedFocal` > 0: the focal length is held at it (pose only; no radial terms).
  Reprojection(const std::vector<cv::Point3d>& obj, const std::vector<cv::Point2d>& img, double cx, double cy,
               int radialTerms, std::vector<double> weights = {}, double fixedFocal = 0)
      : obj_(obj),
        img_(img),
        cx_(cx),
        cy_(cy),
        radial_(fixedFocal > 0 ? 0 : radialTerms),
        sqrtWeight_(std::move(weights)),
        fixedFocal_(fixedFocal) {
    for (double& w : sqrtWeight_) w = std::sqrt(std::max(0.0, w));
  }
  void setPrior(const FocalPrior& prior) { prior_ = fixedFocal_ > 0 ? FocalPrior{} : prior; }

  int numParams() const { return fixedFocal_ > 0 ? 6 : 7 + radial_; }
  cv::Mat pack(const Params& p) const {
    cv::Mat x(numParams(), 1, CV_64F);
    for (int i = 0; i < 3; ++i) x.at<double>(i) = p.rvec[i], x.at<double>(3 + i) = p.tvec[i];
    if (fixedFocal_ > 0) return x;
    x.at<double>(6) = p.focal;
    if (radial_ >= 1) x.at<double>(7) = p.k1;
    if (radial_ >= 2) x.at<double>(8) = p.k2;
    return x;
  }
  Params unpack(const cv::Mat& x) const {
    Params p;
    for (int i = 0; i < 3; ++i) p.rvec[i] = x.at<double>(i), p.tvec[i] = x.at<double>(3 + i);
    p.focal = fixedFocal_ > 0 ? fixedFocal_ : x.at<double>(6);
    p.k1 = radial_ >= 1 ? x.at<double>(7) : 0;
    p.k2 = radial_ >= 2 ? x.at<double>(8) : 0;
    return p;
  }

  bool compute(cv::InputArray param, cv::OutputArray err, cv::OutputArray J) const override {
    const Params p = unpack(param.getMat());
    const int n = static_cast<int>(obj_.size());
    std::vector<cv::Point2d> proj;
    cv::Mat full;
    projectAll(obj_, p, cx_, cy_, proj, J.needed() ? &full : nullptr);
    const int rows = 2 * n + (prior_.weight > 0);
    err.create(rows, 1, CV_64F);
    cv::Mat e = err.getMat();
    if (prior_.weight > 0) e.at<double>(2 * n) = prior_.residual(p.focal);
    auto weight = [&](int row) { return sqrtWeight_.empty() ? 1.0 : sqrtWeight_[row / 2]; };
    for (int i = 0; i < n; ++i) {
      e.at<double>(2 * i) = weight(2 * i) * (proj[i].x - img_[i].x);
      e.at<double>(2 * i + 1) = weight(2 * i) * (proj[i].y - img_[i].y);
    }
    if (J.needed()) {
      J.create(rows, numParams(), CV_64F);
      cv::Mat j = J.getMat();
      if (prior_.weight > 0) j.row(2 * n).setTo(0), j.at<double>(2 * n, 6) = prior_.weight;
      for (int r = 0; r < 2 * n; ++r) {
        const double w = weight(r);
        for (int c = 0; c < 6; ++c) j.at<double>(r, c) = w * full.at<double>(r, c);
        if (fixedFocal_ > 0) continue;
        j.at<double>(r, 6) = w * (full.at<double>(r, 6) + full.at<double>(r, 7));  // fx = fy = focal
        if (radial_ >= 1) j.at<double>(r, 7) = w * full.at<double>(r, 10);
        if (radial_ >= 2) j.at<double>(r, 8) = w * full.at<double>(r, 11);
      }
    }
    return true;
  }

 private:
  const std::vector<cv::Point3d>& obj_;
  const std::vector<cv::Point2d>& img_;
  double cx_, cy_;
  int radial_;
  std::vector<double> sqrtWeight_;
  double fixedFocal_;
  FocalPrior prior_;
};

// LM from `start` on the clicks `use` selects (weighted by `weights` when given: one per click).
Params refine(const std::vector<cv::Point3d>& obj, const std::vector<cv::Point2d>& img, const std::vector<char>& use,
              const Params& start, double cx, double cy, int radialTerms, const std::vector<double>& weights = {},
              bool fixFocal = false, const FocalPrior& prior = {}) {
  std::vector<cv::Point3d> o;
  std::vector<cv::Point2d> m;
  std::vector<double> w;
  for (size_t i = 0; i < obj.size(); ++i)
    if (use[i]) o.push_back(obj[i]), m.push_back(img[i]), w.push_back(weights.empty() ? 1.0 : weights[i]);
  auto callback = cv::makePtr<Reprojection>(o, m, cx, cy, radialTerms, weights.empty() ? std::vector<double>() : w,
                                            fixFocal ? start.focal : 0.0);
  callback->setPrior(prior);
  cv::Mat x = callback->pack(start);
  cv::Ptr<cv::LMSolver> solver = cv::LMSolver::create(callback, 200, 1e-12);
  try {
    solver->run(x);
  } catch (const cv::Exception&) {
    return start;  // degenerate set: keep the start
  }
  Params p = callback->unpack(x);
  if (!std::isfinite(p.focal) || p.focal <= 0) return start;
  return p;
}

double rmsOf(const std::vector<double>& r, const std::vector<char>& use) {
  double s = 0;
  int n = 0;
  for (size_t i = 0; i < r.size(); ++i)
    if (use[i]) s += r[i] * r[i], ++n;
  return n ? std::sqrt(s / n) : kInf;
}

std::vector<char> agreeing(const std::vector<double>& r, double tau) {
  std::vector<char> in(r.size());
  for (size_t i = 0; i < r.size(); ++i) in[i] = r[i] < tau;
  return in;
}

int countOf(const std::vector<char>& v) {
  return static_cast<int>(std::count(v.begin(), v.end(), 1));
}

}  // namespace

bool PhotoCamera::project(const Vec3& p, Vec2& pixel, double* depth) const {
  const Vec3 c = pinhole.toCamera(p);
  if (depth) *depth = c.z();
  if (!(c.z() > 1e-12)) return false;
  const double x = c.x() / c.z(), y = c.y() / c.z();
  const double r2 = x * x + y * y;
  const double s = 1 + k1 * r2 + k2 * r2 * r2;
  pixel = Vec2(pinhole.fx * x * s + pinhole.cx, pinhole.fy * y * s + pinhole.cy);
  return true;
}

double PhotoCamera::fovYDeg() const {
  return 2 * std::atan(0.5 * pinhole.height / pinhole.fy) * 180 / M_PI;
}

std::vector<CameraClick> photoClicks(const Project& project, int photo) {
  std::vector<CameraClick> clicks;
  for (size_t i = 0; i < project.points.size(); ++i)
    for (const PhotoPoint& at : project.points[i].at)
      if (at.photo == photo) clicks.push_back(CameraClick{static_cast<int>(i), project.points[i].vertex, {at.x, at.y}});
  return clicks;
}

namespace {

// The clicks' noise, pixels per axis (CameraFit::noisePx). Two estimates, each an upper bound, the smaller kept:
// the agreeing clicks' residuals (their median square over chi-square(2)'s median, 2 ln 2, scaled by the degrees of
// freedom the camera's parameters take), which a misfit the camera cannot explain (a lens term it dropped, a mesh
// that differs from the photo) inflates; and the differences between each agreeing click's residual and its nearest
// agreeing neighbour's on the surface (a variogram's nugget), which a smooth misfit barely enters. 0 with too few
// clicks to tell.
double clickNoise(const Mesh& mesh, const CameraFit& fit) {
  std::vector<int> in;
  for (size_t i = 0; i < fit.clicks.size(); ++i)
    if (fit.inlier[i] && std::isfinite(fit.residual[i])) in.push_back(static_cast<int>(i));
  const int n = static_cast<int>(in.size());
  const int parameters = 7 + (fit.camera.k1 != 0) + (fit.camera.k2 != 0);
  const int dof = 2 * n - parameters;
  if (n < 6 || dof < 8) return 0;
  constexpr double kChi2Median = 1.3862943611198906;  // 2 ln 2
  const auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  std::vector<double> own(n), pair(n);
  for (int a = 0; a < n; ++a) {
    const int i = in[a];
    const Vec2 r = fit.clicks[i].pixel - fit.reprojected[i];
    own[a] = r.squaredNorm();
    const Vec3 p = mesh.position(fit.clicks[i].vertex);
    double nearest = kInf;
    for (int b = 0; b < n; ++b) {
      const int j = in[b];
      const double d = b == a ? kInf : (mesh.position(fit.clicks[j].vertex) - p).squaredNorm();
      if (d < nearest) nearest = d, pair[a] = (r - (fit.clicks[j].pixel - fit.reprojected[j])).squaredNorm();
    }
  }
  const double global = median(own) / kChi2Median * (2.0 * n / dof);
  const double nugget = median(pair) / (2 * kChi2Median);
  return std::sqrt(std::min(global, nugget));
}

// The camera in world coordinates from LM's parameters on points centred on `centre`:
// p_cam = R (x - centre) + t = R x + (t - R centre).
void setCamera(PhotoCamera& camera, const Params& p, const Vec3& centre) {
  cv::Matx33d R;
  cv::Rodrigues(p.rvec, R);
  Camera& cam = camera.pinhole;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) cam.R(r, c) = R(r, c);
  cam.t = Vec3(p.tvec[0], p.tvec[1], p.tvec[2]) - cam.R * centre;
  cam.fx = cam.fy = p.focal;
  camera.k1 = p.k1;
  camera.k2 = p.k2;
}

// LM's parameters (on points centred on `centre`) of a world camera.
Params paramsOf(const PhotoCamera& camera, const Vec3& centre) {
  const Camera& c = camera.pinhole;
  cv::Matx33d R;
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k) R(r, k) = c.R(r, k);
  cv::Mat rvec;
  cv::Rodrigues(R, rvec);
  Params p;
  p.rvec = cv::Vec3d(rvec);
  const Vec3 t = c.t + c.R * centre;
  p.tvec = cv::Vec3d(t.x(), t.y(), t.z());
  p.focal = c.fx;
  p.k1 = camera.k1;
  p.k2 = camera.k2;
  return p;
}

void checkInputs(const Mesh& mesh, const std::vector<CameraClick>& clicks, int width, int height) {
  TM_CHECK(width > 0 && height > 0,
           "camera fit: photo size " + std::to_string(width) + "x" + std::to_string(height) + " must be positive");
  for (size_t i = 0; i < clicks.size(); ++i)
    TM_CHECK(clicks[i].vertex >= 0 && clicks[i].vertex < mesh.numVertices(),
             "camera fit: clicks[" + std::to_string(i) + "].vertex: " + std::to_string(clicks[i].vertex) +
                 " is not a vertex of the mesh (" + std::to_string(mesh.numVertices()) + " vertices)");
}

}  // namespace

void measureClicks(const Mesh& mesh, CameraFit& fit) {
  const size_t n = fit.clicks.size();
  fit.reprojected.assign(n, Vec2::Constant(std::numeric_limits<double>::quiet_NaN()));
  fit.residual.assign(n, kInf);
  fit.inlier.assign(n, 0);
  std::vector<double> in;
  for (size_t i = 0; i < n; ++i) {
    Vec2 px;
    if (!fit.camera.project(mesh.position(fit.clicks[i].vertex), px)) continue;
    fit.reprojected[i] = px;
    fit.residual[i] = (px - fit.clicks[i].pixel).norm();
    fit.inlier[i] = fit.residual[i] < fit.thresholdPx;
    if (fit.inlier[i]) in.push_back(fit.residual[i]);
  }
  fit.inliers = static_cast<int>(in.size());
  fit.medianResidual = fit.maxResidual = fit.rmsResidual = 0;
  if (!in.empty()) {
    std::sort(in.begin(), in.end());
    fit.medianResidual = in.size() % 2 ? in[in.size() / 2] : 0.5 * (in[in.size() / 2 - 1] + in[in.size() / 2]);
    fit.maxResidual = in.back();
    double s = 0;
    for (double r : in) s += r * r;
    fit.rmsResidual = std::sqrt(s / in.size());
  }
  fit.noisePx = clickNoise(mesh, fit);
}

std::vector<char> fittingPhotos(const std::vector<CameraFit>& fits) {
  std::vector<char> out;
  for (const CameraFit& fit : fits) out.push_back(fit.fits && !fit.subject);
  return out;
}

CameraFit fitCamera(const Mesh& mesh, const std::vector<CameraClick>& clicks, int width, int height,
                    const CameraFitOptions& o, const PhotoCamera* startCamera) {
  const auto start = Clock::now();
  checkInputs(mesh, clicks, width, height);
  TM_CHECK(o.minInliers >= 4, "camera fit: minInliers: must be >= 4 (got " + std::to_string(o.minInliers) + ")");
  TM_CHECK(o.minFovDeg > 0 && o.maxFovDeg < 180 && o.minFovDeg < o.maxFovDeg,
           "camera fit: field of view range must satisfy 0 < minFovDeg < maxFovDeg < 180");
  CameraFit fit;
  fit.clicks = clicks;
  const double cx = 0.5 * width, cy = 0.5 * height;
  fit.thresholdPx = std::max(o.minThresholdPx, o.thresholdFraction * std::hypot(width, height));
  const double tau = fit.thresholdPx;
  const int n = static_cast<int>(clicks.size());
  fit.camera.pinhole.width = width;
  fit.camera.pinhole.height = height;
  fit.camera.pinhole.cx = cx;
  fit.camera.pinhole.cy = cy;
  auto finish = [&](const std::string& reason) {
    fit.reason = reason;
    fit.seconds = secondsSince(start);
    return fit;
  };
  auto noCamera = [&] {
    fit.reprojected.assign(n, Vec2::Constant(std::numeric_limits<double>::quiet_NaN()));
    fit.residual.assign(n, kInf);
    fit.inlier.assign(n, 0);
  };
  if (n < o.minInliers) {
    noCamera();
    return finish(std::to_string(n) + " clicks: at least " + std::to_string(o.minInliers) +
                  " are needed to fit a camera");
  }

  auto [centre, obj, img] = centredClicks(mesh, clicks);

  // Start: the given camera, or a focal sweep x RANSAC PnP with the best MSAC score. RANSAC's pose on its
  // inliers is EPnP's, not Levenberg-Marquardt's: the refinement below polishes the chosen start, and the
  // scores pick the same focal (same fits on the test scenes, a quarter less time).
  Params best;
  double bestScore = kInf;
  if (startCamera && startCamera->pinhole.width == width && startCamera->pinhole.height == height) {
    best = paramsOf(*startCamera, centre);
    best.k1 = best.k2 = 0;
    bestScore = msac(residuals(obj, img, best, cx, cy), tau);
  }
  const double halfSize = 0.5 * std::max(width, height);
  const double fLo = halfSize / std::tan(0.5 * o.maxFovDeg * M_PI / 180);
  const double fHi = halfSize / std::tan(0.5 * o.minFovDeg * M_PI / 180);
  const int samples = std::isfinite(bestScore) ? 0 : std::max(2, o.focalSamples);
  constexpr int kSampleSize = 5;  // solvePnPRansac's EPnP samples
  constexpr double kConfidence = 0.999;
  const double allAgree = std::pow(std::clamp(o.minInlierRatio, 0.01, 0.99), kSampleSize);
  const int iterations =  // at most 1000: a low minInlierRatio would ask for millions
      o.ransacIterations > 0
          ? o.ransacIterations
          : static_cast<int>(std::min(1000.0, std::ceil(std::log(1 - kConfidence) / std::log1p(-allAgree))));
  cv::theRNG().state = 0x9E3779B97F4A7C15ull ^ o.seed;
  std::vector<double> focals;
  for (int s = 0; s < samples; ++s) focals.push_back(fLo * std::pow(fHi / fLo, double(s) / (samples - 1)));
  if (samples > 0 && o.focalPriorPx > 0) focals.push_back(o.focalPriorPx);  // the EXIF's, when it tells
  for (double focal : focals) {
    Params p;
    p.focal = focal;
    cv::Mat rvec, tvec;
    std::vector<int> inl;
    try {
      if (!cv::solvePnPRansac(obj, img, intrinsics(p.focal, cx, cy), cv::noArray(), rvec, tvec, false, iterations,
                              static_cast<float>(tau), kConfidence, inl, cv::SOLVEPNP_EPNP))
        continue;
    } catch (const cv::Exception&) {
      continue;  // degenerate sample set for this focal
    }
    p.rvec = cv::Vec3d(rvec.reshape(1, 3));
    p.tvec = cv::Vec3d(tvec.reshape(1, 3));
    const double score = msac(residuals(obj, img, p, cx, cy), tau);
    if (score < bestScore) bestScore = score, best = p;
  }
  if (!std::isfinite(bestScore)) {
    noCamera();
    return finish("no camera agrees with the clicks for any focal length: a photo of another subject");
  }

  // Refinement on the agreeing clicks, re-classified until stable.
  auto refineLoop = [&](Params p, int radial, const FocalPrior& prior = {}) {
    std::vector<char> in = agreeing(residuals(obj, img, p, cx, cy), tau);
    for (int round = 0; round < 8; ++round) {
      if (countOf(in) < 4) break;
      p = refine(obj, img, in, p, cx, cy, radial, {}, false, prior);
      std::vector<char> next = agreeing(residuals(obj, img, p, cx, cy), tau);
      if (next == in) break;
      in.swap(next);
    }
    return p;
  };
  Params p = refineLoop(best, 0);
  if (o.radialDistortion) {
    const std::vector<char> in = agreeing(residuals(obj, img, p, cx, cy), tau);
    const int count = countOf(in);
    // Below minDistortionRmsPx there is nothing left for radial terms to explain.
    if (count >= o.minInliersForDistortion && rmsOf(residuals(obj, img, p, cx, cy), in) > o.minDistortionRmsPx) {
      const int radial = count >= 20 ? 2 : 1;
      const Params q = refineLoop(p, radial);
      const std::vector<double> rq = residuals(obj, img, q, cx, cy);
      const std::vector<char> inq = agreeing(rq, tau);
      // F-test of the extra radial terms on the same clicks: on an undistorted photo they only fit noise.
      const double rss0 = std::pow(rmsOf(residuals(obj, img, p, cx, cy), in), 2) * count;
      const double rss1 = std::pow(rmsOf(rq, in), 2) * count;
      const int dof = 2 * count - 7 - radial;
      const double f = dof > 0 && rss1 > 0 ? ((rss0 - rss1) / radial) / (rss1 / dof) : 0;
      CameraFit::RadialTrial& trial = fit.radialTrial;
      trial = {radial, rss0 - rss1, rss1, dof, countOf(inq) >= count, false};
      trial.kept = trial.agrees && f > o.distortionF;
      fit.radialPooled = trial.agrees && !trial.kept && o.keepRadial;
      if (trial.kept || fit.radialPooled) p = q;
    }
  }
  // The EXIF's focal length as a prior (of focalPriorSigma), kept when the clicks agree with it: their sum of squares
  // rises by no more than chi-square's 99% quantile with one degree of freedom times their variance. A photo cropped
  // after it was taken keeps its EXIF, whose focal length then no longer fits its frame: the clicks refuse it.
  if (o.focalPriorPx > 0) {
    const std::vector<char> in = agreeing(residuals(obj, img, p, cx, cy), tau);
    const int count = countOf(in);
    const int radial = p.k2 != 0 ? 2 : p.k1 != 0 ? 1 : 0;
    const int dof = 2 * count - 7 - radial;
    if (count >= 4 && dof > 0) {
      const double rss = std::pow(rmsOf(residuals(obj, img, p, cx, cy), in), 2) * count;
      const FocalPrior prior = FocalPrior::of(o, std::sqrt(rss / dof));
      const Params q = refineLoop(p, radial, prior);
      const std::vector<double> rq = residuals(obj, img, q, cx, cy);
      const double rssQ = std::pow(rmsOf(rq, in), 2) * count;
      constexpr double kChi2Quantile99 = 6.635;  // one degree of freedom
      const bool agrees = countOf(agreeing(rq, tau)) >= count && rssQ - rss <= kChi2Quantile99 * rss / dof;
      fit.focalPrior = agrees ? 1 : -1;
      if (agrees) p = q;
    }
  }

  setCamera(fit.camera, p, centre);
  measureClicks(mesh, fit);

  const double fov = fit.camera.fovYDeg();
  const double share = double(fit.inliers) / n;
  if (fit.inliers < o.minInliers)
    return finish("only " + std::to_string(fit.inliers) + " of " + std::to_string(n) + " clicks agree within " +
                  formatFixed(tau, 1) + " px (at least " + std::to_string(o.minInliers) +
                  " needed): a photo of another subject");
  if (share < o.minInlierRatio)
    return finish("only " + std::to_string(fit.inliers) + " of " + std::to_string(n) + " clicks (" +
                  formatFixed(100 * share, 0) + "%) agree within " + formatFixed(tau, 1) + " px (at least " +
                  formatFixed(100 * o.minInlierRatio, 0) + "% needed): a photo of another subject");
  if (!(fov >= o.minFovDeg && fov <= o.maxFovDeg))
    return finish("implausible field of view " + formatFixed(fov, 1) + " degrees");
  fit.fits = true;
  return finish(describeFit(fit));
}

CameraFit fitCameraToEveryClick(const Mesh& mesh, const std::vector<CameraClick>& clicks, int width, int height,
                                const CameraFitOptions& o, const CameraFit& start) {
  const auto begin = Clock::now();
  checkInputs(mesh, clicks, width, height);
  CameraFit fit;
  fit.subject = true;
  fit.clicks = clicks;
  fit.thresholdPx = std::max(o.minThresholdPx, o.thresholdFraction * std::hypot(width, height));
  const double cx = 0.5 * width, cy = 0.5 * height;
  const int n = static_cast<int>(clicks.size());
  PhotoCamera& camera = fit.camera;
  camera.pinhole.width = width;
  camera.pinhole.height = height;
  camera.pinhole.cx = cx;
  camera.pinhole.cy = cy;
  auto finish = [&](const std::string& reason) {
    fit.reason = reason;
    fit.seconds = secondsSince(begin);
    return fit;
  };
  if (n < o.minInliers) {
    fit.reprojected.assign(n, Vec2::Constant(std::numeric_limits<double>::quiet_NaN()));
    fit.residual.assign(n, kInf);
    fit.inlier.assign(n, 0);
    return finish(std::to_string(n) + " clicks: at least " + std::to_string(o.minInliers) +
                  " are needed for a camera and warp");
  }
  auto [centre, obj, img] = centredClicks(mesh, clicks);
  // Robust cost: Cauchy with scale c, summed over every click (none is left out).
  auto cauchy = [](const std::vector<double>& r, double c) {
    double s = 0;
    for (double x : r) s += std::isfinite(x) ? std::log1p((x / c) * (x / c)) : 1e3;
    return s;
  };
  auto spreadOf = [](std::vector<double> r) {
    std::sort(r.begin(), r.end());
    return r.empty() ? 0.0 : 1.4826 * r[r.size() / 2];
  };
  // Starts: the object fit's best camera when it has one, and EPnP on every click over a focal sweep.
  std::vector<Params> starts;
  if (start.inliers >= 4 && start.camera.pinhole.width == width && start.camera.pinhole.height == height) {
    Params p = paramsOf(start.camera, centre);
    p.k1 = p.k2 = 0;
    starts.push_back(p);
  }
  const double halfSize = 0.5 * std::max(width, height);
  const std::vector<char> all(n, 1);
  {
    // The affine camera of every click (least squares), as a long-lens perspective camera: the scaled rotation
    // closest to its 2 x 3 matrix, far enough that every click is in front. EPnP on clicks that no camera
    // explains can put some behind it; this start never does.
    Eigen::Matrix4d normal = Eigen::Matrix4d::Zero();
    Eigen::Matrix<double, 4, 2> rhs = Eigen::Matrix<double, 4, 2>::Zero();
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector4d x(obj[i].x, obj[i].y, obj[i].z, 1);
      normal += x * x.transpose();
      rhs.col(0) += x * img[i].x;
      rhs.col(1) += x * img[i].y;
    }
    const Eigen::Matrix<double, 4, 2> a = normal.ldlt().solve(rhs);
    Eigen::Matrix<double, 2, 3> m;
    m.row(0) = a.col(0).head<3>().transpose();
    m.row(1) = a.col(1).head<3>().transpose();
    Eigen::JacobiSVD<Eigen::Matrix<double, 2, 3>> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
    const double scale = 0.5 * (svd.singularValues()[0] + svd.singularValues()[1]);
    if (a.allFinite() && scale > 0) {
      const Eigen::Matrix<double, 2, 3> rows = svd.matrixU() * svd.matrixV().leftCols<2>().transpose();
      Eigen::Matrix3d R;
      R.row(0) = rows.row(0);
      R.row(1) = rows.row(1);
      R.row(2) = rows.row(0).cross(rows.row(1));
      Params p;
      p.focal = halfSize / std::tan(0.5 * 20.0 * M_PI / 180);
      const double tz = p.focal / scale;
      cv::Matx33d Rcv;
      for (int r = 0; r < 3; ++r)
        for (int k = 0; k < 3; ++k) Rcv(r, k) = R(r, k);
      cv::Mat rvec;
      cv::Rodrigues(Rcv, rvec);
      p.rvec = cv::Vec3d(rvec);
      p.tvec = cv::Vec3d((a(3, 0) - cx) / scale, (a(3, 1) - cy) / scale, tz);
      starts.push_back(p);
    }
  }
  for (double fov : {20.0, 35.0, 50.0, 70.0}) {
    Params p;
    p.focal = halfSize / std::tan(0.5 * fov * M_PI / 180);
    cv::Mat rvec, tvec;
    try {
      if (!cv::solvePnP(obj, img, intrinsics(p.focal, cx, cy), cv::noArray(), rvec, tvec, false,
                        n >= 6 ? cv::SOLVEPNP_EPNP : cv::SOLVEPNP_ITERATIVE))
        continue;
    } catch (const cv::Exception&) {
      continue;
    }
    p.rvec = cv::Vec3d(rvec.reshape(1, 3));
    p.tvec = cv::Vec3d(tvec.reshape(1, 3));
    starts.push_back(p);
  }
  // Iteratively reweighted LM on the pose from each start, its focal length held (a photo of another subject
  // says little about it, and left free it runs off to infinity); the lowest robust cost wins.
  Params best;
  double bestCost = kInf;
  for (Params p : starts) {
    double scale = fit.thresholdPx;
    for (int round = 0; round < 6; ++round) {
      const std::vector<double> r = residuals(obj, img, p, cx, cy);
      scale = std::max(fit.thresholdPx, spreadOf(r));
      std::vector<double> w(n);
      for (int i = 0; i < n; ++i) w[i] = std::isfinite(r[i]) ? 1 / (1 + (r[i] / scale) * (r[i] / scale)) : 1e-3;
      p = refine(obj, img, all, p, cx, cy, 0, w, true);
    }
    const double cost = cauchy(residuals(obj, img, p, cx, cy), fit.thresholdPx);
    if (cost < bestCost) bestCost = cost, best = p;
  }
  if (!std::isfinite(bestCost)) {
    fit.reprojected.assign(n, Vec2::Constant(std::numeric_limits<double>::quiet_NaN()));
    fit.residual.assign(n, kInf);
    fit.inlier.assign(n, 0);
    return finish("no camera places the clicks in front of it");
  }
  setCamera(camera, best, centre);
  measureClicks(mesh, fit);
  // Every click is kept: the warp makes each exact (none is an outlier).
  int behind = 0;
  for (int i = 0; i < n; ++i) behind += !std::isfinite(fit.residual[i]);
  if (behind > 0) return finish(std::to_string(behind) + " clicks lie behind every camera that places the others");
  fit.inlier.assign(n, 1);
  fit.inliers = n;
  std::vector<double> r = fit.residual;
  std::sort(r.begin(), r.end());
  fit.medianResidual = r[n / 2];
  fit.maxResidual = r.back();
  double ss = 0;
  for (double x : r) ss += x * x;
  fit.rmsResidual = std::sqrt(ss / n);
  fit.fits = true;
  return finish("another subject: a camera fitted to all " + std::to_string(n) + " clicks (median residual " +
                formatFixed(fit.medianResidual, 1) + " px, max " + formatFixed(fit.maxResidual, 1) +
                " px), warped to each click");
}

void SilhouetteDistance::make() const {
  const Photo& photo = *photo_;
  // Alpha in [0, 1] at the file's pixels (photos keep 8-bit alpha, maybe at a working resolution).
  photo.alpha.convertTo(alpha_, CV_32F, photo.alpha.depth() == CV_8U ? 1.0 / 255 : 1.0);
  if (alpha_.cols != photo.width || alpha_.rows != photo.height)
    cv::resize(alpha_, alpha_, cv::Size(photo.width, photo.height), 0, 0, cv::INTER_LINEAR);
  cv::Mat fg = alpha_ >= 0.5f, bg = alpha_ < 0.5f, in, out;
  cv::distanceTransform(fg, in, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  cv::distanceTransform(bg, out, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  coarse_ = cv::Mat(photo.height, photo.width, CV_32F);
  for (int y = 0; y < photo.height; ++y)
    for (int x = 0; x < photo.width; ++x) {
      const float o = out.at<float>(y, x), i = in.at<float>(y, x);
      coarse_.at<float>(y, x) = o > 0 ? o - 0.5f : -(i - 0.5f);
    }
}

double SilhouetteDistance::at(const Vec2& p) const {
  std::call_once(made_, [this] { make(); });
  const double d = sampleBilinear1(coarse_, p.x(), p.y());
  if (std::abs(d) > 1.5) return d;
  const double a = sampleBilinear1(alpha_, p.x(), p.y());
  const double gx = 0.5 * (sampleBilinear1(alpha_, p.x() + 1, p.y()) - sampleBilinear1(alpha_, p.x() - 1, p.y()));
  const double gy = 0.5 * (sampleBilinear1(alpha_, p.x(), p.y() + 1) - sampleBilinear1(alpha_, p.x(), p.y() - 1));
  const double g = std::hypot(gx, gy);
  return g > 0.1 ? std::clamp((0.5 - a) / g, -1.5, 1.5) : d;
}

Vec2 SilhouetteDistance::gradient(const Vec2& p) const {
  const double h = 0.25;
  return Vec2(at(p + Vec2(h, 0)) - at(p - Vec2(h, 0)), at(p + Vec2(0, h)) - at(p - Vec2(0, h))) / (2 * h);
}

std::vector<Vec3> outerContour(const Mesh& mesh, const Camera& camera, double spacingPx) {
  RasterOptions depthOnly;
  depthOnly.barycentrics = false;
  const RasterBuffers raster = rasterize(mesh, camera, depthOnly);
  // Within a pixel and a half of the rendered outline: an empty pixel among the 8 neighbours (the
  // nearest pixel centres beyond are 2 px away).
  auto nearOutline = [&](int c, int r) {
    for (int dr = -1; dr <= 1; ++dr)
      for (int dc = -1; dc <= 1; ++dc)
        if (raster.face[raster.index(c + dc, r + dr)] < 0) return true;
    return false;
  };
  Vec3 lo, hi;
  mesh.bounds(lo, hi);
  const double tol = 0.005 * (hi - lo).norm();
  const Vec3 eye = camera.center();
  const TriMesh& tri = mesh.tri;
  auto facing = [&](OpenMesh::FaceHandle f) {
    const auto q = mesh.facePositions(f.idx());
    return mesh.faceNormal(f.idx()).dot(eye - (q[0] + q[1] + q[2]) / 3) > 0;
  };
  // The edges in chunks, in parallel; the chunks' samples are joined in edge order (the same list as
  // one pass over the edges).
  constexpr int kChunk = 4096;
  const int ne = static_cast<int>(tri.n_edges());
  std::vector<std::vector<Vec3>> chunks((ne + kChunk - 1) / kChunk);
  tbb::parallel_for(size_t(0), chunks.size(), [&](size_t chunk) {
    std::vector<Vec3>& found = chunks[chunk];
    const int end = std::min(ne, static_cast<int>(chunk + 1) * kChunk);
    for (int e = static_cast<int>(chunk) * kChunk; e < end; ++e) {
      const OpenMesh::HalfedgeHandle h = tri.halfedge_handle(tri.edge_handle(e), 0);
      const OpenMesh::FaceHandle f0 = tri.face_handle(h), f1 = tri.opposite_face_handle(h);
      if (f0.is_valid() && f1.is_valid() && facing(f0) == facing(f1)) continue;
      const Vec3 a = mesh.position(tri.from_vertex_handle(h).idx()), b = mesh.position(tri.to_vertex_handle(h).idx());
      Vec2 pa, pb;
      if (!camera.project(a, pa) || !camera.project(b, pb)) continue;
      const int n = std::max(1, static_cast<int>(std::ceil((pa - pb).norm() / spacingPx)));
      for (int k = 0; k < n; ++k) {
        const Vec3 x = a + (b - a) * ((k + 0.5) / n);
        Vec2 px;
        double z = 0;
        if (!camera.project(x, px, &z)) continue;
        const int c = static_cast<int>(std::floor(px.x())), r = static_cast<int>(std::floor(px.y()));
        if (c < 1 || r < 1 || c >= camera.width - 1 || r >= camera.height - 1) continue;
        const int i = raster.index(c, r);
        if (raster.face[i] >= 0 && (raster.depth[i] < z - tol || !nearOutline(c, r))) continue;
        found.push_back(x);
      }
    }
  });
  std::vector<Vec3> out;
  for (const auto& found : chunks) out.insert(out.end(), found.begin(), found.end());
  return out;
}

namespace {

// LM residuals: the agreeing clicks (pixels) and the contour samples' signed distances to the photo's
// silhouette, weighted.
class SilhouetteFit : public cv::LMSolver::Callback {
 public:
  SilhouetteFit(const std::vector<cv::Point3d>& clicks3, const std::vector<cv::Point2d>& clicks2,
                const std::vector<cv::Point3d>& contour, const std::vector<double>& weights,
                const SilhouetteDistance& distance, double cx, double cy, int radialTerms)
      : base_(clicks3, clicks2, cx, cy, radialTerms),
        contour_(contour),
        weights_(weights),
        distance_(distance),
        cx_(cx),
        cy_(cy),
        radial_(radialTerms) {}
  cv::Mat pack(const Params& p) const { return base_.pack(p); }
  Params unpack(const cv::Mat& x) const { return base_.unpack(x); }

  bool compute(cv::InputArray param, cv::OutputArray err, cv::OutputArray J) const override {
    cv::Mat e0, j0;
    if (J.needed())
      base_.compute(param, e0, j0);
    else
      base_.compute(param, e0, cv::noArray());
    const Params p = unpack(param.getMat());
    std::vector<cv::Point2d> proj;
    cv::Mat full;
    projectAll(contour_, p, cx_, cy_, proj, J.needed() ? &full : nullptr);
    const int n0 = e0.rows, m = static_cast<int>(contour_.size()), np = base_.numParams();
    err.create(n0 + m, 1, CV_64F);
    cv::Mat e = err.getMat();
    e0.copyTo(e.rowRange(0, n0));
    if (J.needed()) {
      J.create(n0 + m, np, CV_64F);
      j0.copyTo(J.getMat().rowRange(0, n0));
    }
    for (int k = 0; k < m; ++k) {
      const Vec2 px(proj[k].x, proj[k].y);
      const double w = std::sqrt(weights_[k]);
      e.at<double>(n0 + k) = w * distance_.at(px);
      if (!J.needed()) continue;
      const Vec2 g = w * distance_.gradient(px);
      cv::Mat j = J.getMat();
      for (int c = 0; c < np; ++c) {
        auto d = [&](int row, int col) { return full.at<double>(2 * k + row, col); };
        double dx, dy;
        if (c < 6) {
          dx = d(0, c), dy = d(1, c);
        } else if (c == 6) {
          dx = d(0, 6) + d(0, 7), dy = d(1, 6) + d(1, 7);
        } else {
          dx = d(0, c + 3), dy = d(1, c + 3);  // k1 at column 10, k2 at 11
        }
        j.at<double>(n0 + k, c) = g.x() * dx + g.y() * dy;
      }
    }
    return true;
  }

 private:
  Reprojection base_;
  const std::vector<cv::Point3d>& contour_;
  const std::vector<double>& weights_;
  const SilhouetteDistance& distance_;
  double cx_, cy_;
  int radial_;
};

}  // namespace

void refineOnSilhouette(const Mesh& mesh, const Photo& photo, CameraFit& fit, const CameraFitOptions& o,
                        const SilhouetteDistance* silhouette, ContourMemo* memo) {
  if (!o.silhouette || !fit.fits || !photo.hasBackground || fit.rmsResidual < o.silhouetteMinClickRmsPx) return;
  if (photo.width != fit.camera.pinhole.width || photo.height != fit.camera.pinhole.height) return;
  const auto start = Clock::now();
  std::optional<SilhouetteDistance> own;
  if (!silhouette) silhouette = &own.emplace(photo);
  const SilhouetteDistance& distance = *silhouette;
  std::vector<cv::Point3d> clicks3;
  std::vector<cv::Point2d> clicks2;
  for (size_t i = 0; i < fit.clicks.size(); ++i)
    if (fit.inlier[i]) {
      const Vec3 q = mesh.position(fit.clicks[i].vertex);
      clicks3.emplace_back(q.x(), q.y(), q.z());
      clicks2.emplace_back(fit.clicks[i].pixel.x(), fit.clicks[i].pixel.y());
    }
  const int radial = fit.camera.k2 != 0 ? 2 : fit.camera.k1 != 0 ? 1 : 0;
  const double sigmaClicks = std::max(o.silhouetteMinClickRmsPx, fit.rmsResidual);
  const double weight = std::pow(sigmaClicks / o.silhouetteSigmaPx, 2);
  const Params p = paramsOf(fit.camera, Vec3::Zero());  // the clicks and contour are not centred here
  // Contours through a camera: from the memo when one within contourReusePx is kept (the preview tier).
  std::vector<std::pair<Camera, std::vector<Vec3>>> made;
  auto contourThrough = [&](const Camera& cam) -> std::vector<Vec3> {
    if (memo && o.contourReusePx > 0) {
      std::lock_guard<std::mutex> lock(memo->mutex);
      for (const auto& [c, contour] : memo->contours)
        if (c.width == cam.width && c.height == cam.height && cameraShiftPx(mesh, c, cam) <= o.contourReusePx)
          return contour;
    }
    made.emplace_back(cam, outerContour(mesh, cam, o.silhouetteSpacingPx));
    return made.back().second;
  };
  struct KeepMade {  // the memo keeps the contours this call extracted, on every way out
    ContourMemo* memo;
    std::vector<std::pair<Camera, std::vector<Vec3>>>& made;
    ~KeepMade() {
      if (!memo || made.empty()) return;
      std::lock_guard<std::mutex> lock(memo->mutex);
      for (auto& m : made) memo->contours.push_back(std::move(m));
      if (memo->contours.size() > 4) memo->contours.erase(memo->contours.begin(), memo->contours.end() - 4);
    }
  } keepMade{memo, made};
  auto meanDistance = [&](const Camera& cam, const PhotoCamera& full, int* count) {
    const std::vector<Vec3> contour = contourThrough(cam);
    double sum = 0;
    int n = 0;
    for (const Vec3& x : contour) {
      Vec2 px;
      if (full.project(x, px)) sum += std::abs(distance.at(px)), ++n;
    }
    if (count) *count = n;
    return n ? sum / n : std::numeric_limits<double>::infinity();
  };
  double before = 0;  // mean distance of the fit's own contour (round 0 extracts it)
  // The fit's own contour, which the first round of every attempt starts from: extracted once.
  std::optional<std::vector<Vec3>> startContour;
  // The rounds with `radial` lens terms free, from `p`; the camera and its contour's mean distance, or nothing.
  struct Attempt {
    CameraFit refined;
    double after = kInf;
    int count = 0;
  };
  const auto attempt = [&](int radial, Params p) -> std::optional<Attempt> {
    CameraFit refined = fit;
    for (int round = 0; round < o.silhouetteRounds; ++round) {
      if (round == 0 && !startContour) startContour = contourThrough(fit.camera.pinhole);
      const std::vector<Vec3> contour = round == 0 ? *startContour : contourThrough(refined.camera.pinhole);
      if (contour.size() < 10) return std::nullopt;
      std::vector<cv::Point3d> c3;
      std::vector<double> w;
      double sum = 0;
      int n = 0;
      const int stride = std::max(1, o.silhouetteSampleStride);
      for (size_t i = 0; i < contour.size(); ++i) {
        const Vec3& x = contour[i];
        Vec2 px;
        if (!refined.camera.project(x, px)) continue;
        const double d = std::abs(distance.at(px));
        sum += d, ++n;
        if (i % stride) continue;
        c3.emplace_back(x.x(), x.y(), x.z());
        // Each sample stands for `stride` of the contour's: the silhouette weighs as much against the clicks.
        w.push_back(stride * weight * (d <= o.silhouetteHuberPx ? 1.0 : o.silhouetteHuberPx / d));
      }
      if (round == 0) before = n == 0 ? kInf : sum / n;
      auto callback = cv::makePtr<SilhouetteFit>(clicks3, clicks2, c3, w, distance, fit.camera.pinhole.cx,
                                                 fit.camera.pinhole.cy, radial);
      cv::Mat x = callback->pack(p);
      try {
        cv::LMSolver::create(callback, 50, o.silhouetteStep)->run(x);
      } catch (const cv::Exception&) {
        return std::nullopt;
      }
      const Params q = callback->unpack(x);
      if (!std::isfinite(q.focal) || q.focal <= 0) return std::nullopt;
      p = q;
      setCamera(refined.camera, p, Vec3::Zero());  // the clicks and contour are not centred here
    }
    measureClicks(mesh, refined);
    Attempt a{std::move(refined)};
    a.after = meanDistance(a.refined.camera.pinhole, a.refined.camera, &a.count);
    return a;
  };
  // Kept when the silhouette agrees better and the clicks still agree within their noise: as many agree and their
  // RMS rises by at most half, or, by a likelihood-ratio test, the rise of their (truncated) sum of squares stays
  // within chi-square's 99.9% quantile with the camera's degrees of freedom, in units of the clicks' variance per
  // axis (the clicks' own fit minimises that sum, so the true camera costs more on them too). The first alone refused
  // most refinements at 3 px of noise, where a click or two cross the agreement threshold either way; the second
  // alone refused some where the camera lacks a lens term the photo has, and the silhouette's camera was better.
  const auto clickCost = [&](const CameraFit& f) {
    double cost = 0;
    for (double r : f.residual) cost += std::min(r * r, fit.thresholdPx * fit.thresholdPx);
    return cost;
  };
  const auto acceptable = [&](const std::optional<Attempt>& a, int radial) {
    if (!a) return false;
    const int parameters = 7 + radial;
    const double variance = fit.rmsResidual * fit.rmsResidual * fit.inliers / std::max(1, 2 * fit.inliers - parameters);
    constexpr double kChi2Quantile999[] = {24.32, 26.12, 27.88};  // 7, 8 and 9 degrees of freedom
    const bool asManyAgree =
        a->refined.inliers >= fit.inliers && a->refined.rmsResidual <= 1.5 * fit.rmsResidual + 0.05;
    const bool withinNoise = clickCost(a->refined) - clickCost(fit) <= kChi2Quantile999[radial] * variance;
    return a->after < before && (asManyAgree || withinNoise);
  };
  std::optional<Attempt> best = attempt(radial, p);
  if (!acceptable(best, radial)) best.reset();
  if (radial == 0 && o.silhouetteLens && o.radialDistortion &&
      static_cast<int>(clicks3.size()) >= o.minInliersForDistortion) {
    // The lens the clicks did not pay for (their noise hid it): the contour, hundreds of samples across the frame,
    // may. Kept when it brings the silhouette nearer by a clear share, and the clicks agree as the rule above asks.
    std::optional<Attempt> lens = attempt(1, p);
    if (acceptable(lens, 1) && lens->after < o.silhouetteLensGain * (best ? best->after : before))
      best = std::move(lens);
  }
  if (!best) return;
  CameraFit refined = std::move(best->refined);
  refined.silhouettePoints = best->count;
  refined.silhouetteResidualPx = best->after;
  refined.seconds = fit.seconds + secondsSince(start);
  refined.reason = describeFit(refined);
  fit = std::move(refined);
}

CameraFit fitFromCamera(const Mesh& mesh, const PhotoCamera& camera, const std::vector<CameraClick>& clicks) {
  checkInputs(mesh, clicks, camera.pinhole.width, camera.pinhole.height);
  CameraFit fit;
  fit.fits = true;
  fit.camera = camera;
  fit.clicks = clicks;
  fit.thresholdPx = kInf;
  measureClicks(mesh, fit);
  fit.reason = "given camera";
  return fit;
}

double pooledRadialF(const std::vector<const CameraFit*>& fits) {
  double drop = 0, rss = 0;
  int terms = 0, dof = 0, photos = 0;
  for (const CameraFit* f : fits) {
    const CameraFit::RadialTrial& t = f->radialTrial;
    if (t.terms == 0 || !t.agrees || t.dof <= 0) continue;
    drop += t.drop, rss += t.rss, terms += t.terms, dof += t.dof, ++photos;
  }
  return photos >= 2 && rss > 0 ? (drop / terms) / (rss / dof) : 0;
}

namespace {

// One photo's agreeing clicks in a joint fit, about their centroid.
struct JointView {
  CentredClicks clicks;
  double cx = 0, cy = 0;
};

// LM over the photos of one camera: a pose per photo (6 parameters each), then the focal length and `radial`
// radial terms they share. Residuals: projection - click, every view's clicks in turn.
class SharedReprojection : public cv::LMSolver::Callback {
 public:
  SharedReprojection(const std::vector<JointView>& views, int radial, const FocalPrior& prior)
      : views_(views), radial_(radial), prior_(prior) {}
  int numParams() const { return 6 * static_cast<int>(views_.size()) + 1 + radial_; }
  cv::Mat pack(const std::vector<Params>& p) const {
    cv::Mat x(numParams(), 1, CV_64F);
    const int s = 6 * static_cast<int>(views_.size());
    for (size_t v = 0; v < views_.size(); ++v)
      for (int i = 0; i < 3; ++i)
        x.at<double>(6 * int(v) + i) = p[v].rvec[i], x.at<double>(6 * int(v) + 3 + i) = p[v].tvec[i];
    x.at<double>(s) = p[0].focal;
    if (radial_ >= 1) x.at<double>(s + 1) = p[0].k1;
    if (radial_ >= 2) x.at<double>(s + 2) = p[0].k2;
    return x;
  }
  std::vector<Params> unpack(const cv::Mat& x) const {
    std::vector<Params> p(views_.size());
    const int s = 6 * static_cast<int>(views_.size());
    for (size_t v = 0; v < views_.size(); ++v) {
      for (int i = 0; i < 3; ++i)
        p[v].rvec[i] = x.at<double>(6 * int(v) + i), p[v].tvec[i] = x.at<double>(6 * int(v) + 3 + i);
      p[v].focal = x.at<double>(s);
      p[v].k1 = radial_ >= 1 ? x.at<double>(s + 1) : 0;
      p[v].k2 = radial_ >= 2 ? x.at<double>(s + 2) : 0;
    }
    return p;
  }
  bool compute(cv::InputArray param, cv::OutputArray err, cv::OutputArray J) const override {
    const std::vector<Params> p = unpack(param.getMat());
    int rows = prior_.weight > 0;  // the prior's row first
    for (const JointView& v : views_) rows += 2 * static_cast<int>(v.clicks.object.size());
    err.create(rows, 1, CV_64F);
    cv::Mat e = err.getMat();
    cv::Mat j;
    if (J.needed()) {
      J.create(rows, numParams(), CV_64F);
      j = J.getMat();
      j.setTo(0);
    }
    const int s = 6 * static_cast<int>(views_.size());
    int row = 0;
    if (prior_.weight > 0) {
      e.at<double>(row) = prior_.residual(p[0].focal);
      if (J.needed()) j.at<double>(row, s) = prior_.weight;
      ++row;
    }
    for (size_t v = 0; v < views_.size(); ++v) {
      const JointView& view = views_[v];
      std::vector<cv::Point2d> proj;
      cv::Mat full;
      projectAll(view.clicks.object, p[v], view.cx, view.cy, proj, J.needed() ? &full : nullptr);
      for (size_t i = 0; i < proj.size(); ++i, row += 2) {
        e.at<double>(row) = proj[i].x - view.clicks.image[i].x;
        e.at<double>(row + 1) = proj[i].y - view.clicks.image[i].y;
        if (!J.needed()) continue;
        for (int a = 0; a < 2; ++a) {
          const int r = 2 * static_cast<int>(i) + a;
          for (int c = 0; c < 6; ++c) j.at<double>(row + a, 6 * int(v) + c) = full.at<double>(r, c);
          j.at<double>(row + a, s) = full.at<double>(r, 6) + full.at<double>(r, 7);  // fx = fy = focal
          if (radial_ >= 1) j.at<double>(row + a, s + 1) = full.at<double>(r, 10);
          if (radial_ >= 2) j.at<double>(row + a, s + 2) = full.at<double>(r, 11);
        }
      }
    }
    return true;
  }

 private:
  const std::vector<JointView>& views_;
  int radial_;
  FocalPrior prior_;
};

double sumOfSquares(const std::vector<double>& r) {
  double s = 0;
  for (double x : r) s += x * x;
  return s;
}

}  // namespace

SharedIntrinsics fitSharedIntrinsics(const Mesh& mesh, const std::vector<CameraFit*>& fits, const CameraFitOptions& o) {
  const auto start = Clock::now();
  SharedIntrinsics out;
  out.photos = static_cast<int>(fits.size());
  auto finish = [&](std::string why) {
    out.why = std::move(why);
    out.seconds = secondsSince(start);
    return out;
  };
  if (fits.size() < 2) return finish("one photo");
  for (const CameraFit* f : fits)
    if (!f->fits || f->subject) return finish("a photo that does not fit as the object itself");
  // The views: each photo's agreeing clicks, re-collected after each joint fit until they are stable.
  const auto viewsOf = [&](const std::vector<CameraFit>& state) {
    std::vector<JointView> views(state.size());
    for (size_t v = 0; v < state.size(); ++v) {
      std::vector<CameraClick> in;
      for (size_t i = 0; i < state[v].clicks.size(); ++i)
        if (state[v].inlier[i]) in.push_back(state[v].clicks[i]);
      views[v].clicks = centredClicks(mesh, in);
      views[v].cx = state[v].camera.pinhole.cx, views[v].cy = state[v].camera.pinhole.cy;
    }
    return views;
  };
  const auto rssOf = [](const std::vector<JointView>& views, const std::vector<Params>& p) {
    double rss = 0;
    for (size_t v = 0; v < views.size(); ++v)
      rss += sumOfSquares(residuals(views[v].clicks.object, views[v].clicks.image, p[v], views[v].cx, views[v].cy));
    return rss;
  };
  // The EXIF's focal length (options.focalPriorPx: the group's, one camera model and lens setting) as a prior,
  // unless a photo's clicks refused it; in the clicks' units of their noise (their residuals' RMS per axis).
  FocalPrior prior;
  if (o.focalPriorPx > 0 &&
      std::none_of(fits.begin(), fits.end(), [](const CameraFit* f) { return f->focalPrior < 0; })) {
    double sum = 0;
    int count = 0;
    for (const CameraFit* f : fits) sum += f->rmsResidual * f->rmsResidual * f->inliers, count += f->inliers;
    prior = FocalPrior::of(o, std::sqrt(sum / std::max(1, 2 * count)));
    out.focalPrior = prior.weight > 0;
  }
  const auto joint = [&](const std::vector<JointView>& views, std::vector<Params> p, int radial) {
    auto callback = cv::makePtr<SharedReprojection>(views, radial, prior);
    cv::Mat x = callback->pack(p);
    try {
      cv::LMSolver::create(callback, 200, 1e-12)->run(x);
    } catch (const cv::Exception&) {
      return p;
    }
    std::vector<Params> q = callback->unpack(x);
    return std::isfinite(q[0].focal) && q[0].focal > 0 ? q : p;
  };
  std::vector<CameraFit> state;
  for (const CameraFit* f : fits) state.push_back(*f);
  std::vector<JointView> views = viewsOf(state);
  std::vector<Params> p;
  std::vector<double> focals;
  for (size_t v = 0; v < state.size(); ++v) {
    p.push_back(paramsOf(state[v].camera, views[v].clicks.centre));
    focals.push_back(p.back().focal);
  }
  std::nth_element(focals.begin(), focals.begin() + focals.size() / 2, focals.end());
  int clicks = 0, radial = 0;
  double rss = 0;
  for (int round = 0; round < 4; ++round) {
    clicks = 0;
    for (const JointView& v : views) clicks += static_cast<int>(v.clicks.object.size());
    // Shared focal, no radial terms; then the terms one at a time while each pays by Akaike's criterion (its F
    // above pooledDistortionF, as for the pooled trials): one k1 for every photo, measured on all their clicks.
    if (round == 0)
      for (Params& q : p) q.focal = focals[focals.size() / 2], q.k1 = q.k2 = 0;
    p = joint(views, p, 0);
    rss = rssOf(views, p);
    radial = 0;
    out.radialF = 0;
    // As for one photo: below minDistortionRmsPx there is nothing left for radial terms to explain.
    const bool lensMayPay = o.radialDistortion && clicks >= o.minInliersForDistortion &&
                            std::sqrt(rss / std::max(1, clicks)) > o.minDistortionRmsPx;
    const int maxTerms = !lensMayPay ? 0 : clicks >= 20 ? 2 : 1;
    for (int terms = 1; terms <= maxTerms; ++terms) {
      const std::vector<Params> q = joint(views, p, terms);
      const double rssQ = rssOf(views, q);
      const int dof = 2 * clicks - (6 * static_cast<int>(views.size()) + 1 + terms);
      const double f = dof > 0 && rssQ > 0 ? (rss - rssQ) / (rssQ / dof) : 0;
      if (terms == 1) out.radialF = f;
      if (!(f > o.pooledDistortionF)) break;
      p = q, rss = rssQ, radial = terms;
    }
    // The agreeing clicks under the shared camera; stable: done.
    bool stable = true;
    for (size_t v = 0; v < state.size(); ++v) {
      setCamera(state[v].camera, p[v], views[v].clicks.centre);
      const std::vector<char> before = state[v].inlier;
      measureClicks(mesh, state[v]);
      stable = stable && state[v].inlier == before;
    }
    if (stable) break;
    const std::vector<JointView> next = viewsOf(state);
    for (size_t v = 0; v < state.size(); ++v)  // the same cameras about the new centroids
      p[v] = paramsOf(state[v].camera, next[v].clicks.centre);
    views = next;
  }
  // The clicks as they now agree (after four rounds they may have changed once more).
  clicks = 0;
  for (const JointView& v : views) clicks += static_cast<int>(v.clicks.object.size());
  rss = rssOf(views, p);
  out.focal = p[0].focal, out.k1 = p[0].k1, out.k2 = p[0].k2, out.terms = radial;

  // Separate intrinsics (the fits as they are: each photo's focal and terms, its pose refitted on the same clicks,
  // since the silhouette refinement moved it off the clicks' optimum) against shared ones, by Akaike's criterion
  // (Gaussian residuals: N ln(RSS / N) + 2k over the N = 2 x clicks residuals).
  double rssSeparate = 0;
  int kSeparate = 0;
  for (size_t v = 0; v < views.size(); ++v) {
    const CameraFit& f = *fits[v];
    const int terms = f.camera.k2 != 0 ? 2 : f.camera.k1 != 0 ? 1 : 0;
    const Params own =
        refine(views[v].clicks.object, views[v].clicks.image, std::vector<char>(views[v].clicks.object.size(), 1),
               paramsOf(f.camera, views[v].clicks.centre), views[v].cx, views[v].cy, terms, {}, false,
               f.focalPrior > 0 ? prior : FocalPrior{});
    rssSeparate +=
        sumOfSquares(residuals(views[v].clicks.object, views[v].clicks.image, own, views[v].cx, views[v].cy));
    kSeparate += 7 + terms;
  }
  const int kShared = 6 * static_cast<int>(views.size()) + 1 + radial;
  const double n = 2.0 * clicks, floor = 1e-12 * n;  // exact clicks: equal fits, the fewer parameters win
  out.aicSeparate = n * std::log(std::max(rssSeparate, floor) / n) + 2 * kSeparate;
  out.aicShared = n * std::log(std::max(rss, floor) / n) + 2 * kShared;
  if (!(out.aicShared <= out.aicSeparate))
    return finish("separate intrinsics explain the clicks better (Akaike " + formatFixed(out.aicSeparate, 1) +
                  " against " + formatFixed(out.aicShared, 1) + " shared)");
  for (const CameraFit& f : state) {
    const double fov = f.camera.fovYDeg();
    if (f.inliers < o.minInliers || f.inliers < o.minInlierRatio * double(f.clicks.size()) ||
        !(fov >= o.minFovDeg && fov <= o.maxFovDeg))
      return finish("a photo's clicks do not agree with the shared intrinsics");
  }
  for (size_t v = 0; v < fits.size(); ++v) {
    CameraFit& f = state[v];
    f.sharedIntrinsics = out.photos;
    f.radialPooled = false;
    f.silhouettePoints = 0, f.silhouetteResidualPx = 0;
    f.reason = describeFit(f);
    *fits[v] = std::move(f);
  }
  out.shared = true;
  return finish(
      "focal " + formatFixed(out.focal, 1) + " px" +
      (radial ? ", k1 " + formatFixed(out.k1, 4) + (radial > 1 ? ", k2 " + formatFixed(out.k2, 4) : "") : "") +
      " shared by " + std::to_string(out.photos) + " photos (Akaike " + formatFixed(out.aicShared, 1) + " against " +
      formatFixed(out.aicSeparate, 1) + " separate)");
}

std::string describeFit(const CameraFit& fit) {
  std::string s = fit.fits ? "fits: " : "does not fit: ";
  if (!fit.fits) return s + fit.reason;
  s += "focal " + formatFixed(fit.camera.focal(), 1) + " px (fov " + formatFixed(fit.camera.fovYDeg(), 1) + " deg";
  if (fit.camera.k1 != 0 || fit.camera.k2 != 0)
    s += ", k1 " + formatFixed(fit.camera.k1, 4) + ", k2 " + formatFixed(fit.camera.k2, 4) +
         (fit.radialPooled ? " (paid for by the photos of its camera together)" : "");
  if (fit.sharedIntrinsics) s += ", shared by " + std::to_string(fit.sharedIntrinsics) + " photos";
  if (fit.focalPrior)
    s += fit.focalPrior > 0 ? ", the EXIF's focal length a prior" : ", the EXIF's focal length refused";
  s += "), " + std::to_string(fit.inliers) + "/" + std::to_string(fit.clicks.size()) + " clicks agree, median " +
       formatFixed(fit.medianResidual, 2) + " px, max " + formatFixed(fit.maxResidual, 2) + " px";
  if (fit.silhouettePoints > 0)
    s += std::string(fit.silhouetteFound ? ", on the silhouette found around the mesh's outline: "
                                         : ", on the silhouette: ") +
         std::to_string(fit.silhouettePoints) + " contour samples, mean " + formatFixed(fit.silhouetteResidualPx, 2) +
         " px";
  if (fit.photometricShiftPx > 0)
    s += ", aligned with the other photos on their overlaps (moved " + formatFixed(fit.photometricShiftPx, 2) + " px)";
  return s;
}

}  // namespace montage
