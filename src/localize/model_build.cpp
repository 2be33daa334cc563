// Start-up: meshes (or oriented clouds) into the fixed model tables and their PPF hash tables.
#include <algorithm>
#include <cmath>
#include <cstring>

#include "edgefuse/localize/localizer.hpp"
#include "ppf_math.hpp"
#include "sort_keys.hpp"

namespace edgefuse {

Status Localizer::init(const LocalizeBuffers& buffers) {
  if (!buffers.models || !buffers.model_points || !buffers.ppf_points || !buffers.ppf_entries ||
      !buffers.ppf_buckets || !buffers.scene || !buffers.scratch || !buffers.grid_index || !buffers.grid_buckets ||
      !buffers.grid_near || !buffers.grid_points || !buffers.sample || !buffers.labels || !buffers.queue ||
      !buffers.votes || !buffers.candidates || !buffers.verified || !buffers.results || buffers.models_max <= 0 ||
      buffers.ppf_points_max < 8 || buffers.model_points_max > buffers.scene_points_max || buffers.ppf_points_max > 65535)
    return Status::kInvalidArgument;
  b_ = buffers;
  model_count_ = 0;
  scene_count_ = 0;
  return Status::kOk;
}

namespace {

// Low-discrepancy (R2) sample k inside a triangle: evenly spread, no random state.
Vec3f triangle_sample(const Vec3f& a, const Vec3f& b, const Vec3f& c, uint32_t k) {
  float u = 0.5f + float(k) * 0.7548776662f, v = 0.5f + float(k) * 0.5698402910f;
  u -= std::floor(u);
  v -= std::floor(v);
  if (u + v > 1.0f) {
    u = 1.0f - u;
    v = 1.0f - v;
  }
  return a + u * (b - a) + v * (c - a);
}

}  // namespace

Status Localizer::add_model(const char* name, const Vec3f* vertices, std::size_t vertex_count,
                            const uint32_t (*triangles)[3], std::size_t triangle_count, const LocalizeParams& params,
                            int& model_index) {
  if (!b_.models) return Status::kNotInitialised;
  if (model_count_ >= b_.models_max) return Status::kCapacityExceeded;
  if (!vertices || !triangles || vertex_count < 3 || triangle_count < 1) return Status::kInvalidArgument;
  double area = 0;
  for (std::size_t t = 0; t < triangle_count; ++t) {
    for (int k = 0; k < 3; ++k)
      if (triangles[t][k] >= vertex_count || !localizable(vertices[triangles[t][k]])) return Status::kInvalidArgument;
    const Vec3f& a = vertices[triangles[t][0]];
    area += 0.5 * double((vertices[triangles[t][1]] - a).cross(vertices[triangles[t][2]] - a).norm());
  }
  if (!(area > 1e-10)) return Status::kInvalidArgument;
  OrientedPoint* dense = b_.model_points + std::size_t(model_count_) * b_.model_points_max;
  // Dense samples: about 85 % of the capacity, not finer than 1 mm (finer than any sensor here).
  float step = std::max(float(std::sqrt(area / (0.85 * double(b_.model_points_max)))), 0.001f);
  std::size_t n = 0;
  for (int attempt = 0; attempt < 40; ++attempt, step *= 1.1f) {
    n = 0;
    double carry = 0;
    const double per_area = 1.0 / (double(step) * double(step));
    bool full = false;
    for (std::size_t t = 0; t < triangle_count && !full; ++t) {
      const Vec3f& a = vertices[triangles[t][0]];
      const Vec3f& b = vertices[triangles[t][1]];
      const Vec3f& c = vertices[triangles[t][2]];
      const Vec3f cr = (b - a).cross(c - a);
      const float len = cr.norm();
      if (!(len > 0)) continue;
      carry += 0.5 * double(len) * per_area;
      const uint32_t k_count = uint32_t(carry);
      carry -= double(k_count);
      for (uint32_t k = 0; k < k_count; ++k) {
        if (n >= b_.model_points_max) {
          full = true;
          break;
        }
        dense[n++] = OrientedPoint{triangle_sample(a, b, c, k), cr / len};
      }
    }
    if (!full) break;
  }
  if (n < 16) return Status::kInvalidArgument;
  const Status s = finish_model(name, n, params, model_index);
  if (s == Status::kOk) b_.models[model_index].dense_step_m = step;
  return s;
}

Status Localizer::add_model_cloud(const char* name, const OrientedPoint* points, std::size_t count,
                                  const LocalizeParams& params, int& model_index) {
  if (!b_.models) return Status::kNotInitialised;
  if (model_count_ >= b_.models_max) return Status::kCapacityExceeded;
  OrientedPoint* dense = b_.model_points + std::size_t(model_count_) * b_.model_points_max;
  // Keep an even share of the points (every k-th) so the table holds the whole model.
  std::size_t valid = 0;
  for (std::size_t i = 0; i < count; ++i)
    if (localizable(points[i].p) && points[i].n.allFinite()) ++valid;
  if (valid < 16) return Status::kInvalidArgument;
  const std::size_t stride = (valid + b_.model_points_max - 1) / b_.model_points_max;
  std::size_t n = 0, seen = 0;
  for (std::size_t i = 0; i < count && n < b_.model_points_max; ++i) {
    if (!localizable(points[i].p) || !points[i].n.allFinite()) continue;
    if (seen++ % stride == 0) dense[n++] = OrientedPoint{points[i].p, points[i].n.normalized()};
  }
  const Status s = finish_model(name, n, params, model_index);
  if (s == Status::kOk) {  // spacing of an even cloud over the model's bounding-box surface
    ModelInfo& info = b_.models[model_index];
    const Vec3f e = 2.0f * info.half_extent_m;
    const float area = 2.0f * (e.x() * e.y() + e.y() * e.z() + e.x() * e.z());
    info.dense_step_m = std::sqrt(area / float(n));
  }
  return s;
}

Status Localizer::finish_model(const char* name, std::size_t dense_count, const LocalizeParams& params,
                               int& model_index) {
  const int m = model_count_;
  ModelInfo& info = b_.models[m];
  info = ModelInfo{};
  std::strncpy(info.name, name ? name : "model", kModelNameMax - 1);
  const OrientedPoint* dense = b_.model_points + std::size_t(m) * b_.model_points_max;
  Vec3f lo = dense[0].p, hi = dense[0].p;
  for (std::size_t i = 0; i < dense_count; ++i) {
    lo = lo.cwiseMin(dense[i].p);
    hi = hi.cwiseMax(dense[i].p);
  }
  float d2 = 0;
  for (std::size_t i = 0; i < dense_count; ++i)
    for (std::size_t j = i + 1; j < dense_count; ++j) d2 = std::max(d2, (dense[i].p - dense[j].p).squaredNorm());
  info.diameter_m = std::sqrt(d2);
  if (!(info.diameter_m > 1e-4f)) return Status::kInvalidArgument;
  info.half_extent_m = 0.5f * (hi - lo);
  info.centre_m = 0.5f * (hi + lo);
  info.dense_count = uint32_t(dense_count);
  // Mean spacing of the dense samples (area / count ~ step^2), estimated from nearest neighbours
  // would cost O(n^2) again; the sampling step is what the surface density gives.
  info.dense_step_m = 0;
  info.ppf_step_m = params.ppf_step_rel * info.diameter_m;
  const Status s = build_ppf_table(m, params);
  if (s != Status::kOk) return s;
  find_rest_faces(m);
  model_index = m;
  ++model_count_;
  return Status::kOk;
}

Status Localizer::build_ppf_table(int m, const LocalizeParams& params) {
  (void)params;
  ModelInfo& info = b_.models[m];
  const OrientedPoint* dense = b_.model_points + std::size_t(m) * b_.model_points_max;
  OrientedPoint* sparse = b_.ppf_points + std::size_t(m) * b_.ppf_points_max;
  KeyIndex* keys = reinterpret_cast<KeyIndex*>(b_.scratch);
  // Voxel-grid subsampling at the PPF step; a cell keeps up to 3 points whose normals differ by more
  // than 30 degrees (edges keep both faces, as Drost et al. recommend).
  std::size_t n = 0;
  for (int attempt = 0; attempt < 60; ++attempt, info.ppf_step_m *= 1.1f) {
    const float inv = 1.0f / info.ppf_step_m;
    for (uint32_t i = 0; i < info.dense_count; ++i) keys[i] = KeyIndex{cell_key(dense[i].p, inv), i};
    sort_key_index(keys, info.dense_count);
    n = 0;
    bool full = false;
    for (uint32_t i = 0; i < info.dense_count && !full;) {
      uint32_t j = i;
      const std::size_t first = n;
      for (; j < info.dense_count && keys[j].key == keys[i].key; ++j) {
        const OrientedPoint& q = dense[keys[j].index];
        bool distinct = n - first < 3;
        for (std::size_t k = first; k < n && distinct; ++k) distinct = sparse[k].n.dot(q.n) < 0.866f;
        if (!distinct) continue;
        if (n >= b_.ppf_points_max) {
          full = true;
          break;
        }
        sparse[n++] = q;
      }
      i = j;
    }
    if (!full) break;
  }
  info.ppf_count = uint32_t(n);
  // Hash table: counting sort of all ordered pairs by bucket.
  uint32_t* buckets = b_.ppf_buckets + std::size_t(m) * (kPpfBuckets + 1);
  PpfEntry* entries = b_.ppf_entries + std::size_t(m) * b_.ppf_points_max * (b_.ppf_points_max - 1);
  std::memset(buckets, 0, sizeof(uint32_t) * (kPpfBuckets + 1));
  const float inv_step = 1.0f / info.ppf_step_m;
  const float max_d = info.diameter_m * 1.01f;
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = 0; j < n; ++j) {
      uint32_t key;
      if (i != j && ppf::feature_key(sparse[i].p, sparse[i].n, sparse[j].p, sparse[j].n, inv_step, max_d, key))
        ++buckets[ppf::bucket_of(key) + 1];
    }
  for (uint32_t k = 0; k < kPpfBuckets; ++k) buckets[k + 1] += buckets[k];
  info.entry_count = buckets[kPpfBuckets];
  // Fill: the running offset of each bucket lives in its start slot and is restored afterwards.
  for (std::size_t i = 0; i < n; ++i) {
    const Mat3f R_g = ppf::align_to_x(sparse[i].n);
    for (std::size_t j = 0; j < n; ++j) {
      uint32_t key;
      if (i == j || !ppf::feature_key(sparse[i].p, sparse[i].n, sparse[j].p, sparse[j].n, inv_step, max_d, key))
        continue;
      const uint32_t bk = ppf::bucket_of(key);
      entries[buckets[bk]++] =
          PpfEntry{key, uint16_t(i), ppf::quantise_alpha(ppf::alpha_of(R_g, sparse[i].p, sparse[j].p))};
    }
  }
  for (uint32_t k = kPpfBuckets; k > 0; --k) buckets[k] = buckets[k - 1];
  buckets[0] = 0;
  return Status::kOk;
}

}  // namespace edgefuse
