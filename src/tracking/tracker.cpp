#include "edgefuse/tracking/tracker.hpp"

#include "edgefuse/tracking/se3.hpp"

namespace edgefuse {

namespace {

int rank(TrackState s) { return s == TrackState::kOk ? 2 : (s == TrackState::kDegraded ? 1 : 0); }

// Second start (standstill) better than the first (constant velocity): a better state; or, when
// the view leaves directions unobservable, the same state (the standstill keeps the last pose in
// those directions instead of extrapolating a motion nobody can check); else more inliers.
bool better(const TrackResult& a, const TrackResult& b) {
  if (rank(b.state) != rank(a.state)) return rank(b.state) > rank(a.state);
  if (b.icp.observable < 6) return true;
  return b.icp.correspondences > a.icp.correspondences;
}

}  // namespace

Status Tracker::start(const Pose& initial, const TrackerParams& params, bool space_empty) {
  if (!params.valid()) return Status::kInvalidArgument;
  params_ = params;
  pose_ = initial;
  velocity_ = Pose::identity();
  has_velocity_ = false;
  last_was_ok_ = false;
  last_good_degraded_ = false;
  frames_since_ok_ = 0;
  last_push_ = initial;
  pushed_any_ = false;
  space_empty_ = space_empty;
  frames_ = 0;
  state_ = TrackState::kOk;
  return Status::kOk;
}

// Nothing to align to: the first frame defines the space at the initial pose.
void Tracker::push_first(TrackResult& result) {
  space_empty_ = false;
  result.T_world_cam = pose_;
  result.first = true;
  result.push = true;
  last_push_ = pose_;
  pushed_any_ = true;
  last_was_ok_ = true;
  frames_since_ok_ = 0;
  state_ = TrackState::kOk;
}

// A frame tracked ok or degraded becomes the current pose; it is pushed when the camera has moved
// enough since the last push.
void Tracker::accept(TrackResult& result) {
  pose_ = result.T_world_cam;
  last_good_degraded_ = result.state != TrackState::kOk;
  result.push = !pushed_any_ || moved_enough_to_push(params_.push, last_push_, pose_);
  if (result.push) {
    last_push_ = pose_;
    pushed_any_ = true;
  }
}

void Tracker::finish_frame(TrackState state) {
  const bool ok = state == TrackState::kOk;
  last_was_ok_ = ok;
  frames_since_ok_ = ok ? 0 : frames_since_ok_ + 1;
  state_ = state;
}

template <class Real>
Status Tracker::track(const FramePyramid<Real>& frame, const RaycastMaps& model, const PinholeIntrinsics& intr,
                      const IcpWorkspace<Real>& ws, TrackResult& result, const RowRunner* runner) {
  result = TrackResult{};
  ++frames_;
  if (space_empty_) {
    push_first(result);
    return Status::kOk;
  }
  // The jump test allows max_jump per frame since the last ok frame (the sensor kept moving while
  // tracking was lost), and is skipped after a degraded frame: its unobservable directions held
  // the prediction, so the first frame that observes them again may legitimately move further.
  const float elapsed = float(frames_since_ok_ + 1);

  // Starts, as T_model_frame (the model is raycast at pose_): constant velocity, then standstill.
  Pose starts[2];
  int n_starts = 0;
  if (has_velocity_) starts[n_starts++] = velocity_;
  starts[n_starts++] = Pose::identity();

  TrackResult best;
  bool have = false;
  for (int i = 0; i < n_starts; ++i) {
    TrackResult r;
    r.start = has_velocity_ ? i : 1;
    Pose T_model_frame;
    const Status s = icp_align(frame, model, intr, starts[i], params_.icp, ws, T_model_frame, r.icp, runner);
    if (s != Status::kOk) return s;
    r.T_world_cam = pose_ * T_model_frame;
    r.T_world_cam.R = orthonormalise(r.T_world_cam.R);
    float angle;
    pose_distance(pose_, r.T_world_cam, r.jump_m, angle);
    r.jump_deg = angle * 180.0f / 3.14159265f;
    r.state = last_good_degraded_ ? classify_frame(r.icp, 0.0f, 0.0f, params_.state)
                                  : classify_frame(r.icp, r.jump_m / elapsed, angle / elapsed, params_.state);
    if (!have || better(best, r)) best = r;
    have = true;
    result.attempts = i + 1;
    if (best.state == TrackState::kOk) break;
  }
  const int attempts = result.attempts;
  result = best;
  result.attempts = attempts;

  const bool ok = result.state == TrackState::kOk;
  if (result.state == TrackState::kLost) {
    result.T_world_cam = pose_;  // keep the last good pose, push nothing
    result.push = false;
  } else {
    // The velocity is only known from two consecutive frames tracked ok (all six directions); a
    // degraded frame's motion in unobservable directions was not measured, so it is not
    // extrapolated (on a plane the in-plane position then never drifts on a guessed velocity).
    // A lost frame keeps the last velocity: the constant-velocity start is tried when frames return.
    if (last_was_ok_ && ok) {
      velocity_ = pose_.inverse() * result.T_world_cam;
      has_velocity_ = true;
    } else if (!ok) {
      has_velocity_ = false;
    }
    accept(result);
  }
  finish_frame(result.state);
  return Status::kOk;
}

template <class Real>
Status Tracker::align_prior(const Pose& prior, const FramePyramid<Real>& frame, const RaycastMaps& model,
                            const PinholeIntrinsics& intr, const IcpWorkspace<Real>& ws, TrackResult& result,
                            const RowRunner* runner) const {
  result = TrackResult{};
  // The model was raycast at the prior: the ICP starts there (identity in the model frame).
  Pose T_model_frame;
  const Status s = icp_align(frame, model, intr, Pose::identity(), params_.icp, ws, T_model_frame, result.icp, runner);
  if (s != Status::kOk) return s;
  result.start = 2;
  result.attempts = 1;
  result.T_world_cam = prior * T_model_frame;
  result.T_world_cam.R = orthonormalise(result.T_world_cam.R);
  float angle;
  pose_distance(prior, result.T_world_cam, result.jump_m, angle);
  result.jump_deg = angle * 180.0f / 3.14159265f;
  // Each frame has its own prior: the correction is not accumulated over frames (no elapsed scaling).
  result.state = classify_frame(result.icp, result.jump_m, angle, params_.state);
  if (result.state == TrackState::kLost) result.T_world_cam = prior;  // robot and data disagree
  return Status::kOk;
}

template <class Real>
Status Tracker::track_prior(const Pose& prior, const FramePyramid<Real>& frame, const RaycastMaps& model,
                            const PinholeIntrinsics& intr, const IcpWorkspace<Real>& ws, TrackResult& result,
                            const RowRunner* runner) {
  ++frames_;
  pose_ = prior;
  if (space_empty_) {
    result = TrackResult{};
    push_first(result);
    return Status::kOk;
  }
  const Status s = align_prior(prior, frame, model, intr, ws, result, runner);
  if (s != Status::kOk) return s;
  has_velocity_ = false;  // the prior replaces the constant-velocity prediction
  if (result.state != TrackState::kLost) {  // a lost frame is not pushed
    accept(result);
  }
  finish_frame(result.state);
  return Status::kOk;
}

template Status Tracker::align_prior<float>(const Pose&, const FramePyramid<float>&, const RaycastMaps&,
                                            const PinholeIntrinsics&, const IcpWorkspace<float>&, TrackResult&,
                                            const RowRunner*) const;
template Status Tracker::align_prior<Fixed>(const Pose&, const FramePyramid<Fixed>&, const RaycastMaps&,
                                            const PinholeIntrinsics&, const IcpWorkspace<Fixed>&, TrackResult&,
                                            const RowRunner*) const;
template Status Tracker::track_prior<float>(const Pose&, const FramePyramid<float>&, const RaycastMaps&,
                                            const PinholeIntrinsics&, const IcpWorkspace<float>&, TrackResult&,
                                            const RowRunner*);
template Status Tracker::track_prior<Fixed>(const Pose&, const FramePyramid<Fixed>&, const RaycastMaps&,
                                            const PinholeIntrinsics&, const IcpWorkspace<Fixed>&, TrackResult&,
                                            const RowRunner*);
template Status Tracker::track<float>(const FramePyramid<float>&, const RaycastMaps&, const PinholeIntrinsics&,
                                      const IcpWorkspace<float>&, TrackResult&, const RowRunner*);
template Status Tracker::track<Fixed>(const FramePyramid<Fixed>&, const RaycastMaps&, const PinholeIntrinsics&,
                                      const IcpWorkspace<Fixed>&, TrackResult&, const RowRunner*);

}  // namespace edgefuse
