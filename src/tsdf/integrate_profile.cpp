#include "edgefuse/tsdf/integrate_profile.hpp"

#include <cmath>

#include "edgefuse/tsdf/integrate.hpp"
#include "edgefuse/tsdf/raycast.hpp"
#include "kernel_math.hpp"
#include "block_mask.hpp"
#include "voxel_update.hpp"

namespace edgefuse {
namespace {

// Voxel index range [lo, hi] covered by the fan of a profile (sensor-frame box of the fan,
// transformed to the world, widened by a voxel), clamped to the volume. False when empty.
bool fan_voxel_box(const TsdfVolume& volume, const LineScannerModel& model, const Pose& T_world_sensor, float band_m,
                   int lo[3], int hi[3]) {
  const float reach = model.max_range_m + volume.params().trunc_m;
  const float x0 = reach * std::sin(model.beam_angle_rad(0));
  const float x1 = reach * std::sin(model.beam_angle_rad(model.beams - 1));
  Vec3f bmin = Vec3f::Constant(1e30f), bmax = Vec3f::Constant(-1e30f);
  for (int k = 0; k < 8; ++k) {
    const Vec3f c((k & 1) ? x1 : (x0 < 0.0f ? x0 : 0.0f), (k & 2) ? band_m : -band_m, (k & 4) ? reach : 0.0f);
    const Vec3f w = T_world_sensor * c;
    bmin = bmin.cwiseMin(w);
    bmax = bmax.cwiseMax(w);
  }
  const float vs = volume.voxel_m();
  for (int a = 0; a < 3; ++a) {
    const float l = (bmin(a) - volume.origin_m()(a)) / vs - 1.0f;
    const float h = (bmax(a) - volume.origin_m()(a)) / vs + 1.0f;
    if (h < 0.0f || l >= float(volume.dim())) return false;
    lo[a] = l < 0.0f ? 0 : int(l);
    hi[a] = h >= float(volume.dim() - 1) ? volume.dim() - 1 : int(h);
  }
  return true;
}

// What the voxel loop reads: the world-to-sensor pose and the profile's constants in the kernel's
// number type. Built once per profile and held in a local of integrate_profile, so the voxel
// stores (uint8_t may alias anything) do not make the loop reload them.
template <class Real>
struct ProfileKernel {
  Real R[9], t[3];  // world to sensor
  Real zero, band, min_r, max_r, trunc, inv_trunc, eps, rho, band_to_index, reach, near_z, q_scale;
  const Real* tan_t;  // per beam, increasing
  int last;           // the last beam
  const float* ranges_m;
  uint32_t trust_q8;
  int32_t full_weight;  // of a sample in front of the surface
  const uint16_t* shape;
  uint8_t max_weight;
};

template <class Real>
ProfileKernel<Real> profile_kernel(const TsdfVolume& volume, const LineScannerModel& model,
                                   const LineScannerTables<Real>& tables, const float* ranges_m,
                                   const Pose& T_world_sensor, float band_m, float trust) {
  const TsdfParams& p = volume.params();
  ProfileKernel<Real> k;
  const Pose T_sensor_world = T_world_sensor.inverse();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) k.R[r * 3 + c] = real_from<Real>(T_sensor_world.R(r, c));
    k.t[r] = real_from<Real>(T_sensor_world.t(r));
  }
  k.zero = real_from_int<Real>(0);
  k.band = real_from<Real>(band_m);
  k.min_r = real_from<Real>(model.min_range_m);
  k.max_r = real_from<Real>(model.max_range_m);
  k.trunc = real_from<Real>(p.trunc_m);
  k.inv_trunc = real_from<Real>(1.0f / p.trunc_m);
  k.eps = real_from<Real>(p.weight.eps_m);
  k.rho = real_from<Real>(p.weight.rho_m);
  k.band_to_index = real_from<Real>(float(WeightTable::kSize) / (p.weight.rho_m - p.weight.eps_m));
  k.reach = k.max_r + k.trunc;
  k.near_z = real_from<Real>(p.voxel_m);  // no division by ~0 near the sensor
  k.q_scale = real_from<Real>(float(kTsdfMax));
  k.tan_t = tables.tan_theta;
  k.last = model.beams - 1;
  k.ranges_m = ranges_m;
  k.trust_q8 = uint32_t(std::lround(trust * 256.0f)) > 0 ? uint32_t(std::lround(trust * 256.0f)) : 1u;
  // A sample weighs at most 255 units (trust kProfileTrustMax): the running average's divisor stays
  // within the reciprocal table (old + new <= 510) and |value x weight| sums within 2^24.
  const int32_t full_weight_raw =
      int32_t((uint32_t(WeightTable::kOne) * k.trust_q8 * kWeightUnitsPerSample + 32768u) >> 16);
  k.full_weight = full_weight_raw > 255 ? 255 : full_weight_raw;
  k.shape = volume.weight_table().shape;
  k.max_weight = p.max_weight;
  return k;
}

