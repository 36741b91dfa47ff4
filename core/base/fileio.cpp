#include "base/fileio.h"

#include <dirent.h>
#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iterator>
#include <utility>
#include <vector>

#include "base/hash.h"

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

  // A locked temporary file: removeStaleTempFiles() takes only unlocked ones. If a cleaner removed the
  // new file between mkstemp and flock (it saw it unlocked), make another.
  std::string name;
  int fd = -1;
  for (int attempt = 0; fd < 0; ++attempt) {
    name = (dir / ("." + target.filename().string() + ".tmp-XXXXXX")).string();
    fd = ::mkstemp(name.data());
    check(fd >= 0, [&] { return "cannot create a temporary file in " + inQuotes(dir.string()); });
    struct stat mine {
    }, named{};
    if (::flock(fd, LOCK_EX) == 0 && ::fstat(fd, &mine) == 0 && ::stat(name.c_str(), &named) == 0 &&
        mine.st_ino == named.st_ino && mine.st_dev == named.st_dev)
      break;
    ::close(fd);
    fd = -1;
    check(attempt < 10, [&] { return "cannot lock a temporary file in " + inQuotes(dir.string()); });
  }
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
  removeStaleTempFiles(target.string());
}

int removeStaleTempFiles(const std::string& path) {
  std::error_code ec;
  const fs::path target = fs::absolute(path, ec).lexically_normal();
  if (ec) return 0;
  const std::string prefix = "." + target.filename().string() + ".tmp-";
  const fs::path dir = target.parent_path();
  DIR* folder = ::opendir(dir.c_str());
  if (!folder) return 0;
  std::vector<std::string> candidates;
  while (const dirent* entry = ::readdir(folder)) {
    const std::string name = entry->d_name;
    if (name.size() == prefix.size() + 6 && name.compare(0, prefix.size(), prefix) == 0) candidates.push_back(name);
  }
  ::closedir(folder);
  int removed = 0;
  for (const std::string& name : candidates) {
    const std::string file = (dir / name).string();
    const int fd = ::open(file.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC | O_NONBLOCK);
    if (fd < 0) continue;
    struct stat mine {
    }, named{};
    // Unlocked: its writer is gone (a live writer holds the lock from creation to rename).
    if (::flock(fd, LOCK_EX | LOCK_NB) == 0 && ::fstat(fd, &mine) == 0 && S_ISREG(mine.st_mode) &&
        ::lstat(file.c_str(), &named) == 0 && mine.st_ino == named.st_ino && mine.st_dev == named.st_dev)
      removed += ::unlink(file.c_str()) == 0;
    ::close(fd);
  }
  return removed;
}

std::string fileProblem(const std::string& path) {
  if (path.empty()) return "the path is empty";
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    const int err = errno;
    switch (err) {
      case ENOENT: {
        struct stat link {};
        if (::lstat(path.c_str(), &link) == 0 && S_ISLNK(link.st_mode)) {
          std::error_code ec;
          const fs::path to = fs::read_symlink(path, ec);
          return "is a dangling symbolic link" + (ec ? std::string() : " to " + inQuotes(to.string()));
        }
        return "not found";
      }
      case ELOOP:
        return "cannot be opened: symbolic link loop (too many levels of symbolic links)";
      case EACCES:
        return "cannot be opened: permission denied";
      case ENOTDIR:
        return "not found (a part of the path is a file, not a folder)";
      case ENAMETOOLONG:
        return "cannot be opened: the path is too long";
      default:
        return std::string("cannot be opened: ") + std::strerror(err);
    }
  }
  if (S_ISDIR(st.st_mode)) return "is a folder, not a file";
  if (!S_ISREG(st.st_mode)) return "is not a regular file (a device, pipe or socket)";
  if (::access(path.c_str(), R_OK) != 0) return std::string("cannot be read: ") + std::strerror(errno);
  return "";
}

void requireRegularFile(const std::string& path, const std::string& what) {
  const std::string problem = fileProblem(path);
  if (!problem.empty()) throw Error(located(path, what.empty() ? problem : what + " " + problem));
}

std::string readFileBytes(const std::string& path, const std::string& what, uint64_t maxBytes, const std::string& why) {
  requireRegularFile(path, what);
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    const int err = errno;
    throw Error(located(path, "cannot open " + what + ": " + std::strerror(err)));
  }
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat st {};
  const uint64_t size = ::fstat(fd, &st) == 0 ? uint64_t(st.st_size) : 0;
  const auto tooLarge = [&](uint64_t bytes) {
    throw Error(located(path, what + " is " + (bytes > size ? "more than " : "") + byteSize(bytes) + "; at most " +
                                  byteSize(maxBytes) + " are read" + (why.empty() ? "" : " (" + why + ")")));
  };
  if (size > maxBytes) tooLarge(size);
  std::string data;
  data.reserve(size_t(size));
  char buffer[1 << 16];
  for (;;) {
    const ssize_t n = ::read(fd, buffer, sizeof buffer);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      const int err = errno;
      throw Error(located(path, "read error in " + what + ": " + std::strerror(err)));
    }
    if (n == 0) break;
    if (data.size() + size_t(n) > maxBytes) tooLarge(data.size() + size_t(n));  // grew while read
    data.append(buffer, size_t(n));
  }
  return data;
}

