#include "surface/surface_synthesis.h"

#include <tbb/parallel_for.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <nanoflann.hpp>
#include <numeric>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <unordered_map>
#include <unordered_set>

#include "base/job.h"
#include "geometry/mesh.h"
#include "geometry/poisson.h"
#include "image/photo.h"
#include "io/project.h"
#include "surface/level.h"

namespace montage {

namespace {

constexpr int kPatch = 7;                 // neighbourhood: kPatch x kPatch grid cells
constexpr int kHalf = kPatch / 2;
constexpr int kDims = kPatch * kPatch * 3;
constexpr double kMinCellsAcross = 8;     // the coarsest level keeps the hole this many grid cells across
constexpr float kSearchEps = 1;          // the kd-tree's patch is within (1 + eps) of the nearest's distance
constexpr double kMinExemplarCells = 40;   // an exemplar is at least this many finest cells a side
constexpr double kMinLevelExemplar = kPatch + 3;  // a level's exemplar, this many cells a side: 16 patches or more
constexpr double kCoherentEnough = 6;     // finest level: a coherent patch this close (L*a*b* per cell) is kept

// The key of cube (x, y, z) of a uniform grid (21 bits per coordinate).
uint64_t cubeKey(int x, int y, int z) {
  constexpr int kOff = 1 << 20;
  return (uint64_t(uint32_t(x + kOff) & 0x1fffff) << 42) | (uint64_t(uint32_t(y + kOff) & 0x1fffff) << 21) |
         uint64_t(uint32_t(z + kOff) & 0x1fffff);
}
int cubeOf(float v, float side) { return static_cast<int>(std::floor(v / side)); }

// Points in a uniform grid of cubes, for neighbourhood queries.
class PointGrid {
 public:
  PointGrid(const std::vector<Vec3f>& points, float cell) : cell_(cell) {
    std::vector<std::pair<uint64_t, int>> keyed(points.size());
    for (size_t i = 0; i < points.size(); ++i) keyed[i] = {keyOf(points[i]), static_cast<int>(i)};
    std::sort(keyed.begin(), keyed.end());
    order_.resize(points.size());
    for (size_t i = 0; i < keyed.size(); ++i) {
      order_[i] = keyed[i].second;
      auto& range = range_[keyed[i].first];
      if (i == 0 || keyed[i - 1].first != keyed[i].first) range.first = static_cast<int>(i);
      range.second = static_cast<int>(i) + 1;
    }
  }
  // Calls f(index) for every point in the cubes that the ball (q, radius) touches.
  template <class F>
  void forEachNear(const Vec3f& q, float radius, F&& f) const {
    const int x0 = cubeOf(q.x() - radius, cell_), x1 = cubeOf(q.x() + radius, cell_);
    const int y0 = cubeOf(q.y() - radius, cell_), y1 = cubeOf(q.y() + radius, cell_);
    const int z0 = cubeOf(q.z() - radius, cell_), z1 = cubeOf(q.z() + radius, cell_);
    for (int x = x0; x <= x1; ++x)
      for (int y = y0; y <= y1; ++y)
        for (int z = z0; z <= z1; ++z) {
          const auto it = range_.find(cubeKey(x, y, z));
          if (it == range_.end()) continue;
          for (int i = it->second.first; i < it->second.second; ++i) f(order_[i]);
        }
  }

