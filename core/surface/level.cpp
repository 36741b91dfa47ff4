#include "surface/level.h"

#include <algorithm>
#include <cmath>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <unordered_map>

#include "base/job.h"
#include "base/util.h"
#include "geometry/mesh.h"
#include "geometry/poisson.h"
#include "image/photo.h"
#include "surface/trust.h"

namespace montage {

Vec3f mappedColor(const TextureMap& map, const std::vector<const Photo*>& photos, const SeamLevelling* levelling,
                  int face, const Vec3& b) {
  const auto& uv = map.cornerUV[face];
  const Vec2 p = b[0] * uv[0] + b[1] * uv[1] + b[2] * uv[2];
  Vec3f c = photos[map.facePhoto[face]]->rgbAt(p.x(), p.y());
  if (levelling && !levelling->cornerOffset.empty()) {
    const auto& o = levelling->cornerOffset[face];
    c += float(b[0]) * o[0] + float(b[1]) * o[1] + float(b[2]) * o[2];
  }
  return c;
}

SeamLevelling levelSeams(const Mesh& mesh, const TextureMap& map, const std::vector<const Photo*>& photos,
                         LevelMode mode, const JobControl& job, PoissonCache* solvers) {
  const auto start = Clock::now();
  SeamLevelling out;
  const int nf = mesh.numFaces();
  // Seam edges: faces of two different photos on either side. Colours sampled along the edge at
  // about one sample per pixel of the finer side.
  struct SeamEdge {
    int u, w;       // vertices
    int fa, fb;     // faces on photo a < photo b
    Vec3f sumDiff;  // sum over samples of colour(b) - colour(a)
    int samples;
    Vec3f unclippedDiff = Vec3f::Zero();  // ... over the samples clipped on neither side
    int unclipped = 0;
    float trust = 0;  // the smaller trust of the two faces (faceTrust)
  };
  std::vector<SeamEdge> seams;
  const TriMesh& tri = mesh.tri;
  auto cornerOf = [&](int f, int v) {
    const auto fv = mesh.faceVertices(f);
    return fv[0] == v ? 0 : (fv[1] == v ? 1 : 2);
  };
  auto edgeSamples = [&](const SeamEdge& e, const SeamLevelling* lev, auto&& visit) {
    const int ua = cornerOf(e.fa, e.u), wa = cornerOf(e.fa, e.w), ub = cornerOf(e.fb, e.u), wb = cornerOf(e.fb, e.w);
    for (int s = 0; s < e.samples; ++s) {
      const double t = (s + 0.5) / e.samples;
      Vec3 ba = Vec3::Zero(), bb = Vec3::Zero();
      ba[ua] = 1 - t, ba[wa] = t, bb[ub] = 1 - t, bb[wb] = t;
      visit(mappedColor(map, photos, lev, e.fa, ba), mappedColor(map, photos, lev, e.fb, bb));
    }
  };
  const TrustOptions trustOptions;
  const FaceTrust trust = faceTrust(mesh, map, trustOptions);
  for (const auto eh : tri.edges()) {
    if (tri.is_boundary(eh)) continue;
    const auto h0 = tri.halfedge_handle(eh, 0);
    int fa = tri.face_handle(h0).idx(), fb = tri.opposite_face_handle(h0).idx();
    if (fa < 0 || fb < 0) continue;
    int pa = map.facePhoto[fa], pb = map.facePhoto[fb];
    if (pa < 0 || pb < 0 || pa == pb) continue;
    if (pa > pb) std::swap(fa, fb), std::swap(pa, pb);
    SeamEdge e{tri.from_vertex_handle(h0).idx(), tri.to_vertex_handle(h0).idx(), fa, fb, Vec3f::Zero(), 0};
    const auto& uva = map.cornerUV[fa];
    const auto& uvb = map.cornerUV[fb];
    const double lenA = (uva[cornerOf(fa, e.u)] - uva[cornerOf(fa, e.w)]).norm();
    const double lenB = (uvb[cornerOf(fb, e.u)] - uvb[cornerOf(fb, e.w)]).norm();
    e.samples = std::clamp(int(std::ceil(std::max(lenA, lenB))), 2, 64);
    edgeSamples(e, nullptr, [&](const Vec3f& ca, const Vec3f& cb) {
      e.sumDiff += cb - ca;
      if (clippedColor(ca, trustOptions) || clippedColor(cb, trustOptions)) return;
      e.unclippedDiff += cb - ca, ++e.unclipped;
    });
    e.trust = e.unclipped > 0 ? std::min(trust.trust[fa], trust.trust[fb]) : 0.0f;
    seams.push_back(e);
  }
  auto mismatch = [&](const SeamLevelling* lev) {
    double sum = 0;
    long n = 0;
    for (const SeamEdge& e : seams)
      edgeSamples(e, lev, [&](const Vec3f& ca, const Vec3f& cb) { sum += (cb - ca).cwiseAbs().mean(), ++n; });
    return n ? sum / n : 0.0;
  };
  out.meanMismatchBefore = mismatch(nullptr);
  if (mode == LevelMode::Off || seams.empty()) {
    out.meanMismatchAfter = out.meanMismatchBefore;
    out.seconds = secondsSince(start);
    return out;
  }
  job.checkCancel();

  // Seams: seam edges of the same photo pair connected through vertices.
  UnionFind sets(seams.size());
  {
    std::unordered_map<uint64_t, int> firstAt;  // (vertex, photo pair) -> seam edge
    for (int i = 0; i < static_cast<int>(seams.size()); ++i) {
      const SeamEdge& e = seams[i];
      const uint64_t pair = uint64_t(map.facePhoto[e.fa]) * 65536 + uint64_t(map.facePhoto[e.fb]);
      for (int v : {e.u, e.w}) {
        const auto [it, fresh] = firstAt.emplace((uint64_t(v) << 32) ^ pair, i);
        if (!fresh) sets.unite(i, it->second);
      }
    }
  }
  // What an edge's difference is taken to be. Its own samples (those clipped on neither side) as far as it is
  // trusted, the rest from the trusted edges of the same photo pair: a grazing edge's smeared texels do not
  // shift the photos' colours, while an exposure difference the pair's trusted edges show is closed there
  // too. A pair with fewer than kMinTrusted trusted samples (its edges all grazing) takes 0 instead.
  constexpr double kMinTrusted = 16;
  std::unordered_map<uint64_t, std::pair<Vec3, double>> pairTrusted;  // photo pair -> trust-weighted sum, weight
  auto pairOf = [&](const SeamEdge& e) {
    return uint64_t(map.facePhoto[e.fa]) * 65536 + uint64_t(map.facePhoto[e.fb]);
  };
  for (const SeamEdge& e : seams) {
    auto& m = pairTrusted[pairOf(e)];
    if (m.second == 0) m.first = Vec3::Zero();
    m.first += double(e.trust) * e.unclippedDiff.cast<double>(), m.second += double(e.trust) * e.unclipped;
  }
  std::vector<Vec3f> edgeDiff(seams.size());
  for (size_t i = 0; i < seams.size(); ++i) {
    const SeamEdge& e = seams[i];
    const auto& m = pairTrusted[pairOf(e)];
    const Vec3f pairDiff = m.second >= kMinTrusted ? Vec3f((m.first / m.second).cast<float>()) : Vec3f::Zero();
    const Vec3f own = e.unclipped > 0 ? Vec3f(e.unclippedDiff / float(e.unclipped)) : pairDiff;
    edgeDiff[i] = e.trust * own + (1 - e.trust) * pairDiff;
  }
  std::unordered_map<int, std::pair<Vec3f, int>> seamMean;
  for (int i = 0; i < static_cast<int>(seams.size()); ++i) {
    auto& m = seamMean[sets.find(i)];
    if (m.second == 0) m.first = Vec3f::Zero();
    m.first += edgeDiff[i] * float(seams[i].samples), m.second += seams[i].samples;
  }
  out.seams = static_cast<int>(seamMean.size());

  // Targets per (vertex, photo): a and b meet half way, +diff/2 on a's side and -diff/2 on b's. A vertex
  // on several seams takes the mean of its targets.
  std::unordered_map<uint64_t, std::pair<Vec3f, int>> target;  // (photo << 32 | vertex) -> sum, count
  for (int i = 0; i < static_cast<int>(seams.size()); ++i) {
    const SeamEdge& e = seams[i];
    Vec3f diff;
    if (mode == LevelMode::Seam) {
      const auto& m = seamMean[sets.find(i)];
      diff = m.first / float(m.second);
    } else {
      diff = edgeDiff[i];
    }
    const uint64_t pa = uint64_t(map.facePhoto[e.fa]) << 32, pb = uint64_t(map.facePhoto[e.fb]) << 32;
    for (int v : {e.u, e.w}) {
      auto& ta = target[pa | uint32_t(v)];
      if (ta.second == 0) ta.first = Vec3f::Zero();
      ta.first += 0.5f * diff, ta.second++;
      auto& tb = target[pb | uint32_t(v)];
      if (tb.second == 0) tb.first = Vec3f::Zero();
      tb.first -= 0.5f * diff, tb.second++;
    }
  }

  // One harmonic offset field per photo over its faces, fixed at its seam vertices; components that
  // touch no seam keep a zero offset.
  out.cornerOffset.assign(nf, {Vec3f::Zero(), Vec3f::Zero(), Vec3f::Zero()});
  const int numPhotos = static_cast<int>(photos.size());
  // The photos in parallel: each writes the offsets of its own faces only.
  const TriangleMesh whole = toTriangleMesh(mesh);
  std::vector<std::vector<int>> photoFaces(std::max(numPhotos, 0));
  for (int f = 0; f < nf; ++f)
    if (map.facePhoto[f] >= 0 && map.facePhoto[f] < numPhotos) photoFaces[map.facePhoto[f]].push_back(f);
  tbb::enumerable_thread_specific<std::vector<int>> scratch([&] { return std::vector<int>(mesh.numVertices(), -1); });
  tbb::parallel_for(0, numPhotos, [&](int p) {
    job.checkCancel();
    const std::vector<int>& faces = photoFaces[p];
    if (faces.empty()) return;
    std::vector<int>& localOf = scratch.local();
    const SubMesh sub = extractTriangles(whole, faces, localOf);
    const int n = sub.mesh.numVertices();
    std::vector<char> fixed(n, 0);
    Eigen::MatrixXd values = Eigen::MatrixXd::Zero(n, 3);
    for (int l = 0; l < n; ++l) {
      const auto it = target.find((uint64_t(p) << 32) | uint32_t(sub.vertex[l]));
      if (it == target.end()) continue;
      fixed[l] = 1;
      values.row(l) = (it->second.first / float(it->second.second)).cast<double>().transpose();
    }
    UnionFind comp(n);
    for (const auto& t : sub.mesh.triangles) comp.unite(t[0], t[1]), comp.unite(t[1], t[2]);
    std::vector<char> anchored(n, 0);
    for (int l = 0; l < n; ++l)
      if (fixed[l]) anchored[comp.find(l)] = 1;
    for (int l = 0; l < n; ++l)
      if (!anchored[comp.find(l)]) fixed[l] = 1;  // value 0
    const Eigen::MatrixXd offset = solvers
                                       ? solvers->solver(sub.mesh, fixed)->solve(Eigen::MatrixXd::Zero(n, 3), values)
                                       : harmonicFill(sub.mesh, fixed, values);
    for (size_t i = 0; i < faces.size(); ++i)
      for (int k = 0; k < 3; ++k) out.cornerOffset[faces[i]][k] = offset.row(sub.mesh.triangles[i][k]).cast<float>();
  });
  out.meanMismatchAfter = mismatch(&out);
  out.seconds = secondsSince(start);
  return out;
}

}  // namespace montage
