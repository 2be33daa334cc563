#include "edgefuse/pipeline/still_detector.hpp"

#include <algorithm>
#include <cmath>

namespace edgefuse {

void StillDetector::update(const Pose& T, uint64_t now_us) {
  if (!have_anchor_) {
    have_anchor_ = true;
    anchor_ = T;
    return;
  }
  const float moved_m = (T.t - anchor_.t).norm();
  const float cos_angle = std::clamp(0.5f * ((anchor_.R.transpose() * T.R).trace() - 1.0f), -1.0f, 1.0f);
  const float rot_deg = std::acos(cos_angle) * 57.29578f;
  if (moved_m > kMoveM || rot_deg > kRotDeg) {
    still_since_us_ = 0;
    anchor_ = T;
  } else if (still_since_us_ == 0) {
    still_since_us_ = now_us;
  }
}

}  // namespace edgefuse
