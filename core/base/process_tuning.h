// Settings that libraries read only when a process starts, for the programs (montage, texturemontage,
// tm_edit_bench). docs/pipeline.md ("Huge pages and BLAS threads") has the measurements.
//   - glibc's malloc. A run allocates, fills and frees buffers of megabytes (photo views, distance
//     maps, sparse systems, refined meshes, the atlas). With the defaults most are fresh mappings whose
//     4 KiB pages each cost a page fault and a zeroing when first written: a fifth of a run's CPU.
//     Tuned: blocks up to 1 GB come from the heap and stay there when freed, and the heap is backed by
//     transparent huge pages (2 MiB: one fault where there were 512).
//   - OpenBLAS (under CHOLMOD's factorisations): its threads spin for about 2^28 cycles after every
//     call, against the pipeline's own threads. Tuned: they go to sleep at once.
#pragma once

#include <memory>

namespace montage {

// Call first in main(). Starts this program again (same process, same arguments) with the settings
// above in its environment, each only where the user has not set it (GLIBC_TUNABLES,
// OPENBLAS_THREAD_TIMEOUT or GOTO_THREAD_TIMEOUT); the started program removes them again, so programs
// it runs do not inherit them. Does nothing when there is nothing to add, under valgrind (it would not
// follow), when TEXTUREMONTAGE_TUNING=off, off glibc/Linux, or when the program cannot be started again
// (it then runs as it is).
void tuneProcess(char** argv);

// The threads a program's work uses, at most `threads` (>= 1) while the object lives (`montage --threads N`):
// TBB's parallel loops and tasks (the pipeline's own parallelism: tbb::global_control), OpenCV's
// parallel_for_ (cv::setNumThreads) and OpenBLAS's threads under CHOLMOD (openblas_set_num_threads, looked
// up at run time: nothing when OpenBLAS is not loaded). The pipeline's results do not depend on it
// (docs/command-line.md, "Determinism"). Throws montage::Error for threads < 1.
class ThreadLimit {
 public:
  explicit ThreadLimit(int threads);
  ~ThreadLimit();
  ThreadLimit(const ThreadLimit&) = delete;
  ThreadLimit& operator=(const ThreadLimit&) = delete;

 private:
  struct State;  // the TBB control and OpenCV's earlier thread count
  std::unique_ptr<State> state_;
};

}  // namespace montage
