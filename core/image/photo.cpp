#include "image/photo.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>

#include "image/color.h"

namespace fs = std::filesystem;

namespace montage {

namespace {

constexpr int kMaxSide = 16384;

void requireFile(const std::string& path) {
  std::error_code ec;
  TM_CHECK(fs::exists(path, ec), located(path, "file not found"));
  TM_CHECK(fs::is_regular_file(path, ec), located(path, "not a regular file"));
}

// ---- Header parsers: the size of PNG, JPEG, BMP and TIFF files without decoding them. ----

class ByteReader {
 public:
  explicit ByteReader(const std::string& path) : in_(path, std::ios::binary) {}
  bool ok() const { return bool(in_); }
  bool read(uint8_t* out, size_t n) { return bool(in_.read(reinterpret_cast<char*>(out), std::streamsize(n))); }
  bool seek(uint64_t pos) { return bool(in_.seekg(std::streamoff(pos))); }
  bool skip(uint64_t n) { return bool(in_.seekg(std::streamoff(n), std::ios::cur)); }
  std::optional<uint32_t> u8() {
    uint8_t b;
    return read(&b, 1) ? std::optional<uint32_t>(b) : std::nullopt;
  }
  std::optional<uint32_t> u16(bool bigEndian) {
    uint8_t b[2];
    if (!read(b, 2)) return std::nullopt;
    return bigEndian ? uint32_t(b[0]) << 8 | b[1] : uint32_t(b[1]) << 8 | b[0];
  }
  std::optional<uint32_t> u32(bool bigEndian) {
    uint8_t b[4];
    if (!read(b, 4)) return std::nullopt;
    return bigEndian ? uint32_t(b[0]) << 24 | uint32_t(b[1]) << 16 | uint32_t(b[2]) << 8 | b[3]
                     : uint32_t(b[3]) << 24 | uint32_t(b[2]) << 16 | uint32_t(b[1]) << 8 | b[0];
  }

