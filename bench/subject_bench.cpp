// Photos of another subject (issue 33): a landmark case (core/bench/landmarks.h, e.g. bench/data/
// face_leeperrysmith.json) run as the user would (photo mode auto, camera fit on) and with the paper's map alone
// (camera off). Prints per run the mode decision and the map chosen, where each held-out landmark lands (pixels
// and share of the face width), the share of the outlined region mapped from the photo, folds, stretch and time;
// then whether the auto decision holds when any one held-out landmark is added as a click, any click moved by 2 px,
// or any click off the outline deleted.
//   tm_subject_bench CASE [--data DIR (../shared/data)] [--out DIR: renders of both results, and the case as a
//                    project, DIR/case.project.json, for tm_edit_bench and the editor] [--runs N (3)]
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>

#include "base/cpu_time.h"
#include "base/util.h"
#include "bench/landmarks.h"
#include "bench/render.h"
#include "image/codec.h"
#include "pipeline.h"

using namespace montage;
namespace fs = std::filesystem;

namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

// The auto decision for photo 0 of `project` (as the camera stage makes it).
ModeDecision decide(const Project& project) {
  return decideAutoMode(*loadScene(project), 0);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: tm_subject_bench CASE [--data DIR] [--out DIR] [--runs N]\n");
    return 2;
  }
  std::string data = "../shared/data", out;
  int runs = 3;
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    if (flag == "--data")
      data = argv[i + 1];
    else if (flag == "--out")
      out = argv[i + 1];
    else if (flag == "--runs")
      runs = std::max(1, std::atoi(argv[i + 1]));
    else {
      std::fprintf(stderr, "unknown option %s\n", flag.c_str());
      return 2;
    }
  }
  try {
    const LandmarkCase c = loadLandmarkCase(argv[1], data);
    double load[3] = {0, 0, 0};
    if (getloadavg(load, 3) < 0) load[0] = -1;
    std::printf("%s: %zu clicks, %zu held out, outline of %zu; face width %.0f px; load %.2f\n", argv[1],
                c.clicks.size(), c.heldOut.size(), c.outline.size(), c.faceWidth, load[0]);
    if (!out.empty()) {
      fs::create_directories(out);
      Project saved = c.project;
      saveProject(saved, out + "/case.project.json");
      std::printf("project: %s\n", saved.file.c_str());
    }
    for (const bool camera : {true, false}) {
      Project project = c.project;
      project.options.cameraMode = camera ? CameraMode::Auto : CameraMode::Off;
      std::vector<double> wall, cpu;
      PipelineResult result;
      for (int r = 0; r < runs; ++r) {
        const double c0 = cpuSeconds();
        const auto t0 = Clock::now();
        result = Pipeline(Pipeline::Keep::ThisRunOnly).run(project);
        wall.push_back(secondsSince(t0));
        cpu.push_back(cpuSeconds() - c0);
      }
      const LandmarkScore s = scoreLandmarks(c, *result.scene, *result.mapping->partition, result.mapping->map);
      std::printf("\n== %s: run %.2f s wall, %.2f s CPU (median of %d)\n",
                  camera ? "as the user runs it (auto)" : "the paper's map alone (camera off)", median(wall),
                  median(cpu), runs);
      if (camera) {
        std::printf("decision: %s\n", result.cameras->fits[0].decision.c_str());
        for (const SubjectChoice& choice : result.projection->result.subjects)
          std::printf("map: %s\n", choice.why.c_str());
      }
      for (size_t i = 0; i < c.heldOut.size(); ++i)
        if (std::isnan(s.heldOutPx[i]))
          std::printf("  held out %-22s outside the outline (not scored)\n", c.heldOut[i].name.c_str());
        else
          std::printf("  held out %-22s %7.1f px  %5.1f%%\n", c.heldOut[i].name.c_str(), s.heldOutPx[i],
                      100 * s.heldOutPx[i] / c.faceWidth);
      std::printf("held-out landmarks: median %.1f%%, worst %.1f%% of the face width\n", 100 * s.medianShare,
                  100 * s.worstShare);
      std::printf("outlined region: %d faces (%s), %.1f%% from the photo, %d folds; surface from photos %.1f%%\n",
                  s.outlinedFaces, s.outlineClosed ? "closed" : "NOT closed: a side is no path",
                  100 * s.outlinedFromPhoto, s.folds, 100 * result.report()["surface"]["photo_share"].get<double>());
      if (!out.empty() && result.exported) {
        fs::create_directories(out);
        RenderOptions view;
        view.size = 768;
        view.yawDeg = c.viewYawDeg;
        view.pitchDeg = 0;
        const std::string name = out + (camera ? "/auto" : "/paper");
        writePng(name + "_front.png", renderModel(*result.exported, view), kPngFast, false);
        view.yawDeg = c.viewYawDeg + 40;
        writePng(name + "_side.png", renderModel(*result.exported, view), kPngFast, false);
        // The outline's inside: mapped from the photo (green) or not (red); outside it, grey.
        const TextureMap& map = result.mapping->map;
        view.yawDeg = c.viewYawDeg;
        const cv::Mat region = renderSurface(
            result.mapping->partition->mesh,
            [&](int f, const Vec3&) {
              return !s.outlined[f]          ? Vec3f(0.7f, 0.7f, 0.7f)
                     : map.facePhoto[f] == 0 ? Vec3f(0.3f, 0.8f, 0.3f)
                                             : Vec3f(0.9f, 0.2f, 0.2f);
            },
            view);
        writePng(name + "_outlined.png", region, kPngFast, false);
        std::printf("renders: %s_front.png, %s_side.png, %s_outlined.png\n", name.c_str(), name.c_str(), name.c_str());
      }
    }

    // The decision under one more click, one moved by 2 px, or one fewer.
    const ModeDecision base = decide(c.project);
    std::printf("\nauto decision with the %zu clicks: %s (%s)\n", c.clicks.size(), kPhotoModeNames[size_t(base.mode)],
                base.why.c_str());
    int changed = 0, tried = 0;
    for (const auto& [what, project] : oneClickChanges(c)) {
      const ModeDecision d = decide(project);
      ++tried;
      if (d.mode != base.mode)
        ++changed, std::printf("  %s: %s (%s)\n", what.c_str(), kPhotoModeNames[size_t(d.mode)], d.why.c_str());
    }
    std::printf("one click added, moved or deleted: the decision changed in %d of %d cases\n", changed, tried);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }
  return 0;
}
