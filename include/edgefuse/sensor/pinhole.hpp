// Pinhole sensor model (paper eq. 3-5): structured light and ToF cameras.
//
// Pixel (u, v) = (column, row) at pixel centres looks along ((u - cx)/fx, (v - cy)/fy, 1) in the
// camera frame (x right, y down, z forward). Depth images hold z-depth; the range along the ray is
// z * |ray|, with |ray| precomputed per pixel in a ray-norm map.
#pragma once

#include <cstdint>

#include "edgefuse/core/image.hpp"
#include "edgefuse/core/status.hpp"
#include "edgefuse/math/pose.hpp"
#include "edgefuse/math/real.hpp"

namespace edgefuse {

struct PinholeIntrinsics {
  int width = 0;             //!< image width in pixels
  int height = 0;            //!< image height in pixels
  float fx = 0, fy = 0;      //!< focal lengths in pixels
  float cx = 0, cy = 0;      //!< principal point in pixels
  float min_range_m = 0.1f;  //!< nearest valid z-depth
  float max_range_m = 10.0f; //!< farthest valid z-depth
  float depth_scale = 1000;  //!< raw depth value / depth_scale = z-depth in metres

  //! Largest focal length and |principal point| in image sizes (the larger of width and height):
  //! a field of view of 0.06 degrees, far narrower than any depth camera. Beyond it the numbers are
  //! garbage (a corrupt camera.toml's 5.7e11), not optics.
  static constexpr float kMaxPixelsPerSize = 1000.0f;
  //! Largest depth_scale (raw units per metre): a raw unit of 1 micrometre, finer than any depth
  //! sensor resolves (its 16-bit range would end at 6.5 cm). Beyond it the number is garbage.
  static constexpr float kMaxDepthScale = 1e6f;

  //! Largest |fx|, |fy|, |cx|, |cy| validate() accepts for this image size (kMaxPixelsPerSize sizes).
  float max_pixel_coordinate() const { return kMaxPixelsPerSize * float(width > height ? width : height); }

  //! Checks that the numbers describe a camera (positive sizes, focal lengths in (0, 1000 sizes],
  //! principal point within 1000 sizes of the origin, depth_scale in (0, kMaxDepthScale], ordered
  //! ranges).
  Status validate() const {
    if (width <= 0 || height <= 0 || !(fx > 0) || !(fy > 0) || !(depth_scale > 0) || !(depth_scale <= kMaxDepthScale) ||
        !(min_range_m >= 0) || !(max_range_m > min_range_m))
      return Status::kInvalidArgument;
    const float limit = max_pixel_coordinate();
    if (!(fx <= limit) || !(fy <= limit) || !(cx >= -limit && cx <= limit) || !(cy >= -limit && cy <= limit))
      return Status::kInvalidArgument;
    return Status::kOk;
  }
  //! Direction of pixel (u, v) with z = 1.
  Vec3f ray(float u, float v) const { return Vec3f((u - cx) / fx, (v - cy) / fy, 1.0f); }
  //! Camera-frame point of pixel (u, v) at z-depth z_m (eq. 5).
  Vec3f back_project(float u, float v, float z_m) const { return ray(u, v) * z_m; }
  //! Pixel coordinates of a camera-frame point (eq. 3-4); false when behind the camera.
  bool project(const Vec3f& p, float& u, float& v) const {
    if (!(p.z() > 0)) return false;
    u = fx * p.x() / p.z() + cx;
    v = fy * p.y() / p.z() + cy;
    return true;
  }
};

//! Fills `norms` (width x height) with |ray(u, v)|, so range = z-depth * norm.
//! \param intr camera intrinsics
//! \param norms output view, must be intr.width x intr.height
template <class Real>
Status build_ray_norms(const PinholeIntrinsics& intr, ImageView<Real> norms) {
  if (intr.validate() != Status::kOk) return Status::kInvalidArgument;
  if (norms.width != intr.width || norms.height != intr.height || norms.data == nullptr)
    return Status::kCapacityExceeded;
  for (int v = 0; v < intr.height; ++v)
    for (int u = 0; u < intr.width; ++u)
      norms.at(u, v) = real_from<Real>(intr.ray(float(u), float(v)).norm());
  return Status::kOk;
}

}  // namespace edgefuse
