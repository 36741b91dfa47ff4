// The process's CPU time, for the benchmarks' figures (CPU beside wall time on a shared machine).
#pragma once

#include <sys/resource.h>

namespace montage {

// User + system CPU seconds this process has used so far (all its threads).
inline double cpuSeconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

}  // namespace montage
