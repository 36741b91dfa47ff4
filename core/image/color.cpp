#include "image/color.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <vector>

namespace montage {

namespace {

// sRGB primaries to CIE XYZ (D65), IEC 61966-2-1. The white point is the image of RGB (1,1,1), so
// sRGB white maps to u* = v* = 0 exactly.
const Eigen::Matrix3d& rgbToXyz() {
  static const Eigen::Matrix3d m = (Eigen::Matrix3d() << 0.4124564, 0.3575761, 0.1804375,  //
                                    0.2126729, 0.7151522, 0.0721750,                       //
                                    0.0193339, 0.1191920, 0.9503041)
                                       .finished();
  return m;
}

const Eigen::Matrix3d& xyzToRgb() {
  static const Eigen::Matrix3d m = rgbToXyz().inverse();
  return m;
}

struct WhitePoint {
  double Y, u, v;  // luminance and CIE 1976 chromaticity (u', v')
};

const WhitePoint& white() {
  static const WhitePoint w = [] {
    const Eigen::Vector3d xyz = rgbToXyz() * Eigen::Vector3d::Ones();
    const double d = xyz.x() + 15 * xyz.y() + 3 * xyz.z();
    return WhitePoint{xyz.y(), 4 * xyz.x() / d, 9 * xyz.y() / d};
  }();
  return w;
}

constexpr double kEpsilon = 216.0 / 24389.0;  // (6/29)^3: below it L* is linear in Y
constexpr double kKappa = 24389.0 / 27.0;     // (29/3)^3

// sRGB (gamma encoded) to CIE XYZ, and back.
Eigen::Vector3d srgbToXyz(const Vec3f& rgb) {
  return rgbToXyz() * Eigen::Vector3d(srgbToLinear(rgb.x()), srgbToLinear(rgb.y()), srgbToLinear(rgb.z()));
}

Vec3f xyzToSrgb(const Eigen::Vector3d& xyz) {
  const Eigen::Vector3d lin = xyzToRgb() * xyz;
  return Vec3f(float(linearToSrgb(lin.x())), float(linearToSrgb(lin.y())), float(linearToSrgb(lin.z())));
}

Eigen::Vector3d toLuv(const Vec3f& rgb) {
  const Eigen::Vector3d xyz = srgbToXyz(rgb);
  const WhitePoint& w = white();
  const double y = xyz.y() / w.Y;
  const double L = y > kEpsilon ? 116 * std::cbrt(y) - 16 : kKappa * y;
  const double d = xyz.x() + 15 * xyz.y() + 3 * xyz.z();
  if (L <= 0 || d <= 0) return Eigen::Vector3d(std::max(L, 0.0), 0, 0);  // black: chromaticity undefined
  const double up = 4 * xyz.x() / d, vp = 9 * xyz.y() / d;
  return Eigen::Vector3d(L, 13 * L * (up - w.u), 13 * L * (vp - w.v));
}

}  // namespace

// Odd extensions keep out-of-gamut (negative) values invertible.
double srgbToLinear(double c) {
  const double a = std::abs(c);
  const double l = a <= 0.04045 ? a / 12.92 : std::pow((a + 0.055) / 1.055, 2.4);
  return std::copysign(l, c);
}

double linearToSrgb(double l) {
  const double a = std::abs(l);
  const double c = a <= 0.0031308 ? 12.92 * a : 1.055 * std::pow(a, 1 / 2.4) - 0.055;
  return std::copysign(c, l);
}

namespace {

class TransferTables {
 public:
  TransferTables() : toLinear_(kSteps + 1), toSrgb_(kSteps + 1) {
    for (int i = 0; i <= kSteps; ++i) {
      toLinear_[i] = float(srgbToLinear(double(i) / kSteps));
      toSrgb_[i] = float(linearToSrgb(double(i) / kSteps));
    }
  }
  float linear(float srgb) const { return lookup(toLinear_, srgb); }
  float srgb(float linear) const { return lookup(toSrgb_, linear); }

