#include "io/project.h"

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <utility>

namespace fs = std::filesystem;

namespace montage {

namespace {

using json = nlohmann::json;
using ojson = nlohmann::ordered_json;  // keeps the written field order

constexpr const char* kFormat = "texturemontage-project";

std::string inQuotes(const std::string& s) {
  return "'" + s + "'";
}

std::string number(double v) {
  std::ostringstream out;
  out.precision(10);
  out << v;
  return out.str();
}

// ---------------------------------------------------------------------------------------------
// Reading: a Field is a JSON value (or its absence) with its path in the document, e.g.
// "points[2].at[0].photo". Every type check and every message goes through it.

// What a value is, for "must be X, not Y" messages (long strings are cut).
std::string describe(const json& v) {
  if (v.is_string()) {
    const std::string& text = v.get_ref<const std::string&>();
    return "the string \"" +
           (text.size() > 60 ? text.substr(0, 60) + "...\" (" + std::to_string(text.size()) + " bytes)" : text + "\"");
  }
  if (v.is_number()) return v.dump();
  if (v.is_object()) return "an object";
  if (v.is_array()) return "an array";
  return v.type_name();  // null, boolean
}

// Levenshtein distance, for naming the field a misspelt one meant.
size_t editDistance(const std::string& a, const std::string& b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = up;
    }
  }
  return row[b.size()];
}

class Field {
 public:
  Field(const std::string& file, const json* value, std::string path)
      : file_(file), value_(value), path_(std::move(path)) {}

  bool present() const { return value_ != nullptr; }

  [[noreturn]] void fail(const std::string& reason) const {
    throw Error(located(file_, located(path_.empty() ? "top level" : path_, reason)));
  }

  // The value, which must be present and satisfy `ok`; `expected` names the type for the message.
  template <class Check>
  const json& require(Check ok, const char* expected) const {
    if (!value_) fail("missing (required)");
    if (!ok(*value_)) fail(std::string("must be ") + expected + ", not " + describe(*value_));
    return *value_;
  }

  // Member of an object (absent when the object lacks it).
  Field operator[](const char* key) const {
    const json& object = require([](const json& v) { return v.is_object(); }, "an object");
    const auto it = object.find(key);
    return Field(file_, it == object.end() ? nullptr : &*it, path_.empty() ? key : path_ + "." + key);
  }
  // The keys of an object that are not in `known`, each as "<path>.<key>" with the closest known key when one is
  // near (a misspelling): what the reader ignores.
  void unknownKeys(const std::vector<std::string>& known, std::vector<std::string>& out) const {
    if (!value_ || !value_->is_object()) return;
    for (const auto& [key, value] : value_->items()) {
      if (std::find(known.begin(), known.end(), key) != known.end()) continue;
      std::string entry = (path_.empty() ? "" : path_ + ".") + key;
      size_t best = 3;  // at most 2 edits away
      std::string nearest;
      for (const std::string& k : known)
        if (const size_t d = editDistance(key, k); d < best) best = d, nearest = k;
      if (!nearest.empty()) entry += " (did you mean \"" + nearest + "\"?)";
      out.push_back(entry);
    }
  }
  // Element of an array.
  size_t size() const { return array().size(); }
  Field operator[](size_t i) const { return Field(file_, &array()[i], path_ + "[" + std::to_string(i) + "]"); }

  // The value converted by fromJson() below; the fallback when absent.
  template <class T>
  T as() const {
    T value{};
    fromJson(*this, value);
    return value;
  }
  template <class T>
  T as(const T& fallback) const {
    return present() ? as<T>() : fallback;
  }

 private:
  const json& array() const {
    return require([](const json& v) { return v.is_array(); }, "an array");
  }

  const std::string& file_;
  const json* value_;
  std::string path_;
};

long long integer(const Field& f, long long lo, long long hi) {
  const json& v = f.require([](const json& j) { return j.is_number_integer(); }, "an integer");
  // Non-negative numbers are stored unsigned: compare them as such, so that huge ones do not wrap.
  const bool inRange = v.is_number_unsigned() ? v.get<unsigned long long>() <= static_cast<unsigned long long>(hi) &&
                                                    v.get<long long>() >= lo
                                              : v.get<long long>() >= lo && v.get<long long>() <= hi;
  if (!inRange) f.fail(v.dump() + " is out of range " + std::to_string(lo) + ".." + std::to_string(hi));
  return v.get<long long>();
}

void fromJson(const Field& f, int& v) {
  v = int(integer(f, INT_MIN, INT_MAX));
}
void fromJson(const Field& f, unsigned& v) {
  v = unsigned(integer(f, 0, UINT_MAX));
}
void fromJson(const Field& f, bool& v) {
  v = f.require([](const json& j) { return j.is_boolean(); }, "true or false").get<bool>();
}
void fromJson(const Field& f, double& v) {
  v = f.require([](const json& j) { return j.is_number() && std::isfinite(j.get<double>()); }, "a finite number")
          .get<double>();
}
void fromJson(const Field& f, std::string& v) {
  v = f.require([](const json& j) { return j.is_string(); }, "a string").get<std::string>();
}
// Enums are written by name (options.h's tables).
template <class E, class = decltype(EnumNames<E>::names)>
void fromJson(const Field& f, E& v) {
  const std::string name = f.as<std::string>();
  std::string names;
  for (size_t i = 0; i < EnumNames<E>::names.size(); ++i) {
    if (name == EnumNames<E>::names[i]) {
      v = E(i);
      return;
    }
    names += std::string(i ? ", " : "") + inQuotes(EnumNames<E>::names[i]);
  }
  f.fail(inQuotes(name) + " is not " + EnumNames<E>::what + " (one of " + names + ")");
}
// A 2D point is [x, y].
void fromJson(const Field& f, Vec2& v) {
  if (f.size() != 2) f.fail("must be [x, y], an array of 2 numbers, not " + std::to_string(f.size()));
  v = Vec2(f[size_t(0)].as<double>(), f[size_t(1)].as<double>());
}
template <class T>
void fromJson(const Field& f, std::vector<T>& v) {
  v.clear();
  for (size_t i = 0, n = f.size(); i < n; ++i) v.push_back(f[i].as<T>());
}