// The profile's range at `ratio` (x / z in the sensor frame): between the two beams around it
// (bisection on tan(theta), eq. 8 without atan), interpolated when both are valid and within a
// truncation of each other, else the nearer beam's; false when that one has no valid range.
template <class Real>
inline bool profile_range(const ProfileKernel<Real>& k, Real ratio, Real& m) {
  const Real* tan_t = k.tan_t;
  int a = 0, b = k.last;
  while (b - a > 1) {
    const int mid = (a + b) >> 1;
    if (tan_t[mid] <= ratio) a = mid; else b = mid;
  }
  const Real f = (ratio - tan_t[a]) / (tan_t[b] - tan_t[a]);
  const Real ra = real_from<Real>(k.ranges_m[a]), rb = real_from<Real>(k.ranges_m[b]);
  const bool va = k.ranges_m[a] > 0.0f && ra >= k.min_r && ra <= k.max_r;
  const bool vb = k.ranges_m[b] > 0.0f && rb >= k.min_r && rb <= k.max_r;
  const Real jump = ra > rb ? ra - rb : rb - ra;
  if (va && vb && jump <= k.trunc) {
    m = ra + (rb - ra) * f;
  } else {
    const bool near_a = f < real_from<Real>(0.5f);
    if (near_a ? !va : !vb) return false;
    m = near_a ? ra : rb;
  }
  return true;
}

// The sample of the voxel centred at w (world): its distance d along the beam to the surface and
// its weight wt. False when the voxel lies outside the profile's slab, fan or reach, its beams have
// no valid range, or it is too far behind the surface.
template <class Real>
inline bool profile_sample(const ProfileKernel<Real>& k, const Real w[3], Real& d, int32_t& wt) {
  const Real* R = k.R;
  const Real py = R[3] * w[0] + R[4] * w[1] + R[5] * w[2] + k.t[1];
  if (py > k.band || py < k.zero - k.band) return false;  // not in this profile's slab (eq. 8)
  const Real pz = R[6] * w[0] + R[7] * w[1] + R[8] * w[2] + k.t[2];
  if (pz < k.near_z) return false;
  const Real px = R[0] * w[0] + R[1] * w[1] + R[2] * w[2] + k.t[0];
  const Real ratio = px / pz;
  if (ratio < k.tan_t[0] || ratio > k.tan_t[k.last]) return false;  // outside the fan
  const Real range = real_sqrt(px * px + pz * pz);
  if (range > k.reach) return false;
  Real m;
  if (!profile_range(k, ratio, m)) return false;
  d = m - range;  // eq. (1) along the beam
  if (d <= k.zero - k.rho) return false;
  wt = k.full_weight;
  if (d < k.zero - k.eps) {
    int32_t i = floor_int((k.zero - d - k.eps) * k.band_to_index);
    i = i < 0 ? 0 : (i >= WeightTable::kSize ? WeightTable::kSize - 1 : i);
    wt = int32_t((k.shape[i] * k.trust_q8 * kWeightUnitsPerSample + 32768u) >> 16);
    wt = wt > 255 ? 255 : wt;
    if (wt == 0) return false;
  }
  return true;
}

