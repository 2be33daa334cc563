#include "edgefuse/tsdf/raycast.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <type_traits>

#include "kernel_math.hpp"
#include "lanes.hpp"
#include "raycast_bounds.hpp"
#include "tsdf_sampler.hpp"

namespace edgefuse {
namespace {

template <class Real>
Real abs_r(Real v) {
  // The float build clears the sign bit: GCC compiled the select as a branch, which the march's
  // distance step (samples on both sides of a surface) mispredicted often.
  if constexpr (std::is_same<Real, float>::value) {
    return __builtin_fabsf(v);
  } else {
    return v < real_from_int<Real>(0) ? real_from_int<Real>(0) - v : v;
  }
}
template <class Real>
Real max_r(Real a, Real b) {
  return a > b ? a : b;
}
template <class Real>
Real min_r(Real a, Real b) {
  return a < b ? a : b;
}

// Per-frame constants of one raycast, in the kernel scalar.
template <class Real>
struct RayFrame {
  Real R[9];            // rotation of T_world_cam, row-major
  Real g0[3];           // sensor centre in grid coordinates (voxel-centre units)
  Real inv_voxel;       // grid units per metre
  Real voxel, trunc;
  Real min_z, max_z;
  Real grid_max;        // last valid trilinear base coordinate + 1 (= dim - 1)
  Real clip_max;        // rays are clipped to [0, clip_max] (float: 1/2048 voxel less, see start())
  Real fx_inv, fy_inv, cx, cy;
};

template <class Real>
RayFrame<Real> make_ray_frame(const TsdfVolume& volume, const PinholeIntrinsics& intr, const Pose& T_world_cam) {
  RayFrame<Real> f;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) f.R[r * 3 + c] = real_from<Real>(T_world_cam.R(r, c));
  const Vec3f g0 = (T_world_cam.t - volume.origin_m()) / volume.voxel_m() - Vec3f::Constant(0.5f);
  for (int r = 0; r < 3; ++r) f.g0[r] = real_from<Real>(g0(r));
  f.inv_voxel = real_from<Real>(1.0f / volume.voxel_m());
  f.voxel = real_from<Real>(volume.voxel_m());
  f.trunc = real_from<Real>(volume.params().trunc_m);
  f.min_z = real_from<Real>(intr.min_range_m);
  f.max_z = real_from<Real>(intr.max_range_m);
  f.grid_max = real_from_int<Real>(volume.dim() - 1);
  f.clip_max = f.grid_max;
  if constexpr (std::is_same<Real, float>::value) f.clip_max = f.grid_max - 1.0f / 2048.0f;
  f.fx_inv = real_from<Real>(1.0f / intr.fx);
  f.fy_inv = real_from<Real>(1.0f / intr.fy);
  f.cx = real_from<Real>(intr.cx);
  f.cy = real_from<Real>(intr.cy);
  return f;
}

// The ray's direction in grid units per metre of z-depth, with what face crossings need. In float
// a crossing costs a multiplication by the reciprocal (a division per axis and brick otherwise);
// in Q16.16 the reciprocal of a large component (~500 at 2 mm voxels) keeps only ~2 digits, so
// the fixed-point build divides. Axes the ray runs (nearly) parallel to are never crossed.
template <class Real>
struct RayDir {
  Real gd[3] = {};
  // The rest is what face crossings need: brick skips and the clip to the grid, which most rays
  // never do (prepare_crossings() runs on first need).
  bool ready = false;       // the members below are set
  Real inv[3] = {};
  bool crosses[3] = {};
  int exit_side[3] = {};    // added to a brick's low face coordinate to get the face the ray leaves by
  Real last_cell[3] = {};   // t the ray takes to cross 1.01 voxels along each axis (crossed axes only)
  void prepare_crossings() {
    const Real tiny = real_from<Real>(1e-4f);
    ready = true;
    const Real* d = gd;
    for (int a = 0; a < 3; ++a) {
      crosses[a] = !(abs_r(d[a]) < tiny);
      exit_side[a] = d[a] > real_from_int<Real>(0) ? kBrickSide : 0;
      inv[a] = real_from_int<Real>(0);
      if constexpr (std::is_same<Real, float>::value) {
        if (crosses[a]) inv[a] = 1.0f / d[a];
      }
      last_cell[a] = crosses[a] ? abs_r(t_for(real_from<Real>(1.01f), a)) : real_from_int<Real>(0);
    }
  }
  //! t at which the ray's coordinate on `axis` has moved by `delta` grid units.
  Real t_for(Real delta, int axis) const {
    if constexpr (std::is_same<Real, float>::value) {
      return delta * inv[axis];
    } else {
      return delta / gd[axis];
    }
  }
};

// Clips t (z-depth along the ray) so that g0 + t gd stays in [0, grid_max) on every axis.
template <class Real>
bool clip_to_grid(const RayFrame<Real>& f, const RayDir<Real>& r, Real& t0, Real& t1) {
  const Real zero = real_from_int<Real>(0);
  for (int a = 0; a < 3; ++a) {
    if (!r.crosses[a]) {
      if (f.g0[a] < zero || !(f.g0[a] < f.clip_max)) return false;
      continue;
    }
    Real ta = r.t_for(zero - f.g0[a], a);
    Real tb = r.t_for(f.clip_max - f.g0[a], a);
    if (ta > tb) {
      const Real s = ta;
      ta = tb;
      tb = s;
    }
    t0 = max_r(t0, ta);
    t1 = min_r(t1, tb);
  }
  return t0 < t1;
}

// t at which the ray leaves the brick holding floor(g); `axis` is the face it leaves through.
template <class Real>
Real brick_exit(const RayFrame<Real>& f, const RayDir<Real>& r, const int cell[3], int& axis) {
  Real t_exit = real_from_int<Real>(1 << 14);
  axis = 0;
  for (int a = 0; a < 3; ++a) {
    if (!r.crosses[a]) continue;
    const Real face = real_from_int<Real>((cell[a] & ~(kBrickSide - 1)) + r.exit_side[a]);
    const Real ta = r.t_for(face - f.g0[a], a);
    if (ta < t_exit) {
      t_exit = ta;
      axis = a;
    }
  }
  return t_exit;
}

}  // namespace