void fromJson(const Field& f, PhotoPoint& p) {
  p.photo = f["photo"].as<int>();
  p.x = f["x"].as<double>();
  p.y = f["y"].as<double>();
}
void fromJson(const Field& f, FeaturePoint& p) {
  p.vertex = f["vertex"].as<int>();
  p.at = f["at"].as<std::vector<PhotoPoint>>();
}
void fromJson(const Field& f, FeatureChain& c) {
  c.photo = f["photo"].as<int>();
  c.points = f["points"].as<std::vector<int>>();
  c.closed = f["closed"].as(false);
}
void fromJson(const Field& f, Stroke& s) {
  s.vertices = f["vertices"].as<std::vector<int>>();
}
void fromJson(const Field& f, CloneOp& c) {
  c.photo = f["photo"].as<int>();
  c.polygon = f["polygon"].as<std::vector<Vec2>>();
  c.targetFaces = f["targetFaces"].as<std::vector<int>>();
  c.anchorVertex = f["anchorVertex"].as<int>();
  c.anchor = f["anchor"].as<Vec2>();
  c.pixelsPerUnit = f["pixelsPerUnit"].as(0.0);
  c.rotationDeg = f["rotationDeg"].as(0.0);
}

void fromJson(const Field& f, DeclinedProposal& d) {
  d.vertex = f["vertex"].as<int>();
  d.photo = f["photo"].as<int>();
}

void fromJson(const Field& f, HoleMode& h) {
  h.face = f["face"].as<int>();
  h.mode = f["mode"].as<InpaintMode>();
  if (f["exemplar"].present()) {
    const Field e = f["exemplar"];
    h.exemplar = HoleExemplar{e["photo"].as<int>(), e["polygon"].as<std::vector<Vec2>>()};
  }
}

// The options table: name, field and allowed range, shared by reading, writing and checking.
template <class Options, class Visit>
void forEachOption(Options& o, Visit&& visit) {
  visit("backgroundThresholdPx", o.backgroundThresholdPx, 0.0, 1000.0);
  visit("stretchSearches", o.stretchSearches, 0, 64);
  visit("seamLambda", o.seamLambda, 0.0, 1.0);
  visit("seamRounds", o.seamRounds, 0, 1000);
  visit("gradientWeight", o.gradientWeight, 0.0, 1.0);
  visit("colorBalance", o.colorBalance, BalanceMode::Off, BalanceMode::GainOffset);
  visit("seamLevelling", o.seamLevelling, LevelMode::Off, LevelMode::Vertex);
  visit("inpaintMode", o.inpaintMode, InpaintMode::Harmonic, InpaintMode::Texture);
  visit("maxInpaintVertices", o.maxInpaintVertices, 1000, 20000000);
  visit("atlasSize", o.atlasSize, 0, kMaxAtlasSizeOption);
  visit("gutter", o.gutter, 0, 64);
  visit("seed", o.seed, 0u, UINT_MAX);
  visit("exportTopology", o.exportTopology, ExportTopology::Original, ExportTopology::Refined);
  visit("bakeInto", o.bakeInto, BakeInto::Atlas, BakeInto::MeshUVs);
  visit("bakeSize", o.bakeSize, kMinBakeSize, kMaxBakeSize);
  visit("pngCompression", o.pngCompression, 0, 9);
  visit("cameraMode", o.cameraMode, CameraMode::Auto, CameraMode::Off);
  visit("cameraThreshold", o.cameraThreshold, 0.0005, 0.2);
  visit("sharedIntrinsics", o.sharedIntrinsics, false, true);
  visit("photometric", o.photometric, false, true);
  visit("foundSilhouettes", o.foundSilhouettes, false, true);
  visit("correction", o.correction, CorrectionMode::Off, CorrectionMode::Noise);
  visit("viewSmoothness", o.viewSmoothness, 0.0, 100.0);
  visit("maxPhotoSide", o.maxPhotoSide, 0, 16384);
  visit("weldIdenticalPositions", o.weldIdenticalPositions, false, true);
}

void fromJson(const Field& f, PipelineOptions& o) {
  forEachOption(o, [&](const char* name, auto& value, auto, auto) { value = f[name].as(value); });
}

// ---------------------------------------------------------------------------------------------
// Checks of a document in memory, shared by loadProject (without the mesh and photos) and
// validateProject (with their sizes).

struct SceneSizes {
  int numVertices, numFaces;
  const std::vector<std::pair<int, int>>& photos;  // width, height
};

class DocumentCheck {
 public:
  DocumentCheck(const Project& project, const std::string& file, const SceneSizes* scene)
      : p_(project), file_(file), scene_(scene) {}

  void run() const {
    checkOptions();
    checkPoints();
    checkChains();
    checkStrokes();
    checkClones();
    checkHoleModes();
    for (size_t i = 0; i < p_.declinedProposals.size(); ++i) {
      const std::string path = "declinedProposals[" + std::to_string(i) + "]";
      index(path + ".vertex", p_.declinedProposals[i].vertex, vertices(), "vertices", "mesh");
      index(path + ".photo", p_.declinedProposals[i].photo, photos(), "photos", "project");
    }
  }

