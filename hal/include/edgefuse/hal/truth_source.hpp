// Simulator truth: what a simulated or recorded camera knows about where it was, and what a real
// device never knows. Offered only by the sim backend's camera (SimDepthCamera: the simulated rig's
// motion and mounting) and the replay backend's camera (ReplayDepthCamera: the recording's ground
// truth); HalDevices::truth(i) hands it out, null for every other backend. Its users decide
// whether to use it from their configuration (edgefused: tracking.poses = known,
// tracking.sim_truth): nothing takes it just because it is there.
#pragma once

#include <cstdint>

#include "edgefuse/math/pose.hpp"

namespace edgefuse::hal {

class TruthSource {
 public:
  virtual ~TruthSource() = default;

  //! The true camera-to-world pose of the frame with device sequence number `sequence`.
  //! sim: the simulated rig's motion at that frame times the camera's mounting on the rig;
  //! replay: the recording's ground truth of that frame (loops included).
  //! \param sequence the frame's DepthFrame::sequence  \param T_world_cam receives the pose
  //! \return false when the frame has no truth (a recording without a pose for it)
  virtual bool pose_of(uint32_t sequence, Pose& T_world_cam) const = 0;
  //! The robot's flange pose at frame `sequence`, where the simulation stands in for a robot.
  //! sim: the simulated robot carries the rig with its flange at the rig's origin, so the
  //! camera's true pose times its mounting inverted; replay: a rig set's rig frame is its
  //! reference sensor's, so the frame's ground truth.
  //! \param sequence the frame's sequence number  \param T_world_flange receives the pose
  //! \return false when there is no robot pose for the frame
  virtual bool flange_pose_of(uint32_t sequence, Pose& T_world_flange) const = 0;
  //! The camera's mounting on the rig. sim: the simulated rig's mounting (bin_rig_a's
  //! extrinsics); replay: none (a rig set's extrinsics.txt is read from the set itself).
  //! \param T_rig_cam receives the camera-to-rig pose  \return false when the backend does not know it
  virtual bool mounting(Pose& T_rig_cam) const = 0;
};

}  // namespace edgefuse::hal
