#include "pipeline.h"

#include <chrono>
#include <filesystem>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "base/util.h"
#include "surface/preview.h"
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
  return fileKey(ref.path) + "|mask:" + (ref.mask.empty() ? "" : fileKey(ref.mask));
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

Mapping mapTexture(const Scene& scene, const JobControl& job, MapCaches* caches) {
  Mapping out;
  auto start = Clock::now();
  PartitionOptions partitionOptions;
  partitionOptions.backgroundThresholdPx = scene.project.options.backgroundThresholdPx;
  out.partition = partitionMesh(scene, partitionOptions, job, caches ? &caches->partition : nullptr);
  out.partitionSeconds = secondsSince(start);

  start = Clock::now();
  FineMapOptions fineOptions;
  fineOptions.seed = scene.project.options.seed;
  fineOptions.lineSearches = scene.project.options.stretchSearches;
  if (fineOptions.lineSearches == 0) fineOptions.finalSweeps = 0;
  CellMapping cells = mapCells(scene, out.partition, fineOptions, job, caches ? &caches->cells : nullptr);
  out.map = std::move(cells.map);
  out.cells = std::move(cells.cells);
  out.stats = cells.stats;
  out.cellsMapped = cells.cellsMapped;
  out.cellsReused = cells.cellsReused;
  out.mapSeconds = secondsSince(start);
  if (scene.project.points.empty())
    out.map.notes.insert(out.map.notes.begin(), "no features: the whole mesh is one empty patch (paper section 3)");
  return out;
}

SurfaceColors colorSurface(const Scene& scene, const Mapping& mapping, const JobControl& job, Tier tier) {
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
  if (tier == Tier::Preview) in.options.detail = kPreviewDetail;
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
  const std::string name = fs::path(scene.project.mesh).stem().string();
  out.model.name = name.empty() ? "model" : name;
  if (scene.project.options.exportTopology == ExportTopology::Original) {
    job.progress(StageId::Bake, 0.8, "transfer to the original mesh");
    const auto start = Clock::now();
    out.original = true;
    // Texels take the montage's own colours (photos, levelling, inpainting), not a second resampling of
    // the refined atlas.
    std::vector<const Photo*> photos;
    for (const auto& p : scene.photos) photos.push_back(p.get());
    const PreviewSurface surface(mapping.map, photos, &colors.levelling, inpaint, options.emptyColor);
    out.originalModel =
        bakeOriginalTopology(*scene.mesh, mesh, mapping.partition.faceParent, out.atlas, out.image, options, {},
                             [&](int f, const Vec3& b) { return surface.color(f, b); });
    out.originalModel.model.name = out.model.name;
    out.transferSeconds = secondsSince(start);
  }
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
    scene->photoKeys.push_back(key);
  }
  cachedPhotos_ = std::move(photos);
  validateProject(project, scene->mesh->numVertices(), scene->mesh->numFaces(), photoSizes(scene->photos));
  return scene;
}

std::string Pipeline::documentKey(const Project& project) const {
  // The document (everything but its file name) and the identity of every file it reads.
  std::string key = projectToJson(project, "");
  key += '|' + fileKey(project.mesh);
  for (const PhotoRef& ref : project.photos) key += '|' + photoKey(ref);
  return key;
}

