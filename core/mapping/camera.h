// Camera fit per photo (the stage between load and partition): from one photo's clicks (mesh vertex
// <-> pixel), a perspective camera with unknown focal length and pose, principal point at the image
// centre, square pixels, no skew, and optional radial distortion. A photo whose clicks agree with
// one camera shows the object itself and is mapped by projection (projection.h); one whose clicks do
// not is a photo of another subject and takes the paper's path (partition, progressive mesh,
// coarse-to-fine).
//
// Method: for a sweep of focal lengths, RANSAC over minimal PnP samples (OpenCV solvePnPRansac) gives
// the start with the most clicks in agreement; Levenberg-Marquardt (OpenCV calibrateCamera with the
// principal point, aspect ratio and tangential terms fixed) refines focal, pose and, with enough
// clicks, the radial terms on the clicks that agree. Inliers are re-classified against the refined
// camera and the refinement repeats until they are stable. Every click keeps its reprojection
// residual.
#pragma once

#include <mutex>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "base/common.h"
#include "geometry/raster.h"

namespace montage {

struct Mesh;
struct Photo;
struct Project;
class JobControl;

// A perspective camera with radial distortion (OpenCV's model with k1, k2): a world point p goes to
// camera coordinates c = R p + t, to normalised coordinates (x, y) = (c.x / c.z, c.y / c.z), is
// distorted by the factor 1 + k1 r^2 + k2 r^4 (r^2 = x^2 + y^2), and lands at pixel
// (fx x' + cx, fy y' + cy) (photo.h convention: origin at the top-left corner, y down).
struct PhotoCamera {
  Camera pinhole;  // intrinsics, pose and image size; pinhole.project() is the undistorted projection
  double k1 = 0, k2 = 0;