 private:
  static constexpr int kSteps = 65536;
  static float lookup(const std::vector<float>& table, float x) {
    const float u = std::clamp(x, 0.0f, 1.0f) * kSteps;
    const int i = std::min(int(u), kSteps - 1);
    return table[i] + (u - i) * (table[i + 1] - table[i]);
  }
  std::vector<float> toLinear_, toSrgb_;
};

const TransferTables& tables() {
  static const TransferTables instance;  // immutable after construction (thread-safe initialisation)
  return instance;
}

}  // namespace

float srgbToLinearFast(float c) {
  return tables().linear(c);
}

float linearToSrgbFast(float l) {
  return tables().srgb(l);
}

float ColorTransform::apply(float srgb, int c) const {
  const float x = linear ? srgbToLinearFast(srgb) : srgb;
  const float y = std::clamp(gain[c] * x + offset[c], 0.0f, 1.0f);
  return linear ? linearToSrgbFast(y) : y;
}

Vec3f ColorTransform::apply(const Vec3f& srgb) const {
  if (identity()) return srgb;
  Vec3f out;
  for (int c = 0; c < 3; ++c) out[c] = apply(srgb[c], c);
  return out;
}

Vec3f srgbToLuv(const Vec3f& rgb) {
  return toLuv(rgb).cast<float>();
}

Vec3f luvToSrgb(const Vec3f& luv) {
  const double L = luv.x();
  if (L <= 0) return Vec3f::Zero();
  const WhitePoint& w = white();
  const double up = luv.y() / (13 * L) + w.u, vp = luv.z() / (13 * L) + w.v;
  const double Y = w.Y * (L > kKappa * kEpsilon ? std::pow((L + 16) / 116, 3) : L / kKappa);
  if (vp <= 0) return Vec3f::Zero();  // not a real colour; map to black rather than divide by zero
  return xyzToSrgb(Eigen::Vector3d(Y * 9 * up / (4 * vp), Y, Y * (12 - 3 * up - 20 * vp) / (4 * vp)));
}

cv::Mat srgbToLuv(const cv::Mat& rgb) {
  TM_CHECK(rgb.type() == CV_32FC3, "srgbToLuv: expected a CV_32FC3 image");
  cv::Mat luv(rgb.size(), CV_32FC3);
  cv::parallel_for_(cv::Range(0, rgb.rows), [&](const cv::Range& rows) {
    for (int r = rows.start; r < rows.end; ++r) {
      const auto* in = rgb.ptr<cv::Vec3f>(r);
      auto* out = luv.ptr<cv::Vec3f>(r);
      for (int c = 0; c < rgb.cols; ++c) {
        const Vec3f v = srgbToLuv(Vec3f(in[c][0], in[c][1], in[c][2]));
        out[c] = cv::Vec3f(v.x(), v.y(), v.z());
      }
    }
  });
  return luv;
}

namespace {

// CIE L*a*b*'s f(t) and its inverse.
double labF(double t) {
  return t > kEpsilon ? std::cbrt(t) : (kKappa * t + 16) / 116;
}
double labFInverse(double f) {
  return f * f * f > kEpsilon ? f * f * f : (116 * f - 16) / kKappa;
}

const Eigen::Vector3d& labWhite() {  // XYZ of sRGB white
  static const Eigen::Vector3d n = rgbToXyz() * Eigen::Vector3d::Ones();
  return n;
}

}  // namespace

Vec3f srgbToLab(const Vec3f& rgb) {
  const Eigen::Vector3d xyz = srgbToXyz(rgb);
  const Eigen::Vector3d& n = labWhite();
  const double fx = labF(xyz.x() / n.x()), fy = labF(xyz.y() / n.y()), fz = labF(xyz.z() / n.z());
  return Vec3f(float(116 * fy - 16), float(500 * (fx - fy)), float(200 * (fy - fz)));
}

Vec3f labToSrgb(const Vec3f& lab) {
  const double fy = (lab.x() + 16) / 116.0, fx = fy + lab.y() / 500.0, fz = fy - lab.z() / 200.0;
  const Eigen::Vector3d& n = labWhite();
  return xyzToSrgb(Eigen::Vector3d(n.x() * labFInverse(fx), n.y() * labFInverse(fy), n.z() * labFInverse(fz)));
}

cv::Mat srgbToLab8(const cv::Mat& rgb) {
  TM_CHECK(rgb.type() == CV_32FC3, "srgbToLab8: expected a CV_32FC3 image");
  cv::Mat lab(rgb.size(), CV_8UC3);
  for (int r = 0; r < rgb.rows; ++r) {
    const auto* in = rgb.ptr<cv::Vec3f>(r);
    auto* out = lab.ptr<cv::Vec3b>(r);
    for (int c = 0; c < rgb.cols; ++c) {
      const Vec3f v = srgbToLab(Vec3f(in[c][0], in[c][1], in[c][2]));
      out[c] = cv::Vec3b(cv::saturate_cast<uchar>(v.x() * 255 / 100), cv::saturate_cast<uchar>(v.y() + 128),
                         cv::saturate_cast<uchar>(v.z() + 128));
    }
  }
  return lab;
}

cv::Mat lab8ToSrgb(const cv::Mat& lab) {
  TM_CHECK(lab.type() == CV_8UC3, "lab8ToSrgb: expected a CV_8UC3 image");
  cv::Mat rgb(lab.size(), CV_32FC3);
  for (int r = 0; r < lab.rows; ++r) {
    const auto* in = lab.ptr<cv::Vec3b>(r);
    auto* out = rgb.ptr<cv::Vec3f>(r);
    for (int c = 0; c < lab.cols; ++c) {
      const Vec3f v = labToSrgb(Vec3f(in[c][0] * 100.0f / 255, in[c][1] - 128.0f, in[c][2] - 128.0f));
      out[c] = cv::Vec3f(std::clamp(v.x(), 0.0f, 1.0f), std::clamp(v.y(), 0.0f, 1.0f), std::clamp(v.z(), 0.0f, 1.0f));
    }
  }
  return rgb;
}

float deltaEuv(const Vec3f& rgbA, const Vec3f& rgbB) {
  return float((toLuv(rgbA) - toLuv(rgbB)).norm());
}

}  // namespace montage
