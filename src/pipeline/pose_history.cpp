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

}  // namespace edgefuse
