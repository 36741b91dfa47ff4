// Projection mapping for photos that fit a camera (camera.h): every vertex a fitted photo sees gets
// its projection as UV, plus a smooth correction field that keeps the photo's clicks exact; faces are
// given to photos by view selection (view_select.h), as photogrammetric texturers do. Faces the
// paper's path mapped to photos of another subject keep that mapping; faces no photo sees stay
// empty for inpainting.
//
// Shapes and units: vertex ids and face ids are those of the mesh given (the partition's mesh, whose
// first vertices are the input mesh's); UVs are photo pixel coordinates (photo.h).
#pragma once

#include <array>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <set>
#include <string>
#include <vector>

#include "base/common.h"
#include "geometry/raster.h"
#include "io/options.h"
#include "mapping/camera.h"
#include "mapping/subject.h"
#include "mapping/texture_map.h"

namespace montage {

struct Mesh;
struct Photo;
struct Scene;
struct Project;
struct Partition;
class JobControl;

// A smooth 2D field over the surface that equals the clicks' residuals (click - projection) at their
// vertices: around each click a compactly supported Wendland C2 bump (3D distance) reaching
// max(localRadiusPx, 4 x its residual) pixels in the photo, so that no bump can fold the texture
// (gradient about 1/4 at most) and there is no step at its edge; 0 beyond, where the camera alone
// rules. Where bumps overlap, their weights are solved so that every click stays exact.
// (A second, coherent part, Wendland RBFs over the click spacing ridge-regularised by generalised
// cross-validation, was measured and dropped: it spread click noise over the surface, docs/pipeline.md.)
// A photo of another subject (mapping/subject.h) has no bumps: its clicks are the handles of a warp of the photo
// plane applied to the camera's projection, and only the surface inside its outlines maps.
struct CorrectionField {
  std::vector<Vec3> centres;                // click vertex positions, model units
  std::vector<Vec2> local;                  // weights of the bumps, pixels
  std::vector<double> localSupport;         // per click, model units
  ImageWarp warp;                           // another subject: the projection's warp (empty for the object itself)
  std::vector<std::vector<Vec2>> outlines;  // another subject: the photo's closed feature polygons, pixels; when
                                            // there are any, only the surface inside one of them maps
  // Another subject: the mesh edges (vertex pairs, lower id first, sorted) of the paths along the outlines' sides,
  // when every side became a path (`outlineWalls`). They split the surface into regions; a region maps when most
  // of its faces' images lie inside an outline, and all of it maps then, its border too (a path's image bulges
  // off the polygon's straight side). Empty: each face's image must lie inside an outline.
  std::vector<std::pair<int, int>> walls;
  Vec2 at(const Vec3& p) const;  // the bumps' sum, pixels
  bool empty() const { return centres.empty() && warp.empty(); }
  uint64_t hash(uint64_t seed) const;  // of everything above
};

// The field of one photo's clicks (mode decides which), over the positions of `mesh`.
// `localRadiusPx`: the smallest reach of a click's bump, photo pixels.
// `noiseThreshold`: mode `noise` moves the texture at a click by its residual shrunk by this many times
// fit.noisePx (soft thresholding: a residual the noise explains moves nothing, exact clicks stay exact).
CorrectionField correctionField(const Mesh& mesh, const CameraFit& fit, CorrectionMode mode, double localRadiusPx = 8,
                                double noiseThreshold = 3);

// The field of a photo of another subject (fit.subject): the warp of its clicks (from their projections to the
// clicks), and its outline: the project's closed feature polygons in that photo.
CorrectionField subjectField(const Project& project, const CameraFit& fit, int photo,
                             const SubjectOptions& options = {});
// The walls of photo `photo`'s outlines (CorrectionField::walls) over `partition`'s mesh: empty unless every side
// of every closed chain of the photo became a path.
std::vector<std::pair<int, int>> outlineWalls(const Project& project, const Partition& partition, int photo);

// Where a fitted photo puts a surface point: its projection, warped, plus the correction. False when behind.
bool predictPixel(const CameraFit& fit, const CorrectionField& field, const Vec3& p, Vec2& pixel);

struct ProjectionOptions {
  CorrectionMode correction = CorrectionMode::Noise;  // clicks kept exact by the correction field
  double localRadiusPx = 8;       // correction: a click's own bump reaches at least this far (photo pixels)
  double noiseThreshold = 3;      // correction `noise`: a click moves the texture by its residual less this many
                                  // times the clicks' noise (CameraFit::noisePx; 3: 99% of pure-noise residuals)
  double smoothness = 1.0;        // view selection: weight of a seam edge (Potts, per mean edge length) against
                                  // the data cost of a face (per mean face area); 0 = best view per face
  double minCos = 0.05;           // faces seen more obliquely than this (cosine) are not textured from a photo
  int maxHidden = 1;              // a face is textured with at most this many of its corners and three off-centre
                                  // samples hidden (its centroid seen, and none when it lies within
                                  // silhouetteMarginPx of the silhouette); 0 = the whole face must be seen
  double silhouetteMarginPx = 4;  // view quality falls linearly within this distance of the silhouette
  double depthTolerance = 0.005;  // occlusion test tolerance, share of the bounding-box diagonal
  double maxBackgroundPx = 1.0;   // a face whose UVs lie farther than this from the foreground is refused
  int maxSweeps = 8;              // view selection: alpha-expansion sweeps at most (it stops when one changes
                                  // nothing; the editor's preview runs one, from the last run's labels)
  double reuseFramePx = 0;        // > 0: a kept frame of a camera within this many pixels serves (the preview
                                  // tier; ViewFrameCache::frame)
};

// What a fitted photo's view needs from its camera alone: the input mesh rendered through the camera
// and the distance to the silhouette. It depends on the input mesh, the photo and the camera, never on
// the partition (whose faces lie inside the input's faces), so it is kept across edits (ViewFrameCache).
struct ViewFrame {
  Camera camera;         // the camera it was rendered through
  RasterBuffers raster;  // the input mesh through the pinhole camera: depth and input face id (no barycentrics)
  cv::Mat silhouette;    // CV_32F, camera pixels: distance to the silhouette (of the rendered mesh, and of the
                         // photo's own foreground), pixels
  size_t bytes() const;
};

// Renders `input` through `camera` for `photo` (sizes must agree).
// `foreground`: the photo's foregroundDistance at the camera's size when the caller keeps one.
ViewFrame viewFrame(const Mesh& input, const Photo& photo, const Camera& camera, const cv::Mat* foreground = nullptr);

// Distance (pixels, CV_32F at width x height) to the edge of the photo's own foreground, inside it; empty
// for photos without a background. It depends on the photo alone.
cv::Mat foregroundDistance(const Photo& photo, int width, int height);

struct PhotoView;

// What a view reads of the refined mesh, kept (for the last mesh views were made on) so that a view made on
// one refinement of the input can carry its entries over to the next one (an added or deleted feature
// moves only some paths).
struct ViewMesh {
  uint64_t hash = 0;                      // ProjectionResult::meshHash
  double diagonal = 0;                    // of the bounding box (the depth tolerance's scale)
  std::vector<Vec3> positions;            // #V
  std::vector<uint64_t> around;           // #V: hash of the sorted input faces around the vertex
  std::vector<std::array<int, 3>> faces;  // #F
  std::vector<int> faceParent;            // #F
};
ViewMesh viewMesh(const Mesh& mesh, const std::vector<int>& faceParent, uint64_t hash);

// Which entries of a view on `from` a view on `to` may take: per vertex of `to`, the vertex of `from` at the
// same position (bit for bit, and the only one there) with the same input faces around it, else -1; per
// face of `to`, the face of `from` with such corners in the same order and the same parent, else -1. Empty
// when the two bounding boxes differ (the depth tolerance would).
struct ViewCarry {
  std::vector<int> vertex, face;
  int vertices = 0, faces = 0;  // how many are carried
};
ViewCarry carryOver(const ViewMesh& from, const ViewMesh& to);

// Frames and views kept across runs. A frame is keyed by the caller's identity of each photo (file, mask,
// mesh) and the camera; a view also by a hash of everything else it reads (the refined mesh, the fit with
// its correction field, the options). Both are exact: a kept one equals what would be computed.
class ViewFrameCache {
 public:
  // Per photo: what identifies the photo and the input mesh (the pipeline's photo and mesh keys).
  std::vector<std::string> photoKeys;
  // The cache keeps the ViewMesh of the last mesh views were made on (mesh()), so that the next run's views of
  // another refinement can carry their entries over (view()); false for a cache that keeps nothing for a next run.
  bool carryViews = true;
  // Thread-safe: frames of several photos may be asked for at once. `reusePx` > 0 (the preview tier): a kept
  // frame of the same photo whose camera puts every sampled vertex of `input` within reusePx pixels of where
  // `camera` puts it serves instead (visibility and silhouette distances then err by at most that much).
  std::shared_ptr<const ViewFrame> frame(int photo, const Mesh& input, const Photo& image, const PhotoCamera& camera,
                                         double reusePx = 0);
  // The view of `photo` on the mesh hashed `meshHash` whose other inputs hash to `settings`, made by `make`
  // when not kept. `make` gets the kept view of the same photo and settings on another mesh, if any (null
  // otherwise), to carry over what the two meshes share. Thread-safe.
  std::shared_ptr<const PhotoView> view(int photo, uint64_t meshHash, uint64_t settings,
                                        const std::function<PhotoView(const PhotoView* base)>& make);
  // The ViewMesh of the mesh hashed `hash`: the kept one when it is of that mesh, else made by `make` and
  // kept instead. `previous` receives the one kept before (of the mesh the last views were made on).
  std::shared_ptr<const ViewMesh> mesh(uint64_t hash, const std::function<ViewMesh()>& make,
                                       std::shared_ptr<const ViewMesh>& previous);
  void endRun();                 // forgets frames and views this run did not use
  void clear();                  // forgets everything (a run that keeps nothing for the next)
  int reused = 0, computed = 0;  // frames, this run
  int nearReused = 0;            // frames, this run: of the reused, those rendered through a camera within reusePx
  int viewsReused = 0;           // views, this run

