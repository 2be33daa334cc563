#include "edgefuse/filters/jump_edge.hpp"

#include <cmath>

#include "view_checks.hpp"

namespace edgefuse {
namespace {

// Q16.16 integer of a kernel scalar, for the exact integer comparison shared by both builds.
inline int64_t to_q16(float v) {
  if (!(v < 32767.0f)) return INT32_MAX;
  if (!(v > -32767.0f)) return -INT32_MAX;
  return round_int(v * 65536.0f);
}
inline int64_t to_q16(Fixed v) { return v.raw(); }

// The 8 neighbours (du, dv) and the axis of their ray offset: 0 = (1, 0), 1 = (0, 1),
// 2 = (1, 1), 3 = (1, -1) in (du, dv); sign -1 for the opposite direction.
struct Neighbour {
  int du, dv, axis, sign;
};
constexpr Neighbour kNeighbours[8] = {{-1, -1, 2, -1}, {0, -1, 1, -1}, {1, -1, 3, 1}, {-1, 0, 0, -1},
                                      {1, 0, 0, 1},    {-1, 1, 3, -1}, {0, 1, 1, 1},  {1, 1, 2, 1}};

// T* of one neighbour direction at a pixel with ray (x, y, 1): the depth jump, in pixel
// footprints, beyond which the neighbour lies within alpha of the ray (see the header). With
// delta = (a, b, 0): |delta x r|^2 = a^2 + b^2 + (a y - b x)^2 and delta . r = a x + b y.
template <class Real>
Real jump_threshold(const JumpEdgeKernel<Real>& k, Real x, Real y, Real inv_r2, int axis, int sign) {
  const Real one = real_from_int<Real>(1);
  const Real asp = k.aspect;
  Real cross2, dot;
  switch (axis) {
    case 0:
      cross2 = one + y * y;
      dot = x;
      break;
    case 1:
      cross2 = asp * asp * (one + x * x);
      dot = asp * y;
      break;
    case 2: {
      const Real c = y - asp * x;
      cross2 = one + asp * asp + c * c;
      dot = x + asp * y;
      break;
    }
    default: {
      const Real c = y + asp * x;
      cross2 = one + asp * asp + c * c;
      dot = x - asp * y;
      break;
    }
  }
  const Real along = sign > 0 ? dot : Real(-dot);
  return (real_sqrt(cross2) * k.inv_tan - along) * inv_r2;
}

// Lower bound of T* over the pixels of a cell and all 8 directions, from the header's formula
// with |delta x r| >= |delta| >= min(1, aspect), delta . r <= |delta| rho <= sqrt(1 + aspect^2) rho
// and 1 <= |r|^2 <= 1 + rho^2, rho^2 <= max x^2 + max y^2 over the cell (x^2, y^2 are convex, so
// their maxima are at the cell's first or last pixel). Computed in double for both builds and
// lowered by a margin that covers the rounding of the exact T* in either scalar.
int64_t cell_bound_q16(const PinholeIntrinsics& c, double inv_tan, int u0, int u1, int v0, int v1) {
  const double xa = (u0 - double(c.cx)) / c.fx, xb = (u1 - double(c.cx)) / c.fx;
  const double ya = (v0 - double(c.cy)) / c.fy, yb = (v1 - double(c.cy)) / c.fy;
  const double rho2 = (xa * xa > xb * xb ? xa * xa : xb * xb) + (ya * ya > yb * yb ? ya * ya : yb * yb);
  const double asp = double(c.fx) / c.fy;
  const double n = (asp < 1.0 ? asp : 1.0) * inv_tan - std::sqrt(1.0 + asp * asp) * std::sqrt(rho2);
  const double t = n >= 0 ? n / (1.0 + rho2) : n;
  const double q = std::floor(t * 65536.0);
  const double clamped = q > 2147483647.0 ? 2147483647.0 : (q < -2147483647.0 ? -2147483647.0 : q);
  const int64_t b = int64_t(clamped);
  return b - ((b >= 0 ? b : -b) >> 6) - 16;
}

}  // namespace

template <class Real>
Status JumpEdgeKernel<Real>::prepare(const JumpEdgeParams& params, const PinholeIntrinsics& intr) {
  prepared = false;
  if (!params.valid() || intr.validate() != Status::kOk) return Status::kInvalidArgument;
  const double alpha = (180.0 - double(params.max_angle_deg)) * 3.14159265358979323846 / 180.0;
  const double inv_tan_d = 1.0 / std::tan(alpha);
  width = intr.width;
  height = intr.height;
  fx = real_from<Real>(intr.fx);
  fy = real_from<Real>(intr.fy);
  cx = real_from<Real>(intr.cx);
  cy = real_from<Real>(intr.cy);
  aspect = real_from<Real>(float(double(intr.fx) / intr.fy));
  inv_tan = real_from<Real>(float(inv_tan_d));
  fx_q16 = int64_t(std::llround(double(intr.fx) * 65536.0));
  cell_w = (width + kGrid - 1) / kGrid;
  cell_h = (height + kGrid - 1) / kGrid;
  for (int gy = 0; gy < kGrid; ++gy)
    for (int gx = 0; gx < kGrid; ++gx) {
      const int u0 = gx * cell_w, v0 = gy * cell_h;
      const int u1 = u0 + cell_w < width ? u0 + cell_w - 1 : width - 1;
      const int v1 = v0 + cell_h < height ? v0 + cell_h - 1 : height - 1;
      bound_q16[gy * kGrid + gx] = (u0 < width && v0 < height) ? cell_bound_q16(intr, inv_tan_d, u0, u1, v0, v1) : 0;
    }
  prepared = true;
  return Status::kOk;
}

template <class Real>
Status remove_jump_edges(ImageView<const uint16_t> depth, const JumpEdgeKernel<Real>& k, ImageView<uint16_t> out) {
  using namespace filters_detail;
  if (!k.prepared) return Status::kNotInitialised;
  if (!usable(depth) || !usable(out) || !same_size(depth, out) || depth.width != k.width || depth.height != k.height ||
      overlap(depth, out))
    return Status::kInvalidArgument;
  const int w = depth.width, h = depth.height;
  for (int v = 0; v < h; ++v) {
    const Real y = (real_from_int<Real>(v) - k.cy) / k.fy;
    const int64_t* cell_bounds = k.bound_q16 + (v / k.cell_h) * JumpEdgeKernel<Real>::kGrid;
    const uint16_t* rows[3] = {v > 0 ? depth.row(v - 1) : nullptr, depth.row(v),
                               v + 1 < h ? depth.row(v + 1) : nullptr};
    uint16_t* o = out.row(v);
    for (int u0 = 0, cell = 0; u0 < w; u0 += k.cell_w, ++cell) {
      const int64_t bound = cell_bounds[cell];
      const int u_end = u0 + k.cell_w < w ? u0 + k.cell_w : w;
      for (int u = u0; u < u_end; ++u) {
        const int32_t zc = rows[1][u];
        if (zc == 0) {
          o[u] = 0;
          continue;
        }
        // Cheap pass: which neighbours jump by more than the cell's lower bound of T*?
        unsigned candidates = 0;
        for (int i = 0; i < 8; ++i) {
          const Neighbour& nb = kNeighbours[i];
          const uint16_t* r = rows[nb.dv + 1];
          const int un = u + nb.du;
          if (r == nullptr || un < 0 || un >= w || r[un] == 0) continue;
          const int64_t zn = r[un];
          if ((zn - zc) * k.fx_q16 > bound * zn) candidates |= 1u << i;
        }
        bool keep = true;
        if (candidates != 0) {
          // Exact test: back-project the pixel's ray and compare with each candidate's own T*.
          const Real x = (real_from_int<Real>(u) - k.cx) / k.fx;
          const Real inv_r2 = real_from_int<Real>(1) / (real_from_int<Real>(1) + x * x + y * y);
          for (int i = 0; i < 8 && keep; ++i) {
            if (!(candidates & (1u << i))) continue;
            const Neighbour& nb = kNeighbours[i];
            const int64_t zn = rows[nb.dv + 1][u + nb.du];
            const int64_t t_q16 = to_q16(jump_threshold(k, x, y, inv_r2, nb.axis, nb.sign));
            keep = !((zn - zc) * k.fx_q16 > t_q16 * zn);
          }
        }
        o[u] = keep ? uint16_t(zc) : uint16_t(0);
      }
    }
  }
  return Status::kOk;
}

template struct JumpEdgeKernel<float>;
template struct JumpEdgeKernel<Fixed>;
template Status remove_jump_edges<float>(ImageView<const uint16_t>, const JumpEdgeKernel<float>&, ImageView<uint16_t>);
template Status remove_jump_edges<Fixed>(ImageView<const uint16_t>, const JumpEdgeKernel<Fixed>&, ImageView<uint16_t>);

}  // namespace edgefuse
