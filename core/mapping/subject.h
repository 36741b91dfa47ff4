// Photos of another subject: the paper's own use (a leopard's skin onto a cat, its Figure 1; a portrait onto a
// head scan). There is no true camera, and every click is meant.
//
// - What a photo shows (PhotoMode): the user says, or `decidePhotoMode` decides from the clicks, with a margin
//   and hysteresis so that one more click does not flip the decision (see SubjectOptions).
// - The map of a photo of another subject: a camera fitted to every click (camera.h, fitCameraToEveryClick),
//   then a smooth warp of the photo plane that takes each click's projection exactly onto the click: moving least
//   squares (Schaefer, McPhail and Warren 2006, as FlexiStickers uses it) with the clicks, and the photo's
//   outline paths, as handles. Only faces inside the photo's outline (its closed feature polygons) are mapped.
// - Per photo, that map or the paper's piecewise map (partition, progressive mesh, coarse-to-fine), whichever
//   has no folds, the lower stretch and the larger coverage (`chooseSubjectMap`); the choice and its figures are
//   reported.
#pragma once

#include <string>
#include <vector>

#include "base/common.h"
#include "io/options.h"
#include "mapping/camera.h"

namespace montage {

struct Mesh;
struct Photo;

struct SubjectOptions {
  // Auto decision. A photo is taken for the object itself only when a camera explains its clicks to the accuracy
  // of a click: at least `objectShare` of them within the camera fit's agreement threshold and a robust spread of
  // all their residuals (1.4826 x the median) below `objectSpread` x that threshold. It is decided on its first
  // `decisionClicks` clicks (in point order), then changes only when all its clicks clearly say otherwise (the
  // flip thresholds), so that adding, moving or deleting one click does not flip it back and forth.
  // A photo with a background (a cut-out) must also show the mesh's silhouette through that camera: an intersection
  // over union of at least `objectSilhouette` (the flip thresholds likewise), the strongest evidence: a similar face
  // fits a camera about as well as a noisy photo of the head itself (spread 0.60 against 0.53 with 1 px noise at
  // 512 px), but overlaps its silhouette by 43% against 99%. Without one, the spread must stay below
  // `objectSpreadAlone`.
  int decisionClicks = 8;
  double objectShare = 0.9;
  double objectSpread = 0.75;
  double objectSpreadAlone = 0.45;
  double objectSilhouette = 0.85;
  double toSubjectShare = 0.75;       // an object photo becomes another subject below this share...
  double toSubjectSpread = 1.0;       // ...or above this spread
  double toSubjectSilhouette = 0.75;  // ...or below this silhouette agreement
  double toObjectShare = 0.97;        // a photo of another subject becomes the object itself above this share...
  double toObjectSpread = 0.35;       // ...and below this spread
  double toObjectSilhouette = 0.92;   // ...and above this silhouette agreement
  // ...or, once it has this many clicks, when all of them pass the first decision's spread with the flip's share and
  // silhouette: the first clicks' spread is a noisy figure (8 clicks of 3 px noise at 1024 px reach 0.76), while
  // dozens of clicks that agree with one camera and show its silhouette are the object itself.
  int joinClicks = 32;
  // Warp (moving least squares): weights 1 / distance^(2 alpha); affine (non-uniform scale and shear: proportions
  // that differ) or similarity (docs/pipeline.md compares them).
  double warpAlpha = 1.0;
  bool affineWarp = true;
  // Choice between the warp and the paper's map.
  double maxFoldShare = 0.01;  // the warp folds at most this share of the faces it maps
  double stretchRatio = 1.5;   // ...and its stretch is at most this times the paper's map's
};

// How well one camera explains a photo (from fitCamera's result over some of its clicks).
struct CameraEvidence {
  int clicks = 0;
  double agreeShare = 0;   // share of clicks within the fit's agreement threshold
  double spread = 0;       // robust spread of all residuals, in units of that threshold (inf: no camera)
  double silhouette = -1;  // intersection over union of the mesh rendered through the camera and the photo's
                           // foreground; -1 when the photo has no background (or there is no camera)
};
// `photo` (may be null): the photo, for the silhouette's agreement.
CameraEvidence cameraEvidence(const CameraFit& fit, const Mesh& mesh, const Photo* photo);

// The decision of an auto photo: `first` is the evidence of its first decisionClicks clicks (empty when it has
// fewer), `all` of all of them.
struct ModeDecision {
  PhotoMode mode = PhotoMode::Subject;
  std::string why;  // plain words, with the figures
};
ModeDecision decidePhotoMode(const CameraEvidence& first, const CameraEvidence& all,
                             const SubjectOptions& options = {});
// The same from the photo's clicks (in point order) and `fit`, the object fit of all of them: fits a camera to its
// first decisionClicks clicks and weighs both (what the camera stage does for an auto photo).
// `findSilhouettes`: a photo without a cut-out that the clicks alone leave for another subject, where a silhouette
// that agrees would make it the object itself, takes the silhouette found around the mesh's outline through `fit`'s
// camera (found_silhouette.h) as a cut-out's; when none is found, the clicks alone decide.
ModeDecision decidePhotoMode(const Mesh& mesh, const Photo& photo, const std::vector<CameraClick>& clicks,
                             const CameraFit& fit, const CameraFitOptions& fitOptions,
                             const SubjectOptions& options = {}, bool findSilhouettes = false);

// A moving-least-squares deformation of the photo plane: handle i moves from `from[i]` to `to[i]`; every point
// moves by the affine (or similarity) map that best moves the handles, each weighted by 1 / |from[i] - x|^(2
// alpha). Exact at the handles. Pixels (photo.h).
struct ImageWarp {
  std::vector<Vec2> from, to;
  double alpha = 1.0;
  bool affine = true;
  bool empty() const { return from.empty(); }
  Vec2 apply(const Vec2& x) const;
  // Where handle i goes when it is left out of the warp (leave-one-out), minus to[i]: the warp's held-out error.
  Vec2 heldOut(int i) const;
  uint64_t hash(uint64_t seed) const;
};

}  // namespace montage
