// Point pair feature helpers shared by the model table and the scene voting (Drost et al. 2010):
// F(m1, m2) = (|d|, angle(n1, d), angle(n2, d), angle(n1, n2)), quantised into one key, and the
// angle alpha about the x axis that brings the pair into a canonical half plane.
#pragma once

#include <cmath>
#include <cstdint>

#include "edgefuse/localize/localize_types.hpp"
#include "edgefuse/math/real.hpp"

namespace edgefuse::ppf {

inline constexpr float kPi = 3.14159265358979323846f;

inline float clamp_unit(float v) { return v > 1.0f ? 1.0f : (v < -1.0f ? -1.0f : v); }

inline int angle_bin(float cos_a) {
  int b = int(std::acos(clamp_unit(cos_a)) * (float(kPpfAngleBins) / kPi));
  return b >= kPpfAngleBins ? kPpfAngleBins - 1 : b;
}

//! Quantised feature of the pair (p1, n1) -> (p2, n2); false when the points coincide or are
//! farther apart than `max_dist_m`.
inline bool feature_key(const Vec3f& p1, const Vec3f& n1, const Vec3f& p2, const Vec3f& n2, float inv_step,
                        float max_dist_m, uint32_t& key) {
  const Vec3f d = p2 - p1;
  const float dist2 = d.squaredNorm();
  if (!(dist2 > 1e-12f) || dist2 > max_dist_m * max_dist_m) return false;
  const float dist = std::sqrt(dist2);
  const Vec3f dn = d / dist;
  const uint32_t qd = uint32_t(dist * inv_step);
  key = ((qd * 32u + uint32_t(angle_bin(n1.dot(dn)))) * 32u + uint32_t(angle_bin(n2.dot(dn)))) * 32u +
        uint32_t(angle_bin(n1.dot(n2)));
  return true;
}

inline uint32_t bucket_of(uint32_t key) { return (key * 2654435761u) >> (32 - 15); }
static_assert(kPpfBuckets == (1u << 15), "bucket_of assumes 2^15 buckets");

//! Rotation that maps the unit normal n onto +x.
inline Mat3f align_to_x(const Vec3f& n) {
  const Vec3f x(1, 0, 0);
  const Vec3f axis = n.cross(x);
  const float s = axis.norm(), c = n.dot(x);
  if (s < 1e-6f) {
    if (c > 0) return Mat3f::Identity();
    return Eigen::AngleAxisf(kPi, Vec3f(0, 1, 0)).toRotationMatrix();
  }
  return Eigen::AngleAxisf(std::atan2(s, c), axis / s).toRotationMatrix();
}

//! Angle about x that brings R_g (p2 - p1) into the x-y half plane y > 0.
inline float alpha_of(const Mat3f& R_g, const Vec3f& p1, const Vec3f& p2) {
  const Vec3f q = R_g * (p2 - p1);
  return std::atan2(-q.z(), q.y());
}

inline Mat3f rot_x(float a) {
  Mat3f R;
  const float c = std::cos(a), s = std::sin(a);
  R << 1, 0, 0, 0, c, -s, 0, s, c;
  return R;
}

inline int16_t quantise_alpha(float a) { return int16_t(std::lround(a * (32767.0f / kPi))); }
inline float alpha_from_q(int16_t q) { return float(q) * (kPi / 32767.0f); }

}  // namespace edgefuse::ppf
