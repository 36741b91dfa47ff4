#include "atlas/atlas.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <mutex>
#include <numeric>
#include <queue>
#include <thread>

#if defined(__linux__)
#include <sys/mman.h>
#endif
#include <tbb/parallel_for.h>

#include <Eigen/Geometry>
#include <cstdio>
#include <cstdlib>
#include <opencv2/imgproc.hpp>

#include "base/fileio.h"
#include "base/util.h"
#include "geometry/mesh.h"
#include "geometry/predicates.h"
#include "image/codec.h"
#include "image/photo.h"
#include "surface/inpaint.h"

namespace montage {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

double signedArea2(const std::array<Vec2, 3>& p) {
  return cross2(p[1] - p[0], p[2] - p[0]);
}

// Closed triangle (possibly degenerate: a segment or a point) against the closed box [x0,x1] x [y0,y1],
// by separating axes: the box's two axes and the triangle's edge normals.
bool overlapsBox(const std::array<Vec2, 3>& p, double x0, double y0, double x1, double y1) {
  if (std::max({p[0].x(), p[1].x(), p[2].x()}) < x0 || std::min({p[0].x(), p[1].x(), p[2].x()}) > x1 ||
      std::max({p[0].y(), p[1].y(), p[2].y()}) < y0 || std::min({p[0].y(), p[1].y(), p[2].y()}) > y1)
    return false;
  const Vec2 centre(0.5 * (x0 + x1), 0.5 * (y0 + y1));
  const double hx = 0.5 * (x1 - x0), hy = 0.5 * (y1 - y0);
  for (int k = 0; k < 3; ++k) {
    const Vec2 e = p[(k + 1) % 3] - p[k];
    const Vec2 n(-e.y(), e.x());
    if (n.x() == 0 && n.y() == 0) continue;
    const double a = n.dot(p[k]), b = n.dot(p[(k + 2) % 3]);
    const double c = n.dot(centre), r = hx * std::abs(n.x()) + hy * std::abs(n.y());
    if (std::max(a, b) < c - r || std::min(a, b) > c + r) return false;
  }
  return true;
}

// Distance from q to the boundary of triangle p and the barycentrics of the closest boundary point.
double closestOnBoundary(const std::array<Vec2, 3>& p, const Vec2& q, Vec3& bary) {
  double best = kInf;
  for (int k = 0; k < 3; ++k) {
    const Vec2 a = p[k], e = p[(k + 1) % 3] - a;
    const double len2 = e.squaredNorm();
    const double t = len2 > 0 ? std::clamp((q - a).dot(e) / len2, 0.0, 1.0) : 0.0;
    const double d = (q - (a + t * e)).norm();
    if (d < best) {
      best = d;
      bary.setZero();
      bary[k] = 1 - t;
      bary[(k + 1) % 3] = t;
    }
  }
  return best;
}

// Visits texels of the footprint of triangle p (texel centre within Chebyshev distance 1, see
// atlas.h) inside [x0,x1) x [y0,y1): visit(x, y, distance of the centre to the triangle, barycentrics
// of the closest point of the triangle). Pass Inside visits the texels whose centre is in the
// triangle, pass Band the others, except where skip(x, y) says they are settled already (a chart's
// interior texels are inside some triangle, so its band work shrinks to its border). Works for
// either orientation and for degenerate triangles (which have only a band).
enum class Pass { Inside, Band };
template <class Skip, class Visit>
void footprintTexels(const std::array<Vec2, 3>& p, int x0, int y0, int x1, int y1, Pass pass, Skip&& skip,
                     Visit&& visit) {
  for (const Vec2& q : p)
    if (!q.allFinite()) return;
  const double minX = std::min({p[0].x(), p[1].x(), p[2].x()}), maxX = std::max({p[0].x(), p[1].x(), p[2].x()});
  const double minY = std::min({p[0].y(), p[1].y(), p[2].y()}), maxY = std::max({p[0].y(), p[1].y(), p[2].y()});
  const int tx0 = std::max(x0, static_cast<int>(std::ceil(minX - 1.5))),
            tx1 = std::min(x1 - 1, static_cast<int>(std::floor(maxX + 0.5)));
  const int ty0 = std::max(y0, static_cast<int>(std::ceil(minY - 1.5))),
            ty1 = std::min(y1 - 1, static_cast<int>(std::floor(maxY + 0.5)));
  const double area2 = signedArea2(p);
  // Below this the triangle has no inside worth testing: only its boundary (a segment) counts.
  const bool solid = std::abs(area2) > 1e-12 * std::max(1.0, (maxX - minX) * (maxY - minY));
  // Barycentrics are affine in the texel centre: value at the row start plus a step per texel.
  const auto bary = [&](double x, double y, double& b0, double& b1) {
    const Vec2 q(x, y);
    b0 = cross2(p[1] - q, p[2] - q) / area2;
    b1 = cross2(p[2] - q, p[0] - q) / area2;
  };
  double s0 = 0, s1 = 0;
  if (solid) {
    double a0, a1;
    bary(0.5, 0.5, a0, a1);
    bary(1.5, 0.5, s0, s1);
    s0 -= a0, s1 -= a1;
  }
  for (int y = ty0; y <= ty1; ++y) {
    double b0 = 0, b1 = 0;
    if (solid) bary(tx0 + 0.5, y + 0.5, b0, b1);
    for (int x = tx0; x <= tx1; ++x, b0 += s0, b1 += s1) {
      if (solid && b0 >= 0 && b1 >= 0 && 1 - b0 - b1 >= 0) {
        if (pass == Pass::Inside) visit(x, y, 0.0, Vec3(b0, b1, 1 - b0 - b1));
        continue;
      }
      if (pass == Pass::Inside || skip(x, y) || !overlapsBox(p, x - 0.5, y - 0.5, x + 1.5, y + 1.5)) continue;
      Vec3 b(1, 0, 0);
      const double d = closestOnBoundary(p, Vec2(x + 0.5, y + 0.5), b);
      visit(x, y, d, b);
    }
  }
}

// Edge neighbours of every face: nb[f][k] is the face across the edge from corner k to corner k+1
// (corner order of Mesh::faceVertices), or -1 on the boundary.
std::vector<std::array<int, 3>> faceNeighbours(const Mesh& mesh) {
  const TriMesh& tri = mesh.tri;
  std::vector<std::array<int, 3>> nb(mesh.numFaces(), {-1, -1, -1});
  for (int f = 0; f < mesh.numFaces(); ++f) {
    const auto fv = mesh.faceVertices(f);
    for (const auto h : tri.fh_range(TriMesh::FaceHandle(f))) {
      const int a = tri.from_vertex_handle(h).idx(), b = tri.to_vertex_handle(h).idx();
      const auto g = tri.opposite_face_handle(h);
      for (int k = 0; k < 3; ++k)
        if (fv[k] == a && fv[(k + 1) % 3] == b) nb[f][k] = g.is_valid() ? g.idx() : -1;
    }
  }
  return nb;
}

int cornerOf(const std::array<int, 3>& fv, int v) {
  for (int k = 0; k < 3; ++k)
    if (fv[k] == v) return k;
  return -1;
}

// ------------------------------------------------------------------------------------------------
// Charting

// A chart before packing: its faces and their corner coordinates in "source texels": photo pixels
// for photo charts, texels at the chosen density (scale 1) for LSCM charts; y down in both.
struct ChartSeed {
  int source = kSourceEmpty;
  std::vector<int> faces;
  std::vector<std::array<Vec2, 3>> uv;  // per face of `faces`
  FlatteningQuality quality;
};

// The faces of `set` split in two by growing regions from two far-apart faces (geodesic Voronoi cells
// over face centroids). Both halves are edge-connected and non-empty when `set` is connected and has
// at least two faces; faces unreachable from the seeds go to the second half.
std::pair<std::vector<int>, std::vector<int>> splitInTwo(const std::vector<int>& set, const Mesh& mesh,
                                                         const std::vector<std::array<int, 3>>& nb,
                                                         std::vector<int>& slot, const std::vector<Vec3>& centroid) {
  const int n = static_cast<int>(set.size());
  for (int i = 0; i < n; ++i) slot[set[i]] = i;
  std::vector<double> dist(n);
  std::vector<int> label(n);
  using Item = std::pair<double, int>;
  const auto grow = [&](const std::vector<int>& seeds) {
    std::fill(dist.begin(), dist.end(), kInf);
    std::fill(label.begin(), label.end(), -1);
    std::priority_queue<Item, std::vector<Item>, std::greater<Item>> queue;
    for (size_t s = 0; s < seeds.size(); ++s) {
      dist[seeds[s]] = 0;
      label[seeds[s]] = static_cast<int>(s);
      queue.push({0.0, seeds[s]});
    }
    int last = seeds[0];
    while (!queue.empty()) {
      const auto [d, i] = queue.top();
      queue.pop();
      if (d > dist[i]) continue;
      last = i;
      const int f = set[i];
      for (int g : nb[f]) {
        if (g < 0 || slot[g] < 0) continue;
        const int j = slot[g];
        const double nd = d + (centroid[f] - centroid[g]).norm() + 1e-12;
        if (nd < dist[j]) dist[j] = nd, label[j] = label[i], queue.push({nd, j});
      }
    }
    return last;  // the farthest face reached
  };
  const int a = grow({0});
  int b = grow({a});
  if (b == a) b = (a + 1) % n;
  grow({a, b});
  std::pair<std::vector<int>, std::vector<int>> halves;
  for (int i = 0; i < n; ++i) (label[i] == 0 ? halves.first : halves.second).push_back(set[i]);
  for (int f : set) slot[f] = -1;
  return halves;
}

struct Charting {
  std::vector<ChartSeed> charts;
  int discCuts = 0, stretchSplits = 0, sizeSplits = 0;
  double lscmSeconds = 0;
};

// Flattens one edge-connected non-photo region with LSCM, cutting it into discs and splitting
// charts that flip or stretch too much (work list, so depth is not limited by the stack).
void flattenRegion(const std::vector<int>& region, int source, double density, const Mesh& mesh,
                   const std::vector<std::array<int, 3>>& nb, std::vector<int>& slot, const std::vector<Vec3>& centroid,
                   const AtlasOptions& options, Charting& out) {
  std::vector<std::vector<int>> work = {region};
  std::vector<int> local(mesh.numVertices(), -1);
  while (!work.empty()) {
    std::vector<int> faces = std::move(work.back());
    work.pop_back();
    std::sort(faces.begin(), faces.end());
    std::vector<int> vertices;
    std::vector<std::array<int, 3>> tris;
    tris.reserve(faces.size());
    for (int f : faces) {
      std::array<int, 3> t;
      const auto fv = mesh.faceVertices(f);
      for (int k = 0; k < 3; ++k) {
        if (local[fv[k]] < 0) local[fv[k]] = static_cast<int>(vertices.size()), vertices.push_back(fv[k]);
        t[k] = local[fv[k]];
      }
      tris.push_back(t);
    }
    for (int v : vertices) local[v] = -1;
    const bool canSplit = faces.size() > 1;
    if (canSplit && faces.size() > size_t(std::max(1, options.maxLscmFaces))) {
      ++out.sizeSplits;
      auto [x, y] = splitInTwo(faces, mesh, nb, slot, centroid);
      work.push_back(std::move(x));
      work.push_back(std::move(y));
      continue;
    }
    if (canSplit && !patchTopology(tris).isDisc()) {
      ++out.discCuts;
      auto [x, y] = splitInTwo(faces, mesh, nb, slot, centroid);
      work.push_back(std::move(x));
      work.push_back(std::move(y));
      continue;
    }
    std::vector<Vec3> positions(vertices.size());
    for (size_t i = 0; i < vertices.size(); ++i) positions[i] = mesh.position(vertices[i]);
    const auto t0 = Clock::now();
    const std::vector<Vec2> uv = lscm(positions, tris, options.lscm);
    out.lscmSeconds += secondsSince(t0);
    const FlatteningQuality q = flatteningQuality(positions, tris, uv);
    if (canSplit && (q.flipped > 0 || q.stretchL2 > options.maxChartStretch)) {
      ++out.stretchSplits;
      auto [x, y] = splitInTwo(faces, mesh, nb, slot, centroid);
      work.push_back(std::move(x));
      work.push_back(std::move(y));
      continue;
    }
    // Unit density (model units), then the wanted texels per model unit; v up -> y down.
    std::vector<cv::Point2f> points(uv.size());
    for (size_t i = 0; i < uv.size(); ++i) points[i] = cv::Point2f(float(uv[i].x()), float(uv[i].y()));
    // Turn the chart so that its minimum-area bounding rectangle is axis aligned: the packer works
    // with axis-aligned footprints.
    double angle = 0;
    if (points.size() >= 3) angle = cv::minAreaRect(points).angle * M_PI / 180.0;
    const double c = std::cos(-angle), s = std::sin(-angle), k = q.areaScale * density;
    ChartSeed chart;
    chart.source = source;
    chart.faces = faces;
    chart.quality = q;
    chart.uv.resize(faces.size());
    for (size_t i = 0; i < faces.size(); ++i)
      for (int j = 0; j < 3; ++j) {
        const Vec2& p = uv[tris[i][j]];
        chart.uv[i][j] = Vec2(k * (c * p.x() - s * p.y()), -k * (s * p.x() + c * p.y()));
      }
    out.charts.push_back(std::move(chart));
  }
}

Charting makeCharts(const Mesh& mesh, const AtlasInput& in, const AtlasOptions& options) {
  const int F = mesh.numFaces();
  const auto nb = faceNeighbours(mesh);
  std::vector<Vec3> centroid(F);
  for (int f = 0; f < F; ++f) {
    const auto q = mesh.facePositions(f);
    centroid[f] = (q[0] + q[1] + q[2]) / 3;
  }
  // Density of photo faces (pixels per model unit), the default for LSCM charts.
  double photoArea = 0, photoArea3 = 0, totalArea3 = 0;
  for (int f = 0; f < F; ++f) {
    totalArea3 += mesh.faceArea(f);
    if (in.faceSource[f] < 0) continue;
    photoArea += 0.5 * std::abs(signedArea2(in.cornerUV[f]));
    photoArea3 += mesh.faceArea(f);
  }
  const double defaultDensity = photoArea > 0 && photoArea3 > 0 ? std::sqrt(photoArea / photoArea3)
                                : totalArea3 > 0                ? std::sqrt(1e6 / totalArea3)
                                                                : 1.0;

  // Two faces of one photo are in one chart when they share an edge whose two corners have the same
  // photo coordinates in both (continuous texture); faces of the other kinds when they share an edge.
  const auto sameChart = [&](int f, int k, int g) {
    if (in.faceSource[f] != in.faceSource[g]) return false;
    if (!in.faceGroup.empty() && in.faceGroup[f] != in.faceGroup[g]) return false;
    if (in.faceSource[f] < 0) return true;
    const auto fv = mesh.faceVertices(f), gv = mesh.faceVertices(g);
    for (int j = 0; j < 2; ++j) {
      const int v = fv[(k + j) % 3], kg = cornerOf(gv, v);
      if (kg < 0) return false;
      const Vec2& a = in.cornerUV[f][(k + j) % 3];
      const Vec2& b = in.cornerUV[g][kg];
      if ((a - b).cwiseAbs().maxCoeff() > 1e-6 * (1 + a.cwiseAbs().maxCoeff())) return false;
    }
    return true;
  };
  Charting out;
  std::vector<int> component(F, -1), slot(F, -1);
  for (int start = 0; start < F; ++start) {
    if (component[start] >= 0) continue;
    std::vector<int> faces = {start};
    component[start] = start;
    for (size_t i = 0; i < faces.size(); ++i) {
      const int f = faces[i];
      for (int k = 0; k < 3; ++k) {
        const int g = nb[f][k];
        if (g >= 0 && component[g] < 0 && sameChart(f, k, g)) component[g] = start, faces.push_back(g);
      }
    }
    const int source = in.faceSource[start];
    if (source >= 0) {
      std::sort(faces.begin(), faces.end());
      ChartSeed chart;
      chart.source = source;
      chart.faces = faces;
      for (int f : faces) chart.uv.push_back(in.cornerUV[f]);
      out.charts.push_back(std::move(chart));
      continue;
    }
    double density = 0, weight = 0;
    if (!in.faceDensity.empty())
      for (int f : faces)
        if (in.faceDensity[f] > 0) density += mesh.faceArea(f) * in.faceDensity[f], weight += mesh.faceArea(f);
    density = weight > 0 ? density / weight : defaultDensity;
    if (source == kSourceEmpty) density *= options.emptyDensity;
    flattenRegion(faces, source, density, mesh, nb, slot, centroid, options, out);
  }
  return out;
}

// ------------------------------------------------------------------------------------------------
// Packing

// Charts are placed on a grid of cells (cell x cell texels). Per chart and scale: which cells its
// footprint touches (F) and which are within `gutter` texels of the footprint (D). Two charts keep
// their gutter when the F cells of one never meet the D cells of the other.
//
// Column profile of one orientation: per column the first and last F row and the first and last D
// row (-1 when the column has none). The packer treats each column's F and D cells as these spans,
// which is conservative for shapes that are not convex along columns.
struct Profile {
  int w = 0, h = 0;
  std::vector<int> fTop, fBottom, dTop, dBottom;
  int fLeft = 0, fRight = -1, fBottomMax = -1;
};

// A chart's frame at one scale: its size in cells and its profiles upright and turned by 90 degrees
// (turned, cell (i, j) of the upright frame goes to column h-1-j, row i; see placeChart).
struct ChartCells {
  int w = 0, h = 0;   // cells of the upright frame
  double margin = 0;  // texels between the cell frame and the chart's bounding box
  Profile upright, turned;
};

struct PackSetup {
  int size = 0, gutter = 0, cell = 1, grid = 0;
  int lo = 0, hi = 0;  // cells [lo, hi) may hold footprint cells in either direction
};

// The extent along the other axis of the closed triangle p within the closed band b0 <= x[a] <= b1;
// false when the triangle misses the band. The triangle (or a degenerate one: a segment, a point)
// meets the closed box band x [lo', hi'] exactly when [lo, hi] meets [lo', hi'].
bool bandExtent(const std::array<Vec2, 3>& p, int a, double b0, double b1, double& lo, double& hi) {
  const int o = 1 - a;
  lo = kInf, hi = -kInf;
  for (int k = 0; k < 3; ++k) {
    const Vec2 &u = p[k], &v = p[(k + 1) % 3];
    if (u[a] >= b0 && u[a] <= b1) lo = std::min(lo, u[o]), hi = std::max(hi, u[o]);
    for (const double b : {b0, b1})
      if ((u[a] < b && v[a] > b) || (u[a] > b && v[a] < b)) {
        const double y = u[o] + (b - u[a]) / (v[a] - u[a]) * (v[o] - u[o]);
        lo = std::min(lo, y), hi = std::max(hi, y);
      }
  }
  return lo <= hi;
}

// The cells of chart c at scale s. Local texel coordinates: s * (uv - min) + margin. Cell (i, j) is F
// when the closed triangle meets its box grown by half a texel, D when it meets it grown by the gutter
// too. Per triangle, one band per column and one per row of cells: each gives the range of cells the
// triangle meets in that column (row), so only the ends matter.
ChartCells chartCells(const ChartSeed& chart, const Vec2& lo, const Vec2& hi, double s, const PackSetup& setup) {
  ChartCells out;
  const int c = setup.cell;
  out.margin = setup.gutter + 2.0;
  const int w = out.w = std::max(1, static_cast<int>(std::ceil((s * (hi.x() - lo.x()) + 2 * out.margin) / c)));
  const int h = out.h = std::max(1, static_cast<int>(std::ceil((s * (hi.y() - lo.y()) + 2 * out.margin) / c)));
  // [F, D][first, last] cell per column (over rows j) and per row (over columns i).
  std::vector<int> column[2][2], row[2][2];
  for (int t = 0; t < 2; ++t) {
    column[t][0].assign(w, std::numeric_limits<int>::max()), column[t][1].assign(w, -1);
    row[t][0].assign(h, std::numeric_limits<int>::max()), row[t][1].assign(h, -1);
  }
  const double eps = 1e-6;  // rounding slack: the footprint test of the bake is exact
  const double fPad = 0.5 + eps, pads[2] = {fPad, fPad + setup.gutter};
  const int extent[2] = {w, h};
  for (const auto& uv : chart.uv) {
    std::array<Vec2, 3> p;
    for (int k = 0; k < 3; ++k) p[k] = s * (uv[k] - lo) + Vec2(out.margin, out.margin);
    Vec2 pmin = p[0].cwiseMin(p[1]).cwiseMin(p[2]), pmax = p[0].cwiseMax(p[1]).cwiseMax(p[2]);
    for (int t = 0; t < 2; ++t) {
      const double pad = pads[t];
      int first[2], last[2];  // the cells of the grown bounding box, per axis
      for (int a = 0; a < 2; ++a) {
        first[a] = std::max(0, static_cast<int>(std::floor((pmin[a] - pad) / c)));
        last[a] = std::min(extent[a] - 1, static_cast<int>(std::floor((pmax[a] + pad) / c)));
      }
      // Axis a = 0: bands of columns, ranges of rows; a = 1: bands of rows, ranges of columns.
      for (int a = 0; a < 2; ++a) {
        std::vector<int>(&ends)[2] = a == 0 ? column[t] : row[t];
        const int o = 1 - a;
        for (int i = first[a]; i <= last[a]; ++i) {
          double e0, e1;
          if (!bandExtent(p, a, i * c - pad, i * c + c + pad, e0, e1)) continue;
          // Cells k whose grown box [k c - pad, k c + c + pad] meets [e0, e1].
          const int k0 = std::max(first[o], static_cast<int>(std::ceil((e0 - pad - c) / c)));
          const int k1 = std::min(last[o], static_cast<int>(std::floor((e1 + pad) / c)));
          if (k0 > k1) continue;
          ends[0][i] = std::min(ends[0][i], k0);
          ends[1][i] = std::max(ends[1][i], k1);
        }
      }
    }
  }
  // Profiles; turned, upright row j becomes column h-1-j and its columns i become rows.
  const auto profile = [](Profile& pr, int pw, int ph, const std::vector<int>(&f)[2], const std::vector<int>(&d)[2],
                          bool reversed) {
    pr.w = pw, pr.h = ph;
    pr.fTop.assign(pw, -1), pr.fBottom.assign(pw, -1), pr.dTop.assign(pw, -1), pr.dBottom.assign(pw, -1);
    pr.fLeft = pw;
    for (int i = 0; i < pw; ++i) {
      const int src = reversed ? pw - 1 - i : i;
      if (d[1][src] >= 0) pr.dTop[i] = d[0][src], pr.dBottom[i] = d[1][src];
      if (f[1][src] < 0) continue;
      pr.fTop[i] = f[0][src], pr.fBottom[i] = f[1][src];
      pr.fLeft = std::min(pr.fLeft, i), pr.fRight = std::max(pr.fRight, i);
      pr.fBottomMax = std::max(pr.fBottomMax, f[1][src]);
    }
  };
  profile(out.upright, w, h, column[0], column[1], false);
  profile(out.turned, h, w, row[0], row[1], true);
  return out;
}

struct Placement {
  int x = 0, y = 0;  // cell of the frame's top-left corner (x may be negative: only D cells go there)
  bool rotated = false;
  ChartCells cells;
};

// Occupied cells of the atlas grid: per column, sorted disjoint spans of rows [first, last].
class ColumnSpans {
 public:
  // Rows above `lo` are the border gutter: occupied from the start. There is no bottom: the packer
  // places everything and reports how many rows it needed.
  ColumnSpans(int columns, int lo) : spans_(columns) {
    if (lo > 0)
      for (auto& c : spans_) c.push_back({0, lo - 1});
  }
  // The smallest y' >= y such that rows [y' + top, y' + bottom] of column col are free.
  int firstFree(int col, int y, int top, int bottom) const {
    const auto& c = spans_[col];
    auto it = std::lower_bound(c.begin(), c.end(), y + top,
                               [](const std::pair<int, int>& s, int row) { return s.second < row; });
    for (; it != c.end() && it->first <= y + bottom; ++it) y = it->second + 1 - top;
    return y;
  }
  void occupy(int col, int first, int last) {
    auto& c = spans_[col];
    auto it = std::lower_bound(c.begin(), c.end(), first - 1,
                               [](const std::pair<int, int>& s, int row) { return s.second < row; });
    // Merge every span that overlaps or touches [first, last].
    auto end = it;
    while (end != c.end() && end->first <= last + 1) {
      first = std::min(first, end->first);
      last = std::max(last, end->second);
      ++end;
    }
    it = c.erase(it, end);
    c.insert(it, {first, last});
  }

