#include "pipeline.h"

#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <functional>
#include <limits>
#include <map>
#include <opencv2/imgproc.hpp>
#include <set>
#include <sstream>

#include "base/fileio.h"
#include "base/hash.h"
#include "base/util.h"
#include "bench/deform.h"
#include "geometry/predicates.h"
#include "image/cutout.h"
#include "io/mesh_anchors.h"
#include "io/mesh_io.h"
#include "io/project_warnings.h"
#include "mapping/simplify.h"
#include "surface/preview.h"

namespace fs = std::filesystem;

namespace montage {

namespace {

// Identifies a file's current contents cheaply: path, size and modification time.
std::string fileKey(const std::string& path) {
  std::error_code ec;
  const auto size = fs::file_size(path, ec);
  const auto time = fs::last_write_time(path, ec).time_since_epoch().count();
  std::ostringstream key;
  key << path << '|' << size << '|' << time;
  return key.str();
}

// A photo's file identity (paths and times): the key of a document state's results, never of a seed.
std::string photoFileKey(const PhotoRef& ref, const PipelineOptions& options) {
  return fileKey(ref.path) + "|mask:" + (ref.mask.empty() ? "" : fileKey(ref.mask)) +
         "|side:" + std::to_string(options.maxPhotoSide) + (ref.mirror ? "|mirror" : "");
}

// photoContentKey with the file hashes from `hashOf` (which may throw montage::Error).
template <class HashOf>
std::string photoContentKeyWith(const PhotoRef& ref, const PipelineOptions& options, HashOf&& hashOf) {
  std::string key;
  try {
    key = "photo:" + hashOf(ref.path) + "|mask:" + (ref.mask.empty() ? "" : hashOf(ref.mask));
  } catch (const Error&) {
    return "unreadable:" + ref.path;
  }
  return key + "|side:" + std::to_string(options.maxPhotoSide) + (ref.mirror ? "|mirror" : "");
}

// A photo that could not be loaded: 1 x 1 and all background, so that nothing maps into it.
std::shared_ptr<const Photo> placeholderPhoto(const PhotoRef& ref) {
  auto photo = std::make_shared<Photo>();
  photo->path = ref.path;
  photo->maskPath = ref.mask;
  photo->mirrored = ref.mirror;
  photo->width = photo->height = 1;
  photo->rgb = cv::Mat::zeros(1, 1, CV_8UC3);
  photo->alpha = cv::Mat::zeros(1, 1, CV_8UC1);
  photo->distance = cv::Mat(1, 1, CV_32FC1, cv::Scalar(1e6));
  photo->hasBackground = true;
  return photo;
}

std::string photoName(const Project& project, int i) {
  return "photo " + std::to_string(i) + " '" + fs::path(project.photos[i].path).filename().string() + "'";
}

std::vector<std::pair<int, int>> photoSizes(const std::vector<std::shared_ptr<const Photo>>& photos) {
  std::vector<std::pair<int, int>> sizes;
  for (const auto& p : photos) sizes.emplace_back(p->width, p->height);
  return sizes;
}

// The checks of the clones that the inpaint stage would make, done at load so that `montage info` and
// `run` reject the same projects: the projection frame (anchor on the target, a mean plane, an area)
// and a polygon that meets the projected target inside the photo.
void checkClones(const Project& project, const Mesh& mesh, const std::vector<std::shared_ptr<const Photo>>& photos) {
  const std::string file = project.file.empty() ? "project" : project.file;
  for (size_t c = 0; c < project.clones.size(); ++c) {
    const CloneOp& clone = project.clones[c];
    const std::string path = "clones[" + std::to_string(c) + "]";
    const CloneProjection proj = projectClone(mesh, {}, clone, located(file, path));
    const Photo& photo = *photos[clone.photo];
    const auto inTriangle = [](const std::array<Vec2, 3>& t, const Vec2& p) {
      const double a = orient2(t[0], t[1], p), b = orient2(t[1], t[2], p), d = orient2(t[2], t[0], p);
      return (a >= 0 && b >= 0 && d >= 0) || (a <= 0 && b <= 0 && d <= 0);
    };
    bool meets = false;
    for (size_t f = 0; f < proj.cornerPixel.size() && !meets; ++f) {
      const auto& t = proj.cornerPixel[f];
      std::vector<Vec2> candidates(t.begin(), t.end());
      for (const Vec2& q : clone.polygon)
        if (inTriangle(t, q)) candidates.push_back(q);
      for (size_t k = 0; k < clone.polygon.size(); ++k)  // edge crossings
        for (int e = 0; e < 3; ++e) {
          const Vec2 &a = clone.polygon[k], &b = clone.polygon[(k + 1) % clone.polygon.size()];
          const double d1 = orient2(a, b, t[e]), d2 = orient2(a, b, t[(e + 1) % 3]);
          if ((d1 > 0) != (d2 > 0) && d1 != d2) candidates.push_back(t[e] + (t[(e + 1) % 3] - t[e]) * (d1 / (d1 - d2)));
        }
      for (const Vec2& q : candidates)
        meets =
            meets ||
            (photo.inside(q.x(), q.y()) && inTriangle(t, q) &&
             (insidePolygon(clone.polygon, q) || std::any_of(clone.polygon.begin(), clone.polygon.end(),
                                                             [&](const Vec2& v) { return (v - q).norm() < 1e-9; })));
    }
    TM_CHECK(meets, located(file, path + ": the polygon maps onto no point of the target region inside the photo "
                                         "(check the anchor, the scale and the rotation)"));
  }
}

}  // namespace

std::string photoContentKey(const PhotoRef& ref, const PipelineOptions& options) {
  return photoContentKeyWith(ref, options, fileContentHashHex);
}

std::string Pipeline::contentHash(const std::string& path) {
  const std::string identity = fileKey(path);
  if (auto it = contentHashes_.find(identity); it != contentHashes_.end()) return it->second;
  std::string hash = fileContentHashHex(path);
  if (contentHashes_.size() > 256) contentHashes_.clear();  // bounded: a long session relinks photos
  contentHashes_.emplace(identity, hash);
  return hash;
}

std::shared_ptr<const Scene> loadScene(const Project& project, const JobControl& job) {
  Pipeline pipeline;
  bool cached = false;
  return pipeline.loadScene(project, job, cached);
}

namespace {

// What identifies the content of the scene's photo i (Scene::photoKeys); 0 when it is unknown.
uint64_t photoKeyOf(const Scene& scene, size_t i) {
  return i < scene.photoKeys.size() && !scene.photoKeys[i].empty()
             ? hashMix(0x9407051, static_cast<uint64_t>(std::hash<std::string>{}(scene.photoKeys[i])))
             : 0;
}

// ... of all the scene's photos; 0 when one is unknown.
uint64_t photosKeyOf(const Scene& scene) {
  if (scene.photoKeys.size() != scene.photos.size()) return 0;
  uint64_t h = 0x9407051;
  for (size_t i = 0; i < scene.photos.size(); ++i) {
    const uint64_t key = photoKeyOf(scene, i);
    if (!key) return 0;
    h = hashMix(h, key);
  }
  return h;
}

CameraFitOptions cameraFitOptions(const PipelineOptions& o) {
  CameraFitOptions options;
  options.thresholdFraction = o.cameraThreshold;
  options.seed = o.seed;
  return options;
}

constexpr const char* kWarm = "#warm";      // camera keys of the preview's warm-started fits
constexpr const char* kPooled = "#pooled";  // camera keys of fits whose lens terms the photos of a camera pay for

// The fit's options; `warm`: the preview's warm start, with one silhouette round instead of the final's four, on
// kept contours within kPreviewContourPx, stopping at a coarser step (1e-6 moves a point by well under 0.01 px:
// half the LM iterations of the final's 1e-10), and no lens trial on the silhouette (the last camera keeps its terms).
CameraFitOptions photoFitOptions(const PipelineOptions& o, bool warm) {
  CameraFitOptions options = cameraFitOptions(o);
  if (warm)
    options.silhouetteRounds = 1, options.contourReusePx = kPreviewContourPx, options.silhouetteStep = 1e-6,
    options.silhouetteSampleStride = 2, options.silhouetteLens = false;
  return options;
}

// One photo's fit (or the reason there is none) under the project's options. `start`: the preview's
// warm start (see fitCamera and photoFitOptions; `contours`, the photo's memo). `refine`: refined on the photo's
// silhouette (else the caller does it, after the bundle adjustment of its camera's photos).
CameraFit fitPhoto(const Scene& scene, int photo, const SilhouetteDistance* silhouette, ContourMemo* contours,
                   const PhotoCamera* start = nullptr, bool keepRadial = false, bool refine = true) {
  const Photo& p = *scene.photos[photo];
  std::vector<CameraClick> clicks = photoClicks(scene.project, photo);
  if (scene.project.options.cameraMode == CameraMode::Off) {
    CameraFit fit;
    fit.clicks = std::move(clicks);
    fit.reprojected.assign(fit.clicks.size(), Vec2::Constant(std::numeric_limits<double>::quiet_NaN()));
    fit.residual.assign(fit.clicks.size(), std::numeric_limits<double>::infinity());
    fit.inlier.assign(fit.clicks.size(), 0);
    fit.reason = "camera fit is off (options.cameraMode)";
    return fit;
  }
  CameraFitOptions options = photoFitOptions(scene.project.options, start != nullptr);
  options.keepRadial = keepRadial;
  options.focalPriorPx = p.exif.focalPx(cv::Size(p.width, p.height));
  CameraFit fit = fitCamera(*scene.mesh, clicks, p.width, p.height, options, start);
  // What the photo shows: the user's word, or decided from the clicks (subject.h).
  const PhotoMode mode = scene.project.photos[photo].mode;
  PhotoMode use = mode;
  std::string decision;
  if (mode == PhotoMode::Auto) {
    const ModeDecision d =
        decidePhotoMode(*scene.mesh, p, clicks, fit, options, {}, scene.project.options.foundSilhouettes);
    use = d.mode;
    decision = "auto: " + d.why;
  } else {
    decision =
        mode == PhotoMode::Object ? "the object itself (the photo's mode)" : "another subject (the photo's mode)";
  }
  if (use == PhotoMode::Subject) {
    CameraFit s = fitCameraToEveryClick(*scene.mesh, clicks, p.width, p.height, options, fit);
    s.decision = decision;
    return s;
  }
  if (start && !fit.fits) return fitPhoto(scene, photo, silhouette, contours, nullptr, keepRadial, refine);  // too far
  if (refine) refineOnSilhouette(*scene.mesh, p, fit, options, silhouette, contours);
  fit.decision = decision;
  return fit;
}

// Point `index` of `project` by the id the user sees (deleting a point renumbers no other).
int reportedPointId(const Project* project, int index) {
  return project && index >= 0 && index < static_cast<int>(project->points.size()) ? pointId(*project, index) : index;
}

nlohmann::json fitJson(const CameraFit& fit, int photo, const Project* project) {
  nlohmann::json outliers = nlohmann::json::array();
  for (size_t i = 0; i < fit.clicks.size(); ++i)
    if (fit.fits && i < fit.inlier.size() && !fit.inlier[i])
      outliers.push_back({{"point", reportedPointId(project, fit.clicks[i].point)}, {"residual", fit.residual[i]}});
  nlohmann::json j = {{"photo", photo},
                      {"shows", fit.subject ? "another subject" : "the object itself"},
                      {"decision", fit.decision},
                      {"path", fit.subject ? "camera and warp, or paper"
                               : fit.fits  ? "projection"
                                           : "paper"},
                      {"fits", fit.fits},
                      {"reason", fit.reason},
                      {"clicks", fit.clicks.size()},
                      {"inliers", fit.inliers},
                      {"threshold_px", fit.thresholdPx}};
  if (fit.fits) {
    j["focal_px"] = fit.camera.focal();
    j["fov_y_deg"] = fit.camera.fovYDeg();
    j["k1"] = fit.camera.k1;
    j["k2"] = fit.camera.k2;
    j["residual_median_px"] = fit.medianResidual;
    j["residual_max_px"] = fit.maxResidual;
    j["residual_rms_px"] = fit.rmsResidual;
    j["click_noise_px"] = fit.noisePx;
    j["radial_pooled"] = fit.radialPooled;
    j["shared_intrinsics"] = fit.sharedIntrinsics;
    j["photometric_shift_px"] = fit.photometricShiftPx;
    j["exif_focal_prior"] = fit.focalPrior > 0 ? "taken" : fit.focalPrior < 0 ? "refused by the clicks" : "none";
    j["silhouette_points"] = fit.silhouettePoints;
    j["silhouette_found"] = fit.silhouetteFound;
    if (!fit.silhouetteSearch.empty()) j["silhouette_search"] = fit.silhouetteSearch;
    j["silhouette_residual_px"] = fit.silhouetteResidualPx;
    j["outliers"] = outliers;
    j["eye"] = {fit.camera.pinhole.center().x(), fit.camera.pinhole.center().y(), fit.camera.pinhole.center().z()};
    // The camera in cameras.json's convention: p_cam = R p + t, R row-major.
    nlohmann::json R = nlohmann::json::array();
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) R.push_back(fit.camera.pinhole.R(r, c));
    j["R"] = R;
    j["t"] = {fit.camera.pinhole.t.x(), fit.camera.pinhole.t.y(), fit.camera.pinhole.t.z()};
    j["cx"] = fit.camera.pinhole.cx;
    j["cy"] = fit.camera.pinhole.cy;
  }
  j["seconds"] = fit.seconds;
  return j;
}

}  // namespace

