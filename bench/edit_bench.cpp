// The live loop's benchmark (issue "the live loop"): a scripted edit sequence in one process, as the
// editor's worker sees it. Per project, `--runs` times with a fresh Pipeline each time:
//
//   cold    the first final run (`montage run`: every stage, the atlas bake)
//   drag    one photo point (--drag-point, else a middle one outside chains) moved by 3 px (--drag-px),
//           preview tier (what the editor shows after the edit)
//   delete  another feature deleted, preview tier
//   add     that feature added back 1 px away from where it was, preview tier
//   undo    back to the state after "delete", preview tier (an earlier document state)
//   final   the last state's final tier (the editor's background bake when idle)
//   drags   with --drags K: after those, the dragged point moved K more times by 1 px each, preview
//           tier, each from the last (a user dragging a point; the median of the K previews)
//
// As the editor's worker runs them (issue 36), an edit's preview is the quick preview (every hole harmonic)
// where it differs from the preview (quickDiffers): then "drag", "delete", "add" and "undo" are quick
// previews, each followed by the preview that refines it ("drag_refine"...: its earlier stages kept), and the
// drags of a series are quick previews (in the editor each newer position cancels the refinement). With
// --preview-only every edit runs the preview tier alone, as before the quick tier.
//
//   tm_edit_bench PROJECT... [--runs N] [--drags K] [--drag-px D] [--drag-point I] [--preview-only] [--json FILE]
//   tm_edit_bench --mesh M [--subdivide L] [--views K] [--features N] [--seed S] --work DIR [--runs N]
//
// The second form first synthesises a scene (montage synth) from M, subdivided L times by midpoint
// subdivision (the 832k-face armadillo is CGAL's armadillo with --subdivide 2). Prints one JSON object:
// per project and step the median wall and CPU milliseconds (user + sys of the whole process, all
// threads), the figures of the last run, the peak memory and the load average.
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "base/cpu_time.h"
#include "base/fileio.h"
#include "base/process_tuning.h"
#include "bench/synth.h"
#include "geometry/shapes.h"
#include "io/mesh_io.h"
#include "io/project.h"
#include "pipeline.h"

namespace fs = std::filesystem;
using namespace montage;

namespace {

double peakMiB() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss / 1024.0;
}

std::string loadAverage() {
  std::ifstream in("/proc/loadavg");
  std::string a, b, c;
  in >> a >> b >> c;
  return a + " " + b + " " + c;
}

struct Timed {
  double wallMs = 0, cpuMs = 0;
  nlohmann::json figures;
};

Timed timedRun(Pipeline& pipeline, const Project& project, Tier tier) {
  // Process CPU time per stage: charged to the stage that last reported progress (the machine is
  // shared, so CPU is steadier than the stages' wall times).
  std::mutex mutex;
  std::map<StageId, double> stageCpu;
  StageId current = StageId::Load;
  double mark = cpuSeconds();
  const JobControl job(nullptr, [&](StageId stage, double, const std::string&) {
    std::lock_guard<std::mutex> lock(mutex);
    if (stage == current) return;
    const double now = cpuSeconds();
    stageCpu[current] += now - mark;
    mark = now, current = stage;
  });
  const double cpu0 = cpuSeconds();
  const auto t0 = std::chrono::steady_clock::now();
  const PipelineResult result = pipeline.run(project, job, tier);
  stageCpu[current] += cpuSeconds() - mark;
  Timed t;
  t.wallMs = 1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  t.cpuMs = 1e3 * (cpuSeconds() - cpu0);
  for (const StageRecord& s : result.stages) {
    t.figures[stageName(s.stage)] = {{"seconds", s.seconds}, {"cached", s.cached}, {"cpu_seconds", stageCpu[s.stage]}};
    for (const auto& [key, value] : s.counts.items())  // the stage's own breakdown (view_seconds, ...)
      if ((key.size() > 8 && key.compare(key.size() - 8, 8, "_seconds") == 0) || key == "searches" ||
          key == "searches_reused" || key == "frames_reused" || key == "views_reused" || key == "views_carried" ||
          key == "carried_share" || key == "frames_near" || key == "selection_kept" || key == "rounds" ||
          key == "selection_sweeps" || key == "warm_sides" || key == "warm_near_sides" || key == "moved_sides" ||
          key == "structure_kept" || key == "photos_kept" || key == "edges_kept")
        t.figures[stageName(s.stage)][key] = value;
    if (s.stage == StageId::Inpaint && s.counts.contains("regions"))  // per region: guidance, factor, solve
      t.figures["inpaint"]["regions"] = s.counts["regions"];
    if (s.stage == StageId::Map) {
      t.figures["map"]["cells_mapped"] = s.counts.value("cells_mapped", 0);
      t.figures["map"]["cells_reused"] = s.counts.value("cells_reused", 0);
    }
  }
  t.figures["mapped_faces"] = result.mapping->map.numMapped();
  return t;
}

