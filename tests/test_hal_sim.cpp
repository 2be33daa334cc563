// The sim backend: structured light and ToF cameras over the bin scene (depth where the geometry
// says, noise of the documented size, colour, amplitude, flying pixels), the line scanner fired by
// simulated trigger edges and stamped with their time and the axis position, debounce.
#include <cmath>
#include <cstdint>
#include <vector>

#include "edgefuse/hal/null/null_backends.hpp"
#include "edgefuse/hal/sim/sim_depth_camera.hpp"
#include "edgefuse/hal/sim/sim_line_scanner.hpp"
#include "edgefuse/hal/sim/sim_position.hpp"
#include "edgefuse/hal/sim/sim_trigger.hpp"
#include "test_support.hpp"

using namespace edgefuse;
using namespace edgefuse::hal;

namespace {
DepthFrameStorage<640 * 480> g_storage;
}

TEST_GROUP(HalSim) {
  SimScene scene;
  ManualClock clock;
  void setup() override { default_bin_scene(scene); }
};

TEST(HalSim, StructuredLightSeesTheBinFloorAtItsDepthWithTheDocumentedNoise) {
  SimDepthCameraConfig cfg = sim_xtion_config();
  cfg.rig_radius_m = 0;  // straight above the bin centre, 0.70 m over the floor
  SimDepthCamera cam(cfg, scene, clock);
  CHECK(cam.start(0) == HalStatus::kOk);
  DepthFrame f = g_storage.frame();
  CHECK(cam.next_frame(f, 100) == HalStatus::kOk);
  CHECK_EQUAL(320, f.width);
  CHECK_EQUAL(240, f.height);
  CHECK(f.has_colour);
  CHECK_FALSE(f.has_amplitude);
  // A floor patch free of objects (world x ~ 0, y ~ +0.11: image v < cy since y' = -y).
  std::vector<float> z;
  for (int v = 60; v < 75; ++v)
    for (int u = 150; u < 170; ++u)
      if (f.depth[v * 320 + u]) z.push_back(f.depth[v * 320 + u] / 5000.0f);
  CHECK(z.size() > 250);
  double mean = 0, var = 0;
  for (float x : z) mean += x;
  mean /= double(z.size());
  for (float x : z) var += (x - mean) * (x - mean);
  const double sd = std::sqrt(var / double(z.size()));
  // Floor top at 0.70 m below the camera; sigma 1.4 mm plus 1.4 mm disparity steps.
  DOUBLES_EQUAL(0.70, mean, 0.002);
  CHECK(sd > 0.0008 && sd < 0.0030);
  // Outside the bin nothing returns (no table): at 0.7 m the 58 deg view spans 0.78 m > 0.42 m,
  // so the left and right borders miss everything.
  CHECK_EQUAL(0, f.depth[120 * 320 + 0]);
  CHECK_EQUAL(0, f.depth[120 * 320 + 319]);
  // Colour: the bin is grey (Lambertian factor at normal incidence = 1).
  const Rgb8 c = f.colour[67 * 320 + 160];
  CHECK(c.r > 110 && c.r == c.g && c.g == c.b);
}

TEST(HalSim, StampsFollowTheFrameRateAndSequenceCounts) {
  SimDepthCameraConfig cfg = sim_tof_config();
  cfg.fps = 25;
  SimDepthCamera cam(cfg, scene, clock);
  DepthFrame f = g_storage.frame();
  CHECK(cam.next_frame(f, 10) == HalStatus::kNotStarted);
  CHECK(cam.start(0) == HalStatus::kOk);
  const uint64_t t0 = clock.now_us();
  for (uint32_t i = 0; i < 5; ++i) {
    CHECK(cam.next_frame(f, 100) == HalStatus::kOk);
    CHECK_EQUAL(i, f.sequence);
    CHECK_EQUAL(t0 + i * 40000u, f.stamp_us);
  }
  // A timeout shorter than the frame period: kTimeout, then the frame comes.
  CHECK(cam.next_frame(f, 10) == HalStatus::kTimeout);
  CHECK(cam.next_frame(f, 100) == HalStatus::kOk);
  CHECK_EQUAL(5u, f.sequence);
}

TEST(HalSim, TofHasAmplitudeAndFlyingPixelsAtDepthJumps) {
  SimDepthCameraConfig cfg = sim_tof_config();
  SimDepthCamera cam(cfg, scene, clock);
  CHECK(cam.start(0) == HalStatus::kOk);
  DepthFrame f = g_storage.frame();
  CHECK(cam.next_frame(f, 100) == HalStatus::kOk);
  CHECK(f.has_amplitude);
  CHECK_FALSE(f.has_colour);
  int valid = 0, amp = 0;
  for (std::size_t i = 0; i < f.pixel_count(); ++i) {
    valid += f.depth[i] != 0;
    amp += f.amplitude[i] != 0;
  }
  CHECK(valid > 1000);
  CHECK(amp >= valid);
  // Flying pixels: in a noise-free render they would not exist; count pixels whose depth lies
  // more than 2 cm away from both horizontal neighbours while those differ by more than 3 cm.
  int flying = 0;
  for (int v = 0; v < f.height; ++v)
    for (int u = 1; u + 1 < f.width; ++u) {
      const float l = f.depth[v * f.width + u - 1] / 5000.0f, c = f.depth[v * f.width + u] / 5000.0f,
                  r = f.depth[v * f.width + u + 1] / 5000.0f;
      if (!l || !c || !r || std::fabs(l - r) < 0.03f) continue;
      if (std::fabs(c - l) > 0.02f && std::fabs(c - r) > 0.02f) ++flying;
    }
  CHECK(flying > 0);
}

