#include "document.h"

#include <algorithm>
#include <cmath>
#include <unordered_set>

namespace montage {

namespace {

void checkIndex(const char* op, const char* what, int index, size_t size) {
  TM_CHECK(index >= 0 && static_cast<size_t>(index) < size, std::string(op) + ": " + what + " " +
                                                                std::to_string(index) + " does not exist (there are " +
                                                                std::to_string(size) + ")");
}

size_t minChainSize(const FeatureChain& chain) {
  return chain.closed ? 3 : 2;
}

bool hasPosition(const FeaturePoint& point, int photo) {
  return std::any_of(point.at.begin(), point.at.end(), [&](const PhotoPoint& a) { return a.photo == photo; });
}

// Removes the holeModes entries on the faces of a hole; returns the one that ruled it (the last, as in the
// pipeline), if any.
std::optional<HoleMode> takeHoleMode(std::vector<HoleMode>& modes, const std::vector<int>& holeFaces) {
  const std::unordered_set<int> inHole(holeFaces.begin(), holeFaces.end());
  std::optional<HoleMode> entry;
  for (const HoleMode& h : modes)
    if (inHole.count(h.face)) entry = h;
  modes.erase(std::remove_if(modes.begin(), modes.end(), [&](const HoleMode& h) { return inHole.count(h.face); }),
              modes.end());
  return entry;
}

}  // namespace

void detachPointFromChains(Project& project, int point, int photo, bool erase) {
  std::vector<FeatureChain> kept;
  for (FeatureChain chain : project.chains) {
    if (photo < 0 || chain.photo == photo)
      chain.points.erase(std::remove(chain.points.begin(), chain.points.end(), point), chain.points.end());
    if (erase)
      for (int& p : chain.points)
        if (p > point) --p;
    // A chain that lost a point but still has enough stays; one too short to be a line or polygon
    // goes, since the pipeline would reject it.
    if (chain.points.size() >= minChainSize(chain)) kept.push_back(std::move(chain));
  }
  project.chains = std::move(kept);
}

Document::Document(Project project) : current_(std::make_shared<const Project>(std::move(project))) {
  file_ = current_->file;
  saved_ = current_->file.empty() ? nullptr : current_;
}

std::shared_ptr<const Project> Document::withFile(std::shared_ptr<const Project> state) const {
  if (state->file == file_) return state;
  auto copy = std::make_shared<Project>(*state);
  copy->file = file_;
  return copy;
}

bool Document::modified() const {
  if (!saved_) return !current_->file.empty() || revision_ > 0;
  return current_ != saved_ && !current_->sameDocument(*saved_);
}

void Document::markSaved(const std::string& file) {
  // The file name is not part of the document's history: undoing past a "save as" keeps the new
  // file, so states taken from the history get the current name (withFile).
  file_ = file;
  current_ = withFile(current_);
  saved_ = current_;
}

void Document::reset(Project project, bool modified) {
  current_ = std::make_shared<const Project>(std::move(project));
  file_ = current_->file;
  saved_ = modified ? nullptr : current_;
  history_.clear();
  position_ = 0;
  groupOpen_ = false;
  groupBefore_.reset();
  ++revision_;
}

void Document::beginGroup(const std::string& label) {
  if (groupOpen_) return;
  groupOpen_ = true;
  groupLabel_ = label;
  groupBefore_ = current_;
}

void Document::endGroup() {
  if (!groupOpen_) return;
  groupOpen_ = false;
  auto before = std::move(groupBefore_);
  groupBefore_.reset();
  if (current_ == before || current_->sameDocument(*before)) {
    current_ = before;  // nothing changed in the end (a drag that came back): no step
    return;
  }
  history_.resize(position_);
  history_.push_back({groupLabel_, before, current_});
  if (static_cast<int>(history_.size()) > kMaxUndoSteps) history_.erase(history_.begin());
  position_ = static_cast<int>(history_.size());
}

void Document::commit(const std::string& label, std::shared_ptr<const Project> next) {
  if (next->sameDocument(*current_)) return;  // a no-op edit leaves no step and no new revision
  ++revision_;
  if (groupOpen_) {
    current_ = std::move(next);
    return;
  }
  history_.resize(position_);
  history_.push_back({label, current_, next});
  if (static_cast<int>(history_.size()) > kMaxUndoSteps) history_.erase(history_.begin());
  position_ = static_cast<int>(history_.size());
  current_ = std::move(next);
}

template <class Change>
void Document::apply(const std::string& label, Change&& change) {
  auto next = std::make_shared<Project>(*current_);
  change(*next);  // throws before anything is committed
  commit(label, std::move(next));
}

void Document::undo() {
  if (!canUndo()) return;
  --position_;
  current_ = withFile(history_[position_].before);
  ++revision_;
}

void Document::redo() {
  if (!canRedo()) return;
  current_ = withFile(history_[position_].after);
  ++position_;
  ++revision_;
}

void Document::jumpTo(int position) {
  position = std::clamp(position, 0, static_cast<int>(history_.size()));
  while (position_ > position && canUndo()) undo();
  while (position_ < position && canRedo()) redo();
}

int Document::pointAt(int vertex, int photo) const {
  const auto& points = current_->points;
  for (size_t i = 0; i < points.size(); ++i)
    if (points[i].vertex == vertex && hasPosition(points[i], photo)) return static_cast<int>(i);
  return -1;
}

int Document::pointOfVertex(int vertex) const {
  const auto& points = current_->points;
  for (size_t i = 0; i < points.size(); ++i)
    if (points[i].vertex == vertex) return static_cast<int>(i);
  return -1;
}

int Document::setPosition(int vertex, int photo, double x, double y) {
  TM_CHECK(vertex >= 0, "set position: vertex " + std::to_string(vertex) + " is not a vertex id");
  checkIndex("set position", "photo", photo, current_->photos.size());
  TM_CHECK(std::isfinite(x) && std::isfinite(y), "set position: the coordinates must be finite");
  int index = pointAt(vertex, photo);
  if (index >= 0) {
    movePosition(index, photo, x, y);
    return index;
  }
  // A vertex has at most one feature point per photo; reuse the vertex's point when it has none here.
  index = pointOfVertex(vertex);
  const bool added = index < 0;
  apply((added ? "Add point (vertex " : "Add position (vertex ") + std::to_string(vertex) + ", photo " +
            std::to_string(photo) + ")",
        [&](Project& p) {
          if (added) {
            FeaturePoint point{vertex, {}};
            // A new id, never one another point has (ids survive deletions); canonical when it is the index.
            const int id = nextPointId(p);
            point.id = id == static_cast<int>(p.points.size()) ? -1 : id;
            p.points.push_back(point);
            index = static_cast<int>(p.points.size()) - 1;
          }
          p.points[index].at.push_back(PhotoPoint{photo, x, y});
        });
  return index;
}

void Document::movePosition(int point, int photo, double x, double y) {
  checkIndex("move point", "point", point, current_->points.size());
  TM_CHECK(std::isfinite(x) && std::isfinite(y), "move point: the coordinates must be finite");
  apply("Move point " + std::to_string(pointId(*current_, point)), [&](Project& p) {
    for (PhotoPoint& a : p.points[point].at)
      if (a.photo == photo) {
        a.x = x;
        a.y = y;
        return;
      }
    throw Error("move point: point " + std::to_string(point) + " has no position in photo " + std::to_string(photo));
  });
}

void Document::removePosition(int point, int photo) {
  checkIndex("remove position", "point", point, current_->points.size());
  apply("Remove point " + std::to_string(pointId(*current_, point)) + " from photo " + std::to_string(photo),
        [&](Project& p) {
          auto& at = p.points[point].at;
          const auto it = std::find_if(at.begin(), at.end(), [&](const PhotoPoint& a) { return a.photo == photo; });
          TM_CHECK(it != at.end(), "remove position: point " + std::to_string(point) + " has no position in photo " +
                                       std::to_string(photo));
          at.erase(it);
          detachPointFromChains(p, point, photo, false);
          if (at.empty()) {
            // A feature point with no position says nothing: it goes, and chain indices shift down (the other
            // points keep their ids).
            erasePoint(p, point);
            detachPointFromChains(p, point, -1, true);
          }
        });
}

void Document::removePoint(int point) {
  checkIndex("remove point", "point", point, current_->points.size());
  apply("Remove point " + std::to_string(pointId(*current_, point)), [&](Project& p) {
    erasePoint(p, point);
    detachPointFromChains(p, point, -1, true);
  });
}

int Document::addChain(const FeatureChain& chain) {
  checkIndex("add chain", "photo", chain.photo, current_->photos.size());
  TM_CHECK(chain.points.size() >= minChainSize(chain),
           std::string("add chain: a feature ") +
               (chain.closed ? "polygon needs at least 3" : "line needs at least 2") + " points, got " +
               std::to_string(chain.points.size()));
  for (size_t k = 0; k < chain.points.size(); ++k) {
    const int pt = chain.points[k];
    checkIndex("add chain", "point", pt, current_->points.size());
    TM_CHECK(std::find(chain.points.begin(), chain.points.begin() + k, pt) == chain.points.begin() + k,
             "add chain: point " + std::to_string(pt) + " appears twice in the chain");
    TM_CHECK(hasPosition(current_->points[pt], chain.photo),
             "add chain: point " + std::to_string(pt) + " has no position in photo " + std::to_string(chain.photo));
  }
  int index = -1;
  apply(std::string(chain.closed ? "Add polygon (" : "Add line (") + std::to_string(chain.points.size()) + " points)",
        [&](Project& p) {
          p.chains.push_back(chain);
          index = static_cast<int>(p.chains.size()) - 1;
        });
  return index;
}

void Document::declineProposal(int vertex, int photo) {
  TM_CHECK(vertex >= 0, "decline proposal: vertex " + std::to_string(vertex) + " is not a vertex id");
  checkIndex("decline proposal", "photo", photo, current_->photos.size());
  const DeclinedProposal d{vertex, photo};
  const auto& list = current_->declinedProposals;
  if (std::find(list.begin(), list.end(), d) != list.end()) return;
  apply("Decline proposal (vertex " + std::to_string(vertex) + ", photo " + std::to_string(photo) + ")",
        [&](Project& p) { p.declinedProposals.push_back(d); });
}

void Document::removeChain(int chain) {
  checkIndex("remove chain", "chain", chain, current_->chains.size());
  apply("Remove chain " + std::to_string(chain), [&](Project& p) { p.chains.erase(p.chains.begin() + chain); });
}

int Document::addStroke(const Stroke& stroke) {
  TM_CHECK(stroke.vertices.size() >= 2,
           "add stroke: a stroke needs at least 2 vertices, got " + std::to_string(stroke.vertices.size()));
  int index = -1;
  apply("Add stroke (" + std::to_string(stroke.vertices.size()) + " vertices)", [&](Project& p) {
    p.strokes.push_back(stroke);
    index = static_cast<int>(p.strokes.size()) - 1;
  });
  return index;
}

void Document::removeStroke(int stroke) {
  checkIndex("remove stroke", "stroke", stroke, current_->strokes.size());
  apply("Remove stroke " + std::to_string(stroke), [&](Project& p) { p.strokes.erase(p.strokes.begin() + stroke); });
}

int Document::addClone(const CloneOp& clone) {
  checkIndex("add clone", "photo", clone.photo, current_->photos.size());
  TM_CHECK(clone.polygon.size() >= 3, "add clone: the source polygon needs at least 3 points");
  TM_CHECK(!clone.targetFaces.empty(), "add clone: the target region on the mesh is empty");
  int index = -1;
  apply("Add clone (" + std::to_string(clone.targetFaces.size()) + " faces)", [&](Project& p) {
    p.clones.push_back(clone);
    index = static_cast<int>(p.clones.size()) - 1;
  });
  return index;
}

void Document::removeClone(int clone) {
  checkIndex("remove clone", "clone", clone, current_->clones.size());
  apply("Remove clone " + std::to_string(clone), [&](Project& p) { p.clones.erase(p.clones.begin() + clone); });
}

void Document::setOptions(const PipelineOptions& options, const std::string& label) {
  apply(label, [&](Project& p) { p.options = options; });
}

void Document::setHoleFill(const std::vector<int>& holeFaces, int face, std::optional<InpaintMode> mode) {
  apply(mode ? std::string("Fill a hole with ") + kInpaintModeNames[size_t(*mode)] : "Fill a hole by default",
        [&](Project& p) {
          const std::optional<HoleMode> entry = takeHoleMode(p.holeModes, holeFaces);
          // A photo region the hole's texture came from stays with texture.
          if (mode)
            p.holeModes.push_back(
                {face, *mode, *mode == InpaintMode::Texture && entry ? entry->exemplar : std::nullopt});
        });
}

void Document::setHoleExemplar(const std::vector<int>& holeFaces, int face, std::optional<HoleExemplar> exemplar) {
  if (exemplar) checkIndex("texture a hole from a photo", "photo", exemplar->photo, current_->photos.size());
  apply(exemplar ? "Texture a hole from photo " + std::to_string(exemplar->photo) : "Texture a hole from around it",
        [&](Project& p) {
          // The hole's entry keeps its face; its mode becomes texture, the only one that reads an exemplar.
          std::optional<HoleMode> entry = takeHoleMode(p.holeModes, holeFaces);
          if (!entry && !exemplar) return;
          if (!entry) entry = HoleMode{face, InpaintMode::Texture, std::nullopt};
          entry->exemplar = exemplar;
          if (exemplar) entry->mode = InpaintMode::Texture;
          p.holeModes.push_back(*entry);
        });
}

int Document::addPhotos(const std::vector<PhotoRef>& photos) {
  const int first = static_cast<int>(current_->photos.size());
  apply(photos.size() == 1 ? "Add photo" : "Add " + std::to_string(photos.size()) + " photos",
        [&](Project& p) { p.photos.insert(p.photos.end(), photos.begin(), photos.end()); });
  return first;
}

void Document::removePhoto(int photo) {
  checkIndex("remove photo", "photo", photo, current_->photos.size());
  apply("Remove photo " + std::to_string(photo), [&](Project& p) {
    p.photos.erase(p.photos.begin() + photo);
    // Chains and clones in the photo go; positions in it go (and points left with none).
    std::vector<FeatureChain> chains;
    for (FeatureChain& c : p.chains)
      if (c.photo != photo) {
        if (c.photo > photo) --c.photo;
        chains.push_back(std::move(c));
      }
    p.chains = std::move(chains);
    std::vector<CloneOp> clones;
    for (CloneOp& c : p.clones)
      if (c.photo != photo) {
        if (c.photo > photo) --c.photo;
        clones.push_back(std::move(c));
      }
    p.clones = std::move(clones);
    for (HoleMode& h : p.holeModes)  // a hole whose texture came from the photo takes it from around it again
      if (h.exemplar && h.exemplar->photo == photo)
        h.exemplar.reset();
      else if (h.exemplar && h.exemplar->photo > photo)
        --h.exemplar->photo;
    std::vector<DeclinedProposal> declined;
    for (DeclinedProposal d : p.declinedProposals)
      if (d.photo != photo) {
        if (d.photo > photo) --d.photo;
        declined.push_back(d);
      }
    p.declinedProposals = std::move(declined);
    for (int i = static_cast<int>(p.points.size()) - 1; i >= 0; --i) {
      auto& at = p.points[i].at;
      at.erase(std::remove_if(at.begin(), at.end(), [&](const PhotoPoint& a) { return a.photo == photo; }), at.end());
      for (PhotoPoint& a : at)
        if (a.photo > photo) --a.photo;
      if (at.empty()) {
        erasePoint(p, i);
        detachPointFromChains(p, i, -1, true);
      }
    }
  });
}

void Document::movePhoto(int from, int to) {
  checkIndex("move photo", "photo", from, current_->photos.size());
  checkIndex("move photo", "position", to, current_->photos.size());
  if (from == to) return;
  // New index of every old photo index.
  const int n = static_cast<int>(current_->photos.size());
  std::vector<int> order(n);
  for (int i = 0; i < n; ++i) order[i] = i;
  order.erase(order.begin() + from);
  order.insert(order.begin() + to, from);
  std::vector<int> newIndex(n);
  for (int i = 0; i < n; ++i) newIndex[order[i]] = i;
  apply("Move photo " + std::to_string(from) + " to " + std::to_string(to), [&](Project& p) {
    std::vector<PhotoRef> photos(n);
    for (int i = 0; i < n; ++i) photos[newIndex[i]] = p.photos[i];
    p.photos = std::move(photos);
    for (FeaturePoint& pt : p.points)
      for (PhotoPoint& a : pt.at) a.photo = newIndex[a.photo];
    for (FeatureChain& c : p.chains) c.photo = newIndex[c.photo];
    for (CloneOp& c : p.clones) c.photo = newIndex[c.photo];
    for (HoleMode& h : p.holeModes)
      if (h.exemplar) h.exemplar->photo = newIndex[h.exemplar->photo];
  });
}

void Document::setPhotoMirror(int photo, bool mirror, int width) {
  checkIndex("mirror photo", "photo", photo, current_->photos.size());
  if (current_->photos[photo].mirror == mirror) return;
  bool used = false;
  for (const FeaturePoint& pt : current_->points) used = used || hasPosition(pt, photo);
  for (const CloneOp& c : current_->clones) used = used || c.photo == photo;
  for (const HoleMode& h : current_->holeModes) used = used || (h.exemplar && h.exemplar->photo == photo);
  TM_CHECK(!used || width > 0, "mirror photo: photo " + std::to_string(photo) +
                                   " has points, clones or hole textures and its width is unknown (it did not load)");
  apply(std::string(mirror ? "Mirror photo " : "Unmirror photo ") + std::to_string(photo), [&](Project& p) {
    p.photos[photo].mirror = mirror;
    for (FeaturePoint& pt : p.points)
      for (PhotoPoint& a : pt.at)
        if (a.photo == photo) a.x = width - a.x;
    for (CloneOp& c : p.clones)
      if (c.photo == photo) {
        for (Vec2& q : c.polygon) q.x() = width - q.x();
        c.anchor.x() = width - c.anchor.x();  // the same region (its clone is mirrored, as the photo is)
      }
    for (HoleMode& h : p.holeModes)
      if (h.exemplar && h.exemplar->photo == photo)
        for (Vec2& q : h.exemplar->polygon) q.x() = width - q.x();
  });
}

void Document::renameMasks(const std::map<std::string, std::string>& moved) {
  std::map<const Project*, std::shared_ptr<const Project>> renamed;  // each state once (steps share them)
  std::vector<std::shared_ptr<const Project>> old;  // alive until the end: no address is reused meanwhile
  auto rename = [&](std::shared_ptr<const Project>& state) {
    if (!state) return;
    old.push_back(state);
    if (auto it = renamed.find(state.get()); it != renamed.end()) {
      state = it->second;
      return;
    }
    auto next = std::make_shared<Project>(*state);
    for (PhotoRef& ref : next->photos)
      if (auto m = moved.find(ref.mask); m != moved.end()) ref.mask = m->second;
    renamed[state.get()] = next;
    state = std::move(next);
  };
  const bool wasSaved = saved_ && saved_ == current_;
  rename(current_);
  for (UndoStep& step : history_) rename(step.before), rename(step.after);
  if (groupBefore_) rename(groupBefore_);
  if (saved_) rename(saved_);
  if (wasSaved) saved_ = current_;
  ++revision_;
}

std::set<std::string> Document::masksNamed() const {
  std::set<std::string> masks;
  auto add = [&](const std::shared_ptr<const Project>& state) {
    if (state)
      for (const PhotoRef& ref : state->photos)
        if (!ref.mask.empty()) masks.insert(ref.mask);
  };
  add(current_);
  for (const UndoStep& step : history_) add(step.before), add(step.after);
  return masks;
}

void Document::setPhotoMask(int photo, const std::string& mask) {
  checkIndex("set mask", "photo", photo, current_->photos.size());
  apply((mask.empty() ? "Remove mask of photo " : "Set mask of photo ") + std::to_string(photo),
        [&](Project& p) { p.photos[photo].mask = mask; });
}

void Document::setColorLocked(int photo, bool locked) {
  checkIndex("lock colours", "photo", photo, current_->photos.size());
  apply((locked ? "Lock colours of photo " : "Unlock colours of photo ") + std::to_string(photo),
        [&](Project& p) { p.photos[photo].colorLocked = locked; });
}

void Document::setPhotoMode(int photo, PhotoMode mode) {
  checkIndex("photo mode", "photo", photo, current_->photos.size());
  apply("Photo " + std::to_string(photo) + " shows: " + kPhotoModeNames[size_t(mode)],
        [&](Project& p) { p.photos[photo].mode = mode; });
}

void Document::relinkPhoto(int photo, const std::string& path) {
  checkIndex("relink photo", "photo", photo, current_->photos.size());
  TM_CHECK(!path.empty(), "relink photo: the new path is empty");
  apply("Relink photo " + std::to_string(photo), [&](Project& p) { p.photos[photo].path = path; });
}

MeshCarry Document::carryToMesh(const Mesh& mesh, const std::string& fingerprint) {
  if (!meshChanged(*current_, fingerprint)) return {};
  MeshCarry report;
  apply("Carry the clicks to the changed mesh",
        [&](Project& p) { report = montage::carryToMesh(p, mesh, fingerprint); });
  return report;
}

void Document::relinkMesh(const std::string& path) {
  TM_CHECK(!path.empty(), "relink mesh: the new path is empty");
  apply("Relink mesh", [&](Project& p) { p.mesh = path; });
}

}  // namespace montage