 private:
  std::vector<std::vector<std::pair<int, int>>> spans_;
};

// Bottom-left packing on the cell grid: charts, largest first, go to the position where their
// bottom is highest in the atlas (lowest row), searching every column and both orientations, holes
// under earlier charts included. Per column the grid keeps its occupied spans, so a query costs a
// binary search; a candidate column stops as soon as it cannot beat the best position found.
// Returns the rows of cells the packing needs (last footprint row + 1; it fits when that is at most
// setup.hi), or +inf when a chart is wider than the atlas in both orientations.
double packAtScale(const std::vector<ChartSeed>& charts, const std::vector<std::pair<Vec2, Vec2>>& bounds, double s,
                   const PackSetup& setup, const AtlasOptions& options, std::vector<Placement>& placements,
                   std::size_t& signature) {
  const int n = static_cast<int>(charts.size());
  placements.assign(n, {});
  tbb::parallel_for(
      0, n, [&](int i) { placements[i].cells = chartCells(charts[i], bounds[i].first, bounds[i].second, s, setup); });
  std::vector<int> order(n);
  signature = 0;
  for (const Placement& pl : placements) {
    for (const Profile* p : {&pl.cells.upright, &pl.cells.turned})
      for (const std::vector<int>* v : {&p->fTop, &p->fBottom, &p->dTop, &p->dBottom})
        for (int x : *v) signature = signature * 31 + std::size_t(x + 1);
    signature = signature * 1000003u + static_cast<std::size_t>(pl.cells.w) * 8191u + pl.cells.h;
  }
  // Tallest (longer side of the frame, in cells, as charts may turn) first; within a size class
  // (about 12%) charts of one photo go one after the other so that they land near each other.
  std::iota(order.begin(), order.end(), 0);
  const auto sizeClass = [&](int i) {
    const int side = std::max(placements[i].cells.w, placements[i].cells.h);
    return static_cast<int>(std::floor(std::log(double(side)) / std::log(1.12)));
  };
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    const int ca = sizeClass(a), cb = sizeClass(b);
    if (ca != cb) return ca > cb;
    if (charts[a].source != charts[b].source) return charts[a].source > charts[b].source;
    return placements[a].cells.w * placements[a].cells.h > placements[b].cells.w * placements[b].cells.h;
  });

  const int G = setup.grid;
  ColumnSpans grid(G, setup.lo);
  int needed = setup.lo;
  const int affinity = std::max(0, options.photoAffinityTexels / setup.cell);
  std::map<int, std::pair<double, int>> photoCentre;  // source -> (sum of centre x, count)
  std::vector<int> cols;
  constexpr int kNoBottom = std::numeric_limits<int>::max() / 4;  // room for "+ affinity" without overflow
  for (int idx : order) {
    const ChartSeed& chart = charts[idx];
    struct Best {
      int x = 0, y = 0, bottom = kNoBottom;
      bool rotated = false;
      double distance = kInf;
    } best;
    const auto centre = photoCentre.find(chart.source);
    for (int o = 0; o < (options.rotateCharts ? 2 : 1); ++o) {
      const Profile& p = o == 0 ? placements[idx].cells.upright : placements[idx].cells.turned;
      if (p.fRight < 0) continue;  // no footprint at all (cannot happen for a chart with faces)
      // Footprint columns, the highest-reaching first: they usually decide where the chart rests.
      cols.clear();
      for (int i = p.fLeft; i <= p.fRight; ++i)
        if (p.fTop[i] >= 0) cols.push_back(i);
      std::sort(cols.begin(), cols.end(), [&](int a, int b) { return p.fTop[a] < p.fTop[b]; });
      const int fTopMin = p.fTop[cols.front()];
      for (int x = setup.lo - p.fLeft; x + p.fRight < setup.hi; ++x) {
        const int limit = best.bottom + affinity - p.fBottomMax;  // a larger y cannot win
        // The lowest y >= the top at which every column is free: go round the columns until all of
        // them, since the last one that moved y, accept it.
        int y = setup.lo - fTopMin;
        const int m = static_cast<int>(cols.size());
        for (int k = 0, accepted = 0; accepted < m && y <= limit; k = k + 1 == m ? 0 : k + 1) {
          const int i = cols[k];
          const int y2 = grid.firstFree(x + i, y, p.fTop[i], p.fBottom[i]);
          accepted = y2 == y ? accepted + 1 : 1;
          y = y2;
        }
        if (y > limit) continue;
        const int bottom = y + p.fBottomMax;
        double distance = 0;
        if (centre != photoCentre.end())
          distance = std::abs((x + 0.5 * p.w) - centre->second.first / centre->second.second);
        // Highest bottom wins, except that a chart of a photo already placed may take a position up
        // to `affinity` cells lower when it is nearer to that photo's charts.
        const bool better =
            centre == photoCentre.end()
                ? bottom < best.bottom
                : (bottom + affinity < best.bottom || (bottom <= best.bottom + affinity && distance < best.distance));
        if (better) best = {x, y, bottom, o == 1, distance};
      }
    }
    if (best.bottom == kNoBottom) return kInf;
    needed = std::max(needed, best.bottom + 1);
    Placement& pl = placements[idx];
    pl.x = best.x;
    pl.y = best.y;
    pl.rotated = best.rotated;
    const Profile& p = best.rotated ? pl.cells.turned : pl.cells.upright;
    for (int i = 0; i < p.w; ++i)
      if (p.dBottom[i] >= 0 && best.x + i >= 0 && best.x + i < G)
        grid.occupy(best.x + i, best.y + p.dTop[i], best.y + p.dBottom[i]);
    auto& pc = photoCentre[chart.source];
    pc.first += best.x + 0.5 * p.w;
    pc.second += 1;
  }
  return needed;
}

}  // namespace

