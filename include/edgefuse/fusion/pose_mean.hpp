// The mean of several estimates of one rigid transform (a calibration repeated over frames), and
// their spread. No storage per sample: the spread is taken in the tangent space at the first
// sample, which for the sub-degree, millimetre deviations of repeated calibrations equals the
// spread about the mean to well below the estimates' own noise.
#pragma once

#include "edgefuse/math/pose.hpp"

namespace edgefuse {

class PoseMean {
 public:
  //! Adds one estimate.
  //! \param T the estimate (e.g. T_a_b of one frame)
  //! \param sigma its own 1-sigma (rotation x, y, z in rad; translation x, y, z in m)
  void add(const Pose& T, const Vec6f& sigma = Vec6f::Zero());

  //! Estimates added so far.
  int count() const { return n_; }
  //! Mean translation and mean rotation (sign-aligned quaternion average); identity when empty.
  Pose mean() const;
  //! Sample standard deviation of the estimates (rotation x, y, z in rad; translation x, y, z in m,
  //! in the estimates' own frame); zero for fewer than two. This is the honest uncertainty of one
  //! estimate; the mean's is smaller by sqrt(count()).
  Vec6f spread() const;
  //! Mean of the estimates' own 1-sigma (from their covariances: a lower bound).
  Vec6f mean_sigma() const;

 private:
  int n_ = 0;
  Pose first_;
  Vec3f t_sum_ = Vec3f::Zero();
  Eigen::Vector4f q_sum_ = Eigen::Vector4f::Zero();
  Vec6f xi_sum_ = Vec6f::Zero();
  Vec6f xi_sq_sum_ = Vec6f::Zero();
  Vec6f sigma_sum_ = Vec6f::Zero();
};

}  // namespace edgefuse
