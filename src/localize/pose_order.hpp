// Orders and groupings of poses shared by the localiser's rounds (PPF voting, rest poses,
// acceptance, picking order, segments). Private to src/localize.
#pragma once
#include <algorithm>
#include <cmath>

#include "edgefuse/localize/localize_types.hpp"
#include "ppf_math.hpp"

namespace edgefuse {

//! A total order on poses (translation, then rotation) so that sorts need no stability.
inline bool pose_less(const Pose& a, const Pose& b) {
  for (int i = 0; i < 3; ++i)
    if (a.t[i] != b.t[i]) return a.t[i] < b.t[i];
  for (int i = 0; i < 9; ++i)
    if (a.R.data()[i] != b.R.data()[i]) return a.R.data()[i] < b.R.data()[i];
  return false;
}

//! Strongest candidate first, ties by pose (std::sort with full tie-breaks: stable_sort would
//! allocate a buffer).
inline bool votes_then_pose(const PoseCandidate& a, const PoseCandidate& b) {
  if (a.votes != b.votes) return a.votes > b.votes;
  return pose_less(a.T_world_object, b.T_world_object);
}

//! Angle of the rotation between A and B (radians).
inline float rot_angle(const Mat3f& A, const Mat3f& B) {
  const float c = 0.5f * ((A.transpose() * B).trace() - 1.0f);
  return std::acos(ppf::clamp_unit(c));
}

//! Greedy pose clustering's test: translations within dt_m and rotations within dr_rad.
inline bool same_pose_cluster(const Pose& a, const Pose& b, float dt_m, float dr_rad) {
  return (a.t - b.t).norm() < dt_m && rot_angle(a.R, b.R) < dr_rad;
}

//! Picking order key: highest first; an occluded object (low supported share) counts up to 5 cm lower.
inline float picking_key(const LocalizedObject& o) { return o.top_m - 0.05f * (1.0f - std::min(o.score, 1.0f)); }

}  // namespace edgefuse
