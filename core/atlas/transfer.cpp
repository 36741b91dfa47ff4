#include "atlas/transfer.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <set>

#include "base/util.h"
#include "geometry/predicates.h"

namespace montage {

namespace {

// Barycentrics of q in the plane of triangle p (least squares: exact for points of the triangle's plane).
Vec3 planeBarycentrics(const std::array<Vec3, 3>& p, const Vec3& q) {
  const Vec3 e1 = p[1] - p[0], e2 = p[2] - p[0], d = q - p[0];
  const double a = e1.dot(e1), b = e1.dot(e2), c = e2.dot(e2), det = a * c - b * b;
  if (!(std::abs(det) > 1e-300)) return Vec3(1.0 / 3, 1.0 / 3, 1.0 / 3);
  const double s = (c * e1.dot(d) - b * e2.dot(d)) / det, t = (a * e2.dot(d) - b * e1.dot(d)) / det;
  return Vec3(1 - s - t, s, t);
}

// Bilinear RGB lookup of an RGBA8 image at texel coordinates (texel (c, r) centred at (c + .5, r + .5)),
// clamped at the border; sRGB in [0,1].
Vec3f sampleRgba8(const cv::Mat& rgba, double x, double y) {
  x = std::clamp(x - 0.5, 0.0, rgba.cols - 1.0);
  y = std::clamp(y - 0.5, 0.0, rgba.rows - 1.0);
  const int x0 = std::min(static_cast<int>(x), rgba.cols - 2 < 0 ? 0 : rgba.cols - 2);
  const int y0 = std::min(static_cast<int>(y), rgba.rows - 2 < 0 ? 0 : rgba.rows - 2);
  const int x1 = std::min(x0 + 1, rgba.cols - 1), y1 = std::min(y0 + 1, rgba.rows - 1);
  const double fx = x - x0, fy = y - y0;
  const auto* r0 = rgba.ptr<cv::Vec4b>(y0);
  const auto* r1 = rgba.ptr<cv::Vec4b>(y1);
  Vec3f out;
  for (int c = 0; c < 3; ++c)
    out[c] = static_cast<float>(
        ((1 - fy) * ((1 - fx) * r0[x0][c] + fx * r0[x1][c]) + fy * ((1 - fx) * r1[x0][c] + fx * r1[x1][c])) / 255.0);
  return out;
}

double psnrOf(double sse, double n) {
  if (n <= 0) return 0;
  const double mse = sse / n;
  return mse > 0 ? 10 * std::log10(255.0 * 255.0 / mse) : 99.0;
}

// Source code of the source layer (atlasSourceLayer) for a face source.
unsigned char sourceCode(int source) {
  return source >= 0 ? static_cast<unsigned char>(std::min(source, 249) + 1) : source == kSourceInpainted ? 254 : 253;
}

// Area-weighted random points of a mesh's surface in fixed chunks of 4096, each chunk with its own seeded
// generator, chunks in parallel: visit(chunk, face, barycentrics). Sums kept per chunk and added in chunk order
// do not depend on the thread count or the schedule. Returns the number of chunks.
int forEachSurfaceSample(const Mesh& mesh, int samples, unsigned seed,
                         const std::function<void(int, int, const Vec3&)>& visit) {
  const int F = mesh.numFaces();
  std::vector<double> cumulative(F);
  double total = 0;
  for (int f = 0; f < F; ++f) cumulative[f] = total += mesh.faceArea(f);
  if (!(total > 0) || samples <= 0) return 0;
  constexpr int kChunk = 4096;
  const int chunks = (samples + kChunk - 1) / kChunk;
  tbb::parallel_for(0, chunks, [&](int chunk) {
    std::mt19937 rng(seed + 7919u * static_cast<unsigned>(chunk));
    std::uniform_real_distribution<double> uniform(0.0, 1.0);
    const int end = std::min(samples, (chunk + 1) * kChunk);
    for (int i = chunk * kChunk; i < end; ++i) {
      const int f = std::min<int>(
          F - 1, static_cast<int>(std::upper_bound(cumulative.begin(), cumulative.end(), uniform(rng) * total) -
                                  cumulative.begin()));
      const double s = std::sqrt(uniform(rng)), t = uniform(rng);
      visit(chunk, f, Vec3(1 - s, s * (1 - t), s * t));
    }
  });
  return chunks;
}

}  // namespace

RefinedLocator::RefinedLocator(const Mesh& input, const Mesh& refined, const std::vector<int>& faceParent) {
  const int F = input.numFaces(), R = refined.numFaces();
  TM_CHECK(static_cast<int>(faceParent.size()) == R, "transfer: faceParent has " + std::to_string(faceParent.size()) +
                                                         " entries for " + std::to_string(R) + " refined faces");
  children_.resize(F);
  corners_.resize(R);
  for (int r = 0; r < R; ++r) {
    const int f = faceParent[r];
    TM_CHECK(f >= 0 && f < F, "transfer: refined face " + std::to_string(r) + " has parent face " + std::to_string(f) +
                                  " outside the input mesh (" + std::to_string(F) + " faces)");
    children_[f].push_back(r);
    const auto pp = input.facePositions(f);
    const auto rv = refined.faceVertices(r);
    for (int k = 0; k < 3; ++k) {
      // Input vertices keep their positions in the refinement (and their ids, unless the refinement is of the
      // input welded): their barycentrics are exact.
      const Vec3 q = refined.position(rv[k]);
      const auto it = std::find(pp.begin(), pp.end(), q);
      corners_[r][k] = it != pp.end() ? Vec3::Unit(static_cast<int>(it - pp.begin())) : planeBarycentrics(pp, q);
    }
  }
}

int RefinedLocator::locate(int f, const Vec3& b, Vec3& childBary) const {
  const std::vector<int>& kids = children_[f];
  if (kids.empty()) return -1;
  const Vec2 q(b[1], b[2]);
  int best = -1;
  double bestMin = -std::numeric_limits<double>::infinity();
  Vec3 bestBary(1, 0, 0);
  for (int r : kids) {
    const auto& c = corners_[r];
    const Vec2 a0(c[0][1], c[0][2]), a1(c[1][1], c[1][2]), a2(c[2][1], c[2][2]);
    const double area = cross2(a1 - a0, a2 - a0);
    if (std::abs(area) < 1e-14) continue;
    const Vec3 l(cross2(a1 - q, a2 - q) / area, cross2(a2 - q, a0 - q) / area, 0);
    const Vec3 lambda(l[0], l[1], 1 - l[0] - l[1]);
    const double m = lambda.minCoeff();
    if (m > bestMin) bestMin = m, best = r, bestBary = lambda;
    if (m >= 0) break;
  }
  if (best < 0) {  // only degenerate children: the first one's first corner
    childBary = Vec3(1, 0, 0);
    return kids[0];
  }
  bestBary = bestBary.cwiseMax(0.0);
  childBary = bestBary / bestBary.sum();
  return best;
}

nlohmann::json TransferLoss::toJson() const {
  return {{"samples", samples},
          {"psnr", psnr},
          {"psnr_interior", psnrInterior},
          {"psnr_chart_border", psnrBorder},
          {"psnr_thin", psnrSmall},
          {"chart_border_area_share", borderShare},
          {"thin_area_share", smallShare},
          {"psnr_original_vs_montage", psnrOriginalVsMontage},
          {"psnr_refined_vs_montage", psnrRefinedVsMontage}};
}

TransferLoss measureTransfer(const TexturedModel& original, const TexturedModel& refined, const RefinedLocator& locator,
                             const Atlas& originalAtlas, const TransferOptions& options, const SurfaceColor& montage) {
  const Mesh& mesh = original.mesh;
  const int F = mesh.numFaces();
  TM_CHECK(static_cast<int>(originalAtlas.faceChart.size()) == F, "transfer: the atlas has " +
                                                                      std::to_string(originalAtlas.faceChart.size()) +
                                                                      " faces, the mesh " + std::to_string(F));
  // Classes: 1 = on a chart border of the new atlas, 2 = thin (under 2 texels of atlas area).
  std::vector<char> border(F, 0), thin(F, 0);
  double total = 0, borderArea = 0, thinArea = 0;
  for (int f = 0; f < F; ++f) {
    const TriMesh::FaceHandle fh(f);
    for (auto h : mesh.tri.fh_range(fh)) {
      const auto g = mesh.tri.opposite_face_handle(h);
      if (g.is_valid() && originalAtlas.faceChart[g.idx()] != originalAtlas.faceChart[f]) border[f] = 1;
    }
    const auto& a = originalAtlas.cornerUV[f];
    thin[f] = 0.5 * std::abs(cross2(a[1] - a[0], a[2] - a[0])) < 2.0;
    const double area = mesh.faceArea(f);
    total += area;
    borderArea += border[f] ? area : 0;
    thinArea += thin[f] ? area : 0;
  }
  TransferLoss out;
  if (!(total > 0) || options.samples <= 0) return out;
  out.borderShare = borderArea / total;
  out.smallShare = thinArea / total;
  struct Sums {
    double sse[4] = {0, 0, 0, 0}, count[4] = {0, 0, 0, 0};  // all, interior, border, thin
    double sseOriginal = 0, sseRefined = 0;                 // against the montage's own colours
  };
  std::vector<Sums> sums((std::max(options.samples, 0) + 4095) / 4096);
  forEachSurfaceSample(mesh, options.samples, options.seed, [&](int chunk, int f, const Vec3& b) {
    Sums& out = sums[chunk];
    {  // one sample
      Vec3 cb;
      const int r = locator.locate(f, b, cb);
      if (r < 0) return;
      const Vec3f co = original.colorAt(f, b), cr = refined.colorAt(r, cb);
      const Vec3f d = 255.0f * (co - cr);
      const double e = d.cast<double>().squaredNorm() / 3;
      if (montage) {
        const Vec3f cm = montage(r, cb);
        out.sseOriginal += (255.0f * (co - cm)).cast<double>().squaredNorm() / 3;
        out.sseRefined += (255.0f * (cr - cm)).cast<double>().squaredNorm() / 3;
      }
      out.sse[0] += e, out.count[0] += 1;
      const int cls = border[f] ? 2 : 1;
      out.sse[cls] += e, out.count[cls] += 1;
      if (thin[f]) out.sse[3] += e, out.count[3] += 1;
    }
  });
  double sse[4] = {0, 0, 0, 0}, count[4] = {0, 0, 0, 0};
  double sseOriginal = 0, sseRefined = 0;
  for (const Sums& part : sums) {
    for (int k = 0; k < 4; ++k) sse[k] += part.sse[k], count[k] += part.count[k];
    sseOriginal += part.sseOriginal, sseRefined += part.sseRefined;
  }
  out.samples = static_cast<int>(count[0]);
  out.psnr = psnrOf(sse[0], count[0]);
  out.psnrInterior = psnrOf(sse[1], count[1]);
  out.psnrBorder = psnrOf(sse[2], count[2]);
  out.psnrSmall = psnrOf(sse[3], count[3]);
  if (montage) {
    out.psnrOriginalVsMontage = psnrOf(sseOriginal, count[0]);
    out.psnrRefinedVsMontage = psnrOf(sseRefined, count[0]);
  }
  return out;
}

OriginalModel bakeOriginalTopology(const Mesh& input, const Mesh& refined, const std::vector<int>& faceParent,
                                   const Atlas& refinedAtlas, const AtlasImage& refinedImage,
                                   const AtlasOptions& options, const TransferOptions& transfer,
                                   const SurfaceColor& color) {
  const auto t0 = Clock::now();
  const int F = input.numFaces(), R = refined.numFaces();
  TM_CHECK(static_cast<int>(refinedAtlas.faceChart.size()) == R && static_cast<int>(refinedAtlas.cornerUV.size()) == R,
           "transfer: the refined atlas has " + std::to_string(refinedAtlas.faceChart.size()) +
               " faces, the refined mesh " + std::to_string(R));
  TM_CHECK(refinedImage.rgba.type() == CV_8UC4 && refinedImage.rgba.rows == refinedAtlas.size &&
               refinedImage.rgba.cols == refinedAtlas.size,
           "transfer: the refined atlas image must be " + std::to_string(refinedAtlas.size) + " squared RGBA8");
  const RefinedLocator locator(input, refined, faceParent);

  // The new charts: an input face joins the refined chart that covers most of its area; faces with only
  // empty children stay empty (flat, low density). The density is kOversample times the refined atlas's
  // texel density there (texels per model unit at scale 1): LSCM's map departs from the photo's, so at
  // the photo's own density the new atlas would blur what the photo shows (docs/atlas.md measures it).
  AtlasInput in;
  in.faceSource.assign(F, kSourceEmpty);
  in.faceGroup.assign(F, -1);
  in.faceDensity.assign(F, 0.0);
  const double unit = refinedAtlas.scale > 0 ? 1.0 / refinedAtlas.scale : 1.0;
  for (int f = 0; f < F; ++f) {
    const std::vector<int>& kids = locator.children(f);
    double bestArea = -1, densitySum = 0, areaSum = 0;
    for (int r : kids) {
      const double area3 = refined.faceArea(r);
      const auto& a = refinedAtlas.cornerUV[r];
      const double areaUV = 0.5 * std::abs(cross2(a[1] - a[0], a[2] - a[0]));
      if (refinedAtlas.faceSource[r] != kSourceEmpty) in.faceSource[f] = kSourceInpainted;
      double chartArea = 0;  // majority by area
      for (int s : kids)
        if (refinedAtlas.faceChart[s] == refinedAtlas.faceChart[r]) chartArea += refined.faceArea(s);
      if (chartArea > bestArea) bestArea = chartArea, in.faceGroup[f] = refinedAtlas.faceChart[r];
      if (area3 > 0) densitySum += area3 * std::sqrt(areaUV / area3) * unit, areaSum += area3;
    }
    in.faceDensity[f] = areaSum > 0 ? transfer.oversample * densitySum / areaSum : 0.0;
  }

  OriginalModel out;
  auto t = Clock::now();
  out.atlas = buildAtlas(input, in, options);
  out.atlasSeconds = secondsSince(t);
  t = Clock::now();
  // One pass gives the colours and the source layer (each point's source code as its label).
  const cv::Mat& image = refinedImage.rgba;
  out.image = bakeAtlasSurface(
      out.atlas,
      [&](int f, const Vec3& b, unsigned char& label) {
        Vec3 cb;
        const int r = locator.locate(f, b, cb);
        label = sourceCode(r < 0 ? kSourceEmpty : refinedAtlas.faceSource[r]);
        if (r < 0) return options.emptyColor;
        if (color) return color(r, cb);
        const auto& a = refinedAtlas.cornerUV[r];
        const Vec2 p = cb[0] * a[0] + cb[1] * a[1] + cb[2] * a[2];
        return sampleRgba8(image, p.x(), p.y());
      },
      options, &out.source);
  out.bakeSeconds = secondsSince(t);
  // The model: the input mesh as loaded, its materials by name, each showing the atlas.
  out.model.mesh = input;
  out.model.mesh.cornerUV.clear();
  out.model.uv.resize(F);
  const double inv = 1.0 / out.atlas.size;
  for (int f = 0; f < F; ++f)
    for (int k = 0; k < 3; ++k) {
      const Vec2& a = out.atlas.cornerUV[f][k];
      out.model.uv[f][k] = Vec2f(static_cast<float>(a.x() * inv), static_cast<float>(1.0 - a.y() * inv));
    }
  Material material;
  material.texture = out.image.rgba;
  material.textureName = "atlas";
  const std::vector<int> faceMaterial = meshFaceValues(input, input.faceMaterial);
  if (input.materialNames.empty() || faceMaterial.empty()) {
    material.name = input.materialNames.size() == 1 ? input.materialNames[0] : "atlas";
    out.model.materials.push_back(material);
    out.model.faceMaterial.assign(F, 0);
  } else {
    for (const std::string& name : input.materialNames) {
      material.name = name;
      out.model.materials.push_back(material);
    }
    out.model.faceMaterial = faceMaterial;
    const int count = static_cast<int>(input.materialNames.size());
    for (int& m : out.model.faceMaterial)
      if (m < 0 || m >= count) {  // faces before the first usemtl
        if (static_cast<int>(out.model.materials.size()) == count) {
          material.name = "default";
          out.model.materials.push_back(material);
        }
        m = count;
      }
  }
  t = Clock::now();
  out.loss =
      measureTransfer(out.model, atlasModel(refined, refinedAtlas, refinedImage), locator, out.atlas, transfer, color);
  out.measureSeconds = secondsSince(t);
  out.seconds = secondsSince(t0);
  return out;
}

}  // namespace montage

