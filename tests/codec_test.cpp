// Tests of core/image/codec: our decoders (libpng, libjpeg, libtiff, stb_image for BMP) and PNG encoder
// (libpng) checked against OpenCV's imgcodecs, another implementation, on every layout photos come in,
// and the layouts OpenCV does not write (written here with libtiff and libjpeg); and the errors.
#include "image/codec.h"

// jpeglib.h needs FILE from <cstdio> first.
// clang-format off
#include <Eigen/Core>
#include <cstdio>
#include <jpeglib.h>
#include <lcms2.h>
// clang-format on
#include <tiffio.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>

#include "base/fileio.h"
#include "test_support.h"

using namespace montage;
using montage::test::errorOf;

namespace {

// A smooth image with noise (photos are neither flat nor pure noise), `channels` channels at `depth`.
cv::Mat testImage(int rows, int cols, int depth, int channels, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> noise(-0.05, 0.05);
  cv::Mat f(rows, cols, CV_32FC(channels));
  for (int y = 0; y < rows; ++y)
    for (int x = 0; x < cols; ++x)
      for (int c = 0; c < channels; ++c)
        f.ptr<float>(y)[x * channels + c] =
            float(std::clamp(0.5 + 0.4 * std::sin(0.07 * x * (c + 1) + 0.05 * y) + noise(rng), 0.0, 1.0));
  cv::Mat out;
  f.convertTo(out, CV_MAKETYPE(depth, channels), depth == CV_8U ? 255.0 : depth == CV_16U ? 65535.0 : 1.0);
  return out;
}

cv::Mat ours(const std::vector<unsigned char>& bytes, const std::string& where = "test image") {
  return decodeImage(bytes.data(), bytes.size(), where);
}

std::vector<unsigned char> cvEncode(const std::string& ext, const cv::Mat& image, const std::vector<int>& params = {}) {
  std::vector<unsigned char> bytes;
  if (!cv::imencode(ext, image, bytes, params)) throw std::runtime_error("cv::imencode failed for " + ext);
  return bytes;
}

double maxDifference(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return 1e30;
  return cv::norm(a, b, cv::NORM_INF);
}

// A TIFF written with libtiff directly: the layouts OpenCV does not write (tiles, palette).
std::vector<unsigned char> libtiffFile(const std::string& path, const cv::Mat& rgb8, bool tiled, bool palette,
                                       int orientation = 0) {
  TIFF* t = TIFFOpen(path.c_str(), "w");
  if (!t) throw std::runtime_error("cannot write " + path);
  const uint32_t w = uint32_t(rgb8.cols), h = uint32_t(rgb8.rows);
  TIFFSetField(t, TIFFTAG_IMAGEWIDTH, w);
  TIFFSetField(t, TIFFTAG_IMAGELENGTH, h);
  TIFFSetField(t, TIFFTAG_BITSPERSAMPLE, 8);
  TIFFSetField(t, TIFFTAG_SAMPLESPERPIXEL, palette ? 1 : 3);
  TIFFSetField(t, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG);
  TIFFSetField(t, TIFFTAG_COMPRESSION, COMPRESSION_LZW);
  TIFFSetField(t, TIFFTAG_PHOTOMETRIC, palette ? PHOTOMETRIC_PALETTE : PHOTOMETRIC_RGB);
  if (orientation) TIFFSetField(t, TIFFTAG_ORIENTATION, orientation);
  cv::Mat samples = rgb8;
  if (palette) {  // 256 entries: index i is grey i; the samples are the red channel
    std::vector<uint16_t> map(256);
    for (int i = 0; i < 256; ++i) map[i] = uint16_t(i * 257);
    TIFFSetField(t, TIFFTAG_COLORMAP, map.data(), map.data(), map.data());
    cv::extractChannel(rgb8, samples, 0);
  }
  if (tiled) {
    TIFFSetField(t, TIFFTAG_TILEWIDTH, 16);
    TIFFSetField(t, TIFFTAG_TILELENGTH, 16);
    cv::Mat tile(16, 16, samples.type());
    for (uint32_t y = 0; y < h; y += 16)
      for (uint32_t x = 0; x < w; x += 16) {
        tile.setTo(0);
        const cv::Rect r(int(x), int(y), int(std::min<uint32_t>(16, w - x)), int(std::min<uint32_t>(16, h - y)));
        samples(r).copyTo(tile(cv::Rect(0, 0, r.width, r.height)));
        TIFFWriteTile(t, tile.data, x, y, 0, 0);
      }
  } else {
    TIFFSetField(t, TIFFTAG_ROWSPERSTRIP, 8);
    for (uint32_t y = 0; y < h; ++y) TIFFWriteScanline(t, samples.ptr(int(y)), y, 0);
  }
  TIFFClose(t);
  const std::string bytes = readFileBytes(path, "test TIFF");
  return std::vector<unsigned char>(bytes.begin(), bytes.end());
}

}  // namespace

