// Coarse map (section 3.2) and coarse-to-fine map construction (section 4.1).
//
// Choices, beyond what the paper says:
// - Frames: photos are y-down, so a face seen by a camera is clockwise in pixels. Every orientation,
//   stretch and kernel computation works in the flipped frame (x, -y); UVs are stored in it and
//   flipped back (exactly: a negation) on output.
// - Photo of a base triangle mappable in several photos: the smallest L-infinity stretch of the
//   base triangle (Sander et al. 2001), i.e. the most frontal view.
// - A vertex on the border of its photo's region (a path paired with a curve, one side mapped to
//   that photo) slides along the curve: it is placed on the line through its two path neighbours
//   and searched along it only. Otherwise an L-infinity optimum with a free border pushes the
//   border outwards (bigger texture triangles, smaller stretch) until the background stops it.
//   When no foreground point exists on the curve, the vertex may leave it as a last resort.
// - Line search: each search spans the whole chord of the kernel through the vertex (both sides),
//   its random direction is drawn uniformly and then shaped by the ring's covariance (thin kernels
//   are searched along their long axis), and rounds of options.lineSearches searches repeat while
//   a round lowers the energy by more than 0.1% (at most 8 rounds). Half-edge collapses leave long,
//   thin fans (whole grid rows collapsed into one vertex); with one round of 8 plain one-sided
//   searches the errors there cascade through the following splits (flat grid with a background
//   stripe: mean stretch 0.3-0.6 instead of 0.103).

#include "mapping/fine_map.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>

#include "base/job.h"
#include "geometry/predicates.h"
#include "geometry/stretch.h"
#include "io/scene.h"
#include "mapping/partition.h"
#include "mapping/simplify.h"

namespace montage {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kMargin = 1e-6;  // relative margin kept from the kernel border along a search line
// Rounds of line searches per vertex optimisation: another round follows while the last one lowered
// the energy by more than kRoundGain (relative), as Sander et al. iterate until convergence.
constexpr int kMaxRounds = 8;
constexpr double kRoundGain = 1e-3;

// All texture positions below live in the flipped frame (x, -y) of the photo's pixels, in which a
// face seen by a camera is counter-clockwise like on the mesh (orient2 > 0).
Vec2 flipY(const Vec2& p) {
  return Vec2(p.x(), -p.y());
}

// One UV of a vertex: the photo and the position in the flipped frame. A vertex on a boundary
// between patches of different photos holds one per photo (section 4.1, third category).
struct PhotoUV {
  int photo;
  Vec2 uv;
};

// The faces around a vertex that are mapped to one photo, ready for energy evaluations: for each
// face the 3D corners (the vertex first) and the texture positions of the two other corners, in
// counter-clockwise order. When these faces do not close around the vertex (it lies on the border
// of the photo's region, i.e. on a path paired with a curve of that photo), the vertex slides along
// the line through its two border neighbours: that line is the curve.
struct Fan {
  std::vector<std::array<Vec3, 3>> q;
  std::vector<std::pair<Vec2, Vec2>> ab;
  bool complete = true;   // every corner has a UV in the photo
  bool open = false;      // the faces do not close around the vertex
  bool usable = true;     // a closed fan, or an open one with exactly two border neighbours
  Vec2 lineFrom, lineTo;  // open fan: UVs of the two border neighbours
  double scale = 0;       // largest distance from the vertex to a fan corner (for unbounded kernels)
  Eigen::Matrix2d shape = Eigen::Matrix2d::Identity();  // square root of the ring's covariance
};

class FineMapper {
 public:
  FineMapper(const Scene& scene, const Partition& partition, ProgressiveMesh& pm, const FineMapOptions& options,
             const JobControl& job, const BoundaryEnergy& boundaryEnergy)
      : scene_(scene),
        partition_(partition),
        pm_(pm),
        options_(options),
        job_(job),
        boundaryEnergy_(boundaryEnergy),
        rng_(options.seed) {}

  TextureMap run(FineMapStats& stats);

