#include "image/codec.h"

// jpeglib.h needs FILE from <cstdio> first.
// clang-format off
#include <cstdio>
#include <jpeglib.h>
#include <lcms2.h>
#include <libexif/exif-data.h>
#include <jerror.h>
// clang-format on
#include <png.h>
#include <stb_image.h>
#include <tiffio.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <csetjmp>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <memory>
#include <opencv2/imgproc.hpp>
#include <streambuf>

#include "base/common.h"
#include "base/fileio.h"

namespace montage {

namespace {

// ---- Header parsers: the size of PNG, JPEG, BMP and TIFF files without decoding them. ----

// A read-only stream buffer over bytes in memory, seekable (header parsers jump around).
class MemoryBuffer : public std::streambuf {
 public:
  MemoryBuffer(const unsigned char* data, size_t size) {
    char* p = const_cast<char*>(reinterpret_cast<const char*>(data));
    setg(p, p, p + size);
  }

 protected:
  pos_type seekoff(off_type off, std::ios_base::seekdir dir, std::ios_base::openmode) override {
    const off_type base = dir == std::ios_base::beg   ? 0
                          : dir == std::ios_base::cur ? gptr() - eback()
                                                      : egptr() - eback();
    return seekpos(pos_type(base + off), std::ios_base::in);
  }
  pos_type seekpos(pos_type pos, std::ios_base::openmode) override {
    if (pos < 0 || pos > egptr() - eback()) return pos_type(off_type(-1));
    setg(eback(), eback() + off_type(pos), egptr());
    return pos;
  }
};

class ByteReader {
 public:
  explicit ByteReader(std::istream& in) : in_(in) {}
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
  std::istream& in_;
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

// An EXIF text field (at most `size` bytes): trailing spaces and NULs dropped, control characters made spaces.
std::string exifText(const char* text, size_t size) {
  std::string t(text, strnlen(text, size));
  while (!t.empty() && (t.back() == ' ' || t.back() == '\0')) t.pop_back();
  for (char& c : t)
    if (static_cast<unsigned char>(c) < 32) c = ' ';
  return t;
}

// Focal lengths and resolutions outside what a camera writes are taken for absent.
void keepPlausible(ExifCamera& c) {
  const auto plausible = [](double v, double hi) { return std::isfinite(v) && v > 0 && v < hi ? v : 0.0; };
  c.focalMm = plausible(c.focalMm, 5000), c.focal35mm = plausible(c.focal35mm, 5000);
  c.focalPlanePxPerMm = plausible(c.focalPlanePxPerMm, 1e6);
  c.writtenWidth = plausible(c.writtenWidth, 1e6), c.writtenHeight = plausible(c.writtenHeight, 1e6);
}

// The focal plane resolution's unit (EXIF 41488: 2 inch, 3 cm, 4 mm, 5 um; inch when absent) in millimetres.
double focalPlaneUnitMm(int unit) {
  return unit == 3 ? 10 : unit == 4 ? 1 : unit == 5 ? 1e-3 : 25.4;
}

// What an APP1 segment's EXIF data says (the segment's payload, from "Exif\0\0" on), read by libexif: the
// orientation (TIFF tag 274, 1..8; 1 when absent) and the camera. Data that is not EXIF says nothing. libexif's
// "follow the specification" option is off: it would add the mandatory tags a file lacks, with made-up values.
struct ExifRead {
  int orientation = 1;
  ExifCamera camera;
};
ExifRead readExif(const uint8_t* p, size_t n) {
  ExifRead out;
  if (n < 14 || std::memcmp(p, "Exif\0\0", 6) != 0) return out;
  ExifData* data = exif_data_new();
  if (!data) return out;
  exif_data_unset_option(data, EXIF_DATA_OPTION_FOLLOW_SPECIFICATION);
  exif_data_load_data(data, p, static_cast<unsigned int>(n));
  const ExifByteOrder order = exif_data_get_byte_order(data);
  const auto entry = [&](ExifIfd ifd, ExifTag tag, ExifFormat format) -> ExifEntry* {
    ExifEntry* e = exif_content_get_entry(data->ifd[ifd], tag);
    return e && e->format == format && e->components >= 1 && e->data && e->size >= exif_format_get_size(format)
               ? e
               : nullptr;
  };
  const auto shortOf = [&](ExifIfd ifd, ExifTag tag) {
    const ExifEntry* e = entry(ifd, tag, EXIF_FORMAT_SHORT);
    return e ? int(exif_get_short(e->data, order)) : 0;
  };
  const auto longOf = [&](ExifIfd ifd, ExifTag tag) {  // SHORT or LONG, as the pixel dimensions may be stored
    if (const ExifEntry* e = entry(ifd, tag, EXIF_FORMAT_LONG)) return double(exif_get_long(e->data, order));
    return double(shortOf(ifd, tag));
  };
  const auto rationalOf = [&](ExifIfd ifd, ExifTag tag) {
    const ExifEntry* e = entry(ifd, tag, EXIF_FORMAT_RATIONAL);
    if (!e) return 0.0;
    const ExifRational r = exif_get_rational(e->data, order);
    return r.denominator ? double(r.numerator) / r.denominator : 0.0;
  };
  const auto textOf = [&](ExifIfd ifd, ExifTag tag) {
    const ExifEntry* e = entry(ifd, tag, EXIF_FORMAT_ASCII);
    return e ? exifText(reinterpret_cast<const char*>(e->data), e->size) : std::string();
  };
  const int orientation = shortOf(EXIF_IFD_0, EXIF_TAG_ORIENTATION);
  out.orientation = orientation >= 1 && orientation <= 8 ? orientation : 1;
  ExifCamera& c = out.camera;
  c.make = textOf(EXIF_IFD_0, EXIF_TAG_MAKE);
  c.model = textOf(EXIF_IFD_0, EXIF_TAG_MODEL);
  c.focalMm = rationalOf(EXIF_IFD_EXIF, EXIF_TAG_FOCAL_LENGTH);
  c.focal35mm = shortOf(EXIF_IFD_EXIF, EXIF_TAG_FOCAL_LENGTH_IN_35MM_FILM);
  // FocalPlaneXResolution in its unit (2: inch, 3: cm, 4: mm, 5: um; 2 when absent), of the image the camera wrote
  // (PixelXDimension wide): pixels per mm of this image's width.
  const double resolution = rationalOf(EXIF_IFD_EXIF, EXIF_TAG_FOCAL_PLANE_X_RESOLUTION);
  const int unit = shortOf(EXIF_IFD_EXIF, EXIF_TAG_FOCAL_PLANE_RESOLUTION_UNIT);
  c.focalPlanePxPerMm = resolution > 0 ? resolution / focalPlaneUnitMm(unit) : 0;
  c.writtenWidth = longOf(EXIF_IFD_EXIF, EXIF_TAG_PIXEL_X_DIMENSION);
  c.writtenHeight = longOf(EXIF_IFD_EXIF, EXIF_TAG_PIXEL_Y_DIMENSION);
  keepPlausible(c);
  exif_data_unref(data);
  return out;
}

// Turns an image decoded as stored into the image as shown, by its EXIF orientation.
cv::Mat orient(const cv::Mat& stored, int orientation) {
  cv::Mat shown;
  switch (orientation) {
    case 2:
      cv::flip(stored, shown, 1);
      break;
    case 3:
      cv::rotate(stored, shown, cv::ROTATE_180);
      break;
    case 4:
      cv::flip(stored, shown, 0);
      break;
    case 5:
      cv::transpose(stored, shown);
      break;
    case 6:
      cv::rotate(stored, shown, cv::ROTATE_90_CLOCKWISE);
      break;
    case 7:
      cv::transpose(stored, shown), cv::flip(shown, shown, -1);
      break;
    case 8:
      cv::rotate(stored, shown, cv::ROTATE_90_COUNTERCLOCKWISE);
      break;
    default:
      return stored;
  }
  return shown;
}

// JPEG: walk the marker segments to the first start-of-frame (SOFn) segment; the first EXIF APP1 segment on the way
// gives the orientation and the camera, an APP2 segment says a colour profile is embedded; the size is the shown
// image's.
std::optional<cv::Size> jpegSize(ByteReader& in, ImageHeader& header) {
  int& orientation = header.orientation;
  bool exifSeen = false;
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
      return orientation >= 5 ? cv::Size(int(*h), int(*w)) : cv::Size(int(*w), int(*h));
    }
    if (*marker == 0xE1 && !exifSeen) {  // APP1: EXIF (or XMP, which says nothing here)
      std::vector<uint8_t> payload(*length - 2);
      if (!in.read(payload.data(), payload.size())) return std::nullopt;
      const ExifRead exif = readExif(payload.data(), payload.size());
      exifSeen = std::memcmp(payload.data(), "Exif\0\0", std::min<size_t>(6, payload.size())) == 0;
      orientation = exif.orientation, header.camera = exif.camera;
    } else if (*marker == 0xE2 && *length - 2 >= 12) {  // APP2: "ICC_PROFILE\0" and a chunk of the profile
      uint8_t tag[12];
      if (!in.read(tag, 12)) return std::nullopt;
      header.iccProfile = header.iccProfile || std::memcmp(tag, "ICC_PROFILE\0", 12) == 0;
      if (!in.skip(*length - 2 - 12)) return std::nullopt;
    } else if (!in.skip(*length - 2)) {
      return std::nullopt;
    }
    auto next = in.u8();  // every segment is followed by a marker
    if (!next || *next != 0xFF) return std::nullopt;
  }
}

// BMP: BITMAPCOREHEADER (16-bit sizes) or BITMAPINFOHEADER and later (signed 32-bit, negative height
// for top-down rows). An uncompressed one (or with bit fields) holds its rows from the pixel data offset on:
// `minBytes`.
void bmpHeader(ByteReader& in, ImageHeader& header) {
  in.seek(10);
  const auto offset = in.u32(false), headerSize = in.u32(false);
  if (!offset || !headerSize) return;
  const bool core = *headerSize == 12;  // no compression field
  const auto w = core ? in.u16(false) : in.u32(false), h = core ? in.u16(false) : in.u32(false);
  if (!w || !h) return;
  const auto absolute = [&](uint32_t v) { return core ? int64_t(v) : std::abs(int64_t(int32_t(v))); };
  const int64_t width = absolute(*w), height = absolute(*h);
  header.size = cv::Size(int(std::min<int64_t>(width, INT32_MAX)), int(std::min<int64_t>(height, INT32_MAX)));
  const auto planes = in.u16(false), bits = in.u16(false);
  const auto compression = core ? std::optional<uint32_t>(0) : in.u32(false);
  if (!planes || !bits || !compression || (*compression != 0 && *compression != 3)) return;
  header.minBytes = *offset + (uint64_t(width) * *bits + 31) / 32 * 4 * uint64_t(height);
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

// libtiff reading through a client's callbacks, never writing; its warnings (unknown tags...) are silent, its
// errors go to `error` with `user`. Null when the data is not a TIFF it opens.
tmsize_t tiffWrite(thandle_t, void*, tmsize_t) {
  return -1;
}
int tiffClose(thandle_t) {
  return 0;
}
int tiffSilent(TIFF*, void*, const char*, const char*, va_list) {
  return 1;
}
struct TiffCloser {
  void operator()(TIFF* t) const { TIFFClose(t); }
};
std::unique_ptr<TIFF, TiffCloser> openTiffClient(const std::string& name, thandle_t handle, TIFFReadWriteProc read,
                                                 TIFFSeekProc seek, TIFFSizeProc size, TIFFErrorHandlerExtR error,
                                                 void* user) {
  TIFFOpenOptions* options = TIFFOpenOptionsAlloc();
  TIFFOpenOptionsSetErrorHandlerExtR(options, error, user);
  TIFFOpenOptionsSetWarningHandlerExtR(options, tiffSilent, nullptr);
  TIFF* tif =
      TIFFClientOpenExt(name.c_str(), "rm", handle, read, tiffWrite, seek, tiffClose, size, nullptr, nullptr, options);
  TIFFOpenOptionsFree(options);
  return std::unique_ptr<TIFF, TiffCloser>(tif);
}

// TIFF: the camera its first directory (Make, Model) and its EXIF directory (FocalLength, FocalLengthIn35mmFilm, the
// focal plane's resolution, PixelX/YDimension) name, read by libtiff from the stream: only the directories are
// read. Nothing when the file is not a TIFF libtiff opens (its messages are not shown: the decoder reports damage).
struct TiffStream {
  std::istream& in;
  uint64_t size;
};
tmsize_t tiffStreamRead(thandle_t handle, void* out, tmsize_t n) {
  auto* s = static_cast<TiffStream*>(handle);
  s->in.clear();
  s->in.read(static_cast<char*>(out), std::streamsize(std::max<tmsize_t>(n, 0)));
  return tmsize_t(s->in.gcount());
}
toff_t tiffStreamSeek(thandle_t handle, toff_t offset, int whence) {
  auto* s = static_cast<TiffStream*>(handle);
  s->in.clear();
  const auto dir = whence == SEEK_CUR ? std::ios::cur : whence == SEEK_END ? std::ios::end : std::ios::beg;
  s->in.seekg(std::streamoff(offset), dir);
  const auto at = s->in.tellg();
  return at < 0 ? toff_t(-1) : toff_t(at);
}
toff_t tiffStreamSize(thandle_t handle) {
  return toff_t(static_cast<TiffStream*>(handle)->size);
}

// A TIFF's camera (its first directory's make and model, its EXIF directory's focal lengths) and its orientation
// (tag 274, 1..8; 1 when absent or out of range).
ExifCamera tiffCamera(std::istream& stream, int& orientation) {
  ExifCamera c;
  orientation = 1;
  stream.clear();
  stream.seekg(0, std::ios::end);
  const auto size = stream.tellg();
  if (size <= 0 || !stream.seekg(0)) return c;  // libtiff reads its header from where the stream stands
  TiffStream source{stream, uint64_t(size)};
  const auto opened =
      openTiffClient("header", &source, tiffStreamRead, tiffStreamSeek, tiffStreamSize, tiffSilent, nullptr);
  TIFF* tif = opened.get();
  if (!tif) return c;
  const auto text = [&](uint32_t tag) {
    const char* t = nullptr;
    return TIFFGetField(tif, tag, &t) && t ? exifText(t, 256) : std::string();
  };
  c.make = text(TIFFTAG_MAKE);
  c.model = text(TIFFTAG_MODEL);
  uint16_t o = 1;
  if (TIFFGetField(tif, TIFFTAG_ORIENTATION, &o) && o >= 1 && o <= 8) orientation = o;
  toff_t exif = 0;
  if (TIFFGetField(tif, TIFFTAG_EXIFIFD, &exif) && exif && TIFFReadEXIFDirectory(tif, exif)) {
    // A field as libtiff stores it: a rational as a float or a double (TIFFFieldSetGetSize), a SHORT or a LONG.
    const auto number = [&](uint32_t tag) -> double {
      const TIFFField* f = TIFFFieldWithTag(tif, tag);
      if (!f) return 0;
      const TIFFDataType type = TIFFFieldDataType(f);
      const int bytes = TIFFFieldSetGetSize(f);
      if (type == TIFF_RATIONAL && bytes == 4) {
        float v = 0;
        return TIFFGetField(tif, tag, &v) ? v : 0;
      }
      if (type == TIFF_RATIONAL && bytes == 8) {
        double v = 0;
        return TIFFGetField(tif, tag, &v) ? v : 0;
      }
      if (bytes == 2) {
        uint16_t v = 0;
        return TIFFGetField(tif, tag, &v) ? v : 0;
      }
      if (bytes == 4) {
        uint32_t v = 0;
        return TIFFGetField(tif, tag, &v) ? v : 0;
      }
      return 0;
    };
    c.focalMm = number(EXIFTAG_FOCALLENGTH);
    c.focal35mm = number(EXIFTAG_FOCALLENGTHIN35MMFILM);
    const double resolution = number(EXIFTAG_FOCALPLANEXRESOLUTION);
    c.focalPlanePxPerMm =
        resolution > 0 ? resolution / focalPlaneUnitMm(int(number(EXIFTAG_FOCALPLANERESOLUTIONUNIT))) : 0;
    c.writtenWidth = number(EXIFTAG_PIXELXDIMENSION);
    c.writtenHeight = number(EXIFTAG_PIXELYDIMENSION);
    keepPlausible(c);
  }
  return c;
}

ImageFormat formatOf(const uint8_t (&magic)[8]) {
  static const uint8_t kPng[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  if (std::equal(magic, magic + 8, kPng)) return ImageFormat::Png;
  if (magic[0] == 0xFF && magic[1] == 0xD8 && magic[2] == 0xFF) return ImageFormat::Jpeg;
  if (magic[0] == 'B' && magic[1] == 'M') return ImageFormat::Bmp;
  if (magic[0] == 'I' && magic[1] == 'I' && magic[2] == 42 && magic[3] == 0) return ImageFormat::TiffLittle;
  if (magic[0] == 'M' && magic[1] == 'M' && magic[2] == 0 && magic[3] == 42) return ImageFormat::TiffBig;
  return ImageFormat::Unknown;
}

}  // namespace

ImageHeader readImageHeader(std::istream& stream) {
  ByteReader in(stream);
  uint8_t magic[8] = {};
  ImageHeader header;
  if (!in.ok() || !in.read(magic, 8)) return header;
  header.format = formatOf(magic);
  switch (header.format) {
    case ImageFormat::Png:
      header.size = pngSize(in);
      break;
    case ImageFormat::Jpeg:
      header.size = jpegSize(in, header);
      break;
    case ImageFormat::Bmp:
      bmpHeader(in, header);
      break;
    case ImageFormat::TiffLittle:
    case ImageFormat::TiffBig:
      header.size = tiffSize(in, header.format == ImageFormat::TiffBig);
      if (header.size) {
        header.camera = tiffCamera(stream, header.orientation);
        if (header.orientation >= 5) header.size = cv::Size(header.size->height, header.size->width);
      }
      break;
    case ImageFormat::Unknown:
      break;
  }
  return header;
}

ImageHeader readImageHeader(const unsigned char* bytes, size_t size) {
  MemoryBuffer buffer(bytes, size);
  std::istream in(&buffer);
  return readImageHeader(in);
}

ImageHeader readImageFileHeader(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return readImageHeader(in);
}

double ExifCamera::focalPx(cv::Size shown) const {
  if (shown.width <= 0 || shown.height <= 0) return 0;
  if (focal35mm > 0) return focal35mm * std::hypot(shown.width, shown.height) / std::hypot(36.0, 24.0);
  if (focalMm > 0 && focalPlanePxPerMm > 0 && writtenWidth > 0 && writtenHeight > 0) {
    // The written image may be shown turned (EXIF orientation 5..8): match its longer side to the shown one's.
    const double written = std::max(writtenWidth, writtenHeight), side = std::max(shown.width, shown.height);
    const double aspect = std::min(writtenWidth, writtenHeight) / written;
    if (std::abs(aspect - std::min(shown.width, shown.height) / side) > 0.01) return 0;  // cropped: unknown
    return focalMm * focalPlanePxPerMm * side / written;
  }
  return 0;
}

std::string ExifCamera::describe() const {
  if (empty()) return "";
  // Many cameras repeat the make in the model ("Canon", "Canon EOS 80D").
  std::string s = make.empty() || model.rfind(make, 0) == 0 ? model : model.empty() ? make : make + " " + model;
  char focal[96] = "";
  if (focalMm > 0 && focal35mm > 0)
    std::snprintf(focal, sizeof focal, "%.3g mm (%.0f mm on 35 mm film)", focalMm, focal35mm);
  else if (focalMm > 0)
    std::snprintf(focal, sizeof focal, "%.3g mm", focalMm);
  else if (focal35mm > 0)
    std::snprintf(focal, sizeof focal, "%.0f mm on 35 mm film", focal35mm);
  if (*focal) s += (s.empty() ? "" : ", ") + std::string(focal);
  return s;
}

namespace {

// ---- Decoding ----

void checkSize(cv::Size size, const std::string& where) {
  TM_CHECK(size.width > 0 && size.height > 0, located(where, "image is empty (0 pixels)"));
  TM_CHECK(size.width <= kMaxImageSide && size.height <= kMaxImageSide,
           located(where, "image is " + std::to_string(size.width) + "x" + std::to_string(size.height) +
                              " pixels; at most " + std::to_string(kMaxImageSide) + " pixels a side are supported"));
}

// libpng and libjpeg report errors by longjmp: the functions that call them set the jump target and make
// no C++ object, so that a jump skips no destructor. Each decoder reads the header in one such function,
// the caller allocates the image, and a second one decodes into it.

// Encoded data: bytes in memory, or a file read as it is decoded (a photo's file is never held whole
// beside its pixels).
struct Encoded {
  const unsigned char* data = nullptr;
  size_t size = 0;
  std::FILE* file = nullptr;  // at the start of the image; `size` is then the file's size
  mutable size_t filePos = 0;

  // Up to n bytes at `at` into out; how many were read. Reads in sequence do not seek.
  size_t read(size_t at, void* out, size_t n) const {
    if (at >= size) return 0;
    n = std::min(n, size - at);
    if (!file) return std::memcpy(out, data + at, n), n;
    if (at != filePos && fseeko(file, off_t(at), SEEK_SET) != 0) return 0;
    const size_t got = std::fread(out, 1, n, file);
    filePos = at + got;
    return got;
  }
};

// ---- PNG (libpng) ----

constexpr int kPngErrorSize = 256;

[[noreturn]] void pngFail(png_structp png, png_const_charp message) {
  std::snprintf(static_cast<char*>(png_get_error_ptr(png)), kPngErrorSize, "%s", message);
  png_longjmp(png, 1);
}
void pngWarn(png_structp, png_const_charp) {}

struct PngSource {
  const Encoded& in;
  size_t at;
  char error[kPngErrorSize];
};

void pngRead(png_structp png, png_bytep out, size_t n) {
  auto* s = static_cast<PngSource*>(png_get_io_ptr(png));
  if (s->in.read(s->at, out, n) != n) png_error(png, "the data ends early (truncated file)");
  s->at += n;
}

struct PngReader {
  png_structp png = nullptr;
  png_infop info = nullptr;
  int width = 0, height = 0, channels = 0, bits = 0;
  ~PngReader() {
    if (png) png_destroy_read_struct(&png, &info, nullptr);
  }
};

// The header, with the transforms that give the samples as stored: palettes and depths below 8 bits
// expanded, transparency (tRNS) as an alpha channel, colour in B,G,R order, 16-bit samples in native order.
bool pngHeader(PngReader& r, PngSource& source) {
  r.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, source.error, pngFail, pngWarn);
  if (!r.png) return false;
  r.info = png_create_info_struct(r.png);
  if (!r.info || setjmp(png_jmpbuf(r.png))) return false;
  png_set_read_fn(r.png, &source, pngRead);
  png_set_user_limits(r.png, kMaxImageSide, kMaxImageSide);
  png_read_info(r.png, r.info);
  png_set_expand(r.png);
  if (png_get_bit_depth(r.png, r.info) == 16) png_set_swap(r.png);
  png_set_bgr(r.png);
  png_set_interlace_handling(r.png);
  png_read_update_info(r.png, r.info);
  r.width = int(png_get_image_width(r.png, r.info));
  r.height = int(png_get_image_height(r.png, r.info));
  r.channels = png_get_channels(r.png, r.info);
  r.bits = png_get_bit_depth(r.png, r.info);
  return true;
}

bool pngPixels(PngReader& r, png_bytepp rows) {
  if (setjmp(png_jmpbuf(r.png))) return false;
  png_read_image(r.png, rows);
  return true;
}

cv::Mat decodePng(const Encoded& in, const std::string& where, std::vector<uint8_t>& icc) {
  PngSource source{in, 0, ""};
  PngReader reader;
  const auto fail = [&] {
    return Error(
        located(where, std::string("cannot decode PNG image: ") + (*source.error ? source.error : "out of memory")));
  };
  if (!pngHeader(reader, source)) throw fail();
  if ((reader.bits != 8 && reader.bits != 16) || reader.channels < 1 || reader.channels > 4)
    throw Error(located(where, "cannot decode PNG image: unexpected layout"));
  checkSize(cv::Size(reader.width, reader.height), where);
  cv::Mat out(reader.height, reader.width, CV_MAKETYPE(reader.bits == 16 ? CV_16U : CV_8U, reader.channels));
  std::vector<png_bytep> rows(reader.height);
  for (int y = 0; y < reader.height; ++y) rows[y] = out.ptr(y);
  if (!pngPixels(reader, rows.data())) throw fail();
  png_charp name = nullptr;
  png_bytep profile = nullptr;
  png_uint_32 length = 0;
  int compression = 0;
  if (png_get_iCCP(reader.png, reader.info, &name, &compression, &profile, &length) && profile)
    icc.assign(profile, profile + length);
  return out;
}

// ---- JPEG (libjpeg) ----

struct JpegError {
  jpeg_error_mgr manager;
  std::jmp_buf jump;
  char message[JMSG_LENGTH_MAX];
};

[[noreturn]] void jpegFail(j_common_ptr info) {
  auto* e = reinterpret_cast<JpegError*>(info->err);
  info->err->format_message(info, e->message);
  std::longjmp(e->jump, 1);
}
// Warnings (damage libjpeg recovers from) do not stop decoding, except a truncated file: libjpeg would
// fill the missing rows with grey.
void jpegMessage(j_common_ptr info, int level) {
  if (level < 0 && info->err->msg_code == JWRN_JPEG_EOF) jpegFail(info);
}

struct JpegReader {
  jpeg_decompress_struct info;
  JpegError error;
  bool created = false;
  ~JpegReader() {
    if (created) jpeg_destroy_decompress(&info);
  }
};

// The header, decoding started: grey stays grey, colour comes as B,G,R, CMYK as stored (4 channels).
bool jpegHeader(JpegReader& r, const Encoded& in) {
  r.info.err = jpeg_std_error(&r.error.manager);
  r.error.manager.error_exit = jpegFail;
  r.error.manager.emit_message = jpegMessage;
  r.error.message[0] = 0;
  if (setjmp(r.error.jump)) return false;
  jpeg_create_decompress(&r.info);
  r.created = true;
  if (in.file)
    jpeg_stdio_src(&r.info, in.file);
  else
    jpeg_mem_src(&r.info, in.data, static_cast<unsigned long>(in.size));
  jpeg_save_markers(&r.info, JPEG_APP0 + 1, 0xFFFF);  // EXIF: the orientation
  jpeg_save_markers(&r.info, JPEG_APP0 + 2, 0xFFFF);  // ICC: the colour profile
  jpeg_read_header(&r.info, TRUE);
  const J_COLOR_SPACE space = r.info.jpeg_color_space;
  r.info.out_color_space = space == JCS_GRAYSCALE                   ? JCS_GRAYSCALE
                           : space == JCS_CMYK || space == JCS_YCCK ? JCS_CMYK
                                                                    : JCS_EXT_BGR;
  jpeg_start_decompress(&r.info);
  return true;
}

bool jpegPixels(JpegReader& r, cv::Mat& out) {
  if (setjmp(r.error.jump)) return false;
  while (r.info.output_scanline < r.info.output_height) {
    JSAMPROW row = out.ptr(int(r.info.output_scanline));
    jpeg_read_scanlines(&r.info, &row, 1);
  }
  jpeg_finish_decompress(&r.info);
  return true;
}

// The orientation of the first EXIF APP1 segment libjpeg kept (jpegHeader), 1 when none.
int jpegOrientation(const jpeg_decompress_struct& info) {
  for (jpeg_saved_marker_ptr m = info.marker_list; m; m = m->next)
    if (m->marker == JPEG_APP0 + 1) {
      const int o = readExif(m->data, m->data_length).orientation;
      if (o != 1) return o;
    }
  return 1;
}

// Decoded as stored (orientation not applied).
cv::Mat decodeJpegStored(JpegReader& reader, const std::string& where) {
  const auto fail = [&] {
    return Error(located(where, std::string("cannot decode JPEG image: ") +
                                    (*reader.error.message ? reader.error.message : "damaged data")));
  };
  const int w = int(reader.info.output_width), h = int(reader.info.output_height);
  const int channels = reader.info.output_components;
  checkSize(cv::Size(w, h), where);
  if (channels != 1 && channels != 3 && channels != 4)
    throw Error(located(where, "cannot decode JPEG image: " + std::to_string(channels) + " components"));
  cv::Mat out(h, w, CV_8UC(channels));
  if (!jpegPixels(reader, out)) throw fail();
  if (channels < 4) return out;
  // CMYK as Adobe stores it (inverted: 255 = no ink) to B,G,R.
  cv::Mat bgr(h, w, CV_8UC3);
  for (int y = 0; y < h; ++y) {
    const uint8_t* s = out.ptr<uint8_t>(y);
    uint8_t* d = bgr.ptr<uint8_t>(y);
    for (int x = 0; x < w; ++x, s += 4, d += 3)
      for (int c = 0; c < 3; ++c) d[c] = uint8_t((s[2 - c] * s[3] + 127) / 255);
  }
  return bgr;
}

cv::Mat decodeJpeg(const Encoded& in, const std::string& where, std::vector<uint8_t>& icc) {
  JpegReader reader;
  if (!jpegHeader(reader, in))
    throw Error(located(where, std::string("cannot decode JPEG image: ") +
                                   (*reader.error.message ? reader.error.message : "damaged data")));
  const int orientation = jpegOrientation(reader.info);
  JOCTET* profile = nullptr;
  unsigned int length = 0;
  if (setjmp(reader.error.jump) == 0) {  // a damaged profile leaves the pixels as stored
    if (jpeg_read_icc_profile(&reader.info, &profile, &length) && profile) icc.assign(profile, profile + length);
  }
  std::free(profile);
  return orient(decodeJpegStored(reader, where), orientation);
}

// ---- BMP (stb_image) ----

// stb_image's pixels (R,G,B(,A), or grey) as an OpenCV image in B,G,R(,A) order.
cv::Mat decodeBmp(const Encoded& in, const std::string& where) {
  int w = 0, h = 0, n = 0;
  unsigned char* pixels = in.file ? stbi_load_from_file(in.file, &w, &h, &n, 0)
                                  : stbi_load_from_memory(in.data, int(in.size), &w, &h, &n, 0);
  if (!pixels) {
    const char* reason = stbi_failure_reason();
    throw Error(located(where, std::string("cannot decode BMP image: ") + (reason ? reason : "damaged data")));
  }
  cv::Mat out;
  {
    const cv::Mat view(h, w, CV_8UC(n), pixels);
    if (n == 3)
      cv::cvtColor(view, out, cv::COLOR_RGB2BGR);
    else if (n == 4)
      cv::cvtColor(view, out, cv::COLOR_RGBA2BGRA);
    else
      out = view.clone();
  }
  stbi_image_free(pixels);
  return out;
}

// Encoded data as libtiff's client input.
struct TiffSource {
  const Encoded& in;
  toff_t at;
  std::string error;  // the first error libtiff reported
};

tmsize_t tiffRead(thandle_t handle, void* out, tmsize_t n) {
  auto* s = static_cast<TiffSource*>(handle);
  const size_t count = s->in.read(size_t(s->at), out, size_t(std::max<tmsize_t>(n, 0)));
  s->at += count;
  return tmsize_t(count);
}
toff_t tiffSeek(thandle_t handle, toff_t offset, int whence) {
  auto* s = static_cast<TiffSource*>(handle);
  const toff_t base = whence == SEEK_CUR ? s->at : whence == SEEK_END ? toff_t(s->in.size) : 0;
  s->at = base + offset;
  return s->at;
}
toff_t tiffSize(thandle_t handle) {
  return toff_t(static_cast<TiffSource*>(handle)->in.size);
}
int tiffError(TIFF*, void* user, const char* module, const char* format, va_list args) {
  auto* s = static_cast<TiffSource*>(user);
  if (s->error.empty()) {
    char text[512];
    std::vsnprintf(text, sizeof text, format, args);
    s->error = text;
  }
  return 1;
}

cv::Mat decodeTiff(const Encoded& in, const std::string& where, std::vector<uint8_t>& icc) {
  TiffSource source{in, 0, ""};
  const auto tif = openTiffClient(where, &source, tiffRead, tiffSeek, tiffSize, tiffError, &source);
  const auto fail = [&](const std::string& why) {
    return Error(located(where, "cannot decode TIFF image: " + (source.error.empty() ? why : source.error)));
  };
  if (!tif) throw fail("damaged header");
  uint32_t iccLength = 0;
  const uint8_t* iccData = nullptr;
  if (TIFFGetField(tif.get(), TIFFTAG_ICCPROFILE, &iccLength, &iccData) && iccData)
    icc.assign(iccData, iccData + iccLength);
  uint32_t w = 0, h = 0;
  uint16_t samples = 1, bits = 1, format = SAMPLEFORMAT_UINT, planar = PLANARCONFIG_CONTIG, photometric = 0;
  TIFFGetField(tif.get(), TIFFTAG_IMAGEWIDTH, &w);
  TIFFGetField(tif.get(), TIFFTAG_IMAGELENGTH, &h);
  TIFFGetFieldDefaulted(tif.get(), TIFFTAG_SAMPLESPERPIXEL, &samples);
  TIFFGetFieldDefaulted(tif.get(), TIFFTAG_BITSPERSAMPLE, &bits);
  TIFFGetFieldDefaulted(tif.get(), TIFFTAG_SAMPLEFORMAT, &format);
  TIFFGetFieldDefaulted(tif.get(), TIFFTAG_PLANARCONFIG, &planar);
  if (!TIFFGetField(tif.get(), TIFFTAG_PHOTOMETRIC, &photometric)) photometric = samples >= 3 ? 2 : 1;
  // The orientation (how the stored rows turn to be shown, as for a JPEG's EXIF), applied below to the pixels as
  // stored: libtiff's RGBA reader would only apply its flips, so it is told the rows are stored as shown.
  uint16_t orientation = ORIENTATION_TOPLEFT;
  TIFFGetField(tif.get(), TIFFTAG_ORIENTATION, &orientation);
  if (orientation < 1 || orientation > 8) orientation = ORIENTATION_TOPLEFT;
  TIFFSetField(tif.get(), TIFFTAG_ORIENTATION, ORIENTATION_TOPLEFT);
  if (w == 0 || h == 0) throw fail("no pixels");
  checkSize(cv::Size(int(std::min<uint32_t>(w, INT32_MAX)), int(std::min<uint32_t>(h, INT32_MAX))), where);
  if (photometric == PHOTOMETRIC_LOGLUV) {  // high dynamic range (OpenCV writes float RGB so): XYZ floats
    TIFFSetField(tif.get(), TIFFTAG_SGILOGDATAFMT, SGILOGDATAFMT_FLOAT);
    bits = 32, format = SAMPLEFORMAT_IEEEFP;
  }
  const bool logLuv = photometric == PHOTOMETRIC_LOGLUV && samples == 3;
  const bool grey = photometric == PHOTOMETRIC_MINISBLACK && samples >= 1 && samples <= 2;
  const bool rgb = photometric == PHOTOMETRIC_RGB && (samples == 3 || samples == 4);
  const int depth = bits == 8 && format == SAMPLEFORMAT_UINT      ? CV_8U
                    : bits == 16 && format == SAMPLEFORMAT_UINT   ? CV_16U
                    : bits == 32 && format == SAMPLEFORMAT_IEEEFP ? CV_32F
                                                                  : -1;
  cv::Mat raw;
  if ((grey || rgb || logLuv) && depth >= 0 && planar == PLANARCONFIG_CONTIG) {
    // The samples as stored, read strip by strip or tile by tile (any compression libtiff decodes).
    raw.create(int(h), int(w), CV_MAKETYPE(depth, samples));
    if (TIFFIsTiled(tif.get())) {
      uint32_t tw = 0, th = 0;
      TIFFGetField(tif.get(), TIFFTAG_TILEWIDTH, &tw);
      TIFFGetField(tif.get(), TIFFTAG_TILELENGTH, &th);
      if (tw == 0 || th == 0 || tw > uint32_t(kMaxImageSide) || th > uint32_t(kMaxImageSide))
        throw fail("tiles of " + std::to_string(tw) + "x" + std::to_string(th) + " pixels");
      cv::Mat tile(int(th), int(tw), raw.type());
      for (uint32_t y = 0; y < h; y += th)
        for (uint32_t x = 0; x < w; x += tw) {
          if (TIFFReadTile(tif.get(), tile.data, x, y, 0, 0) < 0) throw fail("damaged tile");
          const cv::Rect r(int(x), int(y), int(std::min(tw, w - x)), int(std::min(th, h - y)));
          tile(cv::Rect(0, 0, r.width, r.height)).copyTo(raw(r));
        }
    } else {
      for (uint32_t y = 0; y < h; ++y)
        if (TIFFReadScanline(tif.get(), raw.ptr(int(y)), y, 0) < 0) throw fail("damaged row " + std::to_string(y));
    }
    if (logLuv)
      cv::cvtColor(raw, raw, cv::COLOR_XYZ2BGR);
    else if (samples == 3)
      cv::cvtColor(raw, raw, cv::COLOR_RGB2BGR);
    if (samples == 4) cv::cvtColor(raw, raw, cv::COLOR_RGBA2BGRA);
    return orient(raw, orientation);
  }
  if (bits > 8 || format == SAMPLEFORMAT_IEEEFP)
    throw fail(std::to_string(bits) + "-bit samples in a layout that is not read (photometric " +
               std::to_string(photometric) + ", " + std::to_string(samples) + " samples, planar " +
               std::to_string(planar) + "); save it as 8-bit, or as contiguous grey or RGB");
  // Anything else of up to 8 bits (palette, bilevel, CMYK, YCbCr, separate planes): libtiff's RGBA.
  raw.create(int(h), int(w), CV_8UC4);
  if (!TIFFReadRGBAImageOriented(tif.get(), w, h, reinterpret_cast<uint32_t*>(raw.data), ORIENTATION_TOPLEFT, 0))
    throw fail("unsupported layout");
  uint16_t extra = 0, *kinds = nullptr;
  TIFFGetFieldDefaulted(tif.get(), TIFFTAG_EXTRASAMPLES, &extra, &kinds);
  cv::cvtColor(raw, raw, extra > 0 ? cv::COLOR_RGBA2BGRA : cv::COLOR_RGBA2BGR);
  return orient(raw, orientation);
}

// ---- Encoding ----

struct PngSink {
  std::vector<unsigned char>* bytes;
  char error[kPngErrorSize] = "";
};

void pngWrite(png_structp png, png_bytep data, size_t n) {
  auto* sink = static_cast<PngSink*>(png_get_io_ptr(png));
  sink->bytes->insert(sink->bytes->end(), data, data + n);
}
void pngFlush(png_structp) {}

bool writePngRows(PngSink& sink, png_bytepp rows, int width, int height, int channels, int bits, int level, bool bgr) {
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, sink.error, pngFail, pngWarn);
  if (!png) return false;
  png_infop info = png_create_info_struct(png);
  if (!info || setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    return false;
  }
  png_set_write_fn(png, &sink, pngWrite, pngFlush);
  png_set_compression_level(png, level);
  if (level <= 1) png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_SUB);
  if (level <= 3) png_set_compression_strategy(png, 3 /* Z_RLE */);
  const int type = channels == 1   ? PNG_COLOR_TYPE_GRAY
                   : channels == 2 ? PNG_COLOR_TYPE_GRAY_ALPHA
                   : channels == 3 ? PNG_COLOR_TYPE_RGB
                                   : PNG_COLOR_TYPE_RGBA;
  png_set_IHDR(png, info, png_uint_32(width), png_uint_32(height), bits, type, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  if (bgr && channels >= 3) png_set_bgr(png);
  if (bits == 16) png_set_swap(png);  // native little-endian samples; PNG stores them big-endian
  png_write_image(png, rows);
  png_write_end(png, info);
  png_destroy_write_struct(&png, &info);
  return true;
}

}  // namespace

