// Mesh file readers (OBJ, OFF, PLY, STL) that fill one triangle soup, turned into a mesh by buildMesh(),
// and the OBJ writer.
#include "io/mesh_io.h"

#include <assimp/config.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <assimp/Importer.hpp>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string_view>
#include <unordered_map>

#include "base/fileio.h"
#include "base/isolate.h"
#include "io/assimp_gltf.h"
#include "io/gltf_document.h"
#include "io/model.h"

namespace montage {

namespace {

[[noreturn]] void failAt(const std::string& file, int line, const std::string& why) {
  throw Error(located(line > 0 ? file + ":" + std::to_string(line) : file, why));
}

std::string quote(std::string_view s) {
  return "'" + std::string(s.substr(0, 40)) + (s.size() > 40 ? "...'" : "'");
}

bool iequals(std::string_view a, std::string_view b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           return std::tolower(static_cast<unsigned char>(x)) == std::tolower(static_cast<unsigned char>(y));
         });
}

bool isBlank(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v';
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && isBlank(s.front())) s.remove_prefix(1);
  while (!s.empty() && isBlank(s.back())) s.remove_suffix(1);
  return s;
}

// Splits the next blank-separated token off `rest`; false when none is left.
bool splitToken(std::string_view& rest, std::string_view& token) {
  size_t b = 0;
  while (b < rest.size() && isBlank(rest[b])) ++b;
  if (b == rest.size()) {
    rest = {};
    return false;
  }
  size_t e = b;
  while (e < rest.size() && !isBlank(rest[e])) ++e;
  token = rest.substr(b, e - b);
  rest.remove_prefix(e);
  return true;
}

// Whole-token number parsing, locale independent. Out-of-range doubles become inf or 0 like strtod.
bool parseDouble(std::string_view s, double& out) {
  const char* b = s.data();
  const char* e = b + s.size();
  if (b != e && *b == '+') ++b;
  const auto r = std::from_chars(b, e, out);
  if (r.ec == std::errc::result_out_of_range && r.ptr == e) {
    out = std::strtod(std::string(s).c_str(), nullptr);
    return true;
  }
  return r.ec == std::errc() && r.ptr == e;
}

bool parseInt(std::string_view s, long long& out) {
  const char* b = s.data();
  const char* e = b + s.size();
  if (b != e && *b == '+') ++b;
  const auto r = std::from_chars(b, e, out);
  return r.ec == std::errc() && r.ptr == e && b != e;
}

// Lines of a text buffer (LF or CRLF) with '#' comments stripped and, for OBJ, lines ending in a
// backslash joined; tokens are read from the current line or across lines. Errors name file and line.
class Tokens {
 public:
  Tokens(const std::string& data, std::string file, bool comments, bool continuation)
      : p_(data.data()),
        end_(data.data() + data.size()),
        file_(std::move(file)),
        comments_(comments),
        continuation_(continuation) {}

  int line() const { return line_; }
  // Byte offset of the next unread line in the buffer.
  size_t consumed(const std::string& data) const { return static_cast<size_t>(p_ - data.data()); }
  [[noreturn]] void fail(const std::string& why) const { failAt(file_, line_, why); }

  // Moves to the next line; false at end of file.
  bool nextLine() {
    if (p_ == end_) return false;
    line_ = ++physical_;
    std::string_view l = physicalLine();
    if (continuation_ && endsWithBackslash(l)) {
      joined_.clear();
      for (;;) {
        const std::string_view t = trim(l);
        const bool more = endsWithBackslash(l);
        joined_.append(l.data(), more ? t.data() + t.size() - 1 - l.data() : l.size());  // drop the backslash
        joined_ += ' ';
        if (!more || p_ == end_) break;
        l = physicalLine();
        ++physical_;
      }
      l = joined_;
    }
    if (comments_) l = l.substr(0, l.find('#'));
    rest_ = l;
    return true;
  }

  // Next token of the current line; false when the line is exhausted.
  bool onLine(std::string_view& token) { return splitToken(rest_, token); }
  // Next token, moving on to the following lines as needed; false at end of file.
  bool next(std::string_view& token) {
    while (!splitToken(rest_, token))
      if (!nextLine()) return false;
    return true;
  }
  // The rest of the current line, trimmed; the line is then exhausted.
  std::string_view restOfLine() {
    const std::string_view r = trim(rest_);
    rest_ = {};
    return r;
  }

  // Required values; `sameLine` false lets them continue on the next lines.
  std::string_view need(const char* what, bool sameLine = true) {
    std::string_view t;
    if (!(sameLine ? onLine(t) : next(t)))
      fail(std::string(sameLine ? "missing " : "unexpected end of file: missing ") + what);
    return t;
  }
  double number(const char* what, bool sameLine = true) {
    const std::string_view t = need(what, sameLine);
    double v;
    if (!parseDouble(t, v)) fail(std::string("expected a number for ") + what + ", got " + quote(t));
    return v;
  }
  long long integer(const char* what, bool sameLine = true) {
    const std::string_view t = need(what, sameLine);
    long long v;
    if (!parseInt(t, v)) fail(std::string("expected an integer for ") + what + ", got " + quote(t));
    return v;
  }

 private:
  std::string_view physicalLine() {
    const char* b = p_;
    const char* nl = static_cast<const char*>(std::memchr(b, '\n', end_ - b));
    const char* e = nl ? nl : end_;
    p_ = nl ? nl + 1 : end_;
    if (e > b && e[-1] == '\r') --e;
    return {b, static_cast<size_t>(e - b)};
  }
  static bool endsWithBackslash(std::string_view l) {
    l = trim(l);
    return !l.empty() && l.back() == '\\';
  }

  const char* p_;
  const char* end_;
  std::string file_;
  bool comments_, continuation_;
  int line_ = 0, physical_ = 0;
  std::string_view rest_;
  std::string joined_;
};

// A per-face name index (OBJ usemtl, g, o), recorded once the first name appears; faces before it get
// the name `unnamed`.
struct FaceLabels {
  std::vector<std::string> names;
  std::vector<int> ids;  // per triangle, empty while no name was set
  std::unordered_map<std::string, int> index;
  int current = -1;

  void set(std::string_view name, size_t facesSoFar, const char* unnamed) {
    if (current < 0 && facesSoFar > 0) {
      ids.assign(facesSoFar, lookup(unnamed));
    }
    current = lookup(std::string(name));
  }
  void tag(int triangles) {
    if (current >= 0) ids.insert(ids.end(), triangles, current);
  }

