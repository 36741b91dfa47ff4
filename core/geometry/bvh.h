// An axis-aligned bounding-box tree over a mesh's triangles: ray casts (editor picking, visibility)
// and closest-point queries (evaluation). Built once, queried from any number of threads.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <limits>
#include <vector>

#include "base/common.h"

namespace montage {

struct Mesh;

struct RayHit {
  int face = -1;             // -1: no hit
  double t = 0;              // ray parameter: hit point = origin + t * direction
  Vec3 bary = Vec3::Zero();  // barycentrics of the face's corners (Mesh::faceVertices order)
};

struct ClosestPoint {
  int face = -1;
  double distance = 0;  // model units
  Vec3 point = Vec3::Zero();
  Vec3 bary = Vec3::Zero();
};

class TriangleBvh {
 public:
  explicit TriangleBvh(const Mesh& mesh);
  // Nearest intersection with t in [tMin, tMax]; both sides of faces count.
  RayHit raycast(const Vec3& origin, const Vec3& direction, double tMin = 0,
                 double tMax = std::numeric_limits<double>::infinity()) const;
  ClosestPoint closest(const Vec3& query) const;

 private:
  struct Node {
    Eigen::AlignedBox3d box;
    int left = -1, right = -1;  // children (internal node)
    int first = 0, count = 0;   // range into order_ (leaf when count > 0)
  };
  int build(int first, int count, int depth);
  std::vector<std::array<Vec3, 3>> tris_;
  std::vector<int> order_;
  std::vector<Node> nodes_;
};

}  // namespace montage
