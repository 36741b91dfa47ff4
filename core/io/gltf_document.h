// glTF documents as the model reader (io/model.cpp) and the write-back export (io/gltf_write_back.cpp) share
// them: the file read with its buffers, an accessor's bytes, the scene's mesh instances, and the triangle soup
// the mesh is built from, with where each of its vertices and triangles came from. Internal to core/io.
#pragma once

#include <tiny_gltf.h>

#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "io/model.h"

namespace montage::gltf {

// Reads a .glb or .gltf file with its buffers (and images, decoded as RGBA8, when `decodeImages`): only files
// inside the model's folder, the JSON's nesting bounded. Throws montage::Error naming the file and the reason.
tinygltf::Model loadDocument(const std::string& path, bool decodeImages);
// The same from a file's bytes (`binary`: a GLB); `path` names it in messages and anchors its relative URIs.
tinygltf::Model parseDocument(const std::string& bytes, const std::string& path, bool binary, bool decodeImages);
// The document the mesh of a source file is read from: a .glb / .gltf as it is, and an FBX, Collada, 3DS or 3MF scene
// with a rig, a second UV set or vertex colours in the glTF form its reader gives it (io/assimp_gltf.h). Throws
// montage::Error naming the file when it is neither.
tinygltf::Model loadSourceDocument(const std::string& path);

// The bytes of an image the file names by URI (a data: URI, or a file inside the model's folder), and their type,
// which must be PNG or JPEG (what a GLB embeds). Throws montage::Error naming the file and the image.
std::vector<unsigned char> imageBytes(const tinygltf::Image& image, const std::string& path, std::string& mimeType);

// An accessor's elements as tightly packed bytes of its own component type (count x components x component
// size), its buffer view's stride removed and its sparse substitution applied. `where` names it for messages.
struct AccessorBytes {
  std::vector<unsigned char> bytes;
  size_t count = 0;
  int components = 0, componentSize = 0, componentType = 0;
  bool normalized = false;
  size_t elementSize() const { return static_cast<size_t>(components) * componentSize; }
};
AccessorBytes accessorBytes(const tinygltf::Model& gm, int index, const std::string& where);
// One component as a double (normalised integers decoded when `normalized`); NaN for an unknown type.
double decodeComponent(const unsigned char* p, int componentType, bool normalized);

// One mesh instance of a glTF scene: a node that shows a mesh, and its world matrix.
struct Instance {
  int node = -1;  // -1: a mesh no node shows (a file without nodes), placed at the origin
  int mesh = 0;
  Eigen::Matrix4d world = Eigen::Matrix4d::Identity();
};
// Every node that shows a mesh, depth first from the default scene's roots (every root node when the file has no
// scene), children in order; each mesh once at the origin when no node shows any.
std::vector<Instance> meshInstances(const tinygltf::Model& gm);

// A glTF file's triangles: every mesh instance of the scene with its node's transform applied, as one soup for
// buildMesh. Primitives of one instance that share their vertex accessors share their vertices; instances never
// share vertices.
struct Soup {
  std::vector<Instance> instances;
  std::vector<Vec3> vertices;
  std::vector<int> vertexElement;  // per vertex: its element in the accessors of the primitive(s) it came from
  std::vector<Vec3> normals;       // per vertex, world space, unit length (when allNormals)
  bool allNormals = true;          // every primitive has NORMAL
  std::vector<std::array<int, 3>> triangles;  // counter-clockwise in world space (mirrored instances turned over)
  struct TriangleOrigin {
    int instance = 0, primitive = 0;  // index into `instances`, and into its mesh's primitives
    std::array<int, 3> vertices{};    // the soup vertices of its corners in the file's order
  };
  std::vector<TriangleOrigin> triangleOrigin;  // per triangle
  std::vector<std::array<Vec2, 3>> uv;         // per triangle, OBJ convention (v up)
  std::vector<int> triMaterial;                // per triangle, index into materials
  std::vector<int> triSource;                  // per triangle, extras.tm_source (kSourceEmpty when absent)
  std::vector<Material> materials;             // in order of first use (textures only when asked for)
  bool anyUV = false, anySource = false;
  std::vector<MeshFinding> notes;  // skins and morph targets read in rest pose
};
Soup readSoup(const tinygltf::Model& gm, const std::string& path, bool withTextures);
// The mesh of a document as loadGltfMesh gives it (welded as `options` say, the file's normals per corner).
LoadedMesh documentMesh(const tinygltf::Model& gm, const std::string& path, const MeshLoadOptions& options);

// Writing: appends `size` bytes to `bin` (buffer 0's data, 4-byte aligned as the format asks) as a new view in
// `views` (`stride` 0: tightly packed); returns the view's index.
int appendView(std::vector<unsigned char>& bin, std::vector<tinygltf::BufferView>& views, const void* data, size_t size,
               int target, size_t stride = 0);
// A PNG texture of `mat` (its image in `bufferView`, named after the texture or `name`; -1 to set later)
// through one linear, repeating sampler (made on first use, kept in `sampler`); returns the texture's index.
int addTexture(tinygltf::Model& gm, const Material& mat, const std::string& name, int bufferView, int& sampler);
// Serialises `gm` as a GLB at `path` (its folder made, the file replaced atomically).
void writeGlb(tinygltf::Model& gm, const std::string& path);

}  // namespace montage::gltf