// Our PNGs decode to the pixels encoded, with OpenCV's decoder (libpng) and with ours, for every depth,
// channel count, order and level.
TEST(Codec, PngRoundTripsEveryLayoutThroughBothDecoders) {
  for (int depth : {CV_8U, CV_16U})
    for (int channels : {1, 2, 3, 4})
      for (int level : {0, kPngFast, 6, 9}) {
        const cv::Mat image = testImage(37, 53, depth, channels, unsigned(depth * 10 + channels));
        const std::string what = "depth " + std::to_string(depth) + ", " + std::to_string(channels) +
                                 " channels, level " + std::to_string(level);
        const std::vector<unsigned char> bytes = encodePng(image, "x.png", level);
        if (channels != 2)  // OpenCV reads grey + alpha as B,G,R,A (see below)
          EXPECT_EQ(maxDifference(cv::imdecode(bytes, cv::IMREAD_UNCHANGED), image), 0) << what;
        EXPECT_EQ(maxDifference(ours(bytes), image), 0) << what;
        if (channels >= 3) {  // R,G,B order: the file holds the channels swapped
          cv::Mat swapped;
          cv::cvtColor(image, swapped, channels == 3 ? cv::COLOR_BGR2RGB : cv::COLOR_BGRA2RGBA);
          EXPECT_EQ(maxDifference(ours(encodePng(image, "x.png", level, false)), swapped), 0) << what;
        }
      }
  // Higher levels compress more (a smooth image).
  const cv::Mat image = testImage(256, 256, CV_8U, 3, 7);
  EXPECT_LT(encodePng(image, "x.png", 6).size(), encodePng(image, "x.png", 0).size());
}

// PNG, BMP and TIFF are lossless: our decoders give OpenCV's pixels exactly, for the layouts OpenCV
// writes (PNG grey, grey + alpha, 16-bit; TIFF 8-bit, 16-bit, float, alpha, LogLuv; BMP grey and colour).
// Grey BMPs (a grey palette) come as B,G,R with the grey thrice.
TEST(Codec, LosslessFormatsDecodeAsOpenCvDecodesThem) {
  struct Case {
    std::string ext;
    int depth, channels;
  };
  const std::vector<Case> cases = {
      {".png", CV_8U, 1},   {".png", CV_8U, 3},   {".png", CV_8U, 4},   {".png", CV_16U, 3},  {".png", CV_16U, 4},
      {".bmp", CV_8U, 1},   {".bmp", CV_8U, 3},   {".tiff", CV_8U, 1},  {".tiff", CV_8U, 3},  {".tiff", CV_8U, 4},
      {".tiff", CV_16U, 1}, {".tiff", CV_16U, 3}, {".tiff", CV_16U, 4}, {".tiff", CV_32F, 1}, {".tiff", CV_32F, 3}};
  for (const Case& c : cases) {
    const std::string what = c.ext + " depth " + std::to_string(c.depth) + ", " + std::to_string(c.channels) + " ch";
    const cv::Mat image = testImage(41, 67, c.depth, c.channels, unsigned(c.channels + 3 * c.depth));
    const std::vector<unsigned char> bytes = cvEncode(c.ext, image);
    const cv::Mat reference = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(reference.empty()) << what;
    cv::Mat decoded = ours(bytes);
    if (c.ext == ".bmp" && c.channels == 1) {
      ASSERT_EQ(decoded.channels(), 3) << what;
      cv::Mat grey;
      cv::extractChannel(decoded, grey, 0);
      cv::Mat bgr;
      cv::cvtColor(grey, bgr, cv::COLOR_GRAY2BGR);
      EXPECT_EQ(maxDifference(decoded, bgr), 0) << what;
      decoded = grey;
    }
    EXPECT_EQ(decoded.type(), reference.type()) << what;
    EXPECT_EQ(maxDifference(decoded, reference), 0) << what;
  }
  // Grey + alpha PNG: ours keeps two channels; OpenCV reads it as B,G,R,A with the grey thrice.
  const cv::Mat ga = testImage(20, 30, CV_8U, 2, 5);
  const std::vector<unsigned char> bytes = encodePng(ga, "ga.png");
  EXPECT_EQ(maxDifference(ours(bytes), ga), 0);
  std::vector<cv::Mat> ch;
  cv::split(ga, ch);
  cv::Mat bgra;
  cv::merge(std::vector<cv::Mat>{ch[0], ch[0], ch[0], ch[1]}, bgra);
  EXPECT_EQ(maxDifference(cv::imdecode(bytes, cv::IMREAD_UNCHANGED), bgra), 0);
}

