#include "edgefuse/hal/replay/replay_line_scanner.hpp"

#include <cmath>
#include <cstring>

namespace edgefuse::hal {

ReplayLineScanner::ReplayLineScanner(const io::LineScan& scan, ReplayRate rate, Clock& clock, double speed)
    : scan_(scan), rate_(rate), clock_(clock), speed_(speed > 0 ? speed : 1.0) {}

LineScannerInfo ReplayLineScanner::info() const {
  const io::LineScannerParams& p = scan_.sensor.line;
  return LineScannerInfo{p.beams, p.fov_deg, p.min_range_m, p.max_range_m};
}

HalStatus ReplayLineScanner::start() {
  if (scan_.profiles.size() == 0) return HalStatus::kNoDevice;
  // The axis: first and last profiles with a pose.
  std::size_t first = scan_.has_pose.size(), last = 0;
  for (std::size_t p = 0; p < scan_.has_pose.size(); ++p)
    if (scan_.has_pose[p]) {
      if (first == scan_.has_pose.size()) first = p;
      last = p;
    }
  has_axis_ = first < last;
  if (has_axis_) {
    origin_ = scan_.T_world_sensor[first].t;
    const Vec3f d = scan_.T_world_sensor[last].t - origin_;
    has_axis_ = d.norm() > 1e-6f;
    if (has_axis_) axis_ = d.normalized();
  }
  running_ = true;
  index_ = 0;
  start_us_ = clock_.now_us();
  return HalStatus::kOk;
}

HalStatus ReplayLineScanner::next_profile(LineProfile& profile, uint32_t timeout_ms) {
  if (!running_) return HalStatus::kNotStarted;
  const int beams = scan_.profiles.beams;
  if (profile.ranges_m == nullptr || profile.capacity_beams < beams) return HalStatus::kInvalidArgument;
  if (index_ >= scan_.profiles.size()) return HalStatus::kEndOfStream;
  const double offset_s = scan_.profiles.stamps_s[index_] - scan_.profiles.stamps_s[0];
  const uint64_t stamp_us = start_us_ + uint64_t(std::llround(offset_s / speed_ * 1e6));
  if (rate_ == ReplayRate::kRecorded) {
    const uint64_t now = clock_.now_us();
    if (stamp_us > now) {
      if (stamp_us - now > uint64_t(timeout_ms) * 1000u) {
        clock_.sleep_us(uint64_t(timeout_ms) * 1000u);
        return HalStatus::kTimeout;
      }
      clock_.sleep_us(stamp_us - now);
    }
  }
  std::memcpy(profile.ranges_m, scan_.profiles.profile(index_), std::size_t(beams) * sizeof(float));
  profile.beams = beams;
  profile.stamp_us = stamp_us;
  profile.sequence = uint32_t(index_);
  profile.has_position = has_axis_ && scan_.has_pose[index_];
  profile.axis_position_m = profile.has_position ? double(axis_.dot(scan_.T_world_sensor[index_].t - origin_)) : 0.0;
  ++index_;
  return HalStatus::kOk;
}

}  // namespace edgefuse::hal