 private:
  [[noreturn]] void fail(const std::string& path, const std::string& reason) const {
    throw Error(located(file_, located(path, reason)));
  }

  // An index into a list of `count` things (count unknown: only >= 0 is checked).
  void index(const std::string& path, long long value, std::optional<int> count, const char* things,
             const char* owner) const {
    if (value < 0) fail(path, std::to_string(value) + " must be >= 0");
    if (count && value >= *count)
      fail(path, std::to_string(value) + " is out of range: the " + owner + " has " + std::to_string(*count) + " " +
                     things + (*count > 0 ? " (0.." + std::to_string(*count - 1) + ")" : ""));
  }
  std::optional<int> vertices() const { return scene_ ? std::optional<int>(scene_->numVertices) : std::nullopt; }
  std::optional<int> faces() const { return scene_ ? std::optional<int>(scene_->numFaces) : std::nullopt; }
  int photos() const { return int(p_.photos.size()); }
  std::string photoName(int i) const {
    return "photo " + std::to_string(i) + " " + inQuotes(fs::path(p_.photos[i].path).filename().string());
  }

  // A point in photo `photo` (already checked to be in range).
  void inside(const std::string& path, int photo, const Vec2& at) const {
    for (int axis = 0; axis < 2; ++axis) {
      const std::string where = path + (axis ? "y" : "x");
      if (!std::isfinite(at[axis])) fail(where, "must be a finite number");
      if (!scene_) continue;
      const int extent = axis ? scene_->photos[photo].second : scene_->photos[photo].first;
      if (at[axis] < 0 || at[axis] > extent)
        fail(where, number(at[axis]) + " is outside " + photoName(photo) + " (" + (axis ? "height " : "width ") +
                        std::to_string(extent) + ")");
    }
  }

  void checkOptions() const {
    if (p_.options.maxPhotoSide > 0 && p_.options.maxPhotoSide < 256)
      fail("options.maxPhotoSide", std::to_string(p_.options.maxPhotoSide) +
                                       " is too small: 0 (the photos' own resolution) or at least 256 pixels");
    forEachOption(p_.options, [&](const char* name, const auto& value, auto lo, auto hi) {
      using T = std::decay_t<decltype(value)>;
      if constexpr (std::is_floating_point_v<T>) {
        if (!std::isfinite(value)) fail(std::string("options.") + name, "must be a finite number");
      }
      if (value < lo || value > hi) {
        if constexpr (std::is_enum_v<T>)
          fail(std::string("options.") + name, std::to_string(int(value)) + " is not " + EnumNames<T>::what);
        else
          fail(std::string("options.") + name,
               number(double(value)) + " is out of range " + number(double(lo)) + ".." + number(double(hi)));
      }
    });
    if (p_.options.atlasSize > 0 && p_.options.atlasSize < kMinAtlasSizeOption)
      fail("options.atlasSize", std::to_string(p_.options.atlasSize) + " is neither 0 (automatic) nor in " +
                                    std::to_string(kMinAtlasSizeOption) + ".." + std::to_string(kMaxAtlasSizeOption));
    if ((p_.options.bakeSize & (p_.options.bakeSize - 1)) != 0)
      fail("options.bakeSize", std::to_string(p_.options.bakeSize) + " is not a power of two (16, 32, .., 8192)");
    if (p_.options.bakeInto == BakeInto::MeshUVs && p_.options.exportTopology == ExportTopology::Refined)
      fail("options.bakeInto",
           "\"meshUVs\" bakes into the mesh as loaded, which exportTopology \"refined\" does not "
           "export (use exportTopology \"original\")");
  }

  void checkPoints() const {
    std::map<std::pair<int, int>, std::string> seen;  // (vertex, photo) -> path of its position
    std::map<int, size_t> ids;                        // id -> index of the point that has it
    for (size_t i = 0; i < p_.points.size(); ++i) {
      const FeaturePoint& point = p_.points[i];
      const std::string path = "points[" + std::to_string(i) + "]";
      const int id = point.id >= 0 ? point.id : int(i);
      const auto [same, freshId] = ids.emplace(id, i);
      if (!freshId)
        fail(path + ".id", std::to_string(id) + " is the id of points[" + std::to_string(same->second) +
                               "] too (a point without \"id\" has its index as id)");
      index(path + ".vertex", point.vertex, vertices(), "vertices", "mesh");
      for (size_t j = 0; j < point.at.size(); ++j) {
        const PhotoPoint& at = point.at[j];
        const std::string atPath = path + ".at[" + std::to_string(j) + "]";
        index(atPath + ".photo", at.photo, photos(), "photos", "project");
        inside(atPath + ".", at.photo, Vec2(at.x, at.y));
        const auto [it, fresh] = seen.emplace(std::make_pair(point.vertex, at.photo), atPath);
        if (!fresh)
          fail(atPath + ".photo", "vertex " + std::to_string(point.vertex) + " is given two points in " +
                                      photoName(at.photo) + ": " + it->second + " and " + atPath);
      }
    }
  }