ProjectionStage projectMapping(const Scene& scene, const std::shared_ptr<const Mapping>& paper,
                               const CameraStage& cameras, const JobControl& job, ViewFrameCache* frames,
                               const ProjectionStage* previous) {
  TM_CHECK(paper, "projectMapping: no mapping");
  const PipelineOptions& o = scene.project.options;
  ProjectionOptions options;
  options.correction = o.correction;
  options.smoothness = o.viewSmoothness;
  // Per input face: the photo the previous run showed on it, or "empty" (the label after the photos).
  std::vector<int> start;
  if (previous && previous->mapping) {
    const Partition& last = *previous->mapping->partition;
    const int empty = static_cast<int>(scene.photos.size());
    start.assign(scene.mesh->numFaces(), empty);
    for (size_t f = 0; f < last.faceParent.size(); ++f) {
      const int photo = previous->mapping->map.facePhoto[f];
      if (last.faceParent[f] < static_cast<int>(start.size())) start[last.faceParent[f]] = photo >= 0 ? photo : empty;
    }
    options.maxSweeps = 1;
    options.reuseFramePx = kPreviewFramePx;
  }
  ProjectionStage out;
  job.progress(StageId::Projection, 0.0);
  out.result = projectionFill(scene, *paper->partition, paper->map, cameras.fits, options, job, frames,
                              start.empty() ? nullptr : &start, start.empty() ? nullptr : &previous->result);
  if (out.result.fittedPhotos == 0) {
    out.mapping = paper;
  } else {
    auto mapping = std::make_shared<Mapping>(*paper);
    mapping->map = std::move(out.result.map);
    out.mapping = mapping;
  }
  out.result.map = TextureMap{};
  return out;
}

std::shared_ptr<const Partition> partitionScene(const Scene& scene, const JobControl& job, MapCaches* caches) {
  PartitionOptions partitionOptions;
  partitionOptions.backgroundThresholdPx = scene.project.options.backgroundThresholdPx;
  return partitionShared(scene, partitionOptions, job, caches ? &caches->partition : nullptr);
}

Mapping mapPartition(const Scene& scene, std::shared_ptr<const Partition> partition, const JobControl& job,
                     MapCaches* caches, const std::vector<char>* projected) {
  Mapping out;
  out.partition = std::move(partition);
  const auto start = Clock::now();
  FineMapOptions fineOptions;
  fineOptions.seed = scene.project.options.seed;
  fineOptions.lineSearches = scene.project.options.stretchSearches;
  if (fineOptions.lineSearches == 0) fineOptions.finalSweeps = 0;
  CellMapping cells = mapCells(scene, *out.partition, fineOptions, job, caches ? &caches->cells : nullptr, projected);
  out.map = std::move(cells.map);
  out.cells = std::move(cells.cells);
  out.stats = cells.stats;
  out.cellsMapped = cells.cellsMapped;
  out.cellsReused = cells.cellsReused;
  out.cellsProjected = cells.cellsProjected;
  out.mapSeconds = secondsSince(start);
  if (scene.project.points.empty())
    out.map.notes.insert(out.map.notes.begin(), "no features: the whole mesh is one empty patch (paper section 3)");
  return out;
}

Mapping mapTexture(const Scene& scene, const JobControl& job, MapCaches* caches, const std::vector<char>* projected) {
  return mapPartition(scene, partitionScene(scene, job, caches), job, caches, projected);
}

BalancedScene balanceScene(const std::shared_ptr<const Scene>& scene, const Mapping& mapping, const JobControl& job,
                           const BalancedScene* previous, double toleranceLevels, BalanceMemo* memo) {
  job.progress(StageId::Balance, 0.0);
  BalanceOptions options;
  options.mode = scene->project.options.colorBalance;
  std::vector<bool> locked;
  std::vector<const Photo*> photos;
  for (size_t i = 0; i < scene->photos.size(); ++i) {
    locked.push_back(scene->project.photos[i].colorLocked || scene->skippedPhotos.count(int(i)));
    photos.push_back(scene->photos[i].get());
  }
  BalancedScene out;
  std::vector<uint64_t> keys;  // the photos' content, for the memo
  for (size_t i = 0; i < scene->photos.size(); ++i) keys.push_back(photoKeyOf(*scene, i));
  // The preview starts from the last balance and stops at a gain step of 1e-5, a thousandth of the
  // 1/255 steps (kPreviewBalanceLevels) within which it keeps the last balanced photos anyway.
  const ColorBalance* warm = toleranceLevels > 0 && previous ? &previous->balance : nullptr;
  if (warm) options.tolerance = 1e-5;
  out.balance = balanceColors(mapping.partition->mesh, mapping.map, photos, locked, options, job, memo, keys, warm);
  out.sources = scene->photos;
  bool changed = false;
  for (const ColorTransform& t : out.balance.transforms) changed = changed || !t.identity();
  if (!changed) {
    out.scene = scene;
    return out;
  }
  const auto start = Clock::now();
  auto balanced = std::make_shared<Scene>(*scene);
  for (size_t i = 0; i < balanced->photos.size(); ++i) {
    job.progress(StageId::Balance, 0.5 + 0.5 * i / balanced->photos.size(), "applying");
    ColorTransform& t = out.balance.transforms[i];
    const auto& source = scene->photos[i];
    const bool sameSource =
        previous && previous->scene && i < previous->sources.size() && source && previous->sources[i] == source;
    const double distance =
        sameSource ? balancedPhotoDistance(t, previous->balance.transforms[i], source->rgb.depth()) : 0;
    if (sameSource && distance <= toleranceLevels) {
      // The same pixels (distance 0) keep the new transform; a photo within the tolerance keeps its own.
      if (distance > 0) t = previous->balance.transforms[i];
      balanced->photos[i] = previous->scene->photos[i];
      ++out.photosKept;
    } else {
      balanced->photos[i] = balancedPhoto(source, t);
    }
  }
  out.scene = balanced;
  out.applySeconds = secondsSince(start);
  return out;
}

std::shared_ptr<const Mapping> optimiseMappingSeams(const Scene& scene, const std::shared_ptr<const Mapping>& mapping,
                                                    const std::vector<char>* projected, SeamResult& seams,
                                                    const JobControl& job,
                                                    std::vector<std::shared_ptr<const LuvTiles>> luv,
                                                    const SeamMemo* warm, uint64_t meshHash) {
  const PipelineOptions& o = scene.project.options;
  SeamInput in;
  in.mesh = &mapping->partition->mesh;
  in.map = &mapping->map;
  for (const auto& p : scene.photos) in.photos.push_back(p.get());
  in.fixedVertices = mapping->partition->featureVertex;
  in.luv = std::move(luv);
  in.warm = warm;
  in.meshHash = meshHash;
  in.warmTolerancePx = warm ? kPreviewFramePx : 0;
  if (projected) in.projectedPhotos = *projected;
  SeamOptions options;
  options.lambda = o.seamLambda;
  options.rounds = o.seamRounds;
  options.gradientWeight = o.gradientWeight;
  options.measureGradients = !warm;  // the warm preview skips the report-only gradient figures
  options.seed = o.seed;
  job.progress(StageId::Seams, 0.0);
  seams = optimiseSeams(in, options, job);
  if (seams.movedSides == 0) return mapping;
  auto out = std::make_shared<Mapping>(*mapping);
  out->map = std::move(seams.map);
  return out;
}

SeamLevelling levelMapping(const Scene& scene, const Mapping& mapping, const JobControl& job, PoissonCache* solvers) {
  std::vector<const Photo*> photos;
  for (const auto& p : scene.photos) photos.push_back(p.get());
  return levelSeams(mapping.partition->mesh, mapping.map, photos, scene.project.options.seamLevelling, job, solvers);
}

SurfaceColors inpaintMapping(const Scene& scene, const Mapping& mapping, SeamLevelling levelling, const JobControl& job,
                             Tier tier, PoissonCache* solvers, SynthesisMemo* synthesis) {
  SurfaceColors out;
  out.levelling = std::move(levelling);
  const PipelineOptions& o = scene.project.options;
  InpaintInput in;
  in.holeModes = scene.project.holeModes;
  in.options.mode = o.inpaintMode;
  if (tier == Tier::Quick) {  // every hole harmonic
    in.options.mode = InpaintMode::Harmonic;
    for (HoleMode& h : in.holeModes) h.mode = InpaintMode::Harmonic, h.exemplar.reset();
  }
  in.mesh = &mapping.partition->mesh;
  in.map = &mapping.map;
  for (const auto& p : scene.photos) in.photos.push_back(p.get());
  in.levelling = &out.levelling;
  in.faceParent = mapping.partition->faceParent;
  in.strokes = scene.project.strokes;
  in.clones = scene.project.clones;
  in.where = scene.project.file;
  in.solvers = solvers;
  in.synthesis = synthesis;
  in.options.synthesisReuseCharts = isPreview(tier);
  in.photosKey = photosKeyOf(scene);
  in.options.maxRefinedVertices = o.maxInpaintVertices;
  in.options.textureSeed = o.seed;
  // The preview inpaints harmonic and texture fills on a coarser refinement (harmonic: the same colours at
  // viewing distance; texture: the same texture at a lower resolution, its grid cell follows the
  // refinement); the other guided fills (RBF, synthesis, structure, strokes) and clones depend on the
  // refinement's density, so they keep it.
  auto coarse = [](InpaintMode m) { return m == InpaintMode::Harmonic || m == InpaintMode::Texture; };
  bool lowDetail = coarse(in.options.mode) && scene.project.strokes.empty() && scene.project.clones.empty();
  for (const HoleMode& h : in.holeModes) lowDetail = lowDetail && coarse(h.mode);
  if (isPreview(tier) && lowDetail) in.options.detail = kPreviewDetail;
  job.progress(StageId::Inpaint, 0.0);
  out.inpaint = inpaintSurface(in, job, &out.warnings);
  return out;
}