// --------------------------------------------------------------------------------------------------

AtlasInput atlasInput(const Mesh& mesh, const TextureMap& map, const std::vector<std::shared_ptr<const Photo>>& photos,
                      const InpaintResult* inpaint) {
  const int F = mesh.numFaces();
  TM_CHECK(map.numFaces() == F && static_cast<int>(map.cornerUV.size()) == F,
           "atlas: the texture map has " + std::to_string(map.numFaces()) + " faces, the mesh " + std::to_string(F));
  TM_CHECK(!inpaint || static_cast<int>(inpaint->faceRegion.size()) == F,
           "atlas: the inpainting result has " + std::to_string(inpaint ? inpaint->faceRegion.size() : 0) +
               " faces, the mesh " + std::to_string(F));
  AtlasInput in;
  in.faceSource.resize(F);
  in.cornerUV = map.cornerUV;
  for (const auto& p : photos) {
    TM_CHECK(p != nullptr, "atlas: a photo is missing");
    in.photoSizes.push_back(cv::Size(p->width, p->height));
  }
  if (inpaint) in.faceDensity.assign(F, 0.0);
  for (int f = 0; f < F; ++f) {
    const int region = inpaint ? inpaint->faceRegion[f] : -1;
    if (region >= 0) {
      TM_CHECK(region < static_cast<int>(inpaint->regions.size()),
               "atlas: face " + std::to_string(f) + " is in inpainted region " + std::to_string(region) + " of only " +
                   std::to_string(inpaint->regions.size()));
      in.faceSource[f] = kSourceInpainted;
      in.faceDensity[f] = inpaint->regions[region].texelsPerUnit;
    } else {
      in.faceSource[f] = map.facePhoto[f] >= 0 ? map.facePhoto[f] : kSourceEmpty;
    }
  }
  return in;
}