  void checkChains() const {
    for (size_t i = 0; i < p_.chains.size(); ++i) {
      const FeatureChain& chain = p_.chains[i];
      const std::string path = "chains[" + std::to_string(i) + "]";
      index(path + ".photo", chain.photo, photos(), "photos", "project");
      for (size_t k = 0; k < chain.points.size(); ++k) {
        const std::string pointPath = path + ".points[" + std::to_string(k) + "]";
        index(pointPath, chain.points[k], int(p_.points.size()), "points", "project");
        const FeaturePoint& point = p_.points[chain.points[k]];
        bool found = false;
        for (const PhotoPoint& at : point.at) found = found || at.photo == chain.photo;
        if (!found)
          fail(pointPath, "point " + std::to_string(chain.points[k]) + " (vertex " + std::to_string(point.vertex) +
                              ") has no position in the chain's " + photoName(chain.photo));
      }
      const size_t needed = chain.closed ? 3 : 2;
      if (scene_ && chain.points.size() < needed)
        fail(path + ".points", std::string(chain.closed ? "a closed chain (polygon)" : "a feature line") +
                                   " needs at least " + std::to_string(needed) + " points, not " +
                                   std::to_string(chain.points.size()));
    }
  }

  void checkStrokes() const {
    for (size_t i = 0; i < p_.strokes.size(); ++i) {
      const std::string path = "strokes[" + std::to_string(i) + "].vertices";
      const auto& vs = p_.strokes[i].vertices;
      for (size_t k = 0; k < vs.size(); ++k)
        index(path + "[" + std::to_string(k) + "]", vs[k], vertices(), "vertices", "mesh");
      if (scene_ && vs.size() < 2) fail(path, "a stroke needs at least 2 vertices, not " + std::to_string(vs.size()));
    }
  }

  void checkClones() const {
    for (size_t i = 0; i < p_.clones.size(); ++i) {
      const CloneOp& clone = p_.clones[i];
      const std::string path = "clones[" + std::to_string(i) + "]";
      index(path + ".photo", clone.photo, photos(), "photos", "project");
      index(path + ".anchorVertex", clone.anchorVertex, vertices(), "vertices", "mesh");
      for (size_t k = 0; k < clone.targetFaces.size(); ++k)
        index(path + ".targetFaces[" + std::to_string(k) + "]", clone.targetFaces[k], faces(), "faces", "mesh");
      for (int axis = 0; axis < 2; ++axis)
        if (!std::isfinite(clone.anchor[axis]))
          fail(path + ".anchor[" + std::to_string(axis) + "]", "must be a finite number");
      if (!std::isfinite(clone.pixelsPerUnit) || clone.pixelsPerUnit < 0)
        fail(path + ".pixelsPerUnit", number(clone.pixelsPerUnit) + " must be a finite number >= 0");
      if (!std::isfinite(clone.rotationDeg)) fail(path + ".rotationDeg", "must be a finite number");
      if (!scene_) continue;
      if (clone.targetFaces.empty()) fail(path + ".targetFaces", "must name at least one face");
      polygonIn(path + ".polygon", clone.photo, clone.polygon);
    }
  }

  void checkHoleModes() const {
    for (size_t i = 0; i < p_.holeModes.size(); ++i) {
      const HoleMode& h = p_.holeModes[i];
      const std::string path = "holeModes[" + std::to_string(i) + "]";
      index(path + ".face", h.face, faces(), "faces", "mesh");
      if (!h.exemplar) continue;
      if (h.mode != InpaintMode::Texture)
        fail(path + ".exemplar", std::string("only mode \"texture\" takes its texture from a photo region; this "
                                             "hole's mode is \"") + kInpaintModeNames[size_t(h.mode)] + "\"");
      index(path + ".exemplar.photo", h.exemplar->photo, photos(), "photos", "project");
      if (scene_) polygonIn(path + ".exemplar.polygon", h.exemplar->photo, h.exemplar->polygon);
    }
  }

  // A region of a photo: at least 3 points, each inside the photo, a non-zero area.
  void polygonIn(const std::string& path, int photo, const std::vector<Vec2>& polygon) const {
    if (polygon.size() < 3) fail(path, "needs at least 3 points, not " + std::to_string(polygon.size()));
    double area2 = 0;
    for (size_t k = 0; k < polygon.size(); ++k) {
      inside(path + "[" + std::to_string(k) + "].", photo, polygon[k]);
      const Vec2& a = polygon[k];
      const Vec2& b = polygon[(k + 1) % polygon.size()];
      area2 += a.x() * b.y() - a.y() * b.x();
    }
    if (std::abs(area2) / 2 < 1e-6) fail(path, "has zero area");
  }

  const Project& p_;
  const std::string& file_;
  const SceneSizes* scene_;
};

// ---------------------------------------------------------------------------------------------
// Writing.

ojson toJson(const Vec2& v) {
  return ojson::array({v.x(), v.y()});
}

ojson toJson(const PipelineOptions& o) {
  ojson j = ojson::object();
  forEachOption(o, [&](const char* name, const auto& value, auto, auto) {
    using T = std::decay_t<decltype(value)>;
    if constexpr (std::is_enum_v<T>) {
      const size_t i = size_t(value);
      TM_CHECK(i < EnumNames<T>::names.size(),
               std::string("options.") + name + ": " + std::to_string(i) + " is not " + EnumNames<T>::what);
      j[name] = EnumNames<T>::names[i];
    } else {
      j[name] = value;
    }
  });
  return j;
}

// JSON has no NaN or infinity (nlohmann would write null): refuse to write them, naming the field.
void requireFinite(const ojson& j, const std::string& path) {
  if (j.is_number_float() && !std::isfinite(j.get<double>()))
    throw Error(located(path, "is not a finite number; the project cannot be saved"));
  if (j.is_object())
    for (const auto& [key, value] : j.items()) requireFinite(value, path.empty() ? key : path + "." + key);
  if (j.is_array())
    for (size_t i = 0; i < j.size(); ++i) requireFinite(j[i], path + "[" + std::to_string(i) + "]");
}

