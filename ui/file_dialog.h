// File dialogs: zenity when it is installed (the desktop's own dialog, run on a helper thread so that
// the editor keeps drawing), otherwise a built-in Dear ImGui browser. One dialog at a time.
#pragma once

#include <future>
#include <optional>
#include <string>
#include <vector>

namespace montage {

enum class DialogKind { OpenFile, OpenFiles, SaveFile, OpenFolder };  // OpenFiles: several at once

struct FileFilter {
  std::string name;                   // "Projects"
  std::vector<std::string> patterns;  // {"*.json"}
};
// A filter's patterns for extensions as lowerExtension gives them: {".obj", ".ply"} -> {"*.obj", "*.ply"}.
std::vector<std::string> patternsOf(const std::vector<std::string>& extensions);

struct DialogResult {
  std::string purpose;             // what the caller asked the dialog for ("open", "save_as", ...)
  std::string path;                // chosen path (absolute); the first one for OpenFiles
  std::vector<std::string> paths;  // every chosen path (absolute), in order
};

class FileDialogs {
 public:
  FileDialogs();
  // Opens a dialog unless one is open already (returns false then). It starts in the folder of the last
  // choice (any dialog's, this session), else in `startDir` (the project's folder), else in the working
  // folder. The first filter is active; the built-in browser lists the files of the active filter only (a
  // combo, each filter shown with its patterns, chooses another), and folders; choosing a folder
  // (OpenFolder), it lists the filter's files greyed, so the user sees what the folder holds. Saving, a
  // name typed without an extension gets the active filter's (when it names one: "*.glb").
  bool request(DialogKind kind, const std::string& title, const std::vector<FileFilter>& filters,
               const std::string& purpose, const std::string& startDir);
  bool active() const { return active_; }
  const std::string& purpose() const { return purpose_; }  // the request's ("open", "save_as", ...)
  // Draws the built-in browser when it is the one in use (call once per frame inside the ImGui
  // frame) and returns the chosen path once, when the user has chosen; cancelling returns nothing.
  std::optional<DialogResult> frame();
  bool usesZenity() const { return zenity_; }
  // Forces the built-in browser (tests, TM_NO_ZENITY=1).
  void disableZenity() { zenity_ = false; }

  // The built-in browser, for the script's `state` and `dialog_filter`: its folder, the active filter's
  // name, and the entries it lists (folders end in '/').
  const std::string& folder() const { return dir_; }
  std::string filterName() const;
  std::vector<std::string> listed() const;
  bool chooseFilter(const std::string& name);  // false when no filter has that name
  const std::string& lastFolder() const { return lastDir_; }

 private:
  void drawBrowser();
  void goToTypedFolder();  // Enter in the folder field
  void confirm();          // the Open/Save button, Enter in the name field or outside the fields
  struct Entry {
    std::string name;
    bool folder = false;
    bool choosable = true;  // false: a file shown (greyed) while choosing a folder
  };
  std::vector<Entry> entries(std::string* error = nullptr) const;
  bool zenity_ = false;
  bool active_ = false;
  bool openPopup_ = false;
  DialogKind kind_ = DialogKind::OpenFile;
  std::string title_, purpose_;
  std::vector<FileFilter> filters_;
  std::future<std::optional<std::string>> pending_;  // zenity's answer
  // Built-in browser state.
  std::string dir_, name_, error_;
  std::string lastDir_;                // folder of the last choice
  int filter_ = 0;                     // active filter
  std::vector<std::string> selected_;  // OpenFiles: file names selected in dir_
  std::optional<std::string> chosen_;
  std::vector<std::string> chosenMany_;
  bool done_ = false;
  bool focusName_ = false;   // the name field is to take the keyboard (a save dialog appearing)
  bool dirActive_ = false;   // the folder field was being typed in at the last frame
};

}  // namespace montage
