// Zero crossings of the TSDF along the grid edges (the point cloud of extract.hpp).
//
// A crossing needs both voxels observed (with at least min_weight, when given) and strictly inside
// the truncation band, so both of their bricks carry kBrickSurface: only those bricks are visited,
// and an edge leaving a brick is followed only when the neighbouring brick has the flag too.
// Order: bricks in index order, voxels z-y-x inside a brick, then the +x, +y, +z edge of each
// voxel -- deterministic.
// Sign convention (shared with marching cubes): a voxel is inside when tsdf < 0; 0 is outside.
#include <cmath>
#include <cstddef>
#include <cstdint>

#include "edgefuse/tsdf/extract.hpp"
#include "extract_detail.hpp"

namespace edgefuse {

Status extract_points(const TsdfVolume& volume, SurfacePoint* out, std::size_t capacity, std::size_t& count,
                      uint8_t min_weight) {
  using namespace extract_detail;
  count = 0;
  if (!volume.initialised()) return Status::kNotInitialised;
  if (out == nullptr && capacity > 0) return Status::kInvalidArgument;

  const Grid g(volume);
  const int nb = g.nb;
  const std::size_t nb2 = std::size_t(nb) * std::size_t(nb);
  const int16_t* const t = g.tsdf;
  const uint8_t* const w = g.weight;
  const uint8_t w_min = min_weight > 1 ? min_weight : 1;  // 1: observed

  std::size_t b = 0;
  for (int bz = 0; bz < nb; ++bz) {
    for (int by = 0; by < nb; ++by) {
      for (int bx = 0; bx < nb; ++bx, ++b) {
        if (!(g.flags[b] & kBrickSurface)) continue;
        // May an edge leave this brick along +x / +y / +z?
        const bool open[3] = {bx + 1 < nb && (g.flags[b + 1] & kBrickSurface) != 0,
                              by + 1 < nb && (g.flags[b + std::size_t(nb)] & kBrickSurface) != 0,
                              bz + 1 < nb && (g.flags[b + nb2] & kBrickSurface) != 0};
        std::size_t idx = volume.brick_base(b);
        for (int lz = 0; lz < kBrickSide; ++lz) {
          for (int ly = 0; ly < kBrickSide; ++ly) {
            for (int lx = 0; lx < kBrickSide; ++lx, ++idx) {
              if (w[idx] < w_min) continue;
              const int16_t t0 = t[idx];
              if (!in_band(t0)) continue;
              const bool neg0 = t0 < 0;
              const int local[3] = {lx, ly, lz};
              const int c[3] = {bx * kBrickSide + lx, by * kBrickSide + ly, bz * kBrickSide + lz};
              for (int d = 0; d < 3; ++d) {
                const bool last = local[d] == kBrickSide - 1;
                if (last && !open[d]) continue;
                const std::size_t j = g.up(idx, c, d);
                const int16_t t1 = t[j];
                if ((t1 < 0) == neg0 || w[j] < w_min || !in_band(t1)) continue;
                if (count == capacity) return Status::kOutputTruncated;
                EdgeSample e;
                edge_sample(g, c, idx, d, j, e);
                SurfacePoint& p = out[count++];
                p.position = e.position;
                p.normal = e.normal;
                p.colour = e.colour;
                p.support = w[idx] < w[j] ? w[idx] : w[j];
              }
            }
          }
        }
      }
    }
  }
  return Status::kOk;
}

int support_around(const TsdfVolume& volume, const Vec3f& p) {
  const Vec3f g = (p - volume.origin_m()) / volume.voxel_m() - Vec3f::Constant(0.5f);
  const int dim = volume.dim();
  int best = 0;
  for (int c = 0; c < 8; ++c) {
    const int x = int(std::floor(g.x())) + (c & 1), y = int(std::floor(g.y())) + ((c >> 1) & 1),
              z = int(std::floor(g.z())) + ((c >> 2) & 1);
    if (x < 0 || y < 0 || z < 0 || x >= dim || y >= dim || z >= dim) continue;
    const int w = volume.weight()[volume.index(x, y, z)];
    if (w > best) best = w;
  }
  return best;
}

std::size_t keep_supported(const TsdfVolume& volume, SurfacePoint* points, std::size_t count, int min_weight) {
  if (min_weight <= 0) return count;
  std::size_t kept = 0;
  for (std::size_t i = 0; i < count; ++i)
    if (support_around(volume, points[i].position) >= min_weight) points[kept++] = points[i];
  return kept;
}

}  // namespace edgefuse
