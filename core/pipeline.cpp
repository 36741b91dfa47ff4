#include "pipeline.h"

#include <chrono>
#include <filesystem>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "raster.h"
#include "simplify.h"
#include "util.h"

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

namespace {

// The photo with the levelling offsets added over its faces. The offsets are rasterised at texel
// centres and then grown by two texels, so that bilinear lookups at a patch's border read levelled
// texels too.
cv::Mat levelledTexture(const Photo& photo, int p, const Mesh& mesh, const TextureMap& map,
                        const SeamLevelling& levelling) {
  cv::Mat texture = photoTexture(photo);
  if (levelling.cornerOffset.empty()) return texture;
  cv::Mat offset(photo.height, photo.width, CV_32FC3, cv::Scalar::all(0));
  cv::Mat mask(photo.height, photo.width, CV_8UC1, cv::Scalar(0));
  for (int f = 0; f < mesh.numFaces(); ++f) {
    if (map.facePhoto[f] != p) continue;
    const auto& o = levelling.cornerOffset[f];
    scanTriangle(map.cornerUV[f], photo.width, photo.height, [&](int x, int y, const Vec3& b) {
      const Vec3f v = float(b[0]) * o[0] + float(b[1]) * o[1] + float(b[2]) * o[2];
      offset.at<cv::Vec3f>(y, x) = cv::Vec3f(v.x(), v.y(), v.z());
      mask.at<uchar>(y, x) = 1;
    });
  }
  for (int pass = 0; pass < 2; ++pass) {
    cv::Mat grown = mask.clone();
    for (int y = 0; y < photo.height; ++y)
      for (int x = 0; x < photo.width; ++x) {
        if (mask.at<uchar>(y, x)) continue;
        cv::Vec3f sum(0, 0, 0);
        int n = 0;
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const int xx = x + dx, yy = y + dy;
            if (xx < 0 || yy < 0 || xx >= photo.width || yy >= photo.height || !mask.at<uchar>(yy, xx)) continue;
            sum += offset.at<cv::Vec3f>(yy, xx), ++n;
          }
        if (n) offset.at<cv::Vec3f>(y, x) = sum / n, grown.at<uchar>(y, x) = 1;
      }
    mask = grown;
  }
  for (int y = 0; y < photo.height; ++y)
    for (int x = 0; x < photo.width; ++x) {
      if (!mask.at<uchar>(y, x)) continue;
      auto& px = texture.at<cv::Vec4b>(y, x);
      const cv::Vec3f& d = offset.at<cv::Vec3f>(y, x);
      for (int c = 0; c < 3; ++c) px[c] = cv::saturate_cast<uchar>(px[c] + 255.0f * d[c]);
    }
  return texture;
}

