// Paper section 3.1: partition of the mesh and the photos by path-curve pairs, after Kraevoy et al.
// 2003 (Matchmaker). Chains enter first, then every pair of feature points in order of mesh path
// length (lazily: Euclidean lower bound first, the real path length when the pair reaches the top).
// A pair is accepted in each photo where its curve crosses no accepted curve, stays over the
// foreground (mean distance <= threshold, paper 3.1) and keeps the cyclic order of the pairs around
// both ends; its mesh path avoids the accepted paths, with Steiner vertices (edge splits) where the
// mesh leaves no room. docs/pipeline.md lists the choices made here.
#include "mapping/partition.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <queue>
#include <set>
#include <sstream>
#include <unordered_map>

#include "base/hash.h"
#include "base/job.h"
#include "geometry/predicates.h"
#include "image/photo.h"
#include "io/scene.h"

namespace montage {

namespace {

using VertexHandle = TriMesh::VertexHandle;
using HalfedgeHandle = TriMesh::HalfedgeHandle;
using EdgeHandle = TriMesh::EdgeHandle;
using FaceHandle = TriMesh::FaceHandle;

constexpr size_t kMaxRejected = 100000;  // entries kept in Partition::rejected
constexpr int kNearFeatures = 8;         // all-pairs rejections are kept among this many nearest features
constexpr int kProgressEvery = 256;      // queue pops between progress reports
constexpr double kMaxSectorDetour = 2;   // longest sector-respecting path, relative to the shortest free one

// A rejection on its way to Partition::rejected, with the trace event of the image test that made it.
struct Why {
  RejectedPair pair;
  int event = -1;  // index into PartitionMemo::Trace::events; -1: not an image test's
};
using Whys = std::vector<Why>;

// An accepted pair around an end vertex, as the cyclic-order tests read it: the ring slot of its exit
// and its curve (its image angle at the vertex comes from the two points' positions).
struct AroundPair {
  int k = 0;
  int from = 0, to = 0;  // the path's points
  bool atFrom = false;   // the vertex is the path's from end
};

// A decision that read photo positions (PartitionMemo::Trace).
struct TraceEvent {
  enum class Kind : unsigned char { Test, Sector, Order };
  Kind kind = Kind::Test;
  int photo = 0, a = 0, b = 0;     // Test: the segment a-b; Sector, Order: the pair self (a) -> other (b)
  int count = 0;                   // Test: the photo's curves then; Sector: ring size; Order: exit slot
  bool result = false;             // Test, Order
  std::vector<AroundPair> around;  // Sector, Order
  std::vector<char> mask;          // Sector
};

// Slots of a ring of d halfedges in which a new pair at image angle `angle` must leave: strictly between
// the pairs just clockwise and counter-clockwise of it (all slots with fewer than 2 pairs around).
std::vector<char> sectorSlots(int d, std::vector<std::pair<int, double>> around, double angle) {
  std::vector<char> mask(2 * d, 1);
  if (around.size() < 2) return mask;
  std::sort(around.begin(), around.end(), [](const auto& x, const auto& y) { return x.second < y.second; });
  const auto next = std::upper_bound(around.begin(), around.end(), angle,
                                     [](double a, const std::pair<int, double>& x) { return a < x.second; });
  const int to = (next == around.end() ? around.front() : *next).first;
  const int from = (next == around.begin() ? around.back() : *(next - 1)).first;
  std::fill(mask.begin(), mask.end(), 0);
  for (int s = (2 * from + 1) % (2 * d); s != 2 * to; s = (s + 1) % (2 * d)) mask[s] = 1;
  return mask;
}

// The mesh cyclic order of the pairs around a vertex, the new one leaving through ring slot k, equals
// their image cyclic order (the new one at `angle`).
bool sameCyclicOrder(std::vector<std::pair<int, double>> around, int k, double angle) {
  around.emplace_back(k, angle);
  const int n = int(around.size());
  std::vector<int> byMesh(n), byImage(n);
  for (int i = 0; i < n; ++i) byMesh[i] = byImage[i] = i;
  std::sort(byMesh.begin(), byMesh.end(), [&](int x, int y) { return around[x].first < around[y].first; });
  std::sort(byImage.begin(), byImage.end(), [&](int x, int y) { return around[x].second < around[y].second; });
  // Rotate both so that the new pair (last) comes first, then compare.
  std::rotate(byMesh.begin(), std::find(byMesh.begin(), byMesh.end(), n - 1), byMesh.end());
  std::rotate(byImage.begin(), std::find(byImage.begin(), byImage.end(), n - 1), byImage.end());
  return byMesh == byImage;
}

}  // namespace

// The last run: what it read besides positions (a replay needs all of it unchanged), the positions,
// every decision that read them, and its result.
struct PartitionMemo::Trace {
  std::shared_ptr<const Mesh> mesh;
  PartitionOptions options;
  std::vector<std::string> photoKeys;
  std::vector<FeatureChain> chains;
  std::vector<std::pair<int, std::vector<int>>> points;  // per point: its vertex and its photos, in order
  std::vector<Vec2> pos;                                 // [canonical point * photos + photo]; NaN: none
  std::vector<TraceEvent> events;                        // in the order the run made them
  std::vector<std::vector<std::pair<int, int>>> curves;  // per photo: its curves' points, in acceptance order
  std::vector<int> rejectedEvent;                        // per Partition::rejected entry: its image test event or -1
  std::shared_ptr<const Partition> result;

