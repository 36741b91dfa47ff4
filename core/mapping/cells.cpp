#include "mapping/cells.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <map>
#include <unordered_map>

#include "base/job.h"
#include "geometry/predicates.h"
#include "geometry/stretch.h"
#include "image/photo.h"
#include "io/scene.h"
#include "mapping/partition.h"

namespace montage {

namespace {

uint64_t edgeKey(int a, int b) {
  if (a > b) std::swap(a, b);
  return (uint64_t(uint32_t(a)) << 32) | uint32_t(b);
}

Vec2 flipY(const Vec2& p) {
  return Vec2(p.x(), -p.y());
}

const Curve* curveIn(const MeshPath& path, int photo) {
  for (const Curve& c : path.curves)
    if (c.photo == photo) return &c;
  return nullptr;
}

std::string pointsText(const Partition& partition, const MeshPath& path) {
  // The ids the user sees (deleting a point renumbers no other).
  const auto id = [&](int point) {
    return point >= 0 && point < int(partition.featureId.size()) ? partition.featureId[point] : point;
  };
  return std::to_string(id(path.fromPoint)) + "-" + std::to_string(id(path.toPoint));
}

// The cell's boundary: one loop of half-edges with the cell on their left, as vertex sequence.
struct Loop {
  std::vector<int> vertices;  // counter-clockwise seen from outside; closed implicitly
  std::vector<char> border;   // per loop edge i (vertices[i] -> vertices[i + 1]): an edge of the mesh border
  bool ok = false;
  bool touchesBorder = false;
  bool dangling = false;  // a path edge with the cell on both sides
};

Loop boundaryLoop(const Partition& partition, const std::vector<int>& faces, int cell,
                  const std::unordered_map<uint64_t, int>& edgePath) {
  const TriMesh& tri = partition.mesh.tri;
  Loop loop;
  std::unordered_map<int, std::pair<int, char>> next;  // from -> (to, on the mesh border) of boundary half-edges
  int pinches = 0;
  for (int f : faces) {
    for (auto h = tri.cfh_iter(TriMesh::FaceHandle(f)); h.is_valid(); ++h) {
      const auto g = tri.opposite_face_handle(*h);
      const int from = tri.from_vertex_handle(*h).idx(), to = tri.to_vertex_handle(*h).idx();
      const bool border = !g.is_valid();
      if (border) loop.touchesBorder = true;
      if (!border && partition.faceCell[g.idx()] == cell) {
        if (edgePath.count(edgeKey(from, to))) loop.dangling = true;
        continue;
      }
      if (!next.emplace(from, std::pair<int, char>{to, border}).second) ++pinches;
    }
  }
  if (loop.dangling || pinches > 0 || next.empty()) return loop;
  const int start = next.begin()->first;
  int v = start;
  do {
    loop.vertices.push_back(v);
    const auto it = next.find(v);
    if (it == next.end()) return loop;
    loop.border.push_back(it->second.second);
    v = it->second.first;
    if (loop.vertices.size() > next.size()) return loop;
  } while (v != start);
  loop.ok = loop.vertices.size() == next.size();  // one loop uses every boundary half-edge
  return loop;
}

// Whether the closed polygon has two non-adjacent edges that cross.
bool selfIntersecting(const std::vector<Vec2>& polygon) {
  const int n = static_cast<int>(polygon.size());
  auto crosses = [](const Vec2& a, const Vec2& b, const Vec2& c, const Vec2& d) {
    const double d1 = orient2(c, d, a), d2 = orient2(c, d, b), d3 = orient2(a, b, c), d4 = orient2(a, b, d);
    return ((d1 > 0) != (d2 > 0)) && ((d3 > 0) != (d4 > 0)) && d1 != 0 && d2 != 0 && d3 != 0 && d4 != 0;
  };
  for (int i = 0; i < n; ++i)
    for (int j = i + 2; j < n; ++j) {
      if (i == 0 && j == n - 1) continue;  // adjacent through the closing edge
      if (crosses(polygon[i], polygon[(i + 1) % n], polygon[j], polygon[(j + 1) % n])) return true;
    }
  return false;
}

double signedArea(const std::vector<Vec2>& polygon) {
  double a = 0;
  for (size_t i = 0; i < polygon.size(); ++i) a += cross2(polygon[i], polygon[(i + 1) % polygon.size()]);
  return 0.5 * a;
}

}  // namespace

std::vector<CellPlan> planCells(const Scene& scene, const Partition& partition) {
  const Mesh& mesh = partition.mesh;
  std::vector<CellPlan> plans(std::max(partition.numCells, 0));
  for (int c = 0; c < partition.numCells; ++c) plans[c].cell = c;
  for (int f = 0; f < mesh.numFaces(); ++f) plans[partition.faceCell[f]].faces.push_back(f);

  std::unordered_map<uint64_t, int> edgePath;
  for (int p = 0; p < static_cast<int>(partition.paths.size()); ++p) {
    const auto& pv = partition.paths[p].vertices;
    for (size_t i = 1; i < pv.size(); ++i) edgePath[edgeKey(pv[i - 1], pv[i])] = p;
  }
  // Features by vertex (a vertex may carry several points: the first serves).
  std::vector<int> featureAt(mesh.numVertices(), -1);
  for (size_t p = 0; p < partition.featureVertex.size(); ++p) {
    const int v = partition.featureVertex[p];
    if (v >= 0 && v < mesh.numVertices() && featureAt[v] < 0) featureAt[v] = static_cast<int>(p);
  }
  auto clickIn = [&](int vertex, int photo, Vec2& at) {
    if (featureAt[vertex] < 0 || featureAt[vertex] >= static_cast<int>(scene.project.points.size())) return false;
    for (const PhotoPoint& a : scene.project.points[featureAt[vertex]].at)
      if (a.photo == photo) {
        at = Vec2(a.x, a.y);
        return true;
      }
    return false;
  };

  // Cells in parallel, each with its thread's vertex marks (a cell's id marks its own vertices).
  tbb::enumerable_thread_specific<std::vector<int>> marks(std::vector<int>(mesh.numVertices(), -1));
  tbb::parallel_for(size_t(0), plans.size(), [&](size_t index) {
    CellPlan& plan = plans[index];
    std::vector<int>& mark = marks.local();
    const int c = plan.cell;
    const Loop loop = boundaryLoop(partition, plan.faces, c, edgePath);
    if (loop.dangling) {
      plan.status = CellStatus::NotTriangle;
      plan.detail = "a path ends inside the region: its end feature needs paths to two more features";
      return;
    }
    // Euler characteristic of a disc: V - E + F = 1. With one boundary loop of B half-edges (loop.ok),
    // each of the 3F face half-edges is either on it or paired with another inside: E = (3F + B) / 2.
    int vertices = 0;
    for (int f : plan.faces)
      for (int v : mesh.faceVertices(f))
        if (mark[v] != c) mark[v] = c, ++vertices;
    const int faces = int(plan.faces.size()), edges = (3 * faces + int(loop.vertices.size())) / 2;
    if (loop.touchesBorder && (!loop.ok || vertices - edges + faces != 1)) {
      plan.status = CellStatus::TouchesBorder;
      plan.detail =
          "the region reaches the border of the mesh and is not a disc (a ring around paths, or several "
          "borders): paths across it from the border cut it into discs";
      return;
    }
    if (!loop.ok || vertices - edges + faces != 1) {
      plan.status = CellStatus::NotDisc;
      plan.detail =
          "the region is not a disc (it wraps around a handle or has several borders): add features "
          "and paths across it";
      return;
    }
    // Sides: runs of loop edges along one path (or along the mesh border, -1); corners where they meet.
    const int n = static_cast<int>(loop.vertices.size());
    std::vector<int> label(n);
    bool sidesOk = true;
    for (int i = 0; i < n; ++i) {
      const auto it = edgePath.find(edgeKey(loop.vertices[i], loop.vertices[(i + 1) % n]));
      label[i] = it != edgePath.end() ? it->second : loop.border[i] ? -1 : -2;
      sidesOk = sidesOk && label[i] != -2;
    }
    std::vector<int> cornerAt;
    for (int i = 0; i < n && sidesOk; ++i)
      if (label[i] != label[(i + n - 1) % n]) cornerAt.push_back(i);
    int pathSides = 0;
    for (int k = 0; k < static_cast<int>(cornerAt.size()); ++k) {
      const int side = label[cornerAt[k]];
      plan.corners.push_back(loop.vertices[cornerAt[k]]);
      plan.sides.push_back(side);
      pathSides += side >= 0;
    }
    const bool enough = sidesOk && (loop.touchesBorder ? pathSides >= 2 : pathSides >= 3 && cornerAt.size() >= 3);
    if (!enough) {
      plan.status = loop.touchesBorder ? CellStatus::TouchesBorder : CellStatus::NotTriangle;
      plan.detail = loop.touchesBorder
                        ? "the region reaches the border of the mesh with " + std::to_string(pathSides) +
                              " path(s) around it: two paths (features clicked in one photo) close it off"
                        : "the region is bounded by " + std::to_string(pathSides) +
                              " paths, not a loop of three or more: add paths (features clicked in a common photo)";
      plan.corners.clear(), plan.sides.clear();
      return;
    }
    // Photos with a curve on every path side.
    std::vector<int> photos;
    const int first = *std::find_if(plan.sides.begin(), plan.sides.end(), [](int s) { return s >= 0; });
    for (const Curve& cv : partition.paths[first].curves) {
      bool all = true;
      for (int s : plan.sides) all = all && (s < 0 || curveIn(partition.paths[s], cv.photo));
      if (all) photos.push_back(cv.photo);
    }
    if (photos.empty()) {
      plan.status = CellStatus::NoCommonPhoto;
      plan.detail = "its paths (points";
      for (int s : plan.sides)
        if (s >= 0) plan.detail += " " + pointsText(partition, partition.paths[s]);
      plan.detail += ") have no photo in common: click its corner features in one photo";
      return;
    }
    // In each, the polygon of the corners (flipped to y up) must keep the cell's orientation and not cross
    // itself; among several, the most frontal: the smallest L-infinity stretch of its fan triangles. (A cell on the
    // mesh border has no closed polygon: its free border may wrap around the paths. Its base map says whether it
    // folds, fine_map.h.)
    const int k = static_cast<int>(plan.corners.size());
    double bestGamma = std::numeric_limits<double>::infinity();
    int anyPhoto = -1;
    for (int p : photos) {
      std::vector<Vec2> polygon(k);
      bool placed = true;
      for (int j = 0; j < k; ++j) {
        // A corner's place: the end of a path side at it (the side it starts, else the one it ends).
        const int out = plan.sides[j], in = plan.sides[(j + k - 1) % k];
        const int side = out >= 0 ? out : in;
        if (side < 0) {
          placed = false;
          break;
        }
        const MeshPath& path = partition.paths[side];
        const Curve* curve = curveIn(path, p);
        polygon[j] = flipY(path.vertices.front() == plan.corners[j] ? curve->from : curve->to);
      }
      if (!placed) continue;
      if (!loop.touchesBorder && (!(signedArea(polygon) > 0) || selfIntersecting(polygon))) continue;
      double gamma = 0;
      for (int j = 1; j + 1 < k; ++j) {
        const TriangleStretch st = triangleStretch(
            {mesh.position(plan.corners[0]), mesh.position(plan.corners[j]), mesh.position(plan.corners[j + 1])},
            {polygon[0], polygon[j], polygon[j + 1]});
        if (!st.flipped && std::isfinite(st.gamma)) gamma = std::max(gamma, st.gamma);
      }
      if (gamma < bestGamma) bestGamma = gamma, plan.photo = p;
      if (anyPhoto < 0) anyPhoto = p;
    }
    if (plan.photo == TextureMap::kEmpty) plan.photo = loop.touchesBorder ? anyPhoto : plan.photo;
    if (plan.photo == TextureMap::kEmpty) {
      plan.status = CellStatus::Mirrored;
      plan.detail =
          "its texture polygon is mirrored or crosses itself in every photo of its paths (the photos show "
          "its back side, or a click is misplaced)";
      return;
    }
    // Features inside (or on a border run) with a click in the photo constrain the map.
    for (int f : plan.faces)
      for (int v : mesh.faceVertices(f)) {
        Vec2 at;
        if (featureAt[v] < 0 || std::find(plan.corners.begin(), plan.corners.end(), v) != plan.corners.end() ||
            std::find(plan.inner.begin(), plan.inner.end(), v) != plan.inner.end() || !clickIn(v, plan.photo, at))
          continue;
        bool onPath = false;
        for (int i = 0; i < n && !onPath; ++i) onPath = loop.vertices[i] == v && label[i] >= 0;
        if (!onPath) plan.inner.push_back(v);
      }
    std::sort(plan.inner.begin(), plan.inner.end());
    plan.status = CellStatus::Mapped;
  });
  return plans;
}

std::vector<Vec2> pathUVs(const Mesh& mesh, const MeshPath& path, const Curve& curve, const Photo& photo) {
  const auto& pv = path.vertices;
  const int n = static_cast<int>(pv.size());
  std::vector<double> along(n, 0.0);
  for (int i = 1; i < n; ++i) along[i] = along[i - 1] + (mesh.position(pv[i]) - mesh.position(pv[i - 1])).norm();
  const double total = along.back();
  std::vector<Vec2> uv(n);
  uv.front() = curve.from;
  uv.back() = curve.to;
  if (n <= 2) return uv;
  const Vec2 d = curve.to - curve.from;
  // Cumulative foreground length along the curve, sampled every <= 0.5 px.
  const int samples = std::max(2, int(std::ceil(d.norm() / 0.5)) + 1);
  std::vector<double> fg(samples, 0.0);
  auto foreground = [&](double s) {
    const Vec2 x = curve.from + s * d;
    return photo.alpha.empty() ? photo.inside(x.x(), x.y()) : photo.isForeground(x.x(), x.y());
  };
  bool prev = foreground(0);
  for (int k = 1; k < samples; ++k) {
    const bool here = foreground(double(k) / (samples - 1));
    fg[k] = fg[k - 1] + ((prev && here) ? 1.0 : (prev || here) ? 0.5 : 0.0);
    prev = here;
  }
  const bool skipGaps = fg.back() > 0;
  for (int i = 1; i + 1 < n; ++i) {
    const double t = total > 0 ? along[i] / total : double(i) / (n - 1);
    double s = t;
    if (skipGaps) {
      // The curve parameter where the foreground length reaches t times its total.
      const double target = t * fg.back();
      const int k = int(std::lower_bound(fg.begin(), fg.end(), target) - fg.begin());
      if (k <= 0) {
        s = 0;
      } else {
        const double step = fg[k] - fg[k - 1];
        const double frac = step > 0 ? (target - fg[k - 1]) / step : 0.0;
        s = (k - 1 + frac) / (samples - 1);
      }
    }
    uv[i] = curve.from + s * d;
  }
  return uv;
}

std::shared_ptr<const CellMap> CellCache::find(const std::string& key) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = entries_.find(key);
  if (it == entries_.end()) return nullptr;
  it->second.lastRun = run_;
  return it->second.map;
}

