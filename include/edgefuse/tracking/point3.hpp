// A 3-vector in the kernel scalar, the storage of the tracking maps (vertices, normals).
//
// Point3<float> and Point3<Fixed> are both 12 bytes, so the static memory map sizes the tracking
// buffers once for either numeric build. The raycast maps stay Eigen Vec3f (the raycast's
// interface); load_real() converts them per access, without the double arithmetic of
// Fixed::from_float (the model is read a few times per ICP iteration, in the innermost loop).
#pragma once

#include <cstdint>

#include "edgefuse/math/pose.hpp"
#include "edgefuse/math/real.hpp"

namespace edgefuse {

template <class Real>
struct Point3 {
  Real x{}, y{}, z{};  //!< metres (vertices) or unit components (normals); z = 0 marks "none"
};

//! float -> kernel scalar for values well inside Q16.16's range (|v| < 32768: metres of a sensor's
//! view, unit normals). Rounds to nearest like Fixed::from_float, in single precision.
template <class Real>
inline Real load_real(float v);
template <>
inline float load_real<float>(float v) { return v; }
template <>
inline Fixed load_real<Fixed>(float v) { return Fixed::from_raw(round_int(v * 65536.0f)); }

//! An Eigen vector of the raycast maps as a Point3 in the kernel scalar.
template <class Real>
inline Point3<Real> load_point(const Vec3f& v) {
  return Point3<Real>{load_real<Real>(v.x()), load_real<Real>(v.y()), load_real<Real>(v.z())};
}

//! A Point3 back to float (tests, tools).
template <class Real>
inline Vec3f to_vec3f(const Point3<Real>& p) {
  return Vec3f(to_float(p.x), to_float(p.y), to_float(p.z));
}

}  // namespace edgefuse
