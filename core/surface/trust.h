// How far a photo's colour at a surface point can be trusted (issue 37): a face seen at a grazing angle is
// smeared over few pixels along one direction, a face far from its camera is seen at low density, and a
// clipped channel says nothing about the surface's colour. Colour balance weights its seam samples by this
// trust, and seam levelling takes the colour differences of untrusted seam edges from the trusted ones.
// Choices and measurements: docs/photos.md ("Trusting good texels").
#pragma once

#include <vector>

#include "base/common.h"
#include "mapping/texture_map.h"

namespace montage {

struct Mesh;

struct TrustOptions {
  double grazingRatio = 0.3;      // a face's stretch ratio (smallest / largest singular value of its map from the
                                  // surface to the photo, 1 = seen head on) below which it is not trusted at all ...
  double fullRatio = 0.6;         // ... and from which on fully (linear in between)
  double clipLow = 3 / 255.0;     // sRGB channel values at or below this are clipped (not trusted) ...
  double clipHigh = 252 / 255.0;  // ... and so are values at or above this
};

// The trust of one mapped face's photo samples, in [0, 1]: its angle term (the stretch ratio of its map
// into its photo, TrustOptions::grazingRatio..fullRatio) times its density term, sqrt(density / median
// density) capped at 1, where density is photo pixels per unit of surface area and the median is over
// every mapped face of every photo.
struct FaceTrust {
  std::vector<float> trust;  // #F, 0 for unmapped faces and faces whose map is degenerate
  std::vector<float> ratio;  // #F, the stretch ratio (0 for unmapped faces)
  double medianDensity = 0;  // photo pixels per unit of surface area, the median over mapped faces
};

// The trust of every face of `map` (cornerUV in pixels of the face's photo) on `mesh`.
FaceTrust faceTrust(const Mesh& mesh, const TextureMap& map, const TrustOptions& options = {});

// True when any channel of an sRGB colour ([0, 1]) is clipped (TrustOptions::clipLow, clipHigh).
bool clippedColor(const Vec3f& srgb, const TrustOptions& options = {});

}  // namespace montage
