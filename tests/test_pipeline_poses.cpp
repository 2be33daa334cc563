// The pipeline's pose helpers: PoseHistory (the reference camera's pose at another camera's stamp:
// constant-velocity interpolation, extrapolation clamped at kPairWindowUs, velocity only between
// placed frames kVelocityGapMinUs..kVelocityGapMaxUs apart), StillDetector (still within 1 mm /
// 0.1 degree of an anchor pose, slow drift counts) and view_centre (median world point of the
// first view, where a new map is centred). Pure arithmetic on float poses: the same in every build.
#include <cmath>
#include <cstdint>
#include <vector>

#include "edgefuse/pipeline/pose_history.hpp"
#include "edgefuse/pipeline/still_detector.hpp"
#include "edgefuse/pipeline/view_centre.hpp"
#include "scenes.hpp"
#include "pipeline_fixture.hpp"

using namespace edgefuse;
using namespace edgefuse_test;
using namespace pipeline_test;

namespace {

constexpr float kDegToRad = 3.14159265f / 180.0f;

Pose pose_of(const Vec3f& t, float deg_about_axis, const Vec3f& axis = Vec3f(0.2f, 1.0f, 0.3f)) {
  Pose p;
  p.R = Eigen::AngleAxisf(deg_about_axis * kDegToRad, axis.normalized()).toRotationMatrix();
  p.t = t;
  return p;
}

// Two reference poses 33 ms apart on a constant-velocity path: 0.25 m/s along x and y, 30 deg/s.
// Float poses: interpolation is exact to ~1e-7 relative, so positions agree within 1 um and angles
// within 1e-3 degree (acos of a float trace near 1 alone has ~0.03 degree noise: the quaternion
// form of pose_error is used).
constexpr uint64_t kT0 = 1000000, kGap = 33000;
const Vec3f kV(0.25f, 0.25f, 0.0f);  // m/s
constexpr float kW = 30.0f;          // deg/s about one fixed axis

Pose truth_at(double t_us) {
  const double s = (t_us - double(kT0)) * 1e-6;
  return pose_of(Vec3f(0.1f, -0.2f, 0.5f) + kV * float(s), 5.0f + kW * float(s));
}

void check_pose(const Pose& got, const Pose& want, float tol_m = 1e-6f, float tol_deg = 1e-3f) {
  float dt, deg;
  pose_distance(got, want, dt, deg);
  if (dt > tol_m || deg > tol_deg) std::printf("\n  pose error %.3g m %.3g deg", double(dt), double(deg));
  CHECK(dt <= tol_m);
  CHECK(deg <= tol_deg);
}

}  // namespace

TEST_GROUP(PipelinePoseHistory){};

TEST(PipelinePoseHistory, InterpolatesAndExtrapolatesAtConstantVelocityClampedAtThePairWindow) {
  PoseHistory h;
  CHECK_FALSE(h.has_pose());
  CHECK_FALSE(h.has_velocity());
  h.record(kT0, truth_at(kT0), true);
  CHECK(h.has_pose());
  CHECK_FALSE(h.has_velocity());  // one pose: no velocity yet, pose_at gives it whatever the stamp
  check_pose(h.pose_at(kT0 + 20000), truth_at(kT0));
  h.record(kT0 + kGap, truth_at(kT0 + kGap), true);
  CHECK(h.has_velocity());
  CHECK(h.stamp_us() == kT0 + kGap);
  check_pose(h.last(), truth_at(kT0 + kGap));
  // Between the two frames, and beyond either by less than the window: on the path.
  for (const double t : {double(kT0), kT0 + 0.5 * kGap, double(kT0 + kGap), double(kT0 + kGap + 30000),
                         double(kT0) - 30000.0})
    check_pose(h.pose_at(uint64_t(t)), truth_at(t), 2e-6f);
  // Beyond the window the pose stops where the window ends (no wild extrapolation).
  const uint64_t last = kT0 + kGap, window = PoseHistory::kPairWindowUs;
  check_pose(h.pose_at(last + window + 500000), truth_at(double(last + window)), 2e-6f);
  check_pose(h.pose_at(kT0 - window - 300000), truth_at(double(kT0 - window)), 2e-6f);
}

