#include "base/process_tuning.h"

#include <dlfcn.h>
#include <sys/prctl.h>
#include <unistd.h>

#include <tbb/global_control.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <string>
#include <utility>
#include <vector>
#include <opencv2/core/utility.hpp>

#include "base/common.h"

namespace montage {

namespace {

// "off" (set by the user) or the names this function added, comma-separated (set for the new start).
constexpr const char* kSwitch = "TEXTUREMONTAGE_TUNING";

// hugetlb=1: madvise(MADV_HUGEPAGE) on the heap and on mapped blocks (glibc 2.35+; older versions ignore
// it); mmap_threshold: blocks up to 1 GB come from the heap; trim_threshold: freed memory stays for the
// next buffers unless a gigabyte of it lies free at the top of the heap.
constexpr const char* kGlibc =
    "glibc.malloc.hugetlb=1:glibc.malloc.mmap_threshold=1000000000:glibc.malloc.trim_threshold=1000000000";
// 2^4 cycles of spinning before a BLAS thread sleeps (OpenBLAS clamps the value to 4..30; default 28).
constexpr const char* kBlasTimeout = "4";

bool isSet(const char* name) {
  return std::getenv(name) != nullptr;
}

}  // namespace

void tuneProcess(char** argv) {
#if defined(__GLIBC__) && defined(__linux__)
  if (const char* value = std::getenv(kSwitch)) {
    if (std::strcmp(value, "off") != 0) {  // the new start: the settings are in effect; do not pass them on
      std::string names = value;
      for (size_t start = 0; start < names.size();) {
        const size_t end = std::min(names.find(',', start), names.size());
        unsetenv(names.substr(start, end - start).c_str());
        start = end + 1;
      }
      unsetenv(kSwitch);
      // The new start of "/proc/self/exe" is named "exe" (after the file exec was given): the program's
      // own name again, as the first start had it, for ps, top and pkill (the kernel keeps 15 bytes).
      if (argv != nullptr && argv[0] != nullptr) {
        const char* slash = std::strrchr(argv[0], '/');
        prctl(PR_SET_NAME, slash ? slash + 1 : argv[0]);
      }
    }
    return;
  }
  if (argv == nullptr || argv[0] == nullptr) return;
  if (const char* preload = std::getenv("LD_PRELOAD"); preload && std::strstr(preload, "vgpreload")) return;
  std::vector<std::pair<const char*, const char*>> add;
  if (!isSet("GLIBC_TUNABLES")) add.emplace_back("GLIBC_TUNABLES", kGlibc);
  if (!isSet("OPENBLAS_THREAD_TIMEOUT") && !isSet("GOTO_THREAD_TIMEOUT"))
    add.emplace_back("OPENBLAS_THREAD_TIMEOUT", kBlasTimeout);
  if (add.empty()) return;
  std::string names;
  bool set = true;
  for (const auto& [name, value] : add) {
    set = set && setenv(name, value, 1) == 0;
    names += (names.empty() ? "" : ",") + std::string(name);
  }
  if (set && setenv(kSwitch, names.c_str(), 1) == 0) execv("/proc/self/exe", argv);
  for (const auto& [name, value] : add) unsetenv(name);  // could not start again: run as it is
  unsetenv(kSwitch);
#else
  (void)argv;
#endif
}

struct ThreadLimit::State {
  explicit State(int threads)
      : control(tbb::global_control::max_allowed_parallelism, size_t(threads)), openCvThreads(cv::getNumThreads()) {}
  tbb::global_control control;
  int openCvThreads;
};

ThreadLimit::ThreadLimit(int threads) {
  TM_CHECK(threads >= 1, "--threads: " + std::to_string(threads) + " is not a number of threads (1 or more)");
  state_ = std::make_unique<State>(threads);
  cv::setNumThreads(threads);
  using SetThreads = void (*)(int);
  if (auto set = reinterpret_cast<SetThreads>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"))) set(threads);
}

ThreadLimit::~ThreadLimit() { cv::setNumThreads(state_->openCvThreads); }

}  // namespace montage
