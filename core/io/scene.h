// The loaded inputs of a project, as every stage reads them.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "geometry/mesh.h"
#include "image/photo.h"
#include "io/project.h"

namespace montage {

// The loaded inputs of a project: immutable once built, shared between runs and threads.
struct Scene {
  Project project;
  std::shared_ptr<const Mesh> mesh;
  MeshReport meshReport;
  std::vector<std::shared_ptr<const Photo>> photos;
  // Per photo: what identifies its content (file, size, time, mask), so that results computed from it
  // can be reused; empty when unknown (such results are never cached).
  std::vector<std::string> photoKeys;
  // What the validation of the project against its mesh and photos found worth a word (points on a
  // photo's background, crossing feature lines, self-intersecting polygons), each naming the element;
  // `montage info` and `run` show the same list.
  std::vector<std::string> warnings;
};

}  // namespace montage