// A path as written in the file: relative to `base` when one is given.
std::string storedPath(const std::string& path, const fs::path& base) {
  if (base.empty() || path.empty()) return path;
  const fs::path absolute = fs::absolute(path).lexically_normal();
  const fs::path relative = absolute.lexically_relative(base);
  return (relative.empty() ? absolute : relative).generic_string();
}

// "line L, column C" of the 1-based byte offset `byte` in `text`.
std::string lineAndColumn(const std::string& text, size_t byte) {
  const size_t end = std::min(std::max<size_t>(byte, 1) - 1, text.size());
  size_t lineStart = 0;
  if (const size_t newline = end ? text.rfind('\n', end - 1) : std::string::npos; newline != std::string::npos)
    lineStart = newline + 1;
  const size_t line = 1 + std::count(text.begin(), text.begin() + end, '\n');
  return "line " + std::to_string(line) + ", column " + std::to_string(end - lineStart + 1);
}

// The DOM builder of nlohmann::json with two changes: a failure (syntax error, number overflow such as
// 1e400) is recorded with its byte position instead of thrown without one, and nesting deeper than
// kMaxDepth is refused. sax_parse calls these members statically, so hiding the base's is enough.
class ProjectSax : public nlohmann::detail::json_sax_dom_parser<json> {
 public:
  static constexpr int kMaxDepth = 64;
  explicit ProjectSax(json& root) : json_sax_dom_parser(root, false) {}

  bool start_object(std::size_t n) { return deeper() && json_sax_dom_parser::start_object(n); }
  bool end_object() { return --depth_, json_sax_dom_parser::end_object(); }
  bool start_array(std::size_t n) { return deeper() && json_sax_dom_parser::start_array(n); }
  bool end_array() { return --depth_, json_sax_dom_parser::end_array(); }
  template <class Exception>
  bool parse_error(std::size_t position, const std::string&, const Exception& e) {
    if (error.empty()) {
      byte = position;
      error = e.what();
      // "[json.exception.parse_error.101] parse error at line 1, column 2: syntax error ..." -> "syntax error ..."
      for (const char* start : {"syntax error", "number overflow"})
        if (const size_t at = error.find(start); at != std::string::npos) error = error.substr(at);
    }
    return false;
  }

  std::string error;
  size_t byte = 0;

 private:
  bool deeper() {
    if (++depth_ <= kMaxDepth) return true;
    error = "values nested more than " + std::to_string(kMaxDepth) + " deep (a project is at most a few levels deep)";
    return false;
  }
  int depth_ = 0;
};

json parseJson(const std::string& path, const std::string& text) {
  json root;
  ProjectSax sax(root);
  bool ok = false;
  try {
    ok = json::sax_parse(text, &sax);
  } catch (const json::exception& e) {  // anything the parser throws despite the handler
    if (sax.error.empty()) sax.error = e.what();
  }
  if (ok && sax.error.empty()) return root;
  if (sax.error.empty()) sax.error = "syntax error";
  throw Error(located(path, (sax.byte > 0 ? lineAndColumn(text, sax.byte) + ": " : "") + "invalid JSON: " + sax.error));
}

// A path from the file, made absolute against the project's folder; the file must exist, unless
// `missing` is given: a file that does not exist is then listed there (`field` names it).
std::string resolveFile(const Field& f, const fs::path& dir, std::vector<MissingFile>* missing = nullptr,
                        const std::string& field = "") {
  const std::string written = f.as<std::string>();
  if (written.empty()) f.fail("must not be empty");
  const fs::path resolved = (dir / written).lexically_normal();
  if (missing) {
    std::error_code ec;
    if (!fs::exists(resolved, ec)) {
      missing->push_back(MissingFile{field, resolved.string()});
      return resolved.string();
    }
  }
  if (const std::string problem = fileProblem(resolved.string()); !problem.empty())
    f.fail("file " + inQuotes(written) + " " + problem + " (resolved to " + inQuotes(resolved.string()) + ")");
  return resolved.string();
}

Project parseProjectText(const std::string& text, const std::string& path, std::vector<MissingFile>* missing);

}  // namespace

bool Project::sameDocument(const Project& o) const {
  return mesh == o.mesh && photos == o.photos && points == o.points && chains == o.chains && strokes == o.strokes &&
         clones == o.clones && holeModes == o.holeModes && declinedProposals == o.declinedProposals &&
         options == o.options;
}

namespace {

std::string readProjectText(const std::string& path) {
  return readFileBytes(path, "project file", kMaxProjectBytes,
                       "a project holds paths and correspondences; its size is limited so that reading it needs "
                       "bounded memory");
}

Project parseProjectNamed(const std::string& text, const std::string& path, std::vector<MissingFile>* missing) {
  try {
    return parseProjectText(text, path, missing);
  } catch (const json::exception& e) {  // never expected (every read goes through Field): still named
    throw Error(located(path, std::string("invalid project: ") + e.what()));
  }
}

}  // namespace

Project loadProject(const std::string& path) {
  return parseProjectNamed(readProjectText(path), path, nullptr);
}

Project loadProjectAllowingMissing(const std::string& path, std::vector<MissingFile>& missing) {
  missing.clear();
  return parseProjectNamed(readProjectText(path), path, &missing);
}

Project parseProject(const std::string& text, const std::string& path) {
  return parseProjectNamed(text, path, nullptr);
}

