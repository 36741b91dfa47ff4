#include "io/project_warnings.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <tuple>

#include "geometry/predicates.h"

namespace montage {

namespace {

std::string number(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.4g", v);
  return text;
}

std::string at(const Vec2& p) {
  return "(" + number(p.x()) + ", " + number(p.y()) + ")";
}

std::string photoName(const Project& project, int i) {
  return "photo " + std::to_string(i) + " '" + std::filesystem::path(project.photos[i].path).filename().string() + "'";
}

// Collects warnings of one kind, keeping the first `limit` and counting the rest.
class Kind {
 public:
  Kind(std::vector<std::string>& out, int limit, std::string more) : out_(out), limit_(limit), more_(std::move(more)) {}
  ~Kind() {
    if (count_ > limit_) out_.push_back(std::to_string(count_ - limit_) + " more " + more_);
  }
  void add(const std::string& text) {
    if (count_++ < limit_) out_.push_back(text);
  }

 private:
  std::vector<std::string>& out_;
  int limit_, count_ = 0;
  std::string more_;
};

// The position of point `index` in `photo`, or null.
const PhotoPoint* positionIn(const Project& project, int index, int photo) {
  if (index < 0 || index >= static_cast<int>(project.points.size())) return nullptr;
  for (const PhotoPoint& p : project.points[index].at)
    if (p.photo == photo) return &p;
  return nullptr;
}

struct Segment {
  int chain, k;  // chains[chain], segment k (from its point k to point k+1, or the closing one)
  int from, to;  // feature point indices
  Vec2 a, b;
  double lo, hi;  // x range
};

// The crossing point of segments s and t, when they cross (touching at an end or overlapping counts;
// sharing a feature point does not).
bool crossing(const Segment& s, const Segment& t, Vec2& where) {
  if (s.from == t.from || s.from == t.to || s.to == t.from || s.to == t.to) return false;
  const double d1 = orient2(s.a, s.b, t.a), d2 = orient2(s.a, s.b, t.b);
  const double d3 = orient2(t.a, t.b, s.a), d4 = orient2(t.a, t.b, s.b);
  if (((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0))) {
    where = t.a + (t.b - t.a) * (d1 / (d1 - d2));
    return true;
  }
  // Touching or collinear overlaps: an end of one segment on the other.
  const auto onSegment = [](const Vec2& p, const Vec2& a, const Vec2& b) {
    return orient2(a, b, p) == 0 && p.x() >= std::min(a.x(), b.x()) && p.x() <= std::max(a.x(), b.x()) &&
           p.y() >= std::min(a.y(), b.y()) && p.y() <= std::max(a.y(), b.y());
  };
  for (const auto& [p, a, b] :
       {std::tuple{t.a, s.a, s.b}, std::tuple{t.b, s.a, s.b}, std::tuple{s.a, t.a, t.b}, std::tuple{s.b, t.a, t.b}})
    if (onSegment(p, a, b)) {
      where = p;
      return true;
    }
  return false;
}

}  // namespace

std::vector<std::string> projectWarnings(const Project& project, const std::vector<const Photo*>& photos,
                                         const ProjectWarningOptions& options) {
  std::vector<std::string> out;
  const int numPhotos = static_cast<int>(std::min(photos.size(), project.photos.size()));
  {
    Kind unknown(out, options.maxPerKind, "fields this build does not know");
    for (const std::string& field : project.unknownFields)
      unknown.add(field + ": not a field this build knows: ignored (a newer TextureMontage's, or misspelt)");
  }
  {
    Kind background(out, options.maxPerKind, "points lie on a photo's background");
    for (size_t i = 0; i < project.points.size(); ++i)
      for (size_t j = 0; j < project.points[i].at.size(); ++j) {
        const PhotoPoint& p = project.points[i].at[j];
        if (p.photo < 0 || p.photo >= numPhotos || !photos[p.photo] || !photos[p.photo]->hasBackground) continue;
        const double d = photos[p.photo]->distanceAt(p.x, p.y);
        if (d > options.backgroundTolerancePx)
          background.add("points[" + std::to_string(i) + "].at[" + std::to_string(j) + "]: " + at(Vec2(p.x, p.y)) +
                         " lies on the background of " + photoName(project, p.photo) + " (" + number(d) +
                         " px from the foreground)");
      }
  }

  {
    Kind crosses(out, options.maxPerKind, "crossings of feature lines");
    Kind selfCrosses(out, options.maxPerKind, "self-intersections of feature lines or polygons");
    for (int photo = 0; photo < static_cast<int>(project.photos.size()); ++photo) {
      std::vector<Segment> segments;
      for (size_t c = 0; c < project.chains.size(); ++c) {
        const FeatureChain& chain = project.chains[c];
        if (chain.photo != photo) continue;
        const int n = static_cast<int>(chain.points.size());
        const int count = chain.closed && n >= 3 ? n : n - 1;
        for (int k = 0; k < count; ++k) {
          const int from = chain.points[k], to = chain.points[(k + 1) % n];
          const PhotoPoint* a = positionIn(project, from, photo);
          const PhotoPoint* b = positionIn(project, to, photo);
          if (!a || !b || from == to) continue;
          Segment s{static_cast<int>(c), k, from, to, Vec2(a->x, a->y), Vec2(b->x, b->y), 0, 0};
          s.lo = std::min(s.a.x(), s.b.x());
          s.hi = std::max(s.a.x(), s.b.x());
          segments.push_back(s);
        }
      }
      // Sweep over x: only segments whose x ranges overlap are compared.
      std::sort(segments.begin(), segments.end(), [](const Segment& a, const Segment& b) { return a.lo < b.lo; });
      for (size_t i = 0; i < segments.size(); ++i)
        for (size_t j = i + 1; j < segments.size() && segments[j].lo <= segments[i].hi; ++j) {
          const Segment *s = &segments[i], *t = &segments[j];
          Vec2 where;
          if (!crossing(*s, *t, where)) continue;
          if (s->chain > t->chain || (s->chain == t->chain && s->k > t->k)) std::swap(s, t);
          if (s->chain == t->chain)
            selfCrosses.add("chains[" + std::to_string(s->chain) + "] crosses itself in " + photoName(project, photo) +
                            " at " + at(where) + " (segments " + std::to_string(s->k) + " and " + std::to_string(t->k) +
                            ")");
          else
            crosses.add("chains[" + std::to_string(s->chain) + "] and chains[" + std::to_string(t->chain) +
                        "] cross in " + photoName(project, photo) + " at " + at(where) + " (segments " +
                        std::to_string(s->k) + " and " + std::to_string(t->k) + ")");
        }
    }
  }  // the counts of what was left out are added here
  return out;
}

}  // namespace montage
