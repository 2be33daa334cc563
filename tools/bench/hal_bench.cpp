// edgefuse_hal_bench [DATA_DIR]: figures of the HAL (thread CPU time, CLOCK_THREAD_CPUTIME_ID):
//   - sim rendering per frame (xtion 320x240 structured light, tof 160x120, a 640-beam profile);
//   - frame hand-off through a FrameChannel (publish + acquire_newest + release), one thread, and
//     the same across two threads (producer CPU per frame);
//   - the sanity checks on a 640x480 frame (worst case: the only valid pixel is the last);
//   - replay of TUM fr1/xyz at full speed (PNG decode + copy per frame), if the data is present.
#include <time.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstring>
#include <string>
#include <thread>

#include "edgefuse/io/dataset.hpp"
#include "edgefuse/hal/acquisition/frame_channel.hpp"
#include "edgefuse/hal/acquisition/frame_checks.hpp"
#include "edgefuse/hal/null/null_backends.hpp"
#include "edgefuse/hal/platform/clock/monotonic_clock.hpp"
#include "edgefuse/hal/replay/replay_depth_camera.hpp"
#include "edgefuse/hal/sim/sim_depth_camera.hpp"
#include "edgefuse/hal/sim/sim_line_scanner.hpp"
#include "edgefuse/hal/sim/sim_position.hpp"
#include "edgefuse/hal/sim/sim_trigger.hpp"

using namespace edgefuse;
using namespace edgefuse::hal;

namespace {

double thread_cpu_s() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

DepthFrameStorage<640 * 480> g_frame;
FrameChannelStorage<640 * 480, 4> g_channel;

void bench_sim(const char* what, SimDepthCameraConfig cfg, const SimScene& scene, int frames) {
  ManualClock clock;
  cfg.paced = false;
  SimDepthCamera cam(cfg, scene, clock);
  cam.start(0);
  DepthFrame f = g_frame.frame();
  cam.next_frame(f, 100);  // warm-up
  const double t0 = thread_cpu_s();
  for (int i = 0; i < frames; ++i) cam.next_frame(f, 100);
  const double ms = 1e3 * (thread_cpu_s() - t0) / frames;
  std::printf("sim %-28s %8.2f ms/frame CPU (%d frames) = %.0f fps on one core\n", what, ms, frames, 1e3 / ms);
}

void bench_laser(const SimScene& scene) {
  ManualClock clock;
  SimTriggerInput trig(1000, clock);
  SimLinearAxis axis(clock.now_us(), 0.0, 0.1);
  SimLineScanner ls(sim_laser_config(), scene, trig, axis);
  ls.start();
  static float ranges[640];
  LineProfile p;
  p.ranges_m = ranges;
  p.capacity_beams = 640;
  const int n = 2000;
  const double t0 = thread_cpu_s();
  for (int i = 0; i < n; ++i) ls.next_profile(p, 10);
  std::printf("sim %-28s %8.3f ms/profile CPU (%d profiles)\n", "laser 640 beams", 1e3 * (thread_cpu_s() - t0) / n, n);
}

void bench_channel_one_thread() {
  AcquisitionCounters cnt;
  FrameChannel ch;
  g_channel.bind(ch, cnt);
  const int n = 2000000;
  const double t0 = thread_cpu_s();
  for (int i = 0; i < n; ++i) {
    ch.producer_frame().stamp_us = uint64_t(i);
    ch.publish();
    ch.release(ch.acquire_newest());
  }
  std::printf("channel hand-off, one thread          %8.1f ns/frame (publish + acquire + release)\n",
              1e9 * (thread_cpu_s() - t0) / n);
}

// Cross-thread latency: the producer stamps each frame with the clock at publish(), one every
// 200 us; the consumer (spinning with yield) takes the newest and notes how old it is.
void bench_channel_across_threads() {
  AcquisitionCounters cnt;
  FrameChannel ch;
  g_channel.bind(ch, cnt);
  const int n = 10000;
  static uint32_t latency_us[10000];
  std::atomic<bool> done{false};
  std::thread producer([&] {
    MonotonicClock& clock = monotonic_clock();
    for (int i = 1; i <= n; ++i) {
      ch.producer_frame().stamp_us = clock.now_us();
      ch.publish();
      clock.sleep_us(200);
    }
    done = true;
  });
  int taken = 0;
  while (!done.load() && taken < n) {
    if (const DepthFrame* f = ch.acquire_newest()) {
      latency_us[taken++] = uint32_t(monotonic_clock().now_us() - f->stamp_us);
      ch.release(f);
    } else {
      std::this_thread::yield();
    }
  }
  producer.join();
  std::sort(latency_us, latency_us + taken);
  std::printf("channel hand-off across threads       median %u us, 99th %u us (%d of %d taken, "
              "dropped_stale %u, dropped_overrun %u)\n",
              taken ? latency_us[taken / 2] : 0, taken ? latency_us[taken * 99 / 100] : 0, taken, n,
              unsigned(cnt.dropped_stale), unsigned(cnt.dropped_overrun));
}

void bench_frame_checks() {
  DepthMode m;
  m.width = 640;
  m.height = 480;
  FrameChecks checks;
  checks.reset(m);
  DepthFrame f = g_frame.frame();
  f.width = 640;
  f.height = 480;
  std::memset(f.depth, 0, 640 * 480 * 2);
  f.depth[640 * 480 - 1] = 1;
  const int n = 2000;
  const double t0 = thread_cpu_s();
  uint32_t gap;
  for (int i = 0; i < n; ++i) {
    f.stamp_us = uint64_t(i + 1);
    f.sequence = uint32_t(i);
    checks.check(f, gap);
  }
  std::printf("sanity checks 640x480 (worst case)    %8.1f us/frame\n", 1e6 * (thread_cpu_s() - t0) / n);
}

void bench_replay_tum(const std::string& data) {
  io::DepthSequence seq;
  std::string err;
  if (!io::open_depth_sequence(data + "/tum_fr1_xyz_37", "", seq, err)) {
    std::printf("replay TUM: skipped (%s)\n", err.c_str());
    return;
  }
  ReplayDepthCamera cam(seq, ReplayRate::kFastest, monotonic_clock());
  cam.start(0);
  DepthFrame f = g_frame.frame();
  int n = 0;
  const double w0 = 1e-6 * double(monotonic_clock().now_us());
  const double t0 = thread_cpu_s();
  while (cam.next_frame(f, 0) == HalStatus::kOk) ++n;
  const double cpu = thread_cpu_s() - t0, wall = 1e-6 * double(monotonic_clock().now_us()) - w0;
  std::printf("replay TUM fr1/xyz 640x480 depth+rgb  %8.2f ms/frame CPU, %.2f ms/frame wall (%d frames, full speed)\n",
              1e3 * cpu / n, 1e3 * wall / n, n);
}

}  // namespace

int main(int argc, char** argv) {
  const std::string data = argc > 1 ? argv[1] : "../shared/data";
  SimScene scene;
  default_bin_scene(scene);
  bench_sim("xtion 320x240 (SL)", sim_xtion_config(), scene, 60);
  bench_sim("tof 160x120 (ToF)", sim_tof_config(), scene, 200);
  bench_laser(scene);
  bench_channel_one_thread();
  bench_channel_across_threads();
  bench_frame_checks();
  bench_replay_tum(data);
  return 0;
}
