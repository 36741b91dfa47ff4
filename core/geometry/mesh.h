// Triangle meshes: the OpenMesh type used throughout the core, building a mesh from a triangle soup,
// and the validation report that `montage info` prints (loading is in io/mesh_io.h).
#pragma once

#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "base/common.h"

namespace montage {

struct MeshTraits : public OpenMesh::DefaultTraits {
  using Point = OpenMesh::Vec3d;
  using Normal = OpenMesh::Vec3d;
  VertexAttributes(OpenMesh::Attributes::Status);
  EdgeAttributes(OpenMesh::Attributes::Status);
  FaceAttributes(OpenMesh::Attributes::Status);
  HalfedgeAttributes(OpenMesh::Attributes::PrevHalfedge | OpenMesh::Attributes::Status);
};
using TriMesh = OpenMesh::TriMesh_ArrayKernelT<MeshTraits>;

// A loaded triangle mesh. Face f of `tri` has corners k = 0,1,2 given by faceVertices(f); every
// per-corner array in the core (UVs, barycentrics) uses that order.
struct Mesh {
  TriMesh tri;  // connectivity and positions (model units), manifold after loading
  // Optional per-corner texture coordinates read from the file: #F entries, corner order as
  // faceVertices(); OBJ convention, (0,0) = bottom-left of the texture, v up. Empty when absent.
  std::vector<std::array<Vec2, 3>> cornerUV;
  // Optional per-face material index into `materialNames` (OBJ usemtl); empty when absent.
  std::vector<int> faceMaterial;
  std::vector<std::string> materialNames;  // OBJ material names, in order of first use
  std::string mtllib;                      // OBJ mtllib file name, as written in the file (may be empty)
  // Optional per-face OBJ group index (`g` name; `o` when no `g`) into `groupNames`; empty when absent.
  std::vector<int> faceGroup;
  std::vector<std::string> groupNames;
  // Optional per-corner normals read from the file (OBJ vn, PLY nx ny nz, Assimp's; unit length, faceVertices order),
  // which the export writes so that hard edges stay hard. Empty when the file has none.
  std::vector<std::array<Vec3f, 3>> cornerNormal;
  // Optional per-face index of the file's polygon the face was cut from (fan triangulation), so that the OBJ export
  // writes quads and n-gons back as they came. Empty when the file had triangles only.
  std::vector<int> facePolygon;
  std::vector<int> faceOrigin;    // #F: index of the input face (after fan triangulation) of each face
  std::vector<int> vertexOrigin;  // #V: index of the input vertex each vertex was made from (the first of those at
                                  // its position when welded; a vertex split at a non-manifold fan: the same)

  int numVertices() const { return static_cast<int>(tri.n_vertices()); }
  int numFaces() const { return static_cast<int>(tri.n_faces()); }
  bool hasUV() const { return !cornerUV.empty(); }

