// Overlay geometry for the editor's views, built without GL so it can be tested and rebuilt only when
// its inputs change: the photo panes' feature markers, partition curves and rejected pairs as one
// vertex array in photo pixel coordinates (the pane's zoom and pan are shader uniforms, so panning
// uploads nothing), and the choice of which id labels to draw so that none overlap.
#pragma once

#include <vector>

#include "io/project.h"
#include "mapping/partition.h"

namespace montage {

// One vertex: photo pixel x, y (photo.h convention), RGBA in [0,1], and `extra`: for lines the arc
// length in photo pixels from the segment's start when dashed (-1: solid), for points the marker's
// diameter in screen pixels.
inline constexpr int kPaneVertexFloats = 7;

struct PaneOverlayOptions {
  bool curves = true;          // the partition's accepted curves in this photo
  bool rejected = true;        // rejected pairs (dashed red)
  bool features = true;        // feature markers
  int selectedPoint = -1;      // the selected feature point (its rejected pairs always drawn)
  int focusPoint = -1;         // the hovered feature point (same)
  int maxRejectedDrawn = 400;  // above this many in the photo, only those of the selected/focus point
};

struct PaneOverlay {
  std::vector<float> lines;   // GL_LINES vertices, kPaneVertexFloats each
  std::vector<float> points;  // GL_POINTS vertices
  int rejectedInPhoto = 0;    // rejected pairs of this photo (drawn or not)
  bool allRejectedDrawn = true;
};

// The overlay of photo `photo`; `partition` may be null (no result yet).
PaneOverlay buildPaneOverlay(const Project& project, const Partition* partition, int photo,
                             const PaneOverlayOptions& options = {});

// An id label that may be drawn at screen rectangle [lo, lo + size].
struct LabelCandidate {
  Vec2 lo = Vec2::Zero(), size = Vec2::Zero();
  bool always = false;  // the selection or the hover: drawn even when it overlaps
};
// Indices of the labels to draw: every `always` one, then the others in order, each only when it
// overlaps none already chosen (greedy; a uniform grid keeps it near linear).
std::vector<int> placeLabels(const std::vector<LabelCandidate>& labels);

}  // namespace montage