 private:
  int lookup(const std::string& name) {
    const auto it = index.emplace(name, static_cast<int>(names.size())).first;
    if (it->second == static_cast<int>(names.size())) names.push_back(name);
    return it->second;
  }
};

// What every reader produces: positions and fan-triangulated faces, with optional texture coordinates
// (by index, -1 = none) and OBJ labels, plus where each triangle came from for error messages.
struct Soup {
  std::string file;
  bool binary = false;  // `source` holds polygon numbers instead of line numbers
  int indexBase = 0;    // 1 for OBJ: indices are shown as written in the file
  std::vector<Vec3> positions;
  std::vector<Vec2> texcoords;
  std::vector<std::array<int, 3>> triangles;
  bool hasUV = false;                       // some face has texture coordinates
  std::vector<std::array<int, 3>> uvIndex;  // per triangle, when hasUV
  std::vector<int> source;                  // per triangle: line (text) or polygon number (binary)
  std::vector<Vec3> normals;
  bool hasNormals = false;                      // some face has normals
  std::vector<std::array<int, 3>> normalIndex;  // per triangle, when hasNormals (-1: none)
  FaceLabels material, group, object;
  std::string mtllib;
  std::vector<MeshFinding> notes;  // reader warnings, appended to the report

  // Adds a polygon of n corners as a fan of n-2 triangles; `uv` and `normal` (indices per corner) may be null.
  void addPolygon(const int* v, const int* uv, int n, int where, const int* normal = nullptr) {
    if (n < 3) fail(where, "a face needs at least 3 vertices, this one has " + std::to_string(n));
    if (uv && !hasUV) uvIndex.assign(triangles.size(), {-1, -1, -1});
    hasUV |= uv != nullptr;
    if (normal && !hasNormals) normalIndex.assign(triangles.size(), {-1, -1, -1});
    hasNormals |= normal != nullptr;
    for (int k = 1; k + 1 < n; ++k) {
      triangles.push_back({v[0], v[k], v[k + 1]});
      if (hasUV) uvIndex.push_back(uv ? std::array<int, 3>{uv[0], uv[k], uv[k + 1]} : std::array<int, 3>{-1, -1, -1});
      if (hasNormals)
        normalIndex.push_back(normal ? std::array<int, 3>{normal[0], normal[k], normal[k + 1]}
                                     : std::array<int, 3>{-1, -1, -1});
      source.push_back(where);
    }
    material.tag(n - 2);
    group.tag(n - 2);
    object.tag(n - 2);
  }

  // Checks every index and returns the corner UVs (empty when the file has none).
  std::vector<std::array<Vec2, 3>> finish() {
    const int nv = static_cast<int>(positions.size()), nuv = static_cast<int>(texcoords.size());
    std::vector<std::array<Vec2, 3>> uv(hasUV ? triangles.size() : 0);
    int missing = 0;
    for (size_t t = 0; t < triangles.size(); ++t)
      for (int k = 0; k < 3; ++k) {
        const int v = triangles[t][k];
        if (v < 0 || v >= nv)
          fail(source[t],
               "face index " + std::to_string(v + indexBase) + " out of range (" + std::to_string(nv) + " vertices)");
        if (!hasUV) continue;
        const int i = uvIndex[t][k];
        if (i >= nuv)
          fail(source[t], "texture coordinate index " + std::to_string(i + indexBase) + " out of range (" +
                              std::to_string(nuv) + " texture coordinates)");
        uv[t][k] = i >= 0 ? texcoords[i] : Vec2::Zero();
        missing += i < 0 && k == 0;
      }
    if (missing > 0)
      notes.push_back({MeshFinding::Severity::Warning,
                       std::to_string(missing) + " faces have no texture coordinates (set to 0,0)",
                       {},
                       missing});
    return uv;
  }

  // The corner normals (unit length; empty when the file has none, or when some face has none: the export then
  // computes them all). Checks every normal index.
  std::vector<std::array<Vec3, 3>> cornerNormals() const {
    if (!hasNormals) return {};
    const int nn = static_cast<int>(normals.size());
    std::vector<std::array<Vec3, 3>> out(triangles.size());
    for (size_t t = 0; t < triangles.size(); ++t)
      for (int k = 0; k < 3; ++k) {
        const int i = normalIndex[t][k];
        if (i < 0) return {};
        if (i >= nn)
          fail(source[t],
               "normal index " + std::to_string(i + indexBase) + " out of range (" + std::to_string(nn) + " normals)");
        const double len = normals[i].norm();
        out[t][k] = len > 0 && std::isfinite(len) ? Vec3(normals[i] / len) : Vec3::Zero();
      }
    return out;
  }

  // Per triangle, the index of the polygon it was cut from (consecutive triangles from one face of the file);
  // empty when every face was a triangle.
  std::vector<int> polygons() const {
    std::vector<int> out(triangles.size());
    int p = -1;
    for (size_t t = 0; t < triangles.size(); ++t) out[t] = t == 0 || source[t] != source[t - 1] ? ++p : p;
    return p + 1 == static_cast<int>(triangles.size()) ? std::vector<int>{} : out;
  }

 private:
  [[noreturn]] void fail(int where, const std::string& why) const {
    if (binary) failAt(file, 0, "face " + std::to_string(where) + ": " + why);
    failAt(file, where, why);
  }
};

// ---- OBJ -------------------------------------------------------------------------------------------------

