#include "mapping/coverage.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <queue>
#include <set>

#include "io/project.h"
#include "mapping/camera.h"
#include "mapping/cells.h"
#include "mapping/projection.h"
#include "mapping/texture_map.h"

namespace montage {

namespace {

std::string joinList(const std::vector<int>& items, size_t most = 6) {
  std::string s;
  for (size_t i = 0; i < items.size() && i < most; ++i) {
    if (i > 0) s += i + 1 == items.size() ? " and " : ", ";
    s += std::to_string(items[i]);
  }
  if (items.size() > most) s += " and " + std::to_string(items.size() - most) + " more";
  return s;
}

std::string plural(size_t n, const char* one, const char* many) {
  return std::to_string(n) + " " + (n == 1 ? one : many);
}

// Everything analyseCoverage works from, indexed once.
class Analysis {
 public:
  Analysis(const CoverageInput& in) : in_(in), mesh_(in.partition.mesh) {
    const int nf = mesh_.numFaces();
    clickable_ = in.inputVertices > 0 ? std::min(in.inputVertices, mesh_.numVertices()) : mesh_.numVertices();
    TM_CHECK(in.map.numFaces() == nf, "coverage: the texture map has " + std::to_string(in.map.numFaces()) +
                                          " faces, the partition's mesh " + std::to_string(nf));
    TM_CHECK(static_cast<int>(in.partition.faceCell.size()) == nf, "coverage: the partition's faceCell has " +
                                                                       std::to_string(in.partition.faceCell.size()) +
                                                                       " entries for " + std::to_string(nf) + " faces");
    for (int c : in.partition.faceCell)
      TM_CHECK(
          c >= 0 && (c < static_cast<int>(in.cells.size()) || in.cells.empty()),
          "coverage: face cell " + std::to_string(c) + " has no plan (" + std::to_string(in.cells.size()) + " cells)");
    pointsAt_.resize(mesh_.numVertices());
    for (size_t p = 0; p < in.partition.featureVertex.size(); ++p) {
      const int v = in.partition.featureVertex[p];
      if (v >= 0 && v < mesh_.numVertices()) pointsAt_[v].push_back(static_cast<int>(p));
    }
    // A face is seen when some fitted photo can texture it; `allFit`: every photo's camera fits.
    allFit_ = in.photos > 0;
    seen_.assign(nf, 0);
    for (int p = 0; p < in.photos; ++p) {
      const PhotoView* view = viewOf(p);
      if (!view) {
        allFit_ = false;
        continue;
      }
      for (int f = 0; f < nf; ++f)
        if (view->faceQuality[f] > 0) seen_[f] = 1;
    }
  }

