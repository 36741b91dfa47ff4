#include "worker.h"

#include <chrono>
#include <map>

#include "atlas/preview_model.h"

namespace montage {

PipelineWorker::PipelineWorker(std::function<void()> notify)
    : notify_(std::move(notify)), thread_([this] { loop(); }) {}

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

void PipelineWorker::cancel() {
  std::lock_guard<std::mutex> lock(mutex_);
  pending_.reset();
  cancel_ = true;
  wake_.notify_all();
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

bool PipelineWorker::runTier(const Project& project, Tier tier, WorkerOutcome& outcome) {
  try {
    JobControl job(&cancel_, [this](StageId stage, double fraction, const std::string& what) {
      std::lock_guard<std::mutex> guard(mutex_);
      status_.stage = stage;
      status_.fraction = fraction;
      status_.what = what;
    });
    outcome.tier = tier;
    outcome.times.started = std::chrono::steady_clock::now();
    outcome.result = std::make_shared<const PipelineResult>(pipeline_.run(project, job, tier));
    outcome.times.modelStarted = std::chrono::steady_clock::now();
    const PipelineResult& r = *outcome.result;
    if (!r.model && r.mapping && r.colors && r.scene) {
      // The preview model: the photos as textures (converted once per photo), the mapping's faces. The
      // textures are of the photos before colour balance, which the model applies as it reads them
      // (gain and offset per photo), so a balance that moves after each edit converts and uploads no
      // photo again.
      std::vector<cv::Mat> textures;
      std::map<const Photo*, std::pair<std::weak_ptr<const Photo>, cv::Mat>> kept;
      const bool balanced = r.balanced && r.balanced->scene;
      // The photos the colour stages read (balanced ones when colour balance is on), and their sources.
      const Scene& colorScene = balanced ? *r.balanced->scene : *r.scene;
      const std::vector<std::shared_ptr<const Photo>>& sources = balanced ? r.balanced->sources : r.scene->photos;
      // Per photo, the balance the model applies to its texture (none without a balance stage).
      const std::vector<ColorTransform> transforms =
          balanced ? r.balanced->balance.transforms : std::vector<ColorTransform>{};
      for (const auto& p : sources) {
        auto it = photoTextures_.find(p.get());
        const bool reuse = it != photoTextures_.end() && it->second.first.lock() == p;
        textures.push_back(reuse ? it->second.second : previewTexture(*p));
        kept[p.get()] = {p, textures.back()};
      }
      photoTextures_ = std::move(kept);
      outcome.preview = std::make_shared<const TexturedModel>(
          previewModel(r.mapping->partition->mesh, r.mapping->map, colorScene.photos, textures, &r.colors->levelling,
                       &r.colors->inpaint, transforms, {}, tier == Tier::Quick));
    }
    return true;
  } catch (const Cancelled&) {
    return false;
  } catch (const std::exception& e) {
    outcome.result.reset();
    outcome.preview.reset();
    outcome.error = e.what();
    return true;
  }
}

void PipelineWorker::loop() {
  // The worker runs at normal priority: the UI thread never waits for it (it takes finished results
  // from a slot), and it redraws only on input, animation and worker progress.
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    wake_.wait(lock, [this] { return quit_ || pending_; });
    if (quit_) return;
    std::shared_ptr<const Project> project = std::move(pending_);
    pending_.reset();
    const long generation = pendingGeneration_;
    cancel_ = false;
    // The quick preview first where it differs from the preview (issue 36): the edit shows at once, and the
    // preview's fills follow.
    std::vector<Tier> tiers = {Tier::Preview, Tier::Final};
    if (quickDiffers(*project)) tiers.insert(tiers.begin(), Tier::Quick);
    for (Tier tier : tiers) {
      status_ = WorkerStatus{true, tier,       tier == tiers.front(),           StageId::Load, 0,
                             "",   generation, std::chrono::steady_clock::now()};
      lock.unlock();
      WorkerOutcome outcome;
      outcome.generation = generation;
      const bool finished = runTier(*project, tier, outcome);
      lock.lock();
      status_.busy = false;
      // A cancelled run, or one overtaken by a newer snapshot, publishes nothing: the newest wins.
      const bool overtaken = !finished || pending_ || quit_;
      const bool succeeded = finished && outcome.result;
      outcome.times.finished = std::chrono::steady_clock::now();
      if (!overtaken) finished_ = std::move(outcome);
      wake_.notify_all();
      if (!overtaken && notify_) notify_();
      // The next tier follows only when this one succeeded and nothing newer is waiting.
      if (overtaken || !succeeded) break;
    }
  }
}

}  // namespace montage
