// The editor's navigation and overlays, scripted under Xvfb on the bundled demo: zoom to the cursor
// keeps the surface point under the cursor, frame all fits the mesh at 800x600 and 2560x1600, and a
// hover highlights the vertex under the pointer (state and pixels). Skips without xvfb-run.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <vector>

#include "test_support.h"

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

std::string tempDir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("tm_nav_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir.string();
}

// Runs the editor on the demo with `script` at `size`; returns its exit status.
int runScript(const std::string& dir, const std::string& script, const std::string& size, const std::string& screen,
              std::string* output) {
  {
    std::ofstream out(dir + "/script.txt");
    out << script;
  }
  const std::string cmd = "cd '" + dir + "' && XDG_STATE_HOME='" + dir +
                          "/state' TM_NO_ZENITY=1 xvfb-run -a -s '-screen 0 " + screen + "' '" +
                          std::string(TM_EDITOR_EXE) + "' '" + montage::test::assetsDir() +
                          "/demo/project.json' --script script.txt --size " + size + " 2>&1";
  return montage::test::runCommand(cmd, output);
}

}  // namespace

TEST(EditorNavigation, ZoomToCursorKeepsTheSurfacePointUnderTheCursor) {
  TM_REQUIRE_XVFB();
  const std::string dir = tempDir("zoom");
  // Candidate pointer positions across the view; the first with a surface hit well off the centre is used.
  std::string script = "view shaded\nframe\nwait_frames 2\nstate frame.json\n";
  // Pixels of the 486x729 view (1280x800 window) over the demo mesh, away from the view's centre.
  const int cx[] = {200, 300, 205, 295, 330};
  const int cy[] = {340, 345, 425, 420, 395};
  for (int k = 0; k < 5; ++k) {
    const int x = cx[k], y = cy[k];
    script += "frame\nhover_3d " + std::to_string(x) + " " + std::to_string(y) + "\nwait_frames 2\nstate before" +
              std::to_string(k) + ".json\nscroll_3d 3 " + std::to_string(x) + " " + std::to_string(y) +
              "\nwait_frames 2\nstate after" + std::to_string(k) + ".json\n";
  }
  script += "quit\n";
  std::string out;
  ASSERT_EQ(runScript(dir, script, "1280x800", "1600x1000x24", &out), 0) << out;
  const json frame = montage::test::readJson(dir + "/frame.json");
  ASSERT_EQ(frame["layout"]["view3d"]["w"].get<double>(), 486) << "the layout changed: update the candidates";
  int tested = 0;
  for (int k = 0; k < 5; ++k) {
    const json b = montage::test::readJson(dir + "/before" + std::to_string(k) + ".json");
    const json a = montage::test::readJson(dir + "/after" + std::to_string(k) + ".json");
    if (b["pointer_hit"].is_null()) continue;
    ASSERT_FALSE(a["pointer_hit"].is_null()) << "zooming lost the surface under the cursor at candidate " << k;
    double moved = 0;
    for (int i = 0; i < 3; ++i)
      moved += std::pow(a["pointer_hit"][i].get<double>() - b["pointer_hit"][i].get<double>(), 2);
    const double dist0 = b["camera"]["distance"].get<double>(), dist1 = a["camera"]["distance"].get<double>();
    EXPECT_LT(dist1, 0.7 * dist0) << "the wheel did not zoom in";
    // Same surface point under the cursor, to a small fraction of the viewing distance.
    EXPECT_LT(std::sqrt(moved), 2e-3 * dist0) << "candidate " << k;
    ++tested;
  }
  EXPECT_GE(tested, 3) << "too few candidate positions on the mesh";
}

TEST(EditorNavigation, FrameAllFitsTheMeshAt800x600And2560x1600) {
  TM_REQUIRE_XVFB();
  for (const auto& [size, screen] : {std::pair<std::string, std::string>{"800x600", "1024x768x24"},
                                     std::pair<std::string, std::string>{"2560x1600", "2600x1700x24"}}) {
    const std::string dir = tempDir("frame" + size);
    std::string out;
    ASSERT_EQ(runScript(dir, "view_preset right\nframe\nwait_frames 2\nstate s.json\nquit\n", size, screen, &out), 0)
        << out;
    const json s = montage::test::readJson(dir + "/s.json");
    const double w = s["layout"]["view3d"]["w"].get<double>(), h = s["layout"]["view3d"]["h"].get<double>();
    const json& b = s["mesh_screen_bounds"];
    EXPECT_GE(b[0].get<double>(), 0) << size;
    EXPECT_GE(b[1].get<double>(), 0) << size;
    EXPECT_LE(b[2].get<double>(), w) << size;
    EXPECT_LE(b[3].get<double>(), h) << size;
    // ... and fills the view in its limiting direction (frame all fits the bounding sphere, so a long
    // mesh seen from the side fills less: the demo's cat about 36%).
    const double fill =
        std::max((b[2].get<double>() - b[0].get<double>()) / w, (b[3].get<double>() - b[1].get<double>()) / h);
    EXPECT_GT(fill, 0.3) << size;
  }
}

