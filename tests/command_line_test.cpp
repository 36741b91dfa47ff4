// The `montage` command line as scripts use it (docs/command-line.md): exit codes, --set, --strict,
// --threads, info --json, the unsupported-photo-format message, and byte-identical outputs whatever the
// folder, the file times or the thread count. Every test runs the real binary on the bundled demo.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "base/fileio.h"
#include "image/codec.h"
#include "image/photo.h"
#include "test_support.h"

namespace fs = std::filesystem;
using namespace montage;

namespace {

// The demo project copied into a fresh folder (its files named relative to it, as in assets/).
std::string copyDemo(const std::string& tag) {
  const std::string dir = test::tempDir(tag) + "/demo";
  fs::copy(test::assetsDir() + "/demo", dir, fs::copy_options::recursive);
  return dir;
}

// Runs `montage ARGS`; returns the exit code, output (stdout and stderr) in `out`.
int runMontage(const std::string& args, std::string* out = nullptr) {
  return test::runCommand(test::montageExe() + " " + args, out);
}

// The files of a run that must not change from run to run.
const char* const kOutputs[] = {"model.obj",       "model.mtl",             "model.glb",
                                "model_atlas.png", "model_atlas_holes.png", "model_atlas_source.png"};

std::string bytesOf(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  EXPECT_TRUE(in) << "missing " << path;
  return std::string(std::istreambuf_iterator<char>(in), {});
}

}  // namespace

TEST(CommandLine, UsageErrorsExitTwoHelpAndVersionZero) {
  std::string out;
  EXPECT_EQ(runMontage("", &out), 2) << out;
  EXPECT_EQ(runMontage("--no-such-option info x.obj", &out), 2) << out;
  EXPECT_NE(out.find("--no-such-option"), std::string::npos) << out;
  EXPECT_EQ(runMontage("run", &out), 2) << out;  // PROJECT and --out are required
  EXPECT_EQ(runMontage("--threads 0 info x.obj", &out), 2) << out;
  EXPECT_EQ(runMontage("--version", &out), 0) << out;
  EXPECT_NE(out.find("project format versions"), std::string::npos) << out;
  EXPECT_EQ(runMontage("run --help", &out), 0) << out;
  EXPECT_NE(out.find("--set"), std::string::npos) << out;
  // An error in the work (not the command line) is 1.
  EXPECT_EQ(runMontage("info /nonexistent/mesh.obj", &out), 1) << out;
}

TEST(CommandLine, SetIsCheckedLikeProjectOptions) {
  const std::string demo = copyDemo("cli_set");
  const std::string out = fs::path(demo).parent_path().string() + "/out";
  std::string text;
  // An unknown key: usage error naming it and the option it probably meant, before any work.
  EXPECT_EQ(runMontage("run " + demo + "/project.json --out " + out + " --set atlasSise=1024", &text), 2) << text;
  EXPECT_NE(text.find("options.atlasSise (did you mean \"atlasSize\"?)"), std::string::npos) << text;
  EXPECT_FALSE(fs::exists(out)) << "a usage error must stop before the output folder is made";
  // A value out of range, of the wrong type, an unknown enum name, no '='.
  EXPECT_EQ(runMontage("run " + demo + "/project.json --out " + out + " --set gutter=99", &text), 2) << text;
  EXPECT_NE(text.find("options.gutter: 99 is out of range"), std::string::npos) << text;
  EXPECT_EQ(runMontage("run " + demo + "/project.json --out " + out + " --set seamRounds=many", &text), 2) << text;
  EXPECT_NE(text.find("options.seamRounds"), std::string::npos) << text;
  EXPECT_EQ(runMontage("run " + demo + "/project.json --out " + out + " --set inpaintMode=paint", &text), 2) << text;
  EXPECT_NE(text.find("'paint' is not"), std::string::npos) << text;
  EXPECT_EQ(runMontage("run " + demo + "/project.json --out " + out + " --set atlasSize", &text), 2) << text;
  EXPECT_NE(text.find("expected KEY=VALUE"), std::string::npos) << text;
  // A good one takes effect: the atlas is 512 pixels a side (the demo's automatic size is larger).
  ASSERT_EQ(runMontage("run " + demo + "/project.json --out " + out + " --set atlasSize=512 --set inpaintMode=harmonic",
                    &text),
            0)
      << text;
  const cv::Size atlas = readImageSize(out + "/model_atlas.png");
  EXPECT_EQ(atlas, cv::Size(512, 512));
}