  // Projects a world point; false when it is behind the camera. `depth` is c.z.
  bool project(const Vec3& p, Vec2& pixel, double* depth = nullptr) const;
  double focal() const { return pinhole.fx; }
  // Vertical field of view in degrees.
  double fovYDeg() const;
};

// One click of a photo: a mesh vertex and where the user put it.
struct CameraClick {
  int point = -1;  // index into Project::points (or -1 when made by hand)
  int vertex = 0;  // mesh vertex id
  Vec2 pixel = Vec2::Zero();
};

// The clicks of photo `photo` in a project, in point order.
std::vector<CameraClick> photoClicks(const Project& project, int photo);

struct CameraFitOptions {
  int minInliers = 6;                // a photo fits when at least this many clicks agree with one camera...
  double minInlierRatio = 0.6;       // ...and they are at least this share of its clicks
  double thresholdFraction = 0.006;  // a click agrees when its residual is below this share of the image
                                     // diagonal (6.1 px at 1024 x 768); never below minThresholdPx
  double minThresholdPx = 2.0;       // lower bound of the agreement threshold, pixels
  bool radialDistortion = true;      // fit k1 (and k2 from 20 inliers on) when enough clicks agree
  int minInliersForDistortion = 12;  // fewer agreeing clicks: no radial terms
  double minDistortionRmsPx = 0.02;  // the pinhole fit's RMS residual must exceed this for radial terms to be tried
  double distortionF = 10;           // keep the radial terms only when their F statistic (residual drop per term
                                     // over the residual variance) exceeds this: p < 0.005, not a fit to noise
  bool keepRadial = false;           // keep them whenever tried and as many clicks agree: the camera stage's
                                     // pooled decision for the photos of one camera (pooledRadialF)...
  double pooledDistortionF = 2;      // ...taken when their pooled F exceeds this: Akaike's criterion (the terms
                                     // predict the texture's place better), not a significance test; dropping a
                                     // real k1 costs up to 12 dB, keeping a needless one 0.1-0.3 dB (pipeline.md)
  double focalPriorPx = 0;        // > 0: the focal length the photo's EXIF gives (ExifCamera::focalPx), a prior of...
  double focalPriorSigma = 0.05;  // ...this relative deviation (EXIF rounds to a millimetre; a zoom's 35 mm
                                  // equivalent is approximate), kept only when the clicks agree with it
  double minFovDeg = 2, maxFovDeg = 150;  // focal lengths outside this field of view are implausible
  int focalSamples = 16;                  // focal lengths tried for the RANSAC start (log-spaced over the fov range)
  // RANSAC iterations per focal length; 0: enough to draw, with 99.9% confidence, one sample of five
  // agreeing clicks when minInlierRatio of them agree (86 at 0.6; at most 1000): a photo with fewer agreeing clicks
  // does not fit anyway, and a focal far from the photo's spends them all.
  int ransacIterations = 0;
  unsigned seed = 1;  // RANSAC seed, so fits are repeatable
  // Silhouette refinement (refineOnSilhouette), for photos with a background:
  bool silhouette = true;                 // refine the camera on the photo's silhouette as well as the clicks
  double silhouetteMinClickRmsPx = 0.15;  // clicks that agree better than this fix the camera on their own
  double silhouetteSigmaPx = 0.5;         // accuracy of the photo's silhouette (the clicks': their RMS residual)
  double silhouetteSpacingPx = 2;         // sample spacing along the mesh's projected contour, pixels
  double silhouetteHuberPx = 1.5;         // silhouette residuals beyond this count linearly (Huber)
  int silhouetteRounds = 4;               // LM rounds, each on the contour re-extracted from the last camera
  double silhouetteStep = 1e-10;          // a round's LM stops when its step is below this (the parameters:
                                          // rotation in radians, translation in mesh units, focal in pixels)
  int silhouetteSampleStride = 1;         // the LM takes every n-th contour sample (the preview tier: 2)
  bool silhouetteLens = true;             // a camera without lens terms also tries k1 on its silhouette...
  double silhouetteLensGain = 0.8;        // ...kept when the contour's mean distance is below this share of the
                                          // pinhole refinement's
  double contourReusePx = 0;              // > 0 (the preview tier): a ContourMemo's contour serves a camera within
                                          // this many pixels of the one it was extracted through
};

// The outer contours (mesh points on the silhouette) a photo's last refinement extracted, with their cameras,
// kept with the photo across runs (refineOnSilhouette). Thread-safe.
struct ContourMemo {
  std::mutex mutex;
  std::vector<std::pair<Camera, std::vector<Vec3>>> contours;  // the last four extracted, oldest first
};

// The fit of one photo.
struct CameraFit {
  bool fits = false;                // the clicks agree with one camera (see CameraFitOptions)
  std::string reason;               // why it does not fit, or a summary when it does
  PhotoCamera camera;               // valid when `fits` (and the best attempt otherwise, when there was one)
  double thresholdPx = 0;           // agreement threshold used for this photo
  std::vector<CameraClick> clicks;  // the clicks, as given
  std::vector<Vec2> reprojected;    // per click: where the camera puts its vertex (NaN when behind it)
  std::vector<double> residual;     // per click: distance click - reprojection, pixels (inf when behind)
  std::vector<char> inlier;         // per click: residual below thresholdPx
  int inliers = 0;
  double medianResidual = 0, maxResidual = 0;  // over the inliers, pixels
  double rmsResidual = 0;                      // over the inliers, pixels
  // The radial terms' trial of fitCamera (terms 0: not tried): the F test's parts on the agreeing clicks, whether
  // as many clicks agree with them, and whether they were kept. The camera stage pools the trials of the photos of
  // one camera (pooledRadialF), so that noise does not drop the terms in one photo and keep them in another.
  struct RadialTrial {
    int terms = 0;
    double drop = 0, rss = 0;  // sum of squared residuals: its drop with the terms, and what is left
    int dof = 0;               // 2 x agreeing clicks - camera parameters
    bool agrees = false, kept = false;
  } radialTrial;
  bool radialPooled = false;  // the terms are kept although this photo alone does not pay for them: the photos of
                              // its camera together do (CameraFitOptions::keepRadial)
  double noisePx = 0;    // the clicks' noise, pixels per axis, as the agreeing clicks' residuals tell it (0: too few
                         // to tell); the correction field's `noise` mode moves the texture only beyond it
  int focalPrior = 0;    // the EXIF's focal length as a prior: 1 taken, -1 refused (the clicks disagree), 0 none
  int sharedIntrinsics = 0;  // > 0: its focal length and lens terms are those this many photos of one camera share
                             // (fitSharedIntrinsics), then refined on its own silhouette where it has one
  bool subject = false;  // a photo of another subject (fitCameraToEveryClick): a camera fitted to every click, which a
                         // warp then keeps exact (mapping/subject.h); every click is an inlier
  std::string
      decision;  // why the photo is taken for the object itself or another subject (its mode, or auto's evidence)
  int silhouettePoints = 0;         // contour samples of the silhouette refinement (0: not refined)
  double silhouetteResidualPx = 0;  // their mean distance to the photo's silhouette, pixels
  bool silhouetteFound = false;     // that silhouette was found around the mesh's outline (found_silhouette.h): the
                                    // photo has no cut-out
  std::string silhouetteSearch;     // a photo without a cut-out: what that search found, or why it took nothing
  double photometricShiftPx = 0;    // > 0: refined on its overlaps with the other photos (refineCamerasPhotometric),
                                    // which moved its view of the surface by this much (median, pixels)
  double seconds = 0;               // time of the fit
};

// Per fit: whether its photo fits a camera as the object itself (the photos the projection maps whatever the paper's
// map does; another subject's camera and warp compete with the paper's map: ProjectionResult::projected).
std::vector<char> fittingPhotos(const std::vector<CameraFit>& fits);

// Fits a camera to one photo's clicks on `mesh` (vertex ids index mesh). `width` x `height` is the
// photo size in pixels. Never throws for clicks that do not fit: `fits` is false with a reason.
// Throws montage::Error for a vertex id out of range or a non-positive size.
// `start`: a camera close to the answer (the fit before a small edit of the clicks) replaces the focal
// sweep and RANSAC as the refinement's start; the rest is the same. The editor's preview refits so.
CameraFit fitCamera(const Mesh& mesh, const std::vector<CameraClick>& clicks, int width, int height,
                    const CameraFitOptions& options = {}, const PhotoCamera* start = nullptr);

// A photo of another subject (a tiger's flank for a cat, a portrait for a head scan): no camera explains its clicks,
// but one camera explains most of their layout, and a smooth warp the rest (mapping/subject.h). Fitted to EVERY
// click with a robust (Cauchy) loss, iteratively reweighted Levenberg-Marquardt from the object fit's best camera
// (`start`, when it has one) and from EPnP on all clicks over a sweep of focal lengths; no radial terms. No click
// is dropped: `inlier` is 1 for all, `subject` is set. `fits` is false (with a reason) with fewer than
// options.minInliers clicks, or when no camera of a plausible field of view has every click in front.
CameraFit fitCameraToEveryClick(const Mesh& mesh, const std::vector<CameraClick>& clicks, int width, int height,
                                const CameraFitOptions& options, const CameraFit& start);

// Samples of the mesh's outer contour as `camera` sees it, about spacingPx apart: on edges between a front- and a
// back-facing face (or on the border), shown by the z-buffer, within a pixel and a half of the rendered outline.
std::vector<Vec3> outerContour(const Mesh& mesh, const Camera& camera, double spacingPx);

// Refines a fitted camera on the photo's silhouette, after Lensch, Heidrich and Seidel 2001: the mesh's
// outer contour (edges between front- and back-facing faces that the z-buffer shows on the rendered
// outline) must land on the edge of the photo's foreground (sub-pixel from the antialiased alpha).
// Levenberg-Marquardt on the agreeing clicks plus the contour samples (Huber, reweighted), the contour
// re-extracted each round. Kept only when the clicks still agree as well as their noise allows. Does
// nothing for photos without a background, fits that do not fit, or clicks that already agree to
// silhouetteMinClickRmsPx.
// Signed distance (file pixels, > 0 outside) to the edge of a photo's foreground: from distance
// transforms of the thresholded alpha, and sub-pixel near the edge from the antialiased alpha itself.
// It depends on the photo alone, so callers that refit often keep one per photo. The maps are made on
// first use (thread-safe); the photo must outlive this object.
class SilhouetteDistance {
 public:
  explicit SilhouetteDistance(const Photo& photo) : photo_(&photo) {}  // the photo must have a background
  double at(const Vec2& p) const;
  Vec2 gradient(const Vec2& p) const;

