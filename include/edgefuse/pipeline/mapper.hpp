// The mapping step, one call per frame (the paper's Fig. 3 with several sensors):
//   reference camera: pre-filters -> trust map (several sensors) -> pose (tracked by ICP against
//     the model raycast at the last good pose, pushed after 1 cm / 1 degree; or the frame's known
//     pose, every frame pushed; or the known pose as the prior that ICP against the model raycast
//     there corrects, "robot+icp") -> a new map is centred on its first view -> integration;
//   another camera of the rig, paired with a reference frame: pre-filters -> trust map -> the
//     reference's pose at the frame's own stamp (PoseHistory) times its extrinsics -> integration;
//   a line scanner's profile: integrated at the pose its axis gives, with the scanner's trust.
// With several sensors each pixel's weight follows its sensor's noise model and the fusion rules
// (fusion_rules.hpp) set each frame's depth-jump limit and sub-unit fill from the cameras' median
// noise so far. edgefused and `edgefuse track|fuse|localize` all map through this class; it
// allocates nothing, calls no OS, and runs its kernels on the runners it is given.
#pragma once

#include <cstdint>

#include "edgefuse/pipeline/camera_slot.hpp"
#include "edgefuse/pipeline/kernels.hpp"
#include "edgefuse/pipeline/pose_history.hpp"
#include "edgefuse/pipeline/view_centre.hpp"
#include "edgefuse/sensor/line_scanner.hpp"
#include "edgefuse/tracking/tracker.hpp"
#include "edgefuse/tsdf/volume.hpp"

namespace edgefuse {

//! Where the reference camera's poses come from.
enum class PoseMode : uint8_t {
  kKnown,    //!< given with each frame (a robot, a recording's ground truth, the simulator)
  kTracked,  //!< ICP against the map (the paper's Fig. 3)
  //! "robot+icp": the pose given with each frame (a robot's flange pose times the camera's mounting)
  //! is the prior, ICP against the map raycast at the prior corrects it (the paper: the robot's pose
  //! is not trusted as it is, the data is). Replaces the tracker's constant-velocity prediction, so
  //! frames may be far apart (robot stations); a new map's first frame is pushed at its prior.
  kPrior,
};

//! The fusion rules that follow the sensors' modelled noise (fusion_rules.hpp; with noise weights only).
struct FusionRuleParams {
  float jump_sigmas = kJumpSigmas;  //!< depth-jump limit = this x the frame's median noise (0: the truncation)
  int sub_unit_fill_units = 0;      //!< 0: decided from the fused cameras' medians so far; else this fill
  float noise_gate_m = 0.0f;        //!< a pixel whose modelled noise exceeds this is not integrated (0: none)
};

struct MapperParams {
  PoseMode poses = PoseMode::kKnown;
  TrackerParams tracker;       //!< kTracked, kPrior: alignment, states, push policy
  bool prefilter = true;       //!< run each camera's pre-filters (off: frames are integrated as given)
  bool noise_weights = false;  //!< weight each pixel by its sensor's noise model (several sensors)
  FusionRuleParams rules;      //!< noise_weights: the depth-jump limit, sub-unit fill and noise gate
};

//! The phases of a reference step, reported to a StepObserver as each ends.
enum class MapPhase : uint8_t { kFilter, kRaycast, kTrack, kIntegrate };

//! Gets the end of each phase (a program's clock: the core has none).
class StepObserver {
 public:
  virtual ~StepObserver() = default;
  //! \param phase the phase that just ended
  virtual void phase_done(MapPhase phase) = 0;
};

//! What map_reference() did with a frame.
struct ReferenceStep {
  TrackResult track;       //!< kTracked, kPrior: the tracker's result; kKnown: state ok, pushed
  Pose T_world_cam;        //!< the frame's pose (tracked and lost: the last good pose; kPrior and lost: the prior)
  bool filtered = false;   //!< the pre-filters ran (the frame counts as processed)
  bool has_pose = false;   //!< known, or tracked / corrected and not lost
  bool integrated = false; //!< pushed into the map
  bool centred = false;    //!< this frame placed a new map (volume cleared, origin on its view)
};

class Mapper {
 public:
  //! Start-up.
  //! \param volume the space (bound)  \param runners the kernels' threads
  //! \param filter_spare the pre-filters' intermediate image (the board's largest, used by no camera)
  //! \param centre scratch for centring a new map  \param params pose mode, filters, weights
  Status init(TsdfVolume& volume, const KernelRunners& runners, ImageView<uint16_t> filter_spare,
              const ViewCentreScratch& centre, const MapperParams& params);
  //! The cameras that feed the map, reference first: their median noise decides the fusion rules.
  //! \param cameras pointers to bound slots (kept)  \param count at most kFusedMax
  void set_fused_cameras(CameraSlot* const* cameras, int count);
  static constexpr int kFusedMax = 4;

  //! Starts a new map: the next reference frame clears the volume and centres it on its view.
  void new_map();
  //! Starts a new map in the volume as it is placed now (the caller set the origin and cleared it).
  void new_map_in_place();
  //! A map is placed (a reference frame centred it, or new_map_in_place()).
  bool placed() const { return !centre_pending_; }
  //! The next reference frame starts the map (no map placed, or nothing integrated yet): with
  //! tracked poses it is pushed at map_reference()'s `start` without alignment.
  bool starts_new_map() const { return centre_pending_ || map_frames_ == 0; }