TEST(PipelinePoseHistory, NoVelocityOutsideTheGapLimitsOrAfterAnUnplacedFrame) {
  const Pose a = truth_at(kT0), b = truth_at(kT0 + kGap);
  PoseHistory h;
  // Closer than kVelocityGapMinUs: pose noise would be magnified; the last pose only.
  h.record(kT0, a, true);
  h.record(kT0 + PoseHistory::kVelocityGapMinUs - 1, b, true);
  CHECK(h.has_pose());
  CHECK_FALSE(h.has_velocity());
  check_pose(h.pose_at(kT0 + 20000), b);
  // The limits themselves give a velocity.
  h.clear();
  h.record(kT0, a, true);
  h.record(kT0 + PoseHistory::kVelocityGapMinUs, b, true);
  CHECK(h.has_velocity());
  h.clear();
  h.record(kT0, a, true);
  h.record(kT0 + PoseHistory::kVelocityGapMaxUs, b, true);
  CHECK(h.has_velocity());
  // Farther than kVelocityGapMaxUs.
  h.clear();
  h.record(kT0, a, true);
  h.record(kT0 + PoseHistory::kVelocityGapMaxUs + 1, b, true);
  CHECK_FALSE(h.has_velocity());
  check_pose(h.pose_at(kT0 + PoseHistory::kVelocityGapMaxUs + 20000), b);
  // A stamp that goes back in time gives no velocity either.
  h.clear();
  h.record(kT0 + kGap, b, true);
  h.record(kT0, a, true);
  CHECK_FALSE(h.has_velocity());
  check_pose(h.pose_at(kT0 + 5000), a);
  // An unplaced (lost) frame: no pose, and the next placed frame has no velocity (its predecessor
  // had no pose); the one after has again.
  h.clear();
  h.record(kT0, a, true);
  h.record(kT0 + kGap, b, true);
  CHECK(h.has_velocity());
  h.record(kT0 + 2 * kGap, Pose(), false);
  CHECK_FALSE(h.has_pose());
  CHECK_FALSE(h.has_velocity());
  h.record(kT0 + 3 * kGap, truth_at(kT0 + 3 * kGap), true);
  CHECK(h.has_pose());
  CHECK_FALSE(h.has_velocity());
  check_pose(h.pose_at(kT0 + 3 * kGap + 20000), truth_at(kT0 + 3 * kGap));
  h.record(kT0 + 4 * kGap, truth_at(kT0 + 4 * kGap), true);
  CHECK(h.has_velocity());
  check_pose(h.pose_at(kT0 + 4 * kGap - kGap / 2), truth_at(kT0 + 3.5 * kGap), 2e-6f);
}

TEST(PipelinePoseHistory, ClearForgetsEveryPose) {
  PoseHistory h;
  h.record(kT0, truth_at(kT0), true);
  h.record(kT0 + kGap, truth_at(kT0 + kGap), true);
  CHECK(h.has_velocity());
  h.clear();
  CHECK_FALSE(h.has_pose());
  CHECK_FALSE(h.has_velocity());
  // The first frame after clear() starts a new history: no velocity with the forgotten pose.
  h.record(kT0 + 2 * kGap, truth_at(kT0 + 2 * kGap), true);
  CHECK(h.has_pose());
  CHECK_FALSE(h.has_velocity());
  check_pose(h.pose_at(kT0 + 2 * kGap + 30000), truth_at(kT0 + 2 * kGap));
}

TEST_GROUP(PipelineStillDetector){};

