// Marching cubes over the TSDF (the mesh of extract.hpp).
//
// A cell is the cube between 8 neighbouring voxel centres, named by its minimum corner (x, y, z),
// 0 <= x, y, z <= dim - 2. It is polygonised when all 8 corners are observed (weight > 0) and at
// least one corner lies strictly inside the truncation band: a cell whose corners are all
// truncated carries no surface position (with mixed signs it is an occlusion boundary between
// "far in front" and "far behind", not a measured surface). That rule lets whole blocks of cells
// be skipped from the brick flags: a block needs kBrickSurface on one of the (up to) 2x2x2 bricks
// holding its corners and kBrickObserved on the brick of its minimum corners.
//
// Cells are visited z-layer by z-layer (deterministic order: z, then bricks by y and x, then
// cells y-x inside the brick); a row of 8 cells is first tested for a sign change with bit masks.
// Every vertex lies on a grid edge and is created once: its id is kept in the scratch, two
// z-slices (voxel layers z and z+1), each laid out y, x, edge axis. Instead of clearing a slice
// before reuse, an entry is trusted only when its id is not older than the first id of the cell
// layer that can have written it (z-1 or z for voxel layer z): ids returned by the sink increase
// (0, 1, 2, ... in call order), so an older id is left over from two layers back. (A sink
// returning other ids costs vertex sharing, never memory safety.)
//
// Support rule (min_weight > 1; the rule of extract_points): a cell is polygonised
// only when both voxels of every one of its crossing edges hold at least min_weight. The whole
// cell goes, not single triangles, so the mesh keeps its topology (a boundary where evidence ends)
// and every vertex is a crossing the point cloud of the same rule also holds.
#include <cstddef>
#include <cstdint>

#include "edgefuse/tsdf/extract.hpp"
#include "extract_detail.hpp"
#include "marching_cubes_tables.hpp"

namespace edgefuse {

namespace {

using namespace extract_detail;

constexpr uint32_t kNoVertex = 0xFFFFFFFFu;

// The walk over the cells, one z-layer at a time. Each of its steps (layer, brick, row, cell, edge
// vertex) has a single call site in this file, so the compiler inlines them all into extract_mesh:
// the cell loop makes no calls but the sink's.
struct MeshWalk {
  const TsdfVolume& volume;
  const Grid g;
  MeshSink& sink;
  const uint8_t min_weight;
  uint32_t next_id = 0;    // one past the newest id the sink returned
  uint32_t first_cur = 0;  // first id of the current layer
  // The current layer z: vertex ids of voxel layers z and z+1, and the first id each may trust
  // (layer z written in layers z-1, z).
  int z = 0;
  uint32_t* slice[2] = {nullptr, nullptr};
  uint32_t valid_from[2] = {0, 0};