SurfaceColors colorSurface(const Scene& scene, const Mapping& mapping, const JobControl& job, Tier tier,
                           PoissonCache* solvers, SynthesisMemo* synthesis) {
  job.progress(StageId::Level, 0.0);
  return inpaintMapping(scene, mapping, levelMapping(scene, mapping, job, solvers), job, tier, solvers, synthesis);
}

BakeResult bakeModel(const Scene& scene, const Mapping& mapping, const SurfaceColors& colors, const JobControl& job) {
  job.progress(StageId::Bake, 0.0, "charts");
  const Mesh& mesh = mapping.partition->mesh;
  const InpaintResult* inpaint = colors.inpaint.faceRegion.empty() ? nullptr : &colors.inpaint;
  AtlasOptions options;
  options.size = scene.project.options.atlasSize;
  options.gutter = scene.project.options.gutter;
  BakeResult out;
  out.atlas = buildAtlas(mesh, atlasInput(mesh, mapping.map, scene.photos, inpaint), options,
                         [&](double f) { job.progress(StageId::Bake, 0.6 * f, "charts, LSCM, packing"); });
  job.progress(StageId::Bake, 0.6, "baking");
  out.image = bakeAtlas(out.atlas, mesh, scene.photos, &colors.levelling, inpaint, options);
  out.model = atlasModel(mesh, out.atlas, out.image);
  const std::string name = fs::path(scene.project.mesh).stem().string();
  out.model.name = name.empty() ? "model" : name;
  if (scene.project.options.exportTopology == ExportTopology::Original) {
    const bool meshUVs = scene.project.options.bakeInto == BakeInto::MeshUVs;
    job.progress(StageId::Bake, 0.8, meshUVs ? "bake into the mesh's own UVs" : "transfer to the original mesh");
    const auto start = Clock::now();
    // Texels take the montage's own colours (photos, levelling, inpainting), not a second resampling of
    // the refined atlas.
    std::vector<const Photo*> photos;
    for (const auto& p : scene.photos) photos.push_back(p.get());
    const PreviewSurface surface(mapping.map, photos, &colors.levelling, inpaint, options.emptyColor);
    // The mesh as loaded: a welded mesh's faces are the loaded ones (WeldedMesh), each refined face lies in one.
    std::vector<int> loadedParent;
    if (scene.welded()) {
      loadedParent.reserve(mapping.partition->faceParent.size());
      for (int f : mapping.partition->faceParent) loadedParent.push_back(scene.mesh->faceOrigin[f]);
    }
    const std::vector<int>& parent = scene.welded() ? loadedParent : mapping.partition->faceParent;
    const auto montage = [&](int f, const Vec3& b) { return surface.color(f, b); };
    if (meshUVs) {  // (loadScene checked that the mesh has UVs)
      MeshUVOptions uvOptions;
      uvOptions.size = scene.project.options.bakeSize;
      uvOptions.emptyColor = options.emptyColor;
      out.meshUVs = true;
      out.meshUVBake = bakeMeshUVs(*scene.loaded, mesh, parent, out.atlas.faceSource, montage, uvOptions);
      out.meshUVBake.model.name = out.model.name;
    } else {
      out.original = true;
      out.originalModel = bakeOriginalTopology(*scene.loaded, mesh, parent, out.atlas, out.image, options, {}, montage);
      out.originalModel.model.name = out.model.name;
    }
    out.transferSeconds = secondsSince(start);
  }
  job.progress(StageId::Bake, 1.0);
  return out;
}

std::shared_ptr<const Scene> Pipeline::loadScene(const Project& given, const JobControl& job, bool& cached) {
  // The mesh and each photo are reloaded only when their files changed.
  auto scene = std::make_shared<Scene>();
  const std::string meshFile = fileKey(given.mesh);
  cached = meshFile == meshFile_ && cachedMesh_;
  if (!cached) {
    job.progress(StageId::Load, 0.0, "mesh " + fs::path(given.mesh).filename().string());
    LoadedMesh loaded = loadMesh(given.mesh);
    cachedMeshReport_ = loaded.report;
    cachedMesh_ = requireUsable(std::move(loaded));
    meshFile_ = meshFile;
  }
  // Refused before any stage runs rather than at the bake.
  TM_CHECK(given.options.bakeInto != BakeInto::MeshUVs || cachedMesh_->hasUV(),
           located(given.mesh,
                   "options.bakeInto \"meshUVs\": the mesh has no texture coordinates (OBJ vt, glTF "
                   "TEXCOORD) to bake into; use bakeInto \"atlas\" for a new layout"));
  // A mesh file that changed since the project was saved (another vertex order, a retopology): the project's ids
  // are carried to it by their saved positions, and what moved is said (io/mesh_anchors.h).
  // (A project without anchors has nothing to compare: the mesh's fingerprint is not even computed.)
  Project carried;
  MeshCarry carry;
  if (given.anchors.present) {
    carried = given;
    carry = carryToMesh(carried, *cachedMesh_);
  }
  const Project& project = carry.changed ? carried : given;
  scene->project = project;
  // A mesh split at UV seams: the stages work on it welded (once per mesh file).
  const bool weld = project.options.weldIdenticalPositions;
  if (!cached || weld != weldTried_) {
    weldTried_ = weld;
    cachedWelded_ = {};
    if (weld) {
      // In canonical order: the same surface listed in another order (a re-export) is the same mesh to the stages.
      WeldedMesh w = weldIdenticalPositions(*cachedMesh_, true);
      if (w.mesh) {
        cachedWelded_.mesh = std::move(w.mesh);
        cachedWelded_.report = std::move(w.report);
        cachedWelded_.vertexOf = std::make_shared<const std::vector<int>>(std::move(w.vertexOf));
        cachedWelded_.faceOf = std::make_shared<const std::vector<int>>(std::move(w.faceOf));
        cachedWelded_.merged = w.mergedVertices;
      }
    }
    cached = false;
  }
  const bool sameMesh = cached;
  // What the stages read: the mesh's contents, not its path or time (photoContentKey).
  meshKey_ = "mesh:" + contentHash(project.mesh) + (cachedWelded_.mesh ? "|welded" : "");
  scene->loaded = cachedMesh_;
  scene->mesh = cachedWelded_.mesh ? cachedWelded_.mesh : cachedMesh_;
  scene->meshReport = cachedWelded_.mesh ? cachedWelded_.report : cachedMeshReport_;
  if (cachedWelded_.mesh) {
    scene->vertexOf = cachedWelded_.vertexOf;
    scene->faceOf = cachedWelded_.faceOf;
    scene->meshReport.path = cachedMeshReport_.path;
    scene->meshReport.format = cachedMeshReport_.format;
    scene->meshReport.inputVertices = cachedMeshReport_.inputVertices;
    scene->meshReport.inputFaces = cachedMeshReport_.inputFaces;
    if (cachedWelded_.merged > 0)
      scene->meshReport.findings.insert(
          scene->meshReport.findings.begin(),
          {MeshFinding::Severity::Warning,
           std::to_string(cachedWelded_.merged) +
               " vertices share their position with another (the mesh is split at UV seams): they are welded for "
               "mapping, and the export keeps the mesh's own vertices",
           {},
           cachedWelded_.merged});
  }
  std::vector<CachedPhoto> photos;
  for (size_t i = 0; i < project.photos.size(); ++i) {
    const PhotoRef& ref = project.photos[i];
    std::string key = photoContentKeyWith(ref, project.options, [&](const std::string& p) { return contentHash(p); });
    CachedPhoto entry;
    for (const CachedPhoto& c : cachedPhotos_)  // the same contents under the same names (messages show them)
      if (c.key == key && c.photo && c.photo->path == ref.path && c.photo->maskPath == ref.mask) entry = c;
    if (!entry.contours || !sameMesh) entry.contours = std::make_shared<ContourMemo>();  // the mesh's contours
    if (!entry.photo) {
      job.progress(StageId::Load, double(i + 1) / (project.photos.size() + 1),
                   "photo " + fs::path(ref.path).filename().string());
      try {
        PhotoLoadOptions options;
        options.maxSide = project.options.maxPhotoSide;
        options.mirror = ref.mirror;
        entry.photo = std::make_shared<Photo>(loadPhoto(ref.path, ref.mask, options));
        if (entry.photo->hasBackground) entry.silhouette = std::make_shared<const SilhouetteDistance>(*entry.photo);
      } catch (const Error& e) {
        // A broken photo disables only itself: the others still texture. Its key never matches a
        // photo's, so the next run tries the file again.
        scene->skippedPhotos[int(i)] = e.what();
        entry.photo = placeholderPhoto(ref);
        key = "skipped:" + key;
      }
      entry.key = key;
      cached = false;
    }
    photos.push_back(entry);
    scene->photos.push_back(entry.photo);
    scene->photoKeys.push_back(scene->skippedPhotos.count(int(i)) ? std::string() : key);
  }
  cachedPhotos_ = std::move(photos);
  if (!scene->skippedPhotos.empty() || scene->welded()) scene->requested = project;
  if (!scene->skippedPhotos.empty()) {
    std::set<int> skipped;
    for (const auto& [i, reason] : scene->skippedPhotos) skipped.insert(i);
    scene->project = withoutPhotoReferences(project, skipped);
  }
  // The document's ids name the mesh as loaded: checked there, then carried to the welded mesh.
  validateProject(scene->project, scene->loaded->numVertices(), scene->loaded->numFaces(), photoSizes(scene->photos));
  if (scene->welded()) {
    scene->project = withMeshIds(scene->project, *scene->vertexOf, *scene->faceOf);
    validateProject(scene->project, scene->mesh->numVertices(), scene->mesh->numFaces(), photoSizes(scene->photos));
  }
  checkClones(scene->project, *scene->mesh, scene->photos);
  std::vector<const Photo*> photoPointers;
  for (const auto& p : scene->photos) photoPointers.push_back(p.get());
  scene->warnings = projectWarnings(scene->project, photoPointers);
  if (carry.changed) scene->warnings.insert(scene->warnings.begin(), carry.message);
  return scene;
}

std::string Pipeline::documentKey(const Project& project) const {
  // The document (everything but its file name) and the identity of every file it reads.
  std::string key = projectToJson(project, "");
  key += '|' + fileKey(project.mesh);
  for (const PhotoRef& ref : project.photos) key += '|' + photoFileKey(ref, project.options);
  return key;
}

std::shared_ptr<const PipelineResult> Pipeline::findResult(const Project& project, Tier tier) {
  const std::string key = documentKey(project);
  constexpr int kRank[] = {1, 2, 0};  // by Tier: preview, final, quick
  std::shared_ptr<const PipelineResult> best;
  for (const auto* list : {&finals_, &previews_})
    for (const auto& [k, result] : *list)
      if (k == key && tierServes(result->tier, tier) && (!best || kRank[int(result->tier)] > kRank[int(best->tier)]))
        best = result;
  return best;
}

bool quickDiffers(const Project& project) {
  bool differs = project.options.inpaintMode != InpaintMode::Harmonic;
  for (const HoleMode& h : project.holeModes) differs = differs || h.mode != InpaintMode::Harmonic;
  return differs;
}

