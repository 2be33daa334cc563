// The localiser's hashed scene grid (built by Localizer::build_grid): the cell hash, the visit of
// every point in the cube of cells within k cells of a point's cell or in the cells a ball
// overlaps, and the breadth-first growth that connected components and fragment grouping share.
// Private to src/localize.
#pragma once
#include <cmath>
#include <cstddef>
#include <cstdint>

#include "edgefuse/localize/localizer.hpp"
#include "edgefuse/math/real.hpp"

namespace edgefuse {

inline uint32_t grid_hash(int32_t x, int32_t y, int32_t z) {
  return (uint32_t(x) * 73856093u ^ uint32_t(y) * 19349663u ^ uint32_t(z) * 83492791u) & (kGridBuckets - 1);
}

//! A query's grid cell and its position inside it.
struct CellPos {
  int32_t c[3];  //!< cell per axis: floor(x / cell), as build_grid files the points
  float f[3];    //!< position inside the cell per axis, in cells ([0, 1))
};

//! \param q query point  \param grid_inv 1 / cell edge  \return q's cell and position in it
inline CellPos cell_pos(const Vec3f& q, float grid_inv) {
  CellPos cp;
  for (int a = 0; a < 3; ++a) {
    const float g = q[a] * grid_inv;
    cp.c[a] = floor_int(g);
    cp.f[a] = g - float(cp.c[a]);
  }
  return cp;
}

//! Allowance for the rounding of the cell a point is filed under (floor(x / cell) in float): a
//! point may lie this far outside its cell's box. Far above the float error at metres (< 1 um).
inline constexpr float kCellBoxMarginM = 1e-5f;

//! Squared distance along one axis from a query to the cells d cells away, less kCellBoxMarginM:
//! never more than the distance to a point filed there, so a cell whose summed gaps exceed the
//! best squared distance so far holds no nearer or equally near point.
//! \param f the query's position in its cell (cells)  \param d cell offset  \param cell_m cell edge
//! \return squared gap in m^2 (0 for the query's own row)
inline float cell_gap2(float f, int d, float cell_m) {
  const float cells = d > 0 ? float(d) - f : (d < 0 ? f - float(d + 1) : 0.0f);
  const float gap_m = cells * cell_m - kCellBoxMarginM;
  return gap_m > 0 ? gap_m * gap_m : 0.0f;
}

//! cell_gap2 per axis for the offsets a ring search has reached, computed once per ring instead of
//! once per cell visited (the search reads each up to (2 ring + 1)^2 times).
class RingGaps {
 public:
  //! \param cp the query's cell and position in it  \param cell_m cell edge
  RingGaps(const CellPos& cp, float cell_m) : cp_(cp), cell_m_(cell_m) {}
  //! Computes the gaps of offsets -ring and +ring on every axis (call for ring 0, 1, ... in turn).
  //! \param ring Chebyshev distance in cells
  void add_ring(int ring) {
    if (ring > kCached) return;  // read through at() from the formula
    for (int a = 0; a < 3; ++a) {
      g2_[a][kCached - ring] = cell_gap2(cp_.f[a], -ring, cell_m_);
      g2_[a][kCached + ring] = cell_gap2(cp_.f[a], ring, cell_m_);
    }
  }
  //! \param axis 0..2  \param d cell offset within a ring added so far  \return cell_gap2 of it
  float at(int axis, int d) const {
    return (d <= kCached && d >= -kCached) ? g2_[axis][kCached + d] : cell_gap2(cp_.f[axis], d, cell_m_);
  }

 private:
  static constexpr int kCached = 15;  // rings beyond (radius > 15 cells) are rare: computed per read
  CellPos cp_;
  float cell_m_;
  float g2_[3][2 * kCached + 1];
};

//! One nearest-neighbour query on the grid (Localizer::nearest): the nearest scene point to q within
//! sqrt(best_d2), ties to the lower scene index, among the cells within k cells of q's cell.
struct NearestSearch {
  static constexpr uint32_t kNone = ~0u;
  const LocalizeBuffers& b;
  Vec3f q;
  CellPos cp;
  float cell_m;
  float best_d2;            //!< the radius squared, then the best squared distance found
  uint32_t best_e = kNone;  //!< the best candidate's slot in grid order (kNone: none yet)
  RingGaps gaps;

  //! \param buffers the grid  \param query the point  \param pos its cell  \param cell grid cell edge
  //! \param radius2 the search radius squared
  NearestSearch(const LocalizeBuffers& buffers, const Vec3f& query, const CellPos& pos, float cell, float radius2)
      : b(buffers), q(query), cp(pos), cell_m(cell), best_d2(radius2), gaps(pos, cell) {}

