// Raycasting a pinhole sensor's view out of the space (paper Fig. 3, "model <- raycast").
//
// First the marked 2^3-voxel blocks of the surface bricks (the blocks holding a distance at or
// below 0) are projected into the image (prepare_raycast): each pixel gets the z range in which its ray can
// meet a zero crossing, from the blocks facing the sensor (near end) and facing away (far end);
// the range is kept in the depth map's own floats until the march reads it. A ray starts a voxel
// before its range and stops a voxel after it; pixels no marked block covers are not marched.
// Then for every pixel the ray from the sensor centre is marched through the volume:
//   - bricks without surface nearby (kBrickNearSurface clear) are skipped whole;
//   - inside, the step is the interpolated distance itself (at least half a voxel), so free space
//     is crossed quickly and the surface is never stepped over by more than the distance bound;
//   - the + to - zero crossing is refined by regula falsi on the trilinear TSDF;
//   - normals come from the TSDF gradient (central differences), colour is trilinear.
// Outputs are organised by pixel and expressed in the sensor frame.
#pragma once

#include <cstdint>

#include "edgefuse/core/image.hpp"
#include "edgefuse/core/status.hpp"
#include "edgefuse/math/pose.hpp"
#include "edgefuse/sensor/pinhole.hpp"
#include "edgefuse/tsdf/volume.hpp"

namespace edgefuse {

//! Output maps, each intr.width x intr.height (vertex/normal/colour may be empty to skip them).
struct RaycastMaps {
  ImageView<float> depth_m;  //!< z-depth of the hit, 0 = no surface
  ImageView<Vec3f> vertex;   //!< hit point in the sensor frame (0 = none)
  ImageView<Vec3f> normal;   //!< unit surface normal in the sensor frame, facing the sensor (0 = none)
  ImageView<Rgba8> colour;   //!< a = 255 where colour was fused, a = 0 otherwise
};

//! Largest volume dim() the raycast handles (its per-axis index tables live on the stack);
//! prepare_raycast refuses larger volumes with kCapacityExceeded.
inline constexpr int kRaycastDimMax = 1024;

//! Step 1: checks the outputs and projects the marked blocks into per-pixel z ranges, kept in
//! maps.depth_m until raycast_rows overwrites each pixel (call raycast_rows on every row after it).
//! \param volume the space
//! \param intr sensor intrinsics (min/max range bound the ray)
//! \param T_world_cam sensor pose
//! \param maps outputs (checked against intr; the ranges need no other memory)
Status prepare_raycast(const TsdfVolume& volume, const PinholeIntrinsics& intr, const Pose& T_world_cam,
                       const RaycastMaps& maps);

//! Step 2: rows [row_begin, row_end) of the raycast. Thread-safe for disjoint row ranges.
template <class Real>
void raycast_rows(const TsdfVolume& volume, const PinholeIntrinsics& intr, const Pose& T_world_cam,
                  const RaycastMaps& maps, int row_begin, int row_end);

//! Both steps, the whole image on the calling thread.
//! \param volume the space
//! \param intr sensor intrinsics
//! \param T_world_cam sensor pose
//! \param maps outputs (checked against intr)
template <class Real>
Status raycast(const TsdfVolume& volume, const PinholeIntrinsics& intr, const Pose& T_world_cam,
               const RaycastMaps& maps);

//! Trilinear TSDF at a world point, in metres (distance * trunc); false where any of the 8
//! voxels is unobserved or the point is outside the volume.
template <class Real>
bool sample_tsdf(const TsdfVolume& volume, const Vec3f& p_world, float& d_m);

}  // namespace edgefuse