std::shared_ptr<const PipelineResult> Pipeline::findResult(const Project& project, Tier tier) {
  const std::string key = documentKey(project);
  for (const auto* list : {&finals_, tier == Tier::Preview ? &previews_ : nullptr}) {
    if (!list) continue;
    for (const auto& [k, result] : *list)
      if (k == key) return result;
  }
  return nullptr;
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

  // Partition, Map: rerun when what they read (mesh, photos, correspondences, options) changed; the
  // cells whose content, boundary and photo did not change are reused from the cell cache.
  std::ostringstream key;
  key << meshKey_;
  for (const auto& [k, p] : cachedPhotos_) key << '#' << k;
  const nlohmann::json document = nlohmann::json::parse(projectToJson(project, ""));
  const nlohmann::json& opts = document["options"];
  key << document["points"].dump() << document["chains"].dump() << opts["backgroundThresholdPx"].dump()
      << opts["stretchSearches"].dump() << opts["seed"].dump();
  const bool mapCached = key.str() == mapKey_ && cachedMapping_;
  if (!mapCached) {
    cachedMapping_ = std::make_shared<const Mapping>(mapTexture(*scene, job, &mapCaches_));
    mapCaches_.cells.endRun();
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
                            {"steiner_vertices", mapping.partition.steinerVertices},
                            {"searches", mapping.partition.searches},
                            {"searches_reused", mapCached ? 0 : mapping.partition.searchesReused}}});
  nlohmann::json cellStatus = nlohmann::json::object();
  for (const CellPlan& c : mapping.cells) {
    const std::string status = kCellStatusNames[static_cast<int>(c.status)];
    cellStatus[status] = cellStatus.value(status, 0) + 1;
  }
  result.stages.push_back({StageId::Map,
                           mapCached,
                           mapCached ? 0 : mapping.mapSeconds,
                           {{"faces", mapping.map.numFaces()},
                            {"mapped_faces", mapping.map.numMapped()},
                            {"cells", cellStatus},
                            {"cells_mapped", mapCached ? 0 : mapping.cellsMapped},
                            {"cells_reused", mapCached ? 0 : mapping.cellsReused},
                            {"splits", mapping.stats.splits},
                            {"base_inner_vertices", mapping.stats.baseInnerVertices},
                            {"centroid_fallbacks", mapping.stats.centroidFallbacks},
                            {"flipped_faces", mapping.stats.flippedFaces},
                            {"max_stretch", mapping.stats.maxStretch}}});
  for (const auto& note : mapping.map.notes) result.warnings.push_back("map: " + note);

  // Level + Inpaint: rerun when the mapping, the tier or what they read (strokes, clones, hole
  // modes, their options) changed.
  key << document["strokes"].dump() << document["clones"].dump() << document["holeModes"].dump()
      << opts["seamLevelling"].dump() << opts["inpaintMode"].dump() << opts["maxInpaintVertices"].dump() << '|'
      << kTierNames[size_t(tier)];
  const bool colorCached = mapCached && key.str() == colorKey_ && cachedColors_;
  if (!colorCached) {
    cachedColors_ = std::make_shared<const SurfaceColors>(colorSurface(*scene, mapping, job, tier));
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
                           {{"tier", kTierNames[size_t(tier)]},
                            {"regions", regions},
                            {"refined_vertices", inp.refined.mesh.numVertices()},
                            {"refined_triangles", inp.refined.mesh.numTriangles()}}});
  for (const auto& w : colors.warnings) result.warnings.push_back("inpaint: " + w);

  // Bake (final tier): rerun when the colours or the atlas and export options changed.
  if (tier == Tier::Final) {
    key << opts["atlasSize"].dump() << opts["gutter"].dump() << opts["exportTopology"].dump();
    const bool bakeCached = colorCached && key.str() == bakeKey_ && cachedBake_;
    start = Clock::now();
    if (!bakeCached) {
      cachedBake_ = std::make_shared<const BakeResult>(bakeModel(*scene, mapping, colors, job));
      bakeKey_ = key.str();
    }
    const BakeResult& baked = *cachedBake_;
    StageRecord bake;
    bake.stage = StageId::Bake;
    bake.cached = bakeCached;
    bake.seconds = bakeCached ? 0 : secondsSince(start);
    bake.counts = baked.atlas.stats();
    bake.counts["bake_seconds"] = baked.image.seconds;
    bake.counts["export_topology"] = kExportTopologyNames[size_t(project.options.exportTopology)];
    if (baked.original) {
      const OriginalModel& o = baked.originalModel;
      bake.counts["original"] = {{"charts", o.atlas.charts.size()},  {"utilisation", o.atlas.utilisation},
                                 {"scale", o.atlas.scale},           {"vertices", o.model.mesh.numVertices()},
                                 {"faces", o.model.mesh.numFaces()}, {"seconds", baked.transferSeconds},
                                 {"atlas_seconds", o.atlasSeconds},  {"bake_seconds", o.bakeSeconds},
                                 {"measure_seconds", o.measureSeconds},
                                 {"transfer_loss", o.loss.toJson()}};
    }
    result.stages.push_back(bake);
    result.baked = cachedBake_;
    result.model = std::shared_ptr<const TexturedModel>(cachedBake_, &baked.model);
    result.exported = std::shared_ptr<const TexturedModel>(cachedBake_, &baked.exported());
  }

  result.scene = scene;
  result.mapping = cachedMapping_;
  result.colors = cachedColors_;

  // Keep the result for this document state (undo and redo find it at once).
  auto& list = tier == Tier::Final ? finals_ : previews_;
  list.emplace_back(documentKey(project), std::make_shared<const PipelineResult>(result));
  const size_t keep = tier == Tier::Final ? kFinalStates : kPreviewStates;
  if (list.size() > keep) list.erase(list.begin(), list.end() - keep);
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
  if (mapping && baked && baked->atlas.faceSource.size() == size_t(mapping->partition.mesh.numFaces())) {
    // Where the surface's colours come from, as area shares: photos (and each photo), inpainting, nothing.
    const Mesh& mesh = mapping->partition.mesh;
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
  const std::shared_ptr<const TexturedModel>& model = result.exported ? result.exported : result.model;
  TM_CHECK(model, "writeRunOutputs: no model to write");
  std::error_code ec;
  fs::create_directories(dir, ec);
  TM_CHECK(!ec, located(dir, "cannot create output folder: " + ec.message()));
  const auto start = Clock::now();
  PngCache pngs(result.scene ? result.scene->project.options.pngCompression : PipelineOptions{}.pngCompression);
  exportObj(*model, dir, "model", &pngs);
  exportGlb(*model, (fs::path(dir) / "model.glb").string(), &pngs);
  std::vector<std::string> files = {"model.obj", "model.mtl", "model.glb"};
  for (const Material& m : model->materials)
    if (!m.texture.empty()) {
      const std::string png = "model_" + (m.textureName.empty() ? m.name : m.textureName) + ".png";
      if (std::find(files.begin(), files.end(), png) == files.end()) files.push_back(png);
    }
  if (result.baked) {
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
       {"counts", {{"files", files}, {"png_encodes", pngs.encodes()}, {"png_seconds", pngs.seconds()}}}});
  report["total_seconds"] = report["total_seconds"].get<double>() + seconds;
  writeFileAtomic((fs::path(dir) / "report.json").string(), report.dump(2) + "\n");
}

}  // namespace montage