  // The scene and options differ from the traced run's at most in positions of points.
  bool replayable(const Scene& scene, const PartitionOptions& o) const {
    if (!result || scene.mesh != mesh || o.backgroundThresholdPx != options.backgroundThresholdPx ||
        o.curveSampleSpacingPx != options.curveSampleSpacingPx || o.maxSteinerPerPath != options.maxSteinerPerPath ||
        scene.photoKeys != photoKeys || scene.photoKeys.size() != scene.photos.size() ||
        scene.project.chains != chains || scene.project.points.size() != points.size())
      return false;
    for (const std::string& key : photoKeys)
      if (key.empty()) return false;  // a photo of unknown content
    for (size_t i = 0; i < points.size(); ++i) {
      const FeaturePoint& p = scene.project.points[i];
      if (p.vertex != points[i].first || p.at.size() != points[i].second.size()) return false;
      for (size_t k = 0; k < p.at.size(); ++k)
        if (p.at[k].photo != points[i].second[k]) return false;
    }
    return true;
  }
};

namespace {

Vec3 pointOf(const TriMesh& tri, int v) {
  const auto& p = tri.point(VertexHandle(v));
  return {p[0], p[1], p[2]};
}

double pathLength(const TriMesh& tri, const std::vector<int>& path) {
  double length = 0;
  for (size_t k = 1; k < path.size(); ++k) length += (pointOf(tri, path[k]) - pointOf(tri, path[k - 1])).norm();
  return length;
}

std::string number(double x) {
  std::ostringstream s;
  s.precision(3);
  s << x;
  return s.str();
}

// ---- Shortest paths -----------------------------------------------------------------------------------------

// Reusable A* state; stamps avoid clearing per-vertex arrays between searches.
struct SearchScratch {
  std::vector<double> dist;
  std::vector<int> parent;
  std::vector<unsigned> seen, closed;
  unsigned stamp = 0;
  std::vector<std::pair<double, int>> heap;
};

// A* along mesh edges with the Euclidean distance to `to` as heuristic (consistent, so the result is
// a shortest path). stepOk(h) tells whether the walk may follow outgoing halfedge h. Gives up (empty
// result) when every path would be longer than maxLength.
template <class StepOk>
std::vector<int> aStar(const TriMesh& tri, int from, int to, const StepOk& stepOk, SearchScratch& s,
                       double maxLength = std::numeric_limits<double>::infinity()) {
  if (from == to) return {from};
  const size_t n = tri.n_vertices();
  if (s.seen.size() < n) {
    s.dist.resize(n);
    s.parent.resize(n);
    s.seen.resize(n, 0);
    s.closed.resize(n, 0);
  }
  if (++s.stamp == 0) {
    std::fill(s.seen.begin(), s.seen.end(), 0u);
    std::fill(s.closed.begin(), s.closed.end(), 0u);
    s.stamp = 1;
  }
  const Vec3 goal = pointOf(tri, to);
  const auto greater = [](const std::pair<double, int>& a, const std::pair<double, int>& b) { return a > b; };
  s.heap.clear();
  s.seen[from] = s.stamp;
  s.dist[from] = 0;
  s.parent[from] = -1;
  s.heap.emplace_back((pointOf(tri, from) - goal).norm(), from);
  while (!s.heap.empty()) {
    std::pop_heap(s.heap.begin(), s.heap.end(), greater);
    const auto [estimate, u] = s.heap.back();
    s.heap.pop_back();
    if (estimate > maxLength) break;
    if (s.closed[u] == s.stamp) continue;
    s.closed[u] = s.stamp;
    if (u == to) {
      std::vector<int> path;
      for (int v = to; v >= 0; v = s.parent[v]) path.push_back(v);
      std::reverse(path.begin(), path.end());
      return path;
    }
    const Vec3 pu = pointOf(tri, u);
    for (auto h = tri.cvoh_iter(VertexHandle(u)); h.is_valid(); ++h) {
      const int w = tri.to_vertex_handle(*h).idx();
      if (s.closed[w] == s.stamp || !stepOk(*h)) continue;
      const Vec3 pw = pointOf(tri, w);
      const double d = s.dist[u] + (pw - pu).norm();
      if (s.seen[w] == s.stamp && d >= s.dist[w]) continue;
      s.seen[w] = s.stamp;
      s.dist[w] = d;
      s.parent[w] = u;
      s.heap.emplace_back(d + (pw - goal).norm(), w);
      std::push_heap(s.heap.begin(), s.heap.end(), greater);
    }
  }
  return {};
}

// Step rule of a search over unblocked vertices (the target is always allowed).
template <class Blocked>
auto freeSteps(const TriMesh& tri, int to, const Blocked& blocked) {
  return [&tri, to, &blocked](HalfedgeHandle h) {
    const int w = tri.to_vertex_handle(h).idx();
    return w == to || !blocked(w);
  };
}

// ---- Image geometry -------------------------------------------------------------------------------------

// The bounding box of a closed segment.
struct Box {
  Vec2 lo, hi;
  Box(const Vec2& a, const Vec2& b) : lo(a.cwiseMin(b)), hi(a.cwiseMax(b)) {}
  bool apart(const Box& o) const {
    return hi.x() < o.lo.x() || o.hi.x() < lo.x() || hi.y() < o.lo.y() || o.hi.y() < lo.y();
  }
  bool contains(const Vec2& q) const {
    return lo.x() <= q.x() && q.x() <= hi.x() && lo.y() <= q.y() && q.y() <= hi.y();
  }
};

// c lies on the closed segment ab (exact collinearity).
bool onSegment(const Vec2& a, const Vec2& b, const Vec2& c) {
  return Box(a, b).contains(c) && orient2(a, b, c) == 0;
}

// Closed segments ab and cd meet (proper crossing, touching or collinear overlap). The caller has
// compared their boxes first (closed segments whose boxes are apart cannot meet).
bool segmentsMeet(const Vec2& a, const Vec2& b, const Vec2& c, const Vec2& d) {
  const double o1 = orient2(a, b, c), o2 = orient2(a, b, d), o3 = orient2(c, d, a), o4 = orient2(c, d, b);
  if (((o1 > 0 && o2 < 0) || (o1 < 0 && o2 > 0)) && ((o3 > 0 && o4 < 0) || (o3 < 0 && o4 > 0))) return true;
  return onSegment(a, b, c) || onSegment(a, b, d) || onSegment(c, d, a) || onSegment(c, d, b);
}

// Direction angle of an image vector, counter-clockwise in the y-flipped frame: a surface seen from
// outside keeps its orientation in (x, -y) pixel coordinates.
double imageAngle(const Vec2& d) {
  return std::atan2(-d.y(), d.x());
}

// ---- The partition ---------------------------------------------------------------------------------------

class Partitioner {
 public:
  Partitioner(const Scene& scene, const PartitionOptions& options, const JobControl& job, PartitionMemo* memo)
      : scene_(scene), options_(options), job_(job), memo_(memo), tri_(out_.mesh.tri) {}

  Partition run() {
    setup();
    for (const FeatureChain& chain : scene_.project.chains) addChain(chain);
    allPairs();
    findCells();
    return std::move(out_);
  }

  // The run, traced into `trace` (its result included) for later replays.
  std::shared_ptr<const Partition> runTraced(PartitionMemo::Trace& trace) {
    trace = PartitionMemo::Trace();
    trace_ = &trace;
    Partition result = run();
    trace.mesh = scene_.mesh;
    trace.options = options_;
    trace.photoKeys = scene_.photoKeys;
    trace.chains = scene_.project.chains;
    for (const FeaturePoint& p : scene_.project.points) trace.points.push_back(photosOf(p));
    trace.pos = pos_;
    for (const auto& curves : photoCurves_) {
      trace.curves.emplace_back();
      for (const PhotoCurve& c : curves) trace.curves.back().emplace_back(c.a, c.b);
    }
    trace.result = std::make_shared<const Partition>(std::move(result));
    trace_ = nullptr;
    return trace.result;
  }

