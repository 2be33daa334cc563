#include "edgefuse/fusion/hand_eye.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <cmath>
#include <cstdio>

namespace edgefuse {

namespace {

using Mat3 = Eigen::Matrix3d;
using Vec3 = Eigen::Vector3d;
using Mat6 = Eigen::Matrix<double, 6, 6>;
using Vec6 = Eigen::Matrix<double, 6, 1>;

constexpr double kDegPerRad = 57.29577951308232;
//! Residual variances are floored here (1e-9 m / rad squared): far below the float inputs'
//! rounding, so exact data still gives finite weights.
constexpr double kVarianceFloor = 1e-18;

struct Motion {
  Mat3 R = Mat3::Identity();
  Vec3 t = Vec3::Zero();
  Motion inverse() const { return Motion{R.transpose(), -(R.transpose() * t)}; }
  Motion operator*(const Motion& o) const { return Motion{R * o.R, R * o.t + t}; }
};

Motion to_motion(const Pose& p) { return Motion{p.R.cast<double>(), p.t.cast<double>()}; }

Pose to_pose(const Motion& m) {
  Pose p;
  p.R = m.R.cast<float>();
  p.t = m.t.cast<float>();
  return p;
}

Mat3 skew(const Vec3& v) {
  Mat3 s;
  s << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return s;
}

// Rotation vector of R (through the quaternion: accurate for small angles too).
Vec3 log_so3(const Mat3& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.axis() * aa.angle();
}

Mat3 exp_so3(const Vec3& w) {
  const double a = w.norm();
  return a > 0.0 ? Eigen::AngleAxisd(a, w / a).toRotationMatrix() : Mat3::Identity();
}

// The proper rotation nearest to M (Frobenius), by SVD.
Mat3 nearest_rotation(const Mat3& M) {
  const Eigen::JacobiSVD<Mat3> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3 D = Mat3::Identity();
  D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0.0 ? -1.0 : 1.0;
  return svd.matrixU() * D * svd.matrixV().transpose();
}

// The stations in double, and the relative motions of a pair computed on the fly (no storage per pair).
struct Stations {
  Motion a[kHandEyeStationsMax];  // T_base_flange
  Motion c[kHandEyeStationsMax];  // T_map_cam
  int n = 0;
  Motion flange_motion(int i, int j) const { return a[i].inverse() * a[j]; }
  Motion camera_motion(int i, int j) const { return c[i].inverse() * c[j]; }
};

// Residual of one pair at X: rotation (rad) then translation (m); see the header.
Vec6 pair_residual(const Motion& A, const Motion& B, const Motion& X) {
  Vec6 e;
  e.head<3>() = log_so3(A.R * X.R * B.R.transpose() * X.R.transpose());
  e.tail<3>() = A.R * X.t + A.t - X.R * B.t - X.t;
  return e;
}

// Jacobian of pair_residual for X's update (phi on the left of R_X, then t_X).
Mat6 pair_jacobian(const Motion& A, const Motion& B, const Motion& X) {
  Mat6 J = Mat6::Zero();
  const Mat3 A_minus_I = A.R - Mat3::Identity();
  J.block<3, 3>(0, 0) = A_minus_I;
  J.block<3, 3>(3, 0) = skew(X.R * B.t);
  J.block<3, 3>(3, 3) = A_minus_I;
  return J;
}

bool refuse(HandEyeResult& out, const char* text) {
  std::snprintf(out.reason, sizeof(out.reason), "%s", text);
  return false;
}

// Does the flange's motion determine X? Largest relative rotation and the spread of the rotation
// axes (principal spreads of the rotation vectors of all pairs).
bool motion_determines_x(const Stations& s, const HandEyeParams& params, HandEyeResult& out) {
  if (s.n < 3) {
    std::snprintf(out.reason, sizeof(out.reason),
                  "%d stations: at least 3 are needed (two motions about different axes)", s.n);
    return false;
  }
  Mat3 spread = Mat3::Zero();
  double largest = 0.0;
  for (int i = 0; i < s.n; ++i)
    for (int j = i + 1; j < s.n; ++j) {
      const Vec3 a = log_so3(s.flange_motion(i, j).R);
      spread += a * a.transpose();
      largest = std::fmax(largest, a.norm());
    }
  out.largest_rotation_deg = float(largest * kDegPerRad);
  if (out.largest_rotation_deg < params.min_rotation_deg) {
    std::snprintf(out.reason, sizeof(out.reason),
                  "rotations too small: the largest between two stations is %.2f deg (< %.2f deg)",
                  out.largest_rotation_deg, params.min_rotation_deg);
    return false;
  }
  const Eigen::SelfAdjointEigenSolver<Mat3> eig(spread, Eigen::EigenvaluesOnly);
  const Vec3 ev = eig.eigenvalues().cwiseMax(0.0);  // ascending
  out.axis_ratio = float(std::sqrt(ev(1) / ev(2)));
  if (out.axis_ratio < params.min_axis_ratio) {
    std::snprintf(out.reason, sizeof(out.reason),
                  "all rotations about one axis: translation along it is free (second axis %.1f %% of the first, "
                  "< %.1f %%)",
                  100.0f * out.axis_ratio, 100.0f * params.min_axis_ratio);
    return false;
  }
  return true;
}

// Park & Martin: a = R_X b for the rotation vectors of every pair; R_X nearest to sum a b^T.
Mat3 closed_form_rotation(const Stations& s) {
  Mat3 Mt = Mat3::Zero();  // M^T = sum a b^T
  for (int i = 0; i < s.n; ++i)
    for (int j = i + 1; j < s.n; ++j)
      Mt += log_so3(s.flange_motion(i, j).R) * log_so3(s.camera_motion(i, j).R).transpose();
  return nearest_rotation(Mt);
}

// (R_A - I) t_X = R_X t_B - t_A over every pair, by least squares (normal equations).
Vec3 closed_form_translation(const Stations& s, const Mat3& R_X) {
  Mat3 N = Mat3::Zero();
  Vec3 rhs = Vec3::Zero();
  for (int i = 0; i < s.n; ++i)
    for (int j = i + 1; j < s.n; ++j) {
      const Motion A = s.flange_motion(i, j), B = s.camera_motion(i, j);
      const Mat3 C = A.R - Mat3::Identity();
      N += C.transpose() * C;
      rhs += C.transpose() * (R_X * B.t - A.t);
    }
  return N.ldlt().solve(rhs);
}

// Mean squared residual per component of each block (rotation, translation) at X, floored.
void block_variances(const Stations& s, const Motion& X, double& var_rot, double& var_trans) {
  double sr = 0.0, st = 0.0;
  int pairs = 0;
  for (int i = 0; i < s.n; ++i)
    for (int j = i + 1; j < s.n; ++j) {
      const Vec6 e = pair_residual(s.flange_motion(i, j), s.camera_motion(i, j), X);
      sr += e.head<3>().squaredNorm();
      st += e.tail<3>().squaredNorm();
      ++pairs;
    }
  var_rot = std::fmax(sr / (3.0 * pairs), kVarianceFloor);
  var_trans = std::fmax(st / (3.0 * pairs), kVarianceFloor);
}

// The weighted normal equations at X: H = sum J^T W J, g = sum J^T W e, chi2 = sum e^T W e.
struct NormalSystem {
  Mat6 H = Mat6::Zero();
  Vec6 g = Vec6::Zero();
  double chi2 = 0.0;
};

NormalSystem normal_system(const Stations& s, const Motion& X, double var_rot, double var_trans) {
  Vec6 w;
  w << Vec3::Constant(1.0 / var_rot), Vec3::Constant(1.0 / var_trans);
  NormalSystem sys;
  for (int i = 0; i < s.n; ++i)
    for (int j = i + 1; j < s.n; ++j) {
      const Motion A = s.flange_motion(i, j), B = s.camera_motion(i, j);
      const Vec6 e = pair_residual(A, B, X);
      const Mat6 J = pair_jacobian(A, B, X);
      const Mat6 JtW = J.transpose() * w.asDiagonal();
      sys.H += JtW * J;
      sys.g += JtW * e;
      sys.chi2 += e.dot(w.asDiagonal() * e);
    }
  return sys;
}

// Gauss-Newton from X over every pair, the weights re-estimated from the residuals each iteration.
Motion refine(const Stations& s, Motion X, const HandEyeParams& params, HandEyeResult& out) {
  for (int it = 0; it < params.iterations; ++it) {
    double var_rot, var_trans;
    block_variances(s, X, var_rot, var_trans);
    const NormalSystem sys = normal_system(s, X, var_rot, var_trans);
    const Vec6 step = -sys.H.ldlt().solve(sys.g);
    if (!step.allFinite()) break;
    X.R = exp_so3(step.head<3>()) * X.R;
    X.t += step.tail<3>();
    out.iterations = it + 1;
    if (step.head<3>().norm() < params.stop_rotation_rad && step.tail<3>().norm() < params.stop_translation_m) break;
  }
  return X;
}

// 1-sigma of X from the normal matrix scaled by the residual variance, and by P / (n - 1) for the
// pairs' shared stations (see the header).
void uncertainty(const Stations& s, const Motion& X, HandEyeResult& out) {
  double var_rot, var_trans;
  block_variances(s, X, var_rot, var_trans);
  const NormalSystem sys = normal_system(s, X, var_rot, var_trans);
  const int P = s.n * (s.n - 1) / 2;
  const double s2 = sys.chi2 / double(6 * P - 6);
  const Mat6 cov = sys.H.ldlt().solve(Mat6::Identity()) * (s2 * double(P) / double(s.n - 1));
  for (int k = 0; k < 6; ++k) out.sigma(k) = float(std::sqrt(std::fmax(cov(k, k), 0.0)));
  out.rms_rotation_deg = float(std::sqrt(3.0 * var_rot) * kDegPerRad);
  out.rms_translation_m = float(std::sqrt(3.0 * var_trans));
}

// T_map_base as the mean of every station's C_i X^-1 A_i^-1, then each station's camera pose as
// the robot predicts it against the measured one.
void station_residuals(const Stations& s, const Motion& X, HandEyeResult& out) {
  Mat3 R_sum = Mat3::Zero();
  Vec3 t_sum = Vec3::Zero();
  const Motion X_inv = X.inverse();
  for (int i = 0; i < s.n; ++i) {
    const Motion Y = s.c[i] * X_inv * s.a[i].inverse();
    R_sum += Y.R;
    t_sum += Y.t;
  }
  const Motion Y{nearest_rotation(R_sum), t_sum / double(s.n)};
  out.T_map_base = to_pose(Y);
  for (int i = 0; i < s.n; ++i) {
    const Motion D = (Y * s.a[i] * X).inverse() * s.c[i];
    out.station_residual_m[i] = float(D.t.norm());
    out.station_residual_deg[i] = float(log_so3(D.R).norm() * kDegPerRad);
  }
}

}  // namespace

Status solve_hand_eye(const Pose* T_base_flange, const Pose* T_map_cam, int count, const HandEyeParams& params,
                      HandEyeResult& out) {
  out = HandEyeResult{};
  if (T_base_flange == nullptr || T_map_cam == nullptr || count < 0 || count > kHandEyeStationsMax ||
      !params.valid())
    return Status::kInvalidArgument;
  Stations s;
  s.n = count;
  for (int i = 0; i < count; ++i) {
    s.a[i] = to_motion(T_base_flange[i]);
    s.c[i] = to_motion(T_map_cam[i]);
  }
  out.stations = count;
  out.pairs = count * (count - 1) / 2;
  if (!motion_determines_x(s, params, out)) return Status::kOk;
  Motion X;
  X.R = closed_form_rotation(s);
  X.t = closed_form_translation(s, X.R);
  out.closed_form = to_pose(X);
  X = refine(s, X, params, out);
  if (!X.R.allFinite() || !X.t.allFinite()) {
    refuse(out, "the refinement diverged (inconsistent robot and camera motions?)");
    return Status::kOk;
  }
  out.T_flange_cam = to_pose(X);
  uncertainty(s, X, out);
  station_residuals(s, X, out);
  out.solved = true;
  return Status::kOk;
}

}  // namespace edgefuse
