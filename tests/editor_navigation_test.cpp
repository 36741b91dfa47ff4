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