  // The run by replaying the trace of the last one, whose input differed from this one's at most in the
  // positions of points (replayable): null when a decision comes out otherwise (then only a run will
  // do). Updates the trace.
  std::shared_ptr<const Partition> replay(PartitionMemo::Trace& trace) {
    setupPoints();
    std::vector<char> moved(numPhotos_, 0);
    for (size_t i = 0; i < pos_.size(); ++i) {
      const Vec2 &now = pos_[i], &then = trace.pos[i];
      if (std::isnan(now.x()) != std::isnan(then.x())) return nullptr;
      if (!std::isnan(now.x()) && now != then) moved[i % numPhotos_] = 1;
    }
    for (int p = 0; p < numPhotos_; ++p)
      if (moved[p])
        for (const auto& [a, b] : trace.curves[p]) photoCurves_[p].emplace_back(a, b, pos(a, p), pos(b, p));
    // Every decision of the moved photos, in order, against the curves accepted before it.
    std::vector<std::pair<RejectReason, std::string>> tested(trace.events.size());
    for (size_t i = 0; i < trace.events.size(); ++i) {
      const TraceEvent& e = trace.events[i];
      if (!moved[e.photo]) continue;
      const double angle = imageAngle(pos(e.b, e.photo) - pos(e.a, e.photo));
      switch (e.kind) {
        case TraceEvent::Kind::Test:
          if (testSegment(e.a, e.b, e.photo, size_t(e.count), tested[i].first, tested[i].second) != e.result)
            return nullptr;
          break;
        case TraceEvent::Kind::Sector:
          if (sectorSlots(e.count, anglesOf(e.around, e.photo), angle) != e.mask) return nullptr;
          break;
        case TraceEvent::Kind::Order:
          if (sameCyclicOrder(anglesOf(e.around, e.photo), e.count, angle) != e.result) return nullptr;
          break;
      }
    }
    // The same course: the last result with the moved photos' curves and image-test rejections renewed.
    auto out = std::make_shared<Partition>(*trace.result);
    for (MeshPath& path : out->paths)
      for (Curve& c : path.curves)
        if (moved[c.photo]) c.from = pos(path.fromPoint, c.photo), c.to = pos(path.toPoint, c.photo);
    for (size_t i = 0; i < out->rejected.size(); ++i) {
      const int e = trace.rejectedEvent[i];
      if (e < 0 || !moved[trace.events[e].photo]) continue;
      out->rejected[i].reason = tested[e].first;
      out->rejected[i].detail = tested[e].second;
    }
    out->searchesReused = out->searches;
    out->replayed = true;
    trace.pos = pos_;
    trace.result = out;
    return out;
  }

  // A point's vertex and photos, in order: what the trace keeps of the points besides their positions.
  static std::pair<int, std::vector<int>> photosOf(const FeaturePoint& p) {
    std::pair<int, std::vector<int>> out{p.vertex, {}};
    for (const PhotoPoint& at : p.at) out.second.push_back(at.photo);
    return out;
  }

 private:
  // Allowed directions out of an end vertex: its outgoing halfedges counter-clockwise (ring[k]) and
  // slots 2k (halfedge ring[k]) and 2k+1 (the face between ring[k] and ring[k+1]).
  struct Sector {
    int v = -1;
    std::vector<HalfedgeHandle> ring;
    std::vector<char> slot;
    int index(HalfedgeHandle h) const { return int(std::find(ring.begin(), ring.end(), h) - ring.begin()); }
    bool allows(HalfedgeHandle h) const { return slot[2 * index(h)]; }
  };
  struct PhotoCurve {
    int a, b;  // points
    Vec2 pa, pb;
    Box box;
    PhotoCurve(int a_, int b_, const Vec2& pa_, const Vec2& pb_) : a(a_), b(b_), pa(pa_), pb(pb_), box(pa_, pb_) {}
  };

  // ---- Setup ----

  void setup() {
    const Mesh& input = *scene_.mesh;
    out_.mesh = input;
    out_.mesh.cornerUV.clear();
    out_.mesh.faceMaterial.clear();
    out_.mesh.materialNames.clear();
    out_.mesh.mtllib.clear();
    out_.mesh.faceGroup.clear();
    out_.mesh.groupNames.clear();
    if (int(out_.mesh.faceOrigin.size()) != input.numFaces()) out_.mesh.faceOrigin.clear();
    out_.faceParent.resize(input.numFaces());
    for (int f = 0; f < input.numFaces(); ++f) out_.faceParent[f] = f;
    const int nv = input.numVertices();
    onPath_.assign(nv, 0);
    edgeOnPath_.assign(tri_.n_edges(), 0);
    pathsAt_.assign(nv, {});
    setupPoints();
    // The state hash: the mesh, the options that shape paths, the feature vertices.
    for (int v = 0; v < nv; ++v) {
      const auto& p = tri_.point(VertexHandle(v));
      for (int k = 0; k < 3; ++k) {
        uint64_t bits;
        std::memcpy(&bits, &p[k], sizeof bits);
        mixState(bits);
      }
    }
    for (int f = 0; f < int(tri_.n_faces()); ++f)
      for (int v : out_.mesh.faceVertices(f)) mixState(uint64_t(v));
    mixState(uint64_t(options_.maxSteinerPerPath));
    for (int a : features_) mixState(uint64_t(vertexOf(a)));
  }

  // The points and their positions in each photo (what a replay needs; setup adds the mesh).
  void setupPoints() {
    const int nv = scene_.mesh->numVertices();
    for (size_t p = 0; p < scene_.photos.size(); ++p)
      photoKeyHash_.push_back(p < scene_.photoKeys.size() && !scene_.photoKeys[p].empty()
                                  ? hashMix(1, uint64_t(std::hash<std::string>()(scene_.photoKeys[p])))
                                  : 0);
    numPhotos_ = int(scene_.photos.size());
    feature_.assign(nv, 0);
    vertexPoint_.assign(nv, -1);
    photoCurves_.assign(numPhotos_, {});

    // Points sharing a vertex (allowed when their photos differ) are merged into the first one.
    const auto& points = scene_.project.points;
    const int np = int(points.size());
    canonical_.resize(np);
    pos_.assign(size_t(np) * numPhotos_, Vec2::Constant(std::numeric_limits<double>::quiet_NaN()));
    maskWords_ = (numPhotos_ + 63) / 64;
    photoMask_.assign(size_t(np) * maskWords_, 0);
    featureIndex_.assign(np, -1);
    for (int i = 0; i < np; ++i) {
      const int v = points[i].vertex;
      const std::string where = "points[" + std::to_string(i) + "]";
      TM_CHECK(v >= 0 && v < nv, where + ".vertex: " + std::to_string(v) + " is not a vertex of the mesh (" +
                                     std::to_string(nv) + " vertices)");
      out_.featureVertex.push_back(v);
      out_.featureId.push_back(pointId(scene_.project, i));
      if (vertexPoint_[v] < 0) {
        vertexPoint_[v] = i;
        featureIndex_[i] = int(features_.size());
        features_.push_back(i);
      }
      canonical_[i] = vertexPoint_[v];
      feature_[v] = 1;
      for (const PhotoPoint& at : points[i].at) {
        TM_CHECK(at.photo >= 0 && at.photo < numPhotos_,
                 where + ".at.photo: " + std::to_string(at.photo) + " is not a photo of the scene");
        Vec2& p = pos_[size_t(canonical_[i]) * numPhotos_ + at.photo];
        if (std::isnan(p.x())) p = Vec2(at.x, at.y);
      }
    }
    photoFeatures_.assign(numPhotos_, {});
    photoFeaturePos_.assign(numPhotos_, {});
    for (int a : features_)
      for (int p = 0; p < numPhotos_; ++p)
        if (hasPos(a, p)) {
          photoMask_[size_t(a) * maskWords_ + p / 64] |= uint64_t(1) << (p % 64);
          photoFeatures_[p].push_back(a);
          photoFeaturePos_[p].push_back(pos(a, p));
        }
    done_.assign(features_.size() * (features_.size() - (features_.empty() ? 0 : 1)) / 2, false);
  }

  // Every change of the mesh or of its blocked vertices enters the state hash (splitmix64 steps).
  void mixState(uint64_t x) {
    uint64_t z = (state_ ^ x) + 0x9e3779b97f4a7c15ull;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    state_ = z ^ (z >> 31);
  }

  // A search, from the memo when this state asked it before.
  template <class Search>
  std::vector<int> memoSearch(const std::string& query, const Search& search) {
    ++out_.searches;
    if (!memo_) return search();
    std::string key(reinterpret_cast<const char*>(&state_), sizeof(state_));
    key += query;
    if (const std::vector<int>* hit = memo_->find(key)) {
      ++out_.searchesReused;
      return *hit;
    }
    std::vector<int> path = search();
    memo_->store(key, path);
    return path;
  }

