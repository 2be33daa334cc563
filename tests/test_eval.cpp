// Trajectory evaluation (tools/edgefuse/eval_metrics.hpp): association, Horn/Umeyama alignment
// with the reflection sign check, ATE and RPE as TUM's evaluate_ate.py / evaluate_rpe.py.
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/SVD>

#include "edgefuse/io/trajectory.hpp"
#include "eval_metrics.hpp"
#include "formats_test_util.hpp"  // includes test_support.hpp (CppUTest) last

using namespace edgefuse;
using eval::Mat3d;
using eval::RigidD;
using eval::Vec3d;

namespace {

//! Deterministic standard normal numbers (LCG + Box-Muller: the same on every target).
struct Gauss {
  uint64_t s;
  explicit Gauss(uint64_t seed) : s(seed) {}
  double uniform() {
    s = s * 6364136223846793005ull + 1442695040888963407ull;
    return (double(s >> 11) + 0.5) / double(1ull << 53);
  }
  double operator()() { return std::sqrt(-2.0 * std::log(uniform())) * std::cos(2.0 * M_PI * uniform()); }
  Vec3d vec() {
    const double a = (*this)(), b = (*this)(), c = (*this)();
    return Vec3d(a, b, c);
  }
};

RigidD rigid(const Vec3d& axis, double angle_rad, const Vec3d& t) {
  RigidD r;
  r.R = Eigen::AngleAxisd(angle_rad, axis.normalized()).toRotationMatrix();
  r.t = t;
  return r;
}

//! A smooth, non-planar camera path with turning orientation, stamps 100 + 0.033 i.
std::vector<io::StampedPose> synthetic_path(int n, bool rotate = true) {
  std::vector<io::StampedPose> v;
  for (int i = 0; i < n; ++i) {
    const double s = 0.02 * i;
    const Vec3d p(0.8 * std::sin(s), 0.5 * std::cos(0.7 * s), 0.3 * s + 0.1 * std::sin(3 * s));
    const RigidD T = rigid(Vec3d(0.3, 1.0, 0.2), rotate ? 0.4 * std::sin(s) : 0.0, p);
    v.push_back({100.0 + 0.033 * i, T.to_pose()});
  }
  return v;
}

std::vector<io::StampedPose> transformed(const RigidD& M, const std::vector<io::StampedPose>& in) {
  std::vector<io::StampedPose> out = in;
  for (auto& p : out) p.T = (M * RigidD::from_pose(p.T)).to_pose();
  return out;
}

double sum_sq(const RigidD& T, const std::vector<Vec3d>& src, const std::vector<Vec3d>& dst) {
  double s = 0;
  for (std::size_t i = 0; i < src.size(); ++i) s += (T * src[i] - dst[i]).squaredNorm();
  return s;
}

}  // namespace

TEST_GROUP(Eval){};

TEST(Eval, ErrorStatsLikeNumpy) {
  const eval::ErrorStats s = eval::error_stats({3.0, 1.0, 4.0, 2.0});
  LONGS_EQUAL(4, s.count);
  DOUBLES_EQUAL(std::sqrt(30.0 / 4.0), s.rmse, 1e-12);
  DOUBLES_EQUAL(2.5, s.mean, 1e-12);
  DOUBLES_EQUAL(2.5, s.median, 1e-12);  // even count: mean of the middle two
  DOUBLES_EQUAL(std::sqrt(1.25), s.std, 1e-12);  // population std (numpy default)
  DOUBLES_EQUAL(1.0, s.min, 0);
  DOUBLES_EQUAL(4.0, s.max, 0);
  DOUBLES_EQUAL(2.0, eval::error_stats({2.0, 9.0, 1.0}).median, 0);
}

