// Coarse map (section 3.2) and coarse-to-fine map construction (section 4.1) of one cell.
//
// Choices, beyond what the paper says:
// - Frames: photos are y-down, so a face seen by a camera is clockwise in pixels. Every orientation,
//   stretch and kernel computation works in the flipped frame (x, -y); UVs are flipped back (exactly:
//   a negation) on output.
// - The cell's boundary is fixed (cells.h), so the progressive mesh never removes a boundary vertex.
//   Where no legal collapse removes an inner vertex (link condition, normal turn, a shortcut between
//   two vertices of one side), it stays at the base and is placed by a Tutte embedding with mean value
//   weights inside the boundary, which is a convex polygon: the texture triangle. Tutte's theorem
//   (Floater 2003) makes that embedding flip-free as long as no inner edge joins two vertices of one
//   side; such an edge is reported as the cell's failure. Mean value weights reproduce a flat mesh's
//   affine map exactly, so the splits that follow start from the right place.
// - Line search: each search spans the whole chord of the kernel through the vertex (both sides),
//   its random direction is drawn uniformly and then shaped by the ring's covariance (thin kernels
//   are searched along their long axis), and rounds of options.lineSearches searches repeat while
//   a round lowers the energy by more than 0.1% (at most 8 rounds).
// - The energy is evaluated in closed form: a face's stretch is a ratio of quadratics in the moving
//   corner, whose coefficients are computed once per optimisation (FanFace).

#include "mapping/fine_map.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Sparse>
#include <Eigen/SparseLU>
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <random>

#include "base/job.h"
#include "geometry/lscm.h"
#include "geometry/predicates.h"
#include "geometry/stretch.h"
#include "image/photo.h"
#include "mapping/simplify.h"

namespace montage {

void FineMapStats::add(const FineMapStats& o) {
  baseFaces += o.baseFaces;
  baseMappedFaces += o.baseMappedFaces;
  splits += o.splits;
  centroidFallbacks += o.centroidFallbacks;
  optimisedVertices += o.optimisedVertices;
  baseInnerVertices += o.baseInnerVertices;
  flippedFaces += o.flippedFaces;
  onBackground += o.onBackground;
  maxStretch = std::max(maxStretch, o.maxStretch);
}

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kMargin = 1e-6;  // relative margin kept from the kernel border along a search line
// Rounds of line searches per vertex optimisation: another round follows while the last one lowered
// the energy by more than kRoundGain (relative), as Sander et al. iterate until convergence.
constexpr int kMaxRounds = 8;
constexpr double kRoundGain = 1e-3;

Vec2 flipY(const Vec2& p) {
  return Vec2(p.x(), -p.y());
}

// One face (v, a, b) around a moving vertex v, counter-clockwise, with a and b fixed. With x = (s, t)
// the position of v, Sander's Jacobian columns times twice the texture area are P + t D and Q - s D
// (D = q_b - q_a), and twice the area is K + alpha s + beta t: the stretch is a ratio of quadratics
// in x whose coefficients are the dot products below.
struct FanFace {
  Vec2 a, b;  // texture positions of the two other corners (flipped frame)
  double pp, pd, dd, qq, qd, pq, k, alpha, beta;

