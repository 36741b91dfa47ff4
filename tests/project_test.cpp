// Tests of core/project: save/load round trip, relative paths, atomic writes, and one test per
// rejection, each checking that the message names the file, the field and the reason.
#include "io/project.h"

#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "io/project_warnings.h"
#include "test_support.h"

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace montage;

namespace {

std::string readFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

void writeText(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

std::vector<std::string> listDir(const std::string& dir) {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(dir)) names.push_back(entry.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

using montage::test::errorOf;

#define EXPECT_MESSAGE_HAS(message, part) \
  EXPECT_NE((message).find(part), std::string::npos) << "message: " << (message) << "\nlacks: " << (part)

// A folder with the files a project refers to: mesh.obj, photos/a.png with photos/a_mask.png, and
// photos/b.png (photos 100x80 and 50x40).
class ProjectTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = test::tempDir("project");
    fs::create_directories(fs::path(dir) / "photos");
    writeText(path("mesh.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    cv::imwrite(path("photos/a.png"), cv::Mat(80, 100, CV_8UC3, cv::Scalar(10, 20, 30)));
    cv::imwrite(path("photos/a_mask.png"), cv::Mat(80, 100, CV_8UC1, cv::Scalar(255)));
    cv::imwrite(path("photos/b.png"), cv::Mat(40, 50, CV_8UC3, cv::Scalar(30, 20, 10)));
  }

  std::string path(const std::string& rel) const { return (fs::path(dir) / rel).string(); }

  // A project using every field, with non-default options and doubles that need all 17 digits.
  Project sample() const {
    Project p;
    p.mesh = path("mesh.obj");
    p.photos = {{path("photos/a.png"), path("photos/a_mask.png"), false, true},
                {path("photos/b.png"), "", true, false}};
    p.points = {{12, {{0, 10.25, 20.5}, {1, 1.0 / 3, 2.0 / 7}}},
                {5, {{0, 0.1, 79.99999999999999}}},
                {7, {{0, 100, 0}, {1, 49.5, 39.5}}}};
    p.chains = {{0, {0, 1, 2}, true}, {1, {2, 0}, false}};
    p.strokes = {{{1, 2, 3}}, {{4, 5}}};
    CloneOp clone;
    clone.photo = 1;
    clone.polygon = {Vec2(1, 1), Vec2(40.5, 2), Vec2(20, 30.125)};
    clone.targetFaces = {0, 3, 4};
    clone.anchorVertex = 3;
    clone.anchor = Vec2(5.5, 6.25);
    clone.pixelsPerUnit = 12.5;
    clone.rotationDeg = -33.3;
    p.clones = {clone};
    p.options.backgroundThresholdPx = 3.5;
    p.options.seamLambda = 0.25;
    p.options.seamRounds = 12;
    p.options.gradientWeight = 0.3;
    p.options.inpaintMode = InpaintMode::Strokes;
    p.options.atlasSize = 2048;
    p.options.gutter = 8;
    p.options.seed = 4000000000u;
    p.options.cameraMode = CameraMode::Off;
    p.options.cameraThreshold = 0.01;
    p.options.sharedIntrinsics = false;
    p.options.photometric = false;
    p.options.foundSilhouettes = false;
    p.options.correction = CorrectionMode::Inliers;
    p.options.viewSmoothness = 2.5;
    p.declinedProposals = {{12, 1}, {7, 0}};
    return p;
  }

  // The sample as a JSON document, to be broken by the rejection tests.
  json sampleJson() const { return json::parse(projectToJson(sample(), path("p.json"))); }

  // Writes `document` as p.json and returns the message of loadProject's error.
  std::string loadError(const json& document) const {
    writeText(path("p.json"), document.dump(2));
    const std::string message = errorOf([&] { loadProject(path("p.json")); });
    EXPECT_MESSAGE_HAS(message, path("p.json"));
    return message;
  }

  // The message of validateProject's error for the sample with 20 vertices and 10 faces.
  static std::string validateError(const Project& p) {
    return errorOf([&] { validateProject(p, 20, 10, {{100, 80}, {50, 40}}); });
  }

  std::string dir;
};

}  // namespace

// ---- Round trip and format ----

TEST_F(ProjectTest, SaveLoadRoundTrip) {
  Project original = sample();
  saveProject(original, path("p.json"));
  EXPECT_EQ(original.file, path("p.json"));
  const Project loaded = loadProject(path("p.json"));
  EXPECT_TRUE(loaded.sameDocument(original));
  EXPECT_EQ(loaded.file, path("p.json"));
  EXPECT_EQ(loaded.points[0].at[1].x, 1.0 / 3);  // exact, not just close
  EXPECT_EQ(loaded.points[1].at[0].y, 79.99999999999999);
  EXPECT_EQ(loaded.options.seed, 4000000000u);
  EXPECT_EQ(loaded.options.inpaintMode, InpaintMode::Strokes);

  // Saving the loaded project gives the same text (deterministic output).
  Project again = loaded;
  saveProject(again, path("q.json"));
  EXPECT_EQ(readFile(path("p.json")), readFile(path("q.json")));
  EXPECT_EQ(projectToJson(loaded, path("p.json")), readFile(path("p.json")));
  validateProject(loaded, 20, 10, {{100, 80}, {50, 40}});  // the sample is valid

  // sameDocument looks at every field but `file`.
  Project other = loaded;
  other.file = "/elsewhere.json";
  EXPECT_TRUE(other.sameDocument(loaded));
  other.options.gutter = 9;
  EXPECT_FALSE(other.sameDocument(loaded));
  other = loaded;
  other.clones[0].rotationDeg = 0;
  EXPECT_FALSE(other.sameDocument(loaded));
  other = loaded;
  other.photos[0].mask.clear();
  EXPECT_FALSE(other.sameDocument(loaded));
  other = loaded;
  other.photos[1].mirror = false;
  EXPECT_FALSE(other.sameDocument(loaded));
  other = loaded;
  other.photos[0].colorLocked = false;
  EXPECT_FALSE(other.sameDocument(loaded));
  EXPECT_TRUE(loaded.photos[1].mirror);
  EXPECT_TRUE(loaded.photos[0].colorLocked);
  EXPECT_EQ(loaded.options.colorBalance, BalanceMode::GainOffset);
  other = loaded;
  other.declinedProposals.pop_back();
  EXPECT_FALSE(other.sameDocument(loaded));
  other = loaded;
  other.options.correction = CorrectionMode::All;
  EXPECT_FALSE(other.sameDocument(loaded));
}

TEST_F(ProjectTest, Version1FilesStillLoadAndDeclinedProposalsAreChecked) {
  json j = sampleJson();
  EXPECT_EQ(j["declinedProposals"], json::parse(R"([{"vertex": 12, "photo": 1}, {"vertex": 7, "photo": 0}])"));
  EXPECT_EQ(j["options"]["cameraMode"], "off");
  EXPECT_EQ(j["options"]["correction"], "inliers");
  // A version 1 file has no declined proposals (the field did not exist; it is not read).
  j["version"] = 1;
  writeText(path("p.json"), j.dump(2));
  EXPECT_TRUE(loadProject(path("p.json")).declinedProposals.empty());
  j["version"] = 2;
  j["declinedProposals"][1]["photo"] = 5;
  EXPECT_MESSAGE_HAS(loadError(j), "declinedProposals[1].photo: 5 is out of range: the project has 2 photos");
  j["declinedProposals"][1]["photo"] = "a";
  EXPECT_MESSAGE_HAS(loadError(j), "declinedProposals[1].photo: must be an integer");
  j["declinedProposals"][1]["photo"] = 0;
  j["options"]["correction"] = "some";
  EXPECT_MESSAGE_HAS(loadError(j), "options.correction: 'some' is not a correction mode");
  Project p = sample();
  p.declinedProposals[0].vertex = 20;
  EXPECT_MESSAGE_HAS(validateError(p), "declinedProposals[0].vertex: 20 is out of range: the mesh has 20 vertices");
}

TEST_F(ProjectTest, FileIsPrettyVersionedJson) {
  Project p = sample();
  p.photos[1].mode = PhotoMode::Subject;  // a photo of another subject: version 4
  saveProject(p, path("p.json"));
  const std::string text = readFile(path("p.json"));
  EXPECT_NE(text.find("\n  \"version\": 4,"), std::string::npos) << text;  // two-space indent
  const json j = json::parse(text);
  EXPECT_EQ(j["format"], "texturemontage-project");
  EXPECT_EQ(j["version"], 4);
  EXPECT_EQ(j["photos"][1]["mirror"], true);
  EXPECT_EQ(j["photos"][1]["mode"], "subject");
  EXPECT_FALSE(j["photos"][0].contains("mode"));    // auto: no field
  EXPECT_FALSE(j["photos"][0].contains("mirror"));  // false: no field
  EXPECT_EQ(j["photos"][0]["colorLocked"], true);
  EXPECT_EQ(j["options"]["colorBalance"], "gain-offset");
  EXPECT_EQ(j["options"]["inpaintMode"], "strokes");
  EXPECT_EQ(j["options"]["atlasSize"], 2048);
  EXPECT_EQ(j["clones"][0]["anchor"], json::array({5.5, 6.25}));
  EXPECT_EQ(j["chains"][0]["closed"], true);
  EXPECT_FALSE(j["photos"][1].contains("mask"));  // no mask: no field
}

TEST_F(ProjectTest, PathsAreRelativeInTheFileAndAbsoluteAfterLoad) {
  Project p = sample();
  saveProject(p, path("p.json"));
  json j = json::parse(readFile(path("p.json")));
  EXPECT_EQ(j["mesh"], "mesh.obj");
  EXPECT_EQ(j["photos"][0]["path"], "photos/a.png");
  EXPECT_EQ(j["photos"][0]["mask"], "photos/a_mask.png");

  // From a sub-folder the paths go up.
  fs::create_directories(path("projects/v1"));
  saveProject(p, path("projects/v1/../v1/p.json"));
  EXPECT_EQ(p.file, path("projects/v1/p.json"));
  j = json::parse(readFile(path("projects/v1/p.json")));
  EXPECT_EQ(j["mesh"], "../../mesh.obj");
  EXPECT_EQ(j["photos"][1]["path"], "../../photos/b.png");
  const Project loaded = loadProject(path("projects/v1/p.json"));
  EXPECT_EQ(loaded.mesh, path("mesh.obj"));
  EXPECT_EQ(loaded.photos[1].path, path("photos/b.png"));
  EXPECT_TRUE(fs::path(loaded.photos[0].mask).is_absolute());

  // Hand-written paths are made lexically normal; absolute ones stay as they are.
  j["mesh"] = "./../../photos/../mesh.obj";
  j["photos"][0]["path"] = path("photos/a.png");
  writeText(path("projects/v1/p.json"), j.dump());
  const Project normal = loadProject(path("projects/v1/p.json"));
  EXPECT_EQ(normal.mesh, path("mesh.obj"));
  EXPECT_EQ(normal.photos[0].path, path("photos/a.png"));

  // With no relativeTo, paths are written as they are.
  EXPECT_EQ(json::parse(projectToJson(p, ""))["mesh"], path("mesh.obj"));
}

TEST_F(ProjectTest, MinimalFileGetsDefaultsAndUnknownFieldsAreIgnored) {
  writeText(path("p.json"), R"({"format": "texturemontage-project", "version": 1, "mesh": "mesh.obj"})");
  const Project minimal = loadProject(path("p.json"));
  EXPECT_EQ(minimal.mesh, path("mesh.obj"));
  EXPECT_TRUE(minimal.photos.empty() && minimal.points.empty() && minimal.chains.empty() && minimal.strokes.empty() &&
              minimal.clones.empty());
  PipelineOptions version1;  // a version-1 file keeps its behaviour: no colour balance
  version1.colorBalance = BalanceMode::Off;
  EXPECT_EQ(minimal.options, version1);

  json j = sampleJson();
  j["comment"] = "written by a later build";
  j["points"][0]["label"] = "nose";
  j["options"]["futureOption"] = 3;
  j["options"].erase("gutter");  // absent option: default
  j["chains"][1].erase("closed");
  j["clones"][0].erase("rotationDeg");
  writeText(path("p.json"), j.dump());
  const Project loaded = loadProject(path("p.json"));
  EXPECT_EQ(loaded.options.gutter, PipelineOptions().gutter);
  EXPECT_EQ(loaded.options.atlasSize, 2048);
  EXPECT_FALSE(loaded.chains[1].closed);
  EXPECT_EQ(loaded.clones[0].rotationDeg, 0);
  EXPECT_EQ(loaded.points, sample().points);
  // Ignored, but named: the run's warnings say so, with the option a misspelt one meant.
  EXPECT_EQ(loaded.unknownFields, (std::vector<std::string>{"comment", "options.futureOption"}));
  j["options"]["atlasSise"] = 4096;
  j["photos"][0]["colourLocked"] = true;
  writeText(path("p.json"), j.dump());
  const Project misspelt = loadProject(path("p.json"));
  EXPECT_EQ(misspelt.options.atlasSize, 2048);
  EXPECT_EQ(misspelt.unknownFields,
            (std::vector<std::string>{"comment", "photos[0].colourLocked (did you mean \"colorLocked\"?)",
                                      "options.atlasSise (did you mean \"atlasSize\"?)", "options.futureOption"}));
  const std::vector<std::string> warnings = projectWarnings(misspelt, {});
  const auto named = std::count_if(warnings.begin(), warnings.end(), [](const std::string& w) {
    return w.find("options.atlasSise (did you mean \"atlasSize\"?): not a field this build knows") != std::string::npos;
  });
  EXPECT_EQ(named, 1) << ::testing::PrintToString(warnings);
  EXPECT_TRUE(misspelt.sameDocument(loaded));  // not part of the document
}

// ---- Atomic save ----

TEST_F(ProjectTest, AtomicSaveLeavesNoTemporaryFiles) {
  Project p = sample();
  const auto before = listDir(dir);
  saveProject(p, path("p.json"));
  saveProject(p, path("p.json"));  // over an existing file
  auto expected = before;
  expected.push_back("p.json");
  std::sort(expected.begin(), expected.end());
  EXPECT_EQ(listDir(dir), expected);

  writeFileAtomic(path("notes.txt"), "hello");
  EXPECT_EQ(readFile(path("notes.txt")), "hello");
  writeFileAtomic(path("notes.txt"), "");
  EXPECT_EQ(readFile(path("notes.txt")), "");
  EXPECT_EQ(listDir(dir).size(), expected.size() + 1);
}

TEST_F(ProjectTest, FailedSaveKeepsTheEarlierFile) {
  Project p = sample();
  saveProject(p, path("p.json"));
  const std::string good = readFile(path("p.json"));
  const auto files = listDir(dir);

  // Serialisation fails: NaN cannot be written as JSON.
  Project bad = sample();
  bad.points[1].at[0].x = std::nan("");
  std::string message = errorOf([&] { saveProject(bad, path("p.json")); });
  EXPECT_MESSAGE_HAS(message, path("p.json") + ": points[1].at[0].x");
  EXPECT_MESSAGE_HAS(message, "not a finite number");
  EXPECT_EQ(bad.file, "");  // not saved
  EXPECT_EQ(readFile(path("p.json")), good);

  // Writing fails half way (a file size limit, like a full disk).
  struct sigaction ignore {
  }, previous{};
  ignore.sa_handler = SIG_IGN;
  sigaction(SIGXFSZ, &ignore, &previous);
  rlimit limit{}, saved{};
  getrlimit(RLIMIT_FSIZE, &saved);
  limit = saved;
  limit.rlim_cur = 64;
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &limit), 0);
  message = errorOf([&] { writeFileAtomic(path("p.json"), std::string(1000, 'x')); });
  setrlimit(RLIMIT_FSIZE, &saved);
  sigaction(SIGXFSZ, &previous, nullptr);
  EXPECT_MESSAGE_HAS(message, path("p.json"));
  EXPECT_MESSAGE_HAS(message, "cannot write");
  EXPECT_MESSAGE_HAS(message, std::strerror(EFBIG));
  EXPECT_EQ(readFile(path("p.json")), good);
  EXPECT_EQ(listDir(dir), files);  // the temporary file is gone

