// The replay backend on the shared recordings: TUM fr1/xyz at full speed (every frame, recorded
// spacing of stamps, end of stream), the recorded rate on a manual clock, a rig set's paired
// sensors and its line scanner with axis positions.
#include <cmath>
#include <cstdint>
#include <string>

#include "edgefuse/io/dataset.hpp"
#include "edgefuse/io/rig.hpp"
#include "edgefuse/hal/acquisition/frame_pairer.hpp"
#include "edgefuse/hal/null/null_backends.hpp"
#include "edgefuse/hal/platform/clock/monotonic_clock.hpp"
#include "edgefuse/hal/replay/replay_depth_camera.hpp"
#include "edgefuse/hal/replay/replay_line_scanner.hpp"
#include "test_support.hpp"

using namespace edgefuse;
using namespace edgefuse::hal;

namespace {
DepthFrameStorage<640 * 480> g_frame;
}

TEST_GROUP(HalReplay){};

TEST(HalReplay, TumAtFullSpeedDeliversEveryFrameWithRecordedSpacing) {
  const std::string dir = edgefuse_test::require_data("tum_fr1_xyz_37");
  if (dir.empty()) return;
  io::DepthSequence seq;
  std::string err;
  CHECK_TEXT(io::open_depth_sequence(dir, "", seq, err), err.c_str());
  ReplayDepthCamera cam(seq, ReplayRate::kFastest, monotonic_clock());
  DepthMode m;
  CHECK(cam.mode(0, m));
  CHECK_EQUAL(640, m.width);
  CHECK(m.fps >= 25 && m.fps <= 35);  // fr1 is 30 Hz
  CHECK(m.colour);
  CHECK(cam.start(0) == HalStatus::kOk);
  DepthFrame f = g_frame.frame();
  uint64_t first = 0;
  for (std::size_t i = 0; i < seq.frames.size(); ++i) {
    CHECK(cam.next_frame(f, 0) == HalStatus::kOk);  // no waiting at full speed
    CHECK_EQUAL(uint32_t(i), f.sequence);
    CHECK(f.has_colour);
    DOUBLES_EQUAL(5000.0, f.depth_scale, 0);
    if (i == 0) first = f.stamp_us;
    const double offset_s = seq.frames[i].stamp_s - seq.frames[0].stamp_s;
    DOUBLES_EQUAL(offset_s * 1e6, double(f.stamp_us - first), 1.0);
  }
  CHECK(cam.next_frame(f, 0) == HalStatus::kEndOfStream);
}

TEST(HalReplay, RecordedRateWaitsForEachFrame) {
  const std::string dir = edgefuse_test::require_data("bin_rig_a");
  if (dir.empty()) return;
  io::DepthSequence seq;
  std::string err;
  CHECK_TEXT(io::open_depth_sequence(dir, "tof", seq, err), err.c_str());
  ManualClock clock;
  ReplayDepthCamera cam(seq, ReplayRate::kRecorded, clock, true);
  CHECK(cam.start(0) == HalStatus::kOk);
  DepthFrame f = g_frame.frame();
  const uint64_t t0 = clock.now_us();
  CHECK(cam.next_frame(f, 100) == HalStatus::kOk);
  CHECK(f.has_amplitude);
  CHECK_EQUAL(t0, f.stamp_us);
  CHECK(cam.next_frame(f, 100) == HalStatus::kTimeout);  // frames are 0.2 s apart
  CHECK(cam.next_frame(f, 300) == HalStatus::kOk);
  CHECK_EQUAL(t0 + 200000u, f.stamp_us);
  CHECK_EQUAL(t0 + 200000u, clock.now_us());
  // Looping: after the last of the 20 frames the first comes again, one period later.
  for (int i = 2; i < 20; ++i) CHECK(cam.next_frame(f, 1000) == HalStatus::kOk);
  CHECK(cam.next_frame(f, 1000) == HalStatus::kOk);
  CHECK_EQUAL(t0 + 20u * 200000u, f.stamp_us);
  CHECK_EQUAL(20u, f.sequence);
}

TEST(HalReplay, RigSensorsPairFrameByFrame) {
  const std::string dir = edgefuse_test::require_data("bin_rig_a");
  if (dir.empty()) return;
  io::DepthSequence xs, ts;
  std::string err;
  CHECK_TEXT(io::open_depth_sequence(dir, "xtion", xs, err), err.c_str());
  CHECK_TEXT(io::open_depth_sequence(dir, "tof", ts, err), err.c_str());
  ManualClock clock;
  ReplayDepthCamera xc(xs, ReplayRate::kFastest, clock), tc(ts, ReplayRate::kFastest, clock);
  CHECK(xc.start(0) == HalStatus::kOk);
  CHECK(tc.start(0) == HalStatus::kOk);
  static DepthFrameStorage<320 * 240> xstore[4];
  static DepthFrameStorage<320 * 240> tstore[4];
  DepthFrame xf[4], tf[4];
  for (int i = 0; i < 4; ++i) {
    xf[i] = xstore[i].frame();
    tf[i] = tstore[i].frame();
  }
  AcquisitionCounters xcnt, tcnt;
  FrameChannel xch, tch;
  CHECK(xch.init(xf, 4, &xcnt));
  CHECK(tch.init(tf, 4, &tcnt));
  FramePairer pairer(xch, tch, 5000);
  int pairs = 0;
  for (int i = 0; i < 20; ++i) {
    CHECK(xc.next_frame(xch.producer_frame(), 0) == HalStatus::kOk);
    xch.publish();
    CHECK(tc.next_frame(tch.producer_frame(), 0) == HalStatus::kOk);
    tch.publish();
    FramePair p;
    if (pairer.poll(p)) {
      CHECK_EQUAL(p.a->stamp_us, p.b->stamp_us);  // triggered together
      CHECK_EQUAL(p.a->sequence, p.b->sequence);
      ++pairs;
      pairer.release(p);
    }
  }
  CHECK_EQUAL(20, pairs);
}

