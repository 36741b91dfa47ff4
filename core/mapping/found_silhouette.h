// A silhouette for a photo of the object itself that has no cut-out (issue 37, real photos): the clicks' camera
// puts the mesh's outline within a few pixels of the object's in the photo, so GrabCut (image/cutout.h) started from
// that outline — certain foreground well inside it, certain background well outside, the band between uncertain —
// finds the object's edge the way a user's cut-out would. The camera stage then refines the camera on it as on a
// user's cut-out (refineOnSilhouette) and keeps it as the photometric refinement's silhouette term: with no photo
// overlapping another (two views 180 degrees apart), the silhouette is the only cue beyond the clicks.
//
// The cut is taken only where the photo shows it: the found foreground must cover the projection as a cut-out of
// the same object does (intersection over union), and its edge must stay inside the band (an edge along the band's
// limit is the mesh's outline meeting more of the photo's object, or a background GrabCut could not tell apart:
// hair or shoulders beyond a head scan, a cluttered room). The camera refinement then keeps it only under its own
// click tests.
#pragma once

#include <opencv2/core.hpp>
#include <string>

#include "image/cutout.h"
#include "mapping/camera.h"

namespace montage {

struct Mesh;
struct Photo;

struct FoundSilhouetteOptions {
  double bandThresholds = 1.5;  // the band's half width: this many of the fit's agreement thresholds (13 px at 1024²)
  double minBandPx = 6;         // ...and never narrower than this (pixels)
  double minIoU = 0.9;          // the found foreground against the projection's
  double maxAtLimit = 0.05;     // share of the found edge allowed within a pixel of the band's limits
  CutoutOptions cutout;         // GrabCut at a working size, its edge decided again at the photo's pixels
};

struct FoundSilhouette {
  bool found = false;
  std::string why;     // why it was not taken, or a summary
  double bandPx = 0;   // the band's half width
  double iou = 0;      // the found foreground against the projection's
  double atLimit = 0;  // share of the found edge at the band's limits
  double seconds = 0;  // the projection, GrabCut and the checks
  cv::Mat mask;        // CV_8UC1 at the photo's stored size: 0 background, 255 foreground, soft on the edge (the
                       // colour unmixed between the two sides' nearby); empty unless found
};

// The mesh's coverage through `camera` (its lens included): CV_8UC1 of the camera's image size, 255 where a
// triangle in front of the camera lands.
cv::Mat projectedCoverage(const Mesh& mesh, const PhotoCamera& camera);

// Intersection over union of the mesh's coverage through `camera` and `mask` (FoundSilhouette::mask, > 127
// foreground), at the mask's size.
double outlineAgreement(const Mesh& mesh, const PhotoCamera& camera, const cv::Mat& mask);

// The cut-out of `photo` (which has no background) found around the mesh's outline through `camera`, whose fit
// agrees within `thresholdPx` (CameraFit::thresholdPx).
FoundSilhouette findSilhouette(const Mesh& mesh, const Photo& photo, const PhotoCamera& camera, double thresholdPx,
                               const FoundSilhouetteOptions& options = {});

// A copy of `photo` sharing its pixels, with `mask` (CV_8UC1, FoundSilhouette::mask) as its alpha (area-averaged to
// the stored size when it is of another). No distance map (the camera stage's SilhouetteDistance reads the alpha
// alone).
Photo withForeground(const Photo& photo, const cv::Mat& mask);

}  // namespace montage
