// The paper's second fusion mode (section 3.3): each sensor maps alone into its own space; the two
// spaces' surfaces are aligned to get the transform between the maps.
//
// Both spaces are seen from one virtual pinhole view V (in the model space): the other space is
// raycast at the believed alignment (T_model_other^-1 V) and its depth map is registered to the
// model space exactly as a sensor frame is in calibrate_pair() (coarse-to-fine ICP against the
// model raycast, the same acceptance tests: all six directions constrained, residual, inliers).
// The correction found in V's frame updates the alignment, T_model_other <- V T_corr V^-1
// T_model_other, and the other space is raycast again at the new alignment (occlusions change
// with it) for `outer_rounds` rounds.
// For two rigidly mounted sensors whose maps start at their first poses, T_model_other is the
// mounting T_A_B.
#pragma once

#include "edgefuse/fusion/calibrate_pair.hpp"

namespace edgefuse {

//! Aligns `other` to `model`.
//! \param model the reference space
//! \param other the space to align
//! \param view_intr intrinsics of the virtual view (its maps and pyramid must fit them)
//! \param T_model_view pose of the virtual view in the model space (should see both surfaces)
//! \param T_model_other_guess initial alignment (maps other-space points into the model space)
//! \param pyramid pyramid storage for the view
//! \param model_maps raycast maps of the view's size (model space; overwritten)
//! \param other_maps raycast maps of the view's size (other space; overwritten)
//! \param depth_scratch raw depth image of the view's size (the other space's depth)
//! \param ws ICP row sums
//! \param params stages and acceptance thresholds
//! \param outer_rounds re-raycasts of the other space (>= 1)
//! \param out result; out.T_a_b is T_model_other
template <class Real>
Status align_spaces(const TsdfVolume& model, const TsdfVolume& other, const PinholeIntrinsics& view_intr,
                    const Pose& T_model_view, const Pose& T_model_other_guess, FramePyramid<Real>& pyramid,
                    const RaycastMaps& model_maps, const RaycastMaps& other_maps, ImageView<uint16_t> depth_scratch, const IcpWorkspace<Real>& ws,
                    const PairCalibrationParams& params, int outer_rounds, PairCalibrationResult& out);

}  // namespace edgefuse