namespace montage {

namespace {

// "faces 3, 17, 40 and 12 more": the first few of a list of faces, for warnings.
std::string faceList(const std::vector<int>& faces) {
  std::string out = faces.size() == 1 ? "face " : "faces ";
  const size_t shown = std::min<size_t>(faces.size(), 10);
  for (size_t i = 0; i < shown; ++i) out += (i ? ", " : "") + std::to_string(faces[i]);
  if (faces.size() > shown) out += " and " + std::to_string(faces.size() - shown) + " more";
  return out;
}

}  // namespace

MeshUVBake bakeMeshUVs(const Mesh& input, const Mesh& refined, const std::vector<int>& faceParent,
                       const std::vector<int>& refinedSource, const SurfaceColor& color, const MeshUVOptions& options) {
  const auto t0 = Clock::now();
  const int F = input.numFaces(), size = options.size;
  TM_CHECK(input.hasUV() && static_cast<int>(input.cornerUV.size()) == F,
           "bake into the mesh's UVs: the mesh has no texture coordinates (OBJ vt, glTF TEXCOORD): bakeInto "
           "\"meshUVs\" needs them; use bakeInto \"atlas\" for a new layout");
  TM_CHECK(size >= 16 && size <= 8192 && (size & (size - 1)) == 0,
           "bake into the mesh's UVs: size " + std::to_string(size) + " is not a power of two in 16..8192");
  TM_CHECK(static_cast<int>(refinedSource.size()) == refined.numFaces(),
           "bake into the mesh's UVs: " + std::to_string(refinedSource.size()) + " face sources for " +
               std::to_string(refined.numFaces()) + " refined faces");
  TM_CHECK(static_cast<bool>(color), "bake into the mesh's UVs: no surface colour given");
  const RefinedLocator locator(input, refined, faceParent);
  MeshUVBake out;

  // Tiles: each face by its UV centroid; warnings for faces across a tile border or outside the UDIM range.
  const std::vector<int> faceMaterial = meshFaceValues(input, input.faceMaterial);
  const int materials = std::max<int>(1, static_cast<int>(input.materialNames.size()));
  std::vector<int> faceTile(F);
  std::vector<Vec2> faceShift(F);  // tile origin subtracted from the face's UVs
  std::vector<int> crossing, outOfRange, invalid;
  for (int f = 0; f < F; ++f) {
    const auto& t = input.cornerUV[f];
    const Vec2 c = (t[0] + t[1] + t[2]) / 3.0;
    if (!c.allFinite()) {
      invalid.push_back(f);
      faceTile[f] = 1001, faceShift[f] = Vec2::Zero();
      continue;
    }
    double tu = std::floor(c.x()), tv = std::floor(c.y());
    if (tu < 0 || tu > 9 || tv < 0 || tv > 99) {
      outOfRange.push_back(f);
      faceShift[f] = Vec2(tu, tv);
      faceTile[f] = 1001;
    } else {
      faceShift[f] = Vec2(tu, tv);
      faceTile[f] = 1001 + static_cast<int>(tu) + 10 * static_cast<int>(tv);
    }
    constexpr double kSlack = 1e-6;
    for (const Vec2& q : t)
      if (q.x() < tu - kSlack || q.x() > tu + 1 + kSlack || q.y() < tv - kSlack || q.y() > tv + 1 + kSlack) {
        crossing.push_back(f);
        break;
      }
  }
  TM_CHECK(invalid.empty(), "bake into the mesh's UVs: " + faceList(invalid) + " have non-finite texture coordinates");
  std::map<std::pair<int, int>, int> tileIndex;  // (material, udim) -> tile, numbered in that order
  std::vector<int> faceGroup(F);
  const auto materialOf = [&](int f) {
    return faceMaterial.empty() || faceMaterial[f] < 0 || faceMaterial[f] >= materials ? 0 : faceMaterial[f];
  };
  for (int f = 0; f < F; ++f) tileIndex.emplace(std::make_pair(materialOf(f), faceTile[f]), 0);
  for (auto& [key, index] : tileIndex) {
    index = static_cast<int>(out.tiles.size());
    MeshUVTile tile;
    tile.material = key.first;
    tile.udim = key.second;
    out.tiles.push_back(tile);
  }
  for (int f = 0; f < F; ++f) {
    faceGroup[f] = tileIndex.at({materialOf(f), faceTile[f]});
    out.tiles[faceGroup[f]].faces.push_back(f);
  }

  // Texel coordinates of every face in its tile (y down, pixel convention of atlas.h).
  std::vector<std::array<Vec2, 3>> texel(F);
  for (int f = 0; f < F; ++f)
    for (int k = 0; k < 3; ++k) {
      const Vec2 q = input.cornerUV[f][k] - faceShift[f];
      texel[f][k] = Vec2(q.x() * size, (1.0 - q.y()) * size);
    }

  // Overlaps: a texel centre strictly inside two faces of one tile.
  std::vector<char> overlapping(F, 0);
  for (const MeshUVTile& tile : out.tiles) {
    cv::Mat owner(size, size, CV_32SC1, cv::Scalar(-1));
    for (int f : tile.faces) {
      const auto& p = texel[f];
      const double area2 = cross2(p[1] - p[0], p[2] - p[0]);
      if (!(std::abs(area2) > 1e-12)) continue;
      const int x0 = std::max(0, static_cast<int>(std::floor(std::min({p[0].x(), p[1].x(), p[2].x()}))));
      const int x1 = std::min(size - 1, static_cast<int>(std::ceil(std::max({p[0].x(), p[1].x(), p[2].x()}))));
      const int y0 = std::max(0, static_cast<int>(std::floor(std::min({p[0].y(), p[1].y(), p[2].y()}))));
      const int y1 = std::min(size - 1, static_cast<int>(std::ceil(std::max({p[0].y(), p[1].y(), p[2].y()}))));
      for (int y = y0; y <= y1; ++y) {
        int* row = owner.ptr<int>(y);
        for (int x = x0; x <= x1; ++x) {
          const Vec2 q(x + 0.5, y + 0.5);
          const double b0 = cross2(p[1] - q, p[2] - q) / area2, b1 = cross2(p[2] - q, p[0] - q) / area2;
          const double b2 = 1 - b0 - b1;
          constexpr double kInside = 1e-9;
          if (b0 <= kInside || b1 <= kInside || b2 <= kInside) continue;
          if (row[x] >= 0 && row[x] != f) overlapping[f] = overlapping[row[x]] = 1;
          row[x] = f;
        }
      }
    }
  }
  std::vector<int> overlaps;
  for (int f = 0; f < F; ++f)
    if (overlapping[f]) overlaps.push_back(f);
  out.overlappingFaces = static_cast<int>(overlaps.size());
  out.crossingFaces = static_cast<int>(crossing.size());
  out.outOfRangeFaces = static_cast<int>(outOfRange.size());
  if (!overlaps.empty())
    out.warnings.push_back(std::to_string(overlaps.size()) + " faces have UVs that overlap another face's (" +
                           faceList(overlaps) + "): where they overlap, the texture shows one of them");
  if (!crossing.empty())
    out.warnings.push_back(std::to_string(crossing.size()) + " faces cross a UDIM tile border (" + faceList(crossing) +
                           "): each is baked into the tile of its UV centroid, and its part beyond repeats that tile");
  if (!outOfRange.empty())
    out.warnings.push_back(std::to_string(outOfRange.size()) +
                           " faces have UVs outside the UDIM range (u 0..10, v >= 0; " + faceList(outOfRange) +
                           "): they are baked wrapped into tile 1001");

  // The bake, tile by tile (in parallel over tiles; each tile's faces in order, so overlaps resolve the same way
  // every run).
  const auto tb = Clock::now();
  tbb::parallel_for(0, static_cast<int>(out.tiles.size()), [&](int ti) {
    MeshUVTile& tile = out.tiles[ti];
    Atlas atlas;
    atlas.size = size;
    atlas.faceChart.assign(F, 0);
    atlas.cornerUV.assign(F, {Vec2::Zero(), Vec2::Zero(), Vec2::Zero()});
    for (int f : tile.faces) atlas.cornerUV[f] = texel[f];
    AtlasChart chart;
    chart.faces = tile.faces;
    chart.width = chart.height = size;
    atlas.charts.push_back(chart);
    AtlasOptions bake;
    bake.threads = 1;
    AtlasImage image = bakeAtlasSurface(
        atlas,
        [&](int f, const Vec3& b, unsigned char& label) {
          Vec3 cb;
          const int r = locator.locate(f, b, cb);
          label = sourceCode(r < 0 ? kSourceEmpty : refinedSource[r]);
          return r < 0 ? options.emptyColor : color(r, cb);
        },
        bake, &tile.source);
    tile.rgba = image.rgba;
  });
  out.bakeSeconds = secondsSince(tb);

  // The model: the input mesh as loaded, its UVs, one material per tile.
  out.model.mesh = input;
  out.model.mesh.cornerUV.clear();
  out.model.uv.resize(F);
  for (int f = 0; f < F; ++f)
    for (int k = 0; k < 3; ++k) out.model.uv[f][k] = input.cornerUV[f][k].cast<float>();
  std::set<int> udims;
  for (const MeshUVTile& tile : out.tiles) udims.insert(tile.udim);
  const bool severalMaterials = out.tiles.size() > udims.size();
  for (const MeshUVTile& tile : out.tiles) {
    Material m;
    const std::string name =
        tile.material < static_cast<int>(input.materialNames.size()) ? input.materialNames[tile.material] : "material";
    m.name = udims.size() > 1 ? name + "_" + std::to_string(tile.udim) : name;
    m.texture = tile.rgba;
    m.textureName = (severalMaterials ? name : "") + "." + std::to_string(tile.udim);
    out.model.materials.push_back(m);
  }
  out.model.faceMaterial = faceGroup;

  // The bake against the montage at area-weighted surface points.
  const auto tm = Clock::now();
  std::vector<std::array<double, 4>> sums((std::max(options.samples, 0) + 4095) / 4096,
                                          {0, 0, 0, 0});  // per chunk: sse, n, covered sse, covered n
  forEachSurfaceSample(input, options.samples, options.seed, [&](int chunk, int f, const Vec3& b) {
    Vec3 cb;
    const int r = locator.locate(f, b, cb);
    if (r < 0) return;
    const double e = (255.0f * (out.model.colorAt(f, b) - color(r, cb))).cast<double>().squaredNorm() / 3;
    auto& s = sums[chunk];
    s[0] += e, s[1] += 1;
    if (refinedSource[r] >= 0) s[2] += e, s[3] += 1;
  });
  std::array<double, 4> sum = {0, 0, 0, 0};
  for (const auto& s : sums)
    for (int k = 0; k < 4; ++k) sum[k] += s[k];
  out.samples = static_cast<int>(sum[1]);
  out.coveredSamples = static_cast<int>(sum[3]);
  out.psnr = psnrOf(sum[0], sum[1]);
  out.psnrCovered = psnrOf(sum[2], sum[3]);
  out.measureSeconds = secondsSince(tm);
  out.seconds = secondsSince(t0);
  return out;
}

}  // namespace montage
