// The board's devices built from board/<name>/hal.toml at start-up (the one place that knows every
// backend): each [[camera]] becomes a sim, replay, openni2, v4l2 or null DepthCamera, wrapped in a
// FaultCamera so the console can inject faults into any of them; the first [[line_scanner]] becomes
// a sim scanner (fired by a free-running simulated trigger at 100 Hz, or by the gpiod line of its
// trigger_pin when this build has libgpiod) or a replay of a rig set's profiles; the hot-plug monitor is libusb
// when a camera lists USB ids (and libusb is built), else the simulated one. Backends that this
// build lacks (no OpenNI2, libusb...) are refused with a message naming the camera.
// Start-up only: this allocates; the objects then live until exit.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "edgefuse/hal/clock.hpp"
#include "edgefuse/hal/depth_camera.hpp"
#include "edgefuse/hal/device_monitor.hpp"
#include "edgefuse/io/board_hal.hpp"
#include "edgefuse/hal/sim/fault_camera.hpp"
#include "edgefuse/hal/line_scanner.hpp"
#include "edgefuse/hal/trigger.hpp"
#include "edgefuse/hal/sim/sim_scene.hpp"

namespace edgefuse::hal {

class SimDepthCamera;
class ReplayDepthCamera;

class HalDevices {
 public:
  HalDevices();
  ~HalDevices();
  //! Builds every camera and the monitor of `board`.
  //! \param board parsed hal.toml  \param clock the HAL clock  \param err names the failing camera
  //! \param replay_override a data set folder: every camera replays its sensor from it instead
  //! \param replay_loop replayed recordings start again after their last frame (else end of stream)
  //! \param replay_speed playback speed of replayed cameras (1: the recorded rate; 0.5: half of it)
  bool build(const io::BoardHal& board, Clock& clock, std::string& err, const std::string& replay_override = "",
             bool replay_loop = true, double replay_speed = 1.0);
  int camera_count() const { return int(cameras_.size()); }
  //! Camera i as the runtime uses it (inside its FaultCamera).
  //! \param i index in hal.toml order
  FaultCamera& camera(int i) { return *faults_[std::size_t(i)]; }
  const io::BoardCamera& camera_config(int i) const { return configs_[std::size_t(i)]; }
  DeviceMonitor& monitor() { return *monitor_; }
  //! The line scanner, or null when the board has none.
  LineScanner* scanner() { return scanner_; }
  //! The true pose of a frame of camera i when its backend knows it (sim: the simulated rig's
  //! motion; replay: the recording's ground truth of that frame); edgefused uses it
  //! in place of tracking when configured. \return false for real devices or without truth
  //! \param i camera index  \param sequence the frame's device sequence number
  //! \param T_world_cam receives the camera-to-world pose
  bool known_pose(int i, uint32_t sequence, Pose& T_world_cam) const;
  //! The robot's flange pose at frame `sequence` of camera i where the simulation stands in for a
  //! robot: the sim backend's robot carries the rig with the flange at the rig's origin (its
  //! pose is the camera's pose times the camera's mounting inverted); a replayed rig set's rig
  //! frame is its reference sensor's, so the frame's ground truth. Real devices: no robot pose.
  //! \param i camera index  \param sequence the frame's sequence number  \param T_world_flange receives it
  //! \return false when no robot pose is available
  bool flange_pose(int i, uint32_t sequence, Pose& T_world_flange) const;
  //! Mounting of camera i on the rig when its backend knows it (sim: the simulated rig's mounting;
  //! edgefused falls back to it when no calibration gives the camera's extrinsics).
  //! \param i camera index  \param T_rig_cam receives the camera-to-rig pose  \return false otherwise
  bool sim_mounting(int i, Pose& T_rig_cam) const;
  //! Where the line scanner's axis carries it (sim: the simulated axis; replay: the line through
  //! the recording's first and last poses): the sensor pose at axis position 0 and the unit
  //! direction of travel, so a profile's pose is T_world_axis0 moved by axis * position.
  //! \param T_world_axis0 receives the pose at position 0  \param axis_world receives the direction
  //! \return false without a scanner or when the backend does not know its axis
  bool scanner_axis(Pose& T_world_axis0, Vec3f& axis_world) const;
  //! Names of the backends compiled into this build ("sim replay v4l2 ...").
  static const char* built_backends();

 private:
  struct Owned;
  std::unique_ptr<Owned> owned_;
  SimScene scene_;
  std::vector<io::BoardCamera> configs_;
  std::vector<DepthCamera*> cameras_;
  std::vector<const SimDepthCamera*> sim_cameras_;        // per camera, null unless sim
  std::vector<const ReplayDepthCamera*> replay_cameras_;  // per camera, null unless replay
  std::vector<std::unique_ptr<FaultCamera>> faults_;
  DeviceMonitor* monitor_ = nullptr;
  LineScanner* scanner_ = nullptr;
  bool has_scanner_axis_ = false;
  Pose scanner_axis0_;
  Vec3f scanner_axis_ = Vec3f::UnitY();
};

}  // namespace edgefuse::hal
