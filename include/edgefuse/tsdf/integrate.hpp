// Push (paper Fig. 3): integrate one depth image, with optional registered RGB, at a pose.
//
// The update of each voxel follows eq. (1)-(2): the voxel centre v is projected into the image at
// (u, v); the z-depth there is interpolated bilinearly from the 4 nearest pixels (nearest pixel at
// the border or where a neighbour is missing; no update where the 4 span a depth jump larger than
// the truncation, which would otherwise smear foreground onto background at silhouettes). With
// v_c the voxel in the camera frame, the measurement along v's ray is m = z |ray| and the voxel's
// range is v_c.z |ray| (|ray| from the precomputed ray-norm map), so d = (z - v_c.z) |ray| (eq. 1);
// then
//   d <= -rho                 : no update (occluded)
//   otherwise                 : tsdf <- (W tsdf + w(d) min(1, d/trunc)) / (W + w(d)), W <- min(W + w, cap)
// with w(d) the Bylow weight (weight.hpp) times the sensor's trust factor and, when the frame has
// a trust map, the pixel's trust (its noise at that range, sensor/noise_model.hpp). Colour is fused with its
// own weight where |d| < colour band.
//
// Only the bricks around the measurements (the truncation band and a free margin in front of it,
// TsdfParams::free_margin_m) and the surface bricks in view are updated (select_band_bricks): free
// space further from any surface is left as it is, observed or not, since more +1 samples there
// carry no information; a surface the camera now sees through is carved, because its bricks are
// always listed. Listed bricks are classified before their voxels
// are touched, with the min / max depth of the pixels or 8x8 pixel tiles they project onto
// (FrameScratch): entirely more than rho behind every measurement -> skipped; entirely more than
// trunc in front of every measurement of fully valid pixels -> free space, each voxel blended
// towards +1 without projection; otherwise voxel by voxel. (Boxes with small footprints are
// classified from their own pixels, larger ones from 2x2-tile windows; the voxels of a 4^3 block
// are projected a row of 4 at a time, see src/tsdf/row_projection.hpp.)
//
// Work is split in three steps so that a caller owning threads can run step 2 in parallel:
//   1. select_band_bricks: the bricks around the measurements (truncation band) and the surface
//      bricks in view (carving) -> volume.brick_list(); free space elsewhere is not touched
//   2. integrate_bricks<Real>(..., begin, end) over slices of that list (bricks are disjoint)
//   3. finish_integration: propagates surface flags to neighbouring bricks (serial, cheap)
// integrate() does all three on the calling thread.
#pragma once

#include <cstddef>
#include <cstdint>

#include "edgefuse/core/image.hpp"
#include "edgefuse/core/status.hpp"
#include "edgefuse/math/pose.hpp"
#include "edgefuse/math/real.hpp"
#include "edgefuse/sensor/pinhole.hpp"
#include "edgefuse/tsdf/frame_scratch.hpp"
#include "edgefuse/tsdf/volume.hpp"