Status prepare_raycast(const TsdfVolume& volume, const PinholeIntrinsics& intr, const Pose& T_world_cam,
                       const RaycastMaps& maps) {
  if (!volume.initialised()) return Status::kNotInitialised;
  if (intr.validate() != Status::kOk) return Status::kInvalidArgument;
  if (maps.depth_m.width != intr.width || maps.depth_m.height != intr.height || maps.depth_m.data == nullptr)
    return Status::kInvalidArgument;
  if ((!maps.vertex.empty() && (maps.vertex.width != intr.width || maps.vertex.height != intr.height)) ||
      (!maps.normal.empty() && (maps.normal.width != intr.width || maps.normal.height != intr.height)) ||
      (!maps.colour.empty() && (maps.colour.width != intr.width || maps.colour.height != intr.height)))
    return Status::kInvalidArgument;
  if (volume.dim() > kRaycastDimMax) return Status::kCapacityExceeded;

  // The bounds live in the depth map itself (raycast_bounds.hpp): no memory of their own.
  raycast_bounds::clear(maps.depth_m);
  const Pose T_cam_world = T_world_cam.inverse();
  const float vs = volume.voxel_m();
  const uint8_t* flags = volume.brick_flags();
  const uint64_t* masks = volume.block_mask();
  const std::size_t bricks = volume.brick_count();
  // The centre of block (0, 0, 0) of brick (0, 0, 0): origin + 1 voxel on each axis.
  const Vec3f first_block = T_cam_world * (volume.origin_m() + Vec3f::Constant(vs));
  const Vec3f brick_step[3] = {T_cam_world.R.col(0) * (kBrickSide * vs), T_cam_world.R.col(1) * (kBrickSide * vs),
                               T_cam_world.R.col(2) * (kBrickSide * vs)};
  const bool dilate = intr.width <= raycast_bounds::kDilateWidthMax;
  const raycast_bounds::Splatter splat(maps.depth_m, intr, T_cam_world, vs, dilate);
  const int nb = volume.bricks_per_axis();
  const std::size_t stride[3] = {1, std::size_t(nb), std::size_t(nb) * std::size_t(nb)};
  const auto brick_mask = [&](std::size_t k) -> uint64_t {
    if (!(flags[k] & kBrickSurface)) return 0;
    return masks != nullptr ? masks[k] : ~uint64_t(0);
  };
  // The sensor in voxel-centre grid coordinates (voxel i spans [i, i + 1)).
  const Vec3f cam_g = (T_world_cam.t - volume.origin_m()) / vs;
  // Calls visit(b, m, bc, c0) for every surface brick b with a non-zero mask m (a zero mask means
  // every observed voxel is positive: no crossing here; without mask storage every block of a
  // surface brick counts), bc its brick coordinates, c0 the sensor-frame centre of its block
  // (0, 0, 0). Surface bricks are a few per cent of the grid: the flags are read eight at a time.
  static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "byte k of a flag word is brick b + k");
  constexpr uint64_t kSurfaceBytes = 0x0101010101010101ull * kBrickSurface;
  const auto for_each_surface_brick = [&](auto&& visit) {
    const auto one = [&](std::size_t b) {
      const uint64_t m = brick_mask(b);
      if (m == 0) return;
      int bc[3];
      volume.brick_coords(b, bc[0], bc[1], bc[2]);
      visit(b, m, bc,
            first_block + float(bc[0]) * brick_step[0] + float(bc[1]) * brick_step[1] + float(bc[2]) * brick_step[2]);
    };
    std::size_t b0 = 0;
    for (; b0 + 8 <= bricks; b0 += 8) {
      uint64_t word;
      std::memcpy(&word, flags + b0, sizeof word);
      word &= kSurfaceBytes;  // one bit per byte at most
      while (word != 0) {
        one(b0 + std::size_t(__builtin_ctzll(word) >> 3));
        word &= word - 1;
      }
    }
    for (; b0 < bricks; ++b0) {
      if (flags[b0] & kBrickSurface) one(b0);
    }
  };
  for_each_surface_brick([&](std::size_t b, uint64_t m, const int* bc, const Vec3f& c0) {
    uint64_t lower[3], upper[3];
    int toward[3];
    for (int a = 0; a < 3; ++a) {
      lower[a] = bc[a] > 0 ? brick_mask(b - stride[a]) : 0;
      upper[a] = bc[a] + 1 < nb ? brick_mask(b + stride[a]) : 0;
      // The brick's crossing cubes span [8 b - 0.5, 8 b + 8.5] in these coordinates; a sensor
      // beyond them (with slack) sees every ray through them going the same way on this axis.
      const float lo = float(kBrickSide * bc[a]) - 2.0f, hi = float(kBrickSide * (bc[a] + 1)) + 2.0f;
      toward[a] = cam_g[a] < lo ? -1 : (cam_g[a] > hi ? 1 : 0);
    }
    splat.brick(raycast_bounds::front_back(m, lower, upper, toward), c0);
  });
  if (dilate) raycast_bounds::dilate(maps.depth_m);
  return Status::kOk;
}

template <class Real>
bool sample_tsdf(const TsdfVolume& volume, const Vec3f& p_world, float& d_m) {
  const Vec3f g = (p_world - volume.origin_m()) / volume.voxel_m() - Vec3f::Constant(0.5f);
  TsdfSampler<Real> s(volume);
  Real value;
  if (!s.sample(real_from<Real>(g.x()), real_from<Real>(g.y()), real_from<Real>(g.z()), value)) return false;
  d_m = to_float(value) * volume.params().trunc_m;
  return true;
}

