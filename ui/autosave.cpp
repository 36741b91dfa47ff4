#include "autosave.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <sstream>

namespace fs = std::filesystem;

namespace montage {

namespace {

std::time_t fileTime(const std::string& path) {
  std::error_code ec;
  const auto t = fs::last_write_time(path, ec);
  if (ec) return 0;
  // file_clock -> system_clock (C++17 has no clock_cast): shift by the two clocks' current offset.
  const auto sys = std::chrono::time_point_cast<std::chrono::system_clock::duration>(
      t - fs::file_time_type::clock::now() + std::chrono::system_clock::now());
  return std::chrono::system_clock::to_time_t(sys);
}

// A short stable name for a path: its file stem (readable) and a hash of the whole path (unique).
std::string keyOf(const std::string& path) {
  std::ostringstream out;
  std::string stem = fs::path(path).stem().string();
  for (char& c : stem)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_') c = '_';
  out << stem << '-' << std::hex << std::setw(16) << std::setfill('0') << std::hash<std::string>{}(path);
  return out.str();
}

std::string absolute(const std::string& path) {
  return path.empty() ? path : fs::absolute(path).lexically_normal().string();
}

}  // namespace

std::string editorStateDir() {
  if (const char* xdg = std::getenv("XDG_STATE_HOME"); xdg && *xdg) return (fs::path(xdg) / "texturemontage").string();
  if (const char* home = std::getenv("HOME"); home && *home)
    return (fs::path(home) / ".local/state/texturemontage").string();
  return (fs::temp_directory_path() / ("texturemontage-" + std::to_string(getuid()))).string();
}

std::string autosavePathFor(const std::string& projectFile, const std::string& meshFile) {
  const fs::path dir = fs::path(editorStateDir()) / "autosave";
  const std::string key = projectFile.empty() ? "untitled-" + keyOf(absolute(meshFile)) : keyOf(absolute(projectFile));
  return (dir / (key + ".json")).string();
}

void writeAutosave(const Project& project, const std::string& autosavePath) {
  // Absolute paths (relativeTo ""), so the side file opens from its own folder.
  auto json = nlohmann::ordered_json::parse(projectToJson(project, ""));
  json["autosave"] = {{"project", absolute(project.file)},
                      {"time", static_cast<long long>(std::time(nullptr))},
                      {"pid", static_cast<long long>(getpid())}};
  std::error_code ec;
  fs::create_directories(fs::path(autosavePath).parent_path(), ec);
  TM_CHECK(!ec, located(fs::path(autosavePath).parent_path().string(),
                        "cannot create the autosave folder: " + ec.message()));
  writeFileAtomic(autosavePath, json.dump(2) + "\n");
}

std::optional<RecoveryCandidate> readAutosaveHeader(const std::string& autosavePath) {
  std::ifstream in(autosavePath);
  if (!in) return std::nullopt;
  try {
    const auto json = nlohmann::json::parse(in);
    if (!json.contains("autosave") || !json["autosave"].is_object()) return std::nullopt;
    RecoveryCandidate c;
    c.autosavePath = autosavePath;
    c.projectFile = json["autosave"].value("project", "");
    c.meshFile = json.value("mesh", "");
    c.time = fileTime(autosavePath);
    if (json.contains("points") && json["points"].is_array()) c.points = static_cast<int>(json["points"].size());
    return c;
  } catch (const std::exception&) {
    return std::nullopt;  // a torn or foreign file is not offered (writes are atomic, so rare)
  }
}

std::optional<RecoveryCandidate> findRecovery(const std::string& projectFile, const std::string& meshFile) {
  const std::string side = autosavePathFor(projectFile, meshFile);
  std::error_code ec;
  if (!fs::exists(side, ec)) return std::nullopt;
  auto candidate = readAutosaveHeader(side);
  if (!candidate) return std::nullopt;
  if (!projectFile.empty() && fs::exists(projectFile, ec)) {
    // Saved after the autosave: the project file holds the newer work.
    if (fs::last_write_time(side, ec) <= fs::last_write_time(projectFile, ec)) return std::nullopt;
  }
  return candidate;
}

std::vector<RecoveryCandidate> listRecoveries() {
  std::vector<RecoveryCandidate> out;
  std::error_code ec;
  const fs::path dir = fs::path(editorStateDir()) / "autosave";
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    if (it->path().extension() != ".json") continue;
    if (auto c = readAutosaveHeader(it->path().string())) out.push_back(*c);
  }
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.time > b.time; });
  return out;
}

Project loadRecovery(const RecoveryCandidate& candidate) {
  Project project = loadProject(candidate.autosavePath);
  project.file = candidate.projectFile;
  return project;
}

void removeAutosave(const std::string& autosavePath) {
  std::error_code ec;
  fs::remove(autosavePath, ec);
}

RecentFiles::RecentFiles(std::string storePath) : store_(std::move(storePath)) {
  if (store_.empty()) store_ = (fs::path(editorStateDir()) / "recent.json").string();
  load();
}

void RecentFiles::load() {
  files_.clear();
  std::ifstream in(store_);
  if (!in) return;
  try {
    const auto json = nlohmann::json::parse(in);
    for (const auto& f : json.value("recent", nlohmann::json::array()))
      if (f.is_string() && files_.size() < kMax) files_.push_back(f.get<std::string>());
  } catch (const std::exception&) {
    files_.clear();  // an unreadable list is only a convenience lost
  }
}

void RecentFiles::save() const {
  try {
    std::error_code ec;
    fs::create_directories(fs::path(store_).parent_path(), ec);
    writeFileAtomic(store_, nlohmann::json{{"recent", files_}}.dump(2) + "\n");
  } catch (const Error&) {
  }
}

void RecentFiles::add(const std::string& file) {
  const std::string abs = absolute(file);
  files_.erase(std::remove(files_.begin(), files_.end(), abs), files_.end());
  files_.insert(files_.begin(), abs);
  if (files_.size() > kMax) files_.resize(kMax);
  save();
}

void RecentFiles::remove(const std::string& file) {
  files_.erase(std::remove(files_.begin(), files_.end(), absolute(file)), files_.end());
  save();
}

void RecentFiles::clear() {
  files_.clear();
  save();
}

}  // namespace montage
