#include "overlay_buffers.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

namespace montage {

namespace {

bool positionIn(const Project& p, int point, int photo, Vec2& out) {
  if (point < 0 || point >= static_cast<int>(p.points.size())) return false;
  for (const PhotoPoint& a : p.points[point].at)
    if (a.photo == photo) {
      out = Vec2(a.x, a.y);
      return true;
    }
  return false;
}

void push(std::vector<float>& out, const Vec2& q, const Vec4f& c, float extra) {
  out.insert(out.end(), {float(q.x()), float(q.y()), c[0], c[1], c[2], c[3], extra});
}

}  // namespace

PaneOverlay buildPaneOverlay(const Project& project, const Partition* partition, int photo,
                             const PaneOverlayOptions& o) {
  PaneOverlay out;
  if (partition && o.rejected) {
    // Every pair is tried (paper 3.1), so there can be tens of thousands: beyond a few hundred in a
    // photo, only those of the selected or hovered point are drawn.
    for (const RejectedPair& rj : partition->rejected) out.rejectedInPhoto += rj.photo == photo || rj.photo < 0;
    out.allRejectedDrawn = out.rejectedInPhoto <= o.maxRejectedDrawn;
    const Vec4f red(0.92f, 0.31f, 0.27f, 0.45f);
    for (const RejectedPair& rj : partition->rejected) {
      if (rj.photo >= 0 && rj.photo != photo) continue;
      if (!out.allRejectedDrawn && rj.fromPoint != o.selectedPoint && rj.toPoint != o.selectedPoint &&
          rj.fromPoint != o.focusPoint && rj.toPoint != o.focusPoint)
        continue;
      Vec2 a, b;
      if (!positionIn(project, rj.fromPoint, photo, a) || !positionIn(project, rj.toPoint, photo, b)) continue;
      push(out.lines, a, red, 0);
      push(out.lines, b, red, float((b - a).norm()));
    }
  }
  if (partition && o.curves) {
    const Vec4f chain(1.0f, 0.59f, 0.16f, 1), plain(1.0f, 0.9f, 0.27f, 0.9f);
    for (const MeshPath& path : partition->paths)
      for (const Curve& c : path.curves)
        if (c.photo == photo) {
          push(out.lines, c.from, path.fromChain ? chain : plain, -1);
          push(out.lines, c.to, path.fromChain ? chain : plain, -1);
        }
  }
  if (o.features) {
    const Vec4f paired(0.35f, 0.94f, 0.43f, 1), single(0.96f, 0.96f, 0.96f, 1);
    for (size_t k = 0; k < project.points.size(); ++k) {
      Vec2 q;
      if (!positionIn(project, static_cast<int>(k), photo, q)) continue;
      push(out.points, q, project.points[k].at.size() >= 2 ? paired : single, 9.0f);
    }
  }
  return out;
}

std::vector<int> placeLabels(const std::vector<LabelCandidate>& labels) {
  std::vector<int> order(labels.size());
  for (size_t i = 0; i < labels.size(); ++i) order[i] = static_cast<int>(i);
  std::stable_partition(order.begin(), order.end(), [&](int i) { return labels[i].always; });
  // Grid cells of 64 px hold the chosen rectangles that touch them.
  constexpr double kCell = 64;
  std::unordered_map<long long, std::vector<int>> grid;
  auto key = [](long long x, long long y) { return (x << 32) ^ (y & 0xffffffffll); };
  std::vector<int> chosen;
  for (int i : order) {
    const LabelCandidate& l = labels[i];
    const long long x0 = std::floor(l.lo.x() / kCell), x1 = std::floor((l.lo.x() + l.size.x()) / kCell);
    const long long y0 = std::floor(l.lo.y() / kCell), y1 = std::floor((l.lo.y() + l.size.y()) / kCell);
    bool overlaps = false;
    for (long long x = x0; x <= x1 && !overlaps && !l.always; ++x)
      for (long long y = y0; y <= y1 && !overlaps; ++y) {
        auto it = grid.find(key(x, y));
        if (it == grid.end()) continue;
        for (int j : it->second) {
          const LabelCandidate& m = labels[j];
          if (l.lo.x() < m.lo.x() + m.size.x() && m.lo.x() < l.lo.x() + l.size.x() &&
              l.lo.y() < m.lo.y() + m.size.y() && m.lo.y() < l.lo.y() + l.size.y()) {
            overlaps = true;
            break;
          }
        }
      }
    if (overlaps) continue;
    chosen.push_back(i);
    for (long long x = x0; x <= x1; ++x)
      for (long long y = y0; y <= y1; ++y) grid[key(x, y)].push_back(i);
  }
  return chosen;
}

}  // namespace montage
