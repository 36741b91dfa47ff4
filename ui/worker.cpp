#include "worker.h"

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <chrono>

namespace montage {

PipelineWorker::PipelineWorker() : thread_([this] { loop(); }) {}

PipelineWorker::~PipelineWorker() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    quit_ = true;
    cancel_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

long PipelineWorker::submit(std::shared_ptr<const Project> snapshot) {
  std::lock_guard<std::mutex> lock(mutex_);
  pending_ = std::move(snapshot);
  pendingGeneration_ = ++nextGeneration_;
  cancel_ = true;  // the running job (if any) stops at its next progress point
  wake_.notify_all();
  return pendingGeneration_;
}

std::optional<WorkerOutcome> PipelineWorker::take() {
  std::lock_guard<std::mutex> lock(mutex_);
  std::optional<WorkerOutcome> out = std::move(finished_);
  finished_.reset();
  return out;
}

WorkerStatus PipelineWorker::status() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return status_;
}

bool PipelineWorker::waitIdle(double timeoutSeconds) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeoutSeconds);
  std::unique_lock<std::mutex> lock(mutex_);
  return wake_.wait_until(lock, deadline, [this] { return !pending_ && !status_.busy; });
}

void PipelineWorker::loop() {
  // The UI thread (and Mesa's rendering threads) must win the CPU over the pipeline: the worker
  // thread, and any thread a stage starts from it, runs at a lower priority (Linux nice is per
  // thread and inherited). Best effort: failing leaves the default priority.
  setpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)), 10);
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    wake_.wait(lock, [this] { return quit_ || pending_; });
    if (quit_) return;
    std::shared_ptr<const Project> project = std::move(pending_);
    pending_.reset();
    const long generation = pendingGeneration_;
    cancel_ = false;
    status_ = WorkerStatus{true, StageId::Load, 0, "", generation};
    lock.unlock();

    WorkerOutcome outcome;
    outcome.generation = generation;
    bool cancelled = false;
    try {
      JobControl job(&cancel_, [this](StageId stage, double fraction, const std::string& what) {
        std::lock_guard<std::mutex> guard(mutex_);
        status_.stage = stage;
        status_.fraction = fraction;
        status_.what = what;
      });
      outcome.result = std::make_shared<const PipelineResult>(pipeline_.run(*project, job));
    } catch (const Cancelled&) {
      cancelled = true;
    } catch (const std::exception& e) {
      outcome.error = e.what();
    }

    lock.lock();
    status_.busy = false;
    // A cancelled run, or one overtaken by a newer snapshot, publishes nothing: the newest wins.
    if (!cancelled && !pending_) finished_ = std::move(outcome);
    wake_.notify_all();
  }
}

}  // namespace montage