  CoverageReport run(const CoverageOptions& options) {
    CoverageReport report;
    const int nf = mesh_.numFaces();
    std::vector<double> area(nf);
    for (int f = 0; f < nf; ++f) {
      area[f] = mesh_.faceArea(f);
      report.totalArea += area[f];
      if (in_.map.facePhoto[f] != TextureMap::kEmpty) report.mappedArea += area[f];
    }
    report.mappedShare = report.totalArea > 0 ? report.mappedArea / report.totalArea : 1.0;

    // Connected components of empty faces (across edges).
    std::vector<int> component(nf, -1);
    std::vector<CoverageRegion> regions;
    for (int f0 = 0; f0 < nf; ++f0) {
      if (in_.map.facePhoto[f0] != TextureMap::kEmpty || component[f0] >= 0) continue;
      CoverageRegion r;
      std::vector<int> stack = {f0};
      component[f0] = static_cast<int>(regions.size());
      while (!stack.empty()) {
        const int f = stack.back();
        stack.pop_back();
        r.faces.push_back(f);
        for (auto g : mesh_.tri.ff_range(mesh_.tri.face_handle(f)))
          if (in_.map.facePhoto[g.idx()] == TextureMap::kEmpty && component[g.idx()] < 0) {
            component[g.idx()] = component[f0];
            stack.push_back(g.idx());
          }
      }
      std::sort(r.faces.begin(), r.faces.end());
      for (int f : r.faces) r.area += area[f];
      r.share = report.totalArea > 0 ? r.area / report.totalArea : 0;
      regions.push_back(std::move(r));
    }
    std::sort(regions.begin(), regions.end(),
              [](const CoverageRegion& a, const CoverageRegion& b) { return a.area > b.area; });
    for (CoverageRegion& r : regions) {
      if (r.share < options.minShare || static_cast<int>(report.regions.size()) >= options.maxRegions) {
        ++report.smallRegions;
        report.smallArea += r.area;
        continue;
      }
      describe(r, area);
      report.regions.push_back(std::move(r));
    }

    // Where to click next: regions with a click, by the area their clickable causes explain.
    for (size_t i = 0; i < report.regions.size(); ++i)
      if (report.regions[i].gain > 0) report.next.push_back(static_cast<int>(i));
    std::stable_sort(report.next.begin(), report.next.end(),
                     [&](int a, int b) { return report.regions[a].gain > report.regions[b].gain; });

    groupRejected(report);
    // The ids the user sees, for the words and report.json (deleting a point renumbers no other).
    report.featureIds = in_.partition.featureId;
    for (CoverageRegion& r : report.regions)
      for (RegionCause& c : r.causes)
        if (c.click.point >= 0) c.click.id = idOf(c.click.point);
    return report;
  }

 private:
  const PhotoView* viewOf(int p) const {
    if (p < 0 || p >= static_cast<int>(in_.views.size())) return nullptr;
    if (!in_.views[p]) return nullptr;
    const PhotoView& v = *in_.views[p];
    if (static_cast<int>(v.faceQuality.size()) != mesh_.numFaces() ||
        static_cast<int>(v.vertexVisible.size()) != mesh_.numVertices())
      return nullptr;
    return &v;
  }
  bool clickedIn(int point, int photo) const {
    if (point < 0 || point >= static_cast<int>(in_.project.points.size())) return false;
    for (const PhotoPoint& at : in_.project.points[point].at)
      if (at.photo == photo) return true;
    return false;
  }
  // A vertex as the user knows it (CoverageInput::documentVertex).
  std::string vertexName(int v) const { return std::to_string(in_.documentVertex ? in_.documentVertex(v) : v); }

  int pointAt(int vertex) const {
    return vertex >= 0 && vertex < static_cast<int>(pointsAt_.size()) && !pointsAt_[vertex].empty()
               ? pointsAt_[vertex].front()
               : -1;
  }
  int vertexOf(int point) const { return in_.partition.featureVertex[point]; }
  // A point as the user knows it: its id (Partition::featureId), not its index.
  int idOf(int point) const {
    const std::vector<int>& ids = in_.partition.featureId;
    return point >= 0 && point < static_cast<int>(ids.size()) ? ids[point] : point;
  }
  std::string name(int point) const { return "feature " + std::to_string(idOf(point)); }
  std::string listText(const std::vector<int>& points) const {
    std::vector<int> ids;
    for (int p : points) ids.push_back(idOf(p));
    return joinList(ids);
  }

  // The photo to click `vertex` in: one whose camera sees it when cameras say so, else (or among those)
  // the one holding most of `near` (features around the place), never one where `point` is clicked.
  int photoFor(int vertex, const std::vector<int>& near, int point = -1) const {
    int best = -1;
    double bestScore = -1;
    for (int p = 0; p < in_.photos; ++p) {
      if (point >= 0 && clickedIn(point, p)) continue;
      double score = 0;
      if (const PhotoView* view = viewOf(p)) {
        if (!view->vertexVisible[vertex]) continue;
        score += 1000;
      }
      for (int q : near) score += clickedIn(q, p) ? 1 : 0;
      if (score > bestScore) bestScore = score, best = p;
    }
    return best;
  }