nlohmann::json Atlas::stats() const {
  return {{"size", size},
          {"gutter", gutter},
          {"scale", scale},
          {"charts", charts.size()},
          {"photo_charts", photoCharts},
          {"lscm_charts", lscmCharts},
          {"disc_cuts", discCuts},
          {"stretch_splits", stretchSplits},
          {"size_splits", sizeSplits},
          {"pack_attempts", packAttempts},
          {"utilisation", utilisation},
          {"seconds", {{"charts", times.charts}, {"lscm", times.lscm}, {"pack", times.pack}}}};
}

Atlas buildAtlas(const Mesh& mesh, const AtlasInput& in, const AtlasOptions& options,
                 const std::function<void(double)>& progress) {
  const int F = mesh.numFaces();
  TM_CHECK(options.size == 0 || (options.size >= kMinAtlasSize && options.size <= kMaxAtlasSize),
           "atlas: size " + std::to_string(options.size) + " is neither 0 (automatic) nor in [" +
               std::to_string(kMinAtlasSize) + ", " + std::to_string(kMaxAtlasSize) + "]");
  TM_CHECK(options.gutter >= 0 && options.gutter <= 64,
           "atlas: gutter " + std::to_string(options.gutter) + " is outside [0, 64] texels");
  TM_CHECK(options.maxScale >= 0 && std::isfinite(options.maxScale),
           "atlas: maxScale " + std::to_string(options.maxScale) + " must be 0 (no limit) or positive");
  TM_CHECK(options.maxChartStretch >= 1,
           "atlas: maxChartStretch " + std::to_string(options.maxChartStretch) + " must be at least 1 (1 = isometric)");
  TM_CHECK(options.emptyDensity > 0 && options.emptyDensity <= 1,
           "atlas: emptyDensity " + std::to_string(options.emptyDensity) + " must be in (0, 1]");
  TM_CHECK(
      static_cast<int>(in.faceSource.size()) == F,
      "atlas: faceSource has " + std::to_string(in.faceSource.size()) + " entries for " + std::to_string(F) + " faces");
  TM_CHECK(
      in.faceGroup.empty() || static_cast<int>(in.faceGroup.size()) == F,
      "atlas: faceGroup has " + std::to_string(in.faceGroup.size()) + " entries for " + std::to_string(F) + " faces");
  TM_CHECK(in.faceDensity.empty() || static_cast<int>(in.faceDensity.size()) == F,
           "atlas: faceDensity has " + std::to_string(in.faceDensity.size()) + " entries for " + std::to_string(F) +
               " faces");
  for (int f = 0; f < F; ++f) {
    const int s = in.faceSource[f];
    const std::string face = "atlas: face " + std::to_string(f);
    TM_CHECK(s >= 0 || s == kSourceInpainted || s == kSourceEmpty, face + ": invalid source " + std::to_string(s));
    if (!in.faceDensity.empty())
      TM_CHECK(std::isfinite(in.faceDensity[f]) && in.faceDensity[f] >= 0,
               face + ": density hint must be finite and >= 0");
    if (s < 0) continue;
    TM_CHECK(s < static_cast<int>(in.photoSizes.size()), face + ": photo " + std::to_string(s) + " has no size (" +
                                                             std::to_string(in.photoSizes.size()) + " photos)");
    TM_CHECK(in.photoSizes[s].width > 0 && in.photoSizes[s].height > 0,
             "atlas: photo " + std::to_string(s) + " has an empty size");
    TM_CHECK(static_cast<int>(in.cornerUV.size()) == F, "atlas: cornerUV has " + std::to_string(in.cornerUV.size()) +
                                                            " entries for " + std::to_string(F) + " faces");
    for (const Vec2& uv : in.cornerUV[f]) TM_CHECK(uv.allFinite(), face + ": photo coordinates are not finite");
  }

  Atlas atlas;
  atlas.gutter = options.gutter;
  atlas.faceSource = in.faceSource;
  atlas.faceChart.assign(F, -1);
  atlas.cornerUV.assign(F, {Vec2::Zero(), Vec2::Zero(), Vec2::Zero()});
  if (progress) progress(0.0);

  auto t0 = Clock::now();
  Charting charting = makeCharts(mesh, in, options);
  atlas.times.lscm = charting.lscmSeconds;
  atlas.times.charts = secondsSince(t0) - charting.lscmSeconds;
  atlas.discCuts = charting.discCuts;
  atlas.stretchSplits = charting.stretchSplits;
  atlas.sizeSplits = charting.sizeSplits;
  if (progress) progress(0.4);

  // Packing.
  t0 = Clock::now();
  const auto& charts = charting.charts;
  const int n = static_cast<int>(charts.size());
  std::vector<std::pair<Vec2, Vec2>> bounds(n);
  double area = 0;  // chart area at scale 1
  for (int i = 0; i < n; ++i) {
    Vec2 lo = Vec2::Constant(kInf), hi = Vec2::Constant(-kInf);
    for (const auto& uv : charts[i].uv)
      for (const Vec2& p : uv) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    bounds[i] = {lo, hi};
    for (const auto& uv : charts[i].uv) area += 0.5 * std::abs(signedArea2(uv));
  }
  auto setupFor = [&](int size) {
    PackSetup setup;
    setup.size = size;
    setup.gutter = options.gutter;
    setup.cell = std::max(1, size / 1024);
    setup.grid = (size + setup.cell - 1) / setup.cell;
    setup.lo = (options.gutter + setup.cell - 1) / setup.cell;
    setup.hi = (size - options.gutter) / setup.cell;
    return setup;
  };
  std::vector<Placement> placements, bestPlacements;
  double bestScale = 0;
  std::size_t signature = 0, failedSignature = 0;
  PackSetup setup = setupFor(options.size > 0 ? options.size : kMaxAtlasSize);
  double maxScale = options.maxScale;
  if (options.size == 0 && n > 0) {
    // Automatic size: the smallest multiple of kAtlasSizeStep that holds every chart at its own
    // density (scale 1: a texel per photo pixel), starting from the chart area at a typical packing
    // density and growing by what the packer says it lacked. When even kMaxAtlasSize is too small,
    // the charts shrink to fit it (the search below).
    maxScale = 1;
    auto roundUp = [](double x) {
      return std::max(kMinAtlasSize, int(std::ceil(x / kAtlasSizeStep)) * kAtlasSizeStep);
    };
    int size = roundUp(std::sqrt(area / 0.7) + 2 * options.gutter);
    while (size <= kMaxAtlasSize) {
      setup = setupFor(size);
      ++atlas.packAttempts;
      const double needed = packAtScale(charts, bounds, 1.0, setup, options, placements, signature) - setup.lo;
      const double usable = setup.hi - setup.lo;
      if (needed <= usable) {
        bestScale = 1, bestPlacements = placements;
        break;
      }
      const int next = roundUp(size * std::sqrt(std::isfinite(needed) ? needed / usable : 2.0) * 1.01);
      if (size == kMaxAtlasSize) break;
      size = std::min(kMaxAtlasSize, std::max(next, size + kAtlasSizeStep));
    }
    if (bestScale == 0) setup = setupFor(kMaxAtlasSize);
  }
  atlas.size = setup.size;
  // Fixed size (or automatic beyond the largest): the largest global scale at which the packer
  // succeeds. The packing fills the atlas from the top, so the rows it needs tell how far the scale is
  // from a tight fit: the next scale is the current one times sqrt(usable rows / needed rows), kept
  // inside the bracket [largest scale that fit, smallest that did not]. Three to six packings, not a
  // bisection's ten.
  const double usableRows = setup.hi - setup.lo;
  if (n > 0 && bestScale == 0) {
    // First guess: charts covering 65% of the atlas (a typical packing density).
    double s = area > 0 ? std::sqrt(0.65 * usableRows * usableRows * setup.cell * setup.cell / area) : 1.0;
    double sLo = 0, sHi = kInf;
    bool stuck = false;
    for (int k = 0; k < 40; ++k) {
      if (maxScale > 0) s = std::min(s, maxScale);
      ++atlas.packAttempts;
      if (progress) progress(std::min(0.75, 0.4 + 0.03 * atlas.packAttempts));
      const double needed = packAtScale(charts, bounds, s, setup, options, placements, signature) - setup.lo;
      const bool fits = needed <= usableRows;
      if (fits) {
        if (s > bestScale) bestScale = s, bestPlacements = placements;
        sLo = std::max(sLo, s);
      } else {
        // Every chart keeps at least a cell and its gutter however small it gets: when shrinking no
        // longer changes any chart's cells, nothing smaller will fit either.
        stuck = sHi < kInf && signature == failedSignature;
        failedSignature = signature;
        sHi = std::min(sHi, s);
        if (stuck) break;
      }
      if (maxScale > 0 && sLo >= maxScale) break;
      // Good enough: the packing fills at least 97% of the rows (the scale is within about 1.5% of
      // the tightest fit, closer than the packer's own run-to-run variation), or the bracket is tight.
      if (fits && needed >= 0.97 * usableRows) break;
      if (sLo > 0 && sHi / sLo < 1.015) break;
      // Estimate from the rows needed, aiming 1.5% below it so that the estimate itself tends to fit.
      double next = std::isfinite(needed) && needed > 0 ? s * std::sqrt(usableRows / needed) * 0.985 : s / 2;
      if (fits && next <= s) next = s * 1.01;
      if (next >= sHi || next <= sLo) next = sLo > 0 ? std::sqrt(sLo * std::min(sHi, 2 * sLo)) : sHi / 2;
      s = next;
    }
    TM_CHECK(bestScale > 0, "atlas: " + std::to_string(n) + " charts do not fit into a " + std::to_string(setup.size) +
                                "x" + std::to_string(setup.size) + " atlas with a " + std::to_string(options.gutter) +
                                "-texel gutter even at a tiny scale: use a larger atlas or a smaller gutter");
  }
  if (n == 0 && options.size == 0) atlas.size = kMinAtlasSize;
  atlas.scale = bestScale;
  atlas.times.pack = secondsSince(t0);
  if (progress) progress(0.8);

  // Atlas coordinates of every corner; chart rectangles and photo transforms.
  double coveredArea = 0;
  for (int i = 0; i < n; ++i) {
    const ChartSeed& seed = charts[i];
    const Placement& pl = bestPlacements[i];
    const double s = bestScale, m = pl.cells.margin;
    const Vec2 offset(pl.x * setup.cell, pl.y * setup.cell);
    const double frameH = pl.cells.h * setup.cell;
    const Vec2 lo = bounds[i].first;
    // local = s (p - lo) + m; turned: (frameH - local.y, local.x); atlas = turned + offset.
    const auto toAtlas = [&](const Vec2& p) -> Vec2 {
      const Vec2 local = s * (p - lo) + Vec2(m, m);
      return (pl.rotated ? Vec2(frameH - local.y(), local.x()) : local) + offset;
    };
    AtlasChart chart;
    chart.source = seed.source;
    chart.faces = seed.faces;
    chart.rotated = pl.rotated;
    chart.quality = seed.quality;
    Vec2 amin = Vec2::Constant(kInf), amax = Vec2::Constant(-kInf);
    for (size_t j = 0; j < seed.faces.size(); ++j) {
      const int f = seed.faces[j];
      for (int k = 0; k < 3; ++k) {
        atlas.cornerUV[f][k] = toAtlas(seed.uv[j][k]);
        amin = amin.cwiseMin(atlas.cornerUV[f][k]);
        amax = amax.cwiseMax(atlas.cornerUV[f][k]);
      }
      atlas.faceChart[f] = i;
      coveredArea += 0.5 * std::abs(signedArea2(atlas.cornerUV[f]));
    }
    // The footprint's texel range (see footprintTexels), clipped to the atlas.
    const int x0 = std::max(0, static_cast<int>(std::ceil(amin.x() - 1.5)));
    const int y0 = std::max(0, static_cast<int>(std::ceil(amin.y() - 1.5)));
    const int x1 = std::min(atlas.size - 1, static_cast<int>(std::floor(amax.x() + 0.5)));
    const int y1 = std::min(atlas.size - 1, static_cast<int>(std::floor(amax.y() + 0.5)));
    chart.x = x0;
    chart.y = y0;
    chart.width = x1 - x0 + 1;
    chart.height = y1 - y0 + 1;
    if (seed.source >= 0) {
      // Inverse of toAtlas: p = lo + (local - m) / s, local = a - offset (or turned back).
      Eigen::Matrix<double, 2, 3> T;
      if (!pl.rotated)
        T << 1 / s, 0, lo.x() - (offset.x() + m) / s, 0, 1 / s, lo.y() - (offset.y() + m) / s;
      else  // local.x = a.y - offset.y, local.y = frameH - (a.x - offset.x)
        T << 0, 1 / s, lo.x() - (offset.y() + m) / s, -1 / s, 0, lo.y() + (frameH + offset.x() - m) / s;
      chart.toPhoto = T;
      ++atlas.photoCharts;
    } else {
      ++atlas.lscmCharts;
    }
    atlas.charts.push_back(std::move(chart));
  }
  atlas.utilisation = coveredArea / (double(atlas.size) * atlas.size);
  if (progress) progress(1.0);
  return atlas;
}

