// When to push (integrate) a tracked frame (paper Fig. 3: "if T_sensor * inverse(T_last_push)
// exceeds a threshold"). A frame is pushed when its translation from the last pushed pose,
// |t_new - t_last| (the norm of the difference, not the difference of the norms as in the
// authors' watchdog), or the angle of R_last^T R_new exceeds its threshold, or on every frame
// when asked. The tracker adds the two fixed rules: the first frame of an empty space is pushed at
// its initial pose, and a lost frame is never pushed.
#pragma once

#include "edgefuse/math/pose.hpp"

namespace edgefuse {

struct PushPolicy {
  //! Push after this much translation since the last push. Default 0.01 m: a 2x2-pixel shift of
  //! the view at 1 m for Kinect-class optics, so new surface is added about every few frames of
  //! normal motion while a still sensor stops spending time (and weight) on identical views.
  float min_translation_m = 0.01f;
  //! ... or this much rotation (degrees). Default 1 degree: about the same image shift as 1 cm at
  //! 0.6 m, i.e. the same rule for turning.
  float min_rotation_deg = 1.0f;
  //! Push every tracked (not lost) frame regardless of motion (KinectFusion's behaviour).
  bool every_frame = false;

  //! Non-negative thresholds.
  bool valid() const { return min_translation_m >= 0.0f && min_rotation_deg >= 0.0f; }
};

//! Whether the frame at `now` has moved far enough from `last_push` to be integrated.
//! \param p policy  \param last_push pose of the last pushed frame  \param now this frame's pose
bool moved_enough_to_push(const PushPolicy& p, const Pose& last_push, const Pose& now);

}  // namespace edgefuse
