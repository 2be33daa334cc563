// The V4L2 backend against a fake driver at the kernel boundary: format negotiation (Z16, Y16,
// neither, a size the driver adjusts), mmap buffer cycling with a padded stride, stamps and
// sequence from the buffers, timeouts, EINTR, corrupt and truncated buffers, and a device that
// vanishes (ENODEV) and comes back.
#include <linux/videodev2.h>

#include <cstring>
#include <string>
#include <vector>

#include "edgefuse/hal/v4l2/fake_v4l2_sys.hpp"
#include "edgefuse/hal/v4l2/v4l2_depth_camera.hpp"
#include "test_support.hpp"

using namespace edgefuse;
using namespace edgefuse::hal;

namespace {
DepthFrameStorage<320 * 240> g_frame;

V4l2CameraConfig config() {
  V4l2CameraConfig c;
  c.device = "/dev/video-fake";
  c.intr.width = 320;
  c.intr.height = 240;
  c.intr.fx = c.intr.fy = 250;
  c.intr.cx = 159.5f;
  c.intr.cy = 119.5f;
  c.depth_unit_m = 0.00025f;  // 1/4 mm units, as some ToF cameras
  return c;
}

std::vector<uint16_t> pattern(uint16_t base) {
  std::vector<uint16_t> d(320 * 240);
  for (std::size_t i = 0; i < d.size(); ++i) d[i] = uint16_t(base + i % 1000);
  return d;
}
}  // namespace

TEST_GROUP(HalV4l2) {
  FakeV4l2Sys sys;
  void setup() override { sys.formats = {V4L2_PIX_FMT_YUYV, V4L2_PIX_FMT_Y16, V4L2_PIX_FMT_Z16}; }
};

TEST(HalV4l2, NegotiatesZ16AndMapsTheGrantedBuffers) {
  V4l2DepthCamera cam(config(), sys);
  CHECK(cam.start(0) == HalStatus::kOk);
  CHECK_EQUAL(uint32_t(V4L2_PIX_FMT_Z16), cam.pixel_format());
  CHECK_EQUAL(3, cam.buffer_count());  // asked for 4, the driver granted 3
  CHECK_EQUAL(3u, sys.queued());
  CHECK_EQUAL(1, sys.streamon_calls);
  DOUBLES_EQUAL(4000.0, cam.intrinsics().depth_scale, 1e-3);
  cam.stop();
  CHECK_EQUAL(3, sys.munmaps);
  CHECK_EQUAL(1, sys.closes);
  CHECK_FALSE(sys.is_open());
}

TEST(HalV4l2, FallsBackToY16) {
  sys.formats = {V4L2_PIX_FMT_YUYV, V4L2_PIX_FMT_Y16};
  V4l2DepthCamera cam(config(), sys);
  CHECK(cam.start(0) == HalStatus::kOk);
  CHECK_EQUAL(uint32_t(V4L2_PIX_FMT_Y16), cam.pixel_format());
}

TEST(HalV4l2, RefusesADeviceWithoutDepthFormats) {
  sys.formats = {V4L2_PIX_FMT_YUYV};
  V4l2DepthCamera cam(config(), sys);
  CHECK(cam.start(0) == HalStatus::kInvalidArgument);
  CHECK(std::string(cam.last_error()).find("neither Z16 nor Y16") != std::string::npos);
  CHECK(std::string(cam.last_error()).find("/dev/video-fake") != std::string::npos);
  CHECK_FALSE(sys.is_open());
}

TEST(HalV4l2, RefusesASizeTheDriverAdjusts) {
  sys.width = 640;
  sys.height = 480;
  V4l2DepthCamera cam(config(), sys);
  CHECK(cam.start(0) == HalStatus::kInvalidArgument);
  STRCMP_CONTAINS("driver offers 640x480 Z16", cam.last_error());
  CHECK_FALSE(sys.is_open());
}

TEST(HalV4l2, CyclesBuffersAndCopiesRowsWithoutThePadding) {
  V4l2DepthCamera cam(config(), sys);
  CHECK(cam.start(0) == HalStatus::kOk);
  DepthFrame f = g_frame.frame();
  for (int k = 0; k < 10; ++k) {  // more frames than buffers: each buffer must come back
    const std::vector<uint16_t> d = pattern(uint16_t(100 * k));
    CHECK(sys.push_frame(d.data(), 5000000u + uint64_t(k) * 33333u));
    CHECK(cam.next_frame(f, 100) == HalStatus::kOk);
    CHECK_EQUAL(320, f.width);
    CHECK_EQUAL(240, f.height);
    CHECK_EQUAL(uint32_t(k), f.sequence);
    CHECK_EQUAL(5000000u + uint64_t(k) * 33333u, f.stamp_us);
    CHECK(std::memcmp(d.data(), f.depth, d.size() * 2) == 0);
    CHECK_EQUAL(3u, sys.queued());
  }
  CHECK_EQUAL(0, sys.driver_drops);
}

TEST(HalV4l2, TimesOutAndSurvivesEintr) {
  V4l2DepthCamera cam(config(), sys);
  CHECK(cam.start(0) == HalStatus::kOk);
  DepthFrame f = g_frame.frame();
  CHECK(cam.next_frame(f, 10) == HalStatus::kTimeout);
  const std::vector<uint16_t> d = pattern(7);
  sys.push_frame(d.data(), 1000);
  sys.poll_eintr = 2;
  CHECK(cam.next_frame(f, 10) == HalStatus::kOk);
  CHECK_EQUAL(0, sys.poll_eintr);
}

TEST(HalV4l2, CorruptAndTruncatedBuffersAreBadFramesAndGoBack) {
  V4l2DepthCamera cam(config(), sys);
  CHECK(cam.start(0) == HalStatus::kOk);
  DepthFrame f = g_frame.frame();
  const std::vector<uint16_t> d = pattern(7);
  sys.push_frame(d.data(), 1000, V4L2_BUF_FLAG_ERROR);
  CHECK(cam.next_frame(f, 10) == HalStatus::kBadFrame);
  STRCMP_CONTAINS("corrupt", cam.last_error());
  sys.push_frame(d.data(), 2000, 0, 1000);
  CHECK(cam.next_frame(f, 10) == HalStatus::kBadFrame);
  STRCMP_CONTAINS("truncated frame (1000 of", cam.last_error());
  CHECK_EQUAL(3u, sys.queued());
  sys.push_frame(d.data(), 3000);
  CHECK(cam.next_frame(f, 10) == HalStatus::kOk);
}

TEST(HalV4l2, VanishedDeviceIsNoDeviceUntilItReturns) {
  V4l2DepthCamera cam(config(), sys);
  CHECK(cam.start(0) == HalStatus::kOk);
  DepthFrame f = g_frame.frame();
  sys.vanish();
  CHECK(cam.next_frame(f, 10) == HalStatus::kNoDevice);
  STRCMP_CONTAINS("No such device", cam.last_error());
  cam.stop();
  CHECK_FALSE(sys.is_open());
  CHECK(cam.start(0) == HalStatus::kNoDevice);  // open: ENOENT
  sys.present = true;
  CHECK(cam.start(0) == HalStatus::kOk);
  const std::vector<uint16_t> d = pattern(9);
  sys.push_frame(d.data(), 4000);
  CHECK(cam.next_frame(f, 10) == HalStatus::kOk);
}