  // The target cannot be replaced (a folder of that name).
  fs::create_directories(path("taken.json/inner"));
  message = errorOf([&] { writeFileAtomic(path("taken.json"), "x"); });
  EXPECT_MESSAGE_HAS(message, path("taken.json"));
  EXPECT_MESSAGE_HAS(message, "cannot replace");
  EXPECT_EQ(listDir(dir).size(), files.size() + 1);

  // The folder does not exist.
  message = errorOf([&] { writeFileAtomic(path("missing/p.json"), "x"); });
  EXPECT_MESSAGE_HAS(message, path("missing/p.json"));
  EXPECT_MESSAGE_HAS(message, std::strerror(ENOENT));
}

TEST_F(ProjectTest, SaveIntoReadOnlyFolderKeepsTheEarlierFile) {
  Project p = sample();
  fs::create_directories(path("locked"));
  saveProject(p, path("locked/p.json"));
  const std::string good = readFile(path("locked/p.json"));
  chmod(path("locked").c_str(), 0555);
  if (access(path("locked").c_str(), W_OK) == 0) {  // root ignores permissions
    chmod(path("locked").c_str(), 0755);
    GTEST_SKIP()
        << "running with permission to write into read-only folders (root); covered by FailedSaveKeepsTheEarlierFile";
  }
  p.options.gutter = 20;
  const std::string message = errorOf([&] { saveProject(p, path("locked/p.json")); });
  chmod(path("locked").c_str(), 0755);
  EXPECT_MESSAGE_HAS(message, path("locked/p.json"));
  EXPECT_MESSAGE_HAS(message, std::strerror(EACCES));
  EXPECT_EQ(readFile(path("locked/p.json")), good);
  EXPECT_EQ(listDir(path("locked")), std::vector<std::string>{"p.json"});
}

