#include "pipeline.h"

#include <chrono>
#include <filesystem>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "base/util.h"
#include "image/cutout.h"
#include "io/mesh_io.h"
#include "mapping/simplify.h"

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

std::string photoKey(const PhotoRef& ref) {
  return fileKey(ref.path) + "|mask:" + (ref.mask.empty() ? "" : fileKey(ref.mask)) + (ref.mirror ? "|mirror" : "");
}

// A photo that could not be loaded: 1 x 1 and all background, so that nothing maps into it.
std::shared_ptr<const Photo> placeholderPhoto(const PhotoRef& ref) {
  auto photo = std::make_shared<Photo>();
  photo->path = ref.path;
  photo->maskPath = ref.mask;
  photo->mirrored = ref.mirror;
  photo->width = photo->height = 1;
  photo->rgb = cv::Mat::zeros(1, 1, CV_32FC3);
  photo->alpha = cv::Mat::zeros(1, 1, CV_32FC1);
  photo->distance = cv::Mat(1, 1, CV_32FC1, cv::Scalar(1e6));
  photo->luv = cv::Mat::zeros(1, 1, CV_32FC3);
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

BalancedScene balanceScene(const std::shared_ptr<const Scene>& scene, const Mapping& mapping, const JobControl& job) {
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
  out.balance = balanceColors(mapping.partition.mesh, mapping.map, photos, locked, options, job);
  bool changed = false;
  for (const ColorTransform& t : out.balance.transforms) changed = changed || !t.identity();
  if (!changed) {
    out.scene = scene;
    return out;
  }
  auto balanced = std::make_shared<Scene>(*scene);
  for (size_t i = 0; i < balanced->photos.size(); ++i) {
    job.progress(StageId::Balance, 0.5 + 0.5 * i / balanced->photos.size(), "applying");
    balanced->photos[i] = balancedPhoto(scene->photos[i], out.balance.transforms[i]);
  }
  out.scene = balanced;
  return out;
}

SurfaceColors colorSurface(const Scene& scene, const Mapping& mapping, const JobControl& job) {
  SurfaceColors out;
  const PipelineOptions& o = scene.project.options;
  std::vector<const Photo*> photos;
  for (const auto& p : scene.photos) photos.push_back(p.get());
  job.progress(StageId::Level, 0.0);
  out.levelling = levelSeams(mapping.partition.mesh, mapping.map, photos, o.seamLevelling, job);
  InpaintInput in;
  in.mesh = &mapping.partition.mesh;
  in.map = &mapping.map;
  in.photos = photos;
  in.levelling = &out.levelling;
  in.faceParent = mapping.partition.faceParent;
  in.strokes = scene.project.strokes;
  in.clones = scene.project.clones;
  in.holeModes = scene.project.holeModes;
  in.where = scene.project.file;
  in.options.mode = o.inpaintMode;
  in.options.maxRefinedVertices = o.maxInpaintVertices;
  job.progress(StageId::Inpaint, 0.0);
  out.inpaint = inpaintSurface(in, job, &out.warnings);
  return out;
}

BakeResult bakeModel(const Scene& scene, const Mapping& mapping, const SurfaceColors& colors, const JobControl& job) {
  job.progress(StageId::Bake, 0.0, "charts");
  const Mesh& mesh = mapping.partition.mesh;
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
  job.progress(StageId::Bake, 1.0);
  return out;
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
    const PhotoRef& ref = project.photos[i];
    const std::string key = photoKey(ref);
    std::shared_ptr<const Photo> photo;
    for (const auto& [k, p] : cachedPhotos_)
      if (k == key) photo = p;
    if (!photo) {
      job.progress(StageId::Load, double(i + 1) / (project.photos.size() + 1),
                   "photo " + fs::path(ref.path).filename().string());
      try {
        photo = std::make_shared<Photo>(loadPhoto(ref.path, ref.mask, ref.mirror));
        photos.emplace_back(key, photo);
      } catch (const Error& e) {
        // A broken photo disables only itself: the others still texture.
        scene->skippedPhotos[int(i)] = e.what();
        photo = placeholderPhoto(ref);
      }
      cached = false;
    } else {
      photos.emplace_back(key, photo);
    }
    scene->photos.push_back(photo);
  }
  cachedPhotos_ = std::move(photos);
  if (!scene->skippedPhotos.empty()) {
    std::set<int> skipped;
    for (const auto& [i, reason] : scene->skippedPhotos) skipped.insert(i);
    scene->requested = project;
    scene->project = withoutPhotoReferences(project, skipped);
  }
  validateProject(scene->project, scene->mesh->numVertices(), scene->mesh->numFaces(), photoSizes(scene->photos));
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
  for (const auto& [i, reason] : scene->skippedPhotos) {
    int positions = 0, chains = 0, clones = 0;
    for (const FeaturePoint& pt : project.points)
      for (const PhotoPoint& a : pt.at) positions += a.photo == i;
    for (const FeatureChain& c : project.chains) chains += c.photo == i;
    for (const CloneOp& c : project.clones) clones += c.photo == i;
    result.warnings.push_back(photoName(project, i) + " skipped (" + reason + "): its " + std::to_string(positions) +
                              " positions, " + std::to_string(chains) + " chains and " + std::to_string(clones) +
                              " clones are left out of this run; relink or remove it");
  }
  for (size_t i = 0; i < scene->photos.size(); ++i)
    if (!scene->skippedPhotos.count(int(i)))
      for (const std::string& w : foregroundWarnings(*scene->photos[i]))
        result.warnings.push_back(photoName(project, int(i)) + ": " + w);

  // Partition, Simplify, Map: rerun when what they read (mesh, photos, correspondences, options) changed.
  std::ostringstream key;
  key << meshKey_;
  for (const auto& [k, p] : cachedPhotos_) key << '#' << k;
  const nlohmann::json document = nlohmann::json::parse(projectToJson(project, ""));
  const nlohmann::json& opts = document["options"];
  key << document["points"].dump() << document["chains"].dump() << opts["backgroundThresholdPx"].dump()
      << opts["stretchSearches"].dump() << opts["seed"].dump();
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

  // Balance: rerun when the mapping, the mode or the locks changed.
  key << opts["colorBalance"].dump() << '|';
  for (const PhotoRef& ref : project.photos) key << ref.colorLocked;
  const bool balanceCached = mapCached && key.str() == balanceKey_ && cachedBalance_;
  if (!balanceCached) {
    cachedBalance_ = std::make_shared<const BalancedScene>(balanceScene(scene, mapping, job));
    balanceKey_ = key.str();
  }
  const ColorBalance& bal = cachedBalance_->balance;
  {
    nlohmann::json gains = nlohmann::json::array(), offsets = nlohmann::json::array(), references = nlohmann::json::array();
    for (size_t i = 0; i < bal.transforms.size(); ++i) {
      const ColorTransform& t = bal.transforms[i];
      gains.push_back({t.gain[0], t.gain[1], t.gain[2]});
      offsets.push_back({t.offset[0], t.offset[1], t.offset[2]});
      if (bal.reference[i]) references.push_back(i);
    }
    result.stages.push_back({StageId::Balance,
                             balanceCached,
                             balanceCached ? 0 : bal.seconds,
                             {{"mode", kBalanceModeNames[size_t(project.options.colorBalance)]},
                              {"samples", bal.samples},
                              {"photo_pairs", bal.pairs},
                              {"references", references},
                              {"gain", gains},
                              {"offset", offsets},
                              {"iterations", bal.iterations},
                              {"outlier_share", bal.outlierShare},
                              {"mismatch_before", bal.mismatchBefore},
                              {"mismatch_after", bal.mismatchAfter}}});
    for (const auto& w : bal.warnings) result.warnings.push_back("balance: " + w);
  }
  const Scene& colorScene = *cachedBalance_->scene;

  // Level + Inpaint: rerun when the balance or what they read (strokes, clones, hole modes, their
  // options) changed.
  key << document["strokes"].dump() << document["clones"].dump() << document["holeModes"].dump()
      << opts["seamLevelling"].dump() << opts["inpaintMode"].dump() << opts["maxInpaintVertices"].dump();
  const bool colorCached = balanceCached && key.str() == colorKey_ && cachedColors_;
  if (!colorCached) {
    cachedColors_ = std::make_shared<const SurfaceColors>(colorSurface(colorScene, mapping, job));
    colorKey_ = key.str();
  }
  const SurfaceColors& colors = *cachedColors_;
  const SeamLevelling& lev = colors.levelling;
  result.stages.push_back({StageId::Level,
                           colorCached,
                           colorCached ? 0 : lev.seconds,
                           {{"mode", kLevelModeNames[size_t(project.options.seamLevelling)]},
                            {"seams", lev.seams},
                            {"mean_mismatch_before", lev.meanMismatchBefore},
                            {"mean_mismatch_after", lev.meanMismatchAfter}}});
  const InpaintResult& inp = colors.inpaint;
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
                       {"note", r.note}});
  result.stages.push_back({StageId::Inpaint,
                           colorCached,
                           colorCached ? 0 : inp.seconds,
                           {{"regions", regions},
                            {"refined_vertices", inp.refined.mesh.numVertices()},
                            {"refined_triangles", inp.refined.mesh.numTriangles()}}});
  for (const auto& w : colors.warnings) result.warnings.push_back("inpaint: " + w);

  // Bake.
  start = Clock::now();
  auto baked = std::make_shared<const BakeResult>(bakeModel(colorScene, mapping, colors, job));
  StageRecord bake;
  bake.stage = StageId::Bake;
  bake.seconds = secondsSince(start);
  bake.counts = baked->atlas.stats();
  bake.counts["bake_seconds"] = baked->image.seconds;
  result.stages.push_back(bake);

  result.scene = scene;
  result.mapping = cachedMapping_;
  result.balanced = cachedBalance_;
  result.colors = cachedColors_;
  result.baked = baked;
  result.model = std::shared_ptr<const TexturedModel>(baked, &baked->model);
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
  std::vector<std::string> files = {"model.obj", "model.mtl", "model.glb"};
  for (const Material& m : result.model->materials)
    if (!m.texture.empty()) files.push_back("model_" + m.name + ".png");
  if (result.baked) {
    writeAtlasLayers(result.baked->atlas, result.baked->image, dir, "model");
    files.insert(files.end(), {"model_atlas_source.png", "model_atlas_holes.png"});
  }
  nlohmann::json report = result.report();
  const double seconds = secondsSince(start);
  report["stages"].push_back(
      {{"stage", stageName(StageId::Export)}, {"seconds", seconds}, {"cached", false}, {"counts", {{"files", files}}}});
  report["total_seconds"] = report["total_seconds"].get<double>() + seconds;
  writeFileAtomic((fs::path(dir) / "report.json").string(), report.dump(2) + "\n");
}

}  // namespace montage