// The rig's cameras start on their own threads, some milliseconds apart: on one shared time base
// their stamps still keep the recorded offsets (the same frame, the same stamp), a camera starting
// late (or reopened) begins with the frame due now, and once all have stopped the next start begins
// the recording afresh.
TEST(HalReplay, RigSensorsStartedApartShareOneTimeBase) {
  const std::string dir = edgefuse_test::require_data("bin_rig_a");
  if (dir.empty()) return;
  io::DepthSequence xs, ts;
  std::string err;
  CHECK_TEXT(io::open_depth_sequence(dir, "xtion", xs, err), err.c_str());
  CHECK_TEXT(io::open_depth_sequence(dir, "tof", ts, err), err.c_str());
  ManualClock clock;
  ReplayEpoch epoch;
  ReplayDepthCamera xc(xs, ReplayRate::kRecorded, clock, true), tc(ts, ReplayRate::kRecorded, clock, true);
  xc.share_epoch(epoch);
  tc.share_epoch(epoch);
  static DepthFrameStorage<320 * 240> xstore, tstore;
  DepthFrame xf = xstore.frame(), tf = tstore.frame();
  const uint64_t t0 = clock.now_us();
  CHECK(xc.start(0) == HalStatus::kOk);
  CHECK(xc.next_frame(xf, 100) == HalStatus::kOk);
  CHECK_EQUAL(t0, xf.stamp_us);
  clock.sleep_us(41000);  // the tof's thread starts 41 ms later: frame 0 is the one due now
  CHECK(tc.start(0) == HalStatus::kOk);
  CHECK(tc.next_frame(tf, 300) == HalStatus::kOk);
  CHECK_EQUAL(0u, tf.sequence);
  CHECK_EQUAL(t0, tf.stamp_us);
  clock.sleep_us(400000);  // 441 ms: frame 2 (400 ms) is due, frame 1 is lost as on a live camera
  tc.stop();
  CHECK(tc.start(0) == HalStatus::kOk);
  CHECK(tc.next_frame(tf, 300) == HalStatus::kOk);
  CHECK_EQUAL(2u, tf.sequence);
  CHECK_EQUAL(t0 + 400000u, tf.stamp_us);
  CHECK(xc.next_frame(xf, 300) == HalStatus::kOk);
  CHECK(xc.next_frame(xf, 300) == HalStatus::kOk);
  CHECK_EQUAL(xf.sequence, tf.sequence);  // the same frame, the same stamp
  CHECK_EQUAL(xf.stamp_us, tf.stamp_us);
  xc.stop();
  tc.stop();
  clock.sleep_us(5000000);
  const uint64_t t1 = clock.now_us();
  CHECK(tc.start(0) == HalStatus::kOk);
  CHECK(tc.next_frame(tf, 100) == HalStatus::kOk);
  CHECK_EQUAL(0u, tf.sequence);
  CHECK_EQUAL(t1, tf.stamp_us);
}

TEST(HalReplay, LineScannerAxisPositionsFromTheRecordedPoses) {
  const std::string dir = edgefuse_test::require_data("bin_rig_a");
  if (dir.empty()) return;
  io::RigToml rig;
  io::LineScan scan;
  std::string err;
  CHECK_TEXT(io::read_rig_toml(dir + "/rig.toml", rig, err), err.c_str());
  CHECK_TEXT(io::open_line_scan(rig, "laser", scan, err), err.c_str());
  ReplayLineScanner ls(scan, ReplayRate::kFastest, monotonic_clock());
  CHECK_EQUAL(640, ls.info().beams);
  CHECK(ls.start() == HalStatus::kOk);
  static float ranges[640];
  LineProfile p;
  p.ranges_m = ranges;
  p.capacity_beams = 640;
  for (int k = 0; k < 300; ++k) {
    CHECK(ls.next_profile(p, 0) == HalStatus::kOk);
    CHECK(p.has_position);
    DOUBLES_EQUAL(0.001 * k, p.axis_position_m, 1e-5);  // 1 mm steps along +y
  }
  CHECK(ls.next_profile(p, 0) == HalStatus::kEndOfStream);
}