namespace {

namespace cell_lanes {
// GCC vector extensions (lanes.hpp): the float build converts and interpolates a cell's corners
// 4 lanes at once.
using namespace lane_types;
}  // namespace cell_lanes

// The 8 corner values of one trilinear cell as the march reads them (corner i: +x for bit 0, +y
// for bit 1, +z for bit 2). The sample that finds a crossing keeps its cell's values: the first
// regula-falsi sample usually falls into the same cell and reuses them (no address, loads,
// unobserved test or conversions).
template <class Real>
struct CellCorners {
  uint32_t base;  // linear index of the cell's base voxel (identifies the cell)
  bool observed;  // no corner is kTsdfUnobserved (c is valid only then)
  Real c[8];      // Q16.16 fractions of trunc, corner order
};
// The float build keeps the stored integers as floats (never scaled, see lerp_cell), as two
// 4-lane vectors: corners 0, 2, 4, 6 (x = 0) and 1, 3, 5, 7 (x = 1).
template <>
struct CellCorners<float> {
  uint32_t base;
  bool observed;
  cell_lanes::F4 x0, x1;
};

// One ray being marched: everything the march needs between two samples.
template <class Real>
struct RayState {
  int u = 0, v = 0;
  RayDir<Real> dir;
  Real rx, ry;
  Real t, t_end;
  Real z_per_m;      // z-depth advanced per metre along the ray
  Real min_step;     // half a voxel
  Real nudge;        // 1/64 voxel
  Real half_trunc;   // half the truncation
  Real far_step;     // from a voxel at +trunc the surface is at least trunc - 1 voxel away
  Real prev_t;
  Real prev_s;  // the last sample's value when it can start a crossing, else 0 (no crossing next)
  Real step_per_value;  // z-depth per value unit (value_one() = trunc) along this ray
};

enum class MarchResult { kGoing, kHit, kMiss };

// The per-frame state of raycast_rows and the march of one ray, one sample at a time.
template <class Real>
class RayMarcher {
 public:
  RayMarcher(const TsdfVolume& volume, const PinholeIntrinsics& intr, const Pose& T_world_cam, const RaycastMaps& maps)
      : volume_(volume), intr_(intr), T_world_cam_(T_world_cam), maps_(maps),
        f_(make_ray_frame<Real>(volume, intr, T_world_cam)), flags_(volume.brick_flags()),
        tsdf_(volume.tsdf()), colour_(volume.colour()), colour_weight_(volume.colour_weight()),
        quant_(intr.max_range_m), last_(uint32_t(volume.dim() - 1)),
        nb_(uint32_t(volume.bricks_per_axis())), nb2_(nb_ * nb_), slot_(volume.brick_slots()),
        // Slack around the pixel's range (raycast_bounds.hpp; exact only up to float rounding):
        // every crossing lies inside the range, so the march's first sample is at least this far
        // in front of it. At least a voxel; and half a truncation less a quarter voxel, because a
        // first sample whose cell has an unobserved corner (depth holes and shadow rims leave such
        // cells in front of surfaces) steps half a truncation: from this start it lands at most a
        // quarter voxel past the near bound, where crossings are rare (they lie within a voxel of
        // a marked voxel, itself within half a voxel of its block's centre, and the bound is the
        // block's cube 1.5 voxels in front of that centre). Measured with cube bounds at
        // trunc = 4 voxels: a margin of 1 voxel lost 0.9 % of bin_rig_a xtion's hits against the
        // sphere bounds (7,981 / 1,999 pixels in one bench run), 1.5 and 1.75 voxels none
        // (docs/BENCHMARKS.md); 1.75 because 1.5 tipped test_edgefused_fusion_e2e's knife-edge
        // tracked can in the fixed-point build.
        margin_(real_from<Real>(std::max(volume.voxel_m(), 0.5f * volume.params().trunc_m - 0.25f * volume.voxel_m()))),
        want_vertex_(!maps.vertex.empty()), want_normal_(!maps.normal.empty()), clear_colour_(!maps.colour.empty()),
        want_colour_(!maps.colour.empty() && volume.has_colour()) {
    for (int axis = 0; axis < 3; ++axis)
      for (int c = 0; c < volume.dim(); ++c) {
        axis_entry_[axis][c] = axis_entry(axis, uint32_t(c));
        axis_step_[axis][c] = axis_step(axis, uint32_t(c));
      }
  }

  // Clears the vertex, normal and colour maps of rows [row_begin, row_end) (all-zero bytes are
  // their "none"): one memset per row instead of three stores per pixel in start().
  void clear_rows(int row_begin, int row_end) const {
    const std::size_t w = std::size_t(intr_.width);
    for (int v = row_begin; v < row_end; ++v) {
      if (want_vertex_) std::memset(static_cast<void*>(maps_.vertex.row(v)), 0, w * sizeof(Vec3f));
      if (want_normal_) std::memset(static_cast<void*>(maps_.normal.row(v)), 0, w * sizeof(Vec3f));
      if (clear_colour_) std::memset(static_cast<void*>(maps_.colour.row(v)), 0, w * sizeof(Rgba8));
    }
  }

