// The robot's flange poses as the pipeline reads them (tracking.poses = robot | robot+icp): a plain
// interface, so the pipeline knows neither the link's wire types nor the robot session that fills
// it (edgefused wires robot::RobotSession's stamped history in; tests a history of their own).
// The camera's pose at a frame is then
//   T_base_cam = T_base_flange(frame stamp + latency) * T_flange_cam
// with T_flange_cam the hand-eye mounting of the calibration store times the camera's mounting on
// the rig. The latency offset exists because a robot stamps its pose when it sends it, which is not
// when the camera exposed: at 0.25 m/s every 4 ms of offset misplace the frame by 1 mm.
#pragma once

#include <cstdint>

#include "edgefuse/math/pose.hpp"

namespace edgefuse::runtime {

class FlangePoseSource {
 public:
  virtual ~FlangePoseSource() = default;
  //! The flange's pose at a time, interpolated between the robot's pose updates around it.
  //! \param stamp_us the time (board clock)  \param T_base_flange set on success
  //! \return false when no update lies on both sides of stamp_us (too old, or not yet received)
  virtual bool flange_pose_at(uint64_t stamp_us, Pose& T_base_flange) const = 0;
};

//! The camera's pose at a frame from the robot: T_base_flange(stamp_us + latency_us) * T_flange_cam.
//! \param source the robot's poses  \param stamp_us the frame's capture stamp
//! \param latency_us how much later the robot stamps a pose than the moment it describes
//! \param T_flange_cam the camera's mounting on the flange  \param T_base_cam set on success
//! \return false when the robot has no pose at that time
inline bool robot_camera_pose(const FlangePoseSource& source, uint64_t stamp_us, int64_t latency_us,
                              const Pose& T_flange_cam, Pose& T_base_cam) {
  if (latency_us < 0 && uint64_t(-latency_us) > stamp_us) return false;
  Pose T_base_flange;
  if (!source.flange_pose_at(uint64_t(int64_t(stamp_us) + latency_us), T_base_flange)) return false;
  T_base_cam = T_base_flange * T_flange_cam;
  return true;
}

}  // namespace edgefuse::runtime
