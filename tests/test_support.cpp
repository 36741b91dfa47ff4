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

std::string gltfValidatorMissing() {
  const std::string nodeDir = TM_GLTF_NODE_DIR;
  if (!fs::exists(nodeDir + "/.tm_gltf_validator_ready"))
    return "the Khronos glTF validator is not installed in '" + nodeDir +
           "': the ctest test npm_gltf_validator_setup installs it with npm (it skips when npm cannot reach its "
           "registry)";
  if (runCommand("command -v node") != 0) return "node is not installed";
  return "";
}

std::string runGltfValidator(const std::string& file, int* status) {
  std::string out;
  *status = runCommand(std::string("NODE_PATH='") + TM_GLTF_NODE_DIR + "/node_modules' node '" + TM_GLTF_VALIDATE_JS +
                           "' '" + file + "'",
                       &out);
  std::printf("%s", out.c_str());
  return out;
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

// ---- EXIF segments (codec and camera tests) ----

using Byte = unsigned char;

std::vector<unsigned char> exif16(bool big, uint32_t v) {
  return big ? std::vector<unsigned char>{Byte(v >> 8), Byte(v)} : std::vector<unsigned char>{Byte(v), Byte(v >> 8)};
}
std::vector<unsigned char> exif32(bool big, uint32_t v) {
  std::vector<unsigned char> out = exif16(big, big ? v >> 16 : v & 0xFFFF),
                             second = exif16(big, big ? v & 0xFFFF : v >> 16);
  out.insert(out.end(), second.begin(), second.end());
  return out;
}

std::vector<unsigned char> exifPayload(bool big, std::vector<ExifEntryBytes> ifd0,
                                       const std::vector<ExifEntryBytes>& exif) {
  std::vector<unsigned char> t;  // the TIFF structure
  const auto put16 = [&](std::vector<unsigned char>& out, uint32_t v) {
    const std::vector<unsigned char> b = exif16(big, v);
    out.insert(out.end(), b.begin(), b.end());
  };
  const auto put32 = [&](std::vector<unsigned char>& out, uint32_t v) {
    const std::vector<unsigned char> b = exif32(big, v);
    out.insert(out.end(), b.begin(), b.end());
  };
  const size_t ifd0Size = 2 + 12 * (ifd0.size() + !exif.empty()) + 4,
               exifSize = exif.empty() ? 0 : 2 + 12 * exif.size() + 4;
  if (!exif.empty()) ifd0.push_back({34665, 4, 1, {}});  // the Exif IFD's offset, filled below
  std::vector<unsigned char> data;                       // values over 4 bytes
  const size_t dataAt = 8 + ifd0Size + exifSize;
  const auto writeIfd = [&](const std::vector<ExifEntryBytes>& entries) {
    put16(t, uint32_t(entries.size()));
    for (const ExifEntryBytes& e : entries) {
      put16(t, e.tag), put16(t, e.type), put32(t, e.count);
      if (e.tag == 34665) {
        put32(t, uint32_t(8 + ifd0Size));
      } else if (e.value.size() <= 4) {
        std::vector<unsigned char> v = e.value;
        v.resize(4, 0);
        t.insert(t.end(), v.begin(), v.end());
      } else {
        put32(t, uint32_t(dataAt + data.size()));
        data.insert(data.end(), e.value.begin(), e.value.end());
      }
    }
    put32(t, 0);
  };
  t.insert(t.end(),
           big ? std::initializer_list<unsigned char>{'M', 'M'} : std::initializer_list<unsigned char>{'I', 'I'});
  put16(t, 42), put32(t, 8);
  writeIfd(ifd0);
  if (!exif.empty()) writeIfd(exif);
  t.insert(t.end(), data.begin(), data.end());
  std::vector<unsigned char> payload = {'E', 'x', 'i', 'f', 0, 0};
  payload.insert(payload.end(), t.begin(), t.end());
  return payload;
}

std::vector<unsigned char> withApp1(const std::vector<unsigned char>& jpeg, const std::vector<unsigned char>& payload) {
  std::vector<unsigned char> bytes(jpeg.begin(), jpeg.begin() + 2);
  const size_t length = payload.size() + 2;
  bytes.insert(bytes.end(), {0xFF, 0xE1, Byte(length >> 8), Byte(length & 0xFF)});
  bytes.insert(bytes.end(), payload.begin(), payload.end());
  bytes.insert(bytes.end(), jpeg.begin() + 2, jpeg.end());
  return bytes;
}

}  // namespace montage::test