  // Reads and clears pixel (u, v)'s depth (`depth` is its depth-map float, which holds the packed
  // bound until here) and sets up its ray; false when there is nothing to march.
  bool start(int u, int v, float& depth, RayState<Real>& r) const {
    const Real zero = real_from_int<Real>(0);
    const Real half = real_from<Real>(0.5f);
    const Real one = real_from_int<Real>(1);
    // This pixel's z range from the marked blocks (raycast_bounds.hpp), read before the clear.
    float near_m = 0.0f, far_m = 0.0f;
    const bool covered = raycast_bounds::read(depth, quant_, near_m, far_m);
    depth = 0.0f;
    if (!covered) return false;
    r.u = u;
    r.v = v;
    // Ray (x, y, 1) in the camera frame: t along it is the z-depth.
    r.rx = (real_from_int<Real>(u) - f_.cx) * f_.fx_inv;
    r.ry = (real_from_int<Real>(v) - f_.cy) * f_.fy_inv;
    Real* gd = r.dir.gd;
    for (int k = 0; k < 3; ++k) gd[k] = (f_.R[k * 3] * r.rx + f_.R[k * 3 + 1] * r.ry + f_.R[k * 3 + 2]) * f_.inv_voxel;
    r.dir.ready = false;
    const Real ray_norm = real_sqrt(r.rx * r.rx + r.ry * r.ry + one);
    r.z_per_m = one / ray_norm;
    r.min_step = half * f_.voxel * r.z_per_m;
    r.nudge = real_from<Real>(1.0f / 64.0f) * f_.voxel * r.z_per_m;
    r.half_trunc = max_r(half * f_.trunc * r.z_per_m, r.min_step);
    r.far_step = max_r((f_.trunc - f_.voxel) * r.z_per_m, r.min_step);
    r.step_per_value = f_.trunc * r.z_per_m;
    if constexpr (std::is_same<Real, float>::value) r.step_per_value *= 1.0f / value_one();
    r.t = max_r(f_.min_z, real_from<Real>(near_m) - margin_);
    r.t_end = min_r(f_.max_z, real_from<Real>(far_m) + margin_);
    // Most ranges lie inside the grid (they come from marked blocks): then the clip, which needs
    // the crossing data (three divisions), would change nothing.
    const bool inside = inside_clip_box(r, r.t) && inside_clip_box(r, r.t_end);
    if (!inside) {
      r.dir.prepare_crossings();
      if (!clip_to_grid(f_, r.dir, r.t, r.t_end)) return false;
    } else if (!(r.t < r.t_end)) {
      return false;
    }
    // Start and stop a little inside the grid: the clip is exact only up to rounding.
    r.t += r.nudge;
    r.t_end -= r.nudge;
    // Ends that were inside the clip box before the nudges stay between those g (g is monotonic
    // in t), so only clipped rays need the proof below.
    if constexpr (std::is_same<Real, float>::value) {
      if (!inside) {
        // The float march reads cells without a bounds test: every sample's t lies in [t, t_end),
        // and g = g0 + t gd, rounded, is monotonic in t, so every sample's g lies between the two
        // ends' g computed here. Both ends inside (-1/2, grid_max - 1/8192) on every axis keep every
        // sample's cell, int(g), in [0, dim - 2] (the margin covers a multiply-add fused at one of
        // the two sites and not at the other: an ulp, 6e-5 at 1024). The clip box leaves 1/2048
        // voxel for this, more than the clip's own rounding; a ray that fails anyway is not marched.
        // (A wider box cut off crossings in the grid's last 1/32 voxel, e.g. of a plane lying
        // there in test_tsdf_analytic.)
        for (int a = 0; a < 3; ++a) {
          const float lo = f_.g0[a] + r.t * gd[a], hi = f_.g0[a] + r.t_end * gd[a];
          if (!(std::min(lo, hi) > -0.5f && std::max(lo, hi) < f_.grid_max - 1.0f / 8192.0f)) return false;
        }
      }
    }
    r.prev_t = zero;
    r.prev_s = zero;
    return true;
  }

  // True when the ray's point at z-depth t lies in the box clip_to_grid clips to.
  bool inside_clip_box(const RayState<Real>& r, Real t) const {
    const Real zero = real_from_int<Real>(0);
    for (int a = 0; a < 3; ++a) {
      const Real g = f_.g0[a] + t * r.dir.gd[a];
      if (!(g > zero && g < f_.clip_max)) return false;
    }
    return true;
  }

