// Writing files safely: a crash or a failure leaves either the old file or the new one, never a
// partial file.
#pragma once

#include <string>

#include "base/common.h"

namespace montage {

// Writes `contents` to `path` atomically: temporary file in the same folder, fsync, rename, fsync of
// the folder. An existing file keeps its permissions; a symbolic link is followed (the file it names
// is replaced, not the link). Throws montage::Error on failure, leaving any earlier file untouched.
void writeFileAtomic(const std::string& path, const std::string& contents);

// The file's extension in lower case, with its dot (".png"), or "" when it has none.
std::string lowerExtension(const std::string& path);
// Whether the extension (from lowerExtension) is one of the photo formats we read.
bool isImageExtension(const std::string& ext);

}  // namespace montage
