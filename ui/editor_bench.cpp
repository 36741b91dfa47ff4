// The overlay benchmark (--bench-overlays): orbits a project's result with every overlay shown
// (features, ids, partition paths, the selection, photo-pane markers, curves and rejected pairs, the
// camera feedback's wireframe, residuals and proposals) and with none of them, alternating in short
// blocks within one run, so both see the same machine load.
// Prints both frame-time distributions, their ratio, the process CPU time per frame and the load.
#include <imgui.h>
#include <sys/resource.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <numeric>

#include "editor.h"
#include "gl.h"

namespace montage {

namespace {

double cpuSeconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_utime.tv_sec + u.ru_stime.tv_sec + 1e-6 * (u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

std::string loadAverage() {
  std::ifstream in("/proc/loadavg");
  std::string a, b, c;
  in >> a >> b >> c;
  return a + " " + b + " " + c;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(q * (v.size() - 1) + 0.5))];
}

}  // namespace

void Editor::setOverlaysShown(bool on) {
  showFeatures_ = showIds_ = showPaths_ = on;
  showCurves_ = showRejected_ = showPaneIds_ = showCamera_ = on;
}

void Editor::benchOverlaysStep() {
  constexpr int kBlock = 12, kSettle = 2;  // frames per block; frames dropped after each switch
  // Wait for the worker's result of the project, uploaded.
  if (!resultCurrent() || meshDirty_ || worker_->status().busy) {
    TM_CHECK(lastErrorGeneration_ != submittedGeneration_ || submittedGeneration_ == 0,
             "--bench-overlays: the pipeline failed: " + lastError_);
    return;
  }
  const double cpu = cpuSeconds();
  if (bench_.frame > 0) {
    // The previous frame, complete (the frame loop glFinish-es in benchmark mode).
    const int inBlock = (bench_.frame - 1) % kBlock;
    if (bench_.frame > kBlock && inBlock >= kSettle) {
      auto& times = bench_.full ? benchTimes_ : bench_.bareTimes;
      auto& cpus = bench_.full ? bench_.fullCpu : bench_.bareCpu;
      times.push_back(lastFrameSeconds_ * 1000);
      cpus.push_back((cpu - bench_.lastCpu) * 1000);
    }
  }
  bench_.lastCpu = cpu;
  if (bench_.frame == 0) bench_.load = loadAverage();
  // This frame's mode: blocks alternate full / bare.
  bench_.full = (bench_.frame / kBlock) % 2 == 0;
  setOverlaysShown(bench_.full);
  if (bench_.full && selectedVertex_ < 0 && !doc_.project().points.empty())
    selectVertex(doc_.project().points.front().vertex);
  if (!bench_.full) selectVertex(-1);
  ++bench_.frame;
  camera_.yawDeg += 360.0 / std::max(1, options_.benchFrames);
  if (static_cast<int>(std::min(benchTimes_.size(), bench_.bareTimes.size())) >= options_.benchFrames) quit_ = true;
}

void Editor::benchOverlaysReport() {
  auto report = [](const char* what, const std::vector<double>& t, const std::vector<double>& cpu) {
    if (t.empty()) {
      std::printf("%s: no frames\n", what);
      return;
    }
    const double mean = std::accumulate(t.begin(), t.end(), 0.0) / t.size();
    const double cpuMean = std::accumulate(cpu.begin(), cpu.end(), 0.0) / std::max<size_t>(1, cpu.size());
    std::printf(
        "%s: %zu frames, wall mean %.2f ms (%.1f fps), median %.2f ms, p95 %.2f ms; CPU user+sys %.2f ms/frame\n", what,
        t.size(), mean, 1000 / mean, median(t), quantile(t, 0.95), cpuMean);
  };
  int w = 0, h = 0;
  glfwGetFramebufferSize(window_, &w, &h);
  const char* renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  const Project& p = doc_.project();
  std::printf(
      "bench overlays: %s, %zu features, %zu photos, %zu paths, window %dx%d, 3D view %.0fx%.0f, %d faces, "
      "renderer %s, load average at start %s, at end %s\n",
      p.file.c_str(), p.points.size(), p.photos.size(),
      result_ && result_->mapping ? result_->mapping->partition->paths.size() : size_t(0), w, h, viewRect_.w,
      viewRect_.h, result_ && result_->model ? result_->model->mesh.numFaces() : 0, renderer ? renderer : "?",
      bench_.load.c_str(), loadAverage().c_str());
  // The orbit moves the camera every frame: with the preference on, the view is drawn reduced as in a
  // user's orbit (only the first frame after the wait is full size).
  std::printf(
      "3D view redraws: %ld reduced (%dx%d, 1/%d per axis), %ld full size; reduced resolution while "
      "navigating %s\n",
      reducedRedraws_, reducedSize_[0], reducedSize_[1], navigationDivisor(int(viewRect_.w), int(viewRect_.h)),
      fullRedraws_, reducedNavigation_ ? "on" : "off");
  report("bare (overlays hidden)", bench_.bareTimes, bench_.bareCpu);
  report("full (every overlay shown)", benchTimes_, bench_.fullCpu);
  if (!benchTimes_.empty() && !bench_.bareTimes.empty())
    std::printf("full / bare: median %.2f, mean %.2f\n", median(benchTimes_) / median(bench_.bareTimes),
                std::accumulate(benchTimes_.begin(), benchTimes_.end(), 0.0) / benchTimes_.size() /
                    (std::accumulate(bench_.bareTimes.begin(), bench_.bareTimes.end(), 0.0) / bench_.bareTimes.size()));
}

}  // namespace montage
