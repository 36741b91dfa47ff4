// The pipeline object: runs the stages (listed below in paper order) in order, reports progress, honours a
// cancel flag, keeps each stage's last output so an edit reruns only what it invalidates, and
// records per-stage timings and counts for report.json.
#pragma once

#include <array>
#include <atomic>
#include <functional>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "atlas/atlas.h"
#include "atlas/transfer.h"
#include "base/job.h"
#include "base/output_folder.h"
#include "geometry/mesh.h"
#include "image/photo.h"
#include "io/model.h"
#include "io/project.h"
#include "io/scene.h"
#include "mapping/camera.h"
#include "mapping/cells.h"
#include "mapping/coverage.h"
#include "mapping/fine_map.h"
#include "mapping/found_silhouette.h"
#include "mapping/partition.h"
#include "mapping/photometric.h"
#include "mapping/projection.h"
#include "mapping/proposals.h"
#include "mapping/seams.h"
#include "mapping/texture_map.h"
#include "stage_graph.h"
#include "surface/balance.h"
#include "surface/inpaint.h"
#include "surface/synthesis.h"

namespace montage {

// What the mapping stages produce together: the partition (whose mesh, with its Steiner vertices,
// is the mesh every later stage works on), the texture map over that mesh, the cells' plans (which
// photo each cell maps into, or why it stays empty) and their figures.
struct Mapping {
  std::shared_ptr<const Partition> partition;  // never null; shared by the mappings derived from it
  TextureMap map;
  std::vector<CellPlan> cells;
  FineMapStats stats;
  int cellsMapped = 0, cellsReused = 0;  // cells mapped in this run; taken from the cell cache
  int cellsProjected = 0;                // cells into photos mapped by projection (mapCells: not mapped)
  double mapSeconds = 0;
};

// The camera stage: a fit per photo (camera.h). A photo that fits is mapped by projection; the
// others take the paper's path.
struct CameraStage {
  std::vector<CameraFit> fits;  // per photo
  int fitted = 0;               // photos that fit a camera as the object itself
  int subjects = 0;             // photos taken for another subject (mapping/subject.h)
  int reused = 0;               // fits reused from the previous run (same clicks, photo, mesh, options)
  double pooledRadialF = 0;     // the largest pooled F of the lens terms over the photos of one camera
  std::vector<SharedIntrinsics> shared;  // per group of object photos of one image size: the joint fit's verdict
  PhotometricRefinement photometric;     // the object photos' poses refined on their overlaps (option photometric)
  double seconds = 0;
};

// The projection stage: the final mapping (the paper's partition with its texture map where faces
// are mapped by projection), the figures, correction fields and views behind it, and the proposed
// correspondences (PipelineResult::proposals).
struct ProjectionStage {
  std::shared_ptr<const Mapping> mapping;  // the paper's mapping itself when no photo fits
  ProjectionResult result;                 // result.map is moved into mapping->map
};

// Colour balance between photos (balance.h), after the final mapping and before every stage that reads
// colours (seams, level, inpaint, bake): the transforms, and the scene those stages read, whose photos are
// the balanced copies (a reference photo, or one left as it is, is the loaded object itself: unchanged bit
// for bit).
struct BalancedScene {
  ColorBalance balance;
  std::shared_ptr<const Scene> scene;
  std::vector<std::shared_ptr<const Photo>> sources;  // per photo: the photo its balanced photo was made from
  int photosKept = 0;                                 // balanced photos taken from the previous run
  double applySeconds = 0;                            // making the balanced photos
};

// What the colour stages add to a mapping: seam levelling offsets and the inpainted/cloned regions.
struct SurfaceColors {
  SeamLevelling levelling;
  InpaintResult inpaint;
  std::vector<std::string> warnings;
};

// Bake (paper section 2, step 5): charts, LSCM, packing and baking into one texture atlas (atlas.h),
// and the model over the partition's mesh that carries it (one material per source, all showing the atlas).
// With exportTopology "original" (the default), the result is also transferred onto the input mesh as
// loaded, with an atlas of its own (atlas/transfer.h), and that is the model the pipeline exports; with
// bakeInto "meshUVs" it is baked into the mesh's own UV layout instead (bakeMeshUVs: UDIM tiles, a texture per
// material and tile).
struct BakeResult {
  Atlas atlas;
  AtlasImage image;       // image.rgba is the model's texture (shared, not copied)
  TexturedModel model;    // over the refined mesh
  bool original = false;  // exportTopology is original: `originalModel` holds the exported model
  OriginalModel originalModel;
  bool meshUVs = false;  // bakeInto is meshUVs: `meshUVBake` holds the exported model (the mesh's own UVs)
  MeshUVBake meshUVBake;
  double transferSeconds = 0;
  const TexturedModel& exported() const { return meshUVs ? meshUVBake.model : original ? originalModel.model : model; }
};

// What a run produces. The preview is what the editor shows after each edit: the mapping, the
// levelling offsets and a light inpainting (the photos are sampled directly through the mapping's
// UVs); the final adds the full inpainting and the atlas bake, for export and `montage run`. Both
// come from the same mapping. The quick preview is the preview with every hole filled harmonically
// (texture, structure, synthesis and RBF fills alike; strokes and clones as they are): the editor shows it
// first after an edit and during a drag, so that its cost does not grow with textured holes, then
// refines it with the preview when nothing newer waits (issue 36). Both previews warm-start alike.
enum class Tier { Preview, Final, Quick };
inline constexpr std::array<const char*, 3> kTierNames = {"preview", "final", "quick"};
inline bool isPreview(Tier tier) {
  return tier != Tier::Final;
}
// Whether a result of tier `have` serves a request for `want` in the same document state: a final serves
// every request, a preview a preview or a quick one, a quick preview only a quick one.
inline bool tierServes(Tier have, Tier want) {
  return have == want || have == Tier::Final || (have == Tier::Preview && want == Tier::Quick);
}
// Whether a quick preview of `project` differs from its preview: some hole may take a fill other than
// harmonic (the project's inpaint mode or a hole's own).
bool quickDiffers(const Project& project);

struct PipelineResult {
  Tier tier = Tier::Final;
  std::shared_ptr<const Scene> scene;
  std::shared_ptr<const CameraStage> cameras;
  std::shared_ptr<const ProjectionStage> projection;
  std::shared_ptr<const Mapping> mapping;         // the final mapping: paper path + projection, then seams (baked)
  std::shared_ptr<const BalancedScene> balanced;  // balanced->scene is what seams, levelling, inpainting and bake read
  std::vector<Proposal> proposals;                // correspondences the cameras propose (proposals.h)
  std::shared_ptr<const SeamResult> seams;        // seam optimisation's figures and per-face seam error
  std::shared_ptr<const SurfaceColors> colors;
  std::shared_ptr<const BakeResult> baked;        // final tier only
  std::shared_ptr<const TexturedModel> model;     // baked->model: the atlas over the refined mesh (final tier only)
  std::shared_ptr<const TexturedModel> exported;  // baked->exported(): what export writes (final tier only)
  std::vector<StageRecord> stages;
  std::vector<std::string> warnings;  // things the user should know (mesh caveats, unmapped regions)
  nlohmann::json report() const;      // what report.json holds
};

// Stage functions, in pipeline order.
// Load: reads the mesh and photos of a validated project and checks the project against them.
std::shared_ptr<const Scene> loadScene(const Project& project, const JobControl& job = {});

// What identifies a photo for the stages (Scene::photoKeys, the cell cache) and seeds their random
// generators: the bytes of the photo and of its mask (fileContentHash), the working resolution and the
// mirror flag; never a path or a file time, so a project copied to another folder, or a photo touched,
// gives the same bytes out. A file that cannot be read gives "unreadable:<path>" (its load then fails and
// the photo is skipped with a warning).
std::string photoContentKey(const PhotoRef& ref, const PipelineOptions& options);
// What the map stage keeps across runs: the partition's searches and each cell's map.
struct MapCaches {
  PartitionMemo partition;
  CellCache cells;
};
// Partition, Map: correspondences -> partition -> per cell: progressive mesh and coarse-to-fine
// (cells.h). What `caches` hold from earlier runs is reused. `projected` (per photo; may be null): the
// photos that fit a camera, whose cells the projection stage maps (mapCells leaves them unmapped).
Mapping mapTexture(const Scene& scene, const JobControl& job = {}, MapCaches* caches = nullptr,
                   const std::vector<char>* projected = nullptr);
// The two halves of mapTexture: the partition, then the cells' maps over it.
std::shared_ptr<const Partition> partitionScene(const Scene& scene, const JobControl& job = {},
                                                MapCaches* caches = nullptr);
Mapping mapPartition(const Scene& scene, std::shared_ptr<const Partition> partition, const JobControl& job = {},
                     MapCaches* caches = nullptr, const std::vector<char>* projected = nullptr);
// Projection: faces that photos fitting a camera see are mapped by projection, the photo chosen per
// face by view selection; the paper's mapping of the other photos is kept (projection.h), and the
// cameras propose correspondences (proposals.h).
// `frames` (may be null) keeps the photos' frames and views across runs (projection.h). `previous` (may be
// null; the preview tier): the last run's projection. View selection starts from its choices (one sweep),
// faces whose views barely changed keep them, and a kept frame within kPreviewFramePx serves.
inline constexpr double kPreviewFramePx = 0.5;
// The preview's silhouette refinement takes a kept contour made through a camera within this many pixels
// (CameraFitOptions::contourReusePx): the projection of a contour generator moves with the camera only
// to second order, so a contour through a nearby camera traces the same silhouette (camera_test measures
// the camera it gives against contours made anew).
inline constexpr double kPreviewContourPx = 3.0;
ProjectionStage projectMapping(const Scene& scene, const std::shared_ptr<const Mapping>& paper,
                               const CameraStage& cameras, const JobControl& job = {}, ViewFrameCache* frames = nullptr,
                               const ProjectionStage* previous = nullptr);
// Balance: colour transforms per photo over the seams between photos of the final mapping
// (options.colorBalance, photos' colorLocked); the photos the later stages read.
// `previous` (may be null): the last run's balance. A photo made from the same source whose new transform
// gives a balanced photo within `toleranceLevels` 8-bit steps of the kept one (balancedPhotoDistance) keeps
// the kept balanced photo, the same object, and, unless its pixels are the same, the kept transform. With
// tolerance 0 (the final) that is exact: the same pixels bit for bit. The preview keeps within
// kPreviewBalanceLevels, and its fits start from the previous transforms (balanceColors' `warm`). `memo`
// (may be null) keeps the seam samples across runs (BalanceMemo, exact).
inline constexpr double kPreviewBalanceLevels = 1.0;
BalancedScene balanceScene(const std::shared_ptr<const Scene>& scene, const Mapping& mapping,
                           const JobControl& job = {}, const BalancedScene* previous = nullptr,
                           double toleranceLevels = 0, BalanceMemo* memo = nullptr);
// Seams: content-based seam optimisation (4.2-4.3, seams.h) over the final map. Returns `mapping` itself
// when nothing moved (seamRounds = 0 or no seam), else a copy with the optimised map (moved out of
// `seams.map`); figures in `seams`.
// `projected` (may be null: none) says which photos are mapped by projection (ProjectionResult::projected,
// SeamInput::projectedPhotos).
// `luv` (per photo, may be empty) holds the L*u*v* tiles of photos the caller keeps (SeamInput::luv); `warm`
// (may be null) the last run's sides for the preview's warm start (SeamMemo; sides whose surroundings moved
// less than kPreviewFramePx take their kept move), and `meshHash` (0: unknown) the partition mesh's hash
// (ProjectionResult::meshHash), with which a warm run may keep the last run's sides (SeamMemo::structure).
std::shared_ptr<const Mapping> optimiseMappingSeams(const Scene& scene, const std::shared_ptr<const Mapping>& mapping,
                                                    const std::vector<char>* projected, SeamResult& seams,
                                                    const JobControl& job = {},
                                                    std::vector<std::shared_ptr<const LuvTiles>> luv = {},
                                                    const SeamMemo* warm = nullptr, uint64_t meshHash = 0);
// Level: seam levelling over the mapping (level.h). `solvers` (may be null) keeps each photo's factorisation.
SeamLevelling levelMapping(const Scene& scene, const Mapping& mapping, const JobControl& job = {},
                           PoissonCache* solvers = nullptr);
// Inpaint: holes, strokes and clones over the levelled mapping (inpaint.h). The preview tier inpaints harmonic
// and texture fills on a coarser refinement (kPreviewDetail of the photos' texel density); guided fills keep
// the final density, since their colours depend on it.
// `synthesis` (may be null) keeps the synthesised holes' charts across runs: the final takes a kept one
// for an identical canvas only, the preview also one that covers the hole (SynthesisMemo).
inline constexpr double kPreviewDetail = 0.25;
SurfaceColors inpaintMapping(const Scene& scene, const Mapping& mapping, SeamLevelling levelling,
                             const JobControl& job = {}, Tier tier = Tier::Final, PoissonCache* solvers = nullptr,
                             SynthesisMemo* synthesis = nullptr);
// Level + Inpaint in one call.
SurfaceColors colorSurface(const Scene& scene, const Mapping& mapping, const JobControl& job = {},
                           Tier tier = Tier::Final, PoissonCache* solvers = nullptr,
                           SynthesisMemo* synthesis = nullptr);
// Bake: see BakeResult.
BakeResult bakeModel(const Scene& scene, const Mapping& mapping, const SurfaceColors& colors,
                     const JobControl& job = {});

// What photo `photo` of `scene` shows in auto mode by its own clicks (mapping/subject.h): the object itself or another
// subject, and why; whatever the photo's mode and the camera option say. (The camera stage decides a photo taken for
// another subject again with the lens terms its camera's object photos pay for.)
ModeDecision decideAutoMode(const Scene& scene, int photo);

// The pipeline's stages as declared (stage_graph.h), in the order of StageId: load, camera, partition, map,
// projection, balance, seams, level, inpaint, bake (the stages Pipeline::run runs) and export (writeRunOutputs).
// Each stage's key, reuse, cancellation point, progress weight (ui/progress.h) and report record come from it.
const StageGraph& pipelineStages();

// The seam stage's outputs: the seamed mapping and the seams' figures (its memo kept apart: Pipeline::seamMemo_).
struct SeamStage {
  std::shared_ptr<const Mapping> mapping;
  std::shared_ptr<const SeamResult> seams;
};

class Pipeline {
 public:
  // What a pipeline keeps after each stage: all it may reuse in later runs (the editor, the benches), or
  // only what this run still reads (`montage run`: one run, so the seams' L*u*v* tiles and the projection's
  // frames go once their stage is over, lowering the peak; the result is the same).
  enum class Keep { ForLaterRuns, ThisRunOnly };
  explicit Pipeline(Keep keep = Keep::ForLaterRuns) : keep_(keep) { frames_.carryViews = keep == Keep::ForLaterRuns; }
  // Runs the stages of `tier` on `project` (already loaded by loadProject), reusing cached outputs
  // whose inputs did not change: the result of an identical document state at once (undo, redo),
  // else the loaded files, the mapping, each cell's map, the colours and the bake as far as their
  // inputs allow. Throws montage::Error for bad input, montage::Cancelled when cancelled.
  PipelineResult run(const Project& project, const JobControl& job = {}, Tier tier = Tier::Final);
  // The Load stage with this pipeline's cache; `cached` tells whether nothing had to be read.
  std::shared_ptr<const Scene> loadScene(const Project& project, const JobControl& job, bool& cached);
  // The best result of an earlier run of the same document state that serves a request for `tier`
  // (tierServes: a final, then a preview, then a quick preview), or null.
  std::shared_ptr<const PipelineResult> findResult(const Project& project, Tier tier);

