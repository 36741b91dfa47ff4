// Source photos: loading (PNG, JPG, TIFF, BMP), foreground mask, distance-to-foreground map, LUV
// colour and bilinear sampling.
//
// Pixel coordinates everywhere in TextureMontage: x to the right, y down, origin at the top-left
// corner of the image, in pixels. Pixel (col c, row r) covers [c, c+1) x [r, r+1); its centre is
// (c + 0.5, r + 0.5). A point is inside the photo when 0 <= x <= width and 0 <= y <= height.
#pragma once

#include <atomic>
#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <string>

#include "base/common.h"
#include "image/codec.h"

namespace montage {

// How photos are kept in memory.
struct PhotoLoadOptions {
  // Working resolution: a photo whose longer side has more pixels than this is stored downscaled to it
  // (area averaging); coordinates stay the file's pixels (Photo::scale). 0 = the file's resolution.
  int maxSide = 0;
  // The photo (and its mask, which is in the file's own pixels) is flipped left to right on load, no copy
  // of the file needed; pixel coordinates then refer to the mirrored photo (Photo::mirrored).
  bool mirror = false;
};

// A photo as the pipeline keeps it: compact maps at the stored resolution (the file's, or a working
// resolution), read through the sampling methods, which take the file's pixel coordinates. A 16384^2
// 8-bit photo with a background takes 805 MB (rgb) + 268 MB (alpha) + 537 MB (distance); there is no
// L*u*v* map (luvAt converts per sample).
struct Photo {
  std::string path;            // absolute or as given
  std::string maskPath;        // empty when the foreground came from alpha (or everything is foreground)
  int width = 0, height = 0;   // of the file: the pixel coordinates of the project
  double scale = 1;            // stored pixels per file pixel: 1, or below 1 under a working resolution
  cv::Mat rgb;                 // sRGB, channels R,G,B, stored resolution, the file's depth: CV_8UC3 (8-bit),
                               // CV_16UC3 (16-bit) or CV_32FC3 (float, [0,1]); read with rgbAt(), or
                               // sampleBilinear3 which maps every depth to [0,1]
  cv::Mat alpha;               // CV_8UC1, stored resolution, 0 = background, 255 = foreground, soft edges between
                               // (CV_32FC1 in [0,1] is accepted in photos made in code); empty when there is
                               // no background
  cv::Mat distance;            // CV_16FC1 (half float, relative error < 2^-11; CV_32FC1 is accepted in photos made
                               // in code), stored resolution: distance in file pixels from each pixel centre to
                               // the nearest foreground pixel centre (0 on the foreground); empty when there is
                               // no background
  bool hasBackground = false;  // false when every pixel is foreground (no alpha, no mask)
  bool mirrored = false;       // loaded mirrored left to right (every map above is of the mirrored photo)
  ExifCamera exif;             // what the file's EXIF says of its camera (a JPEG's; empty otherwise)

  bool inside(double x, double y) const { return x >= 0 && y >= 0 && x <= width && y <= height; }
  // Foreground test at a point, by the stored pixel containing it (true everywhere inside without background).
  bool isForeground(double x, double y) const;
  // Bilinear samples at file pixel coordinates (clamped at the border): sRGB in [0,1]; alpha in [0,1]
  // (1 without background); distance to the foreground in file pixels (0 without background); CIE
  // L*u*v* (D65, L in [0,100]) of the sRGB sample.
  Vec3f rgbAt(double x, double y) const;
  float alphaAt(double x, double y) const;
  float distanceAt(double x, double y) const;
  Vec3f luvAt(double x, double y) const;
  // Bytes held by the maps.
  size_t bytes() const;
};

// The photo's CIE L*u*v* image at its stored resolution (CV_32FC3), for stages that sample colour
// differences densely (seam optimisation). Its pixel (x, y) is the photo's file pixel
// (x, y) * rgb.cols / width.
cv::Mat luvImage(const Photo& photo);

// luvImage(photo) made tile by tile on first read, for readers that sample a small part of a photo (the
// seams' samples lie along the seams): the same values, at the cost of the tiles read. Thread-safe.
class LuvTiles {
 public:
  explicit LuvTiles(const Photo& photo);
  // sampleBilinear3 and sampleGradient3 of luvImage(photo), at stored-pixel coordinates.
  Vec3f sample(double x, double y) const;
  void gradient(double x, double y, Vec3f& ddx, Vec3f& ddy) const;
  int cols() const { return luv_.cols; }
  int tilesMade() const { return made_; }  // tiles converted so far
  int tiles() const { return tilesX_ * tilesY_; }

