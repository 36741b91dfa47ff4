#include "base/common.h"

#include <algorithm>
#include <cstdio>

namespace montage {

std::string printable(const std::string& text, bool keepLines) {
  static const char* kHex = "0123456789abcdef";
  std::string out;
  out.reserve(text.size());
  const auto escape = [&](const char* prefix, unsigned char byte) {
    out += prefix;
    out += kHex[byte >> 4];
    out += kHex[byte & 15];
  };
  const size_t n = text.size();
  for (size_t i = 0; i < n;) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c < 0x80) {
      if ((c < 0x20 && !(keepLines && (c == '\n' || c == '\t'))) || c == 0x7f)
        escape("\\x", c);
      else
        out += static_cast<char>(c);
      ++i;
      continue;
    }
    // The length of a well-formed UTF-8 sequence starting here (RFC 3629: no overlong forms, no
    // surrogates, nothing above U+10FFFF), or 0.
    const auto cont = [&](size_t k, unsigned char lo = 0x80, unsigned char hi = 0xbf) {
      if (i + k >= n) return false;
      const auto b = static_cast<unsigned char>(text[i + k]);
      return b >= lo && b <= hi;
    };
    size_t len = 0;
    if (c >= 0xc2 && c <= 0xdf && cont(1))
      len = 2;
    else if (c == 0xe0 && cont(1, 0xa0) && cont(2))
      len = 3;
    else if (((c >= 0xe1 && c <= 0xec) || c == 0xee || c == 0xef) && cont(1) && cont(2))
      len = 3;
    else if (c == 0xed && cont(1, 0x80, 0x9f) && cont(2))
      len = 3;
    else if (c == 0xf0 && cont(1, 0x90) && cont(2) && cont(3))
      len = 4;
    else if (c >= 0xf1 && c <= 0xf3 && cont(1) && cont(2) && cont(3))
      len = 4;
    else if (c == 0xf4 && cont(1, 0x80, 0x8f) && cont(2) && cont(3))
      len = 4;
    if (len == 0) {
      escape("\\x", c);
      ++i;
    } else if (len == 2 && c == 0xc2 && static_cast<unsigned char>(text[i + 1]) < 0xa0) {
      escape("\\u00", static_cast<unsigned char>(text[i + 1]));  // C1 control (U+0080..U+009F), e.g. CSI
      i += 2;
    } else {
      out.append(text, i, len);
      i += len;
    }
  }
  return out;
}

std::string located(const std::string& where, const std::string& what) {
  return where.empty() ? what : where + ": " + what;
}

std::string formatFixed(double v, int digits) {
  char buffer[400];  // the longest double printed in full is 309 digits before the point
  std::snprintf(buffer, sizeof buffer, "%.*f", std::clamp(digits, 0, 30), v);
  return buffer;
}

}  // namespace montage
