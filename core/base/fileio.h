// Writing files safely: a crash or a failure leaves either the old file or the new one, never a
// partial file.
#pragma once

#include <cstdint>
#include <string>

#include "base/common.h"

namespace montage {

// Writes `contents` to `path` atomically: temporary file in the same folder, fsync, rename, fsync of
// the folder. An existing file keeps its permissions; a symbolic link is followed (the file it names
// is replaced, not the link). Throws montage::Error on failure, leaving any earlier file untouched.
// The temporary file (".<name>.tmp-XXXXXX") is locked (flock) while it is written; temporary files of
// the same name left by a writer that was killed (unlocked) are removed after a successful write.
void writeFileAtomic(const std::string& path, const std::string& contents);

// Removes ".<name>.tmp-XXXXXX" files beside `path` that no live writer holds (see writeFileAtomic);
// returns how many were removed. Never throws.
int removeStaleTempFiles(const std::string& path);

// Why `path` cannot be read as a regular file, or "" when it can: "not found", "is a folder",
// "symbolic link loop (too many levels of symbolic links)", "dangling symbolic link to 'x'",
// "permission denied", "is not a regular file (a device, pipe or socket)"...
std::string fileProblem(const std::string& path);
// Throws montage::Error "<path>: <what> <problem>" (e.g. "a.obj: mesh file not found") unless
// fileProblem(path) is empty. `what` may be empty.
void requireRegularFile(const std::string& path, const std::string& what = "");

// The whole file as bytes. Throws montage::Error naming the path and the reason when it cannot be
// read (see fileProblem) or when it is larger than `maxBytes` ("<what> is 200.0 MB; at most 64.0 MB
// are read", followed by `why`, e.g. a hint of what such a file should hold).
std::string readFileBytes(const std::string& path, const std::string& what, uint64_t maxBytes = UINT64_MAX,
                          const std::string& why = "");

// A 64-bit hash of the file's bytes (its contents only: not its name, folder or times), for keys and
// random seeds that must not change when a file is copied, moved or touched. Reads the file in 64 KiB
// blocks. Throws montage::Error naming the path and the reason when it cannot be read (see fileProblem).
uint64_t fileContentHash(const std::string& path);
// The same hash as 16 lower-case hex digits.
std::string fileContentHashHex(const std::string& path);

// Whether `path` lies inside the folder `folder` (or is in it), after resolving ".." and symbolic
// links of both (so a link inside the folder that points out of it is outside).
bool isInsideFolder(const std::string& path, const std::string& folder);

// Checks a path the user gave for an output file before any work is done: not empty, not a folder, its
// folder present or creatable (it is created). `what` names the option, e.g. "--out". Throws
// montage::Error naming the path and the reason.
void prepareOutputFile(const std::string& path, const std::string& what);

// "12.3 MB", "850 KB", "17 bytes": a size for messages (decimal units).
std::string byteSize(uint64_t bytes);

// The file's extension in lower case, with its dot (".png"), or "" when it has none.
std::string lowerExtension(const std::string& path);
// Whether the extension (from lowerExtension) is one of the photo formats we read.
bool isImageExtension(const std::string& ext);
// The photo formats we read, for messages: ".png, .jpg, .jpeg, .tif, .tiff, .bmp".
extern const char* const kPhotoExtensions;
// Whether the extension (from lowerExtension) is an image format other programs write that we do not read
// (.webp, .exr, .gif, .heic, .avif, .jxl, .hdr, .psd, .tga, .jp2, camera raw...): a file named so is meant
// as a photo, and its message should say so.
bool isOtherImageExtension(const std::string& ext);
// "unsupported photo format 'webp' (supported: .png, .jpg, .jpeg, .tif, .tiff, .bmp)".
std::string unsupportedPhotoFormat(const std::string& ext);

}  // namespace montage
