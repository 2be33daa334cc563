// The per-pixel part of an ICP evaluation (private to src/tracking): association, rejection,
// residual, Jacobian and robust weight of every frame point of some rows, summed per row.
// Templated over the kernel scalar; see icp.hpp for the equations and the accumulation scheme.
#pragma once

#include "../tsdf/kernel_math.hpp"
#include "edgefuse/tracking/icp.hpp"
#include "edgefuse/tracking/point3.hpp"

namespace edgefuse {

//! Constants of one evaluation, in the kernel scalar.
template <class Real>
struct IcpPass {
  Real R[9], t[3];             //!< current T_model_frame, row-major rotation
  Real fx, fy, cx, cy;         //!< full-resolution intrinsics (the model maps)
  Real min_z;                  //!< points nearer than this in the model frame are not projected
  Real max_dist2;              //!< squared rejection distance
  Real min_cos;                //!< cosine of the rejection angle
  Real robust_scale;           //!< Huber k / Tukey c
  RobustLoss loss = RobustLoss::kHuber;  //!< robust weight
  int model_w = 0, model_h = 0;          //!< model map size
  const PyramidLevel<Real>* level = nullptr;          //!< the frame's level being aligned
  ImageView<const Vec3f> model_vertex, model_normal;  //!< raycast maps (float, converted on load)
  typename IcpAccumulator<Real>::Row* rows = nullptr;  //!< one per row of `level`
};

inline void mul_acc(float& a, float x, float y) { a += x * y; }
inline void mul_acc(int64_t& a, Fixed x, Fixed y) { a += int64_t(x.raw()) * int64_t(y.raw()); }

//! Rows [begin, end) of the level: fills pass.rows[begin..end).
template <class Real>
void icp_rows(const IcpPass<Real>& pass, int begin, int end) {
  const Real zero = real_from_int<Real>(0);
  const Real one = real_from_int<Real>(1);
  const PyramidLevel<Real>& L = *pass.level;
  for (int v = begin; v < end; ++v) {
    typename IcpAccumulator<Real>::Row sums;
    const Point3<Real>* vert = L.vertex.row(v);
    const Point3<Real>* nrm = L.normal.row(v);
    for (int u = 0; u < L.intr.width; ++u) {
      const Point3<Real>& p = vert[u];
      const Point3<Real>& nf = nrm[u];
      if (!(p.z > zero) || (nf.x == zero && nf.y == zero && nf.z == zero)) continue;
      ++sums.valid;
      // Frame point in the model frame, projected into the full-resolution model.
      const Real px = pass.R[0] * p.x + pass.R[1] * p.y + pass.R[2] * p.z + pass.t[0];
      const Real py = pass.R[3] * p.x + pass.R[4] * p.y + pass.R[5] * p.z + pass.t[1];
      const Real pz = pass.R[6] * p.x + pass.R[7] * p.y + pass.R[8] * p.z + pass.t[2];
      if (!(pz > pass.min_z)) continue;
      const Real inv_z = one / pz;
      int mu, mv;
      if (!pixel_of(pass.fx * px * inv_z + pass.cx, pass.model_w, mu) ||
          !pixel_of(pass.fy * py * inv_z + pass.cy, pass.model_h, mv))
        continue;
      const Vec3f& nmf = pass.model_normal.at(mu, mv);
      if (nmf.x() == 0.0f && nmf.y() == 0.0f && nmf.z() == 0.0f) continue;  // no model surface
      const Point3<Real> n = load_point<Real>(nmf);
      // Frame normal rotated into the model frame against the model normal.
      const Real nrx = pass.R[0] * nf.x + pass.R[1] * nf.y + pass.R[2] * nf.z;
      const Real nry = pass.R[3] * nf.x + pass.R[4] * nf.y + pass.R[5] * nf.z;
      const Real nrz = pass.R[6] * nf.x + pass.R[7] * nf.y + pass.R[8] * nf.z;
      if (nrx * n.x + nry * n.y + nrz * n.z < pass.min_cos) continue;
      ++sums.candidates;
      const Point3<Real> q = load_point<Real>(pass.model_vertex.at(mu, mv));
      const Real dx = px - q.x, dy = py - q.y, dz = pz - q.z;
      if (dx * dx + dy * dy + dz * dz > pass.max_dist2) continue;
      const Real r = n.x * dx + n.y * dy + n.z * dz;
      const Real a = r < zero ? zero - r : r;
      Real w = one;
      if (pass.loss == RobustLoss::kHuber) {
        if (a > pass.robust_scale) w = pass.robust_scale / a;
      } else if (pass.loss == RobustLoss::kTukey) {
        if (!(a < pass.robust_scale)) continue;
        const Real s = r / pass.robust_scale;
        const Real m = one - s * s;
        w = m * m;
      }
      // J = [p_m x n, n].
      const Real J[6] = {py * n.z - pz * n.y, pz * n.x - px * n.z, px * n.y - py * n.x, n.x, n.y, n.z};
      Real wJ[6];
      for (int i = 0; i < 6; ++i) wJ[i] = w == one ? J[i] : w * J[i];
      int k = 0;
      for (int i = 0; i < 6; ++i)
        for (int j = i; j < 6; ++j) mul_acc(sums.ata[k++], wJ[i], J[j]);
      for (int i = 0; i < 6; ++i) mul_acc(sums.atb[i], wJ[i], r);
      mul_acc(sums.rr, r, r);
      ++sums.count;
    }
    pass.rows[v] = sums;
  }
}

}  // namespace edgefuse
