// The board's devices built from board/<name>/hal.toml at start-up (the one place that knows every
// backend): each [[camera]] becomes a sim, replay, openni2, v4l2 or null DepthCamera (wrapped in
// the simulator's FaultCamera only when build() is asked to inject faults: tests, `edgefuse
// acquire --fault`); the sim and replay cameras offer simulator truth (TruthSource, truth(i)),
// which their users take only when configured to; the first [[line_scanner]] becomes
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
#include "edgefuse/hal/truth_source.hpp"
#include "edgefuse/hal/sim/sim_rig_path.hpp"
#include "edgefuse/hal/sim/sim_scene.hpp"

namespace edgefuse::hal {

class HalDevices {
 public:
  HalDevices();
  ~HalDevices();
  //! Builds every camera and the monitor of `board`.
  //! \param board parsed hal.toml  \param clock the HAL clock  \param err names the failing camera
  //! \param replay_override a data set folder: every camera replays its sensor from it instead
  //! \param replay_loop replayed recordings start again after their last frame (else end of stream)
  //! \param replay_speed playback speed of replayed cameras (1: the recorded rate; 0.5: half of it)
  //! \param inject_faults wrap every camera in a FaultCamera (faults(i)) whose unplug/replug the
  //! simulated monitor reports; else camera(i) is the backend itself
  bool build(const io::BoardHal& board, Clock& clock, std::string& err, const std::string& replay_override = "",
             bool replay_loop = true, double replay_speed = 1.0, bool inject_faults = false);
  //! Before build(): the sim cameras' rig follows these key poses instead of its circle.
  //! \param path kept by pointer (must outlive the devices); null: the circle
  void set_sim_rig_path(const SimRigPath* path) { sim_rig_path_ = path; }
  //! The HAL clock time (us) the sim rig's motion started at (its path's time 0); 0 without sim cameras.
  uint64_t sim_rig_epoch_us() const { return sim_rig_epoch_us_; }
  int camera_count() const { return int(cameras_.size()); }
  //! Camera i as the runtime uses it: the backend, or its FaultCamera when faults are injected.
  //! \param i index in hal.toml order
  DepthCamera& camera(int i) { return *used_[std::size_t(i)]; }
  //! Camera i's fault injection, or null unless build() was asked to inject faults.
  //! \param i index in hal.toml order
  FaultCamera* faults(int i) { return faults_.empty() ? nullptr : faults_[std::size_t(i)].get(); }
  const io::BoardCamera& camera_config(int i) const { return configs_[std::size_t(i)]; }
  DeviceMonitor& monitor() { return *monitor_; }
  //! The line scanner, or null when the board has none.
  LineScanner* scanner() { return scanner_; }
  //! Simulator truth of camera i (TruthSource: true poses, the robot's flange pose, the
  //! mounting): the sim backend's camera, or a replayed recording with ground truth; null for
  //! real devices, the null backend and recordings without poses. Take it only when configured to.
  //! \param i camera index
  const TruthSource* truth(int i) const {
    return i < 0 || i >= int(truths_.size()) ? nullptr : truths_[std::size_t(i)];
  }
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
  // build()'s steps: each returns false with err naming the camera or scanner it cannot build.
  //! Camera c on its backend (every camera replays from replay_override when that is set).
  bool add_camera(const io::BoardCamera& c, Clock& clock, const std::string& replay_override, bool replay_loop,
                  double replay_speed, uint64_t& rig_epoch_us, bool& any_usb, std::string& err);
  bool make_sim_camera(const io::BoardCamera& c, Clock& clock, uint64_t& rig_epoch_us,
                       std::unique_ptr<DepthCamera>& cam, const TruthSource*& truth, std::string& err);
  bool make_replay_camera(const io::BoardCamera& c, const std::string& folder, Clock& clock, bool loop, double speed,
                          std::unique_ptr<DepthCamera>& cam, const TruthSource*& truth, std::string& err);
  bool make_openni2_camera(const io::BoardCamera& c, Clock& clock, bool loop, std::unique_ptr<DepthCamera>& cam,
                           std::string& err);
  bool make_v4l2_camera(const io::BoardCamera& c, std::unique_ptr<DepthCamera>& cam, std::string& err);
  //! The libusb monitor replaces the simulated one when a camera lists USB ids (and libusb is built).
  void watch_usb(bool any_usb, Clock& clock);
  bool add_replay_scanner(const io::BoardScanner& sc, const std::string& replay_override, Clock& clock,
                          double replay_speed, std::string& err);
  bool add_sim_scanner(const io::BoardHal& board, const io::BoardScanner& sc, Clock& clock, std::string& err);
  //! The scanner's trigger on the gpiod line of its trigger_pin.
  bool make_gpiod_trigger(const io::BoardPin& pin, const io::BoardScanner& sc, Clock& clock, std::string& err);

  std::unique_ptr<Owned> owned_;
  SimScene scene_;
  std::vector<io::BoardCamera> configs_;
  std::vector<DepthCamera*> cameras_;                 // the backends
  std::vector<DepthCamera*> used_;                    // per camera: the backend or its FaultCamera
  std::vector<const TruthSource*> truths_;            // per camera, null unless sim / replay with truth
  std::vector<std::unique_ptr<FaultCamera>> faults_;  // empty unless faults are injected
  DeviceMonitor* monitor_ = nullptr;
  LineScanner* scanner_ = nullptr;
  const SimRigPath* sim_rig_path_ = nullptr;
  uint64_t sim_rig_epoch_us_ = 0;
  bool has_scanner_axis_ = false;
  Pose scanner_axis0_;
  Vec3f scanner_axis_ = Vec3f::UnitY();
};

}  // namespace edgefuse::hal