// ---- Rejections by loadProject ----

TEST_F(ProjectTest, RejectsUnknownVersion) {
  json j = sampleJson();
  j["version"] = Project::kVersion + 1;
  const std::string message = loadError(j);
  EXPECT_MESSAGE_HAS(message, "version: 7 is not supported");
  EXPECT_MESSAGE_HAS(message, "reads versions 1 to 6");
  EXPECT_MESSAGE_HAS(message, "written by a newer TextureMontage");
  j["version"] = 0;
  EXPECT_MESSAGE_HAS(loadError(j), "version: 0 is not supported");
  j["version"] = "1";
  EXPECT_MESSAGE_HAS(loadError(j), "version: must be an integer, not the string \"1\"");
  j.erase("version");
  EXPECT_MESSAGE_HAS(loadError(j), "version: missing");
}

TEST_F(ProjectTest, RejectsOtherDocuments) {
  json j = sampleJson();
  j["format"] = "something-else";
  EXPECT_MESSAGE_HAS(loadError(j), "format: 'something-else' is not a TextureMontage project");
  EXPECT_MESSAGE_HAS(loadError(json::array({1, 2})), "top level: must be an object, not an array");
  EXPECT_MESSAGE_HAS(loadError(json{{"mesh", "mesh.obj"}}), "format: missing");
  const std::string missing = path("absent.json");
  const std::string message = errorOf([&] { loadProject(missing); });
  EXPECT_MESSAGE_HAS(message, missing);
  EXPECT_MESSAGE_HAS(message, "not found");
}

