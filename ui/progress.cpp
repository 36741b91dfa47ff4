#include "progress.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>

namespace montage {

std::array<double, RunProgress::kStages> RunProgress::typicalShares(Tier tier) {
  // As pipelineStages() declares them (the preview stops before the bake and the export).
  const std::vector<double> declared = pipelineStages().typicalShares(isPreview(tier));
  std::array<double, kStages> shares{};
  std::copy_n(declared.begin(), std::min(declared.size(), kStages), shares.begin());
  return shares;
}

void RunProgress::record(Tier tier, const std::vector<StageRecord>& stages) {
  auto& s = seconds_[int(tier)];
  s.fill(0);
  for (const StageRecord& r : stages)
    if (static_cast<size_t>(r.stage) < kStages) s[static_cast<size_t>(r.stage)] += r.cached ? 0 : r.seconds;
  // A run that took no measurable time (everything cached) says nothing about the next one.
  measured_[int(tier)] = std::accumulate(s.begin(), s.end(), 0.0) > 0.05;
}

std::array<double, RunProgress::kStages> RunProgress::weights(Tier tier) const {
  std::array<double, kStages> w{};
  if (measured_[int(tier)])
    w = seconds_[int(tier)];
  else
    w = typicalShares(tier);
  const double total = std::accumulate(w.begin(), w.end(), 0.0);
  for (double& x : w) x = total > 0 ? x / total : 1.0 / kStages;
  return w;
}

double RunProgress::overall(Tier tier, StageId stage, double fraction) const {
  const auto w = weights(tier);
  const int current = static_cast<int>(stage);
  double done = 0;
  for (int s = 0; s < current; ++s) done += w[s];
  done += w[current] * std::clamp(fraction, 0.0, 1.0);
  return std::clamp(done, 0.0, 1.0);
}

double RunProgress::secondsLeft(Tier tier, StageId stage, double fraction, double elapsedSeconds) const {
  const double done = overall(tier, stage, fraction);
  if (measured_[int(tier)]) {
    const auto& s = seconds_[int(tier)];
    const double total = std::accumulate(s.begin(), s.end(), 0.0);
    const double left = total * (1 - done), before = total * done;
    // This run may be faster (cached stages) or slower (a larger edit) than the last: scale the measured
    // time still ahead by the ratio of elapsed to measured for the part done, once that part is large
    // enough to say something.
    const double ratio = before > 0.5 && elapsedSeconds > 0 ? std::clamp(elapsedSeconds / before, 0.25, 4.0) : 1.0;
    return left * ratio;
  }
  if (done < 0.05 || elapsedSeconds <= 0) return -1;
  return elapsedSeconds * (1 - done) / done;
}

std::string RunProgress::timeText(Tier tier, StageId stage, double fraction, double elapsedSeconds, double runId) {
  const double left = secondsLeft(tier, stage, fraction, elapsedSeconds);
  if (runId != estimatedRun_) {
    estimatedRun_ = runId;
    estimatedTotal_ = -1;
  }
  if (estimatedTotal_ < 0 && left >= 0) estimatedTotal_ = elapsedSeconds + left;
  char text[48];
  const auto duration = [&](double seconds, const char* what) {
    if (seconds < 60)
      std::snprintf(text, sizeof(text), "%.0f s %s", std::max(1.0, std::ceil(seconds)), what);
    else
      std::snprintf(text, sizeof(text), "%.0f min %s", std::ceil(seconds / 60), what);
    return std::string(text);
  };
  if (estimatedTotal_ >= 0 && elapsedSeconds > estimatedTotal_ + std::max(2.0, 0.25 * estimatedTotal_))
    return duration(std::floor(elapsedSeconds), "so far");
  if (left < 0) return "";
  return "about " + duration(left, "left");
}

}  // namespace montage
