#include "base/output_folder.h"

#include <dirent.h>
#include <fcntl.h>
#include <stdio.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "base/fileio.h"

namespace fs = std::filesystem;

namespace montage {

namespace {

std::string inQuotes(const std::string& s) {
  return "'" + s + "'";
}

[[noreturn]] void failErrno(const std::string& where, const std::string& what) {
  const int err = errno;
  throw Error(located(where, what + ": " + std::strerror(err)));
}

bool sameFile(int fd, const std::string& path) {
  struct stat mine {
  }, named{};
  return ::fstat(fd, &mine) == 0 && ::lstat(path.c_str(), &named) == 0 && mine.st_ino == named.st_ino &&
         mine.st_dev == named.st_dev;
}

// Names of the entries of a folder ("" entries excluded); empty when it cannot be read.
std::vector<std::string> entries(const std::string& dir) {
  std::vector<std::string> names;
  if (DIR* d = ::opendir(dir.c_str())) {
    while (const dirent* e = ::readdir(d)) {
      const std::string name = e->d_name;
      if (name != "." && name != "..") names.push_back(name);
    }
    ::closedir(d);
  }
  std::sort(names.begin(), names.end());
  return names;
}

// A fresh folder "<parent>/.<name>.tmp-XXXXXX" with a lock held on it (its fd is returned), so that a
// cleaner never takes it for a leftover.
int makeLockedStaging(const std::string& parent, const std::string& name, std::string& staging) {
  for (int attempt = 0; attempt < 10; ++attempt) {
    std::string pattern = (fs::path(parent) / ("." + name + ".tmp-XXXXXX")).string();
    if (!::mkdtemp(pattern.data())) failErrno(parent, "cannot create a staging folder for " + inQuotes(name));
    const int fd = ::open(pattern.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd >= 0 && ::flock(fd, LOCK_EX) == 0 && sameFile(fd, pattern)) {
      staging = pattern;
      return fd;
    }
    if (fd >= 0) ::close(fd);
  }
  throw Error(located(parent, "cannot lock a staging folder for " + inQuotes(name)));
}

// The process's umask, read without changing it (umask() would race with other threads creating files).
mode_t currentUmask() {
  std::ifstream status("/proc/self/status");
  for (std::string line; std::getline(status, line);)
    if (line.rfind("Umask:", 0) == 0) return mode_t(std::stoul(line.substr(6), nullptr, 8));
  return 022;
}

// Removes "<parent>/.<name>.tmp-XXXXXX" folders and files that nobody holds locked; returns how many.
int removeLeftovers(const std::string& parent, const std::string& name) {
  const std::string prefix = "." + name + ".tmp-";
  int removed = 0;
  for (const std::string& entry : entries(parent)) {
    if (entry.size() != prefix.size() + 6 || entry.compare(0, prefix.size(), prefix) != 0) continue;
    const std::string path = (fs::path(parent) / entry).string();
    const int fd = ::open(path.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC | O_NONBLOCK);
    if (fd < 0) continue;
    if (::flock(fd, LOCK_EX | LOCK_NB) == 0 && sameFile(fd, path)) {
      std::error_code ec;
      removed += fs::remove_all(path, ec) > 0;
    }
    ::close(fd);
  }
  return removed;
}

void syncPath(const std::string& path, bool folder) {
  const int fd = ::open(path.c_str(), (folder ? O_RDONLY | O_DIRECTORY : O_RDONLY) | O_CLOEXEC);
  if (fd < 0) failErrno(path, "cannot open to flush it to disk");
  const bool ok = ::fsync(fd) == 0 || errno == EINVAL;  // some file systems cannot sync a folder
  const int err = errno;
  ::close(fd);
  errno = err;
  if (!ok) failErrno(path, "cannot flush to disk");
}

// Flushes every regular file below `dir`, then the folders themselves.
void syncTree(const std::string& dir) {
  std::error_code ec;
  for (fs::recursive_directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec))
    if (it->is_regular_file(ec) && !it->is_symlink(ec))
      syncPath(it->path().string(), false);
    else if (it->is_directory(ec) && !it->is_symlink(ec))
      syncPath(it->path().string(), true);
  if (ec) throw Error(located(dir, "cannot list the folder to flush it: " + ec.message()));
  syncPath(dir, true);
}

// Whether an existing folder may be replaced: empty, or a result (our manifest, or the report.json of
// a run made before manifests existed).
bool isReplaceable(const std::string& dir, const std::vector<std::string>& names) {
  if (names.empty()) return true;
  if (std::find(names.begin(), names.end(), OutputFolder::kManifest) != names.end()) return true;
  if (std::find(names.begin(), names.end(), "report.json") == names.end()) return false;
  std::ifstream in(fs::path(dir) / "report.json");
  std::string head(4096, '\0');
  in.read(head.data(), std::streamsize(head.size()));
  head.resize(size_t(in.gcount()));
  return head.find("\"generator\": \"TextureMontage\"") != std::string::npos;
}

std::set<std::string> manifestOf(const std::string& dir) {
  std::set<std::string> names;
  std::ifstream in(fs::path(dir) / OutputFolder::kManifest);
  for (std::string line; std::getline(in, line);)
    if (!line.empty()) names.insert(line);
  return names;
}

}  // namespace

