// Texture synthesis in a hole (inpaintMode "synthesis", the paper's future work): the hole and a band
// of mapped faces around it are flattened into one chart (LSCM), the band is drawn into it from the
// photos (levelled colours), and the hole's texels are synthesised from the band by exemplar-based
// inpainting (OpenCV xphoto shift-map, He and Sun 2012: it copies whole patches, so fur, stripes and
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
#include <vector>

#include "base/common.h"
#include "mapping/texture_map.h"

namespace montage {

struct Mesh;
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

// Whether a synthesis's shift-map output came from a SynthesisMemo: no, for the same canvas (exact), or
// for one within the preview's tolerance (near).
enum class SynthesisKept { No, Exact, Near };

// Shift-map results kept across runs. Shift-map is most of a synthesised hole's cost, and an edit leaves
// most holes' canvases as they were. An entry is keyed by a hash of the hole's geometry and of its
// canvas (size and known mask), and holds the canvas's known colours and the shift-map output.
//  - An exact hit (the known colours are the same floats) is the result a new call would give.
//  - A near hit (each known texel within `nearColour` per channel) takes the synthesised texels of
//    the kept result; the known texels are always the current ones. Only the preview allows it.
// Entries not used in the last run are dropped at the start of the next (endRun). Thread-safe.
class SynthesisMemo {
 public:
  struct Entry {
    cv::Mat rgb;     // CV_32FC3: the canvas's known colours (0 elsewhere)
    cv::Mat filled;  // CV_8UC3 L*a*b*: shift-map's output
  };
  // The kept entry under `key` whose known colours match `rgb` exactly (exact = true) or within
  // nearColour (> 0: near, exact = false); null when there is none.
  std::shared_ptr<const Entry> find(uint64_t key, const cv::Mat& rgb, const cv::Mat& known, float nearColour,
                                    bool& exact);
  void store(uint64_t key, std::shared_ptr<const Entry> entry);
  void endRun();  // the run is over: entries it did not use are dropped

 private:
  std::mutex mutex_;
  std::unordered_map<uint64_t, std::shared_ptr<const Entry>> current_, previous_;
};

struct SynthesisInput {
  const Mesh* mesh = nullptr;  // the mesh the map is over
  const TextureMap* map = nullptr;
  std::vector<const Photo*> photos;
  const SeamLevelling* levelling = nullptr;  // offsets added to photo colours (may be null)
  std::vector<int> holeFaces;                // the hole: faces of `mesh` without a photo, edge-connected
  double texelsPerUnit = 0;                  // canvas density (texels per model unit)
  const JobControl* job = nullptr;           // cancellation (may be null): a cancel stops the shift-map call at once
  SynthesisMemo* memo = nullptr;             // shift-map results of earlier runs (may be null)
  float nearColour = 0;                      // memo: reuse within this (sRGB [0,1], per channel); 0 = exact only
  // The faces around each vertex of `mesh` (may be null: made per call), for the band's rings.
  const std::vector<std::vector<int>>* vertexFaces = nullptr;
};

struct SynthesisResult {
  bool ok = false;
  std::string note;                         // what was done, or why it failed (the caller then falls back)
  std::unordered_map<int, int> faceSlot;    // the chart's faces of mesh: index into `corner`
  std::vector<std::array<Vec2, 3>> corner;  // per chart face: its corners on the canvas (pixels)
  cv::Mat image;                            // CV_32FC3 sRGB [0,1]: band from the photos, hole synthesised
  cv::Mat known;                            // CV_8UC1: 255 where the canvas came from a photo
  int bandFaces = 0, rings = 0;
  SynthesisKept kept = SynthesisKept::No;  // the shift-map output came from the memo
  // The synthesised colour at barycentrics b of face f (which must be in the chart).
  Vec3f colorAt(int face, const Vec3& b) const;
};

// Synthesises one hole; never throws for a hole it cannot chart (ok = false and a note instead). Throws
// Cancelled when input.job is cancelled, also in the middle of the shift-map call (runCancellable).
SynthesisResult synthesiseHole(const SynthesisInput& input, const SynthesisOptions& options = {});

}  // namespace montage
