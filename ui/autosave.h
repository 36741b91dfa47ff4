// Never losing work: the autosave side files, crash recovery and the recent-files list. No GL, GLFW
// or ImGui, so the file handling is unit-tested without a display.
//
// Where: side files live under $XDG_STATE_HOME/texturemontage/autosave/ (default
// ~/.local/state/...), not next to the project, so that a project folder that is read-only or under
// version control is never written to behind the user's back, and so that an unsaved project (opened
// from a mesh) has a place too. A side file is a normal project file (absolute paths) with an extra
// "autosave" object naming the project it belongs to; loadProject ignores it.
//
// Lifecycle: written every interval while the document has unsaved changes; removed after a
// successful save and on a clean exit. One left behind at start-up therefore means a crash (or a
// kill), and it is offered for recovery when it is newer than its project file.
#pragma once

#include <ctime>
#include <optional>
#include <string>
#include <vector>

#include "io/project.h"

namespace montage {

// $XDG_STATE_HOME/texturemontage (or ~/.local/state/texturemontage, or /tmp/texturemontage-<uid>).
std::string editorStateDir();

// The side file of a document: keyed by its project file, or by its mesh when it was never saved.
std::string autosavePathFor(const std::string& projectFile, const std::string& meshFile);

// Writes the side file atomically (core's writeFileAtomic). Throws montage::Error on failure.
void writeAutosave(const Project& project, const std::string& autosavePath);

struct RecoveryCandidate {
  std::string autosavePath;
  std::string projectFile;  // the project it belongs to; empty for an unsaved project
  std::string meshFile;
  std::time_t time = 0;  // when it was written
  int points = 0;        // feature points in it, for the prompt
};

// Reads the "autosave" header of a side file; nullopt when it is not one (or unreadable).
std::optional<RecoveryCandidate> readAutosaveHeader(const std::string& autosavePath);

// The side file to offer when opening `projectFile` (or a new document on `meshFile`): it exists and
// is newer than the project file (or the project file is gone). nullopt otherwise.
std::optional<RecoveryCandidate> findRecovery(const std::string& projectFile, const std::string& meshFile);

// Every side file in the autosave folder, newest first (the start-up prompt without a file).
std::vector<RecoveryCandidate> listRecoveries();

// Loads a side file as the document it saves: file set to its project (empty when unsaved).
// Throws montage::Error naming the side file when it cannot be read.
Project loadRecovery(const RecoveryCandidate& candidate);

// Removes a side file; a missing file is not an error.
void removeAutosave(const std::string& autosavePath);

// When an autosave is due: every `intervalSeconds` while the document has changes that are neither
// saved nor autosaved. Time is passed in, so tests need no clock.
class AutosaveClock {
 public:
  explicit AutosaveClock(double intervalSeconds = 120) : interval_(intervalSeconds) {}
  void setInterval(double seconds) { interval_ = seconds; }
  double interval() const { return interval_; }
  // `revision` is the document's revision; `modified` whether it has unsaved changes.
  bool due(double now, long revision, bool modified) const {
    return modified && revision != writtenRevision_ && now - lastWrite_ >= interval_;
  }
  void written(double now, long revision) {
    lastWrite_ = now;
    writtenRevision_ = revision;
  }
  // After a save or an open: nothing to autosave until the next edit, and a full interval after it.
  void reset(double now, long revision) { written(now, revision); }

 private:
  double interval_;
  double lastWrite_ = 0;
  long writtenRevision_ = -1;
};

// Most-recently-used files (projects and meshes), kept in editorStateDir()/recent.json.
class RecentFiles {
 public:
  static constexpr size_t kMax = 10;
  explicit RecentFiles(std::string storePath = "");  // "" = editorStateDir()/recent.json
  const std::vector<std::string>& files() const { return files_; }
  void add(const std::string& file);     // moves it to the front and saves
  void remove(const std::string& file);  // e.g. when it no longer opens
  void clear();

 private:
  void load();
  void save() const;  // best effort: a read-only state folder only loses the list
  std::string store_;
  std::vector<std::string> files_;
};

}  // namespace montage
