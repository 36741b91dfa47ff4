// What is legal in a project but probably a mistake, found against its photos: the warnings that
// `montage info` and `montage run` (and the editor's status) show, each naming the element.
#pragma once

#include <string>
#include <vector>

#include "image/photo.h"
#include "io/project.h"

namespace montage {

struct ProjectWarningOptions {
  double backgroundTolerancePx = 1.0;  // a point this far (file pixels) from the foreground is "on the background"
  int maxPerKind = 20;                 // warnings listed per kind; the rest are counted in one line
};

// Warnings about a project that validateProject accepted, given its loaded photos (photos[i] is the
// project's photo i):
// - a point on a photo's background: "points[3].at[0]: (10, 20) lies on the background of photo 0
//   'a.png' (12.5 px from the foreground)";
// - feature lines that cross in a photo: "chains[1] and chains[4] cross in photo 0 'a.png' at (x, y)
//   (segments 2 and 0)";
// - a chain that crosses itself: "chains[2] crosses itself in photo 1 'b.png' at (x, y) (segments 1 and 4)".
// Segments that share a feature point (chains meeting at a common point) do not cross. O(n log n + k)
// in the number of segments n and crossings k.
std::vector<std::string> projectWarnings(const Project& project, const std::vector<const Photo*>& photos,
                                         const ProjectWarningOptions& options = {});

}  // namespace montage
