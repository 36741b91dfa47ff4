// Sections 4.2-4.3: content-based seam optimisation (see seams.h).
//
// Choices, beyond what the paper says:
// - It runs over the final map, not during the coarse-to-fine replay (docs/pipeline.md: the mapping
//   is built per partition cell with fixed cell borders, and the camera path has no replay at all).
// - "Sides": the corners of a vertex are grouped by (photo, UV). A vertex between two photos has two
//   sides, one between two patches of one photo mapped discontinuously has two as well; both are seams.
// - Normalisation: E_tex per sample is |dLUV| / 100 (100 = black against white), the gradient term
//   |dG'| / 50 L*u*v* per pixel (a black-white step over two pixels), each clamped to 1, averaged over
//   the samples the side's move changes; E_geo is Sander's L-infinity stretch times the photo's mean
//   scale (pixels per model unit over the photo's faces), so 1 = isometric at that scale.
// - Line search: the random direction's chord through the kernel (no flip), at most the fan's size
//   long, is sampled at 8 points first (E_tex is not quasi-convex along a line, unlike the stretch),
//   then refined by golden section around the best sample.
// - The gradient G' is the chain rule through the hinge map: G'(s) = G(p) * T * H^-1, where T maps
//   barycentric to image and H barycentric to the hinge plane (the paper writes psi(G), which applied
//   to the gradient as a vector would be the transpose of that).

#include "mapping/seams.h"

#include <tbb/parallel_for.h>

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <unordered_map>

#include "base/hash.h"
#include "base/job.h"
#include "base/util.h"
#include "geometry/mesh.h"
#include "geometry/predicates.h"
#include "geometry/stretch.h"
#include "image/photo.h"

namespace montage {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kColourNorm = 100;        // L*u*v* difference that counts as 1 in E_tex
constexpr double kGradientNorm = 50;       // L*u*v* per pixel gradient difference that counts as 1
constexpr double kSampleSpacing = 0.4;     // pixels between samples (the paper: under half a pixel)
constexpr int kMaxSamplesPerEdge = 512;    // cap for very long edges
constexpr int kCoarseSamples = 6;          // samples of a search chord before the golden section
constexpr double kMargin = 1e-3;           // relative margin kept from the kernel border
constexpr double kMaxStretchGrowth = 2;    // a projected side's move may at most double its faces' stretch
constexpr double kStopGain = 1e-3;         // rounds stop when the total E falls by less than this (relative)
constexpr double kNoticeableDeltaE = 2.3;  // a seam matching better than this (mean Delta E*uv) is left as it is
constexpr double kSideGain = 1e-2;  // a side whose E fell by less than this (relative) does not wake its neighbours

// One side of a vertex: its corners that show one photo through one UV.
struct Side {
  int vertex = -1, photo = -1;
  Vec2 uv;
  Vec2 start;                                // its UV before the optimisation
  bool projected = false;                    // in a photo mapped by projection (SeamInput::projectedPhotos)
  int corner0 = 0, corners = 0;              // its corners: SeamOptimiser::corners_[corner0, corner0 + corners)
  int edge0 = 0, edges = 0;                  // seam edges whose samples depend on its UV: SeamOptimiser::edges_[...]
  bool fixed = false;                        // a feature vertex, or a degenerate face around it
  bool onSeam = false;                       // an end of a seam edge
  bool closed = false;                       // its faces are all the faces around the vertex
  double scale = 0;                          // largest distance to a corner of its faces (pixels)
  double startStretch = 0;                   // largest stretch of its faces before the optimisation
};

// A seam edge a-b between face f (third vertex c, on one side of the hinge) and face g (third vertex
// d, on the other). s[0..2] are the sides of f's corners at a, b, c; t[0..2] those of g's at a, b, d.
struct SeamEdge {
  int f = -1, g = -1;
  std::array<int, 3> s{}, t{};
  Vec2 c2, d2;  // hinge map: a at the origin, b at (length, 0), c above, d below
  double length = 0;
  double pixelsPerUnit = 1;  // reference scale for the gradients (geometric mean of the two photos')
  int samples = 0;
};

// A run of a flat array (the sides' corners and edges are kept in one array each).
template <typename T>
struct Run {
  const T *first, *last;
  const T* begin() const { return first; }
  const T* end() const { return last; }
};

}  // namespace

// What buildSides and buildSeams make that does not read a UV (given which corners share one), and the
// rounds' plan (SeamMemo::structure).
struct SeamStructure {
  uint64_t meshHash = 0;
  double alpha = 1;
  std::vector<int> facePhoto, fixedVertices;
  std::vector<char> projectedPhotos;
  std::vector<Side> sides;  // their UV-dependent members are set again (setUvDependent)
  std::vector<std::pair<int, int>> corners;
  std::vector<int> edges;
  std::vector<std::array<int, 3>> faceSide;
  std::vector<double> faceArea;
  std::vector<SeamEdge> seams;
  std::vector<int> vertexSide0, vertexSides;  // per vertex: its sides (the grouping check)
  // The plan, valid while every side's `fixed` is as in planFixed.
  std::vector<char> planFixed;
  std::vector<int> touchedStart, touched;
  std::vector<std::vector<int>> batches;
};

namespace {

class SeamOptimiser {
 public:
  SeamOptimiser(const SeamInput& in, const SeamOptions& options, const JobControl& job)
      : in_(in), mesh_(*in.mesh), options_(options), job_(job) {
    TM_CHECK(in.luv.empty() || in.luv.size() == in.photos.size(), "optimiseSeams: " + std::to_string(in.luv.size()) +
                                                                      " L*u*v* images for " +
                                                                      std::to_string(in.photos.size()) + " photos");
    for (size_t k = 0; k < in.photos.size(); ++k) {
      const Photo* p = in.photos[k];
      luv_.push_back(k < in.luv.size() && in.luv[k] ? in.luv[k] : std::make_shared<const LuvTiles>(*p));
      luvScale_.push_back(p->width > 0 ? double(luv_.back()->cols()) / p->width : 1.0);
    }
  }

  SeamResult run();

