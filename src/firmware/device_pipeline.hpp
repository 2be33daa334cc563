// The real pipeline of edgefused: the board's depth cameras (board/<name>/hal.toml, through the
// HAL; host-sim: the sim backend, or a rig set's replay with sensors.replay), each streamed by its
// own acquisition thread (hal/acquisition: fixed frame pool, SPSC rings, newest-frame policy,
// sanity checks, stall -> reopen with back-off, unplug/replug) -> the sensor kind's depth
// pre-filters -> pose -> integration into the static TSDF -> on LOCALIZE: surface extraction, bin
// removal and model-based localisation (PPF + ICP + free-space verification) or, without models,
// model-free segments -> the objects for the runtime (plain types; the link encodes them).
//
// Sensors (sensors.fuse): the cameras that feed the map; the first is the reference whose poses
// are known or tracked. Another camera's frame, paired with the reference frame nearest in time
// (within kPairWindowUs), is integrated at the reference's pose at the frame's own capture stamp
// (reference_pose_at: constant velocity through the reference's last two poses) times its
// extrinsics T_ref_cam: the calibration store's pair (ref,
// cam), else the store's rig mountings of both, else the replayed rig set's extrinsics.txt, else
// (tracking.sim_truth) the sim backend's mountings. With more than one camera in the map each pixel's weight follows its
// sensor's noise model (trust maps, as `edgefuse fuse --sensors`). Every camera streams (and is
// counted in `status`) whether it feeds the map or not, so `calib fuse` can use its newest frame.
// The line scanner (sensors.fuse lists it by name) streams on its own thread too; every profile is
// integrated (integrate_profile) at the pose its axis position gives along the axis the backend
// reports (HalDevices::scanner_axis), once the reference camera has placed the map.
//
// Poses (tracking.poses): "icp" (default; "tracked" is the same) = the tracking module (ICP against
// the model raycast at the last good pose, push after 1 cm / 1 degree), starting at the pose composed
// from the robot's flange pose at the map's first frame, the hand-eye mounting T_flange_rig of the
// calibration store and the reference camera's mounting on the rig T_rig_ref (calibration store,
// else the identity); without a robot pose (no robot connected) the identity.
// "robot" = every frame at T_base_flange(frame stamp + robot.latency_us) x T_flange_rig x T_rig_ref,
// the flange pose interpolated between the robot's pose updates (set_flange_poses: edgefused's robot
// session), every frame pushed; "robot+icp" = that pose as the prior, ICP against the map raycast
// there corrects it (Mapper's PoseMode::kPrior). The map and every result are then in the robot's
// base frame. A reference frame the robot has no pose for yet is held (no newer frame taken) for up
// to kRobotPoseWaitUs past its stamp plus the latency offset (the robot's update for that instant
// may still be on the way), then it is skipped and counted (robot_pose_missing(), in the drops;
// tracking lost, said once a scan).
// "known" = every frame at the reference camera's true pose from its backend's simulator truth
// (hal::TruthSource: sim = the simulated rig's motion; replay = the recording's ground truth),
// every frame pushed; refused at start-up when the reference camera offers no truth (a real
// device, a recording without poses); a frame without a pose is counted as a drop, said once.
// Simulator truth (tracking.sim_truth, off by default) may further stand in for what a real rig
// gets from its robot and its calibration: the flange pose of a tracked map's start (sim robot /
// the rig set's reference sensor), the sim rig's mountings (T_rig_ref of the start pose, and a
// paired camera's extrinsics after the store and the rig set's extrinsics.txt), and the tracking
// error reported at each localisation. Nothing else takes the backend's truth.
//
// Memory: everything is allocated in init() (arena carve as CoreSetup does, models, worker threads,
// the localisation thread); step() and the localisation run without the heap (the replay backend's
// PNG decoder is host-only and allocates inside libpng).
//
// Threads: one acquisition thread per camera (started by scan start, stopped by scan stop: the
// replay of a recording begins with the scan); step() runs in edgefused's main loop, takes each
// camera's newest frame and integrates at most one frame per camera per call; the
// localisation (hundreds of milliseconds) runs on its own thread so the console and the link stay
// served; no frame is integrated while it reads the volume, so it spreads its voting and refinement
// over the worker pool (the board's [tsdf] threads) meanwhile.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "camera_stream.hpp"
#include "scanner_stream.hpp"
#include "edgefuse/localize/localizer.hpp"
#include "edgefuse/pipeline/mapper.hpp"
#include "edgefuse/pipeline/still_detector.hpp"
#include "edgefuse/runtime/pipeline.hpp"
#include "edgefuse/io/rig.hpp"
#include "edgefuse/runtime/calibration.hpp"
#include "edgefuse/runtime/flange_pose_source.hpp"
#include "edgefuse/hal/devices/hal_devices.hpp"
#include "edgefuse/hal/platform/threads/pool_row_runner.hpp"
#include "edgefuse/hal/platform/threads/background_job.hpp"
#include "edgefuse/hal/platform/threads/worker_pool.hpp"

