// Projection mapping, view selection and the projection stage (see projection.h).
//
// Choices beyond the outline:
// - Visibility: the mesh is rasterised with the fitted pinhole camera (radial distortion moves pixels
//   along rays from the centre and never changes what is in front). A vertex is seen when the
//   z-buffer at its pixel shows one of its faces, lies within depthTolerance of its depth, or is empty
//   (the vertex is on the silhouette). A face is seen when its centroid passes the same test, at most
//   maxHidden of its three corners and three points near them fail it (one, by default, and only for a
//   face at least silhouetteMarginPx inside the silhouette: a face an ear hides a corner of is seen, and
//   mapped, rather than inpainted; issue 34), and when it faces the camera (cosine >= minCos).
// - Quality of a view of a face (the data term): its projected area in pixels squared (resolution,
//   distance and obliqueness in one figure, as Allene et al. 2008 use it), times a factor falling
//   linearly from 1 to 0.1 within silhouetteMarginPx of the silhouette (rendered from the mesh, and the
//   photo's own foreground edge): there a small camera error mixes in background colours.
// - Refused: a face whose corrected UV triangle is flipped or degenerate relative to its projection,
//   and a face whose UVs (corners or centroid) lie farther than maxBackgroundPx from the photo's
//   foreground (the paper's background restriction).
// - Smoothness: a Potts term per interior edge, weight smoothness x (edge length / mean edge length)
//   x (1 + dE / 10), dE the mean CIE Delta E*uv between the candidate photos at the edge's midpoint:
//   cuts are cheap where the photos agree (seams "fall where the photos agree") and dear where they do
//   not; 10 is a clearly visible colour difference. Data costs are (1 - q / q_best) x face area / mean
//   face area, so the balance does not depend on the mesh's resolution.
#include "mapping/projection.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>
#include <opencv2/imgproc.hpp>
#include <unordered_map>

#include "base/hash.h"
#include "base/job.h"
#include "base/util.h"
#include "geometry/mesh.h"
#include "geometry/predicates.h"
#include "geometry/raster.h"
#include "geometry/stretch.h"
#include "image/photo.h"
#include "io/scene.h"
#include "mapping/partition.h"
#include "mapping/view_select.h"

namespace montage {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double wendland(double r, double support) {
  if (r >= support) return 0;
  const double q = 1 - r / support;
  const double q2 = q * q;
  return q2 * q2 * (4 * r / support + 1);
}

// A camera's intrinsics, pose and size mixed into a hash (base/hash.h).
uint64_t hashCamera(uint64_t h, const Camera& c) {
  for (double x : {c.fx, c.fy, c.cx, c.cy}) h = hashMix(h, x);
  for (int i = 0; i < 9; ++i) h = hashMix(h, c.R.data()[i]);
  return hashMix(hashMix(hashMix(h, c.t), c.width), c.height);
}

double diagonalOf(const Mesh& mesh) {
  Vec3 lo, hi;
  mesh.bounds(lo, hi);
  return (hi - lo).norm();
}

// Nearest-pixel lookup of a CV_32F map, clamped to the image.
float at(const cv::Mat& m, const Vec2& px) {
  const int c = std::clamp(static_cast<int>(std::floor(px.x())), 0, m.cols - 1);
  const int r = std::clamp(static_cast<int>(std::floor(px.y())), 0, m.rows - 1);
  return m.at<float>(r, c);
}

}  // namespace

Vec2 CorrectionField::at(const Vec3& p) const {
  Vec2 d = Vec2::Zero();
  for (size_t i = 0; i < centres.size(); ++i) {
    const double r2 = (p - centres[i]).squaredNorm();
    if (r2 < localSupport[i] * localSupport[i]) d += wendland(std::sqrt(r2), localSupport[i]) * local[i];
  }
  return d;
}