  // The vertex of `faces` farthest along edges from the faces' border (a vertex also on another face,
  // or on the mesh border); the one nearest to `centre` when the faces have no border.
  int innerVertex(const std::vector<int>& faces, const Vec3& centre) const {
    std::set<int> inside(faces.begin(), faces.end());
    std::map<int, double> dist;
    std::map<int, std::vector<int>> adjacent;
    for (int f : faces) {
      const auto fv = mesh_.faceVertices(f);
      for (int k = 0; k < 3; ++k) {
        adjacent[fv[k]].push_back(fv[(k + 1) % 3]);
        adjacent[fv[k]].push_back(fv[(k + 2) % 3]);
      }
    }
    using Item = std::pair<double, int>;
    std::priority_queue<Item, std::vector<Item>, std::greater<>> queue;
    for (const auto& [v, _] : adjacent) {
      bool border = mesh_.tri.is_boundary(mesh_.tri.vertex_handle(v));
      for (auto g : mesh_.tri.vf_range(mesh_.tri.vertex_handle(v)))
        if (!inside.count(g.idx())) border = true;
      if (border) dist[v] = 0, queue.push({0.0, v});
    }
    int best = -1;
    double bestDist = -1;
    if (queue.empty()) {
      for (const auto& [v, _] : adjacent) {
        const double d = -(mesh_.position(v) - centre).norm();
        if (v < clickable_ && (best < 0 || d > bestDist)) best = v, bestDist = d;
      }
      return best;
    }
    while (!queue.empty()) {
      const auto [d, v] = queue.top();
      queue.pop();
      if (d > dist[v]) continue;
      if (d > bestDist && v < clickable_) bestDist = d, best = v;
      for (int w : adjacent[v]) {
        const double nd = d + (mesh_.position(v) - mesh_.position(w)).norm();
        const auto it = dist.find(w);
        if (it == dist.end() || nd < it->second) dist[w] = nd, queue.push({nd, w});
      }
    }
    return best;
  }

  // The vertex halfway along the shortest edge path between two features, or -1 when they are neighbours.
  int midVertex(int a, int b) const {
    const std::vector<int> path = shortestPath(mesh_, vertexOf(a), vertexOf(b));
    if (path.size() < 3) return -1;
    std::vector<double> along(path.size(), 0);
    for (size_t i = 1; i < path.size(); ++i)
      along[i] = along[i - 1] + (mesh_.position(path[i]) - mesh_.position(path[i - 1])).norm();
    int best = -1;
    for (size_t i = 1; i + 1 < path.size(); ++i)
      if (path[i] < clickable_ &&
          (best < 0 || std::abs(along[i] - along.back() / 2) < std::abs(along[best] - along.back() / 2)))
        best = static_cast<int>(i);
    return best < 0 ? -1 : path[best];
  }

