// Helpers of the fuzz targets: a private scratch folder (in /dev/shm when there is one) and file writing.
#pragma once

#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

namespace montage::fuzz {

// A folder of this process, created on first use: /dev/shm/tm_fuzz_<tag>_<pid> (or under $TMPDIR).
inline std::string scratch(const std::string& tag) {
  namespace fs = std::filesystem;
  const fs::path base = fs::is_directory("/dev/shm") ? fs::path("/dev/shm") : fs::temp_directory_path();
  const fs::path dir = base / ("tm_fuzz_" + tag + "_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir.string();
}

inline void writeFile(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc).write(bytes.data(), std::streamsize(bytes.size()));
}

}  // namespace montage::fuzz