namespace {

Project parseProjectText(const std::string& text, const std::string& path, std::vector<MissingFile>* missing) {
  const json document = parseJson(path, text);
  const Field root(path, &document, "");
  const Field format = root["format"];
  if (!format.present())
    format.fail("missing: not a TextureMontage project (expected \"format\": \"" + std::string(kFormat) + "\")");
  if (format.as<std::string>() != kFormat)
    format.fail(inQuotes(format.as<std::string>()) + " is not a TextureMontage project (expected " + inQuotes(kFormat) +
                ")");
  const int version = root["version"].as<int>();
  if (version < Project::kOldestVersion || version > Project::kVersion)
    root["version"].fail(std::to_string(version) + " is not supported: this build reads versions " +
                         std::to_string(Project::kOldestVersion) + " to " + std::to_string(Project::kVersion) +
                         (version > Project::kVersion ? " (the file was written by a newer TextureMontage)" : ""));

  Project project;
  project.file = fs::absolute(path).lexically_normal().string();
  const fs::path dir = fs::path(project.file).parent_path();
  project.mesh = resolveFile(root["mesh"], dir, missing, "mesh");
  const Field photos = root["photos"];
  for (size_t i = 0, n = photos.present() ? photos.size() : 0; i < n; ++i) {
    PhotoRef ref;
    const std::string at = "photos[" + std::to_string(i) + "]";
    ref.path = resolveFile(photos[i]["path"], dir, missing, at + ".path");
    if (photos[i]["mask"].present()) ref.mask = resolveFile(photos[i]["mask"], dir, missing, at + ".mask");
    ref.mirror = photos[i]["mirror"].as(false);
    ref.colorLocked = photos[i]["colorLocked"].as(false);
    ref.mode = photos[i]["mode"].as(PhotoMode::Auto);
    project.photos.push_back(ref);
  }
  project.points = root["points"].as(project.points);
  // Version 5: a point's id when it is not its index (points deleted before it kept the ids the user saw).
  if (version >= 5)
    for (size_t i = 0; i < project.points.size(); ++i) {
      const Field id = root["points"][i]["id"];
      if (!id.present()) continue;
      project.points[i].id = int(integer(id, 0, INT_MAX));
      if (project.points[i].id == int(i)) project.points[i].id = -1;  // canonical
    }
  project.chains = root["chains"].as(project.chains);
  project.strokes = root["strokes"].as(project.strokes);
  project.clones = root["clones"].as(project.clones);
  project.holeModes = root["holeModes"].as(project.holeModes);
  if (version >= 2) project.declinedProposals = root["declinedProposals"].as(project.declinedProposals);
  if (root["options"].present()) project.options = root["options"].as<PipelineOptions>();
  // The editor's camera, in any version: an older build lists it as an unknown field and goes on.
  if (const Field view = root["view"]; view.present()) {
    const Field target = view["target"];
    if (target.size() != 3)
      target.fail("must be [x, y, z], an array of 3 numbers, not " + std::to_string(target.size()));
    ViewState& v = project.view;
    v.target = Vec3(target[size_t(0)].as<double>(), target[size_t(1)].as<double>(), target[size_t(2)].as<double>());
    v.distance = view["distance"].as<double>();
    v.yawDeg = view["yaw"].as<double>();
    v.pitchDeg = view["pitch"].as<double>();
    v.fovYDeg = view["fov"].as<double>();
    if (!(v.distance > 0)) view["distance"].fail(number(v.distance) + " is not above 0");
    if (!(v.fovYDeg > 0 && v.fovYDeg < 180)) view["fov"].fail(number(v.fovYDeg) + " is out of range (0, 180) degrees");
    v.present = true;
    view.unknownKeys({"target", "distance", "yaw", "pitch", "fov"}, project.unknownFields);
  }
  // Where the ids lay on the mesh the project was saved with (io/mesh_anchors.h), in any version.
  if (const Field anchors = root["anchors"]; anchors.present()) {
    MeshAnchors& a = project.anchors;
    a.fingerprint = anchors["fingerprint"].as<std::string>();
    if (a.fingerprint.size() != 16 || a.fingerprint.find_first_not_of("0123456789abcdef") != std::string::npos)
      anchors["fingerprint"].fail(inQuotes(a.fingerprint) + " is not 16 hexadecimal digits");
    a.vertices = int(integer(anchors["vertices"], 0, INT_MAX));
    a.faces = int(integer(anchors["faces"], 0, INT_MAX));
    auto positions = [](const Field& list, int count, std::map<int, Vec3>& out) {
      for (size_t i = 0, n = list.present() ? list.size() : 0; i < n; ++i) {
        const Field e = list[i];
        if (e.size() != 4) e.fail("must be [id, x, y, z], an array of 4 numbers, not " + std::to_string(e.size()));
        const int id = int(integer(e[size_t(0)], 0, std::max(0, count - 1)));
        const Vec3 p(e[size_t(1)].as<double>(), e[size_t(2)].as<double>(), e[size_t(3)].as<double>());
        if (!p.allFinite()) e.fail("the position must be finite");
        out[id] = p;
      }
    };
    positions(anchors["vertex"], a.vertices, a.vertex);
    positions(anchors["face"], a.faces, a.face);
    a.present = true;
    anchors.unknownKeys({"fingerprint", "vertices", "faces", "vertex", "face"}, project.unknownFields);
  }
  // Fields this build does not know are ignored (a newer build's additions, docs/project-format.md), and named.
  root.unknownKeys({"format", "version", "mesh", "photos", "points", "chains", "strokes", "clones", "holeModes",
                    "declinedProposals", "options", "view", "anchors"},
                   project.unknownFields);
  for (size_t i = 0, n = photos.present() ? photos.size() : 0; i < n; ++i)
    photos[i].unknownKeys({"path", "mask", "mirror", "colorLocked", "mode"}, project.unknownFields);
  if (root["options"].present()) {
    std::vector<std::string> names;
    PipelineOptions defaults;
    forEachOption(defaults, [&](const char* name, auto&, auto, auto) { names.push_back(name); });
    root["options"].unknownKeys(names, project.unknownFields);
  }
  // Versions 1 and 2 had no colour balance: such a file keeps its behaviour.
  if (version < 3 && !(root["options"].present() && root["options"]["colorBalance"].present()))
    project.options.colorBalance = BalanceMode::Off;
  DocumentCheck(project, path, nullptr).run();
  return project;
}

}  // namespace

