#include "base/isolate.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <exception>
#include <fstream>

#include "base/common.h"

namespace montage {

namespace {

// The process's virtual size in bytes (/proc/self/statm's first field), 0 when unknown.
size_t virtualSize() {
  std::ifstream statm("/proc/self/statm");
  size_t pages = 0;
  if (!(statm >> pages)) return 0;
  return pages * size_t(sysconf(_SC_PAGESIZE));
}

void writeAll(int fd, const char* data, size_t size) {
  while (size > 0) {
    const ssize_t n = ::write(fd, data, size);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return;
    data += n, size -= size_t(n);
  }
}

}  // namespace

std::string runIsolated(const std::function<std::string()>& work, size_t memoryBudget, double timeoutSeconds,
                        const std::string& what) {
  int fds[2];
  if (::pipe(fds) != 0) throw Error(what + ": cannot make a pipe: " + std::strerror(errno));
  const size_t limit = virtualSize() + memoryBudget;
  std::fflush(nullptr);
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::close(fds[0]), ::close(fds[1]);
    throw Error(what + ": cannot start a process: " + std::strerror(errno));
  }
  if (pid == 0) {
    ::close(fds[0]);
    // The parser's own complaints (an assert's message) are not the user's to read: the Error says it.
    const int devnull = ::open("/dev/null", O_WRONLY);
    if (devnull >= 0) ::dup2(devnull, STDERR_FILENO);
    const rlimit rl{limit, limit};
    ::setrlimit(RLIMIT_AS, &rl);
    char tag = '+';
    std::string out;
    try {
      out = work();
    } catch (const std::exception& e) {
      tag = '-', out = e.what();
    } catch (...) {
      tag = '-', out = what + ": unknown error";
    }
    writeAll(fds[1], &tag, 1);
    writeAll(fds[1], out.data(), out.size());
    ::_exit(0);
  }
  ::close(fds[1]);
  std::string got;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeoutSeconds);
  bool timedOut = false;
  char buffer[1 << 16];
  for (;;) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) {
      timedOut = true;
      break;
    }
    pollfd p{fds[0], POLLIN, 0};
    const int ready = ::poll(&p, 1, int(std::min<long long>(left.count(), 1000)));
    if (ready < 0 && errno != EINTR) break;
    if (ready <= 0) continue;
    const ssize_t n = ::read(fds[0], buffer, sizeof buffer);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    got.append(buffer, size_t(n));
  }
  ::close(fds[0]);
  if (timedOut) ::kill(pid, SIGKILL);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (timedOut) throw Error(what + ": still running after " + std::to_string(int(timeoutSeconds)) + " s, stopped");
  if (WIFSIGNALED(status))
    throw Error(what + ": the reader stopped on signal " + std::to_string(WTERMSIG(status)) + " (" +
                strsignal(WTERMSIG(status)) + "); the file is damaged or not of this format");
  if (got.empty())
    throw Error(what + ": the reader ended without an answer (exit status " +
                std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1) + ")");
  if (got[0] == '-') throw Error(got.substr(1));
  return got.substr(1);
}

}  // namespace montage