CorrectionField correctionField(const Mesh& mesh, const CameraFit& fit, CorrectionMode mode, double localRadiusPx,
                                double noiseThreshold) {
  CorrectionField field;
  if (mode == CorrectionMode::Off) return field;
  std::vector<Vec2> residual;
  std::vector<double> pixelSize;  // model units per photo pixel at the click's depth
  for (size_t i = 0; i < fit.clicks.size(); ++i) {
    if (!std::isfinite(fit.residual[i])) continue;  // behind the camera: no projection to correct
    if (mode == CorrectionMode::Inliers && !fit.inlier[i]) continue;
    const Vec3 p = mesh.position(fit.clicks[i].vertex);
    field.centres.push_back(p);
    Vec2 r = fit.clicks[i].pixel - fit.reprojected[i];
    if (mode == CorrectionMode::Noise) {  // soft threshold; a click inside it still pins its vertex where the camera
      const double tau = noiseThreshold * fit.noisePx, length = r.norm();  // puts it
      r *= length > tau ? 1 - tau / length : 0.0;
    }
    residual.push_back(r);
    pixelSize.push_back(fit.camera.pinhole.toCamera(p).z() / fit.camera.focal());
  }
  const int n = static_cast<int>(field.centres.size());
  if (n == 0) return field;
  Eigen::MatrixXd r(n, 2);
  for (int i = 0; i < n; ++i) r.row(i) = residual[i].transpose();

  // Local part: exact at every click.
  field.localSupport.resize(n);
  for (int i = 0; i < n; ++i) field.localSupport[i] = std::max(localRadiusPx, 4 * r.row(i).norm()) * pixelSize[i];
  Eigen::MatrixXd phi(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      phi(i, j) = wendland((field.centres[i] - field.centres[j]).norm(), field.localSupport[j]);
  const Eigen::MatrixXd w = phi.partialPivLu().solve(r);
  field.local.assign(n, Vec2::Zero());
  if (w.allFinite())
    for (int i = 0; i < n; ++i) field.local[i] = w.row(i).transpose();
  return field;
}

uint64_t CorrectionField::hash(uint64_t h) const {
  for (size_t i = 0; i < centres.size(); ++i) h = hashMix(hashMix(hashMix(h, centres[i]), local[i]), localSupport[i]);
  h = warp.hash(h);
  for (const auto& outline : outlines) {
    h = hashMix(h, uint64_t(outline.size()));
    for (const Vec2& q : outline) h = hashMix(h, q);
  }
  h = hashMix(h, uint64_t(walls.size()));
  for (const auto& [a, b] : walls) h = hashMix(hashMix(h, uint64_t(a)), uint64_t(b));
  return h;
}

CorrectionField subjectField(const Project& project, const CameraFit& fit, int photo, const SubjectOptions& options) {
  CorrectionField field;
  ImageWarp& warp = field.warp;
  warp.alpha = options.warpAlpha;
  warp.affine = options.affineWarp;
  for (size_t i = 0; i < fit.clicks.size(); ++i) {
    if (!fit.reprojected[i].allFinite()) continue;
    warp.from.push_back(fit.reprojected[i]);
    warp.to.push_back(fit.clicks[i].pixel);
  }
  // The outline: closed chains of this photo. (Its paths are not handles: pinned onto the polygon's straight sides,
  // they pulled the surface inside them along, docs/pipeline.md.)
  for (const FeatureChain& chain : project.chains) {
    if (chain.photo != photo || !chain.closed || chain.points.size() < 3) continue;
    std::vector<Vec2> polygon;
    for (int point : chain.points)
      for (const PhotoPoint& at : project.points[point].at)
        if (at.photo == photo) polygon.push_back(Vec2(at.x, at.y));
    if (polygon.size() >= 3) field.outlines.push_back(std::move(polygon));
  }
  return field;
}

std::vector<std::pair<int, int>> outlineWalls(const Project& project, const Partition& partition, int photo) {
  std::vector<std::pair<int, int>> walls;
  for (const FeatureChain& chain : project.chains) {
    if (chain.photo != photo || !chain.closed || chain.points.size() < 3) continue;
    const size_t n = chain.points.size();
    for (size_t i = 0; i < n; ++i) {
      const int a = chain.points[i], b = chain.points[(i + 1) % n];
      const auto side = std::find_if(partition.paths.begin(), partition.paths.end(), [&](const MeshPath& p) {
        return (p.fromPoint == a && p.toPoint == b) || (p.fromPoint == b && p.toPoint == a);
      });
      if (side == partition.paths.end()) return {};  // the outline is open: its inside is not known on the mesh
      for (size_t k = 1; k < side->vertices.size(); ++k)
        walls.emplace_back(std::min(side->vertices[k - 1], side->vertices[k]),
                           std::max(side->vertices[k - 1], side->vertices[k]));
    }
  }
  std::sort(walls.begin(), walls.end());
  walls.erase(std::unique(walls.begin(), walls.end()), walls.end());
  return walls;
}

bool predictPixel(const CameraFit& fit, const CorrectionField& field, const Vec3& p, Vec2& pixel) {
  if (!fit.camera.project(p, pixel)) return false;
  if (!field.warp.empty()) pixel = field.warp.apply(pixel);
  pixel += field.at(p);
  return true;
}

size_t ViewFrame::bytes() const {
  return raster.depth.size() * sizeof(float) + raster.face.size() * sizeof(int) +
         silhouette.total() * silhouette.elemSize();
}

cv::Mat foregroundDistance(const Photo& photo, int width, int height) {
  cv::Mat inside;
  if (!photo.hasBackground) return inside;
  cv::Mat foreground = photo.alpha > 0;  // stored resolution: brought to the camera's pixels
  if (foreground.cols != width || foreground.rows != height)
    cv::resize(foreground, foreground, cv::Size(width, height), 0, 0, cv::INTER_NEAREST);
  cv::distanceTransform(foreground, inside, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  return inside;
}

ViewFrame viewFrame(const Mesh& input, const Photo& photo, const Camera& cam, const cv::Mat* foreground) {
  TM_CHECK(cam.width == photo.width && cam.height == photo.height,
           located(photo.path, "camera fit is for a " + std::to_string(cam.width) + "x" + std::to_string(cam.height) +
                                   " image, the photo is " + std::to_string(photo.width) + "x" +
                                   std::to_string(photo.height)));
  ViewFrame frame;
  frame.camera = cam;
  RasterOptions depthOnly;
  depthOnly.barycentrics = false;  // the frame is kept across edits: only what views read
  frame.raster = rasterize(input, cam, depthOnly);
  const RasterBuffers& raster = frame.raster;
  // Distance (pixels) to the silhouette: of the rendered mesh, and of the photo's own foreground.
  cv::Mat covered(cam.height, cam.width, CV_8U);
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) covered.at<uchar>(y, x) = raster.face[raster.index(x, y)] >= 0 ? 255 : 0;
  cv::distanceTransform(covered, frame.silhouette, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  if (photo.hasBackground)
    frame.silhouette =
        cv::min(frame.silhouette, foreground && foreground->cols == cam.width && foreground->rows == cam.height
                                      ? *foreground
                                      : foregroundDistance(photo, cam.width, cam.height));
  return frame;
}

std::string ViewFrameCache::photoKey(int photo) const {
  return photo < static_cast<int>(photoKeys.size()) ? photoKeys[photo] : std::to_string(photo);
}

std::shared_ptr<const ViewFrame> ViewFrameCache::frame(int photo, const Mesh& input, const Photo& image,
                                                       const PhotoCamera& camera, double reusePx) {
  const Camera& c = camera.pinhole;
  const std::string photoKey = this->photoKey(photo) + '@' + std::to_string(c.width) + 'x' + std::to_string(c.height);
  std::string key = photoKey;
  auto add = [&key](const void* data, size_t n) { key.append(static_cast<const char*>(data), n); };
  for (double v : {c.fx, c.fy, c.cx, c.cy}) add(&v, sizeof v);
  add(c.R.data(), 9 * sizeof(double));
  add(c.t.data(), 3 * sizeof(double));
  cv::Mat foreground;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    usedForeground_.insert(photoKey);
    if (auto it = used_.find(key); it != used_.end()) return it->second;
    if (auto it = frames_.find(key); it != frames_.end()) {
      ++reused;
      return used_[key] = it->second;
    }
    if (reusePx > 0)  // a frame of the same photo through a camera close enough (keys start with the photo's)
      for (const auto* kept : {&frames_, &used_})
        for (auto it = kept->lower_bound(photoKey);
             it != kept->end() && it->first.compare(0, photoKey.size(), photoKey) == 0; ++it)
          if (it->first.size() == key.size() && cameraShiftPx(input, it->second->camera, c) <= reusePx) {
            ++reused, ++nearReused;  // kept under its own camera's key: an exact request never finds it
            return used_[it->first] = it->second;
          }
    foreground = foreground_[photoKey];
  }
  if (image.hasBackground && foreground.empty()) foreground = foregroundDistance(image, c.width, c.height);
  auto out = std::make_shared<const ViewFrame>(viewFrame(input, image, c, &foreground));
  std::lock_guard<std::mutex> lock(mutex_);
  foreground_[photoKey] = foreground;
  ++computed;
  return used_[key] = out;
}

std::shared_ptr<const PhotoView> ViewFrameCache::view(int photo, uint64_t meshHash, uint64_t settings,
                                                      const std::function<PhotoView(const PhotoView* base)>& make) {
  const std::string byPhoto = photoKey(photo) + '#' + std::to_string(photo) + '#' + std::to_string(settings);
  const std::string key = byPhoto + '#' + std::to_string(meshHash);
  std::shared_ptr<const PhotoView> base;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (auto it = usedViews_.find(key); it != usedViews_.end()) return it->second;
    if (auto it = views_.find(key); it != views_.end()) {
      ++viewsReused;
      return usedLatest_[byPhoto] = usedViews_[key] = it->second;
    }
    if (auto it = latest_.find(byPhoto); it != latest_.end()) base = it->second;
  }
  auto out = std::make_shared<const PhotoView>(make(base.get()));
  std::lock_guard<std::mutex> lock(mutex_);
  return usedLatest_[byPhoto] = usedViews_[key] = out;
}