  //! One frame of the reference camera.
  //! \param cam its slot  \param frame the raw frame  \param known its pose when known (null: none;
  //! kPrior: the prior)  \param start kTracked: the pose a new map starts at  \param out what happened
  //! \param observer optional phase clock
  //! \return kOk also when the frame was not integrated (see out); an error when a kernel refused
  Status map_reference(CameraSlot& cam, const SensorFrame& frame, const Pose* known, const Pose& start,
                       ReferenceStep& out, StepObserver* observer = nullptr);
  //! kPrior's correction alone: a frame of the reference camera aligned by ICP against the map
  //! raycast at `prior`, not integrated, counting nothing and leaving the tracking state as it is
  //! (e.g. every robot station aligned again once the map holds them all).
  //! \param cam its slot  \param frame the raw frame  \param prior its approximate pose
  //! \param out the aligned pose (the prior when lost), state, correction and ICP statistics; never pushed
  //! \return kNotInitialised while nothing is mapped; else kOk or a kernel's error
  Status align_reference(CameraSlot& cam, const SensorFrame& frame, const Pose& prior, TrackResult& out);
  //! One frame of any camera at a pose the caller knows (a recording's poses, a calibrated mounting).
  //! \param cam its slot  \param frame the raw frame  \param T_world_cam its pose
  //! \return kNotInitialised while no map is placed; kOk when integrated
  Status map_at(CameraSlot& cam, const SensorFrame& frame, const Pose& T_world_cam);
  //! One frame of another camera, at the reference's pose of its stamp times T_ref_cam.
  //! \param cam its slot  \param frame the raw frame  \param T_ref_cam its extrinsics
  //! \return kNotInitialised while no map is placed or the reference has no pose; kOk when integrated
  Status map_paired(CameraSlot& cam, const SensorFrame& frame, const Pose& T_ref_cam);
  //! One line-scanner profile.
  //! \param model the scanner  \param tables its tables  \param ranges_m model.beams ranges
  //! \param T_world_sensor the profile's pose  \param sigma_m the scanner's constant range noise
  //! \return kNotInitialised while no map is placed; kOk when integrated
  Status map_profile(const LineScannerModel& model, const LineScannerTables<real_t>& tables, const float* ranges_m,
                     const Pose& T_world_sensor, float sigma_m);

  //! The reference camera's poses (pose at a stamp, the last stamp).
  const PoseHistory& reference() const { return history_; }
  const Tracker& tracker() const { return tracker_; }
  uint32_t map_frames() const { return map_frames_; }  //!< frames integrated into this map
  //! Mean position of the integrated frames' sensors (the localiser's viewpoint).
  Vec3f mean_viewpoint() const { return map_frames_ > 0 ? Vec3f(view_sum_ / float(map_frames_)) : Vec3f::Zero(); }
  uint64_t last_capture_us() const { return last_capture_us_; }  //!< the last integrated reference frame's stamp
  //! Sub-unit fill of the fused cameras (fusion_rules.hpp default_sub_unit_fill, medians so far),
  //! or the one set by set_sub_unit_fill().
  int sub_unit_fill() const;
  //! Fixes the sub-unit fill for the frames to come (a set planned from each camera's first frame).
  //! \param units weight units (0: decided from the medians again)
  void set_sub_unit_fill(int units) { params_.rules.sub_unit_fill_units = units; }
  //! A frame's median modelled noise as mapping would measure it (pre-filters, noise gate), counting
  //! nothing: for planning the fusion rules before the frames are mapped.
  //! \param cam its slot  \param frame the raw frame  \param sigma_m the median (0 without noise weights)
  Status measure_noise(CameraSlot& cam, const SensorFrame& frame, float& sigma_m);
  //! Extraction's support rule for this map: 0 with one camera (equal weights), else
  //! fusion_rules.hpp default_support_weight of the fused cameras' medians so far.
  uint8_t support_weight() const;
  const TsdfVolume& volume() const { return *volume_; }
  TsdfVolume& volume() { return *volume_; }
  const MapperParams& params() const { return params_; }

 private:
  Status prepare_frame(CameraSlot& cam, const SensorFrame& in, DepthFrame& out, bool* filtered);
  Status weigh_frame(CameraSlot& cam, const SensorFrame& in, DepthFrame& out, float& sigma_m, bool* filtered);
  void apply_noise_gate(CameraSlot& cam, const DepthFrame& f);
  Status integrate_at(CameraSlot& cam, const DepthFrame& f, const Pose& T_world_cam);
  Status track(CameraSlot& cam, const DepthFrame& f, const Pose& start, const Pose* prior, ReferenceStep& out,
               StepObserver* observer);
  bool centre_on(const CameraSlot& cam, const DepthFrame& f, const Pose& T_world_cam);
  void fused_sigmas(float (&sigma)[kFusedMax]) const;

  TsdfVolume* volume_ = nullptr;
  KernelRunners runners_;
  ImageView<uint16_t> filter_spare_;
  ViewCentreScratch centre_;
  MapperParams params_;
  CameraSlot* fused_[kFusedMax] = {};
  int fused_count_ = 0;
  Tracker tracker_;
  PoseHistory history_;
  bool centre_pending_ = true;
  uint32_t map_frames_ = 0;
  Vec3f view_sum_ = Vec3f::Zero();
  uint64_t last_capture_us_ = 0;
};

}  // namespace edgefuse
