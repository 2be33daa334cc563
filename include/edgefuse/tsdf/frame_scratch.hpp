// Per-sensor scratch of the integration kernel: coarse 8x8-pixel tiles.
//   depth_tiles: min / max of the valid raw depth in each tile of the frame being pushed, so a
//                whole brick can be classified at once (entirely behind the surface: skipped;
//                entirely in free space: updated without projecting each voxel).
// The raycast needs none: it keeps each pixel's march range in its own depth map
// (src/tsdf/raycast_bounds.hpp), so prepare_raycast / raycast take no scratch.
#pragma once

#include <cstddef>
#include <cstdint>

namespace edgefuse {

struct DepthTile {
  uint16_t min_raw = 0;     //!< smallest valid raw depth (0: none valid)
  uint16_t max_raw = 0;     //!< largest valid raw depth
  uint16_t near_raw = 0;    //!< smallest valid raw depth of this tile and its 8 neighbours (0: none)
  uint8_t all_valid = 0;    //!< every pixel of the tile has a depth
  //! The same three for the 2x2 tiles starting here (this tile, the next one to the right and the
  //! two below; not set in the last tile row and column): a box's tile range is then covered by
  //! a quarter as many reads (overlapping windows give the same minimum, maximum and "all").
  uint8_t all_valid2 = 0;
  uint16_t min_raw2 = 0;
  uint16_t max_raw2 = 0;
  //! near_raw in metres (float(near_raw) / depth scale, as the float kernel converts a raw depth):
  //! the voxel loop's free-space test reads it for most voxels of the surface band.
  float near_m = 0.0f;
};

struct FrameScratch {
  static constexpr int kTile = 8;  //!< tile edge in pixels
  DepthTile* depth_tiles = nullptr;
  std::size_t capacity = 0;        //!< tiles each array holds

  static constexpr int tiles_x(int width) { return (width + kTile - 1) / kTile; }
  static constexpr int tiles_y(int height) { return (height + kTile - 1) / kTile; }
  static constexpr std::size_t tiles_for(int width, int height) {
    return std::size_t(tiles_x(width)) * std::size_t(tiles_y(height));
  }
  bool fits(int width, int height) const {
    return depth_tiles != nullptr && tiles_for(width, height) <= capacity;
  }
};

}  // namespace edgefuse