// Inpainted faces until the atlas exists: each face gets a square cell of a texture, its corners at
// three corners of the cell, and the refined triangles inside it are drawn with their vertex colours.
cv::Mat inpaintedTexture(const Mesh& mesh, const InpaintResult& inpaint, std::vector<std::array<Vec2f, 3>>& uv) {
  std::vector<int> faces;
  std::vector<double> texels;
  for (int f = 0; f < mesh.numFaces(); ++f) {
    if (inpaint.faceRegion[f] < 0) continue;
    faces.push_back(f);
    const auto p = mesh.facePositions(f);
    const double longest = std::max({(p[1] - p[0]).norm(), (p[2] - p[1]).norm(), (p[0] - p[2]).norm()});
    texels.push_back(longest * inpaint.regions[inpaint.faceRegion[f]].texelsPerUnit);
  }
  if (faces.empty()) return {};
  std::nth_element(texels.begin(), texels.begin() + texels.size() / 2, texels.end());
  const int n = static_cast<int>(faces.size());
  const int cols = static_cast<int>(std::ceil(std::sqrt(double(n))));
  const int rows = (n + cols - 1) / cols;
  int cell = std::clamp(int(std::ceil(texels[texels.size() / 2])) + 2, 4, 32);
  while (cell > 4 && std::max(cols, rows) * cell > 8192) --cell;
  const int width = cols * cell, height = rows * cell;
  cv::Mat texture(height, width, CV_8UC4, cv::Scalar(128, 128, 128, 255));
  cv::Mat written(height, width, CV_8UC1, cv::Scalar(0));
  std::vector<int> slot(mesh.numFaces(), -1);
  std::vector<std::array<Vec2, 3>> corner(n);
  for (int i = 0; i < n; ++i) {
    slot[faces[i]] = i;
    const double x0 = (i % cols) * cell, y0 = (i / cols) * cell;
    corner[i] = {Vec2(x0 + 1, y0 + 1), Vec2(x0 + cell - 1, y0 + 1), Vec2(x0 + 1, y0 + cell - 1)};
    for (int k = 0; k < 3; ++k)
      uv[faces[i]][k] = Vec2f(float(corner[i][k].x() / width), float(1.0 - corner[i][k].y() / height));
  }
  const RefinedSurface& rs = inpaint.refined;
  for (int t = 0; t < rs.mesh.numTriangles(); ++t) {
    const int i = slot[rs.parentFace[t]];
    if (i < 0) continue;
    std::array<Vec2, 3> q;
    for (int k = 0; k < 3; ++k) {
      const Vec3& b = rs.parentBary[t][k];
      q[k] = b[0] * corner[i][0] + b[1] * corner[i][1] + b[2] * corner[i][2];
    }
    const auto& tri = rs.mesh.triangles[t];
    scanTriangle(q, width, height, [&](int x, int y, const Vec3& b) {
      const Eigen::RowVector3f c = float(b[0]) * inpaint.colors.row(tri[0]) + float(b[1]) * inpaint.colors.row(tri[1]) +
                                   float(b[2]) * inpaint.colors.row(tri[2]);
      auto& px = texture.at<cv::Vec4b>(y, x);
      for (int ch = 0; ch < 3; ++ch) px[ch] = cv::saturate_cast<uchar>(255.0f * c[ch]);
      written.at<uchar>(y, x) = 1;
    });
  }
  // Grow each cell's texels outwards by two so bilinear lookups at a triangle's edge stay inside it.
  for (int pass = 0; pass < 2; ++pass) {
    cv::Mat next = written.clone();
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x) {
        if (written.at<uchar>(y, x)) continue;
        cv::Vec4i sum(0, 0, 0, 0);
        int k = 0;
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const int xx = x + dx, yy = y + dy;
            if (xx < 0 || yy < 0 || xx >= width || yy >= height || !written.at<uchar>(yy, xx)) continue;
            if (xx / cell != x / cell || yy / cell != y / cell) continue;  // stay in the cell
            const auto& s = texture.at<cv::Vec4b>(yy, xx);
            sum += cv::Vec4i(s[0], s[1], s[2], s[3]), ++k;
          }
        if (k) {
          texture.at<cv::Vec4b>(y, x) = cv::Vec4b(uchar(sum[0] / k), uchar(sum[1] / k), uchar(sum[2] / k), 255);
          next.at<uchar>(y, x) = 1;
        }
      }
    written = next;
  }
  return texture;
}

}  // namespace

TexturedModel bakeModel(const Scene& scene, const Mapping& mapping, const SurfaceColors& colors,
                        const JobControl& job) {
  job.progress(StageId::Bake, 0.0);
  const Mesh& mesh = mapping.partition.mesh;
  const TextureMap& map = mapping.map;
  const InpaintResult& inpaint = colors.inpaint;
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
  const bool hasInpaint = static_cast<int>(inpaint.faceRegion.size()) == F;
  for (int f = 0; f < F; ++f) {
    const int p = map.facePhoto[f];
    if (p == TextureMap::kEmpty || (hasInpaint && inpaint.faceRegion[f] >= 0)) continue;
    const Photo& photo = *scene.photos[p];
    if (photoMaterial[p] < 0) {
      Material m;
      m.name = "photo" + std::to_string(p);
      m.texture = levelledTexture(photo, p, mesh, map, colors.levelling);
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
  job.progress(StageId::Bake, 0.5);
  if (hasInpaint) {
    cv::Mat texture = inpaintedTexture(mesh, inpaint, model.uv);
    if (!texture.empty()) {
      Material m;
      m.name = "inpainted";
      m.texture = texture;
      const int id = static_cast<int>(model.materials.size());
      model.materials.push_back(std::move(m));
      for (int f = 0; f < F; ++f)
        if (inpaint.faceRegion[f] >= 0) model.faceMaterial[f] = id, model.faceSource[f] = kSourceInpainted;
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
  auto model = std::make_shared<TexturedModel>(bakeModel(*scene, mapping, colors, job));
  StageRecord bake;
  bake.stage = StageId::Bake;
  bake.seconds = secondsSince(start);
  bake.counts = {{"materials", model->materials.size()}};
  result.stages.push_back(bake);

  result.scene = scene;
  result.mapping = cachedMapping_;
  result.colors = cachedColors_;
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
