#include "pipeline.h"

#include <chrono>
#include <filesystem>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "simplify.h"

namespace fs = std::filesystem;

namespace montage {

void JobControl::checkCancel() const {
  if (cancelled()) throw Cancelled();
}

void JobControl::progress(StageId stage, double fraction, const std::string& what) const {
  checkCancel();
  if (callback_) callback_(stage, fraction, what);
}

namespace {

using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// Identifies a file's current contents cheaply: path, size and modification time.
std::string fileKey(const std::string& path) {
  std::error_code ec;
  const auto size = fs::file_size(path, ec);
  const auto time = fs::last_write_time(path, ec).time_since_epoch().count();
  std::ostringstream key;
  key << path << '|' << size << '|' << time;
  return key.str();
}

std::string photoKey(const PhotoRef& ref) {
  return fileKey(ref.path) + "|mask:" + (ref.mask.empty() ? "" : fileKey(ref.mask));
}

std::vector<std::pair<int, int>> photoSizes(const std::vector<std::shared_ptr<const Photo>>& photos) {
  std::vector<std::pair<int, int>> sizes;
  for (const auto& p : photos) sizes.emplace_back(p->width, p->height);
  return sizes;
}

// The photo as an RGBA8 texture (row 0 = top), alpha from the foreground.
cv::Mat photoTexture(const Photo& photo) {
  cv::Mat rgb8, alpha8, rgba;
  photo.rgb.convertTo(rgb8, CV_8UC3, 255.0);
  photo.alpha.convertTo(alpha8, CV_8UC1, 255.0);
  std::vector<cv::Mat> channels;
  cv::split(rgb8, channels);
  channels.push_back(alpha8);
  cv::merge(channels, rgba);
  return rgba;
}

}  // namespace

std::shared_ptr<const Scene> loadScene(const Project& project, const JobControl& job) {
  Pipeline pipeline;
  bool cached = false;
  return pipeline.loadScene(project, job, cached);
}

Mapping mapTexture(const Scene& scene, const JobControl& job) {
  Mapping out;
  auto start = Clock::now();
  PartitionOptions partitionOptions;
  partitionOptions.backgroundThresholdPx = scene.project.options.backgroundThresholdPx;
  out.partition = partitionMesh(scene, partitionOptions, job);
  out.partitionSeconds = secondsSince(start);

  start = Clock::now();
  ProgressiveMesh pm(out.partition, SimplifyOptions{}, job);
  out.simplifySeconds = secondsSince(start);
  out.collapses = static_cast<int>(pm.records().size());
  out.baseVertices = pm.aliveVertices();
  out.baseFaces = pm.aliveFaces();

  start = Clock::now();
  FineMapOptions fineOptions;
  fineOptions.seed = scene.project.options.seed;
  fineOptions.lineSearches = scene.project.options.stretchSearches;
  if (fineOptions.lineSearches == 0) fineOptions.finalSweeps = 0;
  out.map = coarseToFine(scene, out.partition, pm, fineOptions, job, &out.stats);
  out.mapSeconds = secondsSince(start);
  if (scene.project.points.empty())
    out.map.notes.insert(out.map.notes.begin(), "no features: the whole mesh is one empty patch (paper section 3)");
  return out;
}

TexturedModel bakeModel(const Scene& scene, const Mapping& mapping, const JobControl& job) {
  job.progress(StageId::Bake, 0.0);
  const Mesh& mesh = mapping.partition.mesh;
  const TextureMap& map = mapping.map;
  TexturedModel model;
  model.mesh = mesh;
  model.mesh.cornerUV.clear();  // the model's UVs are in `uv`; the mesh's own are not carried over
  const int F = mesh.numFaces();
  model.uv.assign(F, {Vec2f::Zero(), Vec2f::Zero(), Vec2f::Zero()});
  model.faceMaterial.assign(F, 0);
  model.faceSource.assign(F, kSourceEmpty);

  Material empty;
  empty.name = "empty";
  model.materials.push_back(empty);
  std::vector<int> photoMaterial(scene.photos.size(), -1);
  for (int f = 0; f < F; ++f) {
    const int p = map.facePhoto[f];
    if (p == TextureMap::kEmpty) continue;
    const Photo& photo = *scene.photos[p];
    if (photoMaterial[p] < 0) {
      Material m;
      m.name = "photo" + std::to_string(p);
      m.texture = photoTexture(photo);
      photoMaterial[p] = static_cast<int>(model.materials.size());
      model.materials.push_back(std::move(m));
    }
    model.faceMaterial[f] = photoMaterial[p];
    model.faceSource[f] = p;
    for (int k = 0; k < 3; ++k) {
      const Vec2& px = map.cornerUV[f][k];
      model.uv[f][k] = Vec2f(float(px.x() / photo.width), float(1.0 - px.y() / photo.height));
    }
  }
  job.progress(StageId::Bake, 1.0);
  return model;
}

std::shared_ptr<const Scene> Pipeline::loadScene(const Project& project, const JobControl& job, bool& cached) {
  // The mesh and each photo are reloaded only when their files changed.
  auto scene = std::make_shared<Scene>();
  scene->project = project;
  const std::string meshKey = fileKey(project.mesh);
  cached = meshKey == meshKey_ && cachedMesh_;
  if (!cached) {
    job.progress(StageId::Load, 0.0, "mesh " + fs::path(project.mesh).filename().string());
    LoadedMesh loaded = loadMesh(project.mesh);
    cachedMeshReport_ = loaded.report;
    cachedMesh_ = requireUsable(std::move(loaded));
    meshKey_ = meshKey;
  }
  scene->mesh = cachedMesh_;
  scene->meshReport = cachedMeshReport_;
  std::vector<std::pair<std::string, std::shared_ptr<const Photo>>> photos;
  for (size_t i = 0; i < project.photos.size(); ++i) {
    const std::string key = photoKey(project.photos[i]);
    std::shared_ptr<const Photo> photo;
    for (const auto& [k, p] : cachedPhotos_)
      if (k == key) photo = p;
    if (!photo) {
      job.progress(StageId::Load, double(i + 1) / (project.photos.size() + 1),
                   "photo " + fs::path(project.photos[i].path).filename().string());
      photo = std::make_shared<Photo>(loadPhoto(project.photos[i].path, project.photos[i].mask));
      cached = false;
    }
    photos.emplace_back(key, photo);
    scene->photos.push_back(photo);
  }
  cachedPhotos_ = std::move(photos);
  validateProject(project, scene->mesh->numVertices(), scene->mesh->numFaces(), photoSizes(scene->photos));
  return scene;
}

PipelineResult Pipeline::run(const Project& project, const JobControl& job) {
  PipelineResult result;

  auto start = Clock::now();
  StageRecord load;
  load.stage = StageId::Load;
  std::shared_ptr<const Scene> scene = loadScene(project, job, load.cached);
  load.seconds = secondsSince(start);
  load.counts = {{"vertices", scene->mesh->numVertices()},
                 {"faces", scene->mesh->numFaces()},
                 {"photos", scene->photos.size()},
                 {"features", project.points.size()},
                 {"chains", project.chains.size()}};
  result.stages.push_back(load);
  for (const auto& finding : scene->meshReport.findings) result.warnings.push_back("mesh: " + finding.what);

  // Partition, Simplify, Map: rerun when what they read (mesh, photos, correspondences, options) changed.
  std::ostringstream key;
  key << meshKey_;
  for (const auto& [k, p] : cachedPhotos_) key << '#' << k;
  const nlohmann::json document = nlohmann::json::parse(projectToJson(project, ""));
  key << document["points"].dump() << document["chains"].dump() << document["options"].dump();
  const bool mapCached = key.str() == mapKey_ && cachedMapping_;
  if (!mapCached) {
    cachedMapping_ = std::make_shared<const Mapping>(mapTexture(*scene, job));
    mapKey_ = key.str();
  }
  const Mapping& mapping = *cachedMapping_;
  nlohmann::json rejected = nlohmann::json::object();
  for (const RejectedPair& r : mapping.partition.rejected) {
    const std::string reason = kRejectReasonNames[static_cast<int>(r.reason)];
    rejected[reason] = rejected.value(reason, 0) + 1;
  }
  result.stages.push_back({StageId::Partition,
                           mapCached,
                           mapCached ? 0 : mapping.partitionSeconds,
                           {{"paths", mapping.partition.paths.size()},
                            {"rejected", rejected},
                            {"cells", mapping.partition.numCells},
                            {"steiner_vertices", mapping.partition.steinerVertices}}});
  result.stages.push_back(
      {StageId::Simplify,
       mapCached,
       mapCached ? 0 : mapping.simplifySeconds,
       {{"collapses", mapping.collapses}, {"base_vertices", mapping.baseVertices}, {"base_faces", mapping.baseFaces}}});
  result.stages.push_back({StageId::Map,
                           mapCached,
                           mapCached ? 0 : mapping.mapSeconds,
                           {{"faces", mapping.map.numFaces()},
                            {"mapped_faces", mapping.map.numMapped()},
                            {"base_mapped_faces", mapping.stats.baseMappedFaces},
                            {"centroid_fallbacks", mapping.stats.centroidFallbacks},
                            {"flipped_faces", mapping.stats.flippedFaces},
                            {"max_stretch", mapping.stats.maxStretch}}});
  for (const auto& note : mapping.map.notes) result.warnings.push_back("map: " + note);

  // Bake.
  start = Clock::now();
  auto model = std::make_shared<TexturedModel>(bakeModel(*scene, mapping, job));
  StageRecord bake;
  bake.stage = StageId::Bake;
  bake.seconds = secondsSince(start);
  bake.counts = {{"materials", model->materials.size()}};
  result.stages.push_back(bake);

  result.scene = scene;
  result.mapping = cachedMapping_;
  result.model = model;
  return result;
}

nlohmann::json PipelineResult::report() const {
  nlohmann::json stagesJson = nlohmann::json::array();
  double total = 0;
  for (const auto& s : stages) {
    stagesJson.push_back(
        {{"stage", stageName(s.stage)}, {"seconds", s.seconds}, {"cached", s.cached}, {"counts", s.counts}});
    total += s.seconds;
  }
  nlohmann::json j;
  j["generator"] = "TextureMontage";
  j["stages"] = stagesJson;
  j["total_seconds"] = total;
  j["warnings"] = warnings;
  if (scene) {
    j["project"] = scene->project.file;
    j["mesh"] = {{"path", scene->meshReport.path},
                 {"vertices", scene->meshReport.vertices},
                 {"faces", scene->meshReport.faces},
                 {"genus", scene->meshReport.genus},
                 {"boundary_loops", scene->meshReport.boundaryLoops},
                 {"components", scene->meshReport.components}};
  }
  if (mapping) {
    // Rejected pairs with their reasons, so a user can see why a region stayed empty (first 1000).
    nlohmann::json rejected = nlohmann::json::array();
    for (const RejectedPair& r : mapping->partition.rejected) {
      if (rejected.size() == 1000) break;
      rejected.push_back({{"points", {r.fromPoint, r.toPoint}},
                          {"photo", r.photo},
                          {"reason", kRejectReasonNames[static_cast<int>(r.reason)]},
                          {"detail", r.detail}});
    }
    j["map"] = {{"faces", mapping->map.numFaces()},
                {"mapped_faces", mapping->map.numMapped()},
                {"notes", mapping->map.notes},
                {"rejected_pairs", rejected},
                {"rejected_total", mapping->partition.rejected.size()}};
  }
  return j;
}

void writeRunOutputs(const PipelineResult& result, const std::string& dir) {
  TM_CHECK(result.model, "writeRunOutputs: no model to write");
  std::error_code ec;
  fs::create_directories(dir, ec);
  TM_CHECK(!ec, located(dir, "cannot create output folder: " + ec.message()));
  const auto start = Clock::now();
  exportObj(*result.model, dir, "model");
  exportGlb(*result.model, (fs::path(dir) / "model.glb").string());
  nlohmann::json report = result.report();
  const double seconds = secondsSince(start);
  report["stages"].push_back({{"stage", stageName(StageId::Export)},
                              {"seconds", seconds},
                              {"cached", false},
                              {"counts", {{"files", {"model.obj", "model.mtl", "model.glb"}}}}});
  report["total_seconds"] = report["total_seconds"].get<double>() + seconds;
  writeFileAtomic((fs::path(dir) / "report.json").string(), report.dump(2) + "\n");
}

}  // namespace montage