TEST(PipelineStillDetector, StillWithinTheToleranceOfTheAnchorMovingWhenItLeaves) {
  StillDetector d;
  const Pose p0 = pose_of(Vec3f(0.3f, 0.1f, 0.6f), 20.0f);
  d.update(p0, 1000);
  LONGS_EQUAL(0, long(d.still_since_us()));  // one pose: not known yet
  // Jitter well inside 1 mm / 0.1 degree of the anchor (a tracked pose's noise): still from the
  // second pose on, and the moment stays put.
  d.update(pose_of(p0.t + Vec3f(0.0004f, -0.0003f, 0.0002f), 20.03f), 2000);
  const uint64_t since = d.still_since_us();
  CHECK(since >= 1000 && since <= 2000);
  for (int i = 0; i < 20; ++i) {
    const float s = (i % 2) ? 1.0f : -1.0f;
    d.update(pose_of(p0.t + s * Vec3f(0.0005f, 0.0004f, -0.0003f), 20.0f + s * 0.05f), 3000 + 1000 * uint64_t(i));
    CHECK(d.still_since_us() == since);
  }
  // Leaving by 1.5 mm: moving.
  const Pose p1 = pose_of(p0.t + Vec3f(0.0015f, 0.0f, 0.0f), 20.0f);
  d.update(p1, 30000);
  LONGS_EQUAL(0, long(d.still_since_us()));
  // Staying at the new place (the anchor moved on with the rig): still again, since then.
  d.update(pose_of(p1.t + Vec3f(0.0002f, 0, 0), 20.0f), 31000);
  const uint64_t since2 = d.still_since_us();
  CHECK(since2 >= 30000 && since2 <= 31000);
  // Turning by 0.15 degree (no translation): moving.
  d.update(pose_of(p1.t, 20.15f), 32000);
  LONGS_EQUAL(0, long(d.still_since_us()));
}

TEST(PipelineStillDetector, SlowDriftAccumulatesPastTheToleranceAndCountsAsMoving) {
  // 0.3 mm per frame: each step is far below 1 mm, but the anchor stays where the rig stopped, so
  // after 4 steps (1.2 mm; 3 steps are 0.9 mm) the rig is moving. A per-frame test would call it
  // still forever.
  StillDetector d;
  Pose p = pose_of(Vec3f(0, 0, 0.5f), 0.0f);
  d.update(p, 0);
  bool moved = false;
  int step_moved = -1;
  for (int i = 1; i <= 8 && !moved; ++i) {
    p.t.x() += 0.0003f;
    d.update(p, uint64_t(i) * 33000);
    if (d.still_since_us() == 0) {
      moved = true;
      step_moved = i;
    } else {
      CHECK(d.still_since_us() == 33000);
    }
  }
  CHECK(moved);
  LONGS_EQUAL(4, step_moved);
  // The same for a slow turn: 0.028 degree per frame passes 0.1 degree on the 4th step (0.084 after
  // 3; the float acos of the trace is good to ~0.01 degree there).
  StillDetector r;
  r.update(pose_of(Vec3f(0, 0, 0.5f), 0.0f), 0);
  int turned = -1;
  for (int i = 1; i <= 8 && turned < 0; ++i) {
    r.update(pose_of(Vec3f(0, 0, 0.5f), 0.028f * float(i)), uint64_t(i) * 33000);
    if (r.still_since_us() == 0) turned = i;
  }
  LONGS_EQUAL(4, turned);
}

TEST(PipelineStillDetector, ResetForgetsTheAnchorAndMarkStillKeepsAnEarlierMoment) {
  StillDetector d;
  const Pose p = pose_of(Vec3f(0.1f, 0, 0.5f), 0.0f);
  d.update(p, 1000);
  d.update(p, 2000);
  CHECK(d.still_since_us() != 0);
  d.reset();
  LONGS_EQUAL(0, long(d.still_since_us()));
  // After reset the first pose is a new anchor, even far from the old one: not yet still.
  const Pose far = pose_of(Vec3f(0.5f, 0, 0.5f), 10.0f);
  d.update(far, 3000);
  LONGS_EQUAL(0, long(d.still_since_us()));
  d.mark_still(4000);  // a recording ended: still from now on
  CHECK(d.still_since_us() == 4000);
  d.mark_still(5000);  // already still: the earlier moment stays
  CHECK(d.still_since_us() == 4000);
  d.update(far, 6000);  // still where it is: the moment stays
  CHECK(d.still_since_us() == 4000);
}