// JPEG: the same library (libjpeg-turbo) and settings as OpenCV's decoder, so the same pixels, baseline
// and progressive, grey and colour.
TEST(Codec, JpegDecodesAsOpenCvDecodesIt) {
  for (int channels : {1, 3})
    for (bool progressive : {false, true}) {
      const cv::Mat image = testImage(120, 160, CV_8U, channels, 11u + unsigned(channels));
      const std::vector<unsigned char> bytes =
          cvEncode(".jpg", image, {cv::IMWRITE_JPEG_QUALITY, 90, cv::IMWRITE_JPEG_PROGRESSIVE, progressive ? 1 : 0});
      EXPECT_EQ(maxDifference(ours(bytes), cv::imdecode(bytes, cv::IMREAD_UNCHANGED)), 0)
          << channels << " channels, progressive " << progressive;
    }
}

namespace {

// `image` encoded by libjpeg itself (OpenCV writes neither CMYK nor an ICC profile): its samples in colour space
// `space`, with `icc` as the embedded profile when given.
std::vector<unsigned char> libjpegEncode(const cv::Mat& image, J_COLOR_SPACE space, int quality,
                                         const std::vector<unsigned char>& icc = {}) {
  jpeg_compress_struct info;
  jpeg_error_mgr error;
  info.err = jpeg_std_error(&error);
  jpeg_create_compress(&info);
  unsigned char* buffer = nullptr;
  unsigned long size = 0;
  jpeg_mem_dest(&info, &buffer, &size);
  info.image_width = image.cols, info.image_height = image.rows, info.input_components = image.channels();
  info.in_color_space = space;
  jpeg_set_defaults(&info);
  jpeg_set_quality(&info, quality, TRUE);
  jpeg_start_compress(&info, TRUE);
  if (!icc.empty()) jpeg_write_icc_profile(&info, icc.data(), unsigned(icc.size()));
  for (int y = 0; y < image.rows; ++y) {
    JSAMPROW row = const_cast<uchar*>(image.ptr(y));
    jpeg_write_scanlines(&info, &row, 1);
  }
  jpeg_finish_compress(&info);
  jpeg_destroy_compress(&info);
  std::vector<unsigned char> bytes(buffer, buffer + size);
  std::free(buffer);
  return bytes;
}

}  // namespace

// A JPEG with an EXIF orientation (a portrait shot stored sideways) comes as photo apps show it, as OpenCV's own
// decoder (which applies the orientation) shows it; the header gives the shown size without decoding.
TEST(Codec, JpegExifOrientationIsApplied) {
  const cv::Mat image = testImage(48, 80, CV_8U, 3, 5u);  // 80 wide, 48 high as stored
  const std::vector<unsigned char> plain = cvEncode(".jpg", image, {cv::IMWRITE_JPEG_QUALITY, 95});
  for (bool bigEndian : {false, true})
    for (int orientation = 1; orientation <= 8; ++orientation) {
      SCOPED_TRACE("orientation " + std::to_string(orientation) + (bigEndian ? " MM" : " II"));
      const std::vector<unsigned char> bytes = test::withApp1(
          plain, test::exifPayload(bigEndian, {{274, 3, 1, test::exif16(bigEndian, uint32_t(orientation))}}, {}));
      const cv::Mat shown = ours(bytes, "portrait.jpg");
      EXPECT_EQ(maxDifference(shown, cv::imdecode(bytes, cv::IMREAD_COLOR)), 0);
      EXPECT_EQ(shown.size(), orientation >= 5 ? cv::Size(48, 80) : cv::Size(80, 48));
      const ImageHeader header = readImageHeader(bytes.data(), bytes.size());
      EXPECT_EQ(header.orientation, orientation);
      ASSERT_TRUE(header.size);
      EXPECT_EQ(*header.size, shown.size());
    }
}

