#include "edgefuse/tracking/tracking_state.hpp"

namespace edgefuse {

const char* to_string(TrackState s) {
  switch (s) {
    case TrackState::kOk: return "ok";
    case TrackState::kDegraded: return "degraded";
    case TrackState::kLost: return "lost";
  }
  return "unknown";
}

TrackState classify_frame(const IcpStats& icp, float jump_m, float jump_rad, const StateThresholds& th) {
  const float ratio = icp.inlier_ratio();
  const float max_jump_rad = th.max_jump_deg * 3.14159265f / 180.0f;
  if (icp.refused || ratio < th.lost_inlier_ratio || icp.rms_m > th.lost_rms_m || jump_m > th.max_jump_m ||
      jump_rad > max_jump_rad)
    return TrackState::kLost;
  if (ratio < th.ok_inlier_ratio || icp.rms_m > th.ok_rms_m || icp.observable < 6) return TrackState::kDegraded;
  return TrackState::kOk;
}

}  // namespace edgefuse
