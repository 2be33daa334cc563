// Whether the rig stands still: its pose is compared with an anchor pose, not with the previous
// frame's. A slow motion moves little per frame when frames come fast, so a per-frame test would
// call a swaying rig still on an idle machine and moving on a loaded one. The anchor moves on when
// the rig leaves its tolerance.
#pragma once

#include <cstdint>

#include "edgefuse/math/pose.hpp"

namespace edgefuse {

class StillDetector {
 public:
  //! Tolerances: well below tracking's 1 cm / 1 degree push threshold, above a tracked pose's noise.
  static constexpr float kMoveM = 0.001f;
  static constexpr float kRotDeg = 0.1f;

  //! Forgets the anchor (mapping stopped, the device paused).
  void reset() {
    have_anchor_ = false;
    still_since_us_ = 0;
  }
  //! One pose of the rig.
  //! \param T_world_rig the pose  \param now_us the time it was taken (monotonic)
  void update(const Pose& T_world_rig, uint64_t now_us);
  //! The moment the rig stopped moving (0: moving, or not known yet).
  uint64_t still_since_us() const { return still_since_us_; }
  //! Marks the rig still from now on when it is not already (a recording has ended).
  void mark_still(uint64_t now_us) {
    if (still_since_us_ == 0) still_since_us_ = now_us;
  }

 private:
  bool have_anchor_ = false;
  Pose anchor_;
  uint64_t still_since_us_ = 0;
};

}  // namespace edgefuse
