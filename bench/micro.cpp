// tm_microbench: timings of the core building blocks (mesh loading, rasterisation, BVH queries).
// Prints figures; asserts nothing. Pipeline stage timings are `montage bench`.
#include <sys/resource.h>
#include <time.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <string>

#include "io/mesh_io.h"
#include "geometry/bvh.h"
#include "geometry/mesh.h"
#include "geometry/raster.h"
#include "geometry/shapes.h"

using namespace montage;
namespace fs = std::filesystem;

namespace {

// CPU time of the calling thread, milliseconds (wall time is noisy on a shared machine).
double threadCpuMs() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

template <class Fn>
double bestCpuMs(int runs, Fn&& fn) {
  double best = std::numeric_limits<double>::infinity();
  for (int r = 0; r < runs; ++r) {
    const double t0 = threadCpuMs();
    fn();
    best = std::min(best, threadCpuMs() - t0);
  }
  return best;
}

std::string writeGridObj(int nx, int ny) {
  const std::string path = (fs::temp_directory_path() / "tm_microbench_grid.obj").string();
  std::ofstream out(path);
  char line[96];
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i)
      out.write(line, std::snprintf(line, sizeof line, "v %.6f %.6f %.6f\n", i * 1e-3, j * 1e-3, 1e-4 * ((i * j) % 7)));
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const int a = j * (nx + 1) + i + 1, b = a + 1, c = a + nx + 1, d = c + 1;
      out.write(line, std::snprintf(line, sizeof line, "f %d %d %d\nf %d %d %d\n", a, b, d, a, d, c));
    }
  return path;
}

}  // namespace

int main() {
  const std::string objPath = writeGridObj(1000, 500);  // 1M triangles
  LoadedMesh loaded;
  const double loadMs = bestCpuMs(1, [&] { loaded = loadMesh(objPath); });
  std::printf("load 1M-face OBJ            %8.1f ms  (%d faces)\n", loadMs, loaded.report.faces);
  fs::remove(objPath);

  const auto sphere = makeIcosphere(6);  // 81920 faces
  const Camera cam = Camera::lookAt(Vec3(0, 0, 2.6), Vec3::Zero(), Vec3(0, 1, 0), 45, 1024, 1024);
  RasterBuffers rb;
  const double rasterMs = bestCpuMs(5, [&] { rb = rasterize(*sphere, cam); });
  std::printf("rasterize 82k faces @1024^2 %8.1f ms\n", rasterMs);

  std::unique_ptr<TriangleBvh> bvh;
  const double buildMs = bestCpuMs(3, [&] { bvh = std::make_unique<TriangleBvh>(*sphere); });
  std::mt19937 rng(1);
  std::normal_distribution<double> n(0, 1);
  std::uniform_real_distribution<double> r(0.9, 1.1);
  const int queries = 1000000;
  double sum = 0;
  const double queryMs = bestCpuMs(1, [&] {  // points near the surface, as evaluation queries are
    for (int i = 0; i < queries; ++i) sum += bvh->closest(Vec3(n(rng), n(rng), n(rng)).normalized() * r(rng)).distance;
  });
  std::printf("BVH build 82k faces         %8.1f ms\n", buildMs);
  std::printf("BVH 1M closest points       %8.1f ms  (%.2f us each, checksum %.3f)\n", queryMs,
              1000 * queryMs / queries, sum);
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  std::printf("peak memory                 %8.1f MiB\n", usage.ru_maxrss / 1024.0);
  return 0;
}
