#include "edgefuse/hal/devices/hal_devices.hpp"

#include "edgefuse/io/dataset.hpp"
#include "edgefuse/hal/null/null_backends.hpp"
#include "edgefuse/hal/replay/replay_depth_camera.hpp"
#include "edgefuse/hal/sim/sim_depth_camera.hpp"
#include "edgefuse/io/rig.hpp"
#include "edgefuse/hal/replay/replay_line_scanner.hpp"
#include "edgefuse/hal/sim/sim_device_monitor.hpp"
#include "edgefuse/hal/sim/sim_line_scanner.hpp"
#include "edgefuse/hal/sim/sim_position.hpp"
#include "edgefuse/hal/sim/sim_trigger.hpp"
#if EDGEFUSE_HAVE_GPIOD
#include "edgefuse/hal/gpiod/gpiod_trigger.hpp"
#endif
#if EDGEFUSE_HAVE_OPENNI2
#include "edgefuse/hal/openni2/openni2_depth_camera.hpp"
#endif
#if EDGEFUSE_HAVE_V4L2
#include "edgefuse/hal/v4l2/v4l2_depth_camera.hpp"
#endif
#if EDGEFUSE_HAVE_LIBUSB
#include "edgefuse/hal/libusb/usb_device_monitor.hpp"
#endif

