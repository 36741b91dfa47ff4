#include "surface/synthesis.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <opencv2/imgproc.hpp>
#include <unordered_map>

#include "base/hash.h"
#include "base/job.h"
#include "geometry/lscm.h"
#include "geometry/mesh.h"
#include "geometry/raster.h"
#include "image/color.h"
#include "image/photo.h"
#include "image/shiftmap.h"
#include "surface/level.h"

namespace montage {

Vec3f SynthesisChart::colorAt(int face, const Vec3& b) const {
  const auto& c = corner[faceSlot.at(face)];
  const Vec2 p = b[0] * c[0] + b[1] * c[1] + b[2] * c[2];
  return sampleBilinear3(image, p.x(), p.y());
}

namespace {

uint64_t faceKeyOf(const Mesh& mesh, int f) {
  uint64_t h = 0xfacefeed;
  for (const Vec3& p : mesh.facePositions(f)) h = hashMix(h, p);
  return h;
}

bool sameColours(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return false;
  for (int y = 0; y < a.rows; ++y)
    if (std::memcmp(a.ptr(y), b.ptr(y), a.cols * a.elemSize()) != 0) return false;
  return true;
}

}  // namespace

void SynthesisMemo::keep(const std::shared_ptr<const SynthesisChart>& chart) {
  if (std::find(current_.begin(), current_.end(), chart) == current_.end()) current_.push_back(chart);
}

cv::Mat SynthesisMemo::findExact(uint64_t canvasKey, const cv::Mat& rgb, const cv::Mat& known) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (const auto* list : {&current_, &previous_})
    for (const auto& chart : *list)
      if (chart->canvasKey == canvasKey && sameColours(chart->rgb, rgb) && sameColours(chart->known, known))
        return chart->image;
  return cv::Mat();
}

std::shared_ptr<const SynthesisChart> SynthesisMemo::findCovering(const std::vector<int>& holeFaces,
                                                                  const std::vector<uint64_t>& faceKey,
                                                                  uint64_t photosKey, double texelsPerUnit,
                                                                  double blur) {
  if (photosKey == 0 || holeFaces.empty()) return nullptr;
  // Of the charts that cover the hole, the one that synthesised most of its faces (rather than drew them
  // from a photo), then the smallest.
  std::lock_guard<std::mutex> lock(mutex_);
  std::shared_ptr<const SynthesisChart> best;
  size_t bestSynthesised = 0;
  for (const auto* list : {&current_, &previous_})
    for (const auto& chart : *list) {
      if (chart->photosKey != photosKey || chart->blur != blur ||
          !(std::abs(std::log(chart->texelsPerUnit / texelsPerUnit)) <= std::log(1.25)))
        continue;
      size_t synthesised = 0;
      bool covers = true;
      for (size_t i = 0; i < holeFaces.size() && covers; ++i) {
        const auto it = chart->faceSlot.find(holeFaces[i]);
        covers = it != chart->faceSlot.end() && chart->faceKey[it->second] == faceKey[i];
        synthesised += covers && static_cast<size_t>(it->second) < chart->holeFaces;
      }
      if (covers && (!best || synthesised > bestSynthesised ||
                     (synthesised == bestSynthesised && chart->corner.size() < best->corner.size())))
        best = chart, bestSynthesised = synthesised;
    }
  if (best) keep(best);
  return best;
}

void SynthesisMemo::store(std::shared_ptr<const SynthesisChart> chart) {
  std::lock_guard<std::mutex> lock(mutex_);
  current_.push_back(std::move(chart));
}

bool SynthesisMemo::flatteningFailed(uint64_t ringsKey) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (failed_.count(ringsKey)) return true;
  const auto it = previousFailed_.find(ringsKey);
  if (it == previousFailed_.end()) return false;
  failed_.insert(*it);
  return true;
}

bool SynthesisMemo::flatteningFailedNear(const std::vector<uint64_t>& holeKey) {
  std::vector<uint64_t> mine = holeKey;
  std::sort(mine.begin(), mine.end());
  std::lock_guard<std::mutex> lock(mutex_);
  for (const auto* list : {&failed_, &previousFailed_})
    for (const auto& [key, faces] : *list) {
      const size_t larger = std::max(mine.size(), faces->size());
      if (10 * std::min(mine.size(), faces->size()) < 9 * larger) continue;
      size_t shared = 0;
      for (size_t i = 0, j = 0; i < mine.size() && j < faces->size();)
        if (mine[i] < (*faces)[j]) ++i;
        else if ((*faces)[j] < mine[i]) ++j;
        else ++shared, ++i, ++j;
      if (10 * shared < 9 * larger) continue;
      failed_.emplace(key, faces);  // kept for the next run too
      return true;
    }
  return false;
}