Project withoutPhotoReferences(const Project& project, const std::set<int>& photos) {
  Project out = project;
  for (FeaturePoint& point : out.points)
    point.at.erase(std::remove_if(point.at.begin(), point.at.end(),
                                  [&](const PhotoPoint& a) { return photos.count(a.photo) > 0; }),
                   point.at.end());
  out.chains.erase(std::remove_if(out.chains.begin(), out.chains.end(),
                                  [&](const FeatureChain& c) { return photos.count(c.photo) > 0; }),
                   out.chains.end());
  out.clones.erase(
      std::remove_if(out.clones.begin(), out.clones.end(), [&](const CloneOp& c) { return photos.count(c.photo) > 0; }),
      out.clones.end());
  for (HoleMode& h : out.holeModes)  // the hole keeps its mode and takes its texture from around it
    if (h.exemplar && photos.count(h.exemplar->photo)) h.exemplar.reset();
  return out;
}

Project withMeshIds(const Project& project, const std::vector<int>& vertexOf, const std::vector<int>& faceOf) {
  Project out = project;
  const std::string file = project.file.empty() ? "project" : project.file;
  auto map = [&](int& id, const std::vector<int>& table, const std::string& field, const char* what) {
    TM_CHECK(id >= 0 && id < static_cast<int>(table.size()),
             located(file, located(field, std::to_string(id) + " is out of range")));
    if (table[id] < 0)
      throw Error(
          located(file, located(field, std::string(what) + " " + std::to_string(id) +
                                           (what[0] == 'v' ? " is used by no face of the mesh"
                                                           : " has no area once the mesh's seams are welded"))));
    id = table[id];
  };
  for (size_t i = 0; i < out.points.size(); ++i)
    map(out.points[i].vertex, vertexOf, "points[" + std::to_string(i) + "].vertex", "vertex");
  for (size_t i = 0; i < out.strokes.size(); ++i)
    for (size_t k = 0; k < out.strokes[i].vertices.size(); ++k)
      map(out.strokes[i].vertices[k], vertexOf,
          "strokes[" + std::to_string(i) + "].vertices[" + std::to_string(k) + "]", "vertex");
  for (size_t i = 0; i < out.clones.size(); ++i) {
    const std::string path = "clones[" + std::to_string(i) + "]";
    map(out.clones[i].anchorVertex, vertexOf, path + ".anchorVertex", "vertex");
    auto& faces = out.clones[i].targetFaces;
    for (size_t k = 0; k < faces.size(); ++k)
      map(faces[k], faceOf, path + ".targetFaces[" + std::to_string(k) + "]", "face");
  }
  for (size_t i = 0; i < out.holeModes.size(); ++i)
    map(out.holeModes[i].face, faceOf, "holeModes[" + std::to_string(i) + "].face", "face");
  for (size_t i = 0; i < out.declinedProposals.size(); ++i)
    map(out.declinedProposals[i].vertex, vertexOf, "declinedProposals[" + std::to_string(i) + "].vertex", "vertex");
  return out;
}

int pointId(const Project& project, int index) {
  const int id = project.points[size_t(index)].id;
  return id >= 0 ? id : index;
}

int pointIndex(const Project& project, int id) {
  for (size_t i = 0; i < project.points.size(); ++i)
    if (pointId(project, int(i)) == id) return int(i);
  return -1;
}

int nextPointId(const Project& project) {
  int next = 0;
  for (size_t i = 0; i < project.points.size(); ++i) next = std::max(next, pointId(project, int(i)) + 1);
  return next;
}

void erasePoint(Project& project, int index) {
  std::vector<FeaturePoint>& points = project.points;
  for (size_t i = size_t(index) + 1; i < points.size(); ++i) points[i].id = pointId(project, int(i));
  points.erase(points.begin() + index);
  for (size_t i = 0; i < points.size(); ++i)
    if (points[i].id == int(i)) points[i].id = -1;
}

int requiredVersion(const Project& project) {
  for (const HoleMode& h : project.holeModes)
    if (h.exemplar) return 6;
  for (const FeaturePoint& p : project.points)
    if (p.id >= 0) return 5;
  bool photoFlags = false;
  for (const PhotoRef& p : project.photos)
    if (p.mode != PhotoMode::Auto) return 4;
  for (const PhotoRef& p : project.photos) photoFlags = photoFlags || p.mirror || p.colorLocked;
  if (photoFlags || project.options.colorBalance != BalanceMode::Off) return 3;
  return project.declinedProposals.empty() ? 1 : 2;
}

std::vector<std::string> projectOptionNames() {
  std::vector<std::string> names;
  PipelineOptions defaults;
  forEachOption(defaults, [&](const char* name, auto&, auto, auto) { names.push_back(name); });
  return names;
}

