// hal::HalDevices builds each board's devices from its hal.toml: host-sim's simulated rig
// (cameras stream, the laser fires), rpi4's real backends (objects built; no hardware here), the
// replay override, and a clear error for a replay folder that is not a recording. Simulator truth
// (TruthSource) comes only from the sim and replay cameras; FaultCameras only when asked for.
#include <string>

#include "edgefuse/board_config.hpp"
#include "edgefuse/io/board_hal.hpp"
#include "edgefuse/hal/devices/hal_devices.hpp"
#include "edgefuse/hal/sim/sim_depth_camera.hpp"
#include "edgefuse/hal/platform/clock/monotonic_clock.hpp"
#include "test_support.hpp"

using namespace edgefuse;
using namespace edgefuse::hal;

namespace {
DepthFrameStorage<640 * 480> g_frame;

io::BoardHal board(const char* name) {
  io::BoardHal hal;
  std::string err;
  CHECK_TEXT(io::read_board_hal(std::string(EDGEFUSE_TEST_BOARD_DIR) + "/" + name + "/hal.toml", hal, err), err.c_str());
  return hal;
}
}  // namespace

TEST_GROUP(HalDevices){};

TEST(HalDevices, HostSimIsTheSimulatedRig) {
  HalDevices dev;
  std::string err;
  CHECK_TEXT(dev.build(board("host-sim"), monotonic_clock(), err), err.c_str());
  CHECK_EQUAL(2, dev.camera_count());
  STRCMP_EQUAL("xtion", dev.camera(0).name());
  STRCMP_EQUAL("tof", dev.camera(1).name());
  CHECK(dev.camera(0).start(0) == HalStatus::kOk);
  DepthFrame f = g_frame.frame();
  CHECK(dev.camera(0).next_frame(f, 200) == HalStatus::kOk);
  CHECK_EQUAL(320, f.width);
  CHECK(f.has_colour);
  dev.camera(0).stop();
  CHECK(dev.scanner() != nullptr);
  CHECK(dev.scanner()->start() == HalStatus::kOk);
  static float ranges[1024];
  LineProfile p;
  p.ranges_m = ranges;
  p.capacity_beams = 1024;
  CHECK(dev.scanner()->next_profile(p, 200) == HalStatus::kOk);  // free-running trigger, 100 Hz
  CHECK_EQUAL(640, p.beams);
  CHECK(p.has_position);
  dev.scanner()->stop();
  CHECK(dev.monitor().present("xtion"));
  CHECK(dev.faults(0) == nullptr);  // no fault injection unless asked for: the backend itself
  CHECK(dynamic_cast<SimDepthCamera*>(&dev.camera(0)) != nullptr);
}

// The sim cameras' truth: the rig's motion times the mounting, the flange at the rig's origin,
// the mounting of sim_tof_config().
TEST(HalDevices, SimCamerasOfferTheirTruth) {
  HalDevices dev;
  std::string err;
  CHECK_TEXT(dev.build(board("host-sim"), monotonic_clock(), err), err.c_str());
  const TruthSource* xtion = dev.truth(0);
  const TruthSource* tof = dev.truth(1);
  CHECK(xtion != nullptr && tof != nullptr);
  CHECK(dev.truth(2) == nullptr && dev.truth(-1) == nullptr);
  Pose T_rig_tof, T_world_tof, T_world_flange, T_world_xtion;
  CHECK(tof->mounting(T_rig_tof));
  const SimDepthCameraConfig tc = sim_tof_config();
  CHECK((T_rig_tof.t - tc.T_rig_cam.t).norm() < 1e-6f);
  CHECK(tof->pose_of(12, T_world_tof));
  CHECK(tof->flange_pose_of(12, T_world_flange));
  CHECK(((T_world_flange * T_rig_tof).t - T_world_tof.t).norm() < 1e-5f);
  CHECK(xtion->flange_pose_of(0, T_world_flange) && xtion->pose_of(0, T_world_xtion));
  CHECK((T_world_flange.t - T_world_xtion.t).norm() < 1e-6f);  // the xtion is the rig's origin
}

// inject_faults: every camera inside a FaultCamera, its unplug reported by the simulated monitor.
TEST(HalDevices, FaultsOnlyWhenAskedFor) {
  HalDevices dev;
  std::string err;
  CHECK_TEXT(dev.build(board("host-sim"), monotonic_clock(), err, "", true, 1.0, true), err.c_str());
  FaultCamera* f = dev.faults(0);
  CHECK(f != nullptr && dev.faults(1) != nullptr);
  CHECK(&dev.camera(0) == static_cast<DepthCamera*>(f));
  f->set_plugged(false);
  CHECK_FALSE(dev.monitor().present("xtion"));
  CHECK(dev.camera(0).start(0) == HalStatus::kNoDevice);
  f->set_plugged(true);
  CHECK(dev.monitor().present("xtion"));
  CHECK(dev.truth(0) != nullptr);  // the truth is the backend's, faults or not
}

TEST(HalDevices, Rpi4BuildsItsRealBackends) {
  HalDevices dev;
  std::string err;
  const bool ok = dev.build(board("rpi4"), monotonic_clock(), err);
  const std::string built = HalDevices::built_backends();
  if (built.find("openni2") == std::string::npos || built.find("v4l2") == std::string::npos ||
      built.find("gpiod") == std::string::npos) {
    CHECK_FALSE(ok);  // refused, naming the missing backend
    STRCMP_CONTAINS("this build has no", err.c_str());
    return;
  }
  CHECK_TEXT(ok, err.c_str());
  CHECK_EQUAL(2, dev.camera_count());
  DepthMode m;
  CHECK(dev.camera(1).mode(0, m));
  CHECK_EQUAL(160, m.width);
  DOUBLES_EQUAL(5000.0, m.depth_scale, 1e-2);  // depth_unit_m = 0.0002 from the board
  CHECK(dev.scanner() != nullptr);
  CHECK(dev.truth(0) == nullptr && dev.truth(1) == nullptr);  // real devices know no truth
}

TEST(HalDevices, ReplayOverrideAndItsErrors) {
  const std::string rig = edgefuse_test::require_data("bin_rig_a");
  if (rig.empty()) return;
  HalDevices dev;
  std::string err;
  CHECK_TEXT(dev.build(board("host-sim"), monotonic_clock(), err, rig), err.c_str());
  CHECK(dev.camera(1).start(0) == HalStatus::kOk);
  DepthFrame f = g_frame.frame();
  CHECK(dev.camera(1).next_frame(f, 200) == HalStatus::kOk);
  CHECK(f.has_amplitude);  // the recorded tof
  // The recording's ground truth: the frame's pose, which is also the robot's flange pose; no mounting.
  const TruthSource* truth = dev.truth(1);
  CHECK(truth != nullptr);
  Pose T, T_flange;
  CHECK(truth->pose_of(f.sequence, T));
  CHECK(truth->flange_pose_of(f.sequence, T_flange));
  CHECK((T.t - T_flange.t).norm() == 0.0f);
  CHECK_FALSE(truth->mounting(T));
  dev.camera(1).stop();
  HalDevices bad;
  CHECK_FALSE(bad.build(board("host-sim"), monotonic_clock(), err, "/nonexistent/folder"));
  STRCMP_CONTAINS("camera 'xtion': replay:", err.c_str());
}
