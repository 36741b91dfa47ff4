// Shared vocabulary of the core library: the project namespace, the error type and checking macros.
#pragma once

#include <Eigen/Core>
#include <stdexcept>
#include <string>

namespace montage {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;
using Vec2f = Eigen::Vector2f;
using Vec3f = Eigen::Vector3f;
using Vec4f = Eigen::Vector4f;

// Text safe to show on a terminal or in a log: control characters (C0 including newline and tab
// unless `keepLines`, DEL, and C1 written as UTF-8) become \xNN (C1 as \u00NN), and bytes that are
// not valid UTF-8 become \xNN. Valid UTF-8 (accented names) is kept. Idempotent: its output contains
// none of the escaped bytes, so escaping twice changes nothing.
std::string printable(const std::string& text, bool keepLines = false);

// Every failure the user can cause (bad file, bad field, impossible request) is reported with this
// exception. The message names the file, the field or element, and the reason, e.g.
//   "scene.json: points[3].at[0].x: 1032.5 is outside photo 0 'a.png' (width 1024)".
// The message goes through printable(): bytes copied from a file or a path (ESC, BEL, newlines) can
// never reach a terminal raw.
class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(printable(message)) {}
  explicit Error(const char* message) : Error(std::string(message)) {}
};

// Thrown when a running job sees its cancel flag; never shown to the user as an error.
class Cancelled : public std::exception {
 public:
  const char* what() const noexcept override { return "cancelled"; }
};

// Builds "<where>: <what>" with an optional location prefix (file or file:line).
std::string located(const std::string& where, const std::string& what);

// `v` with `digits` digits after the point ("%.*f"): the figures of reports and messages.
std::string formatFixed(double v, int digits);

}  // namespace montage

// TM_CHECK(cond, msg): throws montage::Error(msg) when cond is false. msg may be any expression yielding
// std::string. Use for input validation; internal invariants use TM_ASSERT.
#define TM_CHECK(cond, msg)                     \
  do {                                          \
    if (!(cond)) throw ::montage::Error((msg)); \
  } while (0)

// TM_ASSERT(cond): an internal invariant. Failing it is a bug in TextureMontage, reported with the
// source file and line so that a user can file it, never a crash.
#define TM_ASSERT(cond)                                                                                         \
  do {                                                                                                          \
    if (!(cond))                                                                                                \
      throw ::montage::Error(std::string("internal error: ") + #cond + " failed at " + __FILE__ + ":" +         \
                             std::to_string(__LINE__) + " (please report this with the input that caused it)"); \
  } while (0)