  MeshWalk(const TsdfVolume& v, MeshSink& s, uint8_t w) : volume(v), g(v), sink(s), min_weight(w) {}
};

// kBrickSurface on one of the (up to) 2x2x2 bricks holding the corners of the cells of brick
// (bx, by, bz); bz1 is the brick layer of their upper corners.
inline bool corner_bricks_have_surface(const MeshWalk& m, int bx, int by, int bz, int bz1) {
  const int nb = m.g.nb;
  for (int cz = bz; cz <= bz1 && cz < nb; ++cz)
    for (int cy = by; cy <= by + 1 && cy < nb; ++cy)
      for (int cx = bx; cx <= bx + 1 && cx < nb; ++cx)
        if (m.g.flags[m.volume.brick_index(cx, cy, cz)] & kBrickSurface) return true;
  return false;
}

// The vertex on edge e of cell (x, y, m.z) with corner indices ci: the one a neighbouring cell
// created already, else a new one from the edge's zero crossing.
inline uint32_t edge_vertex(MeshWalk& m, int e, int x, int y, const std::size_t ci[8]) {
  const int s = mc::kEdgeStart[e];
  const int axis = mc::kEdgeAxis[e];
  const int up = mc::kCorner[s][2];
  const int vx = x + mc::kCorner[s][0], vy = y + mc::kCorner[s][1];
  uint32_t& slot = m.slice[up][(std::size_t(vy) * std::size_t(m.g.dim) + std::size_t(vx)) * 3 + std::size_t(axis)];
  if (slot != kNoVertex && slot >= m.valid_from[up]) return slot;
  const int other = mc::kEdgeCorners[e][0] == s ? mc::kEdgeCorners[e][1] : mc::kEdgeCorners[e][0];
  const int c[3] = {vx, vy, m.z + up};
  EdgeSample smp;
  edge_sample(m.g, c, ci[s], axis, ci[other], smp);
  const uint32_t id = m.sink.add_vertex(smp.position, smp.normal, smp.colour);
  slot = id;
  if (id + 1u > m.next_id) m.next_id = id + 1u;
  return id;
}

// Cell (x, y, m.z), corner indices ci, corner signs `cube` (not all one sign): its triangles,
// when all corners are observed, one is in the band and the crossing edges hold min_weight.
inline void polygonise_cell(MeshWalk& m, int x, int y, unsigned cube, const std::size_t ci[8]) {
  const int16_t* const t = m.g.tsdf;
  const uint8_t* const w = m.g.weight;
  bool observed = true, band = false;
  for (int i = 0; i < 8; ++i) {
    observed = observed && w[ci[i]] != 0;
    band = band || in_band(t[ci[i]]);
  }
  if (!observed || !band) return;
  const unsigned mask = mc::kMc.edge_mask[cube];
  if (m.min_weight > 1) {
    bool supported = true;
    for (int e = 0; e < 12 && supported; ++e)
      if (mask & (1u << e))
        supported = w[ci[mc::kEdgeCorners[e][0]]] >= m.min_weight && w[ci[mc::kEdgeCorners[e][1]]] >= m.min_weight;
    if (!supported) return;
  }
  uint32_t vid[12];
  for (int e = 0; e < 12; ++e)
    if (mask & (1u << e)) vid[e] = edge_vertex(m, e, x, y, ci);
  const int8_t* tri = mc::kMc.tri[cube];
  for (int k = 0, n = mc::kMc.tri_count[cube]; k < n; ++k, tri += 3)
    m.sink.add_triangle(vid[tri[0]], vid[tri[1]], vid[tri[2]]);
}

// The cells of row ly of brick column (bx, by) in layer m.z whose bit is set in `wanted`.
inline void polygonise_row(MeshWalk& m, int bx, int by, int ly, unsigned wanted) {
  const Grid& g = m.g;
  const int y = by * kBrickSide + ly, x0 = bx * kBrickSide;
  const bool has_next_x = bx + 1 < g.nb;
  // The cells' four corner rows (y, z), (y+1, z), (y, z+1), (y+1, z+1): 8 voxels each in this
  // brick column (row r's own brick: the rows may cross into the +y or +z brick) and a 9th, x =
  // 8 bx + 8, in the next brick along x. Bricks sit anywhere in the pool, so each row's start
  // comes from the index.
  std::size_t rows[4], next[4] = {0, 0, 0, 0};
  unsigned sign[4];
  for (int r = 0; r < 4; ++r) {
    const int yy = y + (r & 1), zz = m.z + (r >> 1);
    rows[r] = m.volume.index(x0, yy, zz);
    const int16_t* v = g.tsdf + rows[r];
    unsigned mk = 0;
    for (int i = 0; i < kBrickSide; ++i) mk |= unsigned(v[i] < 0) << i;
    if (has_next_x) {
      next[r] = m.volume.index(x0 + kBrickSide, yy, zz);
      mk |= unsigned(g.tsdf[next[r]] < 0) << kBrickSide;
    }
    sign[r] = mk;
  }
  const unsigned any = sign[0] | sign[1] | sign[2] | sign[3];
  const unsigned all = sign[0] & sign[1] & sign[2] & sign[3];
  const unsigned mixed = (any | any >> 1) & ~(all & all >> 1) & wanted;  // not all one sign
  for (int lx = 0; (mixed >> lx) != 0; ++lx) {
    if (!((mixed >> lx) & 1u)) continue;
    const unsigned a0 = sign[0] >> lx, a1 = sign[1] >> lx, a2 = sign[2] >> lx, a3 = sign[3] >> lx;
    const unsigned cube = (a0 & 3u) | (a1 << 1 & 4u) | (a1 << 3 & 8u) | (a2 << 4 & 16u) | (a2 << 4 & 32u) |
                          (a3 << 5 & 64u) | (a3 << 7 & 128u);
    std::size_t at[4], after[4];  // each row's voxel at x and at x + 1
    for (int r = 0; r < 4; ++r) {
      at[r] = rows[r] + std::size_t(lx);
      after[r] = lx < kBrickSide - 1 ? at[r] + 1u : next[r];
    }
    const std::size_t ci[8] = {at[0], after[0], after[1], at[1], at[2], after[2], after[3], at[3]};
    polygonise_cell(m, x0 + lx, y, cube, ci);
  }
}

// The cells of layer m.z whose minimum corners lie in brick (bx, by, m.z >> 3).
inline void polygonise_brick(MeshWalk& m, int bx, int by) {
  const Grid& g = m.g;
  const int dim = g.dim;
  const int bz = m.z >> 3, lz = m.z & 7;
  const int bz1 = (m.z + 1) >> 3;  // brick layer of the cells' upper corners
  const std::size_t b = m.volume.brick_index(bx, by, bz);
  if (!(g.flags[b] & kBrickObserved)) return;
  if (!corner_bricks_have_surface(m, bx, by, bz, bz1)) return;
  const int ly_end = by * kBrickSide + kBrickSide <= dim - 1 ? kBrickSide : dim - 1 - by * kBrickSide;
  const bool has_next_x = bx + 1 < g.nb;  // else the last cell column lies outside the volume
  const unsigned columns = has_next_x ? 0xFFu : 0x7Fu;
  // Without kBrickSurface on this brick, only cells reaching into a neighbour brick (the
  // last column, row or layer) can have an in-band corner.
  const bool edges_only = !(g.flags[b] & kBrickSurface) && lz < kBrickSide - 1;
  for (int ly = 0; ly < ly_end; ++ly) {
    const unsigned wanted = edges_only && ly < kBrickSide - 1 ? columns & 0x80u : columns;
    if (wanted != 0) polygonise_row(m, bx, by, ly, wanted);
  }
}

// Layer z of cells: the slices take turns (voxel layer z is the previous layer's z + 1).
inline void polygonise_layer(MeshWalk& m, int z, MeshScratch scratch, std::size_t slice_entries) {
  const uint32_t first_prev = z == 0 ? m.next_id : m.first_cur;
  m.first_cur = m.next_id;
  m.z = z;
  m.slice[0] = scratch.edge_ids + std::size_t(z & 1) * slice_entries;
  m.slice[1] = scratch.edge_ids + std::size_t((z + 1) & 1) * slice_entries;
  m.valid_from[0] = first_prev;
  m.valid_from[1] = m.first_cur;
  for (int by = 0; by < m.g.nb; ++by)
    for (int bx = 0; bx < m.g.nb; ++bx) polygonise_brick(m, bx, by);
}

}  // namespace

Status extract_mesh(const TsdfVolume& volume, MeshScratch scratch, MeshSink& sink, uint8_t min_weight) {
  if (!volume.initialised()) return Status::kNotInitialised;
  const int dim = volume.dim();
  if (scratch.capacity < MeshScratch::entries_for(dim)) return Status::kCapacityExceeded;
  if (scratch.edge_ids == nullptr) return Status::kInvalidArgument;
  const std::size_t plane = std::size_t(dim) * std::size_t(dim);
  const std::size_t slice_entries = 3 * plane;
  for (std::size_t i = 0; i < 2 * slice_entries; ++i) scratch.edge_ids[i] = kNoVertex;
  MeshWalk walk(volume, sink, min_weight);
  for (int z = 0; z + 1 < dim; ++z) polygonise_layer(walk, z, scratch, slice_entries);
  return Status::kOk;
}

}  // namespace edgefuse
