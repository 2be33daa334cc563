// The scene: points with normals copied into the static scene table, a hashed uniform grid for
// nearest-neighbour queries, voxel-grid subsampling, and the TSDF free-space lookup.
#include <cmath>
#include <cstring>

#include "edgefuse/localize/localizer.hpp"
#include "edgefuse/math/real.hpp"
#include "scene_grid.hpp"
#include "sort_keys.hpp"

namespace edgefuse {

template <class PointAt>
Status Localizer::load_scene(std::size_t count, PointAt point_at, const SceneContext& context,
                             const TsdfVolume* volume, float grid_cell_m) {
  if (!b_.scene) return Status::kNotInitialised;
  if (!(grid_cell_m >= kLocalizeGridCellMinM)) return Status::kInvalidArgument;
  std::size_t n = 0;
  Status s = Status::kOk;
  for (std::size_t i = 0; i < count; ++i) {
    const ScenePoint p = point_at(i);
    if (!localizable(p.p) || !p.n.allFinite()) continue;
    if (n >= b_.scene_points_max) {
      s = Status::kOutputTruncated;
      break;
    }
    b_.scene[n++] = p;
  }
  scene_count_ = n;
  ctx_ = context;
  volume_ = volume;
  build_grid(grid_cell_m);
  return s;
}

Status Localizer::set_scene(const SurfacePoint* points, std::size_t count, const SceneContext& context,
                            const TsdfVolume* volume, float grid_cell_m) {
  const auto point_at = [points](std::size_t i) {
    return ScenePoint{points[i].position, points[i].normal, uint32_t(i), points[i].colour};
  };
  return load_scene(count, point_at, context, volume, grid_cell_m);
}

Status Localizer::set_scene_points(const ScenePoint* points, std::size_t count, const SceneContext& context,
                                   const TsdfVolume* volume, float grid_cell_m) {
  return load_scene(count, [points](std::size_t i) { return points[i]; }, context, volume, grid_cell_m);
}

void Localizer::build_grid(float cell_m) {
  grid_cell_m_ = cell_m;
  grid_inv_ = 1.0f / cell_m;
  uint32_t* buckets = b_.grid_buckets;
  std::memset(buckets, 0, sizeof(uint32_t) * (kGridBuckets + 1));
  for (std::size_t i = 0; i < scene_count_; ++i) {
    const Vec3f& p = b_.scene[i].p;
    ++buckets[grid_hash(floor_int(p.x() * grid_inv_), floor_int(p.y() * grid_inv_), floor_int(p.z() * grid_inv_)) + 1];
  }
  for (uint32_t k = 0; k < kGridBuckets; ++k) buckets[k + 1] += buckets[k];
  for (std::size_t i = 0; i < scene_count_; ++i) {
    const Vec3f& p = b_.scene[i].p;
    const uint32_t h =
        grid_hash(floor_int(p.x() * grid_inv_), floor_int(p.y() * grid_inv_), floor_int(p.z() * grid_inv_));
    b_.grid_points[buckets[h]] = p;
    b_.grid_index[buckets[h]++] = uint32_t(i);
  }
  for (uint32_t k = kGridBuckets; k > 0; --k) buckets[k] = buckets[k - 1];
  buckets[0] = 0;
  mark_near_cells();
}

void Localizer::mark_near_cells() {
  uint64_t* near = b_.grid_near;
  std::memset(near, 0, sizeof(uint64_t) * (kGridBuckets / 64));
  // Points are in grid order, so those of one cell mostly follow each other: each run of a cell
  // marks its 27 cells once.
  int32_t last[3] = {0, 0, 0};
  for (std::size_t e = 0; e < scene_count_; ++e) {
    const CellPos cp = cell_pos(b_.grid_points[e], grid_inv_);
    if (e > 0 && cp.c[0] == last[0] && cp.c[1] == last[1] && cp.c[2] == last[2]) continue;
    for (int a = 0; a < 3; ++a) last[a] = cp.c[a];
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const uint32_t h = grid_hash(cp.c[0] + dx, cp.c[1] + dy, cp.c[2] + dz);
          near[h >> 6] |= uint64_t(1) << (h & 63);
        }
  }
}

int32_t Localizer::nearest(const Vec3f& q, float radius_m, float& dist2) const {
  const CellPos cp = cell_pos(q, grid_inv_);
  const int k = int(std::ceil(radius_m * grid_inv_));
  NearestSearch search(b_, q, cp, grid_cell_m_, radius_m * radius_m);
  search.run(k);
  dist2 = search.best_d2;
  return search.found();
}

void Localizer::for_each_within(const Vec3f& q, float radius_m, int32_t label) const {
  // The labels do not depend on the order of the visit, so the cells whose box lies beyond the
  // radius are skipped without reading their buckets.
  const float r2 = radius_m * radius_m;
  const int k = int(std::ceil(radius_m * grid_inv_));
  const CellPos cp = cell_pos(q, grid_inv_);
  for (int dz = -k; dz <= k; ++dz) {
    const float gz2 = cell_gap2(cp.f[2], dz, grid_cell_m_);
    for (int dy = -k; dy <= k && gz2 <= r2; ++dy) {
      const float gyz2 = gz2 + cell_gap2(cp.f[1], dy, grid_cell_m_);
      for (int dx = -k; dx <= k && gyz2 <= r2; ++dx) {
        if (gyz2 + cell_gap2(cp.f[0], dx, grid_cell_m_) > r2) continue;
        const uint32_t h = grid_hash(cp.c[0] + dx, cp.c[1] + dy, cp.c[2] + dz);
        for (uint32_t e = b_.grid_buckets[h]; e < b_.grid_buckets[h + 1]; ++e) {
          const uint32_t i = b_.grid_index[e];
          if ((b_.grid_points[e] - q).squaredNorm() <= r2 && b_.labels[i] == 0) b_.labels[i] = label;
        }
      }
    }
  }
}

std::size_t Localizer::grow_component(std::size_t seed, float radius_m, uint32_t* visited, std::size_t tail) const {
  const std::size_t start = tail;
  visited[seed] = 1;
  b_.queue[tail++] = uint32_t(seed);
  return grow_within(b_, grid_inv_, radius_m, start, tail, [visited](uint32_t j) {
    if (visited[j]) return false;
    visited[j] = 1;
    return true;
  });
}

std::size_t Localizer::subsample_scene(float step_m) {
  KeyIndex* keys = reinterpret_cast<KeyIndex*>(b_.scratch);
  const float inv = 1.0f / step_m;
  for (std::size_t i = 0; i < scene_count_; ++i) keys[i] = KeyIndex{cell_key(b_.scene[i].p, inv), i};
  sort_key_index(keys, scene_count_);
  std::size_t n = 0;
  for (std::size_t i = 0; i < scene_count_; ++i)
    if (i == 0 || keys[i].key != keys[i - 1].key) b_.sample[n++] = uint32_t(keys[i].index);
  return n;
}

float Localizer::free_space_at(const Vec3f& p) const {
  if (!volume_) return 0;
  const TsdfVolume& v = *volume_;
  const Vec3f g = (p - v.origin_m()) / v.voxel_m();
  const int x = floor_int(g.x()), y = floor_int(g.y()), z = floor_int(g.z());
  if (x < 0 || y < 0 || z < 0 || x >= v.dim() || y >= v.dim() || z >= v.dim()) return 0;
  const std::size_t i = v.index(x, y, z);
  if (v.weight()[i] == 0) return 0;
  return float(v.tsdf()[i]) * (v.params().trunc_m / 32767.0f);
}

}  // namespace edgefuse