 private:
  void buildSides();
  void buildSeams();
  // Takes SeamInput::warm's structure when it fits this run's mesh, photos and UVs; false otherwise.
  bool adoptStructure();
  // What reads the UVs: faces' orientation, photos' scales, sides' `fixed` and `scale`, edges' samples.
  void setUvDependent();
  std::shared_ptr<const SeamStructure> structure(const std::vector<std::vector<int>>& batches) const;
  // Sum over the edge's samples of the per-sample E_tex (normalised); optionally the sums of the raw
  // colour (Delta E) and gradient differences.
  double edgeError(const SeamEdge& e, double* deltaE = nullptr, double* gradient = nullptr) const;
  double faceStretch(int face) const;  // normalised L-infinity stretch, kInf when flipped
  double sideEnergy(const Side& side) const;
  // Per seam edge: edgeError's sum, Delta E and gradient sums, all edges in parallel.
  struct EdgeFigures {
    std::vector<double> error, deltaE, gradient;
    bool gradients = false;  // `gradient` was measured
  };
  EdgeFigures measureEdges(bool gradients) const;
  // Measures again, in `edges` and `stretch` (#F, as faceStretches), the seam edges and faces whose
  // figures read the UV of a side in `moved`: the values a full measure would give.
  void remeasure(const std::vector<int>& moved, EdgeFigures& edges, std::vector<double>& stretch) const;
  // E of eq. (2) over all seam sides, from per-edge errors and per-face stretches.
  double totalEnergy(const std::vector<double>& edgeErrors, const std::vector<double>& stretch) const;
  double maxStep(const Side& side, const Vec2& x, const Vec2& d) const;
  bool onForeground(int photo, const Vec2& x) const;
  // Random line searches on one side (directions from `rng`); returns the energy decrease.
  double optimiseSide(int i, std::mt19937& rng);
  // The sides whose UVs side i's energy reads (its faces' corners and its seam edges' ends), itself included.
  void touchedSides(int i, std::vector<int>& out) const;
  // Per side with `needed` set: its SeamMemo key (before any move) and, in `shape`, the same without the
  // UVs (SeamMemo::near); 0 for the others.
  std::vector<uint64_t> sideKeys(const std::vector<char>& needed, std::vector<uint64_t>& shape) const;
  std::vector<double> faceStretches() const;  // #F: faceStretch of mapped faces, 0 elsewhere
  // Mean Delta E and gradient (NaN when not measured) over the seam samples, the largest stretch of the
  // mapped faces that are not degenerate.
  void measure(const EdgeFigures& edges, const std::vector<double>& stretch, double& deltaE, double& gradient,
               double& maxStretch) const;

  Vec2 uvOf(int face, int corner) const { return sides_[faceSide_[face][corner]].uv; }
  Run<std::pair<int, int>> cornersOf(const Side& s) const {  // (face, corner)
    return {corners_.data() + s.corner0, corners_.data() + s.corner0 + s.corners};
  }
  Run<int> edgesOf(const Side& s) const { return {edges_.data() + s.edge0, edges_.data() + s.edge0 + s.edges}; }
  Run<int> touchedOf(int i) const {  // touchedSides(i), for the sides a round may move
    return {touched_.data() + touchedStart_[i], touched_.data() + touchedStart_[i + 1]};
  }

  const SeamInput& in_;
  const Mesh& mesh_;
  const SeamOptions& options_;
  const JobControl& job_;
  double alpha_ = 1;