void readObj(const std::string& data, Soup& soup) {
  Tokens in(data, soup.file, true, true);
  soup.indexBase = 1;
  std::vector<int> v, vt, vn;
  std::string_view keyword, token;
  int unknown = 0;
  std::string firstUnknown;

  // 1-based or negative (relative) OBJ index to 0-based; range is checked in Soup::finish (forward use).
  auto index = [&](std::string_view s, size_t count, const char* what) {
    long long i;
    if (!parseInt(s, i)) in.fail("bad face corner " + quote(token) + " (expected v, v/vt, v//vn or v/vt/vn)");
    if (i == 0) in.fail(std::string(what) + " index 0 is invalid (OBJ indices start at 1)");
    if (i < 0 && i < -static_cast<long long>(count))  // not -i: -LLONG_MIN overflows
      in.fail(std::string(what) + " index " + std::to_string(i) + " out of range (" + std::to_string(count) +
              " defined before this line)");
    if (i > INT_MAX) in.fail(std::string(what) + " index " + std::to_string(i) + " out of range");
    return static_cast<int>(i < 0 ? static_cast<long long>(count) + i : i - 1);
  };

  while (in.nextLine()) {
    if (!in.onLine(keyword)) continue;
    if (keyword == "v") {
      const double x = in.number("x coordinate"), y = in.number("y coordinate"), z = in.number("z coordinate");
      soup.positions.emplace_back(x, y, z);
    } else if (keyword == "vn") {
      const double x = in.number("normal x"), y = in.number("normal y"), z = in.number("normal z");
      soup.normals.emplace_back(x, y, z);
    } else if (keyword == "vt") {
      const double u = in.number("u coordinate");
      double w = 0;
      if (in.onLine(token) && !parseDouble(token, w))
        in.fail("expected a number for v coordinate, got " + quote(token));
      soup.texcoords.emplace_back(u, w);
    } else if (keyword == "f") {
      v.clear();
      vt.clear();
      vn.clear();
      while (in.onLine(token)) {
        const size_t s1 = token.find('/');
        v.push_back(index(token.substr(0, s1), soup.positions.size(), "face"));
        if (s1 == std::string_view::npos) continue;
        const size_t s2 = token.find('/', s1 + 1);
        const std::string_view t = token.substr(s1 + 1, s2 - s1 - 1);
        if (!t.empty()) vt.push_back(index(t, soup.texcoords.size(), "texture coordinate"));
        if (s2 != std::string_view::npos && s2 + 1 < token.size())
          vn.push_back(index(token.substr(s2 + 1), soup.normals.size(), "normal"));
      }
      if (!vt.empty() && vt.size() != v.size()) in.fail("face gives texture coordinates for some corners only");
      const bool normals = !vn.empty() && vn.size() == v.size();  // normals on some corners only: none
      soup.addPolygon(v.data(), vt.empty() ? nullptr : vt.data(), static_cast<int>(v.size()), in.line(),
                      normals ? vn.data() : nullptr);
    } else if (keyword == "usemtl") {
      soup.material.set(in.restOfLine(), soup.triangles.size(), "");
    } else if (keyword == "g" || keyword == "o") {
      const std::string_view name = in.restOfLine();
      (keyword == "g" ? soup.group : soup.object)
          .set(name.empty() ? "default" : name, soup.triangles.size(), "default");
    } else if (keyword == "mtllib") {
      if (soup.mtllib.empty()) soup.mtllib = in.restOfLine();
    } else if (std::any_of(keyword.begin(), keyword.end(), [](char c) { return c < 0x20 || c > 0x7e; })) {
      in.fail("unexpected binary data (not an OBJ text file?)");
    } else {
      static const char* known[] = {"vp",    "s",          "l",        "p",        "cstype", "deg",    "bmat",
                                    "step",  "curv",       "curv2",    "surf",     "parm",   "trim",   "hole",
                                    "scrv",  "sp",         "end",      "con",      "mg",     "bevel",  "lod",
                                    "call",  "csh",        "c_interp", "d_interp", "usemap", "maplib", "ctech",
                                    "stech", "shadow_obj", "trace_obj"};
      const bool isKnown = std::any_of(std::begin(known), std::end(known), [&](const char* k) { return keyword == k; });
      if (!isKnown && unknown++ == 0) firstUnknown = "line " + std::to_string(in.line()) + ": " + quote(keyword);
    }
  }
  if (soup.group.names.empty()) soup.group = std::move(soup.object);
  if (unknown > 0)
    soup.notes.push_back(
        {MeshFinding::Severity::Warning,
         std::to_string(unknown) + " lines with unknown statements ignored (first at " + firstUnknown + ")",
         {},
         unknown});
}

// ---- OFF -------------------------------------------------------------------------------------------------

void readOff(const std::string& data, Soup& soup) {
  Tokens in(data, soup.file, true, false);
  std::string_view token;
  if (!in.next(token)) in.fail("empty file (expected an OFF header)");
  // [ST][C][N]OFF; the 4 / n (dimension) variants and binary OFF are not supported.
  const std::string_view prefix = token.substr(0, token.size() >= 3 ? token.size() - 3 : 0);
  if (token.size() < 3 || token.substr(token.size() - 3) != "OFF" ||
      prefix.find_first_not_of("STCN") != std::string_view::npos)
    in.fail("not an OFF file: expected 'OFF' header, got " + quote(token));
  std::string_view rest = in.restOfLine(), counts[3];
  if (!rest.empty() && rest.substr(0, 6) == "BINARY") in.fail("binary OFF is not supported");
  int numCounts = 0;
  while (numCounts < 3 && splitToken(rest, counts[numCounts])) ++numCounts;
  long long nv, nf;
  if (numCounts > 0) {  // counts on the header line
    if (numCounts < 2 || !parseInt(counts[0], nv) || !parseInt(counts[1], nf))
      in.fail("bad vertex/face counts after OFF");
  } else {
    nv = in.integer("vertex count", false);
    nf = in.integer("face count", false);
    in.restOfLine();  // edge count
  }
  if (nv < 0 || nf < 0 || nv > INT_MAX || nf > INT_MAX) in.fail("bad vertex/face counts");
  // Declared counts against the bytes left: a vertex takes at least 6 ("0 0 0\n"), a face 8 ("3 0 1 2\n").
  const size_t left = data.size() - in.consumed(data);
  if (static_cast<unsigned long long>(nv) * 6 + static_cast<unsigned long long>(nf) * 8 > left + 1)
    in.fail("the header declares " + std::to_string(nv) + " vertices and " + std::to_string(nf) + " faces, but only " +
            std::to_string(left) + " bytes follow (at least 6 per vertex and 8 per face)");

  auto dataLine = [&](const char* what) {
    do
      if (!in.nextLine()) in.fail(std::string("unexpected end of file: missing ") + what);
    while (!in.onLine(token));
  };
  soup.positions.reserve(std::min<long long>(nv, data.size() / 6));
  for (long long i = 0; i < nv; ++i) {
    dataLine("vertex");
    double x;
    if (!parseDouble(token, x)) in.fail("expected a number for x coordinate, got " + quote(token));
    const double y = in.number("y coordinate"), z = in.number("z coordinate");
    soup.positions.emplace_back(x, y, z);
  }
  std::vector<int> poly;
  for (long long i = 0; i < nf; ++i) {
    dataLine("face");
    long long n;
    if (!parseInt(token, n) || n < 0 || n > 1000000) in.fail("bad face vertex count " + quote(token));
    poly.resize(n);
    for (auto& v : poly) {
      const long long idx = in.integer("face vertex index");
      if (idx < 0 || idx > INT_MAX) in.fail("face index " + std::to_string(idx) + " out of range");
      v = static_cast<int>(idx);
    }
    soup.addPolygon(poly.data(), nullptr, static_cast<int>(n), in.line());
  }
}

