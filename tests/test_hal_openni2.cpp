// The openni2 backend on OpenNI2's built-in Dummy device (Debian's libopenni2-0 ships it in
// OpenNI2/Drivers/libDummyDevice.so): real API, real driver thread, no hardware. The Dummy
// streams 320x240 DEPTH_1_MM at 30 fps, first row 2000 mm, a moving disc near 1000 mm; it has
// no registration, so no colour is delivered. .oni playback plays a recording the test makes with
// OpenNI2's Recorder from the Dummy (oni_test_recording.cpp: written to a temp dir, not committed).
#include <chrono>
#include <cmath>
#include <string>
#include <thread>

#include "edgefuse/hal/acquisition/camera_worker.hpp"
#include "edgefuse/hal/openni2/openni2_depth_camera.hpp"
#include "edgefuse/hal/platform/clock/monotonic_clock.hpp"
#include "oni_test_recording.hpp"
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

TEST(HalOpenni2, ColourWithoutRegistrationIsAReportedState) {
  // The Dummy has a colour sensor but cannot register it to depth: colour is not delivered and the
  // reason is a state (and one stderr line), not silence.
  Openni2DepthCamera cam(dummy(), monotonic_clock());
  CHECK_TEXT(cam.start(0) == HalStatus::kOk, cam.last_error());
  CHECK(cam.colour_state() == Openni2ColourState::kRegistrationUnsupported);
  STRCMP_EQUAL("registration to depth unsupported", to_string(cam.colour_state()));
  CHECK_FALSE(cam.colour_registered());
  DepthFrame f = g_frame.frame();
  CHECK(cam.next_frame(f, 1000) == HalStatus::kOk);
  CHECK_FALSE(f.has_colour);
  cam.stop();
  Openni2CameraConfig c = dummy();
  c.colour = false;
  Openni2DepthCamera depth_only(c, monotonic_clock());
  CHECK_TEXT(depth_only.start(0) == HalStatus::kOk, depth_only.last_error());
  CHECK(depth_only.colour_state() == Openni2ColourState::kNotRequested);
}

namespace {

// A Dummy recording (patched as a PrimeSense recording, see oni_test_recording.hpp) in a temp dir.
struct OniRecording {
  std::string dir, path, error;
  int frames = 0;
  explicit OniRecording(bool patch, int wanted = 10) {
    dir = edgefuse_test::make_temp_dir();
    if (dir.empty()) {
      error = "no temp dir";
      return;
    }
    path = dir + "/dummy.oni";
    error = edgefuse_test::record_dummy_oni(path, wanted, frames);
    if (error.empty() && patch) error = edgefuse_test::add_cropping_record(path);
  }
  ~OniRecording() {
    if (!path.empty()) std::remove(path.c_str());
    if (!dir.empty()) std::remove(dir.c_str());
  }
};

Openni2CameraConfig recording(const std::string& path, bool fast, bool loop) {
  Openni2CameraConfig c = dummy();
  c.uri = path.c_str();
  c.playback_fast = fast;
  c.playback_loop = loop;
  return c;
}

// Plays until the end; checks every frame against what the Dummy recorded.
void play_to_end(Openni2DepthCamera& cam, int recorded, bool every_frame) {
  DepthFrame f = g_frame.frame();
  int got = 0;
  uint32_t last_seq = 0;
  uint64_t last_stamp = 0;
  HalStatus s = HalStatus::kOk;
  for (int k = 0; k < 4 * recorded + 10; ++k) {
    s = cam.next_frame(f, 2000);
    if (s != HalStatus::kOk) break;
    ++got;
    CHECK_EQUAL(320, f.width);
    CHECK_EQUAL(240, f.height);
    DOUBLES_EQUAL(1000.0, f.depth_scale, 0);
    CHECK_EQUAL(2000, f.depth[5]);  // the Dummy's first row, through the 16zT codec
    if (got > 1) {
      CHECK(f.sequence > last_seq);
      // Recorded spacing kept: the Dummy stamps its frames 33 ms apart.
      const uint64_t d_us = f.stamp_us - last_stamp;
      CHECK_EQUAL(0u, d_us % 33000u);
      CHECK(d_us >= 33000u);
      if (every_frame) {
        CHECK_EQUAL(last_seq + 1, f.sequence);
        CHECK_EQUAL(33000u, d_us);
      }
    } else if (every_frame) {
      CHECK_EQUAL(1u, f.sequence);
    }
    last_seq = f.sequence;
    last_stamp = f.stamp_us;
  }
  CHECK_EQUAL(int(HalStatus::kEndOfStream), int(s));
  CHECK_EQUAL(uint32_t(recorded), last_seq);  // the last recorded frame always arrives
  if (every_frame) CHECK_EQUAL(recorded, got);
  // The end is immediate and stays the end (no waiting for a timeout).
  const auto t0 = std::chrono::steady_clock::now();
  CHECK(cam.next_frame(f, 5000) == HalStatus::kEndOfStream);
  CHECK(std::chrono::steady_clock::now() - t0 < std::chrono::milliseconds(1000));
}

}  // namespace