void CellCache::insert(const std::string& key, std::shared_ptr<const CellMap> map) {
  std::lock_guard<std::mutex> lock(mutex_);
  entries_[key] = {std::move(map), run_};
}

void CellCache::endRun() {
  std::lock_guard<std::mutex> lock(mutex_);
  for (auto it = entries_.begin(); it != entries_.end();)
    it = run_ - it->second.lastRun >= keepRuns_ ? entries_.erase(it) : std::next(it);
  ++run_;
}

size_t CellCache::size() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return entries_.size();
}

namespace {

template <class T>
void appendBytes(std::string& out, const T& value) {
  out.append(reinterpret_cast<const char*>(&value), sizeof(T));
}

// One mapped cell's problem in canonical form, with the way back to the partition's mesh.
struct CellJob {
  int plan = -1;
  CellProblem problem;
  std::vector<int> globalVertex;  // local -> Partition::mesh vertex
  std::shared_ptr<const CellMap> result;
  bool cacheable = false;
};

// `sideUV`: per side of the plan, its path's fixed UVs (empty for a border run); `innerUV`: per inner feature.
CellJob buildJob(const Scene& scene, const Partition& partition, const CellPlan& plan, const FineMapOptions& options,
                 const std::vector<std::vector<Vec2>>& sideUV, const std::vector<Vec2>& innerUV) {
  const Mesh& mesh = partition.mesh;
  const int inputVertices = scene.mesh ? scene.mesh->numVertices() : mesh.numVertices();
  CellJob job;
  std::vector<int>& global = job.globalVertex;
  for (int f : plan.faces)
    for (int v : mesh.faceVertices(f)) global.push_back(v);
  std::sort(global.begin(), global.end());
  global.erase(std::unique(global.begin(), global.end()), global.end());
  // Canonical order: input vertices by id, then Steiner vertices by position (their ids depend on the
  // order in which the partition split edges, which other cells influence).
  std::sort(global.begin(), global.end(), [&](int a, int b) {
    const bool sa = a >= inputVertices, sb = b >= inputVertices;
    if (sa != sb) return !sa;
    if (!sa) return a < b;
    const Vec3 pa = mesh.position(a), pb = mesh.position(b);
    if (pa.x() != pb.x()) return pa.x() < pb.x();
    if (pa.y() != pb.y()) return pa.y() < pb.y();
    if (pa.z() != pb.z()) return pa.z() < pb.z();
    return a < b;
  });
  std::unordered_map<int, int> local;
  local.reserve(global.size() * 2);
  for (int i = 0; i < static_cast<int>(global.size()); ++i) local[global[i]] = i;
  CellProblem& pr = job.problem;
  const int n = static_cast<int>(global.size());
  pr.positions.resize(n);
  for (int i = 0; i < n; ++i) pr.positions[i] = mesh.position(global[i]);
  for (int f : plan.faces) {
    const auto fv = mesh.faceVertices(f);
    std::array<int, 3> t = {local[fv[0]], local[fv[1]], local[fv[2]]};
    std::rotate(t.begin(), std::min_element(t.begin(), t.end()), t.end());
    pr.faces.push_back(t);
  }
  std::sort(pr.faces.begin(), pr.faces.end());
  pr.fixed.assign(n, 0);
  pr.fixedUV.assign(n, Vec2::Zero());
  for (size_t k = 0; k < plan.sides.size(); ++k) {
    if (plan.sides[k] < 0) continue;  // a run along the mesh border: free
    const MeshPath& path = partition.paths[plan.sides[k]];
    std::vector<int> side;
    for (size_t i = 0; i < path.vertices.size(); ++i) {
      const int l = local.at(path.vertices[i]);
      pr.fixed[l] = 1;
      pr.fixedUV[l] = sideUV[k][i];
      side.push_back(l);
    }
    if (path.vertices.front() != plan.corners[k]) std::reverse(side.begin(), side.end());
    pr.sides.push_back(side);
  }
  for (size_t i = 0; i < plan.inner.size(); ++i) {
    const int l = local.at(plan.inner[i]);
    pr.fixed[l] = 1;
    pr.fixedUV[l] = innerUV[i];
  }
  // Sides in a canonical order too: starting at the side whose first corner has the smallest local id.
  std::rotate(pr.sides.begin(),
              std::min_element(pr.sides.begin(), pr.sides.end(),
                               [](const auto& a, const auto& b) { return a.front() < b.front(); }),
              pr.sides.end());

  pr.triangle = plan.triangle();
  std::string& key = pr.key;
  key = pr.triangle ? "cell2|" : "cell2p|";
  key += scene.photoKeys.size() > size_t(plan.photo) ? scene.photoKeys[plan.photo] : std::string();
  job.cacheable = !(scene.photoKeys.size() <= size_t(plan.photo) || scene.photoKeys[plan.photo].empty());
  key += '|';
  appendBytes(key, options.lineSearches);
  appendBytes(key, options.searchSteps);
  appendBytes(key, options.finalSweeps);
  appendBytes(key, options.seed);
  appendBytes(key, n);
  for (const Vec3& p : pr.positions) appendBytes(key, p.x()), appendBytes(key, p.y()), appendBytes(key, p.z());
  for (const auto& t : pr.faces) appendBytes(key, t);
  for (const auto& side : pr.sides) {
    appendBytes(key, int(side.size()));
    for (int l : side) appendBytes(key, l), appendBytes(key, pr.fixedUV[l].x()), appendBytes(key, pr.fixedUV[l].y());
  }
  for (int l = 0; l < n; ++l)  // every fixed vertex (sides' and inner features')
    if (pr.fixed[l]) appendBytes(key, l), appendBytes(key, pr.fixedUV[l].x()), appendBytes(key, pr.fixedUV[l].y());
  return job;
}

}  // namespace

