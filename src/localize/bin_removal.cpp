// The bin: the dominant plane (floor) by RANSAC with a fixed-seed generator, then up to four walls
// (planes containing the floor normal that have almost all floor points on one side), and removal
// of every point on, below or outside them.
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

#include "edgefuse/localize/localizer.hpp"

namespace edgefuse {
namespace {

struct Lcg {  // deterministic: results must not depend on time or run
  uint32_t s = 12345u;
  uint32_t next(uint32_t n) {
    s = s * 1664525u + 1013904223u;
    return uint32_t((uint64_t(s >> 8) * n) >> 24);
  }
};

struct Plane {
  Vec3f n = Vec3f(0, 0, 1);
  float d = 0;
  float dist(const Vec3f& p) const { return n.dot(p) + d; }
};

//! Least-squares plane through the points within tol of `pl` (normals compatible).
Plane refit(const ScenePoint* pts, std::size_t count, const Plane& pl, float tol, float min_dot) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  std::size_t n = 0;
  for (std::size_t i = 0; i < count; ++i)
    if (std::fabs(pl.dist(pts[i].p)) < tol && std::fabs(pl.n.dot(pts[i].n)) > min_dot) {
      mean += pts[i].p.cast<double>();
      ++n;
    }
  if (n < 3) return pl;
  mean /= double(n);
  for (std::size_t i = 0; i < count; ++i)
    if (std::fabs(pl.dist(pts[i].p)) < tol && std::fabs(pl.n.dot(pts[i].n)) > min_dot) {
      const Eigen::Vector3d q = pts[i].p.cast<double>() - mean;
      cov += q * q.transpose();
    }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
  Vec3f nn = es.eigenvectors().col(0).cast<float>().normalized();
  if (nn.dot(pl.n) < 0) nn = -nn;
  Plane out;
  out.n = nn;
  out.d = -nn.dot(mean.cast<float>());
  return out;
}

//! The dominant plane (the floor) by RANSAC: triples whose normals agree with their plane, scored
//! by the inliers in the strided subset. \return the inlier count of `best` (0: none scored)
std::size_t dominant_plane(const ScenePoint* pts, std::size_t n, std::size_t stride, float tol, Lcg& rng,
                           Plane& best) {
  std::size_t best_count = 0;
  // 200 draws of three points; a triple is scored only when the normals agree with its plane.
  // Where no dominant plane came out of those, drawing goes on (up to 20000 draws or 400 scored
  // planes): with the floor a fifth of the surface (a fused xtion + tof + laser map of bin_rig_a:
  // 19 %) a floor triple comes up 1.4 times per 200 draws on average, and in about a quarter of
  // the maps never (edgefused's live map of the three sensors: "floor not found", walls matched).
  // A map whose floor the first 200 draws find stops there, as the dominant-plane check allows.
  int scored = 0;
  for (int draw = 0; draw < 20000 && scored < 400; ++draw) {
    if (draw >= 200 && best_count * stride >= n / 10) break;
    const ScenePoint& a = pts[rng.next(uint32_t(n))];
    const ScenePoint& b = pts[rng.next(uint32_t(n))];
    const ScenePoint& c = pts[rng.next(uint32_t(n))];
    Vec3f nn = (b.p - a.p).cross(c.p - a.p);
    const float len = nn.norm();
    if (!(len > 1e-9f)) continue;
    nn /= len;
    if (std::fabs(nn.dot(a.n)) < 0.9f || std::fabs(nn.dot(b.n)) < 0.9f || std::fabs(nn.dot(c.n)) < 0.9f) continue;
    ++scored;
    Plane pl{nn, -nn.dot(a.p)};
    std::size_t cnt = 0;
    for (std::size_t i = 0; i < n; i += stride)
      if (std::fabs(pl.dist(pts[i].p)) < tol && std::fabs(nn.dot(pts[i].n)) > 0.9f) ++cnt;
    if (cnt > best_count) {
      best_count = cnt;
      best = pl;
    }
  }
  return best_count;
}

//! The best of 300 vertical planes (containing ctx.up) through two points off the floor that is not
//! one of ctx's walls already. \return the inlier count of `wall` in the strided subset
std::size_t best_wall_plane(const ScenePoint* pts, std::size_t n, std::size_t stride, const Plane& floor_plane,
                            const SceneContext& ctx, const LocalizeParams& params, Lcg& rng, Plane& wall) {
  std::size_t wcount = 0;
  for (int it = 0; it < 300; ++it) {
    const ScenePoint& a = pts[rng.next(uint32_t(n))];
    const ScenePoint& b = pts[rng.next(uint32_t(n))];
    if (std::fabs(floor_plane.dist(a.p)) < params.floor_tol_m || std::fabs(floor_plane.dist(b.p)) < params.floor_tol_m)
      continue;
    Vec3f nn = (b.p - a.p).cross(ctx.up);
    const float len = nn.norm();
    if (!(len > 0.02f)) continue;  // points at least 2 cm apart horizontally
    nn /= len;
    if (std::fabs(nn.dot(a.n)) < 0.8f || std::fabs(nn.dot(b.n)) < 0.8f) continue;
    Plane pl{nn, -nn.dot(a.p)};
    bool known = false;
    for (int k = 0; k < ctx.walls; ++k)
      known = known ||
              (std::fabs(ctx.wall_n[k].dot(nn)) > 0.9f && std::fabs(ctx.wall_n[k].dot(a.p) + ctx.wall_d[k]) < 0.02f);
    if (known) continue;
    std::size_t cnt = 0;
    for (std::size_t i = 0; i < n; i += stride)
      if (std::fabs(pl.dist(pts[i].p)) < params.wall_tol_m && std::fabs(nn.dot(pts[i].n)) > 0.8f) ++cnt;
    if (cnt > wcount) {
      wcount = cnt;
      wall = pl;
    }
  }
  return wcount;
}

//! A wall has (almost) all floor points on one side: counts them on each side and turns the wall's
//! normal towards them. \return false when the floor lies on both sides (an object face, not a wall)
bool wall_faces_floor(const ScenePoint* pts, std::size_t n, std::size_t stride, const Plane& floor_plane,
                      const LocalizeParams& params, Plane& wall) {
  std::size_t pos = 0, neg = 0;
  for (std::size_t i = 0; i < n; i += stride)
    if (std::fabs(floor_plane.dist(pts[i].p)) < params.floor_tol_m) {
      const float s = wall.dist(pts[i].p);
      if (s > params.wall_tol_m) ++pos;
      else if (s < -params.wall_tol_m) ++neg;
    }
  const std::size_t lo = pos < neg ? pos : neg, hi = pos < neg ? neg : pos;
  if (hi == 0 || float(lo) > 0.03f * float(hi)) return false;
  if (neg > pos) {
    wall.n = -wall.n;
    wall.d = -wall.d;
  }
  return true;
}

//! Up to four walls into ctx (inward normals): vertical planes on the floor's boundary, drawn from
//! the same generator as the floor.
void detect_walls(const ScenePoint* pts, std::size_t n, std::size_t stride, const Plane& floor_plane,
                  const LocalizeParams& params, Lcg& rng, SceneContext& ctx) {
  for (int w = 0; w < 4; ++w) {
    Plane wall;
    const std::size_t count = best_wall_plane(pts, n, stride, floor_plane, ctx, params, rng, wall);
    if (float(count * stride) < params.wall_min_share * float(n)) break;
    if (!wall_faces_floor(pts, n, stride, floor_plane, params, wall)) break;
    ctx.wall_n[ctx.walls] = wall.n;
    ctx.wall_d[ctx.walls] = wall.d;
    ++ctx.walls;
  }
}

//! A floor point: near the plane, its normal along the plane's.
inline bool on_floor(const ScenePoint& s, const Plane& floor_plane, float tol) {
  return std::fabs(floor_plane.dist(s.p)) < tol && std::fabs(floor_plane.n.dot(s.n)) > 0.9f;
}

//! Mean and scatter matrix of the floor points in the strided subset.
void floor_moments(const ScenePoint* pts, std::size_t n, std::size_t stride, const Plane& floor_plane, float tol,
                   Eigen::Vector3d& mean, Eigen::Matrix3d& scatter) {
  mean = Eigen::Vector3d::Zero();
  scatter = Eigen::Matrix3d::Zero();
  std::size_t count = 0;
  for (std::size_t i = 0; i < n; i += stride)
    if (on_floor(pts[i], floor_plane, tol)) {
      mean += pts[i].p.cast<double>();
      ++count;
    }
  mean /= double(count);
  for (std::size_t i = 0; i < n; i += stride)
    if (on_floor(pts[i], floor_plane, tol)) {
      const Eigen::Vector3d q = pts[i].p.cast<double>() - mean;
      scatter += q * q.transpose();
    }
}

//! The floor's in-plane axes: the principal axes of its points, or, with walls, the first wall's
//! normal and its turn about `up` (a bin is a box: its walls give the axes exactly, PCA of a
//! half-hidden floor does not).
void floor_axes(const Eigen::Matrix3d& scatter, const SceneContext& ctx, Vec3f& e1, Vec3f& e2) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(scatter);
  e1 = es.eigenvectors().col(2).cast<float>();
  e2 = es.eigenvectors().col(1).cast<float>();
  if (ctx.walls > 0) {
    e1 = (ctx.wall_n[0] - ctx.up * ctx.wall_n[0].dot(ctx.up)).normalized();
    e2 = ctx.up.cross(e1);
  }
}