namespace edgefuse::hal {

struct HalDevices::Owned {
  std::vector<std::unique_ptr<DepthCamera>> cameras;
  std::vector<std::unique_ptr<io::DepthSequence>> sequences;
  ReplayEpoch replay_epoch;  // the replayed cameras play one recording on one time base
  std::unique_ptr<SimDeviceMonitor> sim_monitor;
  std::unique_ptr<DeviceMonitor> usb_monitor;
  std::unique_ptr<TriggerInput> trigger;
  std::unique_ptr<PositionSource> axis;
  std::unique_ptr<LineScanner> scanner;
  std::unique_ptr<io::LineScan> line_scan;
  std::string trigger_chip;
#if EDGEFUSE_HAVE_OPENNI2
  std::vector<std::unique_ptr<Openni2CameraConfig>> oni_configs;
#endif
#if EDGEFUSE_HAVE_V4L2
  std::vector<std::unique_ptr<V4l2CameraConfig>> v4l2_configs;
#endif
};

HalDevices::HalDevices() : owned_(new Owned) { default_bin_scene(scene_); }
HalDevices::~HalDevices() = default;

bool HalDevices::scanner_axis(Pose& T_world_axis0, Vec3f& axis_world) const {
  if (scanner_ == nullptr || !has_scanner_axis_) return false;
  T_world_axis0 = scanner_axis0_;
  axis_world = scanner_axis_;
  return true;
}

const char* HalDevices::built_backends() {
  return "sim replay null"
#if EDGEFUSE_HAVE_OPENNI2
         " openni2"
#endif
#if EDGEFUSE_HAVE_V4L2
         " v4l2"
#endif
#if EDGEFUSE_HAVE_LIBUSB
         " libusb"
#endif
#if EDGEFUSE_HAVE_GPIOD
         " gpiod"
#endif
      ;
}

namespace {

std::string camera_where(const io::BoardCamera& c) { return "camera '" + c.name + "'"; }
std::string scanner_where(const io::BoardScanner& sc) { return "line_scanner '" + sc.name + "'"; }

}  // namespace

bool HalDevices::make_sim_camera(const io::BoardCamera& c, Clock& clock, uint64_t& rig_epoch_us,
                                 std::unique_ptr<DepthCamera>& cam, const TruthSource*& truth, std::string& err) {
  SimDepthCameraConfig sc;
  if (c.name == "xtion")
    sc = sim_xtion_config();
  else if (c.name == "tof")
    sc = sim_tof_config();
  else {
    err = camera_where(c) + ": the sim backend knows the rig's 'xtion' and 'tof'";
    return false;
  }
  if (c.fps > 0) sc.fps = c.fps;
  sc.rig_path = sim_rig_path_;
  SimDepthCamera* sc_cam = new SimDepthCamera(sc, scene_, clock);
  // One rig: its cameras' poses follow the same motion clock (each starts on its own thread).
  if (rig_epoch_us == 0) rig_epoch_us = clock.now_us();
  sc_cam->set_rig_epoch_us(rig_epoch_us);
  sim_rig_epoch_us_ = rig_epoch_us;
  cam.reset(sc_cam);
  truth = sc_cam;
  return true;
}

bool HalDevices::make_replay_camera(const io::BoardCamera& c, const std::string& folder, Clock& clock, bool loop,
                                    double speed, std::unique_ptr<DepthCamera>& cam, const TruthSource*& truth,
                                    std::string& err) {
  std::unique_ptr<io::DepthSequence> seq(new io::DepthSequence);
  std::string e;
  // A rig set replays the sensor of the camera's name; other layouts take no sensor name.
  if (!io::open_depth_sequence(folder, c.name, *seq, e) && !io::open_depth_sequence(folder, "", *seq, e)) {
    err = camera_where(c) + ": replay: " + e;
    return false;
  }
  ReplayDepthCamera* rc = new ReplayDepthCamera(*seq, ReplayRate::kRecorded, clock, loop, speed);
  rc->share_epoch(owned_->replay_epoch);
  cam.reset(rc);
  if (rc->has_truth()) truth = rc;
  owned_->sequences.push_back(std::move(seq));
  return true;
}

#if EDGEFUSE_HAVE_OPENNI2
bool HalDevices::make_openni2_camera(const io::BoardCamera& c, Clock& clock, bool loop,
                                     std::unique_ptr<DepthCamera>& cam, std::string&) {
  std::unique_ptr<Openni2CameraConfig> oc(new Openni2CameraConfig);
  oc->name = c.name.c_str();
  oc->uri = c.uri.c_str();
  if (c.width) oc->width = c.width;
  if (c.height) oc->height = c.height;
  if (c.fps) oc->fps = c.fps;
  oc->playback_loop = loop;  // an .oni uri loops like a replay folder
  if (c.has_intrinsics) {
    oc->intr.fx = float(c.fx);
    oc->intr.fy = float(c.fy);
    oc->intr.cx = float(c.cx);
    oc->intr.cy = float(c.cy);
  }
  cam.reset(new Openni2DepthCamera(*oc, clock));
  owned_->oni_configs.push_back(std::move(oc));
  return true;
}
#else
bool HalDevices::make_openni2_camera(const io::BoardCamera& c, Clock&, bool, std::unique_ptr<DepthCamera>&,
                                     std::string& err) {
  err = camera_where(c) + ": this build has no openni2 backend (libopenni2-dev missing); built: " + built_backends();
  return false;
}
#endif

#if EDGEFUSE_HAVE_V4L2
bool HalDevices::make_v4l2_camera(const io::BoardCamera& c, std::unique_ptr<DepthCamera>& cam, std::string&) {
  std::unique_ptr<V4l2CameraConfig> vc(new V4l2CameraConfig);
  vc->name = c.name.c_str();
  vc->device = c.uri.c_str();
  vc->intr.width = c.width;
  vc->intr.height = c.height;
  vc->intr.fx = float(c.fx);
  vc->intr.fy = float(c.fy);
  vc->intr.cx = float(c.cx);
  vc->intr.cy = float(c.cy);
  vc->depth_unit_m = float(c.depth_unit_m);
  if (c.fps) vc->fps = c.fps;
  cam.reset(new V4l2DepthCamera(*vc, linux_v4l2_sys()));
  owned_->v4l2_configs.push_back(std::move(vc));
  return true;
}
#else
bool HalDevices::make_v4l2_camera(const io::BoardCamera& c, std::unique_ptr<DepthCamera>&, std::string& err) {
  err = camera_where(c) + ": this build has no v4l2 backend; built: " + built_backends();
  return false;
}
#endif

bool HalDevices::add_camera(const io::BoardCamera& c, Clock& clock, const std::string& replay_override,
                            bool replay_loop, double replay_speed, uint64_t& rig_epoch_us, bool& any_usb,
                            std::string& err) {
  std::unique_ptr<DepthCamera> cam;
  const TruthSource* truth = nullptr;  // sim, or a recording with ground truth
  const io::CameraBackend backend = replay_override.empty() ? c.backend : io::CameraBackend::kReplay;
  bool made = true;
  switch (backend) {
    case io::CameraBackend::kSim: made = make_sim_camera(c, clock, rig_epoch_us, cam, truth, err); break;
    case io::CameraBackend::kReplay:
      made = make_replay_camera(c, replay_override.empty() ? c.uri : replay_override, clock, replay_loop,
                                replay_speed, cam, truth, err);
      break;
    case io::CameraBackend::kOpenni2: made = make_openni2_camera(c, clock, replay_loop, cam, err); break;
    case io::CameraBackend::kV4l2: made = make_v4l2_camera(c, cam, err); break;
    case io::CameraBackend::kNull: cam.reset(new NullDepthCamera); break;
  }
  if (!made) return false;
  any_usb = any_usb || (c.has_usb && replay_override.empty() && backend != io::CameraBackend::kSim);
  configs_.push_back(c);
  cameras_.push_back(cam.get());
  truths_.push_back(truth);
  owned_->cameras.push_back(std::move(cam));
  return true;
}

void HalDevices::watch_usb(bool any_usb, Clock& clock) {
#if EDGEFUSE_HAVE_LIBUSB
  if (any_usb) {
    std::unique_ptr<UsbDeviceMonitor> usb(new UsbDeviceMonitor(libusb_api(), clock));
    for (const io::BoardCamera& c : configs_)
      if (c.has_usb) usb->watch(c.name.c_str(), c.usb_vid, c.usb_pid);
    monitor_ = usb.get();
    owned_->usb_monitor = std::move(usb);
  }
#else
  (void)any_usb;  // without libusb a vanished camera is retried with back-off
  (void)clock;
#endif
}

bool HalDevices::add_replay_scanner(const io::BoardScanner& sc, const std::string& replay_override, Clock& clock,
                                    double replay_speed, std::string& err) {
  const std::string where = scanner_where(sc);
  if (replay_override.empty()) {
    err = where + ": replay needs a rig set (edgefuse acquire --replay DATASET)";
    return false;
  }
  io::RigToml rig;
  std::unique_ptr<io::LineScan> scan(new io::LineScan);
  if (!io::read_rig_toml(replay_override + "/rig.toml", rig, err) || !io::open_line_scan(rig, sc.name, *scan, err)) {
    err = where + ": replay: " + err;
    return false;
  }
  // The scanner's sweep keeps its own time base: a rig set records it after the cameras' frames
  // (bin_rig_a: 1 s after), and played as recorded it would arrive when the cameras have ended.
  owned_->scanner.reset(new ReplayLineScanner(*scan, ReplayRate::kRecorded, clock, replay_speed));
  // The axis as the replay reports positions: from the first to the last recorded pose.
  std::size_t first = scan->has_pose.size(), last = 0;
  for (std::size_t p = 0; p < scan->has_pose.size(); ++p)
    if (scan->has_pose[p]) {
      if (first == scan->has_pose.size()) first = p;
      last = p;
    }
  if (first < last && (scan->T_world_sensor[last].t - scan->T_world_sensor[first].t).norm() > 1e-6f) {
    scanner_axis0_ = scan->T_world_sensor[first];
    scanner_axis_ = (scan->T_world_sensor[last].t - scan->T_world_sensor[first].t).normalized();
    has_scanner_axis_ = true;
  }
  owned_->line_scan = std::move(scan);
  return true;
}

#if EDGEFUSE_HAVE_GPIOD
bool HalDevices::make_gpiod_trigger(const io::BoardPin& pin, const io::BoardScanner&, Clock& clock, std::string&) {
  owned_->trigger_chip = pin.chip;
  GpiodLineConfig lc;
  lc.chip = owned_->trigger_chip.c_str();
  lc.offset = unsigned(pin.offset);
  owned_->trigger.reset(new GpiodTriggerInput(lc, *libgpiod_api(), clock));
  return true;
}
#else
bool HalDevices::make_gpiod_trigger(const io::BoardPin&, const io::BoardScanner& sc, Clock&, std::string& err) {
  err = scanner_where(sc) + ": trigger_pin '" + sc.trigger_pin + "' needs the gpiod backend; built: " +
        built_backends();
  return false;
}
#endif

bool HalDevices::add_sim_scanner(const io::BoardHal& board, const io::BoardScanner& sc, Clock& clock,
                                 std::string& err) {
  const io::BoardPin* pin = sc.trigger_pin.empty() ? nullptr : board.find_pin(sc.trigger_pin);
  if (pin) {
    if (!make_gpiod_trigger(*pin, sc, clock, err)) return false;
  } else {
    owned_->trigger.reset(new SimTriggerInput(10000u, clock));  // 100 profiles per second
  }
  // The robot moves the scanner at 0.1 m/s back and forth over the bin's 0.3 m (bin_rig_a's
  // laser path starts at the bin's -y wall).
  owned_->axis.reset(new SimLinearAxis(clock.now_us(), 0.0, 0.1, 0.299));
  const SimLineScannerConfig lc = sim_laser_config();
  owned_->scanner.reset(new SimLineScanner(lc, scene_, *owned_->trigger, *owned_->axis));
  scanner_axis0_ = lc.T_world_axis0;
  scanner_axis_ = lc.axis_world;
  has_scanner_axis_ = true;
  return true;
}

bool HalDevices::build(const io::BoardHal& board, Clock& clock, std::string& err, const std::string& replay_override,
                       bool replay_loop, double replay_speed, bool inject_faults) {
  owned_->sim_monitor.reset(new SimDeviceMonitor(clock));
  monitor_ = owned_->sim_monitor.get();
  bool any_usb = false;
  uint64_t rig_epoch_us = 0;  // the sim rig's motion starts when its devices are built
  for (const io::BoardCamera& c : board.cameras)
    if (!add_camera(c, clock, replay_override, replay_loop, replay_speed, rig_epoch_us, any_usb, err)) return false;
  watch_usb(any_usb, clock);
  if (!board.scanners.empty()) {
    const io::BoardScanner& sc = board.scanners[0];
    const bool replay = !replay_override.empty() || sc.backend == io::ScannerBackend::kReplay;
    if (replay) {
      if (!add_replay_scanner(sc, replay_override, clock, replay_speed, err)) return false;
    } else if (sc.backend == io::ScannerBackend::kSim) {
      if (!add_sim_scanner(board, sc, clock, err)) return false;
    }
    scanner_ = owned_->scanner.get();
  }
  // Faults only when asked for; an unplug is reported by the simulated monitor (even when libusb
  // watches the real bus).
  used_ = cameras_;
  if (inject_faults)
    for (std::size_t i = 0; i < cameras_.size(); ++i) {
      faults_.emplace_back(new FaultCamera(*cameras_[i], clock, owned_->sim_monitor.get()));
      used_[i] = faults_.back().get();
    }
  return true;
}

}  // namespace edgefuse::hal
