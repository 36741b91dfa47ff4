#include "base/common.h"

namespace montage {

std::string located(const std::string& where, const std::string& what) {
  return where.empty() ? what : where + ": " + what;
}

}  // namespace montage