constexpr int kExtentBins = 2048;  // 1 mm bins over +-1.024 m around the floor centre

//! [lo, hi] of a 1 mm histogram after dropping `drop` counts from each end.
void trimmed_extent(const uint32_t* h, std::size_t drop, float& lo, float& hi) {
  std::size_t acc = 0;
  int b = 0;
  for (; b < kExtentBins && acc + h[b] <= drop; ++b) acc += h[b];
  lo = float(b - kExtentBins / 2) * 0.001f;
  acc = 0;
  for (b = kExtentBins - 1; b >= 0 && acc + h[b] <= drop; --b) acc += h[b];
  hi = float(b + 1 - kExtentBins / 2) * 0.001f;
}

//! The floor's extent along e1, e2 around `centre`: the extremes after dropping the outermost
//! 0.2 % of its points, from a coarse 1 mm-bin count over +-1 m (static and small; two passes of
//! "largest k" would need sorting).
void floor_extent(const ScenePoint* pts, std::size_t n, std::size_t stride, const Plane& floor_plane, float tol,
                  const Vec3f& centre, const Vec3f& e1, const Vec3f& e2, float lo[2], float hi[2]) {
  uint32_t h1[kExtentBins] = {}, h2[kExtentBins] = {};
  std::size_t tot = 0;
  for (std::size_t i = 0; i < n; i += stride)
    if (on_floor(pts[i], floor_plane, tol)) {
      const Vec3f q = pts[i].p - centre;
      const int b1 = std::min(kExtentBins - 1, std::max(0, int(q.dot(e1) * 1000.0f) + kExtentBins / 2));
      const int b2 = std::min(kExtentBins - 1, std::max(0, int(q.dot(e2) * 1000.0f) + kExtentBins / 2));
      ++h1[b1];
      ++h2[b2];
      ++tot;
    }
  const std::size_t drop = tot / 500;
  trimmed_extent(h1, drop, lo[0], hi[0]);
  trimmed_extent(h2, drop, lo[1], hi[1]);
}

}  // namespace