// ---- PLY -------------------------------------------------------------------------------------------------

enum class PlyType { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64 };

bool plyType(std::string_view name, PlyType& type) {
  static const std::pair<const char*, PlyType> names[] = {
      {"char", PlyType::Int8},      {"int8", PlyType::Int8},       {"uchar", PlyType::UInt8},
      {"uint8", PlyType::UInt8},    {"short", PlyType::Int16},     {"int16", PlyType::Int16},
      {"ushort", PlyType::UInt16},  {"uint16", PlyType::UInt16},   {"int", PlyType::Int32},
      {"int32", PlyType::Int32},    {"uint", PlyType::UInt32},     {"uint32", PlyType::UInt32},
      {"float", PlyType::Float32},  {"float32", PlyType::Float32}, {"double", PlyType::Float64},
      {"float64", PlyType::Float64}};
  for (const auto& [n, t] : names)
    if (name == n) return type = t, true;
  return false;
}

// Bytes of one binary value.
size_t plySize(PlyType type) {
  switch (type) {
    case PlyType::Int8:
    case PlyType::UInt8:
      return 1;
    case PlyType::Int16:
    case PlyType::UInt16:
      return 2;
    case PlyType::Int32:
    case PlyType::UInt32:
    case PlyType::Float32:
      return 4;
    case PlyType::Float64:
      return 8;
  }
  return 1;
}

// Properties the reader keeps; everything else is read and skipped.
enum class PlyRole { Skip, X, Y, Z, U, V, NX, NY, NZ, Indices, TexCoords };

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::Float32;
  bool list = false;
  PlyType countType = PlyType::UInt8;
  PlyRole role = PlyRole::Skip;
};

struct PlyElement {
  std::string name;
  long long count = 0;
  std::vector<PlyProperty> properties;
};

// The element instance being read, named in error messages.
struct PlyCursor {
  const std::string* element = nullptr;
  long long index = 0;
  std::string where() const { return element ? "element '" + *element + "' " + std::to_string(index) + ": " : ""; }
};

// Values of an ascii PLY body.
struct PlyAsciiReader : PlyCursor {
  Tokens& in;
  explicit PlyAsciiReader(Tokens& tokens) : in(tokens) {}
  double value(PlyType, const char* what) { return in.number(what, false); }
  int line() const { return in.line(); }
  [[noreturn]] void fail(const std::string& why) const { in.fail(where() + why); }
};

// Values of a binary PLY body, either byte order.
struct PlyBinaryReader : PlyCursor {
  const char* p;
  const char* end;
  bool swap;
  const std::string& file;
  PlyBinaryReader(const char* begin, const char* stop, bool swapBytes, const std::string& name)
      : p(begin), end(stop), swap(swapBytes), file(name) {}

  template <class T>
  double get() {
    if (end - p < static_cast<std::ptrdiff_t>(sizeof(T))) fail("unexpected end of file");
    unsigned char bytes[sizeof(T)];
    std::memcpy(bytes, p, sizeof(T));
    p += sizeof(T);
    if (swap) std::reverse(bytes, bytes + sizeof(T));
    T v;
    std::memcpy(&v, bytes, sizeof(T));
    return static_cast<double>(v);
  }
  double value(PlyType type, const char*) {
    switch (type) {
      case PlyType::Int8:
        return get<int8_t>();
      case PlyType::UInt8:
        return get<uint8_t>();
      case PlyType::Int16:
        return get<int16_t>();
      case PlyType::UInt16:
        return get<uint16_t>();
      case PlyType::Int32:
        return get<int32_t>();
      case PlyType::UInt32:
        return get<uint32_t>();
      case PlyType::Float32:
        return get<float>();
      case PlyType::Float64:
        return get<double>();
    }
    return 0;
  }
  int line() const { return 0; }
  [[noreturn]] void fail(const std::string& why) const { failAt(file, 0, where() + why); }
};

template <class Reader>
void readPlyBody(Reader& in, const std::vector<PlyElement>& elements, bool vertexUV, bool faceUV, bool vertexNormals,
                 Soup& soup) {
  std::vector<int> poly, uvIndex;
  std::vector<double> values;
  for (const PlyElement& el : elements) {
    const bool isVertex = el.name == "vertex", isFace = el.name == "face";
    if (el.properties.empty()) continue;  // nothing to read, however many are declared
    for (long long i = 0; i < el.count; ++i) {
      in.element = &el.name;
      in.index = i;
      double coord[8] = {0, 0, 0, 0, 0, 0, 0, 0};  // x y z u v nx ny nz
      poly.clear();
      values.clear();
      for (const PlyProperty& p : el.properties) {
        if (!p.list) {
          const double v = in.value(p.type, p.name.c_str());
          if (p.role >= PlyRole::X && p.role <= PlyRole::NZ) coord[static_cast<int>(p.role) - 1] = v;
          continue;
        }
        const double n = in.value(p.countType, "list count");
        if (!(n >= 0 && n <= 1e6 && n == std::floor(n))) in.fail("bad list count for '" + p.name + "'");
        for (int k = 0; k < static_cast<int>(n); ++k) {
          const double v = in.value(p.type, p.name.c_str());
          if (p.role == PlyRole::Indices) {
            if (!(v >= 0 && v <= INT_MAX && v == std::floor(v))) in.fail("bad vertex index " + std::to_string(v));
            poly.push_back(static_cast<int>(v));
          } else if (p.role == PlyRole::TexCoords) {
            values.push_back(v);
          }
        }
      }
      if (isVertex) {
        soup.positions.emplace_back(coord[0], coord[1], coord[2]);
        if (vertexUV) soup.texcoords.emplace_back(coord[3], coord[4]);
        if (vertexNormals) soup.normals.emplace_back(coord[5], coord[6], coord[7]);
      } else if (isFace) {
        const int source = in.line() > 0 ? in.line() : static_cast<int>(i);
        const bool cornerUV = faceUV && !values.empty();  // an empty texcoord list: no UVs on this face
        if (cornerUV) {
          if (values.size() != 2 * poly.size())
            in.fail("texcoord list has " + std::to_string(values.size()) + " values for " +
                    std::to_string(poly.size()) + " corners");
          uvIndex.resize(poly.size());
          for (size_t k = 0; k < poly.size(); ++k) {
            uvIndex[k] = static_cast<int>(soup.texcoords.size());
            soup.texcoords.emplace_back(values[2 * k], values[2 * k + 1]);
          }
        }
        const int* uv = cornerUV ? uvIndex.data() : vertexUV ? poly.data() : nullptr;
        soup.addPolygon(poly.data(), uv, static_cast<int>(poly.size()), source, vertexNormals ? poly.data() : nullptr);
      }
    }
  }
}