void checkImageHeader(const ImageHeader& header, const std::string& where) {
  TM_CHECK(header.format != ImageFormat::Unknown,
           located(where, "not a PNG, JPEG, TIFF or BMP image (unknown file signature)"));
  if (header.size) checkSize(*header.size, where);
}

namespace {

// Pixels in the colour space an embedded ICC profile describes, to sRGB (relative colorimetric with black point
// compensation, Little CMS): what every stage assumes photos are. Only RGB profiles on 8- and 16-bit B,G,R(,A)
// pixels, alpha kept; a profile that names itself sRGB is left alone (the pixels are what it says), and so is one
// Little CMS cannot read (the pixels as stored).
void convertToSrgb(cv::Mat& image, const std::vector<uint8_t>& icc) {
  const int depth = image.depth(), channels = image.channels();
  if ((depth != CV_8U && depth != CV_16U) || (channels != 3 && channels != 4)) return;
  std::unique_ptr<void, decltype(&cmsCloseProfile)> from(cmsOpenProfileFromMem(icc.data(), cmsUInt32Number(icc.size())),
                                                         &cmsCloseProfile);
  if (!from || cmsGetColorSpace(from.get()) != cmsSigRgbData) return;
  char name[256] = {};
  cmsGetProfileInfoASCII(from.get(), cmsInfoDescription, "en", "US", name, sizeof name);
  if (std::strstr(name, "sRGB")) return;
  std::unique_ptr<void, decltype(&cmsCloseProfile)> to(cmsCreate_sRGBProfile(), &cmsCloseProfile);
  const cmsUInt32Number format =
      depth == CV_8U ? (channels == 3 ? TYPE_BGR_8 : TYPE_BGRA_8) : (channels == 3 ? TYPE_BGR_16 : TYPE_BGRA_16);
  cmsHTRANSFORM transform = cmsCreateTransform(from.get(), format, to.get(), format, INTENT_RELATIVE_COLORIMETRIC,
                                               cmsFLAGS_BLACKPOINTCOMPENSATION | cmsFLAGS_COPY_ALPHA);
  if (!transform) return;
  for (int y = 0; y < image.rows; ++y)
    cmsDoTransform(transform, image.ptr(y), image.ptr(y), cmsUInt32Number(image.cols));
  cmsDeleteTransform(transform);
}

// stb_image reads zeros past the end of a BMP: a file shorter than its header's rows is refused first.
cv::Mat decode(const Encoded& in, const ImageHeader& header, const std::string& where) {
  TM_CHECK(in.size >= header.minBytes,
           located(where, "cannot decode the image: the data ends early (truncated file: " + std::to_string(in.size) +
                              " bytes, its header needs " + std::to_string(header.minBytes) + ")"));
  cv::Mat image;
  std::vector<uint8_t> icc;
  switch (header.format) {
    case ImageFormat::Png:
      image = decodePng(in, where, icc);
      break;
    case ImageFormat::Jpeg:
      image = decodeJpeg(in, where, icc);
      break;
    case ImageFormat::Bmp:
      image = decodeBmp(in, where);
      break;
    default:
      image = decodeTiff(in, where, icc);
      break;
  }
  checkSize(image.size(), where);
  if (!icc.empty()) convertToSrgb(image, icc);
  return image;
}

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};

}  // namespace

