// Running a parser we do not own in a child process: a file it cannot handle may make it abort (an assert), ask
// for more memory than the machine has, or loop; the child dies or is stopped, the caller gets an Error.
#pragma once

#include <cstddef>
#include <functional>
#include <string>

namespace montage {

// Runs `work` in a forked child with its address space limited to the parent's plus `memoryBudget` bytes, and
// returns the bytes it returned. A montage::Error or std::exception thrown by `work` is rethrown here as an Error
// with the same message; a child that is killed by a signal (an abort, running out of memory), or still runs after
// `timeoutSeconds` (then killed), gives an Error "`what`: ..." saying so. The child only computes and writes
// to a pipe; it never returns into the caller's code.
std::string runIsolated(const std::function<std::string()>& work, size_t memoryBudget, double timeoutSeconds,
                        const std::string& what);

}  // namespace montage
