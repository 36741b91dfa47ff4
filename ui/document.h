// The editor's document: the live Project, the edit operations the tools call, and the undo history.
// No GL, GLFW or ImGui: the document logic is unit-tested without a display.
//
// Every state of the document is an immutable shared Project. An edit copies the current state,
// changes the copy and makes it current; an undo step keeps the states before and after. Why
// snapshots and not inverse commands: the document (features, chains, strokes, clones, options) is
// small next to the mesh and photos, the worker needs an immutable copy after every edit anyway, and
// a snapshot cannot get an inverse wrong. Undo never stores pipeline outputs.
#pragma once

#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "io/mesh_anchors.h"
#include "io/project.h"

namespace montage {

struct UndoStep {
  std::string label;                      // what the history panel shows, e.g. "Add point (vertex 12)"
  std::shared_ptr<const Project> before;  // state before the step
  std::shared_ptr<const Project> after;   // state after it
};

class Document {
 public:
  static constexpr int kMaxUndoSteps = 1000;  // the oldest steps are dropped beyond this

  explicit Document(Project project = {});

  const Project& project() const { return *current_; }
  // The current state, immutable: what the worker and the autosave receive.
  std::shared_ptr<const Project> snapshot() const { return current_; }
  // Increments with every change of the document (edit, undo, redo, open); the worker and the
  // autosave compare it with what they last saw.
  long revision() const { return revision_; }
  // The document differs from what was last opened or saved.
  bool modified() const;
  // Records that the current state was saved to `file` (absolute). Not an edit: no undo step.
  void markSaved(const std::string& file);
  // Marks the current state as unsaved (a recovered autosave, a new project from a mesh).
  void markUnsaved() { saved_.reset(); }
  // Replaces the whole document (open, recover): clears the history.
  void reset(Project project, bool modified = false);

  // Grouping: between beginGroup and endGroup every edit goes into one undo step labelled
  // `label` (a drag of a point, a stroke being drawn). Groups do not nest: an inner begin is ignored.
  // A group that changed nothing leaves no step.
  void beginGroup(const std::string& label);
  void endGroup();
  bool inGroup() const { return groupOpen_; }

  bool canUndo() const { return position_ > 0 && !groupOpen_; }
  bool canRedo() const { return position_ < static_cast<int>(history_.size()) && !groupOpen_; }
  void undo();
  void redo();
  // The history: steps [0, position()) are applied, the rest can be redone.
  const std::vector<UndoStep>& history() const { return history_; }
  int position() const { return position_; }
  // Undoes or redoes steps until `position` steps are applied.
  void jumpTo(int position);

  // --- Edit operations. Each is one undo step (or part of the open group). Bad indices throw
  // montage::Error naming the operation and the index; the document is then unchanged.