  bool hasPos(int point, int photo) const { return !std::isnan(pos_[size_t(point) * numPhotos_ + photo].x()); }
  const Vec2& pos(int point, int photo) const { return pos_[size_t(point) * numPhotos_ + photo]; }
  int vertexOf(int point) const { return scene_.project.points[point].vertex; }
  // A point as the user knows it: its id, which deletions of other points do not change.
  std::string pointName(int point) const { return std::to_string(pointId(scene_.project, point)); }
  static uint64_t pairKey(int a, int b) {
    return (uint64_t(uint32_t(std::min(a, b))) << 32) | uint32_t(std::max(a, b));
  }
  int pathOf(int a, int b) const {
    const auto it = pairPath_.find(pairKey(a, b));
    return it == pairPath_.end() ? -1 : it->second;
  }
  bool blocked(int v) const { return feature_[v] || onPath_[v]; }
  // The photos showing both points, from their photo masks (photoMask_).
  std::vector<int> commonPhotos(int a, int b) const {
    std::vector<int> photos;
    for (int w = 0; w < maskWords_; ++w)
      for (uint64_t m = photoMask_[size_t(a) * maskWords_ + w] & photoMask_[size_t(b) * maskWords_ + w]; m; m &= m - 1)
        photos.push_back(64 * w + __builtin_ctzll(m));
    return photos;
  }
  bool shareAPhoto(int a, int b) const {
    for (int w = 0; w < maskWords_; ++w)
      if (photoMask_[size_t(a) * maskWords_ + w] & photoMask_[size_t(b) * maskWords_ + w]) return true;
    return false;
  }
  // Pairs settled by the all-pairs queue: one bit per pair of features (i < j in features_ order).
  size_t doneBit(int a, int b) const {
    size_t i = size_t(featureIndex_[a]), j = size_t(featureIndex_[b]);
    if (i > j) std::swap(i, j);
    return i * (2 * features_.size() - i - 1) / 2 + (j - i - 1);
  }
  // An edge between two feature vertices whose pair may still become a path: kept by the bridge splits.
  bool pendingPair(int u, int w) const {
    if (!feature_[u] || !feature_[w]) return false;
    const int a = vertexPoint_[u], b = vertexPoint_[w];
    return pathOf(a, b) < 0 && !done_[doneBit(a, b)] && shareAPhoto(a, b);
  }

  void reject(int a, int b, int photo, RejectReason reason, const std::string& detail, Whys& into,
              int event = -1) const {
    into.push_back({{a, b, photo, reason, detail}, event});
  }
  void record(const Whys& rejections) {
    for (const Why& r : rejections)
      if (out_.rejected.size() < kMaxRejected) {
        out_.rejected.push_back(r.pair);
        if (trace_) trace_->rejectedEvent.push_back(r.event);
      }
  }

  // ---- Image-side tests (a)-(c) -----

  // True when segment a-b of `photo` may become a curve; otherwise appends the reason. Traced.
  bool imageTest(int a, int b, int photo, Whys& why) const {
    const int event = trace_ ? int(trace_->events.size()) : -1;
    RejectReason reason = RejectReason::CurveCrossesCurve;
    std::string detail;
    const bool ok = testSegment(a, b, photo, photoCurves_[photo].size(), reason, detail);
    if (trace_) {
      TraceEvent e;
      e.photo = photo, e.a = a, e.b = b, e.count = int(photoCurves_[photo].size()), e.result = ok;
      trace_->events.push_back(std::move(e));
    }
    if (!ok) reject(a, b, photo, reason, detail, why, event);
    return ok;
  }

  // The image tests of segment a-b of `photo` against the first `curves` accepted curves there; when it
  // fails, the reason and its detail.
  bool testSegment(int a, int b, int photo, size_t curves, RejectReason& reason, std::string& detail) const {
    const Vec2 &pa = pos(a, photo), &pb = pos(b, photo);
    reason = RejectReason::CurveCrossesCurve;
    if (pa == pb) {
      detail = "both ends at the same position";
      return false;
    }
    const Box box(pa, pb);
    for (size_t i = 0; i < curves; ++i) {
      const PhotoCurve& c = photoCurves_[photo][i];
      // Closed segments whose boxes are apart cannot meet (nor share an end: it lies in both boxes).
      if (box.apart(c.box)) continue;
      bool meets;
      if (c.a == a || c.a == b || c.b == a || c.b == b) {
        // Sharing one end point s: only a collinear overlap counts.
        const bool sharedA = c.a == a || c.a == b;
        const Vec2& s = sharedA ? c.pa : c.pb;
        const Vec2& w = sharedA ? c.pb : c.pa;                 // the curve's other end
        const Vec2& u = (sharedA ? c.a : c.b) == a ? pb : pa;  // the new segment's other end
        meets = cross2(u - s, w - s) == 0 && (u - s).dot(w - s) > 0;
      } else {
        meets = segmentsMeet(pa, pb, c.pa, c.pb);
      }
      if (meets) {
        detail = "crosses the curve of points " + pointName(c.a) + "-" + pointName(c.b);
        return false;
      }
    }
    const std::vector<int>& features = photoFeatures_[photo];
    const std::vector<Vec2>& at = photoFeaturePos_[photo];
    for (size_t i = 0; i < features.size(); ++i) {
      const Vec2& q = at[i];
      if (!box.contains(q)) continue;  // onSegment, with the segment's box made once
      const int k = features[i];
      if (k != a && k != b && orient2(pa, pb, q) == 0) {
        detail = "passes through point " + pointName(k);
        return false;
      }
    }
    // Paper 3.1: mean distance to the foreground over samples less than a pixel apart.
    const Photo& image = *scene_.photos[photo];
    if (image.distance.empty()) return true;
    const uint64_t key = photoKeyHash_[photo]
                             ? hashMix(hashMix(hashMix(photoKeyHash_[photo], pa), pb), options_.curveSampleSpacingPx)
                             : 0;
    const double* kept = memo_ && key ? memo_->findBackground(key) : nullptr;
    double mean = kept ? *kept : 0;
    if (!kept) {
      const double length = (pb - pa).norm();
      const int segments = int(std::floor(length / options_.curveSampleSpacingPx)) + 1;
      double sum = 0;
      for (int k = 0; k <= segments; ++k) {
        const Vec2 q = pa + (pb - pa) * (double(k) / segments);
        sum += image.distanceAt(q.x(), q.y());
      }
      mean = sum / (segments + 1);
      if (memo_ && key) memo_->storeBackground(key, mean);
    }
    if (mean > options_.backgroundThresholdPx) {
      reason = RejectReason::CurveOverBackground;
      detail = "mean distance " + number(mean) + " px > " + number(options_.backgroundThresholdPx) + " px";
      return false;
    }
    return true;
  }

  // The photos of `photos` that pass the image tests. Photos where the pair's path already has a
  // curve are reported as duplicates when `reportDuplicates`, else skipped.
  std::vector<int> imageTests(int a, int b, const std::vector<int>& photos, bool reportDuplicates, Whys& why) const {
    const int existing = pathOf(a, b);
    std::vector<int> pass;
    for (int p : photos) {
      if (existing >= 0 && curveIn(out_.paths[existing], p)) {
        if (reportDuplicates) reject(a, b, p, RejectReason::Duplicate, "already accepted in this photo", why);
        continue;
      }
      if (imageTest(a, b, p, why)) pass.push_back(p);
    }
    return pass;
  }