  // The cause of an empty part whose features around it include a rejected pair.
  RegionCause pairCause(int index, const std::vector<int>& near) const {
    const RejectedPair& r = in_.partition.rejected[index];
    const int a = r.fromPoint, b = r.toPoint;
    RegionCause c;
    c.rejected = index;
    c.points = {a, b};
    const std::string pair = name(a) + " and " + name(b);
    const std::string inPhoto = r.photo >= 0 ? " in photo " + std::to_string(r.photo) : "";
    // A new feature halfway between them splits the pair into two shorter ones.
    auto between = [&](const std::string& fix) {
      const int mid = midVertex(a, b);
      if (mid < 0) {
        c.fix = "no mesh vertex lies between " + pair + ": subdivide the mesh there, or move one of them";
        return;
      }
      c.click.vertex = mid;
      c.click.point = pointAt(mid);
      std::vector<int> prefer = near;
      prefer.insert(prefer.end(), {a, b, a, b});  // the pair's own photos first
      const bool inPairPhoto = r.photo >= 0 && !clickedIn(c.click.point, r.photo) &&
                               (!viewOf(r.photo) || viewOf(r.photo)->vertexVisible[mid]);
      c.click.photo = inPairPhoto ? r.photo : photoFor(mid, prefer, c.click.point);
      c.fix = fix + " (vertex " + vertexName(mid) + ")" +
              (c.click.photo >= 0 ? " in photo " + std::to_string(c.click.photo) : std::string());
    };
    switch (r.reason) {
      case RejectReason::NoCommonPhoto: {
        c.cause = CoverageCause::NoCommonPhoto;
        c.why = pair + " are never clicked in the same photo, so no path joins them";
        // Click b where a is (or a where b is), in the photo holding most of the features around.
        for (int k = 0; k < 2 && !c.click.valid(); ++k) {
          const int have = k == 0 ? a : b, want = k == 0 ? b : a;
          int photo = -1;
          double best = -1;
          for (int p = 0; p < in_.photos; ++p) {
            if (!clickedIn(have, p) || clickedIn(want, p)) continue;
            const PhotoView* view = viewOf(p);
            if (view && !view->vertexVisible[vertexOf(want)]) continue;
            double score = 0;
            for (int q : near) score += clickedIn(q, p);
            if (score > best) best = score, photo = p;
          }
          if (photo >= 0) c.click = {want, vertexOf(want), photo};
        }
        c.fix = c.click.valid() ? "click " + name(c.click.point) + " in photo " + std::to_string(c.click.photo)
                                : "click " + pair + " in one photo that shows both";
        break;
      }
      case RejectReason::NoPath:
        c.cause = CoverageCause::NeedsRoom;
        c.why = "a path between " + pair + " needs more room: the mesh has no free path between them";
        between("add a feature between " + pair);
        break;
      case RejectReason::CurveCrossesCurve:
        c.cause = CoverageCause::CurveCrosses;
        c.why = "the straight line between " + pair + inPhoto + " crosses a line already accepted";
        between("add a feature between " + pair + " so each half stays clear");
        break;
      case RejectReason::CurveOverBackground:
        c.cause = CoverageCause::OverBackground;
        c.why = "the straight line between " + pair + inPhoto + " runs over the background";
        between("add a feature between " + pair + " on the subject");
        break;
      case RejectReason::CyclicOrder:
        c.cause = CoverageCause::CyclicOrder;
        c.why = "around " + pair + ", the lines come in another order" + inPhoto +
                " than on the mesh (a misplaced click, or the surface folds away)";
        between("check the clicks of " + pair + inPhoto + "; if they are right, add a feature between them");
        break;
      case RejectReason::Duplicate:
        c.cause = CoverageCause::NotTriangle;
        c.why = pair + " are already joined";
        break;
    }
    return c;
  }

  // The cause given by the rejected pairs among `near` (both ends; duplicates left out): the shortest one in
  // space whose fix is a click (a pair whose fix was already clicked yields none), else the shortest one.
  std::optional<RegionCause> rejectedCause(const std::vector<int>& near) const {
    std::set<int> set(near.begin(), near.end());
    std::vector<std::pair<double, int>> pairs;
    for (size_t i = 0; i < in_.partition.rejected.size(); ++i) {
      const RejectedPair& r = in_.partition.rejected[i];
      if (r.reason == RejectReason::Duplicate || !set.count(r.fromPoint) || !set.count(r.toPoint)) continue;
      const double length = (mesh_.position(vertexOf(r.fromPoint)) - mesh_.position(vertexOf(r.toPoint))).norm();
      pairs.emplace_back(length, static_cast<int>(i));
    }
    std::sort(pairs.begin(), pairs.end());
    for (const auto& [_, i] : pairs) {
      RegionCause c = pairCause(i, near);
      if (c.click.valid()) return c;
    }
    if (pairs.empty()) return std::nullopt;
    return pairCause(pairs.front().second, near);
  }

