// Photos of another subject (see subject.h).
#include "mapping/subject.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "base/hash.h"
#include "geometry/mesh.h"
#include "geometry/raster.h"
#include "image/photo.h"
#include "mapping/found_silhouette.h"

namespace montage {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

std::string percent(double share) {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(0);
  s << 100 * share << "%";
  return s.str();
}

// `spreadAlone`: the spread bound for a photo without a silhouette to compare.
bool objectLike(const CameraEvidence& e, double share, double spread, double spreadAlone, double silhouette) {
  return e.clicks > 0 && e.agreeShare >= share && e.spread <= (e.silhouette < 0 ? spreadAlone : spread) &&
         (e.silhouette < 0 || e.silhouette >= silhouette);
}

std::string evidenceWords(const CameraEvidence& e) {
  std::string s = percent(e.agreeShare) + " of " + std::to_string(e.clicks) + " clicks agree with one camera, spread " +
                  (std::isfinite(e.spread) ? formatFixed(e.spread, 2) : std::string("unbounded")) + " x its threshold";
  if (e.silhouette >= 0) s += ", silhouette overlap " + percent(e.silhouette);
  return s;
}

}  // namespace

namespace {

// Intersection over union of the mesh's silhouette through `camera` and the photo's foreground, at a working
// size of at most 256 pixels a side (a coarse figure: whether the photo shows this mesh's outline at all).
double silhouetteAgreement(const Mesh& mesh, const Photo& photo, const PhotoCamera& camera) {
  const double scale = std::min(1.0, 256.0 / std::max(photo.width, photo.height));
  Camera small = camera.pinhole;
  small.width = std::max(1, static_cast<int>(std::lround(photo.width * scale)));
  small.height = std::max(1, static_cast<int>(std::lround(photo.height * scale)));
  small.fx *= scale, small.fy *= scale, small.cx *= scale, small.cy *= scale;
  RasterOptions options;
  options.barycentrics = false;
  const RasterBuffers raster = rasterize(mesh, small, options);
  int both = 0, either = 0;
  for (int y = 0; y < small.height; ++y)
    for (int x = 0; x < small.width; ++x) {
      const bool rendered = raster.face[raster.index(x, y)] >= 0;
      const bool shown = photo.isForeground((x + 0.5) / scale, (y + 0.5) / scale);
      both += rendered && shown;
      either += rendered || shown;
    }
  return either > 0 ? double(both) / either : 0.0;
}

}  // namespace

CameraEvidence cameraEvidence(const CameraFit& fit, const Mesh& mesh, const Photo* photo) {
  CameraEvidence e;
  e.clicks = static_cast<int>(fit.clicks.size());
  if (e.clicks == 0) return e;
  if (photo && photo->hasBackground && fit.inliers >= 4) e.silhouette = silhouetteAgreement(mesh, *photo, fit.camera);
  std::vector<double> r(fit.residual.begin(), fit.residual.end());
  r.resize(e.clicks, kInf);
  int agree = 0;
  for (double x : r) agree += x < fit.thresholdPx;
  e.agreeShare = double(agree) / e.clicks;
  std::sort(r.begin(), r.end());
  const double median = r[r.size() / 2];
  e.spread = std::isfinite(median) && fit.thresholdPx > 0 ? 1.4826 * median / fit.thresholdPx : kInf;
  return e;
}

ModeDecision decidePhotoMode(const CameraEvidence& first, const CameraEvidence& all, const SubjectOptions& o) {
  ModeDecision d;
  if (all.clicks < o.decisionClicks) {
    d.mode = PhotoMode::Subject;
    d.why = std::to_string(all.clicks) + " clicks: " + std::to_string(o.decisionClicks) +
            " decide whether the photo shows the object itself; until then it maps as another subject "
            "(every click kept)";
    return d;
  }
  const bool early = objectLike(first, o.objectShare, o.objectSpread, o.objectSpreadAlone, o.objectSilhouette);
  const std::string firstWords =
      "its first " + std::to_string(first.clicks) + " clicks " + (early ? "fit" : "do not fit") + " one camera";
  if (early) {
    const bool leave = all.agreeShare < o.toSubjectShare || all.spread > o.toSubjectSpread ||
                       (all.silhouette >= 0 && all.silhouette < o.toSubjectSilhouette);
    d.mode = leave ? PhotoMode::Subject : PhotoMode::Object;
    d.why = leave ? firstWords + ", but all do not (" + evidenceWords(all) + "): another subject"
                  : "the object itself: " + firstWords + ", and " + evidenceWords(all);
  } else {
    const bool join = objectLike(all, o.toObjectShare, o.toObjectSpread,
                                 std::min(o.toObjectSpread, o.objectSpreadAlone), o.toObjectSilhouette) ||
                      (all.clicks >= o.joinClicks &&
                       objectLike(all, o.toObjectShare, o.objectSpread, o.objectSpreadAlone, o.toObjectSilhouette));
    d.mode = join ? PhotoMode::Object : PhotoMode::Subject;
    d.why = join ? firstWords + ", but all clearly do (" + evidenceWords(all) + "): the object itself"
                 : "another subject: " + firstWords + " (" + evidenceWords(first) + ")";
  }
  return d;
}