const StageGraph& pipelineStages() {
  static const StageGraph graph = [] {
    StageGraph g;
    const auto add = [&](StageId id, std::initializer_list<StageId> reads, std::vector<std::string> fields,
                         std::string also, double typicalShare, bool finalOnly = false) {
      StageDecl d{stageName(id), {}, std::move(fields), std::move(also), typicalShare, finalOnly};
      for (StageId r : reads) d.reads.push_back(static_cast<int>(r));
      TM_CHECK(g.add(std::move(d)) == static_cast<int>(id), "pipelineStages: stages out of StageId order");
    };
    using S = StageId;
    // Typical shares: the demo and the armadillo synth project spend most of a run in the mapping, the
    // inpainting and the bake.
    add(S::Load, {}, {},
        "the mesh's and photos' contents (the files' bytes, weldIdenticalPositions, maxPhotoSide, each photo's "
        "mask and mirror), never their paths or times",
        0.04);
    add(S::Camera, {S::Load},
        {"/options/cameraMode", "/options/cameraThreshold", "/options/sharedIntrinsics", "/options/photometric",
         "/options/foundSilhouettes", "/options/seed"},
        "per photo: the photo, the mesh, its clicks (vertex and pixel, in point order) and its mode; the preview's "
        "warm-started fits are their own",
        0.06);
    add(S::Partition, {S::Load},
        {"/points", "/chains", "/options/backgroundThresholdPx", "/options/stretchSearches", "/options/seed"}, "",
        0.16);
    add(S::Map, {S::Partition}, {}, "which photos fit a camera (the projection maps them)", 0.18);
    add(S::Projection, {S::Map, S::Camera}, {"/options/correction", "/options/viewSmoothness"},
        "the preview's view selection, warm-started from the last run's", 0.02);
    add(S::Balance, {S::Projection}, {"/options/colorBalance", "/photos/*/colorLocked"}, "", 0.03);
    add(S::Seams, {S::Balance}, {"/options/seamLambda", "/options/seamRounds", "/options/gradientWeight"},
        "the preview's sides, warm-started from the last run's", 0.08);
    add(S::Level, {S::Seams}, {"/options/seamLevelling"}, "", 0.03);
    add(S::Inpaint, {S::Level},
        {"/strokes", "/clones", "/holeModes", "/options/inpaintMode", "/options/maxInpaintVertices"}, "the tier", 0.18);
    add(S::Bake, {S::Inpaint},
        {"/options/atlasSize", "/options/gutter", "/options/exportTopology", "/options/bakeInto", "/options/bakeSize"},
        "", 0.16, true);
    add(S::Export, {S::Bake}, {"/options/pngCompression"}, "run by writeRunOutputs into the output folder, never kept",
        0.06, true);
    return g;
  }();
  return graph;
}

namespace {

constexpr int kLoad = int(StageId::Load), kCamera = int(StageId::Camera), kPartition = int(StageId::Partition),
              kMap = int(StageId::Map), kProjection = int(StageId::Projection), kBalance = int(StageId::Balance),
              kSeams = int(StageId::Seams), kLevel = int(StageId::Level), kInpaint = int(StageId::Inpaint),
              kBake = int(StageId::Bake);

// The run's warnings about the loaded scene: mesh findings, project warnings, skipped photos (with what of the
// document they take out of the run) and foregrounds.
void addLoadWarnings(const Project& project, const Scene& scene, std::vector<std::string>& warnings) {
  for (const auto& finding : scene.meshReport.findings) warnings.push_back("mesh: " + finding.what);
  for (const auto& w : scene.warnings) warnings.push_back("project: " + w);
  for (const auto& [i, reason] : scene.skippedPhotos) {
    int positions = 0, chains = 0, clones = 0, textures = 0;
    for (const FeaturePoint& pt : project.points)
      for (const PhotoPoint& a : pt.at) positions += a.photo == i;
    for (const FeatureChain& c : project.chains) chains += c.photo == i;
    for (const CloneOp& c : project.clones) clones += c.photo == i;
    for (const HoleMode& h : project.holeModes) textures += h.exemplar && h.exemplar->photo == i;
    const std::string holes =
        textures ? " (and the texture of " + std::to_string(textures) + (textures == 1 ? " hole)" : " holes)") : "";
    warnings.push_back(photoName(project, i) + " skipped (" + reason + "): its " + std::to_string(positions) +
                       " positions, " + std::to_string(chains) + " chains and " + std::to_string(clones) + " clones" +
                       holes + " are left out of this run; relink or remove it");
  }
  for (size_t i = 0; i < scene.photos.size(); ++i)
    if (!scene.skippedPhotos.count(int(i)))
      for (const std::string& w : foregroundWarnings(*scene.photos[i]))
        warnings.push_back(photoName(project, int(i)) + ": " + w);
}

// Each stage's figures for the report.
nlohmann::json cameraCounts(const CameraStage& cameras, const Project& project) {
  nlohmann::json photos = nlohmann::json::array();
  for (size_t p = 0; p < cameras.fits.size(); ++p) photos.push_back(fitJson(cameras.fits[p], int(p), &project));
  nlohmann::json shared = nlohmann::json::array();
  for (const SharedIntrinsics& s : cameras.shared)
    shared.push_back({{"photos", s.photos},
                      {"shared", s.shared},
                      {"focal_px", s.focal},
                      {"k1", s.k1},
                      {"k2", s.k2},
                      {"radial_terms", s.terms},
                      {"radial_f", s.radialF},
                      {"exif_focal_prior", s.focalPrior},
                      {"aic_shared", s.aicShared},
                      {"aic_separate", s.aicSeparate},
                      {"why", s.why},
                      {"seconds", s.seconds}});
  const PhotometricRefinement& ph = cameras.photometric;
  nlohmann::json photometric = {{"tried", ph.tried},
                                {"kept", ph.kept},
                                {"why", ph.why},
                                {"photos", ph.photos},
                                {"samples", ph.samples},
                                {"held_out_error_before", ph.heldOutBefore},
                                {"held_out_error_after", ph.heldOutAfter},
                                {"shift_px", ph.shiftPx},
                                {"seconds", ph.seconds}};
  return {{"fitted", cameras.fitted},
          {"subjects", cameras.subjects},
          {"reused", cameras.reused},
          {"pooled_radial_f", cameras.pooledRadialF},
          {"shared_intrinsics", shared},
          {"photometric", photometric},
          {"photos", photos}};
}

nlohmann::json partitionCounts(const Partition& partition, bool kept) {
  nlohmann::json rejected = nlohmann::json::object();
  for (const RejectedPair& r : partition.rejected) {
    const std::string reason = kRejectReasonNames[static_cast<int>(r.reason)];
    rejected[reason] = rejected.value(reason, 0) + 1;
  }
  return {{"paths", partition.paths.size()},
          {"rejected", rejected},
          {"cells", partition.numCells},
          {"steiner_vertices", partition.steinerVertices},
          {"searches", partition.searches},
          {"searches_reused", kept ? 0 : partition.searchesReused},
          {"replayed", !kept && partition.replayed}};
}

nlohmann::json mapCounts(const Mapping& mapping, bool kept) {
  nlohmann::json cellStatus = nlohmann::json::object();
  for (const CellPlan& c : mapping.cells) {
    const std::string status = kCellStatusNames[static_cast<int>(c.status)];
    cellStatus[status] = cellStatus.value(status, 0) + 1;
  }
  return {{"faces", mapping.map.numFaces()},
          {"mapped_faces", mapping.map.numMapped()},
          {"cells", cellStatus},
          {"cells_mapped", kept ? 0 : mapping.cellsMapped},
          {"cells_reused", kept ? 0 : mapping.cellsReused},
          {"cells_projected", mapping.cellsProjected},
          {"splits", mapping.stats.splits},
          {"base_inner_vertices", mapping.stats.baseInnerVertices},
          {"centroid_fallbacks", mapping.stats.centroidFallbacks},
          {"flipped_faces", mapping.stats.flippedFaces},
          {"max_stretch", mapping.stats.maxStretch}};
}

nlohmann::json projectionCounts(const ProjectionResult& pr) {
  nlohmann::json photos = nlohmann::json::array();
  nlohmann::json subjects = nlohmann::json::array();
  for (const SubjectChoice& c : pr.subjects)
    subjects.push_back({{"photo", c.photo},
                        {"map", c.warp ? "camera and warp" : "paper"},
                        {"why", c.why},
                        {"warp_faces", c.warpFaces},
                        {"warp_share", c.warpArea},
                        {"warp_folds", c.warpFolds},
                        {"warp_stretch", c.warpStretch},
                        {"paper_faces", c.paperFaces},
                        {"paper_share", c.paperArea},
                        {"paper_stretch", c.paperStretch},
                        {"held_out_median_px", c.heldOutMedianPx},
                        {"held_out_max_px", c.heldOutMaxPx}});
  for (size_t p = 0; p < pr.photoFaces.size(); ++p)
    photos.push_back({{"photo", p},
                      {"path", pr.projected.size() > p && pr.projected[p] ? "projection" : "paper"},
                      {"faces", pr.photoFaces[p]},
                      {"projected_faces", pr.photoProjectedFaces[p]},
                      {"refused_flipped", pr.photoRefusedFlipped[p]},
                      {"refused_background", pr.photoRefusedBackground[p]}});
  return {{"fitted_photos", pr.fittedPhotos},
          {"seen_faces", pr.seenFaces},
          {"filled_faces", pr.filledFaces},
          {"relabelled_faces", pr.relabelledFaces},
          {"dropped_faces", pr.droppedFaces},
          {"empty_faces", pr.emptyFaces},
          {"selection_sweeps", pr.selectionSweeps},
          {"view_seconds", pr.viewSeconds},
          {"frame_seconds", pr.frameSeconds},
          {"frames_reused", pr.framesReused},
          {"frames_near", pr.framesNear},
          {"selection_kept", pr.selectionKept},
          {"views_reused", pr.viewsReused},
          {"views_carried", pr.viewsCarried},
          {"carried_share", pr.carriedShare},
          {"select_seconds", pr.selectSeconds},
          {"photos", photos},
          {"subjects", subjects}};
}

nlohmann::json balanceCounts(const BalancedScene& balanced, BalanceMode mode) {
  const ColorBalance& bal = balanced.balance;
  nlohmann::json gains = nlohmann::json::array(), offsets = nlohmann::json::array();
  nlohmann::json references = nlohmann::json::array();
  for (size_t i = 0; i < bal.transforms.size(); ++i) {
    const ColorTransform& t = bal.transforms[i];
    gains.push_back({t.gain[0], t.gain[1], t.gain[2]});
    offsets.push_back({t.offset[0], t.offset[1], t.offset[2]});
    if (bal.reference[i]) references.push_back(i);
  }
  return {{"mode", kBalanceModeNames[size_t(mode)]},
          {"photos_kept", balanced.photosKept},
          {"apply_seconds", balanced.applySeconds},
          {"edges_kept", bal.edgesKept},
          {"samples", bal.samples},
          {"photo_pairs", bal.pairs},
          {"references", references},
          {"gain", gains},
          {"offset", offsets},
          {"iterations", bal.iterations},
          {"outlier_share", bal.outlierShare},
          {"mismatch_before", bal.mismatchBefore},
          {"mismatch_after", bal.mismatchAfter}};
}

nlohmann::json seamCounts(const SeamResult& sr) {
  return {{"seam_edges", sr.seamEdges},
          {"seam_vertices", sr.seamVertices},
          {"neighbour_vertices", sr.neighbourVertices},
          {"moved_sides", sr.movedSides},
          {"structure_kept", sr.structureKept},
          {"sleeping_sides", sr.sleepingSides},
          {"rounds", sr.rounds},
          {"warm_sides", sr.warmSides},
          {"warm_near_sides", sr.warmNearSides},
          {"setup_seconds", sr.setupSeconds},
          {"measure_seconds", sr.measureSeconds},
          {"round_seconds", sr.roundSeconds},
          {"delta_e_before", sr.deltaEBefore},
          {"delta_e_after", sr.deltaEAfter},
          {"gradient_before", sr.gradientBefore},
          {"gradient_after", sr.gradientAfter},
          {"max_stretch_before", sr.maxStretchBefore},
          {"max_stretch_after", sr.maxStretchAfter}};
}

nlohmann::json levelCounts(const SeamLevelling& lev, LevelMode mode) {
  return {{"mode", kLevelModeNames[size_t(mode)]},
          {"seams", lev.seams},
          {"mean_mismatch_before", lev.meanMismatchBefore},
          {"mean_mismatch_after", lev.meanMismatchAfter}};
}

nlohmann::json inpaintCounts(const InpaintResult& inp, Tier tier) {
  constexpr const char* kKeptNames[] = {"no", "exact", "chart"};
  nlohmann::json regions = nlohmann::json::array();
  for (const InpaintRegion& r : inp.regions)
    regions.push_back({{"kind", r.kind == InpaintRegion::Kind::Hole ? "hole" : "clone"},
                       {"mode", kInpaintModeNames[size_t(r.mode)]},
                       {"clone", r.clone},
                       {"base_faces", r.baseFaces},
                       {"refined_vertices", r.refinedVertices},
                       {"unknowns", r.unknowns},
                       {"texels_per_unit", r.texelsPerUnit},
                       {"guidance_seconds", r.guidanceSeconds},
                       {"factor_seconds", r.factorSeconds},
                       {"solve_seconds", r.solveSeconds},
                       {"synthesis_kept", kKeptNames[size_t(r.synthesisKept)]},
                       {"note", r.note}});
  return {{"tier", kTierNames[size_t(tier)]},
          {"regions", regions},
          {"refined_vertices", inp.refined.mesh.numVertices()},
          {"refined_triangles", inp.refined.mesh.numTriangles()}};
}

nlohmann::json bakeCounts(const BakeResult& baked, const PipelineOptions& options) {
  nlohmann::json counts = baked.atlas.stats();
  counts["bake_seconds"] = baked.image.seconds;
  counts["export_topology"] = kExportTopologyNames[size_t(options.exportTopology)];
  if (baked.original) {
    const OriginalModel& o = baked.originalModel;
    nlohmann::json original = o.atlas.stats();              // size, charts, packing attempts
    original["atlas_parts_seconds"] = original["seconds"];  // charts, LSCM, packing; "seconds" is all of it
    original.update({{"vertices", o.model.mesh.numVertices()},
                     {"faces", o.model.mesh.numFaces()},
                     {"seconds", baked.transferSeconds},
                     {"atlas_seconds", o.atlasSeconds},
                     {"bake_seconds", o.bakeSeconds},
                     {"measure_seconds", o.measureSeconds},
                     {"transfer_loss", o.loss.toJson()}});
    counts["original"] = original;
  }
  if (baked.meshUVs) {
    const MeshUVBake& u = baked.meshUVBake;
    nlohmann::json tiles = nlohmann::json::array();
    for (const MeshUVTile& t : u.tiles)
      tiles.push_back(
          {{"material", u.model.materials[&t - u.tiles.data()].name}, {"udim", t.udim}, {"faces", t.faces.size()}});
    counts["mesh_uvs"] = {{"size", options.bakeSize},
                          {"tiles", tiles},
                          {"overlapping_faces", u.overlappingFaces},
                          {"faces_across_tiles", u.crossingFaces},
                          {"faces_out_of_range", u.outOfRangeFaces},
                          {"psnr_vs_montage", u.psnr},
                          {"psnr_covered_vs_montage", u.psnrCovered},
                          {"samples", u.samples},
                          {"covered_samples", u.coveredSamples},
                          {"seconds", baked.transferSeconds},
                          {"bake_seconds", u.bakeSeconds},
                          {"measure_seconds", u.measureSeconds}};
  }
  return counts;
}

}  // namespace

