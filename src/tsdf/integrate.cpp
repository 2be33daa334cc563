#include "edgefuse/tsdf/integrate.hpp"

#include <cmath>

#include "kernel_math.hpp"

namespace edgefuse {
namespace {

// Weighted running average of two integer samples, rounded to nearest (ties away from zero).
inline int32_t blend(int32_t old_value, int32_t old_weight, int32_t sample, int32_t sample_weight) {
  const int32_t num = old_value * old_weight + sample * sample_weight;
  const int32_t den = old_weight + sample_weight;
  return num >= 0 ? (num + den / 2) / den : -((-num + den / 2) / den);
}

inline uint8_t cap_weight(int32_t w, uint8_t max_weight) { return uint8_t(w > max_weight ? max_weight : w); }

// Measured z-depth at the projection (pu, pv) of a voxel; (iu, iv) is the nearest pixel.
// Bilinear over the 4 surrounding pixels when all are valid and within a depth jump of each other;
// the nearest pixel when some are missing (or at the border); false at a discontinuity or no data.
template <class Real>
bool depth_at(const IntegrationJob<Real>& job, Real pu, Real pv, int iu, int iv, Real& z) {
  const ImageView<const uint16_t>& img = job.frame.depth;
  const uint32_t nearest = img.at(iu, iv);
  const int u0 = floor_int(pu), v0 = floor_int(pv);
  if (u0 >= 0 && v0 >= 0 && u0 + 1 < job.width && v0 + 1 < job.height) {
    const uint16_t* r0 = img.row(v0) + u0;
    const uint16_t* r1 = img.row(v0 + 1) + u0;
    const uint32_t q[4] = {r0[0], r0[1], r1[0], r1[1]};
    uint32_t lo = 0xffff, hi = 0;
    int valid = 0;
    for (uint32_t x : q)
      if (x != 0) {
        ++valid;
        lo = x < lo ? x : lo;
        hi = x > hi ? x : hi;
      }
    if (valid == 4 && hi - lo <= job.jump_raw) {
      const Real fu = pu - real_from_int<Real>(u0), fv = pv - real_from_int<Real>(v0);
      const Real a = job.depth.metres(uint16_t(q[0])), b = job.depth.metres(uint16_t(q[1]));
      const Real c = job.depth.metres(uint16_t(q[2])), e = job.depth.metres(uint16_t(q[3]));
      const Real top = a + (b - a) * fu, bottom = c + (e - c) * fu;
      z = top + (bottom - top) * fv;
      return true;
    }
    if (nearest == 0) return false;
    if (valid > 0 && (hi > nearest + job.jump_raw || nearest > lo + job.jump_raw)) return false;
  } else if (nearest == 0) {
    return false;
  }
  z = job.depth.metres(uint16_t(nearest));
  return true;
}

}  // namespace

template <class Real>
Status prepare_integration(const TsdfVolume& volume, const PinholeIntrinsics& intr, const DepthFrame& frame,
                           const Pose& T_world_cam, float trust,
                           IntegrationJob<Real>& job) {
  if (!volume.initialised()) return Status::kNotInitialised;
  if (intr.validate() != Status::kOk || !(trust > 0.0f) || trust > 1.0f) return Status::kInvalidArgument;
  if (frame.depth.empty() || frame.depth.width != intr.width || frame.depth.height != intr.height)
    return Status::kInvalidArgument;
  if (!frame.colour.empty() && (frame.colour.width != intr.width || frame.colour.height != intr.height))
    return Status::kInvalidArgument;
  if (!T_world_cam.R.allFinite() || !T_world_cam.t.allFinite()) return Status::kInvalidArgument;

  const Pose T_cam_world = T_world_cam.inverse();
  const TsdfParams& p = volume.params();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) job.R[r * 3 + c] = real_from<Real>(T_cam_world.R(r, c));
    job.t[r] = real_from<Real>(T_cam_world.t(r));
    job.origin[r] = real_from<Real>(volume.origin_m()(r));
  }
  job.fx = real_from<Real>(intr.fx);
  job.fy = real_from<Real>(intr.fy);
  job.cx = real_from<Real>(intr.cx);
  job.cy = real_from<Real>(intr.cy);
  job.min_z = real_from<Real>(intr.min_range_m);
  job.max_z = real_from<Real>(intr.max_range_m);
  job.depth = DepthScale<Real>(intr.depth_scale);
  job.trunc = real_from<Real>(p.trunc_m);
  job.inv_trunc = real_from<Real>(1.0f / p.trunc_m);
  job.eps = real_from<Real>(p.weight.eps_m);
  job.rho = real_from<Real>(p.weight.rho_m);
  job.band_to_index = real_from<Real>(float(WeightTable::kSize) / (p.weight.rho_m - p.weight.eps_m));
  job.colour_band = real_from<Real>(p.colour_band_m > 0.0f ? p.colour_band_m : p.weight.eps_m);
  job.voxel = real_from<Real>(p.voxel_m);
  job.trust_q8 = uint32_t(std::lround(trust * 256.0f));
  if (job.trust_q8 == 0) job.trust_q8 = 1;
  const float jump = std::round(p.trunc_m * intr.depth_scale);
  job.jump_raw = jump < 1.0f ? 1u : (jump > 65535.0f ? 65535u : uint32_t(jump));
  job.frame = frame;
  job.width = intr.width;
  job.height = intr.height;
  return Status::kOk;
}

