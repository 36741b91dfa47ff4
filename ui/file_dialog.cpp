#include "file_dialog.h"

#include <imgui.h>
#include <imgui_stdlib.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>

namespace fs = std::filesystem;

namespace montage {

namespace {

// Single-quotes an argument for /bin/sh.
std::string shellQuote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

bool onPath(const char* program) {
  const char* path = std::getenv("PATH");
  if (!path) return false;
  std::string dirs = path;
  size_t start = 0;
  while (start <= dirs.size()) {
    const size_t end = std::min(dirs.find(':', start), dirs.size());
    const fs::path candidate = fs::path(dirs.substr(start, end - start)) / program;
    std::error_code ec;
    if (fs::is_regular_file(candidate, ec)) return true;
    start = end + 1;
  }
  return false;
}

bool matches(const std::string& name, const FileFilter& filter) {
  std::string lower = name;
  for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  for (const auto& p : filter.patterns) {
    if (p == "*") return true;
    const std::string ext = p.substr(p.find('.') == std::string::npos ? 0 : p.find('.'));
    if (lower.size() >= ext.size() && lower.compare(lower.size() - ext.size(), ext.size(), ext) == 0) return true;
  }
  return false;
}

// "glTF binary (*.glb)": the filter as the combo and zenity show it.
std::string label(const FileFilter& filter) {
  std::string patterns;
  for (const auto& p : filter.patterns) patterns += (patterns.empty() ? "" : " ") + p;
  return patterns.empty() || patterns == "*" ? filter.name : filter.name + " (" + patterns + ")";
}

// The extension a filter names when it has one pattern "*.ext" (".glb"), else "".
std::string soleExtension(const FileFilter& filter) {
  if (filter.patterns.size() != 1) return "";
  const std::string& p = filter.patterns.front();
  if (p.rfind("*.", 0) != 0 || p.size() < 3 || p.find_first_of("*?[", 1) != std::string::npos) return "";
  return p.substr(1);
}

}  // namespace

std::vector<std::string> patternsOf(const std::vector<std::string>& extensions) {
  std::vector<std::string> out;
  for (const std::string& e : extensions) out.push_back("*" + e);
  return out;
}

FileDialogs::FileDialogs() {
  const char* no = std::getenv("TM_NO_ZENITY");
  zenity_ = !(no && *no && std::string(no) != "0") && onPath("zenity");
}

bool FileDialogs::request(DialogKind kind, const std::string& title, const std::vector<FileFilter>& filters,
                          const std::string& purpose, const std::string& startDir) {
  if (active_) return false;
  active_ = true;
  kind_ = kind;
  title_ = title;
  filters_ = filters;
  purpose_ = purpose;
  std::error_code ec;
  if (!lastDir_.empty() && fs::is_directory(lastDir_, ec))
    dir_ = lastDir_;
  else if (!startDir.empty() && fs::is_directory(startDir, ec))
    dir_ = startDir;
  else
    dir_ = fs::current_path(ec).string();
  filter_ = 0;
  name_.clear();
  error_.clear();
  selected_.clear();
  chosen_.reset();
  chosenMany_.clear();
  done_ = false;
  focusName_ = kind == DialogKind::SaveFile;
  dirActive_ = false;
  if (zenity_) {
    std::string cmd = "zenity --file-selection --title=" + shellQuote(title);
    if (kind == DialogKind::SaveFile) cmd += " --save --confirm-overwrite";
    if (kind == DialogKind::OpenFolder) cmd += " --directory";
    if (kind == DialogKind::OpenFiles) cmd += " --multiple --separator='\n'";
    cmd += " --filename=" + shellQuote(dir_ + "/");
    for (const auto& f : filters) {
      std::string spec = label(f) + " |";
      for (const auto& p : f.patterns) spec += " " + p;
      cmd += " --file-filter=" + shellQuote(spec);
    }
    cmd += " 2>/dev/null";
    // zenity blocks until the user answers: it runs on its own thread so the editor keeps drawing
    // (and the worker's results keep arriving) meanwhile.
    pending_ = std::async(std::launch::async, [cmd]() -> std::optional<std::string> {
      FILE* pipe = popen(cmd.c_str(), "r");
      if (!pipe) return std::nullopt;
      std::string out;
      char buffer[4096];
      while (size_t n = std::fread(buffer, 1, sizeof(buffer), pipe)) out.append(buffer, n);
      const int status = pclose(pipe);
      while (!out.empty() && (out.back() == '\n' || out.back() == '\r')) out.pop_back();
      if (status != 0 || out.empty()) return std::nullopt;  // cancelled
      return out;
    });
  } else {
    openPopup_ = true;
  }
  return true;
}

std::optional<DialogResult> FileDialogs::frame() {
  if (!active_) return std::nullopt;
  if (zenity_) {
    if (pending_.valid() && pending_.wait_for(std::chrono::seconds(0)) == std::future_status::ready) {
      active_ = false;
      if (auto out = pending_.get()) {
        // One path, or one per line (--multiple).
        DialogResult result{purpose_, "", {}};
        size_t start = 0;
        while (start <= out->size()) {
          const size_t end = std::min(out->find('\n', start), out->size());
          if (end > start)
            result.paths.push_back(fs::absolute(out->substr(start, end - start)).lexically_normal().string());
          start = end + 1;
        }
        if (result.paths.empty()) return std::nullopt;
        result.path = result.paths.front();
        lastDir_ = kind_ == DialogKind::OpenFolder ? result.path : fs::path(result.path).parent_path().string();
        return result;
      }
    }
    return std::nullopt;
  }
  drawBrowser();
  if (done_) {
    active_ = false;
    done_ = false;
    if (chosen_ || !chosenMany_.empty()) lastDir_ = dir_;
    if (!chosenMany_.empty()) {
      DialogResult result{purpose_, "", {}};
      for (const auto& p : chosenMany_) result.paths.push_back(fs::absolute(p).lexically_normal().string());
      result.path = result.paths.front();
      return result;
    }
    if (chosen_) {
      const std::string path = fs::absolute(*chosen_).lexically_normal().string();
      return DialogResult{purpose_, path, {path}};
    }
  }
  return std::nullopt;
}

std::string FileDialogs::filterName() const {
  return filter_ < static_cast<int>(filters_.size()) ? filters_[filter_].name : "";
}

bool FileDialogs::chooseFilter(const std::string& name) {
  for (size_t i = 0; i < filters_.size(); ++i)
    if (filters_[i].name == name) {
      filter_ = static_cast<int>(i);
      return true;
    }
  return false;
}

std::vector<FileDialogs::Entry> FileDialogs::entries(std::string* error) const {
  std::error_code ec;
  std::vector<Entry> out;
  for (fs::directory_iterator it(dir_, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.empty() || name[0] == '.') continue;
    std::error_code e;
    const bool isDir = it->is_directory(e);
    const bool shown =
        isDir || filters_.empty() || matches(name, filters_[std::min<size_t>(filter_, filters_.size() - 1)]);
    if (!shown) continue;
    out.push_back({name, isDir, isDir || kind_ != DialogKind::OpenFolder});
  }
  if (ec && error) *error = "cannot list " + dir_ + ": " + ec.message();
  std::sort(out.begin(), out.end(),
            [](const Entry& a, const Entry& b) { return a.folder != b.folder ? a.folder : a.name < b.name; });
  return out;
}

std::vector<std::string> FileDialogs::listed() const {
  std::vector<std::string> names;
  for (const Entry& e : entries()) names.push_back(e.folder ? e.name + "/" : e.name);
  return names;
}

void FileDialogs::goToTypedFolder() {
  std::error_code ec;
  const fs::path typed = fs::absolute(dir_.empty() ? fs::path("/") : fs::path(dir_)).lexically_normal();
  if (fs::is_directory(typed, ec)) {
    std::string d = typed.string();
    if (d.size() > 1 && d.back() == '/') d.pop_back();
    dir_ = d;
    error_.clear();
    selected_.clear();
  } else if (fs::is_regular_file(typed, ec) && kind_ != DialogKind::OpenFolder) {
    // A file's path typed in the folder field: its folder, with the file as the name.
    dir_ = typed.parent_path().string();
    name_ = typed.filename().string();
    error_.clear();
    selected_.clear();
  } else {
    error_ = typed.string() + ": no such folder";
  }
}

void FileDialogs::confirm() {
  if (kind_ == DialogKind::OpenFolder) {
    chosen_ = dir_;
    done_ = true;
  } else if (kind_ == DialogKind::OpenFiles && !selected_.empty()) {
    for (const auto& n : selected_) chosenMany_.push_back((fs::path(dir_) / n).string());
    done_ = true;
  } else if (name_.empty()) {
    error_ = "type or choose a file name";
  } else {
    fs::path path = fs::path(name_).is_absolute() ? fs::path(name_) : fs::path(dir_) / name_;
    std::error_code e;
    if (kind_ == DialogKind::SaveFile && path.extension().empty() && !filters_.empty()) {
      // The filter chosen says the type: "model" with "glTF binary (*.glb)" is model.glb.
      const std::string ext = soleExtension(filters_[std::min<size_t>(filter_, filters_.size() - 1)]);
      if (!ext.empty()) path += ext;
    }
    if ((kind_ == DialogKind::OpenFile || kind_ == DialogKind::OpenFiles) && !fs::is_regular_file(path, e)) {
      error_ = path.string() + ": no such file";
    } else if (fs::is_directory(path, e)) {
      // A folder's name typed as the file name: go into it.
      dir_ = path.lexically_normal().string();
      name_.clear();
      error_.clear();
    } else {
      chosen_ = path.string();
      done_ = true;
    }
  }
}

void FileDialogs::drawBrowser() {
  const char* popupId = "##tm_file_browser";
  if (openPopup_) {
    ImGui::OpenPopup(popupId);
    openPopup_ = false;
  }
  const ImVec2 display = ImGui::GetIO().DisplaySize;
  ImGui::SetNextWindowSize(ImVec2(std::min(ImGui::GetFontSize() * 48, display.x * 0.9f),
                                  std::min(ImGui::GetFontSize() * 35, display.y * 0.85f)),
                           ImGuiCond_Appearing);
  ImGui::SetNextWindowPos(ImVec2(display.x * 0.5f, display.y * 0.5f), ImGuiCond_Appearing, ImVec2(0.5f, 0.5f));
  if (!ImGui::BeginPopupModal(popupId, nullptr, ImGuiWindowFlags_NoSavedSettings)) {
    // Closed some other way (Escape): a cancel.
    done_ = true;
    return;
  }
  ImGui::TextUnformatted(title_.c_str());
  ImGui::Separator();
  if (ImGui::Button("Up")) {
    dir_ = fs::path(dir_).parent_path().string();
    error_.clear();
  }
  ImGui::SameLine();
  if (filters_.size() > 1) {
    // The type filter: only the chosen one's files are listed.
    ImGui::SetNextItemWidth(ImGui::GetFontSize() * 14);
    if (ImGui::BeginCombo("##filter", label(filters_[filter_]).c_str())) {
      for (size_t i = 0; i < filters_.size(); ++i)
        if (ImGui::Selectable(label(filters_[i]).c_str(), filter_ == static_cast<int>(i)))
          filter_ = static_cast<int>(i);
      ImGui::EndCombo();
    }
    ImGui::SameLine();
  }
  ImGui::SetNextItemWidth(-1);
  const bool dirEntered = ImGui::InputText("##dir", &dir_, ImGuiInputTextFlags_EnterReturnsTrue);
  dirActive_ = ImGui::IsItemActive();
  if (dirEntered) goToTypedFolder();

  const float footer = ImGui::GetFrameHeightWithSpacing() * (kind_ == DialogKind::OpenFolder ? 2.2f : 3.2f);
  ImGui::BeginChild("##entries", ImVec2(0, -footer), true);
  std::string listError;
  for (const Entry& entry : entries(&listError)) {
    const std::string& name = entry.name;
    const bool isDir = entry.folder;
    const std::string label = (isDir ? "[dir] " : "      ") + name;
    if (!entry.choosable) {
      ImGui::TextDisabled("%s", label.c_str());  // a file of the folder being chosen
      continue;
    }
    const bool many = kind_ == DialogKind::OpenFiles;
    const bool isSelected =
        many ? std::find(selected_.begin(), selected_.end(), name) != selected_.end() : name == name_;
    if (ImGui::Selectable(label.c_str(), !isDir && isSelected, ImGuiSelectableFlags_AllowDoubleClick)) {
      if (isDir) {
        if (ImGui::IsMouseDoubleClicked(0)) {
          dir_ = (fs::path(dir_) / name).string();
          selected_.clear();
          error_.clear();
        }
      } else if (many && !ImGui::IsMouseDoubleClicked(0)) {
        // A click toggles the file in the selection.
        if (isSelected)
          selected_.erase(std::find(selected_.begin(), selected_.end(), name));
        else
          selected_.push_back(name);
        name_.clear();
        for (const auto& n : selected_) name_ += (name_.empty() ? "" : "; ") + n;
      } else {
        name_ = name;
        if (ImGui::IsMouseDoubleClicked(0)) {
          chosen_ = (fs::path(dir_) / name).string();
          done_ = true;
        }
      }
    }
  }
  if (!listError.empty()) ImGui::TextColored(ImVec4(1, 0.4f, 0.4f, 1), "%s", listError.c_str());
  ImGui::EndChild();

  bool nameEntered = false;
  if (kind_ != DialogKind::OpenFolder) {
    ImGui::SetNextItemWidth(-1);
    // A save dialog: type the name at once. Asked again until the field has the keyboard (a popup's first
    // frame is hidden and drops the request), unless the user clicks somewhere first.
    if (focusName_ && ImGui::IsMouseClicked(ImGuiMouseButton_Left)) focusName_ = false;
    if (focusName_) ImGui::SetKeyboardFocusHere();
    nameEntered = ImGui::InputTextWithHint("##name", "file name", &name_, ImGuiInputTextFlags_EnterReturnsTrue);
    if (ImGui::IsItemActive()) focusName_ = false;
  }
  if (!error_.empty()) ImGui::TextColored(ImVec4(1, 0.4f, 0.4f, 1), "%s", error_.c_str());
  const char* ok = kind_ == DialogKind::SaveFile ? "Save" : kind_ == DialogKind::OpenFolder ? "Choose folder" : "Open";
  // Enter outside the folder field chooses (the folder field's Enter went to its folder above).
  const bool enterOutside = ImGui::IsKeyPressed(ImGui::GetKeyIndex(ImGuiKey_Enter)) && !dirEntered && !dirActive_;
  if ((ImGui::Button(ok, ImVec2(ImGui::GetFontSize() * 8, 0)) || nameEntered || enterOutside) && !done_) confirm();
  ImGui::SameLine();
  if (ImGui::Button("Cancel", ImVec2(ImGui::GetFontSize() * 8, 0)) ||
      ImGui::IsKeyPressed(ImGui::GetKeyIndex(ImGuiKey_Escape))) {
    chosen_.reset();
    chosenMany_.clear();
    done_ = true;
  }
  if (done_) ImGui::CloseCurrentPopup();
  ImGui::EndPopup();
}

}  // namespace montage