cv::Mat decodeImage(const unsigned char* bytes, size_t size, const std::string& where) {
  const ImageHeader header = readImageHeader(bytes, size);
  checkImageHeader(header, where);
  TM_CHECK(size <= size_t(INT32_MAX), located(where, "image data is larger than 2 GB"));
  Encoded in;
  in.data = bytes, in.size = size;
  return decode(in, header, where);
}

cv::Mat readImageFile(const std::string& path) {
  requireRegularFile(path, "image file");
  const ImageHeader header = readImageFileHeader(path);
  // A file of another format named as such (.webp, .exr...): say which formats are read.
  const std::string ext = lowerExtension(path);
  TM_CHECK(header.format != ImageFormat::Unknown || isImageExtension(ext), located(path, unsupportedPhotoFormat(ext)));
  checkImageHeader(header, path);
  const std::unique_ptr<std::FILE, FileCloser> file(std::fopen(path.c_str(), "rb"));
  TM_CHECK(file != nullptr, located(path, "cannot open the image file: " + std::string(std::strerror(errno))));
  Encoded in;
  in.file = file.get();
  TM_CHECK(fseeko(in.file, 0, SEEK_END) == 0, located(path, "cannot read the image file"));
  in.size = size_t(ftello(in.file));
  std::rewind(in.file);
  return decode(in, header, path);
}