 private:
  uint64_t keyOf(const Vec3f& p) const { return cubeKey(cubeOf(p.x(), cell_), cubeOf(p.y(), cell_), cubeOf(p.z(), cell_)); }
  float cell_;
  std::unordered_map<uint64_t, std::pair<int, int>> range_;
  std::vector<int> order_;
};

// sRGB in [0,1] <-> L*a*b* for many colours at once (OpenCV's conversion, as for the exemplar's pixels).
std::vector<Vec3f> convert(const std::vector<Vec3f>& in, int code) {
  std::vector<Vec3f> out(in.size());
  if (in.empty()) return out;
  cv::Mat src(static_cast<int>(in.size()), 1, CV_32FC3, const_cast<Vec3f*>(in.data()));
  cv::Mat dst(static_cast<int>(out.size()), 1, CV_32FC3, out.data());
  cv::cvtColor(src, dst, code);
  return out;
}

// The photo's x and y axes on a mapped face: the 3D directions in which its photo coordinates grow.
bool photoAxes(const Mesh& mesh, const TextureMap& map, int f, Vec3& dx, Vec3& dy) {
  const auto p = mesh.facePositions(f);
  const auto& c = map.cornerUV[f];
  Eigen::Matrix<double, 3, 2> e;
  e << p[1] - p[0], p[2] - p[0];
  Eigen::Matrix2d d;
  d << c[1] - c[0], c[2] - c[0];
  if (!(std::abs(d.determinant()) > 1e-12)) return false;
  const Eigen::Matrix<double, 3, 2> j = e * d.inverse();
  dx = j.col(0), dy = j.col(1);
  return dx.allFinite() && dy.allFinite() && dx.norm() > 0 && dy.norm() > 0;
}

// The candidates' PCA features as a nanoflann dataset (rows of a CV_32F matrix).
struct FeatureRows {
  cv::Mat rows;
  size_t kdtree_get_point_count() const { return size_t(rows.rows); }
  float kdtree_get_pt(size_t i, size_t d) const { return rows.at<float>(int(i), int(d)); }
  template <class Box>
  bool kdtree_get_bbox(Box&) const {
    return false;
  }
};
using FeatureTree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, FeatureRows>, FeatureRows,
                                                        -1, uint32_t>;

// One level's exemplar: L*a*b* pixels one grid cell each, and the patches a point may take.
struct Exemplar {
  cv::Mat lab;                  // CV_32FC3
  cv::Mat inner;                // CV_8UC1: the patch centred here is all foreground
  std::vector<cv::Point> at;    // candidate patch centres
  FeatureRows features;         // candidates x pcaDimensions, CV_32F
  std::unique_ptr<FeatureTree> tree;  // over `features` (deterministic; queries from any thread)
  cv::PCA pca;
};

Vec3f colourAt(const Exemplar& ex, const cv::Point& c) {
  const cv::Vec3f& e = ex.lab.at<cv::Vec3f>(c);
  return Vec3f(e[0], e[1], e[2]);
}

void patchOf(const cv::Mat& lab, int cx, int cy, float* out) {
  for (int j = -kHalf; j <= kHalf; ++j) {
    const auto* row = lab.ptr<cv::Vec3f>(cy + j);
    for (int i = -kHalf; i <= kHalf; ++i, out += 3) {
      const cv::Vec3f& v = row[cx + i];
      out[0] = v[0], out[1] = v[1], out[2] = v[2];
    }
  }
}

// Distinctive features are not texture (a face's eyes, brows and lips beside its skin, a mole, a logo): the
// patches whose mean colour is rare in the exemplar, at a squared Mahalanobis distance above chi2 from the
// foreground patches' means (mean and covariance estimated twice, the second time without the rare ones),
// leave `inner`: no point takes them, no coherent step lands on them. At most a fifth of the patches go (the
// threshold rises to the 80th percentile): what is common is texture, however it is distributed.
void excludeRarePatches(const cv::Mat& lab, cv::Mat& inner, double chi2) {
  std::vector<cv::Point> at;
  cv::findNonZero(inner, at);
  if (at.size() < 64) return;
  cv::Mat mean;
  cv::blur(lab, mean, cv::Size(kPatch, kPatch));
  std::vector<Eigen::Vector3d> value(at.size());
  for (size_t i = 0; i < at.size(); ++i) {
    const cv::Vec3f& v = mean.at<cv::Vec3f>(at[i]);
    value[i] = Eigen::Vector3d(v[0], v[1], v[2]);
  }
  std::vector<double> d2(at.size(), 0);
  for (int round = 0; round < 2; ++round) {
    Eigen::Vector3d mu = Eigen::Vector3d::Zero();
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    double count = 0;
    for (size_t i = 0; i < at.size(); ++i)
      if (round == 0 || d2[i] <= chi2) mu += value[i], ++count;
    if (count < 16) return;
    mu /= count;
    for (size_t i = 0; i < at.size(); ++i)
      if (round == 0 || d2[i] <= chi2) cov += (value[i] - mu) * (value[i] - mu).transpose();
    cov = cov / count + Eigen::Matrix3d::Identity();  // one L*a*b* unit of slack: a flat exemplar keeps all
    const Eigen::Matrix3d inv = cov.inverse();
    for (size_t i = 0; i < at.size(); ++i) d2[i] = (value[i] - mu).dot(inv * (value[i] - mu));
  }
  std::vector<double> sorted = d2;
  const size_t q = sorted.size() * 4 / 5;
  std::nth_element(sorted.begin(), sorted.begin() + q, sorted.end());
  const double threshold = std::max(chi2, sorted[q]);
  for (size_t i = 0; i < at.size(); ++i)
    if (d2[i] > threshold) inner.at<uchar>(at[i]) = 0;
}

// Candidates: every patch whose pixels are all foreground and not rare, strided down to at most maxCandidates.
bool makeExemplar(const cv::Mat& lab, const cv::Mat& valid, const SurfaceSynthesisOptions& options, std::mt19937_64& rng,
                  Exemplar& ex) {
  ex.lab = lab;
  if (lab.cols < kPatch || lab.rows < kPatch) return false;
  cv::Mat& inner = ex.inner;
  cv::erode(valid, inner, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(kPatch, kPatch)), cv::Point(-1, -1), 1,
            cv::BORDER_CONSTANT, cv::Scalar(0));
  if (options.rareChi2 > 0) excludeRarePatches(lab, inner, options.rareChi2);
  const int count = cv::countNonZero(inner);
  if (count < 16) return false;
  const int stride = std::max(1, int(std::ceil(std::sqrt(double(count) / options.maxCandidates))));
  const int ox = int(rng() % stride), oy = int(rng() % stride);
  for (int y = kHalf + oy; y < lab.rows - kHalf; y += stride)
    for (int x = kHalf + ox; x < lab.cols - kHalf; x += stride)
      if (inner.at<uchar>(y, x)) ex.at.emplace_back(x, y);
  if (ex.at.size() < 16) return false;
  cv::Mat patches(static_cast<int>(ex.at.size()), kDims, CV_32F);
  for (size_t i = 0; i < ex.at.size(); ++i) patchOf(lab, ex.at[i].x, ex.at[i].y, patches.ptr<float>(int(i)));
  // PCA from a sample of the candidates, then every candidate in its space.
  const int sample = std::min(patches.rows, 4000);
  cv::Mat rows(sample, kDims, CV_32F);
  for (int i = 0; i < sample; ++i) patches.row(int(i * int64_t(patches.rows) / sample)).copyTo(rows.row(i));
  const int dims = std::min({options.pcaDimensions, kDims, sample});
  ex.pca = cv::PCA(rows, cv::noArray(), cv::PCA::DATA_AS_ROW, dims);
  ex.features.rows = ex.pca.project(patches);
  ex.tree = std::make_unique<FeatureTree>(ex.features.rows.cols, ex.features, nanoflann::KDTreeSingleIndexAdaptorParams(16));
  return true;
}

std::vector<int> allIndices(int begin, int end) {
  std::vector<int> out(end - begin);
  std::iota(out.begin(), out.end(), begin);
  return out;
}

// A Poisson-disk subset of points[begin, end): taken in a seeded random order, each kept when no kept
// point lies closer than `spacing`. Sorted.
std::vector<int> poissonDiskSubset(const std::vector<Vec3f>& points, int begin, int end, double spacing,
                                   std::mt19937_64& rng) {
  std::vector<int> order = allIndices(begin, end), kept;
  std::shuffle(order.begin(), order.end(), rng);
  const float r = float(spacing);
  std::unordered_map<uint64_t, std::vector<int>> taken;
  for (int i : order) {
    const Vec3f& p = points[i];
    const int cx = cubeOf(p.x(), r), cy = cubeOf(p.y(), r), cz = cubeOf(p.z(), r);
    bool free = true;
    for (int x = cx - 1; x <= cx + 1 && free; ++x)
      for (int y = cy - 1; y <= cy + 1 && free; ++y)
        for (int z = cz - 1; z <= cz + 1 && free; ++z) {
          const auto it = taken.find(cubeKey(x, y, z));
          if (it == taken.end()) continue;
          for (int c : it->second)
            if ((points[c] - p).squaredNorm() < r * r) free = false;
        }
    if (free) taken[cubeKey(cx, cy, cz)].push_back(i), kept.push_back(i);
  }
  std::sort(kept.begin(), kept.end());
  return kept;
}

// The exemplar's grain: the direction of least change of its lightness (the structure tensor's minor
// eigenvector, over its foreground), as an angle from its x axis in its pixels (y down), and how marked it is
// ((l1 - l2) / (l1 + l2): 0 isotropic, 1 all along one line).
std::pair<double, double> grainOf(const cv::Mat& lab, const cv::Mat& valid) {
  cv::Mat l, gx, gy;
  cv::extractChannel(lab, l, 0);
  cv::Sobel(l, gx, CV_32F, 1, 0), cv::Sobel(l, gy, CV_32F, 0, 1);
  double xx = 0, xy = 0, yy = 0;
  for (int y = 0; y < l.rows; ++y)
    for (int x = 0; x < l.cols; ++x) {
      if (!valid.at<uchar>(y, x)) continue;
      const double a = gx.at<float>(y, x), b = gy.at<float>(y, x);
      xx += a * a, xy += a * b, yy += b * b;
    }
  const double gradient = 0.5 * std::atan2(2 * xy, xx - yy);  // the major eigenvector's angle
  const double spread = std::sqrt((xx - yy) * (xx - yy) + 4 * xy * xy);
  return {gradient + M_PI / 2, xx + yy > 0 ? spread / (xx + yy) : 0};
}

// Strokes steer the direction field (issue 34): at the unknown vertices a stroke passes (within 0.75 of a cell
// of its segments) the frame is turned so that the exemplar's grain runs along the stroke (an exemplar without a
// marked grain: its x axis), signed to agree with the field the border alone gives there (grain has no sign;
// opposite signs would cancel); then the field is harmonic again with the border's directions and the strokes'
// fixed. Where that system cannot be solved (a part of the hole that neither touches), the border's field stays.
std::vector<Vec3> steerByStrokes(const SurfaceSynthesisInput& in, const std::vector<Vec3>& vertexNormal,
                                 const std::vector<Vec3f>& pos, const std::vector<int>& unknownVertex, double h0,
                                 const cv::Mat& lab, const cv::Mat& valid, double flip, const std::vector<Vec3>& field,
                                 int& steered) {
  const TriangleMesh& surf = *in.surface;
  const int n = surf.numVertices();
  const auto [grain, marked] = grainOf(lab, valid);
  const double phi = marked > 0.1 ? grain : 0;
  const PointGrid unknowns(std::vector<Vec3f>(pos.begin(), pos.begin() + long(unknownVertex.size())), float(h0));
  Eigen::MatrixXd sum = Eigen::MatrixXd::Zero(n, 3);
  std::vector<char> passed(n, 0);
  for (const auto& [from, to] : in.strokes) {
    const Vec3 along = to - from;
    const double length = along.norm();
    if (!(length > 0)) continue;
    const int steps = std::max(1, int(std::ceil(2 * length / h0)));
    for (int k = 0; k <= steps; ++k) {
      const Vec3f x = (from + along * (double(k) / steps)).cast<float>();
      unknowns.forEachNear(x, float(0.75 * h0), [&](int i) {
        if ((pos[i] - x).norm() > 0.75 * h0) return;
        const int v = unknownVertex[i];
        const Vec3& nrm = vertexNormal[v];
        Vec3 s = along - along.dot(nrm) * nrm;
        if (!(s.norm() > 1e-12)) return;
        s.normalize();
        Vec3 t = std::cos(phi) * s - std::sin(phi) * (flip * nrm.cross(s));
        if (t.dot(field[v]) < 0) t = -t;
        sum.row(v) += t.transpose(), passed[v] = 1;
      });
    }
  }
  std::vector<char> fixed = in.fixed;
  Eigen::MatrixXd values = Eigen::MatrixXd::Zero(n, 3);
  steered = 0;
  for (int v = 0; v < n; ++v) {
    if (fixed[v]) values.row(v) = field[v].transpose();
    if (passed[v] && sum.row(v).norm() > 0) values.row(v) = sum.row(v).normalized(), fixed[v] = 1, ++steered;
  }
  if (steered == 0) return field;
  try {
    const PoissonSolver solver(surf, fixed);
    const Eigen::MatrixXd solved = solver.solve(Eigen::MatrixXd::Zero(n, 3), values);
    std::vector<Vec3> out(n);
    for (int v = 0; v < n; ++v) out[v] = solved.row(v).transpose();
    return out;
  } catch (const Error&) {
    steered = 0;
    return field;
  }
}

}  // namespace