// --------------------------------------------------------------------------------------------------
// Baking

namespace {

// A triangle to rasterise into the atlas: its atlas corners and per-corner colours, which are an
// additive offset on top of the photo for photo charts and the colour itself otherwise.
struct BakeTriangle {
  std::array<Vec2, 3> p;
  std::array<Vec3f, 3> c;
  int refined = -1;  // a refined triangle with synthesised texture between its vertices (InpaintResult::colourAt)
};

// An uninitialised image for the atlas's full-size buffers. On Linux, transparent huge pages are
// requested before the first touch: on virtual machines the page faults of the ~200 MB a 4096^2 bake
// touches cost more than the bake itself (measured: 0.46 s for 150 MB with 4 KiB pages, 0.13 s with
// huge pages).
cv::Mat largeMat(int rows, int cols, int type) {
  cv::Mat m(rows, cols, type);
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  const uintptr_t page = uintptr_t(2) << 20;
  const uintptr_t begin = (reinterpret_cast<uintptr_t>(m.data) + page - 1) & ~(page - 1);
  const uintptr_t end = reinterpret_cast<uintptr_t>(m.data + m.total() * m.elemSize()) & ~(page - 1);
  if (end > begin) madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);  // a hint: failure is harmless
#endif
  return m;
}

// Gutters and free space take the colour of the nearest texel some chart wrote, so that bilinear
// lookups and every mip level see chart colours only. Nearest texels come from two raster sweeps
// (forward with the left and upper neighbours, backward with the right and lower ones) that pass on
// each neighbour's nearest source, keeping the closest: Danielsson's vector propagation, exact up to
// rare off-by-a-texel choices, which do not matter for a fill colour.
void fillFromNearest(cv::Mat& rgba, const cv::Mat& chart) {
  const int W = rgba.cols, H = rgba.rows;
  constexpr uint32_t kNone = 0xFFFFFFFFu;
  cv::Mat nearMat = largeMat(H, W, CV_32SC1);  // source texel as x | y << 16
  uint32_t* near = reinterpret_cast<uint32_t*>(nearMat.data);
  bool any = false;
  for (int y = 0; y < H; ++y) {
    const int* c = chart.ptr<int>(y);
    uint32_t* n = near + static_cast<size_t>(y) * W;
    for (int x = 0; x < W; ++x) {
      n[x] = c[x] >= 0 ? uint32_t(x) | uint32_t(y) << 16 : kNone;
      any = any || c[x] >= 0;
    }
  }
  if (!any) return;
  const auto dist2 = [](uint32_t src, int x, int y) {
    const long dx = x - long(src & 0xFFFF), dy = y - long(src >> 16);
    return dx * dx + dy * dy;
  };
  const auto sweep = [&](int y, int x, uint32_t& cur, const int(*offsets)[2]) {
    long best = cur == kNone ? std::numeric_limits<long>::max() : dist2(cur, x, y);
    for (int k = 0; k < 4; ++k) {
      const int xx = x + offsets[k][0], yy = y + offsets[k][1];
      if (xx < 0 || yy < 0 || xx >= W || yy >= H) continue;
      const uint32_t cand = near[static_cast<size_t>(yy) * W + xx];
      if (cand == kNone) continue;
      const long d = dist2(cand, x, y);
      if (d < best) best = d, cur = cand;
    }
  };
  static const int forward[4][2] = {{-1, 0}, {-1, -1}, {0, -1}, {1, -1}};
  static const int backward[4][2] = {{1, 0}, {1, 1}, {0, 1}, {-1, 1}};
  for (int y = 0; y < H; ++y) {
    const int* c = chart.ptr<int>(y);
    for (int x = 0; x < W; ++x)
      if (c[x] < 0) sweep(y, x, near[static_cast<size_t>(y) * W + x], forward);
  }
  for (int y = H - 1; y >= 0; --y) {
    const int* c = chart.ptr<int>(y);
    cv::Vec4b* row = rgba.ptr<cv::Vec4b>(y);
    for (int x = W - 1; x >= 0; --x) {
      if (c[x] >= 0) continue;
      uint32_t& cur = near[static_cast<size_t>(y) * W + x];
      sweep(y, x, cur, backward);
      if (cur != kNone) row[x] = rgba.ptr<cv::Vec4b>(cur >> 16)[cur & 0xFFFF];
    }
  }
}