void readPly(const std::string& data, Soup& soup) {
  Tokens in(data, soup.file, false, false);
  std::string_view token;
  if (!in.nextLine() || !in.onLine(token) || token != "ply") in.fail("not a PLY file (first line must be 'ply')");
  std::string format;
  std::vector<PlyElement> elements;
  for (;;) {
    if (!in.nextLine()) in.fail("unexpected end of file in the header (missing 'end_header')");
    if (!in.onLine(token) || token == "comment" || token == "obj_info") continue;
    if (token == "end_header") break;
    if (token == "format") {
      format = in.need("format name");
      if (format != "ascii" && format != "binary_little_endian" && format != "binary_big_endian")
        in.fail("unknown PLY format " + quote(format));
    } else if (token == "element") {
      PlyElement el;
      el.name = in.need("element name");
      el.count = in.integer("element count");
      if (el.count < 0 || el.count > INT_MAX) in.fail("bad element count");
      elements.push_back(el);
    } else if (token == "property") {
      if (elements.empty()) in.fail("property before any element");
      PlyElement& el = elements.back();
      PlyProperty p;
      std::string_view type = in.need("property type");
      if (type == "list") {
        p.list = true;
        const std::string_view count = in.need("list count type");
        if (!plyType(count, p.countType)) in.fail("unknown PLY type " + quote(count));
        type = in.need("list item type");
      }
      if (!plyType(type, p.type)) in.fail("unknown PLY type " + quote(type));
      p.name = in.need("property name");
      if (el.name == "vertex" && !p.list) {
        static const std::pair<const char*, PlyRole> roles[] = {
            {"x", PlyRole::X},         {"y", PlyRole::Y},         {"z", PlyRole::Z},         {"u", PlyRole::U},
            {"v", PlyRole::V},         {"s", PlyRole::U},         {"t", PlyRole::V},         {"texture_u", PlyRole::U},
            {"texture_v", PlyRole::V}, {"texture_s", PlyRole::U}, {"texture_t", PlyRole::V}, {"nx", PlyRole::NX},
            {"ny", PlyRole::NY},       {"nz", PlyRole::NZ}};
        for (const auto& [n, r] : roles)
          if (p.name == n) p.role = r;
      } else if (el.name == "face" && p.list) {
        if (p.name == "vertex_indices" || p.name == "vertex_index") p.role = PlyRole::Indices;
        if (p.name == "texcoord") p.role = PlyRole::TexCoords;
      }
      el.properties.push_back(p);
    } else {
      in.fail("unexpected header line starting with " + quote(token));
    }
  }
  if (format.empty()) in.fail("missing 'format' line in the header");

  // Requirements: x, y, z on vertices, a vertex index list on faces; both u and v for vertex UVs.
  for (PlyElement& el : elements) {
    auto has = [&](PlyRole r) {
      return std::any_of(el.properties.begin(), el.properties.end(), [&](const PlyProperty& p) { return p.role == r; });
    };
    if (el.name == "vertex" && !(has(PlyRole::X) && has(PlyRole::Y) && has(PlyRole::Z)))
      in.fail("vertex element lacks an x, y or z property");
    if (el.name == "face" && !has(PlyRole::Indices)) in.fail("face element lacks a 'vertex_indices' list property");
    if (el.name == "vertex" && !(has(PlyRole::U) && has(PlyRole::V)))
      for (auto& p : el.properties)
        if (p.role == PlyRole::U || p.role == PlyRole::V) p.role = PlyRole::Skip;
    if (el.name == "vertex" && !(has(PlyRole::NX) && has(PlyRole::NY) && has(PlyRole::NZ)))
      for (auto& p : el.properties)
        if (p.role >= PlyRole::NX && p.role <= PlyRole::NZ) p.role = PlyRole::Skip;
  }
  // Texture coordinates: the face texcoord lists, else the vertex u and v.
  auto anyRole = [&](PlyRole r) {
    return std::any_of(elements.begin(), elements.end(), [&](const PlyElement& el) {
      return std::any_of(el.properties.begin(), el.properties.end(), [&](const PlyProperty& p) { return p.role == r; });
    });
  };
  const bool faceUV = anyRole(PlyRole::TexCoords), vertexUV = !faceUV && anyRole(PlyRole::U),
             vertexNormals = anyRole(PlyRole::NX);
  for (PlyElement& el : elements)
    for (auto& p : el.properties)
      if (faceUV && (p.role == PlyRole::U || p.role == PlyRole::V)) p.role = PlyRole::Skip;

  // Declared counts against the bytes left, so that a tiny file cannot announce billions of elements:
  // a binary value takes its size (a list at least its count), an ascii value at least a digit and a
  // separator.
  const size_t left = data.size() - in.consumed(data);
  unsigned long long needed = 0;
  for (const PlyElement& el : elements) {
    unsigned long long each = 0;
    for (const PlyProperty& p : el.properties) each += format == "ascii" ? 2 : plySize(p.list ? p.countType : p.type);
    needed += each * static_cast<unsigned long long>(el.count);
    if (needed > left + 1)
      in.fail("element '" + el.name + "' declares " + std::to_string(el.count) + " instances of at least " +
              std::to_string(each) + " bytes, but only " + std::to_string(left) + " bytes follow the header" +
              (&el == &elements.front() ? "" : " (with the elements before it)"));
  }

  if (format == "ascii") {
    PlyAsciiReader reader(in);
    readPlyBody(reader, elements, vertexUV, faceUV, vertexNormals, soup);
  } else {
    soup.binary = true;
    const size_t offset = in.consumed(data);
    const bool bigEndianHost = [] {
      const uint16_t one = 1;
      unsigned char b;
      std::memcpy(&b, &one, 1);
      return b == 0;
    }();
    PlyBinaryReader reader(data.data() + offset, data.data() + data.size(),
                           (format == "binary_big_endian") != bigEndianHost, soup.file);
    readPlyBody(reader, elements, vertexUV, faceUV, vertexNormals, soup);
  }
}

// ---- STL -------------------------------------------------------------------------------------------------