TEST(Eval, AssociationIsOneToOneWithinMaxDt) {
  std::vector<io::StampedPose> gt, est;
  for (double t : {1.00, 1.10, 1.20, 1.30}) gt.push_back({t, Pose::identity()});
  // 1.095 and 1.104 both want 1.10: the closer (1.104, 0.004) wins, 1.095 has no other partner
  // within 0.02; 1.23 is 0.03 from 1.20 (too far); 1.305 -> 1.30.
  for (double t : {0.99, 1.095, 1.104, 1.23, 1.305}) est.push_back({t, Pose::identity()});
  const auto pairs = eval::associate(est, gt, 0.02);
  LONGS_EQUAL(3, pairs.size());
  LONGS_EQUAL(0, pairs[0].est);
  LONGS_EQUAL(0, pairs[0].gt);
  LONGS_EQUAL(2, pairs[1].est);
  LONGS_EQUAL(1, pairs[1].gt);
  LONGS_EQUAL(4, pairs[2].est);
  LONGS_EQUAL(3, pairs[2].gt);
  // Per-frame layout: integer stamps match exactly.
  std::vector<io::StampedPose> a, b;
  for (int i = 0; i < 10; ++i) a.push_back({double(i), Pose::identity()});
  for (int i = 3; i < 20; ++i) b.push_back({double(i), Pose::identity()});
  LONGS_EQUAL(7, eval::associate(a, b, 0.02).size());
}

TEST(Eval, RigidlyMovedTrajectoryHasZeroAte) {
  const auto gt = synthetic_path(400);
  const RigidD M = rigid(Vec3d(1, -2, 0.5), 2.3, Vec3d(3.0, -1.0, 0.7));  // 132 deg, metres away
  auto est = transformed(M, gt);
  for (auto& p : est) p.stamp_s += 0.004;  // clock offset within max_dt
  eval::AteResult r;
  std::string err;
  CHECK_TEXT(eval::compute_ate(est, gt, 0.02, r, err), err.c_str());
  LONGS_EQUAL(400, r.stats.count);
  CHECK(r.stats.rmse < 2e-6);  // float poses: ~1e-7 m rounding
  CHECK(r.stats.max < 5e-6);
  CHECK_FALSE(r.align.reflection_avoided);
  LONGS_EQUAL(3, r.align.rank);
  // The alignment is the inverse of the applied motion.
  const RigidD Mi = M.inverse();
  CHECK((r.align.T.R - Mi.R).norm() < 1e-6);
  CHECK((r.align.T.t - Mi.t).norm() < 1e-5);
  DOUBLES_EQUAL(1.0, r.align.T.R.determinant(), 1e-9);
}

TEST(Eval, KnownNoiseGivesExpectedRmse) {
  // Isotropic noise sigma per axis on the positions: after the 6-dof fit the expected mean squared
  // residual is sigma^2 (3n - 6) / n.
  const int n = 3000;
  const double sigma = 0.004;
  const auto gt = synthetic_path(n);
  auto est = transformed(rigid(Vec3d(0, 0, 1), 0.7, Vec3d(0.2, 0.1, -0.3)), gt);
  Gauss g(42);
  for (auto& p : est) p.T.t += (sigma * g.vec()).cast<float>();
  eval::AteResult r;
  std::string err;
  CHECK_TEXT(eval::compute_ate(est, gt, 0.02, r, err), err.c_str());
  const double expected = sigma * std::sqrt((3.0 * n - 6.0) / n);
  DOUBLES_EQUAL(expected, r.stats.rmse, 0.03 * expected);  // 3 % (sampling spread ~1.1 %)
  // Mean of a chi distribution with 3 dof: sigma * 2 sqrt(2 / pi).
  DOUBLES_EQUAL(sigma * 2.0 * std::sqrt(2.0 / M_PI), r.stats.mean, 0.03 * sigma * 1.6);
}

TEST(Eval, AlignmentMatchesClosedFormOptimumWithNoise) {
  // Small sets with large noise: the fit must not be beaten by any nearby rigid transform.
  Gauss g(7);
  std::vector<Vec3d> src, dst;
  const RigidD M = rigid(Vec3d(0.2, 0.9, -0.4), 0.9, Vec3d(1, 2, 3));
  for (int i = 0; i < 12; ++i) {
    src.push_back(g.vec());
    dst.push_back(M * src.back() + 0.3 * g.vec());
  }
  eval::Alignment a;
  std::string err;
  CHECK(eval::align_rigid(src, dst, a, err));
  const double best = sum_sq(a.T, src, dst);
  for (int k = 0; k < 200; ++k) {
    RigidD d = rigid(g.vec(), 1e-3 * g(), 1e-3 * g.vec());
    CHECK(sum_sq(d * a.T, src, dst) >= best - 1e-12);
  }
}

