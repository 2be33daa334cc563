// edgefused's real pipeline (src/firmware/device_pipeline.cpp) on host-sim's sim backend: frames
// through the HAL, filters, known or tracked poses, integration and a model-free localisation, with
// no heap allocation once started (mapping, tracking and the localisation thread), and the states
// the runtime sees (empty map refused, tracking state, still detection off while the rig moves).
// Every build runs it on its own board (its memory map and [tsdf] defaults) with host-sim's
// devices: the target boards' hal.toml list real cameras, so the ARM builds (under qemu) run the
// same simulated rig through DevicePipelineConfig::hal_file.
#include <time.h>
#include <algorithm>
#include <cmath>

#include <filesystem>
#include <memory>
#include <string>

#include "alloc_counter.hpp"
#include "test_support.hpp"
#include "edgefuse/board_config.hpp"
#include "edgefuse/hal/platform/config/board_defaults.hpp"
#include "edgefuse/fusion/fusion_rules.hpp"
#include "device_pipeline.hpp"
#include "edgefuse/hal/sim/fault_camera.hpp"
#include "edgefuse/hal/sim/sim_depth_camera.hpp"

#include <CppUTest/TestHarness.h>

using namespace edgefuse;

namespace {

uint64_t now_us() {
  timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return uint64_t(t.tv_sec) * 1000000u + uint64_t(t.tv_nsec) / 1000u;
}

void sleep_ms(int ms) {
  timespec t{0, long(ms) * 1000000L};
  nanosleep(&t, nullptr);
}

// The build's board with host-sim's simulated rig (its xtion, tof and laser), voxel and truncation
// of the board's [tsdf] defaults as edgefused takes them (am335x: 4 mm, its 128^3 volume spans the
// bin only so; the others 2 mm).
firmware::DevicePipelineConfig sim_rig_config() {
  firmware::DevicePipelineConfig c;
  c.board = kBuildBoard.name;
  c.hal_file = std::string(EDGEFUSE_TEST_BOARD_DIR) + "/host-sim/hal.toml";
  hal::BoardDefaults d;
  std::string err;
  CHECK_TRUE_TEXT(hal::read_board_defaults(c.board, d, err), err.c_str());
  c.voxel_m = d.voxel_m;
  c.trunc_m = d.trunc_m;
  return c;
}

// Steps until `frames` more frames were processed (at most 60 s). frame_steps_us (optional, two):
// the times handed to the steps that processed the last two frames, older first.
bool step_frames(firmware::DevicePipeline& p, uint32_t frames, uint64_t* frame_steps_us = nullptr) {
  const uint32_t target = p.stats().frames + frames;
  const uint64_t end = now_us() + 60000000u;
  while (p.stats().frames < target && now_us() < end) {
    const uint32_t before = p.stats().frames;
    const uint64_t t = now_us();
    p.step(t);
    if (frame_steps_us != nullptr && p.stats().frames != before) {
      frame_steps_us[0] = frame_steps_us[1];
      frame_steps_us[1] = t;
    }
    sleep_ms(2);
  }
  return p.stats().frames >= target;
}

bool localize(firmware::DevicePipeline& p, runtime::LocalizationOutcome& r) {
  const char* why = "";
  if (!p.start_localization(now_us(), &why)) return false;
  const uint64_t end = now_us() + 120000000u;
  while (now_us() < end) {
    p.step(now_us());
    if (p.poll_localization(r)) return true;
    sleep_ms(5);
  }
  return false;
}

// Tracked: from the sim robot's flange pose (simulator truth allowed), as edgefused on host-sim.
void run_pipeline(bool tracked) {
  firmware::DevicePipelineConfig c = sim_rig_config();
  c.poses = tracked ? firmware::CameraPoses::kIcp : firmware::CameraPoses::kKnown;
  c.use_sim_truth = tracked;
  c.push_every_frame = true;
  std::unique_ptr<firmware::DevicePipeline> p(new firmware::DevicePipeline);
  std::string err;
  CHECK_TRUE_TEXT(p->init(c, err), err.c_str());
  CHECK_EQUAL(0, p->model_count());  // no models configured, no replay: model-free segments
  CHECK_TRUE(p->map_empty());
  runtime::LocalizationOutcome r;
  const char* why = "";
  CHECK_FALSE(p->start_localization(now_us(), &why));  // nothing mapped yet
  STRCMP_EQUAL("the map is empty", why);

  CHECK_TRUE(p->start_mapping(&why));
  CHECK_TRUE(step_frames(*p, 3));  // warm-up: the first frame centres the volume
  CHECK_FALSE(p->map_empty());
  edgefuse_test::alloc_count_start();
  uint64_t frame_steps_us[2] = {0, 0};
  CHECK_TRUE(step_frames(*p, 5, frame_steps_us));
  const uint64_t still_since = p->stats().still_since_us;  // before localising: mapping pauses then
  CHECK_TRUE(localize(*p, r));
  const long allocations = edgefuse_test::alloc_count();
  CHECK_EQUAL(0L, allocations);

  CHECK_TRUE(runtime::TrackingState::kOk == p->stats().tracking);
  // The simulated rig sways on its circle at 2 pi 0.02 m / 8 s = 15.7 mm/s: it leaves the 1 mm
  // still tolerance within 64 ms, so it is never still for long (at any frame rate): still, if at
  // all, since one of the last two frames (counted in frames: the detector takes the time of the
  // step that processed a frame, and under an emulator one step takes seconds).
  CHECK_TRUE(still_since == 0 || still_since >= frame_steps_us[0]);
  CHECK_FALSE(r.failed);
  CHECK_TRUE(r.stamp_us > 0);
  // bin_rig_a's six objects as segments (some may merge). A segment needs 150 surface points
  // (LocalizeParams::segment_min_points); the map's surface holds a point per voxel of it, so at 4 mm
  // (board am335x) a lying 60 x 40 mm box's top holds 150 at best and the boxes and the upright
  // bracket drop out: the can, the lying bracket and the cylinder are left (600 points a box top at 2 mm).
  CHECK_TRUE(r.count >= (c.voxel_m <= 0.002f ? 4 : 3));
  for (int i = 0; i < r.count; ++i) CHECK_EQUAL(0u, r.objects[i].id);
  // The rig's pose for a hand-eye station: the reference's newest pose times its mounting's
  // inverse (the sim mounting when simulator truth is allowed, else the identity).
  Pose T_map_rig, T_rig_ref;
  uint64_t rig_stamp_us = 0;
  CHECK_TRUE(p->rig_pose(T_map_rig, rig_stamp_us));
  CHECK_EQUAL(p->reference_stamp_us(), rig_stamp_us);
  if (!tracked || !p->devices().truth(0)->mounting(T_rig_ref)) T_rig_ref = Pose::identity();
  CHECK_TRUE(((T_map_rig * T_rig_ref).t - p->reference_pose_at(rig_stamp_us).t).norm() < 1e-4f);
  p->stop_mapping();
  CHECK_FALSE(p->rig_pose(T_map_rig, rig_stamp_us));  // not mapping: no station
  p->shutdown();
}

}  // namespace

