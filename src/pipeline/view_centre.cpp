#include "edgefuse/pipeline/view_centre.hpp"

#include <algorithm>

namespace edgefuse {

std::size_t view_centre(const PinholeIntrinsics& intr, ImageView<const uint16_t> depth, const Pose& T_world_cam,
                        const ViewCentreScratch& s, Vec3f& centre_m) {
  std::size_t n = 0;
  for (int v = 0; v < intr.height; v += 2)
    for (int u = 0; u < intr.width; u += 2) {
      const uint16_t raw = depth.at(u, v);
      const float z = float(raw) / intr.depth_scale;
      if (raw == 0 || z < intr.min_range_m || z > intr.max_range_m || n >= s.capacity) continue;
      const Vec3f p = T_world_cam * intr.back_project(float(u), float(v), z);
      s.xs[n] = p.x();
      s.ys[n] = p.y();
      s.zs[n] = p.z();
      ++n;
    }
  if (n == 0) return 0;
  auto median = [n](float* v) {
    std::nth_element(v, v + n / 2, v + n);
    return v[n / 2];
  };
  centre_m = Vec3f(median(s.xs), median(s.ys), median(s.zs));
  return n;
}

}  // namespace edgefuse