TEST(CommandLine, StrictMakesUnknownFieldsErrorsAndWarningsExitThree) {
  const std::string demo = copyDemo("cli_strict");
  const std::string root = fs::path(demo).parent_path().string();
  std::string text;
  // The demo has warnings (clicks on a photo's background, regions left empty): 0, or 3 under --strict,
  // with the outputs written either way.
  ASSERT_EQ(runMontage("run " + demo + "/project.json --out " + root + "/plain", &text), 0) << text;
  EXPECT_NE(text.find("warning:"), std::string::npos) << text;
  EXPECT_EQ(runMontage("--strict run " + demo + "/project.json --out " + root + "/strict", &text), 3) << text;
  EXPECT_NE(text.find("--strict: exit code 3"), std::string::npos) << text;
  EXPECT_TRUE(fs::exists(root + "/strict/model.glb"));
  // A misspelt option in the project: warned by name, an error under --strict (given after the command).
  nlohmann::json project = test::readJson(demo + "/project.json");
  project["options"]["atlasSise"] = 1024;
  std::ofstream(demo + "/project.json") << project.dump(1);
  EXPECT_EQ(runMontage("info " + demo + "/project.json", &text), 0) << text;
  EXPECT_NE(text.find("options.atlasSise (did you mean \"atlasSize\"?): not a field this build knows"),
            std::string::npos)
      << text;
  EXPECT_EQ(runMontage("run " + demo + "/project.json --out " + root + "/misspelt --strict", &text), 1) << text;
  EXPECT_NE(text.find("options.atlasSise"), std::string::npos) << text;
  EXPECT_NE(text.find("an error under --strict"), std::string::npos) << text;
}

TEST(CommandLine, InfoJson) {
  std::string text;
  // stdout alone (progress and messages go to stderr).
  const auto json = [&](const std::string& file) {
    return test::runCommand("{ " + test::montageExe() + " info --json " + file + " 2>/dev/null; }", &text);
  };
  ASSERT_EQ(json(test::assetsDir() + "/demo/project.json"), 0) << text;
  const nlohmann::json j = nlohmann::json::parse(text);
  EXPECT_EQ(j["kind"], "project");
  EXPECT_EQ(j["valid"], true);
  EXPECT_EQ(j["photos"].size(), 2u);
  EXPECT_EQ(j["photos"][0]["width"], 453);
  EXPECT_EQ(j["counts"]["points"], 216);
  EXPECT_EQ(j["counts"]["hole_modes"], 0);
  EXPECT_EQ(j["counts"]["hole_textures"], 0);
  EXPECT_EQ(j["mesh"]["vertices"], 7949);
  EXPECT_GT(j["warnings"].size(), 0u);  // the clicks on the background
  ASSERT_EQ(json(test::assetsDir() + "/demo/cat.obj"), 0) << text;
  EXPECT_EQ(nlohmann::json::parse(text)["kind"], "mesh");
  // A photo: its EXIF orientation, colour profile and camera (a PNG has none; a JPEG's EXIF names them).
  ASSERT_EQ(json(test::assetsDir() + "/demo/tiger_left.png"), 0) << text;
  const nlohmann::json png = nlohmann::json::parse(text);
  EXPECT_EQ(png["exif_orientation"], 1);
  EXPECT_EQ(png["icc_profile"], false);
  EXPECT_TRUE(png["camera"].is_null());
  cv::Mat bgr;
  cv::cvtColor(readImageFile(test::assetsDir() + "/demo/tiger_left.png"), bgr, cv::COLOR_BGRA2BGR);
  std::vector<unsigned char> jpeg;
  ASSERT_TRUE(cv::imencode(".jpg", bgr, jpeg));
  const std::vector<unsigned char> exif = test::exifPayload(
      false, {{271, 2, 5, {'A', 'c', 'm', 'e', 0}}, {272, 2, 3, {'X', '1', 0}}, {274, 3, 1, test::exif16(false, 6)}},
      {{41989, 3, 1, test::exif16(false, 35)}});
  const std::string photo = test::tempDir("cli_info_exif") + "/shot.jpg";
  const std::vector<unsigned char> bytes = test::withApp1(jpeg, exif);
  writeFileAtomic(photo, std::string(bytes.begin(), bytes.end()));
  ASSERT_EQ(json(photo), 0) << text;
  const nlohmann::json jpg = nlohmann::json::parse(text);
  EXPECT_EQ(jpg["exif_orientation"], 6);
  EXPECT_EQ(jpg["width"], bgr.rows);  // shown turned
  EXPECT_EQ(jpg["camera"]["make"], "Acme");
  EXPECT_EQ(jpg["camera"]["model"], "X1");
  EXPECT_EQ(jpg["camera"]["focal_35mm"], 35.0);
  EXPECT_NEAR(jpg["camera"]["focal_px"].get<double>(), 35 * std::hypot(bgr.cols, bgr.rows) / std::hypot(36, 24), 1e-6);
  ASSERT_EQ(test::runCommand(test::montageExe() + " info " + photo + " 2>&1", &text), 0) << text;
  EXPECT_NE(text.find("camera: Acme X1, 35 mm on 35 mm film, focal length"), std::string::npos) << text;
  EXPECT_NE(text.find("EXIF orientation 6"), std::string::npos) << text;
  // An error still answers in JSON on stdout (the message also goes to stderr).
  ASSERT_EQ(json("/nonexistent/a.obj"), 1) << text;
  const nlohmann::json error = nlohmann::json::parse(text);
  EXPECT_EQ(error["valid"], false);
  EXPECT_NE(error["error"].get<std::string>().find("not found"), std::string::npos) << text;
}

