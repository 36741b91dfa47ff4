// The background worker of the editor: one thread owns a core Pipeline and runs it on immutable
// project snapshots. Submitting a new snapshot cancels the running job; the newest snapshot wins.
// Finished results wait in a mutex-guarded slot until the UI thread takes them. The worker never
// touches ImGui, GL or the live document.
#pragma once

#include <atomic>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "pipeline.h"

namespace montage {

struct WorkerStatus {
  bool busy = false;
  StageId stage = StageId::Load;
  double fraction = 0;  // of the current stage
  std::string what;     // what the stage is doing
  long generation = 0;  // snapshot being worked on (or last finished)
};

// What one run produced: a result or an error message, for snapshot `generation`.
struct WorkerOutcome {
  long generation = 0;
  std::shared_ptr<const PipelineResult> result;  // null when the run failed
  std::string error;                             // empty on success
};

class PipelineWorker {
 public:
  PipelineWorker();
  ~PipelineWorker();  // cancels the running job and joins the thread
  PipelineWorker(const PipelineWorker&) = delete;
  PipelineWorker& operator=(const PipelineWorker&) = delete;

  // Hands the worker a snapshot; cancels any job still running. Returns its generation number.
  long submit(std::shared_ptr<const Project> snapshot);
  // The newest finished outcome not yet taken, if any. Never blocks on the running job.
  std::optional<WorkerOutcome> take();
  WorkerStatus status() const;
  // Blocks until the worker is idle (tests and batch use); returns false on timeout.
  bool waitIdle(double timeoutSeconds);

 private:
  void loop();

  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::shared_ptr<const Project> pending_;
  long pendingGeneration_ = 0;
  long nextGeneration_ = 0;
  std::optional<WorkerOutcome> finished_;
  WorkerStatus status_;
  std::atomic<bool> cancel_{false};
  bool quit_ = false;
  Pipeline pipeline_;   // owned and used by the worker thread only
  std::thread thread_;  // last: started after every other member exists
};

}  // namespace montage
