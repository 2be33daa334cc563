// The calibration store's poses as the maths' Pose, and the questions every reader of the store
// asks of them: is the hand-eye still the stored default, and where is a sensor on the rig.
#pragma once

#include "edgefuse/math/pose.hpp"
#include "edgefuse/runtime/calibration.hpp"

namespace edgefuse::runtime {

//! The stored pose (translation, quaternion x y z w) as a Pose.
//! \param p a pose of the calibration data
inline Pose to_pose(const CalibPose& p) {
  return Pose::from_tq(p.tq[0], p.tq[1], p.tq[2], p.tq[3], p.tq[4], p.tq[5], p.tq[6]);
}

//! True when the pose is the store's default (the identity): nothing was calibrated into it.
//! \param p a pose of the calibration data
inline bool is_default(const CalibPose& p) {
  const CalibPose unset;
  for (int k = 0; k < 7; ++k)
    if (p.tq[k] != unset.tq[k]) return false;
  return true;
}

//! The sensor's mounting on the rig, T_rig_sensor, from the stored pair ("rig", sensor).
//! \param d the calibration data
//! \param sensor the sensor's name
//! \param T_rig_sensor set when the pair is stored, else left as it is
//! \return false when the store has no such pair
inline bool rig_mounting(const CalibrationData& d, const char* sensor, Pose& T_rig_sensor) {
  const SensorPair* p = calib_find_pair(d, "rig", sensor);
  if (p == nullptr) return false;
  T_rig_sensor = to_pose(p->T_from_to);
  return true;
}

}  // namespace edgefuse::runtime
