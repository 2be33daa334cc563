#include "fusion_pipeline.hpp"

#include <dirent.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <vector>

#include "board_defaults.hpp"
#include "edgefuse/board_config.hpp"
#include "edgefuse/io/board_hal.hpp"
#include "edgefuse/io/rig.hpp"
#include "edgefuse/link/messages.hpp"
#include "edgefuse/fusion/fusion_rules.hpp"
#include "edgefuse/tsdf/extract.hpp"
#include "edgefuse/tsdf/integrate_profile.hpp"
#include "edgefuse/hal/platform/clock/monotonic_clock.hpp"
#include "localize_io.hpp"
#include "edgefuse/hal/platform/threads/parallel_tsdf.hpp"
#include "edgefuse/tracking/pyramid.hpp"

namespace edgefuse::wire {

namespace {

constexpr int kPixels = kBuildBoard.image_width_max * kBuildBoard.image_height_max;
// The filters' intermediate image lives in .bss (static memory, no heap); the frames live in the
// cameras' pools (camera_stream.cpp) and the filtered images in the board's per-sensor buffers.
uint16_t g_filter_scratch[kPixels];

// The rig counts as still while its pose stays within this of the pose where the still period
// began: well below the 1 cm / 1 degree push threshold of tracking, above the noise of a tracked pose.
constexpr float kStillMoveM = 0.001f;
constexpr float kStillRotDeg = 0.1f;

double thread_cpu_ms() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return double(ts.tv_sec) * 1e3 + double(ts.tv_nsec) * 1e-6;
}

bool is_dir(const std::string& p) {
  struct stat st;
  return stat(p.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

Pose to_pose(const runtime::CalibPose& p) {
  return Pose::from_tq(p.tq[0], p.tq[1], p.tq[2], p.tq[3], p.tq[4], p.tq[5], p.tq[6]);
}

}  // namespace

bool FusionPipeline::init(const FusionPipelineConfig& config, std::string& err) {
  config_ = config;
  const BoardCapacities* board = find_board(config.board.c_str());
  if (board == nullptr) {
    err = "unknown board " + config.board;
    return false;
  }
  if (std::strcmp(board->name, build_board().name) != 0) {
    err = "board " + config.board + ": this build's static memory is sized for board " + build_board().name +
          " (build that board's preset, or run pipeline.source=simulated)";
    return false;
  }
  // Devices from the board's hal.toml (sensors.replay: every camera replays the rig set instead).
  const std::string hal_path = std::string(kBoardSourceDir) + "/" + config.board + "/hal.toml";
  io::BoardHal hal_data;
  if (!io::read_board_hal(hal_path, hal_data, err)) return false;
  // A replayed recording is one scan: it ends after its last frame (each frame integrated once) and
  // the rig then counts as still (the still-period trigger localises).
  if (!devices_.build(hal_data, hal::monotonic_clock(), err, config.replay, false, config.replay_speed)) {
    err = hal_path + ": " + err;
    return false;
  }
  if (devices_.camera_count() == 0) {
    err = hal_path + " lists no [[camera]]";
    return false;
  }
  if (devices_.camera_count() > kCamerasMax || devices_.camera_count() > board->sensors_max) {
    err = hal_path + ": " + std::to_string(devices_.camera_count()) + " cameras, board " + board->name +
          " has buffers for " + std::to_string(std::min(kCamerasMax, int(board->sensors_max)));
    return false;
  }
  camera_count_ = devices_.camera_count();
  std::string names;
  for (int i = 0; i < camera_count_; ++i) {
    CameraStream& c = cams_[i];
    hal::FaultCamera& cam = devices_.camera(i);
    hal::DepthMode mode;
    if (!cam.mode(0, mode)) {
      err = std::string("camera '") + cam.name() + "' offers no mode";
      return false;
    }
    c.name = devices_.camera_config(i).name;
    c.index = i;
    c.intr = cam.intrinsics();
    c.tof = mode.amplitude;
    names += (i ? ", " : "") + c.name;
  }
  // sensors.fuse: the cameras that feed the map, the first is the reference.
  fuse_count_ = 0;
  std::string list = config.fuse.empty() ? cams_[0].name : config.fuse;
  for (std::size_t pos = 0; pos <= list.size();) {
    const std::size_t comma = std::min(list.find(',', pos), list.size());
    const std::string n = list.substr(pos, comma - pos);
    pos = comma + 1;
    int found = -1;
    for (int i = 0; i < camera_count_; ++i)
      if (cams_[i].name == n) found = i;
    if (found < 0 && devices_.scanner() != nullptr && n == devices_.scanner()->name()) {
      if (fuse_count_ == 0) {
        err = "sensors.fuse = '" + config.fuse + "': the first sensor is the reference and must be a camera";
        return false;
      }
      scanner_.fuse = true;
      continue;
    }
    if (found < 0) {
      err = "sensors.fuse = '" + config.fuse + "': '" + n + "' is not a sensor of " + hal_path + " (" + names +
            (devices_.scanner() != nullptr ? std::string(", ") + devices_.scanner()->name() : std::string()) + ")";
      return false;
    }
    if (cams_[found].fuse) {
      err = "sensors.fuse = '" + config.fuse + "': '" + n + "' is listed twice";
      return false;
    }
    cams_[found].fuse = true;
    order_[fuse_count_++] = found;
  }
  CameraStream& ref = cams_[order_[0]];
  intr_ = ref.intr;
  if (config.auto_poses) {
    Pose first;
    config_.tracked = !devices_.known_pose(ref.index, 0, first);
  }

  // Static buffers: the arena carve of the host tools, the volume bound to the board's capacity.
  cli::BoardDefaults defaults;
  if (!cli::read_board_defaults(config.board, defaults, err)) return false;
  if (!core_.init(*board, intr_, err)) {
    err = "camera '" + ref.name + "': " + err;
    return false;
  }
  fuse_.voxel_m = config.voxel_m;
  fuse_.trunc_m = config.trunc_m;
  fuse_.max_weight = defaults.max_weight;
  fuse_.threads = defaults.threads;
  fuse_.dim = board->volume_dim;
  if (!core_.make_volume(fuse_, err)) return false;
  // Each camera: its slot of the per-sensor buffers, its filters, its frame pool and its thread.
  for (int i = 0; i < camera_count_; ++i) {
    CameraStream& c = cams_[i];
    if (!c.bind(core_.buffers, *board, config.bilateral, err)) return false;
    c.worker.reset(new hal::CameraWorker(devices_.camera(i), c.channel, c.counters, hal::monotonic_clock(),
                                         &devices_.monitor()));
  }
  // The line scanner: the slot after the cameras', its own thread and pool.
  if (devices_.scanner() != nullptr) {
    scanner_.name = devices_.scanner()->name();
    if (!scanner_.bind(*devices_.scanner(), core_.buffers, *board, camera_count_, err)) {
      if (scanner_.fuse) return false;
      std::printf("line scanner %s not streamed: %s\n", scanner_.name.c_str(), err.c_str());
      scanner_.name.clear();
      err.clear();
    } else {
      scanner_.has_axis = devices_.scanner_axis(scanner_.T_world_axis0, scanner_.axis_world);
      if (scanner_.fuse && !scanner_.has_axis) {
        err = "sensors.fuse: line_scanner '" + scanner_.name + "': its backend reports no axis to place profiles";
        return false;
      }
    }
  }
  // Several sensors in one map: each pixel weighted by its sensor's noise (as edgefuse fuse --sensors).
  use_trust_ = fuse_count_ > 1 || scanner_.fuse;
  if (use_trust_ && ref.trust.data == nullptr) {
    err = std::string("board ") + board->name + " has no trust maps in its memory map (needed to fuse several sensors)";
    return false;
  }
  if (!config.replay.empty() && access((config.replay + "/extrinsics.txt").c_str(), R_OK) == 0 &&
      !io::read_extrinsics_txt(config.replay + "/extrinsics.txt", rig_extrinsics_, err))
    return false;
  update_mounts();

  // Models: the configured file/folder, else the replayed rig set's (rig.toml [[object]] models).
  if (loc_.init(core_.buffers.localize) != Status::kOk) {
    err = std::string("board ") + board->name + " has no localisation buffers in its memory map";
    return false;
  }
  loc_params_.min_score = config.min_score;
  loc_params_.max_per_model = board->objects_max;
  std::vector<std::string> files;
  if (!config.models.empty()) {
    if (!cli::model_files(config.models, files, err)) {
      err = "localize.models: " + err;
      return false;
    }
  } else if (!config.replay.empty() && is_dir(config.replay) &&
             access((config.replay + "/rig.toml").c_str(), R_OK) == 0) {
    io::RigToml rig;
    if (!io::read_rig_toml(config.replay + "/rig.toml", rig, err)) return false;
    for (const io::RigObject& o : rig.objects)
      if (std::find(files.begin(), files.end(), o.model_path) == files.end()) files.push_back(o.model_path);
  }
  for (const std::string& f : files) {
    int index = -1;
    if (!cli::load_model(loc_, f, loc_params_, index, err)) {
      err = "model " + f + ": " + err;
      return false;
    }
    const ModelInfo& mi = loc_.model(index);
    std::printf("model %d: %s (%s), diameter %.1f mm, %u PPF samples\n", index + 1, mi.name, f.c_str(),
                mi.diameter_m * 1e3, mi.ppf_count);
  }
  if (files.empty()) std::printf("models: none (localize reports model-free segments, id 0)\n");

  std::printf("pipeline: camera %s (%s%s), %dx%d, filters %s%s, volume %d^3 x %.1f mm, poses: %s, %d thread(s)\n",
              ref.name.c_str(), config.replay.empty() ? "hal.toml backend" : "replay of ", config.replay.c_str(),
              intr_.width, intr_.height, ref.tof ? "tof" : "structured-light", config.bilateral ? "+bilateral" : "",
              fuse_.dim, fuse_.voxel_m * 1e3,
              config_.tracked ? (config.push_every_frame ? "tracked (ICP against the raycast model, every frame pushed)"
                                                        : "tracked (ICP against the raycast model, push after 1 cm / 1 deg)")
                             : "known (the backend's truth)",
              fuse_.threads);
  std::string fused;
  for (int k = 0; k < fuse_count_; ++k) fused += (k ? "," : "") + cams_[order_[k]].name;
  if (scanner_.fuse) fused += "," + scanner_.name;
  if (!scanner_.name.empty()) names += ", " + scanner_.name;
  std::printf("sensors: %s stream (one acquisition thread each); map: %s%s\n", names.c_str(), fused.c_str(),
              use_trust_ ? " (weights from each sensor's noise model)" : "");
  pool_.start(fuse_.threads);
  thread_ = std::thread([this] { localize_thread(); });
  return true;
}

// Extrinsics of every camera in the reference camera's frame, best source first.
void FusionPipeline::update_mounts() {
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
    if (source == nullptr && devices_.sim_mounting(ref.index, T_rig_ref) && devices_.sim_mounting(c.index, T_rig_cam)) {
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

void FusionPipeline::calibration_changed(const runtime::CalibrationData& d) {
  calib_ = d;
  if (camera_count_ > 0) update_mounts();
}

void FusionPipeline::shutdown() {
  if (thread_.joinable()) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      quit_ = true;
    }
    wake_.notify_all();
    thread_.join();
  }
  pool_.stop();
  for (int i = 0; i < camera_count_; ++i)
    if (cams_[i].worker) cams_[i].worker->stop();
  if (scanner_.worker) scanner_.worker->stop();
  camera_running_ = false;
}

const char* FusionPipeline::device_name(int i) const {
  return i < camera_count_ ? cams_[i].name.c_str() : scanner_.name.c_str();
}

const char* FusionPipeline::device_state(int i) const {
  return i < camera_count_ ? cams_[i].status_text() : scanner_.status_text();
}

bool FusionPipeline::start_mapping(const char** why) {
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
  return true;
}

void FusionPipeline::stop_mapping() {
  mapping_ = false;
  // The threads stop; each camera's held frame stays valid (calib fuse may still use it).
  for (int i = 0; i < camera_count_; ++i) cams_[i].worker->stop();
  if (scanner_.worker) scanner_.worker->stop();
  camera_running_ = false;
  have_still_anchor_ = false;
  stats_.fps = 0;
  stats_.still_since_us = 0;
  stats_.tracking = edgefuse_link_TrackingState_TRACKING_OFF;
}

void FusionPipeline::reset_map() {
  if (localizing_) return;  // the localiser reads the volume; the runtime refuses this anyway
  map_frames_ = 0;
  clear_pending_ = true;
  have_ref_pose_ = false;
  have_prev_ref_pose_ = false;
  view_sum_ = Vec3f::Zero();
}

void FusionPipeline::step(uint64_t now_us) {
  if (!mapping_ || !camera_running_) return;
  // Newest-frame policy for the reference camera; the others are paired with its frames below.
  CameraStream& ref = cams_[order_[0]];
  ref.take_newest();
  if (localizing_) {
    update_drops();
    return;  // the volume belongs to the localiser now; the held frames wait
  }
  const hal::DeviceState st = ref.counters.device_state();
  if (ref.held_new) {
    ref.held_new = false;
    process_reference(now_us);
    drain_profiles();  // between the cameras too: the profile pool holds 150 ms at 100 Hz
  } else if (st == hal::DeviceState::kEnded) {
    stats_.fps = 0;
    if (stats_.still_since_us == 0) stats_.still_since_us = now_us;
  } else if (st != hal::DeviceState::kStreaming) {
    // Stalled, reopening or unplugged: tracking pauses, the map is kept; it resumes with the frames.
    stats_.fps = 0;
    stats_.tracking = edgefuse_link_TrackingState_TRACKING_OFF;
    have_still_anchor_ = false;
    stats_.still_since_us = 0;
  }
  // Every other camera: the frame nearest in time to the reference's last frame (until one within
  // the pairing window is found); integrated at the reference's pose when it feeds the map, else
  // kept for calib fuse. Frames that find no partner are counted as unpaired.
  for (int i = 0; i < camera_count_; ++i) {
    CameraStream& c = cams_[i];
    if (&c == &ref || !have_ref_pose_ || c.paired_stamp_us == ref_stamp_us_) continue;
    c.take_nearest(ref_stamp_us_);
    if (c.held == nullptr) continue;
    const uint64_t s = c.held->stamp_us;
    if ((s > ref_stamp_us_ ? s - ref_stamp_us_ : ref_stamp_us_ - s) > kPairWindowUs) continue;
    c.paired_stamp_us = ref_stamp_us_;
    if (c.fuse && c.held_new) {
      process_other(c);
      drain_profiles();
    }
    c.held_new = false;
  }
  drain_profiles();
  update_drops();
}

Pose FusionPipeline::reference_pose_at(uint64_t stamp_us) const {
  if (!have_prev_ref_pose_) return ref_pose_;
  const double gap_us = double(ref_stamp_us_ - prev_ref_stamp_us_), window_us = double(kPairWindowUs);
  const double since_us = std::clamp(double(stamp_us) - double(ref_stamp_us_), -gap_us - window_us, window_us);
  return interpolate(prev_ref_pose_, ref_pose_, float(1.0 + since_us / gap_us));
}

// The line scanner: every profile, in order (each is one slice of the scan).
void FusionPipeline::drain_profiles() {
  if (scanner_.worker) scanner_.channel.drain([this](const hal::LineProfile& p) { process_profile(p); });
}

void FusionPipeline::process_profile(const hal::LineProfile& p) {
  if (!scanner_.fuse) return;
  Pose T;
  if (clear_pending_ || !scanner_.pose_of(p, T)) {  // no map placed yet, or no axis position
    ++scanner_.skipped;
    return;
  }
  // The laser's noise (20 um, constant) against the trust reference, as edgefuse fuse --sensors.
  // Not capped at one camera sample (kProfileTrustMax), as in edgefuse fuse --sensors: the 20 um
  // scanner must be able to outweigh an average of many coarser camera samples on its strip.
  const float trust = NoiseModel::constant(20e-6f).trust(0.5f * fuse_.voxel_m, 0.0f, 0.0f, kProfileTrustMax);
  if (integrate_profile<real_t>(core_.volume, scanner_.model, scanner_.tables, p.ranges_m, T, 0.0f, trust) !=
      Status::kOk) {
    ++pipeline_drops_;
    return;
  }
  ++scanner_.integrated;
}

void FusionPipeline::update_drops() {
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

void FusionPipeline::process_reference(uint64_t now_us) {
  CameraStream& ref = cams_[order_[0]];
  const hal::DepthFrame& frame = *ref.held;
  const bool had_ref_pose = have_ref_pose_;  // ref_pose_ is the previous frame's, valid (this frame may clear it)
  if (last_frame_us_ != 0 && now_us > last_frame_us_) {
    const float inst = 1e6f / float(now_us - last_frame_us_);
    stats_.fps = stats_.fps <= 0 ? inst : 0.9f * stats_.fps + 0.1f * inst;
  }
  last_frame_us_ = now_us;
  if (!ref.filter_held(ImageView<uint16_t>(g_filter_scratch, frame.width, frame.height))) {
    ++pipeline_drops_;
    return;
  }
  ++stats_.frames;
  DepthFrame f;
  f.depth = ImageView<const uint16_t>(ref.filtered.data, frame.width, frame.height);
  if (frame.has_colour) f.colour = frame.colour_view();
  if (use_trust_) {
    float sigma_m = 0.0f;
    if (build_trust_map(ref.noise, 0.5f * fuse_.voxel_m, f.depth, intr_.depth_scale, frame.amplitude_view(),
                        ref.trust, 0.0f, &sigma_m) != Status::kOk) {
      ++pipeline_drops_;
      return;
    }
    f.trust = ref.trust;
    apply_noise_rules(ref, f, sigma_m);
  }

  Pose T;
  const bool known = devices_.known_pose(ref.index, frame.sequence, T);
  bool push = true;
  if (config_.tracked) {
    // The paper's loop (Fig. 3): ICP of the frame against the model raycast at the last good pose;
    // pushed when it moved 1 cm / 1 degree. A new map starts at the pose the robot's flange and
    // the calibrated hand-eye mounting give (tracking_start_pose).
    const bool first = clear_pending_ || map_frames_ == 0;
    TrackerParams tp;
    tp.push.every_frame = config_.push_every_frame;
    const Pose start = first ? tracking_start_pose(frame.sequence) : Pose::identity();
    if (first && tracker_.start(start, tp, true) != Status::kOk) {
      ++pipeline_drops_;
      return;
    }
    if (first && clear_pending_) centre_volume(f, start);
    Status s = Status::kOk;
    if (!first) s = raycast_parallel<real_t>(pool_, core_.volume, intr_, tracker_.raycast_pose(), ref.maps);
    TrackResult r;
    if (s == Status::kOk) s = build_pyramid<real_t>(f.depth, PyramidParams(), ref.pyramid);
    if (s == Status::kOk) s = tracker_.track<real_t>(ref.pyramid, ref.maps, intr_, ref.icp_ws, r, nullptr);
    if (s != Status::kOk) {
      ++pipeline_drops_;
      return;
    }
    stats_.tracking = r.state == TrackState::kOk         ? edgefuse_link_TrackingState_TRACKING_OK
                      : r.state == TrackState::kDegraded ? edgefuse_link_TrackingState_TRACKING_DEGRADED
                                                         : edgefuse_link_TrackingState_TRACKING_LOST;
    if (r.state == TrackState::kLost) ++lost_frames_;
    push = r.push;
    if (known) track_err_m_ = (r.T_world_cam.t - T.t).norm();  // against the backend's truth
    T = r.T_world_cam;
    have_ref_pose_ = r.state != TrackState::kLost;
  } else {
    if (!known) {
      // No truth for this frame (a real device, or a recording without ground truth) and tracking
      // is off (tracking.poses = known): the frame cannot be placed and is not integrated.
      stats_.tracking = edgefuse_link_TrackingState_TRACKING_LOST;
      ++pipeline_drops_;
      have_ref_pose_ = false;
      if (!warned_no_pose_) {
        std::printf("pipeline: camera %s gives no known pose (set tracking.poses = tracked): frames are not integrated\n",
                    ref.name.c_str());
        warned_no_pose_ = true;
      }
      return;
    }
    stats_.tracking = edgefuse_link_TrackingState_TRACKING_OK;
    have_ref_pose_ = true;
  }
  have_prev_ref_pose_ = had_ref_pose && have_ref_pose_ && frame.stamp_us >= ref_stamp_us_ + kPoseVelocityGapMinUs &&
                        frame.stamp_us - ref_stamp_us_ <= kPoseVelocityGapMaxUs;
  prev_ref_pose_ = ref_pose_;
  prev_ref_stamp_us_ = ref_stamp_us_;
  ref_pose_ = T;
  ref_stamp_us_ = frame.stamp_us;
  // Still detection against an anchor pose, not the previous frame: a slow motion moves little
  // per frame when frames come fast, so a per-frame test would call a swaying rig still on an idle
  // machine and moving on a loaded one. The anchor moves on when the rig leaves its tolerance.
  if (have_still_anchor_) {
    const float moved_m = (T.t - still_anchor_.t).norm();
    const float cos_angle = std::clamp(0.5f * ((still_anchor_.R.transpose() * T.R).trace() - 1.0f), -1.0f, 1.0f);
    const float rot_deg = std::acos(cos_angle) * 57.29578f;
    if (moved_m > kStillMoveM || rot_deg > kStillRotDeg) {
      stats_.still_since_us = 0;
      still_anchor_ = T;
    } else if (stats_.still_since_us == 0) {
      stats_.still_since_us = now_us;
    }
  } else {
    have_still_anchor_ = true;
    still_anchor_ = T;
  }
  if (!push) return;

  if (clear_pending_) centre_volume(f, T);
  const Status s = integrate_parallel<real_t>(pool_, core_.volume, intr_, ref.ray_norms, f, T, ref.scratch);
  if (s != Status::kOk) {
    ++pipeline_drops_;
    return;
  }
  ++ref.integrated;
  ++map_frames_;
  view_sum_ += T.t;
  last_capture_us_ = frame.stamp_us;
}

// T_world_ref = T_world_flange * T_flange_rig * T_rig_ref: the robot's flange pose (where a robot
// pose is available), the hand-eye mounting and the reference camera's mounting on the rig.
Pose FusionPipeline::tracking_start_pose(uint32_t sequence) {
  const CameraStream& ref = cams_[order_[0]];
  Pose T_world_flange;
  if (!devices_.flange_pose(ref.index, sequence, T_world_flange)) {
    std::printf("tracking: no robot pose: the map starts at the identity\n");
    return Pose::identity();
  }
  Pose T_rig_ref = Pose::identity();
  const char* mount = "identity";
  if (const runtime::SensorPair* p = runtime::calib_find_pair(calib_, "rig", ref.name.c_str())) {
    T_rig_ref = to_pose(p->T_from_to);
    mount = "calibration store";
  } else if (devices_.sim_mounting(ref.index, T_rig_ref)) {
    mount = "sim mounting";
  }
  const Pose T = T_world_flange * to_pose(calib_.T_flange_rig) * T_rig_ref;
  std::printf("tracking: start pose = flange pose (robot) x hand-eye T_flange_rig (calibration) x T_rig_%s (%s): "
              "t %.4f %.4f %.4f\n",
              ref.name.c_str(), mount, double(T.t.x()), double(T.t.y()), double(T.t.z()));
  std::fflush(stdout);
  return T;
}

// Another camera of the map: its frame at the reference's pose of the same instant times its
// extrinsics, weighted by its noise model.
void FusionPipeline::process_other(CameraStream& c) {
  if (!c.has_mount || clear_pending_) {  // no extrinsics yet, or no map placed yet
    ++c.unpaired;
    return;
  }
  const hal::DepthFrame& frame = *c.held;
  if (!c.filter_held(ImageView<uint16_t>(g_filter_scratch, frame.width, frame.height))) {
    ++pipeline_drops_;
    return;
  }
  DepthFrame f;
  f.depth = ImageView<const uint16_t>(c.filtered.data, frame.width, frame.height);
  float sigma_m = 0.0f;
  if (build_trust_map(c.noise, 0.5f * fuse_.voxel_m, f.depth, c.intr.depth_scale, frame.amplitude_view(), c.trust, 0.0f,
                      &sigma_m) != Status::kOk) {
    ++pipeline_drops_;
    return;
  }
  f.trust = c.trust;
  apply_noise_rules(c, f, sigma_m);
  const Pose T = reference_pose_at(frame.stamp_us) * c.T_ref_cam;
  if (integrate_parallel<real_t>(pool_, core_.volume, c.intr, c.ray_norms, f, T, c.scratch) != Status::kOk) {
    ++pipeline_drops_;
    return;
  }
  ++stats_.frames;
  ++c.integrated;
  ++map_frames_;
  view_sum_ += T.t;
}

// The noise rules of `edgefuse fuse --sensors` (fusion_rules.hpp), shared code: the depth-jump
// limit follows the frame's median modelled noise (from its trust map); the median is also kept per
// camera for the set's sub-unit fill and the support rule of extraction (map_support_weight()).
void FusionPipeline::apply_noise_rules(CameraStream& c, DepthFrame& f, float sigma_m) {
  c.sigma.add(sigma_m);
  f.jump_m = noise_jump_m(sigma_m, kJumpSigmas);
  // Round 5b (fusion_rules.hpp rule 3): in a mixed set sub-unit samples fill a voxel only up to 3
  // units. Decided from the medians so far, this frame's included, so a sub-unit camera's frames all
  // take it (the reference camera's frames before the first of them keep 8: its own sub-unit pixels).
  f.sub_unit_fill_units = map_sub_unit_fill();
}

void FusionPipeline::fused_median_sigmas(float (&sigma)[kCamerasMax]) const {
  for (int k = 0; k < kCamerasMax; ++k) sigma[k] = k < fuse_count_ ? cams_[order_[k]].median_sigma() : 0.0f;
}

int FusionPipeline::map_sub_unit_fill() const {
  float sigma[kCamerasMax];
  fused_median_sigmas(sigma);
  return default_sub_unit_fill(sigma, fuse_count_, 0.5f * fuse_.voxel_m);
}

uint8_t FusionPipeline::map_support_weight() const {
  if (!use_trust_) return 0;  // one camera, equal weights: every observed crossing, as before
  float sigma[kCamerasMax];
  fused_median_sigmas(sigma);
  return default_support_weight(sigma, fuse_count_, 0.5f * fuse_.voxel_m, map_sub_unit_fill());
}

// A new map is centred on the median of what its first frame sees (the bin), as `edgefuse fuse`
// and `localize` centre theirs, so the board's volume covers the work space wherever the rig stands.
// No heap: every 2nd pixel into static arrays, nth_element in place.
void FusionPipeline::centre_volume(const DepthFrame& f, const Pose& T_world_cam) {
  static float xs[kPixels / 4 + 1], ys[kPixels / 4 + 1], zs[kPixels / 4 + 1];
  std::size_t n = 0;
  for (int v = 0; v < intr_.height; v += 2)
    for (int u = 0; u < intr_.width; u += 2) {
      const uint16_t raw = f.depth.at(u, v);
      const float z = float(raw) / intr_.depth_scale;
      if (raw == 0 || z < intr_.min_range_m || z > intr_.max_range_m || n >= kPixels / 4 + 1) continue;
      const Vec3f p = T_world_cam * intr_.back_project(float(u), float(v), z);
      xs[n] = p.x();
      ys[n] = p.y();
      zs[n] = p.z();
      ++n;
    }
  if (n == 0) return;  // nothing seen: stay pending, the next frame centres
  auto median = [n](float* v) {
    std::nth_element(v, v + n / 2, v + n);
    return v[n / 2];
  };
  const Vec3f centre(median(xs), median(ys), median(zs));
  core_.volume.set_origin(centre - Vec3f::Constant(0.5f * float(fuse_.dim) * fuse_.voxel_m));
  core_.volume.clear();
  clear_pending_ = false;
  std::printf("map: volume origin %.3f %.3f %.3f m (centred on the first frame's view)\n",
              double(core_.volume.origin_m().x()), double(core_.volume.origin_m().y()),
              double(core_.volume.origin_m().z()));
  std::fflush(stdout);
}

bool FusionPipeline::start_localization(uint64_t, const char** why) {
  if (map_frames_ == 0) {
    *why = "the map is empty";
    return false;
  }
  if (localizing_) {
    *why = "a localisation is running";
    return false;
  }
  done_ = false;
  localizing_ = true;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    request_ = true;
  }
  wake_.notify_one();
  return true;
}

bool FusionPipeline::poll_localization(link::LocalizationResult& out) {
  if (!localizing_ || !done_) return false;
  out = result_;
  localizing_ = false;
  return true;
}

void FusionPipeline::localize_thread() {
  for (;;) {
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [this] { return quit_ || request_; });
      if (quit_) return;
      request_ = false;
    }
    run_localization();
    done_ = true;
  }
}