int Pipeline::addStage(StageDecl stage, ExtraStage run) {
  TM_CHECK(run, "Pipeline::addStage: stage '" + stage.name + "' has nothing to run");
  const int index = graph_.add(std::move(stage));
  extras_.push_back({index, std::move(run), {}});
  return index;
}

std::shared_ptr<const CameraStage> Pipeline::fitCameras(const Scene& scene, const Project& project,
                                                        const std::string& fieldsKey, Tier tier, const JobControl& job,
                                                        std::string& key) {
  // A fit per photo, reused while the photo's clicks, the photo, the mesh and the options stay. Keyed by what
  // the fit reads: the clicks' vertices and pixels in point order, not the points' indices, so that deleting or
  // adding another point keeps the fit (its click ids are renumbered). The preview refits a photo whose clicks
  // changed from its last camera (fitCamera's warm start); its key says so, so that the final tier fits from
  // scratch and matches a fresh run exactly.
  auto cameras = std::make_shared<CameraStage>();
  const auto start = Clock::now();
  const size_t np = scene.photos.size();
  // One camera: photos of one size, and of one camera model and focal length where their EXIF says. A photo that may
  // share its camera with another (not set to show another subject) is refined on its silhouette after the bundle
  // adjustment, from the camera it gives (once, not before and after).
  using CameraKey = std::tuple<int, int, std::string>;
  const auto cameraOf = [&](size_t p) -> CameraKey {
    const Photo& photo = *scene.photos[p];
    return std::make_tuple(photo.width, photo.height,
                           photo.exif.make + '\n' + photo.exif.model + '\n' + std::to_string(photo.exif.focalMm) +
                               '\n' + std::to_string(photo.exif.focal35mm));
  };
  std::vector<char> deferSilhouette(np, 0);
  if (project.options.sharedIntrinsics) {
    std::map<CameraKey, int> mayShare;
    for (size_t p = 0; p < np; ++p) mayShare[cameraOf(p)] += project.photos[p].mode != PhotoMode::Subject;
    for (size_t p = 0; p < np; ++p)
      deferSilhouette[p] = project.photos[p].mode != PhotoMode::Subject && mayShare[cameraOf(p)] >= 2;
  }
  std::vector<std::pair<std::string, std::shared_ptr<const CameraFit>>> fits(np);
  std::vector<std::vector<CameraClick>> photoClickLists(np);
  std::vector<size_t> toFit;
  std::vector<const PhotoCamera*> warmStart(np, nullptr);  // kept alive by cachedFits_ until the fits end
  std::vector<std::string> baseKeys(np);                   // without kPooled or kWarm
  for (size_t p = 0; p < np; ++p) {
    photoClickLists[p] = photoClicks(scene.project, static_cast<int>(p));
    nlohmann::json clicks = nlohmann::json::array();
    for (const CameraClick& c : photoClickLists[p]) clicks.push_back({c.vertex, c.pixel.x(), c.pixel.y()});
    const std::string photoKey = meshKey_ + '#' + cachedPhotos_[p].key;
    fits[p].first = photoKey + clicks.dump() + fieldsKey + "|mode:" + kPhotoModeNames[size_t(project.photos[p].mode)] +
                    (deferSilhouette[p] ? "#silhouette after sharing" : "");
    baseKeys[p] = fits[p].first;
    std::string found;
    for (const auto& [k, f] : cachedFits_)  // a pooled fit stands for the photo's own: its trial is the same
      for (const std::string& kept : {fits[p].first, fits[p].first + kPooled})
        if (k == kept || (isPreview(tier) && k == kept + kWarm)) fits[p].second = f, found = k;
    if (fits[p].second) {
      fits[p].first = found;
      ++cameras->reused;
      if (fits[p].second->clicks.size() == photoClickLists[p].size()) {
        bool same = true;
        for (size_t i = 0; i < photoClickLists[p].size(); ++i)
          same = same && fits[p].second->clicks[i].point == photoClickLists[p][i].point;
        if (!same) {  // the same clicks under new point indices
          auto renumbered = std::make_shared<CameraFit>(*fits[p].second);
          renumbered->clicks = photoClickLists[p];
          fits[p].second = renumbered;
        }
      }
    } else {
      toFit.push_back(p);
      // The preview starts from the photo's last camera when it had one (same photo and mesh).
      const CameraFit* last = p < cachedFits_.size() ? cachedFits_[p].second.get() : nullptr;
      if (isPreview(tier) && last && last->fits && cachedFits_[p].first.compare(0, photoKey.size(), photoKey) == 0)
        warmStart[p] = &last->camera;
    }
  }
  // Photos are fitted in parallel (each fit seeds its own generator: the result does not depend on it).
  tbb::parallel_for(size_t(0), toFit.size(), [&](size_t k) {
    const size_t p = toFit[k];
    fits[p].second = std::make_shared<const CameraFit>(
        fitPhoto(scene, static_cast<int>(p), cachedPhotos_[p].silhouette.get(), cachedPhotos_[p].contours.get(),
                 warmStart[p], false, !deferSilhouette[p]));
    if (warmStart[p]) fits[p].first += kWarm;
  });
  job.checkCancel();
  // Lens terms pooled over the photos of one camera (issue 37): noisy clicks drop k1 in one photo by its own F test
  // and keep it in another, and a photo without it lands the texture pixels off. Photos of one size (one camera)
  // that fit as the object itself pool their trials' F test (pooledRadialF); when the pool pays for the terms by
  // Akaike's criterion, every photo that tried them keeps them. A photo whose pooled state changes is refitted (warm
  // in the preview).
  std::map<CameraKey, std::vector<size_t>> sameCamera;  // the object photos of each camera
  const auto groupByCamera = [&] {
    sameCamera.clear();
    for (size_t p = 0; p < np; ++p)
      if (fits[p].second->fits && !fits[p].second->subject) sameCamera[cameraOf(p)].push_back(p);
  };
  const double distortionF = cameraFitOptions(project.options).pooledDistortionF;
  std::vector<char> pool(np, 0);
  std::set<CameraKey> paying;  // the cameras whose object photos pay for the lens terms together
  const auto poolLensTerms = [&] {
    groupByCamera();
    std::vector<size_t> toRefit;
    paying.clear();
    for (const auto& [camera, photos] : sameCamera) {
      std::vector<const CameraFit*> group;
      for (size_t p : photos) group.push_back(fits[p].second.get());
      const double f = pooledRadialF(group);
      cameras->pooledRadialF = std::max(cameras->pooledRadialF, f);
      if (f > distortionF) paying.insert(camera);
      for (size_t p : photos) {
        const CameraFit::RadialTrial& t = fits[p].second->radialTrial;
        pool[p] = f > distortionF && t.terms > 0 && t.agrees && !t.kept;
        if (bool(pool[p]) == fits[p].second->radialPooled) continue;
        toRefit.push_back(p);
        if (std::find(toFit.begin(), toFit.end(), p) == toFit.end()) --cameras->reused;
      }
    }
    tbb::parallel_for(size_t(0), toRefit.size(), [&](size_t k) {
      const size_t p = toRefit[k];
      fits[p].second = std::make_shared<const CameraFit>(
          fitPhoto(scene, static_cast<int>(p), cachedPhotos_[p].silhouette.get(), cachedPhotos_[p].contours.get(),
                   warmStart[p], pool[p], !deferSilhouette[p]));
      fits[p].first = baseKeys[p] + (pool[p] ? kPooled : "") + (warmStart[p] ? kWarm : "");
    });
    job.checkCancel();
  };
  poolLensTerms();
  // An auto photo that its clicks' own fit, without the lens terms (noisy clicks drop them by the photo's own F test),
  // took for another subject, is decided again with the terms its camera's object photos pay for: the lens's
  // residuals had counted against it (bob, 4 views, 2 px clicks, k1 -0.25: one photo of four warped to its clicks,
  // -5.1 dB). When it now fits as the object itself it joins its camera, and the pool is made again with it, as a
  // later run that finds its fit in the cache makes it.
  std::vector<size_t> toRedecide;
  for (size_t p = 0; p < np; ++p)
    if (project.photos[p].mode == PhotoMode::Auto && fits[p].second->subject && paying.count(cameraOf(p)))
      toRedecide.push_back(p);
  std::vector<std::shared_ptr<const CameraFit>> redecided(toRedecide.size());
  tbb::parallel_for(size_t(0), toRedecide.size(), [&](size_t k) {
    const size_t p = toRedecide[k];
    redecided[k] = std::make_shared<const CameraFit>(
        fitPhoto(scene, static_cast<int>(p), cachedPhotos_[p].silhouette.get(), cachedPhotos_[p].contours.get(),
                 warmStart[p], true, !deferSilhouette[p]));
  });
  bool joined = false;
  for (size_t k = 0; k < toRedecide.size(); ++k) {
    const size_t p = toRedecide[k];
    if (redecided[k]->subject) continue;
    fits[p].second = redecided[k];
    fits[p].first = baseKeys[p] + kPooled + (warmStart[p] ? kWarm : "");
    if (std::find(toFit.begin(), toFit.end(), p) == toFit.end()) --cameras->reused;
    joined = true;
  }
  if (joined) poolLensTerms();
  // One camera, many photos (issue 37): the object photos of one camera share their intrinsics when Akaike's
  // criterion says so (fitSharedIntrinsics); then each photo whose silhouette refinement waited is refined, from the
  // shared camera or its own. Cached by the group's fit keys; a photo's refinement on its own camera is reused
  // whenever its own fit is the same. A click moved in one photo moves the shared camera, and with it every photo's
  // (by 0.3-0.8 px before their silhouettes pull them back to within 0.03 px on the preview test's scene): the
  // preview keeps the last camera of a photo whose own clicks stayed, as it does without sharing, and the final
  // tier takes every camera as a fresh run does.
  decltype(cachedShared_) shared;
  std::vector<std::string> sharedKey(np);
  std::vector<std::shared_ptr<const CameraFit>> given(np);  // the fits the stage gives; cachedFits_ keeps each own
  for (size_t p = 0; p < np; ++p) given[p] = fits[p].second;
  groupByCamera();
  for (const auto& [camera, photos] : sameCamera) {
    if (!deferSilhouette[photos[0]]) continue;  // a camera of its own: refined in fitPhoto
    std::string groupKey;
    for (size_t p : photos) groupKey += std::to_string(p) + ':' + fits[p].first + '|';
    // A group the preview makes may keep some photos' last fits: its own key, which the final tier never looks up;
    // a final's serves the preview.
    auto it = cachedShared_.find(groupKey);
    if (isPreview(tier)) {
      groupKey = "preview|" + groupKey;
      if (it == cachedShared_.end()) it = cachedShared_.find(groupKey);
    }
    std::shared_ptr<const SharedCameraGroup> group;
    if (it != cachedShared_.end()) {
      group = it->second;
      groupKey = it->first;
    } else {
      auto made = std::make_shared<SharedCameraGroup>();
      for (size_t p : photos) made->joint.push_back(*fits[p].second), made->photoKeys.push_back(fits[p].first);
      made->photos = photos;
      CameraFitOptions options = cameraFitOptions(project.options);
      const Photo& first = *scene.photos[photos[0]];
      options.focalPriorPx = first.exif.focalPx(cv::Size(first.width, first.height));
      std::vector<CameraFit*> members;
      for (CameraFit& f : made->joint) members.push_back(&f);
      made->summary = fitSharedIntrinsics(*scene.mesh, members, options);
      const bool sharedNow = made->summary.shared;
      made->fits.resize(photos.size());
      tbb::parallel_for(size_t(0), photos.size(), [&](size_t k) {
        const size_t p = photos[k];
        // The last run's refinement of this photo: the same when it was on the same fit of its own, and in the
        // preview good enough when it was on a shared camera of the same clicks.
        for (const auto& [lastKey, last] : cachedShared_)
          for (size_t j = 0; j < last->photos.size(); ++j)
            if (last->photos[j] == p && last->photoKeys[j] == made->photoKeys[k] && last->summary.shared == sharedNow &&
                (!sharedNow || isPreview(tier))) {
              made->fits[k] = last->fits[j];
              return;
            }
        CameraFit fit = made->joint[k];  // the shared camera, or the photo's own fit as it was
        refineOnSilhouette(*scene.mesh, *scene.photos[p], fit,
                           photoFitOptions(project.options, warmStart[p] != nullptr), cachedPhotos_[p].silhouette.get(),
                           cachedPhotos_[p].contours.get());
        made->fits[k] = std::make_shared<const CameraFit>(std::move(fit));
      });
      group = made;
    }
    shared[groupKey] = group;
    if (photos.size() >= 2) cameras->shared.push_back(group->summary);
    for (size_t k = 0; k < photos.size(); ++k) {
      given[photos[k]] = group->fits[k];
      if (group->summary.shared) sharedKey[photos[k]] = "#shared:" + groupKey;
    }
  }
  cachedShared_ = std::move(shared);
  job.checkCancel();
  key.clear();
  for (size_t p = 0; p < np; ++p) key += "#fit:" + fits[p].first + sharedKey[p];
  // Photos of the object itself without a cut-out (issue 37): a silhouette found around the mesh's outline through the
  // clicks' camera (findSilhouette), the camera refined on it as on a cut-out and, kept, the photometric
  // refinement's silhouette term. Cached per photo by its fit's key; the final tier searches, the preview takes the
  // last search while the fit is the same and the clicks' camera otherwise (a few tenths of a second a photo).
  std::vector<const SilhouetteDistance*> foundDistance(np, nullptr);
  if (project.options.foundSilhouettes) {
    decltype(cachedFound_) kept;
    std::vector<std::string> foundKey(np);
    std::vector<size_t> toSearch;
    for (size_t p = 0; p < np; ++p) {
      if (scene.photos[p]->hasBackground || !given[p]->fits || given[p]->subject) continue;
      foundKey[p] = fits[p].first + sharedKey[p];
      if (const auto it = cachedFound_.find(foundKey[p]); it != cachedFound_.end())
        kept[foundKey[p]] = it->second;
      else if (!isPreview(tier))
        toSearch.push_back(p);
    }
    std::vector<std::shared_ptr<const FoundCamera>> searched(toSearch.size());
    tbb::parallel_for(size_t(0), toSearch.size(), [&](size_t k) {
      const size_t p = toSearch[k];
      const Photo& photo = *scene.photos[p];
      auto made = std::make_shared<FoundCamera>();
      const FoundSilhouette search = findSilhouette(*scene.mesh, photo, given[p]->camera, given[p]->thresholdPx);
      CameraFit fit = *given[p];
      fit.silhouetteSearch = search.why;
      if (search.found) {
        auto withIt = std::make_shared<const Photo>(withForeground(photo, search.mask));
        auto distance = std::make_shared<const SilhouetteDistance>(*withIt);
        refineOnSilhouette(*scene.mesh, *withIt, fit, photoFitOptions(project.options, false), distance.get());
        fit.silhouetteFound = fit.silhouettePoints > 0;
        if (fit.silhouetteFound) made->photo = withIt, made->distance = distance;
        fit.reason = describeFit(fit);
      }
      made->fit = std::make_shared<const CameraFit>(std::move(fit));
      searched[k] = made;
    });
    for (size_t k = 0; k < toSearch.size(); ++k) kept[foundKey[toSearch[k]]] = searched[k];
    for (size_t p = 0; p < np; ++p) {
      const auto it = foundKey[p].empty() ? kept.end() : kept.find(foundKey[p]);
      if (it == kept.end()) continue;
      given[p] = it->second->fit;
      foundDistance[p] = it->second->distance.get();
      key += "#found:" + std::to_string(p);
    }
    cachedFound_ = std::move(kept);
    job.checkCancel();
  }
  // The object photos' cameras refined on what they show where they overlap (issue 37; refineCamerasPhotometric),
  // kept when the photos predict each other better on held-out samples. Cached by the fits' keys. The final tier runs
  // it; the preview takes the last verdict while its fits are the same, and the clicks' cameras otherwise (a second or
  // more per run).
  if (project.options.photometric) {
    std::shared_ptr<const PhotometricCameras> verdict;
    if (cachedPhotometric_.second && cachedPhotometric_.first == key) {
      verdict = cachedPhotometric_.second;
    } else if (!isPreview(tier)) {
      auto made = std::make_shared<PhotometricCameras>();
      std::vector<CameraFit> refined;
      for (size_t p = 0; p < np; ++p) refined.push_back(*given[p]);
      std::vector<CameraFit*> members;
      std::vector<const Photo*> photos;
      std::vector<const SilhouetteDistance*> silhouettes;
      for (size_t p = 0; p < np; ++p) {
        members.push_back(&refined[p]);
        photos.push_back(scene.photos[p].get());
        silhouettes.push_back(foundDistance[p] ? foundDistance[p] : cachedPhotos_[p].silhouette.get());
      }
      made->summary = refineCamerasPhotometric(*scene.mesh, photos, members, PhotometricOptions{}, &job, silhouettes);
      for (size_t p = 0; p < np; ++p)
        made->fits.push_back(made->summary.kept ? std::make_shared<const CameraFit>(std::move(refined[p])) : given[p]);
      verdict = made;
      cachedPhotometric_ = {key, verdict};
    }
    if (verdict) {
      cameras->photometric = verdict->summary;
      if (verdict->summary.kept) {
        given = verdict->fits;
        key += "#photometric";
      }
    }
  }
  for (size_t p = 0; p < np; ++p) {
    const CameraFit& fit = *given[p];
    cameras->fits.push_back(fit);
    cameras->fitted += fit.fits && !fit.subject;
    cameras->subjects += fit.subject;
  }
  cachedFits_ = std::move(fits);
  cameras->seconds = secondsSince(start);
  return cameras;
}

