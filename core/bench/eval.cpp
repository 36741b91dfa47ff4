// Evaluation of a textured result against a ground-truth textured model (see eval.h).
#include "bench/eval.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <mutex>
#include <numeric>
#include <random>
#include <thread>

#include "geometry/bvh.h"
#include "geometry/stretch.h"
#include "image/color.h"

namespace montage {

namespace {

// Checks the per-face arrays of a model so that colour lookups cannot go out of range.
void checkModel(const TexturedModel& model, const std::string& which) {
  const int faces = model.mesh.numFaces();
  const std::string where = "evaluate: " + which;
  TM_CHECK(faces > 0, where + ": the mesh has no faces");
  auto sizeError = [&](const std::string& field, size_t n) {
    return where + ": " + field + ": " + std::to_string(n) + " entries for " + std::to_string(faces) + " faces";
  };
  TM_CHECK(model.uv.empty() || static_cast<int>(model.uv.size()) == faces, sizeError("uv", model.uv.size()));
  TM_CHECK(model.faceMaterial.empty() || static_cast<int>(model.faceMaterial.size()) == faces,
           sizeError("faceMaterial", model.faceMaterial.size()));
  TM_CHECK(model.faceSource.empty() || static_cast<int>(model.faceSource.size()) == faces,
           sizeError("faceSource", model.faceSource.size()));
  for (int f = 0; f < static_cast<int>(model.faceMaterial.size()); ++f) {
    const int m = model.faceMaterial[f];
    TM_CHECK(m >= 0 && m < static_cast<int>(model.materials.size()),
             where + ": faceMaterial[" + std::to_string(f) + "]: " + std::to_string(m) + " is not one of the " +
                 std::to_string(model.materials.size()) + " materials");
  }
}

int materialOf(const TexturedModel& model, int f) {
  return model.faceMaterial.empty() ? 0 : model.faceMaterial[f];
}

// Texture size (texels) of a face's material, or 1 x 1 when untextured: UVs times this are texels.
Vec2 texelScale(const TexturedModel& model, int f) {
  const int m = materialOf(model, f);
  if (m < static_cast<int>(model.materials.size()) && !model.materials[m].texture.empty())
    return Vec2(model.materials[m].texture.cols, model.materials[m].texture.rows);
  return Vec2(1, 1);
}

int cornerOf(const std::array<int, 3>& corners, int v) {
  for (int k = 0; k < 3; ++k)
    if (corners[k] == v) return k;
  return -1;
}

struct EdgeFaces {
  int va = -1, vb = -1;  // edge endpoints
  int f = -1, g = -1;    // the faces on each side (g = -1 on the boundary)
};

std::vector<EdgeFaces> interiorEdges(const Mesh& mesh) {
  const TriMesh& tri = mesh.tri;
  std::vector<EdgeFaces> edges;
  edges.reserve(tri.n_edges());
  for (auto eh : tri.edges()) {
    const auto h0 = tri.halfedge_handle(eh, 0), h1 = tri.halfedge_handle(eh, 1);
    const auto f0 = tri.face_handle(h0), f1 = tri.face_handle(h1);
    if (!f0.is_valid() || !f1.is_valid()) continue;
    edges.push_back(EdgeFaces{tri.from_vertex_handle(h0).idx(), tri.to_vertex_handle(h0).idx(), f0.idx(), f1.idx()});
  }
  return edges;
}

// True when the two faces of an edge continue one another in texture space: same material and the
// same UVs at both shared vertices.
bool continuousAcross(const TexturedModel& model, const EdgeFaces& e) {
  if (materialOf(model, e.f) != materialOf(model, e.g)) return false;
  if (!model.textured()) return true;
  const auto cf = model.mesh.faceVertices(e.f), cg = model.mesh.faceVertices(e.g);
  for (int v : {e.va, e.vb}) {
    const int kf = cornerOf(cf, v), kg = cornerOf(cg, v);
    if (kf < 0 || kg < 0 || model.uv[e.f][kf] != model.uv[e.g][kg]) return false;
  }
  return true;
}

int findRoot(std::vector<int>& parent, int x) {
  while (parent[x] != x) {
    parent[x] = parent[parent[x]];
    x = parent[x];
  }
  return x;
}

double psnr(double sumSquared, long count) {
  if (count == 0) return 0;
  const double mse = sumSquared / (3.0 * count);
  if (mse <= 0) return 100;
  return std::min(100.0, 10 * std::log10(255.0 * 255.0 / mse));
}

// Runs body(begin, end) over [0, n) in contiguous chunks on the available cores.
template <typename Body>
void parallelChunks(int n, const Body& body) {
  const int threads = std::max(1, std::min<int>(std::thread::hardware_concurrency(), 16));
  const int chunks = std::min(threads, std::max(1, n / 1024));
  if (chunks <= 1) {
    body(0, n);
    return;
  }
  std::vector<std::thread> pool;
  std::exception_ptr failure;
  std::mutex failureMutex;
  for (int c = 0; c < chunks; ++c) {
    const int begin = static_cast<int>(static_cast<long>(n) * c / chunks);
    const int end = static_cast<int>(static_cast<long>(n) * (c + 1) / chunks);
    pool.emplace_back([&, begin, end] {
      try {
        body(begin, end);
      } catch (...) {
        std::lock_guard<std::mutex> lock(failureMutex);
        if (!failure) failure = std::current_exception();
      }
    });
  }
  for (auto& t : pool) t.join();
  if (failure) std::rethrow_exception(failure);
}

}  // namespace

EvalResult evaluate(const TexturedModel& result, const TexturedModel& truth, const EvalOptions& options) {
  TM_CHECK(options.samples >= 1, "evaluate: samples: must be >= 1 (got " + std::to_string(options.samples) + ")");
  TM_CHECK(options.seamSamplesPerEdge >= 1,
           "evaluate: seamSamplesPerEdge: must be >= 1 (got " + std::to_string(options.seamSamplesPerEdge) + ")");
  checkModel(result, "result");
  checkModel(truth, "truth");
  const Mesh& rmesh = result.mesh;
  const int rfaces = rmesh.numFaces();
  EvalResult out;

  // ---- Colour fidelity: area-weighted samples of the truth surface, closest point on the result.
  const int tfaces = truth.mesh.numFaces();
  std::vector<double> cdf(tfaces);
  double total = 0;
  for (int f = 0; f < tfaces; ++f) cdf[f] = (total += truth.mesh.faceArea(f));
  TM_CHECK(total > 0, "evaluate: truth: the surface has zero area");

  const int n = options.samples;
  std::vector<int> sampleFace(n);
  std::vector<Vec3> sampleBary(n);
  std::mt19937 rng(options.seed);
  auto unit = [&rng] { return (rng() + 0.5) * (1.0 / 4294967296.0); };  // (0, 1), library independent
  for (int i = 0; i < n; ++i) {
    const double u = unit() * total;
    const int f =
        std::min<int>(static_cast<int>(std::upper_bound(cdf.begin(), cdf.end(), u) - cdf.begin()), tfaces - 1);
    const double s = std::sqrt(unit()), r = unit();
    sampleFace[i] = f;
    sampleBary[i] = Vec3(1 - s, s * (1 - r), s * r);
  }

  auto coveredFace = [&](int f) { return result.faceSource.empty() ? result.textured() : result.faceSource[f] >= 0; };
  const TriangleBvh bvh(rmesh);
  std::vector<double> squared(n);
  std::vector<float> deltaE(n);
  std::vector<char> covered(n);
  parallelChunks(n, [&](int begin, int end) {
    for (int i = begin; i < end; ++i) {
      const int f = sampleFace[i];
      const auto q = truth.mesh.facePositions(f);
      const Vec3& b = sampleBary[i];
      const Vec3 p = b[0] * q[0] + b[1] * q[1] + b[2] * q[2];
      const Vec3f want = options.truthColor ? options.truthColor(f, b) : truth.colorAt(f, b);
      const ClosestPoint hit = bvh.closest(p);
      TM_ASSERT(hit.face >= 0);
      const Vec3f got = result.colorAt(hit.face, hit.bary);
      const Vec3 diff = 255.0 * (got.cast<double>() - want.cast<double>());
      squared[i] = diff.squaredNorm();
      deltaE[i] = deltaEuv(got, want);
      covered[i] = coveredFace(hit.face) ? 1 : 0;
    }
  });
  double sqAll = 0, sqCovered = 0, deAll = 0, deCovered = 0;
  long nCovered = 0;
  for (int i = 0; i < n; ++i) {
    sqAll += squared[i];
    deAll += deltaE[i];
    if (covered[i]) {
      sqCovered += squared[i];
      deCovered += deltaE[i];
      ++nCovered;
    }
  }
  out.samples = n;
  out.coveredSamples = static_cast<int>(nCovered);
  out.psnrAll = psnr(sqAll, n);
  out.psnrCovered = psnr(sqCovered, nCovered);
  out.deltaEAll = deAll / n;
  out.deltaECovered = nCovered > 0 ? deCovered / nCovered : 0;
  out.coveredSample = covered;
  if (!options.seen.empty()) {
    TM_CHECK(static_cast<int>(options.seen.size()) == n, "evaluate: seen: " + std::to_string(options.seen.size()) +
                                                             " flags for " + std::to_string(n) + " samples");
    double sqSeen = 0, deSeen = 0;
    long nSeen = 0;
    for (int i = 0; i < n; ++i)
      if (options.seen[i]) sqSeen += squared[i], deSeen += deltaE[i], ++nSeen;
    out.seenSamples = static_cast<int>(nSeen);
    out.psnrSeen = psnr(sqSeen, nSeen);
    out.deltaESeen = nSeen > 0 ? deSeen / nSeen : 0;
  }

  // ---- Coverage by area of the result's face sources.
  std::vector<double> area3(rfaces);
  double areaAll = 0, areaPhoto = 0, areaInpainted = 0, areaEmpty = 0;
  for (int f = 0; f < rfaces; ++f) {
    area3[f] = rmesh.faceArea(f);
    areaAll += area3[f];
    const int source = result.faceSource.empty() ? (result.textured() ? 0 : kSourceEmpty) : result.faceSource[f];
    (source >= 0 ? areaPhoto : source == kSourceInpainted ? areaInpainted : areaEmpty) += area3[f];
  }
  if (areaAll > 0) {
    out.coveragePhoto = areaPhoto / areaAll;
    out.coverageInpainted = areaInpainted / areaAll;
    out.coverageEmpty = areaEmpty / areaAll;
  }

  // ---- Charts: faces joined across edges where the texture continues.
  const std::vector<EdgeFaces> edges = interiorEdges(rmesh);
  std::vector<char> continuous(edges.size());
  std::vector<int> chart(rfaces);
  std::iota(chart.begin(), chart.end(), 0);
  for (size_t e = 0; e < edges.size(); ++e) {
    continuous[e] = continuousAcross(result, edges[e]) ? 1 : 0;
    if (continuous[e]) {
      const int a = findRoot(chart, edges[e].f), b = findRoot(chart, edges[e].g);
      if (a != b) chart[std::max(a, b)] = std::min(a, b);
    }
  }
  for (int f = 0; f < rfaces; ++f) chart[f] = findRoot(chart, f);

  // ---- Flipped triangles and stretch (textured models only).
  if (result.textured()) {
    Vec3 lo, hi;
    rmesh.bounds(lo, hi);
    const double area3Eps = 1e-14 * std::max((hi - lo).squaredNorm(), 1e-300);
    // A texture triangle smaller than a tenth of a texel is degenerate (a sliver whose orientation
    // cannot show); it is counted apart from flips and left out of the stretch.
    const auto uvAreaEps = [&](int f) { return texelScale(result, f) == Vec2(1, 1) ? 1e-12 : 0.1; };
    // Where some materials carry a texture, faces of untextured materials (e.g. the flat "empty"
    // material of unmapped faces) have no texture coordinates worth judging.
    bool anyTexture = false;
    for (const auto& m : result.materials) anyTexture |= !m.texture.empty();
    const auto judged = [&](int f) { return !anyTexture || texelScale(result, f) != Vec2(1, 1); };
    std::vector<std::array<Vec2, 3>> texel(rfaces);
    std::vector<double> uvArea(rfaces);  // signed, texels^2
    std::vector<double> chartVote(rfaces, 0.0);
    for (int f = 0; f < rfaces; ++f) {
      const Vec2 scale = texelScale(result, f);
      for (int k = 0; k < 3; ++k) texel[f][k] = result.uv[f][k].cast<double>().cwiseProduct(scale);
      const Vec2 e1 = texel[f][1] - texel[f][0], e2 = texel[f][2] - texel[f][0];
      uvArea[f] = 0.5 * (e1.x() * e2.y() - e1.y() * e2.x());
      if (judged(f) && std::abs(uvArea[f]) > uvAreaEps(f)) chartVote[chart[f]] += uvArea[f] > 0 ? area3[f] : -area3[f];
    }
    double sumA2 = 0, sumA3 = 0, sumL2 = 0, maxGamma = 0;
    for (int f = 0; f < rfaces; ++f) {
      if (!judged(f)) continue;
      const double sign = chartVote[chart[f]] >= 0 ? 1 : -1;  // the chart's majority orientation
      if (std::abs(uvArea[f]) <= uvAreaEps(f)) {
        if (area3[f] > area3Eps) ++out.degenerateUvTriangles;
        continue;
      }
      if ((uvArea[f] > 0 ? 1 : -1) != sign) {
        ++out.flippedTriangles;
        continue;
      }
      std::array<Vec2, 3> uv = texel[f];
      if (sign < 0)
        for (auto& t : uv) t.x() = -t.x();  // a mirrored chart: stretch is invariant to the mirror
      const TriangleStretch s = triangleStretch(rmesh.facePositions(f), uv);
      if (s.flipped || !std::isfinite(s.gamma)) {
        if (area3[f] > area3Eps) ++out.flippedTriangles;
        continue;
      }
      sumL2 += s.l2() * s.l2() * area3[f];
      sumA3 += area3[f];
      sumA2 += std::abs(uvArea[f]);
      maxGamma = std::max(maxGamma, s.gamma);
    }
    if (sumA3 > 0 && sumA2 > 0) {
      const double norm = std::sqrt(sumA2 / sumA3);
      out.stretchL2 = std::sqrt(sumL2 / sumA3) * norm;
      out.stretchLinf = maxGamma * norm;
    }
  }

  // ---- Seams: colour difference across edges where the texture does not continue.
  const int perEdge = options.seamSamplesPerEdge;
  std::vector<size_t> seams;
  for (size_t e = 0; e < edges.size(); ++e)
    if (!continuous[e]) seams.push_back(e);
  std::vector<double> seamSum(seams.size(), 0.0);
  parallelChunks(static_cast<int>(seams.size()), [&](int begin, int end) {
    for (int i = begin; i < end; ++i) {
      const EdgeFaces& e = edges[seams[i]];
      const auto cf = rmesh.faceVertices(e.f), cg = rmesh.faceVertices(e.g);
      const int fa = cornerOf(cf, e.va), fb = cornerOf(cf, e.vb), ga = cornerOf(cg, e.va), gb = cornerOf(cg, e.vb);
      TM_ASSERT(fa >= 0 && fb >= 0 && ga >= 0 && gb >= 0);
      double sum = 0;
      for (int s = 0; s < perEdge; ++s) {
        const double t = (s + 0.5) / perEdge;
        Vec3 bf = Vec3::Zero(), bg = Vec3::Zero();
        bf[fa] = bg[ga] = 1 - t;
        bf[fb] = bg[gb] = t;
        sum += deltaEuv(result.colorAt(e.f, bf), result.colorAt(e.g, bg));
      }
      seamSum[i] = sum;
    }
  });
  out.seamEdges = static_cast<int>(seams.size());
  if (!seams.empty())
    out.seamMismatch =
        std::accumulate(seamSum.begin(), seamSum.end(), 0.0) / (static_cast<double>(seams.size()) * perEdge);
  if (!result.faceSource.empty()) {
    double sum = 0;
    for (size_t i = 0; i < seams.size(); ++i) {
      const int sf = result.faceSource[edges[seams[i]].f], sg = result.faceSource[edges[seams[i]].g];
      if (sf >= 0 && sg >= 0 && sf != sg) sum += seamSum[i], out.photoSeamEdges++;
    }
    if (out.photoSeamEdges) out.photoSeamMismatch = sum / (static_cast<double>(out.photoSeamEdges) * perEdge);
  }
  return out;
}

nlohmann::json EvalResult::toJson() const {
  nlohmann::json j{{"samples", samples},
                        {"covered_samples", coveredSamples},
                        {"psnr_all", psnrAll},
                        {"psnr_covered", psnrCovered},
                        {"delta_e_all", deltaEAll},
                        {"delta_e_covered", deltaECovered},
                        {"coverage_photo", coveragePhoto},
                        {"coverage_inpainted", coverageInpainted},
                        {"coverage_empty", coverageEmpty},
                        {"flipped_triangles", flippedTriangles},
                        {"degenerate_uv_triangles", degenerateUvTriangles},
                        {"stretch_l2", stretchL2},
                        {"stretch_linf", stretchLinf},
                        {"seam_mismatch", seamMismatch},
                        {"seam_edges", seamEdges},
                        {"photo_seam_mismatch", photoSeamMismatch},
                        {"photo_seam_edges", photoSeamEdges}};
  if (seenSamples > 0) j["seen_samples"] = seenSamples, j["psnr_seen"] = psnrSeen, j["delta_e_seen"] = deltaESeen;
  return j;
}

std::string EvalResult::summary() const {
  char buf[1024];
  std::snprintf(buf, sizeof buf,
                "samples            %d (%d on photo-covered faces)\n"
                "PSNR               %.2f dB all, %.2f dB covered\n"
                "Delta E*uv (mean)  %.3f all, %.3f covered\n"
                "coverage           %.2f%% photo, %.2f%% inpainted, %.2f%% empty\n"
                "flipped triangles  %d (and %d degenerate texture triangles)\n"
                "stretch (Sander)   L2 %.4f, Linf %.4f (1 = isometric up to scale)\n"
                "seam mismatch      %.3f Delta E*uv over %d seam edges (%.3f over the %d between photos)\n",
                samples, coveredSamples, psnrAll, psnrCovered, deltaEAll, deltaECovered, 100 * coveragePhoto,
                100 * coverageInpainted, 100 * coverageEmpty, flippedTriangles, degenerateUvTriangles, stretchL2,
                stretchLinf, seamMismatch, seamEdges, photoSeamMismatch, photoSeamEdges);
  return buf;
}

}  // namespace montage
