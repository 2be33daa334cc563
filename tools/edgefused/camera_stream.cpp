#include "camera_stream.hpp"

#include <cstdio>
#include <cstring>

#include "edgefuse/board_config.hpp"
#include "edgefuse/sensor/pinhole.hpp"

namespace edgefuse::wire {

bool CameraStream::bind(CoreBuffers& b, const BoardCapacities& board, bool bilateral, std::string& err) {
  const std::string where = "camera '" + name + "'";
  if (index < 0 || index >= board.sensors_max || index >= kBuildBoard.sensors_max) {
    err = where + ": board " + board.name + " has buffers for " + std::to_string(board.sensors_max) + " sensors";
    return false;
  }
  if (intr.width > board.image_width_max || intr.height > board.image_height_max) {
    err = where + ": a " + std::to_string(intr.width) + "x" + std::to_string(intr.height) +
          " image exceeds board " + board.name + "'s largest image";
    return false;
  }
  const std::size_t off = std::size_t(index) * b.pixels_per_sensor;
  const int w = intr.width, h = intr.height;
  ray_norms = ImageView<real_t>(reinterpret_cast<real_t*>(b.ray_norms) + off, w, h);
  if (build_ray_norms<real_t>(intr, ray_norms) != Status::kOk) {
    err = where + ": bad intrinsics";
    return false;
  }
  scratch = b.scratch(index);
  // Tracking ICP and calib fuse read depth, vertex and normal only: no colour map, so the raycast
  // skips its colour lookups (as edgefuse track).
  maps = b.raycast_maps(index, w, h, false);
  filtered = ImageView<uint16_t>(b.depth_frames + off, w, h);
  trust = b.trust_maps != nullptr ? ImageView<uint8_t>(b.trust_maps + off, w, h) : ImageView<uint8_t>();
  if (b.pyramid<real_t>(index, intr, pyramid) != Status::kOk) {
    err = where + ": the frame pyramid does not fit the board's buffers";
    return false;
  }
  icp_ws = b.icp_workspace<real_t>(index);
  filters = DepthFilterChain<real_t>::defaults_for(intr, tof ? DepthSensorKind::kTimeOfFlight
                                                             : DepthSensorKind::kStructuredLight);
  filters.bilateral_enabled = bilateral;
  if (filters.prepare(intr) != Status::kOk) {
    err = where + ": the depth filters refuse its intrinsics";
    return false;
  }
  noise = tof ? NoiseModel::time_of_flight() : NoiseModel::structured_light();
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

bool CameraStream::filter_held(ImageView<uint16_t> filter_scratch) {
  if (held == nullptr) return false;
  return filters.run(held->depth_view(), held->amplitude_view(),
                     ImageView<uint16_t>(filter_scratch.data, held->width, held->height),
                     ImageView<uint16_t>(filtered.data, held->width, held->height)) == Status::kOk;
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

}  // namespace edgefuse::wire
