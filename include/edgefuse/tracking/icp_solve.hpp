// The 6x6 Gauss-Newton step of the ICP, restricted to the directions the view observes.
//
// Units: omega is in radians, v in metres, so the rotation columns of J (p x n, metres) and the
// translation columns (n, unitless) differ by a length. The system is scaled with
// S = diag(1/L, 1/L, 1/L, 1, 1, 1), L = the view's mean depth (a rotation by 1/L moves points at
// that depth by about 1 m, like a 1 m translation), then expressed in the eigenvectors V of the
// view's observability system (observability.hpp): B = V^T S A S V, c = V^T S b. Rows and columns
// of unobservable directions are replaced by the identity (their step is zero), the rest is solved
// by LDL^T, and xi = S V y. On a single plane the in-plane translation and the rotation about the
// normal therefore stay exactly at the prediction.
#pragma once

#include <Eigen/Core>

#include "edgefuse/math/pose.hpp"

namespace edgefuse {

using Mat6f = Eigen::Matrix<float, 6, 6>;

//! One evaluation's normal equations, in float.
struct IcpSystem {
  Mat6f A = Mat6f::Zero();  //!< sum w J^T J (symmetric)
  Vec6f b = Vec6f::Zero();  //!< sum w J^T r
  float rr = 0;             //!< sum r^2 over the inliers
  int count = 0;            //!< inliers
  int valid = 0;            //!< frame points with depth and normal
  int candidates = 0;       //!< frame points projecting onto model surface with a compatible normal
};

struct ViewObservability;

//! Solves A xi = -b in the observable directions.
//! \param s the system
//! \param view observable directions and scale
//! \param xi result (omega, v), to apply as exp(xi) T
//! \return false when the restricted system is not positive definite (no step)
bool solve_icp_step(const IcpSystem& s, const ViewObservability& view, Vec6f& xi);

}  // namespace edgefuse
