#include "edgefuse/tsdf/raycast.hpp"

#include <algorithm>
#include <cmath>

#include "kernel_math.hpp"
#include "tsdf_sampler.hpp"

namespace edgefuse {
namespace {

template <class Real>
Real abs_r(Real v) {
  return v < real_from_int<Real>(0) ? real_from_int<Real>(0) - v : v;
}
template <class Real>
Real max_r(Real a, Real b) {
  return a > b ? a : b;
}
template <class Real>
Real min_r(Real a, Real b) {
  return a < b ? a : b;
}

// Per-frame constants of one raycast, in the kernel scalar.
template <class Real>
struct RayFrame {
  Real R[9];            // rotation of T_world_cam, row-major
  Real g0[3];           // sensor centre in grid coordinates (voxel-centre units)
  Real inv_voxel;       // grid units per metre
  Real voxel, trunc;
  Real min_z, max_z;
  Real grid_max;        // last valid trilinear base coordinate + 1 (= dim - 1)
  Real fx_inv, fy_inv, cx, cy;
};

template <class Real>
RayFrame<Real> make_ray_frame(const TsdfVolume& volume, const PinholeIntrinsics& intr, const Pose& T_world_cam) {
  RayFrame<Real> f;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) f.R[r * 3 + c] = real_from<Real>(T_world_cam.R(r, c));
  const Vec3f g0 = (T_world_cam.t - volume.origin_m()) / volume.voxel_m() - Vec3f::Constant(0.5f);
  for (int r = 0; r < 3; ++r) f.g0[r] = real_from<Real>(g0(r));
  f.inv_voxel = real_from<Real>(1.0f / volume.voxel_m());
  f.voxel = real_from<Real>(volume.voxel_m());
  f.trunc = real_from<Real>(volume.params().trunc_m);
  f.min_z = real_from<Real>(intr.min_range_m);
  f.max_z = real_from<Real>(intr.max_range_m);
  f.grid_max = real_from_int<Real>(volume.dim() - 1);
  f.fx_inv = real_from<Real>(1.0f / intr.fx);
  f.fy_inv = real_from<Real>(1.0f / intr.fy);
  f.cx = real_from<Real>(intr.cx);
  f.cy = real_from<Real>(intr.cy);
  return f;
}

// Clips t (z-depth along the ray) so that g0 + t gd stays in [0, grid_max) on every axis.
template <class Real>
bool clip_to_grid(const RayFrame<Real>& f, const Real gd[3], Real& t0, Real& t1) {
  const Real zero = real_from_int<Real>(0);
  const Real tiny = real_from<Real>(1e-4f);
  for (int a = 0; a < 3; ++a) {
    if (abs_r(gd[a]) < tiny) {
      if (f.g0[a] < zero || !(f.g0[a] < f.grid_max)) return false;
      continue;
    }
    Real ta = (zero - f.g0[a]) / gd[a];
    Real tb = (f.grid_max - f.g0[a]) / gd[a];
    if (ta > tb) {
      const Real s = ta;
      ta = tb;
      tb = s;
    }
    t0 = max_r(t0, ta);
    t1 = min_r(t1, tb);
  }
  return t0 < t1;
}

// t at which the ray leaves the brick holding floor(g); `axis` is the face it leaves through.
template <class Real>
Real brick_exit(const RayFrame<Real>& f, const Real gd[3], const int cell[3], int& axis) {
  const Real tiny = real_from<Real>(1e-4f);
  Real t_exit = real_from_int<Real>(1 << 14);
  axis = 0;
  for (int a = 0; a < 3; ++a) {
    const int lo = cell[a] & ~(kBrickSide - 1);
    Real ta = t_exit;
    if (gd[a] > tiny) {
      ta = (real_from_int<Real>(lo + kBrickSide) - f.g0[a]) / gd[a];
    } else if (gd[a] < real_from_int<Real>(0) - tiny) {
      ta = (real_from_int<Real>(lo) - f.g0[a]) / gd[a];
    }
    if (ta < t_exit) {
      t_exit = ta;
      axis = a;
    }
  }
  return t_exit;
}

}  // namespace

