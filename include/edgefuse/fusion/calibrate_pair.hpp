// Calibration of two rigidly mounted sensors from the data (paper section 3.3, Fig. 6, FUSESENSORS):
// the space is filled by sensor A; with the rig still, the space is raycast at sensor B's guessed
// pose (T_world_A T_A_B) and B's frame is registered to that model by the point-to-plane ICP of the
// tracking module; the correction gives T_A_B.
//
// Coarse to fine: the ICP runs in stages of shrinking association windows (wide first, so that a
// hand-measured guess a few centimetres and degrees off still finds its partners), each stage a
// few rounds of raycast + ICP (the model is re-raycast at the improved pose so that the projective
// association stays correct for large corrections).
//
// Acceptance (all must hold, otherwise `accepted` is false and `reason` says what is missing):
//   - the model seen from B constrains all six directions (observability.hpp on the final raycast;
//     a single plane constrains three: "scene is a single plane"), and the ICP solved in all six;
//   - enough correspondences for B's resolution (a fraction of its pixels, and a floor), point-to-
//     plane RMS below max_rms_m, inlier ratio above min_inlier_ratio;
//   - the evidence: the 1-sigma of every direction (below) within max_sigma_m / max_sigma_deg. A
//     sensor that sees little of the map is accepted when what it sees determines the mounting.
// Uncertainty: cov(xi) = s^2 A^-1 with A = sum J^T J over the final inliers and s^2 = sum r^2 /
// (n - 6), xi = (omega, v) in B's frame; sigma = sqrt(diag). Neighbouring pixels' residuals are
// correlated (the TSDF smooths over a few voxels, the sensor noise is per pixel), so this is a
// lower bound; the spread over several frames (edgefuse calibrate --frames) is the honest figure.
#pragma once

#include "edgefuse/core/status.hpp"
#include "edgefuse/math/pose.hpp"
#include "edgefuse/tracking/icp.hpp"
#include "edgefuse/tsdf/raycast.hpp"
#include "edgefuse/tsdf/volume.hpp"

namespace edgefuse {

struct PairCalibrationParams {
  static constexpr int kMaxStages = 4;
  int stages = 3;  //!< association stages, wide to fine (<= kMaxStages)
  //! Association window per stage. Defaults 60 / 20 / 8 mm: the first catches a guess ~5 cm off
  //! (a hand measurement of a mounting), the last is ~2 x the ToF noise at 0.7 m.
  float max_distance_m[kMaxStages] = {0.06f, 0.02f, 0.008f, 0.008f};
  float max_normal_deg[kMaxStages] = {60.0f, 40.0f, 30.0f, 30.0f};  //!< normal compatibility per stage
  int rounds_per_stage = 3;      //!< raycast + ICP rounds per stage
  float max_rms_m = 0.006f;      //!< accept: point-to-plane RMS of the inliers (ToF noise ~ 4-7 mm)
  float min_inlier_ratio = 0.6f; //!< accept: inliers / candidates
  int min_correspondences = 60;  //!< accept: inliers at full resolution, at least (ten per unknown)
  //! accept: inliers at full resolution, at least this fraction of B's pixels (500 at 320x240, 125 at
  //! 160x120)
  float min_pixel_fraction = 0.0065f;
  float max_sigma_m = 0.003f;    //!< accept: 1-sigma of each translation component
  float max_sigma_deg = 0.3f;    //!< accept: 1-sigma of each rotation component
  float min_eigen_ratio = 1e-4f; //!< observability threshold (as IcpParams::min_eigen_ratio)
  int observability_tiles = 10;  //!< tiles across the width for the observability system

  bool valid() const;
  //! The inliers a fit of a `pixels`-pixel image needs. \param pixels B's width x height
  int required_correspondences(int pixels) const;
};

struct PairCalibrationResult {
  Pose T_a_b;                 //!< the estimate (the guess when nothing could be aligned)
  bool accepted = false;      //!< all acceptance tests passed
  char reason[200] = {};      //!< why not accepted ("" when accepted)
  float rms_m = 0;            //!< point-to-plane RMS of the final inliers
  float inlier_ratio = 0;     //!< inliers / candidates of the final evaluation
  int correspondences = 0;    //!< final inliers
  int observable = 0;         //!< directions the scene constrains, seen from B (6 = all)
  float weakest_ratio = 0;    //!< smallest / largest eigenvalue of the observability system
  Vec6f sigma = Vec6f::Zero();  //!< 1-sigma of (rotation about x, y, z in rad; translation x, y, z in m), B frame
};

//! Registers B's frame to the space filled by A.
//! \param volume the space filled by sensor A
//! \param T_world_a A's pose at the still frame
//! \param T_a_b_guess initial mounting (pose of B in A's frame)
//! \param intr_b B's intrinsics
//! \param frame_b B's frame at the still pose (pyramid, after B's pre-filters)
//! \param maps_b raycast maps of B's size (depth, vertex, normal; overwritten)
//! \param ws ICP row sums (>= intr_b.height rows)
//! \param params stages and acceptance thresholds
//! \param out result
//! \param runner optional ICP row runner
template <class Real>
Status calibrate_pair(const TsdfVolume& volume, const Pose& T_world_a, const Pose& T_a_b_guess,
                      const PinholeIntrinsics& intr_b, const FramePyramid<Real>& frame_b, const RaycastMaps& maps_b,
                      const IcpWorkspace<Real>& ws, const PairCalibrationParams& params,
                      PairCalibrationResult& out, const RowRunner* runner = nullptr);

}  // namespace edgefuse
