#include "laser_push.hpp"

#include <cmath>
#include <cstdio>
#include <vector>

#include "edgefuse/math/real.hpp"
#include "edgefuse/core/status.hpp"
#include "edgefuse/sensor/line_scanner.hpp"

namespace edgefuse::cli {

bool push_line_scan(Mapper& mapper, const io::LineScan& scan, void* tan_table, int tan_capacity,
                    const LaserPushOptions& options, LaserPushStats& stats, std::string& err) {
  const TsdfVolume& volume = mapper.volume();
  stats = LaserPushStats{};
  LineScannerModel model;
  model.beams = scan.sensor.line.beams;
  model.fov_deg = scan.sensor.line.fov_deg;
  model.min_range_m = scan.sensor.line.min_range_m;
  model.max_range_m = scan.sensor.line.max_range_m;
  LineScannerTables<real_t> tables;
  tables.tan_theta = static_cast<real_t*>(tan_table);
  tables.capacity = tan_capacity;
  if (tables.build(model) != Status::kOk) {
    err = scan.sensor.name + ": bad line scanner parameters";
    return false;
  }
  if (options.register_patches && options.patch_profiles < 1) {
    err = "a registration patch needs at least 1 profile";
    return false;
  }
  ProfileRegistrationParams reg = options.reg;
  if (!(reg.max_distance_m > 0.0f)) reg.max_distance_m = 0.5f * volume.params().trunc_m;
  const float max_rms = options.max_rms_m > 0.0f ? options.max_rms_m : 0.5f * volume.voxel_m();
  const std::size_t n = scan.profiles.size();
  const std::size_t patch = options.register_patches ? std::size_t(options.patch_profiles) : 1;
  std::vector<Pose> poses(patch);  // host side: one allocation before the loop
  Pose carried;                    // world-frame correction carried from patch to patch
  double rms_sum = 0;
  for (std::size_t p0 = 0; p0 < n;) {
    // A patch: up to `patch` consecutive profiles that all have poses.
    std::size_t count = 0;
    while (p0 + count < n && count < patch && scan.has_pose[p0 + count]) {
      poses[count] = carried * scan.T_world_sensor[p0 + count];
      ++count;
    }
    if (count == 0) {  // a profile without a pose is skipped
      ++p0;
      continue;
    }
    if (options.register_patches) {
      ++stats.patches;
      ProfileRegistrationResult r;
      const Status s = register_profiles<real_t>(volume, model, scan.profiles.profile(p0), poses.data(), count, reg, r);
      if (s != Status::kOk) {
        err = scan.sensor.name + ": profiles " + std::to_string(p0) + "..: registration: " + to_string(s);
        return false;
      }
      if (options.verbose) {
        const Vec3f o = poses[0].t;
        std::printf("  patch %zu-%zu: %s, %d points, %d of %d directions, rms %.3f mm, moves the first profile by "
                    "%.3f mm, %.4f deg\n",
                    p0, p0 + count - 1, r.accepted && r.rms_m <= max_rms ? "accepted" : "refused", r.points,
                    r.observable, reg.translation_only ? 3 : 6, 1e3f * r.rms_m, 1e3f * (r.T_correction * o - o).norm(),
                    57.29578f * r.T_correction.angle_rad());
      }
      if (r.accepted && r.rms_m <= max_rms) {
        ++stats.accepted;
        rms_sum += r.rms_m;
        // How far the correction moved a point of this patch (the first profile's origin).
        const Vec3f o = poses[0].t;
        const float step_mm = 1e3f * (r.T_correction * o - o).norm();
        if (stats.accepted > 1 && step_mm > stats.max_step_mm) stats.max_step_mm = step_mm;
        carried = r.T_correction * carried;
        for (std::size_t k = 0; k < count; ++k) poses[k] = r.T_correction * poses[k];
      }
    }
    if (stats.profiles == 0) stats.first_pose_used = poses[0];
    for (std::size_t k = 0; k < count; ++k) {
      const Status s = mapper.map_profile(model, tables, scan.profiles.profile(p0 + k), poses[k], kLineScannerSigmaM);
      if (s != Status::kOk) {
        err = scan.sensor.name + ": profile " + std::to_string(p0 + k) + ": " + to_string(s);
        return false;
      }
      ++stats.profiles;
    }
    p0 += count;
  }
  stats.mean_rms_m = stats.accepted > 0 ? float(rms_sum / stats.accepted) : 0.0f;
  stats.last_correction = carried;
  return true;
}

}  // namespace edgefuse::cli