Status prepare_raycast(const TsdfVolume& volume, const PinholeIntrinsics& intr, const Pose& T_world_cam,
                       const RaycastMaps& maps, FrameScratch& scratch) {
  if (!volume.initialised()) return Status::kNotInitialised;
  if (intr.validate() != Status::kOk) return Status::kInvalidArgument;
  if (maps.depth_m.width != intr.width || maps.depth_m.height != intr.height || maps.depth_m.data == nullptr)
    return Status::kInvalidArgument;
  if ((!maps.vertex.empty() && (maps.vertex.width != intr.width || maps.vertex.height != intr.height)) ||
      (!maps.normal.empty() && (maps.normal.width != intr.width || maps.normal.height != intr.height)) ||
      (!maps.colour.empty() && (maps.colour.width != intr.width || maps.colour.height != intr.height)))
    return Status::kInvalidArgument;
  if (!scratch.fits(intr.width, intr.height)) return Status::kCapacityExceeded;

  const int tx = FrameScratch::tiles_x(intr.width), ty = FrameScratch::tiles_y(intr.height);
  const std::size_t tiles = FrameScratch::tiles_for(intr.width, intr.height);
  for (std::size_t i = 0; i < tiles; ++i) {
    scratch.model_min_z[i] = 1e30f;
    scratch.model_max_z[i] = -1.0f;
  }
  const Pose T_cam_world = T_world_cam.inverse();
  const float vs = volume.voxel_m();
  const uint8_t* flags = volume.brick_flags();
  const std::size_t bricks = volume.brick_count();
  // A zero crossing can lie in a cell reaching one voxel past the brick's last voxel centre.
  const float lo_off = 0.5f * vs, hi_off = (kBrickSide + 0.5f) * vs;
  for (std::size_t b = 0; b < bricks; ++b) {
    if (!(flags[b] & kBrickSurface)) continue;
    int bx, by, bz;
    volume.brick_coords(b, bx, by, bz);
    const Vec3f corner = volume.origin_m() + Vec3f(float(bx), float(by), float(bz)) * (kBrickSide * vs);
    float z_lo = 1e30f, z_hi = -1e30f, u_lo = 1e30f, u_hi = -1e30f, v_lo = 1e30f, v_hi = -1e30f;
    bool behind = false;
    for (int k = 0; k < 8; ++k) {
      const Vec3f p = T_cam_world * (corner + Vec3f((k & 1) ? hi_off : lo_off, (k & 2) ? hi_off : lo_off,
                                                    (k & 4) ? hi_off : lo_off));
      z_lo = std::min(z_lo, p.z());
      z_hi = std::max(z_hi, p.z());
      if (p.z() <= 1e-3f) {
        behind = true;
        continue;
      }
      float u = 0.0f, v = 0.0f;
      intr.project(p, u, v);  // p.z > 0 here
      u_lo = std::min(u_lo, u);
      u_hi = std::max(u_hi, u);
      v_lo = std::min(v_lo, v);
      v_hi = std::max(v_hi, v);
    }
    if (z_hi <= 0.0f) continue;
    if (behind) {  // straddles the sensor plane: may cover any pixel
      u_lo = v_lo = -1e30f;
      u_hi = v_hi = 1e30f;
    }
    const int i0 = std::max(0, int(std::floor((u_lo + 0.5f) / FrameScratch::kTile)));
    const int i1 = std::min(tx - 1, int(std::floor((std::min(u_hi, 1e6f) + 0.5f) / FrameScratch::kTile)));
    const int j0 = std::max(0, int(std::floor((v_lo + 0.5f) / FrameScratch::kTile)));
    const int j1 = std::min(ty - 1, int(std::floor((std::min(v_hi, 1e6f) + 0.5f) / FrameScratch::kTile)));
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) {
        const std::size_t t = std::size_t(j) * tx + i;
        scratch.model_min_z[t] = std::min(scratch.model_min_z[t], z_lo);
        scratch.model_max_z[t] = std::max(scratch.model_max_z[t], z_hi);
      }
  }
  return Status::kOk;
}

template <class Real>
bool sample_tsdf(const TsdfVolume& volume, const Vec3f& p_world, float& d_m) {
  const Vec3f g = (p_world - volume.origin_m()) / volume.voxel_m() - Vec3f::Constant(0.5f);
  TsdfSampler<Real> s(volume);
  Real value;
  if (!s.sample(real_from<Real>(g.x()), real_from<Real>(g.y()), real_from<Real>(g.z()), value)) return false;
  d_m = to_float(value) * volume.params().trunc_m;
  return true;
}

