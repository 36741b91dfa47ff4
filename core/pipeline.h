// The pipeline object: runs the stages (listed below in paper order) in order, reports progress, honours a
// cancel flag, keeps each stage's last output so an edit reruns only what it invalidates, and
// records per-stage timings and counts for report.json.
#pragma once

#include <array>
#include <atomic>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "atlas/atlas.h"
#include "base/job.h"
#include "geometry/mesh.h"
#include "image/photo.h"
#include "io/model.h"
#include "io/project.h"
#include "io/scene.h"
#include "mapping/fine_map.h"
#include "mapping/partition.h"
#include "mapping/texture_map.h"
#include "surface/balance.h"
#include "surface/inpaint.h"

namespace montage {

struct StageRecord {
  StageId stage = StageId::Load;
  bool cached = false;    // output reused from the previous run
  double seconds = 0;     // wall time of this run (0 when cached)
  nlohmann::json counts;  // stage-specific figures (faces, photos, mapped faces...)
};

// What the mapping stages produce together: the partition (whose mesh, with its Steiner vertices,
// is the mesh every later stage works on), the texture map over that mesh, and their figures.
struct Mapping {
  Partition partition;
  TextureMap map;
  int collapses = 0, baseVertices = 0, baseFaces = 0;
  FineMapStats stats;
  double partitionSeconds = 0, simplifySeconds = 0, mapSeconds = 0;
};

// Colour balance between photos (balance.h), after the mapping and before every stage that reads colours:
// the transforms, and the scene those stages read, whose photos are the balanced copies (a reference
// photo, or one left as it is, is the loaded object itself: unchanged bit for bit).
struct BalancedScene {
  ColorBalance balance;
  std::shared_ptr<const Scene> scene;
};

// What the colour stages add to a mapping: seam levelling offsets and the inpainted/cloned regions.
struct SurfaceColors {
  SeamLevelling levelling;
  InpaintResult inpaint;
  std::vector<std::string> warnings;
};

// Bake (paper section 2, step 5): charts, LSCM, packing and baking into one texture atlas (atlas.h),
// and the model over the partition's mesh that carries it (one material "atlas").
struct BakeResult {
  Atlas atlas;
  AtlasImage image;  // image.rgba is the model's texture (shared, not copied)
  TexturedModel model;
};

struct PipelineResult {
  std::shared_ptr<const Scene> scene;
  std::shared_ptr<const Mapping> mapping;
  std::shared_ptr<const BalancedScene> balanced;  // balanced->scene is what levelling, inpainting and bake read
  std::shared_ptr<const SurfaceColors> colors;
  std::shared_ptr<const BakeResult> baked;
  std::shared_ptr<const TexturedModel> model;  // baked->model
  std::vector<StageRecord> stages;
  std::vector<std::string> warnings;  // things the user should know (mesh caveats, unmapped regions)
  nlohmann::json report() const;      // what report.json holds
};

// Stage functions, in pipeline order.
// Load: reads the mesh and photos of a validated project and checks the project against them.
std::shared_ptr<const Scene> loadScene(const Project& project, const JobControl& job = {});
// Partition, Simplify, Map: correspondences -> partition -> progressive mesh -> texture map.
Mapping mapTexture(const Scene& scene, const JobControl& job = {});
// Balance: colour transforms per photo over the mapping's seams (options.colorBalance, photos' colorLocked).
BalancedScene balanceScene(const std::shared_ptr<const Scene>& scene, const Mapping& mapping,
                           const JobControl& job = {});
// Level + Inpaint: seam levelling over the mapping, then holes, strokes and clones (inpaint.h).
SurfaceColors colorSurface(const Scene& scene, const Mapping& mapping, const JobControl& job = {});
// Bake: see BakeResult.
BakeResult bakeModel(const Scene& scene, const Mapping& mapping, const SurfaceColors& colors,
                     const JobControl& job = {});

class Pipeline {
 public:
  // Runs every stage on `project` (already loaded by loadProject), reusing cached outputs whose
  // inputs did not change. Throws montage::Error for bad input, montage::Cancelled when cancelled.
  PipelineResult run(const Project& project, const JobControl& job = {});
  // The Load stage with this pipeline's cache; `cached` tells whether nothing had to be read.
  std::shared_ptr<const Scene> loadScene(const Project& project, const JobControl& job, bool& cached);

 private:
  std::shared_ptr<const Mesh> cachedMesh_;
  MeshReport cachedMeshReport_;
  std::string meshKey_;
  std::vector<std::pair<std::string, std::shared_ptr<const Photo>>> cachedPhotos_;  // key -> photo
  std::string mapKey_;
  std::shared_ptr<const Mapping> cachedMapping_;
  std::string balanceKey_;
  std::shared_ptr<const BalancedScene> cachedBalance_;
  std::string colorKey_;
  std::shared_ptr<const SurfaceColors> cachedColors_;
};

// Writes DIR/model.obj + model.mtl + model_atlas.png, DIR/model.glb, the atlas layers
// DIR/model_atlas_source.png and DIR/model_atlas_holes.png (when the result has an atlas) and
// DIR/report.json.
void writeRunOutputs(const PipelineResult& result, const std::string& dir);

}  // namespace montage
