// Colour spaces: sRGB <-> linear <-> CIE XYZ (D65) <-> CIE L*u*v*, and the difference metrics the
// evaluation uses.
#pragma once

#include <opencv2/core.hpp>

#include "base/common.h"

namespace montage {

// sRGB transfer function, one channel: gamma-encoded value to linear light (odd extension below 0).
double srgbToLinear(double c);
// Inverse of srgbToLinear: linear light to gamma-encoded sRGB (odd extension below 0, no clamping).
double linearToSrgb(double l);
// The same through tables with linear interpolation (65536 steps: error below 1e-7), inputs clamped to
// [0,1], so that a 12-megapixel photo is transformed in a fraction of a second.
float srgbToLinearFast(float c);
float linearToSrgbFast(float l);

// A colour transform on linear RGB (or on the sRGB values themselves when not `linear`): c' = gain * c +
// offset, per channel, clamped to [0, 1]. Colour balance makes one per photo (surface/balance.h); a
// Material applies one to its texture (io/model.h).
struct ColorTransform {
  Vec3f gain = Vec3f::Ones();
  Vec3f offset = Vec3f::Zero();
  bool linear = true;
  bool identity() const { return gain == Vec3f::Ones() && offset == Vec3f::Zero(); }
  // Channel c of an sRGB value in [0,1] after the transform.
  float apply(float srgb, int c) const;
  // The transformed colour of an sRGB colour in [0,1].
  Vec3f apply(const Vec3f& srgb) const;
};

// sRGB in [0,1] (gamma encoded) to CIE L*u*v* with the D65 white point; L in [0,100].
Vec3f srgbToLuv(const Vec3f& rgb);
Vec3f luvToSrgb(const Vec3f& luv);
// Whole-image conversion, CV_32FC3 RGB in [0,1] to CV_32FC3 L*u*v*.
cv::Mat srgbToLuv(const cv::Mat& rgb);
// sRGB in [0,1] to CIE L*a*b* (D65 white; L in [0,100]) and back (no clamping).
Vec3f srgbToLab(const Vec3f& rgb);
Vec3f labToSrgb(const Vec3f& lab);
// Whole-image conversions to and from 8-bit L*a*b* in OpenCV's encoding (L * 255 / 100, a + 128, b + 128):
// CV_32FC3 RGB in [0,1] to CV_8UC3, and back (clamped into [0,1]). OpenCV's own 8-bit conversion builds
// its tables on first use, a tenth of a second of a cold run.
cv::Mat srgbToLab8(const cv::Mat& rgb);
cv::Mat lab8ToSrgb(const cv::Mat& lab);
// Euclidean distance in L*u*v* (the CIE 1976 Delta E*uv) between two sRGB colours.
float deltaEuv(const Vec3f& rgbA, const Vec3f& rgbB);

}  // namespace montage
