// The acquisition runtime: SPSC ring across threads, newest-frame policy with drop counters,
// pairing by nearest stamp, sanity checks, and a device thread that survives injected faults
// (stall, drop, garbage, unplug/replug) while processing keeps running; zero heap allocations
// per frame in steady state.
#include <atomic>
#include <chrono>
#include <cstdio>
#include <thread>

#include "alloc_counter.hpp"
#include "edgefuse/hal/acquisition/camera_worker.hpp"
#include "edgefuse/memory/arena.hpp"
#include "edgefuse/hal/acquisition/frame_pairer.hpp"
#include "edgefuse/hal/acquisition/frame_pool.hpp"
#include "edgefuse/hal/acquisition/hotplug_watcher.hpp"
#include "edgefuse/hal/acquisition/scanner_worker.hpp"
#include "edgefuse/hal/platform/clock/monotonic_clock.hpp"
#include "edgefuse/hal/sim/fault_camera.hpp"
#include "edgefuse/hal/sim/sim_depth_camera.hpp"
#include "edgefuse/hal/sim/sim_line_scanner.hpp"
#include "edgefuse/hal/sim/sim_position.hpp"
#include "edgefuse/hal/sim/sim_trigger.hpp"
#include "test_support.hpp"

using namespace edgefuse;
using namespace edgefuse::hal;

