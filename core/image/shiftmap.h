// Shift-map image completion (He and Sun 2012, "Statistics of patch offsets for image completion"):
// the offsets between similar patches of the known region are counted, the most frequent ones (the
// texture's periods and repeats) become the labels, and a graph cut gives every unknown pixel (and a
// band of known ones around them) the offset to copy it from, with the photomontage seam cost
// (Agarwala et al. 2004) between neighbours.
//
// OpenCV's xphoto shift-map does the same, but reads past the end of its offset list when an image has
// fewer than 60 dominant offsets (valgrind: invalid reads on a 27 x 16 or 54 x 44 canvas); its fill of
// such a canvas then changes from run to run. This one is deterministic (a seeded search) and checks
// every index.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>

namespace montage {

struct ShiftMapOptions {
  int patch = 8;             // patch side (pixels) for the offset statistics
  int offsets = 60;          // most frequent offsets kept as labels (fewer when the image has fewer)
  int minOffset = 16;        // an offset must move a patch this far (pixels, in x or in y): not onto itself
  int searchIterations = 5;  // PatchMatch passes (propagation and random search)
  int rounds = 3;            // alpha-expansion rounds over all labels at most
  int band = 2;              // known pixels within this distance of the unknown ones may be relabelled too
  uint64_t seed = 0x5eedf111;
};

struct ShiftMapStats {
  int labels = 0;     // offsets used (without the identity)
  int domain = 0;     // pixels labelled (unknown and band)
  int unreached = 0;  // unknown pixels no offset could fill (filled from their nearest filled neighbour)
  int moves = 0;      // accepted expansion moves
};

// Fills the pixels of `image` (CV_8UC3, a perceptual space such as L*a*b*) where `known` (CV_8UC1) is
// 0. Known pixels outside the band keep their values. Throws montage::Error on mismatched inputs.
cv::Mat shiftMapFill(const cv::Mat& image, const cv::Mat& known, const ShiftMapOptions& options = {},
                     ShiftMapStats* stats = nullptr);

}  // namespace montage