bool isInsideFolder(const std::string& path, const std::string& folder) {
  std::error_code ec;
  const fs::path dir = fs::weakly_canonical(fs::absolute(folder, ec), ec);
  if (ec) return false;
  const fs::path file = fs::weakly_canonical(fs::absolute(path, ec), ec);
  if (ec) return false;
  auto d = dir.begin(), f = file.begin();
  for (; d != dir.end(); ++d, ++f)
    if (f == file.end() || *d != *f) {
      if (d->empty() && std::next(d) == dir.end()) return true;  // "folder/" ends in an empty element
      return false;
    }
  return true;
}

void prepareOutputFile(const std::string& path, const std::string& what) {
  TM_CHECK(!path.empty(), what + ": the path is empty");
  std::error_code ec;
  const fs::path target = fs::absolute(path, ec).lexically_normal();
  if (ec) throw Error(located(path, what + ": cannot resolve the path: " + ec.message()));
  TM_CHECK(target.has_filename(), located(path, what + ": names a folder, not a file"));
  struct stat st {};
  if (::stat(target.c_str(), &st) == 0) {
    TM_CHECK(!S_ISDIR(st.st_mode), located(path, what + ": is a folder, not a file"));
  } else if (errno != ENOENT) {
    throw Error(located(path, what + ": " + fileProblem(target.string())));
  }
  const fs::path dir = target.parent_path();
  fs::create_directories(dir, ec);
  if (ec) throw Error(located(dir.string(), what + ": cannot create the folder: " + ec.message()));
  if (::access(dir.c_str(), W_OK | X_OK) != 0) {
    const int err = errno;
    throw Error(located(dir.string(), what + ": cannot write here: " + std::strerror(err)));
  }
}

std::string byteSize(uint64_t bytes) {
  char text[64];
  if (bytes < 1000) {
    std::snprintf(text, sizeof text, "%llu bytes", static_cast<unsigned long long>(bytes));
  } else {
    const char* units[] = {"KB", "MB", "GB", "TB", "PB", "EB"};
    double value = bytes / 1000.0;
    int u = 0;
    while (value >= 1000 && u < 5) value /= 1000, ++u;
    std::snprintf(text, sizeof text, value < 100 ? "%.1f %s" : "%.0f %s", value, units[u]);
  }
  return text;
}

std::string lowerExtension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  for (char& ch : ext) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  return ext;
}

bool isImageExtension(const std::string& ext) {
  return ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".tif" || ext == ".tiff" || ext == ".bmp";
}

const char* const kPhotoExtensions = ".png, .jpg, .jpeg, .tif, .tiff, .bmp";

bool isOtherImageExtension(const std::string& ext) {
  static const char* const kOther[] = {".webp", ".exr", ".gif", ".heic", ".heif", ".avif", ".jxl", ".hdr",
                                       ".pic", ".psd", ".tga", ".jp2", ".j2k", ".pbm", ".pgm", ".ppm",
                                       ".pnm", ".dng", ".cr2", ".cr3", ".nef", ".arw", ".raf", ".orf",
                                       ".rw2", ".svg", ".ico", ".xcf", ".kra"};
  return std::find(std::begin(kOther), std::end(kOther), ext) != std::end(kOther);
}

std::string unsupportedPhotoFormat(const std::string& ext) {
  return "unsupported photo format '" + (ext.empty() ? std::string("(no extension)") : ext.substr(1)) +
         "' (supported: " + kPhotoExtensions + ")";
}

uint64_t fileContentHash(const std::string& path) {
  requireRegularFile(path);
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    const int err = errno;
    throw Error(located(path, std::string("cannot open: ") + std::strerror(err)));
  }
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  // Words of 8 bytes mixed in order (base/hash.h), the tail padded with zeros, then the length: two files
  // that differ only in trailing zero bytes still differ.
  uint64_t h = 0x7e47c0de5eedull, length = 0;
  char buffer[1 << 16];
  size_t held = 0;  // bytes of `buffer` not yet mixed in (fewer than 8)
  for (;;) {
    const ssize_t n = ::read(fd, buffer + held, sizeof buffer - held);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      const int err = errno;
      throw Error(located(path, std::string("read error: ") + std::strerror(err)));
    }
    length += uint64_t(n);
    const size_t have = held + size_t(n);
    const size_t words = n == 0 ? (have + 7) / 8 : have / 8;
    if (n == 0) std::memset(buffer + have, 0, words * 8 - have);
    for (size_t w = 0; w < words; ++w) {
      uint64_t v;
      std::memcpy(&v, buffer + 8 * w, 8);
      h = hashMix(h, v);
    }
    if (n == 0) break;
    held = have - words * 8;
    std::memmove(buffer, buffer + words * 8, held);
  }
  return hashMix(h, length);
}

std::string fileContentHashHex(const std::string& path) {
  char text[17];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(fileContentHash(path)));
  return text;
}

}  // namespace montage