  // The trilinear cell with base `cell`, addressed for the march: the pool index of its base
  // voxel and the index offsets to its +x, +y, +z neighbours (inside the brick 1, 8, 64; across a
  // brick face into the neighbour brick's slot), its grid brick, and the axes along which it
  // reaches into the next brick (bit 0 x, 1 y, 2 z). While it crosses at most one face, every
  // corner is the base plus a sum of the offsets (corners on the far side of the face keep their
  // relative place in the neighbour brick); a cell crossing two or three faces (1 in 22 of them)
  // has corners in up to 8 bricks and is addressed corner by corner. A base in the empty brick
  // (slot 0) makes the cell unobserved, so `base` identifies the cell among the observed ones.
  struct CellAddress {
    uint32_t base, dx, dy, dz, brick, local;
    unsigned cross;
    bool additive() const { return (cross & (cross - 1u)) == 0; }
  };
  // The cell's address, without a branch (it is computed for every sample, and 1 sample in 3
  // sits on a brick face along some axis: branches there mispredict). Three table reads give the
  // base voxel's grid brick and its offset in the brick (instead of ~30 instructions of shifts and
  // masks), three more each axis's step to the +1 neighbour: the brick step (0 inside the brick)
  // and the in-brick step (+1 or, from local coordinate 7, -7 on that axis). The index then gives
  // the slots of the base brick and of the brick each +1 neighbour lies in (the base brick's own
  // slot again when it lies inside). The cell must lie in the grid.
  CellAddress address(const int cell[3]) const {
    const uint64_t e = axis_entry_[0][cell[0]] + axis_entry_[1][cell[1]] + axis_entry_[2][cell[2]];
    const uint64_t sx = axis_step_[0][cell[0]], sy = axis_step_[1][cell[1]], sz = axis_step_[2][cell[2]];
    CellAddress a;
    a.brick = uint32_t(e >> 32);
    a.local = uint32_t(e);
    const uint32_t slot_base = slot_[a.brick] << 9;
    a.base = slot_base + a.local;
    a.dx = (slot_[a.brick + uint32_t(sx >> 32)] << 9) - slot_base + uint32_t(sx);
    a.dy = (slot_[a.brick + uint32_t(sy >> 32)] << 9) - slot_base + uint32_t(sy);
    a.dz = (slot_[a.brick + uint32_t(sz >> 32)] << 9) - slot_base + uint32_t(sz);
    a.cross = unsigned(sx >> 32 != 0) | unsigned(sy >> 32 != 0) << 1 | unsigned(sz >> 32 != 0) << 2;
    return a;
  }
  // The step entry of coordinate c on `axis` (see address()): the brick step to c + 1 (high 32
  // bits) and the in-brick step (low 32 bits, modulo 2^32).
  uint64_t axis_step(int axis, uint32_t c) const {
    const uint32_t bricks = axis == 0 ? 1u : (axis == 1 ? nb_ : nb2_);
    const uint32_t unit = 1u << (3 * axis);
    return (c & 7u) == 7u ? uint64_t(bricks) << 32 | uint64_t(uint32_t(0u - 7u * unit)) : uint64_t(unit);
  }
  // The pool index of corner k of a cell crossing several faces (+x for bit 0, +y for bit 1, +z
  // for bit 2): the corner's own brick from the index.
  uint32_t corner_across(const CellAddress& a, unsigned k) const {
    const uint32_t brick_step[3] = {1u, nb_, nb2_};
    uint32_t brick = a.brick, off = a.local;
    for (int axis = 0; axis < 3; ++axis) {
      if (!((k >> axis) & 1u)) continue;
      const uint32_t unit = 1u << (3 * axis);
      if ((a.cross >> axis) & 1u) {
        brick += brick_step[axis];
        off -= 7u * unit;  // local coordinate 7 -> 0 of the next brick
      } else {
        off += unit;
      }
    }
    return (slot_[brick] << 9) + off;
  }
  // The pool index of corner k of the cell.
  uint32_t corner(const CellAddress& a, unsigned k) const {
    if (!a.additive()) return corner_across(a, k);
    return a.base + (k & 1u ? a.dx : 0u) + (k & 2u ? a.dy : 0u) + (k & 4u ? a.dz : 0u);
  }
  // The pool indices of the cell's 8 corners.
  void corners(const CellAddress& a, uint32_t idx[8]) const {
    if (a.additive()) {
      idx[0] = a.base;
      idx[1] = a.base + a.dx;
      idx[2] = a.base + a.dy;
      idx[3] = idx[2] + a.dx;
      idx[4] = a.base + a.dz;
      idx[5] = idx[4] + a.dx;
      idx[6] = idx[4] + a.dy;
      idx[7] = idx[6] + a.dx;
      return;
    }
    for (unsigned k = 0; k < 8; ++k) idx[k] = corner_across(a, k);
  }
  // The pool index of voxel c - 1 along `axis` from voxel c (index idx); c[axis] >= 1.
  uint32_t step_down(uint32_t idx, const int c[3], int axis) const {
    if ((c[axis] & 7) != 0) return idx - (1u << (3 * axis));
    int n[3] = {c[0], c[1], c[2]};
    --n[axis];
    return uint32_t(volume_.index(n[0], n[1], n[2]));
  }
  // The table entry of coordinate c on `axis` (see address()): the coordinate's part of the grid
  // brick index (high 32 bits) and of the offset in the brick (low 32 bits; the three sum below
  // 512, so the 64-bit sum does not carry into the high half).
  uint64_t axis_entry(int axis, uint32_t c) const {
    const uint32_t bricks = axis == 0 ? 1u : (axis == 1 ? nb_ : nb2_);
    return uint64_t((c >> 3) * bricks) << 32 | uint64_t((c & 7u) << (3 * axis));
  }
  // True when the cell with base `cell` lies inside the grid (its +1 corners too).
  bool in_grid(const int cell[3]) const {
    return uint32_t(cell[0]) < last_ && uint32_t(cell[1]) < last_ && uint32_t(cell[2]) < last_;
  }
  // The cell holding grid point g. The march only samples g >= 0 up to rounding (rays are clipped
  // to the grid and nudged inside), so the float build truncates instead of flooring (floor_int's
  // compare and correction were ~8 % of the raycast's instructions). A g rounded to just below 0
  // then samples cell 0 a hair outside it (extrapolating by far less than 1e-3 voxel).
  static int march_cell(Real v) {
    if constexpr (std::is_same<Real, float>::value) {
      return int32_t(v);
    } else {
      return floor_int(v);
    }
  }
  // The march's value of a distance of +trunc: 1 in Q16.16 (fractions of trunc), the stored
  // integers' scale (kTsdfMax + 1) in float (see lerp_cell).
  static Real value_one() {
    if constexpr (std::is_same<Real, float>::value) {
      return 32768.0f;
    } else {
      return real_from_int<Real>(1);
    }
  }
  // Reads the 8 corners of the cell at `a` into `out`.
  const CellCorners<Real>& load_corners(const CellAddress& a, CellCorners<Real>& out) const {
    uint32_t idx[8];
    corners(a, idx);
    const uint32_t i0 = idx[0], i1 = idx[1], i2 = idx[2], i3 = idx[3];
    const uint32_t i4 = idx[4], i5 = idx[5], i6 = idx[6], i7 = idx[7];
    out.base = a.base;
    if constexpr (std::is_same<Real, float>::value) {
      using namespace cell_lanes;
      // The 4 x-pairs (corner 2j, 2j + 1) as 32-bit lanes, low half the first (little endian:
      // x86-64, aarch64, armhf). Inside a brick the pair is adjacent in memory: one load.
      I4 pairs;
      if ((a.cross & 1u) == 0) {
        int32_t w0, w1, w2, w3;
        std::memcpy(&w0, tsdf_ + i0, 4);
        std::memcpy(&w1, tsdf_ + i2, 4);
        std::memcpy(&w2, tsdf_ + i4, 4);
        std::memcpy(&w3, tsdf_ + i6, 4);
        pairs = I4{w0, w1, w2, w3};
      } else {
        const uint16_t* t = reinterpret_cast<const uint16_t*>(tsdf_);
        pairs = I4{int32_t(uint32_t(t[i0]) | uint32_t(t[i1]) << 16), int32_t(uint32_t(t[i2]) | uint32_t(t[i3]) << 16),
                   int32_t(uint32_t(t[i4]) | uint32_t(t[i5]) << 16), int32_t(uint32_t(t[i6]) | uint32_t(t[i7]) << 16)};
      }
      // kTsdfUnobserved in any of the 8 int16 lanes: one compare, the 16 mask bytes ORed.
      const S8 unobserved = S8(pairs) == S8{kTsdfUnobserved, kTsdfUnobserved, kTsdfUnobserved, kTsdfUnobserved,
                                    kTsdfUnobserved, kTsdfUnobserved, kTsdfUnobserved, kTsdfUnobserved};
      const U2 m = U2(unobserved);
      out.observed = (m[0] | m[1]) == 0;
      if (out.observed) {
        out.x0 = __builtin_convertvector((pairs << 16) >> 16, F4);  // even corners, sign-extended
        out.x1 = __builtin_convertvector(pairs >> 16, F4);          // odd corners
      }
    } else {
      const int16_t q[8] = {tsdf_[i0], tsdf_[i1], tsdf_[i2], tsdf_[i3], tsdf_[i4], tsdf_[i5], tsdf_[i6], tsdf_[i7]};
      // kTsdfUnobserved is the smallest int16: one test on the minimum.
      int16_t lowest = q[0];
      for (int i = 1; i < 8; ++i) lowest = q[i] < lowest ? q[i] : lowest;
      out.observed = lowest != kTsdfUnobserved;
      if (out.observed)
        for (int i = 0; i < 8; ++i) out.c[i] = tsdf_fraction(Real(), q[i]);
    }
    return out;
  }
  // Trilinear TSDF of an observed cell at offsets fx, fy, fz, in the march's value unit
  // (value_one() per truncation): TsdfSampler::sample's interpolation (in float as a weighted sum
  // of the corners, equal to the nested lerps up to rounding). The float build works on
  // the stored integers and never scales them: the march needs only signs, ratios of values
  // (regula falsi) and the step per value unit, so the scaling (by a power of two, which commutes
  // exactly with the lerps) would only lengthen every sample's dependency chain.
  static Real lerp_cell(const CellCorners<Real>& k, Real fx, Real fy, Real fz) {
    if constexpr (std::is_same<Real, float>::value) {
      using namespace cell_lanes;
      // As the sum of the 8 corners times their weights: the weights depend only on the position,
      // which is known long before the corners arrive from memory, so only two multiplications,
      // an addition and the sum over the lanes wait for them (the nested lerps chained nine
      // operations after the loads; every sample's step waits for this value).
      const float gx = 1.0f - fx, gy = 1.0f - fy, gz = 1.0f - fz;
      const F4 wyz = F4{gy * gz, fy * gz, gy * fz, fy * fz};  // lanes: corner pairs (y, z) = 00, 10, 01, 11
      const F4 v = k.x0 * (wyz * gx) + k.x1 * (wyz * fx);
      const F4 h = v + __builtin_shufflevector(v, v, 2, 3, 0, 1);
      return h[0] + h[1];
    } else {
      const Real* c = k.c;
      const Real c00 = c[0] + (c[1] - c[0]) * fx, c10 = c[2] + (c[3] - c[2]) * fx;
      const Real c01 = c[4] + (c[5] - c[4]) * fx, c11 = c[6] + (c[7] - c[6]) * fx;
      const Real c0 = c00 + (c10 - c00) * fy, c1 = c01 + (c11 - c01) * fy;
      return c0 + (c1 - c0) * fz;
    }
  }
  // Trilinear TSDF at grid point g (refinement samples); false when a corner is unobserved.
  // `known` is a cell already read: reused when g falls into it.
  bool sample(const Real g[3], const CellCorners<Real>& known, Real& out) const {
    const int cell[3] = {march_cell(g[0]), march_cell(g[1]), march_cell(g[2])};
    if (!in_grid(cell)) return false;
    const CellAddress a = address(cell);
    CellCorners<Real> read;
    const CellCorners<Real>* k = a.base == known.base ? &known : &load_corners(a, read);
    if (!k->observed) return false;
    out = lerp_cell(*k, g[0] - real_from_int<Real>(cell[0]), g[1] - real_from_int<Real>(cell[1]),
                    g[2] - real_from_int<Real>(cell[2]));
    return true;
  }