TEST(EditorNavigation, HoverHighlightsTheVertexUnderThePointer) {
  TM_REQUIRE_XVFB();
  const std::string dir = tempDir("hover");
  // Candidate pointer positions around the centre of the 486x729 3D view at 1280x800; the first one over
  // the mesh is checked (the demo's cat does not cover every candidate).
  std::vector<std::pair<int, int>> candidates;
  for (int dy : {0, -60, 60, -120, 120})
    for (int dx : {0, -60, 60}) candidates.emplace_back(243 + dx, 364 + dy);
  std::string script = "view shaded\nview features off\nframe\n";
  for (size_t i = 0; i < candidates.size(); ++i)
    script += "hover_3d " + std::to_string(candidates[i].first) + " " + std::to_string(candidates[i].second) +
              "\nwait_frames 3\nstate s" + std::to_string(i) + ".json\nscreenshot shot" + std::to_string(i) + ".png\n";
  script += "quit\n";
  std::string out;
  ASSERT_EQ(runScript(dir, script, "1280x800", "1600x1000x24", &out), 0) << out;
  size_t hit = candidates.size();
  for (size_t i = 0; i < candidates.size() && hit == candidates.size(); ++i)
    if (montage::test::readJson(dir + "/s" + std::to_string(i) + ".json")["hover_vertex"].get<int>() >= 0) hit = i;
  ASSERT_LT(hit, candidates.size()) << "no candidate position is over the mesh";
  const auto [x, y] = candidates[hit];
  const json s = montage::test::readJson(dir + "/s" + std::to_string(hit) + ".json");
  const double px = s["hover_vertex_pixel"][0].get<double>(), py = s["hover_vertex_pixel"][1].get<double>();
  EXPECT_LT(std::hypot(px - x, py - y), 25) << "the hovered vertex is not near the pointer";
  // The highlight: a white marker at the vertex (the shaded mesh is at most 72% grey).
  const cv::Mat shot = cv::imread(dir + "/shot" + std::to_string(hit) + ".png");
  ASSERT_FALSE(shot.empty());
  const int sx = int(s["layout"]["view3d"]["x"].get<double>() + px),
            sy = int(s["layout"]["view3d"]["y"].get<double>() + py);
  int white = 0;
  for (int dy = -3; dy <= 3; ++dy)
    for (int dx = -3; dx <= 3; ++dx) {
      const cv::Vec3b c = shot.at<cv::Vec3b>(sy + dy, sx + dx);
      white += c[0] > 240 && c[1] > 240 && c[2] > 240;
    }
  EXPECT_GT(white, 8) << "no highlight marker at the hovered vertex";
}

