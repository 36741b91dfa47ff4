#include "atlas/preview_model.h"

#include "geometry/mesh.h"
#include "image/photo.h"
#include "surface/inpaint.h"
#include "surface/level.h"
#include "surface/preview.h"

namespace montage {

cv::Mat previewTexture(const Photo& photo) {
  return toRgba8(photo.rgb, false, photo.path);
}

TexturedModel previewModel(const Mesh& mesh, const TextureMap& map,
                           const std::vector<std::shared_ptr<const Photo>>& photos,
                           const std::vector<cv::Mat>& photoTextures, const SeamLevelling* levelling,
                           const InpaintResult* inpaint, const std::vector<ColorTransform>& photoTransforms,
                           const AtlasOptions& options, bool smoothInpaint) {
  const int nf = mesh.numFaces();
  const int np = static_cast<int>(photos.size());
  TM_CHECK(map.numFaces() == nf, "preview model: the texture map has " + std::to_string(map.numFaces()) +
                                     " faces, the mesh " + std::to_string(nf));
  TM_CHECK(static_cast<int>(photoTextures.size()) == np, "preview model: " + std::to_string(photoTextures.size()) +
                                                             " textures for " + std::to_string(np) + " photos");
  TM_CHECK(photoTransforms.empty() || static_cast<int>(photoTransforms.size()) == np,
           "preview model: " + std::to_string(photoTransforms.size()) + " colour transforms for " + std::to_string(np) +
               " photos");
  const bool hasInpaint = inpaint && static_cast<int>(inpaint->faceRegion.size()) == nf;
  const int inpaintedMaterial = np, emptyMaterial = np + 1;
  TexturedModel model;
  model.name = "preview";
  model.mesh = mesh;
  model.uv.assign(nf, {Vec2f::Zero(), Vec2f::Zero(), Vec2f::Zero()});
  model.faceMaterial.assign(nf, emptyMaterial);
  model.faceSource.assign(nf, kSourceEmpty);
  model.cornerColor.assign(nf, {Vec3f::Zero(), Vec3f::Zero(), Vec3f::Zero()});
  for (int p = 0; p < np; ++p) {
    Material m;
    m.name = "photo_" + std::to_string(p);
    m.texture = photoTextures[p];
    if (!photoTransforms.empty()) m.transform = photoTransforms[p];
    model.materials.push_back(std::move(m));
  }
  Material inpainted, empty;
  inpainted.name = "inpainted";
  empty.name = "empty";
  empty.diffuse = options.emptyColor;
  model.materials.push_back(inpainted);
  model.materials.push_back(empty);

  const bool hasOffsets = levelling && static_cast<int>(levelling->cornerOffset.size()) == nf;
  std::vector<int> inpaintedFaces;
  for (int f = 0; f < nf; ++f) {
    if (hasInpaint && inpaint->faceRegion[f] >= 0) {
      inpaintedFaces.push_back(f);
      continue;
    }
    const int p = map.facePhoto[f];
    if (p < 0 || p >= np) continue;
    TM_CHECK(photos[p] != nullptr, "preview model: photo " + std::to_string(p) + " is missing");
    model.faceMaterial[f] = p;
    model.faceSource[f] = p;
    for (int k = 0; k < 3; ++k) {
      const Vec2& uv = map.cornerUV[f][k];
      model.uv[f][k] = Vec2f(float(uv.x() / photos[p]->width), float(1.0 - uv.y() / photos[p]->height));
      if (hasOffsets) model.cornerColor[f][k] = levelling->cornerOffset[f][k];
    }
  }
  if (inpaintedFaces.empty()) return model;
  std::vector<const Photo*> photoPointers;
  for (const auto& p : photos) photoPointers.push_back(p.get());
  const PreviewSurface surface(map, photoPointers, levelling, inpaint, options.emptyColor);
  if (smoothInpaint) {  // the corners' colours over black, shaded as the textured faces are
    model.materials[inpaintedMaterial].texture = cv::Mat(1, 1, CV_8UC4, cv::Scalar(0, 0, 0, 255));
    for (int f : inpaintedFaces) {
      model.faceMaterial[f] = inpaintedMaterial;
      model.faceSource[f] = kSourceInpainted;
      for (int k = 0; k < 3; ++k) model.cornerColor[f][k] = surface.color(f, Vec3::Unit(k));
    }
    return model;
  }

  // The inpainted faces' own atlas: their sub-mesh, its charts at the regions' densities, baked from
  // the inpainted colours (PreviewSurface: the refined triangles' colours, as the final bake has them).
  std::vector<int> local(mesh.numVertices(), -1);
  std::vector<Vec3> vertices;
  std::vector<std::array<int, 3>> triangles;
  for (int f : inpaintedFaces) {
    std::array<int, 3> t{};
    const auto c = mesh.faceVertices(f);
    for (int k = 0; k < 3; ++k) {
      if (local[c[k]] < 0) {
        local[c[k]] = static_cast<int>(vertices.size());
        vertices.push_back(mesh.position(c[k]));
      }
      t[k] = local[c[k]];
    }
    triangles.push_back(t);
  }
  MeshLoadOptions keep;
  keep.splitNonManifoldVertices = true;
  const std::unique_ptr<Mesh> sub = requireUsable(buildMesh(vertices, triangles, {}, keep, "preview"));
  const int sf = sub->numFaces();
  TM_CHECK(static_cast<int>(sub->faceOrigin.size()) == sf,
           "preview model: the inpainted sub-mesh lost its face origins");
  AtlasInput in;
  in.faceSource.assign(sf, kSourceInpainted);
  in.cornerUV.assign(sf, {Vec2::Zero(), Vec2::Zero(), Vec2::Zero()});
  in.faceDensity.resize(sf);
  std::vector<int> parent(sf);
  // Per sub-mesh corner, the parent face's corner at the same position (buildMesh keeps a triangle's
  // corners but may start a face at another one).
  std::vector<std::array<int, 3>> cornerOf(sf, {0, 1, 2});
  for (int g = 0; g < sf; ++g) {
    parent[g] = inpaintedFaces[sub->faceOrigin[g]];
    in.faceDensity[g] = inpaint->regions[inpaint->faceRegion[parent[g]]].texelsPerUnit;
    const auto q = sub->facePositions(g);
    const auto c = mesh.faceVertices(parent[g]);
    for (int k = 0; k < 3; ++k)
      for (int j = 0; j < 3; ++j)
        if (q[k] == mesh.position(c[j])) cornerOf[g][k] = j;
  }
  const Atlas atlas = buildAtlas(*sub, in, options);
  const AtlasImage image = bakeAtlasSurface(
      atlas,
      [&](int g, const Vec3& b, unsigned char&) {
        Vec3 bf = Vec3::Zero();
        for (int k = 0; k < 3; ++k) bf[cornerOf[g][k]] = b[k];
        return surface.color(parent[g], bf);
      },
      options);
  model.materials[inpaintedMaterial].texture = image.rgba;
  const double size = atlas.size;
  for (int g = 0; g < sf; ++g) {
    const int f = parent[g];
    model.faceMaterial[f] = inpaintedMaterial;
    model.faceSource[f] = kSourceInpainted;
    for (int k = 0; k < 3; ++k)
      model.uv[f][cornerOf[g][k]] =
          Vec2f(float(atlas.cornerUV[g][k].x() / size), float(1.0 - atlas.cornerUV[g][k].y() / size));
  }
  return model;
}

}  // namespace montage