std::size_t select_bricks(TsdfVolume& volume, const PinholeIntrinsics& intr, const Pose& T_world_cam) {
  if (!volume.initialised()) return 0;
  const Pose T_cam_world = T_world_cam.inverse();
  const float vs = volume.voxel_m();
  const float radius = 0.5f * std::sqrt(3.0f) * kBrickSide * vs;
  const float far_z = intr.max_range_m + volume.params().trunc_m;
  // Side planes of the frustum through the sensor centre, inward normals. Pixel u is inside when
  // -0.5 <= u <= width - 0.5, i.e. fx x + (cx + 0.5) z >= 0 and -fx x + (width - 0.5 - cx) z >= 0.
  Vec3f planes[4] = {Vec3f(intr.fx, 0, intr.cx + 0.5f), Vec3f(-intr.fx, 0, intr.width - 0.5f - intr.cx),
                     Vec3f(0, intr.fy, intr.cy + 0.5f), Vec3f(0, -intr.fy, intr.height - 0.5f - intr.cy)};
  for (Vec3f& n : planes) n.normalize();

  const int nb = volume.bricks_per_axis();
  uint32_t* list = volume.brick_list();
  std::size_t count = 0;
  const Vec3f half = Vec3f::Constant(0.5f * kBrickSide * vs);
  for (int bz = 0; bz < nb; ++bz)
    for (int by = 0; by < nb; ++by)
      for (int bx = 0; bx < nb; ++bx) {
        const Vec3f centre_w = volume.origin_m() + Vec3f(float(bx), float(by), float(bz)) * (kBrickSide * vs) + half;
        const Vec3f c = T_cam_world * centre_w;
        if (c.z() + radius <= 0.0f || c.z() - radius > far_z) continue;
        bool outside = false;
        for (const Vec3f& n : planes) outside = outside || n.dot(c) < -radius;
        if (outside) continue;
        list[count++] = uint32_t(volume.brick_index(bx, by, bz));
      }
  return count;
}