  static const Curve* curveIn(const MeshPath& path, int photo) {
    for (const Curve& c : path.curves)
      if (c.photo == photo) return &c;
    return nullptr;
  }

  // ---- Cyclic order (e) ----

  std::vector<HalfedgeHandle> ring(int v) const {
    std::vector<HalfedgeHandle> out;
    const HalfedgeHandle start = tri_.halfedge_handle(VertexHandle(v));
    if (!start.is_valid()) return out;
    HalfedgeHandle h = start;
    do {
      out.push_back(h);
      h = tri_.ccw_rotated_halfedge_handle(h);  // opposite(prev(h)): the next outgoing halfedge counter-clockwise
    } while (h != start && out.size() <= tri_.n_halfedges());
    return out;
  }

  // The neighbour through which a path leaves its end vertex v.
  static int exitNeighbour(const MeshPath& path, int v) {
    return path.vertices.front() == v ? path.vertices[1] : path.vertices[path.vertices.size() - 2];
  }

  // Accepted pairs at v with a curve in `photo` (except `skip`): ring index of their exit and their
  // points.
  std::vector<AroundPair> pairsAround(int v, int photo, const std::vector<HalfedgeHandle>& ring, int skip) const {
    std::vector<AroundPair> out;
    for (int id : pathsAt_[v]) {
      const MeshPath& path = out_.paths[id];
      if (id == skip || !curveIn(path, photo)) continue;
      const int w = exitNeighbour(path, v);
      const int k = int(std::find_if(ring.begin(), ring.end(),
                                     [&](HalfedgeHandle h) { return tri_.to_vertex_handle(h).idx() == w; }) -
                        ring.begin());
      TM_ASSERT(k < int(ring.size()));
      out.push_back({k, path.fromPoint, path.toPoint, vertexOf(path.fromPoint) == v});
    }
    return out;
  }
  // Their exits and the image angles of their curves at the vertex.
  std::vector<std::pair<int, double>> anglesOf(const std::vector<AroundPair>& around, int photo) const {
    std::vector<std::pair<int, double>> out;
    for (const AroundPair& p : around) {
      const Vec2 &from = pos(p.from, photo), &to = pos(p.to, photo);
      out.emplace_back(p.k, imageAngle(p.atFrom ? Vec2(to - from) : Vec2(from - to)));
    }
    return out;
  }

  // Slots of the sector of v in which the curve self->other of `photo` must leave (sectorSlots). Traced.
  std::vector<char> sectorMask(const std::vector<HalfedgeHandle>& ring, int v, int self, int other, int photo) const {
    std::vector<AroundPair> around = pairsAround(v, photo, ring, -1);
    std::vector<char> mask =
        sectorSlots(int(ring.size()), anglesOf(around, photo), imageAngle(pos(other, photo) - pos(self, photo)));
    if (trace_ && around.size() >= 2) {  // with fewer pairs every slot is open: positions not read
      TraceEvent e;
      e.kind = TraceEvent::Kind::Sector;
      e.photo = photo, e.a = self, e.b = other, e.count = int(ring.size());
      e.around = std::move(around);
      e.mask = mask;
      trace_->events.push_back(std::move(e));
    }
    return mask;
  }

  // Mesh cyclic order of the pairs around v (with the new one leaving through ring[exit]) equals
  // their image cyclic order in `photo`. Traced.
  bool cyclicOrderHolds(int v, int self, int other, int photo, int exitNeighbourVertex, int skip) const {
    const auto r = ring(v);
    std::vector<AroundPair> around = pairsAround(v, photo, r, skip);
    if (around.size() < 2) return true;  // positions not read
    const int k =
        int(std::find_if(r.begin(), r.end(),
                         [&](HalfedgeHandle h) { return tri_.to_vertex_handle(h).idx() == exitNeighbourVertex; }) -
            r.begin());
    TM_ASSERT(k < int(r.size()));
    const bool ok = sameCyclicOrder(anglesOf(around, photo), k, imageAngle(pos(other, photo) - pos(self, photo)));
    if (trace_) {
      TraceEvent e;
      e.kind = TraceEvent::Kind::Order;
      e.photo = photo, e.a = self, e.b = other, e.count = k, e.result = ok;
      e.around = std::move(around);
      trace_->events.push_back(std::move(e));
    }
    return ok;
  }

  // The photos of `photos` in which a path a -> b along `vertices` keeps the cyclic order at both
  // ends (test e); the others are rejected into `why` when given. `skip`: the pair's own path, if any.
  std::vector<int> orderedPhotos(int a, int b, const std::vector<int>& vertices, const std::vector<int>& photos,
                                 int skip, Whys* why) const {
    std::vector<int> kept;
    const int va = vertices.front(), vb = vertices.back();
    for (int p : photos) {
      const bool okA = cyclicOrderHolds(va, a, b, p, vertices[1], skip);
      if (okA && cyclicOrderHolds(vb, b, a, p, vertices[vertices.size() - 2], skip)) {
        kept.push_back(p);
      } else if (why) {
        reject(a, b, p, RejectReason::CyclicOrder,
               "around vertex " + std::to_string(okA ? vb : va) + " the order of the pairs differs from the mesh",
               *why);
      }
    }
    return kept;
  }

  // Joint sectors of both ends over `photos`; a photo whose sector leaves nothing in common with the
  // others' is dropped (CyclicOrder into `why` when given).
  void sectors(int a, int b, std::vector<int>& photos, Sector& sa, Sector& sb, Whys* why) const {
    for (auto [s, v] : {std::pair<Sector*, int>{&sa, vertexOf(a)}, {&sb, vertexOf(b)}}) {
      s->v = v;
      s->ring = ring(v);
      s->slot.assign(2 * s->ring.size(), 1);
      for (size_t k = 0; k < s->ring.size(); ++k) s->slot[2 * k + 1] = !tri_.is_boundary(s->ring[k]);
    }
    std::vector<int> kept;
    for (int p : photos) {
      std::vector<char> ma = sectorMask(sa.ring, sa.v, a, b, p), mb = sectorMask(sb.ring, sb.v, b, a, p);
      const bool anyA = intersect(ma, sa.slot), anyB = intersect(mb, sb.slot);
      if (anyA && anyB) {
        sa.slot = std::move(ma);
        sb.slot = std::move(mb);
        kept.push_back(p);
      } else if (why) {
        reject(a, b, p, RejectReason::CyclicOrder,
               "the order of pairs around vertex " + std::to_string(anyA ? sb.v : sa.v) +
                   " conflicts with the pair's other photos",
               *why);
      }
    }
    photos = std::move(kept);
  }

  // mask &= other; true when something is left.
  static bool intersect(std::vector<char>& mask, const std::vector<char>& other) {
    bool any = false;
    for (size_t s = 0; s < mask.size(); ++s) any |= (mask[s] = mask[s] && other[s]) != 0;
    return any;
  }

  // ---- Mesh-side tests (d) ----

