// The processing pipeline as the runtime sees it (HAL frames -> filters -> tracking -> fusion ->
// localisation), in plain types: the state machine, console and link do not depend on how poses
// are produced. edgefused plugs in its device pipeline (src/firmware/device_pipeline.hpp); the
// tests a pipeline of exact, fixed results (tests/firmware/exact_pose_pipeline.hpp).
// Calls must return quickly (the main loop also serves the console and the link).
#pragma once

#include <cstdint>

#include "edgefuse/math/pose.hpp"
#include "edgefuse/runtime/calibration.hpp"

namespace edgefuse::runtime {

//! The tracking of the reference camera as the runtime reports it.
enum class TrackingState : uint8_t { kOff, kOk, kDegraded, kLost };

struct PipelineStats {
  uint32_t frames = 0;  //!< frames processed since start
  uint32_t drops = 0;   //!< frames dropped since start
  float fps = 0;        //!< recent frame rate
  TrackingState tracking = TrackingState::kOff;
  uint64_t still_since_us = 0;  //!< when the rig stopped moving (0: moving or unknown)
};

//! One localised object as the runtime reports it.
struct ObjectResult {
  uint32_t id = 0;                     //!< 1 + the model's index in `model list`; 0: a model-free segment
  Pose T_world_object;                 //!< object-to-world pose
  float score = 0;                     //!< 0..1
  Vec3f grasp_m = Vec3f::Zero();       //!< grasp point in the world frame
  Vec3f approach = Vec3f(0, 0, -1);    //!< unit approach direction in the world frame
};

//! Objects a result carries at most (the link's message holds as many; every board's
//! objects_max is checked against it at compile time).
inline constexpr int kResultObjectsMax = 32;

//! A finished localisation, in picking order.
struct LocalizationOutcome {
  bool failed = false;    //!< the job refused (its reason is logged)
  uint64_t stamp_us = 0;  //!< capture stamp of the last frame in the map
  int count = 0;
  ObjectResult objects[kResultObjectsMax];
  //! Appends an object. \return false when full
  bool add(const ObjectResult& o) {
    if (count >= kResultObjectsMax) return false;
    objects[count++] = o;
    return true;
  }
};

//! Outcome of `calib fuse <from> <to>`: the mounting of `to` in `from`'s frame and how well the
//! data determined it.
struct PairCalibrationReport {
  CalibPose T_from_to;                 //!< pose of `to` in `from`'s frame
  float sigma_rot_deg[3] = {0, 0, 0};  //!< 1 sigma of the result about x, y, z (`to`'s frame)
  float sigma_trans_mm[3] = {0, 0, 0}; //!< 1 sigma of the result along x, y, z
  int frames = 1;                      //!< estimates averaged (one per paired frame)
  float spread_rot_deg[3] = {0, 0, 0};  //!< scatter of one frame's estimate about x, y, z (0 for one frame)
  float spread_trans_mm[3] = {0, 0, 0}; //!< scatter of one frame's estimate along x, y, z
  float rms_mm = 0;                    //!< point-to-plane RMS of the inliers
  float inlier_ratio = 0;              //!< inliers / candidates
  int correspondences = 0;             //!< inliers
  float moved_mm = 0;                  //!< distance from the starting guess
  float moved_deg = 0;                 //!< rotation from the starting guess
  const char* guess_source = "";       //!< where the starting guess came from
};

class Pipeline {
 public:
  virtual ~Pipeline() = default;
  //! Starts tracking and pushing frames into the map. \return false with a reason in `why`
  virtual bool start_mapping(const char** why) = 0;
  virtual void stop_mapping() = 0;
  //! Empties the map (the next frames start a new one).
  virtual void reset_map() = 0;
  //! Does the work due now (grab, filter, track, integrate). Never blocks long.
  //! \param now_us monotonic time
  virtual void step(uint64_t now_us) = 0;
  //! Starts localisation on the current map. \return false with a reason in `why`
  virtual bool start_localization(uint64_t now_us, const char** why) = 0;
  //! True once the started localisation finished; fills `out` (objects, status, capture stamp;
  //! the runtime sets the sequence number).
  virtual bool poll_localization(LocalizationOutcome& out) = 0;
  //! Rigid-pair calibration of `to` against the map filled by `from` (paper Fig. 6) on the live
  //! map and `to`'s newest frame; runs to completion (a fraction of a second).
  //! \param from the map's sensor  \param to the sensor to register  \param out the result
  //! \param why the refusal's reason (unknown sensor, empty map, scene does not constrain the pose)
  //! \return false when refused
  virtual bool calibrate_pair(const char* from, const char* to, PairCalibrationReport& out, const char** why) = 0;
  //! The calibration changed (loaded, set, reset, calibrated): extrinsics apply from the next frame.
  //! \param d the runtime's calibration
  virtual void calibration_changed(const CalibrationData& d) { (void)d; }
  //! The rig's newest pose in the map (the reference camera's tracked pose times the inverse of
  //! its mounting on the rig): what a hand-eye station measures on the camera side.
  //! \param T_map_rig set on success  \param stamp_us its capture stamp
  //! \return false when there is none (not mapping, tracking lost, no pose source)
  virtual bool rig_pose(Pose& T_map_rig, uint64_t& stamp_us) const {
    (void)T_map_rig;
    (void)stamp_us;
    return false;
  }
  virtual PipelineStats stats() const = 0;
  virtual bool map_empty() const = 0;
  virtual int device_count() const = 0;
  virtual const char* device_name(int i) const = 0;
  virtual const char* device_state(int i) const = 0;
  virtual int model_count() const = 0;
  virtual const char* model_name(int i) const = 0;
};

}  // namespace edgefuse::runtime