// The voxels of brick (bx, by, bz) within [lo, hi] updated from the profile: false when none was;
// `surface` when one of them holds a distance inside the band. Counts them into `updated`.
template <class Real>
inline bool integrate_profile_brick(TsdfVolume& volume, const ProfileKernel<Real>& k, const int lo[3],
                                    const int hi[3], int bx, int by, int bz, bool& surface, int& updated) {
  const TsdfParams& p = volume.params();
  int16_t* tsdf = volume.tsdf();
  uint8_t* weight = volume.weight();
  bool observed = false;
  const std::size_t brick = volume.brick_index(bx, by, bz);
  const int z_end = (bz << 3) + 7 < hi[2] ? (bz << 3) + 7 : hi[2];
  const int y_end = (by << 3) + 7 < hi[1] ? (by << 3) + 7 : hi[1];
  const int x_end = (bx << 3) + 7 < hi[0] ? (bx << 3) + 7 : hi[0];
  for (int z = (bz << 3) > lo[2] ? (bz << 3) : lo[2]; z <= z_end; ++z)
    for (int y = (by << 3) > lo[1] ? (by << 3) : lo[1]; y <= y_end; ++y)
      for (int x = (bx << 3) > lo[0] ? (bx << 3) : lo[0]; x <= x_end; ++x) {
        // Voxel centre from the exact voxel size (as integrate.cpp), then into the sensor frame.
        const Real w[3] = {real_from<Real>(volume.origin_m()(0) + (float(x) + 0.5f) * p.voxel_m),
                           real_from<Real>(volume.origin_m()(1) + (float(y) + 0.5f) * p.voxel_m),
                           real_from<Real>(volume.origin_m()(2) + (float(z) + 0.5f) * p.voxel_m)};
        Real d;
        int32_t wt;
        if (!profile_sample(k, w, d, wt)) continue;
        int32_t q = d >= k.trunc ? kTsdfMax : round_int(d * k.inv_trunc * k.q_scale);
        q = q > kTsdfMax ? kTsdfMax : (q < -kTsdfMax ? -kTsdfMax : q);
        // The brick gets its pool slot with its first sample; a full pool leaves it out (counted).
        if (!volume.store_brick(brick)) return false;
        const std::size_t idx = volume.index(x, y, z);
        const int32_t old_w = weight[idx];
        if (old_w == k.max_weight && tsdf[idx] == kTsdfMax && q == kTsdfMax) continue;
        const int32_t value = old_w == 0 ? q : voxel_update::blend(tsdf[idx], old_w, q, wt);
        tsdf[idx] = int16_t(value);
        weight[idx] = voxel_update::cap_weight(old_w + wt, k.max_weight);
        observed = true;
        surface = surface || (value < kTsdfMax && value > -kTsdfMax);
        ++updated;
      }
  return observed;
}

}  // namespace

