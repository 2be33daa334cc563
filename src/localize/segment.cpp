// Model-free segments: region growing over the scene left after bin removal. Neighbours (within
// segment_radius_m) join when their normals agree (smooth surface) or when the connection is
// convex ((n_j - n_i) . (p_j - p_i) >= 0, as at a box edge); a concave connection (a box resting
// on another, two parts touching) separates segments. Measured normals blend across a concave
// crease, so the smooth test alone walks through it: the crease band is marked first, kept out of
// the growing and attached afterwards (mark_creases, attach_creases); small pieces join the segment
// they touch. Each segment gets an oriented box (PCA), a grasp point on its top surface and the
// approach direction.
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "edgefuse/localize/localizer.hpp"
#include "edgefuse/math/real.hpp"
#include "pose_order.hpp"
#include "scene_grid.hpp"

namespace edgefuse {

void Localizer::connected_components(float radius_m) {
  const std::size_t n = scene_count_;
  for (std::size_t i = 0; i < n; ++i) b_.labels[i] = 0;
  std::size_t tail = 0;
  int32_t label = 0;
  for (std::size_t seed = 0; seed < n; ++seed) {
    if (b_.labels[seed] != 0) continue;
    ++label;
    const std::size_t start = tail;
    b_.labels[seed] = label;
    b_.queue[tail++] = uint32_t(seed);
    tail = grow_within(b_, grid_inv_, radius_m, start, tail, [this, label](uint32_t j) {
      if (b_.labels[j] != 0) return false;
      b_.labels[j] = label;
      return true;
    });
  }
}

namespace {

constexpr int32_t kCrease = -1;  //!< label of a point on a concave crease while growing

}  // namespace

void Localizer::mark_creases(const LocalizeParams& params) {
  // A point is on a crease when a neighbour within segment_crease_radius_m has a normal turned by
  // more than segment_crease_deg and the pair is clearly concave ((n_j - n_i).(p_j - p_i) below
  // -segment_crease_concave |p_j - p_i|; a right-angled inner corner gives -1 .. -1.41, noise on a
  // plane about 0, a convex box edge > 0). Normals estimated across the crease are blended, so the
  // region growing's "smooth" test alone walks through it in small turns (a box on a box, a can
  // on a tin); without the band of crease points the two sides are 2 radii apart.
  // The test is the costliest part of segment(): it runs in kCreaseChunks chunks over the caller's
  // threads (each point writes only its own label, so the result does not depend on the threads).
  job_params_ = &params;
  if (parallel_.run) parallel_.run(parallel_.runner, kCreaseChunks, &Localizer::crease_job, this);
  else
    for (std::size_t c = 0; c < kCreaseChunks; ++c) crease_job(this, c);
}

void Localizer::crease_job(void* self, std::size_t chunk) {
  Localizer& L = *static_cast<Localizer*>(self);
  const LocalizeParams& params = *L.job_params_;
  const LocalizeBuffers& b = L.b_;
  const std::size_t n = L.scene_count_;
  const float r = params.segment_crease_radius_m, r2 = r * r;
  const float cos_crease = std::cos(params.segment_crease_deg * 3.14159265f / 180.0f);
  const float concave = params.segment_crease_concave;
  const std::size_t begin = n * chunk / kCreaseChunks, end = n * (chunk + 1) / kCreaseChunks;
  for (std::size_t i = begin; i < end; ++i) {
    const ScenePoint& a = b.scene[i];
    int near = 0, pairs = 0;
    for_grid_neighbours(b, L.grid_inv_, r, a.p, [&](uint32_t j) {
      const ScenePoint& c = b.scene[j];
      const Vec3f d = c.p - a.p;
      const float dd = d.squaredNorm();
      if (dd > r2 || !(dd > 0)) return;
      ++near;
      if (a.n.dot(c.n) > cos_crease) return;
      pairs += (c.n - a.n).dot(d) < -concave * std::sqrt(dd);
    });
    // A crease is seen by many neighbours; noisy normals (far or dark surfaces) give single pairs.
    const bool crease = pairs >= params.segment_crease_min_pairs && float(pairs) >= params.segment_crease_share * float(near);
    if (crease) b.labels[i] = kCrease;
  }
}

int32_t Localizer::grow_regions(const LocalizeParams& params, int32_t label) {
  // Region growing from every unlabelled point: neighbours within segment_radius_m join across
  // smooth or convex connections. Points labelled already (segments, creases) are not entered.
  const std::size_t n = scene_count_;
  const float r = params.segment_radius_m, r2 = r * r;
  const float cos_smooth = std::cos(params.segment_smooth_deg * 3.14159265f / 180.0f);
  for (std::size_t seed = 0; seed < n; ++seed) {
    if (b_.labels[seed] != 0) continue;
    ++label;
    std::size_t tail = 0;
    b_.labels[seed] = label;
    b_.queue[tail++] = uint32_t(seed);
    for (std::size_t head = 0; head < tail; ++head) {
      const ScenePoint& a = b_.scene[b_.queue[head]];
      for_grid_neighbours(b_, grid_inv_, r, a.p, [&](uint32_t j) {
        if (b_.labels[j] != 0) return;
        const ScenePoint& c = b_.scene[j];
        const Vec3f d = c.p - a.p;
        const float dd = d.squaredNorm();
        if (dd > r2 || !(dd > 0)) return;
        const bool smooth = a.n.dot(c.n) > cos_smooth;
        const bool convex = (c.n - a.n).dot(d) >= -params.segment_concave_tol * std::sqrt(dd);
        if (!smooth && !convex) return;
        if (params.segment_colour_tol > 0 && a.colour.a && c.colour.a &&
            std::abs(int(a.colour.r) - int(c.colour.r)) + std::abs(int(a.colour.g) - int(c.colour.g)) +
                    std::abs(int(a.colour.b) - int(c.colour.b)) >
                params.segment_colour_tol)
          return;
        b_.labels[j] = label;
        b_.queue[tail++] = j;
      });
    }
  }
  return label;
}

void Localizer::attach_creases(const LocalizeParams& params) {
  // Crease points join the segment next to them whose surface they continue smoothly: breadth-first
  // from the labelled points next to the band, in index order (deterministic), each side taking its
  // own half of the band. The normal test is against the seed's normal (sample[] keeps the seed), so
  // a chain of small turns cannot walk through the blended crease line to the other side.
  // The blended points on the line itself then go, in sweeps, to the labelled neighbour whose normal
  // is closest to theirs (they are the boundary, not a part of their own); any left stay kCrease.
  const std::size_t n = scene_count_;
  const float r = params.segment_radius_m, r2 = r * r;
  const float cos_smooth = std::cos(params.segment_smooth_deg * 3.14159265f / 180.0f);
  for (std::size_t i = 0; i < n; ++i) b_.sample[i] = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (b_.labels[i] != kCrease) continue;
    const Vec3f p = b_.scene[i].p;
    for_grid_neighbours(b_, grid_inv_, r, p, [&](uint32_t j) {
      if (b_.labels[j] > 0 && (b_.scene[j].p - p).squaredNorm() <= r2) b_.sample[j] = 1;
    });
  }
  std::size_t tail = 0;
  for (std::size_t i = 0; i < n; ++i)
    if (b_.sample[i]) {
      b_.sample[i] = uint32_t(i);
      b_.queue[tail++] = uint32_t(i);
    }
  for (std::size_t head = 0; head < tail; ++head) {
    const uint32_t ia = b_.queue[head];
    const ScenePoint& a = b_.scene[ia];
    const int32_t la = b_.labels[ia];
    const uint32_t origin = b_.sample[ia];
    const Vec3f& n0 = b_.scene[origin].n;
    for_grid_neighbours(b_, grid_inv_, r, a.p, [&](uint32_t j) {
      if (b_.labels[j] != kCrease) return;
      const ScenePoint& c = b_.scene[j];
      if (n0.dot(c.n) <= cos_smooth || (c.p - a.p).squaredNorm() > r2) return;
      b_.labels[j] = la;
      b_.sample[j] = origin;
      b_.queue[tail++] = j;
    });
  }
  for (int sweep = 0; sweep < 8; ++sweep) {
    bool changed = false;
    for (std::size_t i = 0; i < n; ++i) {
      if (b_.labels[i] != kCrease) continue;
      const ScenePoint& a = b_.scene[i];
      float best = -2.0f;
      int32_t target = 0;
      for_grid_neighbours(b_, grid_inv_, r, a.p, [&](uint32_t j) {
        const int32_t lj = b_.labels[j];
        if (lj <= 0 || (b_.scene[j].p - a.p).squaredNorm() > r2) return;
        const float d = a.n.dot(b_.scene[j].n);
        if (d > best) {
          best = d;
          target = lj;
        }
      });
      if (target > 0) {
        b_.labels[i] = target;
        changed = true;
      }
    }
    if (!changed) break;
  }
}