namespace edgefuse {

//! One depth frame to push.
struct DepthFrame {
  ImageView<const uint16_t> depth;  //!< raw z-depth, metres = raw / intrinsics.depth_scale, 0 = none
  ImageView<const Rgb8> colour;     //!< optional, pixel-registered to depth (empty: no colour)
  //! Optional per-pixel trust in 1/255 from the sensor's noise model (sensor/noise_model.hpp):
  //! scales the weight of the samples read from that pixel (empty: full trust everywhere).
  ImageView<const uint8_t> trust = {};
  //! Depth difference (metres) between the pixels a voxel interpolates from that counts as a
  //! discontinuity (no update there); 0: the truncation distance. A sensor whose per-pixel noise
  //! is of the order of the truncation (ToF) needs more, or its noise alone reads as depth edges
  //! and most of its samples are dropped - selectively: at slopes only those whose noise happens
  //! to cancel the slope pass (docs/BENCHMARKS.md, "Multi-sensor fusion").
  float jump_m = 0.0f;
  //! Weight units up to which samples worth less than half a unit (trust map) still fill a voxel,
  //! one unit each (voxel_update.hpp scale_by_trust), 1..255: 8 (one full sample, the default) keeps
  //! a noisy sensor's lone surface; a mixed set lowers it below the support rule
  //! (fusion_rules.hpp kSubUnitFillUnits) so such a voxel never passes for a good sensor's frame.
  int sub_unit_fill_units = kWeightUnitsPerSample;
};

//! Everything integrate_bricks needs, converted once per frame to the kernel scalar.
template <class Real>
struct IntegrationJob {
  Real R[9];                 //!< rotation of T_cam_world, row-major
  Real t[3];                 //!< translation of T_cam_world
  Real fx, fy, cx, cy;
  Real min_z, max_z;         //!< valid measured z-depth
  DepthScale<Real> depth;    //!< raw depth -> metres
  Real trunc, inv_trunc;     //!< truncation and its inverse
  Real eps, rho;             //!< weight band
  Real band_to_index;        //!< 256 / (rho - eps): weight table index per metre behind -eps
  Real colour_band;
  Real voxel;
  Real origin[3];
  float voxel_m;             //!< exact voxel size and origin, to place each brick once
  float origin_m[3];
  uint32_t trust_q8 = 256;   //!< sensor trust factor in 1/256 (256 = full)
  //! Paint pass (colour_pass.hpp): only the colour of observed voxels near the depth image's
  //! surface is updated; distances, weights and free space are left alone.
  bool colour_only = false;
  uint32_t jump_raw = 0;     //!< raw depth difference counted as a discontinuity (frame.jump_m, else trunc)
  int32_t sub_unit_fill = kWeightUnitsPerSample;  //!< frame.sub_unit_fill_units
  //! Raw depths r with min_z <= metres(r) <= max_z: r - raw_in_range_lo <= raw_in_range_span (unsigned)
  uint32_t raw_in_range_lo = 0, raw_in_range_span = 0;
  Real jump;                 //!< the same in metres
  DepthFrame frame;
  ImageView<const Real> ray_norms;
  const DepthTile* tiles = nullptr;
  int tiles_x = 0, tiles_y = 0;
  int width = 0, height = 0;
};

//! Builds the per-frame job (and the frame's depth tiles). Fails when sizes disagree or
//! parameters are out of range.
//! \param volume the space (initialised)
//! \param intr intrinsics of the depth image
//! \param ray_norms |ray| per pixel (build_ray_norms), same size as the image
//! \param frame depth (and optional colour) of this frame
//! \param T_world_cam sensor-to-world pose of this frame
//! \param trust sensor trust factor in (0, 1] scaling the weight (1 = full)
//! \param scratch the sensor's tile scratch (fits the image)
//! \param job output
template <class Real>
Status prepare_integration(const TsdfVolume& volume, const PinholeIntrinsics& intr, ImageView<const Real> ray_norms,
                           const DepthFrame& frame, const Pose& T_world_cam, float trust, FrameScratch& scratch,
                           IntegrationJob<Real>& job);

//! Step 1: the bricks this frame updates, written to volume.brick_list() (returns how many):
//! those holding voxels within -rho..trunc + free margin of a measurement they may read, and the surface bricks
//! inside the frustum (src/tsdf/band_select.cpp). Marks them kBrickListed until
//! finish_integration. Computed in float in both numeric builds (the same list).
//! \param volume the space
//! \param intr intrinsics of the depth image (bounds, range limits, depth scale)
//! \param frame the frame's depth (and its jump_m)
//! \param T_world_cam sensor pose
std::size_t select_band_bricks(TsdfVolume& volume, const PinholeIntrinsics& intr, const DepthFrame& frame,
                               const Pose& T_world_cam);

//! Every brick inside the frustum, written to volume.brick_list(); returns how many. The colour
//! pass (colour_pass.hpp) paints what it sees with it. It gives no brick a pool slot:
//! integrate_bricks skips the listed bricks that have none.
//! \param volume the space
//! \param intr intrinsics (image bounds and range limits)
//! \param T_world_cam sensor pose
std::size_t select_bricks(TsdfVolume& volume, const PinholeIntrinsics& intr, const Pose& T_world_cam);

//! Step 2: updates bricks list[begin, end) of volume.brick_list(). Thread-safe for disjoint ranges.
template <class Real>
void integrate_bricks(TsdfVolume& volume, const IntegrationJob<Real>& job, std::size_t begin, std::size_t end);

//! Step 3: marks the neighbours of surface bricks among the first `count` listed bricks and clears
//! their kBrickListed mark.
void finish_integration(TsdfVolume& volume, std::size_t count);

//! All three steps on the calling thread.
template <class Real>
Status integrate(TsdfVolume& volume, const PinholeIntrinsics& intr, ImageView<const Real> ray_norms,
                 const DepthFrame& frame, const Pose& T_world_cam, FrameScratch& scratch, float trust = 1.0f);

}  // namespace edgefuse
