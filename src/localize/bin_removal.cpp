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

}  // namespace

Status Localizer::remove_bin(const LocalizeParams& params) {
  if (!b_.scene) return Status::kNotInitialised;
  const std::size_t n = scene_count_;
  if (n < 100) return Status::kOk;
  const ScenePoint* pts = b_.scene;
  const std::size_t stride = n > 20000 ? n / 20000 : 1;  // inlier counts on an even subset
  Lcg rng;
  // --- floor: the plane with the most inliers whose normals agree
  Plane best;
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
      if (std::fabs(pl.dist(pts[i].p)) < params.floor_tol_m && std::fabs(nn.dot(pts[i].n)) > 0.9f) ++cnt;
    if (cnt > best_count) {
      best_count = cnt;
      best = pl;
    }
  }
  if (best_count * stride < n / 10) return Status::kOk;  // no dominant plane: nothing removed
  best = refit(pts, n, best, params.floor_tol_m, 0.9f);
  if (best.dist(ctx_.viewpoint_m) < 0) {  // up = towards the sensor
    best.n = -best.n;
    best.d = -best.d;
  }
  ctx_.up = best.n;
  ctx_.floor_offset = best.d;
  ctx_.has_floor = true;
  ctx_.walls = 0;
  // --- walls: vertical planes (containing `up`) through two points, on the floor's boundary
  if (params.detect_walls) {
    for (int w = 0; w < 4; ++w) {
      Plane wb;
      std::size_t wcount = 0;
      for (int it = 0; it < 300; ++it) {
        const ScenePoint& a = pts[rng.next(uint32_t(n))];
        const ScenePoint& b = pts[rng.next(uint32_t(n))];
        if (std::fabs(best.dist(a.p)) < params.floor_tol_m || std::fabs(best.dist(b.p)) < params.floor_tol_m) continue;
        Vec3f nn = (b.p - a.p).cross(ctx_.up);
        const float len = nn.norm();
        if (!(len > 0.02f)) continue;  // points at least 2 cm apart horizontally
        nn /= len;
        if (std::fabs(nn.dot(a.n)) < 0.8f || std::fabs(nn.dot(b.n)) < 0.8f) continue;
        Plane pl{nn, -nn.dot(a.p)};
        bool known = false;
        for (int k = 0; k < ctx_.walls; ++k)
          known = known || (std::fabs(ctx_.wall_n[k].dot(nn)) > 0.9f && std::fabs(ctx_.wall_n[k].dot(a.p) + ctx_.wall_d[k]) < 0.02f);
        if (known) continue;
        std::size_t cnt = 0;
        for (std::size_t i = 0; i < n; i += stride)
          if (std::fabs(pl.dist(pts[i].p)) < params.wall_tol_m && std::fabs(nn.dot(pts[i].n)) > 0.8f) ++cnt;
        if (cnt > wcount) {
          wcount = cnt;
          wb = pl;
        }
      }
      if (float(wcount * stride) < params.wall_min_share * float(n)) break;
      // The floor must lie on one side: count floor points on each side.
      std::size_t pos = 0, neg = 0;
      for (std::size_t i = 0; i < n; i += stride)
        if (std::fabs(best.dist(pts[i].p)) < params.floor_tol_m) {
          const float s = wb.dist(pts[i].p);
          if (s > params.wall_tol_m) ++pos;
          else if (s < -params.wall_tol_m) ++neg;
        }
      const std::size_t lo = pos < neg ? pos : neg, hi = pos < neg ? neg : pos;
      if (hi == 0 || float(lo) > 0.03f * float(hi)) break;  // floor on both sides: an object face, not a wall
      if (neg > pos) {
        wb.n = -wb.n;
        wb.d = -wb.d;
      }
      ctx_.wall_n[ctx_.walls] = wb.n;
      ctx_.wall_d[ctx_.walls] = wb.d;
      ++ctx_.walls;
    }
  }
  // --- the floor's extent along its principal axes: anything beyond it (rims, outer walls, the
  // cell around the bin) is not in the bin. Robust bounds: 0.2 % of the floor points may lie outside.
  Eigen::Vector3d fm = Eigen::Vector3d::Zero();
  Eigen::Matrix3d fc = Eigen::Matrix3d::Zero();
  std::size_t fn = 0;
  for (std::size_t i = 0; i < n; i += stride)
    if (std::fabs(best.dist(pts[i].p)) < params.floor_tol_m && std::fabs(best.n.dot(pts[i].n)) > 0.9f) {
      fm += pts[i].p.cast<double>();
      ++fn;
    }
  fm /= double(fn);
  for (std::size_t i = 0; i < n; i += stride)
    if (std::fabs(best.dist(pts[i].p)) < params.floor_tol_m && std::fabs(best.n.dot(pts[i].n)) > 0.9f) {
      const Eigen::Vector3d q = pts[i].p.cast<double>() - fm;
      fc += q * q.transpose();
    }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> fes(fc);
  Vec3f e1 = fes.eigenvectors().col(2).cast<float>(), e2 = fes.eigenvectors().col(1).cast<float>();
  if (ctx_.walls > 0) {  // a bin is a box: its walls give the axes exactly, PCA of a half-hidden floor does not
    e1 = (ctx_.wall_n[0] - ctx_.up * ctx_.wall_n[0].dot(ctx_.up)).normalized();
    e2 = ctx_.up.cross(e1);
  }
  // Histogram-free robust bounds: the extremes after dropping the outermost 0.2 % (two passes of
  // "largest k" would need sorting; a coarse 1 mm-bin count over +-1 m is static and small).
  float lo1 = 0, hi1 = 0, lo2 = 0, hi2 = 0;
  {
    constexpr int kBins = 2048;  // 1 mm bins over +-1.024 m around the floor centre
    uint32_t h1[kBins] = {}, h2[kBins] = {};
    const Vec3f c = fm.cast<float>();
    std::size_t tot = 0;
    for (std::size_t i = 0; i < n; i += stride)
      if (std::fabs(best.dist(pts[i].p)) < params.floor_tol_m && std::fabs(best.n.dot(pts[i].n)) > 0.9f) {
        const Vec3f q = pts[i].p - c;
        const int b1 = std::min(kBins - 1, std::max(0, int(q.dot(e1) * 1000.0f) + kBins / 2));
        const int b2 = std::min(kBins - 1, std::max(0, int(q.dot(e2) * 1000.0f) + kBins / 2));
        ++h1[b1];
        ++h2[b2];
        ++tot;
      }
    const std::size_t drop = tot / 500;
    auto bounds = [&](const uint32_t* h, float& lo, float& hi) {
      std::size_t acc = 0;
      int b = 0;
      for (; b < kBins && acc + h[b] <= drop; ++b) acc += h[b];
      lo = float(b - kBins / 2) * 0.001f;
      acc = 0;
      for (b = kBins - 1; b >= 0 && acc + h[b] <= drop; --b) acc += h[b];
      hi = float(b + 1 - kBins / 2) * 0.001f;
    };
    bounds(h1, lo1, hi1);
    bounds(h2, lo2, hi2);
  }
  const Vec3f fcen = fm.cast<float>();
  ctx_.floor_centre_m = fcen;
  ctx_.floor_axis[0] = e1;
  ctx_.floor_axis[1] = e2;
  ctx_.floor_lo[0] = lo1;
  ctx_.floor_hi[0] = hi1;
  ctx_.floor_lo[1] = lo2;
  ctx_.floor_hi[1] = hi2;
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