TEST_GROUP(DevicePipeline){};

TEST(DevicePipeline, KnownPosesSegmentsWithoutHeap) { run_pipeline(false); }

TEST(DevicePipeline, TrackedPosesSegmentsWithoutHeap) { run_pipeline(true); }

namespace {
// Steps for `ms` milliseconds.
void step_for(firmware::DevicePipeline& p, int ms) {
  const uint64_t end = now_us() + uint64_t(ms) * 1000u;
  while (now_us() < end) {
    p.step(now_us());
    sleep_ms(2);
  }
}
// Steps until the reference camera is in state `s` (at most 10 s).
bool wait_state(firmware::DevicePipeline& p, hal::DeviceState s) {
  const uint64_t end = now_us() + 10000000u;
  while (p.camera_stream(0).counters.device_state() != s && now_us() < end) step_for(p, 5);
  return p.camera_stream(0).counters.device_state() == s;
}
// A pipeline of the build board with sensors.fuse = `fuse` at the sim rig's known poses, the sim
// mountings allowed (tracking.sim_truth), initialised (the checks are the calling test's) and not
// mapping yet.
std::unique_ptr<firmware::DevicePipeline> fusing_pipeline(const char* fuse) {
  firmware::DevicePipelineConfig c = sim_rig_config();
  c.fuse = fuse;
  c.poses = firmware::CameraPoses::kKnown;
  c.use_sim_truth = true;
  std::unique_ptr<firmware::DevicePipeline> p(new firmware::DevicePipeline);
  std::string err;
  CHECK_TRUE_TEXT(p->init(c, err), err.c_str());
  return p;
}
}  // namespace