  // Shortest path from a to b leaving and entering through the sectors, over free vertices only, if
  // one is at most maxLength long.
  std::vector<int> searchInSectors(const Sector& sa, const Sector& sb, double maxLength) {
    const auto stepOk = [&](HalfedgeHandle h) {
      const int u = tri_.from_vertex_handle(h).idx(), w = tri_.to_vertex_handle(h).idx();
      if (u == sa.v && !sa.allows(h)) return false;
      if (w == sb.v) return sb.allows(tri_.opposite_halfedge_handle(h));
      return !blocked(w);
    };
    std::string query = "S";
    for (int x : {sa.v, sb.v}) query.append(reinterpret_cast<const char*>(&x), sizeof(x));
    query.append(reinterpret_cast<const char*>(&maxLength), sizeof(maxLength));
    query.append(sa.slot.begin(), sa.slot.end());
    query += '|';
    query.append(sb.slot.begin(), sb.slot.end());
    return memoSearch(query, [&] { return aStar(tri_, sa.v, sb.v, stepOk, scratch_, maxLength); });
  }

  // Shortest path over free vertices, in any direction. The last result is kept: the queue's length
  // estimate of a pair is usually followed by its full test.
  const std::vector<int>& searchFree(int from, int to) {
    if (lastFree_.from != from || lastFree_.to != to || lastFree_.version != version_) {
      const auto isBlocked = [this](int v) { return blocked(v); };
      std::string query = "F";
      for (int x : {from, to}) query.append(reinterpret_cast<const char*>(&x), sizeof(x));
      lastFree_ = {from, to, version_,
                   memoSearch(query, [&] { return aStar(tri_, from, to, freeSteps(tri_, to, isBlocked), scratch_); })};
    }
    return lastFree_.path;
  }

  // The sector of s has a first step: a free neighbour, or the other end through its own sector.
  bool hasExit(const Sector& s, const Sector& other) const {
    for (size_t k = 0; k < s.ring.size(); ++k) {
      const int w = tri_.to_vertex_handle(s.ring[k]).idx();
      if (s.slot[2 * k] && (w == other.v ? other.allows(tri_.opposite_halfedge_handle(s.ring[k])) : !blocked(w)))
        return true;
    }
    return false;
  }

  // Steiner vertex (Kraevoy et al. 2003): splits the edge opposite the end vertex in the sector face
  // nearest to the target, giving the path a free first vertex. False when no face can be split.
  bool splitInSector(const Sector& s, int target) {
    const Vec3 goal = pointOf(tri_, target);
    EdgeHandle best;
    double bestDistance = std::numeric_limits<double>::infinity();
    for (size_t k = 0; k < s.ring.size(); ++k) {
      if (!s.slot[2 * k + 1]) continue;
      const HalfedgeHandle opposite = tri_.next_halfedge_handle(s.ring[k]);
      const EdgeHandle e = tri_.edge_handle(opposite);
      if (edgeOnPath_[e.idx()]) continue;
      const Vec3 mid = 0.5 * (pointOf(tri_, tri_.from_vertex_handle(opposite).idx()) +
                              pointOf(tri_, tri_.to_vertex_handle(opposite).idx()));
      const double d = (mid - goal).norm();
      if (d < bestDistance) bestDistance = d, best = e;
    }
    if (!best.is_valid()) return false;
    splitEdge(best);
    return true;
  }

  // Splits edge e at its midpoint. New faces inherit the parent of the face they were cut from.
  void splitEdge(EdgeHandle e) {
    mixState(3);
    mixState(uint64_t(tri_.from_vertex_handle(tri_.halfedge_handle(e, 0)).idx()));
    mixState(uint64_t(tri_.to_vertex_handle(tri_.halfedge_handle(e, 0)).idx()));
    std::vector<std::pair<int, int>> sides;  // (vertex opposite the edge, face) per side
    for (int i = 0; i < 2; ++i) {
      const HalfedgeHandle h = tri_.halfedge_handle(e, i);
      if (!tri_.is_boundary(h))
        sides.emplace_back(tri_.to_vertex_handle(tri_.next_halfedge_handle(h)).idx(), tri_.face_handle(h).idx());
    }
    const HalfedgeHandle h = tri_.halfedge_handle(e, 0);
    const VertexHandle m =
        tri_.add_vertex(0.5 * (tri_.point(tri_.from_vertex_handle(h)) + tri_.point(tri_.to_vertex_handle(h))));
    const int firstNew = int(tri_.n_faces());
    tri_.split_edge(e, m);
    for (int f = firstNew; f < int(tri_.n_faces()); ++f) {
      const auto corners = out_.mesh.faceVertices(f);
      int from = -1;
      for (const auto& [corner, face] : sides)
        if (std::find(corners.begin(), corners.end(), corner) != corners.end()) from = face;
      TM_ASSERT(from >= 0);
      out_.faceParent.push_back(out_.faceParent[from]);
      if (!out_.mesh.faceOrigin.empty()) out_.mesh.faceOrigin.push_back(out_.mesh.faceOrigin[from]);
    }
    feature_.push_back(0);
    onPath_.push_back(0);
    edgeOnPath_.resize(tri_.n_edges(), 0);
    ++out_.steinerVertices;
    ++version_;
  }

  // Non-path edges between two blocked vertices next to `vertices` ("bridges"): splitting them lets
  // later paths pass between neighbouring paths. Edges of pending feature pairs are kept.
  bool isBridge(HalfedgeHandle h) const {
    const int u = tri_.from_vertex_handle(h).idx(), w = tri_.to_vertex_handle(h).idx();
    return !edgeOnPath_[tri_.edge_handle(h).idx()] && blocked(u) && blocked(w) && !pendingPair(u, w);
  }
  std::vector<EdgeHandle> bridges(const std::vector<int>& vertices) const {
    std::vector<EdgeHandle> out;
    for (int u : vertices)
      for (auto h = tri_.cvoh_iter(VertexHandle(u)); h.is_valid(); ++h)
        if (isBridge(*h) && std::find(out.begin(), out.end(), tri_.edge_handle(*h)) == out.end())
          out.push_back(tri_.edge_handle(*h));
    return out;
  }

  // ---- Candidates ----