 private:
  // Section 3.2: base faces -> photos, feature vertices -> clicks.
  void coarseMap(TextureMap& map, FineMapStats& stats);
  // Section 4.1: initial UV of a reinserted vertex from its stored barycentric coordinates.
  void insertVertex(const CollapseRecord& r, FineMapStats& stats);
  // Random line search on every photo of a vertex.
  void optimiseVertex(int v);
  void optimiseVertexInPhoto(int v, int photo);

  int facePhoto(int f) const { return cellPhoto_[partition_.faceCell[f]]; }
  const Vec2* uvOf(int v, int photo) const {
    for (const PhotoUV& e : uvs_[v])
      if (e.photo == photo) return &e.uv;
    return nullptr;
  }
  void setUV(int v, int photo, const Vec2& uv) {
    for (PhotoUV& e : uvs_[v])
      if (e.photo == photo) {
        e.uv = uv;
        return;
      }
    uvs_[v].push_back({photo, uv});
  }
  // The click of feature vertex v in a photo, or nullptr.
  const PhotoPoint* click(int v, int photo) const;

  Fan buildFan(int v, int photo) const;
  double energy(int v, int photo, const Fan& fan, const Vec2& x) const;
  bool onForeground(int photo, const Vec2& x) const;
  bool feasible(const Fan& fan, const Vec2& x) const;
  double maxStep(const Fan& fan, const Vec2& x, const Vec2& d) const;
  bool kernelCentroid(const Fan& fan, bool alongCurve, Vec2& centroid) const;
  bool leaveBackground(int v, int photo, const Fan& fan, bool alongLine, Vec2& x, double& e);
  void searchLine(int v, int photo, const Fan& fan, const Vec2& d, Vec2& x, double& e);
  Vec2 randomDirection(const Fan& fan);

  // Max and mean L-infinity stretch over mapped faces whose corners all have UVs; counts flips.
  void measure(double& maxGamma, double& meanGamma, int& flipped) const;

  const Scene& scene_;
  const Partition& partition_;
  ProgressiveMesh& pm_;
  const FineMapOptions& options_;
  const JobControl& job_;
  const BoundaryEnergy& boundaryEnergy_;
  std::mt19937 rng_;

