// Progress reporting and cancellation of a pipeline job, and the names of the pipeline's stages. Every
// stage takes a JobControl; it lives here, below the stages, so that nothing under core/ includes the
// pipeline that sits on top of them.
#pragma once

#include <array>
#include <atomic>
#include <functional>
#include <memory>
#include <mutex>
#include <string>

#include "base/common.h"

namespace montage {

// The stages, in pipeline order (paper Figure 2): load, camera (a camera fit per photo), partition
// (3.1), map (per cell: progressive mesh 3.2 and coarse-to-fine 4.1), projection (photos that fit a
// camera: projection mapping and view selection), balance (colour balance between photos, the paper's
// Photoshop step, over the seams of the final map), seams (content-based seam optimisation 4.2-4.3, over
// the final map and the balanced photos), level (seam levelling, end of 5), inpaint (5: holes, strokes,
// clones), bake (atlas: charts, LSCM, packing, baking), export.
enum class StageId { Load, Camera, Partition, Map, Projection, Balance, Seams, Level, Inpaint, Bake, Export };
inline constexpr std::array<const char*, 11> kStageNames = {
    "load", "camera", "partition", "map", "projection", "balance", "seams", "level", "inpaint", "bake", "export"};
inline const char* stageName(StageId s) {
  return kStageNames[static_cast<int>(s)];
}

// Progress reporting and cancellation for one job. Stages call progress() at convenient points;
// it throws montage::Cancelled when the cancel flag is set. Stages that run side by side may call it
// from several threads: the callback is called under a lock, one call at a time.
class JobControl {
 public:
  using Callback = std::function<void(StageId stage, double fraction, const std::string& what)>;
  JobControl() = default;
  JobControl(const std::atomic<bool>* cancel, Callback callback)
      : cancel_(cancel), callback_(std::move(callback)), callbackMutex_(std::make_shared<std::mutex>()) {}
  void progress(StageId stage, double fraction, const std::string& what = "") const;
  void checkCancel() const;
  bool cancelled() const { return cancel_ && cancel_->load(std::memory_order_relaxed); }
  bool cancellable() const { return cancel_ != nullptr; }

 private:
  const std::atomic<bool>* cancel_ = nullptr;
  Callback callback_;
  std::shared_ptr<std::mutex> callbackMutex_;  // shared by copies of this JobControl
};

// Runs `work`, a long call that has no cancellation point of its own (OpenCV's shift-map inpainting), so
// that a cancel takes effect within a few tens of milliseconds: `work` runs on a thread of its own while
// this thread checks `job`. Without a cancel flag (`montage run`) `work` simply runs here. Exceptions of
// `work` are rethrown here. On cancel this throws Cancelled at once and leaves `work` to finish on its
// thread, so `work` must own everything it touches (capture by value, results through a shared_ptr): the
// thread is joined later, by the next call or at exit. At most one abandoned call runs at a time: a new
// call first waits (cancellably) for it, so repeated cancels do not pile up threads.
void runCancellable(const JobControl& job, const std::function<void()>& work);

}  // namespace montage
