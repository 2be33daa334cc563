#include "edgefuse/tracking/pyramid.hpp"

namespace edgefuse {
namespace {

template <class Real>
Real abs_r(Real v) {
  return v < real_from_int<Real>(0) ? real_from_int<Real>(0) - v : v;
}

// Per-level constants. The ray of pixel (u, v) is (ray_x[u], ray_y(v), 1), each factor computed in
// float and rounded once: in Q16.16, 1/fx itself (~0.002) would carry a relative error of 5e-4,
// i.e. 0.15 mm at the image border at 1 m, where the rounded factor is exact to 8 um.
constexpr int kMaxLevelWidth = 2048;  // stack table of ray factors (8 KB)

template <class Real>
struct LevelConst {
  Real ray_x[kMaxLevelWidth];
  Real fx;
  Real min_z, max_z;
  float cy, fy;
  Real ray_y(int v) const { return real_from<Real>((float(v) - cy) / fy); }
};

template <class Real>
void init_level_const(const PinholeIntrinsics& c, LevelConst<Real>& k) {
  for (int u = 0; u < c.width && u < kMaxLevelWidth; ++u) k.ray_x[u] = real_from<Real>((float(u) - c.cx) / c.fx);
  k.fx = real_from<Real>(c.fx);
  k.min_z = real_from<Real>(c.min_range_m);
  k.max_z = real_from<Real>(c.max_range_m);
  k.cy = c.cy;
  k.fy = c.fy;
}

template <class Real>
Point3<Real> back_project(const LevelConst<Real>& k, int u, Real ry, Real z) {
  return Point3<Real>{k.ray_x[u] * z, ry * z, z};
}

// Level 0: raw depth -> vertices.
template <class Real>
void vertices_from_depth(ImageView<const uint16_t> depth, const PyramidLevel<Real>& out) {
  LevelConst<Real> k;
  init_level_const(out.intr, k);
  const DepthScale<Real> scale(out.intr.depth_scale);
  const Real zero = real_from_int<Real>(0);
  for (int v = 0; v < out.intr.height; ++v) {
    const uint16_t* d = depth.row(v);
    Point3<Real>* p = out.vertex.row(v);
    const Real ry = k.ray_y(v);
    for (int u = 0; u < out.intr.width; ++u) {
      const Real z = d[u] ? scale.metres(d[u]) : zero;
      p[u] = (z > zero && !(z < k.min_z) && !(z > k.max_z)) ? back_project(k, u, ry, z) : Point3<Real>{};
    }
  }
}

// Level k+1 from level k: the 2x2 block's depths near its nearest one, averaged.
template <class Real>
void downsample(const PyramidLevel<Real>& fine, const PyramidLevel<Real>& coarse, Real jump) {
  LevelConst<Real> k;
  init_level_const(coarse.intr, k);
  const Real zero = real_from_int<Real>(0);
  for (int v = 0; v < coarse.intr.height; ++v) {
    const Real ry = k.ray_y(v);
    for (int u = 0; u < coarse.intr.width; ++u) {
      Real z[4];
      int n = 0;
      Real z_min = zero;
      for (int dv = 0; dv < 2; ++dv)
        for (int du = 0; du < 2; ++du) {
          const Real zi = fine.vertex.at(2 * u + du, 2 * v + dv).z;
          if (!(zi > zero)) continue;
          z[n++] = zi;
          if (n == 1 || zi < z_min) z_min = zi;
        }
      Point3<Real>& out = coarse.vertex.at(u, v);
      if (n == 0) {
        out = Point3<Real>{};
        continue;
      }
      Real sum = zero;
      int used = 0;
      for (int i = 0; i < n; ++i)
        if (!(z[i] - z_min > jump)) {
          sum += z[i];
          ++used;
        }
      out = back_project(k, u, ry, sum / real_from_int<Real>(used));
    }
  }
}

// Difference towards the neighbours along one axis: central where both are usable, else one-sided.
template <class Real>
bool neighbour_difference(const Point3<Real>& c, const Point3<Real>* lo, const Point3<Real>* hi, Real jump,
                          Point3<Real>& d) {
  const Real zero = real_from_int<Real>(0);
  const bool use_lo = lo != nullptr && lo->z > zero && !(abs_r(lo->z - c.z) > jump);
  const bool use_hi = hi != nullptr && hi->z > zero && !(abs_r(hi->z - c.z) > jump);
  if (!use_lo && !use_hi) return false;
  const Point3<Real>& a = use_lo ? *lo : c;
  const Point3<Real>& b = use_hi ? *hi : c;
  d = Point3<Real>{b.x - a.x, b.y - a.y, b.z - a.z};
  return true;
}

template <class Real>
void normals(const PyramidLevel<Real>& level, Real jump) {
  const Real fx = real_from<Real>(level.intr.fx);
  const Real zero = real_from_int<Real>(0);
  const int w = level.intr.width, h = level.intr.height;
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      Point3<Real>& n = level.normal.at(u, v);
      n = Point3<Real>{};
      const Point3<Real>& c = level.vertex.at(u, v);
      if (!(c.z > zero)) continue;
      Point3<Real> du, dv;
      if (!neighbour_difference(c, u > 0 ? &level.vertex.at(u - 1, v) : nullptr,
                                u + 1 < w ? &level.vertex.at(u + 1, v) : nullptr, jump, du) ||
          !neighbour_difference(c, v > 0 ? &level.vertex.at(u, v - 1) : nullptr,
                                v + 1 < h ? &level.vertex.at(u, v + 1) : nullptr, jump, dv))
        continue;
      // Times f: a neighbour step (about z / f) becomes about z, so in Q16.16 the cross product of
      // two millimetre steps does not underflow (z from 0.1 to 10 m keeps it in 1e-2 .. 1e2).
      const Real ax = du.x * fx, ay = du.y * fx, az = du.z * fx;
      const Real bx = dv.x * fx, by = dv.y * fx, bz = dv.z * fx;
      Real nx = ay * bz - az * by, ny = az * bx - ax * bz, nz = ax * by - ay * bx;
      const Real len = real_sqrt(nx * nx + ny * ny + nz * nz);
      if (!(len > zero)) continue;
      const Real inv_len = real_from_int<Real>(1) / len;
      nx = nx * inv_len;
      ny = ny * inv_len;
      nz = nz * inv_len;
      if (nx * c.x + ny * c.y + nz * c.z > zero) {  // face the sensor
        nx = zero - nx;
        ny = zero - ny;
        nz = zero - nz;
      }
      n = Point3<Real>{nx, ny, nz};
    }
}

}  // namespace

