// Proposed correspondences: a feature clicked in a photo that fits a camera is predicted, by each
// other fitted photo's camera and correction field (projection.h), wherever that photo sees it. The
// user accepts a proposal (it becomes a click) or declines it (Project::declinedProposals); proposals
// are pipeline output and never mix with the clicks.
#pragma once

#include <vector>

#include "base/common.h"
#include "mapping/camera.h"
#include "mapping/projection.h"

namespace montage {

struct Mesh;
struct Project;

struct Proposal {
  int point = -1;             // index into Project::points: the feature
  int vertex = 0;             // its mesh vertex
  int photo = 0;              // the photo it is proposed in
  Vec2 pixel = Vec2::Zero();  // predicted position (projection + correction), pixels (photo.h)
  int from = -1;              // a fitted photo where the feature is clicked
};

struct ProposalOptions {
  double minFacing = 0.2;         // the vertex normal must face the camera at least this much (cosine)
  double silhouetteMarginPx = 3;  // ...and its projection lie this far inside the silhouette
};

// Proposals for every feature point with a click in a fitted photo, in every other fitted photo that
// sees its vertex and has no click of it, except the declined ones. `views` and `fields` are per
// photo (empty for photos that do not fit), over `mesh`, whose first vertices are the project's.
// Ordered by point, then photo.
std::vector<Proposal> proposeCorrespondences(const Project& project, const Mesh& mesh,
                                             const std::vector<CameraFit>& fits, const PhotoViews& views,
                                             const ProposalOptions& options = {});

}  // namespace montage