// A TIFF's orientation (tag 274: a camera's or raw converter's portrait stored sideways) is applied as a JPEG's is,
// whichever way libtiff decodes it (contiguous RGB read row by row; a palette through libtiff's RGBA reader, which
// applies only the flips itself); the header gives the shown size.
TEST(Codec, TiffOrientationIsApplied) {
  const std::string dir = test::tempDir("codec_tiff_orientation");
  const cv::Mat stored = testImage(24, 40, CV_8U, 3, 7u);  // 40 wide, 24 high as stored (R,G,B)
  for (bool palette : {false, true})
    for (int orientation = 1; orientation <= 8; ++orientation) {
      SCOPED_TRACE("orientation " + std::to_string(orientation) + (palette ? ", palette" : ", RGB"));
      const std::vector<unsigned char> bytes = libtiffFile(dir + "/o.tif", stored, false, palette, orientation);
      // What the orientation means (EXIF 2.32, tag 274), on the stored pixels as our decoder gives them.
      const cv::Mat asStored = ours(libtiffFile(dir + "/plain.tif", stored, false, palette));
      cv::Mat expected;
      switch (orientation) {
        case 1:
          expected = asStored;
          break;
        case 2:
          cv::flip(asStored, expected, 1);
          break;
        case 3:
          cv::flip(asStored, expected, -1);
          break;
        case 4:
          cv::flip(asStored, expected, 0);
          break;
        case 5:
          cv::transpose(asStored, expected);
          break;
        case 6:
          cv::transpose(asStored, expected), cv::flip(expected, expected, 1);
          break;
        case 7:
          cv::transpose(asStored, expected), cv::flip(expected, expected, -1);
          break;
        case 8:
          cv::transpose(asStored, expected), cv::flip(expected, expected, 0);
          break;
      }
      const cv::Mat shown = ours(bytes, "portrait.tif");
      EXPECT_EQ(maxDifference(shown, expected), 0);
      const ImageHeader header = readImageHeader(bytes.data(), bytes.size());
      EXPECT_EQ(header.orientation, orientation);
      ASSERT_TRUE(header.size);
      EXPECT_EQ(*header.size, shown.size());
      EXPECT_EQ(shown.size(), orientation >= 5 ? cv::Size(24, 40) : cv::Size(40, 24));
    }
}

// A photo's EXIF names its camera and focal length (issue 37: photos of one camera are fitted together, its focal
// length a prior), in either byte order, with the orientation beside them; from the focal length in pixels follow
// the field of view. Cameras write the 35 mm equivalent or the focal plane's resolution; a crop after the shot
// leaves the latter unusable, and the EXIF says nothing then.
namespace {

// EXIF values' bytes in one byte order, for the EXIF and TIFF tests.
struct ExifValues {
  bool big;
  std::vector<unsigned char> u16(uint32_t v) const { return test::exif16(big, v); }
  std::vector<unsigned char> u32(uint32_t v) const { return test::exif32(big, v); }
  std::vector<unsigned char> rational(uint32_t n, uint32_t d) const {
    std::vector<unsigned char> out = u32(n), b = u32(d);
    out.insert(out.end(), b.begin(), b.end());
    return out;
  }
  static std::vector<unsigned char> ascii(const std::string& text) {
    std::vector<unsigned char> out(text.begin(), text.end());
    out.push_back(0);
    return out;
  }
};

}  // namespace

