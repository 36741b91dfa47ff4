// Texture synthesis in a hole (inpaintMode "synthesis", the paper's future work): the hole and a band
// of mapped faces around it are flattened into one chart (LSCM), the band is drawn into it from the
// photos (levelled colours), and the hole's texels are synthesised from the band by exemplar-based
// inpainting (shift-map, He and Sun 2012, image/shiftmap: it copies whole patches, so fur, stripes and
// skin keep their structure). inpaint.cpp then takes the synthesised colours as the guidance of its
// Poisson solve (d = their Laplacian), so the border blends into the photos without a seam.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "base/common.h"
#include "mapping/texture_map.h"

namespace montage {

struct Mesh;
struct VertexFaces;
struct Photo;
struct SeamLevelling;
class JobControl;

struct SynthesisOptions {
  double bandAreaRatio = 3;  // band of mapped faces around the hole: this many times the hole's area (3 = as wide
                             // as a round hole's radius), grown ring by ring
  int maxRings = 24;         // at most this many rings of faces in the band
  int maxCanvas = 640;       // largest side of the chart's canvas in texels (coarser texels beyond)
  double blur = 0;           // Gaussian blur of the synthesised texture, sigma in units of the hole's radius
                             // (sqrt(area / pi)): keeps the structure that continues from the border, drops
                             // the grain (0 = the texture as synthesised)
};

// Where a hole's synthesised texture came from: synthesised now (No); kept from an earlier run for the
// same canvas (Exact: what a new shift-map call would return); or kept from an earlier run whose chart
// covers every face of the hole (Chart: the preview's reuse, below).
enum class SynthesisKept { No, Exact, Chart };

// One hole's synthesised texture: the hole and its band flattened into a chart, with the canvas.
struct SynthesisChart {
  std::unordered_map<int, int> faceSlot;    // the chart's faces of the mesh: index into `corner`
  std::vector<std::array<Vec2, 3>> corner;  // per chart face: its corners on the canvas (pixels)
  std::vector<uint64_t> faceKey;            // per chart face: hash of its corner positions
  size_t holeFaces = 0;                     // the first this many chart faces are the hole's
  cv::Mat image;  // CV_32FC3 sRGB [0,1]: band from the photos, hole synthesised (blurred, for structure)
  cv::Mat known;  // CV_8UC1: 255 where the canvas came from a photo
  // What the canvas was made from: its key (hole geometry, canvas size, known mask, blur), the known
  // texels' colours (CV_32FC3, 0 elsewhere), the photos' identity (0: unknown), density and blur.
  uint64_t canvasKey = 0;
  cv::Mat rgb;
  uint64_t photosKey = 0;
  double texelsPerUnit = 0, blur = 0;
  // The synthesised colour at barycentrics b of face f (which must be in the chart).
  Vec3f colorAt(int face, const Vec3& b) const;
};

// Syntheses kept across runs. Shift-map is most of a synthesised hole's cost, and an edit leaves most
// holes as they were.
//  - Exact: a hole whose canvas is the same (same key, the same known colours to the bit) takes the kept
//    chart's image: it is the result a new call would give. Both tiers.
//  - Chart (the preview only): a hole whose every face is in a kept chart, unchanged in position, with
//    the same photos, density (within 25%) and blur, takes that chart as it is, even when the canvas
//    would differ (the hole grew into the kept band or shrank, the band's colours drifted with the
//    balance). Of several, it takes the one that synthesised most of the hole's faces. The synthesised
//    texture is the Poisson solve's guidance (its Laplacian), and the solve takes the hole's current
//    border, so the fill keeps its structure and blends into today's colours; the final synthesises again.
// Charts not used in the last run are dropped at the start of the next (endRun). Thread-safe.
class SynthesisMemo {
 public:
  // The synthesised image of a kept chart for this canvas key whose known colours equal `rgb` where `known`
  // is set (empty when none): what shift-map would return for the canvas. Only the image: the chart's
  // faces may have other indices now (an edit elsewhere renumbers the refined mesh's faces), so the caller
  // lays its own faces over it.
  cv::Mat findExact(uint64_t canvasKey, const cv::Mat& rgb, const cv::Mat& known);
  // A kept chart that covers every face of `holeFaces` (faceKey: the face's position hash), made from
  // the same photos (photosKey != 0), the same blur and a density within 25%; null when none.
  std::shared_ptr<const SynthesisChart> findCovering(const std::vector<int>& holeFaces,
                                                     const std::vector<uint64_t>& faceKey, uint64_t photosKey,
                                                     double texelsPerUnit, double blur);
  void store(std::shared_ptr<const SynthesisChart> chart);
  // Holes whose band did not flatten (both tiers: the flattening depends on the rings' faces and their
  // positions only, `ringsKey`), so that the next run does not try the same LSCM solves again.
  bool flatteningFailed(uint64_t ringsKey);
  // The preview only: a hole whose band failed to flatten shares at least nine in ten of its faces with this
  // one (`holeKey`: the faces' position hashes), both ways. A drag moves a large hole's border by a few faces;
  // its band folds as it did, and the LSCM retries are most of the preview's cost. The final tries again.
  bool flatteningFailedNear(const std::vector<uint64_t>& holeKey);
  void storeFailedFlattening(uint64_t ringsKey, const std::vector<uint64_t>& holeKey);
  void endRun();  // the run is over: charts and failures it did not meet are dropped

 private:
  void keep(const std::shared_ptr<const SynthesisChart>& chart);  // marks it used in this run (mutex held)
  std::mutex mutex_;
  std::vector<std::shared_ptr<const SynthesisChart>> current_, previous_;
  // Failed flattenings by rings key, with their holes' sorted face keys.
  std::unordered_map<uint64_t, std::shared_ptr<const std::vector<uint64_t>>> failed_, previousFailed_;
};

// A hole and what it is filled from: what both syntheses (this chart synthesis and surface_synthesis.h) read.
struct HoleInput {
  const Mesh* mesh = nullptr;  // the mesh the map is over
  const TextureMap* map = nullptr;
  std::vector<const Photo*> photos;
  const SeamLevelling* levelling = nullptr;  // offsets added to photo colours (may be null)
  const VertexFaces* vertexFaces = nullptr;  // faces around each vertex of `mesh` (may be null: made per call)
  std::vector<int> holeFaces;                // the hole: faces of `mesh` without a photo, edge-connected
  const JobControl* job = nullptr;           // cancellation (may be null)
};

struct SynthesisInput : HoleInput {
  double texelsPerUnit = 0;  // canvas density (texels per model unit)
  SynthesisMemo* memo = nullptr;             // syntheses of earlier runs (may be null)
  bool reuseCharts = false;                  // memo: a kept chart covering the hole serves, and a failed flattening of
                                             // a hole sharing nine in ten faces (the preview)
  uint64_t photosKey = 0;                    // what identifies the photos' content (0: unknown, no chart reuse)
};

struct SynthesisResult {
  bool ok = false;
  std::string note;                             // what was done, or why it failed (the caller then falls back)
  std::shared_ptr<const SynthesisChart> chart;  // ok: the chart and its canvas
  int bandFaces = 0, rings = 0;
  SynthesisKept kept = SynthesisKept::No;
  Vec3f colorAt(int face, const Vec3& b) const { return chart->colorAt(face, b); }
};

// Synthesises one hole; never throws for a hole it cannot chart (ok = false and a note instead). Throws
// Cancelled when input.job is cancelled, also in the middle of the shift-map call (runCancellable).
SynthesisResult synthesiseHole(const SynthesisInput& input, const SynthesisOptions& options = {});

}  // namespace montage
