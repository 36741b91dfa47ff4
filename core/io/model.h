// A textured model: what export writes and what `montage eval` and `montage render` read.
// Formats: OBJ + MTL + PNG textures, and glTF 2.0 binary (.glb, textures embedded).
#pragma once

#include <array>
#include <list>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "base/common.h"
#include "geometry/mesh.h"
#include "image/color.h"

namespace montage {

// Where a face's colour comes from. Values >= 0 are photo indices.
enum FaceSource : int { kSourceEmpty = -2, kSourceInpainted = -1 };

struct Material {
  std::string name;
  cv::Mat texture;          // CV_8UC4 RGBA, row 0 = top of the image; empty when untextured
  std::string textureFile;  // file name relative to the model (OBJ) or empty; set by the loaders
  // Name of the texture image when several materials show the same one (the atlas): the exporters
  // write one image per distinct texture, named after this or, when empty, the first material using it
  // (textureFileName: <base>_<name>.png; a name that starts with '.', a UDIM tile's ".1001", <base>.1001.png).
  std::string textureName;
  Vec3f diffuse = Vec3f(0.7f, 0.7f, 0.7f);  // sRGB [0,1], used where there is no texture
  // Applied to the texture's colours as they are read (colorAt, the editor's shader). Only the editor's
  // preview model sets one (a photo's colour balance, so that the photo's texture serves unchanged while
  // the balance moves); exporters ignore it.
  ColorTransform transform;
};

struct TexturedModel {
  std::string name = "model";  // the glTF mesh and node name and the OBJ object name
  Mesh mesh;
  // #F x 3 texture coordinates, corner order of Mesh::faceVertices; (0,0) = bottom-left of the
  // texture, v up (OBJ convention; the glTF writer and reader flip v).
  std::vector<std::array<Vec2f, 3>> uv;
  std::vector<int> faceMaterial;  // #F, index into materials
  std::vector<int> faceSource;    // #F, FaceSource or photo index; empty when unknown
  std::vector<Material> materials;
  // #F x 3 sRGB colours added to the material's colour at each corner, interpolated over the face; empty
  // = none. Only the editor's preview model has them (surface/preview.h: the seam levelling offsets of
  // photo faces; the inpainted colours of untextured faces, over a black diffuse). Exporters ignore them.
  std::vector<std::array<Vec3f, 3>> cornerColor;

  bool textured() const { return !uv.empty(); }
  // Colour (sRGB [0,1]) of face f at barycentrics b: bilinear texture lookup with repeat wrapping (then
  // the material's transform), or the material's diffuse colour when it has no texture.
  Vec3f colorAt(int f, const Vec3& b) const;
};

// Loads .obj (with its .mtl and map_Kd textures, groups "tm_source_<k>", "tm_inpainted",
// "tm_empty" as face sources), .glb/.gltf (every mesh instance, as loadGltfMesh reads them, welded;
// baseColorTexture, primitive extras "tm_source"), or any plain mesh format (untextured). Throws montage::Error naming
// the file and reason.
TexturedModel loadModel(const std::string& path);

// Reads a glTF 2.0 file (.glb, or .gltf with its buffers) as a mesh for the pipeline, with the same reader as
// loadModel: every mesh instance of the default scene (each node that shows a mesh) with its node's world
// transform (a mirroring transform turns the faces over so that they stay front-facing), the texture coordinates
// of the set each material's base colour texture uses (Mesh::cornerUV, v up), material names
// (Mesh::faceMaterial, materialNames). Vertices in file order (instance by instance, primitive by primitive;
// primitives sharing their accessors share their vertices), welded only as `options` asks. Skins and morph targets
// are read in their rest pose, with a warning in the report. Throws montage::Error naming the file, the mesh, the
// primitive and the accessor.
LoadedMesh loadGltfMesh(const std::string& path, const MeshLoadOptions& options = {});

// Per-face values of a loaded mesh (Mesh::faceMaterial, Mesh::faceGroup: per mesh face, or per input face
// mapped through Mesh::faceOrigin). Empty when `values` is empty or does not fit the mesh.
std::vector<int> meshFaceValues(const Mesh& mesh, const std::vector<int>& values);

// PNG encoding of textures, shared between the exporters so that a texture written to the OBJ's PNG
// and embedded in the GLB is encoded once (the GLB embeds the same bytes).
class PngCache {
 public:
  // compression: zlib level 0..9. Levels up to 3 use zlib's run-length strategy, which on atlases (flat
  // gutters, smooth charts) is both faster and smaller than the default filter at the same level.
  explicit PngCache(int compression = 6) : compression_(compression) {}
  // The PNG bytes of an RGBA8 texture (written as RGB when every alpha is 255), encoded on first use.
  // `where` names the file for errors.
  const std::vector<unsigned char>& encode(const cv::Mat& rgba, const std::string& where);
  int encodes() const { return encodes_; }     // images encoded so far
  double seconds() const { return seconds_; }  // time spent encoding

