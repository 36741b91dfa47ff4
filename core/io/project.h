// The project document: what the user made (mesh and photo paths, correspondences, strokes, clone
// operations, options). Saved as versioned JSON; see docs/project-format.md.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "base/common.h"
#include "base/fileio.h"  // writeFileAtomic, which callers of saveProject use too
#include "io/options.h"

namespace montage {

struct Mesh;

// A position in one photo, pixel coordinates (see photo.h).
struct PhotoPoint {
  int photo = 0;
  double x = 0, y = 0;
  bool operator==(const PhotoPoint& o) const { return photo == o.photo && x == o.x && y == o.y; }
};

// A correspondence: a mesh vertex and where it appears in one or more photos.
struct FeaturePoint {
  int vertex = 0;
  std::vector<PhotoPoint> at;
  // The id the user sees (lists, labels, messages, report.json), which a deletion of another point does not
  // change; -1: the point's index in Project::points. Kept canonical (an id equal to the index is -1, see
  // pointId and erasePoint), so documents with the same ids compare equal.
  int id = -1;
  bool operator==(const FeaturePoint& o) const { return vertex == o.vertex && at == o.at && id == o.id; }
};

// A feature line (open) or polygon (closed): a chain of feature points drawn in one photo. Every
// point of the chain must have a position in that photo.
struct FeatureChain {
  int photo = 0;
  std::vector<int> points;  // indices into Project::points
  bool closed = false;
  bool operator==(const FeatureChain& o) const { return photo == o.photo && points == o.points && closed == o.closed; }
};

// An inpainting guidance stroke drawn on the surface: a polyline through mesh vertices; its
// direction at each vertex is the direction of travel.
struct Stroke {
  std::vector<int> vertices;
  bool operator==(const Stroke& o) const { return vertices == o.vertices; }
};

// Seamless cloning of a photo region onto the surface (paper section 5).
struct CloneOp {
  int photo = 0;
  std::vector<Vec2> polygon;     // source region in the photo, pixel coordinates, >= 3 points
  std::vector<int> targetFaces;  // target region on the mesh (face indices)
  int anchorVertex = 0;          // this vertex receives the photo point `anchor`
  Vec2 anchor = Vec2::Zero();    // pixel coordinates
  double pixelsPerUnit = 0;      // scale: photo pixels per model unit (0 = fit the polygon to the region)
  double rotationDeg = 0;        // rotation of the photo around the anchor, degrees
  bool operator==(const CloneOp& o) const {
    return photo == o.photo && polygon == o.polygon && targetFaces == o.targetFaces && anchorVertex == o.anchorVertex &&
           anchor == o.anchor && pixelsPerUnit == o.pixelsPerUnit && rotationDeg == o.rotationDeg;
  }
};

// A photo region the user picked as the texture of a hole (version 6): "texture" synthesises the hole from
// these pixels instead of the photos mapped around it (issue 34).
struct HoleExemplar {
  int photo = 0;
  std::vector<Vec2> polygon;  // in the photo, pixel coordinates, >= 3 points
  bool operator==(const HoleExemplar& o) const { return photo == o.photo && polygon == o.polygon; }
};

// The guidance chosen for one hole (a connected region no photo covers): the hole is the one that
// contains `face` (a mesh face id); the others follow options.inpaintMode.
struct HoleMode {
  int face = 0;
  InpaintMode mode = InpaintMode::Rbf;
  std::optional<HoleExemplar> exemplar;  // mode "texture" only
  bool operator==(const HoleMode& o) const { return face == o.face && mode == o.mode && exemplar == o.exemplar; }
};

// A correspondence the cameras proposed (a feature clicked in one photo that fits a camera, predicted
// in another such photo where it is visible; mapping/proposals.h) and the user declined: it is not
// proposed again. Proposals themselves are pipeline output, never stored with the clicks.
struct DeclinedProposal {
  int vertex = 0;  // mesh vertex of the feature
  int photo = 0;   // photo it was proposed in
  bool operator==(const DeclinedProposal& o) const { return vertex == o.vertex && photo == o.photo; }
};

struct PhotoRef {
  std::string path;                  // absolute once loaded; written relative to the project file
  std::string mask;                  // optional foreground mask image (in the file's own pixels); same rules
  bool mirror = false;               // flipped left to right on load; positions are in the mirrored photo
  bool colorLocked = false;          // colour balance keeps this photo as it is and matches the others to it
  PhotoMode mode = PhotoMode::Auto;  // what the photo shows: the object itself, another subject, or decided (auto)
  bool operator==(const PhotoRef& o) const {
    return path == o.path && mask == o.mask && mirror == o.mirror && colorLocked == o.colorLocked && mode == o.mode;
  }
};

// The editor's 3D view as it was when the project was saved (an orbit camera: the point it turns about, its
// distance, yaw and pitch in degrees, the vertical field of view; orthographic is a field of view under 2
// degrees). Not part of the document: it is no undo step and no unsaved change, and runs ignore it.
struct ViewState {
  bool present = false;
  Vec3 target = Vec3::Zero();
  double distance = 1, yawDeg = 0, pitchDeg = 0, fovYDeg = 35;
  bool operator==(const ViewState& o) const {
    return present == o.present && (!present || (target == o.target && distance == o.distance && yawDeg == o.yawDeg &&
                                                 pitchDeg == o.pitchDeg && fovYDeg == o.fovYDeg));
  }
};

// Where a project's ids lay on the mesh it was saved with (io/mesh_anchors.h): the mesh's fingerprint and sizes,
// the position of every vertex and the centroid of every face the project names. Not part of the document (no
// undo step, not compared by sameDocument); written by the editor's saves, read in any version.
struct MeshAnchors {
  bool present = false;
  std::string fingerprint;  // meshFingerprint: 16 hexadecimal digits
  int vertices = 0, faces = 0;
  std::map<int, Vec3> vertex;  // vertex id -> position
  std::map<int, Vec3> face;    // face id -> centroid
  bool operator==(const MeshAnchors& o) const {
    return present == o.present && fingerprint == o.fingerprint && vertices == o.vertices && faces == o.faces &&
           vertex == o.vertex && face == o.face;
  }
};

struct Project {
  static constexpr int kVersion = 6;        // newest format version this build reads and writes
  static constexpr int kOldestVersion = 1;  // oldest version it reads

