// base/process_tuning: the programs start again with glibc's malloc and OpenBLAS tuned, the user's own
// settings win, TEXTUREMONTAGE_TUNING=off leaves the process alone, and programs they run inherit
// nothing. Each case runs this test program again as a child with a chosen environment; the child's
// ProcessTuning.DISABLED_Report prints what it started with (/proc/self/environ, the environment exec gave
// it), what it has now, what a program it runs sees, whether a 64 MB block came from the heap, and its
// process name.
#include "base/process_tuning.h"

#include <gtest/gtest.h>
#include <malloc.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>
#include <string>

#include "test_support.h"

namespace {

using montage::test::runCommand;

std::map<std::string, std::string> startEnvironment() {
  std::ifstream in("/proc/self/environ", std::ios::binary);
  const std::string all((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::map<std::string, std::string> env;
  std::stringstream entries(all);
  for (std::string entry; std::getline(entries, entry, '\0');)
    if (const size_t eq = entry.find('='); eq != std::string::npos) env[entry.substr(0, eq)] = entry.substr(eq + 1);
  return env;
}

std::string valueOr(const char* name, const char* otherwise) {
  const char* v = std::getenv(name);
  return v ? v : otherwise;
}

// Runs this program with `env` (arguments to env(1), after the variables it clears) and returns the
// child's report as name -> value.
// This program's file, by its own path (the child's name comes from it).
std::string selfPath() {
  char path[4096];
  const ssize_t n = readlink("/proc/self/exe", path, sizeof(path) - 1);
  return n > 0 ? std::string(path, size_t(n)) : std::string("/proc/self/exe");
}

// The name the kernel gives a process started from `path`: its file name, cut to 15 bytes.
std::string processName(const std::string& path) {
  return path.substr(path.rfind('/') + 1).substr(0, 15);
}

std::map<std::string, std::string> childReport(const std::string& env) {
  const std::string cmd =
      "env -u GLIBC_TUNABLES -u OPENBLAS_THREAD_TIMEOUT -u GOTO_THREAD_TIMEOUT -u "
      "TEXTUREMONTAGE_TUNING -u LD_PRELOAD " +
      env + " '" + selfPath() + "' --gtest_also_run_disabled_tests --gtest_filter=ProcessTuning.DISABLED_Report";
  std::string out;
  EXPECT_EQ(runCommand(cmd, &out), 0) << out;
  std::map<std::string, std::string> report;
  std::istringstream lines(out);
  for (std::string line; std::getline(lines, line);)
    if (line.rfind("report ", 0) == 0)
      if (const size_t eq = line.find('='); eq != std::string::npos)
        report[line.substr(7, eq - 7)] = line.substr(eq + 1);
  EXPECT_FALSE(report.empty()) << out;
  return report;
}

// Run by the cases below only (disabled in a normal run).
TEST(ProcessTuning, DISABLED_Report) {
  const auto start = startEnvironment();
  auto startValue = [&](const char* name) {
    const auto it = start.find(name);
    return it == start.end() ? std::string("(unset)") : it->second;
  };
  std::printf("report start GLIBC_TUNABLES=%s\n", startValue("GLIBC_TUNABLES").c_str());
  std::printf("report start OPENBLAS_THREAD_TIMEOUT=%s\n", startValue("OPENBLAS_THREAD_TIMEOUT").c_str());
  std::printf("report now GLIBC_TUNABLES=%s\n", valueOr("GLIBC_TUNABLES", "(unset)").c_str());
  std::printf("report now OPENBLAS_THREAD_TIMEOUT=%s\n", valueOr("OPENBLAS_THREAD_TIMEOUT", "(unset)").c_str());
  std::printf("report now TEXTUREMONTAGE_TUNING=%s\n", valueOr("TEXTUREMONTAGE_TUNING", "(unset)").c_str());
  std::ifstream comm("/proc/self/comm");
  std::string name;
  std::getline(comm, name);
  std::printf("report name=%s\n", name.c_str());
  std::string child;
  runCommand("sh -c 'echo \"${GLIBC_TUNABLES-(unset)},${OPENBLAS_THREAD_TIMEOUT-(unset)}\"'", &child);
  std::printf("report child=%s\n", child.substr(0, child.find('\n')).c_str());
  // One 64 MB block. glibc's default maps a block this large by itself (its threshold stops at 32 MiB);
  // tuned, it comes from the heap. Huge pages: a heap madvised for them gets 2 MiB pages where the
  // kernel has them, or counts a fallback where it has none at hand (fragmented memory). Both show the
  // advice was given.
  auto hugeKiB = [] {
    std::ifstream in("/proc/self/smaps_rollup");
    for (std::string key; in >> key;) {
      if (key == "AnonHugePages:") {
        long kib = 0;
        in >> kib;
        return kib;
      }
    }
    return -1L;
  };
  auto fallbacks = [] {
    std::ifstream in("/proc/vmstat");
    long n = 0;
    for (std::string key; in >> key;) {
      long value = 0;
      in >> value;
      if (key == "thp_fault_fallback") n = value;
    }
    return n;
  };
  std::ifstream mode("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string modes((std::istreambuf_iterator<char>(mode)), std::istreambuf_iterator<char>());
  constexpr size_t kBytes = 64u << 20;
  const size_t before = mallinfo2().hblks;
  const long fallbacksBefore = fallbacks();
  auto* block = static_cast<volatile char*>(std::malloc(kBytes));
  ASSERT_NE(block, nullptr);
  for (size_t i = 0; i < kBytes; i += 4096) block[i] = 1;
  const size_t after = mallinfo2().hblks;
  const bool huge = hugeKiB() > 0 || fallbacks() > fallbacksBefore;
  std::free(const_cast<char*>(block));
  std::printf("report mapped_blocks=%zu\n", after - before);
  std::printf("report huge_pages=%s\n", modes.empty() || modes.find("[never]") != std::string::npos ? "not offered"
                                        : huge                                                      ? "yes"
                                                                                                    : "no");
}

TEST(ProcessTuning, TheProgramStartsAgainTunedAndPassesNothingOn) {
  auto r = childReport("");
  // ld.so cuts the string it parsed at the first ':' in place, so only its start shows here; the
  // effects below show the rest.
  EXPECT_EQ(r["start GLIBC_TUNABLES"].rfind("glibc.malloc.hugetlb=1", 0), 0u) << r["start GLIBC_TUNABLES"];
  EXPECT_EQ(r["start OPENBLAS_THREAD_TIMEOUT"], "4");
  EXPECT_EQ(r["now GLIBC_TUNABLES"], "(unset)");
  EXPECT_EQ(r["now OPENBLAS_THREAD_TIMEOUT"], "(unset)");
  EXPECT_EQ(r["now TEXTUREMONTAGE_TUNING"], "(unset)");
  EXPECT_EQ(r["child"], "(unset),(unset)");
  EXPECT_EQ(r["mapped_blocks"], "0");
  EXPECT_NE(r["huge_pages"], "no");
  // Started again from /proc/self/exe, it has its own name again (ps, top and pkill show it, not "exe").
  EXPECT_EQ(r["name"], processName(selfPath()));
}

TEST(ProcessTuning, OffLeavesTheProcessAsItIs) {
  auto r = childReport("TEXTUREMONTAGE_TUNING=off");
  EXPECT_EQ(r["start GLIBC_TUNABLES"], "(unset)");
  EXPECT_EQ(r["start OPENBLAS_THREAD_TIMEOUT"], "(unset)");
  EXPECT_EQ(r["now TEXTUREMONTAGE_TUNING"], "off");
  EXPECT_EQ(r["mapped_blocks"], "1");
  EXPECT_EQ(r["name"], processName(selfPath()));
}

TEST(ProcessTuning, TheUsersOwnSettingsWin) {
  auto r = childReport("GLIBC_TUNABLES=glibc.malloc.mmap_threshold=65536");
  EXPECT_EQ(r["start GLIBC_TUNABLES"], "glibc.malloc.mmap_threshold=65536");
  EXPECT_EQ(r["start OPENBLAS_THREAD_TIMEOUT"], "4");                       // still added: the user did not set it
  EXPECT_EQ(r["now GLIBC_TUNABLES"], "glibc.malloc.mmap_threshold=65536");  // theirs, kept for children
  EXPECT_EQ(r["now OPENBLAS_THREAD_TIMEOUT"], "(unset)");
  EXPECT_EQ(r["child"], "glibc.malloc.mmap_threshold=65536,(unset)");
  EXPECT_EQ(r["mapped_blocks"], "1");

  r = childReport("GLIBC_TUNABLES=glibc.malloc.check=0 OPENBLAS_THREAD_TIMEOUT=20");
  EXPECT_EQ(r["start GLIBC_TUNABLES"], "glibc.malloc.check=0");  // nothing to add: not started again
  EXPECT_EQ(r["now OPENBLAS_THREAD_TIMEOUT"], "20");
  EXPECT_EQ(r["now TEXTUREMONTAGE_TUNING"], "(unset)");
}

}  // namespace

int main(int argc, char** argv) {
  montage::tuneProcess(argv);
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