namespace edgefuse::firmware {

struct PairRun;  // one `calib fuse` command while it collects estimates (pair_calibration.cpp)

//! Where the reference camera's poses come from (tracking.poses).
enum class CameraPoses : uint8_t {
  kIcp,       //!< "icp" / "tracked": ICP against the map
  kKnown,     //!< "known": the backend's truth
  kRobot,     //!< "robot": the robot's flange pose x the hand-eye mounting
  kRobotIcp,  //!< "robot+icp": that pose corrected by ICP against the map
};
//! Parses tracking.poses. \param text the value \param out set on success \return false when unknown
bool parse_camera_poses(const std::string& text, CameraPoses& out);

struct DevicePipelineConfig {
  std::string board;        //!< board folder name (hal.toml, board.toml)
  std::string replay;       //!< rig set / sequence folder every camera replays ("" : hal.toml's backends)
  std::string models;       //!< a PLY model or a folder of them ("" : a replayed rig set's models)
  int dim = 0;              //!< TSDF voxels per axis, up to the board's capacity (0: the board's [tsdf] dim)
  float voxel_m = 0.002f;   //!< TSDF voxel edge
  float trunc_m = 0.008f;   //!< TSDF truncation
  bool bilateral = false;   //!< bilateral filter on
  float min_score = 0.3f;   //!< localiser's own acceptance (the runtime filters again by its param)
  //! kKnown: every frame at the reference camera's true pose (its hal::TruthSource; refused at init
  //! without one); kRobot, kRobotIcp: from the robot (set_flange_poses); kIcp: tracked by ICP
  CameraPoses poses = CameraPoses::kIcp;
  int64_t robot_latency_us = 0;  //!< robot modes: the flange pose is looked up at the frame's stamp plus this
  bool use_sim_truth = false;  //!< simulator truth stands in for the robot's flange pose, the rig
                               //!< mountings and the tracking error's reference (tracking.sim_truth)
  bool inject_faults = false;  //!< cameras wrapped in FaultCameras (devices().faults(i)): tests
  bool push_every_frame = false;  //!< tracked: integrate every frame (else after 1 cm / 1 degree)
  double replay_speed = 1;  //!< replayed cameras' playback speed (1: the recorded rate)
  std::string sim_path;     //!< sim cameras: the rig's key-pose file (hal::SimRigPath; "" : its circle)
  std::string fuse;         //!< cameras feeding the map, "a,b" (first: reference); "" : hal.toml's first
  std::string hal_file;     //!< the devices' hal.toml ("" : the board's); memory stays the board's (the
                            //!< tests of a target board's build run host-sim's simulated rig with it)
};

class DevicePipeline final : public runtime::Pipeline {
 public:
  DevicePipeline() = default;
  ~DevicePipeline() override { shutdown(); }

  //! Start-up: devices, static buffers, filters, models, threads. Prints what it set up.
  //! \param config what to open  \param err names the failing file / device / value
  bool init(const DevicePipelineConfig& config, std::string& err);
  //! Stops the threads and the camera (idempotent).
  void shutdown();

