// Rigid-pair calibration (paper Fig. 6): a space filled by camera A, a second camera B of other
// intrinsics mounted at a known T_A_B; calibrate_pair recovers T_A_B from a rough guess, and
// refuses a scene that is a single plane with a message that says so.
#include <cmath>
#include <cstring>
#include <vector>

#include "edgefuse/fusion/align_spaces.hpp"
#include "edgefuse/fusion/calibrate_pair.hpp"
#include "edgefuse/fusion/pose_mean.hpp"
#include "edgefuse/tsdf/integrate.hpp"
#include "test_tracking_rig.hpp"
#include "test_support.hpp"

using namespace edgefuse;
using namespace edgefuse_test;

namespace {
constexpr int kBW = 160, kBH = 120;
RigBuffers<float> g_rig;
RigBuffers<Fixed> g_rig_q;
template <class Real>
struct BBuffers {
  static constexpr std::size_t kPyr = pyramid_pixels(kBW, kBH);
  Point3<Real> pv[kPyr], pn[kPyr];
  alignas(8) unsigned char rows[kBH * kIcpRowBytes];
  float depth_m[kBW * kBH];
  Vec3f vertex[kBW * kBH], normal[kBW * kBH];
  uint16_t frame[kBW * kBH];
};
BBuffers<float> g_b;
BBuffers<Fixed> g_b_q;
template <class Real>
RigBuffers<Real>& rig_buffers();
template <>
RigBuffers<float>& rig_buffers<float>() { return g_rig; }
template <>
RigBuffers<Fixed>& rig_buffers<Fixed>() { return g_rig_q; }
template <class Real>
BBuffers<Real>& b_buffers();
template <>
BBuffers<float>& b_buffers<float>() { return g_b; }
template <>
BBuffers<Fixed>& b_buffers<Fixed>() { return g_b_q; }

// A ToF-like camera: 160 x 120, wide, non-square pixels; `binning` pixels to one (the same view).
PinholeIntrinsics camera_b(int binning = 1) {
  PinholeIntrinsics c;
  c.width = kBW / binning;
  c.height = kBH / binning;
  c.fx = 160.0f / float(binning);
  c.fy = 170.0f / float(binning);
  c.cx = 0.5f * float(c.width) - 0.5f;
  c.cy = 0.5f * float(c.height) - 0.5f;
  c.depth_scale = 10000.0f;
  c.min_range_m = 0.1f;
  c.max_range_m = 3.0f;
  return c;
}

Pose mounting() {  // B 5 cm to the right of A, 6 mm down, turned by 3.4 degrees
  Pose T;
  T.R = Eigen::AngleAxisf(3.4f * float(M_PI) / 180.0f, Vec3f(-0.45f, -0.63f, 0.64f).normalized()).toRotationMatrix();
  T.t = Vec3f(0.05f, 0.006f, -0.002f);
  return T;
}

struct Outcome {
  PairCalibrationResult r;
  Status status;
};

// B's view: all of it, or a window of it (w x h pixels with its top-left corner at x0, y0; the rest
// sees nothing), as a sensor whose field of view holds little of the map.
struct View {
  int x0 = 0, y0 = 0, w = kBW, h = kBH;
  int binning = 1;  //!< camera_b's binning
};

template <class Real = float>
Outcome run_pair(const Scene& scene, const Pose& guess, const View& view = View()) {
  RigBuffers<Real>& g_rig = rig_buffers<Real>();
  BBuffers<Real>& g_b = b_buffers<Real>();
  Rig<Real> rig(g_rig, kRigCentre, 0.01f);
  const std::vector<Pose> poses = known_motion(6);
  std::vector<uint16_t> depth;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    render(scene, rig.cam, poses[i], depth);
    add_depth_noise(depth, rig.cam.depth_scale, 0.0015f, uint32_t(i + 1));
    for (std::size_t k = 0; k < depth.size(); ++k) g_rig.frame[k] = depth[k];
    integrate<Real>(rig.volume, rig.cam, rig.norms, DepthFrame{ImageView<const uint16_t>(g_rig.frame, kRigW, kRigH), {}},
                     poses[i], rig.scratch);
  }
  const PinholeIntrinsics cb = camera_b(view.binning);
  const int bw = cb.width, bh = cb.height;
  const Pose T_world_a = poses.back();
  render(scene, cb, T_world_a * mounting(), depth);
  add_depth_noise(depth, cb.depth_scale, 0.004f, 99u);
  for (std::size_t k = 0; k < depth.size(); ++k) {
    const int x = int(k) % bw, y = int(k) / bw;
    const bool seen = x >= view.x0 && x < view.x0 + view.w && y >= view.y0 && y < view.y0 + view.h;
    g_b.frame[k] = seen ? depth[k] : 0;
  }
  FramePyramid<Real> pyr;
  bind_pyramid<Real>(cb, g_b.pv, g_b.pn, BBuffers<Real>::kPyr, pyr);
  build_pyramid<Real>(ImageView<const uint16_t>(g_b.frame, bw, bh), PyramidParams(), pyr);
  RaycastMaps maps;
  maps.depth_m = ImageView<float>(g_b.depth_m, bw, bh);
  maps.vertex = ImageView<Vec3f>(g_b.vertex, bw, bh);
  maps.normal = ImageView<Vec3f>(g_b.normal, bw, bh);
  const IcpWorkspace<Real> ws = IcpWorkspace<Real>::bind(g_b.rows, sizeof(g_b.rows));
  Outcome o;
  o.status = calibrate_pair<Real>(rig.volume, T_world_a, guess, cb, pyr, maps, ws, PairCalibrationParams(), o.r);
  return o;
}
}  // namespace