  FanFace(const Vec3& qv, const Vec3& qa, const Vec3& qb, const Vec2& ua, const Vec2& ub) : a(ua), b(ub) {
    const double s2 = ua.x(), t2 = ua.y(), s3 = ub.x(), t3 = ub.y();
    const Vec3 d = qb - qa;
    const Vec3 p = qv * (t2 - t3) + qa * t3 - qb * t2;
    const Vec3 q = qv * (s3 - s2) - qa * s3 + qb * s2;
    pp = p.dot(p), pd = p.dot(d), dd = d.dot(d), qq = q.dot(q), qd = q.dot(d), pq = p.dot(q);
    k = s2 * t3 - s3 * t2, alpha = t2 - t3, beta = s3 - s2;
  }
  double twiceArea(const Vec2& x) const { return k + alpha * x.x() + beta * x.y(); }
  // d/dt of twiceArea(x + t d).
  double areaRate(const Vec2& d) const { return alpha * d.x() + beta * d.y(); }
  // Squared largest singular value, +inf when flipped or degenerate.
  double gamma2(const Vec2& x) const {
    const double area = twiceArea(x);
    if (!(area > 0)) return kInf;
    const double s = x.x(), t = x.y();
    const double inv = 1 / (area * area);
    const double ea = (pp + t * (2 * pd + t * dd)) * inv;
    const double ec = (qq + s * (-2 * qd + s * dd)) * inv;
    const double eb = (pq - s * pd + t * qd - s * t * dd) * inv;
    const double diff = ea - ec;
    return 0.5 * (ea + ec + std::sqrt(diff * diff + 4 * eb * eb));
  }
};

// The faces around a free vertex, ready for energy evaluations.
struct Fan {
  std::vector<FanFace> faces;
  Eigen::Matrix2d shape = Eigen::Matrix2d::Identity();  // square root of the ring's covariance
  double scale = 0;                                     // largest distance from the vertex to a ring corner
};

class CellMapper {
 public:
  CellMapper(const CellProblem& problem, const Photo& photo, const FineMapOptions& options, const JobControl& job)
      : problem_(problem), photo_(photo), options_(options), job_(job) {
    std::seed_seq seq{options.seed, static_cast<unsigned>(std::hash<std::string>{}(problem.key)),
                      static_cast<unsigned>(problem.positions.size())};
    rng_.seed(seq);
  }

  CellMap run();

 private:
  bool embedBase();
  void insertVertex(const CollapseRecord& r);
  void optimise(int v);
  Fan buildFan(int v) const;
  double energy(const Fan& fan, const Vec2& x) const;
  bool onForeground(const Vec2& x) const {
    const Vec2 pixel = flipY(x);
    if (photo_.alpha.empty()) return photo_.inside(pixel.x(), pixel.y());
    return photo_.isForeground(pixel.x(), pixel.y());
  }
  static bool feasible(const Fan& fan, const Vec2& x);
  static double maxStep(const Fan& fan, const Vec2& x, const Vec2& d);
  static bool kernelCentroid(const Fan& fan, Vec2& centroid);
  bool leaveBackground(const Fan& fan, Vec2& x, double& e);
  void searchLine(const Fan& fan, const Vec2& d, Vec2& x, double& e);
  Vec2 randomDirection(const Fan& fan);