Status Localizer::remove_bin(const LocalizeParams& params) {
  if (!b_.scene) return Status::kNotInitialised;
  const std::size_t n = scene_count_;
  if (n < 100) return Status::kOk;
  const ScenePoint* pts = b_.scene;
  const std::size_t stride = n > 20000 ? n / 20000 : 1;  // inlier counts on an even subset
  Lcg rng;
  // --- floor: the plane with the most inliers whose normals agree
  Plane floor_plane;
  const std::size_t floor_count = dominant_plane(pts, n, stride, params.floor_tol_m, rng, floor_plane);
  if (floor_count * stride < n / 10) return Status::kOk;  // no dominant plane: nothing removed
  floor_plane = refit(pts, n, floor_plane, params.floor_tol_m, 0.9f);
  if (floor_plane.dist(ctx_.viewpoint_m) < 0) {  // up = towards the sensor
    floor_plane.n = -floor_plane.n;
    floor_plane.d = -floor_plane.d;
  }
  ctx_.up = floor_plane.n;
  ctx_.floor_offset = floor_plane.d;
  ctx_.has_floor = true;
  ctx_.walls = 0;
  // --- walls: vertical planes (containing `up`) through two points, on the floor's boundary
  if (params.detect_walls) detect_walls(pts, n, stride, floor_plane, params, rng, ctx_);
  // --- the floor's extent along its axes: anything beyond it (rims, outer walls, the cell around
  // the bin) is not in the bin. Robust bounds: 0.2 % of the floor points may lie outside.
  Eigen::Vector3d mean;
  Eigen::Matrix3d scatter;
  floor_moments(pts, n, stride, floor_plane, params.floor_tol_m, mean, scatter);
  const Vec3f centre = mean.cast<float>();
  Vec3f e1, e2;
  floor_axes(scatter, ctx_, e1, e2);
  floor_extent(pts, n, stride, floor_plane, params.floor_tol_m, centre, e1, e2, ctx_.floor_lo, ctx_.floor_hi);
  ctx_.floor_centre_m = centre;
  ctx_.floor_axis[0] = e1;
  ctx_.floor_axis[1] = e2;
  remove_bin_points(params);
  return Status::kOk;
}