TEST_F(ProjectTest, RejectsMissingFiles) {
  json j = sampleJson();
  j["mesh"] = "meshes/gone.obj";
  std::string message = loadError(j);
  EXPECT_MESSAGE_HAS(message, "mesh: file 'meshes/gone.obj' not found");
  EXPECT_MESSAGE_HAS(message, path("meshes/gone.obj"));  // resolved

  j = sampleJson();
  j["photos"][1]["path"] = "photos/c.png";
  message = loadError(j);
  EXPECT_MESSAGE_HAS(message, "photos[1].path: file 'photos/c.png' not found");
  EXPECT_MESSAGE_HAS(message, path("photos/c.png"));

  j = sampleJson();
  j["photos"][0]["mask"] = "photos/nomask.png";
  EXPECT_MESSAGE_HAS(loadError(j), "photos[0].mask: file 'photos/nomask.png' not found");

  j = sampleJson();
  j["mesh"] = "photos";
  EXPECT_MESSAGE_HAS(loadError(j), "mesh: file 'photos' is a folder, not a file");
  j["mesh"] = "";
  EXPECT_MESSAGE_HAS(loadError(j), "mesh: must not be empty");
  j.erase("mesh");
  EXPECT_MESSAGE_HAS(loadError(j), "mesh: missing (required)");
}

TEST_F(ProjectTest, BadJsonNamesLineAndColumn) {
  writeText(path("p.json"), "{\n  \"format\": \"texturemontage-project\",\n  \"version\": 1,,\n}\n");
  std::string message = errorOf([&] { loadProject(path("p.json")); });
  EXPECT_MESSAGE_HAS(message, path("p.json") + ": line 3, column 16: invalid JSON");
  writeText(path("p.json"), "");
  message = errorOf([&] { loadProject(path("p.json")); });
  EXPECT_MESSAGE_HAS(message, "line 1, column 1: invalid JSON");
  writeText(path("p.json"), "{\"format\": \"texturemontage-project\",\n\"version\": 1\n");  // unterminated
  message = errorOf([&] { loadProject(path("p.json")); });
  EXPECT_MESSAGE_HAS(message, "line 3, column 1: invalid JSON");
}

// ---- Hostile files (issue 15) ----

TEST_F(ProjectTest, NumberOverflowIsNamedWithLineAndColumn) {
  // Was "[json.exception.out_of_range.406] number overflow parsing '1e400'" with no file, line or field.
  writeText(path("p.json"), "{\n  \"format\": \"texturemontage-project\",\n  \"version\": 1e400\n}\n");
  const std::string message = errorOf([&] { loadProject(path("p.json")); });
  EXPECT_MESSAGE_HAS(message, path("p.json") + ": line 3, column 18: invalid JSON: number overflow parsing '1e400'");
  EXPECT_EQ(message.find("json.exception"), std::string::npos) << message;
}

TEST_F(ProjectTest, DeepNestingIsRefused) {
  writeText(path("p.json"), std::string(200000, '[') + std::string(200000, ']'));
  EXPECT_MESSAGE_HAS(errorOf([&] { loadProject(path("p.json")); }), "invalid JSON: values nested more than 64 deep");
}

TEST_F(ProjectTest, OversizedFileIsRefusedWithItsSize) {
  // A 200 MB project once took 4.5 GB to read. The size is checked before anything is read (this file is
  // sparse: it costs no disk).
  writeText(path("p.json"), projectToJson(sample(), path("p.json")));
  fs::resize_file(path("p.json"), 200000000);
  const std::string message = errorOf([&] { loadProject(path("p.json")); });
  EXPECT_MESSAGE_HAS(message, path("p.json") + ": project file is 200 MB; at most 67.1 MB are read");
}

TEST_F(ProjectTest, LongStringsAndControlCharactersInMessages) {
  json j = sampleJson();
  j["version"] = std::string(100000, 'v') + "\x1b[2J";
  std::string message = loadError(j);
  EXPECT_LT(message.size(), 400u) << message;
  j = sampleJson();
  j["format"] = "evil\x1b]0;title\x07";
  message = loadError(j);
  EXPECT_EQ(message.find('\x1b'), std::string::npos) << message;
  EXPECT_EQ(message.find('\x07'), std::string::npos) << message;
  EXPECT_MESSAGE_HAS(message, "'evil\\x1b]0;title\\x07' is not a TextureMontage project");
}

TEST_F(ProjectTest, SymlinkLoopIsNamed) {
  fs::create_symlink("loop_b.obj", path("loop_a.obj"));
  fs::create_symlink("loop_a.obj", path("loop_b.obj"));
  json j = sampleJson();
  j["mesh"] = "loop_a.obj";
  EXPECT_MESSAGE_HAS(loadError(j), "mesh: file 'loop_a.obj' cannot be opened: symbolic link loop");
  fs::create_symlink("p_loop2.json", path("p_loop1.json"));
  fs::create_symlink("p_loop1.json", path("p_loop2.json"));
  EXPECT_MESSAGE_HAS(errorOf([&] { loadProject(path("p_loop1.json")); }), "symbolic link loop");
}

