// The editor's Coverage tab, scripted under Xvfb on a known scene (a synthetic turtle with 40 sampled
// features, the paper's path): the tab lists the regions the core finds (report.json of the same project),
// and "Fly to" centres the region it names: its centroid lands at the 3D view's centre and a pick there
// hits one of its faces. Skips without xvfb-run.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "test_support.h"

namespace fs = std::filesystem;
using nlohmann::json;

namespace {}  // namespace

TEST(EditorCoverage, TheTabListsTheRegionsAndFlyToCentresOne) {
  TM_REQUIRE_XVFB();
  const std::string dir = montage::test::tempDir("editor_coverage");
  std::string out;
  ASSERT_EQ(
      montage::test::runCommand("'" + montage::test::montageExe() + "' synth --mesh '" + montage::test::testDataDir() +
                                    "/turtle.obj' --views 4 --features 40 "
                                    "--size 512 --out '" +
                                    dir + "/scene' 2>&1",
                                &out),
      0)
      << out;
  // The paper's path (no camera): the regions come from the partition, with causes and clicks.
  json project = montage::test::readJson(dir + "/scene/project.json");
  project["options"]["cameraMode"] = "off";
  std::ofstream(dir + "/scene/project.json") << project.dump(1);
  ASSERT_EQ(montage::test::runCommand("'" + montage::test::montageExe() + "' run '" + dir +
                                          "/scene/project.json' --out '" + dir + "/run' 2>&1",
                                      &out),
            0)
      << out;
  const json report = montage::test::readJson(dir + "/run/report.json")["coverage"];
  ASSERT_GE(report["regions"].size(), 2u) << "the scene should leave several regions empty";

  std::ofstream(dir + "/script.txt") << "wait_worker\n"
                                        "tab coverage\n"
                                        "wait_frames 3\n"
                                        "state before.json\n"
                                        "click_button \"Fly to region 1\"\n"
                                        "wait_frames 3\n"
                                        "state after.json\n"
                                        "screenshot coverage.png\n"
                                        "quit\n";
  const std::string cmd = "cd '" + dir + "' && XDG_STATE_HOME='" + dir +
                          "/state' TM_NO_ZENITY=1 xvfb-run -a -s '-screen 0 1600x1000x24' '" +
                          std::string(TM_EDITOR_EXE) + "' scene/project.json --script script.txt --size 1280x800 2>&1";
  ASSERT_EQ(montage::test::runCommand(cmd, &out), 0) << out;

  const json before = montage::test::readJson(dir + "/before.json");
  ASSERT_TRUE(before["coverage"].is_object()) << before.dump();
  const json& regions = before["coverage"]["regions"];
  // The same regions as report.json's (the editor's preview runs the same mapping).
  ASSERT_EQ(regions.size(), report["regions"].size());
  for (size_t i = 0; i < regions.size(); ++i) {
    EXPECT_EQ(regions[i]["faces"], report["regions"][i]["faces"]) << i;
    EXPECT_EQ(regions[i]["why"], report["regions"][i]["why"]) << i;
    EXPECT_FALSE(regions[i]["fix"].get<std::string>().empty()) << i;
  }
  EXPECT_EQ(before["coverage"]["highlighted"].get<int>(), -1);

  const json after = montage::test::readJson(dir + "/after.json");
  EXPECT_EQ(after["coverage"]["highlighted"].get<int>(), 1);
  const json& flown = after["coverage"]["regions"][1];
  ASSERT_FALSE(flown["centre_pixel"].is_null());
  const json& view = after["layout"]["view3d"];
  EXPECT_NEAR(flown["centre_pixel"][0].get<double>(), view["w"].get<double>() / 2, 2.0);
  EXPECT_NEAR(flown["centre_pixel"][1].get<double>(), view["h"].get<double>() / 2, 2.0);
  EXPECT_TRUE(flown["at_view_centre"].get<bool>()) << "a pick at the view's centre misses the region";
  EXPECT_FALSE(before["coverage"]["regions"][1]["at_view_centre"].get<bool>() && before["camera"] == after["camera"])
      << "the camera did not move";
  EXPECT_TRUE(fs::exists(dir + "/coverage.png"));
}

// A photo that does not decode is reported by the UI's own load and again by the worker's: listed once.
TEST(EditorErrors, ALoadErrorIsListedOnce) {
  TM_REQUIRE_XVFB();
  const std::string dir = montage::test::tempDir("editor_errors");
  json project = montage::test::demoProjectAbsolute();
  project["photos"][0]["path"] = dir + "/broken.png";
  std::ofstream(dir + "/broken.png") << "not a png";
  std::ofstream(dir + "/project.json") << project.dump(1);
  std::ofstream(dir + "/script.txt") << "wait_worker\nwait_frames 3\nstate state.json\nquit\n";
  std::string out;
  const std::string cmd = "cd '" + dir + "' && XDG_STATE_HOME='" + dir +
                          "/state' TM_NO_ZENITY=1 xvfb-run -a -s '-screen 0 1600x1000x24' '" +
                          std::string(TM_EDITOR_EXE) + "' project.json --script script.txt --size 1280x800 2>&1";
  ASSERT_EQ(montage::test::runCommand(cmd, &out), 0) << out;
  const json state = montage::test::readJson(dir + "/state.json");
  ASSERT_FALSE(state["errors"].empty()) << "the missing photo was not reported";
  std::vector<std::string> bare;
  for (const auto& e : state["errors"]) {
    std::string m = e.get<std::string>();
    if (m.rfind("pipeline: ", 0) == 0) m = m.substr(10);
    EXPECT_EQ(std::count(bare.begin(), bare.end(), m), 0) << "listed twice: " << m;
    bare.push_back(m);
  }
  bool named = false;
  for (const std::string& m : bare) named = named || m.find("broken.png") != std::string::npos;
  EXPECT_TRUE(named) << state["errors"].dump();
}