PipelineResult Pipeline::run(const Project& project, const JobControl& job, Tier tier) {
  // An identical document state (undo, redo, a repeated run): its result at once.
  const auto lookupStart = Clock::now();
  if (auto earlier = findResult(project, tier)) {
    PipelineResult result = *earlier;
    for (StageRecord& s : result.stages) s.cached = true, s.seconds = 0;
    result.stages.front().seconds = secondsSince(lookupStart);
    return result;
  }

  PipelineResult result;
  result.tier = tier;
  const bool preview = isPreview(tier);
  const nlohmann::json document = nlohmann::json::parse(projectToJson(project, ""));
  StageRun run(graph_, document, job);

  run.begin(kLoad);
  bool loadKept = false;
  const std::shared_ptr<const Scene> scene = loadScene(project, job, loadKept);
  std::string loadKey = meshKey_;
  for (const CachedPhoto& c : cachedPhotos_) loadKey += '#' + c.key;
  run.setKey(kLoad, std::move(loadKey));
  run.record(kLoad,
             {{"vertices", scene->mesh->numVertices()},
              {"faces", scene->mesh->numFaces()},
              {"photos", scene->photos.size()},
              {"features", project.points.size()},
              {"chains", project.chains.size()}},
             loadKept);
  addLoadWarnings(project, *scene, result.warnings);

  // The camera fits and the partition read different inputs and touch different caches: they run side by
  // side, so that the fits use the core the partition's sequential queue leaves idle.
  run.begin(kCamera);
  run.begin(kPartition);
  std::shared_ptr<const CameraStage> cameras;
  std::string cameraKey;
  std::shared_ptr<const Partition> partition;
  double partitionSeconds = 0;
  tbb::parallel_invoke(
      [&] { cameras = fitCameras(*scene, project, graph_.fieldsKey(kCamera, document), tier, job, cameraKey); },
      [&] {
        const auto start = Clock::now();
        partition = run.get(kPartition, partition_, [&] { return partitionScene(*scene, job, &mapCaches_); });
        partitionSeconds = secondsSince(start);
      });
  run.setKey(kCamera, cameraKey);
  const bool camerasKept = cameras->reused == static_cast<int>(cameras->fits.size());
  run.record(kCamera, cameraCounts(*cameras, scene->project), camerasKept, cameras->seconds);
  for (size_t p = 0; p < cameras->fits.size(); ++p) {
    const CameraFit& fit = cameras->fits[p];
    if (!fit.fits && !fit.clicks.empty() && project.options.cameraMode == CameraMode::Auto)
      result.warnings.push_back("camera: photo " + std::to_string(p) + (fit.subject ? " (another subject)" : "") +
                                " takes the paper's path: " + fit.reason);
  }

  // Map: the cells of photos that fit no camera (the projection maps the others: mapCells).
  const std::vector<char> projected = fittingPhotos(cameras->fits);
  std::string fitting = "fitting:";
  for (char c : projected) fitting += c ? '1' : '0';
  run.begin(kMap, fitting);
  const auto mapping = run.get(kMap, mapping_, [&] {
    auto m = std::make_shared<const Mapping>(mapPartition(*scene, partition, job, &mapCaches_, &projected));
    mapCaches_.cells.endRun();
    return m;
  });
  run.record(kPartition, partitionCounts(*partition, run.kept(kPartition)), {}, partitionSeconds);
  run.record(kMap, mapCounts(*mapping, run.kept(kMap)), {}, mapping->mapSeconds);
  for (const auto& note : mapping->map.notes) result.warnings.push_back("map: " + note);

  // Projection. The preview's view selection starts from the last run's choices (one sweep): its result is its
  // own.
  const bool warmSelection = preview && projection_.value && projection_.value->mapping->partition->faceParent.size();
  run.begin(kProjection, "", warmSelection ? "#warm-selection" : "");
  const auto projection = run.get(kProjection, projection_, [&] {
    frames_.photoKeys.clear();
    for (const CachedPhoto& c : cachedPhotos_) frames_.photoKeys.push_back(meshKey_ + '#' + c.key);
    auto p = std::make_shared<const ProjectionStage>(
        projectMapping(*scene, mapping, *cameras, job, &frames_, warmSelection ? projection_.value.get() : nullptr));
    frames_.endRun();
    if (keep_ == Keep::ThisRunOnly) frames_.clear();
    return p;
  });
  run.record(kProjection, projectionCounts(projection->result), {}, projection->result.seconds);
  for (const SubjectChoice& c : projection->result.subjects)
    if (!c.warp)
      result.warnings.push_back("projection: photo " + std::to_string(c.photo) +
                                " (another subject) takes the paper's path: " + c.why);
  result.proposals = proposeCorrespondences(scene->project, projection->mapping->partition->mesh, cameras->fits,
                                            projection->result.views);
  for (Proposal& pr : result.proposals) pr.vertex = scene->documentVertex(pr.vertex);  // as the document names it

  // Balance: reads the seams between photos of the final mapping (which photo each face shows: seam
  // optimisation moves UVs, never a face to another photo); seams, levelling, inpainting and bake read its
  // balanced photos.
  run.begin(kBalance);
  const auto balanced = run.get(kBalance, balance_, [&] {
    balanceSamples_.beginRun();
    return std::make_shared<const BalancedScene>(balanceScene(scene, *projection->mapping, job, balance_.value.get(),
                                                              preview ? kPreviewBalanceLevels : 0.0, &balanceSamples_));
  });
  run.record(kBalance, balanceCounts(*balanced, project.options.colorBalance), {}, balanced->balance.seconds);
  for (const auto& w : balanced->balance.warnings) result.warnings.push_back("balance: " + w);
  const Scene& colorScene = *balanced->scene;

  // Seams. The preview starts from the last run's sides (SeamMemo): its result is its own.
  const SeamMemo* warmSeams = preview && seams_.value ? seamMemo_.get() : nullptr;
  run.begin(kSeams, "", warmSeams ? "#warm-seams" : "");
  const auto seamed = run.get(kSeams, seams_, [&] {
    auto seams = std::make_shared<SeamResult>();
    // The photos' L*u*v* tiles, kept with the photo objects they convert (a loaded photo, or a balanced
    // photo the balance kept): the tiles the last runs made are not made again.
    std::vector<std::shared_ptr<const LuvTiles>> luv;
    std::vector<std::pair<std::shared_ptr<const Photo>, std::shared_ptr<const LuvTiles>>> kept;
    for (const auto& photo : colorScene.photos) {
      std::shared_ptr<const LuvTiles> tiles;
      for (const auto& [p, t] : luvTiles_)
        if (p == photo) tiles = t;
      if (!tiles && photo && photo->rgb.channels() == 3) tiles = std::make_shared<const LuvTiles>(*photo);
      luv.push_back(tiles);
      kept.emplace_back(photo, tiles);
    }
    luvTiles_ = std::move(kept);
    if (keep_ == Keep::ThisRunOnly) luvTiles_.clear();  // `luv` holds them for this run's seams
    auto stage = std::make_shared<SeamStage>();
    stage->mapping = optimiseMappingSeams(colorScene, projection->mapping, &projection->result.projected, *seams, job,
                                          std::move(luv), warmSeams, projection->result.meshHash);
    seams->map = TextureMap();  // the seamed mapping holds it
    seamMemo_ = std::move(seams->memo);
    if (keep_ == Keep::ThisRunOnly) seamMemo_.reset();
    stage->seams = seams;
    return std::shared_ptr<const SeamStage>(std::move(stage));
  });
  run.record(kSeams, seamCounts(*seamed->seams), {}, seamed->seams->seconds);

  run.begin(kLevel);
  const auto levelling = run.get(kLevel, levelling_, [&] {
    return std::make_shared<const SeamLevelling>(levelMapping(colorScene, *seamed->mapping, job, &solvers_));
  });
  run.record(kLevel, levelCounts(*levelling, project.options.seamLevelling), {}, levelling->seconds);

  run.begin(kInpaint, kTierNames[size_t(tier)]);
  const auto colors = run.get(kInpaint, colors_, [&] {
    auto c = std::make_shared<const SurfaceColors>(
        inpaintMapping(colorScene, *seamed->mapping, *levelling, job, tier, &solvers_, &synthesis_));
    solvers_.endRun();
    if (tier != Tier::Quick) synthesis_.endRun();  // a quick preview synthesises nothing: the preview's charts stay
    return c;
  });
  run.record(kInpaint, inpaintCounts(colors->inpaint, tier), {}, colors->inpaint.seconds);
  for (const auto& w : colors->warnings) result.warnings.push_back("inpaint: " + w);

  if (!preview) {
    run.begin(kBake);
    const auto baked = run.get(kBake, bake_, [&] {
      return std::make_shared<const BakeResult>(bakeModel(colorScene, *seamed->mapping, *colors, job));
    });
    run.record(kBake, bakeCounts(*baked, project.options));
    if (baked->meshUVs)
      for (const std::string& w : baked->meshUVBake.warnings)
        result.warnings.push_back("bake into the mesh's UVs: " + w);
    result.baked = baked;
    result.model = std::shared_ptr<const TexturedModel>(baked, &baked->model);
    result.exported = std::shared_ptr<const TexturedModel>(baked, &baked->exported());
  }

  result.scene = scene;
  result.cameras = cameras;
  result.projection = projection;
  result.mapping = seamed->mapping;
  result.balanced = balanced;
  result.seams = seamed->seams;
  result.colors = colors;
  for (Extra& e : extras_) {
    if (preview && graph_[e.index].finalOnly) continue;
    run.begin(e.index);
    result.stages = run.records();  // what the stage sees of the run so far
    const auto counts =
        run.get(e.index, e.memo, [&] { return std::make_shared<const nlohmann::json>(e.run(result, job)); });
    run.record(e.index, *counts);
  }
  result.stages = run.records();

  // Keep the result for this document state (undo and redo find it at once).
  auto& list = preview ? previews_ : finals_;
  list.emplace_back(documentKey(project), std::make_shared<const PipelineResult>(result));
  const size_t keep = preview ? kPreviewStates : kFinalStates;
  if (list.size() > keep) list.erase(list.begin(), list.end() - keep);
  return result;
}

