// The new frame as vertex and normal maps at kPyramidLevels resolutions (ICP input, coarse to fine).
//
// Level 0 back-projects the raw depth (paper eq. 5) with the sensor's intrinsics; level k + 1
// halves level k: each of its pixels covers a 2x2 block, whose valid z-depths are averaged over
// those within `block_depth_jump_m` of the nearest one (so a block straddling a silhouette takes
// the foreground, never a point floating between the two surfaces). Pixel centres stay
// consistent: level k+1 pixel u covers level-k pixels 2u and 2u+1, centred at 2u + 0.5, hence
// fx' = fx / 2, cx' = (cx - 0.5) / 2 (level_intrinsics()).
//
// Normals: cross product of the neighbour differences along the row and the column (central
// where both neighbours are valid and within `normal_depth_jump_m`, else one-sided), turned to
// face the sensor. The differences are multiplied by the focal length before the cross product, so
// that in Q16.16 the product of two millimetre steps does not underflow.
// Pixels without depth, and normals without a usable neighbour pair, are zero (z = 0).
//
// Storage comes from the caller (the board's static memory map): each map holds all levels
// back to back, pyramid_pixels(width, height) points.
#pragma once

#include <cstddef>
#include <cstdint>

#include "edgefuse/core/image.hpp"
#include "edgefuse/core/status.hpp"
#include "edgefuse/sensor/pinhole.hpp"
#include "edgefuse/tracking/point3.hpp"

namespace edgefuse {

inline constexpr int kPyramidLevels = 3;  //!< full, half and quarter resolution

//! Points of one map of all levels for a width x height image (level k is (w >> k) x (h >> k)).
constexpr std::size_t pyramid_pixels(int width, int height) {
  std::size_t n = 0;
  for (int k = 0; k < kPyramidLevels; ++k) n += std::size_t(width >> k) * std::size_t(height >> k);
  return n;
}

//! Intrinsics of pyramid level k (0 = the sensor's own).
//! \param intr the sensor's intrinsics  \param level 0..kPyramidLevels-1
PinholeIntrinsics level_intrinsics(const PinholeIntrinsics& intr, int level);

struct PyramidParams {
  //! Depths of a 2x2 block further than this behind the block's nearest one are left out of the
  //! coarse pixel. Default 0.03 m: above the depth noise of Kinect-class cameras up to ~2.5 m
  //! (~1.5 cm there) and of the ToF's bright surfaces, below the size of a bin's objects.
  float block_depth_jump_m = 0.03f;
  //! A neighbour further than this in depth is not used for the normal (silhouette). Default
  //! 0.03 m, for the same reason.
  float normal_depth_jump_m = 0.03f;

  //! Both thresholds positive.
  bool valid() const { return block_depth_jump_m > 0.0f && normal_depth_jump_m > 0.0f; }
};

template <class Real>
struct PyramidLevel {
  PinholeIntrinsics intr;          //!< intrinsics at this level
  ImageView<Point3<Real>> vertex;  //!< sensor-frame point, z = 0 where none
  ImageView<Point3<Real>> normal;  //!< unit normal facing the sensor, zero where none
};

template <class Real>
struct FramePyramid {
  PyramidLevel<Real> level[kPyramidLevels];  //!< 0 = full resolution
};

//! Points the views into caller storage (pyramid_pixels(intr.width, intr.height) points each).
//! \param intr sensor intrinsics  \param vertex_storage vertex points of all levels
//! \param normal_storage normal points of all levels  \param capacity points each storage holds
//! \param out the pyramid's views
template <class Real>
Status bind_pyramid(const PinholeIntrinsics& intr, Point3<Real>* vertex_storage, Point3<Real>* normal_storage,
                    std::size_t capacity, FramePyramid<Real>& out);

//! Fills every level from a raw depth image (0 = no depth; z outside the intrinsics' range is
//! treated as none).
//! \param depth raw z-depth, the size of level 0  \param params thresholds  \param pyr bound pyramid
template <class Real>
Status build_pyramid(ImageView<const uint16_t> depth, const PyramidParams& params, FramePyramid<Real>& pyr);

}  // namespace edgefuse
