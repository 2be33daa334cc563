// Marching-cubes case tables (Lorensen & Cline 1987), private to src/tsdf.
//
// Numbering as in Paul Bourke's "Polygonising a scalar field" tables: corner i of a cell at
// offset kCorner[i] (0:(0,0,0) 1:(1,0,0) 2:(1,1,0) 3:(0,1,0) 4:(0,0,1) 5:(1,0,1) 6:(1,1,1)
// 7:(0,1,1)), edge e joining corners kEdgeCorners[e]; case bit i set when corner i is inside
// (tsdf < 0). The tables have the usual shape -- kMc.edge_mask[case] (12 bits, equal to Bourke's
// edgeTable) and kMc.tri[case] (up to 5 triangles as edge triples, -1 terminated) -- but are
// computed at compile time from the rule below instead of being typed in, so they are
// crack-free and consistently wound by construction:
//
//   On each cell face (corners counter-clockwise seen from outside the cell), the iso-line
//   segments cut off the inside corners: a segment starts on an edge where the walk enters the
//   inside and ends on the next edge where it leaves. An ambiguous face (two diagonal inside
//   corners) thus always separates its inside corners; the decision depends on the face's four
//   signs only, so both cells sharing the face draw the same segments (no cracks). The segments
//   chain into closed loops on the cell surface, oriented as the boundary of the inside region,
//   and each loop is cut into triangles (keeping that orientation: every triangle (a, b, c) has
//   (b - a) x (c - a) pointing out of the surface, towards positive tsdf). The triangulation never
//   uses a diagonal between two vertices on the same cell face: a loop that meets an ambiguous
//   face twice would otherwise lay a triangle edge into the face, where the neighbouring cell may
//   lay the same one -- an edge shared by four triangles. Interior diagonals belong to one cell
//   only, so the mesh is edge-manifold: every edge is shared by at most two triangles.
#pragma once

#include <cstdint>

namespace edgefuse {
namespace mc {

inline constexpr int kCorner[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                                      {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
inline constexpr int kEdgeCorners[12][2] = {{0, 1}, {1, 2}, {2, 3}, {3, 0}, {4, 5}, {5, 6},
                                            {6, 7}, {7, 4}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};
//! Each edge as (corner at its lower end, axis 0/1/2 = x/y/z along which it runs).
inline constexpr int kEdgeStart[12] = {0, 1, 3, 0, 4, 5, 7, 4, 0, 1, 2, 3};
inline constexpr int kEdgeAxis[12] = {0, 1, 0, 1, 0, 1, 0, 1, 2, 2, 2, 2};
//! Cell faces, corners counter-clockwise seen from outside the cell (-z, +z, -y, +y, -x, +x).
inline constexpr int kFace[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4},
                                    {3, 7, 6, 2}, {0, 4, 7, 3}, {1, 2, 6, 5}};

inline constexpr int kMaxTriangles = 5;

struct Tables {
  uint16_t edge_mask[256] = {};
  int8_t tri[256][3 * kMaxTriangles + 1] = {};
  uint8_t tri_count[256] = {};

  static constexpr int edge_of(int a, int b) {
    for (int e = 0; e < 12; ++e)
      if ((kEdgeCorners[e][0] == a && kEdgeCorners[e][1] == b) ||
          (kEdgeCorners[e][0] == b && kEdgeCorners[e][1] == a))
        return e;
    return -1;
  }

  static constexpr bool on_face(int e, int f) {
    bool a = false, b = false;
    for (int k = 0; k < 4; ++k) {
      a = a || kFace[f][k] == kEdgeCorners[e][0];
      b = b || kFace[f][k] == kEdgeCorners[e][1];
    }
    return a && b;
  }
  static constexpr bool share_face(int e1, int e2) {
    for (int f = 0; f < 6; ++f)
      if (on_face(e1, f) && on_face(e2, f)) return true;
    return false;
  }
  //! Triangulates the polygon poly[0..n) (edge ids, in loop order) without same-face diagonals,
  //! appending edge triples to out at len. Splits off the triangle on the side (n-1, 0).
  static constexpr bool triangulate(const int* poly, int n, int8_t* out, int& len) {
    if (n < 3) return true;
    for (int k = 1; k <= n - 2; ++k) {
      if (k > 1 && share_face(poly[0], poly[k])) continue;          // new diagonal (0, k)
      if (k < n - 2 && share_face(poly[k], poly[n - 1])) continue;  // new diagonal (k, n-1)
      const int saved = len;
      out[len++] = int8_t(poly[0]);
      out[len++] = int8_t(poly[k]);
      out[len++] = int8_t(poly[n - 1]);
      if (triangulate(poly, k + 1, out, len) && triangulate(poly + k, n - k, out, len)) return true;
      len = saved;
    }
    return false;
  }

  bool complete = true;  //!< every loop could be triangulated

  constexpr Tables() {
    for (int c = 0; c < 256; ++c) {
      int next[12] = {-1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1};
      for (int f = 0; f < 6; ++f) {
        for (int k = 0; k < 4; ++k) {
          const int a = kFace[f][k], b = kFace[f][(k + 1) & 3];
          if (((c >> a) & 1) || !((c >> b) & 1)) continue;  // not entering the inside here
          for (int m = k + 1; m < k + 5; ++m) {
            const int a2 = kFace[f][m & 3], b2 = kFace[f][(m + 1) & 3];
            if (((c >> a2) & 1) && !((c >> b2) & 1)) {  // leaving the inside
              next[edge_of(a, b)] = edge_of(a2, b2);
              break;
            }
          }
        }
      }
      uint16_t mask = 0;
      for (int e = 0; e < 12; ++e)
        if (next[e] >= 0) mask = uint16_t(mask | (1u << e));
      edge_mask[c] = mask;
      for (int i = 0; i < 3 * kMaxTriangles + 1; ++i) tri[c][i] = -1;
      bool seen[12] = {};
      int n = 0;  // entries written
      for (int e = 0; e < 12; ++e) {
        if (next[e] < 0 || seen[e]) continue;
        int loop[12] = {};
        int len = 0;
        for (int x = e; !seen[x]; x = next[x]) {
          seen[x] = true;
          loop[len++] = x;
        }
        if (n + 3 * (len - 2) > 3 * kMaxTriangles || !triangulate(loop, len, tri[c], n)) complete = false;
      }
      tri_count[c] = uint8_t(n / 3);
    }
  }
};

inline constexpr Tables kMc{};

// Spot checks against Bourke's edgeTable (the edge masks are fixed by the case alone).
static_assert(kMc.edge_mask[1] == 0x109 && kMc.edge_mask[5] == 0x50f && kMc.edge_mask[100] == 0x256 &&
                  kMc.edge_mask[254] == 0x109 && kMc.edge_mask[0] == 0 && kMc.edge_mask[255] == 0,
              "marching-cubes edge table");
static_assert(kMc.complete, "marching-cubes triangulation");
static_assert(kMc.tri_count[0] == 0 && kMc.tri_count[1] == 1 && kMc.tri_count[3] == 2, "marching-cubes triangles");

}  // namespace mc
}  // namespace edgefuse