  // The zero crossing between the last sample (prev_t, prev_s > 0) and this one (t, s <= 0, in
  // cell k): regula falsi on the trilinear field.
  Real refine(const RayState<Real>& r, const CellCorners<Real>& k, Real s) const {
    const Real zero = real_from_int<Real>(0);
    const Real* gd = r.dir.gd;
    Real ta = r.prev_t, sa = r.prev_s, tb = r.t, sb = s;
    for (int it = 0; it < 3; ++it) {
      const Real tm = ta + (tb - ta) * (sa / (sa - sb));
      const Real gm[3] = {f_.g0[0] + tm * gd[0], f_.g0[1] + tm * gd[1], f_.g0[2] + tm * gd[2]};
      Real sm;
      if (!sample(gm, k, sm)) break;
      if constexpr (std::is_same<Real, float>::value) {
        // Done when the next secant correction, |sm| / slope, is under 1/200 voxel (on a plane
        // the first secant lands on the surface; the remaining iterations would only repeat it).
        // Q16.16 cannot resolve that bound at millimetre voxels, so the fixed-point build
        // always iterates.
        if (abs_r(sm) * (tb - ta) < real_from<Real>(0.01f) * r.min_step * (sa - sb)) return tm;
      }
      if (sm > zero) {
        ta = tm;
        sa = sm;
      } else {
        tb = tm;
        sb = sm;
      }
    }
    return sa > sb ? ta + (tb - ta) * (sa / (sa - sb)) : ta;
  }