nlohmann::json PipelineResult::report() const {
  nlohmann::json stagesJson = nlohmann::json::array();
  double total = 0;
  for (const auto& s : stages) {
    stagesJson.push_back({{"stage", s.name}, {"seconds", s.seconds}, {"cached", s.cached}, {"counts", s.counts}});
    total += s.seconds;
  }
  nlohmann::json j;
  j["generator"] = "TextureMontage";
  j["stages"] = stagesJson;
  j["total_seconds"] = total;
  j["warnings"] = warnings;
  const Project* project = scene ? &scene->project : nullptr;
  if (scene) {
    j["project"] = scene->project.file;
    j["mesh"] = {{"path", scene->meshReport.path},
                 {"vertices", scene->meshReport.vertices},
                 {"faces", scene->meshReport.faces},
                 {"genus", scene->meshReport.genus},
                 {"boundary_loops", scene->meshReport.boundaryLoops},
                 {"components", scene->meshReport.components}};
  }
  if (mapping && baked && baked->atlas.faceSource.size() == size_t(mapping->partition->mesh.numFaces())) {
    // Where the surface's colours come from, as area shares: photos (and each photo), inpainting, nothing.
    const Mesh& mesh = mapping->partition->mesh;
    double total = 0, photo = 0, inpainted = 0, empty = 0;
    std::vector<double> perPhoto(scene ? scene->photos.size() : 0, 0.0);
    for (int f = 0; f < mesh.numFaces(); ++f) {
      const double a = mesh.faceArea(f);
      const int s = baked->atlas.faceSource[f];
      total += a;
      (s >= 0 ? photo : s == kSourceInpainted ? inpainted : empty) += a;
      if (s >= 0 && s < static_cast<int>(perPhoto.size())) perPhoto[s] += a;
    }
    if (total > 0) {
      for (double& p : perPhoto) p /= total;
      j["surface"] = {{"photo_share", photo / total},
                      {"inpainted_share", inpainted / total},
                      {"empty_share", empty / total},
                      {"photo_shares", perPhoto}};
    }
  }
  if (cameras) {
    // Each photo's path (projection or the paper's) and its camera fit.
    nlohmann::json photos = nlohmann::json::array();
    for (size_t p = 0; p < cameras->fits.size(); ++p)
      photos.push_back(fitJson(cameras->fits[p], static_cast<int>(p), project));
    j["cameras"] = photos;
    nlohmann::json proposed = nlohmann::json::array();
    for (const Proposal& pr : proposals)
      proposed.push_back({{"point", reportedPointId(project, pr.point)},
                          {"vertex", pr.vertex},
                          {"photo", pr.photo},
                          {"x", pr.pixel.x()},
                          {"y", pr.pixel.y()}});
    j["proposals"] = proposed;
  }
  if (mapping) {
    // Rejected pairs with their reasons, so a user can see why a region stayed empty (first 1000).
    nlohmann::json rejected = nlohmann::json::array();
    for (const RejectedPair& r : mapping->partition->rejected) {
      if (rejected.size() == 1000) break;
      rejected.push_back({{"points", {reportedPointId(project, r.fromPoint), reportedPointId(project, r.toPoint)}},
                          {"photo", r.photo},
                          {"reason", kRejectReasonNames[static_cast<int>(r.reason)]},
                          {"detail", r.detail}});
    }
    j["map"] = {{"faces", mapping->map.numFaces()},
                {"mapped_faces", mapping->map.numMapped()},
                {"notes", mapping->map.notes},
                {"rejected_pairs", rejected},
                {"rejected_total", mapping->partition->rejected.size()}};
  }
  // Every unmapped region: its area, why it is empty and the fix; where to click next (coverage.h).
  if (mapping) j["coverage"] = coverageJson(coverageOf(*this));
  if (seams) {
    // Per face of the map, the mean Delta E*uv across its seam edges (faces on no seam left out).
    nlohmann::json faces = nlohmann::json::array(), error = nlohmann::json::array();
    for (size_t f = 0; f < seams->faceError.size(); ++f)
      if (seams->faceError[f] >= 0) faces.push_back(f), error.push_back(std::round(seams->faceError[f] * 100) / 100);
    j["seams"] = {{"delta_e_before", seams->deltaEBefore},
                  {"delta_e_after", seams->deltaEAfter},
                  {"faces", faces},
                  {"face_delta_e", error}};
  }
  return j;
}