// Faults at the camera in edgefused: the acquisition thread recovers a stall by
// reopening, rejects a garbage frame with a counted reason, waits out an unplug; tracking pauses
// meanwhile and the map is kept (frames go on adding to it afterwards).
TEST(DevicePipeline, CameraFaultsKeepTheMap) {
  firmware::DevicePipelineConfig c = sim_rig_config();
  c.poses = firmware::CameraPoses::kKnown;
  c.inject_faults = true;
  std::unique_ptr<firmware::DevicePipeline> p(new firmware::DevicePipeline);
  std::string err;
  CHECK_TRUE_TEXT(p->init(c, err), err.c_str());
  const char* why = "";
  CHECK_TRUE(p->start_mapping(&why));
  CHECK_TRUE(step_frames(*p, 3));
  const hal::AcquisitionCounters& k = p->camera_stream(0).counters;
  CHECK_TRUE(p->devices().faults(0) != nullptr);
  hal::FaultCamera& cam = *p->devices().faults(0);

  // Stall longer than the worker's 1 s stall limit: stop, back off, reopen.
  const uint32_t timeouts_before = k.timeouts.load();
  cam.inject_stall(2500);
  // The frames rendered before the stall drain: the worker's first 200 ms timeout follows its last
  // frame, and one more step takes what it published (a fixed 300 ms was too short for the ASan
  // build at load: a step there takes ~300 ms and a frame was integrated after it).
  for (int i = 0; i < 200 && k.timeouts.load() == timeouts_before; ++i) step_for(*p, 10);
  step_for(*p, 1);
  uint32_t mapped = p->map_frames();
  const uint32_t published = k.published.load();
  step_for(*p, 300);
  CHECK_EQUAL(published, k.published.load());  // nothing arrives
  CHECK_EQUAL(mapped, p->map_frames());         // and nothing late is integrated
  CHECK_TRUE(step_frames(*p, 3));         // frames return by themselves
  CHECK_TRUE(k.stalls.load() >= 1);
  CHECK_TRUE(k.opens.load() >= 2);
  CHECK_TRUE(p->map_frames() >= mapped + 3);

  // A frame with no valid pixel: rejected with its reason, never integrated.
  cam.inject_garbage(hal::GarbageKind::kAllInvalid);
  CHECK_TRUE(step_frames(*p, 2));
  CHECK_EQUAL(1u, k.rejected[size_t(hal::FrameReject::kAllInvalid)].load());

  // Unplugged: the thread waits for the device monitor; tracking off, the map kept; replugged: on.
  mapped = p->map_frames();
  cam.set_plugged(false);
  CHECK_TRUE(wait_state(*p, hal::DeviceState::kUnplugged));
  // The frames delivered before the unplug are integrated first (one step each on a slow machine).
  for (int i = 0; i < 500 && p->stats().tracking != runtime::TrackingState::kOff; ++i) step_for(*p, 10);
  CHECK_TEXT(runtime::TrackingState::kOff == p->stats().tracking, p->device_state(0));
  CHECK_FALSE(p->map_empty());
  cam.set_plugged(true);
  CHECK_TRUE(step_frames(*p, 3));
  CHECK_TRUE(k.reconnects.load() >= 1);
  CHECK_TRUE(p->map_frames() >= mapped + 3);
  const std::string status = p->device_state(0);
  CHECK_TRUE_TEXT(status.find("streaming (map)") == 0, status.c_str());
  CHECK_TRUE_TEXT(status.find("all_invalid 1") != std::string::npos, status.c_str());
  p->stop_mapping();
  p->shutdown();
}

