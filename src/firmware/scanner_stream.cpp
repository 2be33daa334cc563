#include "scanner_stream.hpp"

#include <cstdio>

#include "edgefuse/board_config.hpp"

namespace edgefuse::firmware {

bool ScannerStream::bind(hal::LineScanner& scanner, CoreBuffers& b, const BoardCapacities& board, int slot_index,
                         std::string& err) {
  const std::string where = "line_scanner '" + name + "'";
  const hal::LineScannerInfo info = scanner.info();
  model.beams = info.beams;
  model.fov_deg = info.fov_deg;
  model.min_range_m = info.min_range_m;
  model.max_range_m = info.max_range_m;
  if (slot_index < 0 || slot_index >= board.sensors_max) {
    err = where + ": board " + board.name + " has no sensor slot left for it";
    return false;
  }
  if (info.beams > b.profile_pool.beams_max) {
    err = where + ": " + std::to_string(info.beams) + " beams exceed the " + std::to_string(b.profile_pool.beams_max) +
          " of board " + board.name + "'s profile pool (its widest image)";
    return false;
  }
  slot = slot_index;
  tables.tan_theta = reinterpret_cast<real_t*>(b.ray_norms) + std::size_t(slot) * b.pixels_per_sensor;
  tables.capacity = int(b.pixels_per_sensor);
  if (tables.build(model) != Status::kOk) {
    err = where + ": bad line scanner parameters";
    return false;
  }
  // The profile pool: the memory map's region "acquisition pools: line profiles", bound once here.
  pool_ = &b.profile_pool;
  beams_ = info.beams;
  if (!hal::bind_profile_pool(*pool_, beams_, pool_views_, channel, counters)) {
    err = where + ": no profile pool in board " + board.name + "'s memory map";
    return false;
  }
  worker.reset(new hal::ScannerWorker(scanner, channel, counters));
  return true;
}

bool ScannerStream::restart_pool() {
  return pool_ != nullptr && hal::bind_profile_pool(*pool_, beams_, pool_views_, channel, counters);
}

const char* ScannerStream::status_text() const {
  auto g = [](const std::atomic<uint32_t>& a) { return unsigned(a.load(std::memory_order_relaxed)); };
  const hal::AcquisitionCounters& c = counters;
  std::snprintf(status_, sizeof(status_),
                "%s (%s) profiles %u published %u integrated %u\n"
                "drops overrun %u skipped %u gaps %u; rejects size %u stamp %u driver %u\n"
                "faults timeouts %u opens %u open_failures %u disconnects %u io_errors %u",
                hal::to_string(c.device_state()), fuse ? "map" : "not in the map", g(c.frames), g(c.published),
                unsigned(integrated), g(c.dropped_overrun), unsigned(skipped), g(c.device_gaps),
                g(c.rejected[size_t(hal::FrameReject::kSize)]), g(c.rejected[size_t(hal::FrameReject::kStamp)]),
                g(c.rejected[size_t(hal::FrameReject::kDriver)]), g(c.timeouts), g(c.opens), g(c.open_failures),
                g(c.disconnects), g(c.io_errors));
  return status_;
}

}  // namespace edgefuse::firmware
