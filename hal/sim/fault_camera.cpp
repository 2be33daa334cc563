#include "edgefuse/hal/sim/fault_camera.hpp"

#include <cstring>

namespace edgefuse::hal {

void FaultCamera::set_plugged(bool plugged) {
  unplugged_ = !plugged;
  if (monitor_) monitor_->set_present(inner_.name(), plugged);
}

HalStatus FaultCamera::start(int mode_index) {
  if (unplugged_) return HalStatus::kNoDevice;
  ++starts_;
  return inner_.start(mode_index);
}

HalStatus FaultCamera::next_frame(DepthFrame& frame, uint32_t timeout_ms) {
  if (unplugged_) return HalStatus::kNoDevice;
  const uint64_t now = clock_.now_us();
  if (now < stall_until_us_) {
    const uint64_t left = stall_until_us_ - now;
    clock_.sleep_us(left < uint64_t(timeout_ms) * 1000u ? left : uint64_t(timeout_ms) * 1000u);
    if (clock_.now_us() < stall_until_us_) return HalStatus::kTimeout;
  }
  HalStatus s = inner_.next_frame(frame, timeout_ms);
  while (s == HalStatus::kOk && drop_ > 0) {
    --drop_;
    s = inner_.next_frame(frame, timeout_ms);
  }
  if (s != HalStatus::kOk) return s;
  switch (GarbageKind(garbage_.exchange(0))) {
    case GarbageKind::kNone: break;
    case GarbageKind::kWrongSize: frame.width = frame.width / 2; break;
    case GarbageKind::kAllInvalid: std::memset(frame.depth, 0, frame.pixel_count() * sizeof(uint16_t)); break;
    case GarbageKind::kStampBack: frame.stamp_us -= frame.stamp_us > 1000000 ? 1000000 : frame.stamp_us; break;
  }
  return HalStatus::kOk;
}

}  // namespace edgefuse::hal