// Extraction -> scene -> bin removal -> poses (or segments) -> the link's result. No heap.
void FusionPipeline::run_localization() {
  const double t0 = thread_cpu_ms();
  link::LocalizationResult& r = result_;
  r = link::LocalizationResult();
  r.stamp_us = last_capture_us_;
  r.status = edgefuse_link_ResultStatus_RESULT_OK;
  const BoardCapacities& board = build_board();
  std::size_t surface = 0;
  const std::size_t cap = std::min<std::size_t>(board.points_max, board.scene_points_max);
  const Status xs = extract_points(core_.volume, core_.buffers.points, cap, surface, map_support_weight());
  SceneContext ctx;
  ctx.viewpoint_m = map_frames_ > 0 ? Vec3f(view_sum_ / float(map_frames_)) : Vec3f::Zero();
  // Grid cell 3.5 voxels: as edgefuse localize (measured fastest on bin_rig_a, same poses).
  const Status ss = loc_.set_scene(core_.buffers.points, surface, ctx, &core_.volume, 3.5f * fuse_.voxel_m);
  if ((xs != Status::kOk && xs != Status::kOutputTruncated) || (ss != Status::kOk && ss != Status::kOutputTruncated)) {
    r.status = edgefuse_link_ResultStatus_RESULT_FAILED;
    std::printf("localize: scene of %zu points refused (%s)\n", surface, to_string(ss));
    return;
  }
  loc_.remove_bin(loc_params_);
  std::size_t count = 0;
  const bool models = loc_.model_count() > 0;
  const Status ls = models ? loc_.localize(loc_params_, int(board.objects_max), count)
                           : loc_.segment(loc_params_, int(board.objects_max), count);
  if (ls != Status::kOk) {
    r.status = edgefuse_link_ResultStatus_RESULT_FAILED;
    std::printf("localize: %s\n", to_string(ls));
    return;
  }
  const LocalizedObject* o = loc_.results();
  for (std::size_t i = 0; i < count; ++i) {
    // id: 1 + the model's index in `model list` (0: a model-free segment); in picking order.
    const uint32_t id = o[i].model >= 0 ? uint32_t(o[i].model + 1) : 0u;
    if (!link::add_object(r, id, o[i].T_world_object, o[i].score, o[i].grasp_m, o[i].approach)) break;
    const Eigen::Quaternionf q = o[i].T_world_object.quaternion();
    const Vec3f& t = o[i].T_world_object.t;
    std::printf("localize: %zu %s t %.4f %.4f %.4f q %.5f %.5f %.5f %.5f score %.3f\n", i + 1,
                models ? loc_.model(o[i].model).name : "segment", double(t.x()), double(t.y()), double(t.z()),
                double(q.x()), double(q.y()), double(q.z()), double(q.w()), double(o[i].score));
  }
  last_localize_cpu_ms_ = thread_cpu_ms() - t0;
  std::printf("localize: %zu frames in the map, surface %zu points, floor %s, %zu %s, %.0f ms CPU\n",
              size_t(map_frames_), surface, loc_.context().has_floor ? "found" : "not found", count,
              models ? "objects" : "segments", last_localize_cpu_ms_);
  if (config_.tracked)
    std::printf("localize: tracking: %u lost frames, last pose %.2f mm from the backend's truth\n",
                unsigned(lost_frames_), double(track_err_m_) * 1e3);
  std::fflush(stdout);
}

}  // namespace edgefuse::wire
