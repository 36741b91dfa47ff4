#include "surface/synthesis.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <opencv2/imgproc.hpp>
#include <opencv2/xphoto/inpainting.hpp>
#include <unordered_map>

#include "atlas/lscm.h"
#include "base/hash.h"
#include "base/job.h"
#include "geometry/mesh.h"
#include "geometry/raster.h"
#include "image/photo.h"
#include "surface/level.h"

namespace montage {

Vec3f SynthesisResult::colorAt(int face, const Vec3& b) const {
  const auto& c = corner[faceSlot.at(face)];
  const Vec2 p = b[0] * c[0] + b[1] * c[1] + b[2] * c[2];
  return sampleBilinear3(image, p.x(), p.y());
}

std::shared_ptr<const SynthesisMemo::Entry> SynthesisMemo::find(uint64_t key, const cv::Mat& rgb, const cv::Mat& known,
                                                               float nearColour, bool& exact) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = current_.find(key);
  if (it == current_.end()) {
    it = previous_.find(key);
    if (it == previous_.end()) return nullptr;
    it = current_.emplace(key, it->second).first;
  }
  const Entry& e = *it->second;
  if (e.rgb.size() != rgb.size()) return nullptr;
  float maxDiff = 0;
  for (int y = 0; y < rgb.rows; ++y) {
    const auto* a = rgb.ptr<cv::Vec3f>(y);
    const auto* b = e.rgb.ptr<cv::Vec3f>(y);
    const uchar* k = known.ptr<uchar>(y);
    for (int x = 0; x < rgb.cols; ++x)
      if (k[x])
        for (int c = 0; c < 3; ++c) maxDiff = std::max(maxDiff, std::abs(a[x][c] - b[x][c]));
  }
  exact = maxDiff == 0;
  if (!exact && !(maxDiff <= nearColour)) return nullptr;
  return it->second;
}

void SynthesisMemo::store(uint64_t key, std::shared_ptr<const Entry> entry) {
  std::lock_guard<std::mutex> lock(mutex_);
  current_[key] = std::move(entry);
}

void SynthesisMemo::endRun() {
  std::lock_guard<std::mutex> lock(mutex_);
  previous_ = std::move(current_);
  current_.clear();
}