TEST(EditorNavigation, ReducedResolutionWhileTheCameraMovesFullSizeOnceStill) {
  TM_REQUIRE_XVFB();
  const std::string dir = tempDir("adaptive");
  // An orbit (a left drag of 8 moves), then still; the same with the preference off. The counters say
  // at which sizes the view was drawn: a drag's frames may be slower than the settle time under load,
  // so the size at the moment of a state dump is only checked once the view is still.
  const std::string script =
      "wait_worker\nview textured\nframe\nwait_frames 3\nstate still0.json\n"
      "drag_3d 150 300 330 340\nstate moving.json\nsleep 0.6\nstate still1.json\nscreenshot still1.png\n"
      "menu \"View/Reduced resolution while navigating\"\nwait_frames 2\nstate off0.json\n"
      "drag_3d 330 340 150 300\nsleep 0.6\nstate off1.json\nquit\n";
  std::string out;
  ASSERT_EQ(runScript(dir, script, "1280x800", "1600x1000x24", &out), 0) << out;
  const json s0 = montage::test::readJson(dir + "/still0.json")["view3d"];
  const json mv = montage::test::readJson(dir + "/moving.json")["view3d"];
  const json s1 = montage::test::readJson(dir + "/still1.json")["view3d"];
  const json o0 = montage::test::readJson(dir + "/off0.json")["view3d"];
  const json o1 = montage::test::readJson(dir + "/off1.json")["view3d"];
  ASSERT_EQ(s0["size"], json({486, 729})) << "the layout changed";
  EXPECT_TRUE(s0["reduced_navigation"].get<bool>()) << "on by default";
  EXPECT_EQ(s0["render"], s0["size"]) << "a still view is drawn at full size";
  // During the orbit: redrawn at half size per axis (486x729 -> 243x365).
  EXPECT_GT(mv["reduced_redraws"].get<long>(), s0["reduced_redraws"].get<long>()) << "the orbit was not reduced";
  EXPECT_EQ(mv["reduced_size"], json({243, 365}));
  EXPECT_EQ(mv["divisor"].get<int>() == 2, mv["render"] == json({243, 365}));
  // Still again: one more full-size redraw, the framebuffer at the view's size.
  EXPECT_FALSE(s1["moving"].get<bool>());
  EXPECT_EQ(s1["render"], s1["size"]);
  EXPECT_EQ(s1["divisor"].get<int>(), 1);
  EXPECT_GT(s1["full_redraws"].get<long>(), mv["full_redraws"].get<long>());
  // The photo pane comes from its cache, which the orbit did not render again.
  const long paneRenders = montage::test::readJson(dir + "/still0.json")["pane_cache_renders"].get<long>();
  EXPECT_GT(paneRenders, 0);
  EXPECT_EQ(montage::test::readJson(dir + "/still1.json")["pane_cache_renders"].get<long>(), paneRenders);
  // Preference off: the orbit is drawn at full size only.
  EXPECT_FALSE(o0["reduced_navigation"].get<bool>());
  EXPECT_EQ(o1["reduced_redraws"], o0["reduced_redraws"]) << "reduced with the preference off";
  EXPECT_GT(o1["full_redraws"].get<long>(), o0["full_redraws"].get<long>() + 3) << "the orbit redrew too little";
  EXPECT_EQ(o1["render"], o1["size"]);
  // The preference is remembered with the layout.
  const json layout = montage::test::readJson(dir + "/state/texturemontage/layout.json");
  EXPECT_FALSE(layout["reduced_navigation"].get<bool>());
  // The still screenshot's view is the mesh (not garbage): varied pixels inside the view.
  const cv::Mat shot = cv::imread(dir + "/still1.png");
  ASSERT_FALSE(shot.empty());
  const json r = montage::test::readJson(dir + "/still1.json")["layout"]["view3d"];
  const cv::Mat view = shot(cv::Rect(int(r["x"].get<double>()), int(r["y"].get<double>()), int(r["w"].get<double>()),
                                     int(r["h"].get<double>())));
  cv::Scalar mean, dev;
  cv::meanStdDev(view, mean, dev);
  EXPECT_GT(dev[0] + dev[1] + dev[2], 20);
  // So is the photo pane's (its cache shown): the photo, not a flat colour.
  const json pr = montage::test::readJson(dir + "/still1.json")["layout"]["photos"];
  const cv::Mat pane = shot(cv::Rect(int(pr["x"].get<double>()), int(pr["y"].get<double>()) + 80,
                                     int(pr["w"].get<double>()), int(pr["h"].get<double>()) - 120));
  cv::meanStdDev(pane, mean, dev);
  EXPECT_GT(dev[0] + dev[1] + dev[2], 20);
}

// The selected point's id is labelled where the point is in sight, never drawn through the mesh when the
// point is behind it (the demo's point 6, a head landmark on the cat's left side: seen from the back preset,
// hidden from the front one).
TEST(EditorNavigation, TheSelectedPointsLabelIsNotDrawnThroughTheMesh) {
  TM_REQUIRE_XVFB();
  const std::string dir = tempDir("labels");
  const json project = montage::test::readJson(montage::test::assetsDir() + "/demo/project.json");
  const int vertex = project["points"][6]["vertex"].get<int>();
  std::string out;
  ASSERT_EQ(runScript(dir,
                      "select_vertex " + std::to_string(vertex) +
                          "\nview_preset back\nframe\nwait_frames 3\nstate back.json\n"
                          "view_preset front\nframe\nwait_frames 3\nstate front.json\nquit\n",
                      "1280x800", "1600x1000x24", &out),
            0)
      << out;
  for (const char* side : {"back", "front"}) {
    const json s = montage::test::readJson(dir + "/" + side + ".json");
    ASSERT_EQ(s["selected_point"].get<int>(), 6) << side;
    const auto& labels = s["labels"];
    const bool labelled = std::find(labels.begin(), labels.end(), json(6)) != labels.end();
    EXPECT_FALSE(labels.empty()) << side;
    EXPECT_EQ(labelled, std::string(side) == "back") << side << ": the selected point's label";
  }
}
