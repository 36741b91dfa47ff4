// Photometric refinement of the object photos' cameras (issue 37, "refine against the photos' content"): where fitted
// photos overlap, their cameras are refined so that every surface point seen by two or more photos takes one colour
// in all of them, after Zhou & Koltun 2014 (colour map optimisation: the cameras and a colour per surface sample,
// optimised alternately), with
// - a gain and an offset per photo and channel, so that exposure differences are not read as misregistration;
// - a robust (Huber) loss, clipped and grazing texels and texels near a depth edge or the photo's silhouette left out;
// - the clicks as a prior weighted by their noise (CameraFit::noisePx): exact clicks keep the camera where it is;
// - the photo's silhouette, where it has a background, as refineOnSilhouette has it (camera.h);
// - coarse to fine over blurred photos, for a wider basin.
// The unknowns are each photo's pose and its focal length (noisy clicks leave the focal a few percent off, which poses
// alone cannot make up), one focal length for the photos that share one camera's intrinsics (fitSharedIntrinsics),
// all in one Levenberg-Marquardt system; the lens terms stay as the clicks' fit gives them.
// Acceptance by held-out re-rendering: the cameras are refined on a spatial half of the surface samples (cells of a
// tenth of the bounding box, in a checkerboard), and each photo is then predicted from the others on the other half;
// the refinement is kept only when those predictions come closer to the photos than with the clicks' cameras. Then
// the cameras are refined on all samples at the finest level, from where the test left them. (Holding out whole photos,
// as virtual rephotography does, judges nothing here: the held-out photo's own camera comes from the same noisy clicks
// and its error dominates, docs/pipeline.md.)
#pragma once

#include <string>
#include <vector>

#include "base/common.h"
#include "mapping/camera.h"

namespace montage {

struct Mesh;
struct Photo;
class JobControl;

struct PhotometricOptions {
  int samples = 60000;                     // surface samples, spread over the surface by area
  std::vector<double> blurPx = {4, 2, 1};  // coarse to fine: the photos blurred by this sigma, file pixels
  int iterations = 8;                      // Gauss-Newton (Levenberg-Marquardt) steps per level and photo
  int rounds = 3;                          // alternations per level: the samples' colours, the gains, the poses
  double minCosine = 0.3;                  // a photo sees a sample within acos(0.3) = 73 degrees of its normal...
  double marginPx = 3;           // ...at least this far from the photo's silhouette and from a depth edge (file pixels)
  int minSharedSamples = 200;    // a photo takes part when it sees this many samples that another photo sees
  double minImprovement = 0.01;  // kept when the held-out error drops by at least this share
  double minClickSigmaPx = 0.05;   // the clicks' prior never weighs more than clicks of this noise (pixels)
  double huber = 1.345;            // Huber's threshold in robust standard deviations of the colour residuals
  double silhouetteSigmaPx = 0.5;  // photos with a background: their silhouette as a term of its own (the camera's
  double silhouetteHuberPx = 1.5;  // silhouette refinement's, CameraFitOptions), so that the overlaps do not undo it
  double silhouetteSpacingPx = 2;
};

struct PhotometricRefinement {
  bool tried = false;  // two or more object photos share enough samples
  bool kept = false;   // the held-out photos (or samples) are re-rendered better: the refined cameras are taken
  std::string why;
  std::vector<int> photos;         // the photos that took part (indices into the fits given)
  int samples = 0;                 // surface samples seen by two or more of them
  double heldOutBefore = 0;        // the held-out error with the clicks' cameras: mean absolute colour difference
  double heldOutAfter = 0;         // ...with the refined cameras (sRGB units, 0..1, per channel)
  std::vector<double> shiftPx;     // per photo in `photos`: median movement of its samples' projections, pixels
  std::vector<Vec3> gain, offset;  // per photo in `photos`: its colour model against the samples' colours
  double seconds = 0;
};

// Refines the poses of `fits` (photos[i] is fits[i]'s photo; fits that do not fit, or fit as another subject, are
// left out) as above. When kept, every refined fit takes its new camera with its clicks re-measured; otherwise the
// fits are left untouched. `job` (may be null) is checked for cancellation between steps.
// `silhouettes` (optional, per photo): the callers' SilhouetteDistance of the photos with a background, or of a
// silhouette found for a photo without one (mapping/found_silhouette.h).
PhotometricRefinement refineCamerasPhotometric(const Mesh& mesh, const std::vector<const Photo*>& photos,
                                               const std::vector<CameraFit*>& fits,
                                               const PhotometricOptions& options = {}, const JobControl* job = nullptr,
                                               const std::vector<const SilhouetteDistance*>& silhouettes = {});

}  // namespace montage