PinholeIntrinsics level_intrinsics(const PinholeIntrinsics& intr, int level) {
  PinholeIntrinsics c = intr;
  for (int k = 0; k < level; ++k) {
    c.width >>= 1;
    c.height >>= 1;
    c.fx *= 0.5f;
    c.fy *= 0.5f;
    c.cx = (c.cx - 0.5f) * 0.5f;
    c.cy = (c.cy - 0.5f) * 0.5f;
  }
  return c;
}

template <class Real>
Status bind_pyramid(const PinholeIntrinsics& intr, Point3<Real>* vertex_storage, Point3<Real>* normal_storage,
                    std::size_t capacity, FramePyramid<Real>& out) {
  if (intr.validate() != Status::kOk || intr.width > kMaxLevelWidth || (intr.width >> (kPyramidLevels - 1)) < 2 ||
      (intr.height >> (kPyramidLevels - 1)) < 2)
    return Status::kInvalidArgument;
  if (vertex_storage == nullptr || normal_storage == nullptr || capacity < pyramid_pixels(intr.width, intr.height))
    return Status::kCapacityExceeded;
  std::size_t offset = 0;
  for (int k = 0; k < kPyramidLevels; ++k) {
    PyramidLevel<Real>& l = out.level[k];
    l.intr = level_intrinsics(intr, k);
    l.vertex = ImageView<Point3<Real>>(vertex_storage + offset, l.intr.width, l.intr.height);
    l.normal = ImageView<Point3<Real>>(normal_storage + offset, l.intr.width, l.intr.height);
    offset += std::size_t(l.intr.width) * std::size_t(l.intr.height);
  }
  return Status::kOk;
}

template <class Real>
Status build_pyramid(ImageView<const uint16_t> depth, const PyramidParams& params, FramePyramid<Real>& pyr) {
  const PyramidLevel<Real>& l0 = pyr.level[0];
  if (!params.valid() || depth.empty() || l0.vertex.empty()) return Status::kInvalidArgument;
  if (depth.width != l0.intr.width || depth.height != l0.intr.height) return Status::kInvalidArgument;
  vertices_from_depth(depth, l0);
  const Real block_jump = real_from<Real>(params.block_depth_jump_m);
  const Real normal_jump = real_from<Real>(params.normal_depth_jump_m);
  for (int k = 1; k < kPyramidLevels; ++k) downsample(pyr.level[k - 1], pyr.level[k], block_jump);
  for (int k = 0; k < kPyramidLevels; ++k) normals(pyr.level[k], normal_jump);
  return Status::kOk;
}

#define EDGEFUSE_INSTANTIATE(Real)                                                                              \
  template Status bind_pyramid<Real>(const PinholeIntrinsics&, Point3<Real>*, Point3<Real>*, std::size_t,      \
                                     FramePyramid<Real>&);                                                     \
  template Status build_pyramid<Real>(ImageView<const uint16_t>, const PyramidParams&, FramePyramid<Real>&);
EDGEFUSE_INSTANTIATE(float)
EDGEFUSE_INSTANTIATE(Fixed)
#undef EDGEFUSE_INSTANTIATE

}  // namespace edgefuse
