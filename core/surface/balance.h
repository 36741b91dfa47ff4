// Colour balance between photos: the paper's first preprocessing step (section 2: "we use Adobe
// Photoshop to adjust exposure differences and color balances between these images"), automated. Per
// photo a colour transform (a gain, or a gain and an offset, per channel of linear RGB) is solved jointly
// over the colour samples on the seams between photos that the mapping just found, with a robust loss, so
// that a photo that differs only somewhere (a shadow, a highlight, a misregistered edge) does not skew
// the whole transform. Reference photos keep their colours; seam levelling then only closes what is left.
// Choices and measurements: docs/photos.md ("Colour balance between photos").
#pragma once

#include <array>
#include <memory>
#include <string>
#include <vector>

#include "base/common.h"
#include "image/color.h"
#include "io/options.h"
#include "mapping/texture_map.h"
#include "surface/trust.h"

namespace montage {

struct Mesh;
struct Photo;
class JobControl;

// The robust loss of the fit (iteratively reweighted least squares): plain least squares, Huber
// (quadratic up to 1.345 sigma, then linear), or Cauchy (weight 1 / (1 + (r / 2.385 sigma)^2)); sigma is
// 1.4826 times the median absolute residual, re-estimated at every iteration.
enum class BalanceLoss { L2, Huber, Cauchy };
inline constexpr std::array<const char*, 3> kBalanceLossNames = {"l2", "huber", "cauchy"};

struct BalanceOptions {
  BalanceMode mode = BalanceMode::GainOffset;  // the transform per photo (Off: every photo as it is)
  BalanceLoss loss = BalanceLoss::Cauchy;      // robust loss (docs/photos.md compares them)
  bool linear = true;                          // the transform acts on linear RGB (false: on sRGB values)
  int maxIterations = 30;                      // IRLS iterations at most
  double tolerance = 1e-7;                     // IRLS stops when no gain or offset moves more than this
  double offsetSigma = 0.02;                   // offsets expected a priori (fit units): a photo's offset is pulled
                                               // towards 0 as by a sample of this size, so that seams showing
                                               // one colour (which cannot tell a gain from an offset) give a gain
  double flatRadiusPx = 4;  // samples are weighted by how flat both photos are within this radius (pixels), so
                            // that a misregistration of the seam that large does not count (0 = no weighting)
  double flatRange = 0.03;  // ... by 1 / (1 + (range / flatRange)^2), range = max - min of the channel there (sRGB)
  double channelPrior = 4;  // a channel's gain is pulled towards the photo's common gain (exposure) as much
                            // as this many average samples agreeing with it would: a channel with few usable
                            // samples does not stray, one with many is free (0 = channels independent)
  int minSamples = 16;      // a photo pair with fewer usable seam samples (counted by their trust) does not count
  double saturated = 0.99;  // sRGB channel values at or above this are clipped: they say
                            // nothing about a gain and are left out
  double darkest = 0.08;    // ... and so are values below this (sRGB): 8-bit quantisation
                            // leaves them a relative error that biases gains towards 0
  TrustOptions trust;       // seam samples are weighted by the smaller trust of their two faces (surface/trust.h):
                            // grazing and sparsely seen texels count less or not at all, also towards minSamples
};

// ColorTransform (image/color.h): per photo, on linear RGB or on sRGB values (BalanceOptions::linear).

struct ColorBalance {
  std::vector<ColorTransform> transforms;  // per photo (identity for references and photos on no seam)
  std::vector<char> reference;  // per photo: kept as it is (locked by the user, or the first photo of a group
                                // of photos joined by seams to no locked photo)
  int samples = 0;              // seam samples used (both sides foreground, not clipped)
  int pairs = 0;                // photo pairs sharing enough seam samples
  int iterations = 0;           // IRLS iterations (largest over the channels)
  int edgesKept = 0;            // seam edges whose samples came from a BalanceMemo
  double outlierShare = 0;      // share of samples the robust loss weighs down (|r| beyond its threshold)
  double mismatchBefore = 0;    // mean Delta E*uv across the seam samples before the transforms
  double mismatchAfter = 0;     // ... and after
  std::vector<double> commonGain;  // per photo: the gain shared by the channels (exposure), the channels' start
  double seconds = 0;
  std::vector<std::string> warnings;
};

// The seam samples of earlier runs, per seam edge: an edge's samples read only its two photos and its
// four UVs, so they are keyed by the photos' content keys, the UVs and the sampling options. A hit is the
// same samples bit for bit: both tiers use it. Entries not used in the last run are dropped at the start
// of the next.
class BalanceMemo {
 public:
  BalanceMemo();
  ~BalanceMemo();
  void beginRun();
  struct Impl;
  Impl& impl() { return *impl_; }

 private:
  std::unique_ptr<Impl> impl_;
};

// Solves the transforms over the seams of `map` (edges between faces mapped to two different photos).
// `locked[i]`: photo i keeps its colours (may be empty: none locked). Photos joined by seams to no locked
// photo are matched to the first of them. Seam samples are weighted by the smaller alpha of their two
// sides, so a feathered cut-out edge counts less, and by the smaller trust of their two faces (faceTrust).
// With `memo` (may be null) and `photoKeys` (per photo, what identifies its pixels; 0 = unknown, never
// kept), the samples of seam edges an earlier run saw are taken from the memo.
// With `warm` (the preview tier: an earlier balance of the same photos), the fits start from its transforms
// and the channels take one round of sample choice instead of two: a few iterations instead of ten or more,
// to within options.tolerance of where they start, so the result is close to, not equal to, a cold fit's.
ColorBalance balanceColors(const Mesh& mesh, const TextureMap& map, const std::vector<const Photo*>& photos,
                           const std::vector<bool>& locked, const BalanceOptions& options, const JobControl& job,
                           BalanceMemo* memo = nullptr, const std::vector<uint64_t>& photoKeys = {},
                           const ColorBalance* warm = nullptr);

// How far apart the balanced photos of two transforms are: the largest difference of a balanced channel
// value, in 8-bit steps (1/255), over every value a photo of this OpenCV depth stores. 0 means the two
// balanced photos are the same bit for bit (for float photos: the transforms are equal; otherwise the
// difference is sampled at 4,097 values a channel and is never 0).
double balancedPhotoDistance(const ColorTransform& a, const ColorTransform& b, int depth);

// The photo with its colours transformed: a new Photo sharing the original's alpha and distance maps, its
// colours at the original's depth (8-bit, 16-bit or float) and stored resolution, or `photo` itself (the
// same object, bit for bit) when the transform is the identity.
std::shared_ptr<const Photo> balancedPhoto(const std::shared_ptr<const Photo>& photo, const ColorTransform& transform);

}  // namespace montage