 private:
  void make() const;
  const Photo* photo_;
  mutable std::once_flag made_;
  mutable cv::Mat alpha_, coarse_;  // CV_32F at the file's pixels: alpha in [0, 1]; distance (pixels)
};

// `silhouette`: the photo's SilhouetteDistance when the caller keeps one (else it is computed here).
// `memo` (may be null): contours kept for options.contourReusePx; it keeps the contours this call extracted.
void refineOnSilhouette(const Mesh& mesh, const Photo& photo, CameraFit& fit, const CameraFitOptions& options = {},
                        const SilhouetteDistance* silhouette = nullptr, ContourMemo* memo = nullptr);

// A fit made from a known camera (the synthetic scenes' true cameras: the projection oracle), with
// the residuals of `clicks` against it. Always `fits`.
CameraFit fitFromCamera(const Mesh& mesh, const PhotoCamera& camera, const std::vector<CameraClick>& clicks);

// The pooled F statistic of the radial terms over `fits` (the object photos of one camera whose trial agrees): their
// residual drops per term over their residual variance, summed. 0 when fewer than two photos tried them.
double pooledRadialF(const std::vector<const CameraFit*>& fits);

// Photos from one camera share its intrinsics (issue 37): a bundle adjustment over the agreeing clicks of
// every photo in `fits` (a pose each, one focal length and one set of radial terms; the mesh's vertices are the
// known points), the terms added one at a time while they pay by Akaike's criterion (F above
// options.pooledDistortionF) on all the photos' clicks together. Kept only when Akaike's criterion prefers the
// shared intrinsics to the fits' own (a zoom lens between shots, or two cameras of one image size, keep theirs)
// and every photo still fits; then each fit takes its camera from the joint one, re-measured, with
// sharedIntrinsics set and any silhouette refinement undone (the camera stage refines each on its silhouette after,
// from the shared camera: few clicks leave the shared focal length a few percent off, which a silhouette pins down
// better, docs/pipeline.md). Otherwise the fits are left as they are.
struct SharedIntrinsics {
  bool shared = false;
  int photos = 0, terms = 0;
  double focal = 0, k1 = 0, k2 = 0;
  double radialF = 0;                     // the F statistic of a shared k1 on the shared focal's fit
  bool focalPrior = false;                // the EXIF's focal length was a prior (options.focalPriorPx)
  double aicShared = 0, aicSeparate = 0;  // Akaike's criterion of both models on the same clicks
  std::string why;
  double seconds = 0;
};
SharedIntrinsics fitSharedIntrinsics(const Mesh& mesh, const std::vector<CameraFit*>& fits,
                                     const CameraFitOptions& options = {});

// Fills the per-click figures of `fit` (reprojected, residual, inlier against fit.thresholdPx, their counts and
// statistics, noisePx) from its camera.
void measureClicks(const Mesh& mesh, CameraFit& fit);

// A one-line summary: "fits: focal 1123 px (fov 49.1 deg), 42/43 clicks agree, median 0.21 px, max 0.80 px".
std::string describeFit(const CameraFit& fit);

}  // namespace montage
