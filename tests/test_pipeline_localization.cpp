// The pipeline's localisation job (src/pipeline/localization_job.cpp) on a fused analytic scene (a
// box on the floor seen from three viewpoints, localize_fixture.hpp: 128^3 voxels of 3 mm): the
// whole job and its three stages one by one find the box at its pose, the report counts the
// surface and scene points, a configured bin replaces the detected one, segments replace poses, and
// each stage that refuses is named (an empty map is no refusal: it gives no objects).
#include <array>
#include <cmath>
#include <cstring>
#include <vector>

#include "edgefuse/localize/localizer.hpp"
#include "edgefuse/pipeline/localization_job.hpp"
#include "edgefuse/tsdf/extract.hpp"
#include "scenes.hpp"
#include "test_support.hpp"
#include "localize_fixture.hpp"

using namespace edgefuse;
using namespace edgefuse_test;

namespace {

const Vec3f kHalf(0.03f, 0.02f, 0.0125f);
constexpr std::size_t kPointCapacity = sizeof(g_points) / sizeof(g_points[0]);

Pose box_pose() {
  Pose p;
  p.R = Eigen::AngleAxisf(0.5f, Vec3f::UnitZ()).toRotationMatrix();
  p.t = Vec3f(0.03f, -0.02f, kHalf.z());
  return p;
}

// The localiser with the box model, and the fused scene (floor + the box at box_pose()).
struct JobRig {
  Localizer loc;
  TsdfVolume vol;
  LocalizationRequest request;
  std::size_t fused_points = 0;  // the fixture's own extraction of the map

  explicit JobRig(bool with_box = true) {
    CHECK(loc.init(buffers()) == Status::kOk);
    std::vector<Vec3f> v;
    std::vector<std::array<uint32_t, 3>> t;
    box_mesh(kHalf, v, t);
    int index = -1;
    CHECK(loc.add_model("box", v.data(), v.size(), reinterpret_cast<const uint32_t(*)[3]>(t.data()), t.size(),
                        request.params, index) == Status::kOk);
    Scene scene;
    scene.add_plane(Vec3f(0, 0, 1), 0.0f);
    if (with_box) scene.add_box(box_pose().t, kHalf, box_pose());
    fused_points = fuse(scene, vol, request.viewpoint_m);
    request.max_results = kObjects;
  }
};

}  // namespace

TEST_GROUP(PipelineLocalization){};

TEST(PipelineLocalization, JobFindsTheBoxAtItsPoseAndReportsItsPoints) {
  JobRig rig;
  CHECK(rig.fused_points > 5000);
  LocalizationReport report;
  report.count = 99;
  CHECK(run_localization_job(rig.vol, g_points, kPointCapacity, rig.request, rig.loc, report) == Status::kOk);
  CHECK(report.status == Status::kOk);
  STRCMP_EQUAL("", report.failed);
  // The job extracts the same surface (support rule 0: every observed crossing) and loads all of
  // it: every point is localizable, so the scene before bin removal holds them all.
  LONGS_EQUAL(long(rig.fused_points), long(report.surface_points));
  CHECK_FALSE(report.truncated);
  LONGS_EQUAL(long(report.surface_points), long(report.scene_points));
  // The floor (most of the view) is detected and removed: the box's visible surface remains.
  CHECK(rig.loc.context().has_floor);
  CHECK(rig.loc.context().up.z() > 0.99f);
  CHECK(rig.loc.scene_count() < report.scene_points / 2);
  LONGS_EQUAL(1, long(report.count));
  const LocalizedObject& o = rig.loc.results()[0];
  // Tolerance from the physics (as test_localize): the surface is fused at 3 mm voxels from exact
  // depth, so the refined corners lie within a voxel of the truth.
  const float err = corner_error(kHalf, o.T_world_object, box_pose());
  std::printf("\n  box: corner error %.2f mm, score %.2f; %zu surface points, %zu after bin removal", err * 1e3f,
              o.score, report.surface_points, rig.loc.scene_count());
  LONGS_EQUAL(0, o.model);
  CHECK(err < 0.003f);
  CHECK(o.score > 0.5f);
  // The stages one by one (as `edgefuse localize` runs them) give the same, bit for bit.
  const Pose first = o.T_world_object;
  LocalizationReport staged;
  CHECK(load_map_scene(rig.vol, g_points, kPointCapacity, rig.request, rig.loc, staged) == Status::kOk);
  LONGS_EQUAL(long(report.surface_points), long(staged.surface_points));
  CHECK(remove_bin(rig.request, rig.loc, staged) == Status::kOk);
  LONGS_EQUAL(long(report.scene_points), long(staged.scene_points));
  CHECK(find_objects(rig.request, rig.loc, staged) == Status::kOk);
  LONGS_EQUAL(1, long(staged.count));
  CHECK(rig.loc.results()[0].T_world_object.t == first.t);
  CHECK(rig.loc.results()[0].T_world_object.R == first.R);
}