CoverageReport coverageOf(const PipelineResult& result, const CoverageOptions& options) {
  if (!result.mapping) return {};
  static const std::vector<CameraFit> noFits;
  static const PhotoViews noViews;
  const Mapping& m = *result.mapping;
  const bool views = result.projection && result.projection->mapping &&
                     result.projection->mapping->partition->mesh.numFaces() == m.partition->mesh.numFaces();
  const Scene* scene = result.scene.get();
  CoverageReport report = analyseCoverage(
      {scene ? scene->project : Project{}, *m.partition, m.map, m.cells, result.cameras ? result.cameras->fits : noFits,
       views ? result.projection->result.views : noViews, scene ? static_cast<int>(scene->photos.size()) : 0,
       scene && scene->mesh ? scene->mesh->numVertices() : 0,
       scene && scene->welded() ? std::function<int(int)>([scene](int v) { return scene->documentVertex(v); })
                                : std::function<int(int)>()},
      options);
  // Clicks name vertices as the document does (a welded mesh's: the loaded vertex).
  if (scene && scene->welded())
    for (CoverageRegion& r : report.regions) {
      r.centreVertex = scene->documentVertex(r.centreVertex);
      for (RegionCause& c : r.causes)
        if (c.click.vertex >= 0) c.click.vertex = scene->documentVertex(c.click.vertex);
    }
  return report;
}

PipelineResult projectionOracle(const Project& project, const std::vector<PhotoCamera>& cameras,
                                const JobControl& job) {
  TM_CHECK(cameras.size() == project.photos.size(),
           located(project.file, std::to_string(cameras.size()) + " cameras given for " +
                                     std::to_string(project.photos.size()) + " photos"));
  // No clicks: the cameras alone place the photos (no correction field, no paper's path).
  Project bare = project;
  bare.points.clear();
  bare.chains.clear();
  bare.clones.clear();
  bare.holeModes.clear();
  bare.strokes.clear();
  bare.options.correction = CorrectionMode::Off;
  PipelineResult result;
  auto start = Clock::now();
  const auto record = [&](StageId id, nlohmann::json counts = {}) {  // the stage since `start`, then a new start
    result.stages.push_back({id, stageName(id), false, secondsSince(start), std::move(counts)});
    start = Clock::now();
  };
  Pipeline pipeline;
  bool cached = false;
  result.scene = pipeline.loadScene(bare, job, cached);
  record(StageId::Load);
  const Scene& scene = *result.scene;
  auto fits = std::make_shared<CameraStage>();
  for (size_t p = 0; p < cameras.size(); ++p) {
    const Photo& photo = *scene.photos[p];
    TM_CHECK(cameras[p].pinhole.width == photo.width && cameras[p].pinhole.height == photo.height,
             located(photo.path, "the given camera is for a " + std::to_string(cameras[p].pinhole.width) + "x" +
                                     std::to_string(cameras[p].pinhole.height) + " image"));
    fits->fits.push_back(fitFromCamera(*scene.mesh, cameras[p], photoClicks(project, static_cast<int>(p))));
    ++fits->fitted;
  }
  result.cameras = fits;
  record(StageId::Camera, {{"fitted", fits->fitted}});
  const std::vector<char> projected = fittingPhotos(fits->fits);
  auto paper = std::make_shared<const Mapping>(mapTexture(scene, job, nullptr, &projected));
  record(StageId::Map);
  result.projection = std::make_shared<const ProjectionStage>(projectMapping(scene, paper, *fits, job));
  result.mapping = result.projection->mapping;
  record(StageId::Projection,
         {{"seen_faces", result.projection->result.seenFaces}, {"empty_faces", result.projection->result.emptyFaces}});
  result.balanced = std::make_shared<const BalancedScene>(balanceScene(result.scene, *result.mapping, job));
  const Scene& colorScene = *result.balanced->scene;
  record(StageId::Balance);
  result.colors = std::make_shared<const SurfaceColors>(colorSurface(colorScene, *result.mapping, job));
  record(StageId::Inpaint);
  auto baked = std::make_shared<const BakeResult>(bakeModel(colorScene, *result.mapping, *result.colors, job));
  record(StageId::Bake);
  result.baked = baked;
  result.model = std::shared_ptr<const TexturedModel>(baked, &baked->model);
  return result;
}

PipelineResult deformedProjectionOracle(const Project& project, const std::vector<PhotoCamera>& cameras,
                                        const std::string& photographedMesh, const JobControl& job) {
  const auto rest = requireUsable(loadMesh(project.mesh));
  const auto shown = requireUsable(loadMesh(photographedMesh));
  TM_CHECK(shown->numVertices() == rest->numVertices() && shown->numFaces() == rest->numFaces(),
           located(photographedMesh, std::to_string(shown->numVertices()) + " vertices and " +
                                         std::to_string(shown->numFaces()) + " faces: not a deformed copy of " +
                                         project.mesh + " (" + std::to_string(rest->numVertices()) + " and " +
                                         std::to_string(rest->numFaces()) + ")"));
  std::vector<Vec3> positions(shown->numVertices());
  for (int v = 0; v < shown->numVertices(); ++v) positions[v] = shown->position(v);
  Project deformed = project;
  deformed.mesh = photographedMesh;
  PipelineResult result = projectionOracle(deformed, cameras, job);
  auto model = std::make_shared<TexturedModel>(*result.model);
  moveToRest(*model, *withPositions(*rest, positions), *rest);
  result.model = model;
  return result;
}

nlohmann::json exportResultGlb(const PipelineResult& result, const std::string& path, PngCache* pngs) {
  const std::shared_ptr<const TexturedModel>& model = result.exported ? result.exported : result.model;
  TM_CHECK(model, "exportResultGlb: no model to write");
  nlohmann::json glb = {{"written_into_source", false}};
  const std::string meshExt = result.scene ? lowerExtension(result.scene->project.mesh) : "";
  // A glTF file, or an Assimp file that may have been read in glTF form (io/assimp_gltf.h; if it was not, the
  // write-back says why and the GLB is a new one).
  const bool gltfForm = meshExt == ".glb" || meshExt == ".gltf" || isAssimpExtension(meshExt);
  if (gltfForm && result.baked && (result.baked->original || result.baked->meshUVs)) {
    try {
      const GltfWriteBack w = exportGlbInto(*model, result.scene->project.mesh, path, pngs);
      glb = {{"written_into_source", true},
             {"triangles", w.triangles},
             {"primitives", w.primitives},
             {"copied_meshes", w.copiedMeshes},
             {"left_out_triangles", w.leftOutTriangles},
             {"dropped_images", w.droppedImages}};
    } catch (const Error& e) {
      glb["why"] = e.what();
    }
  }
  if (!glb["written_into_source"].get<bool>()) exportGlb(*model, path, pngs);
  return glb;
}

void writeRunOutputs(const PipelineResult& result, const std::string& dir) {
  TM_CHECK(result.model, "writeRunOutputs: no model to write");
  OutputFolder out(dir);
  writeRunOutputs(result, out);
}

void writeRunOutputs(const PipelineResult& result, OutputFolder& out) {
  const std::shared_ptr<const TexturedModel>& model = result.exported ? result.exported : result.model;
  TM_CHECK(model, "writeRunOutputs: no model to write");
  const std::string dir = out.staging();  // everything is written here, then swapped in by commit()
  const auto start = Clock::now();
  PngCache pngs(result.scene ? result.scene->project.options.pngCompression : PipelineOptions{}.pngCompression);
  exportObj(*model, dir, "model", &pngs);
  const nlohmann::json glb = exportResultGlb(result, (fs::path(dir) / "model.glb").string(), &pngs);
  std::vector<std::string> files = {"model.obj", "model.mtl", "model.glb"};
  for (const Material& m : model->materials)
    if (!m.texture.empty()) {
      const std::string png = textureFileName("model", m.textureName.empty() ? m.name : m.textureName);
      if (std::find(files.begin(), files.end(), png) == files.end()) files.push_back(png);
    }
  if (result.baked && !result.baked->meshUVs) {  // the mesh's own UVs: no atlas layers (a texture per tile)
    if (result.baked->original)
      writeAtlasLayers(result.baked->originalModel.source, dir, "model");
    else
      writeAtlasLayers(result.baked->atlas, result.baked->image, dir, "model");
    files.insert(files.end(), {"model_atlas_source.png", "model_atlas_holes.png"});
  }
  nlohmann::json report = result.report();
  const double seconds = secondsSince(start);
  report["stages"].push_back(
      {{"stage", stageName(StageId::Export)},
       {"seconds", seconds},
       {"cached", false},
       {"counts", {{"files", files}, {"png_encodes", pngs.encodes()}, {"png_seconds", pngs.seconds()}, {"glb", glb}}}});
  report["total_seconds"] = report["total_seconds"].get<double>() + seconds;
  writeFileAtomic((fs::path(dir) / "report.json").string(), report.dump(2) + "\n");
  out.commit();
}

ModeDecision decideAutoMode(const Scene& scene, int photo) {
  const Photo& p = *scene.photos.at(photo);
  const std::vector<CameraClick> clicks = photoClicks(scene.project, photo);
  const CameraFitOptions options = cameraFitOptions(scene.project.options);
  return decidePhotoMode(*scene.mesh, p, clicks, fitCamera(*scene.mesh, clicks, p.width, p.height, options), options);
}

}  // namespace montage