  // Replaces `c`'s click by a new feature amid the features of `near` clicked in the photo holding most
  // of them: the vertex of `faces` nearest to their centroid. Keeps `c` as it is when there is none.
  void fanClick(RegionCause& c, const std::vector<int>& faces, const std::vector<int>& near) const {
    int photo = -1, most = 0;
    for (int p = 0; p < in_.photos; ++p) {
      int n = 0;
      for (int q : near) n += clickedIn(q, p);
      if (n > most) most = n, photo = p;
    }
    if (photo < 0 || most < 3) return;
    Vec3 centroid = Vec3::Zero();
    std::vector<int> amid;
    for (int q : near)
      if (clickedIn(q, photo)) centroid += mesh_.position(vertexOf(q)), amid.push_back(q);
    centroid /= static_cast<double>(amid.size());
    const PhotoView* view = viewOf(photo);
    int best = -1;
    double bestDistance = std::numeric_limits<double>::infinity();
    for (int f : faces)
      for (int v : mesh_.faceVertices(f)) {
        if (v >= clickable_ || pointAt(v) >= 0 || (view && !view->vertexVisible[v])) continue;
        const double d = (mesh_.position(v) - centroid).norm();
        if (d < bestDistance) bestDistance = d, best = v;
      }
    if (best < 0) return;
    c.click = {-1, best, photo};
    c.fix = "add a feature amid features " + listText(amid) + ": click vertex " + vertexName(best) + " in photo " +
            std::to_string(photo);
  }

  // The features whose vertex lies on `faces` (inside or on their border), sorted.
  std::vector<int> featuresOn(const std::vector<int>& faces) const {
    std::set<int> points;
    for (int f : faces)
      for (int v : mesh_.faceVertices(f))
        for (int p : pointsAt_[v]) points.insert(p);
    return {points.begin(), points.end()};
  }