// The simulated devices at their real-time rates: pairing two cameras' frames, the line scanner's
// 100 Hz profiles. Under an emulator (the ARM builds' qemu-user: tests/CMakeLists.txt leaves this
// group out there) neither holds: the sim camera stamps a frame when it starts rendering it, and the
// xtion's 320x240 render takes 0.3-1 s there, so the tof frame of the same instant has been compared
// with the previous reference frame and let go long before the xtion's frame arrives (the pairing
// window is 40 ms; on the host a render takes milliseconds); and the sim trigger delivers every edge
// of its 10 ms period, missed ones too, so a scanner thread slower than that never catches up and
// takes the cores from the cameras.
TEST_GROUP(DevicePipelineRealTime){};

// sensors.fuse = "xtion,tof": the tof's frames enter the map at the xtion's pose of the same
// instant times the sim rig's mounting, weighted by its noise model; no heap while mapping; and
// calib fuse on the live map recovers the mounting.
TEST(DevicePipelineRealTime, TofFeedsTheMapAndCalibrates) {
  std::unique_ptr<firmware::DevicePipeline> p = fusing_pipeline("xtion,tof");
  STRCMP_EQUAL("sim rig mounting", p->camera_stream(1).mount_source);
  const char* why = "";
  CHECK_TRUE(p->start_mapping(&why));
  CHECK_TRUE(step_frames(*p, 4));
  edgefuse_test::alloc_count_start();
  CHECK_TRUE(step_frames(*p, 10));
  // A ToF frame enters the map only when it pairs with an xtion frame (40 ms window); a starved
  // ToF worker (load ~10 on 2 cores) can miss the first pairings, so give it up to 150 more frames
  // (30 are not enough for the host-fixed build at load ~5; the loop ends as soon as two ToF
  // frames are in).
  for (int extra = 0; extra < 150 && p->camera_stream(1).integrated < 2; ++extra) CHECK_TRUE(step_frames(*p, 1));
  CHECK_EQUAL(0L, edgefuse_test::alloc_count());
  CHECK_TRUE(p->camera_stream(1).integrated >= 2);
  // The map takes the rules of `edgefuse fuse --sensors` (fusion_rules.hpp): each fused frame's
  // median noise sets its depth-jump limit, and a set mixing the ToF's sub-unit samples with the
  // xtion's fills sub-unit samples only to 3 units, so its support rule is 4 (rule 3), not the
  // evidence rule's 9.
  CHECK_TRUE(p->camera_stream(0).slot.sigma.frames >= 2 && p->camera_stream(1).slot.sigma.frames >= 2);
  const float sigma_ref_m = 0.5f * sim_rig_config().voxel_m;  // the pipeline's trust reference
  CHECK_FALSE(sub_unit_sensor(p->camera_stream(0).slot.median_sigma(), sigma_ref_m));
  CHECK_TRUE(sub_unit_sensor(p->camera_stream(1).slot.median_sigma(), sigma_ref_m));
  LONGS_EQUAL(kSubUnitFillUnits, p->mapper().sub_unit_fill());
  LONGS_EQUAL(kMinSupportWeight, p->map_support_weight());
  // The tof's newest frame against the map (the sim rig sways slowly: within the pairing window).
  runtime::PairCalibrationReport r, attempt_r;
  bool ok = false;
  std::string last_why;
  // A command averages the frames that pair within a second of each other; on a starved machine
  // (load ~10 on 2 cores, or the ASan build at load: its sim ToF renders a frame in hundreds of ms)
  // fewer pair, or none in one command. That is the product's behaviour ("average what there is"),
  // so the test asks again until a command has averaged at least two, and keeps the command that
  // averaged most; the bound below follows its frame count.
  for (int attempt = 0; attempt < 20 && !(ok && r.frames >= 2); ++attempt) {
    step_for(*p, 30);
    if (p->calibrate_pair("xtion", "tof", attempt_r, &why)) {
      if (!ok || attempt_r.frames > r.frames) r = attempt_r;
      ok = true;
    } else {
      last_why = why;
    }
  }
  CHECK_TRUE_TEXT(ok, last_why.c_str());
  if (r.frames < 2) std::printf("  (a starved machine: no calib fuse command paired two frames; checked with one)\n");
  // Started at the true mounting: the mean of the frames' fits stays within a few mm / tenths of a
  // degree of it. One ToF frame scatters by ~3 mm per axis in x and y (up to 7 mm seen; z 0.5 mm),
  // so calib fuse averages kCalibFrames = 10 of them: 0.25-1.42 mm off in 30 runs, two at a time
  // (with 5 frames 0.2-6.0 mm: a fixed 5 mm bound fails there). The bound is
  // 4.5 sigma of the mean's distance (Rayleigh in x, y: exceeded once in ~20,000 commands) for
  // the frames a starved machine actually averaged, and 5 mm at 10 frames or more.
  CHECK_TRUE(r.frames >= 1);
  const float one_frame_sigma_mm = 3.0f;
  const float bound_mm = std::max(5.0f, 4.5f * one_frame_sigma_mm / std::sqrt(float(r.frames)));
  CHECK_TRUE_TEXT(r.moved_mm < bound_mm, (std::to_string(r.moved_mm) + " mm from the mounting after " +
                                          std::to_string(r.frames) + " frames").c_str());
  CHECK_TRUE(r.moved_deg < 1.0f);
  CHECK_FALSE(p->calibrate_pair("tof", "xtion", r, &why));
  CHECK_FALSE(p->calibrate_pair("xtion", "laser", r, &why));  // streams, but is no camera
  STRCMP_EQUAL("'laser' is a line scanner: only depth cameras are calibrated as a pair", why);
  p->stop_mapping();
  p->shutdown();
}

