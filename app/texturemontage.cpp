// `texturemontage`: the editor. Opens a project (.json) or a mesh, and lets the user click
// correspondences between the mesh and the photos while a background worker reruns the pipeline.
//   texturemontage [FILE] [--script S] [--screenshot PNG --frames N] [--autosave-seconds S]
//                  [--size WxH] [--bench-orbit MESH | --bench-worker] [--bench-frames N]
// docs/editor.md describes the window, the tools, the shortcuts and the script format.
#include <CLI/CLI.hpp>
#include <cstdio>

#include "base/process_tuning.h"
#include "editor.h"
#include "io/mesh_io.h"

using namespace montage;

int main(int argc, char** argv) {
  montage::tuneProcess(argv);
  CLI::App app{"TextureMontage editor: texture a mesh from a few photos (Zhou et al. 2005)", "texturemontage"};
  EditorOptions options;
  std::string size = "1280x800";
  bool noWait = false, noVsync = false;
  app.add_option("FILE", options.file, "project (.json) or mesh (" + montage::meshExtensionList() + ") to open");
  app.add_option("--script", options.script, "run a script of UI actions (docs/editor.md)");
  app.add_option("--screenshot", options.screenshot,
                 "render, save the window as this PNG and exit (waits for the worker's result first)");
  app.add_option("--frames", options.frames, "frames to render before the screenshot")->check(CLI::Range(1, 100000));
  app.add_flag("--no-wait", noWait, "--screenshot: do not wait for the worker's result");
  app.add_option("--autosave-seconds", options.autosaveSeconds, "autosave interval in seconds (default 120)")
      ->check(CLI::Range(0.1, 86400.0));
  app.add_option("--size", size, "window size, WIDTHxHEIGHT (default 1280x800)");
  app.add_option("--bench-orbit", options.benchOrbit, "benchmark: orbit this mesh and print frame times");
  app.add_flag("--bench-worker", options.benchWorker,
               "benchmark: orbit FILE while the worker reruns the pipeline; print UI frame times");
  app.add_flag("--bench-overlays", options.benchOverlays,
               "benchmark: orbit FILE's result with every overlay shown and with none, alternating; print both");
  app.add_option("--bench-frames", options.benchFrames, "benchmark: frames to measure (default 240)")
      ->check(CLI::Range(10, 100000));
  app.add_flag("--no-vsync", noVsync, "do not wait for the display's refresh");
  app.add_option("--scale", options.scale, "UI scale for fonts and sizes (HiDPI; default: the monitor's content scale)")
      ->check(CLI::Range(0.5, 4.0));
  CLI11_PARSE(app, argc, argv);
  try {
    int w = 0, h = 0;
    char x = 0;
    TM_CHECK(std::sscanf(size.c_str(), "%d%c%d", &w, &x, &h) == 3 && x == 'x' && w >= 320 && h >= 240 && w <= 16384 &&
                 h <= 16384,
             "--size: '" + size + "' is not WIDTHxHEIGHT (at least 320x240)");
    options.width = w;
    options.height = h;
    options.waitWorker = !noWait;
    options.vsync = !noVsync;
    TM_CHECK(!options.benchWorker || !options.file.empty(), "--bench-worker: give the project to run (FILE)");
    TM_CHECK(!options.benchOverlays || !options.file.empty(), "--bench-overlays: give the project to orbit (FILE)");
    Editor editor(options);
    return editor.run();
  } catch (const std::exception& e) {  // montage::Error and anything else: one line, exit status 1
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