  std::vector<int> cellPhoto_;
  std::vector<char> isFeature_;
  std::vector<std::vector<int>> vertexPoints_;  // per vertex: indices into Project::points
  std::vector<std::vector<PhotoUV>> uvs_;
  std::vector<char> optimised_;
  int stuckOnBackground_ = 0;
};

const PhotoPoint* FineMapper::click(int v, int photo) const {
  for (int i : vertexPoints_[v])
    for (const PhotoPoint& at : scene_.project.points[i].at)
      if (at.photo == photo) return &at;
  return nullptr;
}

void FineMapper::coarseMap(TextureMap& map, FineMapStats& stats) {
  const Mesh& mesh = partition_.mesh;
  int nonFeature = 0, notPath = 0, noPhoto = 0, cellConflicts = 0;
  for (int f = 0; f < pm_.numFaces(); ++f) {
    if (!pm_.faceAlive(f)) continue;
    ++stats.baseFaces;
    const std::array<int, 3>& c = pm_.face(f);
    if (!isFeature_[c[0]] || !isFeature_[c[1]] || !isFeature_[c[2]]) {
      ++nonFeature;
      continue;
    }
    // The photos in which all three edges (paths) have a curve.
    std::vector<int> photos;
    bool allPaths = true;
    for (int k = 0; k < 3 && allPaths; ++k) {
      const int path = pm_.pathOfEdge(c[k], c[(k + 1) % 3]);
      if (path < 0) {
        allPaths = false;
        break;
      }
      std::vector<int> curvePhotos;
      for (const Curve& curve : partition_.paths[path].curves) curvePhotos.push_back(curve.photo);
      std::sort(curvePhotos.begin(), curvePhotos.end());
      curvePhotos.erase(std::unique(curvePhotos.begin(), curvePhotos.end()), curvePhotos.end());
      if (k == 0) {
        photos = curvePhotos;
      } else {
        std::vector<int> common;
        std::set_intersection(photos.begin(), photos.end(), curvePhotos.begin(), curvePhotos.end(),
                              std::back_inserter(common));
        photos.swap(common);
      }
    }
    if (!allPaths) {
      ++notPath;
      continue;
    }
    // Among the photos whose texture triangle keeps the face's orientation, the most frontal view:
    // the smallest L-infinity stretch of the base triangle (Sander et al. 2001).
    const std::array<Vec3, 3> q = {mesh.position(c[0]), mesh.position(c[1]), mesh.position(c[2])};
    int best = TextureMap::kEmpty;
    double bestGamma = kInf;
    for (int p : photos) {
      const PhotoPoint *a = click(c[0], p), *b = click(c[1], p), *d = click(c[2], p);
      if (!a || !b || !d) continue;
      const std::array<Vec2, 3> uv = {flipY(Vec2(a->x, a->y)), flipY(Vec2(b->x, b->y)), flipY(Vec2(d->x, d->y))};
      const TriangleStretch s = triangleStretch(q, uv);
      if (s.flipped || !std::isfinite(s.gamma)) continue;
      if (s.gamma < bestGamma) bestGamma = s.gamma, best = p;
    }
    if (best == TextureMap::kEmpty) {
      ++noPhoto;
      continue;
    }
    int& cell = cellPhoto_[partition_.faceCell[f]];
    if (cell != TextureMap::kEmpty && cell != best) {
      ++cellConflicts;  // cannot happen when a mapped base face is a whole cell; keep the first
      continue;
    }
    cell = best;
    ++stats.baseMappedFaces;
    for (int v : c) {
      const PhotoPoint* at = click(v, best);
      setUV(v, best, flipY(Vec2(at->x, at->y)));
    }
  }
  if (nonFeature > 0) map.notes.push_back(std::to_string(nonFeature) + " base faces have a non-feature vertex");
  if (notPath > 0) map.notes.push_back(std::to_string(notPath) + " base faces have an edge that is not a path");
  if (noPhoto > 0)
    map.notes.push_back(std::to_string(noPhoto) + " base faces have no common photo / flipped texture triangle");
  if (cellConflicts > 0)
    map.notes.push_back(std::to_string(cellConflicts) + " base faces share a cell with another mapped base face");
}

Fan FineMapper::buildFan(int v, int photo) const {
  Fan fan;
  const Mesh& mesh = partition_.mesh;
  const Vec2* self = uvOf(v, photo);
  // Per neighbour: +1 when it follows v in a face, -1 when it precedes v. A closed fan sums to 0.
  std::vector<std::pair<int, int>> count;
  auto bump = [&count](int w, int delta) {
    for (auto& e : count)
      if (e.first == w) {
        e.second += delta;
        return;
      }
    count.emplace_back(w, delta);
  };
  for (int f : pm_.vertexFaces(v)) {
    if (facePhoto(f) != photo) continue;
    const std::array<int, 3>& c = pm_.face(f);
    const int k = c[0] == v ? 0 : (c[1] == v ? 1 : 2);
    const int a = c[(k + 1) % 3], b = c[(k + 2) % 3];
    const Vec2 *ua = uvOf(a, photo), *ub = uvOf(b, photo);
    if (!ua || !ub) {
      fan.complete = false;
      continue;
    }
    fan.q.push_back({mesh.position(v), mesh.position(a), mesh.position(b)});
    fan.ab.emplace_back(*ua, *ub);
    if (self) fan.scale = std::max({fan.scale, (*ua - *self).norm(), (*ub - *self).norm()});
    bump(a, +1);
    bump(b, -1);
  }
  if (!fan.ab.empty()) {
    Vec2 mean = Vec2::Zero();
    for (const auto& [a, b] : fan.ab) mean += a + b;
    mean /= 2.0 * fan.ab.size();
    Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
    for (const auto& [a, b] : fan.ab) cov += (a - mean) * (a - mean).transpose() + (b - mean) * (b - mean).transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(cov);
    const Vec2 sd = eig.eigenvalues().cwiseMax(1e-12 * std::max(eig.eigenvalues().maxCoeff(), 1e-300)).cwiseSqrt();
    fan.shape = eig.eigenvectors() * sd.asDiagonal() * eig.eigenvectors().transpose();
  }
  int start = -1, end = -1, loose = 0;
  for (const auto& [w, n] : count) {
    if (n == 0) continue;
    ++loose;
    if (n == 1) start = w;  // v -> w is a border edge of the fan
    if (n == -1) end = w;
  }
  if (loose > 0) {
    fan.open = true;
    fan.usable = loose == 2 && start >= 0 && end >= 0;
    if (fan.usable) fan.lineFrom = *uvOf(start, photo), fan.lineTo = *uvOf(end, photo);
  }
  return fan;
}

double FineMapper::energy(int v, int photo, const Fan& fan, const Vec2& x) const {
  double gamma = 0;
  for (size_t i = 0; i < fan.q.size(); ++i) {
    const TriangleStretch s = triangleStretch(fan.q[i], {x, fan.ab[i].first, fan.ab[i].second});
    gamma = std::max(gamma, s.gamma);
    if (!std::isfinite(gamma)) return kInf;
  }
  // Section 4.2 plugs in here: a vertex mapped into two photos minimises E_boundary on each side.
  if (boundaryEnergy_ && uvs_[v].size() >= 2) return boundaryEnergy_(v, photo, flipY(x), gamma);
  return gamma;
}

// Section 4.1's background restriction: no vertex lands where the photo's alpha is zero.
bool FineMapper::onForeground(int photo, const Vec2& x) const {
  const Photo& ph = *scene_.photos[photo];
  const Vec2 pixel = flipY(x);
  if (ph.alpha.empty()) return ph.inside(pixel.x(), pixel.y());
  return ph.isForeground(pixel.x(), pixel.y());
}

bool FineMapper::feasible(const Fan& fan, const Vec2& x) const {
  for (const auto& [a, b] : fan.ab)
    if (!(orient2(x, a, b) > 0)) return false;
  return true;
}

// The largest step t along d from x (feasible) that flips no face: orient2(x + t d, a, b) is linear
// in t, so each ring edge bounds t analytically. Open fans without a bound are capped at the fan size.
double FineMapper::maxStep(const Fan& fan, const Vec2& x, const Vec2& d) const {
  double t = kInf;
  for (const auto& [a, b] : fan.ab) {
    const double g0 = orient2(x, a, b);
    const double dg = (b - a).x() * d.y() - (b - a).y() * d.x();  // d/dt orient2(x + t d, a, b)
    if (dg < 0) t = std::min(t, g0 / -dg);
  }
  if (!std::isfinite(t)) t = 2 * fan.scale / std::max(d.norm(), 1e-300);
  return std::max(0.0, t * (1 - kMargin));
}

// Section 4.1 after Sander et al. 2002, for a flipping initial position: the centroid of the kernel
// of the one-ring polygon, i.e. of the intersection of the half-planes of the ring edges (alongCurve:
// of its part of an open fan's curve segment). False when the kernel is empty.
bool FineMapper::kernelCentroid(const Fan& fan, bool alongCurve, Vec2& centroid) const {
  if (fan.ab.empty()) return false;
  if (alongCurve) {
    // Interval of s in (0, 1) on lineFrom + s (lineTo - lineFrom) where every face stays positive.
    const Vec2 d = fan.lineTo - fan.lineFrom;
    double lo = 0, hi = 1;
    for (const auto& [a, b] : fan.ab) {
      const double g0 = orient2(fan.lineFrom, a, b);
      const double dg = (b - a).x() * d.y() - (b - a).y() * d.x();
      if (dg > 0)
        lo = std::max(lo, -g0 / dg);
      else if (dg < 0)
        hi = std::min(hi, g0 / -dg);
      else if (!(g0 > 0))
        return false;
    }
    if (!(lo < hi)) return false;
    centroid = fan.lineFrom + 0.5 * (lo + hi) * d;
    return true;
  }
  // Convex clipping of a box around the ring by each half-plane orient2(x, a, b) >= 0.
  Vec2 lo(kInf, kInf), hi(-kInf, -kInf);
  for (const auto& [a, b] : fan.ab) {
    lo = lo.cwiseMin(a).cwiseMin(b);
    hi = hi.cwiseMax(a).cwiseMax(b);
  }
  const Vec2 pad = (hi - lo) + Vec2(1, 1);
  lo -= pad;
  hi += pad;
  std::vector<Vec2> poly = {lo, Vec2(hi.x(), lo.y()), hi, Vec2(lo.x(), hi.y())}, next;
  for (const auto& [a, b] : fan.ab) {
    next.clear();
    for (size_t i = 0; i < poly.size(); ++i) {
      const Vec2& p = poly[i];
      const Vec2& q = poly[(i + 1) % poly.size()];
      const double gp = orient2(p, a, b), gq = orient2(q, a, b);
      if (gp >= 0) next.push_back(p);
      if ((gp >= 0) != (gq >= 0)) next.push_back(p + (gp / (gp - gq)) * (q - p));
    }
    poly.swap(next);
    if (poly.size() < 3) return false;
  }
  double area = 0;
  Vec2 c = Vec2::Zero();
  for (size_t i = 0; i < poly.size(); ++i) {
    const Vec2& p = poly[i];
    const Vec2& q = poly[(i + 1) % poly.size()];
    const double w = p.x() * q.y() - q.x() * p.y();
    area += w;
    c += w * (p + q);
  }
  if (!(area > 0)) return false;
  centroid = c / (3 * area);
  return true;
}

// Samples rays from x through the kernel (along the curve only, or in all directions) for the
// foreground point of lowest energy; moves x there. False when every sample is on the background.
bool FineMapper::leaveBackground(int v, int photo, const Fan& fan, bool alongLine, Vec2& x, double& e) {
  const int directions = alongLine ? 2 : std::max(16, 2 * options_.lineSearches);
  const int samples = alongLine ? 64 : 24;
  const double offset = std::uniform_real_distribution<double>(0, 2 * M_PI)(rng_);
  double bestE = kInf;
  Vec2 best = x;
  for (int i = 0; i < directions; ++i) {
    Vec2 d;
    if (alongLine) {
      d = (fan.lineTo - fan.lineFrom).normalized() * (i == 0 ? 1.0 : -1.0);
    } else {
      const double angle = offset + 2 * M_PI * i / directions;
      d = Vec2(std::cos(angle), std::sin(angle));
    }
    const double tmax = maxStep(fan, x, d);
    for (int j = 1; j <= samples; ++j) {
      const Vec2 y = x + (tmax * j / (samples + 1)) * d;
      if (!onForeground(photo, y)) continue;
      const double ey = energy(v, photo, fan, y);
      if (ey < bestE) bestE = ey, best = y;
    }
  }
  if (!(bestE < kInf)) return false;
  x = best;
  e = bestE;
  return true;
}

Vec2 FineMapper::randomDirection(const Fan& fan) {
  if (fan.open) {
    const Vec2 d = (fan.lineTo - fan.lineFrom).normalized();
    return (rng_() & 1u) ? d : Vec2(-d);
  }
  const double angle = std::uniform_real_distribution<double>(0, 2 * M_PI)(rng_);
  return (fan.shape * Vec2(std::cos(angle), std::sin(angle))).normalized();
}

void FineMapper::insertVertex(const CollapseRecord& r, FineMapStats& stats) {
  const int v = r.removed;
  const int n = static_cast<int>(r.ring.size());
  std::vector<int> photos;
  for (int f : pm_.vertexFaces(v)) {
    const int p = facePhoto(f);
    if (p != TextureMap::kEmpty && std::find(photos.begin(), photos.end(), p) == photos.end()) photos.push_back(p);
  }
  for (int p : photos) {
    // Which sides of the vertex's path the photo's faces lie on: face (v, ring[k], ring[k+1]) is
    // on the left when k runs from pathA to pathB (the left sub-polygon ring[pathA..pathB]).
    bool left = false, right = false;
    if (r.pathA >= 0 && n > 0) {
      const int span = ((r.pathB - r.pathA) % n + n) % n;
      for (int f : pm_.vertexFaces(v)) {
        if (facePhoto(f) != p) continue;
        const std::array<int, 3>& c = pm_.face(f);
        const int kv = c[0] == v ? 0 : (c[1] == v ? 1 : 2);
        const int a = c[(kv + 1) % 3];
        const int k = static_cast<int>(std::find(r.ring.begin(), r.ring.end(), a) - r.ring.begin());
        if (k >= n) continue;
        ((((k - r.pathA) % n + n) % n) < span ? left : right) = true;
      }
    }
    // Equation (1), over the sub-polygon of the photo's side for a vertex on a path (section 4.2).
    const std::vector<double>* weights = &r.weights;
    int first = 0;
    if (left && !right && !r.left.empty()) weights = &r.left, first = r.pathA;
    if (right && !left && !r.right.empty()) weights = &r.right, first = r.pathB;
    if (static_cast<int>(weights->size()) > n || weights->empty()) weights = nullptr;
    Vec2 sum = Vec2::Zero(), plain = Vec2::Zero();
    double total = 0;
    int used = 0;
    for (int i = 0; i < n; ++i) {
      const int k = weights ? (first + i) % n : i;
      if (weights && i >= static_cast<int>(weights->size())) break;
      const Vec2* uv = uvOf(r.ring[k], p);
      if (!uv) continue;
      const double w = weights ? (*weights)[i] : 1.0;
      sum += w * *uv;
      plain += *uv;
      total += w;
      ++used;
    }
    if (used == 0) continue;
    const Vec2* kept = uvOf(r.kept, p);
    Vec2 x = std::abs(total) > 1e-12 ? Vec2(sum / total) : kept ? *kept : Vec2(plain / used);
    setUV(v, p, x);
    const Fan fan = buildFan(v, p);
    if (fan.open && fan.usable) {
      // A vertex on its photo region's border stays on the curve between its path neighbours.
      const Vec2 d = fan.lineTo - fan.lineFrom;
      const double len2 = d.squaredNorm();
      const double s = len2 > 0 ? std::clamp((x - fan.lineFrom).dot(d) / len2, 0.0, 1.0) : 0.5;
      x = fan.lineFrom + s * d;
    }
    if (!feasible(fan, x)) {
      // A vertex whose curve crosses no point of the kernel (e.g. a face with three corners on the
      // path) leaves the curve rather than flip a face.
      Vec2 c;
      const bool onCurve = fan.open && fan.usable;
      if (kernelCentroid(fan, onCurve, c) || (onCurve && kernelCentroid(fan, false, c))) x = c;
      ++stats.centroidFallbacks;
    }
    setUV(v, p, x);
  }
}

void FineMapper::optimiseVertex(int v) {
  if (isFeature_[v] || uvs_[v].empty()) return;
  // Category 3 (two photos): each photo's UV separately, with that photo's faces.
  for (size_t i = 0; i < uvs_[v].size(); ++i) optimiseVertexInPhoto(v, uvs_[v][i].photo);
  optimised_[v] = 1;
}

// Sander et al. 2001 random line search, restricted to the kernel (no flip) and to the foreground.
// Rounds of options.lineSearches searches are repeated while they still gain (see kMaxRounds).
void FineMapper::optimiseVertexInPhoto(int v, int photo) {
  const Fan fan = buildFan(v, photo);
  if (!fan.complete || !fan.usable || fan.ab.empty()) return;
  Vec2 x = *uvOf(v, photo);
  if (!feasible(fan, x)) return;
  double e = energy(v, photo, fan, x);
  if (!onForeground(photo, x)) {
    // On the background (the initial position, or a curve crossing the background): move to the
    // best foreground point of the kernel, whatever its energy; as a last resort off the curve.
    if (!leaveBackground(v, photo, fan, fan.open, x, e) && !(fan.open && leaveBackground(v, photo, fan, false, x, e)))
      return;  // no foreground point in the kernel: counted at the end
  }
  for (int round = 0; round < kMaxRounds; ++round) {
    const double before = e;
    for (int s = 0; s < options_.lineSearches; ++s) searchLine(v, photo, fan, randomDirection(fan), x, e);
    if (!(e < before * (1 - kRoundGain))) break;
  }
  setUV(v, photo, x);
}

// One line search: golden-section minimisation of the energy over the chord of the kernel through x
// along d (Sander's stretch is quasi-convex along a line inside the kernel); x moves only when the
// minimum is an improvement on the foreground.
void FineMapper::searchLine(int v, int photo, const Fan& fan, const Vec2& d, Vec2& x, double& e) {
  constexpr double kGolden = 0.6180339887498949;
  double a = -maxStep(fan, x, -d), b = maxStep(fan, x, d);
  if (!(b > a)) return;
  auto f = [&](double t) { return energy(v, photo, fan, x + t * d); };
  double c = b - kGolden * (b - a), m = a + kGolden * (b - a);
  double fc = f(c), fm = f(m);
  for (int k = 0; k < options_.searchSteps; ++k) {
    if (fc < fm) {
      b = m, m = c, fm = fc;
      c = b - kGolden * (b - a);
      fc = f(c);
    } else {
      a = c, c = m, fc = fm;
      m = a + kGolden * (b - a);
      fm = f(m);
    }
  }
  double t = fc < fm ? c : m, et = std::min(fc, fm);
  // Background restriction: a candidate on the background is pulled back towards x.
  for (int k = 0; k < 4 && et < e && !onForeground(photo, x + t * d); ++k) {
    t *= 0.5;
    et = f(t);
  }
  if (et < e && onForeground(photo, x + t * d)) {
    x += t * d;
    e = et;
  }
}

void FineMapper::measure(double& maxGamma, double& meanGamma, int& flipped) const {
  maxGamma = meanGamma = 0;
  flipped = 0;
  int count = 0;
  for (int f = 0; f < pm_.numFaces(); ++f) {
    if (!pm_.faceAlive(f)) continue;
    const int p = facePhoto(f);
    if (p == TextureMap::kEmpty) continue;
    const std::array<int, 3>& c = pm_.face(f);
    const Vec2 *a = uvOf(c[0], p), *b = uvOf(c[1], p), *d = uvOf(c[2], p);
    if (!a || !b || !d) continue;
    const TriangleStretch s = triangleStretch(
        {partition_.mesh.position(c[0]), partition_.mesh.position(c[1]), partition_.mesh.position(c[2])}, {*a, *b, *d});
    if (s.flipped) {
      ++flipped;
      continue;
    }
    maxGamma = std::max(maxGamma, s.gamma);
    meanGamma += s.gamma;
    ++count;
  }
  if (count > 0) meanGamma /= count;
}

TextureMap FineMapper::run(FineMapStats& stats) {
  const Mesh& mesh = partition_.mesh;
  TM_CHECK(pm_.atBase(), "coarseToFine: the progressive mesh must be at its base level");
  TM_CHECK(static_cast<int>(partition_.faceCell.size()) == pm_.numFaces() && pm_.numFaces() == mesh.numFaces() &&
               pm_.numVertices() == mesh.numVertices(),
           "coarseToFine: the progressive mesh does not match the partition's mesh");
  const int numV = mesh.numVertices();
  cellPhoto_.assign(std::max(partition_.numCells, 0), TextureMap::kEmpty);
  for (int c : partition_.faceCell) TM_ASSERT(c >= 0 && c < partition_.numCells);
  isFeature_.assign(numV, 0);
  vertexPoints_.assign(numV, {});
  for (size_t i = 0; i < partition_.featureVertex.size(); ++i) {
    const int v = partition_.featureVertex[i];
    if (v < 0 || v >= numV || i >= scene_.project.points.size()) continue;
    isFeature_[v] = 1;
    vertexPoints_[v].push_back(static_cast<int>(i));
  }
  uvs_.assign(numV, {});
  optimised_.assign(numV, 0);

  TextureMap map = TextureMap::allEmpty(mesh.numFaces());
  coarseMap(map, stats);

  // Section 4: replay the vertex splits (Schreiner et al. 2004 order): place the inserted vertex,
  // optimise it, then each of its one-ring neighbours once.
  const int total = static_cast<int>(pm_.records().size());
  job_.progress(StageId::Map, 0.0, "coarse-to-fine");
  while (!pm_.atFull()) {
    const CollapseRecord& r = pm_.split();
    ++stats.splits;
    insertVertex(r, stats);
    optimiseVertex(r.removed);
    for (int w : r.ring) optimiseVertex(w);
    if (stats.splits % 256 == 0) job_.progress(StageId::Map, 0.9 * stats.splits / std::max(total, 1), "coarse-to-fine");
  }

  // Final sweeps at full resolution, in a seeded random order.
  std::vector<int> order;
  for (int v = 0; v < numV; ++v)
    if (!isFeature_[v] && !uvs_[v].empty()) order.push_back(v);
  for (int sweep = 0; sweep < options_.finalSweeps; ++sweep) {
    job_.progress(StageId::Map, 0.9 + 0.1 * sweep / options_.finalSweeps, "coarse-to-fine: final sweep");
    std::shuffle(order.begin(), order.end(), rng_);
    for (int v : order) optimiseVertex(v);
  }

  // Output over Partition::mesh's faces, pixel coordinates (y down).
  int missing = 0;
  for (int f = 0; f < mesh.numFaces(); ++f) {
    map.facePatch[f] = partition_.faceCell[f];
    const int p = facePhoto(f);
    if (p == TextureMap::kEmpty) continue;
    const std::array<int, 3> c = mesh.faceVertices(f);
    const Vec2 *a = uvOf(c[0], p), *b = uvOf(c[1], p), *d = uvOf(c[2], p);
    if (!a || !b || !d) {
      ++missing;
      continue;
    }
    map.facePhoto[f] = p;
    map.cornerUV[f] = {flipY(*a), flipY(*b), flipY(*d)};
  }
  if (missing > 0)
    map.notes.push_back(std::to_string(missing) +
                        " faces of mapped cells left empty: a corner got no texture coordinate");

  double meanGamma = 0;
  measure(stats.maxStretch, meanGamma, stats.flippedFaces);
  if (stats.flippedFaces > 0)
    map.notes.push_back(std::to_string(stats.flippedFaces) + " mapped faces are flipped in their photo");
  for (int v = 0; v < numV; ++v) {
    if (!isFeature_[v] && !uvs_[v].empty()) stats.optimisedVertices += optimised_[v];
    for (const PhotoUV& e : uvs_[v])
      if (!isFeature_[v] && !onForeground(e.photo, e.uv)) ++stuckOnBackground_;
  }
  if (stuckOnBackground_ > 0)
    map.notes.push_back(std::to_string(stuckOnBackground_) +
                        " texture coordinates could not leave the photo background");
  job_.progress(StageId::Map, 1.0, "coarse-to-fine");
  return map;
}

}  // namespace

TextureMap coarseToFine(const Scene& scene, const Partition& partition, ProgressiveMesh& pm,
                        const FineMapOptions& options, const JobControl& job, FineMapStats* stats,
                        const BoundaryEnergy& boundaryEnergy) {
  FineMapStats local;
  FineMapper mapper(scene, partition, pm, options, job, boundaryEnergy);
  TextureMap map = mapper.run(local);
  if (stats) *stats = local;
  return map;
}

}  // namespace montage