TEST(Codec, JpegExifNamesTheCameraAndItsFocalLength) {
  const cv::Mat image = testImage(48, 80, CV_8U, 3, 9u);  // 80 x 48 as stored
  const std::vector<unsigned char> plain = cvEncode(".jpg", image, {cv::IMWRITE_JPEG_QUALITY, 95});
  for (bool big : {false, true}) {
    SCOPED_TRACE(big ? "MM" : "II");
    const ExifValues v{big};
    const std::vector<test::ExifEntryBytes> ifd0 = {{271, 2, 6, ExifValues::ascii("Canon")},
                                                    {272, 2, 14, ExifValues::ascii("Canon EOS 80D")},
                                                    {274, 3, 1, v.u16(6)}};  // stored turned: shown 48 x 80
    std::vector<test::ExifEntryBytes> exif = {
        {37386, 5, 1, v.rational(180, 10)},  // 18 mm
        {40962, 4, 1, v.u32(6000)},          // written 6000 x 3600 (5:3, as 80 x 48)
        {40963, 4, 1, v.u32(3600)},
        {41486, 5, 1, v.rational(6000 * 25400, 22320)},  // 6000 px on 22.32 mm, per inch
        {41488, 3, 1, v.u16(2)},
        {41989, 3, 1, v.u16(29)}};
    const std::vector<unsigned char> bytes = test::withApp1(plain, test::exifPayload(big, ifd0, exif));
    const ImageHeader header = readImageHeader(bytes.data(), bytes.size());
    EXPECT_EQ(header.orientation, 6);
    ASSERT_TRUE(header.size);
    EXPECT_EQ(*header.size, cv::Size(48, 80));
    const ExifCamera& camera = header.camera;
    EXPECT_EQ(camera.make, "Canon");
    EXPECT_EQ(camera.model, "Canon EOS 80D");
    EXPECT_DOUBLE_EQ(camera.focalMm, 18);
    EXPECT_DOUBLE_EQ(camera.focal35mm, 29);
    EXPECT_NEAR(camera.focalPlanePxPerMm, 6000 / 22.32, 1e-9);
    EXPECT_EQ(camera.describe(), "Canon EOS 80D, 18 mm (29 mm on 35 mm film)");
    // From the 35 mm equivalent: 29 mm on the frame's 43.27 mm diagonal, as a share of this image's diagonal.
    EXPECT_NEAR(camera.focalPx(*header.size), 29 * std::hypot(48, 80) / std::hypot(36, 24), 1e-9);
    // Without it, from the focal plane: 18 mm x 268.8 px/mm at 6000 px wide, scaled to this image's 80.
    exif.pop_back();
    const std::vector<unsigned char> noEquivalent = test::withApp1(plain, test::exifPayload(big, ifd0, exif));
    const ExifCamera plane = readImageHeader(noEquivalent.data(), noEquivalent.size()).camera;
    EXPECT_EQ(plane.focal35mm, 0);
    EXPECT_NEAR(plane.focalPx(cv::Size(48, 80)), 18 * (6000 / 22.32) * 80 / 6000, 1e-9);
    EXPECT_EQ(plane.focalPx(cv::Size(48, 60)), 0);  // cropped to another aspect: unknown
    // The decoder applies the same orientation.
    EXPECT_EQ(ours(bytes, "canon.jpg").size(), cv::Size(48, 80));
  }
  // No EXIF, or an APP1 that is not EXIF: nothing.
  EXPECT_TRUE(readImageHeader(plain.data(), plain.size()).camera.empty());
  const std::vector<unsigned char> xmp = test::withApp1(plain, {'h', 't', 't', 'p', ':', '/', '/', 'n', 's', 0});
  EXPECT_TRUE(readImageHeader(xmp.data(), xmp.size()).camera.empty());
  EXPECT_EQ(readImageHeader(xmp.data(), xmp.size()).orientation, 1);
}

// A TIFF (a raw converter's, a scanner's) names its camera in its first directory and its EXIF directory, read by
// libtiff: the same camera as a JPEG's EXIF.
TEST(Codec, TiffExifNamesTheCameraAndItsFocalLength) {
  for (bool big : {false, true}) {
    SCOPED_TRACE(big ? "MM" : "II");
    const ExifValues v{big};
    // A 4 x 4 grey image whose 16 bytes of pixels are the file's first 16 (any bytes are grey levels).
    const std::vector<test::ExifEntryBytes> ifd0 = {{256, 3, 1, v.u16(4)},
                                                    {257, 3, 1, v.u16(4)},
                                                    {258, 3, 1, v.u16(8)},
                                                    {259, 3, 1, v.u16(1)},
                                                    {262, 3, 1, v.u16(1)},
                                                    {271, 2, 7, ExifValues::ascii("NIKON ")},
                                                    {272, 2, 10, ExifValues::ascii("NIKON Z 6")},
                                                    {273, 4, 1, v.u32(0)},
                                                    {277, 3, 1, v.u16(1)},
                                                    {278, 3, 1, v.u16(4)},
                                                    {279, 4, 1, v.u32(16)}};
    const std::vector<test::ExifEntryBytes> exif = {{37386, 5, 1, v.rational(50, 1)},  // 50 mm
                                                    {41989, 3, 1, v.u16(50)}};         // on a full frame
    std::vector<unsigned char> bytes = test::exifPayload(big, ifd0, exif);
    bytes.erase(bytes.begin(), bytes.begin() + 6);  // "Exif\0\0": the rest is a TIFF file
    const ImageHeader header = readImageHeader(bytes.data(), bytes.size());
    ASSERT_TRUE(header.size);
    EXPECT_EQ(*header.size, cv::Size(4, 4));
    EXPECT_EQ(header.camera.make, "NIKON");
    EXPECT_EQ(header.camera.model, "NIKON Z 6");
    EXPECT_NEAR(header.camera.focalMm, 50, 1e-6);
    EXPECT_DOUBLE_EQ(header.camera.focal35mm, 50);
    EXPECT_EQ(header.camera.describe(), "NIKON Z 6, 50 mm (50 mm on 35 mm film)");
    EXPECT_EQ(ours(bytes, "nikon.tif").size(), cv::Size(4, 4));  // and it decodes
  }
  // A TIFF without a camera (OpenCV's): nothing.
  const std::vector<unsigned char> plain = cvEncode(".tif", testImage(8, 8, CV_8U, 3, 3u), {});
  const ImageHeader header = readImageHeader(plain.data(), plain.size());
  ASSERT_TRUE(header.size);
  EXPECT_TRUE(header.camera.empty());
}