CellMapping mapCells(const Scene& scene, const Partition& partition, const FineMapOptions& options,
                     const JobControl& job, CellCache* cache, const std::vector<char>* projected) {
  const Mesh& mesh = partition.mesh;
  CellMapping out;
  out.map = TextureMap::allEmpty(mesh.numFaces());
  for (int f = 0; f < mesh.numFaces(); ++f) out.map.facePatch[f] = partition.faceCell[f];
  out.cells = planCells(scene, partition);

  // Fixed UVs of every path, per photo it is used in; then the cells' problems. Both in parallel.
  std::map<std::pair<int, int>, std::vector<Vec2>> pathUV;  // (path, photo) -> per path vertex
  std::vector<int> mapped;                                  // plans to map
  for (int i = 0; i < static_cast<int>(out.cells.size()); ++i) {
    const CellPlan& plan = out.cells[i];
    if (plan.status != CellStatus::Mapped) continue;
    if (projected && plan.photo >= 0 && plan.photo < static_cast<int>(projected->size()) && (*projected)[plan.photo]) {
      for (int f : plan.faces) out.map.facePhoto[f] = plan.photo;  // UVs: the empty map's
      ++out.cellsProjected;
      continue;
    }
    mapped.push_back(i);
    for (int side : plan.sides)
      if (side >= 0) pathUV[{side, plan.photo}];
  }
  // An inner feature's click in a photo (planCells made sure it has one).
  std::unordered_map<int, int> pointAt;
  for (size_t p = 0; p < partition.featureVertex.size(); ++p) pointAt.emplace(partition.featureVertex[p], int(p));
  auto clickOf = [&](int vertex, int photo) {
    for (const PhotoPoint& a : scene.project.points[pointAt.at(vertex)].at)
      if (a.photo == photo) return Vec2(a.x, a.y);
    return Vec2(Vec2::Zero());
  };
  std::vector<std::pair<const std::pair<int, int>, std::vector<Vec2>>*> entries;
  for (auto& entry : pathUV) entries.push_back(&entry);
  tbb::parallel_for(size_t(0), entries.size(), [&](size_t e) {
    const auto [path, photo] = entries[e]->first;
    const MeshPath& p = partition.paths[path];
    entries[e]->second = pathUVs(mesh, p, *curveIn(p, photo), *scene.photos[photo]);
  });
  std::vector<CellJob> jobs(mapped.size());
  tbb::parallel_for(size_t(0), mapped.size(), [&](size_t j) {
    const CellPlan& plan = out.cells[mapped[j]];
    std::vector<std::vector<Vec2>> sideUV(plan.sides.size());
    for (size_t k = 0; k < plan.sides.size(); ++k)
      if (plan.sides[k] >= 0) sideUV[k] = pathUV.at({plan.sides[k], plan.photo});
    std::vector<Vec2> innerUV;
    for (int v : plan.inner) innerUV.push_back(clickOf(v, plan.photo));
    jobs[j] = buildJob(scene, partition, plan, options, sideUV, innerUV);
    jobs[j].plan = mapped[j];
  });
  job.checkCancel();

  // Cached cells first; the others are mapped in parallel, largest first.
  std::vector<int> todo;
  for (int j = 0; j < static_cast<int>(jobs.size()); ++j) {
    if (cache && jobs[j].cacheable) jobs[j].result = cache->find(jobs[j].problem.key);
    if (jobs[j].result)
      ++out.cellsReused;
    else
      todo.push_back(j);
  }
  std::sort(todo.begin(), todo.end(),
            [&](int a, int b) { return jobs[a].problem.faces.size() > jobs[b].problem.faces.size(); });
  std::atomic<int> done{0};
  std::mutex progressMutex;
  tbb::parallel_for(size_t(0), todo.size(), size_t(1), [&](size_t i) {
    CellJob& cj = jobs[todo[i]];
    const CellPlan& plan = out.cells[cj.plan];
    auto result = std::make_shared<CellMap>(coarseToFineCell(cj.problem, *scene.photos[plan.photo], options, job));
    cj.result = result;
    if (cache && cj.cacheable) cache->insert(cj.problem.key, result);
    const int d = ++done;
    if (d % 16 == 0) {
      std::lock_guard<std::mutex> lock(progressMutex);
      job.progress(StageId::Map, double(d) / todo.size(), "coarse-to-fine");
    }
  });
  out.cellsMapped = static_cast<int>(todo.size());

  // Assemble the texture map.
  std::map<CellStatus, int> empty;
  for (const CellJob& cj : jobs) {
    CellPlan& plan = out.cells[cj.plan];
    const CellMap& m = *cj.result;
    if (!m.failure.empty()) {
      plan.status = CellStatus::Failed;
      plan.detail = m.failure;
      continue;
    }
    out.stats.add(m.stats);
    std::unordered_map<int, int> local;
    for (int i = 0; i < static_cast<int>(cj.globalVertex.size()); ++i) local[cj.globalVertex[i]] = i;
    for (int f : plan.faces) {
      const auto fv = mesh.faceVertices(f);
      out.map.facePhoto[f] = plan.photo;
      for (int k = 0; k < 3; ++k) out.map.cornerUV[f][k] = m.uv[local.at(fv[k])];
    }
  }
  for (const CellPlan& plan : out.cells)
    if (plan.status != CellStatus::Mapped) ++empty[plan.status];
  for (const auto& [status, count] : empty)
    out.map.notes.push_back(std::to_string(count) + (count == 1 ? " region is" : " regions are") +
                            " left empty: " + kCellStatusNames[static_cast<int>(status)]);
  if (out.stats.flippedFaces > 0)
    out.map.notes.push_back(std::to_string(out.stats.flippedFaces) + " mapped faces are flipped in their photo");
  if (out.stats.onBackground > 0)
    out.map.notes.push_back(std::to_string(out.stats.onBackground) +
                            " texture coordinates could not leave the photo background");
  job.progress(StageId::Map, 1.0, "coarse-to-fine");
  return out;
}

}  // namespace montage