void SynthesisMemo::storeFailedFlattening(uint64_t ringsKey, const std::vector<uint64_t>& holeKey) {
  auto faces = std::make_shared<std::vector<uint64_t>>(holeKey);
  std::sort(faces->begin(), faces->end());
  std::lock_guard<std::mutex> lock(mutex_);
  failed_.emplace(ringsKey, std::move(faces));
}

void SynthesisMemo::endRun() {
  std::lock_guard<std::mutex> lock(mutex_);
  previous_ = std::move(current_);
  current_.clear();
  previousFailed_ = std::move(failed_);
  failed_.clear();
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
  const double blur = std::max(options.blur, 0.0);
  std::vector<uint64_t> holeKey;
  holeKey.reserve(in.holeFaces.size());
  for (int f : in.holeFaces) holeKey.push_back(faceKeyOf(mesh, f));
  if (in.memo && in.reuseCharts)
    if (auto kept = in.memo->findCovering(in.holeFaces, holeKey, in.photosKey, in.texelsPerUnit, blur)) {
      out.ok = true;
      out.kept = SynthesisKept::Chart;
      out.chart = std::move(kept);
      out.note = "synthesis: " + std::to_string(out.chart->image.cols) + " x " + std::to_string(out.chart->image.rows) +
                 " texel chart kept from an earlier run (it covers the hole)";
      return out;
    }
  auto chart = std::make_shared<SynthesisChart>();
  chart->photosKey = in.photosKey;
  chart->texelsPerUnit = in.texelsPerUnit;
  chart->blur = blur;
  chart->holeFaces = in.holeFaces.size();
  VertexFaces ownVertexFaces;
  if (!in.vertexFaces) ownVertexFaces = facesAroundVertices(mesh);
  const VertexFaces& vertexFaces = in.vertexFaces ? *in.vertexFaces : ownVertexFaces;

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
  // The flattening below depends on the rings' faces and positions only: one that failed before fails again.
  uint64_t ringsKey = 0xf01d;
  for (const auto& r : rings)
    for (int f : r) ringsKey = hashMix(hashMix(ringsKey, f), faceKeyOf(mesh, f));
  const char* foldNote = "synthesis: the hole and its band do not flatten without folds";
  if (in.memo && in.memo->flatteningFailed(ringsKey)) {
    out.note = std::string(foldNote) + " (known from the last run)";
    return out;
  }
  if (in.memo && in.reuseCharts && in.memo->flatteningFailedNear(holeKey)) {
    out.note = std::string(foldNote) + " (a hole sharing nine in ten of its faces did not, in the last run)";
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
    if (in.memo) in.memo->storeFailedFlattening(ringsKey, holeKey);
    out.note = foldNote;
    return out;
  }

  // Canvas: the chart at texelsPerUnit (coarser when it would exceed maxCanvas texels a side).
  Vec2 lo = uv[0], hi = uv[0];
  for (const Vec2& p : uv) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  double scale = in.texelsPerUnit;
  // A blurred synthesis keeps structure only at the scale of the blur: 48 texels across the hole's
  // radius are plenty, and keep shift-map fast on big holes.
  constexpr double kBlurredRadiusTexels = 48;
  if (blur > 0) scale = std::min(scale, kBlurredRadiusTexels / std::max(std::sqrt(holeArea / M_PI), 1e-300));
  const double extent = (hi - lo).maxCoeff();
  if (extent * scale > options.maxCanvas - 4) scale = (options.maxCanvas - 4) / std::max(extent, 1e-300);
  const int width = std::max(8, int(std::ceil((hi.x() - lo.x()) * scale)) + 4);
  const int height = std::max(8, int(std::ceil((hi.y() - lo.y()) * scale)) + 4);
  chart->faceSlot.reserve(faces.size());
  chart->corner.resize(faces.size());
  chart->faceKey.resize(faces.size());
  for (size_t i = 0; i < faces.size(); ++i) {
    chart->faceSlot[faces[i]] = static_cast<int>(i);
    chart->faceKey[i] = i < holeKey.size() ? holeKey[i] : faceKeyOf(mesh, faces[i]);  // the hole comes first
    for (int k = 0; k < 3; ++k) {
      const Vec2 p = (uv[tris[i][k]] - lo) * scale + Vec2(2, 2);
      chart->corner[i][k] = Vec2(p.x(), height - p.y());  // image rows go down; the chart is v up
    }
  }
  out.bandFaces = static_cast<int>(faces.size() - in.holeFaces.size());

  cv::Mat& rgb = chart->rgb;
  cv::Mat& known = chart->known;
  rgb = cv::Mat(height, width, CV_32FC3, cv::Scalar(0, 0, 0));
  known = cv::Mat(height, width, CV_8UC1, cv::Scalar(0));
  int knownPixels = 0;
  for (size_t i = 0; i < faces.size(); ++i) {
    const int f = faces[i];
    if (map.facePhoto[f] < 0) continue;
    const Photo& photo = *in.photos[map.facePhoto[f]];
    scanTriangle(chart->corner[i], width, height, [&](int x, int y, const Vec3& b) {
      if (photo.hasBackground) {
        const auto& c = map.cornerUV[f];
        const Vec2 q = b[0] * c[0] + b[1] * c[1] + b[2] * c[2];
        if (photo.alphaAt(q.x(), q.y()) < 0.5f) return;
      }
      const Vec3f colour = mappedColor(map, in.photos, in.levelling, f, b).cwiseMax(0.f).cwiseMin(1.f);
      rgb.at<cv::Vec3f>(y, x) = cv::Vec3f(colour[0], colour[1], colour[2]);
      if (!known.at<uchar>(y, x)) ++knownPixels;
      known.at<uchar>(y, x) = 255;
    });
  }
  if (knownPixels < 16) {
    out.note = "synthesis: the band around the hole covers no photo texel";
    return out;
  }
  // The canvas's key: the hole's geometry, the canvas's size, scale and known mask, and the blur (the
  // known colours are compared apart, in findExact).
  uint64_t key = hashMix(hashMix(hashMix(hashMix(uint64_t(0x5e17e5), width), height), scale), blur);
  for (uint64_t h : holeKey) key = hashMix(key, h);
  for (int y = 0; y < height; ++y) {
    const uchar* k = known.ptr<uchar>(y);
    for (int x = 0; x < width; x += 8) {
      uint64_t word = 0;
      std::memcpy(&word, k + x, std::min(8, width - x));
      key = hashMix(key, word);
    }
  }
  chart->canvasKey = key;
  const std::string made = "synthesis: " + std::to_string(width) + " x " + std::to_string(height) + " texel chart, " +
                           std::to_string(out.rings) + " rings (" + std::to_string(out.bandFaces) +
                           " faces) of exemplar";
  if (in.memo) {
    // The same canvas: the kept image is what shift-map would return; this run's faces lie over it.
    const cv::Mat kept = in.memo->findExact(key, rgb, known);
    if (!kept.empty()) {
      chart->image = kept;
      in.memo->store(chart);
      out.ok = true;
      out.kept = SynthesisKept::Exact;
      out.chart = std::move(chart);
      out.note = made + ", kept (same canvas)";
      return out;
    }
  }
  // Shift-map works on 8-bit L*a*b* (its patch distances expect a perceptual space).
  const cv::Mat lab = srgbToLab8(rgb);
  // Shift-map is one long call without a cancellation point (up to a second on a big hole): a cancel does not
  // wait for it (runCancellable), so it works on copies of its inputs (cv::Mat headers share their pixels).
  auto shifted = std::make_shared<cv::Mat>();
  runCancellable(job, [lab, known, shifted] { *shifted = shiftMapFill(lab, known); });
  chart->image = lab8ToSrgb(*shifted);
  // Known texels keep their exact (float) colours.
  rgb.copyTo(chart->image, known);
  if (blur > 0) cv::GaussianBlur(chart->image, chart->image, cv::Size(), blur * std::sqrt(holeArea / M_PI) * scale);
  if (in.memo) in.memo->store(chart);
  out.ok = true;
  out.chart = std::move(chart);
  out.note = made;
  return out;
}

}  // namespace montage