void Localizer::sort_by_label(std::size_t labels_n) {
  const std::size_t n = scene_count_;
  for (std::size_t l = 0; l < labels_n; ++l) b_.sample[l] = 0;
  for (std::size_t i = 0; i < n; ++i) ++b_.sample[b_.labels[i]];
  uint32_t acc = 0;
  for (std::size_t l = 0; l < labels_n; ++l) {
    const uint32_t c = b_.sample[l];
    b_.sample[l] = acc;
    acc += c;
  }
  for (std::size_t i = 0; i < n; ++i) b_.queue[b_.sample[b_.labels[i]]++] = uint32_t(i);
}

bool Localizer::merge_small_segments(const LocalizeParams& params, std::size_t labels_n) {
  // A piece smaller than segment_min_points that touches a segment large enough to be reported
  // joins the one with the closest point: the crease cut and noisy normals leave such chips along
  // edges and on curved parts (a tin lying on its side lost 10 % of its points to them); alone
  // they would be dropped as noise.
  const float r = params.segment_radius_m, r2 = r * r;
  const uint32_t min_points = uint32_t(params.segment_min_points);
  auto size_of = [&](std::size_t l) { return b_.sample[l] - (l ? b_.sample[l - 1] : 0u); };
  bool merged = false;
  for (std::size_t l = 1; l < labels_n; ++l) {
    const uint32_t start = b_.sample[l - 1], end = b_.sample[l];
    if (end == start || end - start >= min_points) continue;
    float best = r2;
    int32_t target = 0;
    for (uint32_t q = start; q < end; ++q) {
      const Vec3f p = b_.scene[b_.queue[q]].p;
      for_grid_neighbours(b_, grid_inv_, r, p, [&](uint32_t j) {
        const int32_t lj = b_.labels[j];
        if (lj <= 0 || std::size_t(lj) == l || size_of(std::size_t(lj)) < min_points) return;
        const float dd = (b_.scene[j].p - p).squaredNorm();
        if (dd < best) {
          best = dd;
          target = lj;
        }
      });
    }
    if (target == 0) continue;
    for (uint32_t q = start; q < end; ++q) b_.labels[b_.queue[q]] = target;
    merged = true;
  }
  return merged;
}

