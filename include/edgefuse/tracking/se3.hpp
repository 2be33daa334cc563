// Small-motion algebra of the ICP update: twists, the exponential map, re-orthonormalisation.
//
// A twist xi = (omega, v) (rotation vector in radians first, then translation in metres) acts on
// the left: T <- exp(xi) T. To first order exp(xi) p = p + omega x p + v, which is the model the
// point-to-plane Jacobian linearises (icp.hpp).
#pragma once

#include "edgefuse/math/pose.hpp"

namespace edgefuse {

//! exp of a twist: rotation by |omega| about omega (Rodrigues), translation V(omega) v with V
//! the left Jacobian of SO(3) (series near zero).
//! \param xi (omega_x, omega_y, omega_z, v_x, v_y, v_z)
Pose se3_exp(const Vec6f& xi);

//! The nearest rotation of a nearly orthonormal R (through the normalised quaternion), so
//! repeated float updates do not accumulate scale or shear.
//! \param R rotation with small numerical error
Mat3f orthonormalise(const Mat3f& R);

//! Translation distance and rotation angle (radians) between two poses: |t_b - t_a| and the angle
//! of R_a^T R_b (the relative motion, not the difference of the poses' norms).
//! \param a first pose  \param b second pose  \param dt_m out  \param angle_rad out
void pose_distance(const Pose& a, const Pose& b, float& dt_m, float& angle_rad);

}  // namespace edgefuse