TEST(PipelineLocalization, ConfiguredBinAndModelFreeSegments) {
  JobRig rig;
  // The bin from configuration: its floor at z = 0 (up = its z axis), 30 x 30 cm inside.
  BinGeometry bin;
  bin.inner_x_m = 0.3f;
  bin.inner_y_m = 0.3f;
  rig.request.bin = &bin;
  LocalizationReport report;
  CHECK(run_localization_job(rig.vol, g_points, kPointCapacity, rig.request, rig.loc, report) == Status::kOk);
  CHECK(rig.loc.context().has_floor);
  CHECK(rig.loc.context().up.z() > 0.999f);
  LONGS_EQUAL(1, long(report.count));
  CHECK(corner_error(kHalf, rig.loc.results()[0].T_world_object, box_pose()) < 0.003f);
  // Model-free: one segment, its centre within 2 voxels of the box's horizontally (its bottom is
  // hidden, so only the horizontal centre and the top are pinned down), its top at the box's.
  rig.request.bin = nullptr;
  rig.request.segments = true;
  CHECK(run_localization_job(rig.vol, g_points, kPointCapacity, rig.request, rig.loc, report) == Status::kOk);
  LONGS_EQUAL(1, long(report.count));
  const LocalizedObject& s = rig.loc.results()[0];
  LONGS_EQUAL(-1, s.model);
  const Vec3f d = s.T_world_object.t - box_pose().t;
  std::printf("\n  segment: centre %.1f mm (horizontal) from the box's, top %.1f mm", std::hypot(d.x(), d.y()) * 1e3f,
              s.top_m * 1e3f);
  CHECK(std::hypot(d.x(), d.y()) < 0.006f);
  DOUBLES_EQUAL(2.0f * kHalf.z(), s.top_m, 0.003);
}

TEST(PipelineLocalization, AnEmptyMapGivesNoObjectsAndATruncatedSurfaceIsReported) {
  JobRig rig(false);  // the floor alone
  LocalizationReport report;
  CHECK(run_localization_job(rig.vol, g_points, kPointCapacity, rig.request, rig.loc, report) == Status::kOk);
  STRCMP_EQUAL("", report.failed);
  CHECK(report.surface_points > 5000);
  LONGS_EQUAL(0, long(report.count));
  // A space with no surface at all (nothing integrated): no refusal, nothing found.
  rig.vol.clear();
  report.count = 5;
  CHECK(run_localization_job(rig.vol, g_points, kPointCapacity, rig.request, rig.loc, report) == Status::kOk);
  CHECK(report.status == Status::kOk);
  STRCMP_EQUAL("", report.failed);
  LONGS_EQUAL(0, long(report.surface_points));
  LONGS_EQUAL(0, long(report.scene_points));
  LONGS_EQUAL(0, long(report.count));
  // More surface than the point buffer holds: the first `capacity` points are localised, and the
  // report says the surface was cut.
  JobRig boxed;
  CHECK(run_localization_job(boxed.vol, g_points, 1000, boxed.request, boxed.loc, report) == Status::kOk);
  CHECK(report.truncated);
  LONGS_EQUAL(1000, long(report.surface_points));
  STRCMP_EQUAL("", report.failed);
}

TEST(PipelineLocalization, EachRefusingStageIsNamed) {
  LocalizationRequest request;
  request.max_results = kObjects;
  LocalizationReport report;
  // Extraction: a volume without storage.
  Localizer loc;
  CHECK(loc.init(buffers()) == Status::kOk);
  TsdfVolume unbound;
  CHECK(run_localization_job(unbound, g_points, kPointCapacity, request, loc, report) == Status::kNotInitialised);
  CHECK(report.status == Status::kNotInitialised);
  STRCMP_EQUAL("extraction", report.failed);
  // Scene: a localiser without its buffers.
  JobRig rig;
  Localizer bare;
  CHECK(run_localization_job(rig.vol, g_points, kPointCapacity, request, bare, report) == Status::kNotInitialised);
  STRCMP_EQUAL("scene", report.failed);
  CHECK(report.surface_points > 5000);  // extraction had run
  // Localisation: find_objects alone on a localiser without its buffers (segments too).
  LocalizationReport r2;
  CHECK(find_objects(request, bare, r2) == Status::kNotInitialised);
  STRCMP_EQUAL("localisation", r2.failed);
  request.segments = true;
  LocalizationReport r3;
  CHECK(find_objects(request, bare, r3) == Status::kNotInitialised);
  STRCMP_EQUAL("localisation", r3.failed);
}
