#include "base/job.h"

namespace montage {

void JobControl::checkCancel() const {
  if (cancelled()) throw Cancelled();
}

void JobControl::progress(StageId stage, double fraction, const std::string& what) const {
  checkCancel();
  if (callback_) callback_(stage, fraction, what);
}

}  // namespace montage