TEST_F(ProjectTest, RejectsWrongTypes) {
  json j = sampleJson();
  j["points"][0]["vertex"] = "12";
  EXPECT_MESSAGE_HAS(loadError(j), "points[0].vertex: must be an integer, not the string \"12\"");
  j = sampleJson();
  j["points"][2]["vertex"] = 7.5;
  EXPECT_MESSAGE_HAS(loadError(j), "points[2].vertex: must be an integer, not 7.5");
  j = sampleJson();
  j["points"][0]["at"][1]["x"] = nullptr;
  EXPECT_MESSAGE_HAS(loadError(j), "points[0].at[1].x: must be a finite number, not null");
  j = sampleJson();
  j["points"][0]["at"][1].erase("photo");
  EXPECT_MESSAGE_HAS(loadError(j), "points[0].at[1].photo: missing (required)");
  j = sampleJson();
  j["points"] = json::object();
  EXPECT_MESSAGE_HAS(loadError(j), "points: must be an array, not an object");
  j = sampleJson();
  j["chains"][0]["closed"] = 1;
  EXPECT_MESSAGE_HAS(loadError(j), "chains[0].closed: must be true or false, not 1");
  j = sampleJson();
  j["clones"][0]["polygon"][2] = json::array({1, 2, 3});
  EXPECT_MESSAGE_HAS(loadError(j), "clones[0].polygon[2]: must be [x, y]");
  j = sampleJson();
  j["strokes"][1]["vertices"][0] = 1e12;
  EXPECT_MESSAGE_HAS(loadError(j), "strokes[1].vertices[0]: must be an integer");
  j = sampleJson();
  j["strokes"][1]["vertices"][0] = 5000000000LL;
  EXPECT_MESSAGE_HAS(loadError(j), "strokes[1].vertices[0]: 5000000000 is out of range");
  j = sampleJson();
  j["options"]["inpaintMode"] = "magic";
  EXPECT_MESSAGE_HAS(loadError(j),
                     "options.inpaintMode: 'magic' is not an inpainting mode (one of 'harmonic', 'rbf', 'strokes', "
                     "'off', 'synthesis', 'structure', 'texture')");
  j = sampleJson();
  j["options"]["seed"] = -1;
  EXPECT_MESSAGE_HAS(loadError(j), "options.seed: -1 is out of range 0..4294967295");
}

TEST_F(ProjectTest, RejectsOptionsOutOfRange) {
  json j = sampleJson();
  j["options"]["atlasSize"] = 100;
  EXPECT_MESSAGE_HAS(loadError(j), "options.atlasSize: 100 is neither 0 (automatic) nor in 256..8192");
  j = sampleJson();
  j["options"]["gutter"] = 65;
  EXPECT_MESSAGE_HAS(loadError(j), "options.gutter: 65 is out of range 0..64");
  j = sampleJson();
  j["options"]["seamLambda"] = 1.5;
  EXPECT_MESSAGE_HAS(loadError(j), "options.seamLambda: 1.5 is out of range 0..1");
  j = sampleJson();
  j["options"]["backgroundThresholdPx"] = -0.5;
  EXPECT_MESSAGE_HAS(loadError(j), "options.backgroundThresholdPx: -0.5 is out of range");
}

TEST_F(ProjectTest, RejectsIndicesOutOfRange) {
  json j = sampleJson();
  j["points"][1]["at"][0]["photo"] = 2;
  EXPECT_MESSAGE_HAS(loadError(j), "points[1].at[0].photo: 2 is out of range: the project has 2 photos (0..1)");
  j = sampleJson();
  j["chains"][1]["points"][1] = 3;
  EXPECT_MESSAGE_HAS(loadError(j), "chains[1].points[1]: 3 is out of range: the project has 3 points (0..2)");
  j = sampleJson();
  j["chains"][0]["points"][0] = -1;
  EXPECT_MESSAGE_HAS(loadError(j), "chains[0].points[0]: -1 must be >= 0");
  j = sampleJson();
  j["chains"][0]["photo"] = 5;
  EXPECT_MESSAGE_HAS(loadError(j), "chains[0].photo: 5 is out of range");
  j = sampleJson();
  j["points"][1]["vertex"] = -3;
  EXPECT_MESSAGE_HAS(loadError(j), "points[1].vertex: -3 must be >= 0");
  j = sampleJson();
  j["clones"][0]["photo"] = 9;
  EXPECT_MESSAGE_HAS(loadError(j), "clones[0].photo: 9 is out of range");
}

TEST_F(ProjectTest, RejectsChainPointWithoutPositionInTheChainPhoto) {
  json j = sampleJson();
  j["chains"][1]["points"] = json::array({2, 1});  // point 1 (vertex 5) is only in photo 0
  EXPECT_MESSAGE_HAS(loadError(j),
                     "chains[1].points[1]: point 1 (vertex 5) has no position in the chain's photo 1 'b.png'");
}

TEST_F(ProjectTest, RejectsTheSameVertexTwiceInOnePhoto) {
  json j = sampleJson();
  j["points"][1]["vertex"] = 12;  // points[0] is vertex 12 too, and both are in photo 0
  std::string message = loadError(j);
  EXPECT_MESSAGE_HAS(message, "points[1].at[0].photo: vertex 12 is given two points in photo 0 'a.png'");
  EXPECT_MESSAGE_HAS(message, "points[0].at[0] and points[1].at[0]");

  j = sampleJson();
  j["points"][0]["at"][1]["photo"] = 0;  // one point listing photo 0 twice
  message = loadError(j);
  EXPECT_MESSAGE_HAS(message, "points[0].at[1].photo: vertex 12 is given two points in photo 0");

  // The same vertex in two different photos is fine, also as two points.
  j = sampleJson();
  j["points"].push_back({{"vertex", 5}, {"at", {{{"photo", 1}, {"x", 1.5}, {"y", 2.5}}}}});
  writeText(path("p.json"), j.dump());
  EXPECT_NO_THROW(loadProject(path("p.json")));
}

// ---- Rejections by validateProject (needs the mesh and photo sizes) ----

TEST_F(ProjectTest, ValidateRejectsVertexIdsOutOfRange) {
  Project p = sample();
  p.file = path("p.json");
  p.points[1].vertex = 20;
  std::string message = validateError(p);
  EXPECT_MESSAGE_HAS(message,
                     path("p.json") + ": points[1].vertex: 20 is out of range: the mesh has 20 vertices (0..19)");
  p = sample();
  p.strokes[1].vertices[1] = 25;
  EXPECT_MESSAGE_HAS(validateError(p), "project: strokes[1].vertices[1]: 25 is out of range: the mesh has 20 vertices");
  p = sample();
  p.clones[0].anchorVertex = 20;
  EXPECT_MESSAGE_HAS(validateError(p), "clones[0].anchorVertex: 20 is out of range");
  p = sample();
  p.clones[0].targetFaces[2] = 10;
  EXPECT_MESSAGE_HAS(validateError(p), "clones[0].targetFaces[2]: 10 is out of range: the mesh has 10 faces (0..9)");
}

