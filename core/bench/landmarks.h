// Landmark cases: photos of another subject (a portrait for a head scan, a tiger for a cat) with anatomical
// landmarks marked on the mesh and in the photo, some clicked, some held out, and an outline. There is no true
// camera; the held-out landmarks say how well the map lands between the clicks (issue 33's measure).
//
// A case file (bench/data/*.json):
//   {"mesh": "meshes/leeperrysmith/LeePerrySmith.obj",   relative to the data root (../shared/data)
//    "photo": "skimage:astronaut.png",                    a file, or "skimage:NAME" (Debian python3-skimage)
//    "faceWidth": 157,                                    pixels: the size that errors are shares of
//    "clicks":  [{"name": "nose tip", "vertex": 1234, "x": 250.5, "y": 160}, ...],   the user's clicks
//    "heldOut": [...],                                    landmarks kept out, the same fields
//    "outline": [...],                                    a closed polygon, counter-clockwise in the photo
//    "viewYawDeg": -90}                                   optional: the side the photo shows, as RenderOptions'
//                                                         yaw (0: the mesh's front, +z)
// Vertex ids are the mesh file's (as loaded, before welding); pixels have their origin at the top-left corner.
#pragma once

#include <string>
#include <vector>

#include "base/common.h"
#include "io/project.h"

namespace montage {

struct Partition;
struct Scene;
struct TextureMap;

struct Landmark {
  std::string name;
  int vertex = 0;
  Vec2 at = Vec2::Zero();  // pixels
};

struct LandmarkCase {
  std::string file;
  // The mesh, the photo (photo 0), a point per click and per outline landmark (the clicks first, in the file's
  // order), and the outline as a closed chain of photo 0.
  Project project;
  std::vector<Landmark> clicks, heldOut, outline;
  double faceWidth = 0;
  double viewYawDeg = 0;
};

// Where Debian's python3-skimage keeps its sample images (the file `name` in it).
std::string skimageDataFile(const std::string& name);

// Reads a case. `dataRoot` resolves the mesh's path. Throws montage::Error naming the file and the field.
LandmarkCase loadLandmarkCase(const std::string& path, const std::string& dataRoot);

// The case's project changed by one click: each held-out landmark added as a click (at the end), each click off
// the outline deleted, each click moved by `movePx` right and up. Named for messages ("+ nose_tip").
std::vector<std::pair<std::string, Project>> oneClickChanges(const LandmarkCase& c, double movePx = 2);

struct LandmarkScore {
  std::vector<double> heldOutPx;           // per held-out landmark: distance from where the map puts it to where it is
                                           // (infinity when the map does not take its vertex from the photo)
  double medianShare = 0, worstShare = 0;  // of faceWidth
  int outlinedFaces = 0;                   // faces of the mesh inside the outline's paths
  double outlinedFromPhoto = 0;            // share of their area seen from the photo's side (a render from
                                           // viewYawDeg) mapped from the photo
  int folds = 0;               // outlined faces mapped from the photo whose image is turned over against the majority
  bool outlineClosed = false;  // the outline's sides all became paths (else the inside is not known)
  std::vector<char> outlined;  // per face of the partition's mesh: inside the outline
};

// Scores a run's final map (over `partition`'s mesh) against the case. `scene` says how
// the file's vertex ids map onto the partition's (welding).
LandmarkScore scoreLandmarks(const LandmarkCase& c, const Scene& scene, const Partition& partition,
                             const TextureMap& map);

}  // namespace montage