std::shared_ptr<const ViewMesh> ViewFrameCache::mesh(uint64_t hash, const std::function<ViewMesh()>& make,
                                                     std::shared_ptr<const ViewMesh>& previous) {
  std::lock_guard<std::mutex> lock(mutex_);
  previous = mesh_;
  if (!mesh_ || mesh_->hash != hash) mesh_ = std::make_shared<const ViewMesh>(make());
  return mesh_;
}

void ViewFrameCache::endRun() {
  frames_ = std::move(used_);
  used_.clear();
  views_ = std::move(usedViews_);
  usedViews_.clear();
  latest_ = std::move(usedLatest_);
  usedLatest_.clear();
  for (auto it = foreground_.begin(); it != foreground_.end();)
    it = usedForeground_.count(it->first) ? std::next(it) : foreground_.erase(it);
  usedForeground_.clear();
  reused = computed = nearReused = viewsReused = 0;
}

void ViewFrameCache::clear() {
  std::lock_guard<std::mutex> lock(mutex_);
  frames_.clear(), used_.clear(), views_.clear(), usedViews_.clear(), foreground_.clear(), usedForeground_.clear();
  latest_.clear(), usedLatest_.clear();
  mesh_.reset();
}

ViewMesh viewMesh(const Mesh& mesh, const std::vector<int>& faceParent, uint64_t hash) {
  const int nv = mesh.numVertices(), nf = mesh.numFaces();
  TM_CHECK(static_cast<int>(faceParent.size()) == nf, "viewMesh: faceParent: " + std::to_string(faceParent.size()) +
                                                          " entries for " + std::to_string(nf) + " faces");
  ViewMesh out;
  out.hash = hash;
  out.diagonal = diagonalOf(mesh);
  out.positions.resize(nv);
  out.around.resize(nv);
  out.faces.resize(nf);
  out.faceParent = faceParent;
  for (int f = 0; f < nf; ++f) out.faces[f] = mesh.faceVertices(f);
  const TriMesh& tri = mesh.tri;
  tbb::parallel_for(tbb::blocked_range<int>(0, nv, 2048), [&](const tbb::blocked_range<int>& range) {
    std::vector<int> parents;
    for (int v = range.begin(); v < range.end(); ++v) {
      out.positions[v] = mesh.position(v);
      parents.clear();
      for (auto fh : tri.vf_range(tri.vertex_handle(v))) parents.push_back(faceParent[fh.idx()]);
      std::sort(parents.begin(), parents.end());
      parents.erase(std::unique(parents.begin(), parents.end()), parents.end());
      uint64_t h = hashMix(0, uint64_t(parents.size()));
      for (int p : parents) h = hashMix(h, p);
      out.around[v] = h;
    }
  });
  return out;
}

ViewCarry carryOver(const ViewMesh& from, const ViewMesh& to) {
  ViewCarry c;
  if (from.diagonal != to.diagonal) return c;
  const int nv = static_cast<int>(to.positions.size()), nf = static_cast<int>(to.faces.size());
  c.vertex.assign(nv, -1);
  c.face.assign(nf, -1);
  // from's vertices by position; a position held by two vertices carries neither.
  std::unordered_map<uint64_t, int> at;
  at.reserve(from.positions.size());
  constexpr int kShared = -2;
  for (int v = 0; v < static_cast<int>(from.positions.size()); ++v) {
    const auto [it, fresh] = at.emplace(hashMix(0, from.positions[v]), v);
    if (!fresh) it->second = kShared;
  }
  for (int v = 0; v < nv; ++v) {
    const auto it = at.find(hashMix(0, to.positions[v]));
    if (it == at.end() || it->second < 0) continue;
    const int u = it->second;
    if (from.positions[u] == to.positions[v] && from.around[u] == to.around[v]) c.vertex[v] = u, ++c.vertices;
  }
  // from's faces around each vertex (CSR), to find a face by its first corner.
  std::vector<int> first(from.positions.size() + 1, 0), faces(from.faces.size());
  for (const auto& f : from.faces) ++first[f[0] + 1];
  for (size_t v = 0; v + 1 < first.size(); ++v) first[v + 1] += first[v];
  std::vector<int> fill(first.begin(), first.end() - 1);
  for (int g = 0; g < static_cast<int>(from.faces.size()); ++g) faces[fill[from.faces[g][0]]++] = g;
  for (int f = 0; f < nf; ++f) {
    const auto& t = to.faces[f];
    const std::array<int, 3> corners = {c.vertex[t[0]], c.vertex[t[1]], c.vertex[t[2]]};
    if (corners[0] < 0 || corners[1] < 0 || corners[2] < 0) continue;
    for (int i = first[corners[0]]; i < first[corners[0] + 1]; ++i) {
      const int g = faces[i];
      if (from.faces[g] == corners && from.faceParent[g] == to.faceParent[f]) {
        c.face[f] = g, ++c.faces;
        break;
      }
    }
  }
  return c;
}

