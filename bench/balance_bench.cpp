// Colour balance: every transform (gain, gain + offset; on linear RGB or on sRGB values) with every loss
// (least squares, Huber, Cauchy) on one project's mapping. Prints the transforms, the seam mismatch before
// and after, and, given the exposures the photos were taken with (montage synth --exposure), the error of
// the recovered gains against the true ones.
//   tm_balance_bench PROJECT [EXPOSURES e.g. 1,0.55,1.3,0.8] [LOCKED photo, default 0] [NAME=VALUE...]
// NAME=VALUE sets a BalanceOptions field: channelPrior, offsetSigma, flatRadiusPx, flatRange, darkest.
#include <cstdio>
#include <sstream>

#include "base/job.h"
#include "base/util.h"
#include "pipeline.h"

using namespace montage;

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: tm_balance_bench PROJECT [EXPOSURES] [LOCKED]\n");
    return 2;
  }
  try {
    Project project = loadProject(argv[1]);
    std::vector<double> exposures;
    if (argc > 2) {
      std::stringstream in(argv[2]);
      for (std::string item; std::getline(in, item, ',');) exposures.push_back(std::stod(item));
    }
    const int lockedPhoto = argc > 3 ? std::stoi(argv[3]) : 0;
    BalanceOptions base;
    for (int i = 4; i < argc; ++i) {
      const std::string arg = argv[i];
      const size_t eq = arg.find('=');
      const std::string name = arg.substr(0, eq);
      const double value = std::stod(arg.substr(eq + 1));
      if (name == "channelPrior")
        base.channelPrior = value;
      else if (name == "offsetSigma")
        base.offsetSigma = value;
      else if (name == "flatRadiusPx")
        base.flatRadiusPx = value;
      else if (name == "flatRange")
        base.flatRange = value;
      else if (name == "darkest")
        base.darkest = value;
      else
        throw Error("unknown option " + name);
    }
    auto scene = loadScene(project);
    const auto start = Clock::now();
    const Mapping mapping = mapTexture(*scene);
    std::printf("%s: %zu photos, mapping %.2f s\n", argv[1], scene->photos.size(), secondsSince(start));
    std::vector<const Photo*> photos;
    for (const auto& p : scene->photos) photos.push_back(p.get());
    std::vector<bool> locked(photos.size(), false);
    locked.at(lockedPhoto) = true;
    for (BalanceMode mode : {BalanceMode::Gain, BalanceMode::GainOffset})
      for (bool linear : {true, false})
        for (BalanceLoss loss : {BalanceLoss::L2, BalanceLoss::Huber, BalanceLoss::Cauchy}) {
          BalanceOptions options = base;
          options.mode = mode;
          options.linear = linear;
          options.loss = loss;
          const ColorBalance b = balanceColors(mapping.partition->mesh, mapping.map, photos, locked, options, {});
          double worst = 0;
          std::string gains;
          for (size_t p = 0; p < photos.size(); ++p) {
            const ColorTransform& t = b.transforms[p];
            char text[160];
            std::snprintf(text, sizeof text, " [%.3f %.3f %.3f | %+.3f %+.3f %+.3f]", t.gain[0], t.gain[1], t.gain[2],
                          t.offset[0], t.offset[1], t.offset[2]);
            gains += text;
            if (linear && p < exposures.size() && exposures.size() > size_t(lockedPhoto)) {
              const double truth = exposures[lockedPhoto] / exposures[p];
              for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(t.gain[c] / truth - 1));
            }
          }
          std::printf(
              "%-11s %-6s %-6s samples %5d outliers %4.1f%% iterations %2d  mismatch %6.2f -> %6.2f dE  %s%s\n",
              kBalanceModeNames[size_t(mode)], linear ? "linear" : "srgb", kBalanceLossNames[size_t(loss)], b.samples,
              100 * b.outlierShare, b.iterations, b.mismatchBefore, b.mismatchAfter,
              exposures.empty() || !linear ? "" : ("worst gain error " + std::to_string(100 * worst) + "%").c_str(),
              gains.c_str());
        }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
