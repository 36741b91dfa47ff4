// The editor itself, driven by scripts under Xvfb + Mesa on the bundled demo: a scripted editing
// session (ray-cast pick, photo click, undo, save/reload), the textured preview in a screenshot, a
// cancelled pipeline run, and crash recovery after SIGKILL. Skips with a message without xvfb-run.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <thread>

#include "io/project.h"
#include "test_support.h"

using namespace montage;
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

bool haveXvfb() {
  return test::runCommand("command -v xvfb-run >/dev/null 2>&1") == 0;
}

#define TM_REQUIRE_XVFB() \
  if (!haveXvfb()) GTEST_SKIP() << "xvfb-run is absent (package xvfb): the editor tests need a virtual display"

std::string demoProject() {
  return test::assetsDir() + "/demo/project.json";
}

// The shell command that runs the editor headless with its state (autosaves, recent files) in `dir`.
std::string editorCommand(const std::string& dir, const std::string& args) {
  return "cd '" + dir + "' && XDG_STATE_HOME='" + dir +
         "/state' TM_NO_ZENITY=1 xvfb-run -a -s '-screen 0 1600x1000x24' '" + std::string(TM_EDITOR_EXE) + "' " + args;
}

int runEditor(const std::string& dir, const std::string& args, std::string* output) {
  return test::runCommand(editorCommand(dir, args) + " 2>&1", output);
}

void writeText(const std::string& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
}

json readJson(const std::string& path) {
  std::ifstream in(path);
  EXPECT_TRUE(in) << "missing " << path;
  return json::parse(in);
}

// A vertex of the demo mesh that is not a feature yet, and a point in photo 0 to put it at.
constexpr int kNewVertex = 100;
constexpr double kPhotoX = 200.25, kPhotoY = 80.5;

std::string pickAndClick() {
  return "tool point\nview_vertex " + std::to_string(kNewVertex) + "\nclick_vertex " + std::to_string(kNewVertex) +
         "\nclick_photo 0 " + std::to_string(kPhotoX) + " " + std::to_string(kPhotoY) + "\n";
}

// Checks that `p` is the demo plus one feature point: kNewVertex in photo 0 near the clicked point
// (a click lands on a whole screen pixel: within 1/zoom photo pixels).
void expectDemoPlusOne(const Project& p, const Project& demo) {
  ASSERT_EQ(p.points.size(), demo.points.size() + 1);
  const FeaturePoint& added = p.points.back();
  EXPECT_EQ(added.vertex, kNewVertex);
  ASSERT_EQ(added.at.size(), 1u);
  EXPECT_EQ(added.at[0].photo, 0);
  EXPECT_NEAR(added.at[0].x, kPhotoX, 2.0);
  EXPECT_NEAR(added.at[0].y, kPhotoY, 2.0);
  for (size_t i = 0; i < demo.points.size(); ++i) EXPECT_EQ(p.points[i], demo.points[i]) << "point " << i;
  EXPECT_EQ(p.chains, demo.chains);
}

}  // namespace

TEST(EditorSession, PickClickUndoSaveReload) {
  TM_REQUIRE_XVFB();
  const std::string dir = test::tempDir("editor_session");
  const Project demo = loadProject(demoProject());
  for (const auto& pt : demo.points) ASSERT_NE(pt.vertex, kNewVertex) << "the test needs a vertex that is no feature";
  writeText(dir + "/s.txt", "wait_frames 2\n" + pickAndClick() +
                                "state after_click.json\n"
                                "save added.json\n"
                                "key ctrl+z\n"
                                "state after_undo.json\n"
                                "save undone.json\n"
                                "key ctrl+shift+z\n"
                                "save redone.json\n"
                                "open redone.json\n"
                                "save reloaded.json\n"
                                "quit\n");
  std::string out;
  ASSERT_EQ(runEditor(dir, "'" + demoProject() + "' --script s.txt", &out), 0) << out;

  const json afterClick = readJson(dir + "/after_click.json");
  EXPECT_EQ(afterClick["selected_vertex"], kNewVertex) << "the ray-cast pick selected another vertex";
  EXPECT_EQ(afterClick["counts"]["points"], demo.points.size() + 1);
  EXPECT_EQ(afterClick["history"]["steps"], 1) << "placing a point is one undo step";
  EXPECT_TRUE(afterClick["modified"].get<bool>());
  EXPECT_EQ(readJson(dir + "/after_undo.json")["counts"]["points"], demo.points.size());

  const Project added = loadProject(dir + "/added.json");
  expectDemoPlusOne(added, demo);
  EXPECT_TRUE(loadProject(dir + "/undone.json").sameDocument(demo)) << "undo must restore the demo exactly";
  EXPECT_TRUE(loadProject(dir + "/redone.json").sameDocument(added));
  const Project reloaded = loadProject(dir + "/reloaded.json");
  EXPECT_TRUE(reloaded.sameDocument(added)) << "save, open and save again must give the same project";
  std::string a, b;
  test::runCommand("cat '" + dir + "/redone.json'", &a);
  test::runCommand("cat '" + dir + "/reloaded.json'", &b);
  EXPECT_EQ(a, b) << "the same document must give the same file";
}