 private:
  static constexpr int kTile = 32;  // pixels a side
  void require(int x, int y) const;  // the tile holding stored pixel (x, y) is converted

  cv::Mat rgb_;  // the photo's pixels (shared)
  double unit_ = 1;
  cv::Mat luv_;  // CV_32FC3; only converted tiles hold values
  int tilesX_ = 0, tilesY_ = 0;
  std::unique_ptr<std::once_flag[]> done_;
  std::unique_ptr<std::atomic<bool>[]> ready_;  // set once a tile's conversion is visible
  mutable std::atomic<int> made_{0};
};

// Loads a photo. Foreground comes from `maskPath` when given (non-zero = foreground, any channel
// count, must match the photo's size; alpha = the value relative to the mask's largest value), otherwise
// from the alpha channel, otherwise the whole photo is foreground. Throws montage::Error naming the file and the reason
// (missing, unreadable, empty, size mismatch, more than 16384 pixels a side, not PNG/JPEG/TIFF/BMP).
Photo loadPhoto(const std::string& path, const std::string& maskPath = "");
Photo loadPhoto(const std::string& path, const std::string& maskPath, const PhotoLoadOptions& options);

// What `montage info` reports about a photo, found with bounded memory and time: the decoded file plus
// one byte per pixel (1.34 GB for a 16384^2 RGBA photo); above 4096 pixels a side the distance is
// measured on a coarse mask (maxDistanceError says how far off it may be).
struct PhotoStats {
  int width = 0, height = 0, channels = 0, bitsPerChannel = 0;
  double foreground = 1;        // fraction of foreground pixels
  double borderForeground = 1;  // fraction of the border pixels (outermost rows and columns) that are foreground
  bool hasBackground = false;
  double maxDistance = 0;       // largest distance of a pixel to the foreground, pixels
  double maxDistanceError = 0;  // bound on |maxDistance - exact|, pixels (0 = exact)
  int distanceScale = 1;        // pixels per pixel of the mask the distance was measured on
};
PhotoStats photoStats(const std::string& path);

// Reads only the size of an image (fast; used to validate projects without decoding everything).
// Throws montage::Error when the file is missing or not an image.
cv::Size readImageSize(const std::string& path);

// Reads an image file as CV_8UC4, channel order R,G,B,A, row 0 = top: any 8-bit, 16-bit or float image
// with 1 to 4 channels (grey is replicated, missing alpha is opaque). Throws montage::Error naming the
// file and the reason when it is missing or cannot be read.
cv::Mat readImageRgba8(const std::string& path);

// Decodes an image held in memory (e.g. embedded in a glTF file) as CV_8UC4 RGBA, with the same rules as
// readImageRgba8 (PNG, JPEG, TIFF or BMP only; at most 16384 pixels a side, checked before decoding).
// `where` names it in messages.
cv::Mat decodeImageRgba8(const unsigned char* bytes, size_t size, const std::string& where);

// Converts an 8-bit, 16-bit or float (in [0,1]) image with 1 to 4 channels to CV_8UC4 RGBA. `bgr`: the
// colour channels are in OpenCV's order B,G,R(,A), as decodeImage (image/codec.h) gives them. Throws montage::Error
// located at `where` for other depths or channel counts.
cv::Mat toRgba8(const cv::Mat& image, bool bgr, const std::string& where);

// Bilinear sample of an image (8-bit, 16-bit, half or float, any channel count up to 4; integer depths are
// mapped to [0,1]) at pixel coordinates (x, y), see the convention above. Coordinates outside are
// clamped to the border pixels.
Vec3f sampleBilinear3(const cv::Mat& image, double x, double y);
float sampleBilinear1(const cv::Mat& image, double x, double y);

// Colour gradient of a 3-channel float image at (x, y): d/dx and d/dy of each channel, by central
// differences of bilinear samples one pixel apart. Units: channel units per pixel.
void sampleGradient3(const cv::Mat& image, double x, double y, Vec3f& ddx, Vec3f& ddy);

}  // namespace montage
