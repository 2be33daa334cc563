#include "edgefuse/hal/acquisition/acquisition_counters.hpp"

#include <cstdio>

namespace edgefuse::hal {

const char* to_string(FrameReject r) {
  switch (r) {
    case FrameReject::kNone: return "none";
    case FrameReject::kSize: return "size";
    case FrameReject::kStamp: return "stamp";
    case FrameReject::kAllInvalid: return "all_invalid";
    case FrameReject::kDriver: return "driver";
    case FrameReject::kCount: break;
  }
  return "unknown";
}

const char* to_string(DeviceState s) {
  switch (s) {
    case DeviceState::kStopped: return "stopped";
    case DeviceState::kOpening: return "opening";
    case DeviceState::kStreaming: return "streaming";
    case DeviceState::kBackoff: return "backoff";
    case DeviceState::kUnplugged: return "unplugged";
    case DeviceState::kEnded: return "ended";
  }
  return "unknown";
}

uint32_t AcquisitionCounters::rejected_total() const {
  uint32_t n = 0;
  for (const auto& r : rejected) n += r.load(std::memory_order_relaxed);
  return n;
}

int format_counters(const AcquisitionCounters& c, char* out, std::size_t size) {
  auto g = [](const std::atomic<uint32_t>& a) { return unsigned(a.load(std::memory_order_relaxed)); };
  return std::snprintf(
      out, size,
      "state=%s frames=%u published=%u dropped_overrun=%u dropped_stale=%u device_gaps=%u "
      "rejected_size=%u rejected_stamp=%u rejected_all_invalid=%u rejected_driver=%u timeouts=%u "
      "stalls=%u opens=%u open_failures=%u disconnects=%u reconnects=%u io_errors=%u",
      to_string(c.device_state()), g(c.frames), g(c.published), g(c.dropped_overrun), g(c.dropped_stale),
      g(c.device_gaps), g(c.rejected[size_t(FrameReject::kSize)]), g(c.rejected[size_t(FrameReject::kStamp)]),
      g(c.rejected[size_t(FrameReject::kAllInvalid)]), g(c.rejected[size_t(FrameReject::kDriver)]), g(c.timeouts),
      g(c.stalls), g(c.opens), g(c.open_failures), g(c.disconnects), g(c.reconnects), g(c.io_errors));
}

}  // namespace edgefuse::hal
