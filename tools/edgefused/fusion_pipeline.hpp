// The real pipeline of edgefused: the board's first depth camera (board/<name>/hal.toml, through
// the HAL; host-sim: the sim backend, or a rig set's replay with sensors.replay) -> the sensor
// kind's depth pre-filters -> pose -> integration into the static TSDF -> on LOCALIZE: surface
// extraction, bin removal and model-based localisation (PPF + ICP + free-space verification) or,
// without models, model-free segments -> a LocalizationResult for the link.
//
// Poses (tracking.poses): "known" = the backend's known poses (sim: the simulated rig's motion;
// replay: the recording's ground truth), every frame pushed; "tracked" = the tracking module (ICP
// against the model raycast at the last good pose, push after 1 cm / 1 degree), starting at the
// backend's known pose of the map's first frame (else the identity). With "known", a camera without
// known poses (a real device) has its frames counted as drops and says so once.
//
// Memory: everything is allocated in init() (arena carve as CoreSetup does, models, worker threads,
// the localisation thread); step() and the localisation run without the heap (the replay backend's
// PNG decoder is host-only and allocates inside libpng).
//
// Threads: step() runs in edgefused's main loop and integrates at most one frame per call; the
// localisation (hundreds of milliseconds) runs on its own thread so the console and the link stay
// served; no frame is integrated while it reads the volume.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>

#include "core_setup.hpp"
#include "edgefuse/filters/depth_filter_chain.hpp"
#include "edgefuse/localize/localizer.hpp"
#include "edgefuse/runtime/pipeline.hpp"
#include "edgefuse/tracking/tracker.hpp"
#include "hal/devices/hal_devices.hpp"
#include "worker_pool.hpp"

namespace edgefuse::wire {

struct FusionPipelineConfig {
  std::string board;        //!< board folder name (hal.toml, board.toml)
  std::string replay;       //!< rig set / sequence folder every camera replays ("" : hal.toml's backends)
  std::string models;       //!< a PLY model or a folder of them ("" : a replayed rig set's models)
  float voxel_m = 0.002f;   //!< TSDF voxel edge
  float trunc_m = 0.008f;   //!< TSDF truncation
  bool bilateral = false;   //!< bilateral filter on
  float min_score = 0.3f;   //!< localiser's own acceptance (the runtime filters again by its param)
  bool tracked = false;     //!< poses by ICP tracking (else the backend's known poses)
  bool push_every_frame = false;  //!< tracked: integrate every frame (else after 1 cm / 1 degree)
};

class FusionPipeline final : public runtime::Pipeline {
 public:
  FusionPipeline() = default;
  ~FusionPipeline() override { shutdown(); }

  //! Start-up: devices, static buffers, filters, models, threads. Prints what it set up.
  //! \param config what to open  \param err names the failing file / device / value
  bool init(const FusionPipelineConfig& config, std::string& err);
  //! Stops the threads and the camera (idempotent).
  void shutdown();

  bool start_mapping(const char** why) override;
  void stop_mapping() override;
  void reset_map() override;
  void step(uint64_t now_us) override;
  bool start_localization(uint64_t now_us, const char** why) override;
  bool poll_localization(link::LocalizationResult& out) override;
  bool start_pair_calibration(const char* from, const char* to, const char** why) override;
  runtime::PipelineStats stats() const override { return stats_; }
  bool map_empty() const override { return map_frames_ == 0; }
  int device_count() const override { return devices_.camera_count(); }
  const char* device_name(int i) const override;
  const char* device_state(int i) const override;
  int model_count() const override { return loc_.model_count(); }
  const char* model_name(int i) const override { return loc_.model(i).name; }

  //! Frames integrated into the current map.
  uint32_t map_frames() const { return map_frames_; }

 private:
  void integrate_frame(uint64_t now_us);
  void centre_volume(const DepthFrame& frame, const Pose& T_world_cam);
  void localize_thread();
  void run_localization();

  FusionPipelineConfig config_;
  hal::HalDevices devices_;
  hal::DepthFrame frame_;  // points at static storage (fusion_pipeline.cpp)
  PinholeIntrinsics intr_;
  cli::CoreSetup core_;
  cli::FuseSettings fuse_;
  DepthFilterChain<real_t> filters_;
  Localizer loc_;
  LocalizeParams loc_params_;
  Tracker tracker_;
  FramePyramid<real_t> pyramid_;
  IcpWorkspace<real_t> icp_ws_;
  uint32_t lost_frames_ = 0;
  float track_err_m_ = 0;
  WorkerPool pool_;

  bool camera_running_ = false;
  bool mapping_ = false;
  bool clear_pending_ = true;  // the volume is cleared and re-centred on the next frame
  uint32_t map_frames_ = 0;
  bool have_sequence_ = false;
  uint32_t last_sequence_ = 0;
  bool have_still_anchor_ = false;
  Pose still_anchor_;  //!< pose where the current still period began (still detection)
  uint64_t last_frame_us_ = 0;
  uint64_t last_capture_us_ = 0;
  Vec3f view_sum_ = Vec3f::Zero();
  runtime::PipelineStats stats_;
  const char* camera_state_ = "stopped";
  bool warned_no_pose_ = false;

  // localisation thread
  std::thread thread_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool quit_ = false;
  bool request_ = false;
  std::atomic<bool> localizing_{false};
  std::atomic<bool> done_{false};
  link::LocalizationResult result_;
  double last_localize_cpu_ms_ = 0;
};

}  // namespace edgefuse::wire