TEST(Eval, ReflectionIsNotReturned) {
  // dst is a mirror image of src (x -> -x) moved rigidly: the best orthogonal fit is a reflection
  // with zero residual. Horn/Kabsch without the sign check returns it (det -1); the sign check
  // gives the best proper rotation, whose residual Umeyama gives in closed form:
  //   min sum |R s_i + t - d_i|^2 = sum |s_i - ms|^2 + sum |d_i - md|^2 - 2 (sv1 + sv2 - sv3).
  Gauss g(99);
  std::vector<Vec3d> src, dst;
  const RigidD M = rigid(Vec3d(1, 1, 0), 0.5, Vec3d(0.1, -0.2, 0.3));
  for (int i = 0; i < 50; ++i) {
    src.push_back(Vec3d(2.0 * g(), 1.0 * g(), 0.5 * g()));
    dst.push_back(M * Vec3d(-src.back().x(), src.back().y(), src.back().z()));
  }
  eval::Alignment a;
  std::string err;
  CHECK(eval::align_rigid(src, dst, a, err));
  CHECK(a.reflection_avoided);
  DOUBLES_EQUAL(1.0, a.T.R.determinant(), 1e-9);
  CHECK((a.T.R.transpose() * a.T.R - Mat3d::Identity()).norm() < 1e-9);
  Vec3d ms = Vec3d::Zero(), md = Vec3d::Zero();
  for (std::size_t i = 0; i < src.size(); ++i) {
    ms += src[i] / double(src.size());
    md += dst[i] / double(src.size());
  }
  Mat3d W = Mat3d::Zero();
  double ss = 0, sd = 0;
  for (std::size_t i = 0; i < src.size(); ++i) {
    W += (dst[i] - md) * (src[i] - ms).transpose();
    ss += (src[i] - ms).squaredNorm();
    sd += (dst[i] - md).squaredNorm();
  }
  const Vec3d sv = Eigen::JacobiSVD<Mat3d>(W).singularValues();
  const double optimum = ss + sd - 2.0 * (sv(0) + sv(1) - sv(2));
  CHECK(optimum > 1.0);  // a real residual, not the reflection's zero
  DOUBLES_EQUAL(optimum, sum_sq(a.T, src, dst), 1e-9 * optimum);
  // The reflection (what a library without the check returns) has zero residual and det -1.
  const Eigen::JacobiSVD<Mat3d> svd(W, Eigen::ComputeFullU | Eigen::ComputeFullV);
  DOUBLES_EQUAL(-1.0, (svd.matrixU() * svd.matrixV().transpose()).determinant(), 1e-9);

  // Through compute_ate: a mirrored trajectory is not reported as perfect.
  const auto gt = synthetic_path(300);
  auto est = gt;
  for (auto& p : est) p.T.t.x() = -p.T.t.x();
  eval::AteResult r;
  CHECK_TEXT(eval::compute_ate(est, gt, 0.02, r, err), err.c_str());
  CHECK(r.align.reflection_avoided);
  DOUBLES_EQUAL(1.0, r.align.T.R.determinant(), 1e-9);
  CHECK(r.stats.rmse > 0.05);
}

TEST(Eval, CollinearAndPlanarPositionsStillFit) {
  std::vector<Vec3d> src, dst;
  const RigidD M = rigid(Vec3d(0, 1, 0), 0.3, Vec3d(1, 0, 0));
  for (int i = 0; i < 10; ++i) {
    src.push_back(Vec3d(0.1 * i, 0, 0));
    dst.push_back(M * src.back());
  }
  eval::Alignment a;
  std::string err;
  CHECK(eval::align_rigid(src, dst, a, err));
  LONGS_EQUAL(1, a.rank);
  CHECK(sum_sq(a.T, src, dst) < 1e-20);
  DOUBLES_EQUAL(1.0, a.T.R.determinant(), 1e-9);
  // Planar set (z = 0): its mirror image in z is itself; no reflection is reported.
  src.clear();
  dst.clear();
  Gauss g(3);
  for (int i = 0; i < 20; ++i) {
    src.push_back(Vec3d(g(), g(), 0));
    dst.push_back(M * src.back());
  }
  CHECK(eval::align_rigid(src, dst, a, err));
  LONGS_EQUAL(2, a.rank);
  CHECK_FALSE(a.reflection_avoided);
  CHECK(sum_sq(a.T, src, dst) < 1e-20);
  CHECK_FALSE(eval::align_rigid({}, {}, a, err));
}