void readStlBinary(const std::string& data, Soup& soup, uint32_t count) {
  soup.binary = true;
  soup.positions.reserve(3 * size_t(count));
  const char* p = data.data() + 84;
  for (uint32_t t = 0; t < count; ++t, p += 50) {
    float f[12];  // normal, then three corners; little endian
    std::memcpy(f, p, sizeof f);
    const int base = static_cast<int>(soup.positions.size());
    for (int k = 1; k < 4; ++k) soup.positions.emplace_back(f[3 * k], f[3 * k + 1], f[3 * k + 2]);
    const int v[3] = {base, base + 1, base + 2};
    soup.addPolygon(v, nullptr, 3, static_cast<int>(t));
  }
}

void readStlAscii(const std::string& data, Soup& soup) {
  Tokens in(data, soup.file, false, false);
  std::string_view token;
  auto expect = [&](const char* word) {
    const std::string_view t = in.need(word, false);
    if (!iequals(t, word)) in.fail(std::string("expected '") + word + "', got " + quote(t));
  };
  std::vector<int> poly;
  while (in.next(token)) {
    if (iequals(token, "solid") || iequals(token, "endsolid")) {
      in.restOfLine();  // solid name
    } else if (iequals(token, "facet")) {
      in.restOfLine();  // normal
      expect("outer");
      expect("loop");
      poly.clear();
      while (!iequals(token = in.need("'vertex' or 'endloop'", false), "endloop")) {
        if (!iequals(token, "vertex")) in.fail("expected 'vertex' or 'endloop', got " + quote(token));
        const double x = in.number("x coordinate"), y = in.number("y coordinate"), z = in.number("z coordinate");
        poly.push_back(static_cast<int>(soup.positions.size()));
        soup.positions.emplace_back(x, y, z);
      }
      expect("endfacet");
      soup.addPolygon(poly.data(), nullptr, static_cast<int>(poly.size()), in.line());
    } else {
      in.fail("expected 'facet' or 'endsolid', got " + quote(token));
    }
  }
}

void readStl(const std::string& data, Soup& soup) {
  uint32_t count = 0;
  if (data.size() >= 84) std::memcpy(&count, data.data() + 80, 4);  // little-endian hosts only
  const size_t expected = 84 + 50 * size_t(count);
  // Text that starts with "solid" (binary files may too, but they contain zero bytes).
  const size_t start = data.find_first_not_of(" \t\r\n");
  const bool ascii = start != std::string::npos && iequals(std::string_view(data).substr(start, 5), "solid") &&
                     data.find('\0') == std::string::npos;
  if (ascii) return readStlAscii(data, soup);
  if (data.size() >= 84 && data.size() == expected) return readStlBinary(data, soup, count);
  if (data.size() < 84) failAt(soup.file, 0, "not an STL file (too short for binary STL, and not 'solid ...' text)");
  failAt(soup.file, 0,
         "binary STL header says " + std::to_string(count) + " triangles (" + std::to_string(expected) +
             " bytes) but the file has " + std::to_string(data.size()) + " bytes");
}

// ---- FBX, Collada, 3DS and 3MF, through Assimp --------------------------------------------------------

// Every mesh of the scene in world space (its nodes' transforms applied), polygons kept as polygons and fanned
// as OBJ's are, the first UV set, faces labelled by their material's and their mesh's names. Assimp gives each
// corner its own vertex where attributes differ; the caller welds identical positions, as for STL. Points and
// lines are skipped with a warning. A scene with skins, morph targets, a second UV set or vertex colours is given as
// a GLB instead (`asGlb`, io/assimp_gltf.h), so that the export carries them.
void readAssimpHere(const std::string& data, Soup& soup, const char* format, const char* name, std::string& asGlb) {
  Assimp::Importer importer;
  importer.SetPropertyBool(AI_CONFIG_IMPORT_FBX_PRESERVE_PIVOTS, false);  // no "$AssimpFbx$" helper nodes
  const aiScene* scene = importer.ReadFileFromMemory(data.data(), data.size(), aiProcess_ValidateDataStructure, format);
  const auto fail = [&] {
    // Assimp names a file read from memory "$$$___magic___$$$.<format>": name the user's instead.
    std::string why = importer.GetErrorString();
    const std::string magic = std::string("$$$___magic___$$$.") + format;
    for (size_t at; (at = why.find(magic)) != std::string::npos;)
      why.replace(at, magic.size(), std::filesystem::path(soup.file).filename().string());
    if (why == "std::bad_alloc") why = "it asks for more memory than a mesh of its size needs (damaged?)";
    failAt(soup.file, 0,
           "cannot read as " + std::string(name) + (why.empty() ? std::string(" (no reason given)") : ": " + why));
  };
  if (!scene) fail();
  if (!scene->HasMeshes()) failAt(soup.file, 0, "the " + std::string(name) + " file holds no mesh");
  if (gltf::assimpSceneNeedsGltf(*scene)) {
    scene = importer.ApplyPostProcessing(aiProcess_Triangulate | aiProcess_JoinIdenticalVertices |
                                         aiProcess_LimitBoneWeights | aiProcess_SortByPType);
    if (!scene) fail();
    try {
      asGlb = gltf::assimpSceneAsGlb(*scene);
    } catch (const Error& e) {
      failAt(soup.file, 0, e.what());
    }
    return;
  }
  scene = importer.ApplyPostProcessing(aiProcess_PreTransformVertices);
  if (!scene) fail();
  soup.binary = true;  // messages name the polygon, counted over the whole scene
  int points = 0, polygon = 0;
  for (unsigned i = 0; i < scene->mNumMeshes; ++i) {
    const aiMesh& m = *scene->mMeshes[i];
    const int base = static_cast<int>(soup.positions.size()), uvBase = static_cast<int>(soup.texcoords.size()),
              normalBase = static_cast<int>(soup.normals.size());
    for (unsigned v = 0; v < m.mNumVertices; ++v)
      soup.positions.emplace_back(m.mVertices[v].x, m.mVertices[v].y, m.mVertices[v].z);
    const bool uv = m.HasTextureCoords(0);
    if (uv)
      for (unsigned v = 0; v < m.mNumVertices; ++v)
        soup.texcoords.emplace_back(m.mTextureCoords[0][v].x, m.mTextureCoords[0][v].y);
    const bool normals = m.HasNormals();
    if (normals)
      for (unsigned v = 0; v < m.mNumVertices; ++v)
        soup.normals.emplace_back(m.mNormals[v].x, m.mNormals[v].y, m.mNormals[v].z);
    const aiMaterial* material =
        m.mMaterialIndex < scene->mNumMaterials ? scene->mMaterials[m.mMaterialIndex] : nullptr;
    soup.material.set(material ? material->GetName().C_Str() : "default", soup.triangles.size(), "default");
    soup.group.set(m.mName.length ? m.mName.C_Str() : ("mesh " + std::to_string(i)).c_str(), soup.triangles.size(),
                   "default");
    std::vector<int> corner, corneruv, cornerNormal;
    for (unsigned f = 0; f < m.mNumFaces; ++f) {
      const aiFace& face = m.mFaces[f];
      ++polygon;
      if (face.mNumIndices < 3) {
        ++points;
        continue;
      }
      corner.resize(face.mNumIndices), corneruv.resize(face.mNumIndices), cornerNormal.resize(face.mNumIndices);
      for (unsigned k = 0; k < face.mNumIndices; ++k) {
        corner[k] = base + int(face.mIndices[k]), corneruv[k] = uvBase + int(face.mIndices[k]);
        cornerNormal[k] = normalBase + int(face.mIndices[k]);
      }
      soup.addPolygon(corner.data(), uv ? corneruv.data() : nullptr, int(corner.size()), polygon,
                      normals ? cornerNormal.data() : nullptr);
    }
  }
  auto note = [&](int count, const std::string& what) {
    if (count) soup.notes.push_back({MeshFinding::Severity::Warning, what, {}, count});
  };
  note(points, std::to_string(points) + " points and lines skipped (only faces are textured)");
}