  // One sample of the march (or the refinement of a crossing, which ends it).
  MarchResult step(RayState<Real>& r, Real& t_hit) const {
    const Real zero = real_from_int<Real>(0);
    const Real half = real_from<Real>(0.5f);
    if (!(r.t < r.t_end)) return MarchResult::kMiss;
    const Real* gd = r.dir.gd;
    const Real g[3] = {f_.g0[0] + r.t * gd[0], f_.g0[1] + r.t * gd[1], f_.g0[2] + r.t * gd[2]};
    const int cell[3] = {march_cell(g[0]), march_cell(g[1]), march_cell(g[2])};
    // The float build proved every sample's cell inside the grid in start().
    if (!std::is_same<Real, float>::value && !in_grid(cell)) return MarchResult::kMiss;
    const CellAddress a = address(cell);
    const uint8_t bf = flags_[a.brick];
    if ((bf & (kBrickNearSurface | kBrickObserved)) != (kBrickNearSurface | kBrickObserved)) {
      // No surface in or next to this brick, or nothing observed in it (then every cell based
      // here has an unobserved corner): leave it whole.
      // A ray grazing a brick face can sit exactly on it: when the nudge is lost to rounding
      // (the exit is where we are), move on by half a voxel so the march always advances.
      int axis;
      const Real t_next = brick_exit(f_, crossings(r), cell, axis) + r.nudge;
      r.t = t_next > r.t + r.nudge ? t_next : r.t + r.min_step;
      r.prev_s = zero;
      return MarchResult::kGoing;
    }
    if (!(bf & kBrickSurface)) {
      // Surface next door but none here: only the last cell before the exit face, which
      // reaches into the next brick, can hold a crossing. Go to one voxel before that face.
      int axis;
      const Real t_exit = brick_exit(f_, crossings(r), cell, axis);
      const Real t_last_cell = t_exit - r.dir.last_cell[axis];
      if (t_last_cell > r.t + r.min_step) {
        r.t = t_last_cell;
        r.prev_s = zero;
        return MarchResult::kGoing;
      }
    }
    // The nearest voxel first (2 loads instead of 16): unobserved or truncated at +1, the
    // trilinear value cannot hold a crossing within the step taken below.
    const Real fx = g[0] - real_from_int<Real>(cell[0]);
    const Real fy = g[1] - real_from_int<Real>(cell[1]);
    const Real fz = g[2] - real_from_int<Real>(cell[2]);
    const uint32_t ni = corner(a, unsigned(!(fx < half)) | unsigned(!(fy < half)) << 1 | unsigned(!(fz < half)) << 2);
    const int16_t nq = tsdf_[ni];
    if (nq == kTsdfUnobserved) {
      // An unobserved corner: no surface can be here. A surface seen from this side has its
      // positive band (at least trunc deep along any ray) observed, so half a truncation lands
      // in that band before its zero crossing, never beyond it.
      r.t += r.half_trunc;
      r.prev_s = zero;
      return MarchResult::kGoing;
    }
    if (nq == kTsdfMax) {
      r.prev_t = r.t;  // a +1 sample: the crossing, if next, lies between here and there
      r.prev_s = value_one();
      r.t += r.far_step;
      return MarchResult::kGoing;
    }
    CellCorners<Real> k;
    load_corners(a, k);
    if (!k.observed) {
      r.t += r.half_trunc;  // another corner is unobserved: as above
      r.prev_s = zero;
      return MarchResult::kGoing;
    }
    const Real s = lerp_cell(k, fx, fy, fz);
    // One branch for both conditions (bitwise &): which sample ends the march is unpredictable.
    if ((r.prev_s > zero) & !(s > zero)) {
      t_hit = refine(r, k, s);
      return MarchResult::kHit;
    }
    r.prev_t = r.t;
    r.prev_s = s;
    // Step by the distance itself (the projective TSDF bounds the distance to the surface).
    r.t += max_r(abs_r(s) * r.step_per_value, r.min_step);
    return MarchResult::kGoing;
  }

  // The ray's direction with its crossing data (computed on the first brick skip).
  static const RayDir<Real>& crossings(RayState<Real>& r) {
    if (!r.dir.ready) r.dir.prepare_crossings();
    return r.dir;
  }

  // Writes the outputs of a ray that hit the surface at z-depth t_hit.
  void finish_hit(const RayState<Real>& r, Real t_hit) const {
    const int u = r.u, v = r.v;
    const float z = to_float(t_hit);
    const Vec3f ray(to_float(r.rx), to_float(r.ry), 1.0f);
    maps_.depth_m.at(u, v) = z;
    if (want_vertex_) maps_.vertex.at(u, v) = ray * z;
    const Real* gd = r.dir.gd;
    const Real gh[3] = {f_.g0[0] + t_hit * gd[0], f_.g0[1] + t_hit * gd[1], f_.g0[2] + t_hit * gd[2]};
    if (want_normal_) {
      float grad[3];
      if (gradient(gh, grad)) {
        const Vec3f n_world(grad[0], grad[1], grad[2]);
        const float len = n_world.norm();
        if (len > 0.0f) {
          Vec3f n = T_world_cam_.R.transpose() * (n_world / len);
          if (n.dot(ray) > 0.0f) n = -n;  // face the sensor
          maps_.normal.at(u, v) = n;
        }
      }
    }
    if (want_colour_) maps_.colour.at(u, v) = colour(gh);
  }

