// Guidance to full coverage (issue 14): from what the mapping stages produced (the partition, the final
// texture map, the cells' plans, the cameras), every unmapped connected region of the surface with its
// area, why it is empty in plain words and what to click to fix it; "where to click next" (the region
// whose mapping gains the most area); the rejected pairs grouped by reason, with the pairs that bear on
// no empty region (expected far crossings) marked.
//
// Causes come from the real record, cell by cell: a region's faces are grouped by partition cell, and
// each part is explained by its cell's plan (cells.h), the rejected pairs between the features around
// it (partition.h) and, for photos whose camera fits, whether any photo sees it (projection.h).
#pragma once

#include <array>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "base/common.h"
#include "mapping/partition.h"
#include "mapping/projection.h"

namespace montage {

struct Project;
struct TextureMap;
struct CellPlan;
struct CameraFit;

// Why part of a region is empty.
enum class CoverageCause {
  NotSeen,         // no photo sees it (every photo's camera fits, none textures these faces)
  FewFeatures,     // fewer than three features around it
  NoCommonPhoto,   // its corner features share no photo
  NeedsRoom,       // a pair around it found no mesh path (partition: no path)
  CurveCrosses,    // a pair around it crosses an accepted curve in its photo
  OverBackground,  // a pair around it runs over a photo's background
  CyclicOrder,     // a pair around it has another order of paths in the photo than on the mesh
  NotTriangle,     // the paths around it do not close a triangle, and no rejected pair says why
  FeatureInside,   // a feature inside it has no paths to the corners
  Mirrored,        // its texture triangle is mirrored in every common photo
  TouchesBorder,   // it reaches the mesh's open border (the paper's path maps only closed cells)
  NotDisc,         // it wraps around a handle
  Failed,          // its cell's map could not be built
  Unprojected,     // its cell is planned to a photo, but the projection left these faces (occluded, background)
};
inline constexpr const char* kCoverageCauseNames[] = {
    "not seen",        "few features", "no common photo", "needs room",     "curve crosses",
    "over background", "cyclic order", "not a triangle",  "feature inside", "mirrored",
    "touches border",  "not a disc",   "failed",          "unprojected"};

// One click that would fix a cause: a vertex of Partition::mesh to click in a photo; `point` >= 0 when it
// is an existing feature (click it in one more photo), -1 for a new feature.
struct CoverageClick {
  int point = -1;  // Project::points index
  int vertex = -1;
  int photo = -1;
  int id = -1;  // the point's id as the user knows it (pointId)
  bool valid() const { return vertex >= 0 && photo >= 0; }
};

// The explanation of one part of a region (the faces of one cell, or of several cells with the same cause).
struct RegionCause {
  CoverageCause cause = CoverageCause::NotTriangle;
  double area = 0;          // model units^2 of the region's faces it explains
  std::string why, fix;     // plain words: "features 3, 8 and 12 share no photo" / "click 12 in photo 2"
  std::vector<int> points;  // features concerned (Project::points indices)
  int rejected = -1;        // the rejected pair behind it (Partition::rejected index), or -1
  CoverageClick click;      // what to click (invalid when no single click fixes it)
};

struct CoverageRegion {
  std::vector<int> faces;           // faces of Partition::mesh, connected through edges
  double area = 0;                  // model units^2
  double share = 0;                 // of the whole surface
  Vec3 centre = Vec3::Zero();       // area-weighted centroid, model units
  double radius = 0;                // largest distance of its vertices from `centre`
  int centreVertex = -1;            // its vertex farthest (along edges) from its border: where to look
  std::vector<int> cells;           // partition cells it overlaps
  std::vector<int> points;          // features on it or on its border (Project::points indices)
  std::vector<RegionCause> causes;  // largest area first; causes[0] is the region's reason
  double gain = 0;                  // area of its causes that a suggested click addresses
};

// The rejected pairs of one reason.
struct RejectedGroup {
  RejectReason reason = RejectReason::NoCommonPhoto;
  std::string words;       // the reason in plain words
  std::vector<int> pairs;  // Partition::rejected indices, the ones bearing on an empty region first
  int expected = 0;        // of them, pairs around no empty region (hidden by default)
};

struct CoverageReport {
  double totalArea = 0, mappedArea = 0;
  double mappedShare = 0;               // mappedArea / totalArea (1 for an empty mesh)
  std::vector<CoverageRegion> regions;  // largest first; those below CoverageOptions::minShare left out
  int smallRegions = 0;                 // regions left out for their size
  double smallArea = 0;                 // their area
  std::vector<int> next;                // "where to click next": region indices with a click, best gain first
  std::vector<char> rejectedExpected;   // per Partition::rejected: bears on no listed empty region
  std::vector<RejectedGroup> rejected;  // by reason, largest group first
  std::vector<int> featureIds;          // per Project::points index: the id the user sees (Partition::featureId)
};

struct CoverageOptions {
  double minShare = 0.0005;  // regions smaller than this share of the surface are counted, not listed
  int maxRegions = 200;      // at most this many regions are listed (the largest)
};

// What analyseCoverage reads. `map`, `partition` and `cells` come from one mapping (the final one);
// `fits` and `views` (per photo; a view is empty for a photo that does not fit) may be empty.
struct CoverageInput {
  const Project& project;
  const Partition& partition;
  const TextureMap& map;
  const std::vector<CellPlan>& cells;
  const std::vector<CameraFit>& fits;
  const PhotoViews& views;
  int photos = 0;         // number of photos of the project
  int inputVertices = 0;  // vertices of the input mesh (Steiner vertices follow): only these are suggested
                          // for a click; 0 = all of Partition::mesh
  // The id the user knows of a vertex below inputVertices, in the words (Scene::documentVertex: a welded
  // mesh's loaded vertex); null: the id itself. Clicks and centres in the report stay Partition::mesh's.
  std::function<int(int)> documentVertex;
};

// Throws montage::Error when the map, the partition and the cells disagree in size.
CoverageReport analyseCoverage(const CoverageInput& input, const CoverageOptions& options = {});

// A rejected pair's reason in plain words ("in photo 2, the straight line between them crosses the line
// 5-9"); the pair's own detail is kept in parentheses where it adds figures.
std::string rejectedWords(const RejectedPair& pair);

// The report as report.json's "coverage" object (regions with faces' count, not the face lists).
nlohmann::json coverageJson(const CoverageReport& report);

// The suggested click of "where to click next" in words: "click feature 12 (vertex 530) in photo 2".
std::string clickWords(const CoverageClick& click);

}  // namespace montage