namespace {

// Colour statistics of the 3D view in a screenshot: the share of surface pixels (not the
// background) whose chroma (max - min of R, G, B) is above 40, and the number of distinct hues
// (of 36 bins) that cover at least 0.5% of the surface.
struct ColourStats {
  double surfaceShare = 0, colourful = 0;
  int hues = 0;
};

ColourStats viewStats(const std::string& png, const json& rect) {
  cv::Mat bgr = cv::imread(png, cv::IMREAD_COLOR);
  EXPECT_FALSE(bgr.empty()) << png;
  if (bgr.empty()) return {};
  const cv::Rect r(rect["x"].get<int>() + 2, rect["y"].get<int>() + 30, rect["w"].get<int>() - 4,
                   rect["h"].get<int>() - 34);  // below the view's caption
  const cv::Mat view = bgr(r & cv::Rect(0, 0, bgr.cols, bgr.rows));
  const cv::Vec3b background(51, 46, 43);  // the view's clear colour (0.17, 0.18, 0.20), as BGR
  cv::Mat hsv;
  cv::cvtColor(view, hsv, cv::COLOR_BGR2HSV);
  std::vector<int> hueCount(36, 0);
  int surface = 0, colourful = 0;
  for (int y = 0; y < view.rows; ++y)
    for (int x = 0; x < view.cols; ++x) {
      const cv::Vec3b c = view.at<cv::Vec3b>(y, x);
      if (cv::norm(cv::Vec3i(c) - cv::Vec3i(background)) < 6) continue;
      ++surface;
      const int chroma = std::max({c[0], c[1], c[2]}) - std::min({c[0], c[1], c[2]});
      if (chroma > 40) {
        ++colourful;
        ++hueCount[hsv.at<cv::Vec3b>(y, x)[0] / 5];
      }
    }
  ColourStats s;
  s.surfaceShare = double(surface) / (view.rows * view.cols);
  s.colourful = surface ? double(colourful) / surface : 0;
  for (int n : hueCount) s.hues += surface && n >= 0.005 * surface;
  return s;
}

}  // namespace

TEST(EditorSession, ScreenshotShowsTheTexturedResult) {
  TM_REQUIRE_XVFB();
  const std::string dir = test::tempDir("editor_shot");
  // --screenshot waits for the worker, renders 3 frames and saves the window; the script runs first.
  writeText(dir + "/s.txt", "view paths off\nview features off\nwait_worker 900\nstate state.json\n");
  std::string out;
  ASSERT_EQ(runEditor(dir, "'" + demoProject() + "' --script s.txt --screenshot textured.png --frames 3", &out), 0)
      << out;
  // The same view, shaded only: the control that the statistics tell texture from flat shading.
  writeText(dir + "/flat.txt",
            "view paths off\nview features off\nview shaded\nwait_frames 3\nscreenshot flat.png\nquit\n");
  ASSERT_EQ(runEditor(dir, "'" + demoProject() + "' --script flat.txt", &out), 0) << out;

  const json state = readJson(dir + "/state.json");
  ASSERT_FALSE(state["result"].is_null()) << "no pipeline result: " << state["worker"].dump();
  EXPECT_TRUE(state["result"]["matches_document"].get<bool>());
  EXPECT_GT(state["result"]["faces"].get<int>(), 0);
  const cv::Mat shot = cv::imread(dir + "/textured.png");
  ASSERT_EQ(shot.cols, 1280);
  ASSERT_EQ(shot.rows, 800);

  const ColourStats textured = viewStats(dir + "/textured.png", state["layout"]["view3d"]);
  const ColourStats flat = viewStats(dir + "/flat.png", state["layout"]["view3d"]);
  std::printf("textured: surface %.2f, colourful %.2f, hues %d; shaded: surface %.2f, colourful %.2f, hues %d\n",
              textured.surfaceShare, textured.colourful, textured.hues, flat.surfaceShare, flat.colourful, flat.hues);
  // Frame all fits the width too: a long mesh fills a small part of the tall 486x729 view.
  EXPECT_GT(textured.surfaceShare, 0.05) << "the mesh should fill part of the view";
  // The demo's tiger fur: orange and black stripes, grey-green belly and inpainted regions (measured 0.41
  // colourful, 2 hue bins); flat shading has none.
  EXPECT_GT(textured.colourful, 0.25) << "much of the surface should show the photos' colours";
  EXPECT_GE(textured.hues, 2) << "the demo texture has more than one hue";
  EXPECT_GT(flat.surfaceShare, 0.05);
  EXPECT_LT(flat.colourful, 0.05) << "flat shading is grey: the check must fail on it";
  EXPECT_LT(flat.hues, 2);
}

