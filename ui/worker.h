// The background worker of the editor: one thread owns a core Pipeline and runs it on immutable
// project snapshots, in tiers: first the preview (the mapping, levelling and a light inpainting,
// shown through a preview model whose faces sample the photos on the GPU), preceded by the quick preview
// (every hole harmonic) where the two differ, then, when no newer snapshot is waiting, the final bake of
// the same snapshot, which replaces the preview. Submitting a new
// snapshot cancels the running job; the newest snapshot wins. Finished results wait in a mutex-guarded
// slot until the UI thread takes them. The worker never touches ImGui, GL or the live document.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "pipeline.h"

namespace montage {

struct WorkerStatus {
  bool busy = false;
  Tier tier = Tier::Preview;  // of the run in progress (or the last one)
  bool first = true;          // the snapshot's first tier: what the user waits for after an edit
  StageId stage = StageId::Load;
  double fraction = 0;                            // of the current stage
  std::string what;                               // what the stage is doing
  long generation = 0;                            // snapshot being worked on (or last finished)
  std::chrono::steady_clock::time_point started;  // when the run of this tier started
};

// When the worker took a snapshot, started the preview model (the pipeline run before it) and published
// the outcome: the editor's latency figures are split by them.
struct OutcomeTimes {
  std::chrono::steady_clock::time_point started, modelStarted, finished;
};

// What one run produced: a result or an error message, for snapshot `generation`.
struct WorkerOutcome {
  long generation = 0;
  Tier tier = Tier::Preview;
  std::shared_ptr<const PipelineResult> result;  // null when the run failed
  std::shared_ptr<const TexturedModel> preview;  // preview tier: previewModel() of the result (surface/preview.h)
  std::string error;                             // empty on success
  OutcomeTimes times;
};

class PipelineWorker {
 public:
  // `notify` (may be empty) is called from the worker thread whenever an outcome is ready to take (the
  // editor wakes its event loop with it).
  explicit PipelineWorker(std::function<void()> notify = {});
  ~PipelineWorker();  // cancels the running job and joins the thread
  PipelineWorker(const PipelineWorker&) = delete;
  PipelineWorker& operator=(const PipelineWorker&) = delete;

  // Hands the worker a snapshot; cancels any job still running. Returns its generation number.
  long submit(std::shared_ptr<const Project> snapshot);
  // Stops the running job at its next progress point and drops a snapshot still waiting; nothing is
  // published for them (the last outcome taken stays the newest). The next submit runs again.
  void cancel();
  // The newest finished outcome not yet taken, if any. Never blocks on the running job.
  std::optional<WorkerOutcome> take();
  WorkerStatus status() const;
  // Blocks until the worker is idle, the final tier included (tests and batch use); false on timeout.
  bool waitIdle(double timeoutSeconds);

 private:
  void loop();
  // Runs one tier of `project`; fills `outcome`, returns false when cancelled.
  bool runTier(const Project& project, Tier tier, WorkerOutcome& outcome);

  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::shared_ptr<const Project> pending_;
  long pendingGeneration_ = 0;
  long nextGeneration_ = 0;
  std::optional<WorkerOutcome> finished_;
  WorkerStatus status_;
  std::atomic<bool> cancel_{false};
  bool quit_ = false;
  std::function<void()> notify_;
  Pipeline pipeline_;  // owned and used by the worker thread only
  // Worker thread only: each photo's preview texture (previewTexture), while the pipeline keeps the photo.
  std::map<const Photo*, std::pair<std::weak_ptr<const Photo>, cv::Mat>> photoTextures_;
  std::thread thread_;  // last: started after every other member exists
};

}  // namespace montage