  std::vector<std::shared_ptr<const LuvTiles>> luv_;  // per photo: its L*u*v* image (stored resolution)
  std::vector<double> luvScale_;  // per photo: stored pixels per file pixel
  std::vector<Side> sides_;
  std::vector<std::pair<int, int>> corners_;  // the sides' corners, side by side (Side::corner0)
  std::vector<int> edges_;                    // the sides' seam edges, side by side (Side::edge0)
  std::vector<int> touchedStart_, touched_;   // touchedSides per side (empty for sides no round moves)
  std::vector<std::array<int, 3>> faceSide_;  // #F x 3, -1 for unmapped faces
  std::vector<double> faceArea_;              // #F: area of the mapped faces (model units)
  std::vector<double> faceSign_;              // #F: orientation of the texture triangle (+1 / -1, 0 = degenerate)
  std::vector<double> photoScale_;            // per photo: pixels per model unit over its faces
  std::vector<SeamEdge> seams_;
};

bool SeamOptimiser::onForeground(int photo, const Vec2& x) const {
  const Photo& ph = *in_.photos[photo];
  if (!ph.inside(x.x(), x.y())) return false;
  return !ph.hasBackground || ph.isForeground(x.x(), x.y());
}

void SeamOptimiser::buildSides() {
  const TextureMap& map = *in_.map;
  const int nf = mesh_.numFaces(), nv = mesh_.numVertices();
  // Each vertex's sides as a list through `nextSide` (first side per vertex in `firstSide`).
  std::vector<int> firstSide(nv, -1), nextSide, valence(nv, 0);
  sides_.clear();
  faceSide_.assign(nf, {-1, -1, -1});
  for (int f = 0; f < nf; ++f)
    for (int v : mesh_.faceVertices(f)) valence[v]++;
  sides_.reserve(nv + nv / 4);
  nextSide.reserve(nv + nv / 4);
  faceArea_.assign(nf, 0);
  for (int f = 0; f < nf; ++f) {
    const auto fv = mesh_.faceVertices(f);
    const int p = map.facePhoto[f];
    if (p < 0) continue;
    const auto& uv = map.cornerUV[f];
    faceArea_[f] = mesh_.faceArea(f);
    for (int k = 0; k < 3; ++k) {
      const int v = fv[k];
      int id = -1;
      for (int s = firstSide[v]; s >= 0 && id < 0; s = nextSide[s])
        if (sides_[s].photo == p && sides_[s].uv == uv[k]) id = s;
      if (id < 0) {
        id = static_cast<int>(sides_.size());
        Side& side = sides_.emplace_back();
        side.vertex = v, side.photo = p, side.uv = side.start = uv[k];
        side.projected = p < static_cast<int>(in_.projectedPhotos.size()) && in_.projectedPhotos[p];
        nextSide.push_back(firstSide[v]);
        firstSide[v] = id;
      }
      ++sides_[id].corners;
      faceSide_[f][k] = id;
    }
  }
  // The corners, side by side, each side's in face order.
  int next = 0;
  for (Side& s : sides_) s.corner0 = next, next += s.corners, s.corners = 0;
  corners_.resize(next);
  for (int f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k)
      if (const int id = faceSide_[f][k]; id >= 0) {
        Side& s = sides_[id];
        corners_[s.corner0 + s.corners++] = {f, k};
      }
  for (Side& s : sides_) s.closed = s.corners == valence[s.vertex];
}

void SeamOptimiser::setUvDependent() {
  const TextureMap& map = *in_.map;
  const int nf = mesh_.numFaces(), nv = mesh_.numVertices();
  faceSign_.assign(nf, 0);
  std::vector<double> pixelArea(in_.photos.size(), 0), surfaceArea(in_.photos.size(), 0);
  for (int f = 0; f < nf; ++f) {
    const int p = map.facePhoto[f];
    if (p < 0) continue;
    const auto& uv = map.cornerUV[f];
    const double area = orient2(uv[0], uv[1], uv[2]);
    faceSign_[f] = area > 0 ? 1 : (area < 0 ? -1 : 0);
    pixelArea[p] += 0.5 * std::abs(area);
    surfaceArea[p] += faceArea_[f];
  }
  photoScale_.assign(in_.photos.size(), 1);
  for (size_t p = 0; p < in_.photos.size(); ++p)
    if (surfaceArea[p] > 0 && pixelArea[p] > 0) photoScale_[p] = std::sqrt(pixelArea[p] / surfaceArea[p]);
  std::vector<char> isFixed(nv, 0);
  for (int v : in_.fixedVertices)
    if (v >= 0 && v < nv) isFixed[v] = 1;
  for (Side& s : sides_) {
    s.fixed = isFixed[s.vertex];
    s.scale = 0;
    for (const auto& [f, k] : cornersOf(s)) {
      if (faceSign_[f] == 0) s.fixed = true;
      for (int j = 1; j < 3; ++j) s.scale = std::max(s.scale, (uvOf(f, (k + j) % 3) - s.uv).norm());
    }
  }
  for (SeamEdge& e : seams_) {
    e.pixelsPerUnit = std::sqrt(photoScale_[map.facePhoto[e.f]] * photoScale_[map.facePhoto[e.g]]);
    const double len1 = (sides_[e.s[1]].uv - sides_[e.s[0]].uv).norm();
    const double len2 = (sides_[e.t[1]].uv - sides_[e.t[0]].uv).norm();
    e.samples = std::clamp(int(std::ceil(std::max(len1, len2) / kSampleSpacing)), 2, kMaxSamplesPerEdge);
  }
}

bool SeamOptimiser::adoptStructure() {
  if (!in_.warm || !in_.warm->structure || in_.meshHash == 0) return false;
  const SeamStructure& st = *in_.warm->structure;
  const TextureMap& map = *in_.map;
  if (st.meshHash != in_.meshHash || st.alpha != alpha_ || st.facePhoto != map.facePhoto ||
      st.fixedVertices != in_.fixedVertices || st.projectedPhotos != in_.projectedPhotos ||
      st.faceSide.size() != size_t(mesh_.numFaces()) || st.vertexSide0.size() != size_t(mesh_.numVertices()) + 1)
    return false;
  // The same grouping: every corner of a side has the side's UV, and the sides of one photo at a vertex
  // have different UVs (buildSides would make the same sides, in the same order).
  std::vector<Vec2> uv(st.sides.size());
  std::vector<char> set(st.sides.size(), 0);
  for (int f = 0; f < mesh_.numFaces(); ++f) {
    if (map.facePhoto[f] < 0) continue;
    for (int k = 0; k < 3; ++k) {
      const int id = st.faceSide[f][k];
      if (!set[id])
        uv[id] = map.cornerUV[f][k], set[id] = 1;
      else if (uv[id] != map.cornerUV[f][k])
        return false;
    }
  }
  for (size_t v = 0; v + 1 < st.vertexSide0.size(); ++v)
    for (int a = st.vertexSide0[v]; a < st.vertexSide0[v + 1]; ++a)
      for (int b = a + 1; b < st.vertexSide0[v + 1]; ++b) {
        const int i = st.vertexSides[a], j = st.vertexSides[b];
        if (st.sides[i].photo == st.sides[j].photo && uv[i] == uv[j]) return false;
      }
  sides_ = st.sides;
  for (size_t i = 0; i < sides_.size(); ++i) {
    Side& side = sides_[i];
    side.uv = side.start = uv[i];
    side.startStretch = 0;
  }
  corners_ = st.corners;
  edges_ = st.edges;
  faceSide_ = st.faceSide;
  faceArea_ = st.faceArea;
  seams_ = st.seams;
  return true;
}

std::shared_ptr<const SeamStructure> SeamOptimiser::structure(const std::vector<std::vector<int>>& batches) const {
  auto st = std::make_shared<SeamStructure>();
  st->meshHash = in_.meshHash;
  st->alpha = alpha_;
  st->facePhoto = in_.map->facePhoto;
  st->fixedVertices = in_.fixedVertices;
  st->projectedPhotos = in_.projectedPhotos;
  st->sides = sides_;
  st->corners = corners_;
  st->edges = edges_;
  st->faceSide = faceSide_;
  st->faceArea = faceArea_;
  st->seams = seams_;
  const int nv = mesh_.numVertices();
  st->vertexSide0.assign(nv + 1, 0);
  for (const Side& side : sides_) ++st->vertexSide0[side.vertex + 1];
  for (int v = 0; v < nv; ++v) st->vertexSide0[v + 1] += st->vertexSide0[v];
  st->vertexSides.resize(sides_.size());
  std::vector<int> fill(st->vertexSide0.begin(), st->vertexSide0.end() - 1);
  for (size_t i = 0; i < sides_.size(); ++i) st->vertexSides[fill[sides_[i].vertex]++] = static_cast<int>(i);
  st->planFixed.resize(sides_.size());
  for (size_t i = 0; i < sides_.size(); ++i) st->planFixed[i] = sides_[i].fixed;
  st->touchedStart = touchedStart_;
  st->touched = touched_;
  st->batches = batches;
  return st;
}

void SeamOptimiser::buildSeams() {
  const TextureMap& map = *in_.map;
  // Interior edges from the mesh's connectivity: face f holds the edge as corner kf -> kf + 1.
  const TriMesh& tri = mesh_.tri;
  auto cornerOf = [&](int face, int vertex) {
    const auto fv = mesh_.faceVertices(face);
    return fv[0] == vertex ? 0 : fv[1] == vertex ? 1 : 2;
  };
  std::vector<std::pair<int, int>> sideEdge;  // (side, seam edge), in edge order
  for (auto eh : tri.edges()) {
    if (tri.is_boundary(eh)) continue;
    const auto h0 = tri.halfedge_handle(eh, 0), h1 = tri.halfedge_handle(eh, 1);
    const int f0 = tri.face_handle(h0).idx(), f1 = tri.face_handle(h1).idx();
    const bool first = f0 < f1;  // the lower face index is f (as before: faces in index order)
    const auto hf = first ? h0 : h1;
    const int f = first ? f0 : f1, g = first ? f1 : f0;
    const int kf = cornerOf(f, tri.from_vertex_handle(hf).idx());
    const int kg = cornerOf(g, tri.to_vertex_handle(hf).idx());
    if (map.facePhoto[f] < 0 || map.facePhoto[g] < 0) continue;
    // f runs a -> b from corner kf; g runs b -> a from corner kg (consistent orientation).
    SeamEdge e;
    e.f = f, e.g = g;
    e.s = {faceSide_[f][kf], faceSide_[f][(kf + 1) % 3], faceSide_[f][(kf + 2) % 3]};
    const auto gv = mesh_.faceVertices(g);
    const int a = mesh_.faceVertices(f)[kf];
    const int ga = gv[kg] == a ? kg : (kg + 1) % 3;  // g's corner at a
    const int gb = gv[kg] == a ? (kg + 1) % 3 : kg;
    e.t = {faceSide_[g][ga], faceSide_[g][gb], faceSide_[g][3 - ga - gb]};
    if (e.s[0] == e.t[0] && e.s[1] == e.t[1]) continue;  // continuous texture across the edge
    const Vec3 pa = mesh_.position(a), pb = mesh_.position(mesh_.faceVertices(f)[(kf + 1) % 3]);
    const Vec3 pc = mesh_.position(mesh_.faceVertices(f)[(kf + 2) % 3]), pd = mesh_.position(gv[3 - ga - gb]);
    e.length = (pb - pa).norm();
    if (!(e.length > 0)) continue;
    const Vec3 ex = (pb - pa) / e.length;
    auto hinge = [&](const Vec3& p, double sign) {
      const Vec3 w = p - pa;
      const double x = w.dot(ex);
      return Vec2(x, sign * (w - x * ex).norm());
    };
    e.c2 = hinge(pc, +1);
    e.d2 = hinge(pd, -1);
    const int id = static_cast<int>(seams_.size());
    seams_.push_back(e);
    for (int j = 0; j < 2; ++j) {
      sides_[e.s[j]].onSeam = sides_[e.t[j]].onSeam = true;
      sideEdge.emplace_back(e.s[j], id), sideEdge.emplace_back(e.t[j], id);
    }
    if (alpha_ < 1) sideEdge.emplace_back(e.s[2], id), sideEdge.emplace_back(e.t[2], id);
  }
  // Side by side, each side's edges in increasing order without repeats (a stable counting sort).
  std::vector<int> start(sides_.size() + 1, 0);
  for (const auto& [side, e] : sideEdge) ++start[side + 1];
  for (size_t i = 0; i < sides_.size(); ++i) start[i + 1] += start[i];
  edges_.assign(sideEdge.size(), -1);
  std::vector<int> fill(start.begin(), start.end() - 1);
  for (const auto& [side, e] : sideEdge)
    if (fill[side] == start[side] || edges_[fill[side] - 1] != e) edges_[fill[side]++] = e;
  for (size_t i = 0; i < sides_.size(); ++i) sides_[i].edge0 = start[i], sides_[i].edges = fill[i] - start[i];
}

double SeamOptimiser::edgeError(const SeamEdge& e, double* deltaE, double* gradient) const {
  const TextureMap& map = *in_.map;
  const int ph1 = map.facePhoto[e.f], ph2 = map.facePhoto[e.g];
  const LuvTiles &luv1 = *luv_[ph1], &luv2 = *luv_[ph2];
  const double s1 = luvScale_[ph1], s2 = luvScale_[ph2];
  const Vec2 a1 = sides_[e.s[0]].uv, b1 = sides_[e.s[1]].uv, c1 = sides_[e.s[2]].uv;
  const Vec2 a2 = sides_[e.t[0]].uv, b2 = sides_[e.t[1]].uv, d2 = sides_[e.t[2]].uv;
  const bool gradients = alpha_ < 1 || gradient;
  // Image gradient (3 x 2, per pixel) -> hinge-plane gradient, per pixel of the reference scale.
  Eigen::Matrix2d toPlane1 = Eigen::Matrix2d::Zero(), toPlane2 = Eigen::Matrix2d::Zero();
  if (gradients) {
    Eigen::Matrix2d t1, t2, h1, h2;
    t1 << (b1 - a1), (c1 - a1);
    t2 << (b2 - a2), (d2 - a2);
    h1 << Vec2(e.length, 0), e.c2;
    h2 << Vec2(e.length, 0), e.d2;
    if (std::abs(h1.determinant()) > 1e-300) toPlane1 = t1 * h1.inverse() / e.pixelsPerUnit;
    if (std::abs(h2.determinant()) > 1e-300) toPlane2 = t2 * h2.inverse() / e.pixelsPerUnit;
  }
  double sum = 0, sumDeltaE = 0, sumGradient = 0;
  for (int k = 0; k < e.samples; ++k) {
    const double t = (k + 0.5) / e.samples;
    const Vec2 q1 = (1 - t) * a1 + t * b1, q2 = (1 - t) * a2 + t * b2;
    const double de =
        (luv1.sample(s1 * q1.x(), s1 * q1.y()) - luv2.sample(s2 * q2.x(), s2 * q2.y()))
            .cast<double>()
            .norm();
    sumDeltaE += de;
    double err = alpha_ * std::min(de / kColourNorm, 1.0);
    if (gradients) {
      Vec3f dx1, dy1, dx2, dy2;
      luv1.gradient(s1 * q1.x(), s1 * q1.y(), dx1, dy1);  // per stored pixel
      luv2.gradient(s2 * q2.x(), s2 * q2.y(), dx2, dy2);
      dx1 *= float(s1), dy1 *= float(s1), dx2 *= float(s2), dy2 *= float(s2);  // per file pixel
      Eigen::Matrix<double, 3, 2> g1, g2;
      g1 << dx1.cast<double>(), dy1.cast<double>();
      g2 << dx2.cast<double>(), dy2.cast<double>();
      const double dg = (g1 * toPlane1 - g2 * toPlane2).norm();
      sumGradient += dg;
      err += (1 - alpha_) * std::min(dg / kGradientNorm, 1.0);
    }
    sum += err;
  }
  if (deltaE) *deltaE = sumDeltaE;
  if (gradient) *gradient = sumGradient;
  return sum;
}

double SeamOptimiser::faceStretch(int face) const {
  const auto fv = mesh_.faceVertices(face);
  std::array<Vec2, 3> uv = {uvOf(face, 0), uvOf(face, 1), uvOf(face, 2)};
  // triangleStretch wants a counter-clockwise texture triangle: mirror clockwise ones (photos are y-down).
  if (faceSign_[face] < 0)
    for (Vec2& p : uv) p.y() = -p.y();
  const TriangleStretch s = triangleStretch({mesh_.position(fv[0]), mesh_.position(fv[1]), mesh_.position(fv[2])}, uv);
  if (s.flipped || !std::isfinite(s.gamma)) return kInf;
  return s.gamma * photoScale_[in_.map->facePhoto[face]];
}

double SeamOptimiser::sideEnergy(const Side& side) const {
  double geo = 0;
  for (const auto& [f, k] : cornersOf(side)) geo = std::max(geo, faceStretch(f));
  if (!std::isfinite(geo)) return kInf;
  // Projected sides: no flip (above), no face stretched past kMaxStretchGrowth x its projection's (a move
  // towards a degenerate texture triangle smears a texel across the face), and near the projection.
  if (side.projected && geo > kMaxStretchGrowth * side.startStretch) return kInf;
  if (side.projected) geo = (side.uv - side.start).squaredNorm();
  double tex = 0;
  int n = 0;
  for (int e : edgesOf(side)) tex += edgeError(seams_[e]), n += seams_[e].samples;
  if (n > 0) tex /= n;
  return options_.lambda * geo + (1 - options_.lambda) * tex;
}

SeamOptimiser::EdgeFigures SeamOptimiser::measureEdges(bool gradients) const {
  const size_t m = seams_.size();
  EdgeFigures out{std::vector<double>(m), std::vector<double>(m), std::vector<double>(m), gradients};
  tbb::parallel_for(size_t(0), m, [&](size_t e) {
    out.error[e] = edgeError(seams_[e], &out.deltaE[e], gradients ? &out.gradient[e] : nullptr);
  });
  return out;
}

void SeamOptimiser::remeasure(const std::vector<int>& moved, EdgeFigures& edges, std::vector<double>& stretch) const {
  if (moved.empty()) return;
  std::vector<char> isMoved(sides_.size(), 0);
  for (int i : moved) {
    isMoved[i] = 1;
    for (const auto& [f, k] : cornersOf(sides_[i])) stretch[f] = faceStretch(f);
  }
  // An edge's figures read the UVs of its six corners' sides (the gradient's hinge map reads the third
  // vertices' even when E_tex does not).
  std::vector<int> edgeList;
  for (int e = 0; e < static_cast<int>(seams_.size()); ++e) {
    const SeamEdge& se = seams_[e];
    for (int k = 0; k < 3; ++k)
      if (isMoved[se.s[k]] || isMoved[se.t[k]]) {
        edgeList.push_back(e);
        break;
      }
  }
  tbb::parallel_for(size_t(0), edgeList.size(), [&](size_t k) {
    const int e = edgeList[k];
    edges.error[e] = edgeError(seams_[e], &edges.deltaE[e], edges.gradients ? &edges.gradient[e] : nullptr);
  });
}

double SeamOptimiser::totalEnergy(const std::vector<double>& edgeErrors, const std::vector<double>& stretch) const {
  double tex = 0, geo = 0;
  int n = 0, sides = 0;
  for (size_t e = 0; e < seams_.size(); ++e) tex += edgeErrors[e], n += seams_[e].samples;
  for (const Side& s : sides_) {
    if (!s.onSeam) continue;
    double g = 0;
    for (const auto& [f, k] : cornersOf(s)) g = std::max(g, stretch[f]);
    geo += g, ++sides;
  }
  return options_.lambda * (sides ? geo / sides : 0) + (1 - options_.lambda) * (n ? tex / n : 0);
}

// The largest step t along d from x that keeps every face of the side oriented as it was; unbounded
// (open fans) is capped at twice the fan's size.
double SeamOptimiser::maxStep(const Side& side, const Vec2& x, const Vec2& d) const {
  double t = kInf;
  for (const auto& [f, k] : cornersOf(side)) {
    const Vec2 a = uvOf(f, (k + 1) % 3), b = uvOf(f, (k + 2) % 3);
    const double g0 = faceSign_[f] * orient2(x, a, b);
    const double dg = faceSign_[f] * cross2(b - a, d);
    if (dg < 0) t = std::min(t, g0 / -dg);
  }
  t = std::min(t, 2 * side.scale / std::max(d.norm(), 1e-300));
  return std::max(0.0, t * (1 - kMargin));
}

void SeamOptimiser::touchedSides(int i, std::vector<int>& out) const {
  out.clear();
  for (const auto& [f, k] : cornersOf(sides_[i]))
    for (int j = 0; j < 3; ++j) out.push_back(faceSide_[f][j]);
  for (int e : edgesOf(sides_[i]))
    for (int j = 0; j < 3; ++j) out.push_back(seams_[e].s[j]), out.push_back(seams_[e].t[j]);
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
}

double SeamOptimiser::optimiseSide(int i, std::mt19937& rng) {
  Side& side = sides_[i];
  const double start = sideEnergy(side);
  if (!std::isfinite(start)) return 0;
  double e = start;
  Vec2 x = side.uv;
  auto energyAt = [&](const Vec2& y) {
    side.uv = y;
    const double ey = sideEnergy(side);
    side.uv = x;
    return ey;
  };
  for (int s = 0; s < options_.lineSearches; ++s) {
    const double angle = std::uniform_real_distribution<double>(0, 2 * M_PI)(rng);
    const Vec2 d(std::cos(angle), std::sin(angle));
    const double lo = -maxStep(side, x, -d), hi = maxStep(side, x, d);
    if (!(hi > lo)) continue;
    // Coarse samples of the chord, then golden section around the best.
    double bestT = 0, bestE = e;
    for (int j = 0; j <= kCoarseSamples; ++j) {
      const double t = lo + (hi - lo) * j / kCoarseSamples;
      if (t == 0) continue;
      const double et = energyAt(x + t * d);
      if (et < bestE) bestE = et, bestT = t;
    }
    constexpr double kGolden = 0.6180339887498949;
    const double h = (hi - lo) / kCoarseSamples;
    double a = std::max(lo, bestT - h), b = std::min(hi, bestT + h);
    double c = b - kGolden * (b - a), m = a + kGolden * (b - a);
    double fc = energyAt(x + c * d), fm = energyAt(x + m * d);
    for (int k = 0; k < options_.searchSteps; ++k) {
      if (fc < fm) {
        b = m, m = c, fm = fc;
        c = b - kGolden * (b - a);
        fc = energyAt(x + c * d);
      } else {
        a = c, c = m, fc = fm;
        m = a + kGolden * (b - a);
        fm = energyAt(x + m * d);
      }
    }
    if (fc < bestE) bestE = fc, bestT = c;
    if (fm < bestE) bestE = fm, bestT = m;
    if (bestE < e && onForeground(side.photo, x + bestT * d)) {
      x += bestT * d;
      e = bestE;
      side.uv = x;
    }
  }
  return start - e;
}

std::vector<uint64_t> SeamOptimiser::sideKeys(const std::vector<char>& needed, std::vector<uint64_t>& shape) const {
  const TextureMap& map = *in_.map;
  // Only the faces the needed sides' keys read are hashed.
  std::vector<char> read(mesh_.numFaces(), 0);
  for (size_t i = 0; i < sides_.size(); ++i) {
    if (!needed[i]) continue;
    for (const auto& [f, k] : cornersOf(sides_[i])) read[f] = 1;
    for (int e : edgesOf(sides_[i])) read[seams_[e].f] = read[seams_[e].g] = 1;
  }
  std::vector<uint64_t> faceHash(mesh_.numFaces(), 0), faceShape(mesh_.numFaces(), 0);
  for (int f = 0; f < mesh_.numFaces(); ++f) {
    if (!read[f] || map.facePhoto[f] < 0) continue;
    uint64_t h = hashMix(0, uint64_t(map.facePhoto[f])), g = h;
    const auto fv = mesh_.faceVertices(f);
    for (int k = 0; k < 3; ++k) {
      h = hashMix(hashMix(h, mesh_.position(fv[k])), map.cornerUV[f][k]);
      g = hashMix(g, mesh_.position(fv[k]));
    }
    faceHash[f] = h;
    faceShape[f] = g;
  }
  std::vector<uint64_t> keys(sides_.size());
  shape.assign(sides_.size(), 0);
  std::vector<uint64_t> around;
  auto keyOf = [&](const Side& side, const std::vector<uint64_t>& hashes, bool withStart) {
    around.clear();
    for (const auto& [f, k] : cornersOf(side)) around.push_back(hashes[f]);
    for (int e : edgesOf(side)) around.push_back(hashes[seams_[e].f]), around.push_back(hashes[seams_[e].g]);
    std::sort(around.begin(), around.end());
    around.erase(std::unique(around.begin(), around.end()), around.end());
    uint64_t h = hashMix(hashMix(0, uint64_t(side.photo)), mesh_.position(side.vertex));
    if (withStart) h = hashMix(h, side.start);
    for (uint64_t a : around) h = hashMix(h, a);
    return h;
  };
  for (size_t i = 0; i < sides_.size(); ++i) {
    if (!needed[i]) continue;
    keys[i] = keyOf(sides_[i], faceHash, true);
    shape[i] = keyOf(sides_[i], faceShape, false);
  }
  return keys;
}

std::vector<double> SeamOptimiser::faceStretches() const {
  std::vector<double> out(mesh_.numFaces(), 0.0);
  for (int f = 0; f < mesh_.numFaces(); ++f)
    if (faceSide_[f][0] >= 0) out[f] = faceStretch(f);
  return out;
}

void SeamOptimiser::measure(const EdgeFigures& edges, const std::vector<double>& stretch, double& deltaE,
                            double& gradient, double& maxStretch) const {
  double de = 0, dg = 0;
  long n = 0;
  for (size_t e = 0; e < seams_.size(); ++e) de += edges.deltaE[e], dg += edges.gradient[e], n += seams_[e].samples;
  deltaE = n ? de / n : 0;
  gradient = !edges.gradients ? std::numeric_limits<double>::quiet_NaN() : n ? dg / n : 0;
  maxStretch = 0;
  for (int f = 0; f < mesh_.numFaces(); ++f)
    if (faceSide_[f][0] >= 0 && faceSign_[f] != 0) maxStretch = std::max(maxStretch, stretch[f]);
}

SeamResult SeamOptimiser::run() {
  const auto start = Clock::now();
  const TextureMap& map = *in_.map;
  const int nf = mesh_.numFaces();
  TM_CHECK(map.numFaces() == nf && static_cast<int>(map.cornerUV.size()) == nf,
           "seams: the texture map has " + std::to_string(map.numFaces()) + " faces, the mesh " + std::to_string(nf));
  for (int f = 0; f < nf; ++f)
    TM_CHECK(map.facePhoto[f] < static_cast<int>(in_.photos.size()) && map.facePhoto[f] >= TextureMap::kEmpty,
             "seams: face " + std::to_string(f) + " names photo " + std::to_string(map.facePhoto[f]) +
                 ", which does not exist (" + std::to_string(in_.photos.size()) + " photos)");
  TM_CHECK(options_.lambda >= 0 && options_.lambda <= 1,
           "seams: seamLambda must be in [0, 1] (got " + std::to_string(options_.lambda) + ")");
  TM_CHECK(options_.gradientWeight >= 0 && options_.gradientWeight <= 1,
           "seams: gradientWeight must be in [0, 1] (got " + std::to_string(options_.gradientWeight) + ")");
  alpha_ = 1 - options_.gradientWeight;

  SeamResult out;
  const std::shared_ptr<const SeamStructure> kept = adoptStructure() ? in_.warm->structure : nullptr;
  if (!kept) {
    buildSides();
    buildSeams();
  }
  setUvDependent();
  out.structureKept = kept != nullptr;
  out.setupSeconds = secondsSince(start);
  auto t = Clock::now();
  const std::vector<double> stretchBefore = faceStretches();
  for (Side& s : sides_)
    for (const auto& [f, k] : cornersOf(s)) s.startStretch = std::max(s.startStretch, stretchBefore[f]);
  const bool gradients = options_.measureGradients || alpha_ < 1;
  const EdgeFigures before = measureEdges(gradients);
  measure(before, stretchBefore, out.deltaEBefore, out.gradientBefore, out.maxStretchBefore);
  out.measureSeconds = secondsSince(t);
  std::vector<int> seamSides, neighbours;
  std::vector<char> seamVertex(mesh_.numVertices(), 0);
  for (int i = 0; i < static_cast<int>(sides_.size()); ++i) {
    const Side& s = sides_[i];
    if (s.fixed || s.edges == 0) continue;
    if (s.onSeam) {
      seamSides.push_back(i);
      seamVertex[s.vertex] = 1;
    } else if (s.closed) {
      neighbours.push_back(i);  // only with gradients: its edges are the seam edges its faces touch
    }
  }
  out.seamEdges = static_cast<int>(seams_.size());
  out.seamVertices = static_cast<int>(std::count(seamVertex.begin(), seamVertex.end(), 1));
  out.neighbourVertices = static_cast<int>(neighbours.size());
  // Alternate the sides of each vertex (section 4.2): sort the seam sides by vertex.
  std::stable_sort(seamSides.begin(), seamSides.end(),
                   [&](int a, int b) { return sides_[a].vertex < sides_[b].vertex; });

  // The order of one round: the seam sides (by vertex), then the gradient neighbours. Sides that read
  // none of each other's UVs are independent: a greedy colouring in that order gives batches that run in
  // parallel, batch after batch, so the result does not depend on the number of threads.
  std::vector<int> order = seamSides;
  order.insert(order.end(), neighbours.begin(), neighbours.end());
  // The plan (touched sides, batches) of the kept structure serves while every side is fixed as there.
  bool planKept = kept != nullptr;
  for (size_t i = 0; planKept && i < sides_.size(); ++i) planKept = sides_[i].fixed == bool(kept->planFixed[i]);
  std::vector<std::vector<int>> batches;
  if (planKept) {
    touchedStart_ = kept->touchedStart;
    touched_ = kept->touched;
    batches = kept->batches;
  } else {
    touchedStart_.assign(sides_.size() + 1, 0);
    touched_.clear();
    std::vector<char> inOrder(sides_.size(), 0);
    for (int i : order) inOrder[i] = 1;
    std::vector<int> list;
    for (size_t i = 0; i < sides_.size(); ++i) {
      if (inOrder[i]) {
        touchedSides(static_cast<int>(i), list);
        touched_.insert(touched_.end(), list.begin(), list.end());
      }
      touchedStart_[i + 1] = static_cast<int>(touched_.size());
    }
    std::vector<int> colour(sides_.size(), -1);
    int colours = 0;
    {
      // side -> optimised sides whose energy reads it, side by side (in `order`'s order)
      std::vector<int> readerStart(sides_.size() + 1, 0), readers;
      for (int i : order)
        for (int j : touchedOf(i)) ++readerStart[j + 1];
      for (size_t j = 0; j < sides_.size(); ++j) readerStart[j + 1] += readerStart[j];
      readers.resize(readerStart.back());
      std::vector<int> fill(readerStart.begin(), readerStart.end() - 1);
      for (int i : order)
        for (int j : touchedOf(i)) readers[fill[j]++] = i;
      std::vector<int> seen(order.size() + 1, -1);
      for (int i : order) {
        for (int j : touchedOf(i))
          if (colour[j] >= 0) seen[colour[j]] = i;  // i reads j
        for (int k = readerStart[i]; k < readerStart[i + 1]; ++k)
          if (colour[readers[k]] >= 0) seen[colour[readers[k]]] = i;  // r reads i
        int c = 0;
        while (seen[c] == i) ++c;
        colour[i] = c;
        colours = std::max(colours, c + 1);
      }
    }
    batches.resize(colours);
    for (int i : order) batches[colour[i]].push_back(i);
  }

  // Rounds over the active sides: all at first, then those a move in the last round may have changed
  // (the moved side and every side whose UVs its energy reads).
  // A side whose seam edges already match below the just-noticeable difference starts asleep.
  std::vector<char> active(sides_.size(), 0), next(sides_.size(), 0);
  for (int i : order) {
    double de = 0;
    int n = 0;
    for (int e : edgesOf(sides_[i])) de += before.deltaE[e], n += seams_[e].samples;
    active[i] = n > 0 && de / n > kNoticeableDeltaE;
    out.sleepingSides += !active[i];
  }
  // Warm start (SeamMemo): sides whose surroundings the last run saw take its UVs and start asleep; a
  // face that would come out flipped or degenerate puts its sides back where they started. Only the
  // sides the rounds may move and those their energies read have keys: the others keep their start.
  std::vector<char> keyed(sides_.size(), 0);
  for (int i : order) {
    keyed[i] = 1;
    for (int j : touchedOf(i)) keyed[j] = 1;
  }
  std::vector<uint64_t> shapeKeys;
  const std::vector<uint64_t> keys = sideKeys(keyed, shapeKeys);
  if (in_.warm) {
    std::vector<char> warm(sides_.size(), 0), near(sides_.size(), 0);
    for (size_t i = 0; i < sides_.size(); ++i) {
      if (sides_[i].fixed || !keyed[i]) continue;
      const auto it = in_.warm->uv.find(keys[i]);
      if (it == in_.warm->uv.end()) continue;
      sides_[i].uv = it->second;
      warm[i] = 1;
    }
    if (in_.warmTolerancePx > 0) {
      // The kept move of each side whose start moved less than the tolerance; a side takes its move when
      // every side its energy reads (itself included) has one.
      std::vector<const SeamMemo::Move*> kept(sides_.size(), nullptr);
      for (size_t i = 0; i < sides_.size(); ++i) {
        if (!keyed[i]) continue;
        const auto it = in_.warm->near.find(shapeKeys[i]);
        if (it != in_.warm->near.end() && (sides_[i].start - it->second.start).norm() < in_.warmTolerancePx)
          kept[i] = &it->second;
      }
      for (int i : order) {
        if (warm[i] || sides_[i].fixed || !kept[i]) continue;
        bool still = true;
        for (int j : touchedOf(i)) still = still && kept[j];
        if (!still) continue;
        sides_[i].uv = sides_[i].start + (kept[i]->uv - kept[i]->start);
        warm[i] = near[i] = 1;
      }
    }
    for (bool again = true; again;) {
      again = false;
      for (int f = 0; f < nf; ++f) {
        if (faceSide_[f][0] < 0) continue;
        const auto& fs = faceSide_[f];
        if (!warm[fs[0]] && !warm[fs[1]] && !warm[fs[2]]) continue;
        const double area = orient2(uvOf(f, 0), uvOf(f, 1), uvOf(f, 2));
        if (area * faceSign_[f] > 0) continue;
        for (int side : fs)
          if (warm[side]) sides_[side].uv = sides_[side].start, warm[side] = 0, again = true;
      }
    }
    for (size_t i = 0; i < sides_.size(); ++i)
      if (warm[i]) {
        out.sleepingSides += active[i];
        active[i] = 0;
        ++out.warmSides;
        out.warmNearSides += near[i];
      }
  }
  // The figures at the current UVs: the warm sides' edges and faces measured anew, then after every
  // round those of the sides that moved.
  EdgeFigures current = before;
  std::vector<double> stretch = stretchBefore;
  {
    std::vector<int> moved;
    for (int i = 0; i < static_cast<int>(sides_.size()); ++i)
      if (sides_[i].uv != sides_[i].start) moved.push_back(i);
    remeasure(moved, current, stretch);
  }
  double energy = totalEnergy(current.error, stretch);
  t = Clock::now();
  for (int round = 0; round < options_.rounds && !order.empty(); ++round) {
    job_.progress(StageId::Seams, double(round) / options_.rounds, "round " + std::to_string(round + 1));
    std::vector<char> moved(sides_.size(), 0), changed(sides_.size(), 0);
    for (const std::vector<int>& batch : batches)
      tbb::parallel_for(size_t(0), batch.size(), [&](size_t b) {
        const int i = batch[b];
        if (!active[i]) return;
        std::seed_seq seq{options_.seed, unsigned(round), unsigned(i)};
        std::mt19937 rng(seq);
        const Vec2 uv = sides_[i].uv;
        const double e = sideEnergy(sides_[i]);
        const double gain = optimiseSide(i, rng);
        moved[i] = gain > kSideGain * e;
        changed[i] = sides_[i].uv != uv;
      });
    std::fill(next.begin(), next.end(), 0);
    std::vector<int> changedSides;
    for (int i : order) {
      if (moved[i])
        for (int j : touchedOf(i)) next[j] = 1;
      if (changed[i]) changedSides.push_back(i);
    }
    active.swap(next);
    out.rounds = round + 1;
    remeasure(changedSides, current, stretch);
    const double after = totalEnergy(current.error, stretch);
    const bool falls = after < energy * (1 - kStopGain);
    energy = after;
    if (!falls || std::find(active.begin(), active.end(), 1) == active.end()) break;
  }
  for (const Side& side : sides_) out.movedSides += side.uv != side.start;
  out.roundSeconds = secondsSince(t);
  auto memo = std::make_shared<SeamMemo>();
  const size_t numKeyed = size_t(std::count(keyed.begin(), keyed.end(), 1));
  memo->uv.reserve(numKeyed);
  memo->near.reserve(numKeyed);
  for (size_t i = 0; i < sides_.size(); ++i) {
    if (!keyed[i]) continue;
    if (!sides_[i].fixed) memo->uv[keys[i]] = sides_[i].uv;
    memo->near[shapeKeys[i]] = {sides_[i].start, sides_[i].uv};
  }
  memo->structure = planKept ? kept : structure(batches);
  out.memo = memo;
  t = Clock::now();

  out.map = map;
  for (int f = 0; f < nf; ++f)
    if (faceSide_[f][0] >= 0)
      for (int k = 0; k < 3; ++k) out.map.cornerUV[f][k] = uvOf(f, k);
  const EdgeFigures& after = current;
  measure(after, stretch, out.deltaEAfter, out.gradientAfter, out.maxStretchAfter);
  // Per face: mean Delta E over its seam edges' samples.
  std::vector<double> sum(nf, 0);
  std::vector<int> count(nf, 0);
  for (size_t e = 0; e < seams_.size(); ++e)
    for (int f : {seams_[e].f, seams_[e].g}) sum[f] += after.deltaE[e], count[f] += seams_[e].samples;
  out.faceError.assign(nf, -1.f);
  for (int f = 0; f < nf; ++f)
    if (count[f] > 0) out.faceError[f] = float(sum[f] / count[f]);
  out.measureSeconds += secondsSince(t);
  out.seconds = secondsSince(start);
  job_.progress(StageId::Seams, 1.0);
  return out;
}

}  // namespace

SeamResult optimiseSeams(const SeamInput& input, const SeamOptions& options, const JobControl& job) {
  TM_CHECK(input.mesh && input.map, "seams: no mesh or no texture map");
  SeamOptimiser optimiser(input, options, job);
  return optimiser.run();
}

}  // namespace montage
