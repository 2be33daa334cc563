// hal::HalDevices builds each board's devices from its hal.toml: host-sim's simulated rig
// (cameras stream, the laser fires), rpi4's real backends (objects built; no hardware here), the
// replay override, and a clear error for a replay folder that is not a recording.
#include <string>

#include "edgefuse/board_config.hpp"
#include "edgefuse/io/board_hal.hpp"
#include "edgefuse/hal/devices/hal_devices.hpp"
#include "edgefuse/hal/platform/clock/monotonic_clock.hpp"
#include "test_support.hpp"

using namespace edgefuse;
using namespace edgefuse::hal;

namespace {
DepthFrameStorage<640 * 480> g_frame;

io::BoardHal board(const char* name) {
  io::BoardHal hal;
  std::string err;
  CHECK_TEXT(io::read_board_hal(std::string(kBoardSourceDir) + "/" + name + "/hal.toml", hal, err), err.c_str());
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
  dev.camera(1).stop();
  HalDevices bad;
  CHECK_FALSE(bad.build(board("host-sim"), monotonic_clock(), err, "/nonexistent/folder"));
  STRCMP_CONTAINS("camera 'xtion': replay:", err.c_str());
}
