// Progress of a pipeline run weighted by each stage's measured time (GL-free). The worker reports the
// stage it is in and the fraction of that stage done; stages take very different times (the mapping
// and inpainting dominate a large project, the load a small one), so counting stages would show 70%
// when inpainting begins. Each stage is weighted by its seconds in the previous run of the same tier,
// and by fixed typical shares before the first run has finished.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "pipeline.h"

namespace montage {

class RunProgress {
 public:
  static constexpr size_t kStages = kStageNames.size();
  // Typical share of a run of `tier` per stage (the first run, before any measurement), summing to 1: the
  // stages' declaration (pipelineStages()).
  static std::array<double, kStages> typicalShares(Tier tier);

  // Records the stage times of a finished run of `tier` (cached stages count 0 s).
  void record(Tier tier, const std::vector<StageRecord>& stages);
  // True when `tier` has measured stage times (a run of it has finished).
  bool measured(Tier tier) const { return measured_[int(tier)]; }
  // Share of a run of `tier` done, 0..1, when it is in `stage` with `fraction` (0..1) of it done.
  double overall(Tier tier, StageId stage, double fraction) const;
  // Estimated seconds left, from the measured seconds still ahead (scaled by how this run's elapsed
  // time compares with the measured time of the part done), or from the elapsed time and the share done
  // with typical shares; negative when there is nothing to go on yet.
  double secondsLeft(Tier tier, StageId stage, double fraction, double elapsedSeconds) const;
  // The status bar's words for the time of the run `runId` (anything that tells runs apart: the worker's
  // start time): "about N s left" (or "N min"), from secondsLeft; "N s so far" once the run has outlasted
  // the end first estimated for it by max(2 s, a quarter), as a run slower than the last or a stage that
  // reports no progress does, instead of an estimate that stays at "about 1 s left"; "" while there is
  // nothing to go on.
  std::string timeText(Tier tier, StageId stage, double fraction, double elapsedSeconds, double runId);

 private:
  std::array<double, kStages> weights(Tier tier) const;  // per stage, summing to 1
  std::array<std::array<double, kStages>, kTierNames.size()> seconds_{};  // by Tier
  std::array<bool, kTierNames.size()> measured_{};
  double estimatedRun_ = -1;    // the run whose end was estimated (timeText's runId)
  double estimatedTotal_ = -1;  // its first estimate of its whole length, seconds
};

}  // namespace montage