  // Explains the faces of one cell that lie in a region.
  RegionCause cellCause(const CellPlan* plan, const std::vector<int>& faces, const Vec3& centre) const {
    const std::vector<int> near = featuresOn(faces);
    RegionCause c;
    c.points = near;
    int seen = 0;
    for (int f : faces) seen += seen_[f];
    if (allFit_ && seen * 2 < static_cast<int>(faces.size())) {
      c.cause = CoverageCause::NotSeen;
      c.why = "no photo sees this part of the surface";
      c.fix = "inpaint it (strokes guide the fill), or add a photo that shows it";
      return c;
    }
    const auto newFeature = [&](const std::string& fix) {
      const int v = innerVertex(faces, centre);
      if (v < 0) return;
      c.click = {pointAt(v), v, photoFor(v, near, pointAt(v))};
      if (c.click.valid())
        c.fix = fix + ": click vertex " + vertexName(v) + " in photo " + std::to_string(c.click.photo);
    };
    const CellStatus status = plan ? plan->status : CellStatus::NotTriangle;
    if (allFit_ || status == CellStatus::Mapped) {
      c.cause = CoverageCause::Unprojected;
      c.why = "the photos' cameras cannot texture these faces (hidden, edge-on, or over the background)";
      c.fix = "inpaint it, or click features here in a photo that shows it";
      newFeature("add a feature here");
      if (!c.click.valid()) c.fix = "inpaint it, or add a photo that shows it";
      return c;
    }
    if (near.size() < 3) {
      c.cause = CoverageCause::FewFeatures;
      c.why = near.empty() ? "no feature lies on or around it"
                           : "only " + plural(near.size(), "feature", "features") + " (" + listText(near) +
                                 ") border it; a triangle needs three";
      c.fix = "click features around it in one photo";
      newFeature("add a feature here");
      return c;
    }
    std::vector<int> corners;
    if (plan)
      for (int v : plan->corners)
        if (pointAt(v) >= 0) corners.push_back(pointAt(v));
    switch (status) {
      case CellStatus::NoCommonPhoto: {
        // A polygon of four or more features sharing no photo: the paper's fix, a pair that cuts it into
        // triangles of features clicked together, comes first (one missing click rarely closes all its sides).
        if (corners.size() > 3)
          if (auto pair = rejectedCause(near)) {
            if (!pair->click.valid()) fanClick(*pair, faces, near);
            return *pair;
          }
        c.cause = CoverageCause::NoCommonPhoto;
        c.points = corners;
        c.why = "features " + listText(corners) + " share no photo";
        // The photo holding most corners; click the first corner it lacks there.
        int photo = -1, most = 0;
        for (int p = 0; p < in_.photos; ++p) {
          int n = 0;
          for (int q : corners) n += clickedIn(q, p);
          if (n > most && n < static_cast<int>(corners.size())) most = n, photo = p;
        }
        for (int q : corners)
          if (photo >= 0 && !clickedIn(q, photo) && (!viewOf(photo) || viewOf(photo)->vertexVisible[vertexOf(q)])) {
            c.click = {q, vertexOf(q), photo};
            break;
          }
        c.fix = c.click.valid() ? "click " + name(c.click.point) + " in photo " + std::to_string(c.click.photo)
                                : "click " + listText(corners) + " in one photo";
        return c;
      }
      case CellStatus::Mirrored:
        c.cause = CoverageCause::Mirrored;
        c.points = corners;
        c.why = "every photo of features " + listText(corners) + " shows this triangle from behind (mirrored)";
        c.fix = "check the clicks of " + listText(corners) + "; one is probably on the wrong spot";
        return c;
      case CellStatus::TouchesBorder:
        c.cause = CoverageCause::TouchesBorder;
        c.why = "it reaches the mesh's open border with fewer than two paths of one photo around it";
        c.fix =
            "click features along its edge in one photo (two paths close it off), or outline it with a feature "
            "polygon, or inpaint it";
        newFeature("add a feature here, clicked in the photo of the features around it");
        return c;
      case CellStatus::NotDisc:
        c.cause = CoverageCause::NotDisc;
        c.why = "it wraps around a handle (or has several borders)";
        newFeature("add features across it");
        if (!c.click.valid()) c.fix = "add features and paths across it";
        return c;
      case CellStatus::Failed:
        c.cause = CoverageCause::Failed;
        c.why = "its map could not be built" + (plan && !plan->detail.empty() ? ": " + plan->detail : std::string());
        newFeature("add a feature inside it to split it");
        if (!c.click.valid()) c.fix = "add a feature inside it to split it";
        return c;
      case CellStatus::FeatureInside: {
        // A rejected pair from the inner feature to a corner says why it has no paths.
        std::vector<int> inner;
        for (int q : near)
          if (std::find(corners.begin(), corners.end(), q) == corners.end()) inner.push_back(q);
        if (auto pair = rejectedCause(near)) return *pair;
        c.cause = CoverageCause::FeatureInside;
        c.why = "features " + listText(inner) + " lie inside it without paths to its corners " + listText(corners);
        if (!inner.empty()) {
          const int q = inner.front();
          c.click = {q, vertexOf(q), photoFor(vertexOf(q), corners, q)};
        }
        c.fix = c.click.valid() ? "click " + name(c.click.point) + " in photo " + std::to_string(c.click.photo)
                                : "click " + listText(inner) + " in a photo that shows its corners";
        return c;
      }
      default:
        break;
    }
    // Not a triangle: a pair that would cut it was rejected. When no click mends the pair, one new feature
    // amid the features around it, in the photo holding most of them, may fan it into triangles.
    if (auto pair = rejectedCause(near)) {
      if (!pair->click.valid()) fanClick(*pair, faces, near);
      return *pair;
    }
    c.cause = CoverageCause::NotTriangle;
    c.why = "the paths around it do not close a triangle (" + plural(near.size(), "feature", "features") +
            " border it: " + listText(near) + ")";
    c.fix = "add a feature inside it";
    newFeature("add a feature inside it");
    return c;
  }