// A point to drag (one with a position in a photo, not in a chain) and another one to delete.
std::pair<int, int> choosePoints(const Project& project) {
  std::vector<char> inChain(project.points.size(), 0);
  for (const FeatureChain& c : project.chains)
    for (int p : c.points) inChain[p] = 1;
  std::vector<int> free;
  for (int i = 0; i < static_cast<int>(project.points.size()); ++i)
    if (!inChain[i] && !project.points[i].at.empty()) free.push_back(i);
  TM_CHECK(free.size() >= 2, "tm_edit_bench: the project needs two points outside chains");
  return {free[free.size() / 2], free[free.size() / 3]};
}

Project withoutPoint(Project p, int index) {
  p.points.erase(p.points.begin() + index);
  for (FeatureChain& c : p.chains)
    for (int& i : c.points) i -= i > index;
  return p;
}

nlohmann::json benchProject(const std::string& path, int runs, int drags, double dragPx, int dragPoint,
                            bool previewOnly) {
  const Project base = loadProject(path);
  auto [drag, del] = choosePoints(base);
  if (dragPoint >= 0) {
    TM_CHECK(dragPoint < int(base.points.size()) && !base.points[dragPoint].at.empty(),
             path + ": --drag-point " + std::to_string(dragPoint) + " is not a point with a photo position");
    drag = dragPoint;
    if (del == drag) del = choosePoints(base).first;
  }
  Project dragged = base;
  PhotoPoint& moved = dragged.points[drag].at[0];
  moved.x += moved.x > dragPx + 1 ? -dragPx : dragPx;
  const Project deleted = withoutPoint(dragged, del);
  Project added = deleted;
  FeaturePoint back = base.points[del];
  back.at[0].x += back.at[0].x > 10 ? -1 : 1;
  added.points.push_back(back);

  const bool quick = !previewOnly && quickDiffers(base);
  std::vector<std::pair<std::string, std::pair<const Project*, Tier>>> steps = {{"cold", {&base, Tier::Final}}};
  for (const auto& [name, project] : std::vector<std::pair<std::string, const Project*>>{
           {"drag", &dragged}, {"delete", &deleted}, {"add", &added}, {"undo", &deleted}}) {
    if (quick) steps.push_back({name, {project, Tier::Quick}});
    steps.push_back({quick ? name + "_refine" : name, {project, Tier::Preview}});
  }
  steps.push_back({"final", {&added, Tier::Final}});
  const Tier dragTier = quick ? Tier::Quick : Tier::Preview;
  std::vector<std::vector<Timed>> times(steps.size());
  std::vector<Timed> series;
  for (int r = 0; r < runs; ++r) {
    Pipeline pipeline;
    for (size_t s = 0; s < steps.size(); ++s)
      times[s].push_back(timedRun(pipeline, *steps[s].second.first, steps[s].second.second));
    Project step = added;
    for (int k = 0; k < drags; ++k) {
      step.points[drag].at[0].x += step.points[drag].at[0].x > 10 + drags ? -1 : 1;
      series.push_back(timedRun(pipeline, step, dragTier));
    }
  }
  nlohmann::json out;
  out["project"] = path;
  out["points"] = base.points.size();
  out["drag_px"] = dragPx;
  for (size_t s = 0; s < steps.size(); ++s) {
    std::vector<double> wall, cpu;
    for (const Timed& t : times[s]) wall.push_back(t.wallMs), cpu.push_back(t.cpuMs);
    std::sort(wall.begin(), wall.end());
    std::sort(cpu.begin(), cpu.end());
    out["steps"][steps[s].first] = {{"wall_ms", wall[wall.size() / 2]},
                                    {"cpu_ms", cpu[cpu.size() / 2]},
                                    {"tier", kTierNames[size_t(steps[s].second.second)]},
                                    {"last_run", times[s].back().figures}};
  }
  if (!series.empty()) {
    std::vector<double> wall, cpu;
    for (const Timed& t : series) wall.push_back(t.wallMs), cpu.push_back(t.cpuMs);
    std::sort(wall.begin(), wall.end());
    std::sort(cpu.begin(), cpu.end());
    nlohmann::json each = nlohmann::json::array();  // every drag in order: CPU ms, and per stage CPU s
    for (const Timed& t : series) {
      nlohmann::json stages;
      for (const auto& [stage, f] : t.figures.items())
        if (f.is_object() && f.contains("cpu_seconds")) stages[stage] = f["cpu_seconds"];
      each.push_back({{"cpu_ms", t.cpuMs}, {"stages_cpu_seconds", stages}});
    }
    out["steps"]["drags"] = {
        {"wall_ms", wall[wall.size() / 2]},     {"cpu_ms", cpu[cpu.size() / 2]}, {"each", each},
        {"tier", kTierNames[size_t(dragTier)]}, {"count", series.size()},        {"last_run", series.back().figures}};
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  montage::tuneProcess(argv);
  std::vector<std::string> projects;
  std::string mesh, work, jsonPath;
  int runs = 3, subdivide = 0, drags = 0, dragPoint = -1;
  bool previewOnly = false;
  double dragPx = 3;
  SynthOptions synth;
  synth.views = 9;
  synth.features = 342;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "%s needs a value\n", a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--runs")
      runs = std::max(1, std::stoi(value()));
    else if (a == "--preview-only")
      previewOnly = true;
    else if (a == "--drags")
      drags = std::max(0, std::stoi(value()));
    else if (a == "--drag-px")
      dragPx = std::stod(value());
    else if (a == "--drag-point")
      dragPoint = std::stoi(value());
    else if (a == "--json")
      jsonPath = value();
    else if (a == "--mesh")
      mesh = value();
    else if (a == "--subdivide")
      subdivide = std::stoi(value());
    else if (a == "--views")
      synth.views = std::stoi(value());
    else if (a == "--features")
      synth.features = std::stoi(value());
    else if (a == "--seed")
      synth.seed = static_cast<unsigned>(std::stoul(value()));
    else if (a == "--work")
      work = value();
    else if (a.rfind("--", 0) == 0) {
      std::fprintf(stderr,
                   "usage: %s PROJECT... [--runs N] [--drags K] [--drag-px D] [--drag-point I] [--preview-only] "
                   "[--json FILE]\n"
                   "       %s --mesh M [--subdivide L] [--views K] [--features N] [--seed S] --work DIR [--runs N]\n",
                   argv[0], argv[0]);
      return 2;
    } else
      projects.push_back(a);
  }
  try {
    TM_CHECK(dragPx > 0 && dragPx < 1000, "tm_edit_bench: --drag-px must be in (0, 1000) pixels");
    if (!mesh.empty()) {
      TM_CHECK(!work.empty(), "tm_edit_bench: --mesh needs --work DIR");
      std::unique_ptr<Mesh> m = requireUsable(loadMesh(mesh));
      if (subdivide > 0) m = subdivideMidpoint(*m, subdivide);
      fs::create_directories(work);
      const std::string meshFile = (fs::path(work) / "mesh.obj").string();
      saveMeshObj(*m, meshFile);
      const SynthScene scene = synthesize(*m, meshFile, meshPattern(*m), synth);
      writeSynthScene(scene, work);
      projects.push_back((fs::path(work) / "project.json").string());
      std::fprintf(stderr, "synthesised %s: %d faces, %zu points\n", work.c_str(), m->numFaces(),
                   scene.project.points.size());
    }
    nlohmann::json all;
    all["load_average_before"] = loadAverage();
    all["runs"] = runs;
    for (const std::string& p : projects) {
      std::fprintf(stderr, "benchmarking %s\n", p.c_str());
      all["projects"].push_back(benchProject(p, runs, drags, dragPx, dragPoint, previewOnly));
    }
    all["load_average_after"] = loadAverage();
    all["peak_mib"] = peakMiB();
    const std::string text = all.dump(2) + "\n";
    std::fputs(text.c_str(), stdout);
    if (!jsonPath.empty()) writeFileAtomic(jsonPath, text);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