// The soup's fields as bytes, to come back from the reader's process.
class Packer {
 public:
  std::string bytes;
  template <class T>
  void put(const std::vector<T>& v) {
    put(uint64_t(v.size()));
    bytes.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
  }
  void put(uint64_t n) { bytes.append(reinterpret_cast<const char*>(&n), sizeof n); }
  void put(const std::string& s) {
    put(uint64_t(s.size()));
    bytes += s;
  }
  void put(const std::vector<std::string>& v) {
    put(uint64_t(v.size()));
    for (const std::string& s : v) put(s);
  }
};

class Unpacker {
 public:
  Unpacker(const std::string& b, size_t from) : bytes_(b), at_(from) {}
  uint64_t count() {
    uint64_t n = 0;
    take(&n, sizeof n);
    return n;
  }
  template <class T>
  void get(std::vector<T>& v) {
    v.resize(count());
    take(v.data(), v.size() * sizeof(T));
  }
  void get(std::string& s) {
    s.resize(count());
    take(s.data(), s.size());
  }
  void get(std::vector<std::string>& v) {
    v.resize(count());
    for (std::string& s : v) get(s);
  }

 private:
  void take(void* to, size_t n) {
    TM_CHECK(n <= bytes_.size() - at_, "mesh reader: a short answer from the reader's process");
    std::memcpy(to, bytes_.data() + at_, n);
    at_ += n;
  }
  const std::string& bytes_;
  size_t at_;
};

// Assimp's parsers are not ours: a damaged file can make them abort on an assert (3MF's zip reader) or ask for
// tens of gigabytes (a flipped array length). They run in a child process (base/isolate.h) with a memory budget
// of 2 GB plus 64 bytes for every byte of the file, and 10 minutes; the soup comes back as bytes.
void readAssimp(const std::string& data, Soup& soup, const char* format, const char* name, std::string& asGlb) {
  const size_t budget = (size_t(2) << 30) + 64 * data.size();
  const std::string packed = runIsolated(
      [&] {
        Soup s;
        s.file = soup.file;
        std::string glb;
        readAssimpHere(data, s, format, name, glb);
        if (!glb.empty()) return "G" + glb;  // the scene in glTF form
        Packer p;
        p.bytes = "S";
        p.put(s.positions), p.put(s.texcoords), p.put(s.triangles), p.put(uint64_t(s.hasUV)), p.put(s.uvIndex);
        p.put(s.source), p.put(s.material.names), p.put(s.material.ids), p.put(s.group.names), p.put(s.group.ids);
        p.put(s.normals), p.put(uint64_t(s.hasNormals)), p.put(s.normalIndex);
        p.put(uint64_t(s.notes.size()));
        for (const MeshFinding& n : s.notes) p.put(n.what), p.put(uint64_t(n.count));
        return p.bytes;
      },
      budget, 600, soup.file + ": reading it as " + name);
  TM_CHECK(!packed.empty(), "mesh reader: an empty answer from the reader's process");
  if (packed[0] == 'G') {
    asGlb = packed.substr(1);
    return;
  }
  Unpacker u(packed, 1);
  u.get(soup.positions), u.get(soup.texcoords), u.get(soup.triangles);
  soup.hasUV = u.count() != 0;
  u.get(soup.uvIndex), u.get(soup.source), u.get(soup.material.names), u.get(soup.material.ids);
  u.get(soup.group.names), u.get(soup.group.ids);
  u.get(soup.normals);
  soup.hasNormals = u.count() != 0;
  u.get(soup.normalIndex);
  soup.binary = true;
  for (uint64_t i = 0, n = u.count(); i < n; ++i) {
    MeshFinding f;
    u.get(f.what);
    f.count = int(u.count());
    soup.notes.push_back(f);
  }
}

// ---- Files -----------------------------------------------------------------------------------------------

void appendNumber(std::string& out, double x) {
  char buf[32];
  out.append(buf, std::to_chars(buf, buf + sizeof buf, x).ptr);
}

using Reader = void (*)(const std::string&, Soup&);

// The formats parseMesh reads (glTF has its own loader, io/model.h): by a reader of ours, or through Assimp
// (`assimp`: its format hint, and the format's name for messages). `welds`: identical positions are welded, as
// the format shares no vertex between faces (STL) or the reader gives each corner its own vertex where its
// attributes differ (Assimp).
struct MeshFormat {
  const char* ext;
  Reader read;
  bool welds;
  const char* assimp = nullptr;
  const char* name = nullptr;
};
const MeshFormat kMeshFormats[] = {{"obj", readObj, false},
                                   {"ply", readPly, false},
                                   {"off", readOff, false},
                                   {"stl", readStl, true},
                                   {"fbx", nullptr, true, "fbx", "FBX"},
                                   {"dae", nullptr, true, "dae", "Collada"},
                                   {"3ds", nullptr, true, "3ds", "3DS"},
                                   {"3mf", nullptr, true, "3mf", "3MF"}};

// The format of an extension ("obj"...); throws naming `path` when there is none.
const MeshFormat& meshFormat(const std::string& ext, const std::string& path) {
  const auto format =
      std::find_if(std::begin(kMeshFormats), std::end(kMeshFormats), [&](auto& f) { return ext == f.ext; });
  if (format == std::end(kMeshFormats))
    failAt(path, 0, "unsupported mesh format " + quote(ext) + " (expected " + meshExtensionList() + ")");
  return *format;
}

}  // namespace