 private:
  std::ifstream in_;
};

// PNG: signature, then the IHDR chunk with width and height (big endian).
std::optional<cv::Size> pngSize(ByteReader& in) {
  uint8_t tag[4];
  in.seek(12);
  if (!in.read(tag, 4) || std::string(reinterpret_cast<char*>(tag), 4) != "IHDR") return std::nullopt;
  auto w = in.u32(true), h = in.u32(true);
  if (!w || !h) return std::nullopt;
  return cv::Size(int(std::min<uint32_t>(*w, INT32_MAX)), int(std::min<uint32_t>(*h, INT32_MAX)));
}

// JPEG: walk the marker segments to the first start-of-frame (SOFn) segment.
std::optional<cv::Size> jpegSize(ByteReader& in) {
  in.seek(2);
  for (;;) {
    auto marker = in.u8();
    while (marker && *marker == 0xFF) marker = in.u8();  // fill bytes
    if (!marker) return std::nullopt;
    if (*marker == 0xD8 || *marker == 0x01 || (*marker >= 0xD0 && *marker <= 0xD7)) continue;  // no payload
    if (*marker == 0xD9 || *marker == 0xDA) return std::nullopt;  // end of image / scan before any frame
    auto length = in.u16(true);
    if (!length || *length < 2) return std::nullopt;
    const bool sof = *marker >= 0xC0 && *marker <= 0xCF && *marker != 0xC4 && *marker != 0xC8 && *marker != 0xCC;
    if (sof) {
      auto precision = in.u8(), h = in.u16(true), w = in.u16(true);
      if (!precision || !h || !w) return std::nullopt;
      return cv::Size(int(*w), int(*h));
    }
    if (!in.skip(*length - 2)) return std::nullopt;
    auto next = in.u8();  // every segment is followed by a marker
    if (!next || *next != 0xFF) return std::nullopt;
  }
}

// BMP: BITMAPCOREHEADER (16-bit sizes) or BITMAPINFOHEADER and later (signed 32-bit, negative height
// for top-down rows).
std::optional<cv::Size> bmpSize(ByteReader& in) {
  in.seek(14);
  auto headerSize = in.u32(false);
  if (!headerSize) return std::nullopt;
  if (*headerSize == 12) {
    auto w = in.u16(false), h = in.u16(false);
    if (!w || !h) return std::nullopt;
    return cv::Size(int(*w), int(*h));
  }
  auto w = in.u32(false), h = in.u32(false);
  if (!w || !h) return std::nullopt;
  const auto absolute = [](uint32_t v) { return int(std::min<int64_t>(std::abs(int64_t(int32_t(v))), INT32_MAX)); };
  return cv::Size(absolute(*w), absolute(*h));
}

// TIFF (classic, not BigTIFF): tags ImageWidth (256) and ImageLength (257) of the first IFD.
std::optional<cv::Size> tiffSize(ByteReader& in, bool bigEndian) {
  in.seek(4);
  auto ifd = in.u32(bigEndian);
  if (!ifd || !in.seek(*ifd)) return std::nullopt;
  auto count = in.u16(bigEndian);
  if (!count) return std::nullopt;
  int width = -1, height = -1;
  for (uint32_t i = 0; i < *count; ++i) {
    auto tag = in.u16(bigEndian), type = in.u16(bigEndian), n = in.u32(bigEndian);
    if (!tag || !type || !n) return std::nullopt;
    std::optional<uint32_t> value;
    if (*type == 3) {  // SHORT, left-justified in the 4-byte value field
      value = in.u16(bigEndian);
      in.skip(2);
    } else {
      value = in.u32(bigEndian);  // LONG (or something we do not read)
    }
    if (!value) return std::nullopt;
    if (*tag == 256 && (*type == 3 || *type == 4)) width = int(std::min<uint32_t>(*value, INT32_MAX));
    if (*tag == 257 && (*type == 3 || *type == 4)) height = int(std::min<uint32_t>(*value, INT32_MAX));
  }
  if (width < 0 || height < 0) return std::nullopt;
  return cv::Size(width, height);
}

// The size from the file header, or nothing when the format is not one of the above (or the header
// is damaged); the caller then decodes the file.
std::optional<cv::Size> headerSize(const std::string& path) {
  ByteReader in(path);
  uint8_t magic[8] = {};
  if (!in.ok() || !in.read(magic, 8)) return std::nullopt;
  static const uint8_t kPng[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  if (std::equal(magic, magic + 8, kPng)) return pngSize(in);
  if (magic[0] == 0xFF && magic[1] == 0xD8 && magic[2] == 0xFF) return jpegSize(in);
  if (magic[0] == 'B' && magic[1] == 'M') return bmpSize(in);
  if (magic[0] == 'I' && magic[1] == 'I' && magic[2] == 42 && magic[3] == 0) return tiffSize(in, false);
  if (magic[0] == 'M' && magic[1] == 'M' && magic[2] == 0 && magic[3] == 42) return tiffSize(in, true);
  return std::nullopt;
}

void checkSize(const std::string& path, cv::Size size) {
  TM_CHECK(size.width > 0 && size.height > 0, located(path, "image is empty (0 pixels)"));
  TM_CHECK(size.width <= kMaxSide && size.height <= kMaxSide,
           located(path, "image is " + std::to_string(size.width) + "x" + std::to_string(size.height) +
                             " pixels; at most " + std::to_string(kMaxSide) + " pixels a side are supported"));
}

// cv::imread with IMREAD_UNCHANGED of an existing file; failures become montage::Error.
cv::Mat readUnchanged(const std::string& path) {
  cv::Mat image;
  try {
    image = cv::imread(path, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    throw Error(located(path, "cannot decode image: " + e.msg));
  }
  TM_CHECK(!image.empty(), located(path, "not a readable image (unsupported format or damaged file)"));
  return image;
}

cv::Mat decode(const std::string& path) {
  requireFile(path);
  // Refuse oversized images before allocating them, when the header tells the size.
  if (auto size = headerSize(path)) checkSize(path, *size);
  cv::Mat image = readUnchanged(path);
  checkSize(path, image.size());
  return image;
}

// Converts any supported depth to float in [0,1].
cv::Mat toUnitFloat(const std::string& path, const cv::Mat& image) {
  double scale = 1;
  switch (image.depth()) {
    case CV_8U:
      scale = 1.0 / 255;
      break;
    case CV_16U:
      scale = 1.0 / 65535;
      break;
    case CV_32F:
      break;
    default:
      throw Error(located(path, "unsupported pixel format (only 8-bit, 16-bit and float images are read)"));
  }
  cv::Mat out;
  image.convertTo(out, CV_MAKETYPE(CV_32F, image.channels()), scale);
  return out;
}

// Foreground from a mask image: a pixel is foreground when one of its colour channels is non-zero and
// (for masks with alpha) it is not transparent. Its alpha is its largest colour channel relative to the
// largest value in the mask, so a 0/1 label image and a 0/255 mask both give alpha 1, and a feathered
// edge (cutout.h) gives partial alpha; the foreground (alpha > 0) is the same either way.
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
  colour.convertTo(alpha, CV_32F, largest > 0 ? 1.0 / largest : 0.0);
  if (colours < mask.channels()) alpha.setTo(0, channels.back() == 0);
  return alpha;
}

std::string sizeText(cv::Size s) {
  return std::to_string(s.width) + "x" + std::to_string(s.height);
}

}  // namespace

Photo loadPhoto(const std::string& path, const std::string& maskPath, bool mirror) {
  cv::Mat image = toUnitFloat(path, decode(path));
  if (mirror) cv::flip(image, image, 1);  // before anything is derived, so all maps are of the mirrored photo
  Photo photo;
  photo.path = path;
  photo.maskPath = maskPath;
  photo.mirrored = mirror;
  photo.width = image.cols;
  photo.height = image.rows;

  std::vector<cv::Mat> channels;
  cv::split(image, channels);
  switch (image.channels()) {
    case 1:
    case 2:
      cv::merge(std::vector<cv::Mat>{channels[0], channels[0], channels[0]}, photo.rgb);
      break;
    case 3:
    case 4:  // OpenCV's order is B, G, R(, A)
      cv::merge(std::vector<cv::Mat>{channels[2], channels[1], channels[0]}, photo.rgb);
      break;
    default:
      throw Error(
          located(path, std::to_string(image.channels()) + " channels; expected 1 (grey), 3 (RGB) or 4 (RGBA)"));
  }

  if (!maskPath.empty()) {
    cv::Mat mask = decode(maskPath);
    if (mirror) cv::flip(mask, mask, 1);  // a mask is in its photo file's pixels
    TM_CHECK(mask.size() == image.size(),
             located(maskPath, "mask is " + sizeText(mask.size()) + " but photo " + path + " is " +
                                   sizeText(image.size()) + "; they must have the same size"));
    photo.alpha = maskToAlpha(mask);
  } else if (image.channels() == 2 || image.channels() == 4) {
    photo.alpha = channels.back();
    cv::max(photo.alpha, 0.0, photo.alpha);
    cv::min(photo.alpha, 1.0, photo.alpha);
  } else {
    photo.alpha = cv::Mat(image.size(), CV_32F, cv::Scalar(1));
  }

  const cv::Mat background = photo.alpha <= 0;  // 255 on background pixels
  const int backgroundCount = cv::countNonZero(background);
  TM_CHECK(
      backgroundCount < image.rows * image.cols,
      located(maskPath.empty() ? path : maskPath,
              "no foreground pixel (" + std::string(maskPath.empty() ? "alpha" : "mask") + " is zero everywhere)"));
  photo.hasBackground = backgroundCount > 0;
  if (photo.hasBackground)
    cv::distanceTransform(background, photo.distance, cv::DIST_L2, cv::DIST_MASK_PRECISE, CV_32F);
  else
    photo.distance = cv::Mat::zeros(image.size(), CV_32F);

  photo.luv = srgbToLuv(photo.rgb);
  return photo;
}

cv::Size readImageSize(const std::string& path) {
  requireFile(path);
  if (auto size = headerSize(path)) {
    TM_CHECK(size->width > 0 && size->height > 0, located(path, "image is empty (0 pixels)"));
    return *size;
  }
  return decode(path).size();
}

cv::Mat readImageRgba8(const std::string& path) {
  requireFile(path);
  return toRgba8(readUnchanged(path), true, path);
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
  if (!inside(x, y) || alpha.empty()) return false;
  const int c = std::min(int(std::floor(x)), width - 1), r = std::min(int(std::floor(y)), height - 1);
  return alpha.at<float>(r, c) > 0;
}

namespace {

// Bilinear interpolation of the first min(channels, N) channels; the others are 0.
template <int N>
std::array<float, N> bilinear(const cv::Mat& image, double x, double y) {
  TM_CHECK(!image.empty() && image.depth() == CV_32F && image.channels() <= 4,
           "sampleBilinear: expected a non-empty float image with at most 4 channels");
  const int cn = image.channels();
  // Pixel centres at +0.5; NaN coordinates sample the first pixel rather than reading out of bounds.
  const double u = std::isnan(x) ? 0.0 : std::clamp(x - 0.5, 0.0, double(image.cols - 1));
  const double v = std::isnan(y) ? 0.0 : std::clamp(y - 0.5, 0.0, double(image.rows - 1));
  const int x0 = int(u), y0 = int(v);
  const int x1 = std::min(x0 + 1, image.cols - 1), y1 = std::min(y0 + 1, image.rows - 1);
  const double fx = u - x0, fy = v - y0;
  const float* r0 = image.ptr<float>(y0);
  const float* r1 = image.ptr<float>(y1);
  std::array<float, N> out{};
  for (int c = 0; c < std::min(cn, N); ++c) {
    const double top = r0[x0 * cn + c] + fx * (r0[x1 * cn + c] - r0[x0 * cn + c]);
    const double bottom = r1[x0 * cn + c] + fx * (r1[x1 * cn + c] - r1[x0 * cn + c]);
    out[c] = float(top + fy * (bottom - top));
  }
  return out;
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
