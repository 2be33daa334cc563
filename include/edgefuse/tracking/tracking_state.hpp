// Tracking state of a frame: ok / degraded / lost, from the ICP's residual, inlier ratio and how
// far the pose jumped from the last good one.
//   lost      the ICP refused the frame (too few inliers, fewer observable directions than asked),
//             or inlier ratio < lost_inlier_ratio, or RMS > lost_rms_m, or the pose moved more than
//             max_jump_m / max_jump_deg from the last good pose: the result is not trusted, the
//             frame is not pushed, the last good pose is kept;
//   degraded  otherwise, when inlier ratio < ok_inlier_ratio, RMS > ok_rms_m, or some direction
//             was not observable (the pose there is the prediction): used and pushed, but flagged;
//   ok        everything else.
#pragma once

#include <cstdint>

#include "edgefuse/tracking/icp.hpp"

namespace edgefuse {

enum class TrackState : uint8_t { kOk, kDegraded, kLost };

//! "ok", "degraded", "lost".
const char* to_string(TrackState s);

struct StateThresholds {
  //! Below this inlier ratio (IcpStats::inlier_ratio: of the frame points that land on a
  //! like-oriented model surface, the share within max_distance_m of it) the frame is degraded.
  //! Default 0.8. Measured on aligned frames: 0.98-1.00 (TUM fr1/xyz, 7-Scenes, bin_rig_a xtion
  //! and ToF, the test scenes); right after a 30 cm jump: 0.02-0.10.
  float ok_inlier_ratio = 0.8f;
  //! Below this inlier ratio the frame is lost. Default 0.3: three times the jump's worst value,
  //! far below any aligned frame.
  float lost_inlier_ratio = 0.3f;
  //! Above this point-to-plane RMS (metres) the frame is degraded. Default 0.01 m: twice the
  //! Kinect-class noise at 1.5 m (measured on aligned frames: 0.3-0.5 mm bin_rig_a xtion, 2.4 mm
  //! TUM fr1/xyz, 2.9 mm bin_rig_a ToF, 5.4 mm 7-Scenes at 2-3 m).
  float ok_rms_m = 0.01f;
  //! Above this RMS it is lost. Default 0.02 m: with max_distance 0.05 m a converged alignment
  //! of the right surfaces stays far below it, a wrong one approaches uniform residuals (~0.029 m).
  float lost_rms_m = 0.02f;
  //! A translation from the last good pose above this (per frame since the last ok frame; the
  //! tracker skips the test right after a degraded frame) is a jump: lost. Default 0.1 m (3 m/s
  //! at 30 Hz, twice a robot's fast approach speed).
  float max_jump_m = 0.1f;
  //! A rotation from the last good pose above this is a jump: lost. Default 15 degrees
  //! (450 deg/s at 30 Hz).
  float max_jump_deg = 15.0f;

  //! 0 <= lost ratio <= ok ratio <= 1, 0 < ok rms <= lost rms, positive jumps.
  bool valid() const {
    return lost_inlier_ratio >= 0.0f && ok_inlier_ratio >= lost_inlier_ratio && ok_inlier_ratio <= 1.0f &&
           ok_rms_m > 0.0f && lost_rms_m >= ok_rms_m && max_jump_m > 0.0f && max_jump_deg > 0.0f;
  }
};

//! The state of one aligned frame.
//! \param icp the ICP's statistics  \param jump_m translation from the last good pose
//! \param jump_rad rotation from the last good pose  \param th thresholds
TrackState classify_frame(const IcpStats& icp, float jump_m, float jump_rad, const StateThresholds& th);

}  // namespace edgefuse