  // The three vertex indices of face f, in the face's counter-clockwise order starting at the
  // to-vertex of tri.halfedge_handle(f). This is the corner order used everywhere.
  // (Inline: the hottest accessors of the core.)
  std::array<int, 3> faceVertices(int f) const {
    auto h = tri.halfedge_handle(OpenMesh::FaceHandle(f));
    std::array<int, 3> v{};
    for (int k = 0; k < 3; ++k) {
      v[k] = tri.to_vertex_handle(h).idx();
      h = tri.next_halfedge_handle(h);
    }
    return v;
  }
  Vec3 position(int v) const {
    const TriMesh::Point& p = tri.point(OpenMesh::VertexHandle(v));
    return Vec3(p[0], p[1], p[2]);
  }
  std::array<Vec3, 3> facePositions(int f) const {
    const auto v = faceVertices(f);
    return {position(v[0]), position(v[1]), position(v[2])};
  }
  double faceArea(int f) const;
  Vec3 faceNormal(int f) const;  // unit normal (zero for a zero-area face)
  // Axis-aligned bounding box of all vertices.
  void bounds(Vec3& lo, Vec3& hi) const;
};

// The faces around each vertex, in increasing order, in one array: vertex v's are
// faces[offset[v] .. offset[v + 1]).
struct VertexFaces {
  struct Range {
    const int *first, *last;
    const int* begin() const { return first; }
    const int* end() const { return last; }
    size_t size() const { return size_t(last - first); }
    bool empty() const { return first == last; }
  };
  std::vector<int> offset;  // #V + 1
  std::vector<int> faces;
  Range operator[](int v) const { return {faces.data() + offset[v], faces.data() + offset[v + 1]}; }
};
VertexFaces facesAroundVertices(const Mesh& mesh);

// One finding of the validation, with the elements it concerns (vertex or face indices of the
// *input file*, 0-based, after fan triangulation of polygons) so a user can find them.
struct MeshFinding {
  enum class Severity { Warning, Error };
  Severity severity = Severity::Warning;
  std::string what;           // e.g. "3 faces dropped: they would make a complex (non-manifold) edge"
  std::vector<int> elements;  // the faces or vertices concerned (at most the first 50 are kept)
  int count = 0;              // how many elements in all
};

struct MeshReport {
  std::string path;
  std::string format;                      // "obj", "ply", "off", "stl"
  int inputVertices = 0;                   // as in the file
  int inputFaces = 0;                      // after fan triangulation of polygons
  int vertices = 0, faces = 0, edges = 0;  // of the built mesh
  int components = 0;
  int boundaryLoops = 0;
  int genus = 0;                // sum over components of (2 - chi - b)/2
  int nonManifoldEdges = 0;     // edges used by more than two input faces
  int nonManifoldVertices = 0;  // vertices whose faces form more than one fan (split on load)
  int zeroAreaFaces = 0;
  int duplicateFaces = 0;        // same vertex set as an earlier face (dropped)
  int unreferencedVertices = 0;  // no face uses them (kept, ignored by the pipeline)
  int droppedFaces = 0;          // input faces not in the mesh (complex edge, duplicate, repeated vertex)
  int flippedFaces = 0;          // faces turned over to agree with their neighbours (inconsistent orientation)
  int nonOrientableFaces = 0;    // faces dropped because their part of the surface cannot be oriented
  bool hasUV = false;
  double diagonal = 0;  // bounding-box diagonal, model units
  std::vector<MeshFinding> findings;

  bool usable() const;          // no Error finding
  std::string summary() const;  // multi-line human-readable report
};

struct LoadedMesh {
  std::unique_ptr<Mesh> mesh;  // null when the file could not be turned into a mesh at all
  MeshReport report;
};

struct MeshLoadOptions {
  bool splitNonManifoldVertices = true;  // duplicate a vertex per fan so the mesh is a 2-manifold
  // Merge vertices with bit-identical positions before building (always done for STL, which has no
  // shared vertices). Off by default so vertex ids match the file, which project files refer to.
  bool weldIdenticalPositions = false;
};

// A mesh whose file splits its surface at UV seams (vertices at identical positions: glTF, most meshes from
// games and scanners) with those vertices merged, so that the stages see one connected surface, and the way
// from the ids of the mesh as loaded (which project files name and the export writes) to its own. The way
// back: the welded mesh's vertexOrigin and faceOrigin, which index the loaded mesh.
struct WeldedMesh {
  std::unique_ptr<Mesh> mesh;  // null when no two vertices of the loaded mesh share a position (and not canonical)
  MeshReport report;           // the welded mesh's validation (components, borders, genus as the stages see them)
  std::vector<int> vertexOf;   // #V(loaded): its welded vertex (-1 for a vertex used by no face)
  std::vector<int> faceOf;     // #F(loaded): its welded face (-1 for a face that welding makes degenerate)
  int mergedVertices = 0;      // loaded vertices merged into another one
};
// With `canonicalOrder`, the welded mesh is built even when nothing merges, its vertices sorted by position and
// its faces by their sorted corners (each starting at its smallest): a file listing the same surface in another
// order (a re-export) gives the same mesh, id for id, so every stage gives the same result.
WeldedMesh weldIdenticalPositions(const Mesh& loaded, bool canonicalOrder = false);

// Throws montage::Error with the report's errors when the mesh is unusable; returns the mesh otherwise.
std::unique_ptr<Mesh> requireUsable(LoadedMesh loaded);

// Builds a mesh from a triangle soup (used by the loaders, by tests and by synthetic scenes).
// `uv`, when not empty, holds 3 UVs per triangle. Same dropping/reporting rules as loadMesh.
LoadedMesh buildMesh(const std::vector<Vec3>& vertices, const std::vector<std::array<int, 3>>& triangles,
                     const std::vector<std::array<Vec2, 3>>& uv = {}, const MeshLoadOptions& options = {},
                     const std::string& name = "");

}  // namespace montage