PhotoView viewPhoto(const Mesh& mesh, const std::vector<int>& faceParent, const ViewFrame& frame, const Photo& photo,
                    int photoIndex, const CameraFit& fit, const CorrectionField& field, const ProjectionOptions& o,
                    const PhotoView* base, const ViewCarry* carry) {
  PhotoView view;
  view.photo = photoIndex;
  const Camera& cam = fit.camera.pinhole;
  const RasterBuffers& raster = frame.raster;
  const cv::Mat& silhouette = frame.silhouette;
  TM_CHECK(raster.width == cam.width && raster.height == cam.height,
           "viewPhoto: the frame is " + std::to_string(raster.width) + "x" + std::to_string(raster.height) +
               ", the camera " + std::to_string(cam.width) + "x" + std::to_string(cam.height));
  const int nv = mesh.numVertices(), nf = mesh.numFaces();
  TM_CHECK(static_cast<int>(faceParent.size()) == nf, "viewPhoto: faceParent: " + std::to_string(faceParent.size()) +
                                                          " entries for " + std::to_string(nf) + " faces");
  if (!base || !carry || carry->vertex.size() != size_t(nv) || carry->face.size() != size_t(nf)) base = nullptr;
  if (!field.walls.empty()) base = nullptr;  // a region's faces decide together: none is carried alone
  const double tol = o.depthTolerance * diagonalOf(mesh);
  const Vec3 eye = cam.center();
  const TriMesh& tri = mesh.tri;

  // Seen at a pinhole pixel with depth z: the z-buffer (of the input mesh) shows the input face that
  // `face` (or a face of `vertex`) lies in, or something no nearer than z - tol, or nothing.
  auto seenAt = [&](const Vec2& px, double z, int face, int vertex) {
    if (!(px.x() >= 0 && px.y() >= 0 && px.x() < cam.width && px.y() < cam.height)) return false;
    const int i = raster.index(static_cast<int>(px.x()), static_cast<int>(px.y()));
    const int shown = raster.face[i];
    if (shown < 0 || raster.depth[i] >= z - tol) return true;
    if (face >= 0) return faceParent[face] == shown;
    for (auto fh : tri.vf_range(tri.vertex_handle(vertex)))
      if (faceParent[fh.idx()] == shown) return true;
    return false;
  };

  std::vector<Vec2> pinhole(nv, Vec2::Constant(kNaN));
  view.vertexUV.assign(nv, Vec2::Constant(kNaN));
  view.vertexVisible.assign(nv, 0);
  view.vertexSilhouettePx.assign(nv, 0.0f);
  // Vertices, faces and edges each write only their own entries: they run in parallel (the same result).
  tbb::parallel_for(tbb::blocked_range<int>(0, nv, 1024), [&](const tbb::blocked_range<int>& range) {
    for (int v = range.begin(); v < range.end(); ++v) {
      const Vec3 p = mesh.position(v);
      double z = 0;
      Vec2 px;
      if (!cam.project(p, px, &z)) continue;
      pinhole[v] = px;
      if (base && carry->vertex[v] >= 0) {
        const int u = carry->vertex[v];
        view.vertexUV[v] = base->vertexUV[u];
        view.vertexVisible[v] = base->vertexVisible[u];
        view.vertexSilhouettePx[v] = base->vertexSilhouettePx[u];
        continue;
      }
      Vec2 uv;
      if (predictPixel(fit, field, p, uv)) view.vertexUV[v] = uv;
      view.vertexVisible[v] = seenAt(px, z, -1, v) ? 1 : 0;
      if (view.vertexVisible[v]) view.vertexSilhouettePx[v] = at(silhouette, px);
    }
  });

  view.faceQuality.assign(nf, 0.0f);
  const std::array<Vec3, 4> samples = {Vec3(1.0 / 3, 1.0 / 3, 1.0 / 3), Vec3(0.8, 0.1, 0.1), Vec3(0.1, 0.8, 0.1),
                                       Vec3(0.1, 0.1, 0.8)};
  enum : char { kKept, kFlipped, kBackground, kOutside };
  std::vector<char>& refused = view.faceRefused;
  refused.assign(nf, kKept);
  std::vector<signed char> polygonSide(field.walls.empty() ? 0 : nf, 0);  // image inside (1) or outside (-1) an outline
  tbb::parallel_for(tbb::blocked_range<int>(0, nf, 1024), [&](const tbb::blocked_range<int>& range) {
    for (int f = range.begin(); f < range.end(); ++f) {
      if (base && carry->face[f] >= 0) {
        view.faceQuality[f] = base->faceQuality[carry->face[f]];
        refused[f] = base->faceRefused[carry->face[f]];
        continue;
      }
      const auto c = mesh.faceVertices(f);
      int hidden = 0;
      for (int k = 0; k < 3; ++k) hidden += !view.vertexVisible[c[k]] || !pinhole[c[k]].allFinite();
      if (hidden > o.maxHidden) continue;
      const auto q = mesh.facePositions(f);
      const Vec3 centroid = (q[0] + q[1] + q[2]) / 3;
      const Vec3 normal = mesh.faceNormal(f);
      if (normal.dot((eye - centroid).normalized()) < o.minCos) continue;
      bool seen = true;
      double silhouetteDistance = std::numeric_limits<double>::infinity();
      for (size_t s = 0; s < samples.size(); ++s) {
        const Vec3& b = samples[s];
        const Vec3 point = b[0] * q[0] + b[1] * q[1] + b[2] * q[2];
        Vec2 px;
        double z = 0;
        if (!cam.project(point, px, &z) || !seenAt(px, z, f, -1)) {
          if (s == 0 || ++hidden > o.maxHidden) {
            seen = false;
            break;
          }
          continue;
        }
        silhouetteDistance = std::min<double>(silhouetteDistance, at(silhouette, px));
      }
      if (!seen || !pinhole[c[0]].allFinite() || !pinhole[c[1]].allFinite() || !pinhole[c[2]].allFinite()) continue;
      // A face partly hidden near the silhouette would take background colours there: inpainting does better.
      if (hidden > 0 && silhouetteDistance < o.silhouetteMarginPx) continue;
      const std::array<Vec2, 3> uv = {view.vertexUV[c[0]], view.vertexUV[c[1]], view.vertexUV[c[2]]};
      const double projected = cross2(pinhole[c[1]] - pinhole[c[0]], pinhole[c[2]] - pinhole[c[0]]);
      const double mapped = cross2(uv[1] - uv[0], uv[2] - uv[0]);
      if (!std::isfinite(mapped) || projected * mapped <= 0 || std::abs(mapped) < 1e-6) {
        refused[f] = kFlipped;
        continue;
      }
      bool background = false;
      for (const Vec2& x : {uv[0], uv[1], uv[2], Vec2((uv[0] + uv[1] + uv[2]) / 3)}) {
        if (!photo.inside(x.x(), x.y()))
          background = true;
        else if (photo.hasBackground && photo.distanceAt(x.x(), x.y()) > o.maxBackgroundPx)
          background = true;
      }
      if (background) {
        refused[f] = kBackground;
        continue;
      }
      if (!field.outlines.empty()) {
        const Vec2 centre = (uv[0] + uv[1] + uv[2]) / 3;
        const bool inside =
            std::any_of(field.outlines.begin(), field.outlines.end(),
                        [&](const std::vector<Vec2>& polygon) { return insidePolygon(polygon, centre); });
        if (!field.walls.empty()) {
          polygonSide[f] = inside ? 1 : -1;  // its region decides below
        } else if (!inside) {
          refused[f] = kOutside;
          continue;
        }
      }
      const double factor = std::clamp(silhouetteDistance / std::max(1e-9, o.silhouetteMarginPx), 0.1, 1.0);
      view.faceQuality[f] = static_cast<float>(0.5 * std::abs(mapped) * factor);
      if (!(view.faceQuality[f] > 0)) view.faceQuality[f] = std::numeric_limits<float>::min();
    }
  });
  if (!field.walls.empty()) {
    // Regions between the walls: one maps whole when most of its mapped faces' images lie inside an outline.
    auto isWall = [&](OpenMesh::SmartHalfedgeHandle h) {
      const int a = h.from().idx(), b = h.to().idx();
      return std::binary_search(field.walls.begin(), field.walls.end(), std::make_pair(std::min(a, b), std::max(a, b)));
    };
    std::vector<int> region(nf, -1), stack;
    for (int seed = 0; seed < nf; ++seed) {
      if (region[seed] >= 0) continue;
      std::vector<int> members;
      int vote = 0;
      region[seed] = seed;
      stack.push_back(seed);
      while (!stack.empty()) {
        const int f = stack.back();
        stack.pop_back();
        members.push_back(f);
        vote += polygonSide[f];
        for (auto h : tri.fh_range(tri.face_handle(f))) {
          const auto g = h.opp().face();
          if (!g.is_valid() || region[g.idx()] >= 0 || isWall(h)) continue;
          region[g.idx()] = seed;
          stack.push_back(g.idx());
        }
      }
      if (vote > 0) continue;
      for (int f : members)
        if (polygonSide[f] != 0) refused[f] = kOutside, view.faceQuality[f] = 0;
    }
  }
  view.refusedFlipped = static_cast<int>(std::count(refused.begin(), refused.end(), kFlipped));
  view.refusedBackground = static_cast<int>(std::count(refused.begin(), refused.end(), kBackground));
  view.refusedOutline = static_cast<int>(std::count(refused.begin(), refused.end(), kOutside));
  view.edgeLuv.assign(tri.n_edges(), Vec3f::Zero());
  tbb::parallel_for(tbb::blocked_range<int>(0, int(tri.n_edges()), 1024), [&](const tbb::blocked_range<int>& range) {
    for (int e = range.begin(); e < range.end(); ++e) {
      const OpenMesh::EdgeHandle eh(e);
      if (tri.is_boundary(eh)) continue;
      const auto h = tri.halfedge_handle(eh, 0);
      if (!(view.faceQuality[tri.face_handle(h).idx()] > 0) ||
          !(view.faceQuality[tri.opposite_face_handle(h).idx()] > 0))
        continue;
      const Vec2 mid =
          0.5 * (view.vertexUV[tri.from_vertex_handle(h).idx()] + view.vertexUV[tri.to_vertex_handle(h).idx()]);
      view.edgeLuv[e] = photo.luvAt(mid.x(), mid.y());
    }
  });
  return view;
}