void setProjectOption(PipelineOptions& options, const std::string& key, const std::string& value,
                      const std::string& where) {
  json parsed;
  try {
    parsed = json::parse(value);
  } catch (const json::exception&) {
    parsed = value;  // a bare word: a string (an enum's name)
  }
  const json object = {{key, parsed}};
  const Field field(where, &object, "options");
  const std::vector<std::string> names = projectOptionNames();
  std::vector<std::string> unknown;
  field.unknownKeys(names, unknown);
  if (!unknown.empty()) {
    std::string list;
    for (const std::string& n : names) list += (list.empty() ? "" : ", ") + n;
    throw Error(located(where, unknown.front() + ": not an option (the options: " + list + ")"));
  }
  Project project;
  project.options = options;
  forEachOption(project.options, [&](const char* name, auto& v, auto, auto) {
    if (key == name) v = field[name].as<std::decay_t<decltype(v)>>();
  });
  DocumentCheck(project, where, nullptr).run();
  options = project.options;
}

void validateProject(const Project& project, int numVertices, int numFaces,
                     const std::vector<std::pair<int, int>>& photoSizes) {
  const std::string file = project.file.empty() ? "project" : project.file;
  TM_CHECK(photoSizes.size() == project.photos.size(),
           located(file, std::to_string(photoSizes.size()) + " photo sizes given for " +
                             std::to_string(project.photos.size()) + " photos"));
  const SceneSizes scene{numVertices, numFaces, photoSizes};
  DocumentCheck(project, file, &scene).run();
}

std::string projectToJson(const Project& project, const std::string& relativeTo) {
  const fs::path base = relativeTo.empty() ? fs::path() : fs::absolute(relativeTo).lexically_normal().parent_path();
  ojson j;
  j["format"] = kFormat;
  j["version"] = requiredVersion(project);
  j["mesh"] = storedPath(project.mesh, base);
  j["photos"] = ojson::array();
  for (const PhotoRef& photo : project.photos) {
    ojson p = {{"path", storedPath(photo.path, base)}};
    if (!photo.mask.empty()) p["mask"] = storedPath(photo.mask, base);
    if (photo.mirror) p["mirror"] = true;
    if (photo.colorLocked) p["colorLocked"] = true;
    if (photo.mode != PhotoMode::Auto) p["mode"] = kPhotoModeNames[size_t(photo.mode)];
    j["photos"].push_back(p);
  }
  j["points"] = ojson::array();
  for (const FeaturePoint& point : project.points) {
    ojson at = ojson::array();
    for (const PhotoPoint& a : point.at) at.push_back({{"photo", a.photo}, {"x", a.x}, {"y", a.y}});
    ojson p = {{"vertex", point.vertex}, {"at", at}};
    if (point.id >= 0) p["id"] = point.id;  // only where it is not the index (version 5)
    j["points"].push_back(p);
  }
  j["chains"] = ojson::array();
  for (const FeatureChain& chain : project.chains)
    j["chains"].push_back({{"photo", chain.photo}, {"points", chain.points}, {"closed", chain.closed}});
  j["strokes"] = ojson::array();
  for (const Stroke& stroke : project.strokes) j["strokes"].push_back({{"vertices", stroke.vertices}});
  j["clones"] = ojson::array();
  for (const CloneOp& clone : project.clones) {
    ojson polygon = ojson::array();
    for (const Vec2& p : clone.polygon) polygon.push_back(toJson(p));
    j["clones"].push_back({{"photo", clone.photo},
                           {"polygon", polygon},
                           {"targetFaces", clone.targetFaces},
                           {"anchorVertex", clone.anchorVertex},
                           {"anchor", toJson(clone.anchor)},
                           {"pixelsPerUnit", clone.pixelsPerUnit},
                           {"rotationDeg", clone.rotationDeg}});
  }
  j["holeModes"] = ojson::array();
  for (const HoleMode& h : project.holeModes) {
    ojson entry = {{"face", h.face}, {"mode", kInpaintModeNames.at(size_t(h.mode))}};
    if (h.exemplar) {
      ojson polygon = ojson::array();
      for (const Vec2& p : h.exemplar->polygon) polygon.push_back(toJson(p));
      entry["exemplar"] = {{"photo", h.exemplar->photo}, {"polygon", polygon}};
    }
    j["holeModes"].push_back(entry);
  }
  j["declinedProposals"] = ojson::array();
  for (const DeclinedProposal& d : project.declinedProposals)
    j["declinedProposals"].push_back({{"vertex", d.vertex}, {"photo", d.photo}});
  j["options"] = toJson(project.options);
  if (project.view.present) {
    const ViewState& v = project.view;
    j["view"] = {{"target", {v.target.x(), v.target.y(), v.target.z()}},
                 {"distance", v.distance},
                 {"yaw", v.yawDeg},
                 {"pitch", v.pitchDeg},
                 {"fov", v.fovYDeg}};
  }
  if (project.anchors.present) {
    const MeshAnchors& a = project.anchors;
    auto list = [](const std::map<int, Vec3>& m) {
      ojson out = ojson::array();
      for (const auto& [id, p] : m) out.push_back({id, p.x(), p.y(), p.z()});
      return out;
    };
    j["anchors"] = {{"fingerprint", a.fingerprint},
                    {"vertices", a.vertices},
                    {"faces", a.faces},
                    {"vertex", list(a.vertex)},
                    {"face", list(a.face)}};
  }
  requireFinite(j, "");
  return j.dump(2) + "\n";
}

void saveProject(Project& project, const std::string& path) {
  const std::string target = fs::absolute(path).lexically_normal().string();
  std::string text;
  try {
    text = projectToJson(project, target);
  } catch (const Error& e) {
    throw Error(located(target, e.what()));
  }
  writeFileAtomic(target, text);
  project.file = target;
}

}  // namespace montage