OutputFolder::OutputFolder(const std::string& dir) {
  TM_CHECK(!dir.empty(), "output folder: the path is empty (give a folder such as out/result)");
  std::error_code ec;
  fs::path p = fs::absolute(dir, ec).lexically_normal();
  if (!ec && !p.has_filename()) p = p.parent_path();
  if (!ec) p = fs::weakly_canonical(p, ec);
  if (ec) throw Error(located(dir, "output folder: cannot resolve the path: " + ec.message()));
  TM_CHECK(p.has_parent_path() && p != p.root_path(), located(dir, "output folder: cannot replace the root folder"));
  dir_ = p.string();
  parent_ = p.parent_path().string();
  name_ = p.filename().string();

  struct stat st {};
  if (::stat(dir_.c_str(), &st) == 0) {
    TM_CHECK(S_ISDIR(st.st_mode), located(dir_, "output folder: is a file, not a folder"));
  } else {
    TM_CHECK(errno == ENOENT, located(dir_, "output folder " + fileProblem(dir_)));
  }
  fs::create_directories(parent_, ec);
  if (ec)
    throw Error(located(parent_, "cannot create the folder for the output " + inQuotes(name_) + ": " + ec.message()));
  if (::access(parent_.c_str(), W_OK | X_OK) != 0)
    failErrno(parent_, "cannot write the output folder " + inQuotes(name_) + " here");

  // The lock file; retried when its previous holder removed it between our open and our flock.
  lockFile_ = (fs::path(parent_) / ("." + name_ + ".lock")).string();
  for (int attempt = 0; lockFd_ < 0; ++attempt) {
    const int fd = ::open(lockFile_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW, 0644);
    if (fd < 0) failErrno(lockFile_, "cannot create the lock file of the output folder");
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
      const int err = errno;
      ::close(fd);
      if (err == EWOULDBLOCK)
        throw Error(located(dir_,
                            "another montage run or editor export is writing this output folder (it holds "
                            "the lock " +
                                inQuotes(lockFile_) + "); wait for it to finish or choose another folder"));
      errno = err;
      failErrno(lockFile_, "cannot lock the output folder");
    }
    if (sameFile(fd, lockFile_)) {
      lockFd_ = fd;
    } else {
      ::close(fd);
      TM_CHECK(attempt < 10, located(lockFile_, "cannot lock the output folder (the lock file keeps changing)"));
    }
  }

  try {
    const std::vector<std::string> names = entries(dir_);
    if (::stat(dir_.c_str(), &st) == 0 && !isReplaceable(dir_, names)) {
      std::string shown;
      for (size_t i = 0; i < std::min<size_t>(names.size(), 3); ++i) shown += (i ? ", " : "") + inQuotes(names[i]);
      throw Error(located(dir_, "output folder is not empty and is not an earlier result (it holds " + shown +
                                    (names.size() > 3 ? ", ..." : "") +
                                    "); a run replaces its output folder as a whole: choose a new or empty folder"));
    }
    removedLeftovers_ = removeLeftovers(parent_, name_);
    const int stagingFd = makeLockedStaging(parent_, name_, staging_);
    // mkdtemp makes it private (0700): give it the previous result's permissions, or the usual ones.
    struct stat previous {};
    ::fchmod(stagingFd, ::stat(dir_.c_str(), &previous) == 0 ? previous.st_mode & 07777 : 0777 & ~currentUmask());
    ::close(stagingFd);  // the output lock keeps cleaners away from it
  } catch (...) {
    ::unlink(lockFile_.c_str());
    ::close(lockFd_);
    throw;
  }
}