template <class Real>
void raycast_rows(const TsdfVolume& volume, const PinholeIntrinsics& intr, const Pose& T_world_cam,
                  const RaycastMaps& maps, const FrameScratch& scratch, int row_begin, int row_end) {
  const int tiles_x = FrameScratch::tiles_x(intr.width);
  // The positive band in front of a surface has |tsdf| < 1, so it belongs to surface bricks too:
  // starting at the tiles' near bound still leaves a positive sample before every crossing.
  const Real margin = real_from<Real>(volume.voxel_m());
  const RayFrame<Real> f = make_ray_frame<Real>(volume, intr, T_world_cam);
  const TsdfSampler<Real> sampler(volume);
  const uint8_t* flags = volume.brick_flags();
  const int16_t* tsdf = volume.tsdf();
  const Real zero = real_from_int<Real>(0);
  const Real half = real_from<Real>(0.5f);
  const Real one = real_from_int<Real>(1);
  const bool want_colour = !maps.colour.empty() && volume.has_colour();

  // Pixels are visited tile by tile (8 columns of the given rows at a time) so that neighbouring
  // rays, which read the same voxels, follow each other while those voxels are still cached.
  for (int u0 = 0; u0 < intr.width; u0 += FrameScratch::kTile)
  for (int v = row_begin; v < row_end; ++v) {
    const int u_end = u0 + FrameScratch::kTile < intr.width ? u0 + FrameScratch::kTile : intr.width;
    for (int u = u0; u < u_end; ++u) {
      maps.depth_m.at(u, v) = 0.0f;
      if (!maps.vertex.empty()) maps.vertex.at(u, v) = Vec3f::Zero();
      if (!maps.normal.empty()) maps.normal.at(u, v) = Vec3f::Zero();
      if (!maps.colour.empty()) maps.colour.at(u, v) = Rgba8{};

      // Ray (x, y, 1) in the camera frame: t along it is the z-depth.
      const Real rx = (real_from_int<Real>(u) - f.cx) * f.fx_inv;
      const Real ry = (real_from_int<Real>(v) - f.cy) * f.fy_inv;
      Real gd[3];
      for (int r = 0; r < 3; ++r) gd[r] = (f.R[r * 3] * rx + f.R[r * 3 + 1] * ry + f.R[r * 3 + 2]) * f.inv_voxel;
      const Real ray_norm = real_sqrt(rx * rx + ry * ry + one);
      const Real z_per_m = one / ray_norm;             // z-depth advanced per metre along the ray
      const Real min_step = half * f.voxel * z_per_m;  // half a voxel
      const Real nudge = real_from<Real>(1.0f / 64.0f) * f.voxel * z_per_m;
      const Real half_trunc = half * f.trunc * z_per_m;
      // From a voxel at +trunc the surface is at least trunc minus half a voxel diagonal away.
      const Real far_step = max_r((f.trunc - f.voxel) * z_per_m, min_step);

      // The z range where this tile's surface bricks lie (and a voxel of slack).
      const std::size_t tile = std::size_t(v / FrameScratch::kTile) * tiles_x + std::size_t(u / FrameScratch::kTile);
      if (scratch.model_max_z[tile] < 0.0f) continue;
      Real t = max_r(f.min_z, real_from<Real>(scratch.model_min_z[tile]) - margin);
      Real t_end = min_r(f.max_z, real_from<Real>(scratch.model_max_z[tile]) + margin);
      if (!clip_to_grid(f, gd, t, t_end)) continue;
      // Start and stop a little inside the grid: the clip is exact only up to rounding.
      t += nudge;
      t_end -= nudge;

      bool prev_valid = false;
      Real prev_t = zero, prev_s = zero;
      bool hit = false;
      Real t_hit = zero;
      while (t < t_end) {
        const Real g[3] = {f.g0[0] + t * gd[0], f.g0[1] + t * gd[1], f.g0[2] + t * gd[2]};
        int cell[3] = {floor_int(g[0]), floor_int(g[1]), floor_int(g[2])};
        if (!sampler.in_grid(cell)) break;
        const uint8_t bf = flags[volume.brick_index(cell[0] >> 3, cell[1] >> 3, cell[2] >> 3)];
        if ((bf & (kBrickNearSurface | kBrickObserved)) != (kBrickNearSurface | kBrickObserved)) {
          // No surface in or next to this brick, or nothing observed in it (then every cell based
          // here has an unobserved corner): leave it whole.
          // A ray grazing a brick face can sit exactly on it: when the nudge is lost to rounding
          // (the exit is where we are), move on by half a voxel so the march always advances.
          int axis;
          const Real t_next = brick_exit(f, gd, cell, axis) + nudge;
          t = t_next > t + nudge ? t_next : t + min_step;
          prev_valid = false;
          continue;
        }
        if (!(bf & kBrickSurface)) {
          // Surface next door but none here: only the last cell before the exit face, which
          // reaches into the next brick, can hold a crossing. Go to one voxel before that face.
          int axis;
          const Real t_exit = brick_exit(f, gd, cell, axis);
          const Real t_last_cell = t_exit - real_from<Real>(1.01f) / abs_r(gd[axis]);
          if (t_last_cell > t + min_step) {
            t = t_last_cell;
            prev_valid = false;
            continue;
          }
        }
        // The nearest voxel first (2 loads instead of 16): unobserved or truncated at +1, the
        // trilinear value cannot hold a crossing within the step taken below.
        const int nearest[3] = {floor_int(g[0] + half), floor_int(g[1] + half), floor_int(g[2] + half)};
        const std::size_t ni = volume.index(nearest[0], nearest[1], nearest[2]);
        if (tsdf[ni] == kTsdfMax) {
          prev_valid = true;  // a +1 sample: the crossing, if next, lies between here and there
          prev_t = t;
          prev_s = one;
          t += far_step;
          continue;
        }
        Real s;
        if (!sampler.sample(g[0], g[1], g[2], s)) {
          // Unobserved corner: no surface can be here. A surface seen from this side has its
          // positive band (at least trunc deep along any ray) observed, so half a truncation
          // lands in that band before its zero crossing, never beyond it.
          t += max_r(half_trunc, min_step);
          prev_valid = false;
          continue;
        }
        if (prev_valid && prev_s > zero && !(s > zero)) {
          // Zero crossing between prev_t and t: regula falsi on the trilinear field.
          Real ta = prev_t, sa = prev_s, tb = t, sb = s;
          for (int it = 0; it < 3; ++it) {
            const Real tm = ta + (tb - ta) * (sa / (sa - sb));
            const Real gm[3] = {f.g0[0] + tm * gd[0], f.g0[1] + tm * gd[1], f.g0[2] + tm * gd[2]};
            Real sm;
            if (!sampler.sample(gm[0], gm[1], gm[2], sm)) break;
            if (sm > zero) {
              ta = tm;
              sa = sm;
            } else {
              tb = tm;
              sb = sm;
            }
          }
          t_hit = sa > sb ? ta + (tb - ta) * (sa / (sa - sb)) : ta;
          hit = true;
          break;
        }
        prev_valid = true;
        prev_t = t;
        prev_s = s;
        // Step by the distance itself (the projective TSDF bounds the distance to the surface).
        t += max_r(abs_r(s) * f.trunc * z_per_m, min_step);
      }
      if (!hit) continue;

      const float z = to_float(t_hit);
      const Vec3f ray(to_float(rx), to_float(ry), 1.0f);
      maps.depth_m.at(u, v) = z;
      if (!maps.vertex.empty()) maps.vertex.at(u, v) = ray * z;
      const Real gh[3] = {f.g0[0] + t_hit * gd[0], f.g0[1] + t_hit * gd[1], f.g0[2] + t_hit * gd[2]};
      if (!maps.normal.empty()) {
        float grad[3];
        if (sampler.gradient(gh[0], gh[1], gh[2], grad)) {
          const Vec3f n_world(grad[0], grad[1], grad[2]);
          const float len = n_world.norm();
          if (len > 0.0f) {
            Vec3f n = T_world_cam.R.transpose() * (n_world / len);
            if (n.dot(ray) > 0.0f) n = -n;  // face the sensor
            maps.normal.at(u, v) = n;
          }
        }
      }
      if (want_colour) maps.colour.at(u, v) = sampler.colour(gh[0], gh[1], gh[2]);
    }
  }
}

template <class Real>
Status raycast(const TsdfVolume& volume, const PinholeIntrinsics& intr, const Pose& T_world_cam,
               const RaycastMaps& maps, FrameScratch& scratch) {
  const Status s = prepare_raycast(volume, intr, T_world_cam, maps, scratch);
  if (s != Status::kOk) return s;
  raycast_rows<Real>(volume, intr, T_world_cam, maps, scratch, 0, intr.height);
  return Status::kOk;
}

#define EDGEFUSE_INSTANTIATE(Real)                                                                                 \
  template bool sample_tsdf<Real>(const TsdfVolume&, const Vec3f&, float&);                                       \
  template void raycast_rows<Real>(const TsdfVolume&, const PinholeIntrinsics&, const Pose&, const RaycastMaps&, \
                                   const FrameScratch&, int, int);                                                \
  template Status raycast<Real>(const TsdfVolume&, const PinholeIntrinsics&, const Pose&, const RaycastMaps&,     \
                                FrameScratch&);
EDGEFUSE_INSTANTIATE(float)
EDGEFUSE_INSTANTIATE(Fixed)
#undef EDGEFUSE_INSTANTIATE

}  // namespace edgefuse
