// Pose token groups and 7-Scenes 4x4 pose files.
#include <cmath>

#include "edgefuse/io/trajectory.hpp"
#include "file_util.hpp"
#include "pose_text.hpp"
#include "text_util.hpp"

namespace edgefuse::io {

using detail::format;

bool detail::pose_from_tq_tokens(const std::string_view* tok, Pose& T, std::string& why) {
  double v[7];
  for (int i = 0; i < 7; ++i) {
    if (!parse_double(tok[i], v[i]) || !std::isfinite(v[i]) || std::fabs(v[i]) > 1e30) {
      why = "not a finite number: " + quote(tok[i]);
      return false;
    }
  }
  const double qn = std::sqrt(v[3] * v[3] + v[4] * v[4] + v[5] * v[5] + v[6] * v[6]);
  if (std::fabs(qn - 1.0) > 0.01) {
    why = format("quaternion (qx qy qz qw) = (%g %g %g %g) has norm %g, expected 1", v[3], v[4], v[5], v[6], qn);
    return false;
  }
  T = Pose::from_tq(float(v[0]), float(v[1]), float(v[2]), float(v[3]), float(v[4]), float(v[5]), float(v[6]));
  return true;
}

bool read_pose_matrix_txt(const std::string& path, Pose& T, std::string& err) {
  double m[16];
  if (!detail::read_number_matrix(path, 4, 4, "pose matrix", m, err)) return false;
  if (m[12] != 0 || m[13] != 0 || m[14] != 0 || m[15] != 1) {
    err = format("%s: last row is %g %g %g %g, expected 0 0 0 1", path.c_str(), m[12], m[13], m[14], m[15]);
    return false;
  }
  Eigen::Matrix3d R;
  R << m[0], m[1], m[2], m[4], m[5], m[6], m[8], m[9], m[10];
  const double dev = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (!(dev < 1e-3) || !(R.determinant() > 0)) {
    err = format("%s: the 3x3 block is not a rotation (|R^T R - I| = %g, det = %g)", path.c_str(), dev,
                 R.determinant());
    return false;
  }
  Mat4f M;
  for (int i = 0; i < 16; ++i) M(i / 4, i % 4) = float(m[i]);
  T = Pose::from_matrix(M);
  return true;
}

}  // namespace edgefuse::io
