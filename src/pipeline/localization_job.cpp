#include "edgefuse/pipeline/localization_job.hpp"

namespace edgefuse {

Status load_map_scene(const TsdfVolume& volume, SurfacePoint* points, std::size_t capacity,
                      const LocalizationRequest& request, Localizer& loc, LocalizationReport& report) {
  std::size_t count = 0;
  const Status xs = extract_points(volume, points, capacity, count, request.support_weight);
  if (xs != Status::kOk && xs != Status::kOutputTruncated) {
    report.status = xs;
    report.failed = "extraction";
    return xs;
  }
  const std::size_t kept = keep_supported(volume, points, count, request.min_point_weight);
  report.weak_points = count - kept;
  count = kept;
  report.surface_points = count;
  SceneContext ctx;
  ctx.viewpoint_m = request.viewpoint_m;
  const Status ss = loc.set_scene(points, count, ctx, &volume, kSceneGridVoxels * volume.voxel_m());
  report.truncated = xs == Status::kOutputTruncated || ss == Status::kOutputTruncated;
  if (ss != Status::kOk && ss != Status::kOutputTruncated) {
    report.status = ss;
    report.failed = "scene";
    return ss;
  }
  return Status::kOk;
}

Status remove_bin(const LocalizationRequest& request, Localizer& loc, LocalizationReport& report) {
  report.scene_points = loc.scene_count();
  // A scene without a floor is localised as it is: the bin's absence is reported in the context.
  return request.bin != nullptr ? loc.set_bin(*request.bin, request.params) : loc.remove_bin(request.params);
}

Status find_objects(const LocalizationRequest& request, Localizer& loc, LocalizationReport& report) {
  report.count = 0;
  const Status s = request.segments ? loc.segment(request.params, request.max_results, report.count)
                                    : loc.localize(request.params, request.max_results, report.count);
  if (s != Status::kOk) {
    report.status = s;
    report.failed = "localisation";
  }
  return s;
}

Status run_localization_job(const TsdfVolume& volume, SurfacePoint* points, std::size_t capacity,
                        const LocalizationRequest& request, Localizer& loc, LocalizationReport& report) {
  report = LocalizationReport();
  Status s = load_map_scene(volume, points, capacity, request, loc, report);
  if (s != Status::kOk) return s;
  remove_bin(request, loc, report);
  return find_objects(request, loc, report);
}

}  // namespace edgefuse