  // Appends a stage run after the pipeline's own, in the tiers its declaration says: `stage.reads` names the
  // stages whose outputs it reads (their keys are in its key), `run` gets the result so far and returns the
  // stage's figures for the report. Like the pipeline's stages it is rerun only when its key changed, starts
  // with a cancellation point, and reports its progress through the job it gets. Returns its index (its
  // StageRecord::stage). For measurements and checks that belong to a run (tests, benches).
  using ExtraStage = std::function<nlohmann::json(const PipelineResult& soFar, const JobControl& job)>;
  int addStage(StageDecl stage, ExtraStage run);

  static constexpr int kPreviewStates = 24;  // preview and quick results kept (document states, tiers)
  static constexpr int kFinalStates = 2;     // document states whose final results (atlases) are kept

 private:
  std::string documentKey(const Project& project) const;

  Keep keep_;
  std::shared_ptr<const Mesh> cachedMesh_;  // as loaded
  MeshReport cachedMeshReport_;
  struct Welded {  // cachedMesh_ welded (weldIdenticalPositions), when it has vertices to merge
    std::shared_ptr<const Mesh> mesh;
    MeshReport report;
    std::shared_ptr<const std::vector<int>> vertexOf, faceOf;
    int merged = 0;
  } cachedWelded_;
  bool weldTried_ = false;  // cachedWelded_ was made for this value of the option
  std::string meshFile_;    // the mesh file's identity (path, size, time): whether to load it again
  std::string meshKey_;     // the stages' mesh: the file's contents (hash), and whether it was welded
  // fileContentHashHex by the file's identity (path, size, time): an unchanged file is not read again.
  std::map<std::string, std::string> contentHashes_;
  std::string contentHash(const std::string& path);
  // A loaded photo and what later stages derive from it alone, made on first use and kept with it.
  struct CachedPhoto {
    std::string key;
    std::shared_ptr<const Photo> photo;
    std::shared_ptr<const SilhouetteDistance> silhouette;  // camera: silhouette refinement
    std::shared_ptr<ContourMemo> contours;                 // camera: the mesh's (meshKey_) outer contours
  };
  std::vector<CachedPhoto> cachedPhotos_;
  // seams: luvImage(photo), tile by tile, of the photos the last run's seams read (loaded or balanced)
  std::vector<std::pair<std::shared_ptr<const Photo>, std::shared_ptr<const LuvTiles>>> luvTiles_;
  BalanceMemo balanceSamples_;         // balance: the seam edges' samples of the last runs
  ViewFrameCache frames_;              // projection: each fitted photo's frame, by camera
  PoissonCache solvers_;               // inpaint: the factorisations of the last two runs' regions
  SynthesisMemo synthesis_;            // inpaint: the synthesised holes' shift-map results of the last two runs
  // The stages' kept outputs (StageMemo: output and key), as pipelineStages() declares them.
  StageGraph graph_ = pipelineStages();  // and the stages addStage appended
  StageMemo<Partition> partition_;
  MapCaches mapCaches_;  // partition and map: the searches and each cell's map of the last runs
  StageMemo<Mapping> mapping_;
  StageMemo<ProjectionStage> projection_;
  StageMemo<BalancedScene> balance_;
  StageMemo<SeamStage> seams_;
  std::shared_ptr<const SeamMemo> seamMemo_;  // the seams' memo: the next preview's warm start
  StageMemo<SeamLevelling> levelling_;
  StageMemo<SurfaceColors> colors_;
  StageMemo<BakeResult> bake_;
  struct Extra {  // a stage addStage appended
    int index;
    ExtraStage run;
    StageMemo<nlohmann::json> memo;
  };
  std::vector<Extra> extras_;
  // Results by document state, most recent last.
  std::vector<std::pair<std::string, std::shared_ptr<const PipelineResult>>> previews_, finals_;
  std::vector<std::pair<std::string, std::shared_ptr<const CameraFit>>> cachedFits_;  // key -> fit, per photo
  struct SharedCameraGroup {  // the photos of one camera after fitSharedIntrinsics (and their silhouettes)
    SharedIntrinsics summary;
    std::vector<size_t> photos;                          // the members, by photo index
    std::vector<std::string> photoKeys;                  // per member: its own fit's key (its clicks, photo, ...)
    std::vector<CameraFit> joint;                        // per member: the bundle adjustment's fit
    std::vector<std::shared_ptr<const CameraFit>> fits;  // per member: the fit given (refined on its silhouette)
  };
  std::map<std::string, std::shared_ptr<const SharedCameraGroup>> cachedShared_;  // the group's fit keys -> group
  struct PhotometricCameras {  // refineCamerasPhotometric's verdict on the fits given, and the fits it gives
    PhotometricRefinement summary;
    std::vector<std::shared_ptr<const CameraFit>> fits;  // per photo
  };
  std::pair<std::string, std::shared_ptr<const PhotometricCameras>> cachedPhotometric_;  // the fits' keys -> verdict
  struct FoundCamera {  // a photo without a cut-out: the silhouette found around the mesh's outline, and its fit
    std::shared_ptr<const Photo> photo;                  // the photo with that silhouette as its foreground
    std::shared_ptr<const SilhouetteDistance> distance;  // of `photo`: the photometric refinement's silhouette term
    std::shared_ptr<const CameraFit> fit;                // refined on it (the search's verdict in silhouetteSearch)
  };
  std::map<std::string, std::shared_ptr<const FoundCamera>> cachedFound_;  // the photo's fit key -> its search
  // The camera stage: each photo's fit, reused from cachedFits_ while its key (the photo, the mesh, its clicks,
  // `fieldsKey`: the camera's declared fields) stays; the preview refits from the last camera. Sets `key` to
  // the fits' keys.
  std::shared_ptr<const CameraStage> fitCameras(const Scene& scene, const Project& project,
                                                const std::string& fieldsKey, Tier tier, const JobControl& job,
                                                std::string& key);
};

// The projection oracle of a synthetic scene (`montage eval --oracle`): the project's mesh and photos
// textured through the given true cameras (one per photo, e.g. synth's cameras.json) with no clicks:
// projection mapping, view selection, colour balance, levelling, inpainting and bake, as the pipeline does
// them. The covered PSNR of its model is the ceiling of any result on that scene.
PipelineResult projectionOracle(const Project& project, const std::vector<PhotoCamera>& cameras,
                                const JobControl& job = {});
// The oracle of a scene whose photos show a deformed copy of the project's mesh (`montage synth --deform`: the
// same vertex ids and faces, its file `photographedMesh`): the true correspondence. projectionOracle on the
// deformed mesh (projection through the true cameras, visibility from its z-buffer), then every point of its model
// moved to the same surface point of the project's mesh (bench/deform's moveToRest): the undeformed mesh textured
// by where each of its points lands in the photos.
PipelineResult deformedProjectionOracle(const Project& project, const std::vector<PhotoCamera>& cameras,
                                        const std::string& photographedMesh, const JobControl& job = {});

// Guidance to full coverage (mapping/coverage.h) over a result's final mapping, its cameras and views;
// an empty report (mapped share 0, no regions) when the result has no mapping.
CoverageReport coverageOf(const PipelineResult& result, const CoverageOptions& options = {});

// Writes the result's GLB: a glTF mesh exported in its own topology goes back into its own file (exportGlbInto:
// skins, morph targets and every attribute kept); otherwise, or when that cannot be (the file changed, its geometry
// is compressed), a new GLB (exportGlb). Returns what happened: {"written_into_source", and its counts or "why"}.
nlohmann::json exportResultGlb(const PipelineResult& result, const std::string& path, PngCache* pngs = nullptr);

// Writes DIR/model.obj + model.mtl + model_atlas.png, DIR/model.glb, the atlas layers
// DIR/model_atlas_source.png and DIR/model_atlas_holes.png (when the result has an atlas) and
// DIR/report.json. The atlas PNG is encoded once (options.pngCompression) and the GLB embeds the same
// bytes. DIR is replaced as one unit (OutputFolder: staging folder, lock, one rename).
void writeRunOutputs(const PipelineResult& result, const std::string& dir);
// The same into an OutputFolder taken earlier (so that `montage run` checks and locks --out before the
// pipeline runs): writes into its staging folder, then commits it.
void writeRunOutputs(const PipelineResult& result, OutputFolder& out);

}  // namespace montage