  const CellProblem& problem_;
  const Photo& photo_;
  const FineMapOptions& options_;
  const JobControl& job_;
  std::mt19937 rng_;
  std::unique_ptr<ProgressiveMesh> pm_;
  std::vector<Vec2> uv_;  // flipped frame
  std::vector<char> placed_;
  std::vector<char> optimised_;
  CellMap out_;
};

double CellMapper::energy(const Fan& fan, const Vec2& x) const {
  double g2 = 0;
  for (const FanFace& f : fan.faces) {
    g2 = std::max(g2, f.gamma2(x));
    if (g2 == kInf) return kInf;
  }
  return std::sqrt(g2);
}

bool CellMapper::feasible(const Fan& fan, const Vec2& x) {
  for (const FanFace& f : fan.faces)
    if (!(f.twiceArea(x) > 0)) return false;
  return true;
}

// The largest step t along d from x (feasible) that flips no face: the area is linear in t, so each
// face bounds t analytically.
double CellMapper::maxStep(const Fan& fan, const Vec2& x, const Vec2& d) {
  double t = kInf;
  for (const FanFace& f : fan.faces) {
    const double rate = f.areaRate(d);
    if (rate < 0) t = std::min(t, f.twiceArea(x) / -rate);
  }
  if (!std::isfinite(t)) t = 2 * fan.scale / std::max(d.norm(), 1e-300);
  return std::max(0.0, t * (1 - kMargin));
}

// Section 4.1 after Sander et al. 2002, for a flipping initial position: the centroid of the kernel
// of the one-ring polygon, the intersection of the half-planes of the ring edges. False when empty.
bool CellMapper::kernelCentroid(const Fan& fan, Vec2& centroid) {
  if (fan.faces.empty()) return false;
  Vec2 lo(kInf, kInf), hi(-kInf, -kInf);
  for (const FanFace& f : fan.faces) {
    lo = lo.cwiseMin(f.a).cwiseMin(f.b);
    hi = hi.cwiseMax(f.a).cwiseMax(f.b);
  }
  const Vec2 pad = (hi - lo) + Vec2(1, 1);
  lo -= pad;
  hi += pad;
  std::vector<Vec2> poly = {lo, Vec2(hi.x(), lo.y()), hi, Vec2(lo.x(), hi.y())}, next;
  for (const FanFace& f : fan.faces) {
    next.clear();
    for (size_t i = 0; i < poly.size(); ++i) {
      const Vec2& p = poly[i];
      const Vec2& q = poly[(i + 1) % poly.size()];
      const double gp = f.twiceArea(p), gq = f.twiceArea(q);
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

Fan CellMapper::buildFan(int v) const {
  Fan fan;
  const Vec3& qv = problem_.positions[v];
  for (int f : pm_->vertexFaces(v)) {
    const std::array<int, 3>& c = pm_->face(f);
    const int k = c[0] == v ? 0 : (c[1] == v ? 1 : 2);
    const int a = c[(k + 1) % 3], b = c[(k + 2) % 3];
    fan.faces.emplace_back(qv, problem_.positions[a], problem_.positions[b], uv_[a], uv_[b]);
    fan.scale = std::max({fan.scale, (uv_[a] - uv_[v]).norm(), (uv_[b] - uv_[v]).norm()});
  }
  if (!fan.faces.empty()) {
    Vec2 mean = Vec2::Zero();
    for (const FanFace& f : fan.faces) mean += f.a + f.b;
    mean /= 2.0 * fan.faces.size();
    Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
    for (const FanFace& f : fan.faces)
      cov += (f.a - mean) * (f.a - mean).transpose() + (f.b - mean) * (f.b - mean).transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(cov);
    const Vec2 sd = eig.eigenvalues().cwiseMax(1e-12 * std::max(eig.eigenvalues().maxCoeff(), 1e-300)).cwiseSqrt();
    fan.shape = eig.eigenvectors() * sd.asDiagonal() * eig.eigenvectors().transpose();
  }
  return fan;
}

// Samples rays from x through the kernel for the foreground point of lowest energy; moves x there.
// False when every sample is on the background.
bool CellMapper::leaveBackground(const Fan& fan, Vec2& x, double& e) {
  const int directions = std::max(16, 2 * options_.lineSearches);
  const int samples = 24;
  const double offset = std::uniform_real_distribution<double>(0, 2 * M_PI)(rng_);
  double bestE = kInf;
  Vec2 best = x;
  for (int i = 0; i < directions; ++i) {
    const double angle = offset + 2 * M_PI * i / directions;
    const Vec2 d(std::cos(angle), std::sin(angle));
    const double tmax = maxStep(fan, x, d);
    for (int j = 1; j <= samples; ++j) {
      const Vec2 y = x + (tmax * j / (samples + 1)) * d;
      if (!onForeground(y)) continue;
      const double ey = energy(fan, y);
      if (ey < bestE) bestE = ey, best = y;
    }
  }
  if (!(bestE < kInf)) return false;
  x = best;
  e = bestE;
  return true;
}

Vec2 CellMapper::randomDirection(const Fan& fan) {
  const double angle = std::uniform_real_distribution<double>(0, 2 * M_PI)(rng_);
  return (fan.shape * Vec2(std::cos(angle), std::sin(angle))).normalized();
}

// One line search: golden-section minimisation of the energy over the chord of the kernel through x
// along d (Sander's stretch is quasi-convex along a line inside the kernel); x moves only when the
// minimum is an improvement on the foreground.
void CellMapper::searchLine(const Fan& fan, const Vec2& d, Vec2& x, double& e) {
  constexpr double kGolden = 0.6180339887498949;
  double a = -maxStep(fan, x, -d), b = maxStep(fan, x, d);
  if (!(b > a)) return;
  auto f = [&](double t) { return energy(fan, x + t * d); };
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
  for (int k = 0; k < 4 && et < e && !onForeground(x + t * d); ++k) {
    t *= 0.5;
    et = f(t);
  }
  if (et < e && onForeground(x + t * d)) {
    x += t * d;
    e = et;
  }
}

// Sander et al. 2001 random line search, restricted to the kernel (no flip) and to the foreground.
void CellMapper::optimise(int v) {
  if (problem_.fixed[v] || !placed_[v] || options_.lineSearches <= 0) return;
  const Fan fan = buildFan(v);
  if (fan.faces.empty()) return;
  Vec2 x = uv_[v];
  if (!feasible(fan, x)) return;
  double e = energy(fan, x);
  // On the background (the initial position): move to the best foreground point of the kernel,
  // whatever its energy.
  if (!onForeground(x) && !leaveBackground(fan, x, e)) return;  // counted at the end
  for (int round = 0; round < kMaxRounds; ++round) {
    const double before = e;
    for (int s = 0; s < options_.lineSearches; ++s) searchLine(fan, randomDirection(fan), x, e);
    if (!(e < before * (1 - kRoundGain))) break;
  }
  uv_[v] = x;
  optimised_[v] = 1;
}

void CellMapper::insertVertex(const CollapseRecord& r) {
  const int v = r.removed;
  // Equation (1): the stored barycentric coordinates over the one-ring (closed: v is inner).
  Vec2 x = Vec2::Zero();
  double total = 0;
  for (size_t i = 0; i < r.ring.size() && i < r.weights.size(); ++i) {
    x += r.weights[i] * uv_[r.ring[i]];
    total += r.weights[i];
  }
  x = std::abs(total) > 1e-12 ? Vec2(x / total) : uv_[r.kept];
  uv_[v] = x;
  placed_[v] = 1;
  const Fan fan = buildFan(v);
  if (!feasible(fan, x)) {
    Vec2 c;
    if (kernelCentroid(fan, c)) uv_[v] = c;
    ++out_.stats.centroidFallbacks;
  }
}

// The base mesh. With its whole boundary fixed (a cell closed by paths): the free vertices by a Tutte embedding
// with mean value weights (Floater 2003): positive, so the embedding inside a convex boundary (a texture triangle)
// has no flip, and exact on flat meshes. With part of its boundary free (a run along the mesh border): the
// least-squares conformal map with the fixed vertices held (Levy et al. 2002), whose free border keeps its shape.
// A polygon that is not convex, or fixed inner features, may fold either: a few rounds move each free vertex of a
// folded face to the centroid of its kernel (Sander et al. 2002's fallback) before the base is given up.
bool CellMapper::embedBase() {
  const int n = static_cast<int>(problem_.positions.size());
  std::vector<int> unknown(n, -1);
  int count = 0;
  for (int v = 0; v < n; ++v)
    if (pm_->vertexAlive(v) && !pm_->vertexFaces(v).empty()) {
      if (problem_.fixed[v]) {
        uv_[v] = flipY(problem_.fixedUV[v]);
        placed_[v] = 1;
      } else {
        unknown[v] = count++;
      }
    }
  out_.stats.baseInnerVertices = count;
  // Free vertices on the base's boundary (edges of one alive face): the mesh border.
  std::map<std::pair<int, int>, int> edgeUse;
  for (int f = 0; f < pm_->numFaces(); ++f) {
    if (!pm_->faceAlive(f)) continue;
    const auto& c = pm_->face(f);
    for (int k = 0; k < 3; ++k) ++edgeUse[std::minmax(c[k], c[(k + 1) % 3])];
  }
  bool freeBorder = false;
  for (const auto& [e, uses] : edgeUse)
    if (uses == 1 && (!problem_.fixed[e.first] || !problem_.fixed[e.second])) freeBorder = true;
  if (count > 0 && freeBorder) {
    std::vector<std::array<int, 3>> faces;
    for (int f = 0; f < pm_->numFaces(); ++f)
      if (pm_->faceAlive(f)) faces.push_back(pm_->face(f));
    std::vector<std::pair<int, Vec2>> pins;
    for (int v = 0; v < n; ++v)
      if (unknown[v] < 0 && placed_[v]) pins.emplace_back(v, uv_[v]);
    if (pins.size() < 2) return false;
    const std::vector<Vec2> uv = lscm(problem_.positions, faces, pins);
    for (int v = 0; v < n; ++v)
      if (unknown[v] >= 0) uv_[v] = uv[v], placed_[v] = 1;
  } else if (count > 0) {
    // Mean value weights: each face (v, a, b) adds tan(angle at v / 2) / |q_w - q_v| to w = a, b.
    std::vector<Eigen::Triplet<double>> triplets;
    Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(count, 2);
    std::vector<std::pair<int, double>> weights;
    for (int v = 0; v < n; ++v) {
      if (unknown[v] < 0) continue;
      weights.clear();
      const Vec3& qv = problem_.positions[v];
      for (int f : pm_->vertexFaces(v)) {
        const auto& c = pm_->face(f);
        const int k = c[0] == v ? 0 : (c[1] == v ? 1 : 2);
        const int a = c[(k + 1) % 3], b = c[(k + 2) % 3];
        const Vec3 ea = problem_.positions[a] - qv, eb = problem_.positions[b] - qv;
        const double half = std::tan(0.5 * std::atan2(ea.cross(eb).norm(), ea.dot(eb)));
        for (const auto& [w, length] : {std::pair{a, ea.norm()}, std::pair{b, eb.norm()}}) {
          const double add = half / std::max(length, 1e-300);
          auto it = std::find_if(weights.begin(), weights.end(), [w = w](const auto& e) { return e.first == w; });
          if (it == weights.end())
            weights.emplace_back(w, add);
          else
            it->second += add;
        }
      }
      double total = 0;
      for (const auto& [w, weight] : weights) total += weight;
      if (!(total > 0) || !std::isfinite(total)) return false;
      triplets.emplace_back(unknown[v], unknown[v], 1.0);
      for (const auto& [w, weight] : weights) {
        if (unknown[w] >= 0)
          triplets.emplace_back(unknown[v], unknown[w], -weight / total);
        else
          rhs.row(unknown[v]) += (weight / total) * uv_[w].transpose();
      }
    }
    Eigen::SparseMatrix<double> system(count, count);
    system.setFromTriplets(triplets.begin(), triplets.end());
    Eigen::SparseLU<Eigen::SparseMatrix<double>> solver(system);
    if (solver.info() != Eigen::Success) return false;
    const Eigen::MatrixXd x = solver.solve(rhs);
    if (solver.info() != Eigen::Success || !x.allFinite()) return false;
    for (int v = 0; v < n; ++v)
      if (unknown[v] >= 0) uv_[v] = x.row(unknown[v]).transpose(), placed_[v] = 1;
  }
  auto folded = [&] {
    std::vector<int> out;
    for (int f = 0; f < pm_->numFaces(); ++f) {
      if (!pm_->faceAlive(f)) continue;
      const auto& c = pm_->face(f);
      if (!(orient2(uv_[c[0]], uv_[c[1]], uv_[c[2]]) > 0)) out.push_back(f);
    }
    return out;
  };
  for (int f = 0; f < pm_->numFaces(); ++f) out_.stats.baseFaces += pm_->faceAlive(f);
  for (int round = 0; round < 16; ++round) {
    const std::vector<int> bad = folded();
    if (bad.empty()) return true;
    for (int f : bad)
      for (int v : pm_->face(f)) {
        Vec2 c;
        if (!problem_.fixed[v] && kernelCentroid(buildFan(v), c)) uv_[v] = c;
      }
  }
  return folded().empty();
}

CellMap CellMapper::run() {
  const int n = static_cast<int>(problem_.positions.size());
  TM_ASSERT(static_cast<int>(problem_.fixed.size()) == n && static_cast<int>(problem_.fixedUV.size()) == n);
  SimplifyInput input;
  input.positions = problem_.positions;
  input.faces = problem_.faces;
  input.pinned = problem_.fixed;
  input.paths = problem_.sides;
  pm_ = std::make_unique<ProgressiveMesh>(input, SimplifyOptions{}, JobControl{});
  uv_.assign(n, Vec2::Zero());
  placed_.assign(n, 0);
  optimised_.assign(n, 0);
  // A cell that is not the paper's base triangle (a polygon, features inside, a free border) is embedded at full
  // resolution: its coarsest mesh joins fixed vertices whose places the simplifier never saw, and may fold.
  if (!problem_.triangle)
    while (!pm_->atFull()) pm_->split();
  if (!embedBase()) {
    out_.failure = problem_.triangle
                       ? "its coarsest mesh has a face with three corners on one straight side of the triangle"
                       : "its map folds inside the photo polygon (a concave outline, or features inside placed "
                         "against their neighbours): add features along it";
    return std::move(out_);
  }
  out_.stats.baseMappedFaces = 1;

  // Section 4: replay the vertex splits (Schreiner et al. 2004 order): place the inserted vertex,
  // optimise it, then each of its free one-ring neighbours once.
  while (!pm_->atFull()) {
    const CollapseRecord& r = pm_->split();
    ++out_.stats.splits;
    insertVertex(r);
    optimise(r.removed);
    for (int w : r.ring) optimise(w);
    if (out_.stats.splits % 256 == 0) job_.checkCancel();
  }

  // Final sweeps at full resolution, in a seeded random order.
  std::vector<int> order;
  for (int v = 0; v < n; ++v)
    if (!problem_.fixed[v]) order.push_back(v);
  const int sweeps = problem_.triangle ? options_.finalSweeps : options_.finalSweeps + 4;
  for (int sweep = 0; sweep < sweeps; ++sweep) {
    job_.checkCancel();
    std::shuffle(order.begin(), order.end(), rng_);
    for (int v : order) optimise(v);
  }

  for (const auto& c : problem_.faces) {
    const TriangleStretch s =
        triangleStretch({problem_.positions[c[0]], problem_.positions[c[1]], problem_.positions[c[2]]},
                        {uv_[c[0]], uv_[c[1]], uv_[c[2]]});
    if (s.flipped)
      ++out_.stats.flippedFaces;
    else
      out_.stats.maxStretch = std::max(out_.stats.maxStretch, s.gamma);
  }
  out_.uv.resize(n);
  for (int v = 0; v < n; ++v) {
    out_.uv[v] = flipY(uv_[v]);
    if (!problem_.fixed[v]) {
      out_.stats.optimisedVertices += optimised_[v];
      out_.stats.onBackground += !onForeground(uv_[v]);
    }
  }
  return std::move(out_);
}

}  // namespace

CellMap coarseToFineCell(const CellProblem& problem, const Photo& photo, const FineMapOptions& options,
                         const JobControl& job) {
  return CellMapper(problem, photo, options, job).run();
}

}  // namespace montage
