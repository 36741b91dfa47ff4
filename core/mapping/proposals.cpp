// Proposed correspondences (see proposals.h).
#include "mapping/proposals.h"

#include <algorithm>

#include "geometry/mesh.h"
#include "io/project.h"

namespace montage {

std::vector<Proposal> proposeCorrespondences(const Project& project, const Mesh& mesh,
                                             const std::vector<CameraFit>& fits, const PhotoViews& views,
                                             const ProposalOptions& o) {
  std::vector<Proposal> out;
  const int np = static_cast<int>(fits.size());
  TM_CHECK(views.size() == fits.size(), "proposeCorrespondences: one view per photo needed");
  for (size_t i = 0; i < project.points.size(); ++i) {
    const FeaturePoint& point = project.points[i];
    const int v = point.vertex;
    if (v < 0 || v >= mesh.numVertices()) continue;
    int from = -1;
    std::vector<char> clicked(np, 0);
    for (const PhotoPoint& at : point.at) {
      if (at.photo < 0 || at.photo >= np) continue;
      clicked[at.photo] = 1;
      if (from < 0 && fits[at.photo].fits && !fits[at.photo].subject) from = at.photo;
    }
    if (from < 0) continue;
    // Area-weighted vertex normal.
    Vec3 normal = Vec3::Zero();
    for (auto fh : mesh.tri.vf_range(mesh.tri.vertex_handle(v)))
      normal += mesh.faceNormal(fh.idx()) * mesh.faceArea(fh.idx());
    if (normal.norm() > 0) normal.normalize();
    for (int q = 0; q < np; ++q) {
      if (clicked[q] || !fits[q].fits || fits[q].subject || !views[q] || views[q]->vertexVisible.empty()) continue;
      if (std::find(project.declinedProposals.begin(), project.declinedProposals.end(), DeclinedProposal{v, q}) !=
          project.declinedProposals.end())
        continue;
      if (!views[q]->vertexVisible[v] || views[q]->vertexSilhouettePx[v] < o.silhouetteMarginPx) continue;
      const Vec3 p = mesh.position(v);
      const Vec3 toEye = (fits[q].camera.pinhole.center() - p).normalized();
      if (normal.dot(toEye) < o.minFacing) continue;
      const Vec2 uv = views[q]->vertexUV[v];
      const Camera& cam = fits[q].camera.pinhole;
      if (!(uv.x() >= 0 && uv.y() >= 0 && uv.x() <= cam.width && uv.y() <= cam.height)) continue;
      out.push_back(Proposal{static_cast<int>(i), v, q, uv, from});
    }
  }
  return out;
}

}  // namespace montage
