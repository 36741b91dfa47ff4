// Synthetic ground-truth scenes: a UV-textured (or solid-patterned) mesh rendered from K cameras
// into photos with a transparent background, with feature correspondences picked by farthest-point
// sampling. They make any mesh a benchmark whose right answer is known.
#pragma once

#include <functional>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "base/common.h"
#include "bench/deform.h"
#include "geometry/raster.h"
#include "io/project.h"

namespace montage {

struct Mesh;

// A deterministic 3D solid colour pattern (sRGB [0,1]) with structure at several scales: used when
// a mesh has no texture, so every surface point has a known, non-trivial colour. `scale` is the
// size of the largest structure in model units.
Vec3f solidPattern(const Vec3& p, double scale);

struct SynthOptions {
  int views = 4;           // number of cameras, spread around the mesh
  int features = 150;      // number of feature vertices (farthest-point sampling)
  unsigned seed = 1;       // seeds the first sample and the camera jitter
  int size = 1024;         // photo width and height in pixels
  double fovYDeg = 35;     // camera field of view
  double minFacing = 0.3;  // a feature is written for a view only if cos(normal, view dir) >= this
  double borderPx = 3;     // ...and it lies this far from the silhouette and the image border
  // Exposure gain per view on linear colour (view k uses exposures[k % size]; empty = 1): photos of one
  // subject taken with different exposures, for seam levelling tests.
  std::vector<double> exposures;
  // Standard deviation (pixels) of a seeded Gaussian error added to each click's x and y (clamped to the
  // photo): clicks as a careful user makes them. 0 = exact projections. The true cameras are unchanged.
  double clickNoisePx = 0;
  // Radial lens distortion of every view (one camera, PhotoCamera's model: OpenCV's k1, k2): the photos are
  // rendered through it, the clicks sit at the distorted projections, and cameras.json carries it (the oracle
  // projects through it). 0, 0 = a pinhole, as before.
  double k1 = 0, k2 = 0;
  // Photos of another subject with a known truth (issue 33): the photos show the mesh deformed (same vertex ids),
  // coloured at each point's undeformed place, and the clicks name the undeformed mesh's vertices. None = the mesh.
  Deformation deform;
};

struct SynthScene {
  SynthOptions options;         // the options the scene was made with
  std::vector<cv::Mat> photos;  // CV_8UC4 RGBA, alpha 0 = background; silhouette antialiased (2x2 supersampling)
  std::vector<Camera> cameras;
  std::vector<int> featureVertices;          // in sampling order
  Project project;                           // photos named photo_<k>.png, mesh path as given
  std::shared_ptr<const Mesh> photographed;  // the deformed copy the photos show (options.deform); null when none
};

// The ground-truth colour function of the surface: colour at a point of face f with barycentrics b.
using SurfaceColor = std::function<Vec3f(int face, const Vec3& bary)>;
// solidPattern over a mesh's surface, its largest structure a quarter of the bounding-box diagonal.
// The mesh must outlive the function.
SurfaceColor meshPattern(const Mesh& mesh);

// Renders and samples a scene. `color` gives the surface colour (texture lookup or solidPattern). With
// options.deform the photos show the deformed copy, each point coloured by `color` at its face and barycentrics
// (its undeformed place: the texture sticks to the surface); features are sampled on `mesh`.
// Progress is reported through `progress(fraction)` when given.
SynthScene synthesize(const Mesh& mesh, const std::string& meshPath, const SurfaceColor& color,
                      const SynthOptions& options, const std::function<void(double)>& progress = {});

// N vertices spread evenly over the surface: farthest-point sampling with geodesic (Dijkstra on
// edges) distances, starting from a vertex chosen by `seed`.
std::vector<int> farthestPointSamples(const Mesh& mesh, int count, unsigned seed);

// Writes photos, project.json and cameras.json (ground truth) into `dir`; a deformed scene also writes the
// photographed mesh as deformed.obj and records it in cameras.json ("deformation": kind, amount, mesh).
void writeSynthScene(const SynthScene& scene, const std::string& dir);

struct PhotoCamera;
// Reads the true cameras of a scene's cameras.json (one per photo, in photo order; k1, k2 when written).
// Throws montage::Error naming the file and the field when it is missing or malformed.
std::vector<PhotoCamera> readSynthCameras(const std::string& path);
// The mesh a scene's photos show when it was made deformed (cameras.json's "deformation"), as a path beside the
// cameras file; empty for a scene of the mesh itself.
std::string readSynthDeformedMesh(const std::string& path);

}  // namespace montage