  // Tries pair a-b in `photos` (image tests passed); accepts it or appends the reasons to `why`.
  void connect(int a, int b, std::vector<int> photos, bool chain, Whys& why) {
    const int existing = pathOf(a, b);
    if (existing >= 0) {
      // The pair already has a path (another chain's photo): add the curves whose cyclic order holds.
      const MeshPath& path = out_.paths[existing];
      for (int p : orderedPhotos(path.fromPoint, path.toPoint, path.vertices, photos, existing, &why))
        addCurve(existing, p);
      return;
    }

    Sector sa, sb;
    int steiner = 0;
    for (;;) {
      sectors(a, b, photos, sa, sb, steiner == 0 ? &why : nullptr);
      if (photos.empty()) return;
      const Sector* starving = !hasExit(sa, sb) ? &sa : !hasExit(sb, sa) ? &sb : nullptr;
      if (!starving || steiner >= options_.maxSteinerPerPath ||
          !splitInSector(*starving, starving == &sa ? sb.v : sa.v))
        break;
      ++steiner;
    }
    // The shortest free path, if it keeps every photo's cyclic order; else the shortest one leaving and
    // entering through the photos' sectors (Praun et al. 2001, Kraevoy et al. 2003), unless that is
    // more than kMaxSectorDetour times longer: then the photos whose order is broken are rejected.
    std::vector<int> path = searchFree(sa.v, sb.v);
    if (path.empty()) {
      reject(a, b, -1, RejectReason::NoPath,
             "no mesh path from vertex " + std::to_string(sa.v) + " to " + std::to_string(sb.v) +
                 " avoids the accepted paths",
             why);
      return;
    }
    if (orderedPhotos(a, b, path, photos, -1, nullptr).size() < photos.size()) {
      std::vector<int> inSectors = searchInSectors(sa, sb, kMaxSectorDetour * pathLength(tri_, path));
      if (!inSectors.empty()) path = std::move(inSectors);
    }
    const std::vector<int> kept = orderedPhotos(a, b, path, photos, -1, &why);
    if (kept.empty()) return;

    // Accept, then split the bridges next to the new path (bounded by maxSteinerPerPath).
    const int id = int(out_.paths.size());
    out_.paths.push_back({a, b, path, {}, chain, pathLength(tri_, path)});
    mark(id, 1);
    const std::vector<EdgeHandle> toSplit = bridges(path);
    if (steiner + int(toSplit.size()) > options_.maxSteinerPerPath) {
      mark(id, 0);
      out_.paths.pop_back();
      reject(a, b, -1, RejectReason::NoPath,
             "the path would need " + std::to_string(steiner + toSplit.size()) + " Steiner vertices (at most " +
                 std::to_string(options_.maxSteinerPerPath) + ")",
             why);
      return;
    }
    for (int p : kept) addCurve(id, p);
    for (EdgeHandle e : toSplit) splitEdge(e);
    ++version_;
  }

  // Marks (on = 1) or unmarks path `id`'s vertices and edges as blocked.
  void mark(int id, char on) {
    const MeshPath& path = out_.paths[id];
    const auto& v = path.vertices;
    mixState(on ? 1 : 2);
    for (int x : v) mixState(uint64_t(x));
    for (size_t k = 1; k + 1 < v.size(); ++k) onPath_[v[k]] = on;
    for (size_t k = 1; k < v.size(); ++k)
      edgeOnPath_[tri_.edge_handle(tri_.find_halfedge(VertexHandle(v[k - 1]), VertexHandle(v[k]))).idx()] = on;
    const int ends[2] = {v.front(), v.back()};
    for (int e : ends) {
      auto& at = pathsAt_[e];
      if (on)
        at.push_back(id);
      else
        at.erase(std::remove(at.begin(), at.end(), id), at.end());
    }
    if (on)
      pairPath_[pairKey(path.fromPoint, path.toPoint)] = id;
    else
      pairPath_.erase(pairKey(path.fromPoint, path.toPoint));
  }

  void addCurve(int id, int photo) {
    MeshPath& path = out_.paths[id];
    path.curves.push_back({photo, pos(path.fromPoint, photo), pos(path.toPoint, photo)});
    photoCurves_[photo].emplace_back(path.fromPoint, path.toPoint, path.curves.back().from, path.curves.back().to);
    ++version_;
  }

  // Feature lines and polygons enter before any other pair (paper 3.1), in chain order.
  void addChain(const FeatureChain& chain) {
    const int n = int(chain.points.size());
    for (int k = 0; k + (chain.closed ? 0 : 1) < n; ++k) {
      const int a = canonical_[chain.points[k]], b = canonical_[chain.points[(k + 1) % n]];
      if (a == b || (k == 1 && n == 2 && chain.closed)) continue;  // a 2-point polygon is one segment
      Whys why;
      const std::vector<int> pass = imageTests(a, b, {chain.photo}, true, why);
      if (!pass.empty()) connect(a, b, pass, true, why);
      chainTried_.emplace(pairKey(a, b), chain.photo);
      record(why);
    }
  }
  bool triedInChain(int a, int b, int photo) const {
    return !chainTried_.empty() && chainTried_.count({pairKey(a, b), photo}) > 0;
  }

  // The all-pairs queue, smallest (key, a, b) first: the first keys sorted once, the deferred pairs in a
  // heap (a pair is in the queue at most once, so the order is strict and the same as one heap's).
  struct PairEntry {
    double key;
    int a, b;
    bool exact;
    int version;
    bool operator>(const PairEntry& o) const { return key != o.key ? key > o.key : a != o.a ? a > o.a : b > o.b; }
  };
  class PairQueue {
   public:
    explicit PairQueue(std::vector<PairEntry> first) : first_(std::move(first)) {
      std::sort(first_.begin(), first_.end(), [](const PairEntry& x, const PairEntry& y) { return y > x; });
    }
    size_t size() const { return first_.size() - next_ + deferred_.size(); }
    bool empty() const { return size() == 0; }
    const PairEntry& top() const {
      if (next_ == first_.size()) return deferred_.top();
      if (deferred_.empty() || deferred_.top() > first_[next_]) return first_[next_];
      return deferred_.top();
    }
    void pop() {
      if (next_ < first_.size() && (deferred_.empty() || deferred_.top() > first_[next_]))
        ++next_;
      else
        deferred_.pop();
    }
    void push(const PairEntry& e) { deferred_.push(e); }

   private:
    std::vector<PairEntry> first_;
    size_t next_ = 0;
    std::priority_queue<PairEntry, std::vector<PairEntry>, std::greater<PairEntry>> deferred_;
  };

  // All pairs in order of mesh path length (paper 3.1), evaluated lazily: the key starts as the
  // Euclidean distance (a lower bound) and becomes the path length when the pair reaches the top.
  void allPairs() {
    findNearRadii();
    std::vector<PairEntry> first;
    for (size_t i = 0; i < features_.size(); ++i)
      for (size_t j = i + 1; j < features_.size(); ++j) {
        const int a = features_[i], b = features_[j];
        if (shareAPhoto(a, b))
          first.push_back({distance(a, b), a, b, false, -1});
        else if (near(a, b))
          record({{a, b, -1, RejectReason::NoCommonPhoto, "no photo shows both points"}});
      }
    PairQueue queue(std::move(first));

    const double total = double(queue.size());
    int pops = 0, finished = 0;
    while (!queue.empty()) {
      const PairEntry e = queue.top();
      queue.pop();
      if (++pops % kProgressEvery == 0) job_.progress(StageId::Partition, finished / total, "partition");
      std::vector<int> photos;
      for (int p : commonPhotos(e.a, e.b))
        if (!triedInChain(e.a, e.b, p)) photos.push_back(p);
      Whys why;
      std::vector<int> pass = imageTests(e.a, e.b, photos, false, why);
      if (!pass.empty() && pathOf(e.a, e.b) < 0 && (!e.exact || e.version != version_)) {
        // Defer the pair while its shortest free path is longer than the next key.
        const std::vector<int>& path = searchFree(vertexOf(e.a), vertexOf(e.b));
        if (!path.empty() && !queue.empty()) {
          const double length = pathLength(tri_, path);
          if (length > queue.top().key) {
            queue.push({length, e.a, e.b, true, version_});
            continue;
          }
        }
      }
      if (!pass.empty()) connect(e.a, e.b, pass, false, why);
      ++finished;
      done_[doneBit(e.a, e.b)] = true;
      if (near(e.a, e.b)) record(why);
      // A rejected pair of neighbouring features no longer needs its edge: it becomes a bridge.
      const HalfedgeHandle direct = tri_.find_halfedge(VertexHandle(vertexOf(e.a)), VertexHandle(vertexOf(e.b)));
      if (direct.is_valid() && isBridge(direct)) splitEdge(tri_.edge_handle(direct));
    }
  }

