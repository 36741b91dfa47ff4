#include "test_support.h"

#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <vector>

#include "pipeline.h"

namespace fs = std::filesystem;

namespace montage::test {

std::string assetsDir() {
  return TM_ASSETS_DIR;
}

std::string testDataDir() {
  return TM_TEST_DATA_DIR;
}

std::string sharedDataDir() {
  std::error_code ec;
  if (const char* env = std::getenv("TM_SHARED_DATA_DIR"); env && fs::is_directory(env, ec)) return env;
  if (fs::is_directory(TM_SHARED_DATA_DIR, ec)) return fs::canonical(TM_SHARED_DATA_DIR).string();
  return "";
}

std::string sharedFile(const std::string& rel) {
  const std::string dir = sharedDataDir();
  std::error_code ec;
  if (dir.empty() || !fs::exists(fs::path(dir) / rel, ec)) {
    std::fprintf(stderr, "SKIPPED: ../shared/data/%s is absent\n", rel.c_str());
    return "";
  }
  return (fs::path(dir) / rel).string();
}

namespace {
struct TempDirs {
  std::mutex mutex;
  std::vector<fs::path> dirs;
  ~TempDirs() {
    if (std::getenv("TM_KEEP_TEST_FILES")) return;
    std::error_code ec;
    for (auto& d : dirs) fs::remove_all(d, ec);
  }
};
TempDirs& tempDirs() {
  static TempDirs dirs;  // process-lifetime registry of folders to clean up
  return dirs;
}
}  // namespace

std::string tempDir(const std::string& tag) {
  std::string pattern = (fs::temp_directory_path() / ("tm_" + tag + "_XXXXXX")).string();
  std::vector<char> buf(pattern.begin(), pattern.end());
  buf.push_back('\0');
  if (!mkdtemp(buf.data())) throw std::runtime_error("mkdtemp failed for " + pattern);
  auto& reg = tempDirs();
  std::lock_guard<std::mutex> lock(reg.mutex);
  reg.dirs.emplace_back(buf.data());
  return buf.data();
}

std::string montageExe() {
  return TM_MONTAGE_EXE;
}

int runCommand(const std::string& command, std::string* output) {
  std::string cmd = command + " 2>&1";
  FILE* pipe = popen(cmd.c_str(), "r");
  if (!pipe) return -1;
  char buf[4096];
  std::string out;
  while (size_t n = fread(buf, 1, sizeof buf, pipe)) out.append(buf, n);
  int status = pclose(pipe);
  if (output) *output = out;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

bool haveXvfb() {
  return runCommand("command -v xvfb-run >/dev/null 2>&1") == 0;
}

nlohmann::json demoProjectAbsolute() {
  nlohmann::json project = readJson(assetsDir() + "/demo/project.json");
  const std::string demo = assetsDir() + "/demo/";
  project["mesh"] = demo + project["mesh"].get<std::string>();
  for (auto& photo : project["photos"]) {
    photo["path"] = demo + photo["path"].get<std::string>();
    if (photo.contains("mask") && photo["mask"].is_string() && !photo["mask"].get<std::string>().empty())
      photo["mask"] = demo + photo["mask"].get<std::string>();
  }
  return project;
}

nlohmann::json readJson(const std::string& path) {
  std::ifstream in(path);
  EXPECT_TRUE(in) << "missing " << path;
  return in ? nlohmann::json::parse(in) : nlohmann::json();
}

void expectSameMapping(const Mapping& a, const Mapping& b, const std::string& what) {
  ASSERT_EQ(a.partition->mesh.numFaces(), b.partition->mesh.numFaces()) << what;
  ASSERT_EQ(a.map.numFaces(), b.map.numFaces()) << what;
  EXPECT_EQ(a.map.facePhoto, b.map.facePhoto) << what;
  double worst = 0;
  for (int f = 0; f < a.map.numFaces(); ++f)
    for (int k = 0; k < 3; ++k) worst = std::max(worst, (a.map.cornerUV[f][k] - b.map.cornerUV[f][k]).norm());
  EXPECT_LE(worst, 1e-9) << what;
}

}  // namespace montage::test
