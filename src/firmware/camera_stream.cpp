#include "camera_stream.hpp"

#include <cstdio>
#include <cstring>

#include "edgefuse/board_config.hpp"

namespace edgefuse::firmware {

bool CameraStream::bind(CoreBuffers& b, const BoardCapacities& board, const PinholeIntrinsics& intr, bool tof,
                        bool bilateral, std::string& err) {
  const std::string where = "camera '" + name + "'";
  if (index >= kBuildBoard.sensors_max) {
    err = where + ": board " + board.name + " has buffers for " + std::to_string(board.sensors_max) + " sensors";
    return false;
  }
  // Tracking ICP and calib fuse read depth, vertex and normal only: no colour map, so the raycast
  // skips its colour lookups.
  const char* why = "";
  if (slot.bind(b, board, index, intr, tof ? DepthSensorKind::kTimeOfFlight : DepthSensorKind::kStructuredLight,
                bilateral, false, &why) != Status::kOk) {
    err = where + ": " + why + " (board " + board.name + ")";
    return false;
  }
  // The frame pool: this sensor slot's pool in the memory map (kFramePoolSlots frames of the
  // board's largest image; regions "acquisition pools: ..."), bound once here.
  pools_ = &b.frame_pools;
  if (!hal::bind_frame_pool(*pools_, index, pool_views_, channel, counters)) {
    err = where + ": no frame pool for sensor slot " + std::to_string(index) + " in board " + board.name +
          "'s memory map";
    return false;
  }
  return true;
}

bool CameraStream::restart_pool() {
  held = nullptr;
  held_new = false;
  paired_stamp_us = 0;
  return pools_ != nullptr && hal::bind_frame_pool(*pools_, index, pool_views_, channel, counters);
}

bool CameraStream::take_newest() {
  const hal::DepthFrame* f = channel.acquire_newest();
  if (f == nullptr) return false;
  if (held != nullptr) {
    if (held_new && fuse) ++skipped;  // a camera outside the map only keeps its newest frame
    channel.release(held);
  }
  held = f;
  held_new = true;
  return true;
}

bool CameraStream::take_nearest(uint64_t stamp_us) {
  const hal::DepthFrame* f = channel.acquire_nearest(stamp_us);
  if (f == nullptr) return false;
  auto dist = [stamp_us](const hal::DepthFrame* x) {
    return x->stamp_us > stamp_us ? x->stamp_us - stamp_us : stamp_us - x->stamp_us;
  };
  if (held != nullptr && dist(held) <= dist(f)) {  // the held one is still the better partner
    channel.release(f);
    return false;
  }
  if (held != nullptr) {
    if (held_new && fuse) ++unpaired;
    channel.release(held);
  }
  held = f;
  held_new = true;
  return true;
}

void CameraStream::release_held() {
  if (held != nullptr) channel.release(held);
  held = nullptr;
  held_new = false;
}

SensorFrame CameraStream::held_frame() const {
  SensorFrame f;
  if (held == nullptr) return f;
  f.depth = held->depth_view();
  f.amplitude = held->amplitude_view();
  if (held->has_colour) f.colour = held->colour_view();
  f.stamp_us = held->stamp_us;
  return f;
}

const char* CameraStream::status_text() const {
  // Three short lines (the console cuts a line at 255 bytes): state and frames, losses, faults.
  auto g = [](const std::atomic<uint32_t>& a) { return unsigned(a.load(std::memory_order_relaxed)); };
  const hal::AcquisitionCounters& c = counters;
  const hal::DeviceState st = c.device_state();
  using R = hal::FrameReject;
  std::snprintf(status_, sizeof(status_),
                "%s%s (%s) frames %u published %u integrated %u\n"
                "drops stale %u overrun %u skipped %u unpaired %u gaps %u; rejects size %u stamp %u all_invalid %u "
                "driver %u\n"
                "faults timeouts %u stalls %u opens %u open_failures %u disconnects %u reconnects %u io_errors %u",
                hal::to_string(st), st == hal::DeviceState::kEnded ? " (end of recording)" : "",
                fuse ? "map" : "not in the map", g(c.frames), g(c.published), unsigned(integrated), g(c.dropped_stale),
                g(c.dropped_overrun), unsigned(skipped), unsigned(unpaired), g(c.device_gaps),
                g(c.rejected[size_t(R::kSize)]), g(c.rejected[size_t(R::kStamp)]),
                g(c.rejected[size_t(R::kAllInvalid)]), g(c.rejected[size_t(R::kDriver)]), g(c.timeouts), g(c.stalls),
                g(c.opens), g(c.open_failures), g(c.disconnects), g(c.reconnects), g(c.io_errors));
  return status_;
}

}  // namespace edgefuse::firmware