std::vector<unsigned char> encodePng(const cv::Mat& image, const std::string& where, int level, bool bgr) {
  const int channels = image.channels(), bits = image.depth() == CV_8U ? 8 : image.depth() == CV_16U ? 16 : 0;
  TM_CHECK(bits > 0 && channels >= 1 && channels <= 4 && !image.empty(),
           located(where, "cannot encode PNG: expected an 8- or 16-bit image with 1 to 4 channels"));
  std::vector<png_bytep> rows(image.rows);
  for (int y = 0; y < image.rows; ++y) rows[y] = const_cast<png_bytep>(image.ptr(y));
  std::vector<unsigned char> bytes;
  bytes.reserve(size_t(image.total() * image.elemSize() / 4));
  PngSink sink{&bytes};
  TM_CHECK(writePngRows(sink, rows.data(), image.cols, image.rows, channels, bits, std::clamp(level, 0, 9), bgr),
           located(where, std::string("cannot encode PNG: ") + (*sink.error ? sink.error : "out of memory")));
  return bytes;
}

void writePng(const std::string& path, const cv::Mat& image, int level, bool bgr) {
  const std::vector<unsigned char> bytes = encodePng(image, path, level, bgr);
  writeFileAtomic(path, std::string(bytes.begin(), bytes.end()));
}

}  // namespace montage