void Localizer::remove_bin_points(const LocalizeParams& params) {
  // In place, order kept.
  std::size_t out = 0;
  const Vec3f& fcen = ctx_.floor_centre_m;
  const Vec3f& e1 = ctx_.floor_axis[0];
  const Vec3f& e2 = ctx_.floor_axis[1];
  for (std::size_t i = 0; i < scene_count_; ++i) {
    const Vec3f& p = b_.scene[i].p;
    bool keep = ctx_.up.dot(p) + ctx_.floor_offset > params.floor_tol_m;
    for (int k = 0; k < ctx_.walls && keep; ++k) keep = ctx_.wall_n[k].dot(p) + ctx_.wall_d[k] > params.wall_tol_m;
    if (keep && params.crop_to_floor) {
      const float a = (p - fcen).dot(e1), b = (p - fcen).dot(e2);
      keep = a > ctx_.floor_lo[0] + params.wall_tol_m && a < ctx_.floor_hi[0] - params.wall_tol_m &&
             b > ctx_.floor_lo[1] + params.wall_tol_m && b < ctx_.floor_hi[1] - params.wall_tol_m;
    }
    if (keep) b_.scene[out++] = b_.scene[i];
  }
  scene_count_ = out;
  build_grid(grid_cell_m_);
}

Status Localizer::set_bin(const BinGeometry& bin, const LocalizeParams& params) {
  if (!b_.scene) return Status::kNotInitialised;
  const Pose& T = bin.T_world_bin;
  if (!T.t.allFinite() || !T.R.allFinite() || !(bin.inner_x_m > 0) || !(bin.inner_y_m > 0))
    return Status::kInvalidArgument;
  const Vec3f ex = T.R.col(0), ey = T.R.col(1), ez = T.R.col(2);
  ctx_.up = ez;
  ctx_.floor_offset = -ez.dot(T.t);
  ctx_.has_floor = true;
  // Walls: inward normals, through the inner faces at +-half the inner size.
  const float hx = 0.5f * bin.inner_x_m, hy = 0.5f * bin.inner_y_m;
  const Vec3f n[4] = {ex, -ex, ey, -ey};
  const float h[4] = {hx, hx, hy, hy};
  for (int k = 0; k < 4; ++k) {
    ctx_.wall_n[k] = n[k];
    ctx_.wall_d[k] = h[k] - n[k].dot(T.t);  // n.p + d = 0 at p = t - n h
  }
  ctx_.walls = 4;
  ctx_.floor_centre_m = T.t;
  ctx_.floor_axis[0] = ex;
  ctx_.floor_axis[1] = ey;
  ctx_.floor_lo[0] = -hx;
  ctx_.floor_hi[0] = hx;
  ctx_.floor_lo[1] = -hy;
  ctx_.floor_hi[1] = hy;
  remove_bin_points(params);
  return Status::kOk;
}

}  // namespace edgefuse