Vec3f TextureDetail::sample(float x, float y) const {
  // Bilinear, clamped to the exemplar's edge (it is at least one neighbourhood, 7 pixels, a side).
  x = std::clamp(x, 0.f, float(rgb.cols - 1)), y = std::clamp(y, 0.f, float(rgb.rows - 1));
  const int x0 = std::min(int(x), rgb.cols - 2), y0 = std::min(int(y), rgb.rows - 2), x1 = x0 + 1, y1 = y0 + 1;
  const float fx = x - float(x0), fy = y - float(y0);
  const cv::Vec3b *r0 = rgb.ptr<cv::Vec3b>(y0), *r1 = rgb.ptr<cv::Vec3b>(y1);
  Vec3f c;
  for (int k = 0; k < 3; ++k)
    c[k] = ((1 - fy) * ((1 - fx) * r0[x0][k] + fx * r0[x1][k]) + fy * ((1 - fx) * r1[x0][k] + fx * r1[x1][k])) / 255.f;
  return c;
}

Vec3f TextureDetail::residual(const std::array<int, 3>& index, const std::array<const Vec3*, 3>& corner,
                              const Vec3& w) const {
  // The exemplar at x as each synthesised corner places it (its coordinate plus x's offset in its frame),
  // blended with weights that favour the nearest corner: where the corners agree (a coherent patch) this is
  // the exemplar itself, texel for texel; where they do not, the seam between their patches stays narrow.
  const Vec3f x = (w[0] * *corner[0] + w[1] * *corner[1] + w[2] * *corner[2]).cast<float>();
  Vec3f looked = Vec3f::Zero();
  float weightSum = 0;
  for (int k = 0; k < 3; ++k) {
    if (index[k] < 0) continue;
    const Point& p = points[index[k]];
    const Vec3f d = x - corner[k]->cast<float>();
    const float wk = float(w[k]), weight = wk * wk * wk * wk + 1e-12f;
    looked += weight * sample(p.at.x() + p.du.dot(d), p.at.y() + p.dv.dot(d));
    weightSum += weight;
  }
  if (!(weightSum > 0)) return Vec3f::Zero();
  looked /= weightSum;
  // Minus the exemplar's values at the corners, interpolated: the vertices' own share, which the Poisson fill
  // already holds. A fixed corner contributes nothing, so the residual vanishes at the border.
  Vec3f r = Vec3f::Zero();
  for (int k = 0; k < 3; ++k)
    if (index[k] >= 0) r += float(w[k]) * (looked - points[index[k]].colour);
  return r;
}