TEST_GROUP(PairCalibration){};

// From a guess 2 cm and 2 degrees off (a hand measurement), the known mounting is recovered.
TEST(PairCalibration, RecoversKnownMounting) {
  Pose guess = mounting();
  guess.t += Vec3f(-0.015f, 0.01f, 0.008f);
  guess.R = Eigen::AngleAxisf(2.0f * float(M_PI) / 180.0f, Vec3f(0.3f, -0.2f, 0.9f).normalized()).toRotationMatrix() * guess.R;
  const Outcome o = run_pair(box_sphere_corner(), guess);
  CHECK(o.status == Status::kOk);
  float dt, deg;
  pose_error(o.r.T_a_b, mounting(), dt, deg);
  std::printf("\n  calibrated: %s, %.2f mm %.3f deg off, rms %.2f mm, inliers %.2f, %d dof, sigma %.2f mm %.3f deg %s\n",
              o.r.accepted ? "accepted" : "refused", 1e3f * dt, deg, 1e3f * o.r.rms_m, o.r.inlier_ratio, o.r.observable,
              1e3f * o.r.sigma.tail<3>().norm(), o.r.sigma.head<3>().norm() * 180.0f / float(M_PI), o.r.reason);
  CHECK(o.r.accepted);
  LONGS_EQUAL(6, o.r.observable);
  // 1 cm voxels, 1.5 / 4 mm depth noise: the model surface is good to ~1 mm.
  CHECK(dt < 0.002f);
  CHECK(deg < 0.2f);
  CHECK(o.r.sigma.tail<3>().norm() > 0.0f);
}

