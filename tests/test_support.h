// Helpers shared by the tests: data locations, temporary folders and error messages.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "base/common.h"

namespace montage {
struct Mapping;
}

namespace montage::test {

// assets/ of the project (always present).
std::string assetsDir();
// tests/data: meshes made for the tests (turtle.obj: scripts/demo_mesh.py).
std::string testDataDir();
// ../shared/data, or "" when absent.
std::string sharedDataDir();
// Path of a file under ../shared/data; calls GTEST_SKIP-compatible logic: returns "" and prints
// "SKIPPED: ../shared/data/<rel> is absent" when the shared data is not there.
std::string sharedFile(const std::string& rel);
// A fresh empty temporary folder, removed at process exit.
std::string tempDir(const std::string& tag);
// Path of the montage executable.
std::string montageExe();
// A JSON file's content; a test failure naming the file (and null) when it is missing.
nlohmann::json readJson(const std::string& path);
// Runs a shell command, returns its exit status; output goes to `output` when given.
int runCommand(const std::string& command, std::string* output = nullptr);
// Why the Khronos glTF validator cannot run here, or "" when it can (the ctest test npm_gltf_validator_setup installs
// it with npm, and skips when npm cannot reach its registry).
std::string gltfValidatorMissing();
// The validator's report on a .glb or .gltf file ("FILE: errors: E, warnings: W, ..." and its messages), printed;
// its exit status in `status` (0: no errors, 77: the validator is missing).
std::string runGltfValidator(const std::string& file, int* status);
// True when xvfb-run is installed (the editor tests run the editor on a virtual display).
bool haveXvfb();
// The bundled demo project with absolute paths, to be written anywhere (editor tests edit copies).
nlohmann::json demoProjectAbsolute();

// Skips an editor test, with the reason, when there is no xvfb-run.
#define TM_REQUIRE_XVFB()           \
  if (!::montage::test::haveXvfb()) \
  GTEST_SKIP() << "xvfb-run is absent (package xvfb): the editor tests need a virtual display"

// EXIF APP1 segments for JPEG tests (codec, the camera fit's EXIF prior).
// Values in EXIF's byte order (`big`: Motorola's).
std::vector<unsigned char> exif16(bool big, uint32_t v);
std::vector<unsigned char> exif32(bool big, uint32_t v);
// An entry: tag, type (2 ASCII, 3 SHORT, 4 LONG, 5 RATIONAL), count, and its value's bytes in the payload's byte order.
struct ExifEntryBytes {
  int tag, type, count;
  std::vector<unsigned char> value;
};
// An EXIF APP1 payload ("Exif\0\0" and a TIFF structure): IFD0 with `ifd0` and, when `exif` is not empty, a pointer
// to an Exif IFD with `exif`; values over 4 bytes go after the IFDs.
std::vector<unsigned char> exifPayload(bool big, std::vector<ExifEntryBytes> ifd0,
                                       const std::vector<ExifEntryBytes>& exif);
// `jpeg` with an APP1 segment holding `payload` after its SOI.
std::vector<unsigned char> withApp1(const std::vector<unsigned char>& jpeg, const std::vector<unsigned char>& payload);

// Test failures (labelled `what`) unless a and b map the same faces to the same photos with corner UVs
// within 1e-9 px: the incremental-equals-from-scratch invariant.
void expectSameMapping(const Mapping& a, const Mapping& b, const std::string& what);

// The message of the montage::Error thrown by `fn`, or "" (and a test failure) when none is thrown.
template <class Fn>
std::string errorOf(Fn fn) {
  try {
    fn();
  } catch (const Error& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected a montage::Error";
  return "";
}

}  // namespace montage::test

// Skips the current test when a ../shared/data file is absent, with a clear message.
#define TM_REQUIRE_SHARED(var, rel)                         \
  const std::string var = ::montage::test::sharedFile(rel); \
  if (var.empty()) GTEST_SKIP() << "../shared/data/" << (rel) << " is absent: test needs the shared data"