 private:
  int compression_;
  int encodes_ = 0;
  double seconds_ = 0;
  std::list<std::pair<cv::Mat, std::vector<unsigned char>>> cache_;  // texture (kept alive) -> bytes
};

// The file exportObj writes a texture to: <base>_<textureName>.png, or <base><textureName>.png when the name starts
// with '.' (UDIM tiles: model.1001.png, model_skin.1001.png); characters other than letters, digits, '_', '-' and
// '.' become '_'.
std::string textureFileName(const std::string& base, const std::string& textureName);

// Makes a model from a mesh that carries UVs (Mesh::cornerUV) and one texture image.
TexturedModel modelFromMesh(const Mesh& mesh, const cv::Mat& textureRgba, const std::string& textureName = "texture");

// Writes DIR/<base>.obj, DIR/<base>.mtl and one PNG per distinct texture (<base>_<texture name>.png,
// see Material::textureName). With face sources, faces are grouped by source ("tm_source_<k>",
// "tm_inpainted", "tm_empty") so the tags survive; without, faces keep the model's order and the mesh's
// own groups (Mesh::groupNames), so a loaded mesh is written back with its structure. `pngs` (may be
// null) shares encoded textures with exportGlb.
void exportObj(const TexturedModel& model, const std::string& dir, const std::string& base = "model",
               PngCache* pngs = nullptr);

// Writes a glTF 2.0 binary file: one mesh and one node named after the model, one primitive per
// (material, source) group, all primitives sharing one vertex list whose first entries are the
// mesh's vertices in order (vertices split at texture seams follow), one embedded PNG per distinct
// texture, per-primitive extras {"tm_source": k} when the model has sources. Throws montage::Error on
// failure.
void exportGlb(const TexturedModel& model, const std::string& path, PngCache* pngs = nullptr);

// What exportGlbInto wrote.
struct GltfWriteBack {
  int triangles = 0;         // triangles written, as many as the file has in its scene
  int primitives = 0;        // primitives of the scene's meshes after the write (one per file primitive and material)
  int copiedMeshes = 0;      // meshes shown by several nodes, copied so that each instance has its own texture
  int leftOutTriangles = 0;  // triangles the mesh left out on loading (complex edges, repeated vertices): UV (0, 0)
  int droppedImages = 0;     // the file's images nothing shows any more (its base colour textures), left out
};

// Writes the model into the glTF file its mesh was read from (`source`, .glb or .gltf; model.mesh as loadGltfMesh
// read it, unwelded, so that its vertexOrigin and faceOrigin name the file's vertices and triangles), as a GLB at
// `path`: everything the file holds is kept (nodes, skins and joint weights, morph targets, normals and tangents,
// every texture coordinate set, vertex colours, animations, materials with their other textures, extras), and the
// scene's primitives show the montage: split per model material, their vertices split where the model's texture
// coordinates differ (every attribute and morph target copied along), the model's coordinates added as the next free
// set TEXCOORD_n, and each material a copy of the file's with the model's texture as its base colour on that set.
// A mesh shown by several nodes is copied per node. Materials, textures and images nothing shows any more (the
// file's base colour images) are left out when the file uses no extension. Throws montage::Error when the file no
// longer holds the model's mesh, or keeps its geometry in an extension (Draco, meshopt, GPU instancing).
GltfWriteBack exportGlbInto(const TexturedModel& model, const std::string& source, const std::string& path,
                            PngCache* pngs = nullptr);

}  // namespace montage