  bool start_mapping(const char** why) override;
  void stop_mapping() override;
  void reset_map() override;
  void step(uint64_t now_us) override;
  bool start_localization(uint64_t now_us, const char** why) override;
  bool poll_localization(runtime::LocalizationOutcome& out) override;
  bool calibrate_pair(const char* from, const char* to, runtime::PairCalibrationReport& out,
                      const char** why) override;
  void calibration_changed(const runtime::CalibrationData& d) override;
  bool rig_pose(Pose& T_map_rig, uint64_t& stamp_us) const override;
  runtime::PipelineStats stats() const override { return stats_; }
  bool map_empty() const override { return mapper_.map_frames() == 0; }
  int device_count() const override { return camera_count_ + (scanner_.name.empty() ? 0 : 1); }
  const char* device_name(int i) const override;
  const char* device_state(int i) const override;
  int model_count() const override { return loc_.model_count(); }
  const char* model_name(int i) const override { return loc_.model(i).name; }

  //! Frames integrated into the current map.
  uint32_t map_frames() const { return mapper_.map_frames(); }
  //! Where a tracked map starts: T_world_flange (robot pose at the reference camera's frame: the
  //! flange pose source at stamp_us, else with tracking.sim_truth the simulated robot's at `sequence`)
  //! * T_flange_rig (hand-eye, calibration) * T_rig_ref; the identity without a robot pose.
  //! \param sequence the first frame's sequence number  \param stamp_us its capture stamp (0: none)
  Pose tracking_start_pose(uint32_t sequence, uint64_t stamp_us = 0);
  //! The robot's flange poses (edgefused: its robot session; null: none). Read in step() only, on
  //! the caller's thread. \param source kept, not owned
  void set_flange_poses(const runtime::FlangePoseSource* source) { flange_poses_ = source; }
  //! The reference camera's pose from the robot at capture stamp_us: T_base_flange(stamp_us +
  //! robot_latency_us) x T_flange_rig x T_rig_ref. \return false without a robot pose at that time
  bool robot_pose(uint64_t stamp_us, Pose& T_base_ref) const;
  //! Reference frames skipped because the robot had no pose at their stamp (robot modes).
  uint32_t robot_pose_missing() const { return robot_pose_missing_; }
  //! How long a reference frame waits for the robot's pose at its stamp before it is skipped.
  static constexpr uint64_t kRobotPoseWaitUs = 200000;
  //! The board's devices (with inject_faults, tests inject faults through devices().faults(i)).
  hal::HalDevices& devices() { return devices_; }
  //! Camera i's stream (counters, extrinsics); i < device_count().
  const CameraStream& camera_stream(int i) const { return cams_[i]; }
  //! The line scanner's stream (name "" without one).
  const ScannerStream& scanner_stream() const { return scanner_; }
  //! The mapping step (map frames, fusion rules, reference poses).
  const Mapper& mapper() const { return mapper_; }
  //! Support rule of the map's extraction (Mapper::support_weight()).
  uint8_t map_support_weight() const { return mapper_.support_weight(); }

  //! Largest stamp difference between a camera's frame and the reference frame whose pose it takes.
  static constexpr uint64_t kPairWindowUs = PoseHistory::kPairWindowUs;
  //! The reference camera's pose at capture time stamp_us (PoseHistory::pose_at).
  Pose reference_pose_at(uint64_t stamp_us) const { return mapper_.reference().pose_at(stamp_us); }
  //! Capture stamp of the reference camera's last processed frame (0 before the first).
  uint64_t reference_stamp_us() const { return mapper_.reference().stamp_us(); }
  //! True when reference_pose_at() interpolates (PoseHistory::has_velocity).
  bool reference_velocity_known() const { return mapper_.reference().has_velocity(); }