  std::string file;  // where it was loaded from / last saved to (absolute); empty for a new project
  std::string mesh;  // absolute path
  std::vector<PhotoRef> photos;
  std::vector<FeaturePoint> points;
  std::vector<FeatureChain> chains;
  std::vector<Stroke> strokes;
  std::vector<CloneOp> clones;
  std::vector<HoleMode> holeModes;
  std::vector<DeclinedProposal> declinedProposals;  // version 2
  PipelineOptions options;
  ViewState view;  // the editor's camera when saved (any version; not compared by sameDocument)
  MeshAnchors anchors;  // the mesh the ids were saved against (any version; not compared by sameDocument)
  // Fields of the file this build does not know and ignored (a newer build's, or misspelt), each as its path with
  // the nearest known name when one is close ("options.atlasSise (did you mean "atlasSize"?)"); not part of the
  // document (a save drops them). projectWarnings names them.
  std::vector<std::string> unknownFields;

  // Document equality (ignores `file`, `view`, `anchors` and `unknownFields`): what save + load must preserve.
  bool sameDocument(const Project& o) const;
};

// Parses a project file and checks everything that needs no mesh or photo: JSON syntax, version,
// field types, index ranges among the project's own lists, files present. Paths become absolute.
// Throws montage::Error "<file>: <field>: <reason>", e.g. "a.json: points[2].vertex: must be an integer".
// Files larger than kMaxProjectBytes are refused with a message (a 64 MB project needs about 1.4 GB
// while it is parsed; real projects are a few MB).
Project loadProject(const std::string& path);
inline constexpr uint64_t kMaxProjectBytes = 64ull << 20;
// The same from the file's text already in memory; `path` is where it was read (paths in it are
// relative to its folder) and names it in messages.
Project parseProject(const std::string& text, const std::string& path);

// A file a project names that does not exist: the JSON field ("mesh", "photos[1].path",
// "photos[1].mask") and the path it resolves to (absolute).
struct MissingFile {
  std::string field;
  std::string path;
};

// Like loadProject, but a mesh, photo or mask file that does not exist is not an error: its path is
// kept (absolute) and listed in `missing`, so that the editor can open the project, say what is missing
// and offer to relink it. Every other check is the same.
Project loadProjectAllowingMissing(const std::string& path, std::vector<MissingFile>& missing);

// The id the user sees of point `index` (FeaturePoint::id, or the index), and the index of the point with id
// `id` (-1 when none has it).
int pointId(const Project& project, int index);
int pointIndex(const Project& project, int id);
// The id a new point takes: one more than the largest id (so the ids of points deleted last may come back,
// never one a point has).
int nextPointId(const Project& project);
// Removes point `index` from the list, keeping every other point's id (the points after it keep theirs
// explicitly) and the ids canonical. Chains index the list: the caller renumbers them.
void erasePoint(Project& project, int index);

// The lowest version that holds a document: 1, 2 when it has declined proposals, 3 when it has a mirrored
// or colour-locked photo or colour balance on, 4 when a photo's mode is set (not auto), 5 when a point's id
// is not its index (a point was deleted before it), so that an older build refuses
// the file instead of silently ignoring what it does not know, and reads it when nothing is lost. projectToJson writes
// this version.
int requiredVersion(const Project& project);

// Checks a project against its mesh and photo sizes: vertex ids in range, points inside their
// photo, the same vertex not given two points in one photo, chains whose points have a position
// in the chain's photo, stroke and clone indices in range. `photoSizes[i]` is photo i's size.
// Throws montage::Error naming the project file, the field and the reason.
void validateProject(const Project& project, int numVertices, int numFaces,
                     const std::vector<std::pair<int, int>>& photoSizes);

// The project with every reference to the photos in `photos` left out: their positions (a point left
// with none stays, with no position, so point indices do not change), and the chains and clones drawn in
// them. Photo entries and photo indices stay as they are. The pipeline runs on this when a photo cannot
// be loaded, so that a broken photo disables only itself.
Project withoutPhotoReferences(const Project& project, const std::set<int>& photos);

// The project with its mesh ids (points' and strokes' vertices, clones' anchors and target faces, hole modes'
// faces, declined proposals' vertices) carried to another mesh by per-id tables (a welded mesh's
// WeldedMesh::vertexOf and faceOf). Throws montage::Error naming the field when an id has no counterpart.
Project withMeshIds(const Project& project, const std::vector<int>& vertexOf, const std::vector<int>& faceOf);

// Sets option `key` of `options` from `value` as a command line gives it (`montage run --set KEY=VALUE`):
// JSON (a number, true or false, "text") or else a bare word, taken as a string (an enum's name such as
// synthesis), read and checked as a project file's "options" are. Throws montage::Error naming `where`,
// the option and the reason: "--set: options.atlasSise: not an option (did you mean "atlasSize"?) ...",
// "--set: options.gutter: 99 is out of range (0..64)".
void setProjectOption(PipelineOptions& options, const std::string& key, const std::string& value,
                      const std::string& where);
// The names of the options, in the order of docs/project-format.md.
std::vector<std::string> projectOptionNames();

// Serialises to JSON text (paths relative to `relativeTo`'s folder when given).
std::string projectToJson(const Project& project, const std::string& relativeTo);

// Writes the project atomically: temporary file in the same folder, fsync, rename, fsync of the
// folder. Sets project.file. Throws montage::Error on failure, leaving any earlier file untouched.
void saveProject(Project& project, const std::string& path);

}  // namespace montage