 private:
  std::string photoKey(int photo) const;
  std::mutex mutex_;  // frame() and view() are called for several photos at once
  std::map<std::string, std::shared_ptr<const ViewFrame>> frames_, used_;
  std::map<std::string, std::shared_ptr<const PhotoView>> views_, usedViews_;
  // Per photo and settings: the last view made, whatever its mesh (the base of the next one).
  std::map<std::string, std::shared_ptr<const PhotoView>> latest_, usedLatest_;
  std::shared_ptr<const ViewMesh> mesh_;       // the last one asked for (one per cache: views keep only its hash)
  std::map<std::string, cv::Mat> foreground_;  // per photo key and size: foregroundDistance
  std::set<std::string> usedForeground_;       // photo keys this run asked for
};

// What one fitted photo sees of a mesh.
struct PhotoView {
  int photo = -1;
  std::vector<Vec2> vertexUV;             // #V: projection + correction, pixels (NaN behind the camera)
  std::vector<char> vertexVisible;        // #V: in the image, in front, not occluded
  std::vector<float> vertexSilhouettePx;  // #V: distance of the projection to the silhouette (mesh or photo), px
  std::vector<float> faceQuality;         // #F: > 0 when the photo can texture the face (projected area in px^2
                                          // times the silhouette factor); 0 when not
  std::vector<Vec3f> edgeLuv;             // per mesh edge (OpenMesh index) whose two faces it can texture: the
                                          // photo's L*u*v* at the midpoint of the edge's UVs (view selection's
                                          // smoothness); unset elsewhere
  std::vector<char> faceRefused;  // #F: 1 refused for a flip, 2 for the background, 3 outside the outline, else 0
  int refusedFlipped = 0, refusedBackground = 0;  // faces otherwise seen, refused for a flip / the background
  int refusedOutline = 0;                         // ... for lying outside the photo's outline (another subject)
  uint64_t meshHash = 0;                          // the mesh it was made on (with a ViewFrameCache)
};

// Per photo: its view (null for a photo that does not fit). Views are shared between results whose
// photo, camera and mesh agree (ViewFrameCache), so results kept for undo cost little each.
using PhotoViews = std::vector<std::shared_ptr<const PhotoView>>;

// Computes the view of photo `fit` (its camera and correction field) on `mesh`, a refinement of the
// input mesh `frame` was rendered from: `faceParent` (#F of mesh) gives each face's input face.
// `base` (optional): a view of the same photo, camera, field and options on another refinement of the
// same input, and `carry` = carryOver(base's mesh, this mesh): the vertices and faces it carries take base's
// entries (what a fresh computation gives them: they read nothing else); the rest are computed.
PhotoView viewPhoto(const Mesh& mesh, const std::vector<int>& faceParent, const ViewFrame& frame, const Photo& photo,
                    int photoIndex, const CameraFit& fit, const CorrectionField& field,
                    const ProjectionOptions& options, const PhotoView* base = nullptr,
                    const ViewCarry* carry = nullptr);

// Per photo of another subject: the map it took (the warp or the paper's), why, and the figures compared.
struct SubjectChoice {
  int photo = -1;
  bool warp = false;  // mapped by its camera and warp; else by the paper's piecewise map
  std::string why;
  int warpFaces = 0, paperFaces = 0;             // faces each would map (the paper's: of those the camera sees)
  double warpArea = 0, paperArea = 0;            // their area, share of the surface
  int warpFolds = 0;                             // faces the warp would fold (seen and facing the camera, flipped)
  double warpStretch = 0, paperStretch = 0;      // normalised L2 stretch over the faces each maps (1 = isometric up to
                                                 // scale; 0 when it maps none)
  double heldOutMedianPx = 0, heldOutMaxPx = 0;  // the warp's leave-one-out error at the clicks, pixels
};

// Compares, for a photo of another subject, its camera and warp (its view and field) with the paper's map of it
// (the faces `paperMap` gives it): the warp unless it folds more than options.maxFoldShare of its faces, or the
// paper's map covers as much with less than 1 / options.stretchRatio of its stretch.
SubjectChoice chooseSubjectMap(const Mesh& mesh, const TextureMap& paperMap, const PhotoView& view,
                               const CorrectionField& field, const CameraFit& fit, const SubjectOptions& options = {});

// The projection stage's output: the final texture map and its figures.
struct ProjectionResult {
  TextureMap map;                           // the paper's map with projection-mapped faces replaced/filled
  std::vector<CorrectionField> fields;      // per photo (empty for photos not mapped by projection)
  PhotoViews views;                         // per photo (null for photos not mapped by projection)
  std::vector<char> projected;              // per photo: mapped by projection (its camera: the object itself, or
                                            // another subject whose warp won over the paper's map)
  std::vector<SubjectChoice> subjects;      // photos of another subject, in photo order
  std::vector<int> photoFaces;              // per photo: faces mapped to it in the final map
  std::vector<int> photoProjectedFaces;     // per photo: of those, mapped by projection
  std::vector<int> photoRefusedFlipped;     // per photo: faces refused for a flip
  std::vector<int> photoRefusedBackground;  // per photo: faces refused for landing on the background
  int fittedPhotos = 0;
  int filledFaces = 0;          // faces empty after the paper's path, now mapped by projection
  int relabelledFaces = 0;      // faces the paper's path gave to a fitted photo, now mapped to another one
  int droppedFaces = 0;         // faces the paper's path gave to a fitted photo that no fitted photo can texture
                                // (occluded, flipped or on the background there): left for inpainting
  int seenFaces = 0;            // faces some fitted photo can texture
  int emptyFaces = 0;           // faces left empty (for inpainting)
  int selectionSweeps = 0;      // alpha-expansion sweeps of the view selection
  int selectionKept = 0;        // faces that kept the previous run's photo without selection (`previous`)
  std::vector<int> faceLabels;  // per face of the mesh: the photo view selection chose, or -1 (empty, or the
                                // paper's path)
  uint64_t meshHash = 0;        // the views' hash of the mesh (0 when no ViewFrameCache was given)
  double selectionEnergy = 0;
  int framesReused = 0;     // fitted photos whose frame (ViewFrame) came from the cache
  int framesNear = 0;       // of those, frames of a camera within ProjectionOptions::reuseFramePx
  int viewsReused = 0;      // fitted photos whose view (PhotoView) came from the cache
  int viewsCarried = 0;     // of the others, views made from a kept view on another mesh
  double carriedShare = 0;  // the vertices and faces they carried over, share of all
  double frameSeconds = 0;  // the frames not in the cache (part of viewSeconds)
  double viewSeconds = 0, selectSeconds = 0, seconds = 0;
};

// The preview's view selection (projectionFill's `previous`): a face is still when, in every photo whose view
// changed, its quality moved by at most this share and the colours at its edges by at most this CIE Delta
// E*uv (a just noticeable difference).
inline constexpr double kStillQuality = 0.02;
inline constexpr double kStillDeltaE = 2.3;

// Maps by projection every face a fitted photo can texture (fits[p].fits), keeping the paper's
// mapping of faces on photos that do not fit. `paperMap` is over partition.mesh. When no photo fits,
// the map is returned unchanged.
// Views of fitted photos are computed in parallel; their frames come from `frames` when given.
// `startLabels` (per input face, the range of partition.faceParent; may be null): the photo (or -1) view
// selection starts a face from where it is allowed, e.g. the last run's choice; else its cheapest photo.
// `previous` (may be null; the preview tier): the last run's result. When it was over the same mesh, a face
// whose data costs and edge colours barely changed since (kStillQuality, kStillDeltaE), and that lies more
// than two rings away from any face that changed, keeps the photo it had: view selection runs on the rest.
ProjectionResult projectionFill(const Scene& scene, const Partition& partition, const TextureMap& paperMap,
                                const std::vector<CameraFit>& fits, const ProjectionOptions& options,
                                const JobControl& job, ViewFrameCache* frames = nullptr,
                                const std::vector<int>* startLabels = nullptr,
                                const ProjectionResult* previous = nullptr);

}  // namespace montage
