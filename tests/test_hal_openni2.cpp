// The openni2 backend on OpenNI2's built-in Dummy device (Debian's libopenni2-0 ships it in
// OpenNI2/Drivers/libDummyDevice.so): real API, real driver thread, no hardware. The Dummy
// streams 320x240 DEPTH_1_MM at 30 fps, first row 2000 mm, a moving disc near 1000 mm; it has
// no registration, so no colour is delivered.
#include <chrono>
#include <cmath>
#include <string>
#include <thread>

#include "hal/acquisition/camera_worker.hpp"
#include "hal/openni2/openni2_depth_camera.hpp"
#include "hal/posix/monotonic_clock.hpp"
#include "test_support.hpp"

using namespace edgefuse;
using namespace edgefuse::hal;

namespace {
DepthFrameStorage<320 * 240> g_frame;
FrameChannelStorage<320 * 240, 4> g_channel;

Openni2CameraConfig dummy() {
  Openni2CameraConfig c;
  c.name = "xtion";
  c.uri = "Dummy";
  c.width = 320;
  c.height = 240;
  c.fps = 30;
  return c;
}
}  // namespace

TEST_GROUP(HalOpenni2){};

TEST(HalOpenni2, DummyDeviceStreamsDepthThroughTheBackend) {
  Openni2DepthCamera cam(dummy(), monotonic_clock());
  const HalStatus s = cam.start(0);
  CHECK_TEXT(s == HalStatus::kOk, cam.last_error());
  CHECK_FALSE(cam.colour_registered());
  const PinholeIntrinsics in = cam.intrinsics();
  CHECK(in.validate() == Status::kOk);
  DOUBLES_EQUAL(0.5 * 320 / std::tan(0.5 * 58.0 * 3.14159265 / 180.0), in.fx, 0.1);  // FOV not reported
  DepthFrame f = g_frame.frame();
  uint32_t last_seq = 0;
  uint64_t last_stamp = 0;
  for (int k = 0; k < 5; ++k) {
    CHECK_EQUAL(int(HalStatus::kOk), int(cam.next_frame(f, 1000)));
    CHECK_EQUAL(320, f.width);
    CHECK_EQUAL(240, f.height);
    DOUBLES_EQUAL(1000.0, f.depth_scale, 0);
    CHECK_FALSE(f.has_colour);
    CHECK_EQUAL(2000, f.depth[5]);  // first row: 2 m
    int disc = 0;
    for (std::size_t i = 320; i < f.pixel_count(); ++i) disc += f.depth[i] != 0;
    CHECK(disc > 0 && disc < 400);  // the moving disc
    if (k > 0) {
      CHECK(f.sequence > last_seq);
      CHECK(f.stamp_us > last_stamp);
    }
    last_seq = f.sequence;
    last_stamp = f.stamp_us;
  }
  cam.stop();
  // Reopen after stop (what the runtime does after a stall).
  CHECK_TEXT(cam.start(0) == HalStatus::kOk, cam.last_error());
  CHECK(cam.next_frame(f, 1000) == HalStatus::kOk);
  CHECK(f.stamp_us > last_stamp);
}

TEST(HalOpenni2, WrongModeNamesTheOfferedModes) {
  Openni2CameraConfig c = dummy();
  c.width = 640;
  c.height = 480;
  Openni2DepthCamera cam(c, monotonic_clock());
  CHECK(cam.start(0) == HalStatus::kInvalidArgument);
  STRCMP_CONTAINS("no depth mode 640x480@30 1mm", cam.last_error());
  STRCMP_CONTAINS("320x240@30", cam.last_error());
}

TEST(HalOpenni2, MissingDeviceIsNoDevice) {
  Openni2CameraConfig c = dummy();
  c.uri = "/nonexistent/recording.oni";
  Openni2DepthCamera cam(c, monotonic_clock());
  CHECK(cam.start(0) == HalStatus::kNoDevice);
  STRCMP_CONTAINS("/nonexistent/recording.oni", cam.last_error());
}

TEST(HalOpenni2, AcquisitionRuntimeStreamsTheDummy) {
  Openni2DepthCamera cam(dummy(), monotonic_clock());
  AcquisitionCounters cnt;
  FrameChannel ch;
  CHECK(g_channel.bind(ch, cnt));
  CameraWorker worker(cam, ch, cnt, monotonic_clock());
  CHECK(worker.start(CameraWorkerConfig{}));
  int taken = 0;
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (taken < 10 && std::chrono::steady_clock::now() < end) {
    if (const DepthFrame* f = ch.acquire_newest()) {
      ++taken;
      ch.release(f);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  worker.stop();
  CHECK_EQUAL(10, taken);
  CHECK_EQUAL(0u, cnt.rejected_total());
}