TEST_F(ProjectTest, ValidateRejectsPointsOutsideTheirPhoto) {
  Project p = sample();
  p.points[2].at[1].x = 50.5;  // photo 1 is 50 wide
  EXPECT_MESSAGE_HAS(validateError(p), "points[2].at[1].x: 50.5 is outside photo 1 'b.png' (width 50)");
  p = sample();
  p.points[0].at[0].y = -0.25;
  EXPECT_MESSAGE_HAS(validateError(p), "points[0].at[0].y: -0.25 is outside photo 0 'a.png' (height 80)");
  p = sample();
  p.clones[0].polygon[1] = Vec2(60, 2);
  EXPECT_MESSAGE_HAS(validateError(p), "clones[0].polygon[1].x: 60 is outside photo 1 'b.png' (width 50)");
  // The border itself is inside.
  p = sample();
  p.points[0].at[0] = {0, 100, 80};
  EXPECT_NO_THROW(validateProject(p, 20, 10, {{100, 80}, {50, 40}}));
}

TEST_F(ProjectTest, ValidateRejectsDegenerateShapes) {
  Project p = sample();
  p.clones[0].polygon = {Vec2(1, 1), Vec2(2, 2), Vec2(3, 3)};
  EXPECT_MESSAGE_HAS(validateError(p), "clones[0].polygon: has zero area");
  p.clones[0].polygon.pop_back();
  EXPECT_MESSAGE_HAS(validateError(p), "clones[0].polygon: needs at least 3 points, not 2");
  p = sample();
  p.clones[0].targetFaces.clear();
  EXPECT_MESSAGE_HAS(validateError(p), "clones[0].targetFaces: must name at least one face");
  p = sample();
  p.chains[0].points = {0, 1};
  EXPECT_MESSAGE_HAS(validateError(p), "chains[0].points: a closed chain (polygon) needs at least 3 points, not 2");
  p = sample();
  p.strokes[0].vertices = {4};
  EXPECT_MESSAGE_HAS(validateError(p), "strokes[0].vertices: a stroke needs at least 2 vertices, not 1");
}

TEST_F(ProjectTest, ValidateRechecksEditsInMemory) {
  Project p = sample();
  p.points[2].vertex = 5;  // points[1] is vertex 5 in photo 0 too
  EXPECT_MESSAGE_HAS(validateError(p), "vertex 5 is given two points in photo 0");
  p = sample();
  p.chains[1].points.push_back(1);
  EXPECT_MESSAGE_HAS(validateError(p),
                     "chains[1].points[2]: point 1 (vertex 5) has no position in the chain's photo 1");
  p = sample();
  p.options.atlasSize = 9000;
  EXPECT_MESSAGE_HAS(validateError(p), "options.atlasSize: 9000 is out of range 0..8192");
  p = sample();
  EXPECT_MESSAGE_HAS(errorOf([&] { validateProject(p, 20, 10, {{100, 80}}); }), "1 photo sizes given for 2 photos");
}

// The example in docs/project-format.md loads, is valid, and is exactly what saving it writes.
TEST_F(ProjectTest, DocumentedExampleIsWhatSaveWrites) {
  const std::string doc = readFile((fs::path(test::assetsDir()) / ".." / "docs" / "project-format.md").string());
  ASSERT_FALSE(doc.empty()) << "docs/project-format.md is missing";
  const size_t begin = doc.find("```json\n{\n  \"format\"");
  ASSERT_NE(begin, std::string::npos) << "no example in docs/project-format.md";
  const size_t start = doc.find('\n', begin) + 1;
  const std::string example = doc.substr(start, doc.find("```", start) - start);

  fs::create_directories(path("meshes"));
  writeText(path("meshes/cat.obj"), "v 0 0 0\n");
  for (const char* photo : {"photos/front.png", "photos/front_mask.png", "photos/side.jpg"}) writeText(path(photo), "");
  writeText(path("example.json"), example);
  Project project = loadProject(path("example.json"));
  EXPECT_EQ(project.photos[0].mask, path("photos/front_mask.png"));
  EXPECT_TRUE(project.chains[0].closed);
  EXPECT_TRUE(project.photos[0].colorLocked);
  EXPECT_TRUE(project.photos[1].mirror);
  validateProject(project, 2000, 1000, {{1024, 768}, {640, 480}});
  saveProject(project, path("example.json"));
  EXPECT_EQ(readFile(path("example.json")), example);
}

// ---- Version 3: mirrored and colour-locked photos, colour balance ----

TEST_F(ProjectTest, WritesTheLowestVersionThatHoldsTheDocument) {
  Project p = sample();
  for (PhotoRef& ref : p.photos) ref.mirror = ref.colorLocked = false;
  p.options.colorBalance = BalanceMode::Off;
  EXPECT_EQ(requiredVersion(p), 2);  // declined proposals: version 2
  EXPECT_EQ(json::parse(projectToJson(p, ""))["version"], 2);
  Project plain = p;
  plain.declinedProposals.clear();
  EXPECT_EQ(requiredVersion(plain), 1);  // an older build reads it and behaves the same
  EXPECT_EQ(json::parse(projectToJson(plain, ""))["version"], 1);
  Project mirrored = plain;
  mirrored.photos[1].mirror = true;
  EXPECT_EQ(requiredVersion(mirrored), 3);  // an older build would ignore the mirror: it must refuse the file
  Project locked = p;
  locked.photos[0].colorLocked = true;
  EXPECT_EQ(requiredVersion(locked), 3);
  Project balanced = plain;
  balanced.options.colorBalance = BalanceMode::Gain;
  EXPECT_EQ(requiredVersion(balanced), 3);
  for (const Project* q : {&p, &plain, &mirrored, &locked, &balanced}) {
    Project copy = *q;
    saveProject(copy, path("v.json"));
    EXPECT_TRUE(loadProject(path("v.json")).sameDocument(*q));
  }
}