TEST_GROUP(PipelineViewCentre){};

namespace {
CentreScratch g_centre;
}

TEST(PipelineViewCentre, MedianOfTheViewInWorldCoordinates) {
  // A fronto-parallel plane at 0.8 m, seen from a camera at (1, 2, 3) turned 90 degrees about z.
  const PinholeIntrinsics cam = small_camera();
  Pose T;
  T.R = Eigen::AngleAxisf(90.0f * kDegToRad, Vec3f::UnitZ()).toRotationMatrix();
  T.t = Vec3f(1.0f, 2.0f, 3.0f);
  std::vector<uint16_t> depth(std::size_t(cam.width) * cam.height, uint16_t(0.8f * cam.depth_scale));
  Vec3f centre;
  const std::size_t n = view_centre(cam, ImageView<const uint16_t>(depth.data(), cam.width, cam.height), T,
                                    g_centre.view(), centre);
  LONGS_EQUAL(80 * 60, long(n));  // every 2nd pixel of every 2nd row
  // The samples sit on even pixels, half a pixel off the principal point (79.5, 59.5), and the median
  // of an even count is the upper middle one: per world axis at most 1.5 pixels from the optical
  // axis, 1.5 x 0.8 / 250 = 4.8 mm at 0.8 m. Tolerance 5 mm per axis; the depth itself is exact.
  const Vec3f expect = T * Vec3f(0, 0, 0.8f);
  std::printf("\n  centre (%.5f %.5f %.5f) expect (%.5f %.5f %.5f)", centre.x(), centre.y(), centre.z(), expect.x(),
              expect.y(), expect.z());
  CHECK(((centre - expect).cwiseAbs().array() < 0.005f).all());
  DOUBLES_EQUAL(3.8, centre.z(), 1e-4);  // the depth itself is exact
}

TEST(PipelineViewCentre, SkipsPixelsWithoutDepthOrOutOfRange) {
  const PinholeIntrinsics cam = small_camera();
  const int w = cam.width, h = cam.height;
  std::vector<uint16_t> depth(std::size_t(w) * h, 0);
  // Left half: no depth; right half: rows 0..59 at 0.05 m (below min_range 0.1), rows 60..119 at
  // 1.0 m. Only the last quarter counts: 40 x 30 samples, median at depth 1.0 m.
  for (int v = 0; v < h; ++v)
    for (int u = w / 2; u < w; ++u) depth[std::size_t(v) * w + u] = uint16_t((v < h / 2 ? 0.05f : 1.0f) * cam.depth_scale);
  Vec3f centre;
  const std::size_t n = view_centre(cam, ImageView<const uint16_t>(depth.data(), w, h), Pose(), g_centre.view(), centre);
  LONGS_EQUAL(40 * 30, long(n));
  DOUBLES_EQUAL(1.0, centre.z(), 1e-4);
  CHECK(centre.x() > 0 && centre.y() > 0);  // right, lower quarter of the image
  // Beyond max_range (3 m) counts as nothing too: no sample, centre_m unchanged.
  std::fill(depth.begin(), depth.end(), uint16_t(3.5f * cam.depth_scale));
  Vec3f kept(7, 8, 9);
  LONGS_EQUAL(0, long(view_centre(cam, ImageView<const uint16_t>(depth.data(), w, h), Pose(), g_centre.view(), kept)));
  CHECK(kept == Vec3f(7, 8, 9));
}

TEST(PipelineViewCentre, VolumeOriginIsTheCentreLessHalfTheCube) {
  const Vec3f o = volume_origin_for(Vec3f(0.1f, -0.2f, 0.9f), 64, 0.01f);
  CHECK((o - Vec3f(-0.22f, -0.52f, 0.58f)).norm() < 1e-6f);
}
