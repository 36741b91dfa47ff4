// Image files: PNG, JPEG, BMP and TIFF read, PNG written, with libpng, libjpeg (libjpeg-turbo, the same
// decoder and settings as OpenCV's, so the same pixels), libtiff and stb_image (BMP only). OpenCV's
// imgcodecs is not used: it loads some 140 shared libraries (GDAL and its dependencies) into every
// process, 0.1 s of CPU before main.
#pragma once

#include <cstdint>
#include <istream>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

namespace montage {

enum class ImageFormat { Unknown, Png, Jpeg, Bmp, TiffLittle, TiffBig };

// What a JPEG's EXIF says of the camera that took it (empty fields when absent): the camera stage fits the photos
// of one camera together and takes the focal length as a prior (mapping/camera.h, issue 37).
struct ExifCamera {
  std::string make, model;       // tags 271, 272
  double focalMm = 0;            // FocalLength (37386), mm
  double focal35mm = 0;          // FocalLengthIn35mmFilm (41989): the lens's on a 36 x 24 mm frame, mm
  double focalPlanePxPerMm = 0;  // FocalPlaneXResolution (41486) in its unit (41488), pixels per mm of the sensor...
  double writtenWidth = 0, writtenHeight = 0;  // ...at the size the camera wrote (PixelX/YDimension; 0: unknown)
  bool empty() const { return make.empty() && model.empty() && focalMm == 0 && focal35mm == 0; }
  // The focal length in pixels of the image as shown, `shown` pixels: from the 35 mm equivalent (its diagonal
  // against the frame's 43.27 mm), else FocalLength on the focal plane's resolution (scaled from the written
  // size, which must then be known and of the same aspect); 0 when the EXIF cannot tell.
  double focalPx(cv::Size shown) const;
  // "Canon EOS 80D, 18 mm (29 mm on 35 mm film)", or "" when empty.
  std::string describe() const;
};

// The format (from the file signature) and, when the header can be read, the size of an image, without
// decoding it. Only PNG, JPEG, BMP and TIFF are recognised.
struct ImageHeader {
  ImageFormat format = ImageFormat::Unknown;
  std::optional<cv::Size> size;  // as the image is shown: the orientation applied (below)
  // A JPEG's EXIF orientation or a TIFF's (1..8, TIFF tag 274: how the stored rows turn to be shown, as photo apps
  // show them; 1 when absent). Decoding applies it: the pixels and `size` are the shown image's, which project
  // coordinates, masks and the editor use.
  int orientation = 1;
  ExifCamera camera;        // a JPEG's EXIF (the first APP1 segment), or a TIFF's (its first and EXIF directories)
  bool iccProfile = false;  // a JPEG with an embedded colour profile (APP2), which decoding converts to sRGB
  uint64_t minBytes = 0;  // the data a complete file holds at least, when its header says (uncompressed BMP)
};
ImageHeader readImageHeader(std::istream& in);
ImageHeader readImageHeader(const unsigned char* bytes, size_t size);
ImageHeader readImageFileHeader(const std::string& path);  // only the header is read

// Images larger than this a side are refused (before decoding when the header gives the size).
constexpr int kMaxImageSide = 16384;
// Throws montage::Error located at `where` when the signature is unknown or the header's size is empty
// or above kMaxImageSide.
void checkImageHeader(const ImageHeader& header, const std::string& where);

// Decodes a PNG, JPEG, BMP or TIFF image held in memory, as stored: depth CV_8U, CV_16U (16-bit PNG and
// TIFF) or CV_32F (float TIFF); 1 channel (grey), 2 (grey, alpha), 3 (B,G,R) or 4 (B,G,R,A), row 0 at the
// top. Throws montage::Error located at `where` (a file name, or "x.glb: image 2") naming the reason:
// unknown signature, empty or above kMaxImageSide, damaged or truncated data, or a layout the decoders
// do not read (e.g. 12-bit JPEG). CMYK JPEGs come as B,G,R; grey BMPs as three equal channels.
cv::Mat decodeImage(const unsigned char* bytes, size_t size, const std::string& where);
// decodeImage of a file, read as it is decoded (never held whole in memory); messages name the path.
cv::Mat readImageFile(const std::string& path);

// The compression of encodePng: zlib level 0..9. Levels 0 and 1 use the SUB row filter and run-length
// matching (fastest; for layers, masks and screenshots), 2 and 3 libpng's adaptive row filters and
// run-length matching, higher levels adaptive filters and full matching (smaller, slower).
constexpr int kPngFast = 1;

// PNG of an 8- or 16-bit image with 1 (grey), 2 (grey, alpha), 3 or 4 channels (B,G,R(,A) when `bgr`,
// else R,G,B(,A)).
// Throws montage::Error located at `where` for other depths or channel counts.
std::vector<unsigned char> encodePng(const cv::Mat& image, const std::string& where, int level = kPngFast,
                                     bool bgr = true);
// encodePng written atomically to `path` (writeFileAtomic).
void writePng(const std::string& path, const cv::Mat& image, int level = kPngFast, bool bgr = true);

}  // namespace montage