// Runs bake(chart index) for every chart on `threads` threads (0 = all cores), largest charts first.
// Footprints are disjoint, so threads write disjoint texels. The first exception stops the others and
// is rethrown.
void forEachChart(const Atlas& atlas, int threads, const std::function<void(int)>& bake) {
  std::vector<int> order(atlas.charts.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    return double(atlas.charts[a].width) * atlas.charts[a].height >
           double(atlas.charts[b].width) * atlas.charts[b].height;
  });
  const int n = std::max(1, std::min<int>(threads > 0 ? threads : static_cast<int>(std::thread::hardware_concurrency()),
                                          static_cast<int>(order.size())));
  std::atomic<size_t> next{0};
  std::exception_ptr failure;
  std::mutex failureMutex;
  const auto worker = [&] {
    try {
      for (size_t k; (k = next++) < order.size();) bake(order[k]);
    } catch (...) {
      std::lock_guard<std::mutex> lock(failureMutex);
      if (!failure) failure = std::current_exception();
      next = order.size();
    }
  };
  std::vector<std::thread> pool;
  for (int i = 1; i < n; ++i) pool.emplace_back(worker);
  worker();
  for (auto& t : pool) t.join();
  if (failure) std::rethrow_exception(failure);
}

}  // namespace

AtlasImage bakeAtlas(const Atlas& atlas, const Mesh& mesh, const std::vector<std::shared_ptr<const Photo>>& photos,
                     const SeamLevelling* levelling, const InpaintResult* inpaint, const AtlasOptions& options) {
  const auto t0 = Clock::now();
  const int F = mesh.numFaces();
  TM_CHECK(
      static_cast<int>(atlas.faceChart.size()) == F,
      "atlas bake: the atlas has " + std::to_string(atlas.faceChart.size()) + " faces, the mesh " + std::to_string(F));
  const bool levelled = levelling && !levelling->cornerOffset.empty();
  TM_CHECK(!levelled || static_cast<int>(levelling->cornerOffset.size()) == F,
           "atlas bake: seam levelling has " + std::to_string(levelling ? levelling->cornerOffset.size() : 0) +
               " faces, the mesh " + std::to_string(F));
  const int size = atlas.size;
  for (const AtlasChart& c : atlas.charts)
    if (c.source >= 0)
      TM_CHECK(c.source < static_cast<int>(photos.size()) && photos[c.source],
               "atlas bake: photo " + std::to_string(c.source) + " is missing (" + std::to_string(photos.size()) +
                   " photos given)");

  // Refined triangles per base face, and the mean colour of every inpainted region (for inpainted
  // faces that were not refined).
  std::vector<std::vector<int>> refinedOf;
  std::vector<Vec3f> regionMean;
  if (inpaint) {
    const RefinedSurface& r = inpaint->refined;
    const int T = static_cast<int>(r.mesh.triangles.size());
    TM_CHECK(static_cast<int>(r.parentFace.size()) == T && static_cast<int>(r.parentBary.size()) == T,
             "atlas bake: the refined surface's parentFace/parentBary do not match its triangles");
    TM_CHECK(inpaint->colors.rows() == r.mesh.numVertices(),
             "atlas bake: " + std::to_string(inpaint->colors.rows()) + " inpainted colours for " +
                 std::to_string(r.mesh.numVertices()) + " refined vertices");
    refinedOf.resize(F);
    for (int t = 0; t < T; ++t) {
      const int f = r.parentFace[t];
      TM_CHECK(f >= 0 && f < F, "atlas bake: refined triangle " + std::to_string(t) + " has parent face " +
                                    std::to_string(f) + " outside the mesh");
      for (int v : r.mesh.triangles[t])
        TM_CHECK(v >= 0 && v < r.mesh.numVertices(),
                 "atlas bake: refined triangle " + std::to_string(t) + " has a vertex out of range");
      if (atlas.faceSource[f] == kSourceInpainted) refinedOf[f].push_back(t);
    }
    regionMean.assign(inpaint->regions.size(), options.emptyColor);
    std::vector<Vec3f> sum(inpaint->regions.size(), Vec3f::Zero());
    std::vector<int> count(inpaint->regions.size(), 0);
    for (int t = 0; t < T; ++t) {
      const int reg = t < static_cast<int>(r.region.size()) ? r.region[t] : -1;
      if (reg < 0 || reg >= static_cast<int>(sum.size())) continue;
      for (int v : r.mesh.triangles[t]) sum[reg] += inpaint->colors.row(v).transpose(), ++count[reg];
    }
    for (size_t g = 0; g < sum.size(); ++g)
      if (count[g]) regionMean[g] = sum[g] / float(count[g]);
  }

  // Photos minified by more than 1.5x are area-averaged to the atlas scale first, so that baking
  // samples a prefiltered image instead of aliasing.
  std::vector<cv::Mat> sources(photos.size());
  std::vector<double> sourceScale(photos.size(), 1.0);
  for (size_t i = 0; i < photos.size(); ++i) {
    if (!photos[i]) continue;
    sources[i] = photos[i]->rgb;
    sourceScale[i] = double(photos[i]->rgb.cols) / photos[i]->width;  // stored pixels per photo pixel
    const double minify = atlas.scale / sourceScale[i];
    if (atlas.scale > 0 && minify < 1 / 1.5) {
      cv::Mat small;
      cv::resize(photos[i]->rgb, small, cv::Size(), minify, minify, cv::INTER_AREA);
      if (small.cols > 0 && small.rows > 0) {
        sources[i] = small;
        sourceScale[i] = double(small.cols) / photos[i]->width;
      }
    }
  }

  AtlasImage out;
  out.rgba = largeMat(size, size, CV_8UC4);
  out.rgba.setTo(cv::Scalar(0, 0, 0, 255));
  out.chart = largeMat(size, size, CV_32SC1);
  out.chart.setTo(cv::Scalar(-1));
  const auto toByte = [](float v) { return static_cast<unsigned char>(std::clamp(v, 0.0f, 1.0f) * 255.0f + 0.5f); };

  // Which triangle of a chart colours a texel: the one containing its centre, else the nearest
  // (distance quantised to 1/64 texel). One byte per texel instead of a float keeps the memory
  // traffic of a 4096^2 atlas down.
  cv::Mat priority = largeMat(size, size, CV_8UC1);
  priority.setTo(cv::Scalar(255));
  const auto bakeChart = [&](int ci, std::vector<BakeTriangle>& tris) {
    const AtlasChart& chart = atlas.charts[ci];
    tris.clear();
    for (int f : chart.faces) {
      const auto& a = atlas.cornerUV[f];
      if (chart.source >= 0) {
        BakeTriangle t{a, {Vec3f::Zero(), Vec3f::Zero(), Vec3f::Zero()}};
        if (levelled) t.c = levelling->cornerOffset[f];
        tris.push_back(t);
      } else if (!refinedOf.empty() && !refinedOf[f].empty()) {
        const RefinedSurface& r = inpaint->refined;
        for (int t : refinedOf[f]) {
          BakeTriangle bt;
          for (int k = 0; k < 3; ++k) {
            const Vec3& b = r.parentBary[t][k];
            const int v = r.mesh.triangles[t][k];
            bt.p[k] = b[0] * a[0] + b[1] * a[1] + b[2] * a[2];
            bt.c[k] = inpaint->colors.row(v).transpose();
            if (!inpaint->detailPoint.empty() && inpaint->detailPoint[v] >= 0) bt.refined = t;
          }
          tris.push_back(bt);
        }
      } else {
        Vec3f flat = options.emptyColor;
        if (chart.source == kSourceInpainted && inpaint && f < static_cast<int>(inpaint->faceRegion.size()) &&
            inpaint->faceRegion[f] >= 0 && inpaint->faceRegion[f] < static_cast<int>(regionMean.size()))
          flat = regionMean[inpaint->faceRegion[f]];
        tris.push_back({a, {flat, flat, flat}});
      }
    }
    const cv::Mat* src = chart.source >= 0 ? &sources[chart.source] : nullptr;
    const double srcScale = chart.source >= 0 ? sourceScale[chart.source] : 1.0;
    const int x1 = chart.x + chart.width, y1 = chart.y + chart.height;
    const auto settled = [&](int x, int y) { return priority.ptr<unsigned char>(y)[x] == 0; };
    for (const Pass pass : {Pass::Inside, Pass::Band})
      for (const BakeTriangle& t : tris) {
        const bool flat = !src && t.refined < 0 && t.c[0] == t.c[1] && t.c[1] == t.c[2];
        footprintTexels(t.p, chart.x, chart.y, x1, y1, pass, settled, [&](int x, int y, double d, const Vec3& b) {
          unsigned char& prio = priority.ptr<unsigned char>(y)[x];
          const int mine = d == 0 ? 0 : 1 + std::min(253, static_cast<int>(d * 64));
          if (mine >= prio) return;
          prio = static_cast<unsigned char>(mine);
          Vec3f c = flat             ? t.c[0]
                    : t.refined >= 0 ? inpaint->colourAt(t.refined, b)
                                     : Vec3f(float(b[0]) * t.c[0] + float(b[1]) * t.c[1] + float(b[2]) * t.c[2]);
          if (src) {
            const double px = chart.toPhoto(0, 0) * (x + 0.5) + chart.toPhoto(0, 1) * (y + 0.5) + chart.toPhoto(0, 2);
            const double py = chart.toPhoto(1, 0) * (x + 0.5) + chart.toPhoto(1, 1) * (y + 0.5) + chart.toPhoto(1, 2);
            c += sampleBilinear3(*src, px * srcScale, py * srcScale);
          }
          out.rgba.ptr<cv::Vec4b>(y)[x] = cv::Vec4b(toByte(c[0]), toByte(c[1]), toByte(c[2]), 255);
          out.chart.ptr<int>(y)[x] = ci;
        });
      }
  };

  forEachChart(atlas, options.threads, [&](int ci) {
    std::vector<BakeTriangle> tris;
    bakeChart(ci, tris);
  });
  fillFromNearest(out.rgba, out.chart);
  out.seconds = secondsSince(t0);
  return out;
}