int32_t Localizer::label_segments(const LocalizeParams& params) {
  const std::size_t n = scene_count_;
  for (std::size_t i = 0; i < n; ++i) b_.labels[i] = 0;
  const bool creases = params.segment_crease_deg > 0;
  if (creases) mark_creases(params);
  int32_t label = grow_regions(params, 0);
  if (creases) {
    attach_creases(params);
    // Crease points that no segment reached (a part narrower than the crease band) grow on their own.
    for (std::size_t i = 0; i < n; ++i)
      if (b_.labels[i] == kCrease) b_.labels[i] = 0;
    label = grow_regions(params, label);
  }
  return label;
}

std::size_t Localizer::group_by_label(const LocalizeParams& params, int32_t& label) {
  // Members of each segment contiguous in queue[]: counting sort by label (sample[] = end offsets).
  // Only when every point is its own segment can a label reach the array's size: that one is dropped.
  const std::size_t n = scene_count_;
  if (std::size_t(label) >= b_.scene_points_max) {
    for (std::size_t i = 0; i < n; ++i)
      if (std::size_t(b_.labels[i]) >= b_.scene_points_max) b_.labels[i] = 0;
    label = int32_t(b_.scene_points_max) - 1;
  }
  const std::size_t labels_n = std::min<std::size_t>(std::size_t(label) + 1, b_.scene_points_max);
  sort_by_label(labels_n);
  if (params.segment_merge_small && merge_small_segments(params, labels_n)) sort_by_label(labels_n);
  return labels_n;
}