TEST(HalOpenni2, OniRecordingPlaysEveryFrameAsFastAsPossibleThenEnds) {
  OniRecording rec(true);
  CHECK_TEXT(rec.error.empty(), rec.error.c_str());
  CHECK_TEXT(rec.frames >= 5, StringFromFormat("recorded %d", rec.frames).asCharString());
  Openni2DepthCamera cam(recording(rec.path, true, false), monotonic_clock());
  CHECK_TEXT(cam.start(0) == HalStatus::kOk, cam.last_error());
  CHECK(cam.is_recording());
  CHECK_EQUAL(rec.frames, cam.recorded_frames());
  CHECK(cam.colour_state() == Openni2ColourState::kNoColourSensor);  // only depth was recorded
  play_to_end(cam, rec.frames, true);
  // Reopen (what the runtime does) plays it again from the start.
  cam.stop();
  CHECK_TEXT(cam.start(0) == HalStatus::kOk, cam.last_error());
  play_to_end(cam, rec.frames, true);
}

TEST(HalOpenni2, OniRecordingAtTheRecordedRateEnds) {
  OniRecording rec(true);
  CHECK_TEXT(rec.error.empty(), rec.error.c_str());
  Openni2DepthCamera cam(recording(rec.path, false, false), monotonic_clock());
  CHECK_TEXT(cam.start(0) == HalStatus::kOk, cam.last_error());
  // OpenNI2 keeps only the newest frame at a fixed rate: a slow reader may skip, never reorder.
  play_to_end(cam, rec.frames, false);
}

TEST(HalOpenni2, OniRecordingLoops) {
  OniRecording rec(true);
  CHECK_TEXT(rec.error.empty(), rec.error.c_str());
  Openni2DepthCamera cam(recording(rec.path, true, true), monotonic_clock());
  CHECK_TEXT(cam.start(0) == HalStatus::kOk, cam.last_error());
  DepthFrame f = g_frame.frame();
  uint64_t last_stamp = 0;
  for (int k = 0; k < 2 * rec.frames + 3; ++k) {
    CHECK_EQUAL(int(HalStatus::kOk), int(cam.next_frame(f, 2000)));
    CHECK(f.stamp_us > last_stamp);  // monotonic across the wrap
    last_stamp = f.stamp_us;
  }
}

TEST(HalOpenni2, RecordingWithoutCroppingIsRefusedWithTheReason) {
  OniRecording rec(false);  // as the Dummy records it: OpenNI2 2.2's player would drop every frame
  CHECK_TEXT(rec.error.empty(), rec.error.c_str());
  Openni2DepthCamera cam(recording(rec.path, true, false), monotonic_clock());
  CHECK(cam.start(0) == HalStatus::kBadFrame);
  STRCMP_CONTAINS(rec.path.c_str(), cam.last_error());
  STRCMP_CONTAINS("no cropping property", cam.last_error());
}

TEST(HalOpenni2, AcquisitionRuntimeEndsWithTheRecording) {
  OniRecording rec(true);
  CHECK_TEXT(rec.error.empty(), rec.error.c_str());
  Openni2DepthCamera cam(recording(rec.path, true, false), monotonic_clock());
  AcquisitionCounters cnt;
  FrameChannel ch;
  CHECK(g_channel.bind(ch, cnt));
  CameraWorker worker(cam, ch, cnt, monotonic_clock());
  CHECK(worker.start(CameraWorkerConfig{}));
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (worker.state() != DeviceState::kEnded && std::chrono::steady_clock::now() < end) {
    if (const DepthFrame* f = ch.acquire_newest()) ch.release(f);
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  CHECK(worker.state() == DeviceState::kEnded);
  worker.stop();
  CHECK_EQUAL(uint64_t(rec.frames), uint64_t(cnt.frames.load()));
  CHECK_EQUAL(0u, cnt.rejected_total());
  CHECK_EQUAL(0u, uint64_t(cnt.timeouts.load()));
}