ModeDecision decidePhotoMode(const Mesh& mesh, const Photo& photo, const std::vector<CameraClick>& clicks,
                             const CameraFit& fit, const CameraFitOptions& fitOptions, const SubjectOptions& o,
                             bool findSilhouettes) {
  CameraEvidence first;
  CameraFit early;
  if (static_cast<int>(clicks.size()) >= o.decisionClicks) {
    // The first clicks' own fit (from scratch, so that it does not depend on the preview's start).
    early = fitCamera(mesh, {clicks.begin(), clicks.begin() + o.decisionClicks}, photo.width, photo.height, fitOptions);
    first = cameraEvidence(early, mesh, &photo);
  }
  CameraEvidence all = cameraEvidence(fit, mesh, &photo);
  ModeDecision d = decidePhotoMode(first, all, o);
  if (!findSilhouettes || d.mode == PhotoMode::Object || photo.hasBackground || !fit.fits || !early.fits) return d;
  // Would a silhouette that agrees decide otherwise? Only then is one looked for (a few tenths of a second).
  CameraEvidence firstShown = first, allShown = all;
  firstShown.silhouette = allShown.silhouette = 1;
  if (decidePhotoMode(firstShown, allShown, o).mode != PhotoMode::Object) return d;
  const FoundSilhouette found = findSilhouette(mesh, photo, fit.camera, fit.thresholdPx);
  if (!found.found) return d;
  first.silhouette = outlineAgreement(mesh, early.camera, found.mask);
  all.silhouette = outlineAgreement(mesh, fit.camera, found.mask);
  d = decidePhotoMode(first, all, o);
  d.why += " (the silhouette found around the mesh's outline; the photo has no cut-out)";
  return d;
}

Vec2 ImageWarp::apply(const Vec2& x) const {
  const int n = static_cast<int>(from.size());
  if (n == 0) return x;
  // Weights; a point on a handle goes where the handle goes.
  std::vector<double> w(n);
  double total = 0;
  Vec2 ps = Vec2::Zero(), qs = Vec2::Zero();
  for (int i = 0; i < n; ++i) {
    const double d2 = (from[i] - x).squaredNorm();
    if (d2 < 1e-18) return to[i];
    w[i] = alpha == 1.0 ? 1.0 / d2 : std::pow(d2, -alpha);
    total += w[i];
    ps += w[i] * from[i];
    qs += w[i] * to[i];
  }
  ps /= total;
  qs /= total;
  if (n == 1) return x - ps + qs;
  // Similarity: the complex factor a minimising sum w |a p^ - q^|^2.
  double pp = 0, re = 0, im = 0;
  Eigen::Matrix2d ppT = Eigen::Matrix2d::Zero(), qpT = Eigen::Matrix2d::Zero();
  for (int i = 0; i < n; ++i) {
    const Vec2 p = from[i] - ps, q = to[i] - qs;
    pp += w[i] * p.squaredNorm();
    re += w[i] * (p.x() * q.x() + p.y() * q.y());
    im += w[i] * (p.x() * q.y() - p.y() * q.x());
    ppT += w[i] * p * p.transpose();
    qpT += w[i] * q * p.transpose();
  }
  const Vec2 v = x - ps;
  if (affine) {
    // Affine when the handles around x span the plane (not nearly collinear), else similarity.
    const double det = ppT.determinant(), tr = ppT.trace();
    if (det > 1e-6 * tr * tr) return qs + qpT * ppT.inverse() * v;
  }
  if (!(pp > 0)) return x - ps + qs;
  const double a = re / pp, b = im / pp;
  return qs + Vec2(a * v.x() - b * v.y(), b * v.x() + a * v.y());
}

Vec2 ImageWarp::heldOut(int i) const {
  ImageWarp without = *this;
  without.from.erase(without.from.begin() + i);
  without.to.erase(without.to.begin() + i);
  return without.apply(from[i]) - to[i];
}

uint64_t ImageWarp::hash(uint64_t h) const {
  h = hashMix(hashMix(h, alpha), uint64_t(affine));
  for (size_t i = 0; i < from.size(); ++i) h = hashMix(hashMix(h, from[i]), to[i]);
  return h;
}

}  // namespace montage