const std::vector<std::string>& meshExtensions() {
  static const std::vector<std::string> all = [] {
    std::vector<std::string> out;
    for (const MeshFormat& f : kMeshFormats) out.push_back(std::string(".") + f.ext);
    out.insert(out.end(), {".glb", ".gltf"});  // loadGltfMesh
    return out;
  }();
  return all;
}

bool isAssimpExtension(const std::string& ext) {
  return std::any_of(std::begin(kMeshFormats), std::end(kMeshFormats),
                     [&](const MeshFormat& f) { return f.assimp && ext == std::string(".") + f.ext; });
}

bool isMeshExtension(const std::string& ext) {
  const auto& all = meshExtensions();
  return std::find(all.begin(), all.end(), ext) != all.end();
}

std::string meshExtensionList(const char* separator) {
  std::string out;
  for (const std::string& e : meshExtensions()) out += (out.empty() ? "" : separator) + e;
  return out;
}

LoadedMesh loadMesh(const std::string& path, const MeshLoadOptions& options) {
  std::string ext = lowerExtension(path);
  if (!ext.empty()) ext.erase(0, 1);
  if (ext == "glb" || ext == "gltf") return loadGltfMesh(path, options);  // io/model.h: the model reader's
  meshFormat(ext, path);  // an unknown format is refused before the file is read
  return parseMesh(readFileBytes(path, "mesh file"), ext, path, options);
}

LoadedMesh parseMesh(const std::string& bytes, const std::string& ext, const std::string& path,
                     const MeshLoadOptions& options) {
  const MeshFormat& format = meshFormat(ext, path);
  Soup soup;
  soup.file = path;
  if (format.assimp) {
    std::string asGlb;
    readAssimp(bytes, soup, format.assimp, format.name, asGlb);
    if (!asGlb.empty()) return gltf::documentMesh(gltf::parseDocument(asGlb, path, true, false), path, options);
  } else {
    format.read(bytes, soup);
  }
  const std::vector<std::array<Vec2, 3>> uv = soup.finish();

  MeshLoadOptions opts = options;
  opts.weldIdenticalPositions |= format.welds;
  LoadedMesh loaded = buildMesh(soup.positions, soup.triangles, uv, opts, path);
  loaded.report.format = ext;
  loaded.report.findings.insert(loaded.report.findings.end(), soup.notes.begin(), soup.notes.end());

  Mesh& mesh = *loaded.mesh;
  mesh.mtllib = soup.mtllib;
  auto labels = [&](const FaceLabels& from, std::vector<int>& ids, std::vector<std::string>& names) {
    if (from.ids.empty()) return;
    names = from.names;
    ids.resize(mesh.numFaces());
    for (int f = 0; f < mesh.numFaces(); ++f) ids[f] = from.ids[mesh.faceOrigin[f]];
  };
  labels(soup.material, mesh.faceMaterial, mesh.materialNames);
  labels(soup.group, mesh.faceGroup, mesh.groupNames);
  // The file's normals per corner, in faceVertices order: a mesh corner is the triangle's corner at its position
  // (welding may have merged the file's vertex into another at the same place).
  if (const std::vector<std::array<Vec3, 3>> normals = soup.cornerNormals(); !normals.empty()) {
    mesh.cornerNormal.resize(mesh.numFaces());
    for (int f = 0; f < mesh.numFaces(); ++f) {
      const int t = mesh.faceOrigin[f];
      const auto fv = mesh.faceVertices(f);
      for (int k = 0; k < 3; ++k) {
        int j = 0;
        while (j < 2 && soup.positions[soup.triangles[t][j]] != mesh.position(fv[k])) ++j;
        mesh.cornerNormal[f][k] = usableNormal(mesh, f, normals[t][j]);
      }
    }
  }
  if (const std::vector<int> polygons = soup.polygons(); !polygons.empty()) {
    mesh.facePolygon.resize(mesh.numFaces());
    for (int f = 0; f < mesh.numFaces(); ++f) mesh.facePolygon[f] = polygons[mesh.faceOrigin[f]];
  }
  return loaded;
}

tinygltf::Model gltf::loadSourceDocument(const std::string& path) {
  std::string ext = lowerExtension(path);
  if (ext == ".glb" || ext == ".gltf") return loadDocument(path, false);
  if (!ext.empty()) ext.erase(0, 1);
  const MeshFormat& format = meshFormat(ext, path);
  std::string asGlb;
  if (format.assimp) {
    montage::Soup soup;
    soup.file = path;
    readAssimp(readFileBytes(path, "mesh file"), soup, format.assimp, format.name, asGlb);
  }
  TM_CHECK(!asGlb.empty(),
           located(path,
                   "holds no skin, morph target, second UV set or vertex colours to write back: the GLB is a new one"));
  return parseDocument(asGlb, path, true, false);
}

Vec3f usableNormal(const Mesh& mesh, int f, const Vec3& normal) {
  const Vec3 n = normal.squaredNorm() > 0 ? normal : mesh.faceNormal(f);
  return n.squaredNorm() > 0 ? n.cast<float>() : Vec3f(0, 0, 1);
}

void saveMeshObj(const Mesh& mesh, const std::string& path) {
  std::string out = "# written by TextureMontage\n";
  out.reserve(40 * (mesh.numVertices() + 2 * mesh.numFaces()));
  for (int v = 0; v < mesh.numVertices(); ++v) {
    const Vec3 p = mesh.position(v);
    out += "v";
    for (int d = 0; d < 3; ++d) appendNumber(out += ' ', p[d]);
    out += '\n';
  }
  for (const auto& corners : mesh.cornerUV)  // one vt per corner, in face order
    for (const Vec2& t : corners) {
      appendNumber(out += "vt ", t.x());
      appendNumber(out += ' ', t.y());
      out += '\n';
    }
  for (int f = 0; f < mesh.numFaces(); ++f) {
    const auto v = mesh.faceVertices(f);
    out += 'f';
    for (int k = 0; k < 3; ++k) {
      out += ' ' + std::to_string(v[k] + 1);
      if (mesh.hasUV()) out += '/' + std::to_string(3 * f + k + 1);
    }
    out += '\n';
  }
  FILE* file = std::fopen(path.c_str(), "wb");
  if (!file) failAt(path, 0, std::string("cannot write: ") + std::strerror(errno));
  const bool ok = std::fwrite(out.data(), 1, out.size(), file) == out.size();
  if (std::fclose(file) != 0 || !ok) failAt(path, 0, std::string("write failed: ") + std::strerror(errno));
}

}  // namespace montage
