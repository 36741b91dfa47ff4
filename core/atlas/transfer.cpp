#include "atlas/transfer.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <random>

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
  std::vector<double> cumulative(F);
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
    cumulative[f] = total;
  }
  TransferLoss out;
  if (!(total > 0) || options.samples <= 0) return out;
  out.borderShare = borderArea / total;
  out.smallShare = thinArea / total;
  // Fixed chunks of samples, each with its own seeded generator, summed in chunk order: the figures do not
  // depend on the thread count or the schedule.
  struct Sums {
    double sse[4] = {0, 0, 0, 0}, count[4] = {0, 0, 0, 0};  // all, interior, border, thin
    double sseOriginal = 0, sseRefined = 0;                 // against the montage's own colours
  };
  constexpr int kChunk = 4096;
  const int chunks = (options.samples + kChunk - 1) / kChunk;
  std::vector<Sums> sums(chunks);
  tbb::parallel_for(0, chunks, [&](int chunk) {
    std::mt19937 rng(options.seed + 7919u * static_cast<unsigned>(chunk));
    std::uniform_real_distribution<double> uniform(0.0, 1.0);
    Sums& out = sums[chunk];
    const int end = std::min(options.samples, (chunk + 1) * kChunk);
    for (int i = chunk * kChunk; i < end; ++i) {
      const int f = std::min<int>(
          F - 1, static_cast<int>(std::upper_bound(cumulative.begin(), cumulative.end(), uniform(rng) * total) -
                                  cumulative.begin()));
      const double s = std::sqrt(uniform(rng)), t = uniform(rng);
      const Vec3 b(1 - s, s * (1 - t), s * t);
      Vec3 cb;
      const int r = locator.locate(f, b, cb);
      if (r < 0) continue;
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
