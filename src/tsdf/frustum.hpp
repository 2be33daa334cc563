// The side planes of a pinhole sensor's frustum, for culling bricks (private to src/tsdf).
#pragma once

#include <cmath>

#include "edgefuse/math/pose.hpp"
#include "edgefuse/sensor/pinhole.hpp"
#include "edgefuse/tsdf/volume.hpp"

namespace edgefuse {

struct FrustumPlanes {
  Vec3f n[4];  //!< inward unit normals of the planes through the sensor centre (camera frame)

  //! Whether a sphere may reach into the frustum.
  //! \param c centre in the camera frame  \param radius_m sphere radius  \param far_z beyond this z it cannot
  bool may_see(const Vec3f& c, float radius_m, float far_z) const {
    if (c.z() + radius_m <= 0.0f || c.z() - radius_m > far_z) return false;
    bool outside = false;
    for (const Vec3f& p : n) outside = outside || p.dot(c) < -radius_m;
    return !outside;
  }
};

//! Pixel u is inside when -0.5 <= u <= width - 0.5, i.e. fx x + (cx + 0.5) z >= 0 and
//! -fx x + (width - 0.5 - cx) z >= 0; likewise in v.
//! \param intr the sensor's intrinsics
inline FrustumPlanes frustum_planes(const PinholeIntrinsics& intr) {
  FrustumPlanes f = {{Vec3f(intr.fx, 0, intr.cx + 0.5f), Vec3f(-intr.fx, 0, intr.width - 0.5f - intr.cx),
                      Vec3f(0, intr.fy, intr.cy + 0.5f), Vec3f(0, -intr.fy, intr.height - 0.5f - intr.cy)}};
  for (Vec3f& p : f.n) p.normalize();
  return f;
}

//! Whether a sensor may see into each brick of a volume: the brick's bounding sphere against the
//! frustum, up to the far range plus the truncation.
class BrickFrustum {
 public:
  //! \param volume the space  \param intr the sensor's intrinsics  \param T_world_cam sensor pose
  BrickFrustum(const TsdfVolume& volume, const PinholeIntrinsics& intr, const Pose& T_world_cam)
      : volume_(volume), T_cam_world_(T_world_cam.inverse()), planes_(frustum_planes(intr)),
        brick_m_(kBrickSide * volume.voxel_m()), radius_m_(0.5f * std::sqrt(3.0f) * brick_m_),
        far_z_m_(intr.max_range_m + volume.params().trunc_m) {}

  //! \param bx \param by \param bz brick coordinates
  bool sees(int bx, int by, int bz) const {
    const Vec3f centre_w =
        volume_.origin_m() + Vec3f(float(bx), float(by), float(bz)) * brick_m_ + Vec3f::Constant(0.5f * brick_m_);
    return planes_.may_see(T_cam_world_ * centre_w, radius_m_, far_z_m_);
  }

 private:
  const TsdfVolume& volume_;
  Pose T_cam_world_;
  FrustumPlanes planes_;
  float brick_m_, radius_m_, far_z_m_;
};

}  // namespace edgefuse
