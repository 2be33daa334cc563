// The pipeline's side of a fault: a sim ToF camera streams through the acquisition runtime into a
// TSDF at the camera's true poses; the camera stalls and is unplugged. Integration pauses while
// the device is not streaming, the space keeps every voxel it had, and fusion resumes (more
// voxels, the same surface) when frames return.
#include <chrono>
#include <cstdio>
#include <thread>

#include "edgefuse/tsdf/integrate.hpp"
#include "edgefuse/hal/acquisition/camera_worker.hpp"
#include "edgefuse/hal/platform/clock/monotonic_clock.hpp"
#include "edgefuse/hal/sim/fault_camera.hpp"
#include "edgefuse/hal/sim/sim_depth_camera.hpp"
#include "scenes.hpp"
#include "test_support.hpp"

using namespace edgefuse;

namespace {
constexpr int kDim = 64;
edgefuse_test::VolumeStorage<kDim> g_volume;
edgefuse_test::SensorBuffers<float> g_sensor;
hal::FrameChannelStorage<160 * 120, 4> g_frames;
}  // namespace

TEST_GROUP(HalSpace){};

TEST(HalSpace, FaultsPauseFusionWithoutLosingTheSpace) {
  hal::MonotonicClock& clock = hal::monotonic_clock();
  hal::SimScene scene;
  hal::default_bin_scene(scene);
  hal::SimDepthCameraConfig cfg = hal::sim_tof_config();
  cfg.fps = 30;
  hal::SimDepthCamera sim(cfg, scene, clock);
  hal::SimDeviceMonitor monitor(clock);
  hal::FaultCamera cam(sim, clock, &monitor);
  hal::AcquisitionCounters cnt;
  hal::FrameChannel channel;
  CHECK(g_frames.bind(channel, cnt));
  hal::CameraWorker worker(cam, channel, cnt, clock, &monitor);
  hal::CameraWorkerConfig wc;
  wc.frame_timeout_ms = 50;
  wc.stall_ms = 200;
  wc.backoff_min_ms = 20;
  wc.backoff_max_ms = 100;
  wc.replug_poll_ms = 20;

  // 8 mm voxels over the bin (0.512 m cube from just below the floor).
  TsdfVolume vol;
  CHECK(vol.init(g_volume.view(false), kDim, Vec3f(-0.256f, -0.256f, -0.05f), TsdfParams::defaults_for(0.008f, 0.032f)) ==
        Status::kOk);
  CHECK(worker.start(wc));
  PinholeIntrinsics intr;
  bool have_intr = false;
  FrameScratch scratch = g_sensor.scratch();
  ImageView<const float> norms;
  int integrated = 0;
  // Processing loop: integrate the newest frame when the device streams; pause otherwise.
  // Processing loop until `done()` or max_ms: integrate the newest frame when one is there;
  // count polls that find the device not streaming (fusion paused).
  int paused = 0;
  auto run_until = [&](auto done, int max_ms) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(max_ms);
    while (!done() && std::chrono::steady_clock::now() < end) {
      const hal::DepthFrame* f = channel.acquire_newest();
      if (f == nullptr) {
        if (worker.state() != hal::DeviceState::kStreaming) ++paused;
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
        continue;
      }
      if (!have_intr) {
        intr = cam.intrinsics();
        norms = g_sensor.ray_norms(intr);
        have_intr = true;
      }
      const DepthFrame df{f->depth_view(), ImageView<const Rgb8>()};
      CHECK(integrate<float>(vol, intr, norms, df, sim.pose_of(f->sequence), scratch) == Status::kOk);
      ++integrated;
      channel.release(f);
    }
    return done();
  };
  // Timeouts are generous: under qemu (ARM test runs) a frame takes tens of milliseconds.
  CHECK(run_until([&] { return integrated >= 5; }, 30000));
  const std::size_t before = vol.observed_voxels();
  CHECK(before > 1000);

  // The camera stalls: wait until the runtime notices (stall -> back-off), then let processing
  // take whatever was still queued.
  cam.inject_stall(3000);
  CHECK(run_until([&] { return cnt.stalls >= 1; }, 30000));
  run_until([] { return false; }, 100);
  const std::size_t stalled = vol.observed_voxels();
  CHECK(stalled >= before);
  // Then it vanishes: nothing arrives, fusion is paused, the space keeps every voxel.
  cam.set_plugged(false);
  paused = 0;
  run_until([] { return false; }, 300);
  CHECK(paused > 0);
  CHECK_EQUAL(stalled, vol.observed_voxels());
  // Replugged: once the stall is over, frames return and fusion resumes.
  cam.set_plugged(true);
  const int frames_at_replug = integrated;
  CHECK(run_until([&] { return integrated >= frames_at_replug + 5; }, 30000));
  worker.stop();
  const std::size_t after = vol.observed_voxels();
  std::printf("\n  voxels before %zu, during fault %zu, after %zu; frames %d + %d", before, stalled, after,
              frames_at_replug, integrated - frames_at_replug);
  CHECK(after >= stalled);
  CHECK_EQUAL(1u, cnt.reconnects.load());
}
