// ATE / RPE after TUM's evaluate_ate.py and evaluate_rpe.py; see eval_metrics.hpp.
#include "eval_metrics.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <system_error>

#include <Eigen/SVD>

#include "edgefuse/io/dataset.hpp"

namespace edgefuse::eval {

double RigidD::angle_rad() const {
  // evaluate_rpe.py takes arccos((trace - 1) / 2); atan2 of the same cosine and the sine from the
  // skew part is the same angle but well conditioned near 0 (float poses: acos would floor small
  // errors at ~0.01 deg).
  const double c = 0.5 * (R.trace() - 1.0);
  const double s = 0.5 * Vec3d(R(2, 1) - R(1, 2), R(0, 2) - R(2, 0), R(1, 0) - R(0, 1)).norm();
  return std::atan2(s, c);
}

ErrorStats error_stats(std::vector<double> e) {
  ErrorStats s;
  s.count = e.size();
  if (e.empty()) return s;
  double sum = 0, sum2 = 0;
  for (double v : e) {
    sum += v;
    sum2 += v * v;
  }
  const double n = double(e.size());
  s.mean = sum / n;
  s.rmse = std::sqrt(sum2 / n);
  double var = 0;
  for (double v : e) var += (v - s.mean) * (v - s.mean);
  s.std = std::sqrt(var / n);
  std::sort(e.begin(), e.end());
  s.min = e.front();
  s.max = e.back();
  const std::size_t h = e.size() / 2;
  s.median = e.size() % 2 ? e[h] : 0.5 * (e[h - 1] + e[h]);
  return s;
}

std::vector<StampPair> associate(const std::vector<io::StampedPose>& est, const std::vector<io::StampedPose>& gt,
                                 double max_dt_s) {
  std::vector<double> se(est.size()), sg(gt.size());
  for (std::size_t i = 0; i < est.size(); ++i) se[i] = est[i].stamp_s;
  for (std::size_t i = 0; i < gt.size(); ++i) sg[i] = gt[i].stamp_s;
  // associate.py is called with (ground truth, estimate): ties in the difference go to the
  // earlier ground-truth stamp, as Python's sort of (diff, a, b) tuples does.
  const std::vector<long> match = io::associate_stamps(sg, se, max_dt_s);
  std::vector<StampPair> pairs;
  for (std::size_t g = 0; g < match.size(); ++g)
    if (match[g] >= 0) pairs.push_back({std::size_t(match[g]), g});
  std::sort(pairs.begin(), pairs.end(), [](const StampPair& a, const StampPair& b) { return a.est < b.est; });
  return pairs;
}

bool align_rigid(const std::vector<Vec3d>& src, const std::vector<Vec3d>& dst, Alignment& out, std::string& err) {
  if (src.size() != dst.size() || src.empty()) {
    err = "alignment needs the same, non-zero number of points on both sides (got " + std::to_string(src.size()) +
          " and " + std::to_string(dst.size()) + ")";
    return false;
  }
  const double n = double(src.size());
  Vec3d ms = Vec3d::Zero(), md = Vec3d::Zero();
  for (std::size_t i = 0; i < src.size(); ++i) {
    ms += src[i];
    md += dst[i];
  }
  ms /= n;
  md /= n;
  Mat3d W = Mat3d::Zero();  // cross-covariance sum (dst - md)(src - ms)^T
  for (std::size_t i = 0; i < src.size(); ++i) W += (dst[i] - md) * (src[i] - ms).transpose();
  for (int k = 0; k < 9; ++k)
    if (!std::isfinite(W.data()[k])) {
      err = "alignment: non-finite positions";
      return false;
    }
  const Eigen::JacobiSVD<Mat3d> svd(W, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Mat3d& U = svd.matrixU();
  const Mat3d& V = svd.matrixV();
  const Vec3d sv = svd.singularValues();  // descending
  const double tol = std::max(sv(0), 1e-300) * 1e-9;
  out.rank = int(sv(0) > 1e-300) + int(sv(1) > tol) + int(sv(2) > tol);
  // Sign check (Umeyama 1991, eq. 39-40): U V^T may be a reflection (det -1); the best proper
  // rotation then flips the axis of the smallest singular value.
  Mat3d S = Mat3d::Identity();
  const bool reflection = U.determinant() * V.determinant() < 0;
  if (reflection) S(2, 2) = -1.0;
  out.reflection_avoided = reflection && out.rank == 3;
  out.T.R = U * S * V.transpose();
  out.T.t = md - out.T.R * ms;
  return true;
}

bool compute_ate(const std::vector<io::StampedPose>& est, const std::vector<io::StampedPose>& gt, double max_dt_s,
                 AteResult& out, std::string& err) {
  out = AteResult();
  out.pairs = associate(est, gt, max_dt_s);
  if (out.pairs.size() < 3) {
    char buf[320];
    std::snprintf(buf, sizeof buf,
                  "only %zu estimated poses have a ground-truth stamp within %g s (ATE needs at least 3); stamps: "
                  "estimate %.6f..%.6f, ground truth %.6f..%.6f",
                  out.pairs.size(), max_dt_s, est.empty() ? 0.0 : est.front().stamp_s,
                  est.empty() ? 0.0 : est.back().stamp_s, gt.empty() ? 0.0 : gt.front().stamp_s,
                  gt.empty() ? 0.0 : gt.back().stamp_s);
    err = buf;
    return false;
  }
  std::vector<Vec3d> src, dst;
  src.reserve(out.pairs.size());
  dst.reserve(out.pairs.size());
  for (const StampPair& p : out.pairs) {
    src.push_back(est[p.est].T.t.cast<double>());
    dst.push_back(gt[p.gt].T.t.cast<double>());
  }
  if (!align_rigid(src, dst, out.align, err)) return false;
  out.errors.resize(src.size());
  for (std::size_t i = 0; i < src.size(); ++i) out.errors[i] = (out.align.T * src[i] - dst[i]).norm();
  out.stats = error_stats(out.errors);
  return true;
}

namespace {

//! Index of the stamp nearest to t in sorted poses (ties: the earlier one).
std::size_t nearest_index(const std::vector<io::StampedPose>& poses, double t) {
  const auto it = std::lower_bound(poses.begin(), poses.end(), t,
                                   [](const io::StampedPose& p, double s) { return p.stamp_s < s; });
  if (it == poses.begin()) return 0;
  if (it == poses.end()) return poses.size() - 1;
  const std::size_t j = std::size_t(it - poses.begin());
  return (t - poses[j - 1].stamp_s) <= (poses[j].stamp_s - t) ? j - 1 : j;
}

}  // namespace

bool compute_rpe(const std::vector<io::StampedPose>& est, const std::vector<io::StampedPose>& gt,
                 const RpeOptions& opt, RpeResult& out, std::string& err) {
  out = RpeResult();
  if (opt.delta < 1) {
    err = "RPE frame delta must be at least 1";
    return false;
  }
  if (gt.size() < 2 || est.size() < 2) {
    err = "RPE needs at least 2 poses in each trajectory (estimate " + std::to_string(est.size()) +
          ", ground truth " + std::to_string(gt.size()) + ")";
    return false;
  }
  if (opt.max_dt_s >= 0) {
    out.gt_max_dt_s = opt.max_dt_s;
  } else {
    std::vector<double> d(gt.size() - 1);
    for (std::size_t i = 0; i + 1 < gt.size(); ++i) d[i] = gt[i + 1].stamp_s - gt[i].stamp_s;
    out.gt_max_dt_s = 2.0 * error_stats(d).median;  // evaluate_rpe.py: 2 x median GT interval
  }
  const std::size_t n = est.size();
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t j = std::min(n - 1, i + std::size_t(opt.delta));
    if (j == n - 1) continue;  // evaluate_rpe.py: `if j != len(traj_est) - 1`
    ++out.candidates;
    RpePair p;
    p.est0 = i;
    p.est1 = j;
    p.gt0 = nearest_index(gt, est[i].stamp_s);
    p.gt1 = nearest_index(gt, est[j].stamp_s);
    if (std::fabs(gt[p.gt0].stamp_s - est[i].stamp_s) > out.gt_max_dt_s ||
        std::fabs(gt[p.gt1].stamp_s - est[j].stamp_s) > out.gt_max_dt_s)
      continue;
    const RigidD E0 = RigidD::from_pose(est[i].T), E1 = RigidD::from_pose(est[j].T);
    const RigidD G0 = RigidD::from_pose(gt[p.gt0].T), G1 = RigidD::from_pose(gt[p.gt1].T);
    // ominus(a, b) = inv(a) b;  error = ominus(ominus(E1, E0), ominus(G1, G0))
    const RigidD dE = E1.inverse() * E0, dG = G1.inverse() * G0;
    const RigidD e = dE.inverse() * dG;
    p.trans_m = e.t.norm();
    p.rot_rad = e.angle_rad();
    out.pairs.push_back(p);
  }
  if (out.pairs.empty()) {
    char buf[320];
    std::snprintf(buf, sizeof buf,
                  "no frame pair (i, i+%d) has ground truth within %g s at both ends (%zu candidates); stamps: "
                  "estimate %.6f..%.6f, ground truth %.6f..%.6f",
                  opt.delta, out.gt_max_dt_s, out.candidates, est.front().stamp_s, est.back().stamp_s,
                  gt.front().stamp_s, gt.back().stamp_s);
    err = buf;
    return false;
  }
  std::vector<double> t, r;
  for (const RpePair& p : out.pairs) {
    t.push_back(p.trans_m);
    r.push_back(p.rot_rad * 180.0 / M_PI);
  }
  out.trans_m = error_stats(t);
  out.rot_deg = error_stats(r);
  return true;
}

bool check_unique_stamps(const std::vector<io::StampedPose>& poses, const std::string& name, std::string& err) {
  for (std::size_t i = 1; i < poses.size(); ++i)
    if (poses[i].stamp_s == poses[i - 1].stamp_s) {
      char buf[64];
      std::snprintf(buf, sizeof buf, "%.6f", poses[i].stamp_s);
      err = name + ": timestamp " + buf + " appears more than once";
      return false;
    }
  return true;
}

bool load_trajectory(const std::string& path, const std::string& sensor, std::vector<io::StampedPose>& poses,
                     std::string& what, std::string& err) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::is_directory(path, ec)) {
    if (!sensor.empty()) {
      err = path + ": --sensor applies to a data-set folder, not to a trajectory file";
      return false;
    }
    if (!io::read_tum_trajectory(path, poses, err)) return false;
    what = path;
    return check_unique_stamps(poses, path, err);
  }
  std::string root = path;
  if (!sensor.empty() || !fs::is_regular_file(fs::path(path) / "groundtruth.txt", ec)) {
    io::DepthSequence seq;
    if (!io::open_depth_sequence(path, sensor, seq, err)) return false;
    root = seq.root;
    if (!fs::is_regular_file(fs::path(root) / "groundtruth.txt", ec)) {
      poses.clear();
      for (const io::FrameRef& f : seq.frames)
        if (f.has_pose) poses.push_back({f.stamp_s, f.T_world_cam});
      if (poses.empty()) {
        err = path + ": the data set has no ground-truth poses (no groundtruth.txt, no per-frame pose files)";
        return false;
      }
      what = path + " (" + io::to_string(seq.layout) + " layout, poses of the frames)";
      return check_unique_stamps(poses, path, err);
    }
  }
  const std::string gt = (fs::path(root) / "groundtruth.txt").string();
  if (!io::read_tum_trajectory(gt, poses, err)) return false;
  what = gt;
  return check_unique_stamps(poses, gt, err);
}

}  // namespace edgefuse::eval
