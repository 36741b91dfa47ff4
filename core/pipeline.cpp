#include "pipeline.h"

#include <chrono>
#include <filesystem>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "base/util.h"
#include "geometry/predicates.h"
#include "io/project_warnings.h"
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

std::string photoKey(const PhotoRef& ref, const PipelineOptions& options) {
  return fileKey(ref.path) + "|mask:" + (ref.mask.empty() ? "" : fileKey(ref.mask)) +
         "|side:" + std::to_string(options.maxPhotoSide);
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
        meets = meets || (photo.inside(q.x(), q.y()) && inTriangle(t, q) &&
                          (insidePolygon(clone.polygon, q) ||
                           std::any_of(clone.polygon.begin(), clone.polygon.end(),
                                       [&](const Vec2& v) { return (v - q).norm() < 1e-9; })));
    }
    TM_CHECK(meets, located(file, path + ": the polygon maps onto no point of the target region inside the photo "
                                          "(check the anchor, the scale and the rotation)"));
  }
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
    const std::string key = photoKey(project.photos[i], project.options);
    std::shared_ptr<const Photo> photo;
    for (const auto& [k, p] : cachedPhotos_)
      if (k == key) photo = p;
    if (!photo) {
      job.progress(StageId::Load, double(i + 1) / (project.photos.size() + 1),
                   "photo " + fs::path(project.photos[i].path).filename().string());
      photo = std::make_shared<Photo>(
          loadPhoto(project.photos[i].path, project.photos[i].mask, PhotoLoadOptions{project.options.maxPhotoSide}));
      cached = false;
    }
    photos.emplace_back(key, photo);
    scene->photos.push_back(photo);
  }
  cachedPhotos_ = std::move(photos);
  validateProject(project, scene->mesh->numVertices(), scene->mesh->numFaces(), photoSizes(scene->photos));
  checkClones(project, *scene->mesh, scene->photos);
  std::vector<const Photo*> photoPointers;
  for (const auto& p : scene->photos) photoPointers.push_back(p.get());
  scene->warnings = projectWarnings(project, photoPointers);
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
  for (const auto& w : scene->warnings) result.warnings.push_back("project: " + w);

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

  // Level + Inpaint: rerun when the mapping or what they read (strokes, clones, hole modes, their
  // options) changed.
  key << document["strokes"].dump() << document["clones"].dump() << document["holeModes"].dump()
      << opts["seamLevelling"].dump() << opts["inpaintMode"].dump() << opts["maxInpaintVertices"].dump();
  const bool colorCached = mapCached && key.str() == colorKey_ && cachedColors_;
  if (!colorCached) {
    cachedColors_ = std::make_shared<const SurfaceColors>(colorSurface(*scene, mapping, job));
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
  auto baked = std::make_shared<const BakeResult>(bakeModel(*scene, mapping, colors, job));
  StageRecord bake;
  bake.stage = StageId::Bake;
  bake.seconds = secondsSince(start);
  bake.counts = baked->atlas.stats();
  bake.counts["bake_seconds"] = baked->image.seconds;
  result.stages.push_back(bake);

  result.scene = scene;
  result.mapping = cachedMapping_;
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
  OutputFolder out(dir);
  writeRunOutputs(result, out);
}

void writeRunOutputs(const PipelineResult& result, OutputFolder& out) {
  TM_CHECK(result.model, "writeRunOutputs: no model to write");
  const std::string dir = out.staging();  // everything is written here, then swapped in by commit()
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
  out.commit();
}

}  // namespace montage
