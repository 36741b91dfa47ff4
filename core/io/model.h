// A textured model: what export writes and what `montage eval` and `montage render` read.
// Formats: OBJ + MTL + PNG textures, and glTF 2.0 binary (.glb, textures embedded).
#pragma once

#include <array>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "base/common.h"
#include "geometry/mesh.h"

namespace montage {

// Where a face's colour comes from. Values >= 0 are photo indices.
enum FaceSource : int { kSourceEmpty = -2, kSourceInpainted = -1 };

struct Material {
  std::string name;
  cv::Mat texture;                          // CV_8UC4 RGBA, row 0 = top of the image; empty when untextured
  std::string textureFile;                  // file name relative to the model (OBJ) or empty; set by the loaders
  Vec3f diffuse = Vec3f(0.7f, 0.7f, 0.7f);  // sRGB [0,1], used where there is no texture
};

struct TexturedModel {
  Mesh mesh;
  // #F x 3 texture coordinates, corner order of Mesh::faceVertices; (0,0) = bottom-left of the
  // texture, v up (OBJ convention; the glTF writer and reader flip v).
  std::vector<std::array<Vec2f, 3>> uv;
  std::vector<int> faceMaterial;  // #F, index into materials
  std::vector<int> faceSource;    // #F, FaceSource or photo index; empty when unknown
  std::vector<Material> materials;

  bool textured() const { return !uv.empty(); }
  // Colour (sRGB [0,1]) of face f at barycentrics b: bilinear texture lookup with repeat wrapping,
  // or the material's diffuse colour when it has no texture.
  Vec3f colorAt(int f, const Vec3& b) const;
};

// Loads .obj (with its .mtl and map_Kd textures, groups "tm_source_<k>", "tm_inpainted",
// "tm_empty" as face sources), .glb/.gltf (first mesh, baseColorTexture, primitive extras
// "tm_source"), or any plain mesh format (untextured). Throws montage::Error naming the file and reason.
TexturedModel loadModel(const std::string& path);

// Makes a model from a mesh that carries UVs (Mesh::cornerUV) and one texture image.
TexturedModel modelFromMesh(const Mesh& mesh, const cv::Mat& textureRgba, const std::string& textureName = "texture");

// Writes DIR/<base>.obj, DIR/<base>.mtl and one PNG per textured material (<base>_<material>.png).
// Faces are grouped by source ("tm_source_<k>", "tm_inpainted", "tm_empty") so the tags survive.
void exportObj(const TexturedModel& model, const std::string& dir, const std::string& base = "model");

// Writes a glTF 2.0 binary file: one mesh, one primitive per (material, source) group, textures
// embedded as PNG, per-primitive extras {"tm_source": k}. Throws montage::Error on failure.
void exportGlb(const TexturedModel& model, const std::string& path);

}  // namespace montage