// A sensor that sees little of the map (B binned to 40 x 30: 400-odd correspondences, fewer than a
// fixed count of 500 would ask for) is accepted on its evidence: the 1-sigma of the fit, and a count
// scaled to its pixels. A window of B that sees only part of the corner is still refused: what it
// sees does not determine the mounting (1-sigma of several mm), and the reason says so.
TEST(PairCalibration, AcceptsAFewPixelsOnTheirEvidence) {
  Pose guess = mounting();
  guess.t += Vec3f(-0.01f, 0.005f, 0.005f);
  View binned;
  binned.binning = 4;
  const Outcome o = run_pair(box_sphere_corner(), guess, binned);
  CHECK(o.status == Status::kOk);
  float dt, deg;
  pose_error(o.r.T_a_b, mounting(), dt, deg);
  std::printf("\n  40 x 30: %s, %d correspondences, %.2f mm %.3f deg off, sigma %.2f mm %.3f deg %s\n",
              o.r.accepted ? "accepted" : "refused", o.r.correspondences, 1e3f * dt, deg,
              1e3f * o.r.sigma.tail<3>().maxCoeff(), o.r.sigma.head<3>().maxCoeff() * 57.2957795f, o.r.reason);
  CHECK(o.r.correspondences < 500);
  CHECK_TEXT(o.r.accepted, o.r.reason);
  // As the full view's bounds (2 mm / 0.2 deg), widened by the 4x larger pixels' noise.
  CHECK(dt < 0.002f);
  CHECK(deg < 0.6f);

  View window;
  window.x0 = 50;
  window.y0 = 40;
  window.w = 30;
  window.h = 22;
  const Outcome w = run_pair(box_sphere_corner(), guess, window);
  CHECK(w.status == Status::kOk);
  std::printf("  a 30 x 22 window: %s\n", w.r.reason);
  CHECK(!w.r.accepted);
  CHECK(std::strstr(w.r.reason, "too uncertain") != nullptr);

  PairCalibrationParams p;
  LONGS_EQUAL(500, p.required_correspondences(320 * 240));
  LONGS_EQUAL(125, p.required_correspondences(160 * 120));
  LONGS_EQUAL(60, p.required_correspondences(40 * 30));
}

// A single plane fixes only distance and two tilts: refused, and the message says why.
TEST(PairCalibration, RefusesSinglePlane) {
  Scene plane;
  plane.add_plane(Vec3f(0.1f, -0.2f, -1.0f).normalized(), 0.85f);
  const Outcome o = run_pair(plane, mounting());
  CHECK(o.status == Status::kOk);
  std::printf("\n  single plane: %s\n", o.r.reason);
  CHECK(!o.r.accepted);
  CHECK(std::strstr(o.r.reason, "single plane") != nullptr);
}

// The Q16.16 kernels (integration, raycast, pyramid, ICP) recover the same mounting.
TEST(PairCalibration, FixedPointRecoversKnownMounting) {
  Pose guess = mounting();
  guess.t += Vec3f(-0.015f, 0.01f, 0.008f);
  const Outcome o = run_pair<Fixed>(box_sphere_corner(), guess);
  CHECK(o.status == Status::kOk);
  float dt, deg;
  pose_error(o.r.T_a_b, mounting(), dt, deg);
  std::printf("\n  calibrated (Q16.16): %s, %.2f mm %.3f deg off, rms %.2f mm %s\n", o.r.accepted ? "accepted" : "refused",
              1e3f * dt, deg, 1e3f * o.r.rms_m, o.r.reason);
  CHECK(o.r.accepted);
  CHECK(dt < 0.002f);
  CHECK(deg < 0.2f);
}

// Second mode: each camera maps alone into its own space (its own frame); aligning the two
// spaces' surfaces recovers the transform between the maps.
namespace {
VolumeStorage<kRigDim> g_other;
float g_o_depth[kRigW * kRigH];
Vec3f g_o_vertex[kRigW * kRigH], g_o_normal[kRigW * kRigH];
uint16_t g_o_raw[kRigW * kRigH];
SensorBuffers<float> g_o_sensor;
}  // namespace

