// libFuzzer target: the photo loader (header parsing, decoding through OpenCV, foreground, distance map)
// and the in-memory decoder the glTF reader uses. Only montage::Error may come out.
#include <cstdint>
#include <string>

#include "fuzz_support.h"
#include "image/photo.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string dir = montage::fuzz::scratch("photo");
  const std::string path = dir + "/photo.png";
  montage::fuzz::writeFile(path, std::string(reinterpret_cast<const char*>(data), size));
  try {
    const cv::Size s = montage::readImageSize(path);
    if (s.width <= 0 || s.height <= 0) __builtin_trap();
  } catch (const montage::Error&) {
  }
  try {
    const montage::Photo photo = montage::loadPhoto(path);
    if (photo.width <= 0 || photo.height <= 0 || photo.width > 16384 || photo.height > 16384) __builtin_trap();
    const float d = photo.distanceAt(photo.width * 0.5, photo.height * 0.5);
    if (!(d >= 0)) __builtin_trap();
    (void)photo.rgbAt(0.5, 0.5);
  } catch (const montage::Error&) {
  }
  try {
    const cv::Mat rgba = montage::decodeImageRgba8(data, size, "fuzz");
    if (rgba.type() != CV_8UC4) __builtin_trap();
  } catch (const montage::Error&) {
  }
  return 0;
}
