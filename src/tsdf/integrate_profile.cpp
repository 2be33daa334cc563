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

  const TsdfParams& p = volume.params();
  const float band_m = plane_band_m > 0.0f ? plane_band_m : 0.5f * p.voxel_m;
  int lo[3], hi[3];
  uint32_t* list = volume.brick_list();
  if (!fan_voxel_box(volume, model, T_world_sensor, band_m, lo, hi)) return Status::kOk;

  const Pose T_sensor_world = T_world_sensor.inverse();
  Real R[9], t[3];
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) R[r * 3 + c] = real_from<Real>(T_sensor_world.R(r, c));
    t[r] = real_from<Real>(T_sensor_world.t(r));
  }
  const Real zero = real_from_int<Real>(0);
  const Real band = real_from<Real>(band_m);
  const Real min_r = real_from<Real>(model.min_range_m), max_r = real_from<Real>(model.max_range_m);
  const Real trunc = real_from<Real>(p.trunc_m), inv_trunc = real_from<Real>(1.0f / p.trunc_m);
  const Real eps = real_from<Real>(p.weight.eps_m), rho = real_from<Real>(p.weight.rho_m);
  const Real band_to_index = real_from<Real>(float(WeightTable::kSize) / (p.weight.rho_m - p.weight.eps_m));
  const Real reach = max_r + trunc;
  const Real near_z = real_from<Real>(p.voxel_m);  // no division by ~0 near the sensor
  const Real q_scale = real_from<Real>(float(kTsdfMax));
  const Real* tan_t = tables.tan_theta;
  const int last = model.beams - 1;
  const uint32_t trust_q8 = uint32_t(std::lround(trust * 256.0f)) > 0 ? uint32_t(std::lround(trust * 256.0f)) : 1u;
  // A sample weighs at most 255 units (trust kProfileTrustMax): the running average's divisor stays
  // within the reciprocal table (old + new <= 510) and |value x weight| sums within 2^24.
  const int32_t full_weight_raw = int32_t((uint32_t(WeightTable::kOne) * trust_q8 * kWeightUnitsPerSample + 32768u) >> 16);
  const int32_t full_weight = full_weight_raw > 255 ? 255 : full_weight_raw;
  const uint16_t* shape = volume.weight_table().shape;
  const uint8_t max_weight = p.max_weight;
  int16_t* tsdf = volume.tsdf();
  uint8_t* weight = volume.weight();
  uint8_t* flags = volume.brick_flags();

  std::size_t listed = 0;
  int updated = 0;
  for (int bz = lo[2] >> 3; bz <= hi[2] >> 3; ++bz)
    for (int by = lo[1] >> 3; by <= hi[1] >> 3; ++by)
      for (int bx = lo[0] >> 3; bx <= hi[0] >> 3; ++bx) {
        const std::size_t brick = volume.brick_index(bx, by, bz);
        bool observed = false, surface = false;
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
              const Real py = R[3] * w[0] + R[4] * w[1] + R[5] * w[2] + t[1];
              if (py > band || py < zero - band) continue;  // not in this profile's slab (eq. 8)
              const Real pz = R[6] * w[0] + R[7] * w[1] + R[8] * w[2] + t[2];
              if (pz < near_z) continue;
              const Real px = R[0] * w[0] + R[1] * w[1] + R[2] * w[2] + t[0];
              const Real ratio = px / pz;
              if (ratio < tan_t[0] || ratio > tan_t[last]) continue;  // outside the fan
              const Real range = real_sqrt(px * px + pz * pz);
              if (range > reach) continue;
              // Beam of the voxel: bisection on tan(theta) (eq. 8 without atan).
              int a = 0, b = last;
              while (b - a > 1) {
                const int mid = (a + b) >> 1;
                if (tan_t[mid] <= ratio) a = mid; else b = mid;
              }
              const Real f = (ratio - tan_t[a]) / (tan_t[b] - tan_t[a]);
              const Real ra = real_from<Real>(ranges_m[a]), rb = real_from<Real>(ranges_m[b]);
              const bool va = ranges_m[a] > 0.0f && ra >= min_r && ra <= max_r;
              const bool vb = ranges_m[b] > 0.0f && rb >= min_r && rb <= max_r;
              Real m;
              const Real jump = ra > rb ? ra - rb : rb - ra;
              if (va && vb && jump <= trunc) {
                m = ra + (rb - ra) * f;
              } else {
                const bool near_a = f < real_from<Real>(0.5f);
                if (near_a ? !va : !vb) continue;
                m = near_a ? ra : rb;
              }
              const Real d = m - range;  // eq. (1) along the beam
              if (d <= zero - rho) continue;
              int32_t wt = full_weight;
              if (d < zero - eps) {
                int32_t k = floor_int((zero - d - eps) * band_to_index);
                k = k < 0 ? 0 : (k >= WeightTable::kSize ? WeightTable::kSize - 1 : k);
                wt = int32_t((shape[k] * trust_q8 * kWeightUnitsPerSample + 32768u) >> 16);
                wt = wt > 255 ? 255 : wt;
                if (wt == 0) continue;
              }
              int32_t q = d >= trunc ? kTsdfMax : round_int(d * inv_trunc * q_scale);
              q = q > kTsdfMax ? kTsdfMax : (q < -kTsdfMax ? -kTsdfMax : q);
              const std::size_t idx = volume.index(x, y, z);
              const int32_t old_w = weight[idx];
              if (old_w == max_weight && tsdf[idx] == kTsdfMax && q == kTsdfMax) continue;
              const int32_t value = old_w == 0 ? q : voxel_update::blend(tsdf[idx], old_w, q, wt);
              tsdf[idx] = int16_t(value);
              weight[idx] = voxel_update::cap_weight(old_w + wt, max_weight);
              observed = true;
              surface = surface || (value < kTsdfMax && value > -kTsdfMax);
              ++updated;
            }
        if (!observed) continue;
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
