// Trajectory accuracy as the TUM RGB-D benchmark measures it (Sturm et al., IROS 2012):
//   - ATE, as evaluate_ate.py: associate stamps one-to-one (associate.py), align the estimated
//     positions to the ground truth with the rigid transform (no scale) that minimises the squared
//     error (Horn 1987 / Umeyama 1991 closed form with the det(R) = +1 sign check), then statistics
//     of the remaining position differences;
//   - RPE, as evaluate_rpe.py --fixed_delta --delta_unit f: for every estimated frame i and
//     j = i + delta, the error of the relative motion, inv(inv(E_i) E_j) inv(G_i) G_j, translational
//     norm and rotation angle.
// Host-side (allocates); double precision throughout. Used by `edgefuse eval` and tests/test_eval.cpp.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "edgefuse/io/trajectory.hpp"

namespace edgefuse::eval {

using Vec3d = Eigen::Vector3d;
using Mat3d = Eigen::Matrix3d;

//! A rigid transform in double precision: p' = R p + t.
struct RigidD {
  Mat3d R = Mat3d::Identity();
  Vec3d t = Vec3d::Zero();

  static RigidD from_pose(const Pose& p) {
    RigidD r;
    r.R = p.R.cast<double>();
    r.t = p.t.cast<double>();
    return r;
  }
  Pose to_pose() const {
    Pose p;
    p.R = R.cast<float>();
    p.t = t.cast<float>();
    return p;
  }
  RigidD inverse() const {
    RigidD r;
    r.R = R.transpose();
    r.t = -(r.R * t);
    return r;
  }
  Vec3d operator*(const Vec3d& x) const { return R * x + t; }
  RigidD operator*(const RigidD& o) const {
    RigidD r;
    r.R = R * o.R;
    r.t = R * o.t + t;
    return r;
  }
  //! Rotation angle in radians (0..pi), as evaluate_rpe.py's compute_angle.
  double angle_rad() const;
};

//! Statistics of a list of non-negative errors, as evaluate_ate.py / evaluate_rpe.py print them
//! (std is the population standard deviation, numpy's default).
struct ErrorStats {
  std::size_t count = 0;
  double rmse = 0, mean = 0, median = 0, std = 0, min = 0, max = 0;
};
ErrorStats error_stats(std::vector<double> errors);

//! An associated pair: indices into the estimated and the ground-truth trajectory.
struct StampPair {
  std::size_t est = 0, gt = 0;
};

//! associate.py: all (gt, est) pairs whose stamps differ by less than max_dt_s, taken greedily by
//! increasing difference, each pose used at most once; returned in estimated-stamp order.
//! Both lists sorted by stamp (as io::read_tum_trajectory returns them).
std::vector<StampPair> associate(const std::vector<io::StampedPose>& est, const std::vector<io::StampedPose>& gt,
                                 double max_dt_s);

struct Alignment {
  RigidD T;                           //!< maps estimated positions onto the ground truth: gt ≈ T * est
  bool reflection_avoided = false;    //!< the unconstrained optimum was a reflection; the sign check fixed it
  int rank = 0;                       //!< rank of the centred cross-covariance (< 2: rotation not unique)
};

//! Horn / Umeyama without scale: the rotation R (det +1) and translation t minimising
//! sum |R src_i + t - dst_i|^2. Needs at least 1 pair (one pair: translation only).
bool align_rigid(const std::vector<Vec3d>& src, const std::vector<Vec3d>& dst, Alignment& out, std::string& err);

struct AteResult {
  std::vector<StampPair> pairs;
  Alignment align;
  std::vector<double> errors;  //!< |T * est_i - gt_i| per pair, in pairs' order (metres)
  ErrorStats stats;
};

//! ATE of `est` against `gt` (both sorted by stamp), evaluate_ate.py's way. Fails (err set) when
//! fewer than 3 poses associate.
bool compute_ate(const std::vector<io::StampedPose>& est, const std::vector<io::StampedPose>& gt, double max_dt_s,
                 AteResult& out, std::string& err);

struct RpeOptions {
  int delta = 1;            //!< frame delta (evaluate_rpe.py --fixed_delta --delta N --delta_unit f)
  double max_dt_s = -1.0;   //!< ground-truth stamp tolerance; < 0: 2 x the median GT interval (evaluate_rpe.py)
};

struct RpePair {
  std::size_t est0 = 0, est1 = 0, gt0 = 0, gt1 = 0;
  double trans_m = 0, rot_rad = 0;
};

struct RpeResult {
  double gt_max_dt_s = 0;        //!< the tolerance used
  std::size_t candidates = 0;    //!< frame pairs (i, i + delta) considered
  std::vector<RpePair> pairs;    //!< those with ground truth at both ends
  ErrorStats trans_m;            //!< translational error, metres
  ErrorStats rot_deg;            //!< rotational error, degrees
};

//! RPE over a fixed frame delta, evaluate_rpe.py's way: pairs (i, j = i + delta) of estimated
//! frames, skipping (like the script) the pair whose j would be the last frame; each end takes the
//! nearest ground-truth pose and the pair is dropped if that is more than max_dt_s away. All pairs
//! are used (the script samples 10000 at random only when there are more). Fails when no pair is left.
bool compute_rpe(const std::vector<io::StampedPose>& est, const std::vector<io::StampedPose>& gt,
                 const RpeOptions& opt, RpeResult& out, std::string& err);

//! Checks that a trajectory (sorted by stamp) has no repeated stamp; `name` goes into the message.
bool check_unique_stamps(const std::vector<io::StampedPose>& poses, const std::string& name, std::string& err);

//! Loads a trajectory for evaluation: a TUM-format file (any stamps, e.g. frame numbers for the
//! per-frame layout), or a data-set folder of FORMATS.md: its groundtruth.txt (TUM folder, rig
//! sensor chosen by `sensor`) or its per-frame poses (frame-NNNNNN.pose.txt, stamp = frame number).
//! `what` says what was read (for the printout). Errors name the file and line.
bool load_trajectory(const std::string& path, const std::string& sensor, std::vector<io::StampedPose>& poses,
                     std::string& what, std::string& err);

}  // namespace edgefuse::eval
