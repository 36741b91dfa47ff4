// Where colour balance runs: the pipeline's order (balance over the final map, then seam optimisation on
// the balanced photos) against the other one (seam optimisation on the photos as taken, then balance over
// the seamed map). Writes both results for `montage eval` and prints the seams' figures.
//   tm_balance_order_bench PROJECT OUT_PIPELINE OUT_SEAMS_FIRST
// docs/pipeline.md ("Balance", where it runs) has the figures.
#include <cstdio>

#include "base/util.h"
#include "pipeline.h"

using namespace montage;

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: tm_balance_order_bench PROJECT OUT_PIPELINE OUT_SEAMS_FIRST\n");
    return 2;
  }
  try {
    const Project project = loadProject(argv[1]);
    Pipeline pipeline;
    const PipelineResult balanceFirst = pipeline.run(project);
    writeRunOutputs(balanceFirst, argv[2]);

    // Seams first: on the photos as loaded, then the balance over the seamed map.
    auto start = Clock::now();
    SeamResult seams;
    const auto seamed = optimiseMappingSeams(*balanceFirst.scene, balanceFirst.projection->mapping,
                                             &balanceFirst.projection->result.projected, seams);
    const double seamSeconds = secondsSince(start);
    const auto balanced = std::make_shared<const BalancedScene>(balanceScene(balanceFirst.scene, *seamed));
    const auto colors = std::make_shared<const SurfaceColors>(colorSurface(*balanced->scene, *seamed));
    const auto baked = std::make_shared<const BakeResult>(bakeModel(*balanced->scene, *seamed, *colors));
    PipelineResult seamsFirst;
    seamsFirst.scene = balanceFirst.scene;
    seamsFirst.cameras = balanceFirst.cameras;
    seamsFirst.projection = balanceFirst.projection;
    seamsFirst.mapping = seamed;
    seamsFirst.balanced = balanced;
    seamsFirst.colors = colors;
    seamsFirst.baked = baked;
    seamsFirst.model = std::shared_ptr<const TexturedModel>(baked, &baked->model);
    seamsFirst.exported = std::shared_ptr<const TexturedModel>(baked, &baked->exported());
    writeRunOutputs(seamsFirst, argv[3]);

    const SeamResult& a = *balanceFirst.seams;
    std::printf("balance, then seams: seam dE %.2f -> %.2f (balanced photos), moved %d, sleeping %d, rounds %d\n",
                a.deltaEBefore, a.deltaEAfter, a.movedSides, a.sleepingSides, a.rounds);
    std::printf(
        "seams, then balance: seam dE %.2f -> %.2f (photos as taken), moved %d, sleeping %d, rounds %d, %.1f s\n",
        seams.deltaEBefore, seams.deltaEAfter, seams.movedSides, seams.sleepingSides, seams.rounds, seamSeconds);
    std::printf("balance mismatch: pipeline %.2f -> %.2f, seams first %.2f -> %.2f dE\n",
                balanceFirst.balanced->balance.mismatchBefore, balanceFirst.balanced->balance.mismatchAfter,
                balanced->balance.mismatchBefore, balanced->balance.mismatchAfter);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