TEST_F(ProjectTest, AbsentColourBalanceDependsOnTheVersion) {
  json j = sampleJson();
  j["options"].erase("colorBalance");
  j["version"] = 1;
  writeText(path("p.json"), j.dump());
  EXPECT_EQ(loadProject(path("p.json")).options.colorBalance, BalanceMode::Off);  // as version 1 behaved
  j["version"] = 2;
  writeText(path("p.json"), j.dump());
  EXPECT_EQ(loadProject(path("p.json")).options.colorBalance, BalanceMode::Off);  // and version 2
  j["version"] = 3;
  writeText(path("p.json"), j.dump());
  EXPECT_EQ(loadProject(path("p.json")).options.colorBalance, PipelineOptions().colorBalance);
  j["options"]["colorBalance"] = "gain";
  j["version"] = 1;  // a version-1 file that names it (written by this build with balance off) keeps it
  writeText(path("p.json"), j.dump());
  EXPECT_EQ(loadProject(path("p.json")).options.colorBalance, BalanceMode::Gain);
  j["options"]["colorBalance"] = "curves";
  EXPECT_MESSAGE_HAS(loadError(j), "options.colorBalance: 'curves' is not a colour balance mode");
  j["options"]["colorBalance"] = "gain";
  j["photos"][0]["mirror"] = "yes";
  EXPECT_MESSAGE_HAS(loadError(j), "photos[0].mirror: must be true or false, not the string \"yes\"");
  j["photos"][0]["mirror"] = false;
  j["photos"][1]["colorLocked"] = 1;
  EXPECT_MESSAGE_HAS(loadError(j), "photos[1].colorLocked: must be true or false, not 1");
}

TEST_F(ProjectTest, MissingFilesAreListedWhenAllowed) {
  Project p = sample();
  saveProject(p, path("p.json"));
  fs::rename(path("photos/b.png"), path("photos/b_moved.png"));
  fs::remove(path("photos/a_mask.png"));
  // The strict loader names the first missing file...
  const std::string message = errorOf([&] { loadProject(path("p.json")); });
  EXPECT_MESSAGE_HAS(message, "photos[0].mask: file 'photos/a_mask.png' not found");
  // ...the lenient one opens the project and lists them all.
  std::vector<MissingFile> missing;
  const Project opened = loadProjectAllowingMissing(path("p.json"), missing);
  EXPECT_TRUE(opened.sameDocument(p));
  ASSERT_EQ(missing.size(), 2u);
  EXPECT_EQ(missing[0].field, "photos[0].mask");
  EXPECT_EQ(missing[0].path, path("photos/a_mask.png"));
  EXPECT_EQ(missing[1].field, "photos[1].path");
  EXPECT_EQ(missing[1].path, path("photos/b.png"));
  // Every other check still applies.
  json j = json::parse(readFile(path("p.json")));
  j["points"][0]["vertex"] = "12";
  writeText(path("p.json"), j.dump());
  EXPECT_MESSAGE_HAS(errorOf([&] { loadProjectAllowingMissing(path("p.json"), missing); }), "points[0].vertex");
  fs::remove(path("mesh.obj"));
  j["points"][0]["vertex"] = 12;
  writeText(path("p.json"), j.dump());
  loadProjectAllowingMissing(path("p.json"), missing);
  ASSERT_EQ(missing.size(), 3u);
  EXPECT_EQ(missing[0].field, "mesh");
}

TEST_F(ProjectTest, WithoutPhotoReferencesKeepsIndices) {
  const Project p = sample();
  const Project q = withoutPhotoReferences(p, {1});
  EXPECT_EQ(q.photos, p.photos);                // entries stay
  ASSERT_EQ(q.points.size(), p.points.size());  // point indices stay
  EXPECT_EQ(q.points[0].at, (std::vector<PhotoPoint>{{0, 10.25, 20.5}}));
  EXPECT_EQ(q.points[2].at, (std::vector<PhotoPoint>{{0, 100, 0}}));
  ASSERT_EQ(q.chains.size(), 1u);  // the chain drawn in photo 1 goes
  EXPECT_EQ(q.chains[0].photo, 0);
  EXPECT_TRUE(q.clones.empty());  // the clone from photo 1 goes
  validateProject(q, 20, 10, {{100, 80}, {50, 40}});
  const Project none = withoutPhotoReferences(p, {0, 1});
  for (const FeaturePoint& pt : none.points) EXPECT_TRUE(pt.at.empty());
  EXPECT_TRUE(none.chains.empty());
}

// `montage run --set KEY=VALUE` (docs/command-line.md): read and checked as the file's options are.
TEST(ProjectOptions, SetFromTheCommandLine) {
  PipelineOptions o;
  setProjectOption(o, "atlasSize", "2048", "--set atlasSize=2048");
  setProjectOption(o, "inpaintMode", "synthesis", "--set inpaintMode=synthesis");  // a bare word: a name
  setProjectOption(o, "weldIdenticalPositions", "false", "--set weldIdenticalPositions=false");
  setProjectOption(o, "seamLambda", "0.25", "--set seamLambda=0.25");
  setProjectOption(o, "sharedIntrinsics", "false", "--set sharedIntrinsics=false");
  EXPECT_FALSE(o.sharedIntrinsics);
  setProjectOption(o, "photometric", "false", "--set photometric=false");
  EXPECT_FALSE(o.photometric);
  setProjectOption(o, "foundSilhouettes", "false", "--set foundSilhouettes=false");
  EXPECT_FALSE(o.foundSilhouettes);
  EXPECT_EQ(o.atlasSize, 2048);
  EXPECT_EQ(o.inpaintMode, InpaintMode::Synthesis);
  EXPECT_FALSE(o.weldIdenticalPositions);
  EXPECT_EQ(o.seamLambda, 0.25);
  const PipelineOptions before = o;
  const auto message = [&](const std::string& key, const std::string& value) {
    return test::errorOf([&] { setProjectOption(o, key, value, "--set " + key + "=" + value); });
  };
  EXPECT_NE(message("atlasSise", "1024").find("--set atlasSise=1024: options.atlasSise (did you mean \"atlasSize\"?)"),
            std::string::npos);
  EXPECT_NE(message("gutter", "99").find("options.gutter: 99 is out of range"), std::string::npos);
  EXPECT_NE(message("gutter", "two").find("options.gutter: must be"), std::string::npos);
  EXPECT_NE(message("inpaintMode", "paint").find("'paint' is not an inpainting mode"), std::string::npos);
  EXPECT_NE(message("atlasSize", "100").find("options.atlasSize"), std::string::npos);
  EXPECT_TRUE(o == before) << "a refused value leaves the options as they were";
  EXPECT_EQ(projectOptionNames().size(), 25u);
}