  double distance(int a, int b) const { return (pointOf(tri_, vertexOf(a)) - pointOf(tri_, vertexOf(b))).norm(); }

  // Rejections of the all-pairs queue are kept for near pairs only: one is among the other's
  // kNearFeatures nearest features (3D distance). Far pairs fail by the thousand, as expected.
  void findNearRadii() {
    nearRadius_.assign(scene_.project.points.size(), std::numeric_limits<double>::infinity());
    if (features_.size() <= size_t(kNearFeatures) + 1) return;
    std::vector<double> d;
    for (int a : features_) {
      d.clear();
      for (int b : features_)
        if (b != a) d.push_back(distance(a, b));
      std::nth_element(d.begin(), d.begin() + kNearFeatures - 1, d.end());
      nearRadius_[a] = d[kNearFeatures - 1];
    }
  }
  bool near(int a, int b) const { return distance(a, b) <= std::max(nearRadius_[a], nearRadius_[b]); }

  // ---- Cells ----

  void findCells() {
    const int nf = int(tri_.n_faces());
    out_.faceCell.assign(nf, -1);
    std::vector<int> stack;
    for (int seed = 0; seed < nf; ++seed) {
      if (out_.faceCell[seed] >= 0) continue;
      const int cell = out_.numCells++;
      out_.faceCell[seed] = cell;
      stack.push_back(seed);
      while (!stack.empty()) {
        const FaceHandle f(stack.back());
        stack.pop_back();
        for (auto h = tri_.cfh_iter(f); h.is_valid(); ++h) {
          if (edgeOnPath_[tri_.edge_handle(*h).idx()]) continue;
          const FaceHandle g = tri_.opposite_face_handle(*h);
          if (g.is_valid() && out_.faceCell[g.idx()] < 0) {
            out_.faceCell[g.idx()] = cell;
            stack.push_back(g.idx());
          }
        }
      }
    }
  }

  const Scene& scene_;
  const PartitionOptions& options_;
  const JobControl& job_;
  PartitionMemo* memo_;
  uint64_t state_ = 0;  // hash of the mesh state (see PartitionMemo)
  Partition out_;
  TriMesh& tri_;
  int numPhotos_ = 0;
  std::vector<int> canonical_;             // per point: the first point with its vertex
  std::vector<int> features_;              // canonical points, in point order
  std::vector<Vec2> pos_;                  // [point * numPhotos + photo]; NaN where the point has no position
  std::vector<int> vertexPoint_;           // per input vertex: its canonical point, -1 if none
  std::vector<double> nearRadius_;         // per point: distance to its kNearFeatures-th nearest feature
  std::vector<uint64_t> photoKeyHash_;     // per photo: hash of Scene::photoKeys (0: none, no memo)
  std::vector<char> feature_;              // per vertex
  std::vector<char> onPath_;               // per vertex: inner vertex of an accepted path
  std::vector<char> edgeOnPath_;           // per edge
  std::vector<std::vector<int>> pathsAt_;  // per input vertex: accepted paths ending there
  std::vector<std::vector<PhotoCurve>> photoCurves_;  // per photo: accepted curves
  std::unordered_map<uint64_t, int> pairPath_;        // pair -> accepted path
  std::vector<bool> done_;                            // pairs settled by the all-pairs queue (doneBit)
  std::vector<int> featureIndex_;                     // per point: its index in features_, -1 if not canonical
  int maskWords_ = 0;                                 // 64-bit words per point in photoMask_
  std::vector<uint64_t> photoMask_;  // [point * maskWords_ + w]: bit p = the point has a position in photo p
  std::vector<std::vector<int>> photoFeatures_;     // per photo: the features with a position in it, in features_ order
  std::vector<std::vector<Vec2>> photoFeaturePos_;  // ... and their positions there
  std::set<std::pair<uint64_t, int>> chainTried_;   // (pair, photo) tried as a chain segment
  int version_ = 0;                                 // bumped at every change of paths or mesh
  struct {
    int from = -1, to = -1, version = -1;
    std::vector<int> path;
  } lastFree_;  // see searchFree
  SearchScratch scratch_;
  PartitionMemo::Trace* trace_ = nullptr;  // the trace being recorded (runTraced)
};

}  // namespace

void PartitionMemo::beginRun() {
  previous_ = std::move(current_);
  current_.clear();
  previousBackground_ = std::move(background_);
  background_.clear();
}

const double* PartitionMemo::findBackground(uint64_t key) {
  if (auto it = background_.find(key); it != background_.end()) return &it->second;
  auto old = previousBackground_.find(key);
  if (old == previousBackground_.end()) return nullptr;
  return &(background_[key] = old->second);
}

const std::vector<int>* PartitionMemo::find(const std::string& key) {
  auto it = current_.find(key);
  if (it != current_.end()) return &it->second;
  auto old = previous_.find(key);
  if (old == previous_.end()) return nullptr;
  auto moved = current_.emplace(key, std::move(old->second)).first;
  previous_.erase(old);
  return &moved->second;
}

void PartitionMemo::store(const std::string& key, const std::vector<int>& path) {
  current_[key] = path;
}

PartitionMemo::PartitionMemo() = default;
PartitionMemo::~PartitionMemo() = default;

namespace {

void checkInput(const Scene& scene, const PartitionOptions& options) {
  TM_CHECK(scene.mesh, "partition: the scene has no mesh");
  TM_CHECK(options.curveSampleSpacingPx > 0 && options.curveSampleSpacingPx < 1,
           "partition: curveSampleSpacingPx " + number(options.curveSampleSpacingPx) + " must be in (0, 1)");
}

}  // namespace

std::shared_ptr<const Partition> partitionShared(const Scene& scene, const PartitionOptions& options,
                                                 const JobControl& job, PartitionMemo* memo) {
  checkInput(scene, options);
  if (!memo) return std::make_shared<const Partition>(Partitioner(scene, options, job, nullptr).run());
  if (memo->trace && memo->trace->replayable(scene, options))
    if (auto replayed = Partitioner(scene, options, job, memo).replay(*memo->trace)) {
      ++memo->replays;
      return replayed;
    }
  memo->beginRun();
  if (!memo->trace) memo->trace = std::make_unique<PartitionMemo::Trace>();
  return Partitioner(scene, options, job, memo).runTraced(*memo->trace);
}

Partition partitionMesh(const Scene& scene, const PartitionOptions& options, const JobControl& job,
                        PartitionMemo* memo) {
  if (memo) return *partitionShared(scene, options, job, memo);
  checkInput(scene, options);
  return Partitioner(scene, options, job, nullptr).run();
}

std::vector<int> shortestPath(const Mesh& mesh, int from, int to, const std::vector<char>& blocked) {
  const int n = mesh.numVertices();
  TM_CHECK(from >= 0 && from < n && to >= 0 && to < n, "shortestPath: vertex " +
                                                           std::to_string(from < 0 || from >= n ? from : to) +
                                                           " is not a vertex of the mesh (" + std::to_string(n) + ")");
  SearchScratch scratch;
  const auto isBlocked = [&](int v) { return v < int(blocked.size()) && blocked[v]; };
  return aStar(mesh.tri, from, to, freeSteps(mesh.tri, to, isBlocked), scratch);
}

}  // namespace montage