template <class Real>
Status integrate_profile(TsdfVolume& volume, const LineScannerModel& model, const LineScannerTables<Real>& tables,
                         const float* ranges_m, const Pose& T_world_sensor, float plane_band_m, float trust,
                         ProfilePushStats* stats) {
  if (!volume.initialised()) return Status::kNotInitialised;
  if (model.validate() != Status::kOk || ranges_m == nullptr || tables.tan_theta == nullptr ||
      tables.capacity < model.beams || !(trust > 0.0f) || trust > kProfileTrustMax || plane_band_m < 0.0f)
    return Status::kInvalidArgument;
  if (!T_world_sensor.R.allFinite() || !T_world_sensor.t.allFinite()) return Status::kInvalidArgument;
  if (stats != nullptr) *stats = ProfilePushStats{};

  const float band_m = plane_band_m > 0.0f ? plane_band_m : 0.5f * volume.params().voxel_m;
  int lo[3], hi[3];
  uint32_t* list = volume.brick_list();
  if (!fan_voxel_box(volume, model, T_world_sensor, band_m, lo, hi)) return Status::kOk;
  const ProfileKernel<Real> k = profile_kernel(volume, model, tables, ranges_m, T_world_sensor, band_m, trust);
  uint8_t* flags = volume.brick_flags();
  std::size_t listed = 0;
  int updated = 0;
  for (int bz = lo[2] >> 3; bz <= hi[2] >> 3; ++bz)
    for (int by = lo[1] >> 3; by <= hi[1] >> 3; ++by)
      for (int bx = lo[0] >> 3; bx <= hi[0] >> 3; ++bx) {
        const std::size_t brick = volume.brick_index(bx, by, bz);
        bool surface = false;
        if (!integrate_profile_brick(volume, k, lo, hi, bx, by, bz, surface, updated)) continue;
        flags[brick] |= surface ? (kBrickObserved | kBrickSurface) : kBrickObserved;
        if (flags[brick] & kBrickSurface) block_mask::refresh(volume, brick);
        list[listed++] = uint32_t(brick);
      }
  finish_integration(volume, listed);
  if (stats != nullptr) {
    stats->voxels_updated = updated;
    stats->bricks_touched = int(listed);
  }
  return Status::kOk;
}

template <class Real>
Status raycast_profile(const TsdfVolume& volume, const LineScannerModel& model, const Pose& T_world_sensor,
                       float* ranges_out_m) {
  if (!volume.initialised()) return Status::kNotInitialised;
  if (model.validate() != Status::kOk || ranges_out_m == nullptr) return Status::kInvalidArgument;
  const float half = 0.5f * volume.voxel_m();
  for (int i = 0; i < model.beams; ++i) {
    ranges_out_m[i] = 0.0f;
    const float th = model.beam_angle_rad(i);
    const Vec3f dir = T_world_sensor.R * Vec3f(std::sin(th), 0.0f, std::cos(th));
    const Vec3f& o = T_world_sensor.t;
    float r = model.min_range_m, prev_r = 0.0f, prev_d = 0.0f;
    bool prev_ok = false;
    while (r <= model.max_range_m) {
      float d;
      const bool ok = sample_tsdf<Real>(volume, o + r * dir, d);
      if (ok && prev_ok && prev_d > 0.0f && d <= 0.0f) {
        // Regula falsi on [prev_r, r], one refinement.
        float rc = prev_r + (r - prev_r) * prev_d / (prev_d - d);
        float dc;
        if (sample_tsdf<Real>(volume, o + rc * dir, dc) && dc != 0.0f) {
          if (dc > 0.0f && d != dc) rc = rc + (r - rc) * dc / (dc - d);
          else if (dc < 0.0f && prev_d != dc) rc = prev_r + (rc - prev_r) * prev_d / (prev_d - dc);
        }
        if (rc >= model.min_range_m && rc <= model.max_range_m) ranges_out_m[i] = rc;
        break;
      }
      prev_ok = ok;
      prev_d = ok ? d : 0.0f;
      prev_r = r;
      r += ok && d > half ? d : half;
    }
  }
  return Status::kOk;
}

#define EDGEFUSE_INSTANTIATE(Real)                                                                                  \
  template Status integrate_profile<Real>(TsdfVolume&, const LineScannerModel&, const LineScannerTables<Real>&,     \
                                          const float*, const Pose&, float, float, ProfilePushStats*);              \
  template Status raycast_profile<Real>(const TsdfVolume&, const LineScannerModel&, const Pose&, float*);
EDGEFUSE_INSTANTIATE(float)
EDGEFUSE_INSTANTIATE(Fixed)
#undef EDGEFUSE_INSTANTIATE

}  // namespace edgefuse
