#include "bench/landmarks.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "bench/render.h"
#include "geometry/mesh.h"
#include "geometry/predicates.h"
#include "geometry/raster.h"
#include "io/scene.h"
#include "mapping/partition.h"
#include "mapping/projection.h"
#include "mapping/texture_map.h"

namespace montage {

namespace fs = std::filesystem;

std::string skimageDataFile(const std::string& name) {
  return "/usr/lib/python3/dist-packages/skimage/data/" + name;
}

namespace {

std::vector<Landmark> readLandmarks(const nlohmann::json& doc, const std::string& field, const std::string& file) {
  std::vector<Landmark> out;
  if (!doc.contains(field) || !doc[field].is_array()) throw Error(file + ": " + field + ": must be an array");
  for (size_t i = 0; i < doc[field].size(); ++i) {
    const nlohmann::json& item = doc[field][i];
    const std::string where = file + ": " + field + "[" + std::to_string(i) + "]";
    if (!item.is_object() || !item.contains("vertex") || !item["vertex"].is_number_integer() || !item.contains("x") ||
        !item["x"].is_number() || !item.contains("y") || !item["y"].is_number())
      throw Error(where + ": needs an integer \"vertex\" and numbers \"x\" and \"y\"");
    Landmark l;
    l.name = item.value("name", field + " " + std::to_string(i));
    l.vertex = item["vertex"].get<int>();
    l.at = Vec2(item["x"].get<double>(), item["y"].get<double>());
    out.push_back(l);
  }
  return out;
}

}  // namespace

LandmarkCase loadLandmarkCase(const std::string& path, const std::string& dataRoot) {
  std::ifstream in(path);
  if (!in) throw Error(path + ": cannot be read");
  nlohmann::json doc;
  try {
    doc = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw Error(path + ": not JSON: " + e.what());
  }
  LandmarkCase c;
  c.file = path;
  if (!doc.contains("mesh") || !doc["mesh"].is_string()) throw Error(path + ": mesh: must be a path");
  if (!doc.contains("photo") || !doc["photo"].is_string()) throw Error(path + ": photo: must be a path");
  if (!doc.contains("faceWidth") || !doc["faceWidth"].is_number() || !(doc["faceWidth"].get<double>() > 0))
    throw Error(path + ": faceWidth: must be a positive number of pixels");
  c.faceWidth = doc["faceWidth"].get<double>();
  if (doc.contains("viewYawDeg")) {
    if (!doc["viewYawDeg"].is_number()) throw Error(path + ": viewYawDeg: must be a number of degrees");
    c.viewYawDeg = doc["viewYawDeg"].get<double>();
  }
  c.clicks = readLandmarks(doc, "clicks", path);
  c.heldOut = readLandmarks(doc, "heldOut", path);
  c.outline = readLandmarks(doc, "outline", path);
  const std::string photo = doc["photo"].get<std::string>();
  c.project.mesh = fs::absolute(fs::path(dataRoot) / doc["mesh"].get<std::string>()).string();
  c.project.photos.push_back(
      PhotoRef{photo.rfind("skimage:", 0) == 0 ? skimageDataFile(photo.substr(8)) : fs::absolute(photo).string(), ""});
  for (const std::string& file : {c.project.mesh, c.project.photos[0].path})
    if (!fs::exists(file)) throw Error(path + ": " + file + ": no such file");
  auto pointOf = [&](const Landmark& l) {
    for (size_t i = 0; i < c.project.points.size(); ++i)
      if (c.project.points[i].vertex == l.vertex) return static_cast<int>(i);
    c.project.points.push_back(FeaturePoint{l.vertex, {PhotoPoint{0, l.at.x(), l.at.y()}}});
    return static_cast<int>(c.project.points.size()) - 1;
  };
  for (const Landmark& l : c.clicks) pointOf(l);
  if (c.outline.size() >= 3) {
    FeatureChain chain;
    chain.photo = 0;
    chain.closed = true;
    for (const Landmark& l : c.outline) chain.points.push_back(pointOf(l));
    c.project.chains.push_back(chain);
  }
  return c;
}

std::vector<std::pair<std::string, Project>> oneClickChanges(const LandmarkCase& c, double movePx) {
  std::vector<std::pair<std::string, Project>> out;
  for (const Landmark& l : c.heldOut) {
    Project p = c.project;
    p.points.push_back(FeaturePoint{l.vertex, {PhotoPoint{0, l.at.x(), l.at.y()}}});
    out.emplace_back("+ " + l.name, std::move(p));
  }
  for (size_t i = 0; i < c.clicks.size(); ++i) {
    Project p = c.project;
    p.points[i].at[0].x += movePx;
    p.points[i].at[0].y -= movePx;
    out.emplace_back("moved " + c.clicks[i].name, p);
    const bool onOutline = std::any_of(p.chains.begin(), p.chains.end(), [&](const FeatureChain& chain) {
      return std::count(chain.points.begin(), chain.points.end(), int(i)) > 0;
    });
    if (onOutline) continue;  // deleting it would open the outline
    p = c.project;
    p.points.erase(p.points.begin() + i);
    for (FeatureChain& chain : p.chains)
      for (int& q : chain.points) q -= q > int(i);
    out.emplace_back("- " + c.clicks[i].name, std::move(p));
  }
  return out;
}

LandmarkScore scoreLandmarks(const LandmarkCase& c, const Scene& scene, const Partition& partition,
                             const TextureMap& map) {
  LandmarkScore s;
  const Mesh& mesh = partition.mesh;
  auto idOf = [&](int v) { return scene.vertexOf ? scene.vertexOf->at(v) : v; };
  // The outline's inside: faces reached from the clicked landmarks off the outline without crossing a side's path.
  const std::vector<std::pair<int, int>> walls = outlineWalls(c.project, partition, 0);
  s.outlineClosed = !c.project.chains.empty() && !walls.empty();
  std::map<std::pair<int, int>, std::vector<int>> edgeFaces;
  for (int f = 0; f < mesh.numFaces(); ++f) {
    const auto fv = mesh.faceVertices(f);
    for (int k = 0; k < 3; ++k)
      edgeFaces[{std::min(fv[k], fv[(k + 1) % 3]), std::max(fv[k], fv[(k + 1) % 3])}].push_back(f);
  }
  std::set<int> onOutline;
  for (const Landmark& l : c.outline) onOutline.insert(idOf(l.vertex));
  std::vector<char> inside(mesh.numFaces(), 0);
  std::vector<int> stack;
  for (const Landmark& l : c.clicks) {
    const int v = idOf(l.vertex);
    if (onOutline.count(v)) continue;
    for (int f = 0; f < mesh.numFaces(); ++f) {
      const auto fv = mesh.faceVertices(f);
      if ((fv[0] == v || fv[1] == v || fv[2] == v) && !inside[f]) inside[f] = 1, stack.push_back(f);
    }
  }
  while (!stack.empty()) {
    const int f = stack.back();
    stack.pop_back();
    const auto fv = mesh.faceVertices(f);
    for (int k = 0; k < 3; ++k) {
      const std::pair<int, int> e{std::min(fv[k], fv[(k + 1) % 3]), std::max(fv[k], fv[(k + 1) % 3])};
      if (std::binary_search(walls.begin(), walls.end(), e)) continue;
      for (int g : edgeFaces[e])
        if (!inside[g]) inside[g] = 1, stack.push_back(g);
    }
  }
  int positive = 0, negative = 0;
  for (int f = 0; f < mesh.numFaces(); ++f) {
    if (!inside[f]) continue;
    ++s.outlinedFaces;
    if (map.facePhoto[f] != 0) continue;
    const auto& uv = map.cornerUV[f];
    (cross2(uv[1] - uv[0], uv[2] - uv[0]) > 0 ? positive : negative)++;
  }
  // Seen from the photo's side: what a user looks at (a mesh may hold hidden surfaces, such as a mouth's or
  // nostrils' insides, that no photo from there shows).
  RenderOptions front;
  front.yawDeg = c.viewYawDeg;
  front.pitchDeg = 0;
  front.size = 1024;
  const RasterBuffers raster = rasterize(mesh, orbitCamera(mesh, front), RasterOptions{false, false});
  int seen = 0, fromPhoto = 0;
  for (int f : raster.face)
    if (f >= 0 && inside[f]) ++seen, fromPhoto += map.facePhoto[f] == 0;
  s.outlinedFromPhoto = seen > 0 ? double(fromPhoto) / seen : 0;
  s.folds = std::min(positive, negative);
  // Held-out landmarks inside the outline (all without one): the mean of their vertex's corners mapped from the
  // photo.
  for (const Landmark& l : c.heldOut) {
    const int v = idOf(l.vertex);
    Vec2 sum = Vec2::Zero();
    int n = 0;
    bool within = !s.outlineClosed;
    for (int f = 0; f < mesh.numFaces(); ++f) {
      const auto fv = mesh.faceVertices(f);
      if (fv[0] != v && fv[1] != v && fv[2] != v) continue;
      within |= inside[f] != 0;
      if (map.facePhoto[f] != 0) continue;
      for (int k = 0; k < 3; ++k)
        if (fv[k] == v) sum += map.cornerUV[f][k], ++n;
    }
    if (!within) {
      s.heldOutPx.push_back(std::numeric_limits<double>::quiet_NaN());
      continue;
    }
    s.heldOutPx.push_back(n ? (sum / n - l.at).norm() : std::numeric_limits<double>::infinity());
  }
  std::vector<double> scored;
  for (double e : s.heldOutPx)
    if (!std::isnan(e)) scored.push_back(e);
  if (!scored.empty()) {
    std::sort(scored.begin(), scored.end());
    s.medianShare = scored[scored.size() / 2] / c.faceWidth;
    s.worstShare = scored.back() / c.faceWidth;
  }
  s.outlined = std::move(inside);
  return s;
}

}  // namespace montage