// Issue 35, finding 9: a deletion renumbered the points after it. Ids survive erasePoint, are written (version 5)
// only where they are not the index, read back exactly; a version 4 file has no ids (each point's is its
// index), an id two points share is refused, and the editor's camera goes with the file in any version.
TEST_F(ProjectTest, PointIdsSurviveDeletionsAndTheViewRoundTrips) {
  Project p = sample();
  p.points.push_back({9, {{1, 3, 4}}});
  erasePoint(p, 1);  // the chains' indices are the caller's (the editor's Document)
  p.chains = {{0, {0, 1}, false}};
  ASSERT_EQ(p.points.size(), 3u);
  EXPECT_EQ(pointId(p, 0), 0);
  EXPECT_EQ(pointId(p, 1), 2);
  EXPECT_EQ(pointId(p, 2), 3);
  EXPECT_EQ(pointIndex(p, 3), 2);
  EXPECT_EQ(pointIndex(p, 1), -1);
  EXPECT_EQ(nextPointId(p), 4);
  EXPECT_EQ(requiredVersion(p), 5);
  p.view = {true, Vec3(0.1, 1.0 / 3, -2), 12.25, 47.5, -10.125, 0.5};
  saveProject(p, path("ids.json"));
  const json j = json::parse(readFile(path("ids.json")));
  EXPECT_EQ(j["version"], 5);
  EXPECT_FALSE(j["points"][0].contains("id"));
  EXPECT_EQ(j["points"][1]["id"], 2);
  EXPECT_EQ(j["view"]["target"][1], 1.0 / 3);
  EXPECT_EQ(j["view"]["fov"], 0.5);
  const Project back = loadProject(path("ids.json"));
  EXPECT_TRUE(back.sameDocument(p));
  EXPECT_EQ(pointId(back, 1), 2);
  EXPECT_TRUE(back.view == p.view);
  EXPECT_TRUE(back.unknownFields.empty());
  // Deleting the first point keeps every id; deleting up to the end gives ids back their index (no "id").
  Project q = back;
  erasePoint(q, 0);
  EXPECT_EQ(pointId(q, 0), 2);
  EXPECT_EQ(pointId(q, 1), 3);
  q = back;
  erasePoint(q, 2);
  erasePoint(q, 1);
  EXPECT_EQ(q.points[0].id, -1);
  EXPECT_EQ(requiredVersion(q), 3);
  // An older file: no ids (an "id" there is not read), its view read all the same.
  json old = j;
  old["version"] = 4;
  writeText(path("old.json"), old.dump(2));
  const Project four = loadProject(path("old.json"));
  EXPECT_EQ(pointId(four, 1), 1);
  EXPECT_TRUE(four.view.present);
  // Two points with one id.
  json twice = j;
  twice["points"][2]["id"] = 2;
  EXPECT_MESSAGE_HAS(loadError(twice), "points[2].id: 2 is the id of points[1] too");
  twice["points"][2]["id"] = -1;
  EXPECT_MESSAGE_HAS(loadError(twice), "points[2].id: -1 is out of range");
  json badView = j;
  badView["view"]["distance"] = 0;
  EXPECT_MESSAGE_HAS(loadError(badView), "view.distance: 0 is not above 0");
  badView["view"]["target"] = json::array({1, 2});
  EXPECT_MESSAGE_HAS(loadError(badView), "view.target: must be [x, y, z]");
}

// A hole's exemplar (a photo region its texture comes from; version 6): saved and read back, checked like a
// clone's polygon, texture mode only, and dropped with a photo that is left out of a run.
TEST_F(ProjectTest, AHolesPickedPhotoRegionRoundTripsAndIsChecked) {
  Project p = sample();
  p.holeModes = {{3, InpaintMode::Texture, HoleExemplar{1, {Vec2(2, 3), Vec2(40, 3), Vec2(40, 30)}}},
                 {4, InpaintMode::Harmonic, std::nullopt}};
  EXPECT_EQ(requiredVersion(p), 6);  // an older build would ignore the region: it must refuse the file
  saveProject(p, path("e.json"));
  const json written = json::parse(readFile(path("e.json")));
  EXPECT_EQ(written["version"], 6);
  EXPECT_EQ(written["holeModes"][0]["exemplar"]["photo"], 1);
  EXPECT_EQ(written["holeModes"][0]["exemplar"]["polygon"].size(), 3u);
  EXPECT_FALSE(written["holeModes"][1].contains("exemplar"));
  const Project loaded = loadProject(path("e.json"));
  EXPECT_TRUE(loaded.sameDocument(p));
  ASSERT_TRUE(loaded.holeModes[0].exemplar);
  EXPECT_EQ(loaded.holeModes[0].exemplar->polygon[1], Vec2(40, 3));
  validateProject(loaded, 20, 10, {{100, 80}, {50, 40}});
  Project other = loaded;
  other.holeModes[0].exemplar->polygon[0].x() = 3;
  EXPECT_FALSE(other.sameDocument(loaded));

  Project bad = p;
  bad.holeModes[0].mode = InpaintMode::Rbf;
  EXPECT_MESSAGE_HAS(validateError(bad), "holeModes[0].exemplar: only mode \"texture\" takes its texture from a photo "
                                         "region; this hole's mode is \"rbf\"");
  bad = p;
  bad.holeModes[0].exemplar->photo = 2;
  EXPECT_MESSAGE_HAS(validateError(bad), "holeModes[0].exemplar.photo: 2 is out of range");
  bad = p;
  bad.holeModes[0].exemplar->polygon[2] = Vec2(60, 30);  // photo 1 is 50 x 40
  EXPECT_MESSAGE_HAS(validateError(bad), "holeModes[0].exemplar.polygon[2].x: 60 is outside");
  bad = p;
  bad.holeModes[0].exemplar->polygon.pop_back();
  EXPECT_MESSAGE_HAS(validateError(bad), "holeModes[0].exemplar.polygon: needs at least 3 points, not 2");
  bad = p;
  bad.holeModes[0].exemplar->polygon[2] = Vec2(21, 3);
  EXPECT_MESSAGE_HAS(validateError(bad), "holeModes[0].exemplar.polygon: has zero area");
  json broken = json::parse(projectToJson(p, path("p.json")));
  broken["holeModes"][0]["exemplar"]["polygon"] = "all of it";
  EXPECT_MESSAGE_HAS(loadError(broken), "holeModes[0].exemplar.polygon");

  // A photo left out of a run takes the region with it; the hole keeps its mode.
  const Project without = withoutPhotoReferences(p, {1});
  EXPECT_EQ(without.holeModes[0].mode, InpaintMode::Texture);
  EXPECT_FALSE(without.holeModes[0].exemplar);
  EXPECT_TRUE(withoutPhotoReferences(p, {0}).holeModes[0].exemplar);
}
