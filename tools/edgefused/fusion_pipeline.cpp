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
#include "edgefuse/tsdf/extract.hpp"
#include "hal/posix/monotonic_clock.hpp"
#include "localize_io.hpp"
#include "parallel_tsdf.hpp"
#include "edgefuse/tracking/pyramid.hpp"

namespace edgefuse::wire {

namespace {

constexpr int kPixels = kBuildBoard.image_width_max * kBuildBoard.image_height_max;
// The incoming frame and the filter's two images live in .bss (static memory, no heap).
hal::DepthFrameStorage<kPixels> g_frame;
uint16_t g_filter_scratch[kPixels];
uint16_t g_filtered[kPixels];

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

// The model files of `spec`: a PLY file, or every *.ply of a folder (sorted: a stable id order).
bool model_files(const std::string& spec, std::vector<std::string>& out, std::string& err) {
  if (!is_dir(spec)) {
    out.push_back(spec);
    return true;
  }
  DIR* d = opendir(spec.c_str());
  if (d == nullptr) {
    err = spec + ": cannot read the folder";
    return false;
  }
  std::vector<std::string> names;
  while (dirent* e = readdir(d)) {
    const std::string n = e->d_name;
    if (n.size() > 4 && n.compare(n.size() - 4, 4, ".ply") == 0) names.push_back(spec + "/" + n);
  }
  closedir(d);
  std::sort(names.begin(), names.end());
  if (names.empty()) {
    err = spec + ": no .ply model in the folder";
    return false;
  }
  out.insert(out.end(), names.begin(), names.end());
  return true;
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
  if (!devices_.build(hal_data, hal::monotonic_clock(), err, config.replay, false)) {
    err = hal_path + ": " + err;
    return false;
  }
  if (devices_.camera_count() == 0) {
    err = hal_path + " lists no [[camera]]";
    return false;
  }
  hal::FaultCamera& cam = devices_.camera(0);
  hal::DepthMode mode;
  if (!cam.mode(0, mode)) {
    err = std::string("camera '") + cam.name() + "' offers no mode";
    return false;
  }
  intr_ = cam.intrinsics();
  frame_ = g_frame.frame();

  // Static buffers: the arena carve of the host tools, the volume bound to the board's capacity.
  cli::BoardDefaults defaults;
  if (!cli::read_board_defaults(config.board, defaults, err)) return false;
  if (!core_.init(*board, intr_, err)) {
    err = std::string("camera '") + cam.name() + "': " + err;
    return false;
  }
  fuse_.voxel_m = config.voxel_m;
  fuse_.trunc_m = config.trunc_m;
  fuse_.max_weight = defaults.max_weight;
  fuse_.threads = defaults.threads;
  fuse_.dim = board->volume_dim;
  if (!core_.make_volume(fuse_, err)) return false;

  // Tracking buffers of sensor slot 0 (board capacities).
  if (core_.buffers.pyramid<real_t>(0, intr_, pyramid_) != Status::kOk) {
    err = std::string("camera '") + cam.name() + "': the frame pyramid does not fit the board's buffers";
    return false;
  }
  icp_ws_ = core_.buffers.icp_workspace<real_t>(0);

  // Filters of the sensor kind (an amplitude image means time of flight).
  filters_ = DepthFilterChain<real_t>::defaults_for(
      intr_, mode.amplitude ? DepthSensorKind::kTimeOfFlight : DepthSensorKind::kStructuredLight);
  filters_.bilateral_enabled = config.bilateral;
  if (filters_.prepare(intr_) != Status::kOk) {
    err = std::string("camera '") + cam.name() + "': the depth filters refuse its intrinsics";
    return false;
  }

  // Models: the configured file/folder, else the replayed rig set's (rig.toml [[object]] models).
  if (loc_.init(core_.buffers.localize) != Status::kOk) {
    err = std::string("board ") + board->name + " has no localisation buffers in its memory map";
    return false;
  }
  loc_params_.min_score = config.min_score;
  loc_params_.max_per_model = board->objects_max;
  std::vector<std::string> files;
  if (!config.models.empty()) {
    if (!model_files(config.models, files, err)) {
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
              cam.name(), config.replay.empty() ? "hal.toml backend" : "replay of ",
              config.replay.c_str(), intr_.width, intr_.height,
              mode.amplitude ? "tof" : "structured-light", config.bilateral ? "+bilateral" : "", fuse_.dim,
              fuse_.voxel_m * 1e3,
              config.tracked ? (config.push_every_frame ? "tracked (ICP against the raycast model, every frame pushed)"
                                                        : "tracked (ICP against the raycast model, push after 1 cm / 1 deg)")
                             : "known (the backend's truth)",
              fuse_.threads);
  pool_.start(fuse_.threads);
  thread_ = std::thread([this] { localize_thread(); });
  return true;
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
  if (camera_running_) devices_.camera(0).stop();
  camera_running_ = false;
}

const char* FusionPipeline::device_name(int i) const { return devices_.camera_config(i).name.c_str(); }

const char* FusionPipeline::device_state(int i) const {
  if (i == 0) return camera_state_;
  return "unused (the pipeline reads the first camera)";
}

bool FusionPipeline::start_mapping(const char** why) {
  if (!camera_running_) {
    const hal::HalStatus s = devices_.camera(0).start(0);
    if (s != hal::HalStatus::kOk) {
      *why = "the camera did not start";
      camera_state_ = hal::to_string(s);
      return false;
    }
    camera_running_ = true;
    have_sequence_ = false;
    camera_state_ = "streaming";
  }
  mapping_ = true;
  return true;
}

void FusionPipeline::stop_mapping() {
  mapping_ = false;
  if (camera_running_) devices_.camera(0).stop();
  camera_running_ = false;
  camera_state_ = "stopped";
  have_still_anchor_ = false;
  stats_.fps = 0;
  stats_.still_since_us = 0;
  stats_.tracking = edgefuse_link_TrackingState_TRACKING_OFF;
}

void FusionPipeline::reset_map() {
  if (localizing_) return;  // the localiser reads the volume; the runtime refuses this anyway
  map_frames_ = 0;
  clear_pending_ = true;
  view_sum_ = Vec3f::Zero();
}

void FusionPipeline::step(uint64_t now_us) {
  if (!mapping_ || !camera_running_) return;
  if (localizing_) return;  // the volume belongs to the localiser now; the camera keeps its newest frame
  const hal::HalStatus s = devices_.camera(0).next_frame(frame_, 0);
  if (s == hal::HalStatus::kTimeout) return;
  if (s == hal::HalStatus::kEndOfStream) {
    camera_state_ = "end of recording";
    stats_.fps = 0;
    if (stats_.still_since_us == 0) stats_.still_since_us = now_us;
    return;
  }
  if (s != hal::HalStatus::kOk) {
    ++stats_.drops;
    camera_state_ = hal::to_string(s);
    return;
  }
  camera_state_ = "streaming";
  if (have_sequence_ && frame_.sequence > last_sequence_ + 1) stats_.drops += frame_.sequence - last_sequence_ - 1;
  have_sequence_ = true;
  last_sequence_ = frame_.sequence;
  if (last_frame_us_ != 0 && now_us > last_frame_us_) {
    const float inst = 1e6f / float(now_us - last_frame_us_);
    stats_.fps = stats_.fps <= 0 ? inst : 0.9f * stats_.fps + 0.1f * inst;
  }
  last_frame_us_ = now_us;
  integrate_frame(now_us);
}

void FusionPipeline::integrate_frame(uint64_t now_us) {
  const ImageView<uint16_t> out(g_filtered, frame_.width, frame_.height);
  if (filters_.run(frame_.depth_view(), frame_.amplitude_view(),
                   ImageView<uint16_t>(g_filter_scratch, frame_.width, frame_.height), out) != Status::kOk) {
    ++stats_.drops;
    return;
  }
  ++stats_.frames;
  DepthFrame f;
  f.depth = ImageView<const uint16_t>(g_filtered, frame_.width, frame_.height);
  if (frame_.has_colour) f.colour = frame_.colour_view();

  Pose T;
  const bool known = devices_.known_pose(0, frame_.sequence, T);
  bool push = true;
  if (config_.tracked) {
    // The paper's loop (Fig. 3): ICP of the frame against the model raycast at the last good pose;
    // pushed when it moved 1 cm / 1 degree. A new map starts at the backend's known pose (the
    // world frame of the truth), else at the identity.
    const bool first = clear_pending_ || map_frames_ == 0;
    TrackerParams tp;
    tp.push.every_frame = config_.push_every_frame;
    if (first && tracker_.start(known ? T : Pose::identity(), tp, true) != Status::kOk) {
      ++stats_.drops;
      return;
    }
    if (first && clear_pending_) centre_volume(f, known ? T : Pose::identity());
    Status s = Status::kOk;
    if (!first) s = raycast_parallel<real_t>(pool_, core_.volume, intr_, tracker_.raycast_pose(), core_.maps, core_.scratch);
    TrackResult r;
    if (s == Status::kOk) s = build_pyramid<real_t>(f.depth, PyramidParams(), pyramid_);
    if (s == Status::kOk) s = tracker_.track<real_t>(pyramid_, core_.maps, intr_, icp_ws_, r, nullptr);
    if (s != Status::kOk) {
      ++stats_.drops;
      return;
    }
    stats_.tracking = r.state == TrackState::kOk         ? edgefuse_link_TrackingState_TRACKING_OK
                      : r.state == TrackState::kDegraded ? edgefuse_link_TrackingState_TRACKING_DEGRADED
                                                         : edgefuse_link_TrackingState_TRACKING_LOST;
    if (r.state == TrackState::kLost) ++lost_frames_;
    push = r.push;
    if (known) track_err_m_ = (r.T_world_cam.t - T.t).norm();  // against the backend's truth
    T = r.T_world_cam;
  } else {
    if (!known) {
      // No truth for this frame (a real device, or a recording without ground truth) and tracking
      // is off (tracking.poses = known): the frame cannot be placed and is not integrated.
      stats_.tracking = edgefuse_link_TrackingState_TRACKING_LOST;
      ++stats_.drops;
      if (!warned_no_pose_) {
        std::printf("pipeline: camera %s gives no known pose (set tracking.poses = tracked): frames are not integrated\n",
                    devices_.camera(0).name());
        warned_no_pose_ = true;
      }
      return;
    }
    stats_.tracking = edgefuse_link_TrackingState_TRACKING_OK;
  }
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
  const Status s = integrate_parallel<real_t>(pool_, core_.volume, intr_, core_.ray_norms, f, T, core_.scratch);
  if (s != Status::kOk) {
    ++stats_.drops;
    return;
  }
  ++map_frames_;
  view_sum_ += T.t;
  last_capture_us_ = frame_.stamp_us;
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

bool FusionPipeline::start_pair_calibration(const char*, const char*, const char** why) {
  *why = "rigid-pair calibration is not wired into edgefused yet (use edgefuse calibrate)";
  return false;
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
  const Status xs = extract_points(core_.volume, core_.buffers.points, cap, surface);
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
