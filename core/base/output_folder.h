// Result folders replaced as one unit: `montage run --out DIR` (and anything else that writes a set of
// files that belong together) writes into a fresh staging folder beside DIR and swaps it in with one
// rename, under a lock that refuses a second writer. A kill at any moment leaves either the previous
// complete result or the new complete result; what a killed writer left behind is removed by the next.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "base/common.h"

namespace montage {

class OutputFolder {
 public:
  // Name of the manifest written into every result folder: one file name per line, the entries the
  // run wrote. It marks the folder as a result that the next run may replace.
  static constexpr const char* kManifest = ".texturemontage-result";

  // Checks `dir` before any work is done (not empty, not a file, parent folder present or creatable
  // and writable; an existing folder must be empty or an earlier result, never, say, the folder of
  // the photos), takes the lock "<parent>/.<name>.lock" (flock: released when this object dies or the
  // process is killed; a second writer gets a montage::Error naming the folder), removes what killed
  // writers left ("<parent>/.<name>.tmp-XXXXXX" folders) and creates a fresh staging folder there.
  // Symbolic links in `dir` are resolved first: the folder a link names is replaced, not the link.
  explicit OutputFolder(const std::string& dir);
  ~OutputFolder();  // removes the staging folder unless committed, then releases the lock
  OutputFolder(const OutputFolder&) = delete;
  OutputFolder& operator=(const OutputFolder&) = delete;

  const std::string& path() const { return dir_; }            // the result folder (absolute, resolved)
  const std::string& staging() const { return staging_; }     // where the new result is written
  int removedLeftovers() const { return removedLeftovers_; }  // staging folders of killed writers removed

  // Publishes the staging folder as the result: writes the manifest, carries over the files of the
  // previous result that the run did not write and that it had not written either (a render the user
  // put there), flushes every file and the folder to disk, and swaps the folder in with
  // renameat2(RENAME_EXCHANGE) (a plain rename when there was no result; on a file system without
  // RENAME_EXCHANGE two renames, with a window of microseconds without DIR). The previous result is
  // then removed. Throws montage::Error naming the folder on failure; the previous result then stays.
  void commit();

 private:
  std::string dir_, parent_, name_, staging_, lockFile_;
  int lockFd_ = -1;
  bool committed_ = false;
  int removedLeftovers_ = 0;
};

// Writes a set of files into an existing folder so that each appears complete: `write(staging)` writes
// them into a fresh hidden folder beside them (locked, cleaned like OutputFolder's), then they are
// flushed and renamed into `folder` one by one in the order given by `order` (file names; files not
// listed go first, in name order), e.g. textures, then the .mtl, then the .obj that names them. Used by
// the editor's OBJ export, whose files share a folder with the user's other files.
void publishFiles(const std::string& folder, const std::string& tag, const std::vector<std::string>& order,
                  const std::function<void(const std::string& staging)>& write);

}  // namespace montage
