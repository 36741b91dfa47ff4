#include "base/fileio.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <utility>

namespace fs = std::filesystem;

namespace montage {

namespace {

std::string inQuotes(const std::string& s) {
  return "'" + s + "'";
}

// Closes a file descriptor and removes a temporary file unless released.
class TempFile {
 public:
  explicit TempFile(std::string path, int fd) : path_(std::move(path)), fd_(fd) {}
  ~TempFile() {
    if (fd_ >= 0) ::close(fd_);
    if (!path_.empty()) ::unlink(path_.c_str());
  }
  int close() { return ::close(std::exchange(fd_, -1)); }
  void release() { path_.clear(); }

 private:
  std::string path_;
  int fd_;
};

}  // namespace

void writeFileAtomic(const std::string& path, const std::string& contents) {
  // Throws "<path>: <what>: <system reason>" unless `ok`; `what` is built after errno is saved.
  const auto check = [&](bool ok, auto what) {
    if (ok) return;
    const int err = errno;
    throw Error(located(path, what() + ": " + std::strerror(err)));
  };
  std::error_code ec;
  fs::path target = fs::absolute(path).lexically_normal();
  if (fs::is_symlink(target, ec)) target = fs::weakly_canonical(target, ec);  // replace the file, not the link
  const fs::path dir = target.parent_path();

  std::string name = (dir / ("." + target.filename().string() + ".tmp-XXXXXX")).string();
  const int fd = ::mkstemp(name.data());
  check(fd >= 0, [&] { return "cannot create a temporary file in " + inQuotes(dir.string()); });
  TempFile temp(name, fd);

  struct stat existing {};
  const mode_t mode = ::stat(target.c_str(), &existing) == 0 ? existing.st_mode & 07777 : 0644;
  check(::fchmod(fd, mode) == 0, [&] { return "cannot set the permissions of " + inQuotes(name); });
  for (size_t written = 0; written < contents.size();) {
    const ssize_t n = ::write(fd, contents.data() + written, contents.size() - written);
    if (n < 0 && errno == EINTR) continue;
    check(n > 0, [&] { return "cannot write " + inQuotes(name); });
    written += size_t(n);
  }
  check(::fsync(fd) == 0, [&] { return "cannot flush " + inQuotes(name) + " to disk"; });
  check(temp.close() == 0, [&] { return "cannot close " + inQuotes(name); });
  check(::rename(name.c_str(), target.c_str()) == 0, [&] { return "cannot replace the file with " + inQuotes(name); });
  temp.release();

  // Make the rename itself durable. Some file systems cannot sync a folder (EINVAL): nothing to do then.
  const int dirFd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  check(dirFd >= 0, [] { return std::string("written, but cannot open the folder to sync it"); });
  const bool synced = ::fsync(dirFd) == 0 || errno == EINVAL;
  const int err = errno;
  ::close(dirFd);
  errno = err;
  check(synced, [] { return std::string("written, but cannot sync the folder"); });
}

std::string lowerExtension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  for (char& ch : ext) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  return ext;
}

bool isImageExtension(const std::string& ext) {
  return ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".tif" || ext == ".tiff" || ext == ".bmp";
}

}  // namespace montage