// A photo with an embedded colour profile (Adobe RGB, as many cameras can store) comes in sRGB: its colours as the
// profile says they are (Little CMS), within JPEG's loss; without the conversion its reds would be off by more.
TEST(Codec, EmbeddedColourProfilesComeInSrgb) {
  // Adobe RGB (1998): D65, its primaries, gamma 563/256.
  const cmsCIExyY white = {0.3127, 0.3290, 1.0};
  const cmsCIExyYTRIPLE primaries = {{0.64, 0.33, 1.0}, {0.21, 0.71, 1.0}, {0.15, 0.06, 1.0}};
  cmsToneCurve* gamma = cmsBuildGamma(nullptr, 563.0 / 256.0);
  cmsToneCurve* curves[3] = {gamma, gamma, gamma};
  cmsHPROFILE adobe = cmsCreateRGBProfile(&white, &primaries, curves);
  cmsFreeToneCurve(gamma);
  cmsUInt32Number size = 0;
  ASSERT_TRUE(cmsSaveProfileToMem(adobe, nullptr, &size));
  std::vector<unsigned char> icc(size);
  ASSERT_TRUE(cmsSaveProfileToMem(adobe, icc.data(), &size));
  cmsCloseProfile(adobe);

  // Flat patches of Adobe RGB colours (B,G,R), each 16 x 16 (JPEG keeps flat blocks nearly exact).
  const std::vector<cv::Vec3b> colours = {{40, 40, 200}, {60, 180, 60}, {200, 90, 30}, {128, 128, 128}};
  cv::Mat image(16, 16 * int(colours.size()), CV_8UC3);
  for (size_t i = 0; i < colours.size(); ++i) image(cv::Rect(16 * int(i), 0, 16, 16)).setTo(colours[i]);
  const std::vector<unsigned char> bytes = libjpegEncode(image, JCS_EXT_BGR, 100, icc);
  const cv::Mat decoded = ours(bytes, "adobe.jpg");
  ASSERT_EQ(decoded.type(), CV_8UC3);

  // The expected sRGB: Adobe RGB to XYZ to linear sRGB (both D65), encoded.
  const Eigen::Matrix3d adobeToXyz{
      {0.5767309, 0.1855540, 0.1881852}, {0.2973769, 0.6273491, 0.0752741}, {0.0270343, 0.0706872, 0.9911085}};
  const Eigen::Matrix3d xyzToSrgb{
      {3.2404542, -1.5371385, -0.4985314}, {-0.9692660, 1.8760108, 0.0415560}, {0.0556434, -0.2040259, 1.0572252}};
  int worstConverted = 0, worstStored = 0;
  for (size_t i = 0; i < colours.size(); ++i) {
    const cv::Vec3b got = decoded.at<cv::Vec3b>(8, 16 * int(i) + 8);
    Eigen::Vector3d linear;
    for (int c = 0; c < 3; ++c) linear[c] = std::pow(colours[i][2 - c] / 255.0, 563.0 / 256.0);  // R,G,B
    const Eigen::Vector3d srgb = xyzToSrgb * adobeToXyz * linear;
    for (int c = 0; c < 3; ++c) {
      const double v = std::clamp(srgb[c], 0.0, 1.0);
      const double encoded = 255 * (v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1 / 2.4) - 0.055);
      worstConverted = std::max(worstConverted, int(std::lround(std::abs(got[2 - c] - encoded))));
      worstStored = std::max(worstStored, std::abs(int(colours[i][2 - c]) - int(std::lround(encoded))));
    }
  }
  std::printf("Adobe RGB patches: %d levels from the expected sRGB (stored values would be %d off)\n", worstConverted,
              worstStored);
  EXPECT_LE(worstConverted, 3);
  EXPECT_GE(worstStored, 20);
  // The header says a profile is embedded (montage info reports it), and not for the same JPEG without one.
  EXPECT_TRUE(readImageHeader(bytes.data(), bytes.size()).iccProfile);
  const std::vector<unsigned char> noProfile = libjpegEncode(image, JCS_EXT_BGR, 100, {});
  EXPECT_FALSE(readImageHeader(noProfile.data(), noProfile.size()).iccProfile);
  // The same pixels without a profile are taken as sRGB, as stored.
  const cv::Mat plain = ours(cvEncode(".jpg", image, {cv::IMWRITE_JPEG_QUALITY, 100}), "plain.jpg");
  EXPECT_LE(cv::norm(plain.at<cv::Vec3b>(8, 8), colours[0], cv::NORM_INF), 2);
}

