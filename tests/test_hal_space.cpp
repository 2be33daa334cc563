// The pipeline's side of a fault: a sim ToF camera streams through the acquisition runtime into a
// TSDF at the camera's true poses; the camera stalls and is unplugged. Integration pauses while
// the device is not streaming, the space keeps every voxel it had, and fusion resumes (more
// voxels, the same surface) when frames return.
#include <chrono>
#include <cstdio>
#include <thread>

#include "edgefuse/tsdf/integrate.hpp"
#include "hal/acquisition/camera_worker.hpp"
#include "hal/posix/monotonic_clock.hpp"
#include "hal/sim/fault_camera.hpp"
#include "hal/sim/sim_depth_camera.hpp"
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
  auto run_for = [&](int ms, int* paused_polls) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(ms);
    while (std::chrono::steady_clock::now() < end) {
      const hal::DepthFrame* f = channel.acquire_newest();
      if (f == nullptr) {
        if (paused_polls && worker.state() != hal::DeviceState::kStreaming) ++*paused_polls;
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
  };
  run_for(600, nullptr);
  const std::size_t before = vol.observed_voxels();
  const int frames_before = integrated;
  CHECK(frames_before >= 3);
  CHECK(before > 1000);

  cam.inject_stall(500);
  int paused = 0;
  run_for(150, nullptr);  // frames stop: the stall is being detected
  const std::size_t stalled = vol.observed_voxels();
  CHECK(stalled >= before);
  cam.set_plugged(false);  // and then the camera vanishes
  run_for(300, &paused);
  CHECK(paused > 0);
  CHECK_EQUAL(stalled, vol.observed_voxels());  // nothing integrated, nothing lost
  cam.set_plugged(true);
  const int frames_at_replug = integrated;
  run_for(1000, nullptr);
  worker.stop();
  const std::size_t after = vol.observed_voxels();
  std::printf("\n  voxels before %zu, during fault %zu, after %zu; frames %d + %d", before, stalled, after,
              frames_at_replug, integrated - frames_at_replug);
  CHECK(integrated - frames_at_replug >= 5);  // fusion resumed
  CHECK(after >= stalled);
  CHECK_EQUAL(1u, cnt.reconnects.load());
}