template <class Real>
void integrate_bricks(TsdfVolume& volume, const IntegrationJob<Real>& job, std::size_t begin, std::size_t end) {
  const uint32_t* list = volume.brick_list();
  int16_t* tsdf = volume.tsdf();
  uint8_t* weight = volume.weight();
  Rgb8* colour = job.frame.colour.empty() ? nullptr : volume.colour();
  uint8_t* colour_weight = volume.colour_weight();
  uint8_t* flags = volume.brick_flags();
  const uint16_t* shape = volume.weight_table().shape;
  const uint8_t max_weight = volume.params().max_weight;
  const Real zero = real_from<Real>(0.0f);
  const Real q_scale = real_from<Real>(float(kTsdfMax));
  // Voxels closer than this to the sensor plane are not projected (division by ~0).
  const Real near_z = job.voxel;

  // Camera-frame step between neighbouring voxels along each grid axis: column of R times voxel.
  Real step[3][3];
  for (int axis = 0; axis < 3; ++axis)
    for (int r = 0; r < 3; ++r) step[axis][r] = job.R[r * 3 + axis] * job.voxel;
  const Real half = real_from<Real>(0.5f);

  for (std::size_t i = begin; i < end; ++i) {
    const uint32_t brick = list[i];
    int bx, by, bz;
    volume.brick_coords(brick, bx, by, bz);
    // World centre of the brick's first voxel, then into the camera frame.
    Real w0[3] = {job.origin[0] + (real_from<Real>(float(bx * kBrickSide)) + half) * job.voxel,
                  job.origin[1] + (real_from<Real>(float(by * kBrickSide)) + half) * job.voxel,
                  job.origin[2] + (real_from<Real>(float(bz * kBrickSide)) + half) * job.voxel};
    Real c0[3];
    for (int r = 0; r < 3; ++r) c0[r] = job.R[r * 3] * w0[0] + job.R[r * 3 + 1] * w0[1] + job.R[r * 3 + 2] * w0[2] + job.t[r];

    const std::size_t base = std::size_t(brick) * kBrickVoxels;
    bool observed = false, surface = false;
    Real pz[3] = {c0[0], c0[1], c0[2]};
    for (int lz = 0; lz < kBrickSide; ++lz) {
      Real py[3] = {pz[0], pz[1], pz[2]};
      for (int ly = 0; ly < kBrickSide; ++ly) {
        Real p[3] = {py[0], py[1], py[2]};
        const std::size_t row = base + std::size_t((lz << 6) | (ly << 3));
        for (int lx = 0; lx < kBrickSide; ++lx, p[0] += step[0][0], p[1] += step[0][1], p[2] += step[0][2]) {
          if (p[2] < near_z) continue;
          const Real inv_z = real_from<Real>(1.0f) / p[2];
          const Real pu = job.fx * (p[0] * inv_z) + job.cx;
          const Real pv = job.fy * (p[1] * inv_z) + job.cy;
          int iu, iv;
          if (!pixel_of(pu, job.width, iu) || !pixel_of(pv, job.height, iv)) continue;
          Real z;
          if (!depth_at(job, pu, pv, iu, iv, z)) continue;
          if (z < job.min_z || z > job.max_z) continue;
          // Eq. (1) along the voxel's own ray: m = z |p| / p.z, d = m - |p| = (z - p.z) |p| / p.z.
          const Real range = real_sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
          const Real d = (z - p[2]) * (range * inv_z);
          if (d <= -job.rho) continue;
          // Eq. (2) from the table: full weight in front of -eps.
          uint32_t w_shape = WeightTable::kOne;
          if (d < -job.eps) {
            int32_t k = floor_int((zero - d - job.eps) * job.band_to_index);
            k = k < 0 ? 0 : (k >= WeightTable::kSize ? WeightTable::kSize - 1 : k);
            w_shape = shape[k];
          }
          const int32_t w = int32_t((w_shape * job.trust_q8 * kWeightUnitsPerSample + 32768u) >> 16);
          if (w == 0) continue;
          int32_t q = d >= job.trunc ? kTsdfMax : round_int(d * job.inv_trunc * q_scale);
          q = q > kTsdfMax ? kTsdfMax : (q < -kTsdfMax ? -kTsdfMax : q);

          const std::size_t idx = row + std::size_t(lx);
          const int32_t old_w = weight[idx];
          const int32_t value = old_w == 0 ? q : blend(tsdf[idx], old_w, q, w);
          tsdf[idx] = int16_t(value);
          weight[idx] = cap_weight(old_w + w, max_weight);
          observed = true;
          surface = surface || (value < kTsdfMax && value > -kTsdfMax);

          if (colour != nullptr && d < job.colour_band && d > zero - job.colour_band) {
            const Rgb8 c = job.frame.colour.at(iu, iv);
            const int32_t cw = colour_weight[idx];
            Rgb8& v = colour[idx];
            if (cw == 0) {
              v = c;
            } else {
              v.r = uint8_t(blend(v.r, cw, c.r, w));
              v.g = uint8_t(blend(v.g, cw, c.g, w));
              v.b = uint8_t(blend(v.b, cw, c.b, w));
            }
            colour_weight[idx] = cap_weight(cw + w, max_weight);
          }
        }
        for (int r = 0; r < 3; ++r) py[r] += step[1][r];
      }
      for (int r = 0; r < 3; ++r) pz[r] += step[2][r];
    }
    if (observed) flags[brick] |= kBrickObserved;
    if (surface) flags[brick] |= kBrickSurface;
  }
}

void finish_integration(TsdfVolume& volume, std::size_t count) {
  const uint32_t* list = volume.brick_list();
  uint8_t* flags = volume.brick_flags();
  const int nb = volume.bricks_per_axis();
  for (std::size_t i = 0; i < count; ++i) {
    const uint32_t brick = list[i];
    if ((flags[brick] & (kBrickSurface | kBrickDilated)) != kBrickSurface) continue;
    flags[brick] |= kBrickDilated;
    int bx, by, bz;
    volume.brick_coords(brick, bx, by, bz);
    for (int z = bz - 1; z <= bz + 1; ++z)
      for (int y = by - 1; y <= by + 1; ++y)
        for (int x = bx - 1; x <= bx + 1; ++x)
          if (x >= 0 && y >= 0 && z >= 0 && x < nb && y < nb && z < nb)
            flags[volume.brick_index(x, y, z)] |= kBrickNearSurface;
  }
}

template <class Real>
Status integrate(TsdfVolume& volume, const PinholeIntrinsics& intr, const DepthFrame& frame,
                 const Pose& T_world_cam, float trust) {
  IntegrationJob<Real> job;
  const Status s = prepare_integration(volume, intr, frame, T_world_cam, trust, job);
  if (s != Status::kOk) return s;
  const std::size_t count = select_bricks(volume, intr, T_world_cam);
  integrate_bricks(volume, job, 0, count);
  finish_integration(volume, count);
  return Status::kOk;
}

#define EDGEFUSE_INSTANTIATE(Real)                                                                              \
  template Status prepare_integration<Real>(const TsdfVolume&, const PinholeIntrinsics&, const DepthFrame&,     \
                                            const Pose&, float, IntegrationJob<Real>&);                        \
  template void integrate_bricks<Real>(TsdfVolume&, const IntegrationJob<Real>&, std::size_t, std::size_t);    \
  template Status integrate<Real>(TsdfVolume&, const PinholeIntrinsics&, const DepthFrame&, const Pose&, float);
EDGEFUSE_INSTANTIATE(float)
EDGEFUSE_INSTANTIATE(Fixed)
#undef EDGEFUSE_INSTANTIATE

}  // namespace edgefuse