AtlasImage bakeAtlasSurface(const Atlas& atlas, const std::function<Vec3f(int, const Vec3&, unsigned char&)>& color,
                            const AtlasOptions& options, cv::Mat* labels) {
  const auto t0 = Clock::now();
  const int size = atlas.size;
  TM_CHECK(size > 0 && atlas.faceChart.size() == atlas.cornerUV.size(), "atlas bake: the atlas is not built");
  AtlasImage out;
  out.rgba = largeMat(size, size, CV_8UC4);
  out.rgba.setTo(cv::Scalar(0, 0, 0, 255));
  out.chart = largeMat(size, size, CV_32SC1);
  out.chart.setTo(cv::Scalar(-1));
  cv::Mat priority = largeMat(size, size, CV_8UC1);
  priority.setTo(cv::Scalar(255));
  if (labels) *labels = cv::Mat(size, size, CV_8UC1, cv::Scalar(0));
  const auto toByte = [](float v) { return static_cast<unsigned char>(std::clamp(v, 0.0f, 1.0f) * 255.0f + 0.5f); };
  forEachChart(atlas, options.threads, [&](int ci) {
    const AtlasChart& chart = atlas.charts[ci];
    const int x1 = chart.x + chart.width, y1 = chart.y + chart.height;
    const auto settled = [&](int x, int y) { return priority.ptr<unsigned char>(y)[x] == 0; };
    for (const Pass pass : {Pass::Inside, Pass::Band})
      for (int f : chart.faces)
        footprintTexels(atlas.cornerUV[f], chart.x, chart.y, x1, y1, pass, settled,
                        [&](int x, int y, double d, const Vec3& b) {
                          unsigned char& prio = priority.ptr<unsigned char>(y)[x];
                          const int mine = d == 0 ? 0 : 1 + std::min(253, static_cast<int>(d * 64));
                          if (mine >= prio) return;
                          prio = static_cast<unsigned char>(mine);
                          unsigned char label = 0;
                          const Vec3f c = color(f, b, label);
                          out.rgba.ptr<cv::Vec4b>(y)[x] = cv::Vec4b(toByte(c[0]), toByte(c[1]), toByte(c[2]), 255);
                          if (labels) labels->ptr<unsigned char>(y)[x] = label;
                          out.chart.ptr<int>(y)[x] = ci;
                        });
  });
  fillFromNearest(out.rgba, out.chart);
  out.seconds = secondsSince(t0);
  return out;
}

