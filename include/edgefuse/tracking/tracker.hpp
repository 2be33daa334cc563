// Frame-to-model tracking of one sensor (paper Fig. 3): prediction, ICP, state, push decision.
//
// Per frame the caller
//   1. raycasts the model at raycast_pose() (the last good pose) into the sensor's maps,
//   2. builds the frame's pyramid (build_pyramid, after the depth pre-filters),
//   3. calls track(), and integrates the frame at result.T_world_cam when result.push.
// track() starts the ICP from the constant-velocity prediction (last good pose moved by the motion
// between the last two frames tracked ok); if that does not end ok, it also starts from the last
// good pose itself and keeps the better outcome (ok > degraded > lost; among degraded ones the
// standstill, which keeps unobservable directions at the last pose; else more inliers). A degraded
// frame forgets the velocity (its motion in unobservable directions was not measured). Both starts use the same
// raycast, so a second attempt costs one ICP, not another raycast. A lost frame keeps the last good
// pose and is not pushed; later frames are tried from that pose again, so tracking resumes as soon
// as the sensor sees what it saw before.
// The first frame of an empty space is not aligned (there is nothing to align to): it is pushed at
// the initial pose.
// track_prior() is the "robot+icp" variant: the frame's pose is known roughly (a robot's flange
// pose times the camera's mounting), the model is raycast at that prior and the ICP starts there,
// so the motion between frames may be as large as the robot likes; the jump test then measures the
// correction from the prior (a large one means robot and data disagree: lost).
#pragma once

#include "edgefuse/core/status.hpp"
#include "edgefuse/math/pose.hpp"
#include "edgefuse/tracking/icp.hpp"
#include "edgefuse/tracking/push_policy.hpp"
#include "edgefuse/tracking/tracking_state.hpp"

namespace edgefuse {

struct TrackerParams {
  IcpParams icp;           //!< alignment
  StateThresholds state;   //!< ok / degraded / lost
  PushPolicy push;         //!< when to integrate

  bool valid() const { return icp.valid() && state.valid() && push.valid(); }
};

struct TrackResult {
  Pose T_world_cam;          //!< this frame's pose (the last good pose when lost)
  TrackState state = TrackState::kOk;
  bool push = false;         //!< integrate this frame at T_world_cam
  bool first = false;        //!< first frame of an empty space (pushed at the initial pose, not aligned)
  int start = -1;            //!< ICP start kept: 0 constant velocity, 1 last good pose, 2 the prior, -1 none
  int attempts = 0;          //!< ICP runs this frame (0..2)
  float jump_m = 0;          //!< translation from the last good pose
  float jump_deg = 0;        //!< rotation from the last good pose
  IcpStats icp;              //!< statistics of the kept ICP run
};

class Tracker {
 public:
  //! Begins a sequence at a known pose.
  //! \param initial sensor-to-world pose of the first frame
  //! \param params thresholds (checked)
  //! \param space_empty true when nothing has been integrated yet: the first frame is pushed at `initial`
  Status start(const Pose& initial, const TrackerParams& params, bool space_empty = true);

  //! Pose to raycast the model at for the next frame (the last good pose).
  const Pose& raycast_pose() const { return pose_; }

  //! Aligns one frame; see the file comment.
  //! \param frame the frame's pyramid
  //! \param model raycast maps at raycast_pose() (vertex and normal)
  //! \param intr the sensor's intrinsics
  //! \param ws ICP row sums
  //! \param result pose, state, push decision
  //! \param runner optional row runner for the ICP (threads do not change the result)
  template <class Real>
  Status track(const FramePyramid<Real>& frame, const RaycastMaps& model, const PinholeIntrinsics& intr,
               const IcpWorkspace<Real>& ws, TrackResult& result, const RowRunner* runner = nullptr);

  //! Aligns one frame starting at its prior (robot+icp); see the file comment. A lost frame keeps
  //! the prior as its pose and is not pushed; the push policy is track()'s.
  //! \param prior the frame's approximate sensor-to-world pose
  //! \param frame the frame's pyramid
  //! \param model raycast maps at `prior` (vertex and normal)
  //! \param intr the sensor's intrinsics
  //! \param ws ICP row sums
  //! \param result pose, state (jump = the correction from the prior), push decision
  //! \param runner optional row runner for the ICP (threads do not change the result)
  template <class Real>
  Status track_prior(const Pose& prior, const FramePyramid<Real>& frame, const RaycastMaps& model,
                     const PinholeIntrinsics& intr, const IcpWorkspace<Real>& ws, TrackResult& result,
                     const RowRunner* runner = nullptr);

  //! track_prior()'s alignment and state without changing the tracker (never pushed): e.g. a frame
  //! aligned again against a map that has grown since.
  //! \param prior the frame's approximate sensor-to-world pose
  //! \param frame the frame's pyramid
  //! \param model raycast maps at `prior` (vertex and normal)
  //! \param intr the sensor's intrinsics
  //! \param ws ICP row sums
  //! \param result pose (the prior when lost), state, correction from the prior, ICP statistics
  //! \param runner optional row runner for the ICP (threads do not change the result)
  template <class Real>
  Status align_prior(const Pose& prior, const FramePyramid<Real>& frame, const RaycastMaps& model,
                     const PinholeIntrinsics& intr, const IcpWorkspace<Real>& ws, TrackResult& result,
                     const RowRunner* runner = nullptr) const;

  TrackState state() const { return state_; }      //!< of the last frame
  const Pose& last_push() const { return last_push_; }
  long frames() const { return frames_; }          //!< frames seen since start()
  const TrackerParams& params() const { return params_; }

 private:
  void push_first(TrackResult& result);
  void accept(TrackResult& result);
  void finish_frame(TrackState state);

  TrackerParams params_;
  Pose pose_;              // last good pose
  Pose velocity_;          // T_prev^-1 T_last of the last two consecutive ok frames
  bool has_velocity_ = false;
  bool last_was_ok_ = false;        // the previous frame was tracked ok
  bool last_good_degraded_ = false; // pose_ comes from a degraded frame
  long frames_since_ok_ = 0;        // frames since the last ok one (0: the previous frame was ok)
  Pose last_push_;
  bool pushed_any_ = false;
  bool space_empty_ = true;
  long frames_ = 0;
  TrackState state_ = TrackState::kOk;
};

}  // namespace edgefuse