SurfaceSynthesisResult synthesiseOnSurface(const SurfaceSynthesisInput& in, const SurfaceSynthesisOptions& options) {
  SurfaceSynthesisResult out;
  const Mesh& mesh = *in.mesh;
  const TextureMap& map = *in.map;
  const TriangleMesh& surf = *in.surface;
  const JobControl noJob;
  const JobControl& job = in.job ? *in.job : noJob;
  const int nf = mesh.numFaces(), n = surf.numVertices();
  if (in.holeFaces.empty() || n == 0 || in.fixed.size() != size_t(n) ||
      in.triangleFace.size() != size_t(surf.numTriangles())) {
    out.note = "texture: empty hole";
    return out;
  }
  std::vector<char> inHole(nf, 0);
  double holeArea = 0;
  for (int f : in.holeFaces) inHole[f] = 1, holeArea += mesh.faceArea(f);

  // Grid cell at the finest level: the hole's mean refined edge.
  double edgeSum = 0;
  int edges = 0;
  for (int t = 0; t < surf.numTriangles(); ++t) {
    if (!inHole[in.triangleFace[t]]) continue;
    const auto& tri = surf.triangles[t];
    for (int k = 0; k < 3; ++k) edgeSum += (surf.positions[tri[k]] - surf.positions[tri[(k + 1) % 3]]).norm(), ++edges;
  }
  if (edges == 0 || !(edgeSum > 0)) {
    out.note = "texture: the hole has no refined triangle";
    return out;
  }
  const double h0 = edgeSum / edges;

  // Exemplar faces: rings of mapped faces around the hole up to exemplarBand times its area; a hole with
  // no mapped neighbour takes the mapped faces nearest to it in space.
  VertexFaces ownVertexFaces;
  if (!in.vertexFaces) ownVertexFaces = facesAroundVertices(mesh);
  const VertexFaces& vertexFaces = in.vertexFaces ? *in.vertexFaces : ownVertexFaces;
  // At least kMinExemplarCells cells a side at the finest level, so that a small hole's exemplar still holds
  // enough whole neighbourhoods.
  const double bandArea = std::max(options.exemplarBand * holeArea, std::pow(kMinExemplarCells * h0, 2));
  std::vector<int> band;
  {
    std::vector<char> seen(inHole);
    std::vector<int> front = in.holeFaces;
    double area = 0;
    for (int ring = 0; ring < 256 && !front.empty() && area < bandArea; ++ring) {
      std::vector<int> next;
      for (int f : front)
        for (int v : mesh.faceVertices(f))
          for (int g : vertexFaces[v])
            if (!seen[g] && map.facePhoto[g] >= 0) seen[g] = 1, next.push_back(g), area += mesh.faceArea(g);
      band.insert(band.end(), next.begin(), next.end());
      front = std::move(next);
    }
  }
  bool nearestInSpace = false;
  if (band.empty()) {
    Vec3 centre = Vec3::Zero();
    for (int f : in.holeFaces) {
      const auto p = mesh.facePositions(f);
      centre += mesh.faceArea(f) * (p[0] + p[1] + p[2]) / 3;
    }
    centre /= std::max(holeArea, 1e-300);
    std::vector<std::pair<double, int>> byDistance;
    for (int f = 0; f < nf; ++f)
      if (map.facePhoto[f] >= 0) {
        const auto p = mesh.facePositions(f);
        byDistance.emplace_back(((p[0] + p[1] + p[2]) / 3 - centre).squaredNorm(), f);
      }
    std::sort(byDistance.begin(), byDistance.end());
    double area = 0;
    for (const auto& [d, f] : byDistance) {
      if (area >= bandArea) break;
      band.push_back(f), area += mesh.faceArea(f);
    }
    nearestInSpace = true;
  }
  if (band.empty()) {
    out.note = "texture: no photo is mapped anywhere to take texture from";
    return out;
  }
  // The photo mapped on most of the band, or the one the user picked.
  std::unordered_map<int, double> photoArea;
  for (int f : band) photoArea[map.facePhoto[f]] += mesh.faceArea(f);
  int photoIndex = -1;
  double bestArea = -1;
  for (const auto& [p, a] : photoArea)
    if (a > bestArea || (a == bestArea && p < photoIndex)) photoIndex = p, bestArea = a;
  const HoleExemplar* picked = in.exemplar;
  if (picked && (picked->photo < 0 || picked->photo >= static_cast<int>(in.photos.size()) ||
                 !in.photos[picked->photo] || picked->polygon.size() < 3)) {
    out.note = "texture: the photo region picked for the hole is not in this run";
    return out;
  }

  // The photo's density and orientation on the surface, over `faces` mapped from photo p, and the bounding box
  // of their stored pixels.
  struct Footprint {
    double area3 = 0, areaPx = 0, chirality = 0;
    Vec3 meanDx = Vec3::Zero();
    Vec2 lo = Vec2::Constant(1e300), hi = Vec2::Constant(-1e300);
    std::vector<int> faces;
  };
  const auto footprint = [&](const std::vector<int>& faces, int p) {
    Footprint fp;
    const double stored = in.photos[p]->scale;
    for (int f : faces) {
      if (map.facePhoto[f] != p) continue;
      fp.faces.push_back(f);
      const auto& c = map.cornerUV[f];
      const double a3 = mesh.faceArea(f);
      fp.area3 += a3;
      fp.areaPx += 0.5 * std::abs((c[1] - c[0]).x() * (c[2] - c[0]).y() - (c[1] - c[0]).y() * (c[2] - c[0]).x()) *
                   stored * stored;
      Vec3 dx, dy;
      if (photoAxes(mesh, map, f, dx, dy)) {
        fp.chirality += a3 * mesh.faceNormal(f).cross(dx.normalized()).dot(dy.normalized());
        fp.meanDx += a3 * dx.normalized();
      }
      for (const Vec2& q : c) fp.lo = fp.lo.cwiseMin(q * stored), fp.hi = fp.hi.cwiseMax(q * stored);
    }
    return fp;
  };
  Footprint fp = footprint(band, photoIndex);
  if (picked) {
    // The picked photo's own scale and handedness on the surface where it is mapped; a photo mapped nowhere
    // (another subject's, taken only for its texture) takes the band's scale and shows as it is, unmirrored
    // (a photo projected onto the surface it faces has chirality -1).
    std::vector<int> all(nf);
    for (int f = 0; f < nf; ++f) all[f] = f;
    Footprint own = footprint(all, picked->photo);
    if (!(own.area3 > 0) || !(own.areaPx > 0)) {
      const double density = fp.areaPx > 0 && fp.area3 > 0 ? fp.areaPx / fp.area3 : 0;
      own.area3 = 1, own.areaPx = density, own.chirality = -1, own.meanDx = fp.meanDx;
    }
    photoIndex = picked->photo;
    const double stored = in.photos[photoIndex]->scale;
    own.lo = Vec2::Constant(1e300), own.hi = Vec2::Constant(-1e300);
    for (const Vec2& q : picked->polygon) own.lo = own.lo.cwiseMin(q * stored), own.hi = own.hi.cwiseMax(q * stored);
    fp = std::move(own);
  }
  const Photo& photo = *in.photos[photoIndex];
  out.exemplarPhoto = photoIndex;
  if (!(fp.area3 > 0) || !(fp.areaPx > 0)) {
    out.note = picked ? "texture: the photo region picked for the hole has no scale on the surface (no photo is mapped "
                        "around the hole)"
                      : "texture: the photo region near the hole has no area";
    return out;
  }
  const double stored = photo.scale;
  const double pixelsPerUnit = std::sqrt(fp.areaPx / fp.area3);  // stored pixels per model unit
  const double flip = fp.chirality < 0 ? -1 : 1;
  const Vec3 meanDx = fp.meanDx;
  const cv::Rect crop = cv::Rect(int(std::floor(fp.lo.x())) - 2, int(std::floor(fp.lo.y())) - 2,
                                 int(std::ceil(fp.hi.x() - fp.lo.x())) + 5, int(std::ceil(fp.hi.y() - fp.lo.y())) + 5) &
                        cv::Rect(0, 0, photo.rgb.cols, photo.rgb.rows);
  if (crop.width < kPatch || crop.height < kPatch) {
    out.note = picked ? "texture: the photo region picked for the hole is smaller than one neighbourhood"
                      : "texture: the photo region near the hole is smaller than one neighbourhood";
    return out;
  }
  cv::Mat rgb;
  const double depthScale = photo.rgb.depth() == CV_8U ? 1 / 255.0 : photo.rgb.depth() == CV_16U ? 1 / 65535.0 : 1;
  photo.rgb(crop).convertTo(rgb, CV_32FC3, depthScale);
  cv::Mat valid(crop.size(), CV_8UC1, cv::Scalar(0));
  const auto toCrop = [&](const Vec2& q) {  // file pixels -> the crop's, 4 bits of subpixel
    return cv::Point(int(std::lround((q.x() * stored - crop.x) * 16)),
                     int(std::lround((q.y() * stored - crop.y) * 16)));
  };
  if (picked) {
    std::vector<cv::Point> pts;
    for (const Vec2& q : picked->polygon) pts.push_back(toCrop(q));
    cv::fillPoly(valid, std::vector<std::vector<cv::Point>>{pts}, cv::Scalar(255), cv::LINE_8, 4);
  } else {
    for (int f : fp.faces) {
      cv::Point pts[3];
      for (int k = 0; k < 3; ++k) pts[k] = toCrop(map.cornerUV[f][k]);
      cv::fillConvexPoly(valid, pts, 3, cv::Scalar(255), cv::LINE_8, 4);
    }
  }
  if (photo.hasBackground && !photo.alpha.empty()) {
    cv::Mat alpha;
    if (photo.alpha.depth() == CV_8U)
      alpha = photo.alpha(crop) >= 128;
    else
      alpha = photo.alpha(crop) >= 0.5;
    valid &= alpha;
  }
  job.checkCancel();

  // Points: the hole's unknown vertices first, then the known ones (the surface's fixed vertices and
  // samples of the mapped faces around the hole, as far as the coarsest neighbourhood reaches).
  // Levels: as many as options.levels allows while the hole stays kMinCellsAcross cells across and the
  // exemplar, at one pixel per cell, kMinLevelExemplar pixels (a coarser one holds too few whole
  // neighbourhoods; each such level would be skipped, and the known points gathered for its reach be wasted: on
  // the face onto the head, a 26 x 29 texel exemplar at the preview took 4 levels' reach for 2 levels' work).
  const double holeExtent = std::sqrt(holeArea);
  const double exemplarCells = std::min(crop.width, crop.height) / (pixelsPerUnit * h0);
  int levels = 1;
  while (levels < options.levels && holeExtent / (h0 * (1 << levels)) >= kMinCellsAcross &&
         exemplarCells / (1 << levels) >= kMinLevelExemplar)
    ++levels;
  const double reach = (kHalf + 1) * std::sqrt(2.0) * h0 * (1 << (levels - 1));
  std::vector<Vec3f> pos, normal;
  std::vector<int> unknownVertex;
  std::vector<Vec3f> knownRgb;
  std::vector<Vec3> vertexNormal(n, Vec3::Zero());
  for (const auto& tri : surf.triangles) {
    const Vec3 nrm = (surf.positions[tri[1]] - surf.positions[tri[0]]).cross(surf.positions[tri[2]] - surf.positions[tri[0]]);
    for (int v : tri) vertexNormal[v] += nrm;
  }
  for (Vec3& v : vertexNormal) v = v.norm() > 0 ? Vec3(v.normalized()) : Vec3(0, 0, 1);
  for (int v = 0; v < n; ++v)
    if (!in.fixed[v]) unknownVertex.push_back(v), pos.push_back(surf.positions[v].cast<float>()),
                      normal.push_back(vertexNormal[v].cast<float>());
  const int nu = static_cast<int>(unknownVertex.size());
  if (nu == 0) {  // every vertex is on the border: their photo colours are the fill
    out.note = "texture: every vertex of the hole is on its border (nothing to synthesise)";
    out.colours = in.fixedValues && in.fixedValues->rows() == n ? *in.fixedValues : Eigen::MatrixXd::Zero(n, 3);
    out.ok = true;
    return out;
  }
  for (int v = 0; v < n; ++v)
    if (in.fixed[v]) {
      pos.push_back(surf.positions[v].cast<float>()), normal.push_back(vertexNormal[v].cast<float>());
      knownRgb.push_back(in.fixedValues->row(v).transpose().cast<float>());
    }
  {
    // Within reach of the hole: in a cube of side reach / 2 that lies two cubes or less from one holding a
    // hole point (a little more than `reach`, tested with one lookup).
    const float cube = float(reach / 2);
    std::unordered_set<uint64_t> reached;
    {
      std::unordered_set<uint64_t> occupied;
      for (int i = 0; i < nu; ++i) {
        const int cx = cubeOf(pos[i].x(), cube), cy = cubeOf(pos[i].y(), cube), cz = cubeOf(pos[i].z(), cube);
        if (occupied.insert(cubeKey(cx, cy, cz)).second)
          for (int dx = -2; dx <= 2; ++dx)
            for (int dy = -2; dy <= 2; ++dy)
              for (int dz = -2; dz <= 2; ++dz) reached.insert(cubeKey(cx + dx, cy + dy, cz + dz));
      }
    }
    auto near = [&](const Vec3& p) {
      return reached.count(cubeKey(cubeOf(float(p.x()), cube), cubeOf(float(p.y()), cube), cubeOf(float(p.z()), cube))) > 0;
    };
    std::vector<char> seen(inHole);
    std::vector<int> front = in.holeFaces;
    for (int ring = 0; ring < 512 && !front.empty(); ++ring) {
      std::vector<int> next;
      for (int f : front)
        for (int v : mesh.faceVertices(f))
          for (int g : vertexFaces[v]) {
            if (seen[g] || map.facePhoto[g] < 0) continue;
            seen[g] = 1;
            if (next.size() % 64 == 0) job.checkCancel();
            const auto p = mesh.facePositions(g);
            double longest = 0;
            for (int k = 0; k < 3; ++k) longest = std::max(longest, (p[k] - p[(k + 1) % 3]).norm());
            const int steps = std::max(1, int(std::ceil(longest / h0)));
            const Vec3f nrm = mesh.faceNormal(g).cast<float>();
            const Photo& ph = *in.photos[map.facePhoto[g]];
            bool any = false;
            for (int i = 0; i <= steps; ++i)
              for (int j = 0; i + j <= steps; ++j) {
                const Vec3 b(double(steps - i - j) / steps, double(i) / steps, double(j) / steps);
                const Vec3 x = b[0] * p[0] + b[1] * p[1] + b[2] * p[2];
                if (!near(x)) continue;
                any = true;
                if (ph.hasBackground) {
                  const auto& c = map.cornerUV[g];
                  const Vec2 q = b[0] * c[0] + b[1] * c[1] + b[2] * c[2];
                  if (ph.alphaAt(q.x(), q.y()) < 0.5f) continue;
                }
                pos.push_back(x.cast<float>()), normal.push_back(nrm);
                knownRgb.push_back(mappedColor(map, in.photos, in.levelling, g, b).cwiseMax(0.f).cwiseMin(1.f));
              }
            if (any) next.push_back(g);
          }
      front = std::move(next);
      job.checkCancel();
    }
  }
  const int np = static_cast<int>(pos.size());
  const std::vector<Vec3f> knownLab = convert(knownRgb, cv::COLOR_RGB2Lab);

  // The exemplar in L*a*b*, its mean and deviation matched to the known points' (the hole's border).
  cv::Mat lab0;
  cv::cvtColor(rgb, lab0, cv::COLOR_RGB2Lab);
  if (!knownLab.empty()) {
    cv::Scalar exMean, exDev;
    cv::meanStdDev(lab0, exMean, exDev, valid);
    Eigen::Vector3d mean = Eigen::Vector3d::Zero(), sq = Eigen::Vector3d::Zero();
    for (const Vec3f& c : knownLab) mean += c.cast<double>(), sq += c.cast<double>().cwiseAbs2();
    mean /= double(knownLab.size());
    const Eigen::Vector3d dev = (sq / double(knownLab.size()) - mean.cwiseAbs2()).cwiseMax(0).cwiseSqrt();
    std::vector<cv::Mat> ch;
    cv::split(lab0, ch);
    for (int c = 0; c < 3; ++c) {
      const double gain = exDev[c] > 1e-3 ? std::clamp(dev[c] / exDev[c], 0.5, 2.0) : 1.0;
      ch[c] = (ch[c] - exMean[c]) * gain + mean[c];
    }
    cv::merge(ch, lab0);
  }

  // Frames: the direction field (the photos' x axis, harmonic over the hole) in each tangent plane.
  std::vector<Vec3> field(n, Vec3::Zero());
  const Vec3 fallbackDx = meanDx.norm() > 0 ? Vec3(meanDx.normalized()) : Vec3(1, 0, 0);
  if (in.solver && in.fixedValues) {
    Eigen::MatrixXd fixedDirs = Eigen::MatrixXd::Zero(n, 3);
    for (int t = 0; t < surf.numTriangles(); ++t) {
      const int f = in.triangleFace[t];
      Vec3 dx, dy;
      if (map.facePhoto[f] < 0 || !photoAxes(mesh, map, f, dx, dy)) continue;
      for (int v : surf.triangles[t])
        if (in.fixed[v]) fixedDirs.row(v) += dx.normalized().transpose();
    }
    for (int v = 0; v < n; ++v)
      if (in.fixed[v] && fixedDirs.row(v).norm() == 0) fixedDirs.row(v) = fallbackDx.transpose();
    const Eigen::MatrixXd solved = in.solver->solve(Eigen::MatrixXd::Zero(n, 3), fixedDirs);
    for (int v = 0; v < n; ++v) field[v] = solved.row(v).transpose();
  } else {
    std::fill(field.begin(), field.end(), fallbackDx);
  }
  if (!in.strokes.empty())
    field = steerByStrokes(in, vertexNormal, pos, unknownVertex, h0, lab0, valid, flip, field, out.strokeVertices);
  std::vector<Vec3f> tangent(nu), bitangent(nu);
  for (int i = 0; i < nu; ++i) {
    const int v = unknownVertex[i];
    const Vec3 nrm = vertexNormal[v];
    Vec3 t = field[v] - field[v].dot(nrm) * nrm;
    if (!(t.norm() > 1e-9)) t = fallbackDx - fallbackDx.dot(nrm) * nrm;
    if (!(t.norm() > 1e-9)) t = nrm.unitOrthogonal();
    t.normalize();
    tangent[i] = t.cast<float>();
    bitangent[i] = (flip * nrm.cross(t)).cast<float>();
  }
  job.checkCancel();

  std::vector<Vec3f> value(nu, Vec3f::Zero());  // the synthesised L*a*b* of the unknown points
  std::mt19937_64 rng(options.seed);
  struct Level {  // the last level synthesised: its points, their positions and exemplar coordinates
    std::vector<int> points;
    std::vector<Vec3f> position;
    std::vector<cv::Point> coord;
    cv::Size size;
    double h = 0;
  } coarse;

  cv::Mat valid32;  // the exemplar's foreground in [0,1], resampled with it per level
  valid.convertTo(valid32, CV_32F, 1 / 255.0);
  for (int level = levels - 1; level >= 0; --level) {
    const double h = h0 * (1 << level);
    // The exemplar at one pixel per cell.
    const double s = 1 / (pixelsPerUnit * h);
    const cv::Size size(std::max(1, int(std::lround(lab0.cols * s))), std::max(1, int(std::lround(lab0.rows * s))));
    Exemplar ex;
    cv::Mat lab, validF, validL;
    cv::resize(lab0, lab, size, 0, 0, s < 1 ? cv::INTER_AREA : cv::INTER_LINEAR);
    cv::resize(valid32, validF, size, 0, 0, s < 1 ? cv::INTER_AREA : cv::INTER_LINEAR);
    validL = validF >= 0.99f;
    job.checkCancel();
    const bool exemplarMade = makeExemplar(lab, validL, options, rng, ex);
    job.checkCancel();
    if (!exemplarMade) {
      if (level > 0) continue;
      out.note = std::string(picked ? "texture: the photo region picked for the hole ("
                                    : "texture: the photo region near the hole (") +
                 std::to_string(size.width) + " x " + std::to_string(size.height) +
                 " texels) holds too few whole neighbourhoods" +
                 (picked ? " of foreground (draw a larger region, on the subject)" : "");
      return out;
    }

    // This level's points, about a cell apart (all of them at the finest level): the unknown ones to
    // synthesise, and the known ones, each the mean of the known points within 0.6 of a cell.
    std::vector<int> pts = level == 0 ? allIndices(0, nu) : poissonDiskSubset(pos, 0, nu, 0.9 * h, rng);
    const std::vector<int> knownPts = level == 0 ? allIndices(nu, np) : poissonDiskSubset(pos, nu, np, 0.9 * h, rng);
    std::vector<Vec3f> knownPos(knownPts.size()), knownValue(knownPts.size()), knownNormal(knownPts.size());
    {
      std::unique_ptr<const PointGrid> grid;  // the known points, for the coarser levels' means
      if (level > 0) grid = std::make_unique<const PointGrid>(std::vector<Vec3f>(pos.begin() + nu, pos.end()), float(h));
      const float r = float(0.6 * h);
      tbb::parallel_for(size_t(0), knownPts.size(), [&](size_t k) {
        const int q = knownPts[k];
        knownPos[k] = pos[q], knownNormal[k] = normal[q];
        if (!grid) {
          knownValue[k] = knownLab[q - nu];
          return;
        }
        Vec3f sum = Vec3f::Zero();
        int count = 0;
        grid->forEachNear(pos[q], r, [&](int j) {
          if ((pos[nu + j] - pos[q]).squaredNorm() <= r * r) sum += knownLab[j], ++count;
        });
        knownValue[k] = count ? Vec3f(sum / float(count)) : knownLab[q - nu];
      });
    }
    const int m = static_cast<int>(pts.size());
    std::vector<Vec3f> levelPos(m);
    for (int i = 0; i < m; ++i) levelPos[i] = pos[pts[i]];

    // Each point's exemplar coordinate: inherited from the nearest point of the coarser level (its
    // coordinate scaled, plus this point's offset in that point's frame), random at the coarsest level.
    std::vector<cv::Point> coord(m);
    auto randomCandidate = [&](uint64_t i) {
      std::mt19937_64 r(options.seed * 0x9e3779b97f4a7c15ull + i * 0xbf58476d1ce4e5b9ull + uint64_t(level));
      return ex.at[r() % ex.at.size()];
    };
    auto usable = [&](const cv::Point& c) {
      return c.x >= kHalf && c.y >= kHalf && c.x < ex.lab.cols - kHalf && c.y < ex.lab.rows - kHalf &&
             ex.inner.at<uchar>(c);
    };
    if (coarse.points.empty()) {
      for (int i = 0; i < m; ++i) coord[i] = randomCandidate(uint64_t(pts[i]));
    } else {
      const PointGrid coarseGrid(coarse.position, float(coarse.h));
      const double rx = double(size.width) / coarse.size.width, ry = double(size.height) / coarse.size.height;
      tbb::parallel_for(0, m, [&](int i) {
        const Vec3f& p = levelPos[i];
        int nearest = -1;
        float best = std::numeric_limits<float>::max();
        coarseGrid.forEachNear(p, float(1.5 * coarse.h), [&](int j) {
          const float d = (coarse.position[j] - p).squaredNorm();
          if (d < best) best = d, nearest = j;
        });
        cv::Point c(-1, -1);
        if (nearest >= 0) {
          const int q = coarse.points[nearest];
          const Vec3f d = p - pos[q];
          const double u = d.dot(tangent[q]) / coarse.h, v = d.dot(bitangent[q]) / coarse.h;
          c = cv::Point(int(std::lround((coarse.coord[nearest].x + u) * rx)),
                        int(std::lround((coarse.coord[nearest].y + v) * ry)));
        }
        coord[i] = usable(c) ? c : randomCandidate(uint64_t(pts[i]));
      });
    }

    // Correction passes (Lefebvre & Hoppe 2005/2006 on the surface's points): each point takes, of the
    // kd-tree's nearest patch to its neighbourhood and the coherent candidates its neighbours suggest
    // (k-coherence, Tong et al. 2002), the exemplar patch nearest to its neighbourhood. The points keep
    // exemplar coordinates, never averages, so the texture stays as sharp as the photo's.
    const float reachL = float((kHalf + 0.5) * std::sqrt(2.0) * h), depth = float(1.5 * h);
    const PointGrid levelGrid(levelPos, reachL), knownGrid(knownPos, reachL);
    std::vector<cv::Point> nextCoord(m);
    std::vector<Vec3f> colour(m);
    const int passes = std::max(1, level == 0 ? options.passes - 1 : options.passes);
    double energy = 0;
    // Subpasses (Lefebvre & Hoppe 2005): the points in eight interleaved sets by the parity of their cell
    // in a grid of one cell, each set corrected seeing the sets before it already corrected. Corrected all at
    // once, every point answers its neighbours' old coordinates, and only flat regions stay consistent.
    std::vector<std::vector<int>> subpass(8);
    for (int i = 0; i < m; ++i) {
      const Vec3f& x = levelPos[i];
      const float c = float(h);
      subpass[(cubeOf(x.x(), c) & 1) | (cubeOf(x.y(), c) & 1) << 1 | (cubeOf(x.z(), c) & 1) << 2].push_back(i);
    }
    for (int i = 0; i < m; ++i) colour[i] = colourAt(ex, coord[i]);
    for (int pass = 0; pass < passes; ++pass) {
      job.checkCancel();
      std::vector<double> distance(m, 0);
      for (const std::vector<int>& members : subpass) {
        const tbb::blocked_range<int> all(0, static_cast<int>(members.size()), 64);
        tbb::parallel_for(all, [&](const tbb::blocked_range<int>& range) {
          job.checkCancel();
          cv::Mat query(1, kDims, CV_32F), projected;
          std::array<Vec3f, kPatch * kPatch> cellSum;
          std::array<int, kPatch * kPatch> cellCount;
          std::vector<cv::Point> candidates;
          for (int slot = range.begin(); slot != range.end(); ++slot) {
            const int i = members[slot];
            const int q = pts[i];
            const Vec3f& p = pos[q];
            const Vec3f& nrm = normal[q];
            cellSum.fill(Vec3f::Zero());
            cellCount.fill(0);
            candidates.clear();
            candidates.push_back(coord[i]);
            auto cellOf = [&](const Vec3f& x, const Vec3f& xn, float& u, float& v) {
              const Vec3f d = x - p;
              if (std::abs(d.dot(nrm)) > depth || xn.dot(nrm) < 0.3f) return -1;
              u = d.dot(tangent[q]) / float(h), v = d.dot(bitangent[q]) / float(h);
              const int ci = int(std::floor(u + 0.5f)) + kHalf, cj = int(std::floor(v + 0.5f)) + kHalf;
              if (ci < 0 || cj < 0 || ci >= kPatch || cj >= kPatch) return -1;
              return cj * kPatch + ci;
            };
            levelGrid.forEachNear(p, reachL, [&](int j) {
              if (j == i) return;
              float u, v;
              const int k = cellOf(levelPos[j], normal[pts[j]], u, v);
              if (k < 0) return;
              cellSum[k] += colour[j], ++cellCount[k];
              candidates.emplace_back(coord[j].x - int(std::floor(u + 0.5f)), coord[j].y - int(std::floor(v + 0.5f)));
            });
            knownGrid.forEachNear(p, reachL, [&](int j) {
              float u, v;
              const int k = cellOf(knownPos[j], knownNormal[j], u, v);
              if (k >= 0) cellSum[k] += knownValue[j], ++cellCount[k];
            });
            Vec3f mean = Vec3f::Zero();
            int filled = 0;
            for (int k = 0; k < kPatch * kPatch; ++k)
              if (cellCount[k]) cellSum[k] /= float(cellCount[k]), mean += cellSum[k], ++filled;
            if (!filled) {
              nextCoord[i] = coord[i];
              continue;
            }
            mean /= float(filled);
            float* x = query.ptr<float>();
            for (int k = 0; k < kPatch * kPatch; ++k) {
              const Vec3f& c = cellCount[k] ? cellSum[k] : mean;
              x[3 * k] = c[0], x[3 * k + 1] = c[1], x[3 * k + 2] = c[2];
            }
            double bestD2 = std::numeric_limits<double>::max();
            cv::Point best = coord[i];
            auto consider = [&](const cv::Point& cand) {
              if (!usable(cand)) return;
              double d2 = 0;
              for (int j = 0; j < kPatch && d2 < bestD2; ++j) {
                const auto* row = ex.lab.ptr<cv::Vec3f>(cand.y + j - kHalf) + cand.x - kHalf;
                for (int k = 0; k < kPatch; ++k) {
                  const int cell = j * kPatch + k;
                  if (cellCount[cell]) d2 += (cellSum[cell] - Vec3f(row[k][0], row[k][1], row[k][2])).squaredNorm();
                }
              }
              if (d2 < bestD2) bestD2 = d2, best = cand;
            };
            // Neighbours in step suggest the same patch: each candidate is measured once.
            std::sort(candidates.begin(), candidates.end(),
                      [](const cv::Point& a, const cv::Point& b) { return a.y != b.y ? a.y < b.y : a.x < b.x; });
            candidates.erase(std::unique(candidates.begin(), candidates.end()), candidates.end());
            for (const cv::Point& cand : candidates) consider(cand);
            // The kd-tree's nearest patch: at the coarser levels always; at the finest, where the coarser levels
            // have set the structure, only for a point its coherent candidates serve badly.
            if (level > 0 || bestD2 > kCoherentEnough * kCoherentEnough * filled) {
              ex.pca.project(query, projected);
              uint32_t nearest = 0;
              float nearestDistance = 0;
              nanoflann::KNNResultSet<float, uint32_t> result(1);
              result.init(&nearest, &nearestDistance);
              ex.tree->findNeighbors(result, projected.ptr<float>(), nanoflann::SearchParams(0, kSearchEps));
              consider(ex.at[std::min<size_t>(nearest, ex.at.size() - 1)]);
            }
            nextCoord[i] = best;
            distance[i] = std::sqrt(bestD2 / filled);
          }
        });
        for (int i : members) coord[i] = nextCoord[i], colour[i] = colourAt(ex, coord[i]);
      }
      energy = m ? std::accumulate(distance.begin(), distance.end(), 0.0) / m : 0;
    }
    for (int i = 0; i < m; ++i) value[pts[i]] = colour[i];
    coarse.points = pts;
    coarse.position = levelPos;
    coarse.coord = coord;
    coarse.size = size;
    coarse.h = h;
    if (level == 0) {
      out.energy = energy;
      out.exemplarWidth = size.width, out.exemplarHeight = size.height;
    }
  }

  std::vector<Vec3f> synthesised(value.begin(), value.begin() + nu);
  const std::vector<Vec3f> rgbOut = convert(synthesised, cv::COLOR_Lab2RGB);

  // The texture between the vertices: the finest level's coordinates in the exemplar at the photo's stored
  // resolution (cell centres scaled back by the level's resampling), the frames in its pixels per unit.
  {
    auto detail = std::make_shared<TextureDetail>();
    cv::Mat rgbMatched;
    cv::cvtColor(lab0, rgbMatched, cv::COLOR_Lab2RGB);
    rgbMatched.convertTo(detail->rgb, CV_8UC3, 255);
    const double rx = double(lab0.cols) / coarse.size.width, ry = double(lab0.rows) / coarse.size.height;
    detail->points.resize(nu);
    out.detailPoint.assign(n, -1);
    for (int i = 0; i < nu; ++i) {
      TextureDetail::Point& p = detail->points[i];
      p.at = Vec2f(float((coarse.coord[i].x + 0.5) * rx - 0.5), float((coarse.coord[i].y + 0.5) * ry - 0.5));
      p.du = tangent[i] * float(rx / h0), p.dv = bitangent[i] * float(ry / h0);
      out.detailPoint[unknownVertex[i]] = i;
    }
    tbb::parallel_for(0, nu, [&](int i) {
      TextureDetail::Point& p = detail->points[i];
      p.colour = detail->sample(p.at.x(), p.at.y());
    });
    out.detail = std::move(detail);
  }
  out.colours = in.fixedValues ? *in.fixedValues : Eigen::MatrixXd::Zero(n, 3);
  if (out.colours.rows() != n) out.colours = Eigen::MatrixXd::Zero(n, 3);
  for (int i = 0; i < nu; ++i)
    out.colours.row(unknownVertex[i]) = rgbOut[i].cwiseMax(0.f).cwiseMin(1.f).cast<double>().transpose();
  out.points = np;
  out.levels = levels;
  out.ok = true;
  char note[256];
  std::snprintf(note, sizeof note,
                "texture: %d vertices synthesised from photo %d (%d x %d texel exemplar%s), %d levels, "
                "energy %.1f",
                nu, photoIndex, out.exemplarWidth, out.exemplarHeight,
                picked           ? ", the region picked"
                : nearestInSpace ? ", the mapped region nearest in space"
                                 : "",
                levels, out.energy);
  out.note = note;
  return out;
}

}  // namespace montage
