#include "edgefuse/pipeline/pose_history.hpp"

#include <algorithm>

namespace edgefuse {

void PoseHistory::record(uint64_t stamp_us, const Pose& T_world_ref, bool placed) {
  have_velocity_ = have_pose_ && placed && stamp_us >= stamp_us_ + kVelocityGapMinUs &&
                   stamp_us - stamp_us_ <= kVelocityGapMaxUs;
  prev_pose_ = pose_;
  prev_stamp_us_ = stamp_us_;
  pose_ = T_world_ref;
  stamp_us_ = stamp_us;
  have_pose_ = placed;
}

Pose PoseHistory::pose_at(uint64_t stamp_us) const {
  if (!have_velocity_) return pose_;
  const double gap_us = double(stamp_us_ - prev_stamp_us_), window_us = double(kPairWindowUs);
  const double since_us = std::clamp(double(stamp_us) - double(stamp_us_), -gap_us - window_us, window_us);
  return interpolate(prev_pose_, pose_, float(1.0 + since_us / gap_us));
}

bool StampedPoseHistory::record(uint64_t stamp_us, const Pose& T_base_flange) {
  if (count_ > 0 && stamp_us <= at(count_ - 1).stamp_us) {
    ++refused_;
    return false;
  }
  ring_[head_] = Entry{stamp_us, T_base_flange};
  head_ = (head_ + 1) % kCapacity;
  if (count_ < kCapacity) ++count_;
  ++recorded_;
  return true;
}

bool StampedPoseHistory::newest(Pose& T_base_flange, uint64_t& stamp_us) const {
  if (count_ == 0) return false;
  T_base_flange = at(count_ - 1).T_base_flange;
  stamp_us = at(count_ - 1).stamp_us;
  return true;
}

bool StampedPoseHistory::pose_at(uint64_t stamp_us, Pose& T_base_flange) const {
  if (count_ == 0 || stamp_us < at(0).stamp_us || stamp_us > at(count_ - 1).stamp_us) return false;
  // Binary search for the last pose at or before stamp_us.
  int lo = 0, hi = count_ - 1;
  while (lo < hi) {
    const int mid = (lo + hi + 1) / 2;
    if (at(mid).stamp_us <= stamp_us)
      lo = mid;
    else
      hi = mid - 1;
  }
  const Entry& a = at(lo);
  if (a.stamp_us == stamp_us || lo == count_ - 1) {
    T_base_flange = a.T_base_flange;
    return true;
  }
  const Entry& b = at(lo + 1);
  const float s = float(double(stamp_us - a.stamp_us) / double(b.stamp_us - a.stamp_us));
  T_base_flange = interpolate(a.T_base_flange, b.T_base_flange, s);
  return true;
}

}  // namespace edgefuse