 private:
  static constexpr int kCamerasMax = 3;
  bool check_pair(PairRun& run);
  void collect_pair_estimates(PairRun& run);
  bool try_pair_estimate(PairRun& run);
  bool init_cameras(const std::string& hal_path, std::string& err);
  //! Loads config_.sim_path (when set) and hands it to the devices.
  //! \param err the file and line of a bad key, or why the path does not apply
  bool load_sim_path(std::string& err);
  void print_sim_path() const;
  bool init_fused(const std::string& hal_path, std::string& err);
  bool init_scanner(const BoardCapacities& board, std::string& err);
  bool init_models(std::string& err);
  void print_setup() const;
  void process_reference(uint64_t now_us);
  void process_other(CameraStream& c);
  void process_profile(const hal::LineProfile& p);
  void drain_profiles();
  void update_mounts();
  void update_drops();
  void run_localization();
  //! The reference's pose comes from ICP (icp, robot+icp): the tracker's state is the tracking's.
  bool icp_poses() const { return config_.poses == CameraPoses::kIcp || config_.poses == CameraPoses::kRobotIcp; }
  bool robot_poses() const { return config_.poses == CameraPoses::kRobot || config_.poses == CameraPoses::kRobotIcp; }
  bool tracked() const { return config_.poses != CameraPoses::kKnown; }
  //! T_flange_ref = T_flange_rig (calibration store) x T_rig_ref. \param mount names T_rig_ref's source
  Pose flange_to_reference(const char** mount) const;
  bool wait_for_robot_pose(const CameraStream& ref, uint64_t now_us) const;
  void count_unplaced_frame(const CameraStream& ref);
  //! Camera `index`'s simulator truth when tracking.sim_truth allows it, else null.
  const hal::TruthSource* sim_truth(int index) const {
    return config_.use_sim_truth ? devices_.truth(index) : nullptr;
  }

  DevicePipelineConfig config_;
  hal::HalDevices devices_;
  hal::SimRigPath sim_rig_path_;  // sensors.sim_path's keys (static: the devices keep a pointer)
  CameraStream cams_[kCamerasMax];
  ScannerStream scanner_;
  int camera_count_ = 0;
  int order_[kCamerasMax] = {0, 1, 2};  // cams_ indices: the reference first, then the other map cameras
  int fuse_count_ = 0;                  // cameras feeding the map (order_[0..fuse_count_))
  std::vector<io::SensorExtrinsic> rig_extrinsics_;  // the replayed rig set's extrinsics.txt
  runtime::CalibrationData calib_;
  bool use_trust_ = false;
  CoreBuffers buffers_;
  TsdfVolume volume_;
  int threads_ = 1;
  Mapper mapper_;
  Localizer loc_;
  LocalizeParams loc_params_;
  uint32_t lost_frames_ = 0;
  float track_err_m_ = 0;
  WorkerPool pool_;
  PoolRowRunner tsdf_rows_{pool_, 1};
  PoolRowRunner icp_rows_{pool_};

  bool camera_running_ = false;
  bool mapping_ = false;
  uint32_t pipeline_drops_ = 0;  // frames taken but not integrated (filter, pose or integration failed)
  StillDetector still_;
  uint64_t last_frame_us_ = 0;
  runtime::PipelineStats stats_;
  bool warned_no_pose_ = false;
  bool said_first_stamp_ = false;  // the scan's first reference frame stamp was printed
  const runtime::FlangePoseSource* flange_poses_ = nullptr;
  uint32_t robot_pose_missing_ = 0;
  // robot+icp: the map's placement in the robot's base frame, averaged over the tracked frames
  // (robot pose x ICP pose^-1 of each); the results are reported through it.
  struct BasePlacement {
    double t[3] = {0, 0, 0};     // sum of the translations
    double q[4] = {0, 0, 0, 0};  // sum of the quaternions (x y z w, sign-aligned to the first)
    uint32_t frames = 0;
    void add(const Pose& T_base_map);
    bool mean(Pose& T_base_map) const;  // false with fewer than 2 frames
  };
  BasePlacement base_placement_;

  // the localisation, on its own thread
  hal::BackgroundJob localization_;
  runtime::LocalizationOutcome result_;
  double last_localize_cpu_ms_ = 0;
};

}  // namespace edgefuse::firmware