TEST(CommandLine, UnsupportedPhotoFormatNamesTheSupportedOnes) {
  const std::string demo = copyDemo("cli_webp");
  const std::string expected = "unsupported photo format 'webp' (supported: .png, .jpg, .jpeg, .tif, .tiff, .bmp)";
  std::ofstream(demo + "/tiger.webp", std::ios::binary) << "RIFF....WEBPVP8 ";
  std::string text;
  EXPECT_EQ(runMontage("info " + demo + "/tiger.webp", &text), 1) << text;
  EXPECT_NE(text.find(expected), std::string::npos) << text;
  // In a project: the photo is skipped with that reason, a warning (exit 3 under --strict).
  nlohmann::json project = test::readJson(demo + "/project.json");
  project["photos"][1]["path"] = "tiger.webp";
  // A hole textured from a region of that photo: the run takes its texture from around it, and says so.
  project["version"] = 6;
  const nlohmann::json region = {{"photo", 1}, {"polygon", {{10, 10}, {60, 10}, {60, 40}}}};
  project["holeModes"] = {{{"face", 299}, {"mode", "texture"}, {"exemplar", region}}};
  std::ofstream(demo + "/project.json") << project.dump(1);
  EXPECT_EQ(runMontage("--strict info " + demo + "/project.json", &text), 3) << text;
  EXPECT_NE(text.find(expected), std::string::npos) << text;
  EXPECT_NE(text.find("hole modes: 1 (1 textured from a photo region)"), std::string::npos) << text;
  EXPECT_EQ(runMontage("run " + demo + "/project.json --out " + demo + "/out", &text), 0) << text;
  EXPECT_NE(text.find("chains and 0 clones (and the texture of 1 hole) are left out of this run"), std::string::npos)
      << text;
}

TEST(CommandLine, SameBytesAcrossFoldersFileTimesAndThreads) {
  // The demo in two folders; the second run after touching a photo, its mask and the mesh, on one
  // thread (and one core when taskset is there); the first on two.
  const std::string a = copyDemo("cli_det_a"), b = copyDemo("cli_det_b");
  std::string text;
  ASSERT_EQ(runMontage("--threads 2 run " + a + "/project.json --out " + a + "/out", &text), 0) << text;
  for (const char* f : {"tiger_left.png", "tiger_left_mask.png", "cat.obj"})
    fs::last_write_time(b + "/" + f, fs::last_write_time(b + "/" + f) + std::chrono::hours(1));
  const std::string pin = test::runCommand("command -v taskset >/dev/null") == 0 ? "taskset -c 0 " : "";
  ASSERT_EQ(test::runCommand(pin + test::montageExe() + " --threads 1 run " + b + "/project.json --out " + b + "/out",
                             &text),
            0)
      << text;
  for (const char* f : kOutputs) {
    const std::string x = bytesOf(a + "/out/" + f), y = bytesOf(b + "/out/" + f);
    EXPECT_GT(x.size(), 0u) << f;
    EXPECT_TRUE(x == y) << f << " differs between the two folders (" << x.size() << " and " << y.size() << " bytes)";
  }
}