  //! Runs the search: k <= 1 by rings, after the bit of q's own cell; wider by blocks.
  //! \param k cells each side (ceil(radius / cell))
  void run(int k) {
    if (k >= 2) {
      by_blocks(k);
    } else if (block_may_hold_points(0, 0, 0)) {
      // Nothing within one ring of q's cell when the bit is clear: ~40 % of the localiser's queries.
      by_rings(k);
    }
  }

  //! \return the nearest point's scene index, or -1 when none is within the radius
  int32_t found() const { return best_e == kNone ? -1 : int32_t(b.grid_index[best_e]); }

  //! \return false when no cell within one cell of q's cell + (dx, dy, dz) holds a point (the
  //! grid_near bit of that cell's bucket is clear; a set bit may be a hash collision)
  bool block_may_hold_points(int dx, int dy, int dz) const {
    const uint32_t h = grid_hash(cp.c[0] + dx, cp.c[1] + dy, cp.c[2] + dz);
    return ((b.grid_near[h >> 6] >> (h & 63)) & 1u) != 0;
  }

  //! Reads the points of the cell at offset (dx, dy, dz) unless its box is beyond the best so far.
  //! \param gyz2 the cell's squared gap along y and z
  void scan_cell(int dx, int dy, int dz, float gyz2) {
    if (gyz2 + gaps.at(0, dx) > best_d2) return;
    const uint32_t h = grid_hash(cp.c[0] + dx, cp.c[1] + dy, cp.c[2] + dz);
    const uint32_t e1 = b.grid_buckets[h + 1];
    for (uint32_t e = b.grid_buckets[h]; e < e1; ++e) {
      const float d2 = (b.grid_points[e] - q).squaredNorm();
      // Equal distance: the lower scene index wins, whatever order the cells come in.
      if (d2 < best_d2 || (d2 == best_d2 && best_e != kNone && b.grid_index[e] < b.grid_index[best_e])) {
        best_d2 = d2;
        best_e = e;
      }
    }
  }

  //! Rings of cells by Chebyshev distance up to k; a point in ring R+1 is at least R cells away, so
  //! the search stops as soon as the best distance is within that. Within the rings, a cell whose
  //! box is farther than the best distance so far is not read (its bucket lookup is the cost: most
  //! of the 26 neighbours of a query near the surface are).
  void by_rings(int k) {
    for (int ring = 0; ring <= k; ++ring) {
      gaps.add_ring(ring);
      for (int dz = -ring; dz <= ring; ++dz) {
        const float gz2 = gaps.at(2, dz);
        if (gz2 > best_d2) continue;
        const bool z_face = dz == -ring || dz == ring;
        for (int dy = -ring; dy <= ring; ++dy) {
          const float gyz2 = gz2 + gaps.at(1, dy);
          if (gyz2 > best_d2) continue;
          if (z_face || dy == -ring || dy == ring) {
            for (int dx = -ring; dx <= ring; ++dx) scan_cell(dx, dy, dz, gyz2);
          } else {  // inside the ring's cube: only its two x faces belong to the ring
            scan_cell(-ring, dy, dz, gyz2);
            scan_cell(ring, dy, dz, gyz2);
          }
        }
      }
      const float reach = float(ring) * cell_m;
      if (best_e != kNone && best_d2 <= reach * reach) return;
    }
  }

  //! The same cells as by_rings(k) (those within k cells of q's), in blocks of 3x3x3 cells centred
  //! on q's cell + 3 (bx, by, bz), by rings of blocks: a block whose grid_near bit is clear holds no
  //! point and costs one bit instead of 27 bucket lookups. For wide radii (k >= 2), where a query
  //! that finds nothing reads every cell of its ball (k = 8: ~2,000).
  void by_blocks(int k) {
    for (int ring = 0; ring <= k; ++ring) gaps.add_ring(ring);
    const int last_ring = (k + 1) / 3;  // blocks reaching into [-k, k]: 3 |b| - 1 <= k
    for (int ring = 0; ring <= last_ring; ++ring) {
      for (int bz = -ring; bz <= ring; ++bz) {
        const float gz2 = block_gap2(2, bz);
        if (gz2 > best_d2) continue;
        const bool z_face = bz == -ring || bz == ring;
        for (int by = -ring; by <= ring; ++by) {
          const float gyz2 = gz2 + block_gap2(1, by);
          if (gyz2 > best_d2) continue;
          const int step = (z_face || by == -ring || by == ring || ring == 0) ? 1 : 2 * ring;
          for (int bx = -ring; bx <= ring; bx += step) scan_block(bx, by, bz, k, gyz2);
        }
      }
      // A block of ring R+1 starts 3 R + 2 cells out: its points are at least 3 R + 1 cells away.
      const float reach = float(3 * ring + 1) * cell_m;
      if (best_e != kNone && best_d2 <= reach * reach) return;
    }
  }