  void describe(CoverageRegion& r, const std::vector<double>& area) const {
    std::set<int> vertices;
    for (int f : r.faces) {
      const auto q = mesh_.facePositions(f);
      r.centre += area[f] * (q[0] + q[1] + q[2]) / 3;
      for (int v : mesh_.faceVertices(f)) vertices.insert(v);
    }
    if (r.area > 0) r.centre /= r.area;
    for (int v : vertices) r.radius = std::max(r.radius, (mesh_.position(v) - r.centre).norm());
    r.centreVertex = innerVertex(r.faces, r.centre);
    r.points = featuresOn(r.faces);
    std::map<int, std::vector<int>> byCell;
    for (int f : r.faces) byCell[in_.partition.faceCell[f]].push_back(f);
    for (const auto& [cell, faces] : byCell) {
      r.cells.push_back(cell);
      const CellPlan* plan = cell < static_cast<int>(in_.cells.size()) ? &in_.cells[cell] : nullptr;
      RegionCause c = cellCause(plan, faces, r.centre);
      for (int f : faces) c.area += area[f];
      // Parts with the same explanation are one cause.
      auto same = std::find_if(r.causes.begin(), r.causes.end(), [&](const RegionCause& o) {
        return o.cause == c.cause && o.why == c.why && o.fix == c.fix;
      });
      if (same != r.causes.end())
        same->area += c.area;
      else
        r.causes.push_back(std::move(c));
    }
    std::stable_sort(r.causes.begin(), r.causes.end(),
                     [](const RegionCause& a, const RegionCause& b) { return a.area > b.area; });
    for (const RegionCause& c : r.causes)
      if (c.click.valid()) r.gain += c.area;
  }

  void groupRejected(CoverageReport& report) const {
    const auto& rejected = in_.partition.rejected;
    // A pair bears on an empty region when both its features lie around one listed region.
    std::vector<std::set<int>> around;
    for (const CoverageRegion& r : report.regions) around.emplace_back(r.points.begin(), r.points.end());
    report.rejectedExpected.assign(rejected.size(), 1);
    for (size_t i = 0; i < rejected.size(); ++i)
      for (const auto& s : around)
        if (s.count(rejected[i].fromPoint) && s.count(rejected[i].toPoint)) report.rejectedExpected[i] = 0;
    std::map<int, RejectedGroup> groups;
    for (int pass = 0; pass < 2; ++pass)
      for (size_t i = 0; i < rejected.size(); ++i) {
        if (report.rejectedExpected[i] != pass) continue;
        RejectedGroup& g = groups[static_cast<int>(rejected[i].reason)];
        g.reason = rejected[i].reason;
        g.pairs.push_back(static_cast<int>(i));
        g.expected += pass;
      }
    for (auto& [_, g] : groups) {
      RejectedPair sample;
      sample.reason = g.reason;
      g.words = rejectedWords(sample);
      report.rejected.push_back(std::move(g));
    }
    std::stable_sort(report.rejected.begin(), report.rejected.end(),
                     [](const RejectedGroup& a, const RejectedGroup& b) { return a.pairs.size() > b.pairs.size(); });
  }