TEST(Eval, AteNeedsThreeAssociatedPoses) {
  const auto gt = synthetic_path(50);
  auto est = gt;
  for (auto& p : est) p.stamp_s += 1000.0;
  eval::AteResult r;
  std::string err;
  CHECK_FALSE(eval::compute_ate(est, gt, 0.02, r, err));
  CHECK_TEXT(err.find("within 0.02 s") != std::string::npos, err.c_str());
}

TEST(Eval, RpeOfConstantTranslationDrift) {
  // est_{i+1} = est_i * (G_i^-1 G_{i+1}) * D with D a pure translation d: every relative-motion
  // error is G-conjugated D, a translation of exactly |d| and no rotation.
  const auto gt = synthetic_path(120);
  RigidD D;
  D.t = Vec3d(0.001, -0.0005, 0.0002);
  std::vector<io::StampedPose> est = gt;
  RigidD E = rigid(Vec3d(1, 0, 0), 0.2, Vec3d(5, 5, 5));  // arbitrary start: RPE ignores it
  est[0].T = E.to_pose();
  for (std::size_t i = 1; i < gt.size(); ++i) {
    E = E * (RigidD::from_pose(gt[i - 1].T).inverse() * RigidD::from_pose(gt[i].T)) * D;
    est[i].T = E.to_pose();
  }
  eval::RpeResult r;
  std::string err;
  CHECK_TEXT(eval::compute_rpe(est, gt, eval::RpeOptions{}, r, err), err.c_str());
  LONGS_EQUAL(118, r.trans_m.count);  // evaluate_rpe.py skips the pair ending at the last frame
  DOUBLES_EQUAL(D.t.norm(), r.trans_m.rmse, 1e-5);
  DOUBLES_EQUAL(D.t.norm(), r.trans_m.min, 2e-5);
  DOUBLES_EQUAL(D.t.norm(), r.trans_m.max, 2e-5);
  CHECK(r.rot_deg.rmse < 1e-3);
  DOUBLES_EQUAL(2 * 0.033, r.gt_max_dt_s, 1e-9);
}

TEST(Eval, RpeOfConstantRotationDrift) {
  // D a pure rotation: the conjugated error has exactly D's angle.
  const auto gt = synthetic_path(100);
  const double angle = 0.5 * M_PI / 180.0;
  const RigidD D = rigid(Vec3d(0.2, -0.3, 1.0), angle, Vec3d::Zero());
  std::vector<io::StampedPose> est = gt;
  RigidD E = RigidD::from_pose(gt[0].T);
  for (std::size_t i = 1; i < gt.size(); ++i) {
    E = E * (RigidD::from_pose(gt[i - 1].T).inverse() * RigidD::from_pose(gt[i].T)) * D;
    est[i].T = E.to_pose();
  }
  eval::RpeResult r;
  std::string err;
  CHECK_TEXT(eval::compute_rpe(est, gt, eval::RpeOptions{}, r, err), err.c_str());
  DOUBLES_EQUAL(0.5, r.rot_deg.rmse, 1e-3);
  DOUBLES_EQUAL(0.5, r.rot_deg.min, 2e-3);
  DOUBLES_EQUAL(0.5, r.rot_deg.max, 2e-3);
}

TEST(Eval, RpeOverTwoFramesOfTranslatingCamera) {
  // Camera without rotation, drift d per frame: over delta = 2 frames the error is 2 |d|.
  const auto gt = synthetic_path(60, false);
  std::vector<io::StampedPose> est = gt;
  const Vec3d d(0.0, 0.002, 0.0);
  for (std::size_t i = 0; i < est.size(); ++i) est[i].T.t += (double(i) * d).cast<float>();
  eval::RpeOptions opt;
  opt.delta = 2;
  eval::RpeResult r;
  std::string err;
  CHECK_TEXT(eval::compute_rpe(est, gt, opt, r, err), err.c_str());
  LONGS_EQUAL(57, r.trans_m.count);  // i = 0..56 (j = i + 2 <= 58; j = 59 skipped as in the script)
  DOUBLES_EQUAL(2 * d.norm(), r.trans_m.rmse, 1e-6);
  CHECK(r.rot_deg.max < 1e-4);
  // Ground truth too far in time: pairs are dropped.
  auto late = est;
  for (auto& p : late) p.stamp_s += 10.0;
  CHECK_FALSE(eval::compute_rpe(late, gt, opt, r, err));
}