// A paired camera's frame is placed at the reference's pose at its own capture stamp (constant
// velocity through the reference's last two poses), not at the nearest reference frame's: on the
// sim rig (known poses, a circle of 2 cm in 8 s, 15.7 mm/s) that pose times the mounting is the
// tof's true pose within the constant-velocity model's error on the circle: a t_e (t_e + g) / 2 for
// the centripetal acceleration a, an extrapolation t_e <= the 40 ms pairing window and a gap g
// <= 250 ms between the two poses (0.072 mm), while the nearest reference frame is off by up to
// 0.6 mm. When the last two reference frames were more than 250 ms apart (a starved machine skips
// reference frames) there is no velocity and the frame takes the last pose exactly (the product's
// rule, PoseHistory::kVelocityGapMaxUs): each frame is checked by the rule that placed it. A CI run with the
// former 100 ms limit placed one frame of eight so (0.046 mm off) and failed the velocity bound.
TEST(DevicePipelineRealTime, PairedFramesTakeTheReferencePoseAtTheirStamp) {
  std::unique_ptr<firmware::DevicePipeline> p = fusing_pipeline("xtion,tof");
  const char* why = "";
  CHECK_TRUE(p->start_mapping(&why));
  CHECK_TRUE(step_frames(*p, 3));
  int by_velocity = 0, by_last_pose = 0;
  uint64_t last_checked_us = 0;
  float worst_mm = 0.0f, nearest_worst_mm = 0.0f;
  const uint64_t end = now_us() + 60000000u;
  while (by_velocity < 8 && by_velocity + by_last_pose < 40 && now_us() < end) {
    p->step(now_us());
    sleep_ms(2);
    const firmware::CameraStream& tof = p->camera_stream(1);
    if (tof.held == nullptr || tof.paired_stamp_us != p->reference_stamp_us() || tof.paired_stamp_us == last_checked_us)
      continue;
    last_checked_us = tof.paired_stamp_us;
    Pose truth;
    CHECK_TRUE(p->devices().truth(tof.index)->pose_of(tof.held->sequence, truth));
    const Pose placed = p->reference_pose_at(tof.held->stamp_us) * tof.T_ref_cam;
    const Pose nearest = p->reference_pose_at(p->reference_stamp_us()) * tof.T_ref_cam;
    CHECK_TRUE((placed.R - truth.R).norm() < 1e-4f);
    if (!p->reference_velocity_known()) {  // no velocity: exactly the last reference pose
      CHECK_TRUE((placed.t - nearest.t).norm() == 0.0f && (placed.R - nearest.R).norm() == 0.0f);
      ++by_last_pose;
      continue;
    }
    worst_mm = std::max(worst_mm, 1e3f * (placed.t - truth.t).norm());
    nearest_worst_mm = std::max(nearest_worst_mm, 1e3f * (nearest.t - truth.t).norm());
    ++by_velocity;
  }
  std::printf("paired tof frames placed by velocity: %d, within %.4f mm of their truth (the nearest reference pose: "
              "%.4f mm); at the last pose (no velocity): %d\n",
              by_velocity, double(worst_mm), double(nearest_worst_mm), by_last_pose);
  CHECK_TRUE(by_velocity + by_last_pose >= 4);
  if (by_velocity == 0) std::printf("  (a starved machine: no two reference frames within 250 ms, the velocity path was not reached)\n");
  const hal::SimDepthCameraConfig rig;
  const double omega = 2.0 * M_PI / double(rig.rig_period_s), accel = double(rig.rig_radius_m) * omega * omega;
  const double window_s = 1e-6 * double(firmware::DevicePipeline::kPairWindowUs);
  const double gap_s = 1e-6 * double(PoseHistory::kVelocityGapMaxUs);
  const double bound_mm = 1e3 * accel * window_s * (window_s + gap_s) / 2.0 + 0.001;  // + float rounding at 0.7 m
  CHECK_TRUE_TEXT(worst_mm < bound_mm, (std::to_string(worst_mm) + " mm > " + std::to_string(bound_mm)).c_str());
  p->stop_mapping();
  p->shutdown();
}

