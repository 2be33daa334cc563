#include "device_pipeline.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <vector>

#include "edgefuse/hal/platform/config/board_data_dir.hpp"
#include "edgefuse/hal/platform/config/board_defaults.hpp"
#include "edgefuse/board_config.hpp"
#include "edgefuse/io/board_hal.hpp"
#include "edgefuse/io/rig.hpp"
#include "edgefuse/memory/arena.hpp"
#include "edgefuse/pipeline/localization_job.hpp"
#include "edgefuse/hal/platform/clock/cpu_clock.hpp"
#include "edgefuse/hal/platform/clock/monotonic_clock.hpp"
#include "edgefuse/hal/platform/threads/pool_parallel_for.hpp"
#include "edgefuse/io/localize_io.hpp"
#include "edgefuse/runtime/calib_pose.hpp"

namespace edgefuse::firmware {

namespace {

constexpr int kPixels = kBuildBoard.image_width_max * kBuildBoard.image_height_max;
// The filters' intermediate image and the scratch of centring a new map live in .bss (static
// memory, no heap); the frames live in the cameras' pools (camera_stream.cpp) and the filtered
// images in the board's per-sensor buffers.
uint16_t g_filter_scratch[kPixels];
constexpr std::size_t kCentreSamples = std::size_t(kBuildBoard.image_width_max / 2 + 1) *
                                       std::size_t(kBuildBoard.image_height_max / 2 + 1);
float g_centre_xyz[3][kCentreSamples];

using runtime::to_pose;

// The acquisition worker's stall limit for a camera: its default (1 s without a frame), or three
// frame periods of a camera slower than that allows: a replay in slow motion (a 5 fps recording at
// sensors.replay_speed 0.1 delivers a frame every 2 s) would otherwise be taken for stalled and
// reopened, that is restarted from its first frame, between every two frames.
uint32_t stall_limit_ms(hal::DepthCamera& camera, bool replayed, double replay_speed) {
  const uint32_t standard = hal::CameraWorkerConfig().stall_ms;
  hal::DepthMode mode;
  if (!camera.mode(0, mode) || mode.fps <= 0) return standard;
  const double period_ms = 1000.0 / (double(mode.fps) * (replayed ? replay_speed : 1.0));
  return std::max(standard, uint32_t(std::ceil(3.0 * period_ms)));
}

runtime::TrackingState runtime_state(TrackState s) {
  return s == TrackState::kOk         ? runtime::TrackingState::kOk
         : s == TrackState::kDegraded ? runtime::TrackingState::kDegraded
                                      : runtime::TrackingState::kLost;
}

PoseMode mapper_pose_mode(CameraPoses p) {
  switch (p) {
    case CameraPoses::kIcp: return PoseMode::kTracked;
    case CameraPoses::kRobotIcp: return PoseMode::kPrior;
    case CameraPoses::kKnown:
    case CameraPoses::kRobot: break;
  }
  return PoseMode::kKnown;
}

const char* pose_mode_text(const DevicePipelineConfig& c) {
  switch (c.poses) {
    case CameraPoses::kIcp:
      return c.push_every_frame ? "icp (ICP against the raycast model, every frame pushed)"
                                : "icp (ICP against the raycast model, push after 1 cm / 1 deg)";
    case CameraPoses::kKnown: return "known (the backend's truth)";
    case CameraPoses::kRobot: return "robot (flange pose x hand-eye, every frame pushed)";
    case CameraPoses::kRobotIcp:
      return c.push_every_frame ? "robot+icp (flange pose x hand-eye corrected by ICP, every frame pushed)"
                                : "robot+icp (flange pose x hand-eye corrected by ICP, push after 1 cm / 1 deg)";
  }
  return "";
}

}  // namespace

bool parse_camera_poses(const std::string& text, CameraPoses& out) {
  if (text == "icp" || text == "tracked")
    out = CameraPoses::kIcp;
  else if (text == "known")
    out = CameraPoses::kKnown;
  else if (text == "robot")
    out = CameraPoses::kRobot;
  else if (text == "robot+icp")
    out = CameraPoses::kRobotIcp;
  else
    return false;
  return true;
}

bool DevicePipeline::init(const DevicePipelineConfig& config, std::string& err) {
  config_ = config;
  const BoardCapacities* board = find_board(config.board.c_str());
  if (board == nullptr) {
    err = "unknown board " + config.board;
    return false;
  }
  if (std::strcmp(board->name, build_board().name) != 0) {
    err = "board " + config.board + ": this build's static memory is sized for board " + build_board().name +
          " (build that board's preset)";
    return false;
  }
  // Devices from the board's hal.toml or config.hal_file (sensors.replay: every camera replays the
  // rig set instead).
  std::string hal_path = config.hal_file;
  if (hal_path.empty() && !hal::board_file_path(config.board, "hal.toml", hal_path, err)) return false;
  hal::BoardDefaults defaults;
  if (!init_cameras(hal_path, err) || !init_fused(hal_path, err) || !hal::read_board_defaults(config.board, defaults, err))
    return false;
  // Static buffers: the board's memory map carved once, the volume bound to its capacity.
  if (carve_memory(*board, static_arena(), static_arena_bytes(), buffers_) != Status::kOk) {
    err = "static arena too small for board " + std::string(board->name) + "'s memory map";
    return false;
  }
  TsdfParams tp = TsdfParams::defaults_for(config.voxel_m, config.trunc_m);
  tp.max_weight = uint8_t(defaults.max_weight);
  const int dim = config.dim > 0 ? config.dim : defaults.dim;
  if (volume_.init(buffers_.voxels, dim, Vec3f::Zero(), tp) != Status::kOk) {
    err = "volume " + std::to_string(dim) + "^3 at " + std::to_string(config.voxel_m) + " m refused";
    return false;
  }
  threads_ = defaults.threads;
  // Each camera: its slot of the per-sensor buffers, its filters, its frame pool and its thread.
  for (int i = 0; i < camera_count_; ++i) {
    CameraStream& c = cams_[i];
    hal::DepthMode mode;
    devices_.camera(i).mode(0, mode);
    if (!c.bind(buffers_, *board, devices_.camera(i).intrinsics(), mode.amplitude, config.bilateral, err)) return false;
    c.worker.reset(new hal::CameraWorker(devices_.camera(i), c.channel, c.counters, hal::monotonic_clock(),
                                         &devices_.monitor()));
  }
  if (!init_scanner(*board, err)) return false;
  // Several sensors in one map: each pixel weighted by its sensor's noise (as edgefuse fuse --sensors).
  use_trust_ = fuse_count_ > 1 || scanner_.fuse;
  if (use_trust_ && cams_[order_[0]].slot.trust.data == nullptr) {
    err = std::string("board ") + board->name + " has no trust maps in its memory map (needed to fuse several sensors)";
    return false;
  }
  MapperParams mp;
  mp.poses = mapper_pose_mode(config.poses);
  mp.tracker.push.every_frame = config.push_every_frame;
  mp.noise_weights = use_trust_;
  const CameraStream& ref = cams_[order_[0]];
  const ViewCentreScratch centre{g_centre_xyz[0], g_centre_xyz[1], g_centre_xyz[2], kCentreSamples};
  KernelRunners runners;
  runners.tsdf = tsdf_rows_.runner();
  runners.icp = icp_rows_.runner();
  if (mapper_.init(volume_, runners, ImageView<uint16_t>(g_filter_scratch, ref.slot.intr.width, ref.slot.intr.height),
                   centre, mp) != Status::kOk) {
    err = "mapping: bad tracker parameters";
    return false;
  }
  CameraSlot* fused[kCamerasMax];
  for (int k = 0; k < fuse_count_; ++k) fused[k] = &cams_[order_[k]].slot;
  mapper_.set_fused_cameras(fused, fuse_count_);
  if (!config.replay.empty() && !io::read_rig_extrinsics(config.replay, rig_extrinsics_, err)) return false;
  update_mounts();
  if (!init_models(err)) return false;
  print_setup();
  pool_.start(threads_);
  // The localiser's voting and refinement run on the integration's workers too: step() integrates
  // and tracks nothing while a localisation is busy and calib fuse is refused then, so the pool is
  // idle and the localisation thread its only caller (same results for any thread count).
  if (threads_ > 1) loc_.set_parallel(pool_parallel_for(pool_));
  localization_.start([](void* self) { static_cast<DevicePipeline*>(self)->run_localization(); }, this);
  return true;
}

// sensors.sim_path: the sim rig's key poses, before the devices are built (they keep a pointer).
bool DevicePipeline::load_sim_path(std::string& err) {
  if (config_.sim_path.empty()) return true;
  if (!config_.replay.empty()) {
    err = "sensors.sim_path moves the sim rig: not with sensors.replay";
    return false;
  }
  if (!hal::load_sim_rig_path(config_.sim_path, sim_rig_path_, err)) return false;
  devices_.set_sim_rig_path(&sim_rig_path_);
  return true;
}

// The robot simulator reads the path's time base from this line (its clock is the HAL clock,
// CLOCK_MONOTONIC, which Python's time.monotonic() reads too).
void DevicePipeline::print_sim_path() const {
  if (config_.sim_path.empty()) return;
  std::printf("sim: rig path %s: %d keys over %.2f s from clock %llu us\n", config_.sim_path.c_str(),
              sim_rig_path_.count, sim_rig_path_.duration_s(),
              static_cast<unsigned long long>(devices_.sim_rig_epoch_us()));
  std::fflush(stdout);
}

// The board's cameras from hal.toml (or the replayed set), each with its first mode.
bool DevicePipeline::init_cameras(const std::string& hal_path, std::string& err) {
  const BoardCapacities& board = build_board();
  io::BoardHal hal_data;
  if (!io::read_board_hal(hal_path, hal_data, err)) return false;
  // A replayed recording is one scan: it ends after its last frame (each frame integrated once) and
  // the rig then counts as still (the still-period trigger localises).
  if (!load_sim_path(err)) return false;
  if (!devices_.build(hal_data, hal::monotonic_clock(), err, config_.replay, false, config_.replay_speed,
                      config_.inject_faults)) {
    err = hal_path + ": " + err;
    return false;
  }
  print_sim_path();
  if (devices_.camera_count() == 0) {
    err = hal_path + " lists no [[camera]]";
    return false;
  }
  if (devices_.camera_count() > kCamerasMax || devices_.camera_count() > board.sensors_max) {
    err = hal_path + ": " + std::to_string(devices_.camera_count()) + " cameras, board " + board.name +
          " has buffers for " + std::to_string(std::min(kCamerasMax, int(board.sensors_max)));
    return false;
  }
  camera_count_ = devices_.camera_count();
  for (int i = 0; i < camera_count_; ++i) {
    hal::DepthMode mode;
    if (!devices_.camera(i).mode(0, mode)) {
      err = std::string("camera '") + devices_.camera(i).name() + "' offers no mode";
      return false;
    }
    cams_[i].name = devices_.camera_config(i).name;
    cams_[i].index = i;
  }
  return true;
}

// sensors.fuse: the cameras that feed the map (the first is the reference) and the line scanner.
bool DevicePipeline::init_fused(const std::string& hal_path, std::string& err) {
  std::string names;
  for (int i = 0; i < camera_count_; ++i) names += (i ? ", " : "") + cams_[i].name;
  fuse_count_ = 0;
  const std::string list = config_.fuse.empty() ? cams_[0].name : config_.fuse;
  for (std::size_t pos = 0; pos <= list.size();) {
    const std::size_t comma = std::min(list.find(',', pos), list.size());
    const std::string n = list.substr(pos, comma - pos);
    pos = comma + 1;
    int found = -1;
    for (int i = 0; i < camera_count_; ++i)
      if (cams_[i].name == n) found = i;
    if (found < 0 && devices_.scanner() != nullptr && n == devices_.scanner()->name()) {
      if (fuse_count_ == 0) {
        err = "sensors.fuse = '" + config_.fuse + "': the first sensor is the reference and must be a camera";
        return false;
      }
      scanner_.fuse = true;
      continue;
    }
    if (found < 0) {
      err = "sensors.fuse = '" + config_.fuse + "': '" + n + "' is not a sensor of " + hal_path + " (" + names +
            (devices_.scanner() != nullptr ? std::string(", ") + devices_.scanner()->name() : std::string()) + ")";
      return false;
    }
    if (cams_[found].fuse) {
      err = "sensors.fuse = '" + config_.fuse + "': '" + n + "' is listed twice";
      return false;
    }
    cams_[found].fuse = true;
    order_[fuse_count_++] = found;
  }
  const CameraStream& ref = cams_[order_[0]];
  if (config_.poses == CameraPoses::kKnown && devices_.truth(ref.index) == nullptr) {
    err = "tracking.poses = known: camera '" + ref.name +
          "' offers no true poses (only the sim backend and a replayed recording with ground truth do); "
          "use tracking.poses = icp (or robot, robot+icp with a robot connected)";
    return false;
  }
  return true;
}

// The line scanner: the slot after the cameras', its own thread and pool.
bool DevicePipeline::init_scanner(const BoardCapacities& board, std::string& err) {
  if (devices_.scanner() == nullptr) return true;
  scanner_.name = devices_.scanner()->name();
  if (!scanner_.bind(*devices_.scanner(), buffers_, board, camera_count_, err)) {
    if (scanner_.fuse) return false;
    std::printf("line scanner %s not streamed: %s\n", scanner_.name.c_str(), err.c_str());
    scanner_.name.clear();
    err.clear();
    return true;
  }
  scanner_.has_axis = devices_.scanner_axis(scanner_.T_world_axis0, scanner_.axis_world);
  if (scanner_.fuse && !scanner_.has_axis) {
    err = "sensors.fuse: line_scanner '" + scanner_.name + "': its backend reports no axis to place profiles";
    return false;
  }
  return true;
}

// Models: the configured file/folder, else the replayed rig set's (rig.toml [[object]] models).
bool DevicePipeline::init_models(std::string& err) {
  const BoardCapacities& board = build_board();
  if (loc_.init(buffers_.localize) != Status::kOk) {
    err = std::string("board ") + board.name + " has no localisation buffers in its memory map";
    return false;
  }
  loc_params_.min_score = config_.min_score;
  loc_params_.max_per_model = board.objects_max;
  std::vector<std::string> files;
  if (!io::model_files_for(config_.models, config_.replay, files, err)) return false;
  for (const std::string& f : files) {
    int index = -1;
    if (!io::load_model(loc_, f, loc_params_, index, err)) {
      err = "model " + f + ": " + err;
      return false;
    }
    const ModelInfo& mi = loc_.model(index);
    std::printf("model %d: %s (%s), diameter %.1f mm, %u PPF samples\n", index + 1, mi.name, f.c_str(),
                mi.diameter_m * 1e3, mi.ppf_count);
  }
  if (files.empty()) std::printf("models: none (localize reports model-free segments, id 0)\n");
  return true;
}

void DevicePipeline::print_setup() const {
  const CameraStream& ref = cams_[order_[0]];
  std::printf("pipeline: camera %s (%s%s), %dx%d, filters %s%s, volume %d^3 x %.1f mm, poses: %s, %d thread(s)\n",
              ref.name.c_str(), config_.replay.empty() ? "hal.toml backend" : "replay of ", config_.replay.c_str(),
              ref.slot.intr.width, ref.slot.intr.height, ref.slot.tof() ? "tof" : "structured-light",
              config_.bilateral ? "+bilateral" : "", volume_.dim(), volume_.voxel_m() * 1e3,
              pose_mode_text(config_), threads_);
  if (robot_poses())
    std::printf("pipeline: camera poses from the robot's flange poses (robot.latency_us %lld), in the robot's base frame\n",
                static_cast<long long>(config_.robot_latency_us));
  if (config_.use_sim_truth)
    std::printf("pipeline: simulator truth allowed (tracking.sim_truth): robot pose, rig mountings, tracking error\n");
  std::string names, fused;
  for (int i = 0; i < camera_count_; ++i) names += (i ? ", " : "") + cams_[i].name;
  for (int k = 0; k < fuse_count_; ++k) fused += (k ? "," : "") + cams_[order_[k]].name;
  if (scanner_.fuse) fused += "," + scanner_.name;
  if (!scanner_.name.empty()) names += ", " + scanner_.name;
  std::printf("sensors: %s stream (one acquisition thread each); map: %s%s\n", names.c_str(), fused.c_str(),
              use_trust_ ? " (weights from each sensor's noise model)" : "");
}

// Extrinsics of every camera in the reference camera's frame, best source first.
void DevicePipeline::update_mounts() {
  const CameraStream& ref = cams_[order_[0]];
  for (int i = 0; i < camera_count_; ++i) {
    CameraStream& c = cams_[i];
    if (&c == &ref) {
      c.T_ref_cam = Pose::identity();
      c.has_mount = true;
      c.mount_source = "reference";
      continue;
    }
    Pose T, T_rig_ref, T_rig_cam;
    const char* source = nullptr;
    const runtime::SensorPair* p = runtime::calib_find_pair(calib_, ref.name.c_str(), c.name.c_str());
    const runtime::SensorPair* q = runtime::calib_find_pair(calib_, c.name.c_str(), ref.name.c_str());
    const runtime::SensorPair* rr = runtime::calib_find_pair(calib_, "rig", ref.name.c_str());
    const runtime::SensorPair* rc = runtime::calib_find_pair(calib_, "rig", c.name.c_str());
    if (p != nullptr) {
      T = to_pose(p->T_from_to);
      source = "calibration store";
    } else if (q != nullptr) {
      T = to_pose(q->T_from_to).inverse();
      source = "calibration store (inverted pair)";
    } else if (rr != nullptr && rc != nullptr) {
      T = to_pose(rr->T_from_to).inverse() * to_pose(rc->T_from_to);
      source = "calibration store (rig mountings)";
    }
    for (const io::SensorExtrinsic& e : rig_extrinsics_) {
      if (source != nullptr) break;
      if (e.sensor_a == ref.name && e.sensor_b == c.name) {
        T = e.T_a_b;
        source = "rig set extrinsics.txt";
      } else if (e.sensor_a == c.name && e.sensor_b == ref.name) {
        T = e.T_a_b.inverse();
        source = "rig set extrinsics.txt (inverted)";
      }
    }
    const hal::TruthSource* truth_ref = sim_truth(ref.index);
    const hal::TruthSource* truth_cam = sim_truth(c.index);
    if (source == nullptr && truth_ref != nullptr && truth_cam != nullptr && truth_ref->mounting(T_rig_ref) &&
        truth_cam->mounting(T_rig_cam)) {
      T = T_rig_ref.inverse() * T_rig_cam;
      source = "sim rig mounting";
    }
    const bool changed = source == nullptr ? c.has_mount : (!c.has_mount || std::strcmp(source, c.mount_source) != 0 ||
                                                           (T.t - c.T_ref_cam.t).norm() > 1e-6f ||
                                                           (T.R - c.T_ref_cam.R).norm() > 1e-6f);
    c.has_mount = source != nullptr;
    c.mount_source = source != nullptr ? source : "none";
    if (c.has_mount) c.T_ref_cam = T;
    if (!changed && c.integrated + c.unpaired > 0) continue;
    if (c.has_mount) {
      const Eigen::Quaternionf qq = T.quaternion();
      std::printf("extrinsics: T_%s_%s = %.4f %.4f %.4f %.5f %.5f %.5f %.5f (%s)\n", ref.name.c_str(), c.name.c_str(),
                  double(T.t.x()), double(T.t.y()), double(T.t.z()), double(qq.x()), double(qq.y()), double(qq.z()),
                  double(qq.w()), source);
    } else if (c.fuse) {
      std::printf("extrinsics: %s has none in %s's frame (calib set / calib fuse): its frames are not integrated\n",
                  c.name.c_str(), ref.name.c_str());
    }
  }
  std::fflush(stdout);
}

void DevicePipeline::calibration_changed(const runtime::CalibrationData& d) {
  calib_ = d;
  if (camera_count_ > 0) update_mounts();
}

void DevicePipeline::shutdown() {
  localization_.stop();
  pool_.stop();
  for (int i = 0; i < camera_count_; ++i)
    if (cams_[i].worker) cams_[i].worker->stop();
  if (scanner_.worker) scanner_.worker->stop();
  camera_running_ = false;
}

const char* DevicePipeline::device_name(int i) const {
  return i < camera_count_ ? cams_[i].name.c_str() : scanner_.name.c_str();
}

const char* DevicePipeline::device_state(int i) const {
  return i < camera_count_ ? cams_[i].status_text() : scanner_.status_text();
}

bool DevicePipeline::start_mapping(const char** why) {
  if (!camera_running_) {
    // Every camera streams on its own thread from now on; a camera that does not open is retried
    // with back-off by its thread (status shows it), the others go on.
    for (int i = 0; i < camera_count_; ++i) {
      CameraStream& c = cams_[i];
      c.held = nullptr;  // the pool starts afresh (the thread is stopped)
      c.held_new = false;
      if (!c.restart_pool()) {
        *why = "frame pool";
        return false;
      }
      hal::CameraWorkerConfig wc;
      const bool replayed = !config_.replay.empty() || devices_.camera_config(i).backend == io::CameraBackend::kReplay;
      wc.stall_ms = stall_limit_ms(devices_.camera(i), replayed, config_.replay_speed);
      if (!c.worker->start(wc)) {
        *why = "the acquisition thread did not start";
        return false;
      }
    }
    if (scanner_.worker) {
      if (!scanner_.restart_pool() || !scanner_.worker->start(hal::ScannerWorkerConfig())) {
        *why = "the line scanner's acquisition thread did not start";
        return false;
      }
    }
    camera_running_ = true;
  }
  mapping_ = true;
  warned_no_pose_ = false;  // said again once a scan
  said_first_stamp_ = false;
  return true;
}

void DevicePipeline::stop_mapping() {
  mapping_ = false;
  // The threads stop; each camera's held frame stays valid (calib fuse may still use it).
  for (int i = 0; i < camera_count_; ++i) cams_[i].worker->stop();
  if (scanner_.worker) scanner_.worker->stop();
  camera_running_ = false;
  still_.reset();
  stats_.fps = 0;
  stats_.still_since_us = 0;
  stats_.tracking = runtime::TrackingState::kOff;
}

void DevicePipeline::reset_map() {
  if (localization_.busy()) return;  // the localiser reads the volume; the runtime refuses this anyway
  mapper_.new_map();
}

void DevicePipeline::step(uint64_t now_us) {
  if (!mapping_ || !camera_running_) return;
  // Newest-frame policy for the reference camera; the others are paired with its frames below.
  CameraStream& ref = cams_[order_[0]];
  // Robot modes: the held frame is placed or skipped (counted) before a newer one is taken; while it
  // waits for the robot's pose at its stamp a newer frame would only wait longer.
  if (!robot_poses() || !ref.held_new) ref.take_newest();
  if (localization_.busy()) {
    update_drops();
    return;  // the volume belongs to the localiser now; the held frames wait
  }
  const hal::DeviceState st = ref.counters.device_state();
  if (ref.held_new && wait_for_robot_pose(ref, now_us)) {
    // held until the robot's pose at its stamp arrives (or a newer frame replaces it)
  } else if (ref.held_new) {
    ref.held_new = false;
    process_reference(now_us);
    drain_profiles();  // between the cameras too: the profile pool holds 150 ms at 100 Hz
  } else if (st == hal::DeviceState::kEnded) {
    stats_.fps = 0;
    still_.mark_still(now_us);
  } else if (st != hal::DeviceState::kStreaming) {
    // Stalled, reopening or unplugged: tracking pauses, the map is kept; it resumes with the frames.
    stats_.fps = 0;
    stats_.tracking = runtime::TrackingState::kOff;
    still_.reset();
  }
  stats_.still_since_us = still_.still_since_us();
  // Every other camera: the frame nearest in time to the reference's last frame (until one within
  // the pairing window is found); integrated at the reference's pose when it feeds the map, else
  // kept for calib fuse. Frames that find no partner are counted as unpaired.
  const uint64_t ref_stamp_us = mapper_.reference().stamp_us();
  for (int i = 0; i < camera_count_; ++i) {
    CameraStream& c = cams_[i];
    if (&c == &ref || !mapper_.reference().has_pose() || c.paired_stamp_us == ref_stamp_us) continue;
    c.take_nearest(ref_stamp_us);
    if (c.held == nullptr) continue;
    const uint64_t s = c.held->stamp_us;
    if ((s > ref_stamp_us ? s - ref_stamp_us : ref_stamp_us - s) > kPairWindowUs) continue;
    c.paired_stamp_us = ref_stamp_us;
    if (c.fuse && c.held_new) {
      process_other(c);
      drain_profiles();
    }
    c.held_new = false;
  }
  drain_profiles();
  update_drops();
}

// The line scanner: every profile, in order (each is one slice of the scan).
void DevicePipeline::drain_profiles() {
  if (scanner_.worker) scanner_.channel.drain([this](const hal::LineProfile& p) { process_profile(p); });
}

void DevicePipeline::process_profile(const hal::LineProfile& p) {
  if (!scanner_.fuse) return;
  Pose T;
  if (!mapper_.placed() || !scanner_.pose_of(p, T)) {  // no map placed yet, or no axis position
    ++scanner_.skipped;
    return;
  }
  if (mapper_.map_profile(scanner_.model, scanner_.tables, p.ranges_m, T, kLineScannerSigmaM) != Status::kOk) {
    ++pipeline_drops_;
    return;
  }
  ++scanner_.integrated;
}

void DevicePipeline::update_drops() {
  uint32_t n = pipeline_drops_;
  for (int k = 0; k < fuse_count_; ++k) {
    const CameraStream& c = cams_[order_[k]];
    n += c.counters.dropped_stale.load(std::memory_order_relaxed) +
         c.counters.dropped_overrun.load(std::memory_order_relaxed) + c.counters.device_gaps.load(std::memory_order_relaxed) +
         c.counters.rejected_total() + c.skipped + c.unpaired;
  }
  if (scanner_.fuse)
    n += scanner_.counters.dropped_overrun.load(std::memory_order_relaxed) +
         scanner_.counters.device_gaps.load(std::memory_order_relaxed) + scanner_.counters.rejected_total() +
         scanner_.skipped;
  stats_.drops = n;
}

void DevicePipeline::process_reference(uint64_t now_us) {
  CameraStream& ref = cams_[order_[0]];
  if (last_frame_us_ != 0 && now_us > last_frame_us_) {
    const float inst = 1e6f / float(now_us - last_frame_us_);
    stats_.fps = stats_.fps <= 0 ? inst : 0.9f * stats_.fps + 0.1f * inst;
  }
  last_frame_us_ = now_us;
  if (!said_first_stamp_) {
    // The board clock's time of the scan's first reference frame: a robot (or a simulated one)
    // lines its pose stream up with the camera's time base by it.
    said_first_stamp_ = true;
    std::printf("pipeline: first frame of the scan: %s stamp %llu us (sequence %u, board clock)\n", ref.name.c_str(),
                static_cast<unsigned long long>(ref.held->stamp_us), unsigned(ref.held->sequence));
    std::fflush(stdout);
  }
  // The backend's truth: the frame's pose with tracking.poses = known, the tracking error's
  // reference with tracking.sim_truth; never otherwise.
  const hal::TruthSource* truth = tracked() ? sim_truth(ref.index) : devices_.truth(ref.index);
  Pose known;
  const bool has_known = truth != nullptr && truth->pose_of(ref.held->sequence, known);
  // The pose given with the frame: the truth (known), the robot's (robot, robot+icp: the prior).
  Pose given = known;
  const bool has_given = robot_poses() ? robot_pose(ref.held->stamp_us, given) : !tracked() && has_known;
  // An icp map starts at the pose the robot's flange and the calibrated hand-eye mounting give.
  const bool starts = config_.poses == CameraPoses::kIcp && mapper_.starts_new_map();
  const Pose start = starts ? tracking_start_pose(ref.held->sequence, ref.held->stamp_us) : Pose::identity();
  ReferenceStep step;
  if (mapper_.starts_new_map()) base_placement_ = BasePlacement();
  const Status s = mapper_.map_reference(ref.slot, ref.held_frame(), has_given ? &given : nullptr, start, step);
  if (step.filtered) ++stats_.frames;
  if (step.centred) {
    const Vec3f& o = volume_.origin_m();
    std::printf("map: volume origin %.3f %.3f %.3f m (centred on the first frame's view)\n", double(o.x()),
                double(o.y()), double(o.z()));
    std::fflush(stdout);
  }
  if (s != Status::kOk) {
    ++pipeline_drops_;
    return;
  }
  if (config_.poses != CameraPoses::kIcp && !has_given) {
    count_unplaced_frame(ref);
    return;
  }
  if (icp_poses()) {
    stats_.tracking = runtime_state(step.track.state);
    if (step.track.state == TrackState::kLost) ++lost_frames_;
    // robot+icp: the map lies where the first frame's robot pose put it (its error included); every
    // tracked frame's robot pose against its ICP pose says where the map lies in the base frame.
    if (config_.poses == CameraPoses::kRobotIcp && has_given && step.track.state == TrackState::kOk)
      base_placement_.add(given * step.T_world_cam.inverse());
  } else {
    stats_.tracking = runtime::TrackingState::kOk;
  }
  if (tracked() && has_known) track_err_m_ = (step.T_world_cam.t - known.t).norm();  // against the backend's truth
  still_.update(step.T_world_cam, now_us);
  stats_.still_since_us = still_.still_since_us();
  if (step.integrated) ++ref.integrated;
}

// A frame without its given pose (known: no truth for it; robot modes: no robot pose at its stamp)
// cannot be placed: not integrated, counted, said once a scan.
void DevicePipeline::count_unplaced_frame(const CameraStream& ref) {
  stats_.tracking = runtime::TrackingState::kLost;
  ++pipeline_drops_;
  if (robot_poses()) ++robot_pose_missing_;
  if (warned_no_pose_) return;
  warned_no_pose_ = true;
  if (!robot_poses())
    std::printf("pipeline: camera %s gives no known pose (set tracking.poses = icp): frames are not integrated\n",
                ref.name.c_str());
  else if (flange_poses_ == nullptr)
    std::printf("pipeline: tracking.poses = %s but no robot pose source: frames are not integrated\n",
                config_.poses == CameraPoses::kRobot ? "robot" : "robot+icp");
  else
    std::printf("pipeline: no robot pose at the frame's stamp %llu us + robot.latency_us %lld (send CAPTURE / POSE "
                "updates): such frames are skipped and counted\n",
                static_cast<unsigned long long>(ref.held->stamp_us), static_cast<long long>(config_.robot_latency_us));
  std::fflush(stdout);
}

// A frame the robot has no pose for waits while its stamp (plus the latency offset) is recent: the
// robot's update for that instant may still be on the way.
bool DevicePipeline::wait_for_robot_pose(const CameraStream& ref, uint64_t now_us) const {
  Pose T;
  if (!robot_poses() || flange_poses_ == nullptr || robot_pose(ref.held->stamp_us, T)) return false;
  return int64_t(now_us) < int64_t(ref.held->stamp_us) + config_.robot_latency_us + int64_t(kRobotPoseWaitUs);
}

void DevicePipeline::BasePlacement::add(const Pose& T_base_map) {
  const Eigen::Quaternionf q = T_base_map.quaternion();
  double qd[4] = {q.x(), q.y(), q.z(), q.w()};
  if (frames > 0 && qd[0] * this->q[0] + qd[1] * this->q[1] + qd[2] * this->q[2] + qd[3] * this->q[3] < 0)
    for (double& c : qd) c = -c;
  for (int k = 0; k < 3; ++k) t[k] += double(T_base_map.t[k]);
  for (int k = 0; k < 4; ++k) this->q[k] += qd[k];
  ++frames;
}

// The mean of small corrections: translations averaged, quaternions averaged and normalised.
bool DevicePipeline::BasePlacement::mean(Pose& T_base_map) const {
  if (frames < 2) return false;
  const double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (!(n > 0)) return false;
  const double f = 1.0 / double(frames);
  T_base_map = Pose::from_tq(float(t[0] * f), float(t[1] * f), float(t[2] * f), float(q[0] / n), float(q[1] / n),
                             float(q[2] / n), float(q[3] / n));
  return true;
}

bool DevicePipeline::robot_pose(uint64_t stamp_us, Pose& T_base_ref) const {
  const char* mount = "";
  return flange_poses_ != nullptr && runtime::robot_camera_pose(*flange_poses_, stamp_us, config_.robot_latency_us,
                                                                flange_to_reference(&mount), T_base_ref);
}

// T_flange_ref = T_flange_rig * T_rig_ref: the hand-eye mounting (calibration store) and the
// reference camera's mounting on the rig (calibration store, else the sim mounting with
// tracking.sim_truth, else the identity: the rig is the reference camera).
Pose DevicePipeline::flange_to_reference(const char** mount) const {
  const CameraStream& ref = cams_[order_[0]];
  Pose T_rig_ref = Pose::identity();
  *mount = "identity";
  if (runtime::rig_mounting(calib_, ref.name.c_str(), T_rig_ref)) {
    *mount = "calibration store";
  } else if (const hal::TruthSource* truth = sim_truth(ref.index)) {
    if (truth->mounting(T_rig_ref)) *mount = "sim mounting";
  }
  return to_pose(calib_.T_flange_rig) * T_rig_ref;
}

// T_world_ref = T_world_flange * T_flange_rig * T_rig_ref: the robot's flange pose (the flange
// pose source at the frame's stamp, else the simulated robot's with tracking.sim_truth), the
// hand-eye mounting and the reference camera's mounting on the rig.
Pose DevicePipeline::tracking_start_pose(uint32_t sequence, uint64_t stamp_us) {
  const CameraStream& ref = cams_[order_[0]];
  const hal::TruthSource* truth = sim_truth(ref.index);
  Pose T_world_flange;
  const bool from_robot =
      stamp_us != 0 && flange_poses_ != nullptr &&
      runtime::robot_camera_pose(*flange_poses_, stamp_us, config_.robot_latency_us, Pose::identity(), T_world_flange);
  if (!from_robot && (truth == nullptr || !truth->flange_pose_of(sequence, T_world_flange))) {
    std::printf("tracking: no robot pose%s: the map starts at the identity\n",
                truth == nullptr && devices_.truth(ref.index) != nullptr
                    ? " (the backend's truth may stand in for it with tracking.sim_truth = true)"
                    : "");
    return Pose::identity();
  }
  const char* robot = from_robot ? "robot" : "sim robot";
  const char* mount = "";
  const Pose T = T_world_flange * flange_to_reference(&mount);
  std::printf("tracking: start pose = flange pose (%s) x hand-eye T_flange_rig (calibration) x T_rig_%s (%s): "
              "t %.4f %.4f %.4f\n",
              robot, ref.name.c_str(), mount, double(T.t.x()), double(T.t.y()), double(T.t.z()));
  std::fflush(stdout);
  return T;
}

// T_map_rig = T_map_ref * T_rig_ref^-1 with the reference's mounting from the calibration store
// (else the sim mounting, else the identity: the rig is the reference camera).
bool DevicePipeline::rig_pose(Pose& T_map_rig, uint64_t& stamp_us) const {
  if (!mapping_ || camera_count_ == 0 || !mapper_.reference().has_pose()) return false;
  const CameraStream& ref = cams_[order_[0]];
  Pose T_rig_ref = Pose::identity();
  if (const runtime::SensorPair* p = runtime::calib_find_pair(calib_, "rig", ref.name.c_str()))
    T_rig_ref = to_pose(p->T_from_to);
  else if (const hal::TruthSource* truth = sim_truth(ref.index))
    truth->mounting(T_rig_ref);
  T_map_rig = mapper_.reference().last() * T_rig_ref.inverse();
  stamp_us = mapper_.reference().stamp_us();
  return true;
}

// Another camera of the map: its frame at the reference's pose of the same instant times its
// extrinsics, weighted by its noise model.
void DevicePipeline::process_other(CameraStream& c) {
  if (!c.has_mount || !mapper_.placed()) {  // no extrinsics yet, or no map placed yet
    ++c.unpaired;
    return;
  }
  if (mapper_.map_paired(c.slot, c.held_frame(), c.T_ref_cam) != Status::kOk) {
    ++pipeline_drops_;
    return;
  }
  ++stats_.frames;
  ++c.integrated;
}

bool DevicePipeline::start_localization(uint64_t, const char** why) {
  if (mapper_.map_frames() == 0) {
    *why = "the map is empty";
    return false;
  }
  if (!localization_.submit()) {
    *why = "a localisation is running";
    return false;
  }
  return true;
}

bool DevicePipeline::poll_localization(runtime::LocalizationOutcome& out) {
  if (!localization_.finished()) return false;
  out = result_;
  localization_.collect();
  return true;
}

// The localisation job on the map, as the runtime reports it. No heap.
void DevicePipeline::run_localization() {
  const double t0 = hal::thread_cpu_ms(), process0_ms = hal::process_cpu_ms();
  const uint64_t wall0_us = hal::monotonic_clock().now_us();
  runtime::LocalizationOutcome& r = result_;
  r = runtime::LocalizationOutcome();
  r.stamp_us = mapper_.last_capture_us();
  const BoardCapacities& board = build_board();
  LocalizationRequest request;
  request.params = loc_params_;
  request.max_results = int(board.objects_max);
  request.segments = loc_.model_count() == 0;
  request.support_weight = mapper_.support_weight();
  request.viewpoint_m = mapper_.mean_viewpoint();
  LocalizationReport report;
  const std::size_t cap = std::min<std::size_t>(board.points_max, board.scene_points_max);
  if (run_localization_job(volume_, buffers_.points, cap, request, loc_, report) != Status::kOk) {
    r.failed = true;
    std::printf("localize: %s of %zu surface points refused (%s)\n", report.failed, report.surface_points,
                to_string(report.status));
    return;
  }
  // robot+icp: results in the base frame through the map's averaged placement there.
  Pose T_base_map = Pose::identity();
  if (config_.poses == CameraPoses::kRobotIcp && base_placement_.mean(T_base_map)) {
    const float deg = Eigen::AngleAxisf(T_base_map.R).angle() * 57.29578f;
    std::printf("localize: map placed in the robot's base frame by %u frames (robot pose x ICP pose^-1 averaged): "
                "%.3f mm, %.4f deg from the first frame's\n",
                unsigned(base_placement_.frames), double(T_base_map.t.norm()) * 1e3, double(deg));
  }
  const LocalizedObject* o = loc_.results();
  for (std::size_t i = 0; i < report.count; ++i) {
    // id: 1 + the model's index in `model list` (0: a model-free segment); in picking order.
    runtime::ObjectResult obj;
    obj.id = o[i].model >= 0 ? uint32_t(o[i].model + 1) : 0u;
    obj.T_world_object = T_base_map * o[i].T_world_object;
    obj.score = o[i].score;
    obj.grasp_m = T_base_map * o[i].grasp_m;
    obj.approach = T_base_map.R * o[i].approach;
    if (!r.add(obj)) break;
    const Eigen::Quaternionf q = obj.T_world_object.quaternion();
    const Vec3f& t = obj.T_world_object.t;
    std::printf("localize: %zu %s t %.4f %.4f %.4f q %.5f %.5f %.5f %.5f score %.3f\n", i + 1,
                request.segments ? "segment" : loc_.model(o[i].model).name, double(t.x()), double(t.y()),
                double(t.z()), double(q.x()), double(q.y()), double(q.z()), double(q.w()), double(o[i].score));
  }
  last_localize_cpu_ms_ = hal::thread_cpu_ms() - t0;
  // Wall time, this thread's CPU and the process's (this thread, the pool's workers and whatever
  // the main loop and the acquisition threads ran meanwhile): the CPU tells the work from the
  // waiting on a loaded machine.
  const double wall_ms = double(hal::monotonic_clock().now_us() - wall0_us) * 1e-3;
  std::printf("localize: %zu frames in the map, surface %zu points, floor %s, %zu %s, %.0f ms wall on %d threads, "
              "%.0f ms CPU on this thread, %.0f ms CPU\n",
              size_t(mapper_.map_frames()), report.surface_points, loc_.context().has_floor ? "found" : "not found",
              report.count, request.segments ? "segments" : "objects", wall_ms, threads_, last_localize_cpu_ms_,
              hal::process_cpu_ms() - process0_ms);
  std::printf("localize: space %u of %u bricks in use%s\n", volume_.bricks_in_use(), volume_.pool_bricks() - 1u,
              volume_.bricks_refused() > 0 ? "; the pool is full: bricks refused, the map stopped growing" : "");
  if (tracked() && sim_truth(cams_[order_[0]].index) != nullptr)
    std::printf("localize: tracking: %u lost frames, last pose %.2f mm from the backend's truth\n",
                unsigned(lost_frames_), double(track_err_m_) * 1e3);
  else if (tracked())
    std::printf("localize: tracking: %u lost frames\n", unsigned(lost_frames_));
  if (robot_poses())
    std::printf("localize: %u frames skipped without a robot pose at their stamp\n", unsigned(robot_pose_missing_));
  std::fflush(stdout);
}

}  // namespace edgefuse::firmware