SynthesisResult synthesiseHole(const SynthesisInput& in, const SynthesisOptions& options) {
  SynthesisResult out;
  const Mesh& mesh = *in.mesh;
  const TextureMap& map = *in.map;
  const int nf = mesh.numFaces(), nv = mesh.numVertices();
  const JobControl noJob;
  const JobControl& job = in.job ? *in.job : noJob;
  if (in.holeFaces.empty() || !(in.texelsPerUnit > 0)) {
    out.note = "synthesis: empty hole or no texel density";
    return out;
  }
  std::vector<std::vector<int>> ownVertexFaces;
  if (!in.vertexFaces) ownVertexFaces = facesAroundVertices(mesh);
  const std::vector<std::vector<int>>& vertexFaces = in.vertexFaces ? *in.vertexFaces : ownVertexFaces;

  // Rings of mapped faces around the hole (faces sharing a vertex with the previous ring).
  std::vector<int> ring(nf, -1);
  double holeArea = 0;
  for (int f : in.holeFaces) ring[f] = 0, holeArea += mesh.faceArea(f);
  std::vector<std::vector<int>> rings = {in.holeFaces};
  double bandArea = 0;
  while (static_cast<int>(rings.size()) <= options.maxRings && bandArea < options.bandAreaRatio * holeArea) {
    std::vector<int> next;
    for (int f : rings.back())
      for (int v : mesh.faceVertices(f))
        for (int g : vertexFaces[v])
          if (ring[g] < 0 && map.facePhoto[g] >= 0) {
            ring[g] = static_cast<int>(rings.size());
            next.push_back(g);
            bandArea += mesh.faceArea(g);
          }
    if (next.empty()) break;
    rings.push_back(std::move(next));
  }
  if (rings.size() < 2) {
    out.note = "synthesis: no mapped face around the hole to take texture from";
    return out;
  }

  // Flatten hole + band; when the flattening folds (a band wrapping around a limb is no disc), retry with
  // fewer rings.
  std::vector<int> faces;
  std::vector<Vec2> uv;
  std::vector<int> local(nv, -1);
  std::vector<std::array<int, 3>> tris;
  std::vector<Vec3> positions;
  for (int use = static_cast<int>(rings.size()) - 1; use >= 1; use = use > 1 ? use / 2 : 0) {
    faces.clear(), tris.clear(), positions.clear();
    std::fill(local.begin(), local.end(), -1);
    for (int r = 0; r <= use; ++r)
      for (int f : rings[r]) {
        std::array<int, 3> t{};
        const auto fv = mesh.faceVertices(f);
        for (int k = 0; k < 3; ++k) {
          if (local[fv[k]] < 0)
            local[fv[k]] = static_cast<int>(positions.size()), positions.push_back(mesh.position(fv[k]));
          t[k] = local[fv[k]];
        }
        tris.push_back(t);
        faces.push_back(f);
      }
    try {
      // A big band's LSCM solve takes a fraction of a second: a cancel does not wait for it either.
      auto flat = std::make_shared<std::vector<Vec2>>();
      runCancellable(job, [positions, tris, flat] { *flat = lscm(positions, tris); });
      uv = std::move(*flat);
    } catch (const Error&) {
      continue;
    }
    const FlatteningQuality q = flatteningQuality(positions, tris, uv);
    if (q.flipped <= static_cast<int>(0.01 * tris.size()) && q.stretchLinf < 8) {
      for (Vec2& p : uv) p *= q.areaScale;
      out.rings = use;
      break;
    }
    uv.clear();
  }
  if (uv.empty()) {
    out.note = "synthesis: the hole and its band do not flatten without folds";
    return out;
  }

  // Canvas: the chart at texelsPerUnit (coarser when it would exceed maxCanvas texels a side).
  Vec2 lo = uv[0], hi = uv[0];
  for (const Vec2& p : uv) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  double scale = in.texelsPerUnit;
  // A blurred synthesis keeps structure only at the scale of the blur: 48 texels across the hole's
  // radius are plenty, and keep shift-map fast on big holes.
  constexpr double kBlurredRadiusTexels = 48;
  if (options.blur > 0) scale = std::min(scale, kBlurredRadiusTexels / std::max(std::sqrt(holeArea / M_PI), 1e-300));
  const double extent = (hi - lo).maxCoeff();
  if (extent * scale > options.maxCanvas - 4) scale = (options.maxCanvas - 4) / std::max(extent, 1e-300);
  const int width = std::max(8, int(std::ceil((hi.x() - lo.x()) * scale)) + 4);
  const int height = std::max(8, int(std::ceil((hi.y() - lo.y()) * scale)) + 4);
  out.faceSlot.reserve(faces.size());
  out.corner.resize(faces.size());
  for (size_t i = 0; i < faces.size(); ++i) {
    out.faceSlot[faces[i]] = static_cast<int>(i);
    for (int k = 0; k < 3; ++k) {
      const Vec2 p = (uv[tris[i][k]] - lo) * scale + Vec2(2, 2);
      out.corner[i][k] = Vec2(p.x(), height - p.y());  // image rows go down; the chart is v up
    }
  }
  out.bandFaces = static_cast<int>(faces.size() - in.holeFaces.size());

  cv::Mat rgb(height, width, CV_32FC3, cv::Scalar(0, 0, 0));
  out.known = cv::Mat(height, width, CV_8UC1, cv::Scalar(0));
  int knownPixels = 0;
  for (size_t i = 0; i < faces.size(); ++i) {
    const int f = faces[i];
    if (map.facePhoto[f] < 0) continue;
    const Photo& photo = *in.photos[map.facePhoto[f]];
    scanTriangle(out.corner[i], width, height, [&](int x, int y, const Vec3& b) {
      if (photo.hasBackground) {
        const auto& c = map.cornerUV[f];
        const Vec2 q = b[0] * c[0] + b[1] * c[1] + b[2] * c[2];
        if (photo.alphaAt(q.x(), q.y()) < 0.5f) return;
      }
      const Vec3f colour = mappedColor(map, in.photos, in.levelling, f, b).cwiseMax(0.f).cwiseMin(1.f);
      rgb.at<cv::Vec3f>(y, x) = cv::Vec3f(colour[0], colour[1], colour[2]);
      if (!out.known.at<uchar>(y, x)) ++knownPixels;
      out.known.at<uchar>(y, x) = 255;
    });
  }
  if (knownPixels < 16) {
    out.note = "synthesis: the band around the hole covers no photo texel";
    return out;
  }
  // The memo's key: the hole's geometry and the canvas's size and known mask (its colours are compared
  // apart, in find).
  cv::Mat filled;
  uint64_t key = hashMix(hashMix(uint64_t(0x5e17e5), width), height);
  for (int f : in.holeFaces)
    for (const Vec3& p : mesh.facePositions(f)) key = hashMix(key, p);
  for (int y = 0; y < height; ++y) {
    const uchar* k = out.known.ptr<uchar>(y);
    for (int x = 0; x < width; x += 8) {
      uint64_t word = 0;
      std::memcpy(&word, k + x, std::min(8, width - x));
      key = hashMix(key, word);
    }
  }
  if (in.memo) {
    bool exact = false;
    if (const auto kept = in.memo->find(key, rgb, out.known, in.nearColour, exact)) {
      filled = kept->filled;
      out.kept = exact ? SynthesisKept::Exact : SynthesisKept::Near;
    }
  }
  cv::Mat rgb8;
  if (filled.empty()) {
    // Shift-map works on 8-bit L*a*b* (its patch distances expect a perceptual space).
    cv::Mat lab;
    rgb.convertTo(rgb8, CV_8UC3, 255.0);
    cv::cvtColor(rgb8, lab, cv::COLOR_RGB2Lab);
    // Shift-map is one long call without a cancellation point (seconds on a big hole): a cancel does not
    // wait for it (runCancellable), so it works on copies of its inputs (cv::Mat headers share their pixels).
    auto shifted = std::make_shared<cv::Mat>();
    const cv::Mat known = out.known;
    runCancellable(job,
                   [lab, known, shifted] { cv::xphoto::inpaint(lab, known, *shifted, cv::xphoto::INPAINT_SHIFTMAP); });
    filled = *shifted;
    if (in.memo) in.memo->store(key, std::make_shared<const SynthesisMemo::Entry>(SynthesisMemo::Entry{rgb, filled}));
  }
  cv::cvtColor(filled, rgb8, cv::COLOR_Lab2RGB);
  rgb8.convertTo(out.image, CV_32FC3, 1.0 / 255);
  // Known texels keep their exact (float) colours.
  rgb.copyTo(out.image, out.known);
  if (options.blur > 0)
    cv::GaussianBlur(out.image, out.image, cv::Size(), options.blur * std::sqrt(holeArea / M_PI) * scale);
  out.ok = true;
  out.note = "synthesis: " + std::to_string(width) + " x " + std::to_string(height) + " texel chart, " +
             std::to_string(out.rings) + " rings (" + std::to_string(out.bandFaces) + " faces) of exemplar" +
             (out.kept == SynthesisKept::Exact  ? ", kept (same canvas)"
              : out.kept == SynthesisKept::Near ? ", kept (canvas within the preview's tolerance)"
                                                : "");
  return out;
}

}  // namespace montage
