#include "edgefuse/fusion/pose_mean.hpp"

#include <cmath>

namespace edgefuse {

void PoseMean::add(const Pose& T, const Vec6f& sigma) {
  if (n_ == 0) first_ = T;
  Eigen::Vector4f q = T.quaternion().coeffs();
  if (q.dot(q_sum_) < 0.0f) q = -q;  // q and -q are the same rotation
  q_sum_ += q;
  t_sum_ += T.t;
  // Deviation from the first estimate in its own frame: T_first^-1 T = exp(xi).
  const Pose D = first_.inverse() * T;
  const Eigen::AngleAxisf aa(D.R);
  Vec6f xi;
  xi.head<3>() = aa.axis() * aa.angle();
  xi.tail<3>() = D.t;
  xi_sum_ += xi;
  xi_sq_sum_ += xi.cwiseProduct(xi);
  sigma_sum_ += sigma;
  ++n_;
}

Pose PoseMean::mean() const {
  if (n_ == 0) return Pose::identity();
  Pose m;
  m.t = t_sum_ / float(n_);
  Eigen::Quaternionf q;
  q.coeffs() = q_sum_.normalized();
  m.R = q.toRotationMatrix();
  return m;
}

Vec6f PoseMean::spread() const {
  if (n_ < 2) return Vec6f::Zero();
  const float n = float(n_);
  Vec6f var = (xi_sq_sum_ - xi_sum_.cwiseProduct(xi_sum_) / n) / (n - 1.0f);
  return var.cwiseMax(0.0f).cwiseSqrt();  // rounding can leave -0 for identical samples
}

Vec6f PoseMean::mean_sigma() const { return n_ == 0 ? Vec6f::Zero() : Vec6f(sigma_sum_ / float(n_)); }

}  // namespace edgefuse
