// Normals of an organised cloud from its image neighbours: the cross product of the horizontal and
// vertical central differences (one-sided at depth jumps), turned towards the camera at the origin.
#include <cmath>

#include "edgefuse/localize/localizer.hpp"

namespace edgefuse {

void organised_normals(const Vec3f* points, int width, int height, float max_jump_m, Vec3f* normals) {
  const float nan = std::nanf("");
  const float jump2 = max_jump_m * max_jump_m;
  for (int v = 0; v < height; ++v)
    for (int u = 0; u < width; ++u) {
      const std::size_t i = std::size_t(v) * std::size_t(width) + std::size_t(u);
      normals[i] = Vec3f(nan, nan, nan);
      const Vec3f& p = points[i];
      if (!p.allFinite()) continue;
      auto usable = [&](int uu, int vv, Vec3f& q) {
        if (uu < 0 || vv < 0 || uu >= width || vv >= height) return false;
        q = points[std::size_t(vv) * std::size_t(width) + std::size_t(uu)];
        return q.allFinite() && (q - p).squaredNorm() < jump2;
      };
      // Two pixels apart smooths the quantised depth of structured light a little.
      Vec3f l, r, t, b;
      const bool hl = usable(u - 2, v, l), hr = usable(u + 2, v, r), vt = usable(u, v - 2, t), vb = usable(u, v + 2, b);
      if (!(hl || hr) || !(vt || vb)) continue;
      const Vec3f dx = (hr ? r : p) - (hl ? l : p);
      const Vec3f dy = (vb ? b : p) - (vt ? t : p);
      Vec3f n = dy.cross(dx);
      const float len = n.norm();
      if (!(len > 0)) continue;
      n /= len;
      if (n.dot(p) > 0) n = -n;  // towards the camera
      normals[i] = n;
    }
}

}  // namespace edgefuse
