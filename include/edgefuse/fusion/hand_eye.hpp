// Hand-eye calibration, AX = XB: the pose X = T_flange_cam of a camera on a robot's flange, from
// stations where both the flange pose (the robot's) and the camera pose (measured from the data,
// in any one fixed frame, e.g. a map) are known.
//
// For every pair of stations (i, j), i < j:
//   A_ij = A_i^-1 A_j   the flange's motion in flange frame i (A_i = T_base_flange at station i),
//   B_ij = C_i^-1 C_j   the camera's motion in camera frame i (C_i = T_map_cam at station i),
// and A_ij X = X B_ij. Both motions are relative, so neither the robot's base nor the map need to
// be placed anywhere in particular. Steps:
//   1. rotation (Park & Martin 1994): the rotation vectors a = log R_A, b = log R_B of all pairs
//      satisfy a = R_X b; R_X = (M^T M)^-1/2 M^T with M = sum b a^T, computed as the rotation
//      nearest to M^T (SVD; the same for a full-rank M, and always a proper rotation);
//   2. translation: (R_A - I) t_X = R_X t_B - t_A for all pairs, by least squares;
//   3. refinement: Gauss-Newton on (R_X, t_X) over all pairs, residuals
//        rotation     e_R = log(R_A R_X R_B^T R_X^T)      (d e_R / d phi = R_A - I)
//        translation  e_t = R_A t_X + t_A - R_X t_B - t_X (d e_t / d phi = [R_X t_B]x, / d t_X = R_A - I)
//      with X's rotation perturbed on the left (R_X <- Exp(phi) R_X, phi in the flange frame), each
//      block weighted by the inverse of its residual variance (radians and metres are not
//      comparable: the data says how well each is measured).
// Uncertainty: cov = s^2 H^-1 (H the weighted normal matrix, s^2 the weighted residual variance),
// scaled by P / (n - 1): the P = n (n - 1) / 2 pairs share their n stations, so their residuals
// are correlated and carry the information of n - 1 independent motions, not of P (checked by
// Monte Carlo in tests/test_fusion_hand_eye.cpp: the scaled sigma matches the spread of repeated
// solves within the test's tolerance; the unscaled one is too small by about sqrt(n / 2)).
// Per station: the camera pose the robot predicts, T_map_base A_i X (T_map_base the mean over the
// stations of C_i X^-1 A_i^-1), against the one measured, C_i, in mm and degrees.
//
// Refusals (solved = false, reason says why): fewer than 3 stations; relative rotations all below
// min_rotation_deg (the axes are noise); all relative rotations about one axis (rotation about it
// and translation along it are free).
// Static capacity (kHandEyeStationsMax), fixed-size Eigen types, no heap, no OS calls; double
// inside (the translation step subtracts metre-sized products to sub-millimetre accuracy).
#pragma once

#include "edgefuse/core/status.hpp"
#include "edgefuse/math/pose.hpp"

namespace edgefuse {

//! Most stations one solve takes (32 stations give 496 pairs).
inline constexpr int kHandEyeStationsMax = 32;

struct HandEyeParams {
  //! Refused when no pair of stations is rotated by more than this. Default 2 degrees: a rotation
  //! axis estimated from a smaller rotation scatters by ~(rotation noise / angle) rad, which at a
  //! robot's ~0.02 degrees and a camera's ~0.05 degrees is already a few degrees of axis.
  float min_rotation_deg = 2.0f;
  //! Refused when the rotation vectors' second principal spread is below this fraction of the
  //! first: all rotations (nearly) about one axis, which leaves X's rotation about it and its
  //! translation along it free. Default 0.05: a second axis with 5 % of the motion (1.2 degrees
  //! RMS against 25) still pins it; one-axis motion with robot-grade noise gives ~0.001.
  float min_axis_ratio = 0.05f;
  //! Gauss-Newton iterations at most. Default 10 (converges in 2-4 from Park & Martin's start).
  int iterations = 10;
  //! Stops when the update's rotation is below this (rad) ... Default 1e-9 (the float inputs carry ~1e-7).
  double stop_rotation_rad = 1e-9;
  //! ... and its translation below this (m). Default 1e-9.
  double stop_translation_m = 1e-9;

  //! Positive thresholds, at least one iteration.
  bool valid() const {
    return min_rotation_deg > 0.0f && min_axis_ratio > 0.0f && min_axis_ratio < 1.0f && iterations >= 1 &&
           stop_rotation_rad > 0.0 && stop_translation_m > 0.0;
  }
};

struct HandEyeResult {
  bool solved = false;           //!< X determined (else `reason`)
  char reason[160] = {};         //!< why not solved ("" when solved)
  Pose T_flange_cam;             //!< X, refined (the closed form's when refinement could not run)
  Pose closed_form;              //!< X from Park & Martin and the linear translation, before refinement
  Pose T_map_base;               //!< the robot's base in the camera poses' frame (mean over stations)
  int stations = 0;              //!< stations used
  int pairs = 0;                 //!< station pairs (n (n - 1) / 2)
  int iterations = 0;            //!< Gauss-Newton iterations run
  float rms_rotation_deg = 0;    //!< RMS of |e_R| over the pairs
  float rms_translation_m = 0;   //!< RMS of |e_t| over the pairs
  float largest_rotation_deg = 0;  //!< largest relative rotation of the flange between two stations
  float axis_ratio = 0;          //!< second / first principal spread of the flange's rotation vectors
  Vec6f sigma = Vec6f::Zero();   //!< 1-sigma of X: rotation about flange x, y, z (rad), translation x, y, z (m)
  //! Per station: translation (m) and rotation (deg) between the camera pose the robot predicts,
  //! T_map_base A_i X, and the one measured, C_i.
  float station_residual_m[kHandEyeStationsMax] = {};
  float station_residual_deg[kHandEyeStationsMax] = {};  //!< see station_residual_m
};

//! Solves A_ij X = X B_ij over all pairs of stations; see the file comment.
//! \param T_base_flange the flange pose at each station (A_i, flange-to-base)
//! \param T_map_cam the camera pose at the same stations, measured in one fixed frame (C_i)
//! \param count stations, at most kHandEyeStationsMax
//! \param params refusal thresholds and iterations
//! \param out the result; out.solved false with out.reason when the motion does not determine X
//! \return kInvalidArgument for a count above the capacity, null poses or bad params; else kOk
//!         (also when refused: that is a property of the data, not an error)
Status solve_hand_eye(const Pose* T_base_flange, const Pose* T_map_cam, int count, const HandEyeParams& params,
                      HandEyeResult& out);

}  // namespace edgefuse