namespace {

// Normalised L2 stretch (Sander et al. 2001) of the faces `use` selects under per-corner UVs (pixels, y down): 1 for
// a map that is isometric up to scale. 0 when it selects none.
template <class UV>
double normalisedStretch(const Mesh& mesh, const std::vector<char>& use, UV&& uvOf) {
  double sum = 0, area3 = 0, areaUV = 0;
  for (int f = 0; f < mesh.numFaces(); ++f) {
    if (!use[f]) continue;
    const auto q = mesh.facePositions(f);
    std::array<Vec2, 3> uv = uvOf(f);
    for (Vec2& x : uv) x.y() = -x.y();
    const TriangleStretch st = triangleStretch(q, uv);
    if (st.flipped || !std::isfinite(st.l2())) continue;
    const double a = mesh.faceArea(f);
    sum += st.l2() * st.l2() * a;
    area3 += a;
    areaUV += 0.5 * std::abs(cross2(uv[1] - uv[0], uv[2] - uv[0]));
  }
  return area3 > 0 ? std::sqrt(sum / area3) * std::sqrt(areaUV / area3) : 0;
}

}  // namespace

SubjectChoice chooseSubjectMap(const Mesh& mesh, const TextureMap& paperMap, const PhotoView& view,
                               const CorrectionField& field, const CameraFit& fit, const SubjectOptions& o) {
  SubjectChoice c;
  c.photo = view.photo;
  const int nf = mesh.numFaces();
  double total = 0;
  std::vector<char> warped(nf, 0), paper(nf, 0);
  for (int f = 0; f < nf; ++f) {
    const double a = mesh.faceArea(f);
    total += a;
    if (view.faceQuality[f] > 0) warped[f] = 1, ++c.warpFaces, c.warpArea += a;
    if (view.faceRefused[f] == 1) ++c.warpFolds;
    // The paper's map is compared where the camera sees the surface (its hidden faces show nothing).
    const bool seen = view.faceQuality[f] > 0 || view.faceRefused[f] != 0;
    if (paperMap.facePhoto[f] == view.photo && seen) paper[f] = 1, ++c.paperFaces, c.paperArea += a;
  }
  if (total > 0) c.warpArea /= total, c.paperArea /= total;
  c.warpStretch = normalisedStretch(mesh, warped, [&](int f) {
    const auto v = mesh.faceVertices(f);
    return std::array<Vec2, 3>{view.vertexUV[v[0]], view.vertexUV[v[1]], view.vertexUV[v[2]]};
  });
  c.paperStretch = normalisedStretch(mesh, paper, [&](int f) { return paperMap.cornerUV[f]; });
  std::vector<double> heldOut;
  const int clicks = static_cast<int>(
      std::count_if(fit.reprojected.begin(), fit.reprojected.end(), [](const Vec2& x) { return x.allFinite(); }));
  for (int i = 0; i < clicks && clicks >= 3; ++i) heldOut.push_back(field.warp.heldOut(i).norm());
  if (!heldOut.empty()) {
    std::sort(heldOut.begin(), heldOut.end());
    c.heldOutMedianPx = heldOut[heldOut.size() / 2];
    c.heldOutMaxPx = heldOut.back();
  }
  const double foldShare = double(c.warpFolds) / std::max(1, c.warpFaces + c.warpFolds);
  const std::string figures = " (warp: " + std::to_string(c.warpFaces) + " faces, " + formatFixed(100 * c.warpArea, 1) +
                              "% of the surface, stretch " + formatFixed(c.warpStretch, 2) + ", " +
                              std::to_string(c.warpFolds) + " folds; paper: " + std::to_string(c.paperFaces) +
                              " faces, " + formatFixed(100 * c.paperArea, 1) + "%, stretch " +
                              formatFixed(c.paperStretch, 2) + ")";
  if (c.warpFaces == 0) {
    c.why = "the camera and warp map no face inside the photo's outline" + figures;
  } else if (foldShare > o.maxFoldShare) {
    c.why = "the warp folds " + formatFixed(100 * foldShare, 1) + "% of its faces" + figures;
  } else if (c.paperFaces > 0 && c.warpStretch > o.stretchRatio * c.paperStretch && c.paperArea >= c.warpArea) {
    c.why = "the paper's map covers as much with less stretch" + figures;
  } else {
    c.warp = true;
    c.why = "camera and warp: " +
            (c.warpFolds == 0 ? std::string("no folds, ")
                              : formatFixed(100 * foldShare, 1) + "% folds (at most " +
                                    formatFixed(100 * o.maxFoldShare, 1) + "% allowed), ") +
            std::string(c.paperFaces == 0                 ? "the paper's map covers nothing"
                        : c.warpStretch <= c.paperStretch ? "less stretch"
                        : c.warpArea >= c.paperArea       ? "it covers more"
                                                          : "stretch within " + formatFixed(o.stretchRatio, 1) + "x") +
            figures;
  }
  return c;
}