namespace {

FrameChannelStorage<320 * 240, 6> g_store_a;
FrameChannelStorage<320 * 240, 6> g_store_b;

// Processing stand-in: takes frames until `pred` holds or timeout_ms passes; counts frames.
template <class Pred>
bool consume_until(FrameChannel& ch, Pred pred, int timeout_ms, int* taken = nullptr) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  while (std::chrono::steady_clock::now() < end) {
    if (const DepthFrame* f = ch.acquire_newest()) {
      if (taken) ++*taken;
      ch.release(f);
    }
    if (pred()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return pred();
}

CameraWorkerConfig fast_config() {
  CameraWorkerConfig c;
  c.frame_timeout_ms = 50;
  c.stall_ms = 200;
  c.backoff_min_ms = 20;
  c.backoff_max_ms = 200;
  c.replug_poll_ms = 20;
  return c;
}

void print_counters(const char* what, const AcquisitionCounters& c) {
  char line[512];
  format_counters(c, line, sizeof(line));
  std::printf("\n  %s: %s", what, line);
}

}  // namespace

TEST_GROUP(HalAcquisition) {
  SimScene scene;
  void setup() override { default_bin_scene(scene); }
};

TEST(HalAcquisition, SpscRingPassesEveryValueInOrderAcrossThreads) {
  static SpscRing<uint32_t, 8> ring;
  const uint32_t n = 20000;
  // Yield when full or empty: on a loaded 2-core machine two spinning threads starve each other.
  std::thread producer([] {
    for (uint32_t i = 0; i < n;) {
      if (ring.push(i))
        ++i;
      else
        std::this_thread::yield();
    }
  });
  uint32_t expect = 0;
  bool ordered = true;
  while (expect < n) {
    uint32_t v;
    if (ring.pop(v))
      ordered = ordered && v == expect++;
    else
      std::this_thread::yield();
  }
  producer.join();
  CHECK(ordered);
  CHECK(ring.empty());
}

TEST(HalAcquisition, NewestFramePolicyCountsStaleAndOverrunDrops) {
  AcquisitionCounters cnt;
  FrameChannel ch;
  CHECK(g_store_a.bind(ch, cnt));
  for (uint32_t i = 0; i < 3; ++i) {
    ch.producer_frame().sequence = i;
    ch.publish();
  }
  const DepthFrame* f = ch.acquire_newest();
  CHECK(f != nullptr);
  CHECK_EQUAL(2u, f->sequence);
  CHECK_EQUAL(2u, cnt.dropped_stale.load());
  CHECK(ch.acquire_newest() == nullptr);
  // Processing holds f and never comes back: 5 more slots fill up, then the device overwrites.
  for (uint32_t i = 3; i < 12; ++i) {
    ch.producer_frame().sequence = i;
    ch.publish();
  }
  CHECK_EQUAL(5u, cnt.dropped_overrun.load());
  ch.release(f);
  const DepthFrame* g = ch.acquire_newest();
  CHECK_EQUAL(6u, g->sequence);  // the newest that made it into the ring (7..11 overwritten)
  ch.release(g);
  ch.producer_frame().sequence = 12;
  ch.publish();
  g = ch.acquire_newest();
  CHECK_EQUAL(12u, g->sequence);
  ch.release(g);
}

TEST(HalAcquisition, PairsByNearestStampWithinTheWindow) {
  AcquisitionCounters ca, cb;
  FrameChannel a, b;
  CHECK(g_store_a.bind(a, ca));
  CHECK(g_store_b.bind(b, cb));
  FramePairer pairer(a, b, 5000);
  auto push = [](FrameChannel& ch, uint64_t t) {
    ch.producer_frame().stamp_us = t;
    ch.publish();
  };
  FramePair p;
  // B ready at 1000, 4000 and 9000 us; A at 9500: nearest is 9000.
  push(b, 1000);
  push(b, 4000);
  push(b, 9000);
  push(a, 9500);
  CHECK(pairer.poll(p));
  CHECK_EQUAL(9500u, p.a->stamp_us);
  CHECK_EQUAL(9000u, p.b->stamp_us);
  pairer.release(p);
  // A at 20000, B at 30000: too far apart; A is older, so A is dropped, B waits.
  push(a, 20000);
  push(b, 30000);
  CHECK_FALSE(pairer.poll(p));
  CHECK_EQUAL(1u, pairer.unpaired_a());
  push(a, 31000);
  CHECK(pairer.poll(p));
  CHECK_EQUAL(31000u, p.a->stamp_us);
  CHECK_EQUAL(30000u, p.b->stamp_us);
  pairer.release(p);
  CHECK_EQUAL(2u, pairer.pairs());
}

TEST(HalAcquisition, SanityChecksRejectBadFramesWithTheirReason) {
  DepthMode mode;
  mode.width = 4;
  mode.height = 2;
  FrameChecks checks;
  checks.reset(mode);
  static DepthFrameStorage<8> st;
  DepthFrame f = st.frame();
  f.width = 4;
  f.height = 2;
  for (int i = 0; i < 8; ++i) st.depth[i] = uint16_t(i);
  f.stamp_us = 100;
  f.sequence = 0;
  uint32_t gap;
  CHECK(checks.check(f, gap) == FrameReject::kNone);
  f.stamp_us = 100;  // not later
  f.sequence = 1;
  CHECK(checks.check(f, gap) == FrameReject::kStamp);
  f.stamp_us = 200;
  f.width = 3;
  CHECK(checks.check(f, gap) == FrameReject::kSize);
  f.width = 4;
  for (int i = 0; i < 8; ++i) st.depth[i] = 0;
  CHECK(checks.check(f, gap) == FrameReject::kAllInvalid);
  st.depth[5] = 7;
  f.sequence = 4;
  CHECK(checks.check(f, gap) == FrameReject::kNone);
  CHECK_EQUAL(2u, gap);  // 2 and 3 never arrived (1 arrived and was rejected)
}

TEST(HalAcquisition, DeviceThreadRecoversFromStallDropGarbageAndUnplug) {
  MonotonicClock& clock = monotonic_clock();
  SimDepthCameraConfig cfg = sim_tof_config();
  cfg.fps = 50;
  SimDepthCamera sim(cfg, scene, clock);
  SimDeviceMonitor monitor(clock);
  FaultCamera cam(sim, clock, &monitor);
  AcquisitionCounters cnt;
  FrameChannel ch;
  CHECK(g_store_a.bind(ch, cnt));
  CameraWorker worker(cam, ch, cnt, clock, &monitor);
  HotplugWatcher watcher(monitor);
  watcher.add(worker);
  CHECK(watcher.start());
  CHECK(worker.start(fast_config()));
  int taken = 0;
  CHECK(consume_until(ch, [&] { return cnt.published >= 5; }, 20000, &taken));
  CHECK(worker.state() == DeviceState::kStreaming);

  // Stall: 600 ms without frames -> timeouts, a stall, reopen(s) with back-off, frames again.
  cam.inject_stall(600);
  CHECK(consume_until(ch, [&] { return cnt.stalls >= 1; }, 20000));
  const uint32_t opens = cnt.opens;
  const uint32_t after_stall = cnt.published;
  CHECK(consume_until(ch, [&] { return cnt.published >= after_stall + 5; }, 20000, &taken));
  CHECK(cnt.timeouts >= 2);
  CHECK(cnt.opens >= opens);
  CHECK(worker.state() == DeviceState::kStreaming);

  // Drop: three frames lost inside the device -> a counted sequence gap, stream goes on.
  const uint32_t gaps = cnt.device_gaps;
  cam.inject_drop(3);
  CHECK(consume_until(ch, [&] { return cnt.device_gaps >= gaps + 3; }, 20000, &taken));

  // Garbage of every kind: rejected with its reason, never published.
  const GarbageKind kinds[] = {GarbageKind::kWrongSize, GarbageKind::kAllInvalid, GarbageKind::kStampBack};
  const FrameReject reasons[] = {FrameReject::kSize, FrameReject::kAllInvalid, FrameReject::kStamp};
  for (int k = 0; k < 3; ++k) {
    cam.inject_garbage(kinds[k]);
    CHECK(consume_until(ch, [&] { return cnt.rejected[size_t(reasons[k])] >= 1; }, 20000, &taken));
  }

  // Unplug: kNoDevice -> state unplugged (no reopen storm), replug -> reconnect, frames again.
  cam.set_plugged(false);
  CHECK(consume_until(ch, [&] { return worker.state() == DeviceState::kUnplugged; }, 20000));
  CHECK_EQUAL(1u, cnt.disconnects.load());
  const uint32_t failures = cnt.open_failures;
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  CHECK(cnt.open_failures <= failures + 1);  // it waits for the monitor instead of retrying
  const uint32_t before_replug = cnt.published;
  cam.set_plugged(true);
  CHECK(consume_until(ch, [&] { return cnt.published >= before_replug + 5; }, 20000, &taken));
  CHECK_EQUAL(1u, cnt.reconnects.load());
  CHECK(watcher.arrivals() >= 1 && watcher.departures() >= 1);
  CHECK(worker.state() == DeviceState::kStreaming);
  print_counters("after faults", cnt);
  worker.stop();
  watcher.stop();
  CHECK(worker.state() == DeviceState::kStopped);
  CHECK(taken >= 10);
}

TEST(HalAcquisition, TwoSimulatedCamerasPairInTheWindow) {
  MonotonicClock& clock = monotonic_clock();
  // Two ToF-like cameras on the rig (the xtion's render takes about 1 s per frame under qemu,
  // which delivers its frames later than the other stream's ring reaches back).
  SimDepthCameraConfig xc = sim_tof_config(), tc = sim_tof_config();
  xc.name = "tof_a";
  xc.seed = 11;
  xc.fps = tc.fps = 5;
  SimDepthCamera x(xc, scene, clock), t(tc, scene, clock);
  AcquisitionCounters cx, ct;
  FrameChannel chx, cht;
  CHECK(g_store_a.bind(chx, cx));
  CHECK(g_store_b.bind(cht, ct));
  CameraWorker wx(x, chx, cx, clock), wt(t, cht, ct, clock);
  CHECK(wx.start(fast_config()));
  CHECK(wt.start(fast_config()));
  // Window = half the frame period: whatever the phase between the two free-running cameras,
  // each frame has a partner within it.
  FramePairer pairer(chx, cht, 100000);
  int pairs = 0;
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (pairs < 5 && std::chrono::steady_clock::now() < end) {
    FramePair p;
    if (pairer.poll(p)) {
      // The cameras run unsynchronised (each starts its clock when its thread opens it).
      const int64_t dt = int64_t(p.b->stamp_us) - int64_t(p.a->stamp_us);
      CHECK(dt >= -100000 && dt <= 100000);
      CHECK_EQUAL(160, p.a->width);
      CHECK_EQUAL(160, p.b->width);
      ++pairs;
      pairer.release(p);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  wx.stop();
  wt.stop();
  pairer.reset();
  print_counters("tof_a", cx);
  print_counters("tof", ct);
  std::printf("\n  pairs %u unpaired %u + %u", pairer.pairs(), pairer.unpaired_a(), pairer.unpaired_b());
  CHECK_EQUAL(5, pairs);
}

TEST(HalAcquisition, NoHeapAllocationPerFrame) {
  MonotonicClock& clock = monotonic_clock();
  SimDepthCameraConfig cfg = sim_tof_config();
  cfg.paced = false;  // as fast as possible: many frames in little time
  SimDepthCamera sim(cfg, scene, clock);
  SimDeviceMonitor monitor(clock);
  FaultCamera cam(sim, clock, &monitor);
  AcquisitionCounters cnt;
  FrameChannel ch;
  CHECK(g_store_a.bind(ch, cnt));
  CameraWorker worker(cam, ch, cnt, clock, &monitor);
  CHECK(worker.start(fast_config()));
  CHECK(consume_until(ch, [&] { return cnt.published >= 10; }, 30000));
  edgefuse_test::alloc_count_start();
  const uint32_t start = cnt.frames;
  cam.inject_garbage(GarbageKind::kAllInvalid);  // the reject path too
  cam.inject_drop(2);
  int taken = 0;
  CHECK(consume_until(ch, [&] { return cnt.frames >= start + 100; }, 60000, &taken));
  const long allocations = edgefuse_test::alloc_count();
  worker.stop();
  std::printf("\n  %u frames, %d taken, %ld allocations", unsigned(cnt.frames - start), taken, allocations);
  CHECK_EQUAL(0L, allocations);
}

TEST(HalAcquisition, LineScannerThreadDeliversOneProfilePerEdgeAndToleratesPauses) {
  static ProfileChannelStorage<640, 8> store;
  MonotonicClock& clock = monotonic_clock();
  SimTriggerLine line;
  SimTriggerOutput out(line, clock);
  SimTriggerInput in(line, clock);
  SimLinearAxis axis(clock.now_us(), 0.0, 0.05);
  SimLineScanner scanner(sim_laser_config(), scene, in, axis);
  AcquisitionCounters cnt;
  ProfileChannel ch;
  CHECK(store.bind(ch, cnt));
  ScannerWorker worker(scanner, ch, cnt);
  ScannerWorkerConfig wc;
  wc.profile_timeout_ms = 50;
  CHECK(worker.start(wc));
  out.start();
  int profiles = 0;
  uint64_t last_stamp = 0;
  double last_pos = -1;
  bool ordered = true;
  auto drain = [&] {
    ch.drain([&](const LineProfile& p) {
      ordered = ordered && p.stamp_us > last_stamp && p.axis_position_m > last_pos && p.beams == 640;
      last_stamp = p.stamp_us;
      last_pos = p.axis_position_m;
      ++profiles;
    });
  };
  for (int k = 0; k < 20; ++k) {  // 20 edges, 5 ms apart
    out.pulse(20);
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    drain();
  }
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(2);
  while (profiles < 20 && std::chrono::steady_clock::now() < end) {
    drain();
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  CHECK_EQUAL(20, profiles);
  // A pause in triggering: timeouts, no reopen, still streaming.
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  CHECK(cnt.timeouts >= 2);
  CHECK(worker.state() == DeviceState::kStreaming);
  CHECK_EQUAL(1u, cnt.opens.load());
  for (int k = 0; k < 5; ++k) {
    out.pulse(20);
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  const auto end2 = std::chrono::steady_clock::now() + std::chrono::seconds(2);
  while (profiles < 25 && std::chrono::steady_clock::now() < end2) {
    drain();
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  worker.stop();
  CHECK_EQUAL(25, profiles);
  CHECK(ordered);
  CHECK_EQUAL(0u, cnt.dropped_overrun.load());
}

TEST(HalAcquisition, FramePoolsLiveInTheBoardMemoryMap) {
  // The device thread fills frames that lie in the memory map's acquisition pool regions.
  CoreBuffers buf;
  CHECK(carve_memory(build_board(), static_arena(), static_arena_bytes(), buf) == Status::kOk);
  CHECK_EQUAL(build_board().sensors_max, buf.frame_pools.pools);
  static FramePoolViews views[2];
  FrameChannel ch;
  AcquisitionCounters cnt;
  CHECK_FALSE(bind_frame_pool(buf.frame_pools, buf.frame_pools.pools, views[1], ch, cnt));  // no such pool
  CHECK(bind_frame_pool(buf.frame_pools, buf.frame_pools.pools - 1, views[0], ch, cnt));
  MonotonicClock& clock = monotonic_clock();
  SimDepthCameraConfig cfg = sim_tof_config();
  cfg.fps = 50;
  SimDepthCamera sim(cfg, scene, clock);
  CameraWorker worker(sim, ch, cnt, clock);
  CHECK(worker.start(fast_config()));
  const uintptr_t lo = reinterpret_cast<uintptr_t>(buf.frame_pools.depth);
  const uintptr_t hi = lo + make_memory_map(build_board()).regions[int(Region::kAcqDepth)].bytes;
  int checked = 0;
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (checked < 5 && std::chrono::steady_clock::now() < end) {
    if (const DepthFrame* f = ch.acquire_newest()) {
      const uintptr_t a = reinterpret_cast<uintptr_t>(f->depth);
      CHECK(a >= lo && a + f->pixel_count() * sizeof(uint16_t) <= hi);
      std::size_t valid = 0;
      for (std::size_t k = 0; k < f->pixel_count(); ++k) valid += f->depth[k] != 0;
      CHECK(valid > 0);  // a real image came through the pool (all-invalid frames are rejected)
      ++checked;
      ch.release(f);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  worker.stop();
  CHECK_EQUAL(5, checked);
}

// The line scanner's profile pool is a memory-map region too.
TEST(HalAcquisition, ProfilePoolLivesInTheBoardMemoryMap) {
  CoreBuffers buf;
  CHECK(carve_memory(build_board(), static_arena(), static_arena_bytes(), buf) == Status::kOk);
  CHECK_EQUAL(build_board().image_width_max, buf.profile_pool.beams_max);
  CHECK_EQUAL(kProfilePoolSlots, buf.profile_pool.slots);
  static ProfilePoolViews views;
  ProfileChannel ch;
  AcquisitionCounters cnt;
  CHECK_FALSE(bind_profile_pool(buf.profile_pool, buf.profile_pool.beams_max + 1, views, ch, cnt));  // too wide
  CHECK_FALSE(bind_profile_pool(ProfilePoolBuffers(), 640, views, ch, cnt));                          // no region
  CHECK(bind_profile_pool(buf.profile_pool, buf.profile_pool.beams_max, views, ch, cnt));
  if (buf.profile_pool.beams_max < 640) {  // a small board (am335x: 320 px): the sim laser's 640 beams do not fit
    CHECK_FALSE(bind_profile_pool(buf.profile_pool, 640, views, ch, cnt));
    return;
  }
  CHECK(bind_profile_pool(buf.profile_pool, 640, views, ch, cnt));
  MonotonicClock& clock = monotonic_clock();
  SimTriggerLine line;
  SimTriggerOutput out(line, clock);
  SimTriggerInput in(line, clock);
  SimLinearAxis axis(clock.now_us(), 0.0, 0.05);
  SimLineScanner scanner(sim_laser_config(), scene, in, axis);
  ScannerWorker worker(scanner, ch, cnt);
  ScannerWorkerConfig wc;
  wc.profile_timeout_ms = 50;
  CHECK(worker.start(wc));
  out.start();
  const uintptr_t lo = reinterpret_cast<uintptr_t>(buf.profile_pool.ranges_m);
  const uintptr_t hi = lo + make_memory_map(build_board()).regions[int(Region::kAcqProfiles)].bytes;
  int profiles = 0;
  bool inside = true;
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (profiles < 10 && std::chrono::steady_clock::now() < end) {
    out.pulse(20);
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    ch.drain([&](const LineProfile& p) {
      const uintptr_t a = reinterpret_cast<uintptr_t>(p.ranges_m);
      inside = inside && a >= lo && a + std::size_t(p.beams) * sizeof(float) <= hi && p.beams == 640;
      ++profiles;
    });
  }
  worker.stop();
  CHECK(profiles >= 10);
  CHECK(inside);
}