TEST(EditorSession, AnEditDuringARunRestartsTheWorkerAndTheLastSnapshotWins) {
  TM_REQUIRE_XVFB();
  const std::string dir = test::tempDir("editor_cancel");
  // A first edit starts a run; once it is busy, a second edit (the user's click) must cancel it.
  writeText(dir + "/s.txt", "wait_frames 2\nset_option stretchSearches 16\nwait_busy 120\nstate busy.json\n" +
                                pickAndClick() + "wait_worker 900\nstate done.json\nsave final.json\nquit\n");
  std::string out;
  ASSERT_EQ(runEditor(dir, "'" + demoProject() + "' --script s.txt", &out), 0) << out;
  const json busy = readJson(dir + "/busy.json");
  const json done = readJson(dir + "/done.json");
  ASSERT_TRUE(busy["worker"]["busy"].get<bool>());
  const long busyGeneration = busy["worker"]["submitted_generation"];
  const long lastGeneration = done["worker"]["submitted_generation"];
  EXPECT_GT(lastGeneration, busyGeneration) << "the click must have been submitted as a new snapshot";
  const auto outcomes = done["worker"]["outcome_generations"].get<std::vector<long>>();
  ASSERT_FALSE(outcomes.empty());
  EXPECT_EQ(outcomes.back(), lastGeneration);
  for (long g : outcomes) EXPECT_NE(g, busyGeneration) << "the run that was busy must have been cancelled";
  EXPECT_EQ(done["worker"]["result_generation"], lastGeneration);
  ASSERT_FALSE(done["result"].is_null()) << done["worker"].dump();
  EXPECT_TRUE(done["result"]["matches_document"].get<bool>());

  // The result's project is the final document: the new point and the changed option.
  writeText(dir + "/result_project.json", done["result"]["project"].dump(2));
  const Project fromResult = loadProject(dir + "/result_project.json");
  const Project final = loadProject(dir + "/final.json");
  EXPECT_TRUE(fromResult.sameDocument(final));
  EXPECT_EQ(final.options.stretchSearches, 16);
  expectDemoPlusOne(final, loadProject(demoProject()));
}

TEST(EditorSession, AutosaveIsRecoveredAfterSigkill) {
  TM_REQUIRE_XVFB();
  const std::string dir = test::tempDir("editor_recover");
  // A project of its own, so that its side file is unique to this test.
  Project project = loadProject(demoProject());
  saveProject(project, dir + "/proj.json");
  writeText(dir + "/edit.txt", pickAndClick() + "wait_autosave 120\nstate crashed.json\nsleep 600\n");

  // Run the editor in the background, wait for its autosave, then kill it with SIGKILL.
  const pid_t shell = fork();
  ASSERT_GE(shell, 0);
  if (shell == 0) {
    const std::string cmd = editorCommand(dir, "proj.json --autosave-seconds 1 --script edit.txt") + " >/dev/null 2>&1";
    execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(240);
  while (!fs::exists(dir + "/crashed.json") && std::chrono::steady_clock::now() < deadline) {
    int status = 0;
    if (waitpid(shell, &status, WNOHANG) == shell) FAIL() << "the editor exited before autosaving";
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  ASSERT_TRUE(fs::exists(dir + "/crashed.json")) << "no autosave within 240 s";
  const json crashed = readJson(dir + "/crashed.json");
  const pid_t editor = crashed["pid"].get<long long>();
  const std::string side = crashed["autosave"]["path"];
  ASSERT_EQ(kill(editor, SIGKILL), 0);
  int status = 0;
  waitpid(shell, &status, 0);
  ASSERT_TRUE(fs::exists(side)) << "the autosave side file is gone: " << side;
  EXPECT_EQ(loadProject(dir + "/proj.json").points.size(), project.points.size()) << "the project file is untouched";

  // Restart: the recovery prompt offers the side file; recover, check, save.
  writeText(dir + "/recover.txt", "click_button Recover\nwait_frames 2\nstate recovered.json\nsave proj.json\nquit\n");
  std::string out;
  ASSERT_EQ(runEditor(dir, "proj.json --script recover.txt", &out), 0) << out;
  const json recovered = readJson(dir + "/recovered.json");
  EXPECT_TRUE(recovered["modified"].get<bool>()) << "recovered work is not saved until the user saves";
  expectDemoPlusOne(loadProject(dir + "/proj.json"), project);
  EXPECT_FALSE(fs::exists(side)) << "saving removes the side file";
}
