// Where a new map is placed: the volume is centred on the median of the points the first frame
// sees (the bin), so the board's volume covers the work space wherever the rig stands.
#pragma once

#include <cstddef>

#include "edgefuse/core/image.hpp"
#include "edgefuse/math/pose.hpp"
#include "edgefuse/sensor/pinhole.hpp"

namespace edgefuse {

//! Scratch for view_centre(): three arrays of `capacity` floats (every 2nd pixel of every 2nd row,
//! so (width / 2 + 1) x (height / 2 + 1) hold any image).
struct ViewCentreScratch {
  float* xs = nullptr;
  float* ys = nullptr;
  float* zs = nullptr;
  std::size_t capacity = 0;
};

//! The median world point of every 2nd pixel of every 2nd row with a depth in the sensor's range.
//! \param intr the sensor  \param depth raw z-depth  \param T_world_cam its pose
//! \param scratch per-axis arrays  \param centre_m receives the median
//! \return the points sampled (0: no pixel in range, centre_m unchanged)
std::size_t view_centre(const PinholeIntrinsics& intr, ImageView<const uint16_t> depth, const Pose& T_world_cam,
                        const ViewCentreScratch& scratch, Vec3f& centre_m);

//! The origin of a dim^3 volume of voxel_m voxels centred on centre_m.
inline Vec3f volume_origin_for(const Vec3f& centre_m, int dim, float voxel_m) {
  return centre_m - Vec3f::Constant(0.5f * float(dim) * voxel_m);
}

}  // namespace edgefuse
