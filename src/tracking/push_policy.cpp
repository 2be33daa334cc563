#include "edgefuse/tracking/push_policy.hpp"

#include "edgefuse/tracking/se3.hpp"

namespace edgefuse {

bool moved_enough_to_push(const PushPolicy& p, const Pose& last_push, const Pose& now) {
  if (p.every_frame) return true;
  float dt, angle;
  pose_distance(last_push, now, dt, angle);
  return dt > p.min_translation_m || angle > p.min_rotation_deg * 3.14159265f / 180.0f;
}

}  // namespace edgefuse