cv::Mat atlasSourceLayer(const Atlas& atlas, const AtlasImage& image) {
  cv::Mat out(image.chart.size(), CV_8UC1, cv::Scalar(0));
  for (int y = 0; y < out.rows; ++y) {
    const int* ids = image.chart.ptr<int>(y);
    unsigned char* o = out.ptr<unsigned char>(y);
    for (int x = 0; x < out.cols; ++x) {
      if (ids[x] < 0 || ids[x] >= static_cast<int>(atlas.charts.size())) continue;
      const int s = atlas.charts[ids[x]].source;
      o[x] = s >= 0 ? static_cast<unsigned char>(std::min(s, 249) + 1) : s == kSourceInpainted ? 254 : 253;
    }
  }
  return out;
}

cv::Mat atlasHoleMask(const Atlas& atlas, const AtlasImage& image) {
  cv::Mat out(image.chart.size(), CV_8UC1, cv::Scalar(0));
  for (int y = 0; y < out.rows; ++y) {
    const int* ids = image.chart.ptr<int>(y);
    unsigned char* o = out.ptr<unsigned char>(y);
    for (int x = 0; x < out.cols; ++x)
      if (ids[x] >= 0 && ids[x] < static_cast<int>(atlas.charts.size()) && atlas.charts[ids[x]].source < 0) o[x] = 255;
  }
  return out;
}

void writeAtlasLayers(const Atlas& atlas, const AtlasImage& image, const std::string& dir, const std::string& base) {
  writeAtlasLayers(atlasSourceLayer(atlas, image), dir, base);
}

void writeAtlasLayers(const cv::Mat& source, const std::string& dir, const std::string& base) {
  namespace fs = std::filesystem;
  TM_CHECK(source.type() == CV_8UC1, located(dir, "the source layer must be 8-bit, one channel"));
  std::error_code ec;
  fs::create_directories(dir, ec);
  const cv::Mat holes = source >= 253;  // inpainted (254) and empty (253)
  for (const auto& [suffix, layer] :
       {std::pair<std::string, cv::Mat>{"_atlas_source.png", source}, {"_atlas_holes.png", holes}}) {
    const std::string path = (fs::path(dir) / (base + suffix)).string();
    writePng(path, layer);
  }
}

TexturedModel atlasModel(const Mesh& mesh, const Atlas& atlas, const AtlasImage& image) {
  const int F = mesh.numFaces();
  TM_CHECK(
      static_cast<int>(atlas.cornerUV.size()) == F && static_cast<int>(atlas.faceSource.size()) == F,
      "atlas model: the atlas has " + std::to_string(atlas.cornerUV.size()) + " faces, the mesh " + std::to_string(F));
  TM_CHECK(image.rgba.type() == CV_8UC4 && image.rgba.rows == atlas.size && image.rgba.cols == atlas.size,
           "atlas model: the atlas image must be " + std::to_string(atlas.size) + "x" + std::to_string(atlas.size) +
               " RGBA (8 bits)");
  TexturedModel model;
  model.mesh = mesh;
  model.mesh.cornerUV.clear();  // the model's texture coordinates are `uv`
  model.uv.resize(F);
  const double inv = 1.0 / atlas.size;
  for (int f = 0; f < F; ++f)
    for (int k = 0; k < 3; ++k) {
      const Vec2& a = atlas.cornerUV[f][k];
      model.uv[f][k] = Vec2f(static_cast<float>(a.x() * inv), static_cast<float>(1.0 - a.y() * inv));
    }
  // One material per source ("photo_<k>", "inpainted", "empty", in that order), all showing the atlas, so
  // that viewers list the parts by where their colours come from.
  model.faceSource = atlas.faceSource;
  std::map<int, int> material;  // source -> material, photos first
  for (int src : atlas.faceSource) material.emplace(src >= 0 ? src : 1'000'000 - src, 0);
  for (auto& [key, index] : material) {
    Material m;
    m.name = key < 1'000'000                       ? "photo_" + std::to_string(key)
             : key == 1'000'000 - kSourceInpainted ? "inpainted"
                                                   : "empty";
    m.texture = image.rgba;
    m.textureName = "atlas";
    index = static_cast<int>(model.materials.size());
    model.materials.push_back(m);
  }
  model.faceMaterial.resize(F);
  for (int f = 0; f < F; ++f) {
    const int src = atlas.faceSource[f];
    model.faceMaterial[f] = material.at(src >= 0 ? src : 1'000'000 - src);
  }
  return model;
}

}  // namespace montage