  // Attaches mesh vertex `vertex` to the photo point (x, y): moves the vertex's position in `photo`
  // if it has one, else adds the position to the vertex's feature point, else adds a new feature
  // point. Returns the index of the feature point.
  int setPosition(int vertex, int photo, double x, double y);
  // Moves the position of feature point `point` in `photo` to (x, y).
  void movePosition(int point, int photo, double x, double y);
  // Removes the position of `point` in `photo`, and the point from the chains drawn in that photo.
  // A point left with no position is removed; a chain left too short (< 2 points, < 3 closed) too.
  void removePosition(int point, int photo);
  // Records that the correspondence the cameras proposed for `vertex` in `photo` is declined
  // (Project::declinedProposals); a proposal is accepted with setPosition.
  void declineProposal(int vertex, int photo);
  // Removes a feature point with all its positions, and from every chain.
  void removePoint(int point);
  // Adds a feature line (closed = false, >= 2 points) or polygon (closed = true, >= 3 points);
  // every point must have a position in the chain's photo. Returns the chain index.
  int addChain(const FeatureChain& chain);
  void removeChain(int chain);
  int addStroke(const Stroke& stroke);  // >= 2 vertices
  void removeStroke(int stroke);
  int addClone(const CloneOp& clone);
  void removeClone(int clone);
  void setOptions(const PipelineOptions& options, const std::string& label = "Change options");
  // How one hole is filled: `mode` for the hole made of `holeFaces` (mesh face ids), recorded on `face` (one
  // of them), replacing the entries on its faces; no mode: the project's inpainting option again.
  void setHoleFill(const std::vector<int>& holeFaces, int face, std::optional<InpaintMode> mode);
  // The photo region the hole's texture is synthesised from (its mode becomes "texture"); none: the photos
  // around it again (the mode stays).
  void setHoleExemplar(const std::vector<int>& holeFaces, int face, std::optional<HoleExemplar> exemplar);
  // Appends photos (absolute paths). Returns the index of the first one added.
  int addPhotos(const std::vector<PhotoRef>& photos);
  // Removes a photo with every position, chain and clone in it; later photo indices shift down.
  void removePhoto(int photo);
  // Moves photo `from` to position `to` (the photos in between shift by one); every position, chain and
  // clone follows its photo.
  void movePhoto(int from, int to);
  // Mirrors a photo left to right on load (PhotoRef::mirror) or not. Its positions and clone polygons
  // keep pointing at the same content: x becomes `width` - x, `width` being the photo's width in pixels
  // (needed only when the photo has positions or clones).
  void setPhotoMirror(int photo, bool mirror, int width);
  // Sets (or, with "", removes) the foreground mask image of a photo (absolute path).
  void setPhotoMask(int photo, const std::string& mask);
  // Locks a photo's colours for the colour balance (the others are matched to it) or unlocks them.
  void setColorLocked(int photo, bool locked);
  // What a photo shows (PhotoMode): auto, the object itself, another subject.
  void setPhotoMode(int photo, PhotoMode mode);
  // Points a photo, or the mesh, at another file (a moved or renamed one); everything else stays.
  void relinkPhoto(int photo, const std::string& path);
  void relinkMesh(const std::string& path);
  // The mesh file changed since the project was saved (its anchors name another mesh): every vertex and face id
  // moves to `mesh`'s (of `fingerprint`) nearest (io/mesh_anchors.h), as one undo step. Returns what moved (`changed`
  // false when `mesh` is the one the project was saved with, or it has no anchors); throws when an id has no anchor.
  MeshCarry carryToMesh(const Mesh& mesh, const std::string& fingerprint);

  // Files the document names that moved (a mask written beside an unsaved project, moved beside it when it
  // is first saved): every photo mask named as a key of `moved` is renamed to its value, in the current
  // state, in every undo step and in the saved state. Not an edit: no undo step; the revision changes.
  void renameMasks(const std::map<std::string, std::string>& moved);
  // Every photo mask the current state or an undo step names (absolute paths).
  std::set<std::string> masksNamed() const;

  // Index of the feature point of `vertex` that has a position in `photo`, or -1.
  int pointAt(int vertex, int photo) const;
  // Index of the first feature point of `vertex`, or -1.
  int pointOfVertex(int vertex) const;

 private:
  // Applies `change` to a copy of the current state and records the step.
  template <class Change>
  void apply(const std::string& label, Change&& change);
  void commit(const std::string& label, std::shared_ptr<const Project> next);
  std::shared_ptr<const Project> withFile(std::shared_ptr<const Project> state) const;

  std::shared_ptr<const Project> current_;
  std::string file_;                      // where the document is saved; kept out of the history (see markSaved)
  std::shared_ptr<const Project> saved_;  // state last opened/saved; null when never saved
  std::vector<UndoStep> history_;
  int position_ = 0;
  long revision_ = 0;
  bool groupOpen_ = false;
  std::string groupLabel_;
  std::shared_ptr<const Project> groupBefore_;
};

// Removes feature point `point` from the project's chains in `photo` (all photos when photo < 0),
// drops chains left too short, and renumbers chain indices when `erase` removes the point itself.
// Exposed for tests; Document's operations use it.
void detachPointFromChains(Project& project, int point, int photo, bool erase);

}  // namespace montage