// sensors.fuse = "xtion,laser": the sim line scanner's profiles (100 Hz, its own thread) enter the
// map at the poses of the simulated axis, every one in order, without heap.
TEST(DevicePipelineRealTime, LineScannerFeedsTheMap) {
  std::unique_ptr<firmware::DevicePipeline> p = fusing_pipeline("xtion,laser");
  CHECK_EQUAL(3, p->device_count());
  STRCMP_EQUAL("laser", p->device_name(2));
  const char* why = "";
  CHECK_TRUE(p->start_mapping(&why));
  CHECK_TRUE(step_frames(*p, 3));
  const uint32_t before = p->scanner_stream().integrated;
  edgefuse_test::alloc_count_start();
  CHECK_TRUE(step_frames(*p, 5));
  CHECK_EQUAL(0L, edgefuse_test::alloc_count());
  CHECK_TRUE(p->scanner_stream().integrated > before + 10);
  LONGS_EQUAL(kMinSupportWeight, p->map_support_weight());  // one camera (+ scanner): support 4
  const std::string status = p->device_state(2);
  CHECK_TRUE_TEXT(status.find("streaming (map) profiles") == 0, status.c_str());
  p->stop_mapping();
  p->shutdown();
}

// A tracked map starts at flange pose x hand-eye x mounting: with the store's identity hand-eye at
// the sim robot's pose (= the camera's true pose); a hand-eye of 10 mm along the flange's x moves
// the start by that much along the flange's x axis.
TEST(DevicePipeline, TrackingStartsAtFlangeTimesHandEye) {
  firmware::DevicePipelineConfig c = sim_rig_config();
  c.use_sim_truth = true;
  std::unique_ptr<firmware::DevicePipeline> p(new firmware::DevicePipeline);
  std::string err;
  CHECK_TRUE_TEXT(p->init(c, err), err.c_str());
  Pose truth;
  CHECK_TRUE(p->devices().truth(0)->pose_of(7, truth));
  const Pose a = p->tracking_start_pose(7);
  CHECK_TRUE((a.t - truth.t).norm() < 1e-5f);
  runtime::CalibrationData d;
  d.T_flange_rig.tq[0] = 0.01f;
  p->calibration_changed(d);
  const Pose b = p->tracking_start_pose(7);
  CHECK_TRUE((b.t - (truth.t + truth.R * Vec3f(0.01f, 0, 0))).norm() < 1e-5f);
}

