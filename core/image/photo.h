// Source photos: loading (PNG, JPG, TIFF, BMP), foreground mask, distance-to-foreground map, LUV
// colour and bilinear sampling.
//
// Pixel coordinates everywhere in TextureMontage: x to the right, y down, origin at the top-left
// corner of the image, in pixels. Pixel (col c, row r) covers [c, c+1) x [r, r+1); its centre is
// (c + 0.5, r + 0.5). A point is inside the photo when 0 <= x <= width and 0 <= y <= height.
#pragma once

#include <opencv2/core.hpp>
#include <string>

#include "base/common.h"

namespace montage {

struct Photo {
  std::string path;      // absolute or as given
  std::string maskPath;  // empty when the foreground came from alpha (or everything is foreground)
  int width = 0, height = 0;
  cv::Mat rgb;                 // CV_32FC3, sRGB in [0,1], channel order R,G,B
  cv::Mat alpha;               // CV_32FC1 in [0,1]; 0 = background, > 0 = foreground
  cv::Mat distance;            // CV_32FC1, Euclidean distance in pixels from each pixel centre to the
                               // nearest foreground pixel centre (0 on the foreground)
  cv::Mat luv;                 // CV_32FC3, CIE L*u*v* (D65): L in [0,100]
  bool hasBackground = false;  // false when every pixel is foreground (no alpha, no mask)
  bool mirrored = false;       // loaded mirrored left to right (every map above is of the mirrored photo)

  bool inside(double x, double y) const { return x >= 0 && y >= 0 && x <= width && y <= height; }
  // Foreground test at a point, by the pixel containing it.
  bool isForeground(double x, double y) const;
};

// Loads a photo. Foreground comes from `maskPath` when given (non-zero = foreground, any channel
// count, must match the photo's size; alpha = the value relative to the mask's largest value), otherwise
// from the alpha channel, otherwise the whole photo is foreground. `mirror`: the photo (and its mask,
// which is in the file's own pixels) is flipped left to right on load, no copy of the file needed; pixel
// coordinates then refer to the mirrored photo. Throws montage::Error naming the file and the reason
// (missing, unreadable, empty, size mismatch, more than 16384 pixels a side).
Photo loadPhoto(const std::string& path, const std::string& maskPath = "", bool mirror = false);

// Reads only the size of an image (fast; used to validate projects without decoding everything).
// Throws montage::Error when the file is missing or not an image.
cv::Size readImageSize(const std::string& path);

// Reads an image file as CV_8UC4, channel order R,G,B,A, row 0 = top: any 8-bit, 16-bit or float image
// with 1 to 4 channels (grey is replicated, missing alpha is opaque). Throws montage::Error naming the
// file and the reason when it is missing or cannot be read.
cv::Mat readImageRgba8(const std::string& path);

// Converts an 8-bit, 16-bit or float (in [0,1]) image with 1 to 4 channels to CV_8UC4 RGBA. `bgr`: the
// colour channels are in OpenCV's order B,G,R(,A), as cv::imread gives them. Throws montage::Error
// located at `where` for other depths or channel counts.
cv::Mat toRgba8(const cv::Mat& image, bool bgr, const std::string& where);

// Bilinear sample of a float image (any channel count up to 4) at pixel coordinates (x, y), see
// the convention above. Coordinates outside are clamped to the border pixels.
Vec3f sampleBilinear3(const cv::Mat& image, double x, double y);
float sampleBilinear1(const cv::Mat& image, double x, double y);

// Colour gradient of a 3-channel float image at (x, y): d/dx and d/dy of each channel, by central
// differences of bilinear samples one pixel apart. Units: channel units per pixel.
void sampleGradient3(const cv::Mat& image, double x, double y, Vec3f& ddx, Vec3f& ddy);

}  // namespace montage