  // TsdfSampler::gradient (central differences of the 6 voxels around the voxel nearest to g;
  // false at an unobserved or truncated neighbour) with the neighbours addressed from the centre
  // voxel's index and the address tables' +1 steps instead of 6 full index computations: the
  // same voxels, the same result.
  bool gradient(const Real g[3], float grad[3]) const {
    const Real half = real_from<Real>(0.5f);
    // A hit lies inside the grid (g > -1/2): march_cell floors g + 1/2 there.
    const int c[3] = {march_cell(g[0] + half), march_cell(g[1] + half), march_cell(g[2] + half)};
    const int last = int(last_);
    if (c[0] < 1 || c[1] < 1 || c[2] < 1 || c[0] >= last || c[1] >= last || c[2] >= last) return false;
    const CellAddress centre = address(c);  // its corners 1, 2, 4 are c's +1 neighbours
    int16_t q[6];
    for (int a = 0; a < 3; ++a) {
      q[2 * a] = tsdf_[step_down(centre.base, c, a)];
      q[2 * a + 1] = tsdf_[corner(centre, 1u << a)];
    }
    // Unobserved (-32768) or truncated (+-32767) neighbours: x + 32766 (mod 2^16) lands at
    // 65533 or above exactly for those three values. One branch for all six.
    bool usable = true;
    for (int k = 0; k < 6; ++k) usable &= uint16_t(q[k] + 32766) < 65533u;
    if (!usable) return false;
    for (int a = 0; a < 3; ++a) grad[a] = float(int32_t(q[2 * a + 1]) - int32_t(q[2 * a]));
    return true;
  }

  // TsdfSampler::colour (blend_corner_colours) with the corners addressed like the march's cells.
  Rgba8 colour(const Real g[3]) const {
    Rgba8 out;
    const int cell[3] = {floor_int(g[0]), floor_int(g[1]), floor_int(g[2])};
    if (!in_grid(cell)) return out;
    const CellAddress a = address(cell);
    uint32_t idx[8];
    corners(a, idx);
    const float f[3] = {to_float(g[0] - real_from_int<Real>(cell[0])), to_float(g[1] - real_from_int<Real>(cell[1])),
                        to_float(g[2] - real_from_int<Real>(cell[2]))};
    return blend_corner_colours(colour_, colour_weight_, idx, f);
  }

 private:
  const TsdfVolume& volume_;
  const PinholeIntrinsics& intr_;
  const Pose& T_world_cam_;
  const RaycastMaps& maps_;
  const RayFrame<Real> f_;
  const uint8_t* flags_;
  const int16_t* tsdf_;
  const Rgb8* colour_;
  const uint8_t* colour_weight_;
  const raycast_bounds::Quant quant_;
  const uint32_t last_, nb_, nb2_;
  const uint32_t* slot_;  // the volume's brick index (pool slot per grid brick)
  const Real margin_;
  const bool want_vertex_, want_normal_, clear_colour_, want_colour_;
  uint64_t axis_entry_[3][kRaycastDimMax];  // address() per coordinate (24 KiB of stack)
  uint64_t axis_step_[3][kRaycastDimMax];   // address()'s +1 steps per coordinate (24 KiB of stack)
};

// Pixels are marched tile column by tile column (8 columns of the given rows at a time), so that
// neighbouring rays, which read the same voxels, follow each other while those voxels are still
// cached.
constexpr int kColumnStrip = 8;

}  // namespace

template <class Real>
void raycast_rows(const TsdfVolume& volume, const PinholeIntrinsics& intr, const Pose& T_world_cam,
                  const RaycastMaps& maps, int row_begin, int row_end) {
  if (row_begin >= row_end || volume.dim() > kRaycastDimMax) return;  // prepare_raycast refused it
  const RayMarcher<Real> marcher(volume, intr, T_world_cam, maps);
  marcher.clear_rows(row_begin, row_end);
  RayState<Real> ray;
  for (int u0 = 0; u0 < intr.width; u0 += kColumnStrip) {
    const int u1 = std::min(u0 + kColumnStrip, intr.width);
    for (int v = row_begin; v < row_end; ++v) {
      float* depth_row = maps.depth_m.row(v);
      for (int u = u0; u < u1; ++u) {
        if (!marcher.start(u, v, depth_row[u], ray)) continue;
        Real t_hit;
        MarchResult res;
        do {
          res = marcher.step(ray, t_hit);
        } while (res == MarchResult::kGoing);
        if (res == MarchResult::kHit) marcher.finish_hit(ray, t_hit);
      }
    }
  }
}

template <class Real>
Status raycast(const TsdfVolume& volume, const PinholeIntrinsics& intr, const Pose& T_world_cam,
               const RaycastMaps& maps) {
  const Status s = prepare_raycast(volume, intr, T_world_cam, maps);
  if (s != Status::kOk) return s;
  raycast_rows<Real>(volume, intr, T_world_cam, maps, 0, intr.height);
  return Status::kOk;
}

#define EDGEFUSE_INSTANTIATE(Real)                                                                                 \
  template bool sample_tsdf<Real>(const TsdfVolume&, const Vec3f&, float&);                                       \
  template void raycast_rows<Real>(const TsdfVolume&, const PinholeIntrinsics&, const Pose&, const RaycastMaps&, int, \
                                   int);                                                                          \
  template Status raycast<Real>(const TsdfVolume&, const PinholeIntrinsics&, const Pose&, const RaycastMaps&);
EDGEFUSE_INSTANTIATE(float)
EDGEFUSE_INSTANTIATE(Fixed)
#undef EDGEFUSE_INSTANTIATE

}  // namespace edgefuse