TEST(HalSim, LineScannerProfilePerTriggerEdgeWithEdgeStampAndAxisPosition) {
  SimTriggerLine line;
  SimTriggerOutput out(line, clock);
  SimTriggerInput in(line, clock);
  SimLinearAxis axis(clock.now_us(), 0.0, 0.1);  // 0.1 m/s
  SimLineScanner scanner(sim_laser_config(), scene, in, axis);
  CHECK(scanner.start() == HalStatus::kOk);
  CHECK(out.start() == HalStatus::kOk);
  static float ranges[640];
  LineProfile p;
  p.ranges_m = ranges;
  p.capacity_beams = 640;
  CHECK(scanner.next_profile(p, 5) == HalStatus::kTimeout);  // no edge, no profile
  uint64_t stamps[3];
  for (int k = 0; k < 3; ++k) {
    clock.sleep_us(100000);
    stamps[k] = clock.now_us();
    CHECK(out.pulse(50) == HalStatus::kOk);  // rising edge now, falling 50 us later
  }
  for (int k = 0; k < 3; ++k) {
    CHECK(scanner.next_profile(p, 10) == HalStatus::kOk);
    CHECK_EQUAL(stamps[k], p.stamp_us);
    CHECK_EQUAL(uint32_t(k), p.sequence);
    CHECK(p.has_position);
    DOUBLES_EQUAL(0.1 * (stamps[k] - 1000000) * 1e-6, p.axis_position_m, 1e-9);
  }
  // The last profile at y = -0.1495 + 0.03 m crosses the floor at 0.22 m below the scanner,
  // except where objects stand: the median return is the floor.
  int floor = 0, valid = 0;
  for (int i = 0; i < 640; ++i) {
    if (ranges[i] == 0) continue;
    ++valid;
    const float z = ranges[i] * std::cos((-10.0f + i * 20.0f / 639.0f) * 3.14159265f / 180.0f);
    floor += std::fabs(z - 0.22f) < 0.0002f;
  }
  CHECK(valid > 500);
  CHECK(floor > valid / 2);
}

TEST(HalSim, TriggerDebounceIgnoresEdgesTooCloseToTheLastOne) {
  SimTriggerLine line;
  SimTriggerOutput out(line, clock);
  SimTriggerInput in(line, clock);
  CHECK(in.start(EdgeSelect::kRising, 1000) == HalStatus::kOk);
  out.start();
  out.pulse(10);
  clock.sleep_us(200);  // bounce: 210 us after the first edge
  out.pulse(10);
  clock.sleep_us(5000);
  out.pulse(10);
  TriggerEdge e;
  CHECK(in.wait_edge(e, 10) == HalStatus::kOk);
  CHECK_EQUAL(0u, e.sequence);
  CHECK(in.wait_edge(e, 10) == HalStatus::kOk);
  CHECK_EQUAL(1u, e.sequence);
  CHECK(in.wait_edge(e, 10) == HalStatus::kTimeout);
  CHECK_EQUAL(1u, in.debounced());
}

TEST(HalSim, FreeRunningTriggerAtItsPeriod) {
  SimTriggerInput in(10000, clock);
  CHECK(in.start(EdgeSelect::kRising, 0) == HalStatus::kOk);
  const uint64_t t0 = clock.now_us();
  TriggerEdge e;
  for (int k = 1; k <= 3; ++k) {
    CHECK(in.wait_edge(e, 50) == HalStatus::kOk);
    CHECK_EQUAL(t0 + uint64_t(k) * 10000u, e.stamp_us);
  }
  CHECK(in.wait_edge(e, 5) == HalStatus::kTimeout);
}

TEST(HalSim, FreeRunningTriggerKeepsOnlyTheLastEdgesForALateReader) {
  SimTriggerInput in(10000, clock);
  CHECK(in.start(EdgeSelect::kRising, 0) == HalStatus::kOk);
  const uint64_t t0 = clock.now_us();
  TriggerEdge e;
  CHECK(in.wait_edge(e, 50) == HalStatus::kOk);
  CHECK_EQUAL(0u, e.sequence);
  clock.sleep_us(1000000);  // the reader is 100 periods late: edges 2..101 have passed
  CHECK(in.wait_edge(e, 50) == HalStatus::kOk);
  const uint32_t queued = SimTriggerInput::kQueuedEdges;
  CHECK_EQUAL(t0 + uint64_t(101 - queued + 1) * 10000u, e.stamp_us);  // the oldest edge still queued
  CHECK_EQUAL(101u - queued, e.sequence);  // the jump shows the lost edges
  CHECK_EQUAL(101u - queued - 1u, in.lost());
}

TEST(HalSim, NullBackendsReportNoDevice) {
  NullDepthCamera cam;
  CHECK(cam.start(0) == HalStatus::kNoDevice);
  NullLineScanner ls;
  CHECK(ls.start() == HalStatus::kNoDevice);
  NullDeviceMonitor mon;
  CHECK(mon.present("xtion"));
}

TEST(HalSim, AxisGoesBackAndForthOverItsTravel) {
  SimLinearAxis axis(0, 0.0, 0.1, 0.3);
  double p = 0;
  axis.position_at(1000000, p);
  DOUBLES_EQUAL(0.1, p, 1e-9);
  axis.position_at(4000000, p);  // 0.4 m travelled: 0.1 m back from the end
  DOUBLES_EQUAL(0.2, p, 1e-9);
  axis.position_at(6500000, p);  // 0.65 m: past a full round trip
  DOUBLES_EQUAL(0.05, p, 1e-9);
}