// Simulator truth only when configured: without tracking.sim_truth a tracked map starts at the
// identity though the sim robot's pose is there, and a paired camera takes no sim mounting; no
// FaultCameras unless asked for.
TEST(DevicePipeline, SimTruthOnlyWhenConfigured) {
  firmware::DevicePipelineConfig c = sim_rig_config();
  c.fuse = "xtion,tof";
  std::unique_ptr<firmware::DevicePipeline> p(new firmware::DevicePipeline);
  std::string err;
  CHECK_TRUE_TEXT(p->init(c, err), err.c_str());
  CHECK_TRUE(p->devices().truth(0) != nullptr);  // offered by the sim backend...
  const Pose a = p->tracking_start_pose(7);     // ...but not taken
  CHECK_TRUE(a.t.norm() == 0.0f && (a.R - Pose::identity().R).norm() == 0.0f);
  STRCMP_EQUAL("none", p->camera_stream(1).mount_source);
  CHECK_TRUE(p->devices().faults(0) == nullptr);
}

// tracking.poses = known with a reference camera that offers no truth (here bin_rig_a replayed
// without the xtion's groundtruth.txt) is refused at start-up, naming the camera.
TEST(DevicePipeline, KnownPosesWithoutTruthRefused) {
  const std::string rig = edgefuse_test::require_data("bin_rig_a");
  if (rig.empty()) return;
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("edgefuse_no_truth_" + std::to_string(now_us()));
  fs::create_directories(dir / "xtion");
  for (const char* e : {"rig.toml", "extrinsics.txt", "objects.txt", "models", "tof", "laser"})
    fs::create_symlink(fs::path(rig) / e, dir / e);
  for (const char* e : {"depth", "depth.txt", "rgb", "rgb.txt"})  // no groundtruth.txt
    fs::create_symlink(fs::path(rig) / "xtion" / e, dir / "xtion" / e);
  firmware::DevicePipelineConfig c = sim_rig_config();
  c.replay = dir.string();
  c.poses = firmware::CameraPoses::kKnown;
  std::unique_ptr<firmware::DevicePipeline> p(new firmware::DevicePipeline);
  std::string err;
  CHECK_FALSE(p->init(c, err));
  CHECK_TRUE_TEXT(err.find("tracking.poses = known: camera 'xtion' offers no true poses") == 0, err.c_str());
  CHECK_TRUE(p->devices().truth(0) == nullptr);  // the recording has no truth for the xtion
  CHECK_TRUE(p->devices().truth(1) != nullptr);  // the tof's groundtruth.txt is there
  p.reset();
  fs::remove_all(dir);
}

// A sensor that is not a camera of hal.toml is refused at start-up with the key and the names.
TEST(DevicePipeline, UnknownFuseSensorRefused) {
  firmware::DevicePipelineConfig c = sim_rig_config();
  c.fuse = "xtion,kinect";
  std::unique_ptr<firmware::DevicePipeline> p(new firmware::DevicePipeline);
  std::string err;
  CHECK_FALSE(p->init(c, err));
  CHECK_TRUE_TEXT(err.find("sensors.fuse = 'xtion,kinect': 'kinect' is not a sensor of") == 0, err.c_str());
  c.fuse = "laser,xtion";  // the reference must be a camera
  std::unique_ptr<firmware::DevicePipeline> q(new firmware::DevicePipeline);
  CHECK_FALSE(q->init(c, err));
  CHECK_TRUE_TEXT(err.find("the first sensor is the reference and must be a camera") != std::string::npos, err.c_str());
}

namespace {
// A robot that reports the sim rig's flange exactly at the instant of the reference camera's held
// frame (the sim robot's truth) and knows no other instant: the device pipeline's wiring of the
// robot modes, without the stream's interpolation (tests/test_pipeline_robot_poses.cpp measures that).
class FrameInstantRobot final : public runtime::FlangePoseSource {
 public:
  FrameInstantRobot(const firmware::CameraStream& ref, const hal::TruthSource& truth) : ref_(ref), truth_(truth) {}
  bool flange_pose_at(uint64_t stamp_us, Pose& T_base_flange) const override {
    const hal::DepthFrame* f = ref_.held;
    return f != nullptr && f->stamp_us == stamp_us && truth_.flange_pose_of(f->sequence, T_base_flange);
  }