  const CoverageInput& in_;
  const Mesh& mesh_;
  std::vector<std::vector<int>> pointsAt_;  // per vertex: the features at it
  std::vector<char> seen_;                  // per face: some fitted photo can texture it
  bool allFit_ = false;
  int clickable_ = 0;  // vertices below this id may be suggested for a click
};

}  // namespace

CoverageReport analyseCoverage(const CoverageInput& input, const CoverageOptions& options) {
  return Analysis(input).run(options);
}

std::string rejectedWords(const RejectedPair& pair) {
  const std::string in = pair.photo >= 0 ? "in photo " + std::to_string(pair.photo) + ", " : "";
  std::string words;
  switch (pair.reason) {
    case RejectReason::NoCommonPhoto:
      return "never clicked in the same photo";
    case RejectReason::CurveCrossesCurve:
      words = in + "the straight line between them crosses a line already accepted";
      break;
    case RejectReason::CurveOverBackground:
      words = in + "the straight line between them runs over the background";
      break;
    case RejectReason::CyclicOrder:
      words = in + "the lines around them come in another order than on the mesh";
      break;
    case RejectReason::NoPath:
      words = "no room on the mesh for a path between them";
      break;
    case RejectReason::Duplicate:
      words = in + "already joined";
      break;
  }
  if (!pair.detail.empty() && pair.reason != RejectReason::Duplicate) words += " (" + pair.detail + ")";
  return words;
}

std::string clickWords(const CoverageClick& click) {
  if (!click.valid()) return "";
  const std::string what = click.point >= 0 ? "feature " + std::to_string(click.id >= 0 ? click.id : click.point) +
                                                  " (vertex " + std::to_string(click.vertex) + ")"
                                            : "vertex " + std::to_string(click.vertex) + " (a new feature)";
  return "click " + what + " in photo " + std::to_string(click.photo);
}

nlohmann::json coverageJson(const CoverageReport& report) {
  // Points by the ids the user sees.
  auto id = [&](int point) {
    return point >= 0 && point < static_cast<int>(report.featureIds.size()) ? report.featureIds[point] : point;
  };
  auto ids = [&](std::vector<int> points) {
    for (int& p : points) p = id(p);
    return points;
  };
  auto clickJson = [&](const CoverageClick& c) -> nlohmann::json {
    if (!c.valid()) return nullptr;
    return {{"point", id(c.point)}, {"vertex", c.vertex}, {"photo", c.photo}};
  };
  nlohmann::json regions = nlohmann::json::array();
  for (const CoverageRegion& r : report.regions) {
    nlohmann::json causes = nlohmann::json::array();
    for (const RegionCause& c : r.causes)
      causes.push_back({{"cause", kCoverageCauseNames[static_cast<int>(c.cause)]},
                        {"area", c.area},
                        {"why", c.why},
                        {"fix", c.fix},
                        {"points", ids(c.points)},
                        {"rejected_pair", c.rejected},
                        {"click", clickJson(c.click)}});
    regions.push_back({{"faces", r.faces.size()},
                       {"area", r.area},
                       {"share", r.share},
                       {"centre", {r.centre.x(), r.centre.y(), r.centre.z()}},
                       {"radius", r.radius},
                       {"centre_vertex", r.centreVertex},
                       {"cells", r.cells},
                       {"points", ids(r.points)},
                       {"why", r.causes.empty() ? "" : r.causes.front().why},
                       {"fix", r.causes.empty() ? "" : r.causes.front().fix},
                       {"causes", causes}});
  }
  nlohmann::json next = nullptr;
  if (!report.next.empty()) {
    const CoverageRegion& r = report.regions[report.next.front()];
    const auto c = std::find_if(r.causes.begin(), r.causes.end(), [](const RegionCause& c) { return c.click.valid(); });
    next = {{"region", report.next.front()},
            {"gain_share", r.share > 0 ? r.gain / r.area * r.share : 0.0},
            {"points", ids(r.points)},
            {"click", clickJson(c->click)},
            {"words", clickWords(c->click)}};
  }
  nlohmann::json groups = nlohmann::json::array();
  for (const RejectedGroup& g : report.rejected)
    groups.push_back({{"reason", kRejectReasonNames[static_cast<int>(g.reason)]},
                      {"words", g.words},
                      {"pairs", g.pairs.size()},
                      {"expected", g.expected}});
  return {{"mapped_share", report.mappedShare},
          {"total_area", report.totalArea},
          {"regions", regions},
          {"small_regions", report.smallRegions},
          {"small_area", report.smallArea},
          {"next", next},
          {"rejected_groups", groups}};
}

}  // namespace montage