void Localizer::segment_box_frame(std::size_t start, std::size_t tail, Vec3f& centre, Mat3f& B) const {
  const std::size_t size = tail - start;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (std::size_t q = start; q < tail; ++q) mean += b_.scene[b_.queue[q]].p.cast<double>();
  mean /= double(size);
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (std::size_t q = start; q < tail; ++q) {
    const Eigen::Vector3d v = b_.scene[b_.queue[q]].p.cast<double>() - mean;
    cov += v * v.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
  Mat3f R = es.eigenvectors().cast<float>();  // columns: smallest .. largest spread
  // Box axes: x = largest spread, z = the remaining axis turned towards `up`, right-handed.
  Vec3f ax = R.col(2), az = R.col(0);
  if (az.dot(ctx_.up) < 0) az = -az;
  Vec3f ay = az.cross(ax);
  B.col(0) = ax;
  B.col(1) = ay;
  B.col(2) = az;
  centre = mean.cast<float>();
}

LocalizedObject Localizer::describe_segment(std::size_t start, std::size_t tail, int32_t seg_label) const {
  Vec3f c;
  Mat3f B;
  segment_box_frame(start, tail, c, B);
  Vec3f lo = Vec3f::Constant(1e9f), hi = Vec3f::Constant(-1e9f);
  float top = -1e9f, best_g = -1e9f;
  Vec3f grasp = c, approach = -ctx_.up;
  for (std::size_t q = start; q < tail; ++q) {
    const ScenePoint& s = b_.scene[b_.queue[q]];
    const Vec3f l = B.transpose() * (s.p - c);
    lo = lo.cwiseMin(l);
    hi = hi.cwiseMax(l);
    const float height = ctx_.has_floor ? ctx_.up.dot(s.p) + ctx_.floor_offset : ctx_.up.dot(s.p);
    top = std::max(top, height);
    if (s.n.dot(ctx_.up) > 0.8f) {
      const Vec3f off = s.p - c;
      const float g = height - 0.5f * (off - ctx_.up * off.dot(ctx_.up)).norm();
      if (g > best_g) {
        best_g = g;
        grasp = s.p;
        approach = -s.n;
      }
    }
  }
  if (best_g == -1e9f) {  // no top-facing surface: the highest point, approached from above
    for (std::size_t q = start; q < tail; ++q) {
      const ScenePoint& s = b_.scene[b_.queue[q]];
      const float height = ctx_.has_floor ? ctx_.up.dot(s.p) + ctx_.floor_offset : ctx_.up.dot(s.p);
      if (height >= top) grasp = s.p;
    }
  }
  LocalizedObject o;
  o.model = -1;
  o.segment = seg_label;
  o.T_world_object.R = B;
  o.T_world_object.t = c + B * (0.5f * (lo + hi));
  o.score = 1.0f;
  o.grasp_m = grasp;
  o.approach = approach;
  o.size_m = hi - lo;
  o.top_m = top;
  o.support = uint32_t(tail - start);
  return o;
}

void Localizer::keep_in_picking_order(const LocalizedObject& o, int max_results, std::size_t& count) const {
  if (count < std::size_t(max_results)) {
    b_.results[count++] = o;
  } else {  // full: replace the last in picking order if this one comes earlier
    std::size_t worst = 0;
    for (std::size_t w = 1; w < count; ++w)
      if (picking_key(b_.results[w]) < picking_key(b_.results[worst])) worst = w;
    if (picking_key(o) > picking_key(b_.results[worst])) b_.results[worst] = o;
  }
}

void Localizer::label_by_picking_rank(int32_t label, std::size_t count) {
  // Labels: picking rank (1 = first) for reported segments, 0 for the rest. `sample` maps raw labels.
  for (int32_t l = 0; l <= label && std::size_t(l) < b_.scene_points_max; ++l) b_.sample[l] = 0;
  for (std::size_t i = 0; i < count; ++i) {
    b_.sample[b_.results[i].segment] = uint32_t(i + 1);
    b_.results[i].segment = int(i + 1);
  }
  for (std::size_t i = 0; i < scene_count_; ++i) b_.labels[i] = int32_t(b_.sample[b_.labels[i]]);
}

Status Localizer::segment(const LocalizeParams& params, int max_results, std::size_t& count) {
  count = 0;
  if (!b_.scene) return Status::kNotInitialised;
  if (max_results > b_.objects_max) max_results = b_.objects_max;
  int32_t label = label_segments(params);
  const std::size_t labels_n = group_by_label(params, label);
  for (std::size_t l = 1; l < labels_n; ++l) {
    // Segment l is queue[sample[l - 1], sample[l]): kept if large enough.
    const std::size_t start = b_.sample[l - 1], tail = b_.sample[l];
    if (tail - start < std::size_t(params.segment_min_points)) continue;
    keep_in_picking_order(describe_segment(start, tail, int32_t(l)), max_results, count);
  }
  sort_picking_order(count);
  label_by_picking_rank(label, count);
  return Status::kOk;
}

}  // namespace edgefuse
