// The core's integration and raycast spread over a WorkerPool. Work is handed out in small chunks
// from an atomic counter so that uneven bricks / rows balance across cores; nothing is allocated.
#pragma once

#include "edgefuse/tsdf/integrate.hpp"
#include "edgefuse/tsdf/raycast.hpp"
#include "edgefuse/hal/platform/threads/worker_pool.hpp"

namespace edgefuse {

//! integrate() on all workers of `pool`.
template <class Real>
Status integrate_parallel(WorkerPool& pool, TsdfVolume& volume, const PinholeIntrinsics& intr,
                          ImageView<const Real> ray_norms, const DepthFrame& frame, const Pose& T_world_cam,
                          FrameScratch& scratch, float trust = 1.0f);

//! raycast() on all workers of `pool`.
template <class Real>
Status raycast_parallel(WorkerPool& pool, const TsdfVolume& volume, const PinholeIntrinsics& intr,
                        const Pose& T_world_cam, const RaycastMaps& maps);

}  // namespace edgefuse
