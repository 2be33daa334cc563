// One frame's TSDF kernels, spread over a RowRunner (the platform's threads) or run on the calling
// thread (null runner). Integration hands out chunks of kIntegrateBricksPerRow bricks, the raycast
// bands of kRaycastRowsPerRow image rows: small enough that uneven bricks and rows balance across
// cores, large enough that the hand-out costs nothing. Bricks and rows are disjoint, so the split
// never changes the result.
#pragma once

#include "edgefuse/core/row_runner.hpp"
#include "edgefuse/tsdf/integrate.hpp"
#include "edgefuse/tsdf/raycast.hpp"

namespace edgefuse {

//! Bricks per row the integration hands to the runner.
inline constexpr int kIntegrateBricksPerRow = 32;
//! Image rows per row the raycast hands to the runner: one band of the integration's tiles.
inline constexpr int kRaycastRowsPerRow = FrameScratch::kTile;

//! The runners a pipeline gives its kernels (null: the calling thread).
struct KernelRunners {
  const RowRunner* tsdf = nullptr;  //!< integration and raycast (a runner that hands out one row at a time)
  const RowRunner* icp = nullptr;   //!< ICP row sums (tracking, pair calibration)
};

//! integrate() with its bricks spread over `runner`.
//! \param runner the threads (null: the calling thread)  \param volume the space
//! \param intr the sensor  \param ray_norms |ray| per pixel  \param frame depth (colour, trust)
//! \param T_world_cam the frame's pose  \param scratch the sensor's tile scratch
//! \param trust sensor trust factor in (0, 1]
template <class Real>
Status integrate_frame(const RowRunner* runner, TsdfVolume& volume, const PinholeIntrinsics& intr,
                       ImageView<const Real> ray_norms, const DepthFrame& frame, const Pose& T_world_cam,
                       FrameScratch& scratch, float trust = 1.0f);

//! raycast() with its rows spread over `runner`.
//! \param runner the threads (null: the calling thread)  \param volume the space
//! \param intr the sensor  \param T_world_cam the pose to cast from  \param maps outputs
template <class Real>
Status raycast_frame(const RowRunner* runner, const TsdfVolume& volume, const PinholeIntrinsics& intr,
                     const Pose& T_world_cam, const RaycastMaps& maps);

}  // namespace edgefuse