TEST(Eval, LoadTrajectoryErrorsNameFileAndLine) {
  formats_test::TempDir dir;
  const std::string p = dir.file("est.txt");
  formats_test::write_bytes(p, "# est\n0 0 0 0 0 0 0 1\n1 0 0 0 0 0 1\n");
  std::vector<io::StampedPose> v;
  std::string what, err;
  CHECK_FALSE(eval::load_trajectory(p, "", v, what, err));
  CHECK_TEXT(err.find(p + ":3:") != std::string::npos, err.c_str());
  formats_test::write_bytes(p, "0 0 0 0 0 0 0 1\n1 0 0 0 0 0 0 1\n1 0 0 0 0 0 0 1\n");
  CHECK_FALSE(eval::load_trajectory(p, "", v, what, err));
  CHECK_TEXT(err.find("appears more than once") != std::string::npos && err.find(p) != std::string::npos,
             err.c_str());
  CHECK_FALSE(eval::load_trajectory(dir.file("missing.txt"), "", v, what, err));
  CHECK_TEXT(err.find("missing.txt") != std::string::npos, err.c_str());
  formats_test::write_bytes(p, "0 0 0 0 0 0 0 1\n1 0 0 0 0 0 0 1\n");
  CHECK_FALSE(eval::load_trajectory(p, "xtion", v, what, err));
  CHECK(eval::load_trajectory(p, "", v, what, err));
  LONGS_EQUAL(2, v.size());
}

TEST(Eval, GroundTruthFromDataSetFolders) {
  const std::string kitchen = edgefuse_test::require_data("7scenes_redkitchen_300");
  if (kitchen.empty()) return;
  std::vector<io::StampedPose> v;
  std::string what, err;
  CHECK_TEXT(eval::load_trajectory(kitchen, "", v, what, err), err.c_str());
  LONGS_EQUAL(300, v.size());
  DOUBLES_EQUAL(0.0, v.front().stamp_s, 0);
  DOUBLES_EQUAL(299.0, v.back().stamp_s, 0);
  Pose p0;
  CHECK(io::read_pose_matrix_txt(kitchen + "/frame-000000.pose.txt", p0, err));
  CHECK((v[0].T.t - p0.t).norm() < 1e-7f);

  const std::string rig = edgefuse_test::require_data("bin_rig_a");
  CHECK_TEXT(eval::load_trajectory(rig, "tof", v, what, err), err.c_str());
  LONGS_EQUAL(20, v.size());
  CHECK_TEXT(what.find("tof/groundtruth.txt") != std::string::npos, what.c_str());
  CHECK_FALSE(eval::load_trajectory(rig, "nosuch", v, what, err));

  // Ground truth against itself moved rigidly, through the per-frame stamps.
  const auto est = transformed(rigid(Vec3d(0, 0, 1), 1.0, Vec3d(1, 1, 1)), v);
  eval::AteResult r;
  CHECK_TEXT(eval::compute_ate(est, v, 0.02, r, err), err.c_str());
  CHECK(r.stats.rmse < 2e-6);
}

TEST(Eval, TumGroundTruthPerturbed) {
  // fr1/xyz ground truth (3000 poses, mocap): rigidly moved + 5 mm noise per axis.
  const std::string tum = edgefuse_test::require_data("tum_fr1_xyz_37");
  if (tum.empty()) return;
  std::vector<io::StampedPose> gt;
  std::string what, err;
  CHECK_TEXT(eval::load_trajectory(tum, "", gt, what, err), err.c_str());
  LONGS_EQUAL(3000, gt.size());
  auto est = transformed(rigid(Vec3d(0.3, 0.3, 1), 0.8, Vec3d(-1, 0.5, 2)), gt);
  eval::AteResult r;
  CHECK(eval::compute_ate(est, gt, 0.02, r, err));
  CHECK(r.stats.rmse < 3e-6);
  Gauss g(5);
  for (auto& p : est) p.T.t += (0.005 * g.vec()).cast<float>();
  CHECK(eval::compute_ate(est, gt, 0.02, r, err));
  const double expected = 0.005 * std::sqrt((3.0 * 3000 - 6.0) / 3000);
  DOUBLES_EQUAL(expected, r.stats.rmse, 0.03 * expected);
}