 private:
  //! Squared gap along one axis from q to the block b blocks away (its nearest cell's).
  float block_gap2(int axis, int b3) const {
    return b3 > 0 ? gaps.at(axis, 3 * b3 - 1) : (b3 < 0 ? gaps.at(axis, 3 * b3 + 1) : 0.0f);
  }

  void scan_block(int bx, int by, int bz, int k, float gyz2) {
    if (gyz2 + block_gap2(0, bx) > best_d2) return;
    if (!block_may_hold_points(3 * bx, 3 * by, 3 * bz)) return;
    const auto lo = [k](int b3) { return 3 * b3 - 1 < -k ? -k : 3 * b3 - 1; };
    const auto hi = [k](int b3) { return 3 * b3 + 1 > k ? k : 3 * b3 + 1; };
    for (int dz = lo(bz); dz <= hi(bz); ++dz) {
      const float gz2 = gaps.at(2, dz);
      if (gz2 > best_d2) continue;
      for (int dy = lo(by); dy <= hi(by); ++dy) {
        const float cyz2 = gz2 + gaps.at(1, dy);
        if (cyz2 > best_d2) continue;
        for (int dx = lo(bx); dx <= hi(bx); ++dx) scan_cell(dx, dy, dz, cyz2);
      }
    }
  }
};

//! Calls f(j, position of j) for every scene point j hashed into the cells within k cells (per
//! axis) of p's cell; candidates only (hash collisions included): the caller checks the distance.
//! \param b the localiser's buffers  \param grid_inv 1 / cell edge  \param k cells each side
//! \param p query point
//! \param f called with each candidate's scene index and its position (read in grid order)
template <typename F>
inline void for_cube_neighbours(const LocalizeBuffers& b, float grid_inv, int k, const Vec3f& p, F&& f) {
  const int32_t cx = floor_int(p.x() * grid_inv), cy = floor_int(p.y() * grid_inv), cz = floor_int(p.z() * grid_inv);
  for (int dz = -k; dz <= k; ++dz)
    for (int dy = -k; dy <= k; ++dy)
      for (int dx = -k; dx <= k; ++dx) {
        const uint32_t h = grid_hash(cx + dx, cy + dy, cz + dz);
        for (uint32_t e = b.grid_buckets[h]; e < b.grid_buckets[h + 1]; ++e) f(b.grid_index[e], b.grid_points[e]);
      }
}

//! Calls f(j) for every scene point j in the grid cells that the ball of radius r around p
//! overlaps (candidates only: the caller checks the distance). The exact cell range, not a cube of
//! ceil(r / cell) cells either side: 2-3 cells per axis instead of 5 for the crease radius.
//! \param b the localiser's buffers  \param grid_inv 1 / cell edge  \param r ball radius
//! \param p ball centre  \param f called with each candidate's scene index
template <typename F>
inline void for_grid_neighbours(const LocalizeBuffers& b, float grid_inv, float r, const Vec3f& p, F&& f) {
  const int32_t x0 = floor_int((p.x() - r) * grid_inv), x1 = floor_int((p.x() + r) * grid_inv);
  const int32_t y0 = floor_int((p.y() - r) * grid_inv), y1 = floor_int((p.y() + r) * grid_inv);
  const int32_t z0 = floor_int((p.z() - r) * grid_inv), z1 = floor_int((p.z() + r) * grid_inv);
  for (int32_t z = z0; z <= z1; ++z)
    for (int32_t y = y0; y <= y1; ++y)
      for (int32_t x = x0; x <= x1; ++x) {
        const uint32_t h = grid_hash(x, y, z);
        for (uint32_t e = b.grid_buckets[h]; e < b.grid_buckets[h + 1]; ++e) f(b.grid_index[e]);
      }
}

//! Breadth-first growth from b.queue[start, tail): every scene point within radius_m of a queued
//! point for which claim(j) returns true (claim marks it) is appended to b.queue.
//! \param b the localiser's buffers (queue, scene, grid)  \param grid_inv 1 / cell edge
//! \param radius_m linking distance  \param start first queued index  \param tail one past the last
//! \param claim bool(uint32_t j): false if j is taken already, else marks it and returns true
//! \return the new tail
template <typename Claim>
inline std::size_t grow_within(const LocalizeBuffers& b, float grid_inv, float radius_m, std::size_t start,
                               std::size_t tail, Claim&& claim) {
  const float r2 = radius_m * radius_m;
  const int k = int(std::ceil(radius_m * grid_inv));
  for (std::size_t head = start; head < tail; ++head) {
    const Vec3f p = b.scene[b.queue[head]].p;
    for_cube_neighbours(b, grid_inv, k, p, [&](uint32_t j, const Vec3f& pj) {
      if ((pj - p).squaredNorm() <= r2 && claim(j)) b.queue[tail++] = j;
    });
  }
  return tail;
}

}  // namespace edgefuse
