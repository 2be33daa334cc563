#include "edgefuse/hal/acquisition/frame_checks.hpp"

namespace edgefuse::hal {

FrameReject FrameChecks::check(const DepthFrame& f, uint32_t& gap) {
  // Sequence gaps first: a rejected frame still arrived, so it is not counted as missing.
  gap = have_seq_ && f.sequence > last_seq_ + 1 ? f.sequence - last_seq_ - 1 : 0;
  have_seq_ = true;
  last_seq_ = f.sequence;
  if (f.width != mode_.width || f.height != mode_.height || !f.fits(f.width, f.height)) return FrameReject::kSize;
  if (f.stamp_us <= last_stamp_us_) return FrameReject::kStamp;
  const std::size_t n = f.pixel_count();
  std::size_t i = 0;
  while (i < n && f.depth[i] == 0) ++i;
  if (i == n) return FrameReject::kAllInvalid;
  last_stamp_us_ = f.stamp_us;
  return FrameReject::kNone;
}

}  // namespace edgefuse::hal