OutputFolder::~OutputFolder() {
  std::error_code ec;
  if (!committed_ && !staging_.empty()) fs::remove_all(staging_, ec);
  if (lockFd_ >= 0) {
    ::unlink(lockFile_.c_str());  // before releasing: a waiter then sees a new lock file (see the constructor)
    ::close(lockFd_);
  }
}

void OutputFolder::commit() {
  TM_CHECK(!committed_, located(dir_, "output folder: already committed"));
  std::error_code ec;
  const std::vector<std::string> written = entries(staging_);
  std::string manifest;
  for (const std::string& name : written) manifest += name + "\n";
  writeFileAtomic((fs::path(staging_) / kManifest).string(), manifest);

  struct stat st {};
  const bool exists = ::stat(dir_.c_str(), &st) == 0;
  if (exists) {
    // Carry over what the user put into the previous result (not written by either run).
    const std::set<std::string> previous = manifestOf(dir_);
    const std::set<std::string> now(written.begin(), written.end());
    for (const std::string& name : entries(dir_)) {
      if (name == kManifest || previous.count(name) || now.count(name)) continue;
      const fs::path from = fs::path(dir_) / name, to = fs::path(staging_) / name;
      fs::copy(from, to,
               fs::copy_options::recursive | fs::copy_options::create_hard_links | fs::copy_options::copy_symlinks, ec);
      if (ec) {
        ec.clear();
        fs::copy(from, to, fs::copy_options::recursive | fs::copy_options::copy_symlinks, ec);
      }
      if (ec) throw Error(located(from.string(), "cannot carry this file over into the new result: " + ec.message()));
    }
  }
  syncTree(staging_);

  if (!exists) {
    if (::rename(staging_.c_str(), dir_.c_str()) != 0) failErrno(dir_, "cannot move the new result into place");
  } else if (::renameat2(AT_FDCWD, staging_.c_str(), AT_FDCWD, dir_.c_str(), RENAME_EXCHANGE) != 0) {
    if (errno != EINVAL && errno != ENOSYS) failErrno(dir_, "cannot swap the new result into place");
    // No RENAME_EXCHANGE here: move the previous result aside (to a leftover name), then the new one in.
    std::string aside;
    const int fd = makeLockedStaging(parent_, name_, aside);
    ::close(fd);
    if (::rename(dir_.c_str(), aside.c_str()) != 0) failErrno(dir_, "cannot move the previous result aside");
    if (::rename(staging_.c_str(), dir_.c_str()) != 0) {
      const int err = errno;
      ::rename(aside.c_str(), dir_.c_str());
      errno = err;
      failErrno(dir_, "cannot move the new result into place");
    }
    staging_ = aside;
  }
  committed_ = true;
  syncPath(parent_, true);
  if (exists) fs::remove_all(staging_, ec);  // the previous result, now under the staging name
}

void publishFiles(const std::string& folder, const std::string& tag, const std::vector<std::string>& order,
                  const std::function<void(const std::string& staging)>& write) {
  std::error_code ec;
  const std::string dir = fs::absolute(folder, ec).lexically_normal().string();
  fs::create_directories(dir, ec);
  TM_CHECK(fs::is_directory(dir, ec), located(dir, "cannot create the folder: " + ec.message()));
  removeLeftovers(dir, tag);
  std::string staging;
  const int lock = makeLockedStaging(dir, tag, staging);
  struct Cleanup {
    std::string path;
    int fd;
    ~Cleanup() {
      std::error_code ec;
      fs::remove_all(path, ec);
      ::close(fd);
    }
  } cleanup{staging, lock};
  write(staging);
  syncTree(staging);
  std::vector<std::string> names = entries(staging);
  const auto rank = [&](const std::string& name) {
    const auto it = std::find(order.begin(), order.end(), name);
    return it == order.end() ? -1 : int(it - order.begin());
  };
  std::stable_sort(names.begin(), names.end(),
                   [&](const std::string& a, const std::string& b) { return rank(a) < rank(b); });
  for (const std::string& name : names) {
    const std::string from = (fs::path(staging) / name).string(), to = (fs::path(dir) / name).string();
    if (::rename(from.c_str(), to.c_str()) != 0) failErrno(to, "cannot move the new file into place");
  }
  syncPath(dir, true);
}

}  // namespace montage