// A CMYK JPEG (as Adobe software writes it, inverted: 255 = no ink; written with libjpeg: OpenCV writes
// none) comes as B,G,R within JPEG's loss of the colours it stands for.
TEST(Codec, CmykJpegComesAsBgr) {
  const int w = 64, h = 48;
  cv::Mat cmyk(h, w, CV_8UC4), expected(h, w, CV_8UC3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int c = 255 - 3 * x, m = 255 - 4 * y, ye = 200, k = 230;  // smooth ramps
      cmyk.at<cv::Vec4b>(y, x) = cv::Vec4b(uchar(c), uchar(m), uchar(ye), uchar(k));
      expected.at<cv::Vec3b>(y, x) = cv::Vec3b(uchar(ye * k / 255), uchar(m * k / 255), uchar(c * k / 255));
    }
  const std::vector<unsigned char> bytes = libjpegEncode(cmyk, JCS_CMYK, 95);
  const cv::Mat decoded = ours(bytes, "cmyk.jpg");
  ASSERT_EQ(decoded.type(), CV_8UC3);
  cv::Mat diff;
  cv::absdiff(decoded, expected, diff);
  EXPECT_LE(cv::norm(diff, cv::NORM_INF), 6);
  EXPECT_LT(cv::mean(diff)[0] + cv::mean(diff)[1] + cv::mean(diff)[2], 3.0);
}

// Tiled and palette TIFFs (written with libtiff: OpenCV writes neither) decode to their pixels.
TEST(Codec, TiledAndPaletteTiffsDecode) {
  const std::string dir = test::tempDir("codec_tiff");
  const cv::Mat rgb = testImage(45, 70, CV_8U, 3, 21);  // not a multiple of the 16-pixel tiles
  cv::Mat bgr;
  cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
  EXPECT_EQ(maxDifference(ours(libtiffFile(dir + "/tiled.tif", rgb, true, false)), bgr), 0);
  EXPECT_EQ(maxDifference(ours(libtiffFile(dir + "/strips.tif", rgb, false, false)), bgr), 0);
  cv::Mat red, grey3;
  cv::extractChannel(rgb, red, 0);
  cv::cvtColor(red, grey3, cv::COLOR_GRAY2BGR);
  for (bool tiled : {false, true})
    EXPECT_EQ(maxDifference(ours(libtiffFile(dir + "/palette.tif", rgb, tiled, true)), grey3), 0) << tiled;
}

