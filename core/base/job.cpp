#include "base/job.h"

#include <chrono>
#include <condition_variable>
#include <exception>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

namespace montage {

namespace {

// One runCancellable call's hand-off between its thread and the caller.
struct CancellableState {
  std::mutex mutex;
  std::condition_variable doneSignal;
  bool done = false;
  std::exception_ptr error;
};

// Threads of cancelled calls, still finishing work nobody waits for. Joined when they are done (by the
// next call) or at exit (this object is built on first use, after the libraries' static objects, so it is
// destroyed before them).
class AbandonedCalls {
 public:
  ~AbandonedCalls() {
    for (auto& [thread, state] : calls_) thread.join();
  }
  void add(std::thread thread, std::shared_ptr<CancellableState> state) {
    std::lock_guard lock(mutex_);
    calls_.emplace_back(std::move(thread), std::move(state));
  }
  // Joins the calls that have finished; returns how many still run.
  size_t reap() {
    std::lock_guard lock(mutex_);
    for (size_t i = 0; i < calls_.size();) {
      bool done = false;
      {
        std::lock_guard stateLock(calls_[i].second->mutex);
        done = calls_[i].second->done;
      }
      if (!done) {
        ++i;
        continue;
      }
      calls_[i].first.join();
      calls_.erase(calls_.begin() + static_cast<long>(i));
    }
    return calls_.size();
  }

 private:
  std::mutex mutex_;
  std::vector<std::pair<std::thread, std::shared_ptr<CancellableState>>> calls_;
};

AbandonedCalls& abandonedCalls() {
  static AbandonedCalls calls;
  return calls;
}

constexpr auto kCancelPoll = std::chrono::milliseconds(20);

}  // namespace

void JobControl::checkCancel() const {
  if (cancelled()) throw Cancelled();
}

void JobControl::progress(StageId stage, double fraction, const std::string& what) const {
  checkCancel();
  if (!callback_) return;
  std::lock_guard<std::mutex> lock(*callbackMutex_);
  callback_(stage, fraction, what);
}

void runCancellable(const JobControl& job, const std::function<void()>& work) {
  if (!job.cancellable()) {
    work();
    return;
  }
  while (abandonedCalls().reap() > 0) {
    job.checkCancel();
    std::this_thread::sleep_for(kCancelPoll);
  }
  job.checkCancel();
  auto state = std::make_shared<CancellableState>();
  // The thread holds its own copy of `work` (and so of what it captured) and of the state.
  std::thread thread([state, work] {
    std::exception_ptr error;
    try {
      work();
    } catch (...) {
      error = std::current_exception();
    }
    std::lock_guard lock(state->mutex);
    state->error = error;
    state->done = true;
    state->doneSignal.notify_all();
  });
  {
    std::unique_lock lock(state->mutex);
    while (!state->done) {
      state->doneSignal.wait_for(lock, kCancelPoll);
      if (!state->done && job.cancelled()) {
        lock.unlock();
        abandonedCalls().add(std::move(thread), state);
        throw Cancelled();
      }
    }
  }
  thread.join();
  if (state->error) std::rethrow_exception(state->error);
}

}  // namespace montage