 private:
  const firmware::CameraStream& ref_;
  const hal::TruthSource& truth_;
};

// A robot that has sent no pose yet.
class SilentRobot final : public runtime::FlangePoseSource {
 public:
  bool flange_pose_at(uint64_t, Pose&) const override { return false; }
};
}  // namespace

// tracking.poses = robot | robot+icp: the reference camera's pose is the robot's flange pose at the
// frame's stamp times the hand-eye mounting (here the identity, the sim rig's flange is the xtion):
// robot places the frames at the truth, robot+icp keeps them there (ICP from exact priors).
TEST(DevicePipeline, RobotPosesPlaceTheFrames) {
  for (const firmware::CameraPoses mode : {firmware::CameraPoses::kRobot, firmware::CameraPoses::kRobotIcp}) {
    firmware::DevicePipelineConfig c = sim_rig_config();
    c.poses = mode;
    c.push_every_frame = true;
    std::unique_ptr<firmware::DevicePipeline> p(new firmware::DevicePipeline);
    std::string err;
    CHECK_TRUE_TEXT(p->init(c, err), err.c_str());
    const hal::TruthSource* truth = p->devices().truth(0);
    CHECK_TRUE(truth != nullptr);
    const FrameInstantRobot robot(p->camera_stream(0), *truth);
    p->set_flange_poses(&robot);
    const char* why = "";
    CHECK_TRUE(p->start_mapping(&why));
    CHECK_TRUE(step_frames(*p, 4));
    CHECK_FALSE(p->map_empty());
    CHECK_TRUE(runtime::TrackingState::kOk == p->stats().tracking);
    const hal::DepthFrame* last = p->camera_stream(0).held;
    Pose T_true;
    CHECK_TRUE(last != nullptr && truth->pose_of(last->sequence, T_true));
    CHECK_EQUAL(last->stamp_us, p->reference_stamp_us());
    float dt = (p->mapper().reference().last().t - T_true.t).norm();
    // robot: the given pose itself; robot+icp: the given pose corrected by ICP on the sim rig's noisy
    // depth against a map of 2 mm (4 mm on am335x) voxels: within a voxel.
    CHECK_TRUE_TEXT(dt < (mode == firmware::CameraPoses::kRobot ? 1e-5f : c.voxel_m), std::to_string(dt).c_str());
    CHECK_EQUAL(0u, p->robot_pose_missing());
    p->stop_mapping();
    p->shutdown();
  }
}

// A robot mode without a robot pose at the frames' stamps: each frame waits for it up to
// kRobotPoseWaitUs, then it is skipped and counted (in the drops too); tracking is lost, the map empty.
TEST(DevicePipeline, FramesWithoutARobotPoseAreSkippedAndCounted) {
  firmware::DevicePipelineConfig c = sim_rig_config();
  c.poses = firmware::CameraPoses::kRobotIcp;
  std::unique_ptr<firmware::DevicePipeline> p(new firmware::DevicePipeline);
  std::string err;
  CHECK_TRUE_TEXT(p->init(c, err), err.c_str());
  const SilentRobot robot;
  p->set_flange_poses(&robot);
  const char* why = "";
  CHECK_TRUE(p->start_mapping(&why));
  const uint64_t end = now_us() + 20000000u;
  while (p->robot_pose_missing() < 3 && now_us() < end) {
    p->step(now_us());
    sleep_ms(2);
  }
  CHECK_TRUE(p->robot_pose_missing() >= 3);
  CHECK_TRUE(p->stats().drops >= p->robot_pose_missing());
  CHECK_TRUE(runtime::TrackingState::kLost == p->stats().tracking);
  CHECK_TRUE(p->map_empty());
  p->stop_mapping();
  p->shutdown();
}