// Bad data: an error that names the image and the reason, never a crash.
TEST(Codec, DamagedOrUnknownDataGivesAnErrorNamingTheImage) {
  const cv::Mat image = testImage(64, 64, CV_8U, 3, 3);
  const std::vector<unsigned char> png = encodePng(image, "x.png");
  const std::vector<unsigned char> tiff = cvEncode(".tiff", image), jpeg = cvEncode(".jpg", image);
  const auto truncated = [](std::vector<unsigned char> v) {
    v.resize(v.size() / 3);
    return v;
  };
  for (const auto& [name, bytes] : std::vector<std::pair<std::string, std::vector<unsigned char>>>{
           {"cut.png", truncated(png)}, {"cut.tif", truncated(tiff)}, {"cut.jpg", truncated(jpeg)}}) {
    const std::string message = errorOf([&] { ours(bytes, name); });
    EXPECT_NE(message.find(name), std::string::npos) << message;
    EXPECT_NE(message.find("cannot decode"), std::string::npos) << message;
  }
  const std::vector<unsigned char> text = {'h', 'e', 'l', 'l', 'o', ' ', 'w', 'o', 'r', 'l', 'd'};
  EXPECT_NE(errorOf([&] { ours(text, "notes.png"); }).find("notes.png: not a PNG, JPEG, TIFF or BMP image"),
            std::string::npos);
  // A header claiming 20000 pixels a side is refused before decoding.
  std::vector<unsigned char> big = png;
  big[16] = 0, big[17] = 0, big[18] = 0x4E, big[19] = 0x20;  // IHDR width = 20000
  const std::string message = errorOf([&] { ours(big, "big.png"); });
  EXPECT_NE(message.find("at most 16384 pixels a side"), std::string::npos) << message;
  // The encoder refuses what PNG cannot hold.
  EXPECT_NE(errorOf([&] { encodePng(cv::Mat(4, 4, CV_32FC3), "f.png"); }).find("f.png: cannot encode PNG"),
            std::string::npos);
}

// Damaged files of every format (seeded byte changes and cuts of valid files) either decode or throw
// montage::Error; none crashes, hangs or throws anything else.
TEST(Codec, MutatedFilesDecodeOrGiveAnError) {
  const cv::Mat image = testImage(40, 56, CV_8U, 3, 9);
  const std::vector<std::pair<std::string, std::vector<unsigned char>>> files = {
      {"m.png", encodePng(image, "m.png")}, {"m16.png", encodePng(testImage(40, 56, CV_16U, 4, 9), "m16.png")},
      {"m.jpg", cvEncode(".jpg", image)},   {"mp.jpg", cvEncode(".jpg", image, {cv::IMWRITE_JPEG_PROGRESSIVE, 1})},
      {"m.tif", cvEncode(".tiff", image)},  {"m.bmp", cvEncode(".bmp", image)}};
  std::mt19937 rng(5);
  int decoded = 0, refused = 0;
  for (const auto& [name, valid] : files)
    for (int trial = 0; trial < 300; ++trial) {
      std::vector<unsigned char> bytes = valid;
      const int changes = 1 + int(rng() % 8);
      for (int k = 0; k < changes; ++k) bytes[rng() % bytes.size()] = uint8_t(rng());
      if (trial % 5 == 0) bytes.resize(1 + rng() % bytes.size());
      try {
        const cv::Mat out = ours(bytes, name);
        EXPECT_FALSE(out.empty()) << name << " trial " << trial;
        ++decoded;
      } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
        ++refused;
      }
    }
  EXPECT_GT(decoded, 0);
  EXPECT_GT(refused, 0);
  std::printf("mutated files: %d decoded, %d refused with an error\n", decoded, refused);
}

// A file is decoded as it is read (never held whole): the same pixels as from memory, for every format,
// and a cut file gives an error naming it.
TEST(Codec, FilesDecodeAsTheirBytesDo) {
  const std::string dir = test::tempDir("codec_files");
  const cv::Mat image = testImage(33, 47, CV_8U, 3, 13);
  for (const std::string ext : {".png", ".jpg", ".bmp", ".tiff"}) {
    const std::vector<unsigned char> bytes = cvEncode(ext, image);
    const std::string path = dir + "/a" + ext, cut = dir + "/cut" + ext;
    writeFileAtomic(path, std::string(bytes.begin(), bytes.end()));
    EXPECT_EQ(maxDifference(readImageFile(path), ours(bytes)), 0) << ext;
    writeFileAtomic(cut, std::string(bytes.begin(), bytes.begin() + long(bytes.size() / 2)));
    const std::string message = errorOf([&] { readImageFile(cut); });
    EXPECT_NE(message.find(cut), std::string::npos) << ext << ": " << message;
  }
  const std::string message = errorOf([&] { readImageFile(dir + "/missing.png"); });
  EXPECT_NE(message.find("missing.png"), std::string::npos) << message;
}