TEST(PairCalibration, AlignsTwoSpaces) {
  Rig<float> rig(g_rig, kRigCentre, 0.01f);
  const Scene scene = box_sphere_corner();
  const std::vector<Pose> poses = known_motion(6);
  // The other map's frame: the model frame moved by a known transform (its sensor started elsewhere).
  Pose T_model_other;
  T_model_other.R = Eigen::AngleAxisf(0.05f, Vec3f(0.2f, 1.0f, -0.3f).normalized()).toRotationMatrix();
  T_model_other.t = Vec3f(0.02f, -0.015f, 0.01f);
  TsdfVolume other;
  other.init(g_other.view(false), kRigDim, T_model_other.inverse() * kRigCentre - Vec3f::Constant(0.5f * kRigDim * 0.01f),
             TsdfParams::defaults_for(0.01f, 0.04f));
  FrameScratch os = g_o_sensor.scratch();
  const ImageView<const float> norms = g_o_sensor.ray_norms(rig.cam);
  std::vector<uint16_t> depth;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    render(scene, rig.cam, poses[i], depth);
    add_depth_noise(depth, rig.cam.depth_scale, 0.0015f, uint32_t(i + 7));
    for (std::size_t k = 0; k < depth.size(); ++k) g_rig.frame[k] = depth[k];
    const DepthFrame f{ImageView<const uint16_t>(g_rig.frame, kRigW, kRigH), {}};
    if (i % 2 == 0) integrate<float>(rig.volume, rig.cam, rig.norms, f, poses[i], rig.scratch);
    else integrate<float>(other, rig.cam, norms, f, T_model_other.inverse() * poses[i], os);
  }
  RaycastMaps om;
  om.depth_m = ImageView<float>(g_o_depth, kRigW, kRigH);
  om.vertex = ImageView<Vec3f>(g_o_vertex, kRigW, kRigH);
  om.normal = ImageView<Vec3f>(g_o_normal, kRigW, kRigH);
  Pose guess = T_model_other;
  guess.t += Vec3f(0.012f, 0.008f, -0.01f);
  PairCalibrationResult r;
  CHECK(align_spaces<float>(rig.volume, other, rig.cam, poses[0], guess, rig.pyramid, rig.maps, om,
                            ImageView<uint16_t>(g_o_raw, kRigW, kRigH), rig.ws, PairCalibrationParams(), 2, r) ==
        Status::kOk);
  float dt, deg;
  pose_error(r.T_a_b, T_model_other, dt, deg);
  std::printf("\n  spaces aligned: %s, %.2f mm %.3f deg off, rms %.2f mm %s\n", r.accepted ? "accepted" : "refused",
              1e3f * dt, deg, 1e3f * r.rms_m, r.reason);
  CHECK(r.accepted);
  CHECK(dt < 0.002f);
  CHECK(deg < 0.2f);
}

// Averaging repeated estimates (edgefused's calib fuse, edgefuse calibrate --frames): estimates
// scattered symmetrically about a mounting average back to it, with their sample spread; q and -q
// count as the same rotation.
TEST(PairCalibration, MeanOfEstimatesAndTheirSpread) {
  const Pose truth = Pose::from_tq(0.057f, 0.007f, -0.001f, -0.0134f, -0.0187f, 0.019f, 0.99955f);
  PoseMean m;
  CHECK_EQUAL(0, m.count());
  CHECK_TRUE(m.spread().isZero());
  const float d_m = 0.002f, a_rad = 0.004f;  // 2 mm, 0.23 deg: one ToF frame's scatter
  for (int s = -1; s <= 1; s += 2) {
    Pose T = truth;
    T.t += truth.R * Vec3f(s * d_m, 0, 0);  // along x of the mounting's own frame
    T.R = truth.R * Eigen::AngleAxisf(s * a_rad, Vec3f::UnitZ()).toRotationMatrix();
    Vec6f sigma;
    sigma << 0.001f, 0.001f, 0.001f, 0.0005f, 0.0005f, 0.0005f;
    m.add(T, sigma);
  }
  Pose flipped = truth;  // the same pose; its quaternion may come out as -q elsewhere
  m.add(flipped);
  CHECK_EQUAL(3, m.count());
  const Pose mean = m.mean();
  CHECK_TRUE((mean.t - truth.t).norm() < 1e-6f);
  CHECK_TRUE((truth.inverse() * mean).angle_rad() < 1e-5f);
  // Sample standard deviation of {-d, +d, 0} is d; the other axes scatter only by the tangent-space
  // approximation (taken at the first estimate, rotated by 2a from the others: 2d sin 2a ~ 3e-5 m),
  // far below one estimate's own noise.
  const Vec6f sp = m.spread();
  DOUBLES_EQUAL(a_rad, sp(2), 1e-5);
  DOUBLES_EQUAL(d_m, sp(3), 2e-6);
  CHECK_TRUE(sp(0) < 1e-5f && sp(1) < 1e-5f && sp(4) < 0.05f * d_m && sp(5) < 1e-6f);
  DOUBLES_EQUAL(2.0 / 3.0 * 0.001, m.mean_sigma()(0), 1e-7);
}
