#include "image/photo.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <opencv2/imgproc.hpp>

#include "base/fileio.h"
#include "image/codec.h"
#include "image/color.h"
#include "image/cutout.h"

namespace fs = std::filesystem;

namespace montage {

namespace {

constexpr int kStatsSide = 4096;  // photoStats: exact distance maps up to this side

void requireFile(const std::string& path) {
  requireRegularFile(path, "image file");
}

// The depths a photo may have: 8-bit, 16-bit or float (in [0,1]).
void requirePhotoDepth(const std::string& path, const cv::Mat& image) {
  TM_CHECK(image.depth() == CV_8U || image.depth() == CV_16U || image.depth() == CV_32F,
           located(path, "unsupported pixel format (only 8-bit, 16-bit and float images are read)"));
  TM_CHECK(image.channels() >= 1 && image.channels() <= 4,
           located(path, std::to_string(image.channels()) + " channels; expected 1 (grey), 3 (RGB) or 4 (RGBA)"));
}

// An alpha or mask channel of any depth as CV_8UC1: 0 stays 0 (background), any value above 0 becomes at
// least 1 (foreground), 1.0 / 65535 / 255 become 255.
cv::Mat alpha8(const cv::Mat& channel) {
  if (channel.depth() == CV_8U) return channel;
  cv::Mat out;
  channel.convertTo(out, CV_8U, channel.depth() == CV_16U ? 1.0 / 257 : 255.0);
  out.setTo(1, (channel > 0) & (out == 0));
  return out;
}

// Foreground from a mask image: a pixel is foreground when one of its colour channels is non-zero and
// (for masks with alpha) it is not transparent. CV_8UC1: its alpha is its largest colour channel relative
// to the largest value in the mask (255 there), so a 0/1 label image and a 0/255 mask both give 255 on the
// foreground, and a feathered edge (cutout.h) gives partial alpha; a non-zero value stays at least 1, so
// the foreground is the same either way.
cv::Mat maskToAlpha(const cv::Mat& mask) {
  std::vector<cv::Mat> channels;
  cv::split(mask, channels);
  const int colours = mask.channels() == 2 || mask.channels() == 4 ? mask.channels() - 1 : mask.channels();
  cv::Mat colour;
  channels[0].convertTo(colour, CV_32F);
  for (int c = 1; c < colours; ++c) {
    cv::Mat other;
    channels[c].convertTo(other, CV_32F);
    cv::max(colour, other, colour);
  }
  cv::max(colour, 0.0, colour);
  double largest = 0;
  cv::minMaxLoc(colour, nullptr, &largest);
  cv::Mat alpha;
  colour.convertTo(alpha, CV_8U, largest > 0 ? 255.0 / largest : 0.0);
  alpha.setTo(1, (colour > 0) & (alpha == 0));
  if (colours < mask.channels()) alpha.setTo(0, channels.back() == 0);
  return alpha;
}

std::string sizeText(cv::Size s) {
  return std::to_string(s.width) + "x" + std::to_string(s.height);
}

// The stored size of a photo under a working resolution (PhotoLoadOptions::maxSide).
cv::Size storedSize(cv::Size file, int maxSide) {
  const int longest = std::max(file.width, file.height);
  if (maxSide <= 0 || longest <= maxSide) return file;
  const double s = double(maxSide) / longest;
  return cv::Size(std::max(1, int(std::lround(file.width * s))), std::max(1, int(std::lround(file.height * s))));
}

// Colour channels of a decoded image (OpenCV order B,G,R(,A) or grey) as R,G,B at its depth.
cv::Mat toRgb(const cv::Mat& image) {
  cv::Mat rgb;
  switch (image.channels()) {
    case 1:
      cv::cvtColor(image, rgb, cv::COLOR_GRAY2RGB);
      break;
    case 2: {
      cv::Mat grey;
      cv::extractChannel(image, grey, 0);
      cv::cvtColor(grey, rgb, cv::COLOR_GRAY2RGB);
      break;
    }
    case 3:
      cv::cvtColor(image, rgb, cv::COLOR_BGR2RGB);
      break;
    default:
      cv::cvtColor(image, rgb, cv::COLOR_BGRA2RGB);
      break;
  }
  return rgb;
}

// The foreground of a photo at the file's resolution, CV_8UC1 (0 = background), or empty when the
// whole photo is foreground (no mask, no alpha channel). Throws when nothing is foreground.
// `mirror`: the mask is flipped left to right, as the (already flipped) image.
cv::Mat fileAlpha(const std::string& path, const std::string& maskPath, const cv::Mat& image, bool mirror = false) {
  cv::Mat alpha;
  if (!maskPath.empty()) {
    cv::Mat mask = readImageFile(maskPath);
    if (mirror) cv::flip(mask, mask, 1);  // a mask is in its photo file's pixels
    TM_CHECK(mask.size() == image.size(),
             located(maskPath, "mask is " + sizeText(mask.size()) + " but photo " + path + " is " +
                                   sizeText(image.size()) + "; they must have the same size"));
    alpha = maskToAlpha(mask);
  } else if (image.channels() == 2 || image.channels() == 4) {
    cv::Mat channel;
    cv::extractChannel(image, channel, image.channels() - 1);
    alpha = alpha8(channel);
  } else {
    return {};
  }
  TM_CHECK(
      cv::countNonZero(alpha) > 0,
      located(maskPath.empty() ? path : maskPath,
              "no foreground pixel (" + std::string(maskPath.empty() ? "alpha" : "mask") + " is zero everywhere)"));
  return alpha;
}

// Distance in pixels from every pixel centre to the nearest foreground pixel centre (CV_32FC1).
cv::Mat distanceToForeground(const cv::Mat& alpha) {
  cv::Mat distance;
  {
    const cv::Mat background = alpha == 0;  // 255 on background pixels
    cv::distanceTransform(background, distance, cv::DIST_L2, cv::DIST_MASK_PRECISE, CV_32F);
  }
  return distance;
}

}  // namespace

Photo loadPhoto(const std::string& path, const std::string& maskPath) {
  return loadPhoto(path, maskPath, PhotoLoadOptions{});
}

Photo loadPhoto(const std::string& path, const std::string& maskPath, const PhotoLoadOptions& options) {
  Photo photo;
  photo.path = path;
  photo.maskPath = maskPath;
  photo.mirrored = options.mirror;
  photo.exif = readImageFileHeader(path).camera;
  cv::Mat alpha;
  {
    // Memory: the decoded image is the largest buffer; colour and foreground are taken out of it at the
    // stored resolution (scaled first under a working resolution) and it is released before the
    // distance map is made.
    cv::Mat image = readImageFile(path);
    requirePhotoDepth(path, image);
    // Mirrored before anything is derived, so every map is of the mirrored photo.
    if (options.mirror) cv::flip(image, image, 1);
    photo.width = image.cols;
    photo.height = image.rows;
    alpha = fileAlpha(path, maskPath, image, options.mirror);
    const cv::Size stored = storedSize(image.size(), options.maxSide);
    if (stored != image.size()) {
      cv::resize(image, image, stored, 0, 0, cv::INTER_AREA);
      if (!alpha.empty()) {
        cv::resize(alpha, alpha, stored, 0, 0, cv::INTER_AREA);  // soft edges; specks below a stored pixel vanish
        TM_CHECK(cv::countNonZero(alpha) > 0,
                 located(maskPath.empty() ? path : maskPath,
                         "no foreground pixel is left at the working resolution of " + sizeText(stored)));
      }
    }
    photo.rgb = toRgb(image);
  }
  photo.scale = double(photo.rgb.cols) / photo.width;
  photo.hasBackground = !alpha.empty() && cv::countNonZero(alpha) < alpha.rows * alpha.cols;
  if (photo.hasBackground) {
    photo.alpha = alpha;
    alpha.release();
    // Half floats (relative error below 2^-11, up to 65504 px): half the memory of the float map
    // (537 MB for a 16384^2 photo), exact enough for the background tests of a few pixels.
    distanceToForeground(photo.alpha).convertTo(photo.distance, CV_16F, 1 / photo.scale);  // file pixels
  }
  return photo;
}

PhotoStats photoStats(const std::string& path) {
  PhotoStats stats;
  cv::Mat background;
  {
    cv::Mat alpha;
    {
      cv::Mat image = readImageFile(path);
      requirePhotoDepth(path, image);
      stats.width = image.cols;
      stats.height = image.rows;
      stats.channels = image.channels();
      stats.bitsPerChannel = image.depth() == CV_8U ? 8 : image.depth() == CV_16U ? 16 : 32;
      alpha = fileAlpha(path, "", image);
    }
    const double pixels = double(stats.width) * stats.height;
    stats.foreground = alpha.empty() ? 1.0 : cv::countNonZero(alpha) / pixels;
    if (stats.foreground == 1.0) return stats;
    stats.hasBackground = true;
    stats.borderForeground = borderForegroundShare(alpha);
    cv::threshold(alpha, alpha, 0, 255, cv::THRESH_BINARY);  // in place: foreground 255
    // Photos above 4096 pixels a side: the distance map of a coarse foreground (a coarse pixel is
    // foreground when any of its pixels is), within sqrt(2) * factor pixels of the exact maximum, in a
    // sixteenth of the time (a 16384^2 transform alone takes about 9 s).
    const int factor = (std::max(stats.width, stats.height) + kStatsSide - 1) / kStatsSide;
    if (factor > 1) {
      cv::Mat coarse;
      cv::resize(alpha, coarse, cv::Size((stats.width + factor - 1) / factor, (stats.height + factor - 1) / factor), 0,
                 0, cv::INTER_AREA);
      alpha = coarse;
      stats.maxDistanceError = std::sqrt(2.0) * factor;
    }
    background = alpha == 0;
    stats.distanceScale = factor;
  }
  cv::Mat distance;
  cv::distanceTransform(background, distance, cv::DIST_L2, cv::DIST_MASK_PRECISE, CV_32F);
  background.release();
  cv::minMaxLoc(distance, nullptr, &stats.maxDistance);
  stats.maxDistance *= stats.distanceScale;
  return stats;
}

cv::Size readImageSize(const std::string& path) {
  requireFile(path);
  // The size from the file header; when the header cannot tell it, the file is decoded.
  if (auto size = readImageFileHeader(path).size) {
    TM_CHECK(size->width > 0 && size->height > 0, located(path, "image is empty (0 pixels)"));
    return *size;
  }
  return readImageFile(path).size();
}

cv::Mat readImageRgba8(const std::string& path) {
  return toRgba8(readImageFile(path), true, path);
}

cv::Mat decodeImageRgba8(const unsigned char* bytes, size_t size, const std::string& where) {
  return toRgba8(decodeImage(bytes, size, where), true, where);
}

cv::Mat toRgba8(const cv::Mat& image, bool bgr, const std::string& where) {
  cv::Mat img8;
  switch (image.depth()) {
    case CV_8U:
      img8 = image;
      break;
    case CV_16U:
      image.convertTo(img8, CV_8U, 1.0 / 257.0);
      break;
    case CV_32F:
      image.convertTo(img8, CV_8U, 255.0);
      break;
    default:
      throw Error(located(where, "unsupported image pixel depth (expected 8 or 16 bits per channel)"));
  }
  cv::Mat rgba;
  switch (img8.channels()) {
    case 1:
      cv::cvtColor(img8, rgba, cv::COLOR_GRAY2RGBA);
      break;
    case 2: {
      std::vector<cv::Mat> ch;
      cv::split(img8, ch);
      cv::merge(std::vector<cv::Mat>{ch[0], ch[0], ch[0], ch[1]}, rgba);
      break;
    }
    case 3:
      cv::cvtColor(img8, rgba, bgr ? cv::COLOR_BGR2RGBA : cv::COLOR_RGB2RGBA);
      break;
    case 4:
      if (bgr)
        cv::cvtColor(img8, rgba, cv::COLOR_BGRA2RGBA);
      else
        rgba = img8.clone();
      break;
    default:
      throw Error(located(where, "unsupported image with " + std::to_string(img8.channels()) + " channels"));
  }
  return rgba;
}

bool Photo::isForeground(double x, double y) const {
  if (!inside(x, y)) return false;
  if (alpha.empty()) return true;  // no background
  const double sx = double(alpha.cols) / width, sy = double(alpha.rows) / height;
  const int c = std::clamp(int(std::floor(x * sx)), 0, alpha.cols - 1);
  const int r = std::clamp(int(std::floor(y * sy)), 0, alpha.rows - 1);
  return alpha.depth() == CV_8U ? alpha.at<uint8_t>(r, c) > 0 : alpha.at<float>(r, c) > 0;
}

Vec3f Photo::rgbAt(double x, double y) const {
  return sampleBilinear3(rgb, x * rgb.cols / width, y * rgb.rows / height);
}

float Photo::alphaAt(double x, double y) const {
  if (alpha.empty()) return 1;
  return sampleBilinear1(alpha, x * alpha.cols / width, y * alpha.rows / height);
}

float Photo::distanceAt(double x, double y) const {
  if (distance.empty()) return 0;
  return sampleBilinear1(distance, x * distance.cols / width, y * distance.rows / height);
}

Vec3f Photo::luvAt(double x, double y) const {
  return srgbToLuv(rgbAt(x, y));
}

namespace {
double unitOf(const cv::Mat& rgb) {
  return rgb.depth() == CV_8U ? 1.0 / 255 : rgb.depth() == CV_16U ? 1.0 / 65535 : 1.0;
}

// The pixels a bilinear sample at (x, y) reads, (x0, y0) to (x1, y1), and its weights: pixel centres at
// +0.5, clamped to the border; NaN coordinates sample the first pixel rather than reading out of bounds.
struct Footprint {
  int x0, y0, x1, y1;
  double fx, fy;
};
inline Footprint bilinearFootprint(int cols, int rows, double x, double y) {
  const double u = std::isnan(x) ? 0.0 : std::clamp(x - 0.5, 0.0, double(cols - 1));
  const double v = std::isnan(y) ? 0.0 : std::clamp(y - 0.5, 0.0, double(rows - 1));
  const int x0 = int(u), y0 = int(v);
  return {x0, y0, std::min(x0 + 1, cols - 1), std::min(y0 + 1, rows - 1), u - x0, v - y0};
}

// Bilinear interpolation over footprint `p` of the first min(channels, N) channels; the others are 0.
// Pixels of type T, multiplied by `unit` (1/255 for 8-bit, 1/65535 for 16-bit, 1 for float). Channels > 0:
// the image has that many channels, known at compile time (the loop unrolls).
template <int N, class T, int Channels = 0>
std::array<float, N> interpolate(const cv::Mat& image, const Footprint& p, double unit) {
  const int cn = Channels > 0 ? Channels : image.channels();
  const T* r0 = image.ptr<T>(p.y0);
  const T* r1 = image.ptr<T>(p.y1);
  std::array<float, N> out{};
  for (int c = 0; c < std::min(cn, N); ++c) {
    const double a = r0[p.x0 * cn + c], b = r0[p.x1 * cn + c], d = r1[p.x0 * cn + c], e = r1[p.x1 * cn + c];
    const double top = a + p.fx * (b - a), bottom = d + p.fx * (e - d);
    out[c] = float((top + p.fy * (bottom - top)) * unit);
  }
  return out;
}
}  // namespace

cv::Mat luvImage(const Photo& photo) {
  cv::Mat rgb;
  photo.rgb.convertTo(rgb, CV_32F, unitOf(photo.rgb));
  return srgbToLuv(rgb);
}

LuvTiles::LuvTiles(const Photo& photo) : rgb_(photo.rgb), unit_(unitOf(photo.rgb)) {
  TM_CHECK(!rgb_.empty() && rgb_.channels() == 3, "LuvTiles: the photo has no 3-channel image");
  luv_.create(rgb_.size(), CV_32FC3);  // not cleared: pages are touched only where tiles are made
  tilesX_ = (rgb_.cols + kTile - 1) / kTile;
  tilesY_ = (rgb_.rows + kTile - 1) / kTile;
  done_ = std::make_unique<std::once_flag[]>(size_t(tilesX_) * tilesY_);
  ready_ = std::make_unique<std::atomic<bool>[]>(size_t(tilesX_) * tilesY_);
  for (int i = 0; i < tilesX_ * tilesY_; ++i) ready_[i].store(false, std::memory_order_relaxed);
}

void LuvTiles::require(int x, int y) const {
  const int tx = x / kTile, ty = y / kTile;
  const size_t tile = size_t(ty) * tilesX_ + tx;
  if (ready_[tile].load(std::memory_order_acquire)) return;  // the common case, without a call
  std::call_once(done_[tile], [&] {
    const cv::Rect r(tx * kTile, ty * kTile, std::min(kTile, rgb_.cols - tx * kTile),
                     std::min(kTile, rgb_.rows - ty * kTile));
    cv::Mat rgb;
    rgb_(r).convertTo(rgb, CV_32F, unit_);  // as luvImage does, so the values are the same
    cv::Mat out = luv_(r);
    for (int row = 0; row < r.height; ++row) {
      const auto* in = rgb.ptr<cv::Vec3f>(row);
      auto* o = out.ptr<cv::Vec3f>(row);
      for (int c = 0; c < r.width; ++c) {
        const Vec3f v = srgbToLuv(Vec3f(in[c][0], in[c][1], in[c][2]));
        o[c] = cv::Vec3f(v.x(), v.y(), v.z());
      }
    }
    ++made_;
    ready_[tile].store(true, std::memory_order_release);
  });
}

Vec3f LuvTiles::sample(double x, double y) const {
  const Footprint p = bilinearFootprint(luv_.cols, luv_.rows, x, y);  // what bilinear() reads
  require(p.x0, p.y0);
  if (p.x1 / kTile != p.x0 / kTile) require(p.x1, p.y0);
  if (p.y1 / kTile != p.y0 / kTile) {
    require(p.x0, p.y1);
    if (p.x1 / kTile != p.x0 / kTile) require(p.x1, p.y1);
  }
  // sampleBilinear3's values, without its checks and depth dispatch: the seams read ten samples per
  // seam point at every step of their line searches.
  const std::array<float, 3> v = interpolate<3, float, 3>(luv_, p, 1.0);
  return Vec3f(v[0], v[1], v[2]);
}

void LuvTiles::gradient(double x, double y, Vec3f& ddx, Vec3f& ddy) const {
  ddx = sample(x + 0.5, y) - sample(x - 0.5, y);
  ddy = sample(x, y + 0.5) - sample(x, y - 0.5);
}

size_t Photo::bytes() const {
  return rgb.total() * rgb.elemSize() + alpha.total() * alpha.elemSize() + distance.total() * distance.elemSize();
}

namespace {

template <int N, class T>
std::array<float, N> bilinear(const cv::Mat& image, double x, double y, double unit) {
  return interpolate<N, T>(image, bilinearFootprint(image.cols, image.rows, x, y), unit);
}

template <int N>
std::array<float, N> bilinear(const cv::Mat& image, double x, double y) {
  TM_CHECK(
      !image.empty() && image.channels() <= 4 &&
          (image.depth() == CV_32F || image.depth() == CV_16F || image.depth() == CV_8U || image.depth() == CV_16U),
      "sampleBilinear: expected a non-empty 8-bit, 16-bit, half or float image with at most 4 channels");
  switch (image.depth()) {
    case CV_8U:
      return bilinear<N, uint8_t>(image, x, y, 1.0 / 255);
    case CV_16U:
      return bilinear<N, uint16_t>(image, x, y, 1.0 / 65535);
    case CV_16F:
      return bilinear<N, cv::float16_t>(image, x, y, 1.0);
    default:
      return bilinear<N, float>(image, x, y, 1.0);
  }
}

}  // namespace

Vec3f sampleBilinear3(const cv::Mat& image, double x, double y) {
  const auto s = bilinear<3>(image, x, y);
  return Vec3f(s[0], s[1], s[2]);
}

float sampleBilinear1(const cv::Mat& image, double x, double y) {
  return bilinear<1>(image, x, y)[0];
}

void sampleGradient3(const cv::Mat& image, double x, double y, Vec3f& ddx, Vec3f& ddy) {
  ddx = sampleBilinear3(image, x + 0.5, y) - sampleBilinear3(image, x - 0.5, y);
  ddy = sampleBilinear3(image, x, y + 0.5) - sampleBilinear3(image, x, y - 0.5);
}

}  // namespace montage