ProjectionResult projectionFill(const Scene& scene, const Partition& partition, const TextureMap& paperMap,
                                const std::vector<CameraFit>& fits, const ProjectionOptions& o, const JobControl& job,
                                ViewFrameCache* cache, const std::vector<int>* startLabels,
                                const ProjectionResult* previous) {
  const auto start = Clock::now();
  const Mesh& mesh = partition.mesh;
  const int nf = mesh.numFaces();
  const int np = static_cast<int>(scene.photos.size());
  TM_CHECK(static_cast<int>(fits.size()) == np,
           "projectionFill: " + std::to_string(fits.size()) + " camera fits for " + std::to_string(np) + " photos");
  TM_CHECK(paperMap.numFaces() == nf, "projectionFill: the texture map is not over the partition's mesh");
  ProjectionResult out;
  out.map = paperMap;
  out.fields.resize(np);
  out.views.resize(np);
  out.photoFaces.assign(np, 0);
  out.photoProjectedFaces.assign(np, 0);
  out.photoRefusedFlipped.assign(np, 0);
  out.photoRefusedBackground.assign(np, 0);
  out.projected.assign(np, 0);
  std::vector<int> fitted;  // photos with a camera: the object itself, or another subject (its warp a candidate)
  for (int p = 0; p < np; ++p)
    if (fits[p].fits) fitted.push_back(p);
  auto countFaces = [&] {
    for (int f = 0; f < nf; ++f)
      if (out.map.facePhoto[f] >= 0) ++out.photoFaces[out.map.facePhoto[f]];
  };
  auto notes = [&] {
    for (int p = 0; p < np; ++p) {
      std::string note = "photo " + std::to_string(p);
      if (out.projected[p])
        note += " maps by projection: " + describeFit(fits[p]);
      else if (fits[p].subject)
        note += " takes the paper's path (another subject)";
      else
        note += " takes the paper's path: " + fits[p].reason;
      out.map.notes.push_back(note);
    }
  };
  if (fitted.empty()) {
    notes();
    countFaces();
    out.seconds = secondsSince(start);
    return out;
  }

  // Views of the fitted photos: frames first (from the cache), then the views, each in parallel.
  auto t = Clock::now();
  std::vector<std::shared_ptr<const ViewFrame>> frames(np);
  job.progress(StageId::Projection, 0.0, "views of " + std::to_string(fitted.size()) + " photos");
  tbb::parallel_for(size_t(0), fitted.size(), [&](size_t k) {
    const int p = fitted[k];
    frames[p] =
        cache ? cache->frame(p, *scene.mesh, *scene.photos[p], fits[p].camera, o.reuseFramePx)
              : std::make_shared<const ViewFrame>(viewFrame(*scene.mesh, *scene.photos[p], fits[p].camera.pinhole));
  });
  if (cache) out.framesReused = cache->reused, out.framesNear = cache->nearReused;
  out.frameSeconds = secondsSince(t);
  job.checkCancel();
  // What every view reads besides its photo and camera: the refined mesh and the view options.
  uint64_t options = 0;
  if (cache) {
    uint64_t h = 0;
    for (int v = 0; v < mesh.numVertices(); ++v) h = hashMix(h, mesh.position(v));
    for (int f = 0; f < nf; ++f) {
      for (int v : mesh.faceVertices(f)) h = hashMix(h, v);
      h = hashMix(h, partition.faceParent[f]);
    }
    out.meshHash = h;
    for (double x : {o.depthTolerance, o.minCos, o.silhouetteMarginPx, o.maxBackgroundPx, double(o.maxHidden)})
      options = hashMix(options, x);
  }
  // A view made anew takes what it can from the last view of its photo and settings on another mesh
  // (ViewFrameCache::view), when that mesh is the one the cache kept a ViewMesh of (the last mesh views were
  // made on): this mesh's ViewMesh and the carry from that one are made once.
  std::mutex carryMutex;
  std::shared_ptr<const ViewMesh> current, lastMesh;
  std::shared_ptr<const ViewCarry> fromLast;
  auto carryFrom = [&](const PhotoView* base) -> std::shared_ptr<const ViewCarry> {
    if (!cache->carryViews) return nullptr;
    std::lock_guard<std::mutex> lock(carryMutex);
    if (!current)
      current = cache->mesh(
          out.meshHash, [&] { return viewMesh(mesh, partition.faceParent, out.meshHash); }, lastMesh);
    if (!base || !lastMesh || base->meshHash != lastMesh->hash || base->meshHash == out.meshHash) return nullptr;
    if (!fromLast) fromLast = std::make_shared<const ViewCarry>(carryOver(*lastMesh, *current));
    return fromLast;
  };
  std::vector<char> carried(np, 0);  // views made this run from a carry that took some entries
  tbb::parallel_for(size_t(0), fitted.size(), [&](size_t k) {
    const int p = fitted[k];
    out.fields[p] = fits[p].subject ? subjectField(scene.project, fits[p], p)
                                    : correctionField(mesh, fits[p], o.correction, o.localRadiusPx, o.noiseThreshold);
    if (!out.fields[p].outlines.empty()) out.fields[p].walls = outlineWalls(scene.project, partition, p);
    if (cache) {
      const PhotoCamera& c = fits[p].camera;
      // The frame's own camera too: a frame within reuseFramePx makes another view.
      const uint64_t h = out.fields[p].hash(
          hashMix(hashMix(hashCamera(hashCamera(options, frames[p]->camera), c.pinhole), c.k1), c.k2));
      out.views[p] = cache->view(p, out.meshHash, h, [&](const PhotoView* base) {
        const std::shared_ptr<const ViewCarry> carry = carryFrom(base);
        carried[p] = carry && carry->vertices + carry->faces > 0;
        PhotoView view = viewPhoto(mesh, partition.faceParent, *frames[p], *scene.photos[p], p, fits[p], out.fields[p],
                                   o, carry ? base : nullptr, carry.get());
        view.meshHash = out.meshHash;
        return view;
      });
    } else {
      out.views[p] = std::make_shared<const PhotoView>(
          viewPhoto(mesh, partition.faceParent, *frames[p], *scene.photos[p], p, fits[p], out.fields[p], o));
    }
    out.photoRefusedFlipped[p] = out.views[p]->refusedFlipped;
    out.photoRefusedBackground[p] = out.views[p]->refusedBackground;
  });
  if (cache) out.viewsReused = cache->viewsReused;
  // Every carried view took the one carry from the last mesh.
  out.viewsCarried = static_cast<int>(std::count(carried.begin(), carried.end(), 1));
  if (out.viewsCarried > 0) out.carriedShare = double(fromLast->vertices + fromLast->faces) / (mesh.numVertices() + nf);
  out.viewSeconds = secondsSince(t);

  // Photos of another subject: the warp, or the paper's map where that maps with less error.
  for (int p : fitted) {
    if (!fits[p].subject) {
      out.projected[p] = 1;
      continue;
    }
    SubjectChoice choice = chooseSubjectMap(mesh, paperMap, *out.views[p], out.fields[p], fits[p]);
    out.projected[p] = choice.warp;
    if (!choice.warp) {
      out.views[p] = nullptr;
      out.fields[p] = {};
      out.photoRefusedFlipped[p] = out.photoRefusedBackground[p] = 0;
    }
    out.subjects.push_back(std::move(choice));
  }
  fitted.erase(std::remove_if(fitted.begin(), fitted.end(), [&](int p) { return !out.projected[p]; }), fitted.end());
  out.fittedPhotos = static_cast<int>(fitted.size());
  notes();
  if (fitted.empty()) {
    countFaces();
    out.seconds = secondsSince(start);
    return out;
  }
  job.progress(StageId::Projection, 0.6, "view selection");

  // The preview: faces whose views barely changed since the last run keep its labels (see projectionFill).
  t = Clock::now();
  std::vector<char> keep;  // per face; empty when every face is selected
  if (previous && startLabels && out.meshHash != 0 && previous->meshHash == out.meshHash &&
      static_cast<int>(previous->faceLabels.size()) == nf && previous->views.size() == out.views.size()) {
    bool sameFits = true;
    for (int p = 0; p < np; ++p) sameFits = sameFits && !previous->views[p] == !out.views[p];
    if (sameFits) {
      const TriMesh& tri = mesh.tri;
      std::vector<char> changed(nf, 0);
      for (int p : fitted) {
        if (previous->views[p] == out.views[p]) continue;
        const PhotoView &a = *previous->views[p], &b = *out.views[p];
        for (int f = 0; f < nf; ++f) {
          const float qa = a.faceQuality[f], qb = b.faceQuality[f];
          if ((qa > 0) != (qb > 0) || std::abs(qa - qb) > kStillQuality * std::max(qa, qb)) changed[f] = 1;
        }
        for (auto eh : tri.edges()) {
          if (tri.is_boundary(eh)) continue;
          const auto h = tri.halfedge_handle(eh, 0);
          const int f = tri.face_handle(h).idx(), g = tri.opposite_face_handle(h).idx();
          if (b.faceQuality[f] > 0 && b.faceQuality[g] > 0 && a.faceQuality[f] > 0 && a.faceQuality[g] > 0 &&
              (a.edgeLuv[eh.idx()] - b.edgeLuv[eh.idx()]).norm() > kStillDeltaE)
            changed[f] = changed[g] = 1;
        }
      }
      for (int ring = 0; ring < 2; ++ring) {
        std::vector<char> grown = changed;
        for (int f = 0; f < nf; ++f)
          if (changed[f])
            for (auto g : tri.ff_range(tri.face_handle(f))) grown[g.idx()] = 1;
        changed.swap(grown);
      }
      keep.assign(nf, 0);
      for (int f = 0; f < nf; ++f) keep[f] = !changed[f];
    }
  }

  // Labels: photo indices (0..np-1), and np for "empty".
  const int kEmptyLabel = np;
  PottsProblem problem;
  problem.numNodes = nf;
  problem.numLabels = np + 1;
  problem.cost.assign(size_t(nf) * problem.numLabels, PottsProblem::kForbidden);
  std::vector<int> labels(nf, -1);
  std::vector<char> free(nf, 0);
  double meanArea = 0;
  for (int f = 0; f < nf; ++f) meanArea += mesh.faceArea(f);
  meanArea = nf ? meanArea / nf : 1;
  if (!(meanArea > 0)) meanArea = 1;
  for (int f = 0; f < nf; ++f) {
    auto cost = [&](int label) -> double& { return problem.cost[size_t(f) * problem.numLabels + label]; };
    const int paper = paperMap.facePhoto[f];
    if (paper >= 0 && !out.projected[paper]) {  // the paper's path: fixed
      cost(paper) = 0;
      labels[f] = paper;
      continue;
    }
    float best = 0;
    for (int p : fitted) best = std::max(best, out.views[p]->faceQuality[f]);
    if (!(best > 0)) {  // no fitted photo can texture it
      cost(kEmptyLabel) = 0;
      labels[f] = kEmptyLabel;
      continue;
    }
    ++out.seenFaces;
    if (!keep.empty() && keep[f]) {  // the preview: keeps the last run's photo where it still may
      const int last = previous->faceLabels[f];
      const float q = last >= 0 && last < np ? out.views[last] ? out.views[last]->faceQuality[f] : 0.0f : 0.0f;
      if (q > 0) {
        cost(last) = 0;
        labels[f] = last;
        ++out.selectionKept;
        continue;
      }
    }
    free[f] = 1;
    const double area = mesh.faceArea(f) / meanArea;
    for (int p : fitted) {
      const float q = out.views[p]->faceQuality[f];
      if (q > 0) cost(p) = (1.0 - q / best) * area;
    }
    if (startLabels) {
      const int parent = partition.faceParent[f];
      const int start = parent < static_cast<int>(startLabels->size()) ? (*startLabels)[parent] : -1;
      if (start >= 0 && start <= kEmptyLabel && std::isfinite(cost(start))) labels[f] = start;
    }
  }
  // Smoothness over interior edges.
  const TriMesh& tri = mesh.tri;
  double meanLength = 0;
  int interior = 0;
  for (auto eh : tri.edges()) {
    if (tri.is_boundary(eh)) continue;
    meanLength += tri.calc_edge_length(eh);
    ++interior;
  }
  meanLength = interior ? meanLength / interior : 1;
  if (!(meanLength > 0)) meanLength = 1;
  if (o.smoothness > 0) {
    std::vector<Vec3f> colours;
    for (auto eh : tri.edges()) {
      if (tri.is_boundary(eh)) continue;
      const auto h0 = tri.halfedge_handle(eh, 0);
      const int f = tri.face_handle(h0).idx(), g = tri.opposite_face_handle(h0).idx();
      if (!free[f] && !free[g]) continue;
      // Mean colour difference between the photos that can texture both faces, at the edge's midpoint.
      colours.clear();
      for (int p : fitted)
        if (out.views[p]->faceQuality[f] > 0 && out.views[p]->faceQuality[g] > 0)
          colours.push_back(out.views[p]->edgeLuv[eh.idx()]);
      double disagreement = 0;
      int pairs = 0;
      for (size_t i = 0; i < colours.size(); ++i)
        for (size_t j = i + 1; j < colours.size(); ++j) disagreement += (colours[i] - colours[j]).norm(), ++pairs;
      if (pairs) disagreement /= pairs;
      const double w = o.smoothness * tri.calc_edge_length(eh) / meanLength * (1 + disagreement / 10.0);
      problem.edges.push_back({f, g});
      problem.weights.push_back(w);
    }
  }
  job.checkCancel();
  PottsStats stats;
  labels = solvePotts(problem, labels, o.maxSweeps, &stats);
  out.selectionSweeps = stats.sweeps;
  out.selectionEnergy = stats.finalEnergy;
  out.selectSeconds = secondsSince(t);

  // The map: projection UVs for faces on fitted photos; paper UVs for the others.
  int nextPatch = 0;
  for (int p : paperMap.facePatch) nextPatch = std::max(nextPatch, p + 1);
  std::vector<int> patchOf(nf, -1);
  for (int f = 0; f < nf; ++f) {
    const int label = labels[f];
    const int paper = paperMap.facePhoto[f];
    if (label < 0 || label == kEmptyLabel) {
      if (paper >= 0) ++out.droppedFaces;
      out.map.facePhoto[f] = TextureMap::kEmpty;
      ++out.emptyFaces;
      continue;
    }
    if (!out.projected[label]) continue;  // paper's path, unchanged
    if (paper == TextureMap::kEmpty)
      ++out.filledFaces;
    else if (paper != label)
      ++out.relabelledFaces;
    out.map.facePhoto[f] = label;
    const auto c = mesh.faceVertices(f);
    for (int k = 0; k < 3; ++k) out.map.cornerUV[f][k] = out.views[label]->vertexUV[c[k]];
    ++out.photoProjectedFaces[label];
  }
  out.faceLabels.assign(nf, -1);
  for (int f = 0; f < nf; ++f)
    if (labels[f] >= 0 && labels[f] < np && out.projected[labels[f]]) out.faceLabels[f] = labels[f];
  // Patch ids of projected faces: edge-connected sets of faces on one photo.
  for (int f = 0; f < nf; ++f) {
    const int label = out.map.facePhoto[f];
    if (label < 0 || !out.projected[label] || patchOf[f] >= 0) continue;
    std::vector<int> stack = {f};
    patchOf[f] = nextPatch;
    while (!stack.empty()) {
      const int g = stack.back();
      stack.pop_back();
      out.map.facePatch[g] = nextPatch;
      for (auto fh : tri.ff_range(tri.face_handle(g))) {
        const int h = fh.idx();
        if (patchOf[h] < 0 && out.map.facePhoto[h] == label) {
          patchOf[h] = nextPatch;
          stack.push_back(h);
        }
      }
    }
    ++nextPatch;
  }
  countFaces();
  out.seconds = secondsSince(start);
  job.progress(StageId::Projection, 1.0);
  return out;
}

}  // namespace montage
